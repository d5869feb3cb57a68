//! The 2D world of the navigation simulator: a rectangular arena with walls, circular and
//! polygonal obstacles — some of them invisible to the LIDAR (below its scan plane, or glass)
//! but seen by the camera — a start pose, a goal, and the geometry every sensor and the
//! collision test need: exact ray casting and exact disc–obstacle distances.

use std::path::Path;

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, Error, Result};
use crate::rng::Rng;

/// An obstacle's footprint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// A disc.
    Circle {
        /// Centre (x, y), metres.
        center: [f32; 2],
        /// Radius, metres.
        radius: f32,
    },
    /// A convex or concave simple polygon, vertices in order.
    Polygon {
        /// Vertices (x, y), metres.
        points: Vec<[f32; 2]>,
    },
}

/// One obstacle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Obstacle {
    /// Footprint.
    pub shape: Shape,
    /// Height above the floor, metres: obstacles lower than the LIDAR's scan plane are not
    /// seen by it. Default 1.0.
    #[serde(default = "default_height")]
    pub height: f32,
    /// Transparent to the LIDAR (glass) whatever its height. Default false.
    #[serde(default)]
    pub transparent: bool,
}

fn default_height() -> f32 {
    1.0
}

/// A world, as read from TOML.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    /// Arena size (width, depth), metres; walls enclose [0, w] × [0, d].
    pub size: [f32; 2],
    /// Start pose (x, y, heading in degrees).
    pub start: [f32; 3],
    /// Goal (x, y).
    pub goal: [f32; 2],
    /// Robot radius, metres. Default 0.2.
    #[serde(default = "default_radius")]
    pub robot_radius: f32,
    /// Height of the LIDAR's scan plane, metres. Default 0.4.
    #[serde(default = "default_scan_height")]
    pub scan_height: f32,
    /// Obstacles.
    #[serde(default)]
    pub obstacles: Vec<Obstacle>,
}

fn default_radius() -> f32 {
    0.2
}

fn default_scan_height() -> f32 {
    0.4
}

/// What a ray hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray, metres.
    pub distance: f32,
    /// Index of the obstacle, or `None` for the arena wall.
    pub obstacle: Option<usize>,
    /// Position along the hit surface (for texturing), metres.
    pub surface: f32,
}

