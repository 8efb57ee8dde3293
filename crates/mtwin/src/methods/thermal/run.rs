//! The thermal methods in the library's one shape, options in and a
//! document out: [`run_fit`] and [`run_predict`] (probing runs per height,
//! `TRAIN.csv` / `SPEED.csv`), [`run_fit_log`] and [`run_predict_log`] (wide
//! machine logs, [`super::log`]). Each reads its input files, does the work
//! and returns what is to be written (model text, plots, rows) beside the
//! document; the caller writes the files and prints the document.
//!
//! Units: time in min, speed in rev/min, heights and drift in mm; a log's
//! drift channels in their own unit (`um` or `mm`).

use std::io::Write;
use std::path::Path;

use super::doc::{
    LogChannelDoc, LogMemberDoc, LogPredictedChannelDoc, LogSelectionStepDoc, LogTestDoc,
    ThermalLogFitDoc, ThermalLogPredictDoc,
};
use super::log::{
    AmbientChoice, ChannelSpec, InputSpec, LogData, LogFitOptions, LogInput, LogModel, at_time,
    fit_log_with, inputs_over_ambient, least_correlated_rise, predict_log, read_log, score,
};
use super::{
    Programme, ThermalError, ThermalFitDoc, ThermalFitOptions, ThermalModel, ThermalPredictDoc,
    TrainingData, predict, read_model, read_programme, read_training,
};
use crate::io::{Table, write_csv_row};
use crate::limits::fmt_message_number;
use crate::report::svg::{Series, xy};

/// Options of [`run_fit`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct FitRunOptions {
    /// Orders, speed model and extra inputs tried ([`super::fit`]).
    pub fit: ThermalFitOptions,
    /// Draw one plot per height (measured and modelled drift over time).
    pub plot: bool,
    /// The name of the model file the caller writes, for the document.
    pub out: String,
}

/// What [`run_fit`] fitted.
#[derive(Debug, Clone)]
pub struct FitRun {
    /// The model.
    pub model: ThermalModel,
    /// The model as TOML text (the model file).
    pub model_toml: String,
    /// With [`FitRunOptions::plot`]: per height, the file name
    /// ([`plot_file_name`]) and the SVG text.
    pub plots: Vec<(String, String)>,
    /// The document; its `plots` are left empty for the caller, who knows
    /// where they are written.
    pub doc: ThermalFitDoc,
}

/// The file name of the plot of height `z_mm`: `drift_z{z}.svg`.
pub fn plot_file_name(z_mm: f64) -> String {
    format!("drift_z{z_mm}.svg")
}

/// `mtwin thermal fit --data TRAIN.csv`: read the probing runs at `data`
/// (`t_min,speed_rpm,z_mm,drift_mm`, optional `run` and extra input
/// columns), fit one ARX model per height, and draw the plots when asked.
///
/// # Errors
/// Options out of their domain ([`ThermalError::Options`]), a bad file at
/// its line ([`ThermalError::Input`]), a height that cannot be modelled.
pub fn run_fit(data: &Path, options: &FitRunOptions) -> Result<FitRun, ThermalError> {
    options.fit.validate()?;
    let training = read_training(data, &options.fit.extra_inputs)?;
    let fit = super::fit(&training, &options.fit)?;
    let model_toml = fit
        .model
        .to_toml()
        .map_err(|e| ThermalError::Model(format!("cannot write the model: {e}")))?;
    let plots = if options.plot {
        plots(&training, &fit.model)
    } else {
        Vec::new()
    };
    let doc = ThermalFitDoc::new(&fit, &options.out, &[]);
    Ok(FitRun {
        model: fit.model,
        model_toml,
        plots,
        doc,
    })
}

