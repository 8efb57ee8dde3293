//! `mtwin servo fit --format json` as a typed document ([`ServoFitDoc`]),
//! which `mtwin report --servo` reads back.

use serde::{Deserialize, Serialize};

use super::ServoFit;

/// ARX orders of the chosen structure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrdersDoc {
    /// Number of `a` coefficients after `a_0 = 1`.
    pub na: usize,
    /// Number of `b` coefficients minus one, per input.
    pub nb: Vec<usize>,
    /// Input delay in samples, per input.
    pub nk: Vec<usize>,
}

impl From<&super::ArxOrders> for OrdersDoc {
    fn from(o: &super::ArxOrders) -> Self {
        OrdersDoc {
            na: o.na,
            nb: o.inputs.iter().map(|i| i.nb).collect(),
            nk: o.inputs.iter().map(|i| i.nk).collect(),
        }
    }
}

impl OrdersDoc {
    /// The orders as [`super::ArxOrders`] (for their `na=… nb=… nk=…` text).
    pub fn orders(&self) -> super::ArxOrders {
        super::ArxOrders {
            na: self.na,
            inputs: self
                .nb
                .iter()
                .zip(&self.nk)
                .map(|(&nb, &nk)| super::InputOrder { nb, nk })
                .collect(),
        }
    }
}

/// An identified servo transfer function, command → encoder position,
/// `y(k) = −Σ a_i·y(k−i) + Σ b_j·u(k−j−nk)`, with its fit statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServoFitDoc {
    /// Denominator coefficients, `a[0] = 1`.
    pub a: Vec<f64>,
    /// Numerator coefficients.
    pub b: Vec<f64>,
    /// −3 dB bandwidth (Hz); `None` above the Nyquist frequency.
    pub bandwidth_hz: Option<f64>,
    /// Order-selection criterion.
    pub criterion: String,
    /// Static gain.
    pub dc_gain: f64,
    /// How the coefficients were refined (`output_error`).
    pub estimator: String,
    /// Feed the following error is given at (mm/min), when asked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_mm_min: Option<f64>,
    /// Following error at that feed (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub following_error_at_feed: Option<f64>,
    /// Following error at the largest velocity of the log (mm).
    pub following_error_at_max_velocity: Option<f64>,
    /// Every structure tried, with its criterion (rows of the order grid).
    pub grid: Vec<super::GridRowDoc>,
    /// Largest velocity in the log (log unit per s).
    pub max_velocity: f64,
    /// Input delay of the chosen model (samples).
    pub nk: usize,
    /// One-step-ahead prediction RMS (log unit).
    pub one_step_rms: f64,
    /// The chosen orders.
    pub orders: OrdersDoc,
    /// The servo file written, when one was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub out: Option<String>,
    /// Samples used.
    pub samples: usize,
    /// Simulation RMS, feedback − simulated (log unit).
    pub simulation_rms: f64,
    /// Largest pole modulus.
    pub spectral_radius: f64,
    /// All poles inside the unit circle.
    pub stable: bool,
    /// Sampling period (s).
    pub ts: f64,
    /// Velocity lag (s), when the static gain is defined.
    pub velocity_lag_s: Option<f64>,
    /// Reservations about the model.
    pub warnings: Vec<String>,
}

impl ServoFitDoc {
    /// The document of `fit`.
    pub fn new(fit: &ServoFit) -> Self {
        let orders = &fit.selection.table[fit.selection.best].orders;
        ServoFitDoc {
            a: fit.servo.a().to_vec(),
            b: fit.servo.b().to_vec(),
            bandwidth_hz: fit.bandwidth_hz,
            criterion: format!("{:?}", fit.selection.criterion).to_lowercase(),
            dc_gain: fit.dc_gain,
            estimator: "output_error".into(),
            feed_mm_min: None,
            following_error_at_feed: None,
            following_error_at_max_velocity: fit.following_error_at_max_velocity,
            grid: fit.selection.table_doc(),
            max_velocity: fit.max_velocity,
            nk: fit.servo.nk(),
            one_step_rms: fit.selection.fit.stats.one_step_rms,
            orders: OrdersDoc {
                na: orders.na,
                nb: orders.inputs.iter().map(|o| o.nb).collect(),
                nk: orders.inputs.iter().map(|o| o.nk).collect(),
            },
            out: None,
            samples: fit.selection.fit.stats.samples,
            simulation_rms: fit.simulation_rms,
            spectral_radius: fit.stability.spectral_radius(),
            stable: fit.stability.is_stable(),
            ts: fit.servo.ts(),
            velocity_lag_s: fit.velocity_lag_s,
            warnings: fit.warnings(),
        }
    }
}