impl World {
    /// Reads and validates a world TOML file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = crate::error::read_input(path)?;
        let world: World = toml::from_str(&text).map_err(|e| Error::ConfigFile {
            path: path.to_path_buf(),
            source: Box::new(ConfigError::from_toml(&text, e)),
        })?;
        world.validate().map_err(|e| Error::ConfigFile {
            path: path.to_path_buf(),
            source: Box::new(ConfigError::invalid("world", e)),
        })?;
        Ok(world)
    }

    /// Checks sizes, finiteness, and that start and goal are free and inside the arena.
    pub fn validate(&self) -> Result<()> {
        let all_finite = self
            .size
            .iter()
            .chain(&self.start)
            .chain(&self.goal)
            .all(|v| v.is_finite());
        if !all_finite || self.size[0] <= 0.0 || self.size[1] <= 0.0 {
            return Err(Error::config(
                "world.size",
                format!("{:?}", self.size),
                "must be finite and > 0 (start and goal finite too)",
            ));
        }
        if !(self.scan_height.is_finite() && self.scan_height > 0.0) {
            return Err(Error::config(
                "world.scan_height",
                self.scan_height,
                "must be finite and > 0 (the LIDAR sees obstacles taller than it)",
            ));
        }
        if !(self.robot_radius.is_finite() && self.robot_radius > 0.0) {
            return Err(Error::config(
                "world.robot_radius",
                self.robot_radius,
                "must be finite and > 0",
            ));
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            let ok = match &o.shape {
                Shape::Circle { center, radius } => {
                    center.iter().all(|v| v.is_finite()) && radius.is_finite() && *radius > 0.0
                }
                Shape::Polygon { points } => {
                    points.len() >= 3 && points.iter().flatten().all(|v| v.is_finite())
                }
            };
            if !ok || !o.height.is_finite() || o.height <= 0.0 {
                return Err(Error::config("world.obstacles", i, "a circle needs a finite centre and radius > 0, a polygon 3+ finite points, and height > 0"));
            }
        }
        for (name, p) in [
            ("world.start", [self.start[0], self.start[1]]),
            ("world.goal", self.goal),
        ] {
            if self.clearance(p) < self.robot_radius {
                return Err(Error::config(
                    name,
                    format!("{p:?}"),
                    "must lie inside the arena, clear of obstacles by the robot radius",
                ));
            }
        }
        Ok(())
    }

    /// True when obstacle `i` shows in the LIDAR's scan plane.
    pub fn lidar_sees(&self, i: usize) -> bool {
        let o = &self.obstacles[i];
        !o.transparent && o.height > self.scan_height
    }

    /// Distance from point `p` to the nearest obstacle surface or wall (negative inside one).
    pub fn clearance(&self, p: [f32; 2]) -> f32 {
        let walls = p[0]
            .min(p[1])
            .min(self.size[0] - p[0])
            .min(self.size[1] - p[1]);
        self.obstacles
            .iter()
            .map(|o| signed_distance(&o.shape, p))
            .fold(walls, f32::min)
    }

    /// True when a robot disc centred at `p` touches any obstacle or wall (every obstacle is
    /// solid, whatever the LIDAR sees).
    pub fn collides(&self, p: [f32; 2]) -> bool {
        self.clearance(p) < self.robot_radius
    }

    /// The first surface along the ray from `origin` in direction `angle` (radians), within
    /// `max_range`; `lidar_only` skips what the LIDAR cannot see.
    pub fn cast(
        &self,
        origin: [f32; 2],
        angle: f32,
        max_range: f32,
        lidar_only: bool,
    ) -> Option<Hit> {
        self.cast_all(origin, angle, max_range, lidar_only)
            .into_iter()
            .next()
    }

    /// Every surface along the ray, nearest first (the camera draws low obstacles in front of
    /// what stands behind them).
    pub fn cast_all(
        &self,
        origin: [f32; 2],
        angle: f32,
        max_range: f32,
        lidar_only: bool,
    ) -> Vec<Hit> {
        let d = Vec2::new(angle.cos(), angle.sin());
        let (o, size) = (Vec2::from(origin), Vec2::from(self.size));
        let mut hits = Vec::new();
        // Arena walls: the ray leaves the box once.
        let mut t_wall = f32::INFINITY;
        let mut surface = 0.0;
        for axis in 0..2 {
            if d[axis].abs() < 1e-9 {
                continue;
            }
            let bound = if d[axis] > 0.0 { size[axis] } else { 0.0 };
            let t = (bound - o[axis]) / d[axis];
            if t >= 0.0 && t < t_wall {
                t_wall = t;
                surface = o[1 - axis] + t * d[1 - axis];
            }
        }
        if t_wall <= max_range {
            hits.push(Hit {
                distance: t_wall,
                obstacle: None,
                surface,
            });
        }
        for (i, obstacle) in self.obstacles.iter().enumerate() {
            if lidar_only && !self.lidar_sees(i) {
                continue;
            }
            if let Some((t, s)) = ray_shape(&obstacle.shape, o, d) {
                if t <= max_range {
                    hits.push(Hit {
                        distance: t,
                        obstacle: Some(i),
                        surface: s,
                    });
                }
            }
        }
        hits.sort_by(|a, b| a.distance.total_cmp(&b.distance));
        hits
    }

    /// Adds a visible pillar (radius 0.3–0.45 m) 1.1–1.6 m before the goal along the line from
    /// the start, 0.35–0.6 m to one side of it, so the goal's bearing swings by tens of degrees
    /// per second in the last metres: the case where a controller whose chosen heading lags
    /// the target passes the goal and drives on.
    pub fn guard_goal(&mut self, seed: u64) {
        let mut rng = Rng(seed ^ 0x6a09_e667_f3bc_c908);
        let (gx, gy) = (self.goal[0], self.goal[1]);
        let (dx, dy) = (self.start[0] - gx, self.start[1] - gy);
        let len = dx.hypot(dy).max(1e-6);
        let (ux, uy) = (dx / len, dy / len);
        let back = rng.range(1.1, 1.6).min(0.8 * len);
        let side = rng.range(0.35, 0.6) * if rng.unit() < 0.5 { -1.0 } else { 1.0 };
        self.obstacles.push(Obstacle {
            shape: Shape::Circle {
                center: [gx + back * ux - side * uy, gy + back * uy + side * ux],
                radius: rng.range(0.3, 0.45),
            },
            height: 1.0,
            transparent: false,
        });
    }

    /// A seeded random world: `count` obstacles (discs and boxes) scattered between start and
    /// goal, a fraction `invisible` of them lower than the LIDAR's scan plane; start and goal
    /// kept clear.
    pub fn random(seed: u64, count: usize, invisible: f32) -> Self {
        let mut rng = Rng(seed);
        let size = [8.0f32, 8.0];
        let start = [1.0, rng.range(1.0, 7.0), 0.0];
        let goal = [7.0, rng.range(1.0, 7.0)];
        let mut world = World {
            size,
            start,
            goal,
            robot_radius: 0.2,
            scan_height: 0.4,
            obstacles: Vec::new(),
        };
        let mut attempts = 0;
        while world.obstacles.len() < count && attempts < 1000 {
            attempts += 1;
            let c = [rng.range(1.8, 6.2), rng.range(0.6, 7.4)];
            let low = rng.unit() < invisible;
            let height = if low { 0.25 } else { 1.0 };
            let shape = if rng.unit() < 0.5 {
                Shape::Circle {
                    center: c,
                    radius: rng.range(0.2, 0.55),
                }
            } else {
                let (hw, hh) = (rng.range(0.15, 0.5), rng.range(0.15, 0.5));
                let a = rng.range(0.0, std::f32::consts::PI);
                let (s, co) = a.sin_cos();
                let corner = |x: f32, y: f32| [c[0] + co * x - s * y, c[1] + s * x + co * y];
                Shape::Polygon {
                    points: vec![
                        corner(-hw, -hh),
                        corner(hw, -hh),
                        corner(hw, hh),
                        corner(-hw, hh),
                    ],
                }
            };
            let candidate = Obstacle {
                shape,
                height,
                transparent: false,
            };
            let keep_clear = |p: [f32; 2]| signed_distance(&candidate.shape, p) > 0.6;
            if keep_clear([start[0], start[1]]) && keep_clear(goal) {
                world.obstacles.push(candidate);
            }
        }
        world
    }
}

