//! The documents the tracker commands print (`--format json` is their serde
//! form, the human text their `Display`); `mtwin report` reads
//! [`TrackerIdentifyDoc`] and [`TrackerValidateDoc`] back.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::Identification;
use super::compensate::CompensationMode;
use super::validate::{ErrorStats, Stats, Validation};
use crate::fit::{
    ConfoundedGroup, Convergence, DeterminedCombination, DroppedDirection, Estimate, FitReport,
    GaugedParameter, Outlier, UndeterminedDirection, Warning,
};

/// Scale and unit of a parameter by its name, for display: registration
/// translations (`REG.tx` …) in mm, rotations (`EA…`, `EB…`, `EC…`,
/// `REG.a/b/c`) in µrad, the other errors in µm.
pub fn unit_of(name: &str) -> (f64, &'static str) {
    if let Some(r) = name.strip_prefix("REG.") {
        return if r.starts_with('t') {
            (1.0, "mm")
        } else {
            (1e6, "µrad")
        };
    }
    match name.chars().nth(1) {
        Some('A' | 'B' | 'C') => (1e6, "µrad"),
        _ => (1e3, "µm"),
    }
}

/// `mtwin identify`: the fitted geometric errors, their identifiability and
/// uncertainties, the residuals before and after.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrackerIdentifyDoc {
    /// Condition number of the scaled Jacobian of the estimated parameters.
    pub condition_number: f64,
    /// Per group of confounded parameters, the combinations the points
    /// determine (value and standard uncertainty in the unit of the leading
    /// parameter, fit units mm or rad); empty when every parameter is
    /// determined.
    #[serde(default)]
    pub confounded_groups: Vec<ConfoundedGroup>,
    /// How the tracker identify gauge was fixed: `start` (the errors pulled
    /// to 0, the minimum-norm solution), `prior` (to a previous
    /// calibration), `null` when every parameter is determined or no gauge
    /// was fixed.
    #[serde(default)]
    pub gauge: Option<String>,
    /// The parameters set by the gauge: name, prior, gauge-fixed value (fit
    /// units) and the share the points do not determine.
    #[serde(default)]
    pub gauge_fixed: Vec<GaugedParameter>,
    /// The determined combinations of every group, as sentences with
    /// their value (display units).
    #[serde(default)]
    pub identifiable_combinations: Vec<String>,
    /// The rank rule for badly determined directions (`off`, `rcond=X`,
    /// `std=X`), `null` without gauge fixing.
    #[serde(default)]
    pub truncation: Option<String>,
    /// The badly determined directions the rule set to the prior: relative
    /// singular value, component and its uncertainty, the residual change
    /// RMS keeping it would have bought (mm), the error it moves most, the
    /// move and the bias bound (fit units).
    #[serde(default)]
    pub dropped_directions: Vec<DroppedDirection>,
    /// RMS change of the residuals the truncation caused (mm).
    #[serde(default)]
    pub truncation_rms_change: f64,
    /// How the iteration ended.
    pub convergence: Convergence,
    /// Every parameter (errors, then registration), in the fit's units (mm, rad).
    pub estimates: Vec<Estimate>,
    /// The identified machine file written.
    pub out: String,
    /// Measurement points flagged as outliers.
    pub outliers: Vec<Outlier>,
    /// Number of parameters.
    pub parameters: usize,
    /// Number of measured points.
    #[serde(default)]
    pub points: usize,
    /// Numerical rank: parameters determined by the data.
    pub rank: usize,
    /// Fitted registration of the tracker frame (tx, ty, tz mm; a, b, c rad), if fitted.
    pub registration: Option<[f64; 6]>,
    /// Confounded combinations, as sentences.
    pub relations: Vec<String>,
    /// Residual RMS per coordinate with the identified model (mm).
    pub rms_after: f64,
    /// Residual RMS per coordinate with the nominal model (mm).
    pub rms_before: f64,
    /// Estimated standard deviation of the measurement (mm), when there are degrees of freedom.
    pub sigma: Option<f64>,
    /// Names of the parameters not determined individually by the points
    /// (their values are set by the gauge, see `gauge_fixed`).
    pub unidentifiable: Vec<String>,
    /// Things to know about the result.
    pub warnings: Vec<Warning>,
}

