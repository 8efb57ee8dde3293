//! Joint identification of the eight PIGEs from any subset of the four modes.
//!
//! 1. **What the modes can tell.** The engine's identifiability analysis is
//!    run on the same angles at the *ideal* configuration (nominal machine,
//!    no set-up error): there an effect that exists only at second order
//!    (a tilt seen through the set-up error in mode 1, say) is exactly zero,
//!    and `EY0A`/`EY0C` in mode 3 are exactly confounded. Such effects do
//!    exist in real data but are far too weak to carry an estimate, so the
//!    PIGEs the analysis rejects are held at 0 and reported with the reason.
//! 2. **Start** from the closed forms ([`super::closed_form`]).
//! 3. **Joint Levenberg–Marquardt** ([`crate::fit`]) over the four
//!    [`ModeModel`]s stacked, on the exact model, with the bar length of
//!    each mode as a nuisance parameter (subtracting the single
//!    noisy 0° reading instead roughly triples the uncertainty of EC0A).
//!    Standard uncertainties come from the residual variance.
//! 4. **Gauge** ([`crate::fit::gauge`], as for the tracker): with
//!    [`IdentifyOptions::default`] (`fit.gauge` = [`fit::Gauge::Start`])
//!    any direction the fit cannot determine at the actual configuration
//!    is pulled to the prior — 0 for the PIGEs, the closed-form start for
//!    the bar lengths — the covariance is the gauge-fixed pseudo-inverse,
//!    and the confounded groups with their determined combinations are
//!    reported; a [`fit::Truncation`] rule (`fit.truncation`) sets badly
//!    determined directions to the same prior and reports the bias. The
//!    structurally unresolved PIGEs of step 1 are the zero columns of this
//!    gauge: held at 0.
//! 5. **Combinations** of the structurally confounded PIGEs: the groups of
//!    the analysis of step 1 (in the sparse basis of [`crate::fit::gauge`]),
//!    each determined combination `Σ c_j·θ_j` evaluated at the solution with
//!    its standard uncertainty ([`Identification::combinations`]): what the
//!    readings tell about PIGEs they cannot separate.

use super::closed_form::start_values;
use super::data::ModeData;
use super::mode::{
    BallbarMode, ModeModel, Rig, Trunnion, TrunnionError, Unknowns, predicted_reading,
};
use super::{Pige, Piges};
use crate::fit::{
    self, ConfoundedGroup, FitError, FitReport, Model, Options, Stack, Unidentifiable,
};
use crate::model::Machine;

/// A mode whose residual RMS exceeds this factor times the median of the
/// others' is flagged.
pub const RESIDUAL_IMBALANCE: f64 = 3.0;

/// Why an identification could not be run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BallbarIdentifyError {
    /// None of the four modes was given.
    #[error("no mode data given; at least one of the four modes is needed")]
    NoModes,
    /// A rig length (bar length, ZB1C, ZB1A) is not a positive finite length.
    #[error("{what} is {} mm; it must be a positive finite length", crate::limits::fmt_message_number(*.value))]
    BadRig {
        /// Which length.
        what: &'static str,
        /// Its value, mm.
        value: f64,
    },
    /// The tool-ball set-up error is not finite.
    #[error("the set-up error ({}, {}) mm is not finite", crate::limits::fmt_message_number(*.ex), crate::limits::fmt_message_number(*.ey))]
    BadSetup {
        /// eX, mm.
        ex: f64,
        /// eY, mm.
        ey: f64,
    },
    /// The machine is not a double turntable with A carrying C.
    #[error(transparent)]
    Machine(#[from] TrunnionError),
    /// The angles of a mode leave the travel of its rotary axis.
    #[error(
        "{mode}: the angles {}°..{}° lie outside the travel of {axis} ([{}, {}]°)",
        crate::limits::fmt_message_number(*.lo),
        crate::limits::fmt_message_number(*.hi),
        crate::limits::fmt_message_number(*.tlo),
        crate::limits::fmt_message_number(*.thi)
    )]
    OutOfTravel {
        /// The mode (`mode1` … `mode4`).
        mode: &'static str,
        /// The rotary axis (`A` or `C`).
        axis: &'static str,
        /// Smallest angle of the data, degrees.
        lo: f64,
        /// Largest angle of the data, degrees.
        hi: f64,
        /// Lower end of the axis travel, degrees.
        tlo: f64,
        /// Upper end of the axis travel, degrees.
        thi: f64,
    },
    /// The least-squares engine failed.
    #[error("the least-squares fit failed: {0}")]
    Fit(#[from] FitError),
}

/// A PIGE the given modes cannot determine.
#[derive(Debug, Clone, PartialEq)]
pub struct Unresolved {
    /// The PIGE.
    pub pige: Pige,
    /// Plain sentence: why.
    pub reason: String,
}

/// The result of [`identify`].
#[derive(Debug, Clone)]
pub struct Identification {
    /// Identified values (mm, rad); PIGEs not estimated are 0.
    pub piges: Piges,
    /// Standard uncertainty of every estimated PIGE.
    pub uncertainty: [Option<f64>; 8],
    /// The PIGEs the modes cannot determine, with the reason.
    pub unresolved: Vec<Unresolved>,
    /// The PIGEs the modes given structurally cannot separate (the
    /// confounded ones of [`Identification::unresolved`] and their
    /// partners), grouped, with the combinations the readings determine —
    /// their value and standard uncertainty at the solution (where the held
    /// PIGEs are 0 and their partners carry the whole combination) — and
    /// the directions they cannot see (fit units mm, rad). Empty when no
    /// PIGE is confounded.
    pub combinations: Vec<ConfoundedGroup>,
    /// Fitted bar length of each mode taking part (mm).
    pub lengths: [Option<f64>; 4],
    /// Residual RMS of each mode taking part at the solution (mm).
    pub residual_rms: [Option<f64>; 4],
    /// Warnings from the engine and about the residual balance of the modes.
    pub warnings: Vec<String>,
    /// The machine with the identified PIGEs written in.
    pub machine: Machine,
    /// The A and C axes of the machine the identification used.
    pub trunnion: Trunnion,
    /// The rig geometry and set-up error used.
    pub rig: Rig,
    /// The engine's full report.
    pub report: FitReport,
}

