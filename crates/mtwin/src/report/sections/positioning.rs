//! Positioning section (ISO 230-2) from the JSON of `mtwin positioning
//! evaluate --format json`: the axis figures, the per-target table and the
//! deviation plot.

use super::fmt;
use crate::methods::positioning::{PositioningDoc, plot_svg};
use crate::report::html::{Block, Section, Table, Verdict};

/// The positioning section of one axis run; `axis` names it in the title
/// (e.g. `X`), `None` for a run whose axis is not known.
pub fn section(doc: &PositioningDoc, axis: Option<&str>) -> Section {
    let id = match axis {
        Some(a) => format!("positioning-{}", a.to_ascii_lowercase()),
        None => "positioning".into(),
    };
    let title = match axis {
        Some(a) => format!("Positioning of axis {a} (ISO 230-2)"),
        None => "Positioning (ISO 230-2)".into(),
    };
    let mut s = Section::new(&id, &title);
    s.push(Block::Text(format!(
        "{} target positions approached {} times from each side; deviation = actual − target. \
         Accuracy A, systematic error E and repeatability R after ISO 230-2:2014 (docs/positioning.md).",
        doc.targets, doc.cycles
    )));
    let mut t = Table::new(
        "Axis figures (µm)",
        &[
            "figure",
            "bidirectional",
            "↑ (increasing)",
            "↓ (decreasing)",
        ],
    );
    let f = |v: f64| fmt(Some(v), 2);
    t.row(vec![
        "accuracy A".into(),
        f(doc.a_um),
        f(doc.a_up_um),
        f(doc.a_down_um),
    ]);
    t.row(vec![
        "systematic positioning error E".into(),
        f(doc.e_um),
        f(doc.e_up_um),
        f(doc.e_down_um),
    ]);
    t.row(vec![
        "repeatability R".into(),
        f(doc.r_um),
        f(doc.r_up_um),
        f(doc.r_down_um),
    ]);
    t.row(vec![
        "reversal B (mean B̄)".into(),
        format!("{} ({})", f(doc.b_um), f(doc.b_mean_um)),
        "".into(),
        "".into(),
    ]);
    t.row(vec![
        "mean bidirectional positioning error M".into(),
        f(doc.m_um),
        "".into(),
        "".into(),
    ]);
    s.push(Block::Table(t));
    let mut pt = Table::new(
        "Per target (µm; target in mm)",
        &["target", "x̄↑", "x̄↓", "x̄", "s↑", "s↓", "Bi", "Ri"],
    );
    for r in &doc.per_target {
        pt.row(vec![
            crate::io::fmt_f64(r.target_mm),
            f(r.mean_up_um),
            f(r.mean_down_um),
            f(r.mean_um),
            f(r.s_up_um),
            f(r.s_down_um),
            f(r.reversal_um),
            f(r.r_um),
        ]);
    }
    s.push(Block::Table(pt));
    s.push(Block::Figure {
        caption: "Deviation against position per direction, mean ± 2s band and every reading."
            .into(),
        svg: plot_svg(doc),
    });
    if !doc.notes.is_empty() {
        s.push(Block::Verdict {
            verdict: Verdict::Caution,
            title: "What the reader dropped or assumed:".into(),
            lines: doc.notes.clone(),
        });
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::positioning::{Run, evaluate};

    #[test]
    fn figures_of_the_document_are_in_the_section() {
        let run = Run {
            source: "r.csv".into(),
            targets_mm: vec![0.0, 100.0],
            up_mm: vec![vec![0.001, 0.003], vec![0.010, 0.010]],
            down_mm: vec![vec![-0.001, -0.001], vec![0.004, 0.006]],
            notes: vec!["one sample dropped".into()],
        };
        let doc = evaluate(&run).unwrap();
        let s = section(&doc, Some("X"));
        let html = crate::report::html::render(&crate::report::html::Report {
            title: "t".into(),
            subtitle: String::new(),
            sections: vec![s],
        });
        // E = 10 − (−1) = 11 µm, M = 7 µm (closed form of this run)
        assert!(html.contains("11.00") && html.contains("7.00"), "{html}");
        assert!(html.contains("Positioning of axis X") && html.contains("one sample dropped"));
        assert!(html.contains("<svg"));
    }
}
