//! Predicting a log with a model, and scoring that prediction.

use super::cross_validation::rms;
use super::model::LogModel;
use super::read::LogData;
use crate::methods::thermal::ThermalError;
use serde::{Deserialize, Serialize};

/// How well a model predicts a test span of a log it was not fitted on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelScore {
    /// Channel column.
    pub column: String,
    /// Mean absolute error over the raw rows of the test span, in the channel's unit.
    pub mae: f64,
    /// RMS error over the test samples divided by the RMS drift (since the start) there.
    pub error_over_drift_rms: f64,
}

/// Where channel `i` of `log` starts, in its unit: its first period mean,
/// the base every prediction adds its drift to (0 when the log lacks the
/// channel).
fn start_value(log: &LogData, i: usize) -> f64 {
    log.channels
        .get(i)
        .and_then(|v| v.first())
        .copied()
        .unwrap_or(0.0)
}

/// The whole log simulated from its start (from rest, inputs only) by
/// `model`: per channel, the predicted value in the channel's unit on the
/// grid (`start + drift`, sample `k` the mean over `[kT, (k+1)T)`).
pub fn predict_log(model: &LogModel, log: &LogData) -> Result<Vec<Vec<f64>>, ThermalError> {
    let scaled = model.scaled_inputs(&log.inputs);
    model
        .channels
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let base = start_value(log, i);
            let d = c.simulate(&scaled, true)?;
            Ok(d.iter().map(|e| base + e / c.channel.unit.mm()).collect())
        })
        .collect()
}

/// Per channel of `model` with members, the lowest and the highest of its
/// models' predictions of `log` per sample (in the channel's unit, placed
/// as [`predict_log`] places the median); `None` for a channel with one
/// model.
#[allow(clippy::type_complexity)]
pub fn predict_log_range(
    model: &LogModel,
    log: &LogData,
) -> Result<Vec<Option<(Vec<f64>, Vec<f64>)>>, ThermalError> {
    let scaled = model.scaled_inputs(&log.inputs);
    model
        .channels
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if c.members.is_empty() {
                return Ok(None);
            }
            let base = start_value(log, i);
            let runs = c.simulate_each(&scaled, true)?;
            let n = runs[0].len();
            let at = |k: usize, pick: fn(f64, f64) -> f64| {
                let e = runs.iter().map(|r| r[k]).reduce(pick).unwrap_or(0.0);
                base + e / c.channel.unit.mm()
            };
            Ok(Some((
                (0..n).map(|k| at(k, f64::min)).collect(),
                (0..n).map(|k| at(k, f64::max)).collect(),
            )))
        })
        .collect()
}

/// The value of a grid series (sample `k` the mean over `[kT, (k+1)T)`,
/// placed at `(k + ½)T`) at time `t` (min since the start), linear between
/// the sample centres, held at the ends.
pub fn at_time(series: &[f64], period_min: f64, t: f64) -> f64 {
    let pos = t / period_min - 0.5;
    if pos <= 0.0 || series.len() == 1 {
        return series[0];
    }
    let k = pos.floor() as usize;
    if k + 1 >= series.len() {
        return series[series.len() - 1];
    }
    let f = pos - k as f64;
    series[k] + f * (series[k + 1] - series[k])
}

/// Score `model` on the samples from `from` on: MAE over the raw rows of
/// that span (predicted at each row's time), error/drift RMS on the grid.
pub fn score(
    model: &LogModel,
    log: &LogData,
    from: usize,
) -> Result<Vec<ChannelScore>, ThermalError> {
    let pred = predict_log(model, log)?;
    let t_from = from as f64 * log.period_min;
    Ok(model
        .channels
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let p = &pred[i];
            let (mut s, mut n) = (0.0, 0usize);
            for (t, values) in &log.raw {
                let v = values[i];
                if *t >= t_from && v.is_finite() {
                    s += (at_time(p, log.period_min, *t) - v).abs();
                    n += 1;
                }
            }
            let m = &log.channels[i];
            let err = rms((from..m.len()).map(|k| p[k] - m[k]));
            let drift = rms((from..m.len()).map(|k| m[k] - m[0]));
            ChannelScore {
                column: c.channel.column.clone(),
                mae: if n > 0 { s / n as f64 } else { f64::NAN },
                error_over_drift_rms: err / drift.max(1e-300),
            }
        })
        .collect())
}
