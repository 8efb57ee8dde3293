//! Inverse kinematics on the actual machine: the axis positions that put the actual tool tip
//! (and, with enough rotary axes, the tool axis) on a target in W, by Gauss–Newton iteration
//! from a start (usually the nominal solution).

use nalgebra::{DMatrix, DVector, SMatrix, SVector, Vector3};

use super::chain::{Kinematics, ToolPose};
use super::jacobian::PoseDerivative;
use super::tangent::MAX_AXES;

/// What the tool must reach, in the workpiece frame W.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkTarget {
    /// Tool tip, mm.
    pub tip: Vector3<f64>,
    /// Unit tool axis, or `None` for position only.
    pub axis: Option<Vector3<f64>>,
}

/// Iteration controls.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct IkOptions {
    /// Largest number of Gauss–Newton steps.
    pub max_iterations: usize,
    /// Tip tolerance, mm.
    pub tip_tolerance: f64,
    /// Tool-axis tolerance, rad.
    pub axis_tolerance: f64,
    /// Reject solutions outside the axis travels.
    pub check_travel: bool,
    /// Give up early (not converged) when a Newton step with fresh derivatives shrinks the
    /// residual by less than this factor: the target is out of reach from here (a singular
    /// pose, say). `None` keeps iterating up to `max_iterations`.
    pub stall_ratio: Option<f64>,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            max_iterations: 50,
            tip_tolerance: 1e-11,
            axis_tolerance: 1e-13,
            check_travel: true,
            stall_ratio: None,
        }
    }
}

/// Why inverse kinematics failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum IkError {
    /// The iteration did not reach the tolerance.
    #[error(
        "inverse kinematics did not converge after {iterations} iterations (tip still {tip_residual:.3e} mm, axis {axis_residual:.3e} rad from the target)"
    )]
    NotConverged {
        /// Iterations made.
        iterations: usize,
        /// Remaining tip distance, mm.
        tip_residual: f64,
        /// Remaining axis angle, rad.
        axis_residual: f64,
    },
    /// The solution leaves the travel of an axis.
    #[error(
        "the solution puts axis {axis} at {} {unit}, outside its travel [{}, {}]",
        crate::limits::fmt_message_number(*.value),
        crate::limits::fmt_message_number(*.lo),
        crate::limits::fmt_message_number(*.hi)
    )]
    OutOfTravel {
        /// Axis name.
        axis: String,
        /// Its solved position.
        value: f64,
        /// mm or deg.
        unit: &'static str,
        /// Travel low end.
        lo: f64,
        /// Travel high end.
        hi: f64,
    },
    /// No axis is free to move.
    #[error("inverse kinematics has no free axis to move")]
    NoFreeAxis,
}

/// The derivatives of tool tip and tool axis with respect to every axis position at the
/// last iterate of an inverse-kinematics solve, kept for the next solve at a nearby target
/// (see [`Kinematics::inverse_warm`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkJacobian {
    d: [PoseDerivative; MAX_AXES],
    /// The step solver factored from `d`, for the free axes and rows it was made for.
    factor: Option<(StepKey, StepSolver)>,
}

/// Which least-squares problem a [`StepSolver`] was factored for: the free axes (bit `i`
/// for axis `i`) and the residual rows (3: tip; 6: tip and axis).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct StepKey {
    free: u32,
    rows: usize,
}

impl StepKey {
    fn new(free: &[usize], rows: usize) -> StepKey {
        StepKey {
            free: free.iter().fold(0, |m, &i| m | 1 << i),
            rows,
        }
    }
}

