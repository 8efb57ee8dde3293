//! The exact kinematic chain of the power-skiving machine (\[R3\]), with the
//! four workpiece set-up errors as parameters:
//!
//! ```text
//! M_xg' = TX(x) · TZ(−h) · RZ(c) · TX(δgx) · TY(δgy) · RY(εxz) · RX(εzy)   (workpiece, actual)
//! M_xt  = TY(y) · TZ(z) · TZ(L) · RX(a) · RY(b) · TZ(−L)                  (tool)
//! M_gt  = M_xg'⁻¹ · M_xt                                                 (tool in workpiece)
//! ```
//!
//! Everything is exact (rotations by `sin`/`cos` of the full angle); the
//! small-angle forms live only in [`super::closed_form`].

use nalgebra::Vector3;

use crate::kinematics::transform::{Rigid, rot};

/// Machine dimensions that enter the chain (all mm, all finite; `rt`, `rg`
/// positive). Build with [`Geometry::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    h: f64,
    l: f64,
    rt: f64,
    rg: f64,
}

/// Why a [`Geometry`] cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GeometryError {
    /// A number is not finite.
    #[error("{name} = {} is not a finite number", crate::limits::fmt_message_number(*.value))]
    NotFinite {
        /// The quantity.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A length is not positive.
    #[error("{name} = {} mm must be positive", crate::limits::fmt_message_number(*.value))]
    NotPositive {
        /// The quantity.
        name: &'static str,
        /// Its value, mm.
        value: f64,
    },
}

impl Geometry {
    /// `h` clamping height of the workpiece top face below the machine
    /// origin, `l` swing length of the tool head, `rt` tool tip radius, `rg`
    /// workpiece (blank) radius; all mm.
    pub fn new(h: f64, l: f64, rt: f64, rg: f64) -> Result<Self, GeometryError> {
        for (name, value) in [("h", h), ("L", l), ("rt", rt), ("rg", rg)] {
            if !value.is_finite() {
                return Err(GeometryError::NotFinite { name, value });
            }
        }
        for (name, value) in [("rt", rt), ("rg", rg)] {
            if value <= 0.0 {
                return Err(GeometryError::NotPositive { name, value });
            }
        }
        Ok(Self { h, l, rt, rg })
    }

    /// Clamping height `h`, mm.
    pub fn h(&self) -> f64 {
        self.h
    }
    /// Swing length `L`, mm.
    pub fn l(&self) -> f64 {
        self.l
    }
    /// Tool tip radius `rt`, mm.
    pub fn rt(&self) -> f64 {
        self.rt
    }
    /// Workpiece radius `rg`, mm.
    pub fn rg(&self) -> f64 {
        self.rg
    }
}

/// Machine axis positions: `x`, `y`, `z` in mm, `a`, `b`, `c` in degrees.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisPositions {
    /// X, mm.
    pub x: f64,
    /// Y, mm.
    pub y: f64,
    /// Z, mm.
    pub z: f64,
    /// A (tool swivel about x), degrees.
    pub a: f64,
    /// B (tool swivel about y), degrees.
    pub b: f64,
    /// C (rotary table), degrees.
    pub c: f64,
}

/// The four workpiece set-up errors: offsets `dgx`, `dgy` (mm, along the
/// table's x and y after `RZ(c)`), tilts `exz` (about y, rad) and `ezy`
/// (about x, rad).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct SetupError {
    /// Offset along the table's x, mm.
    pub dgx: f64,
    /// Offset along the table's y, mm.
    pub dgy: f64,
    /// Tilt about y, rad.
    pub exz: f64,
    /// Tilt about x, rad.
    pub ezy: f64,
}

