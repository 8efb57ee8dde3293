//! Gauge fixing: where a rank-deficient fit puts the parameters the data do
//! not determine, and which combinations of them the data do determine.
//!
//! Levenberg–Marquardt runs over the estimated parameters only (the
//! pivoted basic solution: every confounded parameter stays at its start
//! value and an estimated partner absorbs the whole combination). The
//! predictions are right, but the individual values are an artefact of the
//! pivoting — a constant straightness term of hundreds of µm that another
//! term cancels. After convergence the solution is moved along the
//! unidentifiable directions only, to the point closest to a stated prior
//! `θ_p` in the scaled variables `y = D·θ` (`D` the column scales of the
//! identifiability analysis):
//!
//! `y ← y − N·Nᵀ·(y − y_p)`,
//!
//! `N` an orthonormal basis of the null space of the scaled Jacobian at the
//! solution (the right singular vectors of its `k − rank` smallest singular
//! values, from the same decomposition the fit uses). With `θ_p = 0` this is
//! the minimum-norm solution in the scaled variables. Parameters whose
//! column is zero are set to their prior. Since `J·N = 0`, the residuals
//! (the predictions at the measured poses) do not change to first order; a
//! model that is not linear in θ changes them to second order, which
//! Levenberg–Marquardt over the estimated parameters, restarted from the
//! projected point, takes back (the confounded parameters keep their
//! gauge-fixed values; the estimated ones move by a second-order amount, so
//! the gauge holds to second order).
//!
//! The covariance of the gauge-fixed estimate is the pseudo-inverse
//! `σ²·D⁻¹·V_r·Λ_r⁻¹·V_rᵀ·D⁻¹` over every non-zero column: the scatter the
//! noise causes *given the gauge*. It says nothing about how far the
//! undetermined part lies from the truth — the data cannot — so a
//! confounded parameter's uncertainty is that of its share of the
//! determined combination, not the ±hundreds of µm of the basic solution.
//!
//! What the data determine is reported per *confounded group*: parameters
//! are linked when the null-space projector `P = N·Nᵀ` (independent of the
//! arbitrary choice of basis) couples them (`|P_ij| > 10⁻⁶`); within a group
//! of `c` parameters carrying `q` null directions, the `c − q` unit vectors
//! orthogonal to the null space (eigenvectors of `I − P` restricted to the
//! group) are the determined combinations, each with its value and standard
//! uncertainty — unchanged by the gauge.

use faer::{Mat, Side};
use serde::{Deserialize, Serialize};

use super::covariance::Covariance;
use super::evaluate::{Need, Pass};
use super::lm::{self, Outcome};
use super::problem::Parameter;
use super::scaling::Scaled;
use super::{FitError, Options};

/// Where the parameters the data do not determine are put.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Gauge {
    /// No gauge fixing (the engine's default): each confounded parameter
    /// stays at its start value and an estimated partner carries the whole
    /// combination (the pivoted basic solution; the uncertainties are those
    /// of the estimated parameters alone).
    #[default]
    Pivoted,
    /// Closest to the start values in the scaled variables (the tracker
    /// identification's default). The tracker starts the errors at 0, so
    /// this is the minimum-norm solution.
    Start,
    /// Closest to these values (one per parameter, in parameter units), e.g.
    /// a previous calibration.
    Prior(Vec<f64>),
}

impl Gauge {
    /// The prior for a fit started at `theta0`, `None` for [`Gauge::Pivoted`].
    pub(crate) fn prior(&self, theta0: &[f64]) -> Option<Vec<f64>> {
        match self {
            Gauge::Pivoted => None,
            Gauge::Start => Some(theta0.to_vec()),
            Gauge::Prior(p) => Some(p.clone()),
        }
    }
}

/// Couplings of the null-space projector below this are rounding.
const LINK: f64 = 1e-6;

