//! `mtwin thermal compensate` (pre-compensation as in [R4], docs/references.md): rewrite
//! the Z targets of an NC program so that the predicted thermal drift is
//! cancelled (with a log model of `thermal fit --log`: the X, Y and Z
//! targets of every axis the model has a channel for); every other byte
//! stays the same.

use std::path::PathBuf;

use anyhow::Context;
use mtwin::methods::thermal::log::LogModel;
use mtwin::methods::thermal::{
    CompensateAxisDoc, CompensateError, CompensateOptions, Compensation, CorrectionUpdate,
    LogCompensateOptions, PlannedTiming, compensate, compensate_log, is_log_model, read_model,
};
use mtwin::report::svg::{Series, xy};

use super::common::{DialectArgs, PlanArgs, diag, load_machine};
use crate::output::{Format, note, print_doc};

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Thermal model (TOML): a height model of `thermal fit --data` (speed_rpm its only input;
    /// Z corrected), or a log model of `thermal fit --log` (every axis with a drift channel
    /// corrected: X, Y and/or Z).
    #[arg(long)]
    model: PathBuf,
    /// Log model only: the model's inputs other than the spindle speed over the program's time,
    /// a CSV with a `t_s` or `t_min` column (its first row is the program's start) and those
    /// columns, averaged over the model's periods (temperatures as their rise since the first
    /// period). Where the program runs longer, the last period's means are held (with a note).
    #[arg(long, value_name = "FILE.csv")]
    inputs_log: Option<PathBuf>,
    /// Log model only: the drift channels to compensate with, comma separated, at most one per
    /// axis (default: every channel, refused when two act on one axis).
    #[arg(long, value_delimiter = ',', value_name = "COLUMN")]
    channel: Vec<String>,
    /// Log model only: the model input that is the spindle speed, taken from the program.
    #[arg(long, default_value = "speed_rpm", value_name = "COLUMN")]
    speed_column: String,
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
    /// (µm, at the end of every Z block, against the estimated time in min;
    /// with a log model one curve per corrected axis).
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
        .inputs(&a.inputs_log)
        .inputs(&a.machine)
        .output(&a.out)
        .outputs(&a.plot)
        .begin()?;
    let text = std::fs::read_to_string(&a.model)
        .with_context(|| format!("cannot read {}", a.model.display()))?;
    let log_model = is_log_model(&text);
    if !log_model {
        let given = [
            (a.inputs_log.is_some(), "--inputs-log"),
            (!a.channel.is_empty(), "--channel"),
            (a.speed_column != "speed_rpm", "--speed-column"),
        ];
        if let Some((_, flag)) = given.iter().find(|g| g.0) {
            anyhow::bail!(
                "{}: {flag} is for a log model (`thermal fit --log`); this is a height model (its only input the spindle speed, Z corrected)",
                a.model.display()
            );
        }
    }
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
    options.machine_axes = a.dialect.machine_axes(machine.as_ref())?;
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
    let located = |e: CompensateError| match &e {
        CompensateError::Gcode(g) => super::common::located_error(&a.program, g),
        CompensateError::Planner(p) => {
            super::gcode::located(&a.program, p.line(), p.column(), p.message())
        }
        CompensateError::Unsafe { line, .. } | CompensateError::Diverges { line, .. } => {
            super::gcode::located(&a.program, Some(*line), 0, e.message())
        }
        CompensateError::Unstable { .. } | CompensateError::UnstableChannel { .. } => {
            anyhow::anyhow!("{}: {e} (--allow-unstable)", a.model.display())
        }
        CompensateError::MissingInputs { .. } => {
            anyhow::anyhow!("{}: {e} (--inputs-log FILE.csv)", a.model.display())
        }
        CompensateError::Channels(_) => {
            anyhow::anyhow!("{}: {e} (--channel COLUMN)", a.model.display())
        }
        CompensateError::InputsLog(d) => diag(d.clone()),
        _ => anyhow::anyhow!("{e}"),
    };
    // Per corrected axis: its letter and the channel (None: the height model's Z).
    let (c, axes): (Compensation, Vec<(mtwin::gcode::Axis, Option<String>)>) = if log_model {
        let model = LogModel::from_toml_str(&a.model, &text).map_err(diag)?;
        let table = match &a.inputs_log {
            Some(p) => Some(mtwin::io::Table::read(p).map_err(diag)?),
            None => None,
        };
        let mut o = LogCompensateOptions::default();
        o.compensate = options;
        o.channels = a.channel.clone();
        o.speed_column = a.speed_column.clone();
        let c = compensate_log(&model, &bytes, table.as_ref(), &o).map_err(located)?;
        let mut axes: Vec<_> = model
            .channels
            .iter()
            .filter(|ch| a.channel.is_empty() || a.channel.contains(&ch.channel.column))
            .map(|ch| {
                let axis = match ch.channel.axis {
                    mtwin::methods::thermal::log::Axis::X => mtwin::gcode::Axis::X,
                    mtwin::methods::thermal::log::Axis::Y => mtwin::gcode::Axis::Y,
                    mtwin::methods::thermal::log::Axis::Z => mtwin::gcode::Axis::Z,
                };
                (axis, Some(ch.channel.column.clone()))
            })
            .collect();
        axes.sort_by_key(|(axis, _)| axis.index());
        (c, axes)
    } else {
        let model = read_model(&a.model).map_err(diag)?;
        let c = compensate(&model, &bytes, &options).map_err(located)?;
        (c, vec![(mtwin::gcode::Axis::Z, None)])
    };
    out.write(&a.out, &c.output)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    if let Some(path) = &a.plot {
        const COLORS: [&str; 3] = ["#1f77b4", "#2ca02c", "#d62728"];
        let series: Vec<Series> = axes
            .iter()
            .map(|(axis, channel)| {
                let letter = axis.letter() as char;
                let points: Vec<(f64, f64)> = c
                    .axis_blocks
                    .iter()
                    .filter(|b| b.axis == *axis && !b.g53)
                    .map(|b| (b.end_min, b.correction_mm * 1e3))
                    .collect();
                Series {
                    name: match channel {
                        Some(ch) => format!("correction subtracted from {letter} ({ch})"),
                        None => format!("correction subtracted from {letter}"),
                    },
                    points,
                    color: COLORS[if channel.is_some() { axis.index() } else { 2 }].into(),
                    markers: false,
                }
            })
            .collect();
        let title = format!("Thermal correction along {}", a.program.display());
        let svg = xy(&title, "t (min)", "correction (µm)", &series);
        out.write(path, svg.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    out.commit()?;
    for n in &c.notes {
        note(n);
    }
    let axis_docs: Vec<CompensateAxisDoc> = if log_model {
        axes.iter()
            .map(|(axis, channel)| {
                let s = c.axis_summary(*axis);
                CompensateAxisDoc {
                    axis: (axis.letter() as char).to_string(),
                    channel: channel.clone().unwrap_or_default(),
                    blocks: s.blocks,
                    blocks_changed: s.changed,
                    max_correction_um: s.max_correction_mm * 1e3,
                    changed_from_min: s.changed_span_min.map(|s| s.0),
                    changed_to_min: s.changed_span_min.map(|s| s.1),
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    let span = if log_model {
        let changed = c.axis_blocks.iter().filter(|b| b.changed);
        let first = changed.clone().map(|b| b.end_min).next();
        first.zip(changed.map(|b| b.end_min).next_back())
    } else {
        c.changed_span_min()
    };
    let doc = mtwin::methods::thermal::ThermalCompensateDoc {
        blocks: c.blocks,
        blocks_changed: if log_model {
            c.lines_changed()
        } else {
            c.blocks_changed()
        },
        changed_from_min: span.map(|s| s.0),
        changed_to_min: span.map(|s| s.1),
        duration_min: c.duration_min,
        max_correction_um: if log_model {
            axis_docs
                .iter()
                .map(|d| d.max_correction_um)
                .fold(0.0, f64::max)
        } else {
            c.max_correction_mm() * 1e3
        },
        notes: c.notes.clone(),
        out: a.out.display().to_string(),
        spindle_used: c.spindle_used,
        z_blocks: c.z_blocks.len(),
        axes: axis_docs,
    };
    print_doc(&doc, a.format)
}
