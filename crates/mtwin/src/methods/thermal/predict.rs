//! The contract commands: `thermal fit` (TRAIN.csv → model), `thermal
//! predict` (model + SPEED.csv → DRIFT.csv), and `simulate` (model + speeds →
//! TRAIN-format data with seeded noise).

use std::io::Write;
use std::path::Path;

use rand::{SeedableRng, rngs::StdRng};
use rand_distr::{Distribution, Normal};

use super::ThermalError;
use super::data::{TrainingData, read_training};
use super::model::{HeightModel, HeightStats, InputChannel, ThermalModel};
use super::speed_model::{SpeedModel, SpeedModelChoice, choose_speed_model};
use crate::io::{Diagnostic, Diagnostics, Table, write_atomic_with, write_csv_row};
use crate::sysid::{Criterion, OrderGrid, OrderSelection, Run, Start, select_orders};

/// Inputs on the model's sample grid from `t = 0`: sample `k` holds over
/// `[kT, (k+1)T)`, raw units (rev/min for the speed), one value per input
/// column of the model ([`ThermalModel::columns`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Programme {
    samples: Vec<Vec<f64>>,
    first: usize,
}

impl Programme {
    /// A programme from its samples, every one with one value per input column.
    pub fn new(samples: Vec<Vec<f64>>) -> Programme {
        Programme { samples, first: 0 }
    }

    /// A speed-only programme (rev/min per sample).
    pub fn speeds(speeds: &[f64]) -> Programme {
        Programme::new(speeds.iter().map(|&s| vec![s]).collect())
    }

    /// Number of samples (including the idle ones before the first given).
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// True without samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The inputs of sample `k`.
    pub fn sample(&self, k: usize) -> &[f64] {
        &self.samples[k]
    }

    /// The first sample given in the file (earlier ones are idle: all inputs 0).
    pub fn first_given(&self) -> usize {
        self.first
    }
}

/// Read `SPEED.csv` (`t_min` and the model's input columns, `speed_rpm`
/// first) for `model`: times on the model's grid `t = kT` (within 1 % of T),
/// `k ≥ 0`, consecutive. Samples before the first time are idle (inputs 0).
pub fn read_programme(path: &Path, model: &ThermalModel) -> Result<Programme, Diagnostics> {
    let table = Table::read(path)?;
    let mut names = vec![crate::io::columns::T_MIN];
    names.extend(model.columns().iter().map(String::as_str));
    let rows = table.number_rows(&names)?;
    if rows.is_empty() {
        return Err(
            Diagnostic::at_line(path, table.header_line(), "the file has no data rows").into(),
        );
    }
    let period = model.period_min();
    let mut diags = Diagnostics::default();
    let mut samples = Vec::new();
    let mut first = 0;
    let mut prev: Option<usize> = None;
    for (r, v) in rows.iter().enumerate() {
        let pos = v[0] / period;
        let k = pos.round();
        if v[0] < 0.0 || (pos - k).abs() > 0.01 {
            diags.push(table.row_error(
                r,
                format!(
                    "time {} min is not on the model's sample grid (t = k x {} min, k >= 0)",
                    crate::limits::fmt_message_number(v[0]),
                    crate::limits::fmt_message_number(period)
                ),
            ));
            continue;
        }
        if prev.is_none() && k > crate::limits::MAX_SAMPLES as f64 {
            // Samples before the first time are idle and held in memory.
            diags.push(table.row_error(
                r,
                format!(
                    "the first time, {} min, is sample {} of the model's grid, above the limit of {} samples: \
                     the programme starts at t = 0; give times from the start of the programme",
                    crate::limits::fmt_message_number(v[0]),
                    crate::limits::fmt_message_number(k),
                    crate::limits::MAX_SAMPLES
                ),
            ));
            break;
        }
        let k = k as usize;
        match prev {
            None => {
                first = k;
                samples = vec![vec![0.0; names.len() - 1]; k];
            }
            Some(p) if k != p + 1 => {
                diags.push(table.row_error(
                    r,
                    format!(
                        "time {} min does not follow the previous sample ({} min) by one period of {} min",
                        crate::limits::fmt_message_number(v[0]),
                        crate::limits::fmt_message_number(p as f64 * period),
                        crate::limits::fmt_message_number(period)
                    ),
                ));
            }
            Some(_) => {}
        }
        prev = Some(k);
        samples.push(v[1..].to_vec());
    }
    diags.into_result(Programme { samples, first })
}

