//! `--planner jerk` on `gcode stats`, `gcode interpolate` and `twin predict
//! --gcode`: the time of a rotary move is the 7-phase closed form, the
//! commands agree, and a machine file without `max_jerk` is refused naming
//! the file, the axis and the key, with no output written.

use crate::common::*;

/// `G1 C300` on the example trunnion's C axis (720 deg/s, 7200 deg/s²,
/// 72 000 deg/s³; the feed of 1000 deg/s is above the velocity limit):
/// a²/j = 720 deg/s reaches the velocity limit, so the rest-to-rest
/// jerk-limited time is L/v + v/a + a/j.
const C_MOVE: &str = "G1 C300 F60000\n";
const C_TIME: f64 = 300.0 / 720.0 + 720.0 / 7200.0 + 7200.0 / 72000.0;

#[test]
fn jerk_planner_times_a_rotary_move_by_the_closed_form_in_stats_and_interpolate() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("c.nc"), C_MOVE).unwrap();
    let m = example("ac-trunnion.toml");
    let o = mtwin_ok(
        dir.path(),
        &[
            "gcode",
            "stats",
            "c.nc",
            "--machine",
            &m,
            "--planner",
            "jerk",
            "--format",
            "json",
        ],
    );
    let v = json(&o);
    let t = v["total_time_s"].as_f64().unwrap();
    assert!((t - C_TIME).abs() < 1e-9, "{t} s against {C_TIME} s");
    let o = mtwin_ok(
        dir.path(),
        &[
            "gcode",
            "interpolate",
            "--machine",
            &m,
            "c.nc",
            "--planner",
            "jerk",
            "--ts",
            "0.001",
            "--out",
            "cmd.csv",
            "--format",
            "json",
        ],
    );
    let v = json(&o);
    let d = v["duration_s"].as_f64().unwrap();
    assert!((d - C_TIME).abs() < 1e-9, "{d}");
    let text = std::fs::read_to_string(dir.path().join("cmd.csv")).unwrap();
    let last: Vec<f64> = text
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    assert_eq!(&last[1..], &[0.0, 0.0, 0.0, 0.0, 300.0]);
}

#[test]
fn jerk_planner_refuses_a_machine_without_max_jerk_naming_file_axis_and_key() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("c.nc"), C_MOVE).unwrap();
    // The example trunnion without the `max_jerk` of axis X.
    let text = std::fs::read_to_string(example("ac-trunnion.toml")).unwrap();
    let mut out = Vec::new();
    let mut axis = String::new();
    for l in text.lines() {
        if let Some(n) = l.strip_prefix("name = ") {
            axis = n.trim_matches('"').to_string();
        }
        if !(axis == "X" && l.starts_with("max_jerk")) {
            out.push(l);
        }
    }
    std::fs::write(dir.path().join("nojerk.toml"), out.join("\n")).unwrap();
    for args in [
        &[
            "gcode",
            "stats",
            "c.nc",
            "--machine",
            "nojerk.toml",
            "--planner",
            "jerk",
        ][..],
        &[
            "gcode",
            "interpolate",
            "--machine",
            "nojerk.toml",
            "c.nc",
            "--planner",
            "jerk",
            "--out",
            "cmd.csv",
        ],
        &[
            "twin",
            "predict",
            "--machine",
            "nojerk.toml",
            "--gcode",
            "c.nc",
            "--planner",
            "jerk",
            "--out",
            "pred.csv",
        ],
    ] {
        let o = mtwin(dir.path(), args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(
            e.contains("nojerk.toml: axis `X` has no `max_jerk`"),
            "{args:?}: {e}"
        );
        assert!(!dir.path().join("cmd.csv").exists());
        assert!(!dir.path().join("pred.csv").exists());
    }
    // The other planners do not need it.
    mtwin_ok(
        dir.path(),
        &["gcode", "stats", "c.nc", "--machine", "nojerk.toml"],
    );
}
