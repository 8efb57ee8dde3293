//! Jerk-limited time law along a given path in joint space: the motion of a
//! controller of the Siemens/Heidenhain/Fanuc class, which limits every
//! joint's velocity, acceleration and jerk, also under TCP.
//!
//! # Algorithm
//!
//! 1. **Path.** The [`JointPath`] points `q_k` at path parameters `s_k` are
//!    joined by a natural cubic spline per joint (C² in `s`): `q'(s)` and
//!    `q''(s)` are continuous, `q'''(s)` is constant on each interval. A
//!    straight move given by collinear points stays exactly straight (the
//!    spline reproduces linear data); a polyline *vertex* is rounded by the
//!    spline, with a curvature `q''` that grows as the points get sparser, so
//!    the speed through it drops accordingly. A corner that must be kept
//!    sharp is an exact stop: the caller plans the two sides as two paths.
//! 2. **Speed and acceleration bounds per interval.** With per-interval
//!    bounds `P1 = max|q_i'|`, `P2 = max|q_i''|`, `P3 = |q_i'''|` of each
//!    joint `i`, the joint derivatives are
//!    `q̇ = q' ṡ`, `q̈ = q' s̈ + q'' ṡ²`, `q⃛ = q' s⃛ + 3 q'' ṡ s̈ + q''' ṡ³`.
//!    The interval gets a path speed cap `V` (programmed feed cap, `v_i/P1`,
//!    and the curvature terms `P2 V² ≤ ρ a_i`, `P3 V³ ≤ ρ j_i` with
//!    `ρ` = [`JerkOptions::curvature_share`]) and a path acceleration `A`
//!    with `P1 A + P2 V² ≤ a_i` and `P1 A / T_j + 3 P2 V A + P3 V³ ≤ j_i`.
//!    By the triangle inequality any motion with `ṡ ≤ V`, `|s̈| ≤ A`,
//!    `|s⃛| ≤ A / T_j` in the interval keeps every joint within its limits.
//! 3. **Filter time.** `T_j` = the largest ratio, over the intervals, of the
//!    path acceleration to the path jerk the joint limits allow alone
//!    (`min a_i/P1 ÷ min j_i/P1`); for a single-axis move that is `a/j`.
//! 4. **Acceleration-limited time-optimal profile** (the phase-plane
//!    forward–backward passes of time-optimal path parameterisation on
//!    piecewise-constant bounds): junction speeds, then per interval an
//!    accelerate–cruise–decelerate profile `s_r(t)`; its acceleration is
//!    piecewise constant.
//! 5. **Jerk limitation by a moving-average (FIR) filter** of length `T_j`:
//!    `s(t) = (1/T_j) ∫_{t-T_j}^{t} s_r(τ) dτ`, the "acceleration/deceleration
//!    after interpolation" of industrial controllers. Then
//!    `ṡ = mean of ṡ_r`, `s̈ = mean of s̈_r`,
//!    `s⃛ = (s̈_r(t) − s̈_r(t−T_j)) / T_j`. The filter delays the motion, so
//!    each interval's bounds are applied to the raw profile `V T_j / 2`
//!    beyond the interval (every raw position averaged into a filtered
//!    position inside the interval lies within that distance; proof in the
//!    source), and where the raw acceleration changes sign within `T_j`
//!    by more than `A` (a short peak or dip of speed) the speed there is
//!    capped so that the raw profile cruises for `T_j` (at most
//!    [`JerkOptions::max_repairs`] rounds; after that, the raw acceleration
//!    is halved everywhere, which bounds every jump by `A`).
//!
//! For a rest-to-rest straight move that reaches its acceleration limit the
//! result is exactly the 7-phase jerk-limited profile (a trapezoid filtered
//! by a moving average of `A/J` is the optimal S-curve), so the time is the
//! closed-form optimum. Elsewhere the plan is near-optimal: a speed change
//! between intervals is started `V T_j / 2` early, and the curvature share
//! fixes the split of each joint's acceleration and jerk between path
//! acceleration and curvature.
//!
//! # Guarantees
//!
//! * No joint exceeds `limit_fraction` × its velocity, acceleration or jerk
//!   limit at any time (the composite `q(s(t))` is C² in `t` when `T_j > 0`).
//! * Starts and ends at rest (`ṡ = s̈ = 0`) at the first and last point.
//! * Planning and sampling cost is linear in the number of points (plus a
//!   sort of the interval ends).
//!
//! # Numerics
//!
//! The third differences of samples `ts` apart amplify position noise by
//! `1/ts³` (1e9 at 1 ms), and a whole program can be one path of metres
//! and many minutes. The filtered position is therefore integrated
//! relative to the start of a nearby raw piece (not as the difference of a
//! running integral, nor rounded to the magnitude of `s` before the spline
//! is evaluated), and [`Cursor::at_clock`] / [`TimeLaw::sampler`] round
//! the sample time once, inside the profile.

pub(crate) mod blend;

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use thiserror::Error;

/// Why no time law was planned.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum JerkError {
    /// The path is malformed (too few points, lengths, non-finite numbers,
    /// `s` not strictly increasing, a cap not positive).
    #[error("joint path: {0}")]
    Path(String),
    /// The limits are malformed or do not bound the motion.
    #[error("joint limits: {0}")]
    Limits(String),
    /// An option is out of its range.
    #[error("jerk planner option: {0}")]
    Options(String),
}

/// A geometric path in joint space: `N ≥ 2` points `q_k` (one value per
/// joint: mm for linear, degree for rotary joints) at strictly increasing
/// path parameters `s_k` (e.g. the tool-path arc length, mm), and per point
/// a cap on the path speed `ds/dt` from the programmed feed (s-units per
/// second; `f64::INFINITY` for none). The cap of point `k ≥ 1` holds on
/// the interval arriving at it, from point `k − 1` (as a block's feed holds
/// on the move ending at the block's point); the first point's cap is not
/// used.
#[derive(Debug, Clone, PartialEq)]
pub struct JointPath {
    joints: usize,
    s: Vec<f64>,
    q: Vec<f64>,
    cap: Vec<f64>,
}

