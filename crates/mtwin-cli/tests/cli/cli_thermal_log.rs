//! `mtwin thermal fit --log` and `thermal predict --log` end to end: a wide
//! log of a known machine (two first-order drifts, one driven by the spindle
//! speed along Z in µm, one by a temperature rise along X in mm, beside a
//! temperature that does not act) → fit → predict a new log from its inputs
//! alone → compared with the machine's exact drift; the documents through
//! JSON; bad input.

use crate::common::*;

use std::path::Path;

/// Poles of the two drifts per 1-min sample.
const P_SPEED: f64 = 0.95;
const P_TEMP: f64 = 0.9;
/// Static gains: µm per rev/min, mm per K of rise.
const G_SPEED: f64 = -0.004;
const G_TEMP: f64 = 0.002;

/// Inputs of the known machine for `n` minutes: speed held for 40 min at a
/// level of `levels`, a temperature rising towards +3 K with a 100-min time
/// constant (scaled by `warm`), a distractor temperature.
fn inputs(n: usize, levels: &[f64], warm: f64) -> Vec<[f64; 3]> {
    (0..n)
        .map(|k| {
            let kf = k as f64;
            [
                levels[(k / 40) % levels.len()],
                20.0 + warm * 3.0 * (1.0 - (-kf / 100.0).exp()) + 0.2 * (kf / 23.0).sin(),
                22.0 + 0.5 * (kf / 37.0).sin(),
            ]
        })
        .collect()
}

/// The exact drift of the machine (ARX with `nk = 1`: the input of minute
/// `k` acts from minute `k + 1`), from rest: `(speed drift µm, temperature
/// drift mm)` per minute.
fn truth(u: &[[f64; 3]]) -> Vec<(f64, f64)> {
    let (mut a, mut b) = (0.0, 0.0);
    let t0 = u[0][1];
    u.iter()
        .map(|r| {
            let now = (a, b);
            a = P_SPEED * a + (1.0 - P_SPEED) * G_SPEED * r[0];
            b = P_TEMP * b + (1.0 - P_TEMP) * G_TEMP * (r[1] - t0);
            now
        })
        .collect()
}

/// A log with one row per minute (`t_min`), with or without the drift columns.
fn log_csv(u: &[[f64; 3]], drift: Option<&[(f64, f64)]>) -> String {
    let mut s = String::from("t_min,speed_rpm,t1_c,t2_c");
    if drift.is_some() {
        s.push_str(",grow_um,shift_mm");
    }
    s.push('\n');
    for (k, r) in u.iter().enumerate() {
        s.push_str(&format!("{k},{},{},{}", r[0], r[1], r[2]));
        if let Some(d) = drift {
            s.push_str(&format!(",{},{}", d[k].0, d[k].1));
        }
        s.push('\n');
    }
    s
}

const FIT: [&str; 12] = [
    "thermal",
    "fit",
    "--log",
    "log.csv",
    "--drift",
    "grow_um:Z,shift_mm:X",
    "--inputs",
    "speed_rpm,t1_c,t2_c",
    "--train-until-min",
    "480",
    "--out",
    "log-model.toml",
];

fn setup(dir: &Path) -> Vec<[f64; 3]> {
    let u = inputs(600, &[0.0, 2000.0, 5000.0, 3500.0, 1000.0], 1.0);
    let d = truth(&u);
    std::fs::write(dir.join("log.csv"), log_csv(&u, Some(&d))).unwrap();
    u
}

/// `t_min` and the other columns of a CSV written by the tool.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn fit_log_then_predict_log_recovers_the_machine_on_a_new_log() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    setup(p);
    let (doc, v) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &FIT);
    assert_eq!(v["out"], "log-model.toml");
    assert_eq!((doc.samples, doc.training_samples), (600, 480));
    // By default chosen by cross-validation over 4 blocks of 120 samples:
    // the last three predicted in turn from the blocks before them.
    assert_eq!((doc.folds, doc.heldout_samples), (3, 360));
    let names: Vec<&str> = doc.channels.iter().map(|c| c.column.as_str()).collect();
    assert_eq!(names, ["grow_um", "shift_mm"]);
    // Each channel picks its own input first, and its model reproduces the
    // noise-free drift.
    assert_eq!(doc.channels[0].selection[0].input, "speed_rpm");
    assert_eq!(doc.channels[1].selection[0].input, "t1_c");
    for c in &doc.channels {
        assert!(c.heldout_rms_mm < 1e-7, "{c:?}");
    }
    // The test span: the last 120 minutes, predicted from the start.
    let t = doc.test.as_ref().unwrap();
    assert_eq!((t.from_min, t.samples), (480.0, 120));
    assert!(
        t.channels.iter().all(|s| s.error_over_drift_rms < 1e-4),
        "{t:?}"
    );
    assert!(doc.warnings.is_empty(), "{:?}", doc.warnings);

    // A new log, other speeds and a cooler machine, without the drift
    // columns: predicted from 0 with the inputs alone.
    let u = inputs(300, &[4500.0, 0.0, 3000.0], 0.5);
    let d = truth(&u);
    std::fs::write(p.join("new.csv"), log_csv(&u, None)).unwrap();
    let args = [
        "thermal",
        "predict",
        "--model",
        "log-model.toml",
        "--log",
        "new.csv",
        "--out",
        "pred.csv",
    ];
    let (pd, _) = json_round_trip::<mtwin::methods::thermal::ThermalLogPredictDoc>(p, &args);
    assert_eq!(pd.samples, 300);
    assert!(pd.channels.iter().all(|c| c.mae.is_none()));
    let (header, rows) = read_csv(&p.join("pred.csv"));
    assert_eq!(header, ["t_min", "grow_um", "shift_mm"]);
    assert_eq!(rows.len(), 300);
    let (mut largest_a, mut largest_b) = (0.0f64, 0.0f64);
    for (k, r) in rows.iter().enumerate() {
        // Period centres; µm for the first channel, mm for the second.
        assert!((r[0] - (k as f64 + 0.5)).abs() < 1e-12);
        assert!(
            (r[1] - d[k].0).abs() < 1e-3,
            "minute {k}: {} vs {}",
            r[1],
            d[k].0
        );
        assert!(
            (r[2] - d[k].1).abs() < 1e-6,
            "minute {k}: {} vs {}",
            r[2],
            d[k].1
        );
        largest_a = largest_a.max(d[k].0.abs());
        largest_b = largest_b.max(d[k].1.abs());
    }
    assert!((pd.channels[0].largest_abs_drift - largest_a).abs() < 1e-3);
    assert!((pd.channels[1].largest_abs_drift - largest_b).abs() < 1e-6);
}

