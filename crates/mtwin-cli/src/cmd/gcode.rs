//! `mtwin gcode`: interpolate a program into axis commands, program statistics.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use mtwin::gcode::{
    self, Axes, Axis, InterpOptions, InterpolateError, InterpolateOptions, StatsOptions,
    TravelCheck,
};

use super::common::{DialectArgs, PlanArgs, load_machine, located_error};
use crate::output::{Format, TableWriter, warn};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Sample a program in time: axis commands at a fixed period (CMD.csv).
    #[command(
        after_help = "Example:\n  mtwin gcode interpolate --machine examples/machines/ac-trunnion.toml part.nc --ts 0.001 --out cmd.csv --tcp\n  mtwin gcode interpolate --machine examples/machines/ac-trunnion.toml part.nc --planner linuxcnc --feed-override 0.8 --out cmd.csv\n  mtwin gcode interpolate --machine examples/machines/ac-trunnion.toml part.nc --planner jerk --ts 0.001 --out cmd.csv"
    )]
    Interpolate(InterpolateArgs),
    /// Program statistics: blocks, path length, estimated time, axis ranges, travel checks.
    #[command(
        after_help = "Example:\n  mtwin gcode stats part.nc --machine examples/machines/ac-trunnion.toml\n  mtwin gcode stats part.nc --machine examples/machines/ac-trunnion.toml --planner linuxcnc --format json\n  mtwin gcode stats part.nc --machine examples/machines/ac-trunnion.toml --planner jerk"
    )]
    Stats(StatsArgs),
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct InterpolateArgs {
    /// Machine model file (TOML): axes, travels, velocity/acceleration limits, rapid feed.
    #[arg(long)]
    machine: PathBuf,
    /// The G-code program.
    program: PathBuf,
    /// Sample period, s.
    #[arg(long, default_value_t = 0.001)]
    ts: f64,
    /// Output CSV: `t_s` and one column per machine axis (mm, deg) (a Parquet
    /// file of the same columns when the name ends in `.parquet`).
    #[arg(long)]
    out: PathBuf,
    /// Treat every move as a TCP move (XYZ = tool tip in W) from the start.
    #[arg(long)]
    tcp: bool,
    /// G54 work offset of one axis, `AXIS=VALUE` (mm, deg); repeatable.
    #[arg(long = "offset", value_name = "AXIS=VALUE")]
    offsets: Vec<String>,
    #[command(flatten)]
    dialect: DialectArgs,
    #[command(flatten)]
    plan: PlanArgs,
    /// Write samples outside the axis travels instead of stopping.
    #[arg(long)]
    no_travel_check: bool,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct StatsArgs {
    /// The G-code program.
    program: PathBuf,
    /// Machine model file (TOML): check the moves against its travels.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Treat every move as a TCP move for the travel check.
    #[arg(long)]
    tcp: bool,
    /// With --machine: exit with code 1 (after the report) when a move leaves
    /// the travel or a tool tip is unreachable, for scripts and CI.
    #[arg(long, requires = "machine")]
    strict: bool,
    /// G54 work offset of one axis, `AXIS=VALUE` (mm, deg); repeatable.
    #[arg(long = "offset", value_name = "AXIS=VALUE")]
    offsets: Vec<String>,
    #[command(flatten)]
    dialect: DialectArgs,
    #[command(flatten)]
    plan: PlanArgs,
    /// Output format.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Interpolate(a) => interpolate(a),
        Command::Stats(a) => stats(a),
    }
}

/// Parses `AXIS=VALUE` offsets into a G54 offset: the given axes set on
/// `base`.
fn parse_offsets(items: &[String], base: Axes) -> anyhow::Result<Axes> {
    let mut off = base;
    for item in items {
        let Some((name, value)) = item.split_once('=') else {
            bail!("--offset `{item}` is not AXIS=VALUE");
        };
        let Some(axis) = Axis::from_name(name.trim()) else {
            bail!("--offset `{item}`: `{name}` is not an axis letter (X Y Z A B C U V W)");
        };
        off[axis] = value
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .with_context(|| format!("--offset `{item}`: `{value}` is not a number"))?;
    }
    Ok(off)
}

