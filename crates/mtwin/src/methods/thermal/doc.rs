//! `mtwin thermal fit`, `predict`, `simulate` and `compensate` results as
//! typed documents ([`ThermalFitDoc`], [`ThermalPredictDoc`],
//! [`ThermalSimulateDoc`], [`ThermalCompensateDoc`]): serialised for
//! `--format json`, displayed for people.

use serde::{Deserialize, Serialize};

use super::{Prediction, SimulatedData, SpeedModelChoice, ThermalFit};
use crate::sysid::{GridRowDoc, OrdersDoc, grid_text};

/// `mtwin thermal simulate`: the synthetic training data written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalSimulateDoc {
    /// Duration covered (min): last minus first time.
    pub duration_min: f64,
    /// Heights simulated (mm).
    pub heights: Vec<f64>,
    /// Largest |drift| in the data (mm).
    pub largest_drift_mm: f64,
    /// Standard deviation of the noise added (mm).
    pub noise: f64,
    /// The CSV written.
    pub out: String,
    /// Rows written.
    pub rows: usize,
    /// Seed of the noise.
    pub seed: u64,
}

impl ThermalSimulateDoc {
    /// The document of `data` simulated at `heights` and written to `out`.
    pub fn new(data: &SimulatedData, heights: &[f64], noise: f64, seed: u64, out: &str) -> Self {
        let t = data.rows.iter().map(|r| r.0);
        let (lo, hi) = t.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
        ThermalSimulateDoc {
            duration_min: if data.rows.is_empty() { 0.0 } else { hi - lo },
            heights: heights.to_vec(),
            largest_drift_mm: data.rows.iter().map(|r| r.3.abs()).fold(0.0, f64::max),
            noise,
            out: out.to_string(),
            rows: data.rows.len(),
            seed,
        }
    }
}

/// The file is announced as a note on stderr: no human text on stdout.
impl std::fmt::Display for ThermalSimulateDoc {
    fn fmt(&self, _: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_document_summarises_the_rows_and_round_trips() {
        let data = SimulatedData {
            input_names: vec!["speed_rpm".into()],
            rows: vec![
                (0.0, vec![1000.0], 0.0, 0.001),
                (1.0, vec![1000.0], 0.0, -0.004),
                (2.5, vec![1000.0], 0.0, 0.002),
            ],
        };
        let d = ThermalSimulateDoc::new(&data, &[0.0], 0.0005, 3, "train.csv");
        assert_eq!(
            (d.rows, d.duration_min, d.largest_drift_mm),
            (3, 2.5, 0.004)
        );
        let back: ThermalSimulateDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
    }
}

/// `mtwin thermal compensate`: what the thermal compensation of a program changed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalCompensateDoc {
    /// Blocks read.
    pub blocks: u64,
    /// Z blocks whose value changed.
    pub blocks_changed: usize,
    /// First time a block changed (min), if any.
    pub changed_from_min: Option<f64>,
    /// Last time a block changed (min), if any.
    pub changed_to_min: Option<f64>,
    /// Estimated duration of the program (min).
    pub duration_min: f64,
    /// Largest Z correction (µm).
    pub max_correction_um: f64,
    /// Things the user should know.
    pub notes: Vec<String>,
    /// The program written.
    pub out: String,
    /// Whether the program's own spindle speeds drove the prediction.
    pub spindle_used: bool,
    /// Blocks that program Z.
    pub z_blocks: usize,
    /// With a log model: per corrected axis, its channel and what changed
    /// (then `blocks_changed` counts blocks with any word changed and
    /// `max_correction_um` is the largest over the axes). Empty (and not
    /// written) with a height model.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub axes: Vec<CompensateAxisDoc>,
}

/// One axis of a compensation with a log model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompensateAxisDoc {
    /// `X`, `Y` or `Z`.
    pub axis: String,
    /// The drift channel (column) the axis is corrected by.
    pub channel: String,
    /// Blocks with a word of the axis.
    pub blocks: usize,
    /// Those whose word changed.
    pub blocks_changed: usize,
    /// Largest correction on the axis (µm).
    pub max_correction_um: f64,
    /// First time a word of the axis changed (min), if any.
    pub changed_from_min: Option<f64>,
    /// Last time a word of the axis changed (min), if any.
    pub changed_to_min: Option<f64>,
}

