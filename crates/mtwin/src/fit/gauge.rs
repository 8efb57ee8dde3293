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
//! of `c` parameters carrying `q` null directions, the `c − q` vectors
//! orthogonal to the null space (eigenvectors of `I − P` restricted to the
//! group) span the determined combinations, each with its value and
//! standard uncertainty — unchanged by the gauge. An orthonormal basis of a
//! large group is dense (every vector mixes all its parameters), so both
//! the determined combinations and the `q` undetermined directions are
//! reported in a sparse basis of the same subspaces: the reduced row
//! echelon form by Gauss–Jordan elimination with complete pivoting
//! ([`sparsify`]). Each vector then has 1 on its own pivot parameter and 0
//! on the other vectors' pivots, so it involves its pivot and the group's
//! non-pivot parameters only, and a simple confound (an offset and a
//! constant term that add) comes out exactly as `a + b` determined, `a − b`
//! undetermined.

use faer::{Mat, Side};
use serde::{Deserialize, Serialize};

use super::covariance::Covariance;
use super::evaluate::{Need, Pass};
use super::lm::{self, Outcome};
use super::problem::Parameter;
use super::scaling::Scaled;
use super::truncation::{self, DroppedDirection, Truncation};
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
    /// Coefficient in the scaled variables, relative to the leading term's
    /// (1 for the leading term).
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
    /// Directions inside the group the gauge set (how many values it
    /// chose): the null directions, and the badly determined ones a
    /// [`Truncation`] rule dropped.
    pub undetermined: usize,
    /// The `undetermined` directions along which the residuals do not
    /// change (or, for a direction a [`Truncation`] rule dropped, change by
    /// no more than its reported cost), each with few dominant terms (a sparse basis, see
    /// [`sparsify`]): moving the parameters by `t·coefficient` for any `t`
    /// leaves the predictions at the measured points unchanged.
    #[serde(default)]
    pub undetermined_directions: Vec<UndeterminedDirection>,
    /// The `parameters − undetermined` combinations the data determine, in
    /// a sparse basis (each has one pivot parameter that no other
    /// combination of the group contains).
    pub determined: Vec<DeterminedCombination>,
}

/// A direction the data do not determine: `Σ coefficient·δθ` changes no
/// prediction at the measured points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UndeterminedDirection {
    /// Terms led by the largest in the scaled variables (coefficient 1),
    /// coefficients in parameter units.
    pub terms: Vec<CombinationTerm>,
}

