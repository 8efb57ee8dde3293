//! Circular-test section (ISO 230-4) from the JSON of `mtwin ballbar
//! circular --format json`: G, H, F, the ranked diagnosis and, when the
//! traces are at hand, the polar plot.

use super::fmt;
use crate::methods::ballbar::circular::{CircularDoc, Trace, plot_svg};
use crate::report::html::{Block, Section, Table, Verdict};

/// The circular-test section; `traces` (clockwise, counter-clockwise) add
/// the polar plot when given.
pub fn section(doc: &CircularDoc, traces: Option<(Option<&Trace>, Option<&Trace>)>) -> Section {
    let plane = doc.plane.as_str().to_uppercase();
    let mut s = Section::new(
        &format!("circular-{}", doc.plane.as_str()),
        &format!("Circular test in {plane} (ISO 230-4)"),
    );
    s.push(Block::Text(format!(
        "Ballbar circle of radius {} mm in the {plane} plane ({}). G circular deviation, H circular \
         hysteresis, F radial deviation; the diagnosis fits the signature of each error to both \
         traces by least squares (docs/ballbar.md).",
        crate::io::fmt_f64(doc.radius_mm),
        doc.directions.join(" + ")
    )));
    let mut t = Table::new("ISO 230-4 figures (µm)", &["figure", "value"]);
    t.row(vec!["circular deviation G".into(), fmt(Some(doc.g_um), 2)]);
    t.row(vec!["circular hysteresis H".into(), fmt(doc.h_um, 2)]);
    t.row(vec![
        "radial deviation F (min … max)".into(),
        format!(
            "{} ({} … {})",
            fmt(Some(doc.f_um), 2),
            fmt(Some(doc.f_min_um), 2),
            fmt(Some(doc.f_max_um), 2)
        ),
    ]);
    s.push(Block::Table(t));
    let mut d = Table::new(
        "Diagnosis, largest signature first",
        &[
            "key",
            "value",
            "± (standard uncertainty)",
            "peak on the trace (µm)",
        ],
    );
    for r in &doc.ranking {
        d.row(vec![
            r.key.clone(),
            fmt(Some(r.value), 2),
            fmt(Some(r.uncertainty), 2),
            fmt(Some(r.peak_um), 2),
        ]);
    }
    s.push(Block::Table(d));
    if let Some((cw, ccw)) = traces {
        s.push(Block::Figure {
            caption:
                "Δr of each direction about the fitted centre (µm rings; 0 the nominal circle)."
                    .into(),
            svg: plot_svg(cw, ccw, doc),
        });
    }
    let lines: Vec<String> = doc
        .inseparable
        .iter()
        .map(|g| format!("{} cannot be told apart in this set-up", g.join(" and ")))
        .collect();
    s.push(Block::Verdict {
        verdict: if lines.is_empty() {
            Verdict::Good
        } else {
            Verdict::Caution
        },
        title: if lines.is_empty() {
            format!(
                "Every diagnostic is separable; residual RMS {} µm.",
                fmt(Some(doc.residual_rms_um), 2)
            )
        } else {
            "Not reported (not guessed):".into()
        },
        lines,
    });
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::ballbar::circular::{CircularOptions, Plane, circular};
    use crate::methods::ballbar::circular_sim::{CircularErrors, simulate_circular};

    #[test]
    fn ranking_and_plot_in_the_section() {
        let e = CircularErrors {
            backlash_x_um: 8.0,
            ..Default::default()
        };
        let o = CircularOptions {
            radius_mm: 150.0,
            plane: Plane::Zx,
            ..Default::default()
        };
        let cw = simulate_circular(&e, &o, false, 720, 0.0, 1);
        let ccw = simulate_circular(&e, &o, true, 720, 0.0, 1);
        let doc = circular(Some(&cw), Some(&ccw), &o).unwrap();
        let s = section(&doc, Some((Some(&cw), Some(&ccw))));
        let html = crate::report::html::render(&crate::report::html::Report {
            title: "t".into(),
            subtitle: String::new(),
            sections: vec![s],
        });
        // the first axis of ZX is z: the backlash put in is `backlash_z_um`
        assert!(html.contains("Circular test in ZX") && html.contains("backlash_z_um"));
        assert!(html.contains("<svg"));
        let at = html.find("backlash_z_um").unwrap();
        let row = &html[at..at + html[at..].find("</tr>").unwrap()];
        // the value cell: 8 µm put in, within 5 %
        let v: f64 = row
            .split("<td class=\"n\">")
            .nth(1)
            .and_then(|c| c.split('<').next())
            .and_then(|c| c.parse().ok())
            .unwrap_or_else(|| panic!("{row}"));
        assert!((v - 8.0).abs() <= 0.4, "{row}");
    }
}
