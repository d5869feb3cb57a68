//! Quaternion algebra for the filter state (eqs 14–16, 19): products, rotation of vectors and
//! the analytic derivatives the EKF needs.
//!
//! Quaternions are `[w, x, y, z]` and rotate camera coordinates into the world (R_wc). The
//! rotation matrix is the homogeneous (degree-2) form, R(q)v = (w² − |u|²)v + 2u(u·v) +
//! 2w(u×v) with u = (x, y, z), so that its derivatives stay exact for the slightly
//! non-unit quaternions the filter passes through between normalisations.

use nalgebra::{Matrix3, Matrix3x4, Matrix4, Matrix4x3, Vector3, Vector4};

/// A quaternion `[w, x, y, z]`.
pub type Quat = Vector4<f64>;

/// The identity rotation.
pub fn identity() -> Quat {
    Vector4::new(1.0, 0.0, 0.0, 0.0)
}

fn vector_part(q: &Quat) -> Vector3<f64> {
    Vector3::new(q[1], q[2], q[3])
}

/// Skew-symmetric matrix \[v\]× with \[v\]× a = v × a.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// R(q) as a matrix.
pub fn matrix(q: &Quat) -> Matrix3<f64> {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    Matrix3::new(
        w * w + x * x - y * y - z * z,
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        w * w - x * x + y * y - z * z,
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        w * w - x * x - y * y + z * z,
    )
}

/// ∂(R(q) v)/∂q, a 3×4 matrix.
pub fn d_rotate_dq(q: &Quat, v: &Vector3<f64>) -> Matrix3x4<f64> {
    d_rotate_signed(q, v, 1.0)
}

/// ∂(R(q)ᵀ v)/∂q, a 3×4 matrix.
pub fn d_rotate_transpose_dq(q: &Quat, v: &Vector3<f64>) -> Matrix3x4<f64> {
    d_rotate_signed(q, v, -1.0)
}

// R(q)ᵀ v is R(q) v with w replaced by −w; `sign` selects which.
fn d_rotate_signed(q: &Quat, v: &Vector3<f64>, sign: f64) -> Matrix3x4<f64> {
    let w = q[0];
    let u = vector_part(q);
    let dw = 2.0 * w * v + sign * 2.0 * u.cross(v);
    let du =
        -2.0 * v * u.transpose() + 2.0 * u.dot(v) * Matrix3::identity() + 2.0 * u * v.transpose()
            - sign * 2.0 * w * skew(v);
    let mut j = Matrix3x4::zeros();
    j.set_column(0, &dw);
    j.fixed_view_mut::<3, 3>(0, 1).copy_from(&du);
    j
}

/// Hamilton product a ⊗ b.
pub fn multiply(a: &Quat, b: &Quat) -> Quat {
    Vector4::new(
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    )
}

/// ∂(a ⊗ b)/∂a.
pub fn d_multiply_d_left(b: &Quat) -> Matrix4<f64> {
    Matrix4::new(
        b[0], -b[1], -b[2], -b[3], //
        b[1], b[0], b[3], -b[2], //
        b[2], -b[3], b[0], b[1], //
        b[3], b[2], -b[1], b[0],
    )
}

/// ∂(a ⊗ b)/∂b.
pub fn d_multiply_d_right(a: &Quat) -> Matrix4<f64> {
    Matrix4::new(
        a[0], -a[1], -a[2], -a[3], //
        a[1], a[0], -a[3], a[2], //
        a[2], a[3], a[0], -a[1], //
        a[3], -a[2], a[1], a[0],
    )
}

/// Conjugate (the inverse of a unit quaternion).
pub fn conjugate(q: &Quat) -> Quat {
    Vector4::new(q[0], -q[1], -q[2], -q[3])
}

/// The quaternion of a rotation vector θ (axis × angle).
pub fn from_rotation_vector(theta: &Vector3<f64>) -> Quat {
    let angle = theta.norm();
    if angle < 1e-12 {
        return Vector4::new(1.0, 0.5 * theta.x, 0.5 * theta.y, 0.5 * theta.z).normalize();
    }
    let s = (0.5 * angle).sin() / angle;
    Vector4::new((0.5 * angle).cos(), s * theta.x, s * theta.y, s * theta.z)
}

