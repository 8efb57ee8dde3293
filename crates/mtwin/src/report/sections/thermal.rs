//! Thermal section (\[R4\]): the fitted drift model (`THERMAL.toml`) as a
//! table per height, and drift curves over time — e.g. the rows of
//! `mtwin thermal predict` (`t_min,z_mm,drift_mm`), or drift with and without
//! compensation.

use super::{COLORS, decimate, fmt};
use crate::methods::thermal::ThermalModel;
use crate::methods::thermal::log::InputSearch;
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

/// Measured and predicted drift of one channel of a wide log, since the
/// log's start, in µm over min (for [`log_section`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LogChannelCurves {
    /// The channel's column.
    pub column: String,
    /// `(t_min, drift_um)`: the period means of the log, since its first.
    pub measured: Vec<(f64, f64)>,
    /// `(t_min, drift_um)`: the model's simulation from the log's start
    /// with the inputs alone.
    pub predicted: Vec<(f64, f64)>,
    /// For a channel with several models (`--folds` with several values,
    /// predicted by their median): the lowest and the highest of their
    /// simulations, as `predicted`; empty otherwise.
    pub lowest: Vec<(f64, f64)>,
    /// See [`LogChannelCurves::lowest`].
    pub highest: Vec<(f64, f64)>,
}

/// The curves of every channel of `model` present in `log` (read with the
/// model's period): sample `k` placed at `(k + ½)·T`, both since sample 0.
pub fn log_curves(
    model: &crate::methods::thermal::log::LogModel,
    log: &crate::methods::thermal::log::LogData,
) -> Result<Vec<LogChannelCurves>, crate::methods::thermal::ThermalError> {
    let pred = crate::methods::thermal::log::predict_log(model, log)?;
    let range = crate::methods::thermal::log::predict_log_range(model, log)?;
    let t = |k: usize| (k as f64 + 0.5) * log.period_min;
    Ok(model
        .channels
        .iter()
        .zip(&pred)
        .zip(&log.channels)
        .zip(&range)
        .map(|(((c, p), m), r)| {
            let um = c.channel.unit.mm() * 1e3;
            let base = m.first().copied().unwrap_or(0.0);
            let curve = |s: &[f64]| -> Vec<(f64, f64)> {
                s.iter()
                    .enumerate()
                    .map(|(k, v)| (t(k), (v - base) * um))
                    .collect()
            };
            let (lowest, highest) = match r {
                Some((low, high)) => (curve(low), curve(high)),
                None => (Vec::new(), Vec::new()),
            };
            LogChannelCurves {
                lowest,
                highest,
                column: c.channel.column.clone(),
                measured: m
                    .iter()
                    .enumerate()
                    .map(|(k, v)| (t(k), (v - base) * um))
                    .collect(),
                predicted: p
                    .iter()
                    .enumerate()
                    .map(|(k, v)| (t(k), (v - base) * um))
                    .collect(),
            }
        })
        .collect())
}

