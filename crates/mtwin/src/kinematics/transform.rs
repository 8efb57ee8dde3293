//! Exact rigid transforms (docs/machine-model.md): rotation matrix and translation, `x ↦ R x + t`.

use nalgebra::{Matrix3, Vector3};

/// `(sin x, cos x)` to full double precision, fast for the small angles of geometric errors.
///
/// For |x| < 0.01 rad the Taylor series is summed to the x⁹ (sin) and x¹⁰ (cos) terms,
/// whose remainders are below 1e-30 relative: this is not a linearisation, it is the same
/// value `f64::sin_cos` returns (within rounding) at a fraction of the cost.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() < 1e-2 {
        small_angle_sin_cos(x)
    } else {
        x.sin_cos()
    }
}

/// The series branch of [`sin_cos`], valid for |x| < 0.01 rad: Horner's rule in `x²` with
/// the reciprocal factorials as constants (multiplications, no divisions).
#[inline(always)]
pub(crate) fn small_angle_sin_cos(x: f64) -> (f64, f64) {
    let x2 = x * x;
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0)))));
    (s, c)
}

/// `Rx(a)·Ry(b)·Rz(c)`, exact.
#[inline]
pub fn rxyz(a: f64, b: f64, c: f64) -> Matrix3<f64> {
    let (sa, ca) = sin_cos(a);
    let (sb, cb) = sin_cos(b);
    let (sc, cc) = sin_cos(c);
    Matrix3::new(
        cb * cc,
        -cb * sc,
        sb,
        sa * sb * cc + ca * sc,
        -sa * sb * sc + ca * cc,
        -sa * cb,
        -ca * sb * cc + sa * sc,
        ca * sb * sc + sa * cc,
        ca * cb,
    )
}

/// Derivatives of `Rx(a)·Ry(b)·Rz(c)·v` with respect to `a`, `b` and `c`.
#[inline]
pub fn rxyz_derivatives(a: f64, b: f64, c: f64, v: &Vector3<f64>) -> [Vector3<f64>; 3] {
    let (sa, ca) = sin_cos(a);
    let (sb, cb) = sin_cos(b);
    let (sc, cc) = sin_cos(c);
    let rz_v = Vector3::new(cc * v.x - sc * v.y, sc * v.x + cc * v.y, v.z);
    let ry = |w: &Vector3<f64>| Vector3::new(cb * w.x + sb * w.z, w.y, -sb * w.x + cb * w.z);
    let rx = |w: &Vector3<f64>| Vector3::new(w.x, ca * w.y - sa * w.z, sa * w.y + ca * w.z);
    let ryrz_v = ry(&rz_v);
    let full = rx(&ryrz_v);
    [
        Vector3::x().cross(&full),
        rx(&Vector3::y().cross(&ryrz_v)),
        rx(&ry(&Vector3::z().cross(&rz_v))),
    ]
}

/// Rotation by `angle` (rad) about the unit vector `u` (Rodrigues).
#[inline]
pub fn rot(u: &Vector3<f64>, angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    let k = u.cross_matrix();
    Matrix3::identity() * c + k * s + u * u.transpose() * (1.0 - c)
}

/// Rotation about the unit vector `u` by the angle whose sine and cosine are `s`, `c`.
#[inline]
pub fn rot_sc(u: &Vector3<f64>, s: f64, c: f64) -> Matrix3<f64> {
    Matrix3::identity() * c + u.cross_matrix() * s + u * u.transpose() * (1.0 - c)
}

/// A rigid transform `T_ab`: maps coordinates in frame b to frame a, `x_a = r·x_b + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rigid {
    /// Rotation part (orthonormal, det +1).
    pub r: Matrix3<f64>,
    /// Translation part, mm.
    pub t: Vector3<f64>,
}

impl Default for Rigid {
    fn default() -> Self {
        Self::identity()
    }
}

impl Rigid {
    /// The identity.
    pub fn identity() -> Self {
        Rigid {
            r: Matrix3::identity(),
            t: Vector3::zeros(),
        }
    }

    /// `Trans(v)`.
    pub fn translation(v: Vector3<f64>) -> Self {
        Rigid {
            r: Matrix3::identity(),
            t: v,
        }
    }

