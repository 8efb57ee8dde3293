//! Levenberg–Marquardt on the exact model, over the estimated parameters.
//!
//! Each linearisation is decomposed once (`Scaled`: `λᵢ`, `V` of the
//! column-scaled problem); every trial damping `μ` then costs only
//! `O(k²)`: the step in scaled variables is
//! `y = −V·diag(1/(λᵢ + μ))·Vᵀ·gₛ`, `δθ_j = y_j / D_j`, and the reduction
//! predicted by the quadratic model is `Σ cᵢ²/(λᵢ+μ) − ½ Σ λᵢ cᵢ²/(λᵢ+μ)²`
//! with `c = Vᵀgₛ`.
//!
//! * Scaling (Moré 1978): `D_j = max(D_j, ‖J_j‖)` over the iterations.
//! * Damping (Nielsen 1999): start `μ = τ₀·max diag(Nₛ)`, or, with
//!   [`super::Options::gauss_newton_first`], `μ = 0` (the Gauss–Newton step
//!   in the identifiable subspace, full rank by construction: an almost
//!   linear identification converges in two or three passes) until a step
//!   is rejected or the spectrum degenerates; on an accepted step
//!   with gain ratio ρ, `μ ← μ·max(1/3, 1 − (2ρ − 1)³)`, `ν ← 2`; on a
//!   rejected one `μ ← μ·ν`, `ν ← 2ν`; when the gain ratio is within
//!   0.1 of 1 (the model is linear along the step) `μ ← μ/10`.
//! * Stopping (MINPACK's tests, in scaled variables): gradient
//!   `max_j |J_jᵀr| / (D_j‖r‖) ≤ gtol` (or `r = 0`); step
//!   `‖D·δθ‖ ≤ xtol·(‖D·θ‖ + xtol)` (tested after the step is evaluated, and
//!   taken if it lowers the cost); cost change: actual and predicted
//!   relative reductions both `≤ ftol`; iteration limit; or no progress
//!   (the damping overflowed without an acceptable step).
//! * Normal-equation path: `JᵀJ` costs `m·n²` flops against `m·n` for the
//!   residuals and gradient, so after an accepted step whose gain ratio is
//!   within [`super::Options::reuse_gain`] of 1 (the quadratic model still
//!   predicts the decrease well) the previous `JᵀJ` and its decomposition
//!   are kept and only the gradient is refreshed (a chord/simplified
//!   Gauss–Newton step: the fixed point is still `Jᵀr = 0`, only the rate
//!   changes). Otherwise
//!   `JᵀJ` is formed anew at the accepted point, except at the step that
//!   ends the iteration (no further step would use it).

use serde::{Deserialize, Serialize};

use super::evaluate::{Evaluation, Need, Pass};
use super::scaling::Scaled;
use super::{FitError, Options, Progress};

/// A step whose gain ratio is within this of 1 was taken where the model is
/// linear: the damping drops ten-fold.
const LINEAR_GAIN: f64 = 0.1;

/// Why the iteration stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The scaled gradient is below `gradient_tolerance` (or `r = 0`).
    Gradient,
    /// The step is below `step_tolerance`.
    Step,
    /// Actual and predicted cost reductions are below `cost_tolerance`.
    CostChange,
    /// `max_iterations` reached.
    MaxIterations,
    /// No acceptable step could be found (damping overflow).
    NoProgress,
    /// Nothing to estimate (rank 0).
    NothingToEstimate,
}

impl StopReason {
    /// Whether the reason means convergence.
    pub fn converged(self) -> bool {
        matches!(
            self,
            StopReason::Gradient
                | StopReason::Step
                | StopReason::CostChange
                | StopReason::NothingToEstimate
        )
    }
}

/// Convergence summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Convergence {
    /// Accepted iterations.
    pub iterations: usize,
    /// `½‖r‖²` at the start (residual unit squared).
    pub initial_cost: f64,
    /// `½‖r‖²` at the solution.
    pub final_cost: f64,
    /// Why the iteration stopped.
    pub reason: StopReason,
    /// Passes over the residuals (each computes residuals and Jacobian rows).
    pub evaluations: usize,
    /// How many times `JᵀJ` or the dense Jacobian was decomposed.
    pub factorizations: usize,
    /// Final damping `μ` (scaled units).
    pub damping: f64,
}

