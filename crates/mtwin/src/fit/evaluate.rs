//! Evaluation passes over the residual rows: residuals, gradient `Jᵀr`, and
//! either the whole Jacobian (dense path) or the normal matrix `JᵀJ`
//! accumulated chunk by chunk (normal-equation path).
//!
//! The rows are cut into *tasks* (a few hundred rows on block boundaries)
//! that rayon runs in parallel; on the normal-equation path the tasks are
//! grouped into *chunks* of [`super::Options::chunk_rows`] rows, and only one
//! chunk of the Jacobian (`chunk_rows × n`) is alive at a time besides the
//! `n × n` normal matrix. `JᵀJ` is accumulated with faer's triangular
//! matmul (lower half only, parallel), then mirrored.

use std::ops::Range;

use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{BlockStructure, matmul as tri_matmul};
use faer::reborrow::ReborrowMut;
use faer::{Accum, ColMut, ColRef, Mat, MatMut, MatRef};
use rayon::prelude::*;

use super::factored::{self, Plan};
use super::problem::{BlockLayout, Factored, Model};
use super::{FitError, Progress};

/// Rows per parallel task.
const TASK_ROWS: usize = 256;

/// What a pass must produce besides the residuals.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Need {
    /// Residuals only.
    Residuals,
    /// Residuals and the gradient `Jᵀr`.
    Gradient,
    /// Residuals, gradient and the full Jacobian kept in memory.
    Dense,
    /// Residuals, gradient and `JᵀJ`.
    Normal,
}

/// The result of one pass at θ. Rows of excluded blocks are zero in `r`,
/// in the Jacobian and therefore in every product.
pub(crate) struct Evaluation {
    /// Residuals (`m`).
    pub r: Vec<f64>,
    /// `½‖r‖²`.
    pub cost: f64,
    /// `Jᵀr` (`n`), empty for [`Need::Residuals`].
    pub g: Vec<f64>,
    /// The transposed Jacobian `Jᵀ` (`n × m`, column-major, so that each
    /// row of J is contiguous) for [`Need::Dense`].
    pub jt: Option<Mat<f64>>,
    /// `JᵀJ` (`n × n`, both halves filled) for [`Need::Normal`].
    pub normal: Option<Mat<f64>>,
}

/// Everything a pass needs to know besides θ.
pub(crate) struct Pass<'a> {
    pub model: &'a dyn Model,
    pub layout: &'a BlockLayout,
    pub n: usize,
    /// Per block: `true` if the block takes part in the fit.
    pub included: &'a [bool],
    pub chunk_rows: usize,
    pub progress: &'a dyn Fn(Progress),
    /// The factored Jacobian and its plan, when the model has one and the
    /// options allow it: gradient and normal passes then use
    /// [`factored`] instead of Jacobian rows.
    pub factored: Option<(&'a dyn Factored, &'a Plan)>,
}

