//! The document `mtwin positioning evaluate` prints: `--format json` is its
//! serde form (the axis figures under the ISO 230-2 symbols `A`, `B`, `E`,
//! `M`, `R` and their unidirectional `_up`/`_down` forms, all in µm), the
//! human text its `Display`.

use std::fmt;

use serde::{Deserialize, Serialize};

/// The figures of one target position (µm unless named `_mm`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetRow {
    /// Target position `Pi`, mm.
    pub target_mm: f64,
    /// Mean unidirectional deviation approaching from below, `x̄↑i`.
    pub mean_up_um: f64,
    /// Mean unidirectional deviation approaching from above, `x̄↓i`.
    pub mean_down_um: f64,
    /// Mean bidirectional deviation `x̄i`.
    pub mean_um: f64,
    /// Standard uncertainty estimate `s↑i` (divisor n − 1).
    pub s_up_um: f64,
    /// Standard uncertainty estimate `s↓i`.
    pub s_down_um: f64,
    /// Reversal value `Bi = x̄↑i − x̄↓i` (signed).
    pub reversal_um: f64,
    /// Unidirectional repeatability `R↑i = 4 s↑i`.
    #[serde(rename = "R_up_um")]
    pub r_up_um: f64,
    /// Unidirectional repeatability `R↓i = 4 s↓i`.
    #[serde(rename = "R_down_um")]
    pub r_down_um: f64,
    /// Bidirectional repeatability `Ri = max(2s↑i + 2s↓i + |Bi|, R↑i, R↓i)`.
    #[serde(rename = "R_um")]
    pub r_um: f64,
    /// The measured deviations `x↑ij`, one per cycle.
    pub deviations_up_um: Vec<f64>,
    /// The measured deviations `x↓ij`, one per cycle.
    pub deviations_down_um: Vec<f64>,
}

/// ISO 230-2 positioning figures of one axis, µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PositioningDoc {
    /// Input file.
    pub source: String,
    /// Number of target positions `m`.
    pub targets: usize,
    /// Number of cycles `n` (approaches per target and direction).
    pub cycles: usize,
    /// Bidirectional accuracy `A`.
    #[serde(rename = "A")]
    pub a_um: f64,
    /// Unidirectional accuracy `A↑`.
    #[serde(rename = "A_up")]
    pub a_up_um: f64,
    /// Unidirectional accuracy `A↓`.
    #[serde(rename = "A_down")]
    pub a_down_um: f64,
    /// Reversal of the axis `B = max |Bi|`.
    #[serde(rename = "B")]
    pub b_um: f64,
    /// Mean reversal `B̄ = mean Bi` (signed).
    #[serde(rename = "B_mean")]
    pub b_mean_um: f64,
    /// Bidirectional systematic positioning error `E`.
    #[serde(rename = "E")]
    pub e_um: f64,
    /// Unidirectional systematic positioning error `E↑`.
    #[serde(rename = "E_up")]
    pub e_up_um: f64,
    /// Unidirectional systematic positioning error `E↓`.
    #[serde(rename = "E_down")]
    pub e_down_um: f64,
    /// Mean bidirectional positioning error `M` (range of `x̄i`).
    #[serde(rename = "M")]
    pub m_um: f64,
    /// Bidirectional repeatability `R = max Ri`.
    #[serde(rename = "R")]
    pub r_um: f64,
    /// Unidirectional repeatability `R↑ = max R↑i`.
    #[serde(rename = "R_up")]
    pub r_up_um: f64,
    /// Unidirectional repeatability `R↓ = max R↓i`.
    #[serde(rename = "R_down")]
    pub r_down_um: f64,
    /// Per-target figures, targets increasing.
    pub per_target: Vec<TargetRow>,
    /// What the reader dropped or assumed.
    #[serde(default)]
    pub notes: Vec<String>,
}

fn um(x: f64) -> String {
    format!("{x:.2}")
}

impl fmt::Display for PositioningDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "ISO 230-2 positioning of {}: {} targets × {} cycles per direction (µm)",
            self.source, self.targets, self.cycles
        )?;
        writeln!(
            f,
            "  A  = {:>9}   A↑ = {:>9}   A↓ = {:>9}   accuracy",
            um(self.a_um),
            um(self.a_up_um),
            um(self.a_down_um)
        )?;
        writeln!(
            f,
            "  E  = {:>9}   E↑ = {:>9}   E↓ = {:>9}   systematic positioning error",
            um(self.e_um),
            um(self.e_up_um),
            um(self.e_down_um)
        )?;
        writeln!(
            f,
            "  R  = {:>9}   R↑ = {:>9}   R↓ = {:>9}   repeatability",
            um(self.r_um),
            um(self.r_up_um),
            um(self.r_down_um)
        )?;
        writeln!(
            f,
            "  B  = {:>9}   B̄  = {:>9}                  reversal (max |Bi|, mean Bi)",
            um(self.b_um),
            um(self.b_mean_um)
        )?;
        writeln!(
            f,
            "  M  = {:>9}                                 mean bidirectional positioning error",
            um(self.m_um)
        )?;
        writeln!(
            f,
            "  {:>10} {:>8} {:>8} {:>8} {:>7} {:>7} {:>8} {:>7}",
            "target mm", "x̄↑", "x̄↓", "x̄", "s↑", "s↓", "Bi", "Ri"
        )?;
        for t in &self.per_target {
            writeln!(
                f,
                "  {:>10} {:>8} {:>8} {:>8} {:>7} {:>7} {:>8} {:>7}",
                crate::io::fmt_f64(t.target_mm),
                um(t.mean_up_um),
                um(t.mean_down_um),
                um(t.mean_um),
                um(t.s_up_um),
                um(t.s_down_um),
                um(t.reversal_um),
                um(t.r_um)
            )?;
        }
        for n in &self.notes {
            writeln!(f, "  note: {n}")?;
        }
        Ok(())
    }
}
