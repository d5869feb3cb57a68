//! GPU-versus-CPU parity of every stage, with the tolerances stated in README.md:
//! derivative planes and steered filter-bank images within 1e-4 of the plane's largest
//! magnitude; Harris responses within 1e-3 of the largest response of their plane; candidate
//! lists: 98% of maxima found by both with the same scale and orientation, positions within
//! 0.01 px and responses within 1e-3 relative; final
//! keypoints: at least 95% of each backend's keypoints have a twin within 0.5 px in the other's.

mod common;

use steernav::low_level::harris::CpuHarris;
use steernav::low_level::harris::GpuHarris;
use steernav::low_level::harris::HarrisPlan;
use steernav::low_level::synth::textured_scene;
use steernav::{Backend, Detector, DetectorConfig};

const W: u32 = 192;
const H: u32 = 144;

#[test]
fn filter_bank_matches_cpu() {
    let Some(ctx) = common::gpu() else { return };
    let frame = textured_scene(W, H, 3);
    for basis in [
        steernav::features::BasisOrder::First,
        steernav::features::BasisOrder::Second,
    ] {
        let cfg = DetectorConfig {
            basis,
            orientations: 6,
            ..Default::default()
        };
        let gpu =
            steernav::low_level::filter_bank::gpu::steered_images(&ctx, &cfg, &frame.gray, W, H)
                .unwrap();
        let cpu = steernav::low_level::filter_bank::steered_images(
            &cfg,
            &frame.gray,
            W as usize,
            H as usize,
        );
        assert_eq!(gpu.len(), 6);
        for (g, c) in gpu.iter().zip(&cpu) {
            let (d, s) = common::max_diff(c, g);
            assert!(s > 0.0 && d <= 1e-4 * s, "{basis:?}: diff {d} vs scale {s}");
        }
    }
}

#[test]
fn derivatives_and_responses_match_cpu() {
    let Some(ctx) = common::gpu() else { return };
    let frame = textured_scene(W, H, 4);
    let plan = HarrisPlan::new(&DetectorConfig::default());
    let gpu = GpuHarris::new(ctx, plan.clone());
    let cpu = CpuHarris::new(plan.clone());
    for s in [0, plan.scales.len() - 1] {
        let g = gpu.derivatives(&frame.gray, W, H, s).unwrap();
        let c = cpu.derivatives(&frame.gray, W as usize, H as usize, s);
        assert_eq!(g.len(), plan.derivative_count());
        for (a, b) in c.iter().zip(&g) {
            let (d, m) = common::max_diff(a, b);
            assert!(
                m > 0.0 && d <= 1e-4 * m,
                "scale {s}: derivative diff {d} vs {m}"
            );
        }
    }
    let g = gpu.responses(&frame.gray, W, H).unwrap();
    let c = cpu.responses(&frame.gray, W as usize, H as usize);
    assert_eq!(g.grids, c.grids);
    assert!(
        c.grids.last().unwrap().0 < W as usize,
        "coarse scales use a subsampled grid"
    );
    for (s, (a, b)) in c.responses.iter().zip(&g.responses).enumerate() {
        let plane = c.grids[s].0 * c.grids[s].1;
        assert_eq!(
            (a.len(), b.len()),
            (
                plane * plan.orientations.len(),
                plane * plan.orientations.len()
            )
        );
        for t in 0..plan.orientations.len() {
            let (d, m) = common::max_diff(
                &a[t * plane..(t + 1) * plane],
                &b[t * plane..(t + 1) * plane],
            );
            assert!(
                m > 0.0 && d <= 1e-3 * m,
                "scale {s} orientation {t}: response diff {d} vs {m}"
            );
        }
    }
}

