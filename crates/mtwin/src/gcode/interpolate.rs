//! Interpolation: axis command samples at a fixed period along a program,
//! following the interpreter's [`Event`]s, within the axis velocity and
//! acceleration limits of a [`Machine`].
//!
//! * Every move (G0, G1, G2/G3) and every dwell is one *segment*. A segment
//!   runs a rest-to-rest trapezoidal profile in its path parameter
//!   `s ∈ [0, 1]`: **the machine stops at every block end** (no blending
//!   between blocks). The programmed speed caps the path speed: G0 uses the
//!   machine's `rapid_feed` (mm/min), G1/G2/G3 the programmed feed (G94
//!   mm/min, G93 inverse time, G95 mm/rev × spindle speed), applied as in
//!   LinuxCNC to the XYZ path (else UVW, else the rotary axes in deg/min).
//! * The path speed and acceleration are then scaled down so that no axis
//!   exceeds `Axis::max_velocity` / `Axis::max_acceleration` (absent = no
//!   limit). With `|dq/ds| ≤ D1` and `|d²q/ds²| ≤ D2` on the segment, the
//!   path speed is at most `vmax/D1` and `√(amax/(2·D2))`, and the path
//!   acceleration at most `amax/(2·D1)` (`amax/D1` when `D2 = 0`), so
//!   `|q̈| ≤ D2·ṡ² + D1·|s̈| ≤ amax`. D1 and D2 are exact for straight
//!   moves and closed-form bounds for arcs; under TCP they are estimated by
//!   finite differences at 16 sub-steps with a 10 % margin (second
//!   differences at the rounding level of the joint positions count as
//!   zero, so a joint path that is a straight line is timed as one).
//! * Without TCP, axis words map to machine axes by name (X Y Z A B C U V
//!   W): machine position = program coordinate + work offset + tool length
//!   offset. With TCP (on in the event, or forced by
//!   [`InterpolateOptions::force_tcp`]), X Y Z + offsets are the tool tip in
//!   the workpiece frame W, the rotary words (+ offsets) are rotary axis
//!   positions, and the linear axes are solved at every sample by
//!   `Kinematics::nominal(machine).inverse` with only the linear axes free,
//!   so the nominal tip moves exactly on the programmed line or arc.
//! * When a move starts away from the current axis positions (TCP switched
//!   on, so the same program position means another axis position), a
//!   straight *transition* in axis space at the rapid rate joins them; it is
//!   counted in [`InterpolationSummary::transitions`]. A rapid (G0) that
//!   starts away from the current axis positions under TCP is itself made that
//!   transition, straight in axis space to its end: the program's last
//!   numbers are not where the tool is, and going to them first would move
//!   the tool where the program never sent it.
//! * Samples are at `t = k·ts`, k = 0, 1, ..., with a last sample at the
//!   first `k·ts` not before the end of the program (holding the final
//!   position). They are handed to a callback one by one: memory does not
//!   grow with the program.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::io::{self, BufRead};

use super::arc::{self, Geometry};
use super::axes::{Axes, Axis, AxisLetterError};
use super::error::GcodeError;
use super::event::{ArcMove, Event, EventKind, Feed, Linear, PathMode, SpindleState};
use super::interp::{InterpOptions, Interpreter};
use super::plan::jerk::blend::{self as jblend, Curve};
use super::plan::jerk::{self, JointLimits, JointPath};
use super::plan::linuxcnc;
use super::plan::lookahead::{Join, Limits, Lookahead, Planned};
use super::plan::naive_cam::NaiveCam;
use super::plan::{PlanOptions, Planner};
use super::program_flow::{Step, run_program};
use super::timing::{self, lerp};
use super::travel;
use crate::kinematics::{IkError, Kinematics};
use crate::model::{AxisKind, Machine};

/// Settings of [`interpolate`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct InterpolateOptions {
    /// Interpreter settings (work offsets, tool table, dialect, TCP M-codes).
    pub interp: InterpOptions,
    /// Sample period, s.
    pub ts: f64,
    /// Treat every move as a TCP move (XYZ = tool tip in W), whatever the
    /// program says.
    pub force_tcp: bool,
    /// Stop with [`InterpolateError::OutOfTravel`] when a sample leaves an
    /// axis travel (otherwise samples are written as computed, never clipped).
    pub check_travel: bool,
    /// Most samples handed to the callback ([`crate::limits::MAX_SAMPLES`]
    /// by default); a program that would need more stops with
    /// [`InterpolateError::TooManySamples`] before the samples of the move
    /// that crosses the bound are made.
    pub max_samples: u64,
    /// The trajectory planner and its settings.
    pub plan: PlanOptions,
}

impl InterpolateOptions {
    /// Default interpreter settings, period `ts` (s), TCP as programmed,
    /// travel checked.
    pub fn new(ts: f64) -> Self {
        InterpolateOptions {
            interp: InterpOptions::default(),
            ts,
            force_tcp: false,
            check_travel: true,
            max_samples: crate::limits::MAX_SAMPLES,
            plan: PlanOptions::default(),
        }
    }
}

/// One command sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample<'a> {
    /// Time since program start, s (`k·ts`).
    pub t: f64,
    /// Axis positions in machine axis order (`Machine::axes`), mm or degree.
    pub q: &'a [f64],
    /// Source line (1-based) of the block being executed; 0 before the first.
    pub line: u64,
}

/// What an interpolation did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct InterpolationSummary {
    /// Samples handed to the callback.
    pub samples: u64,
    /// Program duration (end of the last segment), s.
    pub duration: f64,
    /// Moves interpolated (zero-length moves are not counted).
    pub moves: u64,
    /// Axis-space transitions inserted (see the module documentation).
    pub transitions: u64,
    /// Dwell time, s.
    pub dwell_time: f64,
}

/// Why a program cannot be interpolated.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InterpolateError {
    /// The sample period is not a positive finite number.
    #[error("the sample period must be a positive number of seconds, not {0}")]
    Period(f64),
    /// The machine's axes are not one G-code axis letter each.
    #[error(transparent)]
    AxisName(#[from] AxisLetterError),
    /// The program moves an axis the machine does not have.
    #[error("line {line}: the program moves axis {letter}, which the machine does not have")]
    MissingAxis { line: u64, letter: char },
    /// A move cannot be timed (zero feed, G95 with the spindle stopped).
    #[error("line {line}: {message}")]
    Feed { line: u64, message: String },
    /// Inverse kinematics failed for a TCP sample.
    #[error("line {line}: cannot place the tool tip at ({x}, {y}, {z}) mm in W: {source}")]
    Ik {
        line: u64,
        x: f64,
        y: f64,
        z: f64,
        #[source]
        source: IkError,
    },
    /// The program needs more samples than [`InterpolateOptions::max_samples`].
    #[error(
        "line {line}: the program runs to t = {} s, which at a sample period of {} s is more than {max} samples (the limit): use a longer sample period",
        crate::limits::fmt_message_number(*t),
        crate::limits::fmt_message_number(*ts)
    )]
    TooManySamples {
        line: u64,
        t: f64,
        ts: f64,
        max: u64,
    },
    /// A sample leaves an axis travel.
    #[error(
        "line {line}: axis {axis} reaches {value} {unit} at t = {t} s, outside its travel [{lo}, {hi}]"
    )]
    OutOfTravel {
        line: u64,
        axis: String,
        value: f64,
        unit: &'static str,
        t: f64,
        lo: f64,
        hi: f64,
    },
    /// Reading or interpreting the program failed.
    #[error(transparent)]
    Gcode(#[from] GcodeError),
    /// The planner settings are out of range.
    #[error("{0}")]
    Plan(String),
    /// The planner needs a limit the machine file does not give.
    #[error(
        "axis `{axis}` has no `{key}` ({unit}), which the jerk planner needs on every axis: add it to the axis in the machine file"
    )]
    MissingLimit {
        /// Axis name.
        axis: String,
        /// The machine-file key.
        key: &'static str,
        /// Its unit.
        unit: String,
    },
    /// The sample callback failed.
    #[error("writing samples failed: {0}")]
    Sink(#[source] io::Error),
}

impl InterpolateError {
    /// Source line of the problem, if it has one.
    pub fn line(&self) -> Option<u64> {
        match self {
            InterpolateError::MissingAxis { line, .. }
            | InterpolateError::Feed { line, .. }
            | InterpolateError::Ik { line, .. }
            | InterpolateError::OutOfTravel { line, .. }
            | InterpolateError::TooManySamples { line, .. } => Some(*line),
            InterpolateError::Gcode(e) => e.location().map(|l| l.line),
            _ => None,
        }
    }

    /// 1-based column of the problem (0 when the whole block is at fault).
    pub fn column(&self) -> u32 {
        match self {
            InterpolateError::Gcode(e) => e.location().map_or(0, |l| l.column),
            _ => 0,
        }
    }

    /// What went wrong, without the location (for callers that print the
    /// location themselves, as `file:line:col: message`); a located
    /// error's [`Display`](std::fmt::Display) is `line N: ` and this.
    pub fn message(&self) -> String {
        match self {
            InterpolateError::Gcode(e) => e.message(),
            InterpolateError::MissingAxis { letter, .. } => {
                format!("the program moves axis {letter}, which the machine does not have")
            }
            InterpolateError::Feed { message, .. } => message.clone(),
            InterpolateError::Ik {
                x, y, z, source, ..
            } => {
                format!("cannot place the tool tip at ({x}, {y}, {z}) mm in W: {source}")
            }
            InterpolateError::TooManySamples { t, ts, max, .. } => format!(
                "the program runs to t = {} s, which at a sample period of {} s is more than {max} samples (the limit): use a longer sample period",
                crate::limits::fmt_message_number(*t),
                crate::limits::fmt_message_number(*ts)
            ),
            InterpolateError::OutOfTravel {
                axis,
                value,
                unit,
                t,
                lo,
                hi,
                ..
            } => format!(
                "axis {axis} reaches {value} {unit} at t = {t} s, outside its travel [{lo}, {hi}]"
            ),
            other => other.to_string(),
        }
    }
}

/// The geometry of a move in work coordinates as a function of `s ∈ [0, 1]`.
#[derive(Debug, Clone, Copy)]
enum Geom {
    Line {
        from: Axes,
        to: Axes,
    },
    Arc {
        arc: ArcMove,
        g: Geometry,
    },
    /// A `linuxcnc` blend arc: XYZ = `center + r (cos(φs) e1 + sin(φs) e2)`,
    /// the other axes at `from`.
    Blend {
        from: Axes,
        center: [f64; 3],
        e1: [f64; 3],
        e2: [f64; 3],
        r: f64,
        phi: f64,
    },
}

impl Geom {
    fn at(&self, s: f64) -> Axes {
        match self {
            Geom::Line { from, to } => lerp(from, to, s),
            Geom::Arc { arc, g } => arc::point_at(arc, g, s),
            Geom::Blend {
                from,
                center,
                e1,
                e2,
                r,
                phi,
            } => {
                let mut x = *from;
                let (c, sn) = ((phi * s).cos(), (phi * s).sin());
                for (i, a) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
                    x[a] = center[i] + r * (c * e1[i] + sn * e2[i]);
                }
                x
            }
        }
    }
}

/// Unit XYZ direction of travel of `geom` at `u ∈ [0, 1]` (zero when XYZ
/// does not move), by a central difference.
fn direction(geom: &Geom, u: f64) -> [f64; 3] {
    let h = 1e-6;
    let (a, b) = ((u - h).max(0.0), (u + h).min(1.0));
    let (p, q) = (geom.at(a), geom.at(b));
    let d = [
        q[Axis::X] - p[Axis::X],
        q[Axis::Y] - p[Axis::Y],
        q[Axis::Z] - p[Axis::Z],
    ];
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if n > 0.0 {
        [d[0] / n, d[1] / n, d[2] / n]
    } else {
        [0.0; 3]
    }
}

/// A block of motion.
enum Path {
    /// Straight in axis space.
    Joint { q0: Vec<f64>, q1: Vec<f64> },
    /// A programmed move.
    Work {
        geom: Box<Geom>,
        offset: Axes,
        tcp: bool,
    },
    /// Standing still (a dwell).
    Hold { q: Vec<f64> },
}

/// A queued block: its path, the length of its path parameter (the path
/// parameter `s ∈ [0, len]` maps to `s / len` along the path), its line.
struct Block {
    path: Path,
    len: f64,
    line: u64,
}

/// What the `linuxcnc` join rules need of the last queued block.
#[derive(Clone, Copy)]
struct Tail {
    side: linuxcnc::Side,
    mode: PathMode,
    tcp: bool,
    offset: Axes,
    speed: Speed,
}

