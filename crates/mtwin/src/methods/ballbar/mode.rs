//! The four measurement modes as measurement models on the exact kinematics.
//!
//! In every mode one rotary axis turns and every other axis stands still.
//! The tool ball B1 is fixed in M; the workpiece ball B2 is set on the table
//! at angle 0 a bar length `ℓ` from B1 (along −y in modes 1–2, along +x in
//! modes 3–4), so at angle α it is at
//!
//! ```text
//! B2(α) = X(α)·X(0)⁻¹·B2(0),     X(q) = A_1(q_1)·…·A_k(q_k)
//! ```
//!
//! with `X` the workpiece chain from the base up to the moving axis
//! (`A_i = P_i·L_i·J_i·E_i`, docs/machine-model.md; the axes beyond the moving one cancel),
//! and the instrument reads `|B2(α) − B1|`. Nothing is linearised. The
//! Jacobian with respect to the location errors is exact: for a component
//! of `L_i`, `∂X/∂p = Pre_i·∂L_i·Post_i` with `Pre_i = A_1…A_{i−1}·P_i` and
//! `Post_i = J_i·E_i·A_{i+1}…A_k`, and
//! `∂B2(α) = Pre_i(α)·∂L_i·Post_i(α)·z − U·Pre_i(0)·∂L_i·Post_i(0)·z` with
//! `U = X(α)·X(0)⁻¹`, `z = X(0)⁻¹·B2(0)`.
//!
//! Positions of the balls are given relative to the *pivot*, the nominal
//! intersection of the A and C lines (the origin of M on the bundled
//! machine).

use std::ops::Range;

use faer::MatMut;
use nalgebra::Vector3;

use super::data::ModeData;
use super::setup::SetupError;
use super::{Pige, Piges, closest_point, rotary_named};
use crate::fit::{BlockLayout, Model, Parameter};
use crate::kinematics::transform::rxyz_derivatives;
use crate::kinematics::{Kinematics, Rigid};
use crate::model::Machine;

/// One of the four measurement modes of \[R1\] (docs/references.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BallbarMode {
    /// A turns; B1 on the A/C intersection; bar along −y. Sees EY0A, EZ0A.
    One,
    /// A turns; B1 `ZB1C` along x from the C line; bar along −y. Adds EB0A, EC0A.
    Two,
    /// C turns (A = 0); B1 on the intersection; bar along +x. Sees EX0C, EY0C (+EY0A).
    Three,
    /// C turns (A = 0); B1 `ZB1A` above the A line; bar along +x. Adds EA0C, EB0C (+EB0A).
    Four,
}

impl BallbarMode {
    /// All four, in order.
    pub const ALL: [BallbarMode; 4] = [
        BallbarMode::One,
        BallbarMode::Two,
        BallbarMode::Three,
        BallbarMode::Four,
    ];

    /// 0..4.
    pub fn index(self) -> usize {
        self as usize
    }

    /// 1..=4, the numbering of the source paper \[R1\].
    pub fn number(self) -> usize {
        self.index() + 1
    }

    /// `mode1` … `mode4`, the label used in reports and JSON.
    pub fn label(self) -> &'static str {
        ["mode1", "mode2", "mode3", "mode4"][self.index()]
    }

    /// True when A turns (modes 1 and 2), false when C turns.
    pub fn moves_a(self) -> bool {
        matches!(self, BallbarMode::One | BallbarMode::Two)
    }

    /// Name of the moving axis.
    pub fn axis_name(self) -> &'static str {
        if self.moves_a() { "A" } else { "C" }
    }

    /// Tool-ball centre B1 relative to the pivot, mm in M, set-up error included.
    pub fn tool_ball(self, rig: &Rig) -> Vector3<f64> {
        let e = Vector3::new(rig.setup.ex, rig.setup.ey, 0.0);
        e + match self {
            BallbarMode::One | BallbarMode::Three => Vector3::zeros(),
            BallbarMode::Two => Vector3::new(rig.zb1c, 0.0, 0.0),
            BallbarMode::Four => Vector3::new(0.0, 0.0, rig.zb1a),
        }
    }

    /// Unit vector from B1 to B2 at angle 0, in M.
    pub fn bar_direction(self) -> Vector3<f64> {
        if self.moves_a() {
            Vector3::new(0.0, -1.0, 0.0)
        } else {
            Vector3::new(1.0, 0.0, 0.0)
        }
    }
}

