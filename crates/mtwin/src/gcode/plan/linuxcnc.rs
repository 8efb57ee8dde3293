//! LinuxCNC 2.9's trajectory-planner rules, as its sources and manual
//! describe them (see `docs/references.md`; behaviour re-stated, no code
//! copied):
//!
//! * **Limits on the world axes.** A straight move's path is its XYZ length
//!   (else UVW, else ABC); its highest speed is the path length over the
//!   longest time any moving world axis needs at its `max_velocity`, its
//!   acceleration the path length over the longest `|Δ|/max_acceleration`
//!   (rotary axes are given the time to finish with the linear ones). An arc
//!   also keeps the in-plane speed within `√(√3/2 · a · r)` and, in the
//!   planner, splits the acceleration between normal (`v²/r`, at most
//!   `√3/2·a`) and tangential (what is left, at least `a/2`).
//! * **Speeds.** Feed moves run at the programmed speed (× feed override),
//!   rapids at the move's highest speed; both within the trajectory limit
//!   (the machine's `rapid_feed`, LinuxCNC's `[TRAJ] MAX_LINEAR_VELOCITY`)
//!   unless only rotary axes move, and within one path length per cycle.
//! * **Junctions.** Under G61.1 every block stops. Two blocks without
//!   rotary or UVW motion whose directions differ so little that the
//!   direction change at full speed needs less than `kink_ratio` of the
//!   axis accelerations join tangentially (no stop, also under G61); under
//!   G64 other corners blend by the fastest of: a circular blend arc between
//!   two straight blocks ([`line_line_blend`]), a parabolic blend (both
//!   blocks at half acceleration, the next starting while this one slows
//!   down, the blend speed within the P tolerance), or a tangent junction at
//!   a reduced speed. Blocks with rotary motion always blend parabolically
//!   under G64.

use super::lookahead::Join;
use crate::gcode::axes::{Axes, Axis};
use crate::gcode::event::PathMode;

/// `√3/2`: the share of the acceleration an arc keeps for its normal
/// acceleration (LinuxCNC's `BLEND_ACC_RATIO_NORMAL` with a tangential ratio of 1/2).
const NORMAL_RATIO: f64 = 0.866_025_403_784_438_6;
/// The tangential share of the acceleration on arcs at their speed limit.
const TANGENTIAL_RATIO: f64 = 0.5;
/// Displacement below which an axis counts as not moving.
const STILL: f64 = 1e-9;

/// Limits of the world axes (program axes X Y Z A B C U V W), mm/s, deg/s,
/// mm/s², deg/s²; infinite where the machine has none or lacks the axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldLimits {
    /// `max_velocity` per axis letter.
    pub vel: [f64; 9],
    /// `max_acceleration` per axis letter.
    pub acc: [f64; 9],
    /// Trajectory speed limit of non-rotary moves, mm/s.
    pub v_traj: f64,
}

/// A move's path length, highest speed and acceleration by the world-axis
/// limits (before feed, trajectory limit and junction rules).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveLimits {
    /// Path length: XYZ, else UVW, else ABC (mm or deg).
    pub len: f64,
    /// Highest path speed the axis limits allow, per s.
    pub v: f64,
    /// Path acceleration the axis limits allow, per s².
    pub a: f64,
    /// Only rotary axes move.
    pub pure_rotary: bool,
    /// A rotary or UVW axis moves.
    pub rotary: bool,
}

fn norm(d: &Axes, axes: [Axis; 3]) -> f64 {
    axes.iter().map(|&a| d[a] * d[a]).sum::<f64>().sqrt()
}

const XYZ: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];
const ABC: [Axis; 3] = [Axis::A, Axis::B, Axis::C];
const UVW: [Axis; 3] = [Axis::U, Axis::V, Axis::W];

