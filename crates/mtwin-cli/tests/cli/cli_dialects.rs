//! `--dialect` of the commands that write a program (`servo excitation`,
//! `tracker plan`, `ballbar program`, `testpiece s-shape`): the Fanuc
//! program is written for Fanuc (dwell `G4 X` in seconds, a decimal point on
//! every real number) and `mtwin gcode stats` reads it, with and without
//! decimal point programming, as the same motion as the LinuxCNC program.

use crate::common::*;

use std::path::Path;

use mtwin::gcode::GcodeStatsDoc;

/// `gcode stats` of `program` read with `reading` (extra flags).
fn stats(dir: &Path, program: &str, reading: &[&str]) -> GcodeStatsDoc {
    let mut args = vec!["gcode", "stats", program, "--format", "json"];
    args.extend_from_slice(reading);
    let o = mtwin(dir, &args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    serde_json::from_str(&stdout(&o)).unwrap()
}

/// Writes the program with `args` + `--dialect linuxcnc|fanuc` + the output
/// flag, and checks that the Fanuc one reads (both ways) as the LinuxCNC one
/// within `tol` mm of path length, with the same moves and dwell time.
fn same_motion(dir: &Path, args: &[&str], out_flag: &str, file: &str, tol: f64) {
    let mut docs = Vec::new();
    for dialect in ["linuxcnc", "fanuc"] {
        let out = format!("{dialect}-{file}");
        let mut a: Vec<&str> = args.to_vec();
        a.extend_from_slice(&["--dialect", dialect, out_flag, &out]);
        let o = mtwin(dir, &a);
        assert_eq!(o.status.code(), Some(0), "{a:?}: {}", stderr(&o));
        let text = std::fs::read_to_string(dir.join(&out)).unwrap();
        if dialect == "fanuc" {
            assert!(!text.contains("G4 P"), "{text}");
            for line in text.lines().filter(|l| l.starts_with("G1 ")) {
                // Every axis and feed word carries a decimal point.
                for w in line.split_whitespace().skip(1) {
                    if w.starts_with(['X', 'Y', 'Z', 'A', 'B', 'C', 'F']) {
                        assert!(w.contains('.'), "{line}");
                    }
                }
            }
            let a = stats(dir, &out, &["--dialect", "fanuc"]);
            let b = stats(dir, &out, &["--dialect", "fanuc", "--decimal-point"]);
            assert_eq!(
                (a.feed_length_mm, a.linear_moves, a.rapid_moves),
                (b.feed_length_mm, b.linear_moves, b.rapid_moves)
            );
            docs.push(a);
        } else {
            docs.push(stats(dir, &out, &[]));
        }
    }
    let (l, f) = (&docs[0], &docs[1]);
    assert_eq!(
        (l.linear_moves, l.rapid_moves),
        (f.linear_moves, f.rapid_moves)
    );
    assert!(
        (l.feed_length_mm - f.feed_length_mm).abs() <= tol,
        "{} vs {}",
        l.feed_length_mm,
        f.feed_length_mm
    );
    assert!((l.dwell_time_s - f.dwell_time_s).abs() < 1e-9);
}

#[test]
fn servo_excitation_takes_the_dialect() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "servo",
        "excitation",
        "--axis",
        "X",
        "--travel",
        "-100,100",
        "--feed",
        "3000",
    ];
    same_motion(dir.path(), &args, "--out", "exc.nc", 1e-9);
    let text = std::fs::read_to_string(dir.path().join("fanuc-exc.nc")).unwrap();
    assert!(text.contains("G4 X0.5"), "{text}");
}

#[test]
fn tracker_plan_takes_the_dialect() {
    let dir = tempfile::tempdir().unwrap();
    let nominal = example("afp-gantry.toml");
    let args = [
        "tracker",
        "plan",
        "--machine",
        &nominal,
        "--fit",
        "pdge:cheb2,location",
        "--candidates",
        "200",
        "--select",
        "90",
        "--seed",
        "4",
        "--out-csv",
        "poses.csv",
    ];
    // 40 moves with up to 3 linear words each rounded to 0.0005 mm.
    same_motion(
        dir.path(),
        &args,
        "--out-gcode",
        "poses.nc",
        40.0 * 3.0 * 5e-4,
    );
}

#[test]
fn ballbar_program_takes_the_dialect() {
    let dir = tempfile::tempdir().unwrap();
    for dialect in ["linuxcnc", "fanuc"] {
        let o = mtwin(
            dir.path(),
            &["ballbar", "program", "--out", dialect, "--dialect", dialect],
        );
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    for mode in ["mode1.ngc", "mode2.ngc", "mode3.ngc", "mode4.ngc"] {
        let l = stats(dir.path(), &format!("linuxcnc/{mode}"), &[]);
        let f = stats(
            dir.path(),
            &format!("fanuc/{mode}"),
            &["--dialect", "fanuc"],
        );
        let text = std::fs::read_to_string(dir.path().join("fanuc").join(mode)).unwrap();
        assert!(text.contains("G4 X2.") && !text.contains("G4 P"), "{text}");
        assert_eq!(
            (l.linear_moves, l.rapid_moves),
            (f.linear_moves, f.rapid_moves)
        );
        assert!((l.dwell_time_s - f.dwell_time_s).abs() < 1e-9);
        assert!((l.feed_time_s - f.feed_time_s).abs() < 1e-6);
    }
}

#[test]
fn testpiece_s_shape_takes_the_dialect() {
    let dir = tempfile::tempdir().unwrap();
    let machine = example("ac-trunnion.toml");
    let args = [
        "testpiece",
        "s-shape",
        "--machine",
        &machine,
        "--segments",
        "40",
        "--tcp",
    ];
    // TCP: X Y Z are the tip; 40 segments whose ends move by at most
    // √3·0.0005 mm each (3 decimals for Fanuc against 6).
    same_motion(
        dir.path(),
        &args,
        "--out",
        "s.nc",
        40.0 * 2.0 * 3f64.sqrt() * 5e-4,
    );
}
