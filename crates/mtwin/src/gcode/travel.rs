//! Machine travel checks of a program's moves, as a [`MotionObserver`] for
//! [`stats_with`](super::stats_with), and the two rules they share with
//! [`interpolate`](super::interpolate): the axis positions of a point of a
//! move ([`machine_position`]) and the travel test ([`first_outside`]).

use nalgebra::Vector3;

use super::arc;
use super::axes::{Axes, Axis};
use super::error::GcodeError;
use super::event::{Event, EventKind, Feed};
use super::stats::{AxisRange, MotionObserver};
use super::syntax::Block;
use crate::kinematics::{IkError, IkOptions, IkTarget, Kinematics};
use crate::model::{AxisKind, Machine};

/// Inverse-kinematics settings of TCP moves, in the interpolator and in the
/// travel check alike.
pub(crate) const TCP_IK: IkOptions = IkOptions {
    max_iterations: 20,
    tip_tolerance: 1e-11,
    axis_tolerance: 1e-13,
    check_travel: false,
    stall_ratio: None,
};

/// Axis positions of the world position `w` (program coordinates plus
/// offsets) into `out`, machine axis order. Without TCP an axis is the
/// G-code axis of its letter (`letter(i)`; axes without one keep their
/// value). Under TCP the rotary axes are so too, and the linear axes come
/// from the nominal inverse kinematics `kin` putting the tool tip at X Y Z of
/// `w` in the workpiece frame, starting from the values in `out` (the
/// previous positions). On error `out` holds the last iterate.
pub(crate) fn machine_position(
    kin: &Kinematics,
    letter: impl Fn(usize) -> Option<Axis>,
    linear: &[bool],
    w: &Axes,
    tcp: bool,
    out: &mut [f64],
) -> Result<(), IkError> {
    for (i, o) in out.iter_mut().enumerate() {
        if let Some(l) = letter(i)
            && !(tcp && linear[i])
        {
            *o = w[l];
        }
    }
    if !tcp {
        return Ok(());
    }
    let tip = Vector3::new(w[Axis::X], w[Axis::Y], w[Axis::Z]);
    if let Some(lin) = three_linear(linear)
        && kin.solve_tip_by_three_linear_axes(lin, &tip, out)
    {
        return Ok(());
    }
    kin.inverse_in_place(&IkTarget { tip, axis: None }, out, linear, &TCP_IK)
}

/// The indices of the linear axes when there are exactly three (the
/// machines whose TCP tip solve is affine).
pub(super) fn three_linear(linear: &[bool]) -> Option<[usize; 3]> {
    let mut lin = [0; 3];
    let mut n = 0;
    for (i, &l) in linear.iter().enumerate() {
        if l {
            if n == 3 {
                return None;
            }
            lin[n] = i;
            n += 1;
        }
    }
    (n == 3).then_some(lin)
}

/// The first machine axis whose position in `q` (machine axis order) is
/// outside its travel ([`crate::model::Axis::in_travel`]), if any.
pub(crate) fn first_outside(machine: &Machine, q: &[f64]) -> Option<usize> {
    machine
        .axes
        .iter()
        .zip(q)
        .position(|(axis, &v)| !axis.in_travel(v))
}

/// One axis position outside its travel.
#[derive(Debug, Clone, PartialEq)]
pub struct TravelViolation {
    /// Source line (1-based).
    pub line: u64,
    /// Machine axis name.
    pub axis: String,
    /// The position, mm or degree (the farthest beyond the travel along the
    /// move).
    pub value: f64,
    /// The travel `[lo, hi]`.
    pub travel: [f64; 2],
}

/// Largest rotary step (deg) and arc sweep step (rad) between the points at
/// which a TCP move is evaluated.
const TCP_ROTARY_STEP: f64 = 0.5;
const TCP_SWEEP_STEP: f64 = std::f64::consts::PI / 180.0;
/// Most points of one TCP move.
const TCP_MAX_SEGMENTS: usize = 4096;
/// Golden-section steps refining the extreme of an axis between two points
/// (the bracket shrinks by 0.618 per step: 60 steps give 3e-13 of it).
const REFINE_STEPS: usize = 60;