/// `--folds 1`: one held-out block, the last third of the training samples
/// (160 of 480), and the same machine recovered.
#[test]
fn fit_log_with_one_held_out_block() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    setup(p);
    let mut a = FIT.to_vec();
    a.extend(["--folds", "1"]);
    let (doc, _) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &a);
    assert_eq!((doc.folds, doc.heldout_samples), (1, 160));
    for c in &doc.channels {
        assert!(c.heldout_rms_mm < 1e-7, "{c:?}");
    }
}

/// `--folds 2-4`: each channel chosen with 2, 3 and 4 held-out blocks,
/// the model file keeping all three models, the summary listing the
/// members, and the channel predicted by their median: every cut recovers
/// the known machine here, so the prediction is its drift.
#[test]
fn fit_log_with_several_fold_counts_keeps_every_model_and_predicts_their_median() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    setup(p);
    let mut a = FIT.to_vec();
    a.extend(["--folds", "2-4"]);
    let (doc, v) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &a);
    assert_eq!((doc.folds, doc.ensemble_folds.as_slice()), (2, &[3, 4][..]));
    assert_eq!(v["ensemble_folds"], serde_json::json!([3, 4]));
    for (c, input) in doc.channels.iter().zip(["speed_rpm", "t1_c"]) {
        let folds: Vec<usize> = c.members.iter().map(|m| m.folds).collect();
        assert_eq!(folds, [3, 4], "{c:?}");
        for m in &c.members {
            // Its own input first (the drift is noise-free: the others
            // may come with a negligible gain).
            assert_eq!(m.inputs[0], input, "{c:?}");
            assert!(m.heldout_rms_mm < 1e-7, "{c:?}");
        }
    }
    let t = doc.test.as_ref().unwrap();
    assert!(
        t.channels.iter().all(|s| s.error_over_drift_rms < 1e-4),
        "{t:?}"
    );
    let model = mtwin::methods::thermal::log::LogModel::read(&p.join("log-model.toml")).unwrap();
    assert!(model.channels.iter().all(|c| c.members.len() == 2));
    let o = mtwin(p, &a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.contains("also chosen with 3, 4 held-out blocks: predicted by the per-sample median of its 3 models"),
        "{text}"
    );
    assert_eq!(
        text.lines().filter(|l| l.starts_with("grow_um ")).count(),
        4,
        "{text}"
    );
    // A count given twice is refused before any work; a falling range by
    // the argument parser.
    std::fs::remove_file(p.join("log-model.toml")).unwrap();
    let mut a = FIT.to_vec();
    a.extend(["--folds", "3,2-3"]);
    expect_failure(p, &a, "3 is given twice", "log-model.toml");
    let mut a = FIT.to_vec();
    a.extend(["--folds", "4-2"]);
    let o = mtwin(p, &a);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("a range goes up"), "{}", stderr(&o));
}

/// `--lags --input-rule every-block`: sums of first-order lags offered beside
/// the ARX orders, an input kept only when it lowers the error in every
/// held-out block: the same machine recovered (its exact first-order ARX
/// model has no held-out error, so no lag structure can beat it), the
/// distractor temperature left out, a bad rule refused.
#[test]
fn fit_log_with_lags_and_the_every_block_rule() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    setup(p);
    let mut a = FIT.to_vec();
    a.extend(["--lags", "--input-rule", "every-block"]);
    let (doc, _) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &a);
    assert_eq!(doc.channels[0].selection[0].input, "speed_rpm");
    assert_eq!(doc.channels[1].selection[0].input, "t1_c");
    for c in &doc.channels {
        assert!(c.heldout_rms_mm < 1e-7, "{c:?}");
        assert!(c.selection.iter().all(|s| s.input != "t2_c"), "{c:?}");
    }
    let t = doc.test.as_ref().unwrap();
    assert!(
        t.channels.iter().all(|s| s.error_over_drift_rms < 1e-4),
        "{t:?}"
    );
    let mut bad = FIT.to_vec();
    bad.extend(["--input-rule", "median"]);
    let out = mtwin(p, &bad);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("every-block"), "{err}");
}

/// `--search exchange`: the forward steps already find the machine's
/// inputs, so no exchange lowers the held-out error and the same models are
/// chosen (exact, no held-out error); an unknown search is refused.
#[test]
fn fit_log_with_the_exchange_search() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    setup(p);
    let mut a = FIT.to_vec();
    a.extend(["--search", "exchange"]);
    let (doc, v) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &a);
    // The search is named in the document and the printed summary; the
    // default search is left out of both.
    assert_eq!(v["search"], "exchange");
    assert!(doc.to_string().contains("--search exchange"), "{doc}");
    let (plain, v) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &FIT);
    assert!(v.get("search").is_none(), "{v}");
    assert!(!plain.to_string().contains("exchange"), "{plain}");
    assert_eq!(doc.channels[0].selection[0].input, "speed_rpm");
    assert_eq!(doc.channels[1].selection[0].input, "t1_c");
    for c in &doc.channels {
        assert!(c.heldout_rms_mm < 1e-7, "{c:?}");
        assert!(
            c.selection
                .iter()
                .all(|s| s.input != "t2_c" && !s.input.contains(['>', '+'])),
            "{c:?}"
        );
    }
    let mut bad = FIT.to_vec();
    bad.extend(["--search", "beam"]);
    let out = mtwin(p, &bad);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("forward or exchange"), "{err}");
}

