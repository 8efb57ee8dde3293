//! Thermal section (\[R4\]): the fitted drift model (`THERMAL.toml`) as a
//! table per height, and drift curves over time — e.g. the rows of
//! `mtwin thermal predict` (`t_min,z_mm,drift_mm`), or drift with and without
//! compensation.

use super::{COLORS, decimate, fmt};
use crate::methods::thermal::ThermalModel;
use crate::report::html::{Block, Section, Table, Verdict};
use crate::report::svg::{Series, xy};

/// One drift curve: `(t_min, drift_mm)` points.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftCurve {
    /// Legend name.
    pub name: String,
    /// `(t_min, drift_mm)` points: time in minutes, drift in mm.
    pub points: Vec<(f64, f64)>,
}

/// One curve per height from `t_min,z_mm,drift_mm` rows (the rows of
/// `thermal predict`), heights in order of first appearance.
pub fn curves_from_rows(rows: &[[f64; 3]]) -> Vec<DriftCurve> {
    let mut out: Vec<(f64, DriftCurve)> = Vec::new();
    for r in rows {
        let k = match out.iter().position(|(z, _)| *z == r[1]) {
            Some(k) => k,
            None => {
                out.push((
                    r[1],
                    DriftCurve {
                        name: format!("z = {} mm", r[1]),
                        points: Vec::new(),
                    },
                ));
                out.len() - 1
            }
        };
        out[k].1.points.push((r[0], r[2]));
    }
    out.into_iter().map(|(_, c)| c).collect()
}

/// The thermal section: the model table and one chart of `curves` (µm over min).
pub fn section(model: &ThermalModel, curves: &[DriftCurve], chart_title: &str) -> Section {
    let mut s = Section::new("thermal", "Thermal drift in Z");
    s.push(Block::Text(format!(
        "ARX model of the Z drift driven by spindle speed, one per measured height, sample period {} min. \
         Drift = displacement of the tool relative to the workpiece in +Z.",
        model.period_min()
    )));
    let mut t = Table::new(
        "Model per height",
        &[
            "z (mm)",
            "orders",
            "one-step RMS (µm)",
            "simulation RMS (µm)",
            "spectral radius",
            "samples",
        ],
    );
    let mut unstable = Vec::new();
    for h in model.heights() {
        let st = h.stats.as_ref();
        if st.is_some_and(|s| s.spectral_radius >= 1.0) {
            unstable.push(h.z_mm);
        }
        t.row(vec![
            fmt(Some(h.z_mm), 1),
            h.model.orders().to_string(),
            fmt(st.map(|s| s.one_step_rms_mm * 1e3), 3),
            fmt(st.map(|s| s.simulation_rms_mm * 1e3), 3),
            fmt(st.map(|s| s.spectral_radius), 4),
            st.map_or("—".into(), |s| s.samples.to_string()),
        ]);
    }
    s.push(Block::Table(t));
    s.push(Block::Verdict {
        verdict: if unstable.is_empty() {
            Verdict::Good
        } else {
            Verdict::Bad
        },
        title: if unstable.is_empty() {
            "Every height model is stable (all poles inside the unit circle).".into()
        } else {
            "Unstable height models: do not use them to predict.".into()
        },
        lines: unstable.iter().map(|z| format!("z = {z} mm")).collect(),
    });
    if !curves.is_empty() {
        let series: Vec<Series> = curves
            .iter()
            .enumerate()
            .map(|(k, c)| Series {
                name: c.name.clone(),
                points: decimate(
                    &c.points
                        .iter()
                        .map(|&(t, d)| (t, d * 1e3))
                        .collect::<Vec<_>>(),
                    2000,
                ),
                color: COLORS[k % COLORS.len()].into(),
                markers: false,
            })
            .collect();
        s.push(Block::Figure {
            caption: format!("{chart_title} (µm over min)."),
            svg: xy(chart_title, "t (min)", "drift (µm)", &series),
        });
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_grouped_by_height_in_order() {
        let rows = [
            [0.0, -100.0, 0.0],
            [0.0, -300.0, 0.0],
            [10.0, -100.0, 0.001],
            [10.0, -300.0, 0.002],
        ];
        let c = curves_from_rows(&rows);
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].name, "z = -100 mm");
        assert_eq!(c[1].points, vec![(0.0, 0.0), (10.0, 0.002)]);
    }
}