/// The speed and acceleration inputs of a `linuxcnc` block, before its
/// joins are known.
#[derive(Clone, Copy)]
struct Speed {
    len: f64,
    /// Highest speed by the axis limits and the cycle, per s.
    v_ini: f64,
    /// Requested speed (feed × override, or the rapid speed), within the
    /// trajectory limit, per s.
    v_req: f64,
    /// Acceleration by the axis limits, per s².
    a_base: f64,
    /// Effective radius of an arc.
    r_eff: Option<f64>,
    /// The acceleration is halved by a parabolic blend before or after.
    halved: bool,
    /// Acceleration reduction of a tangent kink before or after.
    kink: f64,
}

impl Speed {
    /// Target speed and tangential acceleration.
    fn limits(&self) -> Limits {
        let a = self.a_base * (1.0 - self.kink) * if self.halved { 0.5 } else { 1.0 };
        let (v_max, ratio) = match self.r_eff {
            Some(r) if a.is_finite() => linuxcnc::arc_speed_and_ratio(self.v_ini, a, r),
            _ => (self.v_ini, 1.0),
        };
        Limits {
            len: self.len,
            v: self.v_req.min(v_max),
            a: a * ratio,
        }
    }
}

/// Sub-steps of the finite-difference derivative bounds under TCP.
const FD_STEPS: usize = 16;

/// A second difference of TCP joint positions up to `FD_NOISE + 64·ε·|q|`
/// (mm or deg) is rounding, not curvature, and counts as zero. The positions
/// come from the inverse kinematics, solved to 1e-11 mm (and 1e-13 rad),
/// with rounding of a few ε·|q|: three of them make a second difference
/// below 4·(1e-11 + ε·|q|), 25 times below the bound. Without it, a joint
/// path that is affine in `s` (a TCP line with the rotary axes held) had a
/// second derivative of pure noise, and its path acceleration was halved or
/// not (`amax/(2·D1)` against `amax/D1`) with the rounding of the block's
/// ends. A real curvature below the bound adds at most
/// `1e-9·FD_STEPS²·ṡ² ≈ 2.6e-7·ṡ²` (mm/s² or deg/s²; ṡ in 1/s) to a joint's
/// acceleration: 0.26 mm/s² for a 0.1 mm block at 6 m/min.
const FD_NOISE: f64 = 1e-9;
/// Axis-space distance below which a move's start is the current position.
const SAME_POSITION: f64 = 1e-7;

/// Streams samples for the events given to it (see the module documentation).
pub struct Interpolator<'m> {
    machine: &'m Machine,
    kin: Kinematics,
    letters: Vec<Axis>,
    linear: Vec<bool>,
    opts: InterpolateOptions,
    /// Axis positions at the end of the last queued block.
    q: Vec<f64>,
    /// Scratch axis positions (the last sample, the IK start).
    buf: Vec<f64>,
    /// Index of the next sample.
    k: u64,
    line: u64,
    summary: InterpolationSummary,
    world: linuxcnc::WorldLimits,
    queue: Lookahead<Block>,
    active: VecDeque<Planned<Block>>,
    mode: PathMode,
    tail: Option<Tail>,
    cam: NaiveCam,
    /// Spindle turning, and its programmed speed (rev/min).
    spindle: (bool, f64),
    /// `(line, end time)` of every planned segment, when asked for
    /// ([`line_end_times`]).
    ends: Option<Vec<(u64, f64)>>,
}

impl<'m> Interpolator<'m> {
    /// An interpolator for `machine` (its nominal kinematics is used for
    /// TCP), starting at `opts.interp.initial_machine_position`.
    pub fn new(machine: &'m Machine, opts: &InterpolateOptions) -> Result<Self, InterpolateError> {
        if !(opts.ts > 0.0 && opts.ts.is_finite()) {
            return Err(InterpolateError::Period(opts.ts));
        }
        let p = &opts.plan;
        if !(p.feed_override > 0.0 && p.feed_override.is_finite()) {
            return Err(InterpolateError::Plan(format!(
                "the feed override must be a positive fraction, not {}",
                p.feed_override
            )));
        }
        if !(p.derivative_margin >= 1.0 && p.derivative_margin.is_finite()) {
            return Err(InterpolateError::Plan(format!(
                "the derivative margin must be a number ≥ 1, not {}",
                p.derivative_margin
            )));
        }
        if !(p.cycle_time > 0.0 && p.cycle_time.is_finite()) || p.lookahead == 0 {
            return Err(InterpolateError::Plan(
                "the planner cycle time must be positive and the look-ahead at least one block"
                    .into(),
            ));
        }
        if p.planner == Planner::Jerk {
            return Err(InterpolateError::Plan(
                "the jerk planner plans whole chains of moves at once: use `interpolate` or `dense_paths`, not an `Interpolator`".into(),
            ));
        }
        let letters = Axis::of_machine(machine)?;
        let q: Vec<f64> = letters
            .iter()
            .map(|&l| opts.interp.initial_machine_position[l])
            .collect();
        let mut opts = opts.clone();
        if opts.force_tcp {
            opts.interp.tcp_at_start = true;
        }
        let mut vel = [f64::INFINITY; 9];
        let mut acc = [f64::INFINITY; 9];
        for (axis, l) in machine.axes.iter().zip(&letters) {
            vel[l.index()] = axis.max_velocity.unwrap_or(f64::INFINITY);
            acc[l.index()] = axis.max_acceleration.unwrap_or(f64::INFINITY);
        }
        let depth = match opts.plan.planner {
            Planner::ExactStop => 1,
            _ => opts.plan.lookahead,
        };
        Ok(Interpolator {
            machine,
            kin: Kinematics::nominal(machine),
            linear: machine
                .axes
                .iter()
                .map(|a| a.kind == AxisKind::Linear)
                .collect(),
            letters,
            buf: q.clone(),
            q,
            opts,
            k: 0,
            line: 0,
            summary: InterpolationSummary::default(),
            world: linuxcnc::WorldLimits {
                vel,
                acc,
                v_traj: machine.rapid_feed / 60.0,
            },
            queue: Lookahead::new(depth),
            active: VecDeque::new(),
            mode: PathMode::DEFAULT,
            tail: None,
            cam: NaiveCam::new(),
            spindle: (false, 0.0),
            ends: None,
        })
    }

    /// The settings in force (with `interp.tcp_at_start` set when TCP is forced).
    pub fn options(&self) -> &InterpolateOptions {
        &self.opts
    }

    /// Axis positions at the end of the moves given so far, machine axis order.
    pub fn position(&self) -> &[f64] {
        &self.q
    }

    /// Interpolates one event, handing the samples it makes ready to `sink`
    /// (with look-ahead, the samples of a move come once the moves after it
    /// are known, or at [`Interpolator::finish`]).
    pub fn push<F>(&mut self, event: &Event, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        self.line = event.at.line;
        let force = self.opts.force_tcp;
        // G64 Q under `linuxcnc`: straight feeds merge (plan::naive_cam).
        if let (Planner::Linuxcnc, PathMode::Blend { q: Some(q), .. }) =
            (self.opts.plan.planner, self.mode)
            && q > 0.0
            && let EventKind::Feed(m) = &event.kind
            && !matches!(m.feed, Feed::InverseTime(_))
        {
            for (m, line) in self.cam.see(m, self.line, q).into_iter().flatten() {
                self.line = line;
                self.linear_move(&m, force, sink)?;
            }
            return Ok(());
        }
        if !matches!(event.kind, EventKind::FeedRate(_))
            && let Some((m, line)) = self.cam.flush()
        {
            self.line = line;
            self.linear_move(&m, force, sink)?;
            self.line = event.at.line;
        }
        match &event.kind {
            EventKind::Traverse(m) | EventKind::Feed(m) => self.linear_move(m, force, sink),
            EventKind::Arc(a) => {
                let geom = Geom::Arc {
                    arc: *a,
                    g: arc::geometry(a),
                };
                self.work_move(geom, &a.from, &a.to, a.offset, a.feed, a.tcp || force, sink)
            }
            EventKind::Dwell { seconds } if *seconds > 0.0 => {
                self.summary.dwell_time += seconds;
                let block = Block {
                    path: Path::Hold { q: self.q.clone() },
                    len: *seconds,
                    line: self.line,
                };
                let lim = Limits {
                    len: *seconds,
                    v: 1.0,
                    a: f64::INFINITY,
                };
                self.enqueue(block, lim, None, sink)
            }
            EventKind::PathControl(mode) => {
                self.mode = *mode;
                Ok(())
            }
            EventKind::SpindleSpeed { rpm } => {
                let before = self.spindle.1;
                self.spindle.1 = *rpm;
                if self.spindle.0 && before != *rpm {
                    let wait = (rpm - before).abs() / self.opts.plan.spindle_accel;
                    return self.task_pause(wait, sink);
                }
                Ok(())
            }
            EventKind::Spindle(state) => {
                let on = !matches!(state, SpindleState::Stopped);
                let ramp = if on && !self.spindle.0 {
                    self.spindle.1.abs() / self.opts.plan.spindle_accel
                } else {
                    0.0
                };
                self.spindle.0 = on;
                self.task_pause(self.opts.plan.task_wait.max(ramp), sink)
            }
            EventKind::Tcp(_) => self.task_pause(self.opts.plan.task_wait, sink),
            EventKind::Wait(w) => {
                let wait = if w.through_io() {
                    self.opts.plan.io_wait
                } else {
                    self.opts.plan.task_wait
                };
                self.task_pause(wait, sink)
            }
            _ => Ok(()),
        }
    }

