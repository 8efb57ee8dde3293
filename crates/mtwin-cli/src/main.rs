//! `mtwin`: the command-line front end of the mtwin library.
//!
//! This crate only parses arguments, formats output and shows progress; every
//! computation lives in the `mtwin` library. Each subcommand family has its own
//! module under `cmd/`.

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

#[cfg(test)]
mod tests {
    use super::Cli;
    use clap::CommandFactory;

    /// Every leaf of the command tree, as its full path (`mtwin ballbar identify`).
    fn leaves(cmd: &clap::Command, path: &str, out: &mut Vec<(String, clap::Command)>) {
        let path = format!("{path} {}", cmd.get_name()).trim().to_string();
        let subs: Vec<_> = cmd
            .get_subcommands()
            .filter(|s| s.get_name() != "help" && !s.is_hide_set())
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
            let Some(examples) = help
                .split_once("Examples:")
                .or_else(|| help.split_once("Example:"))
                .map(|(_, rest)| rest)
            else {
                panic!("`{path}` has no `Example:` in its after_help");
            };
            // Every example line is a real invocation of this very command.
            let lines: Vec<&str> = examples
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            assert!(!lines.is_empty(), "`{path}`: empty example");
            for line in lines {
                assert!(line.starts_with(&path), "`{path}`: example `{line}`");
                let argv: Vec<&str> = line
                    .split(" > ")
                    .next()
                    .unwrap()
                    .split_whitespace()
                    .collect();
                if let Err(e) = Cli::command().try_get_matches_from(&argv) {
                    panic!("`{path}`: the example `{line}` does not parse: {e}");
                }
            }
        }
    }

    /// The tracker commands are the `mtwin tracker` family; the old top-level
    /// spellings still parse to the same arguments but are not listed in help.
    #[test]
    fn tracker_family_and_hidden_old_spellings() {
        let mut top = Cli::command();
        top.build();
        let help = top.render_help().to_string();
        assert!(help.contains("\n  tracker "), "{help}");
        for old in [
            "identify",
            "validate",
            "plan",
            "simulate",
            "compensate-points",
        ] {
            assert!(
                !help
                    .lines()
                    .any(|l| l.trim_start().starts_with(&format!("{old} "))),
                "`{old}` listed in\n{help}"
            );
        }
        let tracker = top.find_subcommand_mut("tracker").unwrap();
        let help = tracker.render_help().to_string();
        for new in [
            "identify",
            "validate",
            "plan",
            "simulate",
            "compensate-points",
        ] {
            assert!(
                help.contains(&format!("\n  {new} ")),
                "`{new}` not in\n{help}"
            );
        }
        let args = "--machine m.toml --data d.csv --fit location --out o.toml";
        let pairs = [
            ("tracker identify", "identify", args),
            (
                "tracker validate",
                "validate",
                "--machine m.toml --data d.csv",
            ),
            (
                "tracker plan",
                "plan tracker",
                "--machine m.toml --fit location --candidates 10 --select 5 --out-csv p.csv --out-gcode p.nc",
            ),
            (
                "tracker simulate",
                "simulate tracker",
                "--machine m.toml --poses p.csv --noise -0.5 --out f.csv",
            ),
            (
                "tracker compensate-points",
                "compensate-points",
                "--machine m.toml --data d.csv --out c.csv",
            ),
        ];
        use clap::Parser;
        for (new, old, rest) in pairs {
            let parse = |verb: &str| {
                let argv = format!("mtwin {verb} {rest}");
                Cli::try_parse_from(argv.split_whitespace())
                    .unwrap_or_else(|e| panic!("{argv}: {e}"))
            };
            // Same arguments parsed; the debug form differs only in the variant path.
            let (n, o) = (format!("{:?}", parse(new)), format!("{:?}", parse(old)));
            let inner = |s: &str| {
                s[s.find("Args {").unwrap()..]
                    .trim_end_matches([')', '}', ' '])
                    .to_string()
            };
            assert_eq!(inner(&n), inner(&o), "{new} / {old}");
        }
        // -q/--quiet is global: listed in the help of a tracker subcommand too.
        let id = tracker.find_subcommand_mut("identify").unwrap();
        assert!(id.render_help().to_string().contains("-q, --quiet"));
    }

    /// Leaves that print no numbers on stdout (files and notes only), so
    /// they take no `--format`.
    const NO_NUMBERS: &[&str] = &["mtwin completions", "mtwin ballbar simulate-circular"];

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