impl Pass<'_> {
    /// Runs one pass at θ.
    pub fn run(&self, theta: &[f64], need: Need) -> Result<Evaluation, FitError> {
        let m = self.layout.rows();
        let n = self.n;
        let mut r = vec![0.0; m];
        let tasks = self.layout.chunks(TASK_ROWS);
        let mut g = if need == Need::Residuals {
            Vec::new()
        } else {
            vec![0.0; n]
        };
        let mut jacobian = None;
        let mut normal = None;
        match (need, self.factored) {
            (Need::Residuals, _) => {
                let mut slices = split_rows(&mut r, &tasks);
                let each = |(rows, out): &mut (Range<usize>, &mut [f64])| {
                    self.model.residuals(theta, rows.clone(), out);
                };
                if crate::par::sequential() {
                    slices.iter_mut().for_each(each);
                } else {
                    slices.par_iter_mut().for_each(each);
                }
                (self.progress)(Progress::Evaluating {
                    rows_done: m,
                    rows_total: m,
                });
            }
            (Need::Dense, _) => {
                let mut jt = Mat::<f64>::zeros(n, m);
                self.fill(theta, &tasks, &mut r, jt.as_mut().transpose_mut());
                (self.progress)(Progress::Evaluating {
                    rows_done: m,
                    rows_total: m,
                });
                gemv(jt.as_ref(), &r, &mut g, Accum::Replace);
                jacobian = Some(jt);
            }
            (Need::Gradient | Need::Normal, Some((fm, plan))) => {
                let slots = factored::Slots::new(plan, n, need == Need::Normal);
                // No Jacobian rows are held: chunks only pace the progress
                // reports (about 16 per pass).
                for chunk in group_tasks(&tasks, self.chunk_rows.max(m / 16)) {
                    let (lo, hi) = (tasks[chunk.start].start, tasks[chunk.end - 1].end);
                    factored::accumulate(
                        fm,
                        plan,
                        self.layout,
                        self.included,
                        theta,
                        lo..hi,
                        &mut r[lo..hi],
                        &slots,
                    );
                    (self.progress)(Progress::Evaluating {
                        rows_done: hi,
                        rows_total: m,
                    });
                }
                if let Some(sums) = slots.total() {
                    if need == Need::Normal {
                        normal = Some(sums.normal(plan, n));
                    }
                    g = sums.g;
                }
            }
            (Need::Gradient | Need::Normal, None) => {
                let mut nm = (need == Need::Normal).then(|| Mat::<f64>::zeros(n, n));
                // Jᵀ of the chunk, n × rows: rows of J contiguous.
                let mut jt = Mat::<f64>::zeros(n, 0);
                for chunk in group_tasks(&tasks, self.chunk_rows) {
                    let (lo, hi) = (tasks[chunk.start].start, tasks[chunk.end - 1].end);
                    if jt.ncols() != hi - lo {
                        jt = Mat::<f64>::zeros(n, hi - lo);
                    }
                    self.fill(
                        theta,
                        &tasks[chunk],
                        &mut r[lo..hi],
                        jt.as_mut().transpose_mut(),
                    );
                    gemv(jt.as_ref(), &r[lo..hi], &mut g, Accum::Add);
                    if let Some(nm) = nm.as_mut() {
                        tri_matmul(
                            nm.as_mut(),
                            BlockStructure::TriangularLower,
                            Accum::Add,
                            jt.as_ref(),
                            BlockStructure::Rectangular,
                            jt.transpose(),
                            BlockStructure::Rectangular,
                            1.0,
                            crate::par::faer(),
                        );
                    }
                    (self.progress)(Progress::Evaluating {
                        rows_done: hi,
                        rows_total: m,
                    });
                }
                if let Some(mut nm) = nm {
                    for c in 0..n {
                        for i in 0..c {
                            nm[(i, c)] = nm[(c, i)];
                        }
                    }
                    normal = Some(nm);
                }
            }
        }
        self.mask_and_check(&mut r, jacobian.as_ref().map(|jt| jt.transpose()))?;
        let cost = 0.5 * r.iter().map(|x| x * x).sum::<f64>();
        if !cost.is_finite() {
            return Err(FitError::NonFinite {
                what: "residual",
                row: r.iter().position(|x| !x.is_finite()).unwrap_or(0),
            });
        }
        if g.iter().any(|x| !x.is_finite())
            || normal.as_ref().is_some_and(|nm| {
                !nm.as_ref()
                    .col_iter()
                    .all(|c| c.iter().all(|x| x.is_finite()))
            })
        {
            return Err(FitError::NonFinite {
                what: "Jacobian",
                row: 0,
            });
        }
        Ok(Evaluation {
            r,
            cost,
            g,
            jt: jacobian,
            normal,
        })
    }

    /// Fills residuals and Jacobian rows of `tasks` (consecutive; `r` and
    /// `j` start at the first task's first row) in parallel, and zeroes the
    /// rows of excluded blocks.
    fn fill(&self, theta: &[f64], tasks: &[Range<usize>], r: &mut [f64], j: MatMut<'_, f64>) {
        let mut parts = Vec::with_capacity(tasks.len());
        let mut rest_r = r;
        let mut rest_j = j;
        for t in tasks {
            let (a, b) = rest_r.split_at_mut(t.len());
            let (ja, jb) = rest_j.split_at_row_mut(t.len());
            parts.push((t.clone(), a, ja));
            rest_r = b;
            rest_j = jb;
        }
        let each = |(rows, r, mut j): (Range<usize>, &mut [f64], MatMut<'_, f64>)| {
            self.model
                .residuals_and_jacobian(theta, rows.clone(), r, j.rb_mut());
            let mut b = self.layout.block_of_row(rows.start);
            while b < self.layout.blocks() && self.layout.block_rows(b).start < rows.end {
                if !self.included[b] {
                    for row in self.layout.block_rows(b) {
                        let i = row - rows.start;
                        r[i] = 0.0;
                        for c in 0..j.ncols() {
                            j[(i, c)] = 0.0;
                        }
                    }
                }
                b += 1;
            }
        };
        if crate::par::sequential() {
            parts.into_iter().for_each(each);
        } else {
            parts.into_par_iter().for_each(each);
        }
    }

    /// Zeroes excluded residual rows (the residual-only pass does not go
    /// through `fill`) and reports the first non-finite entry.
    fn mask_and_check(
        &self,
        r: &mut [f64],
        j: Option<faer::MatRef<'_, f64>>,
    ) -> Result<(), FitError> {
        for b in 0..self.layout.blocks() {
            if !self.included[b] {
                r[self.layout.block_rows(b)]
                    .iter_mut()
                    .for_each(|x| *x = 0.0);
            }
        }
        if let Some(row) = r.iter().position(|x| !x.is_finite()) {
            return Err(FitError::NonFinite {
                what: "residual",
                row,
            });
        }
        // The scan in column order below names the first bad entry; the
        // quick test over the contiguous rows of J decides whether to scan.
        let all_finite = |j: faer::MatRef<'_, f64>| {
            (0..j.nrows()).all(|i| {
                j.row(i)
                    .try_as_row_major()
                    .is_some_and(|row| row.as_slice().iter().all(|x| x.is_finite()))
            })
        };
        if let Some(j) = j
            && !all_finite(j)
        {
            for c in 0..j.ncols() {
                if let Some(row) = j.col(c).iter().position(|x| !x.is_finite()) {
                    return Err(FitError::NonFinite {
                        what: "Jacobian",
                        row,
                    });
                }
            }
        }
        Ok(())
    }
}