    /// `linuxcnc`: the machine stops and stands still for `wait` s (LinuxCNC's
    /// task waiting for the motion queue to empty before a spindle, TCP,
    /// coolant, tool or I/O command, and for the spindle to reach its
    /// speed); with no wait it still stops (no blend across the command).
    fn task_pause<F>(&mut self, wait: f64, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        match self.opts.plan.planner {
            // Before the first move the machine has not started: LinuxCNC's
            // run time counts from the first motion.
            Planner::Linuxcnc
                if wait > 0.0
                    && wait.is_finite()
                    && self.summary.moves + self.summary.transitions > 0 =>
            {
                let block = Block {
                    path: Path::Hold { q: self.q.clone() },
                    len: wait,
                    line: self.line,
                };
                let lim = Limits {
                    len: wait,
                    v: 1.0,
                    a: f64::INFINITY,
                };
                self.enqueue(block, lim, None, sink)
            }
            Planner::Linuxcnc => {
                self.end_chain();
                self.tail = None;
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Plans and samples what is still queued, emits the last sample (at
    /// the first `k·ts` not before the end) and returns the summary.
    pub fn finish<F>(self, sink: &mut F) -> Result<InterpolationSummary, InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        self.finish_with_ends(sink).map(|(s, _)| s)
    }

    /// [`Interpolator::finish`], also handing back the `(line, end time)` of
    /// every planned segment when they were recorded.
    fn finish_with_ends<F>(
        mut self,
        sink: &mut F,
    ) -> Result<(InterpolationSummary, Vec<(u64, f64)>), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        if let Some((m, line)) = self.cam.flush() {
            self.line = line;
            let force = self.opts.force_tcp;
            self.linear_move(&m, force, sink)?;
        }
        self.end_chain();
        while let Some(p) = self.queue.pop_flush() {
            self.start(p, sink)?;
        }
        let end = self.active.iter().map(|p| p.t1()).fold(0.0, f64::max);
        self.emit_until(end, sink)?;
        let t = self.k as f64 * self.opts.ts;
        let sample = Sample {
            t,
            q: &self.q,
            line: self.active.back().map_or(self.line, |p| p.payload.line),
        };
        sink(&sample).map_err(InterpolateError::Sink)?;
        self.summary.samples += 1;
        self.summary.duration = end;
        Ok((self.summary, self.ends.take().unwrap_or_default()))
    }

    fn linear_move<F>(
        &mut self,
        m: &Linear,
        force: bool,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let geom = Geom::Line {
            from: m.from,
            to: m.to,
        };
        self.work_move(geom, &m.from, &m.to, m.offset, m.feed, m.tcp || force, sink)
    }

    #[allow(clippy::too_many_arguments)]
    fn work_move<F>(
        &mut self,
        geom: Geom,
        from: &Axes,
        to: &Axes,
        offset: Axes,
        feed: Feed,
        tcp: bool,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let d = to.sub(from);
        let still = match geom {
            Geom::Line { .. } | Geom::Blend { .. } => d.0.iter().all(|&x| x == 0.0),
            Geom::Arc { g, .. } => g.sweep == 0.0 && d.0.iter().all(|&x| x == 0.0),
        };
        self.check_axes(&geom, &d, still)?;
        let path = Path::Work {
            geom: Box::new(geom),
            offset,
            tcp,
        };
        // Join the current position to the move's start if they differ.
        let mut start = self.q.clone();
        self.eval(&path, 0.0, &mut start)?;
        let gap = start
            .iter()
            .zip(&self.q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if gap > SAME_POSITION && tcp && matches!(feed, Feed::Rapid) && !still {
            // The first rapid after TCP is switched on: the program's idea of the
            // tip (its last programmed numbers) is not where the tool is, so the
            // whole rapid goes straight in axis space to its end, instead of
            // diving to the programmed start first.
            let mut end = self.q.clone();
            self.eval(&path, 1.0, &mut end)?;
            self.transition(end, sink)?;
            self.summary.moves += 1;
            return Ok(());
        }
        if gap > SAME_POSITION {
            self.transition(start.clone(), sink)?;
        }
        self.q.copy_from_slice(&start);
        if still {
            return Ok(());
        }
        let xyz = match geom {
            Geom::Line { .. } | Geom::Blend { .. } => d.xyz_norm(),
            Geom::Arc { g, .. } => g.xyz_length(),
        };
        let mut seconds = self.feed_seconds(feed, xyz, &d)?;
        if !matches!(feed, Feed::Rapid) {
            seconds /= self.opts.plan.feed_override;
        }
        match self.opts.plan.planner {
            Planner::ExactStop => {
                let lim = self.exact_limits(&path, seconds)?;
                let block = Block {
                    path,
                    len: 1.0,
                    line: self.line,
                };
                self.enqueue(block, lim, None, sink)?;
            }
            _ => {
                let ml = match geom {
                    Geom::Line { .. } | Geom::Blend { .. } => linuxcnc::straight(&d, &self.world),
                    Geom::Arc { arc, g } => {
                        let (p, q, n) = arc.plane.axes();
                        let shape = linuxcnc::ArcShape {
                            plane: (p, q),
                            radius: (g.radius, g.end_radius),
                            sweep: g.sweep,
                            normal_len: d[n],
                        };
                        linuxcnc::arc(&d, &shape, xyz, &self.world)
                    }
                };
                let len = if matches!(geom, Geom::Arc { .. }) {
                    xyz
                } else {
                    ml.len
                };
                if len.is_nan() || len <= 0.0 {
                    return Ok(());
                }
                let v_ini = ml.v.min(len / self.opts.plan.cycle_time);
                let mut v_req = match feed {
                    Feed::Rapid => v_ini,
                    _ => len / seconds,
                };
                if !ml.pure_rotary {
                    v_req = v_req.min(self.world.v_traj);
                }
                let speed = Speed {
                    len,
                    v_ini,
                    v_req,
                    a_base: ml.a,
                    r_eff: match geom {
                        Geom::Arc { arc, g } => Some(
                            linuxcnc::ArcShape {
                                plane: (arc.plane.axes().0, arc.plane.axes().1),
                                radius: (g.radius, g.end_radius),
                                sweep: g.sweep,
                                normal_len: 0.0,
                            }
                            .effective_radius(),
                        ),
                        Geom::Line { .. } | Geom::Blend { .. } => None,
                    },
                    halved: false,
                    kink: 0.0,
                };
                let lim = speed.limits();
                let side = linuxcnc::Side {
                    dir: direction(&geom, 0.0),
                    rotary: ml.rotary,
                    circular: matches!(geom, Geom::Arc { .. }),
                    v: lim.v,
                    a: lim.a,
                    len,
                    nominal: len,
                    v_req,
                    v_max: v_ini,
                    tolerance: match self.mode {
                        PathMode::Blend { p: Some(p), .. } => p,
                        _ => 0.0,
                    },
                };
                let tail = Tail {
                    side,
                    mode: self.mode,
                    tcp,
                    offset,
                    speed,
                };
                let block = Block {
                    path,
                    len,
                    line: self.line,
                };
                self.enqueue(block, lim, Some(tail), sink)?;
                if let Some(t) = self.tail.as_mut() {
                    // The join rules see the end direction of this block next time.
                    t.side.dir = direction(&geom, 1.0);
                }
            }
        }
        let mut end = self.q.clone();
        if let Some((b, _, _)) = self.queue.last_mut() {
            let path = std::mem::replace(&mut b.path, Path::Hold { q: Vec::new() });
            let r = self.eval(&path, 1.0, &mut end);
            if let Some((b, _, _)) = self.queue.last_mut() {
                b.path = path;
            }
            r?;
        }
        self.check_travel(&end, 0.0)?;
        self.q.copy_from_slice(&end);
        self.summary.moves += 1;
        Ok(())
    }

    /// Axes the program moves must exist on the machine.
    fn check_axes(&self, geom: &Geom, d: &Axes, still: bool) -> Result<(), InterpolateError> {
        for axis in Axis::ALL {
            let moved = match geom {
                Geom::Arc { arc, .. } => {
                    let (p, q, _) = arc.plane.axes();
                    d[axis] != 0.0 || axis == p || axis == q
                }
                Geom::Line { .. } | Geom::Blend { .. } => d[axis] != 0.0,
            };
            if moved && !still && !self.letters.contains(&axis) {
                return Err(InterpolateError::MissingAxis {
                    line: self.line,
                    letter: char::from(axis.letter()),
                });
            }
        }
        Ok(())
    }

    /// Queues a straight axis-space move from the current position to `end`
    /// at the rapid rate (stops before and after).
    fn transition<F>(&mut self, end: Vec<f64>, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let joint = Path::Joint {
            q0: self.q.clone(),
            q1: end.clone(),
        };
        let minutes = self.joint_rapid_minutes(&self.q, &end);
        let lim = self.exact_limits(&joint, 60.0 * minutes)?;
        let block = Block {
            path: joint,
            len: 1.0,
            line: self.line,
        };
        self.enqueue(block, lim, None, sink)?;
        self.check_travel(&end, 0.0)?;
        self.q.copy_from_slice(&end);
        self.summary.transitions += 1;
        Ok(())
    }

    /// Queues a block, joining it to the one before by the planner's rules
    /// (`tail`: the block's join data for `linuxcnc`; `None`: stops before
    /// and after), and samples what becomes ready.
    fn enqueue<F>(
        &mut self,
        block: Block,
        mut lim: Limits,
        tail: Option<Tail>,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let mut tail = tail;
        let joinable = match (&self.tail, &tail) {
            (Some(prev), Some(next)) => prev.tcp == next.tcp && prev.offset == next.offset,
            _ => false,
        };
        if !joinable {
            self.end_chain();
        }
        if let (true, Some(prev), Some(next)) = (joinable, self.tail.as_mut(), tail.as_mut()) {
            let set = linuxcnc::JoinSettings {
                cycle_time: self.opts.plan.cycle_time,
                kink_ratio: self.opts.plan.kink_ratio,
                acc_xyz: [self.world.acc[0], self.world.acc[1], self.world.acc[2]],
                vel_xyz: [self.world.vel[0], self.world.vel[1], self.world.vel[2]],
                max_feed_scale: self.opts.plan.max_feed_override,
            };
            let rule = linuxcnc::join(prev.mode, &prev.side, &next.side, &set);
            if let Some(arc) = rule.arc {
                return self.blend_arc(block, tail, arc, sink);
            }
            for (t, f) in [(&mut *prev, rule.a_prev), (&mut *next, rule.a_next)] {
                if f == 0.5 {
                    t.speed.halved = true;
                } else if f < 1.0 {
                    t.speed.kink = t.speed.kink.max(1.0 - f);
                }
            }
            let prev_lim = prev.speed.limits();
            lim = next.speed.limits();
            if let Some((_, l, j)) = self.queue.last_mut() {
                *l = prev_lim;
                *j = Some(rule.join);
            }
        }
        self.tail = tail;
        self.queue.push(block, lim);
        while let Some(p) = self.queue.pop_ready() {
            self.start(p, sink)?;
        }
        Ok(())
    }

    /// Queues a `linuxcnc` blend arc between the last queued straight block
    /// and `block` (straight too), trimming both by `arc.trim`, then
    /// `block`; all joins tangent.
    fn blend_arc<F>(
        &mut self,
        mut block: Block,
        tail: Option<Tail>,
        arc: linuxcnc::BlendArc,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let (Some(prev), Some(mut next)) = (self.tail.take(), tail) else {
            return Ok(());
        };
        let mut prev = prev;
        let (u1, u2) = (prev.side.dir, next.side.dir);
        let trim = arc.trim;
        let cycle = self.opts.plan.cycle_time;
        let v_arc = arc.v_max;
        let shorten = |t: &mut Tail, b: &mut Block| {
            let rest = t.speed.len - trim;
            // What is left shorter than 4 cycles at the arc's speed LinuxCNC
            // runs as part of the arc: no per-cycle speed cap on it.
            if rest > 4.0 * cycle * v_arc {
                t.speed.v_ini = t.speed.v_ini.min(rest / cycle);
            }
            t.speed.len = rest.max(1e-9);
            t.side.len = t.speed.len;
            b.len = t.speed.len;
        };
        // The corner and the arc's start and end, work coordinates.
        let corner = match self.queue.last_mut() {
            Some((b, _, _)) => match &mut b.path {
                Path::Work { geom, .. } => match geom.as_mut() {
                    Geom::Line { to, .. } => {
                        let c = [to[Axis::X], to[Axis::Y], to[Axis::Z]];
                        for (i, a) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
                            to[a] = c[i] - u1[i] * trim;
                        }
                        c
                    }
                    _ => return Err(InterpolateError::Plan("blend arc after a non-line".into())),
                },
                _ => return Err(InterpolateError::Plan("blend arc after a non-line".into())),
            },
            None => return Err(InterpolateError::Plan("blend arc without a block".into())),
        };
        let from = match &mut block.path {
            Path::Work { geom, .. } => match geom.as_mut() {
                Geom::Line { from, .. } => {
                    let f0 = *from;
                    for (i, a) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
                        from[a] = corner[i] + u2[i] * trim;
                    }
                    f0
                }
                _ => return Err(InterpolateError::Plan("blend arc before a non-line".into())),
            },
            _ => return Err(InterpolateError::Plan("blend arc before a non-line".into())),
        };
        let dist = arc.radius / (arc.phi / 2.0).cos();
        let center: [f64; 3] = std::array::from_fn(|i| corner[i] + arc.normal[i] * dist);
        let start: [f64; 3] = std::array::from_fn(|i| corner[i] - u1[i] * trim);
        let e1: [f64; 3] = std::array::from_fn(|i| (start[i] - center[i]) / arc.radius);
        let geom = Geom::Blend {
            from,
            center,
            e1,
            e2: u1,
            r: arc.radius,
            phi: arc.phi,
        };
        let (v, a) = arc.limits();
        let arc_block = Block {
            path: Path::Work {
                geom: Box::new(geom),
                offset: prev.offset,
                tcp: prev.tcp,
            },
            len: arc.len(),
            line: self.queue.last_mut().map_or(self.line, |(b, _, _)| b.line),
        };
        if let Some((b, l, j)) = self.queue.last_mut() {
            shorten(&mut prev, b);
            *l = prev.speed.limits();
            *j = Some(Join::Tangent { v });
        }
        self.queue.push(
            arc_block,
            Limits {
                len: arc.len(),
                v,
                a,
            },
        );
        if let Some((_, _, j)) = self.queue.last_mut() {
            *j = Some(Join::Tangent { v });
        }
        shorten(&mut next, &mut block);
        let lim = next.speed.limits();
        self.tail = Some(next);
        self.queue.push(block, lim);
        while let Some(p) = self.queue.pop_ready() {
            self.start(p, sink)?;
        }
        Ok(())
    }

    /// The last queued block stops at its end: under G64 (its term
    /// condition stays a blend with nothing to blend into) LinuxCNC runs it
    /// at half acceleration, as it does every block that blends.
    fn end_chain(&mut self) {
        if let Some(prev) = self.tail.as_mut()
            && matches!(prev.mode, PathMode::Blend { .. })
            && !prev.speed.halved
        {
            prev.speed.halved = true;
            let lim = prev.speed.limits();
            if let Some((_, l, _)) = self.queue.last_mut() {
                *l = lim;
            }
        }
    }

    /// Samples up to the start of the planned block `p`, then makes it active.
    fn start<F>(&mut self, p: Planned<Block>, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        self.emit_until(p.t0, sink)?;
        if let Some(ends) = &mut self.ends {
            ends.push((p.payload.line, p.t1()));
        }
        self.active.push_back(p);
        Ok(())
    }

    /// Minutes of an axis-space transition at the rapid rate.
    fn joint_rapid_minutes(&self, q0: &[f64], q1: &[f64]) -> f64 {
        let (mut lin, mut rot) = (0.0f64, 0.0f64);
        for (i, (a, b)) in q0.iter().zip(q1).enumerate() {
            if self.linear[i] {
                lin += (b - a).powi(2);
            } else {
                rot += (b - a).powi(2);
            }
        }
        let path = if lin > 0.0 { lin.sqrt() } else { rot.sqrt() };
        path / self.machine.rapid_feed
    }

    /// Programmed duration of a move, s ([`timing::move_seconds`]).
    fn feed_seconds(&self, feed: Feed, xyz: f64, d: &Axes) -> Result<f64, InterpolateError> {
        timing::move_seconds(feed, xyz, d, self.machine.rapid_feed).map_err(|e| {
            InterpolateError::Feed {
                line: self.line,
                message: e.0,
            }
        })
    }

    /// Work coordinates plus offset of a programmed move at `u ∈ [0, 1]`.
    fn world(geom: &Geom, offset: &Axes, u: f64) -> Axes {
        let w = geom.at(u);
        Axes(std::array::from_fn(|i| w.0[i] + offset.0[i]))
    }

    /// Axis positions of the world position `w` (machine position under
    /// TCP: the tip plus the rotary axes) into `out`, which holds the
    /// previous positions (the IK start under TCP).
    fn joints(&self, w: &Axes, tcp: bool, out: &mut [f64]) -> Result<(), InterpolateError> {
        travel::machine_position(
            &self.kin,
            |i| Some(self.letters[i]),
            &self.linear,
            w,
            tcp,
            out,
        )
        .map_err(|source| InterpolateError::Ik {
            line: self.line,
            x: w[Axis::X],
            y: w[Axis::Y],
            z: w[Axis::Z],
            source,
        })
    }

    /// Axis positions at `s ∈ [0, 1]` along `path` into `out` (which holds the
    /// previous positions, used as the IK start under TCP).
    fn eval(&self, path: &Path, s: f64, out: &mut [f64]) -> Result<(), InterpolateError> {
        match path {
            Path::Joint { q0, q1 } => {
                for i in 0..out.len() {
                    out[i] = if s >= 1.0 {
                        q1[i]
                    } else {
                        q0[i] + (q1[i] - q0[i]) * s
                    };
                }
                Ok(())
            }
            Path::Hold { q } => {
                out.copy_from_slice(q);
                Ok(())
            }
            Path::Work { geom, offset, tcp } => {
                let w = Self::world(geom, offset, s);
                self.joints(&w, *tcp, out)
            }
        }
    }

    /// Bounds `(D1, D2)` on `|dq/ds|` and `|d²q/ds²|` per machine axis.
    fn derivative_bounds(&self, path: &Path) -> Result<(Vec<f64>, Vec<f64>), InterpolateError> {
        let n = self.q.len();
        let mut d1 = vec![0.0; n];
        let mut d2 = vec![0.0; n];
        let margin = self.opts.plan.derivative_margin;
        match path {
            Path::Hold { .. } => {}
            Path::Joint { q0, q1 } => {
                for i in 0..n {
                    d1[i] = (q1[i] - q0[i]).abs();
                }
            }
            Path::Work {
                geom, tcp: false, ..
            } => {
                let (from, to) = match geom.as_ref() {
                    Geom::Line { from, to } => (from, to),
                    Geom::Arc { arc, .. } => (&arc.from, &arc.to),
                    Geom::Blend { from, .. } => (from, from),
                };
                for (i, &l) in self.letters.iter().enumerate() {
                    d1[i] = (to[l] - from[l]).abs();
                }
                if let Geom::Blend { r, phi, .. } = geom.as_ref() {
                    for (i, &l) in self.letters.iter().enumerate() {
                        if matches!(l, Axis::X | Axis::Y | Axis::Z) {
                            d1[i] = r * phi;
                            d2[i] = r * phi * phi;
                        }
                    }
                }
                if let Geom::Arc { arc, g } = geom.as_ref() {
                    // q = c + r(s)·cos(a0 + φ s): |q'| ≤ |Δr| + r·|φ|,
                    // |q''| ≤ 2|Δr·φ| + r·φ².
                    let (p, q, _) = arc.plane.axes();
                    let dr = (g.end_radius - g.radius).abs();
                    let r = g.radius.max(g.end_radius);
                    let phi = g.sweep.abs();
                    for (i, &l) in self.letters.iter().enumerate() {
                        if l == p || l == q {
                            d1[i] = dr + r * phi;
                            d2[i] = 2.0 * dr * phi + r * phi * phi;
                        }
                    }
                }
            }
            Path::Work { tcp: true, .. } => {
                // Finite differences over FD_STEPS sub-steps, times the margin.
                let h = 1.0 / FD_STEPS as f64;
                let mut pts = Vec::with_capacity(FD_STEPS + 1);
                let mut cur = self.q.clone();
                for j in 0..=FD_STEPS {
                    self.eval(path, j as f64 * h, &mut cur)?;
                    pts.push(cur.clone());
                }
                // Per axis, the rounding level of a second difference.
                let mut noise = vec![FD_NOISE; n];
                for p in &pts {
                    for (z, q) in noise.iter_mut().zip(p) {
                        *z = z.max(FD_NOISE + 64.0 * f64::EPSILON * q.abs());
                    }
                }
                for j in 0..FD_STEPS {
                    for i in 0..n {
                        let v = (pts[j + 1][i] - pts[j][i]).abs() / h;
                        d1[i] = f64::max(d1[i], margin * v);
                        if j > 0 {
                            let dd = (pts[j + 1][i] - 2.0 * pts[j][i] + pts[j - 1][i]).abs();
                            if dd > noise[i] {
                                d2[i] = f64::max(d2[i], margin * dd / (h * h));
                            }
                        }
                    }
                }
            }
        }
        Ok((d1, d2))
    }

    /// `exact-stop` limits of a block over `s ∈ [0, 1]` whose programmed
    /// duration is `seconds`: the path speed and acceleration scaled down so
    /// that no joint exceeds its limits (see the module documentation).
    fn exact_limits(&self, path: &Path, seconds: f64) -> Result<Limits, InterpolateError> {
        let (d1, d2) = self.derivative_bounds(path)?;
        let mut v = 1.0 / seconds;
        let mut a = f64::INFINITY;
        for (i, axis) in self.machine.axes.iter().enumerate() {
            if d1[i] == 0.0 && d2[i] == 0.0 {
                continue;
            }
            if let Some(vmax) = axis.max_velocity
                && d1[i] > 0.0
            {
                v = v.min(vmax / d1[i]);
            }
            if let Some(amax) = axis.max_acceleration {
                if d2[i] > 0.0 {
                    v = v.min((amax / (2.0 * d2[i])).sqrt());
                    if d1[i] > 0.0 {
                        a = a.min(amax / (2.0 * d1[i]));
                    }
                } else {
                    a = a.min(amax / d1[i]);
                }
            }
        }
        Ok(Limits { len: 1.0, v, a })
    }

    /// Axis positions at time `t` into `out` (the blocks active then; while
    /// two blocks blend, the second one's displacement adds to the first's).
    fn position_at(&mut self, t: f64, out: &mut [f64]) -> Result<u64, InterpolateError> {
        while self.active.len() > 1 && self.active[0].t1() <= t && self.active[1].t0 <= t {
            self.active.pop_front();
        }
        let started = self.active.iter().take_while(|p| p.t0 <= t).count().max(1);
        let first = &self.active[0];
        let line = self.active[started - 1].payload.line;
        let u = |p: &Planned<Block>| p.profile.s_at(t - p.t0) / p.payload.len;
        if started == 1 {
            self.eval(&first.payload.path, u(first), out)?;
            return Ok(line);
        }
        let mut w = Axes::default();
        let mut tcp = false;
        for (i, p) in self.active.iter().take(started).enumerate() {
            if let Path::Work {
                geom,
                offset,
                tcp: c,
            } = &p.payload.path
            {
                tcp = *c;
                let x = Self::world(geom, offset, u(p));
                if i == 0 {
                    w = x;
                } else {
                    let x0 = Self::world(geom, offset, 0.0);
                    for j in 0..9 {
                        w.0[j] += x.0[j] - x0.0[j];
                    }
                }
            }
        }
        self.joints(&w, tcp, out)?;
        Ok(line)
    }

    /// Emits samples `k·ts < end`.
    fn emit_until<F>(&mut self, end: f64, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        if self.active.is_empty() {
            return Ok(());
        }
        // The samples this move needs, counted before any is made.
        if end / self.opts.ts >= self.opts.max_samples as f64 {
            return Err(InterpolateError::TooManySamples {
                line: self.line,
                t: end,
                ts: self.opts.ts,
                max: self.opts.max_samples,
            });
        }
        let mut out = std::mem::take(&mut self.buf);
        let result = loop {
            let t = self.k as f64 * self.opts.ts;
            if t >= end {
                break Ok(());
            }
            let line = match self.position_at(t, &mut out) {
                Ok(l) => l,
                Err(e) => break Err(e),
            };
            if let Err(e) = self.check_travel(&out, t) {
                break Err(e);
            }
            let sample = Sample { t, q: &out, line };
            if let Err(e) = sink(&sample) {
                break Err(InterpolateError::Sink(e));
            }
            self.k += 1;
            self.summary.samples += 1;
        };
        self.buf = out;
        result
    }
    fn check_travel(&self, q: &[f64], t: f64) -> Result<(), InterpolateError> {
        if !self.opts.check_travel {
            return Ok(());
        }
        travel_error(self.machine, q, t, self.line)
    }
}

/// The duration (s) of the program read from `input` on `machine` under the
/// planner of `opts.plan` — accelerations, junctions and limits included —
/// from the interpolator run without sampling (one sample at each end; the
/// period only bounds the count, travels are not checked). This is
/// `total_time_s` of `gcode stats` with a machine. An error of the planner's
/// settings is [`InterpolateError::Plan`]; any other error means the program
/// cannot be interpolated on the machine (an unreachable tip, …), and callers
/// fall back to the estimate without accelerations.
pub fn planned_duration<R: BufRead>(
    input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
) -> Result<f64, InterpolateError> {
    let mut input = input;
    timing_run(&mut input, machine, opts, None, None).map(|s| s.duration)
}

/// A run of the planner for its timing alone: nothing is sampled (the
/// period only bounds the count) and travels are not checked; the steps are
/// shown to `hook` and the segments' end times added to `ends` as in
/// [`drive`].
fn timing_run(
    input: &mut dyn BufRead,
    machine: &Machine,
    opts: &InterpolateOptions,
    hook: Option<&mut Hook<'_>>,
    ends: Option<&mut Vec<(u64, f64)>>,
) -> Result<InterpolationSummary, InterpolateError> {
    let mut o = opts.clone();
    o.ts = 1e9;
    o.check_travel = false;
    drive(input, machine, &o, &mut |_| Ok(()), hook, ends)
}

/// When each program line's motion ends under the planner of `opts.plan`:
/// what [`line_end_times`] returns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LineEndTimes {
    /// `(line, t)`: the 1-based source line of every planned segment (a
    /// move, the piece of a move between blends, a dwell, a stand-still of
    /// the `linuxcnc` task, an axis-space transition) and the time its
    /// segment ends, s from program start, in the order the planner
    /// finishes them. A line's motion ends at the largest `t` given for it
    /// (a move blended into the next under `linuxcnc` ends where its blend
    /// begins; under `jerk` a move ends when the time law passes its end
    /// point). Lines without motion (S, M3, F, …) have no entry: they take
    /// effect at the end of the motion before them.
    pub ends: Vec<(u64, f64)>,
    /// The program's duration, s ([`planned_duration`]).
    pub duration: f64,
}

