//! The three `mtwin servo` methods in the library's one shape, options in
//! and a document out: [`run_fit`] (identify a servo from a log),
//! [`run_simulate`] (the encoder log of a servo for commands) and
//! [`run_excitation`] (the excitation program). The callers write the files
//! and print the documents.
//!
//! Units: time in s, positions in mm (deg for a rotary axis), feeds in
//! mm/min (deg/min).

use std::path::Path;

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use thiserror::Error;

use super::{
    ExcitationError, ExcitationOptions, Servo, ServoExcitationDoc, ServoFit, ServoFitDoc,
    ServoFitError, ServoFitOptions, ServoSimulateDoc, excitation_program, fit_servo_csv,
};
use crate::io::{Diagnostic, Diagnostics, Table, fmt_f64};
use crate::limits::fmt_message_number;

/// Options of [`run_fit`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct FitRunOptions {
    /// The orders and delays tried ([`fit_servo`](super::fit_servo)).
    pub fit: ServoFitOptions,
    /// Feed at which the steady following error is reported, mm/min
    /// (deg/min); `None`: not reported.
    pub feed_mm_min: Option<f64>,
}

impl FitRunOptions {
    /// Checks the options before any work: a positive finite feed
    /// ([`ServoFitError::Setting`]), then [`ServoFitOptions::validate`]
    /// ([`ServoFitError::Fit`]).
    pub fn validate(&self) -> Result<(), ServoFitError> {
        if let Some(feed) = self.feed_mm_min
            && !(feed.is_finite() && feed > 0.0)
        {
            return Err(ServoFitError::Setting {
                option: "feed",
                problem: format!(
                    "must be a positive feed in mm/min, not {}",
                    fmt_message_number(feed)
                ),
            });
        }
        Ok(self.fit.validate()?)
    }
}

/// `mtwin servo fit`: the servo identified from the log at `data`
/// (`t_s,command_mm,feedback_mm`) and its document, with the following
/// error at `options.feed_mm_min` when one is given. The document's `out`
/// is left empty for the caller.
///
/// # Errors
/// A feed that is not positive and finite ([`ServoFitError::Setting`]), bad
/// orders, a bad log, data that cannot be fitted.
pub fn run_fit(
    data: &Path,
    options: &FitRunOptions,
) -> Result<(ServoFit, ServoFitDoc), ServoFitError> {
    options.validate()?;
    let fit = fit_servo_csv(data, &options.fit)?;
    let doc = ServoFitDoc {
        feed_mm_min: options.feed_mm_min,
        following_error_at_feed: options
            .feed_mm_min
            .and_then(|feed| fit.servo.following_error(feed / 60.0).ok()),
        ..ServoFitDoc::new(&fit)
    };
    Ok((fit, doc))
}

/// Options of [`run_simulate`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct SimulateRunOptions {
    /// Standard deviation of white encoder noise added to the feedback
    /// (log unit, ≥ 0).
    pub noise: f64,
    /// Seed of the noise (same seed, same log).
    pub seed: u64,
    /// Simulate even an unstable servo (a pole on or outside the unit
    /// circle); the simulation stops with an error if it overflows.
    pub allow_unstable: bool,
}

impl SimulateRunOptions {
    /// Checks the options: a finite noise level `>= 0`.
    pub fn validate(&self) -> Result<(), SimulateRunError> {
        if !(self.noise.is_finite() && self.noise >= 0.0) {
            return Err(SimulateRunError::Setting {
                option: "noise",
                problem: format!(
                    "must be finite and >= 0 mm, not {}",
                    fmt_message_number(self.noise)
                ),
            });
        }
        Ok(())
    }

    /// Checks that `servo` may be simulated: stable, or `allow_unstable`.
    pub fn check_servo(&self, servo: &Servo) -> Result<(), SimulateRunError> {
        match servo.arx().stability().warning() {
            Some(w) if !self.allow_unstable => Err(SimulateRunError::Unstable(w)),
            _ => Ok(()),
        }
    }
}

