//! `mtwin thermal simulate --format json` as a typed document
//! ([`ThermalSimulateDoc`]).

use serde::{Deserialize, Serialize};

use super::SimulatedData;

/// `mtwin thermal simulate`: the synthetic training data written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalSimulateDoc {
    /// Duration covered (min): last minus first time.
    pub duration_min: f64,
    /// Heights simulated (mm).
    pub heights: Vec<f64>,
    /// Largest |drift| in the data (mm).
    pub largest_drift_mm: f64,
    /// Standard deviation of the noise added (mm).
    pub noise: f64,
    /// The CSV written.
    pub out: String,
    /// Rows written.
    pub rows: usize,
    /// Seed of the noise.
    pub seed: u64,
}

impl ThermalSimulateDoc {
    /// The document of `data` simulated at `heights` and written to `out`.
    pub fn new(data: &SimulatedData, heights: &[f64], noise: f64, seed: u64, out: &str) -> Self {
        let t = data.rows.iter().map(|r| r.0);
        let (lo, hi) = t.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
        ThermalSimulateDoc {
            duration_min: if data.rows.is_empty() { 0.0 } else { hi - lo },
            heights: heights.to_vec(),
            largest_drift_mm: data.rows.iter().map(|r| r.3.abs()).fold(0.0, f64::max),
            noise,
            out: out.to_string(),
            rows: data.rows.len(),
            seed,
        }
    }
}

/// The file is announced as a note on stderr: no human text on stdout.
impl std::fmt::Display for ThermalSimulateDoc {
    fn fmt(&self, _: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_document_summarises_the_rows_and_round_trips() {
        let data = SimulatedData {
            input_names: vec!["speed_rpm".into()],
            rows: vec![
                (0.0, vec![1000.0], 0.0, 0.001),
                (1.0, vec![1000.0], 0.0, -0.004),
                (2.5, vec![1000.0], 0.0, 0.002),
            ],
        };
        let d = ThermalSimulateDoc::new(&data, &[0.0], 0.0005, 3, "train.csv");
        assert_eq!(
            (d.rows, d.duration_min, d.largest_drift_mm),
            (3, 2.5, 0.004)
        );
        let back: ThermalSimulateDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
    }
}

/// `mtwin thermal compensate`: what the thermal compensation of a program changed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalCompensateDoc {
    /// Blocks read.
    pub blocks: u64,
    /// Z blocks whose value changed.
    pub blocks_changed: usize,
    /// First time a block changed (min), if any.
    pub changed_from_min: Option<f64>,
    /// Last time a block changed (min), if any.
    pub changed_to_min: Option<f64>,
    /// Estimated duration of the program (min).
    pub duration_min: f64,
    /// Largest Z correction (µm).
    pub max_correction_um: f64,
    /// Things the user should know.
    pub notes: Vec<String>,
    /// The program written.
    pub out: String,
    /// Whether the program's own spindle speeds drove the prediction.
    pub spindle_used: bool,
    /// Blocks that program Z.
    pub z_blocks: usize,
}

impl std::fmt::Display for ThermalCompensateDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let span = match (self.changed_from_min, self.changed_to_min) {
            (Some(a), Some(b)) => format!(", changes from {a:.1} to {b:.1} min"),
            _ => String::new(),
        };
        writeln!(
            f,
            "{} blocks, estimated {:.1} min → {}\n{} of {} Z blocks changed, largest correction {:.2} µm{}",
            self.blocks,
            self.duration_min,
            self.out,
            self.blocks_changed,
            self.z_blocks,
            self.max_correction_um,
            span
        )
    }
}

#[cfg(test)]
mod compensate_tests {
    use super::*;

    #[test]
    fn the_compensate_document_round_trips_and_prints_the_span() {
        let d = ThermalCompensateDoc {
            blocks: 10,
            blocks_changed: 3,
            changed_from_min: Some(1.0),
            changed_to_min: Some(2.5),
            duration_min: 4.0,
            max_correction_um: 12.5,
            notes: vec![],
            out: "p.ngc".into(),
            spindle_used: true,
            z_blocks: 4,
        };
        let back: ThermalCompensateDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        assert_eq!(
            d.to_string(),
            "10 blocks, estimated 4.0 min → p.ngc\n3 of 4 Z blocks changed, largest correction 12.50 µm, changes from 1.0 to 2.5 min\n"
        );
    }
}