fn span_text(from: Option<f64>, to: Option<f64>) -> String {
    match (from, to) {
        (Some(a), Some(b)) => format!(", changes from {a:.1} to {b:.1} min"),
        _ => String::new(),
    }
}

impl std::fmt::Display for ThermalCompensateDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let span = span_text(self.changed_from_min, self.changed_to_min);
        if !self.axes.is_empty() {
            writeln!(
                f,
                "{} blocks, estimated {:.1} min → {}",
                self.blocks, self.duration_min, self.out
            )?;
            for a in &self.axes {
                writeln!(
                    f,
                    "{} by {}: {} of {} {} blocks changed, largest correction {:.2} µm{}",
                    a.axis,
                    a.channel,
                    a.blocks_changed,
                    a.blocks,
                    a.axis,
                    a.max_correction_um,
                    span_text(a.changed_from_min, a.changed_to_min)
                )?;
            }
            return Ok(());
        }
        writeln!(
            f,
            "{} blocks, estimated {:.1} min → {}\n{} of {} Z blocks changed, largest correction {:.2} µm{}",
            self.blocks,
            self.duration_min,
            self.out,
            self.blocks_changed,
            self.z_blocks,
            self.max_correction_um,
            span
        )
    }
}

#[cfg(test)]
mod compensate_tests {
    use super::*;

    #[test]
    fn the_compensate_document_round_trips_and_prints_the_span() {
        let d = ThermalCompensateDoc {
            blocks: 10,
            blocks_changed: 3,
            changed_from_min: Some(1.0),
            changed_to_min: Some(2.5),
            duration_min: 4.0,
            max_correction_um: 12.5,
            notes: vec![],
            out: "p.ngc".into(),
            spindle_used: true,
            z_blocks: 4,
            axes: Vec::new(),
        };
        assert!(!serde_json::to_string(&d).unwrap().contains("axes"));
        let back: ThermalCompensateDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        assert_eq!(
            d.to_string(),
            "10 blocks, estimated 4.0 min → p.ngc\n3 of 4 Z blocks changed, largest correction 12.50 µm, changes from 1.0 to 2.5 min\n"
        );
        let x = CompensateAxisDoc {
            axis: "X".into(),
            channel: "dx_um".into(),
            blocks: 5,
            blocks_changed: 2,
            max_correction_um: 3.25,
            changed_from_min: Some(1.0),
            changed_to_min: Some(2.0),
        };
        let d = ThermalCompensateDoc { axes: vec![x], ..d };
        let back: ThermalCompensateDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        assert_eq!(
            d.to_string(),
            "10 blocks, estimated 4.0 min → p.ngc\nX by dx_um: 2 of 5 X blocks changed, largest correction 3.25 µm, changes from 1.0 to 2.0 min\n"
        );
    }
}

/// One input channel of a thermal model: the model sees `(value / scale)^power`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputChannelDoc {
    /// Column name (`speed_rpm` for the spindle speed).
    pub name: String,
    /// Power of the scaled value (1: linear).
    pub power: u32,
    /// Scale (the unit of the column).
    pub scale: f64,
}

/// The held-out comparison of the linear and quadratic speed models.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpeedModelDoc {
    /// `linear` or `quadratic`.
    pub chosen: String,
    /// Held-out runs.
    pub folds: usize,
    /// Held-out RMS of the linear model (mm).
    pub linear_rms_mm: f64,
    /// Held-out RMS of the quadratic model (mm); `None` when it could not be fitted on every fold.
    pub quadratic_rms_mm: Option<f64>,
}

impl From<&SpeedModelChoice> for SpeedModelDoc {
    fn from(c: &SpeedModelChoice) -> Self {
        SpeedModelDoc {
            chosen: if c.quadratic { "quadratic" } else { "linear" }.into(),
            folds: c.folds,
            linear_rms_mm: c.linear_rms_mm,
            quadratic_rms_mm: c.quadratic_rms_mm,
        }
    }
}