/// `--start-offset`: every sample after the first of both channels reads
/// high by a constant (0.5 µm on `grow_um`, 0.2 µm on `shift_mm`), as if
/// the first period mean (the base the drift is counted from) had read that
/// much low. With the flag each channel's model estimates that offset
/// (stored as `start_offset_mm`) and predicts the measured log; without it
/// the offset is 0.
#[test]
fn fit_log_with_the_start_offset() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let u = inputs(600, &[0.0, 2000.0, 5000.0, 3500.0, 1000.0], 1.0);
    let offsets = [0.5, 0.2e-3]; // µm, mm
    let d: Vec<(f64, f64)> = truth(&u)
        .iter()
        .enumerate()
        .map(|(k, &(a, b))| match k {
            0 => (a, b),
            _ => (a + offsets[0], b + offsets[1]),
        })
        .collect();
    std::fs::write(p.join("log.csv"), log_csv(&u, Some(&d))).unwrap();
    let mut a = FIT.to_vec();
    a.extend(["--lags", "--start-offset", "--input-rule", "same-sign"]);
    let (doc, _) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &a);
    let model = mtwin::methods::thermal::log::LogModel::read(&p.join("log-model.toml")).unwrap();
    let want_mm = [offsets[0] * 1e-3, offsets[1]];
    for (c, want) in model.channels.iter().zip(want_mm) {
        assert!(
            (c.start_offset_mm - want).abs() < 0.05 * want,
            "{}: {} vs {want} mm",
            c.channel.column,
            c.start_offset_mm
        );
    }
    // The test span (480 … 600 min) predicted with the offset: its error is
    // a small part of the drift there.
    let t = doc.test.as_ref().unwrap();
    assert!(
        t.channels.iter().all(|s| s.error_over_drift_rms < 0.02),
        "{t:?}"
    );
    // Without the flag no offset is estimated.
    let mut a = FIT.to_vec();
    a.push("--lags");
    mtwin_ok(p, &a);
    let model = mtwin::methods::thermal::log::LogModel::read(&p.join("log-model.toml")).unwrap();
    assert!(model.channels.iter().all(|c| c.start_offset_mm == 0.0));
}

#[test]
fn predict_log_scores_a_measured_column_against_its_rows() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    setup(p);
    let o = mtwin(p, &FIT);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // The training log itself, its drift columns present: the prediction
    // (exact on the grid) is placed at the period centres, so a row at the
    // start of minute k is read halfway between samples k − 1 and k (the
    // first row at sample 0): the MAE is the mean of |e_k − e_{k−1}| / 2.
    let u = inputs(600, &[0.0, 2000.0, 5000.0, 3500.0, 1000.0], 1.0);
    let d = truth(&u);
    let half_steps = |f: &dyn Fn(&(f64, f64)) -> f64| {
        d.windows(2)
            .map(|w| (f(&w[1]) - f(&w[0])).abs() / 2.0)
            .sum::<f64>()
            / d.len() as f64
    };
    let o = mtwin(
        p,
        &[
            "thermal",
            "predict",
            "--model",
            "log-model.toml",
            "--log",
            "log.csv",
            "--out",
            "pred.csv",
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let doc: mtwin::methods::thermal::ThermalLogPredictDoc =
        serde_json::from_str(&stdout(&o)).unwrap();
    let want = [half_steps(&|e| e.0), half_steps(&|e| e.1)];
    for (c, w) in doc.channels.iter().zip(want) {
        let mae = c.mae.unwrap();
        assert!(
            (mae - w).abs() < 1e-6 * w.max(1e-9) + 1e-9,
            "{}: {mae} vs {w}",
            c.column
        );
    }
}

#[test]
fn bad_logs_and_options_name_the_place_exit_1_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let u = setup(p);
    let d = truth(&u);
    let fit_args = |log: &'static str| -> Vec<&'static str> {
        let mut a = FIT.to_vec();
        a[3] = log;
        a
    };
    // A cell that is not a number: line 12 (the header is line 1), column 2.
    let mut bad = log_csv(&u, Some(&d));
    let mut lines: Vec<String> = bad.lines().map(String::from).collect();
    let mut cells: Vec<&str> = lines[11].split(',').collect();
    cells[1] = "fast";
    lines[11] = cells.join(",");
    bad = lines.join("\n") + "\n";
    std::fs::write(p.join("cell.csv"), &bad).unwrap();
    expect_failure(p, &fit_args("cell.csv"), "cell.csv:12:2:", "log-model.toml");
    // A gap of 5 minutes at 1-min periods (t = 96 … 99 left out): the
    // error names the row after it, t = 100, now line 98.
    let mut gap: Vec<String> = log_csv(&u, Some(&d)).lines().map(String::from).collect();
    gap.drain(97..101);
    std::fs::write(p.join("gap.csv"), gap.join("\n") + "\n").unwrap();
    expect_failure(p, &fit_args("gap.csv"), "gap.csv:98:", "log-model.toml");
    // A missing input column names the header line.
    let no_t2 = log_csv(&u, Some(&d)).replace("t2_c", "t9_c");
    std::fs::write(p.join("cols.csv"), no_t2).unwrap();
    expect_failure(p, &fit_args("cols.csv"), "cols.csv:1", "log-model.toml");
    // Options: a drift channel without an axis, a non-positive period.
    let mut a = FIT.to_vec();
    a[5] = "grow_um";
    expect_failure(p, &a, "--drift", "log-model.toml");
    let mut a = FIT.to_vec();
    a.extend(["--period-min", "0"]);
    expect_failure(p, &a, "period", "log-model.toml");
    let mut a = FIT.to_vec();
    a.extend(["--folds", "0"]);
    expect_failure(p, &a, "cross-validation blocks", "log-model.toml");
    // --log with --data, or --plot, is refused by the argument parser (exit 2).
    let mut a = FIT.to_vec();
    a.extend(["--data", "train.csv"]);
    assert_eq!(mtwin(p, &a).status.code(), Some(2));

    // Predict: a model that is not one, a log without an input column.
    std::fs::write(
        p.join("bad-model.toml"),
        "period_min = -1\ninputs = []\nchannels = []\n",
    )
    .unwrap();
    expect_failure(
        p,
        &[
            "thermal",
            "predict",
            "--model",
            "bad-model.toml",
            "--log",
            "log.csv",
            "--out",
            "pred.csv",
        ],
        "bad-model.toml",
        "pred.csv",
    );
    let o = mtwin(p, &FIT);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let no_speed = log_csv(&u, None).replace("speed_rpm", "spindle");
    std::fs::write(p.join("nospeed.csv"), no_speed).unwrap();
    expect_failure(
        p,
        &[
            "thermal",
            "predict",
            "--model",
            "log-model.toml",
            "--log",
            "nospeed.csv",
            "--out",
            "pred.csv",
        ],
        "nospeed.csv:1",
        "pred.csv",
    );
}

