//! The camera trajectories of the generated sequences: the hand-held room loop, the car's
//! drive, a person walking through one or two rooms while looking around, and a wheeled robot
//! that drives and turns in place. Each is sampled at any rate, so motion blur can integrate
//! the true motion between frames.

use std::f64::consts::{PI, TAU};

use nalgebra::{Vector2, Vector3};

use super::{SyntheticConfig, SyntheticMotion};
use crate::rng::Rng;
use crate::slam::data::trajectory::Pose;
use crate::slam::rotation;

/// Walk: the fastest the camera's yaw turns, rad/s (60°/s, a person looking around).
const WALK_MAX_YAW_RATE: f64 = PI / 3.0;
/// Rover: the camera sits this far ahead of the wheels' turning centre, metres, so an
/// in-place turn moves it on a small circle (as on a real robot base).
const ROVER_CAMERA_AHEAD: f64 = 0.10;
/// Rover: acceleration while driving, m/s², and while turning, rad/s².
const ROVER_ACCELERATION: f64 = 0.5;
const ROVER_ANGULAR_ACCELERATION: f64 = 2.0;
/// Walk and rover are integrated at this rate, Hz, and sampled from it.
const INTEGRATION_RATE: f64 = 600.0;

/// `count` poses of the configured motion at times `i / rate`, i = 0, 1, …
pub(super) fn trajectory(config: &SyntheticConfig, rate: f64, count: usize) -> Vec<Pose> {
    match config.motion {
        SyntheticMotion::Room => room_loop(config, rate, count),
        SyntheticMotion::Drive => drive(config, rate, count),
        SyntheticMotion::Walk => sample(&walk_track(config, duration(rate, count)), rate, count),
        SyntheticMotion::Rover => sample(&rover_track(config, duration(rate, count)), rate, count),
        SyntheticMotion::Slider => slider(config, rate, count),
    }
}

/// The slider: s(t) = L·(1 − cos(πt/T))/2 along the camera's x axis over the sequence's
/// length T (at the frame rate; any other rate samples the same curve), orientation fixed.
fn slider(config: &SyntheticConfig, rate: f64, count: usize) -> Vec<Pose> {
    let mut rng = Rng(config.seed.wrapping_mul(0xA24B_AED4_963E_E407) ^ 0x511D);
    let yaw = (rng.unit_f64() - 0.5) * 0.6;
    let point = TrackPoint {
        position: Vector3::zeros(),
        yaw,
        pitch: -0.1,
        roll: 0.0,
    };
    let orientation = orientation(&point);
    let along = rotation::matrix(&orientation) * Vector3::x();
    let length = config.amplitude;
    let span = (config.frames.saturating_sub(1) as f64 / config.fps).max(1e-9);
    let start = Vector3::new(
        -0.5 * length * along.x,
        config.room[1] - config.camera_height,
        1.0 - config.room[2],
    );
    (0..count)
        .map(|k| {
            let t = k as f64 / rate;
            let s = 0.5 * length * (1.0 - (PI * (t / span).min(1.0)).cos());
            Pose {
                timestamp: t,
                position: start + along * s,
                orientation,
            }
        })
        .collect()
}

fn duration(rate: f64, count: usize) -> f64 {
    count.saturating_sub(1) as f64 / rate + 2.0 / INTEGRATION_RATE
}

/// The hand-held loop: sway, yaw and pitch, starting at the origin looking along +z.
fn room_loop(config: &SyntheticConfig, rate: f64, count: usize) -> Vec<Pose> {
    let period = config.period;
    (0..count)
        .map(|k| {
            let t = k as f64 / rate;
            let phase = TAU * t / period;
            let a = config.amplitude;
            let position = Vector3::new(
                a * phase.sin(),
                0.15 * a * (2.0 * phase).sin(),
                0.6 * a * (1.0 - phase.cos()),
            );
            let orientation = rotation::from_rotation_vector(&Vector3::new(
                0.06 * (1.3 * phase).sin(),
                0.3 * phase.sin(),
                0.05 * (0.7 * phase).sin(),
            ));
            Pose {
                timestamp: t,
                position,
                orientation,
            }
        })
        .collect()
}