/// ∂q(θ)/∂θ, a 4×3 matrix.
pub fn d_from_rotation_vector(theta: &Vector3<f64>) -> Matrix4x3<f64> {
    let angle = theta.norm();
    let mut j = Matrix4x3::zeros();
    if angle < 1e-8 {
        // First order: q ≈ (1 − |θ|²/8, θ/2).
        j.set_row(0, &(-0.25 * theta.transpose()));
        j.fixed_view_mut::<3, 3>(1, 0)
            .copy_from(&(0.5 * Matrix3::identity()));
        return j;
    }
    let (s, c) = (0.5 * angle).sin_cos();
    j.set_row(0, &(-0.5 * s / angle * theta.transpose()));
    let block = (s / angle) * Matrix3::identity()
        + theta * theta.transpose() * (0.5 * c / (angle * angle) - s / (angle * angle * angle));
    j.fixed_view_mut::<3, 3>(1, 0).copy_from(&block);
    j
}

/// The rotation vector of a unit quaternion (the inverse of [`from_rotation_vector`]).
pub fn to_rotation_vector(q: &Quat) -> Vector3<f64> {
    let q = if q[0] < 0.0 { -q } else { *q };
    let u = vector_part(&q);
    let s = u.norm();
    if s < 1e-12 {
        return 2.0 * u;
    }
    let angle = 2.0 * s.atan2(q[0]);
    u * (angle / s)
}

/// ∂(q/|q|)/∂q, used to carry the covariance through the normalisation.
pub fn d_normalize(q: &Quat) -> Matrix4<f64> {
    let n2 = q.norm_squared();
    let n = n2.sqrt();
    (Matrix4::identity() * n2 - q * q.transpose()) / (n2 * n)
}

/// Rotation matrix to unit quaternion (Shepperd's method, numerically safe for all angles).
pub fn from_matrix(m: &Matrix3<f64>) -> Quat {
    let uq = nalgebra::UnitQuaternion::from_matrix(m);
    let q = uq.quaternion();
    Vector4::new(q.w, q.i, q.j, q.k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numeric<const R: usize, const C: usize>(
        f: impl Fn(&nalgebra::SVector<f64, C>) -> nalgebra::SVector<f64, R>,
        at: &nalgebra::SVector<f64, C>,
    ) -> nalgebra::SMatrix<f64, R, C> {
        let mut j = nalgebra::SMatrix::<f64, R, C>::zeros();
        for c in 0..C {
            let (mut a, mut b) = (*at, *at);
            a[c] += 1e-6;
            b[c] -= 1e-6;
            j.set_column(c, &((f(&a) - f(&b)) / 2e-6));
        }
        j
    }

    #[test]
    fn rotation_derivatives_match_finite_differences() {
        let q = Vector4::new(0.9, 0.2, -0.3, 0.25).normalize();
        let v = Vector3::new(0.4, -1.2, 2.5);
        let fd = numeric(|q: &Quat| matrix(q) * v, &q);
        assert!((fd - d_rotate_dq(&q, &v)).amax() < 1e-7);
        let fd = numeric(|q: &Quat| matrix(q).transpose() * v, &q);
        assert!((fd - d_rotate_transpose_dq(&q, &v)).amax() < 1e-7);
    }

    #[test]
    fn product_and_rotation_vector_derivatives_match() {
        let a = Vector4::new(0.8, 0.1, 0.5, -0.3).normalize();
        let b = Vector4::new(0.7, -0.4, 0.2, 0.5).normalize();
        let fd = numeric(|x: &Quat| multiply(x, &b), &a);
        assert!((fd - d_multiply_d_left(&b)).amax() < 1e-8);
        let fd = numeric(|x: &Quat| multiply(&a, x), &b);
        assert!((fd - d_multiply_d_right(&a)).amax() < 1e-8);
        for theta in [
            Vector3::new(0.3, -0.2, 0.9),
            Vector3::new(1e-10, 0.0, 2e-10),
        ] {
            let fd = numeric(from_rotation_vector, &theta);
            assert!((fd - d_from_rotation_vector(&theta)).amax() < 1e-6);
        }
        let fd = numeric(|q: &Quat| q.normalize(), &(a * 1.3));
        assert!((fd - d_normalize(&(a * 1.3))).amax() < 1e-7);
    }

    #[test]
    fn product_composes_rotations() {
        let a = from_rotation_vector(&Vector3::new(0.3, 0.1, -0.2));
        let b = from_rotation_vector(&Vector3::new(-0.5, 0.4, 0.2));
        let ab = matrix(&multiply(&a, &b));
        assert!((ab - matrix(&a) * matrix(&b)).amax() < 1e-12);
        let theta = Vector3::new(0.7, -0.1, 0.4);
        assert!((to_rotation_vector(&from_rotation_vector(&theta)) - theta).amax() < 1e-12);
        assert!((from_matrix(&matrix(&a)) - a).amax() < 1e-12);
    }
}
