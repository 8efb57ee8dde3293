//! The probing sign end to end: a synthetic machine whose tool grows by
//! `e(t, z)` in +Z relative to the work is probed as the measurement
//! programme does it (the probe trips when the indicated Z is `b − e`, `b`
//! the ball top), the touched Z values are turned into training data by the
//! documented convention (drift = cold touched Z − touched Z, or the raw
//! `probe_shift_mm` = touched − cold), the model is fitted, a program is
//! compensated, and the tool's actual Z at the compensated targets is
//! compared with the nominal one.

use mtwin::methods::thermal::{
    CompensateOptions, CorrectionUpdate, ThermalFitOptions, TruthMachine, compensate, fit_csv,
};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const HEIGHTS: [f64; 4] = [-350.0, -250.0, -150.0, -50.0];
const BALL_RADIUS: f64 = 12.7;

/// The identification programme: speed steps, one value per 10-min period.
fn speeds() -> Vec<f64> {
    [
        2000.0, 6000.0, 8000.0, 0.0, 4000.0, 7000.0, 1000.0, 8000.0, 3000.0, 0.0,
    ]
    .iter()
    .flat_map(|&s| [s; 4])
    .collect()
}

/// Touched Z of every pass (rows) and ball (columns): the probe moves down
/// onto the ball top `b`; with the tool displaced by `e` in +Z the stylus
/// meets the ball when the indicated Z is `b − e`. Probing noise 0.3 µm.
fn touched(machine: &TruthMachine) -> Vec<Vec<f64>> {
    let noise = Normal::new(0.0, 0.0003).unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    let drifts: Vec<Vec<f64>> = HEIGHTS
        .iter()
        .map(|&z| machine.drift(&speeds(), z))
        .collect();
    (0..speeds().len())
        .map(|k| {
            HEIGHTS
                .iter()
                .zip(&drifts)
                .map(|(&z, e)| (z + BALL_RADIUS) - e[k] + noise.sample(&mut rng))
                .collect()
        })
        .collect()
}

/// `t_min,speed_rpm,z_mm,<column>` with `value(cold, touched)` per row.
fn training(column: &str, value: impl Fn(f64, f64) -> f64, probes: &[Vec<f64>]) -> String {
    let mut s = format!("t_min,speed_rpm,z_mm,{column}\n");
    for (k, (pass, n)) in probes.iter().zip(speeds()).enumerate() {
        for (i, &z) in HEIGHTS.iter().enumerate() {
            s.push_str(&format!(
                "{},{n},{z},{}\n",
                10 * k,
                value(probes[0][i], pass[i])
            ));
        }
    }
    s
}

/// The truth's drift at height `z` after `t` minutes at a constant `rpm`
/// from cold (the continuous solution of [`TruthMachine`]).
fn truth_drift(m: &TruthMachine, rpm: f64, t: f64, z: f64) -> f64 {
    let h = rpm / 1000.0;
    h * (m.fast_gain_mm * (1.0 - (-t / m.fast_tau_min).exp())
        + m.slow_gain_mm * m.slow_weight(z) * (1.0 - (-t / m.slow_tau_min).exp()))
}

/// Fit `train`, compensate a program that runs at 8000 rev/min and then
/// moves to Z−50 and Z−150; returns per Z move (nominal, actual error mm,
/// uncompensated error mm).
fn actual_errors(train: &str) -> Vec<(f64, f64, f64)> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("TRAIN.csv");
    std::fs::write(&path, train).unwrap();
    let options = ThermalFitOptions {
        max_order: 2,
        ..ThermalFitOptions::default()
    };
    let fit = fit_csv(&path, &options).unwrap();
    let program = "G21 G90 G17\nS8000 M3\nG4 P3000\nG1 Z-50 F1000\nG4 P1800\nG1 Z-150\nM5\nM2\n";
    let mut options = CompensateOptions::default();
    options.update = CorrectionUpdate::Continuous;
    let out = compensate(&fit.model, program.as_bytes(), &options).unwrap();
    let text = String::from_utf8(out.output).unwrap();
    let written: Vec<f64> = text
        .lines()
        .filter(|l| l.starts_with("G1"))
        .map(|l| {
            let w = l.split_whitespace().find(|w| w.starts_with('Z')).unwrap();
            w[1..].parse().unwrap()
        })
        .collect();
    let machine = TruthMachine::demo();
    out.z_blocks
        .iter()
        .zip(written)
        .map(|(b, z_written)| {
            let nominal = b.machine_z_mm;
            let e = truth_drift(&machine, 8000.0, b.end_min, nominal);
            // The tool sits at the written Z displaced by the drift.
            (nominal, z_written + e - nominal, e)
        })
        .collect()
}

#[test]
fn probed_drift_compensates_to_near_zero_and_the_wrong_sign_doubles_it() {
    let machine = TruthMachine::demo();
    let probes = touched(&machine);
    // The documented convention: drift = cold touched Z − touched Z.
    let right = actual_errors(&training("drift_mm", |cold, t| cold - t, &probes));
    // The same data given as the raw shift (touched − cold) in its own column.
    let shift = actual_errors(&training("probe_shift_mm", |cold, t| t - cold, &probes));
    // The old, wrong instruction: "touched Z minus the cold pass's" as drift.
    let wrong = actual_errors(&training("drift_mm", |cold, t| t - cold, &probes));
    assert_eq!(right.len(), 2);
    for ((r, s), w) in right.iter().zip(&shift).zip(&wrong) {
        let (nominal, err, uncompensated) = *r;
        assert!(
            uncompensated.abs() > 0.010,
            "the drift at Z{nominal} should be tens of µm: {uncompensated}"
        );
        assert!(
            // The model's prediction error (40 probing passes, 0.3 µm
            // noise): a tenth of the drift, against all of it uncompensated
            // and twice it with the wrong sign.
            err.abs() < 0.1 * uncompensated.abs(),
            "Z{nominal}: actual error {err} mm, drift {uncompensated} mm"
        );
        assert!((s.1 - err).abs() < 1e-9, "{s:?} vs {r:?}");
        assert!(
            (w.1 - 2.0 * uncompensated).abs() < 0.1 * uncompensated.abs(),
            "the wrong sign should double the error: {w:?}"
        );
    }
}
