//! The documents the skiving commands print with `--format json`; `mtwin
//! report --skiving` reads [`SkivingSetupDoc`] back.

use serde::{Deserialize, Serialize};

use super::{SetupError, Solution, TouchFlag, UncertaintyBasis};

/// `mtwin skiving setup-error`: the four set-up errors (mm, rad), their
/// uncertainties, the first-order closed form and every touch's residual.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkivingSetupDoc {
    /// 95 % coverage factor of the uncertainties, when there are any.
    pub coverage_factor_95: Option<f64>,
    /// The estimate: `dgx`, `dgy` (mm), `exz`, `ezy` (rad), at the top level.
    #[serde(flatten)]
    pub estimate: SetupError,
    /// The first-order closed form (six standard touches), when it applies.
    pub first_order: Option<SetupError>,
    /// Residual size (mm) above which a touch is flagged.
    pub flag_noise: f64,
    /// What the other touches say about each touch.
    pub flags: Vec<TouchFlag>,
    /// Leverage of each touch.
    pub leverage: Vec<f64>,
    /// Residual of each touch after the fit (mm).
    pub residuals: Vec<f64>,
    /// Residual over its expected size, per touch (`null`: unchecked).
    pub standardized_residuals: Vec<Option<f64>>,
    /// Number of touches.
    pub touches: usize,
    /// Standard uncertainties (mm, rad), when there are any.
    pub uncertainty: Option<SetupError>,
    /// Where the uncertainties come from.
    pub uncertainty_basis: Option<UncertaintyBasis>,
}

impl SkivingSetupDoc {
    /// The document of `s` from `touches` touches, beside the first-order form.
    pub fn new(s: &Solution, first_order: Option<SetupError>, touches: usize) -> Self {
        let four = |u: [f64; 4]| SetupError {
            dgx: u[0],
            dgy: u[1],
            exz: u[2],
            ezy: u[3],
        };
        SkivingSetupDoc {
            coverage_factor_95: s.uncertainty.map(|u| u.coverage_factor_95()),
            estimate: s.estimate,
            first_order,
            flag_noise: s.flag_noise,
            flags: s.flags.clone(),
            leverage: s.leverage.clone(),
            residuals: s.residuals.clone(),
            standardized_residuals: s.standardized.clone(),
            touches,
            uncertainty: s.uncertainty.map(|u| four(u.std)),
            uncertainty_basis: s.uncertainty.map(|u| u.basis),
        }
    }
}

/// `mtwin skiving program`: the touch-off program written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkivingProgramDoc {
    /// The G-code file.
    pub out: String,
    /// Probing moves in it.
    pub probing_moves: usize,
}

/// The file is announced as a note on stderr: no human text on stdout.
impl std::fmt::Display for SkivingProgramDoc {
    fn fmt(&self, _: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        Ok(())
    }
}

/// `mtwin skiving simulate`: the simulated touches written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkivingSimulateDoc {
    /// The CSV written.
    pub out: String,
    /// Touches simulated.
    pub touches: usize,
}

impl std::fmt::Display for SkivingSimulateDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{} touches → {}", self.touches, self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::skiving::program::Plan;
    use crate::methods::skiving::simulate::{Noise, simulate};
    use crate::methods::skiving::{Geometry, Options, closed_form, identify};

    #[test]
    fn the_setup_document_round_trips_from_a_simulated_run() {
        let g = Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap();
        let plan = Plan::standard(0.0, &g).touches(&g).unwrap();
        let truth = SetupError {
            dgx: 0.02,
            dgy: -0.01,
            exz: 1e-4,
            ezy: -5e-5,
        };
        let touches = simulate(
            &plan,
            &g,
            &truth,
            Some(Noise {
                sigma: 0.001,
                seed: 3,
            }),
        )
        .unwrap();
        let s = identify(&touches, &g, &Options { noise: Some(0.001) }).unwrap();
        let first = closed_form::first_order(&touches, &g).ok();
        let doc = SkivingSetupDoc::new(&s, first, touches.len());
        assert_eq!(doc.touches, touches.len());
        assert_eq!(doc.flags.len(), touches.len());
        assert!((doc.estimate.dgx - truth.dgx).abs() < 0.005);
        let text = serde_json::to_string_pretty(&doc).unwrap();
        let back: SkivingSetupDoc = serde_json::from_str(&text).unwrap();
        assert_eq!(back, doc);
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["uncertainty_basis"]["kind"], "known_noise");
        assert!(v["dgx"].is_number() && v["flags"][0].is_string());
    }
}