/// `mtwin report --thermal-log-fit`: the fit's document as a section, its
/// figures recomputed here from the saved document; with the model and the
/// log, one chart of measured against predicted drift per channel.
#[test]
fn report_shows_a_log_fit_with_measured_and_predicted_drift() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    setup(p);
    let mut a = FIT.to_vec();
    a.extend(["--format", "json"]);
    let o = mtwin(p, &a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::write(p.join("fit.json"), &o.stdout).unwrap();
    let doc: mtwin::methods::thermal::ThermalLogFitDoc = serde_json::from_slice(&o.stdout).unwrap();
    let o = mtwin(
        p,
        &[
            "report",
            "--out",
            "r.html",
            "--thermal-log-fit",
            "fit.json",
            "--thermal-log-model",
            "log-model.toml",
            "--thermal-log",
            "log.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let html = std::fs::read_to_string(p.join("r.html")).unwrap();
    assert!(html.contains("Thermal drift from a machine log"));
    for c in &doc.channels {
        assert!(html.contains(&c.column));
        assert!(html.contains(&c.inputs.join(", ")), "{:?}", c.inputs);
        for v in [c.heldout_rms_mm, c.training_rms_mm] {
            let cell = format!("{:.3}", v * 1e3);
            assert!(html.contains(&format!(">{cell}</td>")), "{cell}");
        }
        assert!(html.contains(&format!("{}: measured and predicted drift", c.column)));
    }
    let t = doc.test.as_ref().unwrap();
    for s in &t.channels {
        let cell = format!("{:.3}", s.error_over_drift_rms);
        assert!(html.contains(&format!(">{cell}</td>")), "{cell}");
    }
    let charts = html.matches("<svg").count();
    // Without the model and the log: the tables, no chart.
    let o = mtwin(
        p,
        &[
            "report",
            "--out",
            "r2.html",
            "--thermal-log-fit",
            "fit.json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let html = std::fs::read_to_string(p.join("r2.html")).unwrap();
    assert!(html.contains("Model per channel"));
    assert_eq!(charts - html.matches("<svg").count(), doc.channels.len());
}

// ---- thermal compensate with a log model ----

/// A log model (1-min periods) with the speed (scale 1000 rev/min) and
/// `t1_c` (its rise, scale 5 K) as inputs and one first-order channel per
/// `(column, axis, input index, pole, b in mm per scaled unit)`.
fn log_model_toml(channels: &[(&str, &str, usize, f64, f64)]) -> String {
    let mut s = String::from(
        "period_min = 1.0\n\n[[inputs]]\ncolumn = \"speed_rpm\"\nrise = false\nscale = 1000.0\n\n\
         [[inputs]]\ncolumn = \"t1_c\"\nrise = true\nscale = 5.0\n",
    );
    for (column, axis, input, pole, b) in channels {
        s.push_str(&format!(
            "\n[[channels]]\ninputs = [{input}]\na = [1.0, {}]\nb = [[{b:?}]]\nheldout_rms_mm = 0.0\n\
             heldout_drift_rms_mm = 0.0\ntraining_rms_mm = 0.0\noutput_error = false\n\n\
             [channels.channel]\ncolumn = \"{column}\"\nunit = \"um\"\naxis = \"{axis}\"\n",
            -pole
        ));
    }
    s
}

/// `t1_c` 20 °C in the first minute, 25 °C after, every 30 s for an hour.
fn temperature_log() -> String {
    let mut s = String::from("t_s,t1_c\n");
    for i in 0..=120 {
        s.push_str(&format!("{},{}\n", 30 * i, if i < 2 { 20.0 } else { 25.0 }));
    }
    s
}

/// Period means of the model's channels in closed form (sample `k`):
/// X after the 5 K step from period 1 (scaled rise 1), pole 0.8, b 0.002;
/// Z under 2000 rev/min from 0 (scaled 2), pole 0.9, b 0.001.
fn x_mean(k: usize) -> f64 {
    if k == 0 {
        0.0
    } else {
        0.002 * (1.0 - 0.8_f64.powi(k as i32 - 1)) / 0.2
    }
}

fn z_mean(k: usize) -> f64 {
    0.002 * (1.0 - 0.9_f64.powi(k as i32)) / 0.1
}

/// A grid series at `t` min: means at the period centres, linear between.
fn at_centres(mean: fn(usize) -> f64, t: f64) -> f64 {
    let k = (t - 0.5).floor() as usize;
    let f = t - 0.5 - k as f64;
    mean(k) + f * (mean(k + 1) - mean(k))
}

fn word_of(line: &str, letter: char) -> f64 {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(letter))
        .unwrap_or_else(|| panic!("no {letter} in `{line}`"))
        .parse()
        .unwrap()
}

const XZ: [(&str, &str, usize, f64, f64); 2] =
    [("dx_um", "X", 1, 0.8, 0.002), ("dz_um", "Z", 0, 0.9, 0.001)];

/// Moves well inside the 10-min correction periods (held at their middles:
/// 5, 15, 25 min), whatever the timing of the short moves.
const PART: &str = "G21 G90\nS2000 M3\nG4 P240\nG0 X10 Z-5\nG4 P600\nG1 X20 Y3 Z-10 F1000\nG4 P600\nG0 X0 Z0\nM30\n";

#[test]
fn compensate_with_a_log_model_corrects_x_and_z_by_the_closed_form_drift() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("m.toml"), log_model_toml(&XZ)).unwrap();
    std::fs::write(p.join("temps.csv"), temperature_log()).unwrap();
    std::fs::write(p.join("part.ngc"), PART).unwrap();
    let args = [
        "thermal",
        "compensate",
        "--model",
        "m.toml",
        "--inputs-log",
        "temps.csv",
        "--program",
        "part.ngc",
        "--out",
        "comp.ngc",
        "--format",
        "json",
    ];
    let o = mtwin(p, &args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = std::fs::read_to_string(p.join("comp.ngc")).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), PART.lines().count());
    for (line, x, z, t) in [
        (4, 10.0, -5.0, 5.0),
        (6, 20.0, -10.0, 15.0),
        (8, 0.0, 0.0, 25.0),
    ] {
        let text = lines[line - 1];
        let (ex, ez) = (at_centres(x_mean, t), at_centres(z_mean, t));
        assert!(ex > 0.005 && ez > 0.007, "{ex} {ez}");
        assert!(
            (word_of(text, 'X') - (x - ex)).abs() <= 0.5e-4 + 1e-12,
            "{text}: X − {ex}"
        );
        assert!(
            (word_of(text, 'Z') - (z - ez)).abs() <= 0.5e-4 + 1e-12,
            "{text}: Z − {ez}"
        );
    }
    // No Y channel: the Y word stays as written; every line without X/Z too.
    assert_eq!(word_of(lines[5], 'Y'), 3.0);
    for (a, b) in lines.iter().zip(PART.lines()) {
        if !b.contains('X') {
            assert_eq!(*a, b);
        }
    }
    let d: mtwin::methods::thermal::ThermalCompensateDoc =
        serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(d.axes.len(), 2);
    assert_eq!(
        (d.axes[0].axis.as_str(), d.axes[0].channel.as_str()),
        ("X", "dx_um")
    );
    assert_eq!(
        (d.axes[1].axis.as_str(), d.axes[1].blocks_changed),
        ("Z", 3)
    );
    let largest_z = at_centres(z_mean, 25.0) * 1e3;
    assert!((d.axes[1].max_correction_um - largest_z).abs() < 1e-9);
    assert_eq!(d.blocks_changed, 3);
    // Human output: one line per axis.
    let o = mtwin(p, &args[..args.len() - 2]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("X by dx_um: 3 of 3 X blocks changed"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn compensate_with_a_zero_log_model_is_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let zero: Vec<_> = [("dx_um", "X", 1), ("dy_um", "Y", 0), ("dz_um", "Z", 0)]
        .iter()
        .map(|&(c, a, i)| (c, a, i, 0.9, 0.0))
        .collect();
    std::fs::write(p.join("zero.toml"), log_model_toml(&zero)).unwrap();
    std::fs::write(p.join("temps.csv"), temperature_log()).unwrap();
    let src = "%\n(part)\r\nG21 G90 G17\nS3000 M3\nG0 X10.000 Y-3 Z5\nG1 Z-1.50 F200\nG2 X20 Y-3 I5 J0\nG91 G1 X1 Y1 Z-0.1\nG90 G53 G0 Z0\nG4 P900\nG0 X0.0 Y0.0\nM30\n%\n";
    std::fs::write(p.join("part.ngc"), src).unwrap();
    let o = mtwin(
        p,
        &[
            "thermal",
            "compensate",
            "--model",
            "zero.toml",
            "--inputs-log",
            "temps.csv",
            "--program",
            "part.ngc",
            "--out",
            "comp.ngc",
            "--continuous",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read(p.join("comp.ngc")).unwrap(), src.as_bytes());
}

#[test]
fn compensate_with_a_log_model_refuses_missing_inputs_and_axis_conflicts() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("m.toml"), log_model_toml(&XZ)).unwrap();
    let two_z = [("a_um", "Z", 0, 0.9, 0.001), ("b_um", "Z", 0, 0.5, 0.001)];
    std::fs::write(p.join("two-z.toml"), log_model_toml(&two_z)).unwrap();
    std::fs::write(p.join("temps.csv"), temperature_log()).unwrap();
    std::fs::write(p.join("bad.csv"), "t_s,t1_c\n0,20\n30,warm\n").unwrap();
    std::fs::write(p.join("part.ngc"), PART).unwrap();
    let run = |extra: &[&str]| -> Vec<String> {
        let mut a: Vec<String> = [
            "thermal",
            "compensate",
            "--program",
            "part.ngc",
            "--out",
            "comp.ngc",
        ]
        .map(String::from)
        .to_vec();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let fail = |extra: &[&str], message: &str| {
        let a = run(extra);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        expect_failure(p, &a, message, "comp.ngc");
    };
    // The X channel takes t1_c: the program alone does not define it.
    fail(
        &["--model", "m.toml"],
        "m.toml: the thermal model's channel(s) dx_um use the input(s) t1_c",
    );
    fail(&["--model", "m.toml"], "(--inputs-log FILE.csv)");
    // Two channels on Z, none named.
    fail(
        &["--model", "two-z.toml"],
        "channels `a_um` and `b_um` both act on Z",
    );
    fail(
        &["--model", "two-z.toml", "--channel", "c_um"],
        "the model has no channel `c_um`",
    );
    fail(
        &["--model", "two-z.toml", "--channel", "a_um,b_um"],
        "both act on Z",
    );
    // A bad inputs log at its line and column.
    fail(
        &["--model", "m.toml", "--inputs-log", "bad.csv"],
        "bad.csv:3:",
    );
    // Log-model flags with a height model.
    std::fs::write(
        p.join("height.toml"),
        "period_min = 10.0\n\n[[inputs]]\nname = \"speed_rpm\"\nscale = 1000.0\n\n[[heights]]\nz_mm = 0.0\na = [1.0, -0.5]\nb = [[0.001]]\nnk = [1]\n",
    )
    .unwrap();
    fail(
        &["--model", "height.toml", "--inputs-log", "temps.csv"],
        "--inputs-log is for a log model",
    );
    // Naming one channel of the axis compensates with it; the Z channel of
    // the X/Z model takes the speed alone and needs no inputs log.
    for extra in [
        &["--model", "two-z.toml", "--channel", "b_um"][..],
        &["--model", "m.toml", "--channel", "dz_um"],
    ] {
        let a = run(extra);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = mtwin(p, &a);
        assert_eq!(o.status.code(), Some(0), "{extra:?}: {}", stderr(&o));
        std::fs::remove_file(p.join("comp.ngc")).unwrap();
    }
    let o = mtwin(p, &["thermal", "compensate", "--help"]);
    assert!(stdout(&o).contains("--inputs-log") && stdout(&o).contains("--channel"));
}

#[test]
fn compensate_with_a_short_inputs_log_holds_its_last_values_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("m.toml"), log_model_toml(&XZ)).unwrap();
    // Four minutes of temperatures (20 °C, then 25 °C); a 24-min program.
    let short: String = temperature_log()
        .lines()
        .take(9)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(p.join("short.csv"), short).unwrap();
    std::fs::write(p.join("part.ngc"), PART).unwrap();
    let o = mtwin(
        p,
        &[
            "thermal",
            "compensate",
            "--model",
            "m.toml",
            "--inputs-log",
            "short.csv",
            "--program",
            "part.ngc",
            "--out",
            "comp.ngc",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the inputs log covers 4 min"),
        "{}",
        stderr(&o)
    );
    // Held at 25 °C: the same closed form as the full log.
    let out = std::fs::read_to_string(p.join("comp.ngc")).unwrap();
    let x = word_of(out.lines().nth(7).unwrap(), 'X');
    assert!(
        (x - (0.0 - at_centres(x_mean, 25.0))).abs() <= 0.5e-4 + 1e-12,
        "{x}"
    );
}

/// A machine whose drift follows how much warmer than the room one of its
/// sensors has become: the room (`room_c`) swings ±2 K over the day,
/// unrelated to the spindle; the spindle housing (`housing_c`) follows the
/// room plus a warm-up that the spindle drives (first order, 60-min time
/// constant, 1 K per 1000 rev/min); the drift along Z is
/// `G_TEMP`·(rise of housing − room), through a first-order lag `P_TEMP`.
/// A third sensor (`bed_c`) follows the room with a small part of the
/// warm-up. Per minute: `(speed, room, housing, bed, drift mm)`.
fn room_machine(n: usize, levels: &[f64], phase: f64) -> Vec<[f64; 5]> {
    let (mut warm, mut e) = (0.0, 0.0);
    let mut first = None;
    (0..n)
        .map(|k| {
            let kf = k as f64;
            let speed = levels[(k / 50) % levels.len()];
            let room = 20.0 + 2.0 * (kf / 180.0 + phase).sin();
            let housing = room + warm;
            let bed = room + 0.2 * warm;
            let over = housing - room;
            let over0 = *first.get_or_insert(over);
            let row = [speed, room, housing, bed, e];
            warm += (speed / 1000.0 - warm) / 60.0;
            e = P_TEMP * e + (1.0 - P_TEMP) * G_TEMP * (over - over0);
            row
        })
        .collect()
}

/// `thermal fit` of `log.csv` (a [`room_log`]): its drift and inputs.
const ROOM_FIT: [&str; 8] = [
    "thermal",
    "fit",
    "--log",
    "log.csv",
    "--drift",
    "z_mm:Z",
    "--inputs",
    "speed_rpm,room_c,housing_c,bed_c",
];

fn room_log(rows: &[[f64; 5]], with_drift: bool) -> String {
    let mut s = String::from("t_min,speed_rpm,room_c,housing_c,bed_c");
    s.push_str(if with_drift { ",z_mm\n" } else { "\n" });
    for (k, r) in rows.iter().enumerate() {
        s.push_str(&format!("{k},{},{},{},{}", r[0], r[1], r[2], r[3]));
        if with_drift {
            s.push_str(&format!(",{}", r[4]));
        }
        s.push('\n');
    }
    s
}

/// `--ambient auto` takes the temperature least correlated with the speed
/// (the room, correlations recomputed here), offers the others over it,
/// the housing over the room is selected first and recovers the machine;
/// the model file keeps `over`, and `thermal predict --log` reproduces the
/// exact drift of a new day from its temperatures alone. `--ambient
/// housing_c` names one itself; an ambient that is not an input is refused.
#[test]
fn fit_log_with_temperatures_over_an_ambient_sensor() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let rows = room_machine(600, &[0.0, 3000.0, 1000.0, 5000.0, 0.0, 2000.0], 0.0);
    std::fs::write(p.join("log.csv"), room_log(&rows, true)).unwrap();
    let args = [
        &ROOM_FIT[..],
        &[
            "--ambient",
            "auto",
            "--train-until-min",
            "480",
            "--out",
            "m.toml",
        ],
    ]
    .concat();
    let (doc, _) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &args);
    // |r| with the speed over the 480 training rows, computed here.
    let corr = |j: usize| {
        let pairs: Vec<(f64, f64)> = rows[..480].iter().map(|r| (r[j], r[0])).collect();
        let n = pairs.len() as f64;
        let (ma, mb) = pairs
            .iter()
            .fold((0.0, 0.0), |(x, y), (a, b)| (x + a / n, y + b / n));
        let (sab, saa, sbb) = pairs.iter().fold((0.0, 0.0, 0.0), |(s, t, u), (a, b)| {
            (
                s + (a - ma) * (b - mb),
                t + (a - ma).powi(2),
                u + (b - mb).powi(2),
            )
        });
        (sab / (saa * sbb).sqrt()).abs()
    };
    let (room, housing, bed) = (corr(1), corr(2), corr(3));
    assert!(room < bed && room < housing, "{room} {housing} {bed}");
    let a = doc
        .ambient
        .as_ref()
        .expect("the ambient choice is in the document");
    assert_eq!(
        (a.column.as_str(), a.against.as_str(), a.rows),
        ("room_c", "speed_rpm", 480)
    );
    for (name, r) in [("room_c", room), ("housing_c", housing), ("bed_c", bed)] {
        let got = a.correlations.iter().find(|(c, _)| c == name).unwrap().1;
        assert!((got - r).abs() < 1e-9, "{name}: {got} vs {r}");
    }
    let names: Vec<String> = doc.inputs.iter().map(|i| i.name()).collect();
    assert_eq!(
        names,
        [
            "speed_rpm",
            "room_c",
            "housing_c:over=room_c",
            "bed_c:over=room_c"
        ]
    );
    let c = &doc.channels[0];
    assert_eq!(c.selection[0].input, "housing_c:over=room_c");
    assert!(c.heldout_rms_mm < 1e-7, "{c:?}");
    let model = std::fs::read_to_string(p.join("m.toml")).unwrap();
    assert!(model.contains("over = \"room_c\""), "{model}");
    // A new day, another phase of the room and other speeds, no drift
    // column: predicted from its inputs alone.
    let new = room_machine(300, &[4000.0, 0.0, 2500.0], 1.3);
    std::fs::write(p.join("new.csv"), room_log(&new, false)).unwrap();
    let o = mtwin(
        p,
        &[
            "thermal", "predict", "--model", "m.toml", "--log", "new.csv", "--out", "pred.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (_, pred) = read_csv(&p.join("pred.csv"));
    assert_eq!(pred.len(), 300);
    for (k, r) in pred.iter().enumerate() {
        assert!(
            (r[1] - new[k][4]).abs() < 1e-6,
            "minute {k}: {} vs {}",
            r[1],
            new[k][4]
        );
    }
    // Without the room's column the prediction is refused at the header.
    let no_room = room_log(&new, false).replace("room_c", "hall_c");
    std::fs::write(p.join("noroom.csv"), no_room).unwrap();
    expect_failure(
        p,
        &[
            "thermal",
            "predict",
            "--model",
            "m.toml",
            "--log",
            "noroom.csv",
            "--out",
            "pred2.csv",
        ],
        "noroom.csv:1",
        "pred2.csv",
    );
    // `thermal compensate` reads the inputs the same way: without an
    // inputs log both columns are named; with one, the program is the one
    // a model of the difference written out as its own column gives.
    std::fs::write(p.join("part.ngc"), PART).unwrap();
    let comp = |model: &str, log: Option<&str>, out: &str| {
        let mut a = vec![
            "thermal",
            "compensate",
            "--program",
            "part.ngc",
            "--model",
            model,
        ];
        if let Some(l) = log {
            a.extend(["--inputs-log", l]);
        }
        a.extend(["--out", out]);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let a = comp("m.toml", None, "c0.ngc");
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    expect_failure(p, &a, "use the input(s) housing_c, room_c", "c0.ngc");
    let diff_model = model.replace(
        "column = \"housing_c\"\nrise = true\nsquare = false\nover = \"room_c\"",
        "column = \"diff_c\"\nrise = true\nsquare = false",
    );
    assert_ne!(
        diff_model, model,
        "the model file's input table changed: {model}"
    );
    std::fs::write(p.join("diff.toml"), diff_model).unwrap();
    let mut diff_log = String::from("t_min,speed_rpm,diff_c\n");
    for (k, r) in new.iter().enumerate() {
        diff_log.push_str(&format!("{k},{},{}\n", r[0], r[2] - r[1]));
    }
    std::fs::write(p.join("diff.csv"), diff_log).unwrap();
    for (m, l, out) in [
        ("m.toml", "new.csv", "c1.ngc"),
        ("diff.toml", "diff.csv", "c2.ngc"),
    ] {
        let a = comp(m, Some(l), out);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = mtwin(p, &a);
        assert_eq!(o.status.code(), Some(0), "{a:?}: {}", stderr(&o));
    }
    let (c1, c2) = (
        std::fs::read_to_string(p.join("c1.ngc")).unwrap(),
        std::fs::read_to_string(p.join("c2.ngc")).unwrap(),
    );
    assert_eq!(c1, c2);
    assert_ne!(c1, PART, "the drift is corrected");
    // Naming the ambient sensor; one that is not an input is refused.
    let mut named = args.to_vec();
    named[9] = "housing_c";
    named[13] = "m2.toml";
    let (doc, _) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &named);
    let names: Vec<String> = doc.inputs.iter().map(|i| i.name()).collect();
    assert_eq!(
        names,
        [
            "speed_rpm",
            "room_c:over=housing_c",
            "housing_c",
            "bed_c:over=housing_c"
        ]
    );
    named[9] = "hall_c";
    named[13] = "m3.toml";
    expect_failure(
        p,
        &named,
        "the ambient sensor `hall_c` must be one of the inputs",
        "m3.toml",
    );
    named[9] = "speed_rpm";
    expect_failure(p, &named, "the ambient sensor `speed_rpm`", "m3.toml");
}

/// `--also-plain` keeps, beside each channel's model over the ambient
/// sensor, its model of the plain rises: the model file holds the inputs of
/// both (the shared ones once) and each channel is predicted by the median
/// of the two, here their mean, computed from the two models fitted apart.
/// With one input and one pole per channel the plain fit can take neither
/// the housing over the room nor the speed through both lags, so the two
/// predictions differ. Without `--ambient` the flag is refused.
#[test]
fn fit_log_with_the_plain_rises_kept_beside_those_over_the_ambient_sensor() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let rows = room_machine(600, &[0.0, 3000.0, 1000.0, 5000.0, 0.0, 2000.0], 0.0);
    std::fs::write(p.join("log.csv"), room_log(&rows, true)).unwrap();
    let new = room_machine(300, &[4000.0, 0.0, 2500.0], 1.3);
    std::fs::write(p.join("new.csv"), room_log(&new, false)).unwrap();
    let fit = |extra: &[&str], out: &str| {
        let mut a = ROOM_FIT.to_vec();
        a.extend([
            "--max-inputs",
            "1",
            "--max-order",
            "1",
            "--train-until-min",
            "480",
            "--out",
            out,
        ]);
        a.extend(extra);
        let a: Vec<String> = a.into_iter().map(String::from).collect();
        a
    };
    let predict = |model: &str, out: &str| {
        let o = mtwin(
            p,
            &[
                "thermal", "predict", "--model", model, "--log", "new.csv", "--out", out,
            ],
        );
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        read_csv(&p.join(out)).1
    };
    for (extra, out) in [
        (&["--ambient", "auto"][..], "over.toml"),
        (&[][..], "plain.toml"),
    ] {
        let a = fit(extra, out);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = mtwin(p, &a);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let a = fit(&["--ambient", "auto", "--also-plain"], "both.toml");
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let (doc, v) = json_round_trip::<mtwin::methods::thermal::ThermalLogFitDoc>(p, &a);
    assert!(doc.also_plain && v["also_plain"] == true);
    let names: Vec<String> = doc.inputs.iter().map(|i| i.name()).collect();
    assert_eq!(
        names,
        [
            "speed_rpm",
            "room_c",
            "housing_c:over=room_c",
            "bed_c:over=room_c",
            "housing_c",
            "bed_c"
        ]
    );
    let c = &doc.channels[0];
    assert_eq!(c.inputs, ["housing_c:over=room_c"]);
    assert_eq!(c.members.len(), 1);
    assert_eq!(c.members[0].inputs.len(), 1);
    assert!(!c.members[0].inputs[0].contains("over="), "{c:?}");
    let human = stdout(&mtwin(p, &a));
    assert!(
        human.contains("median of its 2 models of both kinds"),
        "{human}"
    );
    let (over, plain, both) = (
        predict("over.toml", "over.csv"),
        predict("plain.toml", "plain.csv"),
        predict("both.toml", "both.csv"),
    );
    assert_eq!(both.len(), 300);
    assert!(
        over.iter()
            .zip(&plain)
            .any(|(o, q)| (o[1] - q[1]).abs() > 1e-3 * (o[1].abs() + 1e-6)),
        "the two kinds predict the same: {:?} {:?}",
        &over[..5],
        &plain[..5]
    );
    for (k, ((o, q), j)) in over.iter().zip(&plain).zip(&both).enumerate() {
        let mean = 0.5 * (o[1] + q[1]);
        assert!(
            (j[1] - mean).abs() <= 1e-9 * (1.0 + mean.abs()),
            "minute {k}: {} vs {mean}",
            j[1]
        );
    }
    // Without --ambient there is nothing to keep the plain rises beside.
    let a = fit(&["--also-plain"], "none.toml");
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let o = mtwin(p, &a);
    assert_ne!(o.status.code(), Some(0));
    assert!(stderr(&o).contains("--ambient"), "{}", stderr(&o));
    assert!(!p.join("none.toml").exists());
}

/// The flags of a wide log are refused with `--data` (never silently
/// ignored): exit 1, the flag named, no model written.
#[test]
fn log_only_flags_are_refused_without_a_log() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("train.csv"),
        "t_min,speed_rpm,z_mm,drift_mm\n0,0,0,0\n10,1000,0,0.001\n",
    )
    .unwrap();
    for extra in [
        &["--drift", "a_um:Z"][..],
        &["--inputs", "t1_c"],
        &["--period-min", "2"],
        &["--train-until-min", "5"],
        &["--max-inputs", "2"],
        &["--folds", "2"],
        &["--lags"],
        &["--input-rule", "same-sign"],
        &["--search", "exchange"],
        &["--start-offset"],
        &["--ambient", "auto"],
    ] {
        let mut a = vec!["thermal", "fit", "--data", "train.csv", "--out", "m.toml"];
        a.extend(extra);
        expect_failure(
            p,
            &a,
            &format!("{} applies to a wide log (--log LOG.csv)", extra[0]),
            "m.toml",
        );
    }
}
