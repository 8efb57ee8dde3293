//! `mtwin compensate`: identity with an error-free model, the actual machine
//! reaching the nominal path with a known error model, refusals, and the
//! commands of docs/compensation.md.

use crate::common::*;

use std::path::Path;

use mtwin::gcode::{self, Axes, EventKind, InterpOptions};
use mtwin::kinematics::Kinematics;
use mtwin::nalgebra::Vector3;

/// A small five-axis TCP program (X Y Z = tip in W).
const PART: &str = "%\nG21 G90 G94\nM428 (tcp on)\nG0 X0 Y0 Z50 A10 C0\n\
G1 X40 Y-30 Z10 F800 (cut)\nG1 X-60 Y30 Z5 A25 C-40\nG1   x-20 y60 z0 a-15 c120 ; lower case\n\
M429\nM30\n%\n";

fn boat() -> Option<std::path::PathBuf> {
    crate::shared::shared_dir("corpus/gcode/linuxcnc/boat-xyzac.ngc")
}

/// Straight TCP moves of a program: (from, to) tips in W, and whether the
/// move is a feed (rapids are compensated at their ends only).
fn tcp_segments(program: &[u8]) -> Vec<(Axes, Axes, bool)> {
    let mut out = Vec::new();
    gcode::interpret(program, InterpOptions::default(), |_, events| {
        for e in events {
            if let EventKind::Feed(m) | EventKind::Traverse(m) = e.kind {
                assert!(m.tcp, "test programs are TCP programs");
                let feed = matches!(e.kind, EventKind::Feed(_));
                out.push((m.from.add(&m.offset), m.to.add(&m.offset), feed));
            }
        }
        Ok(())
    })
    .unwrap();
    out
}

/// Actual tip when a nominal TCP controller runs program point `p` on the
/// AC trunnion (axes Y X Z A C): nominal IK of the tip, actual FK.
fn actual_tip(nominal: &Kinematics, actual: &Kinematics, p: &Axes) -> Vector3<f64> {
    use mtwin::gcode::Axis;
    let tip = Vector3::new(p[Axis::X], p[Axis::Y], p[Axis::Z]);
    let q0 = [0.0, 0.0, 0.0, p[Axis::A], p[Axis::C]];
    let q = nominal
        .inverse(
            &mtwin::kinematics::IkTarget { tip, axis: None },
            &q0,
            &[true, true, true, false, false],
            &mtwin::kinematics::IkOptions::default(),
        )
        .unwrap();
    actual.pose(&q).tip
}

fn to_segment(x: &Vector3<f64>, a: &Axes, b: &Axes) -> f64 {
    let a = Vector3::from(a.xyz());
    let d = Vector3::from(b.xyz()) - a;
    let t = if d.norm_squared() > 0.0 {
        ((x - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + d * t - x).norm()
}

/// Largest distance of the actual tip (ends of every new move, midpoints of
/// every new feed move)
/// from the nominal path (the straight tip segments of the old program).
fn worst_deviation(old: &[u8], new: &[u8]) -> f64 {
    let m =
        mtwin::model::read_machine(Path::new(&example("ac-trunnion-with-errors.toml"))).unwrap();
    let (kn, ka) = (Kinematics::nominal(&m), Kinematics::new(&m));
    let nominal = tcp_segments(old);
    let mut worst: f64 = 0.0;
    for (a, b, feed) in tcp_segments(new).iter().skip(1) {
        let mid = Axes(std::array::from_fn(|i| 0.5 * (a.0[i] + b.0[i])));
        let points = if *feed { vec![&mid, b] } else { vec![b] };
        for p in points {
            let x = actual_tip(&kn, &ka, p);
            let d = nominal
                .iter()
                .map(|(u, v, _)| to_segment(&x, u, v))
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(d);
        }
    }
    worst
}

#[test]
fn error_free_model_leaves_programs_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("part.ngc"), PART).unwrap();
    let mut inputs = vec![dir.path().join("part.ngc")];
    inputs.extend(boat());
    for input in inputs {
        let out = dir.path().join("same.ngc");
        let o = mtwin(
            dir.path(),
            &[
                "compensate",
                "--machine",
                &example("ac-trunnion.toml"),
                "--program",
                input.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--format",
                "json",
            ],
        );
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(std::fs::read(&out).unwrap() == std::fs::read(&input).unwrap());
        let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        assert_eq!(v["blocks_changed"], 0);
        let d: mtwin::methods::compensate::CompensateDoc =
            serde_json::from_str(&stdout(&o)).expect("stdout is a CompensateDoc");
        assert_eq!(d.blocks_changed, 0);
    }
}

#[test]
fn known_errors_bring_the_actual_machine_onto_the_nominal_path() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("part.ngc"), PART).unwrap();
    let mut inputs = vec![dir.path().join("part.ngc")];
    inputs.extend(boat());
    for input in inputs {
        let out = dir.path().join("comp.ngc");
        let o = mtwin(
            dir.path(),
            &[
                "compensate",
                "--machine",
                &example("ac-trunnion-with-errors.toml"),
                "--program",
                input.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--tol",
                "0.001",
            ],
        );
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(stdout(&o).contains("largest correction"));
        let old = std::fs::read(&input).unwrap();
        let new = std::fs::read(&out).unwrap();
        let before = worst_deviation(&old, &old);
        let after = worst_deviation(&old, &new);
        assert!(before > 0.01, "uncompensated deviation {before}");
        assert!(after <= 0.001 + 1e-4, "compensated deviation {after}");
    }
}

#[test]
fn refusals_name_the_line_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("part.ngc"), PART).unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "compensate",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--program",
            "part.ngc",
            "--out",
            "comp.ngc",
            "--max-correction",
            "0.0001",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("part.ngc:4:1: "), "{}", stderr(&o));
    assert!(!dir.path().join("comp.ngc").exists());
    std::fs::write(
        dir.path().join("far.ngc"),
        "G21 G90\nG1 X10 F100\nG1 X350\n",
    )
    .unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "compensate",
            "--machine",
            &example("ac-trunnion.toml"),
            "--program",
            "far.ngc",
            "--out",
            "comp.ngc",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("far.ngc:3:") && stderr(&o).contains("outside its travel"));
    assert!(!dir.path().join("comp.ngc").exists());
}

#[test]
fn fanuc_programs_get_a_decimal_point_in_every_rewritten_word() {
    let dir = tempfile::tempdir().unwrap();
    // Fanuc without decimal point programming: X40000 is 40 mm.
    let part = "G21 G90 G94\nG0 X40000 Y0 Z-50000 A20000 C0\nG1 X-40000 F1000\nG1 Y30000\nM30\n";
    std::fs::write(dir.path().join("part.nc"), part).unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "compensate",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--program",
            "part.nc",
            "--out",
            "comp.nc",
            "--dialect",
            "fanuc",
            "--max-correction",
            "2",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let new = std::fs::read_to_string(dir.path().join("comp.nc")).unwrap();
    let old: Vec<&str> = part.split_whitespace().collect();
    let changed: Vec<&str> = new
        .split_whitespace()
        .filter(|w| !old.contains(w) && w.starts_with(['X', 'Y', 'Z', 'A', 'C']))
        .collect();
    assert!(changed.len() >= 4, "{new}");
    for w in changed {
        assert!(w.contains('.'), "`{w}` lacks a decimal point:\n{new}");
    }
}
