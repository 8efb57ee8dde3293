//! Rank rule for badly determined directions: a truncated SVD toward the
//! gauge's prior.
//!
//! Gauge fixing ([`super::gauge`]) sets the directions the data do not see
//! at all. Directions the data see only faintly are another matter: their
//! singular value `sᵢ` of the column-scaled Jacobian is small but not zero,
//! so the least-squares estimate along them is the data's, amplified by
//! `1/sᵢ` — its standard uncertainty in the scaled variables is `σ/sᵢ`.
//! On a large gantry model these directions carry straightness constants of
//! hundreds of µm that cancel each other at the measured poses: a table
//! built from one of them is wrong although the model predicts the
//! measurements well.
//!
//! With a [`Truncation`] rule, such a direction `vᵢ` (right singular vector,
//! scaled variables `y = D·θ`) is dropped: the solution's component along
//! it is set to the prior's,
//!
//! `y ← y − Σ_dropped vᵢ·vᵢᵀ·(y − y_p)`,
//!
//! exactly as for the null directions, and the estimated parameters are
//! polished by Gauss–Newton steps restricted to the kept directions (for a
//! model linear in θ the projection is already the truncated-SVD solution;
//! the steps take back the model's curvature). The price is a bias: the
//! truth's component along a dropped direction is replaced by the prior's.
//! Per dropped direction the report ([`DroppedDirection`]) gives
//!
//! * its relative singular value `sᵢ/s_max`;
//! * the estimate's component `cᵢ = vᵢᵀ·(y − y_p)` with its standard
//!   uncertainty `σ/sᵢ` (scaled variables);
//! * what keeping it would have bought on the measured poses: the RMS
//!   change of the residuals, `sᵢ·|cᵢ|/√m` (residual unit, `m` rows) — the
//!   predicted-error cost of dropping it;
//! * the parameter it moves most, by how much the truncation moved it
//!   (`cᵢ·v_ij/D_j`), and a bias bound for that parameter,
//!   `(|cᵢ| + 2σ/sᵢ)·|v_ij|/D_j`: the truth's component lies within
//!   `cᵢ ± 2σ/sᵢ` at about 95 % confidence, and the truncation replaces it
//!   by the prior's.
//!
//! The covariance reported is the truncated pseudo-inverse over the kept
//! directions (the scatter given the truncation); the bias is the report's.

use std::fmt;
use std::str::FromStr;

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use serde::{Deserialize, Serialize};

use super::FitError;
use super::evaluate::{Need, Pass};
use super::problem::Parameter;
use super::scaling::Scaled;

/// Which badly determined (non-null) directions are set by the gauge too.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Truncation {
    /// Keep every direction above the rank threshold (plain gauge fixing).
    #[default]
    Off,
    /// Drop directions whose singular value is below this fraction of the
    /// largest (`sᵢ < rcond·s_max`, column-scaled Jacobian).
    Relative(f64),
    /// Drop directions whose standard uncertainty puts more than this many
    /// typical scales ([`Parameter::scale`], 1 when unknown) into some
    /// parameter: `max_j σ/sᵢ·|v_ij|/(D_j·scale_j) > bound`, `σ` the
    /// residual standard deviation of the fit. For the tracker model the
    /// typical scales are 1 µm (lengths) and 10 µrad (angles), so `10`
    /// drops directions that would scatter a parameter by more than 10 µm
    /// or 100 µrad.
    Uncertainty(f64),
}

impl fmt::Display for Truncation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Truncation::Off => write!(f, "off"),
            Truncation::Relative(r) => write!(f, "rcond={r}"),
            Truncation::Uncertainty(b) => write!(f, "std={b}"),
        }
    }
}

/// Why a truncation rule could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "'{0}' is not a truncation rule: expected off, rcond=X (0 < X < 1) or std=X (X > 0, in typical scales)"
)]
pub struct TruncationParseError(pub String);

impl FromStr for Truncation {
    type Err = TruncationParseError;

    /// `off`, `rcond=1e-3` or `std=10`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || TruncationParseError(s.to_string());
        let t = s.trim();
        if t == "off" || t == "none" {
            return Ok(Truncation::Off);
        }
        let (key, value) = t.split_once('=').ok_or_else(err)?;
        let x: f64 = value.trim().parse().map_err(|_| err())?;
        match key.trim() {
            "rcond" if x > 0.0 && x < 1.0 => Ok(Truncation::Relative(x)),
            "std" if x > 0.0 && x.is_finite() => Ok(Truncation::Uncertainty(x)),
            _ => Err(err()),
        }
    }
}

/// One badly determined direction the rule dropped (see the module
/// documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DroppedDirection {
    /// `sᵢ/s_max` of the column-scaled Jacobian.
    pub relative_singular_value: f64,
    /// The estimate's component `cᵢ` along the direction, relative to the
    /// prior (scaled variables: residual unit).
    pub component: f64,
    /// Its standard uncertainty `σ/sᵢ` (scaled variables), when there are
    /// degrees of freedom.
    pub component_uncertainty: Option<f64>,
    /// RMS change of the residuals at the measured points had it been kept,
    /// `sᵢ·|cᵢ|/√m` (residual unit).
    pub rms_change: f64,
    /// The parameter the direction moves most (in typical scales).
    pub parameter: String,
    /// How much the truncation moved that parameter (parameter unit).
    pub shift: f64,
    /// Bias bound for that parameter, `(|cᵢ| + 2σ/sᵢ)·|v_ij|/D_j`
    /// (parameter unit; `|shift|` without degrees of freedom).
    pub bias_bound: f64,
}

