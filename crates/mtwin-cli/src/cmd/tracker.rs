//! Tool-tip (laser-tracker) identification commands, the `mtwin tracker`
//! family: `identify`, `validate`, `plan`, `simulate`, `compensate-points`.
//! The old top-level spellings (`mtwin identify`, `mtwin validate`,
//! `mtwin plan tracker`, `mtwin simulate tracker`, `mtwin compensate-points`)
//! are hidden subcommands that run the same code.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use mtwin::fit::Progress;
use mtwin::io::{Outputs, Table, write_csv_row};
use mtwin::methods::tracker::compensate::CompensatePointsOptions;
use mtwin::methods::tracker::plan::{PlanInputs, PlanOptions};
use mtwin::methods::tracker::simulate::SimulateOptions;
use mtwin::methods::tracker::validate::ValidateOptions;
use mtwin::methods::tracker::{self, IdentifyInputs, IdentifyOptions, TrackerPoint};
use mtwin::model::{Machine, ParameterSet, machine_to_toml, read_poses};
use mtwin::nalgebra::Vector3;
use mtwin::report::svg::{Series, xy};

use super::common::{diag, load_machine, load_table};
use crate::output::{Format, note, print_doc, progress, warn};

/// How long the identification runs before it shows a progress bar.
const PROGRESS_AFTER: std::time::Duration = std::time::Duration::from_secs(1);

/// `mtwin tracker …`.
#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Choose laser-tracker measurement poses (greedy D-optimal).
    #[command(
        allow_negative_numbers = true,
        after_help = "Example:\n  mtwin tracker plan --machine examples/machines/afp-gantry.toml --fit pdge:cheb3,location --candidates 1000 --select 180 --out-csv poses.csv --out-gcode poses.nc"
    )]
    Plan(PlanArgs),
    /// Simulate a laser-tracker measurement of a known machine.
    #[command(
        allow_negative_numbers = true,
        after_help = "Example:\n  mtwin tracker simulate --machine examples/machines/afp-gantry-with-errors.toml --poses poses.csv --noise 0.010 --seed 1 --out fit.csv"
    )]
    Simulate(SimulateArgs),
    /// Identify geometric errors from measured tool-tip positions.
    #[command(
        after_help = "Example:\n  mtwin tracker identify --machine examples/machines/afp-gantry.toml --data fit.csv --fit pdge:cheb3,location --out identified.toml"
    )]
    Identify(IdentifyArgs),
    /// Compare measured tool tips at check poses with the nominal and the identified model.
    #[command(
        after_help = "Example:\n  mtwin tracker validate --machine identified.toml --data check.csv --plot check.svg"
    )]
    Validate(ValidateArgs),
    /// Corrected axis commands from an identified model (inverse kinematics).
    #[command(
        after_help = "Example:\n  mtwin tracker compensate-points --machine identified.toml --data targets.csv --out corrected.csv"
    )]
    CompensatePoints(CompensateArgs),
}

/// Run one `mtwin tracker` subcommand.
pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Plan(a) => run_plan(PlanCommand::Tracker(a)),
        Command::Simulate(a) => run_simulate(SimulateCommand::Tracker(a)),
        Command::Identify(a) => run_identify(a),
        Command::Validate(a) => run_validate(a),
        Command::CompensatePoints(a) => run_compensate(a),
    }
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct IdentifyArgs {
    /// Machine model file (TOML): nominal geometry (and errors not being fitted).
    #[arg(long)]
    machine: PathBuf,
    /// CSV: one column per axis (mm, deg) and the measured tool tip x,y,z (mm, W).
    #[arg(long)]
    data: PathBuf,
    /// What to fit, e.g. `pdge:cheb3,location` or `EXX:cheb3,EY0A`.
    #[arg(long)]
    fit: String,
    /// Output machine model with the identified values written in.
    #[arg(long)]
    out: PathBuf,
    /// Fit a 6-parameter rigid registration tracker frame → W with the errors
    /// (x,y,z are then in the tracker frame).
    #[arg(long)]
    registration: bool,
    /// A previous calibration of the same machine (TOML): the values of the
    /// fitted errors that the points cannot determine individually are
    /// pulled to it. Default: 0 (the minimum-norm solution). See
    /// docs/tracker.md, "Gauge fixing".
    #[arg(long, value_name = "MACHINE.toml")]
    prior: Option<PathBuf>,
    /// Rank rule for badly determined directions (truncated SVD toward the
    /// prior): `std=X` drops the directions whose standard uncertainty
    /// would exceed X typical scales (1 µm, 10 µrad) in some error,
    /// `rcond=X` those whose relative singular value is below X, `off`
    /// keeps every direction the data see. The bias each dropped direction
    /// introduces is reported. Default: the library's (see docs/tracker.md,
    /// "Badly determined directions").
    #[arg(long, value_name = "RULE")]
    truncate: Option<mtwin::fit::Truncation>,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct ValidateArgs {
    /// Identified machine model (TOML).
    #[arg(long)]
    machine: PathBuf,
    /// CSV: axis columns and measured x,y,z (mm, W) at check poses.
    #[arg(long)]
    data: PathBuf,
    /// Write an SVG chart of |Δp| per point before and after.
    #[arg(long)]
    plot: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// The old spelling `mtwin plan tracker` (hidden; `mtwin tracker plan`).
#[derive(Debug, clap::Subcommand)]
pub enum PlanCommand {
    /// Choose laser-tracker measurement poses (greedy D-optimal); the same as `mtwin tracker plan`.
    #[command(
        allow_negative_numbers = true,
        after_help = "Example:\n  mtwin plan tracker --machine examples/machines/afp-gantry.toml --fit pdge:cheb3,location --candidates 1000 --select 180 --out-csv poses.csv --out-gcode poses.nc"
    )]
    Tracker(PlanArgs),
}

