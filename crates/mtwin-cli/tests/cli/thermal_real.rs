//! The real record `../shared/data/real/fl-thermal-first60.csv` (a machine
//! tool's five displacement channels, spindle speed and sixteen
//! temperatures every 15 s): fitted on its first two thirds, the last third
//! predicted from the start of the record using the inputs alone. The mean
//! absolute errors are recomputed here from the predicted series against
//! the raw rows of the file (read independently), and must be the figures
//! of docs/thermal.md.

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

use mtwin::io::Table;
use mtwin::methods::thermal::log::{
    ChannelMember, ChannelSpec, InputRule, InputSpec, LogData, LogFitOptions, LogModel, at_time,
    fit_log, least_correlated_rise, predict_log, read_log,
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

/// The training span of every evaluation: the first 1 110 min (two thirds
/// of the file, a multiple of every period tried).
const TRAIN_UNTIL_MIN: f64 = 1110.0;

/// The fit of the first 1 110 min with `inputs` at periods of `period_min`.
#[derive(Clone)]
struct Evaluation {
    /// Per channel: MAE (µm) over the raw rows from 1 110 min on.
    mae: Vec<f64>,
    /// Per channel: error/drift RMS on the grid from 1 110 min on.
    ratio: Vec<f64>,
    /// Per channel: the held-out (cross-validation) RMS it was chosen by, µm.
    heldout_um: Vec<f64>,
    /// The model.
    model: Arc<LogModel>,
}

fn evaluate(path: &Path, inputs: &[&str], period_min: f64, folds: usize) -> Evaluation {
    try_evaluate(path, inputs, period_min, folds).unwrap()
}

/// [`try_evaluate`] with the default options.
fn try_evaluate(
    path: &Path,
    inputs: &[&str],
    period_min: f64,
    folds: usize,
) -> Result<Evaluation, String> {
    let mut options = LogFitOptions::default();
    options.folds = folds;
    try_evaluate_with(path, inputs, period_min, &options)
}

/// The evaluation with `options`, `Err` when the fit refuses (too few
/// training samples for the period). Each setting is fitted once per test
/// run: the tests that need the same fit (the lags row's candidates without
/// lags are the cross-validation row's) share it, the later one waiting for
/// the first.
fn try_evaluate_with(
    path: &Path,
    inputs: &[&str],
    period_min: f64,
    options: &LogFitOptions,
) -> Result<Evaluation, String> {
    type Slot = Arc<OnceLock<Result<Evaluation, String>>>;
    static FITS: OnceLock<Mutex<HashMap<String, Slot>>> = OnceLock::new();
    let key = format!("{} {inputs:?} {period_min} {options:?}", path.display());
    let slot = FITS
        .get_or_init(Default::default)
        .lock()
        .unwrap()
        .entry(key)
        .or_default()
        .clone();
    slot.get_or_init(|| fit_and_score(path, inputs, period_min, options))
        .clone()
}

/// The fit and its scores behind [`try_evaluate_with`].
fn fit_and_score(
    path: &Path,
    inputs: &[&str],
    period_min: f64,
    options: &LogFitOptions,
) -> Result<Evaluation, String> {
    let folds = options.folds;
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
    let n_train = (TRAIN_UNTIL_MIN / period_min).round() as usize;
    let start = std::time::Instant::now();
    let fit =
        fit_log(&log, &channels, &inputs, Some(n_train), options).map_err(|e| e.to_string())?;
    eprintln!(
        "{period_min} min, {folds} block(s), lags {}, rule {:?}: fit in {:.2} s: {:?}",
        options.lags,
        options.rule,
        start.elapsed().as_secs_f64(),
        fit.selection
    );
    let (mae, ratio) = score(path, &fit.model, &log, n_train);
    let heldout_um = fit
        .model
        .channels
        .iter()
        .map(|c| c.heldout_rms_mm * 1e3)
        .collect();
    eprintln!("MAE {mae:.3?} µm, error/drift RMS {ratio:.3?}, held-out {heldout_um:.3?} µm");
    Ok(Evaluation {
        mae,
        ratio,
        heldout_um,
        model: Arc::new(fit.model),
    })
}

/// Per channel of `model` predicting `log` (the record read at the model's
/// period, `n_train` training samples): the MAE over the raw rows from
/// 1 110 min on, and the error/drift RMS on the grid from `n_train` on.
fn score(path: &Path, model: &LogModel, log: &LogData, n_train: usize) -> (Vec<f64>, Vec<f64>) {
    let pred = predict_log(model, log).unwrap();
    let raw = raw_rows(path);
    let mut mae = Vec::new();
    let mut ratio = Vec::new();
    for (i, p) in pred.iter().enumerate() {
        let test: Vec<(f64, f64)> = raw
            .iter()
            .filter(|(t, _)| *t >= TRAIN_UNTIL_MIN)
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
    (mae, ratio)
}

/// Per channel, `alt` or `base` chosen by the lower cross-validation RMS
/// (`base` on a tie): 1 where `alt` is chosen (else 0), and the chosen
/// MAE and error/drift RMS.
fn choose_by_cross_validation(
    base: &Evaluation,
    alt: &Evaluation,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut chosen = Vec::new();
    let mut mae = Vec::new();
    let mut ratio = Vec::new();
    for ch in 0..CHANNELS.len() {
        let a = alt.heldout_um[ch] < base.heldout_um[ch];
        let e = if a { alt } else { base };
        chosen.push(if a { 1.0 } else { 0.0 });
        mae.push(e.mae[ch]);
        ratio.push(e.ratio[ch]);
    }
    (chosen, mae, ratio)
}

fn temperatures() -> Vec<String> {
    (1..=16).map(|i| format!("t{i}_c")).collect()
}

/// The candidates of the cross-validation row: the speed, its square and
/// the sixteen temperatures as rises.
fn speed_and_rises() -> Vec<String> {
    let mut inputs = vec!["speed_rpm".to_string(), "speed_rpm:square".to_string()];
    inputs.extend(temperatures());
    inputs
}

/// The speed, its square, the ambient sensor `tA_c` as its own rise and
/// every other temperature over it (what `--ambient` makes of
/// [`speed_and_rises`]).
fn speed_and_rises_over(ambient: usize) -> Vec<String> {
    let mut inputs = vec![
        "speed_rpm".to_string(),
        "speed_rpm:square".to_string(),
        format!("t{ambient}_c"),
    ];
    inputs.extend(rises_over(ambient));
    inputs
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
    let e = evaluate(&path, &["speed_rpm"], 1.0, 1);
    assert_documented("speed only, one block, MAE µm", &e.mae);
    assert_documented("speed only, one block, error/drift RMS", &e.ratio);
    let e = evaluate(&path, &["speed_rpm"], 1.0, 3);
    assert_documented("speed only, 3 held-out blocks, MAE µm", &e.mae);
    assert_documented("speed only, 3 held-out blocks, error/drift RMS", &e.ratio);
}

#[test]
fn real_record_last_third_with_temperatures() {
    let Some(path) = record() else { return };
    let mut inputs = vec!["speed_rpm".to_string()];
    inputs.extend(temperatures());
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let e = evaluate(&path, &inputs, 1.0, 1);
    assert_documented("speed + 16 temperatures, one block, MAE µm", &e.mae);
    assert_documented(
        "speed + 16 temperatures, one block, error/drift RMS",
        &e.ratio,
    );
    let e = evaluate(&path, &inputs, 1.0, 3);
    assert_documented("speed + 16 temperatures, 3 held-out blocks, MAE µm", &e.mae);
    assert_documented(
        "speed + 16 temperatures, 3 held-out blocks, error/drift RMS",
        &e.ratio,
    );
}

/// The same at 5-minute periods with one held-out block: the setting that
/// was chosen after seeing the test span (kept as the "before" figures).
#[test]
fn real_record_last_third_with_temperatures_at_five_minute_periods() {
    let Some(path) = record() else { return };
    let mut inputs = vec!["speed_rpm".to_string()];
    inputs.extend(temperatures());
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let e = evaluate(&path, &inputs, 5.0, 1);
    assert_documented(
        "speed + 16 temperatures, 5-min periods, one block, MAE µm",
        &e.mae,
    );
    assert_documented(
        "speed + 16 temperatures, 5-min periods, one block, error/drift RMS",
        &e.ratio,
    );
}

/// Every setting chosen on the training span alone: the speed, its square
/// and the sixteen temperatures as candidates, cross-validation over 3
/// held-out blocks (the default),
/// and per channel the period (1, 2, 5 or 10 min) whose cross-validation
/// RMS is lowest. The test span is looked at only to score the choice.
#[test]
fn real_record_last_third_with_every_setting_chosen_by_cross_validation() {
    let Some(path) = record() else { return };
    let inputs = speed_and_rises();
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    // 5- and 10-min periods leave 222 and 111 training samples: too few for
    // the default options' four blocks (the fit refuses), so they drop out.
    let (periods, runs): (Vec<f64>, Vec<Evaluation>) = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .filter_map(|p| try_evaluate(&path, &inputs, p, 3).ok().map(|e| (p, e)))
        .unzip();
    assert_eq!(periods, [1.0, 2.0]);
    let mut period = Vec::new();
    let mut mae = Vec::new();
    let mut ratio = Vec::new();
    for ch in 0..CHANNELS.len() {
        let best = (0..periods.len())
            .min_by(|&a, &b| runs[a].heldout_um[ch].total_cmp(&runs[b].heldout_um[ch]))
            .unwrap();
        period.push(periods[best]);
        mae.push(runs[best].mae[ch]);
        ratio.push(runs[best].ratio[ch]);
    }
    eprintln!("chosen periods {period:?}, MAE {mae:.3?}");
    assert_documented("chosen by cross-validation, period min", &period);
    assert_documented("chosen by cross-validation, MAE µm", &mae);
    assert_documented("chosen by cross-validation, error/drift RMS", &ratio);
}

/// The fits of `inputs` at 1-min periods with 2, 3, 4, 5 and 6 held-out
/// blocks, and the model `thermal fit --folds 2-6` assembles from them (the
/// 2-block model with the others as members).
fn five_cuts(path: &Path, inputs: &[String]) -> (Vec<Evaluation>, LogModel) {
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let runs: Vec<Evaluation> = (2..=6).map(|k| evaluate(path, &inputs, 1.0, k)).collect();
    let mut model = (*runs[0].model).clone();
    for (k, run) in (3..=6).zip(&runs[1..]) {
        for (c, m) in model.channels.iter_mut().zip(&run.model.channels) {
            c.members.push(ChannelMember::from_model(k, m));
        }
    }
    (runs, model)
}

/// `model`'s scores on the record read with the model's own inputs.
fn score_model(path: &Path, model: &LogModel) -> (Vec<f64>, Vec<f64>) {
    let channels: Vec<ChannelSpec> = model.channels.iter().map(|c| c.channel.clone()).collect();
    let specs: Vec<InputSpec> = model.inputs.iter().map(|i| i.spec()).collect();
    let log = read_log(&Table::read(path).unwrap(), &channels, &specs, 1.0).unwrap();
    score(path, model, &log, TRAIN_UNTIL_MIN as usize)
}

/// The candidates of the cross-validation row at 1-min periods, each
/// channel chosen and fitted with 2, 3, 4, 5 and 6 held-out blocks and
/// predicted by the per-sample median of the five models (`thermal fit
/// --folds 2-6`; the model assembled here from the five single fits, as
/// the fit assembles it: the 2-block model with the others as members).
/// Fixed before the test span was scored; the test span only scores.
#[test]
fn real_record_last_third_by_the_median_of_the_models_of_five_cuts() {
    let Some(path) = record() else { return };
    let inputs = speed_and_rises();
    let (runs, model) = five_cuts(&path, &inputs);
    let (mae, ratio) = score_model(&path, &model);
    eprintln!("median of five cuts: MAE {mae:.3?} µm, error/drift RMS {ratio:.3?}");
    for (k, run) in (2..=6).zip(&runs) {
        assert_documented(&format!("one cut, {k} held-out blocks, MAE µm"), &run.mae);
    }
    assert_documented("median of the models of 2…6 held-out blocks, MAE µm", &mae);
    assert_documented(
        "median of the models of 2…6 held-out blocks, error/drift RMS",
        &ratio,
    );
}

/// The same five cuts over the ambient sensor (`--folds 2-6 --ambient
/// auto`), then with the plain rises' five models kept beside them
/// (`--also-plain`: the model over the ambient sensor joined by the plain
/// one, ten models per channel, as `thermal fit` joins them). The test
/// span only scores.
#[test]
fn real_record_last_third_by_the_median_of_ten_models_of_both_kinds() {
    let Some(path) = record() else { return };
    let plain = speed_and_rises();
    let ambient = ambient_sensor(&path);
    let over = speed_and_rises_over(ambient);
    let (runs, over_model) = five_cuts(&path, &over);
    let (mae, ratio) = score_model(&path, &over_model);
    eprintln!("over ambient, median of five cuts: MAE {mae:.3?} µm, error/drift RMS {ratio:.3?}");
    for (k, run) in (2..=6).zip(&runs) {
        assert_documented(
            &format!("over the ambient sensor, one cut, {k} held-out blocks, MAE µm"),
            &run.mae,
        );
    }
    assert_documented(
        "over the ambient sensor, median of the models of 2…6 held-out blocks, MAE µm",
        &mae,
    );
    let (_, plain_model) = five_cuts(&path, &plain);
    let joined = over_model.join(&plain_model, 2).unwrap();
    assert_eq!(joined.inputs.len(), 3 + 15 + 15);
    assert!(joined.channels.iter().all(|c| c.members.len() == 9));
    let (mae, ratio) = score_model(&path, &joined);
    eprintln!("both kinds, median of ten: MAE {mae:.3?} µm, error/drift RMS {ratio:.3?}");
    assert_documented(
        "median of the ten models of both kinds, 2…6 held-out blocks, MAE µm",
        &mae,
    );
    assert_documented(
        "median of the ten models of both kinds, 2…6 held-out blocks, error/drift RMS",
        &ratio,
    );
}

/// The candidates of the last row, and sums of first-order lags offered
/// beside the ARX orders (`--lags`), with each input rule; per channel the
/// period (1 or 2 min) and whether lags are offered chosen by the lowest
/// cross-validation RMS. The test span only scores.
#[test]
fn real_record_last_third_with_lags_chosen_by_cross_validation() {
    let Some(path) = record() else { return };
    let inputs = speed_and_rises();
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let with = |lags: bool, rule: InputRule| {
        let mut o = LogFitOptions::default();
        o.lags = lags;
        o.rule = rule;
        o
    };
    let mut candidates = Vec::new();
    for period in [1.0, 2.0] {
        for lags in [false, true] {
            let e =
                try_evaluate_with(&path, &inputs, period, &with(lags, InputRule::Pooled)).unwrap();
            candidates.push(((period, lags), e));
        }
    }
    let mut period = Vec::new();
    let mut lags = Vec::new();
    let mut mae = Vec::new();
    let mut ratio = Vec::new();
    for ch in 0..CHANNELS.len() {
        let (setting, e) = candidates
            .iter()
            .min_by(|a, b| a.1.heldout_um[ch].total_cmp(&b.1.heldout_um[ch]))
            .unwrap();
        period.push(setting.0);
        lags.push(if setting.1 { 1.0 } else { 0.0 });
        mae.push(e.mae[ch]);
        ratio.push(e.ratio[ch]);
    }
    eprintln!("chosen periods {period:?}, lags {lags:?}, MAE {mae:.3?}");
    let every = try_evaluate_with(&path, &inputs, 1.0, &with(true, InputRule::EveryBlock)).unwrap();
    let lags_1 = &candidates[1].1;
    assert_documented("with lags, 3 held-out blocks, MAE µm", &lags_1.mae);
    assert_documented(
        "with lags, 3 held-out blocks, error/drift RMS",
        &lags_1.ratio,
    );
    assert_documented(
        "lags or not chosen by cross-validation, period min",
        &period,
    );
    assert_documented(
        "lags or not chosen by cross-validation, lags (1 = yes)",
        &lags,
    );
    assert_documented("lags or not chosen by cross-validation, MAE µm", &mae);
    assert_documented(
        "lags or not chosen by cross-validation, error/drift RMS",
        &ratio,
    );
    assert_documented("with lags, every block must gain, MAE µm", &every.mae);
    assert_documented(
        "with lags, every block must gain, error/drift RMS",
        &every.ratio,
    );
}

/// The candidates of the cross-validation row at 1-min periods with the
/// same-sign rule (an input is kept only when it lowers the error in every
/// held-out block and every input's static gain has one sign in every
/// block's fit), and per channel the rule (pooled, the cross-validation
/// row's 1-min fit, or same-sign) chosen by the lowest cross-validation RMS.
/// The test span only scores.
#[test]
fn real_record_last_third_with_the_same_sign_rule() {
    let Some(path) = record() else { return };
    let inputs = speed_and_rises();
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let pooled = try_evaluate(&path, &inputs, 1.0, 3).unwrap();
    let mut options = LogFitOptions::default();
    options.rule = InputRule::SameSign;
    let same = try_evaluate_with(&path, &inputs, 1.0, &options).unwrap();
    let (chosen, mae, ratio) = choose_by_cross_validation(&pooled, &same);
    eprintln!(
        "cross-validation RMS pooled {:.3?} / same-sign {:.3?} µm; same-sign chosen {chosen:?}, MAE {mae:.3?}",
        pooled.heldout_um, same.heldout_um
    );
    assert_documented("same-sign rule, 3 held-out blocks, MAE µm", &same.mae);
    assert_documented(
        "same-sign rule, 3 held-out blocks, error/drift RMS",
        &same.ratio,
    );
    assert_documented(
        "pooled or same-sign chosen by cross-validation, same-sign (1 = yes)",
        &chosen,
    );
    assert_documented(
        "pooled or same-sign chosen by cross-validation, MAE µm",
        &mae,
    );
    assert_documented(
        "pooled or same-sign chosen by cross-validation, error/drift RMS",
        &ratio,
    );
}

/// The ambient sensor of the record: the temperature least correlated with
/// the speed over the raw rows of the training span (the library's
/// `least_correlated_rise`, as `thermal fit --ambient auto` chooses it).
fn ambient_sensor(path: &Path) -> usize {
    let table = Table::read(path).unwrap();
    let mut inputs = vec![InputSpec::parse("speed_rpm").unwrap()];
    inputs.extend(temperatures().iter().map(|t| InputSpec::parse(t).unwrap()));
    let a = least_correlated_rise(&table, &inputs, Some(TRAIN_UNTIL_MIN)).unwrap();
    eprintln!(
        "ambient {} over {} rows: {:.3?}",
        a.column, a.rows, a.correlations
    );
    a.column
        .strip_prefix('t')
        .and_then(|c| c.strip_suffix("_c"))
        .and_then(|n| n.parse().ok())
        .unwrap()
}

/// Every temperature but `ambient` over it (`tN_c:over=tA_c`).
fn rises_over(ambient: usize) -> Vec<String> {
    (1..=16)
        .filter(|&i| i != ambient)
        .map(|i| format!("t{i}_c:over=t{ambient}_c"))
        .collect()
}

/// Temperatures as rises over an ambient sensor chosen on the training span
/// (the one least correlated with the speed), with the speed and its square,
/// 1-min periods, cross-validation over 3 held-out blocks; per channel the
/// plain rises (the cross-validation row's 1-min fit) or the rises over
/// ambient chosen by the lowest cross-validation RMS. The test span only
/// scores.
#[test]
fn real_record_last_third_with_rises_over_an_ambient_sensor() {
    let Some(path) = record() else { return };
    let inputs = speed_and_rises();
    let plain_inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let plain = try_evaluate(&path, &plain_inputs, 1.0, 3).unwrap();
    let ambient = ambient_sensor(&path);
    let inputs = speed_and_rises_over(ambient);
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let over = try_evaluate(&path, &inputs, 1.0, 3).unwrap();
    let (chosen, mae, ratio) = choose_by_cross_validation(&plain, &over);
    eprintln!(
        "ambient t{ambient}_c; cross-validation RMS plain {:.3?} / over ambient {:.3?} µm; chosen {chosen:?}, MAE {mae:.3?}",
        plain.heldout_um, over.heldout_um
    );
    assert_eq!(ambient, 1, "the ambient sensor chosen on the training span");
    assert_documented("rises over the ambient sensor, MAE µm", &over.mae);
    assert_documented(
        "rises over the ambient sensor, error/drift RMS",
        &over.ratio,
    );
    assert_documented(
        "plain or over ambient chosen by cross-validation, over ambient (1 = yes)",
        &chosen,
    );
    assert_documented(
        "plain or over ambient chosen by cross-validation, MAE µm",
        &mae,
    );
    assert_documented(
        "plain or over ambient chosen by cross-validation, error/drift RMS",
        &ratio,
    );
}

/// The record with one more column, `speed_on` (1 while the spindle turns,
/// 0 at rest; its period mean is the fraction of the period spent turning),
/// written to `dir`.
fn with_speed_on(path: &Path, dir: &Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let speed = header.split(',').position(|h| h == "speed_rpm").unwrap();
    let mut out = format!("{header},speed_on\n");
    for l in lines {
        let v: f64 = l.split(',').nth(speed).unwrap().parse().unwrap();
        out.push_str(&format!("{l},{}\n", u8::from(v > 0.0)));
    }
    let file = dir.join("speed-on.csv");
    std::fs::write(&file, out).unwrap();
    file
}

/// The candidates of the cross-validation row at 1-min periods and a
/// speed-on indicator (`speed_on:level`, a heat source that does not scale
/// with the speed, e.g. the drive and coolant once the spindle turns); per
/// channel with or without it chosen by the lowest cross-validation RMS. The
/// test span only scores.
#[test]
fn real_record_last_third_with_a_speed_on_indicator() {
    let Some(path) = record() else { return };
    let mut inputs = speed_and_rises();
    let plain_inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let plain = try_evaluate(&path, &plain_inputs, 1.0, 3).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = with_speed_on(&path, dir.path());
    inputs.insert(2, "speed_on:level".to_string());
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let on = try_evaluate(&file, &inputs, 1.0, 3).unwrap();
    let (chosen, mae, ratio) = choose_by_cross_validation(&plain, &on);
    eprintln!(
        "cross-validation RMS without {:.3?} / with speed-on {:.3?} µm; chosen {chosen:?}, MAE {mae:.3?}",
        plain.heldout_um, on.heldout_um
    );
    assert_documented("with a speed-on indicator, MAE µm", &on.mae);
    assert_documented("with a speed-on indicator, error/drift RMS", &on.ratio);
    assert_documented(
        "speed-on or not chosen by cross-validation, speed-on (1 = yes)",
        &chosen,
    );
    assert_documented("speed-on or not chosen by cross-validation, MAE µm", &mae);
    assert_documented(
        "speed-on or not chosen by cross-validation, error/drift RMS",
        &ratio,
    );
}

/// Both kinds of temperature inputs offered together (the sixteen plain
/// rises and the fifteen rises over the ambient sensor, with the speed and
/// its square); per channel this or the plain rises chosen by the lowest
/// cross-validation RMS. The test span only scores.
#[test]
fn real_record_last_third_with_plain_rises_and_rises_over_ambient() {
    let Some(path) = record() else { return };
    let mut inputs = speed_and_rises();
    let plain_inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let plain = try_evaluate(&path, &plain_inputs, 1.0, 3).unwrap();
    inputs.extend(rises_over(ambient_sensor(&path)));
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let both = try_evaluate(&path, &inputs, 1.0, 3).unwrap();
    let (chosen, mae, ratio) = choose_by_cross_validation(&plain, &both);
    eprintln!(
        "cross-validation RMS plain {:.3?} / both {:.3?} µm; chosen {chosen:?}, MAE {mae:.3?}",
        plain.heldout_um, both.heldout_um
    );
    assert_documented("plain rises and rises over ambient, MAE µm", &both.mae);
    assert_documented(
        "plain rises and rises over ambient, error/drift RMS",
        &both.ratio,
    );
    assert_documented(
        "plain or both chosen by cross-validation, both (1 = yes)",
        &chosen,
    );
    assert_documented("plain or both chosen by cross-validation, MAE µm", &mae);
    assert_documented(
        "plain or both chosen by cross-validation, error/drift RMS",
        &ratio,
    );
}
