//! Raw continuous logs of a positioning run: one sample per line,
//!
//! ```text
//! NAME  YYYY-MM-DD HH:MM:SS.ffffff  VALUE
//! ```
//!
//! (the layout `camonitor` of EPICS writes; other channels in the file are
//! ignored). Two channels are used: the commanded position (a new value starts
//! a move to that target) and the measured reference position, scaled to mm
//! as `gain × value + offset`.
//!
//! Each command is one approach: its direction is the sign of the change from
//! the previous command (so an overrun move to `P − a` followed by `P` is an
//! approach to `P` from below). Its measurement is the mean of the dwell — the
//! longest run of reference samples at the end of the move, before the next
//! command, whose spread stays within `dwell_band_mm`. Samples taken while
//! moving, commands that are not targets (overruns, the first command whose
//! direction is unknown) are dropped and listed in the run's notes.
//!
//! Targets are given, or else every commanded value approached from both
//! sides. A target that is never commanded, or whose dwell never settles or
//! settles farther than `reach_tol_mm` from it, is an error.

use std::collections::BTreeMap;
use std::path::Path;

use super::iso230_2::{Entry, Run, assemble};
use crate::io::{Diagnostic, Diagnostics, fmt_f64};

/// How to read a raw log (or a capture, see [`super::read_rtx_run`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LogOptions {
    /// Channel of the measured reference position (required for logs).
    pub reference: Option<String>,
    /// Channel of the commanded position (required for logs).
    pub command: Option<String>,
    /// Reference in mm = `gain × value + offset`.
    pub gain: f64,
    /// See `gain`, mm.
    pub offset: f64,
    /// Target positions, mm; `None`: every commanded value approached from both sides.
    pub targets_mm: Option<Vec<f64>>,
    /// Largest spread (max − min) of the reference samples of a dwell, mm.
    pub dwell_band_mm: f64,
    /// Fewest samples that make a dwell.
    pub min_dwell_samples: usize,
    /// Shortest dwell in a capture (see [`super::read_rtx_run`]), s.
    pub min_dwell_s: f64,
    /// Largest |measured − target| of a dwell that reaches its target, mm.
    pub reach_tol_mm: f64,
}

impl Default for LogOptions {
    fn default() -> Self {
        Self {
            reference: None,
            command: None,
            gain: 1.0,
            offset: 0.0,
            targets_mm: None,
            dwell_band_mm: 0.005,
            min_dwell_samples: 3,
            min_dwell_s: 0.5,
            reach_tol_mm: 0.1,
        }
    }
}

/// Days from 1970-01-01 of a proleptic Gregorian date.
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * (m + if m > 2 { -3 } else { 9 }) + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Seconds of `YYYY-MM-DD` `HH:MM:SS.fff`.
fn timestamp(date: &str, time: &str) -> Option<f64> {
    let d: Vec<i64> = date
        .split('-')
        .map(|p| p.parse().ok())
        .collect::<Option<_>>()?;
    let t: Vec<&str> = time.split(':').collect();
    if d.len() != 3 || t.len() != 3 || !(1..=12).contains(&d[1]) || !(1..=31).contains(&d[2]) {
        return None;
    }
    let h: f64 = t[0].parse().ok()?;
    let mi: f64 = t[1].parse().ok()?;
    let s: f64 = t[2].parse().ok()?;
    let secs = days_from_civil(d[0], d[1], d[2]) as f64 * 86_400.0 + h * 3600.0 + mi * 60.0 + s;
    secs.is_finite().then_some(secs)
}

/// One sample: time s, value, line, column of the value.
#[derive(Debug, Clone, Copy)]
struct Sample {
    t: f64,
    v: f64,
    line: usize,
    col: usize,
}

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * (1.0 + a.abs().max(b.abs()))
}

/// The trailing dwell of `x`: the longest run at the end with `max − min ≤ band`.
pub(crate) fn trailing_dwell(x: &[f64], band: f64) -> usize {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut k = 0;
    for &v in x.iter().rev() {
        lo = lo.min(v);
        hi = hi.max(v);
        if hi - lo > band {
            break;
        }
        k += 1;
    }
    k
}

/// One move: the command sample and the reference samples until the next command.
pub(crate) struct Move {
    pub command_mm: f64,
    pub line: usize,
    pub col: usize,
    /// `None` for the first command (no previous position).
    pub up: Option<bool>,
    /// Reference samples in mm, in time order.
    pub reference_mm: Vec<f64>,
}

