//! The real record `../shared/data/real/fl-thermal-first60.csv` (a machine
//! tool's five displacement channels, spindle speed and sixteen
//! temperatures every 15 s): fitted on its first two thirds, the last third
//! predicted from the start of the record using the inputs alone. The mean
//! absolute errors are recomputed here from the predicted series against
//! the raw rows of the file (read independently), and must be the figures
//! of docs/thermal.md.

use std::path::Path;

use mtwin::io::Table;
use mtwin::methods::thermal::log::{
    ChannelSpec, InputSpec, LogFitOptions, at_time, fit_log, predict_log, read_log,
};

const CHANNELS: [&str; 5] = ["ch1_um", "ch2_um", "ch3_um", "ch4_um", "ch5_um"];

fn record() -> Option<std::path::PathBuf> {
    crate::shared::shared_dir("data/real/fl-thermal-first60.csv")
}

/// The raw rows of the file, read with nothing from the library: time (min)
/// and the five channels (µm).
fn raw_rows(path: &Path) -> Vec<(f64, [f64; 5])> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let t = header.iter().position(|h| *h == "t_s").unwrap();
    let cols: Vec<usize> = CHANNELS
        .iter()
        .map(|c| header.iter().position(|h| h == c).unwrap())
        .collect();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let mut v = [0.0; 5];
            for (o, &c) in v.iter_mut().zip(&cols) {
                *o = f[c].parse().unwrap();
            }
            (f[t].parse::<f64>().unwrap() / 60.0, v)
        })
        .collect()
}

/// Fit on the first two thirds with `inputs` at periods of `period_min`;
/// MAE (µm) per channel over the raw rows of the last third, and the
/// error/drift RMS per channel on the grid.
fn evaluate(path: &Path, inputs: &[&str], period_min: f64) -> (Vec<f64>, Vec<f64>) {
    let channels: Vec<ChannelSpec> = CHANNELS
        .iter()
        .map(|c| ChannelSpec::parse(&format!("{c}:Z")).unwrap())
        .collect();
    let inputs: Vec<InputSpec> = inputs
        .iter()
        .map(|c| InputSpec::parse(c).unwrap())
        .collect();
    let table = Table::read(path).unwrap();
    let log = read_log(&table, &channels, &inputs, period_min).unwrap();
    let n_train = (log.len() * 2) / 3;
    let start = std::time::Instant::now();
    let fit = fit_log(
        &log,
        &channels,
        &inputs,
        Some(n_train),
        &LogFitOptions::default(),
    )
    .unwrap();
    eprintln!(
        "fit in {:.2} s: {:?}",
        start.elapsed().as_secs_f64(),
        fit.selection
    );
    let pred = predict_log(&fit.model, &log).unwrap();
    let t_test = n_train as f64 * log.period_min;
    let raw = raw_rows(path);
    let mut mae = Vec::new();
    let mut ratio = Vec::new();
    for (i, p) in pred.iter().enumerate() {
        let test: Vec<(f64, f64)> = raw
            .iter()
            .filter(|(t, _)| *t >= t_test)
            .map(|(t, v)| (at_time(p, log.period_min, *t), v[i]))
            .collect();
        mae.push(test.iter().map(|(p, m)| (p - m).abs()).sum::<f64>() / test.len() as f64);
        let m = &log.channels[i];
        let sq = |f: &dyn Fn(usize) -> f64| {
            ((n_train..m.len()).map(|k| f(k).powi(2)).sum::<f64>() / (m.len() - n_train) as f64)
                .sqrt()
        };
        ratio.push(sq(&|k| p[k] - m[k]) / sq(&|k| m[k] - m[0]));
    }
    eprintln!("MAE {mae:.3?} µm, error/drift RMS {ratio:.3?}");
    (mae, ratio)
}

fn temperatures() -> Vec<String> {
    (1..=16).map(|i| format!("t{i}_c")).collect()
}

/// The five numbers of the docs/thermal.md table row starting `| {label} |`.
fn documented(label: &str) -> Vec<f64> {
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/thermal.md");
    let text = std::fs::read_to_string(&docs).unwrap();
    let start = format!("| {label} |");
    let line = text
        .lines()
        .find(|l| l.starts_with(&start))
        .unwrap_or_else(|| panic!("docs/thermal.md has no row `{start}`"));
    let v: Vec<f64> = line[start.len()..]
        .split('|')
        .filter(|c| !c.trim().is_empty())
        .map(|c| c.trim().parse().unwrap())
        .collect();
    assert_eq!(v.len(), 5, "{line}");
    v
}

fn assert_documented(label: &str, computed: &[f64]) {
    let want = documented(label);
    for (i, (c, w)) in computed.iter().zip(&want).enumerate() {
        assert!(
            (c - w).abs() <= 0.0051,
            "{label}, ch{}: computed {c:.4}, documented {w}",
            i + 1
        );
    }
}

#[test]
fn real_record_last_third_speed_only() {
    let Some(path) = record() else { return };
    let (mae, ratio) = evaluate(&path, &["speed_rpm"], 1.0);
    assert_documented("speed only, MAE µm", &mae);
    assert_documented("speed only, error/drift RMS", &ratio);
}

#[test]
fn real_record_last_third_with_temperatures() {
    let Some(path) = record() else { return };
    let mut inputs = vec!["speed_rpm".to_string()];
    inputs.extend(temperatures());
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let (mae, ratio) = evaluate(&path, &inputs, 1.0);
    assert_documented("speed + 16 temperatures, MAE µm", &mae);
    assert_documented("speed + 16 temperatures, error/drift RMS", &ratio);
}

/// The same at 5-minute periods (the training span ends at 1 110 min).
#[test]
fn real_record_last_third_with_temperatures_at_five_minute_periods() {
    let Some(path) = record() else { return };
    let mut inputs = vec!["speed_rpm".to_string()];
    inputs.extend(temperatures());
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let (mae, ratio) = evaluate(&path, &inputs, 5.0);
    assert_documented("speed + 16 temperatures, 5-min periods, MAE µm", &mae);
    assert_documented(
        "speed + 16 temperatures, 5-min periods, error/drift RMS",
        &ratio,
    );
}