#[test]
fn candidate_lists_match_cpu() {
    if common::gpu().is_none() {
        return;
    }
    let frame = textured_scene(W, H, 10);
    let cfg = DetectorConfig::default();
    let g_run = Detector::new(&cfg, Backend::Gpu)
        .unwrap()
        .candidates(&frame)
        .unwrap();
    let c_run = Detector::new(&cfg, Backend::Cpu)
        .unwrap()
        .candidates(&frame)
        .unwrap();
    let (g, gt, c, ct) = (
        g_run.candidates,
        g_run.threshold,
        c_run.candidates,
        c_run.threshold,
    );
    // The relative threshold follows each backend's strongest response, which agree to the
    // responses' tolerance.
    assert!((gt - ct).abs() <= 1e-4 * ct, "thresholds {gt} vs {ct}");
    assert!(c.len() > 100, "{} candidates", c.len());
    // The same maxima (scale, orientation, position within 0.01 px, sub-scale offset within
    // 0.01 step, response within 1e-3 relative) for all but near-ties; NMS of nearly equal
    // neighbours may flip.
    let twin = |a: &steernav::features::Candidate, list: &[steernav::features::Candidate]| {
        list.iter().any(|b| {
            a.scale_index() == b.scale_index()
                && a.orientation_index() == b.orientation_index()
                && (a.scale_offset() - b.scale_offset()).abs() <= 0.01
                && (a.x - b.x).abs() < 0.01
                && (a.y - b.y).abs() < 0.01
                && (a.response - b.response).abs() <= 1e-3 * a.response.abs()
        })
    };
    let matched = c.iter().filter(|a| twin(a, &g)).count() as f64 / c.len() as f64;
    let back = g.iter().filter(|a| twin(a, &c)).count() as f64 / g.len() as f64;
    assert!(
        matched >= 0.98 && back >= 0.98,
        "cpu→gpu {matched}, gpu→cpu {back}"
    );
}

#[test]
fn final_keypoints_have_twins_on_the_other_backend() {
    if common::gpu().is_none() {
        return;
    }
    for (seed, cfg) in [
        (5, DetectorConfig::default()),
        (
            6,
            DetectorConfig {
                orientations: 3,
                scales: 3,
                basis: steernav::features::BasisOrder::First,
                ..Default::default()
            },
        ),
    ] {
        let frame = textured_scene(320, 240, seed);
        let g = Detector::new(&cfg, Backend::Gpu)
            .unwrap()
            .detect(&frame)
            .unwrap();
        let c = Detector::new(&cfg, Backend::Cpu)
            .unwrap()
            .detect(&frame)
            .unwrap();
        assert_eq!((g.backend, c.backend), (Backend::Gpu, Backend::Cpu));
        assert!(
            c.keypoints.len() > 50,
            "too few keypoints to compare: {}",
            c.keypoints.len()
        );
        let (gk, ck) = (common::points(&g), common::points(&c));
        let (a, b) = (
            common::twin_fraction(&gk, &ck, 0.5),
            common::twin_fraction(&ck, &gk, 0.5),
        );
        assert!(a >= 0.95 && b >= 0.95, "twins: gpu→cpu {a}, cpu→gpu {b}");
    }
}

#[test]
fn candidate_overflow_raises_the_threshold_identically() {
    if common::gpu().is_none() {
        return;
    }
    let frame = textured_scene(W, H, 7);
    let cfg = DetectorConfig {
        candidate_capacity: 64,
        threshold: 0.0,
        ..Default::default()
    };
    let g = Detector::new(&cfg, Backend::Gpu).unwrap();
    let c = Detector::new(&cfg, Backend::Cpu).unwrap();
    let (g_run, c_run) = (g.candidates(&frame).unwrap(), c.candidates(&frame).unwrap());
    let (gc, gt, cc, ct) = (
        g_run.candidates,
        g_run.threshold,
        c_run.candidates,
        c_run.threshold,
    );
    assert!(
        gt > 0.0 && (gt - ct).abs() <= 1e-4 * ct,
        "thresholds {gt} vs {ct}"
    );
    assert!(gc.len() <= 64 && cc.len() <= 64 && !cc.is_empty());
    assert!(
        (gc.len() as i64 - cc.len() as i64).abs() <= 2,
        "{} vs {}",
        gc.len(),
        cc.len()
    );
}

#[test]
fn buffers_are_reused_across_frames_and_sizes() {
    if common::gpu().is_none() {
        return;
    }
    let det = Detector::new(&DetectorConfig::default(), Backend::Gpu).unwrap();
    let a = textured_scene(W, H, 8);
    let b = textured_scene(W / 2, H / 2, 9);
    let first = det.detect(&a).unwrap();
    det.detect(&b).unwrap();
    let again = det.detect(&a).unwrap();
    assert_eq!(
        first.keypoints, again.keypoints,
        "a cached frame must give identical results"
    );
    assert!(
        first
            .timings
            .gpu
            .as_ref()
            .is_some_and(|t| t.structure_tensor_ms > 0.0),
        "timestamp queries give stage timings"
    );
}

