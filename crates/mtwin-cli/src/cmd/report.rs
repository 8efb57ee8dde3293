//! `mtwin report`: one self-contained HTML file (inline CSS and SVG, no
//! script, no network) from the files the other commands write — their
//! `--format json` output saved to a file, model files and CSVs. The sections
//! are built by `mtwin::report::sections`, as in `mtwin demo`.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use mtwin::report::html::{Report, Section, render};
use mtwin::report::sections::{self, thermal::curves_from_rows};

use super::common::{diag, load_machine, load_table};
use crate::output::{Format, note, print_doc};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output HTML file.
    #[arg(long)]
    out: PathBuf,
    /// Title of the report.
    #[arg(long, default_value = "mtwin report")]
    title: String,
    /// Machine model (TOML), e.g. an identified one: location errors and every PDGE over its travel.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Saved output of `mtwin ballbar identify --format json`.
    #[arg(long)]
    ballbar: Option<PathBuf>,
    /// Folder of polar plots written by `ballbar identify --plot DIR` (mode1.svg … mode4.svg).
    #[arg(long, requires = "ballbar")]
    ballbar_plots: Option<PathBuf>,
    /// Saved output of `mtwin tracker identify --format json` (tracker identification).
    #[arg(long)]
    identify: Option<PathBuf>,
    /// Saved output of `mtwin tracker validate --format json`.
    #[arg(long)]
    validate: Option<PathBuf>,
    /// Saved output of `mtwin skiving setup-error --format json`.
    #[arg(long)]
    skiving: Option<PathBuf>,
    /// Thermal model written by `mtwin thermal fit` (THERMAL.toml).
    #[arg(long)]
    thermal_model: Option<PathBuf>,
    /// Drift written by `mtwin thermal predict` (t_min,z_mm,drift_mm), drawn over time.
    #[arg(long, requires = "thermal_model")]
    thermal_drift: Option<PathBuf>,
    /// Saved output of `mtwin thermal fit --log ... --format json`: per drift channel the held-out
    /// error, the chosen inputs and orders, the test span's scores.
    #[arg(long)]
    thermal_log_fit: Option<PathBuf>,
    /// With --thermal-log-fit: the model it wrote (--out of `thermal fit --log`), to draw the
    /// measured and predicted drift of --thermal-log.
    #[arg(long, requires_all = ["thermal_log_fit", "thermal_log"])]
    thermal_log_model: Option<PathBuf>,
    /// With --thermal-log-model: the log (the fitted one or another with the same columns), its
    /// drift channels drawn against the model's prediction from the log's start.
    #[arg(long, requires = "thermal_log_model")]
    thermal_log: Option<PathBuf>,
    /// Saved output of `mtwin servo fit --format json` for one axis, as AXIS=FILE (repeatable).
    #[arg(long, value_name = "AXIS=FILE")]
    servo: Vec<String>,
    /// Saved output of `mtwin positioning evaluate --format json` for one axis, as AXIS=FILE (repeatable).
    #[arg(long, value_name = "AXIS=FILE")]
    positioning: Vec<String>,
    /// Saved output of `mtwin ballbar circular --format json` (repeatable, e.g. one per plane).
    #[arg(long)]
    circular: Vec<PathBuf>,
    /// Saved output of `mtwin compensate --format json`.
    #[arg(long)]
    compensate: Option<PathBuf>,
    /// Prediction of `mtwin twin predict` (PRED.csv): trajectory errors along the path.
    #[arg(long)]
    twin: Option<PathBuf>,
    /// A second PRED.csv of the same program (e.g. after `mtwin compensate`), compared with --twin.
    #[arg(long, requires = "twin")]
    twin_compensated: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// A saved `--format json` document read into its type `D`, with errors
