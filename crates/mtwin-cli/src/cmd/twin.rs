//! `mtwin twin predict` ([R5] in docs/references.md): the five-axis digital twin of
//! trajectory error. Commands (CMD.csv or a G-code program) → command and actual
//! tool tip and tool axis in W → tool-tip error ε_p (mm) and tool-axis error ε_o
//! (rad) against the exact nearest point of the command path, per sample, in
//! PRED.csv.

use std::path::{Path, PathBuf};

use anyhow::Context;
use mtwin::gcode::InterpolateOptions;
use mtwin::io::write_csv_row;
use mtwin::methods::twin::{
    self, Progress, Sources, Twin, TwinError, TwinSample, TwinSummary, plot::PlotCollector,
};
use mtwin::model::Machine;
use serde_json::{Value, json};

use super::common::DialectArgs;
use super::common::load_machine;
use super::gcode::{interp_options, located, open};
use crate::output::{Format, print_json, progress};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Predict the tool-tip and tool-axis trajectory errors of a program or of axis commands.
    #[command(
        after_help = "Example:\n  mtwin twin predict --machine examples/machines/ac-trunnion-twin.toml --commands cmd.csv --out pred.csv\n  mtwin twin predict --machine examples/machines/ac-trunnion-twin.toml --gcode part.nc --tcp --ts 0.001 --out pred.csv --plot plots --format json"
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
    /// Interpolate samples outside the axis travels instead of stopping.
    #[arg(long, requires = "gcode")]
    no_travel_check: bool,
    /// Output PRED.csv: t_s, command and actual tool tip (mm) and axis in W, tip_error (mm), axis_error (rad).
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

/// One run of the twin on the input of `a`, rows to `sink`.
fn run_twin(
    a: &PredictArgs,
    machine: &Machine,
    sources: Sources,
    sink: impl FnMut(&TwinSample) -> std::io::Result<()>,
) -> anyhow::Result<TwinSummary> {
    let twin = Twin::new(machine, sources)?;
    let pb = progress(0, &format!("twin {}", sources.as_str()));
    let mut hook = |p: Progress| match p {
        Progress::Commands(n) => {
            pb.set_length(n);
            pb.set_position(n);
        }
        Progress::Errors { done, total } => {
            pb.set_length(total);
            pb.set_position(done);
        }
    };
    let r = if let Some(path) = &a.commands {
        twin::predict_csv(&twin, path, open(path)?, sink, &mut hook)
    } else {
        let path = a
            .gcode
            .as_deref()
            .context("--commands or --gcode is needed")?;
        let mut opts = InterpolateOptions::new(a.ts);
        opts.interp = interp_options(&a.offsets, &a.dialect)?;
        opts.interp.tcp_at_start = a.tcp;
        opts.check_travel = !a.no_travel_check;
        twin::predict_gcode(&twin, machine, open(path)?, &opts, sink, &mut hook)
    };
    pb.finish_and_clear();
    r.map_err(|e| match (e, &a.gcode) {
        (TwinError::Program(e), Some(p)) => located(p, e.line(), e.column(), &e),
        (e, _) => e.into(),
    })
}

/// The plot files written into `--plot DIR`.
const PLOT_FILES: [&str; 3] = ["path.svg", "tip_error.svg", "axis_error.svg"];

fn predict(a: PredictArgs) -> anyhow::Result<()> {
    let plot_files: Vec<PathBuf> = a
        .plot
        .iter()
        .flat_map(|d| PLOT_FILES.map(|f| d.join(f)))
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
    let sources = match a.only {
        None => Sources::All,
        Some(Only::Servo) => Sources::Servo,
        Some(Only::Geometry) => Sources::Geometry,
    };
    let mut plot = a.plot.as_ref().map(|_| PlotCollector::new(2000));
    let mut summary = None;
    out.write_with(&a.out, |w| -> anyhow::Result<()> {
        // The PRED.csv columns, defined once beside the reader of the report.
        writeln!(w, "{}", mtwin::report::twin::COLUMNS.join(","))?;
        let s = run_twin(&a, &machine, sources, |r| {
            if let Some(p) = plot.as_mut() {
                p.add(r);
            }
            write_csv_row(
                w,
                &[
                    r.t,
                    r.cmd_tip.x,
                    r.cmd_tip.y,
                    r.cmd_tip.z,
                    r.cmd_axis.x,
                    r.cmd_axis.y,
                    r.cmd_axis.z,
                    r.tip.x,
                    r.tip.y,
                    r.tip.z,
                    r.axis.x,
                    r.axis.y,
                    r.axis.z,
                    r.tip_error,
                    r.axis_error,
                ],
            )
        })?;
        summary = Some(s);
        Ok(())
    })?;
    let s = summary.context("the twin produced no summary")?;
    let parts = if a.breakdown {
        Some([
            run_twin(&a, &machine, Sources::Servo, |_| Ok(()))?,
            run_twin(&a, &machine, Sources::Geometry, |_| Ok(()))?,
        ])
    } else {
        None
    };
    let mut plots = Vec::new();
    if let (Some(dir), Some(p)) = (&a.plot, &plot) {
        let pts = p.points();
        for (name, svg) in PLOT_FILES.into_iter().zip([
            twin::plot::path_svg(&pts),
            twin::plot::tip_error_svg(&pts),
            twin::plot::axis_error_svg(&pts),
        ]) {
            let f = dir.join(name);
            out.write(&f, svg.as_bytes())
                .with_context(|| format!("cannot write {}", f.display()))?;
            plots.push(f);
        }
    }
    out.commit()?;
    match a.format {
        Format::Json => {
            let mut v = summary_json(&s);
            v["out"] = json!(a.out.display().to_string());
            v["sources"] = json!(s.sources.as_str());
            if let Some([sv, ge]) = &parts {
                v["breakdown"] = breakdown_json(&s, sv, ge);
            }
            if !plots.is_empty() {
                v["plots"] = plots
                    .iter()
                    .map(|p| json!(p.display().to_string()))
                    .collect();
            }
            print_json(&v)
        }
        Format::Human => {
            print_human(&s, &a.out);
            if let Some([sv, ge]) = &parts {
                print_breakdown(&s, sv, ge);
            }
            for p in &plots {
                println!("plot → {}", p.display());
            }
            Ok(())
        }
    }
}

