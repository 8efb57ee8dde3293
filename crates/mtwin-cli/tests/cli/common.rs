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

/// Run `mtwin` with `args` in `cwd` and require success (exit 0; its
/// stderr in the failure message otherwise).
pub fn mtwin_ok(cwd: &Path, args: &[&str]) -> Output {
    let o = mtwin(cwd, args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    o
}

/// The stdout of a successful run as one JSON document.
pub fn json(o: &Output) -> serde_json::Value {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
    serde_json::from_str(&stdout(o)).expect("one JSON document on stdout")
}

/// Run `mtwin` with `args` in `cwd` and require the refusal of bad input:
/// exit 1, `message` in stderr, nothing on stdout, and no file `out`
/// written (relative to `cwd`).
pub fn expect_failure(cwd: &Path, args: &[&str], message: &str, out: &str) {
    let o = mtwin(cwd, args);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
    assert!(
        stderr(&o).contains(message),
        "want `{message}` in:\n{}",
        stderr(&o)
    );
    assert!(stdout(&o).is_empty(), "{}", stdout(&o));
    assert!(!cwd.join(out).exists(), "{out} must not be written");
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Run one page of `docs/` by the documentation convention, in `dir` (which
/// gets an `examples` link to the repository's `examples/` folder); see
/// [`run_doc_text`]. Returns the commands run with their stdout.
pub fn run_doc(page: &str, dir: &Path) -> Vec<(String, String)> {
    let text = std::fs::read_to_string(repo().join("docs").join(page))
        .unwrap_or_else(|e| panic!("docs/{page}: {e}"));
    run_doc_text(&format!("docs/{page}"), &text, dir)
}

/// Run a page written by the documentation convention, in `dir`; `name`
/// labels failures. Every fenced block whose info string holds `file=NAME`
/// is written to NAME, and every `$ mtwin …` line of a ```` ```console ````
/// block is run in order; each must exit 0, and with `--format json` its
/// stdout must be one JSON document. A line ending in `> NAME` writes its
/// stdout to NAME, as a shell would. A block indented (under a list item)
/// is read without the indent of its opening fence.
///
/// The lines after a command, up to the next `$` line or the end of the
/// block, are the output the page shows: the command's stdout must equal
/// them line for line (see `docs::output_matches`: only wall-clock timings are
/// normalised, and a line holding only `…` stands for lines left out). A
/// command followed by no lines is run but its output is not compared.
/// Every `$` line must be an `mtwin` command.
pub fn run_doc_text(name: &str, text: &str, dir: &Path) -> Vec<(String, String)> {
    let link = dir.join("examples");
    if !link.exists() {
        #[cfg(unix)]
        std::os::unix::fs::symlink(repo().join("examples"), &link).unwrap();
    }
    let mut ran = Vec::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        let Some(info) = line.trim_start().strip_prefix("```") else {
            continue;
        };
        // A block indented under a list item: its lines lose the fence's indent.
        let indent = line.len() - line.trim_start().len();
        let body: Vec<&str> = lines
            .by_ref()
            .take_while(|l| !l.trim_start().starts_with("```"))
            .map(|l| {
                let spaces = l.len() - l.trim_start_matches(' ').len();
                &l[spaces.min(indent)..]
            })
            .collect();
        if let Some(file) = info
            .split_whitespace()
            .find_map(|w| w.strip_prefix("file="))
        {
            std::fs::write(dir.join(file), body.join("\n") + "\n").unwrap();
        } else if info.split_whitespace().next() == Some("console") {
            for (cmd, shown) in crate::docs::console_commands(name, &body) {
                let words = split_words(cmd);
                let mut args: Vec<&str> = words.iter().map(String::as_str).collect();
                let redirect = match args[..] {
                    [.., ">", file] => {
                        args.truncate(args.len() - 2);
                        Some(file)
                    }
                    _ => None,
                };
                let o = mtwin(dir, &args);
                if let Some(file) = redirect {
                    std::fs::write(dir.join(file), &o.stdout).unwrap();
                }
                assert_eq!(
                    o.status.code(),
                    Some(0),
                    "{name}: `mtwin {cmd}` failed: {}",
                    stderr(&o)
                );
                let out = stdout(&o);
                if args.windows(2).any(|w| w == ["--format", "json"]) {
                    let _: serde_json::Value = serde_json::from_str(&out).unwrap_or_else(|e| {
                        panic!("{name}: `mtwin {cmd}`: stdout is not one JSON document: {e}")
                    });
                }
                if !shown.is_empty() {
                    assert!(
                        redirect.is_none(),
                        "{name}: `mtwin {cmd}` writes its stdout to a file, yet output is shown"
                    );
                    if let Err(why) = crate::docs::output_matches(&shown, &out) {
                        panic!(
                            "{name}: `mtwin {cmd}` does not print what the page shows ({why}).\n\
                             The page shows:\n{}\nThe command prints:\n{out}",
                            shown.join("\n")
                        );
                    }
                }
                ran.push((cmd.to_string(), out));
            }
        }
    }
    ran
}

/// Words of a command line as a shell splits them: on white space, with
/// double quotes grouping words (`--title "Machine 7"`).
pub fn split_words(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut word = String::new();
    let (mut quoted, mut any) = (false, false);
    for c in line.chars() {
        match c {
            '"' => {
                quoted = !quoted;
                any = true;
            }
            c if c.is_whitespace() && !quoted => {
                if any {
                    out.push(std::mem::take(&mut word));
                    any = false;
                }
            }
            c => {
                word.push(c);
                any = true;
            }
        }
    }
    if any {
        out.push(word);
    }
    out
}

/// The JSON round trip of a command's document: runs `mtwin args --format
/// json` in `dir` (exit 0), reads stdout into the library's document type
/// `D` (so `--format json` is exactly the serialised `D`), checks that `D`
/// serialises back to the same JSON value, then runs `mtwin args` (human
/// output) and checks its stdout is `D`'s `Display`. Returns the document and
/// the JSON value.
pub fn json_round_trip<D>(dir: &Path, args: &[&str]) -> (D, serde_json::Value)
where
    D: serde::de::DeserializeOwned + serde::Serialize + std::fmt::Display,
{
    let mut with_json = args.to_vec();
    with_json.extend(["--format", "json"]);
    let o = mtwin(dir, &with_json);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o))
        .unwrap_or_else(|e| panic!("{args:?}: {e}: {}", stdout(&o)));
    let doc: D = serde_json::from_str(&stdout(&o)).unwrap_or_else(|e| {
        panic!(
            "{args:?}: stdout is not a {}: {e}",
            std::any::type_name::<D>()
        )
    });
    assert_eq!(serde_json::to_value(&doc).unwrap(), v, "{args:?}");
    let human = mtwin(dir, args);
    assert_eq!(human.status.code(), Some(0), "{args:?}: {}", stderr(&human));
    assert_eq!(stdout(&human), doc.to_string(), "{args:?}");
    (doc, v)
}

/// The example AC trunnion with the limits of LinuxCNC's xyzac-trt
/// simulation configuration: X Y Z 20 mm/s, A C 30 deg/s, 300 mm/s² (deg/s²)
/// on every axis, trajectory (rapid) 35 mm/s (the planner test modules).
pub fn linuxcnc_trunnion() -> mtwin::model::Machine {
    let mut m = mtwin::examples::machine("ac-trunnion").unwrap();
    for a in m.axes.iter_mut() {
        let lin = a.kind == mtwin::model::AxisKind::Linear;
        a.max_velocity = Some(if lin { 20.0 } else { 30.0 });
        a.max_acceleration = Some(300.0);
    }
    m.rapid_feed = 35.0 * 60.0;
    m
}
