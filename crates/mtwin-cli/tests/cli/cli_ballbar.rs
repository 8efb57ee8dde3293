//! `mtwin ballbar` ([R1] in docs/references.md): setup-error, identify on simulated data, bad
//! input with file and line, subsets, outputs (docs/ballbar.md is run by docs.rs).

use crate::common::*;

use serde_json::Value;

fn json(o: &std::process::Output) -> Value {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
    serde_json::from_str(&stdout(o)).expect("one JSON document on stdout")
}

/// stdout read into the library's document type: `--format json` is exactly
/// the serialised document.
fn doc<D: serde::de::DeserializeOwned>(o: &std::process::Output) -> D {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
    serde_json::from_str(&stdout(o)).expect("the command's document on stdout")
}

#[test]
fn setup_error_matches_the_cosine_rule_by_hand() {
    // Ball at (−0.06, −0.08): R = 0.1, |OB2|² = 99.94² + 0.08², cos φ = 0.6, θ2 = 233.13°.
    let dir = tempfile::tempdir().unwrap();
    let ob2 = (99.94_f64.powi(2) + 0.0064).sqrt();
    let (lmax, lmin) = (format!("{}", ob2 + 0.1), format!("{}", ob2 - 0.1));
    let o = mtwin(
        dir.path(),
        &[
            "ballbar",
            "setup-error",
            "--length",
            "100",
            "--lmax",
            &lmax,
            "--lmin",
            &lmin,
            "--theta2",
            "233.13",
            "--format",
            "json",
        ],
    );
    let v = json(&o);
    let d: mtwin::methods::ballbar::BallbarSetupDoc = doc(&o);
    assert_eq!(
        (d.ex, d.ey),
        (v["ex"].as_f64().unwrap(), v["ey"].as_f64().unwrap())
    );
    assert!((v["ex"].as_f64().unwrap() + 0.06).abs() < 1e-9, "{v}");
    assert!((v["ey"].as_f64().unwrap() + 0.08).abs() < 1e-9, "{v}");
    // θ2 in (0°, 180°]: the sign of eY flips.
    let o = mtwin(
        dir.path(),
        &[
            "ballbar",
            "setup-error",
            "--length=100",
            "--lmax",
            &lmax,
            "--lmin",
            &lmin,
            "--theta2",
            "126.87",
            "--format",
            "json",
        ],
    );
    assert!((json(&o)["ey"].as_f64().unwrap() - 0.08).abs() < 1e-9);
    let o = mtwin(
        dir.path(),
        &[
            "ballbar",
            "setup-error",
            "--length",
            "100",
            "--lmax",
            "90.2",
            "--lmin",
            "90",
            "--theta2",
            "10",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no triangle"), "{}", stderr(&o));
}

fn simulate(dir: &std::path::Path, machine: &str) {
    let o = mtwin(
        dir,
        &[
            "ballbar",
            "simulate",
            "--machine",
            machine,
            "--ex",
            "-0.0403",
            "--ey=-0.0765",
            "--noise",
            "0.0003",
            "--seed",
            "4",
            "--out",
            "data",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

fn identify_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
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
        "--length",
        "100",
        "--zb1c",
        "100",
        "--zb1a",
        "100",
        "--ex",
        "-0.0403",
        "--ey",
        "-0.0765",
        "--format",
        "json",
    ];
    v.extend_from_slice(extra);
    v
}

#[test]
fn identify_recovers_the_machine_file_errors() {
    // Simulated on the machine with PIGEs and PDGEs, identified with the same machine
    // (its PIGEs ignored): the values of the file come back.
    let dir = tempfile::tempdir().unwrap();
    let m = example("ac-trunnion-with-errors.toml");
    simulate(dir.path(), &m);
    let o = mtwin(
        dir.path(),
        &identify_args(&["--machine", &m, "--out", "id.toml"]),
    );
    let v = json(&o);
    let d: mtwin::methods::ballbar::BallbarIdentifyDoc = doc(&o);
    assert_eq!(d.out.as_deref(), Some("id.toml"));
    assert!(d.unidentified.is_empty() && d.residual_rms.0.iter().all(Option::is_some));
    let truth = [
        ("EY0A", 0.021),
        ("EZ0A", -0.017),
        ("EB0A", 8.7e-5),
        ("EC0A", -6.1e-5),
        ("EX0C", 0.014),
        ("EY0C", -0.026),
        ("EA0C", 4.4e-5),
        ("EB0C", -9.3e-5),
    ];
    for (k, t) in truth {
        let got = v[k].as_f64().unwrap();
        let s = v["uncertainty"][k].as_f64().unwrap();
        assert!(
            s > 0.0 && (got - t).abs() < 5.0 * s,
            "{k}: {got} vs {t} (σ {s})"
        );
    }
    for m in ["mode1", "mode2", "mode3", "mode4"] {
        let r = v["residual_rms"][m].as_f64().unwrap();
        assert!((2e-4..4e-4).contains(&r), "{m}: {r}");
    }
    // The written model carries the identified values and reads back.
    let text = std::fs::read_to_string(dir.path().join("id.toml")).unwrap();
    assert!(text.contains("EY0A"), "{text}");
    let o = mtwin(dir.path(), &["model", "check", "id.toml"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Compensation: the corrected axis lines are the nominal ones (through 0) plus the offsets.
    assert_eq!(v["compensation"]["A_line_y"], v["EY0A"]);
}

#[test]
fn a_subset_says_what_it_cannot_identify() {
    let dir = tempfile::tempdir().unwrap();
    simulate(dir.path(), &example("ac-trunnion.toml"));
    let o = mtwin(
        dir.path(),
        &[
            "ballbar",
            "identify",
            "--mode3",
            "data/mode3.csv",
            "--length",
            "100",
            "--ex",
            "-0.0403",
            "--ey",
            "-0.0765",
            "--format",
            "json",
        ],
    );
    let v = json(&o);
    let d: mtwin::methods::ballbar::BallbarIdentifyDoc = doc(&o);
    assert_eq!(
        d.unidentified.len(),
        v["unidentified"].as_object().unwrap().len()
    );
    // EY0A and EY0C act as one in mode 3: exactly one of them is left unidentified.
    let nulls = ["EY0A", "EY0C"].iter().filter(|k| v[**k].is_null()).count();
    assert_eq!(nulls, 1, "{v}");
    assert!(v["EZ0A"].is_null() && v["EB0C"].is_null() && v["EX0C"].is_number());
    assert!(stderr(&o).contains("not identified"), "{}", stderr(&o));
}

#[test]
fn bad_mode_files_are_named_with_file_and_line_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    simulate(dir.path(), &example("ac-trunnion.toml"));
    let cases = [
        (
            "angle_deg,length_mm\n5,100\n10,100\n15,100\n20,100\n25,100\n",
            "bad.csv:1",
            "no reading at angle 0",
        ),
        (
            "angle_deg,length_mm\n0,100\n5,100\n5,100\n15,100\n20,100\n",
            "bad.csv:4",
            "appears twice",
        ),
        (
            "angle_deg,length_mm\n0,100\n5,100\n10,100\n",
            "bad.csv:1",
            "at least 5",
        ),
        (
            "angle_deg,length_mm\n0,100\n5,1o0\n10,100\n15,100\n20,100\n",
            "bad.csv:3:2",
            "not a number",
        ),
    ];
    for (text, at, what) in cases {
        std::fs::write(dir.path().join("bad.csv"), text).unwrap();
        let mut args = identify_args(&["--out", "never.toml"]);
        args[3] = "bad.csv";
        let o = mtwin(dir.path(), &args);
        assert_eq!(o.status.code(), Some(1), "{what}");
        let e = stderr(&o);
        assert!(e.contains(at) && e.contains(what), "{what}: {e}");
        assert!(stdout(&o).is_empty());
        assert!(!dir.path().join("never.toml").exists());
    }
}

#[test]
fn program_writes_four_programs() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "ballbar",
            "program",
            "--out",
            "p",
            "--a-range",
            "-45,45,15",
            "--dwell",
            "1.5",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let p1 = std::fs::read_to_string(dir.path().join("p/mode1.ngc")).unwrap();
    assert_eq!(p1.matches("G4 P1.5").count(), 7);
    let p4 = std::fs::read_to_string(dir.path().join("p/mode4.ngc")).unwrap();
    assert!(p4.contains("G0 X0 Y0 Z100"));
    let o = mtwin(
        dir.path(),
        &["ballbar", "program", "--out", "q", "--a-range", "5,45,10"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("must pass through 0"));
}

#[test]
fn sensitivity_program_and_simulate_print_their_documents() {
    use mtwin::methods::ballbar::{BallbarProgramDoc, BallbarSensitivityDoc, BallbarSimulateDoc};
    let dir = tempfile::tempdir().unwrap();
    let d: BallbarSensitivityDoc = doc(&mtwin(
        dir.path(),
        &["ballbar", "sensitivity", "--format", "json"],
    ));
    assert_eq!(d.0.len(), 8);
    let d: BallbarProgramDoc = doc(&mtwin(
        dir.path(),
        &["ballbar", "program", "--out", "progs", "--format", "json"],
    ));
    assert_eq!(d.files.len(), 4);
    assert!(
        d.files.iter().all(|f| dir.path().join(f).exists()),
        "{:?}",
        d.files
    );
    let d: BallbarSimulateDoc = doc(&mtwin(
        dir.path(),
        &[
            "ballbar", "simulate", "--noise", "0.0002", "--seed", "9", "--out", "sim", "--format",
            "json",
        ],
    ));
    assert_eq!((d.files.len(), d.seed, d.noise), (4, 9, 0.0002));
}
