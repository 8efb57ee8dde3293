//! Trajectory planners (`exact-stop`, `linuxcnc`) against closed forms and
//! properties: collinear blocks run as one move, G64 corners stay within P,
//! G61/G61.1 stop at corners, limits hold at every sample, look-ahead
//! reaches the feed, time is linear in the program length, and the boat
//! under LinuxCNC's limits.

use mtwin::gcode::plan::{PlanOptions, Planner};
use mtwin::gcode::{InterpolateOptions, InterpolationSummary, interpolate};
use mtwin::model::{AxisKind, Machine};
use proptest::prelude::*;

/// Cartesian XYZ machine, `vmax` mm/s and `amax` mm/s² on every axis,
/// trajectory limit `v_traj` mm/s.
fn xyz(vmax: f64, amax: f64, v_traj: f64) -> Machine {
    let mut m = mtwin::examples::xyz(1000.0);
    for a in &mut m.axes {
        a.max_velocity = Some(vmax);
        a.max_acceleration = Some(amax);
    }
    m.rapid_feed = 60.0 * v_traj;
    m
}

type Samples = Vec<(f64, Vec<f64>)>;

fn run(prog: &str, m: &Machine, planner: Planner, ts: f64) -> (Samples, InterpolationSummary) {
    let mut opts = InterpolateOptions::new(ts);
    opts.plan = PlanOptions::new(planner);
    let mut out = Vec::new();
    let s = interpolate(prog.as_bytes(), m, &opts, |s| {
        out.push((s.t, s.q.to_vec()));
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{e}"));
    (out, s)
}

fn time(prog: &str, m: &Machine, planner: Planner) -> f64 {
    run(prog, m, planner, 0.01).1.duration
}

/// Largest sample-to-sample speed along the path, mm/s.
fn peak_speed(s: &Samples, ts: f64) -> f64 {
    s.windows(2)
        .map(|w| {
            let d: f64 = (0..3).map(|i| (w[1].1[i] - w[0].1[i]).powi(2)).sum();
            d.sqrt() / ts
        })
        .fold(0.0, f64::max)
}

#[test]
fn collinear_blocks_run_as_one_move() {
    // 10 blocks of 10 mm along X at 600 mm/min (10 mm/s), a = 300 mm/s².
    let m = xyz(20.0, 300.0, 35.0);
    let mut prog = String::from("G1 F600\n");
    for k in 1..=10 {
        prog.push_str(&format!("X{}\n", 10 * k));
    }
    let (v, a, l) = (10.0, 300.0, 100.0);
    // G61 (exact path) and G61.1 never blend; collinear blocks join
    // tangentially under G61: one trapezoid L/v + v/a.
    let t = time(&format!("G61\n{prog}"), &m, Planner::Linuxcnc);
    assert!((t - (l / v + v / a)).abs() < 1e-9, "G61: {t}");
    // Under G64 the last block keeps the blend term and decelerates at a/2:
    // L/v + v/(2a) + v/(2·a/2).
    let t = time(&format!("G64\n{prog}"), &m, Planner::Linuxcnc);
    let want = l / v + v / (2.0 * a) + v / a;
    assert!((t - want).abs() < 1e-9, "G64: {t} vs {want}");
    // Exact stop at every block: 10 × (10/v + v/a).
    let t = time(&format!("G61.1\n{prog}"), &m, Planner::Linuxcnc);
    assert!((t - 10.0 * (10.0 / v + v / a)).abs() < 1e-9, "G61.1: {t}");
    let t = time(&prog, &m, Planner::ExactStop);
    assert!(
        (t - 10.0 * (10.0 / v + v / a)).abs() < 1e-9,
        "exact-stop: {t}"
    );
}

/// Distance from `p` to the polyline `pts` (XY).
fn to_polyline(p: [f64; 2], pts: &[[f64; 2]]) -> f64 {
    pts.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let t = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]))
                .clamp(0.0, 1.0);
            (p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1])
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn g64_corner_stays_within_p() {
    let m = xyz(20.0, 300.0, 35.0);
    let pts = [[0.0, 0.0], [40.0, 0.0], [40.0, 40.0], [0.0, 40.0]];
    for p in [0.01, 0.05, 0.5] {
        let prog = format!("G64 P{p}\nG1 X40 F1200\nY40\nX0\n");
        let (s, _) = run(&prog, &m, Planner::Linuxcnc, 0.0005);
        let worst = s
            .iter()
            .map(|(_, q)| to_polyline([q[0], q[1]], &pts))
            .fold(0.0, f64::max);
        assert!(worst <= p + 1e-9, "P{p}: {worst}");
        // It does cut the corner (no stop there).
        assert!(worst > 0.1 * p, "P{p}: {worst}");
        let near = s
            .iter()
            .map(|(_, q)| (q[0] - 40.0).hypot(q[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(near > 1e-6, "P{p} passes the corner exactly");
    }
}

#[test]
fn g61_stops_at_corners() {
    let m = xyz(20.0, 300.0, 35.0);
    let ts = 0.001;
    for mode in ["G61", "G61.1"] {
        let prog = format!("{mode}\nG1 X40 F1200\nY40\n");
        let (s, _) = run(&prog, &m, Planner::Linuxcnc, ts);
        // The sample nearest the corner is within a·ts² of it and the
        // speed there is at most 2·a·ts.
        let (i, d) = s
            .iter()
            .enumerate()
            .map(|(i, (_, q))| (i, (q[0] - 40.0).hypot(q[1])))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!(d <= 300.0 * ts * ts, "{mode}: {d}");
        let v = (s[i + 1].1[1] - s[i - 1].1[1]).hypot(s[i + 1].1[0] - s[i - 1].1[0]) / (2.0 * ts);
        assert!(v <= 2.0 * 300.0 * ts, "{mode}: corner speed {v}");
    }
}

#[test]
fn arcs_in_the_three_planes_take_the_same_time() {
    // Equal axis limits: the same arc in G17, G18 and G19 takes the same time.
    let m = xyz(20.0, 300.0, 35.0);
    let progs = [
        "G17 G1 X10 F900\nG3 X-10 Y0 I-10 J0\nG2 X10 Y0 I10 J0\n",
        "G18 G1 Z10 F900\nG3 Z-10 X0 K-10 I0\nG2 Z10 X0 K10 I0\n",
        "G19 G1 Y10 F900\nG3 Y-10 Z0 J-10 K0\nG2 Y10 Z0 J10 K0\n",
    ];
    for planner in [Planner::Linuxcnc, Planner::ExactStop] {
        let t: Vec<f64> = progs.iter().map(|p| time(p, &m, planner)).collect();
        assert!(
            (t[0] - t[1]).abs() < 1e-9 && (t[0] - t[2]).abs() < 1e-9,
            "{t:?}"
        );
        // Never faster than the path at the feed.
        let at_feed = (10.0 + 2.0 * std::f64::consts::PI * 10.0) / 15.0;
        assert!(t[0] > at_feed, "{planner}: {} vs {at_feed}", t[0]);
    }
}

#[test]
fn feed_modes_that_mean_the_same_speed_take_the_same_time() {
    // 30 mm at 600 mm/min: G94 F600, G93 F20 (3 s), G95 F0.1 at S6000.
    let m = xyz(20.0, 300.0, 35.0);
    for planner in [Planner::Linuxcnc, Planner::ExactStop] {
        let a = time("G94 G1 X30 F600\n", &m, planner);
        let b = time("G93 G1 X30 F20\n", &m, planner);
        let c = time("S6000 M3\nG95 G1 X30 F0.1\n", &m, planner);
        assert!((a - b).abs() < 1e-9 && (a - c).abs() < 1e-9, "{a} {b} {c}");
        // 3 s at 10 mm/s plus the time lost ramping: v/a (at a/2 to stop under G64).
        assert!(
            a > 3.0 && a < 3.0 + 2.0 * 10.0 / 300.0 + 1e-9,
            "{planner}: {a}"
        );
    }
}

#[test]
fn feed_override_scales_the_feed() {
    let m = xyz(20.0, 300.0, 35.0);
    let mut opts = InterpolateOptions::new(0.01);
    opts.plan = PlanOptions::new(Planner::Linuxcnc);
    opts.plan.feed_override = 0.5;
    let s = interpolate(b"G61 G1 X30 F600\n".as_slice(), &m, &opts, |_| Ok(())).unwrap();
    // 30 mm at 5 mm/s: 6 s + 5/300 s.
    assert!(
        (s.duration - (6.0 + 5.0 / 300.0)).abs() < 1e-9,
        "{}",
        s.duration
    );
}

#[test]
fn lookahead_reaches_the_feed_on_short_collinear_blocks() {
    // 200 blocks of 0.5 mm at 15 mm/s: rest to rest each peaks at √(a·L) = 12.2 mm/s.
    let m = xyz(20.0, 300.0, 35.0);
    let mut prog = String::from("G1 F900\n");
    for k in 1..=200 {
        prog.push_str(&format!("X{}\n", 0.5 * k as f64));
    }
    let ts = 0.001;
    let (s, _) = run(&prog, &m, Planner::Linuxcnc, ts);
    let v = peak_speed(&s, ts);
    assert!((v - 15.0).abs() < 1e-6, "linuxcnc peak {v}");
    let (s, _) = run(&prog, &m, Planner::ExactStop, ts);
    let v = peak_speed(&s, ts);
    assert!(v < (300.0f64 * 0.5).sqrt() + 1e-6, "exact-stop peak {v}");
}

#[test]
fn time_is_linear_in_the_program_length() {
    let m = xyz(20.0, 300.0, 35.0);
    let part = "G1 X20 Y0 F900\nX20 Y20\nG2 X0 Y20 I-10 J0\nG1 X0 Y0\nG0 Z5\nG0 Z0\n";
    for planner in [Planner::Linuxcnc, Planner::ExactStop] {
        let t1 = time(&format!("G64 P0.02\n{}", part.repeat(20)), &m, planner);
        let t2 = time(&format!("G64 P0.02\n{}", part.repeat(40)), &m, planner);
        assert!((t2 / t1 - 2.0).abs() < 0.02, "{planner}: {t1} {t2}");
    }
}

/// Per-axis finite differences of the samples within `vmax`, `amax`.
fn check_limits(s: &Samples, ts: f64, vmax: f64, amax: f64) -> Result<(), TestCaseError> {
    for w in s.windows(3) {
        for i in 0..3 {
            let v = (w[1].1[i] - w[0].1[i]) / ts;
            prop_assert!(
                v.abs() <= vmax * (1.0 + 1e-6) + 1e-9,
                "v = {v} at {}",
                w[0].0
            );
            let a = (w[2].1[i] - 2.0 * w[1].1[i] + w[0].1[i]) / (ts * ts);
            prop_assert!(
                a.abs() <= amax * (1.0 + 1e-4) + 1e-6,
                "a = {a} at {}",
                w[0].0
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn limits_hold_at_every_sample(
        moves in prop::collection::vec(
            (-30.0f64..30.0, -30.0f64..30.0, -5.0f64..5.0, 100.0f64..3000.0, 0u8..4),
            2..12,
        ),
        p in 0.001f64..0.5,
    ) {
        let (vmax, amax, ts) = (20.0, 300.0, 0.001);
        let m = xyz(vmax, amax, 35.0);
        let mut prog = format!("G64 P{p:.4}\n");
        for (x, y, z, f, kind) in &moves {
            let mode = match kind {
                0 => "G61 ",
                1 => "G61.1 ",
                _ => "G64 ",
            };
            let motion = if *kind == 3 { "G0" } else { "G1" };
            prog.push_str(&format!("{mode}{motion} X{x:.3} Y{y:.3} Z{z:.3} F{f:.1}\n"));
        }
        for planner in [Planner::Linuxcnc, Planner::ExactStop] {
            let (s, _) = run(&prog, &m, planner, ts);
            check_limits(&s, ts, vmax, amax)?;
        }
    }
}

/// A corpus program under `--planner linuxcnc` with the limits of
/// LinuxCNC's xyzac-trt simulation (X Y Z 20 mm/s, 300 mm/s²; A C 30 deg/s,
/// 300 deg/s², C unlimited; trajectory 35 mm/s; its `MAX_FEED_OVERRIDE` 2
/// and simulated spindle ramp): mtwin's time relative to `reference`
/// (LinuxCNC 2.9's simulator, docs/linuxcnc.md), minus one.
fn corpus_under_linuxcnc_limits(name: &str, reference: f64) -> Option<f64> {
    let dir = crate::shared::shared_dir("corpus/gcode/linuxcnc")?;
    let text = std::fs::read_to_string(dir.join(name)).unwrap();
    let mut m = crate::common::linuxcnc_trunnion();
    for a in m.axes.iter_mut() {
        if a.kind != AxisKind::Linear {
            a.travel = [-36000.0, 36000.0];
        }
    }
    let mut opts = InterpolateOptions::new(1e6);
    opts.plan = PlanOptions::new(Planner::Linuxcnc);
    opts.plan.max_feed_override = 2.0;
    opts.plan.spindle_accel = 5000.0;
    opts.check_travel = false;
    let s = interpolate(text.as_bytes(), &m, &opts, |_| Ok(())).unwrap();
    let rel = s.duration / reference - 1.0;
    eprintln!(
        "{name} linuxcnc: {:.3} s vs LinuxCNC {reference} s ({:+.2} %)",
        s.duration,
        100.0 * rel
    );
    Some(rel)
}

/// The boat: LinuxCNC 2.9's simulator runs it in 562.952 s.
#[test]
fn boat_under_linuxcnc_limits() {
    if let Some(rel) = corpus_under_linuxcnc_limits("boat-xyzac.ngc", 562.952) {
        assert!(rel.abs() < BOAT_TOLERANCE, "{:+.2} %", 100.0 * rel);
    }
}

/// The impeller: LinuxCNC 2.9's simulator runs it in 1163.001 s.
#[test]
fn impeller_under_linuxcnc_limits() {
    if let Some(rel) = corpus_under_linuxcnc_limits("impeller-7bl-xyzac.ngc", 1163.001) {
        assert!(rel.abs() < IMPELLER_TOLERANCE, "{:+.2} %", 100.0 * rel);
    }
}

/// Relative tolerance of the boat's time against LinuxCNC's: the motion
/// issue's 1 % (measured +0.71 %, docs/gcode.md).
const BOAT_TOLERANCE: f64 = 0.01;

/// Relative tolerance of the impeller's time against LinuxCNC's: the
/// motion issue's 1 % (measured +0.40 %, docs/gcode.md).
const IMPELLER_TOLERANCE: f64 = 0.01;
