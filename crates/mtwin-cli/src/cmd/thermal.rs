//! `mtwin thermal …` ([R4] in docs/references.md): fit the spindle-speed-driven drift
//! model from probing data, predict the drift of a speed programme, and
//! simulate probing data from a model.
//!
//! Units: time in minutes, speed in rev/min, heights and drift in mm (drift =
//! displacement of the tool relative to the workpiece in +Z).

use std::path::{Path, PathBuf};

use anyhow::Context;
use mtwin::methods::thermal::{
    self, Programme, SpeedModel, ThermalFitOptions, ThermalModel, TrainingData, read_training,
};
use mtwin::report::svg::{Series, xy};
use serde_json::json;

use super::common::DialectArg;
use super::common::diag;
use crate::output::{Format, note, print_json, warn};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Fit one ARX drift model per measured height from TRAIN.csv (orders by FPE).
    #[command(
        after_help = "Example:\n  mtwin thermal fit --data train.csv --max-order 3 --out thermal.toml --plot plots"
    )]
    Fit(FitArgs),
    /// Predict the drift of a spindle-speed programme at given heights (from cold).
    #[command(
        after_help = "Example:\n  mtwin thermal predict --model thermal.toml --speed speed.csv --z -100,-300 --out drift.csv"
    )]
    Predict(PredictArgs),
    /// Simulate probing data (TRAIN.csv layout) of a model for a speed programme.
    #[command(
        after_help = "Example:\n  mtwin thermal simulate --model thermal.toml --speed speed.csv --z -50,-350 --noise 0.001 --seed 7 --out train.csv"
    )]
    Simulate(SimulateArgs),
    /// Pre-compensate an NC program: Z targets replaced by Z − e(t, Z) (as in [R4], docs/references.md).
    #[command(
        after_help = "Example:\n  mtwin thermal compensate --model thermal.toml --program part.nc --out part-comp.nc --period-min 10"
    )]
    Compensate(super::thermal_compensate::Args),
    /// Write the measurement programme as G-code: cold pass, then spindle speeds with a probing pass every period.
    #[command(
        after_help = "Example:\n  mtwin thermal program --z -50,-150,-250,-350 --x0 -100 --pitch 50 --speeds 2000,4000,6000 --step-min 60 --period-min 10 --out thermal.ngc"
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
    /// Rapid rate assumed for the timing, mm/min (as `gcode stats --rapid`).
    #[arg(long, default_value_t = 10000.0)]
    rapid: f64,
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
    #[arg(long)]
    data: PathBuf,
    /// Largest ARX order tried (na in 1..=N, nb in 0..=N).
    #[arg(long, default_value_t = 4)]
    max_order: usize,
    /// How the spindle speed enters the model: `linear` (the model of [R4]), `quadratic` (speed and
    /// speed², for heat that grows faster than the speed), or `auto` (quadratic only if it predicts
    /// held-out runs better: each run predicted by the model of the others; needs two runs or more).
    #[arg(long, default_value = "linear", value_parser = parse_speed_model)]
    speed_model: SpeedModel,
    /// Further input columns of the training data (temperatures, …) that enter the model beside
    /// the speed, comma separated; `thermal predict` then needs them in SPEED.csv too.
    #[arg(long, value_delimiter = ',')]
    extra_inputs: Vec<String>,
    /// Output model file (TOML).
    #[arg(long)]
    out: PathBuf,
    /// Also write one SVG plot per height (measured and modelled drift over time) into this folder.
    #[arg(long)]
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

fn parse_heights(items: &[String]) -> anyhow::Result<Vec<f64>> {
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
    #[arg(long)]
    speed: PathBuf,
    #[command(flatten)]
    heights: Heights,
    /// Output CSV: `t_min,z_mm,drift_mm`, one row per time and height.
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
    let p = thermal::thermal_program(
        &balls,
        &motion,
        &a.speeds,
        a.step_min,
        a.period_min,
        dialect,
    )?;
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
            note("the times hold from the end of the initial positioning, at the given rapid rate");
            Ok(())
        }
    }
}

fn parse_speed_model(s: &str) -> Result<SpeedModel, String> {
    s.parse()
}

