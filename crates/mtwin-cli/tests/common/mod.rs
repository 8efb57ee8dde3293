//! Helpers for the CLI integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run `mtwin` with `args` in `cwd`.
pub fn mtwin(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mtwin"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("mtwin runs")
}

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// An example machine file.
pub fn example(name: &str) -> String {
    repo()
        .join("examples/machines")
        .join(name)
        .display()
        .to_string()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Run a walkthrough page of `docs/` as the docs convention says: in `dir`
/// (where `examples` is linked to the repository's), write every
/// ```` ```lang file=NAME ```` block to NAME and run every `$ mtwin …` line
/// of the ```` ```console ```` blocks in order; each must succeed, and with
/// `--format json` its stdout must be one JSON document. Returns every
/// command run with its stdout.
pub fn run_doc(page: &str, dir: &Path) -> Vec<(String, String)> {
    let link = dir.join("examples");
    if !link.exists() {
        std::os::unix::fs::symlink(repo().join("examples"), link).unwrap();
    }
    let text = std::fs::read_to_string(repo().join("docs").join(page)).unwrap();
    let mut ran = Vec::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        let Some(info) = line.strip_prefix("```") else {
            continue;
        };
        let body: Vec<&str> = lines
            .by_ref()
            .take_while(|l| !l.starts_with("```"))
            .collect();
        if let Some(name) = info
            .split_whitespace()
            .find_map(|w| w.strip_prefix("file="))
        {
            std::fs::write(dir.join(name), body.join("\n") + "\n").unwrap();
        } else if info == "console" {
            for cmd in body.iter().filter_map(|l| l.strip_prefix("$ mtwin ")) {
                let args: Vec<&str> = cmd.split_whitespace().collect();
                let o = mtwin(dir, &args);
                assert_eq!(o.status.code(), Some(0), "{cmd}: {}", stderr(&o));
                if cmd.contains("--format json") {
                    let _: serde_json::Value = serde_json::from_str(&stdout(&o))
                        .unwrap_or_else(|e| panic!("{cmd}: stdout is not JSON: {e}"));
                }
                ran.push((cmd.to_string(), stdout(&o)));
            }
        }
    }
    ran
}
