//! One report section per kind of result. Each builder takes what the
//! corresponding command writes — its `--format json` document, a model file
//! or a CSV — so `mtwin report` (from saved files) and `mtwin demo` (from
//! in-memory results) build the same sections through the same functions.

pub mod ballbar;
pub mod compensate;
pub mod machine;
pub mod servo;
pub mod skiving;
pub mod thermal;
pub mod tracker;
pub mod twin;

use serde_json::Value;

/// A result that cannot be read into a section.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum ReportError {
    /// A field the section needs is missing or has the wrong type.
    #[error("{what}: `{field}` is missing or is not {expected}")]
    Field {
        what: String,
        field: String,
        expected: &'static str,
    },
    /// Anything else wrong with an input.
    #[error("{what}: {message}")]
    Input { what: String, message: String },
}

/// Typed access to a JSON result, with errors naming the input.
pub(crate) struct Json<'a> {
    pub v: &'a Value,
    pub what: &'a str,
}

impl<'a> Json<'a> {
    pub fn new(v: &'a Value, what: &'a str) -> Self {
        Json { v, what }
    }

    fn get(&self, path: &str) -> Option<&'a Value> {
        path.split('.').try_fold(self.v, |v, k| v.get(k))
    }

    fn err(&self, field: &str, expected: &'static str) -> ReportError {
        ReportError::Field {
            what: self.what.to_string(),
            field: field.to_string(),
            expected,
        }
    }

    /// A required number.
    pub fn num(&self, path: &str) -> Result<f64, ReportError> {
        self.get(path)
            .and_then(Value::as_f64)
            .ok_or_else(|| self.err(path, "a number"))
    }

    /// A number that may be absent or null.
    pub fn opt_num(&self, path: &str) -> Option<f64> {
        self.get(path).and_then(Value::as_f64)
    }

    /// A required array.
    pub fn arr(&self, path: &str) -> Result<&'a Vec<Value>, ReportError> {
        self.get(path)
            .and_then(Value::as_array)
            .ok_or_else(|| self.err(path, "an array"))
    }

    /// An array that may be absent (empty then).
    pub fn opt_arr(&self, path: &str) -> &'a [Value] {
        self.get(path)
            .and_then(Value::as_array)
            .map_or(&[], |v| v.as_slice())
    }

    /// Strings of an array that may be absent.
    pub fn strings(&self, path: &str) -> Vec<String> {
        self.opt_arr(path)
            .iter()
            .map(|v| match v {
                Value::String(s) => s.clone(),
                other => other.to_string(),
            })
            .collect()
    }
}

/// `v` with `decimals` decimals, a true minus sign, `—` for none.
pub fn fmt(v: Option<f64>, decimals: usize) -> String {
    match v {
        Some(v) if v.is_finite() => {
            let s = format!("{v:.decimals$}");
            let s = if s
                .trim_start_matches('-')
                .chars()
                .all(|c| c == '0' || c == '.')
            {
                s.trim_start_matches('-').to_string()
            } else {
                s
            };
            s.replacen('-', "−", 1)
        }
        _ => "—".into(),
    }
}

/// At most about `max` points of a curve, keeping the smallest and largest
/// value of every bucket so that peaks survive.
pub fn decimate(points: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max < 4 {
        return points.to_vec();
    }
    let bucket = points.len().div_ceil(max / 2);
    let mut out = Vec::with_capacity(max + 2);
    for chunk in points.chunks(bucket) {
        let (mut lo, mut hi) = (0, 0);
        for (k, p) in chunk.iter().enumerate() {
            if p.1 < chunk[lo].1 {
                lo = k;
            }
            if p.1 > chunk[hi].1 {
                hi = k;
            }
        }
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push(chunk[a]);
        if b != a {
            out.push(chunk[b]);
        }
    }
    out
}

/// Colours of the series, in order.
pub const COLORS: [&str; 6] = [
    "#c0392b", "#2471a3", "#27ae60", "#8e44ad", "#d68910", "#17202a",
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_the_extremes() {
        let pts: Vec<(f64, f64)> = (0..10_000)
            .map(|k| {
                (
                    k as f64,
                    if k == 4321 {
                        9.0
                    } else if k == 777 {
                        -3.0
                    } else {
                        (k as f64).sin()
                    },
                )
            })
            .collect();
        let d = decimate(&pts, 500);
        assert!(d.len() <= 502, "{}", d.len());
        assert!(d.contains(&(4321.0, 9.0)));
        assert!(d.contains(&(777.0, -3.0)));
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
    }

    #[test]
    fn numbers_use_a_true_minus_and_no_negative_zero() {
        assert_eq!(fmt(Some(-1.26), 1), "−1.3");
        assert_eq!(fmt(Some(-0.0001), 2), "0.00");
        assert_eq!(fmt(None, 2), "—");
        assert_eq!(fmt(Some(f64::NAN), 2), "—");
    }

    #[test]
    fn missing_fields_name_the_input() {
        let v = serde_json::json!({"a": {"b": 1.5}});
        let j = Json::new(&v, "r.json");
        assert_eq!(j.num("a.b"), Ok(1.5));
        let e = j.num("a.c").unwrap_err().to_string();
        assert!(e.contains("r.json") && e.contains("a.c"), "{e}");
    }
}