impl JointPath {
    /// A path of `joints` joints; `q` holds the points one after the other
    /// (`q[k * joints + i]` is joint `i` at point `k`).
    pub fn new(joints: usize, s: Vec<f64>, q: Vec<f64>, cap: Vec<f64>) -> Result<Self, JerkError> {
        let bad = |m: String| Err(JerkError::Path(m));
        if joints == 0 {
            return bad("a path needs at least one joint".into());
        }
        if s.len() < 2 {
            return bad(format!(
                "a path needs at least 2 points, it has {}",
                s.len()
            ));
        }
        if q.len() != s.len() * joints {
            return bad(format!(
                "{} points of {joints} joints need {} joint values, not {}",
                s.len(),
                s.len() * joints,
                q.len()
            ));
        }
        if cap.len() != s.len() {
            return bad(format!(
                "{} points need {} speed caps, not {}",
                s.len(),
                s.len(),
                cap.len()
            ));
        }
        if let Some(k) = s.iter().position(|x| !x.is_finite()) {
            return bad(format!("s of point {k} is not a finite number"));
        }
        if let Some(k) = q.iter().position(|x| !x.is_finite()) {
            return bad(format!(
                "joint {} of point {} is not a finite number",
                k % joints,
                k / joints
            ));
        }
        if let Some(k) = s.windows(2).position(|w| w[1] <= w[0]) {
            return bad(format!(
                "s must be strictly increasing: point {} has {} after {}",
                k + 1,
                s[k + 1],
                s[k]
            ));
        }
        if let Some(k) = cap.iter().position(|c| c.is_nan() || *c <= 0.0) {
            return bad(format!(
                "the speed cap of point {k} must be positive, not {}",
                cap[k]
            ));
        }
        Ok(JointPath { joints, s, q, cap })
    }

    /// Number of joints.
    pub fn joints(&self) -> usize {
        self.joints
    }

    /// Number of points.
    pub fn points(&self) -> usize {
        self.s.len()
    }

    /// Path parameters of the points.
    pub fn s(&self) -> &[f64] {
        &self.s
    }

    /// Joint values of point `k`.
    pub fn q(&self, k: usize) -> &[f64] {
        &self.q[k * self.joints..(k + 1) * self.joints]
    }

    /// Speed cap of point `k`.
    pub fn cap(&self, k: usize) -> f64 {
        self.cap[k]
    }
}

/// Per-joint limits: velocity (mm/s or deg/s), acceleration (/s²) and jerk
/// (/s³). Each positive; `f64::INFINITY` is no limit.
#[derive(Debug, Clone, PartialEq)]
pub struct JointLimits {
    /// Velocity limits.
    pub v: Vec<f64>,
    /// Acceleration limits.
    pub a: Vec<f64>,
    /// Jerk limits.
    pub j: Vec<f64>,
}

/// What the planner keeps in reserve and how it splits the limits; every
/// default is documented.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JerkOptions {
    /// Fraction of every joint limit the plan may use, in (0, 1].
    /// Default 1.0: the full limits, nothing held back.
    pub limit_fraction: f64,
    /// Share, in (0, 1), of a joint's acceleration and jerk limit that the
    /// path's curvature may take at the speed cap of a curved interval (the
    /// rest is left for speeding up and slowing down along the path).
    /// Default 0.5. Straight intervals are not affected.
    pub curvature_share: f64,
    /// Length `T_j` of the jerk filter, s. Default `None`: chosen from the
    /// limits (the largest path acceleration-to-jerk ratio along the path).
    /// `Some(0.0)` turns the jerk limitation off (allowed only when no
    /// moving joint has a finite jerk limit).
    pub filter_time: Option<f64>,
    /// Rounds of local speed caps at short speed peaks and dips before the
    /// fallback (halving the path acceleration). Default 32.
    pub max_repairs: usize,
}

impl Default for JerkOptions {
    fn default() -> Self {
        JerkOptions {
            limit_fraction: 1.0,
            curvature_share: 0.5,
            filter_time: None,
            max_repairs: 32,
        }
    }
}

/// Natural cubic spline of every joint over the knots `s` (relative to the
/// first point): interval `k`, joint `i` is
/// `c[0] + c[1] u + c[2] u² + c[3] u³`, `u = s − s_k`.
#[derive(Debug, Clone)]
struct Spline {
    n: usize,
    s: Vec<f64>,
    c: Vec<[f64; 4]>,
}

impl Spline {
    fn natural(path: &JointPath) -> Spline {
        let n = path.joints;
        let s0 = path.s[0];
        let s: Vec<f64> = path.s.iter().map(|x| x - s0).collect();
        let np = s.len();
        let h: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
        // Interior second derivatives M_1..M_{np-2}; M_0 = M_{np-1} = 0.
        let m = np - 2;
        let mut cp = vec![0.0; m];
        let mut den = vec![0.0; m];
        for r in 0..m {
            let i = r + 1;
            let sub = if r > 0 { h[i - 1] } else { 0.0 };
            let diag = 2.0 * (h[i - 1] + h[i]);
            let prev = if r > 0 { cp[r - 1] } else { 0.0 };
            den[r] = diag - sub * prev;
            cp[r] = if r + 1 < m { h[i] / den[r] } else { 0.0 };
        }
        let mut c = vec![[0.0; 4]; (np - 1) * n];
        let mut mm = vec![0.0; np];
        let mut dp = vec![0.0; m];
        for j in 0..n {
            let y = |k: usize| path.q[k * n + j];
            for r in 0..m {
                let i = r + 1;
                let rhs = 6.0 * ((y(i + 1) - y(i)) / h[i] - (y(i) - y(i - 1)) / h[i - 1]);
                let sub = if r > 0 { h[i - 1] } else { 0.0 };
                let prev = if r > 0 { dp[r - 1] } else { 0.0 };
                dp[r] = (rhs - sub * prev) / den[r];
            }
            mm[0] = 0.0;
            mm[np - 1] = 0.0;
            for r in (0..m).rev() {
                let next = if r + 1 < m { mm[r + 2] } else { 0.0 };
                mm[r + 1] = dp[r] - cp[r] * next;
            }
            for k in 0..np - 1 {
                let (y0, y1, hk) = (y(k), y(k + 1), h[k]);
                c[k * n + j] = [
                    y0,
                    (y1 - y0) / hk - hk * (2.0 * mm[k] + mm[k + 1]) / 6.0,
                    mm[k] / 2.0,
                    (mm[k + 1] - mm[k]) / (6.0 * hk),
                ];
            }
        }
        Spline { n, s, c }
    }

