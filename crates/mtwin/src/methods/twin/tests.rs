//! End-to-end checks of the twin against independent computations and closed forms.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use super::*;
use crate::gcode::InterpolateOptions;
use crate::kinematics::Kinematics;
use crate::model::{ErrorFunction, Machine, ServoTable, read_machine};

fn example(name: &str) -> Machine {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines")
        .join(name);
    read_machine(&p).unwrap()
}

/// Five different servo models (unit static gain), one per axis of the trunnion.
fn five_servos() -> Vec<ServoTable> {
    let lag = |p: f64, nk: usize| ServoTable {
        ts: 0.001,
        b: vec![1.0 - p],
        a: vec![1.0, -p],
        nk,
    };
    vec![
        ServoTable {
            ts: 0.001,
            b: vec![0.0, 0.0183, 0.0171],
            a: vec![1.0, -1.8106, 0.8460],
            nk: 0,
        },
        lag(0.95, 1),
        ServoTable {
            ts: 0.001,
            b: vec![0.04, 0.04],
            a: vec![1.0, -1.6, 0.68],
            nk: 2,
        },
        lag(0.9, 0),
        ServoTable {
            ts: 0.001,
            b: vec![0.0, 0.2 * 0.12, 0.8 * 0.12],
            a: vec![1.0, -1.3, 0.42],
            nk: 1,
        },
    ]
}

/// The servo difference equation written out (docs/servo.md), on deviations from `u(0)`.
fn servo_reference(s: &ServoTable, u: &[f64]) -> Vec<f64> {
    let u0 = u[0];
    let mut y: Vec<f64> = Vec::with_capacity(u.len());
    for k in 0..u.len() {
        let mut v = 0.0;
        for i in 1..s.a.len() {
            if k >= i {
                v -= s.a[i] * y[k - i];
            }
        }
        for (j, b) in s.b.iter().enumerate() {
            if k >= j + s.nk {
                v += b * (u[k - j - s.nk] - u0);
            }
        }
        y.push(v);
    }
    y.iter().map(|v| v + u0).collect()
}

#[test]
fn matches_an_independent_computation_of_every_definition() {
    let mut m = example("ac-trunnion-with-errors.toml");
    assert_eq!(m.n_error_terms(), 41);
    for (a, s) in m.axes.iter_mut().zip(five_servos()) {
        a.servo = Some(s);
    }
    // A random smooth five-axis trajectory inside the travels, 20 000 samples at 1 ms.
    let mut rng = rand::rngs::StdRng::seed_from_u64(2024);
    let n = 20_000;
    let ts = 0.001;
    let amp = [80.0, 90.0, 60.0, 40.0, 150.0];
    let waves: Vec<[(f64, f64, f64); 2]> = (0..5)
        .map(|i| {
            [0, 1].map(|_| {
                (
                    rng.gen_range(0.2..1.5),
                    rng.gen_range(0.0..std::f64::consts::TAU),
                    amp[i] * rng.gen_range(0.2..0.5),
                )
            })
        })
        .collect();
    let mut qs = Vec::with_capacity(5 * n);
    for k in 0..n {
        let t = k as f64 * ts;
        for w in &waves {
            let v: f64 = w
                .iter()
                .map(|(f, ph, a)| a * (2.0 * std::f64::consts::PI * f * t + ph).sin())
                .sum();
            qs.push(v);
        }
    }
    let twin = Twin::new(&m, Sources::All).unwrap();
    let (rows, summary) = twin.predict_slice(0.0, ts, &qs).unwrap();
    assert_eq!(rows.len(), n);
    assert_eq!(summary.samples, n as u64);

    // Independent: the servo equation, full-transform kinematics, exhaustive search.
    let servos = five_servos();
    let mut qa = vec![0.0; 5 * n];
    for i in 0..5 {
        let u: Vec<f64> = (0..n).map(|k| qs[5 * k + i]).collect();
        for (k, y) in servo_reference(&servos[i], &u).into_iter().enumerate() {
            qa[5 * k + i] = y;
        }
    }
    let nominal = Kinematics::nominal(&m);
    let actual = Kinematics::new(&m);
    let dir = m.tool_direction;
    let full = |kin: &Kinematics, q: &[f64]| {
        let g = kin.tool_in_workpiece(q);
        (g.point(&Vector3::zeros()), g.vector(&dir))
    };
    let cmd: Vec<_> = qs.par_chunks(5).map(|q| full(&nominal, q)).collect();
    let act: Vec<_> = qa.par_chunks(5).map(|q| full(&actual, q)).collect();
    let tips: Vec<_> = cmd.iter().map(|c| c.0).collect();
    for k in 0..n {
        let r = &rows[k];
        assert!((r.cmd_tip - cmd[k].0).norm() < 1e-9, "{k}");
        assert!(angle_between(&r.cmd_axis, &cmd[k].1) < 1e-12);
        assert!(
            (r.tip - act[k].0).norm() < 1e-6,
            "{k}: {} vs {}",
            r.tip,
            act[k].0
        );
        assert!(angle_between(&r.axis, &act[k].1) < 1e-9);
    }
    // Every 7th sample (about 2 900) against all 19 999 segments.
    let checked: Vec<usize> = (0..n).step_by(7).collect();
    let worst = checked
        .par_iter()
        .map(|&j| {
            let (k, u, d) = nearest::tests::brute(&tips, &act[j].0, j);
            let o = (cmd[k].1 * (1.0 - u) + cmd[k + 1].1 * u).normalize();
            let eo = angle_between(&act[j].1, &o);
            let r = &rows[j];
            ((r.tip_error - d).abs(), (r.axis_error - eo).abs())
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0.max(b.0), a.1.max(b.1)));
    assert!(worst.0 < 1e-6, "tip error off by {} mm", worst.0);
    assert!(worst.1 < 1e-9, "axis error off by {} rad", worst.1);
    // The errors are real (servo lag of mm/s-scale motion plus 41 terms), not zero.
    assert!(summary.tip_error_max > 1e-3, "{summary:?}");
    let rms = (rows.iter().map(|r| r.tip_error.powi(2)).sum::<f64>() / n as f64).sqrt();
    assert!((summary.tip_error_rms - rms).abs() < 1e-12);
}