fn fit(a: FitArgs) -> anyhow::Result<()> {
    let options = ThermalFitOptions {
        max_order: a.max_order,
        speed_model: a.speed_model,
        extra_inputs: a.extra_inputs.clone(),
        ..ThermalFitOptions::default()
    };
    options.validate()?;
    let data = read_training(&a.data, &options.extra_inputs).map_err(diag)?;
    // The plot files are named after the heights of the data.
    let plot_files: Vec<PathBuf> = a
        .plot
        .iter()
        .flat_map(|dir| data.heights.iter().map(|h| plot_path(dir, h.z_mm)))
        .collect();
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.data)
        .output(&a.out)
        .folders(&a.plot)
        .outputs(&plot_files)
        .begin()?;
    let fit = thermal::fit(&data, &options)?;
    out.write(&a.out, fit.model.to_toml()?.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    let mut plots = Vec::new();
    if let Some(dir) = &a.plot {
        plots = write_plots(&mut out, dir, &data, &fit.model)?;
    }
    out.commit()?;
    for w in &fit.warnings {
        warn(w);
    }
    let plots: Vec<String> = plots.iter().map(|p| p.display().to_string()).collect();
    let doc = thermal::ThermalFitDoc::new(&fit, &a.out.display().to_string(), &plots);
    crate::output::print_doc(&doc, a.format)?;
    if a.format == Format::Human {
        for p in &plots {
            note(format!("plot written: {p}"));
        }
    }
    Ok(())
}

fn predict(a: PredictArgs) -> anyhow::Result<()> {
    let heights = a.heights.parse()?;
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.model)
        .input(&a.speed)
        .output(&a.out)
        .begin()?;
    let model = thermal::read_model(&a.model).map_err(diag)?;
    let programme = thermal::read_programme(&a.speed, &model).map_err(diag)?;
    let p = thermal::predict(&model, &programme, &heights);
    // An unstable model diverges: never write inf or NaN with exit 0.
    if let Some(r) = p.rows.iter().find(|r| r.iter().any(|v| !v.is_finite())) {
        anyhow::bail!(
            "{}: the predicted drift overflows at t = {} min, z = {} mm (the model is unstable or \
             its coefficients too large); nothing written",
            a.model.display(),
            mtwin::limits::fmt_message_number(r[0]),
            mtwin::limits::fmt_message_number(r[1])
        );
    }
    out.write_with(&a.out, |w| p.write_csv_to(w))
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    let warnings = p.warnings(&model);
    for w in &warnings {
        warn(w);
    }
    let doc = thermal::ThermalPredictDoc::new(&p, &heights, &a.out.display().to_string(), warnings);
    crate::output::print_doc(&doc, a.format)
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

/// One SVG per measured height: the measured drift (dots) and the model
/// simulated from cold with the run's own speeds (line), every run after the
/// previous one on the time axis. Returns the files written.
fn write_plots(
    out: &mut mtwin::io::Outputs,
    dir: &Path,
    data: &TrainingData,
    model: &ThermalModel,
) -> anyhow::Result<Vec<PathBuf>> {
    let period = model.period_min();
    let mut written = Vec::new();
    for (hi, h) in data.heights.iter().enumerate() {
        let mut measured = Vec::new();
        let mut modelled = Vec::new();
        let mut t0 = 0.0;
        for s in &h.series {
            let n = s.drift.len();
            let samples: Vec<Vec<f64>> = (0..n)
                .map(|k| s.inputs.iter().map(|u| u[k]).collect())
                .collect();
            let history = model.drift_history(&Programme::new(samples));
            let mut line = Vec::with_capacity(n);
            for (k, (&d, e)) in s.drift.iter().zip(&history).enumerate() {
                let t = t0 + k as f64 * period;
                measured.push((t, d * 1e3));
                line.push((t, e[hi] * 1e3));
            }
            modelled.push(line);
            t0 += n as f64 * period;
        }
        let title = format!("Thermal drift at z = {} mm", h.z_mm);
        let mut series = vec![Series {
            name: "measured".into(),
            points: measured,
            color: "#1f77b4".into(),
            markers: true,
        }];
        let runs = modelled.len();
        series.extend(modelled.into_iter().enumerate().map(|(r, points)| Series {
            name: if runs == 1 {
                "model (from cold)".into()
            } else {
                format!("model run {} (from cold)", r + 1)
            },
            points,
            color: "#d62728".into(),
            markers: false,
        }));
        let svg = xy(&title, "t (min)", "drift (µm)", &series);
        let path = plot_path(dir, h.z_mm);
        out.write(&path, svg.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}

/// The plot file of one height.
fn plot_path(dir: &Path, z_mm: f64) -> PathBuf {
    dir.join(format!("drift_z{z_mm}.svg"))
}

#[cfg(test)]
mod tests {
    use super::parse_heights;

    #[test]
    fn heights_parse_negatives_and_reject_garbage() {
        let v: Vec<String> = ["-100", " -300.5", "2e1"].map(String::from).to_vec();
        assert_eq!(parse_heights(&v).unwrap(), vec![-100.0, -300.5, 20.0]);
        for bad in ["abc", "nan", "inf", ""] {
            let e = parse_heights(&[bad.to_string()]).unwrap_err().to_string();
            assert!(e.starts_with("--z:"), "{e}");
        }
    }
}
