//! Column scaling and the spectral decomposition of the scaled problem.
//!
//! Parameters come in incompatible units (mm, rad, Chebyshev coefficients
//! of either), so every decision is taken on the *column-scaled* Jacobian
//! `Jₛ = J·D⁻¹`, `D = diag(‖J_j‖)`: each column has unit norm and the
//! scaled variables `y = D·θ` are in residual units. Levenberg–Marquardt
//! damping `μ·I` in `y` is Moré's `μ·D²` damping in θ.
//!
//! The decomposition comes from one of two sources:
//! * **dense**: thin SVD of `Jₛ` (`m × k`), `λᵢ = sᵢ²`. Singular values are
//!   accurate to `≈ ε·s_max`, so the relative rank floor is
//!   `τ = max(m, n)·ε` on `s` (the LAPACK/NumPy `matrix_rank` default).
//! * **normal equations**: symmetric eigen-decomposition of
//!   `Nₛ = D⁻¹·JᵀJ·D⁻¹` (`k × k`). Forming `JᵀJ` squares the spectrum:
//!   eigenvalues are accurate to `≈ max(m, n)·ε·λ_max`, i.e. singular values
//!   only to `√(max(m, n)·ε)·s_max`. The floor on `s` is therefore
//!   `τ = √(max(m, n)·ε)` (`λᵢ ≤ τ²·λ_max` is zero), which for 300 000 rows
//!   means condition numbers above ≈ 1.2·10⁵ of the scaled Jacobian are
//!   read as rank deficiency. Use the dense path when finer distinctions
//!   matter.

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::linalg::svd::{ComputeSvdVectors, svd};
use faer::{Accum, Mat, MatRef, Par, Side};

use super::FitError;
use super::evaluate::Evaluation;

/// Which decomposition produced a `Spectrum`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Thin SVD of the scaled Jacobian.
    DenseSvd,
    /// Eigen-decomposition of the scaled normal matrix.
    NormalEigen,
}

impl Source {
    /// The smallest meaningful relative singular-value threshold for an
    /// `m × n` problem (see the module documentation).
    pub fn floor(self, m: usize, n: usize) -> f64 {
        let base = m.max(n) as f64 * f64::EPSILON;
        match self {
            Source::DenseSvd => base,
            Source::NormalEigen => base.sqrt(),
        }
    }
}

/// The column-scaled problem restricted to a set of parameter columns.
pub(crate) struct Scaled {
    /// Parameter index of every column.
    pub cols: Vec<usize>,
    /// Scale `D_j` of every column (its norm, in residual unit per
    /// parameter unit).
    pub d: Vec<f64>,
    /// Squared singular values of `Jₛ`, descending, `≥ 0`.
    pub lambda: Vec<f64>,
    /// Right singular vectors (columns), `k × k`, in scaled variables.
    pub v: Mat<f64>,
    /// `Nₛ = JₛᵀJₛ`, `k × k`.
    pub normal: Mat<f64>,
    /// Scaled gradient `Jₛᵀ r`.
    pub g: Vec<f64>,
    pub source: Source,
}

