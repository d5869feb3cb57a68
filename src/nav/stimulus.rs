//! Stimuli and velocity laws of section 3.2.1 (eqs 32–37): the obstacle stimulus from LIDAR
//! range/bearing pairs, the target stimulus, their combination, and the velocities V_T, V_O, V.
//! Headings are radians on the ring [0, 2π) (neuron i ↔ 2πi/N); differences wrap to [−π, π].

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Parameters of eqs 32–37, with documented defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StimulusConfig {
    /// c_o, amplitude of one obstacle's stimulus (eq 32). Default 2.0.
    pub c_o: f32,
    /// σ, angular sharpness of an obstacle's inhibition, 1/rad² (eq 32). Default 20.
    pub sigma: f32,
    /// Distance scale of g(d) = exp(−d / g_scale), m: nearer obstacles weigh more. Default 1.0.
    pub g_scale: f32,
    /// Obstacles beyond this range (m) are ignored. Default 4.0.
    pub max_range: f32,
    /// m_1, the target stimulus at the target heading (eq 33). Default 6.0.
    pub m1: f32,
    /// m_2, its decrease per radian away from the target (eq 33). Default 2.0.
    pub m2: f32,
    /// V_max of eq 35 (m/s). Default 0.5.
    pub v_max: f32,
    /// σ_v of eq 35 (1/m). Default 1.0.
    pub sigma_v: f32,
    /// C_O of eq 36. Default 1.0.
    pub c_ov: f32,
    /// σ_ov of eq 36 (1/rad²). Default 4.0.
    pub sigma_ov: f32,
}

impl Default for StimulusConfig {
    fn default() -> Self {
        Self {
            c_o: 2.0,
            sigma: 20.0,
            g_scale: 1.0,
            max_range: 4.0,
            m1: 6.0,
            m2: 2.0,
            v_max: 0.5,
            sigma_v: 1.0,
            c_ov: 1.0,
            sigma_ov: 4.0,
        }
    }
}

impl StimulusConfig {
    /// Checks every value; the error names the field.
    pub fn validate(&self) -> Result<()> {
        let fields = [
            ("c_o", self.c_o),
            ("sigma", self.sigma),
            ("g_scale", self.g_scale),
            ("max_range", self.max_range),
            ("m1", self.m1),
            ("m2", self.m2),
            ("v_max", self.v_max),
            ("sigma_v", self.sigma_v),
            ("c_ov", self.c_ov),
            ("sigma_ov", self.sigma_ov),
        ];
        for (field, v) in fields {
            if !v.is_finite() || v < 0.0 {
                return Err(Error::Config {
                    field,
                    value: v.to_string(),
                    reason: "must be a finite number ≥ 0".into(),
                });
            }
        }
        Ok(())
    }

    /// g(d) of eqs 32 and 36: 1 at contact, decreasing with distance.
    pub fn g(&self, d: f32) -> f32 {
        (-d.max(0.0) / self.g_scale.max(1e-6)).exp()
    }

    /// The configuration for a scan whose beams are `spacing` radians apart, each beam taken
    /// as a point obstacle: c_o is weighted by the beams' angular density, so a wall inhibits
    /// as much whatever the scanner's resolution.
    pub fn per_beam(&self, spacing: f32) -> Self {
        Self {
            c_o: self.c_o * spacing * (self.sigma / std::f32::consts::PI).sqrt(),
            ..self.clone()
        }
    }
}

/// a − b wrapped to [−π, π].
pub fn angle_diff(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(std::f32::consts::TAU);
    if d > std::f32::consts::PI {
        d - std::f32::consts::TAU
    } else {
        d
    }
}

/// A scanner's field of view from its beams (robot frame, rad): the first and last bearings,
/// widened by half a beam each side; `None` for a scan with no beam.
pub fn field_of_view(bearings: &[f32], angle_increment: f32) -> Option<(f32, f32)> {
    let half = 0.5 * angle_increment;
    let lo = bearings.iter().copied().reduce(f32::min)?;
    let hi = bearings.iter().copied().reduce(f32::max)?;
    Some((lo - half, hi + half))
}

/// Whether the robot-frame heading `h` (in [−π, π]) lies inside the view `fov`; a view of 360°
/// holds every heading.
pub fn in_view(h: f32, fov: (f32, f32)) -> bool {
    fov.1 - fov.0 >= std::f32::consts::TAU - 1e-3 || (h >= fov.0 && h <= fov.1)
}

/// Heading of each of `n` neurons.
fn headings(n: usize) -> impl Iterator<Item = f32> {
    (0..n).map(move |i| i as f32 * std::f32::consts::TAU / n as f32)
}

/// S_obstacle (eq 32) on `n` neurons from LIDAR beams: `ranges[l]` metres at `bearings[l]`
/// radians (robot frame, 0 = straight ahead = heading 0 of the ring). Beams beyond
/// `max_range` are free space. A non-finite range or bearing is an error naming the beam.
pub fn obstacle_stimulus(
    ranges: &[f32],
    bearings: &[f32],
    cfg: &StimulusConfig,
    n: usize,
) -> Result<Vec<f32>> {
    if ranges.len() != bearings.len() {
        return Err(Error::Config {
            field: "scan",
            value: format!("{} ranges, {} bearings", ranges.len(), bearings.len()),
            reason: "one bearing per range".into(),
        });
    }
    let mut s = vec![0.0f32; n];
    for (l, (&d, &phi)) in ranges.iter().zip(bearings).enumerate() {
        if !d.is_finite() || !phi.is_finite() {
            return Err(Error::Config {
                field: "scan",
                value: format!("beam {l}: range {d}, bearing {phi}"),
                reason: "ranges and bearings must be finite".into(),
            });
        }
        if d >= cfg.max_range {
            continue;
        }
        let weight = cfg.g(d) * cfg.c_o;
        for (si, h) in s.iter_mut().zip(headings(n)) {
            let a = angle_diff(h, phi);
            *si += weight * (-cfg.sigma * a * a).exp();
        }
    }
    Ok(s)
}