/// The corrected axis-line positions a controller takes (mm): where the
/// actual axis lines pass, nominal position plus the identified offset.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Compensation {
    /// y of the A-axis line in M.
    #[serde(rename = "A_line_y")]
    pub a_y: f64,
    /// z of the A-axis line in M.
    #[serde(rename = "A_line_z")]
    pub a_z: f64,
    /// x of the C-axis line in the A frame.
    #[serde(rename = "C_line_x")]
    pub c_x: f64,
    /// y of the C-axis line in the A frame.
    #[serde(rename = "C_line_y")]
    pub c_y: f64,
}

impl Identification {
    /// Whether `p` was estimated.
    pub fn is_estimated(&self, p: Pige) -> bool {
        self.uncertainty[p.index()].is_some() || !self.unresolved.iter().any(|u| u.pige == p)
    }

    /// The four compensation values (corrected axis-line positions).
    pub fn compensation(&self) -> Compensation {
        let a = &self.machine.axes[self.trunnion.a];
        let c = &self.machine.axes[self.trunnion.c];
        let p = &self.piges;
        Compensation {
            a_y: a.origin.y + p.get(Pige::EY0A),
            a_z: a.origin.z + p.get(Pige::EZ0A),
            c_x: c.origin.x - a.origin.x + p.get(Pige::EX0C),
            c_y: c.origin.y - a.origin.y + p.get(Pige::EY0C),
        }
    }

    /// The fitted `ΔL(α) = L(α) − ℓ` (mm) of `mode` on the identified machine.
    pub fn fitted_delta_l(&self, mode: BallbarMode, alpha_deg: f64) -> Option<f64> {
        let ell = self.lengths[mode.index()]?;
        Some(
            predicted_reading(
                &self.machine,
                &self.trunnion,
                mode,
                &self.rig,
                ell,
                alpha_deg,
            ) - ell,
        )
    }
}

/// The inputs of [`run`]: the machine, the rig and the readings of the
/// modes given.
#[derive(Debug, Clone, Copy)]
pub struct IdentifyInputs<'a> {
    /// Nominal geometry and any PDGEs; its PIGEs are replaced by the identified ones.
    pub machine: &'a Machine,
    /// Bar length, tool-ball placements and set-up error (mm).
    pub rig: Rig,
    /// Readings of each mode given, in [`BallbarMode::ALL`](super::BallbarMode::ALL) order.
    pub modes: [Option<&'a ModeData>; 4],
}

/// Options of [`run`].
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct IdentifyOptions {
    /// Options of the least-squares engine (including its parallelism,
    /// `fit.par`). The default gauge-fixes the solution (`fit.gauge` is
    /// [`fit::Gauge::Start`]: PIGEs the fit cannot determine are pulled to
    /// 0, bar lengths to their closed-form start) with the engine's default
    /// truncation rule (off).
    pub fit: Options,
    /// Name of the file the caller writes the identified machine to, reported by the document.
    pub out: Option<String>,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        let mut fit = Options::default();
        fit.gauge = fit::Gauge::Start;
        Self { fit, out: None }
    }
}

/// `mtwin ballbar identify`: the identification ([`identify`]) and its
/// document (the document's `plots` are empty: the caller adds the plots it
/// writes, see [`super::plot::polar_plot`]).
pub fn run(
    inputs: &IdentifyInputs<'_>,
    options: &IdentifyOptions,
) -> Result<(Identification, super::BallbarIdentifyDoc), BallbarIdentifyError> {
    let id = identify(inputs.machine, &inputs.rig, &inputs.modes, &options.fit)?;
    let doc = super::BallbarIdentifyDoc::new(&id, options.out.clone(), Vec::new());
    Ok((id, doc))
}

