//! `mtwin twin predict` ([R5] in docs/references.md): the five-axis digital twin of
//! trajectory error. Commands (CMD.csv or a G-code program) → command and actual
//! tool tip and tool axis in W → tool-tip error ε_p (mm) and tool-axis error ε_o
//! (rad) against the exact nearest point of the command path, per sample, in
//! PRED.csv.

use std::path::PathBuf;

use anyhow::Context;
use mtwin::gcode::InterpolateOptions;
use mtwin::methods::twin::{self, Commands, PredictOptions, Progress, Sources, TwinError};

use super::common::load_machine;
use super::common::{DialectArgs, PlanArgs};
use super::gcode::{interp_options, located};
use crate::output::{Format, TableWriter, print_doc, progress};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Predict the tool-tip and tool-axis trajectory errors of a program or of axis commands.
    #[command(
        after_help = "Example:\n  mtwin twin predict --machine examples/machines/ac-trunnion-twin.toml --commands cmd.csv --out pred.csv\n  mtwin twin predict --machine examples/machines/ac-trunnion-twin.toml --gcode part.nc --tcp --ts 0.001 --out pred.csv --plot plots --format json\n  mtwin twin predict --machine examples/machines/ac-trunnion-twin.toml --gcode part.nc --planner linuxcnc --out pred.csv"
    )]
    Predict(PredictArgs),
}

/// Which error sources to keep (`--only`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Only {
    /// Servo models on the nominal geometry.
    Servo,
    /// Geometric errors; the axes follow their commands exactly.
    Geometry,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct PredictArgs {
    /// Machine model file (TOML): geometry, geometric errors, `[axes.servo]` models.
    #[arg(long)]
    machine: PathBuf,
    /// Axis commands: `t_s` and one column per machine axis (mm, deg), equally spaced.
    #[arg(long, required_unless_present = "gcode", conflicts_with = "gcode")]
    commands: Option<PathBuf>,
    /// A G-code program, interpolated at `--ts` by the project's interpolator.
    #[arg(long)]
    gcode: Option<PathBuf>,
    /// Read the program as a TCP program (XYZ = tool tip in W) from its start.
    #[arg(long, requires = "gcode")]
    tcp: bool,
    /// Interpolation period for `--gcode`, s (the servo models' period).
    #[arg(long, default_value_t = 0.001)]
    ts: f64,
    /// G54 work offset of one axis for `--gcode`, `AXIS=VALUE` (mm, deg); repeatable.
    #[arg(long = "offset", value_name = "AXIS=VALUE", requires = "gcode")]
    offsets: Vec<String>,
    #[command(flatten)]
    dialect: DialectArgs,
    #[command(flatten)]
    plan: PlanArgs,
    /// Interpolate samples outside the axis travels instead of stopping.
    #[arg(long, requires = "gcode")]
    no_travel_check: bool,
    /// Output PRED.csv: t_s, command and actual tool tip (mm) and axis in W, tip_error (mm), axis_error (rad)
    /// (a Parquet file of the same columns when the name ends in `.parquet`).
    #[arg(long)]
    out: PathBuf,
    /// Keep only one error source: `servo` (nominal geometry) or `geometry` (axes follow exactly).
    #[arg(long, value_enum, conflicts_with = "breakdown")]
    only: Option<Only>,
    /// Also run servo-only and geometry-only and show which source dominates where.
    #[arg(long)]
    breakdown: bool,
    /// Write SVG plots into this folder: path.svg, tip_error.svg, axis_error.svg.
    #[arg(long, value_name = "DIR")]
    plot: Option<PathBuf>,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Predict(a) => predict(a),
    }
}

/// The twin's progress on a bar, one bar per run (`twin all`, `twin servo`, …).
struct Bars {
    bar: Option<(Sources, indicatif::ProgressBar)>,
}

impl Bars {
    fn show(&mut self, sources: Sources, p: Progress) {
        if self.bar.as_ref().is_none_or(|(s, _)| *s != sources) {
            self.finish();
            self.bar = Some((sources, progress(0, &format!("twin {}", sources.as_str()))));
        }
        let Some((_, pb)) = &self.bar else { return };
        match p {
            Progress::Commands(n) => {
                pb.set_length(n);
                pb.set_position(n);
            }
            Progress::Errors { done, total } => {
                pb.set_length(total);
                pb.set_position(done);
            }
        }
    }

