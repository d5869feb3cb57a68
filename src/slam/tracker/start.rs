//! The start-up of a monocular session: keypoints followed by KLT from a reference frame until
//! two views fix the motion (the essential matrix, then landmarks at triangulated depths), or
//! the paper's own start at rest (eq 13's prior depth) when the camera does not move.

use std::time::Instant;

use nalgebra::{Vector2, Vector3};
use rayon::prelude::*;

use super::report::{FrameReport, SlamTimings};
use super::{ms, Slam};
use crate::error::Result;
use crate::features::Detector;
use crate::image::Frame;
use crate::slam::camera::PinholeCamera;
use crate::slam::ekf::Seat;
use crate::slam::klt::{self, Pyramid};
use crate::slam::resect::resect;
use crate::slam::rotation::{self, Quat};
use crate::slam::two_view;

/// Where a session is in its start.
#[derive(Clone, Debug)]
pub(super) enum Phase {
    /// No map yet: points are followed from a reference frame (none before the first frame)
    /// until the two views determine the motion. Frames are reported `initialising`.
    Starting(Option<Bootstrap>),
    /// Started at rest: the map has bearings but no depths. The start-up points are still
    /// followed, to seat the filter again once the camera moves.
    AtRest(Bootstrap),
    /// The map is seated; every frame is tracked against it.
    Tracking,
}

/// Points followed by KLT from a reference frame, for the two-view start.
#[derive(Clone, Debug)]
pub(super) struct Bootstrap {
    /// Timestamp of the reference frame.
    timestamp: f64,
    /// Camera pose at the reference frame.
    pub(super) position: Vector3<f64>,
    pub(super) orientation: Quat,
    /// Pixels in the reference frame and where KLT has followed them to.
    pub(super) start: Vec<Vector2<f64>>,
    pub(super) current: Vec<Vector2<f64>>,
    /// Timestamp of `current`.
    current_time: f64,
    /// The frames between the reference and `current`: their timestamps and where the points
    /// were in each (same order as `start`), to place them once two views fix the points.
    between: Vec<(f64, Vec<Vector2<f64>>)>,
}

/// Frames between the reference and the current one kept for placing them afterwards; the
/// later ones keep their reported pose.
const MAX_BETWEEN: usize = 150;

/// The normalised image points (x/z, y/z) of pixels `from[i]` and `to[i]`, undistorted.
pub(super) fn normalised_pairs(
    cam: &PinholeCamera,
    from: &[Vector2<f64>],
    to: &[Vector2<f64>],
) -> Vec<two_view::Correspondence> {
    let normalised = |z: &Vector2<f64>| {
        let (ray, _) = cam.back_project(*z);
        ray / ray.z
    };
    from.iter()
        .zip(to)
        .map(|(a, c)| (normalised(a), normalised(c)))
        .collect()
}

impl Slam {
    fn reference(&self) -> Option<&Bootstrap> {
        match &self.phase {
            Phase::Starting(b) => b.as_ref(),
            Phase::AtRest(b) => Some(b),
            Phase::Tracking => None,
        }
    }

    fn reference_mut(&mut self) -> Option<&mut Bootstrap> {
        match &mut self.phase {
            Phase::Starting(b) => b.as_mut(),
            Phase::AtRest(b) => Some(b),
            Phase::Tracking => None,
        }
    }