/// The drive: heading ψ(t) = amplitude · sin(2πt / period) about the vertical (y points
/// down), position integrated from the speed along the heading, starting 25 m into the box.
fn drive(config: &SyntheticConfig, rate: f64, count: usize) -> Vec<Pose> {
    let heading = |t: f64| config.amplitude * (TAU * t / config.period).sin();
    let height = config.room[1] - config.camera_height;
    let mut position = Vector3::new(0.0, height, 25.0 - config.room[2]);
    // 50 midpoint steps per frame at the frame rate, about as fine at any other rate.
    let substeps = ((50.0 * config.fps / rate).round() as usize).max(1);
    let dt = 1.0 / (rate * substeps as f64);
    let mut t = 0.0;
    let mut poses = Vec::with_capacity(count);
    for k in 0..count {
        if k > 0 {
            for _ in 0..substeps {
                let mid = t + 0.5 * dt;
                let psi = heading(mid);
                let speed = config.speed * (1.0 + 0.3 * (TAU * mid / (1.5 * config.period)).sin());
                position += Vector3::new(psi.sin(), 0.0, psi.cos()) * (speed * dt);
                t += dt;
            }
        }
        poses.push(Pose {
            timestamp: k as f64 / rate,
            position,
            orientation: rotation::from_rotation_vector(&Vector3::new(0.0, heading(t), 0.0)),
        });
    }
    poses
}

/// One sample of an integrated motion: the camera centre and its yaw (about the vertical,
/// from +z towards +x), pitch and roll, radians. Angles are kept unwrapped so that samples
/// interpolate.
#[derive(Clone, Copy)]
struct TrackPoint {
    position: Vector3<f64>,
    yaw: f64,
    pitch: f64,
    roll: f64,
}

/// R = R_y(yaw) · R_x(pitch) · R_z(roll): yaw 0 looks along +z, y points down.
fn orientation(p: &TrackPoint) -> rotation::Quat {
    let yaw = rotation::from_rotation_vector(&Vector3::new(0.0, p.yaw, 0.0));
    let pitch = rotation::from_rotation_vector(&Vector3::new(-p.pitch, 0.0, 0.0));
    let roll = rotation::from_rotation_vector(&Vector3::new(0.0, 0.0, p.roll));
    rotation::multiply(&yaw, &rotation::multiply(&pitch, &roll))
}

/// Poses at `i / rate` from a track integrated at [`INTEGRATION_RATE`], interpolated linearly.
fn sample(track: &[TrackPoint], rate: f64, count: usize) -> Vec<Pose> {
    (0..count)
        .map(|i| {
            let t = i as f64 / rate;
            let f = t * INTEGRATION_RATE;
            let j = (f.floor() as usize).min(track.len() - 2);
            let w = (f - j as f64).clamp(0.0, 1.0);
            let (a, b) = (&track[j], &track[j + 1]);
            let lerp = |x: f64, y: f64| x + (y - x) * w;
            let point = TrackPoint {
                position: a.position + (b.position - a.position) * w,
                yaw: lerp(a.yaw, b.yaw),
                pitch: lerp(a.pitch, b.pitch),
                roll: lerp(a.roll, b.roll),
            };
            Pose {
                timestamp: t,
                position: point.position,
                orientation: orientation(&point),
            }
        })
        .collect()
}

/// A closed walking route on the floor (x, z), parameterised by arc length.
pub(super) struct Route {
    points: Vec<Vector2<f64>>,
    cumulative: Vec<f64>,
}

