//! `mtwin tracker identify` (contract), `validate`, `plan`, `simulate`,
//! `compensate-points`: an end-to-end run on the AFP gantry and bad input;
//! the old top-level spellings still work and print the same.

use crate::common::*;

use std::path::Path;

fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

fn json(o: &std::process::Output) -> serde_json::Value {
    serde_json::from_str(&stdout(o)).unwrap_or_else(|e| panic!("{e}: {}", stdout(o)))
}

/// stdout read into the library's document type: `--format json` is exactly
/// the serialised document.
fn doc<D: serde::de::DeserializeOwned>(o: &std::process::Output) -> D {
    serde_json::from_str(&stdout(o)).unwrap_or_else(|e| panic!("{e}: {}", stdout(o)))
}

fn ok(o: &std::process::Output) {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
}

#[test]
fn plan_simulate_identify_validate_compensate() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let nominal = example("afp-gantry.toml");
    let truth = example("afp-gantry-with-errors.toml");
    let spec = "pdge:cheb2,location";
    let o = mtwin(
        d,
        &[
            "tracker",
            "plan",
            "--machine",
            &nominal,
            "--fit",
            spec,
            "--candidates",
            "200",
            "--select",
            "90",
            "--seed",
            "4",
            "--out-csv",
            "poses.csv",
            "--out-gcode",
            "poses.nc",
            "--format",
            "json",
        ],
    );
    ok(&o);
    let p = json(&o);
    assert_eq!(p["poses"], 90);
    let pd: mtwin::methods::tracker::TrackerPlanDoc = doc(&o);
    assert_eq!((pd.poses, pd.candidates), (90, 200));
    let csv = std::fs::read_to_string(d.join("poses.csv")).unwrap();
    assert_eq!(csv.lines().next().unwrap(), "X,Y,Z,B,A,C");
    assert_eq!(csv.lines().count(), 91);
    let nc = std::fs::read_to_string(d.join("poses.nc")).unwrap();
    assert_eq!(nc.matches("\nG4 P2\n").count(), 90);

    for (poses, out, seed) in [
        ("poses.csv", "fit.csv", "1"),
        ("poses.csv", "check.csv", "2"),
    ] {
        let o = mtwin(
            d,
            &[
                "tracker",
                "simulate",
                "--machine",
                &truth,
                "--poses",
                poses,
                "--noise",
                "0.005",
                "--seed",
                seed,
                "--out",
                out,
                "--format",
                "json",
            ],
        );
        ok(&o);
        let sd: mtwin::methods::tracker::TrackerSimulateDoc = doc(&o);
        assert_eq!((sd.points, sd.out.as_str()), (90, out));
    }
    let o = identify_with(d, spec, &["--format", "json"]);
    ok(&o);
    let j = json(&o);
    let idd: mtwin::methods::tracker::TrackerIdentifyDoc = doc(&o);
    assert_eq!((idd.parameters, idd.points), (144, 90));
    // 6 axes × 6 PDGEs × 3 coefficients + 36 location errors.
    assert_eq!(j["parameters"], 144);
    let rank = j["rank"].as_u64().unwrap() as usize;
    let unident = j["unidentifiable"].as_array().unwrap();
    assert_eq!(rank + unident.len(), 144);
    // The roll of C does not move a tip on the C axis (by hand).
    assert!(unident.iter().any(|u| u == "ECC.c0") && unident.iter().any(|u| u == "EC0C"));
    let (before, after) = (
        j["rms_before"].as_f64().unwrap(),
        j["rms_after"].as_f64().unwrap(),
    );
    assert!(after < 0.2 * before, "{before} → {after}");
    assert!(d.join("id.toml").exists());

    let o = mtwin(
        d,
        &[
            "tracker",
            "validate",
            "--machine",
            "id.toml",
            "--data",
            "check.csv",
            "--plot",
            "v.svg",
            "--format",
            "json",
        ],
    );
    ok(&o);
    let v = json(&o);
    assert_eq!(v["points"], 90);
    let vd: mtwin::methods::tracker::TrackerValidateDoc = doc(&o);
    assert_eq!(vd.points, 90);
    assert!(v["rms_after"].as_f64().unwrap() < 0.3 * v["rms_before"].as_f64().unwrap());
    assert!(
        std::fs::read_to_string(d.join("v.svg"))
            .unwrap()
            .contains("<polyline")
    );
    let o = mtwin(
        d,
        &[
            "tracker",
            "validate",
            "--machine",
            "id.toml",
            "--data",
            "check.csv",
        ],
    );
    ok(&o);
    assert!(stdout(&o).contains("|Δp|"));

    let o = mtwin(
        d,
        &[
            "tracker",
            "compensate-points",
            "--machine",
            "id.toml",
            "--data",
            "poses.csv",
            "--out",
            "corr.csv",
            "--format",
            "json",
        ],
    );
    ok(&o);
    let c = json(&o);
    assert!(c["max_error_after"].as_f64().unwrap() < 1e-8);
    let cd: mtwin::methods::tracker::CompensatePointsDoc = doc(&o);
    assert_eq!(cd.poses, 90);
    let corr = std::fs::read_to_string(d.join("corr.csv")).unwrap();
    assert_eq!(
        corr.lines().next().unwrap(),
        "X,Y,Z,B,A,C,error_before,error_after,axis_error_after"
    );
}

