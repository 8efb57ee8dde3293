//! The ISO 230-2 picture: mean deviation against target position per
//! direction, the ±2s band of each, and the single readings.

use super::doc::PositioningDoc;
use crate::report::svg::{Series, xy};

/// SVG plot of `doc`: x̄↑ and x̄↓ (µm) against position (mm), x̄ ± 2s of each
/// direction as thin lines, every reading as a marker.
pub fn plot_svg(doc: &PositioningDoc) -> String {
    let rows = &doc.per_target;
    let line = |name: &str, color: &str, f: &dyn Fn(&super::TargetRow) -> f64| Series {
        name: name.to_string(),
        points: rows.iter().map(|t| (t.target_mm, f(t))).collect(),
        color: color.to_string(),
        markers: false,
    };
    let (cu, cd) = ("#1f77b4", "#d62728");
    let mut series = vec![
        line("mean up", cu, &|t| t.mean_up_um),
        line("mean up + 2s", cu, &|t| t.mean_up_um + 2.0 * t.s_up_um),
        line("mean up - 2s", cu, &|t| t.mean_up_um - 2.0 * t.s_up_um),
        line("mean down", cd, &|t| t.mean_down_um),
        line("mean down + 2s", cd, &|t| {
            t.mean_down_um + 2.0 * t.s_down_um
        }),
        line("mean down - 2s", cd, &|t| {
            t.mean_down_um - 2.0 * t.s_down_um
        }),
    ];
    for (name, color, up) in [("readings up", cu, true), ("readings down", cd, false)] {
        series.push(Series {
            name: name.to_string(),
            points: rows
                .iter()
                .flat_map(|t| {
                    let v = if up {
                        &t.deviations_up_um
                    } else {
                        &t.deviations_down_um
                    };
                    v.iter().map(move |d| (t.target_mm, *d))
                })
                .collect(),
            color: color.to_string(),
            markers: true,
        });
    }
    xy(
        &format!(
            "ISO 230-2 positioning: A = {:.1} µm, E = {:.1} µm, R = {:.1} µm, B = {:.1} µm",
            doc.a_um, doc.e_um, doc.r_um, doc.b_um
        ),
        "target position (mm)",
        "deviation (µm)",
        &series,
    )
}
