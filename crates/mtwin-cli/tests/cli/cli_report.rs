//! `mtwin report` and `mtwin demo`: the report from saved results carries the
//! numbers of its inputs in the units it names, bad inputs are refused with
//! the file named and nothing written, and the demo recovers its known truths.

use std::path::Path;

use crate::common::{example, mtwin, repo, stderr, stdout};

fn ok(dir: &Path, args: &[&str]) -> String {
    let o = mtwin(dir, args);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

/// The text content of the HTML with tags removed (cells become words).
fn text(html: &str) -> String {
    let mut out = String::new();
    let mut tag = false;
    for c in html.chars() {
        match c {
            '<' => {
                tag = true;
                out.push(' ');
            }
            '>' => tag = false,
            c if !tag => out.push(c),
            _ => {}
        }
    }
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[test]
fn report_shows_the_numbers_of_its_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(
        d,
        &[
            "ballbar", "simulate", "--ex", "-0.0403", "--ey", "-0.0765", "--seed", "1", "--out",
            "data",
        ],
    );
    let bb = ok(
        d,
        &[
            "ballbar",
            "identify",
            "--mode1",
            "data/mode1.csv",
            "--mode2",
            "data/mode2.csv",
            "--mode3",
            "data/mode3.csv",
            "--mode4",
            "data/mode4.csv",
            "--ex",
            "-0.0403",
            "--ey",
            "-0.0765",
            "--plot",
            "plots",
            "--out",
            "id.toml",
            "--format",
            "json",
        ],
    );
    std::fs::write(d.join("ballbar.json"), &bb).unwrap();
    let comp = ok(
        d,
        &[
            "compensate",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--program",
            repo()
                .join("examples/programs/s-curve-5axis.ngc")
                .to_str()
                .unwrap(),
            "--out",
            "c.ngc",
            "--max-correction",
            "2",
            "--format",
            "json",
        ],
    );
    std::fs::write(d.join("comp.json"), &comp).unwrap();
    // A twin prediction written here: tip error k µm and axis error 2k µrad at sample k.
    let mut pred =
        String::from("t_s,x_cmd,y_cmd,z_cmd,i_cmd,j_cmd,k_cmd,x,y,z,i,j,k,tip_error,axis_error\n");
    for k in 0..=40 {
        let t = k as f64 * 0.001;
        pred.push_str(&format!(
            "{t},{k},0,0,0,0,1,{k},0,0,0,0,1,{},{}\n",
            k as f64 * 1e-3,
            2e-6 * k as f64
        ));
    }
    std::fs::write(d.join("pred.csv"), pred).unwrap();
    let v: serde_json::Value = serde_json::from_str(&ok(
        d,
        &[
            "report",
            "--machine",
            "id.toml",
            "--ballbar",
            "ballbar.json",
            "--ballbar-plots",
            "plots",
            "--compensate",
            "comp.json",
            "--twin",
            "pred.csv",
            "--title",
            "Acceptance",
            "--out",
            "r.html",
            "--format",
            "json",
        ],
    ))
    .unwrap();
    assert_eq!(v["sections"], 4);
    // The document is exactly the library's `ReportDoc`.
    let doc: mtwin::report::sections::ReportDoc = serde_json::from_value(v.clone()).unwrap();
    assert_eq!((doc.sections, doc.out.as_str()), (4, "r.html"));
    let html = std::fs::read_to_string(d.join("r.html")).unwrap();
    // Self-contained: no script and nothing fetched.
    for bad in ["<script", "src=", "<link", "https://"] {
        assert!(!html.contains(bad), "{bad}");
    }
    // Four polar plots embedded, plus PDGE and twin charts.
    assert!(html.matches("<svg").count() >= 4 + 3);
    assert_eq!(
        v["figures"].as_u64().unwrap() as usize,
        html.matches("<figure>").count()
    );
    let t = text(&html);
    let bb: serde_json::Value = serde_json::from_str(&bb).unwrap();
    // EY0A in µm with its uncertainty, as the JSON says in mm.
    let ey0a = bb["EY0A"].as_f64().unwrap() * 1e3;
    let u = bb["uncertainty"]["EY0A"].as_f64().unwrap() * 1e3;
    let want = format!("EY0A offset of the A line {} {:.2} µm", fmt(ey0a, 2), u);
    assert!(t.contains(&want), "{want} not in the report");
    // The twin's largest tip error is 40 µm, RMS sqrt(Σk²/41) µm, axis 80 µrad.
    let rms = ((0..=40).map(|k| (k * k) as f64).sum::<f64>() / 41.0).sqrt();
    assert!(t.contains("largest ε_p 40.00 µm"), "{t}");
    assert!(t.contains(&format!("RMS ε_p {rms:.2} µm")));
    assert!(t.contains("largest ε_o 80.00 µrad"));
    // The compensation's largest correction, as printed by compensate.
    let c: serde_json::Value = serde_json::from_str(&comp).unwrap();
    let lc = c["largest_correction_um"].as_f64().unwrap();
    assert!(t.contains(&format!("largest correction {lc:.2} µm")));
    assert!(t.contains("Acceptance"));
}

fn fmt(v: f64, d: usize) -> String {
    format!("{v:.d$}").replacen('-', "−", 1)
}

#[test]
fn bad_inputs_name_the_file_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("broken.json"), "{\n  \"rank\": 3,\n  oops\n}\n").unwrap();
    let o = mtwin(
        d,
        &["report", "--identify", "broken.json", "--out", "r.html"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("broken.json:3:"), "{}", stderr(&o));
    assert!(!d.join("r.html").exists());
    // A JSON of another command: the missing field is named.
    std::fs::write(d.join("other.json"), "{\"rank\": 3}").unwrap();
    let o = mtwin(
        d,
        &["report", "--identify", "other.json", "--out", "r.html"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("other.json:1:")
            && stderr(&o).contains("missing field `condition_number`"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("r.html").exists());
    // A PRED.csv without the contract's columns.
    std::fs::write(d.join("pred.csv"), "t_s,x\n0,1\n").unwrap();
    let o = mtwin(d, &["report", "--twin", "pred.csv", "--out", "r.html"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("x_cmd"), "{}", stderr(&o));
    // Nothing to report.
    let o = mtwin(d, &["report", "--out", "r.html"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("nothing to report"));
    assert!(!d.join("r.html").exists());
}

#[test]
fn demo_recovers_its_truths_and_writes_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v: serde_json::Value =
        serde_json::from_str(&ok(d, &["demo", "--out-dir", "out", "--format", "json"])).unwrap();
    let html = std::fs::read_to_string(d.join("out/report.html")).unwrap();
    assert_eq!(v["report"], "out/report.html");
    for id in [
        "machine",
        "ballbar",
        "tracker-identify",
        "tracker-validate",
        "skiving",
        "thermal",
        "servo",
        "compensate",
        "positioning-x",
        "circular-xy",
    ] {
        assert!(html.contains(&format!("<section id=\"{id}\">")), "{id}");
    }
    // Ballbar: table 4 of the source paper [R1] — offsets re-identified after compensating
    // the identified ones are what the 0.3 µm noise leaves (truth offsets of
    // the example machine: up to 26 µm).
    let b = &v["ballbar"];
    assert!(b["largest_offset_before_mm"].as_f64().unwrap() > 0.020);
    assert!(b["largest_offset_after_mm"].as_f64().unwrap() < 0.001);
    // Compensating the offsets also shrinks the bar's largest deviation.
    assert!(
        b["largest_deviation_after_mm"].as_f64().unwrap()
            < 0.5 * b["largest_deviation_before_mm"].as_f64().unwrap()
    );
    // Truth recovered within 1 µm / µrad (noise 0.3 µm on 220 readings).
    assert!(b["largest_error_vs_truth_um_or_urad"].as_f64().unwrap() < 1.5);
    // Twin: compensated with `--tol 0.001`, the geometric error left while
    // cutting is within that tolerance (twice, for the nearest-point search
    // between samples); the original program's is tens of µm.
    let g = &v["twin"]["geometry_only"];
    assert!(g["original"]["tip_error_max"].as_f64().unwrap() > 0.010);
    assert!(g["compensated"]["tip_error_max"].as_f64().unwrap() < 0.002);
    // Tracker: the identified model beats the nominal one on the diagonals.
    assert!(
        v["tracker"]["diagonal_change_mean_percent"]
            .as_f64()
            .unwrap()
            < -50.0
    );
    // Skiving: the set-up error of the simulation, within 5 µm / 50 µrad.
    let s = &v["skiving"];
    for (k, tol) in [("dgx", 5e-3), ("dgy", 5e-3), ("exz", 5e-5), ("ezy", 5e-5)] {
        let e = s[k].as_f64().unwrap() - s["truth"][k].as_f64().unwrap();
        assert!(e.abs() < tol, "{k}: {e}");
    }
    // Thermal: compensation shrinks the face difference.
    let t = &v["thermal"];
    assert!(
        t["face_difference_compensated_mm"].as_f64().unwrap()
            < 0.5 * t["face_difference_mm"].as_f64().unwrap()
    );
    // Servo: the velocity lag of every axis within 0.1 ms of its truth.
    assert!(v["servo"]["largest_velocity_lag_error_s"].as_f64().unwrap() < 1e-4);
    // The files the later steps and the twin need.
    for f in [
        "ac-trunnion-twin.toml",
        "s-curve-5axis-comp.ngc",
        "gantry-identified.toml",
        "thermal.toml",
    ] {
        assert!(d.join("out").join(f).exists(), "{f}");
    }
    let o = mtwin(d, &["model", "check", "out/ac-trunnion-twin.toml"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn completions_and_man_pages_cover_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let s = ok(d, &["completions", shell]);
        assert!(s.contains("mtwin") && s.contains("report"), "{shell}");
    }
    let bash = ok(d, &["completions", "bash"]);
    assert!(bash.contains("--ballbar-plots"));
    let v: serde_json::Value =
        serde_json::from_str(&ok(d, &["man", "--out-dir", "man", "--format", "json"])).unwrap();
    let files: Vec<&str> = v["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap())
        .collect();
    for page in [
        "mtwin.1",
        "mtwin-report.1",
        "mtwin-ballbar-identify.1",
        "mtwin-demo.1",
    ] {
        assert!(files.iter().any(|f| f.ends_with(page)), "{page}");
        let text = std::fs::read_to_string(d.join("man").join(page)).unwrap();
        assert!(text.starts_with(".ie") || text.contains(".TH"), "{page}");
    }
    let top = std::fs::read_to_string(d.join("man/mtwin.1")).unwrap();
    assert!(top.contains("report") && top.contains("completions"));
}

#[test]
fn quiet_silences_notes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = mtwin(
        d,
        &[
            "report",
            "--machine",
            &example("ac-trunnion.toml"),
            "--out",
            "r.html",
        ],
    );
    assert!(stderr(&o).contains("note:"));
    let o = mtwin(
        d,
        &[
            "--quiet",
            "report",
            "--machine",
            &example("ac-trunnion.toml"),
            "--out",
            "r.html",
        ],
    );
    assert_eq!(o.status.code(), Some(0));
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
}