fn fit_csv(d: &Path, rows: &str) {
    write(d, "fit.csv", &format!("X,Y,Z,B,A,C,x,y,z\n{rows}"));
}

fn identify(d: &Path, spec: &str) -> std::process::Output {
    identify_with(d, spec, &[])
}

/// `mtwin tracker identify` on the AFP gantry from fit.csv into id.toml.
fn identify_with(d: &Path, spec: &str, extra: &[&str]) -> std::process::Output {
    let machine = example("afp-gantry.toml");
    let mut args = vec![
        "tracker",
        "identify",
        "--machine",
        &machine,
        "--data",
        "fit.csv",
        "--fit",
        spec,
        "--out",
        "id.toml",
    ];
    args.extend_from_slice(extra);
    mtwin(d, &args)
}

fn fails_with(o: &std::process::Output, d: &Path, needles: &[&str]) {
    assert_eq!(o.status.code(), Some(1), "{}", stderr(o));
    let e = stderr(o);
    for n in needles {
        assert!(e.contains(n), "`{n}` not in: {e}");
    }
    assert!(!d.join("id.toml").exists(), "output written on failure");
}

#[test]
fn identify_rejects_bad_input_without_writing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A missing column: the header line.
    write(d, "fit.csv", "X,Y,Z,B,A,C,x,y\n1,1,-1,0,0,0,1,1\n");
    fails_with(
        &identify(d, "location"),
        d,
        &["fit.csv:1", "missing column `z`"],
    );
    // A missing axis column.
    write(d, "fit.csv", "X,Y,Z,B,C,x,y,z\n1,1,-1,0,0,1,1,-501\n");
    fails_with(
        &identify(d, "location"),
        d,
        &["fit.csv:1", "missing column `A`"],
    );
    // NaN, on line 3, column 2 (an axis) and column 8 (a measured coordinate).
    fit_csv(d, "1,1,-1,0,0,0,1,1,-501\n2,NaN,-1,0,0,0,2,1,-501\n");
    fails_with(
        &identify(d, "location"),
        d,
        &["fit.csv:3:2", "`Y`", "not a finite number"],
    );
    fit_csv(d, "1,1,-1,0,0,0,1,1,-501\n2,1,-1,0,0,0,2,nan,-501\n");
    fails_with(
        &identify(d, "location"),
        d,
        &["fit.csv:3:8", "`y`", "not a finite number"],
    );
    // An empty cell: line 2, column 9.
    fit_csv(d, "1,1,-1,0,0,0,1,1,\n");
    fails_with(
        &identify(d, "location"),
        d,
        &["fit.csv:2:9", "`z` is empty"],
    );
    // A pose outside the travel (X ≤ 8000), line 2.
    fit_csv(d, "9000,1,-1,0,0,0,1,1,-501\n");
    fails_with(
        &identify(d, "location"),
        d,
        &["fit.csv:2", "outside its travel"],
    );
    // A spec naming an axis the machine does not have.
    fit_csv(d, "1,1,-1,0,0,0,1,1,-501\n");
    fails_with(&identify(d, "EY0Q"), d, &["--fit", "axis `Q`"]);
    // Fewer points than identifiable parameters: 2 points, 9 constants of X, Y, Z
    // translations and tilts.
    fit_csv(
        d,
        "1,1,-1,0,0,0,1,1,-501\n3000,2000,-700,10,20,30,3000,2000,-1201\n",
    );
    fails_with(
        &identify(d, "EXX:cheb2,EYY:cheb2,EZZ:cheb2,EAX:const,EBY:const"),
        d,
        &["cannot determine"],
    );
}

