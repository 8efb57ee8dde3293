//! The fitted log model: its inputs and scales, one ARX model per channel
//! (with the members of further cuts, predicted by their median), and its
//! model file.

use super::spec::{ChannelSpec, InputSpec, input_name};
use crate::io::{Diagnostic, Diagnostics};
use crate::methods::thermal::ThermalError;
use crate::sysid::Arx;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One input of a log model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogInput {
    /// Column name.
    pub column: String,
    /// The change since the first sample is used.
    pub rise: bool,
    /// The square of the value is used (before the scale).
    #[serde(default)]
    pub square: bool,
    /// The difference from this column is used ([`InputSpec::over`]);
    /// absent in model files written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub over: Option<String>,
    /// The model sees the input divided by this (its largest training magnitude).
    pub scale: f64,
}

impl LogInput {
    /// The name the input is known by ([`InputSpec::name`]).
    pub fn name(&self) -> String {
        input_name(&self.column, self.square, self.over.as_deref())
    }

    /// The log column(s) this input reads and how ([`read_log`](super::read_log)).
    pub fn spec(&self) -> InputSpec {
        InputSpec {
            column: self.column.clone(),
            rise: self.rise,
            square: self.square,
            over: self.over.clone(),
        }
    }
}

/// The model of one drift channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelModel {
    /// The channel.
    pub channel: ChannelSpec,
    /// Indices into [`LogModel::inputs`] of the inputs this channel uses.
    pub inputs: Vec<usize>,
    /// `[1, a_1, …]` (empty-tailed `[1]` for a model without poles).
    pub a: Vec<f64>,
    /// `b` per used input (mm per scaled input unit), delay `nk = 1`.
    pub b: Vec<Vec<f64>>,
    /// Simulation RMS on the held-out block the structure was chosen by, mm.
    pub heldout_rms_mm: f64,
    /// RMS of the drift on that block, mm.
    pub heldout_drift_rms_mm: f64,
    /// Simulation RMS over all training samples of the final model, mm.
    pub training_rms_mm: f64,
    /// True when output-error refinement replaced the least-squares estimate.
    pub output_error: bool,
    /// The channel's value at the cold start minus its first period mean,
    /// mm, estimated with the model ([`LogFitOptions::start_offset`](super::LogFitOptions::start_offset); 0
    /// without): the first period mean is one noisy measurement, so the
    /// measured channel is predicted as that mean plus this offset plus the
    /// simulated drift ([`predict_log`](super::predict_log)). The drift itself (what a
    /// compensation corrects) is [`LogModel::simulate`], without it.
    #[serde(default)]
    pub start_offset_mm: f64,
    /// Other models of this channel, each chosen with another number of
    /// held-out blocks ([`LogFitOptions::ensemble_folds`](super::LogFitOptions::ensemble_folds)) or on
    /// other candidate inputs ([`LogModel::join`]); empty for a single model. With members, the channel's drift is the per-sample
    /// median of this model's and its members' simulations
    /// ([`ChannelModel::simulate`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub members: Vec<ChannelMember>,
}

/// Another model of a channel, chosen by the same search with another
/// number of held-out blocks ([`LogFitOptions::ensemble_folds`](super::LogFitOptions::ensemble_folds)) or
/// on other candidate inputs ([`LogModel::join`]); its fields mean what
/// those of [`ChannelModel`] do.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelMember {
    /// Held-out blocks of the cross-validation it was chosen by.
    pub folds: usize,
    /// Indices into [`LogModel::inputs`] of the inputs it uses.
    pub inputs: Vec<usize>,
    /// `[1, a_1, …]`.
    pub a: Vec<f64>,
    /// `b` per used input (mm per scaled input unit), delay `nk = 1`.
    pub b: Vec<Vec<f64>>,
    /// Simulation RMS on the held-out blocks it was chosen by, mm.
    pub heldout_rms_mm: f64,
    /// Simulation RMS over all training samples, mm.
    pub training_rms_mm: f64,
    /// True when output-error refinement replaced the least-squares estimate.
    pub output_error: bool,
    /// Its start offset, mm ([`ChannelModel::start_offset_mm`]).
    #[serde(default)]
    pub start_offset_mm: f64,
}

impl ChannelMember {
    /// `model` (a channel's model fitted with `folds` held-out blocks) as a
    /// member of another model of the channel; its own members are dropped.
    pub fn from_model(folds: usize, model: &ChannelModel) -> ChannelMember {
        ChannelMember {
            folds,
            inputs: model.inputs.clone(),
            a: model.a.clone(),
            b: model.b.clone(),
            heldout_rms_mm: model.heldout_rms_mm,
            training_rms_mm: model.training_rms_mm,
            output_error: model.output_error,
            start_offset_mm: model.start_offset_mm,
        }
    }
}

