//! `mtwin twin predict` ([R5] in docs/references.md) end to end through the binary.

use crate::common::*;

use std::path::Path;

const HEADER: &str = "t_s,x_cmd,y_cmd,z_cmd,i_cmd,j_cmd,k_cmd,x,y,z,i,j,k,tip_error,axis_error";

/// A five-axis command file (columns in a shuffled order) of `n` samples at 1 ms.
fn write_commands(dir: &Path, n: usize) -> std::path::PathBuf {
    let mut s = String::from("# five-axis commands\nC,t_s,X,Y,Z,A\n");
    for k in 0..n {
        let t = k as f64 * 0.001;
        let w = 2.0 * std::f64::consts::PI * t;
        s.push_str(&format!(
            "{},{},{},{},{},{}\n",
            20.0 * (0.5 * w).sin(),
            t,
            30.0 * w.sin(),
            25.0 * w.cos() - 25.0,
            -10.0 + 2.0 * (3.0 * w).sin(),
            10.0 * (0.7 * w).sin()
        ));
    }
    let p = dir.join("cmd.csv");
    std::fs::write(&p, s).unwrap();
    p
}

/// PRED.csv as numbers (header checked against the contract).
fn read_pred(p: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(p).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), HEADER);
    lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

fn json(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}: {}", stdout(o)))
}