/// A parameter the gauge set (wholly or in part).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GaugedParameter {
    /// Parameter index in the model's order.
    pub index: usize,
    /// Parameter name.
    pub name: String,
    /// The prior it was pulled to (parameter unit).
    pub prior: f64,
    /// Its value after gauge fixing (parameter unit).
    pub value: f64,
    /// Share of the parameter (in the scaled variables) that the data do not
    /// determine, `‖Nᵀe_j‖² ∈ [0, 1]`: 1 for a parameter the data do not see
    /// at all (it equals its prior), small for one that is almost determined.
    pub undetermined: f64,
}

/// One term of a determined combination.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CombinationTerm {
    /// Parameter name.
    pub name: String,
    /// Coefficient in parameter units (1 for the leading term).
    pub coefficient: f64,
    /// Coefficient of the unit vector in the scaled variables.
    pub scaled: f64,
}

/// A combination of parameters the data determine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeterminedCombination {
    /// The combination is `Σ coefficient·θ`, in the unit of the first
    /// (leading) parameter, whose coefficient is 1; terms ordered by their
    /// weight in the scaled variables, those below 10⁻⁶ of the leading one
    /// left out.
    pub terms: Vec<CombinationTerm>,
    /// Its value (unit of the leading parameter).
    pub value: f64,
    /// Its standard uncertainty, when there are degrees of freedom.
    pub uncertainty: Option<f64>,
}

impl DeterminedCombination {
    /// Text such as `EXX.c0 + 1.0000·EX0Y` (coefficients in parameter
    /// units; terms below a tenth of the leading one's scaled weight are
    /// summarised as `+ …`).
    pub fn describe(&self) -> String {
        let mut s = String::new();
        let lead = self.terms.first().map_or(0.0, |t| t.scaled.abs());
        let mut rest = 0;
        for (i, t) in self.terms.iter().enumerate() {
            if i == 0 {
                s.push_str(&t.name);
            } else if t.scaled.abs() >= 0.1 * lead {
                let sign = if t.coefficient < 0.0 { '−' } else { '+' };
                s.push_str(&format!(" {sign} {:.4}·{}", t.coefficient.abs(), t.name));
            } else {
                rest += 1;
            }
        }
        if rest > 0 {
            s.push_str(&format!(" + … ({rest} smaller terms)"));
        }
        s
    }
}

/// Parameters the data tell apart only in combination.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConfoundedGroup {
    /// The parameters of the group, in the model's order.
    pub parameters: Vec<String>,
    /// Null directions inside the group (how many values the gauge chose).
    pub undetermined: usize,
    /// The `parameters − undetermined` combinations the data determine.
    pub determined: Vec<DeterminedCombination>,
}

/// What the gauge fixing did (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GaugeReport {
    /// `start` (the start values, 0 for the errors: minimum norm) or
    /// `prior` (values given).
    pub kind: String,
    /// Dimension of the null space (zero columns included).
    pub null_dimension: usize,
    /// Largest change of a residual caused by the gauge fixing (residual
    /// unit): 0 up to rounding and the model's curvature.
    pub max_residual_change: f64,
    /// Every parameter the gauge set, in the model's order.
    pub parameters: Vec<GaugedParameter>,
    /// The confounded groups and what the data determine in each.
    pub groups: Vec<ConfoundedGroup>,
}

/// The gauge-fixed solution, before its report is assembled.
pub(crate) struct Fixed {
    /// Decomposition over the non-zero columns at the final θ (same scales
    /// as the identifiability analysis).
    pub scaled: Scaled,
    /// Estimated columns' count (the rank used).
    pub rank: usize,
    pub prior: Vec<f64>,
    pub zero: Vec<bool>,
    pub max_residual_change: f64,
}

/// The null basis (`k × (k − rank)`, scaled variables) of `s`.
fn null_basis(s: &Scaled, rank: usize) -> Mat<f64> {
    let k = s.len();
    Mat::from_fn(k, k - rank, |i, c| s.v[(i, rank + c)])
}

