//! The least-squares engine every identification uses: Levenberg–Marquardt
//! on the exact model with column scaling, identifiability analysis,
//! uncertainties and outlier screening.
//!
//! A measurement model implements [`Model`]: its parameters, the block
//! layout of its residual rows, and one method, [`Model::evaluate`], that
//! writes residuals and/or the exact Jacobian for a range of rows; [`fit`]
//! then
//!
//! 1. evaluates the Jacobian at the start values and analyses which
//!    parameters the data determine ([`identifiability`]): zero columns,
//!    the numerical rank of the column-scaled Jacobian, the confounded
//!    combinations, and which parameters to fix so the rest is full rank;
//! 2. runs Levenberg–Marquardt over the estimated parameters only (the
//!    others stay at their start value, typically 0) ([`lm`]);
//! 3. when parameters are unidentifiable and [`Options::gauge`] asks for
//!    it, moves the solution along the null space only, to the point
//!    closest to a stated prior (e.g. the start values: minimum norm) and
//!    reports the combinations the data determine ([`gauge`]); with a
//!    [`Options::truncation`] rule, badly determined directions are set
//!    to the prior too, and the bias this introduces is reported
//!    ([`truncation`]);
//! 4. reports standard uncertainties and correlations ([`covariance`]),
//!    per-group residual RMS, outlier blocks ([`outliers`]) and warnings,
//!    optionally refitting without the outliers.
//!
//! Two paths ([`Strategy`]):
//! * **dense**: the whole Jacobian in memory, thin SVD of the scaled
//!   Jacobian at every linearisation; the most accurate, for problems up to
//!   [`Options::dense_limit`] entries (a 162-parameter, 540-row tracker fit
//!   takes a few ms).
//! * **normal equations**: `JᵀJ` and `Jᵀr` accumulated chunk by chunk in
//!   parallel (only one chunk of Jacobian rows and the `n × n` matrix in
//!   memory: 300 000 × 1000 would be 2.4 GB as a whole), eigen-decomposed;
//!   `JᵀJ` is reused across iterations while the model behaves linearly.
//!   Chosen over a blocked QR (TSQR) because forming `JᵀJ` with faer's
//!   triangular matmul costs `m·n²` flops once (half of a QR's `2·m·n²`),
//!   runs at matmul speed on both cores, and the reuse makes the remaining
//!   iterations `O(m·n)`; the price is the squared spectrum (rank decisions
//!   are adapted, see [`scaling`]). A model whose Jacobian factors into
//!   per-function derivatives times shared basis vectors ([`Factored`], e.g.
//!   the tracker model: component derivative × Chebyshev values of the
//!   axis position) never forms Jacobian rows: `JᵀJ` comes from products of
//!   basis outer products with function-pair weights (`factored`), about a
//!   third of the work for three-row points, and `Jᵀr` costs `O(n)` per
//!   block.

pub mod check;
pub mod covariance;
mod evaluate;
mod factored;
pub mod gauge;
pub mod identifiability;
pub mod lm;
pub mod outliers;
pub mod problem;
pub mod report;
pub mod scaling;
pub mod truncation;

use serde::Serialize;

pub use check::{JacobianCheck, check_jacobian};
pub use covariance::Covariance;
pub use gauge::{
    CombinationTerm, ConfoundedGroup, DeterminedCombination, Gauge, GaugeReport, GaugedParameter,
    UndeterminedDirection,
};
pub use identifiability::{Combination, Identifiability, RankRule, Term, Unidentifiable};
pub use lm::{Convergence, StopReason};
pub use outliers::{Outlier, OutlierRule, OutlierScan, block_norms};
pub use problem::{BlockLayout, FactorGroup, Factored, Model, Parameter, Stack};
pub use report::{Estimate, FitReport, GroupStats, Warning};
pub use truncation::{DroppedDirection, Truncation, TruncationParseError};

use evaluate::{Need, Pass};
use scaling::Scaled;

