//! The command tree's own checks (clap's consistency, an example per leaf,
//! the tracker family's spellings, `--format json` wherever numbers are
//! printed) and two helpers of the commands: these need the tool's types, so
//! they live in the one integration binary and read them from the `mtwin_cli`
//! library target instead of a second, test-only compile of the tool.
use clap::CommandFactory;
use mtwin_cli::Cli;

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
/// The tracker commands, once top-level verbs, now under `mtwin tracker`.
const TRACKER_VERBS: [&str; 5] = [
    "identify",
    "validate",
    "plan",
    "simulate",
    "compensate-points",
];

#[test]
fn tracker_family_and_hidden_old_spellings() {
    let mut top = Cli::command();
    top.build();
    let help = top.render_help().to_string();
    assert!(help.contains("\n  tracker "), "{help}");
    for old in TRACKER_VERBS {
        assert!(
            !help
                .lines()
                .any(|l| l.trim_start().starts_with(&format!("{old} "))),
            "`{old}` listed in\n{help}"
        );
    }
    let tracker = top.find_subcommand_mut("tracker").unwrap();
    let help = tracker.render_help().to_string();
    for new in TRACKER_VERBS {
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
            Cli::try_parse_from(argv.split_whitespace()).unwrap_or_else(|e| panic!("{argv}: {e}"))
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

mod located_errors {
    use mtwin_cli::testing::located;
    use std::path::Path;

    #[test]
    fn located_errors_put_the_place_first() {
        let p = Path::new("part.ngc");
        let e = located(p, Some(3), 5, "syntax error: bad");
        assert_eq!(e.to_string(), "part.ngc:3:5: syntax error: bad");
        // A whole block at fault is column 1.
        let e = located(p, Some(12), 0, "unsupported canned cycle G81");
        assert_eq!(e.to_string(), "part.ngc:12:1: unsupported canned cycle G81");
        // Another line named in the message stays.
        let e = located(p, Some(1), 0, "see line 12");
        assert_eq!(e.to_string(), "part.ngc:1:1: see line 12");
        let e = located(p, None, 0, "no moves");
        assert_eq!(e.to_string(), "part.ngc: no moves");
    }
}

mod heights {
    use mtwin_cli::testing::parse_heights;

    #[test]
    fn heights_parse_negatives_and_reject_garbage() {
        let v: Vec<String> = ["-100", " -300.5", "2e1"].map(String::from).to_vec();
        assert_eq!(parse_heights(&v).unwrap(), vec![-100.0, -300.5, 20.0]);
        for bad in ["abc", "nan", "inf", ""] {
            let e = parse_heights(&[bad.to_string()]).unwrap_err().to_string();
            assert!(e.starts_with("--z:"), "{e}");
        }
    }
}
