//! `mtwin positioning evaluate`: the JSON contract, the plot, bad input.

use crate::common::{mtwin, stderr, stdout};

fn json(out: &std::process::Output) -> serde_json::Value {
    assert!(out.status.success(), "{}", stderr(out));
    serde_json::from_str(&stdout(out)).expect("one JSON document")
}

const RUN: &str = "target_mm,direction,cycle,deviation_um\n\
0,up,1,1\n0,up,2,3\n0,down,1,-1\n0,down,2,-1\n\
100,up,1,10\n100,up,2,10\n100,down,1,4\n100,down,2,6\n";

#[test]
fn json_contract_keys_in_micrometres() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("run.csv"), RUN).unwrap();
    let v = json(&mtwin(
        dir.path(),
        &[
            "positioning",
            "evaluate",
            "--data",
            "run.csv",
            "--format",
            "json",
            "--plot",
            "run.svg",
        ],
    ));
    let s2 = std::f64::consts::SQRT_2;
    // x̄↑ = 2, 10; x̄↓ = -1, 5 µm; s = √2 at 0↑ and 100↓, 0 elsewhere
    for (k, want) in [
        ("B", 5.0),
        ("E", 11.0),
        ("E_up", 8.0),
        ("E_down", 6.0),
        ("M", 7.0),
        ("R_up", 4.0 * s2),
        ("R_down", 4.0 * s2),
        ("R", 5.0 + 2.0 * s2),
        ("A", 11.0),
    ] {
        let got = v[k].as_f64().unwrap_or_else(|| panic!("key {k} in {v}"));
        assert!((got - want).abs() < 1e-9, "{k}: {got} vs {want}");
    }
    assert_eq!(v["per_target"].as_array().unwrap().len(), 2);
    let svg = std::fs::read_to_string(dir.path().join("run.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("mean-down-2s"));
}

#[test]
fn real_ecmc_table_through_the_cli() {
    let Some(d) = crate::shared::shared_dir("corpus/positioning/ecmc-muts-b02-x") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let dat = d.join("target_x_ISO230.dat");
    let v = json(&mtwin(
        dir.path(),
        &[
            "positioning",
            "evaluate",
            "--data",
            dat.to_str().unwrap(),
            "--format",
            "json",
        ],
    ));
    // Figures of the tool's own report that follow ISO 230-2 (mm to 5 decimals).
    for (k, want) in [("A", 135.27), ("M", 93.65), ("B", 33.58), ("E_down", 90.65)] {
        let got = v[k].as_f64().unwrap();
        assert!((got - want).abs() < 0.01, "{k}: {got} vs {want}");
    }
    let human = mtwin(
        dir.path(),
        &["positioning", "evaluate", "--data", dat.to_str().unwrap()],
    );
    assert!(
        stdout(&human).contains("9 targets × 5 cycles"),
        "{}",
        stdout(&human)
    );
}

#[test]
fn bad_runs_exit_1_with_file_line_column_and_no_plot() {
    let dir = tempfile::tempdir().unwrap();
    let one = "target_mm,direction,measured_mm\n0,up,0.001\n0,up,0.002\n10,up,10.001\n10,up,10.0\n";
    std::fs::write(dir.path().join("one.csv"), one).unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "positioning",
            "evaluate",
            "--data",
            "one.csv",
            "--plot",
            "p.svg",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("one.csv:2:1: one direction only"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("p.svg").exists());

    let uneven = "target_mm,direction,deviation_um\n0,up,1\n0,up,2\n0,down,1\n0,down,2\n5,up,1\n5,down,1\n5,down,3\n";
    std::fs::write(dir.path().join("uneven.csv"), uneven).unwrap();
    let o = mtwin(
        dir.path(),
        &["positioning", "evaluate", "--data", "uneven.csv"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("uneven.csv:6:1: cycles of unequal length"),
        "{}",
        stderr(&o)
    );

    std::fs::write(dir.path().join("x.log"), "CMD 2024-01-01 00:00:00.1 0\n").unwrap();
    let o = mtwin(dir.path(), &["positioning", "evaluate", "--data", "x.log"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("x.log: name the reference channel"),
        "{}",
        stderr(&o)
    );
}