/// The section of a wide-log fit (the JSON of `mtwin thermal fit --log
/// --format json`): per channel the held-out error it was chosen by, the
/// chosen inputs and orders, the test span's scores when the fit stopped
/// before the log's end, and one chart per entry of `curves` (measured and
/// predicted drift, µm over min).
pub fn log_section(
    doc: &crate::methods::thermal::ThermalLogFitDoc,
    curves: &[LogChannelCurves],
) -> Section {
    let mut s = Section::new("thermal-log", "Thermal drift from a machine log");
    let how = if doc.folds > 1 {
        format!(
            "blocked cross-validation over {} blocks (each block predicted from cold by a model fitted on the blocks before it)",
            doc.folds
        )
    } else {
        format!(
            "one held-out block of {} samples at the end of the training time",
            doc.heldout_samples
        )
    };
    let search = match doc.search {
        InputSearch::Forward => "forward selection",
        InputSearch::Exchange => "forward selection with exchanges and pairs",
    };
    s.push(Block::Text(format!(
        "One ARX model per drift channel, inputs chosen by {search} and orders by the simulation \
         error from cold on held-out data ({how}); sample period {} min, {} of {} samples for training. \
         Drift = displacement of the tool relative to the workpiece along the channel's axis.",
        doc.period_min, doc.training_samples, doc.samples
    )));
    let mut t = Table::new(
        "Model per channel",
        &[
            "channel",
            "axis",
            "na, nb",
            "inputs",
            "held-out RMS (µm)",
            "held-out / drift (%)",
            "training RMS (µm)",
            "output error",
        ],
    );
    for c in &doc.channels {
        t.row(vec![
            c.column.clone(),
            format!("{:?}", c.axis),
            format!("{}, {}", c.na, c.nb),
            c.inputs.join(", "),
            fmt(Some(c.heldout_rms_mm * 1e3), 3),
            fmt(
                Some(100.0 * c.heldout_rms_mm / c.heldout_drift_rms_mm.max(1e-300)),
                1,
            ),
            fmt(Some(c.training_rms_mm * 1e3), 3),
            if c.output_error { "yes" } else { "no" }.into(),
        ]);
    }
    s.push(Block::Table(t));
    if doc.channels.iter().any(|c| !c.members.is_empty()) {
        let mut caption = String::from("The other models of each channel");
        if !doc.ensemble_folds.is_empty() {
            let blocks: Vec<String> = doc.ensemble_folds.iter().map(usize::to_string).collect();
            caption += &format!(", chosen with {} held-out blocks", blocks.join(", "));
        }
        if doc.also_plain {
            caption += ", and its models of the plain rises (the temperatures not taken over the ambient sensor)";
        }
        caption += ": a channel is predicted by the per-sample median of all its models";
        let mut t = Table::new(
            &caption,
            &[
                "channel",
                "held-out blocks",
                "na, nb",
                "inputs",
                "held-out RMS (µm)",
                "training RMS (µm)",
                "output error",
            ],
        );
        for c in &doc.channels {
            for m in &c.members {
                t.row(vec![
                    c.column.clone(),
                    m.folds.to_string(),
                    format!("{}, {}", m.na, m.nb),
                    m.inputs.join(", "),
                    fmt(Some(m.heldout_rms_mm * 1e3), 3),
                    fmt(Some(m.training_rms_mm * 1e3), 3),
                    if m.output_error { "yes" } else { "no" }.into(),
                ]);
            }
        }
        s.push(Block::Table(t));
    }
    if let Some(test) = &doc.test {
        let mut t = Table::new(
            &format!(
                "Test span from {} min ({} samples), predicted from the log's start",
                fmt(Some(test.from_min), 1),
                test.samples
            ),
            &["channel", "MAE (channel unit)", "error / drift RMS"],
        );
        for c in &test.channels {
            t.row(vec![
                c.column.clone(),
                fmt(Some(c.mae), 3),
                fmt(Some(c.error_over_drift_rms), 3),
            ]);
        }
        s.push(Block::Table(t));
    }
    s.push(Block::Verdict {
        verdict: if doc.warnings.is_empty() {
            Verdict::Good
        } else {
            Verdict::Caution
        },
        title: if doc.warnings.is_empty() {
            "Every channel's held-out error is small against its drift.".into()
        } else {
            "Channels with reservations:".into()
        },
        lines: doc.warnings.clone(),
    });
    for c in curves {
        let series = vec![
            Series {
                name: "measured".into(),
                points: decimate(&c.measured, 2000),
                color: COLORS[0].into(),
                markers: false,
            },
            Series {
                name: "predicted".into(),
                points: decimate(&c.predicted, 2000),
                color: COLORS[1].into(),
                markers: false,
            },
        ];
        let mut series = series;
        if !c.lowest.is_empty() {
            for (name, points) in [
                ("lowest of the models", &c.lowest),
                ("highest of the models", &c.highest),
            ] {
                series.push(Series {
                    name: name.into(),
                    points: decimate(points, 2000),
                    color: COLORS[2].into(),
                    markers: false,
                });
            }
        }
        let title = format!("{}: measured and predicted drift", c.column);
        let models = if c.lowest.is_empty() {
            ""
        } else {
            "; predicted: the median of the channel's models, drawn with the lowest and the highest of them"
        };
        s.push(Block::Figure {
            caption: format!("{title} (µm over min, since the log's start{models})."),
            svg: xy(&title, "t (min)", "drift (µm)", &series),
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

    #[test]
    fn a_log_fit_section_shows_each_channel_and_draws_the_simulated_step() {
        use crate::methods::thermal::ThermalLogFitDoc;
        use crate::methods::thermal::log::{
            Axis, ChannelModel, ChannelSpec, LengthUnit, LogData, LogInput, LogModel,
        };
        let doc: ThermalLogFitDoc = serde_json::from_value(serde_json::json!({
            "out": "m.toml", "period_min": 1.0, "samples": 100, "training_samples": 60,
            "heldout_samples": 45, "folds": 3,
            "inputs": [{"column": "speed_rpm", "rise": false, "scale": 5000.0}],
            "channels": [{"column": "ch1_um", "unit": "um", "axis": "X", "na": 1, "nb": 0,
                "inputs": ["speed_rpm", "t4_c"], "heldout_rms_mm": 0.0015,
                "heldout_drift_rms_mm": 0.006, "training_rms_mm": 0.0008, "output_error": true,
                "selection": []}],
            "test": {"from_min": 60.0, "samples": 40,
                "channels": [{"column": "ch1_um", "mae": 2.5, "error_over_drift_rms": 0.25}]},
            "notes": [], "warnings": ["ch1_um: large"]
        }))
        .unwrap();
        // A first-order model e(k) = 0.5·e(k−1) + 0.5·u(k−1) (mm, level input
        // 1 from sample 0): e(k) = 1 − 0.5^k mm = (1 − 0.5^k)·1000 µm.
        let spec = ChannelSpec {
            column: "ch1_um".into(),
            unit: LengthUnit::Um,
            axis: Axis::X,
        };
        let model = LogModel {
            period_min: 2.0,
            inputs: vec![LogInput {
                column: "u".into(),
                rise: false,
                square: false,
                over: None,
                scale: 1.0,
            }],
            channels: vec![ChannelModel {
                channel: spec,
                inputs: vec![0],
                a: vec![1.0, -0.5],
                b: vec![vec![0.5]],
                heldout_rms_mm: 0.0,
                heldout_drift_rms_mm: 0.0,
                training_rms_mm: 0.0,
                output_error: false,
                start_offset_mm: 0.0,
                members: Vec::new(),
            }],
        };
        let log = LogData {
            path: "LOG.csv".into(),
            period_min: 2.0,
            start_min: 0.0,
            channels: vec![vec![10.0, 11.0, 13.0, 12.0]],
            inputs: vec![vec![1.0; 4]],
            raw: Vec::new(),
            notes: Vec::new(),
        };
        let curves = log_curves(&model, &log).unwrap();
        assert_eq!(curves.len(), 1);
        assert_eq!(
            curves[0].measured,
            vec![(1.0, 0.0), (3.0, 1.0), (5.0, 3.0), (7.0, 2.0)]
        );
        for (k, &(t, v)) in curves[0].predicted.iter().enumerate() {
            assert_eq!(t, 2.0 * k as f64 + 1.0);
            let want = (1.0 - 0.5f64.powi(k as i32)) * 1000.0;
            assert!((v - want).abs() < 1e-9, "{k}: {v} vs {want}");
        }
        let s = log_section(&doc, &curves);
        let Block::Table(t) = &s.blocks[1] else {
            panic!("no model table")
        };
        // 0.0015 mm = 1.500 µm; 1.5 / 6 = 25.0 %; 0.0008 mm = 0.800 µm.
        assert_eq!(
            t.rows[0],
            vec![
                "ch1_um",
                "X",
                "1, 0",
                "speed_rpm, t4_c",
                "1.500",
                "25.0",
                "0.800",
                "yes"
            ]
        );
        let Block::Table(t) = &s.blocks[2] else {
            panic!("no test table")
        };
        assert_eq!(t.rows[0], vec!["ch1_um", "2.500", "0.250"]);
        // The search the document names is the one the text states.
        let text = |s: &Section| match &s.blocks[0] {
            Block::Text(t) => t.clone(),
            _ => panic!("no text first"),
        };
        assert!(text(&s).contains("chosen by forward selection and"));
        let mut exchange = doc.clone();
        exchange.search = crate::methods::thermal::log::InputSearch::Exchange;
        let s = log_section(&exchange, &curves);
        assert!(text(&s).contains("forward selection with exchanges and pairs"));
        let s = log_section(&doc, &curves);
        assert!(matches!(
            &s.blocks[3],
            Block::Verdict {
                verdict: Verdict::Caution,
                ..
            }
        ));
        let figures: Vec<&String> = s
            .blocks
            .iter()
            .filter_map(|b| match b {
                Block::Figure { svg, .. } => Some(svg),
                _ => None,
            })
            .collect();
        assert_eq!(figures.len(), 1);
        assert!(figures[0].contains("ch1_um: measured and predicted drift"));
        assert!(figures[0].contains("measured") && figures[0].contains("predicted"));
        // A member of half the gain: the prediction is the median of two
        // (the mean, 750·(1 − 0.5^k) µm), drawn between the member's 500·…
        // and the model's 1000·… µm.
        let mut two = model.clone();
        two.channels[0].members = vec![crate::methods::thermal::log::ChannelMember {
            folds: 2,
            inputs: vec![0],
            a: vec![1.0, -0.5],
            b: vec![vec![0.25]],
            heldout_rms_mm: 0.0,
            training_rms_mm: 0.0,
            output_error: false,
            start_offset_mm: 0.0,
        }];
        let c2 = log_curves(&two, &log).unwrap();
        for k in 0..4 {
            let f = 1.0 - 0.5f64.powi(k as i32);
            for (got, want) in [
                (c2[0].predicted[k].1, 750.0 * f),
                (c2[0].lowest[k].1, 500.0 * f),
                (c2[0].highest[k].1, 1000.0 * f),
            ] {
                assert!((got - want).abs() < 1e-9, "{k}: {got} vs {want}");
            }
        }
        assert!(curves[0].lowest.is_empty() && curves[0].highest.is_empty());
        let s2 = log_section(&doc, &c2);
        let fig = s2
            .blocks
            .iter()
            .find_map(|b| match b {
                Block::Figure { svg, caption } => Some((svg, caption)),
                _ => None,
            })
            .unwrap();
        assert!(fig.0.contains("lowest of the models") && fig.0.contains("highest of the models"));
        assert!(
            fig.1.contains("the median of the channel's models"),
            "{}",
            fig.1
        );
        // With members (several numbers of held-out blocks), a second table
        // lists them after the model table.
        let mut ensemble = doc.clone();
        ensemble.ensemble_folds = vec![2, 4];
        ensemble.channels[0].members = serde_json::from_value(serde_json::json!([
            {"folds": 2, "na": 0, "nb": 1, "inputs": ["t4_c"], "heldout_rms_mm": 0.002,
             "training_rms_mm": 0.001, "output_error": false},
            {"folds": 4, "na": 1, "nb": 1, "inputs": ["speed_rpm"], "heldout_rms_mm": 0.0025,
             "training_rms_mm": 0.0012, "output_error": true}
        ]))
        .unwrap();
        let s = log_section(&ensemble, &curves);
        let Block::Table(t) = &s.blocks[2] else {
            panic!("no members table")
        };
        assert!(
            t.caption.contains("chosen with 2, 4 held-out blocks"),
            "{}",
            t.caption
        );
        assert_eq!(
            t.rows,
            vec![
                vec!["ch1_um", "2", "0, 1", "t4_c", "2.000", "1.000", "no"],
                vec!["ch1_um", "4", "1, 1", "speed_rpm", "2.500", "1.200", "yes"],
            ]
        );
        // With the plain rises kept beside those over the ambient sensor the
        // caption says so, with or without other numbers of blocks.
        let members_caption =
            |doc: &crate::methods::thermal::ThermalLogFitDoc| match &log_section(doc, &curves)
                .blocks[2]
            {
                Block::Table(t) => t.caption.clone(),
                _ => panic!("no members table"),
            };
        ensemble.also_plain = true;
        let caption = members_caption(&ensemble);
        assert!(
            caption.contains("2, 4 held-out blocks, and its models of the plain rises"),
            "{caption}"
        );
        ensemble.ensemble_folds.clear();
        let caption = members_caption(&ensemble);
        assert!(
            caption
                .starts_with("The other models of each channel, and its models of the plain rises"),
            "{caption}"
        );
    }
}
