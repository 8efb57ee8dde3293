//! `mtwin compensate`: rewrite a part program so that the identified (actual)
//! machine reaches the nominal targets.

use std::path::PathBuf;

use mtwin::methods::compensate::{
    CompensateDoc, CompensateError, CompensateOptions, Compensator, Summary,
};

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
    anyhow::ensure!(
        a.tol > 0.0 && a.tol.is_finite(),
        "--tol must be a positive number of mm, not {}",
        mtwin::limits::fmt_message_number(a.tol)
    );
    anyhow::ensure!(
        a.max_correction > 0.0 && a.max_correction.is_finite(),
        "--max-correction must be a positive number of mm, not {}",
        mtwin::limits::fmt_message_number(a.max_correction)
    );
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.machine)
        .input(&a.program)
        .output(&a.out)
        .begin()?;
    let m = load_machine(&a.machine)?;
    let mut opts = CompensateOptions::default();
    opts.tol = a.tol;
    opts.max_correction = a.max_correction;
    opts.interp = super::gcode::interp_options(&a.offsets, &a.dialect, &a.program)?;
    opts.interp.tcp_at_start = a.tcp;
    let comp =
        Compensator::new(&m, opts).map_err(|e| anyhow::anyhow!("{}: {e}", a.machine.display()))?;
    let (input, bar) = crate::output::open_with_progress(&a.program, "compensate")?;
    let mut summary = Summary::default();
    let written = out.write_with(&a.out, |w| -> Result<(), CompensateError> {
        summary = comp.run(input, w)?;
        Ok(())
    });
    bar.finish_and_clear();
    written.map_err(|e| match e {
        CompensateError::Io(e) => anyhow::anyhow!("cannot write {}: {e}", a.out.display()),
        CompensateError::Gcode(e) => super::common::located_error(&a.program, &e),
        e => super::gcode::located(&a.program, e.line(), e.column(), &e),
    })?;
    out.commit()?;
    for n in &summary.notes {
        note(n);
    }
    print_doc(
        &CompensateDoc::new(&summary, &a.out.display().to_string()),
        a.format,
    )
}
