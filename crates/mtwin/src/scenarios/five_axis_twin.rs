//! The digital twin on a five-axis program ([R5] in docs/references.md),
//! before and after geometric compensation: the whole trajectory error
//! (servo + geometry) and the geometric part alone, both measured against
//! the original program's path while cutting.

use std::fmt;
use std::time::Instant;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::gcode::{self, EventKind, GcodeError, InterpOptions, InterpolateOptions};
use crate::methods::twin::{self, CommandPath, Sources, Twin, angle_between};
use crate::model::Machine;
use crate::report::html::Section;
use crate::report::twin::{TwinRow, comparison_section, section_from_rows, summary};

/// The step's heading.
pub const TITLE: &str = "Digital twin: trajectory errors of the five-axis program";

/// Sample period used when no axis has a servo model, s.
pub const DEFAULT_TS: f64 = 0.001;

/// The largest and RMS tool-tip error and the largest tool-axis error of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorsDoc {
    /// Largest `ε_o`, rad.
    pub axis_error_max: f64,
    /// Largest `ε_p`, mm.
    pub tip_error_max: f64,
    /// RMS of `ε_p`, mm.
    pub tip_error_rms: f64,
}

impl ErrorsDoc {
    /// The errors of `rows`.
    pub fn of(rows: &[TwinRow]) -> Self {
        let (tip_error_max, tip_error_rms, axis_error_max) = summary(rows);
        ErrorsDoc {
            axis_error_max,
            tip_error_max,
            tip_error_rms,
        }
    }
}

/// The geometric part alone, original and compensated program.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GeometryOnlyDoc {
    /// The compensated program.
    pub compensated: ErrorsDoc,
    /// The original program.
    pub original: ErrorsDoc,
}

/// The twin summary (`twin` in the demo's JSON). Errors are taken while
/// cutting (from `cutting_from_s` on), against the original program's path.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FiveAxisTwinDoc {
    /// Largest `ε_o` of the original program, servo + geometry, rad.
    pub axis_error_max: f64,
    /// The compensated program, servo + geometry.
    pub compensated: ErrorsDoc,
    /// Start of the first feed move, s.
    pub cutting_from_s: f64,
    /// Samples from then on.
    pub cutting_samples: usize,
    /// The geometric part alone.
    pub geometry_only: GeometryOnlyDoc,
    /// Sample period, s.
    pub sample_period_s: f64,
    /// Samples of the whole original program.
    pub samples: usize,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
    /// Largest `ε_p` of the original program, servo + geometry, mm.
    pub tip_error_max: f64,
    /// RMS of `ε_p` of the original program, servo + geometry, mm.
    pub tip_error_rms: f64,
}

impl fmt::Display for FiveAxisTwinDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} samples at {} ms, {} while cutting (from t = {:.3} s); the source patent's [R5] S-piece: tip −1.2…1.5 mm, axis −4.5e-3…4e-3 rad",
            self.samples,
            self.sample_period_s * 1e3,
            self.cutting_samples,
            self.cutting_from_s
        )?;
        let original = ErrorsDoc {
            axis_error_max: self.axis_error_max,
            tip_error_max: self.tip_error_max,
            tip_error_rms: self.tip_error_rms,
        };
        let g = &self.geometry_only;
        for (what, e) in [
            ("original program, servo + geometry", &original),
            ("compensated program, servo + geometry", &self.compensated),
            ("original program, geometry only", &g.original),
            ("compensated program, geometry only", &g.compensated),
        ] {
            writeln!(
                f,
                "{what}: tool tip up to {:.1} µm (RMS {:.1} µm), tool axis up to {:.1} µrad",
                e.tip_error_max * 1e3,
                e.tip_error_rms * 1e3,
                e.axis_error_max * 1e6
            )?;
        }
        writeln!(
            f,
            "geometric compensation removes {:.1} % of the geometric tip error (RMS, while cutting); what is left is servo lag, which a geometric model cannot correct",
            100.0
                * (1.0
                    - g.compensated.tip_error_rms
                        / g.original.tip_error_rms.max(f64::MIN_POSITIVE))
        )
    }
}

