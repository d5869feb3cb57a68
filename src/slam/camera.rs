//! Camera models: the pinhole camera with Brown–Conrady distortion used by the monocular
//! filter (eq 20 with distortion applied to the normalised coordinates), and the calibrated
//! stereo pair of eqs 1–2.
//!
//! Camera frame: x right, y down, z forward (the pixel convention of docs/DESIGN.md). Eq 2 writes
//! u = u₀ − f·x/z for a camera frame whose x and y axes point left and up; with x right and
//! y down the signs are +, which is what is implemented.

use std::path::Path;

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, Error, Result};

/// A number as people write it: plain in the usual range, in exponent form outside it.
fn short(v: f64) -> String {
    if v == 0.0 || (1e-3..1e7).contains(&v.abs()) {
        v.to_string()
    } else {
        format!("{v:e}")
    }
}

/// The farthest image corner of a pinhole camera, in focal lengths from the axis, at most:
/// tan 85°, a field of view of 170° across the diagonal.
const MAX_CORNER_RADIUS: f64 = 11.43;

/// Intrinsics and distortion of one camera (the `[camera]` table of a calibration TOML).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinholeCamera {
    /// Focal length in pixels along x.
    pub fx: f64,
    /// Focal length in pixels along y.
    pub fy: f64,
    /// Principal point, x (pixel centres at integers).
    pub cx: f64,
    /// Principal point, y.
    pub cy: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Radial distortion, r² term.
    #[serde(default)]
    pub k1: f64,
    /// Radial distortion, r⁴ term.
    #[serde(default)]
    pub k2: f64,
    /// Tangential distortion p₁.
    #[serde(default)]
    pub p1: f64,
    /// Tangential distortion p₂.
    #[serde(default)]
    pub p2: f64,
    /// Radial distortion, r⁶ term.
    #[serde(default)]
    pub k3: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CalibrationFile {
    camera: PinholeCamera,
}

impl PinholeCamera {
    /// A distortion-free camera.
    pub fn ideal(fx: f64, fy: f64, cx: f64, cy: f64, width: u32, height: u32) -> Self {
        Self {
            fx,
            fy,
            cx,
            cy,
            width,
            height,
            k1: 0.0,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
            k3: 0.0,
        }
    }

    /// Checks that every parameter is finite, the focal lengths and size are positive, the
    /// principal point lies within an image size of the image, the field of view is one a
    /// pinhole camera can have, and the radial distortion does not fold the image.
    pub fn validate(&self) -> Result<()> {
        for (field, value) in [
            ("camera.fx", self.fx),
            ("camera.fy", self.fy),
            ("camera.cx", self.cx),
            ("camera.cy", self.cy),
            ("camera.k1", self.k1),
            ("camera.k2", self.k2),
            ("camera.p1", self.p1),
            ("camera.p2", self.p2),
            ("camera.k3", self.k3),
        ] {
            if !value.is_finite() {
                return Err(Error::config(field, value, "must be finite"));
            }
        }
        if self.fx <= 0.0 {
            return Err(Error::config(
                "camera.fx",
                self.fx,
                "focal length must be > 0",
            ));
        }
        if self.fy <= 0.0 {
            return Err(Error::config(
                "camera.fy",
                self.fy,
                "focal length must be > 0",
            ));
        }
        if self.width == 0 || self.height == 0 {
            return Err(Error::config(
                "camera.width",
                format!("{}x{}", self.width, self.height),
                "image size must be positive",
            ));
        }
        // The principal point may sit off centre, or just outside a cropped image, but not
        // image sizes away from it.
        for (field, c, size) in [
            ("camera.cx", self.cx, self.width),
            ("camera.cy", self.cy, self.height),
        ] {
            let size = size as f64;
            if !(-size..=2.0 * size).contains(&c) {
                return Err(Error::config(
                    field,
                    c,
                    format!("the principal point must lie within one image size ({size} px) of the image"),
                ));
            }
        }
        // A pinhole camera sees less than 180°: the farthest corner at 11.4 focal lengths from
        // the axis is already 170° across. A smaller focal length is a unit or typing error.
        let r_max = self.farthest_corner_radius();
        if r_max > MAX_CORNER_RADIUS {
            return Err(Error::config(
                "camera.fx",
                format!("{} (fy = {})", short(self.fx), short(self.fy)),
                format!(
                    "the image's farthest corner lies {r_max:.3e} focal lengths from the axis, a field of view of {:.1}° across; a pinhole camera sees at most 170° (corner at ≤ {MAX_CORNER_RADIUS:.1} focal lengths): is the focal length in pixels?",
                    2.0 * r_max.atan().to_degrees()
                ),
            ));
        }
        self.check_radial_distortion_is_monotonic()
    }