/// Limits of a straight move of displacement `d` (LinuxCNC's straight
/// velocity and acceleration rules).
pub fn straight(d: &Axes, lim: &WorldLimits) -> MoveLimits {
    let moved = |a: Axis| d[a].abs() > STILL;
    let cart = XYZ.iter().chain(&UVW).any(|&a| moved(a));
    let ang = ABC.iter().any(|&a| moved(a));
    let rot_uvw = ang || UVW.iter().any(|&a| moved(a));
    let xyz = norm(d, XYZ);
    let len = if xyz > STILL {
        xyz
    } else if norm(d, UVW) > STILL {
        norm(d, UVW)
    } else {
        norm(d, ABC)
    };
    let mut tv = 0.0f64;
    let mut ta = 0.0f64;
    for a in Axis::ALL {
        let counts = if cart { true } else { a.is_rotary() };
        if counts && moved(a) {
            let i = a.index();
            tv = tv.max(d[a].abs() / lim.vel[i]);
            ta = ta.max(d[a].abs() / lim.acc[i]);
        }
    }
    MoveLimits {
        len,
        v: if tv > 0.0 { len / tv } else { f64::INFINITY },
        a: if ta > 0.0 { len / ta } else { f64::INFINITY },
        pure_rotary: ang && !cart,
        rotary: rot_uvw,
    }
}

/// The arc shape the limits need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcShape {
    /// First and second in-plane axes.
    pub plane: (Axis, Axis),
    /// Start and end radius, mm.
    pub radius: (f64, f64),
    /// Swept angle, rad (absolute value used).
    pub sweep: f64,
    /// Displacement along the normal, mm.
    pub normal_len: f64,
}

impl ArcShape {
    /// The radius LinuxCNC uses for the normal acceleration of a spiral:
    /// `√((Δr/φ)² + r_min²)`.
    pub fn effective_radius(&self) -> f64 {
        let dr = (self.radius.1 - self.radius.0) / self.sweep.abs().max(1e-12);
        let rmin = self.radius.0.min(self.radius.1);
        (dr * dr + rmin * rmin).sqrt()
    }
}

/// Limits of an arc (LinuxCNC's arc-feed rules): `chord` is the end minus
/// the start (all axes), `len` the helical XYZ length.
pub fn arc(chord: &Axes, shape: &ArcShape, len: f64, lim: &WorldLimits) -> MoveLimits {
    let (p, q) = shape.plane;
    let v_axes = lim.vel[p.index()].min(lim.vel[q.index()]);
    let a_axes = lim.acc[p.index()].min(lim.acc[q.index()]);
    let r_eff = shape.effective_radius();
    let v_radial = (a_axes * NORMAL_RATIO * r_eff).sqrt();
    let v_planar = v_radial.min(v_axes);
    let st = straight(chord, lim);
    let rmin = shape.radius.0.min(shape.radius.1);
    let spiral = (rmin * shape.sweep.abs()).hypot(shape.radius.1 - shape.radius.0);
    let total = spiral.hypot(shape.normal_len);
    let t_motion = if st.v.is_finite() && st.v > 0.0 {
        st.len / st.v
    } else {
        0.0
    };
    let t_v = t_motion.max(spiral / v_planar);
    let tt_motion = if st.a.is_finite() && st.a > 0.0 {
        st.len / st.a
    } else {
        0.0
    };
    let t_a = tt_motion.max(spiral / a_axes);
    MoveLimits {
        len,
        v: if t_v > 0.0 {
            total / t_v
        } else {
            f64::INFINITY
        },
        a: if t_a > 0.0 {
            total / t_a
        } else {
            f64::INFINITY
        },
        pure_rotary: false,
        rotary: st.rotary,
    }
}

