//! `--planner jerk` through G-code: the 7-phase closed form of a straight
//! move, and over random short programs (lines, arcs, rapids, feeds) on a
//! 3-axis machine and on the 5-axis example machine under TCP, every joint's
//! velocity, acceleration and jerk within its limits at every 1 ms sample
//! (finite differences), rest at both ends, and the tool on the programmed
//! path within the stated tolerance. Also the boat under the jerk planner.

use mtwin::gcode::plan::{PlanOptions, Planner};
use mtwin::gcode::{InterpolateError, InterpolateOptions, InterpolationSummary, interpolate};
use mtwin::kinematics::Kinematics;
use mtwin::model::{AxisKind, Machine};
use nalgebra::Vector3;
use proptest::prelude::*;

/// Sample period of the checks, s.
const TS: f64 = 0.001;

/// Cartesian XYZ machine with `v` mm/s, `a` mm/s², `j` mm/s³ on every axis
/// and a `rapid_feed` of 6000 mm/min.
fn xyz(v: f64, a: f64, j: f64) -> Machine {
    let mut m = mtwin::examples::xyz(1000.0);
    for ax in &mut m.axes {
        ax.max_velocity = Some(v);
        ax.max_acceleration = Some(a);
        ax.max_jerk = Some(j);
    }
    m
}

/// The 5-axis example machine (AC trunnion), limits scaled down so that
/// short programs reach them: linear 50 mm/s, 500 mm/s², 10 000 mm/s³;
/// rotary 60 deg/s, 600 deg/s², 12 000 deg/s³.
fn trunnion() -> Machine {
    let mut m = mtwin::examples::machine("ac-trunnion").unwrap();
    for ax in m.axes.iter_mut() {
        let k = if ax.kind == AxisKind::Linear {
            1.0
        } else {
            1.2
        };
        ax.max_velocity = Some(50.0 * k);
        ax.max_acceleration = Some(500.0 * k);
        ax.max_jerk = Some(10000.0 * k);
    }
    m
}

type Samples = Vec<(f64, Vec<f64>, u64)>;