    fn intervals(&self) -> usize {
        self.s.len() - 1
    }

    /// Bounds `(max|q'|, max|q''|, |q'''|)` of joint `j` over interval `k`.
    fn bounds(&self, k: usize, j: usize) -> (f64, f64, f64) {
        let [_, b, c, d] = self.c[k * self.n + j];
        let h = self.s[k + 1] - self.s[k];
        let d1 = |u: f64| b + u * (2.0 * c + 3.0 * d * u);
        let mut p1 = d1(0.0).abs().max(d1(h).abs());
        if d != 0.0 {
            let u = -c / (3.0 * d);
            if u > 0.0 && u < h {
                p1 = p1.max(d1(u).abs());
            }
        }
        let p2 = (2.0 * c).abs().max((2.0 * c + 6.0 * d * h).abs());
        (p1, p2, (6.0 * d).abs())
    }

    /// Interval holding `s` (clamped), searching forward from `hint`.
    fn locate(&self, s: f64, hint: usize) -> usize {
        let last = self.intervals() - 1;
        let mut k = hint.min(last);
        if s < self.s[k] {
            k = self
                .s
                .partition_point(|x| *x <= s)
                .saturating_sub(1)
                .min(last);
        } else {
            while k < last && s >= self.s[k + 1] {
                k += 1;
            }
        }
        k
    }

    /// Joint positions at `s = r + d` (interval `k`), with
    /// `u = (r − s_k) + d` (no rounding of `r + d` to the magnitude of `s`).
    fn eval_parts(&self, k: usize, r: f64, d: f64, out: &mut [f64]) {
        let u = (r - self.s[k]) + d;
        for (j, o) in out.iter_mut().enumerate().take(self.n) {
            let [a, b, c, d] = self.c[k * self.n + j];
            *o = a + u * (b + u * (c + u * d));
        }
    }
}

/// A stretch of the path with constant bounds on the raw profile.
#[derive(Debug, Clone, Copy)]
struct Cell {
    s0: f64,
    s1: f64,
    v: f64,
    a: f64,
}

/// A stretch `[s0, s1]` on which the raw profile must keep `ṡ ≤ v`, `|s̈| ≤ a`.
#[derive(Debug, Clone, Copy)]
struct Zone {
    s0: f64,
    s1: f64,
    v: f64,
    a: f64,
}

/// One constant-acceleration piece of the raw profile.
#[derive(Debug, Clone, Copy)]
struct Piece {
    t0: f64,
    s0: f64,
    v0: f64,
    a: f64,
}

#[derive(Debug, Clone, Copy)]
struct RawState {
    s: f64,
    v: f64,
    a: f64,
}

/// A time `k·ts − off`, evaluated inside a piece of the raw profile as one
/// fused multiply-add. Samples at `k = 0, 1, …` then lie on an exactly
/// uniform grid: computing `k·ts` first would round each time to the
/// resolution of its magnitude (1e-13 s after 15 min), and that noise,
/// times a joint's speed, dominates the third differences of 1 ms samples.
#[derive(Debug, Clone, Copy)]
struct Clock {
    k: f64,
    ts: f64,
    off: f64,
}

impl Clock {
    fn at(t: f64) -> Clock {
        Clock {
            k: t,
            ts: 1.0,
            off: 0.0,
        }
    }

    /// The time, rounded (to find pieces).
    fn t(&self) -> f64 {
        self.k * self.ts - self.off
    }

    /// The time minus `t0 + shift`, rounded once.
    fn since(&self, t0: f64, shift: f64) -> f64 {
        self.k.mul_add(self.ts, -(self.off + shift + t0))
    }
}

/// f64 ordered by `total_cmp`, for the heaps.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Ord64(f64);
impl Eq for Ord64 {}
impl PartialOrd for Ord64 {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Ord64 {
    fn cmp(&self, o: &Self) -> Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// The raw (acceleration-limited) profile: pieces in time order.
#[derive(Debug, Clone)]
struct Raw {
    pieces: Vec<Piece>,
    /// Duration.
    t: f64,
    /// Length.
    l: f64,
}

impl Raw {
    /// Forward–backward passes and per-cell accelerate–cruise–decelerate.
    fn build(cells: &[Cell], l: f64) -> Raw {
        let m = cells.len();
        let mut v = vec![0.0; m + 1];
        for k in 1..m {
            v[k] = cells[k - 1].v.min(cells[k].v);
        }
        for k in 0..m {
            let c = &cells[k];
            let reach = (v[k] * v[k] + 2.0 * c.a * (c.s1 - c.s0)).sqrt();
            v[k + 1] = v[k + 1].min(reach);
        }
        for k in (0..m).rev() {
            let c = &cells[k];
            let reach = (v[k + 1] * v[k + 1] + 2.0 * c.a * (c.s1 - c.s0)).sqrt();
            v[k] = v[k].min(reach);
        }
        let mut pieces = Vec::with_capacity(2 * m);
        let mut t = 0.0;
        let mut push = |s0: f64, v0: f64, a: f64, dur: f64| {
            if dur > 0.0 {
                pieces.push(Piece { t0: t, s0, v0, a });
                t += dur;
            }
        };
        for (k, c) in cells.iter().enumerate() {
            let (vs, ve, a, d) = (v[k], v[k + 1], c.a, c.s1 - c.s0);
            let vp = ((vs * vs + ve * ve) / 2.0 + a * d)
                .sqrt()
                .min(c.v)
                .max(vs)
                .max(ve);
            let d_acc = (vp * vp - vs * vs) / (2.0 * a);
            let d_dec = (vp * vp - ve * ve) / (2.0 * a);
            let d_cru = d - d_acc - d_dec;
            push(c.s0, vs, a, (vp - vs) / a);
            if d_cru > 0.0 {
                push(c.s0 + d_acc, vp, 0.0, d_cru / vp);
            }
            push(c.s1 - d_dec, vp, -a, (vp - ve) / a);
        }
        Raw { pieces, t, l }
    }

