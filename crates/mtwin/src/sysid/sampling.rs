//! Checks of the time column of logged data: strictly increasing, evenly sampled.

use crate::io::{Diagnostics, Table};
use crate::limits::fmt_message_number;

/// Relative tolerance on a sample interval: text files round times, and a
/// logger's clock jitters a little; a missing or doubled sample is far outside.
pub(crate) const PERIOD_TOLERANCE: f64 = 0.01;

/// The median of the positive intervals between successive `times`, if any.
///
/// The median is rounded to 9 significant digits: the difference of two
/// decimal times carries binary rounding noise (0.003 − 0.002 is
/// 0.0010000000000000002), which would otherwise show in every file and
/// message that prints the period (`ts = 0.0010000000000000009`).
pub(crate) fn median_interval(times: &[f64]) -> Option<f64> {
    median_positive(times.windows(2).map(|w| w[1] - w[0]).collect())
        .map(|d| format!("{d:.8e}").parse().unwrap_or(d))
}

/// The median of the positive values of `d`, if any.
pub(crate) fn median_positive(mut d: Vec<f64>) -> Option<f64> {
    d.retain(|v| *v > 0.0);
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    Some(d[d.len() / 2])
}

/// Report, at the line of the offending row, every time that does not
/// increase and every interval that differs from `period` by more than
/// [`PERIOD_TOLERANCE`]. `rows[i]` is the table row of `times[i]`; `unit`
/// names the time unit in messages; `within` says what the series is
/// ("run `a`, z = -50 mm"), empty for a whole file.
pub(crate) fn check_sampling(
    table: &Table,
    rows: &[usize],
    times: &[f64],
    period: f64,
    unit: &str,
    within: &str,
    diags: &mut Diagnostics,
) {
    let ctx = if within.is_empty() {
        String::new()
    } else {
        format!(" within {within}")
    };
    for i in 1..times.len() {
        let dt = times[i] - times[i - 1];
        if dt <= 0.0 {
            diags.push(table.row_error(
                rows[i],
                format!(
                    "time {} {unit} does not increase{ctx} (the previous sample, line {}, is at {} {unit})",
                    fmt_message_number(times[i]),
                    table.line(rows[i - 1]),
                    fmt_message_number(times[i - 1])
                ),
            ));
        } else if (dt - period).abs() > PERIOD_TOLERANCE * period {
            diags.push(table.row_error(
                rows[i],
                format!(
                    "uneven sampling{ctx}: {} {unit} since the previous sample (line {}), but the \
                     sample period is {} {unit}; every interval must be equal",
                    fmt_message_number(dt),
                    table.line(rows[i - 1]),
                    fmt_message_number(period)
                ),
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_period_of_decimal_times_prints_as_written() {
        let t: Vec<f64> = (0..1000).map(|k| 10.0 + f64::from(k) * 0.001).collect();
        let ts = median_interval(&t).unwrap();
        assert_eq!(ts, 0.001);
        assert_eq!(crate::io::fmt_f64(ts), "0.001");
        assert_eq!(
            median_interval(&[0.0, 1.0 / 3.0, 2.0 / 3.0]),
            Some(0.333333333)
        );
    }
}