fn summary_json(s: &TwinSummary) -> Value {
    json!({
        "samples": s.samples,
        "tip_error_max": s.tip_error_max,
        "tip_error_rms": s.tip_error_rms,
        "axis_error_max": s.axis_error_max,
        "axis_error_rms": s.axis_error_rms,
        "tip_error_max_t_s": s.tip_error_max_at.t,
        "tip_error_max_path_mm": s.tip_error_max_at.path_length,
        "axis_error_max_t_s": s.axis_error_max_at.t,
        "axis_error_max_path_mm": s.axis_error_max_at.path_length,
        "duration_s": s.t[1] - s.t[0],
        "path_length_mm": s.path_length,
    })
}

/// The source whose tool-tip RMS is larger in a stretch.
fn dominant(servo: f64, geometry: f64) -> &'static str {
    if servo >= geometry {
        "servo"
    } else {
        "geometry"
    }
}

fn breakdown_json(all: &TwinSummary, sv: &TwinSummary, ge: &TwinSummary) -> Value {
    let core = |s: &TwinSummary| {
        json!({"tip_error_max": s.tip_error_max, "tip_error_rms": s.tip_error_rms,
               "axis_error_max": s.axis_error_max, "axis_error_rms": s.axis_error_rms})
    };
    let bins: Vec<Value> = all
        .bins
        .iter()
        .zip(&sv.bins)
        .zip(&ge.bins)
        .map(|((b, s), g)| {
            json!({
                "t_s": b.t, "path_mm": b.path_length,
                "tip_error_rms": {"all": b.tip_error_rms, "servo": s.tip_error_rms, "geometry": g.tip_error_rms},
                "tip_error_max": {"all": b.tip_error_max, "servo": s.tip_error_max, "geometry": g.tip_error_max},
                "dominant": dominant(s.tip_error_rms, g.tip_error_rms),
            })
        })
        .collect();
    json!({
        "all": core(all), "servo": core(sv), "geometry": core(ge),
        "dominant": dominant(sv.tip_error_rms, ge.tip_error_rms),
        "stretches": bins,
    })
}

fn print_human(s: &TwinSummary, out: &Path) {
    let what = match s.sources {
        Sources::All => "servo + geometry",
        Sources::Servo => "servo only",
        Sources::Geometry => "geometry only",
    };
    println!(
        "{} samples, {:.3} s, command path {:.3} mm ({what}) → {}",
        s.samples,
        s.t[1] - s.t[0],
        s.path_length,
        out.display()
    );
    println!(
        "tool-tip error ε_p:  max {:.3} µm at t = {:.3} s (path {:.3} mm), RMS {:.3} µm",
        s.tip_error_max * 1e3,
        s.tip_error_max_at.t,
        s.tip_error_max_at.path_length,
        s.tip_error_rms * 1e3
    );
    println!(
        "tool-axis error ε_o: max {:.3} µrad at t = {:.3} s (path {:.3} mm), RMS {:.3} µrad",
        s.axis_error_max * 1e6,
        s.axis_error_max_at.t,
        s.axis_error_max_at.path_length,
        s.axis_error_rms * 1e6
    );
}

fn print_breakdown(all: &TwinSummary, sv: &TwinSummary, ge: &TwinSummary) {
    println!("\nbreakdown (tool-tip error ε_p in µm, tool-axis error ε_o in µrad):");
    println!(
        "  {:<10} {:>12} {:>12} {:>12}",
        "source", "ε_p max", "ε_p RMS", "ε_o max"
    );
    for (n, s) in [("all", all), ("servo", sv), ("geometry", ge)] {
        println!(
            "  {:<10} {:>12.3} {:>12.3} {:>12.3}",
            n,
            s.tip_error_max * 1e3,
            s.tip_error_rms * 1e3,
            s.axis_error_max * 1e6
        );
    }
    println!(
        "  dominant overall: {}",
        dominant(sv.tip_error_rms, ge.tip_error_rms)
    );
    println!(
        "\n  {:>21} {:>12} {:>12} {:>12}  dominant",
        "path, mm", "all RMS", "servo RMS", "geom. RMS"
    );
    for ((b, s), g) in all.bins.iter().zip(&sv.bins).zip(&ge.bins) {
        println!(
            "  {:>10.3}–{:<10.3} {:>12.3} {:>12.3} {:>12.3}  {}",
            b.path_length[0],
            b.path_length[1],
            b.tip_error_rms * 1e3,
            s.tip_error_rms * 1e3,
            g.tip_error_rms * 1e3,
            dominant(s.tip_error_rms, g.tip_error_rms)
        );
    }
}
