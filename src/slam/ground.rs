//! The wheeled model's ground plane, as pseudo-measurements taken by eqs 22–24: a vehicle's
//! camera rides at a fixed height H over the flat ground it drives on, so every landmark on
//! the ground lies H below the camera along its vertical axis, whatever the frame. H is a
//! state entry in the map's own unit ([`GROUND`]), seated from the converged landmarks once
//! enough lie below the camera; from then on the ground's landmarks hold the map's unit to
//! it. Monocular SLAM cannot observe its scale, and a map's unit drifts as landmarks are
//! replaced (most in the turns, where new landmarks come with little parallax); the ground
//! the vehicle drives on is the one length the scene keeps.

use nalgebra::{DMatrix, DVector, Vector3};

use super::ekf::Filter;
use super::inverse_depth;
use super::inverse_depth::Parametrisation;
use super::motion::{MotionModel, GROUND};
use super::rotation;

/// A landmark counts as converged when σ_ρ/ρ is below this (Euclidean ones always do).
const CONVERGED: f64 = 0.3;
/// H is seated at this quantile of the converged landmarks' heights below the camera: the
/// ground is the lowest surface, and the top tenth allows for depths still too long.
const SEAT_QUANTILE: f64 = 0.9;
/// H is seated once this many converged landmarks lie below the camera.
const SEAT_MIN_LANDMARKS: usize = 10;
/// Prior standard deviation of the seated H, as a fraction of it.
const SEAT_SPREAD: f64 = 0.25;
/// A converged landmark lies on the ground when its height below the camera is within this
/// fraction of H.
const BAND: f64 = 0.1;
/// Standard deviation of a ground landmark's height, as a fraction of H: the ground's
/// unevenness and the vehicle's bounce on it …
const HEIGHT_SIGMA: f64 = 0.03;
/// … plus this many radians of the vehicle's pitch and roll on it (a landmark's height error
/// grows with its distance).
const TILT_SIGMA: f64 = 0.01;
/// Rays within about 3° of the horizon (this sine) meet the ground too far away for their
/// height to say anything.
const MIN_SLOPE: f64 = 0.05;
/// Fewest ground landmarks for a frame's constraint.
const MIN_GROUND: usize = 3;

impl Filter {
    /// The wheeled model's height of the camera over the ground and its standard deviation,
    /// in map units; `None` before it is seated and for the other models.
    pub fn ground(&self) -> Option<(f64, f64)> {
        let ground = self.ground_entry()?;
        let variance = self.p[(ground, ground)];
        (variance > 0.0).then(|| (self.x[ground], variance.sqrt()))
    }

    /// The index of H in the state, when the model carries it and its ground prior is on.
    fn ground_entry(&self) -> Option<usize> {
        match &self.motion {
            MotionModel::Wheeled(w) if w.ground_prior => Some(GROUND),
            _ => None,
        }
    }

    /// Each converged landmark below the camera: slot, height below the camera (along its y
    /// axis), the sine of its ray's slope below the horizon, and its distance.
    fn below_camera(&self) -> Vec<(usize, f64, f64, f64)> {
        let r = self.position();
        let to_camera = rotation::matrix(&self.orientation()).transpose();
        (0..self.slots.len())
            .filter_map(|slot| {
                let point = self.landmark_point(slot)?;
                let distance = (point - r).norm().max(1e-9);
                let converged = self.rho_variance(slot).sqrt() < CONVERGED / distance;
                let height = (to_camera * (point - r)).y;
                (converged && height > 0.0).then_some((slot, height, height / distance, distance))
            })
            .collect()
    }

    /// The ground's distance below the camera as the map places it, map units: the
    /// [`SEAT_QUANTILE`] of the converged landmarks' heights below the camera, once
    /// [`SEAT_MIN_LANDMARKS`] lie there.
    pub(in crate::slam) fn ground_from_map(&self) -> Option<f64> {
        ground_from(&self.below_camera())
    }

