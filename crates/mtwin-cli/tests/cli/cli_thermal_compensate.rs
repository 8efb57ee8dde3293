//! `mtwin thermal compensate`: the check of the source paper [R4] replayed in simulation (a face
//! milled cold and again after an hour at varying speed), G91 and G53 blocks,
//! programs without spindle, errors with file:line, and the commands of
//! docs/thermal-compensation.md.

use std::path::Path;
use std::process::Output;

use crate::common::{mtwin, run_doc, stderr, stdout};
use mtwin::gcode::{
    Axis, EventKind, InterpOptions, Interpreter, Program, ProgramStats, SpindleState, StatsOptions,
};
use mtwin::methods::thermal::{SpeedHistory, ThermalFitOptions, TruthMachine, fit_csv};

/// The one place that names the subcommand (the lead moves it under `thermal`).
fn compensate(cwd: &Path, args: &[&str]) -> Output {
    let mut argv = vec!["thermal", "compensate"];
    argv.extend_from_slice(args);
    mtwin(cwd, &argv)
}

const MEASURED: [f64; 4] = [-50.0, -150.0, -250.0, -350.0];
const FACE_Z: f64 = -50.0;

/// The demo machine with every gain scaled by `k`.
fn truth(k: f64) -> TruthMachine {
    let mut m = TruthMachine::demo();
    m.fast_gain_mm *= k;
    m.slow_gain_mm *= k;
    m
}

/// Writes THERMAL.toml fitted on `machine`'s probing runs (0.1 µm noise).
fn fit_model(machine: &TruthMachine, dir: &Path) {
    let steps = [2000.0, 6000.0, 0.0, 8000.0, 4000.0, 1000.0, 7000.0, 3000.0];
    let runs = vec![
        ("const4000", vec![4000.0; 48]),
        ("const8000", vec![8000.0; 48]),
        ("steps", steps.iter().flat_map(|&s| [s; 6]).collect()),
    ];
    let train = dir.join("TRAIN.csv");
    std::fs::write(&train, machine.training_csv(&runs, &MEASURED, 1e-4, 11)).unwrap();
    let fit = fit_csv(&train, &ThermalFitOptions::default()).unwrap();
    fit.model.write(&dir.join("THERMAL.toml")).unwrap();
}

/// Face Z = −50 with 20 passes of 200 mm at 2000 mm/min (2 min), tagged
/// `(face N)` on every pass.
fn face(n: u32, out: &mut String) {
    out.push_str(&format!("G0 X0 Y0\nG1 Z{FACE_Z} F500\n"));
    for i in 0..20 {
        let x = if i % 2 == 0 { 200 } else { 0 };
        out.push_str(&format!("G1 X{x} F2000 (face {n})\nG1 Y{}\n", (i + 1) * 5));
    }
    out.push_str("G0 Z5\n");
}

/// Cold face, an hour at varying speed (dwells stand for cutting elsewhere),
/// face again.
fn source_paper_program() -> String {
    let mut s = String::from("%\nG21 G90 G94 G17\nG0 Z5\nS6000 M3\n");
    face(1, &mut s);
    for (rpm, seconds) in [
        (3000, 600),
        (8000, 900),
        (5000, 600),
        (7000, 900),
        (2000, 600),
    ] {
        s.push_str(&format!("S{rpm}\nG4 P{seconds}\n"));
    }
    s.push_str("S6000\n");
    face(2, &mut s);
    s.push_str("M5\nM30\n%\n");
    s
}

/// Height of each face: the mean over its passes of the actual tool Z,
/// programmed Z plus the true drift at the pass's end time (the truth is
/// linear in time between its samples, as the model's convention). The
/// program is timed and its spindle history built from its own events.
fn face_heights(program: &str, machine: &TruthMachine) -> [f64; 2] {
    let prog = Program::parse(program.as_bytes()).unwrap();
    let opts = StatsOptions::default();
    let mut interp = Interpreter::new(InterpOptions::default());
    let mut st = ProgramStats::default();
    let mut speed = SpeedHistory::default();
    let (mut rpm, mut on) = (0.0, false);
    let mut passes: Vec<(usize, f64, f64)> = Vec::new(); // face, t_min, z
    let mut events = Vec::new();
    for b in &prog.blocks {
        events.clear();
        interp.execute(b, &mut events).unwrap();
        let mut z = None;
        for e in &events {
            match e.kind {
                EventKind::SpindleSpeed { rpm: r } => rpm = r,
                EventKind::Spindle(s) => on = s != SpindleState::Stopped,
                EventKind::Feed(l) => z = Some(l.to[Axis::Z]),
                _ => {}
            }
            speed.set(st.total_time() / 60.0, if on { rpm } else { 0.0 });
            st.add(e, &opts).unwrap();
        }
        let text = String::from_utf8_lossy(b.text()).into_owned();
        for n in [1, 2] {
            if text.contains(&format!("(face {n})")) {
                passes.push((n - 1, st.total_time() / 60.0, z.unwrap()));
            }
        }
    }
    let t_end = st.total_time() / 60.0;
    let samples = (t_end / machine.period_min).ceil() as usize + 2;
    let speeds: Vec<f64> = (0..samples)
        .map(|k| speed.mean(k as f64 * 10.0, (k + 1) as f64 * 10.0))
        .collect();
    let drift = machine.drift(&speeds, FACE_Z);
    let mut sum = [0.0; 2];
    let mut count = [0usize; 2];
    for (f, t, z) in passes {
        let k = (t / machine.period_min).floor() as usize;
        let frac = t / machine.period_min - k as f64;
        let e = drift[k] + frac * (drift[k + 1] - drift[k]);
        sum[f] += z + e;
        count[f] += 1;
    }
    assert_eq!(count, [20, 20]);
    [sum[0] / 20.0, sum[1] / 20.0]
}