    /// Index of the piece holding time `t` (in `[0, t)`), searching forward
    /// from `hint`.
    fn locate(&self, t: f64, hint: usize) -> usize {
        let p = &self.pieces;
        let mut k = hint.min(p.len() - 1);
        if t < p[k].t0 {
            k = p.partition_point(|x| x.t0 <= t).saturating_sub(1);
        } else {
            while k + 1 < p.len() && t >= p[k + 1].t0 {
                k += 1;
            }
        }
        k
    }

    fn state(&self, t: f64, hint: &mut usize) -> RawState {
        if t <= 0.0 {
            return RawState {
                s: 0.0,
                v: 0.0,
                a: 0.0,
            };
        }
        if t >= self.t {
            return RawState {
                s: self.l,
                v: 0.0,
                a: 0.0,
            };
        }
        let k = self.locate(t, *hint);
        *hint = k;
        let p = &self.pieces[k];
        let u = t - p.t0;
        RawState {
            s: p.s0 + u * (p.v0 + u * p.a / 2.0),
            v: p.v0 + u * p.a,
            a: p.a,
        }
    }

    /// The filtered position `s(t) = (1/T_j) ∫_{t−T_j}^{t} s_r dτ` as
    /// `(S, Δ)` with `s = S + Δ`: `S` the start of the piece holding
    /// `t − T_j` (0 before the start, the length after the end) and `Δ`
    /// integrated piece by piece relative to `S`. The rounding error is then
    /// of the order of `Δ`'s, not of `s`'s magnitude; in plain `s` (one ulp is
    /// 1e-12 mm at 5 m of path) the noise, times a joint's `dq/ds` under TCP,
    /// shows in the third differences of 1 ms samples.
    fn window(&self, tj: f64, c: Clock, ha: &mut usize, hb: &mut usize) -> (f64, f64) {
        let tb = c.t();
        let ta = tb - tj;
        if tb <= 0.0 {
            return (0.0, 0.0);
        }
        if ta >= self.t {
            return (self.l, 0.0);
        }
        let p = &self.pieces;
        let ka = if ta > 0.0 { self.locate(ta, *ha) } else { 0 };
        let kb = if tb < self.t {
            self.locate(tb, *hb)
        } else {
            p.len() - 1
        };
        *ha = ka;
        *hb = kb;
        let reference = if ta > 0.0 { p[ka].s0 } else { 0.0 };
        let mut w = 0.0;
        if ta < 0.0 {
            // At 0 before the start: (0 − S) over −ta.
            w -= reference * (-c.since(0.0, tj)).min(tj);
        }
        if tb > self.t {
            w += (self.l - reference) * c.since(self.t, 0.0).min(tj);
        }
        for k in ka..=kb {
            let q = &p[k];
            let span = if k + 1 < p.len() {
                p[k + 1].t0 - q.t0
            } else {
                self.t - q.t0
            };
            let ua = if k == ka && ta > 0.0 {
                c.since(q.t0, tj).max(0.0)
            } else {
                0.0
            };
            let ub = if k == kb && tb < self.t {
                c.since(q.t0, 0.0).min(span)
            } else {
                span
            };
            let d = ub - ua;
            if d > 0.0 {
                let sa = (q.s0 - reference) + ua * (q.v0 + ua * q.a / 2.0);
                let va = q.v0 + ua * q.a;
                w += d * (sa + d * (va / 2.0 + d * q.a / 6.0));
            }
        }
        (reference, w / tj)
    }