impl Route {
    /// The walk's route: a loop through four seeded corners, one in each quarter of the room
    /// (so with two rooms it passes through the dividing wall twice), its corners rounded by
    /// four rounds of Chaikin's corner cutting.
    pub(super) fn walk(config: &SyntheticConfig) -> Self {
        let mut rng = Rng(config.seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x57A1);
        let [rx, _, rz] = config.room;
        let (a, b) = (0.5 * rx, 0.5 * rz);
        let mut jitter = |half: f64| (rng.unit_f64() - 0.5) * 0.6 * half;
        let clamp = |x: f64, limit: f64| x.clamp(-(limit - 0.8), limit - 0.8);
        let mut corners: Vec<Vector2<f64>> = [(-a, -b), (-a, b), (a, b), (a, -b)]
            .iter()
            .map(|&(x, z)| {
                let (jx, jz) = (jitter(a), jitter(b));
                Vector2::new(clamp(x + jx, rx), clamp(z + jz, rz))
            })
            .collect();
        if rng.next_u64() & 1 == 1 {
            corners.reverse();
        }
        let mut points = corners;
        for _ in 0..4 {
            let n = points.len();
            points = (0..n)
                .flat_map(|i| {
                    let (p, q) = (points[i], points[(i + 1) % n]);
                    [p * 0.75 + q * 0.25, p * 0.25 + q * 0.75]
                })
                .collect();
        }
        points.push(points[0]);
        let mut cumulative = vec![0.0];
        for w in points.windows(2) {
            let last = *cumulative.last().expect("starts with 0");
            cumulative.push(last + (w[1] - w[0]).norm());
        }
        Self { points, cumulative }
    }

    /// Total length, metres.
    pub(super) fn length(&self) -> f64 {
        *self.cumulative.last().expect("a route has points")
    }

    /// The point at arc length `s` (wrapping around the loop).
    pub(super) fn at(&self, s: f64) -> Vector2<f64> {
        let s = s.rem_euclid(self.length());
        let i = self
            .cumulative
            .partition_point(|&c| c <= s)
            .clamp(1, self.points.len() - 1);
        let (c0, c1) = (self.cumulative[i - 1], self.cumulative[i]);
        let w = if c1 > c0 { (s - c0) / (c1 - c0) } else { 0.0 };
        self.points[i - 1] + (self.points[i] - self.points[i - 1]) * w
    }

    /// Where the closed route crosses the plane z = `z`: the x of each crossing.
    pub(super) fn crossings(&self, z: f64) -> Vec<f64> {
        self.points
            .windows(2)
            .filter(|w| (w[0].y - z) * (w[1].y - z) < 0.0)
            .map(|w| w[0].x + (w[1].x - w[0].x) * (z - w[0].y) / (w[1].y - w[0].y))
            .collect()
    }

    /// Direction of travel at `s`, radians from +z towards +x, over a 0.5 m chord.
    fn heading(&self, s: f64) -> f64 {
        let d = self.at(s + 0.25) - self.at(s - 0.25);
        d.x.atan2(d.y)
    }
}