/// Checks every move against the machine travels along the whole move, and
/// records the range of every machine axis. Without TCP a machine axis is
/// the G-code axis of the same name plus the event offset: a straight move
/// reaches its extremes at its ends, an arc also at its quadrant points.
/// Under TCP (in the event, or [`TravelCheck::force_tcp`]) the linear axes
/// come from the nominal inverse kinematics ([`machine_position`], as in
/// `gcode interpolate`): the move is evaluated at points at most 0.5° of
/// rotary motion and 1° of arc sweep apart, and the largest and smallest
/// point of each linear axis is refined between its neighbours by
/// golden-section search, so an axis driven beyond its travel between the
/// move's ends is found. The first rapid of a TCP stretch that starts away
/// from the current axis positions goes straight in axis space to its end
/// (as the interpolator moves it): only its end is checked.
pub struct TravelCheck<'m> {
    machine: &'m Machine,
    letters: Vec<Option<Axis>>,
    linear: Vec<bool>,
    kin: Kinematics,
    /// Axis positions at the end of the last move checked.
    last: Option<Vec<f64>>,
    /// Scratch: the points of the current move.
    pts: Vec<(f64, Vec<f64>)>,
    /// Treat every move as a TCP move.
    pub force_tcp: bool,
    /// Violations found (one per move and axis, the farthest value), at
    /// most [`TravelCheck::KEEP`] of them.
    pub violations: Vec<TravelViolation>,
    /// Number of violations found (including those not kept).
    pub count: u64,
    /// Lines of TCP moves with a point the inverse kinematics cannot reach
    /// (first [`TravelCheck::KEEP`]).
    pub unreachable: Vec<u64>,
    /// Range of every machine axis over the points checked (machine axis
    /// order; `None` for an axis without a G-code letter or before any move):
    /// the positions the travel check tests, from the inverse kinematics
    /// under TCP.
    pub ranges: Vec<Option<AxisRange>>,
}

impl<'m> TravelCheck<'m> {
    /// Most violations kept in [`TravelCheck::violations`].
    pub const KEEP: usize = 1000;

    /// A check against `machine` (axes whose names are not G-code letters are
    /// not checked).
    pub fn new(machine: &'m Machine) -> Self {
        TravelCheck {
            machine,
            letters: machine
                .axes
                .iter()
                .map(|a| Axis::from_name(&a.name))
                .collect(),
            linear: machine
                .axes
                .iter()
                .map(|a| a.kind == AxisKind::Linear)
                .collect(),
            kin: Kinematics::nominal(machine),
            last: None,
            pts: Vec::new(),
            force_tcp: false,
            violations: Vec::new(),
            count: 0,
            unreachable: Vec::new(),
            ranges: vec![None; machine.n_axes()],
        }
    }

    /// Axis positions of the world point `w` into `q` (holding the IK start).
    fn position(&self, w: &Axes, tcp: bool, q: &mut [f64]) -> Result<(), IkError> {
        machine_position(&self.kin, |i| self.letters[i], &self.linear, w, tcp, q)
    }

    fn unreachable_at(&mut self, line: u64) {
        if self.unreachable.len() < Self::KEEP {
            self.unreachable.push(line);
        }
    }

