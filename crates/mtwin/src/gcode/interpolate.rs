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
//!   finite differences at 16 sub-steps with a 10 % margin.
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

use std::io::{self, BufRead};

use nalgebra::Vector3;

use super::arc::{self, Geometry};
use super::axes::{Axes, Axis, AxisLetterError};
use super::error::GcodeError;
use super::event::{ArcMove, Event, EventKind, Feed, Linear};
use super::interp::{InterpOptions, Interpreter};
use super::profile::Trapezoid;
use super::program_flow::{Step, run_program};
use super::timing::{self, lerp};
use crate::kinematics::{IkError, IkOptions, IkTarget, Kinematics};
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
    Line { from: Axes, to: Axes },
    Arc { arc: ArcMove, g: Geometry },
}

impl Geom {
    fn at(&self, s: f64) -> Axes {
        match self {
            Geom::Line { from, to } => lerp(from, to, s),
            Geom::Arc { arc, g } => {
                let (p, q, _) = arc.plane.axes();
                let mut x = lerp(&arc.from, &arc.to, s);
                if s >= 1.0 {
                    return arc.to;
                }
                let ang = g.start_angle + g.sweep * s;
                let r = g.radius + (g.end_radius - g.radius) * s;
                x[p] = g.center[0] + r * ang.cos();
                x[q] = g.center[1] + r * ang.sin();
                x
            }
        }
    }
}

/// A segment of motion.
enum Path {
    /// Straight in axis space.
    Joint { q0: Vec<f64>, q1: Vec<f64> },
    /// A programmed move.
    Work {
        geom: Box<Geom>,
        offset: Axes,
        tcp: bool,
    },
}

/// Fraction of a sub-step margin on finite-difference derivative bounds.
const FD_MARGIN: f64 = 1.1;
/// Sub-steps of the finite-difference derivative bounds under TCP.
const FD_STEPS: usize = 16;
/// Axis-space distance below which a move's start is the current position.
const SAME_POSITION: f64 = 1e-7;

/// Streams samples for the events given to it (see the module documentation).
pub struct Interpolator<'m> {
    machine: &'m Machine,
    kin: Kinematics,
    letters: Vec<Axis>,
    linear: Vec<bool>,
    ik: IkOptions,
    opts: InterpolateOptions,
    /// Current axis positions.
    q: Vec<f64>,
    /// Scratch axis positions.
    buf: Vec<f64>,
    /// Index of the next sample.
    k: u64,
    /// End time of the last segment, s.
    now: f64,
    line: u64,
    summary: InterpolationSummary,
}

