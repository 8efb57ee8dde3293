use std::path::Path;

use super::*;
use crate::gcode::{InterpolateOptions, StatsOptions, interpolate, stats};
use crate::model::read_machine;

fn trunnion() -> Machine {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/ac-trunnion.toml");
    read_machine(&p).unwrap()
}

/// Every `G0`/`G1` line's words as (letter, value).
fn moves(program: &str) -> Vec<Vec<(char, f64)>> {
    program
        .lines()
        .filter(|l| l.starts_with("G0 ") || l.starts_with("G1 "))
        .map(|l| {
            l.split_whitespace()
                .skip(1)
                .map(|w| (w.chars().next().unwrap(), w[1..].parse().unwrap()))
                .collect()
        })
        .collect()
}

fn word(words: &[(char, f64)], c: char) -> Option<f64> {
    words.iter().find(|w| w.0 == c).map(|w| w.1)
}

#[test]
fn guide_curves_match_their_definition() {
    let s = SShape::default();
    let (l, w, h) = (160.0, 40.0, 30.0);
    let lean = 30.0 * 15f64.to_radians().tan();
    let near = |a: Vector3<f64>, b: [f64; 3]| (a - Vector3::from(b)).norm() < 1e-12;
    assert!(near(s.lower(0.0), [-l / 2.0, 0.0, 0.0]));
    assert!(near(s.lower(0.25), [-l / 4.0, -w / 2.0, 0.0]));
    assert!(near(s.lower(0.75), [l / 4.0, w / 2.0, 0.0]));
    assert!(near(
        s.upper(0.75),
        [0.875 * l / 4.0, 0.8 * w / 2.0 - lean, h]
    ));
    assert!(near(s.upper(1.0), [0.875 * l / 2.0, -lean, h]));
    // The ruling is never vertical: the y gap upper − lower is
    // −4·sin(·) − lean ∈ [−4 − lean, 4 − lean] (lean = 8.04 mm), so the tilt
    // from z is at least atan((lean − 4)/30); at s = 1/4 the gap is
    // (5, 4 − lean), an upper bound of the smallest tilt. The x gap is at
    // most 10 mm, so the tilt is at most atan(√(10² + (4 + lean)²)/30).
    let mut lo = f64::INFINITY;
    let mut hi = 0.0f64;
    for i in 0..=1000 {
        let a = s.ruling(i as f64 / 1000.0).z.acos();
        lo = lo.min(a);
        hi = hi.max(a);
    }
    assert!(lo >= ((lean - 4.0) / 30.0).atan() - 1e-12, "{lo}");
    assert!(
        lo <= (25.0 + (lean - 4.0).powi(2)).sqrt().atan2(30.0),
        "{lo}"
    );
    assert!(
        hi <= (100.0 + (lean + 4.0).powi(2)).sqrt().atan2(30.0) + 1e-12,
        "{hi}"
    );
    eprintln!("tilt {} .. {} deg", lo.to_degrees(), hi.to_degrees());
    let big = s.scaled(2.0);
    assert!(near(big.lower(0.25), [-l / 2.0, -w, 0.0]));
}

#[test]
fn joint_program_puts_the_tip_on_the_curve_and_the_axis_along_the_ruling() {
    let m = trunnion();
    let shape = SShape::default();
    let n = 80;
    let opts = SShapeProgram {
        segments: n,
        ..SShapeProgram::default()
    };
    let text = s_shape_program(&m, &shape, &opts).unwrap();
    let kin = Kinematics::nominal(&m);
    let names = kin.axis_names();
    let mv = moves(&text);
    assert_eq!(mv.len(), n + 1);
    for (i, words) in mv.iter().enumerate() {
        let q: Vec<f64> = names
            .iter()
            .map(|a| word(words, a.chars().next().unwrap()).unwrap())
            .collect();
        kin.check_travel(&q).unwrap();
        let pose = kin.pose(&q);
        let s = i as f64 / n as f64;
        // Written with 6 decimals: 5e-7 mm / 5e-7° of rounding at most.
        let tip = (pose.tip - shape.lower(s)).norm();
        let axis = (pose.axis - shape.ruling(s)).norm();
        assert!(tip < 5e-6 && axis < 5e-8, "pose {i}: tip {tip} axis {axis}");
    }
    // At full precision (the poses before formatting) to 1e-9.
    for (i, q) in s_shape_poses(&m, &shape, n).unwrap().iter().enumerate() {
        let s = i as f64 / n as f64;
        let pose = kin.pose(q);
        assert!((pose.tip - shape.lower(s)).norm() < 1e-9);
        assert!((pose.axis - shape.ruling(s)).norm() < 1e-9);
    }
    assert!(text.contains("G94") && text.contains(" F1000") && text.trim_end().ends_with("M30\n%"));
    // The G-code engine interpolates it on the machine, within travel; it
    // ends at the last pose.
    let mut last = Vec::new();
    let summary = interpolate(
        text.as_bytes(),
        &m,
        &InterpolateOptions::new(0.001),
        |smp| {
            last = smp.q.to_vec();
            Ok(())
        },
    )
    .unwrap();
    assert!(summary.samples > 100);
    let end = mv.last().unwrap();
    for (a, v) in names.iter().zip(&last) {
        let w = word(end, a.chars().next().unwrap()).unwrap();
        assert!((v - w).abs() < 1e-9, "{a}: {v} vs {w}");
    }
}