impl SpeedModelDoc {
    /// The comparison it records.
    pub fn choice(&self) -> SpeedModelChoice {
        SpeedModelChoice {
            folds: self.folds,
            linear_rms_mm: self.linear_rms_mm,
            quadratic_rms_mm: self.quadratic_rms_mm,
            quadratic: self.chosen == "quadratic",
        }
    }
}

/// The drift model of one measured height: `a` (with `a[0] = 1`) and, per
/// input, `b` after a delay of `nk` samples, with standard uncertainties and
/// fit statistics (drift in mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalHeightDoc {
    /// Denominator coefficients, `a[0] = 1`.
    pub a: Vec<f64>,
    /// Standard uncertainties of `a[1..]`.
    pub a_std: Vec<f64>,
    /// Akaike's information criterion.
    pub aic: f64,
    /// Numerator coefficients, per input.
    pub b: Vec<Vec<f64>>,
    /// Standard uncertainties of `b`, per input.
    pub b_std: Vec<Vec<f64>>,
    /// Final prediction error (mm²).
    pub fpe: f64,
    /// Every structure tried.
    pub grid: Vec<GridRowDoc>,
    /// Input delays (samples), per input.
    pub nk: Vec<usize>,
    /// One-step-ahead prediction RMS (mm).
    pub one_step_rms_mm: f64,
    /// The chosen orders.
    pub orders: OrdersDoc,
    /// Free parameters.
    pub params: usize,
    /// Regression rows.
    pub samples: usize,
    /// Simulation RMS from cold (mm).
    pub simulation_rms_mm: f64,
    /// Largest pole modulus.
    pub spectral_radius: f64,
    /// All poles inside the unit circle.
    pub stable: bool,
    /// The height (mm).
    pub z_mm: f64,
}

/// `mtwin thermal fit`: the fitted drift model and how its orders were chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalFitDoc {
    /// One model per height, ascending.
    pub heights: Vec<ThermalHeightDoc>,
    /// The input channels.
    pub inputs: Vec<InputChannelDoc>,
    /// The model file written.
    pub out: String,
    /// Sample period (min).
    pub period_min: f64,
    /// Plot files written.
    pub plots: Vec<String>,
    /// Runs in the data.
    pub runs: usize,
    /// The speed-model comparison, when `auto` chose.
    pub speed_model: Option<SpeedModelDoc>,
    /// Reservations about the model.
    pub warnings: Vec<String>,
}

impl ThermalFitDoc {
    /// The document of `fit`, written to `out`, with the plot files `plots`.
    pub fn new(fit: &ThermalFit, out: &str, plots: &[String]) -> Self {
        let heights = fit
            .model
            .heights()
            .iter()
            .zip(&fit.heights)
            .map(|(h, r)| {
                let m = &h.model;
                let n = m.n_inputs();
                let f = &r.selection.fit;
                let s = &f.stats;
                ThermalHeightDoc {
                    a: m.a().to_vec(),
                    a_std: f.std_a(),
                    aic: s.aic,
                    b: (0..n).map(|i| m.b(i).to_vec()).collect(),
                    b_std: (0..n).map(|i| f.std_b(i)).collect(),
                    fpe: s.fpe,
                    grid: r.selection.table_doc(),
                    nk: (0..n).map(|i| m.nk(i)).collect(),
                    one_step_rms_mm: s.one_step_rms,
                    orders: OrdersDoc::from(&m.orders()),
                    params: s.params,
                    samples: s.samples,
                    simulation_rms_mm: s.simulation_rms,
                    spectral_radius: s.spectral_radius,
                    stable: m.stability().is_stable(),
                    z_mm: h.z_mm,
                }
            })
            .collect();
        ThermalFitDoc {
            heights,
            inputs: fit
                .model
                .inputs()
                .iter()
                .map(|c| InputChannelDoc {
                    name: c.name.clone(),
                    power: c.power,
                    scale: c.scale,
                })
                .collect(),
            out: out.to_string(),
            period_min: fit.model.period_min(),
            plots: plots.to_vec(),
            runs: fit.runs,
            speed_model: fit.speed_model.as_ref().map(SpeedModelDoc::from),
            warnings: fit.warnings.clone(),
        }
    }
}

