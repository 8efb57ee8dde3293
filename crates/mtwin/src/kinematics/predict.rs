//! `mtwin predict`: the actual tool tip and tool axis of a machine with errors
//! at given axis positions, and how far it is from the nominal machine
//! ([`PredictDoc`]).

use std::fmt;

use serde::{Deserialize, Serialize};

use super::{Kinematics, ToolPose};
use crate::model::Machine;

/// Columns the prediction CSV writes after the axis columns: the actual tool
/// tip x, y, z (mm) and tool axis i, j, k in the workpiece frame W.
pub const PREDICT_COLUMNS: [&str; 6] = ["x", "y", "z", "i", "j", "k"];

/// The actual tool poses of `m` (with its errors) at `poses` (one row of axis
/// positions per pose, mm and deg, in `m.axis_names()` order), and the summary
/// of their distance to the nominal tool tips.
pub fn run(m: &Machine, poses: &[Vec<f64>], out: &str) -> (Vec<ToolPose>, PredictDoc) {
    let flat: Vec<f64> = poses.iter().flatten().copied().collect();
    let actual = Kinematics::new(m).poses(&flat);
    let nominal = Kinematics::nominal(m).poses(&flat);
    let errs: Vec<f64> = actual
        .iter()
        .zip(&nominal)
        .map(|(a, n)| (a.tip - n.tip).norm())
        .collect();
    let max = errs.iter().copied().fold(0.0, f64::max);
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt();
    let doc = PredictDoc {
        out: out.to_string(),
        poses: poses.len(),
        volumetric_error_max: max,
        volumetric_error_rms: rms,
    };
    (actual, doc)
}

/// Summary of a prediction: the volumetric error |Δp| between the actual and
/// the nominal tool tip over the given poses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PredictDoc {
    /// The CSV written.
    pub out: String,
    /// Number of poses.
    pub poses: usize,
    /// Largest |Δp| (mm).
    pub volumetric_error_max: f64,
    /// RMS of |Δp| (mm).
    pub volumetric_error_rms: f64,
}

impl fmt::Display for PredictDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} poses → {}\nvolumetric error |Δp| (actual − nominal): max {:.2} µm, rms {:.2} µm",
            self.poses,
            self.out,
            self.volumetric_error_max * 1e3,
            self.volumetric_error_rms * 1e3
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_document_round_trips_through_json() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/machines/ac-trunnion-with-errors.toml"
        );
        let m = crate::model::read_machine(std::path::Path::new(path)).unwrap();
        let poses = vec![vec![0.0; m.n_axes()], vec![10.0; m.n_axes()]];
        let (actual, doc) = run(&m, &poses, "pred.csv");
        assert_eq!(actual.len(), 2);
        assert_eq!(doc.poses, 2);
        assert!(doc.volumetric_error_max >= doc.volumetric_error_rms);
        assert!(doc.volumetric_error_max > 0.0);
        let back: PredictDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&doc).unwrap()).unwrap();
        assert_eq!(back, doc);
    }
}