impl TrackerIdentifyDoc {
    /// The document of `id`, fitted to `points` measurements, written to `out`.
    pub fn new(id: &Identification, points: usize, out: &str) -> Self {
        let r: &FitReport = &id.report;
        let (rms_before, rms_after) = r.rms();
        let g = r.gauge.as_ref();
        let groups = g.map(|g| g.groups.clone()).unwrap_or_default();
        TrackerIdentifyDoc {
            condition_number: r.condition_number,
            identifiable_combinations: groups
                .iter()
                .flat_map(|g| g.determined.iter().map(sentence))
                .collect(),
            confounded_groups: groups,
            gauge: g.map(|g| g.kind.clone()),
            gauge_fixed: g.map(|g| g.parameters.clone()).unwrap_or_default(),
            truncation: g.map(|g| g.truncation.clone()),
            dropped_directions: g.map(|g| g.dropped.clone()).unwrap_or_default(),
            truncation_rms_change: g.map_or(0.0, |g| g.truncation_rms_change),
            convergence: r.convergence.clone(),
            estimates: r.estimates.clone(),
            out: out.to_string(),
            outliers: r.outliers.flagged.clone(),
            parameters: r.estimates.len(),
            points,
            rank: r.identifiability.rank,
            registration: id.registration,
            relations: r
                .identifiability
                .relations
                .iter()
                .map(|c| c.describe())
                .collect(),
            rms_after,
            rms_before,
            sigma: r.sigma,
            unidentifiable: r
                .unidentifiable_names()
                .into_iter()
                .map(String::from)
                .collect(),
            warnings: r.warnings.clone(),
        }
    }
}

/// `EXX.c0 − 1.0000·EX0Y (free)`: a direction the points do not see.
pub fn free_sentence(d: &UndeterminedDirection) -> String {
    format!("{} (free)", d.describe())
}

/// `s/s_max 1.2e-5: EXX.c0 moved by −73.000 µm (bias ≤ 90.000 µm); keeping
/// it changes the residuals by 0.300 µm RMS` (display units).
pub fn dropped_sentence(d: &DroppedDirection) -> String {
    let (scale, unit) = unit_of(&d.parameter);
    format!(
        "s/s_max {:.2e}: {} moved by {:.3} {unit} (bias ≤ {:.3} {unit}); keeping it changes the residuals by {:.3} µm RMS",
        d.relative_singular_value,
        d.parameter,
        d.shift * scale,
        d.bias_bound * scale,
        d.rms_change * 1e3
    )
}

/// `EXX.c0 + 1.0000·EX0Y = 12.345 ± 0.678 µm` (the unit of the leading
/// parameter).
pub fn sentence(c: &DeterminedCombination) -> String {
    let (scale, unit) = c.terms.first().map_or((1.0, ""), |t| unit_of(&t.name));
    let u = c
        .uncertainty
        .map_or(String::new(), |u| format!(" ± {:.3}", u * scale));
    format!("{} = {:.3}{u} {unit}", c.describe(), c.value * scale)
}

impl fmt::Display for TrackerIdentifyDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} points, {} parameters: rank {}, condition number {:.3e}",
            self.points, self.parameters, self.rank, self.condition_number
        )?;
        writeln!(
            f,
            "{:<10} {:>14} {:>14}  unit",
            "parameter", "value", "uncertainty"
        )?;
        let gauged = |name: &str| self.gauge_fixed.iter().any(|g| g.name == name);
        for e in &self.estimates {
            if e.unidentifiable.is_some() && !gauged(&e.name) {
                continue;
            }
            let (scale, unit) = unit_of(&e.name);
            let unit = if e.unidentifiable.is_some() {
                format!("{unit} (gauge)")
            } else {
                unit.to_string()
            };
            let u = e
                .uncertainty
                .map_or("-".to_string(), |u| format!("{:.3}", u * scale));
            writeln!(
                f,
                "{:<10} {:>14.3} {:>14}  {unit}",
                e.name,
                e.value * scale,
                u
            )?;
        }
        if !self.unidentifiable.is_empty() && self.gauge.is_none() {
            writeln!(
                f,
                "not identifiable (kept at 0): {}",
                self.unidentifiable.join(", ")
            )?;
            for c in &self.relations {
                writeln!(f, "  {c}")?;
            }
        } else if !self.unidentifiable.is_empty() {
            let prior = match self.gauge.as_deref() {
                Some("prior") => "the prior calibration",
                _ => "0 (minimum norm)",
            };
            writeln!(
                f,
                "not determined individually, set by the gauge (pulled to {prior}; marked (gauge)): {}",
                self.unidentifiable.join(", ")
            )?;
            writeln!(f, "combinations the points determine:")?;
            for g in &self.confounded_groups {
                writeln!(
                    f,
                    "  group {} ({} undetermined):",
                    g.parameters.join(", "),
                    g.undetermined
                )?;
                for c in &g.determined {
                    writeln!(f, "    {}", sentence(c))?;
                }
                for d in &g.undetermined_directions {
                    writeln!(f, "    {}", free_sentence(d))?;
                }
            }
        }
        if !self.dropped_directions.is_empty() {
            writeln!(
                f,
                "badly determined directions set to the prior ({}): {}, residual change {:.3} µm RMS",
                self.truncation.as_deref().unwrap_or("off"),
                self.dropped_directions.len(),
                self.truncation_rms_change * 1e3
            )?;
            for d in &self.dropped_directions {
                writeln!(f, "  {}", dropped_sentence(d))?;
            }
        }
        writeln!(
            f,
            "residual RMS per coordinate: before {:.2} µm, after {:.2} µm",
            self.rms_before * 1e3,
            self.rms_after * 1e3
        )?;
        for o in &self.outliers {
            writeln!(
                f,
                "outlier: point {} (RMS {:.2} µm)",
                o.block + 1,
                o.rms * 1e3
            )?;
        }
        Ok(())
    }
}

