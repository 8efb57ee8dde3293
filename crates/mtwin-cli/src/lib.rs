//! `mtwin`: the command-line front end of the mtwin library.
//!
//! This crate only parses arguments, formats output and shows progress; every
//! computation lives in the `mtwin` library. Each subcommand family has its own
//! module under `cmd/`. The binary (`src/main.rs`) only calls [`main`]; the
//! command tree lives in this library target so that the workspace's one
//! integration-test binary checks it (`tests/cli/cli_tree.rs`) without a
//! second, test-only compile of the whole tool.

// Every `print!`/`println!`/`eprint!`/`eprintln!` of this crate goes through
// `output`: these crate-level macros are defined before the modules, so they
// shadow the standard ones everywhere below. A closed standard output then
// ends the command quietly (exit 141, temporary files removed) instead of
// the standard macros' panic; see `output::print_out`.
#[allow(unused_macros)]
macro_rules! print {
    ($($arg:tt)*) => {
        $crate::output::print_out(::std::format_args!($($arg)*))
    };
}
#[allow(unused_macros)]
macro_rules! println {
    () => {
        $crate::output::print_out(::std::format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::output::print_out(::std::format_args!("{}\n", ::std::format_args!($($arg)*)))
    };
}
#[allow(unused_macros)]
macro_rules! eprint {
    ($($arg:tt)*) => {
        $crate::output::print_err(::std::format_args!($($arg)*))
    };
}
#[allow(unused_macros)]
macro_rules! eprintln {
    () => {
        $crate::output::print_err(::std::format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::output::print_err(::std::format_args!("{}\n", ::std::format_args!($($arg)*)))
    };
}

mod bundled;
mod cmd;
mod output;

/// Functions of the commands that the integration tests check directly
/// (`tests/cli/cli_tree.rs`); not an API.
#[doc(hidden)]
pub mod testing {
    pub use crate::cmd::gcode::located;
    pub use crate::cmd::thermal::parse_heights;
}

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

/// The `mtwin` command: parse the arguments, run the command, print its result
/// or its error; the exit status (0, 1, or 141 when standard output was closed).
pub fn main() -> std::process::ExitCode {
    output::remove_temporaries_on_signals();
    let cli = Cli::parse();
    output::set_quiet(cli.quiet);
    let result = cmd::run(cli.command);
    // Whatever is still buffered for stdout: a closed pipe here is handled too.
    output::flush_stdout();
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) if output::is_closed_pipe(&e) => {
            std::process::ExitCode::from(output::EXIT_CLOSED_PIPE)
        }
        Err(e) => {
            output::print_error(&e);
            std::process::ExitCode::from(1)
        }
    }
}
