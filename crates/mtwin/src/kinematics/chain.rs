//! Forward kinematics of a [`Machine`] with its geometric errors, exact (docs/machine-model.md):
//! `A_i(q) = P_i·L_i·J_i(q)·E_i(q)`, `T_WT = T_MW⁻¹·T_MT`.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::lanes::sin_cos_deg;
use super::transform::{Rigid, rot_sc};
use crate::model::{AxisKind, ErrorFunction, Machine};

/// Tool tip (mm) and unit tool axis in the workpiece frame W.
///
/// Laid out as six `f64` in the order `x, y, z, i, j, k` (`repr(C)` of two
/// `repr(C)` vectors), so that a slice of poses can be viewed as rows of a flat
/// (N, 6) float64 buffer: the Python binding computes straight into NumPy's array.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct ToolPose {
    /// Tool tip position in W, mm.
    pub tip: Vector3<f64>,
    /// Unit tool-axis direction in W (from the tip towards the spindle).
    pub axis: Vector3<f64>,
}

/// Largest polynomial degree evaluated on the fast path.
const FAST_DEGREE: usize = 7;

/// The six PDGE functions of an axis compiled for speed: where every component is a
/// constant, power polynomial or Chebyshev series of degree ≤ 7, all six are held as
/// power series in one argument `u = scale·q + offset` and evaluated together by Horner's
/// rule. (A Chebyshev series is converted to the power basis in its normalised argument
/// `u ∈ [−1, 1]`, which is well conditioned at these degrees.) Tables fall back to the
/// general path.
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)] // inline on purpose: it is read on every pose
pub(crate) enum CompiledPdge {
    /// No PDGE at all.
    None,
    /// Power series: value_c = Σ_k coeff[k][c] · u_c^k with u_c = scale[c]·q + offset[c].
    Fast {
        degree: usize,
        scale: [f64; 6],
        offset: [f64; 6],
        coeff: [[f64; 6]; FAST_DEGREE + 1],
    },
    /// Anything else: evaluate each function.
    General,
}

impl CompiledPdge {
    fn new(pdge: &[Option<ErrorFunction>; 6], travel: [f64; 2]) -> Self {
        if pdge.iter().all(|f| f.as_ref().is_none_or(|f| f.is_zero())) {
            return CompiledPdge::None;
        }
        let mut degree = 0;
        let mut scale = [0.0; 6];
        let mut offset = [0.0; 6];
        let mut coeff = [[0.0; 6]; FAST_DEGREE + 1];
        for (c, f) in pdge.iter().enumerate() {
            match f {
                None => {}
                Some(ErrorFunction::Constant(v)) => coeff[0][c] = *v,
                Some(ErrorFunction::Poly(p)) if p.len() <= FAST_DEGREE + 1 => {
                    scale[c] = 1.0;
                    for (k, &v) in p.iter().enumerate() {
                        coeff[k][c] = v;
                    }
                    degree = degree.max(p.len() - 1);
                }
                Some(ErrorFunction::Cheb(ch)) if ch.len() <= FAST_DEGREE + 1 => {
                    let w = travel[1] - travel[0];
                    scale[c] = 2.0 / w;
                    offset[c] = -(travel[0] + travel[1]) / w;
                    // T_k in the power basis by T_{k+1} = 2u·T_k − T_{k−1}.
                    let mut t_prev = [0.0; FAST_DEGREE + 1];
                    let mut t_cur = [0.0; FAST_DEGREE + 1];
                    t_cur[0] = 1.0;
                    for (k, &ck) in ch.iter().enumerate() {
                        if k == 1 {
                            t_prev = t_cur;
                            t_cur = [0.0; FAST_DEGREE + 1];
                            t_cur[1] = 1.0;
                        } else if k > 1 {
                            let mut next = [0.0; FAST_DEGREE + 1];
                            for j in 0..FAST_DEGREE {
                                next[j + 1] += 2.0 * t_cur[j];
                            }
                            for j in 0..=FAST_DEGREE {
                                next[j] -= t_prev[j];
                            }
                            t_prev = t_cur;
                            t_cur = next;
                        }
                        for j in 0..=FAST_DEGREE {
                            coeff[j][c] += ck * t_cur[j];
                        }
                    }
                    degree = degree.max(ch.len() - 1);
                }
                Some(_) => return CompiledPdge::General,
            }
        }
        CompiledPdge::Fast {
            degree,
            scale,
            offset,
            coeff,
        }
    }
}

/// One axis, compiled for fast evaluation.
#[derive(Debug, Clone)]
pub(crate) struct AxisKin {
    pub(crate) name: String,
    pub(crate) kind: AxisKind,
    pub(crate) dir: Vector3<f64>,
    pub(crate) travel: [f64; 2],
    /// `P_i·L_i` (placement in the parent and location error).
    pub(crate) pl: Rigid,
    /// `P_i` translation `o_i − o_parent`.
    pub(crate) p: Vector3<f64>,
    /// Location error values `EX0, EY0, EZ0, EA0, EB0, EC0`.
    pub(crate) loc: [f64; 6],
    pub(crate) has_loc_rotation: bool,
    pub(crate) pdge: [Option<ErrorFunction>; 6],
    pub(crate) has_pdge: bool,
    /// Some rotational PDGE component (EA, EB, EC) is not zero.
    pub(crate) pdge_rotates: bool,
    pub(crate) compiled: CompiledPdge,
    /// For a rotary axis, `[M₀, M₁, M₂]` with `L_i·J_i(θ) = cos θ·M₀ + sin θ·M₁ + M₂`
    /// (rotation parts; Rodrigues with the location rotation folded in).
    pub(crate) rot_terms: [Matrix3<f64>; 3],
}

