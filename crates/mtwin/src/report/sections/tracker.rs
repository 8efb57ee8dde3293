//! Tracker sections (\[R2\]): identification from the JSON of
//! `mtwin tracker identify --format json` (identifiability verdict and estimates with
//! uncertainties) and validation from the JSON of `mtwin tracker validate --format
//! json` (before/after statistics per direction and as a chart).

use super::{COLORS, decimate, fmt};
use crate::methods::tracker::doc::unit_of;
use crate::methods::tracker::{TrackerIdentifyDoc, TrackerValidateDoc};
use crate::report::html::{Block, Section, Table, Verdict};
use crate::report::svg::{Series, bars, xy};

/// The identification section.
pub fn identify_section(doc: &TrackerIdentifyDoc) -> Section {
    let (rank, params) = (doc.rank, doc.parameters);
    let cond = Some(doc.condition_number);
    let (before, after) = (doc.rms_before, doc.rms_after);
    let unident = &doc.unidentifiable;
    let relations = &doc.relations;
    let outliers = &doc.outliers;
    let warnings: Vec<String> = doc.warnings.iter().map(|w| w.to_string()).collect();
    let mut s = Section::new("tracker-identify", "Tracker: identification");
    s.push(Block::Text(format!(
        "Geometric errors fitted by Levenberg–Marquardt to measured tool-tip positions. Residual RMS \
         per coordinate: {} µm with the nominal model, {} µm with the identified one.",
        fmt(Some(before * 1e3), 2),
        fmt(Some(after * 1e3), 2)
    )));
    let mut lines = vec![
        format!("rank {rank} of {params} parameters"),
        format!(
            "condition number (scaled): {}",
            cond.map_or("—".into(), |c| format!("{c:.3e}"))
        ),
    ];
    let gauged = doc.gauge.is_some();
    if !unident.is_empty() && !gauged {
        lines.push(format!(
            "not identifiable, kept at their start value: {}",
            unident.join(", ")
        ));
        for r in relations.iter().take(20) {
            lines.push(format!("confounded: {r}"));
        }
        if relations.len() > 20 {
            lines.push(format!("… and {} more relations", relations.len() - 20));
        }
    } else if !unident.is_empty() {
        let prior = match doc.gauge.as_deref() {
            Some("prior") => "the prior calibration",
            _ => "0 (the minimum-norm solution)",
        };
        lines.push(format!(
            "not determined individually, gauge-fixed (pulled to {prior} along the directions the \
             points do not see; the predictions are unchanged): {}",
            unident.join(", ")
        ));
        let combos = &doc.identifiable_combinations;
        for c in combos.iter().take(20) {
            lines.push(format!("determined: {c}"));
        }
        if combos.len() > 20 {
            lines.push(format!(
                "… and {} more determined combinations",
                combos.len() - 20
            ));
        }
    }
    if !outliers.is_empty() {
        lines.push(format!("{} outlier point(s) excluded", outliers.len()));
    }
    lines.extend(warnings.iter().cloned());
    let verdict = if rank == params && warnings.is_empty() {
        Verdict::Good
    } else if rank > 0 {
        Verdict::Caution
    } else {
        Verdict::Bad
    };
    s.push(Block::Verdict {
        verdict,
        title: if rank == params {
            "Every parameter is identifiable from these points.".into()
        } else {
            if gauged {
                format!(
                    "Identifiability: {} of {} independent directions determined; the confounded or unseen parameters are gauge-fixed (marked “gauge” below) and only their combinations are meaningful.",
                    rank, params
                )
            } else {
                format!(
                    "Identifiability: {} of {} parameters determined; the others are confounded or unseen and stay at their start value.",
                    rank, params
                )
            }
        },
        lines,
    });
    let mut t = Table::new(
        "Estimates (coefficients of the error functions; ± standard uncertainty)",
        &["parameter", "value", "std. uncertainty", "unit"],
    );
    for e in &doc.estimates {
        let (f, unit) = unit_of(&e.name);
        let is_gauged = doc.gauge_fixed.iter().any(|g| g.name == e.name);
        if e.unidentifiable.is_some() && !is_gauged {
            continue;
        }
        t.row(vec![
            if e.unidentifiable.is_some() {
                format!("{} (gauge)", e.name)
            } else {
                e.name.clone()
            },
            fmt(Some(e.value * f), 3),
            fmt(e.uncertainty.map(|v| v * f), 3),
            unit.into(),
        ]);
    }
    s.push(Block::Table(t));
    s
}

