//! Laser-tracker identification of a six-axis gantry ([R2] in
//! docs/references.md): measurement poses planned (D-optimal), measured on
//! the machine with errors (simulated), a volumetric error model identified
//! on the nominal one and validated on the four body diagonals.

use std::fmt;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::methods::tracker::{self, Identification, IdentifyOptions, Validation};
use crate::model::{Machine, ParameterSet};
use crate::report::html::{Block, Headline, Section};
use crate::report::sections;

/// The step's heading.
pub const TITLE: &str = "Tracker: volumetric error model of the six-axis gantry";

/// The change of the largest and of the mean |Δp| on the body diagonals in
/// the source paper [R2], percent.
pub const SOURCE_CHANGE_PERCENT: [f64; 2] = [-70.0, -81.0];

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// The error parameters identified (`ParameterSet::from_spec`).
    pub spec: String,
    /// Candidate poses drawn in the travels.
    pub candidates: usize,
    /// Poses chosen among them.
    pub poses: usize,
    /// Tracker noise (standard deviation per coordinate), mm.
    pub noise: f64,
    /// Poses per body diagonal for the validation.
    pub per_diagonal: usize,
    /// Random seeds of the plan and measurement, and of the validation.
    pub seeds: [u64; 2],
}

impl Default for Options {
    /// The demo's: `pdge:cheb3,location`, 180 of 1000 poses, 10 µm noise,
    /// 25 poses per diagonal.
    fn default() -> Self {
        Options {
            spec: "pdge:cheb3,location".into(),
            candidates: 1000,
            poses: 180,
            noise: 0.010,
            per_diagonal: 25,
            seeds: [1, 2],
        }
    }
}

/// The tracker summary (`tracker` in the demo's JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GantryTrackerDoc {
    /// Candidate poses.
    pub candidates: usize,
    /// Condition number of the scaled identification problem.
    pub condition_number: f64,
    /// Change of the largest |Δp| on the diagonals, percent.
    pub diagonal_change_max_percent: f64,
    /// Change of the mean |Δp| on the diagonals, percent.
    pub diagonal_change_mean_percent: f64,
    /// Largest |Δp| on the diagonals: nominal model (before) and identified
    /// model (after), mm.
    pub diagonal_max_mm: [f64; 2],
    /// Mean |Δp| on the diagonals, before and after, mm.
    pub diagonal_mean_mm: [f64; 2],
    /// Points measured on the diagonals.
    pub diagonal_points: usize,
    /// Measurement noise simulated, mm.
    pub noise_mm: f64,
    /// Error parameters of the model.
    pub parameters: usize,
    /// Poses planned and measured.
    pub poses: usize,
    /// Rank of the identification problem.
    pub rank: usize,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
    /// The source paper's [R2] change of the largest |Δp|, percent.
    pub source_change_max_percent: f64,
    /// The source paper's [R2] change of the mean |Δp|, percent.
    pub source_change_mean_percent: f64,
    /// The error parameters identified.
    pub spec: String,
}

impl fmt::Display for GantryTrackerDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "planned {} of {} candidate poses (D-optimal), simulated with {:.0} µm noise; fit `{}`: rank {} of {} parameters, condition number {:.2e}",
            self.poses,
            self.candidates,
            self.noise_mm * 1e3,
            self.spec,
            self.rank,
            self.parameters,
            self.condition_number
        )?;
        writeln!(
            f,
            "validation on the four body diagonals ({} points): |Δp| max {:.0} → {:.0} µm ({:.0} %), mean {:.0} → {:.0} µm ({:.0} %) (source paper [R2]: max {}, mean {})",
            self.diagonal_points,
            self.diagonal_max_mm[0] * 1e3,
            self.diagonal_max_mm[1] * 1e3,
            self.diagonal_change_max_percent,
            self.diagonal_mean_mm[0] * 1e3,
            self.diagonal_mean_mm[1] * 1e3,
            self.diagonal_change_mean_percent,
            percent(self.source_change_max_percent),
            percent(self.source_change_mean_percent)
        )
    }
}

/// `−70 %` with a true minus sign, as the source prints it.
fn percent(v: f64) -> String {
    format!("{:.0} %", v).replace('-', "−")
}

