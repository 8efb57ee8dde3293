//! The fit of a whole log: every channel selected and fitted, once per cut
//! of the training span.

use super::cross_validation::{fit_fold, make_folds, mean_residual, rms};
use super::lags::{LAG_GRID_MIN, lag_columns, lags_to_arx, prefix_grams, refine_lags, solve_gains};
use super::model::{ChannelMember, ChannelModel, LogInput, LogModel, scaled};
use super::options::LogFitOptions;
use super::orders::{Judge, admissible};
use super::read::LogData;
use super::select::select_inputs;
use super::spec::{ChannelSpec, InputSpec};
use crate::methods::thermal::ThermalError;
use crate::sysid::{Run, Start, fit_arx, fit_output_error_par};
use serde::Serialize;

/// The fit of a log with its selection record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LogFit {
    /// The model.
    pub model: LogModel,
    /// Training samples used.
    pub training_samples: usize,
    /// Training samples judged out of their fit (all of them with blocked
    /// cross-validation; the last block with a single held-out block).
    pub heldout_samples: usize,
    /// Cross-validation blocks the structures were chosen by (1: a single
    /// held-out block at the end of the training samples).
    pub folds: usize,
    /// Per channel: the selection path (inputs added, `-name` for one removed
    /// by the backward pass, held-out RMS after each step, mm).
    pub selection: Vec<Vec<(String, f64)>>,
    /// Notes from reading and fitting.
    pub notes: Vec<String>,
    /// Warnings (held-out error large compared with the drift, …).
    pub warnings: Vec<String>,
}

fn fail(spec: &ChannelSpec, e: crate::sysid::SysidError) -> ThermalError {
    ThermalError::Model(format!(
        "channel `{}` could not be modelled: {e}",
        spec.column
    ))
}

/// Fit one model per channel of `log`, using its first `n_train` samples
/// (all when `None`). See the module documentation for the selection.
pub fn fit_log(
    log: &LogData,
    channels: &[ChannelSpec],
    inputs: &[InputSpec],
    n_train: Option<usize>,
    options: &LogFitOptions,
) -> Result<LogFit, ThermalError> {
    fit_log_with(log, channels, inputs, n_train, options, &mut |_, _| {})
}

/// [`fit_log`], calling `progress(channel, Some(steps))` after each forward
/// selection step of a channel (and each move of the exchange search;
/// `steps` is the length of the selection path so far) and
/// `progress(channel, None)` when the channel is finished (for a progress
/// bar). With [`LogFitOptions::ensemble_folds`] the channels are fitted
/// once per number of held-out blocks, one pass after the other, and
/// `channel` counts on across the passes (channel `c` of pass `p` is
/// `p · channels + c`).
pub fn fit_log_with(
    log: &LogData,
    channels: &[ChannelSpec],
    inputs: &[InputSpec],
    n_train: Option<usize>,
    options: &LogFitOptions,
    progress: &mut dyn FnMut(usize, Option<usize>),
) -> Result<LogFit, ThermalError> {
    fit_log_pruned(log, channels, inputs, n_train, options, progress, true)
}

/// [`fit_log_with`], the refinements stopping early against the selection
/// steps' bounds (`prune`, always but in the test that checks that this
/// changes nothing).
pub(super) fn fit_log_pruned(
    log: &LogData,
    channels: &[ChannelSpec],
    inputs: &[InputSpec],
    n_train: Option<usize>,
    options: &LogFitOptions,
    progress: &mut dyn FnMut(usize, Option<usize>),
    prune: bool,
) -> Result<LogFit, ThermalError> {
    options.validate(channels.len(), inputs.len())?;
    let cut = |options: &LogFitOptions, progress: &mut dyn FnMut(usize, Option<usize>)| {
        fit_one_cut(log, channels, inputs, n_train, options, progress, prune)
    };
    if options.ensemble_folds.is_empty() {
        return cut(options, progress);
    }
    let mut single = options.clone();
    single.ensemble_folds.clear();
    let mut fit = cut(&single, progress)?;
    for (pass, &folds) in options.ensemble_folds.iter().enumerate() {
        single.folds = folds;
        let first = (pass + 1) * channels.len();
        let other = cut(&single, &mut |c, s| progress(first + c, s))?;
        // The inputs and their scales depend on the training samples only.
        debug_assert_eq!(other.model.inputs, fit.model.inputs);
        for (c, m) in fit.model.channels.iter_mut().zip(&other.model.channels) {
            c.members.push(ChannelMember::from_model(folds, m));
        }
        fit.warnings.extend(
            other
                .warnings
                .into_iter()
                .map(|w| format!("with {folds} held-out blocks: {w}")),
        );
    }
    Ok(fit)
}