/// The summary, the inputs, the speed-model choice, then per height its
/// chosen orders and statistics (µm) followed by the order grid. The
/// warnings go to stderr.
impl std::fmt::Display for ThermalFitDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} height(s), {} run(s), sample period {} min → {}",
            self.heights.len(),
            self.runs,
            self.period_min,
            self.out
        )?;
        let inputs: Vec<String> = self
            .inputs
            .iter()
            .map(|c| match c.power {
                1 => format!("{}/{}", c.name, c.scale),
                p => format!("({}/{})^{p}", c.name, c.scale),
            })
            .collect();
        writeln!(f, "inputs: {}", inputs.join(", "))?;
        if let Some(c) = &self.speed_model {
            writeln!(f, "{}", c.choice().summary())?;
        }
        for h in &self.heights {
            writeln!(
                f,
                "\nz = {} mm: orders {}, one-step RMS {:.2} µm, simulation RMS {:.2} µm, spectral radius {:.4}",
                h.z_mm,
                h.orders.orders(),
                h.one_step_rms_mm * 1e3,
                h.simulation_rms_mm * 1e3,
                h.spectral_radius
            )?;
            write!(f, "{}", grid_text(&h.grid))?;
        }
        Ok(())
    }
}

/// The predicted drift at one height.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PredictedHeightDoc {
    /// Drift at the last sample time (mm).
    pub final_drift_mm: f64,
    /// Largest |drift| (mm).
    pub max_abs_drift_mm: f64,
    /// The height (mm).
    pub z_mm: f64,
}

/// `mtwin thermal predict`: the drift predicted for a speed programme.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalPredictDoc {
    /// One summary per requested height, in the order requested.
    pub heights: Vec<PredictedHeightDoc>,
    /// The `DRIFT.csv` written.
    pub out: String,
    /// Sample times per height.
    pub samples: usize,
    /// Heights outside the measured range, …
    pub warnings: Vec<String>,
}

impl ThermalPredictDoc {
    /// The document of prediction `p` at `heights` (as asked of
    /// [`super::predict`]), written to `out`, with its `warnings`.
    pub fn new(p: &Prediction, heights: &[f64], out: &str, warnings: Vec<String>) -> Self {
        let heights_doc = heights
            .iter()
            .map(|&z| {
                let series = p.rows.iter().filter(|r| r[1] == z).map(|r| r[2]);
                let (max_abs, last) = series.fold((0.0f64, 0.0), |(m, _), d| (m.max(d.abs()), d));
                PredictedHeightDoc {
                    final_drift_mm: last,
                    max_abs_drift_mm: max_abs,
                    z_mm: z,
                }
            })
            .collect();
        ThermalPredictDoc {
            heights: heights_doc,
            out: out.to_string(),
            samples: p.rows.len() / heights.len().max(1),
            warnings,
        }
    }
}

