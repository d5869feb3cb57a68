//! The generated world and its ray casting: a box whose six walls carry seeded procedural
//! textures ([`crate::synth::textured_scene`]), an optional dividing wall with a door wherever
//! the walk's route crosses it, and furniture-like clutter — boxes (some stacked), pillars,
//! tables and shelves standing 0.5 m or more from the camera's path, occluding each other and
//! the walls, textured with seeded contrast or left plain (textureless), shaded by the
//! direction they face so that plain faces still meet at edges.

use nalgebra::{Vector2, Vector3};
use rayon::prelude::*;

use super::SyntheticConfig;
use crate::image::Frame;
use crate::rng::Rng;

/// The dividing wall's thickness, metres, and its doors' width and height.
const DIVIDER_THICKNESS: f64 = 0.1;
const DOOR_WIDTH: f64 = 1.1;
const DOOR_HEIGHT: f64 = 2.0;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    min: Vector3<f64>,
    max: Vector3<f64>,
}

impl Aabb {
    fn new(min: [f64; 3], max: [f64; 3]) -> Self {
        Self {
            min: Vector3::from(min),
            max: Vector3::from(max),
        }
    }

    /// The smallest box holding all of `parts`.
    fn around(parts: &[Aabb]) -> Self {
        let mut out = parts[0];
        for p in &parts[1..] {
            out.min = out.min.inf(&p.min);
            out.max = out.max.sup(&p.max);
        }
        out
    }

    /// Where a ray from outside first enters the box, nearer than `limit`: the distance and
    /// the axis of the face it enters through (the slab test).
    fn hit(&self, origin: &Vector3<f64>, dir: &Vector3<f64>, limit: f64) -> Option<(f64, usize)> {
        let (mut near, mut far, mut axis) = (0.0f64, limit, 0usize);
        for a in 0..3 {
            if dir[a].abs() < 1e-12 {
                if origin[a] < self.min[a] || origin[a] > self.max[a] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / dir[a];
            let (mut t0, mut t1) = (
                (self.min[a] - origin[a]) * inv,
                (self.max[a] - origin[a]) * inv,
            );
            if t0 > t1 {
                std::mem::swap(&mut t0, &mut t1);
            }
            if t0 > near {
                near = t0;
                axis = a;
            }
            far = far.min(t1);
            if near > far {
                return None;
            }
        }
        (near > 0.0).then_some((near, axis))
    }

    /// Whether the floor footprints (x, z) of the two boxes, the first grown by `margin`,
    /// overlap.
    fn footprint_overlaps(&self, other: &Aabb, margin: f64) -> bool {
        self.min.x - margin < other.max.x
            && other.min.x < self.max.x + margin
            && self.min.z - margin < other.max.z
            && other.min.z < self.max.z + margin
    }
}

/// How a solid looks.
enum Material {
    /// A seeded texture, wrapped, its contrast scaled about a seeded mean level.
    Texture {
        texels: Frame,
        contrast: f64,
        mean: f64,
    },
    /// One colour: a textureless surface.
    Plain([f64; 3]),
}

/// One piece of furniture (or the dividing wall): boxes sharing a material.
struct Solid {
    bounds: Aabb,
    parts: Vec<Aabb>,
    material: Material,
    /// How far other furniture keeps from it on the floor, metres.
    keep_off: f64,
}

/// The world a synthetic camera looks at.
pub(super) struct Scene {
    room: [f64; 3],
    texels_per_metre: f64,
    walls: Vec<Frame>,
    solids: Vec<Solid>,
}

impl Scene {
    /// The box, its walls' textures, the dividing wall (with a door at each x in `doors`) when
    /// the configuration has two rooms, and `config.clutter` pieces of furniture kept at least
    /// `clearance` metres (on the floor) from every point of `path`.
    pub(super) fn build(
        config: &SyntheticConfig,
        path: &[Vector3<f64>],
        doors: &[f64],
        clearance: f64,
    ) -> Self {
        let walls = (0..6u64)
            .into_par_iter()
            .map(|i| {
                let [rx, ry, rz] = config.room;
                let (a, b) = match i / 2 {
                    0 => (ry, rz),
                    1 => (rx, rz),
                    _ => (rx, ry),
                };
                let w = ((2.0 * a * config.texels_per_metre) as u32).clamp(16, 4096);
                let h = ((2.0 * b * config.texels_per_metre) as u32).clamp(16, 4096);
                tiled_texture(w, h, config.seed.wrapping_mul(31).wrapping_add(i))
            })
            .collect();
        let mut solids = Vec::new();
        if config.rooms == 2 {
            solids.push(divider(config, doors));
        }
        furnish(config, path, clearance, &mut solids);
        Self {
            room: config.room,
            texels_per_metre: config.texels_per_metre,
            walls,
            solids,
        }
    }