/// The directions to drop (indices into the decomposition `s`, below
/// `rank`) by `rule`, with residual standard deviation `sigma`.
pub(crate) fn select(
    rule: Truncation,
    s: &Scaled,
    rank: usize,
    sigma: Option<f64>,
    params: &[Parameter],
) -> Vec<usize> {
    let s0 = s.lambda.first().copied().unwrap_or(0.0).sqrt();
    (0..rank)
        .filter(|&i| {
            let si = s.lambda[i].sqrt();
            match rule {
                Truncation::Off => false,
                Truncation::Relative(r) => si < r * s0,
                Truncation::Uncertainty(b) => sigma.is_some_and(|sg| {
                    let worst = (0..s.len())
                        .map(|a| {
                            let scale = params[s.cols[a]].scale.unwrap_or(1.0).abs();
                            s.v[(a, i)].abs() / (s.d[a] * scale)
                        })
                        .fold(0.0, f64::max);
                    sg / si * worst > b
                }),
            }
        })
        .collect()
}

/// Applies the truncation: `theta` (the gauge-fixed least-squares solution,
/// decomposed in `s`) loses its components along `drop` relative to
/// `prior`, then Gauss–Newton steps over the directions `keep` polish it.
/// Returns the report of every dropped direction and the passes used.
#[allow(clippy::too_many_arguments)]
pub(crate) fn apply(
    pass: &Pass<'_>,
    need: Need,
    theta: &mut [f64],
    s: &Scaled,
    keep: &[usize],
    drop: &[usize],
    prior: &[f64],
    sigma: Option<f64>,
    rows: usize,
    params: &[Parameter],
) -> Result<(Vec<DroppedDirection>, usize), FitError> {
    let k = s.len();
    let y: Vec<f64> = (0..k)
        .map(|a| s.d[a] * (theta[s.cols[a]] - prior[s.cols[a]]))
        .collect();
    let mut report = Vec::new();
    let s0 = s.lambda.first().copied().unwrap_or(0.0).sqrt();
    for &i in drop {
        let si = s.lambda[i].sqrt();
        let c: f64 = (0..k).map(|a| s.v[(a, i)] * y[a]).sum();
        let lead = (0..k)
            .max_by(|&a, &b| {
                let w = |x: usize| {
                    s.v[(x, i)].abs() / (s.d[x] * params[s.cols[x]].scale.unwrap_or(1.0).abs())
                };
                w(a).total_cmp(&w(b))
            })
            .unwrap_or(0);
        let per = s.v[(lead, i)] / s.d[lead];
        let std = sigma.map(|sg| sg / si);
        report.push(DroppedDirection {
            relative_singular_value: if s0 > 0.0 { si / s0 } else { 0.0 },
            component: c,
            component_uncertainty: std,
            rms_change: si * c.abs() / (rows.max(1) as f64).sqrt(),
            parameter: params[s.cols[lead]].name.clone(),
            shift: -c * per,
            bias_bound: (c.abs() + 2.0 * std.unwrap_or(0.0)) * per.abs(),
        });
        for a in 0..k {
            theta[s.cols[a]] -= c * s.v[(a, i)] / s.d[a];
        }
    }
    // Gauss–Newton over the kept directions (fixed basis): min over δ of
    // ‖r + Jₛ·K·δ‖², i.e. (Kᵀ·Nₛ·K)·δ = −Kᵀ·g.
    let mut passes = 0;
    if keep.is_empty() {
        return Ok((report, passes));
    }
    let kb = Mat::<f64>::from_fn(k, keep.len(), |a, c| s.v[(a, keep[c])]);
    let mut e = pass.run(theta, need)?;
    passes += 1;
    for _ in 0..4 {
        let sc = Scaled::new(&e, &s.cols, &s.d)?;
        let a = kb.transpose() * &sc.normal * &kb;
        let g = Mat::<f64>::from_fn(k, 1, |i, _| sc.g[i]);
        let b = kb.transpose() * &g;
        let Ok(llt) = a.llt(Side::Lower) else { break };
        let delta = llt.solve(&b);
        let dy = &kb * &delta;
        let mut trial = theta.to_vec();
        for a in 0..k {
            trial[s.cols[a]] -= dy[(a, 0)] / s.d[a];
        }
        let e2 = pass.run(&trial, need)?;
        passes += 1;
        if e2.cost >= e.cost {
            break;
        }
        let gain = e.cost - e2.cost;
        theta.copy_from_slice(&trial);
        e = e2;
        if gain <= 1e-12 * e.cost.max(f64::MIN_POSITIVE) {
            break;
        }
    }
    Ok((report, passes))
}

/// `s` with its directions reordered: `keep` first, then `drop`, then the
/// rest (the null directions), so that the first `keep.len()` directions
/// are those the covariance and the gauge report treat as determined.
pub(crate) fn reorder(s: &Scaled, keep: &[usize], drop: &[usize], rank: usize) -> Scaled {
    let order: Vec<usize> = keep
        .iter()
        .chain(drop)
        .copied()
        .chain(rank..s.len())
        .collect();
    Scaled {
        cols: s.cols.clone(),
        d: s.d.clone(),
        lambda: order.iter().map(|&i| s.lambda[i]).collect(),
        v: Mat::from_fn(s.len(), s.len(), |a, c| s.v[(a, order[c])]),
        normal: s.normal.clone(),
        g: s.g.clone(),
        source: s.source,
    }
}
