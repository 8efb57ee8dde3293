//! Which parameters the measurements determine.
//!
//! Three decisions, all relative and scale-aware, never a fixed epsilon on
//! unscaled columns:
//!
//! 1. **Zero columns.** The *effect* of parameter j is `e_j = ‖J_j‖·s_j`,
//!    the change of the residual vector when θ_j moves by its typical scale
//!    `s_j` ([`super::Parameter::scale`], 1 when unknown). A column with
//!    `e_j ≤ τ·max_k e_k` is zero to rounding: the parameter is reported
//!    individually unidentifiable. Column norms are sums of squares, accurate
//!    on both paths, so `τ` is the dense floor `max(m, n)·ε` (or the user's
//!    [`RankRule::Relative`]). A column that is small only because of its
//!    unit (a length in km, a coefficient of `q³`) keeps an effect far above
//!    rounding and stays in.
//! 2. **Rank** of the column-scaled Jacobian of the remaining columns: the
//!    singular values `sᵢ > τ·s_max` count, `τ` being the floor of the
//!    decomposition ([`Source::floor`]: `max(m, n)·ε` for the dense SVD,
//!    `√(max(m, n)·ε)` on the normal-equation path, whose spectrum is
//!    squared) or a user threshold (never below that floor).
//! 3. **Which parameters to fix.** Greedy column pivoting on the scaled
//!    problem (`pivot_order`, equivalent to column-pivoted
//!    QR): the first `rank` pivots are estimated, the others are fixed at
//!    their start value. Ties go to the parameter listed first.
//!
//! The confounded combinations are reported twice, in parameter names with
//! their significant coefficients:
//! * [`Identifiability::null_space`]: the right singular vectors of the
//!   neglected singular values, an orthonormal basis of the null space
//!   (when the null space has several dimensions the basis mixes them
//!   arbitrarily);
//! * [`Identifiability::relations`]: one per fixed parameter f, its scaled
//!   column regressed on the estimated ones, `J_f ≈ Σ c_k J_k`, i.e. the
//!   null direction `e_f − Σ c_k e_k`: sparse and readable ("EX0Y moves like
//!   EXX.c0").

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use serde::{Deserialize, Serialize};

use super::problem::Parameter;
use super::scaling::{Scaled, Source, pivot_order};

/// How the numerical rank is decided.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum RankRule {
    /// The floor of the decomposition (see the module documentation).
    #[default]
    Auto,
    /// Singular values of the scaled Jacobian `≤ τ·s_max` are zero (and
    /// columns with effect `≤ τ·max effect`). Clamped to the floor of the
    /// decomposition.
    Relative(f64),
}

/// Why a parameter is not estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Unidentifiable {
    /// Its Jacobian column is zero to rounding: the data do not see it.
    ZeroColumn,
    /// It is confounded with others; pivoting chose to fix it.
    Confounded,
}

/// One term of a confounded combination.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Term {
    /// Parameter index in the model's order.
    pub index: usize,
    /// Parameter name.
    pub name: String,
    /// Coefficient of the scaled (unit-norm) null vector.
    pub scaled: f64,
    /// Coefficient of the direction in parameter units, normalised so that
    /// the term with the largest scaled coefficient has coefficient 1 (a
    /// positive one).
    pub coefficient: f64,
}

/// A direction in parameter space along which the residuals do not change
/// (to the rank threshold): `J·δθ ≈ 0`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Combination {
    /// Singular value of the scaled Jacobian along it, relative to the
    /// largest (`None` for a relation from pivoting).
    pub relative_singular_value: Option<f64>,
    /// Unit null vector in scaled variables, over all `n` parameters (zero
    /// for zero columns).
    pub scaled: Vec<f64>,
    /// The same direction in parameter units, `δθ_j = v_j / D_j`.
    pub direction: Vec<f64>,
    /// Terms with `|scaled| ≥ 0.1·max |scaled|`, largest first.
    pub terms: Vec<Term>,
}

impl Combination {
    /// Text such as `EXX.c0 − 1·EX0Y ≈ 0` (coefficients in parameter units).
    pub fn describe(&self) -> String {
        let mut s = String::new();
        for (i, t) in self.terms.iter().enumerate() {
            let sign = if t.coefficient < 0.0 { '−' } else { '+' };
            if i > 0 || sign == '−' {
                s.push_str(if i > 0 { " " } else { "" });
                s.push(sign);
                s.push(' ');
            }
            if i == 0 {
                s.push_str(&t.name);
            } else {
                s.push_str(&format!("{:.4}·{}", t.coefficient.abs(), t.name));
            }
        }
        s.push_str(" ≈ 0");
        s
    }
}