/// A Cartesian XYZ machine, tool chain X, Y, Z, no workpiece axes.
fn xyz() -> Machine {
    let mut m = crate::examples::xyz(500.0);
    m.rapid_feed = 10000.0;
    m
}

#[test]
fn constant_positioning_error_across_a_move_is_its_size() {
    // EXX = c everywhere, a move along Y: the actual path is the command path shifted by
    // c across it, so ε_p = |c| at every sample and the tool axis is untouched.
    let c = -0.0042;
    let mut m = xyz();
    m.axes[0].errors.pdge[0] = Some(ErrorFunction::Constant(c));
    let twin = Twin::new(&m, Sources::All).unwrap();
    let qs: Vec<f64> = (0..5001)
        .flat_map(|k| [12.0, -20.0 + 0.01 * k as f64, 3.0])
        .collect();
    let (rows, s) = twin.predict_slice(0.0, 0.001, &qs).unwrap();
    for r in &rows {
        assert!((r.tip_error - c.abs()).abs() < 1e-12, "{r:?}");
        assert_eq!(r.axis_error, 0.0);
    }
    assert!((s.tip_error_rms - c.abs()).abs() < 1e-12);
    assert!((s.path_length - 50.0).abs() < 1e-9);
}

/// Identical first-order lags `y(k) = p·y(k−1) + (1−p)·u(k)` on X and Y.
fn lagged_xyz(p: f64) -> Machine {
    let mut m = xyz();
    for a in &mut m.axes[..2] {
        a.servo = Some(ServoTable {
            ts: 0.001,
            b: vec![1.0 - p],
            a: vec![1.0, -p],
            nk: 0,
        });
    }
    m
}

