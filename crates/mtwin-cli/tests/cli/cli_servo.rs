//! `mtwin servo …` ([R5] in docs/references.md) end to end through the binary: a
//! known second-order axis → simulated excitation log → fit → the fitted
//! model reproduces a held-out command; the fitted file works as `[axes.servo]`.

use crate::common::*;

use std::path::Path;

const TS: f64 = 0.001;

/// A discrete second-order axis with unit static gain: poles r·e^{±jθ}
/// (r = 0.95, θ = 0.05 rad at 1 kHz: about 8 Hz, damping ≈ 0.7), one sample
/// of delay, `B(1) = A(1)` split evenly over `b_0, b_1`.
fn truth() -> ([f64; 3], [f64; 2]) {
    let (r, th) = (0.95f64, 0.05f64);
    let a = [1.0, -2.0 * r * th.cos(), r * r];
    let g = a.iter().sum::<f64>();
    (a, [0.5 * g, 0.5 * g])
}

fn truth_toml() -> String {
    let (a, b) = truth();
    format!(
        "ts = {TS:?}\nb = [{:?}, {:?}]\na = [{:?}, {:?}, {:?}]\nnk = 1\n",
        b[0], b[1], a[0], a[1], a[2]
    )
}

/// The truth's difference equation written out by hand, on deviations from u(0).
fn truth_response(u: &[f64]) -> Vec<f64> {
    let (a, b) = truth();
    let d: Vec<f64> = u.iter().map(|v| v - u[0]).collect();
    let mut y = vec![0.0; u.len()];
    for k in 0..u.len() {
        let at = |s: &[f64], i: usize| if k >= i { s[k - i] } else { 0.0 };
        y[k] = -a[1] * at(&y, 1) - a[2] * at(&y, 2) + b[0] * at(&d, 1) + b[1] * at(&d, 2);
    }
    y.iter().map(|v| v + u[0]).collect()
}

/// Excitation like `servo excitation`: moves at 50 mm/s to ±A of growing
/// amplitude around 10 mm, each followed by a 0.1 s dwell.
fn excitation_commands() -> Vec<f64> {
    let (centre, v) = (10.0, 50.0 * TS);
    let mut u = vec![centre; 100];
    let mut pos = centre;
    for level in 1..=4 {
        let amp = 5.0 * level as f64;
        for target in [centre + amp, centre - amp, centre] {
            while (target - pos).abs() > v {
                pos += v * (target - pos).signum();
                u.push(pos);
            }
            pos = target;
            u.extend(std::iter::repeat_n(pos, 100));
        }
    }
    u
}

/// A held-out command: a 2 mm sine sweep from 0.5 to 12 Hz over 2 s.
fn sweep_commands() -> Vec<f64> {
    (0..2000)
        .map(|k| {
            let t = k as f64 * TS;
            let f = 0.5 + 11.5 * t / 2.0;
            -30.0 + 2.0 * (2.0 * std::f64::consts::PI * f * t).sin()
        })
        .collect()
}

fn commands_csv(u: &[f64]) -> String {
    let mut s = String::from("t_s,command_mm\n");
    for (k, v) in u.iter().enumerate() {
        s.push_str(&format!("{:?},{v}\n", k as f64 * TS));
    }
    s
}

fn read_log(path: &Path) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "t_s,command_mm,feedback_mm");
    lines
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [f[0], f[1], f[2]]
        })
        .collect()
}

fn simulate(dir: &Path, servo: &str, cmds: &str, out: &str, noise: &str, seed: &str) {
    let o = mtwin(
        dir,
        &[
            "servo",
            "simulate",
            "--servo",
            servo,
            "--commands",
            cmds,
            "--noise",
            noise,
            "--seed",
            seed,
            "--out",
            out,
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).is_empty());
    // With --format json: the library's `ServoSimulateDoc`.
    let o = mtwin(
        dir,
        &[
            "servo",
            "simulate",
            "--servo",
            servo,
            "--commands",
            cmds,
            "--noise",
            noise,
            "--seed",
            seed,
            "--out",
            out,
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let d: mtwin::sysid::ServoSimulateDoc =
        serde_json::from_str(&stdout(&o)).expect("stdout is a ServoSimulateDoc");
    assert_eq!(
        (d.out.as_str(), d.seed.to_string()),
        (out, seed.to_string())
    );
    assert!(d.samples > 1 && d.duration_s > 0.0);
}

#[test]
fn simulate_follows_the_difference_equation() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("truth.toml"), truth_toml()).unwrap();
    let u = sweep_commands();
    std::fs::write(p.join("cmd.csv"), commands_csv(&u)).unwrap();
    simulate(p, "truth.toml", "cmd.csv", "log.csv", "0", "0");
    let log = read_log(&p.join("log.csv"));
    let want = truth_response(&u);
    assert_eq!(log.len(), u.len());
    for (k, (row, w)) in log.iter().zip(&want).enumerate() {
        assert_eq!(row[1], u[k]);
        assert!((row[2] - w).abs() < 1e-12, "sample {k}: {} vs {w}", row[2]);
    }
}

