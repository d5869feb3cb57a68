//! Landmarks: the inverse-depth parametrisation of eq 13, its measurement model (eqs 17–21)
//! with analytic Jacobians, initialisation from one observation, and the conversion to
//! Euclidean form once the linearity index says depth is well known (Civera, Davison and
//! Montiel, "Inverse depth parametrization for monocular SLAM", 2008).
//!
//! An inverse-depth landmark y = (x, y, z, α, β, ρ) is the ray from the anchor (x, y, z), the
//! camera centre at first sight, along m(α, β) = (cos β sin α, sin β, cos β cos α) (eq 18), at
//! depth 1/ρ. In the camera at (r, q) it is seen along h = R(q)ᵀ(ρ(anchor − r) + m), which is
//! the point's direction scaled by ρ — well defined even at ρ = 0 (points at infinity).

use nalgebra::{Matrix2x3, Matrix3, SMatrix, Vector2, Vector3};

use super::camera::PinholeCamera;
use super::rotation::{self, Quat};

/// The two landmark parametrisations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Parametrisation {
    /// (x, y, z, α, β, ρ), six state entries.
    InverseDepth,
    /// (X, Y, Z), three state entries.
    Euclidean,
}

impl Parametrisation {
    /// Number of state entries.
    pub fn dim(self) -> usize {
        match self {
            Parametrisation::InverseDepth => 6,
            Parametrisation::Euclidean => 3,
        }
    }
}

/// Unit direction m(α, β) of eq 18 and its derivatives w.r.t. α and β.
pub fn direction(alpha: f64, beta: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let (sa, ca) = alpha.sin_cos();
    let (sb, cb) = beta.sin_cos();
    (
        Vector3::new(cb * sa, sb, cb * ca),
        Vector3::new(cb * ca, 0.0, -cb * sa),
        Vector3::new(-sb * sa, cb, -sb * ca),
    )
}

/// Azimuth and elevation of a world direction, and their 2×3 Jacobian.
pub fn angles(h: &Vector3<f64>) -> (f64, f64, Matrix2x3<f64>) {
    let xz2 = h.x * h.x + h.z * h.z;
    let xz = xz2.sqrt().max(1e-12);
    let n2 = (xz2 + h.y * h.y).max(1e-24);
    let alpha = h.x.atan2(h.z);
    let beta = h.y.atan2(xz);
    let j = Matrix2x3::new(
        h.z / xz2.max(1e-24),
        0.0,
        -h.x / xz2.max(1e-24),
        -h.y * h.x / (n2 * xz),
        xz / n2,
        -h.y * h.z / (n2 * xz),
    );
    (alpha, beta, j)
}

/// A predicted observation: the pixel and the Jacobians of eq 21 w.r.t. the camera pose
/// (r, q) — 2×7 — and the landmark's own entries (2×6 or 2×3, stored 2×6, unused columns 0).
#[derive(Clone, Debug)]
pub struct Prediction {
    /// Predicted pixel h(x).
    pub pixel: Vector2<f64>,
    /// ∂h/∂(r, q).
    pub d_pose: SMatrix<f64, 2, 7>,
    /// ∂h/∂y (first `dim` columns meaningful).
    pub d_landmark: SMatrix<f64, 2, 6>,
    /// The ray in camera coordinates (its z is > 0).
    pub camera_ray: Vector3<f64>,
}

