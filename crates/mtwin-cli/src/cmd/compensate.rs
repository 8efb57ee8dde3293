//! `mtwin compensate`: rewrite a part program so that the identified (actual)
//! machine reaches the nominal targets.

use std::path::PathBuf;

use mtwin::methods::compensate::{self, CompensateDoc, CompensateError, CompensateOptions};

use super::common::{DialectArgs, load_machine};
use crate::output::{Format, note, print_doc};

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Identified machine model (TOML): its errors are the actual machine.
    #[arg(long)]
    machine: PathBuf,
    /// Part program to compensate (G-code; `--dialect` says how it reads).
    #[arg(long)]
    program: PathBuf,
    /// Compensated program to write (not written on any error).
    #[arg(long)]
    out: PathBuf,
    /// Largest deviation of the compensated path from the nominal path, mm.
    #[arg(long, default_value_t = 0.001)]
    tol: f64,
    /// Largest accepted correction of one target, mm.
    #[arg(long, default_value_t = 0.5)]
    max_correction: f64,
    /// The program is written for tool centre point control from its start
    /// (X Y Z = tool tip in the work frame); M428/M429 switch it anywhere.
    #[arg(long)]
    tcp: bool,
    /// G54 work offset of one axis, `AXIS=VALUE` (mm, deg); repeatable.
    #[arg(long = "offset", value_name = "AXIS=VALUE")]
    offsets: Vec<String>,
    #[command(flatten)]
    dialect: DialectArgs,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mut opts = CompensateOptions::default();
    opts.tol = a.tol;
    opts.max_correction = a.max_correction;
    let error = |e: CompensateError| match e {
        CompensateError::Setting { option, problem } => {
            anyhow::anyhow!("--{} {problem}", option.replace('_', "-"))
        }
        CompensateError::Io(e) => anyhow::anyhow!("cannot write {}: {e}", a.out.display()),
        CompensateError::Gcode(e) => super::common::located_error(&a.program, &e),
        CompensateError::AxisName(e) => anyhow::anyhow!("{}: {e}", a.machine.display()),
        e => super::gcode::located(&a.program, e.line(), e.column(), e.message()),
    };
    opts.validate().map_err(error)?;
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.machine)
        .input(&a.program)
        .output(&a.out)
        .begin()?;
    let m = load_machine(&a.machine)?;
    opts.interp = super::gcode::interp_options(&a.offsets, &a.dialect, &a.program, Some(&m))?;
    opts.interp.tcp_at_start = a.tcp;
    let (input, bar) = crate::output::open_with_progress(&a.program, "compensate")?;
    let mut result = None;
    let written = out.write_with(&a.out, |w| -> Result<(), CompensateError> {
        result = Some(compensate::run(&m, input, w, &opts)?);
        Ok(())
    });
    bar.finish_and_clear();
    written.map_err(error)?;
    out.commit()?;
    let (summary, doc) = result.ok_or_else(|| anyhow::anyhow!("the compensation did not run"))?;
    for n in &summary.notes {
        note(n);
    }
    let doc = CompensateDoc {
        out: a.out.display().to_string(),
        ..doc
    };
    print_doc(&doc, a.format)
}