    /// Acceleration at `t` (the piece's, 0 outside `[0, t)`).
    fn accel(&self, t: f64, hint: &mut usize) -> f64 {
        if t < 0.0 || t >= self.t {
            0.0
        } else {
            self.state(t, hint).a
        }
    }
}

/// Apply zones to cells: split where zones begin and end, cap each part by
/// the zones covering it, merge neighbours with equal bounds.
fn apply_zones(cells: &[Cell], zones: &mut [Zone], l: f64) -> Vec<Cell> {
    if zones.is_empty() {
        return cells.to_vec();
    }
    zones.sort_by(|a, b| a.s0.total_cmp(&b.s0));
    let mut cuts: Vec<f64> = cells.iter().map(|c| c.s0).collect();
    cuts.push(l);
    for z in zones.iter() {
        for x in [z.s0, z.s1] {
            if x > 0.0 && x < l {
                cuts.push(x);
            }
        }
    }
    cuts.sort_by(|a, b| a.total_cmp(b));
    let tol = 1e-12 * l.max(1.0);
    cuts.dedup_by(|b, a| *b - *a <= tol);
    // The end must be exactly l.
    if let Some(last) = cuts.last_mut() {
        *last = l;
    }
    let mut out: Vec<Cell> = Vec::with_capacity(cuts.len());
    let (mut ci, mut zi) = (0, 0);
    let mut hv: BinaryHeap<Reverse<(Ord64, Ord64)>> = BinaryHeap::new();
    let mut ha: BinaryHeap<Reverse<(Ord64, Ord64)>> = BinaryHeap::new();
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let mid = 0.5 * (a + b);
        while ci + 1 < cells.len() && cells[ci].s1 <= mid {
            ci += 1;
        }
        while zi < zones.len() && zones[zi].s0 <= mid {
            let z = zones[zi];
            hv.push(Reverse((Ord64(z.v), Ord64(z.s1))));
            ha.push(Reverse((Ord64(z.a), Ord64(z.s1))));
            zi += 1;
        }
        let top = |h: &mut BinaryHeap<Reverse<(Ord64, Ord64)>>| -> f64 {
            while let Some(Reverse((x, end))) = h.peek() {
                if end.0 < mid {
                    h.pop();
                } else {
                    return x.0;
                }
            }
            f64::INFINITY
        };
        let v = cells[ci].v.min(top(&mut hv));
        let acc = cells[ci].a.min(top(&mut ha));
        match out.last_mut() {
            Some(p) if p.v == v && p.a == acc => p.s1 = b,
            _ => out.push(Cell {
                s0: a,
                s1: b,
                v,
                a: acc,
            }),
        }
    }
    out
}

/// A violation of the jump bound of the filtered jerk: in the time window
/// ending in `[ta, tb]` the raw acceleration changes sign by more than the
/// path acceleration allows.
#[derive(Debug, Clone, Copy)]
struct Jump {
    ta: f64,
    tb: f64,
    peak: bool,
}

/// Per original interval: knots and own acceleration bound.
struct Own<'a> {
    s: &'a [f64],
    a: &'a [f64],
}

impl Own<'_> {
    /// Smallest own acceleration bound over `[s0, s1]`.
    fn min_a(&self, s0: f64, s1: f64) -> f64 {
        let last = self.a.len() - 1;
        let mut k = self
            .s
            .partition_point(|x| *x <= s0)
            .saturating_sub(1)
            .min(last);
        let mut m = self.a[k];
        while k < last && self.s[k + 1] < s1 {
            k += 1;
            m = m.min(self.a[k]);
        }
        m
    }
}

/// The windows where `|s̈_r(t) − s̈_r(t − T_j)|` (raw accelerations of
/// opposite sign) exceeds the own acceleration bound somewhere the filtered
/// position can be.
fn jumps(raw: &Raw, tj: f64, own: &Own) -> Vec<Jump> {
    let mut times: Vec<f64> = Vec::with_capacity(2 * raw.pieces.len() + 2);
    for p in &raw.pieces {
        times.push(p.t0);
        times.push(p.t0 + tj);
    }
    times.push(raw.t);
    times.push(raw.t + tj);
    times.sort_by(|a, b| a.total_cmp(b));
    let mut out = Vec::new();
    let (mut h1, mut h2, mut h3, mut h4) = (0, 0, 0, 0);
    for w in times.windows(2) {
        let (ta, tb) = (w[0], w[1]);
        if tb - ta <= 1e-12 * raw.t.max(1.0) {
            continue;
        }
        let mid = 0.5 * (ta + tb);
        let a2 = raw.accel(mid, &mut h1);
        let a1 = raw.accel(mid - tj, &mut h2);
        if a1 * a2 >= 0.0 {
            continue;
        }
        let s_lo = raw.state(ta - tj, &mut h3).s;
        let s_hi = raw.state(tb, &mut h4).s;
        if a1.abs() + a2.abs() > own.min_a(s_lo, s_hi) * (1.0 + 1e-9) {
            out.push(Jump {
                ta,
                tb,
                peak: a1 > 0.0,
            });
        }
    }
    out
}

/// Times around `t` where the raw speed crosses `level` (leaving the stretch
/// where it is above it when `above`, below it otherwise).
fn crossing(raw: &Raw, t: f64, level: f64, above: bool) -> (f64, f64) {
    let p = &raw.pieces;
    let inside = |v: f64| if above { v >= level } else { v <= level };
    let speed_at = |k: usize, t: f64| p[k].v0 + (t - p[k].t0) * p[k].a;
    let end_of = |k: usize| if k + 1 < p.len() { p[k + 1].t0 } else { raw.t };
    let k0 = raw.locate(t.clamp(0.0, raw.t), usize::MAX);
    // Left.
    let mut lo = 0.0;
    let mut k = k0;
    loop {
        let v0 = p[k].v0;
        if !inside(v0) {
            // Crossing inside piece k, between its start and t-ish.
            lo = if p[k].a != 0.0 {
                p[k].t0 + (level - v0) / p[k].a
            } else {
                p[k].t0
            };
            lo = lo.clamp(p[k].t0, end_of(k));
            break;
        }
        if k == 0 {
            break;
        }
        k -= 1;
    }
    // Right.
    let mut hi = raw.t;
    let mut k = k0;
    loop {
        let e = end_of(k);
        let ve = speed_at(k, e);
        if !inside(ve) {
            hi = if p[k].a != 0.0 {
                p[k].t0 + (level - p[k].v0) / p[k].a
            } else {
                e
            };
            hi = hi.clamp(p[k].t0, e);
            break;
        }
        if k + 1 == p.len() {
            break;
        }
        k += 1;
    }
    (lo, hi)
}

