//! Cross-validation in time: the folds of the training span, the fits on
//! their fit samples and the simulation error on their held-out blocks.

use super::options::LogFitOptions;
use super::orders::admissible;
use crate::sysid::{Arx, ArxOrders, Run, Start, fit_arx};
use std::sync::atomic::{AtomicU64, Ordering};

pub(super) fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 { 0.0 } else { (s / n as f64).sqrt() }
}

#[derive(Clone)]
pub(super) struct Candidate {
    pub(super) inputs: Vec<usize>,
    pub(super) orders: ArxOrders,
    /// Pooled held-out RMS, mm.
    pub(super) heldout_rms: f64,
    /// Per held-out block its simulation MSE, mm².
    pub(super) blocks: Vec<f64>,
    /// Per fold, the static gain of each input of its fit (mm per unit of
    /// the scaled input, in the order of `inputs`).
    pub(super) gains: Vec<Vec<f64>>,
    /// Time constants (model periods) of a sum-of-lags candidate
    /// ([`best_lags`](super::lags::best_lags)); `None` for an ARX candidate.
    pub(super) lags: Option<Vec<f64>>,
}

impl Candidate {
    /// The candidate of `inputs` with the structure `orders` (and the time
    /// constants `lags` of a sum of lags) judged by its held-out errors.
    pub(super) fn judged(
        inputs: &[usize],
        orders: ArxOrders,
        held: &HeldOut,
        lags: Option<Vec<f64>>,
    ) -> Candidate {
        Candidate {
            inputs: inputs.to_vec(),
            orders,
            heldout_rms: held.rms(),
            blocks: held.block_mse(),
            gains: held.gains.clone(),
            lags,
        }
    }
}

/// The held-out RMS a candidate input set must stay at or below to be
/// chosen in one selection step: the step's acceptance limit (a change must
/// lower the held-out RMS below `(1 − min_gain)` times the current one),
/// lowered to the RMS of every set already judged and accepted in the step.
/// Shared by the sets judged in parallel; a set whose RMS exceeds it cannot
/// be the step's choice (the accepted set behind the bound is strictly
/// better, and a tie is no loss: pruning needs more than the bound), so its
/// costly output-error refinements stop at the first block whose pooled
/// RMS so far is above it ([`cv_rms`]). Which sets are cut short depends on
/// the threads' timing; the choice, and everything recorded of it, does
/// not.
pub(super) struct Bound(AtomicU64);

impl Bound {
    /// A bound starting at `limit` (`f64::INFINITY`: none yet).
    pub(super) fn new(limit: f64) -> Bound {
        Bound(AtomicU64::new(limit.to_bits()))
    }

    /// The bound now.
    pub(super) fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Relaxed))
    }

    /// Lower the bound to `rms` (an accepted set's held-out RMS) if that is
    /// below it.
    pub(super) fn lower(&self, rms: f64) {
        let mut now = self.0.load(Ordering::Relaxed);
        while rms < f64::from_bits(now) {
            match self.0.compare_exchange_weak(
                now,
                rms.to_bits(),
                Ordering::Relaxed,
                Ordering::Relaxed,
            ) {
                Ok(_) => break,
                Err(seen) => now = seen,
            }
        }
    }
}

/// One fold of the blocked cross-validation: the model is fitted on the
/// samples of `fit` (one run per range) and judged on the samples of `test`,
/// simulated from rest at sample 0 with the inputs alone.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Fold {
    pub(super) fit: Vec<std::ops::Range<usize>>,
    pub(super) test: std::ops::Range<usize>,
}

/// The folds for `n_train` training samples: with `folds` = 1 the last
/// `holdout` fraction of them is held out and the model fitted on the rest;
/// with `folds` = K ≥ 2 the training samples are cut into K + 1 contiguous
/// blocks of (nearly) equal length and each block after the first is held
/// out in turn, the model fitted on all the blocks before it (a rolling
/// origin: every fold predicts its block from cold, as the model will
/// predict the future, and every fold's fit is one run from rest, so it can
/// be refined by output error).
// One fit range per fold, kept a list (a fold may hold several runs).
#[allow(clippy::single_range_in_vec_init)]
pub(super) fn make_folds(n_train: usize, options: &LogFitOptions) -> Vec<Fold> {
    if options.folds <= 1 {
        let n_fit = ((n_train as f64) * (1.0 - options.holdout)).round() as usize;
        return vec![Fold {
            fit: vec![0..n_fit],
            test: n_fit..n_train,
        }];
    }
    let k = options.folds;
    let edge = |j: usize| (j * n_train) / (k + 1);
    (1..=k)
        .map(|j| Fold {
            fit: vec![0..edge(j)],
            test: edge(j)..edge(j + 1),
        })
        .collect()
}

