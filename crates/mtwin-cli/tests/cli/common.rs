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
/// them line for line (see [`output_matches`]: only wall-clock timings are
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
            for (cmd, shown) in console_commands(name, &body) {
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
                    if let Err(why) = output_matches(&shown, &out) {
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

/// The commands of a console block, each with the output lines shown after it.
fn console_commands<'a>(name: &str, body: &[&'a str]) -> Vec<(&'a str, Vec<&'a str>)> {
    let mut out: Vec<(&str, Vec<&str>)> = Vec::new();
    for &line in body {
        if let Some(cmd) = line.strip_prefix("$ mtwin ") {
            out.push((cmd, Vec::new()));
        } else if line.starts_with('$') {
            panic!("{name}: `{line}`: only `$ mtwin …` commands can be run by the docs test");
        } else if let Some((_, shown)) = out.last_mut() {
            shown.push(line);
        } else {
            panic!("{name}: `{line}`: output before any `$ mtwin` command");
        }
    }
    out
}

/// Whether `printed` (a command's stdout) is what the page shows in `shown`,
/// line for line, after [`normalise_timings`] on both. A shown line holding
/// only `…` stands for any number of printed lines (none included); the
/// other shown lines must appear in order, the first at the start and the
/// last at the end unless a `…` is there. On a mismatch, says where.
pub fn output_matches(shown: &[&str], printed: &str) -> Result<(), String> {
    let printed: Vec<String> = printed.lines().map(normalise_timings).collect();
    let shown: Vec<String> = shown.iter().map(|l| normalise_timings(l)).collect();
    // Runs of shown lines between the `…` lines.
    let runs: Vec<&[String]> = shown.split(|l| l == "…").collect();
    let (first, last) = (0, runs.len() - 1);
    let mut at = 0;
    for (k, run) in runs.iter().enumerate() {
        let found = if k == first {
            printed.starts_with(run).then_some(0)
        } else if k == last {
            let start = printed.len().checked_sub(run.len()).filter(|&s| s >= at);
            start.filter(|&s| printed[s..] == **run)
        } else {
            (at..=printed.len().saturating_sub(run.len())).find(|&s| printed[s..].starts_with(run))
        };
        let Some(start) = found else {
            if k == first
                && let Some(i) = (0..run.len()).find(|&i| printed.get(i) != Some(&run[i]))
            {
                let got = printed.get(i).map_or("nothing", |l| l.as_str());
                return Err(format!(
                    "line {}: the page shows `{}`, it prints `{got}`",
                    i + 1,
                    run[i]
                ));
            }
            let line = run
                .first()
                .map_or("(the end of the output)", |l| l.as_str());
            return Err(format!(
                "the shown line `{line}` and those after it are not printed"
            ));
        };
        at = start + run.len();
        if k == first && runs.len() == 1 && at != printed.len() {
            return Err(format!(
                "it prints {} lines, the page shows {}",
                printed.len(),
                at
            ));
        }
    }
    Ok(())
}

/// `line` with its wall-clock timings replaced by `…`, the only figures the
/// docs test does not compare: a duration in parentheses that closes the
/// line, `(0.1 s)`, `(12 ms)` (units `s`, `ms`, `µs`, `min`), and a rate
/// `0.9 million poses/s` (a number, `million`, a word and `/s`, then perhaps
/// a comma, semicolon, full stop or parenthesis). Durations that
/// are results, a program's `8.258 s` or a lag of `9.000 ms`, are compared.
pub fn normalise_timings(line: &str) -> String {
    let is_number = |w: &str| !w.is_empty() && w.parse::<f64>().is_ok();
    let mut line = line.to_string();
    if let Some(open) = line.rfind('(').filter(|_| line.ends_with(')')) {
        let inner: Vec<&str> = line[open + 1..line.len() - 1].split(' ').collect();
        if let [n, unit] = inner[..]
            && is_number(n)
            && ["s", "ms", "µs", "min"].contains(&unit)
        {
            line = format!("{}(… {unit})", &line[..open]);
        }
    }
    let words: Vec<&str> = line.split(' ').collect();
    let mut out = Vec::with_capacity(words.len());
    let mut i = 0;
    while i < words.len() {
        if let [n, "million", rate, ..] = words[i..]
            && is_number(n)
            && rate
                .trim_end_matches([',', ';', '.', ')'])
                .strip_suffix("/s")
                .is_some_and(|w| !w.is_empty() && w.chars().all(char::is_alphabetic))
        {
            out.extend(["…", "million", rate]);
            i += 3;
        } else {
            out.push(words[i]);
            i += 1;
        }
    }
    out.join(" ")
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