impl<'m> Interpolator<'m> {
    /// An interpolator for `machine` (its nominal kinematics is used for
    /// TCP), starting at `opts.interp.initial_machine_position`.
    pub fn new(machine: &'m Machine, opts: &InterpolateOptions) -> Result<Self, InterpolateError> {
        if !(opts.ts > 0.0 && opts.ts.is_finite()) {
            return Err(InterpolateError::Period(opts.ts));
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
        Ok(Interpolator {
            machine,
            kin: Kinematics::nominal(machine),
            linear: machine
                .axes
                .iter()
                .map(|a| a.kind == AxisKind::Linear)
                .collect(),
            letters,
            ik: IkOptions {
                max_iterations: 20,
                tip_tolerance: 1e-11,
                axis_tolerance: 1e-13,
                check_travel: false,
                stall_ratio: None,
            },
            buf: q.clone(),
            q,
            opts,
            k: 0,
            now: 0.0,
            line: 0,
            summary: InterpolationSummary::default(),
        })
    }

    /// The settings in force (with `interp.tcp_at_start` set when TCP is forced).
    pub fn options(&self) -> &InterpolateOptions {
        &self.opts
    }

    /// Current axis positions, machine axis order.
    pub fn position(&self) -> &[f64] {
        &self.q
    }

    /// Interpolates one event, handing its samples to `sink`.
    pub fn push<F>(&mut self, event: &Event, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        self.line = event.at.line;
        let force = self.opts.force_tcp;
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
                let end = self.now + seconds;
                let q = self.q.clone();
                self.emit_until(end, sink, |_, out| {
                    out.copy_from_slice(&q);
                    Ok(())
                })?;
                self.now = end;
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Emits the last sample (at the first `k·ts` not before the end) and
    /// returns the summary.
    pub fn finish<F>(mut self, sink: &mut F) -> Result<InterpolationSummary, InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let t = self.k as f64 * self.opts.ts;
        let sample = Sample {
            t,
            q: &self.q,
            line: self.line,
        };
        sink(&sample).map_err(InterpolateError::Sink)?;
        self.summary.samples += 1;
        self.summary.duration = self.now;
        Ok(self.summary)
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
            Geom::Line { .. } => d.0.iter().all(|&x| x == 0.0),
            Geom::Arc { g, .. } => g.sweep == 0.0 && d.0.iter().all(|&x| x == 0.0),
        };
        // Axes the program moves must exist.
        for axis in Axis::ALL {
            let moved = match geom {
                Geom::Arc { arc, .. } => {
                    let (p, q, _) = arc.plane.axes();
                    d[axis] != 0.0 || axis == p || axis == q
                }
                Geom::Line { .. } => d[axis] != 0.0,
            };
            if moved && !still && !self.letters.contains(&axis) {
                return Err(InterpolateError::MissingAxis {
                    line: self.line,
                    letter: char::from(axis.letter()),
                });
            }
        }
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
            let joint = Path::Joint {
                q0: self.q.clone(),
                q1: end.clone(),
            };
            let minutes = self.joint_rapid_minutes(&self.q, &end);
            self.segment(&joint, 60.0 * minutes, sink)?;
            self.summary.transitions += 1;
            self.summary.moves += 1;
            self.q.copy_from_slice(&end);
            return Ok(());
        }
        if gap > SAME_POSITION {
            let joint = Path::Joint {
                q0: self.q.clone(),
                q1: start.clone(),
            };
            let minutes = self.joint_rapid_minutes(&self.q, &start);
            self.segment(&joint, 60.0 * minutes, sink)?;
            self.summary.transitions += 1;
        }
        self.q.copy_from_slice(&start);
        if still {
            return Ok(());
        }
        let length = match geom {
            Geom::Line { .. } => d.xyz_norm(),
            Geom::Arc { g, .. } => g.xyz_length(),
        };
        let seconds = self.feed_seconds(feed, length, &d)?;
        self.segment(&path, seconds, sink)?;
        self.summary.moves += 1;
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