#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    #[arg(long)]
    machine: PathBuf,
    /// What the measurement should identify (fit specification).
    #[arg(long)]
    fit: String,
    /// Number of random candidate poses drawn in the travel.
    #[arg(long)]
    candidates: usize,
    /// Number of poses to keep.
    #[arg(long)]
    select: usize,
    /// Tracker noise, mm (standard deviation per coordinate).
    #[arg(long, default_value_t = 0.010)]
    noise: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output CSV of the chosen poses (axis columns).
    #[arg(long)]
    out_csv: PathBuf,
    /// Output G-code program visiting the poses with a dwell at each.
    #[arg(long)]
    out_gcode: PathBuf,
    #[command(flatten)]
    dialect: super::common::WriteDialectArgs,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// The old spelling `mtwin simulate tracker` (hidden; `mtwin tracker simulate`).
#[derive(Debug, clap::Subcommand)]
pub enum SimulateCommand {
    /// Simulate a laser-tracker measurement of a known machine; the same as `mtwin tracker simulate`.
    #[command(
        allow_negative_numbers = true,
        after_help = "Example:\n  mtwin simulate tracker --machine examples/machines/afp-gantry-with-errors.toml --poses poses.csv --noise 0.010 --seed 1 --out fit.csv"
    )]
    Tracker(SimulateArgs),
}