/// The ballbar set-up shared by the four modes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rig {
    /// Nominal bar length `L`, mm.
    pub length: f64,
    /// Distance of B1 from the C line in mode 2 (along x), mm.
    pub zb1c: f64,
    /// Height of B1 above the A line in mode 4 (along z), mm.
    pub zb1a: f64,
    /// Tool-ball set-up error.
    pub setup: SetupError,
}

impl Rig {
    /// The rig of the source paper \[R1\]: `L = 100`, `ZB1C = ZB1A = 100` mm, no set-up error.
    pub fn source_paper() -> Rig {
        Rig {
            length: 100.0,
            zb1c: 100.0,
            zb1a: 100.0,
            setup: SetupError::default(),
        }
    }
}

/// Why a machine does not fit the ballbar method.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TrunnionError {
    /// The workpiece chain has no rotary axis of this name (`A` or `C`).
    #[error(
        "the machine has no rotary axis named {0} in its workpiece chain; the ballbar PIGE \
         method needs a double turntable with A carrying C"
    )]
    MissingAxis(&'static str),
    /// C comes before A in the workpiece chain.
    #[error("in the workpiece chain C must come after A (A carries C)")]
    Order,
}

/// Where A and C are in a machine, and the pivot (nominal A/C intersection).
#[derive(Debug, Clone, PartialEq)]
pub struct Trunnion {
    /// Axis index of A.
    pub a: usize,
    /// Axis index of C.
    pub c: usize,
    /// Workpiece chain from the base up to and including A (axis indices).
    pub chain_a: Vec<usize>,
    /// Workpiece chain from the base up to and including C.
    pub chain_c: Vec<usize>,
    /// Point of the nominal A line closest to the nominal C line, mm in M.
    pub pivot: Vector3<f64>,
}

impl Trunnion {
    /// Finds A and C in `machine` (rotary, workpiece chain, A before C).
    pub fn of(machine: &Machine) -> Result<Trunnion, TrunnionError> {
        let wc = &machine.workpiece_chain;
        let find = |name: &'static str| {
            rotary_named(machine, name)
                .and_then(|i| wc.iter().position(|&j| j == i).map(|p| (i, p)))
                .ok_or(TrunnionError::MissingAxis(name))
        };
        let (a, pa) = find("A")?;
        let (c, pc) = find("C")?;
        if pc < pa {
            return Err(TrunnionError::Order);
        }
        let (ax, cx) = (&machine.axes[a], &machine.axes[c]);
        Ok(Trunnion {
            a,
            c,
            chain_a: wc[..=pa].to_vec(),
            chain_c: wc[..=pc].to_vec(),
            pivot: closest_point(&ax.origin, &ax.direction, &cx.origin, &cx.direction),
        })
    }

    /// Axis index of the axis `p` belongs to.
    pub fn axis_of(&self, p: Pige) -> usize {
        if p.axis() == 'A' { self.a } else { self.c }
    }

    fn chain(&self, mode: BallbarMode) -> &[usize] {
        if mode.moves_a() {
            &self.chain_a
        } else {
            &self.chain_c
        }
    }

    fn moving(&self, mode: BallbarMode) -> usize {
        if mode.moves_a() { self.a } else { self.c }
    }
}

/// The exact geometry of one mode on one actual machine.
pub(crate) struct Geometry<'k> {
    kin: &'k Kinematics,
    chain: &'k [usize],
    moving: usize,
    /// B1 in M (absolute, pivot added).
    b1: Vector3<f64>,
    u: Vector3<f64>,
    /// `X(0)`.
    x0: Rigid,
}

impl<'k> Geometry<'k> {
    pub(crate) fn new(kin: &'k Kinematics, t: &'k Trunnion, mode: BallbarMode, rig: &Rig) -> Self {
        let chain = t.chain(mode);
        let x0 = product(kin, chain, |_| 0.0);
        Geometry {
            kin,
            chain,
            moving: t.moving(mode),
            b1: t.pivot + mode.tool_ball(rig),
            u: mode.bar_direction(),
            x0,
        }
    }