/// One SVG per measured height: the measured drift (dots) and the model
/// simulated from cold with the run's own inputs (line), every run after the
/// previous one on the time axis.
fn plots(data: &TrainingData, model: &ThermalModel) -> Vec<(String, String)> {
    let period = model.period_min();
    let mut written = Vec::new();
    for (hi, h) in data.heights.iter().enumerate() {
        let mut measured = Vec::new();
        let mut modelled = Vec::new();
        let mut t0 = 0.0;
        for s in &h.series {
            let n = s.drift.len();
            let samples: Vec<Vec<f64>> = (0..n)
                .map(|k| s.inputs.iter().map(|u| u[k]).collect())
                .collect();
            let history = model.drift_history(&Programme::new(samples));
            let mut line = Vec::with_capacity(n);
            for (k, (&d, e)) in s.drift.iter().zip(&history).enumerate() {
                let t = t0 + k as f64 * period;
                measured.push((t, d * 1e3));
                line.push((t, e[hi] * 1e3));
            }
            modelled.push(line);
            t0 += n as f64 * period;
        }
        let title = format!("Thermal drift at z = {} mm", h.z_mm);
        let mut series = vec![Series {
            name: "measured".into(),
            points: measured,
            color: "#1f77b4".into(),
            markers: true,
        }];
        let runs = modelled.len();
        series.extend(modelled.into_iter().enumerate().map(|(r, points)| Series {
            name: if runs == 1 {
                "model (from cold)".into()
            } else {
                format!("model run {} (from cold)", r + 1)
            },
            points,
            color: "#d62728".into(),
            markers: false,
        }));
        let svg = xy(&title, "t (min)", "drift (µm)", &series);
        written.push((plot_file_name(h.z_mm), svg));
    }
    written
}

/// Options of [`run_predict`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct PredictRunOptions {
    /// Heights at which the drift is predicted, mm (at least one, finite).
    pub heights: Vec<f64>,
    /// The name of the `DRIFT.csv` the caller writes, for the document.
    pub out: String,
}

/// What [`run_predict`] predicted.
#[derive(Debug, Clone)]
pub struct PredictRun {
    /// The drift rows (`t_min,z_mm,drift_mm`; write them with
    /// [`super::Prediction::write_csv_to`]).
    pub prediction: super::Prediction,
    /// The document (its `warnings` are also meant for stderr).
    pub doc: ThermalPredictDoc,
}

/// `mtwin thermal predict --speed SPEED.csv`: the drift of the model at
/// `model` for the speed programme at `speed`, at `options.heights`,
/// simulated from cold.
///
/// # Errors
/// No or non-finite heights ([`ThermalError::Options`]), a bad model or
/// programme at its line ([`ThermalError::Input`]), a prediction that
/// overflows ([`ThermalError::Diverged`]: never written as inf or NaN).
pub fn run_predict(
    model: &Path,
    speed: &Path,
    options: &PredictRunOptions,
) -> Result<PredictRun, ThermalError> {
    if options.heights.is_empty() || options.heights.iter().any(|z| !z.is_finite()) {
        return Err(ThermalError::Options(
            "give at least one finite height in mm".into(),
        ));
    }
    let m = read_model(model)?;
    let programme = read_programme(speed, &m)?;
    let p = predict(&m, &programme, &options.heights);
    if let Some(r) = p.rows.iter().find(|r| r.iter().any(|v| !v.is_finite())) {
        return Err(ThermalError::Diverged(format!(
            "{}: the predicted drift overflows at t = {} min, z = {} mm (the model is unstable or \
             its coefficients too large); nothing written",
            model.display(),
            fmt_message_number(r[0]),
            fmt_message_number(r[1])
        )));
    }
    let warnings = p.warnings(&m);
    let doc = ThermalPredictDoc::new(&p, &options.heights, &options.out, warnings);
    Ok(PredictRun { prediction: p, doc })
}

/// Options of [`run_fit_log`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct LogFitRunOptions {
    /// The drift channels (at least one).
    pub channels: Vec<ChannelSpec>,
    /// The candidate inputs (at least one).
    pub inputs: Vec<InputSpec>,
    /// Model period: the log is averaged over periods of this length, min.
    pub period_min: f64,
    /// Fit on the samples before this time (min from the log's start) and
    /// score the prediction of the rest; `None`: fit on the whole log.
    pub train_until_min: Option<f64>,
    /// Orders, inputs per channel, held-out fraction, bounds.
    pub fit: LogFitOptions,
    /// Take every temperature but one over an ambient sensor
    /// ([`inputs_over_ambient`]); `None`: the inputs as given.
    pub ambient: Option<Ambient>,
    /// With [`LogFitRunOptions::ambient`]: also fit every channel on the
    /// inputs as given (the plain rises), and keep those models as members
    /// beside the ones over the ambient sensor ([`LogModel::join`]): each
    /// channel is predicted by the median of the models of both kinds
    /// (with several numbers of held-out blocks, twice as many models).
    pub also_plain: bool,
    /// The name of the model file the caller writes, for the document.
    pub out: String,
}

