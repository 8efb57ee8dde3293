//! The best ARX orders of one input set, judged by the held-out simulation
//! error, and the admissibility of a structure (stable, bounded gains).

use super::cross_validation::{Bound, Candidate, Fold, cv_rms, fit_fold};
use super::lags::{best_lags, lag_orders};
use super::options::LogFitOptions;
use crate::sysid::{Arx, ArxOrders, InputOrder, Run, fit_output_error_par};

/// What the input sets of one channel are judged with: the channel's drift
/// `y` (mm since the first sample), the scaled inputs `u`, the folds, the
/// options and the largest training drift `y_max` (for the gain bound).
pub(super) struct Judge<'a> {
    pub(super) y: &'a [f64],
    pub(super) u: &'a [Vec<f64>],
    pub(super) folds: &'a [Fold],
    pub(super) options: &'a LogFitOptions,
    pub(super) y_max: f64,
    /// The lag grid of `--lags`, in model periods.
    pub(super) lag_grid: &'a [f64],
    /// Whether refinements stop early against a [`Bound`] (always, but in
    /// the test that checks they choose the same as without).
    pub(super) prune: bool,
}

impl Judge<'_> {
    /// Every order pair for `inputs` (indices into `u`): least squares on
    /// each fold's fit samples, simulated from rest, pooled RMS over the
    /// test blocks ([`cv_rms`]); the admissible structures, best first.
    /// Always judged in full: their ranking decides which are refined.
    pub(super) fn rank(&self, inputs: &[usize]) -> Vec<Candidate> {
        let (y, u, folds, options) = (self.y, self.u, self.folds, self.options);
        let mut ranked: Vec<Candidate> = Vec::new();
        for na in 0..=options.max_order {
            for nb in 0..=options.max_order {
                let orders = ArxOrders {
                    na,
                    inputs: inputs.iter().map(|_| InputOrder { nb, nk: 1 }).collect(),
                };
                let fit = |_: usize, f: &Fold| fit_fold(y, u, inputs, f, &orders);
                let lost = &|_| false;
                if let Some(e) = cv_rms(y, u, inputs, folds, fit, options, self.y_max, lost) {
                    ranked.push(Candidate::judged(inputs, orders, &e, None));
                }
            }
        }
        ranked.sort_by(|a, b| a.heldout_rms.total_cmp(&b.heldout_rms));
        ranked
    }

    /// The best structure of `inputs` given its least-squares structures
    /// `ranked` ([`Judge::rank`]): the best of them; with a single run per
    /// fold the [`REFINED`] best with `na > 0` refined by output error on
    /// the same samples and judged the same way; with `--lags` the best sum
    /// of lags. A refinement stops early ([`cv_rms`]) once it can no
    /// longer beat the best structure found so far, nor `bound`.
    pub(super) fn best(
        &self,
        inputs: &[usize],
        ranked: &[Candidate],
        bound: &Bound,
    ) -> Option<Candidate> {
        let (y, u, folds, options, y_max) = (self.y, self.u, self.folds, self.options, self.y_max);
        let keep = |best: &mut Option<Candidate>, c: Candidate| {
            if best.as_ref().is_none_or(|b| c.heldout_rms < b.heldout_rms) {
                *best = Some(c);
            }
        };
        let mut best: Option<Candidate> = ranked.first().cloned();
        // Output-error refinement needs one run from rest per fold.
        let single = folds
            .iter()
            .all(|f| f.fit.len() == 1 && f.fit[0].start == 0);
        if single {
            let runs: Vec<Run> = folds
                .iter()
                .map(|f| {
                    Run::new(
                        y[f.fit[0].clone()].to_vec(),
                        inputs
                            .iter()
                            .map(|&i| u[i][f.fit[0].clone()].to_vec())
                            .collect(),
                    )
                    .ok()
                })
                .collect::<Option<_>>()?;
            let refine = ranked.iter().filter(|c| c.orders.na > 0).take(REFINED);
            for orders in refine.map(|c| c.orders.clone()) {
                let fit = |i: usize, _: &Fold| {
                    fit_output_error_par(&runs[i], &orders, 0, crate::par::Par::Seq)
                        .ok()
                        .map(|oe| oe.fit.model)
                };
                // Kept only if strictly better than `best`; chosen in the
                // step only if not above `bound`.
                let to_beat = best.as_ref().map_or(f64::INFINITY, |b| b.heldout_rms);
                let lost = |rms: f64| self.prune && (rms >= to_beat || rms > bound.get());
                if let Some(e) = cv_rms(y, u, inputs, folds, fit, options, y_max, &lost) {
                    keep(&mut best, Candidate::judged(inputs, orders, &e, None));
                }
            }
        }
        if options.lags
            && let Some((taus, e)) = best_lags(y, u, inputs, folds, options, y_max, self.lag_grid)
        {
            let orders = lag_orders(inputs.len(), taus.len());
            keep(&mut best, Candidate::judged(inputs, orders, &e, Some(taus)));
        }
        best
    }
}

/// How many of the best least-squares structures of an input set are
/// refined by output error during the selection.
const REFINED: usize = 2;

/// Stable, and every static gain bounded.
pub(super) fn admissible(model: &Arx, options: &LogFitOptions, y_max: f64) -> bool {
    if !model.stability().is_stable() {
        return false;
    }
    let bound = options.gain_bound * y_max.max(1e-12);
    (0..model.n_inputs()).all(|i| {
        let g = model.dc_gain(i);
        g.is_finite() && g.abs() <= bound
    })
}