/// Why [`run_simulate`] refuses.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SimulateRunError {
    /// An option out of its domain: `option` names the field of
    /// [`SimulateRunOptions`].
    #[error("{option} {problem}")]
    Setting {
        /// The option.
        option: &'static str,
        /// What is wrong, as "must be …, not …".
        problem: String,
    },
    /// The servo is unstable and `allow_unstable` is not set (the reason).
    #[error("{0}; refusing to simulate it")]
    Unstable(String),
    /// The simulated feedback overflows at this time (s) and sample (from 1).
    #[error(
        "the simulated feedback overflows at t_s = {} (sample {sample}): the servo diverges",
        fmt_f64(*t_s)
    )]
    Diverges {
        /// Time of the sample, s.
        t_s: f64,
        /// The sample, counted from 1.
        sample: usize,
    },
}

/// The commands of `servo simulate` from `table`: the columns `t_s` and
/// `column` (e.g. `command_mm`, or `X` of a CMD.csv), at least one row,
/// `t_s` increasing by `ts` (within 1 %); every problem with its line.
pub fn read_servo_commands(
    table: &Table,
    column: &str,
    ts: f64,
) -> Result<Vec<[f64; 2]>, Diagnostics> {
    let rows = table.number_rows(&[crate::io::columns::T_S, column])?;
    let mut d = Diagnostics::default();
    if rows.is_empty() {
        d.push(Diagnostic::at_line(
            table.path(),
            table.header_line(),
            "the file has no data rows",
        ));
    }
    for (r, w) in rows.windows(2).enumerate() {
        let dt = w[1][0] - w[0][0];
        if (dt - ts).abs() > 0.01 * ts {
            d.push(table.row_error(
                r + 1,
                format!(
                    "t_s = {} does not follow the previous sample ({}) by the servo's ts = {} s",
                    fmt_f64(w[1][0]),
                    fmt_f64(w[0][0]),
                    fmt_f64(ts)
                ),
            ));
        }
    }
    d.into_result(rows.iter().map(|r| [r[0], r[1]]).collect())
}

/// `mtwin servo simulate`: the log `[t_s, command, feedback]` of `servo`
/// driven by `commands` (`[t_s, command]`, sampled at the servo's `ts`),
/// with white encoder noise of `options.noise` drawn from `options.seed`,
/// and its document (`out` left empty for the caller). The largest
/// following error of the document is that before the noise.
pub fn run_simulate(
    servo: &Servo,
    commands: &[[f64; 2]],
    options: &SimulateRunOptions,
) -> Result<(Vec<[f64; 3]>, ServoSimulateDoc), SimulateRunError> {
    options.validate()?;
    options.check_servo(servo)?;
    let u: Vec<f64> = commands.iter().map(|r| r[1]).collect();
    let feedback = servo.simulate(&u);
    if let Some(k) = feedback.iter().position(|y| !y.is_finite()) {
        return Err(SimulateRunError::Diverges {
            t_s: commands[k][0],
            sample: k + 1,
        });
    }
    let noise = Normal::new(0.0, options.noise).map_err(|e| SimulateRunError::Setting {
        option: "noise",
        problem: e.to_string(),
    })?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(options.seed);
    let log = commands
        .iter()
        .zip(&feedback)
        .map(|(c, y)| [c[0], c[1], y + noise.sample(&mut rng)])
        .collect();
    let doc = ServoSimulateDoc {
        duration_s: commands.len() as f64 * servo.ts(),
        largest_following_error: u
            .iter()
            .zip(&feedback)
            .map(|(c, y)| (c - y).abs())
            .fold(0.0, f64::max),
        noise: options.noise,
        out: String::new(),
        samples: commands.len(),
        seed: options.seed,
    };
    Ok((log, doc))
}

