//! Exact Jacobians of the tool pose in W with respect to the error components of every axis
//! and to the axis positions.
//!
//! Each derivative is the exact derivative of the full (non-linearised) chain: a perturbation
//! of a component of `E_i` or `L_i` is mapped through the actual frames of the chain, and
//! for the workpiece chain through `T_MW⁻¹` (`d(T⁻¹) = −T⁻¹·dT·T⁻¹`).

use nalgebra::Vector3;

use super::chain::{AxisKin, Kinematics, ToolPose};
use super::transform::{Rigid, rxyz_derivatives};
use crate::model::AxisKind;

/// Number of error slots per axis in [`PoseJacobian::components`]: the six PDGE components
/// (slots 0..6, [`crate::model::Component`] order) then the six location components (6..12).
pub const SLOTS: usize = 12;

/// Derivatives of the tool pose in W, `[∂tip_x, ∂tip_y, ∂tip_z, ∂axis_i, ∂axis_j, ∂axis_k]`.
pub type PoseDerivative = [f64; 6];

/// The pose and its exact derivatives at one set of axis positions.
#[derive(Debug, Clone)]
pub struct PoseJacobian {
    /// The pose itself.
    pub pose: ToolPose,
    /// For every axis (machine order) and every slot (see [`SLOTS`]): the derivative of the
    /// pose with respect to that error component's value (per mm or per rad).
    pub components: Vec<[PoseDerivative; SLOTS]>,
    /// For every axis: the derivative of the pose with respect to its position (per mm or per
    /// degree), including the change of its own PDGEs along the axis.
    pub positions: Vec<PoseDerivative>,
}

#[derive(Clone, Copy)]
struct Frames {
    /// M ← parent frame (before `P_i·L_i`), rotation only is used.
    prev: Rigid,
    /// M ← frame after `L_i`.
    after_l: Rigid,
    /// M ← frame after `J_i`.
    after_j: Rigid,
    /// M ← axis frame (after `E_i`).
    after_e: Rigid,
}

fn frames(kin: &Kinematics, chain: &[usize], q: &[f64]) -> (Vec<(usize, Frames)>, Rigid) {
    let mut g = Rigid::identity();
    let mut out = Vec::with_capacity(chain.len());
    for &i in chain {
        let a = &kin.axes[i];
        let prev = g;
        let after_l = g.compose(&a.pl);
        let after_j = after_l.compose(&a.j_transform(q[i]));
        let after_e = after_j.compose(&a.e_transform(q[i]));
        out.push((
            i,
            Frames {
                prev,
                after_l,
                after_j,
                after_e,
            },
        ));
        g = after_e;
    }
    (out, g)
}

fn pack(
    sign: f64,
    rt: &nalgebra::Matrix3<f64>,
    dp: Vector3<f64>,
    dv: Vector3<f64>,
) -> PoseDerivative {
    let p = rt * dp * sign;
    let v = rt * dv * sign;
    [p.x, p.y, p.z, v.x, v.y, v.z]
}

fn unit(k: usize) -> Vector3<f64> {
    let mut v = Vector3::zeros();
    v[k] = 1.0;
    v
}

/// Fill the derivatives of one axis. `pm`, `om` are the M coordinates of the body-fixed point
/// and vector being moved; `rt = R_MWᵀ`; `sign` +1 for the tool chain, −1 for the workpiece chain.
#[allow(clippy::too_many_arguments)]
fn axis_derivatives(
    a: &AxisKin,
    q: f64,
    f: &Frames,
    pm: &Vector3<f64>,
    om: &Vector3<f64>,
    rt: &nalgebra::Matrix3<f64>,
    sign: f64,
    comps: &mut [PoseDerivative; SLOTS],
    dq: &mut PoseDerivative,
) {
    // PDGE components, in the frame after J.
    let e = a.pdge_values(q);
    let s = f.after_e.inv_point(pm);
    let w = f.after_e.inv_vector(om);
    let rj = f.after_j.r;
    let ds = rxyz_derivatives(e[3], e[4], e[5], &s);
    let dw = rxyz_derivatives(e[3], e[4], e[5], &w);
    let mut local_p = [Vector3::zeros(); 6];
    let mut local_v = [Vector3::zeros(); 6];
    for k in 0..3 {
        local_p[k] = unit(k);
        local_p[3 + k] = ds[k];
        local_v[3 + k] = dw[k];
    }
    for k in 0..6 {
        comps[k] = pack(sign, rt, rj * local_p[k], rj * local_v[k]);
    }
    // Location components, in the parent frame (P is a pure translation).
    let x = f.after_l.inv_point(pm);
    let xv = f.after_l.inv_vector(om);
    let l = a.loc;
    let dx = rxyz_derivatives(l[3], l[4], l[5], &x);
    let dxv = rxyz_derivatives(l[3], l[4], l[5], &xv);
    let rp = f.prev.r;
    for k in 0..3 {
        comps[6 + k] = pack(sign, rt, rp * unit(k), Vector3::zeros());
        comps[9 + k] = pack(sign, rt, rp * dx[k], rp * dxv[k]);
    }
    // Axis position: the joint motion plus the change of the PDGEs along the axis.
    let de = a.pdge_derivs(q);
    let mut d_es = Vector3::zeros(); // in the frame after J
    let mut d_ew = Vector3::zeros();
    for k in 0..6 {
        d_es += local_p[k] * de[k];
        d_ew += local_v[k] * de[k];
    }
    let (jp, jv) = match a.kind {
        AxisKind::Linear => (f.after_l.r * a.dir, Vector3::zeros()),
        AxisKind::Rotary => {
            // x = R_J·y with y the coordinates after J; d/dq = (π/180)·d × x, in the frame after L.
            let k = std::f64::consts::PI / 180.0;
            (
                f.after_l.r * (a.dir.cross(&x) * k),
                f.after_l.r * (a.dir.cross(&xv) * k),
            )
        }
    };
    *dq = pack(sign, rt, jp + rj * d_es, jv + rj * d_ew);
}

impl Kinematics {
    /// The pose at `q` and its exact derivatives with respect to every error component of
    /// every axis and to every axis position.
    pub fn jacobian(&self, q: &[f64]) -> PoseJacobian {
        let n = self.axes.len();
        let (tool_frames, g_t) = frames(self, &self.tool_chain, q);
        let (work_frames, g_w) = frames(self, &self.work_chain, q);
        let t_mt = g_t.compose(&Rigid::translation(self.tool_point));
        let t_mw = g_w.compose(&Rigid::translation(self.work_point));
        let pm = t_mt.t;
        let om = t_mt.r * self.tool_dir;
        let pose = ToolPose {
            tip: t_mw.inv_point(&pm),
            axis: t_mw.inv_vector(&om),
        };
        let rt = t_mw.r.transpose();
        let mut components = vec![[[0.0; 6]; SLOTS]; n];
        let mut positions = vec![[0.0; 6]; n];
        for (chain, sign) in [(&tool_frames, 1.0), (&work_frames, -1.0)] {
            for (i, f) in chain {
                axis_derivatives(
                    &self.axes[*i],
                    q[*i],
                    f,
                    &pm,
                    &om,
                    &rt,
                    sign,
                    &mut components[*i],
                    &mut positions[*i],
                );
            }
        }
        PoseJacobian {
            pose,
            components,
            positions,
        }
    }
}
