use super::*;
use proptest::prelude::*;

/// Time of a jerk-limited velocity change by `dv ≥ 0` starting and ending
/// at zero acceleration (closed form of the S-curve).
fn ramp_time(dv: f64, a: f64, j: f64) -> f64 {
    if dv <= 0.0 {
        0.0
    } else if dv >= a * a / j {
        dv / a + a / j
    } else {
        2.0 * (dv / j).sqrt()
    }
}

/// Shortest time over `d` from `v0` to `v1` under the speed cap `cap`, with
/// zero acceleration at both ends: accelerate to a peak, cruise,
/// decelerate (the peak found by bisection on the distance). `None` when
/// even the lowest peak needs more than `d`.
fn segment_time(d: f64, v0: f64, v1: f64, cap: f64, a: f64, j: f64) -> Option<f64> {
    let dist = |vp: f64| {
        (v0 + vp) / 2.0 * ramp_time(vp - v0, a, j) + (vp + v1) / 2.0 * ramp_time(vp - v1, a, j)
    };
    let lo0 = v0.max(v1);
    if dist(lo0) > d * (1.0 + 1e-12) {
        return None;
    }
    let (mut lo, mut hi) = (lo0, cap);
    if dist(hi) <= d {
        lo = hi;
    } else {
        for _ in 0..100 {
            let m = 0.5 * (lo + hi);
            if dist(m) <= d {
                lo = m;
            } else {
                hi = m;
            }
        }
    }
    let vp = lo;
    if vp <= 0.0 {
        return None;
    }
    Some(ramp_time(vp - v0, a, j) + ramp_time(vp - v1, a, j) + (d - dist(vp)).max(0.0) / vp)
}

/// Closed-form rest-to-rest time of the optimal 7-phase profile.
fn seven_phase_time(d: f64, v: f64, a: f64, j: f64) -> f64 {
    segment_time(d, 0.0, 0.0, v, a, j).unwrap()
}

fn limits(v: &[f64], a: &[f64], j: &[f64]) -> JointLimits {
    JointLimits {
        v: v.to_vec(),
        a: a.to_vec(),
        j: j.to_vec(),
    }
}

/// Chord-length parameter of a polyline of `n` joints.
fn chord(n: usize, q: &[f64]) -> Vec<f64> {
    let mut s = vec![0.0];
    for k in 1..q.len() / n {
        let d: f64 = (0..n)
            .map(|i| (q[k * n + i] - q[(k - 1) * n + i]).powi(2))
            .sum::<f64>()
            .sqrt();
        s.push(s[k - 1] + d);
    }
    s
}

/// Checks every joint's velocity, acceleration and jerk by finite
/// differences of the positions sampled at `ts` (with the rest before the
/// start and after the end), and rest at both ends.
///
/// Tolerance: the law is C² in t, so the k-th difference divided by `ts^k`
/// is a weighted mean of the k-th derivative and never exceeds its
/// maximum; what is left is rounding of the sampled positions, bounded by
/// `δ = 64 ε (max|q| + G (L + L T / T_j))` with `G` a bound on `|dq/ds|`
/// (the cumulative integral behind the filtered `s` has size `L T`, divided
/// by `T_j`); the k-th difference of values off by `δ` is off by at most
/// `2^k δ`.
fn check(path: &JointPath, lim: &JointLimits, law: &TimeLaw, ts: f64) {
    let n = path.joints();
    let q = law.sample(ts);
    let count = q.len() / n;
    let mut rows: Vec<&[f64]> = Vec::with_capacity(count + 6);
    for _ in 0..3 {
        rows.push(&q[..n]);
    }
    for k in 0..count {
        rows.push(&q[k * n..(k + 1) * n]);
    }
    for _ in 0..3 {
        rows.push(&q[(count - 1) * n..]);
    }
    // Rest at both ends, at the first and last point.
    for i in 0..n {
        assert!((q[i] - path.q(0)[i]).abs() <= 1e-9 * (1.0 + path.q(0)[i].abs()));
        let last = path.q(path.points() - 1)[i];
        assert!(
            (q[(count - 1) * n + i] - last).abs() <= 1e-9 * (1.0 + last.abs()),
            "joint {i} ends at {} not {last}",
            q[(count - 1) * n + i]
        );
    }
    let t_end = law.duration();
    let vmax = (0..=100)
        .map(|k| law.ds_dt(t_end * k as f64 / 100.0))
        .fold(0.0, f64::max);
    assert_eq!(law.ds_dt(0.0), 0.0);
    assert_eq!(law.d2s_dt2(0.0), 0.0);
    assert!(law.ds_dt(t_end).abs() <= 1e-9 * vmax.max(1.0));
    assert!(law.d2s_dt2(t_end).abs() <= 1e-6 * vmax.max(1.0));
    let s = path.s();
    let l = s[s.len() - 1] - s[0];
    assert!((law.s(t_end + 1.0) - s[s.len() - 1]).abs() <= 1e-9 * (1.0 + l));
    let qmax = q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut g = 0.0f64;
    for k in 1..path.points() {
        for i in 0..n {
            g = g.max((path.q(k)[i] - path.q(k - 1)[i]).abs() / (s[k] - s[k - 1]));
        }
    }
    let g = 4.0 * g + 1.0;
    let tj = law.filter_time().max(1e-6);
    let delta = 64.0 * f64::EPSILON * (qmax + g * (l + l * t_end / tj));
    let mut worst = [0.0f64; 3];
    for i in 0..n {
        for w in rows.windows(4) {
            let (q0, q1, q2, q3) = (w[0][i], w[1][i], w[2][i], w[3][i]);
            let d1 = (q1 - q0) / ts;
            let d2 = (q2 - 2.0 * q1 + q0) / (ts * ts);
            let d3 = (q3 - 3.0 * q2 + 3.0 * q1 - q0) / (ts * ts * ts);
            let lims = [lim.v[i], lim.a[i], lim.j[i]];
            let tols = [
                2.0 * delta / ts,
                4.0 * delta / ts.powi(2),
                8.0 * delta / ts.powi(3),
            ];
            for (c, (d, (li, tol))) in [d1, d2, d3].iter().zip(lims.iter().zip(tols)).enumerate() {
                if li.is_finite() {
                    worst[c] = worst[c].max(d.abs() / li);
                    assert!(
                        d.abs() <= li * (1.0 + 1e-9) + tol,
                        "joint {i}: derivative {} is {d}, limit {li} (tolerance {tol})",
                        c + 1
                    );
                }
            }
        }
    }
}