/// The identifiability analysis of a problem at one θ.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Identifiability {
    /// Number of parameters `n`.
    pub parameters: usize,
    /// Numerical rank: number of parameters estimated.
    pub rank: usize,
    /// Relative singular-value threshold used.
    pub threshold: f64,
    /// Which decomposition gave the singular values.
    pub source: Source,
    /// Singular values of the column-scaled Jacobian over the non-zero
    /// columns, descending (dimensionless).
    pub singular_values: Vec<f64>,
    /// `s_max / s_rank`, the condition number of the identifiable part of
    /// the scaled Jacobian (1 when nothing is estimated).
    pub condition_number: f64,
    /// Estimated parameters, ascending.
    pub estimated: Vec<usize>,
    /// Parameters not estimated, ascending, with the reason.
    pub unidentifiable: Vec<(usize, Unidentifiable)>,
    /// The confounded combinations (null space of the non-zero columns).
    pub null_space: Vec<Combination>,
    /// For every parameter fixed because confounded, in the order of
    /// `unidentifiable`, the combination that makes it redundant.
    pub relations: Vec<Combination>,
}

impl Identifiability {
    /// Whether parameter `j` is estimated.
    pub fn is_estimated(&self, j: usize) -> bool {
        self.estimated.binary_search(&j).is_ok()
    }
}

/// The zero-column decision. `norms` are the Jacobian column norms.
pub(crate) fn zero_columns(norms: &[f64], params: &[Parameter], tau: f64) -> Vec<bool> {
    let effect: Vec<f64> = norms
        .iter()
        .zip(params)
        .map(|(&c, p)| c * p.scale.unwrap_or(1.0).abs())
        .collect();
    let max = effect.iter().copied().fold(0.0, f64::max);
    effect
        .iter()
        .map(|&e| e.is_nan() || e <= tau * max)
        .collect()
}

/// The relative threshold for a decomposition source and rule.
pub(crate) fn threshold(rule: RankRule, source: Source, m: usize, n: usize) -> f64 {
    let floor = source.floor(m, n);
    match rule {
        RankRule::Auto => floor,
        RankRule::Relative(t) => t.max(floor),
    }
}

/// Rank, pivoting and null space of the scaled problem `scaled` (built over
/// the non-zero columns `scaled.cols`), given the zero columns already
/// found.
pub(crate) fn analyse(
    scaled: &Scaled,
    zero: &[bool],
    params: &[Parameter],
    tau: f64,
) -> Identifiability {
    let n = params.len();
    let k = scaled.len();
    let rank = scaled.rank(tau);
    let s: Vec<f64> = scaled.lambda.iter().map(|l| l.sqrt()).collect();
    let condition_number = if rank == 0 { 1.0 } else { s[0] / s[rank - 1] };
    let mut unidentifiable: Vec<(usize, Unidentifiable)> = (0..n)
        .filter(|&j| zero[j])
        .map(|j| (j, Unidentifiable::ZeroColumn))
        .collect();
    let mut estimated: Vec<usize> = scaled.cols.clone();
    let mut relations = Vec::new();
    if rank < k {
        let order = pivot_order(&scaled.normal, rank);
        relations = redundancy(scaled, &order[..rank], &order[rank..], params);
        estimated = order[..rank].iter().map(|&c| scaled.cols[c]).collect();
        unidentifiable.extend(
            order[rank..]
                .iter()
                .map(|&c| (scaled.cols[c], Unidentifiable::Confounded)),
        );
    }
    estimated.sort_unstable();
    unidentifiable.sort_unstable_by_key(|u| u.0);
    let null_space = (rank..k)
        .map(|c| {
            let mut v = vec![0.0; n];
            let mut dir = vec![0.0; n];
            for i in 0..k {
                v[scaled.cols[i]] = scaled.v[(i, c)];
                dir[scaled.cols[i]] = scaled.v[(i, c)] / scaled.d[i];
            }
            combination(v, dir, Some(s[c] / s[0].max(f64::MIN_POSITIVE)), params)
        })
        .collect();
    Identifiability {
        parameters: n,
        rank,
        threshold: tau,
        source: scaled.source,
        singular_values: s,
        condition_number,
        estimated,
        unidentifiable,
        null_space,
        relations,
    }
}