/// Predicted drift rows `t_min, z_mm, drift_mm`.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// `[t_min, z_mm, drift_mm]`, time-major, heights in the order requested.
    pub rows: Vec<[f64; 3]>,
    /// Requested heights outside the measured range (their drift is the held end value).
    pub extrapolated: Vec<f64>,
}

impl Prediction {
    /// Plain sentences for the heights outside the measured range.
    pub fn warnings(&self, model: &ThermalModel) -> Vec<String> {
        let (lo, hi) = (
            model.heights()[0].z_mm,
            model.heights()[model.heights().len() - 1].z_mm,
        );
        self.extrapolated
            .iter()
            .map(|z| {
                format!(
                    "z = {z} mm is outside the measured heights [{lo}, {hi}] mm: the drift of the nearest \
                     end is used"
                )
            })
            .collect()
    }

    /// Write `DRIFT.csv` atomically (header `t_min,z_mm,drift_mm`).
    pub fn write_csv(&self, path: &Path) -> std::io::Result<()> {
        write_atomic_with(path, |w| self.write_csv_to(w))
    }

    /// Write the `DRIFT.csv` text (header `t_min,z_mm,drift_mm`) to `w`.
    pub fn write_csv_to(&self, w: &mut dyn Write) -> std::io::Result<()> {
        writeln!(
            w,
            "{}",
            crate::io::columns::header(&crate::io::columns::THERMAL_PREDICTION)
        )?;
        for r in &self.rows {
            write_csv_row(&mut &mut *w, r)?;
        }
        Ok(())
    }
}

/// Drift at `heights` for every sample time of `programme` that was given
/// (from [`Programme::first_given`]), simulated from cold at `t = 0`.
pub fn predict(model: &ThermalModel, programme: &Programme, heights: &[f64]) -> Prediction {
    let history = model.drift_history(programme);
    let mut rows = Vec::with_capacity(heights.len() * programme.len());
    for (k, values) in history
        .iter()
        .enumerate()
        .take(programme.len())
        .skip(programme.first_given())
    {
        let t = k as f64 * model.period_min();
        for &z in heights {
            rows.push([t, z, model.interpolate(values, z).mm]);
        }
    }
    let extrapolated = heights
        .iter()
        .copied()
        .filter(|&z| model.interpolate(&history[0], z).is_extrapolated())
        .collect();
    Prediction { rows, extrapolated }
}

/// Options of [`fit`].
#[derive(Debug, Clone, PartialEq)]
pub struct ThermalFitOptions {
    /// Largest `na` (the `k` of 04) and `nb` (the `m`) tried: `na ∈ 1..=max`, `nb ∈ 0..=max`.
    pub max_order: usize,
    /// Input delay `nk ≥ 1`, samples (1: a speed acts from the next sample on).
    pub delay: usize,
    /// Criterion choosing the orders (by default Akaike's final prediction error, FPE; `docs/references.md`).
    pub criterion: Criterion,
    /// Further input columns of `TRAIN.csv` (temperatures, …) beside `speed_rpm`.
    pub extra_inputs: Vec<String>,
    /// How the speed enters the model (04's model: linearly).
    pub speed_model: SpeedModel,
}

impl Default for ThermalFitOptions {
    fn default() -> Self {
        ThermalFitOptions {
            max_order: 4,
            delay: 1,
            criterion: Criterion::Fpe,
            extra_inputs: Vec::new(),
            speed_model: SpeedModel::Linear,
        }
    }
}

impl ThermalFitOptions {
    /// Checks the options before any work: `max_order` from 1 to
    /// [`crate::limits::MAX_MODEL_ORDER`], `delay` from 1 to
    /// [`crate::limits::MAX_DELAY_SAMPLES`], and the order grid (one fit per
    /// `na` and per `nb` of every input: `max · (max + 1)^inputs`, the speed
    /// counted twice for the quadratic model) at most
    /// [`crate::limits::MAX_FIT_CANDIDATES`].
    pub fn validate(&self) -> Result<(), ThermalError> {
        if self.max_order == 0 {
            return Err(ThermalError::Options(
                "the largest order (--max-order) must be at least 1 (the drift needs at least one pole)".into(),
            ));
        }
        if self.delay == 0 {
            return Err(ThermalError::Options(
                "the input delay must be at least 1: a speed given at t holds over [t, t+T)".into(),
            ));
        }
        let limit = |e: crate::limits::LimitError| ThermalError::Options(e.to_string());
        crate::limits::check(
            "the largest order (--max-order)",
            self.max_order as f64,
            crate::limits::MAX_MODEL_ORDER,
            "a thermal drift needs a few poles; use a smaller order",
        )
        .map_err(limit)?;
        crate::limits::check(
            "the input delay",
            self.delay as f64,
            crate::limits::MAX_DELAY_SAMPLES,
            "use a smaller delay",
        )
        .map_err(limit)?;
        let quadratic = usize::from(self.speed_model != SpeedModel::Linear);
        let inputs = 1 + quadratic + self.extra_inputs.len();
        let m = self.max_order as f64;
        crate::limits::check(
            "the number of order combinations to fit (--max-order, --extra-inputs)",
            m * (m + 1.0).powi(inputs as i32),
            crate::limits::MAX_FIT_CANDIDATES,
            "each is a separate fit; lower --max-order or give fewer --extra-inputs",
        )
        .map_err(limit)?;
        Ok(())
    }
}

