//! What a replay's figures say: each scan's motion over the look-ahead (driving forward,
//! turning in place, reversing, standing), the deviation statistics over the forward-driving
//! scans, and the reference they are judged against: the free heading nearest to the real
//! motion, found with the same free test as the field's choice. Where even the reference is
//! far off, the robot moved where the free test sees no room (a doorway narrower than the
//! free cone, say), and the field cannot be blamed for it.

use serde::Serialize;

use super::super::carmen::Scan;
use super::super::stimulus::{angle_diff, field_of_view, in_view};

/// What the robot did over the look-ahead after a scan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// Moved at least `min_motion`, in a direction within ±90° of the scanner's axis and
    /// inside its field of view.
    Forward,
    /// Moved less than `min_motion` and turned at least `turn_min_deg`.
    TurningInPlace,
    /// Moved at least `min_motion` backwards (beyond ±90°) or out of the scanner's view.
    Reversing,
    /// Neither moved nor turned.
    Standing,
}

/// How many scans fell in each [`Motion`].
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MotionCounts {
    /// [`Motion::Forward`].
    pub forward: usize,
    /// [`Motion::TurningInPlace`].
    pub turning_in_place: usize,
    /// [`Motion::Reversing`].
    pub reversing: usize,
    /// [`Motion::Standing`].
    pub standing: usize,
}

impl MotionCounts {
    /// Counts one scan.
    pub fn add(&mut self, motion: Motion) {
        *match motion {
            Motion::Forward => &mut self.forward,
            Motion::TurningInPlace => &mut self.turning_in_place,
            Motion::Reversing => &mut self.reversing,
            Motion::Standing => &mut self.standing,
        } += 1;
    }
}

/// Statistics of absolute deviations, degrees.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Deviation {
    /// Scans counted.
    pub scans: usize,
    /// Mean.
    pub mean_deg: f64,
    /// Median (the mean of the two middle values for an even count).
    pub median_deg: f64,
    /// 90th percentile, nearest rank.
    pub p90_deg: f64,
}

impl Deviation {
    /// The statistics of `values` (degrees); all zero when there are none.
    pub fn of(mut values: Vec<f64>) -> Self {
        let n = values.len();
        if n == 0 {
            return Self::default();
        }
        values.sort_by(f64::total_cmp);
        let median = if n % 2 == 1 {
            values[n / 2]
        } else {
            0.5 * (values[n / 2 - 1] + values[n / 2])
        };
        let rank = ((0.9 * n as f64).ceil() as usize).clamp(1, n);
        Self {
            scans: n,
            mean_deg: values.iter().sum::<f64>() / n as f64,
            median_deg: median,
            p90_deg: values[rank - 1],
        }
    }
}

/// The scanner's field of view of a scan (its first and last bearings, widened by half a beam
/// each side); a scan whose beams were all dropped sees nothing.
pub fn view_of(scan: &Scan) -> (f32, f32) {
    field_of_view(&scan.bearings, scan.angle_increment).unwrap_or((0.0, 0.0))
}

/// The motion over the look-ahead: `distance` moved (m) in the robot-frame direction
/// `direction` (rad), while the heading turned by `turned` (rad).
pub fn classify(
    distance: f64,
    direction: f32,
    turned: f64,
    fov: (f32, f32),
    min_motion: f64,
    turn_min: f64,
) -> Motion {
    if distance >= min_motion {
        if direction.abs() <= std::f32::consts::FRAC_PI_2 && in_view(direction, fov) {
            Motion::Forward
        } else {
            Motion::Reversing
        }
    } else if turned.abs() >= turn_min {
        Motion::TurningInPlace
    } else {
        Motion::Standing
    }
}

/// The free heading nearest to `target` inside the scanner's view, on a 0.5° grid either side
/// of it, by the same test as the field's choice (`free`); `None` when no heading is free.
pub fn nearest_free(scan: &Scan, target: f32, free: impl Fn(f32) -> bool) -> Option<f32> {
    let fov = view_of(scan);
    let step = 0.5f32.to_radians();
    let steps = (std::f32::consts::PI / step).ceil() as usize;
    for k in 0..=steps {
        let offset = k as f32 * step;
        for h in [target - offset, target + offset] {
            let h = angle_diff(h, 0.0);
            if in_view(h, fov) && free(h) {
                return Some(h);
            }
            if k == 0 {
                break;
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deviation_statistics() {
        let d = Deviation::of((1..=10).map(f64::from).collect());
        assert_eq!(
            (d.scans, d.mean_deg, d.median_deg, d.p90_deg),
            (10, 5.5, 5.5, 9.0)
        );
        let d = Deviation::of(vec![3.0, 1.0, 2.0]);
        assert_eq!((d.median_deg, d.p90_deg), (2.0, 3.0));
        assert_eq!(Deviation::of(Vec::new()), Deviation::default());
    }

    #[test]
    fn motions_and_views() {
        let half = (-std::f32::consts::FRAC_PI_2, std::f32::consts::FRAC_PI_2);
        let turn = 15f64.to_radians();
        assert_eq!(classify(0.5, 0.2, 0.0, half, 0.1, turn), Motion::Forward);
        assert_eq!(classify(0.5, 2.5, 0.0, half, 0.1, turn), Motion::Reversing);
        assert_eq!(
            classify(0.05, 0.0, 0.5, half, 0.1, turn),
            Motion::TurningInPlace
        );
        assert_eq!(classify(0.05, 0.0, 0.1, half, 0.1, turn), Motion::Standing);
        // A 100° scanner: sideways motion is out of its view.
        let narrow = (-50f32.to_radians(), 50f32.to_radians());
        assert_eq!(
            classify(0.5, 1.2, 0.0, narrow, 0.1, turn),
            Motion::Reversing
        );
        let full = (-std::f32::consts::PI, std::f32::consts::PI);
        assert!(in_view(3.1, full) && !in_view(1.6, half));
    }

    #[test]
    fn the_nearest_free_heading() {
        let n = 181;
        let bearings: Vec<f32> = (0..n)
            .map(|i| -std::f32::consts::FRAC_PI_2 + i as f32 * std::f32::consts::PI / 180.0)
            .collect();
        let scan = Scan {
            ranges: vec![5.0; n],
            bearings,
            angle_increment: std::f32::consts::PI / 180.0,
            x: 0.0,
            y: 0.0,
            theta: 0.0,
            time: 0.0,
        };
        // Free only beyond 20° to the left.
        let free = |h: f32| h >= 20f32.to_radians();
        let h = nearest_free(&scan, 0.0, free).unwrap();
        assert!((h.to_degrees() - 20.0).abs() < 0.51, "{}", h.to_degrees());
        assert_eq!(nearest_free(&scan, 0.3, |_| true), Some(0.3));
        assert_eq!(nearest_free(&scan, 0.0, |_| false), None);
    }
}