impl AxisKin {
    /// Values of the six PDGE components at `q`.
    #[inline]
    pub(crate) fn pdge_values(&self, q: f64) -> [f64; 6] {
        let mut e = [0.0; 6];
        match &self.compiled {
            CompiledPdge::None => {}
            CompiledPdge::Fast {
                degree,
                scale,
                offset,
                coeff,
            } => {
                let mut u = [0.0; 6];
                for c in 0..6 {
                    u[c] = scale[c] * q + offset[c];
                }
                e = coeff[*degree];
                for k in (0..*degree).rev() {
                    for c in 0..6 {
                        e[c] = e[c] * u[c] + coeff[k][c];
                    }
                }
            }
            CompiledPdge::General => {
                for (k, f) in self.pdge.iter().enumerate() {
                    if let Some(f) = f {
                        e[k] = f.eval(q, self.travel);
                    }
                }
            }
        }
        e
    }

    /// Derivatives of the six PDGE components with respect to `q`.
    pub(crate) fn pdge_derivs(&self, q: f64) -> [f64; 6] {
        let mut e = [0.0; 6];
        for (k, f) in self.pdge.iter().enumerate() {
            if let Some(f) = f {
                e[k] = f.deriv(q, self.travel);
            }
        }
        e
    }

    /// `E_i(q)`.
    #[inline]
    pub(crate) fn e_transform(&self, q: f64) -> Rigid {
        if !self.has_pdge {
            return Rigid::identity();
        }
        let e = self.pdge_values(q);
        Rigid::from_error(Vector3::new(e[0], e[1], e[2]), e[3], e[4], e[5])
    }

    /// `J_i(q)`.
    #[inline]
    pub(crate) fn j_transform(&self, q: f64) -> Rigid {
        match self.kind {
            AxisKind::Linear => Rigid::translation(self.dir * q),
            AxisKind::Rotary => {
                let (s, c) = sin_cos_deg(q);
                Rigid {
                    r: rot_sc(&self.dir, s, c),
                    t: Vector3::zeros(),
                }
            }
        }
    }

    /// `A_i(q) = P_i·L_i·J_i(q)·E_i(q)`.
    pub(crate) fn transform(&self, q: f64) -> Rigid {
        self.pl
            .compose(&self.j_transform(q))
            .compose(&self.e_transform(q))
    }
}

/// The kinematics of one machine with its current geometric errors, compiled from a
/// [`Machine`]. Axis positions are always given in the machine's axis order (mm, degree).
///
/// Build a new one after changing the machine's errors (it is cheap).
#[derive(Debug, Clone)]
pub struct Kinematics {
    pub(crate) axes: Vec<AxisKin>,
    pub(crate) tool_chain: Vec<usize>,
    pub(crate) work_chain: Vec<usize>,
    /// `tip − o_last_tool_axis`: the tool tip in the last tool-chain frame.
    pub(crate) tool_point: Vector3<f64>,
    pub(crate) tool_dir: Vector3<f64>,
    /// `origin − o_last_workpiece_axis`.
    pub(crate) work_point: Vector3<f64>,
}

impl Kinematics {
    /// The actual machine: nominal geometry plus every geometric error of `machine`.
    pub fn new(machine: &Machine) -> Self {
        let mut axes: Vec<AxisKin> = machine
            .axes
            .iter()
            .map(|a| {
                let loc = a.errors.location;
                let l =
                    Rigid::from_error(Vector3::new(loc[0], loc[1], loc[2]), loc[3], loc[4], loc[5]);
                let u = a.direction;
                let uu = u * u.transpose();
                let rot_terms = [l.r - l.r * uu, l.r * u.cross_matrix(), l.r * uu];
                let pdge_rotates = a.errors.pdge[3..]
                    .iter()
                    .any(|f| f.as_ref().is_some_and(|f| !f.is_zero()));
                AxisKin {
                    name: a.name.clone(),
                    kind: a.kind,
                    dir: a.direction,
                    travel: a.travel,
                    pl: l,
                    p: Vector3::zeros(),
                    loc,
                    has_loc_rotation: loc[3] != 0.0 || loc[4] != 0.0 || loc[5] != 0.0,
                    pdge: a.errors.pdge.clone(),
                    has_pdge: a.errors.has_pdge(),
                    pdge_rotates,
                    compiled: CompiledPdge::new(&a.errors.pdge, a.travel),
                    rot_terms,
                }
            })
            .collect();
        for chain in [&machine.tool_chain, &machine.workpiece_chain] {
            let mut parent_origin = Vector3::zeros();
            for &i in chain.iter() {
                let o = machine.axes[i].origin;
                let p = o - parent_origin;
                axes[i].p = p;
                axes[i].pl = Rigid::translation(p).compose(&axes[i].pl);
                parent_origin = o;
            }
        }
        let last = |chain: &[usize]| {
            chain
                .last()
                .map_or(Vector3::zeros(), |&i| machine.axes[i].origin)
        };
        Kinematics {
            axes,
            tool_chain: machine.tool_chain.clone(),
            work_chain: machine.workpiece_chain.clone(),
            tool_point: machine.tool_tip - last(&machine.tool_chain),
            tool_dir: machine.tool_direction,
            work_point: machine.workpiece_origin - last(&machine.workpiece_chain),
        }
    }

