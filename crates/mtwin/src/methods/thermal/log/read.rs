//! Reading a wide log and averaging it onto the model's sample grid.

use super::spec::{ChannelSpec, InputSpec};
use crate::io::{Diagnostic, Diagnostics, Table};
use std::path::PathBuf;

/// A log averaged onto the sample grid.
#[derive(Debug, Clone, PartialEq)]
pub struct LogData {
    /// The file it came from.
    pub path: PathBuf,
    /// Sample period, min.
    pub period_min: f64,
    /// Time of the log's first row in the file's time column (as min).
    pub start_min: f64,
    /// Bin means per channel, in the channel's unit, as read (not yet since the start).
    pub channels: Vec<Vec<f64>>,
    /// Bin means per input, as read.
    pub inputs: Vec<Vec<f64>>,
    /// Raw rows: time since the start (min) and each channel's value (its unit; NaN where missing).
    pub raw: Vec<(f64, Vec<f64>)>,
    /// Notes for the user (missing cells skipped, a dropped partial last bin, …).
    pub notes: Vec<String>,
}

impl LogData {
    /// Number of samples on the grid.
    pub fn len(&self) -> usize {
        self.inputs
            .first()
            .or(self.channels.first())
            .map_or(0, Vec::len)
    }

    /// True without samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

pub(super) fn is_missing(text: &str) -> bool {
    let t = text.trim();
    t.is_empty() || t.eq_ignore_ascii_case("nan") || t.eq_ignore_ascii_case("na")
}

/// The time column of a wide log (`t_s` or `t_min`), in minutes as written
/// (not yet from the first row), checked to increase row by row.
pub(super) fn time_minutes(table: &Table) -> Result<Vec<f64>, Diagnostics> {
    let path = table.path();
    use crate::io::columns::{T_MIN, T_S};
    let (time_col, to_min) = match (table.column(T_S), table.column(T_MIN)) {
        (Some(_), Some(_)) => {
            return Err(Diagnostic::at_line(
                path,
                table.header_line(),
                "both `t_s` and `t_min` are given: keep one time column",
            )
            .into());
        }
        (Some(c), None) => (c, 1.0 / 60.0),
        (None, Some(c)) => (c, 1.0),
        (None, None) => {
            return Err(Diagnostic::at_line(
                path,
                table.header_line(),
                "no time column: name it `t_s` (seconds) or `t_min` (minutes)",
            )
            .into());
        }
    };
    if table.is_empty() {
        return Err(
            Diagnostic::at_line(path, table.header_line(), "the file has no data rows").into(),
        );
    }
    let mut diags = Diagnostics::default();
    let mut times = Vec::with_capacity(table.len());
    for r in 0..table.len() {
        match table.number(r, time_col) {
            Ok(t) => {
                let t = t * to_min;
                if let Some(&prev) = times.last()
                    && t <= prev
                {
                    diags.push(table.row_error(
                        r,
                        format!(
                            "the time does not increase ({} min after {} min)",
                            crate::limits::fmt_message_number(t),
                            crate::limits::fmt_message_number(prev)
                        ),
                    ));
                }
                times.push(t);
            }
            Err(d) => {
                diags.push(d);
                times.push(f64::NAN);
            }
        }
        if diags.0.len() > 20 {
            break;
        }
    }
    if !diags.is_empty() {
        return Err(diags);
    }
    Ok(times)
}

/// Read a wide log: the time column (`t_s` or `t_min`), the `channels` and
/// the `inputs`, averaged over bins of `period_min` from the first row.
///
/// Errors at their line: a missing column, a cell that is neither a number
/// nor missing, a time that does not increase, a gap longer than the
/// period (no row in a whole bin), a bin without any value of a column.
pub fn read_log(
    table: &Table,
    channels: &[ChannelSpec],
    inputs: &[InputSpec],
    period_min: f64,
) -> Result<LogData, Diagnostics> {
    let path = table.path();
    if !(period_min.is_finite() && period_min > 0.0) {
        return Err(Diagnostic::whole(
            path,
            format!("the model period must be > 0 min, not {period_min}"),
        )
        .into());
    }
    // The value of an input per row: its column, minus its reference's
    // with `over` (the difference is taken row by row, then averaged).
    let mut names: Vec<&str> = channels.iter().map(|c| c.column.as_str()).collect();
    names.extend(inputs.iter().map(|c| c.column.as_str()));
    let times = time_minutes(table)?;
    let cols = table.require(&names)?;
    let overs: Vec<&str> = inputs.iter().filter_map(|c| c.over.as_deref()).collect();
    let over_cols = table.require(&overs)?;
    let mut over_cols = over_cols.into_iter();
    let over_of: Vec<Option<crate::io::Column>> = channels
        .iter()
        .map(|_| None)
        .chain(
            inputs
                .iter()
                .map(|c| c.over.as_ref().and_then(|_| over_cols.next())),
        )
        .collect();
    // What messages call each series: a channel's column, an input's name.
    let labels: Vec<String> = channels
        .iter()
        .map(|c| c.column.clone())
        .chain(inputs.iter().map(InputSpec::name))
        .collect();
    let mut diags = Diagnostics::default();
    let start = times[0];
    let span = ((times[times.len() - 1] - start) / period_min).floor() + 1.0;
    let bins = span as usize;
    if span > crate::limits::MAX_SAMPLES as f64 {
        return Err(Diagnostic::whole(
            path,
            format!(
                "the log spans {bins} periods of {period_min} min, above the limit of {} samples: use a longer period",
                crate::limits::MAX_SAMPLES
            ),
        )
        .into());
    }
    let mut sums = vec![vec![0.0; bins]; cols.len()];
    let mut counts = vec![vec![0usize; bins]; cols.len()];
    let mut rows_in = vec![0usize; bins];
    let mut first_row = vec![usize::MAX; bins];
    let mut missing = vec![0usize; cols.len()];
    let mut raw = Vec::with_capacity(table.len());
    for (r, &t) in times.iter().enumerate() {
        let k = (((t - start) / period_min).floor() as usize).min(bins - 1);
        rows_in[k] += 1;
        first_row[k] = first_row[k].min(r);
        let mut raw_values = Vec::with_capacity(channels.len());
        for (j, &c) in cols.iter().enumerate() {
            let mut cell = |c: crate::io::Column| {
                let text = table.text(r, c);
                if is_missing(text) {
                    None
                } else {
                    match table.number(r, c) {
                        Ok(v) => Some(v),
                        Err(d) => {
                            diags.push(d);
                            Some(f64::NAN)
                        }
                    }
                }
            };
            let v = match (cell(c), over_of[j].map(&mut cell)) {
                (Some(v), None) => Some(v),
                (Some(v), Some(Some(o))) => Some(v - o),
                _ => None,
            };
            let v = match v {
                None => {
                    missing[j] += 1;
                    f64::NAN
                }
                Some(v) => {
                    if v.is_finite() {
                        sums[j][k] += v;
                        counts[j][k] += 1;
                    }
                    v
                }
            };
            if j < channels.len() {
                raw_values.push(v);
            }
        }
        raw.push((t - start, raw_values));
    }
    let mut notes = Vec::new();
    if start != 0.0 {
        notes.push(format!(
            "the log starts at t = {} min: times are counted from its first row (the start, taken as cold)",
            crate::limits::fmt_message_number(start)
        ));
    }
    // Gaps: a bin without rows.
    let mut prev_row = 0;
    for k in 0..bins {
        if rows_in[k] == 0 {
            let next = (k + 1..bins)
                .find(|&j| rows_in[j] > 0)
                .map(|j| first_row[j]);
            let r = next.unwrap_or(prev_row);
            diags.push(table.row_error(
                r,
                format!(
                    "no row between t = {} and {} min before this line: the gap is longer than the period of {} min \
                     (use a longer period, or split the log where the machine was off the record)",
                    crate::limits::fmt_message_number(times[prev_row] - start),
                    crate::limits::fmt_message_number(times[r] - start),
                    crate::limits::fmt_message_number(period_min)
                ),
            ));
            break;
        }
        prev_row = first_row[k];
    }
    if diags.is_empty() {
        'outer: for (j, name) in labels.iter().enumerate() {
            for k in 0..bins {
                if counts[j][k] == 0 {
                    diags.push(table.cell_error(
                        first_row[k],
                        cols[j],
                        format!(
                            "`{name}` has no value in the period from t = {} min (every cell missing)",
                            crate::limits::fmt_message_number(k as f64 * period_min)
                        ),
                    ));
                    continue 'outer;
                }
            }
        }
    }
    if !diags.is_empty() {
        return Err(diags);
    }
    for (j, name) in labels.iter().enumerate() {
        if missing[j] > 0 {
            notes.push(format!(
                "`{name}`: {} missing cells left out of the period means",
                missing[j]
            ));
        }
    }
    // A last bin much shorter than the others is dropped.
    let mut used = bins;
    if bins > 1 {
        let mut sorted = rows_in.clone();
        sorted.sort_unstable();
        let median = sorted[bins / 2];
        if 2 * rows_in[bins - 1] < median {
            used = bins - 1;
            notes.push(format!(
                "the last {} rows cover less than half a period: left out",
                rows_in[bins - 1]
            ));
        }
    }
    let means: Vec<Vec<f64>> = sums
        .iter()
        .zip(&counts)
        .map(|(s, c)| {
            s.iter()
                .zip(c)
                .take(used)
                .map(|(s, &c)| s / c as f64)
                .collect()
        })
        .collect();
    let (ch, inp) = means.split_at(channels.len());
    Ok(LogData {
        path: path.to_path_buf(),
        period_min,
        start_min: start,
        channels: ch.to_vec(),
        inputs: inp.to_vec(),
        raw,
        notes,
    })
}