    fn q(&self, alpha: f64) -> impl Fn(usize) -> f64 + '_ {
        move |i| if i == self.moving { alpha } else { 0.0 }
    }

    /// The reading `|B2(α) − B1|` (mm) at angle `alpha` (deg) for bar length `ell` (mm).
    pub(crate) fn reading(&self, ell: f64, alpha: f64) -> f64 {
        let b0 = self.b1 + self.u * ell;
        let xa = product(self.kin, self.chain, self.q(alpha));
        (xa.point(&self.x0.inv_point(&b0)) - self.b1).norm()
    }

    /// The reading and its derivatives: with respect to `ell`, and to each
    /// location component `(axis, component index)` in `params`.
    pub(crate) fn reading_and_gradient(
        &self,
        ell: f64,
        alpha: f64,
        params: &[(usize, usize)],
        grad: &mut [f64],
    ) -> (f64, f64) {
        let b0 = self.b1 + self.u * ell;
        let z = self.x0.inv_point(&b0);
        let qa = self.q(alpha);
        let q0 = |_: usize| 0.0;
        let xa = product(self.kin, self.chain, &qa);
        let y = xa.point(&z);
        let d = y - self.b1;
        let reading = d.norm();
        let n = d / reading;
        let u_rot = xa.r * self.x0.r.transpose();
        let d_ell = n.dot(&(u_rot * self.u));
        for (g, &(axis, comp)) in grad.iter_mut().zip(params) {
            let Some(k) = self.chain.iter().position(|&i| i == axis) else {
                *g = 0.0;
                continue;
            };
            let da = self.d_point(k, comp, &qa, &z);
            let d0 = self.d_point(k, comp, &q0, &z);
            *g = n.dot(&(da - u_rot * d0));
        }
        (reading, d_ell)
    }

    /// `Pre_k(q)·∂L·Post_k(q)·z` for location component `comp` of chain axis `k`.
    fn d_point(
        &self,
        k: usize,
        comp: usize,
        q: &impl Fn(usize) -> f64,
        z: &Vector3<f64>,
    ) -> Vector3<f64> {
        let i = self.chain[k];
        let ax = &self.kin.axes[i];
        let pre = product(self.kin, &self.chain[..k], q);
        if comp < 3 {
            let mut e = Vector3::zeros();
            e[comp] = 1.0;
            return pre.r * e;
        }
        let post = ax
            .j_transform(q(i))
            .compose(&ax.e_transform(q(i)))
            .compose(&product(self.kin, &self.chain[k + 1..], q));
        let w = post.point(z);
        let l = ax.loc;
        pre.r * rxyz_derivatives(l[3], l[4], l[5], &w)[comp - 3]
    }
}

/// `A_{c0}(q)·A_{c1}(q)·…` over `chain`.
fn product(kin: &Kinematics, chain: &[usize], q: impl Fn(usize) -> f64) -> Rigid {
    chain.iter().fold(Rigid::identity(), |g, &i| {
        g.compose(&kin.axis_transform(i, q(i)))
    })
}

/// The exact reading `|B2(α) − B1|` (mm) of `mode` on `machine` (its errors as
/// they are) for bar length `ell` (mm) at angle `alpha_deg`.
pub fn predicted_reading(
    machine: &Machine,
    t: &Trunnion,
    mode: BallbarMode,
    rig: &Rig,
    ell: f64,
    alpha_deg: f64,
) -> f64 {
    let kin = Kinematics::new(machine);
    Geometry::new(&kin, t, mode, rig).reading(ell, alpha_deg)
}

/// The unknowns of a joint fit: which PIGEs are estimated (the others are
/// held at `fixed`), and one bar length per mode taking part.
///
/// θ is laid out as `[free PIGEs…, ℓ of each mode…]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Unknowns {
    /// Estimated PIGEs, in θ order.
    pub free: Vec<Pige>,
    /// Values of the PIGEs not estimated (the free ones' entries are ignored).
    pub fixed: Piges,
    /// Modes taking part, in θ order of their bar lengths.
    pub modes: Vec<BallbarMode>,
}

impl Unknowns {
    /// Number of unknowns.
    pub fn len(&self) -> usize {
        self.free.len() + self.modes.len()
    }

    /// True when there is nothing to estimate.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The engine's parameter list: PIGE names, then `L.mode1`, ….
    pub fn parameters(&self) -> Vec<Parameter> {
        let mut out: Vec<Parameter> = self
            .free
            .iter()
            .map(|p| Parameter::with_scale(p.name(), if p.is_tilt() { 1e-4 } else { 1e-2 }))
            .collect();
        out.extend(
            self.modes
                .iter()
                .map(|m| Parameter::with_scale(format!("L.{}", m.label()), 1e-2)),
        );
        out
    }