/// The local speed cap that removes a jump: at a peak, the level `V_c` whose
/// stretch above it takes `T_j` at `V_c`; at a dip, a stretch of `T_j` at
/// the lowest speed.
fn repair(raw: &Raw, tj: f64, j: &Jump) -> Option<Zone> {
    // Extreme raw speed over the window: the speed is piecewise linear, so
    // at a piece boundary or the window ends.
    let (w0, w1) = ((j.ta - tj).max(0.0), j.tb.min(raw.t));
    let mut hint = usize::MAX;
    let mut best = (w0, raw.state(w0, &mut hint).v);
    let mut consider = |t: f64, hint: &mut usize| {
        let v = raw.state(t, hint).v;
        if (j.peak && v > best.1) || (!j.peak && v < best.1) {
            best = (t, v);
        }
    };
    consider(w1, &mut hint);
    let k0 = raw.locate(w0, usize::MAX);
    let mut k = k0 + 1;
    while k < raw.pieces.len() && raw.pieces[k].t0 < w1 {
        consider(raw.pieces[k].t0, &mut hint);
        k += 1;
    }
    let (tp, vp) = best;
    let want = tj * (1.0 + 1e-6);
    let mut h = usize::MAX;
    if j.peak {
        let span = |vc: f64, h: &mut usize| {
            let (lo, hi) = crossing(raw, tp, vc, true);
            (raw.state(lo, h).s, raw.state(hi, h).s)
        };
        let (mut lo, mut hi) = (0.0, vp);
        for _ in 0..60 {
            let vc = 0.5 * (lo + hi);
            let (a, b) = span(vc, &mut h);
            if b - a >= vc * want {
                lo = vc;
            } else {
                hi = vc;
            }
        }
        if lo <= 0.0 {
            return None;
        }
        let (a, b) = span(lo, &mut h);
        Some(Zone {
            s0: a,
            s1: b,
            v: lo,
            a: f64::INFINITY,
        })
    } else {
        let level = vp * (1.0 + 1e-12) + 1e-300;
        let (t_lo, t_hi) = crossing(raw, tp, level, false);
        let (a, b) = (raw.state(t_lo, &mut h).s, raw.state(t_hi, &mut h).s);
        let c = 0.5 * (a + b);
        let half = (0.5 * vp * want).max(0.5 * (b - a));
        if vp <= 0.0 {
            return None;
        }
        Some(Zone {
            s0: c - half,
            s1: c + half,
            v: vp,
            a: f64::INFINITY,
        })
    }
}

/// A planned motion along a [`JointPath`]: the path parameter `s(t)` for
/// `t ∈ [0, duration]` (at rest before and after) and joint positions.
#[derive(Debug, Clone)]
pub struct TimeLaw {
    spline: Spline,
    raw: Raw,
    tj: f64,
    s_first: f64,
    repairs: usize,
    fallback: bool,
}

/// Filtered position as `(S, Δ)`, `s = S + Δ` (see [`Raw::window`]),
/// clamped to the path.
fn position_parts(raw: &Raw, tj: f64, c: Clock, h0: &mut usize, h1: &mut usize) -> (f64, f64) {
    let (r, d) = if tj == 0.0 {
        let t = c.t();
        if t <= 0.0 {
            (0.0, 0.0)
        } else if t >= raw.t {
            (raw.l, 0.0)
        } else {
            let k = raw.locate(t, *h0);
            *h0 = k;
            let p = &raw.pieces[k];
            let u = c.since(p.t0, 0.0);
            (p.s0, u * (p.v0 + u * p.a / 2.0))
        }
    } else {
        raw.window(tj, c, h1, h0)
    };
    if r + d > raw.l {
        (raw.l, 0.0)
    } else if r + d < 0.0 {
        (0.0, 0.0)
    } else {
        (r, d)
    }
}

/// Filtered state `(s, ṡ, s̈, s⃛)` (s relative to the first point).
fn filtered(raw: &Raw, tj: f64, t: f64, h0: &mut usize, h1: &mut usize) -> [f64; 4] {
    if tj == 0.0 {
        let r = raw.state(t, h0);
        return [r.s, r.v, r.a, 0.0];
    }
    let (sr, sd) = raw.window(tj, Clock::at(t), &mut h1.clone(), &mut h0.clone());
    let r1 = raw.state(t, h0);
    let r0 = raw.state(t - tj, h1);
    let a1 = if t >= 0.0 && t < raw.t { r1.a } else { 0.0 };
    let a0 = if t - tj >= 0.0 && t - tj < raw.t {
        r0.a
    } else {
        0.0
    };
    [
        sr + sd,
        (r1.s - r0.s) / tj,
        (r1.v - r0.v) / tj,
        (a1 - a0) / tj,
    ]
}

impl TimeLaw {
    /// Total time, s: from leaving the first point to stopping at the last.
    pub fn duration(&self) -> f64 {
        self.raw.t + self.tj
    }

    /// Length `T_j` of the jerk filter used, s.
    pub fn filter_time(&self) -> f64 {
        self.tj
    }

    /// Rounds of local speed caps taken (see [`JerkOptions::max_repairs`]).
    pub fn repairs(&self) -> usize {
        self.repairs
    }

    /// True when the fallback (halved path acceleration) was taken.
    pub fn fell_back(&self) -> bool {
        self.fallback
    }

    fn state(&self, t: f64) -> [f64; 4] {
        let (mut h0, mut h1) = (usize::MAX, usize::MAX);
        filtered(&self.raw, self.tj, t, &mut h0, &mut h1)
    }

    /// Path parameter at time `t` (s-units; the first point's `s` before 0,
    /// the last one's after the end).
    pub fn s(&self, t: f64) -> f64 {
        self.s_first + self.state(t)[0].clamp(0.0, self.raw.l)
    }

    /// Path speed `ds/dt` at time `t`.
    pub fn ds_dt(&self, t: f64) -> f64 {
        self.state(t)[1]
    }

    /// Path acceleration `d²s/dt²` at time `t`.
    pub fn d2s_dt2(&self, t: f64) -> f64 {
        self.state(t)[2]
    }

