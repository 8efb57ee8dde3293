//! `mtwin predict` (contract): columns, values against an independent closed form, bad input.

use crate::common::*;

fn write(dir: &std::path::Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

#[test]
fn nominal_machine_predicts_the_closed_form() {
    // AC trunnion, nominal: the tip in W is Rz(−c)·Rx(−a)·(x, y, z) − (0, 0, −150) … computed
    // here by hand for a = 90°, c = 0: Rx(−90°) maps (x, y, z) to (x, z, −y).
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "poses.csv",
        "# a comment\nX,Y,Z,A,C,extra\n10,20,30,90,0,ignored\n0,0,0,0,0,1\n",
    );
    let o = mtwin(
        dir.path(),
        &[
            "predict",
            "--machine",
            &example("ac-trunnion.toml"),
            "--data",
            "poses.csv",
            "--out",
            "pred.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(dir.path().join("pred.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "Y,X,Z,A,C,x,y,z,i,j,k");
    let row: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let expect = [
        20.0,
        10.0,
        30.0,
        90.0,
        0.0,
        10.0,
        30.0,
        -20.0 + 150.0,
        0.0,
        1.0,
        0.0,
    ];
    for (a, b) in row.iter().zip(expect) {
        assert!((a - b).abs() < 1e-12, "{row:?}");
    }
    let row: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    assert_eq!(&row[5..], &[0.0, 0.0, 150.0, 0.0, 0.0, 1.0]);
}

#[test]
fn bad_cell_names_line_and_column_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "poses.csv",
        "X,Y,Z,A,C\n1,2,3,4,5\n1,2,abc,4,5\n",
    );
    let o = mtwin(
        dir.path(),
        &[
            "predict",
            "--machine",
            &example("ac-trunnion.toml"),
            "--data",
            "poses.csv",
            "--out",
            "pred.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("poses.csv:3:3:"), "{}", stderr(&o));
    assert!(!dir.path().join("pred.csv").exists());
}

#[test]
fn missing_axis_column_and_pose_outside_travel() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "a.csv", "X,Y,Z,A\n1,2,3,4\n");
    let o = mtwin(
        dir.path(),
        &[
            "predict",
            "--machine",
            &example("ac-trunnion.toml"),
            "--data",
            "a.csv",
            "--out",
            "p.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("missing column `C`"), "{}", stderr(&o));
    write(dir.path(), "b.csv", "X,Y,Z,A,C\n1,2,3,150,5\n");
    let o = mtwin(
        dir.path(),
        &[
            "predict",
            "--machine",
            &example("ac-trunnion.toml"),
            "--data",
            "b.csv",
            "--out",
            "p.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("b.csv:2:4:") && stderr(&o).contains("outside its travel"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("p.csv").exists());
}

#[test]
fn existing_output_survives_a_failed_run() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "p.csv", "keep me\n");
    write(dir.path(), "b.csv", "X,Y,Z,A,C\n1,2,3,4,NaN\n");
    let o = mtwin(
        dir.path(),
        &[
            "predict",
            "--machine",
            &example("ac-trunnion.toml"),
            "--data",
            "b.csv",
            "--out",
            "p.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("p.csv")).unwrap(),
        "keep me\n"
    );
}

#[test]
fn json_summary_and_full_precision() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "poses.csv",
        "X,Y,Z,A,C\n0.1,0.2,0.3,1.7,-33.3\n",
    );
    let o = mtwin(
        dir.path(),
        &[
            "predict",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--data",
            "poses.csv",
            "--out",
            "p.csv",
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["poses"], 1);
    assert!(v["volumetric_error_max"].as_f64().unwrap() > 0.0);
    // The document is exactly the library's `PredictDoc`.
    let doc: mtwin::kinematics::PredictDoc = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(doc.poses, 1);
    assert_eq!(doc.out, "p.csv");
    let text = std::fs::read_to_string(dir.path().join("p.csv")).unwrap();
    let row = text.lines().nth(1).unwrap();
    // Input values are echoed exactly, and outputs have full precision (not rounded).
    assert!(row.starts_with("0.2,0.1,0.3,1.7,-33.3,"), "{row}");
    assert!(row.split(',').nth(5).unwrap().len() > 10, "{row}");
}