    /// The eight PIGEs at θ.
    pub fn piges(&self, theta: &[f64]) -> Piges {
        let mut p = self.fixed;
        for (k, &q) in self.free.iter().enumerate() {
            p.set(q, theta[k]);
        }
        p
    }

    /// θ index of the bar length of `mode`.
    pub fn length_index(&self, mode: BallbarMode) -> Option<usize> {
        self.modes
            .iter()
            .position(|&m| m == mode)
            .map(|k| self.free.len() + k)
    }

    /// θ from PIGE values and bar lengths (`lengths[mode.index()]`).
    pub fn theta(&self, piges: &Piges, lengths: &[f64; 4]) -> Vec<f64> {
        let mut t: Vec<f64> = self.free.iter().map(|&p| piges.get(p)).collect();
        t.extend(self.modes.iter().map(|m| lengths[m.index()]));
        t
    }
}

/// One mode's readings as a [`crate::fit::Model`]: residual row `i` is
/// `reading_i − |B2(α_i) − B1|` (mm), one block per reading, group label
/// `mode1` … `mode4`.
pub struct ModeModel<'a> {
    base: &'a Machine,
    trunnion: &'a Trunnion,
    mode: BallbarMode,
    rig: Rig,
    data: &'a ModeData,
    unknowns: &'a Unknowns,
    /// `(axis, component)` of every free PIGE.
    slots: Vec<(usize, usize)>,
}

impl<'a> ModeModel<'a> {
    /// The model of `mode` with readings `data` on `base` (its nominal
    /// geometry and PDGEs; its eight PIGEs are replaced by θ).
    ///
    /// # Panics
    /// If `mode` is not among `unknowns.modes`.
    pub fn new(
        base: &'a Machine,
        trunnion: &'a Trunnion,
        mode: BallbarMode,
        rig: Rig,
        data: &'a ModeData,
        unknowns: &'a Unknowns,
    ) -> Self {
        assert!(
            unknowns.modes.contains(&mode),
            "the unknowns have no bar length for {}",
            mode.label()
        );
        let slots = unknowns
            .free
            .iter()
            .map(|&p| (trunnion.axis_of(p), p.component().index()))
            .collect();
        ModeModel {
            base,
            trunnion,
            mode,
            rig,
            data,
            unknowns,
            slots,
        }
    }

    /// The actual machine at θ.
    pub fn machine_at(&self, theta: &[f64]) -> Machine {
        let mut m = self.base.clone();
        self.unknowns.piges(theta).write_to(&mut m, self.trunnion);
        m
    }

    fn ell(&self, theta: &[f64]) -> f64 {
        // `new` checked that the mode has a bar length.
        theta[self
            .unknowns
            .length_index(self.mode)
            .expect("checked in new")]
    }
}

