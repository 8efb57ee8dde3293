//! Digital-twin sections (\[R5\], docs/references.md): tool-tip and tool-axis trajectory errors
//! along the path, from the rows of `PRED.csv` (`t_s, x_cmd,y_cmd,z_cmd,
//! i_cmd,j_cmd,k_cmd, x,y,z, i,j,k, tip_error, axis_error`: command and
//! actual tool tip (mm) and tool axis in W, ε_p in mm, ε_o in rad).

use super::{COLORS, ReportError, decimate, fmt};
use crate::io::Table as CsvTable;
use crate::report::html::{Block, Headline, Section, Table};
use crate::report::svg::{Series, xy};

/// The columns of `PRED.csv`, in order (docs/twin.md).
pub const COLUMNS: [&str; 15] = [
    crate::io::columns::T_S,
    "x_cmd",
    "y_cmd",
    "z_cmd",
    "i_cmd",
    "j_cmd",
    "k_cmd",
    "x",
    "y",
    "z",
    "i",
    "j",
    "k",
    "tip_error",
    "axis_error",
];

/// One sample of a twin prediction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwinRow {
    /// Time, s.
    pub t_s: f64,
    /// Command tool tip in W, mm.
    pub tip_cmd: [f64; 3],
    /// Command tool axis in W (unit).
    pub axis_cmd: [f64; 3],
    /// Actual tool tip in W, mm.
    pub tip: [f64; 3],
    /// Actual tool axis in W (unit).
    pub axis: [f64; 3],
    /// ε_p, mm.
    pub tip_error: f64,
    /// ε_o, rad.
    pub axis_error: f64,
}

impl TwinRow {
    /// A row from the 15 numbers of a `PRED.csv` line, in [`COLUMNS`] order.
    pub fn from_values(v: &[f64; 15]) -> TwinRow {
        TwinRow {
            t_s: v[0],
            tip_cmd: [v[1], v[2], v[3]],
            axis_cmd: [v[4], v[5], v[6]],
            tip: [v[7], v[8], v[9]],
            axis: [v[10], v[11], v[12]],
            tip_error: v[13],
            axis_error: v[14],
        }
    }
}

/// The rows of a `PRED.csv` table (columns found by name).
pub fn rows_from_table(t: &CsvTable) -> Result<Vec<TwinRow>, ReportError> {
    let rows = t.number_rows(&COLUMNS).map_err(|d| ReportError::Input {
        what: t.path().display().to_string(),
        message: d.to_string(),
    })?;
    Ok(rows
        .iter()
        .map(|r| {
            let mut v = [0.0; 15];
            v.copy_from_slice(&r[..15]);
            TwinRow::from_values(&v)
        })
        .collect())
}

/// Largest and RMS tip error (mm) and largest axis error (rad).
pub fn summary(rows: &[TwinRow]) -> (f64, f64, f64) {
    let n = rows.len().max(1) as f64;
    let tip_max = rows.iter().map(|r| r.tip_error).fold(0.0, f64::max);
    let tip_rms = (rows.iter().map(|r| r.tip_error * r.tip_error).sum::<f64>() / n).sqrt();
    let axis_max = rows.iter().map(|r| r.axis_error).fold(0.0, f64::max);
    (tip_max, tip_rms, axis_max)
}

fn along(rows: &[TwinRow], f: impl Fn(&TwinRow) -> f64) -> Vec<(f64, f64)> {
    decimate(
        &rows.iter().map(|r| (r.t_s, f(r))).collect::<Vec<_>>(),
        3000,
    )
}