impl LineEndTimes {
    /// The end time (s) of each line's motion, the largest of its entries.
    pub fn by_line(&self) -> std::collections::HashMap<u64, f64> {
        let mut m = std::collections::HashMap::new();
        for &(line, t) in &self.ends {
            let e = m.entry(line).or_insert(t);
            if t > *e {
                *e = t;
            }
        }
        m
    }
}

/// The planner's timing of each program line read from `input` on
/// `machine` (see [`LineEndTimes`]): accelerations, junctions and limits
/// included, as [`planned_duration`]; nothing is sampled and travels are
/// not checked.
pub fn line_end_times<R: BufRead>(
    input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
) -> Result<LineEndTimes, InterpolateError> {
    let mut ends = Vec::new();
    let mut input = input;
    let s = timing_run(&mut input, machine, opts, None, Some(&mut ends))?;
    Ok(LineEndTimes {
        ends,
        duration: s.duration,
    })
}

/// [`planned_duration`] in the same run of the interpreter that shows every
/// step (block and events) to `on_step` — `gcode stats` with a machine reads
/// and interprets the program once for its statistics and the planned time.
/// The outer error is the interpreter's or `on_step`'s (the run stopped);
/// the inner one the planner's: the planner stops at its first error while
/// the run goes on to the end of the program for `on_step`.
pub fn planned_duration_with<R: BufRead>(
    input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
    on_step: &mut dyn FnMut(&Step<'_>) -> Result<(), GcodeError>,
) -> Result<Result<f64, InterpolateError>, GcodeError> {
    let mut hook = Hook {
        on_step,
        failed: None,
        run_error: None,
    };
    let mut input = input;
    let r = timing_run(&mut input, machine, opts, Some(&mut hook), None);
    if let Some(e) = hook.run_error {
        return Err(e);
    }
    Ok(match hook.failed {
        Some(e) => Err(e),
        None => r.map(|s| s.duration),
    })
}

/// The steps of a program run shown to someone besides the planner
/// ([`planned_duration_with`]): planner errors are kept in `failed` (the run
/// goes on without the planner), an error of the run in `run_error`.
struct Hook<'h> {
    on_step: &'h mut dyn FnMut(&Step<'_>) -> Result<(), GcodeError>,
    failed: Option<InterpolateError>,
    run_error: Option<GcodeError>,
}