impl Kinematics {
    /// Axis positions near `start` that put the tool on `target` (see [`IkTarget`]).
    ///
    /// `free[i]` says whether axis `i` may move; the others keep their `start` value. With a
    /// position-only target on a five-axis machine, free only the linear axes (the usual
    /// choice) or all axes (minimum-norm steps). Converges quadratically; for the small
    /// geometric errors of a machine tool two or three steps reach 1e-11 mm. On a machine
    /// without errors, with only linear axes free, the tip is affine in them, so the first
    /// Newton step is the exact solution.
    ///
    /// Newton steps are least-squares solutions with the exact position Jacobian: by
    /// Cholesky on the column-scaled normal equations when the free columns are well
    /// conditioned, else (and with more free axes than rows) the minimum-norm solution by SVD
    /// with singular values below `1e-12·σ_max` dropped. Nothing is allocated but the result
    /// (machines of up to 8 axes).
    pub fn inverse(
        &self,
        target: &IkTarget,
        start: &[f64],
        free: &[bool],
        opts: &IkOptions,
    ) -> Result<Vec<f64>, IkError> {
        let mut q = start.to_vec();
        self.inverse_in_place(target, &mut q, free, opts)?;
        Ok(q)
    }

    /// [`Kinematics::inverse`] starting from, and writing the solution into, `q`. On error
    /// `q` holds the last iterate.
    pub fn inverse_in_place(
        &self,
        target: &IkTarget,
        q: &mut [f64],
        free: &[bool],
        opts: &IkOptions,
    ) -> Result<(), IkError> {
        self.inverse_warm(target, q, free, opts, &mut None)
    }

    /// [`Kinematics::inverse_in_place`] along a path of nearby targets: `jac` holds the
    /// derivatives of the previous solve (or `None`) and, on return, those of this one.
    /// With them the first steps are chord steps (no derivatives computed); the
    /// derivatives are refreshed as soon as a step shrinks the residual less than a
    /// hundredfold, so a stale `jac` costs iterations, never accuracy: the tolerances
    /// decide convergence exactly as in [`Kinematics::inverse`].
    pub fn inverse_warm(
        &self,
        target: &IkTarget,
        q: &mut [f64],
        free: &[bool],
        opts: &IkOptions,
        jac: &mut Option<IkJacobian>,
    ) -> Result<(), IkError> {
        let n = self.n_axes();
        if n > MAX_AXES {
            let sol = self.inverse_dynamic(target, q, free, opts)?;
            q.copy_from_slice(&sol);
            return Ok(());
        }
        let mut free_idx = [0usize; MAX_AXES];
        let mut m = 0;
        for i in 0..n {
            if free[i] {
                free_idx[m] = i;
                m += 1;
            }
        }
        if m == 0 {
            return Err(IkError::NoFreeAxis);
        }
        let free_idx = &free_idx[..m];
        let rows = if target.axis.is_some() { 6 } else { 3 };
        // The first pose comes with its derivatives (unless the caller kept
        // those of a nearby solve): a warm start usually needs exactly one
        // step, so this saves a forward kinematics per call.
        let fresh = jac.is_none();
        let (j, mut pose) = match jac {
            Some(j) => {
                let pose = self.pose(q);
                (j, pose)
            }
            None => {
                let mut d = [[0.0; 6]; MAX_AXES];
                let pose = self.pose_and_position_derivatives(q, &mut d);
                (jac.insert(IkJacobian { d, factor: None }), pose)
            }
        };
        let key = StepKey::new(free_idx, rows);
        self.iterate(target, q, free_idx, rows, key, opts, fresh, j, &mut pose)
    }

