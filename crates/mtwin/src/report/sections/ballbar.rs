//! Ballbar section (\[R1\]) from the JSON of `mtwin ballbar identify --format json`:
//! the eight PIGEs with standard uncertainties, residual RMS per mode, the
//! corrected axis-line positions and the polar plots.

use super::{ReportError, fmt};
use crate::methods::ballbar::{BallbarIdentifyDoc, BallbarMode, Pige};
use crate::report::html::{Block, Section, Table, Verdict};

/// The ballbar section. `figures` are `(caption, SVG)` pairs, e.g. the polar
/// plots of `ballbar identify --plot DIR`; `what` names the input in errors.
pub fn section(
    doc: &BallbarIdentifyDoc,
    what: &str,
    figures: Vec<(String, String)>,
) -> Result<Section, ReportError> {
    let mut s = Section::new("ballbar", "Ballbar: location errors of the rotary axes");
    s.push(Block::Text(
        "Eight position-independent location errors (PIGEs) of the A and C axes, identified from \
         the four ballbar modes. Offsets in µm, tilts in µrad, ± one standard uncertainty."
            .into(),
    ));
    let unidentified = &doc.unidentified;
    let mut t = Table::new(
        "Identified PIGEs (absolute)",
        &["PIGE", "meaning", "value", "std. uncertainty", "unit"],
    );
    for p in Pige::ALL {
        let (f, unit) = if p.is_tilt() {
            (1e6, "µrad")
        } else {
            (1e3, "µm")
        };
        let meaning = match (p.axis(), p.is_tilt()) {
            ('A', false) => "offset of the A line",
            ('A', true) => "tilt of the A line",
            (_, false) => "offset of the C line",
            (_, true) => "tilt of the C line",
        };
        let (val, unc) = if !doc.is_identified(p) {
            ("not identified".to_string(), "—".to_string())
        } else {
            (
                fmt(doc.value[p].map(|v| v * f), 2),
                fmt(doc.uncertainty[p].map(|u| u * f), 2),
            )
        };
        t.row(vec![p.name().into(), meaning.into(), val, unc, unit.into()]);
    }
    s.push(Block::Table(t));
    let mut r = Table::new(
        "Residuals and fitted bar lengths per mode",
        &["mode", "residual RMS (µm)", "fitted bar length (mm)"],
    );
    for m in BallbarMode::ALL {
        let rms = doc.residual_rms[m];
        if rms.is_some() {
            r.row(vec![
                m.label().into(),
                fmt(rms.map(|v| v * 1e3), 3),
                fmt(doc.bar_length[m], 4),
            ]);
        }
    }
    if r.rows.is_empty() {
        return Err(ReportError::Input {
            what: what.into(),
            message: "no mode has a residual (`residual_rms`): is this `ballbar identify --format json` output?".into(),
        });
    }
    s.push(Block::Table(r));
    let mut c = Table::new(
        "Compensation: where the actual axis lines pass (enter in the control)",
        &["axis line", "coordinate", "value (mm)"],
    );
    let comp = &doc.compensation;
    for (value, line, coord) in [
        (comp.a_y, "A (in M)", "Y"),
        (comp.a_z, "A (in M)", "Z"),
        (comp.c_x, "C (in the A frame)", "X"),
        (comp.c_y, "C (in the A frame)", "Y"),
    ] {
        c.row(vec![line.into(), coord.into(), fmt(Some(value), 4)]);
    }
    s.push(Block::Table(c));
    unseparable(&mut s, doc);
    let warnings = &doc.warnings;
    let mut lines: Vec<String> = unidentified
        .iter()
        .map(|(k, v)| format!("{k}: {v}"))
        .collect();
    lines.extend(warnings.iter().cloned());
    let (verdict, title) = if unidentified.is_empty() && warnings.is_empty() {
        (
            Verdict::Good,
            "All eight PIGEs are identified by the modes given.".to_string(),
        )
    } else if unidentified.len() < 8 {
        (
            Verdict::Caution,
            format!(
                "{} of 8 PIGEs identified; read the notes below.",
                8 - unidentified.len()
            ),
        )
    } else {
        (Verdict::Bad, "No PIGE is identified.".to_string())
    };
    s.push(Block::Verdict {
        verdict,
        title,
        lines,
    });
    for (caption, svg) in figures {
        s.push(Block::Figure { caption, svg });
    }
    Ok(s)
}

