//! Skiving section (\[R3\]) from the JSON of `mtwin skiving setup-error
//! --format json`: the four set-up errors with uncertainties, the first-order
//! closed form beside them, and the residual of every touch.

use super::{COLORS, fmt};
use crate::methods::skiving::TouchFlag;
use crate::methods::skiving::doc::SkivingSetupDoc;
use crate::report::html::{Block, Section, Table, Verdict};
use crate::report::svg::bars;

/// The skiving section.
pub fn section(doc: &SkivingSetupDoc) -> Section {
    let mut s = Section::new("skiving", "Skiving: workpiece set-up error");
    s.push(Block::Text(
        "Offsets δgx, δgy of the workpiece on the table (µm) and tilts εxz (about Y), εzy (about X) \
         (µrad), from touch-offs of the skiving tool; exact chain, least squares."
            .into(),
    ));
    let mut t = Table::new(
        "Set-up error",
        &[
            "quantity",
            "value",
            "std. uncertainty",
            "first-order formula",
            "unit",
        ],
    );
    let value = doc.estimate.to_array();
    let unc = doc.uncertainty.map(|u| u.to_array());
    let first = doc.first_order.map(|u| u.to_array());
    for k in 0..4 {
        let (f, unit) = if k < 2 { (1e3, "µm") } else { (1e6, "µrad") };
        t.row(vec![
            ["δgx", "δgy", "εxz", "εzy"][k].into(),
            fmt(Some(value[k] * f), 3),
            fmt(unc.map(|u| u[k] * f), 3),
            fmt(first.map(|u| u[k] * f), 3),
            unit.into(),
        ]);
    }
    s.push(Block::Table(t));
    let residuals: Vec<f64> = doc.residuals.iter().map(|r| r * 1e3).collect();
    let flags = &doc.flags;
    let bad: Vec<String> = flags
        .iter()
        .enumerate()
        .filter(|(_, f)| **f == TouchFlag::Inconsistent)
        .map(|(i, _)| format!("touch {} is inconsistent with the others", i + 1))
        .collect();
    let unchecked = flags.iter().filter(|f| **f == TouchFlag::Unchecked).count();
    let mut lines = bad.clone();
    if unchecked > 0 {
        lines.push(format!(
            "{unchecked} touch(es) are not checked by any other: an error in them goes straight into the result"
        ));
    }
    s.push(Block::Verdict {
        verdict: if !bad.is_empty() {
            Verdict::Bad
        } else if unchecked > 0 {
            Verdict::Caution
        } else {
            Verdict::Good
        },
        title: if bad.is_empty() {
            format!("{} touches, all consistent.", residuals.len())
        } else {
            format!("{} of {} touches inconsistent.", bad.len(), residuals.len())
        },
        lines,
    });
    let groups: Vec<String> = (1..=residuals.len()).map(|k| k.to_string()).collect();
    s.push(Block::Figure {
        caption: "Residual of every touch after the fit (µm).".into(),
        svg: bars(
            "Touch residuals",
            "residual (µm)",
            &groups,
            &[("residual".into(), COLORS[1].into(), residuals)],
        ),
    });
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_in_um_tilts_in_urad_and_inconsistent_touches_flagged() {
        let v = serde_json::json!({
            "dgx": 0.03, "dgy": -0.02, "exz": 2e-4, "ezy": -1e-4,
            "uncertainty": {"dgx": 1e-4, "dgy": 1e-4, "exz": 1e-6, "ezy": 1e-6},
            "first_order": {"dgx": 0.0301, "dgy": -0.0199, "exz": 2.01e-4, "ezy": -1e-4},
            "residuals": [0.0, 0.001, -0.001],
            "flags": ["ok", "inconsistent", "ok"],
            "coverage_factor_95": 2.0, "flag_noise": 0.001, "leverage": [0.5, 0.5, 0.5],
            "standardized_residuals": [0.0, 3.5, null], "touches": 3,
            "uncertainty_basis": {"kind": "known_noise", "sigma": 0.001}
        });
        let doc: SkivingSetupDoc = serde_json::from_value(v).unwrap();
        let s = section(&doc);
        let Block::Table(t) = &s.blocks[1] else {
            panic!()
        };
        assert_eq!(t.rows[0][1], "30.000");
        assert_eq!(t.rows[2][1], "200.000");
        assert_eq!(t.rows[1][3], "−19.900");
        assert!(matches!(
            &s.blocks[2],
            Block::Verdict {
                verdict: Verdict::Bad,
                ..
            }
        ));
    }
}
