//! `mtwin positioning evaluate`: the JSON contract, the plot, bad input.

use crate::common::{example, json, mtwin, mtwin_ok, stderr, stdout};

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

/// The known positioning error of the synthetic run below, µm, at X = −300,
/// −150, 0, 150, 300 mm; each target read three times per direction at
/// `truth ± reversal/2 + spread`.
const TRUTH_UM: [f64; 5] = [-4.0, 2.5, 0.0, 7.25, 12.0];

fn synthetic_run() -> String {
    let mut s = String::from("target_mm,direction,cycle,deviation_um\n");
    let targets = [-300.0, -150.0, 0.0, 150.0, 300.0];
    let spread = [0.5, -1.0, 0.5];
    for (t, m) in targets.iter().zip(TRUTH_UM) {
        for (dir, half_b) in [("up", 3.0), ("down", -3.0)] {
            for (j, e) in spread.iter().enumerate() {
                s.push_str(&format!("{t},{dir},{},{}\n", j + 1, m + half_b + e));
            }
        }
    }
    s
}

fn predicted_x(dir: &std::path::Path, machine: &str, xs: &[f64]) -> Vec<f64> {
    let mut poses = String::from("X,Y,Z,A,C\n");
    for x in xs {
        poses.push_str(&format!("{x},0,0,0,0\n"));
    }
    std::fs::write(dir.join("poses.csv"), poses).unwrap();
    mtwin_ok(
        dir,
        &[
            "predict",
            "--machine",
            machine,
            "--data",
            "poses.csv",
            "--out",
            "pred.csv",
        ],
    );
    let text = std::fs::read_to_string(dir.join("pred.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = head.iter().position(|h| *h == "x").unwrap();
    lines
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn update_model_puts_the_mean_deviation_into_exx_predict_and_linuxcnc_carry_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("run.csv"), synthetic_run()).unwrap();
    let model = example("ac-trunnion.toml");
    let o = mtwin_ok(
        p,
        &[
            "positioning",
            "evaluate",
            "--data",
            "run.csv",
            "--update-model",
            &model,
            "--axis",
            "X",
            "--out-model",
            "new.toml",
            "--format",
            "json",
        ],
    );
    assert!(stderr(&o).contains("EXX of 5 points"), "{}", stderr(&o));
    let text = std::fs::read_to_string(p.join("new.toml")).unwrap();
    assert!(text.contains("EXX"), "{text}");

    // predict: tool tip x of the updated model − nominal = the known deviation
    // (X is on the tool chain along +x); between targets linear interpolation.
    let xs = [-300.0, -150.0, 0.0, 150.0, 300.0, 90.0, -210.0];
    let want_um: Vec<f64> = TRUTH_UM
        .iter()
        .copied()
        .chain([0.6 * 7.25, -4.0 + 0.6 * (2.5 + 4.0)])
        .collect();
    let new = predicted_x(p, "new.toml", &xs);
    let nominal = predicted_x(p, &model, &xs);
    for ((n, o), want) in new.iter().zip(&nominal).zip(&want_um) {
        let got = (n - o) * 1000.0;
        assert!((got - want).abs() < 1e-9, "{got} vs {want} µm");
    }

    // export to LinuxCNC: comp_X.txt corrects by −EXX at each grid point.
    mtwin_ok(
        p,
        &[
            "export",
            "--machine",
            "new.toml",
            "--to",
            "linuxcnc",
            "--out",
            "lc",
        ],
    );
    let comp = std::fs::read_to_string(p.join("lc/comp_X.txt")).unwrap();
    let rows: Vec<[f64; 3]> = comp
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect();
    for (x, want) in xs.iter().zip(&want_um) {
        let r = rows
            .iter()
            .find(|r| (r[0] - x).abs() < 1e-9)
            .unwrap_or_else(|| panic!("no comp line at {x}: {comp}"));
        for c in [r[1], r[2]] {
            assert!(
                (c * 1000.0 + want).abs() < 1e-5,
                "at {x}: {c} mm vs −{want} µm"
            );
        }
    }
}

#[test]
fn update_model_refusals_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("run.csv"), synthetic_run()).unwrap();
    std::fs::copy(example("ac-trunnion.toml"), p.join("m.toml")).unwrap();
    let before = std::fs::read(p.join("m.toml")).unwrap();
    let args = |axis: &'static str, out: &'static str| {
        [
            "positioning",
            "evaluate",
            "--data",
            "run.csv",
            "--update-model",
            "m.toml",
            "--axis",
            axis,
            "--out-model",
            out,
            "--plot",
            "p.svg",
        ]
    };
    // the input as output
    let o = mtwin(p, &args("X", "m.toml"));
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("same file as the input"),
        "{}",
        stderr(&o)
    );
    // an axis the model has not
    let o = mtwin(p, &args("W", "new.toml"));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no axis W"), "{}", stderr(&o));
    // targets beyond the travel of A (±120°)
    std::fs::write(p.join("run.csv"), synthetic_run().replace("300,", "400,")).unwrap();
    let o = mtwin(p, &args("A", "new.toml"));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("outside the travel"), "{}", stderr(&o));
    // --update-model without --out-model is a usage error
    let o = mtwin(
        p,
        &[
            "positioning",
            "evaluate",
            "--data",
            "run.csv",
            "--update-model",
            "m.toml",
            "--axis",
            "X",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(!p.join("new.toml").exists() && !p.join("p.svg").exists());
    assert_eq!(std::fs::read(p.join("m.toml")).unwrap(), before);
}