    /// The normalised radius (in focal lengths) of the image corner farthest from the axis.
    fn farthest_corner_radius(&self) -> f64 {
        let (w, h) = (self.width as f64, self.height as f64);
        [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .iter()
            .map(|&(u, v)| ((u - self.cx) / self.fx).hypot((v - self.cy) / self.fy))
            .fold(0.0, f64::max)
    }

    /// The radial model r_d = r(1 + k1 r² + k2 r⁴ + k3 r⁶) must grow with r out to the image's
    /// farthest corner, or two image radii map to one ray and undistortion has no answer; a
    /// k1 of 1e308 (accepted as finite) gives an all-identity trajectory otherwise.
    fn check_radial_distortion_is_monotonic(&self) -> Result<()> {
        let r_max = self.farthest_corner_radius();
        let radial = |r: f64| {
            let r2 = r * r;
            r * (1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3)))
        };
        const STEPS: usize = 400;
        let mut previous = 0.0;
        for i in 1..=STEPS {
            let r = r_max * i as f64 / STEPS as f64;
            let rd = radial(r);
            if !rd.is_finite() || rd <= previous {
                return Err(Error::config(
                    "camera.k1",
                    format!("k1 = {}, k2 = {}, k3 = {}", self.k1, self.k2, self.k3),
                    format!(
                        "the radial distortion folds the image: it stops growing at {:.0}% of the way to the farthest corner",
                        100.0 * r / r_max
                    ),
                ));
            }
            previous = rd;
        }
        // Monotonic but extreme (k1 = 1e308 still is): no real lens scales the corner's radius
        // by more than a few times.
        let factor = radial(r_max) / r_max.max(1e-12);
        if !(0.2..=5.0).contains(&factor) {
            return Err(Error::config(
                "camera.k1",
                format!("k1 = {}, k2 = {}, k3 = {}", self.k1, self.k2, self.k3),
                format!(
                    "the radial distortion scales the farthest corner's radius by {factor:.3e}, outside [0.2, 5]"
                ),
            ));
        }
        Ok(())
    }

    /// Reads a calibration: a TOML file with a `[camera]` table, or a EuRoC `sensor.yaml`.
    pub fn load(path: &Path) -> Result<Self> {
        let text = crate::error::read_input(path)?;
        let camera = if path.extension().is_some_and(|e| e == "yaml" || e == "yml") {
            parse_euroc_yaml(&text).map_err(|reason| Error::config_file(path, reason))?
        } else {
            toml::from_str::<CalibrationFile>(&text)
                .map_err(|e| Error::ConfigFile {
                    path: path.to_path_buf(),
                    source: Box::new(ConfigError::from_toml(&text, e)),
                })?
                .camera
        };
        camera.validate().map_err(|e| Error::ConfigFile {
            path: path.to_path_buf(),
            source: Box::new(ConfigError::invalid("camera", e)),
        })?;
        Ok(camera)
    }

    fn has_distortion(&self) -> bool {
        self.k1 != 0.0 || self.k2 != 0.0 || self.p1 != 0.0 || self.p2 != 0.0 || self.k3 != 0.0
    }

    /// Distorted normalised coordinates and their 2×2 Jacobian w.r.t. the ideal ones.
    pub fn distort(&self, n: Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
        let (x, y) = (n.x, n.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let d_radial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2); // ∂radial/∂r²
        let xd = x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y;
        let j = Matrix2::new(
            radial + 2.0 * x * x * d_radial + 2.0 * self.p1 * y + 6.0 * self.p2 * x,
            2.0 * x * y * d_radial + 2.0 * self.p1 * x + 2.0 * self.p2 * y,
            2.0 * x * y * d_radial + 2.0 * self.p1 * x + 2.0 * self.p2 * y,
            radial + 2.0 * y * y * d_radial + 6.0 * self.p1 * y + 2.0 * self.p2 * x,
        );
        (Vector2::new(xd, yd), j)
    }

    /// Ideal normalised coordinates of a distorted pixel (Newton iterations on [`Self::distort`]).
    pub fn undistort_pixel(&self, z: Vector2<f64>) -> Vector2<f64> {
        let target = Vector2::new((z.x - self.cx) / self.fx, (z.y - self.cy) / self.fy);
        if !self.has_distortion() {
            return target;
        }
        let mut n = target;
        for _ in 0..20 {
            let (d, j) = self.distort(n);
            let step = j.try_inverse().map(|ji| ji * (d - target));
            match step {
                Some(s) if s.iter().all(|v| v.is_finite()) => {
                    n -= s;
                    if s.norm() < 1e-12 {
                        break;
                    }
                }
                _ => break,
            }
        }
        n
    }

    /// The viewing ray (z = 1) of a pixel and its 3×2 Jacobian w.r.t. the pixel.
    pub fn back_project(&self, z: Vector2<f64>) -> (Vector3<f64>, nalgebra::Matrix3x2<f64>) {
        let n = self.undistort_pixel(z);
        let (_, jd) = self.distort(n);
        let jn = jd.try_inverse().unwrap_or_else(Matrix2::identity)
            * Matrix2::new(1.0 / self.fx, 0.0, 0.0, 1.0 / self.fy);
        let mut j = nalgebra::Matrix3x2::zeros();
        j.fixed_view_mut::<2, 2>(0, 0).copy_from(&jn);
        (Vector3::new(n.x, n.y, 1.0), j)
    }

    /// Pixel of a point in camera coordinates (eq 20 plus distortion), or `None` behind the camera.
    pub fn project(&self, h: &Vector3<f64>) -> Option<Vector2<f64>> {
        if h.z <= 1e-9 {
            return None;
        }
        let (d, _) = self.distort(Vector2::new(h.x / h.z, h.y / h.z));
        Some(Vector2::new(
            self.fx * d.x + self.cx,
            self.fy * d.y + self.cy,
        ))
    }

    /// Pixel of a camera-frame point and its 2×3 Jacobian, or `None` behind the camera.
    pub fn project_with_jacobian(
        &self,
        h: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        if h.z <= 1e-9 {
            return None;
        }
        let iz = 1.0 / h.z;
        let (d, jd) = self.distort(Vector2::new(h.x * iz, h.y * iz));
        let jn = Matrix2x3::new(iz, 0.0, -h.x * iz * iz, 0.0, iz, -h.y * iz * iz);
        let j = Matrix2::new(self.fx, 0.0, 0.0, self.fy) * jd * jn;
        Some((
            Vector2::new(self.fx * d.x + self.cx, self.fy * d.y + self.cy),
            j,
        ))
    }

    /// True when the pixel lies at least `margin` pixels inside the image.
    pub fn contains(&self, z: &Vector2<f64>, margin: f64) -> bool {
        z.x >= margin
            && z.y >= margin
            && z.x <= self.width as f64 - 1.0 - margin
            && z.y <= self.height as f64 - 1.0 - margin
    }
}