    /// The Gauss–Newton / chord iteration of [`Kinematics::inverse_warm`] from `q`, whose
    /// pose is `pose`, with derivatives `jac.d` (of `q` when `fresh`, else of a nearby
    /// point) and their factored step solver when it was made for `key` (kept while the
    /// derivatives are: chord steps solve with the same matrix).
    #[allow(clippy::too_many_arguments)]
    fn iterate(
        &self,
        target: &IkTarget,
        q: &mut [f64],
        free_idx: &[usize],
        rows: usize,
        key: StepKey,
        opts: &IkOptions,
        fresh: bool,
        jac: &mut IkJacobian,
        pose: &mut ToolPose,
    ) -> Result<(), IkError> {
        if jac.factor.is_some_and(|(k, _)| k != key) {
            jac.factor = None;
        }
        let mut last = (f64::INFINITY, f64::INFINITY);
        // Residual norm before the last step (tip in mm, axis in rad), and
        // whether that step used derivatives taken where it started.
        let mut before = f64::INFINITY;
        let mut newton = fresh;
        let mut iterations = opts.max_iterations;
        for it in 0..=opts.max_iterations {
            if it > 0 {
                *pose = self.pose(q);
            }
            let dp = pose.tip - target.tip;
            let (dv, ang) = match target.axis {
                Some(t) => (
                    pose.axis - t,
                    pose.axis.cross(&t).norm().atan2(pose.axis.dot(&t)),
                ),
                None => (Vector3::zeros(), 0.0),
            };
            last = (dp.norm(), ang);
            if dp.norm() <= opts.tip_tolerance && ang <= opts.axis_tolerance {
                if opts.check_travel {
                    self.check_travel(q)?;
                }
                return Ok(());
            }
            if it == opts.max_iterations {
                break;
            }
            // Chord steps: the Jacobian of the previous step is kept while it
            // still shrinks the residual a hundredfold per step (the small
            // corrections of a warm start), else it is refreshed (Newton).
            let now = (dp.norm_squared() + dv.norm_squared()).sqrt();
            if it > 0 && now > 1e-2 * before {
                if newton && opts.stall_ratio.is_some_and(|r| now > r * before) {
                    iterations = it;
                    break;
                }
                self.pose_and_position_derivatives(q, &mut jac.d);
                jac.factor = None;
                newton = true;
            } else {
                newton = it == 0 && fresh;
            }
            before = now;
            let r = [-dp.x, -dp.y, -dp.z, -dv.x, -dv.y, -dv.z];
            let (_, solver) = jac
                .factor
                .get_or_insert_with(|| (key, StepSolver::new(&jac.d, free_idx, rows)));
            let Some(step) = solver.solve(&jac.d, free_idx, rows, &r) else {
                iterations = it;
                break;
            };
            for (c, &i) in free_idx.iter().enumerate() {
                q[i] += step[c];
            }
        }
        Err(IkError::NotConverged {
            iterations,
            tip_residual: last.0,
            axis_residual: last.1,
        })
    }

    /// The reference implementation of [`Kinematics::inverse`] (heap matrices, the full
    /// Jacobian and an SVD every step); used for machines of more than 8 axes and in tests.
    pub(crate) fn inverse_dynamic(
        &self,
        target: &IkTarget,
        start: &[f64],
        free: &[bool],
        opts: &IkOptions,
    ) -> Result<Vec<f64>, IkError> {
        let free_idx: Vec<usize> = (0..self.n_axes()).filter(|&i| free[i]).collect();
        if free_idx.is_empty() {
            return Err(IkError::NoFreeAxis);
        }
        let rows = if target.axis.is_some() { 6 } else { 3 };
        let mut q = start.to_vec();
        let mut last = (f64::INFINITY, f64::INFINITY);
        for it in 0..=opts.max_iterations {
            let jac = self.jacobian(&q);
            let dp = jac.pose.tip - target.tip;
            let (dv, ang) = match target.axis {
                Some(t) => (
                    jac.pose.axis - t,
                    jac.pose.axis.cross(&t).norm().atan2(jac.pose.axis.dot(&t)),
                ),
                None => (Vector3::zeros(), 0.0),
            };
            last = (dp.norm(), ang);
            if dp.norm() <= opts.tip_tolerance && ang <= opts.axis_tolerance {
                if opts.check_travel {
                    self.check_travel(&q)?;
                }
                return Ok(q);
            }
            if it == opts.max_iterations {
                break;
            }
            let mut j = DMatrix::zeros(rows, free_idx.len());
            for (c, &i) in free_idx.iter().enumerate() {
                let d = jac.positions[i];
                for r in 0..rows {
                    j[(r, c)] = d[r];
                }
            }
            let mut r = DVector::zeros(rows);
            for k in 0..3 {
                r[k] = -dp[k];
                if rows == 6 {
                    r[3 + k] = -dv[k];
                }
            }
            let svd = j.svd(true, true);
            let smax = svd.singular_values.max();
            let step = match svd.solve(&r, smax * 1e-12) {
                Ok(s) => s,
                Err(_) => break,
            };
            for (c, &i) in free_idx.iter().enumerate() {
                q[i] += step[c];
            }
        }
        Err(IkError::NotConverged {
            iterations: opts.max_iterations,
            tip_residual: last.0,
            axis_residual: last.1,
        })
    }

