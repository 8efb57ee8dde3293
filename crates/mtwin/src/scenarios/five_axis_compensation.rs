//! Geometric compensation of a five-axis program: every target rewritten by
//! inverse kinematics on the machine with errors, so that it puts the tool
//! where the nominal machine would.

use std::fmt;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::methods::compensate::{CompensateDoc, CompensateOptions, Compensator};
use crate::model::Machine;
use crate::report::html::Section;
use crate::report::sections;

/// The step's heading.
pub const TITLE: &str = "Geometric compensation of a five-axis program";

/// The bundled five-axis test program (TCP), `examples/programs/s-curve-5axis.ngc`.
pub const S_CURVE_PROGRAM: &str = include_str!("../../../../examples/programs/s-curve-5axis.ngc");

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// The compensation's settings.
    pub compensate: CompensateOptions,
}

impl Default for Options {
    /// Tolerance 1 µm, corrections up to 2 mm, otherwise the defaults.
    fn default() -> Self {
        Options {
            compensate: CompensateOptions {
                tol: 0.001,
                max_correction: 2.0,
                ..Default::default()
            },
        }
    }
}

/// The compensation summary (`compensate` in the demo's JSON): the
/// compensation's own document, the program's name and the time taken.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FiveAxisCompensationDoc {
    /// What the compensation changed (`out`: the file the caller wrote the
    /// compensated program to, empty if none).
    #[serde(flatten)]
    pub compensation: CompensateDoc,
    /// Name of the program compensated.
    pub program: String,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
}

impl fmt::Display for FiveAxisCompensationDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = &self.compensation;
        writeln!(
            f,
            "{}: {} blocks, {} changed, largest correction {:.1} µm, largest deviation left at a checked midpoint {:.3} µm → {}",
            self.program,
            c.blocks,
            c.blocks_changed,
            c.largest_correction_um,
            c.largest_midpoint_deviation_um,
            c.out
        )
    }
}

/// What [`run`] found.
#[derive(Debug, Clone)]
pub struct FiveAxisCompensationRun {
    /// The summary.
    pub doc: FiveAxisCompensationDoc,
    /// The compensated program.
    pub output: Vec<u8>,
}

/// Compensates `program` (named `name` in the summary) for the geometric
/// errors of `machine`.
pub fn run(
    machine: &Machine,
    name: &str,
    program: &[u8],
    opts: &Options,
) -> Result<FiveAxisCompensationRun> {
    run_inner(machine, name, program, opts).map_err(ScenarioError::new)
}

fn run_inner(
    machine: &Machine,
    name: &str,
    program: &[u8],
    opts: &Options,
) -> Inner<FiveAxisCompensationRun> {
    let t0 = Instant::now();
    let comp = Compensator::new(machine, opts.compensate.clone())?;
    let mut output = Vec::new();
    let summary = comp.run(std::io::BufReader::new(program), &mut output)?;
    Ok(FiveAxisCompensationRun {
        doc: FiveAxisCompensationDoc {
            compensation: CompensateDoc::new(&summary, ""),
            program: name.into(),
            seconds: since(t0),
        },
        output,
    })
}

impl FiveAxisCompensationRun {
    /// The report section of the compensation.
    pub fn sections(&self) -> Vec<Section> {
        vec![sections::compensate::section(&self.doc.compensation)]
    }
}
