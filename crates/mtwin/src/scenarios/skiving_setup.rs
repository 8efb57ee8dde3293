//! Skiving set-up: touch-offs of the skiving tool simulated on a workpiece
//! with a known set-up error (offsets δgx, δgy and tilts εxz, εzy), the
//! set-up error identified from them.

use std::fmt;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::methods::skiving::{
    self, Geometry, SetupError, Solution, closed_form, program::Plan, simulate::Noise,
};
use crate::report::html::Section;
use crate::report::sections;

/// The step's heading.
pub const TITLE: &str = "Skiving: workpiece set-up error from touch-offs";

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// Workpiece and tool geometry.
    pub geometry: Geometry,
    /// The set-up error simulated (mm, rad).
    pub truth: SetupError,
    /// Touch noise (standard deviation), mm.
    pub noise: f64,
    /// One run of the standard touch plan per seed.
    pub seeds: Vec<u64>,
}

impl Default for Options {
    /// The demo's: geometry 80, 150, 40, 60 mm; set-up error 30, −20 µm,
    /// 200, −100 µrad; 1 µm noise; the six touches of the standard plan twice.
    fn default() -> Self {
        Options {
            geometry: Geometry::new(80.0, 150.0, 40.0, 60.0).expect("a valid geometry"),
            truth: SetupError {
                dgx: 0.03,
                dgy: -0.02,
                exz: 2e-4,
                ezy: -1e-4,
            },
            noise: 0.001,
            seeds: vec![1, 2],
        }
    }
}

/// The skiving summary (`skiving` in the demo's JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkivingSetupScenarioDoc {
    /// Identified workpiece offset along x, mm.
    pub dgx: f64,
    /// Identified workpiece offset along y, mm.
    pub dgy: f64,
    /// Identified tilt about y, rad.
    pub exz: f64,
    /// Identified tilt about x, rad.
    pub ezy: f64,
    /// Touch noise simulated, mm.
    pub noise_mm: f64,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
    /// Touches simulated.
    pub touches: usize,
    /// The set-up error simulated.
    pub truth: SetupError,
    /// Standard uncertainties of the identified values (mm, rad).
    pub uncertainty: Option<SetupError>,
}

impl fmt::Display for SkivingSetupScenarioDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} touches ({:.0} µm noise): δgx {:.2} µm, δgy {:.2} µm, εxz {:.1} µrad, εzy {:.1} µrad",
            self.touches,
            self.noise_mm * 1e3,
            self.dgx * 1e3,
            self.dgy * 1e3,
            self.exz * 1e6,
            self.ezy * 1e6
        )?;
        let t = &self.truth;
        let signed = |v: f64| format!("{v:.0}").replace('-', "−");
        writeln!(
            f,
            "truth {}, {} µm, {}, {} µrad: off by {:.2}, {:.2} µm, {:.2}, {:.2} µrad",
            signed(t.dgx * 1e3),
            signed(t.dgy * 1e3),
            signed(t.exz * 1e6),
            signed(t.ezy * 1e6),
            (self.dgx - t.dgx) * 1e3,
            (self.dgy - t.dgy) * 1e3,
            (self.exz - t.exz) * 1e6,
            (self.ezy - t.ezy) * 1e6
        )
    }
}

/// What [`run`] found.
#[derive(Debug, Clone)]
pub struct SkivingSetupRun {
    /// The summary.
    pub doc: SkivingSetupScenarioDoc,
    /// The identification.
    pub solution: Solution,
    /// The first-order closed form from the first six touches, when it solves.
    pub first_order: Option<SetupError>,
}

/// Simulates the standard touch plan once per seed on a workpiece set up
/// with `truth`, with `noise`, and identifies the set-up error (the noise
/// known).
pub fn run(opts: &Options) -> Result<SkivingSetupRun> {
    run_inner(opts).map_err(ScenarioError::new)
}

fn run_inner(opts: &Options) -> Inner<SkivingSetupRun> {
    let t0 = Instant::now();
    let g = &opts.geometry;
    let plan = Plan::standard(0.0, g).touches(g)?;
    let mut touches = Vec::new();
    for &seed in &opts.seeds {
        touches.extend(skiving::simulate::simulate(
            &plan,
            g,
            &opts.truth,
            Some(Noise {
                sigma: opts.noise,
                seed,
            }),
        )?);
    }
    let sol = skiving::identify(&touches, g, &skiving::Options::with_noise(Some(opts.noise)))?;
    let first_order = closed_form::first_order(&touches[..plan.len().min(touches.len())], g).ok();
    let e = sol.estimate;
    let doc = SkivingSetupScenarioDoc {
        dgx: e.dgx,
        dgy: e.dgy,
        exz: e.exz,
        ezy: e.ezy,
        noise_mm: opts.noise,
        seconds: since(t0),
        touches: touches.len(),
        truth: opts.truth,
        uncertainty: sol.uncertainty.as_ref().map(|u| SetupError {
            dgx: u.std[0],
            dgy: u.std[1],
            exz: u.std[2],
            ezy: u.std[3],
        }),
    };
    Ok(SkivingSetupRun {
        doc,
        solution: sol,
        first_order,
    })
}

impl SkivingSetupRun {
    /// The report section of the identification.
    pub fn sections(&self) -> Vec<Section> {
        vec![sections::skiving::section(
            &skiving::doc::SkivingSetupDoc::new(&self.solution, self.first_order, self.doc.touches),
        )]
    }
}