    /// An error naming the first axis of `q` outside its travel.
    pub fn check_travel(&self, q: &[f64]) -> Result<(), IkError> {
        for (a, &v) in self.axes.iter().zip(q) {
            let [lo, hi] = a.travel;
            let tol = 1e-9 * (hi - lo).abs().max(1.0);
            if v < lo - tol || v > hi + tol {
                return Err(IkError::OutOfTravel {
                    axis: a.name.clone(),
                    value: v,
                    unit: a.kind.unit(),
                    lo,
                    hi,
                });
            }
        }
        Ok(())
    }
}

/// The least-squares step `x` minimising `|J·x − r|` over the first `rows` components, where
/// column `c` of `J` is `d[free[c]]`, factored once for a fixed `J` and solved for any `r`.
// Kept inline (no box): a solver is made per derivative refresh and must not allocate.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
enum StepSolver {
    /// Full column rank: the Cholesky factor `L` (lower triangle) of the normal matrix
    /// `Sᵀ JᵀJ S` with the columns scaled to unit length by `S = diag(scale)`.
    Cholesky {
        scale: [f64; MAX_AXES],
        l: [[f64; MAX_AXES]; MAX_AXES],
    },
    /// More free axes than rows, or nearly dependent columns: the minimum-norm solution by
    /// SVD, each solve.
    Svd,
}

/// Smallest accepted ratio of a Cholesky pivot to the (unit) diagonal of the column-scaled
/// normal matrix: below it the columns are too close to dependent (condition number above
/// ~1e6) and the SVD decides.
const MIN_PIVOT: f64 = 1e-12;

impl StepSolver {
    fn new(d: &[PoseDerivative; MAX_AXES], free: &[usize], rows: usize) -> StepSolver {
        if free.len() <= rows {
            Self::cholesky(d, free, rows).unwrap_or(StepSolver::Svd)
        } else {
            StepSolver::Svd
        }
    }

    /// The Cholesky factor of the column-scaled normal matrix; `None` when a column is zero
    /// or the matrix is nearly singular.
    fn cholesky(d: &[PoseDerivative; MAX_AXES], free: &[usize], rows: usize) -> Option<Self> {
        let m = free.len();
        let mut scale = [0.0; MAX_AXES];
        for (c, &i) in free.iter().enumerate() {
            let n2: f64 = d[i][..rows].iter().map(|v| v * v).sum();
            if n2.is_nan() || n2 <= 0.0 || !n2.is_finite() {
                return None;
            }
            scale[c] = 1.0 / n2.sqrt();
        }
        // a = Sᵀ JᵀJ S (unit diagonal).
        let mut a = [[0.0; MAX_AXES]; MAX_AXES];
        for c in 0..m {
            let jc = &d[free[c]];
            for e in 0..=c {
                let je = &d[free[e]];
                let mut s = 0.0;
                for k in 0..rows {
                    s += jc[k] * je[k];
                }
                a[c][e] = s * scale[c] * scale[e];
            }
        }
        // In-place Cholesky a = L·Lᵀ (lower triangle).
        for c in 0..m {
            let mut diag = a[c][c];
            for k in 0..c {
                diag -= a[c][k] * a[c][k];
            }
            if diag.is_nan() || diag <= MIN_PIVOT {
                return None;
            }
            let l = diag.sqrt();
            a[c][c] = l;
            for e in c + 1..m {
                let mut s = a[e][c];
                for k in 0..c {
                    s -= a[e][k] * a[c][k];
                }
                a[e][c] = s / l;
            }
        }
        Some(StepSolver::Cholesky { scale, l: a })
    }

