//! One report section per kind of result. Each builder takes the typed
//! document the corresponding command prints with `--format json` (e.g.
//! [`crate::methods::ballbar::BallbarIdentifyDoc`]), a model file or a CSV, so
//! `mtwin report` (documents read back from saved files) and `mtwin demo`
//! (documents in memory) build the same sections through the same functions.

pub mod ballbar;
pub mod circular;
pub mod compensate;
pub mod machine;
pub mod positioning;
pub mod servo;
pub mod skiving;
pub mod thermal;
pub mod tracker;
pub mod twin;

/// `mtwin report --format json`: the HTML file written and what it holds.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReportDoc {
    /// Figures in the report.
    pub figures: usize,
    /// The HTML file written.
    pub out: String,
    /// Sections in the report.
    pub sections: usize,
}

impl std::fmt::Display for ReportDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "report → {}", self.out)
    }
}

/// A result that cannot be read into a section.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum ReportError {
    /// Anything else wrong with an input.
    #[error("{what}: {message}")]
    Input {
        /// The input (file or document).
        what: String,
        /// What is wrong with it.
        message: String,
    },
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
    fn the_report_document_round_trips() {
        let d = ReportDoc {
            figures: 3,
            out: "r.html".into(),
            sections: 2,
        };
        let back: ReportDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        assert_eq!(d.to_string(), "report → r.html\n");
    }

    #[test]
    fn numbers_use_a_true_minus_and_no_negative_zero() {
        assert_eq!(fmt(Some(-1.26), 1), "−1.3");
        assert_eq!(fmt(Some(-0.0001), 2), "0.00");
        assert_eq!(fmt(None, 2), "—");
        assert_eq!(fmt(Some(f64::NAN), 2), "—");
    }
}