/// What [`run`] found: the summary and the rows of the report.
#[derive(Debug, Clone)]
pub struct FiveAxisTwinRun {
    /// The summary.
    pub doc: FiveAxisTwinDoc,
    /// Every sample of the original program, servo + geometry.
    pub original: Vec<TwinRow>,
    /// The original program while cutting.
    pub original_cutting: Vec<TwinRow>,
    /// The compensated program while cutting, against the original path.
    pub compensated_cutting: Vec<TwinRow>,
    /// Geometry alone: the original program while cutting.
    pub geometry_original: Vec<TwinRow>,
    /// Geometry alone: the compensated program while cutting, against the
    /// original path.
    pub geometry_compensated: Vec<TwinRow>,
}

/// The sample period of `machine`'s servos (the first axis with one), else
/// [`DEFAULT_TS`], s.
pub fn servo_period(machine: &Machine) -> f64 {
    machine
        .axes
        .iter()
        .find_map(|a| a.servo.as_ref().map(|s| s.ts))
        .unwrap_or(DEFAULT_TS)
}

/// The twin's prediction of `program` on `machine` with `sources`: one
/// [`TwinRow`] per sample, interpolated at `opts.ts`.
pub fn predict_rows(
    machine: &Machine,
    program: &[u8],
    sources: Sources,
    opts: &InterpolateOptions,
) -> std::result::Result<Vec<TwinRow>, twin::TwinError> {
    let model = Twin::new(machine, sources)?;
    let mut rows = Vec::new();
    twin::predict_gcode(
        &model,
        machine,
        std::io::BufReader::new(program),
        opts,
        |s| {
            rows.push(TwinRow {
                t_s: s.t,
                tip_cmd: s.cmd_tip.into(),
                axis_cmd: s.cmd_axis.into(),
                tip: s.tip.into(),
                axis: s.axis.into(),
                tip_error: s.tip_error,
                axis_error: s.axis_error,
            });
            Ok(())
        },
        &mut |_| {},
    )?;
    Ok(rows)
}

/// `rows` (actual samples of another program, a compensated one) measured
/// against the command path of `original`: the twin's own errors are against
/// the program it runs, and a compensated program deliberately commands a
/// path off the part. Exact global nearest point, as in the twin; the
/// search starts near the same sample index. `original` empty: `rows`
/// unchanged.
pub fn against_original(original: &[TwinRow], rows: &[TwinRow]) -> Vec<TwinRow> {
    if original.is_empty() {
        return rows.to_vec();
    }
    let path = CommandPath::new(
        original.iter().map(|r| Vector3::from(r.tip_cmd)).collect(),
        original.iter().map(|r| Vector3::from(r.axis_cmd)).collect(),
    );
    let mut scratch = Vec::new();
    rows.iter()
        .enumerate()
        .map(|(j, r)| {
            let tip = Vector3::from(r.tip);
            let near = path.nearest(&tip, j.min(original.len() - 1), &mut scratch);
            TwinRow {
                tip_cmd: near.point.into(),
                axis_cmd: near.axis.into(),
                tip_error: near.distance,
                axis_error: angle_between(&Vector3::from(r.axis), &near.axis),
                ..*r
            }
        })
        .collect()
}

/// The source line (1-based) of `program`'s first feed move — the first
/// `Feed` (G1) event that moves an axis or `Arc` (G2/G3) event of the
/// interpreter, whatever the block's spelling (`N10 G1`, `G1X5`, a modal
/// continuation `X5` after `G1`) — or `None` when it has none.
pub fn first_feed_line(
    program: &[u8],
    opts: &InterpOptions,
) -> std::result::Result<Option<u64>, GcodeError> {
    let mut first = None;
    gcode::interpret(program, opts.clone(), |_, events| {
        if first.is_none() {
            first = events
                .iter()
                .find(|e| match &e.kind {
                    EventKind::Feed(l) => l.from != l.to,
                    EventKind::Arc(_) => true,
                    _ => false,
                })
                .map(|e| e.at.line);
        }
        Ok(())
    })?;
    Ok(first)
}

