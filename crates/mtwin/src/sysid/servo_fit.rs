//! `servo fit` (docs/servo.md): identify an axis' command-to-encoder transfer function
//! from a log `t_s,command_mm,feedback_mm`, and the `SERVO.toml` file.

use std::path::Path;

use toml_edit::TableLike;

use thiserror::Error;

use super::sampling::{check_sampling, median_interval};
use super::{
    Criterion, OrderGrid, OrderSelection, Run, Servo, Stability, SysidError,
    select_orders_output_error,
};
use crate::io::TomlWriteError;
use crate::io::toml::{Span, TomlReader, parse};
use crate::io::toml_write::{float, floats, int, set, with_header};
use crate::io::{Diagnostic, Diagnostics, Table, fmt_f64};
use crate::limits;
use crate::model::rules;
use toml_edit::DocumentMut;

/// A servo log: commands and encoder positions (mm or deg) every `ts` seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoLog {
    ts: f64,
    command: Vec<f64>,
    feedback: Vec<f64>,
}

impl ServoLog {
    /// A log from its sample period (s) and equally long command and feedback series.
    pub fn new(ts: f64, command: Vec<f64>, feedback: Vec<f64>) -> Result<ServoLog, SysidError> {
        if !(ts.is_finite() && ts > 0.0) {
            return Err(SysidError::BadPeriod(ts));
        }
        if command.len() != feedback.len() {
            return Err(SysidError::LengthMismatch {
                input: 0,
                expected: feedback.len(),
                found: command.len(),
            });
        }
        if command.iter().chain(&feedback).any(|v| !v.is_finite()) {
            return Err(SysidError::NotFinite {
                what: "the servo log".into(),
            });
        }
        Ok(ServoLog {
            ts,
            command,
            feedback,
        })
    }

    /// Sample period, s.
    pub fn ts(&self) -> f64 {
        self.ts
    }

    /// Commanded positions.
    pub fn command(&self) -> &[f64] {
        &self.command
    }

    /// Encoder positions.
    pub fn feedback(&self) -> &[f64] {
        &self.feedback
    }
}

/// Read `LOG.csv` (`t_s,command_mm,feedback_mm`): times strictly increasing
/// and evenly spaced; every problem is reported with its line.
pub fn read_servo_log(path: &Path) -> Result<ServoLog, Diagnostics> {
    let table = Table::read(path)?;
    let rows = table.number_rows(&crate::io::columns::SERVO_LOG)?;
    if rows.len() < 2 {
        return Err(Diagnostic::whole(path, "the log needs at least two samples").into());
    }
    let t: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let mut diags = Diagnostics::default();
    let ts = median_interval(&t).unwrap_or(0.0);
    if ts <= 0.0 {
        diags.push(Diagnostic::whole(path, "the times `t_s` never increase"));
    } else {
        let idx: Vec<usize> = (0..t.len()).collect();
        check_sampling(&table, &idx, &t, ts, "s", "", &mut diags);
    }
    let log = ServoLog {
        ts,
        command: rows.iter().map(|r| r[1]).collect(),
        feedback: rows.iter().map(|r| r[2]).collect(),
    };
    diags.into_result(log)
}

/// Options of [`fit_servo`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct ServoFitOptions {
    /// Largest `na` and `nb` tried (`na ∈ 1..=max`, `nb ∈ 0..=max`).
    pub max_order: usize,
    /// Largest input delay `nk` tried (`nk ∈ 0..=max_delay`), samples.
    pub max_delay: usize,
    /// The criterion choosing the orders.
    pub criterion: Criterion,
}

impl Default for ServoFitOptions {
    fn default() -> Self {
        ServoFitOptions {
            max_order: 4,
            max_delay: 3,
            criterion: Criterion::Fpe,
        }
    }
}