    /// Start-up: follows keypoints from a reference frame until the two views determine the
    /// motion, then seats the filter there — pose, velocity, angular velocity, and landmarks
    /// at their triangulated depths.
    pub(super) fn initialise(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        detector: &Detector,
        previous: Option<&Pyramid>,
        pyramid: &Pyramid,
        start: Instant,
    ) -> Result<FrameReport> {
        let mut timings = SlamTimings::default();
        let mut created = 0;
        let t = Instant::now();
        let (followed, _) = self.follow_bootstrap(previous, pyramid, timestamp);
        timings.association_ms = ms(t);
        if followed >= self.config.start.min_points {
            let t = Instant::now();
            created = self.try_seat(frame, timestamp);
            timings.filter_ms = ms(t);
        }
        let at_rest = matches!(&self.phase, Phase::Starting(Some(b))
            if followed >= self.config.start.min_points
                && timestamp - b.timestamp >= self.config.start.stationary_after);
        if at_rest {
            // The points stay put: the camera is (nearly) at rest, which is the paper's own
            // start — the filter at rest, landmarks at the inverse-depth prior. The points
            // stay followed, to seat the filter again once it moves (`follow_rest_start`).
            if let Phase::Starting(Some(b)) = std::mem::replace(&mut self.phase, Phase::Tracking) {
                self.phase = Phase::AtRest(b);
            }
            let (n, detection_ms, creation_ms) = self.create_landmarks(frame, detector, None)?;
            created = n;
            timings.detection_ms = detection_ms;
            timings.filter_ms += creation_ms;
        }
        if matches!(self.phase, Phase::Starting(_)) && followed < self.config.start.min_points {
            let t = Instant::now();
            self.restart_bootstrap(pyramid, timestamp);
            timings.detection_ms = ms(t);
        }
        timings.total_ms = ms(start);
        let initialising = matches!(self.phase, Phase::Starting(_));
        Ok(self.report(timestamp, timings, created, initialising))
    }

    /// Starts the two-view reference at this frame: Shi–Tomasi corners of `pyramid`, at the
    /// filter's current pose.
    fn restart_bootstrap(&mut self, pyramid: &Pyramid, timestamp: f64) {
        let margin = self.config.klt.half_window + 2;
        let points = klt::good_features(
            pyramid,
            self.config.start.corner_grid,
            self.config.start.corners_per_cell,
            margin,
        );
        let reference = Bootstrap {
            timestamp,
            position: self.filter.position(),
            orientation: self.filter.orientation(),
            start: points.clone(),
            current: points,
            current_time: timestamp,
            between: Vec::new(),
        };
        self.phase = match &self.phase {
            Phase::AtRest(_) => Phase::AtRest(reference),
            _ => Phase::Starting(Some(reference)),
        };
    }

    /// Follows the start-up points from `previous` into `current` by KLT, dropping those it
    /// loses. Returns how many are left and their median displacement in pixels.
    fn follow_bootstrap(
        &mut self,
        previous: Option<&Pyramid>,
        current: &Pyramid,
        timestamp: f64,
    ) -> (usize, f64) {
        let params = self.config.klt;
        let (Some(b), Some(from)) = (self.reference_mut(), previous) else {
            return (0, 0.0);
        };
        if b.current_time > b.timestamp && b.between.len() < MAX_BETWEEN {
            b.between.push((b.current_time, b.current.clone()));
        }
        b.current_time = timestamp;
        let moved: Vec<Option<Vector2<f64>>> = b
            .current
            .par_iter()
            .map(|&z| klt::track(from, current, z, z, &params))
            .collect();
        let mut kept = 0;
        let mut displacements = Vec::with_capacity(moved.len());
        for (i, m) in moved.into_iter().enumerate() {
            if let Some(z) = m {
                displacements.push((z - b.current[i]).norm());
                b.start[kept] = b.start[i];
                b.current[kept] = z;
                for (_, pixels) in &mut b.between {
                    pixels[kept] = pixels[i];
                }
                kept += 1;
            }
        }
        b.start.truncate(kept);
        b.current.truncate(kept);
        for (_, pixels) in &mut b.between {
            pixels.truncate(kept);
        }
        displacements.sort_by(f64::total_cmp);
        (kept, displacements.get(kept / 2).copied().unwrap_or(0.0))
    }

    /// After a start at rest the map has bearings but no depths. The start-up points keep
    /// being followed from the last frame at rest; once the camera has moved enough for two
    /// views, the filter is seated again there as if it had started moving — the trajectory
    /// continues from the pose at rest, and the depthless map is replaced. Returns the
    /// landmarks created when it seated.
    pub(super) fn follow_rest_start(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        previous: Option<&Pyramid>,
        current: &Pyramid,
    ) -> Option<usize> {
        let (followed, median_step) = self.follow_bootstrap(previous, current, timestamp);
        if followed < self.config.start.min_points {
            self.restart_bootstrap(current, timestamp);
            return None;
        }
        let (r, q) = (self.filter.position(), self.filter.orientation());
        let rest_step = self.config.start.rest_step;
        let b = self.reference_mut()?;
        if median_step < rest_step {
            // Still at rest: the motion, when it comes, starts from here.
            b.start.clone_from(&b.current);
            b.between.clear();
            b.timestamp = timestamp;
            b.position = r;
            b.orientation = q;
            return None;
        }
        let created = self.try_seat(frame, timestamp);
        (created > 0).then_some(created)
    }