/// naming the file, line and column, and the field that does not fit.
fn read_doc<D: serde::de::DeserializeOwned>(path: &Path, what: &str) -> anyhow::Result<D> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| {
        let kind = if e.is_syntax() || e.is_eof() {
            "not a JSON document".to_string()
        } else {
            format!("not the output of `{what}`")
        };
        anyhow::anyhow!(
            "{}:{}:{}: {kind}: {e}",
            path.display(),
            e.line(),
            e.column()
        )
    })
}

fn section_err(path: &Path, e: sections::ReportError) -> anyhow::Error {
    anyhow::anyhow!("{}: {e}", path.display())
}

fn read_svg(path: &Path) -> anyhow::Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))
}

/// Every section the arguments ask for, in the order of the methods.
fn build(a: &Args) -> anyhow::Result<Vec<Section>> {
    let mut out = Vec::new();
    let name = |p: &Path| p.display().to_string();
    if let Some(p) = &a.machine {
        let m = load_machine(p)?;
        out.push(sections::machine::section(
            &m,
            "machine",
            &format!("Machine model: {}", m.name),
        ));
    }
    if let Some(p) = &a.ballbar {
        let mut figures = Vec::new();
        if let Some(dir) = &a.ballbar_plots {
            for m in ["mode1", "mode2", "mode3", "mode4"] {
                let f = dir.join(format!("{m}.svg"));
                if f.exists() {
                    figures.push((
                        format!("{m}: measured, fitted and compensated ΔL (µm)."),
                        read_svg(&f)?,
                    ));
                }
            }
            if figures.is_empty() {
                bail!("{}: no mode1.svg … mode4.svg in this folder", dir.display());
            }
        }
        out.push(
            sections::ballbar::section(
                &read_doc(p, "mtwin ballbar identify --format json")?,
                &name(p),
                figures,
            )
            .map_err(|e| section_err(p, e))?,
        );
    }
    if let Some(p) = &a.identify {
        out.push(sections::tracker::identify_section(&read_doc(
            p,
            "mtwin identify --format json",
        )?));
    }
    if let Some(p) = &a.validate {
        out.push(sections::tracker::validate_section(
            &read_doc(p, "mtwin validate --format json")?,
            None,
        ));
    }
    if let Some(p) = &a.skiving {
        out.push(sections::skiving::section(&read_doc(
            p,
            "mtwin skiving setup-error --format json",
        )?));
    }
    if let Some(p) = &a.thermal_model {
        let model = mtwin::methods::thermal::read_model(p).map_err(diag)?;
        let curves = match &a.thermal_drift {
            Some(d) => {
                let t = load_table(d)?;
                let rows = t
                    .number_rows(&mtwin::io::columns::THERMAL_PREDICTION)
                    .map_err(diag)?;
                curves_from_rows(&rows.iter().map(|r| [r[0], r[1], r[2]]).collect::<Vec<_>>())
            }
            None => Vec::new(),
        };
        out.push(sections::thermal::section(
            &model,
            &curves,
            "Predicted drift",
        ));
    }
    if let Some(p) = &a.thermal_log_fit {
        let doc: mtwin::methods::thermal::ThermalLogFitDoc =
            read_doc(p, "mtwin thermal fit --log --format json")?;
        let curves = match (&a.thermal_log_model, &a.thermal_log) {
            (Some(m), Some(l)) => {
                let model = mtwin::methods::thermal::log::LogModel::read(m).map_err(diag)?;
                let specs: Vec<_> = model.channels.iter().map(|c| c.channel.clone()).collect();
                let inputs: Vec<_> = model
                    .inputs
                    .iter()
                    .map(mtwin::methods::thermal::log::LogInput::spec)
                    .collect();
                let log = mtwin::methods::thermal::log::read_log(
                    &load_table(l)?,
                    &specs,
                    &inputs,
                    model.period_min,
                )
                .map_err(diag)?;
                sections::thermal::log_curves(&model, &log)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", l.display()))?
            }
            _ => Vec::new(),
        };
        out.push(sections::thermal::log_section(&doc, &curves));
    }
    if !a.servo.is_empty() {
        let mut fits = Vec::new();
        for s in &a.servo {
            let Some((axis, file)) = s.split_once('=') else {
                bail!("--servo {s}: give AXIS=FILE, e.g. --servo X=servo-x.json");
            };
            fits.push((
                axis.to_string(),
                read_doc(Path::new(file), "mtwin servo fit --format json")?,
            ));
        }
        out.push(sections::servo::section(&fits));
    }
    for s in &a.positioning {
        let Some((axis, file)) = s.split_once('=') else {
            bail!("--positioning {s}: give AXIS=FILE, e.g. --positioning X=x.json");
        };
        let doc: mtwin::methods::positioning::PositioningDoc =
            read_doc(Path::new(file), "mtwin positioning evaluate --format json")?;
        out.push(sections::positioning::section(&doc, Some(axis)));
    }
    for p in &a.circular {
        let doc: mtwin::methods::ballbar::circular::CircularDoc =
            read_doc(p, "mtwin ballbar circular --format json")?;
        out.push(sections::circular::section(&doc));
    }
    if let Some(p) = &a.compensate {
        out.push(sections::compensate::section(&read_doc(
            p,
            "mtwin compensate --format json",
        )?));
    }
    if let Some(p) = &a.twin {
        let rows = mtwin::report::twin::rows_from_table(&load_table(p)?)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        out.push(mtwin::report::twin::section_from_rows(
            "twin",
            "Digital twin: trajectory errors",
            &rows,
        ));
        if let Some(q) = &a.twin_compensated {
            let after = mtwin::report::twin::rows_from_table(&load_table(q)?)
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            out.push(mtwin::report::twin::comparison_section(
                "twin-compared",
                "Digital twin: the two predictions compared",
                (&name(p), &rows),
                (&name(q), &after),
            ));
        }
    }
    Ok(out)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let servo_files = a
        .servo
        .iter()
        .filter_map(|s| s.split_once('=').map(|(_, f)| f));
    let plot_files = a
        .ballbar_plots
        .iter()
        .flat_map(|d| ["mode1", "mode2", "mode3", "mode4"].map(|m| d.join(format!("{m}.svg"))));
    let mut out = mtwin::io::Outputs::plan()
        .inputs(&a.machine)
        .inputs(&a.ballbar)
        .inputs(plot_files)
        .inputs(&a.identify)
        .inputs(&a.validate)
        .inputs(&a.skiving)
        .inputs(&a.thermal_model)
        .inputs(&a.thermal_drift)
        .inputs(&a.thermal_log_fit)
        .inputs(&a.thermal_log_model)
        .inputs(&a.thermal_log)
        .inputs(servo_files)
        .inputs(
            a.positioning
                .iter()
                .filter_map(|s| s.split_once('=').map(|(_, f)| f)),
        )
        .inputs(&a.circular)
        .inputs(&a.compensate)
        .inputs(&a.twin)
        .inputs(&a.twin_compensated)
        .output(&a.out)
        .begin()?;
    let sections = build(&a)?;
    if sections.is_empty() {
        bail!(
            "nothing to report: give at least one input (--machine, --ballbar, --identify, --validate, --skiving, --thermal-model, --thermal-log-fit, --servo, --positioning, --circular, --compensate, --twin)"
        );
    }
    let figures: usize = sections.iter().map(Section::figures).sum();
    let n = sections.len();
    let report = Report {
        title: a.title.clone(),
        subtitle: format!("{n} section(s) from the results of mtwin commands."),
        sections,
    };
    out.write(&a.out, render(&report).as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    if a.format == Format::Human {
        note(format!("{n} section(s), {figures} figure(s)"));
    }
    let doc = sections::ReportDoc {
        figures,
        out: a.out.display().to_string(),
        sections: n,
    };
    print_doc(&doc, a.format)
}
