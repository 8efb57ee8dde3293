//! Finite-difference check of a model's exact Jacobian (for tests of the
//! models; it evaluates the whole `m × n` Jacobian, so keep problems small).
//!
//! Central differences `(r(θ + h·e_j) − r(θ − h·e_j)) / 2h` with
//! `h_j = ε^{1/3}·max(|θ_j|, s_j)` (`s_j` the parameter's typical scale, 1
//! when unknown): the truncation error `O(h²)` and the rounding error
//! `O(ε/h)` balance there, leaving about 10⁻¹⁰ relative error on smooth
//! models.

use faer::Mat;

use super::FitError;
use super::problem::Model;

/// The worst disagreement between the model's Jacobian and the differences.
#[derive(Debug, Clone, PartialEq)]
pub struct JacobianCheck {
    /// Largest `|analytic − numeric|` over all entries (residual unit per
    /// parameter unit).
    pub max_abs_error: f64,
    /// Largest over columns of `max_i |analytic − numeric| / max_i |numeric|`
    /// (0 for columns that are zero in both).
    pub max_rel_error: f64,
    /// `(row, column)` of the worst relative column error's worst entry.
    pub worst: (usize, usize),
}

impl JacobianCheck {
    /// Whether every column agrees to the relative tolerance `tol`.
    pub fn passes(&self, tol: f64) -> bool {
        self.max_rel_error <= tol
    }
}

/// Compares `model.jacobian` at θ with central differences of
/// `model.residuals`.
pub fn check_jacobian(model: &dyn Model, theta: &[f64]) -> Result<JacobianCheck, FitError> {
    let params = model.parameters();
    let n = params.len();
    if theta.len() != n {
        return Err(FitError::ParameterCount {
            expected: n,
            got: theta.len(),
        });
    }
    let m = model.layout().rows();
    let mut j = Mat::<f64>::zeros(m, n);
    model.jacobian(theta, 0..m, j.as_mut());
    let mut plus = vec![0.0; m];
    let mut minus = vec![0.0; m];
    let mut out = JacobianCheck {
        max_abs_error: 0.0,
        max_rel_error: 0.0,
        worst: (0, 0),
    };
    let mut t = theta.to_vec();
    for c in 0..n {
        let h = f64::EPSILON.cbrt() * theta[c].abs().max(params[c].scale.unwrap_or(1.0).abs());
        t[c] = theta[c] + h;
        model.residuals(&t, 0..m, &mut plus);
        t[c] = theta[c] - h;
        model.residuals(&t, 0..m, &mut minus);
        t[c] = theta[c];
        // The step actually taken, after rounding of θ ± h.
        let step = (theta[c] + h) - (theta[c] - h);
        let mut col_err = 0.0f64;
        let mut col_max = 0.0f64;
        let mut row_err = 0;
        for i in 0..m {
            let numeric = (plus[i] - minus[i]) / step;
            let e = (j[(i, c)] - numeric).abs();
            if e > col_err || e.is_nan() {
                col_err = e;
                row_err = i;
            }
            col_max = col_max.max(numeric.abs());
        }
        out.max_abs_error = out.max_abs_error.max(col_err);
        let rel = if col_max > 0.0 {
            col_err / col_max
        } else if col_err > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        if rel > out.max_rel_error || rel.is_nan() {
            out.max_rel_error = rel;
            out.worst = (row_err, c);
        }
    }
    Ok(out)
}