/// The ambient sensor of [`LogFitRunOptions::ambient`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Ambient {
    /// This input column (a temperature given as a rise).
    Column(String),
    /// The temperature least correlated with the spindle speed over the
    /// training rows ([`least_correlated_rise`]).
    LeastCorrelatedWithSpeed,
}

impl std::str::FromStr for Ambient {
    type Err = String;
    /// `auto` or a column name.
    fn from_str(s: &str) -> Result<Ambient, String> {
        match s.trim() {
            "" => Err("give an input column or `auto`".into()),
            "auto" => Ok(Ambient::LeastCorrelatedWithSpeed),
            c => Ok(Ambient::Column(c.to_string())),
        }
    }
}

impl Default for LogFitRunOptions {
    /// No channels or inputs (give them), 1-min periods, the whole log.
    fn default() -> Self {
        LogFitRunOptions {
            channels: Vec::new(),
            inputs: Vec::new(),
            period_min: 1.0,
            train_until_min: None,
            fit: LogFitOptions::default(),
            ambient: None,
            also_plain: false,
            out: String::new(),
        }
    }
}

impl LogFitRunOptions {
    /// Checks the options before any file is read: channels and inputs
    /// given, each column once, a positive period and training time, and
    /// the number of candidate fits ([`LogFitOptions::validate`]).
    pub fn validate(&self) -> Result<(), ThermalError> {
        let bad = |m: String| Err(ThermalError::Options(m));
        if self.channels.is_empty() {
            return bad("give at least one drift channel".into());
        }
        if self.inputs.is_empty() {
            return bad("give at least one input column".into());
        }
        let mut names: Vec<String> = self.channels.iter().map(|c| c.column.clone()).collect();
        names.extend(self.inputs.iter().map(InputSpec::name));
        for (i, n) in names.iter().enumerate() {
            if names[..i].contains(n) {
                return bad(format!("column `{n}` is named twice"));
            }
        }
        if let Some(Ambient::Column(a)) = &self.ambient {
            inputs_over_ambient(&self.inputs, a).map_err(ThermalError::Options)?;
        }
        if self.also_plain && self.ambient.is_none() {
            return bad(
                "the models of the plain rises are kept beside those over an ambient sensor: give the ambient sensor too"
                    .into(),
            );
        }
        if !(self.period_min.is_finite() && self.period_min > 0.0) {
            return bad(format!(
                "the model period must be > 0 min, not {}",
                fmt_message_number(self.period_min)
            ));
        }
        if let Some(t) = self.train_until_min
            && !(t.is_finite() && t > 0.0)
        {
            return bad(format!(
                "the training time must be > 0 min, not {}",
                fmt_message_number(t)
            ));
        }
        self.fit
            .validate(self.channels.len() * self.kinds(), self.inputs.len())
            .map(|_| ())
    }

    /// Kinds of candidate inputs each channel is fitted with: 2 with
    /// [`LogFitRunOptions::also_plain`] (over the ambient sensor and plain), else 1.
    fn kinds(&self) -> usize {
        if self.also_plain && self.ambient.is_some() {
            2
        } else {
            1
        }
    }
}

/// `(na, nb)` of an ARX model's coefficients `a = [1, a_1, …]` and `b` per
/// input (one `nb` for all inputs; 0 without inputs).
fn orders(a: &[f64], b: &[Vec<f64>]) -> (usize, usize) {
    (
        a.len().saturating_sub(1),
        b.first().map_or(0, |b| b.len().saturating_sub(1)),
    )
}

/// Where [`run_fit_log`] is: channel `channel` of `channels`, after forward
/// selection step `step` (`None`: the channel is finished). With several
/// numbers of held-out blocks ([`LogFitOptions::ensemble_folds`]) the
/// channels are fitted once per number, and `channel` and `channels` count
/// every pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LogFitProgress {
    /// Index of the channel being fitted.
    pub channel: usize,
    /// Number of channels.
    pub channels: usize,
    /// Selection steps done on this channel (the length of its selection
    /// path so far: with the exchange search it may pass `max_steps`);
    /// `None` when it is finished.
    pub step: Option<usize>,
    /// Most forward steps a channel can take (`max_inputs`, at most the inputs).
    pub max_steps: usize,
}

