//! The dynamic neural field (eqs 28–31): a single stable peak at a bell-shaped stimulus that
//! follows it when it moves, no peak below threshold, one winner between two stimuli.

use steernav::low_level::dnf::{
    bell, ring_distance, Activation, FieldBatch, FieldConfig, Interaction,
};

/// The paper's lattice: 72 neurons of 5°. Positions and widths below are in its neurons, scaled
/// to each lattice tested.
const PAPER_N: usize = 72;

/// The fields tested: the default (the controller's) and the replay's, 5 times finer.
fn lattices() -> [FieldConfig; 2] {
    [FieldConfig::default(), FieldConfig::refined(5)]
}

/// A bell at paper neuron `centre` (amplitude, width in paper neurons) on `cfg`'s lattice.
fn bell_at(cfg: &FieldConfig, centre: f32, amplitude: f32, sigma: f32) -> Vec<f32> {
    let k = (cfg.neurons / PAPER_N) as f32;
    bell(cfg.neurons, centre * k, amplitude, sigma * k)
}

/// The neurons above zero, as one contiguous arc (None if they are not contiguous).
fn active_arc(u: &[f32]) -> Option<Vec<usize>> {
    let active: Vec<usize> = (0..u.len()).filter(|&i| u[i] > 0.0).collect();
    let contiguous = active
        .iter()
        .all(|&i| active.iter().any(|&j| ring_distance(i, j, u.len()) == 1) || active.len() == 1);
    contiguous.then_some(active)
}

fn settle(field: &mut FieldBatch, stimulus: &[f32], steps: usize) {
    field.step(stimulus, steps).unwrap();
}

#[test]
fn a_single_stable_peak_forms_at_the_stimulus_and_follows_it() {
    for cfg in lattices() {
        let k = cfg.neurons / PAPER_N;
        let mut field = FieldBatch::new(cfg.clone(), 1).unwrap();
        let s = bell_at(&cfg, 20.0, 5.0, 3.0);
        settle(&mut field, &s, 1000);
        let arc = active_arc(field.field(0)).expect("one contiguous peak");
        assert!(
            !arc.is_empty() && arc.len() <= 9 * k,
            "{} neurons: peak width {}",
            cfg.neurons,
            arc.len()
        );
        assert_eq!(field.peak(0).0, 20 * k);
        // Stable: more steps change nothing.
        let before = field.u.clone();
        settle(&mut field, &s, 500);
        let drift = before
            .iter()
            .zip(&field.u)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(drift < 1e-3, "{} neurons: drift {drift}", cfg.neurons);
        // The stimulus moves 5° every 0.2 s to 160°, and across the wrap-around.
        for c in 21..=32 {
            settle(&mut field, &bell_at(&cfg, c as f32, 5.0, 3.0), 20);
        }
        settle(&mut field, &bell_at(&cfg, 32.0, 5.0, 3.0), 300);
        assert_eq!(field.peak(0).0, 32 * k);
        assert!(active_arc(field.field(0)).is_some());
        let mut wrap = FieldBatch::new(cfg.clone(), 1).unwrap();
        settle(&mut wrap, &bell_at(&cfg, 70.0, 5.0, 3.0), 1000);
        for c in 71..=75 {
            settle(&mut wrap, &bell_at(&cfg, c as f32, 5.0, 3.0), 20);
        }
        settle(&mut wrap, &bell_at(&cfg, 3.0, 5.0, 3.0), 300);
        assert_eq!(wrap.peak(0).0, 3 * k);
    }
}

#[test]
fn no_peak_below_threshold() {
    for cfg in lattices() {
        let mut field = FieldBatch::new(cfg.clone(), 1).unwrap();
        settle(&mut field, &bell_at(&cfg, 40.0, 1.8, 3.0), 2000);
        assert!(
            field.field(0).iter().all(|&u| u < 0.0),
            "{:?}",
            field.field(0)
        );
    }
}

#[test]
fn two_stimuli_have_one_winner() {
    for cfg in lattices() {
        let (n, k) = (cfg.neurons, cfg.neurons / PAPER_N);
        let mut field = FieldBatch::new(cfg.clone(), 2).unwrap();
        let mut s: Vec<f32> = bell_at(&cfg, 10.0, 5.0, 3.0)
            .iter()
            .zip(bell_at(&cfg, 45.0, 4.5, 3.0))
            .map(|(a, b)| a + b)
            .collect();
        // The second field sees the two stimuli with the strengths swapped.
        s.extend(
            bell_at(&cfg, 10.0, 4.5, 3.0)
                .iter()
                .zip(bell_at(&cfg, 45.0, 5.0, 3.0))
                .map(|(a, b)| a + b),
        );
        settle(&mut field, &s, 2000);
        for (b, winner) in [(0, 10), (1, 45)] {
            let arc = active_arc(field.field(b)).expect("one contiguous peak");
            assert!(
                arc.iter()
                    .all(|&i| ring_distance(i, winner * k, n) <= 4 * k),
                "{n} neurons, field {b}: {arc:?}"
            );
            assert_eq!(field.peak(b).0, winner * k, "{n} neurons, field {b}");
        }
    }
}

