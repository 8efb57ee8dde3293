//! Thermal drift ([R4] in docs/references.md): probing runs of a known
//! two-time-constant machine, an ARX model of the Z drift fitted per height,
//! and the check of the source paper: a face milled cold and again after an
//! hour at varying spindle speed, without and with the program compensated.

use std::fmt;
use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::gcode::{Dialect, ProgramEnd, ProgramWriter, WriteError};
use crate::io::Table;
use crate::methods::thermal::{
    self, Compensation, ThermalFitOptions, ThermalModel, TruthMachine, ZBlock,
};
use crate::report::html::{Block, Headline, Section};
use crate::report::sections;
use crate::report::sections::thermal::DriftCurve;

/// The step's heading.
pub const TITLE: &str = "Thermal: spindle-speed-driven Z drift, fit and program compensation";

/// The height difference of the two faces in the source paper [R4], without
/// and with compensation, mm.
pub const SOURCE_FACE_DIFFERENCE_MM: [f64; 2] = [0.007, 0.002];

/// Height of the milled faces, mm (machine Z).
pub const FACE_Z: f64 = -50.0;

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// The machine whose drift is simulated.
    pub truth: TruthMachine,
    /// Probed heights, mm.
    pub heights: Vec<f64>,
    /// Probing runs: name and spindle speed per period (rev/min).
    pub runs: Vec<(String, Vec<f64>)>,
    /// Probing noise (standard deviation), mm.
    pub noise: f64,
    /// Random seed of the probing noise.
    pub seed: u64,
}

impl Default for Options {
    /// The demo's: [`TruthMachine::demo`] at half its gains, four heights,
    /// three runs of 48 periods (4000 and 8000 rev/min, then steps), 0.1 µm
    /// noise.
    fn default() -> Self {
        let mut truth = TruthMachine::demo();
        truth.fast_gain_mm *= 0.5;
        truth.slow_gain_mm *= 0.5;
        let steps = [2000.0, 6000.0, 0.0, 8000.0, 4000.0, 1000.0, 7000.0, 3000.0];
        Options {
            truth,
            heights: vec![-50.0, -150.0, -250.0, -350.0],
            runs: vec![
                ("const4000".into(), vec![4000.0; 48]),
                ("const8000".into(), vec![8000.0; 48]),
                ("steps".into(), steps.iter().flat_map(|&s| [s; 6]).collect()),
            ],
            noise: 1e-4,
            seed: 11,
        }
    }
}

/// The thermal summary (`thermal` in the demo's JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThermalFacesDoc {
    /// Height difference of the two faces with the program compensated, mm.
    pub face_difference_compensated_mm: f64,
    /// Height difference of the two faces without compensation, mm.
    pub face_difference_mm: f64,
    /// Heights with a model.
    pub heights: usize,
    /// Largest simulation RMS of the fitted models, mm.
    pub largest_simulation_rms_mm: f64,
    /// Blocks of the test program.
    pub program_blocks: u64,
    /// Duration of the test program, min.
    pub program_minutes: f64,
    /// Probing runs fitted.
    pub runs: usize,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
    /// The source paper's [R4] difference with compensation, mm.
    pub source_face_difference_compensated_mm: f64,
    /// The source paper's [R4] difference without compensation, mm.
    pub source_face_difference_mm: f64,
}

impl fmt::Display for ThermalFacesDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "ARX model per height fitted on {} probing runs at {} heights; largest simulation RMS {:.2} µm",
            self.runs,
            self.heights,
            self.largest_simulation_rms_mm * 1e3
        )?;
        writeln!(
            f,
            "test program ({:.0} min, {} blocks): faces cold and after an hour differ by {:.1} µm without and {:.1} µm with compensation (source paper [R4]: {:.0} → {:.0} µm)",
            self.program_minutes,
            self.program_blocks,
            self.face_difference_mm * 1e3,
            self.face_difference_compensated_mm * 1e3,
            self.source_face_difference_mm * 1e3,
            self.source_face_difference_compensated_mm * 1e3
        )
    }
}

