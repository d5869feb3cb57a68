//! What a real sensor does to the rendered light: auto-exposure changing the gain between
//! frames, and sensor noise. (Motion blur is the average of renders over the exposure, in
//! `render`; radial distortion is the camera's k₁, in the ray directions.)

use crate::rng::Rng;

/// Per-frame gains of the auto-exposure: log g follows an AR(1) process,
/// log g_k = 0.8 log g_{k−1} + σ n_k, so the brightness wanders by about ±σ/0.6 and
/// comes back, as a camera's exposure control does when the view changes.
pub(super) fn exposure_gains(frames: usize, sigma: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng(seed.wrapping_mul(0x8CB9_2BA7_2F3D_8DD7) ^ 0xE0);
    let mut log_gain = 0.0;
    (0..frames)
        .map(|k| {
            if k > 0 && sigma > 0.0 {
                log_gain = 0.8 * log_gain + sigma * normal(&mut rng);
            }
            log_gain.exp()
        })
        .collect()
}

/// Applies `gain`, adds Gaussian noise of `sigma` grey levels (seeded by `seed`, so each row
/// of each frame draws its own stream) and quantises to 8 bits.
pub(super) fn quantise(light: &[f64], gain: f64, sigma: f64, seed: u64, out: &mut [u8]) {
    let mut rng = Rng(seed);
    for (o, &l) in out.iter_mut().zip(light) {
        let noise = if sigma > 0.0 {
            sigma * normal(&mut rng)
        } else {
            0.0
        };
        *o = (l * gain + noise).round().clamp(0.0, 255.0) as u8;
    }
}

/// A standard normal draw (Box–Muller).
fn normal(rng: &mut Rng) -> f64 {
    let u = rng.unit_f64().max(f64::MIN_POSITIVE);
    let v = rng.unit_f64();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_has_the_asked_spread_and_gains_wander_about_one() {
        let light = vec![128.0; 20_000];
        let mut out = vec![0u8; light.len()];
        quantise(&light, 1.0, 4.0, 3, &mut out);
        let mean = out.iter().map(|&v| v as f64).sum::<f64>() / out.len() as f64;
        let var = out.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / out.len() as f64;
        assert!((mean - 128.0).abs() < 0.2, "mean {mean}");
        assert!((var.sqrt() - 4.0).abs() < 0.2, "sd {}", var.sqrt());
        let gains = exposure_gains(2000, 0.05, 1);
        assert_eq!(gains[0], 1.0);
        let log_mean = gains.iter().map(|g| g.ln()).sum::<f64>() / gains.len() as f64;
        assert!(log_mean.abs() < 0.02, "mean log gain {log_mean}");
        assert!(gains.iter().all(|g| (0.6..1.6).contains(g)));
        assert_eq!(exposure_gains(5, 0.0, 1), vec![1.0; 5]);
    }
}