#[test]
fn single_axis_straight_move_takes_the_closed_form_7_phase_time() {
    // (length, v, a, j): cruise reached; no cruise but a reached.
    for (d, v, a, j) in [
        (100.0, 50.0, 500.0, 10000.0),
        (300.0, 200.0, 2000.0, 40000.0),
        (2.0, 50.0, 500.0, 10000.0),
        (10.0, 1000.0, 500.0, 20000.0),
    ] {
        let path = JointPath::new(1, vec![0.0, d], vec![5.0, 5.0 + d], vec![v, v]).unwrap();
        let lim = limits(&[f64::INFINITY], &[a], &[j]);
        let law = plan(&path, &lim, &JerkOptions::default()).unwrap();
        let best = seven_phase_time(d, v, a, j);
        let t = law.duration();
        assert!(
            t >= best * (1.0 - 1e-9) && t <= best * 1.01,
            "{d} mm at v {v} a {a} j {j}: {t} s against the optimum {best} s"
        );
        check(&path, &lim, &law, 1e-3);
    }
}

#[test]
fn multi_joint_straight_move_takes_the_tangential_closed_form_time() {
    // Direction u; the tangential limits are min over joints of limit/|u_i|.
    let u = [0.6, -0.8, 0.0];
    let (v, a, j) = (
        [100.0, 60.0, 10.0],
        [800.0, 1000.0, 50.0],
        [20000.0, 10000.0, 100.0],
    );
    let d = 150.0;
    let q = vec![1.0, 2.0, 3.0, 1.0 + d * u[0], 2.0 + d * u[1], 3.0];
    let path = JointPath::new(3, vec![0.0, d], q, vec![f64::INFINITY; 2]).unwrap();
    let lim = limits(&v, &a, &j);
    let law = plan(&path, &lim, &JerkOptions::default()).unwrap();
    let vt = (v[0] / 0.6f64).min(v[1] / 0.8);
    let at = (a[0] / 0.6f64).min(a[1] / 0.8);
    let jt = (j[0] / 0.6f64).min(j[1] / 0.8);
    let best = seven_phase_time(d, vt, at, jt);
    let t = law.duration();
    assert!(
        t >= best * (1.0 - 1e-9) && t <= best * 1.01,
        "{t} against {best}"
    );
    check(&path, &lim, &law, 1e-3);
}

/// Brute force over the junction speeds of collinear segments with
/// different feeds: the best sum of segment times, each the optimal
/// accelerate–cruise–decelerate between the junction speeds (zero
/// acceleration at a junction is optimal: arriving at the lower cap while
/// still slowing down would dip below it).
fn brute_force(lengths: &[f64], caps: &[f64], a: f64, j: f64) -> f64 {
    fn go(k: usize, v0: f64, lengths: &[f64], caps: &[f64], a: f64, j: f64, steps: usize) -> f64 {
        let last = k + 1 == lengths.len();
        if last {
            return segment_time(lengths[k], v0, 0.0, caps[k], a, j).unwrap_or(f64::INFINITY);
        }
        let top = caps[k].min(caps[k + 1]);
        let mut best = f64::INFINITY;
        for i in 0..=steps {
            let vj = top * i as f64 / steps as f64;
            let Some(t) = segment_time(lengths[k], v0, vj, caps[k], a, j) else {
                continue;
            };
            best = best.min(t + go(k + 1, vj, lengths, caps, a, j, steps));
        }
        best
    }
    let steps = if lengths.len() > 2 { 300 } else { 4000 };
    go(0, 0.0, lengths, caps, a, j, steps)
}