/// The planner's speed cap and tangential-acceleration share of an arc at
/// overall acceleration `a` (LinuxCNC's actual-arc-speed rule): the speed
/// at most `√(√3/2·a·r)`; the tangential share `√(1 − (v²/r/a)²)`, `1/2`
/// at the cap.
pub fn arc_speed_and_ratio(v_max: f64, a: f64, r_eff: f64) -> (f64, f64) {
    let an_cut = NORMAL_RATIO * a;
    let an = v_max * v_max / r_eff.max(1e-300);
    if an > an_cut {
        ((an_cut * r_eff).sqrt(), TANGENTIAL_RATIO)
    } else {
        (v_max, (1.0 - (an / a).powi(2)).sqrt())
    }
}

/// One side of a junction, as the join rules see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Side {
    /// Unit XYZ direction of travel at the junction (zero when XYZ is still).
    pub dir: [f64; 3],
    /// A rotary or UVW axis moves.
    pub rotary: bool,
    /// The block is an arc.
    pub circular: bool,
    /// Target speed (feed and limits), per s.
    pub v: f64,
    /// Acceleration before any blend or kink reduction, per s².
    pub a: f64,
    /// Path length (what is left of the block after earlier trims).
    pub len: f64,
    /// Programmed length of the block (LinuxCNC's `nominal_length`).
    pub nominal: f64,
    /// Requested speed (feed), per s.
    pub v_req: f64,
    /// Highest speed by the axis limits and the cycle (LinuxCNC's `maxvel`), per s.
    pub v_max: f64,
    /// The block's G64 P tolerance, mm (0: none given).
    pub tolerance: f64,
}

/// How two blocks join and what it does to their accelerations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoinRule {
    /// How the blocks join.
    pub join: Join,
    /// Factor on the acceleration of the block before (blend: 1/2; kink:
    /// `1 − ratio`).
    pub a_prev: f64,
    /// Factor on the acceleration of the block after.
    pub a_next: f64,
    /// A circular blend arc replaces the corner: the block before ends
    /// `trim` before it, the block after starts `trim` after it, and the arc
    /// joins them tangentially (`join` is then the tangent junction speed).
    pub arc: Option<BlendArc>,
}

/// A circular blend arc between two straight blocks (LinuxCNC 2.9's
/// line–line blend arc): tangent to both, within the blend tolerance of
/// the corner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlendArc {
    /// Radius, mm.
    pub radius: f64,
    /// Distance from the corner to the arc's ends along each block, mm.
    pub trim: f64,
    /// Swept angle, rad (π minus the angle between the blocks).
    pub phi: f64,
    /// Unit direction from the corner to the arc's centre (the bisector).
    pub normal: [f64; 3],
    /// Highest speed on the arc (its normal acceleration within
    /// `√3/2 · a`, and at most its length per cycle), mm/s.
    pub v_max: f64,
    /// Requested speed (the faster of the two blocks' feeds), mm/s.
    pub v_req: f64,
    /// Acceleration limit in the arc's plane, mm/s² (half of it tangential).
    pub a: f64,
}

impl BlendArc {
    /// Arc length, mm.
    pub fn len(&self) -> f64 {
        self.radius * self.phi
    }

    /// The arc's limits along its path (tangential acceleration `a/2`).
    pub fn limits(&self) -> (f64, f64) {
        (self.v_req.min(self.v_max), self.a * TANGENTIAL_RATIO)
    }
}

