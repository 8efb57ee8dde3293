//! `mtwin model check`: read a machine file, report its chains, axes and errors, or every problem.

use std::path::PathBuf;

use mtwin::model::ModelCheckDoc;

use super::common::load_machine;
use crate::output::{Format, print_doc};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Check a machine model file and summarise it (chains, axes, errors).
    #[command(after_help = "Example:\n  mtwin model check examples/machines/ac-trunnion.toml")]
    Check {
        /// The machine model file (TOML, see docs/machine-model.md).
        machine: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t)]
        format: Format,
    },
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Check { machine, format } => {
            let m = load_machine(&machine)?;
            print_doc(
                &ModelCheckDoc::new(&m, &machine.display().to_string()),
                format,
            )
        }
    }
}