/// [`fit_log_with`] for `options.folds` alone (`ensemble_folds` ignored).
fn fit_one_cut(
    log: &LogData,
    channels: &[ChannelSpec],
    inputs: &[InputSpec],
    n_train: Option<usize>,
    options: &LogFitOptions,
    progress: &mut dyn FnMut(usize, Option<usize>),
    prune: bool,
) -> Result<LogFit, ThermalError> {
    let n_train = n_train.unwrap_or(log.len()).min(log.len());
    let folds = make_folds(n_train, options);
    let params = 2 * options.max_order + options.max_inputs * (options.max_order + 1);
    let n_fit = folds
        .iter()
        .map(|f| f.fit.iter().map(|r| r.len()).sum::<usize>())
        .min()
        .unwrap_or(0);
    let n_test = folds.iter().map(|f| f.test.len()).min().unwrap_or(0);
    if n_fit < 3 * params || n_test < 3 {
        return Err(ThermalError::Options(format!(
            "{n_train} training samples are too few: the fit part ({n_fit}) needs at least {} samples for models of up \
             to {params} parameters and each held-out block ({n_test}) at least 3 (a longer log or a shorter period)",
            3 * params
        )));
    }
    let heldout_samples: usize = folds.iter().map(|f| f.test.len()).sum();
    let lag_grid: Vec<f64> = LAG_GRID_MIN.iter().map(|t| t / log.period_min).collect();
    let model_inputs: Vec<LogInput> = inputs
        .iter()
        .zip(&log.inputs)
        .map(|(spec, u)| {
            let r = scaled(&u[..n_train], spec.rise, spec.square, 1.0);
            let m = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            LogInput {
                column: spec.column.clone(),
                rise: spec.rise,
                square: spec.square,
                over: spec.over.clone(),
                scale: if m > 0.0 { m } else { 1.0 },
            }
        })
        .collect();
    let u: Vec<Vec<f64>> = model_inputs
        .iter()
        .zip(&log.inputs)
        .map(|(spec, u)| scaled(u, spec.rise, spec.square, spec.scale))
        .collect();
    let mut models = Vec::new();
    let mut selection = Vec::new();
    let mut warnings = Vec::new();
    for (ci, (spec, values)) in channels.iter().zip(&log.channels).enumerate() {
        let base = values[0];
        let y: Vec<f64> = values.iter().map(|v| (v - base) * spec.unit.mm()).collect();
        let y_max = y[..n_train].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let names: Vec<String> = model_inputs.iter().map(LogInput::name).collect();
        let judge = Judge {
            y: &y,
            u: &u,
            folds: &folds,
            options,
            y_max,
            lag_grid: &lag_grid,
            prune,
        };
        let (chosen, path) = select_inputs(u.len(), &names, options, &judge, &mut |steps| {
            progress(ci, Some(steps))
        });
        let Some(cand) = chosen else {
            return Err(ThermalError::Options(format!(
                "channel `{}`: no stable model with bounded gains was found for any input",
                spec.column
            )));
        };
        // Refit the chosen structure on all training samples, then refine
        // by output error.
        let run = Run::new(
            y[..n_train].to_vec(),
            cand.inputs
                .iter()
                .map(|&i| u[i][..n_train].to_vec())
                .collect(),
        )
        .map_err(|e| fail(spec, e))?;
        let arx = fit_arx(std::slice::from_ref(&run), &cand.orders, Start::AtRest)
            .map_err(|e| fail(spec, e))?;
        let mut model = arx.model.clone();
        let mut training_rms = arx.stats.simulation_rms;
        let mut output_error = false;
        // A sum of lags: its gains by least squares on all training samples
        // (the output-error fit for its time constants).
        let offset = options.start_offset;
        let lag_model = cand.lags.as_ref().and_then(|taus| {
            let taus = &refine_lags(&y, &u, &cand.inputs, taus, n_train, offset);
            let cols = lag_columns(&u, &cand.inputs, taus, n_train, offset);
            let g = prefix_grams(&cols, &y, &[n_train]);
            let gains = solve_gains(&g[0])?;
            let c = if offset { gains[gains.len() - 1] } else { 0.0 };
            lags_to_arx(taus, &gains, cand.inputs.len()).map(|m| (m, c))
        });
        let mut start_offset = 0.0;
        if let Some((m, c)) = lag_model {
            let sim = m.simulate(&run.input_slices()).map_err(|e| fail(spec, e))?;
            training_rms = rms(sim
                .iter()
                .zip(run.output())
                .enumerate()
                .map(|(k, (s, m))| s + if k > 0 { c } else { 0.0 } - m));
            model = m;
            start_offset = c;
        } else if cand.orders.na > 0
            && let Ok(oe) = fit_output_error_par(&run, &cand.orders, 0, crate::par::Par::Seq)
            && admissible(&oe.fit.model, options, y_max)
        {
            let sim = oe.fit.model.simulate(&run.input_slices()).ok();
            if let Some(sim) = sim {
                let e = rms(sim.iter().zip(run.output()).map(|(s, m)| s - m));
                if e < training_rms {
                    training_rms = e;
                    model = oe.fit.model.clone();
                    output_error = true;
                }
            }
        }
        if !admissible(&model, options, y_max) {
            // The refit on all samples left the bounds: keep the first
            // fold's model (admissible, as the candidate was judged so).
            model = folds
                .iter()
                .filter_map(|f| fit_fold(&y, &u, &cand.inputs, f, &cand.orders))
                .find(|m| admissible(m, options, y_max))
                .ok_or_else(|| {
                    ThermalError::Model(format!(
                        "channel `{}` could not be modelled: no admissible refit",
                        spec.column
                    ))
                })?;
            output_error = false;
        }
        if offset && cand.lags.is_none() {
            // An ARX structure: the start offset is the mean simulation
            // residual after the first sample (its least-squares value for
            // the simulated model).
            let sim = model
                .simulate(&run.input_slices())
                .map_err(|e| fail(spec, e))?;
            start_offset = mean_residual(&sim, run.output());
            training_rms =
                rms((0..n_train).map(|k| sim[k] + if k > 0 { start_offset } else { 0.0 } - y[k]));
        }
        let heldout_drift = rms(folds.iter().flat_map(|f| y[f.test.clone()].iter().copied()));
        if cand.heldout_rms > options.warn_ratio * heldout_drift {
            warnings.push(format!(
                "channel `{}`: the held-out simulation error ({:.2} µm RMS) is {:.0} % of the drift there: \
                 the model predicts this channel poorly",
                spec.column,
                cand.heldout_rms * 1e3,
                100.0 * cand.heldout_rms / heldout_drift.max(1e-300)
            ));
        }
        models.push(ChannelModel {
            channel: spec.clone(),
            inputs: cand.inputs.clone(),
            a: model.a().to_vec(),
            b: (0..model.n_inputs()).map(|i| model.b(i).to_vec()).collect(),
            heldout_rms_mm: cand.heldout_rms,
            heldout_drift_rms_mm: heldout_drift,
            training_rms_mm: training_rms,
            output_error,
            start_offset_mm: start_offset,
            members: Vec::new(),
        });
        selection.push(path);
        progress(ci, None);
    }
    Ok(LogFit {
        model: LogModel {
            period_min: log.period_min,
            inputs: model_inputs,
            channels: models,
        },
        training_samples: n_train,
        heldout_samples,
        folds: folds.len(),
        selection,
        notes: log.notes.clone(),
        warnings,
    })
}
