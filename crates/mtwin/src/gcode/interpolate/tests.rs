use nalgebra::Vector3;
use std::path::{Path as FsPath, PathBuf};

use super::*;
use crate::gcode::{StatsOptions, stats};
use crate::model::read_machine;

/// A Cartesian XYZ machine with the given limits on every axis.
fn xyz(vmax: Option<f64>, amax: Option<f64>) -> Machine {
    let mut m = crate::examples::xyz(1000.0);
    for a in &mut m.axes {
        a.max_velocity = vmax;
        a.max_acceleration = amax;
    }
    m
}

type Samples = Vec<(f64, Vec<f64>, u64)>;

fn run(
    program: &str,
    machine: &Machine,
    opts: &InterpolateOptions,
) -> Result<(Samples, InterpolationSummary), InterpolateError> {
    let mut out = Vec::new();
    let summary = interpolate(program.as_bytes(), machine, opts, |s| {
        out.push((s.t, s.q.to_vec(), s.line));
        Ok(())
    })?;
    Ok((out, summary))
}

/// The sample count of a move is checked before its samples are made:
/// 5 s at ts = 1e-12 s is 5e12 samples, refused with nothing emitted; at
/// a bound of 5001 the 5 s move (samples 0..4999, then the last) passes
/// and at 4999 it does not.
#[test]
fn sample_count_is_bounded_before_sampling() {
    let m = xyz(None, None);
    let opts = InterpolateOptions::new(1e-12);
    let mut n = 0u64;
    let r = interpolate(b"G1 X30 Y40 F600\n".as_slice(), &m, &opts, |_| {
        n += 1;
        Ok(())
    });
    assert!(
        matches!(r, Err(InterpolateError::TooManySamples { line: 1, .. })),
        "{r:?}"
    );
    assert_eq!(n, 0);
    let mut opts = InterpolateOptions::new(0.001);
    opts.max_samples = 5001;
    assert_eq!(run("G1 X30 Y40 F600\n", &m, &opts).unwrap().0.len(), 5001);
    opts.max_samples = 4999;
    assert!(matches!(
        run("G1 X30 Y40 F600\n", &m, &opts),
        Err(InterpolateError::TooManySamples { .. })
    ));
    // A dwell of 1e8 s (1e11 samples) is refused, not run.
    let opts = InterpolateOptions::new(0.001);
    assert!(matches!(
        run("G4 P100000000\n", &m, &opts),
        Err(InterpolateError::TooManySamples { .. })
    ));
}

#[test]
fn straight_feed_takes_length_over_feed() {
    let m = xyz(None, None);
    let opts = InterpolateOptions::new(0.001);
    let (s, sum) = run("G1 X30 Y40 F600\n", &m, &opts).unwrap();
    // 50 mm at 600 mm/min = 5 s.
    assert!((sum.duration - 5.0).abs() < 1e-12);
    assert_eq!(s.len(), 5001);
    for (k, (t, q, _)) in s.iter().enumerate() {
        assert_eq!(*t, k as f64 * 0.001);
        // Constant speed 10 mm/s along (3, 4, 0)/5.
        let along = 10.0 * t;
        assert!((q[0] - 0.6 * along).abs() < 1e-9, "{t} {q:?}");
        assert!((q[1] - 0.8 * along).abs() < 1e-9);
        assert_eq!(q[2], 0.0);
    }
    assert_eq!(s.last().unwrap().1, vec![30.0, 40.0, 0.0]);
}

#[test]
fn arc_keeps_its_radius() {
    let m = xyz(Some(100.0), Some(500.0));
    let opts = InterpolateOptions::new(0.001);
    let prog = "G0 X10 Y0\nG2 X-10 Y0 I-10 J0 F1200\n";
    let (s, _) = run(prog, &m, &opts).unwrap();
    let arc: Vec<_> = s.iter().filter(|x| x.2 == 2).collect();
    assert!(arc.len() > 100);
    for (_, q, _) in arc {
        assert!((q[0].hypot(q[1]) - 10.0).abs() < 1e-9);
        assert!(q[1] <= 1e-12, "G2 from +X to -X passes through -Y");
    }
}

