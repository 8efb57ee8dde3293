//! `mtwin`: the command-line front end of the mtwin library.
//!
//! This crate only parses arguments, formats output and shows progress; every
//! computation lives in the `mtwin` library. Each subcommand family has its own
//! module under `cmd/`.

mod bundled;
mod cmd;
mod output;

use clap::Parser;

/// Exact, fast tools for the accuracy of machine tools: model a machine's geometry
/// and errors, identify them from measurements, predict and compensate.
#[derive(Debug, Parser)]
#[command(name = "mtwin", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    /// Print nothing but results and errors (no progress, no notes).
    #[arg(long, short, global = true)]
    pub quiet: bool,

    #[command(subcommand)]
    pub command: cmd::Command,
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    output::set_quiet(cli.quiet);
    match cmd::run(cli.command) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            output::print_error(&e);
            std::process::ExitCode::from(1)
        }
    }
}