/// The ARX model of coefficients `a`, `b` (delay 1) of channel `column`.
fn arx_of(column: &str, a: &[f64], b: &[Vec<f64>]) -> Result<Arx, ThermalError> {
    Arx::new(a.to_vec(), b.iter().map(|b| (b.clone(), 1)).collect())
        .map_err(|e| ThermalError::Model(format!("channel `{column}`: {e}")))
}

/// One model of a channel: its inputs, ARX model and start offset (mm).
struct MemberView<'a> {
    inputs: &'a [usize],
    a: &'a [f64],
    b: &'a [Vec<f64>],
    start_offset_mm: f64,
}

impl ChannelModel {
    /// The ARX model (inputs in the order of [`ChannelModel::inputs`]).
    pub fn arx(&self) -> Result<Arx, ThermalError> {
        arx_of(&self.channel.column, &self.a, &self.b)
    }

    /// The ARX model of this model and of each member, in that order.
    pub fn arx_models(&self) -> Result<Vec<Arx>, ThermalError> {
        self.views()
            .map(|m| arx_of(&self.channel.column, m.a, m.b))
            .collect()
    }

    /// Every input this model or a member uses, ascending.
    pub fn used_inputs(&self) -> Vec<usize> {
        let mut used: Vec<usize> = self
            .views()
            .flat_map(|m| m.inputs.iter().copied())
            .collect();
        used.sort_unstable();
        used.dedup();
        used
    }

    fn views(&self) -> impl Iterator<Item = MemberView<'_>> {
        std::iter::once(MemberView {
            inputs: &self.inputs,
            a: &self.a,
            b: &self.b,
            start_offset_mm: self.start_offset_mm,
        })
        .chain(self.members.iter().map(|m| MemberView {
            inputs: &m.inputs,
            a: &m.a,
            b: &m.b,
            start_offset_mm: m.start_offset_mm,
        }))
    }

    /// The channel's drift (mm since the start) simulated from rest from
    /// the scaled inputs of every model input ([`LogModel::scaled_inputs`]):
    /// the model's simulation, or with members the per-sample median of
    /// the model's and the members' (the mean of the middle two for an
    /// even count). With `start_offset`, each model's start offset is
    /// added from the second sample on before the median is taken.
    pub fn simulate(
        &self,
        scaled_inputs: &[Vec<f64>],
        start_offset: bool,
    ) -> Result<Vec<f64>, ThermalError> {
        let n = scaled_inputs.first().map_or(0, Vec::len);
        let mut runs = self.simulate_each(scaled_inputs, start_offset)?;
        if runs.len() == 1 {
            return Ok(runs.pop().unwrap_or_default());
        }
        let mut at = vec![0.0; runs.len()];
        Ok((0..n)
            .map(|k| {
                for (v, r) in at.iter_mut().zip(&runs) {
                    *v = r[k];
                }
                median(&mut at)
            })
            .collect())
    }

    /// [`ChannelModel::simulate`] of this model and of each member apart,
    /// in that order (the spread of a channel's models).
    pub fn simulate_each(
        &self,
        scaled_inputs: &[Vec<f64>],
        start_offset: bool,
    ) -> Result<Vec<Vec<f64>>, ThermalError> {
        let n = scaled_inputs.first().map_or(0, Vec::len);
        let mut runs = Vec::with_capacity(1 + self.members.len());
        for m in self.views() {
            let mut sim = if m.inputs.is_empty() {
                vec![0.0; n]
            } else {
                let u: Vec<&[f64]> = m
                    .inputs
                    .iter()
                    .map(|&i| scaled_inputs[i].as_slice())
                    .collect();
                arx_of(&self.channel.column, m.a, m.b)?
                    .simulate(&u)
                    .map_err(|e| {
                        ThermalError::Model(format!("channel `{}`: {e}", self.channel.column))
                    })?
            };
            if start_offset {
                sim.iter_mut().skip(1).for_each(|v| *v += m.start_offset_mm);
            }
            runs.push(sim);
        }
        Ok(runs)
    }
}

/// The median of `v` (the mean of the middle two for an even count; NaN
/// sorts last). `v` is reordered.
pub(super) fn median(v: &mut [f64]) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// A thermal model of a wide log: shared inputs, one model per drift channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogModel {
    /// Sample period, min.
    pub period_min: f64,
    /// Every input any channel may use.
    pub inputs: Vec<LogInput>,
    /// One model per drift channel.
    pub channels: Vec<ChannelModel>,
}

