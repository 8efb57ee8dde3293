//! Every program mtwin generates, in every dialect its generator offers,
//! read back through the library's interpreter in that dialect: the move
//! ends are the points the generator meant (computed here from its inputs,
//! by closed form or by hand), and the dwells keep their durations. Fanuc
//! programs are read both with and without decimal point programming: the
//! writer puts a decimal point on every real-valued word, so both readings
//! must agree.
//!
//! The interpreter runs the motion subset; the lines of a Fanuc program that
//! are Macro B statements (`#501=#5061`, `IF[…]`, `DPRNT`, `POPEN`, `PCLOS`)
//! or its program number (`O9100`) are outside it and are dropped before
//! reading (and only those: every other line must read).

use mtwin::gcode::{Axis, Dialect, Event, EventKind, Feed, InterpOptions, interpret};
use mtwin::kinematics::Kinematics;
use mtwin::methods::ballbar::{self, BallbarMode, ProgramSpec, Rig, angle_range};
use mtwin::methods::skiving::Geometry;
use mtwin::methods::skiving::program::{Motion, Plan, ProbeAxis};
use mtwin::methods::testpiece::{SShape, SShapeProgram, s_shape_program};
use mtwin::methods::thermal::{BallArray, ProbeMotion, thermal_program};
use mtwin::methods::tracker;
use mtwin::sysid::{ExcitationOptions, excitation_program};

const FANUC: Dialect = Dialect::Fanuc {
    decimal_point_programming: false,
};
const FANUC_CALCULATOR: Dialect = Dialect::Fanuc {
    decimal_point_programming: true,
};

/// A move end or a dwell, as the interpreter read it.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    /// End of a straight move (work coordinates = machine coordinates here:
    /// no offsets), the feed, and whether it was a rapid.
    Move {
        to: [f64; 9],
        rapid: bool,
        feed: Feed,
    },
    /// A dwell, s.
    Dwell(f64),
}

fn is_fanuc_macro(line: &str) -> bool {
    let l = line.trim_start();
    l.starts_with('#')
        || l.starts_with("IF[")
        || l.starts_with("DPRNT")
        || l == "POPEN"
        || l == "PCLOS"
        || (l.starts_with('O') && l[1..].chars().all(|c| c.is_ascii_digit()))
}