/// One line of counts, then per height its largest and final drift (µm).
/// The warnings go to stderr.
impl std::fmt::Display for ThermalPredictDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} sample time(s) × {} height(s) → {}",
            self.samples,
            self.heights.len(),
            self.out
        )?;
        for h in &self.heights {
            writeln!(
                f,
                "z = {} mm: largest |drift| {:.2} µm, final drift {:.2} µm",
                h.z_mm,
                h.max_abs_drift_mm * 1e3,
                h.final_drift_mm * 1e3
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod fit_predict_tests {
    use super::super::{
        Programme, ThermalFitOptions, TruthMachine, fit, predict, training_from_table,
    };
    use super::*;

    fn small_fit() -> ThermalFit {
        let m = TruthMachine::demo();
        let runs = [
            ("a", [vec![4000.0; 12], vec![0.0; 6]].concat()),
            ("b", [vec![8000.0; 8], vec![2000.0; 10]].concat()),
        ];
        let csv = m.training_csv(&runs, &[-300.0, -100.0], 0.0, 1);
        let table =
            crate::io::Table::from_reader(std::path::Path::new("train.csv"), csv.as_bytes())
                .unwrap();
        let data = training_from_table(&table, &[]).unwrap();
        let options = ThermalFitOptions {
            max_order: 2,
            ..ThermalFitOptions::default()
        };
        fit(&data, &options).unwrap()
    }

    #[test]
    fn the_fit_document_carries_the_grid_and_round_trips() {
        let fit = small_fit();
        let d = ThermalFitDoc::new(&fit, "thermal.toml", &["plots/drift_z-300.svg".into()]);
        // Noise-free data of two first-order lags: na = 2, nb = 1 reproduces them.
        assert_eq!((d.runs, d.heights.len(), d.period_min), (2, 2, 10.0));
        assert_eq!(d.heights[0].z_mm, -300.0);
        for h in &d.heights {
            // na ∈ 1..=2 × nb ∈ 0..=2, one of them chosen: the one of `orders`.
            assert_eq!(h.grid.len(), 6);
            let chosen: Vec<&GridRowDoc> = h.grid.iter().filter(|r| r.chosen).collect();
            assert_eq!(chosen.len(), 1);
            assert_eq!(
                (chosen[0].na, &chosen[0].nb, &chosen[0].nk),
                (h.orders.na, &h.orders.nb, &h.orders.nk)
            );
            assert!(h.orders.na >= 2 && h.orders.nb[0] >= 1, "{:?}", h.orders);
            assert!(h.simulation_rms_mm < 1e-6, "{}", h.simulation_rms_mm);
            assert_eq!(h.a[0], 1.0);
            assert_eq!(h.a_std.len(), h.a.len() - 1);
            assert!(h.stable && h.spectral_radius < 1.0);
        }
        // The JSON keys of today's output.
        let v = serde_json::to_value(&d).unwrap();
        let keys =
            |v: &serde_json::Value| v.as_object().unwrap().keys().cloned().collect::<Vec<_>>();
        assert_eq!(
            keys(&v),
            [
                "heights",
                "inputs",
                "out",
                "period_min",
                "plots",
                "runs",
                "speed_model",
                "warnings"
            ]
        );
        assert!(v["speed_model"].is_null());
        assert_eq!(
            keys(&v["heights"][0]),
            [
                "a",
                "a_std",
                "aic",
                "b",
                "b_std",
                "fpe",
                "grid",
                "nk",
                "one_step_rms_mm",
                "orders",
                "params",
                "samples",
                "simulation_rms_mm",
                "spectral_radius",
                "stable",
                "z_mm"
            ]
        );
        assert_eq!(
            keys(&v["heights"][0]["grid"][0]),
            [
                "aic",
                "chosen",
                "fpe",
                "na",
                "nb",
                "nk",
                "one_step_rms",
                "params",
                "samples",
                "simulation_rms",
                "stable"
            ]
        );
        let back: ThermalFitDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        let text = d.to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "2 height(s), 2 run(s), sample period 10 min → thermal.toml"
        );
        assert_eq!(lines[1], format!("inputs: speed_rpm/{}", d.inputs[0].scale));
        // Per height: a blank line, the summary, the grid header and six rows.
        assert_eq!(lines.len(), 2 + 2 * 9);
        assert!(
            lines[3].starts_with("z = -300 mm: orders na="),
            "{}",
            lines[3]
        );
        assert_eq!(
            lines[5..11].iter().filter(|l| l.starts_with('*')).count(),
            1
        );
    }

    #[test]
    fn the_speed_model_choice_survives_the_document() {
        let c = SpeedModelChoice {
            folds: 3,
            linear_rms_mm: 0.002,
            quadratic_rms_mm: None,
            quadratic: false,
        };
        let d = SpeedModelDoc::from(&c);
        assert_eq!(d.chosen, "linear");
        assert_eq!(d.choice(), c);
        let v = serde_json::to_value(&d).unwrap();
        assert!(v["quadratic_rms_mm"].is_null());
        assert_eq!(serde_json::from_value::<SpeedModelDoc>(v).unwrap(), d);
    }

    #[test]
    fn the_predict_document_summarises_the_drift_of_the_truth() {
        let fit = small_fit();
        let speeds = [vec![6000.0; 9], vec![0.0; 4]].concat();
        let heights = [-100.0, -300.0];
        let p = predict(&fit.model, &Programme::speeds(&speeds), &heights);
        let d = ThermalPredictDoc::new(&p, &heights, "drift.csv", vec![]);
        assert_eq!(d.samples, speeds.len());
        let truth = TruthMachine::demo();
        let mut want = "13 sample time(s) × 2 height(s) → drift.csv\n".to_string();
        for (h, &z) in d.heights.iter().zip(&heights) {
            let e = truth.drift(&speeds, z);
            let max_abs = e.iter().fold(0.0f64, |m, d| m.max(d.abs()));
            assert_eq!(h.z_mm, z);
            assert!(
                (h.max_abs_drift_mm - max_abs).abs() < 1e-7,
                "{h:?} vs {max_abs}"
            );
            assert!(
                (h.final_drift_mm - e[12]).abs() < 1e-7,
                "{h:?} vs {}",
                e[12]
            );
            want.push_str(&format!(
                "z = {z} mm: largest |drift| {:.2} µm, final drift {:.2} µm\n",
                max_abs * 1e3,
                e[12] * 1e3
            ));
        }
        assert_eq!(d.to_string(), want);
        let back: ThermalPredictDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
    }
}

/// One step of a channel's input selection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogSelectionStepDoc {
    /// The input added (`-name`: removed by the backward pass; with the
    /// exchange search `old>new`: `old` exchanged for `new`, `a+b`: the pair
    /// added together).
    pub input: String,
    /// Held-out simulation RMS after the step (mm).
    pub heldout_rms_mm: f64,
}

