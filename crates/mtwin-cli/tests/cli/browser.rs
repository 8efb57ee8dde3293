//! The demo report in a real browser: headless Chromium loads it offline,
//! logs no console message (the page has no script, so any message is an
//! error: a blocked fetch, a bad resource), and its DOM holds every figure.
//! Also writes a screenshot; with `MTWIN_UPDATE_SCREENSHOT=1` it replaces
//! `docs/img/report.png`.
//!
//! Needs Debian's `chromium` (`.ci/run` installs it). Without it the test
//! says so and passes, unless `MTWIN_REQUIRE_BROWSER=1` (set by `.ci/run`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common::{mtwin, repo, stderr};

fn chromium() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("MTWIN_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser"]
        .iter()
        .flat_map(|n| std::env::split_paths(&path).map(move |d| d.join(n)))
        .find(|p| p.is_file())
}

/// Runs headless Chromium on `url` with a fresh profile and the network
/// features off; `extra` are the action flags (`--dump-dom`, `--screenshot=…`).
fn run_chromium(exe: &Path, url: &str, extra: &[&str]) -> Output {
    let profile = tempfile::tempdir().unwrap();
    let mut cmd = Command::new(exe);
    cmd.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--enable-logging=stderr",
        "--v=0",
    ])
    .arg(format!("--user-data-dir={}", profile.path().display()))
    .args(extra)
    .arg(url);
    let out = cmd.output().expect("chromium starts");
    drop(profile);
    out
}

#[test]
fn demo_report_loads_in_chromium_with_every_plot() {
    let Some(exe) = chromium() else {
        assert!(
            std::env::var_os("MTWIN_REQUIRE_BROWSER").is_none(),
            "MTWIN_REQUIRE_BROWSER is set but chromium is not on PATH"
        );
        eprintln!("skipped: chromium is not installed (apt-get install chromium; .ci/run does)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(dir.path(), &["--quiet", "demo", "--out-dir", "out"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let page = dir.path().join("out/report.html");
    let html = std::fs::read_to_string(&page).unwrap();
    let figures = html.matches("<figure>").count();
    assert!(figures >= 20, "{figures} figures");
    let url = format!("file://{}", page.display());

    let o = run_chromium(&exe, &url, &["--dump-dom"]);
    let log = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "chromium failed: {log}");
    let console: Vec<&str> = log.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(
        console.is_empty(),
        "console messages:\n{}",
        console.join("\n")
    );
    let dom = String::from_utf8_lossy(&o.stdout);
    // Every figure rendered as an SVG element with drawn content.
    assert_eq!(dom.matches("<figure>").count(), figures);
    assert!(dom.matches("<svg").count() >= figures);
    assert!(dom.matches("<polyline").count() >= figures);
    for id in [
        "ballbar",
        "tracker-validate",
        "thermal",
        "servo",
        "compensate",
    ] {
        assert!(dom.contains(&format!("id=\"{id}\"")), "{id}");
    }

    let shot = dir.path().join("report.png");
    let o = run_chromium(
        &exe,
        &url,
        &[
            "--window-size=1280,2200",
            "--hide-scrollbars",
            &format!("--screenshot={}", shot.display()),
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let png = std::fs::read(&shot).unwrap();
    // A PNG with content (a blank page of this size compresses to ~10 kB).
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"));
    assert!(png.len() > 50_000, "{} bytes", png.len());
    if std::env::var_os("MTWIN_UPDATE_SCREENSHOT").is_some() {
        let dest = repo().join("docs/img/report.png");
        std::fs::create_dir_all(dest.parent().unwrap()).unwrap();
        std::fs::write(&dest, &png).unwrap();
    }
}