    /// Axis positions at `s` along `path` into `out` (which holds the
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
            Path::Work { geom, offset, tcp } => {
                let w = geom.at(s);
                if !tcp {
                    for (o, &l) in out.iter_mut().zip(&self.letters) {
                        *o = w[l] + offset[l];
                    }
                    return Ok(());
                }
                for (i, (o, &l)) in out.iter_mut().zip(&self.letters).enumerate() {
                    if !self.linear[i] {
                        *o = w[l] + offset[l];
                    }
                }
                let tip = Vector3::new(
                    w[Axis::X] + offset[Axis::X],
                    w[Axis::Y] + offset[Axis::Y],
                    w[Axis::Z] + offset[Axis::Z],
                );
                let target = IkTarget { tip, axis: None };
                let q = self
                    .kin
                    .inverse(&target, out, &self.linear, &self.ik)
                    .map_err(|source| InterpolateError::Ik {
                        line: self.line,
                        x: tip.x,
                        y: tip.y,
                        z: tip.z,
                        source,
                    })?;
                out.copy_from_slice(&q);
                Ok(())
            }
        }
    }

    /// Bounds `(D1, D2)` on `|dq/ds|` and `|d²q/ds²|` per machine axis.
    fn derivative_bounds(&self, path: &Path) -> Result<(Vec<f64>, Vec<f64>), InterpolateError> {
        let n = self.q.len();
        let mut d1 = vec![0.0; n];
        let mut d2 = vec![0.0; n];
        match path {
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
                };
                for (i, &l) in self.letters.iter().enumerate() {
                    d1[i] = (to[l] - from[l]).abs();
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
                // Finite differences over FD_STEPS sub-steps.
                let h = 1.0 / FD_STEPS as f64;
                let mut pts = Vec::with_capacity(FD_STEPS + 1);
                let mut cur = self.q.clone();
                for j in 0..=FD_STEPS {
                    self.eval(path, j as f64 * h, &mut cur)?;
                    pts.push(cur.clone());
                }
                for j in 0..FD_STEPS {
                    for i in 0..n {
                        let v = (pts[j + 1][i] - pts[j][i]).abs() / h;
                        d1[i] = f64::max(d1[i], FD_MARGIN * v);
                        if j > 0 {
                            let a =
                                (pts[j + 1][i] - 2.0 * pts[j][i] + pts[j - 1][i]).abs() / (h * h);
                            d2[i] = f64::max(d2[i], FD_MARGIN * a);
                        }
                    }
                }
            }
        }
        Ok((d1, d2))
    }

    /// Runs one segment whose programmed duration is `seconds`.
    fn segment<F>(
        &mut self,
        path: &Path,
        seconds: f64,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
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
        let profile = Trapezoid::new(v, a);
        let t0 = self.now;
        let end = t0 + profile.duration();
        self.emit_until(end, sink, |me, out| {
            let s = profile.s_at(me.k as f64 * me.opts.ts - t0);
            me.eval(path, s, out)
        })?;
        let mut last = std::mem::take(&mut self.buf);
        last.copy_from_slice(&self.q);
        self.eval(path, 1.0, &mut last)?;
        self.check_travel(&last, end)?;
        self.q.copy_from_slice(&last);
        self.buf = last;
        self.now = end;
        Ok(())
    }

    /// Emits samples `k·ts < end`, positions from `at(self, out)`.
    fn emit_until<F, G>(&mut self, end: f64, sink: &mut F, at: G) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
        G: Fn(&Self, &mut [f64]) -> Result<(), InterpolateError>,
    {
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
        out.copy_from_slice(&self.q);
        let result = loop {
            let t = self.k as f64 * self.opts.ts;
            if t >= end {
                break Ok(());
            }
            if let Err(e) = at(self, &mut out) {
                break Err(e);
            }
            if let Err(e) = self.check_travel(&out, t) {
                break Err(e);
            }
            let sample = Sample {
                t,
                q: &out,
                line: self.line,
            };
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
        for (axis, &value) in self.machine.axes.iter().zip(q) {
            if !axis.in_travel(value) {
                return Err(InterpolateError::OutOfTravel {
                    line: self.line,
                    axis: axis.name.clone(),
                    value,
                    unit: match axis.kind {
                        AxisKind::Linear => "mm",
                        AxisKind::Rotary => "deg",
                    },
                    t,
                    lo: axis.travel[0],
                    hi: axis.travel[1],
                });
            }
        }
        Ok(())
    }
}

/// Interpolates the program read from `input` on `machine`, streaming:
/// `sink` gets every sample in time order (see the module documentation).
pub fn interpolate<R, F>(
    input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
    mut sink: F,
) -> Result<InterpolationSummary, InterpolateError>
where
    R: BufRead,
    F: FnMut(&Sample<'_>) -> io::Result<()>,
{
    let mut ip = Interpolator::new(machine, opts)?;
    let iopts = ip.options().interp.clone();
    let mut interp = Interpreter::new(iopts.clone());
    run_program(
        input,
        &mut interp,
        &iopts.program,
        iopts.dialect,
        |step: &Step<'_>| -> Result<(), InterpolateError> {
            for e in step.events {
                ip.push(e, &mut sink)?;
            }
            Ok(())
        },
    )?;
    ip.finish(&mut sink)
}

#[cfg(test)]
mod tests {
    use std::path::{Path as FsPath, PathBuf};

    use super::*;
    use crate::gcode::{StatsOptions, stats};
    use crate::model::{Axis as MAxis, read_machine};

    /// A Cartesian XYZ machine with the given limits on every axis.
    fn xyz(vmax: Option<f64>, amax: Option<f64>) -> Machine {
        let mut axes = Vec::new();
        for (name, d) in [
            ("X", [1.0, 0.0, 0.0]),
            ("Y", [0.0, 1.0, 0.0]),
            ("Z", [0.0, 0.0, 1.0]),
        ] {
            let mut a = MAxis::new(name, AxisKind::Linear, d, [0.0; 3], [-1000.0, 1000.0]);
            a.max_velocity = vmax;
            a.max_acceleration = amax;
            axes.push(a);
        }
        Machine {
            name: "xyz".into(),
            axes,
            tool_chain: vec![0, 1, 2],
            workpiece_chain: vec![],
            tool_tip: Vector3::zeros(),
            tool_direction: Vector3::z(),
            workpiece_origin: Vector3::zeros(),
            rapid_feed: 6000.0,
        }
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