fn run_jerk(prog: &str, m: &Machine, step: f64) -> Result<(Samples, InterpolationSummary), String> {
    let mut opts = InterpolateOptions::new(TS);
    opts.plan = PlanOptions::new(Planner::Jerk);
    opts.plan.jerk_step = step;
    opts.check_travel = false;
    let mut out = Vec::new();
    let s = interpolate(prog.as_bytes(), m, &opts, |s| {
        out.push((s.t, s.q.to_vec(), s.line));
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    Ok((out, s))
}

/// Position of the rest-to-rest 7-phase jerk-limited profile over `l` that
/// reaches `a` and `v` (jerk ±j), at time `t`, by integrating the piecewise
/// constant jerk exactly.
fn seven_phase(l: f64, v: f64, a: f64, j: f64, t: f64) -> f64 {
    let tj = a / j;
    let ta = v / a - tj;
    let t1 = v / a + tj;
    let tv = l / v - t1;
    assert!(ta >= 0.0 && tv >= 0.0, "limits not reached");
    let phases = [
        (j, tj),
        (0.0, ta),
        (-j, tj),
        (0.0, tv),
        (-j, tj),
        (0.0, ta),
        (j, tj),
    ];
    let (mut s, mut sv, mut sa, mut left) = (0.0, 0.0, 0.0, t.max(0.0));
    for (jj, d) in phases {
        let d = d.min(left);
        s += sv * d + sa * d * d / 2.0 + jj * d * d * d / 6.0;
        sv += sa * d + jj * d * d / 2.0;
        sa += jj * d;
        left -= d;
    }
    s
}

#[test]
fn straight_move_through_gcode_is_the_7_phase_closed_form() {
    // v 50 mm/s, a 500 mm/s², j 10 000 mm/s³: a²/j = 25 ≤ v, so a is
    // reached; the programmed feed (100 mm/s) is above v. T = L/v + v/a + a/j.
    let (v, a, j, l) = (50.0, 500.0, 10000.0, 100.0);
    let m = xyz(v, a, j);
    let (s, sum) = run_jerk("G1 X100 F6000\n", &m, 0.1).unwrap();
    let best = l / v + v / a + a / j;
    assert!(
        (sum.duration - best).abs() < 1e-9 * best,
        "{} s against the closed form {best} s",
        sum.duration
    );
    for (t, q, _) in &s {
        let want = seven_phase(l, v, a, j, *t);
        assert!(
            (q[0] - want).abs() < 1e-6,
            "t = {t}: x = {}, closed form {want}",
            q[0]
        );
        assert_eq!((q[1], q[2]), (0.0, 0.0));
    }
    assert_eq!(s.len() as u64, (best / TS).ceil() as u64 + 1);
    // The same along a diagonal: the path limits are the joint limits over
    // the largest direction cosine (0.8 for a 3-4-5 direction).
    let (s, sum) = run_jerk("G1 X60 Y-80 F6000\n", &m, 0.1).unwrap();
    let (vt, at, jt) = (v / 0.8, a / 0.8, j / 0.8);
    let best = l / vt + vt / at + at / jt;
    assert!(
        (sum.duration - best).abs() < 1e-9 * best,
        "{}",
        sum.duration
    );
    for (t, q, _) in &s {
        let want = seven_phase(l, vt, at, jt, *t);
        assert!((q[0] - 0.6 * want).abs() < 1e-6 && (q[1] + 0.8 * want).abs() < 1e-6);
    }
}

/// Largest |first, second, third finite difference| of joint `i`, divided by
/// ts, ts², ts³.
fn peaks(s: &Samples, i: usize) -> [f64; 3] {
    let x: Vec<f64> = s.iter().map(|r| r.1[i]).collect();
    let mut p = [0.0f64; 3];
    for w in x.windows(4) {
        p[0] = p[0].max((w[1] - w[0]).abs() / TS);
        p[1] = p[1].max((w[2] - 2.0 * w[1] + w[0]).abs() / (TS * TS));
        p[2] = p[2].max((w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]).abs() / (TS * TS * TS));
    }
    p
}

/// Every joint within its limits at every sample. A difference quotient of
/// order k over samples of a motion whose k-th derivative is bounded by L is
/// a weighted mean of that derivative, so it is at most L; the tolerance is
/// 1e-6 relative plus the rounding of positions (1e-9 mm or deg each,
/// amplified by 2^k / ts^k).
fn assert_limits(s: &Samples, m: &Machine) {
    for (i, ax) in m.axes.iter().enumerate() {
        let p = peaks(s, i);
        let lim = [
            ax.max_velocity.unwrap(),
            ax.max_acceleration.unwrap(),
            ax.max_jerk.unwrap(),
        ];
        for k in 0..3 {
            let round = 2f64.powi(k as i32 + 1) * 1e-9 / TS.powi(k as i32 + 1);
            assert!(
                p[k] <= lim[k] * (1.0 + 1e-6) + round,
                "axis {}: derivative {} peaks at {} > limit {}",
                ax.name,
                k + 1,
                p[k],
                lim[k]
            );
        }
    }
}

/// Rest at both ends: from rest with jerk at most J the first step moves at
/// most J·ts³/6; the last two samples (the end held) likewise.
fn assert_rest(s: &Samples, m: &Machine) {
    let n = s.len();
    assert!(n >= 3);
    for (i, ax) in m.axes.iter().enumerate() {
        let bound = ax.max_jerk.unwrap() * TS.powi(3) / 6.0 + 1e-9;
        assert!((s[1].1[i] - s[0].1[i]).abs() <= bound, "start not at rest");
        assert!(
            (s[n - 1].1[i] - s[n - 2].1[i]).abs() <= bound,
            "end not at rest"
        );
    }
}

/// A programmed move in XYZ: a line or an arc in the XY plane (Z linear).
#[derive(Debug, Clone)]
enum Seg {
    Line(Vector3<f64>, Vector3<f64>),
    /// Centre (x, y), radius, start angle, signed sweep, z from and to.
    Arc {
        c: [f64; 2],
        r: f64,
        a0: f64,
        sweep: f64,
        z: [f64; 2],
    },
}

impl Seg {
    /// The segment as a polyline: a line is its two ends; an arc the helix
    /// sampled at 2000 points per radian (the arcs here are planar or
    /// short), its chords within 1e-7 mm of the arc for radii up to 8 mm.
    fn polyline(&self) -> Vec<Vector3<f64>> {
        match self {
            Seg::Line(a, b) => vec![*a, *b],
            Seg::Arc { c, r, a0, sweep, z } => {
                let n = ((sweep.abs() * 2000.0).ceil() as usize).max(2);
                (0..=n)
                    .map(|k| {
                        let u = k as f64 / n as f64;
                        let ang = a0 + sweep * u;
                        Vector3::new(
                            c[0] + r * ang.cos(),
                            c[1] + r * ang.sin(),
                            z[0] + (z[1] - z[0]) * u,
                        )
                    })
                    .collect()
            }
        }
    }
}

/// Distance of `p` from the segment `a`–`b`.
fn off_chord(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = b - a;
    let t = if d.norm_squared() > 0.0 {
        ((p - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + d * t)).norm()
}

/// Chords per block of [`Path`].
const BLOCK: usize = 32;

/// The programmed path (lines and arcs, see [`Seg::polyline`]) for many
/// distance queries: the chords of every segment, in blocks of [`BLOCK`]
/// with a ball around each (a chord lies in the convex hull of its ends,
/// so in the ball around them). [`Path::dist`] is the smallest distance to
/// any chord, as a scan of them all gives it: a block is skipped only when
/// its ball is farther than the nearest chord found so far.
struct Path {
    /// Polylines of the segments.
    lines: Vec<Vec<Vector3<f64>>>,
    /// Blocks: segment, first chord, chord count, ball centre and radius.
    blocks: Vec<(usize, usize, usize, Vector3<f64>, f64)>,
}

impl Path {
    fn new(segs: &[Seg]) -> Path {
        let lines: Vec<Vec<Vector3<f64>>> = segs.iter().map(Seg::polyline).collect();
        let mut blocks = Vec::new();
        for (i, l) in lines.iter().enumerate() {
            let chords = l.len() - 1;
            for k0 in (0..chords).step_by(BLOCK) {
                let n = BLOCK.min(chords - k0);
                let pts = &l[k0..=k0 + n];
                let c = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
                let r = pts.iter().map(|q| (q - c).norm()).fold(0.0, f64::max);
                blocks.push((i, k0, n, c, r));
            }
        }
        Path { lines, blocks }
    }

    /// Distance of `p` from the path, mm.
    fn dist(&self, p: &Vector3<f64>) -> f64 {
        // Nearest balls first; the bound is kept 1e-9 mm on the safe side
        // of rounding.
        let mut order: Vec<(f64, usize)> = self
            .blocks
            .iter()
            .enumerate()
            .map(|(b, blk)| ((p - blk.3).norm() - blk.4 - 1e-9, b))
            .collect();
        order.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut best = f64::INFINITY;
        for (bound, b) in order {
            if bound >= best {
                break;
            }
            let (i, k0, n, _, _) = self.blocks[b];
            let l = &self.lines[i];
            for k in k0..k0 + n {
                best = best.min(off_chord(p, &l[k], &l[k + 1]));
            }
        }
        best
    }
}

/// [`Path::dist`] skips blocks of chords by their balls: it gives what a
/// scan of every chord gives, exactly, at points on, near and far from a
/// line, a planar arc and helical arcs of both senses.
#[test]
fn path_distance_is_the_scan_of_every_chord() {
    let segs = [
        Seg::Line(Vector3::new(-3.0, 1.0, 0.0), Vector3::new(7.0, -2.0, 4.0)),
        Seg::Arc {
            c: [1.0, 2.0],
            r: 6.5,
            a0: 0.3,
            sweep: 2.9,
            z: [1.0, 1.0],
        },
        Seg::Arc {
            c: [-4.0, 0.5],
            r: 1.2,
            a0: -2.0,
            sweep: -3.1,
            z: [0.0, 9.0],
        },
    ];
    let path = Path::new(&segs);
    let lines: Vec<Vec<Vector3<f64>>> = segs.iter().map(Seg::polyline).collect();
    let scan = |p: &Vector3<f64>| {
        lines
            .iter()
            .flat_map(|l| l.windows(2).map(|w| off_chord(p, &w[0], &w[1])))
            .fold(f64::INFINITY, f64::min)
    };
    let mut n = 0;
    for i in 0..=20 {
        for j in 0..=20 {
            for k in 0..=6 {
                let p = Vector3::new(
                    -9.0 + 0.85 * i as f64,
                    -6.0 + 0.8 * j as f64,
                    -1.0 + 1.7 * k as f64,
                );
                assert_eq!(path.dist(&p), scan(&p), "at {p:?}");
                n += 1;
            }
        }
    }
    // Points on the chords' ends: distance zero.
    for l in &lines {
        for q in l.iter().step_by(97) {
            assert_eq!(path.dist(q), 0.0);
            n += 1;
        }
    }
    assert!(n > 3000);
}

/// A random short program: from (x0, y0, z0), moves of kinds 0 (G1), 1 (G0),
/// 2 (G2/G3 arc in XY about a centre at (i, j) from the start, sweeping
/// `sw` rad); feeds in mm/min; `rot` adds A and C words (5-axis).
#[allow(clippy::type_complexity)]
fn program(
    start: [f64; 3],
    moves: &[(u8, [f64; 3], [f64; 2], f64, [f64; 2])],
    rot: bool,
) -> (String, Vec<Seg>) {
    let mut text = String::new();
    if rot {
        text.push_str("M428\n");
    }
    text.push_str(&format!(
        "G0 X{:.4} Y{:.4} Z{:.4}{}\n",
        start[0],
        start[1],
        start[2],
        if rot { " A0 C0" } else { "" }
    ));
    let mut p = Vector3::new(start[0], start[1], start[2]);
    // Numbers as written (4 decimals), so the path checked is the program's.
    let r4 = |x: f64| (x * 1e4).round() / 1e4;
    let p0 = p.map(r4);
    p = p0;
    let mut segs = Vec::new();
    for &(kind, to, ij, feed, ac) in moves {
        let rw = if rot {
            format!(" A{:.4} C{:.4}", ac[0], ac[1])
        } else {
            String::new()
        };
        match kind {
            0 | 1 => {
                let q = Vector3::new(r4(to[0]), r4(to[1]), r4(to[2]));
                if kind == 0 {
                    text.push_str(&format!(
                        "G1 X{:.4} Y{:.4} Z{:.4}{rw} F{:.1}\n",
                        q.x, q.y, q.z, feed
                    ));
                } else {
                    text.push_str(&format!("G0 X{:.4} Y{:.4} Z{:.4}{rw}\n", q.x, q.y, q.z));
                }
                segs.push(Seg::Line(p, q));
                p = q;
            }
            _ => {
                let (i, j) = (r4(ij[0]), r4(ij[1]));
                let c = [p.x + i, p.y + j];
                let r = i.hypot(j);
                let a0 = (-j).atan2(-i);
                let sw = to[0];
                let a1 = a0 + sw;
                let q = Vector3::new(r4(c[0] + r * a1.cos()), r4(c[1] + r * a1.sin()), r4(to[2]));
                text.push_str(&format!(
                    "{} X{:.4} Y{:.4} Z{:.4} I{i:.4} J{j:.4}{rw} F{:.1}\n",
                    if sw < 0.0 { "G2" } else { "G3" },
                    q.x,
                    q.y,
                    q.z,
                    feed
                ));
                // The end as written lies off the circle by < 1e-4 mm: the
                // interpreter's arc (radius blended from start to end) stays
                // within that of the circle of the start radius.
                segs.push(Seg::Arc {
                    c,
                    r,
                    a0,
                    sweep: sw,
                    z: [p.z, q.z],
                });
                p = q;
            }
        }
    }
    (text, segs)
}

/// Tolerance of the tool path under G64 with the default step of 0.1 mm: a
/// corner is rounded by the joint spline through points at most a step apart
/// by at most a quarter step; 2e-4 mm more for the written numbers (arc
/// ends rounded to 1e-4 mm).
const PATH_TOL: f64 = 0.1 / 4.0 + 2e-4;

/// One random move of `moves_strategy`, as `program` reads it: kind (0 G1,
/// 1 G0, 2 arc; for an arc the first coordinate is the sweep), XYZ, arc
/// centre offset IJ, feed (mm/min), A C.
type RandomMove = (u8, [f64; 3], [f64; 2], f64, [f64; 2]);

fn moves_strategy() -> impl Strategy<Value = Vec<RandomMove>> {
    prop::collection::vec(
        (
            0u8..3,
            [-20.0..20.0f64, -20.0..20.0f64, 0.0..20.0f64],
            [-8.0..8.0f64, -8.0..8.0f64],
            120.0..6000.0f64,
            [-30.0..30.0f64, -90.0..90.0f64],
        )
            .prop_filter(
                "arc radius ≥ 1 mm and sweep ≥ 0.2 rad",
                |(k, to, ij, _, _)| *k != 2 || (ij[0].hypot(ij[1]) >= 1.0 && to[0].abs() >= 0.2),
            )
            .prop_map(|(k, mut to, ij, f, ac)| {
                if k == 2 {
                    // An arc's first coordinate is its sweep: ±(0.2..π) rad.
                    to[0] = to[0].signum() * (0.2 + (to[0].abs() / 20.0) * 2.9);
                }
                (k, to, ij, f, ac)
            }),
        1..5,
    )
}

/// `prog` under `G64 P<p>` when `p` is given (in its first block, so the
/// line numbers stay), and the path tolerance then: P, or the spline's
/// rounding of the corners not blended (reversals) where that is larger.
fn with_tolerance(prog: &str, p: Option<f64>) -> (String, f64) {
    match p {
        Some(p) => (format!("G64 P{p} {prog}"), p.max(PATH_TOL - 2e-4) + 2e-4),
        None => (prog.to_string(), PATH_TOL),
    }
}

fn check_program(prog: &str, segs: &[Seg], m: &Machine, tcp: bool, first_line: u64, tol: f64) {
    let (s, _) = run_jerk(prog, m, 0.1).unwrap_or_else(|e| panic!("{e}\n{prog}"));
    assert_limits(&s, m);
    assert_rest(&s, m);
    let kin = Kinematics::nominal(m);
    let path = Path::new(segs);
    let mut worst = 0.0f64;
    for (_, q, line) in &s {
        // Samples of the programmed moves (not the initial positioning).
        if *line < first_line {
            continue;
        }
        let tip = if tcp {
            kin.pose(q).tip
        } else {
            Vector3::new(q[0], q[1], q[2])
        };
        worst = worst.max(path.dist(&tip));
    }
    assert!(
        worst <= tol,
        "path off by {worst} mm (tolerance {tol})\n{prog}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn random_programs_on_three_axes_keep_every_limit_and_the_path(
        start in [-20.0..20.0f64, -20.0..20.0f64, 0.0..20.0f64],
        moves in moves_strategy(),
        p in prop::option::of(prop::sample::select(vec![0.05, 0.3, 1.0])),
    ) {
        let m = xyz(50.0, 500.0, 10000.0);
        let (prog, segs) = program(start, &moves, false);
        let (prog, tol) = with_tolerance(&prog, p);
        // Line 1 is the rapid to the start, part of the path too.
        let mut all = vec![Seg::Line(Vector3::zeros(), Vector3::new(
            (start[0] * 1e4).round() / 1e4, (start[1] * 1e4).round() / 1e4,
            (start[2] * 1e4).round() / 1e4))];
        all.extend(segs);
        check_program(&prog, &all, &m, false, 1, tol);
    }

    #[test]
    fn random_tcp_programs_on_five_axes_keep_every_limit_and_the_path(
        start in [-20.0..20.0f64, -20.0..20.0f64, 0.0..20.0f64],
        moves in moves_strategy(),
        p in prop::option::of(prop::sample::select(vec![0.05, 0.3, 1.0])),
    ) {
        let m = trunnion();
        let (prog, segs) = program(start, &moves, true);
        let (prog, tol) = with_tolerance(&prog, p);
        // Line 2 (the first rapid after M428) goes straight in axis space,
        // off the programmed path by design: checked from line 3 on.
        check_program(&prog, &segs, &m, true, 3, tol);
    }
}

#[test]
fn g61_stops_at_corners_and_g61_1_at_every_block() {
    // Two perpendicular 10 mm moves on axes with equal limits. Stopping at
    // the corner makes two rest-to-rest motions, each as long as one move
    // planned alone.
    let m = xyz(50.0, 500.0, 10000.0);
    let alone = run_jerk("G1 X10 F6000\n", &m, 0.1).unwrap().1.duration;
    for mode in ["G61", "G61.1"] {
        let prog = format!("{mode}\nG1 X10 F6000\nY10\n");
        let (s, sum) = run_jerk(&prog, &m, 0.1).unwrap();
        assert!(
            (sum.duration - 2.0 * alone).abs() < 1e-9,
            "{mode}: {}",
            sum.duration
        );
        // The machine passes the corner at rest: the sample nearest to that
        // moment (within ts) is within j·ts³/6 of the corner.
        let near = s
            .iter()
            .map(|r| (r.1[0] - 10.0).hypot(r.1[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(near <= 10000.0 * TS.powi(3) / 6.0 + 1e-9, "{mode}: {near}");
    }
    // Collinear blocks under G61 run through without stopping: faster.
    let (_, through) = run_jerk("G61\nG1 X10 F6000\nX20\n", &m, 0.1).unwrap();
    assert!(through.duration < 0.9 * 2.0 * alone, "{}", through.duration);
}

#[test]
fn a_machine_without_max_jerk_is_refused_naming_the_axis_and_key() {
    let mut m = xyz(50.0, 500.0, 10000.0);
    m.axes[1].max_jerk = None;
    let mut opts = InterpolateOptions::new(TS);
    opts.plan = PlanOptions::new(Planner::Jerk);
    let e = interpolate(b"G1 X10 F600\n".as_slice(), &m, &opts, |_| Ok(())).unwrap_err();
    assert!(
        matches!(e, InterpolateError::MissingLimit { ref axis, key: "max_jerk", .. } if axis == "Y"),
        "{e}"
    );
    assert!(e.to_string().contains("`max_jerk`"), "{e}");
}

/// The boat program (M428 TCP, 5 axes) under `--planner jerk` with
/// LinuxCNC's xyzac-trt limits (X Y Z 20 mm/s, 300 mm/s²; A C 30 deg/s,
/// 300 deg/s²; `rapid_feed` 2100 mm/min) and jerk limits of 3000 mm/s³ and
/// 3000 deg/s³: every joint within its limits at every 1 ms sample, rest at
/// both ends, and no faster than the programmed feeds allow.
///
/// One chain of 71 543 points, 5585 mm and 885 s: the sampled positions
/// must be free of rounding noise at that scale (the filtered position is
/// computed relative to a nearby piece start, the time rounded once inside
/// the profile), which the third differences amplify by 1/ts³ = 1e9.
#[test]
fn boat_under_jerk_limits() {
    let Some(dir) = crate::shared::shared_dir("corpus/gcode/linuxcnc") else {
        return;
    };
    let text = std::fs::read_to_string(dir.join("boat-xyzac.ngc")).unwrap();
    let m = boat_machine();
    let st = mtwin::gcode::stats(text.as_bytes(), &{
        let mut o = mtwin::gcode::StatsOptions::default();
        o.rapid_feed = m.rapid_feed;
        o
    })
    .unwrap();
    let (s, sum) = run_jerk(&text, &m, 0.1).unwrap();
    eprintln!(
        "boat jerk: {:.3} s ({} samples, programmed {:.3} s)",
        sum.duration,
        s.len(),
        st.feed_time + st.rapid_time
    );
    for (i, ax) in m.axes.iter().enumerate() {
        eprintln!("  {}: v a j peaks {:?}", ax.name, peaks(&s, i));
    }
    assert_limits(&s, &m);
    assert_rest(&s, &m);
    assert!(sum.duration >= st.feed_time);
    // For docs/gcode.md: the same machine stopping at every block.
    let mut o = InterpolateOptions::new(TS);
    o.plan = PlanOptions::new(Planner::ExactStop);
    let stop = mtwin::gcode::planned_duration(text.as_bytes(), &m, &o).unwrap();
    eprintln!("boat exact-stop: {stop:.3} s");
    assert!(stop >= st.feed_time);
}

/// The example trunnion with LinuxCNC's xyzac-trt limits and jerk 3000 /s³.
fn boat_machine() -> Machine {
    let mut m = crate::common::linuxcnc_trunnion();
    for a in m.axes.iter_mut() {
        a.max_jerk = Some(3000.0);
    }
    m
}

/// Distance of the point (x, y) from the programmed corner path
/// (0,0)–(10,0)–(10,10).
fn corner_path_distance(x: f64, y: f64) -> f64 {
    let d1 = (x.clamp(0.0, 10.0) - x).hypot(y);
    let d2 = (x - 10.0).hypot(y.clamp(0.0, 10.0) - y);
    d1.min(d2)
}

#[test]
fn g64_corner_blend_is_never_slower_than_stopping_and_stays_within_p() {
    // Two perpendicular 10 mm moves; 50 mm/s, 500 mm/s², 10 000 mm/s³.
    // Under G61 the machine stops at the corner (two rest-to-rest moves of
    // L/v + v/a + a/j = 0.35 s each). Under G64 a blend curve within the
    // tolerance (P, or a quarter of the dense step without P) replaces the
    // corner where that is faster than stopping: never slower than G61,
    // faster where it blends, every joint within its limits, the tool
    // within P of the programmed path.
    let m = xyz(50.0, 500.0, 10000.0);
    let g61 = run_jerk("G61\nG1 X10 F6000\nY10\n", &m, 0.1)
        .unwrap()
        .1
        .duration;
    assert!((g61 - 2.0 * (10.0 / 50.0 + 50.0 / 500.0 + 500.0 / 10000.0)).abs() < 1e-9);
    let mut blended = Vec::new();
    for (mode, tol) in [
        ("G64", 0.025),
        ("G64 P0.01", 0.01),
        ("G64 P0.2", 0.2),
        ("G64 P1", 1.0),
        ("G64 P2", 2.0),
    ] {
        let (s, sum) = run_jerk(&format!("{mode}\nG1 X10 F6000\nY10\n"), &m, 0.1).unwrap();
        let worst = s
            .iter()
            .map(|r| corner_path_distance(r.1[0], r.1[1]))
            .fold(0.0f64, f64::max);
        // Blended: the tool never comes nearer the corner point than the
        // blend's middle (at least a tenth of P away); stopped: it rests there.
        let nearest = s
            .iter()
            .map(|r| (r.1[0] - 10.0).hypot(r.1[1]))
            .fold(f64::INFINITY, f64::min);
        let blend = nearest > 0.1 * tol;
        eprintln!(
            "{mode}: {:.4} s against G61 {g61:.4} s; {}; farthest from the path {worst:.6} mm (P {tol})",
            sum.duration,
            if blend { "blended" } else { "stopped" }
        );
        assert!(
            sum.duration <= g61 + 1e-9,
            "{mode}: {} s > G61 {g61} s",
            sum.duration
        );
        if blend {
            assert!(sum.duration < g61, "{mode}: blended in {} s", sum.duration);
            blended.push(mode);
        } else {
            assert!(
                (sum.duration - g61).abs() < 1e-9,
                "{mode}: stopped in {} s",
                sum.duration
            );
        }
        assert_limits(&s, &m);
        assert_rest(&s, &m);
        assert!(
            worst <= tol * (1.0 + 1e-3),
            "{mode}: {worst} mm from the path"
        );
    }
    assert!(blended.contains(&"G64 P2"), "blended: {blended:?}");
}

/// One G64 corner next to an arc, as a program and its programmed moves.
struct ArcCorner {
    name: &'static str,
    /// The moves after `G1 X0 Y0` (from the origin), without the mode.
    moves: &'static str,
    segs: Vec<Seg>,
    /// The corner point.
    corner: [f64; 2],
}

fn arc_corners() -> Vec<ArcCorner> {
    use std::f64::consts::{FRAC_PI_2, PI};
    let line = |a: [f64; 2], b: [f64; 2]| {
        Seg::Line(Vector3::new(a[0], a[1], 0.0), Vector3::new(b[0], b[1], 0.0))
    };
    let arc = |c: [f64; 2], r: f64, a0: f64, sweep: f64| Seg::Arc {
        c,
        r,
        a0,
        sweep,
        z: [0.0, 0.0],
    };
    vec![
        // +X to (10, 0), then clockwise about (30, 0) up to (30, 20): a
        // right angle from +X to +Y.
        ArcCorner {
            name: "line-arc",
            moves: "G1 X10 F6000\nG2 X30 Y20 I20 J0\n",
            segs: vec![
                line([0.0, 0.0], [10.0, 0.0]),
                arc([30.0, 0.0], 20.0, PI, -FRAC_PI_2),
            ],
            corner: [10.0, 0.0],
        },
        // Counter-clockwise about (0, 20) from the origin to (20, 20),
        // leaving along +Y, then a line along +X: a right angle.
        ArcCorner {
            name: "arc-line",
            moves: "G3 X20 Y20 I0 J20 F6000\nG1 X30\n",
            segs: vec![
                arc([0.0, 20.0], 20.0, -FRAC_PI_2, FRAC_PI_2),
                line([20.0, 20.0], [30.0, 20.0]),
            ],
            corner: [20.0, 20.0],
        },
        // Clockwise about (20, 0) to (20, 20) arriving along +X, then
        // counter-clockwise about (0, 20) leaving along +Y: a right angle
        // between two arcs.
        ArcCorner {
            name: "arc-arc",
            moves: "G2 X20 Y20 I20 J0 F6000\nG3 X0 Y40 I-20 J0\n",
            segs: vec![
                arc([20.0, 0.0], 20.0, PI, -FRAC_PI_2),
                arc([0.0, 20.0], 20.0, 0.0, FRAC_PI_2),
            ],
            corner: [20.0, 20.0],
        },
    ]
}

#[test]
fn g64_blends_next_to_arcs_are_never_slower_than_stopping_and_stay_within_p() {
    // A line into an arc, an arc into a line and two arcs, each meeting at
    // a right angle; 50 mm/s, 500 mm/s², 10 000 mm/s³. Under G61 the
    // machine stops at the corner; under G64 the blend (C² with both
    // moves) replaces it where that is faster: never slower than G61 with
    // the same dense step (`G64 P` makes it at most 4·P; on an arc a finer
    // step alone changes the time, as the spline's ends at a stop differ),
    // faster where it blends, every joint within its limits at every
    // sample (finite differences), and every sample within P of the
    // programmed line and arc (distances computed here from the geometry).
    let m = xyz(50.0, 500.0, 10000.0);
    let mut any_blend = false;
    for c in arc_corners() {
        let mut blended = Vec::new();
        for (mode, tol) in [
            ("G64", 0.025),
            ("G64 P0.01", 0.01),
            ("G64 P0.2", 0.2),
            ("G64 P1", 1.0),
            ("G64 P2", 2.0),
        ] {
            let (s, sum) = run_jerk(&format!("{mode}\n{}", c.moves), &m, 0.1).unwrap();
            let step = if mode == "G64" {
                0.1
            } else {
                f64::min(4.0 * tol, 0.1)
            };
            let g61 = run_jerk(&format!("G61\n{}", c.moves), &m, step)
                .unwrap()
                .1
                .duration;
            let path = Path::new(&c.segs);
            let worst = s
                .iter()
                .map(|r| path.dist(&Vector3::new(r.1[0], r.1[1], r.1[2])))
                .fold(0.0f64, f64::max);
            let nearest = s
                .iter()
                .map(|r| (r.1[0] - c.corner[0]).hypot(r.1[1] - c.corner[1]))
                .fold(f64::INFINITY, f64::min);
            // Stopped: as G61, at rest at the corner point (a sample within
            // J ts³ / 6 = 1.7e-6 mm of it).
            let blend = sum.duration < g61 - 1e-9;
            eprintln!(
                "{} {mode}: {:.4} s against G61 {g61:.4} s; {}; farthest from the path \
                 {worst:.6} mm, nearest the corner {nearest:.4} mm (P {tol})",
                c.name,
                sum.duration,
                if blend { "blended" } else { "stopped" }
            );
            if !blend {
                assert!(nearest < 1e-5, "{} {mode}: {nearest}", c.name);
            }
            assert!(
                sum.duration <= g61 + 1e-9,
                "{} {mode}: {} s > G61 {g61} s",
                c.name,
                sum.duration
            );
            if blend {
                assert!(
                    sum.duration < g61,
                    "{} {mode}: blended in {} s",
                    c.name,
                    sum.duration
                );
                blended.push(mode);
            } else {
                assert!((sum.duration - g61).abs() < 1e-9, "{} {mode}", c.name);
            }
            assert_limits(&s, &m);
            assert_rest(&s, &m);
            assert!(
                worst <= tol * (1.0 + 1e-3),
                "{} {mode}: {worst} mm from the path",
                c.name
            );
        }
        eprintln!("{}: blended under {blended:?}", c.name);
        any_blend |= !blended.is_empty();
    }
    assert!(any_blend, "no corner next to an arc blended");
}