impl UndeterminedDirection {
    /// Text such as `EXX.c0 − 1.0000·EX0Y` (terms below a tenth of the
    /// leading one's scaled weight summarised).
    pub fn describe(&self) -> String {
        DeterminedCombination {
            terms: self.terms.clone(),
            value: 0.0,
            uncertainty: None,
        }
        .describe()
    }
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
    /// The rank rule for badly determined directions (`off`, `rcond=X`,
    /// `std=X`; see [`super::truncation`]).
    #[serde(default)]
    pub truncation: String,
    /// The badly determined directions the rule set to the prior, with the
    /// bias each introduces.
    #[serde(default)]
    pub dropped: Vec<DroppedDirection>,
    /// RMS change of the residuals the truncation caused (residual unit).
    #[serde(default)]
    pub truncation_rms_change: f64,
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
    /// Directions treated as determined: the first `rank` of `scaled`
    /// (the estimated columns' count less the truncated directions).
    pub rank: usize,
    /// The numerical rank (estimated columns' count).
    pub numerical_rank: usize,
    pub prior: Vec<f64>,
    pub zero: Vec<bool>,
    pub max_residual_change: f64,
    /// The rule and the directions it dropped.
    pub truncation: Truncation,
    pub dropped: Vec<DroppedDirection>,
    /// RMS change of the residuals caused by the truncation.
    pub truncation_rms_change: f64,
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
    params: &[Parameter],
    rows: usize,
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
    let (mut passes, mut factorizations) = (
        2 + polished.convergence.evaluations,
        2 + polished.convergence.factorizations,
    );
    let (mut theta, mut eval) = (polished.theta, e3);
    let max_residual_change = before
        .iter()
        .zip(&eval.r)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    // The rank rule for badly determined directions (truncated SVD toward
    // the prior), see [`super::truncation`].
    let dof = rows.saturating_sub(rank);
    let sigma = (dof > 0).then(|| (2.0 * eval.cost / dof as f64).sqrt());
    let drop = truncation::select(options.truncation, &scaled, rank, sigma, params);
    let (scaled, kept_directions, dropped, truncation_rms_change) = if drop.is_empty() {
        (scaled, rank, Vec::new(), 0.0)
    } else {
        let keep: Vec<usize> = (0..rank).filter(|i| !drop.contains(i)).collect();
        let (dropped, used) = truncation::apply(
            pass, need, &mut theta, &scaled, &keep, &drop, &prior, sigma, rows, params,
        )?;
        passes += used;
        let e4 = pass.run(&theta, need)?;
        passes += 1;
        let change = (eval
            .r
            .iter()
            .zip(&e4.r)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            / rows.max(1) as f64)
            .sqrt();
        eval = e4;
        factorizations += used;
        (
            truncation::reorder(&scaled, &keep, &drop, rank),
            keep.len(),
            dropped,
            change,
        )
    };
    outcome.convergence.evaluations += passes;
    outcome.convergence.factorizations += factorizations;
    outcome.convergence.final_cost = eval.cost;
    outcome.theta = theta;
    outcome.eval = eval;
    Ok(Fixed {
        scaled,
        rank: kept_directions,
        numerical_rank: rank,
        prior,
        zero: zero.to_vec(),
        max_residual_change,
        truncation: options.truncation,
        dropped,
        truncation_rms_change,
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
        null_dimension: (k - fixed.numerical_rank) + fixed.zero.iter().filter(|&&z| z).count(),
        max_residual_change: fixed.max_residual_change,
        truncation: fixed.truncation.to_string(),
        dropped: fixed.dropped.clone(),
        truncation_rms_change: fixed.truncation_rms_change,
        parameters,
        groups,
    }
}

/// Reduced row echelon form of the rows of `b` (an `r × c` basis of a
/// subspace, one vector per row) by Gauss–Jordan elimination with complete
/// pivoting: a basis of the same subspace in which every vector has 1 on
/// its own pivot parameter and 0 on the others' pivots, so each vector
/// involves its pivot and the non-pivot parameters only — the sparsest
/// readable basis this construction gives (column-pivoted QR chooses the
/// same pivots). Rows that vanish to rounding are dropped.
pub(crate) fn sparsify(b: &Mat<f64>) -> Vec<Vec<f64>> {
    let (r, c) = (b.nrows(), b.ncols());
    let mut m: Vec<Vec<f64>> = (0..r)
        .map(|i| (0..c).map(|j| b[(i, j)]).collect())
        .collect();
    let scale = m.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
    let mut used = vec![false; c];
    let mut t = 0;
    while t < r {
        let mut best = (0.0, 0, 0);
        for (i, row) in m.iter().enumerate().skip(t) {
            for (j, x) in row.iter().enumerate() {
                if !used[j] && x.abs() > best.0 {
                    best = (x.abs(), i, j);
                }
            }
        }
        if best.0 <= 1e-10 * scale {
            break;
        }
        let (_, i, j) = best;
        m.swap(t, i);
        let p = m[t][j];
        for x in &mut m[t] {
            *x /= p;
        }
        let pivot = m[t].clone();
        for (i2, row) in m.iter_mut().enumerate() {
            if i2 != t {
                let f = row[j];
                if f != 0.0 {
                    for (x, pv) in row.iter_mut().zip(&pivot) {
                        *x -= f * pv;
                    }
                    row[j] = 0.0;
                }
            }
        }
        used[j] = true;
        t += 1;
    }
    m.truncate(t);
    // Entries that are rounding of an exact zero.
    for row in &mut m {
        let big = row.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for x in row.iter_mut() {
            if x.abs() < 1e-9 * big {
                *x = 0.0;
            }
        }
    }
    m
}

/// What a scaled vector stands for.
#[derive(Clone, Copy)]
enum Kind {
    /// A linear combination of the parameters (a row).
    Combination,
    /// A direction in parameter space (a column).
    Direction,
}

/// Weights within this fraction of the largest of each other count as
/// equal, so that which term leads a combination, and the order of the
/// others, does not depend on rounding (two parameters that enter a
/// combination symmetrically get weights that differ in the last bits, in
/// either direction).
const WEIGHT_TIE: f64 = 1e-9;

/// The indices of `w` by decreasing `|w|`, equal weights (to
/// [`WEIGHT_TIE`] of the largest) in index order, i.e. the model's order.
pub(crate) fn by_weight(w: &[f64]) -> Vec<usize> {
    let max = w.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let key = |i: usize| {
        if max > 0.0 {
            (w[i].abs() / max / WEIGHT_TIE).round()
        } else {
            0.0
        }
    };
    let mut order: Vec<usize> = (0..w.len()).collect();
    order.sort_by(|&a, &b| key(b).total_cmp(&key(a)).then(a.cmp(&b)));
    order
}

/// The index of the leading weight of `w` (see [`by_weight`]).
fn lead_of(w: &[f64]) -> usize {
    by_weight(w).first().copied().unwrap_or(0)
}

/// The terms of the scaled vector `w` over the group `members` (terms
/// below 10⁻⁶ of the largest left out), led by the largest: coefficients
/// in parameter units relative to it.
fn terms_of(
    w: &[f64],
    members: &[usize],
    s: &Scaled,
    params: &[Parameter],
    kind: Kind,
) -> Vec<CombinationTerm> {
    let lead = lead_of(w);
    // A combination Σ w_i·y_i is Σ w_i·D_i·θ_i; a direction δy = w is
    // δθ_i = w_i/D_i.
    let unit = |i: usize| match kind {
        Kind::Combination => w[i] * s.d[members[i]],
        Kind::Direction => w[i] / s.d[members[i]],
    };
    let norm = unit(lead);
    let order: Vec<usize> = by_weight(w)
        .into_iter()
        .filter(|&i| w[i] != 0.0 && w[i].abs() >= 1e-6 * w[lead].abs())
        .collect();
    order
        .iter()
        .map(|&i| CombinationTerm {
            name: params[s.cols[members[i]]].name.clone(),
            coefficient: if i == lead { 1.0 } else { unit(i) / norm },
            scaled: w[i] / w[lead],
        })
        .collect()
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
    let mut directions = Vec::new();
    let mut undetermined = c;
    if let Ok(evd) = q.self_adjoint_eigen(Side::Lower) {
        let ev = evd.S().column_vector();
        let u = evd.U();
        let pick = |keep: bool| {
            let cols: Vec<usize> = (0..c).filter(|&e| (ev[e] > 0.5) == keep).collect();
            Mat::<f64>::from_fn(cols.len(), c, |r, i| u[(i, cols[r])])
        };
        let (det, null) = (pick(true), pick(false));
        undetermined = null.nrows();
        // Scaled vector w: the combination Σ w_i·y_i = Σ w_i·D_i·θ_i.
        for w in sparsify(&det) {
            let terms = terms_of(&w, members, s, params, Kind::Combination);
            let lead = lead_of(&w);
            let norm = w[lead] * s.d[members[lead]];
            let full: Vec<(usize, f64)> = (0..c)
                .filter(|&i| w[i] != 0.0)
                .map(|i| (s.cols[members[i]], w[i] * s.d[members[i]] / norm))
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
                terms,
                value,
                uncertainty,
            });
        }
        for w in sparsify(&null) {
            directions.push(UndeterminedDirection {
                terms: terms_of(&w, members, s, params, Kind::Direction),
            });
        }
    }
    ConfoundedGroup {
        parameters: members
            .iter()
            .map(|&i| params[s.cols[i]].name.clone())
            .collect(),
        undetermined,
        undetermined_directions: directions,
        determined,
    }
}

#[cfg(test)]
mod tests {
    use super::by_weight;

    #[test]
    fn equal_weights_up_to_rounding_keep_the_models_order() {
        // Two parameters entering a combination symmetrically: 1/√2 each,
        // one of them a bit above or below the other after rounding.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let up = f64::from_bits(h.to_bits() + 1);
        for w in [[h, -up], [up, -h], [-h, h]] {
            assert_eq!(by_weight(&w), vec![0, 1], "{w:?}");
        }
        // A real difference still orders by weight; zeros go last.
        assert_eq!(by_weight(&[0.0, 0.5, -0.9, 0.5]), vec![2, 1, 3, 0]);
        assert_eq!(by_weight(&[0.0, 0.0]), vec![0, 1]);
    }
}
