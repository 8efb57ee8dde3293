//! Ballbar on a trunnion ([R1] in docs/references.md): the four modes
//! simulated on a machine with known location errors (PIGEs) of A and C,
//! the eight PIGEs identified on the nominal model, the four offsets
//! compensated and identified again from a second measurement.

use std::fmt;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::fit::Options as FitOptions;
use crate::methods::ballbar::{
    self, BallbarMode, Identification, ModeData, Pige, Piges, Rig, SimulationSpec, Trunnion,
    angle_range, simulate_modes,
};
use crate::model::Machine;
use crate::report::html::{Block, Headline, Section};
use crate::report::sections;

/// The step's heading.
pub const TITLE: &str = "Ballbar: the eight location errors (PIGEs) of A and C from four modes";

/// The headline of the source paper [R1] (its table 4): the largest location
/// offset before and after compensation, mm.
pub const SOURCE_OFFSETS_MM: [f64; 2] = [0.2035, 0.0051];

/// The four location offsets compensated (the tilts are not, as in [R1]).
pub const OFFSETS: [Pige; 4] = [Pige::EY0A, Pige::EZ0A, Pige::EX0C, Pige::EY0C];

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// The rig (bar length, tool-cup positions, set-up error).
    pub rig: Rig,
    /// Reading noise (standard deviation), mm.
    pub noise: f64,
    /// Angle step of every mode, degree (A over −90…90, C over 0…360).
    pub step_deg: f64,
    /// Random seeds of the first and the second (after compensation) measurement.
    pub seeds: [u64; 2],
}

impl Default for Options {
    /// The rig of the source paper [R1] set up 40.3 and 76.5 µm off, 0.3 µm
    /// noise, 5° steps.
    fn default() -> Self {
        let mut rig = Rig::source_paper();
        rig.setup = ballbar::SetupError {
            ex: -0.0403,
            ey: -0.0765,
        };
        Options {
            rig,
            noise: 0.0003,
            step_deg: 5.0,
            seeds: [1, 2],
        }
    }
}

/// One PIGE: the truth, what was identified and its standard uncertainty
/// (mm for offsets, rad for tilts).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PigeCheckDoc {
    /// Identified value.
    pub identified: f64,
    /// The PIGE's name (`EY0A`, …).
    pub name: String,
    /// The value simulated.
    pub truth: f64,
    /// Standard uncertainty of the identified value (`null`: not identified).
    pub uncertainty: Option<f64>,
}

/// The ballbar summary (`ballbar` in the demo's JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrunnionBallbarDoc {
    /// Largest |ΔL| of an ideally set bar (no set-up error, no noise) after
    /// compensating the four offsets, mm.
    pub largest_deviation_after_mm: f64,
    /// The same before, mm.
    pub largest_deviation_before_mm: f64,
    /// Largest |identified − truth| over the eight PIGEs, µm for offsets and
    /// µrad for tilts.
    pub largest_error_vs_truth_um_or_urad: f64,
    /// Largest |offset| re-identified after compensation, mm.
    pub largest_offset_after_mm: f64,
    /// Largest |offset| identified before compensation, mm.
    pub largest_offset_before_mm: f64,
    /// Reading noise simulated, mm.
    pub noise_mm: f64,
    /// The eight PIGEs identified before compensation, against the truth.
    pub piges: Vec<PigeCheckDoc>,
    /// Readings of the four modes.
    pub readings: usize,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
    /// The source paper's [R1] offset after compensation, mm.
    pub source_after_mm: f64,
    /// The source paper's [R1] offset before compensation, mm.
    pub source_before_mm: f64,
}

impl fmt::Display for TrunnionBallbarDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "identified on the nominal model from {} simulated readings ({:.1} µm noise); largest difference from the truth {:.2} µm / µrad",
            self.readings,
            self.noise_mm * 1e3,
            self.largest_error_vs_truth_um_or_urad
        )?;
        writeln!(
            f,
            "largest location offset {:.1} µm → {:.2} µm re-identified after compensating the four offsets (source paper [R1]: {:.1} → {:.1} µm)",
            self.largest_offset_before_mm * 1e3,
            self.largest_offset_after_mm * 1e3,
            self.source_before_mm * 1e3,
            self.source_after_mm * 1e3
        )?;
        writeln!(
            f,
            "largest ballbar ΔL {:.1} µm → {:.1} µm (the four tilts are not compensated, as in the source paper [R1])",
            self.largest_deviation_before_mm * 1e3,
            self.largest_deviation_after_mm * 1e3
        )
    }
}

/// What [`run`] found.
#[derive(Debug, Clone)]
pub struct TrunnionBallbarRun {
    /// The summary.
    pub doc: TrunnionBallbarDoc,
    /// The identification before compensation.
    pub identification: Identification,
    /// The readings of the four modes before compensation (mode order).
    pub data: Vec<ModeData>,
}

/// The ballbar on the trunnion: `truth` is `nominal` with the eight PIGEs
/// of `with_errors` (the ballbar sees the rotary axes; the source paper [R1]
/// takes the linear axes as calibrated). Four modes are simulated on it and
/// the PIGEs identified on `nominal`; the machine with its four offsets
/// corrected by the identified ones is measured and identified again.
pub fn run(nominal: &Machine, with_errors: &Machine, opts: &Options) -> Result<TrunnionBallbarRun> {
    run_inner(nominal, with_errors, opts).map_err(ScenarioError::new)
}