/// Eqs 17–21: predicts the pixel of landmark `y` seen by the camera at (r, q).
pub fn predict(
    camera: &PinholeCamera,
    kind: Parametrisation,
    y: &[f64],
    r: &Vector3<f64>,
    q: &Quat,
) -> Option<Prediction> {
    let rot_t = rotation::matrix(q).transpose();
    let (world, d_world_dr, d_world_dy): (Vector3<f64>, f64, SMatrix<f64, 3, 6>) = match kind {
        Parametrisation::InverseDepth => {
            let anchor = Vector3::new(y[0], y[1], y[2]);
            let rho = y[5];
            let (m, dm_da, dm_db) = direction(y[3], y[4]);
            let mut dy = SMatrix::<f64, 3, 6>::zeros();
            dy.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&(Matrix3::identity() * rho));
            dy.set_column(3, &dm_da);
            dy.set_column(4, &dm_db);
            dy.set_column(5, &(anchor - r));
            (rho * (anchor - r) + m, -rho, dy)
        }
        Parametrisation::Euclidean => {
            let point = Vector3::new(y[0], y[1], y[2]);
            let mut dy = SMatrix::<f64, 3, 6>::zeros();
            dy.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&Matrix3::identity());
            (point - r, -1.0, dy)
        }
    };
    let h = rot_t * world;
    let (pixel, jp) = camera.project_with_jacobian(&h)?;
    let mut d_pose = SMatrix::<f64, 2, 7>::zeros();
    d_pose
        .fixed_view_mut::<2, 3>(0, 0)
        .copy_from(&(jp * rot_t * d_world_dr));
    d_pose
        .fixed_view_mut::<2, 4>(0, 3)
        .copy_from(&(jp * rotation::d_rotate_transpose_dq(q, &world)));
    let d_landmark = jp * rot_t * d_world_dy;
    Some(Prediction {
        pixel,
        d_pose,
        d_landmark,
        camera_ray: h,
    })
}

/// A new inverse-depth landmark from pixel `z` seen at (r, q), with the Jacobians needed to
/// grow the covariance: ∂y/∂(r, q) (6×7) and ∂y/∂z (6×2); ∂y/∂ρ₀ is e₆.
pub fn initialise(
    camera: &PinholeCamera,
    z: Vector2<f64>,
    r: &Vector3<f64>,
    q: &Quat,
    rho0: f64,
) -> ([f64; 6], SMatrix<f64, 6, 7>, SMatrix<f64, 6, 2>) {
    let (ray, d_ray_dz) = camera.back_project(z);
    let world = rotation::matrix(q) * ray;
    let (alpha, beta, d_angles) = angles(&world);
    let mut d_pose = SMatrix::<f64, 6, 7>::zeros();
    d_pose
        .fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&Matrix3::identity());
    d_pose
        .fixed_view_mut::<2, 4>(3, 3)
        .copy_from(&(d_angles * rotation::d_rotate_dq(q, &ray)));
    let mut d_pixel = SMatrix::<f64, 6, 2>::zeros();
    d_pixel
        .fixed_view_mut::<2, 2>(3, 0)
        .copy_from(&(d_angles * rotation::matrix(q) * d_ray_dz));
    ([r.x, r.y, r.z, alpha, beta, rho0], d_pose, d_pixel)
}

/// The Euclidean point of an inverse-depth landmark and the 3×6 Jacobian of the conversion.
pub fn to_euclidean(y: &[f64]) -> (Vector3<f64>, SMatrix<f64, 3, 6>) {
    let (m, dm_da, dm_db) = direction(y[3], y[4]);
    let rho = y[5];
    let mut j = SMatrix::<f64, 3, 6>::zeros();
    j.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&Matrix3::identity());
    j.set_column(3, &(dm_da / rho));
    j.set_column(4, &(dm_db / rho));
    j.set_column(5, &(-m / (rho * rho)));
    (Vector3::new(y[0], y[1], y[2]) + m / rho, j)
}

