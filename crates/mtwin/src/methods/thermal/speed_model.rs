//! How the spindle speed enters the thermal model: linearly (04's model), or
//! as speed and speed² — a Hammerstein variant (a static nonlinearity before
//! the linear dynamics) for heat that grows faster than the speed, as bearing
//! friction does — or whichever of the two predicts held-out runs better.
//!
//! The choice is by leave-one-run-out: each run is predicted, from cold, by
//! the model fitted to the other runs; the quadratic variant is kept only when
//! its held-out RMS is below [`REQUIRED_GAIN`] times the linear one's, so a
//! variant that merely fits the noise is not chosen.

use std::str::FromStr;

use serde_json::json;

use super::ThermalError;
use super::data::TrainingData;
use super::predict::{Programme, ThermalFitOptions, fit_with, predict};

/// How the speed enters the thermal model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpeedModel {
    /// `b·n`: 04's model.
    #[default]
    Linear,
    /// `b₁·n + b₂·n²` (both through the ARX lags): heat growing faster than the speed.
    Quadratic,
    /// Quadratic only when it predicts held-out runs better (leave-one-run-out).
    Auto,
}

impl FromStr for SpeedModel {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "linear" => Ok(SpeedModel::Linear),
            "quadratic" => Ok(SpeedModel::Quadratic),
            "auto" => Ok(SpeedModel::Auto),
            other => Err(format!(
                "unknown speed model `{other}` (linear, quadratic or auto)"
            )),
        }
    }
}

/// The quadratic variant must bring the held-out RMS below this fraction of
/// the linear model's to be chosen.
pub const REQUIRED_GAIN: f64 = 0.95;

/// The leave-one-run-out comparison behind [`SpeedModel::Auto`].
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedModelChoice {
    /// Held-out runs (one fold each).
    pub folds: usize,
    /// RMS of the held-out drift error of the linear model, mm.
    pub linear_rms_mm: f64,
    /// The same for the quadratic model, mm (`None`: it could not be fitted
    /// on every fold, e.g. too few samples for its larger order grid).
    pub quadratic_rms_mm: Option<f64>,
    /// Whether the quadratic model was chosen.
    pub quadratic: bool,
}

impl SpeedModelChoice {
    /// One plain sentence.
    pub fn summary(&self) -> String {
        let q = self
            .quadratic_rms_mm
            .map_or("could not be fitted on every fold".to_string(), |q| {
                format!("{:.2} µm", q * 1e3)
            });
        format!(
            "speed model: {} (held-out RMS over {} runs, each predicted by the others: linear {:.2} µm, quadratic {q}; quadratic needs < {:.0} % of linear)",
            if self.quadratic {
                "quadratic"
            } else {
                "linear"
            },
            self.folds,
            self.linear_rms_mm * 1e3,
            REQUIRED_GAIN * 100.0
        )
    }

    /// `{"chosen", "folds", "linear_rms_mm", "quadratic_rms_mm"}`.
    pub fn to_json(&self) -> serde_json::Value {
        json!({
            "chosen": if self.quadratic { "quadratic" } else { "linear" },
            "folds": self.folds,
            "linear_rms_mm": self.linear_rms_mm,
            "quadratic_rms_mm": self.quadratic_rms_mm,
        })
    }
}

/// Compare the linear and quadratic speed models by leave-one-run-out on
/// `data` (at least two runs) with the order search of `options`.
pub fn choose_speed_model(
    data: &TrainingData,
    options: &ThermalFitOptions,
) -> Result<SpeedModelChoice, ThermalError> {
    if data.runs.len() < 2 {
        return Err(ThermalError::SpeedModel(format!(
            "auto compares predictions of held-out runs, but {} has {} run(s): \
             add runs (a `run` column) or choose linear or quadratic",
            data.path.display(),
            data.runs.len()
        )));
    }
    let mut linear = (0.0, 0usize);
    let mut quadratic = Some((0.0, 0usize));
    for label in &data.runs {
        let train = data.without_run(label);
        let fit = fit_with(&train, options, false).map_err(|e| {
            ThermalError::SpeedModel(format!(
                "without run `{label}` the linear model cannot be fitted ({e}); \
                 choose linear or quadratic instead of auto"
            ))
        })?;
        add(&mut linear, held_out(&fit.model, data, label));
        quadratic = match (quadratic, fit_with(&train, options, true)) {
            (Some(mut acc), Ok(fit)) => {
                add(&mut acc, held_out(&fit.model, data, label));
                Some(acc)
            }
            _ => None,
        };
    }
    let rms = |(s, n): (f64, usize)| (s / n.max(1) as f64).sqrt();
    let linear_rms_mm = rms(linear);
    let quadratic_rms_mm = quadratic.map(rms);
    Ok(SpeedModelChoice {
        folds: data.runs.len(),
        linear_rms_mm,
        quadratic_rms_mm,
        quadratic: quadratic_rms_mm.is_some_and(|q| q < REQUIRED_GAIN * linear_rms_mm),
    })
}

fn add(acc: &mut (f64, usize), (s, n): (f64, usize)) {
    acc.0 += s;
    acc.1 += n;
}

/// Sum of squared errors (mm²) and count of `model`'s prediction, from cold,
/// of every series of run `label` at its measured height.
fn held_out(model: &super::ThermalModel, data: &TrainingData, label: &str) -> (f64, usize) {
    let mut acc = (0.0, 0);
    for h in &data.heights {
        for s in h.series.iter().filter(|s| s.run == label) {
            let samples = (0..s.drift.len())
                .map(|k| s.inputs.iter().map(|col| col[k]).collect())
                .collect();
            let pred = predict(model, &Programme::new(samples), &[h.z_mm]);
            for (row, e) in pred.rows.iter().zip(&s.drift) {
                acc.0 += (row[2] - e).powi(2);
                acc.1 += 1;
            }
        }
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse() {
        assert_eq!("auto".parse::<SpeedModel>(), Ok(SpeedModel::Auto));
        assert_eq!("linear".parse::<SpeedModel>(), Ok(SpeedModel::Linear));
        assert_eq!("quadratic".parse::<SpeedModel>(), Ok(SpeedModel::Quadratic));
        assert!("cubic".parse::<SpeedModel>().is_err());
    }
}
