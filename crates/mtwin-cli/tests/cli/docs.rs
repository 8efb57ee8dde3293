//! The user guide cannot rot: every page of `docs/` is run by the
//! documentation convention (`common::run_doc_text`), each in a fresh empty
//! folder, and the walkthrough pages must show commands.
//!
//! Where a page shows a command's output (the lines after `$ mtwin …` in a
//! `console` block), the command's stdout must equal it line for line
//! ([`output_matches`]). Only wall-clock timings are normalised
//! ([`normalise_timings`]): a duration in parentheses closing a line,
//! `(0.1 s)`, and a rate such as `0.9 million poses/s` are replaced by `…` on
//! both sides before comparing; every other figure, durations that are
//! results included (a program's `8.258 s`, a lag of `9.000 ms`), must be as
//! printed. A shown line holding only `…` stands for printed lines left out.

use crate::common::{example, mtwin, repo, run_doc, run_doc_text, stdout};

/// The commands of a console block, each with the output lines shown after it.
pub fn console_commands<'a>(name: &str, body: &[&'a str]) -> Vec<(&'a str, Vec<&'a str>)> {
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

fn pages() -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(repo().join("docs"))
        .unwrap()
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            name.ends_with(".md").then_some(name)
        })
        .collect();
    v.sort();
    v
}

#[test]
fn every_page_of_the_guide_runs() {
    let pages = pages();
    assert!(pages.len() >= 9, "{pages:?}");
    // Pages in parallel (each in its own folder): the commands are small.
    let handles: Vec<_> = pages
        .into_iter()
        .map(|page| {
            std::thread::spawn(move || {
                let dir = tempfile::tempdir().unwrap();
                let ran = run_doc(&page, dir.path());
                (page, ran.len())
            })
        })
        .collect();
    let mut failed = Vec::new();
    let mut ran = std::collections::BTreeMap::new();
    for h in handles {
        match h.join() {
            Ok((page, n)) => {
                ran.insert(page, n);
            }
            Err(e) => failed.push(
                e.downcast_ref::<String>()
                    .cloned()
                    .unwrap_or_else(|| "a page panicked".into()),
            ),
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n\n"));
    let total: usize = ran.values().sum();
    assert!(total >= 40, "only {total} documented commands ran");
    // Pages written as walkthroughs must run at least one command each.
    for page in ["guide.md", "report.md"] {
        assert!(ran[page] > 0, "docs/{page} runs no command");
    }
}

#[test]
fn shown_output_is_compared_with_what_the_command_prints() {
    // `model check` prints the machine's name on its first line; the page
    // text is built from the real output with one figure changed, so the
    // comparison must catch it.
    let dir = tempfile::tempdir().unwrap();
    let machine = example("ac-trunnion.toml");
    let printed = stdout(&mtwin(dir.path(), &["model", "check", &machine]));
    let cmd = format!("model check \"{machine}\"");
    assert!(printed.lines().count() >= 2, "{printed}");
    let page = |body: &str| format!("```console\n$ mtwin {cmd}\n{body}```\n");
    // The real output passes, whole or with lines left out.
    let ran = run_doc_text("good", &page(&printed), dir.path());
    assert_eq!(ran.len(), 1);
    let first = printed.lines().next().unwrap();
    run_doc_text("elided", &page(&format!("{first}\n…\n")), dir.path());
    // A changed digit, a missing line and an extra line each fail.
    let digit = printed
        .find(|c: char| c.is_ascii_digit())
        .expect("a figure");
    let mut changed = printed.clone();
    let d = changed.as_bytes()[digit];
    changed.replace_range(digit..=digit, if d == b'1' { "2" } else { "1" });
    let missing: String = printed.lines().skip(1).map(|l| format!("{l}\n")).collect();
    let extra = format!("{printed}one more line\n");
    for (label, body) in [("changed", changed), ("missing", missing), ("extra", extra)] {
        let dir = dir.path().to_owned();
        let cmd_page = page(&body);
        let r = std::panic::catch_unwind(move || run_doc_text(label, &cmd_page, &dir));
        assert!(r.is_err(), "{label}: a wrong page passed");
    }
}

#[test]
fn only_wall_clock_timings_are_normalised() {
    // The demo's step timing and its kinematics throughput.
    assert_eq!(
        normalise_timings("1. Machine model (5 axes) (0.1 s)"),
        normalise_timings("1. Machine model (5 axes) (43.7 s)")
    );
    assert_eq!(
        normalise_timings("kinematics: 0.9 million poses/s; IK"),
        "kinematics: … million poses/s; IK"
    );
    // Results that are durations stay.
    for line in [
        "8038 samples at 0.001 s (6 moves, 8.258 s) → cmd.csv",
        "Y: velocity lag 9.000 ms (truth 9.000 ms), simulation RMS 0.02 µm",
        "test program (64 min, 104 blocks)",
        "a feed of 12 mm/s",
    ] {
        assert_eq!(normalise_timings(line), line);
    }
    // A `…` line leaves lines out; elsewhere lines must match in order.
    let printed = "a\nb (1.0 s)\nc\nd\n";
    assert!(output_matches(&["a", "b (2.5 s)", "c", "d"], printed).is_ok());
    assert!(output_matches(&["a", "…", "d"], printed).is_ok());
    assert!(output_matches(&["…", "c", "…"], printed).is_ok());
    assert!(output_matches(&["a", "…"], printed).is_ok());
    assert!(output_matches(&["a", "b (2.5 s)", "c"], printed).is_err());
    assert!(output_matches(&["a", "…", "c"], printed).is_err());
    assert!(output_matches(&["b (1.0 s)", "…"], printed).is_err());
    assert!(output_matches(&["a", "…", "x", "…"], printed).is_err());
    assert!(output_matches(&["a", "b (1.0 min)", "c", "d"], printed).is_err());
}