impl Scaled {
    /// Builds the scaled problem from an evaluation that holds either the
    /// Jacobian or the normal matrix, over columns `cols` with scales `d`
    /// (all positive).
    pub fn new(eval: &Evaluation, cols: &[usize], d: &[f64]) -> Result<Self, FitError> {
        let k = cols.len();
        let g: Vec<f64> = cols.iter().zip(d).map(|(&c, &dc)| eval.g[c] / dc).collect();
        if k == 0 {
            return Ok(Self {
                cols: Vec::new(),
                d: Vec::new(),
                lambda: Vec::new(),
                v: Mat::zeros(0, 0),
                normal: Mat::zeros(0, 0),
                g,
                source: if eval.jt.is_some() {
                    Source::DenseSvd
                } else {
                    Source::NormalEigen
                },
            });
        }
        if let Some(jt) = &eval.jt {
            // `js[(i, c)] = J[(i, cols[c])] / d[c]`, read along the
            // contiguous rows of J (the columns of `Jᵀ`).
            let mut js = Mat::<f64>::zeros(jt.ncols(), k);
            let mut out: Vec<&mut [f64]> = js
                .col_iter_mut()
                .map(|c| {
                    c.try_as_col_major_mut()
                        .expect("an owned matrix's columns are contiguous")
                        .as_slice_mut()
                })
                .collect();
            for i in 0..jt.ncols() {
                let row = super::lm::contiguous(jt.col(i));
                for ((o, &c), &dc) in out.iter_mut().zip(cols).zip(d) {
                    o[i] = row[c] / dc;
                }
            }
            drop(out);
            let (s, v) = singular_values_and_v(js.as_ref())?;
            // With fewer rows than columns there are only m singular values:
            // the others are zero (V is complete).
            let mut lambda: Vec<f64> = s.iter().map(|x| x * x).collect();
            lambda.resize(k, 0.0);
            let mut normal = Mat::<f64>::zeros(k, k);
            matmul(
                normal.as_mut(),
                Accum::Replace,
                js.transpose(),
                js.as_ref(),
                1.0,
                Par::Seq,
            );
            Ok(Self {
                cols: cols.to_vec(),
                d: d.to_vec(),
                lambda,
                v,
                normal,
                g,
                source: Source::DenseSvd,
            })
        } else if let Some(nm) = &eval.normal {
            let normal = Mat::<f64>::from_fn(k, k, |a, b| nm[(cols[a], cols[b])] / (d[a] * d[b]));
            let evd = normal
                .self_adjoint_eigen(Side::Lower)
                .map_err(|_| FitError::Decomposition)?;
            // faer sorts eigenvalues ascending: reverse to descending.
            let s = evd.S().column_vector();
            let lambda: Vec<f64> = (0..k).rev().map(|i| s[i].max(0.0)).collect();
            let u = evd.U();
            let v = Mat::<f64>::from_fn(k, k, |i, c| u[(i, k - 1 - c)]);
            Ok(Self {
                cols: cols.to_vec(),
                d: d.to_vec(),
                lambda,
                v,
                normal,
                g,
                source: Source::NormalEigen,
            })
        } else {
            Err(FitError::Decomposition)
        }
    }

    /// Number of columns.
    pub fn len(&self) -> usize {
        self.cols.len()
    }

    /// Numerical rank with relative singular-value threshold `tau`.
    pub fn rank(&self, tau: f64) -> usize {
        let l0 = self.lambda.first().copied().unwrap_or(0.0);
        self.lambda
            .iter()
            .take_while(|&&l| l > tau * tau * l0 && l > 0.0)
            .count()
    }

    /// `Vᵀ·x`.
    pub fn project(&self, x: &[f64]) -> Vec<f64> {
        let k = self.len();
        (0..k)
            .map(|c| (0..k).map(|i| self.v[(i, c)] * x[i]).sum())
            .collect()
    }

    /// `V·c`.
    pub fn expand(&self, c: &[f64]) -> Vec<f64> {
        let k = self.len();
        (0..k)
            .map(|i| (0..k).map(|a| self.v[(i, a)] * c[a]).sum())
            .collect()
    }
}

/// Below this many entries the SVD runs on the calling thread: thread
/// hand-offs cost more than they save on a 540 × 162 matrix.
const PARALLEL_SVD_ENTRIES: usize = 1 << 20;

/// Singular values (descending, `min(m, k)` of them) and the complete
/// `k × k` matrix V of right singular vectors of `a`.
fn singular_values_and_v(a: MatRef<'_, f64>) -> Result<(Vec<f64>, Mat<f64>), FitError> {
    let (m, k) = a.shape();
    // A tall, thin matrix (the scaled Jacobians of most fits: hundreds or
    // thousands of rows, a few dozen columns) is first reduced to its
    // triangle `R` by a Householder QR, and `R` (`k × k`) has the same
    // singular values and right vectors. faer's SVD would do the same
    // reduction itself, but its QR computes every Householder norm with an
    // overflow-safe scaled sum that costs more than the rest of the
    // factorisation at these shapes; the columns here have unit norm, so
    // the plain sum of squares of nalgebra's QR cannot overflow. Measured
    // in BENCHMARKS.md ("Output-error refinement and the dense fits' QR").
    if k > 0 && m >= 2 * k && m * k < PARALLEL_SVD_ENTRIES {
        let mut na = nalgebra::DMatrix::<f64>::zeros(m, k);
        for (j, mut dst) in na.column_iter_mut().enumerate() {
            match a.col(j).try_as_col_major() {
                Some(src) => dst.copy_from_slice(src.as_slice()),
                None => dst.iter_mut().enumerate().for_each(|(i, x)| *x = a[(i, j)]),
            }
        }
        let r = na.qr().unpack_r();
        let rf = Mat::<f64>::from_fn(k, k, |i, j| r[(i, j)]);
        return svd_of(rf.as_ref());
    }
    svd_of(a)
}