/// A quadratic in X fitted from poses that span 4 mm of X's 8000 mm travel:
/// the Chebyshev columns T0 and T2 are nearly parallel there. The fit runs
/// (every parameter is still identifiable), writes its output and warns
/// with the condition number, on stderr and in the JSON summary.
#[test]
fn ill_conditioned_fit_warns_with_the_condition_number() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut rows = String::new();
    for k in 0..12 {
        let x = 4000.0 + 4.0 * k as f64 / 11.0;
        let (y, z) = (100.0 + 250.0 * k as f64, -50.0 - 70.0 * k as f64);
        // Nominal tip (tool tip 500 mm below C) plus a 1 µm·k straightness.
        let dx = 1e-3 * (k as f64 / 11.0).powi(2);
        rows += &format!("{x},{y},{z},0,0,0,{},{y},{}\n", x + dx, z - 500.0);
    }
    fit_csv(d, &rows);
    let o = identify_with(d, "EXX:cheb2", &["--format", "json"]);
    ok(&o);
    let e = stderr(&o);
    assert!(
        e.contains("ill-conditioned") && e.contains("condition number"),
        "{e}"
    );
    let j = json(&o);
    assert_eq!(j["rank"], 3);
    let cond = j["condition_number"].as_f64().unwrap();
    assert!(cond > 1e6, "{cond}");
    assert!(e.contains(&format!("{cond:.3e}")), "{e}");
    assert!(
        j["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.to_string().contains("ill_conditioned")),
        "{}",
        j["warnings"]
    );
    assert!(d.join("id.toml").exists());
}