    /// The nominal machine: `machine`'s geometry with every error removed.
    pub fn nominal(machine: &Machine) -> Self {
        Self::new(&machine.nominal())
    }

    /// Number of axes (length of every position vector).
    pub fn n_axes(&self) -> usize {
        self.axes.len()
    }

    /// Axis names in position-vector order.
    pub fn axis_names(&self) -> Vec<&str> {
        self.axes.iter().map(|a| a.name.as_str()).collect()
    }

    /// Tool tip and tool axis in W at axis positions `q` (mm, degree).
    #[inline]
    pub fn pose(&self, q: &[f64]) -> ToolPose {
        debug_assert_eq!(q.len(), self.axes.len());
        let (p, v) = self.pose_lanes::<1>(|i| [q[i]]);
        ToolPose {
            tip: Vector3::new(p[0][0], p[1][0], p[2][0]),
            axis: Vector3::new(v[0][0], v[1][0], v[2][0]),
        }
    }

    /// Poses for many positions: `qs` holds `n_axes` values per pose, row after row.
    /// Runs in parallel (rayon); see [`Kinematics::par_poses_into`]. The result is
    /// bit-for-bit that of single calls.
    pub fn poses(&self, qs: &[f64]) -> Vec<ToolPose> {
        let n = self.axes.len().max(1);
        let zero = ToolPose {
            tip: Vector3::zeros(),
            axis: Vector3::zeros(),
        };
        let mut out = vec![zero; qs.len() / n];
        self.par_poses_into(&qs[..out.len() * n], &mut out);
        out
    }

    /// [`Kinematics::poses_into`] in parallel (rayon) over blocks of 1024 poses,
    /// writing into a caller-owned buffer so repeated batches allocate nothing.
    ///
    /// # Panics
    /// If `out.len() · n_axes ≠ qs.len()`.
    pub fn par_poses_into(&self, qs: &[f64], out: &mut [ToolPose]) {
        const BLOCK: usize = 1024;
        let n = self.axes.len();
        if n == 0 {
            return self.poses_into(qs, out);
        }
        assert_eq!(
            qs.len(),
            out.len() * n,
            "par_poses_into: {} positions for {} poses of {n} axes",
            qs.len(),
            out.len()
        );
        if crate::par::sequential() {
            return self.poses_into(qs, out);
        }
        out.par_chunks_mut(BLOCK)
            .zip(qs.par_chunks(n * BLOCK))
            .for_each(|(o, q)| self.poses_into(q, o));
    }

    /// `T_MT(q)`: the tool frame in M.
    pub fn tool_frame(&self, q: &[f64]) -> Rigid {
        let mut g = Rigid::identity();
        for &i in &self.tool_chain {
            g = g.compose(&self.axes[i].transform(q[i]));
        }
        g.compose(&Rigid::translation(self.tool_point))
    }

    /// `T_MW(q)`: the workpiece frame in M.
    pub fn workpiece_frame(&self, q: &[f64]) -> Rigid {
        let mut g = Rigid::identity();
        for &i in &self.work_chain {
            g = g.compose(&self.axes[i].transform(q[i]));
        }
        g.compose(&Rigid::translation(self.work_point))
    }

    /// `T_WT(q) = T_MW⁻¹·T_MT`: the tool frame in W (full transform).
    pub fn tool_in_workpiece(&self, q: &[f64]) -> Rigid {
        self.workpiece_frame(q)
            .inverse()
            .compose(&self.tool_frame(q))
    }

    /// The transform `A_i(q)` of axis `i` alone (its frame in its parent's frame).
    pub fn axis_transform(&self, i: usize, q: f64) -> Rigid {
        self.axes[i].transform(q)
    }

    /// Travel of axis `i`.
    pub fn travel(&self, i: usize) -> [f64; 2] {
        self.axes[i].travel
    }

    /// Kind of axis `i`.
    pub fn kind(&self, i: usize) -> AxisKind {
        self.axes[i].kind
    }

    /// Name of axis `i`.
    pub fn axis_name(&self, i: usize) -> &str {
        &self.axes[i].name
    }

    /// Location error values of axis `i` in [`Component::ALL`](crate::model::Component::ALL) order.
    pub fn location(&self, i: usize) -> [f64; 6] {
        self.axes[i].loc
    }
}