/// Length of a vector as `hypot` gives it (no overflow or underflow of the squares, and the
/// same figures as before the simulator's geometry moved to glam).
pub(crate) fn length(v: Vec2) -> f32 {
    v.x.hypot(v.y)
}

/// Signed distance from `p` to a shape's boundary (negative inside).
pub fn signed_distance(shape: &Shape, p: [f32; 2]) -> f32 {
    let p = Vec2::from(p);
    match shape {
        Shape::Circle { center, radius } => length(p - Vec2::from(*center)) - radius,
        Shape::Polygon { points } => {
            let mut best = f32::INFINITY;
            let mut inside = false;
            for k in 0..points.len() {
                let a = Vec2::from(points[k]);
                let b = Vec2::from(points[(k + 1) % points.len()]);
                best = best.min(segment_distance(p, a, b));
                // Even-odd rule along the ray to +x.
                if (a.y > p.y) != (b.y > p.y) {
                    let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
                    if p.x < x {
                        inside = !inside;
                    }
                }
            }
            if inside {
                -best
            } else {
                best
            }
        }
    }
}

/// Distance from `p` to the segment from `a` to `b`.
pub(crate) fn segment_distance(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let (ab, ap) = (b - a, p - a);
    let len2 = ab.dot(ab);
    let t = if len2 > 0.0 {
        (ap.dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    length(ap - ab * t)
}

/// Nearest non-negative intersection of a ray from `o` along the unit vector `d` with a
/// shape: (distance, surface coordinate).
fn ray_shape(shape: &Shape, o: Vec2, d: Vec2) -> Option<(f32, f32)> {
    match shape {
        Shape::Circle { center, radius } => {
            let oc = o - Vec2::from(*center);
            let b = oc.dot(d);
            let c = oc.dot(oc) - radius * radius;
            let disc = b * b - c;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            let t = if -b - sq >= 0.0 { -b - sq } else { -b + sq };
            if t < 0.0 {
                return None;
            }
            let hit = oc + d * t;
            Some((t, hit.y.atan2(hit.x) * radius))
        }
        Shape::Polygon { points } => {
            let mut best: Option<(f32, f32)> = None;
            let mut along = 0.0;
            for k in 0..points.len() {
                let a = Vec2::from(points[k]);
                let b = Vec2::from(points[(k + 1) % points.len()]);
                let e = b - a;
                let len = length(e);
                let denom = d.perp_dot(e);
                if denom.abs() > 1e-9 {
                    let w = a - o;
                    let t = w.perp_dot(e) / denom;
                    let s = w.perp_dot(d) / denom;
                    if t >= 0.0 && (0.0..=1.0).contains(&s) && best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, along + s * len));
                    }
                }
                along += len;
            }
            best
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn world() -> World {
        World {
            size: [10.0, 6.0],
            start: [1.0, 3.0, 0.0],
            goal: [9.0, 3.0],
            robot_radius: 0.2,
            scan_height: 0.4,
            obstacles: vec![
                Obstacle {
                    shape: Shape::Circle {
                        center: [5.0, 3.0],
                        radius: 1.0,
                    },
                    height: 1.0,
                    transparent: false,
                },
                Obstacle {
                    shape: Shape::Polygon {
                        points: vec![[2.0, 0.5], [3.0, 0.5], [3.0, 1.5], [2.0, 1.5]],
                    },
                    height: 0.2,
                    transparent: false,
                },
            ],
        }
    }

    #[test]
    fn rays_hit_what_the_sensor_can_see() {
        let w = world();
        let hit = w.cast([1.0, 3.0], 0.0, 20.0, true).unwrap();
        assert!((hit.distance - 3.0).abs() < 1e-5 && hit.obstacle == Some(0));
        // The low box is invisible to the LIDAR: the ray reaches the wall behind it.
        let a = (1.0f32 - 3.0).atan2(2.5 - 1.0);
        let lidar = w.cast([1.0, 3.0], a, 20.0, true).unwrap();
        let camera = w.cast([1.0, 3.0], a, 20.0, false).unwrap();
        assert_eq!(camera.obstacle, Some(1));
        assert!(lidar.obstacle.is_none() && lidar.distance > camera.distance);
        assert!(
            w.cast([1.0, 3.0], 0.0, 2.0, true).is_none(),
            "beyond the range"
        );
    }

    #[test]
    fn collisions_are_exact() {
        let w = world();
        assert!(!w.collides([3.79, 3.0]));
        assert!(w.collides([3.81, 3.0]));
        assert!(w.collides([2.5, 1.0]), "inside the low box");
        assert!(w.collides([2.5, 1.69]) && !w.collides([2.5, 1.71]));
        assert!(w.collides([0.1, 3.0]), "the wall");
    }

    #[test]
    fn random_worlds_are_valid_and_seeded() {
        for seed in 0..20 {
            let w = World::random(seed, 8, 0.4);
            w.validate().unwrap();
            assert_eq!(w, World::random(seed, 8, 0.4));
        }
    }
}