    /// Checks the move `at(u)` (world points, `u ∈ [0, 1]`) of `line`:
    /// `segments` intervals under TCP; without TCP `extra` holds the
    /// interior points where an axis has its extreme (arc quadrant points).
    fn check_move(
        &mut self,
        line: u64,
        at: &dyn Fn(f64) -> Axes,
        tcp: bool,
        rapid: bool,
        segments: usize,
        extra: &[Axes],
    ) {
        let n = self.machine.n_axes();
        let guess = |this: &Self, w: &Axes| -> Vec<f64> {
            let mut q = this.last.clone().unwrap_or_else(|| vec![0.0; n]);
            for (i, l) in this.letters.iter().enumerate() {
                if let Some(l) = l {
                    q[i] = w[*l];
                }
            }
            q
        };
        let mut pts = std::mem::take(&mut self.pts);
        pts.clear();
        // The start: counted (for violations) only when the move does not
        // start where the last one ended.
        let w0 = at(0.0);
        let mut q0 = match (&self.last, tcp) {
            (Some(q), true) => q.clone(),
            _ => guess(self, &w0),
        };
        if self.position(&w0, tcp, &mut q0).is_err() {
            self.unreachable_at(line);
            self.pts = pts;
            return;
        }
        let gap = match &self.last {
            Some(q) => q.iter().zip(&q0).any(|(a, b)| (a - b).abs() > 1e-7),
            None => tcp,
        };
        let start_counts = gap && !(tcp && rapid);
        if tcp && rapid && gap {
            // Straight in axis space to the end: only the end.
            let w1 = at(1.0);
            let mut q1 = q0.clone();
            if self.position(&w1, tcp, &mut q1).is_err() {
                self.unreachable_at(line);
                self.pts = pts;
                return;
            }
            pts.push((1.0, q1));
        } else {
            pts.push((0.0, q0));
            if tcp {
                for j in 1..=segments {
                    let u = j as f64 / segments as f64;
                    let mut q = pts[j - 1].1.clone();
                    if self.position(&at(u), tcp, &mut q).is_err() {
                        self.unreachable_at(line);
                        self.pts = pts;
                        return;
                    }
                    pts.push((u, q));
                }
            } else {
                for w in extra.iter().chain(std::iter::once(&at(1.0))) {
                    let mut q = guess(self, w);
                    // Without TCP this cannot fail.
                    let _ = self.position(w, false, &mut q);
                    pts.push((f64::NAN, q));
                }
            }
        }
        // Per axis: the smallest and largest value over the move.
        let first = usize::from(!start_counts && pts.len() > 1);
        for i in 0..n {
            if self.letters[i].is_none() {
                continue;
            }
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            let (mut jlo, mut jhi) = (0, 0);
            for (j, (_, q)) in pts.iter().enumerate() {
                if q[i] < lo {
                    (lo, jlo) = (q[i], j);
                }
                if q[i] > hi {
                    (hi, jhi) = (q[i], j);
                }
            }
            if tcp && self.linear[i] && pts.len() > 2 {
                lo = self.refine(at, &pts, i, jlo, -1.0).unwrap_or(lo);
                hi = self.refine(at, &pts, i, jhi, 1.0).unwrap_or(hi);
            }
            let r = &mut self.ranges[i];
            for v in [lo, hi] {
                AxisRange::include(r, v);
            }
            // Violations: over the points after the start (unless it counts).
            let (mut clo, mut chi) = (f64::INFINITY, f64::NEG_INFINITY);
            for (_, q) in &pts[first..] {
                clo = clo.min(q[i]);
                chi = chi.max(q[i]);
            }
            if jlo >= first {
                clo = clo.min(lo);
            }
            if jhi >= first {
                chi = chi.max(hi);
            }
            let axis = &self.machine.axes[i];
            for v in [chi, clo] {
                if v.is_finite() && !axis.in_travel(v) {
                    self.count += 1;
                    if self.violations.len() < Self::KEEP {
                        self.violations.push(TravelViolation {
                            line,
                            axis: axis.name.clone(),
                            value: v,
                            travel: axis.travel,
                        });
                    }
                    break;
                }
            }
        }
        self.last = pts.last().map(|(_, q)| q.clone());
        self.pts = pts;
    }

    /// The extreme (`sign` 1: largest, −1: smallest) of axis `i` between the
    /// neighbours of the point `j`, by golden-section search; `None` at the
    /// move's ends or where the inverse kinematics fails.
    fn refine(
        &self,
        at: &dyn Fn(f64) -> Axes,
        pts: &[(f64, Vec<f64>)],
        i: usize,
        j: usize,
        sign: f64,
    ) -> Option<f64> {
        if j == 0 || j + 1 >= pts.len() {
            return None;
        }
        let mut q = pts[j].1.clone();
        let mut f = |u: f64| -> Option<f64> {
            self.position(&at(u), true, &mut q).ok()?;
            Some(sign * q[i])
        };
        let g = (5f64.sqrt() - 1.0) / 2.0;
        let (mut a, mut b) = (pts[j - 1].0, pts[j + 1].0);
        let mut c = b - g * (b - a);
        let mut d = a + g * (b - a);
        let (mut fc, mut fd) = (f(c)?, f(d)?);
        for _ in 0..REFINE_STEPS {
            if fc > fd {
                (b, d, fd) = (d, c, fc);
                c = b - g * (b - a);
                fc = f(c)?;
            } else {
                (a, c, fc) = (c, d, fd);
                d = a + g * (b - a);
                fd = f(d)?;
            }
        }
        Some(sign * fc.max(fd).max(sign * pts[j].1[i]))
    }

    /// Segments of a TCP move: rotary motion and arc sweep in small steps.
    fn segments(&self, d: &Axes, sweep: f64) -> usize {
        let rot = self
            .letters
            .iter()
            .zip(&self.linear)
            .filter_map(|(l, &lin)| l.filter(|_| !lin).map(|l| d[l].abs()))
            .fold(0.0, f64::max);
        let n = (rot / TCP_ROTARY_STEP)
            .max(sweep.abs() / TCP_SWEEP_STEP)
            .ceil();
        if n <= 1.0 {
            // Without rotary motion a straight TCP move is straight in axis space.
            if sweep == 0.0 { 1 } else { 4 }
        } else {
            (n as usize).clamp(4, TCP_MAX_SEGMENTS)
        }
    }
}