/// What [`run_fit_log`] fitted.
#[derive(Debug, Clone)]
pub struct LogFitRun {
    /// The model.
    pub model: LogModel,
    /// The model as TOML text (the model file).
    pub model_toml: String,
    /// The document (its `notes` and `warnings` are also meant for stderr).
    pub doc: ThermalLogFitDoc,
}

/// `mtwin thermal fit --log LOG.csv`: read the wide log at `log`, average
/// it onto the period grid, choose and fit one model per drift channel by
/// held-out simulation error ([`super::log`]), and with
/// `train_until_min` score the prediction of the rest of the log from its
/// start. `progress` is called after every forward selection step and
/// channel.
///
/// # Errors
/// Options out of their domain or too many candidate fits
/// ([`ThermalError::Options`], before the file is read), a bad log at its
/// line ([`ThermalError::Input`]), too few samples, a channel without an
/// admissible model.
pub fn run_fit_log(
    log: &Path,
    options: &LogFitRunOptions,
    progress: &mut dyn FnMut(LogFitProgress),
) -> Result<LogFitRun, ThermalError> {
    options.validate()?;
    let table = Table::read(log)?;
    let ambient = match &options.ambient {
        None => None,
        Some(Ambient::Column(c)) => Some(AmbientChoice {
            column: c.clone(),
            against: String::new(),
            correlations: Vec::new(),
            rows: 0,
        }),
        Some(Ambient::LeastCorrelatedWithSpeed) => Some(least_correlated_rise(
            &table,
            &options.inputs,
            options.train_until_min,
        )?),
    };
    let inputs = match &ambient {
        Some(a) => {
            inputs_over_ambient(&options.inputs, &a.column).map_err(ThermalError::Options)?
        }
        None => options.inputs.clone(),
    };
    let mut data = read_log(&table, &options.channels, &inputs, options.period_min)?;
    let n_train = options
        .train_until_min
        .map(|t| ((t / data.period_min).floor() as usize).min(data.len()));
    let per_kind = options.channels.len() * options.fit.fold_counts().count();
    let channels = per_kind * options.kinds();
    let max_steps = options.fit.max_inputs.min(options.inputs.len());
    let mut fit = fit_log_with(
        &data,
        &options.channels,
        &inputs,
        n_train,
        &options.fit,
        &mut |channel, step| {
            progress(LogFitProgress {
                channel,
                channels,
                step,
                max_steps,
            })
        },
    )?;
    if options.kinds() == 2 {
        // The plain rises' models join those over the ambient sensor as
        // members; the log is read again with the inputs of both.
        let plain = read_log(
            &table,
            &options.channels,
            &options.inputs,
            options.period_min,
        )?;
        let other = fit_log_with(
            &plain,
            &options.channels,
            &options.inputs,
            n_train,
            &options.fit,
            &mut |channel, step| {
                progress(LogFitProgress {
                    channel: per_kind + channel,
                    channels,
                    step,
                    max_steps,
                })
            },
        )?;
        fit.model = fit.model.join(&other.model, options.fit.folds)?;
        let joined: Vec<InputSpec> = fit.model.inputs.iter().map(LogInput::spec).collect();
        data = read_log(&table, &options.channels, &joined, options.period_min)?;
        fit.warnings.extend(
            other
                .warnings
                .into_iter()
                .map(|w| format!("with the plain rises: {w}")),
        );
    }
    let test = match n_train {
        Some(n) if n < data.len() => Some(LogTestDoc {
            from_min: n as f64 * data.period_min,
            samples: data.len() - n,
            channels: score(&fit.model, &data, n)?,
        }),
        _ => None,
    };
    let model_toml = fit.model.to_toml()?;
    let doc = ThermalLogFitDoc {
        out: options.out.clone(),
        period_min: data.period_min,
        samples: data.len(),
        training_samples: fit.training_samples,
        heldout_samples: fit.heldout_samples,
        folds: fit.folds,
        ensemble_folds: options.fit.ensemble_folds.clone(),
        also_plain: options.kinds() == 2,
        search: options.fit.search,
        inputs: fit.model.inputs.clone(),
        ambient,
        channels: fit
            .model
            .channels
            .iter()
            .zip(&fit.selection)
            .map(|(c, path)| LogChannelDoc {
                column: c.channel.column.clone(),
                unit: c.channel.unit,
                axis: c.channel.axis,
                na: orders(&c.a, &c.b).0,
                nb: orders(&c.a, &c.b).1,
                inputs: c
                    .inputs
                    .iter()
                    .map(|&i| fit.model.inputs[i].name())
                    .collect(),
                heldout_rms_mm: c.heldout_rms_mm,
                heldout_drift_rms_mm: c.heldout_drift_rms_mm,
                training_rms_mm: c.training_rms_mm,
                output_error: c.output_error,
                selection: path
                    .iter()
                    .map(|(input, rms)| LogSelectionStepDoc {
                        input: input.clone(),
                        heldout_rms_mm: *rms,
                    })
                    .collect(),
                members: c
                    .members
                    .iter()
                    .map(|m| LogMemberDoc {
                        folds: m.folds,
                        na: orders(&m.a, &m.b).0,
                        nb: orders(&m.a, &m.b).1,
                        inputs: m
                            .inputs
                            .iter()
                            .map(|&i| fit.model.inputs[i].name())
                            .collect(),
                        heldout_rms_mm: m.heldout_rms_mm,
                        training_rms_mm: m.training_rms_mm,
                        output_error: m.output_error,
                    })
                    .collect(),
            })
            .collect(),
        test,
        notes: fit.notes.clone(),
        warnings: fit.warnings.clone(),
    };
    Ok(LogFitRun {
        model: fit.model,
        model_toml,
        doc,
    })
}