    /// Path jerk `d³s/dt³` at time `t` (piecewise constant; the value right
    /// of `t`).
    pub fn d3s_dt3(&self, t: f64) -> f64 {
        self.state(t)[3]
    }

    /// Joint positions at time `t` into `out` (length: the joints).
    pub fn position(&self, t: f64, out: &mut [f64]) {
        self.cursor().at(t, out);
    }

    /// Joint positions into `out` at the sample `t = k·ts − t0` of a clock
    /// on which this motion starts at `t0` (the time rounded once inside
    /// the profile: samples exactly uniform however far from the clock's
    /// start).
    fn position_parts(&self, c: Clock, h: &mut (usize, usize, usize), out: &mut [f64]) -> f64 {
        let (r, d) = position_parts(&self.raw, self.tj, c, &mut h.0, &mut h.1);
        h.2 = self.spline.locate(r + d, h.2);
        self.spline.eval_parts(h.2, r, d, out);
        r + d
    }

    /// Positions at `t = k·ts`, `k = 0, 1, …` up to the first sample at or
    /// after the end (held at the last point).
    pub fn sampler(&self, ts: f64) -> Sampler<'_> {
        assert!(
            ts > 0.0 && ts.is_finite(),
            "the sample period must be positive"
        );
        Sampler {
            law: self,
            ts,
            k: 0,
            n: (self.duration() / ts).ceil() as u64 + 1,
            h0: 0,
            h1: 0,
            hs: 0,
        }
    }

    /// A cursor for positions at increasing times (amortised constant cost
    /// per call, as [`TimeLaw::sampler`], at any times).
    pub fn cursor(&self) -> Cursor<'_> {
        Cursor {
            law: self,
            h0: 0,
            h1: 0,
            hs: 0,
        }
    }

    /// All samples of [`TimeLaw::sampler`], one after the other
    /// (`joints` values each).
    pub fn sample(&self, ts: f64) -> Vec<f64> {
        let n = self.spline.n;
        let mut s = self.sampler(ts);
        let mut out = vec![0.0; s.len() * n];
        for row in out.chunks_mut(n) {
            s.next_into(row);
        }
        out
    }
}

/// Samples of a [`TimeLaw`] at a fixed period, in time order; amortised
/// constant cost per sample.
#[derive(Debug, Clone)]
pub struct Sampler<'a> {
    law: &'a TimeLaw,
    ts: f64,
    k: u64,
    n: u64,
    h0: usize,
    h1: usize,
    hs: usize,
}

impl Sampler<'_> {
    /// Number of samples in all.
    pub fn len(&self) -> usize {
        self.n as usize
    }

    /// True when there are no samples (never: the first point is one).
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The next sample's positions into `out`; returns its time, or `None`
    /// after the last.
    pub fn next_into(&mut self, out: &mut [f64]) -> Option<f64> {
        if self.k >= self.n {
            return None;
        }
        let c = Clock {
            k: self.k as f64,
            ts: self.ts,
            off: 0.0,
        };
        self.k += 1;
        let mut h = (self.h0, self.h1, self.hs);
        self.law.position_parts(c, &mut h, out);
        (self.h0, self.h1, self.hs) = h;
        Some(c.t())
    }
}

/// Positions of a [`TimeLaw`] at times given in increasing order (any
/// order works; going back costs a binary search).
#[derive(Debug, Clone)]
pub struct Cursor<'a> {
    law: &'a TimeLaw,
    h0: usize,
    h1: usize,
    hs: usize,
}

impl Cursor<'_> {
    /// Joint positions at time `t` into `out` (length: the joints); returns
    /// the path parameter there (as [`TimeLaw::s`]).
    pub fn at(&mut self, t: f64, out: &mut [f64]) -> f64 {
        self.at_clock(t, 1.0, 0.0, out)
    }

    /// As [`Cursor::at`] at the time `t = k·ts − t0` (`k` a sample index
    /// of a clock on which this motion starts at `t0`): the time is
    /// rounded once inside the profile, so samples far from the clock's
    /// start stay exactly uniform (computing `k·ts − t0` first rounds each
    /// to the resolution of its magnitude, noise that the third differences
    /// of the samples amplify by `1/ts³`).
    pub fn at_clock(&mut self, k: f64, ts: f64, t0: f64, out: &mut [f64]) -> f64 {
        let c = Clock { k, ts, off: t0 };
        let mut h = (self.h0, self.h1, self.hs);
        let s = self.law.position_parts(c, &mut h, out);
        (self.h0, self.h1, self.hs) = h;
        self.law.s_first + s
    }
}

