//! What a fit hands back: estimates with uncertainties, the identifiability
//! analysis, convergence, per-group residual statistics, outliers and
//! warnings. Everything except the large arrays serialises to JSON.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::Strategy;
use super::covariance::Covariance;
use super::gauge::GaugeReport;
use super::identifiability::{Identifiability, Unidentifiable};
use super::lm::{Convergence, StopReason};
use super::outliers::OutlierScan;

/// One parameter's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Parameter name.
    pub name: String,
    /// Start value (parameter unit).
    pub start: f64,
    /// Final value. For a parameter not estimated: its start value without
    /// gauge fixing; with it ([`super::Gauge`]), the gauge-fixed value (its
    /// prior plus its share of the determined combinations).
    pub value: f64,
    /// Standard uncertainty (parameter unit); `None` when the column is zero,
    /// when not estimated without gauge fixing, or when there are no degrees
    /// of freedom. With gauge fixing, from the pseudo-inverse covariance:
    /// the scatter given the gauge, not the distance from the truth of the
    /// undetermined part.
    pub uncertainty: Option<f64>,
    /// `None` when estimated, otherwise why not.
    pub unidentifiable: Option<Unidentifiable>,
}

/// Residual statistics of one labelled group of blocks.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroupStats {
    /// Group label (as the model names its blocks).
    pub label: String,
    /// Blocks taking part in the fit.
    pub blocks: usize,
    /// Blocks left out as outliers.
    pub excluded_blocks: usize,
    /// Residual rows taking part.
    pub rows: usize,
    /// RMS per row at the start over the rows taking part (residual unit).
    pub rms_before: f64,
    /// RMS per row at the solution.
    pub rms_after: f64,
    /// Largest block norm `‖r_b‖` at the solution over the blocks taking
    /// part.
    pub max_block_norm_after: f64,
}

/// Something the user must know about the result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Warning {
    /// The condition number of the scaled Jacobian of the estimated
    /// parameters exceeds [`super::Options::ill_conditioned_above`].
    IllConditioned {
        /// The condition number.
        condition_number: f64,
    },
    /// Some parameters are not identifiable: they are set by the gauge
    /// (closest to the prior, see [`super::Gauge`]), or left at their start
    /// values with [`super::Gauge::Pivoted`].
    RankDeficient {
        /// Numerical rank.
        rank: usize,
        /// Parameters of the model.
        parameters: usize,
    },
    /// The iteration stopped without converging.
    NotConverged {
        /// Why it stopped.
        reason: StopReason,
    },
    /// At the solution, directions that were identifiable at the start have
    /// become singular; they were left out of the covariance.
    SingularAtSolution {
        /// Directions left out.
        directions: usize,
    },
    /// `m ≤ rank`: no residual variance, no uncertainties.
    NoDegreesOfFreedom,
    /// Blocks flagged as outliers (listed in the report).
    Outliers {
        /// Blocks flagged.
        flagged: usize,
        /// Blocks left out of the fit.
        excluded: usize,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::IllConditioned { condition_number } => write!(
                f,
                "the identification is ill-conditioned: condition number {condition_number:.3e} of the scaled Jacobian"
            ),
            Warning::RankDeficient { rank, parameters } => write!(
                f,
                "only {rank} of {parameters} parameters are identifiable; the others are not determined individually (see the determined combinations)"
            ),
            Warning::NotConverged { reason } => {
                write!(f, "the iteration did not converge (stopped: {reason:?})")
            }
            Warning::SingularAtSolution { directions } => write!(
                f,
                "{directions} parameter directions became singular at the solution and have no uncertainty"
            ),
            Warning::NoDegreesOfFreedom => write!(
                f,
                "there are no more residuals than estimated parameters: no uncertainties"
            ),
            Warning::Outliers { flagged, excluded } => write!(
                f,
                "{flagged} measurement blocks flagged as outliers, {excluded} of them excluded from the fit"
            ),
        }
    }
}

/// The result of [`super::fit`].
#[derive(Debug, Clone, Serialize)]
pub struct FitReport {
    /// The path actually taken.
    /// The linear-algebra path taken.
    pub strategy: Strategy,
    /// Per parameter, in the model's order.
    pub estimates: Vec<Estimate>,
    /// Final parameter vector.
    pub theta: Vec<f64>,
    /// How the iteration ended.
    pub convergence: Convergence,
    /// Analysis at the start values of the final fit.
    pub identifiability: Identifiability,
    /// What the gauge fixing did (`None` when every parameter is estimated
    /// or with [`super::Gauge::Pivoted`]).
    pub gauge: Option<GaugeReport>,
    /// Condition number of the scaled Jacobian of the estimated parameters
    /// at the solution.
    pub condition_number: f64,
    /// Residual standard deviation `σ = √(2·cost/(m − rank))` (residual
    /// unit); `None` without degrees of freedom.
    pub sigma: Option<f64>,
    /// `m − rank` over the rows taking part.
    pub degrees_of_freedom: usize,
    /// Residual statistics per labelled group of blocks.
    pub groups: Vec<GroupStats>,
    /// Outlier scan at the solution.
    pub outliers: OutlierScan,
    /// What the user must know about the result.
    pub warnings: Vec<Warning>,
    /// Covariance of the estimated parameters (`None` without degrees of
    /// freedom).
    #[serde(skip)]
    pub covariance: Option<Covariance>,
    /// Final residuals of every row (excluded blocks included).
    #[serde(skip)]
    pub residuals: Vec<f64>,
}

impl FitReport {
    /// Names of the parameters that were not estimated.
    pub fn unidentifiable_names(&self) -> Vec<&str> {
        self.estimates
            .iter()
            .filter(|e| e.unidentifiable.is_some())
            .map(|e| e.name.as_str())
            .collect()
    }

    /// One line for logs and benchmarks: size, rank, conditioning, work
    /// done and the RMS per row before → after (residual unit).
    pub fn summary(&self) -> String {
        let c = &self.convergence;
        let (before, after) = self.rms();
        format!(
            "{} parameters, rank {}, condition {:.3e}, {} iterations, {} passes, {} factorizations, {:?}, rms {:.3e} → {:.3e}",
            self.estimates.len(),
            self.identifiability.rank,
            self.condition_number,
            c.iterations,
            c.evaluations,
            c.factorizations,
            c.reason,
            before,
            after
        )
    }

    /// RMS per row over all groups at the start and at the solution.
    pub fn rms(&self) -> (f64, f64) {
        let rows: usize = self.groups.iter().map(|g| g.rows).sum();
        if rows == 0 {
            return (0.0, 0.0);
        }
        let sq = |f: fn(&GroupStats) -> f64| {
            (self
                .groups
                .iter()
                .map(|g| f(g).powi(2) * g.rows as f64)
                .sum::<f64>()
                / rows as f64)
                .sqrt()
        };
        (sq(|g| g.rms_before), sq(|g| g.rms_after))
    }
}