/// The largest circle centred in the box `±bounds` cut by the plane of unit
/// normal `n` (LinuxCNC's inscribed-diameter rule for the limits in a
/// blend's plane): `min_i bounds_i / √(1 − n_i²)` over the axes with a bound.
pub fn planar_bound(n: &[f64; 3], bounds: &[f64; 3]) -> f64 {
    let mut out = f64::INFINITY;
    for i in 0..3 {
        if bounds[i] > 0.0 && bounds[i].is_finite() {
            let scale = (1.0 - n[i] * n[i]).max(0.0).sqrt().max(1e-12);
            out = out.min(bounds[i] / scale);
        }
    }
    out
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (n > 1e-300).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

/// The blend tolerance of two blocks (LinuxCNC's rule): each block's G64 P
/// (a quarter of its programmed length when none is given), at most a
/// quarter of either block's programmed length.
pub fn blend_tolerance(prev: &Side, next: &Side) -> f64 {
    let own = |s: &Side| {
        if s.tolerance > 0.0 {
            s.tolerance
        } else {
            s.nominal * 0.25
        }
    };
    own(prev)
        .min(own(next))
        .min(prev.nominal * 0.25)
        .min(next.nominal * 0.25)
}

/// LinuxCNC 2.9's circular blend arc between the straight blocks `prev` and
/// `next` (`None` when the blocks are (anti)parallel or the arc would be
/// degenerate). The arc may use at most half of either block (its distance
/// from the corner at most half of `next`, and half of `prev`'s programmed
/// length or what is left of it), deviates from the corner by at most the
/// blend tolerance, and its speed keeps the normal acceleration within
/// `√3/2` of the acceleration limit in its plane; its radius is then
/// enlarged towards the size of the equivalent parabolic blend.
pub fn line_line_blend(prev: &Side, next: &Side, set: &JoinSettings) -> Option<BlendArc> {
    let (u1, u2) = (prev.dir, next.dir);
    let dot: f64 = (0..3).map(|i| u1[i] * u2[i]).sum();
    let theta = (-dot.clamp(-1.0, 1.0)).acos() / 2.0;
    let eps = 1e-6;
    if std::f64::consts::FRAC_PI_2 - theta < eps || theta < eps {
        return None;
    }
    let binormal = unit(cross(&u1, &u2))?;
    let normal = unit([u2[0] - u1[0], u2[1] - u1[1], u2[2] - u1[2]])?;
    let phi = std::f64::consts::PI - 2.0 * theta;
    let tolerance = blend_tolerance(prev, next);
    let a_max = planar_bound(&binormal, &set.acc_xyz);
    let a_n = a_max * NORMAL_RATIO;
    let scale = set.max_feed_scale;
    let v_req = prev.v_req.max(next.v_req);
    let mut v_goal = (prev.v_req * scale)
        .min(prev.v_max)
        .max((next.v_req * scale).min(next.v_max));
    let v_planar = planar_bound(&binormal, &set.vel_xyz);
    let phi_eff = phi.min(std::f64::consts::PI * 0.49);
    let v1 = prev.v_max.min(next.v_max / phi_eff.cos());
    let v2 = next.v_max.min(prev.v_max / phi_eff.cos());
    let area = v1 * v2 / 2.0 * phi.sin();
    let base = (0..3)
        .map(|i| (u2[i] * v2 - u1[i] * v1).powi(2))
        .sum::<f64>()
        .sqrt();
    let v_alt = if base > 0.0 { 2.0 * area / base } else { 0.0 };
    v_goal = v_goal.min(v_alt.max(v_planar));
    let l1 = prev.len.min(prev.nominal * 0.5);
    let l2 = next.len * 0.5;
    let h_tol = tolerance / (1.0 - theta.sin());
    let d_tol = theta.cos() * h_tol;
    let d_geom = l1.min(l2).min(d_tol);
    let r_geom = theta.tan() * d_geom;
    let v_plan = (a_n * r_geom).sqrt().min(v_goal);
    let a_par = a_max * 0.5;
    let v_tri = (2.0 * a_par * d_geom).sqrt();
    let s_blend = v_tri.min(v_plan) / a_par * v_plan;
    let r_blend = (s_blend / phi).min(r_geom);
    let radius = (v_plan * v_plan / a_n).max(r_blend);
    let s_arc = radius * phi;
    if !(radius >= 1e-12 && s_arc >= 1e-6 && v_plan.is_finite()) {
        return None;
    }
    Some(BlendArc {
        radius,
        trim: radius / theta.tan(),
        phi,
        normal,
        v_max: v_plan.min(s_arc / set.cycle_time),
        v_req,
        a: a_max,
    })
}

/// Settings of the join rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoinSettings {
    /// Servo/trajectory cycle, s.
    pub cycle_time: f64,
    /// Largest share of the axis accelerations a direction change at full
    /// speed may take for the blocks to join tangentially (LinuxCNC's
    /// `ARC_BLEND_KINK_RATIO`, default 0.1).
    pub kink_ratio: f64,
    /// XYZ acceleration limits, mm/s² (for the direction-change check).
    pub acc_xyz: [f64; 3],
    /// XYZ velocity limits, mm/s (blend arcs).
    pub vel_xyz: [f64; 3],
    /// Highest feed override the blend arcs are sized for (LinuxCNC's
    /// `[DISPLAY] MAX_FEED_OVERRIDE`).
    pub max_feed_scale: f64,
}