/// What [`run`] found.
#[derive(Debug, Clone)]
pub struct ThermalFacesRun {
    /// The summary.
    pub doc: ThermalFacesDoc,
    /// The fitted model (write it with [`ThermalModel::to_toml`]).
    pub model: ThermalModel,
    /// The test program.
    pub program: String,
    /// The compensation of the test program (`output`: the compensated program).
    pub compensation: Compensation,
    /// The curves of the report: true drift at the face height, the model's
    /// prediction, what is left after compensation (min, mm).
    pub curves: Vec<DriftCurve>,
}

/// A face milled at [`FACE_Z`] (20 passes tagged `(face n)`).
fn face(n: u32, w: &mut ProgramWriter) -> std::result::Result<(), WriteError> {
    w.rapid(&[('X', 0.0), ('Y', 0.0)])?;
    w.linear(&[('Z', FACE_Z)], Some(500.0))?;
    for i in 0..20 {
        let x = if i % 2 == 0 { 200.0 } else { 0.0 };
        w.block()
            .g(1)
            .axes(&[('X', x)])
            .feed(2000.0)
            .comment(&format!("face {n}"))
            .write()?;
        w.linear(&[('Y', f64::from((i + 1) * 5))], None)?;
    }
    w.rapid(&[('Z', 5.0)])
}

/// The speed changes of [`faces_program`] between the faces: rev/min and
/// the dwell at each, s (an hour in all).
pub const FACES_SPEED_STEPS: [(f64, f64); 5] = [
    (3000.0, 600.0),
    (8000.0, 900.0),
    (5000.0, 600.0),
    (7000.0, 900.0),
    (2000.0, 600.0),
];

/// The check of the source paper [R4] as a program in `dialect` (through
/// the one G-code writer, [`ProgramWriter`]): a face at 6000 rev/min, an
/// hour of dwells at the speeds of [`FACES_SPEED_STEPS`], the same face
/// again.
///
/// # Errors
/// None for the dialects of [`Dialect`] (every value fits); the writer's
/// error otherwise.
pub fn faces_program(dialect: Dialect) -> std::result::Result<String, WriteError> {
    let mut w = ProgramWriter::new(dialect);
    w.start(None)?;
    w.block().g(21).g(90).g(94).g(17).write()?;
    w.rapid(&[('Z', 5.0)])?;
    w.block().spindle_speed(6000.0).m(3).write()?;
    face(1, &mut w)?;
    for (rpm, seconds) in FACES_SPEED_STEPS {
        w.block().spindle_speed(rpm).write()?;
        w.dwell(seconds)?;
    }
    w.block().spindle_speed(6000.0).write()?;
    face(2, &mut w)?;
    w.block().m(5).write()?;
    w.end(ProgramEnd::M30)?;
    Ok(w.finish())
}

/// Simulates the probing runs on `truth`, fits the thermal model, compensates
/// [`faces_program`] with it, and compares the two faces' heights under the
/// true drift without and with the compensation.
pub fn run(opts: &Options) -> Result<ThermalFacesRun> {
    run_inner(opts).map_err(ScenarioError::new)
}