/// `mtwin validate`: tool-tip error statistics at check points with the
/// nominal (before) and the identified (after) model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrackerValidateDoc {
    /// Measured − identified model (mm).
    pub after: ErrorStats,
    /// Measured − nominal model (mm).
    pub before: ErrorStats,
    /// `after/before − 1` (percent); NaN (`null`) where before is 0.
    pub change_percent: ErrorStats,
    /// Number of check points.
    pub points: usize,
    /// RMS of |Δp| after (mm).
    pub rms_after: f64,
    /// RMS of |Δp| before (mm).
    pub rms_before: f64,
}

impl From<&Validation> for TrackerValidateDoc {
    fn from(v: &Validation) -> Self {
        TrackerValidateDoc {
            after: v.after,
            before: v.before,
            change_percent: v.change,
            points: v.points,
            rms_after: v.after.rms(),
            rms_before: v.before.rms(),
        }
    }
}

impl fmt::Display for TrackerValidateDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} check points: |error| before (nominal) and after (identified model)",
            self.points
        )?;
        writeln!(
            f,
            "{:<5} {:>26} {:>26} {:>21}",
            "", "before max/mean/std µm", "after max/mean/std µm", "change max/mean/std %"
        )?;
        let (b, a, c) = (&self.before, &self.after, &self.change_percent);
        let row = |f: &mut fmt::Formatter<'_>, n: &str, b: &Stats, a: &Stats, c: &Stats| {
            writeln!(
                f,
                "{n:<5} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>6.0} {:>6.0} {:>6.0}",
                b.max * 1e3,
                b.mean * 1e3,
                b.std * 1e3,
                a.max * 1e3,
                a.mean * 1e3,
                a.std * 1e3,
                c.max,
                c.mean,
                c.std
            )
        };
        row(f, "x", &b.x, &a.x, &c.x)?;
        row(f, "y", &b.y, &a.y, &c.y)?;
        row(f, "z", &b.z, &a.z, &c.z)?;
        row(f, "|Δp|", &b.distance, &a.distance, &c.distance)
    }
}

/// Expected standard uncertainty of one parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExpectedUncertainty {
    /// Parameter name.
    pub name: String,
    /// Expected standard uncertainty (mm, rad); `None` when not identifiable.
    pub uncertainty: Option<f64>,
}

/// `mtwin plan tracker`: the chosen poses and the identification they promise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrackerPlanDoc {
    /// Candidate poses drawn.
    #[serde(default)]
    pub candidates: usize,
    /// Condition number of the expected fit.
    pub condition_number: f64,
    /// Per parameter, at the assumed noise.
    pub expected_uncertainties: Vec<ExpectedUncertainty>,
    /// Assumed measurement noise (mm).
    #[serde(default)]
    pub noise: f64,
    /// Number of parameters.
    pub parameters: usize,
    /// Poses chosen.
    pub poses: usize,
    /// Expected rank.
    pub rank: usize,
    /// Parameters these poses cannot determine.
    pub unidentifiable: Vec<String>,
}

impl TrackerPlanDoc {
    /// The document of an expected identification `r` over `poses` chosen poses.
    pub fn new(r: &FitReport, poses: usize, candidates: usize, noise: f64) -> Self {
        TrackerPlanDoc {
            candidates,
            condition_number: r.condition_number,
            expected_uncertainties: r
                .estimates
                .iter()
                .map(|e| ExpectedUncertainty {
                    name: e.name.clone(),
                    uncertainty: e.uncertainty,
                })
                .collect(),
            noise,
            parameters: r.estimates.len(),
            poses,
            rank: r.identifiability.rank,
            unidentifiable: r
                .unidentifiable_names()
                .into_iter()
                .map(String::from)
                .collect(),
        }
    }
}