/// Options of [`run_predict_log`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct LogPredictRunOptions {
    /// The name of the CSV the caller writes, for the document.
    pub out: String,
}

/// What [`run_predict_log`] predicted.
#[derive(Debug, Clone)]
pub struct LogPredictRun {
    /// The header: `t_min`, then one column per drift channel.
    pub columns: Vec<String>,
    /// One row per period: its centre (min since the log's start), then
    /// each channel's predicted value in its unit.
    pub rows: Vec<Vec<f64>>,
    /// The document (its `notes` are also meant for stderr).
    pub doc: ThermalLogPredictDoc,
}

impl LogPredictRun {
    /// The prediction as CSV text: [`LogPredictRun::columns`], then the rows.
    pub fn write_csv_to(&self, w: &mut dyn Write) -> std::io::Result<()> {
        writeln!(w, "{}", self.columns.join(","))?;
        for r in &self.rows {
            write_csv_row(&mut *w, r)?;
        }
        Ok(())
    }
}

/// `mtwin thermal predict --log LOG.csv`: the drift channels of the model at
/// `model` (from [`run_fit_log`]) predicted from the start of the log at
/// `log` with its input columns alone (from rest). A drift column present
/// in the log gives the prediction's base (its first period mean) and is
/// scored (MAE over its rows); an absent one is predicted from 0.
///
/// # Errors
/// A bad model or log at its line ([`ThermalError::Input`]), a prediction
/// that overflows ([`ThermalError::Diverged`]).
pub fn run_predict_log(
    model: &Path,
    log: &Path,
    options: &LogPredictRunOptions,
) -> Result<LogPredictRun, ThermalError> {
    let m = LogModel::read(model)?;
    let channels: Vec<ChannelSpec> = m.channels.iter().map(|c| c.channel.clone()).collect();
    let inputs: Vec<InputSpec> = m.inputs.iter().map(LogInput::spec).collect();
    let table = Table::read(log)?;
    let present: Vec<ChannelSpec> = channels
        .iter()
        .filter(|c| table.column(&c.column).is_some())
        .cloned()
        .collect();
    let data = read_log(&table, &present, &inputs, m.period_min)?;
    // Per model channel: its measured grid series and raw values, if present.
    let measured: Vec<Option<usize>> = channels
        .iter()
        .map(|c| present.iter().position(|p| p == c))
        .collect();
    let full = LogData {
        channels: measured
            .iter()
            .map(|p| p.map_or(vec![0.0], |j| data.channels[j].clone()))
            .collect(),
        ..data.clone()
    };
    let pred = predict_log(&m, &full)?;
    if pred.iter().flatten().any(|v| !v.is_finite()) {
        return Err(ThermalError::Diverged(format!(
            "{}: the predicted drift overflows (the model is unstable or its coefficients too large); \
             nothing written",
            model.display()
        )));
    }
    let samples = data.len();
    let mut columns = vec![crate::io::columns::T_MIN.to_string()];
    columns.extend(channels.iter().map(|c| c.column.clone()));
    let rows = (0..samples)
        .map(|k| {
            let mut row = vec![(k as f64 + 0.5) * m.period_min];
            row.extend(pred.iter().map(|p| p[k]));
            row
        })
        .collect();
    let channel_docs = channels
        .iter()
        .zip(&pred)
        .zip(&measured)
        .map(|((c, p), j)| {
            let base = p.first().copied().unwrap_or(0.0);
            let largest = p.iter().fold(0.0f64, |a, v| a.max((v - base).abs()));
            let mae = j.and_then(|j| {
                let (mut s, mut n) = (0.0, 0usize);
                for (t, values) in &data.raw {
                    let v = values[j];
                    if v.is_finite() {
                        s += (at_time(p, m.period_min, *t) - v).abs();
                        n += 1;
                    }
                }
                (n > 0).then(|| s / n as f64)
            });
            LogPredictedChannelDoc {
                column: c.column.clone(),
                unit: c.unit,
                axis: c.axis,
                largest_abs_drift: largest,
                final_drift: p.last().copied().unwrap_or(0.0) - base,
                mae,
            }
        })
        .collect();
    let doc = ThermalLogPredictDoc {
        out: options.out.clone(),
        period_min: m.period_min,
        samples,
        channels: channel_docs,
        notes: data.notes.clone(),
    };
    Ok(LogPredictRun { columns, rows, doc })
}