/// Turn moves into approaches (see the module documentation).
pub(crate) fn approaches(
    path: &Path,
    moves: &[Move],
    opts: &LogOptions,
    last_line: usize,
    mut notes: Vec<String>,
) -> Result<Run, Diagnostics> {
    let mut diags = Diagnostics::default();
    let targets: Vec<f64> = match &opts.targets_mm {
        Some(t) => t.clone(),
        None => {
            let mut t: Vec<f64> = Vec::new();
            for m in moves {
                let both = [true, false].iter().all(|&d| {
                    moves
                        .iter()
                        .any(|o| same(o.command_mm, m.command_mm) && o.up == Some(d))
                });
                if both && !t.iter().any(|&x| same(x, m.command_mm)) {
                    t.push(m.command_mm);
                }
            }
            t
        }
    };
    if let Some(given) = &opts.targets_mm {
        for &t in given {
            if !moves
                .iter()
                .any(|m| same(m.command_mm, t) && m.up.is_some())
            {
                diags.push(Diagnostic::at(
                    path,
                    last_line.max(1),
                    1,
                    format!(
                        "target {} mm never reached: the log ends without a move commanded to it",
                        fmt_f64(t)
                    ),
                ));
            }
        }
    }
    let mut dropped: BTreeMap<String, usize> = BTreeMap::new();
    let mut entries = Vec::new();
    let (mut used, mut moving, mut dwell_min, mut dwell_max) = (0usize, 0usize, usize::MAX, 0);
    for m in moves {
        let is_target = targets.iter().any(|&t| same(t, m.command_mm));
        let Some(up) = m.up.filter(|_| is_target) else {
            let why = if m.up.is_none() {
                format!(
                    "{} mm (first command, direction unknown)",
                    fmt_f64(m.command_mm)
                )
            } else {
                format!("{} mm (not a target)", fmt_f64(m.command_mm))
            };
            *dropped.entry(why).or_default() += 1;
            moving += m.reference_mm.len();
            continue;
        };
        let k = trailing_dwell(&m.reference_mm, opts.dwell_band_mm);
        let dwell = &m.reference_mm[m.reference_mm.len() - k..];
        let mean = dwell.iter().sum::<f64>() / k.max(1) as f64;
        if k < opts.min_dwell_samples.max(1) {
            diags.push(Diagnostic::at(
                path,
                m.line,
                m.col,
                format!(
                    "target {} mm never reached: no dwell of {} samples within {} mm before the next command ({} reference samples in the move)",
                    fmt_f64(m.command_mm),
                    opts.min_dwell_samples.max(1),
                    fmt_f64(opts.dwell_band_mm),
                    m.reference_mm.len()
                ),
            ));
            continue;
        }
        if (mean - m.command_mm).abs() > opts.reach_tol_mm {
            diags.push(Diagnostic::at(
                path,
                m.line,
                m.col,
                format!(
                    "target {} mm never reached: the reference settled at {} mm, more than {} mm away (check the channel, gain and offset)",
                    fmt_f64(m.command_mm),
                    fmt_f64(mean),
                    fmt_f64(opts.reach_tol_mm)
                ),
            ));
            continue;
        }
        used += k;
        moving += m.reference_mm.len() - k;
        dwell_min = dwell_min.min(k);
        dwell_max = dwell_max.max(k);
        entries.push(Entry {
            target_mm: m.command_mm,
            up,
            cycle: None,
            deviation_mm: mean - m.command_mm,
            line: m.line,
            col: m.col,
        });
    }
    diags.into_result(())?;
    if !dropped.is_empty() {
        let list: Vec<String> = dropped
            .iter()
            .map(|(w, n)| {
                if *n > 1 {
                    format!("{w} ×{n}")
                } else {
                    w.clone()
                }
            })
            .collect();
        notes.push(format!(
            "dropped {} command(s) that are not approaches to a target: {}",
            dropped.values().sum::<usize>(),
            list.join(", ")
        ));
    }
    if !entries.is_empty() && opts.dwell_band_mm.is_finite() {
        notes.push(format!(
            "each approach is the mean of its dwell ({dwell_min} to {dwell_max} samples within {} mm); {used} reference samples averaged, {moving} taken while moving or in dropped moves left out",
            fmt_f64(opts.dwell_band_mm)
        ));
    }
    assemble(path, &entries, notes)
}

