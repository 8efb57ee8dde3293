//! The tool-tip measurement model: every measured point is a block of three
//! residuals `p_model(q; θ) − p_measured` in W (mm), with the exact Jacobian
//! from [`Kinematics::jacobian`].
//!
//! With a registration the measured points are given in the tracker frame T
//! and mapped to W by `p_W = Rx(a)·Ry(b)·Rz(c)·p_T + t`; the six registration
//! parameters `REG.tx, REG.ty, REG.tz` (mm) and `REG.a, REG.b, REG.c` (rad)
//! follow the error parameters in θ.

use std::ops::Range;

use faer::MatMut;
use nalgebra::Vector3;

use crate::fit::{BlockLayout, FactorGroup, Factored, Model, Parameter};
use crate::kinematics::Kinematics;
use crate::kinematics::transform::{rxyz, rxyz_derivatives};
use crate::model::{Form, Machine, ParameterSet};

/// Names of the registration parameters, in θ order.
pub const REGISTRATION_NAMES: [&str; 6] = ["REG.tx", "REG.ty", "REG.tz", "REG.a", "REG.b", "REG.c"];

/// One tool-tip measurement: commanded axis positions and the measured tip.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerPoint {
    /// Axis positions in the machine's axis order (mm, degree).
    pub q: Vec<f64>,
    /// Measured tool tip (mm), in W, or in the tracker frame when registered.
    pub measured: Vector3<f64>,
}

/// The least-squares model of a laser-tracker identification.
///
/// Its Jacobian factors ([`Factored`]): the column of coefficient `k` of a
/// fitted error `e` on axis `a` is `(∂tip/∂e)·β_k(q_a)`, the component
/// derivative of the kinematics Jacobian times the basis value of the
/// error's form. Errors of one axis with the same form share the basis
/// vector (one group per axis and form); constants (location errors,
/// constant PDGEs, the registration) form one group with the basis `[1]`.
pub struct TrackerModel<'a> {
    machine: &'a Machine,
    params: &'a ParameterSet,
    points: &'a [TrackerPoint],
    registration: bool,
    /// The groups of the factored Jacobian.
    groups: Vec<BasisGroup>,
}

/// A group of the factored Jacobian.
struct BasisGroup {
    group: FactorGroup,
    /// The axis and form of the group's basis (`None`: the constant `[1]`).
    basis: Option<(usize, Form)>,
    /// Its functions, in order.
    functions: Vec<Function>,
}

/// A function of the factored Jacobian.
#[derive(Debug, Clone, Copy)]
enum Function {
    /// Fitted error number `i` of the parameter set.
    Error(usize),
    /// Registration parameter `c` (0..6).
    Registration(usize),
}

impl<'a> TrackerModel<'a> {
    /// The model of `points` for the errors `params` of `machine` (whose other
    /// errors, those not in `params`, are kept as they are), with or without
    /// the tracker-to-W registration.
    pub fn new(
        machine: &'a Machine,
        params: &'a ParameterSet,
        points: &'a [TrackerPoint],
        registration: bool,
    ) -> Self {
        let mut groups: Vec<BasisGroup> = Vec::new();
        let mut put =
            |key: Option<(usize, Form)>, len: usize, offset: usize, f: Function| match groups
                .iter_mut()
                .find(|g| g.basis == key)
            {
                Some(g) => {
                    g.group.offsets.push(offset);
                    g.functions.push(f);
                }
                None => groups.push(BasisGroup {
                    group: FactorGroup {
                        basis_len: len,
                        offsets: vec![offset],
                    },
                    basis: key,
                    functions: vec![f],
                }),
            };
        for (i, e) in params.errors().iter().enumerate() {
            let key = match e.form {
                Form::Constant => None,
                ref f => Some((e.axis, f.clone())),
            };
            put(key, e.form.n_coeffs(), e.offset, Function::Error(i));
        }
        if registration {
            for c in 0..6 {
                put(None, 1, params.len() + c, Function::Registration(c));
            }
        }
        Self {
            machine,
            params,
            points,
            registration,
            groups,
        }
    }

    /// Total number of unknowns: errors, then registration if any.
    pub fn len(&self) -> usize {
        self.params.len() + if self.registration { 6 } else { 0 }
    }

    /// True when there is nothing to fit.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The machine with the error part of `theta` written in.
    pub fn machine_at(&self, theta: &[f64]) -> Machine {
        let mut m = self.machine.clone();
        self.params.set(&mut m, &theta[..self.params.len()]);
        m
    }

    /// The measured point of block `b` mapped to W with the registration of `theta`.
    fn measured_in_w(&self, theta: &[f64], b: usize) -> Vector3<f64> {
        let p = self.points[b].measured;
        if !self.registration {
            return p;
        }
        let g = &theta[self.params.len()..];
        rxyz(g[3], g[4], g[5]) * p + Vector3::new(g[0], g[1], g[2])
    }

    fn blocks(rows: &Range<usize>) -> Range<usize> {
        rows.start / 3..rows.end / 3
    }
}