/// The order search of one height.
#[derive(Debug, Clone)]
pub struct HeightReport {
    /// Height, mm.
    pub z_mm: f64,
    /// The whole grid table and the chosen fit.
    pub selection: OrderSelection,
}

/// A fitted thermal model with its report.
#[derive(Debug, Clone)]
pub struct ThermalFit {
    /// The model (write it with [`ThermalModel::to_toml`]).
    pub model: ThermalModel,
    /// One report per height, ascending.
    pub heights: Vec<HeightReport>,
    /// Number of runs in the data.
    pub runs: usize,
    /// Plain sentences for the user (unstable models, …).
    pub warnings: Vec<String>,
    /// The held-out comparison of linear and quadratic speed models, when
    /// [`SpeedModel::Auto`] chose.
    pub speed_model: Option<SpeedModelChoice>,
}

impl ThermalFit {
    /// The summary for `--format json`: `period_min`, `runs`, `inputs`
    /// (`name`, `scale`), per height `z_mm`, chosen `orders`, `a`, `b`, `nk`,
    /// their standard uncertainties `a_std`, `b_std`, `samples`, `params`,
    /// `fpe` (mm²), `aic`, `one_step_rms_mm`, `simulation_rms_mm`, `stable`,
    /// `spectral_radius` and the whole order `grid`; then the `warnings`.
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(super::ThermalFitDoc::new(self, "", &[]))
            .expect("the fit document serialises");
        let obj = v.as_object_mut().expect("the document is an object");
        obj.remove("out");
        obj.remove("plots");
        v
    }
}

/// Fit one ARX model per height (orders by `options.criterion` over
/// `na ∈ 1..=max_order`, `nb ∈ 0..=max_order` per input, every run from cold).
/// The inputs are the data's columns, linear, plus the squared speed for
/// [`SpeedModel::Quadratic`], or for [`SpeedModel::Auto`] when it predicts
/// held-out runs better ([`choose_speed_model`]).
///
/// A height with fewer than three samples per parameter of the largest model
/// of the grid is an error at the line of its first sample.
pub fn fit(data: &TrainingData, options: &ThermalFitOptions) -> Result<ThermalFit, ThermalError> {
    match options.speed_model {
        SpeedModel::Linear => fit_with(data, options, false),
        SpeedModel::Quadratic => fit_with(data, options, true),
        SpeedModel::Auto => {
            let choice = choose_speed_model(data, options)?;
            let mut fit = fit_with(data, options, choice.quadratic)?;
            fit.speed_model = Some(choice);
            Ok(fit)
        }
    }
}

