//! The tool pose and its exact derivatives with respect to the axis positions, without heap
//! allocation: forward-mode differentiation along the chain. Each axis starts a tangent
//! `(∂p/∂q_i, ∂v/∂q_i)` where it acts, and every later transform of the chain carries it
//! along with its rotation. This is what inverse kinematics needs at every step, at about
//! the cost of two poses; [`Kinematics::jacobian`] also gives the error-component
//! derivatives and is the reference these are tested against.

use nalgebra::{Matrix3, Vector3};

use super::chain::{AxisKin, CompiledPdge, Kinematics, ToolPose};
use super::jacobian::PoseDerivative;
use super::lanes::sin_cos_deg;
use super::transform::{rot_sc, rxyz, rxyz_derivatives};
use crate::model::AxisKind;

/// Most axes handled by the allocation-free paths (pose derivatives, fixed-size IK).
pub(crate) const MAX_AXES: usize = 8;

/// One axis acting on a point and a vector, with the derivative of the result with respect
/// to the axis position and the rotation part of the axis transform.
struct Local {
    p: Vector3<f64>,
    v: Vector3<f64>,
    dp: Vector3<f64>,
    dv: Vector3<f64>,
    /// Rotation part of `A_i(q)`, or `None` when it is the identity.
    r: Option<Matrix3<f64>>,
}

impl AxisKin {
    /// PDGE values and their derivatives along the axis (per mm or per degree).
    fn pdge_with_derivs(&self, q: f64) -> ([f64; 6], [f64; 6]) {
        match &self.compiled {
            CompiledPdge::None => ([0.0; 6], [0.0; 6]),
            CompiledPdge::Fast {
                degree,
                scale,
                offset,
                coeff,
            } => {
                let mut e = coeff[*degree];
                let mut d = [0.0; 6];
                for c in 0..6 {
                    let u = scale[c] * q + offset[c];
                    for k in (0..*degree).rev() {
                        d[c] = d[c] * u + e[c];
                        e[c] = e[c] * u + coeff[k][c];
                    }
                    d[c] *= scale[c];
                }
                (e, d)
            }
            CompiledPdge::General => (self.pdge_values(q), self.pdge_derivs(q)),
        }
    }

    /// `A_i(q)` applied to `(x, w)` with the derivative with respect to `q`.
    fn local(&self, q: f64, x: &Vector3<f64>, w: &Vector3<f64>) -> Local {
        let (mut p, mut v) = (*x, *w);
        let (mut dp, mut dv) = (Vector3::zeros(), Vector3::zeros());
        let mut r: Option<Matrix3<f64>> = None;
        if self.has_pdge {
            let (e, de) = self.pdge_with_derivs(q);
            if self.pdge_rotates {
                let re = rxyz(e[3], e[4], e[5]);
                let ds = rxyz_derivatives(e[3], e[4], e[5], &p);
                let dw = rxyz_derivatives(e[3], e[4], e[5], &v);
                dp = ds[0] * de[3] + ds[1] * de[4] + ds[2] * de[5];
                dv = dw[0] * de[3] + dw[1] * de[4] + dw[2] * de[5];
                p = re * p;
                v = re * v;
                r = Some(re);
            }
            p += Vector3::new(e[0], e[1], e[2]);
            dp += Vector3::new(de[0], de[1], de[2]);
        }
        match self.kind {
            AxisKind::Linear => {
                p += self.dir * q;
                dp += self.dir;
                if self.has_loc_rotation {
                    let rl = self.pl.r;
                    p = rl * p;
                    v = rl * v;
                    dp = rl * dp;
                    dv = rl * dv;
                    r = Some(r.map_or(rl, |re| rl * re));
                }
            }
            AxisKind::Rotary => {
                let (s, c) = sin_cos_deg(q);
                // L·J(θ) as one rotation; its θ-derivative maps y to (π/180)·R_L·(u × J y).
                let rlj = self.rot_terms[0] * c + self.rot_terms[1] * s + self.rot_terms[2];
                let rj = rot_sc(&self.dir, s, c);
                let k = std::f64::consts::PI / 180.0;
                let (jp, jv) = (rj * p, rj * v);
                let rl = self.pl.r;
                dp = rlj * dp + rl * (self.dir.cross(&jp) * k);
                dv = rlj * dv + rl * (self.dir.cross(&jv) * k);
                p = rlj * p;
                v = rlj * v;
                r = Some(r.map_or(rlj, |re| rlj * re));
            }
        }
        p += self.pl.t;
        Local { p, v, dp, dv, r }
    }
}

impl Kinematics {
    /// The pose at `q` and its derivatives with respect to every axis position (per mm or per
    /// degree) into `d[..n_axes]`, without allocating. Same values as
    /// [`Kinematics::jacobian`]'s `positions` (to rounding).
    ///
    /// # Panics
    /// If the machine has more than [`MAX_AXES`] axes.
    pub(crate) fn pose_and_position_derivatives(
        &self,
        q: &[f64],
        d: &mut [PoseDerivative; MAX_AXES],
    ) -> ToolPose {
        assert!(
            self.axes.len() <= MAX_AXES,
            "too many axes for the fixed-size path"
        );
        let mut dp = [Vector3::zeros(); MAX_AXES];
        let mut dv = [Vector3::zeros(); MAX_AXES];
        let mut active = [0usize; MAX_AXES];
        let mut n_active = 0;
        let mut p = self.tool_point;
        let mut v = self.tool_dir;
        for &i in self.tool_chain.iter().rev() {
            let loc = self.axes[i].local(q[i], &p, &v);
            if let Some(r) = loc.r {
                for &j in &active[..n_active] {
                    dp[j] = r * dp[j];
                    dv[j] = r * dv[j];
                }
            }
            (p, v) = (loc.p, loc.v);
            dp[i] = loc.dp;
            dv[i] = loc.dv;
            active[n_active] = i;
            n_active += 1;
        }
        for &i in &self.work_chain {
            let a = &self.axes[i];
            // x = A⁻¹·p; ∂(A⁻¹p)/∂q = −R_Aᵀ·(∂A/∂q)(x).
            let (x, w) = self.axes[i].inverse_point_vector(q[i], &p, &v);
            let loc = a.local(q[i], &x, &w);
            let rt = loc.r.map(|r| r.transpose());
            if let Some(rt) = rt {
                for &j in &active[..n_active] {
                    dp[j] = rt * dp[j];
                    dv[j] = rt * dv[j];
                }
            }
            let (own_p, own_v) = match rt {
                Some(rt) => (-(rt * loc.dp), -(rt * loc.dv)),
                None => (-loc.dp, -loc.dv),
            };
            (p, v) = (x, w);
            dp[i] = own_p;
            dv[i] = own_v;
            active[n_active] = i;
            n_active += 1;
        }
        p -= self.work_point;
        for i in 0..self.axes.len() {
            d[i] = [dp[i].x, dp[i].y, dp[i].z, dv[i].x, dv[i].y, dv[i].z];
        }
        ToolPose { tip: p, axis: v }
    }
}

impl AxisKin {
    /// `A_i(q)⁻¹` applied to a point and a vector (the one-lane kernel).
    fn inverse_point_vector(
        &self,
        q: f64,
        p: &Vector3<f64>,
        v: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let mut pp = [[p.x], [p.y], [p.z]];
        let mut vv = [[v.x], [v.y], [v.z]];
        self.apply_inv_lanes::<1>(&[q], &mut pp, &mut vv);
        (
            Vector3::new(pp[0][0], pp[1][0], pp[2][0]),
            Vector3::new(vv[0][0], vv[1][0], vv[2][0]),
        )
    }
}