    /// The step for residual `r`, with the `d`, `free` and `rows` the solver was made
    /// from. `None` when the SVD cannot solve (never, for finite input).
    fn solve(
        &self,
        d: &[PoseDerivative; MAX_AXES],
        free: &[usize],
        rows: usize,
        r: &[f64; 6],
    ) -> Option<[f64; MAX_AXES]> {
        let m = free.len();
        let StepSolver::Cholesky { scale, l } = self else {
            return svd_step(d, free, rows, r);
        };
        // b = Sᵀ Jᵀ r; L y = b, Lᵀ z = y, x = S z.
        let mut y = [0.0; MAX_AXES];
        for c in 0..m {
            let jc = &d[free[c]];
            let mut s = 0.0;
            for k in 0..rows {
                s += jc[k] * r[k];
            }
            let mut s = s * scale[c];
            for k in 0..c {
                s -= l[c][k] * y[k];
            }
            y[c] = s / l[c][c];
        }
        let mut x = [0.0; MAX_AXES];
        for c in (0..m).rev() {
            let mut s = y[c];
            for k in c + 1..m {
                s -= l[k][c] * x[k];
            }
            x[c] = s / l[c][c];
        }
        for c in 0..m {
            x[c] *= scale[c];
        }
        Some(x)
    }
}

/// The minimum-norm least-squares step by SVD, zero-padded to a fixed 8×8 (zero rows and
/// columns do not change the pseudo-inverse solution of the others).
fn svd_step(
    d: &[PoseDerivative; MAX_AXES],
    free: &[usize],
    rows: usize,
    r: &[f64; 6],
) -> Option<[f64; MAX_AXES]> {
    let m = free.len();
    let mut j = SMatrix::<f64, MAX_AXES, MAX_AXES>::zeros();
    let mut b = SVector::<f64, MAX_AXES>::zeros();
    for (c, &i) in free.iter().enumerate() {
        for k in 0..rows {
            j[(k, c)] = d[i][k];
        }
    }
    for k in 0..rows {
        b[k] = r[k];
    }
    let svd = j.svd(true, true);
    let smax = svd.singular_values.max();
    let s = svd.solve(&b, smax * 1e-12).ok()?;
    let mut x = [0.0; MAX_AXES];
    for c in 0..m {
        x[c] = s[c];
    }
    Some(x)
}

impl Kinematics {
    /// The tool-tip solve for a machine of three linear axes (`lin`, their
    /// indices; the TCP moves of `gcode::travel::machine_position`): the
    /// linear axes that put the tool tip on `tip` (W, mm) with the rotary
    /// axes as `q` holds them, written into `q`. With the rotary axes fixed, the nominal tip is
    /// an affine function `A·x + b` of the linear positions `x` (every linear
    /// axis adds `dir·x` before fixed rotations), so one Newton step from the
    /// current `q` — the tip and its derivatives there, then the 3×3 system
    /// solved by Cramer's rule — is the exact solution up to rounding (about
    /// 1e-13 mm; `Kinematics::inverse` takes the same step by a least-squares
    /// factorisation, and then a second forward kinematics to check it).
    /// `false` (and `q` unchanged) when the columns of `A` are nearly dependent
    /// (|det A| below 1e-9 of the product of the column lengths) or the result
    /// is not finite, or the machine has more axes than the derivative
    /// kernel holds: the caller then runs the general solver.
    pub(crate) fn solve_tip_by_three_linear_axes(
        &self,
        lin: [usize; 3],
        tip: &Vector3<f64>,
        q: &mut [f64],
    ) -> bool {
        if q.len() > MAX_AXES {
            return false;
        }
        let mut d = [[0.0; 6]; MAX_AXES];
        let pose = self.pose_and_position_derivatives(q, &mut d);
        let col = |i: usize| Vector3::new(d[i][0], d[i][1], d[i][2]);
        let (c0, c1, c2) = (col(lin[0]), col(lin[1]), col(lin[2]));
        let r = tip - pose.tip;
        let c12 = c1.cross(&c2);
        let det = c0.dot(&c12);
        if det.is_nan() || det.abs() <= 1e-9 * c0.norm() * c1.norm() * c2.norm() {
            return false;
        }
        let x = [
            r.dot(&c12) / det,
            c0.dot(&r.cross(&c2)) / det,
            c0.dot(&c1.cross(&r)) / det,
        ];
        if !x.iter().all(|v| v.is_finite()) {
            return false;
        }
        for (&i, dx) in lin.iter().zip(x) {
            q[i] += dx;
        }
        true
    }
}