/// A twin section from the rows of one prediction: summary table with the
/// source patent's \[R5\] figures, tip error and tool-axis error along the path, and the path
/// itself (command and actual tool tip in the XY plane of W).
pub fn section_from_rows(id: &str, title: &str, rows: &[TwinRow]) -> Section {
    let (tip_max, tip_rms, axis_max) = summary(rows);
    let mut s = Section::new(id, title);
    s.push(Block::Text(format!(
        "{} samples over {} s: the actual tool tip and tool axis (servo response and geometric errors) \
         against the command trajectory; ε_p is the distance to the nearest point of the command path, \
         ε_o the angle to the command tool axis there.",
        rows.len(),
        fmt(rows.last().map(|r| r.t_s - rows[0].t_s), 3)
    )));
    s.push(Block::Headlines(vec![
        Headline {
            label: "largest tool-tip error ε_p".into(),
            ours: format!("{} µm", fmt(Some(tip_max * 1e3), 1)),
            source: "−1.2…1.5 mm (S-shaped test piece)".into(),
        },
        Headline {
            label: "largest tool-axis error ε_o".into(),
            ours: format!("{} µrad", fmt(Some(axis_max * 1e6), 1)),
            source: "−4.5e-3…4e-3 rad".into(),
        },
    ]));
    let mut t = Table::new("Trajectory errors", &["quantity", "value", "unit"]);
    t.row(vec!["samples".into(), rows.len().to_string(), "".into()]);
    t.row(vec![
        "largest ε_p".into(),
        fmt(Some(tip_max * 1e3), 2),
        "µm".into(),
    ]);
    t.row(vec![
        "RMS ε_p".into(),
        fmt(Some(tip_rms * 1e3), 2),
        "µm".into(),
    ]);
    t.row(vec![
        "largest ε_o".into(),
        fmt(Some(axis_max * 1e6), 2),
        "µrad".into(),
    ]);
    s.push(Block::Table(t));
    s.push(Block::Figure {
        caption: "Tool-tip error ε_p along the path (µm over s).".into(),
        svg: xy(
            "Tool-tip error along the path",
            "t (s)",
            "ε_p (µm)",
            &[Series {
                name: "ε_p".into(),
                points: along(rows, |r| r.tip_error * 1e3),
                color: COLORS[0].into(),
                markers: false,
            }],
        ),
    });
    s.push(Block::Figure {
        caption: "Tool-axis error ε_o along the path (µrad over s).".into(),
        svg: xy(
            "Tool-axis error along the path",
            "t (s)",
            "ε_o (µrad)",
            &[Series {
                name: "ε_o".into(),
                points: along(rows, |r| r.axis_error * 1e6),
                color: COLORS[3].into(),
                markers: false,
            }],
        ),
    });
    let path = |f: fn(&TwinRow) -> (f64, f64)| {
        let step = (rows.len() / 3000).max(1);
        rows.iter().step_by(step).map(f).collect::<Vec<_>>()
    };
    s.push(Block::Figure {
        caption: "The tool-tip path in the XY plane of W: command and actual (mm).".into(),
        svg: xy(
            "Tool-tip path (XY of W)",
            "x (mm)",
            "y (mm)",
            &[
                Series {
                    name: "command".into(),
                    points: path(|r| (r.tip_cmd[0], r.tip_cmd[1])),
                    color: COLORS[5].into(),
                    markers: false,
                },
                Series {
                    name: "actual".into(),
                    points: path(|r| (r.tip[0], r.tip[1])),
                    color: COLORS[0].into(),
                    markers: false,
                },
            ],
        ),
    });
    s
}

/// Two predictions of the same program side by side — e.g. before and after
/// geometric compensation: ε_p of both along the path and their summaries.
pub fn comparison_section(
    id: &str,
    title: &str,
    before: (&str, &[TwinRow]),
    after: (&str, &[TwinRow]),
) -> Section {
    let (b, a) = (summary(before.1), summary(after.1));
    let mut s = Section::new(id, title);
    let mut t = Table::new(
        "Trajectory errors",
        &[
            "program",
            "largest ε_p (µm)",
            "RMS ε_p (µm)",
            "largest ε_o (µrad)",
        ],
    );
    for (name, v) in [(before.0, b), (after.0, a)] {
        t.row(vec![
            name.into(),
            fmt(Some(v.0 * 1e3), 2),
            fmt(Some(v.1 * 1e3), 2),
            fmt(Some(v.2 * 1e6), 2),
        ]);
    }
    s.push(Block::Table(t));
    s.push(Block::Figure {
        caption: format!(
            "ε_p along the path: {} and {} (µm over s).",
            before.0, after.0
        ),
        svg: xy(
            "Tool-tip error along the path",
            "t (s)",
            "ε_p (µm)",
            &[
                Series {
                    name: before.0.into(),
                    points: along(before.1, |r| r.tip_error * 1e3),
                    color: COLORS[0].into(),
                    markers: false,
                },
                Series {
                    name: after.0.into(),
                    points: along(after.1, |r| r.tip_error * 1e3),
                    color: COLORS[1].into(),
                    markers: false,
                },
            ],
        ),
    });
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn csv() -> String {
        let mut s = COLUMNS.join(",");
        s.push('\n');
        for k in 0..5 {
            let e = 0.001 * k as f64;
            s.push_str(&format!(
                "{},{k},0,0,0,0,1,{k},{e},0,0,0,1,{e},{}\n",
                k as f64 * 0.001,
                1e-6 * k as f64
            ));
        }
        s
    }

    #[test]
    fn rows_read_by_column_name_and_summarised() {
        let t = CsvTable::from_reader(Path::new("pred.csv"), csv().as_bytes()).unwrap();
        let rows = rows_from_table(&t).unwrap();
        assert_eq!(rows.len(), 5);
        assert_eq!(rows[4].tip, [4.0, 0.004, 0.0]);
        let (max, rms, axis) = summary(&rows);
        assert!((max - 0.004).abs() < 1e-15);
        // RMS of 0,1,2,3,4 µm = sqrt(30/5) µm.
        assert!((rms - 6f64.sqrt() * 1e-3).abs() < 1e-15);
        assert!((axis - 4e-6).abs() < 1e-18);
        let s = section_from_rows("twin", "Twin", &rows);
        assert_eq!(s.figures(), 3);
    }

    #[test]
    fn a_missing_column_is_named() {
        let t = CsvTable::from_reader(Path::new("pred.csv"), "t_s,x\n0,1\n".as_bytes()).unwrap();
        let e = rows_from_table(&t).unwrap_err().to_string();
        assert!(e.contains("x_cmd"), "{e}");
    }
}
