//! Machine section: the geometric errors of a machine model (typically an
//! identified one) — location errors as a table, and every PDGE drawn over its
//! axis' travel (translations in µm, rotations in µrad), optionally beside
//! the curves of a known truth (a simulation's error model).

use super::{COLORS, fmt};
use crate::model::{Component, Machine};
use crate::report::html::{Block, Section, Table};
use crate::report::svg::{Series, xy};

/// Points per PDGE curve.
const CURVE_POINTS: usize = 101;

/// Colour of the truth curves.
const TRUTH_COLOR: &str = "#999999";

/// The section of machine `m`; `id` is its anchor, `title` its heading.
pub fn section(m: &Machine, id: &str, title: &str) -> Section {
    section_against(m, None, id, title)
}

/// [`section`] with the PDGE curves of `truth` (same axis names) drawn in grey
/// beside those of `m`, for an identified model whose truth is known.
pub fn section_against(m: &Machine, truth: Option<&Machine>, id: &str, title: &str) -> Section {
    let mut s = Section::new(id, title);
    s.push(Block::Text(format!(
        "Machine `{}`: {} axes, {} geometric error terms.",
        m.name,
        m.n_axes(),
        m.n_error_terms()
    )));
    if truth.is_some() {
        s.push(Block::Text(
            "Grey curves: the truth the data were simulated from. Error terms that the \
             measurements cannot tell apart (see the identifiability verdict) are \
             gauge-fixed: the parts the data do not see are pulled to 0 (the \
             minimum-norm solution) and the determined combinations shared among the \
             group. Such a curve can still differ from the truth by a constant or a \
             trend that another term makes up for, while the predicted tool tip \
             agrees (see the validation)."
                .into(),
        ));
    }
    let mut t = Table::new(
        "Location errors (constant)",
        &["axis", "error", "value", "unit"],
    );
    for a in &m.axes {
        for c in Component::ALL {
            let v = a.errors.location[c.index()];
            if v != 0.0 {
                let (f, unit) = if c.is_rotation() {
                    (1e6, "µrad")
                } else {
                    (1e3, "µm")
                };
                t.row(vec![
                    a.name.clone(),
                    format!("E{}0{}", c.letter(), a.name),
                    fmt(Some(v * f), 3),
                    unit.into(),
                ]);
            }
        }
    }
    if t.rows.is_empty() {
        s.push(Block::Text("No location errors.".into()));
    } else {
        s.push(Block::Table(t));
    }
    for a in &m.axes {
        let true_axis = truth.and_then(|t| t.axis_index(&a.name).map(|i| &t.axes[i]));
        if !a.errors.has_pdge() && !true_axis.is_some_and(|t| t.errors.has_pdge()) {
            continue;
        }
        let unit = a.kind.unit();
        for rot in [false, true] {
            let scale = if rot { 1e6 } else { 1e3 };
            let curve = |a: &crate::model::Axis, c: Component| -> Vec<(f64, f64)> {
                (0..CURVE_POINTS)
                    .map(|i| {
                        let q = a.travel[0]
                            + (a.travel[1] - a.travel[0]) * i as f64 / (CURVE_POINTS - 1) as f64;
                        (q, a.pdge_at(c, q) * scale)
                    })
                    .collect()
            };
            let mut series: Vec<Series> = Vec::new();
            let shown = Component::ALL
                .iter()
                .filter(|c| c.is_rotation() == rot)
                .filter(|c| {
                    let has = |a: &crate::model::Axis| {
                        a.errors.pdge[c.index()]
                            .as_ref()
                            .is_some_and(|f| !f.is_zero())
                    };
                    has(a) || true_axis.is_some_and(has)
                });
            for (k, &c) in shown.enumerate() {
                let name = format!("E{}{}", c.letter(), a.name);
                if let Some(t) = true_axis {
                    series.push(Series {
                        name: format!("{name} truth"),
                        points: curve(t, c),
                        color: TRUTH_COLOR.into(),
                        markers: false,
                    });
                }
                series.push(Series {
                    name,
                    points: curve(a, c),
                    color: COLORS[k % COLORS.len()].into(),
                    markers: false,
                });
            }
            if series.is_empty() {
                continue;
            }
            let (what, yl) = if rot {
                ("rotations", "error (µrad)")
            } else {
                ("translations", "error (µm)")
            };
            s.push(Block::Figure {
                caption: format!(
                    "Position-dependent {what} of axis {} over its travel ({unit}).",
                    a.name
                ),
                svg: xy(
                    &format!("{} axis: PDGE {what}", a.name),
                    &format!("{} ({unit})", a.name),
                    yl,
                    &series,
                ),
            });
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_machine;
    use std::path::Path;

    #[test]
    fn every_pdge_axis_gets_its_curves_and_locations_their_rows() {
        let text = include_str!("../../../../../examples/machines/ac-trunnion-with-errors.toml");
        let m = parse_machine(Path::new("m.toml"), text).unwrap();
        let s = section(&m, "machine", "M");
        let pdge_axes = m.axes.iter().filter(|a| a.errors.has_pdge()).count();
        assert!(pdge_axes > 0);
        assert!(s.figures() >= pdge_axes);
        let n_loc = m
            .axes
            .iter()
            .flat_map(|a| a.errors.location.iter())
            .filter(|v| **v != 0.0)
            .count();
        let rows = s
            .blocks
            .iter()
            .find_map(|b| match b {
                Block::Table(t) => Some(t.rows.len()),
                _ => None,
            })
            .unwrap_or(0);
        assert_eq!(rows, n_loc);
    }

    #[test]
    fn truth_curves_are_drawn_beside_the_model() {
        let text = include_str!("../../../../../examples/machines/ac-trunnion-with-errors.toml");
        let truth = parse_machine(Path::new("t.toml"), text).unwrap();
        let nominal = include_str!("../../../../../examples/machines/ac-trunnion.toml");
        let m = parse_machine(Path::new("m.toml"), nominal).unwrap();
        // A model without PDGEs still shows the truth's curves, one grey and one
        // coloured line per error.
        let with = section_against(&m, Some(&truth), "id", "T");
        let without = section(&truth, "id", "T");
        assert_eq!(with.figures(), without.figures());
        let grey: usize = with
            .blocks
            .iter()
            .filter_map(|b| match b {
                Block::Figure { svg, .. } => Some(svg.matches(TRUTH_COLOR).count()),
                _ => None,
            })
            .sum();
        let pdges: usize = truth
            .axes
            .iter()
            .map(|a| {
                a.errors
                    .pdge
                    .iter()
                    .filter(|f| f.as_ref().is_some_and(|f| !f.is_zero()))
                    .count()
            })
            .sum();
        // Each grey series appears twice: its line and its legend swatch.
        assert_eq!(grey, 2 * pdges);
    }
}