/// What [`run`] found.
#[derive(Debug, Clone)]
pub struct GantryTrackerRun {
    /// The summary.
    pub doc: GantryTrackerDoc,
    /// The identification (its `machine` is the identified model).
    pub identification: Identification,
    /// Points measured for the fit.
    pub points: usize,
    /// The validation on the body diagonals.
    pub validation: Validation,
    /// The machine measured (the truth).
    pub truth: Machine,
}

/// Plans `poses` of `candidates` poses on `model` (D-optimal for `spec`),
/// measures them on `truth` with `noise`, identifies `spec` on `model` and
/// validates the identified machine on the four body diagonals
/// (`tracker::simulate::body_diagonal_poses`) measured on `truth`.
pub fn run(truth: &Machine, model: &Machine, opts: &Options) -> Result<GantryTrackerRun> {
    run_inner(truth, model, opts).map_err(ScenarioError::new)
}

fn run_inner(truth: &Machine, model: &Machine, opts: &Options) -> Inner<GantryTrackerRun> {
    let t0 = Instant::now();
    let params = ParameterSet::from_spec(model, &opts.spec)?;
    let plan = tracker::plan::plan(
        model,
        &params,
        opts.candidates,
        opts.poses,
        opts.noise,
        opts.seeds[0],
    )?;
    let points = tracker::simulate::simulate_seeded(truth, &plan.poses, opts.noise, opts.seeds[0]);
    let id = tracker::identify(
        model,
        &params,
        &points,
        &IdentifyOptions::default(),
        &|_| {},
    )?;
    let diagonals = tracker::simulate::body_diagonal_poses(model, opts.per_diagonal);
    let check = tracker::simulate::simulate_seeded(truth, &diagonals, opts.noise, opts.seeds[1]);
    let v = tracker::validate(&id.machine, &check);
    let r = &id.report;
    let doc = GantryTrackerDoc {
        candidates: opts.candidates,
        condition_number: r.condition_number,
        diagonal_change_max_percent: v.change.distance.max,
        diagonal_change_mean_percent: v.change.distance.mean,
        diagonal_max_mm: [v.before.distance.max, v.after.distance.max],
        diagonal_mean_mm: [v.before.distance.mean, v.after.distance.mean],
        diagonal_points: v.points,
        noise_mm: opts.noise,
        parameters: r.estimates.len(),
        poses: plan.poses.len(),
        rank: r.identifiability.rank,
        seconds: since(t0),
        source_change_max_percent: SOURCE_CHANGE_PERCENT[0],
        source_change_mean_percent: SOURCE_CHANGE_PERCENT[1],
        spec: opts.spec.clone(),
    };
    Ok(GantryTrackerRun {
        doc,
        identification: id,
        points: points.len(),
        validation: v,
        truth: truth.clone(),
    })
}

impl GantryTrackerRun {
    /// The report sections: the identification (its model written to
    /// `identified_file`), the validation with the headlines against the
    /// source paper, the identified error curves against the truth.
    pub fn sections(&self, identified_file: &str) -> Vec<Section> {
        let v = &self.validation;
        let id_doc =
            tracker::TrackerIdentifyDoc::new(&self.identification, self.points, identified_file);
        let before: Vec<f64> = v.errors_before.iter().map(|e| e.norm()).collect();
        let after: Vec<f64> = v.errors_after.iter().map(|e| e.norm()).collect();
        let mut vs = sections::tracker::validate_section(
            &tracker::TrackerValidateDoc::from(v),
            Some((&before, &after)),
        );
        let d = &self.doc;
        vs.blocks.insert(
            1,
            Block::Headlines(vec![
                Headline {
                    label: "body diagonals, change of the largest |Δp|".into(),
                    ours: format!("{:.0} %", d.diagonal_change_max_percent),
                    source: percent(d.source_change_max_percent),
                },
                Headline {
                    label: "body diagonals, change of the mean |Δp|".into(),
                    ours: format!("{:.0} %", d.diagonal_change_mean_percent),
                    source: percent(d.source_change_mean_percent),
                },
            ]),
        );
        vec![
            sections::tracker::identify_section(&id_doc),
            vs,
            sections::machine::section_against(
                &self.identification.machine,
                Some(&self.truth),
                "gantry-identified",
                "Identified gantry: error curves over the travels",
            ),
        ]
    }
}
