//! `mtwin positioning …`: linear positioning accuracy of an axis after
//! ISO 230-2 (docs/positioning.md). Units: mm for positions, µm for figures.

use std::path::PathBuf;

use anyhow::Context;
use mtwin::methods::positioning::{self, InputFormat, LogOptions, Options};

use mtwin::model::machine_to_toml;

use super::common::{diag, load_machine};
use crate::output::{Format, note, print_doc};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// ISO 230-2 evaluation of a positioning run: A, B, E, M, R per direction and per target.
    #[command(
        after_help = "Example:\n  mtwin positioning evaluate --data run.csv\n  mtwin positioning evaluate --data target_x_ISO230.dat --format json --plot x.svg\n  mtwin positioning evaluate --data x.log --ref-channel IOC_TEST:ILD_DownSample --cmd-channel TARGET_DU:X-PosCmd --ref-gain -1.0035779146 --ref-offset 50.3193131396\n  mtwin positioning evaluate --data x.csv --update-model m.toml --axis X --out-model m-with-exx.toml"
    )]
    Evaluate(EvaluateArgs),
}

/// Input formats of `--data`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum DataFormat {
    /// From the file name: .csv, .dat, .rtx, anything else a raw log.
    #[default]
    Auto,
    /// CSV table: target_mm,direction[,cycle],measured_mm|deviation_mm|deviation_um.
    Csv,
    /// ecmc key=value data file (TGT_DATA[i], REF_DATA_FWD[i,j], REF_DATA_BWD[i,j]).
    Dat,
    /// Renishaw dynamic capture (needs --targets).
    Rtx,
    /// Raw log, `NAME date time value` lines (needs --ref-channel and --cmd-channel).
    Log,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct EvaluateArgs {
    /// The run: CSV table, ecmc .dat, Renishaw .rtx or raw log.
    #[arg(long)]
    data: PathBuf,
    /// Format of --data.
    #[arg(long, value_enum, default_value_t)]
    input_format: DataFormat,
    /// Write the plot (deviation against position per direction, ±2s band) as SVG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Raw log: channel of the measured reference position.
    #[arg(long)]
    ref_channel: Option<String>,
    /// Raw log: channel of the commanded position.
    #[arg(long)]
    cmd_channel: Option<String>,
    /// Raw log or capture: reference in mm = gain × value + offset.
    #[arg(long, default_value_t = 1.0)]
    ref_gain: f64,
    /// Raw log or capture: see --ref-gain, mm.
    #[arg(long, default_value_t = 0.0)]
    ref_offset: f64,
    /// Target positions, mm, comma separated (default for logs: every commanded value approached from both sides).
    #[arg(long, value_delimiter = ',')]
    targets: Option<Vec<f64>>,
    /// Largest spread of the samples of a dwell, mm.
    #[arg(long, default_value_t = 0.005)]
    dwell_band: f64,
    /// Fewest samples that make a dwell (raw logs).
    #[arg(long, default_value_t = 3)]
    min_dwell_samples: usize,
    /// Shortest dwell in a capture, s.
    #[arg(long, default_value_t = 0.5)]
    min_dwell_s: f64,
    /// Largest |measured − target| of a dwell that reaches its target, mm.
    #[arg(long, default_value_t = 0.1)]
    reach_tol: f64,
    /// Machine model (TOML) to receive the axis's positioning error (with --axis and --out-model; never overwritten).
    #[arg(long, requires_all = ["axis", "out_model"])]
    update_model: Option<PathBuf>,
    /// Axis of --update-model the run measured (X gets EXX, Y EYY, C ECC, …).
    #[arg(long, requires = "update_model")]
    axis: Option<String>,
    /// Where to write the updated machine model (a new file; not an input).
    #[arg(long, requires = "update_model")]
    out_model: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Evaluate(a) => evaluate(a),
    }
}

fn evaluate(a: EvaluateArgs) -> anyhow::Result<()> {
    super::common::positive("--dwell-band", a.dwell_band)?;
    super::common::positive("--min-dwell-s", a.min_dwell_s)?;
    super::common::positive("--reach-tol", a.reach_tol)?;
    if !(a.ref_gain.is_finite() && a.ref_gain != 0.0 && a.ref_offset.is_finite()) {
        anyhow::bail!("--ref-gain must be a non-zero number and --ref-offset a number");
    }
    if let Some(t) = &a.targets
        && t.iter().any(|v| !v.is_finite())
    {
        anyhow::bail!("--targets must be numbers");
    }
    let mut plan = mtwin::io::Outputs::plan().input(&a.data);
    if let Some(p) = &a.plot {
        plan = plan.output(p);
    }
    if let (Some(m), Some(o)) = (&a.update_model, &a.out_model) {
        plan = plan.input(m).output(o);
    }
    let mut out = plan.begin()?;
    let opts = Options {
        format: match a.input_format {
            DataFormat::Auto => InputFormat::Auto,
            DataFormat::Csv => InputFormat::Csv,
            DataFormat::Dat => InputFormat::Dat,
            DataFormat::Rtx => InputFormat::Rtx,
            DataFormat::Log => InputFormat::Log,
        },
        log: LogOptions {
            reference: a.ref_channel.clone(),
            command: a.cmd_channel.clone(),
            gain: a.ref_gain,
            offset: a.ref_offset,
            targets_mm: a.targets.clone(),
            dwell_band_mm: a.dwell_band,
            min_dwell_samples: a.min_dwell_samples,
            min_dwell_s: a.min_dwell_s,
            reach_tol_mm: a.reach_tol,
        },
    };
    let doc = positioning::run(&a.data, &opts).map_err(diag)?;
    let mut updated = None;
    if let (Some(mpath), Some(axis), Some(opath)) = (&a.update_model, &a.axis, &a.out_model) {
        let machine = load_machine(mpath)?;
        let (m, u) = positioning::update_machine(&machine, axis, &doc)
            .map_err(|e| anyhow::anyhow!("{}: {e}", mpath.display()))?;
        let header = [
            format!(
                "Machine model {} with {} from the ISO 230-2 run {}:",
                mpath.display(),
                u.error,
                a.data.display()
            ),
            "the mean bidirectional deviation per target (actual - commanded), written by `mtwin positioning evaluate --update-model`.".to_string(),
        ];
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        out.write(opath, machine_to_toml(&m, &header)?.as_bytes())
            .with_context(|| format!("cannot write {}", opath.display()))?;
        updated = Some((u, opath.clone()));
    }
    if let Some(p) = &a.plot {
        out.write(p, positioning::plot_svg(&doc).as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    out.commit()?;
    print_doc(&doc, a.format)?;
    if a.format == Format::Human
        && let Some(p) = &a.plot
    {
        note(format!("plot written to {}", p.display()));
    }
    if let Some((u, p)) = updated {
        note(format!(
            "{} of {} points{} written to {}",
            u.error,
            u.q.len(),
            if u.replaced {
                " (replacing the model's)"
            } else {
                ""
            },
            p.display()
        ));
    }
    Ok(())
}
