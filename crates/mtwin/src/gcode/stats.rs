//! Program statistics from the canonical events: counts, path lengths, per
//! axis travel and range, and an estimated time (programmed feeds, G93
//! inverse time, rapids at a configured rate, dwells; no acceleration).
//!
//! Further checks (e.g. travel limits of a machine) plug in as a
//! [`MotionObserver`] passed to [`stats_with`], seeing every event.

use std::io::BufRead;

use super::arc;
use super::axes::{Axes, Axis};
use super::error::GcodeError;
use super::event::{ArcMove, Event, EventKind, Feed, Linear};
use super::interp::{InterpOptions, Interpreter};
use super::interpolate::{InterpolateError, InterpolateOptions, planned_duration_with};
use super::program_flow::{Step, run_program};
use super::syntax::Block;
use super::timing;
use crate::model::Machine;

/// Settings of [`stats`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct StatsOptions {
    /// Interpreter settings (offsets, tools, dialect, ...).
    pub interp: InterpOptions,
    /// Rapid feed of the linear axes along the path, mm/min (the machine's
    /// [`Machine::rapid_feed`](crate::model::Machine::rapid_feed)).
    pub rapid_feed: f64,
    /// Rapid feed of each rotary axis, deg/min.
    pub rapid_feed_rotary: f64,
}

impl Default for StatsOptions {
    /// Rapids at [`DEFAULT_RAPID_FEED`](crate::model::DEFAULT_RAPID_FEED)
    /// (10 m/min) and 3600 deg/min (10 rev/min).
    fn default() -> Self {
        StatsOptions {
            interp: InterpOptions::default(),
            rapid_feed: crate::model::DEFAULT_RAPID_FEED,
            rapid_feed_rotary: 3600.0,
        }
    }
}

/// Smallest and largest value an axis reached, mm or degree.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisRange {
    /// Smallest value, mm or degree.
    pub min: f64,
    /// Largest value, mm or degree.
    pub max: f64,
}

impl AxisRange {
    pub(crate) fn include(range: &mut Option<AxisRange>, v: f64) {
        match range {
            Some(r) => {
                r.min = r.min.min(v);
                r.max = r.max.max(v);
            }
            None => *range = Some(AxisRange { min: v, max: v }),
        }
    }
}

/// Statistics of one program.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ProgramStats {
    /// Blocks (lines) read.
    pub blocks: u64,
    /// Blocks that moved an axis.
    pub motion_blocks: u64,
    /// Rapid (G0) moves.
    pub rapid_moves: u64,
    /// Straight feed (G1) moves.
    pub linear_moves: u64,
    /// Arc (G2/G3) moves.
    pub arc_moves: u64,
    /// XYZ path length of feed moves (straight and arc), mm.
    pub feed_length: f64,
    /// XYZ path length of rapid moves, mm.
    pub rapid_length: f64,
    /// Total travel of each axis (sum of |change|, arcs exact), mm or degree.
    pub axis_travel: Axes,
    /// Range of each axis over the moves, work coordinates (arcs include
    /// their extreme points); `None` for an axis that never moved or stood.
    pub work_range: [Option<AxisRange>; 9],
    /// The same in machine coordinates before kinematics (work + work offset
    /// + tool length offset); meaningful for axis limits only without TCP.
    pub machine_range: [Option<AxisRange>; 9],
    /// Time of feed moves, s.
    pub feed_time: f64,
    /// Time of rapid moves, s.
    pub rapid_time: f64,
    /// Dwell time, s.
    pub dwell_time: f64,
    /// The program's time as a trajectory planner runs it on a machine
    /// (accelerations and junctions included), s, when one was computed
    /// (`gcode stats --machine`); not set by [`stats`].
    pub planned_time: Option<f64>,
}

impl ProgramStats {
    /// Estimated total time, s: the planned time when there is one, else
    /// feeds, rapids and dwells without acceleration.
    pub fn total_time(&self) -> f64 {
        self.planned_time
            .unwrap_or(self.feed_time + self.rapid_time + self.dwell_time)
    }

    /// Adds one event.
    pub fn add(&mut self, event: &Event, opts: &StatsOptions) -> Result<(), GcodeError> {
        self.add_after(event, opts, &mut LastEnd::default())
    }