    /// Tries the two-view estimate on the followed points; when it is well determined, seats
    /// the filter and returns the number of landmarks created.
    fn try_seat(&mut self, frame: &Frame, timestamp: f64) -> usize {
        let Some(b) = self.reference().cloned() else {
            return 0;
        };
        let cam = self.filter.camera().clone();
        let pairs = normalised_pairs(&cam, &b.start, &b.current);
        let threshold = self.config.ransac.threshold / cam.fx.max(cam.fy);
        let Some(pose) = two_view::relative_pose(
            &pairs,
            threshold,
            self.config.start.two_view_iterations,
            &mut self.rng,
        ) else {
            return 0;
        };
        let alternative = if self.config.start.two_view_search {
            two_view::searched_alternative(&pairs, &pose, threshold)
        } else {
            None
        };
        // The rival is this session as it stands before it seats, seated on the other motion.
        let rival = alternative.is_some().then(|| self.clone());
        let created = self.seat_on(frame, timestamp, &b, &pairs, &pose);
        if let (Some(mut rival), Some(alternative)) = (rival, alternative) {
            if created > 0 && rival.seat_on(frame, timestamp, &b, &pairs, &alternative) > 0 {
                self.start_trial(rival, &b);
            }
        }
        created
    }

    /// Seats the filter on a two-view motion when it is well determined (enough inliers,
    /// enough parallax); returns the number of landmarks created, 0 when it did not seat.
    fn seat_on(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        b: &Bootstrap,
        pairs: &[(Vector3<f64>, Vector3<f64>)],
        pose: &two_view::RelativePose,
    ) -> usize {
        let cam = self.filter.camera().clone();
        let inlier_count = pose.inliers.iter().filter(|&&i| i).count();
        let mut parallax: Vec<f64> = pose
            .parallax
            .iter()
            .zip(&pose.inliers)
            .filter(|(_, &i)| i)
            .map(|(p, _)| *p)
            .collect();
        if inlier_count < self.config.start.min_points || 2 * inlier_count < pairs.len() {
            return 0;
        }
        parallax.sort_by(f64::total_cmp);
        if parallax[3 * parallax.len() / 4] < self.config.start.min_parallax {
            return 0;
        }
        let elapsed = (timestamp - b.timestamp).max(1e-9);
        let mut inverse_depths: Vec<f64> = pose
            .depths
            .iter()
            .zip(&pose.inliers)
            .filter(|(_, &i)| i)
            .map(|(d, _)| 1.0 / d)
            .collect();
        inverse_depths.sort_by(f64::total_cmp);
        let median_rho = inverse_depths[inverse_depths.len() / 2];
        // Map units per unit of two-view translation: the median landmark lands at the
        // inverse-depth prior ρ₀, as a landmark started from one view would.
        let scale = median_rho / self.config.filter.initial_inverse_depth.max(1e-6);
        let rot0 = rotation::matrix(&b.orientation);
        // Camera 1 in camera 0's frame: centre −Rᵀt, orientation Rᵀ.
        let centre = -(pose.rotation.transpose() * pose.translation) * scale;
        let r = b.position + rot0 * centre;
        let q = rotation::multiply(
            &b.orientation,
            &rotation::from_matrix(&pose.rotation.transpose()),
        );
        let velocity = (r - b.position) / elapsed;
        let omega =
            rotation::to_rotation_vector(&rotation::from_matrix(&pose.rotation.transpose()))
                / elapsed;
        if matches!(self.phase, Phase::AtRest(_)) {
            // Re-seating after a start at rest: the old landmarks carry no depth.
            let all: Vec<usize> = (0..self.filter.slots().len()).collect();
            self.remove(&all);
        }
        let baseline = (r - b.position).norm();
        let velocity_variance = |v: &Vector3<f64>| {
            (self.config.start.velocity_sigma_fraction * v.norm()).powi(2)
                + self.config.filter.velocity_sigma.powi(2)
        };
        let mut seat = Seat {
            position: r,
            orientation: q,
            position_variance: (self.config.start.position_sigma_per_baseline * baseline).powi(2)
                + 1e-12,
            orientation_variance: self.config.start.orientation_variance,
            velocity,
            velocity_variance: velocity_variance(&velocity),
            angular_velocity: omega,
            angular_velocity_variance: self.config.filter.angular_velocity_sigma.powi(2),
        };
        self.filter.seat(&seat);
        // Landmarks at the triangulated inliers, spread over the grid.
        let inliers: Vec<(Vector2<f64>, f64, f64)> = (0..pairs.len())
            .filter(|&i| pose.inliers[i])
            .map(|i| {
                let rho = 1.0 / (pose.depths[i] * scale);
                // Depth from parallax α with one pixel of noise: σ_ρ/ρ ≈ (σ/f)/α.
                let relative =
                    (self.config.filter.pixel_sigma / cam.fx) / pose.parallax[i].max(1e-6);
                let sigma = (rho * relative.max(self.config.start.depth_floor))
                    .min(self.config.filter.inverse_depth_sigma.max(rho));
                (b.current[i], rho, sigma)
            })
            .collect();
        let initialising = matches!(self.phase, Phase::Starting(_));
        self.revised = self.place_between(b, pose, scale, initialising);
        // A camera that sped up (or slowed down) through the wait moves at the seat faster
        // (slower) than the wait's mean: with `accelerated_seat`, the velocity at the seat
        // comes from the placed frames when a constant velocity does not explain them.
        if self.config.start.accelerated_seat {
            let track: Vec<(f64, Vector3<f64>)> =
                std::iter::once((b.timestamp - timestamp, b.position))
                    .chain(
                        self.revised
                            .iter()
                            .map(|f| (f.timestamp - timestamp, Vector3::from(f.position))),
                    )
                    .chain(std::iter::once((0.0, r)))
                    .collect();
            // Seated again rather than once after the placing: the placed frames' reports
            // read the seated filter, and a seat only overwrites the camera block.
            if let Some(v) = velocity_at_end(&track) {
                seat.velocity = v;
                seat.velocity_variance = velocity_variance(&v);
                self.filter.seat(&seat);
            }
        }
        self.phase = Phase::Tracking;
        let visible = self.visible_pixels();
        let limit = (2 * self.config.map.target_visible).saturating_sub(visible.len());
        self.add_at_free_cells(frame, &visible, inliers, limit, |_, _| None)
    }