#[test]
fn source_paper_check_faces_cold_and_after_an_hour() {
    let dir = tempfile::tempdir().unwrap();
    let program = source_paper_program();
    // Truth magnitude chosen so the uncompensated faces differ by about 7 µm
    // (the demo machine gives about 14 µm on this program).
    let machine = truth(0.5);
    let [f1, f2] = face_heights(&program, &machine);
    let uncompensated = (f2 - f1) * 1e3;
    assert!(
        (6.0..8.0).contains(&uncompensated.abs()),
        "uncompensated face difference {uncompensated} µm"
    );
    fit_model(&machine, dir.path());
    std::fs::write(dir.path().join("IN.nc"), &program).unwrap();
    for extra in [&[][..], &["--continuous"][..]] {
        let mut args = vec![
            "--model",
            "THERMAL.toml",
            "--program",
            "IN.nc",
            "--out",
            "OUT.nc",
        ];
        args.extend_from_slice(extra);
        let o = compensate(dir.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = std::fs::read_to_string(dir.path().join("OUT.nc")).unwrap();
        let [c1, c2] = face_heights(&out, &machine);
        let compensated = (c2 - c1) * 1e3;
        eprintln!(
            "{extra:?}: uncompensated {uncompensated:.2} µm, compensated {compensated:.2} µm"
        );
        assert!(compensated.abs() <= 2.0, "{extra:?}: {compensated} µm");
        // Only Z words changed: same line count, and lines without Z identical.
        assert_eq!(out.lines().count(), program.lines().count());
        for (a, b) in out.lines().zip(program.lines()) {
            if !b.contains('Z') {
                assert_eq!(a, b);
            }
        }
    }
}

#[test]
fn incremental_g53_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    fit_model(&truth(1.0), dir.path());
    let src = "G21 G90\nS8000 M3\nG4 P1800\nG53 G0 Z-10\nG0 Z-50\nG91\nG4 P1200\nG1 Z-1 F100\nX10\nG90\nM30\n";
    std::fs::write(dir.path().join("IN.nc"), src).unwrap();
    let o = compensate(
        dir.path(),
        &[
            "--model",
            "THERMAL.toml",
            "--program",
            "IN.nc",
            "--out",
            "OUT.nc",
            "--continuous",
            "--format",
            "json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["blocks_changed"], 2);
    assert_eq!(j["z_blocks"], 3);
    // The document is exactly the library's `ThermalCompensateDoc`.
    let d: mtwin::methods::thermal::ThermalCompensateDoc =
        serde_json::from_str(&stdout(&o)).expect("stdout is a ThermalCompensateDoc");
    assert_eq!((d.blocks_changed, d.z_blocks), (2, 3));
    assert!(
        stderr(&o).contains("G53") && stderr(&o).contains("line(s) 4"),
        "{}",
        stderr(&o)
    );
    let out = std::fs::read_to_string(dir.path().join("OUT.nc")).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[3], "G53 G0 Z-10");
    let z = |l: &str| -> f64 {
        l.split_whitespace()
            .find_map(|w| w.strip_prefix('Z'))
            .unwrap()
            .parse()
            .unwrap()
    };
    // Drift is negative (the tool moves down): targets move up; the G91 step
    // moves up by the growth of the drift over 20 min, so it is smaller in size.
    let (z_abs, z_inc) = (z(lines[4]), z(lines[7]));
    assert!(z_abs > -50.0 && z_inc > -1.0, "{z_abs} {z_inc}");
    let c1 = -50.0 - z_abs;
    let c2 = c1 + (-1.0 - z_inc);
    let largest = j["max_correction_um"].as_f64().unwrap();
    assert!((largest - c2.abs() * 1e3).abs() < 0.2, "{largest} vs {c2}");
    assert_eq!(lines[8], "X10");
}

#[test]
fn no_spindle_program_is_unchanged_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    fit_model(&truth(1.0), dir.path());
    let src = "%\r\nG21 G90 (mm)\r\nG0 Z10.000\r\nG1  Z-1.50 F100\r\nG4 P3600\r\nG1 Z-2.5\nM30";
    std::fs::write(dir.path().join("IN.nc"), src).unwrap();
    let o = compensate(
        dir.path(),
        &[
            "--model",
            "THERMAL.toml",
            "--program",
            "IN.nc",
            "--out",
            "OUT.nc",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(dir.path().join("OUT.nc")).unwrap(),
        src.as_bytes()
    );
    assert!(
        stderr(&o).contains("never turns the spindle on"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn errors_name_file_and_line_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    fit_model(&truth(1.0), dir.path());
    for (src, line) in [
        ("S1000 M3\nG0 Z5\nG1 Z-1\n", 3), // no feed before a feed move
        ("S1000 M3\nG0 Z5\nG81 X1 Z-1 R1 F100\n", 3), // canned cycle
        ("S1000 M3\nG18\nG0 X0 Z0\nG2 X10 Z0 I5 F100\n", 4), // Z of a ZX-plane arc
    ] {
        std::fs::write(dir.path().join("BAD.nc"), src).unwrap();
        let o = compensate(
            dir.path(),
            &[
                "--model",
                "THERMAL.toml",
                "--program",
                "BAD.nc",
                "--out",
                "OUT.nc",
            ],
        );
        assert_eq!(o.status.code(), Some(1), "{src}");
        assert!(
            stderr(&o).contains(&format!("BAD.nc:{line}:")),
            "{src}: {}",
            stderr(&o)
        );
        assert!(!dir.path().join("OUT.nc").exists());
    }
}

/// Runs every `$ mtwin thermal compensate` line of the documentation on the
/// documentation's example program.
#[test]
fn documented_commands_run() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let ran = run_doc("thermal-compensation.md", p).len();
    assert_eq!(ran, 4, "the documentation shows its commands");
    // The live compensation's export writes the HAL component beside its
    // HAL file and instructions.
    for f in ["mtwin_thermal.py", "thermal.hal", "thermal-README.txt"] {
        assert!(p.join("live").join(f).is_file(), "live/{f}");
    }
    // The plot's y range is the range of the corrections actually written:
    // original Z minus rewritten Z of every Z word (0.1 µm resolution).
    let z_words = |f: &str| -> Vec<f64> {
        std::fs::read_to_string(p.join(f))
            .unwrap()
            .split_whitespace()
            .filter_map(|w| w.strip_prefix('Z').and_then(|v| v.parse().ok()))
            .collect()
    };
    let (orig, comp) = (z_words("faces.nc"), z_words("faces-comp.nc"));
    assert_eq!(orig.len(), comp.len());
    let c: Vec<f64> = orig.iter().zip(&comp).map(|(a, b)| (a - b) * 1e3).collect();
    let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let svg = std::fs::read_to_string(p.join("correction.svg")).unwrap();
    // y tick labels: whole steps from the last step at or below the smallest
    // correction to the first at or above the largest.
    let labels: Vec<f64> = svg
        .lines()
        .filter(|l| l.contains(r#"text-anchor="end""#))
        .filter_map(|l| l.rsplit("</text>").nth(1)?.rsplit('>').next()?.parse().ok())
        .collect();
    assert!(labels.len() >= 3, "{svg}");
    let step = labels[1] - labels[0];
    assert!(step > 0.0, "{labels:?}");
    for w in labels.windows(2) {
        assert!((w[1] - w[0] - step).abs() < 1e-9, "{labels:?}");
    }
    let last = labels[labels.len() - 1];
    assert!(
        labels[0] <= lo + 0.06 && lo - 0.06 < labels[0] + step,
        "{labels:?} vs {lo}"
    );
    assert!(
        last >= hi - 0.06 && hi + 0.06 > last - step,
        "{labels:?} vs {hi}"
    );
    // One plotted point per Z block.
    let points = svg
        .lines()
        .find(|l| l.contains("<polyline"))
        .and_then(|l| l.split("points=\"").nth(1))
        .map(|r| r.split('"').next().unwrap().split_whitespace().count())
        .unwrap();
    assert_eq!(points, c.len());
}

/// A word of an axis the machine (`--machine`) lacks is refused with the
/// program's `file:line:col`, nothing written; without a machine it is read.
#[test]
fn words_of_axes_the_machine_lacks_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    fit_model(&truth(1.0), dir.path());
    std::fs::write(
        dir.path().join("W.nc"),
        "S1000 M3\nG0 Z5\nG1 Z1 W2 F100\nM2\n",
    )
    .unwrap();
    let machine = crate::common::example("ac-trunnion.toml");
    let args = |with_machine: bool| {
        let mut a = vec![
            "--model",
            "THERMAL.toml",
            "--program",
            "W.nc",
            "--out",
            "OUT.nc",
        ];
        if with_machine {
            a.extend_from_slice(&["--machine", machine.as_str()]);
        }
        a
    };
    let o = compensate(dir.path(), &args(true));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("W.nc:3:7: invalid block: W word: the machine has no W axis"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("OUT.nc").exists());
    let o = compensate(dir.path(), &args(false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}
