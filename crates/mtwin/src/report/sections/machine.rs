//! Machine section: the geometric errors of a machine model (typically an
//! identified one) — location errors as a table, and every PDGE drawn over its
//! axis' travel (translations in µm, rotations in µrad).

use super::{COLORS, fmt};
use crate::model::{Component, Machine};
use crate::report::html::{Block, Section, Table};
use crate::report::svg::{Series, xy};

/// Points per PDGE curve.
const CURVE_POINTS: usize = 101;

/// The section of machine `m`; `id` is its anchor, `title` its heading.
pub fn section(m: &Machine, id: &str, title: &str) -> Section {
    let mut s = Section::new(id, title);
    s.push(Block::Text(format!(
        "Machine `{}`: {} axes, {} geometric error terms.",
        m.name,
        m.n_axes(),
        m.n_error_terms()
    )));
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
        if !a.errors.has_pdge() {
            continue;
        }
        let unit = a.kind.unit();
        for rot in [false, true] {
            let series: Vec<Series> = Component::ALL
                .iter()
                .filter(|c| c.is_rotation() == rot)
                .filter(|c| {
                    a.errors.pdge[c.index()]
                        .as_ref()
                        .is_some_and(|f| !f.is_zero())
                })
                .enumerate()
                .map(|(k, &c)| Series {
                    name: format!("E{}{}", c.letter(), a.name),
                    points: (0..CURVE_POINTS)
                        .map(|i| {
                            let q = a.travel[0]
                                + (a.travel[1] - a.travel[0]) * i as f64
                                    / (CURVE_POINTS - 1) as f64;
                            (q, a.pdge_at(c, q) * if rot { 1e6 } else { 1e3 })
                        })
                        .collect(),
                    color: COLORS[k % COLORS.len()].into(),
                    markers: false,
                })
                .collect();
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
}