/// Time, s, of the first sample of `program`'s first feed move
/// ([`first_feed_line`]) interpolated on `machine` with `opts`, as the
/// twin samples it; `None` without a feed move or a sample of one.
pub fn cutting_starts(
    machine: &Machine,
    program: &[u8],
    opts: &InterpolateOptions,
) -> Inner<Option<f64>> {
    let Some(line) = first_feed_line(program, &opts.interp)? else {
        return Ok(None);
    };
    let mut t_cut = None;
    gcode::interpolate(program, machine, opts, |s| {
        if t_cut.is_none() && s.line >= line {
            t_cut = Some(s.t);
        }
        Ok(())
    })?;
    Ok(t_cut)
}

/// Runs the twin of `machine` (servos and geometric errors) on `original`
/// (a TCP program) and on `compensated` (its geometric compensation), with
/// every source and with the geometry alone, at the servos' period
/// ([`servo_period`]). The compensated runs are measured against the
/// original path ([`against_original`]); the errors are taken while cutting,
/// from the original's first feed move on: before it the machine stands at
/// its start position, which no program compensation can move, and rapids
/// to the part.
pub fn run(machine: &Machine, original: &[u8], compensated: &[u8]) -> Result<FiveAxisTwinRun> {
    run_inner(machine, original, compensated).map_err(ScenarioError::new)
}

fn run_inner(machine: &Machine, original: &[u8], compensated: &[u8]) -> Inner<FiveAxisTwinRun> {
    let t0 = Instant::now();
    let ts = servo_period(machine);
    let opts = InterpolateOptions::new(ts);
    let before = predict_rows(machine, original, Sources::All, &opts)?;
    if before.is_empty() {
        return Err("the five-axis program gave no samples".into());
    }
    let after = against_original(
        &before,
        &predict_rows(machine, compensated, Sources::All, &opts)?,
    );
    let geo_before = predict_rows(machine, original, Sources::Geometry, &opts)?;
    let geo_after = against_original(
        &geo_before,
        &predict_rows(machine, compensated, Sources::Geometry, &opts)?,
    );
    let t_cut = cutting_starts(machine, original, &opts)?
        .ok_or("the five-axis program has no feed move")?;
    let cutting = |rows: &[TwinRow]| -> Vec<TwinRow> {
        rows.iter().filter(|r| r.t_s >= t_cut).copied().collect()
    };
    let (before_cut, after) = (cutting(&before), cutting(&after));
    let (geo_before, geo_after) = (cutting(&geo_before), cutting(&geo_after));
    let b = ErrorsDoc::of(&before_cut);
    let doc = FiveAxisTwinDoc {
        axis_error_max: b.axis_error_max,
        compensated: ErrorsDoc::of(&after),
        cutting_from_s: t_cut,
        cutting_samples: before_cut.len(),
        geometry_only: GeometryOnlyDoc {
            compensated: ErrorsDoc::of(&geo_after),
            original: ErrorsDoc::of(&geo_before),
        },
        sample_period_s: ts,
        samples: before.len(),
        seconds: since(t0),
        tip_error_max: b.tip_error_max,
        tip_error_rms: b.tip_error_rms,
    };
    Ok(FiveAxisTwinRun {
        doc,
        original: before,
        original_cutting: before_cut,
        compensated_cutting: after,
        geometry_original: geo_before,
        geometry_compensated: geo_after,
    })
}

impl FiveAxisTwinRun {
    /// The report sections: the original program's errors, then original
    /// against compensated with every source and with the geometry alone.
    pub fn sections(&self) -> Vec<Section> {
        vec![
            section_from_rows(
                "twin",
                "Digital twin: the five-axis program",
                &self.original,
            ),
            comparison_section(
                "twin-compensated",
                "Digital twin: original and compensated program (against the original path)",
                ("original", &self.original_cutting),
                ("compensated", &self.compensated_cutting),
            ),
            comparison_section(
                "twin-geometry",
                "Geometric part alone: original and compensated program",
                ("original", &self.geometry_original),
                ("compensated", &self.geometry_compensated),
            ),
        ]
    }
}
