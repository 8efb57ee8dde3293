//! Servo identification: command/encoder logs of every axis simulated with
//! known transfer functions and encoder noise, each axis fitted by ARX with
//! order selection, and the identified servos written into the machine
//! model (the digital twin's machine).

use std::fmt;
use std::time::Instant;

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::model::{Machine, ServoTable};
use crate::report::html::Section;
use crate::report::sections;
use crate::sysid::{OrdersDoc, Servo, ServoFitDoc, ServoFitOptions, ServoLog, fit_servo};

/// The step's heading.
pub const TITLE: &str = "Servo: axis transfer functions from command/encoder logs";

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// Encoder noise (standard deviation), mm or degree.
    pub noise: f64,
    /// Random seed of the noise.
    pub seed: u64,
    /// Sample period of the true servos, s.
    pub ts: f64,
    /// The double pole of each axis's true servo, in machine axis order
    /// (the last repeats for further axes).
    pub poles: Vec<f64>,
}

impl Default for Options {
    /// The demo's: 20 nm noise, 1 ms, poles 0.80, 0.82, 0.78, 0.85, 0.83.
    fn default() -> Self {
        Options {
            noise: 0.00002,
            seed: 5,
            ts: 0.001,
            poles: vec![0.80, 0.82, 0.78, 0.85, 0.83],
        }
    }
}

/// The true servo of one axis: a double pole at `p` with static gain 1,
/// `(1 − p)² z⁻¹ / (1 − 2p z⁻¹ + p² z⁻²)`.
pub fn double_pole(ts: f64, p: f64) -> std::result::Result<Servo, crate::sysid::SysidError> {
    Servo::new(
        ts,
        vec![(1.0 - p) * (1.0 - p)],
        vec![1.0, -2.0 * p, p * p],
        1,
    )
}

/// A linear sine sweep (chirp) of `n` samples at period `ts` (s): amplitude
/// `amplitude`, frequency rising linearly from `f0` to `f0 + (f1 − f0)·(n−1)/n`
/// Hz; sample `k` is `amplitude·sin(φ_k)` with `φ_k = 2π·ts·Σ_{j≤k} f_j`
/// and `f_j = f0 + (f1 − f0)·j/n`.
pub fn sine_sweep(ts: f64, n: usize, f0: f64, f1: f64, amplitude: f64) -> Vec<f64> {
    let mut phase = 0.0;
    (0..n)
        .map(|k| {
            let t = k as f64 * ts;
            let f = f0 + (f1 - f0) * t / (n as f64 * ts);
            phase += 2.0 * std::f64::consts::PI * f * ts;
            amplitude * phase.sin()
        })
        .collect()
}

/// The excitation of every axis: a sweep of 20 mm (or degrees) from 0.5 to
/// 8 Hz over 4000 samples.
pub fn excitation(ts: f64) -> Vec<f64> {
    sine_sweep(ts, 4000, 0.5, 8.0, 20.0)
}

/// One axis: the orders chosen, the velocity lag against the truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisServoDoc {
    /// Axis name.
    pub axis: String,
    /// ARX orders chosen.
    pub orders: OrdersDoc,
    /// RMS of feedback minus the fitted servo simulated, mm or degree.
    pub simulation_rms: f64,
    /// The true servo's velocity lag, s.
    pub true_velocity_lag_s: f64,
    /// Velocity lag of the fitted servo, s (`null` without a static gain).
    pub velocity_lag_s: Option<f64>,
}

/// The servo summary (`servo` in the demo's JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServoIdentificationDoc {
    /// One entry per axis, in machine axis order.
    pub axis: Vec<AxisServoDoc>,
    /// Axes identified.
    pub axes: usize,
    /// Largest |fitted − true| velocity lag, s.
    pub largest_velocity_lag_error_s: f64,
    /// The file the caller wrote the twin machine to (empty if none).
    pub machine: String,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
}

impl fmt::Display for ServoIdentificationDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for a in &self.axis {
            writeln!(
                f,
                "{}: orders {}, velocity lag {:.3} ms (truth {:.3} ms), simulation RMS {:.2} µm",
                a.axis,
                a.orders.orders(),
                a.velocity_lag_s.unwrap_or(f64::NAN) * 1e3,
                a.true_velocity_lag_s * 1e3,
                a.simulation_rms * 1e3
            )?;
        }
        Ok(())
    }
}

/// What [`run`] found.
#[derive(Debug, Clone)]
pub struct ServoIdentificationRun {
    /// The summary.
    pub doc: ServoIdentificationDoc,
    /// The machine with the identified servos (`[axes.servo]`).
    pub twin: Machine,
    /// The fit of every axis, by axis name.
    pub fits: Vec<(String, ServoFitDoc)>,
}

/// Simulates a log of every axis of `machine` ([`excitation`] through its
/// true servo, [`double_pole`], plus Gaussian encoder noise), fits each and
/// writes the fitted servos into a copy of `machine`.
pub fn run(machine: &Machine, opts: &Options) -> Result<ServoIdentificationRun> {
    run_inner(machine, opts).map_err(ScenarioError::new)
}

fn run_inner(m: &Machine, opts: &Options) -> Inner<ServoIdentificationRun> {
    let t0 = Instant::now();
    let Some(&last_pole) = opts.poles.last() else {
        return Err("the servo scenario needs at least one pole".into());
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(opts.seed);
    let noise = Normal::new(0.0, opts.noise)?;
    let mut fits = Vec::new();
    let mut axes = Vec::new();
    let mut twin = m.clone();
    let mut worst_lag = 0.0f64;
    for (k, axis) in m.axes.iter().enumerate() {
        let truth = double_pole(opts.ts, *opts.poles.get(k).unwrap_or(&last_pole))?;
        let cmd = excitation(truth.ts());
        let fb: Vec<f64> = truth
            .simulate(&cmd)
            .into_iter()
            .map(|y| y + noise.sample(&mut rng))
            .collect();
        let fit = fit_servo(
            &ServoLog::new(truth.ts(), cmd, fb)?,
            &ServoFitOptions::default(),
        )?;
        let lag_true = truth.velocity_lag_s()?;
        let lag = fit.velocity_lag_s.unwrap_or(f64::NAN);
        worst_lag = worst_lag.max((lag - lag_true).abs());
        axes.push(AxisServoDoc {
            axis: axis.name.clone(),
            orders: (&fit.selection.table[fit.selection.best].orders).into(),
            simulation_rms: fit.simulation_rms,
            true_velocity_lag_s: lag_true,
            velocity_lag_s: fit.velocity_lag_s,
        });
        twin.axes[k].servo = Some(ServoTable {
            ts: fit.servo.ts(),
            b: fit.servo.b().to_vec(),
            a: fit.servo.a().to_vec(),
            nk: fit.servo.nk(),
        });
        fits.push((axis.name.clone(), ServoFitDoc::new(&fit)));
    }
    Ok(ServoIdentificationRun {
        doc: ServoIdentificationDoc {
            axes: axes.len(),
            axis: axes,
            largest_velocity_lag_error_s: worst_lag,
            machine: String::new(),
            seconds: since(t0),
        },
        twin,
        fits,
    })
}

impl ServoIdentificationRun {
    /// The report section: the fit of every axis.
    pub fn sections(&self) -> Vec<Section> {
        vec![sections::servo::section(&self.fits)]
    }
}
