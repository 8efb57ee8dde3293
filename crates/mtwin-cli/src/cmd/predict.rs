//! `mtwin predict` (see docs/machine-model.md): the actual tool tip and tool axis in W at given poses.

use std::path::PathBuf;

use anyhow::Context;
use mtwin::kinematics::PREDICT_COLUMNS;
use mtwin::model::read_poses;

use super::common::{diag, load_machine, load_table};
use crate::output::{Format, TableWriter, print_doc};

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Machine model file (TOML) with the errors to apply.
    #[arg(long)]
    machine: PathBuf,
    /// CSV with one column per axis (mm, deg); other columns are ignored.
    #[arg(long)]
    data: PathBuf,
    /// Output CSV: the axis columns, then x,y,z (mm) and i,j,k of the actual tool in W
    /// (a Parquet file of the same columns when the name ends in `.parquet`).
    #[arg(long)]
    out: PathBuf,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.machine)
        .input(&a.data)
        .output(&a.out)
        .begin()?;
    let m = load_machine(&a.machine)?;
    let t = load_table(&a.data)?;
    let poses = read_poses(&t, &m, true).map_err(diag)?;
    let (actual, doc) = mtwin::kinematics::predict::run(&m, &poses, &a.out.display().to_string());
    out.write_with(&a.out, |w| -> std::io::Result<()> {
        let mut header: Vec<&str> = m.axis_names();
        header.extend(PREDICT_COLUMNS);
        let mut table = TableWriter::new(&a.out, w, &header)?;
        let mut row = Vec::with_capacity(m.n_axes() + 6);
        for (q, p) in poses.iter().zip(&actual) {
            row.clear();
            row.extend_from_slice(q);
            row.extend_from_slice(p.tip.as_slice());
            row.extend_from_slice(p.axis.as_slice());
            table.row(&row)?;
        }
        table.finish()
    })
    .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    print_doc(&doc, a.format)
}