/// Splits `r` into the row slices of `tasks` (consecutive, from row 0).
fn split_rows<'a>(r: &'a mut [f64], tasks: &[Range<usize>]) -> Vec<(Range<usize>, &'a mut [f64])> {
    let mut out = Vec::with_capacity(tasks.len());
    let mut rest = r;
    for t in tasks {
        let (a, b) = rest.split_at_mut(t.len());
        out.push((t.clone(), a));
        rest = b;
    }
    out
}

/// Groups consecutive tasks into ranges of task indices of about
/// `chunk_rows` rows each.
fn group_tasks(tasks: &[Range<usize>], chunk_rows: usize) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut a = 0;
    while a < tasks.len() {
        let start = tasks[a].start;
        let mut b = a + 1;
        while b < tasks.len() && tasks[b].end - start <= chunk_rows.max(1) {
            b += 1;
        }
        out.push(a..b);
        a = b;
    }
    out
}

/// `g = Jᵀ·r` (`Accum::Replace`) or `g += Jᵀ·r` (`Accum::Add`), with the
/// transposed Jacobian `jt` given.
fn gemv(jt: MatRef<'_, f64>, r: &[f64], g: &mut [f64], accum: Accum) {
    matmul(
        ColMut::from_slice_mut(g).as_mat_mut(),
        accum,
        jt,
        ColRef::from_slice(r).as_mat(),
        1.0,
        crate::par::faer(),
    );
}
