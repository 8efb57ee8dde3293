//! `mtwin servo …` ([R5] in docs/references.md): identify an axis' command-to-encoder
//! transfer function from a log, simulate a servo, and write an excitation
//! program to record such a log.
//!
//! Units: time in s, positions in mm (deg for a rotary axis), feeds in mm/min
//! (deg/min).

use std::path::PathBuf;

use anyhow::Context;
use mtwin::io::{Outputs, Table, columns, fmt_f64, write_csv_row};
use mtwin::sysid::{
    self, ExcitationError, ExcitationOptions, ServoExcitationDoc, ServoFitDoc, ServoFitOptions,
    ServoSimulateDoc, excitation_program,
};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use super::common::{diag, load_table};
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
    if !(a.feed.is_finite() && a.feed > 0.0) {
        anyhow::bail!(
            "--feed must be a positive feed in mm/min, not {}",
            mtwin::limits::fmt_message_number(a.feed)
        );
    }
    let mut options = ServoFitOptions::default();
    options.max_order = a.max_order;
    options.max_delay = a.max_delay;
    options.validate().map_err(|e| match e {
        sysid::SysidError::Limit(l) => anyhow::anyhow!("{}", l.naming(FIT_FLAGS)),
        other => anyhow::anyhow!("--max-order: {other}"),
    })?;
    let mut out = Outputs::plan().input(&a.data).output(&a.out).begin()?;
    // Every structure of the order grid is refined by output error: seconds
    // on a long log.
    let spin = crate::output::spinner("fitting servo structures");
    let fit = sysid::fit_servo_csv(&a.data, &options);
    spin.finish_and_clear();
    let fit = fit?;
    out.write(&a.out, fit.to_toml()?.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    for w in fit.warnings() {
        warn(w);
    }
    let velocity = a.feed / 60.0;
    let following = fit.servo.following_error(velocity).ok();
    let doc = ServoFitDoc {
        out: Some(a.out.display().to_string()),
        feed_mm_min: Some(a.feed),
        following_error_at_feed: following,
        ..ServoFitDoc::new(&fit)
    };
    crate::output::print_doc(&doc, a.format)?;
    if a.format == Format::Human {
        note(format!(
            "copy the keys of {} under the axis' [axes.servo] table of the machine model",
            a.out.display()
        ));
    }
    Ok(())
}

fn simulate(a: SimulateArgs) -> anyhow::Result<()> {
    if !(a.noise.is_finite() && a.noise >= 0.0) {
        anyhow::bail!(
            "--noise must be finite and >= 0 mm, not {}",
            mtwin::limits::fmt_message_number(a.noise)
        );
    }
    let mut out = Outputs::plan()
        .input(&a.servo)
        .input(&a.commands)
        .output(&a.out)
        .begin()?;
    let servo = sysid::read_servo_toml(&a.servo).map_err(diag)?;
    if let Some(w) = servo.arx().stability().warning()
        && !a.allow_unstable
    {
        anyhow::bail!(
            "{}: {w}; refusing to simulate it (give --allow-unstable to simulate anyway)",
            a.servo.display()
        );
    }
    let table = load_table(&a.commands)?;
    let column = a.axis.as_deref().unwrap_or(columns::SERVO_COMMAND);
    let rows = table.number_rows(&[columns::T_S, column]).map_err(diag)?;
    check_grid(&table, &rows, servo.ts())?;
    let commands: Vec<f64> = rows.iter().map(|r| r[1]).collect();
    let feedback = servo.simulate(&commands);
    if let Some(k) = feedback.iter().position(|y| !y.is_finite()) {
        anyhow::bail!(
            "the simulated feedback overflows at t_s = {} (sample {}): the servo of {} diverges; nothing written",
            fmt_f64(rows[k][0]),
            k + 1,
            a.servo.display()
        );
    }
    let noise = Normal::new(0.0, a.noise).context("the noise level")?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(a.seed);
    out.write_with(&a.out, |w| -> std::io::Result<()> {
        w.write_all(format!("{}\n", columns::header(&columns::SERVO_LOG)).as_bytes())?;
        for (r, y) in rows.iter().zip(&feedback) {
            write_csv_row(w, &[r[0], r[1], y + noise.sample(&mut rng)])?;
        }
        Ok(())
    })
    .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    note(format!(
        "{} samples (noise {} mm, seed {}) → {}",
        rows.len(),
        mtwin::limits::fmt_message_number(a.noise),
        a.seed,
        a.out.display()
    ));
    let doc = ServoSimulateDoc {
        duration_s: rows.len() as f64 * servo.ts(),
        largest_following_error: commands
            .iter()
            .zip(&feedback)
            .map(|(c, y)| (c - y).abs())
            .fold(0.0, f64::max),
        noise: a.noise,
        out: a.out.display().to_string(),
        samples: rows.len(),
        seed: a.seed,
    };
    print_doc(&doc, a.format)
}

/// Commands must be at least two samples, `t_s` increasing by the servo's `ts` (within 1 %).
fn check_grid(table: &Table, rows: &[Vec<f64>], ts: f64) -> anyhow::Result<()> {
    let mut d = mtwin::io::Diagnostics::default();
    if rows.is_empty() {
        d.push(mtwin::io::Diagnostic::at_line(
            table.path(),
            table.header_line(),
            "the file has no data rows",
        ));
    }
    for (r, w) in rows.windows(2).enumerate() {
        let dt = w[1][0] - w[0][0];
        if (dt - ts).abs() > 0.01 * ts {
            d.push(table.row_error(
                r + 1,
                format!(
                    "t_s = {} does not follow the previous sample ({}) by the servo's ts = {} s",
                    fmt_f64(w[1][0]),
                    fmt_f64(w[0][0]),
                    fmt_f64(ts)
                ),
            ));
        }
    }
    d.into_result(()).map_err(diag)
}

fn excitation(a: ExcitationArgs) -> anyhow::Result<()> {
    let mut out = Outputs::plan().output(&a.out).begin()?;
    let values: Vec<f64> = a
        .travel
        .iter()
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let travel = match values.as_slice() {
        [lo, hi] if a.travel.len() == 2 => (*lo, *hi),
        _ => anyhow::bail!(
            "--travel needs two numbers MIN,MAX (mm or deg), not `{}`",
            a.travel.join(",")
        ),
    };
    let mut options = ExcitationOptions::new(&a.axis, [travel.0, travel.1], a.feed);
    options.levels = a.levels;
    options.dwell_s = a.dwell;
    let text = excitation_program(&options).map_err(|e| match e {
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
        axis: a.axis.clone(),
        dwell_s: a.dwell,
        feed: a.feed,
        levels: a.levels,
        lines: text.lines().count(),
        out: a.out.display().to_string(),
        travel: [travel.0, travel.1],
    };
    print_doc(&doc, a.format)
}