/// For every fixed scaled column f, `e_f − Σ c_k e_k` with `c` the least-
/// squares coefficients of column f on the kept columns, sorted by the
/// fixed parameter's index.
fn redundancy(
    scaled: &Scaled,
    kept: &[usize],
    fixed: &[usize],
    params: &[Parameter],
) -> Vec<Combination> {
    let n = params.len();
    let a = Mat::<f64>::from_fn(kept.len(), kept.len(), |i, j| {
        scaled.normal[(kept[i], kept[j])]
    });
    let b = Mat::<f64>::from_fn(kept.len(), fixed.len(), |i, j| {
        scaled.normal[(kept[i], fixed[j])]
    });
    let coef = match a.llt(Side::Lower) {
        Ok(llt) => llt.solve(&b),
        // The kept columns are full rank by construction; should rounding
        // still defeat Cholesky, only the null-space basis is reported.
        Err(_) => return Vec::new(),
    };
    let mut fixed_sorted: Vec<(usize, usize)> = fixed
        .iter()
        .enumerate()
        .map(|(f, &c)| (scaled.cols[c], f))
        .collect();
    fixed_sorted.sort_unstable();
    fixed_sorted
        .into_iter()
        .map(|(_, f)| {
            let mut v = vec![0.0; n];
            v[scaled.cols[fixed[f]]] = 1.0;
            for (i, &kc) in kept.iter().enumerate() {
                v[scaled.cols[kc]] = -coef[(i, f)];
            }
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            v.iter_mut().for_each(|x| *x /= norm);
            let mut dir = vec![0.0; n];
            for (i, &c) in scaled.cols.iter().enumerate() {
                dir[c] = v[c] / scaled.d[i];
            }
            combination(v, dir, None, params)
        })
        .collect()
}

fn combination(
    mut scaled: Vec<f64>,
    mut direction: Vec<f64>,
    relative_singular_value: Option<f64>,
    params: &[Parameter],
) -> Combination {
    // The first of the largest coefficients leads, the others follow by
    // weight (equal weights in the model's order).
    let order = super::gauge::by_weight(&scaled);
    let lead = order.first().copied().unwrap_or(0);
    // Sign convention: the leading term is positive.
    if scaled.get(lead).is_some_and(|&x| x < 0.0) {
        scaled.iter_mut().for_each(|x| *x = -*x);
        direction.iter_mut().for_each(|x| *x = -*x);
    }
    let vmax = scaled.get(lead).copied().unwrap_or(0.0);
    let dlead = direction.get(lead).copied().unwrap_or(1.0);
    let terms: Vec<Term> = order
        .into_iter()
        .filter(|&j| scaled[j].abs() >= 0.1 * vmax && vmax > 0.0)
        .map(|j| Term {
            index: j,
            name: params[j].name.clone(),
            scaled: scaled[j],
            coefficient: direction[j] / dlead,
        })
        .collect();
    Combination {
        relative_singular_value,
        scaled,
        direction,
        terms,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_column_decision_uses_effects_not_raw_norms() {
        let p = vec![
            Parameter::new("a"),
            Parameter::new("b"),
            Parameter::with_scale("c", 1e6),
        ];
        // b is 1e-20 relative: rounding. c has a tiny norm but a large
        // typical value: its effect is 1e-12 * 1e6 = 1e-6, informative.
        let z = zero_columns(&[1.0, 1e-20, 1e-12], &p, 1e-13);
        assert_eq!(z, vec![false, true, false]);
        // Without the scale, c would be at 1e-12 > 1e-13: still kept.
        let z = zero_columns(
            &[1.0, 0.0, 1e-12],
            &p[..2]
                .iter()
                .cloned()
                .chain([Parameter::new("c")])
                .collect::<Vec<_>>(),
            1e-13,
        );
        assert_eq!(z, vec![false, true, false]);
    }

    #[test]
    fn describe_names_terms() {
        let p = vec![Parameter::new("EXX.c0"), Parameter::new("EX0Y")];
        let c = combination(
            vec![-0.5f64.sqrt(), 0.5f64.sqrt()],
            vec![-1.0, 1.0],
            None,
            &p,
        );
        assert_eq!(c.terms.len(), 2);
        assert_eq!(c.terms[0].coefficient, 1.0);
        assert_eq!(c.terms[1].coefficient, -1.0);
        assert_eq!(c.describe(), "EXX.c0 − 1.0000·EX0Y ≈ 0");
    }
}