impl ServoFitOptions {
    /// Checks the options before any work: `max_order` at least 1 and at
    /// most [`limits::MAX_MODEL_ORDER`], `max_delay` at most
    /// [`limits::MAX_DELAY_SAMPLES`], and the number of structures tried
    /// (`max_order · (max_order + 1) · (max_delay + 1)`, each one an
    /// output-error fit) at most [`limits::MAX_FIT_CANDIDATES`].
    pub fn validate(&self) -> Result<(), SysidError> {
        if self.max_order == 0 {
            return Err(SysidError::BadOption(
                "the largest order must be at least 1 (a servo has at least one pole)".into(),
            ));
        }
        limits::check_fields(
            &["max_order"],
            "the largest order",
            self.max_order as f64,
            limits::MAX_MODEL_ORDER,
            "a servo axis needs a few poles; use a smaller order",
        )?;
        limits::check_fields(
            &["max_delay"],
            "the largest delay",
            self.max_delay as f64,
            limits::MAX_DELAY_SAMPLES,
            "a servo dead time is a few samples; use a smaller delay",
        )?;
        let n =
            self.max_order as f64 * (self.max_order as f64 + 1.0) * (self.max_delay as f64 + 1.0);
        limits::check_fields(
            &["max_order", "max_delay"],
            "the number of structures to fit (orders × delays)",
            n,
            limits::MAX_FIT_CANDIDATES,
            "each is a separate fit; lower the largest order or delay",
        )?;
        Ok(())
    }
}

/// An identified servo with what the CLI reports.
#[derive(Debug, Clone)]
pub struct ServoFit {
    /// The identified transfer function.
    pub servo: Servo,
    /// The whole order table and the chosen output-error fit (on deviations
    /// from the first command); `loss`, `fpe` and `aic` of the table are
    /// those of the simulation error.
    pub selection: OrderSelection,
    /// RMS of feedback minus the servo simulated from the commands (mm or deg).
    pub simulation_rms: f64,
    /// −3 dB bandwidth, Hz (`None` above Nyquist).
    pub bandwidth_hz: Option<f64>,
    /// Velocity lag τ, s: following error = velocity × τ (`None` without a static gain).
    pub velocity_lag_s: Option<f64>,
    /// Largest commanded speed in the log, mm/s or deg/s.
    pub max_velocity: f64,
    /// Steady following error at `max_velocity`, mm or deg.
    pub following_error_at_max_velocity: Option<f64>,
    /// Static gain (1 for an axis that reaches its command).
    pub dc_gain: f64,
    /// Pole location check.
    pub stability: Stability,
}

impl ServoFit {
    /// Plain sentences for anything suspicious (unstable model, static gain far from 1).
    pub fn warnings(&self) -> Vec<String> {
        let mut w: Vec<String> = self.stability.warning().into_iter().collect();
        if (self.dc_gain - 1.0).abs() > 0.01 {
            w.push(format!(
                "the static gain is {}, not 1: the axis would not reach a held command",
                limits::fmt_message_fixed(self.dc_gain, 4)
            ));
        }
        w
    }

    /// The summary for `--format json`: the transfer function (`ts` s, `b`,
    /// `a`, `nk`), chosen orders, `simulation_rms` (log unit), `bandwidth_hz`,
    /// `velocity_lag_s`, `max_velocity` and `following_error_at_max_velocity`
    /// (log unit per s, log unit), `dc_gain`, `stable`, `spectral_radius`, the
    /// whole order `grid` and the `warnings`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(super::ServoFitDoc::new(self)).unwrap_or_default()
    }

    /// `SERVO.toml`: top-level `ts`, `b`, `a`, `nk`, with the fit summary as comments.
    ///
    /// # Errors
    /// A non-finite coefficient or sample time, named by its key.
    pub fn to_toml(&self) -> Result<String, TomlWriteError> {
        let s = &self.selection.fit.stats;
        let mut header = vec![
            "Servo transfer function identified by mtwin, command -> encoder position.".to_string(),
            format!(
                "orders {}; simulation RMS {} (log unit); one-step RMS {}; samples {}",
                self.selection.table[self.selection.best].orders,
                fmt_f64(self.simulation_rms),
                fmt_f64(s.one_step_rms),
                s.samples
            ),
        ];
        if let Some(bw) = self.bandwidth_hz {
            header.push(format!("bandwidth (-3 dB) {} Hz", fmt_f64(bw)));
        }
        if let Some(lag) = self.velocity_lag_s {
            header.push(format!("following error = velocity x {} s", fmt_f64(lag)));
        }
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        Ok(with_header(&self.servo.toml_document()?, &header))
    }
}