/// Runs the program `input` through the interpreter with `iopts` and hands
/// every event, in program order, to `f` (the one driver loop of the
/// planners), and every step to the `hook` if there is one.
fn for_each_event<R: BufRead>(
    input: R,
    iopts: &InterpOptions,
    mut hook: Option<&mut Hook<'_>>,
    mut f: impl FnMut(&Event) -> Result<(), InterpolateError>,
) -> Result<(), InterpolateError> {
    let mut interp = Interpreter::new(iopts.clone());
    let r = run_program(
        input,
        &mut interp,
        &iopts.program,
        iopts.dialect,
        |step: &Step<'_>| -> Result<(), InterpolateError> {
            let Some(h) = hook.as_deref_mut() else {
                return step.events.iter().try_for_each(&mut f);
            };
            (h.on_step)(step)?;
            if h.failed.is_none()
                && let Err(e) = step.events.iter().try_for_each(&mut f)
            {
                h.failed = Some(e);
            }
            Ok(())
        },
    );
    match (r, hook) {
        (Err(InterpolateError::Gcode(e)), Some(h)) => {
            h.run_error = Some(e);
            Err(InterpolateError::Plan("the program run failed".into()))
        }
        (r, _) => r.map(|_| ()),
    }
}

/// Interpolates the program read from `input` on `machine`, streaming:
/// `sink` gets every sample in time order (see the module documentation).
pub fn interpolate<R, F>(
    mut input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
    mut sink: F,
) -> Result<InterpolationSummary, InterpolateError>
where
    R: BufRead,
    F: FnMut(&Sample<'_>) -> io::Result<()>,
{
    drive(&mut input, machine, opts, &mut sink, None, None)
}

/// The sink of [`drive`]: every sample in time order.
type SampleSink<'s> = dyn FnMut(&Sample<'_>) -> io::Result<()> + 's;

/// [`interpolate`], with the steps also shown to `hook` when there is one
/// (then a planner that cannot start still lets the program run for it),
/// and the `(line, end time)` of every planned segment added to `ends` when
/// given ([`line_end_times`]). A `dyn` reader and sink: the interpreter and
/// the planners are compiled once, whatever the callers' types (the public
/// functions are thin generic shims over it).
fn drive(
    input: &mut dyn BufRead,
    machine: &Machine,
    opts: &InterpolateOptions,
    mut sink: &mut SampleSink<'_>,
    mut hook: Option<&mut Hook<'_>>,
    ends: Option<&mut Vec<(u64, f64)>>,
) -> Result<InterpolationSummary, InterpolateError> {
    if opts.plan.planner == Planner::Jerk {
        return interpolate_jerk(input, machine, opts, sink, hook, ends);
    }
    let mut ip = match Interpolator::new(machine, opts) {
        Ok(ip) => ip,
        Err(e) => return without_planner(input, opts, hook, e),
    };
    if ends.is_some() {
        ip.ends = Some(Vec::new());
    }
    let iopts = ip.options().interp.clone();
    for_each_event(input, &iopts, hook.as_deref_mut(), |e| {
        ip.push(e, &mut sink)
    })?;
    if let Some(e) = hook.and_then(|h| h.failed.take()) {
        return Err(e);
    }
    let (summary, planned) = ip.finish_with_ends(&mut sink)?;
    if let Some(ends) = ends {
        *ends = planned;
    }
    Ok(summary)
}

/// A planner that could not start (`e`): without a hook its error; with one
/// the program still runs for the hook.
fn without_planner<R: BufRead>(
    input: R,
    opts: &InterpolateOptions,
    hook: Option<&mut Hook<'_>>,
    e: InterpolateError,
) -> Result<InterpolationSummary, InterpolateError> {
    let Some(h) = hook else {
        return Err(e);
    };
    h.failed = Some(e);
    let mut iopts = opts.interp.clone();
    iopts.tcp_at_start |= opts.force_tcp;
    for_each_event(input, &iopts, Some(h), |_| Ok(()))?;
    Err(InterpolateError::Plan("the planner did not start".into()))
}

/// A chain of programmed moves between two stops, sampled densely in joint
/// space: the input of a planner that times a whole chain at once (a
/// jerk-limited one).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DensePath {
    /// Path parameter at each point: the cumulative path length along the
    /// chain, each move counting its XYZ length (else UVW, else ABC, as the
    /// feed does), mm (deg for rotary-only moves). Starts at 0, increasing.
    pub s: Vec<f64>,
    /// Axis positions at each point, machine axis order (mm, deg); under
    /// TCP from the nominal inverse kinematics, the tip exactly on the
    /// programmed path.
    pub q: Vec<Vec<f64>>,
    /// Highest path speed at each point, path units per s: the programmed
    /// feed (× feed override; G93 and G95 as speeds), the machine's
    /// `rapid_feed` for rapids and as the trajectory limit of non-rotary
    /// moves. The point closes the move it ends; the first point takes the
    /// first move's cap.
    pub v_cap: Vec<f64>,
    /// Source line of the move each point ends (the first: the first move's).
    pub line: Vec<u64>,
}

/// The walker's chain of moves: [`DensePath`] with the points one after
/// the other in one vector (`q[k * n + i]` is axis `i` at point `k`), so
/// that a point costs no allocation and the planner takes the vectors as
/// they are.
#[derive(Debug, Clone, Default)]
struct Chain {
    s: Vec<f64>,
    q: Vec<f64>,
    v_cap: Vec<f64>,
    line: Vec<u64>,
}

impl Chain {
    /// Appends a point.
    fn push(&mut self, s: f64, q: &[f64], v: f64, line: u64) {
        self.s.push(s);
        self.q.extend_from_slice(q);
        self.v_cap.push(v);
        self.line.push(line);
    }

    /// Removes the last point of `n` axes.
    fn pop(&mut self, n: usize) {
        self.s.pop();
        self.q.truncate(self.q.len().saturating_sub(n));
        self.v_cap.pop();
        self.line.pop();
    }

    /// The chain as a [`DensePath`] of `n` axes.
    fn dense(&self, n: usize) -> DensePath {
        DensePath {
            s: self.s.clone(),
            q: self.q.chunks(n).map(|c| c.to_vec()).collect(),
            v_cap: self.v_cap.clone(),
            line: self.line.clone(),
        }
    }
}

/// One stretch of a program under the `jerk` planner: the machine is at rest
/// before and after it.
#[derive(Debug)]
enum Stretch<'a> {
    /// A chain of programmed moves (the receiver may take its vectors).
    Chain(&'a mut Chain),
    /// A straight axis-space move at the rapid rate (see the module
    /// documentation on transitions).
    Transition {
        q0: &'a [f64],
        q1: &'a [f64],
        line: u64,
    },
    /// Standing still at `q` for `seconds` (a dwell).
    Dwell {
        q: &'a [f64],
        seconds: f64,
        line: u64,
    },
}

/// Joint-space direction change (rad) above which G61 (exact path) stops
/// between two moves under the `jerk` planner.
const CORNER_ANGLE: f64 = 1.0f64.to_radians();
/// Smallest dense-path step that `G64 P` may ask for.
const MIN_JERK_STEP: f64 = 1e-3;

/// The last straight move of a chain (program coordinates), for the corner
/// blend of the next one under G64.
#[derive(Debug, Clone, Copy)]
struct LastLine {
    from: Axes,
    to: Axes,
    offset: Axes,
    tcp: bool,
    /// Path length (XYZ), mm.
    len: f64,
    /// Length taken from its start by a corner blend, mm.
    cut0: f64,
    /// The move as a curve (a line or an arc) for blends next to arcs.
    curve: Curve,
}

/// What to do at a corner between two moves under G64.
enum Corner {
    /// No corner (collinear) or nothing to blend: go on.
    None,
    /// Blended: the fraction of the new move the blend took.
    Blend(f64),
    /// Stop at the corner: blending within the tolerance is slower.
    Stop,
}

/// Points of a G64 corner blend between two straight moves under the `jerk`
/// planner, at least.
const BLEND_POINTS: usize = 16;

/// The G64 corner blend of the `jerk` planner between a straight move along
/// the unit direction `e1` (per mm of XYZ path) ending at the corner `c`
/// and one along `e2` leaving it: the quintic Bézier curve with the control
/// points `c − d e1`, `c − d e1 / 2`, `c`, `c`, `c + d e2 / 2`, `c + d e2`,
/// at `λ` in [0, 1]. Three control points on each line make the curve
/// meet the lines with the same tangent and zero curvature (C² with the
/// lines, so the joint spline through it needs no speed drop at its ends).
/// For `λ ≤ 1/2` the curve point is `x1 + d (b4/2 + b5) e2`, with `x1` on
/// the incoming line within `d` of the corner and `b_k` the Bernstein
/// polynomials; `b4/2 + b5 ≤ 7/64` there (at `λ = 1/2`); symmetrically for
/// `λ ≥ 1/2`. So the curve stays within `7 d / 64` of the programmed path:
/// `d = 64 P / 7` keeps it within the tolerance `P`.
pub(crate) fn corner_blend(c: &Axes, e1: &Axes, e2: &Axes, d: f64, lambda: f64) -> Axes {
    let (l, m) = (lambda, 1.0 - lambda);
    let b0 = m.powi(5);
    let b1 = 5.0 * l * m.powi(4);
    let b4 = 5.0 * l.powi(4) * m;
    let b5 = l.powi(5);
    let (w1, w2) = (d * (b0 + b1 / 2.0), d * (b4 / 2.0 + b5));
    Axes(std::array::from_fn(|i| {
        c.0[i] - w1 * e1.0[i] + w2 * e2.0[i]
    }))
}

/// The points of [`corner_blend`] at `λ = j / nb`, `j = 0..=nb`.
fn pts_blend_iter<'a>(
    c: &'a Axes,
    e1: &'a Axes,
    e2: &'a Axes,
    d: f64,
    nb: usize,
) -> impl Iterator<Item = Axes> + 'a {
    (0..=nb).map(move |j| corner_blend(c, e1, e2, d, j as f64 / nb as f64))
}

/// The TCP solve of a machine with three linear axes while its other axes
/// stand still, as the affine map it is: with the rotary axes fixed the
/// nominal tip is affine in the linear axes (see
/// `Kinematics::solve_tip_by_three_linear_axes`), so the linear axes are
/// affine in the tip, `x(p) = x0 + M (p − p0)`. Built from four solves
/// (at `p0` and 1 mm along X, Y, Z) and checked at a fifth point; then a
/// point costs a 3×3 product instead of a forward kinematics with
/// derivatives. Equal to solving each point to rounding.
#[derive(Debug, Clone)]
struct AffineTcp {
    /// The positions of the other axes it holds for (all axes; the linear
    /// ones not used).
    fixed: Vec<f64>,
    p0: [f64; 3],
    x0: [f64; 3],
    /// `m[k][c]`: linear axis `lin[k]` per mm of the tip along `c`.
    m: [[f64; 3]; 3],
    /// False when the map did not check out (the general solve is used).
    ok: bool,
}

/// The last [`AffineTcp`] map and the other axes of the last point solved
/// without one.
#[derive(Debug, Clone, Default)]
struct AffineCache {
    map: Option<AffineTcp>,
    miss: Option<Vec<f64>>,
}

