//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::sync::Arc;

use steernav::gpu::{gpu_required, GpuContext};

/// The shared GPU context, or None when there is no adapter. With STEERNAV_REQUIRE_GPU=1 (CI)
/// a missing adapter fails the test instead.
pub fn gpu() -> Option<Arc<GpuContext>> {
    match GpuContext::shared() {
        Ok(ctx) => Some(ctx),
        Err(e) if gpu_required() => panic!("STEERNAV_REQUIRE_GPU=1 but {e}"),
        Err(e) => {
            eprintln!(
                "no GPU adapter ({e}): this GPU test checks nothing here; CI runs it on lavapipe"
            );
            None
        }
    }
}

/// Largest absolute difference between two planes, and the largest magnitude in `a`.
pub fn max_diff(a: &[f32], b: &[f32]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    let diff = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    let scale = a.iter().map(|x| x.abs()).fold(0.0, f32::max);
    (diff, scale)
}

/// Fraction of points of `a` with a point of `b` within `radius`.
pub fn twin_fraction(a: &[(f32, f32)], b: &[(f32, f32)], radius: f32) -> f64 {
    if a.is_empty() {
        return 1.0;
    }
    let hits = a
        .iter()
        .filter(|p| {
            b.iter()
                .any(|q| (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2) <= radius * radius)
        })
        .count();
    hits as f64 / a.len() as f64
}
