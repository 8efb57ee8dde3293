//! Circular test (ISO 230-4): clockwise and counter-clockwise ballbar traces
//! in XY simulated with known errors, the circle run at a feed through the
//! servo models of the X and Y axes (those identified by the servo step),
//! diagnosed, and the squareness and scale mismatch written into the nominal
//! model.

use std::fmt;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::methods::ballbar::circular::{CircularDoc, CircularOptions, Plane, Trace, circular};
use crate::methods::ballbar::circular_model::update_machine;
use crate::methods::ballbar::circular_sim::{
    CircularErrors, ServoPair, servo_signature, simulate_circular,
};
use crate::model::Machine;
use crate::report::html::Section;
use crate::report::sections;
use crate::sysid::Servo;

/// The step's heading.
pub const TITLE: &str = "Circular test (ISO 230-4): ballbar diagnosis into the model";

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// Radius, mm.
    pub radius_mm: f64,
    /// Feed, mm/min.
    pub feed_mm_min: f64,
    /// The errors simulated besides the servos.
    pub errors: CircularErrors,
    /// Reading noise, µm.
    pub noise_um: f64,
    /// Samples per direction.
    pub samples: usize,
}

impl Default for Options {
    /// The demo's: R 150 mm at 3000 mm/min, backlash X 6 µm and Y −4 µm,
    /// squareness 30 µm/m, scale mismatch 8 µm (the servos add their own,
    /// [`Recovered::servo_part`]), 0.2 µm noise, 3600 samples.
    fn default() -> Self {
        Options {
            radius_mm: 150.0,
            feed_mm_min: 3000.0,
            errors: CircularErrors {
                backlash_x_um: 6.0,
                backlash_y_um: -4.0,
                squareness_um_per_m: 30.0,
                scale_mismatch_um: 8.0,
                ..Default::default()
            },
            noise_um: 0.2,
            samples: 3600,
        }
    }
}

/// One diagnostic against its truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Recovered {
    /// JSON key of the diagnostic.
    pub key: String,
    /// Simulated value: the geometric error put in plus `servo_part`.
    pub truth: f64,
    /// The part of `truth` the two servo models give (closed form,
    /// `circular_sim::servo_signature`); absent for a diagnostic servos do
    /// not touch.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub servo_part: Option<f64>,
    /// Diagnosed value (`None`: not separable).
    pub value: Option<f64>,
}

/// The circular-test summary (`circular` in the demo's JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CircularTestDoc {
    /// Radius, mm.
    pub radius_mm: f64,
    /// Feed, mm/min.
    pub feed_mm_min: f64,
    /// Circular deviation G, µm.
    #[serde(rename = "G")]
    pub g_um: f64,
    /// Circular hysteresis H, µm.
    #[serde(rename = "H")]
    pub h_um: Option<f64>,
    /// Radial deviation F, µm.
    #[serde(rename = "F")]
    pub f_um: f64,
    /// The diagnostics simulated and what came back.
    pub recovered: Vec<Recovered>,
    /// The changes to the nominal model, one sentence each.
    pub model_changes: Vec<String>,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
}

impl fmt::Display for CircularTestDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "R {} mm in XY at {} mm/min through the X and Y servo models: G {:.2} µm, H {} µm, F {:.2} µm",
            crate::io::fmt_f64(self.radius_mm),
            crate::io::fmt_f64(self.feed_mm_min),
            self.g_um,
            self.h_um.map_or("—".into(), |h| format!("{h:.2}")),
            self.f_um
        )?;
        let parts: Vec<String> = self
            .recovered
            .iter()
            .map(|r| {
                let value = r.value.map_or("—".into(), |v| format!("{v:.2}"));
                match r.servo_part {
                    Some(s) => format!(
                        "{} {value} (truth {:.2} = {:.2} geometric {} {:.2} servo)",
                        r.key,
                        r.truth,
                        r.truth - s,
                        if s < 0.0 { '−' } else { '+' },
                        s.abs()
                    ),
                    None => format!("{} {value} (truth {:.2})", r.key, r.truth),
                }
            })
            .collect();
        writeln!(f, "{}", parts.join(", "))?;
        writeln!(
            f,
            "into the nominal model: {}",
            self.model_changes.join("; ")
        )
    }
}

