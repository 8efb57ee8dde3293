//! Inverse kinematics on the actual machine: the axis positions that put the actual tool tip
//! (and, with enough rotary axes, the tool axis) on a target in W, by Gauss–Newton iteration
//! from a start (usually the nominal solution).

use nalgebra::{DMatrix, DVector, Vector3};

use super::chain::Kinematics;

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
pub struct IkOptions {
    /// Largest number of Gauss–Newton steps.
    pub max_iterations: usize,
    /// Tip tolerance, mm.
    pub tip_tolerance: f64,
    /// Tool-axis tolerance, rad.
    pub axis_tolerance: f64,
    /// Reject solutions outside the axis travels.
    pub check_travel: bool,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            max_iterations: 50,
            tip_tolerance: 1e-11,
            axis_tolerance: 1e-13,
            check_travel: true,
        }
    }
}

/// Why inverse kinematics failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
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
    #[error("the solution puts axis {axis} at {value} {unit}, outside its travel [{lo}, {hi}]")]
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

impl Kinematics {
    /// Axis positions near `start` that put the tool on `target` (see [`IkTarget`]).
    ///
    /// `free[i]` says whether axis `i` may move; the others keep their `start` value. With a
    /// position-only target on a five-axis machine, free only the linear axes (the usual
    /// choice) or all axes (minimum-norm steps). Converges quadratically; for the small
    /// geometric errors of a machine tool two or three steps reach 1e-11 mm.
    pub fn inverse(
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