/// The model chosen for one drift channel of a wide log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogChannelDoc {
    /// The column.
    pub column: String,
    /// Unit of the column's values.
    pub unit: super::log::LengthUnit,
    /// The axis the channel displaces the tool along.
    pub axis: super::log::Axis,
    /// Denominator order.
    pub na: usize,
    /// Numerator order (one for every input of the channel; delay 1).
    pub nb: usize,
    /// The inputs the channel's model uses.
    pub inputs: Vec<String>,
    /// Held-out simulation RMS the structure was chosen by (mm).
    pub heldout_rms_mm: f64,
    /// RMS of the drift on the held-out block (mm).
    pub heldout_drift_rms_mm: f64,
    /// Simulation RMS of the final model over the training samples (mm).
    pub training_rms_mm: f64,
    /// Output-error refinement replaced the least-squares estimate.
    pub output_error: bool,
    /// The selection path.
    pub selection: Vec<LogSelectionStepDoc>,
    /// The channel's other models, each chosen with another number of
    /// held-out blocks (`--folds` with several values); the channel is
    /// predicted by the per-sample median of this model and these.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub members: Vec<LogMemberDoc>,
}

/// One more model of a channel ([`LogChannelDoc::members`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogMemberDoc {
    /// Held-out blocks of the cross-validation it was chosen by.
    pub folds: usize,
    /// Denominator order.
    pub na: usize,
    /// Numerator order.
    pub nb: usize,
    /// The inputs it uses.
    pub inputs: Vec<String>,
    /// Held-out simulation RMS it was chosen by (mm).
    pub heldout_rms_mm: f64,
    /// Simulation RMS over the training samples (mm).
    pub training_rms_mm: f64,
    /// Output-error refinement replaced the least-squares estimate.
    pub output_error: bool,
}

/// The prediction of the log after the training time, from the log's start
/// with the inputs alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogTestDoc {
    /// Start of the test span (min since the log's start).
    pub from_min: f64,
    /// Samples (periods) of the test span.
    pub samples: usize,
    /// Per channel: MAE (channel unit) and error/drift RMS.
    pub channels: Vec<super::log::ChannelScore>,
}