    fn finish(&mut self) {
        if let Some((_, pb)) = self.bar.take() {
            pb.finish_and_clear();
        }
    }
}

/// The input of `a`, as the library takes it: `opts` holds the interpolation
/// settings of `--gcode`.
fn commands<'a>(
    a: &'a PredictArgs,
    opts: &'a Option<InterpolateOptions>,
) -> anyhow::Result<Commands<'a>> {
    match (&a.commands, opts) {
        (Some(path), _) => Ok(Commands::Csv { path }),
        (None, Some(opts)) => Ok(Commands::Gcode { opts }),
        (None, None) => anyhow::bail!("--commands or --gcode is needed"),
    }
}

/// The file `a` reads its commands from.
fn input(a: &PredictArgs) -> anyhow::Result<&std::path::Path> {
    a.commands
        .as_deref()
        .or(a.gcode.as_deref())
        .context("--commands or --gcode is needed")
}

/// A twin error with the program's `file:line:col` when it has one.
fn twin_error(a: &PredictArgs, e: TwinError) -> anyhow::Error {
    match (e, &a.gcode) {
        (TwinError::Program(e), Some(p)) => located(p, e.line(), e.column(), e.message()),
        (TwinError::Read(e), _) => match input(a) {
            Ok(p) => anyhow::anyhow!("cannot read {}: {e}", p.display()),
            Err(e) => e,
        },
        (e, _) => e.into(),
    }
}

fn predict(a: PredictArgs) -> anyhow::Result<()> {
    let plot_files: Vec<PathBuf> = a
        .plot
        .iter()
        .flat_map(|d| twin::PLOT_FILES.map(|f| d.join(f)))
        .collect();
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.machine)
        .inputs(&a.commands)
        .inputs(&a.gcode)
        .output(&a.out)
        .folders(&a.plot)
        .outputs(&plot_files)
        .begin()?;
    let machine = load_machine(&a.machine)?;
    let mut options = PredictOptions::default();
    options.sources = match a.only {
        None => Sources::All,
        Some(Only::Servo) => Sources::Servo,
        Some(Only::Geometry) => Sources::Geometry,
    };
    options.breakdown = a.breakdown;
    options.plot = a.plot.is_some();
    options.out = a.out.display().to_string();
    let opts = match &a.gcode {
        Some(path) => {
            let mut opts = InterpolateOptions::new(a.ts);
            opts.interp = interp_options(&a.offsets, &a.dialect, path, Some(&machine))?;
            opts.interp.tcp_at_start = a.tcp;
            opts.check_travel = !a.no_travel_check;
            opts.plan = a.plan.options();
            a.plan.check_machine(&a.machine, &machine)?;
            Some(opts)
        }
        None => None,
    };
    let commands = commands(&a, &opts)?;
    let path = input(&a)?;
    let mut bars = Bars { bar: None };
    let mut result = None;
    out.write_with(&a.out, |w| -> anyhow::Result<()> {
        // The PRED.csv columns, defined once beside the reader of the report.
        let mut table = TableWriter::new(&a.out, w, &mtwin::report::twin::COLUMNS)?;
        let r = twin::run(
            &machine,
            commands,
            || std::fs::File::open(path).map(std::io::BufReader::new),
            &options,
            |r| table.row(&twin::pred_row(r)),
            &mut |sources, p| bars.show(sources, p),
        );
        bars.finish();
        result = Some(r.map_err(|e| twin_error(&a, e))?);
        table.finish()?;
        Ok(())
    })?;
    let r = result.context("the twin produced no summary")?;
    let mut plots = Vec::new();
    if let Some(dir) = &a.plot {
        for (name, svg) in &r.plots {
            let f = dir.join(name);
            out.write(&f, svg.as_bytes())
                .with_context(|| format!("cannot write {}", f.display()))?;
            plots.push(f.display().to_string());
        }
    }
    out.commit()?;
    let doc = twin::TwinPredictDoc { plots, ..r.doc };
    print_doc(&doc, a.format)
}