/// A calibrated stereo pair (eqs 1–2): the rig frame is the left camera's; the right camera
/// sits at `baseline` metres along the rig's x axis with the same orientation (rectified).
#[derive(Clone, Debug)]
pub struct StereoRig {
    /// Left camera intrinsics.
    pub left: PinholeCamera,
    /// Right camera intrinsics.
    pub right: PinholeCamera,
    /// Distance between the optical centres, metres.
    pub baseline: f64,
}

impl StereoRig {
    /// Eq 1: a world point in the left camera frame, h = R_RW (y − r), for the rig pose (r, R_WR).
    pub fn to_rig(
        point: &Vector3<f64>,
        r: &Vector3<f64>,
        r_world_rig: &Matrix3<f64>,
    ) -> Vector3<f64> {
        r_world_rig.transpose() * (point - r)
    }

    /// Eq 2 for both cameras: the pixels of a world point, or `None` if behind either camera.
    pub fn project(
        &self,
        point: &Vector3<f64>,
        r: &Vector3<f64>,
        r_world_rig: &Matrix3<f64>,
    ) -> Option<(Vector2<f64>, Vector2<f64>)> {
        let h = Self::to_rig(point, r, r_world_rig);
        let left = self.left.project(&h)?;
        let right = self
            .right
            .project(&(h - Vector3::new(self.baseline, 0.0, 0.0)))?;
        Some((left, right))
    }

