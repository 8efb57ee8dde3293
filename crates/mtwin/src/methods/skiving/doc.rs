//! The documents the skiving commands print with `--format json`; `mtwin
//! report --skiving` reads [`SkivingSetupDoc`] back.

use serde::{Deserialize, Serialize};

use super::closed_form::STANDARD_FORMULAS;
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
    /// The touches file, named in the heading of the human output.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Each touch as read: its line in the file, table angle and kind (for
    /// the table of the human output; empty when not given).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rows: Vec<TouchRowDoc>,
    /// Why the first-order closed form does not apply, when it does not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_order_not_applicable: Option<String>,
}

/// One touch of [`SkivingSetupDoc::rows`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TouchRowDoc {
    /// 1-based line of the touch in its file (the touch's number when it
    /// was not read from a file).
    pub line: usize,
    /// Table angle c, degrees.
    pub c_deg: f64,
    /// Which point of the tool touched (`face` or `tip`).
    pub point: String,
    /// Which surface was touched (`top` or `side`).
    pub contact: String,
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
            source: None,
            rows: Vec::new(),
            first_order_not_applicable: None,
        }
    }
}

/// The human output: the four values with their uncertainties (µm, µrad),
/// where the uncertainties come from, then every touch with its residual,
/// standardized residual and flag. The alternate form (`{:#}`, `--explain`)
/// adds the first-order closed forms and their formulas beside the values.
impl std::fmt::Display for SkivingSetupDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let explain = f.alternate();
        let e = &self.estimate;
        let names = SetupError::NAMES;
        write!(f, "Workpiece set-up error from {} touches", self.touches)?;
        if let Some(src) = &self.source {
            write!(f, " ({src})")?;
        }
        writeln!(f, ", exact chain, least squares")?;
        let val = [e.dgx * 1e3, e.dgy * 1e3, e.exz * 1e6, e.ezy * 1e6];
        let unit = ["µm", "µm", "µrad", "µrad"];
        let unc = self.uncertainty.map(|u| [u.dgx, u.dgy, u.exz, u.ezy]);
        let fo = self
            .first_order
            .map(|f| [f.dgx * 1e3, f.dgy * 1e3, f.exz * 1e6, f.ezy * 1e6]);
        write!(f, "  {:<4} {:>12} {:>14}", "", "value", "std. uncert.")?;
        if explain {
            write!(f, " {:>13}  formula (x = 0, six touches)", "first order")?;
        }
        writeln!(f)?;
        for k in 0..4 {
            let u = unc
                .map(|u| format!("±{:.3}", u[k] * if k < 2 { 1e3 } else { 1e6 }))
                .unwrap_or_else(|| "—".into());
            write!(
                f,
                "  {:<4} {:>12.3} {:>9} {:<4}",
                names[k], val[k], u, unit[k]
            )?;
            if explain {
                match fo {
                    Some(v) => write!(f, " {:>13.3}  {}", v[k], STANDARD_FORMULAS[k].1)?,
                    None => write!(f, " {:>13}", "—")?,
                }
            }
            writeln!(f)?;
        }
        match (self.uncertainty_basis, self.coverage_factor_95) {
            (Some(UncertaintyBasis::KnownNoise { sigma }), Some(k)) => writeln!(
                f,
                "uncertainties from the given touch noise σ = {:.3} µm; 95 % interval: ±{:.2}·u",
                sigma * 1e3,
                k
            )?,
            (Some(UncertaintyBasis::Residuals { sigma, dof }), Some(k)) => writeln!(
                f,
                "uncertainties from the residuals, σ = {:.3} µm with only {dof} degree(s) of freedom; \
                 95 % interval: ±{:.2}·u (give --noise if the touch repeatability is known)",
                sigma * 1e3,
                k
            )?,
            _ => writeln!(
                f,
                "no uncertainties: as many touches as unknowns and no --noise"
            )?,
        }
        if explain {
            match (&self.first_order, &self.first_order_not_applicable) {
                (Some(_), _) => writeln!(
                    f,
                    "first order: products of the unknowns dropped (sub-µm, sub-µrad for a few 0.01 mm and 1e-4 rad)"
                )?,
                (None, Some(why)) => writeln!(f, "first order: not applicable: {why}")?,
                (None, None) => writeln!(f, "first order: not applicable")?,
            }
        }
        if self.rows.is_empty() {
            return Ok(());
        }
        writeln!(
            f,
            "  {:>5} {:>5} {:>8} {:<5} {:<5} {:>12} {:>8}  flag",
            "touch", "line", "c [deg]", "point", "cont.", "residual µm", "r/σ"
        )?;
        for (i, t) in self.rows.iter().enumerate() {
            let st = self
                .standardized_residuals
                .get(i)
                .copied()
                .flatten()
                .map(|v| format!("{v:.2}"))
                .unwrap_or_else(|| "—".into());
            writeln!(
                f,
                "  {:>5} {:>5} {:>8.3} {:<5} {:<5} {:>12.4} {:>8}  {}",
                i + 1,
                t.line,
                t.c_deg,
                t.point,
                t.contact,
                self.residuals.get(i).copied().unwrap_or(f64::NAN) * 1e3,
                st,
                self.flags.get(i).map_or("—", |fl| fl.name())
            )?;
        }
        Ok(())
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
    use crate::methods::skiving::{Geometry, Options, closed_form, identify, run};

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

    #[test]
    fn the_setup_document_prints_values_touches_and_on_request_the_closed_forms() {
        let g = Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap();
        let plan = Plan::standard(0.0, &g).touches(&g).unwrap();
        let truth = SetupError {
            dgx: 0.03,
            dgy: -0.02,
            exz: 2e-4,
            ezy: -1e-4,
        };
        // No noise: the exact solution is the truth.
        let touches = simulate(&plan, &g, &truth, None).unwrap();
        let (_, _, mut doc) = run(&touches, &g, &Options { noise: Some(0.001) }).unwrap();
        doc.source = Some("touches.csv".into());
        let text = doc.to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "Workpiece set-up error from 6 touches (touches.csv), exact chain, least squares"
        );
        // dgx = 30 µm, ezy = −100 µrad, to the printed 3 decimals.
        assert!(
            lines[2].starts_with("  dgx") && lines[2].contains("30.000"),
            "{text}"
        );
        assert!(
            lines[5].starts_with("  ezy") && lines[5].contains("-100.000"),
            "{text}"
        );
        assert!(lines[6].starts_with("uncertainties from the given touch noise σ = 1.000 µm"));
        // The touch table: a header and one line per touch, numbered 1…6.
        assert!(lines[7].contains("touch") && lines[7].ends_with("flag"));
        assert_eq!(lines.len(), 8 + 6);
        assert!(lines[13].trim_start().starts_with("6 "), "{text}");
        assert!(!text.contains("formula"));
        // The alternate form adds the closed forms and their formulas.
        let explained = format!("{doc:#}");
        assert!(explained.contains("formula (x = 0, six touches)"));
        for (_, formula) in STANDARD_FORMULAS {
            assert!(explained.contains(formula), "{formula}");
        }
        assert!(explained.contains("first order: products of the unknowns dropped"));
        // The rows round-trip with the rest.
        let back: SkivingSetupDoc =
            serde_json::from_str(&serde_json::to_string(&doc).unwrap()).unwrap();
        assert_eq!(back, doc);
        assert_eq!(back.to_string(), text);
    }
}