/// Identifies the PIGEs from the modes given (`data[mode.index()]`).
///
/// `machine` supplies the nominal geometry and any PDGEs; the eight PIGEs it
/// may carry are ignored and replaced by the identified (absolute) values.
pub fn identify(
    machine: &Machine,
    rig: &Rig,
    data: &[Option<&ModeData>; 4],
    options: &Options,
) -> Result<Identification, BallbarIdentifyError> {
    for (what, value) in [
        ("the bar length", rig.length),
        ("ZB1C", rig.zb1c),
        ("ZB1A", rig.zb1a),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(BallbarIdentifyError::BadRig { what, value });
        }
    }
    if !(rig.setup.ex.is_finite() && rig.setup.ey.is_finite()) {
        return Err(BallbarIdentifyError::BadSetup {
            ex: rig.setup.ex,
            ey: rig.setup.ey,
        });
    }
    let modes: Vec<BallbarMode> = BallbarMode::ALL
        .into_iter()
        .filter(|m| data[m.index()].is_some())
        .collect();
    if modes.is_empty() {
        return Err(BallbarIdentifyError::NoModes);
    }
    let trunnion = Trunnion::of(machine)?;
    for &m in &modes {
        let d = data[m.index()].expect("present");
        let ax = &machine.axes[trunnion.axis_of(if m.moves_a() { Pige::EY0A } else { Pige::EX0C })];
        let lo = d.angles_deg.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = d
            .angles_deg
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        if lo < ax.travel[0] || hi > ax.travel[1] {
            return Err(BallbarIdentifyError::OutOfTravel {
                mode: m.label(),
                axis: m.axis_name(),
                lo,
                hi,
                tlo: ax.travel[0],
                thi: ax.travel[1],
            });
        }
    }
    let mut base = machine.clone();
    Piges::default().write_to(&mut base, &trunnion);

    // 1. Structural identifiability at the ideal configuration.
    let (unresolved, structural_groups) = structural(&base, &trunnion, rig, data, &modes, options)?;
    let free: Vec<Pige> = Pige::ALL
        .into_iter()
        .filter(|p| !unresolved.iter().any(|u| u.pige == *p))
        .collect();

    // 2. Start.
    let standard = {
        let a = &machine.axes[trunnion.a].direction;
        let c = &machine.axes[trunnion.c].direction;
        (a - nalgebra::Vector3::x()).norm() < 1e-9 && (c - nalgebra::Vector3::z()).norm() < 1e-9
    };
    let (mut start, lengths0) = start_values(data, rig);
    if !standard {
        start = Piges::default();
    }
    let unknowns = Unknowns {
        free,
        fixed: Piges::default(),
        modes: modes.clone(),
    };
    let theta0 = unknowns.theta(&start, &lengths0);

    // 3. Joint fit.
    let models: Vec<ModeModel> = modes
        .iter()
        .map(|&m| {
            ModeModel::new(
                &base,
                &trunnion,
                m,
                *rig,
                data[m.index()].expect("present"),
                &unknowns,
            )
        })
        .collect();
    let parts: Vec<&dyn Model> = models.iter().map(|m| m as &dyn Model).collect();
    let stack = Stack::new(parts)?;
    // The gauge's prior: 0 for the PIGEs, the start for the bar lengths.
    let mut fit_options = options.clone();
    if fit_options.gauge == fit::Gauge::Start {
        let mut prior = theta0.clone();
        prior[..unknowns.free.len()].fill(0.0);
        fit_options.gauge = fit::Gauge::Prior(prior);
    }
    let report = fit::fit(&stack, &theta0, &fit_options)?;

    let piges = unknowns.piges(&report.theta);
    let mut uncertainty = [None; 8];
    for (k, p) in unknowns.free.iter().enumerate() {
        uncertainty[p.index()] = report.estimates[k].uncertainty;
    }
    let mut lengths = [None; 4];
    let mut residual_rms = [None; 4];
    for &m in &modes {
        let k = unknowns.length_index(m).expect("present");
        lengths[m.index()] = Some(report.theta[k]);
        residual_rms[m.index()] = report
            .groups
            .iter()
            .find(|g| g.label == m.label())
            .map(|g| g.rms_after);
    }
    let mut warnings: Vec<String> = report.warnings.iter().map(|w| w.to_string()).collect();
    warnings.extend(imbalance(&residual_rms));
    let mut identified = base.clone();
    piges.write_to(&mut identified, &trunnion);
    let combinations = evaluate_groups(structural_groups, &unknowns, &report);
    Ok(Identification {
        piges,
        uncertainty,
        unresolved,
        combinations,
        lengths,
        residual_rms,
        warnings,
        machine: identified,
        trunnion,
        rig: *rig,
        report,
    })
}

/// The PIGEs the given modes cannot determine, from the engine's analysis
/// at the ideal configuration. The hint of each (which modes to add) is
/// derived the same way: the analysis is repeated with each absent mode
/// added (its readings at the angles of a given mode of the same axis, or
/// an even spread), and the modes after which the PIGE is determined are
/// named.
fn structural(
    base: &Machine,
    trunnion: &Trunnion,
    rig: &Rig,
    data: &[Option<&ModeData>; 4],
    modes: &[BallbarMode],
    options: &Options,
) -> Result<(Vec<Unresolved>, Vec<ConfoundedGroup>), BallbarIdentifyError> {
    let (ident, groups) = analyse(base, trunnion, rig, data, modes, options)?;
    // Readings for the absent modes, used only for their sensitivity.
    let stand_in = |m: BallbarMode| -> ModeData {
        let angles = modes
            .iter()
            .find(|g| g.moves_a() == m.moves_a())
            .and_then(|g| data[g.index()])
            .map(|d| d.angles_deg.clone())
            .unwrap_or_else(|| {
                if m.moves_a() {
                    crate::methods::ballbar::simulate::angle_range(-90.0, 90.0, 10.0)
                } else {
                    crate::methods::ballbar::simulate::angle_range(0.0, 350.0, 10.0)
                }
            });
        ModeData {
            source: None,
            lengths: vec![rig.length; angles.len()],
            angles_deg: angles,
        }
    };
    let mut separating: Vec<(BallbarMode, Vec<Pige>)> = Vec::new();
    if !ident.unidentifiable.is_empty() {
        for m in BallbarMode::ALL.into_iter().filter(|m| !modes.contains(m)) {
            let extra = stand_in(m);
            let mut with = *data;
            with[m.index()] = Some(&extra);
            let mut more = modes.to_vec();
            more.push(m);
            more.sort();
            let (after, _) = analyse(base, trunnion, rig, &with, &more, options)?;
            let still: Vec<Pige> = after
                .unidentifiable
                .iter()
                .filter_map(|&(j, _)| Pige::ALL.get(j).copied())
                .collect();
            separating.push((m, still));
        }
    }
    let hint = |pige: Pige, verb: &str| -> String {
        let helps: Vec<&str> = separating
            .iter()
            .filter(|(_, still)| !still.contains(&pige))
            .map(|(m, _)| m.label())
            .collect();
        if helps.is_empty() {
            format!("no single further mode {verb} it")
        } else {
            format!("add {} to {verb} it", helps.join(" or "))
        }
    };
    let mut out = Vec::new();
    for (k, &(j, why)) in ident.unidentifiable.iter().enumerate() {
        let Some(&pige) = Pige::ALL.get(j) else {
            continue; // a bar length: cannot happen with ≥ 5 distinct angles
        };
        let reason = match why {
            Unidentifiable::ZeroColumn => format!(
                "{pige} does not change the bar length in the modes given ({})",
                hint(pige, "determine")
            ),
            Unidentifiable::Confounded => {
                let rel = ident
                    .relations
                    .get(
                        ident
                            .unidentifiable
                            .iter()
                            .take(k)
                            .filter(|u| u.1 == Unidentifiable::Confounded)
                            .count(),
                    )
                    .map(|c| c.describe())
                    .unwrap_or_default();
                format!(
                    "{pige} acts exactly like other PIGEs in the modes given ({rel}); it is held \
                     at 0, so the estimate it is confounded with absorbs it: only their \
                     combination is determined (reported with its value) ({})",
                    hint(pige, "separate")
                )
            }
        };
        out.push(Unresolved { pige, reason });
    }
    // The groups of confounded PIGEs (a zero column is in none); the ideal
    // configuration's values mean nothing, only the terms are kept.
    let confounded: Vec<&str> = out
        .iter()
        .filter(|u| {
            ident.unidentifiable.iter().any(|&(j, why)| {
                why == Unidentifiable::Confounded && Pige::ALL.get(j) == Some(&u.pige)
            })
        })
        .map(|u| u.pige.name())
        .collect();
    let groups = groups
        .into_iter()
        .filter(|g| {
            g.parameters
                .iter()
                .any(|p| confounded.contains(&p.as_str()))
        })
        .collect();
    Ok((out, groups))
}

