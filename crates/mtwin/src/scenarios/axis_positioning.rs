//! Axis positioning (ISO 230-2): a laser run of axis X of the AC trunnion
//! simulated from the machine's known positioning error `EXX` (plus a known
//! reversal and reading noise), evaluated after ISO 230-2, and its mean
//! bidirectional deviation written into the nominal model as a table.

use std::fmt;
use std::time::Instant;

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::methods::positioning::{PositioningDoc, Run, evaluate, update_machine};
use crate::model::{Component, Machine};
use crate::report::html::Section;
use crate::report::sections;

/// The step's heading.
pub const TITLE: &str = "Positioning: ISO 230-2 run of axis X, its table into the model";

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// The axis measured.
    pub axis: String,
    /// Target positions over the travel.
    pub targets: usize,
    /// Approaches per target and direction.
    pub cycles: usize,
    /// Reversal simulated (↑ reads +B/2, ↓ −B/2), µm.
    pub reversal_um: f64,
    /// Reading noise (standard deviation), µm.
    pub noise_um: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for Options {
    /// The demo's: axis X, 11 targets, 5 cycles, reversal 4 µm, noise 0.5 µm.
    fn default() -> Self {
        Options {
            axis: "X".into(),
            targets: 11,
            cycles: 5,
            reversal_um: 4.0,
            noise_um: 0.5,
            seed: 3,
        }
    }
}

/// The positioning summary (`positioning` in the demo's JSON), µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisPositioningDoc {
    /// The axis measured.
    pub axis: String,
    /// Targets × cycles.
    pub targets: usize,
    /// Approaches per target and direction.
    pub cycles: usize,
    /// Accuracy A.
    #[serde(rename = "A")]
    pub a_um: f64,
    /// Systematic positioning error E.
    #[serde(rename = "E")]
    pub e_um: f64,
    /// Repeatability R.
    #[serde(rename = "R")]
    pub r_um: f64,
    /// Reversal B.
    #[serde(rename = "B")]
    pub b_um: f64,
    /// Mean bidirectional positioning error M.
    #[serde(rename = "M")]
    pub m_um: f64,
    /// Reversal simulated.
    pub reversal_truth_um: f64,
    /// Noise simulated.
    pub noise_um: f64,
    /// The error written into the model (`EXX`).
    pub error: String,
    /// Largest |table − truth| at the targets, µm.
    pub largest_table_error_um: f64,
    /// Largest |truth| at the targets, µm.
    pub largest_truth_um: f64,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
}

impl fmt::Display for AxisPositioningDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "axis {}: {} targets × {} cycles per direction, simulated from the example machine's {} with a {:.0} µm reversal and {:.1} µm noise",
            self.axis, self.targets, self.cycles, self.error, self.reversal_truth_um, self.noise_um
        )?;
        writeln!(
            f,
            "ISO 230-2: A {:.2} µm, E {:.2} µm, R {:.2} µm, B {:.2} µm, M {:.2} µm",
            self.a_um, self.e_um, self.r_um, self.b_um, self.m_um
        )?;
        writeln!(
            f,
            "{} table into the nominal model: largest difference from the truth at the targets {:.2} µm (truth up to {:.1} µm)",
            self.error, self.largest_table_error_um, self.largest_truth_um
        )
    }
}

/// What [`run`] returns.
#[derive(Debug, Clone)]
pub struct AxisPositioningRun {
    /// The summary.
    pub doc: AxisPositioningDoc,
    /// The ISO 230-2 evaluation.
    pub evaluation: PositioningDoc,
    /// The nominal machine with the positioning table.
    pub machine: Machine,
}

/// Simulate the run on `truth` (its positioning error of `opts.axis`),
/// evaluate it, and write the table into `nominal`.
pub fn run(truth: &Machine, nominal: &Machine, opts: &Options) -> Result<AxisPositioningRun> {
    run_inner(truth, nominal, opts).map_err(ScenarioError::new)
}

fn run_inner(truth: &Machine, nominal: &Machine, opts: &Options) -> Inner<AxisPositioningRun> {
    let t0 = Instant::now();
    let i = truth
        .axis_index(&opts.axis)
        .ok_or_else(|| format!("the machine has no axis {}", opts.axis))?;
    let ax = &truth.axes[i];
    let comp = Component::ALL[(0..3)
        .max_by(|&a, &b| ax.direction[a].abs().total_cmp(&ax.direction[b].abs()))
        .unwrap_or(0)];
    let [lo, hi] = ax.travel;
    let m = opts.targets.max(2);
    let targets: Vec<f64> = (0..m)
        .map(|k| lo + (hi - lo) * k as f64 / (m - 1) as f64)
        .collect();
    let truth_mm: Vec<f64> = targets.iter().map(|&q| ax.pdge_at(comp, q)).collect();
    let mut rng = rand::rngs::StdRng::seed_from_u64(opts.seed);
    let noise = Normal::new(0.0, opts.noise_um * 1e-3)?;
    let half_b = 0.5 * opts.reversal_um * 1e-3;
    let mut dir = |sign: f64| -> Vec<Vec<f64>> {
        truth_mm
            .iter()
            .map(|t| {
                (0..opts.cycles)
                    .map(|_| t + sign * half_b + noise.sample(&mut rng))
                    .collect()
            })
            .collect()
    };
    let up = dir(1.0);
    let down = dir(-1.0);
    let evaluation = evaluate(&Run {
        source: format!("simulated {} run", opts.axis),
        targets_mm: targets.clone(),
        up_mm: up,
        down_mm: down,
        notes: vec![],
    })?;
    let (machine, update) = update_machine(nominal, &opts.axis, &evaluation)?;
    let largest = update
        .e
        .iter()
        .zip(&truth_mm)
        .map(|(e, t)| (e - t).abs() * 1e3)
        .fold(0.0, f64::max);
    let doc = AxisPositioningDoc {
        axis: opts.axis.clone(),
        targets: m,
        cycles: opts.cycles,
        a_um: evaluation.a_um,
        e_um: evaluation.e_um,
        r_um: evaluation.r_um,
        b_um: evaluation.b_um,
        m_um: evaluation.m_um,
        reversal_truth_um: opts.reversal_um,
        noise_um: opts.noise_um,
        error: update.error.to_string(),
        largest_table_error_um: largest,
        largest_truth_um: truth_mm.iter().map(|t| t.abs() * 1e3).fold(0.0, f64::max),
        seconds: since(t0),
    };
    Ok(AxisPositioningRun {
        doc,
        evaluation,
        machine,
    })
}

impl AxisPositioningRun {
    /// The report section.
    pub fn sections(&self) -> Vec<Section> {
        vec![sections::positioning::section(
            &self.evaluation,
            Some(&self.doc.axis),
        )]
    }
}