#[test]
fn collinear_feed_changes_within_one_percent_of_the_brute_force_optimum() {
    let (a, j) = (1000.0, 20000.0);
    for (lengths, caps) in [
        (vec![200.0, 100.0], vec![100.0, 40.0]),
        (vec![60.0, 200.0], vec![30.0, 120.0]),
        (vec![150.0, 40.0, 150.0], vec![100.0, 25.0, 80.0]),
        (vec![30.0, 30.0, 30.0], vec![40.0, 80.0, 40.0]),
    ] {
        let mut s = vec![0.0];
        for l in &lengths {
            s.push(s.last().unwrap() + l);
        }
        // A point's cap holds on the interval arriving at it.
        let mut cap = vec![caps[0]];
        cap.extend_from_slice(&caps);
        let path = JointPath::new(1, s.clone(), s.clone(), cap).unwrap();
        let lim = limits(&[f64::INFINITY], &[a], &[j]);
        let law = plan(&path, &lim, &JerkOptions::default()).unwrap();
        let best = brute_force(&lengths, &caps, a, j);
        let t = law.duration();
        assert!(
            t >= best * (1.0 - 1e-3) && t <= best * 1.01,
            "{lengths:?} at {caps:?}: {t} s against the brute-force {best} s"
        );
        check(&path, &lim, &law, 1e-3);
        // The feed caps hold along the path.
        for k in 0..2000 {
            let t = law.duration() * k as f64 / 2000.0;
            let (sv, v) = (law.s(t), law.ds_dt(t));
            let seg = s.partition_point(|x| *x <= sv).clamp(1, lengths.len()) - 1;
            assert!(
                v <= caps[seg] * (1.0 + 1e-9),
                "{v} at s = {sv} over {}",
                caps[seg]
            );
        }
    }
}

#[test]
fn collinear_points_stay_on_the_line() {
    let q = vec![0.0, 0.0, 1.0, 2.0, 1.5, 3.0, 7.0, 14.0];
    let s = chord(2, &q);
    let path = JointPath::new(2, s, q, vec![20.0; 4]).unwrap();
    let lim = limits(&[50.0, 50.0], &[500.0, 500.0], &[5000.0, 5000.0]);
    let law = plan(&path, &lim, &JerkOptions::default()).unwrap();
    let p = law.sample(0.01);
    for r in p.chunks(2) {
        assert!((r[1] - 2.0 * r[0]).abs() < 1e-9, "{r:?} is off y = 2x");
    }
    check(&path, &lim, &law, 1e-3);
}

#[test]
fn options_scale_the_limits_and_bad_input_is_refused() {
    let path = JointPath::new(1, vec![0.0, 50.0], vec![0.0, 50.0], vec![40.0; 2]).unwrap();
    let lim = limits(&[f64::INFINITY], &[400.0], &[8000.0]);
    let opts = JerkOptions {
        limit_fraction: 0.5,
        ..JerkOptions::default()
    };
    let law = plan(&path, &lim, &opts).unwrap();
    let best = seven_phase_time(50.0, 40.0, 200.0, 4000.0);
    assert!((law.duration() - best).abs() <= 1e-9 * best);
    check(
        &path,
        &limits(&[f64::INFINITY], &[200.0], &[4000.0]),
        &law,
        1e-3,
    );

    assert!(JointPath::new(1, vec![0.0], vec![0.0], vec![1.0]).is_err());
    assert!(JointPath::new(1, vec![0.0, 0.0], vec![0.0, 1.0], vec![1.0; 2]).is_err());
    assert!(JointPath::new(2, vec![0.0, 1.0], vec![0.0, 1.0], vec![1.0; 2]).is_err());
    assert!(JointPath::new(1, vec![0.0, 1.0], vec![0.0, f64::NAN], vec![1.0; 2]).is_err());
    assert!(JointPath::new(1, vec![0.0, 1.0], vec![0.0, 1.0], vec![1.0, 0.0]).is_err());
    let bad = limits(&[1.0], &[-1.0], &[1.0]);
    assert!(matches!(
        plan(&path, &bad, &JerkOptions::default()),
        Err(JerkError::Limits(_))
    ));
    let unbounded =
        JointPath::new(1, vec![0.0, 1.0], vec![0.0, 1.0], vec![f64::INFINITY; 2]).unwrap();
    assert!(plan(&unbounded, &lim, &JerkOptions::default()).is_err());
    let o = JerkOptions {
        curvature_share: 1.0,
        ..JerkOptions::default()
    };
    assert!(matches!(plan(&path, &lim, &o), Err(JerkError::Options(_))));
}