/// Why `servo fit` failed: a bad file, or data that cannot be fitted.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ServoFitError {
    /// Problems in the log file, each with its line.
    #[error("{0}")]
    Input(#[from] Diagnostics),
    /// The identification failed.
    #[error("{0}")]
    Fit(#[from] SysidError),
    /// An option out of its domain: `option` names the field of
    /// [`super::FitRunOptions`].
    #[error("{option} {problem}")]
    Setting {
        /// The option.
        option: &'static str,
        /// What is wrong, as "must be …, not …".
        problem: String,
    },
}

/// Identify a servo from a log, on deviations from the first command
/// (`u − u(0)`, `y − u(0)`), with no assumption about the state before the
/// log (residual rows start after the largest lag of the grid).
///
/// Every structure `na ∈ 1..=max_order`, `nb ∈ 0..=max_order`,
/// `nk ∈ 0..=max_delay` is fitted by ARX least squares and refined to the
/// output-error estimate (Levenberg–Marquardt on the simulation error,
/// [`super::fit_output_error`]): encoder noise biases the ARX estimate of a
/// servo sampled much faster than its bandwidth (0.2 µm of noise moves its
/// simulation by several µm), the output-error estimate is consistent. The
/// orders are chosen by `criterion` evaluated on the simulation error,
/// preferring stable models.
pub fn fit_servo(log: &ServoLog, options: &ServoFitOptions) -> Result<ServoFit, SysidError> {
    options.validate()?;
    let Some(&u0) = log.command.first() else {
        return Err(SysidError::TooFewSamples { rows: 0, params: 1 });
    };
    let u: Vec<f64> = log.command.iter().map(|c| c - u0).collect();
    let y: Vec<f64> = log.feedback.iter().map(|c| c - u0).collect();
    let run = Run::new(y, vec![u])?;
    let grid = OrderGrid {
        na: 1..=options.max_order,
        inputs: vec![super::InputGrid {
            nb: 0..=options.max_order,
            nk: 0..=options.max_delay,
        }],
    };
    let selection = select_orders_output_error(&run, &grid, options.criterion)?;
    let servo = Servo::from_arx(log.ts, &selection.fit.model)?;
    let sim = servo.simulate(&log.command);
    let simulation_rms = rms(sim.iter().zip(&log.feedback).map(|(s, m)| m - s));
    if !simulation_rms.is_finite() {
        return Err(SysidError::NotFinite {
            what: "the simulation of the fitted servo (the model diverges on this log)".into(),
        });
    }
    let max_velocity = log
        .command
        .windows(2)
        .map(|w| ((w[1] - w[0]) / log.ts).abs())
        .fold(0.0, f64::max);
    let velocity_lag_s = servo.velocity_lag_s().ok();
    Ok(ServoFit {
        bandwidth_hz: servo.bandwidth_hz(),
        following_error_at_max_velocity: velocity_lag_s.map(|l| l * max_velocity),
        velocity_lag_s,
        max_velocity,
        dc_gain: servo.dc_gain(),
        stability: servo.arx().stability(),
        simulation_rms,
        servo,
        selection,
    })
}

/// `mtwin servo fit --data LOG.csv`: read the log and fit it.
pub fn fit_servo_csv(path: &Path, options: &ServoFitOptions) -> Result<ServoFit, ServoFitError> {
    let log = read_servo_log(path)?;
    Ok(fit_servo(&log, options)?)
}

fn rms(it: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = it.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    if n == 0 { 0.0 } else { (s / n as f64).sqrt() }
}

impl Servo {
    /// The four keys of `SERVO.toml` / `[axes.servo]`: `ts`, `b`, `a`, `nk`, at full precision.
    ///
    /// # Errors
    /// A non-finite coefficient or sample time, named by its key.
    pub fn to_toml(&self) -> Result<String, TomlWriteError> {
        Ok(self.toml_document()?.to_string())
    }

    fn toml_document(&self) -> Result<DocumentMut, TomlWriteError> {
        let mut doc = DocumentMut::new();
        let t = doc.as_table_mut();
        set(t, "ts", float("ts", self.ts())?, None);
        set(t, "b", floats("b", self.b())?, None);
        set(t, "a", floats("a", self.a())?, None);
        set(t, "nk", int(self.nk() as i64), None);
        Ok(doc)
    }
}

/// Read a servo table — the top level of `SERVO.toml` or an `[axes.servo]`
/// table of a machine file (`what` names it in messages): `ts` (s, positive),
/// `b` (at least b_0), `a` (with `a_0 = 1`) and optional `nk` (samples,
/// default 0). Every problem is reported to `r`; a missing key at `at`.
pub(crate) fn read_servo_table(
    r: &mut TomlReader<'_>,
    t: &dyn TableLike,
    what: &str,
    at: Span,
) -> Option<Servo> {
    r.check_keys(t, &["ts", "b", "a", "nk"], what);
    let ts = r.required(t, "ts", what, at.clone()).and_then(|i| {
        let x = r.number(i, &format!("`ts` of {what} (s)"))?;
        if let Err(e) = rules::servo_ts(what, x) {
            r.error(i.span(), e);
            return None;
        }
        Some(x)
    });
    let b = r.required(t, "b", what, at.clone()).and_then(|i| {
        let b = r.numbers(i, &format!("`b` of {what}"))?;
        if let Err(e) = rules::servo_b(what, &b) {
            r.error(i.span(), e);
            return None;
        }
        Some(b)
    });
    let a = r.required(t, "a", what, at.clone()).and_then(|i| {
        let a = r.numbers(i, &format!("`a` of {what}"))?;
        if let Err(e) = rules::servo_a(what, &a) {
            r.error(i.span(), e);
            return None;
        }
        Some(a)
    });
    let nk = match t.get("nk") {
        Some(i) => r
            .count(i, &format!("`nk` of {what} (samples)"))
            .and_then(|nk| match rules::servo_nk(what, nk) {
                Ok(()) => Some(nk),
                Err(e) => {
                    r.error(i.span(), e);
                    None
                }
            }),
        None => Some(0),
    };
    match rules::servo(what, ts?, b?, a?, nk?) {
        Ok(s) => Some(s),
        Err(e) => {
            r.error(at, e);
            None
        }
    }
}

/// Read `SERVO.toml` text: top-level `ts`, `b`, `a` (with `a_0 = 1`) and
/// optional `nk` (default 0), the same rules as `[axes.servo]` of a machine
/// file (`read_servo_table`). Unknown keys and bad values are reported with their line.
pub fn servo_from_toml_str(path: &Path, text: &str) -> Result<Servo, Diagnostics> {
    let doc = parse(path, text)?;
    let mut r = TomlReader::new(path, text);
    let servo = read_servo_table(&mut r, doc.as_table(), "the servo file", None);
    match servo {
        Some(s) if r.diags.is_empty() => Ok(s),
        _ => Err(r.diags),
    }
}

/// Read a `SERVO.toml` file.
pub fn read_servo_toml(path: &Path) -> Result<Servo, Diagnostics> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Diagnostic::whole(path, format!("cannot read the file: {e}")))?;
    servo_from_toml_str(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, Matrix2, Vector2};
    use rand::{Rng, SeedableRng, rngs::StdRng};
    use rand_distr::StandardNormal;

    /// A continuous second-order axis `ωn²/(s² + 2ζωn s + ωn²)` sampled with a
    /// zero-order hold, simulated in state space (independent of the ARX code).
    struct Axis {
        ad: Matrix2<f64>,
        bd: Vector2<f64>,
    }

    impl Axis {
        fn new(fn_hz: f64, zeta: f64, ts: f64) -> Axis {
            let wn = 2.0 * std::f64::consts::PI * fn_hz;
            let a = Matrix2::new(0.0, 1.0, -wn * wn, -2.0 * zeta * wn);
            let b = Vector2::new(0.0, wn * wn);
            // exp([[A, B], [0, 0]]·ts) = [[Ad, Bd], [0, 1]].
            let mut m = DMatrix::<f64>::zeros(3, 3);
            m.view_mut((0, 0), (2, 2)).copy_from(&(a * ts));
            m.view_mut((0, 2), (2, 1)).copy_from(&(b * ts));
            let e = m.exp();
            Axis {
                ad: e.fixed_view::<2, 2>(0, 0).into_owned(),
                bd: e.fixed_view::<2, 1>(0, 2).into_owned(),
            }
        }

        /// `|C (zI − Ad)⁻¹ Bd|` at `z = e^{jωts}`, `C = [1, 0]`.
        fn gain(&self, f_hz: f64, ts: f64) -> f64 {
            use nalgebra::Complex;
            let z = Complex::from_polar(1.0, 2.0 * std::f64::consts::PI * f_hz * ts);
            let (a, b, c, d) = (
                self.ad[(0, 0)],
                self.ad[(0, 1)],
                self.ad[(1, 0)],
                self.ad[(1, 1)],
            );
            let det = (z - a) * (z - d) - b * c;
            // First row of the adjugate of (zI − Ad): [z − d, b].
            ((z - d) * self.bd[0] + b * self.bd[1]).norm() / det.norm()
        }

        fn run(&self, u: &[f64]) -> Vec<f64> {
            let mut x = Vector2::new(u[0], 0.0);
            u.iter()
                .map(|&uk| {
                    let y = x[0];
                    x = self.ad * x + self.bd * uk;
                    y
                })
                .collect()
        }
    }

    /// A variable-amplitude excitation: random position steps smoothed by a
    /// moving average, plus a sweep (mm).
    fn excitation(n: usize, rng: &mut StdRng) -> Vec<f64> {
        let mut target = 0.0;
        let mut raw = Vec::with_capacity(n);
        for k in 0..n {
            if k % 60 == 0 {
                target = rng.gen_range(-2.0..2.0);
            }
            raw.push(target);
        }
        let w = 8;
        (0..n)
            .map(|k| {
                let lo = k.saturating_sub(w);
                let m = raw[lo..=k].iter().sum::<f64>() / (k - lo + 1) as f64;
                let t = k as f64 * 0.001;
                m + 0.3 * (2.0 * std::f64::consts::PI * (2.0 + 30.0 * t) * t).sin()
            })
            .collect()
    }

    /// Issue 8: with 0.2 µm encoder noise the fitted and true axes differ by
    /// under 1 µm RMS on a held-out command, for bandwidths across 20–60 Hz
    /// and several noise seeds.
    #[test]
    fn recovers_a_second_order_axis() {
        let ts = 0.001;
        let cases = [
            (20.0, 0.7, 1),
            (20.0, 0.7, 2),
            (30.0, 0.5, 3),
            (40.0, 0.6, 4),
            (40.0, 0.6, 5),
            (50.0, 0.9, 6),
            (60.0, 0.8, 7),
            (60.0, 0.8, 8),
        ];
        for (fn_hz, zeta, seed) in cases {
            let axis = Axis::new(fn_hz, zeta, ts);
            let mut rng = StdRng::seed_from_u64(seed);
            let u = excitation(4000, &mut rng);
            let y: Vec<f64> = axis
                .run(&u)
                .iter()
                .map(|v| v + 0.0002 * rng.sample::<f64, _>(StandardNormal))
                .collect();
            let log = ServoLog::new(ts, u, y).unwrap();
            let fit = fit_servo(&log, &ServoFitOptions::default()).unwrap();
            // Held-out command: a different excitation, compared noise-free.
            let mut rng = StdRng::seed_from_u64(99);
            let u2: Vec<f64> = excitation(3000, &mut rng)
                .iter()
                .map(|v| 5.0 + 0.7 * v)
                .collect();
            let truth = axis.run(&u2);
            let sim = fit.servo.simulate(&u2);
            let err = rms(truth.iter().zip(&sim).map(|(a, b)| a - b));
            assert!(
                err < 0.001,
                "{fn_hz} Hz seed {seed}: held-out RMS {err} mm ({})",
                fit.selection.fit.model.orders()
            );
            // The simulation error of the fit sits at the noise level.
            assert!(
                (fit.simulation_rms - 0.0002).abs() < 0.00003,
                "{}",
                fit.simulation_rms
            );
            assert!(
                fit.stability.is_stable() && fit.warnings().is_empty(),
                "{:?}",
                fit.warnings()
            );
            // Velocity lag of the true sampled axis: steady error of a long ramp.
            let v = 50.0;
            let ramp: Vec<f64> = (0..3000).map(|k| v * ts * k as f64).collect();
            let yr = axis.run(&ramp);
            let lag = (ramp[2999] - yr[2999]) / v;
            let got = fit.velocity_lag_s.unwrap();
            assert!((got - lag).abs() < 0.01 * lag, "lag {got} vs {lag}");
            // At the fitted bandwidth the true sampled axis has |H| = 1/√2.
            let got = fit.bandwidth_hz.unwrap();
            assert!((15.0..=100.0).contains(&got));
            let mag = axis.gain(got, ts);
            assert!(
                (mag - std::f64::consts::FRAC_1_SQRT_2).abs() < 0.01,
                "|H({got} Hz)| = {mag}"
            );
            let j = fit.to_json();
            assert_eq!(j["nk"], fit.servo.nk());
            assert_eq!(j["a"][0], 1.0);
            // The document round-trips through its type.
            let doc = super::super::ServoFitDoc::new(&fit);
            let text = serde_json::to_string_pretty(&doc).unwrap();
            assert_eq!(
                serde_json::from_str::<super::super::ServoFitDoc>(&text).unwrap(),
                doc
            );
            let back = servo_from_toml_str(Path::new("S.toml"), &fit.to_toml().unwrap()).unwrap();
            assert_eq!(back, fit.servo);
        }
    }

    #[test]
    fn servo_toml_round_trip_and_errors() {
        let s = Servo::new(
            0.001,
            vec![0.0, 0.0183, 0.0171],
            vec![1.0, -1.8106, 0.846],
            2,
        )
        .unwrap();
        let back = servo_from_toml_str(Path::new("S.toml"), &s.to_toml().unwrap()).unwrap();
        assert_eq!(back, s);
        let e = servo_from_toml_str(
            Path::new("S.toml"),
            "ts = 0.001\nb = [1.0]\na = [2.0, 0.5]\nfoo = 1\n",
        )
        .unwrap_err();
        let msgs: Vec<String> = e.0.iter().map(ToString::to_string).collect();
        assert!(
            msgs.iter()
                .any(|m| m.starts_with("S.toml:4:") && m.contains("`foo`")),
            "{msgs:?}"
        );
        assert!(
            msgs.iter()
                .any(|m| m.starts_with("S.toml:3:") && m.contains("a_0 = 1")),
            "{msgs:?}"
        );
        let e =
            servo_from_toml_str(Path::new("S.toml"), "ts = 0.001\nb = [1.0, \"x\"]\n").unwrap_err();
        assert!(e.0.iter().any(|d| d.line == 2), "{e}");
        assert!(e.0.iter().any(|d| d.message.contains("`a`")), "{e}");
        let e = servo_from_toml_str(Path::new("S.toml"), "ts = \n").unwrap_err();
        assert_eq!(e.0[0].line, 1);
    }

    #[test]
    fn log_errors_have_lines() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("LOG.csv");
        std::fs::write(
            &p,
            "t_s,command_mm,feedback_mm\n0,0,0\n0.001,1,0\n0.001,1,0.5\n0.002,1,0.7\n0.0045,1,1\n",
        )
        .unwrap();
        let e = read_servo_log(&p).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.line == 4 && d.message.contains("does not increase")),
            "{e}"
        );
        assert!(
            e.0.iter()
                .any(|d| d.line == 6 && d.message.contains("uneven")),
            "{e}"
        );
        std::fs::write(&p, "t_s,command_mm\n0,0\n").unwrap();
        assert!(
            read_servo_log(&p)
                .unwrap_err()
                .to_string()
                .contains("feedback_mm")
        );
    }

    /// `[axes.servo]` of a machine file and `SERVO.toml` accept the same
    /// tables and report the same problems in the same words (only the
    /// naming of the table differs).
    #[test]
    fn machine_servo_table_and_servo_file_share_their_rules() {
        let machine = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/machines/ac-trunnion.toml"
        ))
        .unwrap();
        let bodies = [
            "ts = 0.001\nb = [0.0, 0.5]\na = [1.0, -0.5]\n",
            "ts = 0.001\nb = [0.5]\na = [1.0, -0.5]\nnk = 2\n",
            "ts = 0.001\nb = [1.0]\na = [2.0, 0.5]\nfoo = 1\n",
            "ts = -1\nb = []\na = [1.0]\nnk = -1\n",
            "ts = \"x\"\nb = [1.0, \"y\"]\n",
            "b = 3\na = []\n",
        ];
        for body in bodies {
            let file = servo_from_toml_str(Path::new("S.toml"), body);
            let m = crate::model::parse_machine(
                Path::new("m.toml"),
                &format!("{machine}\n[axes.servo]\n{body}"),
            );
            match (file, m) {
                (Ok(s), Ok(m)) => {
                    let t = m.axes.last().unwrap().servo.as_ref().unwrap();
                    assert_eq!(
                        (t.ts, &t.b[..], &t.a[..], t.nk),
                        (s.ts(), s.b(), s.a(), s.nk())
                    );
                }
                (Err(f), Err(m)) => {
                    let f: Vec<String> =
                        f.0.iter()
                            .map(|d| {
                                d.message
                                    .replace("the servo file", "the servo table of axis `C`")
                            })
                            .collect();
                    let m: Vec<String> = m.0.iter().map(|d| d.message.clone()).collect();
                    assert!(!f.is_empty());
                    assert_eq!(f, m, "{body}");
                }
                (f, m) => panic!("{body}: file {f:?}, machine {m:?}"),
            }
        }
    }

    // Any finite number the reader accepts (within `limits::MAX_ABS_VALUE`).
    use crate::limits::strategies::{finite, positive};

    proptest::proptest! {
        /// Any finite coefficients and positive sample time within the readers'
        /// bound read back identical.
        #[test]
        fn servo_toml_round_trips_any_finite_values(
            ts in positive(),
            b in proptest::collection::vec(finite(), 1..6),
            tail in proptest::collection::vec(finite(), 0..6),
            nk in 0usize..100,
        ) {
            let mut a = vec![1.0];
            a.extend(tail);
            let s = Servo::new(ts, b, a, nk).unwrap();
            let back = servo_from_toml_str(Path::new("S.toml"), &s.to_toml().unwrap()).unwrap();
            proptest::prop_assert_eq!(back, s);
        }

        #[test]
        fn servo_toml_parser_never_panics(s in ".{0,120}") {
            let _ = servo_from_toml_str(Path::new("p.toml"), &s);
        }

        #[test]
        fn servo_toml_parser_never_panics_on_edits(pos in 0usize..200, junk in "[\\[\\]{}=,.0-9a-z\" \n-]{0,8}", del in 0usize..6) {
            let good = Servo::new(0.001, vec![0.0, 0.0183, 0.0171], vec![1.0, -1.8106, 0.846], 2)
                .unwrap()
                .to_toml()
                .unwrap();
            let mut cut = pos.min(good.len());
            while !good.is_char_boundary(cut) {
                cut -= 1;
            }
            let end = (cut + del).min(good.len());
            let text = format!("{}{}{}", &good[..cut], junk, &good[end..]);
            let _ = servo_from_toml_str(Path::new("p.toml"), &text);
        }
    }
}
