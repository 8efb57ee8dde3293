//! The best ARX orders of one input set, judged by the held-out simulation
//! error, and the admissibility of a structure (stable, bounded gains).

use super::cross_validation::{Candidate, Fold, cv_rms, fit_fold};
use super::lags::{best_lags, lag_orders};
use super::options::LogFitOptions;
use crate::sysid::{Arx, ArxOrders, InputOrder, Run, fit_output_error_par};

/// Try every order pair for `inputs` (indices into `u`): least squares on
/// each fold's fit samples, simulated from rest, pooled RMS over the test
/// blocks ([`cv_rms`]); with a single fold the [`REFINED`] best structures
/// are then refined by output error on the same samples and judged the
/// same way.
pub(super) fn best_orders(
    y: &[f64],
    u: &[Vec<f64>],
    inputs: &[usize],
    folds: &[Fold],
    options: &LogFitOptions,
    y_max: f64,
    lag_grid: &[f64],
) -> Option<Candidate> {
    let mut ranked: Vec<Candidate> = Vec::new();
    for na in 0..=options.max_order {
        for nb in 0..=options.max_order {
            let orders = ArxOrders {
                na,
                inputs: inputs.iter().map(|_| InputOrder { nb, nk: 1 }).collect(),
            };
            let fit = |_: usize, f: &Fold| fit_fold(y, u, inputs, f, &orders);
            if let Some(e) = cv_rms(y, u, inputs, folds, fit, options, y_max) {
                ranked.push(Candidate {
                    inputs: inputs.to_vec(),
                    orders,
                    heldout_rms: e.rms(),
                    blocks: e.block_mse(),
                    gains: e.gains.clone(),
                    lags: None,
                });
            }
        }
    }
    ranked.sort_by(|a, b| a.heldout_rms.total_cmp(&b.heldout_rms));
    let mut best: Option<Candidate> = None;
    let mut keep = |c: Candidate| {
        if best.as_ref().is_none_or(|b| c.heldout_rms < b.heldout_rms) {
            best = Some(c);
        }
    };
    // Output-error refinement needs one run from rest per fold.
    let single = folds
        .iter()
        .all(|f| f.fit.len() == 1 && f.fit[0].start == 0);
    let refine: Vec<ArxOrders> = match single {
        true => ranked
            .iter()
            .filter(|c| c.orders.na > 0)
            .take(REFINED)
            .map(|c| c.orders.clone())
            .collect(),
        false => Vec::new(),
    };
    if let Some(c) = ranked.into_iter().next() {
        keep(c);
    }
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
        for orders in refine {
            let fit = |i: usize, _: &Fold| {
                fit_output_error_par(&runs[i], &orders, 0, crate::par::Par::Seq)
                    .ok()
                    .map(|oe| oe.fit.model)
            };
            if let Some(e) = cv_rms(y, u, inputs, folds, fit, options, y_max) {
                keep(Candidate {
                    inputs: inputs.to_vec(),
                    orders,
                    heldout_rms: e.rms(),
                    blocks: e.block_mse(),
                    gains: e.gains.clone(),
                    lags: None,
                });
            }
        }
    }
    if options.lags
        && let Some((taus, e)) = best_lags(y, u, inputs, folds, options, y_max, lag_grid)
    {
        keep(Candidate {
            inputs: inputs.to_vec(),
            orders: lag_orders(inputs.len(), taus.len()),
            heldout_rms: e.rms(),
            blocks: e.block_mse(),
            gains: e.gains.clone(),
            lags: Some(taus),
        });
    }
    best
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
