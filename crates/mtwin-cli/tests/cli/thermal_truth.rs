//! End to end through the contract files: a synthetic two-time-constant machine
//! is "measured" at four heights on constant-speed and speed-step runs
//! (TRAIN.csv), the model is fitted, written, read back, and predicts a
//! cutting-like speed programme (SPEED.csv) at heights between the measured
//! ones; the prediction is compared with the machine's true drift.

use std::path::Path;

use mtwin::methods::thermal::{
    SpeedModel, ThermalFitOptions, TruthMachine, fit_csv, predict, read_model, read_programme,
};
use rand::{Rng, SeedableRng, rngs::StdRng};

const MEASURED: [f64; 4] = [-50.0, -150.0, -250.0, -350.0];
const BETWEEN: [f64; 3] = [-100.0, -200.0, -300.0];

fn training_runs() -> Vec<(&'static str, Vec<f64>)> {
    let steps = [2000.0, 6000.0, 0.0, 8000.0, 4000.0, 1000.0, 7000.0, 3000.0];
    vec![
        ("const4000", vec![4000.0; 48]),
        ("const8000", vec![8000.0; 48]),
        ("steps", steps.iter().flat_map(|&s| [s; 6]).collect()),
    ]
}

/// Six hours of speeds changing every 20 to 40 min, as a cutting job would.
fn cutting(seed: u64) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    let levels = [0.0, 1500.0, 3000.0, 4500.0, 6000.0, 7500.0];
    let mut out = Vec::new();
    while out.len() < 36 {
        let s = levels[rng.gen_range(0..levels.len())];
        let hold = rng.gen_range(2..=4);
        out.extend(std::iter::repeat_n(s, hold));
    }
    out.truncate(36);
    out
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n as f64).sqrt()
}

/// Fit on `machine`'s training runs, predict the cutting run between the
/// measured heights; returns error RMS / drift RMS.
fn relative_error(machine: &TruthMachine, noise_mm: f64, seed: u64, dir: &Path) -> f64 {
    relative_error_with(machine, noise_mm, seed, dir, SpeedModel::Linear).0
}

/// [`relative_error`] with a speed model; also returns the fit's choice
/// (`Some(true)`: quadratic) when `speed_model` is auto.
fn relative_error_with(
    machine: &TruthMachine,
    noise_mm: f64,
    seed: u64,
    dir: &Path,
    speed_model: SpeedModel,
) -> (f64, Option<bool>) {
    let train = dir.join("TRAIN.csv");
    std::fs::write(
        &train,
        machine.training_csv(&training_runs(), &MEASURED, noise_mm, seed),
    )
    .unwrap();
    let options = ThermalFitOptions {
        speed_model,
        ..ThermalFitOptions::default()
    };
    let fit = fit_csv(&train, &options).unwrap();
    assert!(fit.warnings.is_empty(), "{:?}", fit.warnings);
    assert_eq!(fit.runs, 3);
    assert_eq!(fit.model.heights().len(), 4);
    let json = fit.to_json();
    assert_eq!(json["heights"].as_array().unwrap().len(), 4);
    assert_eq!(json["heights"][0]["z_mm"], -350.0);
    let quadratic = fit.model.inputs().len() == 2;
    // na 1..4 × nb 0..4 per input.
    let grid = if quadratic { 4 * 5 * 5 } else { 4 * 5 };
    assert_eq!(json["heights"][0]["grid"].as_array().unwrap().len(), grid);
    let choice = fit.speed_model.as_ref().map(|c| c.quadratic);
    assert_eq!(choice.is_some(), speed_model == SpeedModel::Auto);
    if let Some(c) = &fit.speed_model {
        assert_eq!(c.quadratic, quadratic);
        assert_eq!(json["speed_model"]["folds"], 3);
        eprintln!("{}", c.summary());
    }
    let model_path = dir.join("THERMAL.toml");
    fit.model.write(&model_path).unwrap();
    let model = read_model(&model_path).unwrap();
    assert_eq!(model, fit.model, "the model file must read back exactly");

    let speeds = cutting(seed + 100);
    let speed_path = dir.join("SPEED.csv");
    let mut text = String::from("t_min,speed_rpm\n");
    for (k, s) in speeds.iter().enumerate() {
        text.push_str(&format!("{},{s}\n", k as f64 * 10.0));
    }
    std::fs::write(&speed_path, text).unwrap();
    let programme = read_programme(&speed_path, &model).unwrap();
    let pred = predict(&model, &programme, &BETWEEN);
    assert!(pred.extrapolated.is_empty());
    assert_eq!(pred.rows.len(), speeds.len() * BETWEEN.len());
    let truth: Vec<Vec<f64>> = BETWEEN.iter().map(|&z| machine.drift(&speeds, z)).collect();
    let mut err = Vec::new();
    let mut drift = Vec::new();
    for (i, row) in pred.rows.iter().enumerate() {
        let (k, h) = (i / BETWEEN.len(), i % BETWEEN.len());
        assert_eq!((row[0], row[1]), (k as f64 * 10.0, BETWEEN[h]));
        err.push(row[2] - truth[h][k]);
        drift.push(truth[h][k]);
    }
    (rms(err.into_iter()) / rms(drift.into_iter()), choice)
}