    /// Triangulates a world point from a left/right pixel pair (midpoint of the closest points
    /// of the two viewing rays); `None` when the rays are parallel.
    pub fn triangulate(
        &self,
        left: Vector2<f64>,
        right: Vector2<f64>,
        r: &Vector3<f64>,
        r_world_rig: &Matrix3<f64>,
    ) -> Option<Vector3<f64>> {
        let (a, _) = self.left.back_project(left);
        let (b, _) = self.right.back_project(right);
        let o_b = Vector3::new(self.baseline, 0.0, 0.0);
        // Solve min |s·a − (o_b + t·b)|.
        let (aa, bb, ab) = (a.dot(&a), b.dot(&b), a.dot(&b));
        let denom = aa * bb - ab * ab;
        if denom.abs() < 1e-12 {
            return None;
        }
        let (ao, bo) = (a.dot(&o_b), b.dot(&o_b));
        let s = (bb * ao - ab * bo) / denom;
        let t = (ab * ao - aa * bo) / denom;
        let mid = 0.5 * (a * s + o_b + b * t);
        Some(r_world_rig * mid + r)
    }
}

/// Reads `intrinsics`, `resolution` and `distortion_coefficients` from a EuRoC sensor.yaml
/// (radial-tangential model: k1, k2, p1, p2).
fn parse_euroc_yaml(text: &str) -> std::result::Result<PinholeCamera, String> {
    let list = |key: &str| -> std::result::Result<Vec<f64>, String> {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{key}:")))
            .ok_or_else(|| format!("no `{key}` entry"))?;
        let inside = line
            .split_once('[')
            .and_then(|(_, rest)| rest.split_once(']'))
            .ok_or_else(|| format!("`{key}` is not a [..] list"))?
            .0;
        inside
            .split(',')
            .map(|v| {
                v.trim()
                    .parse::<f64>()
                    .map_err(|e| format!("`{key}`: {v:?}: {e}"))
            })
            .collect()
    };
    let k = list("intrinsics")?;
    let size = list("resolution")?;
    if k.len() != 4 || size.len() != 2 {
        return Err("intrinsics needs 4 values and resolution 2".into());
    }
    let d = list("distortion_coefficients").unwrap_or_default();
    let at = |i: usize| d.get(i).copied().unwrap_or(0.0);
    Ok(PinholeCamera {
        fx: k[0],
        fy: k[1],
        cx: k[2],
        cy: k[3],
        width: size[0] as u32,
        height: size[1] as u32,
        k1: at(0),
        k2: at(1),
        p1: at(2),
        p2: at(3),
        k3: at(4),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn euroc() -> PinholeCamera {
        PinholeCamera {
            k1: -0.28340811,
            k2: 0.07395907,
            p1: 0.00019359,
            p2: 1.76187114e-05,
            ..PinholeCamera::ideal(458.654, 457.296, 367.215, 248.375, 752, 480)
        }
    }

    #[test]
    fn distortion_that_folds_the_image_is_refused() {
        let mut cam = PinholeCamera::ideal(500.0, 500.0, 320.0, 240.0, 640, 480);
        cam.k1 = -0.3;
        cam.k2 = 0.1;
        assert!(cam.validate().is_ok(), "a typical barrel lens");
        cam.k1 = 1e308;
        let e = cam.validate().unwrap_err().to_string();
        assert!(
            e.contains("camera.k1") && e.contains("farthest corner"),
            "{e}"
        );
        cam.k1 = -2.0;
        cam.k2 = 0.0;
        assert!(
            cam.validate().is_err(),
            "r(1 − 2r²) turns back inside the image"
        );
    }

    #[test]
    fn projection_jacobian_matches_finite_differences() {
        let cam = euroc();
        let h = Vector3::new(0.4, -0.3, 1.7);
        let (_, j) = cam.project_with_jacobian(&h).unwrap();
        for c in 0..3 {
            let mut a = h;
            let mut b = h;
            a[c] += 1e-6;
            b[c] -= 1e-6;
            let fd = (cam.project(&a).unwrap() - cam.project(&b).unwrap()) / 2e-6;
            assert!((fd - j.column(c)).amax() < 1e-4, "column {c}");
        }
    }

    #[test]
    fn undistortion_inverts_distortion_and_back_projection_jacobian_matches() {
        let cam = euroc();
        for z in [
            Vector2::new(10.0, 12.0),
            Vector2::new(700.0, 400.0),
            Vector2::new(367.0, 248.0),
        ] {
            let (ray, j) = cam.back_project(z);
            assert!((cam.project(&ray).unwrap() - z).amax() < 1e-6);
            for c in 0..2 {
                let mut a = z;
                let mut b = z;
                a[c] += 1e-4;
                b[c] -= 1e-4;
                let fd = (cam.back_project(a).0 - cam.back_project(b).0) / 2e-4;
                assert!((fd - j.column(c)).amax() < 1e-6);
            }
        }
    }

    #[test]
    fn stereo_projection_round_trips() {
        let cam = PinholeCamera::ideal(400.0, 400.0, 320.0, 240.0, 640, 480);
        let rig = StereoRig {
            left: cam.clone(),
            right: cam,
            baseline: 0.12,
        };
        let r = Vector3::new(0.3, -0.1, 0.2);
        let rot = crate::slam::rotation::matrix(&crate::slam::rotation::from_rotation_vector(
            &Vector3::new(0.05, 0.2, -0.1),
        ));
        let point = Vector3::new(1.0, 0.5, 4.0);
        let (l, rr) = rig.project(&point, &r, &rot).unwrap();
        assert!(l.x > rr.x, "disparity must be positive");
        let back = rig.triangulate(l, rr, &r, &rot).unwrap();
        assert!((back - point).amax() < 1e-9);
    }

    #[test]
    fn zero_focal_length_is_refused_naming_the_field() {
        let cam = PinholeCamera::ideal(0.0, 400.0, 320.0, 240.0, 640, 480);
        let message = cam.validate().unwrap_err().to_string();
        assert!(message.contains("camera.fx"), "{message}");
    }

    #[test]
    fn a_focal_length_no_lens_has_and_a_far_principal_point_are_refused() {
        // 1e-300 px used to pass as finite and was blamed on the distortion.
        let tiny = PinholeCamera::ideal(1e-300, 400.0, 320.0, 240.0, 640, 480);
        let message = tiny.validate().unwrap_err().to_string();
        assert!(
            message.contains("camera.fx = 1e-300") && message.contains("170°"),
            "{message}"
        );
        assert!(!message.contains("distortion"), "{message}");
        // A wide but real lens (about 150° across the diagonal) passes.
        assert!(PinholeCamera::ideal(100.0, 100.0, 320.0, 240.0, 640, 480)
            .validate()
            .is_ok());
        let far = PinholeCamera::ideal(400.0, 400.0, 1e6, 240.0, 640, 480);
        let message = far.validate().unwrap_err().to_string();
        assert!(
            message.contains("camera.cx") && message.contains("principal point"),
            "{message}"
        );
    }
}
