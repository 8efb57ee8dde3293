//! Temperatures read over an ambient sensor, and the choice of that sensor
//! from a log (the rise least correlated with the spindle speed).

use super::read::{is_missing, time_minutes};
use super::spec::InputSpec;
use crate::io::{Diagnostic, Diagnostics, Table};
use serde::{Deserialize, Serialize};

/// The inputs with every temperature but `ambient` taken over `ambient`:
/// each input that is a rise (not squared, not already over another
/// column) other than `ambient` itself becomes `COLUMN:over=AMBIENT`;
/// `ambient` stays as its own rise, the levels (speed, …) as they are.
///
/// # Errors
/// `ambient` is not one of the inputs' rises.
pub fn inputs_over_ambient(inputs: &[InputSpec], ambient: &str) -> Result<Vec<InputSpec>, String> {
    let is_candidate = |i: &InputSpec| i.rise && !i.square && i.over.is_none();
    if !inputs
        .iter()
        .any(|i| i.column == ambient && is_candidate(i))
    {
        return Err(format!(
            "the ambient sensor `{ambient}` must be one of the inputs, as a rise (e.g. a column ending in _c)"
        ));
    }
    let over: Vec<InputSpec> = inputs
        .iter()
        .map(|i| {
            if is_candidate(i) && i.column != ambient {
                InputSpec {
                    over: Some(ambient.to_string()),
                    ..i.clone()
                }
            } else {
                i.clone()
            }
        })
        .collect();
    let names: Vec<String> = over.iter().map(InputSpec::name).collect();
    for (k, n) in names.iter().enumerate() {
        if names[..k].contains(n) {
            return Err(format!(
                "`{n}` would be offered twice: it is among the inputs, and taking the temperatures over `{ambient}` makes it again"
            ));
        }
    }
    Ok(over)
}

/// How the ambient sensor was chosen ([`least_correlated_rise`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct AmbientChoice {
    /// The chosen column.
    pub column: String,
    /// The level input it was compared with (the first input that is
    /// neither a rise nor squared, e.g. the spindle speed).
    pub against: String,
    /// |Pearson correlation| of every candidate with `against` over the
    /// rows used, in the inputs' order (0 for a constant column).
    pub correlations: Vec<(String, f64)>,
    /// Rows the correlations were computed over.
    pub rows: usize,
}

/// The ambient sensor a log suggests: among the inputs that are rises (not
/// squared, not over another column), the one whose raw values are least
/// correlated (smallest |Pearson r|) with the first level input (the
/// spindle speed), over the table's rows before `until_min` (minutes from
/// its first row; all rows when `None`). A row with either cell missing is
/// left out of that pair. Ties go to the earlier input.
///
/// # Errors
/// No level input, fewer than two rises, a missing column or time column,
/// a bad cell (at its line).
pub fn least_correlated_rise(
    table: &Table,
    inputs: &[InputSpec],
    until_min: Option<f64>,
) -> Result<AmbientChoice, Diagnostics> {
    let path = table.path();
    let whole = |m: String| -> Diagnostics { Diagnostic::whole(path, m).into() };
    let Some(against) = inputs
        .iter()
        .find(|i| !i.rise && !i.square && i.over.is_none())
    else {
        return Err(whole(
            "choosing the ambient sensor needs a level input to compare with (the spindle speed, e.g. speed_rpm)"
                .into(),
        ));
    };
    let candidates: Vec<&InputSpec> = inputs
        .iter()
        .filter(|i| i.rise && !i.square && i.over.is_none())
        .collect();
    if candidates.len() < 2 {
        return Err(whole(
            "choosing the ambient sensor needs at least two temperatures (rises) among the inputs"
                .into(),
        ));
    }
    let times = time_minutes(table)?;
    let start = times[0];
    let rows: Vec<usize> = (0..table.len())
        .filter(|&r| until_min.is_none_or(|u| times[r] - start < u))
        .collect();
    let mut names: Vec<&str> = vec![against.column.as_str()];
    names.extend(candidates.iter().map(|c| c.column.as_str()));
    let cols = table.require(&names)?;
    let value = |r: usize, c: crate::io::Column| -> Result<Option<f64>, Diagnostics> {
        if is_missing(table.text(r, c)) {
            Ok(None)
        } else {
            table.number(r, c).map(Some).map_err(Diagnostics::from)
        }
    };
    let mut correlations = Vec::with_capacity(candidates.len());
    for (spec, &c) in candidates.iter().zip(&cols[1..]) {
        let mut pairs = Vec::with_capacity(rows.len());
        for &r in &rows {
            if let (Some(a), Some(b)) = (value(r, c)?, value(r, cols[0])?) {
                pairs.push((a, b));
            }
        }
        let n = pairs.len() as f64;
        let (ma, mb) = pairs
            .iter()
            .fold((0.0, 0.0), |(x, y), (a, b)| (x + a / n, y + b / n));
        let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
        for (a, b) in &pairs {
            let (a, b) = (a - ma, b - mb);
            sab += a * b;
            saa += a * a;
            sbb += b * b;
        }
        let r = (sab / (saa * sbb).sqrt()).abs();
        correlations.push((spec.column.clone(), if r.is_finite() { r } else { 0.0 }));
    }
    let best = correlations
        .iter()
        .enumerate()
        .min_by(|(i, a), (j, b)| a.1.total_cmp(&b.1).then(i.cmp(j)))
        .map(|(i, _)| i)
        .unwrap_or(0);
    Ok(AmbientChoice {
        column: correlations[best].0.clone(),
        against: against.column.clone(),
        correlations,
        rows: rows.len(),
    })
}