#[test]
fn tcp_program_round_trips_the_geometry() {
    let m = trunnion();
    let shape = SShape::default().scaled(0.5);
    let n = 40;
    let opts = SShapeProgram {
        segments: n,
        tcp: true,
        ..SShapeProgram::default()
    };
    let text = s_shape_program(&m, &shape, &opts).unwrap();
    assert!(text.contains("G43.4 H0") && text.contains("G49"));
    let kin = Kinematics::nominal(&m);
    let names = kin.axis_names();
    let linear: Vec<bool> = names.iter().map(|a| "XYZ".contains(*a)).collect();
    let mv = moves(&text);
    assert_eq!(mv.len(), n + 1);
    for (i, words) in mv.iter().enumerate() {
        let s = i as f64 / n as f64;
        let tip = Vector3::new(
            word(words, 'X').unwrap(),
            word(words, 'Y').unwrap(),
            word(words, 'Z').unwrap(),
        );
        assert!((tip - shape.lower(s)).norm() < 1e-6);
        // Rotary words as written, the linear axes solved for the tip alone:
        // the tool axis must then lie along the ruling.
        let start: Vec<f64> = names
            .iter()
            .map(|a| {
                if "XYZ".contains(*a) {
                    0.0
                } else {
                    word(words, a.chars().next().unwrap()).unwrap()
                }
            })
            .collect();
        let q = kin
            .inverse(
                &IkTarget { tip, axis: None },
                &start,
                &linear,
                &IkOptions::default(),
            )
            .unwrap();
        let axis = kin.pose(&q).axis;
        assert!((axis - shape.ruling(s)).norm() < 1e-7, "pose {i}");
    }
    // Interpolated by the engine under TCP: every sample after the rapid
    // lies with its tip on the polyline of the lower-curve vertices.
    let rapid_line = text.lines().position(|l| l.starts_with("G0 ")).unwrap() as u64 + 1;
    let verts: Vec<Vector3<f64>> = (0..=n).map(|i| shape.lower(i as f64 / n as f64)).collect();
    let mut worst = 0.0f64;
    let mut on_part = 0;
    interpolate(
        text.as_bytes(),
        &m,
        &InterpolateOptions::new(0.002),
        |smp| {
            if smp.line <= rapid_line {
                return Ok(()); // the rapid approach
            }
            on_part += 1;
            let p = kin.pose(smp.q).tip;
            let d = verts
                .windows(2)
                .map(|w| {
                    let (a, b) = (w[0], w[1]);
                    let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
                    (p - (a + (b - a) * t)).norm()
                })
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(d);
            Ok(())
        },
    )
    .unwrap();
    assert!(on_part > 100);
    assert!(worst < 1e-6, "{worst}");
}

#[test]
fn inverse_time_feeds_give_the_tip_feed() {
    let m = trunnion();
    let shape = SShape::default();
    let n = 50;
    let feed = 600.0;
    let opts = SShapeProgram {
        segments: n,
        feed,
        inverse_time: true,
        ..SShapeProgram::default()
    };
    let text = s_shape_program(&m, &shape, &opts).unwrap();
    assert!(text.contains("G93"));
    let length: f64 = (1..=n)
        .map(|i| (shape.lower(i as f64 / n as f64) - shape.lower((i - 1) as f64 / n as f64)).norm())
        .sum();
    // G93: each segment takes 1/F minutes, so the feed time is the tip path over the feed.
    let st = stats(text.as_bytes(), &StatsOptions::default()).unwrap();
    let want = length / feed * 60.0;
    // F is written with 4 decimals (~1e-6 relative).
    assert!(
        (st.feed_time - want).abs() < 1e-5 * want,
        "{} vs {want}",
        st.feed_time
    );
}

#[test]
fn out_of_travel_and_bad_options_are_refused() {
    let mut m = trunnion();
    for a in &mut m.axes {
        if a.name == "A" {
            a.travel = [-5.0, 5.0];
        }
    }
    let e = s_shape_program(&m, &SShape::default(), &SShapeProgram::default()).unwrap_err();
    let msg = e.to_string();
    let chain = format!("{msg}: {}", std::error::Error::source(&e).unwrap());
    assert!(
        chain.contains("axis A") && chain.contains("travel"),
        "{chain}"
    );
    let m = trunnion();
    let bad = SShapeProgram {
        segments: 0,
        ..SShapeProgram::default()
    };
    assert!(s_shape_program(&m, &SShape::default(), &bad).is_err());
    let bad = SShapeProgram {
        feed: 0.0,
        ..SShapeProgram::default()
    };
    assert!(s_shape_program(&m, &SShape::default(), &bad).is_err());
    assert!(
        s_shape_program(
            &m,
            &SShape::default().scaled(-1.0),
            &SShapeProgram::default()
        )
        .is_err()
    );
}