/// Plan the jerk-limited motion along `path` within `limits`.
pub fn plan(
    path: &JointPath,
    limits: &JointLimits,
    opts: &JerkOptions,
) -> Result<TimeLaw, JerkError> {
    let n = path.joints;
    for (name, l) in [("v", &limits.v), ("a", &limits.a), ("j", &limits.j)] {
        if l.len() != n {
            return Err(JerkError::Limits(format!(
                "{name} has {} values for {n} joints",
                l.len()
            )));
        }
        if let Some(i) = l.iter().position(|x| x.is_nan() || *x <= 0.0) {
            return Err(JerkError::Limits(format!(
                "{name} of joint {i} must be positive, not {}",
                l[i]
            )));
        }
    }
    let f = opts.limit_fraction;
    if !(f > 0.0 && f <= 1.0) {
        return Err(JerkError::Options(format!(
            "limit_fraction must be in (0, 1], not {f}"
        )));
    }
    let rho = opts.curvature_share;
    if !(rho > 0.0 && rho < 1.0) {
        return Err(JerkError::Options(format!(
            "curvature_share must be in (0, 1), not {rho}"
        )));
    }
    if let Some(tj) = opts.filter_time
        && !(tj >= 0.0 && tj.is_finite())
    {
        return Err(JerkError::Options(format!(
            "filter_time must be a finite time ≥ 0 s, not {tj}"
        )));
    }
    let (vl, al, jl): (Vec<f64>, Vec<f64>, Vec<f64>) = (
        limits.v.iter().map(|x| x * f).collect(),
        limits.a.iter().map(|x| x * f).collect(),
        limits.j.iter().map(|x| x * f).collect(),
    );
    let spline = Spline::natural(path);
    let m = spline.intervals();
    let mut b = vec![(0.0, 0.0, 0.0); m * n];
    for k in 0..m {
        for i in 0..n {
            b[k * n + i] = spline.bounds(k, i);
        }
    }
    // Filter time.
    let mut tj_auto: f64 = 0.0;
    let mut jerk_bounded = false;
    for k in 0..m {
        let (mut at, mut jt) = (f64::INFINITY, f64::INFINITY);
        for i in 0..n {
            let p1 = b[k * n + i].0;
            if p1 > 0.0 {
                at = at.min(al[i] / p1);
                jt = jt.min(jl[i] / p1);
            }
        }
        if jt.is_finite() {
            jerk_bounded = true;
            if at.is_finite() {
                tj_auto = tj_auto.max(at / jt);
            }
        }
    }
    let tj = opts.filter_time.unwrap_or(tj_auto);
    if tj == 0.0 && jerk_bounded {
        return Err(JerkError::Limits(
            "a moving joint has a jerk limit but no joint limits the acceleration along the \
             path: give acceleration limits or a filter_time"
                .into(),
        ));
    }
    // Per-interval speed cap and path acceleration.
    let mut own_v = vec![0.0; m];
    let mut own_a = vec![0.0; m];
    for k in 0..m {
        let mut v = path.cap[k + 1];
        for i in 0..n {
            let (p1, p2, p3) = b[k * n + i];
            if p1 > 0.0 {
                v = v.min(vl[i] / p1);
            }
            if p2 > 0.0 {
                v = v.min((rho * al[i] / p2).sqrt());
            }
            if p3 > 0.0 {
                v = v.min((rho * jl[i] / p3).cbrt());
            }
        }
        if !v.is_finite() {
            return Err(JerkError::Limits(format!(
                "nothing bounds the speed between points {k} and {}: give a speed cap or \
                 velocity limits",
                k + 1
            )));
        }
        let mut a = f64::INFINITY;
        for i in 0..n {
            let (p1, p2, p3) = b[k * n + i];
            if p1 > 0.0 {
                a = a.min((al[i] - p2 * v * v) / p1);
            }
            if jl[i].is_finite() {
                let den = if tj > 0.0 { p1 / tj } else { 0.0 } + 3.0 * p2 * v;
                if den > 0.0 {
                    a = a.min((jl[i] - p3 * v * v * v) / den);
                }
            }
        }
        own_v[k] = v;
        own_a[k] = a;
    }
    // Where nothing bounds the path acceleration: the largest finite bound,
    // or reaching the speed in 1 ms.
    let a_max = own_a
        .iter()
        .copied()
        .filter(|a| a.is_finite())
        .fold(0.0, f64::max);
    for k in 0..m {
        if !own_a[k].is_finite() {
            own_a[k] = if a_max > 0.0 { a_max } else { own_v[k] / 1e-3 };
        }
    }
    let l = spline.s[m];
    let cells: Vec<Cell> = (0..m)
        .map(|k| Cell {
            s0: spline.s[k],
            s1: spline.s[k + 1],
            v: own_v[k],
            a: own_a[k],
        })
        .collect();
    if tj == 0.0 {
        let raw = Raw::build(&cells, l);
        return Ok(TimeLaw {
            spline,
            raw,
            tj,
            s_first: path.s[0],
            repairs: 0,
            fallback: false,
        });
    }
    // Each interval's bounds reach V T_j / 2 beyond it. Neighbours with
    // the same bounds are one stretch first (a straight move's points):
    // the zones of their inner ends lie within the stretch and its own
    // zones, with the same bounds, so the capped cells are the same.
    let mut merged: Vec<Cell> = Vec::with_capacity(m);
    for c in &cells {
        match merged.last_mut() {
            Some(p) if p.v == c.v && p.a == c.a => p.s1 = c.s1,
            _ => merged.push(*c),
        }
    }
    let mut zones: Vec<Zone> = Vec::with_capacity(2 * merged.len());
    for c in &merged {
        let r = c.v * tj / 2.0;
        zones.push(Zone {
            s0: c.s0 - r,
            s1: c.s0,
            v: c.v,
            a: c.a,
        });
        zones.push(Zone {
            s0: c.s1,
            s1: c.s1 + r,
            v: c.v,
            a: c.a,
        });
    }
    let base = apply_zones(&merged, &mut zones, l);
    let own = Own {
        s: &spline.s,
        a: &own_a,
    };
    let mut cur = base.clone();
    let mut repairs = 0;
    loop {
        let raw = Raw::build(&cur, l);
        let found = jumps(&raw, tj, &own);
        if found.is_empty() {
            return Ok(TimeLaw {
                spline,
                raw,
                tj,
                s_first: path.s[0],
                repairs,
                fallback: false,
            });
        }
        if repairs >= opts.max_repairs {
            break;
        }
        repairs += 1;
        let mut fix: Vec<Zone> = found.iter().filter_map(|j| repair(&raw, tj, j)).collect();
        if fix.is_empty() {
            break;
        }
        cur = apply_zones(&cur, &mut fix, l);
    }
    // Fallback: half the path acceleration bounds every jump by A.
    let halved: Vec<Cell> = base.iter().map(|c| Cell { a: c.a / 2.0, ..*c }).collect();
    let raw = Raw::build(&halved, l);
    Ok(TimeLaw {
        spline,
        raw,
        tj,
        s_first: path.s[0],
        repairs,
        fallback: true,
    })
}

#[cfg(test)]
mod tests;