/// Why a fit could not be run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    /// The start vector's length is not the model's parameter count.
    #[error("the start vector has {got} values but the model has {expected} parameters")]
    ParameterCount {
        /// Parameters of the model.
        expected: usize,
        /// Values in the start vector.
        got: usize,
    },
    /// The model declares no parameters.
    #[error("the model has no parameters")]
    NoParameters,
    /// The model has no residual rows.
    #[error("the problem has no residual rows")]
    NoResiduals,
    /// A start value is NaN or infinite.
    #[error("start value of parameter {name} is not a finite number")]
    NonFiniteStart {
        /// The parameter's name.
        name: String,
    },
    /// The model returned a NaN or infinite residual or Jacobian entry.
    #[error("the model produced a non-finite {what} value (row {row})")]
    NonFinite {
        /// `residual` or `Jacobian`.
        what: &'static str,
        /// Residual row.
        row: usize,
    },
    /// A part of a stacked model declares other parameters than the first.
    #[error("part {part} of the stack does not declare the same parameters as the first part")]
    StackParameters {
        /// Index of the part.
        part: usize,
    },
    /// An SVD or eigen-decomposition did not converge.
    #[error("a matrix decomposition failed to converge")]
    Decomposition,
}

/// Which linear-algebra path to take.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Strategy {
    /// Dense when `m·n ≤ dense_limit`, normal equations otherwise.
    #[default]
    Auto,
    /// Whole Jacobian, SVD.
    Dense,
    /// `JᵀJ` accumulated by row chunks, eigen-decomposition.
    NormalEquations,
}

/// What the engine reports while it works (for a progress bar). Called
/// from the calling thread only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress {
    /// A pass over the residual rows.
    Evaluating {
        /// Rows evaluated in this pass.
        rows_done: usize,
        /// Rows of the problem.
        rows_total: usize,
    },
    /// The identifiability analysis is running.
    Analysing,
    /// An accepted Levenberg–Marquardt step.
    Iteration {
        /// Iteration number, from 1.
        iteration: usize,
        /// `½‖r‖²` after the step (residual unit squared).
        cost: f64,
        /// Levenberg–Marquardt damping λ after the step.
        damping: f64,
    },
}

/// Settings of a fit. The defaults suit the identifications of this crate.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// Linear-algebra path (default [`Strategy::Auto`]).
    pub strategy: Strategy,
    /// Largest `m·n` for which [`Strategy::Auto`] goes dense (default
    /// 2²⁴ ≈ 16.8 M entries, 134 MB).
    pub dense_limit: usize,
    /// How the numerical rank is decided.
    pub rank: RankRule,
    /// Largest number of Levenberg–Marquardt iterations; default 100.
    pub max_iterations: usize,
    /// Gradient test (MINPACK `gtol`), default 1e-10.
    pub gradient_tolerance: f64,
    /// Step test (MINPACK `xtol`), default 1e-10.
    pub step_tolerance: f64,
    /// Cost-change test (MINPACK `ftol`), default 1e-12.
    pub cost_tolerance: f64,
    /// `τ₀` of the initial damping `μ = τ₀·max diag(Nₛ)`, default 1e-3.
    pub initial_damping: f64,
    /// Begin with undamped Gauss–Newton steps (`μ = 0`) and damp with
    /// `τ₀·max diag(Nₛ)` from the first rejected step on (default true):
    /// the estimated columns are full rank, and identifications are almost
    /// linear, so this saves the passes a damped start spends creeping up
    /// to the solution.
    pub gauss_newton_first: bool,
    /// Normal-equation path: keep `JᵀJ` after a step whose gain ratio is
    /// within `reuse_gain` of 1 (default 0.1).
    pub reuse_gain: f64,
    /// Normal-equation path: allow the reuse at all (default true).
    pub reuse_normal_matrix: bool,
    /// Rows per chunk on the normal-equation path (default 8192: 64 MB of
    /// Jacobian for 1000 parameters).
    pub chunk_rows: usize,
    /// Normal-equation path: use the model's factored Jacobian
    /// ([`Model::factored`]) when it has one (default true); false forms
    /// Jacobian rows as for any model.
    pub factored: bool,
    /// Which blocks count as outliers and whether they are left out.
    pub outliers: OutlierRule,
    /// Warn above this condition number of the scaled Jacobian of the
    /// estimated parameters (default 1e6: uncertainties amplified a million
    /// times along the weakest direction).
    pub ill_conditioned_above: f64,
    /// Where the parameters the data do not determine are put after
    /// convergence (see [`gauge`]; the predictions at the measured points do
    /// not change). Default [`Gauge::Pivoted`]: no gauge fixing, the
    /// confounded parameters stay at their start values; the tracker
    /// identification chooses [`Gauge::Start`] (closest to the start values
    /// in the scaled variables, the minimum-norm solution when they are 0).
    pub gauge: Gauge,
    /// Rank rule for badly determined (not null) directions: which of them
    /// are set to the gauge's prior as well (a truncated SVD; see
    /// [`truncation`]). Default [`Truncation::Off`]. Ignored with
    /// [`Gauge::Pivoted`].
    pub truncation: Truncation,
    /// Parallelism of the evaluation and the decompositions:
    /// [`Par::Seq`](crate::par::Par::Seq) on the calling thread only,
    /// `Par::rayon(_)` (default `Par::rayon(0)`) on the rayon pool the call
    /// runs in (choose its size with [`crate::par::install`]).
    pub par: crate::par::Par,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            strategy: Strategy::Auto,
            dense_limit: 1 << 24,
            rank: RankRule::Auto,
            max_iterations: 100,
            gradient_tolerance: 1e-10,
            step_tolerance: 1e-10,
            cost_tolerance: 1e-12,
            initial_damping: 1e-3,
            gauss_newton_first: true,
            reuse_gain: 0.1,
            reuse_normal_matrix: true,
            chunk_rows: 8192,
            factored: true,
            outliers: OutlierRule::default(),
            ill_conditioned_above: 1e6,
            gauge: Gauge::Pivoted,
            truncation: Truncation::Off,
            par: crate::par::Par::rayon(0),
        }
    }
}