/// `θ ← θ − D⁻¹·N·Nᵀ·D·(θ − θ_p)` over the columns of `s`.
pub(crate) fn project(theta: &mut [f64], s: &Scaled, rank: usize, prior: &[f64]) {
    let nb = null_basis(s, rank);
    let t: Vec<f64> = s
        .cols
        .iter()
        .zip(&s.d)
        .map(|(&j, d)| d * (theta[j] - prior[j]))
        .collect();
    for c in 0..nb.ncols() {
        let a: f64 = (0..s.len()).map(|i| nb[(i, c)] * t[i]).sum();
        for (i, &j) in s.cols.iter().enumerate() {
            theta[j] -= a * nb[(i, c)] / s.d[i];
        }
    }
}

/// Moves the converged `outcome` to the gauge (see the module
/// documentation). `nonzero` are the non-zero columns with scales `d`,
/// `rank` the number of estimated parameters.
#[allow(clippy::too_many_arguments)]
pub(crate) fn fix(
    pass: &Pass<'_>,
    outcome: &mut Outcome,
    zero: &[bool],
    nonzero: &[usize],
    d: &[f64],
    rank: usize,
    kept: &[usize],
    prior: Vec<f64>,
    options: &Options,
    dense: bool,
) -> Result<Fixed, FitError> {
    let need = if dense { Need::Dense } else { Need::Normal };
    let before = outcome.eval.r.clone();
    let e1 = pass.run(&outcome.theta, need)?;
    let s1 = Scaled::new(&e1, nonzero, d)?;
    let mut theta = outcome.theta.clone();
    project(&mut theta, &s1, rank, &prior);
    for (j, &z) in zero.iter().enumerate() {
        if z {
            theta[j] = prior[j];
        }
    }
    // Levenberg–Marquardt over the estimated parameters again, from the
    // projected point: the confounded ones keep their gauge-fixed values,
    // the estimated ones take back what the model's curvature changed (a
    // second-order move, which leaves the gauge to second order).
    let e2 = pass.run(&theta, need)?;
    let kd: Vec<f64> = kept
        .iter()
        .map(|j| d[nonzero.binary_search(j).unwrap_or(0)])
        .collect();
    let polished = lm::minimise(pass, theta, e2, kept, lm::Start::Scales(kd), options, dense)?;
    let e3 = pass.run(&polished.theta, need)?;
    let scaled = Scaled::new(&e3, nonzero, d)?;
    let (passes, factorizations) = (
        2 + polished.convergence.evaluations,
        2 + polished.convergence.factorizations,
    );
    let (theta, eval) = (polished.theta, e3);
    let max_residual_change = before
        .iter()
        .zip(&eval.r)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    outcome.convergence.evaluations += passes;
    outcome.convergence.factorizations += factorizations;
    outcome.convergence.final_cost = eval.cost;
    outcome.theta = theta;
    outcome.eval = eval;
    Ok(Fixed {
        scaled,
        rank,
        prior,
        zero: zero.to_vec(),
        max_residual_change,
    })
}