/// S_target (eq 33): m_1 − m_2·|φ_target − φ|.
pub fn target_stimulus(target: f32, cfg: &StimulusConfig, n: usize) -> Vec<f32> {
    headings(n)
        .map(|h| cfg.m1 - cfg.m2 * angle_diff(target, h).abs())
        .collect()
}

/// S = S_target − S_obstacle (eq 34).
pub fn combined(target: &[f32], obstacle: &[f32]) -> Vec<f32> {
    target.iter().zip(obstacle).map(|(t, o)| t - o).collect()
}

/// V_T (eq 35): V_max (1 − exp(−σ_v d_T)).
pub fn target_velocity(distance_to_target: f32, cfg: &StimulusConfig) -> f32 {
    cfg.v_max * (1.0 - (-cfg.sigma_v * distance_to_target.max(0.0)).exp())
}

/// V_O (eq 36): C_O (1 − g(d_no) exp(−σ_ov (φ_F − i_no)²)), slowing down when the chosen
/// heading points at the nearest obstacle.
pub fn obstacle_velocity(
    heading: f32,
    nearest_distance: f32,
    nearest_bearing: f32,
    cfg: &StimulusConfig,
) -> f32 {
    let a = angle_diff(heading, nearest_bearing);
    cfg.c_ov * (1.0 - cfg.g(nearest_distance) * (-cfg.sigma_ov * a * a).exp())
}

/// V (eq 37): V_T·V_O when the field has a peak (its largest activation is above zero, the
/// reading of "φ_F > 0" adopted here), else 0 — no decision, no motion.
pub fn velocity(v_t: f32, v_o: f32, peak_activation: f32) -> f32 {
    if peak_activation > 0.0 {
        v_t * v_o
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav::dnf::{FieldBatch, FieldConfig};

    const N: usize = 72;

    #[test]
    fn obstacle_stimulus_peaks_at_the_obstacle_and_fades_with_distance() {
        let cfg = StimulusConfig::default();
        let near = obstacle_stimulus(&[0.5], &[1.0], &cfg, N).unwrap();
        let far = obstacle_stimulus(&[3.0], &[1.0], &cfg, N).unwrap();
        let at = (1.0 / std::f32::consts::TAU * N as f32).round() as usize;
        let argmax = (0..N).fold(0, |b, i| if near[i] > near[b] { i } else { b });
        assert_eq!(argmax, at);
        assert!(near[at] > far[at] && far[at] > 0.0);
        assert!(obstacle_stimulus(&[9.0], &[1.0], &cfg, N)
            .unwrap()
            .iter()
            .all(|&v| v == 0.0));
        // Wrap-around: an obstacle at −0.1 rad excites neurons near 2π.
        let wrap = obstacle_stimulus(&[0.5], &[-0.1], &cfg, N).unwrap();
        assert!(wrap[N - 1] > wrap[N / 2]);
    }

    #[test]
    fn non_finite_beams_are_refused_by_index() {
        let e = obstacle_stimulus(&[1.0, f32::NAN], &[0.0, 0.1], &StimulusConfig::default(), N)
            .unwrap_err()
            .to_string();
        assert!(e.contains("beam 1"), "{e}");
        assert!(obstacle_stimulus(&[1.0], &[0.0, 0.1], &StimulusConfig::default(), N).is_err());
        assert!(StimulusConfig {
            sigma: f32::NAN,
            ..Default::default()
        }
        .validate()
        .is_err());
    }

    #[test]
    fn the_field_heads_for_the_target_around_an_obstacle() {
        let cfg = StimulusConfig::default();
        let target = target_stimulus(0.0, &cfg, N);
        assert_eq!(
            (0..N).fold(0, |b, i| if target[i] > target[b] { i } else { b }),
            0
        );
        // Free space: the field picks the target heading.
        let mut field = FieldBatch::new(FieldConfig::default(), 2).unwrap();
        // An obstacle 0.4 m straight ahead, slightly to the left (+0.05 rad).
        let obstacle = obstacle_stimulus(&[0.4, 0.4, 0.4], &[0.0, 0.05, 0.1], &cfg, N).unwrap();
        let mut s = target.clone();
        s.extend(combined(&target, &obstacle));
        field.step(&s, 1500).unwrap();
        assert_eq!(field.peak(0).0, 0);
        let (_, heading) = field.peak(1);
        let off = angle_diff(heading, 0.05).abs();
        assert!(
            off > 0.3,
            "the chosen heading {heading} rad avoids the obstacle"
        );
        // Velocities: slower near the target and when heading at the obstacle.
        assert!(target_velocity(0.1, &cfg) < target_velocity(3.0, &cfg));
        assert!(obstacle_velocity(0.0, 0.4, 0.0, &cfg) < obstacle_velocity(1.5, 0.4, 0.0, &cfg));
        assert_eq!(velocity(0.5, 0.8, -1.0), 0.0);
        assert!((velocity(0.5, 0.8, 1.0) - 0.4).abs() < 1e-6);
    }
}