fn svd_of(a: MatRef<'_, f64>) -> Result<(Vec<f64>, Mat<f64>), FitError> {
    let (m, k) = a.shape();
    let par = if m * k < PARALLEL_SVD_ENTRIES {
        Par::Seq
    } else {
        crate::par::faer()
    };
    let mut s = Diag::<f64>::zeros(m.min(k));
    let mut v = Mat::<f64>::zeros(k, k);
    let scratch = faer::linalg::svd::svd_scratch::<f64>(
        m,
        k,
        ComputeSvdVectors::No,
        ComputeSvdVectors::Full,
        par,
        Default::default(),
    );
    svd(
        a,
        s.as_mut(),
        None,
        Some(v.as_mut()),
        par,
        MemStack::new(&mut MemBuffer::new(scratch)),
        Default::default(),
    )
    .map_err(|_| FitError::Decomposition)?;
    Ok((s.column_vector().iter().copied().collect(), v))
}

/// Relative difference below which two pivot candidates are tied.
const PIVOT_TIE: f64 = 1e-8;

/// Greedy diagonal pivoting of the positive semi-definite `a` (`k × k`):
/// the order in which columns of the scaled Jacobian would be chosen by
/// Businger–Golub column-pivoted QR (in exact arithmetic the largest
/// remaining diagonal of the Schur complement is the largest remaining
/// column norm after projection). Stops after `steps` pivots; returns the
/// permutation (original indices, chosen first).
pub(crate) fn pivot_order(a: &Mat<f64>, steps: usize) -> Vec<usize> {
    let k = a.nrows();
    let mut w = a.clone();
    let mut perm: Vec<usize> = (0..k).collect();
    for j in 0..steps.min(k) {
        // Ties go to the earlier parameter. Diagonals within 1e-8 of each
        // other are ties: after many elimination steps the Schur complement
        // carries rounding far above ε, and the choice among equivalent
        // columns must not depend on how JᵀJ was summed.
        let mut p = j;
        for i in j + 1..k {
            let better = w[(i, i)] > w[(p, p)] * (1.0 + PIVOT_TIE)
                || (w[(i, i)] >= w[(p, p)] * (1.0 - PIVOT_TIE) && perm[i] < perm[p]);
            if better {
                p = i;
            }
        }
        if p != j {
            perm.swap(j, p);
            for c in 0..k {
                let t = w[(j, c)];
                w[(j, c)] = w[(p, c)];
                w[(p, c)] = t;
            }
            for r in 0..k {
                let t = w[(r, j)];
                w[(r, j)] = w[(r, p)];
                w[(r, p)] = t;
            }
        }
        let piv = w[(j, j)];
        if piv <= 0.0 {
            break;
        }
        let l: Vec<f64> = (j + 1..k).map(|i| w[(i, j)] / piv.sqrt()).collect();
        for (cb, &lc) in l.iter().enumerate() {
            let c = j + 1 + cb;
            for (ib, &li) in l.iter().enumerate() {
                w[(j + 1 + ib, c)] -= li * lc;
            }
        }
    }
    perm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pivoting_picks_largest_then_most_independent() {
        // Columns of J: a = (1,0,0), b = (2,0,0) (parallel to a), c = (0,1,1).
        // Largest norm first: c (√2) vs b (2) → b; then c; a is left.
        let j = [[1.0, 2.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
        let a = Mat::<f64>::from_fn(3, 3, |p, q| (0..3).map(|i| j[i][p] * j[i][q]).sum());
        let order = pivot_order(&a, 2);
        assert_eq!(&order[..2], &[1, 2]);
        assert_eq!(order[2], 0);
    }
}