/// `mtwin thermal fit --log`: the models chosen per drift channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalLogFitDoc {
    /// The model file written.
    pub out: String,
    /// Sample period (min).
    pub period_min: f64,
    /// Samples (periods) of the log.
    pub samples: usize,
    /// Samples used for training.
    pub training_samples: usize,
    /// Training samples judged out of their fit to choose the structures by
    /// (all of them with blocked cross-validation).
    pub heldout_samples: usize,
    /// Blocks of the blocked cross-validation (1: one held-out block at the
    /// end of the training samples).
    #[serde(default = "one")]
    pub folds: usize,
    /// Further numbers of held-out blocks each channel was also fitted
    /// with ([`LogChannelDoc::members`]); empty for one model per channel.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ensemble_folds: Vec<usize>,
    /// Every channel was also fitted on the plain rises, and those models
    /// are members beside the ones over the ambient sensor
    /// ([`LogFitRunOptions::also_plain`](super::run::LogFitRunOptions::also_plain)).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub also_plain: bool,
    /// How the input sets were searched (left out for the default, the
    /// forward search).
    #[serde(default, skip_serializing_if = "super::log::InputSearch::is_forward")]
    pub search: super::log::InputSearch,
    /// Every candidate input with its scale.
    pub inputs: Vec<super::log::LogInput>,
    /// The ambient sensor the other temperatures were taken over, when one
    /// was asked for ([`super::run::Ambient`]), with how it was chosen.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ambient: Option<super::log::AmbientChoice>,
    /// One model per drift channel.
    pub channels: Vec<LogChannelDoc>,
    /// The test span's scores, when the fit stopped before the log's end.
    pub test: Option<LogTestDoc>,
    /// Notes from reading and fitting.
    pub notes: Vec<String>,
    /// Reservations (a held-out error large compared with the drift, …).
    pub warnings: Vec<String>,
}

fn one() -> usize {
    1
}

fn axis_name(a: super::log::Axis) -> &'static str {
    match a {
        super::log::Axis::X => "X",
        super::log::Axis::Y => "Y",
        super::log::Axis::Z => "Z",
    }
}

fn unit_name(u: super::log::LengthUnit) -> &'static str {
    match u {
        super::log::LengthUnit::Mm => "mm",
        super::log::LengthUnit::Um => "µm",
    }
}

