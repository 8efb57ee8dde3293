//! `thermal fit` input checks (each a clear error naming file and line) and
//! extra inputs (temperatures) through the multi-input ARX model.

use mtwin::methods::thermal::{
    HeightModel, InputChannel, Programme, ThermalError, ThermalFitOptions, ThermalModel, fit_csv,
    predict, simulate,
};
use mtwin::sysid::Arx;

/// A TRAIN.csv with 30 samples at each of two heights (time-major), `edit`
/// applied to the text of the data rows.
fn train(edit: impl Fn(usize, f64, f64) -> Option<String>) -> String {
    let mut s = String::from("# probing runs\nrun,t_min,speed_rpm,z_mm,drift_mm\n");
    for k in 0..30 {
        for z in [-50.0, -150.0] {
            let t = k as f64 * 10.0;
            let line =
                edit(k, t, z).unwrap_or_else(|| format!("r1,{t},3000,{z},{}", -1e-4 * k as f64));
            s.push_str(&line);
            s.push('\n');
        }
    }
    s
}

fn fit_err(text: &str, options: &ThermalFitOptions) -> (String, Vec<mtwin::io::Diagnostic>) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("TRAIN.csv");
    std::fs::write(&p, text).unwrap();
    match fit_csv(&p, options) {
        Err(ThermalError::Input(d)) => (d.to_string(), d.0),
        Err(e) => panic!("expected an input error, got {e}"),
        Ok(_) => panic!("expected an input error"),
    }
}

/// Line in the file of data row (k, z index): two comment/header lines, two rows per k.
fn line(k: usize, zi: usize) -> usize {
    3 + 2 * k + zi
}

#[test]
fn time_not_increasing_within_a_run() {
    let text = train(|k, _, z| (k == 7 && z == -150.0).then(|| format!("r1,60,3000,{z},0")));
    let (msg, d) = fit_err(&text, &ThermalFitOptions::default());
    assert!(
        d.iter()
            .any(|d| d.line == line(7, 1) && d.message.contains("does not increase")),
        "{msg}"
    );
    assert!(msg.contains("TRAIN.csv:"), "{msg}");
    // The next sample is then 30 min after it: also reported, as uneven.
    assert!(d.iter().any(|d| d.line == line(8, 1)), "{msg}");
}

#[test]
fn uneven_sampling() {
    let text =
        train(|k, t, z| (k >= 12 && z == -50.0).then(|| format!("r1,{},3000,{z},0", t + 5.0)));
    let (msg, d) = fit_err(&text, &ThermalFitOptions::default());
    assert_eq!(d.len(), 1, "{msg}");
    assert_eq!(d[0].line, line(12, 0), "{msg}");
    assert!(
        d[0].message.contains("uneven") && d[0].message.contains("z = -50 mm"),
        "{msg}"
    );
}

#[test]
fn a_height_with_too_few_samples() {
    // z = -150 only measured for the first 8 samples.
    let text = train(|k, _, z| (k >= 8 && z == -150.0).then(|| "# not measured".to_string()));
    let (msg, d) = fit_err(&text, &ThermalFitOptions::default());
    assert_eq!(d.len(), 1, "{msg}");
    assert_eq!(d[0].line, line(0, 1), "{msg}");
    assert!(d[0].message.contains("z = -150 mm has 8 samples"), "{msg}");
    // With orders up to 1 (at most 3 parameters) 9 samples are needed: still too few.
    let (msg, _) = fit_err(
        &text,
        &ThermalFitOptions {
            max_order: 1,
            ..Default::default()
        },
    );
    assert!(msg.contains("at least 9"), "{msg}");
}

#[test]
fn a_temperature_input_enters_the_model() {
    // Truth: drift from speed (nk = 1) and from an ambient temperature offset (nk = 1).
    let truth = ThermalModel::new(
        10.0,
        vec![
            InputChannel::linear("speed_rpm", 1000.0),
            InputChannel::linear("ambient_c", 1.0),
        ],
        vec![
            HeightModel {
                z_mm: -50.0,
                model: Arx::new(
                    vec![1.0, -1.2, 0.35],
                    vec![(vec![-0.002, 0.001], 1), (vec![0.004], 1)],
                )
                .unwrap(),
                stats: None,
            },
            HeightModel {
                z_mm: -250.0,
                model: Arx::new(vec![1.0, -0.7], vec![(vec![-0.003], 1), (vec![0.002], 1)])
                    .unwrap(),
                stats: None,
            },
        ],
    )
    .unwrap();
    let samples: Vec<Vec<f64>> = (0..60)
        .map(|k| {
            vec![
                [0.0, 4000.0, 8000.0, 2000.0][(k / 7) % 4],
                1.5 * ((k as f64) / 9.0).sin(),
            ]
        })
        .collect();
    let data = simulate(&truth, &Programme::new(samples), &[-50.0, -250.0], 0.0, 1).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("TRAIN.csv");
    data.write_csv(&p).unwrap();
    let options = ThermalFitOptions {
        max_order: 2,
        extra_inputs: vec!["ambient_c".into()],
        ..Default::default()
    };
    let fit = fit_csv(&p, &options).unwrap();
    assert_eq!(fit.model.inputs()[1].name, "ambient_c");
    // A new programme is predicted exactly (noise-free data of a model inside the grid).
    let new: Vec<Vec<f64>> = (0..40)
        .map(|k| vec![(k * 250 % 7000) as f64, 0.3 * (k % 5) as f64])
        .collect();
    let prog = Programme::new(new);
    let a = predict(&truth, &prog, &[-50.0, -120.0, -250.0]);
    let b = predict(&fit.model, &prog, &[-50.0, -120.0, -250.0]);
    for (x, y) in a.rows.iter().zip(&b.rows) {
        assert!((x[2] - y[2]).abs() < 1e-9, "{x:?} vs {y:?}");
    }
    // Without the temperature the same data cannot be reproduced.
    let speed_only = fit_csv(
        &p,
        &ThermalFitOptions {
            max_order: 2,
            ..Default::default()
        },
    )
    .unwrap();
    let c = predict(
        &speed_only.model,
        &Programme::new(prog_speed_only(&prog)),
        &[-50.0],
    );
    let worst = c
        .rows
        .iter()
        .zip(a.rows.iter().step_by(3))
        .map(|(x, y)| (x[2] - y[2]).abs())
        .fold(0.0, f64::max);
    assert!(worst > 1e-4, "{worst}");
}

fn prog_speed_only(p: &Programme) -> Vec<Vec<f64>> {
    (0..p.len()).map(|k| vec![p.sample(k)[0]]).collect()
}