impl fmt::Display for TrackerPlanDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} of {} candidate poses chosen: rank {} of {} parameters, condition number {:.3e}",
            self.poses, self.candidates, self.rank, self.parameters, self.condition_number
        )?;
        writeln!(
            f,
            "expected standard uncertainty at {} µm noise:",
            self.noise * 1e3
        )?;
        for e in &self.expected_uncertainties {
            if let Some(u) = e.uncertainty {
                let (s, unit) = unit_of(&e.name);
                writeln!(f, "  {:<10} {:>10.3} {unit}", e.name, u * s)?;
            }
        }
        if !self.unidentifiable.is_empty() {
            writeln!(
                f,
                "not identifiable from these poses: {}",
                self.unidentifiable.join(", ")
            )?;
        }
        Ok(())
    }
}

/// `mtwin simulate tracker`: the simulated measurement written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrackerSimulateDoc {
    /// Standard deviation of the noise added per coordinate (mm).
    pub noise: f64,
    /// The CSV written.
    pub out: String,
    /// Points simulated.
    pub points: usize,
    /// Random seed.
    pub seed: u64,
}

/// The file is announced as a note on stderr: no human text on stdout.
impl fmt::Display for TrackerSimulateDoc {
    fn fmt(&self, _: &mut fmt::Formatter<'_>) -> fmt::Result {
        Ok(())
    }
}

/// `mtwin compensate-points`: corrected axis commands for target poses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompensatePointsDoc {
    /// Largest predicted tip error after correction (mm).
    pub max_error_after: f64,
    /// Largest predicted tip error before correction (mm).
    pub max_error_before: f64,
    /// What the correction matches.
    pub mode: CompensationMode,
    /// The CSV written.
    pub out: String,
    /// Poses corrected.
    pub poses: usize,
}

impl fmt::Display for CompensatePointsDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} poses corrected ({:?}): predicted tip error max {:.2} µm before, {:.2e} µm after → {}",
            self.poses,
            self.mode,
            self.max_error_before * 1e3,
            self.max_error_after * 1e3,
            self.out
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::tracker::compensate::PointCompensator;
    use crate::methods::tracker::{IdentifyOptions, identify, plan, simulate, validate};
    use crate::model::{Machine, ParameterSet, parse_machine};
    use std::path::Path;

    fn machine(name: &str, text: &str) -> Machine {
        parse_machine(Path::new(name), text).unwrap()
    }

    fn round_trip<D>(doc: &D) -> D
    where
        D: Serialize + for<'de> Deserialize<'de>,
    {
        serde_json::from_str(&serde_json::to_string_pretty(doc).unwrap()).unwrap()
    }

    #[test]
    fn every_tracker_document_round_trips_from_a_real_run() {
        let truth = machine(
            "afp-gantry-with-errors.toml",
            include_str!("../../../../../examples/machines/afp-gantry-with-errors.toml"),
        );
        let nominal = machine(
            "afp-gantry.toml",
            include_str!("../../../../../examples/machines/afp-gantry.toml"),
        );
        let params = ParameterSet::from_spec(&nominal, "location").unwrap();
        let p = plan::plan(&nominal, &params, 200, 60, 0.010, 1).unwrap();
        let pd = TrackerPlanDoc::new(&p.expected, p.poses.len(), 200, 0.010);
        assert_eq!((pd.poses, pd.candidates), (60, 200));
        assert_eq!(round_trip(&pd), pd);

        let points = simulate::simulate_seeded(&truth, &p.poses, 0.005, 1);
        let id = identify(
            &nominal,
            &params,
            &points,
            &IdentifyOptions::default(),
            &|_| {},
        )
        .unwrap();
        let doc = TrackerIdentifyDoc::new(&id, points.len(), "id.toml");
        assert_eq!(doc.points, 60);
        assert_eq!(doc.parameters, doc.estimates.len());
        assert!(doc.rms_after < doc.rms_before);
        assert_eq!(round_trip(&doc), doc);
        assert!(doc.to_string().starts_with("60 points, "));

        let check = simulate::simulate_seeded(&truth, &p.poses[..20], 0.005, 2);
        let v = TrackerValidateDoc::from(&validate(&id.machine, &check));
        assert_eq!(v.points, 20);
        assert_eq!(round_trip(&v), v);

        let c = PointCompensator::new(&id.machine);
        let cd = CompensatePointsDoc {
            max_error_after: 1e-9,
            max_error_before: 0.02,
            mode: c.mode(),
            out: "c.csv".into(),
            poses: 3,
        };
        assert_eq!(round_trip(&cd), cd);
        let sd = TrackerSimulateDoc {
            noise: 0.01,
            out: "s.csv".into(),
            points: 60,
            seed: 4,
        };
        assert_eq!(round_trip(&sd), sd);
    }

    #[test]
    fn a_change_over_a_zero_reads_back_as_nan() {
        let s: Stats = serde_json::from_str(r#"{"max": null, "mean": 1.5, "std": 0.0}"#).unwrap();
        assert!(s.max.is_nan() && s.mean == 1.5);
    }
}
