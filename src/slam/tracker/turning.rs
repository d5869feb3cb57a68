//! The wheeled model's depth prior for the landmarks met while the vehicle turns in place, in
//! place of eq 13's fixed ρ₀. A turn sweeps the camera over surfaces it has not seen with
//! almost no baseline, and a point's image then moves by about ω·(1 + d·ρ): a common error of
//! the new landmarks' ρ trades against the turn rate, so the turn keeps whatever depth they
//! start at, and the next leg takes its unit from them (docs/SLAM.md, "The map's depths against
//! the truth"). Two guesses, in the map's own unit:
//! - below the horizon, where the ray meets the ground: the camera rides at a fixed height over
//!   it, the filter's (`ground.rs`) once seated, before that the height below the camera that
//!   the converged landmarks reach (the ground is the lowest surface there is);
//! - elsewhere, the median inverse distance of the converged landmarks in view.

use nalgebra::{Vector2, Vector3};

use super::Slam;
use crate::slam::camera::PinholeCamera;
use crate::slam::motion::MotionModel;

/// The turning prior applies while the camera translates less than this fraction of what its
/// rotation sweeps at the scene's depth (|v| < k·|ω|/ρ): an in-place turn on its arm is about
/// 0.05, a car in a bend about 1.
const TURNING_TRANSLATION: f64 = 0.2;
/// σ_ρ of the turning prior, as a fraction of its ρ (0.3 and 1.0 measured worse on the
/// rover: docs/SLAM.md).
const TURNING_PRIOR_SPREAD: f64 = 0.5;
/// A landmark counts as converged when σ_ρ/ρ is below this (Euclidean ones always do).
const CONVERGED: f64 = 0.3;
/// Rays within about 3° of the horizon (this sine) meet the ground too far away to say
/// anything; they take the scene's median.
const GROUND_MIN_SLOPE: f64 = 0.05;

/// The depth prior of the landmarks started in one frame of an in-place turn.
pub(super) struct TurningPrior {
    /// The median inverse distance of the converged landmarks in view.
    rho: f64,
    /// The ground's distance below the camera (along its y axis, down), map units.
    ground: Option<f64>,
    camera: PinholeCamera,
}

impl TurningPrior {
    /// ρ and σ_ρ of a landmark started at `pixel`.
    pub(super) fn at(&self, pixel: &Vector2<f64>) -> (f64, f64) {
        let rho = self
            .ground
            .and_then(|height| {
                let ray = self.camera.back_project(*pixel).0.normalize();
                (ray.y > GROUND_MIN_SLOPE).then(|| ray.y / height)
            })
            .unwrap_or(self.rho);
        (rho, TURNING_PRIOR_SPREAD * rho)
    }
}

impl Slam {
    /// The prior while a wheeled vehicle turns in place, from the converged landmarks
    /// (`in_view`: those predicted in the image, from `visible_landmarks`; at least 5 of
    /// them converged). `None` (the caller keeps ρ₀) for the other models and when the camera
    /// translates more than a fifth of what its rotation sweeps at the scene's depth.
    pub(super) fn turning_prior(&self, in_view: &[(usize, Vector2<f64>)]) -> Option<TurningPrior> {
        let MotionModel::Wheeled(wheeled) = self.filter.motion() else {
            return None;
        };
        let r = self.filter.position();
        let mut inverse: Vec<f64> = in_view
            .iter()
            .filter_map(|&(slot, _)| self.converged_point(slot, &r))
            .map(|p| 1.0 / (p - r).norm().max(1e-9))
            .collect();
        if inverse.len() < 5 {
            return None;
        }
        let mid = inverse.len() / 2;
        let rho = *inverse.select_nth_unstable_by(mid, f64::total_cmp).1;
        let x = self.filter.state();
        let speed = Vector3::new(x[7], x[8], x[9]).norm();
        let turn = Vector3::new(x[10], x[11], x[12]).norm();
        (speed < TURNING_TRANSLATION * turn / rho).then(|| TurningPrior {
            rho,
            ground: wheeled
                .ground_prior
                .then(|| {
                    self.filter
                        .ground()
                        .map(|g| g.0)
                        .or_else(|| self.filter.ground_from_map())
                })
                .flatten(),
            camera: self.filter.camera().clone(),
        })
    }

    /// The landmark in `slot`, when its depth seen from `r` has converged.
    fn converged_point(&self, slot: usize, r: &Vector3<f64>) -> Option<Vector3<f64>> {
        let point = self.filter.landmark_point(slot)?;
        let distance = (point - r).norm().max(1e-9);
        let sigma = self.filter.rho_variance(slot).sqrt();
        (sigma < CONVERGED / distance).then_some(point)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn below_the_horizon_a_landmark_starts_where_its_ray_meets_the_ground() {
        let camera = PinholeCamera::ideal(500.0, 500.0, 319.5, 239.5, 640, 480);
        let prior = TurningPrior {
            rho: 0.4,
            ground: Some(0.15),
            camera: camera.clone(),
        };
        // 100 px below the centre: the ray falls by 0.2 per unit ahead, so it meets the ground
        // 0.15 units below at 0.75 units ahead.
        let (rho, sigma) = prior.at(&Vector2::new(319.5, 339.5));
        let ray = Vector3::new(0.0, 0.2, 1.0).normalize();
        assert!((rho - ray.y / 0.15).abs() < 1e-12, "{rho}");
        assert!((sigma - TURNING_PRIOR_SPREAD * rho).abs() < 1e-12);
        // On the horizon and above it, and without a ground, the scene's median.
        for pixel in [Vector2::new(319.5, 245.0), Vector2::new(100.0, 20.0)] {
            assert_eq!(prior.at(&pixel).0, 0.4);
        }
        let no_ground = TurningPrior {
            ground: None,
            ..prior
        };
        assert_eq!(no_ground.at(&Vector2::new(319.5, 339.5)).0, 0.4);
    }
}