/// The report of `fixed` at the final `theta`, with the gauge-fixed
/// covariance when there is one.
pub(crate) fn report(
    fixed: &Fixed,
    gauge: &Gauge,
    params: &[Parameter],
    theta: &[f64],
    covariance: Option<&Covariance>,
) -> GaugeReport {
    let s = &fixed.scaled;
    let (n, k) = (params.len(), s.len());
    let nb = null_basis(s, fixed.rank);
    // P = N·Nᵀ over the non-zero columns (scaled variables).
    let p = Mat::<f64>::from_fn(k, k, |a, b| {
        (0..nb.ncols()).map(|c| nb[(a, c)] * nb[(b, c)]).sum()
    });
    let mut parameters = Vec::new();
    let mut touched = vec![false; k];
    let mut undetermined = vec![1.0; n];
    for (i, &j) in s.cols.iter().enumerate() {
        undetermined[j] = p[(i, i)];
        touched[i] = p[(i, i)] > LINK;
    }
    for j in 0..n {
        let pos = s.cols.binary_search(&j).ok();
        if fixed.zero[j] || pos.is_some_and(|i| touched[i]) {
            parameters.push(GaugedParameter {
                index: j,
                name: params[j].name.clone(),
                prior: fixed.prior[j],
                value: theta[j],
                undetermined: undetermined[j].clamp(0.0, 1.0),
            });
        }
    }
    // Connected components of the coupling graph over the touched columns.
    let mut group = vec![usize::MAX; k];
    let mut groups = Vec::new();
    for start in 0..k {
        if !touched[start] || group[start] != usize::MAX {
            continue;
        }
        let g = groups.len();
        let mut members = vec![start];
        group[start] = g;
        let mut next = 0;
        while next < members.len() {
            let a = members[next];
            next += 1;
            for b in 0..k {
                if touched[b] && group[b] == usize::MAX && p[(a, b)].abs() > LINK {
                    group[b] = g;
                    members.push(b);
                }
            }
        }
        members.sort_unstable();
        groups.push(members);
    }
    let groups = groups
        .into_iter()
        .map(|members| confounded_group(&members, &p, s, params, theta, covariance))
        .collect();
    GaugeReport {
        kind: match gauge {
            Gauge::Prior(_) => "prior".into(),
            _ => "start".into(),
        },
        null_dimension: (k - fixed.rank) + fixed.zero.iter().filter(|&&z| z).count(),
        max_residual_change: fixed.max_residual_change,
        parameters,
        groups,
    }
}

/// One group: `members` are positions in the scaled columns.
fn confounded_group(
    members: &[usize],
    p: &Mat<f64>,
    s: &Scaled,
    params: &[Parameter],
    theta: &[f64],
    covariance: Option<&Covariance>,
) -> ConfoundedGroup {
    let c = members.len();
    // I − P restricted to the group: eigenvalue 1 on the determined
    // combinations, 0 on the null directions inside the group.
    let q = Mat::<f64>::from_fn(c, c, |a, b| {
        let id = if a == b { 1.0 } else { 0.0 };
        id - p[(members[a], members[b])]
    });
    let mut determined = Vec::new();
    let mut undetermined = c;
    if let Ok(evd) = q.self_adjoint_eigen(Side::Lower) {
        let ev = evd.S().column_vector();
        let u = evd.U();
        for e in 0..c {
            if ev[e] <= 0.5 {
                continue;
            }
            undetermined -= 1;
            // Scaled vector w: the combination Σ w_i·y_i = Σ w_i·D_i·θ_i.
            let coef: Vec<f64> = (0..c).map(|i| u[(i, e)] * s.d[members[i]]).collect();
            let w: Vec<f64> = (0..c).map(|i| u[(i, e)]).collect();
            let lead = (0..c).fold(0, |b, i| if w[i].abs() > w[b].abs() { i } else { b });
            let norm = coef[lead];
            let mut order: Vec<usize> = (0..c)
                .filter(|&i| w[i].abs() >= 1e-6 * w[lead].abs())
                .collect();
            order.sort_by(|&a, &b| w[b].abs().total_cmp(&w[a].abs()).then(a.cmp(&b)));
            let full: Vec<(usize, f64)> = order
                .iter()
                .map(|&i| (s.cols[members[i]], coef[i] / norm))
                .collect();
            let value = full.iter().map(|(j, a)| a * theta[*j]).sum();
            let uncertainty = covariance.map(|cv| {
                let mut v = 0.0;
                for (ja, a) in &full {
                    for (jb, b) in &full {
                        v += a * b * cv.get(*ja, *jb).unwrap_or(0.0);
                    }
                }
                v.max(0.0).sqrt()
            });
            determined.push(DeterminedCombination {
                terms: order
                    .iter()
                    .map(|&i| CombinationTerm {
                        name: params[s.cols[members[i]]].name.clone(),
                        coefficient: coef[i] / norm,
                        scaled: w[i] * w[lead].signum(),
                    })
                    .collect(),
                value,
                uncertainty,
            });
        }
    }
    ConfoundedGroup {
        parameters: members
            .iter()
            .map(|&i| params[s.cols[i]].name.clone())
            .collect(),
        undetermined,
        determined,
    }
}