/// The walk, integrated: speed 0.3–1 m/s around `config.speed`, the route followed from a
/// seeded start, the yaw following the route plus a look-around of ±`config.amplitude`
/// radians over `config.period` seconds (rate-limited to 60°/s), pitch within ±20°, roll within
/// ±5°, and the step bounce (2 cm up and down at the step rate, 1.5 cm side to side).
fn walk_track(config: &SyntheticConfig, duration: f64) -> Vec<TrackPoint> {
    let route = Route::walk(config);
    let mut rng = Rng(config.seed.wrapping_mul(0x9E37_79B9) ^ 0x3A1C);
    let mut phase = || rng.unit_f64() * TAU;
    let phases: [f64; 8] = std::array::from_fn(|_| phase());
    let dt = 1.0 / INTEGRATION_RATE;
    let base_height = config.room[1] - config.camera_height;
    let mut s = phases[0] / TAU * route.length();
    let mut step = 0.0f64;
    let mut heading = route.heading(s);
    let look = |t: f64| {
        let slow = (TAU * t / config.period + phases[1]).sin();
        let fast = (TAU * t / (0.37 * config.period) + phases[2]).sin();
        config.amplitude * (0.75 * slow + 0.25 * fast)
    };
    let mut yaw = heading + look(0.0);
    let steps = (duration * INTEGRATION_RATE).ceil() as usize + 2;
    let mut track = Vec::with_capacity(steps);
    for i in 0..steps {
        let t = i as f64 * dt;
        let speed = (config.speed
            * (1.0
                + 0.35 * (TAU * t / 6.0 + phases[3]).sin()
                + 0.15 * (TAU * t / 2.3 + phases[4]).sin()))
        .clamp(0.3, 1.0);
        if i > 0 {
            s += speed * dt;
            step += TAU * (1.5 + 0.9 * (speed - 0.3) / 0.7) * dt;
            // Unwrapped: the heading's change, wrapped to (−π, π], added on.
            let h = route.heading(s);
            heading += (h - heading + PI).rem_euclid(TAU) - PI;
            let target = heading + look(t);
            let limit = WALK_MAX_YAW_RATE * dt;
            yaw += (target - yaw).clamp(-limit, limit);
        }
        let centre = route.at(s);
        let normal = Vector2::new(heading.cos(), -heading.sin());
        let sway = 0.015 * (0.5 * step).sin();
        let position = Vector3::new(
            centre.x + normal.x * sway,
            base_height - 0.02 * step.cos(),
            centre.y + normal.y * sway,
        );
        track.push(TrackPoint {
            position,
            yaw,
            pitch: 0.05
                + 0.17 * (TAU * t / 7.1 + phases[5]).sin()
                + 0.06 * (TAU * t / 2.7 + phases[6]).sin(),
            roll: 0.05 * (TAU * t / 4.3 + phases[7]).sin() + 0.02 * (0.5 * step).sin(),
        });
    }
    track
}

/// What a rover is doing.
enum Leg {
    Drive { remaining: f64 },
    Turn { remaining: f64 },
}