fn run_inner(
    nominal: &Machine,
    with_errors: &Machine,
    opts: &Options,
) -> Inner<TrunnionBallbarRun> {
    let t0 = Instant::now();
    let t = Trunnion::of(nominal)?;
    let true_piges = Piges::from_machine(with_errors, &Trunnion::of(with_errors)?);
    let mut truth = nominal.clone();
    true_piges.write_to(&mut truth, &t);
    let rig = opts.rig;
    let specs: Vec<(BallbarMode, SimulationSpec)> = BallbarMode::ALL
        .iter()
        .map(|&m| {
            let angles = if m.moves_a() {
                angle_range(-90.0, 90.0, opts.step_deg)
            } else {
                angle_range(0.0, 360.0, opts.step_deg)
            };
            (
                m,
                SimulationSpec {
                    rig,
                    noise: opts.noise,
                    angles_deg: angles,
                },
            )
        })
        .collect();
    let identify = |data: &[ModeData]| {
        let refs: [Option<&ModeData>; 4] = [0, 1, 2, 3].map(|i| data.get(i));
        ballbar::identify(nominal, &rig, &refs, &FitOptions::default())
    };
    let data = simulate_modes(&truth, &specs, opts.seeds[0])?;
    let id = identify(&data)?;
    // Second measurement: the offsets compensated (the machine's offsets
    // minus the identified ones).
    let mut corrected = true_piges;
    for p in OFFSETS {
        corrected.set(p, true_piges.get(p) - id.piges.get(p));
    }
    let mut after_machine = truth.clone();
    corrected.write_to(&mut after_machine, &t);
    let again = simulate_modes(&after_machine, &specs, opts.seeds[1])?;
    let id_again = identify(&again)?;
    let largest_offset = |p: &Piges| {
        OFFSETS
            .iter()
            .map(|&o| p.get(o).abs())
            .fold(0.0f64, f64::max)
    };
    // The ballbar's own view: largest ΔL of an ideally set bar before and
    // after; the tilts, not compensated, remain.
    let clean: Vec<(BallbarMode, SimulationSpec)> = specs
        .iter()
        .map(|(m, s)| {
            let mut s = s.clone();
            s.noise = 0.0;
            s.rig.setup = ballbar::SetupError::default();
            (*m, s)
        })
        .collect();
    let largest_dl = |machine: &Machine| -> Inner<f64> {
        Ok(simulate_modes(machine, &clean, 1)?
            .iter()
            .flat_map(|m| m.lengths.iter())
            .map(|l| (l - rig.length).abs())
            .fold(0.0f64, f64::max))
    };
    let mut worst_err = 0.0f64;
    for p in Pige::ALL {
        worst_err = worst_err
            .max((id.piges.get(p) - true_piges.get(p)).abs() * if p.is_tilt() { 1e6 } else { 1e3 });
    }
    let piges = Pige::ALL
        .iter()
        .map(|&p| PigeCheckDoc {
            identified: id.piges.get(p),
            name: p.name().into(),
            truth: true_piges.get(p),
            uncertainty: id.uncertainty[p.index()],
        })
        .collect();
    let doc = TrunnionBallbarDoc {
        largest_deviation_after_mm: largest_dl(&after_machine)?,
        largest_deviation_before_mm: largest_dl(&truth)?,
        largest_error_vs_truth_um_or_urad: worst_err,
        largest_offset_after_mm: largest_offset(&id_again.piges),
        largest_offset_before_mm: largest_offset(&id.piges),
        noise_mm: opts.noise,
        piges,
        readings: data.iter().map(|d| d.lengths.len()).sum(),
        seconds: since(t0),
        source_after_mm: SOURCE_OFFSETS_MM[1],
        source_before_mm: SOURCE_OFFSETS_MM[0],
    };
    Ok(TrunnionBallbarRun {
        doc,
        identification: id,
        data,
    })
}

impl TrunnionBallbarRun {
    /// The report section: the identification with a polar plot per mode
    /// and the headline against the source paper.
    pub fn sections(&self) -> Result<Vec<Section>> {
        let id = &self.identification;
        let figures: Vec<(String, String)> = BallbarMode::ALL
            .iter()
            .filter_map(|&m| {
                ballbar::plot::polar_plot(id, m, &self.data[m.index()]).map(|svg| {
                    (
                        format!(
                            "{}: measured ΔL, the identified model's fit, and the prediction after compensating the four offsets (µm).",
                            m.label()
                        ),
                        svg,
                    )
                })
            })
            .collect();
        let mut s = sections::ballbar::section(
            &ballbar::BallbarIdentifyDoc::new(id, None, Vec::new()),
            "ballbar identify",
            figures,
        )
        .map_err(ScenarioError::new)?;
        let d = &self.doc;
        s.blocks.insert(
            1,
            Block::Headlines(vec![Headline {
                label: "largest location offset of A and C: identified before → re-identified after compensating the four offsets".into(),
                ours: format!(
                    "{:.1} → {:.2} µm",
                    d.largest_offset_before_mm * 1e3,
                    d.largest_offset_after_mm * 1e3
                ),
                source: format!(
                    "{:.1} → {:.1} µm",
                    d.source_before_mm * 1e3,
                    d.source_after_mm * 1e3
                ),
            }]),
        );
        Ok(vec![s])
    }
}
