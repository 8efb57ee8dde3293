//! `mtwin thermal compensate` (pre-compensation as in [R4], docs/references.md): rewrite
//! the Z targets of an NC program so that the predicted thermal drift is
//! cancelled; every other byte stays the same.

use std::path::PathBuf;

use anyhow::Context;
use mtwin::methods::thermal::{
    CompensateError, CompensateOptions, CorrectionUpdate, PlannedTiming, compensate, read_model,
};
use mtwin::report::svg::{Series, xy};

use super::common::{DialectArgs, PlanArgs, diag, load_machine};
use crate::output::{Format, note, print_doc};

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Thermal model (TOML, from `mtwin thermal fit`), speed_rpm its only input.
    #[arg(long)]
    model: PathBuf,
    /// The NC program to compensate.
    #[arg(long)]
    program: PathBuf,
    /// The compensated program (not written when anything fails).
    #[arg(long)]
    out: PathBuf,
    /// The correction is held over intervals of this length, min.
    #[arg(long, default_value_t = 10.0, conflicts_with = "continuous")]
    period_min: f64,
    /// Update the correction at every block instead of once per period.
    #[arg(long)]
    continuous: bool,
    /// Rapid (G0) rate along the path, mm/min (without --machine; with it
    /// the machine's `rapid_feed`).
    #[arg(long, default_value_t = 10_000.0)]
    rapid: f64,
    /// Machine model file (TOML): time the blocks with --planner on its axis
    /// limits (accelerations and junctions included) instead of the
    /// programmed feeds without accelerations.
    #[arg(long)]
    machine: Option<PathBuf>,
    #[command(flatten)]
    plan: PlanArgs,
    #[command(flatten)]
    dialect: DialectArgs,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
    /// Also write an SVG plot of the correction applied along the program
    /// (µm, at the end of every Z block, against the estimated time in min).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Compensate even with a model that is unstable at some height (a pole
    /// on or outside the unit circle); a drift that then diverges is still
    /// refused.
    #[arg(long)]
    allow_unstable: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.model)
        .input(&a.program)
        .output(&a.out)
        .outputs(&a.plot)
        .begin()?;
    let model = read_model(&a.model).map_err(diag)?;
    let machine = a.machine.as_deref().map(load_machine).transpose()?;
    if let (Some(m), Some(path)) = (&machine, &a.machine) {
        a.plan.check_machine(path, m)?;
    }
    let bytes = std::fs::read(&a.program)
        .with_context(|| format!("cannot read {}", a.program.display()))?;
    let mut options = CompensateOptions::default();
    options.dialect = a.dialect.dialect();
    options.program = a.dialect.program_options(&a.program)?;
    options.tools = a.dialect.tools()?;
    options.skip_deleted_blocks = a.dialect.skip_deleted_blocks();
    options.rapid_feed = a.rapid;
    options.allow_unstable = a.allow_unstable;
    options.timing = machine.map(|machine| PlannedTiming {
        machine,
        plan: a.plan.options(),
    });
    options.update = if a.continuous {
        CorrectionUpdate::Continuous
    } else {
        CorrectionUpdate::Periodic {
            period_min: a.period_min,
        }
    };
    let c = compensate(&model, &bytes, &options).map_err(|e| match &e {
        CompensateError::Gcode(g) => super::common::located_error(&a.program, g),
        CompensateError::Planner(p) => {
            super::gcode::located(&a.program, p.line(), p.column(), p.message())
        }
        CompensateError::Unsafe { line, .. } | CompensateError::Diverges { line, .. } => {
            super::gcode::located(&a.program, Some(*line), 0, e.message())
        }
        CompensateError::Unstable { .. } => {
            anyhow::anyhow!("{}: {e} (--allow-unstable)", a.model.display())
        }
        _ => anyhow::anyhow!("{e}"),
    })?;
    out.write(&a.out, &c.output)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    if let Some(path) = &a.plot {
        let points: Vec<(f64, f64)> = c
            .z_blocks
            .iter()
            .filter(|b| !b.g53)
            .map(|b| (b.end_min, b.correction_mm * 1e3))
            .collect();
        let series = [Series {
            name: "correction subtracted from Z".into(),
            points,
            color: "#d62728".into(),
            markers: false,
        }];
        let title = format!("Thermal correction along {}", a.program.display());
        let svg = xy(&title, "t (min)", "correction (µm)", &series);
        out.write(path, svg.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    out.commit()?;
    for n in &c.notes {
        note(n);
    }
    let span = c.changed_span_min();
    let doc = mtwin::methods::thermal::ThermalCompensateDoc {
        blocks: c.blocks,
        blocks_changed: c.blocks_changed(),
        changed_from_min: span.map(|s| s.0),
        changed_to_min: span.map(|s| s.1),
        duration_min: c.duration_min,
        max_correction_um: c.max_correction_mm() * 1e3,
        notes: c.notes.clone(),
        out: a.out.display().to_string(),
        spindle_used: c.spindle_used,
        z_blocks: c.z_blocks.len(),
    };
    print_doc(&doc, a.format)
}