/// The rover, integrated: legs of straight driving at up to `config.speed` (accelerating and
/// braking at 0.5 m/s²) and turns in place at up to `config.amplitude` rad/s; the first turn
/// is a half turn, later ones ±90°, ±135° or 180°, chosen so the next leg has room. The camera
/// is `config.camera_height` above the floor, 0.1 m ahead of the turning centre, with a
/// small vibration.
fn rover_track(config: &SyntheticConfig, duration: f64) -> Vec<TrackPoint> {
    let mut rng = Rng(config.seed.wrapping_mul(0xD6E8_FEB8_6659_FD93) ^ 0x70E7);
    let [rx, ry, rz] = config.room;
    let margin = 0.7;
    // Distance from (x, z) along heading h to the edge of the drivable area.
    let free = |p: Vector2<f64>, h: f64| {
        let d = Vector2::new(h.sin(), h.cos());
        let reach = |pos: f64, dir: f64, limit: f64| {
            if dir.abs() < 1e-9 {
                f64::INFINITY
            } else {
                ((limit - margin) * dir.signum() - pos) / dir
            }
        };
        reach(p.x, d.x, rx).min(reach(p.y, d.y, rz)).max(0.0)
    };
    let mut centre = Vector2::new(
        (rng.unit_f64() - 0.5) * (rx - margin),
        (rng.unit_f64() - 0.5) * (rz - margin),
    );
    let mut heading = (0..8)
        .map(|k| k as f64 * TAU / 8.0)
        .max_by(|a, b| free(centre, *a).total_cmp(&free(centre, *b)))
        .expect("eight headings");
    let choose_length = |rng: &mut Rng, room: f64| (1.0 + 1.5 * rng.unit_f64()).min(room);
    let mut leg = Leg::Drive {
        remaining: choose_length(&mut rng, free(centre, heading)),
    };
    let mut turns = 0usize;
    let (mut speed, mut rate) = (0.0f64, 0.0f64);
    let dt = 1.0 / INTEGRATION_RATE;
    let steps = (duration * INTEGRATION_RATE).ceil() as usize + 2;
    let phases: [f64; 4] = std::array::from_fn(|_| rng.unit_f64() * TAU);
    let mut track = Vec::with_capacity(steps);
    for i in 0..steps {
        let t = i as f64 * dt;
        if i > 0 {
            match &mut leg {
                Leg::Drive { remaining } => {
                    speed = (speed + ROVER_ACCELERATION * dt)
                        .min(config.speed)
                        .min((2.0 * ROVER_ACCELERATION * *remaining).sqrt());
                    let step = (speed * dt).min(*remaining);
                    centre += Vector2::new(heading.sin(), heading.cos()) * step;
                    *remaining -= step;
                }
                Leg::Turn { remaining } => {
                    rate = (rate + ROVER_ANGULAR_ACCELERATION * dt)
                        .min(config.amplitude)
                        .min((2.0 * ROVER_ANGULAR_ACCELERATION * remaining.abs()).sqrt());
                    let step = (rate * dt).min(remaining.abs()) * remaining.signum();
                    heading += step;
                    *remaining -= step;
                }
            }
        }
        let done = match leg {
            Leg::Drive { remaining } | Leg::Turn { remaining } => remaining.abs() < 1e-6,
        };
        if done {
            leg = match leg {
                Leg::Drive { .. } => {
                    speed = 0.0;
                    turns += 1;
                    let options = [PI, -PI, 0.5 * PI, -0.5 * PI, 0.75 * PI, -0.75 * PI];
                    let pick = if turns == 1 {
                        (rng.next_u64() % 2) as usize
                    } else {
                        (rng.next_u64() % options.len() as u64) as usize
                    };
                    let turn = (0..options.len())
                        .map(|k| options[(pick + k) % options.len()])
                        .find(|&a| free(centre, heading + a) >= 1.0)
                        .unwrap_or(PI);
                    Leg::Turn { remaining: turn }
                }
                Leg::Turn { .. } => {
                    rate = 0.0;
                    Leg::Drive {
                        remaining: choose_length(&mut rng, free(centre, heading)),
                    }
                }
            };
        }
        let ahead = Vector2::new(heading.sin(), heading.cos()) * ROVER_CAMERA_AHEAD;
        track.push(TrackPoint {
            position: Vector3::new(
                centre.x + ahead.x,
                ry - config.camera_height,
                centre.y + ahead.y,
            ),
            yaw: heading,
            pitch: 0.004 * (TAU * 7.0 * t + phases[0]).sin()
                + 0.003 * (TAU * 11.3 * t + phases[1]).sin(),
            roll: 0.003 * (TAU * 5.3 * t + phases[2]).sin()
                + 0.002 * (TAU * 13.1 * t + phases[3]).sin(),
        });
    }
    track
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The camera's heading on the floor, from its optical axis.
    fn yaw(pose: &Pose) -> f64 {
        let forward = rotation::matrix(&pose.orientation) * Vector3::new(0.0, 0.0, 1.0);
        forward.x.atan2(forward.z)
    }

    /// Per frame: horizontal speed (m/s) and yaw rate (rad/s, wrapped).
    fn rates(poses: &[Pose]) -> Vec<(f64, f64)> {
        poses
            .windows(2)
            .map(|w| {
                let dt = w[1].timestamp - w[0].timestamp;
                let d = w[1].position - w[0].position;
                let turn = (yaw(&w[1]) - yaw(&w[0]) + PI).rem_euclid(TAU) - PI;
                ((d.x * d.x + d.z * d.z).sqrt() / dt, turn / dt)
            })
            .collect()
    }

    #[test]
    fn the_walk_moves_at_walking_pace_and_looks_around_within_its_bounds() {
        let config = SyntheticConfig::for_motion(SyntheticMotion::Walk);
        let poses = trajectory(&config, config.fps, config.frames);
        let rates = rates(&poses);
        for &(speed, _) in &rates {
            assert!((0.2..1.2).contains(&speed), "speed {speed}");
        }
        let path: f64 = poses
            .windows(2)
            .map(|w| (w[1].position - w[0].position).norm())
            .sum();
        assert!((5.0..15.0).contains(&path), "path {path} m");
        let fastest = rates.iter().map(|r| r.1.abs()).fold(0.0, f64::max);
        // 60°/s, and the pitch of the look-around bends the heading of the axis a little.
        assert!(
            fastest < 1.15 && fastest > 0.5,
            "fastest turn {fastest} rad/s"
        );
    }

    #[test]
    fn the_slider_moves_one_metre_sideways_without_turning() {
        let config = SyntheticConfig::for_motion(SyntheticMotion::Slider);
        let poses = trajectory(&config, config.fps, config.frames);
        let first = &poses[0];
        let last = poses.last().expect("poses");
        let travel = last.position - first.position;
        assert!((travel.norm() - config.amplitude).abs() < 1e-9, "{travel}");
        let sideways = rotation::matrix(&first.orientation) * Vector3::x();
        assert!(travel.normalize().dot(&sideways) > 1.0 - 1e-12);
        assert!(poses.iter().all(|p| p.orientation == first.orientation));
        // Starts and stops at rest.
        let step = |a: &Pose, b: &Pose| (b.position - a.position).norm();
        let middle = config.frames / 2;
        assert!(step(&poses[0], &poses[1]) < 0.05 * step(&poses[middle], &poses[middle + 1]));
    }

    #[test]
    fn the_rover_turns_in_place_by_half_a_turn() {
        let config = SyntheticConfig::for_motion(SyntheticMotion::Rover);
        let poses = trajectory(&config, config.fps, config.frames);
        // The largest turn made while the camera moves no faster than its offset from the
        // turning centre allows.
        let (mut turned, mut best) = (0.0f64, 0.0f64);
        for (speed, rate) in rates(&poses) {
            if speed <= 1.01 * ROVER_CAMERA_AHEAD * config.amplitude {
                turned += rate / config.fps;
                best = best.max(turned.abs());
            } else {
                turned = 0.0;
            }
        }
        assert!(best > 0.95 * PI, "longest in-place turn {best} rad");
        for p in &poses {
            assert!((p.position.y - (config.room[1] - 0.3)).abs() < 1e-9);
        }
    }

    #[test]
    fn the_rovers_sideways_motion_is_its_arm_swinging_as_the_wheeled_model_says() {
        // At 600 Hz, so that a step's chord is its velocity: the sideways velocity in the
        // camera frame is d·ω_y (`slam::motion::constraint`'s first row) with d the arm.
        let config = SyntheticConfig::for_motion(SyntheticMotion::Rover);
        let poses = trajectory(&config, INTEGRATION_RATE, 20 * config.frames);
        let (mut sideways, mut unexplained) = (0.0, 0.0);
        for w in poses.windows(2) {
            let dt = w[1].timestamp - w[0].timestamp;
            let step = crate::slam::motion::relative_motion(
                &w[0].position,
                &w[0].orientation,
                &w[1].position,
                &w[1].orientation,
            );
            let (u, omega) = (step.translation / dt, step.rotation / dt);
            sideways += u.x.abs();
            unexplained += (u.x - ROVER_CAMERA_AHEAD * omega.y).abs();
        }
        assert!(sideways > 1.0, "the rover never turns ({sideways})");
        assert!(unexplained < 0.05 * sideways, "{unexplained} of {sideways}");
    }
}