/// The summary (µm, Hz, ms), the following error at the feed when one was
/// given, then the order grid. The warnings go to stderr.
impl std::fmt::Display for ServoFitDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} samples at ts = {} s",
            self.samples,
            crate::io::fmt_f64(self.ts)
        )?;
        match &self.out {
            Some(out) => writeln!(f, " → {out}")?,
            None => writeln!(f)?,
        }
        writeln!(f, "orders: {}", self.orders.orders())?;
        writeln!(
            f,
            "simulation RMS (feedback − simulated): {:.3} µm",
            self.simulation_rms * 1e3
        )?;
        match self.bandwidth_hz {
            Some(bw) => writeln!(f, "bandwidth (−3 dB): {bw:.2} Hz")?,
            None => writeln!(f, "bandwidth (−3 dB): above the Nyquist frequency")?,
        }
        writeln!(f, "static gain: {:.6}", self.dc_gain)?;
        if let Some(feed) = self.feed_mm_min {
            match self.following_error_at_feed {
                Some(e) => writeln!(
                    f,
                    "following error at F{} mm/min: {:.2} µm (velocity lag {:.3} ms)",
                    crate::io::fmt_f64(feed),
                    e * 1e3,
                    e / (feed / 60.0) * 1e3
                )?,
                None => writeln!(f, "following error: undefined (no static gain)")?,
            }
        }
        write!(f, "\n{}", super::grid_text(&self.grid))
    }
}

/// `mtwin servo simulate`: the encoder log written from a servo and commands.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServoSimulateDoc {
    /// Duration of the log (s): samples × ts.
    pub duration_s: f64,
    /// Largest |command − feedback| before noise (log unit).
    pub largest_following_error: f64,
    /// Standard deviation of the encoder noise added (log unit).
    pub noise: f64,
    /// The LOG.csv written.
    pub out: String,
    /// Samples written.
    pub samples: usize,
    /// Seed of the noise.
    pub seed: u64,
}

/// The file is announced as a note on stderr: no human text on stdout.
impl std::fmt::Display for ServoSimulateDoc {
    fn fmt(&self, _: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        Ok(())
    }
}

/// `mtwin servo excitation`: the excitation program written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServoExcitationDoc {
    /// The axis letter.
    pub axis: String,
    /// Dwell after every move (s).
    pub dwell_s: f64,
    /// Feed of the moves (mm/min or deg/min).
    pub feed: f64,
    /// Amplitude levels.
    pub levels: usize,
    /// Lines of the program.
    pub lines: usize,
    /// The program written.
    pub out: String,
    /// Allowed travel `[min, max]` (mm or deg).
    pub travel: [f64; 2],
}

/// The file is announced as a note on stderr: no human text on stdout.
impl std::fmt::Display for ServoExcitationDoc {
    fn fmt(&self, _: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simulate_and_excitation_documents_round_trip() {
        let servo = super::super::Servo::new(0.001, vec![0.0, 0.1], vec![1.0, -0.9], 1).unwrap();
        let commands: Vec<f64> = (0..200).map(|k| k as f64 * 0.01).collect();
        let feedback = servo.simulate(&commands);
        let lag = commands
            .iter()
            .zip(&feedback)
            .map(|(c, y)| (c - y).abs())
            .fold(0.0, f64::max);
        // y(k) = 0.9·y(k−1) + 0.1·u(k−2): a ramp of 0.01 mm per sample
        // settles 0.9/0.1 + 2 = 11 samples behind, 0.11 mm, approached from below.
        assert!(lag > 0.109 && lag <= 0.11 + 1e-9, "{lag}");
        let d = ServoSimulateDoc {
            duration_s: 200.0 * servo.ts(),
            largest_following_error: lag,
            noise: 0.0,
            out: "log.csv".into(),
            samples: 200,
            seed: 1,
        };
        let back: ServoSimulateDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        let e = ServoExcitationDoc {
            axis: "X".into(),
            dwell_s: 0.5,
            feed: 3000.0,
            levels: 5,
            lines: 40,
            out: "exc.nc".into(),
            travel: [-100.0, 100.0],
        };
        let back: ServoExcitationDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&e).unwrap()).unwrap();
        assert_eq!(back, e);
    }
}