impl Model for ModeModel<'_> {
    fn parameters(&self) -> Vec<Parameter> {
        self.unknowns.parameters()
    }

    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform(self.mode.label(), self.data.len(), 1)
    }

    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        mut r: Option<&mut [f64]>,
        mut j: Option<MatMut<'_, f64>>,
    ) {
        let kin = Kinematics::new(&self.machine_at(theta));
        let g = Geometry::new(&kin, self.trunnion, self.mode, &self.rig);
        let ell = self.ell(theta);
        let li = self
            .unknowns
            .length_index(self.mode)
            .expect("checked in new");
        let mut grad = vec![0.0; self.slots.len()];
        for (k, i) in rows.enumerate() {
            let alpha = self.data.angles_deg[i];
            if let Some(jm) = j.as_mut() {
                let (reading, d_ell) = g.reading_and_gradient(ell, alpha, &self.slots, &mut grad);
                for c in 0..jm.ncols() {
                    jm[(k, c)] = 0.0;
                }
                for (c, gc) in grad.iter().enumerate() {
                    jm[(k, c)] = -gc;
                }
                jm[(k, li)] = -d_ell;
                if let Some(r) = r.as_mut() {
                    r[k] = self.data.lengths[i] - reading;
                }
            } else if let Some(r) = r.as_mut() {
                r[k] = self.data.lengths[i] - g.reading(ell, alpha);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::check_jacobian;
    use crate::model::parse_machine;
    use std::path::Path;

    pub(crate) fn trunnion_machine() -> Machine {
        let text = include_str!("../../../../../examples/machines/ac-trunnion.toml");
        parse_machine(Path::new("ac-trunnion.toml"), text).unwrap()
    }

    #[test]
    fn mode_one_matches_the_source_paper_exact_formula_for_offsets() {
        // With offsets only, eq. 4/6 of the source paper [R1] is exact: B2 turns about the line x-parallel
        // through (·, EY0A, EZ0A).
        let mut m = trunnion_machine();
        let t = Trunnion::of(&m).unwrap();
        let (dy, dz) = (0.0203, -0.0117);
        let p = Piges([dy, dz, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        p.write_to(&mut m, &t);
        let rig = Rig {
            setup: SetupError {
                ex: -0.0403,
                ey: -0.0765,
            },
            ..Rig::source_paper()
        };
        let (ex, ey, l) = (rig.setup.ex, rig.setup.ey, 100.0);
        for alpha in [-90.0_f64, -35.0, 0.0, 20.0, 90.0] {
            let (s, c) = alpha.to_radians().sin_cos();
            let y = (ey - l - dy) * c + dz * s + dy;
            let z = (ey - l - dy) * s - dz * c + dz;
            let expect = ((y - ey).powi(2) + z * z).sqrt();
            let got = predicted_reading(&m, &t, BallbarMode::One, &rig, l, alpha);
            assert!((got - expect).abs() < 1e-11, "{alpha}: {got} {expect}");
        }
        let _ = ex;
    }

    #[test]
    fn mode_three_is_a_circle_about_the_displaced_c_line() {
        // Offsets only: B2 turns about the z-parallel line through
        // (EX0C, EY0A + EY0C); the reading is the distance from B1 to it.
        let mut m = trunnion_machine();
        let t = Trunnion::of(&m).unwrap();
        let p = Piges([0.011, 0.0, 0.0, 0.0, -0.023, 0.007, 0.0, 0.0]);
        p.write_to(&mut m, &t);
        let rig = Rig {
            setup: SetupError {
                ex: 0.03,
                ey: -0.02,
            },
            ..Rig::source_paper()
        };
        let ctr = nalgebra::Vector2::new(-0.023, 0.011 + 0.007);
        let b1 = nalgebra::Vector2::new(0.03, -0.02);
        let b20 = b1 + nalgebra::Vector2::new(100.0, 0.0);
        for alpha in [0.0_f64, 45.0, 170.0, 300.0] {
            let rot = nalgebra::Rotation2::new(alpha.to_radians());
            let b2 = ctr + rot * (b20 - ctr);
            let got = predicted_reading(&m, &t, BallbarMode::Three, &rig, 100.0, alpha);
            assert!((got - (b2 - b1).norm()).abs() < 1e-11);
        }
    }

    #[test]
    fn jacobian_matches_finite_differences_in_every_mode() {
        let mut base = trunnion_machine();
        // PDGEs on A and C must not spoil the derivative.
        let with = parse_machine(
            Path::new("w.toml"),
            include_str!("../../../../../examples/machines/ac-trunnion-with-errors.toml"),
        )
        .unwrap();
        base.axes = with.axes.clone();
        let t = Trunnion::of(&base).unwrap();
        let unknowns = Unknowns {
            free: Pige::ALL.to_vec(),
            fixed: Piges::default(),
            modes: BallbarMode::ALL.to_vec(),
        };
        let rig = Rig {
            setup: SetupError {
                ex: -0.04,
                ey: 0.07,
            },
            ..Rig::source_paper()
        };
        let angles: Vec<f64> = (-18..=18).map(|k| k as f64 * 10.0).collect();
        let data = ModeData {
            source: None,
            lengths: vec![100.0; angles.len()],
            angles_deg: angles,
        };
        let theta = unknowns.theta(
            &Piges([0.02, -0.015, 9e-5, -6e-5, 0.014, -0.026, 4.4e-5, -9.3e-5]),
            &[100.001, 99.999, 100.0, 100.002],
        );
        for mode in BallbarMode::ALL {
            let model = ModeModel::new(&base, &t, mode, rig, &data, &unknowns);
            let c = check_jacobian(&model, &theta).unwrap();
            // Columns are O(1) mm/mm for offsets and O(100) mm/rad for tilts; the
            // differences carry ~1e-7 mm/mm and ~3e-5 mm/rad of rounding (seen on the weak, second-order columns
            // such as EZ0A in mode 3, ~3e-5 mm/mm, where the relative error reaches 1e-2).
            assert!(c.max_abs_error < 1e-4, "{mode:?}: {c:?}");
        }
    }
}
