//! Servo: identify an axis transfer function from a simulated
//! command/encoder log (a sine sweep), the model the digital twin runs.
//!
//! `cargo run -p mtwin --example servo`

use mtwin::sysid::{Servo, ServoFitOptions, ServoLog, fit_servo};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The true axis: a double pole at 0.8 sampled at 1 ms, unit static gain,
    // one sample of input delay.
    let p: f64 = 0.8;
    let truth = Servo::new(
        0.001,
        vec![(1.0 - p).powi(2)],
        vec![1.0, -2.0 * p, p * p],
        1,
    )?;
    // Command: a 20 mm sine sweep from 0.5 to 8 Hz over 2 s; feedback: the
    // true servo's response plus a deterministic 0.1 µm ripple.
    let (ts, n) = (truth.ts(), 2000);
    let mut phase = 0.0;
    let cmd: Vec<f64> = (0..n)
        .map(|k| {
            let f = 0.5 + 7.5 * k as f64 / n as f64;
            phase += 2.0 * std::f64::consts::PI * f * ts;
            20.0 * phase.sin()
        })
        .collect();
    let fb: Vec<f64> = truth
        .simulate(&cmd)
        .into_iter()
        .enumerate()
        .map(|(k, y)| y + 1e-4 * (0.37 * k as f64).sin())
        .collect();
    let fit = fit_servo(&ServoLog::new(ts, cmd, fb)?, &ServoFitOptions::default())?;
    println!(
        "orders {}, simulation rms {:.3} µm",
        fit.selection.table[fit.selection.best].orders,
        fit.simulation_rms * 1e3
    );
    println!(
        "velocity lag {:.3} ms (truth {:.3} ms)",
        fit.velocity_lag_s.unwrap_or(f64::NAN) * 1e3,
        truth.velocity_lag_s()? * 1e3
    );
    Ok(())
}