fn stop() -> JoinRule {
    JoinRule {
        join: Join::Stop,
        a_prev: 1.0,
        a_next: 1.0,
        arc: None,
    }
}

/// LinuxCNC's blend speeds of a parabolic blend between `prev` and `next`
/// (both at their blended accelerations): the speed of `prev` at which the
/// blend starts, and the net speed along the blend (its performance).
pub fn parabolic_blend_speed(prev: &Side, next: &Side, tolerance: Option<f64>) -> (f64, f64) {
    let reach = |s: &Side| (s.a * s.len).sqrt().min(s.v);
    let (r1, r2) = (reach(prev), reach(next));
    let t_reach = (prev.len / r1).min(next.len / r2);
    let t_blend = t_reach.min((r1 / prev.a).max(r2 / next.a));
    let mut v1 = r1.min(t_blend * prev.a);
    let mut v2 = r2.min(t_blend * next.a);
    let dot: f64 = (0..3).map(|i| prev.dir[i] * next.dir[i]).sum();
    let theta = (-dot.clamp(-1.0, 1.0)).acos() / 2.0;
    let cos = theta.cos();
    if let Some(t) = tolerance
        && cos > (std::f64::consts::FRAC_PI_2 - 1e-3).cos()
    {
        let v = 2.0 * (prev.a * t / cos).sqrt();
        v1 = v1.min(v);
        v2 = v2.min(v);
    }
    (v1, theta.sin() * (v1 + v2) / 2.0)
}

