//! Subcommands. One module per family; `run` dispatches.

pub mod common;

pub use common::diag as common_diag;
mod demo;
mod model;
mod predict;
mod thermal_compensate;

use clap::Subcommand;

/// Every subcommand of `mtwin`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run every method end to end on the bundled examples and print a summary.
    #[command(after_help = "Example:\n  mtwin demo")]
    Demo(demo::Args),
    /// Inspect and check machine model files.
    #[command(subcommand)]
    Model(model::Command),
    /// Predict the actual tool tip and tool axis at given axis positions.
    #[command(
        after_help = "Example:\n  mtwin predict --machine examples/machines/ac-trunnion-with-errors.toml --data poses.csv --out pred.csv"
    )]
    Predict(predict::Args),
    /// TEMPORARY top-level name of `mtwin thermal compensate`: rewrite an NC
    /// program's Z targets against the predicted thermal drift.
    #[command(
        after_help = "Example:\n  mtwin thermal-compensate --model THERMAL.toml --program IN.nc --out OUT.nc --period-min 10"
    )]
    ThermalCompensate(thermal_compensate::Args),
}

/// Run one subcommand.
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Demo(a) => demo::run(a),
        Command::Model(c) => model::run(c),
        Command::Predict(a) => predict::run(a),
        Command::ThermalCompensate(a) => thermal_compensate::run(a),
    }
}