#[test]
fn contract_columns_and_summary_keys() {
    let dir = tempfile::tempdir().unwrap();
    write_commands(dir.path(), 2000);
    let m = example("ac-trunnion-twin.toml");
    let o = mtwin(
        dir.path(),
        &[
            "twin",
            "predict",
            "--machine",
            &m,
            "--commands",
            "cmd.csv",
            "--out",
            "pred.csv",
            "--format",
            "json",
        ],
    );
    let v = json(&o);
    let rows = read_pred(&dir.path().join("pred.csv"));
    assert_eq!(rows.len(), 2000);
    assert_eq!(v["samples"], 2000);
    // The summary agrees with the file it describes.
    let max = rows.iter().map(|r| r[13]).fold(0.0, f64::max);
    let rms = (rows.iter().map(|r| r[13] * r[13]).sum::<f64>() / 2000.0).sqrt();
    let amax = rows.iter().map(|r| r[14]).fold(0.0, f64::max);
    assert_eq!(v["tip_error_max"].as_f64().unwrap(), max);
    assert!((v["tip_error_rms"].as_f64().unwrap() - rms).abs() < 1e-15);
    assert_eq!(v["axis_error_max"].as_f64().unwrap(), amax);
    assert!(
        max > 1e-3,
        "servo lag and 41 terms give a visible error: {max}"
    );
    for r in &rows {
        // Unit tool axes; the tip error never exceeds the distance to the time-matched
        // command sample (which is a point of the command path).
        let n1 = (r[4] * r[4] + r[5] * r[5] + r[6] * r[6]).sqrt();
        let n2 = (r[10] * r[10] + r[11] * r[11] + r[12] * r[12]).sqrt();
        assert!((n1 - 1.0).abs() < 1e-12 && (n2 - 1.0).abs() < 1e-12);
        let d = ((r[7] - r[1]).powi(2) + (r[8] - r[2]).powi(2) + (r[9] - r[3]).powi(2)).sqrt();
        assert!(r[13] <= d + 1e-12);
    }
    // Human output names the units.
    let o = mtwin(
        dir.path(),
        &[
            "twin",
            "predict",
            "--machine",
            &m,
            "--commands",
            "cmd.csv",
            "--out",
            "pred2.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("µm") && text.contains("µrad") && text.contains("at t ="),
        "{text}"
    );
}

#[test]
fn only_modes_separate_the_sources() {
    let dir = tempfile::tempdir().unwrap();
    write_commands(dir.path(), 1500);
    let run = |machine: &str, extra: &[&str], out: &str| {
        let m = example(machine);
        let mut args = vec![
            "twin",
            "predict",
            "--machine",
            &m,
            "--commands",
            "cmd.csv",
            "--out",
            out,
            "--format",
            "json",
        ];
        args.extend_from_slice(extra);
        json(&mtwin(dir.path(), &args))
    };
    // Servo only on a machine without servo models: the axes follow exactly on the
    // nominal geometry, so the actual tool is the command tool.
    let v = run(
        "ac-trunnion-with-errors.toml",
        &["--only", "servo"],
        "a.csv",
    );
    assert!(v["tip_error_max"].as_f64().unwrap() < 1e-9, "{v}");
    assert!(v["axis_error_max"].as_f64().unwrap() < 1e-12, "{v}");
    // Geometry only on the twin machine = the full twin of the same machine without
    // servo models (the same 41 terms).
    run("ac-trunnion-twin.toml", &["--only", "geometry"], "b.csv");
    run("ac-trunnion-with-errors.toml", &[], "c.csv");
    let b = std::fs::read(dir.path().join("b.csv")).unwrap();
    assert_eq!(b, std::fs::read(dir.path().join("c.csv")).unwrap());
    // Servo only on the twin machine = the full twin of the nominal machine with the
    // same servos: its tip error differs from geometry-only and from the full twin.
    let s = run("ac-trunnion-twin.toml", &["--only", "servo"], "d.csv");
    let all = run("ac-trunnion-twin.toml", &["--breakdown"], "e.csv");
    let bd = &all["breakdown"];
    assert_eq!(bd["servo"]["tip_error_max"], s["tip_error_max"]);
    assert_eq!(bd["all"]["tip_error_max"], all["tip_error_max"]);
    assert_eq!(bd["stretches"].as_array().unwrap().len(), 10);
    assert!(["servo", "geometry"].contains(&bd["dominant"].as_str().unwrap()));
    // The JSON is the library's `TwinPredictDoc`, whose text is the human output.
    let doc: mtwin::methods::twin::TwinPredictDoc =
        serde_json::from_value(all.clone()).expect("stdout is a TwinPredictDoc");
    assert_eq!(serde_json::to_value(&doc).unwrap(), all);
    let b = doc.breakdown.as_ref().unwrap();
    assert_eq!(b.servo.tip_error_max, s["tip_error_max"].as_f64().unwrap());
    assert!(doc.plots.is_empty() && all.get("plots").is_none());
    let m = example("ac-trunnion-twin.toml");
    let o = mtwin(
        dir.path(),
        &[
            "twin",
            "predict",
            "--machine",
            &m,
            "--commands",
            "cmd.csv",
            "--out",
            "e.csv",
            "--breakdown",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), doc.to_string());
    // Without --breakdown the key is absent and the document has none.
    let doc: mtwin::methods::twin::TwinPredictDoc = serde_json::from_value(s.clone()).unwrap();
    assert!(doc.breakdown.is_none() && s.get("breakdown").is_none());
    assert_eq!(doc.sources, "servo");
}

/// Runs the twin on a bad command file `name` (text `text`): exit 1, the stderr must hold
/// `want`, and no output (nor temporary) file is left.
fn refused(dir: &Path, name: &str, text: &str, want: &str) {
    std::fs::write(dir.join(name), text).unwrap();
    let before = std::fs::read_dir(dir).unwrap().count();
    let m = example("ac-trunnion-twin.toml");
    let args = [
        "twin",
        "predict",
        "--machine",
        &m,
        "--commands",
        name,
        "--out",
        "pred.csv",
    ];
    let o = mtwin(dir, &args);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(want), "{}", stderr(&o));
    assert!(!dir.join("pred.csv").exists());
    assert_eq!(
        std::fs::read_dir(dir).unwrap().count(),
        before,
        "no temporary file left"
    );
}

#[test]
fn uneven_sampling_and_missing_columns_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_commands(dir.path(), 100);
    let text = std::fs::read_to_string(&p).unwrap();
    // Data row 41 (t = 0.04 s) is on line 43; move it to 0.0405 s.
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[42] = lines[42].replacen(",0.04,", ",0.0405,", 1);
    refused(
        dir.path(),
        "uneven.csv",
        &lines.join("\n"),
        "uneven.csv:43:2: t_s = 0.0405",
    );
    // Time going back.
    lines[42] = lines[42].replacen(",0.0405,", ",0.039,", 1);
    refused(
        dir.path(),
        "back.csv",
        &lines.join("\n"),
        "back.csv:43:2: t_s = 0.039 does not increase",
    );
    refused(
        dir.path(),
        "noc.csv",
        "t_s,X,Y,Z,A\n0,0,0,0,0\n",
        "noc.csv:1: missing column `C`",
    );
    // Commands every 2 ms against 1 ms servo models.
    refused(
        dir.path(),
        "slow.csv",
        "t_s,X,Y,Z,A,C\n0,0,0,0,0,0\n0.002,0,0,0,0,0\n",
        "servo model runs at ts = 0.001 s",
    );
}

