//! The `mtwin` binary: everything is in the `mtwin_cli` library target.

fn main() -> std::process::ExitCode {
    mtwin_cli::main()
}