#[test]
fn the_refined_lattice_of_factor_one_is_the_default() {
    assert_eq!(FieldConfig::refined(1), FieldConfig::default());
}

#[test]
fn difference_of_gaussians_and_sigmoid_also_select_one_heading() {
    let cfg = FieldConfig {
        interaction: Interaction::GaussianDifference {
            a_e: 2.5,
            sigma_e: 2.0,
            a_i: 1.0,
            sigma_i: 10.0,
            global: 0.8,
        },
        activation: Activation::Sigmoid { beta: 4.0 },
        neurons: PAPER_N,
        ..Default::default()
    };
    let mut field = FieldBatch::new(cfg, 1).unwrap();
    let s: Vec<f32> = bell(PAPER_N, 50.0, 5.0, 3.0)
        .iter()
        .zip(bell(PAPER_N, 20.0, 4.0, 3.0))
        .map(|(a, b)| a + b)
        .collect();
    settle(&mut field, &s, 2000);
    assert_eq!(field.peak(0).0, 50);
    assert!(
        field.field(0)[20] < 0.0,
        "the weaker stimulus is suppressed"
    );
}

#[test]
fn bad_values_are_refused_by_name() {
    let mut field = FieldBatch::new(FieldConfig::default(), 1).unwrap();
    let mut s = vec![0.0; FieldConfig::default().neurons];
    s[7] = f32::NAN;
    let e = field.step(&s, 1).unwrap_err().to_string();
    assert!(e.contains("stimulus") && e.contains("neuron 7"), "{e}");
    assert!(field.step(&[0.0; 3], 1).is_err());
    for cfg in [
        FieldConfig {
            tau: f32::NAN,
            ..Default::default()
        },
        FieldConfig {
            dt: 1.0,
            ..Default::default()
        },
        FieldConfig {
            neurons: 2,
            ..Default::default()
        },
        FieldConfig {
            h: f32::INFINITY,
            ..Default::default()
        },
    ] {
        assert!(FieldBatch::new(cfg, 1).is_err());
    }
    assert!(FieldBatch::new(FieldConfig::default(), 0).is_err());
}

mod common;

/// GPU and CPU fields agree after long runs (many dispatches) for both kernels: the same peak
/// in every field and activations within 1e-3 (float sums in another order; a Heaviside step
/// can only flip for a neuron at zero, which a settled field does not have).
#[test]
fn gpu_fields_match_the_cpu() {
    let Some(ctx) = common::gpu() else { return };
    let configs = [
        FieldConfig::default(),
        FieldConfig::refined(5),
        FieldConfig {
            interaction: Interaction::GaussianDifference {
                a_e: 2.5,
                sigma_e: 2.0,
                a_i: 1.0,
                sigma_i: 10.0,
                global: 0.8,
            },
            activation: Activation::Sigmoid { beta: 4.0 },
            neurons: PAPER_N,
            ..Default::default()
        },
    ];
    for cfg in configs {
        let n = cfg.neurons;
        let fields = 64;
        let mut stimulus = Vec::new();
        for b in 0..fields {
            let c1 = (b * 7 % n) as f32;
            let c2 = ((b * 13 + 30) % n) as f32;
            let a2 = 3.0 + (b % 5) as f32 * 0.4;
            stimulus.extend(
                bell(n, c1, 5.0, 3.0)
                    .iter()
                    .zip(bell(n, c2, a2, 2.5))
                    .map(|(a, b)| a + b),
            );
        }
        let mut cpu = FieldBatch::new(cfg.clone(), fields).unwrap();
        let mut gpu =
            steernav::low_level::dnf::GpuFieldBatch::new(ctx.clone(), cfg.clone(), fields).unwrap();
        // 1500 steps: several dispatches, far past lavapipe's per-invocation loop cap if run in one.
        cpu.step(&stimulus, 1500).unwrap();
        gpu.step(&stimulus, 1500).unwrap();
        let g = gpu.read().unwrap();
        let diff = cpu
            .u
            .iter()
            .zip(&g)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(diff < 1e-3, "{:?}: max difference {diff}", cfg.interaction);
        for b in 0..fields {
            let gf = &g[b * n..(b + 1) * n];
            let gp = (0..n).fold(0, |best, i| if gf[i] > gf[best] { i } else { best });
            assert_eq!(gp, cpu.peak(b).0, "field {b}");
        }
    }
}