/// Fits `model` from `theta0`. See the module documentation.
pub fn fit(model: &dyn Model, theta0: &[f64], options: &Options) -> Result<FitReport, FitError> {
    fit_with_progress(model, theta0, options, &|_| {})
}

/// [`fit`] with a progress hook.
pub fn fit_with_progress(
    model: &dyn Model,
    theta0: &[f64],
    options: &Options,
    progress: &dyn Fn(Progress),
) -> Result<FitReport, FitError> {
    crate::par::here(options.par, || fit_here(model, theta0, options, progress))
}

/// [`fit_with_progress`] on the current thread's parallelism.
fn fit_here(
    model: &dyn Model,
    theta0: &[f64],
    options: &Options,
    progress: &dyn Fn(Progress),
) -> Result<FitReport, FitError> {
    let params = model.parameters();
    let layout = model.layout();
    let (m, n) = (layout.rows(), params.len());
    if n == 0 {
        return Err(FitError::NoParameters);
    }
    if theta0.len() != n {
        return Err(FitError::ParameterCount {
            expected: n,
            got: theta0.len(),
        });
    }
    if let Some(j) = theta0.iter().position(|t| !t.is_finite()) {
        return Err(FitError::NonFiniteStart {
            name: params[j].name.clone(),
        });
    }
    if m == 0 {
        return Err(FitError::NoResiduals);
    }
    let strategy = match options.strategy {
        Strategy::Auto if m.saturating_mul(n) <= options.dense_limit => Strategy::Dense,
        Strategy::Auto => Strategy::NormalEquations,
        s => s,
    };
    let dense = strategy == Strategy::Dense;
    let plan = match model.factored() {
        Some(f) if !dense && options.factored => factored::plan_for(f, n).map(|p| (f, p)),
        _ => None,
    };
    let factors = plan.as_ref().map(|(f, p)| (*f, p));
    let mut included = vec![true; layout.blocks()];
    let mut stage = Stage::run(
        model, &layout, &params, theta0, &included, options, dense, factors, progress,
    )?;
    let mut scan = outliers::scan(&stage.outcome.eval.r, &layout, &included, options.outliers);
    if options.outliers.exclude && !scan.flagged.is_empty() {
        for o in &scan.flagged {
            included[o.block] = false;
        }
        stage = Stage::run(
            model, &layout, &params, theta0, &included, options, dense, factors, progress,
        )?;
        // Residuals of every block, excluded ones included, at the solution.
        let all = vec![true; layout.blocks()];
        let pass = Pass {
            model,
            layout: &layout,
            n,
            included: &all,
            chunk_rows: options.chunk_rows,
            progress,
            factored: factors,
        };
        let r = pass.run(&stage.outcome.theta, Need::Residuals)?.r;
        scan = outliers::scan(&r, &layout, &included, options.outliers);
        stage.outcome.eval.r = r;
    }
    Ok(stage.report(&layout, &params, theta0, &included, scan, strategy, options))
}