impl SetupError {
    /// Parameter names in the order of [`SetupError::to_array`].
    pub const NAMES: [&'static str; 4] = ["dgx", "dgy", "exz", "ezy"];

    /// `[dgx, dgy, exz, ezy]`.
    pub fn to_array(self) -> [f64; 4] {
        [self.dgx, self.dgy, self.exz, self.ezy]
    }

    /// From `[dgx, dgy, exz, ezy]`.
    pub fn from_array(a: [f64; 4]) -> Self {
        Self {
            dgx: a[0],
            dgy: a[1],
            exz: a[2],
            ezy: a[3],
        }
    }

    /// From a slice of at least four values `[dgx, dgy, exz, ezy, …]`.
    pub(crate) fn from_slice(t: &[f64]) -> Self {
        Self::from_array([t[0], t[1], t[2], t[3]])
    }
}

/// `M_xg'`: the actual workpiece frame in the machine frame.
pub fn workpiece_frame(x: f64, c_deg: f64, h: f64, e: &SetupError) -> Rigid {
    table_frame(x, c_deg, h)
        .compose(&Rigid::translation(Vector3::new(e.dgx, e.dgy, 0.0)))
        .compose(&Rigid::rotation(&Vector3::y(), e.exz))
        .compose(&Rigid::rotation(&Vector3::x(), e.ezy))
}

/// `TX(x) · TZ(−h) · RZ(c)`: the nominal workpiece frame.
fn table_frame(x: f64, c_deg: f64, h: f64) -> Rigid {
    Rigid {
        r: rot(&Vector3::z(), c_deg.to_radians()),
        t: Vector3::new(x, 0.0, -h),
    }
}

/// `M_xt`: the tool frame in the machine frame.
pub fn tool_frame(y: f64, z: f64, a_deg: f64, b_deg: f64, l: f64) -> Rigid {
    Rigid::translation(Vector3::new(0.0, y, z + l))
        .compose(&Rigid::rotation(&Vector3::x(), a_deg.to_radians()))
        .compose(&Rigid::rotation(&Vector3::y(), b_deg.to_radians()))
        .compose(&Rigid::translation(Vector3::new(0.0, 0.0, -l)))
}

/// `M_gt = M_xg'⁻¹ · M_xt`: the tool frame in the actual workpiece frame.
pub fn tool_in_workpiece(q: &AxisPositions, g: &Geometry, e: &SetupError) -> Rigid {
    workpiece_frame(q.x, q.c, g.h, e)
        .inverse()
        .compose(&tool_frame(q.y, q.z, q.a, q.b, g.l))
}

/// A tool point `tp` (tool frame, mm) in the workpiece frame, `gP = M_gt·tP`,
/// with its exact derivatives with respect to `[dgx, dgy, exz, ezy]`.
///
/// With `u = (TX(x)·TZ(−h)·RZ(c))⁻¹·M_xt·tP`, `q = u − (δgx, δgy, 0)`,
/// `w = RY(εxz)ᵀ·q` and `gP = RX(εzy)ᵀ·w`:
/// `∂gP/∂δgx = −RX(εzy)ᵀRY(εxz)ᵀ·eₓ`, `∂gP/∂δgy` likewise with `e_y`,
/// `∂gP/∂εxz = −RX(εzy)ᵀ·(e_y × w)`, `∂gP/∂εzy = −eₓ × gP`.
pub fn point_with_derivatives(
    q: &AxisPositions,
    g: &Geometry,
    e: &SetupError,
    tp: &Vector3<f64>,
) -> (Vector3<f64>, [Vector3<f64>; 4]) {
    let p = tool_frame(q.y, q.z, q.a, q.b, g.l).point(tp);
    let u = table_frame(q.x, q.c, g.h).inv_point(&p);
    let qv = u - Vector3::new(e.dgx, e.dgy, 0.0);
    let ry = rot(&Vector3::y(), e.exz);
    let rx = rot(&Vector3::x(), e.ezy);
    let w = ry.tr_mul(&qv);
    let gp = rx.tr_mul(&w);
    let r = rx.transpose() * ry.transpose();
    let d = [
        -r.column(0).into_owned(),
        -r.column(1).into_owned(),
        -rx.tr_mul(&Vector3::y().cross(&w)),
        -Vector3::x().cross(&gp),
    ];
    (gp, d)
}

/// The derivative of `gP` with respect to the machine coordinate `y` (`axis
/// = 1`) or `z` (`axis = 2`) at fixed set-up errors: the machine direction
/// seen in the workpiece frame.
pub fn probe_direction(
    q: &AxisPositions,
    g: &Geometry,
    e: &SetupError,
    axis: usize,
) -> Vector3<f64> {
    let mut d = Vector3::zeros();
    d[axis] = 1.0;
    workpiece_frame(q.x, q.c, g.h, e).inv_vector(&d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> Geometry {
        Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap()
    }

    fn sample() -> (AxisPositions, SetupError) {
        (
            AxisPositions {
                x: 1.5,
                y: 47.0,
                z: -91.0,
                a: 12.0,
                b: -7.0,
                c: 33.0,
            },
            SetupError {
                dgx: 0.03,
                dgy: -0.04,
                exz: 2.5e-4,
                ezy: -1.7e-4,
            },
        )
    }

    /// The chain as a product of homogeneous 4×4 matrices, built directly
    /// from the factors of the patent's chain (`docs/references.md` [R3]; independent of `Rigid::compose`).
    fn chain_by_matrices(
        q: &AxisPositions,
        g: &Geometry,
        e: &SetupError,
    ) -> nalgebra::Matrix4<f64> {
        use nalgebra::Matrix4;
        let t = |x: f64, y: f64, z: f64| Matrix4::new_translation(&Vector3::new(x, y, z));
        let r = |axis: Vector3<f64>, ang: f64| {
            Matrix4::from_axis_angle(&nalgebra::Unit::new_normalize(axis), ang)
        };
        let xg = t(q.x, 0.0, 0.0)
            * t(0.0, 0.0, -g.h())
            * r(Vector3::z(), q.c.to_radians())
            * t(e.dgx, 0.0, 0.0)
            * t(0.0, e.dgy, 0.0)
            * r(Vector3::y(), e.exz)
            * r(Vector3::x(), e.ezy);
        let xt = t(0.0, q.y, 0.0)
            * t(0.0, 0.0, q.z)
            * t(0.0, 0.0, g.l())
            * r(Vector3::x(), q.a.to_radians())
            * r(Vector3::y(), q.b.to_radians())
            * t(0.0, 0.0, -g.l());
        xg.try_inverse().unwrap() * xt
    }

    #[test]
    fn chain_matches_the_spec_product() {
        let g = geometry();
        let (q, e) = sample();
        let m = tool_in_workpiece(&q, &g, &e).to_homogeneous();
        assert!((m - chain_by_matrices(&q, &g, &e)).norm() < 1e-12);
        let tp = Vector3::new(0.0, -g.rt(), 0.0);
        let (gp, _) = point_with_derivatives(&q, &g, &e, &tp);
        let h = chain_by_matrices(&q, &g, &e) * nalgebra::Vector4::new(0.0, -g.rt(), 0.0, 1.0);
        assert!((gp - h.xyz()).norm() < 1e-12);
    }

    #[test]
    fn nominal_face_touch_is_on_the_top_face_at_z_minus_h() {
        // With no set-up error and a = b = 0, the tool face centre at machine
        // z = −h lies in the workpiece top face.
        let g = geometry();
        let q = AxisPositions {
            x: 0.0,
            y: 20.0,
            z: -80.0,
            ..Default::default()
        };
        let (gp, _) = point_with_derivatives(&q, &g, &SetupError::default(), &Vector3::zeros());
        assert!((gp - Vector3::new(0.0, 20.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn derivatives_match_central_differences() {
        let g = geometry();
        let (q, e) = sample();
        let tp = Vector3::new(0.0, -g.rt(), 0.0);
        let (_, d) = point_with_derivatives(&q, &g, &e, &tp);
        let base = e.to_array();
        for k in 0..4 {
            let step = if k < 2 { 1e-4 } else { 1e-6 };
            let mut p = base;
            let mut m = base;
            p[k] += step;
            m[k] -= step;
            let (gp, _) = point_with_derivatives(&q, &g, &SetupError::from_array(p), &tp);
            let (gm, _) = point_with_derivatives(&q, &g, &SetupError::from_array(m), &tp);
            let fd = (gp - gm) / (2.0 * step);
            assert!(
                (fd - d[k]).norm() < 1e-6 * d[k].norm().max(1.0),
                "{k}: {fd} vs {}",
                d[k]
            );
        }
    }

    #[test]
    fn probe_direction_matches_a_coordinate_step() {
        let g = geometry();
        let (q, e) = sample();
        let tp = Vector3::zeros();
        for axis in [1usize, 2] {
            let mut q2 = q;
            if axis == 1 {
                q2.y += 0.5;
            } else {
                q2.z += 0.5;
            }
            let (a, _) = point_with_derivatives(&q, &g, &e, &tp);
            let (b, _) = point_with_derivatives(&q2, &g, &e, &tp);
            assert!(((b - a) / 0.5 - probe_direction(&q, &g, &e, axis)).norm() < 1e-12);
        }
    }

    #[test]
    fn geometry_rejects_bad_values() {
        assert!(Geometry::new(80.0, 150.0, 0.0, 60.0).is_err());
        assert!(Geometry::new(f64::NAN, 150.0, 40.0, 60.0).is_err());
        assert!(Geometry::new(80.0, 150.0, 40.0, -1.0).is_err());
    }
}