#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// The "true" machine (TOML) whose tips are measured.
    #[arg(long)]
    machine: PathBuf,
    /// CSV with axis columns.
    #[arg(long)]
    poses: PathBuf,
    /// Noise, mm (standard deviation per coordinate).
    #[arg(long, default_value_t = 0.010)]
    noise: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output CSV: axis columns and x,y,z (mm, W).
    #[arg(long)]
    out: PathBuf,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct CompensateArgs {
    /// Identified machine model (TOML).
    #[arg(long)]
    machine: PathBuf,
    /// CSV with the commanded (nominal) axis positions.
    #[arg(long)]
    data: PathBuf,
    /// Output CSV: corrected axis columns, then the predicted tip error before
    /// and after correction (mm) and the tool-axis error after (rad).
    #[arg(long)]
    out: PathBuf,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// Axis positions and measured x,y,z of every row.
fn read_points(t: &Table, m: &Machine) -> anyhow::Result<Vec<TrackerPoint>> {
    let poses = read_poses(t, m, true).map_err(diag)?;
    let xyz = t
        .number_rows(&mtwin::io::columns::TRACKER_MEASURED)
        .map_err(diag)?;
    Ok(poses
        .into_iter()
        .zip(xyz)
        .map(|(q, p)| TrackerPoint {
            q,
            measured: Vector3::new(p[0], p[1], p[2]),
        })
        .collect())
}

fn header(m: &Machine, extra: &[&str]) -> String {
    let mut h: Vec<&str> = m.axis_names();
    h.extend_from_slice(extra);
    h.join(",")
}

fn write_points(
    out: &mut Outputs,
    path: &Path,
    m: &Machine,
    rows: &[Vec<f64>],
    extra: &[&str],
) -> anyhow::Result<()> {
    out.write_with(path, |w| -> std::io::Result<()> {
        writeln!(w, "{}", header(m, extra))?;
        for r in rows {
            write_csv_row(w, r)?;
        }
        Ok(())
    })
    .with_context(|| format!("cannot write {}", path.display()))
}

pub fn run_identify(a: IdentifyArgs) -> anyhow::Result<()> {
    let mut out = Outputs::plan()
        .input(&a.machine)
        .input(&a.data)
        .output(&a.out)
        .begin()?;
    let m = load_machine(&a.machine)?;
    let params = ParameterSet::from_spec(&m, &a.fit).map_err(|e| anyhow::anyhow!("--fit: {e}"))?;
    let t = load_table(&a.data)?;
    let points = read_points(&t, &m)?;
    let mut options = IdentifyOptions::default();
    options.registration = a.registration;
    if let Some(p) = &a.prior {
        options.prior = Some(load_machine(p)?);
    }
    if let Some(t) = a.truncate {
        options.fit.truncation = t;
    }
    options.out = a.out.display().to_string();
    // A progress bar once the identification has run for a second: the
    // rows of the current pass over the data, or the analysis stage.
    let start = std::time::Instant::now();
    let bar: std::cell::OnceCell<indicatif::ProgressBar> = std::cell::OnceCell::new();
    let passes = std::cell::Cell::new(0usize);
    let inputs = IdentifyInputs {
        machine: &m,
        params: &params,
        points: &points,
    };
    let (id, doc) = tracker::identify::run(&inputs, &options, &|p| {
        if bar.get().is_none() && start.elapsed() >= PROGRESS_AFTER {
            let _ = bar.set(progress(3 * points.len() as u64, "identify"));
        }
        match p {
            Progress::Evaluating {
                rows_done,
                rows_total,
            } => {
                if let Some(b) = bar.get() {
                    b.set_message(format!("pass {}", passes.get() + 1));
                    b.set_length(rows_total as u64);
                    b.set_position(rows_done as u64);
                }
                if rows_done >= rows_total {
                    passes.set(passes.get() + 1);
                }
            }
            Progress::Analysing => {
                if let Some(b) = bar.get() {
                    b.set_message("analysing");
                }
            }
            Progress::Iteration { .. } => {}
        }
    })
    .with_context(|| format!("cannot identify from {}", a.data.display()))?;
    if let Some(b) = bar.get() {
        b.finish_and_clear();
    }
    let r = &id.report;
    for w in &r.warnings {
        warn(w.to_string());
    }
    let text = machine_to_toml(
        &id.machine,
        &[
            &format!("Identified by mtwin tracker identify --fit {}", a.fit),
            &format!("from {} ({} points)", a.data.display(), points.len()),
        ],
    )?;
    out.write(&a.out, text.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    print_doc(&doc, a.format)?;
    if a.format == Format::Human {
        note(format!("identified machine written to {}", a.out.display()));
    }
    Ok(())
}

pub fn run_validate(a: ValidateArgs) -> anyhow::Result<()> {
    let mut out = Outputs::plan()
        .input(&a.machine)
        .input(&a.data)
        .outputs(&a.plot)
        .begin()?;
    let m = load_machine(&a.machine)?;
    let t = load_table(&a.data)?;
    let points = read_points(&t, &m)?;
    if points.is_empty() {
        bail!("{}: no data rows", a.data.display());
    }
    let (v, doc) = tracker::validate::run(&m, &points, &ValidateOptions::default());
    if let Some(p) = &a.plot {
        let series = |name: &str, errs: &[mtwin::nalgebra::Vector3<f64>], color: &str| Series {
            name: name.to_string(),
            points: errs
                .iter()
                .enumerate()
                .map(|(k, e)| (k as f64, e.norm() * 1e3))
                .collect(),
            color: color.to_string(),
            markers: false,
        };
        let svg = xy(
            &format!("|Δp| per point, {}", a.data.display()),
            "point",
            "|Δp| (µm)",
            &[
                series("before (nominal)", &v.errors_before, "#c0392b"),
                series("after (identified)", &v.errors_after, "#2471a3"),
            ],
        );
        out.write(p, svg.as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    out.commit()?;
    print_doc(&doc, a.format)
}

/// The flag of each argument of `tracker::plan::plan` that `tracker plan` sets.
const PLAN_FLAGS: &[(&str, &str)] = &[("candidates", "--candidates"), ("select", "--select")];

pub fn run_plan(c: PlanCommand) -> anyhow::Result<()> {
    let PlanCommand::Tracker(a) = c;
    if !(a.noise.is_finite() && a.noise > 0.0) {
        bail!(
            "--noise must be a positive number of mm, got {}",
            mtwin::limits::fmt_message_number(a.noise)
        );
    }
    if a.select == 0 || a.select > a.candidates {
        bail!(
            "--select must be between 1 and --candidates ({}), got {}",
            a.candidates,
            a.select
        );
    }
    mtwin::methods::tracker::plan::check_plan_size(a.candidates, a.select)
        .map_err(|e| anyhow::anyhow!("{}", e.naming(PLAN_FLAGS)))?;

    let mut out = Outputs::plan()
        .input(&a.machine)
        .output(&a.out_csv)
        .output(&a.out_gcode)
        .begin()?;
    let m = load_machine(&a.machine)?;
    let params = ParameterSet::from_spec(&m, &a.fit).map_err(|e| anyhow::anyhow!("--fit: {e}"))?;
    let mut options = PlanOptions::default();
    options.candidates = a.candidates;
    options.select = a.select;
    options.noise = a.noise;
    options.seed = a.seed;
    options.dialect = a.dialect.dialect();
    let spin = crate::output::spinner("planning");
    let r = tracker::plan::run(
        &PlanInputs {
            machine: &m,
            params: &params,
        },
        &options,
    );
    spin.finish_and_clear();
    let (p, g, doc) = r.context("cannot evaluate the chosen poses")?;
    write_points(&mut out, &a.out_csv, &m, &p.poses, &[])?;
    out.write(&a.out_gcode, g.as_bytes())
        .with_context(|| format!("cannot write {}", a.out_gcode.display()))?;
    out.commit()?;
    print_doc(&doc, a.format)
}

pub fn run_simulate(c: SimulateCommand) -> anyhow::Result<()> {
    let SimulateCommand::Tracker(a) = c;
    if !(a.noise.is_finite() && a.noise >= 0.0) {
        bail!(
            "--noise must be a non-negative number of mm, got {}",
            mtwin::limits::fmt_message_number(a.noise)
        );
    }
    let mut out = Outputs::plan()
        .input(&a.machine)
        .input(&a.poses)
        .output(&a.out)
        .begin()?;
    let m = load_machine(&a.machine)?;
    let t = load_table(&a.poses)?;
    let poses = read_poses(&t, &m, true).map_err(diag)?;
    let mut options = SimulateOptions::default();
    options.noise = a.noise;
    options.seed = a.seed;
    options.out = a.out.display().to_string();
    let (pts, doc) = tracker::simulate::run(&m, &poses, &options);
    let rows: Vec<Vec<f64>> = pts
        .iter()
        .map(|p| {
            let mut r = p.q.clone();
            r.extend_from_slice(p.measured.as_slice());
            r
        })
        .collect();
    write_points(
        &mut out,
        &a.out,
        &m,
        &rows,
        &mtwin::io::columns::TRACKER_MEASURED,
    )?;
    out.commit()?;
    print_doc(&doc, a.format)?;
    if a.format == Format::Human {
        note(format!(
            "{} simulated points written to {}",
            rows.len(),
            a.out.display()
        ));
    }
    Ok(())
}

pub fn run_compensate(a: CompensateArgs) -> anyhow::Result<()> {
    let mut out = Outputs::plan()
        .input(&a.machine)
        .input(&a.data)
        .output(&a.out)
        .begin()?;
    let m = load_machine(&a.machine)?;
    let t = load_table(&a.data)?;
    let poses = read_poses(&t, &m, true).map_err(diag)?;
    let mut options = CompensatePointsOptions::default();
    options.out = a.out.display().to_string();
    let (corrected, doc) = tracker::compensate::run(&m, &poses, &options).map_err(|e| {
        diag(
            t.row_error(
                e.index,
                format!("cannot compensate this pose: {}", e.source),
            )
            .into(),
        )
    })?;
    let rows: Vec<Vec<f64>> = corrected
        .iter()
        .map(|r| {
            let mut row = r.q.clone();
            row.extend([r.error_before, r.error_after, r.axis_error_after]);
            row
        })
        .collect();
    write_points(
        &mut out,
        &a.out,
        &m,
        &rows,
        &mtwin::io::columns::TRACKER_COMPENSATED,
    )?;
    out.commit()?;
    print_doc(&doc, a.format)
}