#[test]
fn perfect_machine_runs_the_corpus_boat_without_error_and_plots() {
    let Some(boat) = crate::shared::shared_dir("corpus/gcode/linuxcnc/boat-xyzac.ngc") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let m = example("ac-trunnion.toml");
    let b = boat.display().to_string();
    let o = mtwin(
        dir.path(),
        &[
            "twin",
            "predict",
            "--machine",
            &m,
            "--gcode",
            &b,
            "--tcp",
            "--ts",
            "0.01",
            "--out",
            "pred.csv",
            "--plot",
            "plots",
            "--format",
            "json",
        ],
    );
    let v = json(&o);
    assert!(v["samples"].as_u64().unwrap() > 1000, "{v}");
    assert!(v["tip_error_max"].as_f64().unwrap() < 1e-6, "{v}");
    for f in ["path.svg", "tip_error.svg", "axis_error.svg"] {
        let svg = std::fs::read_to_string(dir.path().join("plots").join(f)).unwrap();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"), "{f}");
    }
    let svg = std::fs::read_to_string(dir.path().join("plots/path.svg")).unwrap();
    assert!(svg.contains("ε_p, µm"));
}

#[test]
fn bad_program_line_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("p.nc"), "G1 X10 F600\nG1 X900\n").unwrap();
    let m = example("ac-trunnion-twin.toml");
    let o = mtwin(
        dir.path(),
        &[
            "twin",
            "predict",
            "--machine",
            &m,
            "--gcode",
            "p.nc",
            "--out",
            "pred.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("p.nc:2:"), "{}", stderr(&o));
    assert!(!dir.path().join("pred.csv").exists());
}

/// The servo errors of the S-piece and the boat under each planner, as
/// docs/twin.md tabulates them ("Servo errors per planner"): every row of
/// that table is run with the command the page gives and its figures
/// (program time, ε_p max and RMS in µm, ε_o max in µrad, three decimals)
/// must be what the command prints. The boat rows need ../shared.
#[test]
fn servo_errors_per_planner_are_as_documented() {
    let page = std::fs::read_to_string(repo().join("docs/twin.md")).unwrap();
    let rows: Vec<Vec<String>> = page
        .split("### Servo errors per planner")
        .nth(1)
        .expect("docs/twin.md has the section")
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().trim_matches('`').to_string())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 6, "two programs × three planners: {rows:?}");
    let dir = tempfile::tempdir().unwrap();
    let m = example("ac-trunnion-twin.toml");
    for row in &rows {
        let [program, planner, time, max, rms, axis] = &row[..] else {
            panic!("row {row:?}");
        };
        let path = match program.as_str() {
            "s-curve-5axis.ngc" => repo().join("examples/programs/s-curve-5axis.ngc"),
            "boat-xyzac.ngc" => {
                match crate::shared::shared_dir("corpus/gcode/linuxcnc/boat-xyzac.ngc") {
                    Some(p) => p,
                    None => continue,
                }
            }
            other => panic!("unknown program {other}"),
        };
        let p = path.display().to_string();
        let v = json(&mtwin(
            dir.path(),
            &[
                "twin",
                "predict",
                "--machine",
                &m,
                "--gcode",
                &p,
                "--planner",
                planner,
                "--ts",
                "0.001",
                "--only",
                "servo",
                "--out",
                "pred.csv",
                "--format",
                "json",
            ],
        ));
        let got = [
            format!("{:.3} s", v["duration_s"].as_f64().unwrap()),
            format!("{:.3}", v["tip_error_max"].as_f64().unwrap() * 1e3),
            format!("{:.3}", v["tip_error_rms"].as_f64().unwrap() * 1e3),
            format!("{:.3}", v["axis_error_max"].as_f64().unwrap() * 1e6),
        ];
        assert_eq!(
            [time, max, rms, axis].map(String::as_str),
            got.each_ref().map(String::as_str),
            "{program} under {planner}"
        );
    }
}