/// `file:line:col: message` for an error with a source position (the one
/// error format of every command); `msg` is the library's message without
/// its location (the errors' `message()`).
pub fn located(
    path: &Path,
    line: Option<u64>,
    column: u32,
    msg: impl std::fmt::Display,
) -> anyhow::Error {
    match line {
        Some(l) => anyhow::anyhow!("{}:{}:{}: {}", path.display(), l, column.max(1), msg),
        None => anyhow::anyhow!("{}: {}", path.display(), msg),
    }
}

/// Interpreter options from `--offset` items and the program-reading
/// arguments (dialect, tool table, block delete, var file, subroutine path)
/// for the program at `program` on `machine` (its axes are those the
/// program may name; all nine without a machine). With a var file the nine
/// work offsets are its 5221… parameters; `--offset` sets the G54 axes it
/// names on top.
pub(super) fn interp_options(
    offsets: &[String],
    dialect: &DialectArgs,
    program: &Path,
    machine: Option<&mtwin::model::Machine>,
) -> anyhow::Result<InterpOptions> {
    let mut o = InterpOptions::default();
    dialect.apply(&mut o)?;
    o.program = dialect.program_options(program)?;
    o.machine_axes = dialect.machine_axes(machine)?;
    if dialect.var_file.is_some() {
        // LinuxCNC starts with the coordinate systems of its var file.
        o.work_offsets = o.program.parameters.work_offsets();
        o.work_rotations = o.program.parameters.work_rotations();
    }
    o.work_offsets[0] = parse_offsets(offsets, o.work_offsets[0])?;
    Ok(o)
}

/// The number of samples the whole program implies (its estimated duration
/// over `--ts`) checked against the bound before any sample is made; the
/// interpolator checks each move against the same bound as it goes. A program
/// that cannot be timed is left to the interpolator, which reports where.
fn check_sample_count(
    a: &InterpolateArgs,
    m: &mtwin::model::Machine,
    opts: &InterpolateOptions,
) -> anyhow::Result<()> {
    if !(a.ts.is_finite() && a.ts > 0.0) {
        return Ok(());
    }
    let mut so = StatsOptions::default();
    so.interp = opts.interp.clone();
    so.rapid_feed = m.rapid_feed;
    let f =
        File::open(&a.program).with_context(|| format!("cannot read {}", a.program.display()))?;
    if let Ok(st) = gcode::stats(BufReader::new(f), &so) {
        let samples = (st.total_time() / a.ts).ceil() + 1.0;
        mtwin::limits::check(
            "the number of samples (estimated program duration / --ts)",
            samples,
            opts.max_samples,
            "give a larger --ts or interpolate a shorter program",
        )
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.program.display()))?;
    }
    Ok(())
}

fn interpolate(a: InterpolateArgs) -> anyhow::Result<()> {
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.machine)
        .input(&a.program)
        .output(&a.out)
        .begin()?;
    let m = load_machine(&a.machine)?;
    a.plan.check_machine(&a.machine, &m)?;
    let mut opts = InterpolateOptions::new(a.ts);
    opts.interp = interp_options(&a.offsets, &a.dialect, &a.program, Some(&m))?;
    opts.force_tcp = a.tcp;
    opts.check_travel = !a.no_travel_check;
    opts.plan = a.plan.options();
    check_sample_count(&a, &m, &opts)?;
    let (input, bar) = crate::output::open_with_progress(&a.program, "interpolate")?;
    let mut failure: Option<InterpolateError> = None;
    let mut summary = None;
    let written = out.write_with(&a.out, |w| -> std::io::Result<()> {
        let mut header = vec![mtwin::io::columns::T_S];
        header.extend(m.axis_names());
        let mut table = TableWriter::new(&a.out, w, &header)?;
        let mut row = Vec::with_capacity(m.n_axes() + 1);
        let r = gcode::interpolate(input, &m, &opts, |s| {
            row.clear();
            row.push(s.t);
            row.extend_from_slice(s.q);
            table.row(&row)
        });
        match r {
            Ok(s) => {
                summary = Some(s);
                table.finish()
            }
            Err(InterpolateError::Sink(e)) => Err(e),
            Err(e) => {
                failure = Some(e);
                Err(std::io::Error::other("interpolation failed"))
            }
        }
    });
    bar.finish_and_clear();
    if let Some(e) = failure {
        return Err(located(&a.program, e.line(), e.column(), e.message()));
    }
    written.with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    let s = summary.context("interpolation produced no summary")?;
    if s.transitions > 0 {
        warn(format!(
            "{} axis-space transition(s) inserted where a move starts away from the current axis positions (TCP switched on)",
            s.transitions
        ));
    }
    let doc = gcode::GcodeInterpolateDoc::new(&s, a.ts, &a.out.display().to_string());
    crate::output::print_doc(&doc, a.format)
}

