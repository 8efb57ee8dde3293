//! The twin's input (docs/twin.md): axis commands at the servo sample period, read from
//! CMD.csv or interpolated from a G-code program, streamed into a [`Predictor`](super::Predictor).

use std::io::{self, BufRead};
use std::path::Path;

use super::TwinError;
use super::pipeline::{Progress, Twin, TwinSample, TwinSummary};
use crate::gcode::{self, InterpolateError, InterpolateOptions};
use crate::io::{CsvRows, Diagnostic, fmt_f64};
use crate::model::Machine;

/// Allowed deviation of one time step from the period (fraction of the period), as in
/// `mtwin servo simulate`.
pub const STEP_TOLERANCE: f64 = 0.01;

/// Report progress every this many command samples in stage 1.
const REPORT_EVERY: u64 = 1 << 16;

/// Runs the twin on CMD.csv read from `reader` (`path` names it in messages): a `t_s`
/// column (s) and one column per machine axis (mm, deg), equally spaced in time
/// (every step within [`STEP_TOLERANCE`] of the first; time must increase).
pub fn predict_csv<R, F>(
    twin: &Twin,
    path: &Path,
    mut reader: R,
    mut sink: F,
    progress: &mut dyn FnMut(Progress),
) -> Result<TwinSummary, TwinError>
where
    R: BufRead,
    F: FnMut(&TwinSample) -> io::Result<()>,
{
    predict_csv_dyn(twin, path, &mut reader, &mut sink, progress)
}

/// [`predict_csv`] for a `dyn` reader and sink (compiled once).
fn predict_csv_dyn(
    twin: &Twin,
    path: &Path,
    reader: &mut dyn BufRead,
    sink: &mut dyn FnMut(&TwinSample) -> io::Result<()>,
    progress: &mut dyn FnMut(Progress),
) -> Result<TwinSummary, TwinError> {
    let mut rows = CsvRows::new(path, reader)?;
    let mut names = vec![crate::io::columns::T_S];
    names.extend(twin.axis_names().iter().map(String::as_str));
    let cols = rows.require(&names)?;
    let mut first = Vec::new();
    let mut second = Vec::new();
    if !rows.next_numbers(&cols, &mut first)? {
        return Err(Diagnostic::whole(path, "the file has no data rows").into());
    }
    if !rows.next_numbers(&cols, &mut second)? {
        return Err(Diagnostic::whole(
            path,
            "the file has one data row: at least two samples are needed to know the period",
        )
        .into());
    }
    let ts = second[0] - first[0];
    if ts <= 0.0 {
        return Err(Diagnostic::at(
            path,
            rows.line(),
            cols[0].index + 1,
            format!(
                "t_s = {} does not increase (previous sample {})",
                fmt_f64(second[0]),
                fmt_f64(first[0])
            ),
        )
        .into());
    }
    let mut p = twin.start(ts)?;
    p.push(first[0], &first[1..]).map_err(TwinError::Spool)?;
    p.push(second[0], &second[1..]).map_err(TwinError::Spool)?;
    let mut prev = second[0];
    let mut row = second;
    while rows.next_numbers(&cols, &mut row)? {
        let dt = row[0] - prev;
        if !(dt > 0.0 && (dt - ts).abs() <= STEP_TOLERANCE * ts) {
            let what = if dt > 0.0 {
                format!(
                    "is {} s after the previous sample ({}), but the period is {} s: CMD.csv must be equally spaced",
                    fmt_f64(dt),
                    fmt_f64(prev),
                    fmt_f64(ts)
                )
            } else {
                format!("does not increase (previous sample {})", fmt_f64(prev))
            };
            return Err(Diagnostic::at(
                path,
                rows.line(),
                cols[0].index + 1,
                format!("t_s = {} {what}", fmt_f64(row[0])),
            )
            .into());
        }
        prev = row[0];
        p.push(row[0], &row[1..]).map_err(TwinError::Spool)?;
        if p.samples().is_multiple_of(REPORT_EVERY) {
            progress(Progress::Commands(p.samples()));
        }
    }
    p.finish(sink, progress)
}

/// Runs the twin on a G-code program read from `input`, interpolated at `opts.ts` by the
/// project's interpolator (`opts.interp.tcp_at_start` reads it as a TCP program from its
/// start; M428/M429 still switch).
pub fn predict_gcode<R, F>(
    twin: &Twin,
    machine: &Machine,
    mut input: R,
    opts: &InterpolateOptions,
    mut sink: F,
    progress: &mut dyn FnMut(Progress),
) -> Result<TwinSummary, TwinError>
where
    R: BufRead,
    F: FnMut(&TwinSample) -> io::Result<()>,
{
    predict_gcode_dyn(twin, machine, &mut input, opts, &mut sink, progress)
}

/// [`predict_gcode`] for a `dyn` reader and sink (compiled once).
fn predict_gcode_dyn(
    twin: &Twin,
    machine: &Machine,
    input: &mut dyn BufRead,
    opts: &InterpolateOptions,
    sink: &mut dyn FnMut(&TwinSample) -> io::Result<()>,
    progress: &mut dyn FnMut(Progress),
) -> Result<TwinSummary, TwinError> {
    if !(opts.ts.is_finite() && opts.ts > 0.0) {
        return Err(TwinError::Period(opts.ts));
    }
    let mut p = twin.start(opts.ts)?;
    let r = gcode::interpolate(input, machine, opts, |s| {
        p.push(s.t, s.q)?;
        if p.samples().is_multiple_of(REPORT_EVERY) {
            progress(Progress::Commands(p.samples()));
        }
        Ok(())
    });
    match r {
        Ok(_) => p.finish(sink, progress),
        Err(InterpolateError::Sink(e)) => Err(TwinError::Spool(e)),
        Err(e) => Err(TwinError::Program(e)),
    }
}