#[test]
fn servo_lag_stays_on_a_straight_line_and_cuts_a_corner_by_the_closed_form() {
    let p: f64 = 0.95;
    let ts = 0.001;
    let c = 0.1; // mm per sample (100 mm/s)
    let twin = Twin::new(&lagged_xyz(p), Sources::All).unwrap();
    // A diagonal line at constant velocity from the first sample: both axes lag by
    // the same fraction, so the actual tip stays on the commanded line.
    let qs: Vec<f64> = (0..3000)
        .flat_map(|k| [0.6 * c * k as f64, 0.8 * c * k as f64, 0.0])
        .collect();
    let (rows, _) = twin.predict_slice(0.0, ts, &qs).unwrap();
    let lag = rows
        .iter()
        .map(|r| (r.tip - r.cmd_tip).norm())
        .fold(0.0, f64::max);
    assert!(lag > 1.0, "the servo lags ({lag} mm behind)");
    assert!(rows.iter().all(|r| r.tip_error < 1e-12), "{:?}", rows[2999]);

    // An L: along X for kc samples, then along Y. After the corner the X error decays
    // as ex(m) = vτ·p^m (vτ = c·p/(1−p)) and Y lags a ramp from rest,
    // ey(m) = c·m − vτ·(1 − p^m); the nearest leg gives ε_p = min(ex, ey).
    let kc = 2000;
    let xc = c * kc as f64;
    let qs: Vec<f64> = (0..4000)
        .flat_map(|k| {
            if k <= kc {
                [c * k as f64, 0.0, 0.0]
            } else {
                [xc, c * (k - kc) as f64, 0.0]
            }
        })
        .collect();
    let (rows, s) = twin.predict_slice(0.0, ts, &qs).unwrap();
    let vtau = c * p / (1.0 - p);
    let expected = (0..2000)
        .map(|m| {
            let pm = p.powi(m);
            (vtau * pm).min(c * m as f64 - vtau * (1.0 - pm))
        })
        .fold(0.0, f64::max);
    assert!(expected > 0.3 * vtau, "{expected} {vtau}");
    assert!(
        (s.tip_error_max - expected).abs() < 1e-9,
        "{} vs {expected}",
        s.tip_error_max
    );
    assert!(s.tip_error_max_at.index > kc as u64 && s.tip_error_max_at.index < kc as u64 + 100);
    // Before the corner (steady lag along X) the actual tip is on the path.
    assert!(rows[..kc].iter().all(|r| r.tip_error < 1e-12));
}

#[test]
fn rotary_only_tcp_move_takes_the_sample_closest_in_time() {
    // Under TCP, with the tip on both rotary axis lines (W (0, 0, 150) is the origin
    // of M), turning A alone keeps the tip still: every command segment has length
    // zero, all are equally near, and the sample at the same time must be taken. With
    // a lag on A only, ε_o is then exactly the lag of A (C = 0), and ε_p = 0.
    let mut m = example("ac-trunnion.toml");
    let p: f64 = 0.9;
    m.axes[3].servo = Some(ServoTable {
        ts: 0.001,
        b: vec![1.0 - p],
        a: vec![1.0, -p],
        nk: 0,
    });
    let twin = Twin::new(&m, Sources::All).unwrap();
    let mut opts = InterpolateOptions::new(0.001);
    opts.interp.tcp_at_start = true;
    let program = "G1 X0 Y0 Z150 A0 C0 F1000\nG1 A30 F1800\nG4 P0.1\n";
    let mut rows = Vec::new();
    let summary = predict_gcode(
        &twin,
        &m,
        program.as_bytes(),
        &opts,
        |r| {
            rows.push(*r);
            Ok(())
        },
        &mut |_| {},
    )
    .unwrap();
    assert!(rows.len() > 1000, "{}", rows.len());
    // Independent: the lag of A by the servo equation, from the commanded A.
    let mut a_act = 0.0;
    let mut a0 = None;
    let mut worst: f64 = 0.0;
    let mut moved = 0.0f64;
    let mut turning = 0;
    for r in &rows {
        // Recover the commanded A from the command tool axis: o = Rx(−A)·z in W.
        let a_cmd = (-r.cmd_axis.y).atan2(r.cmd_axis.z).to_degrees();
        let origin = *a0.get_or_insert(a_cmd);
        a_act = p * a_act + (1.0 - p) * (a_cmd - origin);
        let lag = ((a_cmd - origin) - a_act).to_radians().abs();
        worst = worst.max((r.axis_error - lag).abs());
        moved = moved.max(lag);
        assert!(r.tip_error < 1e-9, "{r:?}");
        if a_cmd.abs() > 1e-9 {
            // (The first block moves the tip to (0, 0, 150) from the program's start.)
            assert!(
                (r.cmd_tip - Vector3::new(0.0, 0.0, 150.0)).norm() < 1e-9,
                "{r:?}"
            );
            turning += 1;
        }
    }
    assert!(turning > 500, "{turning} samples with A turned");
    assert!(moved > 1e-3, "A lags visibly ({moved} rad)");
    assert!(
        worst < 1e-12,
        "ε_o differs from the lag of A by {worst} rad"
    );
    assert!((summary.axis_error_max - moved).abs() < 1e-12);
}