    /// The frames between the reference and the seat were reported at the reference pose (or
    /// at rest): once seated, each is placed by resection on the triangulated inliers it saw,
    /// from the pose interpolated in time between the reference and the seat (kept where the
    /// resection fails). Their reports, for [`Slam::take_revised`].
    fn place_between(
        &self,
        b: &Bootstrap,
        pose: &two_view::RelativePose,
        scale: f64,
        initialising: bool,
    ) -> Vec<FrameReport> {
        let cam = self.filter.camera();
        let normalised = |z: &Vector2<f64>| {
            let (ray, _) = cam.back_project(*z);
            ray / ray.z
        };
        let (r, q) = (self.filter.position(), self.filter.orientation());
        let rot = rotation::matrix(&q);
        let seen: Vec<usize> = (0..pose.inliers.len())
            .filter(|&i| pose.inliers[i])
            .collect();
        let points: Vec<Vector3<f64>> = seen
            .iter()
            .map(|&i| r + rot * (normalised(&b.current[i]) * (pose.depths[i] * scale)))
            .collect();
        let turn = rotation::to_rotation_vector(&rotation::from_matrix(
            &(rotation::matrix(&b.orientation).transpose() * rot),
        ));
        let span = (b.current_time - b.timestamp).max(1e-9);
        b.between
            .iter()
            .map(|(t, pixels)| {
                let f = ((t - b.timestamp) / span).clamp(0.0, 1.0);
                let guess = (
                    b.position + (r - b.position) * f,
                    rotation::multiply(
                        &b.orientation,
                        &rotation::from_rotation_vector(&(turn * f)),
                    ),
                );
                let rays: Vec<(f64, f64)> = seen
                    .iter()
                    .map(|&i| {
                        let n = normalised(&pixels[i]);
                        (n.x, n.y)
                    })
                    .collect();
                let (c, o) = resect(
                    &points,
                    &rays,
                    guess.0,
                    guess.1,
                    cam.fx,
                    2.0 * self.config.filter.pixel_sigma,
                    self.config.ransac.threshold,
                )
                .unwrap_or(guess);
                FrameReport {
                    position: [c.x, c.y, c.z],
                    orientation: [o[0], o[1], o[2], o[3]],
                    ..self.report(*t, SlamTimings::default(), 0, initialising)
                }
            })
            .collect()
    }
}