/// The structural groups with the value and standard uncertainty of each
/// determined combination `Σ c_j·θ_j` at the fitted solution (a PIGE held at
/// 0 counts 0; its variance and covariances are 0): value `Σ c_j·θ_j`,
/// variance `Σ c_i·c_j·Cov(θ_i, θ_j)` over the estimated parameters.
fn evaluate_groups(
    mut groups: Vec<ConfoundedGroup>,
    unknowns: &Unknowns,
    report: &FitReport,
) -> Vec<ConfoundedGroup> {
    let params = unknowns.parameters();
    let index = |name: &str| params.iter().position(|p| p.name == name);
    for g in &mut groups {
        for c in &mut g.determined {
            let at: Vec<(Option<usize>, f64)> = c
                .terms
                .iter()
                .map(|t| (index(&t.name), t.coefficient))
                .collect();
            c.value = at
                .iter()
                .filter_map(|&(j, k)| j.map(|j| k * report.theta[j]))
                .sum();
            c.uncertainty = report.covariance.as_ref().and_then(|cov| {
                let mut v = 0.0;
                for &(i, a) in &at {
                    for &(j, b) in &at {
                        if let (Some(i), Some(j)) = (i, j) {
                            v += a * b * cov.get(i, j)?;
                        }
                    }
                }
                Some(v.max(0.0).sqrt())
            });
        }
    }
    groups
}

/// The engine's identifiability analysis of all PIGEs (and one bar length
/// per mode) from the given modes at the ideal configuration; columns
/// `0..Pige::ALL.len()` are the PIGEs in order. With it the confounded
/// groups there (their terms; the values are those of one step at the ideal
/// configuration and mean nothing).
fn analyse(
    base: &Machine,
    trunnion: &Trunnion,
    rig: &Rig,
    data: &[Option<&ModeData>; 4],
    modes: &[BallbarMode],
    options: &Options,
) -> Result<(crate::fit::Identifiability, Vec<ConfoundedGroup>), BallbarIdentifyError> {
    let ideal = base.nominal();
    let ideal_rig = Rig {
        setup: Default::default(),
        ..*rig
    };
    let unknowns = Unknowns {
        free: Pige::ALL.to_vec(),
        fixed: Piges::default(),
        modes: modes.to_vec(),
    };
    let models: Vec<ModeModel> = modes
        .iter()
        .map(|&m| {
            ModeModel::new(
                &ideal,
                trunnion,
                m,
                ideal_rig,
                data[m.index()].expect("present"),
                &unknowns,
            )
        })
        .collect();
    let parts: Vec<&dyn Model> = models.iter().map(|m| m as &dyn Model).collect();
    let stack = Stack::new(parts)?;
    let theta0 = unknowns.theta(&Piges::default(), &[rig.length; 4]);
    // The analysis and the confounded groups (the gauge's report: which
    // combinations the modes determine); no truncation.
    let opts = Options {
        max_iterations: 1,
        gauge: fit::Gauge::Start,
        truncation: fit::Truncation::Off,
        ..options.clone()
    };
    let report = fit::fit(&stack, &theta0, &opts)?;
    let groups = report.gauge.map(|g| g.groups).unwrap_or_default();
    Ok((report.identifiability, groups))
}

/// Which modes a PIGE moves at first order (table 2 of \[R1\]).
pub fn sees(mode: BallbarMode, p: Pige) -> bool {
    use Pige::*;
    match mode {
        BallbarMode::One => matches!(p, EY0A | EZ0A),
        BallbarMode::Two => matches!(p, EY0A | EZ0A | EB0A | EC0A),
        BallbarMode::Three => matches!(p, EY0A | EX0C | EY0C),
        BallbarMode::Four => matches!(p, EY0A | EB0A | EX0C | EY0C | EA0C | EB0C),
    }
}