pub(crate) struct Outcome {
    pub theta: Vec<f64>,
    /// Last accepted evaluation (holds the final residuals).
    pub eval: Evaluation,
    /// Last decomposition of the estimated columns.
    pub scaled: Scaled,
    pub convergence: Convergence,
}

/// The values of a column of an owned matrix (stored contiguously).
pub(crate) fn contiguous(col: faer::ColRef<'_, f64>) -> &[f64] {
    col.try_as_col_major()
        .expect("an owned matrix's columns are contiguous")
        .as_slice()
}

/// Column norms of the evaluated Jacobian (`None` if the pass kept neither
/// the Jacobian nor `JᵀJ`).
pub(crate) fn column_norms(eval: &Evaluation) -> Option<Vec<f64>> {
    if let Some(jt) = &eval.jt {
        // Over the contiguous columns of `Jᵀ` (the rows of J), each sum in
        // row order as a sum over a column of J would be.
        let mut sq = vec![0.0f64; jt.nrows()];
        for i in 0..jt.ncols() {
            for (s, x) in sq.iter_mut().zip(contiguous(jt.col(i))) {
                *s += x * x;
            }
        }
        Some(sq.into_iter().map(f64::sqrt).collect())
    } else {
        eval.normal.as_ref().map(|nm| {
            (0..nm.ncols())
                .map(|c| nm[(c, c)].max(0.0).sqrt())
                .collect()
        })
    }
}

/// The iterate and its bookkeeping.
struct State {
    theta: Vec<f64>,
    eval: Evaluation,
    scaled: Scaled,
    d: Vec<f64>,
    mu: f64,
    iterations: usize,
    evaluations: usize,
    factorizations: usize,
    initial_cost: f64,
}

impl State {
    fn finish(self, reason: StopReason) -> Outcome {
        Outcome {
            theta: self.theta,
            convergence: Convergence {
                iterations: self.iterations,
                initial_cost: self.initial_cost,
                final_cost: self.eval.cost,
                reason,
                evaluations: self.evaluations,
                factorizations: self.factorizations,
                damping: self.mu,
            },
            eval: self.eval,
            scaled: self.scaled,
        }
    }

    /// Moré's scale update from the column norms of a new linearisation.
    fn update_scales(&mut self, kept: &[usize]) {
        if let Some(norms) = column_norms(&self.eval) {
            for (dj, &j) in self.d.iter_mut().zip(kept) {
                *dj = dj.max(norms[j]);
            }
        }
    }
}

/// How the first linearisation is handed over.
pub(crate) enum Start {
    /// Already decomposed over exactly the estimated columns.
    Decomposed(Scaled),
    /// The column scales of the estimated columns; decompose here.
    Scales(Vec<f64>),
}