fn corpus(name: &str) -> Option<PathBuf> {
    crate::test_support::shared_dir("corpus/gcode/linuxcnc").map(|d| d.join(name))
}

#[test]
fn perfect_machine_runs_the_boat_without_error() {
    let Some(path) = corpus("boat-xyzac.ngc") else {
        return;
    };
    let text = std::fs::read(&path).unwrap();
    let m = example("ac-trunnion.toml");
    let twin = Twin::new(&m, Sources::All).unwrap();
    let mut opts = InterpolateOptions::new(0.01);
    opts.interp.tcp_at_start = true;
    let s = predict_gcode(&twin, &m, &text[..], &opts, |_| Ok(()), &mut |_| {}).unwrap();
    assert!(s.samples > 1000, "{s:?}");
    assert!(s.tip_error_max < 1e-6, "{s:?}");
    assert!(s.axis_error_max < 1e-9, "{s:?}");
    assert!(s.path_length > 100.0);
}

#[test]
fn csv_commands_stream_and_uneven_time_is_refused_at_its_line() {
    let m = lagged_xyz(0.9);
    let twin = Twin::new(&m, Sources::All).unwrap();
    let mut text = String::from("# commands\nt_s,Z,Y,X,extra\n");
    for k in 0..50 {
        text.push_str(&format!(
            "{},{},0,{},x\n",
            k as f64 * 0.001,
            1.0,
            0.1 * k as f64
        ));
    }
    let path = Path::new("cmd.csv");
    let mut rows = Vec::new();
    let s = predict_csv(
        &twin,
        path,
        text.as_bytes(),
        |r| {
            rows.push(*r);
            Ok(())
        },
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(s.samples, 50);
    // Column order in the file does not matter: X = 0.1·k, Z = 1.
    assert_eq!(rows[10].cmd_tip, Vector3::new(1.0, 0.0, 1.0));
    assert!(rows.iter().all(|r| r.tip_error < 1e-12));

    let bad = text.replace("0.007,", "0.0075,");
    let e = predict_csv(&twin, path, bad.as_bytes(), |_| Ok(()), &mut |_| {}).unwrap_err();
    assert!(
        e.to_string().starts_with("cmd.csv:10:1: t_s = 0.0075"),
        "{e}"
    );
    let back = text.replace("0.007,", "0.005,");
    let e = predict_csv(&twin, path, back.as_bytes(), |_| Ok(()), &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("does not increase"), "{e}");
    let e = predict_csv(
        &twin,
        path,
        "t_s,X,Y\n0,0,0\n".as_bytes(),
        |_| Ok(()),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("missing column `Z`"), "{e}");
    // The servos run at 1 ms: commands at 2 ms are refused.
    let slow = "t_s,X,Y,Z\n0,0,0,0\n0.002,0,0,0\n";
    let e = predict_csv(&twin, path, slow.as_bytes(), |_| Ok(()), &mut |_| {}).unwrap_err();
    assert!(matches!(e, TwinError::ServoPeriod { .. }), "{e}");
}

#[test]
fn long_runs_spool_to_a_file_with_the_same_result() {
    // More samples than the in-memory spool holds (the spool moves to a file): 34 laps
    // of a circle whose lagged tip error is known in closed form once settled; the laps
    // lie on each other, so every query also meets equally near segments of other laps.
    let n = pipeline::SPILL_SAMPLES + 5000;
    let twin = Twin::new(&lagged_xyz(0.8), Sources::All).unwrap();
    let r = 20.0;
    let w = 2.0 * std::f64::consts::PI / 4000.0;
    let qs: Vec<f64> = (0..n)
        .flat_map(|k| {
            let a = w * k as f64;
            [r * a.cos(), r * a.sin(), 5.0]
        })
        .collect();
    let (rows, s) = twin.predict_slice(0.0, 0.001, &qs).unwrap();
    assert_eq!(rows.len(), n);
    assert_eq!(s.bins.len(), pipeline::BINS);
    // A first-order lag on a circle: the actual circle has radius r·|H(e^{jw})|, so once
    // settled the tip is r·(1 − |H|) inside the path (up to the chord sag of the polyline).
    let p: f64 = 0.8;
    let h = (1.0 - p) / (1.0 - 2.0 * p * w.cos() + p * p).sqrt();
    let radial = r * (1.0 - h);
    let sag = r * (1.0 - (w / 2.0).cos());
    for row in rows.iter().skip(1000).step_by(997) {
        assert!(
            (row.tip_error - radial).abs() < sag + 1e-9,
            "{} vs {radial}",
            row.tip_error
        );
        assert_eq!(row.t, row.index as f64 * 0.001);
    }
}

#[test]
fn progress_reaches_the_total_and_rows_come_in_order() {
    let twin = Twin::new(&lagged_xyz(0.9), Sources::All).unwrap();
    let mut p = twin.start(0.001).unwrap();
    let n = 40_000u64;
    for k in 0..n {
        p.push(k as f64 * 0.001, &[0.01 * k as f64, 0.0, 0.0])
            .unwrap();
    }
    assert_eq!(p.samples(), n);
    let mut seen = Vec::new();
    let mut next = 0u64;
    p.finish(
        |r| {
            assert_eq!(r.index, next);
            next += 1;
            Ok(())
        },
        &mut |e| seen.push(e),
    )
    .unwrap();
    assert_eq!(next, n);
    assert_eq!(seen.first(), Some(&Progress::Commands(n)));
    assert_eq!(seen.last(), Some(&Progress::Errors { done: n, total: n }));
    // A failing sink stops the run with its error.
    let mut p = twin.start(0.001).unwrap();
    p.push(0.0, &[0.0; 3]).unwrap();
    let e = p
        .finish(|_| Err(std::io::Error::other("disk full")), &mut |_| {})
        .unwrap_err();
    assert!(
        matches!(e, TwinError::Sink(_)) && e.to_string() == "disk full",
        "{e}"
    );
}

#[test]
fn the_predict_document_of_a_lagged_corner_round_trips_with_its_breakdown() {
    // The L of `servo_lag_stays_on_a_straight_line_and_cuts_a_corner_by_the_closed_form`
    // on a machine without geometric errors: servo alone = all, geometry alone = 0.
    let p: f64 = 0.95;
    let c = 0.1;
    let kc = 2000;
    let qs: Vec<f64> = (0..4000)
        .flat_map(|k| {
            if k <= kc {
                [c * k as f64, 0.0, 0.0]
            } else {
                [c * kc as f64, c * (k - kc) as f64, 0.0]
            }
        })
        .collect();
    let m = lagged_xyz(p);
    let run = |s| {
        Twin::new(&m, s)
            .unwrap()
            .predict_slice(0.0, 0.001, &qs)
            .unwrap()
            .1
    };
    let (all, servo, geometry) = (
        run(Sources::All),
        run(Sources::Servo),
        run(Sources::Geometry),
    );
    let b = TwinBreakdownDoc::new(&all, &servo, &geometry);
    let d = TwinPredictDoc::new(&all, "pred.csv", Some(b), &["plots/path.svg".into()]);
    assert_eq!((d.samples, d.sources.as_str()), (4000, "all"));
    assert!((d.duration_s - 3.999).abs() < 1e-12, "{}", d.duration_s);
    // Path: 200 mm along X then 199.9 mm along Y.
    assert!(
        (d.path_length_mm - 399.9).abs() < 1e-9,
        "{}",
        d.path_length_mm
    );
    // The closed form of the corner cut (see the test named above).
    let vtau = c * p / (1.0 - p);
    let expected = (0..2000)
        .map(|m| {
            let pm = p.powi(m);
            (vtau * pm).min(c * m as f64 - vtau * (1.0 - pm))
        })
        .fold(0.0, f64::max);
    assert!(
        (d.tip_error_max - expected).abs() < 1e-9,
        "{}",
        d.tip_error_max
    );
    let b = d.breakdown.as_ref().unwrap();
    assert_eq!(b.dominant, "servo");
    assert!(b.geometry.tip_error_max < 1e-12, "{:?}", b.geometry);
    assert!((b.servo.tip_error_max - b.all.tip_error_max).abs() < 1e-12);
    assert!((b.servo.tip_error_rms - b.all.tip_error_rms).abs() < 1e-12);
    assert_eq!(b.stretches.len(), 10);
    // Before the corner the lagging tip stays on the path; the stretch of the corner
    // holds the largest error.
    assert!(b.stretches[0].tip_error_max.all < 1e-12);
    assert!(b.stretches.iter().all(|s| s.dominant == "servo"));
    let text = d.to_string();
    assert!(
        text.starts_with(
            "4000 samples, 3.999 s, command path 399.900 mm (servo + geometry) → pred.csv\n"
        ),
        "{text}"
    );
    assert!(text.contains("\n  dominant overall: servo\n"), "{text}");
    assert!(text.ends_with("plot → plots/path.svg\n"), "{text}");
    // One line per stretch after the stretch header.
    let after = text.split("dominant\n").nth(1).unwrap();
    assert_eq!(after.lines().count(), 10 + 1);
    let back: TwinPredictDoc =
        serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
    assert_eq!(back, d);
    // Without breakdown and plots those keys are absent.
    let v = serde_json::to_value(TwinPredictDoc::new(&servo, "p.csv", None, &[])).unwrap();
    assert!(v.get("breakdown").is_none() && v.get("plots").is_none());
    assert_eq!(v["sources"], "servo");
}

/// `Par::Seq` (the calling thread only) and the parallel path (two threads)
/// predict bit-identical samples and summaries, over more than one chunk of
/// kinematics and with servos and geometric errors.
#[test]
fn sequential_and_parallel_runs_are_bit_identical() {
    let mut m = example("ac-trunnion-with-errors.toml");
    for (a, s) in m.axes.iter_mut().zip(five_servos()) {
        a.servo = Some(s);
    }
    let n = 3 * pipeline::CHUNK + 17;
    let qs: Vec<f64> = (0..n)
        .flat_map(|k| {
            let t = k as f64 * 0.001;
            [
                60.0 * (0.7 * t).sin(),
                50.0 * (0.9 * t + 1.0).sin(),
                30.0 * (1.1 * t).cos(),
                25.0 * (0.5 * t).sin(),
                120.0 * (0.3 * t).sin(),
            ]
        })
        .collect();
    let twin = Twin::new(&m, Sources::All).unwrap();
    let seq = twin
        .clone()
        .with_par(crate::par::Par::Seq)
        .predict_slice(0.0, 0.001, &qs)
        .unwrap();
    let par = crate::par::install(crate::par::Par::rayon(2), || {
        twin.predict_slice(0.0, 0.001, &qs).unwrap()
    });
    assert_eq!(seq.0.len(), n);
    assert_eq!(format!("{seq:?}"), format!("{par:?}"));
}

/// `run` on CSV commands: a constant positioning error EXX = c across a
/// move along Y gives ε_p = |c| on every row (closed form); the breakdown
/// puts it all on the geometry, the three plots are drawn and every row
/// reaches the sink in the order of the PRED.csv columns.
#[test]
fn run_streams_rows_and_returns_the_document_with_breakdown_and_plots() {
    let c = 0.003;
    let mut m = xyz();
    m.axes[0].errors.pdge[0] = Some(ErrorFunction::Constant(c));
    let mut text = String::from("t_s,X,Y,Z\n");
    for k in 0..200 {
        text.push_str(&format!("{},5,{},1\n", k as f64 * 0.001, 0.05 * k as f64));
    }
    let mut opens = 0;
    let mut rows = Vec::new();
    let options = PredictOptions {
        breakdown: true,
        plot: true,
        out: "pred.csv".into(),
        ..Default::default()
    };
    let r = run(
        &m,
        Commands::Csv {
            path: Path::new("cmd.csv"),
        },
        || {
            opens += 1;
            Ok(text.as_bytes())
        },
        &options,
        |s| {
            rows.push(pred_row(s));
            Ok(())
        },
        &mut |_, _| {},
    )
    .unwrap();
    // The run, then servo alone and geometry alone.
    assert_eq!(opens, 3);
    assert_eq!(rows.len(), 200);
    let col = |name: &str| {
        crate::report::twin::COLUMNS
            .iter()
            .position(|c| *c == name)
            .unwrap()
    };
    assert_eq!(rows[7][col("t_s")], 0.007);
    assert!((rows[7][col("y_cmd")] - 0.35).abs() < 1e-12);
    assert!(rows.iter().all(|r| (r[col("tip_error")] - c).abs() < 1e-12));
    assert!((r.doc.tip_error_max - c).abs() < 1e-12);
    assert_eq!((r.doc.out.as_str(), r.doc.samples), ("pred.csv", 200));
    assert_eq!(r.doc.breakdown.as_ref().unwrap().dominant, "geometry");
    assert_eq!(
        r.plots.iter().map(|p| p.0).collect::<Vec<_>>(),
        PLOT_FILES.to_vec()
    );
    assert!(r.plots.iter().all(|p| p.1.starts_with("<svg")));
}