/// Scale and unit of a parameter of a combination: µrad for a tilt PIGE,
/// µm otherwise (offsets, bar lengths).
fn unit_of(name: &str) -> (f64, &'static str) {
    if Pige::from_name(name).is_some_and(Pige::is_tilt) {
        (1e6, "µrad")
    } else {
        (1e3, "µm")
    }
}

/// The PIGEs the modes given cannot separate (`unseparable_combinations`):
/// the combinations measured with value ± uncertainty, the directions the
/// readings do not see, and what that means.
fn unseparable(s: &mut Section, doc: &BallbarIdentifyDoc) {
    let groups = &doc.unseparable_combinations;
    if groups.is_empty() {
        return;
    }
    let mut t = Table::new(
        "PIGEs the modes given cannot separate: the combinations measured",
        &[
            "PIGEs",
            "combination measured",
            "value",
            "std. uncertainty",
            "unit",
        ],
    );
    let mut unseen = Vec::new();
    for g in groups {
        for c in &g.determined {
            let (k, unit) = c.terms.first().map_or((1e3, "µm"), |t| unit_of(&t.name));
            t.row(vec![
                g.parameters.join(", "),
                c.describe(),
                fmt(Some(c.value * k), 2),
                fmt(c.uncertainty.map(|u| u * k), 2),
                unit.into(),
            ]);
        }
        for d in &g.undetermined_directions {
            unseen.push(format!(
                "Not seen by the readings: {} (any amount of it reads the same).",
                d.describe()
            ));
        }
    }
    s.push(Block::Table(t));
    let mut text = String::from(
        "These PIGEs move the readings of the modes given only together, so the readings measure \
         the combination above, within its uncertainty, and not each PIGE: any amount along the \
         unseen direction fits them equally well. In the table of PIGEs the one held at 0 shows \
         as not identified and its partner carries the whole combination; neither is its own \
         value. A compensation that moves the axis line by the combination corrects what these \
         modes measure, but a set-up that sees the PIGEs apart can be off by the unknown split. \
         The mode named in the notes below separates them.",
    );
    for u in unseen {
        text += " ";
        text += &u;
    }
    s.push(Block::Text(text));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A saved `ballbar identify --format json` document, as a user's file.
    fn sample() -> BallbarIdentifyDoc {
        serde_json::from_value(serde_json::json!({
            "EY0A": 0.010, "EZ0A": -0.02, "EB0A": 1e-5, "EC0A": 2e-5,
            "EX0C": 0.003, "EY0C": null, "EA0C": 0.0, "EB0C": 0.0,
            "uncertainty": {"EY0A": 1e-4, "EZ0A": 2e-4, "EB0A": 1e-6, "EC0A": null, "EX0C": 1e-4, "EY0C": null, "EA0C": 1e-6, "EB0C": 1e-6},
            "residual_rms": {"mode1": 3e-4, "mode2": null, "mode3": 2e-4, "mode4": null},
            "bar_length": {"mode1": 100.001, "mode3": 99.999},
            "compensation": {"A_line_y": 0.01, "A_line_z": -0.02, "C_line_x": 0.003, "C_line_y": 0.0},
            "unidentified": {"EY0C": "mode 3 and 4 missing"},
            "warnings": []
        }))
        .unwrap()
    }

    #[test]
    fn values_are_scaled_to_their_units_and_unidentified_are_named() {
        let s = section(&sample(), "id.json", vec![]).unwrap();
        let Block::Table(t) = &s.blocks[1] else {
            panic!()
        };
        assert_eq!(t.rows[0][2], "10.00"); // 0.010 mm = 10 µm
        assert_eq!(t.rows[0][3], "0.10");
        assert_eq!(t.rows[2][2], "10.00"); // 1e-5 rad = 10 µrad
        assert_eq!(t.rows[2][4], "µrad");
        assert_eq!(t.rows[5][2], "not identified");
        let Block::Table(r) = &s.blocks[2] else {
            panic!()
        };
        assert_eq!(r.rows.len(), 2);
        assert_eq!(r.rows[0][1], "0.300");
        assert!(
            s.blocks
                .iter()
                .any(|b| matches!(b, Block::Verdict { verdict: Verdict::Caution, lines, .. } if lines[0].starts_with("EY0C")))
        );
    }

    /// Mode 3 alone, as `ballbar identify` writes it: `EY0C` held at 0,
    /// `EY0A` carrying the sum, the group and its combination.
    fn mode3_alone() -> BallbarIdentifyDoc {
        serde_json::from_value(serde_json::json!({
            "EY0A": -0.00457, "EZ0A": 0.0012, "EB0A": null, "EC0A": null,
            "EX0C": 0.0031, "EY0C": null, "EA0C": 2.5e-6, "EB0C": -1.5e-6,
            "uncertainty": {"EY0A": 7e-5, "EZ0A": 5e-5, "EB0A": null, "EC0A": null, "EX0C": 6e-5, "EY0C": null, "EA0C": 1e-7, "EB0C": 1e-7},
            "residual_rms": {"mode1": null, "mode2": null, "mode3": 4e-4, "mode4": null},
            "bar_length": {"mode3": 100.0002},
            "compensation": {"A_line_y": 0.0, "A_line_z": 0.0012, "C_line_x": 0.0031, "C_line_y": -0.00457},
            "unidentified": {"EY0C": "held at 0, its effect absorbed by EY0A; add mode1 to separate it"},
            "warnings": [],
            "unseparable_combinations": [{
                "parameters": ["EY0A", "EY0C"],
                "undetermined": 1,
                "undetermined_directions": [{"terms": [
                    {"name": "EY0A", "coefficient": 1.0, "scaled": 1.0},
                    {"name": "EY0C", "coefficient": -1.0, "scaled": -1.0}
                ]}],
                "determined": [{
                    "terms": [
                        {"name": "EY0C", "coefficient": 1.0, "scaled": 1.0},
                        {"name": "EY0A", "coefficient": 1.0, "scaled": 1.0}
                    ],
                    "value": -0.00457,
                    "uncertainty": 7e-5
                }]
            }]
        }))
        .unwrap()
    }

    #[test]
    fn unseparable_combinations_are_shown_with_their_unseen_direction() {
        let doc = mode3_alone();
        let s = section(&doc, "id.json", vec![]).unwrap();
        let t = s
            .blocks
            .iter()
            .find_map(|b| match b {
                Block::Table(t) if t.caption.contains("cannot separate") => Some(t),
                _ => None,
            })
            .expect("a table of the combinations");
        assert_eq!(t.rows.len(), 1);
        let row = &t.rows[0];
        assert_eq!(row[0], "EY0A, EY0C");
        assert_eq!(row[4], "µm");
        // The shown value recomputed from the document: Σ coefficient · PIGE
        // over the combination's terms (the PIGE held at 0, `null`, counts
        // 0), in µm; the uncertainty the document's, in µm.
        let g = &doc.unseparable_combinations[0].determined[0];
        let sum: f64 = g
            .terms
            .iter()
            .map(|term| {
                let p = Pige::from_name(&term.name).unwrap();
                term.coefficient * doc.value[p].unwrap_or(0.0) * 1e3
            })
            .sum();
        // The report writes a minus sign (U+2212).
        let shown: f64 = row[2].replace('−', "-").parse().unwrap();
        assert!((shown - sum).abs() <= 0.005 + 1e-9, "{shown} vs {sum}");
        assert_eq!(row[2], "−4.57");
        let unc: f64 = row[3].parse().unwrap();
        assert!((unc - 0.07).abs() < 1e-9);
        // The combination names both PIGEs with their coefficients.
        assert!(
            row[1].contains("EY0C") && row[1].contains("EY0A"),
            "{}",
            row[1]
        );
        // The sentence: what is measured, the unseen direction.
        let text = s
            .blocks
            .iter()
            .find_map(|b| match b {
                Block::Text(t) if t.contains("Not seen") => Some(t),
                _ => None,
            })
            .expect("the sentence");
        assert!(text.contains("EY0A − 1.0000·EY0C"), "{text}");
        assert!(text.contains("measure the combination"), "{text}");
        // Without combinations, no table.
        let s = section(&sample(), "id.json", vec![]).unwrap();
        assert!(
            !s.blocks
                .iter()
                .any(|b| matches!(b, Block::Table(t) if t.caption.contains("cannot separate")))
        );
    }

    #[test]
    fn other_json_is_refused_naming_the_field() {
        let e = serde_json::from_value::<BallbarIdentifyDoc>(serde_json::json!({"rank": 3}))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bar_length") || e.contains("missing field"),
            "{e}"
        );
    }

    #[test]
    fn a_document_without_residuals_is_refused_with_its_name() {
        let mut d = sample();
        d.residual_rms = crate::methods::ballbar::PerMode::new([None; 4]);
        let e = section(&d, "x.json", vec![]).unwrap_err();
        assert!(e.to_string().contains("x.json"), "{e}");
    }
}
