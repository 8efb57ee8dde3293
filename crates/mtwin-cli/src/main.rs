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

#[cfg(test)]
mod tests {
    use super::Cli;
    use clap::CommandFactory;

    /// Every leaf of the command tree, as its full path (`mtwin ballbar identify`).
    fn leaves(cmd: &clap::Command, path: &str, out: &mut Vec<(String, clap::Command)>) {
        let path = format!("{path} {}", cmd.get_name()).trim().to_string();
        let subs: Vec<_> = cmd
            .get_subcommands()
            .filter(|s| s.get_name() != "help")
            .collect();
        for s in &subs {
            leaves(s, &path, out);
        }
        if subs.is_empty() {
            out.push((path, cmd.clone()));
        }
    }

    fn all_leaves() -> Vec<(String, clap::Command)> {
        let mut cmd = Cli::command();
        cmd.build();
        let mut out = Vec::new();
        leaves(&cmd, "", &mut out);
        out
    }

    #[test]
    fn the_command_tree_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn every_subcommand_has_an_example_that_parses() {
        let leaves = all_leaves();
        assert!(leaves.len() > 20, "{}", leaves.len());
        for (path, c) in leaves {
            let help = c
                .get_after_help()
                .map(|h| h.to_string())
                .unwrap_or_default();
            let Some(example) = help.split("Example:").nth(1) else {
                panic!("`{path}` has no `Example:` in its after_help");
            };
            // The first example line is a real invocation of this very command.
            let line = example
                .lines()
                .map(str::trim)
                .find(|l| !l.is_empty())
                .unwrap_or_default();
            assert!(line.starts_with(&path), "`{path}`: example `{line}`");
            let argv: Vec<&str> = line
                .split(" > ")
                .next()
                .unwrap()
                .split_whitespace()
                .collect();
            if let Err(e) = Cli::command().try_get_matches_from(&argv) {
                panic!("`{path}`: the example does not parse: {e}");
            }
        }
    }

    /// Leaves that print no numbers on stdout (files and notes only), so
    /// they take no `--format`.
    const NO_NUMBERS: &[&str] = &["mtwin completions"];

    #[test]
    fn every_subcommand_that_prints_numbers_takes_format_json() {
        let mut missing = Vec::new();
        for (path, c) in all_leaves() {
            let format = c.get_arguments().find(|a| a.get_id() == "format");
            match format {
                Some(f) => {
                    let values: Vec<String> = f
                        .get_possible_values()
                        .iter()
                        .map(|v| v.get_name().to_string())
                        .collect();
                    assert_eq!(values, ["human", "json"], "`{path}`");
                    assert_eq!(
                        f.get_default_values(),
                        ["human"],
                        "`{path}`: the default format is for people"
                    );
                }
                None if NO_NUMBERS.contains(&path.as_str()) => {}
                None => missing.push(path),
            }
        }
        assert!(missing.is_empty(), "no --format human|json: {missing:?}");
    }
}