/// `mtwin servo excitation`: the program ([`excitation_program`]) and its
/// document (`out` left empty for the caller).
pub fn run_excitation(
    options: &ExcitationOptions,
) -> Result<(String, ServoExcitationDoc), ExcitationError> {
    let text = excitation_program(options)?;
    let doc = ServoExcitationDoc {
        axis: options.axis.clone(),
        dwell_s: options.dwell_s,
        feed: options.feed,
        levels: options.levels,
        lines: text.lines().count(),
        out: String::new(),
        travel: options.travel,
    };
    Ok((text, doc))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `y(k) = 0.9·y(k−1) + 0.1·u(k−1)`: a first-order lag of one sample.
    fn lag() -> Servo {
        Servo::new(0.001, vec![0.0, 0.1], vec![1.0, -0.9], 0).unwrap()
    }

    #[test]
    fn simulate_follows_a_step_like_a_first_order_lag() {
        let commands: Vec<[f64; 2]> = (0..50).map(|k| [k as f64 * 0.001, 1.0]).collect();
        let (log, doc) = run_simulate(&lag(), &commands, &SimulateRunOptions::default()).unwrap();
        // On deviations from the first command (1 mm) a constant command
        // leaves the axis at rest: feedback = command.
        assert!(log.iter().all(|r| (r[2] - 1.0).abs() < 1e-12));
        assert_eq!(doc.samples, 50);
        assert!((doc.duration_s - 0.05).abs() < 1e-12);
        let step: Vec<[f64; 2]> = (0..50)
            .map(|k| [k as f64 * 0.001, if k == 0 { 0.0 } else { 1.0 }])
            .collect();
        let (log, doc) = run_simulate(&lag(), &step, &SimulateRunOptions::default()).unwrap();
        // Closed form of the step response: y(k) = 1 − 0.9^(k−1) for k ≥ 1
        // (the input reaches the output one sample late).
        for (k, r) in log.iter().enumerate().skip(1) {
            assert!(
                (r[2] - (1.0 - 0.9f64.powi(k as i32 - 1))).abs() < 1e-12,
                "{k}"
            );
        }
        assert!((doc.largest_following_error - 1.0).abs() < 1e-12);
    }

    #[test]
    fn simulate_noise_is_seeded_and_bad_settings_are_refused() {
        let commands: Vec<[f64; 2]> = (0..20).map(|k| [k as f64 * 0.001, 0.0]).collect();
        let mut o = SimulateRunOptions {
            noise: 0.001,
            seed: 7,
            ..Default::default()
        };
        let (a, _) = run_simulate(&lag(), &commands, &o).unwrap();
        let (b, _) = run_simulate(&lag(), &commands, &o).unwrap();
        assert_eq!(a, b);
        assert!(a.iter().any(|r| r[2] != 0.0));
        o.noise = -1.0;
        assert!(matches!(
            run_simulate(&lag(), &commands, &o),
            Err(SimulateRunError::Setting {
                option: "noise",
                ..
            })
        ));
        let unstable = Servo::new(0.001, vec![0.0, 0.1], vec![1.0, -1.5], 0).unwrap();
        let step: Vec<[f64; 2]> = (0..5000)
            .map(|k| [k as f64 * 0.001, 1.0 + k as f64])
            .collect();
        assert!(matches!(
            run_simulate(&unstable, &step, &SimulateRunOptions::default()),
            Err(SimulateRunError::Unstable(_))
        ));
        let o = SimulateRunOptions {
            allow_unstable: true,
            ..Default::default()
        };
        // 1.5^k overflows f64 after about 1750 samples.
        assert!(matches!(
            run_simulate(&unstable, &step, &o),
            Err(SimulateRunError::Diverges { sample, .. }) if sample > 1000
        ));
    }

    #[test]
    fn excitation_document_counts_the_program_lines() {
        let o = ExcitationOptions::new("Y", [-10.0, 30.0], 1200.0);
        let (text, doc) = run_excitation(&o).unwrap();
        assert_eq!(doc.lines, text.lines().count());
        assert_eq!(doc.travel, [-10.0, 30.0]);
        assert_eq!(doc.levels, 5);
        let back: ServoExcitationDoc =
            serde_json::from_str(&serde_json::to_string(&doc).unwrap()).unwrap();
        assert_eq!(back, doc);
    }

    #[test]
    fn fit_refuses_a_bad_feed_before_reading() {
        let o = FitRunOptions {
            feed_mm_min: Some(0.0),
            ..Default::default()
        };
        let e = run_fit(Path::new("/nonexistent/log.csv"), &o).unwrap_err();
        assert!(
            matches!(&e, ServoFitError::Setting { option: "feed", .. }),
            "{e}"
        );
    }
}
