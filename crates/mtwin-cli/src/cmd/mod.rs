//! Subcommands. One module per family; `run` dispatches.

use clap::Subcommand;

/// Every subcommand of `mtwin`.
#[derive(Debug, Subcommand)]
pub enum Command {}

/// Run one subcommand.
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {}
}