/// Read a raw log (layout and detection in the module documentation).
pub fn read_log(path: &Path, opts: &LogOptions) -> Result<Run, Diagnostics> {
    let bytes = std::fs::read(path)
        .map_err(|e| Diagnostic::whole(path, format!("cannot read the file: {e}")))?;
    let text = String::from_utf8_lossy(&bytes);
    let mut channels: BTreeMap<&str, usize> = BTreeMap::new();
    let mut refs: Vec<Sample> = Vec::new();
    let mut cmds: Vec<Sample> = Vec::new();
    let mut diags = Diagnostics::default();
    let mut last_line = 0;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        last_line = line;
        let fields: Vec<(usize, &str)> = raw
            .split_whitespace()
            .map(|f| (f.as_ptr() as usize - raw.as_ptr() as usize + 1, f))
            .collect();
        if fields.is_empty() || fields[0].1.starts_with('#') {
            continue;
        }
        let name = fields[0].1;
        *channels.entry(name).or_default() += 1;
        let is_ref = opts.reference.as_deref() == Some(name);
        let is_cmd = opts.command.as_deref() == Some(name);
        if !(is_ref || is_cmd) {
            continue;
        }
        if fields.len() < 4 {
            diags.push(Diagnostic::at(
                path,
                line,
                1,
                "expected `NAME date time value`",
            ));
            continue;
        }
        let Some(t) = timestamp(fields[1].1, fields[2].1) else {
            diags.push(Diagnostic::at(
                path,
                line,
                fields[1].0,
                "expected a time stamp `YYYY-MM-DD HH:MM:SS.ffffff`",
            ));
            continue;
        };
        let Some(v) = fields[3].1.parse::<f64>().ok().filter(|v| v.is_finite()) else {
            diags.push(Diagnostic::at(
                path,
                line,
                fields[3].0,
                format!("`{}` is not a number", fields[3].1),
            ));
            continue;
        };
        let s = Sample {
            t,
            v,
            line,
            col: fields[3].0,
        };
        if is_ref {
            refs.push(Sample {
                v: opts.gain * v + opts.offset,
                ..s
            });
        } else {
            cmds.push(s);
        }
    }
    let names = || channels.keys().copied().collect::<Vec<_>>().join(", ");
    for (given, what, flag, got) in [
        (&opts.reference, "reference", "--ref-channel", refs.len()),
        (&opts.command, "command", "--cmd-channel", cmds.len()),
    ] {
        match given {
            None => diags.push(Diagnostic::whole(
                path,
                format!(
                    "name the {what} channel of the log ({flag}); channels in the log: {}",
                    names()
                ),
            )),
            Some(n) if got == 0 => diags.push(Diagnostic::whole(
                path,
                format!(
                    "the log has no sample of the {what} channel `{n}`; channels in the log: {}",
                    names()
                ),
            )),
            _ => {}
        }
    }
    diags.into_result(())?;
    refs.sort_by(|a, b| a.t.total_cmp(&b.t));
    cmds.sort_by(|a, b| a.t.total_cmp(&b.t));
    cmds.dedup_by(|b, a| same(a.v, b.v)); // a command sent again is the same move
    let mut moves = Vec::with_capacity(cmds.len());
    let mut before = refs.partition_point(|r| r.t < cmds[0].t);
    let dropped_before = before;
    for (k, c) in cmds.iter().enumerate() {
        let end = cmds
            .get(k + 1)
            .map(|n| refs.partition_point(|r| r.t < n.t))
            .unwrap_or(refs.len());
        moves.push(Move {
            command_mm: c.v,
            line: c.line,
            col: c.col,
            up: (k > 0).then(|| c.v > cmds[k - 1].v),
            reference_mm: refs[before..end].iter().map(|r| r.v).collect(),
        });
        before = end;
    }
    let mut notes = vec![format!(
        "reference = {} × {} + {} mm; commands from {}",
        fmt_f64(opts.gain),
        opts.reference.as_deref().unwrap_or(""),
        fmt_f64(opts.offset),
        opts.command.as_deref().unwrap_or("")
    )];
    if dropped_before > 0 {
        notes.push(format!(
            "dropped {dropped_before} reference samples taken before the first command"
        ));
    }
    approaches(path, &moves, opts, last_line, notes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_days_known_dates() {
        assert_eq!(days_from_civil(1970, 1, 1), 0);
        assert_eq!(days_from_civil(2000, 3, 1), 11_017);
        assert_eq!(days_from_civil(2022, 4, 6), 19_088);
    }

    #[test]
    fn trailing_dwell_stops_at_motion() {
        assert_eq!(
            trailing_dwell(&[0.0, 0.5, 1.0, 1.0005, 1.001, 1.0008], 0.002),
            4
        );
        assert_eq!(trailing_dwell(&[], 0.002), 0);
    }
}
