//! `mtwin import` (docs/controller-tables.md): controller compensation
//! tables read back into a machine model's error functions.

use std::path::PathBuf;

use anyhow::Context;
use mtwin::controller::Format as Table;
use mtwin::model::machine_to_toml;

use super::common::load_machine;
use super::export::To;
use crate::output::{Format, print_out};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Format of the table files.
    #[arg(long, value_enum)]
    from: To,
    /// Machine model file (TOML) the tables go into (usually the nominal machine); not changed.
    #[arg(long)]
    into: PathBuf,
    /// The new machine model file (TOML); must not be an input.
    #[arg(long)]
    out: PathBuf,
    /// Table files: isg/etalon a `.lis` list or parameter files; linuxcnc `comp_<AXIS>.txt` or
    /// AXIS=PATH; siemens-eec/-cec initialisation programs (AX1, AX2, … = axes in the order X Y Z A B C).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// `--format json` of `mtwin import`.
#[derive(Debug, serde::Serialize)]
struct Doc {
    /// `--from` name.
    format: &'static str,
    /// The model written.
    out: String,
    /// The errors the tables set, ISO 230-1 names.
    changed: Vec<String>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let machine = load_machine(&a.into)?;
    let format: Table = a.from.table();
    let imported = mtwin::controller::import(format, &a.files, &machine)
        .map_err(|d| anyhow::anyhow!("{d}"))?;
    // The files read (an AXIS= prefix of a LinuxCNC file is not part of its path).
    let read: Vec<PathBuf> = a
        .files
        .iter()
        .map(|f| match (format, f.to_string_lossy().split_once('=')) {
            (Table::LinuxCnc, Some((axis, p))) if !axis.contains(['/', '\\']) => PathBuf::from(p),
            _ => f.clone(),
        })
        .collect();
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.into)
        .inputs(&read)
        .output(&a.out)
        .begin()?;
    let names: Vec<String> = imported.changed.iter().map(|n| n.to_string()).collect();
    let header = [
        format!(
            "Machine model with controller tables ({}) read by `mtwin import` into {}.",
            format.name(),
            a.into.display()
        ),
        format!("Set from the tables: {}.", names.join(", ")),
    ];
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    out.write(
        &a.out,
        machine_to_toml(&imported.machine, &header)?.as_bytes(),
    )
    .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    match a.format {
        Format::Json => print_out(format_args!(
            "{}\n",
            serde_json::to_string_pretty(&Doc {
                format: format.name(),
                out: a.out.display().to_string(),
                changed: names,
            })?
        )),
        Format::Human => print_out(format_args!(
            "{}: wrote {} with {} error(s) from the tables: {}\n",
            format.name(),
            a.out.display(),
            names.len(),
            if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            }
        )),
    }
    Ok(())
}