/// The moves and dwells of `text` read in `dialect`.
fn read(text: &str, dialect: Dialect) -> Vec<Step> {
    let kept: String = if dialect == Dialect::LinuxCnc {
        text.to_owned()
    } else {
        text.lines()
            .filter(|l| !is_fanuc_macro(l))
            .map(|l| format!("{l}\n"))
            .collect()
    };
    let mut opts = InterpOptions::default();
    opts.dialect = dialect;
    let mut steps = Vec::new();
    interpret(kept.as_bytes(), opts, |_, events: &[Event]| {
        for e in events {
            match e.kind {
                EventKind::Traverse(m) | EventKind::Feed(m) => {
                    assert!(m.offset.0.iter().all(|&o| o == 0.0));
                    steps.push(Step::Move {
                        to: m.to.0,
                        rapid: matches!(e.kind, EventKind::Traverse(_)),
                        feed: m.feed,
                    });
                }
                EventKind::Dwell { seconds } => steps.push(Step::Dwell(seconds)),
                EventKind::Arc(_) => panic!("no generator writes arcs"),
                _ => {}
            }
        }
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{e}\n{kept}"));
    steps
}

/// The moves of `steps`.
fn moves(steps: &[Step]) -> Vec<([f64; 9], bool, Feed)> {
    steps
        .iter()
        .filter_map(|s| match s {
            Step::Move { to, rapid, feed } => Some((*to, *rapid, *feed)),
            Step::Dwell(_) => None,
        })
        .collect()
}

fn dwells(steps: &[Step]) -> Vec<f64> {
    steps
        .iter()
        .filter_map(|s| match s {
            Step::Dwell(d) => Some(*d),
            Step::Move { .. } => None,
        })
        .collect()
}

/// Positions reached by a sequence of partial targets (axis letter, value)
/// from zero: the full end of every move.
fn ends(targets: &[Vec<(Axis, f64)>]) -> Vec<[f64; 9]> {
    let mut at = [0.0; 9];
    targets
        .iter()
        .map(|t| {
            for &(a, v) in t {
                at[a.index()] = v;
            }
            at
        })
        .collect()
}

fn assert_close(got: &[f64; 9], want: &[f64; 9], tol: f64, what: &str) {
    for k in 0..9 {
        assert!(
            (got[k] - want[k]).abs() <= tol,
            "{what}: axis {k}: {} vs {} (tolerance {tol})",
            got[k],
            want[k]
        );
    }
}

/// Half the last written decimal of a dialect's default writer.
fn tolerance(dialect: Dialect) -> f64 {
    if dialect == Dialect::LinuxCnc {
        0.5e-4 + 1e-12
    } else {
        0.5e-3 + 1e-12
    }
}

#[test]
fn skiving_touch_off_reads_back_in_every_dialect() {
    let g = Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap();
    // An x off the centre, so that the side contact y has many decimals.
    let plan = Plan::standard(3.3, &g);
    let m = Motion {
        approach: 2.0,
        overtravel: 1.0,
        clearance: 20.0,
        feed: 15.0,
    };
    let (h, rt, rg, x): (f64, f64, f64, f64) = (80.0, 40.0, 60.0, 3.3);
    let f = rg / 2.0;
    let side_y = rt + (rg * rg - x * x).sqrt();
    let safe = -h + m.clearance;
    // Each touch by hand: (c, probe axis, held or nominal positions).
    let touches = [
        (0.0, ProbeAxis::MinusZ, f, -h),
        (0.0, ProbeAxis::MinusZ, -f, -h),
        (0.0, ProbeAxis::MinusY, side_y, -h - 10.0),
        (90.0, ProbeAxis::MinusZ, f, -h),
        (90.0, ProbeAxis::MinusZ, -f, -h),
        (90.0, ProbeAxis::MinusY, side_y, -h - 10.0),
    ];
    let mut targets = vec![vec![(Axis::Z, safe)]];
    let mut probes = Vec::new();
    for &(c, probe, y, z) in &touches {
        targets.push(vec![(Axis::A, 0.0), (Axis::B, 0.0), (Axis::C, c)]);
        match probe {
            ProbeAxis::MinusZ => {
                targets.push(vec![(Axis::X, x), (Axis::Y, y)]);
                targets.push(vec![(Axis::Z, z + m.approach)]);
                probes.push(targets.len());
                targets.push(vec![(Axis::Z, z - m.overtravel)]);
                targets.push(vec![(Axis::Z, z + m.approach)]);
            }
            ProbeAxis::MinusY => {
                targets.push(vec![(Axis::X, x), (Axis::Y, y + m.approach)]);
                targets.push(vec![(Axis::Z, z)]);
                probes.push(targets.len());
                targets.push(vec![(Axis::Y, y - m.overtravel)]);
                targets.push(vec![(Axis::Y, y + m.approach)]);
            }
        }
        targets.push(vec![(Axis::Z, safe)]);
    }
    let want = ends(&targets);
    for (dialect, readings) in [
        (Dialect::LinuxCnc, vec![Dialect::LinuxCnc]),
        (FANUC, vec![FANUC, FANUC_CALCULATOR]),
    ] {
        let text = mtwin::methods::skiving::program::program(&plan, &g, &m, dialect).unwrap();
        let mut first = None;
        for reading in readings {
            let steps = read(&text, reading);
            let got = moves(&steps);
            assert_eq!(got.len(), want.len(), "{reading:?}");
            for (k, ((to, rapid, feed), w)) in got.iter().zip(&want).enumerate() {
                assert_close(to, w, tolerance(dialect), &format!("{reading:?} move {k}"));
                if probes.contains(&k) {
                    assert!(!rapid && *feed == Feed::PerMinute(m.feed), "{feed:?}");
                } else {
                    assert!(rapid, "move {k} is a rapid");
                }
            }
            assert!(dwells(&steps).is_empty());
            // Both Fanuc readings are the same.
            match &first {
                None => first = Some(steps),
                Some(f) => assert_eq!(f, &steps),
            }
        }
    }
}

#[test]
fn thermal_programme_reads_back_in_every_dialect() {
    let balls = BallArray {
        x0: -100.0,
        pitch: 50.0,
        y: 20.0,
        heights: vec![-50.0, -150.0, -250.0],
        diameter: 25.4,
    };
    let motion = ProbeMotion::default();
    let speeds = [2000.0, 0.0, 6000.0];
    let (step_min, period_min) = (25.0, 10.0);
    // By hand: safe height 12.7 + 10 above the highest ball; one pass is
    // 100 mm of rapid along X there and back, down to 2 mm above and up
    // from 1 mm below each ball top, 3 mm of probing per ball at 100 mm/min.
    let r = 12.7;
    let safe = -50.0 + r + 10.0;
    let mut rapid = 200.0;
    for z in [-50.0, -150.0, -250.0] {
        rapid += (safe - (z + r + 2.0)) + (safe - (z + r - 1.0));
    }
    let pass_s = 60.0 * (rapid / 10_000.0 + 3.0 * 3.0 / 100.0);
    let passes = 8; // 75 min of programme, a pass every 10 min: 0, 10, …, 70.
    let mut targets = vec![
        vec![(Axis::Z, safe)],
        vec![(Axis::X, -100.0), (Axis::Y, 20.0)],
    ];
    for _ in 0..passes {
        for (i, z) in [-50.0, -150.0, -250.0].iter().enumerate() {
            targets.push(vec![(Axis::X, -100.0 + 50.0 * i as f64)]);
            targets.push(vec![(Axis::Z, z + r + 2.0)]);
            targets.push(vec![(Axis::Z, z + r - 1.0)]);
            targets.push(vec![(Axis::Z, safe)]);
        }
        targets.push(vec![(Axis::X, -100.0)]);
    }
    let want = ends(&targets);
    for (dialect, readings) in [
        (Dialect::LinuxCnc, vec![Dialect::LinuxCnc]),
        (FANUC, vec![FANUC, FANUC_CALCULATOR]),
    ] {
        let p = thermal_program(&balls, &motion, &speeds, step_min, period_min, dialect).unwrap();
        assert_eq!(p.passes, passes);
        assert!((p.pass_s - pass_s).abs() < 1e-9);
        for reading in readings {
            let steps = read(&p.text, reading);
            let got = moves(&steps);
            assert_eq!(got.len(), want.len());
            for (k, ((to, rapid, feed), w)) in got.iter().zip(&want).enumerate() {
                assert_close(to, w, 1e-9, &format!("{reading:?} move {k}"));
                // The probing moves are the third of every ball's four.
                let probing = k >= 2 && (k - 2) % 13 != 12 && (k - 2) % 13 % 4 == 2;
                assert_eq!(!rapid, probing, "move {k}");
                if probing {
                    assert_eq!(*feed, Feed::PerMinute(motion.feed));
                }
            }
            // The dwells between pass k and k + 1 fill the period: the dwell
            // time read up to the end of pass k + 1 is (k + 1)·(T − p), to
            // 0.5 ms (written to 1 ms, rounding not accumulated).
            let mut dwell = 0.0;
            let mut pass = 0;
            let mut since_pass_end = false;
            let mut moves_seen = 0;
            for s in &steps {
                match s {
                    Step::Dwell(d) => {
                        assert!(*d > 0.0);
                        dwell += d;
                        since_pass_end = true;
                    }
                    Step::Move { .. } => {
                        moves_seen += 1;
                        if since_pass_end {
                            pass += 1;
                            let want = pass as f64 * (600.0 - pass_s);
                            assert!(
                                (dwell - want).abs() <= 0.5e-3 + 1e-9,
                                "{reading:?} before pass {pass}: {dwell} s of dwell, want {want}"
                            );
                            since_pass_end = false;
                        }
                    }
                }
            }
            assert_eq!(moves_seen, want.len());
            assert_eq!(pass, passes - 1);
        }
    }
}

#[test]
fn servo_excitation_reads_back_in_every_dialect() {
    // Travel [-100, 60], 4 levels: centre −20, amplitudes 20, 40, 60, 80.
    let hand = [
        -20.0, 0.0, -40.0, 20.0, -60.0, 40.0, -80.0, 60.0, -100.0, -20.0,
    ];
    // An uneven travel: centre 0.00005, amplitudes 10.00005·k/3, the
    // targets inside the travel to 1 µm.
    let (lo, hi) = (-10.0, 10.0001);
    let mut uneven = vec![0.5 * (lo + hi)];
    for k in 1..=3 {
        let amp = 0.5 * (hi - lo) * k as f64 / 3.0;
        uneven.extend([0.5 * (lo + hi) + amp, 0.5 * (lo + hi) - amp]);
    }
    uneven.push(0.5 * (lo + hi));
    for (dialect, readings) in [
        (Dialect::LinuxCnc, vec![Dialect::LinuxCnc]),
        (FANUC, vec![FANUC, FANUC_CALCULATOR]),
    ] {
        for (axis, travel, levels, want, index) in [
            ("x", [-100.0, 60.0], 4, hand.to_vec(), Axis::X),
            ("C", [lo, hi], 3, uneven.clone(), Axis::C),
        ] {
            let mut o = ExcitationOptions::new(axis, travel, 3000.0);
            o.levels = levels;
            o.dwell_s = 0.25;
            o.dialect = dialect;
            let text = excitation_program(&o).unwrap();
            for &reading in &readings {
                let steps = read(&text, reading);
                let got: Vec<f64> = moves(&steps).iter().map(|m| m.0[index.index()]).collect();
                assert_eq!(got.len(), want.len(), "{text}");
                for (g, w) in got.iter().zip(&want) {
                    // Rounded inward to 1 µm, then written.
                    assert!((g - w).abs() <= 1e-3 + 1e-9, "{g} vs {w}");
                    assert!(*g >= travel[0] && *g <= travel[1], "{g} outside {travel:?}");
                }
                assert!(moves(&steps).iter().all(|m| m.2 == Feed::PerMinute(3000.0)));
                assert_eq!(dwells(&steps), vec![0.25; want.len()]);
            }
        }
    }
}

/// The writer's dialects and the readings of each: a Fanuc program keeps a
/// decimal point on every number, so it reads the same with and without
/// decimal point programming.
fn dialects() -> [(Dialect, Vec<Dialect>); 2] {
    [
        (Dialect::LinuxCnc, vec![Dialect::LinuxCnc]),
        (FANUC, vec![FANUC, FANUC_CALCULATOR]),
    ]
}

#[test]
fn ballbar_programs_read_back_in_every_dialect() {
    let machine = mtwin::examples::machine("ac-trunnion").unwrap();
    let spec = |angles: Vec<f64>, dialect| ProgramSpec {
        rig: Rig::source_paper(),
        angles_deg: angles,
        dwell_s: 1.5,
        feed: 720.0,
        dialect,
    };
    // The source paper's rig on the trunnion: the ball 100 mm from the C
    // line along x for mode 2 (A turns), 100 mm above the table for mode 4.
    for (mode, ball, moving) in [
        (BallbarMode::Two, [100.0, 0.0, 0.0], Axis::A),
        (BallbarMode::Four, [0.0, 0.0, 100.0], Axis::C),
    ] {
        let angles = if moving == Axis::A {
            angle_range(-90.0, 90.0, 7.5)
        } else {
            angle_range(0.0, 360.0, 12.5)
        };
        let mut targets = vec![
            vec![(Axis::A, 0.0), (Axis::C, 0.0)],
            vec![(Axis::X, ball[0]), (Axis::Y, ball[1]), (Axis::Z, ball[2])],
        ];
        for &a in angles.iter().chain(&[0.0]) {
            targets.push(vec![(moving, a)]);
        }
        let want = ends(&targets);
        for (dialect, readings) in dialects() {
            let text = ballbar::program(&machine, mode, &spec(angles.clone(), dialect)).unwrap();
            for reading in readings {
                let steps = read(&text, reading);
                let got = moves(&steps);
                assert_eq!(got.len(), want.len());
                for (k, ((to, rapid, feed), w)) in got.iter().zip(&want).enumerate() {
                    assert_close(to, w, 1e-9, &format!("{mode:?} {reading:?} move {k}"));
                    assert_eq!(*rapid, k < 2);
                    if k >= 2 {
                        assert_eq!(*feed, Feed::PerMinute(720.0));
                    }
                }
                assert_eq!(dwells(&steps), vec![1.5; angles.len()]);
            }
        }
    }
}

#[test]
fn tracker_pose_program_reads_back_in_every_dialect() {
    let machine = mtwin::examples::machine("afp-gantry").unwrap();
    // Axis order of the gantry: X Y Z B A C.
    let poses = vec![
        vec![100.123_44, -2.0, -300.5, 10.0, -0.00004, 45.0],
        vec![0.0, 1.0 / 3.0, -0.25, -12.345_67, 5.0, -90.0],
    ];
    let order = [Axis::X, Axis::Y, Axis::Z, Axis::B, Axis::A, Axis::C];
    let want: Vec<Vec<(Axis, f64)>> = poses
        .iter()
        .map(|q| order.iter().copied().zip(q.iter().copied()).collect())
        .collect();
    let want = ends(&want);
    for (dialect, readings) in dialects() {
        let text = tracker::plan::gcode(&machine, &poses, 2000.0, 2.0, dialect).unwrap();
        for reading in readings {
            let steps = read(&text, reading);
            let got = moves(&steps);
            assert_eq!(got.len(), 2);
            for (k, ((to, rapid, feed), w)) in got.iter().zip(&want).enumerate() {
                assert_close(to, w, tolerance(dialect), &format!("{reading:?} pose {k}"));
                assert!(!rapid && *feed == Feed::PerMinute(2000.0));
            }
            assert_eq!(dwells(&steps), vec![2.0, 2.0]);
        }
    }
}

#[test]
fn s_shape_programs_read_back_in_every_dialect() {
    let machine = mtwin::examples::machine("ac-trunnion").unwrap();
    let kin = Kinematics::nominal(&machine);
    let letters: Vec<Axis> = Axis::of_machine(&machine).unwrap();
    let shape = SShape::default().scaled(0.5);
    let n = 24;
    for (dialect, readings) in dialects() {
        // Half the last written decimal: 6 for LinuxCNC, 3 for Fanuc.
        let half = if dialect == Dialect::LinuxCnc {
            0.5e-6
        } else {
            0.5e-3
        };
        for (tcp, inverse_time) in [(false, false), (false, true), (true, false)] {
            let opts = SShapeProgram {
                segments: n,
                feed: 800.0,
                inverse_time,
                tcp,
                dialect,
            };
            let text = s_shape_program(&machine, &shape, &opts).unwrap();
            for &reading in &readings {
                let steps = read(&text, reading);
                let got = moves(&steps);
                assert_eq!(got.len(), n + 1);
                for (i, (to, rapid, feed)) in got.iter().enumerate() {
                    let s = i as f64 / n as f64;
                    assert_eq!(*rapid, i == 0);
                    if tcp {
                        // X Y Z are the tip on the lower curve, to the written decimals.
                        for (k, a) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
                            assert!((to[a.index()] - shape.lower(s)[k]).abs() <= half + 1e-12);
                        }
                    } else {
                        // The axis positions put the tip on the lower curve
                        // and the tool axis along the ruling, within what
                        // the written decimals move them (a lever of about
                        // 200 mm turns 0.0005° into 2 µm).
                        let q: Vec<f64> = letters.iter().map(|a| to[a.index()]).collect();
                        let pose = kin.pose(&q);
                        let (tip_tol, axis_tol) = if dialect == Dialect::LinuxCnc {
                            (5e-6, 5e-8)
                        } else {
                            (5e-3, 2e-5)
                        };
                        assert!((pose.tip - shape.lower(s)).norm() < tip_tol, "pose {i}");
                        assert!((pose.axis - shape.ruling(s)).norm() < axis_tol, "pose {i}");
                    }
                    if i > 0 && inverse_time {
                        // F = feed / segment length of the tip, 1/min: the
                        // segment lasts its length at the feed (F written
                        // to the dialect's decimals).
                        let len = (shape.lower(s) - shape.lower((i - 1) as f64 / n as f64)).norm();
                        let Feed::InverseTime(f) = feed else {
                            panic!("{feed:?}")
                        };
                        let exact = 800.0 / len;
                        assert!((f - exact).abs() <= half + 1e-9, "segment {i}");
                    } else if i > 0 {
                        assert_eq!(*feed, Feed::PerMinute(800.0));
                    }
                }
                assert!(dwells(&steps).is_empty());
            }
        }
    }
}

#[test]
fn thermal_faces_program_reads_back_in_every_dialect() {
    use mtwin::scenarios::thermal_faces::{FACE_Z, faces_program};
    // By hand: up to Z5, then per face a rapid to X0 Y0, the plunge to the
    // face height at F500, 20 passes along X (200 mm, F2000) each followed
    // by a 5 mm step in Y, and the retract to Z5; between the faces an
    // hour of dwells: 600, 900, 600, 900, 600 s.
    let mut targets = vec![vec![(Axis::Z, 5.0)]];
    let mut kinds = vec![(true, None)];
    for _ in 0..2 {
        targets.push(vec![(Axis::X, 0.0), (Axis::Y, 0.0)]);
        kinds.push((true, None));
        targets.push(vec![(Axis::Z, FACE_Z)]);
        kinds.push((false, Some(500.0)));
        for i in 0..20 {
            targets.push(vec![(Axis::X, if i % 2 == 0 { 200.0 } else { 0.0 })]);
            kinds.push((false, Some(2000.0)));
            targets.push(vec![(Axis::Y, 5.0 * f64::from(i + 1))]);
            kinds.push((false, Some(2000.0)));
        }
        targets.push(vec![(Axis::Z, 5.0)]);
        kinds.push((true, None));
    }
    let want = ends(&targets);
    for (dialect, readings) in dialects() {
        let text = faces_program(dialect).unwrap();
        for reading in readings {
            let steps = read(&text, reading);
            let got = moves(&steps);
            assert_eq!(got.len(), want.len(), "{reading:?}");
            for (k, ((to, rapid, feed), (w, (want_rapid, want_feed)))) in
                got.iter().zip(want.iter().zip(&kinds)).enumerate()
            {
                assert_close(to, w, 1e-9, &format!("{reading:?} move {k}"));
                assert_eq!(rapid, want_rapid, "{reading:?} move {k}");
                if let Some(f) = want_feed {
                    assert_eq!(*feed, Feed::PerMinute(*f), "{reading:?} move {k}");
                }
            }
            assert_eq!(
                dwells(&steps),
                [600.0, 900.0, 600.0, 900.0, 600.0],
                "{reading:?}"
            );
        }
    }
}
