//! Standard uncertainties and correlations of the estimated parameters.
//!
//! With the residual variance `σ² = 2·cost / (m − rank)` (`m` rows taking
//! part in the fit), the covariance of the estimated parameters is
//! `C = σ²·(J_KᵀJ_K)⁻¹ = σ²·D⁻¹·V·diag(1/λᵢ)·Vᵀ·D⁻¹`, from the last
//! decomposition of the scaled Jacobian of the estimated columns `K`.
//! Directions whose `λᵢ` fell below the rank threshold at the solution
//! (possible when the rank changed along the way) are left out (a
//! pseudo-inverse) and reported as a warning by the caller. On the
//! normal-equation path the last decomposition is that of the last `JᵀJ`
//! formed, which may be from an earlier iterate when the model was linear
//! enough for it to be reused (see [`super::lm`]). Unidentifiable
//! parameters have no uncertainty: they are not estimated — unless the fit
//! is gauge-fixed ([`super::gauge`]): then the covariance is the
//! pseudo-inverse over every non-zero column at the gauge-fixed solution,
//! and confounded parameters get the uncertainty of their share of the
//! determined combinations.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};

use super::scaling::Scaled;

/// Below this many multiply-adds the product runs on the calling thread.
const PARALLEL_FLOPS: usize = 1 << 24;

/// Covariance of the estimated parameters, in their own units squared.
#[derive(Debug, Clone, PartialEq)]
pub struct Covariance {
    /// Parameter index of every row/column of `matrix`, ascending.
    pub estimated: Vec<usize>,
    /// `k × k` covariance matrix.
    pub matrix: Mat<f64>,
}

impl Covariance {
    /// Builds `σ²·(J_KᵀJ_K)⁺` from the scaled decomposition, ignoring
    /// `λᵢ ≤ τ²·λ_max`. Returns the covariance and the number of ignored
    /// directions. `scaled.cols` must be ascending.
    pub(crate) fn from_scaled(scaled: &Scaled, sigma2: f64, tau: f64) -> (Self, usize) {
        let rank = scaled.rank(tau);
        (
            Self::pseudo_inverse(scaled, sigma2, rank),
            scaled.len() - rank,
        )
    }

    /// `σ²·D⁻¹·V_r·Λ_r⁻¹·V_rᵀ·D⁻¹` over the first `rank` directions of
    /// `scaled` (whose columns must be ascending): the covariance of the
    /// gauge-fixed (minimum-distance) estimate over every column of
    /// `scaled`, see [`super::gauge`].
    pub(crate) fn pseudo_inverse(scaled: &Scaled, sigma2: f64, rank: usize) -> Self {
        let k = scaled.len();
        let rank = rank.min(k);
        // C = σ²·A·Aᵀ with A = D⁻¹·V_r·diag(1/√λ) (k × rank).
        let a = Mat::<f64>::from_fn(k, rank, |a, i| {
            scaled.v[(a, i)] / (scaled.lambda[i].sqrt() * scaled.d[a])
        });
        let mut matrix = Mat::<f64>::zeros(k, k);
        let par = if k * k * rank < PARALLEL_FLOPS {
            Par::Seq
        } else {
            crate::par::faer()
        };
        matmul(
            matrix.as_mut(),
            Accum::Replace,
            a.as_ref(),
            a.transpose(),
            sigma2,
            par,
        );
        // Exactly symmetric, whatever the product's summation order.
        for c in 0..k {
            for r in 0..c {
                matrix[(r, c)] = matrix[(c, r)];
            }
        }
        Self {
            estimated: scaled.cols.clone(),
            matrix,
        }
    }

    /// Standard uncertainty of parameter `j` (`None` if not estimated).
    pub fn std(&self, j: usize) -> Option<f64> {
        let i = self.estimated.binary_search(&j).ok()?;
        Some(self.matrix[(i, i)].max(0.0).sqrt())
    }

    /// Covariance between parameters `i` and `j` (`None` if either is not
    /// estimated).
    pub fn get(&self, i: usize, j: usize) -> Option<f64> {
        let a = self.estimated.binary_search(&i).ok()?;
        let b = self.estimated.binary_search(&j).ok()?;
        Some(self.matrix[(a, b)])
    }

    /// Correlation matrix over [`Covariance::estimated`] (1 on the
    /// diagonal; 0 where a variance is 0).
    pub fn correlation(&self) -> Mat<f64> {
        let k = self.estimated.len();
        let s: Vec<f64> = (0..k)
            .map(|i| self.matrix[(i, i)].max(0.0).sqrt())
            .collect();
        Mat::from_fn(k, k, |a, b| {
            if a == b {
                1.0
            } else if s[a] > 0.0 && s[b] > 0.0 {
                self.matrix[(a, b)] / (s[a] * s[b])
            } else {
                0.0
            }
        })
    }
}