/// The join of `prev` (queued under `mode`) and `next`.
pub fn join(mode: PathMode, prev: &Side, next: &Side, set: &JoinSettings) -> JoinRule {
    let blend_mode = match mode {
        PathMode::ExactStop => return stop(),
        PathMode::ExactPath => None,
        PathMode::Blend { p, .. } => Some(p),
    };
    let parabolic = |tol: Option<f64>| {
        let mut a = *prev;
        let mut b = *next;
        a.a *= 0.5;
        b.a *= 0.5;
        let (v, _) = parabolic_blend_speed(&a, &b, tol);
        JoinRule {
            join: Join::Blend { v },
            a_prev: 0.5,
            a_next: 0.5,
            arc: None,
        }
    };
    if prev.rotary || next.rotary {
        return match blend_mode {
            Some(tol) => parabolic(tol),
            None => stop(),
        };
    }
    // Reversal within 2 degrees: a sharp corner, stop.
    let dot: f64 = (0..3).map(|i| prev.dir[i] * next.dir[i]).sum();
    let sharp = (2.0f64).to_radians();
    if dot < -(1.0 - sharp * sharp / 2.0) {
        return stop();
    }
    let v_max = prev.v.min(next.v);
    let a_inst = v_max / set.cycle_time + next.a;
    let mut scale = 0.0f64;
    for i in 0..3 {
        let diff = a_inst * (next.dir[i] - prev.dir[i]);
        if set.acc_xyz[i] > 0.0 && set.acc_xyz[i].is_finite() {
            scale = scale.max((diff / set.acc_xyz[i]).abs());
        }
    }
    if prev.circular || next.circular {
        scale /= TANGENTIAL_RATIO;
    }
    let k = set.kink_ratio;
    if scale < k {
        return JoinRule {
            join: Join::Tangent { v: v_max },
            a_prev: 1.0 - scale,
            a_next: 1.0 - scale,
            arc: None,
        };
    }
    let Some(tol) = blend_mode else {
        return stop();
    };
    let kink_v = v_max * k / scale;
    let mut a = *prev;
    let mut b = *next;
    a.a *= 0.5;
    b.a *= 0.5;
    let (_, net) = parabolic_blend_speed(&a, &b, tol);
    // LinuxCNC's choice: the fastest of the parabolic blend (its net speed
    // halved, for the halved accelerations), the tangent kink and the blend
    // arc (straight blocks only here); the first on a tie.
    let arc = if prev.circular || next.circular {
        None
    } else {
        line_line_blend(prev, next, set)
    };
    let perf_arc = arc.map_or(0.0, |a| a.v_max);
    let perf_par = net / 2.0;
    if perf_par >= kink_v && perf_par >= perf_arc {
        parabolic(tol)
    } else if kink_v >= perf_arc {
        JoinRule {
            join: Join::Tangent { v: kink_v },
            a_prev: 1.0 - k,
            a_next: 1.0 - k,
            arc: None,
        }
    } else {
        JoinRule {
            join: Join::Tangent { v: perf_arc },
            a_prev: 1.0,
            a_next: 1.0,
            arc,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> WorldLimits {
        let mut vel = [f64::INFINITY; 9];
        let mut acc = [f64::INFINITY; 9];
        for (i, (v, a)) in [(20.0, 300.0), (20.0, 300.0), (20.0, 300.0), (30.0, 300.0)]
            .iter()
            .enumerate()
        {
            vel[i] = *v;
            acc[i] = *a;
        }
        WorldLimits {
            vel,
            acc,
            v_traj: 35.0,
        }
    }

    #[test]
    fn straight_limits_follow_the_slowest_axis() {
        // (3, 4) mm in XY: X needs 3/20 s, Y 4/20 s: v = 5 / 0.2 = 25 mm/s.
        let mut d = Axes::default();
        d[Axis::X] = 3.0;
        d[Axis::Y] = 4.0;
        let m = straight(&d, &lim());
        assert!((m.len - 5.0).abs() < 1e-12);
        assert!((m.v - 25.0).abs() < 1e-12);
        assert!((m.a - 375.0).abs() < 1e-12);
        // Adding 60 deg of A (2 s at 30 deg/s) slows the path to 5/2 mm/s.
        d[Axis::A] = 60.0;
        let m = straight(&d, &lim());
        assert!((m.v - 2.5).abs() < 1e-12 && m.rotary && !m.pure_rotary);
        // Pure rotary: the ABC length at the A limit.
        let mut r = Axes::default();
        r[Axis::A] = 90.0;
        let m = straight(&r, &lim());
        assert!(m.pure_rotary && (m.len - 90.0).abs() < 1e-12 && (m.v - 30.0).abs() < 1e-12);
    }

    #[test]
    fn arc_speed_cap_is_the_normal_share() {
        // r = 1, a = 300: cap √(√3/2·300) = 16.12 mm/s; slower keeps more tangential.
        let (v, ratio) = arc_speed_and_ratio(100.0, 300.0, 1.0);
        assert!((v - (NORMAL_RATIO * 300.0f64).sqrt()).abs() < 1e-12);
        assert_eq!(ratio, 0.5);
        let (v, ratio) = arc_speed_and_ratio(10.0, 300.0, 1.0);
        assert_eq!(v, 10.0);
        assert!((ratio - (1.0 - (100.0f64 / 300.0).powi(2)).sqrt()).abs() < 1e-12);
    }

    fn side(dir: [f64; 3]) -> Side {
        Side {
            dir,
            rotary: false,
            circular: false,
            v: 10.0,
            a: 300.0,
            len: 10.0,
            nominal: 10.0,
            v_req: 10.0,
            v_max: 20.0,
            tolerance: 0.01,
        }
    }

    fn settings() -> JoinSettings {
        JoinSettings {
            cycle_time: 0.001,
            kink_ratio: 0.1,
            acc_xyz: [300.0; 3],
            vel_xyz: [20.0; 3],
            max_feed_scale: 1.0,
        }
    }

    #[test]
    fn collinear_blocks_join_tangentially_even_under_g61() {
        let s = settings();
        let a = side([1.0, 0.0, 0.0]);
        for mode in [PathMode::ExactPath, PathMode::DEFAULT] {
            let r = join(mode, &a, &a, &s);
            assert_eq!(r.join, Join::Tangent { v: 10.0 });
        }
        assert_eq!(join(PathMode::ExactStop, &a, &a, &s).join, Join::Stop);
        // A right angle stops under G61 and blends under G64.
        let b = side([0.0, 1.0, 0.0]);
        assert_eq!(join(PathMode::ExactPath, &a, &b, &s).join, Join::Stop);
        let r = join(
            PathMode::Blend {
                p: Some(0.01),
                q: None,
            },
            &a,
            &b,
            &s,
        );
        assert!(r.arc.is_some(), "{r:?}");
    }

    /// A right-angle corner under G64 P0.01: the arc tangent to both lines
    /// whose midpoint is 0.01 from the corner has radius `T/(√2 − 1)`
    /// (centre on the bisector at `R√2` from the corner), its ends `R` from
    /// the corner; its speed `√(√3/2·a·R)`; the parabolic blend (net speed
    /// about 1 mm/s) and the kink (0.03 mm/s) are slower.
    #[test]
    fn right_angle_blend_arc_touches_the_tolerance() {
        let s = settings();
        let a = side([1.0, 0.0, 0.0]);
        let b = side([0.0, 1.0, 0.0]);
        let arc = line_line_blend(&a, &b, &s).unwrap();
        let r = 0.01 / (2f64.sqrt() - 1.0);
        assert!((arc.radius - r).abs() < 1e-12, "{} {r}", arc.radius);
        assert!((arc.trim - r).abs() < 1e-12);
        assert!((arc.phi - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let v = (3f64.sqrt() / 2.0 * 300.0 * r).sqrt();
        assert!((arc.v_max - v).abs() < 1e-9, "{} {v}", arc.v_max);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((arc.normal[0] + h).abs() < 1e-12 && (arc.normal[1] - h).abs() < 1e-12);
        // Without P the tolerance is a quarter of the shorter block: 2.5,
        // the arc then limited by half the block (5) and sized by speed.
        let mut a2 = a;
        let mut b2 = b;
        a2.tolerance = 0.0;
        b2.tolerance = 0.0;
        assert_eq!(blend_tolerance(&a2, &b2), 2.5);
        let big = line_line_blend(&a2, &b2, &s).unwrap();
        assert!(big.radius > arc.radius && big.trim <= 5.0 + 1e-12);
        // Its speed is at most the requested feed's goal (10 mm/s here).
        assert!(big.limits().0 <= 10.0 + 1e-12);
        // Parallel and reversed blocks have no arc.
        assert!(line_line_blend(&a, &a, &s).is_none());
        assert!(line_line_blend(&a, &side([-1.0, 0.0, 0.0]), &s).is_none());
    }

    #[test]
    fn planar_bound_is_the_inscribed_circle() {
        // XY plane: the smaller of the X and Y bounds; a plane at 45° about
        // Y between X and Z: X's bound stretched by √2 (its axis lies at
        // 45° in the plane), Z's too: min(300√2, 200√2).
        assert_eq!(
            planar_bound(&[0.0, 0.0, 1.0], &[300.0, 200.0, 100.0]),
            200.0
        );
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let b = planar_bound(&[h, 0.0, h], &[300.0, 500.0, 200.0]);
        assert!((b - 200.0 * 2f64.sqrt()).abs() < 1e-9, "{b}");
    }
}