#[test]
fn predicts_held_out_cutting_between_heights_within_15_percent() {
    let dir = tempfile::tempdir().unwrap();
    let machine = TruthMachine::demo();
    for seed in [1, 2, 3] {
        let r = relative_error(&machine, 0.0005, seed, dir.path());
        eprintln!("linear heat, 0.5 µm noise, seed {seed}: error RMS / drift RMS = {r:.4}");
        assert!(r <= 0.15, "seed {seed}: {r}");
    }
}

#[test]
fn tolerates_heat_growing_faster_than_speed() {
    // Bearing friction heat grows faster than linearly with speed: the linear
    // ARX model is then only an approximation, and must still hold 15 %.
    let dir = tempfile::tempdir().unwrap();
    let machine = TruthMachine {
        speed_exponent: 1.2,
        ..TruthMachine::demo()
    };
    let r = relative_error(&machine, 0.0005, 11, dir.path());
    eprintln!("heat ~ n^1.2: error RMS / drift RMS = {r:.4}");
    assert!(r <= 0.15, "{r}");
}

#[test]
fn quadratic_speed_model_predicts_square_law_heat_better_and_auto_picks_it() {
    // Heat ∝ n²: the linear model's error is a modelling error, which the
    // Hammerstein variant (speed and speed² through the same lags) removes.
    let dir = tempfile::tempdir().unwrap();
    let machine = TruthMachine {
        speed_exponent: 2.0,
        ..TruthMachine::demo()
    };
    for seed in [21, 22] {
        let (lin, _) = relative_error_with(&machine, 0.0005, seed, dir.path(), SpeedModel::Linear);
        let (quad, _) =
            relative_error_with(&machine, 0.0005, seed, dir.path(), SpeedModel::Quadratic);
        let (auto, chose) =
            relative_error_with(&machine, 0.0005, seed, dir.path(), SpeedModel::Auto);
        eprintln!(
            "heat ~ n², seed {seed}: held-out error / drift RMS linear {lin:.4}, quadratic {quad:.4}"
        );
        assert!(
            quad < 0.5 * lin,
            "seed {seed}: quadratic {quad} vs linear {lin}"
        );
        assert_eq!(chose, Some(true), "seed {seed}");
        assert_eq!(auto, quad);
    }
}

#[test]
fn auto_keeps_the_linear_model_when_heat_is_linear_in_speed() {
    let dir = tempfile::tempdir().unwrap();
    let machine = TruthMachine::demo();
    for seed in [31, 32] {
        let (lin, _) = relative_error_with(&machine, 0.0005, seed, dir.path(), SpeedModel::Linear);
        let (auto, chose) =
            relative_error_with(&machine, 0.0005, seed, dir.path(), SpeedModel::Auto);
        assert_eq!(chose, Some(false), "seed {seed}");
        assert_eq!(auto, lin);
    }
}

#[test]
fn noise_free_measured_heights_are_reproduced_exactly() {
    // Each measured height of the truth is exactly a second-order ARX model
    // (two first-order lags, zero-order-hold input): the fit must find it.
    let dir = tempfile::tempdir().unwrap();
    let machine = TruthMachine::demo();
    let train = dir.path().join("TRAIN.csv");
    std::fs::write(
        &train,
        machine.training_csv(&training_runs(), &MEASURED, 0.0, 0),
    )
    .unwrap();
    let fit = fit_csv(&train, &ThermalFitOptions::default()).unwrap();
    let speeds = cutting(5);
    let programme = mtwin::methods::thermal::Programme::speeds(&speeds);
    let pred = predict(&fit.model, &programme, &MEASURED);
    for (i, row) in pred.rows.iter().enumerate() {
        let (k, h) = (i / MEASURED.len(), i % MEASURED.len());
        let truth = machine.drift(&speeds, MEASURED[h])[k];
        assert!((row[2] - truth).abs() < 1e-9, "{row:?} vs {truth}");
    }
    for h in &fit.heights {
        let o = &h.selection.table[h.selection.best].orders;
        assert!(o.na >= 2, "z = {}: {o}", h.z_mm);
    }
}