    /// [`ProgramStats::add`] of the event after the one that left `last`
    /// (see [`LastEnd`]), which it updates.
    fn add_after(
        &mut self,
        event: &Event,
        opts: &StatsOptions,
        last: &mut LastEnd,
    ) -> Result<(), GcodeError> {
        match &event.kind {
            EventKind::Traverse(m) => {
                self.rapid_moves += 1;
                let d = m.to.sub(&m.from);
                self.rapid_length += d.xyz_norm();
                self.rapid_time +=
                    timing::rapid_seconds(&d, opts.rapid_feed, opts.rapid_feed_rotary);
                self.linear_extent(m, last);
            }
            EventKind::Feed(m) => {
                self.linear_moves += 1;
                let d = m.to.sub(&m.from);
                self.feed_length += d.xyz_norm();
                self.feed_time += feed_seconds(m.feed, d.xyz_norm(), &d, event, opts)?;
                self.linear_extent(m, last);
            }
            EventKind::Arc(a) => {
                self.arc_moves += 1;
                let len = a.xyz_length();
                self.feed_length += len;
                self.feed_time += feed_seconds(a.feed, len, &a.to.sub(&a.from), event, opts)?;
                self.arc_extent(a, last);
            }
            EventKind::Dwell { seconds } => self.dwell_time += seconds,
            _ => {}
        }
        Ok(())
    }

    fn include(&mut self, work: &Axes, offset: &Axes) {
        for i in 0..9 {
            AxisRange::include(&mut self.work_range[i], work.0[i]);
            AxisRange::include(&mut self.machine_range[i], work.0[i] + offset.0[i]);
        }
    }

    /// Includes the start of a move, unless it is the point (and offset)
    /// the last range update included: including a value twice in a row
    /// changes no range (`min` and `max` return the same operand each time,
    /// signed zeros included), so the result is the same bit for bit.
    fn include_start(&mut self, from: &Axes, offset: &Axes, last: &LastEnd) {
        let same = |a: &Axes, b: &Axes| {
            a.0.iter()
                .zip(&b.0)
                .all(|(x, y)| x.to_bits() == y.to_bits())
        };
        if !(last.valid && same(&last.to, from) && same(&last.offset, offset)) {
            self.include(from, offset);
        }
    }

    fn linear_extent(&mut self, m: &Linear, last: &mut LastEnd) {
        for i in 0..9 {
            self.axis_travel.0[i] += (m.to.0[i] - m.from.0[i]).abs();
        }
        self.include_start(&m.from, &m.offset, last);
        self.include(&m.to, &m.offset);
        // Field by field, in place (an `Option` of the pair was a 0.14 KB
        // copy through `memcpy` per move).
        last.to = m.to;
        last.offset = m.offset;
        last.valid = true;
    }

    fn arc_extent(&mut self, a: &ArcMove, last: &mut LastEnd) {
        let (p, q, _) = a.plane.axes();
        // Out-of-plane axes move linearly.
        for axis in Axis::ALL {
            if axis != p && axis != q {
                self.axis_travel[axis] += (a.to[axis] - a.from[axis]).abs();
            }
        }
        // In-plane axes: monotone between quadrant crossings.
        let pts = arc::plane_points(a);
        for w in pts.windows(2) {
            self.axis_travel[p] += (w[1][0] - w[0][0]).abs();
            self.axis_travel[q] += (w[1][1] - w[0][1]).abs();
        }
        self.include_start(&a.from, &a.offset, last);
        self.include(&a.to, &a.offset);
        // The points below are the last ones included.
        last.valid = false;
        for pt in &pts {
            let mut x = a.from;
            x[p] = pt[0];
            x[q] = pt[1];
            AxisRange::include(&mut self.work_range[p.index()], x[p]);
            AxisRange::include(&mut self.work_range[q.index()], x[q]);
            AxisRange::include(&mut self.machine_range[p.index()], x[p] + a.offset[p]);
            AxisRange::include(&mut self.machine_range[q.index()], x[q] + a.offset[q]);
        }
    }
}

/// The end of the last straight move and its offset, when that end was the
/// last point whose ranges were updated (none after an arc, whose extreme
/// points come last, and at the start).
#[derive(Default)]
struct LastEnd {
    /// `to` and `offset` are that point.
    valid: bool,
    /// The end, work coordinates.
    to: Axes,
    /// Its offset.
    offset: Axes,
}

/// Time of a feed move ([`timing::move_seconds`]); a move that cannot be
/// timed is an error naming its line.
fn feed_seconds(
    feed: Feed,
    xyz: f64,
    d: &Axes,
    event: &Event,
    opts: &StatsOptions,
) -> Result<f64, GcodeError> {
    timing::move_seconds(feed, xyz, d, opts.rapid_feed)
        .map_err(|e| GcodeError::invalid(event.at.line, 0, &e.0))
}

