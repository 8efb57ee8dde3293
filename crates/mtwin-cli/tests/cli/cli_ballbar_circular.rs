//! `mtwin ballbar circular` / `simulate-circular`: the JSON contract, recovery
//! through the CLI, bad input.

use crate::common::{mtwin, stderr, stdout};

#[test]
fn simulated_errors_come_back_through_the_json_contract() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "ballbar",
            "simulate-circular",
            "--out",
            "t",
            "--radius",
            "150",
            "--noise",
            "0.2",
            "--backlash-x-um",
            "8",
            "--squareness-um-per-m",
            "40",
            "--scale-mismatch-um",
            "10",
            "--centre-x-um",
            "5",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = mtwin(
        dir.path(),
        &[
            "ballbar",
            "circular",
            "--cw",
            "t/cw.csv",
            "--ccw",
            "t/ccw.csv",
            "--radius",
            "150",
            "--format",
            "json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    for k in [
        "G",
        "H",
        "F",
        "backlash_y_um",
        "lateral_play_x_um",
        "reversal_spike_x_um",
        "cyclic_error_x_um",
        "servo_mismatch_um",
        "straightness_x_um",
    ] {
        assert!(v[k].is_number(), "{k} in {v}");
    }
    for (k, want) in [
        ("backlash_x_um", 8.0),
        ("squareness_um_per_m", 40.0),
        ("scale_mismatch_um", 10.0),
    ] {
        let got = v[k].as_f64().unwrap();
        assert!(
            (got - want).abs() <= (0.05 * want).max(0.5),
            "{k}: {got} vs {want}"
        );
    }
    // squareness 40 µm/m over R = 150 mm: ±3 µm of sin 2θ; the trace is not round
    assert!(v["G"].as_f64().unwrap() > 5.0);
}

#[test]
fn bad_trace_is_a_file_line_column_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("angle_deg,deviation_um\n");
    for k in 0..10 {
        csv.push_str(&format!(
            "{},{}\n",
            k * 36,
            if k == 4 { "x" } else { "0.5" }
        ));
    }
    std::fs::write(dir.path().join("cw.csv"), &csv).unwrap();
    let o = mtwin(
        dir.path(),
        &["ballbar", "circular", "--cw", "cw.csv", "--radius", "100"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("cw.csv:6:2:"), "{}", stderr(&o));
}