/// A curved five-joint path of the kind TCP produces: X, Y, Z on a helix and
/// a rotary joint (deg) turning with it, s the tool-path arc length.
fn tcp_like(points: usize, radius: f64, turns: f64, pitch: f64) -> (Vec<f64>, Vec<f64>) {
    let mut q = Vec::with_capacity(points * 5);
    for k in 0..points {
        let th = turns * std::f64::consts::TAU * k as f64 / (points - 1) as f64;
        q.extend_from_slice(&[
            radius * th.cos(),
            radius * th.sin(),
            pitch * th,
            th.to_degrees(),
            20.0 * (0.5 * th).sin(),
        ]);
    }
    let mut s = vec![0.0];
    for k in 1..points {
        let d: f64 = (0..3)
            .map(|i| (q[k * 5 + i] - q[(k - 1) * 5 + i]).powi(2))
            .sum::<f64>()
            .sqrt();
        s.push(s[k - 1] + d);
    }
    (s, q)
}

#[test]
fn tcp_like_helix_respects_every_joint_limit() {
    let (s, q) = tcp_like(400, 30.0, 1.5, 2.0);
    let path = JointPath::new(5, s, q, vec![80.0; 400]).unwrap();
    let lim = limits(
        &[100.0, 100.0, 50.0, 90.0, 30.0],
        &[1000.0, 1000.0, 500.0, 600.0, 300.0],
        &[20000.0, 20000.0, 10000.0, 5000.0, 3000.0],
    );
    let law = plan(&path, &lim, &JerkOptions::default()).unwrap();
    check(&path, &lim, &law, 1e-3);
}

fn limit_values() -> impl Strategy<Value = (f64, f64, f64)> {
    (
        prop_oneof![3 => 10.0..300.0f64, 1 => Just(f64::INFINITY)],
        100.0..5000.0f64,
        1000.0..100000.0f64,
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    /// Random polylines (2–5 joints, 2–7 points, sharp vertices rounded by
    /// the spline), random limits and feed caps.
    #[test]
    fn random_polylines_respect_the_limits_and_rest(
        n in 2usize..=5,
        pts in prop::collection::vec(prop::collection::vec(-50.0..50.0f64, 5), 2..=7),
        lims in prop::collection::vec(limit_values(), 5),
        caps in prop::collection::vec(5.0..150.0f64, 7),
    ) {
        let mut q = Vec::new();
        for p in &pts {
            q.extend_from_slice(&p[..n]);
        }
        // Drop repeated points (s must increase).
        let mut s = chord(n, &q);
        let mut keep_q = q[..n].to_vec();
        let mut keep_s = vec![0.0];
        for k in 1..s.len() {
            if s[k] - keep_s[keep_s.len() - 1] > 1e-3 {
                keep_q.extend_from_slice(&q[k * n..(k + 1) * n]);
                keep_s.push(s[k]);
            }
        }
        prop_assume!(keep_s.len() >= 2);
        s = keep_s;
        let path = JointPath::new(n, s.clone(), keep_q, caps[..s.len()].to_vec()).unwrap();
        let lim = JointLimits {
            v: lims[..n].iter().map(|l| l.0).collect(),
            a: lims[..n].iter().map(|l| l.1).collect(),
            j: lims[..n].iter().map(|l| l.2).collect(),
        };
        let law = plan(&path, &lim, &JerkOptions::default()).unwrap();
        check(&path, &lim, &law, 1e-3);
    }

    /// Dense curved TCP-like paths with random limits and feed.
    #[test]
    fn random_tcp_like_paths_respect_the_limits_and_rest(
        points in 20usize..300,
        radius in 2.0..60.0f64,
        turns in 0.1..1.5f64,
        pitch in -3.0..3.0f64,
        lims in prop::collection::vec(limit_values(), 5),
        feed in 5.0..150.0f64,
        share in 0.2..0.8f64,
    ) {
        let (s, q) = tcp_like(points, radius, turns, pitch);
        let path = JointPath::new(5, s, q, vec![feed; points]).unwrap();
        let lim = JointLimits {
            v: lims.iter().map(|l| l.0).collect(),
            a: lims.iter().map(|l| l.1).collect(),
            j: lims.iter().map(|l| l.2).collect(),
        };
        let opts = JerkOptions {
            curvature_share: share,
            ..JerkOptions::default()
        };
        let law = plan(&path, &lim, &opts).unwrap();
        check(&path, &lim, &law, 1e-3);
    }
}
