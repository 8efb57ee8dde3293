//! Planned durations: a program's time and the time at which each line
//! ends, by the same planners as the samples, without producing samples.

use super::*;

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