/// Axis positions of the world position `w` into `out` as
/// [`Interpolator::joints`], through the cached affine map under TCP on a
/// machine of three linear axes (see [`AffineTcp`]).
fn fast_joints(
    ip: &Interpolator<'_>,
    cache: &RefCell<AffineCache>,
    w: &Axes,
    tcp: bool,
    out: &mut [f64],
) -> Result<(), InterpolateError> {
    let Some(lin) = (if tcp {
        super::travel::three_linear(&ip.linear)
    } else {
        None
    }) else {
        return ip.joints(w, tcp, out);
    };
    for (i, o) in out.iter_mut().enumerate() {
        if !ip.linear[i] {
            *o = w[ip.letters[i]];
        }
    }
    let tip = [w[Axis::X], w[Axis::Y], w[Axis::Z]];
    let same = |c: &AffineTcp| {
        c.fixed
            .iter()
            .zip(out.iter())
            .enumerate()
            .all(|(i, (a, b))| ip.linear[i] || a == b)
    };
    let hit = matches!(&cache.borrow().map, Some(c) if same(c));
    if !hit {
        // Built at the second point with the same other axes (a point
        // alone costs one solve, as without the map).
        let again = cache.borrow().miss.as_ref().is_some_and(|m| {
            m.iter()
                .zip(out.iter())
                .enumerate()
                .all(|(i, (a, b))| ip.linear[i] || a == b)
        });
        if !again {
            match &mut cache.borrow_mut().miss {
                Some(m) if m.len() == out.len() => m.copy_from_slice(out),
                m => *m = Some(out.to_vec()),
            }
            return ip.joints(w, tcp, out);
        }
        let built = affine_tcp(ip, lin, w, out);
        *cache.borrow_mut() = AffineCache {
            map: Some(built),
            miss: None,
        };
    }
    let c = cache.borrow();
    let c = &c.map;
    let Some(c) = c.as_ref().filter(|c| c.ok) else {
        return ip.joints(w, tcp, out);
    };
    let d = [tip[0] - c.p0[0], tip[1] - c.p0[1], tip[2] - c.p0[2]];
    for (k, &i) in lin.iter().enumerate() {
        out[i] = c.x0[k] + (c.m[k][0] * d[0] + c.m[k][1] * d[1] + c.m[k][2] * d[2]);
    }
    Ok(())
}

/// Builds the [`AffineTcp`] map at `w` (the other axes as `out` holds them).
fn affine_tcp(ip: &Interpolator<'_>, lin: [usize; 3], w: &Axes, out: &[f64]) -> AffineTcp {
    let mut q = out.to_vec();
    let mut solve = |d: [f64; 3]| -> Option<[f64; 3]> {
        let mut p = *w;
        p[Axis::X] += d[0];
        p[Axis::Y] += d[1];
        p[Axis::Z] += d[2];
        ip.joints(&p, true, &mut q).ok()?;
        Some(lin.map(|i| q[i]))
    };
    let mut map = AffineTcp {
        fixed: out.to_vec(),
        p0: [w[Axis::X], w[Axis::Y], w[Axis::Z]],
        x0: [0.0; 3],
        m: [[0.0; 3]; 3],
        ok: false,
    };
    let Some(x0) = solve([0.0; 3]) else {
        return map;
    };
    let mut m = [[0.0; 3]; 3];
    for c in 0..3 {
        let mut d = [0.0; 3];
        d[c] = 1.0;
        let Some(x) = solve(d) else {
            return map;
        };
        for k in 0..3 {
            m[k][c] = x[k] - x0[k];
        }
    }
    // The check: a point off the axes.
    let probe = [0.6, -0.7, 0.4];
    let Some(x) = solve(probe) else {
        return map;
    };
    map.ok = (0..3).all(|k| {
        let pred = x0[k] + m[k][0] * probe[0] + m[k][1] * probe[1] + m[k][2] * probe[2];
        (pred - x[k]).abs() <= 1e-9 * (1.0 + x[k].abs())
    }) && m.iter().flatten().all(|v| v.is_finite());
    map.x0 = x0;
    map.m = m;
    map
}

/// Cuts a program into [`Stretch`]es for the `jerk` planner (see
/// [`dense_paths`]).
struct Walker<'m> {
    ip: Interpolator<'m>,
    chain: Chain,
    /// The chain's last move when it is straight (for a G64 corner blend).
    last: Option<LastLine>,
    /// The joint limits, when the machine gives them all (a G64 corner
    /// blend that is slower than a stop is not taken).
    limits: Option<JointLimits>,
    opts_jerk: jerk::JerkOptions,
    /// (TCP, offset) of the chain's moves.
    key: Option<(bool, Axes)>,
    mode: PathMode,
    /// Joint-space direction at the end of the chain's last move.
    end_dir: Vec<f64>,
    step: f64,
    /// The TCP solve as an affine map while the rotary axes stand still.
    affine: RefCell<AffineCache>,
}

impl<'m> Walker<'m> {
    fn new(machine: &'m Machine, opts: &InterpolateOptions) -> Result<Self, InterpolateError> {
        let step = opts.plan.jerk_step;
        if !(step > 0.0 && step.is_finite()) {
            return Err(InterpolateError::Plan(format!(
                "the dense path step must be a positive length, not {step}"
            )));
        }
        let mut o = opts.clone();
        o.plan.planner = Planner::ExactStop;
        let ip = Interpolator::new(machine, &o)?;
        Ok(Walker {
            ip,
            chain: Chain::default(),
            last: None,
            limits: jerk_limits(machine).ok(),
            opts_jerk: opts.plan.jerk,
            key: None,
            mode: PathMode::DEFAULT,
            end_dir: Vec::new(),
            step,
            affine: RefCell::new(AffineCache::default()),
        })
    }