/// [`fit`] with the squared speed as a further input or not.
pub(super) fn fit_with(
    data: &TrainingData,
    options: &ThermalFitOptions,
    quadratic: bool,
) -> Result<ThermalFit, ThermalError> {
    options.validate()?;
    let n_inputs = data.input_names.len() + usize::from(quadratic);
    let grid = OrderGrid::up_to(options.max_order, &vec![options.delay; n_inputs]);
    let needed = 3 * grid.max_params();
    let mut diags = Diagnostics::default();
    for h in &data.heights {
        if h.samples() < needed {
            diags.push(Diagnostic::at_line(
                &data.path,
                h.first_line(),
                format!(
                    "z = {} mm has {} samples, but models up to order {} have up to {} parameters and \
                     need at least {needed} samples (measure longer, add runs or lower --max-order)",
                    crate::limits::fmt_message_number(h.z_mm),
                    h.samples(),
                    options.max_order,
                    grid.max_params()
                ),
            ));
        }
    }
    if !diags.is_empty() {
        return Err(diags.into());
    }
    let mut inputs: Vec<InputChannel> = data
        .input_names
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let max = data
                .heights
                .iter()
                .flat_map(|h| h.series.iter().flat_map(move |s| s.inputs[i].iter()))
                .fold(0.0f64, |m, v| m.max(v.abs()));
            InputChannel::linear(name.clone(), if max > 0.0 { max } else { 1.0 })
        })
        .collect();
    // Column of every input: the data's columns in order, then the speed again.
    let mut column_of: Vec<usize> = (0..inputs.len()).collect();
    if quadratic {
        inputs.push(InputChannel {
            power: 2,
            ..inputs[0].clone()
        });
        column_of.push(0);
    }
    let mut reports = Vec::new();
    let mut models = Vec::new();
    let mut warnings = Vec::new();
    for h in &data.heights {
        let fail = |source| ThermalError::Fit {
            z_mm: h.z_mm,
            source,
        };
        let runs: Vec<Run> = h
            .series
            .iter()
            .map(|s| {
                let scaled = inputs
                    .iter()
                    .zip(&column_of)
                    .map(|(c, &col)| s.inputs[col].iter().map(|&v| c.apply(v)).collect());
                Run::new(s.drift.clone(), scaled.collect())
            })
            .collect::<Result<_, _>>()
            .map_err(fail)?;
        let selection =
            select_orders(&runs, &grid, options.criterion, Start::AtRest).map_err(fail)?;
        let fit = &selection.fit;
        if let Some(w) = fit.model.stability().warning() {
            warnings.push(format!(
                "z = {} mm: {w}",
                crate::limits::fmt_message_number(h.z_mm)
            ));
        }
        let stats = HeightStats {
            samples: fit.stats.samples,
            params: fit.stats.params,
            fpe: fit.stats.fpe,
            aic: fit.stats.aic,
            one_step_rms_mm: fit.stats.one_step_rms,
            simulation_rms_mm: fit.stats.simulation_rms,
            spectral_radius: fit.stats.spectral_radius,
            a_std: fit.std_a(),
            b_std: (0..n_inputs).map(|i| fit.std_b(i)).collect(),
        };
        models.push(HeightModel {
            z_mm: h.z_mm,
            model: fit.model.clone(),
            stats: Some(stats),
        });
        reports.push(HeightReport {
            z_mm: h.z_mm,
            selection,
        });
    }
    let model = ThermalModel::new(data.period_min, inputs, models)?;
    Ok(ThermalFit {
        model,
        heights: reports,
        runs: data.runs.len(),
        warnings,
        speed_model: None,
    })
}

/// `mtwin thermal fit --data TRAIN.csv`: read, check and fit.
pub fn fit_csv(path: &Path, options: &ThermalFitOptions) -> Result<ThermalFit, ThermalError> {
    let data = read_training(path, &options.extra_inputs)?;
    fit(&data, options)
}

/// Simulated measurements in the `TRAIN.csv` layout.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedData {
    /// Input column names (the model's).
    pub input_names: Vec<String>,
    /// `(t_min, inputs, z_mm, drift_mm)` rows, time-major.
    pub rows: Vec<(f64, Vec<f64>, f64, f64)>,
}

impl SimulatedData {
    /// Write as `TRAIN.csv` (`t_min,<inputs>,z_mm,drift_mm`), atomically.
    pub fn write_csv(&self, path: &Path) -> std::io::Result<()> {
        write_atomic_with(path, |w| self.write_csv_to(w))
    }

    /// Write the `TRAIN.csv` text (`t_min,<inputs>,z_mm,drift_mm`) to `w`.
    pub fn write_csv_to(&self, w: &mut dyn Write) -> std::io::Result<()> {
        use crate::io::columns::{DRIFT_MM, T_MIN, Z_MM};
        writeln!(
            w,
            "{T_MIN},{},{Z_MM},{DRIFT_MM}",
            self.input_names.join(",")
        )?;
        let mut row = Vec::new();
        for (t, inputs, z, e) in &self.rows {
            row.clear();
            row.push(*t);
            row.extend_from_slice(inputs);
            row.extend_from_slice(&[*z, *e]);
            write_csv_row(&mut &mut *w, &row)?;
        }
        Ok(())
    }
}