/// The planned time of `gcode stats` with a machine: `Some` when the program
/// can be interpolated on the machine, else `None` with a warning (an
/// unreachable tip, reported by the travel check); an error of the
/// planner's settings stops the command.
fn planned_time(
    a: &StatsArgs,
    planned: Result<f64, InterpolateError>,
) -> anyhow::Result<Option<f64>> {
    match planned {
        Ok(t) => Ok(Some(t)),
        Err(InterpolateError::Plan(e)) => bail!("{e}"),
        Err(e) => {
            warn(format!(
                "{}: the planned time is not available ({}); total_time_s is the estimate without accelerations",
                a.program.display(),
                located(&a.program, e.line(), e.column(), e.message())
            ));
            Ok(None)
        }
    }
}

fn stats(a: StatsArgs) -> anyhow::Result<()> {
    let machine = a.machine.as_deref().map(load_machine).transpose()?;
    let mut opts = StatsOptions::default();
    opts.interp = interp_options(&a.offsets, &a.dialect, &a.program, machine.as_ref())?;
    if let (Some(m), Some(path)) = (&machine, &a.machine) {
        opts.rapid_feed = m.rapid_feed;
        a.plan.check_machine(path, m)?;
    }
    opts.interp.tcp_at_start = a.tcp;
    let (input, bar) = crate::output::open_with_progress(&a.program, "read")?;
    // With a machine: statistics, travel check and planned time from one
    // run of the interpreter.
    let result = match &machine {
        Some(m) => {
            let mut check = TravelCheck::new(m);
            check.force_tcp = a.tcp;
            let mut plan = InterpolateOptions::new(1e9);
            plan.interp = opts.interp.clone();
            plan.force_tcp = a.tcp;
            plan.plan = a.plan.options();
            gcode::stats_planned(input, &opts, &mut check, m, &plan)
                .map(|(st, planned)| (st, Some(planned), Some(check)))
        }
        None => gcode::stats(input, &opts).map(|st| (st, None, None)),
    };
    bar.finish_and_clear();
    let (mut st, planned, check) = result.map_err(|e| located_error(&a.program, &e))?;
    if let Some(planned) = planned {
        st.planned_time = planned_time(&a, planned)?;
    }
    let doc = gcode::GcodeStatsDoc::new(
        &a.program.display().to_string(),
        &st,
        machine.as_ref(),
        check.as_ref(),
    );
    crate::output::print_doc(&doc, a.format)?;
    if let Some(c) = check.as_ref().filter(|_| a.strict) {
        // The first move at fault (in program order), as `file:line:col`.
        let first_violation = c.violations.iter().min_by_key(|v| v.line);
        let first_unreachable = c.unreachable.iter().min();
        let summary = format!(
            "{} move(s) outside the travel and {} unreachable tool tip(s) (--strict)",
            c.count,
            c.unreachable.len()
        );
        match (first_violation, first_unreachable) {
            (Some(v), u) if u.is_none_or(|&l| v.line <= l) => {
                return Err(located(
                    &a.program,
                    Some(v.line),
                    0,
                    format!(
                        "axis {} reaches {} along the move, outside its travel [{}, {}]; {summary}",
                        v.axis, v.value, v.travel[0], v.travel[1]
                    ),
                ));
            }
            (_, Some(&l)) => {
                return Err(located(
                    &a.program,
                    Some(l),
                    0,
                    format!("the tool tip is not reachable; {summary}"),
                ));
            }
            _ if c.count > 0 => bail!("{}: {summary}", a.program.display()),
            _ => {}
        }
    }
    Ok(())
}