/// Civera's linearity index L = 4σ_d/d₁ · |cos a| of an inverse-depth landmark seen from r,
/// with σ_d = σ_ρ/ρ²; below about 0.1 the Euclidean form is as linear as the inverse depth.
pub fn linearity_index(y: &[f64], rho_variance: f64, r: &Vector3<f64>) -> f64 {
    let rho = y[5];
    if rho <= 0.0 {
        return f64::INFINITY;
    }
    let (m, _, _) = direction(y[3], y[4]);
    let point = Vector3::new(y[0], y[1], y[2]) + m / rho;
    let to_point = point - r;
    let d1 = to_point.norm().max(1e-12);
    let cos_a = m.dot(&to_point) / d1;
    let sigma_d = rho_variance.max(0.0).sqrt() / (rho * rho);
    4.0 * sigma_d / d1 * cos_a.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> PinholeCamera {
        PinholeCamera {
            k1: -0.2,
            k2: 0.05,
            p1: 0.001,
            p2: -0.0005,
            ..PinholeCamera::ideal(300.0, 310.0, 160.0, 120.0, 320, 240)
        }
    }

    fn pose() -> (Vector3<f64>, Quat) {
        (
            Vector3::new(0.2, -0.1, 0.3),
            rotation::from_rotation_vector(&Vector3::new(0.1, -0.25, 0.05)),
        )
    }

    #[test]
    fn measurement_jacobians_match_finite_differences() {
        let cam = camera();
        let (r, q) = pose();
        let id = [0.1, 0.05, -0.2, 0.2, -0.1, 0.4];
        let eu = [0.8, -0.3, 3.0, 0.0, 0.0, 0.0];
        for (kind, y) in [
            (Parametrisation::InverseDepth, id),
            (Parametrisation::Euclidean, eu),
        ] {
            let p = predict(&cam, kind, &y, &r, &q).unwrap();
            let mut state = [0.0; 13];
            state[..3].copy_from_slice(r.as_slice());
            state[3..7].copy_from_slice(q.as_slice());
            state[7..].copy_from_slice(&y);
            let eval = |s: &[f64; 13]| {
                let r = Vector3::new(s[0], s[1], s[2]);
                let q = Quat::new(s[3], s[4], s[5], s[6]);
                predict(&cam, kind, &s[7..], &r, &q).unwrap().pixel
            };
            for c in 0..7 + kind.dim() {
                let (mut a, mut b) = (state, state);
                a[c] += 1e-6;
                b[c] -= 1e-6;
                let fd = (eval(&a) - eval(&b)) / 2e-6;
                let analytic = if c < 7 {
                    p.d_pose.column(c).into_owned()
                } else {
                    p.d_landmark.column(c - 7).into_owned()
                };
                assert!(
                    (fd - analytic).amax() < 1e-3 * (1.0 + fd.amax()),
                    "{kind:?} col {c}: {fd} vs {analytic}"
                );
            }
        }
    }

    #[test]
    fn initialisation_jacobians_match_and_point_reprojects() {
        let cam = camera();
        let (r, q) = pose();
        let z = Vector2::new(40.0, 200.0);
        let (y, d_pose, d_pixel) = initialise(&cam, z, &r, &q, 0.5);
        let back = predict(&cam, Parametrisation::InverseDepth, &y, &r, &q).unwrap();
        assert!((back.pixel - z).amax() < 1e-6);
        let mut state = [0.0; 9];
        state[..3].copy_from_slice(r.as_slice());
        state[3..7].copy_from_slice(q.as_slice());
        state[7..].copy_from_slice(z.as_slice());
        let eval = |s: &[f64; 9]| {
            let (y, _, _) = initialise(
                &cam,
                Vector2::new(s[7], s[8]),
                &Vector3::new(s[0], s[1], s[2]),
                &Quat::new(s[3], s[4], s[5], s[6]),
                0.5,
            );
            nalgebra::Vector6::from_row_slice(&y)
        };
        for c in 0..9 {
            let (mut a, mut b) = (state, state);
            a[c] += 1e-6;
            b[c] -= 1e-6;
            let fd = (eval(&a) - eval(&b)) / 2e-6;
            let analytic = if c < 7 {
                d_pose.column(c).into_owned()
            } else {
                d_pixel.column(c - 7).into_owned()
            };
            assert!((fd - analytic).amax() < 1e-5, "col {c}: {fd} vs {analytic}");
        }
    }

    #[test]
    fn euclidean_conversion_jacobian_matches() {
        let y = [0.1, 0.05, -0.2, 0.2, -0.1, 0.4];
        let (_, j) = to_euclidean(&y);
        for c in 0..6 {
            let (mut a, mut b) = (y, y);
            a[c] += 1e-6;
            b[c] -= 1e-6;
            let fd = (to_euclidean(&a).0 - to_euclidean(&b).0) / 2e-6;
            assert!((fd - j.column(c)).amax() < 1e-5);
        }
        // A far, uncertain point is non-linear; a near, certain one is linear.
        let r = Vector3::zeros();
        assert!(linearity_index(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.1], 0.25, &r) > 0.1);
        assert!(linearity_index(&[0.0, 0.0, 0.0, 0.0, 0.0, 1.0], 1e-4, &r) < 0.1);
    }
}