    /// Seats H when it is not yet and the map allows, then takes this frame's constraint:
    /// each ground landmark's height below the camera is H. A no-op for the other models.
    pub(in crate::slam) fn constrain_ground(&mut self) {
        let Some(entry) = self.ground_entry() else {
            return;
        };
        let below = self.below_camera();
        if self.p[(entry, entry)] <= 0.0 {
            let Some(height) = ground_from(&below) else {
                return;
            };
            self.x[entry] = height;
            self.p[(entry, entry)] = (SEAT_SPREAD * height).powi(2);
            log::debug!("ground seated {height:.3} map units below the camera");
        }
        let h = self.x[entry];
        let (ground, distances): (Vec<usize>, Vec<f64>) = below
            .iter()
            .filter(|&&(_, height, slope, _)| (height - h).abs() < BAND * h && slope > MIN_SLOPE)
            .map(|b| (b.0, b.3))
            .unzip();
        if ground.len() < MIN_GROUND {
            return;
        }
        let (value, columns, jacobian) = self.ground_residuals(&ground, entry);
        let sigma = DVector::from_iterator(
            ground.len(),
            distances.iter().map(|d| HEIGHT_SIGMA * h + TILT_SIGMA * d),
        );
        self.take_constraint(&value, &columns, &jacobian, &sigma);
    }

    /// The residuals (height below the camera − H) of the landmarks in `slots`, the state
    /// entries they depend on (the camera's position and orientation, H, the landmarks), and
    /// their Jacobian over those entries.
    fn ground_residuals(
        &self,
        slots: &[usize],
        entry: usize,
    ) -> (DVector<f64>, Vec<usize>, DMatrix<f64>) {
        let r = self.position();
        let q = self.orientation();
        let rt = rotation::matrix(&q).transpose();
        let mut columns: Vec<usize> = (0..7).chain([entry]).collect();
        for &slot in slots {
            let s = self.slots[slot];
            columns.extend(s.offset..s.offset + s.kind.dim());
        }
        let mut value = DVector::zeros(slots.len());
        let mut jacobian = DMatrix::zeros(slots.len(), columns.len());
        let mut next = 8;
        for (row, &slot) in slots.iter().enumerate() {
            let s = self.slots[slot];
            let y = self.landmark(slot);
            let (point, dp_dy) = match s.kind {
                Parametrisation::Euclidean => {
                    (Vector3::new(y[0], y[1], y[2]), DMatrix::identity(3, 3))
                }
                Parametrisation::InverseDepth => {
                    let (p, j) = inverse_depth::to_euclidean(y);
                    (p, DMatrix::from_iterator(3, 6, j.iter().copied()))
                }
            };
            let d = point - r;
            value[row] = (rt * d).y - self.x[entry];
            let down = rt.row(1);
            for k in 0..3 {
                jacobian[(row, k)] = -down[k];
            }
            let dq = rotation::d_rotate_transpose_dq(&q, &d);
            for k in 0..4 {
                jacobian[(row, 3 + k)] = dq[(1, k)];
            }
            jacobian[(row, 7)] = -1.0;
            let along = DMatrix::from_row_slice(1, 3, &[down[0], down[1], down[2]]) * dp_dy;
            for k in 0..s.kind.dim() {
                jacobian[(row, next + k)] = along[k];
            }
            next += s.kind.dim();
        }
        (value, columns, jacobian)
    }
}