/// Whether the model file text `text` is a log model (`thermal fit --log`:
/// a `channels` array at its root) rather than a height model (`heights`).
/// Text that is not TOML is neither: reading it as a height model reports
/// the error at its line.
pub fn is_log_model(text: &str) -> bool {
    text.parse::<toml_edit::DocumentMut>()
        .is_ok_and(|d| d.get("channels").is_some() && d.get("heights").is_none())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options() -> LogFitRunOptions {
        LogFitRunOptions {
            channels: vec![ChannelSpec::parse("d_um:Z").unwrap()],
            inputs: vec![
                InputSpec::parse("speed_rpm").unwrap(),
                InputSpec::parse("t1_c").unwrap(),
            ],
            ..LogFitRunOptions::default()
        }
    }

    #[test]
    fn log_fit_options_are_checked_before_any_file_is_read() {
        assert!(options().validate().is_ok());
        let refused = |o: LogFitRunOptions, what: &str| {
            let e = o.validate().unwrap_err().to_string();
            assert!(e.contains(what), "{e}");
            // The file is never opened: a missing one is not the error.
            let e = run_fit_log(Path::new("/nonexistent/LOG.csv"), &o, &mut |_| {})
                .unwrap_err()
                .to_string();
            assert!(e.contains(what), "{e}");
        };
        let mut o = options();
        o.channels.clear();
        refused(o, "drift channel");
        let mut o = options();
        o.inputs.clear();
        refused(o, "input column");
        let mut o = options();
        o.inputs.push(InputSpec::parse("d_um").unwrap());
        refused(o, "`d_um` is named twice");
        let mut o = options();
        o.period_min = 0.0;
        refused(o, "period");
        let mut o = options();
        o.train_until_min = Some(f64::NAN);
        refused(o, "training time");
        let mut o = options();
        o.fit.max_inputs = 0;
        refused(o, "at least one input");
    }

    #[test]
    fn log_models_are_told_from_height_models() {
        assert!(is_log_model(
            "period_min = 1.0\n[[channels]]\ninputs = []\n"
        ));
        assert!(!is_log_model(
            "period_min = 10.0\n[[heights]]\nz_mm = 0.0\n"
        ));
        assert!(!is_log_model("[[channels]\n"));
    }

    #[test]
    fn predict_refuses_missing_or_non_finite_heights_before_reading() {
        let mut o = PredictRunOptions::default();
        let none = Path::new("/nonexistent/x.csv");
        for heights in [vec![], vec![f64::NAN]] {
            o.heights = heights;
            let e = run_predict(none, none, &o).unwrap_err().to_string();
            assert!(e.contains("height"), "{e}");
        }
    }
}