/// The summary, one line per channel (orders, held-out error in µm and as %
/// of the held-out drift, training error, inputs), then the test scores.
/// Notes and warnings go to stderr.
impl std::fmt::Display for ThermalLogFitDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.folds > 1 {
            writeln!(
                f,
                "{} channel(s), {} samples of {} min ({} for training, chosen by blocked cross-validation over {} blocks) → {}",
                self.channels.len(),
                self.samples,
                self.period_min,
                self.training_samples,
                self.folds,
                self.out
            )?;
        } else {
            writeln!(
                f,
                "{} channel(s), {} samples of {} min ({} for training, the last {} of them held out to choose by) → {}",
                self.channels.len(),
                self.samples,
                self.period_min,
                self.training_samples,
                self.heldout_samples,
                self.out
            )?;
        }
        if !self.ensemble_folds.is_empty() {
            let more: Vec<String> = self.ensemble_folds.iter().map(usize::to_string).collect();
            write!(
                f,
                "each channel also chosen with {} held-out blocks",
                more.join(", ")
            )?;
            if self.also_plain {
                writeln!(f)?;
            } else {
                writeln!(
                    f,
                    ": predicted by the per-sample median of its {} models",
                    1 + self.ensemble_folds.len()
                )?;
            }
        }
        if !self.search.is_forward() {
            writeln!(
                f,
                "input sets searched by forward steps, exchanges and pairs (--search exchange)"
            )?;
        }
        if let Some(a) = &self.ambient {
            match a.correlations.iter().find(|(c, _)| *c == a.column) {
                Some((_, r)) => writeln!(
                    f,
                    "temperatures taken over the ambient sensor {} (the least correlated with {}: |r| = {:.3} over {} rows)",
                    a.column, a.against, r, a.rows
                )?,
                None => writeln!(f, "temperatures taken over the ambient sensor {}", a.column)?,
            }
            if self.also_plain {
                writeln!(
                    f,
                    "each channel also fitted on the plain rises: predicted by the per-sample median of its {} models of both kinds",
                    2 * (1 + self.ensemble_folds.len())
                )?;
            }
        }
        writeln!(
            f,
            "{:<12} {:>4} {:>3} {:>3} {:>12} {:>8} {:>12} {:>3}  inputs",
            "channel", "axis", "na", "nb", "held-out µm", "% drift", "training µm", "OE"
        )?;
        for c in &self.channels {
            writeln!(
                f,
                "{:<12} {:>4} {:>3} {:>3} {:>12.3} {:>8.1} {:>12.3} {:>3}  {}",
                c.column,
                axis_name(c.axis),
                c.na,
                c.nb,
                c.heldout_rms_mm * 1e3,
                100.0 * c.heldout_rms_mm / c.heldout_drift_rms_mm.max(1e-300),
                c.training_rms_mm * 1e3,
                if c.output_error { "yes" } else { "no" },
                c.inputs.join(",")
            )?;
        }
        if self.channels.iter().any(|c| !c.members.is_empty()) {
            writeln!(
                f,
                "{:<12} {:>4} {:>3} {:>3} {:>12} {:>8} {:>12} {:>3}  inputs",
                "members", "blks", "na", "nb", "held-out µm", "", "training µm", "OE"
            )?;
            for c in &self.channels {
                for m in &c.members {
                    writeln!(
                        f,
                        "{:<12} {:>4} {:>3} {:>3} {:>12.3} {:>8} {:>12.3} {:>3}  {}",
                        c.column,
                        m.folds,
                        m.na,
                        m.nb,
                        m.heldout_rms_mm * 1e3,
                        "",
                        m.training_rms_mm * 1e3,
                        if m.output_error { "yes" } else { "no" },
                        m.inputs.join(",")
                    )?;
                }
            }
        }
        if let Some(t) = &self.test {
            writeln!(
                f,
                "test from t = {} min ({} samples), predicted from the log's start with the inputs alone:",
                t.from_min, t.samples
            )?;
            writeln!(
                f,
                "{:<12} {:>10} {:>16}",
                "channel", "MAE", "error/drift RMS"
            )?;
            for (s, c) in t.channels.iter().zip(&self.channels) {
                writeln!(
                    f,
                    "{:<12} {:>7.3} {:<2} {:>16.3}",
                    s.column,
                    s.mae,
                    unit_name(c.unit),
                    s.error_over_drift_rms
                )?;
            }
        }
        Ok(())
    }
}

/// One drift channel predicted from a log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogPredictedChannelDoc {
    /// The column.
    pub column: String,
    /// Unit of the predicted values.
    pub unit: super::log::LengthUnit,
    /// The axis.
    pub axis: super::log::Axis,
    /// Largest |change since the first period| predicted (channel unit).
    pub largest_abs_drift: f64,
    /// Change at the last period (channel unit).
    pub final_drift: f64,
    /// Mean absolute error against the log's rows of this column, when the
    /// log has it (channel unit).
    pub mae: Option<f64>,
}

/// `mtwin thermal predict --log`: the drift channels predicted from a log's inputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalLogPredictDoc {
    /// The CSV written.
    pub out: String,
    /// Sample period (min).
    pub period_min: f64,
    /// Samples (periods) predicted.
    pub samples: usize,
    /// One summary per channel of the model.
    pub channels: Vec<LogPredictedChannelDoc>,
    /// Notes from reading the log.
    pub notes: Vec<String>,
}

/// One line of counts, then per channel its largest and final drift and
/// the MAE when measured. Notes go to stderr.
impl std::fmt::Display for ThermalLogPredictDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} samples of {} min × {} channel(s), predicted from the log's start with the inputs alone → {}",
            self.samples,
            self.period_min,
            self.channels.len(),
            self.out
        )?;
        for c in &self.channels {
            let u = unit_name(c.unit);
            write!(
                f,
                "{} ({}): largest |drift| {:.3} {u}, final drift {:.3} {u}",
                c.column,
                axis_name(c.axis),
                c.largest_abs_drift,
                c.final_drift
            )?;
            match c.mae {
                Some(m) => writeln!(f, ", MAE against the log {m:.3} {u}")?,
                None => writeln!(f)?,
            }
        }
        Ok(())
    }
}