/// Drift data of `model` for `programme` at `heights`, with white
/// measurement noise of standard deviation `noise_mm` drawn from `seed`
/// (same seed, same data): one row per given sample time and height.
pub fn simulate(
    model: &ThermalModel,
    programme: &Programme,
    heights: &[f64],
    noise_mm: f64,
    seed: u64,
) -> Result<SimulatedData, ThermalError> {
    let bad = || {
        ThermalError::Model(format!(
            "the noise level must be finite and >= 0, not {noise_mm} mm"
        ))
    };
    if !(noise_mm.is_finite() && noise_mm >= 0.0) {
        return Err(bad());
    }
    let noise = Normal::new(0.0, noise_mm).map_err(|_| bad())?;
    let mut rng = StdRng::seed_from_u64(seed);
    let pred = predict(model, programme, heights);
    let period = model.period_min();
    let rows = pred
        .rows
        .iter()
        .map(|&[t, z, e]| {
            let k = (t / period).round() as usize;
            (
                t,
                programme.sample(k).to_vec(),
                z,
                e + noise.sample(&mut rng),
            )
        })
        .collect();
    Ok(SimulatedData {
        input_names: model.columns().to_vec(),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sysid::Arx;

    fn model() -> ThermalModel {
        let h = |z: f64, g: f64| HeightModel {
            z_mm: z,
            model: Arx::new(vec![1.0, -0.8], vec![(vec![0.2 * g], 1)]).unwrap(),
            stats: None,
        };
        let inputs = vec![InputChannel::linear("speed_rpm", 1000.0)];
        ThermalModel::new(10.0, inputs, vec![h(-50.0, 0.01), h(-150.0, 0.03)]).unwrap()
    }

    /// A programme starting at an epoch time (an epoch in seconds written as
    /// minutes, far on the model's grid) would hold every idle sample before
    /// it: refused at its line, with the limit, before anything is allocated.
    #[test]
    fn speed_file_far_from_zero_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("SPEED.csv");
        std::fs::write(&p, "t_min,speed_rpm\n1732550000,1000\n1732550010,1000\n").unwrap();
        let Err(e) = read_programme(&p, &model()) else {
            panic!("a programme starting at sample 173255000 was accepted");
        };
        assert!(
            e.0.iter().any(|d| d.line == 2
                && d.message.contains("sample 173255000")
                && d.message.contains("limit")),
            "{e:?}"
        );
    }

    #[test]
    fn speed_file_on_grid_with_idle_start() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("SPEED.csv");
        std::fs::write(&p, "t_min,speed_rpm\n20,1000\n30,1000\n40,0\n").unwrap();
        let m = model();
        let prog = read_programme(&p, &m).unwrap();
        assert_eq!(prog.len(), 5);
        assert_eq!(prog.first_given(), 2);
        assert_eq!(prog.sample(1), &[0.0]);
        let pred = predict(&m, &prog, &[-100.0, 0.0]);
        assert_eq!(pred.rows.len(), 6);
        assert_eq!(pred.rows[0], [20.0, -100.0, 0.0]);
        // At 40 min, two periods of 1000 rpm: e = g(1 − 0.8²) at each height, mean of the two.
        let want = 0.5 * (0.01 + 0.03) * (1.0 - 0.64);
        assert!((pred.rows[4][2] - want).abs() < 1e-15, "{:?}", pred.rows[4]);
        assert_eq!(pred.extrapolated, vec![0.0]);
        assert_eq!(pred.warnings(&m).len(), 1);
        let out = dir.path().join("DRIFT.csv");
        pred.write_csv(&out).unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(
            text.starts_with("t_min,z_mm,drift_mm\n20,-100,0\n"),
            "{text}"
        );
        let back = Table::read(&out).unwrap();
        assert_eq!(
            back.numbers(back.column("drift_mm").unwrap()).unwrap()[4],
            pred.rows[4][2]
        );

        std::fs::write(&p, "t_min,speed_rpm\n0,1000\n10,1000\n25,0\n40,0\n").unwrap();
        let e = read_programme(&p, &m).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.line == 4 && d.message.contains("grid")),
            "{e}"
        );
        assert!(
            e.0.iter()
                .any(|d| d.line == 5 && d.message.contains("does not follow")),
            "{e}"
        );
    }

    #[test]
    fn simulate_is_seeded_and_noise_free_matches_predict() {
        let m = model();
        let prog = Programme::speeds(&[3000.0, 3000.0, 0.0, 5000.0]);
        let a = simulate(&m, &prog, &[-50.0, -120.0], 0.001, 7).unwrap();
        let b = simulate(&m, &prog, &[-50.0, -120.0], 0.001, 7).unwrap();
        assert_eq!(a, b);
        let clean = simulate(&m, &prog, &[-50.0, -120.0], 0.0, 7).unwrap();
        let p = predict(&m, &prog, &[-50.0, -120.0]);
        for (r, q) in clean.rows.iter().zip(&p.rows) {
            assert_eq!((r.0, r.2, r.3), (q[0], q[1], q[2]));
        }
        assert_eq!(clean.rows[4].1, vec![0.0]);
        assert!(simulate(&m, &prog, &[0.0], -1.0, 1).is_err());
    }
}