#[test]
fn tiled_gpu_runs_match_the_untiled_run_exactly() {
    if common::gpu().is_none() {
        return;
    }
    // Tiles far smaller than the image (cores of 64 and 100 px, with halos of about 50 px),
    // so every kind of tile edge cuts through structure.
    let frame = textured_scene(W, H, 13);
    let whole_cfg = DetectorConfig::default();
    let whole = Detector::new(&whole_cfg, Backend::Gpu).unwrap();
    let expected = whole.candidates(&frame).unwrap();
    let expected_keypoints = common::points(&whole.detect(&frame).unwrap());
    assert!(expected.candidates.len() > 100);
    for tile in [64, 100] {
        let cfg = DetectorConfig {
            gpu_tile_size: tile,
            ..Default::default()
        };
        let tiled = Detector::new(&cfg, Backend::Gpu).unwrap();
        let run = tiled.candidates(&frame).unwrap();
        assert_eq!(run.threshold, expected.threshold, "tile {tile}");
        assert!(
            run.candidates == expected.candidates,
            "tile {tile}: {} vs {} candidates",
            run.candidates.len(),
            expected.candidates.len()
        );
        assert_eq!(
            common::points(&tiled.detect(&frame).unwrap()),
            expected_keypoints
        );
    }
}

#[test]
fn frames_in_flight_give_the_results_of_one_frame_at_a_time() {
    if common::gpu().is_none() {
        return;
    }
    let cfg = DetectorConfig::default();
    let detector = Detector::new(&cfg, Backend::Gpu).unwrap();
    // Sizes change mid-stream, and a decoding error passes through in its place.
    let frames: Vec<steernav::Frame> = [(192, 144, 1), (192, 144, 2), (160, 120, 3), (192, 144, 4)]
        .iter()
        .map(|&(w, h, seed)| textured_scene(w, h, seed))
        .collect();
    let expected: Vec<_> = frames
        .iter()
        .map(|f| common::points(&detector.detect(f).unwrap()))
        .collect();
    let mut items: Vec<(usize, steernav::error::Result<steernav::Frame>)> =
        frames.iter().cloned().map(Ok).enumerate().collect();
    items.insert(
        2,
        (
            99,
            Err(steernav::error::Error::Config {
                field: "test",
                value: "x".into(),
                reason: "a frame that failed to decode".into(),
            }),
        ),
    );
    let mut seen = Vec::new();
    detector.detect_stream(items, |tag, result| match result {
        Ok((frame, d)) => {
            assert_eq!(frame.width, frames[tag].width);
            assert_eq!(d.backend, Backend::Gpu);
            assert_eq!(common::points(&d), expected[tag], "frame {tag}");
            seen.push(tag);
        }
        Err(_) => seen.push(tag),
    });
    assert_eq!(seen, [0, 1, 99, 2, 3]);
}

/// One GPU detector shared by four threads (a Python thread pool, a robot's camera threads):
/// every detection is the one a lone thread gets for that frame. The synchronous slot used
/// to be released between a frame's submission and its readback, so a thread could read
/// another's candidates, or hang waiting for a mapping that waited for the other's frame.
#[test]
fn one_gpu_detector_shared_by_four_threads_gives_each_frame_its_own_keypoints() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let detector = Detector::with_context(ctx, &DetectorConfig::default()).unwrap();
    let frames: Vec<_> = (0..4)
        .map(|seed| textured_scene(192, 144, 40 + seed))
        .collect();
    let alone: Vec<_> = frames
        .iter()
        .map(|f| common::points(&detector.detect(f).unwrap()))
        .collect();
    std::thread::scope(|scope| {
        for t in 0..4 {
            let (detector, frames, alone) = (&detector, &frames, &alone);
            scope.spawn(move || {
                for round in 0..6 {
                    let i = (t + round) % frames.len();
                    let found = common::points(&detector.detect(&frames[i]).unwrap());
                    assert!(found == alone[i], "thread {t}, round {round}, frame {i}");
                }
            });
        }
    });
}