/// Fewest positions (the reference, the placed frames, the seat) for a start's velocity to be
/// fitted with an acceleration.
const MIN_ACCELERATION_SAMPLES: usize = 8;

/// F statistic above which the acceleration of a start's wait is taken as real: the quadratic
/// term must explain this many times the residual variance per degree of freedom (for 3 and
/// 15 or more degrees of freedom, a chance under 0.1%).
const ACCELERATION_F: f64 = 10.0;

/// The velocity at t = 0 of positions `track` (time, position; times up to 0) when they
/// accelerate: least squares of a quadratic in time on each axis, kept over a straight line
/// when its quadratic term passes an F test ([`ACCELERATION_F`]); `None` when a constant
/// velocity explains them or they are too few.
fn velocity_at_end(track: &[(f64, Vector3<f64>)]) -> Option<Vector3<f64>> {
    let n = track.len();
    if n < MIN_ACCELERATION_SAMPLES {
        return None;
    }
    // Normal equations of the fit on the powers 0..terms of t, all three axes at once.
    let fit = |terms: usize| -> Option<(nalgebra::DMatrix<f64>, f64)> {
        let design = nalgebra::DMatrix::from_fn(n, terms, |i, k| track[i].0.powi(k as i32));
        let values = nalgebra::DMatrix::from_fn(n, 3, |i, axis| track[i].1[axis]);
        let gram = design.transpose() * &design;
        let coefficients = gram.cholesky()?.solve(&(design.transpose() * &values));
        let rss = (&design * &coefficients - values).norm_squared();
        Some((coefficients, rss))
    };
    let (_, rss_line) = fit(2)?;
    let (quadratic, rss_quadratic) = fit(3)?;
    let dof = (3 * (n - 3)) as f64;
    let f = ((rss_line - rss_quadratic) / 3.0) / (rss_quadratic / dof).max(1e-300);
    (f > ACCELERATION_F)
        .then(|| Vector3::new(quadratic[(1, 0)], quadratic[(1, 1)], quadratic[(1, 2)]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positions every 1/30 s up to t = 0 along `path`, with a deterministic ±`noise` wobble.
    fn track(
        path: impl Fn(f64) -> Vector3<f64>,
        count: usize,
        noise: f64,
    ) -> Vec<(f64, Vector3<f64>)> {
        (0..count)
            .map(|i| {
                let t = (i as f64 - (count - 1) as f64) / 30.0;
                let wobble = Vector3::new(
                    (i as f64 * 1.7).sin(),
                    (i as f64 * 2.3).cos(),
                    (i as f64 * 0.9).sin(),
                );
                (t, path(t) + wobble * noise)
            })
            .collect()
    }

    #[test]
    fn a_start_from_rest_seats_at_its_final_velocity_and_a_steady_one_keeps_the_mean() {
        // From rest at t = −0.5 s with 2 units/s² along x: 1 unit/s at the seat, against a
        // mean of 0.5 over the wait.
        let accelerating = track(|t| Vector3::new((t + 0.5).powi(2), 0.0, 0.0), 16, 1e-3);
        let v = velocity_at_end(&accelerating).expect("an acceleration this clear is taken");
        assert!((v - Vector3::new(1.0, 0.0, 0.0)).norm() < 0.05, "{v}");
        // A steady camera with the same wobble: the straight line explains it.
        let steady = track(|t| Vector3::new(0.5 * t, 0.2 * t, 0.0), 16, 1e-3);
        assert_eq!(velocity_at_end(&steady), None);
        // Too few positions to tell.
        assert_eq!(
            velocity_at_end(&accelerating[..MIN_ACCELERATION_SAMPLES - 1]),
            None
        );
    }
}
