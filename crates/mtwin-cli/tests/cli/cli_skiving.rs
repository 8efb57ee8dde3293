//! `mtwin skiving` ([R3] in docs/references.md): the setup-error contract against synthetic
//! truths, the program and simulate subcommands, bad input, and every
//! command of docs/skiving.md.

use crate::common::*;

use std::path::Path;

const GEOM: [&str; 8] = ["--h", "80", "--L", "150", "--rt", "40", "--rg", "60"];

fn run(dir: &Path, args: &[&str]) -> std::process::Output {
    let o = mtwin(dir, args);
    assert_eq!(o.status.code(), Some(0), "{args:?}\n{}", stderr(&o));
    o
}

fn simulate(dir: &Path, truth: [&str; 4], extra: &[&str], out: &str) {
    let mut args = vec!["skiving", "simulate", "--x", "0"];
    args.extend(GEOM);
    args.extend([
        "--dgx", truth[0], "--dgy", truth[1], "--exz", truth[2], "--ezy", truth[3], "--out", out,
    ]);
    args.extend(extra);
    args.extend(["--format", "json"]);
    let o = run(dir, &args);
    let d: mtwin::methods::skiving::doc::SkivingSimulateDoc =
        serde_json::from_slice(&o.stdout).expect("stdout is a SkivingSimulateDoc");
    assert_eq!(d.out, out);
}

fn setup_error_json(dir: &Path, data: &str, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["skiving", "setup-error", "--data", data];
    args.extend(GEOM);
    args.extend(["--format", "json"]);
    args.extend(extra);
    let o = run(dir, &args);
    let v: serde_json::Value =
        serde_json::from_slice(&o.stdout).expect("stdout is one JSON document");
    // The document is exactly the library's `SkivingSetupDoc`.
    let d: mtwin::methods::skiving::doc::SkivingSetupDoc =
        serde_json::from_slice(&o.stdout).expect("stdout is a SkivingSetupDoc");
    assert_eq!(Some(d.touches as u64), v["touches"].as_u64());
    assert_eq!(Some(d.estimate.dgx), v["dgx"].as_f64());
    v
}

#[test]
fn contract_recovers_a_synthetic_truth() {
    let dir = tempfile::tempdir().unwrap();
    let truth = ["0.047", "-0.033", "0.00029", "-0.00021"];
    simulate(dir.path(), truth, &[], "touches.csv");
    let v = setup_error_json(dir.path(), "touches.csv", &[]);
    let want: Vec<f64> = truth.iter().map(|s| s.parse().unwrap()).collect();
    for (k, name) in ["dgx", "dgy", "exz", "ezy"].iter().enumerate() {
        let got = v[name].as_f64().unwrap();
        let tol = if k < 2 { 1e-9 } else { 1e-11 };
        assert!((got - want[k]).abs() < tol, "{name}: {got} vs {}", want[k]);
    }
    let r = v["residuals"].as_array().unwrap();
    assert_eq!(r.len(), 6);
    assert!(r.iter().all(|x| x.as_f64().unwrap().abs() < 1e-10));
    // Closed forms beside the exact solution, within their truncation error.
    assert!((v["first_order"]["ezy"].as_f64().unwrap() - want[3]).abs() < 1e-6);
}