impl Model for TrackerModel<'_> {
    fn parameters(&self) -> Vec<Parameter> {
        let rot = self.params.is_rotation();
        let mut out: Vec<Parameter> = self
            .params
            .labels()
            .into_iter()
            .zip(rot)
            // Typical sizes: 1 µm and 10 µrad.
            .map(|(l, r)| Parameter::with_scale(l, if r { 1e-5 } else { 1e-3 }))
            .collect();
        if self.registration {
            for (k, n) in REGISTRATION_NAMES.iter().enumerate() {
                out.push(Parameter::with_scale(*n, if k < 3 { 1.0 } else { 1e-3 }));
            }
        }
        out
    }

    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform("tracker", self.points.len(), 3)
    }

    fn factored(&self) -> Option<&dyn Factored> {
        Some(self)
    }

    /// Residuals alone take the tip only; with the Jacobian, the tip comes
    /// with the chain's derivatives.
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        let Some(mut j) = j else {
            if let Some(out) = r {
                let kin = Kinematics::new(&self.machine_at(theta));
                for (k, b) in Self::blocks(&rows).enumerate() {
                    let d = kin.pose(&self.points[b].q).tip - self.measured_in_w(theta, b);
                    out[3 * k..3 * k + 3].copy_from_slice(d.as_slice());
                }
            }
            return;
        };
        let mut scratch = Vec::new();
        let r = match r {
            Some(r) => r,
            None => {
                scratch.resize(rows.len(), 0.0);
                &mut scratch[..]
            }
        };
        let kin = Kinematics::new(&self.machine_at(theta));
        let n_err = self.params.len();
        let mut basis = vec![0.0; n_err];
        for (k, b) in Self::blocks(&rows).enumerate() {
            let q = &self.points[b].q;
            let jac = kin.jacobian(q);
            let d = jac.pose.tip - self.measured_in_w(theta, b);
            r[3 * k..3 * k + 3].copy_from_slice(d.as_slice());
            self.params.basis(self.machine, q, &mut basis);
            for e in self.params.errors() {
                let comp = jac.components[e.axis][e.slot()];
                for c in 0..e.form.n_coeffs() {
                    let col = e.offset + c;
                    for x in 0..3 {
                        j[(3 * k + x, col)] = comp[x] * basis[col];
                    }
                }
            }
            if self.registration {
                let g = &theta[n_err..];
                let dr = rxyz_derivatives(g[3], g[4], g[5], &self.points[b].measured);
                for x in 0..3 {
                    for c in 0..3 {
                        j[(3 * k + x, n_err + c)] = if x == c { -1.0 } else { 0.0 };
                        j[(3 * k + x, n_err + 3 + c)] = -dr[c][x];
                    }
                }
            }
        }
    }
}

impl Factored for TrackerModel<'_> {
    fn groups(&self) -> Vec<FactorGroup> {
        self.groups.iter().map(|g| g.group.clone()).collect()
    }

    fn residuals_and_factors(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: &mut [f64],
        mut g: MatMut<'_, f64>,
        mut basis: MatMut<'_, f64>,
    ) {
        let kin = Kinematics::new(&self.machine_at(theta));
        let reg = &theta[self.params.len()..];
        let errors = self.params.errors();
        for (k, b) in Self::blocks(&rows).enumerate() {
            let point = &self.points[b];
            let jac = kin.jacobian(&point.q);
            let d = jac.pose.tip - self.measured_in_w(theta, b);
            r[3 * k..3 * k + 3].copy_from_slice(d.as_slice());
            let dr = self
                .registration
                .then(|| rxyz_derivatives(reg[3], reg[4], reg[5], &point.measured));
            let (mut f, mut col) = (0, 0);
            for BasisGroup {
                group,
                basis: key,
                functions,
            } in &self.groups
            {
                for func in functions {
                    for x in 0..3 {
                        g[(3 * k + x, f)] = match (*func, &dr) {
                            (Function::Error(i), _) => {
                                let e = &errors[i];
                                jac.components[e.axis][e.slot()][x]
                            }
                            (Function::Registration(c), _) if c < 3 => {
                                if x == c {
                                    -1.0
                                } else {
                                    0.0
                                }
                            }
                            (Function::Registration(c), Some(dr)) => -dr[c - 3][x],
                            (Function::Registration(_), None) => 0.0,
                        };
                    }
                    f += 1;
                }
                let len = group.basis_len;
                let mut out = vec![0.0; len];
                match key {
                    Some((axis, form)) => {
                        form.basis(point.q[*axis], self.machine.axes[*axis].travel, &mut out)
                    }
                    None => out[0] = 1.0,
                }
                for (c, v) in out.into_iter().enumerate() {
                    basis[(k, col + c)] = v;
                }
                col += len;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::check_jacobian;

    #[test]
    fn jacobian_matches_finite_differences_with_registration() {
        let mut m = crate::examples::machine("afp-gantry").unwrap();
        // Tip off the C axis: every column is well above the rounding of the
        // differences (on the axis, the roll of C moves the tip by ~1e-13 mm).
        m.tool_tip = Vector3::new(30.0, 20.0, -500.0);
        let params = ParameterSet::from_spec(&m, "pdge:cheb2,location").unwrap();
        let points: Vec<TrackerPoint> = [
            [1000.0, 500.0, -300.0, 10.0, -20.0, 30.0],
            [7000.0, 3000.0, -900.0, -40.0, 35.0, -170.0],
            [4000.0, 10.0, -10.0, 0.0, 0.0, 90.0],
        ]
        .iter()
        .map(|q| TrackerPoint {
            q: q.to_vec(),
            measured: Vector3::new(q[0], q[1], q[2] - 500.0),
        })
        .collect();
        let model = TrackerModel::new(&m, &params, &points, true);
        let mut theta: Vec<f64> = (0..model.len())
            .map(|j| 1e-5 * ((j * 7919 % 13) as f64 - 6.0))
            .collect();
        let n = theta.len();
        theta[n - 6..n - 3].copy_from_slice(&[2.0, -1.0, 0.5]);
        let check = check_jacobian(&model, &theta).unwrap();
        // Steps of ~1e-10 rad on 8000 mm coordinates leave ~1e-4 relative
        // rounding in the differences; a wrong entry is off by O(1).
        assert!(check.passes(1e-3), "{check:?}");
    }
}
