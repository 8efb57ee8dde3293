//! Subcommands. One module per family; `run` dispatches.

pub mod common;

pub use common::diag as common_diag;
mod ballbar;
mod ballbar_circular;
mod compensate;
mod completions;
mod demo;
mod export;
pub(crate) mod gcode;
mod import;
mod model;
mod positioning;
mod predict;
mod report;
mod servo;
mod skiving;
mod testpiece;
pub(crate) mod thermal;
mod thermal_compensate;
mod tracker;
mod twin;

use clap::Subcommand;

/// Every subcommand of `mtwin`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Double-ballbar identification of the rotary-axis location errors (after [R1], docs/references.md).
    #[command(subcommand)]
    Ballbar(ballbar::Command),
    /// Run every method end to end on the bundled examples, print a summary, write an HTML report.
    #[command(after_help = "Example:\n  mtwin demo --out-dir mtwin-demo")]
    Demo(demo::Args),
    /// Write an identified model as controller compensation tables (ISG, Etalon, LinuxCNC, Siemens) with the error they leave.
    #[command(
        after_help = "Example:\n  mtwin export --machine identified.toml --to linuxcnc --out comp"
    )]
    Export(export::Args),
    /// Read G-code: interpolate it into axis commands, program statistics.
    #[command(subcommand)]
    Gcode(gcode::Command),
    /// Read controller compensation tables (ISG, Etalon, LinuxCNC, Siemens) into a machine model.
    #[command(
        after_help = "Example:\n  mtwin import --from linuxcnc --into examples/machines/ac-trunnion.toml --out imported.toml comp/comp_X.txt comp/comp_Y.txt comp/comp_Z.txt"
    )]
    Import(import::Args),
    /// Inspect and check machine model files.
    #[command(subcommand)]
    Model(model::Command),
    /// Linear positioning accuracy of an axis after ISO 230-2 (docs/positioning.md).
    #[command(subcommand)]
    Positioning(positioning::Command),
    /// Predict the actual tool tip and tool axis at given axis positions.
    #[command(
        after_help = "Example:\n  mtwin predict --machine examples/machines/ac-trunnion-with-errors.toml --data poses.csv --out pred.csv"
    )]
    Predict(predict::Args),
    /// Identify, simulate and excite axis servo transfer functions (after [R5], docs/references.md).
    #[command(subcommand)]
    Servo(servo::Command),
    /// Fit and predict spindle-speed-driven thermal drift in Z (after [R4], docs/references.md).
    #[command(subcommand)]
    Thermal(thermal::Command),
    /// Laser-tracker identification of the volumetric error model: plan, simulate, identify, validate, compensate points.
    #[command(subcommand)]
    Tracker(tracker::Command),
    /// Old spelling of `mtwin tracker identify` (hidden).
    #[command(hide = true)]
    Identify(tracker::IdentifyArgs),
    /// Old spelling of `mtwin tracker validate` (hidden).
    #[command(hide = true)]
    Validate(tracker::ValidateArgs),
    /// Old spelling of `mtwin tracker plan`: `mtwin plan tracker` (hidden).
    #[command(subcommand, hide = true)]
    Plan(tracker::PlanCommand),
    /// Old spelling of `mtwin tracker simulate`: `mtwin simulate tracker` (hidden).
    #[command(subcommand, hide = true)]
    Simulate(tracker::SimulateCommand),
    /// Old spelling of `mtwin tracker compensate-points` (hidden).
    #[command(hide = true)]
    CompensatePoints(tracker::CompensateArgs),
    /// Workpiece set-up error of a power-skiving machine from touch-offs (after [R3], docs/references.md).
    #[command(subcommand)]
    Skiving(skiving::Command),
    /// Machining test pieces as five-axis programs (ISO 10791-7 S-shaped piece).
    #[command(subcommand)]
    Testpiece(testpiece::Command),
    /// Rewrite a part program so that the actual machine reaches the nominal targets.
    #[command(
        after_help = "Example:\n  mtwin compensate --machine examples/machines/ac-trunnion-with-errors.toml --program part.ngc --out part-comp.ngc --tol 0.001"
    )]
    Compensate(compensate::Args),
    /// Digital twin of five-axis trajectory error: servo + geometry → tool-tip and tool-axis error (after [R5], docs/references.md).
    #[command(subcommand)]
    Twin(twin::Command),
    /// One self-contained HTML report from saved results of the other commands.
    #[command(
        after_help = "Example:\n  mtwin report --machine identified.toml --identify identify.json --validate validate.json --out report.html"
    )]
    Report(report::Args),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    #[command(after_help = "Example:\n  mtwin completions bash > /etc/bash_completion.d/mtwin")]
    Completions(completions::CompletionsArgs),
    /// Write man pages for mtwin and every subcommand.
    #[command(after_help = "Example:\n  mtwin man --out-dir man/man1")]
    Man(completions::ManArgs),
}

/// Run one subcommand.
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Ballbar(c) => ballbar::run(c),
        Command::Demo(a) => demo::run(a),
        Command::Export(a) => export::run(a),
        Command::Gcode(c) => gcode::run(c),
        Command::Import(a) => import::run(a),
        Command::Model(c) => model::run(c),
        Command::Positioning(c) => positioning::run(c),
        Command::Predict(a) => predict::run(a),
        Command::Servo(c) => servo::run(c),
        Command::Thermal(c) => thermal::run(c),
        Command::Tracker(c) => tracker::run(c),
        Command::Identify(a) => tracker::run_identify(a),
        Command::Validate(a) => tracker::run_validate(a),
        Command::Plan(c) => tracker::run_plan(c),
        Command::Simulate(c) => tracker::run_simulate(c),
        Command::CompensatePoints(a) => tracker::run_compensate(a),
        Command::Skiving(c) => skiving::run(c),
        Command::Testpiece(c) => testpiece::run(c),
        Command::Compensate(a) => compensate::run(a),
        Command::Twin(c) => twin::run(c),
        Command::Report(a) => report::run(a),
        Command::Completions(a) => completions::run_completions(a),
        Command::Man(a) => completions::run_man(a),
    }
}