#[test]
fn plan_and_simulate_reject_bad_arguments() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = example("afp-gantry.toml");
    let o = mtwin(
        d,
        &[
            "tracker",
            "plan",
            "--machine",
            &m,
            "--fit",
            "location",
            "--candidates",
            "10",
            "--select",
            "20",
            "--out-csv",
            "p.csv",
            "--out-gcode",
            "p.nc",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--select"));
    assert!(!d.join("p.csv").exists() && !d.join("p.nc").exists());
    write(d, "poses.csv", "X,Y,Z,B,A,C\n1,1,-1,0,0,0\n");
    let o = mtwin(
        d,
        &[
            "tracker",
            "simulate",
            "--machine",
            &m,
            "--poses",
            "poses.csv",
            "--noise",
            "-1",
            "--out",
            "f.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--noise"));
    assert!(!d.join("f.csv").exists());
}

/// The old spellings (`mtwin plan tracker`, `simulate tracker`, `identify`,
/// `validate`, `compensate-points`) are hidden aliases: the whole chain run
/// with either spelling, each in its own folder, prints and writes the same.
#[test]
fn old_spellings_run_the_same_commands() {
    let nominal = example("afp-gantry.toml");
    let truth = example("afp-gantry-with-errors.toml");
    let steps: [(&[&str], &[&str], Vec<&str>); 5] = [
        (
            &["tracker", "plan"],
            &["plan", "tracker"],
            vec![
                "--machine",
                &nominal,
                "--fit",
                "location",
                "--candidates",
                "60",
                "--select",
                "30",
                "--out-csv",
                "poses.csv",
                "--out-gcode",
                "poses.nc",
            ],
        ),
        (
            &["tracker", "simulate"],
            &["simulate", "tracker"],
            vec![
                "--machine",
                &truth,
                "--poses",
                "poses.csv",
                "--seed",
                "3",
                "--out",
                "fit.csv",
            ],
        ),
        (
            &["tracker", "identify"],
            &["identify"],
            vec![
                "--machine",
                &nominal,
                "--data",
                "fit.csv",
                "--fit",
                "location",
                "--out",
                "id.toml",
            ],
        ),
        (
            &["tracker", "validate"],
            &["validate"],
            vec![
                "--machine",
                "id.toml",
                "--data",
                "fit.csv",
                "--plot",
                "v.svg",
            ],
        ),
        (
            &["tracker", "compensate-points"],
            &["compensate-points"],
            vec![
                "--machine",
                "id.toml",
                "--data",
                "poses.csv",
                "--out",
                "c.csv",
            ],
        ),
    ];
    let (new_dir, old_dir) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for (new, old, rest) in &steps {
        let mut printed = Vec::new();
        for (d, verb) in [(new_dir.path(), new), (old_dir.path(), old)] {
            let mut args: Vec<&str> = verb.to_vec();
            args.extend(rest);
            args.extend(["--format", "json"]);
            let o = mtwin(d, &args);
            ok(&o);
            printed.push(stdout(&o));
        }
        assert_eq!(printed[0], printed[1], "{new:?} / {old:?}");
    }
    for f in [
        "poses.csv",
        "poses.nc",
        "fit.csv",
        "id.toml",
        "v.svg",
        "c.csv",
    ] {
        let read = |d: &Path| std::fs::read_to_string(d.join(f)).unwrap();
        assert_eq!(read(new_dir.path()), read(old_dir.path()), "{f}");
    }
}

/// `--prior`: the constant x-straightness of X and of Y move the tip alike
/// (only their sum S is determined). Without a prior the gauge splits S in
/// half (minimum norm); with a prior (p_X, p_Y) the closed form is
/// `EXX.c0 = (S + p_X − p_Y)/2`, `EXY.c0 = (S − p_X + p_Y)/2`.
#[test]
fn identify_prior_sets_the_undetermined_split() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = 0.010;
    let mut rows = String::new();
    for k in 0..12 {
        let kf = k as f64;
        let (x, y, z) = (300.0 + 600.0 * kf, 100.0 + 280.0 * kf, -80.0 * kf);
        let y = if k % 2 == 0 { y } else { 3400.0 - y };
        rows += &format!("{x},{y},{z},0,0,0,{},{y},{}\n", x + s, z - 500.0);
    }
    fit_csv(d, &rows);
    let spec = "EXX:cheb1,EXY:cheb1";
    let value = |j: &serde_json::Value, name: &str| {
        j["estimates"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == name)
            .unwrap()["value"]
            .as_f64()
            .unwrap()
    };
    let o = identify_with(d, spec, &["--format", "json"]);
    ok(&o);
    let j = json(&o);
    assert_eq!(j["gauge"], "start");
    assert!(
        (value(&j, "EXX.c0") - s / 2.0).abs() < 1e-9,
        "{}",
        j["estimates"]
    );
    assert!((value(&j, "EXY.c0") - s / 2.0).abs() < 1e-9);
    let combos = j["identifiable_combinations"].as_array().unwrap();
    assert_eq!(combos.len(), 1, "{combos:?}");
    let text = combos[0].as_str().unwrap();
    assert!(text.contains("EXX.c0") && text.contains("EXY.c0"), "{text}");
    assert!(text.contains("10.000"), "{text}");
    // The rank rule: `std=10` by default; noise-free data leave no badly
    // determined direction, so nothing is dropped. `--truncate` picks
    // another rule; a rule that is not one is refused, nothing written.
    assert_eq!(j["truncation"], "std=10");
    assert_eq!(j["dropped_directions"].as_array().unwrap().len(), 0);
    let free = j["confounded_groups"][0]["undetermined_directions"]
        .as_array()
        .unwrap();
    assert_eq!(free.len(), 1, "{free:?}");
    let o = identify_with(d, spec, &["--truncate", "rcond=1e-3", "--format", "json"]);
    ok(&o);
    assert_eq!(json(&o)["truncation"], "rcond=0.001");
    std::fs::remove_file(d.join("id.toml")).unwrap();
    let o = identify_with(d, spec, &["--truncate", "rcond=5"]);
    assert_ne!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("not a truncation rule"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("id.toml").exists());

    let (px, py) = (0.004, -0.001);
    let prior = std::fs::read_to_string(example("afp-gantry.toml"))
        .unwrap()
        .replacen(
            "travel = [0.0, 8000.0]\n",
            &format!("travel = [0.0, 8000.0]\n  [axes.errors]\n  EXX = {{ cheb = [{px}, 0.0] }}\n"),
            1,
        )
        .replacen(
            "travel = [0.0, 3500.0]\n",
            &format!("travel = [0.0, 3500.0]\n  [axes.errors]\n  EXY = {{ cheb = [{py}, 0.0] }}\n"),
            1,
        );
    write(d, "prior.toml", &prior);
    let o = identify_with(d, spec, &["--prior", "prior.toml", "--format", "json"]);
    ok(&o);
    let j = json(&o);
    assert_eq!(j["gauge"], "prior");
    assert!(
        (value(&j, "EXX.c0") - (s + px - py) / 2.0).abs() < 1e-9,
        "{}",
        j["estimates"]
    );
    assert!((value(&j, "EXY.c0") - (s - px + py) / 2.0).abs() < 1e-9);
    let fixed = j["gauge_fixed"].as_array().unwrap();
    let fx = fixed.iter().find(|g| g["name"] == "EXX.c0").unwrap();
    assert_eq!(fx["prior"].as_f64().unwrap(), px);

    // A prior of another machine is refused, nothing written.
    std::fs::remove_file(d.join("id.toml")).unwrap();
    let other = example("ac-trunnion.toml");
    let o = identify_with(d, spec, &["--prior", &other]);
    fails_with(&o, d, &["prior machine has axes"]);
}
