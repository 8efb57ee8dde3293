//! Program compensation section from the JSON of `mtwin compensate --format
//! json`: what the geometric compensation of a part program changed.

use super::fmt;
use crate::methods::compensate::CompensateDoc;
use crate::report::html::{Block, Section, Table, Verdict};

/// The compensation section.
pub fn section(doc: &CompensateDoc) -> Section {
    let mut s = Section::new("compensate", "Geometric compensation of the program");
    s.push(Block::Text(
        "Every target of the program rewritten by inverse kinematics on the identified machine, so \
         that the actual machine puts the tool where the nominal one would; long moves are split \
         until the path between targets is within tolerance."
            .into(),
    ));
    let mut t = Table::new("What changed", &["quantity", "value", "unit"]);
    let count = |n: u64| n.to_string();
    t.row(vec!["blocks read".into(), count(doc.blocks), "".into()]);
    t.row(vec![
        "blocks changed".into(),
        count(doc.blocks_changed),
        "".into(),
    ]);
    t.row(vec![
        "moves subdivided".into(),
        count(doc.blocks_subdivided),
        "".into(),
    ]);
    t.row(vec![
        "blocks inserted".into(),
        count(doc.blocks_inserted),
        "".into(),
    ]);
    t.row(vec![
        "arcs converted to lines".into(),
        count(doc.arcs_converted),
        "".into(),
    ]);
    t.row(vec![
        "largest correction".into(),
        fmt(Some(doc.largest_correction_um), 2),
        "µm".into(),
    ]);
    t.row(vec![
        "largest rotary correction".into(),
        fmt(Some(doc.largest_rotary_correction_deg), 5),
        "deg".into(),
    ]);
    t.row(vec![
        "largest deviation left at a checked midpoint".into(),
        fmt(Some(doc.largest_midpoint_deviation_um), 3),
        "µm".into(),
    ]);
    s.push(Block::Table(t));
    let not_corrected = doc.axis_not_corrected;
    let mut lines = doc.notes.clone();
    if not_corrected > 0 {
        lines.insert(
            0,
            format!("{not_corrected} targets near the singular pose: tip corrected, tool axis not"),
        );
    }
    s.push(Block::Verdict {
        verdict: if not_corrected > 0 {
            Verdict::Caution
        } else {
            Verdict::Good
        },
        title: if not_corrected > 0 {
            "Compensated, with targets where only the tip could be corrected.".into()
        } else {
            "Every target compensated in tip and tool axis.".into()
        },
        lines,
    });
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn singular_targets_make_a_caution() {
        let v = serde_json::json!({"blocks": 10, "blocks_changed": 8, "blocks_subdivided": 1,
            "blocks_inserted": 3, "arcs_converted": 0, "largest_correction_um": 41.257,
            "largest_rotary_correction_deg": 0.01, "largest_midpoint_deviation_um": 0.4,
            "axis_not_corrected": 2, "notes": [], "largest_correction_line": 7, "out": "c.ngc"});
        let doc: CompensateDoc = serde_json::from_value(v).unwrap();
        let s = section(&doc);
        let Block::Table(t) = &s.blocks[1] else {
            panic!()
        };
        assert_eq!(t.rows[5][1], "41.26");
        assert!(
            matches!(&s.blocks[2], Block::Verdict { verdict: Verdict::Caution, lines, .. } if lines[0].starts_with("2 targets"))
        );
    }
}