/// One complete fit over a fixed set of blocks.
struct Stage {
    ident: Identifiability,
    outcome: lm::Outcome,
    fixed: Option<gauge::Fixed>,
    initial_r: Vec<f64>,
    tau: f64,
}

impl Stage {
    #[allow(clippy::too_many_arguments)]
    fn run(
        model: &dyn Model,
        layout: &BlockLayout,
        params: &[Parameter],
        theta0: &[f64],
        included: &[bool],
        options: &Options,
        dense: bool,
        factors: Option<(&dyn Factored, &factored::Plan)>,
        progress: &dyn Fn(Progress),
    ) -> Result<Self, FitError> {
        let (m, n) = (layout.rows(), params.len());
        let pass = Pass {
            model,
            layout,
            n,
            included,
            chunk_rows: options.chunk_rows,
            progress,
            factored: factors,
        };
        let eval0 = pass.run(theta0, if dense { Need::Dense } else { Need::Normal })?;
        progress(Progress::Analysing);
        let norms = lm::column_norms(&eval0).ok_or(FitError::Decomposition)?;
        let source = if dense {
            scaling::Source::DenseSvd
        } else {
            scaling::Source::NormalEigen
        };
        let tau = identifiability::threshold(options.rank, source, m, n);
        let zero_tau = identifiability::threshold(options.rank, scaling::Source::DenseSvd, m, n);
        let zero = identifiability::zero_columns(&norms, params, zero_tau);
        let nonzero: Vec<usize> = (0..n).filter(|&j| !zero[j]).collect();
        let d: Vec<f64> = nonzero.iter().map(|&j| norms[j]).collect();
        let scaled = Scaled::new(&eval0, &nonzero, &d)?;
        let ident = identifiability::analyse(&scaled, &zero, params, tau);
        let kept = ident.estimated.clone();
        // Full rank over the non-zero columns: the decomposition is reused.
        let start = if kept == nonzero {
            lm::Start::Decomposed(scaled)
        } else {
            lm::Start::Scales(kept.iter().map(|&j| norms[j]).collect())
        };
        let initial_r = eval0.r.clone();
        let mut outcome =
            lm::minimise(&pass, theta0.to_vec(), eval0, &kept, start, options, dense)?;
        let rows_in: usize = (0..layout.blocks())
            .filter(|&b| included[b])
            .map(|b| layout.block_rows(b).len())
            .sum();
        let truncating = options.truncation != truncation::Truncation::Off;
        let fixed = match options.gauge.prior(theta0) {
            Some(prior) if kept.len() < n || truncating => {
                if prior.len() != n {
                    return Err(FitError::ParameterCount {
                        expected: n,
                        got: prior.len(),
                    });
                }
                Some(gauge::fix(
                    &pass,
                    &mut outcome,
                    &zero,
                    &nonzero,
                    &d,
                    kept.len(),
                    &kept,
                    prior,
                    options,
                    dense,
                    params,
                    rows_in,
                )?)
            }
            _ => None,
        };
        Ok(Self {
            ident,
            outcome,
            fixed,
            initial_r,
            tau,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn report(
        self,
        layout: &BlockLayout,
        params: &[Parameter],
        theta0: &[f64],
        included: &[bool],
        scan: OutlierScan,
        strategy: Strategy,
        options: &Options,
    ) -> FitReport {
        let Stage {
            ident,
            outcome,
            fixed,
            initial_r,
            tau,
        } = self;
        let rows_in: usize = (0..layout.blocks())
            .filter(|&b| included[b])
            .map(|b| layout.block_rows(b).len())
            .sum();
        let rank = outcome.scaled.len();
        let dof = rows_in.saturating_sub(rank);
        let mut warnings = Vec::new();
        let (covariance, sigma) = if dof > 0 {
            let sigma2 = 2.0 * outcome.convergence.final_cost / dof as f64;
            let (mut c, lost) = Covariance::from_scaled(&outcome.scaled, sigma2, tau);
            if lost > 0 {
                warnings.push(Warning::SingularAtSolution { directions: lost });
            }
            if let Some(f) = &fixed {
                c = Covariance::pseudo_inverse(&f.scaled, sigma2, f.rank.saturating_sub(lost));
            }
            (Some(c), Some(sigma2.sqrt()))
        } else {
            warnings.push(Warning::NoDegreesOfFreedom);
            (None, None)
        };
        let lambda = &outcome.scaled.lambda;
        let condition_number = match (lambda.first(), lambda.last()) {
            (Some(&a), Some(&b)) if b > 0.0 => (a / b).sqrt(),
            (Some(_), Some(_)) => f64::INFINITY,
            _ => 1.0,
        };
        if condition_number > options.ill_conditioned_above {
            warnings.push(Warning::IllConditioned { condition_number });
        }
        if ident.rank < params.len() {
            warnings.push(Warning::RankDeficient {
                rank: ident.rank,
                parameters: params.len(),
            });
        }
        if !outcome.convergence.reason.converged() {
            warnings.push(Warning::NotConverged {
                reason: outcome.convergence.reason,
            });
        }
        if !scan.flagged.is_empty() {
            warnings.push(Warning::Outliers {
                flagged: scan.flagged.len(),
                excluded: scan.flagged.iter().filter(|o| o.excluded).count(),
            });
        }
        let why: Vec<Option<Unidentifiable>> = (0..params.len())
            .map(|j| ident.unidentifiable.iter().find(|u| u.0 == j).map(|u| u.1))
            .collect();
        let estimates = params
            .iter()
            .enumerate()
            .map(|(j, p)| Estimate {
                name: p.name.clone(),
                start: theta0[j],
                value: outcome.theta[j],
                uncertainty: covariance.as_ref().and_then(|c| c.std(j)),
                unidentifiable: why[j],
            })
            .collect();
        let groups = group_stats(layout, included, &initial_r, &outcome.eval.r);
        let gauge = fixed.as_ref().map(|f| {
            gauge::report(
                f,
                &options.gauge,
                params,
                &outcome.theta,
                covariance.as_ref(),
            )
        });
        FitReport {
            strategy,
            gauge,
            estimates,
            theta: outcome.theta,
            convergence: outcome.convergence,
            identifiability: ident,
            condition_number,
            sigma,
            degrees_of_freedom: dof,
            groups,
            outliers: scan,
            warnings,
            covariance,
            residuals: outcome.eval.r,
        }
    }
}

fn group_stats(
    layout: &BlockLayout,
    included: &[bool],
    before: &[f64],
    after: &[f64],
) -> Vec<GroupStats> {
    let mut groups: Vec<GroupStats> = layout
        .labels()
        .iter()
        .map(|l| GroupStats {
            label: l.clone(),
            blocks: 0,
            excluded_blocks: 0,
            rows: 0,
            rms_before: 0.0,
            rms_after: 0.0,
            max_block_norm_after: 0.0,
        })
        .collect();
    for b in 0..layout.blocks() {
        let g = &mut groups[layout.block_group(b)];
        if !included[b] {
            g.excluded_blocks += 1;
            continue;
        }
        let rows = layout.block_rows(b);
        g.blocks += 1;
        g.rows += rows.len();
        g.rms_before += before[rows.clone()].iter().map(|x| x * x).sum::<f64>();
        let a: f64 = after[rows].iter().map(|x| x * x).sum();
        g.rms_after += a;
        g.max_block_norm_after = g.max_block_norm_after.max(a.sqrt());
    }
    for g in &mut groups {
        if g.rows > 0 {
            g.rms_before = (g.rms_before / g.rows as f64).sqrt();
            g.rms_after = (g.rms_after / g.rows as f64).sqrt();
        }
    }
    groups
}

#[cfg(test)]
mod tests;