#[test]
fn fitted_servo_reproduces_a_held_out_command_within_1_um() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("truth.toml"), truth_toml()).unwrap();
    std::fs::write(p.join("exc.csv"), commands_csv(&excitation_commands())).unwrap();
    // 0.2 µm encoder noise: plain ARX least squares is biased by it (several
    // µm on the held-out sweep for this slow axis); the output-error
    // refinement of `servo fit` is not.
    simulate(p, "truth.toml", "exc.csv", "log.csv", "0.0002", "3");

    let o = mtwin(
        p,
        &[
            "servo",
            "fit",
            "--data",
            "log.csv",
            "--max-order",
            "3",
            "--feed",
            "3000",
            "--out",
            "servo.toml",
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&stdout(&o)).expect("stdout is one JSON document");
    let d: mtwin::sysid::ServoFitDoc =
        serde_json::from_str(&stdout(&o)).expect("stdout is a ServoFitDoc");
    assert_eq!(
        (d.feed_mm_min, d.out.as_deref()),
        (Some(3000.0), Some("servo.toml"))
    );
    assert!((v["ts"].as_f64().unwrap() - TS).abs() < 1e-12);
    assert_eq!(v["stable"], true);
    // Steady following error at 50 mm/s = velocity × group delay of the truth:
    // ts·(Σ (j+nk) b_j / B(1) − Σ i a_i / A(1)).
    let (a, b) = truth();
    let lag = TS
        * ((1.0 * b[0] + 2.0 * b[1]) / (b[0] + b[1]) - (a[1] + 2.0 * a[2]) / a.iter().sum::<f64>());
    let fe = v["following_error_at_feed"].as_f64().unwrap();
    assert!(
        (fe - 50.0 * lag).abs() < 0.02 * 50.0 * lag,
        "{fe} vs {}",
        50.0 * lag
    );

    // Held-out sweep: fitted vs true axis, both noise-free.
    std::fs::write(p.join("sweep.csv"), commands_csv(&sweep_commands())).unwrap();
    simulate(p, "servo.toml", "sweep.csv", "fitted.csv", "0", "0");
    let fitted = read_log(&p.join("fitted.csv"));
    let want = truth_response(&sweep_commands());
    let rms = (fitted
        .iter()
        .zip(&want)
        .map(|(f, w)| (f[2] - w).powi(2))
        .sum::<f64>()
        / want.len() as f64)
        .sqrt();
    assert!(rms < 0.001, "held-out simulation RMS {rms} mm\n{v}");
    // The sweep does excite the dynamics: the axis lags its command by far more than 1 µm.
    let lag_rms = (want
        .iter()
        .zip(sweep_commands())
        .map(|(w, u)| (w - u).powi(2))
        .sum::<f64>()
        / want.len() as f64)
        .sqrt();
    assert!(lag_rms > 0.05, "{lag_rms}");

    // The human summary names the orders, RMS, bandwidth and following error.
    // It is the text of the same fit's document.
    let o = mtwin(
        p,
        &[
            "servo",
            "fit",
            "--data",
            "log.csv",
            "--max-order",
            "3",
            "--feed",
            "3000",
            "--out",
            "servo2.toml",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let s = stdout(&o);
    for word in [
        "orders:",
        "simulation RMS",
        "bandwidth",
        "following error at F3000 mm/min",
    ] {
        assert!(s.contains(word), "`{word}` in:\n{s}");
    }
    let d2 = mtwin::sysid::ServoFitDoc {
        out: Some("servo2.toml".into()),
        ..d
    };
    assert_eq!(s, d2.to_string());
}

/// A time column of raw epoch nanoseconds (1.73e18, beyond the 1e15 bound on
/// other numbers) reads: `servo simulate` and `servo fit` take times in the
/// column's unit as written, so a servo model with `ts = 1e6` (1 ms in ns)
/// simulates on it, the log keeps the timestamps, and the fit finds the
/// sample period 1e6 and the truth's coefficients.
#[test]
fn epoch_nanosecond_time_column_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let ts_ns = 1e6;
    std::fs::write(
        p.join("truth.toml"),
        truth_toml().replace(&format!("ts = {TS:?}"), "ts = 1000000.0"),
    )
    .unwrap();
    let t0: u64 = 1_732_550_000_000_000_000;
    let u = excitation_commands();
    let mut csv = String::from("t_s,command_mm\n");
    for (k, v) in u.iter().enumerate() {
        csv.push_str(&format!("{},{v}\n", t0 + k as u64 * 1_000_000));
    }
    std::fs::write(p.join("exc.csv"), csv).unwrap();
    simulate(p, "truth.toml", "exc.csv", "log.csv", "0", "1");
    let log = read_log(&p.join("log.csv"));
    assert_eq!(log.len(), u.len());
    for (k, row) in log.iter().enumerate() {
        // The f64 nearest each timestamp (spacing 256 ns at 1.7e18).
        assert_eq!(row[0], (t0 + k as u64 * 1_000_000) as f64);
    }
    let o = mtwin(
        p,
        &[
            "servo",
            "fit",
            "--data",
            "log.csv",
            "--max-order",
            "2",
            "--max-delay",
            "1",
            "--out",
            "servo.toml",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let fitted = mtwin::sysid::read_servo_toml(&p.join("servo.toml")).unwrap();
    // Timestamps are f64 to within 128 ns: the median interval is 1e6 ± 256.
    assert!((fitted.ts() - ts_ns).abs() <= 256.0, "ts = {}", fitted.ts());
    let (a, _) = truth();
    assert_eq!(fitted.a().len(), 3, "{:?}", fitted.a());
    for (got, want) in fitted.a().iter().zip(a) {
        assert!((got - want).abs() < 1e-6, "a = {:?}", fitted.a());
    }
}

#[test]
fn fitted_file_is_a_valid_axes_servo_table() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("truth.toml"), truth_toml()).unwrap();
    std::fs::write(p.join("exc.csv"), commands_csv(&excitation_commands())).unwrap();
    simulate(p, "truth.toml", "exc.csv", "log.csv", "0.0002", "4");
    let o = mtwin(
        p,
        &["servo", "fit", "--data", "log.csv", "--out", "servo.toml"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // The last axis of the example (C) gets the fitted servo.
    let machine = std::fs::read_to_string(example("ac-trunnion.toml")).unwrap();
    let servo = std::fs::read_to_string(p.join("servo.toml")).unwrap();
    std::fs::write(
        p.join("m.toml"),
        format!("{machine}\n[axes.servo]\n{servo}"),
    )
    .unwrap();
    let o = mtwin(p, &["model", "check", "m.toml", "--format", "json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let axes = v["axes"].as_array().unwrap();
    assert_eq!(axes.last().unwrap()["name"], "C");
    assert_eq!(axes.last().unwrap()["servo"], true);
    assert_eq!(axes[0]["servo"], false);
}

#[test]
fn bad_input_exits_1_names_the_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let mut log = String::from("t_s,command_mm,feedback_mm\n");
    for k in 0..50 {
        let t = if k == 20 { 0.0185 } else { k as f64 * TS };
        log.push_str(&format!("{t},{k},{k}\n"));
    }
    std::fs::write(p.join("back.csv"), &log).unwrap();
    // Row 20 (line 22) goes back in time.
    expect_failure(
        p,
        &[
            "servo", "fit", "--data", "back.csv", "--out", "s.toml", "--format", "json",
        ],
        "back.csv:22",
        "s.toml",
    );
    std::fs::write(p.join("nofb.csv"), "t_s,command_mm\n0,0\n0.001,1\n").unwrap();
    expect_failure(
        p,
        &["servo", "fit", "--data", "nofb.csv", "--out", "s.toml"],
        "feedback_mm",
        "s.toml",
    );
    std::fs::write(p.join("truth.toml"), truth_toml()).unwrap();
    std::fs::write(p.join("cmd.csv"), "t_s,command_mm\n0,0\n0.001,1\n0.003,2\n").unwrap();
    expect_failure(
        p,
        &[
            "servo",
            "simulate",
            "--servo",
            "truth.toml",
            "--commands",
            "cmd.csv",
            "--out",
            "l.csv",
        ],
        "cmd.csv:4",
        "l.csv",
    );
    // `--axis` names a column the file does not have.
    expect_failure(
        p,
        &[
            "servo",
            "simulate",
            "--servo",
            "truth.toml",
            "--commands",
            "cmd.csv",
            "--axis",
            "Q",
            "--out",
            "l.csv",
        ],
        "Q",
        "l.csv",
    );
    std::fs::write(
        p.join("bad.toml"),
        "ts = 0.001\nb = [1.0]\na = [2.0, 0.5]\n",
    )
    .unwrap();
    expect_failure(
        p,
        &[
            "servo",
            "simulate",
            "--servo",
            "bad.toml",
            "--commands",
            "cmd.csv",
            "--out",
            "l.csv",
        ],
        "bad.toml:3",
        "l.csv",
    );
    expect_failure(
        p,
        &[
            "servo",
            "excitation",
            "--axis",
            "X",
            "--travel",
            "100,-100",
            "--feed",
            "3000",
            "--out",
            "e.nc",
        ],
        "--travel",
        "e.nc",
    );
}

#[test]
fn excitation_program_stays_inside_the_travel() {
    let dir = tempfile::tempdir().unwrap();
    let (d, _) = json_round_trip::<mtwin::sysid::ServoExcitationDoc>(
        dir.path(),
        &[
            "servo",
            "excitation",
            "--axis",
            "X",
            "--travel",
            "-100,100",
            "--feed",
            "3000",
            "--out",
            "exc.nc",
        ],
    );
    assert_eq!((d.axis.as_str(), d.travel), ("X", [-100.0, 100.0]));
    let text = std::fs::read_to_string(dir.path().join("exc.nc")).unwrap();
    assert_eq!(d.lines, text.lines().count());
    let xs: Vec<f64> = text
        .lines()
        .filter(|l| l.starts_with("G1 "))
        .filter_map(|l| l.split_whitespace().find(|w| w.starts_with('X')))
        .map(|w| w[1..].parse().unwrap())
        .collect();
    // Five levels of ±20, ±40, … ±100 around 0, back to 0.
    assert_eq!(
        xs,
        vec![
            0.0, 20.0, -20.0, 40.0, -40.0, 60.0, -60.0, 80.0, -80.0, 100.0, -100.0, 0.0
        ]
    );
    assert!(text.contains("F3000"));
}

#[test]
fn docs_walkthrough_runs() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let ran = run_doc("servo.md", p);
    assert_eq!(ran.len(), 6, "{ran:?}");
    // The interpolated excitation visits ±100 mm.
    let cmd = read_log(&p.join("predicted.csv"));
    let max = cmd.iter().fold(0.0f64, |m, r| m.max(r[1].abs()));
    assert_eq!(max, 100.0);
    // The fitted servo, played through the excitation, follows the true axis
    // (the truth's difference equation written out here) within 1 µm RMS.
    let u: Vec<f64> = cmd.iter().map(|r| r[1]).collect();
    let (a, b) = ([1.0, -1.8976255, 0.9025], [0.00243725, 0.00243725]);
    let mut y = vec![0.0; u.len()];
    for k in 0..u.len() {
        let at = |s: &[f64], i: usize| if k >= i { s[k - i] - s[0] } else { 0.0 };
        let yd = |i: usize| if k >= i { y[k - i] - u[0] } else { 0.0 };
        y[k] = u[0] - a[1] * yd(1) - a[2] * yd(2) + b[0] * at(&u, 1) + b[1] * at(&u, 2);
    }
    let rms = (cmd
        .iter()
        .zip(&y)
        .map(|(r, w)| (r[2] - w).powi(2))
        .sum::<f64>()
        / y.len() as f64)
        .sqrt();
    assert!(rms < 0.001, "{rms}");
}