fn assert_limits(s: &[(f64, Vec<f64>, u64)], ts: f64, vmax: f64, amax: f64) {
    for w in s.windows(3) {
        for i in 0..3 {
            let v = (w[1].1[i] - w[0].1[i]) / ts;
            assert!(v.abs() <= vmax * (1.0 + 1e-9), "v = {v}");
            let a = (w[2].1[i] - 2.0 * w[1].1[i] + w[0].1[i]) / (ts * ts);
            assert!(a.abs() <= amax * (1.0 + 1e-6), "a = {a}");
        }
    }
}

#[test]
fn trapezoid_respects_axis_limits() {
    let (vmax, amax, ts) = (50.0, 200.0, 0.001);
    let m = xyz(Some(vmax), Some(amax));
    let opts = InterpolateOptions::new(ts);
    // Single axis: T = L/v + v/a = 100/50 + 50/200 = 2.25 s.
    let (s, sum) = run("G1 X100 F100000\n", &m, &opts).unwrap();
    assert!((sum.duration - 2.25).abs() < 1e-12);
    assert_limits(&s, ts, vmax, amax);
    // Diagonal and arcs, including a fast full circle.
    let prog = "G1 X100 Y50 F100000\nG3 X100 Y50 I-20 J0 F100000\nG2 X60 Y10 R40\n";
    let (s, _) = run(prog, &m, &opts).unwrap();
    assert_limits(&s, ts, vmax, amax);
}

/// The `(line, end)` times of the planners: closed-form trapezoids under
/// `exact-stop`; under every planner non-decreasing per line in time,
/// the last one the program's duration.
#[test]
fn line_end_times_follow_the_planners() {
    let m = xyz(Some(50.0), Some(200.0));
    let mut m_jerk = m.clone();
    for a in &mut m_jerk.axes {
        a.max_jerk = Some(4000.0);
    }
    // Line 2: 100 mm, 100/50 + 50/200 = 2.25 s; line 3: a dwell of
    // 0.5 s; line 4: 10 mm at 20 mm/s, 10/20 + 20/200 = 0.6 s.
    let prog = "G21 G90 G64\nG1 X100 F6000\nG4 P0.5\nG1 Y10 F1200\nM2\n";
    let opts = InterpolateOptions::new(0.001);
    let t = line_end_times(prog.as_bytes(), &m, &opts).unwrap();
    let by = t.by_line();
    assert!((by[&2] - 2.25).abs() < 1e-12, "{by:?}");
    assert!((by[&3] - 2.75).abs() < 1e-12, "{by:?}");
    assert!((by[&4] - 3.35).abs() < 1e-12, "{by:?}");
    assert!((t.duration - 3.35).abs() < 1e-12);
    for p in [Planner::Linuxcnc, Planner::Jerk] {
        let mut o = opts.clone();
        o.plan = PlanOptions::new(p);
        let machine = if p == Planner::Jerk { &m_jerk } else { &m };
        let t = line_end_times(prog.as_bytes(), machine, &o).unwrap();
        let by = t.by_line();
        assert!(by[&2] < by[&3] && by[&3] < by[&4], "{p}: {by:?}");
        // The dwell lasts its 0.5 s after the stop.
        assert!((by[&3] - by[&2] - 0.5).abs() < 1e-9, "{p}: {by:?}");
        assert!((by[&4] - t.duration).abs() < 1e-9, "{p}: {by:?}");
        let d = interpolate(prog.as_bytes(), machine, &o, |_| Ok(())).unwrap();
        assert!((d.duration - t.duration).abs() < 1e-12);
    }
}