    /// `Rot(u, angle)` about the line through the origin (angle in rad).
    pub fn rotation(u: &Vector3<f64>, angle: f64) -> Self {
        Rigid {
            r: rot(u, angle),
            t: Vector3::zeros(),
        }
    }

    /// `Trans(t)·Rx(a)·Ry(b)·Rz(c)`: the error transform of docs/machine-model.md.
    pub fn from_error(t: Vector3<f64>, a: f64, b: f64, c: f64) -> Self {
        Rigid {
            r: rxyz(a, b, c),
            t,
        }
    }

    /// `self · other`.
    #[inline]
    pub fn compose(&self, other: &Rigid) -> Rigid {
        Rigid {
            r: self.r * other.r,
            t: self.r * other.t + self.t,
        }
    }

    /// The inverse transform.
    #[inline]
    pub fn inverse(&self) -> Rigid {
        let rt = self.r.transpose();
        Rigid {
            r: rt,
            t: -(rt * self.t),
        }
    }

    /// Transform a point.
    #[inline]
    pub fn point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.r * p + self.t
    }

    /// Transform a free vector (rotation only).
    #[inline]
    pub fn vector(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.r * v
    }

    /// Apply the inverse to a point: `r^T (p − t)`.
    #[inline]
    pub fn inv_point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.r.tr_mul(&(p - self.t))
    }

    /// Apply the inverse to a vector.
    #[inline]
    pub fn inv_vector(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.r.tr_mul(v)
    }

    /// The 4×4 homogeneous matrix.
    pub fn to_homogeneous(&self) -> nalgebra::Matrix4<f64> {
        let mut m = nalgebra::Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.r);
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.t);
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_angle_sin_cos_is_exact() {
        for i in -2000..=2000 {
            let x = i as f64 * 5.0e-6 + 1.234e-9;
            let (s, c) = sin_cos(x);
            assert!((s - x.sin()).abs() <= 2.0 * f64::EPSILON * x.abs(), "x={x}");
            assert!((c - x.cos()).abs() <= 2.0 * f64::EPSILON, "x={x}");
        }
    }

    #[test]
    fn rxyz_is_the_product_of_elementary_rotations() {
        let (a, b, c) = (0.3, -0.7, 1.1);
        let m = rot(&Vector3::x(), a) * rot(&Vector3::y(), b) * rot(&Vector3::z(), c);
        assert!((rxyz(a, b, c) - m).norm() < 1e-15);
        let r = rxyz(1e-4, -2e-4, 3e-5);
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-15);
    }

    #[test]
    fn rodrigues_matches_nalgebra() {
        let u = Vector3::new(1.0, 2.0, -0.5).normalize();
        let r = rot(&u, 0.8);
        let n = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(u), 0.8);
        assert!((r - n.matrix()).norm() < 1e-15);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let (a, b, c) = (0.2, -0.4, 0.9);
        let v = Vector3::new(3.0, -1.0, 2.0);
        let d = rxyz_derivatives(a, b, c, &v);
        let h = 1e-6;
        let f = |a: f64, b: f64, c: f64| rxyz(a, b, c) * v;
        let fd = [
            (f(a + h, b, c) - f(a - h, b, c)) / (2.0 * h),
            (f(a, b + h, c) - f(a, b - h, c)) / (2.0 * h),
            (f(a, b, c + h) - f(a, b, c - h)) / (2.0 * h),
        ];
        for k in 0..3 {
            assert!((d[k] - fd[k]).norm() < 1e-8, "{k}");
        }
    }

    #[test]
    fn compose_and_inverse() {
        let a = Rigid {
            r: rxyz(0.1, 0.2, 0.3),
            t: Vector3::new(1.0, 2.0, 3.0),
        };
        let b = Rigid {
            r: rxyz(-0.3, 0.5, 0.1),
            t: Vector3::new(-4.0, 0.0, 7.0),
        };
        let p = Vector3::new(0.5, -0.25, 2.0);
        assert!((a.compose(&b).point(&p) - a.point(&b.point(&p))).norm() < 1e-14);
        assert!((a.inverse().point(&a.point(&p)) - p).norm() < 1e-14);
        assert!((a.inv_point(&a.point(&p)) - p).norm() < 1e-14);
        let h = a.to_homogeneous() * b.to_homogeneous();
        assert!((h - a.compose(&b).to_homogeneous()).norm() < 1e-14);
    }
}