fn run_inner(opts: &Options) -> Inner<ThermalFacesRun> {
    let t0 = Instant::now();
    let truth = &opts.truth;
    let runs: Vec<(&str, Vec<f64>)> = opts
        .runs
        .iter()
        .map(|(n, s)| (n.as_str(), s.clone()))
        .collect();
    let text = truth.training_csv(&runs, &opts.heights, opts.noise, opts.seed);
    let table = Table::from_reader(Path::new("TRAIN.csv"), text.as_bytes())?;
    let data = thermal::training_from_table(&table, &[])?;
    let fit = thermal::fit(&data, &ThermalFitOptions::default())?;
    let model = fit.model;
    let program = faces_program(Dialect::LinuxCnc)?;
    let comp = thermal::compensate(
        &model,
        program.as_bytes(),
        &thermal::CompensateOptions::default(),
    )?;
    // True drift at the face height over the program's speed programme.
    let speeds: Vec<f64> = (0..comp.programme.len())
        .map(|k| comp.programme.sample(k)[0])
        .collect();
    let drift = truth.drift(&speeds, FACE_Z);
    if drift.len() < 2 {
        return Err("the test program is shorter than two thermal periods".into());
    }
    let at = |t: f64| {
        let p = t / truth.period_min;
        let k = (p.floor() as usize).min(drift.len() - 2);
        drift[k] + (p - k as f64) * (drift[k + 1] - drift[k])
    };
    // Each face starts with its plunge to FACE_Z; the correction written
    // there holds over the face's passes (two minutes, short against the
    // drift's time constants), so the face sits at FACE_Z − correction + e(t).
    let plunges: Vec<&ZBlock> = comp
        .z_blocks
        .iter()
        .filter(|b| (b.machine_z_mm - FACE_Z).abs() < 1e-9)
        .collect();
    let [f1, f2] = plunges[..] else {
        return Err(format!("the test program should plunge to Z{FACE_Z} twice").into());
    };
    let d_raw = (at(f2.end_min) - at(f1.end_min)).abs();
    let d_cor = ((at(f2.end_min) - f2.correction_mm) - (at(f1.end_min) - f1.correction_mm)).abs();
    let curves = vec![
        DriftCurve {
            name: format!("true drift at z = {FACE_Z} mm"),
            points: (0..drift.len())
                .map(|k| (k as f64 * truth.period_min, drift[k]))
                .collect(),
        },
        DriftCurve {
            name: "model prediction".into(),
            points: (0..drift.len())
                .map(|k| {
                    let t = k as f64 * truth.period_min;
                    (t, model.drift_at(&comp.programme, t, FACE_Z).mm)
                })
                .collect(),
        },
        DriftCurve {
            name: "left after compensation".into(),
            points: comp
                .z_blocks
                .iter()
                .filter(|b| !b.g53)
                .map(|b| (b.end_min, at(b.end_min) - b.correction_mm))
                .collect(),
        },
    ];
    let doc = ThermalFacesDoc {
        face_difference_compensated_mm: d_cor,
        face_difference_mm: d_raw,
        heights: model.heights().len(),
        largest_simulation_rms_mm: model
            .heights()
            .iter()
            .filter_map(|h| h.stats.as_ref().map(|s| s.simulation_rms_mm))
            .fold(0.0f64, f64::max),
        program_blocks: comp.blocks,
        program_minutes: comp.duration_min,
        runs: opts.runs.len(),
        seconds: since(t0),
        source_face_difference_compensated_mm: SOURCE_FACE_DIFFERENCE_MM[1],
        source_face_difference_mm: SOURCE_FACE_DIFFERENCE_MM[0],
    };
    Ok(ThermalFacesRun {
        doc,
        model,
        program,
        compensation: comp,
        curves,
    })
}

impl ThermalFacesRun {
    /// The report section: the model, the drift curves and the headline
    /// against the source paper.
    pub fn sections(&self) -> Vec<Section> {
        let mut s = sections::thermal::section(
            &self.model,
            &self.curves,
            "Drift at the face height during the test program",
        );
        let d = &self.doc;
        s.blocks.insert(
            1,
            Block::Headlines(vec![Headline {
                label:
                    "cold face vs face after an hour: height difference without → with compensation"
                        .into(),
                ours: format!(
                    "{:.1} → {:.1} µm",
                    d.face_difference_mm * 1e3,
                    d.face_difference_compensated_mm * 1e3
                ),
                source: format!(
                    "{:.0} → {:.0} µm",
                    d.source_face_difference_mm * 1e3,
                    d.source_face_difference_compensated_mm * 1e3
                ),
            }]),
        );
        vec![s]
    }
}