    fn flush<F>(&mut self, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(Stretch<'_>) -> Result<(), InterpolateError>,
    {
        if self.chain.s.len() > 1 {
            sink(Stretch::Chain(&mut self.chain))?;
        }
        self.chain = Chain::default();
        self.last = None;
        Ok(())
    }

    /// Unit joint-space direction of `path` at `u` (0 or 1), from a
    /// one-sided difference; zero when the joints do not move there.
    fn direction(&self, path: &Path, u: f64) -> Result<Vec<f64>, InterpolateError> {
        let h = 1e-6;
        let (a, b) = if u >= 1.0 { (1.0 - h, 1.0) } else { (0.0, h) };
        let mut qa = self.ip.q.clone();
        let mut qb = self.ip.q.clone();
        self.ip.eval(path, a, &mut qa)?;
        self.ip.eval(path, b, &mut qb)?;
        let d: Vec<f64> = qb.iter().zip(&qa).map(|(x, y)| x - y).collect();
        let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        Ok(if n > 0.0 {
            d.iter().map(|x| x / n).collect()
        } else {
            d
        })
    }

    fn event<F>(&mut self, e: &Event, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(Stretch<'_>) -> Result<(), InterpolateError>,
    {
        self.ip.line = e.at.line;
        let force = self.ip.opts.force_tcp;
        let (geom, offset, feed, tcp) = match &e.kind {
            EventKind::Traverse(m) | EventKind::Feed(m) => (
                Geom::Line {
                    from: m.from,
                    to: m.to,
                },
                m.offset,
                m.feed,
                m.tcp || force,
            ),
            EventKind::Arc(a) => (
                Geom::Arc {
                    arc: *a,
                    g: arc::geometry(a),
                },
                a.offset,
                a.feed,
                a.tcp || force,
            ),
            EventKind::PathControl(m) => {
                self.mode = *m;
                return Ok(());
            }
            EventKind::Dwell { seconds } if *seconds > 0.0 => {
                self.flush(sink)?;
                self.key = None;
                self.ip.summary.dwell_time += seconds;
                return sink(Stretch::Dwell {
                    q: &self.ip.q,
                    seconds: *seconds,
                    line: self.ip.line,
                });
            }
            // Where LinuxCNC's task waits for the motion to end, the
            // machine stops (no wait time: that is LinuxCNC's own).
            EventKind::ProgramEnd
            | EventKind::Tcp(_)
            | EventKind::Spindle(_)
            | EventKind::Wait(_) => {
                self.flush(sink)?;
                self.key = None;
                return Ok(());
            }
            _ => return Ok(()),
        };
        let (from, to) = match geom {
            Geom::Line { from, to } => (from, to),
            Geom::Arc { arc, .. } => (arc.from, arc.to),
            Geom::Blend { .. } => (geom.at(0.0), geom.at(1.0)),
        };
        let d = to.sub(&from);
        let still = match geom {
            Geom::Line { .. } => d.0.iter().all(|&x| x == 0.0),
            Geom::Arc { g, .. } => g.sweep == 0.0 && d.0.iter().all(|&x| x == 0.0),
            Geom::Blend { r, phi, .. } => r * phi == 0.0,
        };
        self.ip.check_axes(&geom, &d, still)?;
        let path = Path::Work {
            geom: Box::new(geom),
            offset,
            tcp,
        };
        let mut start = self.ip.q.clone();
        self.ip.eval(&path, 0.0, &mut start)?;
        let gap = start
            .iter()
            .zip(&self.ip.q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if gap > SAME_POSITION && tcp && matches!(feed, Feed::Rapid) && !still {
            // As `exact-stop` does: the first rapid after TCP is switched on
            // goes straight in axis space to its end.
            self.flush(sink)?;
            self.key = None;
            let mut end = self.ip.q.clone();
            self.ip.eval(&path, 1.0, &mut end)?;
            self.transition(end, sink)?;
            self.ip.summary.moves += 1;
            return Ok(());
        }
        if gap > SAME_POSITION {
            self.flush(sink)?;
            self.key = None;
            self.transition(start.clone(), sink)?;
        }
        self.ip.q.copy_from_slice(&start);
        if still {
            return Ok(());
        }
        let ml = linuxcnc::straight(&d, &self.ip.world);
        let len = match geom {
            Geom::Arc { g, .. } => g.xyz_length(),
            Geom::Blend { r, phi, .. } => r * phi,
            Geom::Line { .. } => ml.len,
        };
        if len.is_nan() || len <= 0.0 {
            return Ok(());
        }
        let exact_path = self.mode == PathMode::ExactPath;
        let corner = exact_path
            && !self.end_dir.is_empty()
            && self
                .direction(&path, 0.0)?
                .iter()
                .zip(&self.end_dir)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                < CORNER_ANGLE.cos();
        if self.key != Some((tcp, offset)) || self.mode == PathMode::ExactStop || corner {
            self.flush(sink)?;
        }
        self.key = Some((tcp, offset));
        let xyz = match geom {
            Geom::Arc { g, .. } => g.xyz_length(),
            Geom::Blend { r, phi, .. } => r * phi,
            Geom::Line { .. } => d.xyz_norm(),
        };
        let mut v = match feed {
            Feed::Rapid => self.ip.world.v_traj,
            _ => len / self.ip.feed_seconds(feed, xyz, &d)? * self.ip.opts.plan.feed_override,
        };
        if !ml.pure_rotary {
            v = v.min(self.ip.world.v_traj);
        }
        let step = match self.mode {
            PathMode::Blend { p: Some(p), .. } if p > 0.0 => {
                self.step.min(4.0 * p).max(MIN_JERK_STEP.min(self.step))
            }
            _ => self.step,
        };
        let mut line_now = match geom {
            Geom::Line { from, to }
                if d.xyz_norm() > 0.0 && (len - d.xyz_norm()).abs() <= 1e-12 * len =>
            {
                Some(LastLine {
                    from,
                    to,
                    offset,
                    tcp,
                    len,
                    cut0: 0.0,
                    curve: Curve::line(from, to, len),
                })
            }
            Geom::Arc { arc, g } if len.is_finite() && g.radius > 0.0 => {
                let (p, q, _) = arc.plane.axes();
                Some(LastLine {
                    from: arc.from,
                    to: arc.to,
                    offset,
                    tcp,
                    len,
                    cut0: 0.0,
                    curve: Curve::arc(
                        arc.from,
                        arc.to,
                        (p, q),
                        g.center,
                        (g.radius, g.end_radius),
                        g.start_angle,
                        g.sweep,
                        len,
                    ),
                })
            }
            _ => None,
        };
        // A G64 corner between two moves (lines or arcs): the blend
        // replaces the last `d` of the previous move and the first `d` of
        // this one.
        let corner = match (self.mode, self.last, line_now) {
            (PathMode::Blend { p, .. }, Some(prev), Some(cur))
                if prev.tcp == tcp && prev.offset == offset && self.chain.s.len() > 1 =>
            {
                let tol = match p {
                    Some(p) if p > 0.0 => p,
                    _ => self.step / 4.0,
                };
                let cap = v.min(*self.chain.v_cap.last().unwrap_or(&v));
                self.blend(&prev, &cur, tol, cap)?
            }
            _ => Corner::None,
        };
        let u0 = match corner {
            Corner::Blend(u0) => u0,
            Corner::Stop => {
                self.flush(sink)?;
                0.0
            }
            Corner::None => 0.0,
        };
        if let Some(l) = line_now.as_mut() {
            l.cut0 = u0 * len;
        }
        self.last = line_now;
        if self.chain.s.is_empty() {
            self.chain.push(0.0, &self.ip.q, v, self.ip.line);
        }
        let ip = &mut self.ip;
        let chain = &mut self.chain;
        // At most a step apart in path length and in every joint (mm, deg).
        let mut q = ip.q.clone();
        ip.eval(&path, 1.0, &mut q)?;
        let spread = q
            .iter()
            .zip(&ip.q)
            .map(|(a, b)| (a - b).abs())
            .fold(len * (1.0 - u0), f64::max);
        let n = (spread / step).ceil().max(1.0) as usize;
        let s0 = *chain.s.last().unwrap_or(&0.0);
        // A straight move whose joint path is straight too: the axes of
        // their letters without TCP; under TCP on three linear axes with
        // the other axes standing still (the nominal tip is then affine in
        // the linear axes, see `Kinematics::solve_tip_by_three_linear_axes`,
        // so its inverse along the line is a line). Its points are then the
        // joint positions of its ends interpolated (equal to solving each
        // point to rounding), no solve per point.
        let straight = matches!(geom, Geom::Line { .. })
            && (!tcp
                || (ip.linear.iter().filter(|l| **l).count() == 3
                    && ip
                        .linear
                        .iter()
                        .zip(q.iter().zip(&ip.q))
                        .all(|(lin, (a, b))| *lin || a == b)));
        if straight {
            // From the chain's last point (the blend's end when one took
            // the move's start) to the move's end.
            let (qa, q1) = (ip.q.clone(), q.clone());
            for j in 1..=n {
                let f = j as f64 / n as f64;
                let u = u0 + (1.0 - u0) * f;
                if j == n {
                    q.copy_from_slice(&q1);
                } else {
                    for i in 0..q.len() {
                        q[i] = qa[i] + (q1[i] - qa[i]) * f;
                    }
                }
                chain.push(s0 + len * (u - u0), &q, v, ip.line);
            }
        } else {
            q.copy_from_slice(&ip.q);
            for j in 1..=n {
                let u = u0 + (1.0 - u0) * (j as f64 / n as f64);
                let w = Interpolator::world(&geom, &offset, u);
                fast_joints(ip, &self.affine, &w, tcp, &mut q)?;
                chain.push(s0 + len * (u - u0), &q, v, ip.line);
            }
        }
        ip.check_travel(&q, 0.0)?;
        ip.q.copy_from_slice(&q);
        ip.summary.moves += 1;
        self.end_dir = if exact_path {
            self.direction(&path, 1.0)?
        } else {
            Vec::new()
        };
        Ok(())
    }

    /// Replaces the end of the chain's last move `prev` by the corner blend
    /// (see [`corner_blend`]) towards the straight move `cur`, within the
    /// tolerance `tol` (mm) of the programmed path; the blend points take
    /// the speed cap `v`. Returns the fraction of `cur` the blend took,
    /// [`Corner::None`] when there is no corner to blend (collinear moves,
    /// a reversal, too short a blend to sample), or [`Corner::Stop`] when
    /// the jerk-limited motion through the blend is slower than stopping at
    /// the corner: compared on the corner's neighbourhood (the blend and
    /// up to `d` of straight path on each side), each alternative planned
    /// rest to rest by the time law itself.
    fn blend(
        &mut self,
        prev: &LastLine,
        cur: &LastLine,
        tol: f64,
        v: f64,
    ) -> Result<Corner, InterpolateError> {
        if !(prev.curve.is_line() && cur.curve.is_line()) {
            return self.blend_curves(prev, cur, tol, v);
        }
        let dir = |m: &LastLine| {
            let d = m.to.sub(&m.from);
            Axes(std::array::from_fn(|i| d.0[i] / m.len))
        };
        let (e1, e2) = (dir(prev), dir(cur));
        let cos = (0..3).map(|i| e1.0[i] * e2.0[i]).sum::<f64>();
        let turn = (0..9)
            .map(|i| (e2.0[i] - e1.0[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        if turn <= 1e-12 || cos < -0.999 {
            return Ok(Corner::None);
        }
        let d = (64.0 * tol / 7.0).min(prev.len / 2.0).min(cur.len / 2.0);
        let nb = ((8.0 * d / self.step).ceil() as usize).max(BLEND_POINTS);
        let c = cur.from;
        let pts: Vec<Axes> = pts_blend_iter(&c, &e1, &e2, d, nb).collect();
        let chords: Vec<f64> = pts.windows(2).map(|w| w[1].sub(&w[0]).xyz_norm()).collect();
        if chords.iter().any(|x| x.is_nan() || *x <= 0.0) {
            return Ok(Corner::None);
        }
        let mut known = None;
        if let Some(lim) = &self.limits {
            // The neighbourhood: `d1`, `d2` of straight path before and
            // after the corner (at least the blend's `d`, up to `2d`).
            let d1 = (2.0 * d).min(prev.len - prev.cut0).max(d);
            let d2 = (2.0 * d).min(cur.len / 2.0).max(d);
            let world = |p: &Axes| Axes(std::array::from_fn(|i| p.0[i] + prev.offset.0[i]));
            let along = |e: &Axes, t: f64| Axes(std::array::from_fn(|i| c.0[i] + t * e.0[i]));
            let n = self.ip.q.len();
            let mut q = self.ip.q.clone();
            let joints = |pts: &[Axes], q: &mut Vec<f64>| -> Result<Vec<f64>, InterpolateError> {
                let mut out = Vec::with_capacity(pts.len() * n);
                for p in pts {
                    fast_joints(&self.ip, &self.affine, &world(p), prev.tcp, q)?;
                    out.extend_from_slice(q);
                }
                Ok(out)
            };
            let plan = |s: Vec<f64>, q: Vec<f64>| -> Option<f64> {
                let caps = vec![v; s.len()];
                let path = JointPath::new(n, s, q, caps).ok()?;
                jerk::plan(&path, lim, &self.opts_jerk)
                    .ok()
                    .map(|l| l.duration())
            };
            let mut pts = vec![along(&e1, -d1)];
            let mut s = vec![0.0];
            if d1 > d {
                pts.push(along(&e1, -d));
                s.push(d1 - d);
            }
            let s_blend = *s.last().unwrap_or(&0.0);
            for (j, p) in pts_blend_iter(&c, &e1, &e2, d, nb).enumerate().skip(1) {
                pts.push(p);
                s.push(s_blend + chords[..j].iter().sum::<f64>());
            }
            if d2 > d {
                pts.push(along(&e2, d2));
                s.push(*s.last().unwrap_or(&0.0) + d2 - d);
            }
            let qb = joints(&pts, &mut q)?;
            // The blend's points are solved once (for the splice too); the
            // ends of the stopped alternative are the neighbourhood's ends
            // and the corner, where the chain is (`self.ip.q`).
            let i0 = usize::from(d1 > d);
            known = Some(qb[i0 * n..(i0 + nb + 1) * n].to_vec());
            let (first, last) = (&qb[..n], &qb[qb.len() - n..]);
            let qa: Vec<f64> = first.iter().chain(&self.ip.q).copied().collect();
            let qc: Vec<f64> = self.ip.q.iter().chain(last).copied().collect();
            let through = plan(s, qb);
            let stop_a = plan(vec![0.0, d1], qa);
            let stop_b = plan(vec![0.0, d2], qc);
            if let (Some(t), Some(a), Some(b)) = (through, stop_a, stop_b)
                && t >= a + b
            {
                return Ok(Corner::Stop);
            }
        }
        self.splice(prev, d, &pts, &chords, v, known.as_deref())?;
        Ok(Corner::Blend(d / cur.len))
    }

    /// As [`Walker::blend`] when `prev` or `cur` is an arc: the blend of
    /// [`jblend`] (C² with both moves, within `tol` of them), its points
    /// and the neighbourhood of the corner sampled at most a step apart.
    fn blend_curves(
        &mut self,
        prev: &LastLine,
        cur: &LastLine,
        tol: f64,
        v: f64,
    ) -> Result<Corner, InterpolateError> {
        let (a, b) = (&prev.curve, &cur.curve);
        let Some(d_max) = jblend::size(a, b, tol) else {
            return Ok(Corner::None);
        };
        let d_max = d_max.min(prev.len - prev.cut0);
        let step = self.step;
        // The blend's points and chords at size `d`; `None` when degenerate.
        let points = |d: f64| -> Option<(Vec<Axes>, Vec<f64>)> {
            let nb = ((8.0 * d / step).ceil() as usize).max(BLEND_POINTS);
            let pts: Vec<Axes> = (0..=nb)
                .map(|j| jblend::point(a, b, d, j as f64 / nb as f64))
                .collect();
            let chords: Vec<f64> = pts.windows(2).map(|w| w[1].sub(&w[0]).xyz_norm()).collect();
            (!chords.iter().any(|x| x.is_nan() || *x <= 0.0)).then_some((pts, chords))
        };
        let Some(lim) = self.limits.clone() else {
            let Some((pts, chords)) = points(d_max) else {
                return Ok(Corner::None);
            };
            self.splice(prev, d_max, &pts, &chords, v, None)?;
            return Ok(Corner::Blend(d_max / cur.len));
        };
        // The neighbourhood: `d1` of the first move before the corner and
        // `d2` of the second after it (up to `2d`, the second move whole
        // where shorter: its curvature beyond the blend counts), sampled
        // at most a step apart.
        let d1 = (2.0 * d_max).min(prev.len - prev.cut0).max(d_max);
        let d2 = (2.0 * d_max).min(cur.len).max(d_max);
        let stretch = |s0: f64, s1: f64| -> Vec<f64> {
            let n = (((s1 - s0) / step).ceil() as usize).max(1);
            (0..=n)
                .map(|k| s0 + (s1 - s0) * k as f64 / n as f64)
                .collect()
        };
        let world = |p: &Axes| Axes(std::array::from_fn(|i| p.0[i] + prev.offset.0[i]));
        let n = self.ip.q.len();
        let joints = |pts: &[Axes]| -> Result<Vec<f64>, InterpolateError> {
            let mut q = self.ip.q.clone();
            let mut out = Vec::with_capacity(pts.len() * n);
            for p in pts {
                fast_joints(&self.ip, &self.affine, &world(p), prev.tcp, &mut q)?;
                out.extend_from_slice(&q);
            }
            Ok(out)
        };
        let plan = |s: Vec<f64>, q: Vec<f64>| -> Option<f64> {
            let caps = vec![v; s.len()];
            let path = JointPath::new(n, s, q, caps).ok()?;
            jerk::plan(&path, &lim, &self.opts_jerk)
                .ok()
                .map(|l| l.duration())
        };
        let sa = stretch(-d1, 0.0);
        let pa: Vec<Axes> = sa.iter().map(|&x| a.near_end(x)).collect();
        let sa: Vec<f64> = sa.iter().map(|x| x + d1).collect();
        let sc = stretch(0.0, d2);
        let pc: Vec<Axes> = sc.iter().map(|&x| b.near_start(x)).collect();
        let stop = match (plan(sa, joints(&pa)?), plan(sc, joints(&pc)?)) {
            (Some(x), Some(y)) => x + y,
            _ => f64::INFINITY,
        };
        // The largest blend within the tolerance, else a half or a quarter
        // of it (a large blend of a tight turn can be slower than a smaller
        // one), the first that is faster than stopping.
        let mut chosen = None;
        for d in [d_max, d_max / 2.0, d_max / 4.0] {
            let Some((pts, chords)) = points(d) else {
                continue;
            };
            let (mut pn, mut sn) = (Vec::new(), Vec::new());
            let before = stretch(-d1, -d);
            for &x in &before[..before.len() - 1] {
                pn.push(a.near_end(x));
                sn.push(x + d1);
            }
            let s_blend = d1 - d;
            for (j, p) in pts.iter().enumerate() {
                pn.push(*p);
                sn.push(s_blend + chords[..j].iter().sum::<f64>());
            }
            let s_after = *sn.last().unwrap_or(&0.0);
            for &x in stretch(d, d2).iter().skip(1) {
                pn.push(b.near_start(x));
                sn.push(s_after + x - d);
            }
            let through = plan(sn, joints(&pn)?);
            if through.is_some_and(|t| t < stop) {
                chosen = Some((d, pts, chords));
                break;
            }
        }
        match chosen {
            Some((d, pts, chords)) => {
                self.splice(prev, d, &pts, &chords, v, None)?;
                Ok(Corner::Blend(d / cur.len))
            }
            None => Ok(Corner::Stop),
        }
    }

    /// Replaces the last `d` of the chain by the blend points `pts` (work
    /// coordinates of `prev`'s offset and TCP; `chords` their distances;
    /// `known` their axis positions when already solved).
    fn splice(
        &mut self,
        prev: &LastLine,
        d: f64,
        pts: &[Axes],
        chords: &[f64],
        v: f64,
        known: Option<&[f64]>,
    ) -> Result<(), InterpolateError> {
        let n = self.ip.q.len();
        let chain = &mut self.chain;
        let s_c = *chain.s.last().unwrap_or(&0.0);
        let cut = s_c - d;
        while chain.s.len() > 1 && *chain.s.last().unwrap_or(&0.0) >= cut - 1e-9 * d {
            chain.pop(n);
        }
        let mut q = if chain.q.len() >= n {
            chain.q[chain.q.len() - n..].to_vec()
        } else {
            self.ip.q.clone()
        };
        let mut s = cut;
        for (j, p) in pts.iter().enumerate() {
            let w = Axes(std::array::from_fn(|i| p.0[i] + prev.offset.0[i]));
            match known {
                Some(k) if k.len() == pts.len() * n => q.copy_from_slice(&k[j * n..(j + 1) * n]),
                _ => fast_joints(&self.ip, &self.affine, &w, prev.tcp, &mut q)?,
            }
            if j > 0 {
                s += chords[j - 1];
            }
            chain.push(s, &q, v, self.ip.line);
        }
        self.ip.q.copy_from_slice(&q);
        Ok(())
    }

    /// A transition from the current position to `end`, as its own stretch.
    fn transition<F>(&mut self, end: Vec<f64>, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(Stretch<'_>) -> Result<(), InterpolateError>,
    {
        self.ip.check_travel(&end, 0.0)?;
        sink(Stretch::Transition {
            q0: &self.ip.q,
            q1: &end,
            line: self.ip.line,
        })?;
        self.ip.q.copy_from_slice(&end);
        self.ip.summary.transitions += 1;
        self.end_dir.clear();
        Ok(())
    }

    /// Runs the program through the walker; returns the moves, transitions
    /// and dwell time counted.
    fn run<R, F>(
        mut self,
        input: R,
        mut sink: F,
        mut hook: Option<&mut Hook<'_>>,
    ) -> Result<InterpolationSummary, InterpolateError>
    where
        R: BufRead,
        F: FnMut(Stretch<'_>) -> Result<(), InterpolateError>,
    {
        let iopts = self.ip.options().interp.clone();
        for_each_event(input, &iopts, hook.as_deref_mut(), |e| {
            self.event(e, &mut sink)
        })?;
        if let Some(e) = hook.and_then(|h| h.failed.take()) {
            return Err(e);
        }
        self.flush(&mut sink)?;
        Ok(self.ip.summary)
    }
}

/// Splits the program read from `input` into chains of moves between stops
/// and hands each to `sink` as a [`DensePath`] with points at most
/// `opts.plan.jerk_step` apart in path length and in every joint (mm, deg;
/// every move end is a point; `G64 P` makes the step at most 4·P). A chain ends at every move under G61.1
/// (exact stop), at a corner under G61 (a joint-space direction change of
/// more than 1°), at a dwell, a change of TCP or of work and tool offsets, a
/// spindle, tool, coolant or I/O command ([`super::TaskWait`]), a
/// move that starts away from the last one's end (TCP switched on: the
/// axis-space transition between the two is not part of either chain), and
/// at the end of the program. The points of a chain are the axis positions
/// of the programmed path (under TCP from the nominal inverse kinematics).
/// Memory holds one chain.
pub fn dense_paths<R, F>(
    mut input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
    mut sink: F,
) -> Result<(), InterpolateError>
where
    R: BufRead,
    F: FnMut(&DensePath) -> Result<(), InterpolateError>,
{
    dense_paths_dyn(&mut input, machine, opts, &mut sink)
}

/// [`dense_paths`] for a `dyn` reader and sink (the walker compiled once).
fn dense_paths_dyn(
    input: &mut dyn BufRead,
    machine: &Machine,
    opts: &InterpolateOptions,
    sink: &mut dyn FnMut(&DensePath) -> Result<(), InterpolateError>,
) -> Result<(), InterpolateError> {
    let n = machine.axes.len();
    Walker::new(machine, opts)?.run(
        input,
        |st| match st {
            Stretch::Chain(c) => sink(&c.dense(n)),
            _ => Ok(()),
        },
        None,
    )?;
    Ok(())
}

/// The joint limits of `machine` for the `jerk` planner: every axis needs
/// `max_acceleration` and `max_jerk` (`max_velocity` may be absent: no
/// limit). The error names the first axis and key missing.
pub fn jerk_limits(machine: &Machine) -> Result<JointLimits, InterpolateError> {
    let mut lim = JointLimits {
        v: Vec::new(),
        a: Vec::new(),
        j: Vec::new(),
    };
    for axis in &machine.axes {
        let unit = match axis.kind {
            AxisKind::Linear => "mm",
            AxisKind::Rotary => "deg",
        };
        for (key, value, power) in [
            ("max_acceleration", axis.max_acceleration, "²"),
            ("max_jerk", axis.max_jerk, "³"),
        ] {
            if value.is_none() {
                return Err(InterpolateError::MissingLimit {
                    axis: axis.name.clone(),
                    key,
                    unit: format!("{unit}/s{power}"),
                });
            }
        }
        lim.v.push(axis.max_velocity.unwrap_or(f64::INFINITY));
        lim.a.push(axis.max_acceleration.unwrap_or(f64::INFINITY));
        lim.j.push(axis.max_jerk.unwrap_or(f64::INFINITY));
    }
    Ok(lim)
}

/// Plans and samples the stretches of the `jerk` planner on one clock.
struct JerkRun<'a, F> {
    machine: &'a Machine,
    limits: JointLimits,
    opts: &'a InterpolateOptions,
    /// Index of the next sample.
    k: u64,
    /// Start of the next stretch, s.
    t0: f64,
    q: Vec<f64>,
    line: u64,
    samples: u64,
    sink: F,
    /// `(line, end time)` of every move and stretch, when asked for.
    ends: Option<Vec<(u64, f64)>>,
}

impl<F> JerkRun<'_, F>
where
    F: FnMut(&Sample<'_>) -> io::Result<()>,
{
    /// Plans `path` and emits its samples before its end.
    fn law(&mut self, path: &JointPath, lines: &[u64]) -> Result<(), InterpolateError> {
        let law = jerk::plan(path, &self.limits, &self.opts.plan.jerk)
            .map_err(|e| InterpolateError::Plan(format!("line {}: {e}", lines[0])))?;
        let end = self.t0 + law.duration();
        self.bound(end, *lines.last().unwrap_or(&0))?;
        if let Some(ends) = &mut self.ends {
            // Each move ends at its last point: the time the law's path
            // parameter reaches it (bisection; the law never goes back).
            let s = path.s();
            for i in 0..lines.len() {
                if i + 1 < lines.len() && lines[i + 1] == lines[i] {
                    continue;
                }
                let t = if i + 1 == lines.len() {
                    law.duration()
                } else {
                    let (mut lo, mut hi) = (0.0, law.duration());
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        if law.s(mid) >= s[i] {
                            hi = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    hi
                };
                ends.push((lines[i], self.t0 + t));
            }
        }
        let mut cur = law.cursor();
        let mut out = vec![0.0; path.joints()];
        let s = path.s();
        let mut idx = 0;
        loop {
            let t = self.k as f64 * self.opts.ts;
            if t >= end {
                break;
            }
            let sp = cur.at_clock(self.k as f64, self.opts.ts, self.t0, &mut out);
            while idx + 1 < s.len() && s[idx] < sp {
                idx += 1;
            }
            self.emit(t, &out, lines[idx])?;
        }
        self.t0 = end;
        self.q.copy_from_slice(path.q(path.points() - 1));
        self.line = *lines.last().unwrap_or(&self.line);
        Ok(())
    }

    fn bound(&self, end: f64, line: u64) -> Result<(), InterpolateError> {
        if end / self.opts.ts >= self.opts.max_samples as f64 {
            return Err(InterpolateError::TooManySamples {
                line,
                t: end,
                ts: self.opts.ts,
                max: self.opts.max_samples,
            });
        }
        Ok(())
    }

    fn emit(&mut self, t: f64, q: &[f64], line: u64) -> Result<(), InterpolateError> {
        if self.opts.check_travel {
            travel_error(self.machine, q, t, line)?;
        }
        (self.sink)(&Sample { t, q, line }).map_err(InterpolateError::Sink)?;
        self.k += 1;
        self.samples += 1;
        Ok(())
    }

    fn stretch(&mut self, st: Stretch<'_>) -> Result<(), InterpolateError> {
        match st {
            Stretch::Chain(c) => {
                let n = self.q.len();
                let (s, q, cap) = (
                    std::mem::take(&mut c.s),
                    std::mem::take(&mut c.q),
                    std::mem::take(&mut c.v_cap),
                );
                let path = JointPath::new(n, s, q, cap)
                    .map_err(|e| InterpolateError::Plan(format!("line {}: {e}", c.line[0])))?;
                self.law(&path, &c.line)
            }
            Stretch::Transition { q0, q1, line } => {
                // Path length as the rapid rate counts it: the linear axes,
                // else the rotary ones.
                let (mut lin, mut rot) = (0.0f64, 0.0f64);
                for (i, (a, b)) in q0.iter().zip(q1).enumerate() {
                    if self.machine.axes[i].kind == AxisKind::Linear {
                        lin += (b - a).powi(2);
                    } else {
                        rot += (b - a).powi(2);
                    }
                }
                let len = if lin > 0.0 { lin.sqrt() } else { rot.sqrt() };
                if len.is_nan() || len <= 0.0 {
                    return Ok(());
                }
                let v = self.machine.rapid_feed / 60.0;
                let q: Vec<f64> = q0.iter().chain(q1).copied().collect();
                let path = JointPath::new(q0.len(), vec![0.0, len], q, vec![v, v])
                    .map_err(|e| InterpolateError::Plan(format!("line {line}: {e}")))?;
                self.law(&path, &[line, line])
            }
            Stretch::Dwell { q, seconds, line } => {
                let end = self.t0 + seconds;
                self.bound(end, line)?;
                self.q.copy_from_slice(q);
                loop {
                    let t = self.k as f64 * self.opts.ts;
                    if t >= end {
                        break;
                    }
                    let q = self.q.clone();
                    self.emit(t, &q, line)?;
                }
                if let Some(ends) = &mut self.ends {
                    ends.push((line, end));
                }
                self.t0 = end;
                self.line = line;
                Ok(())
            }
        }
    }
}

/// An [`InterpolateError::OutOfTravel`] when `q` leaves an axis travel.
fn travel_error(machine: &Machine, q: &[f64], t: f64, line: u64) -> Result<(), InterpolateError> {
    match travel::first_outside(machine, q) {
        None => Ok(()),
        Some(i) => {
            let axis = &machine.axes[i];
            Err(InterpolateError::OutOfTravel {
                line,
                axis: axis.name.clone(),
                value: q[i],
                unit: match axis.kind {
                    AxisKind::Linear => "mm",
                    AxisKind::Rotary => "deg",
                },
                t,
                lo: axis.travel[0],
                hi: axis.travel[1],
            })
        }
    }
}

/// [`interpolate`] under the `jerk` planner: each stretch between stops is
/// one jerk-limited motion ([`jerk::plan`]) along its dense joint path.
fn interpolate_jerk<R, F>(
    input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
    sink: F,
    hook: Option<&mut Hook<'_>>,
    ends: Option<&mut Vec<(u64, f64)>>,
) -> Result<InterpolationSummary, InterpolateError>
where
    R: BufRead,
    F: FnMut(&Sample<'_>) -> io::Result<()>,
{
    let (limits, walker) =
        match jerk_limits(machine).and_then(|l| Ok((l, Walker::new(machine, opts)?))) {
            Ok(x) => x,
            Err(e) => return without_planner(input, opts, hook, e),
        };
    let q = walker.ip.q.clone();
    let mut run = JerkRun {
        machine,
        limits,
        opts,
        k: 0,
        t0: 0.0,
        q,
        line: 0,
        samples: 0,
        sink,
        ends: ends.is_some().then(Vec::new),
    };
    let mut summary = walker.run(input, |st| run.stretch(st), hook)?;
    let t = run.k as f64 * opts.ts;
    let q = run.q.clone();
    (run.sink)(&Sample {
        t,
        q: &q,
        line: run.line,
    })
    .map_err(InterpolateError::Sink)?;
    summary.samples = run.samples + 1;
    summary.duration = run.t0;
    if let (Some(ends), Some(planned)) = (ends, run.ends) {
        *ends = planned;
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
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
        let p = FsPath::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/machines/ac-trunnion.toml");
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
}
