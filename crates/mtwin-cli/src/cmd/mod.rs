//! Subcommands. One module per family; `run` dispatches.

pub mod common;

pub use common::diag as common_diag;
mod demo;
mod gcode;
mod model;
mod predict;

use clap::Subcommand;

/// Every subcommand of `mtwin`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run every method end to end on the bundled examples and print a summary.
    #[command(after_help = "Example:\n  mtwin demo")]
    Demo(demo::Args),
    /// Read G-code: interpolate it into axis commands, program statistics.
    #[command(subcommand)]
    Gcode(gcode::Command),
    /// Inspect and check machine model files.
    #[command(subcommand)]
    Model(model::Command),
    /// Predict the actual tool tip and tool axis at given axis positions.
    #[command(
        after_help = "Example:\n  mtwin predict --machine examples/machines/ac-trunnion-with-errors.toml --data poses.csv --out pred.csv"
    )]
    Predict(predict::Args),
}

/// Run one subcommand.
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Demo(a) => demo::run(a),
        Command::Gcode(c) => gcode::run(c),
        Command::Model(c) => model::run(c),
        Command::Predict(a) => predict::run(a),
    }
}