/// What [`run`] returns.
#[derive(Debug, Clone)]
pub struct CircularTestRun {
    /// The summary.
    pub doc: CircularTestDoc,
    /// The diagnosis.
    pub diagnosis: CircularDoc,
    /// The traces (clockwise, counter-clockwise).
    pub traces: [Trace; 2],
    /// The nominal machine with the squareness and scale mismatch.
    pub machine: Machine,
}

fn servo_of(m: &Machine, axis: &str) -> Inner<Servo> {
    let i = m
        .axis_index(axis)
        .ok_or_else(|| format!("the machine has no axis {axis}"))?;
    let t = m.axes[i]
        .servo
        .as_ref()
        .ok_or_else(|| format!("axis {axis} has no servo model"))?;
    Ok(Servo::new(t.ts, t.b.clone(), t.a.clone(), t.nk)?)
}

/// Simulate the test with the X and Y servos of `servos` (a machine with
/// `[axes.servo]` tables), diagnose it and update `nominal`.
pub fn run(servos: &Machine, nominal: &Machine, opts: &Options) -> Result<CircularTestRun> {
    run_inner(servos, nominal, opts).map_err(ScenarioError::new)
}

fn run_inner(servos: &Machine, nominal: &Machine, opts: &Options) -> Inner<CircularTestRun> {
    let t0 = Instant::now();
    let (sx, sy) = (servo_of(servos, "X")?, servo_of(servos, "Y")?);
    let pair = ServoPair {
        first: sx,
        second: sy,
        feed_mm_min: opts.feed_mm_min,
    };
    // What the two models put on the circle (closed form): the servo
    // mismatch of their phase lags, and a scale mismatch of their different
    // gains and phases at ω = v/R.
    let sig = servo_signature(&pair, opts.radius_mm);
    let mut e = opts.errors.clone();
    e.servos = Some(pair);
    let o = CircularOptions {
        radius_mm: opts.radius_mm,
        plane: Plane::Xy,
        ..Default::default()
    };
    let cw = simulate_circular(&e, &o, false, opts.samples, opts.noise_um, 21);
    let ccw = simulate_circular(&e, &o, true, opts.samples, opts.noise_um, 21);
    let d = circular(Some(&cw), Some(&ccw), &o)?;
    let recovered = [
        ("backlash_x_um", e.backlash_x_um, None),
        ("backlash_y_um", e.backlash_y_um, None),
        ("squareness_um_per_m", e.squareness_um_per_m, None),
        (
            "scale_mismatch_um",
            e.scale_mismatch_um,
            Some(sig.scale_mismatch_um),
        ),
        (
            "servo_mismatch_um",
            e.servo_mismatch_um,
            Some(sig.servo_mismatch_um),
        ),
    ]
    .into_iter()
    .map(|(k, geometric, servo_part)| Recovered {
        key: k.into(),
        truth: geometric + servo_part.unwrap_or(0.0),
        servo_part,
        value: d.get(k),
    })
    .collect();
    let (machine, changes) = update_machine(nominal, &d)?;
    let doc = CircularTestDoc {
        radius_mm: opts.radius_mm,
        feed_mm_min: opts.feed_mm_min,
        g_um: d.g_um,
        h_um: d.h_um,
        f_um: d.f_um,
        recovered,
        model_changes: changes
            .iter()
            .map(|c| format!("{} {}", c.error, c.note))
            .collect(),
        seconds: since(t0),
    };
    Ok(CircularTestRun {
        doc,
        diagnosis: d,
        traces: [cw, ccw],
        machine,
    })
}

impl CircularTestRun {
    /// The report section.
    pub fn sections(&self) -> Vec<Section> {
        vec![sections::circular::section(&self.diagnosis)]
    }
}
