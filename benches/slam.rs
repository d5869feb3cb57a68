//! Criterion benches of the EKF update (eqs 22–24) with 20 observed landmarks while the map
//! holds 50, 100 and 200 landmarks, all inverse depth (6 entries each, the worst case) or all
//! Euclidean (3 each) — the O(n²) covariance update measured, not assumed.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use nalgebra::Vector2;
use steernav::low_level::ekf::{Filter, Observation};
use steernav::low_level::motion::MotionModel;
use steernav::slam::camera::PinholeCamera;

fn filter_with(landmarks: usize, euclidean: bool) -> Filter {
    let camera = PinholeCamera::ideal(500.0, 500.0, 319.5, 239.5, 640, 480);
    let mut f = Filter::new(camera, MotionModel::default(), 1.0, 0.05, 0.05);
    let pixels: Vec<Vector2<f64>> = (0..landmarks)
        .map(|i| Vector2::new(40.0 + (i % 20) as f64 * 28.0, 40.0 + (i / 20) as f64 * 36.0))
        .collect();
    f.add_landmarks(&pixels, 0.5, 0.5);
    if euclidean {
        for slot in 0..landmarks {
            f.convert_to_euclidean(slot);
        }
    }
    f.predict(1.0 / 30.0, None);
    f
}

fn observations(f: &Filter, count: usize) -> Vec<Observation> {
    let stride = f.slots().len() / count;
    (0..count)
        .map(|i| {
            let slot = i * stride;
            let prediction = f.predict_observation(slot).expect("visible");
            Observation {
                slot,
                pixel: prediction.pixel + Vector2::new(0.7, -0.4),
                prediction,
            }
        })
        .collect()
}

fn update(c: &mut Criterion) {
    let mut group = c.benchmark_group("ekf update, 20 observations");
    group.sample_size(20);
    for euclidean in [false, true] {
        for n in [50usize, 100, 200] {
            let f = filter_with(n, euclidean);
            let obs = observations(&f, 20);
            let kind = if euclidean {
                "euclidean"
            } else {
                "inverse-depth"
            };
            group.bench_function(format!("{kind}/{n} landmarks (state {})", f.dim()), |b| {
                b.iter_batched_ref(
                    || f.clone(),
                    |filter| filter.update(&obs).expect("consistent"),
                    BatchSize::LargeInput,
                )
            });
        }
    }
    group.finish();
}

criterion_group!(benches, update);
criterion_main!(benches);