/// Sees every canonical event of a program (with its block) during
/// [`stats_with`]; the place for checks such as machine travel limits.
pub trait MotionObserver {
    /// Called for each event, in order.
    fn observe(&mut self, block: &Block, event: &Event) -> Result<(), GcodeError>;
}

/// An observer that does nothing.
impl MotionObserver for () {
    fn observe(&mut self, _: &Block, _: &Event) -> Result<(), GcodeError> {
        Ok(())
    }
}

/// Statistics of the program read from `input`, streaming (constant memory).
pub fn stats<R: BufRead>(input: R, opts: &StatsOptions) -> Result<ProgramStats, GcodeError> {
    stats_with(input, opts, &mut ())
}

/// [`stats`] that also shows every event to `observer`.
pub fn stats_with<R: BufRead>(
    input: R,
    opts: &StatsOptions,
    observer: &mut dyn MotionObserver,
) -> Result<ProgramStats, GcodeError> {
    let mut interp = Interpreter::new(opts.interp.clone());
    let mut st = ProgramStats::default();
    let mut last = LastEnd::default();
    run_program(
        input,
        &mut interp,
        &opts.interp.program,
        opts.interp.dialect,
        |step: &Step<'_>| st.step(step, opts, observer, &mut last),
    )?;
    Ok(st)
}

/// [`stats_with`] and the program's
/// [`planned_duration`](super::planned_duration) on `machine` under
/// `plan` (its interpreter settings are `plan.interp`, which should be
/// `opts.interp`) from one run of the interpreter. The planned time is an
/// error when the program cannot be planned on the machine (the statistics
/// are complete then); [`ProgramStats::planned_time`] is left unset.
pub fn stats_planned<R: BufRead>(
    input: R,
    opts: &StatsOptions,
    observer: &mut dyn MotionObserver,
    machine: &Machine,
    plan: &InterpolateOptions,
) -> Result<(ProgramStats, Result<f64, InterpolateError>), GcodeError> {
    let mut st = ProgramStats::default();
    let mut last = LastEnd::default();
    let planned = planned_duration_with(input, machine, plan, &mut |step: &Step<'_>| {
        st.step(step, opts, observer, &mut last)
    })?;
    Ok((st, planned))
}