impl MotionObserver for TravelCheck<'_> {
    fn observe(&mut self, _: &Block, event: &Event) -> Result<(), GcodeError> {
        let line = event.at.line;
        match &event.kind {
            EventKind::Traverse(m) | EventKind::Feed(m) => {
                let tcp = m.tcp || self.force_tcp;
                let at = |u: f64| super::timing::lerp(&m.from, &m.to, u).add(&m.offset);
                let segments = self.segments(&m.to.sub(&m.from), 0.0);
                let rapid = matches!(m.feed, Feed::Rapid);
                self.check_move(line, &at, tcp, rapid, segments, &[]);
            }
            EventKind::Arc(a) => {
                let tcp = a.tcp || self.force_tcp;
                let g = arc::geometry(a);
                let at = |u: f64| arc::point_at(a, &g, u).add(&a.offset);
                let (p, q, _) = a.plane.axes();
                let extra: Vec<Axes> = if tcp {
                    Vec::new()
                } else {
                    let pts = arc::plane_points(a);
                    pts[1..pts.len() - 1]
                        .iter()
                        .map(|pt| {
                            let mut x = a.from;
                            x[p] = pt[0];
                            x[q] = pt[1];
                            x.add(&a.offset)
                        })
                        .collect()
                };
                let segments = self.segments(&a.to.sub(&a.from), g.sweep);
                self.check_move(line, &at, tcp, false, segments, &extra);
            }
            _ => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::{StatsOptions, stats_with};
    use crate::model::Axis as MAxis;

    #[test]
    fn arc_extremes_out_of_travel_are_found() {
        let x = MAxis::new(
            "X",
            AxisKind::Linear,
            [1.0, 0.0, 0.0],
            [0.0; 3],
            [-5.0, 100.0],
        );
        let y = MAxis::new(
            "Y",
            AxisKind::Linear,
            [0.0, 1.0, 0.0],
            [0.0; 3],
            [-100.0, 100.0],
        );
        let m = Machine {
            name: "xy".into(),
            axes: vec![x, y],
            tool_chain: vec![0, 1],
            workpiece_chain: vec![],
            tool_tip: Vector3::zeros(),
            tool_direction: Vector3::z(),
            workpiece_origin: Vector3::zeros(),
            rapid_feed: 1000.0,
        };
        // A half circle about the origin from (0, 10) to (0, -10) through
        // -X reaches X = -10 at its extreme, though both ends have X = 0.
        let prog = "G0 X0 Y10\nG3 X0 Y-10 I0 J-10 F100\n";
        let mut check = TravelCheck::new(&m);
        stats_with(prog.as_bytes(), &StatsOptions::default(), &mut check).unwrap();
        assert_eq!(check.count, 1);
        let v = &check.violations[0];
        assert_eq!((v.line, v.axis.as_str()), (2, "X"));
        assert!((v.value + 10.0).abs() < 1e-12);
    }

    fn trunnion() -> Machine {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/machines/ac-trunnion.toml");
        crate::model::read_machine(&p).unwrap()
    }

    #[test]
    fn tcp_turn_beyond_travel_between_inside_ends_is_found_at_its_peak() {
        // Tip held at (250, 250, 0) in W while C turns 0 → 90°: the machine's
        // (X, Y) = Rz(C)·(250, 250) (A = 0), inside ±300 at both ends, with
        // Y = 250·√2 at C = 45° (closed form of the nominal trunnion).
        let m = trunnion();
        let prog = "G0 X250 Y250 Z0 A0 C0\nG1 C90 F2000\n";
        let mut check = TravelCheck::new(&m);
        check.force_tcp = true;
        let mut opts = StatsOptions::default();
        opts.interp.tcp_at_start = true;
        stats_with(prog.as_bytes(), &opts, &mut check).unwrap();
        assert_eq!(check.count, 1, "{:?}", check.violations);
        let v = &check.violations[0];
        assert_eq!((v.line, v.axis.as_str()), (2, "Y"));
        assert!((v.value - 250.0 * 2f64.sqrt()).abs() < 1e-9, "{}", v.value);
        // Ranges: X from 250 to −250 (monotone: 250·(cos C − sin C)), Y up
        // to the peak, Z at −150 throughout.
        let x = check.ranges[1].unwrap();
        assert!((x.min + 250.0).abs() < 1e-9 && (x.max - 250.0).abs() < 1e-9);
        let y = check.ranges[0].unwrap();
        assert!((y.max - 250.0 * 2f64.sqrt()).abs() < 1e-9 && (y.min - 250.0).abs() < 1e-9);
        let z = check.ranges[2].unwrap();
        assert!((z.min + 150.0).abs() < 1e-9 && (z.max + 150.0).abs() < 1e-9);
        // A radius of 282.8 mm stays inside all along.
        let mut ok = TravelCheck::new(&m);
        ok.force_tcp = true;
        stats_with(
            "G0 X200 Y200 Z0 A0 C0\nG1 C90 F2000\n".as_bytes(),
            &opts,
            &mut ok,
        )
        .unwrap();
        assert_eq!((ok.count, ok.unreachable.len()), (0, 0));
    }
}