/// The [`SEAT_QUANTILE`] of the heights of `below` (from `Filter::below_camera`), once
/// [`SEAT_MIN_LANDMARKS`] lie there.
fn ground_from(below: &[(usize, f64, f64, f64)]) -> Option<f64> {
    if below.len() < SEAT_MIN_LANDMARKS {
        return None;
    }
    let mut heights: Vec<f64> = below.iter().map(|b| b.1).collect();
    let k = ((heights.len() - 1) as f64 * SEAT_QUANTILE) as usize;
    Some(*heights.select_nth_unstable_by(k, f64::total_cmp).1)
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector2;

    use super::*;
    use crate::slam::camera::PinholeCamera;
    use crate::slam::motion::WheeledMotion;

    const HEIGHT: f64 = 0.3;

    /// A wheeled filter at the origin, looking along +z with its y axis down, and converged
    /// landmarks (σ_ρ = 5% of ρ) at `heights` below the camera, seen at pixels spread over the
    /// lower half of the image.
    fn filter_over_ground(heights: &[f64]) -> Filter {
        let cam = PinholeCamera::ideal(300.0, 300.0, 160.0, 120.0, 320, 240);
        let mut f = Filter::new(
            cam.clone(),
            MotionModel::Wheeled(WheeledMotion::default()),
            1.0,
            0.1,
            0.1,
        );
        let priors: Vec<(Vector2<f64>, f64, f64)> = heights
            .iter()
            .enumerate()
            .map(|(i, &height)| {
                let pixel = Vector2::new(20.0 + 23.0 * i as f64 % 280.0, 150.0 + 7.0 * i as f64);
                let ray = cam.back_project(pixel).0.normalize();
                let rho = ray.y / height;
                (pixel, rho, 0.05 * rho)
            })
            .collect();
        f.add_landmarks_with_depth(&priors);
        f
    }

    fn height_below_camera(f: &Filter, slot: usize) -> f64 {
        let to_camera = rotation::matrix(&f.orientation()).transpose();
        (to_camera * (f.landmark_point(slot).unwrap() - f.position())).y
    }

    #[test]
    fn the_ground_is_seated_from_the_map_and_pulls_its_landmarks_to_one_height() {
        // Twelve landmarks on the ground, one a little high on it, one on a box top.
        let mut heights = vec![HEIGHT; 12];
        heights.push(1.06 * HEIGHT);
        heights.push(0.4 * HEIGHT);
        let mut f = filter_over_ground(&heights);
        assert_eq!(f.ground(), None, "not seated before the first constraint");
        f.constrain_ground();
        let (h, sigma) = f
            .ground()
            .expect("seated: 14 converged landmarks below the camera");
        assert!((h - HEIGHT).abs() < 0.2 * HEIGHT * 0.06, "H {h}");
        assert!(
            sigma < SEAT_SPREAD * HEIGHT,
            "σ_H {sigma} shrinks with the first constraint"
        );
        // The high ground landmark comes down, by how much its own uncertainty (σ 5%) against
        // the constraint's (3% of H and 1% of its distance) says; the box top stays.
        let high = height_below_camera(&f, 12);
        assert!(
            high > HEIGHT && high < (1.0 + 0.75 * 0.06) * HEIGHT,
            "height {high}"
        );
        let top = height_below_camera(&f, 13);
        assert!((top - 0.4 * HEIGHT).abs() < 1e-9, "box top moved to {top}");
    }

    #[test]
    fn too_few_landmarks_below_the_camera_leave_the_ground_unseated() {
        let mut f = filter_over_ground(&[HEIGHT; 5]);
        let before = f.state().clone();
        f.constrain_ground();
        assert_eq!(f.ground(), None);
        assert_eq!(f.state(), &before);
    }

    #[test]
    fn the_ground_residuals_jacobian_matches_finite_differences() {
        let mut f = filter_over_ground(&[HEIGHT, 0.9 * HEIGHT, 1.1 * HEIGHT]);
        f.convert_to_euclidean(1);
        // A camera turned and moved off the origin, H off the landmarks' heights.
        f.x[0] = 0.1;
        f.x[1] = -0.02;
        f.x[2] = 0.3;
        let q = rotation::from_rotation_vector(&Vector3::new(0.05, 0.3, -0.02));
        f.x.fixed_rows_mut::<4>(3).copy_from(&q);
        f.x[GROUND] = 0.28;
        let slots = [0, 1, 2];
        let (_, columns, jacobian) = f.ground_residuals(&slots, GROUND);
        for (k, &column) in columns.iter().enumerate() {
            let (mut plus, mut minus) = (f.clone(), f.clone());
            plus.x[column] += 1e-6;
            minus.x[column] -= 1e-6;
            let fd = (plus.ground_residuals(&slots, GROUND).0
                - minus.ground_residuals(&slots, GROUND).0)
                / 2e-6;
            for row in 0..slots.len() {
                assert!(
                    (fd[row] - jacobian[(row, k)]).abs() < 1e-6,
                    "row {row} column {column}: {} against {}",
                    jacobian[(row, k)],
                    fd[row]
                );
            }
        }
    }
}