impl ProgramStats {
    /// Adds one step (a block and its events) and shows its events to `observer`.
    fn step(
        &mut self,
        step: &Step<'_>,
        opts: &StatsOptions,
        observer: &mut dyn MotionObserver,
        last: &mut LastEnd,
    ) -> Result<(), GcodeError> {
        self.blocks += 1;
        let mut moved = false;
        for e in step.events {
            moved |= matches!(
                e.kind,
                EventKind::Traverse(_) | EventKind::Feed(_) | EventKind::Arc(_)
            );
            self.add_after(e, opts, last)?;
            observer.observe(step.block, e)?;
        }
        self.motion_blocks += u64::from(moved);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    fn st(src: &str) -> ProgramStats {
        stats(src.as_bytes(), &StatsOptions::default()).unwrap()
    }

    #[test]
    fn square_at_feed_plus_rapid_and_dwell() {
        let s = st("G0 X0 Y0 Z100\nG0 Z0\nG1 X10 F600\nY10\nX0\nY0\nG4 P1.5\nM30\n");
        assert_eq!(s.blocks, 8);
        assert_eq!(s.motion_blocks, 6);
        assert_eq!((s.rapid_moves, s.linear_moves, s.arc_moves), (2, 4, 0));
        assert!((s.feed_length - 40.0).abs() < 1e-12);
        assert!((s.feed_time - 4.0).abs() < 1e-12, "40 mm at 600 mm/min");
        assert!((s.rapid_length - 200.0).abs() < 1e-12);
        assert!((s.rapid_time - 60.0 * 200.0 / 10_000.0).abs() < 1e-12);
        assert_eq!(s.dwell_time, 1.5);
        assert_eq!(s.axis_travel[Axis::X], 20.0);
        assert_eq!(
            s.work_range[Axis::Z.index()],
            Some(AxisRange {
                min: 0.0,
                max: 100.0
            })
        );
        assert!((s.total_time() - (4.0 + 1.2 + 1.5)).abs() < 1e-12);
    }

    #[test]
    fn arcs_reach_their_extremes_and_travel_exactly() {
        // Full circle radius 10 about the origin, from (10, 0).
        let s = st("G0 X10 Y0\nG3 X10 Y0 I-10 F100\n");
        let r = |a: Axis| s.work_range[a.index()].unwrap();
        assert!((r(Axis::X).min + 10.0).abs() < 1e-12 && (r(Axis::Y).max - 10.0).abs() < 1e-12);
        assert!((r(Axis::Y).min + 10.0).abs() < 1e-12);
        // Per-axis travel of a full circle is 4 r; X also had the 10 mm rapid.
        assert!((s.axis_travel[Axis::X] - 50.0).abs() < 1e-9);
        assert!((s.axis_travel[Axis::Y] - 40.0).abs() < 1e-9);
        assert!((s.feed_time - 60.0 * 2.0 * PI * 10.0 / 100.0).abs() < 1e-9);
        // A quarter arc from (10,0) to (0,10) crosses no quadrant boundary
        // inside: X range stays [0, 10].
        let q = st("G0 X10 Y0\nG3 X0 Y10 R10 F100\n");
        assert_eq!(q.work_range[0].unwrap().min, 0.0);
    }

    #[test]
    fn inverse_time_per_revolution_and_rotary_only_feeds() {
        let s = st("G93 G1 X100 F2\nG1 X0 F0.5\n");
        assert!((s.feed_time - (30.0 + 120.0)).abs() < 1e-12);
        let r = st("G95 S500 G1 X10 F0.1\n");
        assert!((r.feed_time - 60.0 * 10.0 / (0.1 * 500.0)).abs() < 1e-12);
        assert!(
            stats("G95 G1 X10 F0.1\n".as_bytes(), &StatsOptions::default()).is_err(),
            "spindle at 0"
        );
        // Rotary-only G94 move: F in deg/min along the rotary path.
        let c = st("G1 C90 F180\n");
        assert!((c.feed_time - 30.0).abs() < 1e-12);
        // Rapid of a rotary axis at the rotary rapid rate.
        let g0 = st("G0 A360\n");
        assert!((g0.rapid_time - 6.0).abs() < 1e-12);
    }

    #[test]
    fn ranges_are_those_of_adding_every_event_alone() {
        // `stats` skips the start of a move that is the end of the one
        // before; `add` includes every start. Same ranges bit for bit, signed
        // zeros included, across offset changes (G92) and arcs.
        let src = "G0 X-0 Y0 Z5\nG1 X0 Y-0 Z-0 F100\nG1 X10\nG92 X3\nG1 X-0\nG1 X-0\n\
                   G2 X5 Y5 I2.5 J2.5\nG1 Y-0\nG0 X0 Y0\nG92.1\nG1 X-0 Y-0\nM30\n";
        let got = st(src);
        let program = crate::gcode::stream::Program::parse(src.as_bytes()).unwrap();
        let opts = StatsOptions::default();
        let mut it = Interpreter::new(opts.interp.clone());
        let mut want = ProgramStats::default();
        for b in &program.blocks {
            let mut events = Vec::new();
            it.execute(b, &mut events).unwrap();
            for e in &events {
                want.add(e, &opts).unwrap();
            }
        }
        let bits =
            |r: &[Option<AxisRange>; 9]| r.map(|r| r.map(|r| (r.min.to_bits(), r.max.to_bits())));
        assert_eq!(bits(&got.work_range), bits(&want.work_range));
        assert_eq!(bits(&got.machine_range), bits(&want.machine_range));
        assert_eq!(got.axis_travel, want.axis_travel);
        assert_eq!(got.feed_length, want.feed_length);
        // Closed forms: G92 X3 at X10 shifts by 7, so the arc's end at work
        // X5 is machine X12; the clockwise arc about (2.5, 2.5) from (0, 0)
        // to (5, 5) passes its leftmost point, 2.5 − 2.5·√2 in work X.
        assert_eq!(got.machine_range[0].unwrap().max, 12.0);
        let left = 2.5 - 2.5 * 2f64.sqrt();
        assert!((got.work_range[0].unwrap().min - left).abs() < 1e-12);
    }

    #[test]
    fn observer_sees_every_event() {
        struct Count(usize);
        impl MotionObserver for Count {
            fn observe(&mut self, _: &Block, _: &Event) -> Result<(), GcodeError> {
                self.0 += 1;
                Ok(())
            }
        }
        let mut c = Count(0);
        // Events: feed rate, feed, traverse.
        stats_with(
            "G1 X1 F10\nG0 X0\n".as_bytes(),
            &StatsOptions::default(),
            &mut c,
        )
        .unwrap();
        assert_eq!(c.0, 3);
    }
}