/// Minimises over the columns `kept`, from `theta0` whose evaluation
/// `eval0` (dense or normal) is given.
pub(crate) fn minimise(
    pass: &Pass<'_>,
    theta0: Vec<f64>,
    eval0: Evaluation,
    kept: &[usize],
    start: Start,
    opts: &Options,
    dense: bool,
) -> Result<Outcome, FitError> {
    let scaled = match start {
        Start::Decomposed(s) => s,
        Start::Scales(d) => Scaled::new(&eval0, kept, &d)?,
    };
    let d0 = scaled.d.clone();
    let max_diag = (0..scaled.len())
        .map(|i| scaled.normal[(i, i)])
        .fold(0.0, f64::max);
    let mu0 = opts.initial_damping * max_diag.max(f64::MIN_POSITIVE);
    let mut st = State {
        theta: theta0,
        initial_cost: eval0.cost,
        eval: eval0,
        scaled,
        d: d0,
        mu: if opts.gauss_newton_first { 0.0 } else { mu0 },
        iterations: 0,
        evaluations: 1,
        factorizations: 1,
    };
    if kept.is_empty() {
        return Ok(st.finish(StopReason::NothingToEstimate));
    }
    let trial_need = if dense { Need::Dense } else { Need::Gradient };
    let mut nu = 2.0;
    loop {
        let rnorm = (2.0 * st.eval.cost).sqrt();
        let gmax = st.scaled.g.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        if st.eval.cost == 0.0 || gmax <= opts.gradient_tolerance * rnorm {
            return Ok(st.finish(StopReason::Gradient));
        }
        if st.iterations >= opts.max_iterations {
            return Ok(st.finish(StopReason::MaxIterations));
        }
        st.iterations += 1;
        let c = st.scaled.project(&st.scaled.g);
        let lmax = st
            .scaled
            .lambda
            .first()
            .copied()
            .unwrap_or(0.0)
            .max(max_diag);
        loop {
            // The undamped step needs every λ clearly positive (the
            // estimated columns are full rank at the start, but the rank
            // can drop along the way).
            let lmin = st.scaled.lambda.last().copied().unwrap_or(0.0);
            if st.mu == 0.0 && lmin <= 1e3 * f64::EPSILON * lmax {
                st.mu = mu0;
            }
            let mu = st.mu;
            let a: Vec<f64> = c
                .iter()
                .zip(&st.scaled.lambda)
                .map(|(ci, li)| -ci / (li + mu))
                .collect();
            let pred: f64 = c
                .iter()
                .zip(&a)
                .zip(&st.scaled.lambda)
                .map(|((ci, ai), li)| -ci * ai - 0.5 * li * ai * ai)
                .sum();
            let y = st.scaled.expand(&a);
            let ynorm = y.iter().map(|x| x * x).sum::<f64>().sqrt();
            let xnorm = kept
                .iter()
                .zip(&st.d)
                .map(|(&j, dj)| (dj * st.theta[j]).powi(2))
                .sum::<f64>()
                .sqrt();
            let tiny_step = ynorm <= opts.step_tolerance * (xnorm + opts.step_tolerance);
            if ynorm == 0.0 {
                return Ok(st.finish(StopReason::Step));
            }
            let mut trial = st.theta.clone();
            for ((&j, yj), dj) in kept.iter().zip(&y).zip(&st.d) {
                trial[j] += yj / dj;
            }
            let te = pass.run(&trial, trial_need)?;
            st.evaluations += 1;
            let actual = st.eval.cost - te.cost;
            let rho = actual / pred;
            let small = actual.abs() <= opts.cost_tolerance * st.eval.cost
                && pred <= opts.cost_tolerance * st.eval.cost;
            if actual > 0.0 && pred > 0.0 {
                st.theta = trial;
                let linear = (rho - 1.0).abs() <= LINEAR_GAIN;
                let reuse = (rho - 1.0).abs() <= opts.reuse_gain;
                // Along a step where the model behaved linearly the
                // quadratic model is trusted: damping drops ten-fold
                // (Nielsen's rule alone never goes below a third).
                st.mu *= if linear {
                    0.1
                } else {
                    (1.0 / 3.0f64).max(1.0 - (2.0 * rho - 1.0).powi(3))
                };
                nu = 2.0;
                let stop = if small && rho <= 2.0 {
                    Some(StopReason::CostChange)
                } else if tiny_step {
                    Some(StopReason::Step)
                } else {
                    None
                };
                if dense {
                    st.eval = te;
                    st.update_scales(kept);
                    st.scaled = Scaled::new(&st.eval, kept, &st.d)?;
                    st.factorizations += 1;
                } else if (reuse || stop.is_some()) && opts.reuse_normal_matrix {
                    // Also when stopping here: a refresh would serve no
                    // further step.
                    st.eval = te;
                    let g = &st.eval.g;
                    st.scaled.g = kept.iter().zip(&st.d).map(|(&j, dj)| g[j] / dj).collect();
                } else {
                    st.eval = pass.run(&st.theta, Need::Normal)?;
                    st.evaluations += 1;
                    st.update_scales(kept);
                    st.scaled = Scaled::new(&st.eval, kept, &st.d)?;
                    st.factorizations += 1;
                }
                (pass.progress)(Progress::Iteration {
                    iteration: st.iterations,
                    cost: st.eval.cost,
                    damping: st.mu,
                });
                if let Some(reason) = stop {
                    return Ok(st.finish(reason));
                }
                break;
            }
            if small {
                return Ok(st.finish(StopReason::CostChange));
            }
            if tiny_step {
                return Ok(st.finish(StopReason::Step));
            }
            // A rejected undamped step: damping from now on.
            st.mu = if st.mu == 0.0 { mu0 } else { st.mu * nu };
            nu *= 2.0;
            if st.mu > 1e30 * lmax.max(1.0) {
                return Ok(st.finish(StopReason::NoProgress));
            }
        }
    }
}
