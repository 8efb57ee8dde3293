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
//!
//! **Where things are.** This file: the options, errors and the entry points
//! ([`interpolate`] and the run that feeds the interpreter's events to a
//! planner). `interpolator.rs`: segments, their geometry, speed limits and
//! samples; `durations.rs`: planned durations and line end times;
//! `dense_path.rs`: the dense joint paths of the jerk-limited planner;
//! `jerk_run.rs`: interpolation with that planner.

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

mod dense_path;
mod durations;
mod interpolator;
mod jerk_run;
#[cfg(test)]
mod tests;

use dense_path::*;
pub use dense_path::{DensePath, dense_paths};
pub use durations::{LineEndTimes, line_end_times, planned_duration, planned_duration_with};
pub use interpolator::Interpolator;
use interpolator::*;
pub use jerk_run::jerk_limits;
use jerk_run::*;

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