/// Warnings for modes whose residual RMS is far above the others'.
fn imbalance(rms: &[Option<f64>; 4]) -> Vec<String> {
    let present: Vec<(usize, f64)> = rms
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.map(|r| (i, r)))
        .collect();
    if present.len() < 2 {
        return Vec::new();
    }
    let mut out = Vec::new();
    for &(i, r) in &present {
        let mut others: Vec<f64> = present
            .iter()
            .filter(|(j, _)| *j != i)
            .map(|p| p.1)
            .collect();
        others.sort_by(f64::total_cmp);
        let med = if others.len() % 2 == 1 {
            others[others.len() / 2]
        } else {
            0.5 * (others[others.len() / 2 - 1] + others[others.len() / 2])
        };
        // 0.05 µm floor: below that, ratios of tiny residuals mean nothing.
        if r > RESIDUAL_IMBALANCE * med.max(5e-5) {
            out.push(format!(
                "{}: residual RMS {:.2} µm is {:.1}× the other modes' ({:.2} µm): check that run \
                 (ball seating, bar set at 0°, {}), or errors the model does not carry",
                BallbarMode::ALL[i].label(),
                r * 1e3,
                r / med.max(1e-12),
                med * 1e3,
                match BallbarMode::ALL[i] {
                    BallbarMode::Two => "ZB1C",
                    BallbarMode::Four => "ZB1A",
                    _ => "the set-up error",
                }
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::ballbar::setup::SetupError;
    use crate::methods::ballbar::simulate::{SimulationSpec, angle_range, simulate_mode};
    use crate::model::parse_machine;
    use rand::SeedableRng;
    use rand::rngs::StdRng;
    use std::path::Path;

    fn nominal() -> Machine {
        parse_machine(
            Path::new("ac-trunnion.toml"),
            include_str!("../../../../../examples/machines/ac-trunnion.toml"),
        )
        .unwrap()
    }

    /// The issue's test case: offsets ±30 µm, tilts ±2e-4 rad.
    const TRUTH: Piges = Piges([
        0.030, -0.021, 2.0e-4, -1.4e-4, -0.027, 0.018, 1.1e-4, -2.0e-4,
    ]);

    fn angles(mode: BallbarMode) -> Vec<f64> {
        if mode.moves_a() {
            angle_range(-90.0, 90.0, 5.0)
        } else {
            angle_range(0.0, 360.0, 5.0)
        }
    }

    fn simulate(truth: &Piges, rig: &Rig, noise: f64, seed: u64) -> Vec<ModeData> {
        let mut m = nominal();
        let t = Trunnion::of(&m).unwrap();
        truth.write_to(&mut m, &t);
        let mut rng = StdRng::seed_from_u64(seed);
        BallbarMode::ALL
            .iter()
            .map(|&mode| {
                let spec = SimulationSpec {
                    rig: *rig,
                    noise,
                    angles_deg: angles(mode),
                };
                simulate_mode(&m, &t, mode, &spec, &mut rng)
            })
            .collect()
    }

    fn all(d: &[ModeData]) -> [Option<&ModeData>; 4] {
        [Some(&d[0]), Some(&d[1]), Some(&d[2]), Some(&d[3])]
    }

    fn rig(ex: f64, ey: f64) -> Rig {
        Rig {
            setup: SetupError { ex, ey },
            ..Rig::source_paper()
        }
    }

    #[test]
    fn gauge_fixed_identification_reports_and_truncates_against_the_truth() {
        let rig = rig(0.1, -0.1);
        let d = simulate(&TRUTH, &rig, 3e-4, 11);
        let pivoted = identify(&nominal(), &rig, &all(&d), &Options::default()).unwrap();
        // The default options gauge-fix; all four modes determine every
        // PIGE, so the gauge changes nothing (no null space).
        let opts = IdentifyOptions::default();
        assert_eq!(opts.fit.gauge, fit::Gauge::Start);
        let gauged = identify(&nominal(), &rig, &all(&d), &opts.fit).unwrap();
        // Nothing to fix: no gauge report, the same solution.
        assert_eq!(
            gauged.report.identifiability.rank,
            gauged.report.theta.len()
        );
        assert!(gauged.report.gauge.is_none());
        for p in Pige::ALL {
            let (a, b) = (gauged.piges.get(p), pivoted.piges.get(p));
            assert!((a - b).abs() < 1e-9, "{p}: {a} vs {b}");
            let (ua, ub) = (
                gauged.uncertainty[p.index()].unwrap(),
                pivoted.uncertainty[p.index()].unwrap(),
            );
            assert!((ua - ub).abs() < 1e-6 * ub, "{p}: {ua} vs {ub}");
        }
        // A truncation that drops the weakest direction only (rcond between
        // the two smallest relative singular values): it is pulled to the
        // prior, the PIGE it moves most moves by the reported shift, and the
        // truth lies within the reported bias bound (plus the scatter of the
        // kept directions, 3σ of the full fit).
        let sv = &gauged.report.identifiability.singular_values;
        let k = sv.len();
        let rcond = (sv[k - 1] * sv[k - 2]).sqrt() / sv[0];
        let mut t = opts.fit.clone();
        t.truncation = fit::Truncation::Relative(rcond);
        let cut = identify(&nominal(), &rig, &all(&d), &t).unwrap();
        let g = cut.report.gauge.as_ref().unwrap();
        assert_eq!(g.kind, "prior");
        assert_eq!(g.null_dimension, 0);
        assert_eq!(g.dropped.len(), 1, "{:?}", g.dropped);
        // The groups hold what the gauge set: here the dropped direction.
        let set: usize = g.groups.iter().map(|x| x.undetermined).sum();
        assert_eq!(set, 1, "{:?}", g.groups);
        let dd = &g.dropped[0];
        assert!(dd.relative_singular_value < rcond, "{dd:?}");
        let j = cut
            .report
            .estimates
            .iter()
            .position(|e| e.name == dd.parameter)
            .unwrap();
        let moved = cut.report.theta[j] - pivoted.report.theta[j];
        let sj = pivoted.report.estimates[j].uncertainty.unwrap();
        // Exact for a linear model; the polish of the kept directions
        // moves it by a second-order amount.
        assert!(
            (moved - dd.shift).abs() < 1e-2 * dd.shift.abs() + 0.05 * sj,
            "{moved} vs {dd:?}"
        );
        if let Some(p) = Pige::from_name(&dd.parameter) {
            let err = (cut.piges.get(p) - TRUTH.get(p)).abs();
            let su = pivoted.uncertainty[p.index()].unwrap();
            assert!(err <= dd.bias_bound + 3.0 * su, "{p}: {err} vs {dd:?}");
        }
        let rms = |id: &Identification| {
            let r = &id.report.residuals;
            (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt()
        };
        let (r0, r1) = (rms(&pivoted), rms(&cut));
        let expect = (r0 * r0 + g.truncation_rms_change.powi(2)).sqrt();
        assert!(r1 >= r0 - 1e-12, "{r1} vs {r0}");
        assert!((r1 - expect).abs() < 0.05 * expect, "{r1} vs {expect}");
        // The document carries it.
        let doc = crate::methods::ballbar::BallbarIdentifyDoc::new(&cut, None, Vec::new());
        assert_eq!(doc.gauge.as_deref(), Some("prior"));
        assert_eq!(doc.dropped_directions.len(), g.dropped.len());
        assert!(doc.to_string().contains("Badly determined directions"));
    }

    #[test]
    fn recovers_known_errors_within_the_issue_tolerances() {
        let rig = rig(0.1, -0.1);
        let d = simulate(&TRUTH, &rig, 3e-4, 7);
        let id = identify(&nominal(), &rig, &all(&d), &Options::default()).unwrap();
        assert!(id.unresolved.is_empty(), "{:?}", id.unresolved);
        for p in Pige::ALL {
            let err = (id.piges.get(p) - TRUTH.get(p)).abs();
            let tol = match p {
                Pige::EC0A => 10e-6,
                _ if p.is_tilt() => 5e-6,
                _ => 1e-3,
            };
            assert!(err < tol, "{p}: error {err:e}");
        }
        // The source paper [R1]: with 0.3 µm noise and 5° steps, σ ≈ 2.2 µrad (EC0A), 1.2 µrad (EB0C),
        // 0.15 µm (EY0A) when the bar length is a nuisance parameter.
        let s = |p: Pige| id.uncertainty[p.index()].unwrap();
        for (p, expect) in [
            (Pige::EC0A, 2.2e-6),
            (Pige::EB0C, 1.2e-6),
            (Pige::EY0A, 1.5e-4),
        ] {
            let ratio = s(p) / expect;
            assert!(
                (0.7..1.4).contains(&ratio),
                "{p}: σ = {:e}, expected {expect:e}",
                s(p)
            );
        }
        for m in BallbarMode::ALL {
            let r = id.residual_rms[m.index()].unwrap();
            assert!((2e-4..4e-4).contains(&r), "{}: rms {r}", m.label());
        }
        assert!(id.warnings.is_empty(), "{:?}", id.warnings);
    }

    #[test]
    fn uncertainties_are_honest_over_many_seeds() {
        let rig = rig(-0.06, 0.08);
        let (mut inside, mut total) = (0usize, 0usize);
        for seed in 0..120 {
            let d = simulate(&TRUTH, &rig, 3e-4, 1000 + seed);
            let id = identify(&nominal(), &rig, &all(&d), &Options::default()).unwrap();
            for p in Pige::ALL {
                let s = id.uncertainty[p.index()].unwrap();
                total += 1;
                inside += usize::from((id.piges.get(p) - TRUTH.get(p)).abs() <= 2.0 * s);
            }
        }
        // 95.45 % expected; 960 draws give a binomial σ of 0.7 %.
        let frac = inside as f64 / total as f64;
        assert!((0.93..0.975).contains(&frac), "coverage {frac}");
    }

    #[test]
    fn source_paper_experiment_replayed_in_simulation() {
        // Source paper [R1], experiment: eX = −0.0403, eY = −0.0765 mm; offsets up to 203.5 µm, tilts ±0.005°.
        let rig = rig(-0.0403, -0.0765);
        let t5 = 0.005_f64.to_radians();
        let truth = Piges([0.2035, -0.1421, t5, -t5, -0.1687, 0.0982, -t5, t5]);
        let d = simulate(&truth, &rig, 3e-4, 11);
        let first = identify(&nominal(), &rig, &all(&d), &Options::default()).unwrap();
        // Compensate the four offsets: the controller's axis lines move to the identified
        // positions, so what remains is truth − identified; the tilts stay.
        let mut after = truth;
        for p in [Pige::EY0A, Pige::EZ0A, Pige::EX0C, Pige::EY0C] {
            after.set(p, truth.get(p) - first.piges.get(p));
        }
        let d2 = simulate(&after, &rig, 3e-4, 12);
        let second = identify(&nominal(), &rig, &all(&d2), &Options::default()).unwrap();
        let worst = [Pige::EY0A, Pige::EZ0A, Pige::EX0C, Pige::EY0C]
            .iter()
            .map(|&p| second.piges.get(p).abs())
            .fold(0.0_f64, f64::max);
        eprintln!(
            "largest remaining offset after compensation: {:.3} µm",
            worst * 1e3
        );
        assert!(
            worst < 1e-3,
            "remaining offset {worst} mm (source paper [R1]: 5.1 µm)"
        );
        // The tilts are still found after compensation.
        for p in [Pige::EB0A, Pige::EC0A, Pige::EA0C, Pige::EB0C] {
            assert!((second.piges.get(p) - truth.get(p)).abs() < 1e-5, "{p}");
        }
    }

    #[test]
    fn subsets_identify_what_they_can_and_say_what_they_cannot() {
        let rig = rig(0.05, -0.03);
        let d = simulate(&TRUTH, &rig, 3e-4, 3);
        let only1 = identify(
            &nominal(),
            &rig,
            &[Some(&d[0]), None, None, None],
            &Options::default(),
        )
        .unwrap();
        let unresolved: Vec<Pige> = only1.unresolved.iter().map(|u| u.pige).collect();
        assert_eq!(
            unresolved,
            vec![
                Pige::EB0A,
                Pige::EC0A,
                Pige::EX0C,
                Pige::EY0C,
                Pige::EA0C,
                Pige::EB0C
            ]
        );
        assert!((only1.piges.get(Pige::EY0A) - TRUTH.get(Pige::EY0A)).abs() < 1e-3);
        assert!((only1.piges.get(Pige::EZ0A) - TRUTH.get(Pige::EZ0A)).abs() < 1e-3);
        assert!(only1.residual_rms[1].is_none());

        // Mode 3 alone sees EY0A and EY0C only as their sum.
        let only3 = identify(
            &nominal(),
            &rig,
            &[None, None, Some(&d[2]), None],
            &Options::default(),
        )
        .unwrap();
        let conf: Vec<&Unresolved> = only3
            .unresolved
            .iter()
            .filter(|u| u.reason.contains("acts exactly like"))
            .collect();
        assert_eq!(conf.len(), 1, "{:?}", only3.unresolved);
        assert!(matches!(conf[0].pige, Pige::EY0A | Pige::EY0C));
        let sum = only3.piges.get(Pige::EY0A) + only3.piges.get(Pige::EY0C);
        assert!((sum - TRUTH.get(Pige::EY0A) - TRUTH.get(Pige::EY0C)).abs() < 1e-3);
        assert!((only3.piges.get(Pige::EX0C) - TRUTH.get(Pige::EX0C)).abs() < 1e-3);
        // Mode 1 sees EY0A without EY0C, so it separates them; mode 3 itself
        // is never proposed. The hint is checked against an identification
        // with the proposed mode added: the PIGE is then determined.
        assert!(
            conf[0].reason.contains("(add mode1") && !conf[0].reason.contains("mode3"),
            "{}",
            conf[0].reason
        );
        let with1 = identify(
            &nominal(),
            &rig,
            &[Some(&d[0]), None, Some(&d[2]), None],
            &Options::default(),
        )
        .unwrap();
        assert!(!with1.unresolved.iter().any(|u| u.pige == conf[0].pige));
        assert!((with1.piges.get(Pige::EY0C) - TRUTH.get(Pige::EY0C)).abs() < 1e-3);

        // A hint never proposes a mode already given.
        let only4 = identify(
            &nominal(),
            &rig,
            &[None, None, None, Some(&d[3])],
            &Options::default(),
        )
        .unwrap();
        assert!(!only4.unresolved.is_empty());
        for u in &only4.unresolved {
            assert!(!u.reason.contains("add mode4"), "{}", u.reason);
            assert!(u.reason.contains("add mode") || u.reason.contains("no single further mode"));
        }
        // With mode 1 alone the C-line offsets need a C mode, never mode 2
        // (an A mode: it does not see the C line); mode 3 does it (checked by
        // the identification from modes 1 and 3 above).
        for u in only1
            .unresolved
            .iter()
            .filter(|u| matches!(u.pige, Pige::EX0C | Pige::EY0C))
        {
            assert!(u.reason.contains("add mode3"), "{}", u.reason);
            assert!(!u.reason.contains("mode2"), "{}", u.reason);
            assert!(!with1.unresolved.iter().any(|w| w.pige == u.pige));
        }
    }

    /// Mode 3 alone cannot separate `EY0A` from `EY0C`: at A = 0 both move
    /// the line C turns about in y, by the same amount (the A line carries
    /// the C line with it), so the readings see `EY0A + EY0C` only; the
    /// document reports the combination `EY0A + EY0C` with the truth's value
    /// and `EY0A − EY0C` as the direction the readings cannot see.
    #[test]
    fn unseparable_piges_are_reported_as_their_combination() {
        let rig = rig(0.05, -0.03);
        for seed in [5, 6] {
            let d = simulate(&TRUTH, &rig, 3e-4, seed);
            let id = identify(
                &nominal(),
                &rig,
                &[None, None, Some(&d[2]), None],
                &Options::default(),
            )
            .unwrap();
            assert_eq!(id.combinations.len(), 1, "{:?}", id.combinations);
            let g = &id.combinations[0];
            assert_eq!(g.parameters, ["EY0A", "EY0C"]);
            assert_eq!((g.determined.len(), g.undetermined), (1, 1));
            let c = &g.determined[0];
            let coef = |terms: &[crate::fit::CombinationTerm], n: &str| {
                terms
                    .iter()
                    .find(|t| t.name == n)
                    .map_or(0.0, |t| t.coefficient)
            };
            // EY0A + EY0C (coefficients 1, 1)
            assert!((coef(&c.terms, "EY0A") - 1.0).abs() < 1e-9, "{c:?}");
            assert!((coef(&c.terms, "EY0C") - 1.0).abs() < 1e-9, "{c:?}");
            let truth = TRUTH.get(Pige::EY0A) + TRUTH.get(Pige::EY0C);
            let u = c.uncertainty.unwrap();
            assert!(u > 0.0 && u < 1e-3, "{u}");
            assert!(
                (c.value - truth).abs() < (4.0 * u).max(2e-4),
                "{} vs {truth} ± {u}",
                c.value
            );
            // the direction not seen: EY0A − EY0C
            let n = &g.undetermined_directions[0];
            let (a, b) = (coef(&n.terms, "EY0A"), coef(&n.terms, "EY0C"));
            assert!(
                (a + b).abs() < 1e-9 && (a.abs() - 1.0).abs() < 1e-9,
                "{n:?}"
            );
            // in the document and its text
            let doc = crate::methods::ballbar::BallbarIdentifyDoc::new(&id, None, Vec::new());
            assert_eq!(doc.unseparable_combinations, id.combinations);
            let back: crate::methods::ballbar::BallbarIdentifyDoc =
                serde_json::from_str(&serde_json::to_string(&doc).unwrap()).unwrap();
            assert_eq!(back, doc);
            let text = doc.to_string();
            let line = text
                .lines()
                .find(|l| l.contains("EY0C") && l.contains(" = "))
                .unwrap_or_else(|| panic!("{text}"));
            let shown: f64 = line
                .split(" = ")
                .nth(1)
                .and_then(|v| v.split_whitespace().next())
                .and_then(|v| v.parse().ok())
                .unwrap();
            assert!((shown - truth * 1e3).abs() < 0.5, "{line}");
        }
        // With all four modes nothing is confounded: no combination.
        let d = simulate(&TRUTH, &rig, 3e-4, 5);
        let id = identify(&nominal(), &rig, &all(&d), &Options::default()).unwrap();
        assert!(id.combinations.is_empty());
    }

    #[test]
    fn partial_arcs_work() {
        let rig = rig(0.02, 0.04);
        let mut m = nominal();
        let t = Trunnion::of(&m).unwrap();
        TRUTH.write_to(&mut m, &t);
        let mut rng = StdRng::seed_from_u64(5);
        let arcs = [
            angle_range(-30.0, 60.0, 5.0),
            angle_range(-45.0, 45.0, 5.0),
            angle_range(-90.0, 180.0, 5.0),
            angle_range(0.0, 270.0, 5.0),
        ];
        let d: Vec<ModeData> = BallbarMode::ALL
            .iter()
            .map(|&mode| {
                let spec = SimulationSpec {
                    rig,
                    noise: 3e-4,
                    angles_deg: arcs[mode.index()].clone(),
                };
                simulate_mode(&m, &t, mode, &spec, &mut rng)
            })
            .collect();
        let id = identify(&nominal(), &rig, &all(&d), &Options::default()).unwrap();
        for p in Pige::ALL {
            let s = id.uncertainty[p.index()].unwrap();
            let err = (id.piges.get(p) - TRUTH.get(p)).abs();
            assert!(err < 4.5 * s, "{p}: error {err:e}, σ {s:e}");
        }
    }

    #[test]
    fn one_bad_mode_is_flagged() {
        let rig = rig(0.0, 0.0);
        let mut d = simulate(&TRUTH, &rig, 3e-4, 9);
        let mut rng = StdRng::seed_from_u64(99);
        let extra = rand_distr::Normal::new(0.0, 3e-3).unwrap();
        for l in &mut d[1].lengths {
            *l += rand_distr::Distribution::sample(&extra, &mut rng);
        }
        let id = identify(&nominal(), &rig, &all(&d), &Options::default()).unwrap();
        // The engine also flags the worst readings of mode 2 as outliers; the balance
        // warning names mode 2 and no other mode.
        let modes: Vec<&String> = id
            .warnings
            .iter()
            .filter(|w| w.starts_with("mode"))
            .collect();
        assert_eq!(modes.len(), 1, "{:?}", id.warnings);
        assert!(modes[0].starts_with("mode2:"), "{:?}", id.warnings);
    }

    #[test]
    fn compensation_values_are_the_corrected_axis_lines() {
        let rig = rig(0.0, 0.0);
        let d = simulate(&TRUTH, &rig, 0.0, 1);
        let id = identify(&nominal(), &rig, &all(&d), &Options::default()).unwrap();
        let c = id.compensation();
        // Nominal lines through the origin: the corrected positions are the offsets.
        assert!((c.a_y - TRUTH.get(Pige::EY0A)).abs() < 1e-9);
        assert!((c.a_z - TRUTH.get(Pige::EZ0A)).abs() < 1e-9);
        assert!((c.c_x - TRUTH.get(Pige::EX0C)).abs() < 1e-9);
        assert!((c.c_y - TRUTH.get(Pige::EY0C)).abs() < 1e-9);
        // Noise-free data on the exact model: the fit reproduces the readings.
        let f = id.fitted_delta_l(BallbarMode::Four, 35.0).unwrap();
        let i = d[3].angles_deg.iter().position(|&a| a == 35.0).unwrap();
        assert!((f - (d[3].lengths[i] - 100.0)).abs() < 1e-10);
    }
}