impl LogModel {
    /// The model as TOML text.
    pub fn to_toml(&self) -> Result<String, ThermalError> {
        toml_edit::ser::to_string_pretty(self)
            .map_err(|e| ThermalError::Model(format!("cannot write the model: {e}")))
    }

    /// A model from TOML text (`path` names it in messages).
    pub fn from_toml_str(path: &Path, text: &str) -> Result<LogModel, Diagnostics> {
        let m: LogModel = toml_edit::de::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            let msg = e.message().to_string();
            match line {
                Some(l) => Diagnostic::at_line(path, l, msg),
                None => Diagnostic::whole(path, msg),
            }
        })?;
        let bad = |msg: String| -> Diagnostics { Diagnostic::whole(path, msg).into() };
        if !(m.period_min.is_finite() && m.period_min > 0.0) {
            return Err(bad("period_min must be > 0".into()));
        }
        for i in &m.inputs {
            if !(i.scale.is_finite() && i.scale > 0.0) {
                return Err(bad(format!("input `{}`: scale must be > 0", i.column)));
            }
        }
        for c in &m.channels {
            for v in c.views() {
                if v.inputs.len() != v.b.len() || v.inputs.iter().any(|&i| i >= m.inputs.len()) {
                    return Err(bad(format!(
                        "channel `{}`: `inputs` and `b` must have one entry per used input, each an index into [[inputs]]",
                        c.channel.column
                    )));
                }
            }
            c.arx_models().map_err(|e| bad(e.to_string()))?;
        }
        Ok(m)
    }

    /// Read a model file.
    pub fn read(path: &Path) -> Result<LogModel, Diagnostics> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Diagnostic::whole(path, format!("cannot read the file: {e}")))?;
        LogModel::from_toml_str(path, &text)
    }

    /// Scaled model inputs from a log's bin means (rises from its first sample).
    pub fn scaled_inputs(&self, log_inputs: &[Vec<f64>]) -> Vec<Vec<f64>> {
        self.inputs
            .iter()
            .zip(log_inputs)
            .map(|(spec, u)| scaled(u, spec.rise, spec.square, spec.scale))
            .collect()
    }

    /// This model with the models of `other` (another fit of the same
    /// channels on the same training samples and period, e.g. with other
    /// candidate inputs) added to each channel as members: `other`'s model
    /// of the channel, chosen with `other_folds` held-out blocks, then its
    /// own members. Inputs the two share (the same column, transform and
    /// scale) are kept once; the others are appended and the members'
    /// indices mapped to them. Each channel is then predicted by the median
    /// of the models of both ([`ChannelModel::simulate`]).
    ///
    /// # Errors
    /// Another period, or a channel of this model that `other` lacks.
    pub fn join(mut self, other: &LogModel, other_folds: usize) -> Result<LogModel, ThermalError> {
        if self.period_min != other.period_min {
            return Err(ThermalError::Model(format!(
                "models of {} and {} min periods cannot be joined",
                self.period_min, other.period_min
            )));
        }
        let map: Vec<usize> = other
            .inputs
            .iter()
            .map(|input| match self.inputs.iter().position(|i| i == input) {
                Some(k) => k,
                None => {
                    self.inputs.push(input.clone());
                    self.inputs.len() - 1
                }
            })
            .collect();
        for c in &mut self.channels {
            let Some(o) = other.channels.iter().find(|o| o.channel == c.channel) else {
                return Err(ThermalError::Model(format!(
                    "channel `{}` is missing from the model to join",
                    c.channel.column
                )));
            };
            let first = ChannelMember::from_model(other_folds, o);
            for mut m in std::iter::once(first).chain(o.members.iter().cloned()) {
                m.inputs.iter_mut().for_each(|i| *i = map[*i]);
                c.members.push(m);
            }
        }
        Ok(self)
    }

    /// The drift of every channel (mm, since the start), simulated from rest
    /// from the scaled inputs alone.
    /// A channel with members is the per-sample median of its models
    /// ([`ChannelModel::simulate`]).
    pub fn simulate(&self, scaled_inputs: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, ThermalError> {
        self.channels
            .iter()
            .map(|c| c.simulate(scaled_inputs, false))
            .collect()
    }
}

pub(super) fn scaled(u: &[f64], rise: bool, square: bool, scale: f64) -> Vec<f64> {
    let f = |v: f64| if square { v * v } else { v };
    let base = if rise {
        u.first().copied().map_or(0.0, f)
    } else {
        0.0
    };
    u.iter().map(|&v| (f(v) - base) / scale).collect()
}