#[test]
fn residuals_follow_file_order_and_a_bad_touch_is_flagged() {
    let dir = tempfile::tempdir().unwrap();
    simulate(
        dir.path(),
        ["0.01", "0.02", "0.0001", "0.0002"],
        &["--noise", "0.001", "--seed", "4"],
        "t.csv",
    );
    // Shuffle the rows (reverse) and spoil the c = 90° face touch at y = +30 by 30 µm.
    let text = std::fs::read_to_string(dir.path().join("t.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header = lines.remove(0);
    lines.reverse();
    let mut f: Vec<String> = lines[2].split(',').map(String::from).collect();
    assert_eq!((f[5].as_str(), f[1].as_str()), ("90", "30"));
    f[2] = (f[2].parse::<f64>().unwrap() + 0.03).to_string();
    lines[2] = f.join(",");
    let body = format!("{header}\n# reversed\n{}\n", lines.join("\n"));
    std::fs::write(dir.path().join("bad.csv"), body).unwrap();
    let mut args = vec!["skiving", "setup-error", "--data", "bad.csv"];
    args.extend(GEOM);
    args.extend(["--noise", "0.001", "--format", "json"]);
    let o = run(dir.path(), &args);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let flags: Vec<&str> = v["flags"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    assert_eq!(
        flags,
        [
            "unchecked",
            "inconsistent",
            "inconsistent",
            "unchecked",
            "ok",
            "ok"
        ]
    );
    // Row 3 of the data is on line 5 (header, comment, two rows before it).
    assert!(
        stderr(&o).contains("bad.csv:5: touch 3 is inconsistent"),
        "{}",
        stderr(&o)
    );
    let r = v["residuals"].as_array().unwrap();
    assert!((r[2].as_f64().unwrap() - 0.015).abs() < 4e-3, "{r:?}");
}

#[test]
fn more_than_six_touches_are_used() {
    let dir = tempfile::tempdir().unwrap();
    let truth = ["-0.02", "0.04", "-0.0002", "0.0001"];
    simulate(dir.path(), truth, &["--repeat", "3"], "t3.csv");
    let v = setup_error_json(dir.path(), "t3.csv", &["--noise", "0.001"]);
    assert_eq!(v["residuals"].as_array().unwrap().len(), 18);
    assert!((v["dgy"].as_f64().unwrap() - 0.04).abs() < 1e-9);
    // Three repeats: uncertainties √3 smaller than the six-touch ones
    // (same Jacobian rows, three times over).
    simulate(dir.path(), truth, &[], "t1.csv");
    let v1 = setup_error_json(dir.path(), "t1.csv", &["--noise", "0.001"]);
    for name in ["dgx", "dgy", "exz", "ezy"] {
        let (u3, u1) = (
            v["uncertainty"][name].as_f64().unwrap(),
            v1["uncertainty"][name].as_f64().unwrap(),
        );
        assert!((u1 / u3 - 3f64.sqrt()).abs() < 1e-6, "{name}: {u1} / {u3}");
    }
    assert_eq!(v1["uncertainty_basis"]["kind"], "known_noise");
    let v0 = setup_error_json(dir.path(), "t3.csv", &[]);
    assert_eq!(v0["uncertainty_basis"]["dof"], 14);
}

#[test]
fn human_output_has_the_table_in_micrometres() {
    let dir = tempfile::tempdir().unwrap();
    simulate(dir.path(), ["0.03", "0", "0", "0"], &[], "t.csv");
    let mut args = vec!["skiving", "setup-error", "--data", "t.csv", "--explain"];
    args.extend(GEOM);
    let o = run(dir.path(), &args);
    let s = stdout(&o);
    let dgx = s
        .lines()
        .find(|l| l.trim_start().starts_with("dgx"))
        .unwrap();
    let n: f64 = dgx.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!((n - 30.0).abs() < 1e-3, "{dgx}");
    assert!(dgx.contains("y6 - rt - rg"), "{dgx}");
    assert!(s.contains("µrad"));
}

fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

fn fails(dir: &Path, data: &str, needle: &str) {
    let mut args = vec!["skiving", "setup-error", "--data", data];
    args.extend(GEOM);
    let o = mtwin(dir, &args);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(stderr(&o).contains(needle), "{}", stderr(&o));
    assert!(stdout(&o).is_empty());
}

#[test]
fn bad_input_is_reported_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "missing.csv", "x,y,z,a,b,c,point\n0,30,-80,0,0,0,face\n");
    fails(d, "missing.csv", "missing.csv:1: missing column `contact`");
    write(
        d,
        "kind.csv",
        "x,y,z,a,b,c,point,contact\n0,30,-80,0,0,0,face,top\n0,30,-80,0,0,0,face,edge\n",
    );
    fails(d, "kind.csv", "kind.csv:3:8: unknown contact type `edge`");
    // The tool face 5 mm above the top face is no contact.
    write(
        d,
        "far.csv",
        "x,y,z,a,b,c,point,contact\n0,30,-80,0,0,0,face,top\n0,30,-75,0,0,0,face,top\n",
    );
    fails(
        d,
        "far.csv",
        "far.csv:3: the tool face is 5.000 mm from the workpiece top face",
    );
    write(
        d,
        "nan.csv",
        "x,y,z,a,b,c,point,contact\n0,abc,-80,0,0,0,face,top\n",
    );
    fails(d, "nan.csv", "nan.csv:2:2: column `y` holds `abc`");
    // Too few touches for four unknowns.
    write(
        d,
        "few.csv",
        "x,y,z,a,b,c,point,contact\n0,30,-80,0,0,0,face,top\n",
    );
    fails(d, "few.csv", "at least 4");
}

#[test]
fn programs_in_both_dialects_and_no_output_on_failure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Written to 4 decimals for LinuxCNC, 3 with a decimal point for Fanuc.
    for (dialect, probe, out, tol) in [
        ("linuxcnc", "G38.2", "a.ngc", 0.5e-4),
        ("fanuc", "G31", "b.nc", 0.5e-3),
    ] {
        let mut args = vec![
            "skiving",
            "program",
            "--x",
            "-2.5",
            "--dialect",
            dialect,
            "--out",
            out,
        ];
        args.extend(GEOM);
        run(d, &args);
        let text = std::fs::read_to_string(d.join(out)).unwrap();
        let probes: Vec<&str> = text.lines().filter(|l| l.starts_with(probe)).collect();
        assert_eq!(probes.len(), 6, "{text}");
        // Side touch target: nominal y = rt + √(rg² − x²) minus the 1 mm overtravel.
        let y = 40.0 + (3600.0f64 - 6.25).sqrt() - 1.0;
        let word = |line: &str, letter: char| -> f64 {
            let w = line.split_whitespace().find(|w| w.starts_with(letter));
            w.unwrap_or_else(|| panic!("{letter} in {line}"))[1..]
                .parse()
                .unwrap()
        };
        assert!((word(probes[2], 'Y') - y).abs() <= tol, "{}", probes[2]);
        assert_eq!(word(probes[0], 'Z'), -81.0, "{}", probes[0]);
        if dialect == "fanuc" {
            assert!(probes[0].contains("Z-81. "), "{}", probes[0]);
        }
    }
    let mut args = vec![
        "skiving",
        "program",
        "--x",
        "70",
        "--dialect",
        "fanuc",
        "--out",
        "c.nc",
    ];
    args.extend(GEOM);
    let o = mtwin(d, &args);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("beside the workpiece"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("c.nc").exists());
}

#[test]
fn documented_walkthrough_recovers_its_truth() {
    let dir = tempfile::tempdir().unwrap();
    let ran = crate::common::run_doc("skiving.md", dir.path());
    assert!(ran.len() >= 6, "{ran:?}");
    // The documented truth, recovered within 3 uncertainties (95 % factor 4.3).
    let o = run(
        dir.path(),
        &[
            "skiving",
            "setup-error",
            "--data",
            "touches3.csv",
            "--h",
            "80",
            "--L",
            "150",
            "--rt",
            "40",
            "--rg",
            "60",
            "--format",
            "json",
        ],
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for (name, t) in [("dgx", 0.03), ("dgy", -0.02), ("exz", 2e-4), ("ezy", -1e-4)] {
        let u = v["uncertainty"][name].as_f64().unwrap();
        assert!(
            (v[name].as_f64().unwrap() - t).abs() < 3.0 * 4.3 * u,
            "{name}"
        );
    }
    for f in ["touchoff.ngc", "O9100.nc", "touches.csv", "touches3.csv"] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
}
