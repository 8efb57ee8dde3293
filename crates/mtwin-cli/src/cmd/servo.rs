//! `mtwin servo …` ([R5] in docs/references.md): identify an axis' command-to-encoder
//! transfer function from a log, simulate a servo, and write an excitation
//! program to record such a log.
//!
//! Units: time in s, positions in mm (deg for a rotary axis), feeds in mm/min
//! (deg/min).

use std::path::PathBuf;

use anyhow::Context;
use mtwin::io::{Outputs, columns, fmt_f64, write_csv_row};
use mtwin::sysid::{
    self, ExcitationError, ExcitationOptions, FitRunOptions, ServoExcitationDoc, ServoFitDoc,
    ServoFitError, ServoSimulateDoc, SimulateRunError, SimulateRunOptions,
};

use super::common::{WriteDialectArgs, diag, load_table};
use crate::output::{Format, note, print_doc, warn};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Identify the servo transfer function of one axis from LOG.csv (`t_s,command_mm,feedback_mm`).
    #[command(
        after_help = "Example:\n  mtwin servo fit --data log.csv --max-order 3 --feed 2000 --out servo.toml"
    )]
    Fit(FitArgs),
    /// Simulate the encoder positions of a servo for commands (`t_s,command_mm`, or one axis of CMD.csv) into LOG.csv.
    #[command(
        after_help = "Example:\n  mtwin servo simulate --servo servo.toml --commands cmd.csv --noise 0.0002 --seed 1 --out log.csv\n  mtwin servo simulate --servo servo.toml --commands interpolated.csv --axis X --out log.csv"
    )]
    Simulate(SimulateArgs),
    /// Write a G-code excitation program for one axis: back-and-forth steps of growing amplitude.
    #[command(
        after_help = "Example:\n  mtwin servo excitation --axis X --travel -100,100 --feed 3000 --out exc.nc"
    )]
    Excitation(ExcitationArgs),
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct FitArgs {
    /// Servo log: `t_s,command_mm,feedback_mm`, evenly sampled.
    #[arg(long)]
    data: PathBuf,
    /// Largest ARX order tried (na in 1..=N, nb in 0..=N).
    #[arg(long, default_value_t = 4)]
    max_order: usize,
    /// Largest input delay tried, samples.
    #[arg(long, default_value_t = 3)]
    max_delay: usize,
    /// Feed (mm/min, deg/min) at which to report the steady following error.
    #[arg(long, default_value_t = 1000.0)]
    feed: f64,
    /// Output SERVO.toml (top-level `ts`, `b`, `a`, `nk`: the keys of `[axes.servo]`).
    #[arg(long)]
    out: PathBuf,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SimulateArgs {
    /// Servo file (SERVO.toml from `mtwin servo fit`, or written by hand).
    #[arg(long)]
    servo: PathBuf,
    /// Commands: `t_s,command_mm`, sampled at the servo's `ts` (or, with
    /// `--axis`, a CMD.csv of `mtwin gcode interpolate`).
    #[arg(long)]
    commands: PathBuf,
    /// Read the commands from this axis' column (e.g. `X` of a CMD.csv)
    /// instead of `command_mm`.
    #[arg(long)]
    axis: Option<String>,
    /// Standard deviation of white encoder noise added to the feedback, mm.
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Seed of the noise (same seed, same log).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output LOG.csv: `t_s,command_mm,feedback_mm`.
    #[arg(long)]
    out: PathBuf,
    /// Simulate even when the servo is unstable (a pole on or outside the
    /// unit circle); the simulation stops with an error if it overflows.
    #[arg(long)]
    allow_unstable: bool,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct ExcitationArgs {
    /// Axis letter (X, Y, Z, A, B, C, …).
    #[arg(long)]
    axis: String,
    /// Allowed travel `MIN,MAX` (mm or deg): every move stays inside it.
    #[arg(
        long,
        required = true,
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    travel: Vec<String>,
    /// Feed of the moves, mm/min (deg/min).
    #[arg(long)]
    feed: f64,
    /// Number of amplitude levels (amplitude k/levels of the half travel, k = 1..levels).
    #[arg(long, default_value_t = 5)]
    levels: usize,
    /// Dwell after every move, s (lets the axis settle: a step response in the log).
    #[arg(long, default_value_t = 0.5)]
    dwell: f64,
    /// Output G-code program.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    dialect: WriteDialectArgs,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Fit(a) => fit(a),
        Command::Simulate(a) => simulate(a),
        Command::Excitation(a) => excitation(a),
    }
}

/// The flag of each field of `ServoFitOptions` that `servo fit` sets.
const FIT_FLAGS: &[(&str, &str)] = &[("max_order", "--max-order"), ("max_delay", "--max-delay")];

fn fit(a: FitArgs) -> anyhow::Result<()> {
    let mut options = FitRunOptions::default();
    options.fit.max_order = a.max_order;
    options.fit.max_delay = a.max_delay;
    options.feed_mm_min = Some(a.feed);
    options.validate().map_err(|e| match e {
        ServoFitError::Fit(sysid::SysidError::Limit(l)) => {
            anyhow::anyhow!("{}", l.naming(FIT_FLAGS))
        }
        ServoFitError::Fit(other) => anyhow::anyhow!("--max-order: {other}"),
        other => fit_error(other),
    })?;
    let mut out = Outputs::plan().input(&a.data).output(&a.out).begin()?;
    // Every structure of the order grid is refined by output error: seconds
    // on a long log.
    let spin = crate::output::spinner("fitting servo structures");
    let result = sysid::run_fit(&a.data, &options);
    spin.finish_and_clear();
    let (fit, doc) = result.map_err(fit_error)?;
    out.write(&a.out, fit.to_toml()?.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    for w in &doc.warnings {
        warn(w);
    }
    let doc = ServoFitDoc {
        out: Some(a.out.display().to_string()),
        ..doc
    };
    print_doc(&doc, a.format)?;
    if a.format == Format::Human {
        note(format!(
            "copy the keys of {} under the axis' [axes.servo] table of the machine model",
            a.out.display()
        ));
    }
    Ok(())
}

/// A fit error, a setting named by its flag.
fn fit_error(e: ServoFitError) -> anyhow::Error {
    match e {
        ServoFitError::Setting { option, problem } => anyhow::anyhow!("--{option} {problem}"),
        other => other.into(),
    }
}

fn simulate(a: SimulateArgs) -> anyhow::Result<()> {
    let mut options = SimulateRunOptions::default();
    options.noise = a.noise;
    options.seed = a.seed;
    options.allow_unstable = a.allow_unstable;
    let simulate_error = |e: SimulateRunError| match e {
        SimulateRunError::Setting { option, problem } => anyhow::anyhow!("--{option} {problem}"),
        SimulateRunError::Unstable(w) => anyhow::anyhow!(
            "{}: {w}; refusing to simulate it (give --allow-unstable to simulate anyway)",
            a.servo.display()
        ),
        SimulateRunError::Diverges { t_s, sample } => anyhow::anyhow!(
            "the simulated feedback overflows at t_s = {} (sample {sample}): the servo of {} diverges; nothing written",
            fmt_f64(t_s),
            a.servo.display()
        ),
        other => other.into(),
    };
    options.validate().map_err(simulate_error)?;
    let mut out = Outputs::plan()
        .input(&a.servo)
        .input(&a.commands)
        .output(&a.out)
        .begin()?;
    let servo = sysid::read_servo_toml(&a.servo).map_err(diag)?;
    options.check_servo(&servo).map_err(simulate_error)?;
    let table = load_table(&a.commands)?;
    let column = a.axis.as_deref().unwrap_or(columns::SERVO_COMMAND);
    let commands = sysid::read_servo_commands(&table, column, servo.ts()).map_err(diag)?;
    let (log, doc) = sysid::run_simulate(&servo, &commands, &options).map_err(simulate_error)?;
    out.write_with(&a.out, |w| -> std::io::Result<()> {
        w.write_all(format!("{}\n", columns::header(&columns::SERVO_LOG)).as_bytes())?;
        for r in &log {
            write_csv_row(w, r)?;
        }
        Ok(())
    })
    .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    note(format!(
        "{} samples (noise {} mm, seed {}) → {}",
        doc.samples,
        mtwin::limits::fmt_message_number(a.noise),
        a.seed,
        a.out.display()
    ));
    let doc = ServoSimulateDoc {
        out: a.out.display().to_string(),
        ..doc
    };
    print_doc(&doc, a.format)
}

fn excitation(a: ExcitationArgs) -> anyhow::Result<()> {
    let mut out = Outputs::plan().output(&a.out).begin()?;
    let values: Vec<f64> = a
        .travel
        .iter()
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let travel = match values.as_slice() {
        [lo, hi] if a.travel.len() == 2 => [*lo, *hi],
        _ => anyhow::bail!(
            "--travel needs two numbers MIN,MAX (mm or deg), not `{}`",
            a.travel.join(",")
        ),
    };
    let mut options = ExcitationOptions::new(&a.axis, travel, a.feed);
    options.levels = a.levels;
    options.dwell_s = a.dwell;
    options.dialect = a.dialect.dialect();
    let (text, doc) = sysid::run_excitation(&options).map_err(|e| match e {
        ExcitationError::Setting { option, problem } => anyhow::anyhow!("--{option} {problem}"),
        ExcitationError::Limit(mut l) => {
            l.what = "--levels".into();
            anyhow::anyhow!("{l}")
        }
        other => anyhow::anyhow!("cannot write the excitation program: {other}"),
    })?;
    out.write(&a.out, text.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    note(format!(
        "excitation program for {} ({} levels) → {}",
        a.axis,
        a.levels,
        a.out.display()
    ));
    let doc = ServoExcitationDoc {
        out: a.out.display().to_string(),
        ..doc
    };
    print_doc(&doc, a.format)
}
