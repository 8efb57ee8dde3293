//! The user guide cannot rot: every page of `docs/` is run by the
//! documentation convention (see `common::run_doc_text`), each in a fresh
//! empty folder, and the walkthrough pages must show commands.
//!
//! Where a page shows a command's output (the lines after `$ mtwin …` in a
//! `console` block), the command's stdout must equal it line for line. Only
//! wall-clock timings are normalised (`common::normalise_timings`): a
//! duration in parentheses closing a line, `(0.1 s)`, and a rate such as
//! `0.9 million poses/s` are replaced by `…` on both sides before comparing;
//! every other figure, durations that are results included (a program's
//! `8.258 s`, a lag of `9.000 ms`), must be as printed. A shown line holding
//! only `…` stands for printed lines left out.

use crate::common::{
    example, mtwin, normalise_timings, output_matches, repo, run_doc, run_doc_text, stdout,
};

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