/// The validation section. `per_point` optionally gives `|Δp|` per check
/// point before and after (mm) for a line chart.
pub fn validate_section(doc: &TrackerValidateDoc, per_point: Option<(&[f64], &[f64])>) -> Section {
    let n = doc.points;
    let mut s = Section::new("tracker-validate", "Tracker: validation at check poses");
    s.push(Block::Text(format!(
        "{n} check points not used in the fit: |error| of the nominal model (before) and of the \
         identified model (after), per direction of W and as distance |Δp|."
    )));
    let mut t = Table::new(
        "Before → after (µm) and change (%)",
        &[
            "direction",
            "before max",
            "before mean",
            "before std",
            "after max",
            "after mean",
            "after std",
            "change max %",
            "change mean %",
            "change std %",
        ],
    );
    let dirs = ["x", "y", "z", "distance"];
    let stat = |e: &crate::methods::tracker::ErrorStats, d: &str| match d {
        "x" => e.x,
        "y" => e.y,
        "z" => e.z,
        _ => e.distance,
    };
    let mut groups = Vec::new();
    let (mut b_mean, mut a_mean, mut b_max, mut a_max) = (vec![], vec![], vec![], vec![]);
    for d in dirs {
        let g = |k: &str, s: &str| -> f64 {
            let e = match k {
                "before" => &doc.before,
                "after" => &doc.after,
                _ => &doc.change_percent,
            };
            let st = stat(e, d);
            match s {
                "max" => st.max,
                "mean" => st.mean,
                _ => st.std,
            }
        };
        let row = vec![
            if d == "distance" {
                "|Δp|".into()
            } else {
                d.to_string()
            },
            fmt(Some(g("before", "max") * 1e3), 2),
            fmt(Some(g("before", "mean") * 1e3), 2),
            fmt(Some(g("before", "std") * 1e3), 2),
            fmt(Some(g("after", "max") * 1e3), 2),
            fmt(Some(g("after", "mean") * 1e3), 2),
            fmt(Some(g("after", "std") * 1e3), 2),
            fmt(Some(g("change_percent", "max")), 0),
            fmt(Some(g("change_percent", "mean")), 0),
            fmt(Some(g("change_percent", "std")), 0),
        ];
        t.row(row);
        groups.push(if d == "distance" {
            "|Δp|".to_string()
        } else {
            d.to_string()
        });
        b_max.push(g("before", "max") * 1e3);
        a_max.push(g("after", "max") * 1e3);
        b_mean.push(g("before", "mean") * 1e3);
        a_mean.push(g("after", "mean") * 1e3);
    }
    s.push(Block::Table(t));
    s.push(Block::Figure {
        caption: "Largest and mean |error| per direction before (nominal model) and after (identified model).".into(),
        svg: bars(
            "Validation: |error| before and after",
            "|error| (µm)",
            &groups,
            &[
                ("max before".into(), "#e6b0aa".into(), b_max),
                ("mean before".into(), COLORS[0].into(), b_mean),
                ("max after".into(), "#a9cce3".into(), a_max),
                ("mean after".into(), COLORS[1].into(), a_mean),
            ],
        ),
    });
    if let Some((before, after)) = per_point {
        let line = |name: &str, e: &[f64], c: &str| Series {
            name: name.into(),
            points: decimate(
                &e.iter()
                    .enumerate()
                    .map(|(k, v)| ((k + 1) as f64, v * 1e3))
                    .collect::<Vec<_>>(),
                2000,
            ),
            color: c.into(),
            markers: false,
        };
        s.push(Block::Figure {
            caption: "|Δp| at every check point, before and after.".into(),
            svg: xy(
                "|Δp| per check point",
                "check point",
                "|Δp| (µm)",
                &[
                    line("before (nominal)", before, COLORS[0]),
                    line("after (identified)", after, COLORS[1]),
                ],
            ),
        });
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_follow_the_parameter_names() {
        assert_eq!(unit_of("EXX.c0"), (1e3, "µm"));
        assert_eq!(unit_of("ECX.c1"), (1e6, "µrad"));
        assert_eq!(unit_of("EB0C"), (1e6, "µrad"));
        assert_eq!(unit_of("REG.tx"), (1.0, "mm"));
        assert_eq!(unit_of("REG.b"), (1e6, "µrad"));
    }

    #[test]
    fn verdict_lists_confounded_parameters() {
        let v = serde_json::json!({
            "rank": 2, "parameters": 3, "rms_before": 0.1, "rms_after": 0.01,
            "condition_number": 12.0, "unidentifiable": ["EXY.c0"],
            "relations": ["EXY.c0 − 1.0000·EXX.c0 ≈ 0"], "outliers": [], "warnings": [],
            "out": "id.toml", "registration": null, "sigma": 0.001,
            "convergence": {"iterations": 3, "initial_cost": 1.0, "final_cost": 0.01,
                "reason": "gradient", "evaluations": 4, "factorizations": 4, "damping": 1e-3},
            "estimates": [
                {"name": "EXX.c0", "start": 0.0, "value": 0.002, "uncertainty": 0.0001, "unidentifiable": null},
                {"name": "EXY.c0", "start": 0.0, "value": 0.0, "uncertainty": null, "unidentifiable": "confounded"},
                {"name": "ECX.c1", "start": 0.0, "value": 3e-6, "uncertainty": 1e-7, "unidentifiable": null}
            ]
        });
        let doc: TrackerIdentifyDoc = serde_json::from_value(v).unwrap();
        let s = identify_section(&doc);
        let Block::Verdict { verdict, lines, .. } = &s.blocks[1] else {
            panic!()
        };
        assert_eq!(*verdict, Verdict::Caution);
        assert!(lines.iter().any(|l| l.contains("EXY.c0 − 1.0000·EXX.c0")));
        let Block::Table(t) = &s.blocks[2] else {
            panic!()
        };
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.rows[0][1], "2.000");
        assert_eq!(t.rows[1][1], "3.000");
        assert_eq!(t.rows[1][3], "µrad");
    }
}
