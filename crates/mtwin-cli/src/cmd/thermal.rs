//! `mtwin thermal …` ([R4] in docs/references.md): fit the spindle-speed-driven drift
//! model from probing data, predict the drift of a speed programme, and
//! simulate probing data from a model.
//!
//! Units: time in minutes, speed in rev/min, heights and drift in mm (drift =
//! displacement of the tool relative to the workpiece in +Z).

use std::path::{Path, PathBuf};

use anyhow::Context;
use mtwin::methods::thermal::log::{ChannelSpec, InputRule, InputSearch, InputSpec};
use mtwin::methods::thermal::{
    self, Ambient, FitRunOptions, LogFitRunOptions, LogPredictRunOptions, PredictRunOptions,
    SpeedModel, ThermalFitOptions,
};
use serde_json::json;

use super::common::DialectArg;
use super::common::diag;
use crate::output::{Format, note, print_json, progress, warn};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Fit one ARX drift model per measured height from TRAIN.csv (orders by FPE), or one model
    /// per drift channel of a wide machine log (--log; inputs and orders by held-out simulation error).
    #[command(
        after_help = "Examples:\n  mtwin thermal fit --data train.csv --max-order 3 --out thermal.toml --plot plots\n  mtwin thermal fit --log log.csv --drift ch1_um:Z --inputs speed_rpm,t1_c,t2_c --train-until-min 1000 --out log-model.toml"
    )]
    Fit(FitArgs),
    /// Predict the drift of a spindle-speed programme at given heights (from cold), or the drift
    /// channels of a wide log from its inputs (--log, a model of `thermal fit --log`).
    #[command(
        after_help = "Examples:\n  mtwin thermal predict --model thermal.toml --speed speed.csv --z -100,-300 --out drift.csv\n  mtwin thermal predict --model log-model.toml --log log.csv --out predicted.csv"
    )]
    Predict(PredictArgs),
    /// Simulate probing data (TRAIN.csv layout) of a model for a speed programme.
    #[command(
        after_help = "Example:\n  mtwin thermal simulate --model thermal.toml --speed speed.csv --z -50,-350 --noise 0.001 --seed 7 --out train.csv"
    )]
    Simulate(SimulateArgs),
    /// Pre-compensate an NC program: Z targets replaced by Z − e(t, Z) (as in [R4], docs/references.md);
    /// with a log model (`thermal fit --log`) the X, Y and Z targets of every axis it has a channel for.
    #[command(
        after_help = "Examples:\n  mtwin thermal compensate --model thermal.toml --program part.nc --out part-comp.nc --period-min 10\n  mtwin thermal compensate --model thermal.toml --program part.nc --out part-comp.nc --machine examples/machines/ac-trunnion.toml --planner linuxcnc\n  mtwin thermal compensate --model log-model.toml --inputs-log temperatures.csv --program part.nc --out part-comp.nc"
    )]
    Compensate(super::thermal_compensate::Args),
    /// Write the measurement programme as G-code: cold pass, then spindle speeds with a probing pass every period.
    #[command(
        after_help = "Example:\n  mtwin thermal program --z -50,-150,-250,-350 --x0 -100 --pitch 50 --speeds 2000,4000,6000 --step-min 60 --period-min 10 --out thermal.ngc\n  mtwin thermal program --z -50,-150 --speeds 2000,6000 --step-min 60 --machine examples/machines/ac-trunnion.toml --planner linuxcnc --out thermal.ngc"
    )]
    Program(ProgramArgs),
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct ProgramArgs {
    #[command(flatten)]
    heights: Heights,
    /// X of the first ball, mm.
    #[arg(long, default_value_t = 0.0)]
    x0: f64,
    /// X spacing of the balls, mm.
    #[arg(long, default_value_t = 50.0)]
    pitch: f64,
    /// Y of the balls, mm.
    #[arg(long, default_value_t = 0.0)]
    y: f64,
    /// Ball diameter, mm.
    #[arg(long, default_value_t = 25.4)]
    ball_diameter: f64,
    /// Spindle speeds (rev/min, 0 = off), each held --step-min: one value is a constant speed.
    #[arg(long, required = true, value_delimiter = ',')]
    speeds: Vec<f64>,
    /// Duration of every speed of --speeds, min.
    #[arg(long)]
    step_min: f64,
    /// Sample period: a probing pass starts every this many minutes, min.
    #[arg(long, default_value_t = 10.0)]
    period_min: f64,
    /// Probing feed, mm/min.
    #[arg(long, default_value_t = 100.0)]
    feed: f64,
    /// Start of each probing move above the ball top, mm.
    #[arg(long, default_value_t = 2.0)]
    approach: f64,
    /// End of each probing move below the ball top, mm.
    #[arg(long, default_value_t = 1.0)]
    overtravel: f64,
    /// Safe height above the highest ball top, mm.
    #[arg(long, default_value_t = 10.0)]
    clearance: f64,
    /// Rapid rate assumed for the timing, mm/min (as `gcode stats --rapid`;
    /// with --machine the machine's `rapid_feed`).
    #[arg(long, default_value_t = 10000.0)]
    rapid: f64,
    /// Machine model file (TOML): time the program with --planner on its
    /// axis limits (accelerations, stops and waits included), so that every
    /// pass starts on the period by that planner's clock.
    #[arg(long)]
    machine: Option<PathBuf>,
    #[command(flatten)]
    plan: super::common::PlanArgs,
    /// Controller dialect: LinuxCNC (G38.2, G4 P seconds, touches logged to
    /// thermal-probe.csv) or Fanuc (G31 skip, G4 X seconds; read #5063 after
    /// each G31 yourself).
    #[arg(long, value_enum, default_value_t)]
    dialect: DialectArg,
    /// Output program.
    #[arg(long)]
    out: PathBuf,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct FitArgs {
    /// Training data: `t_min,speed_rpm,z_mm,drift_mm` (optional `run` column), one row per time and height.
    #[arg(long, required_unless_present = "log", conflicts_with = "log")]
    data: Option<PathBuf>,
    /// A wide machine log instead: a `t_s` or `t_min` column, the --drift channels and the --inputs
    /// columns, one row per time stamp (models chosen by held-out simulation error; docs/thermal.md).
    #[arg(long)]
    log: Option<PathBuf>,
    /// Drift channels of --log: COLUMN:AXIS or COLUMN:UNIT:AXIS (unit um or mm, axis X, Y or Z),
    /// comma separated, e.g. `ch1_um:X,ch2_um:Z`.
    #[arg(long, value_delimiter = ',', requires = "log")]
    drift: Vec<String>,
    /// Input columns of --log, comma separated (`COLUMN`, `COLUMN:rise`, `COLUMN:level`,
    /// `COLUMN:square` or `COLUMN:over=OTHER`, the rise of COLUMN − OTHER since the start; a column
    /// ending in `_c` is a temperature and enters as its rise since the start).
    #[arg(long, value_delimiter = ',', requires = "log")]
    inputs: Vec<String>,
    /// Model period for --log: the log is averaged over periods of this length, min (default 1).
    #[arg(long, requires = "log")]
    period_min: Option<f64>,
    /// With --log: fit on the samples before this time (min from the log's start) and report how
    /// the model predicts the rest from the start (mean absolute error, error/drift RMS).
    #[arg(long, requires = "log")]
    train_until_min: Option<f64>,
    /// With --log: most inputs one channel's model may use (forward selection; default 6).
    #[arg(long, requires = "log")]
    max_inputs: Option<usize>,
    /// With --log: inputs and orders are chosen by blocked cross-validation: the training samples
    /// are cut into N + 1 contiguous blocks, each block after the first is predicted from the
    /// start by a model fitted on the blocks before it, and the errors are pooled; 1: one
    /// held-out block, the last third. Default 3. Several values (`2,4,6` or `2-6`): each channel
    /// is chosen and fitted once per value, and predicted by the per-sample median of those
    /// models (the model file keeps them all; each value costs a whole fit).
    #[arg(long, value_parser = parse_fold_counts, requires = "log")]
    folds: Option<FoldCounts>,
    /// With --log: also try, per channel, every input through one or two first-order lags with
    /// shared time constants (5 to 405 min, refined), beside the ARX orders; chosen only where it
    /// predicts the held-out blocks better (stored as the equivalent ARX model).
    #[arg(long, requires = "log")]
    lags: bool,
    /// With --log: when an input is added (and kept): `pooled` (it lowers the pooled held-out RMS
    /// by 2 %), `every-block` (that, and it lowers the error in every held-out block) or
    /// `same-sign` (that, and every input's fitted static gain has one sign in every block's fit).
    /// Default `pooled`.
    #[arg(long, value_parser = parse_input_rule, requires = "log")]
    input_rule: Option<InputRule>,
    /// With --log: how each channel's input set is searched: `forward` (forward steps, then a
    /// backward pass) or `exchange` (that, then while it lowers the held-out RMS one chosen input
    /// exchanged for one not chosen, or else a pair of inputs added together, the forward and
    /// backward passes again after each move: finds inputs that help only together; on the real
    /// record of docs/thermal.md about six times the work, growing with the square of the inputs). Default `forward`.
    #[arg(long, value_parser = parse_input_search, requires = "log")]
    search: Option<InputSearch>,
    /// With --log: also estimate each channel's start offset with its model: the drift is counted
    /// from the channel's first period mean, one noisy measurement, whose error is otherwise an
    /// offset on every later sample that the inputs are made to explain. Stored per channel
    /// (`start_offset_mm`); `thermal predict --log` adds it to the predicted channel, the drift that
    /// `thermal compensate` corrects holds none.
    #[arg(long, requires = "log")]
    start_offset: bool,
    /// With --log: take every temperature input but one over an ambient sensor (`COLUMN:over=AMBIENT`,
    /// the rise of the difference since the start); the ambient one stays as its own rise. Give the
    /// ambient input column, or `auto`: the temperature least correlated with the first level input
    /// (the spindle speed) over the training rows (docs/thermal.md, "Rises over an ambient sensor").
    #[arg(long, value_name = "COLUMN|auto", value_parser = parse_ambient, requires = "log")]
    ambient: Option<Ambient>,
    /// With --ambient: also fit every channel on the temperatures as given (the plain rises), and
    /// predict it by the per-sample median of the models of both kinds (with --folds 2-6, ten
    /// models); twice the work (docs/thermal.md, "The two kinds of rises together").
    #[arg(long, requires = "ambient")]
    also_plain: bool,
    /// Largest ARX order tried: na in 1..=N, nb in 0..=N (default 4); with --log na and nb in
    /// 0..=N (default 2).
    #[arg(long)]
    max_order: Option<usize>,
    /// How the spindle speed enters the model: `linear` (the model of [R4]), `quadratic` (speed and
    /// speed², for heat that grows faster than the speed), or `auto` (quadratic only if it predicts
    /// held-out runs better: each run predicted by the model of the others; needs two runs or more).
    #[arg(long, default_value = "linear", value_parser = parse_speed_model, conflicts_with = "log")]
    speed_model: SpeedModel,
    /// Further input columns of the training data (temperatures, …) that enter the model beside
    /// the speed, comma separated; `thermal predict` then needs them in SPEED.csv too.
    #[arg(long, value_delimiter = ',', conflicts_with = "log")]
    extra_inputs: Vec<String>,
    /// Output model file (TOML).
    #[arg(long)]
    out: PathBuf,
    /// Also write one SVG plot per height (measured and modelled drift over time) into this folder.
    #[arg(long, conflicts_with = "log")]
    plot: Option<PathBuf>,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// The heights argument: `--z -100,-300` (mm, comma separated, negatives allowed).
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Heights {
    /// Heights z (mm), comma separated, e.g. `--z -100,-300`.
    #[arg(
        long = "z",
        required = true,
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    z: Vec<String>,
}

impl Heights {
    /// The heights as numbers; an error names the bad item.
    fn parse(&self) -> anyhow::Result<Vec<f64>> {
        parse_heights(&self.z)
    }
}

pub fn parse_heights(items: &[String]) -> anyhow::Result<Vec<f64>> {
    let mut out = Vec::with_capacity(items.len());
    for s in items {
        let s = s.trim();
        match s.parse::<f64>() {
            Ok(z) if z.is_finite() => out.push(z),
            _ => anyhow::bail!(
                "--z: `{s}` is not a height in mm (give finite numbers separated by commas, e.g. --z -100,-300)"
            ),
        }
    }
    if out.is_empty() {
        anyhow::bail!("--z: give at least one height in mm");
    }
    Ok(out)
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct PredictArgs {
    /// Thermal model file (from `mtwin thermal fit`).
    #[arg(long)]
    model: PathBuf,
    /// Speed programme: `t_min,speed_rpm` on the model's sample grid.
    #[arg(long, required_unless_present = "log", conflicts_with = "log")]
    speed: Option<PathBuf>,
    /// A wide log with the input columns of a model fitted with `thermal fit --log`: writes
    /// `t_min` (period centres) and one predicted column per drift channel, in its unit.
    #[arg(long)]
    log: Option<PathBuf>,
    /// Heights z (mm), comma separated, e.g. `--z -100,-300` (with --speed).
    #[arg(
        long = "z",
        value_delimiter = ',',
        allow_hyphen_values = true,
        required_unless_present = "log",
        conflicts_with = "log"
    )]
    z: Vec<String>,
    /// Output CSV: `t_min,z_mm,drift_mm`, one row per time and height (with --log: `t_min` and
    /// one column per drift channel).
    #[arg(long)]
    out: PathBuf,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SimulateArgs {
    /// Thermal model file.
    #[arg(long)]
    model: PathBuf,
    /// Speed programme: `t_min,speed_rpm` on the model's sample grid.
    #[arg(long)]
    speed: PathBuf,
    #[command(flatten)]
    heights: Heights,
    /// Standard deviation of the white probing noise added to the drift, mm.
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Seed of the noise (same seed, same data).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output CSV in the TRAIN.csv layout: `t_min,speed_rpm,z_mm,drift_mm`.
    #[arg(long)]
    out: PathBuf,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Fit(a) => fit(a),
        Command::Predict(a) => predict(a),
        Command::Simulate(a) => simulate(a),
        Command::Compensate(a) => super::thermal_compensate::run(a),
        Command::Program(a) => program(a),
    }
}

fn program(a: ProgramArgs) -> anyhow::Result<()> {
    use mtwin::gcode::Dialect;
    let mut out = mtwin::io::Outputs::plan().output(&a.out).begin()?;
    let balls = thermal::BallArray {
        x0: a.x0,
        pitch: a.pitch,
        y: a.y,
        heights: a.heights.parse()?,
        diameter: a.ball_diameter,
    };
    let mut motion = thermal::ProbeMotion::default();
    motion.approach = a.approach;
    motion.overtravel = a.overtravel;
    motion.clearance = a.clearance;
    motion.feed = a.feed;
    motion.rapid_feed = a.rapid;
    let dialect = match a.dialect {
        DialectArg::Linuxcnc => Dialect::LinuxCnc,
        // Every number is written with a decimal point: the program reads
        // the same with and without decimal point programming.
        DialectArg::Fanuc => Dialect::Fanuc {
            decimal_point_programming: false,
        },
    };
    let p = match &a.machine {
        Some(path) => {
            let machine = super::common::load_machine(path)?;
            a.plan.check_machine(path, &machine)?;
            let timing = thermal::PlannedTiming {
                machine,
                plan: a.plan.options(),
            };
            thermal::thermal_program_on(
                &balls,
                &motion,
                &a.speeds,
                a.step_min,
                a.period_min,
                dialect,
                &timing,
            )?
        }
        None => thermal::thermal_program(
            &balls,
            &motion,
            &a.speeds,
            a.step_min,
            a.period_min,
            dialect,
        )?,
    };
    out.write(&a.out, p.text.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    match a.format {
        Format::Json => print_json(&json!({
            "out": a.out.display().to_string(),
            "passes": p.passes,
            "pass_s": p.pass_s,
            "period_min": a.period_min,
            "duration_min": p.duration_min,
            "time_s": p.time_s,
            "heights_mm": balls.heights,
        })),
        Format::Human => {
            println!(
                "{} probing passes (the cold one first) every {} min over {} min; one pass {:.1} s → {}",
                p.passes,
                a.period_min,
                p.duration_min,
                p.pass_s,
                a.out.display()
            );
            if a.machine.is_some() {
                note(format!(
                    "the times hold from the end of the initial positioning, by the {} planner on the machine",
                    a.plan.options().planner
                ));
            } else {
                note(
                    "the times hold from the end of the initial positioning, at the given rapid rate",
                );
            }
            Ok(())
        }
    }
}

fn parse_speed_model(s: &str) -> Result<SpeedModel, String> {
    s.parse()
}

/// `--folds`: one number of held-out blocks or several (never empty).
#[derive(Debug, Clone)]
struct FoldCounts(Vec<usize>);

fn parse_fold_counts(s: &str) -> Result<FoldCounts, String> {
    mtwin::methods::thermal::log::parse_fold_counts(s).map(FoldCounts)
}

fn parse_input_rule(s: &str) -> Result<InputRule, String> {
    s.parse()
}

fn parse_input_search(s: &str) -> Result<InputSearch, String> {
    s.parse()
}

fn parse_ambient(s: &str) -> Result<Ambient, String> {
    s.parse()
}

fn fit(a: FitArgs) -> anyhow::Result<()> {
    if let Some(log) = a.log.clone() {
        return fit_log(&log, a);
    }
    // Flags of --log only: refused without it, never silently ignored.
    let log_only = [
        ("--drift", !a.drift.is_empty()),
        ("--inputs", !a.inputs.is_empty()),
        ("--period-min", a.period_min.is_some()),
        ("--train-until-min", a.train_until_min.is_some()),
        ("--max-inputs", a.max_inputs.is_some()),
        ("--folds", a.folds.is_some()),
        ("--lags", a.lags),
        ("--input-rule", a.input_rule.is_some()),
        ("--search", a.search.is_some()),
        ("--start-offset", a.start_offset),
        ("--ambient", a.ambient.is_some()),
        ("--also-plain", a.also_plain),
    ];
    if let Some((flag, _)) = log_only.iter().find(|(_, given)| *given) {
        anyhow::bail!("{flag} applies to a wide log (--log LOG.csv), not to --data");
    }
    let Some(data) = a.data.clone() else {
        anyhow::bail!("give --data TRAIN.csv or --log LOG.csv");
    };
    let mut options = FitRunOptions::default();
    options.fit = ThermalFitOptions {
        max_order: a.max_order.unwrap_or(4),
        speed_model: a.speed_model,
        extra_inputs: a.extra_inputs.clone(),
        ..ThermalFitOptions::default()
    };
    options.plot = a.plot.is_some();
    options.out = a.out.display().to_string();
    options.fit.validate()?;
    let run = thermal::run_fit(&data, &options)?;
    let plots: Vec<(PathBuf, &String)> = a
        .plot
        .iter()
        .flat_map(|dir| run.plots.iter().map(|(name, svg)| (dir.join(name), svg)))
        .collect();
    let plot_files: Vec<PathBuf> = plots.iter().map(|(p, _)| p.clone()).collect();
    let mut out = mtwin::io::Outputs::plan()
        .input(&data)
        .output(&a.out)
        .folders(&a.plot)
        .outputs(&plot_files)
        .begin()?;
    out.write(&a.out, run.model_toml.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    for (path, svg) in &plots {
        out.write(path, svg.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    out.commit()?;
    for w in &run.doc.warnings {
        warn(w);
    }
    let mut doc = run.doc;
    doc.plots = plot_files.iter().map(|p| p.display().to_string()).collect();
    crate::output::print_doc(&doc, a.format)?;
    if a.format == Format::Human {
        for p in &doc.plots {
            note(format!("plot written: {p}"));
        }
    }
    Ok(())
}

/// `thermal fit --log`: flags to [`LogFitRunOptions`], a progress bar over
/// the forward selection steps of every channel.
fn fit_log(log: &Path, a: FitArgs) -> anyhow::Result<()> {
    if a.drift.is_empty() {
        anyhow::bail!("--drift: give the drift channels, e.g. --drift ch1_um:X,ch2_um:Z");
    }
    if a.inputs.is_empty() {
        anyhow::bail!("--inputs: give the input columns, e.g. --inputs speed_rpm,t1_c");
    }
    let mut options = LogFitRunOptions::default();
    options.channels = a
        .drift
        .iter()
        .map(|s| ChannelSpec::parse(s).map_err(|e| anyhow::anyhow!("--drift: {e}")))
        .collect::<anyhow::Result<_>>()?;
    options.inputs = a
        .inputs
        .iter()
        .map(|s| InputSpec::parse(s).map_err(|e| anyhow::anyhow!("--inputs: {e}")))
        .collect::<anyhow::Result<_>>()?;
    options.period_min = a.period_min.unwrap_or(options.period_min);
    options.train_until_min = a.train_until_min;
    options.fit.max_order = a.max_order.unwrap_or(options.fit.max_order);
    options.fit.max_inputs = a.max_inputs.unwrap_or(options.fit.max_inputs);
    if let Some(FoldCounts(folds)) = &a.folds {
        options.fit.folds = folds[0];
        options.fit.ensemble_folds = folds[1..].to_vec();
    }
    options.fit.lags = a.lags;
    options.fit.rule = a.input_rule.unwrap_or(options.fit.rule);
    options.fit.search = a.search.unwrap_or(options.fit.search);
    options.fit.start_offset = a.start_offset;
    options.ambient = a.ambient.clone();
    options.also_plain = a.also_plain;
    options.out = a.out.display().to_string();
    options.validate()?;
    let mut out = mtwin::io::Outputs::plan()
        .input(log)
        .output(&a.out)
        .begin()?;
    let steps = (options.fit.max_inputs.min(options.inputs.len()) + 1) as u64;
    let passes = options.fit.fold_counts().count() as u64;
    let bar = progress(options.channels.len() as u64 * passes * steps, "selecting");
    let run = thermal::run_fit_log(log, &options, &mut |p| {
        let c = p.channel as u64 * steps;
        bar.set_position(match p.step {
            // Exchanges and removals lengthen the path past the steps.
            Some(s) => c + (s as u64).min(steps - 1),
            None => c + steps,
        });
    });
    bar.finish_and_clear();
    let run = run?;
    out.write(&a.out, run.model_toml.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    for n in &run.doc.notes {
        note(n);
    }
    for w in &run.doc.warnings {
        warn(w);
    }
    crate::output::print_doc(&run.doc, a.format)
}

fn predict(a: PredictArgs) -> anyhow::Result<()> {
    if let Some(log) = &a.log {
        let mut out = mtwin::io::Outputs::plan()
            .input(&a.model)
            .input(log)
            .output(&a.out)
            .begin()?;
        let mut options = LogPredictRunOptions::default();
        options.out = a.out.display().to_string();
        let run = thermal::run_predict_log(&a.model, log, &options)?;
        out.write_with(&a.out, |w| run.write_csv_to(w))
            .with_context(|| format!("cannot write {}", a.out.display()))?;
        out.commit()?;
        for n in &run.doc.notes {
            note(n);
        }
        return crate::output::print_doc(&run.doc, a.format);
    }
    let Some(speed) = a.speed.clone() else {
        anyhow::bail!("give --speed SPEED.csv or --log LOG.csv");
    };
    let mut options = PredictRunOptions::default();
    options.heights = parse_heights(&a.z)?;
    options.out = a.out.display().to_string();
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.model)
        .input(&speed)
        .output(&a.out)
        .begin()?;
    let run = thermal::run_predict(&a.model, &speed, &options)?;
    out.write_with(&a.out, |w| run.prediction.write_csv_to(w))
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    for w in &run.doc.warnings {
        warn(w);
    }
    crate::output::print_doc(&run.doc, a.format)
}

fn simulate(a: SimulateArgs) -> anyhow::Result<()> {
    let heights = a.heights.parse()?;
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.model)
        .input(&a.speed)
        .output(&a.out)
        .begin()?;
    let model = thermal::read_model(&a.model).map_err(diag)?;
    let programme = thermal::read_programme(&a.speed, &model).map_err(diag)?;
    let data = thermal::simulate(&model, &programme, &heights, a.noise, a.seed)?;
    out.write_with(&a.out, |w| data.write_csv_to(w))
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    note(format!(
        "{} rows ({} height(s), noise {} mm, seed {}) → {}",
        data.rows.len(),
        heights.len(),
        mtwin::limits::fmt_message_number(a.noise),
        a.seed,
        a.out.display()
    ));
    let doc = thermal::ThermalSimulateDoc::new(
        &data,
        &heights,
        a.noise,
        a.seed,
        &a.out.display().to_string(),
    );
    crate::output::print_doc(&doc, a.format)
}