/// A coolant command between two blended moves stops the machine at the
/// corner under `linuxcnc` (standing `io_wait` there) and `jerk`; the
/// corner is blended without it.
#[test]
fn coolant_commands_stop_the_blending() {
    let m = {
        let mut m = xyz(Some(50.0), Some(200.0));
        for a in &mut m.axes {
            a.max_jerk = Some(4000.0);
        }
        m
    };
    let corner = |prog: &str, p: Planner| -> (bool, f64) {
        let mut o = InterpolateOptions::new(0.001);
        o.plan = PlanOptions::new(p);
        let (s, sum) = run(prog, &m, &o).unwrap();
        // Samples standing at the corner (X20 Y0).
        let at = s
            .iter()
            .filter(|x| (x.1[0] - 20.0).abs() < 1e-5 && x.1[1].abs() < 1e-5)
            .count();
        (at > 0, sum.duration)
    };
    let plain = "G21 G90 G64 P0.5\nG1 X20 F1200\nY20\nM2\n";
    let cool = "G21 G90 G64 P0.5\nG1 X20 F1200\nM8\nY20\nM2\n";
    for p in [Planner::Linuxcnc, Planner::Jerk] {
        let (through_plain, t_plain) = corner(plain, p);
        let (through_cool, t_cool) = corner(cool, p);
        assert!(!through_plain && through_cool, "{p}");
        assert!(t_cool > t_plain, "{p}: {t_cool} s against {t_plain} s");
    }
    // Under linuxcnc the machine stands io_wait at the corner: each of
    // the two 20 mm moves at 20 mm/s, rest to rest at half acceleration
    // (G64), takes 20/20 + 20/100 = 1.2 s.
    let (_, t) = corner(cool, Planner::Linuxcnc);
    let want = 2.0 * 1.2 + PlanOptions::default().io_wait;
    assert!((t - want).abs() < 1e-9, "{t} s against {want} s");
}

#[test]
fn rapid_dwell_and_inverse_time() {
    let m = xyz(None, None);
    let opts = InterpolateOptions::new(0.01);
    // 60 mm at 6000 mm/min = 0.6 s; dwell 1.5 s; G93 F30 = 2 s.
    let (_, sum) = run("G0 X60\nG4 P1.5\nG93 G1 X0 F30\n", &m, &opts).unwrap();
    assert!((sum.duration - 4.1).abs() < 1e-12);
    assert_eq!(sum.dwell_time, 1.5);
    assert_eq!(sum.moves, 2);
}