    /// Number of pieces of furniture and dividing walls.
    pub(super) fn solid_count(&self) -> usize {
        self.solids.len()
    }

    /// Distance along `dir` (a unit vector) from `origin` to the first surface.
    pub(super) fn depth(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> f64 {
        let (t, _) = self.wall_hit(origin, dir);
        self.solid_hit(origin, dir, t).map_or(t, |(t, _, _)| t)
    }

    /// The nearest wall along `dir`: distance and face (2 · axis + 1 for the far side).
    fn wall_hit(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> (f64, usize) {
        let mut best = (f64::INFINITY, 0usize);
        for axis in 0..3 {
            if dir[axis].abs() < 1e-12 {
                continue;
            }
            let bound = self.room[axis] * dir[axis].signum();
            let t = (bound - origin[axis]) / dir[axis];
            if t > 0.0 && t < best.0 {
                best = (t, 2 * axis + usize::from(dir[axis] > 0.0));
            }
        }
        best
    }

    /// The nearest piece of furniture along `dir` nearer than `limit`: distance, the axis of
    /// the face hit, and the piece.
    fn solid_hit(
        &self,
        origin: &Vector3<f64>,
        dir: &Vector3<f64>,
        mut limit: f64,
    ) -> Option<(f64, usize, &Solid)> {
        let mut nearest = None;
        for solid in &self.solids {
            if solid.bounds.hit(origin, dir, limit).is_none() {
                continue;
            }
            for part in &solid.parts {
                if let Some((t, axis)) = part.hit(origin, dir, limit) {
                    limit = t;
                    nearest = Some((t, axis, solid));
                }
            }
        }
        nearest
    }

    /// Colour seen from `origin` along `dir` inside the room.
    pub(super) fn shade(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> [f64; 3] {
        let best = self.wall_hit(origin, dir);
        if let Some((t, axis, solid)) = self.solid_hit(origin, dir, best.0) {
            return self.shade_solid(solid, &(origin + dir * t), axis, dir[axis] > 0.0);
        }
        let room = self.room;
        let (t, face) = best;
        let hit = origin + dir * t;
        let (u_axis, v_axis) = face_axes(face / 2);
        let wall = &self.walls[face];
        let u = (hit[u_axis] + room[u_axis]) * self.texels_per_metre;
        let v = (hit[v_axis] + room[v_axis]) * self.texels_per_metre;
        bilinear(wall, u, v, false)
    }

    fn shade_solid(&self, solid: &Solid, hit: &Vector3<f64>, axis: usize, along: bool) -> [f64; 3] {
        // y points down: a ray going down (+y) lands on a top face, lit most.
        let light = match (axis, along) {
            (1, true) => 1.0,
            (1, false) => 0.5,
            (0, true) => 0.8,
            (0, false) => 0.65,
            (_, true) => 0.9,
            (_, false) => 0.72,
        };
        let colour = match &solid.material {
            Material::Plain(c) => *c,
            Material::Texture {
                texels,
                contrast,
                mean,
            } => {
                let (u_axis, v_axis) = face_axes(axis);
                // An offset keeps the coordinates positive before the wrap.
                let u = (hit[u_axis] + 1000.0) * self.texels_per_metre;
                let v = (hit[v_axis] + 1000.0) * self.texels_per_metre;
                bilinear(texels, u, v, true).map(|c| mean + contrast * (c - 128.0))
            }
        };
        colour.map(|c| (c * light).clamp(0.0, 255.0))
    }
}

/// The two axes spanning a face whose normal is `axis`.
fn face_axes(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// A wall across the room at z = 0, floor to ceiling, with a door (1.1 m × 2 m) at each x
/// of `doors`.
fn divider(config: &SyntheticConfig, doors: &[f64]) -> Solid {
    let [rx, ry, _] = config.room;
    let (z0, z1) = (-0.5 * DIVIDER_THICKNESS, 0.5 * DIVIDER_THICKNESS);
    let mut gaps: Vec<(f64, f64)> = doors
        .iter()
        .map(|&x| {
            (
                (x - 0.5 * DOOR_WIDTH).max(-rx),
                (x + 0.5 * DOOR_WIDTH).min(rx),
            )
        })
        .collect();
    gaps.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut parts = Vec::new();
    let mut x = -rx;
    let lintel = (ry - DOOR_HEIGHT).max(-ry);
    for &(a, b) in &gaps {
        if a > x {
            parts.push(Aabb::new([x, -ry, z0], [a, ry, z1]));
        }
        if lintel > -ry {
            parts.push(Aabb::new([a, -ry, z0], [b, lintel, z1]));
        }
        x = x.max(b);
    }
    if x < rx {
        parts.push(Aabb::new([x, -ry, z0], [rx, ry, z1]));
    }
    let size = (2.0 * rx.max(ry) * config.texels_per_metre).clamp(32.0, 1024.0) as u32;
    Solid {
        bounds: Aabb::around(&parts),
        parts,
        material: Material::Texture {
            texels: tiled_texture(size, size, config.seed.wrapping_mul(977).wrapping_add(17)),
            contrast: 0.8,
            mean: 128.0,
        },
        // Furniture keeps clear of the doors.
        keep_off: 0.6,
    }
}

/// Places `config.clutter` pieces of furniture, each tried up to 200 times at seeded places
/// until it keeps `clearance` from the path, 0.1 m from the other pieces and 0.6 m from the
/// dividing wall.
fn furnish(
    config: &SyntheticConfig,
    path: &[Vector3<f64>],
    clearance: f64,
    solids: &mut Vec<Solid>,
) {
    let mut rng = Rng(config.seed.wrapping_mul(0xA076_1D64_78BD_642F) ^ 0xC1u64);
    let [rx, ry, rz] = config.room;
    let floor: Vec<Vector2<f64>> = path.iter().map(|p| Vector2::new(p.x, p.z)).collect();
    let mut placed = 0;
    while placed < config.clutter {
        let seed = rng.next_u64();
        let mut found = None;
        for _ in 0..200 {
            let parts = furniture(&mut rng, config.room);
            let bounds = Aabb::around(&parts);
            let inside = bounds.min.x >= -rx
                && bounds.max.x <= rx
                && bounds.min.z >= -rz
                && bounds.max.z <= rz
                && bounds.min.y >= -ry;
            let clear_of_path = floor.iter().all(|p| {
                p.x < bounds.min.x - clearance
                    || p.x > bounds.max.x + clearance
                    || p.y < bounds.min.z - clearance
                    || p.y > bounds.max.z + clearance
            });
            let clear_of_others = solids
                .iter()
                .all(|s| !bounds.footprint_overlaps(&s.bounds, s.keep_off));
            if inside && clear_of_path && clear_of_others {
                found = Some((bounds, parts));
                break;
            }
        }
        let Some((bounds, parts)) = found else {
            log::warn!(
                "synthetic: room for {placed} of {} pieces of furniture away from the path",
                config.clutter
            );
            break;
        };
        let mut look = Rng(seed);
        let material = if look.unit_f64() < config.plain_fraction {
            Material::Plain([
                40.0 + 190.0 * look.unit_f64(),
                40.0 + 190.0 * look.unit_f64(),
                40.0 + 190.0 * look.unit_f64(),
            ])
        } else {
            let extent = (bounds.max - bounds.min).max();
            let size = (extent * config.texels_per_metre).clamp(32.0, 512.0) as u32;
            Material::Texture {
                texels: tiled_texture(size, size, look.next_u64()),
                contrast: 0.2 + 0.8 * look.unit_f64(),
                mean: 70.0 + 120.0 * look.unit_f64(),
            }
        };
        solids.push(Solid {
            bounds,
            parts,
            material,
            keep_off: 0.1,
        });
        placed += 1;
    }
}

/// One seeded piece of furniture standing on the floor (y = room[1], y points down): a box
/// (sometimes with a smaller one on top), a pillar to the ceiling, a table on four legs, or a
/// shelf with its back to a wall.
fn furniture(rng: &mut Rng, room: [f64; 3]) -> Vec<Aabb> {
    let [rx, ry, rz] = room;
    let mut u = |a: f64, b: f64| a + (b - a) * rng.unit_f64();
    let kind = u(0.0, 1.0);
    let (x, z) = (u(-rx, rx), u(-rz, rz));
    let floor = ry;
    if kind < 0.35 {
        let (w, d, h) = (u(0.3, 1.0), u(0.3, 1.0), u(0.3, 1.2).min(2.0 * ry - 0.1));
        let mut parts = vec![Aabb::new([x, floor - h, z], [x + w, floor, z + d])];
        if u(0.0, 1.0) < 0.3 {
            let (w2, d2, h2) = (w * u(0.4, 0.8), d * u(0.4, 0.8), u(0.2, 0.5));
            let (x2, z2) = (x + u(0.0, w - w2), z + u(0.0, d - d2));
            let top = (floor - h - h2).max(-ry);
            parts.push(Aabb::new([x2, top, z2], [x2 + w2, floor - h, z2 + d2]));
        }
        parts
    } else if kind < 0.5 {
        let side = u(0.25, 0.4);
        vec![Aabb::new([x, -ry, z], [x + side, floor, z + side])]
    } else if kind < 0.75 {
        let (w, d, h) = (u(0.8, 1.6), u(0.6, 0.9), u(0.72, 0.78).min(2.0 * ry - 0.1));
        let (leg, inset, top) = (0.05, 0.04, 0.04);
        let mut parts = vec![Aabb::new(
            [x, floor - h, z],
            [x + w, floor - h + top, z + d],
        )];
        for (lx, lz) in [
            (x + inset, z + inset),
            (x + w - inset - leg, z + inset),
            (x + inset, z + d - inset - leg),
            (x + w - inset - leg, z + d - inset - leg),
        ] {
            parts.push(Aabb::new(
                [lx, floor - h + top, lz],
                [lx + leg, floor, lz + leg],
            ));
        }
        parts
    } else {
        let (w, d, h) = (u(0.8, 1.4), u(0.3, 0.4), u(1.2, 2.0).min(2.0 * ry - 0.1));
        let wall = (u(0.0, 4.0) as usize).min(3);
        shelf(wall, (x, z), (w, d, h), room)
    }
}

/// A shelf against wall `wall` (0: −x, 1: +x, 2: −z, 3: +z) at `along` on that wall: two
/// sides, a back, a top and boards, open towards the room.
fn shelf(wall: usize, along: (f64, f64), (w, d, h): (f64, f64, f64), room: [f64; 3]) -> Vec<Aabb> {
    let [rx, ry, rz] = room;
    let floor = ry;
    // Local frame: `a` along the wall, `b` away from it (0 at the wall).
    let (t_side, t_back, t_board) = (0.03, 0.02, 0.025);
    let mut local: Vec<([f64; 3], [f64; 3])> = vec![
        ([0.0, floor - h, 0.0], [t_side, floor, d]),
        ([w - t_side, floor - h, 0.0], [w, floor, d]),
        ([0.0, floor - h, 0.0], [w, floor, t_back]),
    ];
    let boards = ((h / 0.4) as usize).max(2);
    for k in 0..=boards {
        let y = floor - h + (h - t_board) * k as f64 / boards as f64;
        local.push(([0.0, y, 0.0], [w, y + t_board, d]));
    }
    let place = |(a, y, b): (f64, f64, f64)| -> [f64; 3] {
        match wall {
            0 => [-rx + b, y, along.1 + a],
            1 => [rx - b, y, along.1 + a],
            2 => [along.0 + a, y, -rz + b],
            _ => [along.0 + a, y, rz - b],
        }
    };
    local
        .into_iter()
        .map(|(lo, hi)| {
            let (p, q) = (place((lo[0], lo[1], lo[2])), place((hi[0], hi[1], hi[2])));
            Aabb::new(
                [p[0].min(q[0]), p[1].min(q[1]), p[2].min(q[2])],
                [p[0].max(q[0]), p[1].max(q[1]), p[2].max(q[2])],
            )
        })
        .collect()
}

/// A texture made of independently seeded 256×256 scenes: the cost of
/// [`crate::synth::textured_scene`] grows with the square of the area (more shapes, each tested
/// at every pixel), while tiles keep it linear and never repeat a pattern.
fn tiled_texture(width: u32, height: u32, seed: u64) -> Frame {
    const TILE: u32 = 256;
    let (tx, ty) = (width.div_ceil(TILE), height.div_ceil(TILE));
    let tiles: Vec<Frame> = (0..tx * ty)
        .into_par_iter()
        .map(|i| {
            crate::synth::textured_scene(
                TILE,
                TILE,
                seed.wrapping_mul(1_000_003).wrapping_add(i as u64),
            )
        })
        .collect();
    let (w, h) = (width as usize, height as usize);
    let mut rgb = vec![0u8; 3 * w * h];
    for y in 0..h {
        for x in 0..w {
            let tile = &tiles[(y / TILE as usize) * tx as usize + x / TILE as usize];
            let o = 3 * ((y % TILE as usize) * TILE as usize + x % TILE as usize);
            rgb[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&tile.rgb[o..o + 3]);
        }
    }
    Frame::from_rgb(width, height, rgb).expect("texture sizes are small and positive")
}

/// Bilinear colour at texel (u, v), clamped to the edges or wrapped around them.
fn bilinear(frame: &Frame, u: f64, v: f64, wrap: bool) -> [f64; 3] {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let (u, v) = if wrap {
        (u.rem_euclid(w as f64), v.rem_euclid(h as f64))
    } else {
        (u.clamp(0.0, (w - 1) as f64), v.clamp(0.0, (h - 1) as f64))
    };
    let (x0, y0) = (
        (u.floor() as usize).min(w - 1),
        (v.floor() as usize).min(h - 1),
    );
    let (x1, y1) = if wrap {
        ((x0 + 1) % w, (y0 + 1) % h)
    } else {
        ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1))
    };
    let (fx, fy) = (u - x0 as f64, v - y0 as f64);
    let px = |x: usize, y: usize, c: usize| frame.rgb[3 * (y * w + x) + c] as f64;
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let top = px(x0, y0, c) * (1.0 - fx) + px(x1, y0, c) * fx;
        let bottom = px(x0, y1, c) * (1.0 - fx) + px(x1, y1, c) * fx;
        *o = top * (1.0 - fy) + bottom * fy;
    }
    out
}