/// The least-squares ARX fit of one fold: its fit samples, one run from
/// rest at sample 0.
pub(super) fn fit_fold(
    y: &[f64],
    u: &[Vec<f64>],
    inputs: &[usize],
    fold: &Fold,
    orders: &ArxOrders,
) -> Option<Arx> {
    let runs: Vec<Run> = fold
        .fit
        .iter()
        .map(|r| {
            Run::new(
                y[r.clone()].to_vec(),
                inputs.iter().map(|&i| u[i][r.clone()].to_vec()).collect(),
            )
            .ok()
        })
        .collect::<Option<_>>()?;
    fit_arx(&runs, orders, Start::AtRest).ok().map(|f| f.model)
}

/// The held-out errors of a candidate over the folds: per held-out block its
/// sum of squared simulation errors and its number of samples.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct HeldOut {
    pub(super) ss: Vec<f64>,
    pub(super) n: Vec<usize>,
    /// Per fold, the static gain of each input of its fit (mm per unit of
    /// the scaled input).
    pub(super) gains: Vec<Vec<f64>>,
}

impl HeldOut {
    pub(super) fn new() -> HeldOut {
        HeldOut {
            ss: Vec::new(),
            n: Vec::new(),
            gains: Vec::new(),
        }
    }

    /// The squared errors of all held-out blocks pooled into one RMS.
    pub(super) fn rms(&self) -> f64 {
        let n: usize = self.n.iter().sum();
        (self.ss.iter().sum::<f64>() / n.max(1) as f64).sqrt()
    }

    /// Per held-out block its mean squared error.
    pub(super) fn block_mse(&self) -> Vec<f64> {
        self.ss
            .iter()
            .zip(&self.n)
            .map(|(s, &n)| s / n.max(1) as f64)
            .collect()
    }

    pub(super) fn finite(self) -> Option<HeldOut> {
        self.ss.iter().all(|v| v.is_finite()).then_some(self)
    }
}

/// Held-out simulation errors of `model`-structures over the folds: each
/// fold's model simulated from rest at sample 0 up to the end of its test
/// block, the squared errors of each test block summed ([`HeldOut`]).
/// `None` when a fold's model cannot be fitted (`fit` gives `None`) or is
/// not admissible: the folds are fitted one after the other by `fit(fold
/// index, fold)` and the first failure ends the candidate (the later folds
/// are not fitted).
///
/// `None` as well, before the next fold is fitted, once `lost(rms)` holds
/// for the pooled RMS of the blocks so far (their squared errors over the
/// samples of all the blocks): the later blocks only add squared errors, so
/// the candidate's RMS can only be at least that (see [`Bound`]).
// The eight arguments are the data, the candidate and its two rules.
#[allow(clippy::too_many_arguments)]
pub(super) fn cv_rms(
    y: &[f64],
    u: &[Vec<f64>],
    inputs: &[usize],
    folds: &[Fold],
    mut fit: impl FnMut(usize, &Fold) -> Option<Arx>,
    options: &LogFitOptions,
    y_max: f64,
    lost: &dyn Fn(f64) -> bool,
) -> Option<HeldOut> {
    let mut held = HeldOut::new();
    let n_all = folds.iter().map(|f| f.test.len()).sum::<usize>().max(1) as f64;
    for (i, fold) in folds.iter().enumerate() {
        if i > 0 && lost((held.ss.iter().sum::<f64>() / n_all).sqrt()) {
            return None;
        }
        let model = &fit(i, fold)?;
        if !admissible(model, options, y_max) {
            return None;
        }
        let full: Vec<&[f64]> = inputs.iter().map(|&i| &u[i][..fold.test.end]).collect();
        let sim = model.simulate(&full).ok()?;
        let c = if options.start_offset {
            let end = fold.fit.last().map_or(0, |r| r.end);
            mean_residual(&sim[..end], &y[..end])
        } else {
            0.0
        };
        let ss: f64 = fold.test.clone().map(|k| (sim[k] + c - y[k]).powi(2)).sum();
        held.ss.push(ss);
        held.n.push(fold.test.len());
        held.gains
            .push((0..model.n_inputs()).map(|i| model.dc_gain(i)).collect());
    }
    held.finite()
}

/// The least-squares start offset of a simulated drift `sim` against `y`
/// (both since the first sample): the mean of `y − sim` after sample 0.
pub(super) fn mean_residual(sim: &[f64], y: &[f64]) -> f64 {
    let n = sim.len().min(y.len());
    if n < 2 {
        return 0.0;
    }
    (1..n).map(|k| y[k] - sim[k]).sum::<f64>() / (n - 1) as f64
}