#[test]
fn offsets_add_to_program_coordinates() {
    let m = xyz(None, None);
    let mut opts = InterpolateOptions::new(0.1);
    opts.interp.work_offsets[0] = Axes([1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    // Unprogrammed axes stay where they are (machine 0 at the start).
    let (s, _) = run("G1 X10 F600\n", &m, &opts).unwrap();
    assert_eq!(s.last().unwrap().1, vec![11.0, 0.0, 0.0]);
    let (s, _) = run("G1 X10 Y0 Z0 F600\n", &m, &opts).unwrap();
    assert_eq!(s.last().unwrap().1, vec![11.0, 2.0, 3.0]);
}

#[test]
fn travel_and_missing_axes_are_reported() {
    let mut m = xyz(None, None);
    m.axes[0].travel = [-10.0, 10.0];
    let opts = InterpolateOptions::new(0.01);
    let e = run("G0 X5\nG1 X20 F600\n", &m, &opts).unwrap_err();
    assert!(
        matches!(e, InterpolateError::OutOfTravel { line: 2, ref axis, .. } if axis == "X"),
        "{e}"
    );
    let e = run("G0 A5\n", &m, &opts).unwrap_err();
    assert!(
        matches!(
            e,
            InterpolateError::MissingAxis {
                line: 1,
                letter: 'A'
            }
        ),
        "{e}"
    );
    let e = InterpolateOptions::new(0.0);
    assert!(matches!(
        Interpolator::new(&m, &e),
        Err(InterpolateError::Period(_))
    ));
}

fn trunnion() -> Machine {
    let p =
        FsPath::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/ac-trunnion.toml");
    read_machine(&p).unwrap()
}

/// Distance of `p` from the segment `a`–`b`.
fn off_line(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = b - a;
    let t = ((p - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
    (p - (a + d * t)).norm()
}

/// A TCP line with the rotary axes held moves every joint in proportion
/// (the joint path is affine in the path parameter), so its exact-stop
/// time must not depend on rounding: moving an end by 1e-12 mm (far below
/// the inverse kinematics' 1e-11 mm) changes the time by rounding only,
/// not by the halved acceleration of a curved joint path. The time is
/// also the closed-form trapezoid with every axis's full acceleration:
/// joint steps `d = 1.1·|Δq|` (the derivative margin), path speed
/// `v = min(1/T, vmax/d)`, acceleration `a = amax/d`.
#[test]
fn tcp_line_with_rotaries_held_is_timed_the_same_under_rounding_changes() {
    let m = trunnion();
    let kin = Kinematics::nominal(&m);
    let opts = InterpolateOptions::new(0.001);
    let start = "M428\nG0 X0 Y0 Z20 A-30 C45\nG4 P0.5\n";
    let ends = [
        (10.0, 5.0, 10.0),
        (-7.3, 12.9, 3.1),
        (0.1, -0.2, 19.7),
        (33.3, -21.7, 40.1),
    ];
    for &(x, y, z) in &ends {
        let prog = |dx: f64| format!("{start}G1 X{:.15} Y{y} Z{z} F600\n", x + dx);
        let t0 = run(&prog(0.0), &m, &opts).unwrap().1.duration;
        for dx in [1e-12, -1e-12, 2e-12] {
            let t1 = run(&prog(dx), &m, &opts).unwrap().1.duration;
            assert!(
                (t1 - t0).abs() < 1e-9,
                "end ({x}, {y}, {z}) moved by {dx} mm: {t0} s became {t1} s"
            );
        }
        // Closed form of the line's time from its joint ends: where the
        // dwell holds the machine, and the program's last sample.
        let (held, before) = run(start, &m, &opts).unwrap();
        let q0 = held.last().unwrap().1.clone();
        let q1 = run(&prog(0.0), &m, &opts)
            .unwrap()
            .0
            .last()
            .unwrap()
            .1
            .clone();
        let target = Vector3::new(x, y, z);
        assert!((kin.pose(&q1).tip - target).norm() < 1e-9);
        let length = (target - kin.pose(&q0).tip).norm();
        let seconds = length / 10.0;
        let (mut v, mut a) = (1.0 / seconds, f64::INFINITY);
        for (i, ax) in m.axes.iter().enumerate() {
            let d = 1.1 * (q1[i] - q0[i]).abs();
            if d > 0.0 {
                v = v.min(ax.max_velocity.unwrap() / d);
                a = a.min(ax.max_acceleration.unwrap() / d);
            }
        }
        let line = if v * v / a < 1.0 {
            1.0 / v + v / a
        } else {
            2.0 / a.sqrt()
        };
        let before = before.duration;
        assert!(
            (t0 - before - line).abs() < 1e-9,
            "end ({x}, {y}, {z}): line {} s, closed form {line} s",
            t0 - before
        );
    }
}

/// The TCP solve by one affine step agrees with the general inverse
/// kinematics (Gauss–Newton to 1e-11 mm) and puts the nominal tip on the
/// target, over the trunnion's workspace from far starts; a machine whose
/// linear axes are dependent is left to the general solver.
#[test]
fn affine_tcp_solve_matches_the_general_inverse_kinematics() {
    use rand::{Rng, SeedableRng};
    let m = trunnion();
    let kin = Kinematics::nominal(&m);
    let lin: Vec<usize> = (0..m.axes.len())
        .filter(|&i| m.axes[i].kind == AxisKind::Linear)
        .collect();
    let lin = [lin[0], lin[1], lin[2]];
    let free: Vec<bool> = m.axes.iter().map(|a| a.kind == AxisKind::Linear).collect();
    let opts = super::travel::TCP_IK;
    let mut rng = rand::rngs::StdRng::seed_from_u64(21);
    let mut worst = (0.0f64, 0.0f64);
    for _ in 0..2000 {
        let mut q: Vec<f64> = m
            .axes
            .iter()
            .map(|a| rng.gen_range(a.travel[0]..a.travel[1]))
            .collect();
        let tip = Vector3::new(
            rng.gen_range(-200.0..200.0),
            rng.gen_range(-200.0..200.0),
            rng.gen_range(-150.0..150.0),
        );
        let general = kin
            .inverse(
                &crate::kinematics::IkTarget { tip, axis: None },
                &q,
                &free,
                &opts,
            )
            .unwrap();
        assert!(kin.solve_tip_by_three_linear_axes(lin, &tip, &mut q));
        let diff = q
            .iter()
            .zip(&general)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        worst.0 = worst.0.max(diff);
        worst.1 = worst.1.max((kin.pose(&q).tip - tip).norm());
    }
    assert!(worst.0 < 1e-11 && worst.1 < 1e-11, "{worst:?}");
    // Y and Z along the same direction: no solution by this step.
    let mut dep = m.clone();
    let (iy, iz) = (lin[0], lin[2]);
    dep.axes[iz].direction = dep.axes[iy].direction;
    let kin = Kinematics::nominal(&dep);
    let mut q = vec![1.0; dep.axes.len()];
    let before = q.clone();
    assert!(!kin.solve_tip_by_three_linear_axes(lin, &Vector3::new(1.0, 2.0, 3.0), &mut q));
    assert_eq!(q, before);
}

#[test]
fn tcp_line_keeps_the_tip_on_the_line() {
    let m = trunnion();
    let kin = Kinematics::nominal(&m);
    let opts = InterpolateOptions::new(0.001);
    let prog = "M428\nG0 X0 Y0 Z20 A-30 C45\nG1 X10 Y5 Z10 A-20 C60 F600\n";
    let (s, sum) = run(prog, &m, &opts).unwrap();
    assert_eq!(
        sum.transitions, 1,
        "the first TCP move starts away from the zero pose"
    );
    let (a, b) = (Vector3::new(0.0, 0.0, 20.0), Vector3::new(10.0, 5.0, 10.0));
    let line: Vec<_> = s.iter().filter(|x| x.2 == 3).collect();
    assert!(line.len() > 100);
    for (_, q, _) in line {
        let tip = kin.pose(q).tip;
        assert!(off_line(&tip, &a, &b) < 1e-9, "{tip:?}");
        // Rotary axes (A is index 3, C 4) move in proportion.
        let f = (q[3] + 30.0) / 10.0;
        assert!((q[4] - (45.0 + 15.0 * f)).abs() < 1e-9);
    }
    // Forcing TCP gives the same samples.
    let mut forced = opts.clone();
    forced.force_tcp = true;
    let (s2, _) = run(&prog[5..], &m, &forced).unwrap();
    assert_eq!(s2.last().unwrap().1, s.last().unwrap().1);
}

#[test]
fn first_tcp_rapid_goes_straight_in_axis_space_to_its_end() {
    // After M428 the program's numbers (X0 Y0 Z0 from before) are not the
    // tip (at W z = 150 at the zero pose): the rapid must not visit them.
    let m = trunnion();
    let kin = Kinematics::nominal(&m);
    let prog = "M428\nG0 X-60 Y0 A20 C-30\nG1 Z5 F600\n";
    let (s, sum) = run(prog, &m, &InterpolateOptions::new(0.001)).unwrap();
    assert_eq!(sum.transitions, 1);
    let rapid: Vec<_> = s.iter().filter(|x| x.2 == 2).collect();
    let q1 = &rapid.last().unwrap().1;
    // The program ends where it says: the tip at (-60, 0, 5) in W.
    let last = kin.pose(&s.last().unwrap().1).tip;
    assert!(
        (last - Vector3::new(-60.0, 0.0, 5.0)).norm() < 1e-9,
        "{last:?}"
    );
    let end = kin.pose(q1).tip;
    // Every sample lies on the straight axis-space segment from the zero pose.
    for (_, q, _) in &rapid {
        let f = q[3] / q1[3];
        for i in 0..q.len() {
            assert!((q[i] - f * q1[i]).abs() < 1e-9, "{q:?} not on 0 → {q1:?}");
        }
    }
    // So the tip never dives below the lower of its two ends.
    let lowest = rapid
        .iter()
        .map(|x| kin.pose(&x.1).tip.z)
        .fold(f64::INFINITY, f64::min);
    assert!(lowest > end.z.min(150.0) - 1.0, "dived to z = {lowest}");
}

#[test]
fn dense_paths_split_at_stops_and_follow_the_path() {
    let m = xyz(Some(20.0), Some(300.0));
    let mut opts = InterpolateOptions::new(0.001);
    opts.plan.jerk_step = 1.0;
    let prog = "G1 X10 F600\nX10 Y5\nG4 P1\nG61.1\nG1 X0 Y0\nX-1\n";
    let mut chains = Vec::new();
    dense_paths(prog.as_bytes(), &m, &opts, |c| {
        chains.push(c.clone());
        Ok(())
    })
    .unwrap();
    // The dwell ends the first chain; G61.1 makes one chain per move.
    assert_eq!(chains.len(), 3);
    let c = &chains[0];
    // 10 mm then 5 mm in 1 mm steps, caps 10 mm/s; the G64 corner at
    // (10, 0) blended within P = step/4 = 0.25 mm: d = 64 P / 7 of each
    // move replaced by a curve at least the chord d√2 long.
    let n = c.s.len();
    let d = 64.0 * 0.25 / 7.0;
    assert!(c.s.windows(2).all(|w| w[1] > w[0]));
    assert!(c.s[n - 1] < 15.0 && c.s[n - 1] >= 15.0 - 2.0 * d + d * 2f64.sqrt());
    assert_eq!(c.q[n - 1], vec![10.0, 5.0, 0.0]);
    assert_eq!(c.q[4], vec![4.0, 0.0, 0.0]);
    for q in &c.q {
        let d1 = (q[0].clamp(0.0, 10.0) - q[0]).hypot(q[1]);
        let d2 = (q[0] - 10.0).hypot(q[1].clamp(0.0, 5.0) - q[1]);
        assert!(d1.min(d2) <= 0.25 + 1e-12, "{q:?} off the path");
    }
    assert!(
        c.q.iter()
            .any(|q| (q[0] - 10.0).hypot(q[1]) > 0.01 && q[0] > 8.0 && q[1] < 2.0)
    );
    assert!(c.v_cap.iter().all(|&v| (v - 10.0).abs() < 1e-12));
    assert_eq!(c.line[n - 1], 2);
    // X10 Y5 -> X0 Y0: √125 mm, 12 points.
    assert!((chains[1].s.last().unwrap() - 125f64.sqrt()).abs() < 1e-12);
    assert_eq!(chains[1].s.len(), 13);
}

fn corpus(name: &str) -> Option<PathBuf> {
    crate::test_support::shared_dir("corpus/gcode/linuxcnc").map(|d| d.join(name))
}

/// Interpolates a corpus program under TCP and checks every sample's
/// nominal tip lies within the program's XYZ range.
fn corpus_tcp(name: &str, ts: f64, m: &Machine) {
    let Some(path) = corpus(name) else { return };
    let text = std::fs::read(&path).unwrap();
    let kin = Kinematics::nominal(m);
    let opts = InterpolateOptions::new(ts);
    let st = stats(&text[..], &StatsOptions::default()).unwrap();
    let mut n = 0u64;
    let mut worst = 0.0f64;
    let sum = interpolate(&text[..], m, &opts, |s| {
        n += 1;
        if n.is_multiple_of(97) {
            let tip = kin.pose(s.q).tip;
            for (i, r) in st.work_range[..3].iter().enumerate() {
                let r = r.unwrap();
                worst = worst.max(r.min - tip[i]).max(tip[i] - r.max);
            }
        }
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(
        worst < 1e-6,
        "{name}: tip leaves the program's box by {worst} mm"
    );
    assert_eq!(sum.samples, n);
    // Samples cover the duration at the period; feeds only slow down.
    assert_eq!(n, (sum.duration / ts).ceil() as u64 + 1);
    assert!(sum.duration >= st.feed_time);
}

#[test]
fn corpus_boat_under_tcp() {
    corpus_tcp("boat-xyzac.ngc", 0.01, &trunnion());
}

#[test]
fn corpus_impeller_under_tcp() {
    // The impeller turns C past -360 deg: on the example machine that is
    // reported at its line, never clipped.
    let Some(path) = corpus("impeller-7bl-xyzac.ngc") else {
        return;
    };
    let text = std::fs::read(&path).unwrap();
    let mut m = trunnion();
    let e = interpolate(&text[..], &m, &InterpolateOptions::new(0.01), |_| Ok(())).unwrap_err();
    assert!(
        matches!(e, InterpolateError::OutOfTravel { ref axis, value, .. } if axis == "C" && value < -360.0),
        "{e}"
    );
    // With C travel ±36000 deg as in the corpus's xyzac-trt.ini it runs.
    m.axes[4].travel = [-36000.0, 36000.0];
    corpus_tcp("impeller-7bl-xyzac.ngc", 0.01, &m);
}
