//! Pre-compensation of an NC program for thermal drift (the compensation of
//! `docs/references.md` \[R4\]: the program rewritten before machining),
//! with a height model ([`compensate`], Z only) or with a log model of
//! `thermal fit --log` ([`compensate_log`], X, Y and Z).
//!
//! 1. Every block is timed. Without a machine
//!    ([`CompensateOptions::timing`] `None`) with the G-code engine's estimate
//!    ([`ProgramStats::add`]: feed moves at the programmed feed, rapids at
//!    [`CompensateOptions::rapid_feed`], `G4` dwells in the dialect's unit,
//!    no accelerations). With a machine, by the trajectory planner on it
//!    ([`crate::gcode::line_end_times`]: the machine's limits, accelerations,
//!    junctions and the planner's stops): a block ends when the planner ends
//!    its motion, and a block without motion (S, M3, M5, …) takes effect when
//!    the motion before it ends.
//! 2. The spindle speed (S with M3/M4, 0 after M5 or before the first M3/M4)
//!    is a step function of time; its mean over each sample period `[kT,
//!    (k+1)T)` of the model is the model input of that sample. A log
//!    model's other inputs (temperatures) come from an inputs log
//!    ([`compensate_log`]).
//! 3. Height model: the drift `e(t, z)` is predicted at every measured height on the sample
//!    grid, linear in time between samples and interpolated across heights
//!    ([`ThermalModel::interpolate`]); `z` is the machine Z of the block's
//!    target (work Z + work offset + tool length offset), mm. Log model: each
//!    channel's drift along its axis, its period means placed at the period
//!    centres and linear between them, whatever the block's position.
//! 4. Targets are moved to `Z − c` (and `X − c`, `Y − c` with a log
//!    model's X and Y channels), `c = e(t_c, …)` the correction of that axis:
//!    * continuous update: `t_c` is the time the block ends;
//!    * periodic update (period `P`, the source paper \[R4\]: 10 min): the correction is
//!      held over `[kP, (k+1)P)` and `t_c = (k + ½)·P`, the middle of the
//!      interval (the whole program is known ahead, so the held value is the
//!      one closest to the drift over the interval).
//!
//! Rewriting rules, the same for every corrected axis (`Z` below stands for
//! X, Y or Z), each axis with its own correction in force:
//!
//! * G90 (absolute) Z words are replaced by the corrected target;
//! * G91 (incremental) Z words change by the change of the correction since
//!   the last corrected Z word;
//! * G53 (machine coordinate) moves are left alone and reported;
//! * a block without a Z word keeps the correction in force at the last Z
//!   word: when the drift changes during a long XY pass the correction
//!   follows at the next Z word (the program's own Z words are the only
//!   places edited, so every other byte stays the same);
//! * a Z change smaller than half the written resolution (0.05 µm) leaves the
//!   word untouched, so a program whose drift is zero is unchanged;
//! * X and Y words of arcs in the XY plane (G17) keep the correction in
//!   force at the arc's start: start, end and centre (start + I/J) then all
//!   move by the same amount, so I and J stay and the arc keeps its radius
//!   (a correction updated at the arc's end would move the end and not the
//!   centre, and the two radii would differ). An absolute X/Y word becomes
//!   `X − c` with that correction, an incremental one is unchanged; the
//!   correction changes at the next straight move. With absolute arc
//!   centres (G90.1) such an arc is refused when it would move;
//! * the Z (helix) word of an XY arc is corrected as a straight move's;
//! * a block the rewriter cannot change safely is an error naming the line:
//!   Z words of arcs in the ZX or YZ plane, X words of arcs in the ZX plane,
//!   Y words of arcs in the YZ plane (the arc geometry would change),
//!   several moves in one block, a move of a corrected X or Y without X or
//!   Y words that the interpreter marks `expanded` (polar coordinates `@`,
//!   `^`; the flag `compensate` goes by): no X or Y word to correct; canned
//!   cycles and everything else outside
//!   the interpreter's subset are already errors of the interpreter. A
//!   Fanuc `G4 X` (a dwell time) is not a target and is left alone.
//!
//! A program that never turns the spindle on is returned unchanged, with a
//! note (with a log model: when its used channels take the speed alone).

use crate::gcode::{
    Axis, Block, Dialect, DistanceMode, Event, EventKind, GcodeError, InterpOptions, Interpreter,
    NumberFormat, Plane, ProgramStats, Programmed, SpindleState, StatsOptions,
};

use super::log::{InputSpec, LogData, LogModel, at_time, read_log};
use super::model::ThermalModel;
use super::predict::Programme;
use crate::io::{Diagnostics, Table};

/// Half the resolution of a written coordinate (4 decimals of mm): smaller
/// Z changes are not written, mm.
const WRITE_TOLERANCE_MM: f64 = 0.5e-4;

/// How often the correction changes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CorrectionUpdate {
    /// Held constant over intervals of this length (min, > 0), starting at `t = 0`.
    Periodic {
        /// Interval length, min.
        period_min: f64,
    },
    /// The drift at the end time of each block.
    Continuous,
}

/// Settings of [`compensate`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct CompensateOptions {
    /// How the program reads (dwell units, Fanuc least increments).
    pub dialect: Dialect,
    /// Rapid rate along the path, mm/min (> 0).
    pub rapid_feed: f64,
    /// Correction update policy.
    pub update: CorrectionUpdate,
    /// Compensate with a model whose ARX model at some height is unstable (a
    /// pole on or outside the unit circle). Refused by default: its drift
    /// grows without bound, so a long program would be corrected by
    /// meaningless amounts.
    pub allow_unstable: bool,
    /// Parameters at start (var file) and program bounds. O-word flow
    /// (subroutines, loops) is refused: each line is rewritten once with the
    /// correction of its one run.
    pub program: crate::gcode::ProgramOptions,
    /// Tool table for T, M6, G43 and G10 L1 (LinuxCNC `.tbl`).
    pub tools: crate::gcode::ToolTable,
    /// Skip blocks starting with `/` (LinuxCNC's default).
    pub skip_deleted_blocks: bool,
    /// The axes the program may name (the machine's; all nine by default),
    /// as [`InterpOptions::machine_axes`].
    pub machine_axes: crate::gcode::AxisMask,
    /// Time the blocks with a trajectory planner on a machine instead of the
    /// programmed feeds (`None`, the default: the estimate without
    /// accelerations; [`CompensateOptions::rapid_feed`] is then unused, the
    /// machine's `rapid_feed` times the rapids).
    pub timing: Option<PlannedTiming>,
}

/// Block times from a trajectory planner on a machine (see the module
/// documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedTiming {
    /// The machine: its axis limits (`max_velocity`, `max_acceleration`,
    /// `max_jerk`) and `rapid_feed`. The program's coordinates are taken as
    /// machine coordinates plus the program's own offsets; travels are not
    /// checked.
    pub machine: crate::model::Machine,
    /// The planner and its settings.
    pub plan: crate::gcode::plan::PlanOptions,
}

impl Default for CompensateOptions {
    /// LinuxCNC, rapids at 10 m/min, correction updated every 10 min (as in \[R4\]).
    fn default() -> Self {
        CompensateOptions {
            dialect: Dialect::LinuxCnc,
            rapid_feed: crate::model::DEFAULT_RAPID_FEED,
            update: CorrectionUpdate::Periodic { period_min: 10.0 },
            allow_unstable: false,
            program: crate::gcode::ProgramOptions::default(),
            tools: crate::gcode::ToolTable::new(),
            skip_deleted_blocks: true,
            machine_axes: crate::gcode::AxisMask::ALL,
            timing: None,
        }
    }
}

/// Why a program could not be compensated.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CompensateError {
    /// The program could not be read, interpreted or timed.
    #[error(transparent)]
    Gcode(#[from] GcodeError),
    /// The planner could not time the program on the machine
    /// ([`CompensateOptions::timing`]).
    #[error(transparent)]
    Planner(#[from] crate::gcode::InterpolateError),
    /// A block whose Z cannot be changed without changing something else.
    #[error("line {line}: cannot compensate this block safely: {reason}")]
    Unsafe {
        /// 1-based line.
        line: u64,
        /// Why.
        reason: String,
    },
    /// The model needs inputs a program does not define.
    #[error(
        "the thermal model takes the inputs {0:?}; a program only defines the spindle speed (a model fitted with speed_rpm alone is needed)"
    )]
    ModelInputs(Vec<String>),
    /// Invalid settings.
    #[error("{0}")]
    Options(String),
    /// The model is unstable at some height and `allow_unstable` is off.
    #[error(
        "the thermal model at z = {} mm: {reason}; refusing to compensate with it (allow it explicitly to go on)",
        crate::limits::fmt_message_number(*.z_mm)
    )]
    Unstable {
        /// The height of the unstable ARX model, mm.
        z_mm: f64,
        /// The stability verdict.
        reason: String,
    },
    /// The predicted drift is not finite or beyond any real drift.
    #[error(
        "line {line}: the predicted drift is {} mm (the model diverges): nothing written",
        crate::limits::fmt_message_number(*.drift_mm)
    )]
    Diverges {
        /// 1-based line of the block.
        line: u64,
        /// The drift predicted there, mm.
        drift_mm: f64,
    },
    /// The model's channels use inputs a program does not define and no
    /// inputs log gives them.
    #[error(
        "the thermal model's channel(s) {} use the input(s) {} that a program does not define: give their values over the program's time in an inputs log (a `t_s` or `t_min` column and these columns)",
        .channels.join(", "),
        .inputs.join(", ")
    )]
    MissingInputs {
        /// The channels (columns) that use them.
        channels: Vec<String>,
        /// The missing inputs (columns).
        inputs: Vec<String>,
    },
    /// The channels to compensate with cannot be chosen: several on one
    /// axis, or a named channel that is not in the model.
    #[error("{0}")]
    Channels(String),
    /// A channel of a log model is unstable and `allow_unstable` is off.
    #[error(
        "the thermal model's channel `{column}`: {reason}; refusing to compensate with it (allow it explicitly to go on)"
    )]
    UnstableChannel {
        /// The channel's column.
        column: String,
        /// The stability verdict.
        reason: String,
    },
    /// The inputs log could not be read (each problem at its line).
    #[error("{0}")]
    InputsLog(Diagnostics),
    /// The estimated duration is beyond what a drift prediction can cover.
    #[error(
        "the program's estimated duration ({} min) exceeds {MAX_DURATION_MIN} min: check its feeds and dwells",
        crate::limits::fmt_message_number(*.duration_min)
    )]
    TooLong {
        /// Estimated duration, min.
        duration_min: f64,
    },
}

impl CompensateError {
    /// What went wrong, without the location (for callers that print the
    /// location themselves, as `file:line:col: message`); a located
    /// error's [`Display`](std::fmt::Display) is `line N: ` and this.
    pub fn message(&self) -> String {
        match self {
            CompensateError::Gcode(e) => e.message(),
            CompensateError::Planner(e) => e.message(),
            CompensateError::Unsafe { reason, .. } => {
                format!("cannot compensate this block safely: {reason}")
            }
            CompensateError::Diverges { drift_mm, .. } => format!(
                "the predicted drift is {} mm (the model diverges): nothing written",
                crate::limits::fmt_message_number(*drift_mm)
            ),
            other => other.to_string(),
        }
    }
}

/// Longest program duration compensated (a year), min: the sample grid of the
/// prediction is held in memory.
pub const MAX_DURATION_MIN: f64 = 525_600.0;

/// What happened to one block that targets a Z position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZBlock {
    /// 1-based line.
    pub line: u64,
    /// Estimated time at the end of the block, min from program start.
    pub end_min: f64,
    /// Machine Z the original block ends at, mm.
    pub machine_z_mm: f64,
    /// Correction in force after the block (subtracted from the target), mm;
    /// 0 for G53 moves.
    pub correction_mm: f64,
    /// The block was G53 (left alone).
    pub g53: bool,
    /// The block's text changed.
    pub changed: bool,
}

/// What happened to the word of one corrected axis in one block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisBlock {
    /// 1-based line.
    pub line: u64,
    /// The axis (X, Y or Z).
    pub axis: Axis,
    /// Estimated time at the end of the block, min from program start.
    pub end_min: f64,
    /// Machine coordinate on `axis` the original block ends at, mm.
    pub machine_mm: f64,
    /// Correction on `axis` in force after the block (subtracted from the
    /// target), mm; for G53 moves the one in force before.
    pub correction_mm: f64,
    /// The block was G53 (left alone).
    pub g53: bool,
    /// The word's text changed.
    pub changed: bool,
}

/// Result of [`compensate`] and [`compensate_log`].
#[derive(Debug, Clone, PartialEq)]
pub struct Compensation {
    /// The compensated program text.
    pub output: Vec<u8>,
    /// Every block with a Z word, in order (the Z entries of `axis_blocks`).
    pub z_blocks: Vec<ZBlock>,
    /// Per block, in order, one entry per corrected axis it has a word of
    /// (Z only for [`compensate`]; X, Y, Z in that order within a block).
    pub axis_blocks: Vec<AxisBlock>,
    /// The spindle speed programme on the model's sample grid (rev/min), from
    /// `t = 0` to past the program's end.
    pub programme: Programme,
    /// Estimated duration of the program, min.
    pub duration_min: f64,
    /// Blocks read.
    pub blocks: u64,
    /// Whether the spindle ever ran.
    pub spindle_used: bool,
    /// Remarks for the user (G53 moves left alone, no spindle, ...).
    pub notes: Vec<String>,
}

impl Compensation {
    /// Number of blocks whose text changed.
    pub fn blocks_changed(&self) -> usize {
        self.z_blocks.iter().filter(|b| b.changed).count()
    }

    /// Largest |correction| applied, mm.
    pub fn max_correction_mm(&self) -> f64 {
        self.z_blocks
            .iter()
            .map(|b| b.correction_mm.abs())
            .fold(0.0, f64::max)
    }

    /// Time of the first and the last changed block, min.
    pub fn changed_span_min(&self) -> Option<(f64, f64)> {
        let first = self.z_blocks.iter().find(|b| b.changed)?.end_min;
        let last = self.z_blocks.iter().rev().find(|b| b.changed)?.end_min;
        Some((first, last))
    }

    /// What changed on `axis`: its entries of [`Compensation::axis_blocks`]
    /// summed up.
    pub fn axis_summary(&self, axis: Axis) -> AxisSummary {
        let on = || self.axis_blocks.iter().filter(move |b| b.axis == axis);
        let first = on().find(|b| b.changed).map(|b| b.end_min);
        let last = on().rfind(|b| b.changed).map(|b| b.end_min);
        AxisSummary {
            blocks: on().count(),
            changed: on().filter(|b| b.changed).count(),
            max_correction_mm: on().map(|b| b.correction_mm.abs()).fold(0.0, f64::max),
            changed_span_min: first.zip(last),
        }
    }

    /// Number of blocks with at least one changed word (any axis).
    pub fn lines_changed(&self) -> usize {
        let mut lines: Vec<u64> = self
            .axis_blocks
            .iter()
            .filter(|b| b.changed)
            .map(|b| b.line)
            .collect();
        lines.dedup();
        lines.len()
    }
}

/// What a compensation changed on one axis ([`Compensation::axis_summary`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisSummary {
    /// Blocks with a word of the axis.
    pub blocks: usize,
    /// Those whose word changed.
    pub changed: usize,
    /// Largest |correction| in force, mm.
    pub max_correction_mm: f64,
    /// Time of the first and the last changed block, min.
    pub changed_span_min: Option<(f64, f64)>,
}

/// Spindle speed as a step function of time: `(start_min, rpm)`, starts
/// ascending, the first at 0.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedHistory {
    steps: Vec<(f64, f64)>,
}

impl Default for SpeedHistory {
    fn default() -> Self {
        SpeedHistory {
            steps: vec![(0.0, 0.0)],
        }
    }
}

impl SpeedHistory {
    /// Sets the speed from `t_min` on (`t_min` not before the last change).
    pub fn set(&mut self, t_min: f64, rpm: f64) {
        let last = self.steps.len() - 1;
        if self.steps[last].1 == rpm {
            return;
        }
        if self.steps[last].0 >= t_min {
            self.steps[last].1 = rpm;
        } else {
            self.steps.push((t_min, rpm));
        }
    }

    /// Mean speed over `[a, b)` (`a < b`), rev/min; the last speed holds forever.
    pub fn mean(&self, a: f64, b: f64) -> f64 {
        let mut sum = 0.0;
        for (i, &(start, rpm)) in self.steps.iter().enumerate() {
            let end = self.steps.get(i + 1).map_or(f64::INFINITY, |s| s.0);
            let overlap = end.min(b) - start.max(a);
            if overlap > 0.0 {
                sum += rpm * overlap;
            }
        }
        sum / (b - a)
    }

    /// The mean speed of each period `[kT, (k+1)T)`, `k = 0..samples`.
    pub fn programme(&self, period_min: f64, samples: usize) -> Programme {
        let speeds: Vec<f64> = (0..samples)
            .map(|k| self.mean(k as f64 * period_min, (k + 1) as f64 * period_min))
            .collect();
        Programme::speeds(&speeds)
    }
}

/// The axes a compensation can correct, in the order their words are
/// rewritten within a block.
const LINEAR: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

/// A move with a word of a corrected axis, found in the first pass.
#[derive(Debug, Clone, Copy)]
struct AxisMove {
    block: usize,
    end_min: f64,
    /// Start, end and offset of the move (work coordinates, mm).
    from: crate::gcode::Axes,
    to: crate::gcode::Axes,
    offset: crate::gcode::Axes,
    words: Programmed,
    /// Per axis of [`LINEAR`]: the block has a word of it and it is corrected.
    has: [bool; 3],
    /// The move is an arc in the XY plane (G17): its X and Y words keep the
    /// correction in force at its start (the arc is moved rigidly).
    xy_arc: bool,
    /// Arc centres were absolute (G90.1) at the block.
    absolute_centres: bool,
}

/// What one compensation corrects and by how much: the drift model behind
/// [`compensate`] (heights, Z only) and [`compensate_log`] (one channel per axis).
trait Corrector {
    /// The axes corrected (of [`LINEAR`]).
    fn axes(&self) -> &[Axis];
    /// Sample period of the model, min.
    fn period_min(&self) -> f64;
    /// Without the spindle the drift is zero (the speed is the only input).
    fn idle_without_spindle(&self) -> bool;
    /// Predicts the drift over the program from its speed `programme` (the
    /// period means, from `t = 0`); may add notes.
    fn prepare(
        &mut self,
        programme: &Programme,
        duration_min: f64,
        notes: &mut Vec<String>,
    ) -> Result<(), CompensateError>;
    /// The drift along `axis` at `t_min` for a block ending at machine
    /// coordinate `machine_mm` on that axis, mm.
    fn drift(&self, axis: Axis, t_min: f64, machine_mm: f64) -> f64;
}

/// The height model of [`compensate`]: Z only, drift interpolated across heights.
struct HeightCorrector<'a> {
    model: &'a ThermalModel,
    history: Vec<Vec<f64>>,
}

impl Corrector for HeightCorrector<'_> {
    fn axes(&self) -> &[Axis] {
        &[Axis::Z]
    }

    fn period_min(&self) -> f64 {
        self.model.period_min()
    }

    fn idle_without_spindle(&self) -> bool {
        true
    }

    fn prepare(
        &mut self,
        programme: &Programme,
        _: f64,
        _: &mut Vec<String>,
    ) -> Result<(), CompensateError> {
        self.history = self.model.drift_history(programme);
        Ok(())
    }

    /// Linear in time between samples (drift at the period marks),
    /// interpolated across heights.
    fn drift(&self, _: Axis, t_min: f64, z: f64) -> f64 {
        let history = &self.history;
        let pos = (t_min / self.model.period_min()).max(0.0);
        let k = (pos.floor() as usize).min(history.len() - 2);
        let frac = (pos - k as f64).min(1.0);
        let values: Vec<f64> = history[k]
            .iter()
            .zip(&history[k + 1])
            .map(|(a, b)| a + frac * (b - a))
            .collect();
        self.model.interpolate(&values, z).mm
    }
}

/// Compensates `program` (the bytes of an NC file) for the drift predicted
/// by `model`. See the module documentation for the rules.
pub fn compensate(
    model: &ThermalModel,
    program: &[u8],
    options: &CompensateOptions,
) -> Result<Compensation, CompensateError> {
    // One column, the speed (it may feed several inputs: speed and speed²).
    if model.columns().len() != 1 {
        return Err(CompensateError::ModelInputs(model.columns().to_vec()));
    }
    check_options(options)?;
    if !options.allow_unstable {
        for h in model.heights() {
            if let Some(reason) = h.model.stability().warning() {
                return Err(CompensateError::Unstable {
                    z_mm: h.z_mm,
                    reason,
                });
            }
        }
    }
    let mut corrector = HeightCorrector {
        model,
        history: Vec::new(),
    };
    compensate_with(&mut corrector, program, options)
}

/// The rapid rate and the correction period in their domains.
fn check_options(options: &CompensateOptions) -> Result<(), CompensateError> {
    if !(options.rapid_feed.is_finite() && options.rapid_feed > 0.0) {
        return Err(CompensateError::Options(format!(
            "the rapid rate must be > 0 mm/min, not {}",
            options.rapid_feed
        )));
    }
    if let CorrectionUpdate::Periodic { period_min } = options.update
        && !(period_min.is_finite() && period_min > 0.0)
    {
        return Err(CompensateError::Options(format!(
            "the correction period must be > 0 min, not {period_min}"
        )));
    }
    Ok(())
}

/// Times the program, predicts the drift with `corrector` and rewrites the
/// words of its axes (the rules of the module documentation).
fn compensate_with(
    corrector: &mut dyn Corrector,
    program: &[u8],
    options: &CompensateOptions,
) -> Result<Compensation, CompensateError> {
    let stats_opts = StatsOptions {
        interp: InterpOptions {
            dialect: options.dialect,
            program: options.program.clone(),
            tools: options.tools.clone(),
            skip_deleted_blocks: options.skip_deleted_blocks,
            machine_axes: options.machine_axes,
            ..InterpOptions::default()
        },
        rapid_feed: options.rapid_feed,
        ..StatsOptions::default()
    };
    // Read up to the end of the program (M2, M30, closing '%'); what
    // follows is copied unread, as LinuxCNC never reads it.
    let (mut prog, read) = crate::gcode::Program::parse_to_end(program, &stats_opts.interp)?;
    let trailer = &program[read..];

    // Pass 1: times, speeds, Z moves.
    let mut result_note = None;
    let mut interp = Interpreter::new(stats_opts.interp.clone());
    let mut stats = ProgramStats::default();
    // (block, time by the estimate in min, spindle speed from then on).
    let mut speed_steps: Vec<(usize, f64, f64)> = Vec::new();
    let (mut rpm, mut on) = (0.0_f64, false);
    let mut spindle_used = false;
    let mut moves = Vec::new();
    let mut events: Vec<Event> = Vec::new();
    for (index, block) in prog.blocks.iter().enumerate() {
        events.clear();
        interp.execute(block, &mut events)?;
        for e in &events {
            match e.kind {
                EventKind::SpindleSpeed { rpm: s } => rpm = s.abs(),
                EventKind::Spindle(state) => on = state != SpindleState::Stopped,
                _ => {}
            }
            let now = stats.total_time() / 60.0;
            let n = if on { rpm } else { 0.0 };
            spindle_used |= n > 0.0;
            speed_steps.push((index, now, n));
            stats.add(e, &stats_opts)?;
        }
        let end_min = stats.total_time() / 60.0;
        let centres = interp.state().arc_distance;
        if let Some(m) = axis_move(block, index, &events, end_min, corrector.axes(), centres)? {
            moves.push(m);
        }
    }
    let mut duration_min = stats.total_time() / 60.0;
    let mut speed = SpeedHistory::default();
    if let Some(timing) = &options.timing {
        // The planner's end time of each block (min): that of its line's
        // motion, else (no motion) the end of the block before it.
        let mut iopts = crate::gcode::InterpolateOptions::new(1.0);
        iopts.interp = stats_opts.interp.clone();
        iopts.plan = timing.plan;
        let times = crate::gcode::line_end_times(&program[..read], &timing.machine, &iopts)?;
        let by_line = times.by_line();
        let mut end = Vec::with_capacity(prog.blocks.len());
        let mut last = 0.0_f64;
        for block in &prog.blocks {
            if let Some(&t) = by_line.get(&block.line()) {
                last = last.max(t / 60.0);
            }
            end.push(last);
        }
        let start = |b: usize| if b == 0 { 0.0 } else { end[b - 1] };
        for &(b, _, n) in &speed_steps {
            speed.set(start(b), n);
        }
        for m in &mut moves {
            m.end_min = end[m.block];
        }
        duration_min = (times.duration / 60.0).max(last);
        result_note = Some(format!(
            "block times from the {} planner on the machine {}",
            timing.plan.planner, timing.machine.name
        ));
    } else {
        for &(_, now, n) in &speed_steps {
            speed.set(now, n);
        }
    }
    // NaN is refused too.
    if duration_min.is_nan() || duration_min > MAX_DURATION_MIN {
        return Err(CompensateError::TooLong { duration_min });
    }
    let period = corrector.period_min();
    let horizon = match options.update {
        CorrectionUpdate::Periodic { period_min } => {
            ((duration_min / period_min).floor() + 1.0) * period_min
        }
        CorrectionUpdate::Continuous => duration_min,
    };
    let samples = (horizon / period).ceil() as usize + 2;
    let programme = speed.programme(period, samples);
    let mut result = Compensation {
        output: Vec::new(),
        z_blocks: Vec::new(),
        axis_blocks: Vec::with_capacity(moves.len()),
        programme,
        duration_min,
        // Lines after the program end count as blocks of the file, as
        // before reading stopped there.
        blocks: (prog.blocks.len()
            + trailer.iter().filter(|&&b| b == b'\n').count()
            + usize::from(!trailer.is_empty() && !trailer.ends_with(b"\n"))) as u64,
        spindle_used,
        notes: result_note.into_iter().collect(),
    };
    if !spindle_used && corrector.idle_without_spindle() {
        result.output = program.to_vec();
        result.notes.push(
            "the program never turns the spindle on (S with M3/M4): no drift, no change".into(),
        );
        for m in &moves {
            for (i, &axis) in LINEAR.iter().enumerate() {
                if m.has[i] {
                    result.axis_blocks.push(AxisBlock {
                        line: prog.blocks[m.block].line(),
                        axis,
                        end_min: m.end_min,
                        machine_mm: m.to[axis] + m.offset[axis],
                        correction_mm: 0.0,
                        g53: m.words.g53,
                        changed: false,
                    });
                }
            }
        }
        result.z_blocks = z_blocks(&result.axis_blocks);
        return Ok(result);
    }

    // Pass 2: corrections and edits.
    corrector.prepare(&result.programme, duration_min, &mut result.notes)?;
    // The correction in force per axis of LINEAR (subtracted from its targets).
    let mut applied = [0.0_f64; 3];
    let mut g53_lines = Vec::new();
    for m in &moves {
        let block = &mut prog.blocks[m.block];
        let line = block.line();
        if m.words.g53 {
            g53_lines.push(line);
        }
        for (i, &axis) in LINEAR.iter().enumerate() {
            if !m.has[i] {
                continue;
            }
            let machine = m.to[axis] + m.offset[axis];
            let mut record = AxisBlock {
                line,
                axis,
                end_min: m.end_min,
                machine_mm: machine,
                correction_mm: 0.0,
                g53: m.words.g53,
                changed: false,
            };
            if m.words.g53 {
                record.correction_mm = applied[i];
                result.axis_blocks.push(record);
                continue;
            }
            let new_end = if m.xy_arc && axis != Axis::Z {
                // An in-plane word of an XY arc: start, centre (start + I/J)
                // and end all move by the correction in force, so the arc
                // keeps its shape; an incremental word is then unchanged.
                match m.words.distance {
                    DistanceMode::Absolute if applied[i] != 0.0 => {
                        if m.absolute_centres {
                            return Err(CompensateError::Unsafe {
                                line,
                                reason: format!(
                                    "an {} word of an arc with absolute centres (G90.1): moving the arc would change its I/J words too",
                                    axis.letter() as char
                                ),
                            });
                        }
                        Some(m.to[axis] - applied[i])
                    }
                    _ => None,
                }
            } else {
                let t_c = match options.update {
                    CorrectionUpdate::Continuous => m.end_min,
                    CorrectionUpdate::Periodic { period_min } => {
                        ((m.end_min / period_min).floor() + 0.5) * period_min
                    }
                };
                let c = corrector.drift(axis, t_c, machine);
                if !(c.is_finite() && c.abs() <= crate::limits::MAX_ERROR_VALUE) {
                    return Err(CompensateError::Diverges { line, drift_mm: c });
                }
                match m.words.distance {
                    DistanceMode::Absolute if c.abs() >= WRITE_TOLERANCE_MM => {
                        applied[i] = c;
                        Some(m.to[axis] - c)
                    }
                    DistanceMode::Absolute => {
                        applied[i] = 0.0;
                        None
                    }
                    DistanceMode::Incremental if (c - applied[i]).abs() >= WRITE_TOLERANCE_MM => {
                        let end = m.to[axis] - (c - applied[i]);
                        applied[i] = c;
                        Some(end)
                    }
                    DistanceMode::Incremental => None,
                }
            };
            if let Some(end) = new_end {
                let value = m.words.word_value(axis, &m.from, end, &m.offset);
                write_word(block, axis, value, options.dialect, m.words)?;
                record.changed = true;
            }
            record.correction_mm = applied[i];
            result.axis_blocks.push(record);
        }
    }
    if !g53_lines.is_empty() {
        let shown: Vec<String> = g53_lines.iter().take(10).map(u64::to_string).collect();
        result.notes.push(format!(
            "{} G53 (machine coordinate) move(s) left alone, line(s) {}{}",
            g53_lines.len(),
            shown.join(", "),
            if g53_lines.len() > 10 { ", ..." } else { "" }
        ));
    }
    result.z_blocks = z_blocks(&result.axis_blocks);
    result.output = prog.to_bytes();
    result.output.extend_from_slice(trailer);
    Ok(result)
}

/// Settings of [`compensate_log`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct LogCompensateOptions {
    /// Dialect, rapid rate, update policy, unstable models, program options
    /// (as [`compensate`]; `allow_unstable` applies to each used channel).
    pub compensate: CompensateOptions,
    /// The model's input column that is the spindle speed (rev/min): its
    /// values come from the program (S with M3/M4), never from the inputs log.
    pub speed_column: String,
    /// The channels (columns) to compensate with, at most one per axis;
    /// empty: every channel of the model, which must then act on distinct axes.
    pub channels: Vec<String>,
}

impl Default for LogCompensateOptions {
    /// [`CompensateOptions::default`], the speed in `speed_rpm`, every channel.
    fn default() -> Self {
        LogCompensateOptions {
            compensate: CompensateOptions::default(),
            speed_column: "speed_rpm".into(),
            channels: Vec::new(),
        }
    }
}

/// The G-code axis of a log channel.
fn gcode_axis(axis: super::log::Axis) -> Axis {
    match axis {
        super::log::Axis::X => Axis::X,
        super::log::Axis::Y => Axis::Y,
        super::log::Axis::Z => Axis::Z,
    }
}

/// The channels of `model` used, as (axis, channel index), one per axis.
fn choose_channels(
    model: &LogModel,
    named: &[String],
) -> Result<Vec<(Axis, usize)>, CompensateError> {
    let columns: Vec<&str> = model
        .channels
        .iter()
        .map(|c| c.channel.column.as_str())
        .collect();
    let picked: Vec<usize> = if named.is_empty() {
        (0..columns.len()).collect()
    } else {
        let mut picked = Vec::new();
        for name in named {
            let Some(i) = columns.iter().position(|c| c == name) else {
                return Err(CompensateError::Channels(format!(
                    "the model has no channel `{name}` (its channels: {})",
                    columns.join(", ")
                )));
            };
            if picked.contains(&i) {
                return Err(CompensateError::Channels(format!(
                    "channel `{name}` is named twice"
                )));
            }
            picked.push(i);
        }
        picked
    };
    let mut chosen: Vec<(Axis, usize)> = Vec::new();
    for i in picked {
        let axis = gcode_axis(model.channels[i].channel.axis);
        if let Some(&(_, j)) = chosen.iter().find(|(a, _)| *a == axis) {
            let on_axis: Vec<&str> = model
                .channels
                .iter()
                .filter(|c| gcode_axis(c.channel.axis) == axis)
                .map(|c| c.channel.column.as_str())
                .collect();
            return Err(CompensateError::Channels(format!(
                "channels `{}` and `{}` both act on {}: a program is corrected by one channel per axis; name the one to use (of {})",
                columns[j],
                columns[i],
                axis.letter() as char,
                on_axis.join(", ")
            )));
        }
        chosen.push((axis, i));
    }
    chosen.sort_by_key(|&(a, _)| a.index());
    if chosen.is_empty() {
        return Err(CompensateError::Channels("the model has no channel".into()));
    }
    Ok(chosen)
}

/// A log model: one channel per corrected axis, inputs from the program
/// (the speed) and from an inputs log (the rest).
struct LogCorrector<'a> {
    model: &'a LogModel,
    /// (axis, channel index), ascending axes.
    chosen: Vec<(Axis, usize)>,
    axes: Vec<Axis>,
    /// Per model input: it is the spindle speed (from the program).
    speed: Vec<bool>,
    /// Per model input: a used channel takes it.
    needed: Vec<bool>,
    /// The inputs log on the model's grid: the needed non-speed inputs, in
    /// model input order.
    log: Option<LogData>,
    /// Per chosen channel: the drift on the grid, mm since the start.
    drift: Vec<Vec<f64>>,
}

impl Corrector for LogCorrector<'_> {
    fn axes(&self) -> &[Axis] {
        &self.axes
    }

    fn period_min(&self) -> f64 {
        self.model.period_min
    }

    fn idle_without_spindle(&self) -> bool {
        self.needed.iter().zip(&self.speed).all(|(&n, &s)| !n || s)
    }

    fn prepare(
        &mut self,
        programme: &Programme,
        duration_min: f64,
        notes: &mut Vec<String>,
    ) -> Result<(), CompensateError> {
        let n = programme.len();
        let period = self.model.period_min;
        let mut logged = self.log.as_ref().map(|l| l.inputs.iter());
        let mut series = Vec::with_capacity(self.model.inputs.len());
        for (i, input) in self.model.inputs.iter().enumerate() {
            let s: Vec<f64> = if self.speed[i] {
                (0..n).map(|k| programme.sample(k)[0]).collect()
            } else if self.needed[i] {
                let Some(values) = logged.as_mut().and_then(Iterator::next) else {
                    return Err(CompensateError::Options(format!(
                        "no values of input `{}`",
                        input.column
                    )));
                };
                // The last period mean holds past the end of the log.
                let last = values.last().copied().unwrap_or(0.0);
                (0..n)
                    .map(|k| values.get(k).copied().unwrap_or(last))
                    .collect()
            } else {
                vec![0.0; n]
            };
            series.push(s);
        }
        if let Some(log) = &self.log {
            let covered = log.len() as f64 * period;
            if covered < duration_min {
                notes.push(format!(
                    "the inputs log covers {} min of the program's {} min: its last period means are held from {} min on",
                    crate::limits::fmt_message_number(covered),
                    crate::limits::fmt_message_number((duration_min * 1e3).round() / 1e3),
                    crate::limits::fmt_message_number(covered)
                ));
            }
        }
        let drift = self
            .model
            .simulate(&self.model.scaled_inputs(&series))
            .map_err(|e| CompensateError::Options(e.to_string()))?;
        self.drift = self.chosen.iter().map(|&(_, c)| drift[c].clone()).collect();
        Ok(())
    }

    /// The channel's period means placed at the period centres, linear
    /// between them, held before the first and after the last.
    fn drift(&self, axis: Axis, t_min: f64, _: f64) -> f64 {
        let i = self
            .chosen
            .iter()
            .position(|&(a, _)| a == axis)
            .expect("only the chosen axes are corrected");
        at_time(&self.drift[i], self.model.period_min, t_min)
    }
}

/// Compensates `program` for the drift of a log model (`thermal fit
/// --log`): every axis with a channel is corrected (X, Y and Z; one channel
/// per axis, see [`LogCompensateOptions::channels`]), by the rules of the
/// module documentation.
///
/// The model's inputs over the program's time (from its start, `t = 0`):
/// the spindle speed column ([`LogCompensateOptions::speed_column`]) is the
/// program's own speed, averaged over each model period; every other input
/// a used channel takes comes from `inputs_log` (a `t_s` or `t_min` column
/// and those columns, its first row the program's start), averaged over the
/// model periods as [`read_log`] does (a temperature as its rise since the
/// first period). Where the program runs longer than the inputs log, the
/// log's last period means are held (with a note). The drift of a channel
/// at time `t` is its period means placed at the period centres, linear
/// between them ([`at_time`]).
///
/// # Errors
/// Those of [`compensate`]; [`CompensateError::Channels`] when two used
/// channels act on one axis or a named channel is not in the model;
/// [`CompensateError::MissingInputs`] when a used channel takes inputs
/// other than the speed and `inputs_log` is `None`;
/// [`CompensateError::InputsLog`] for a bad inputs log (at its line);
/// [`CompensateError::UnstableChannel`].
pub fn compensate_log(
    model: &LogModel,
    program: &[u8],
    inputs_log: Option<&Table>,
    options: &LogCompensateOptions,
) -> Result<Compensation, CompensateError> {
    check_options(&options.compensate)?;
    let chosen = choose_channels(model, &options.channels)?;
    if !options.compensate.allow_unstable {
        for &(_, c) in &chosen {
            let channel = &model.channels[c];
            let models = channel
                .arx_models()
                .map_err(|e| CompensateError::Options(e.to_string()))?;
            if let Some(reason) = models.iter().find_map(|arx| arx.stability().warning()) {
                return Err(CompensateError::UnstableChannel {
                    column: channel.channel.column.clone(),
                    reason,
                });
            }
        }
    }
    let speed: Vec<bool> = model
        .inputs
        .iter()
        .map(|i| i.column == options.speed_column && i.over.is_none())
        .collect();
    let mut needed = vec![false; model.inputs.len()];
    for &(_, c) in &chosen {
        for i in model.channels[c].used_inputs() {
            needed[i] = true;
        }
    }
    let logged: Vec<usize> = (0..model.inputs.len())
        .filter(|&i| needed[i] && !speed[i])
        .collect();
    let mut notes = Vec::new();
    let log = match inputs_log {
        None if !logged.is_empty() => {
            let users = chosen
                .iter()
                .map(|&(_, c)| &model.channels[c])
                .filter(|c| c.used_inputs().iter().any(|i| logged.contains(i)))
                .map(|c| c.channel.column.clone())
                .collect();
            let mut inputs: Vec<String> = Vec::new();
            for &i in &logged {
                let input = &model.inputs[i];
                for column in std::iter::once(&input.column).chain(&input.over) {
                    if !inputs.contains(column) {
                        inputs.push(column.clone());
                    }
                }
            }
            return Err(CompensateError::MissingInputs {
                channels: users,
                inputs,
            });
        }
        None => None,
        Some(table) if logged.is_empty() => {
            notes.push(format!(
                "{}: not used (the channels used take only the spindle speed, from the program)",
                table.path().display()
            ));
            None
        }
        Some(table) => {
            if table.column(&options.speed_column).is_some() {
                notes.push(format!(
                    "{}: column `{}` not used (the spindle speed comes from the program)",
                    table.path().display(),
                    options.speed_column
                ));
            }
            // The log's own reading (time column, averaging, gaps, missing
            // cells), one input per model input; a column taken both as it
            // is and squared is read twice.
            let specs: Vec<InputSpec> = logged
                .iter()
                .map(|&i| InputSpec {
                    rise: false,
                    square: false,
                    ..model.inputs[i].spec()
                })
                .collect();
            let data = read_log(table, &[], &specs, model.period_min)
                .map_err(CompensateError::InputsLog)?;
            notes.extend(data.notes.iter().cloned());
            Some(data)
        }
    };
    let axes = chosen.iter().map(|&(a, _)| a).collect();
    let mut corrector = LogCorrector {
        model,
        chosen,
        axes,
        speed,
        needed,
        log,
        drift: Vec::new(),
    };
    let mut result = compensate_with(&mut corrector, program, &options.compensate)?;
    notes.append(&mut result.notes);
    result.notes = notes;
    Ok(result)
}

/// The Z entries of `blocks`.
fn z_blocks(blocks: &[AxisBlock]) -> Vec<ZBlock> {
    blocks
        .iter()
        .filter(|b| b.axis == Axis::Z)
        .map(|b| ZBlock {
            line: b.line,
            end_min: b.end_min,
            machine_z_mm: b.machine_mm,
            correction_mm: b.correction_mm,
            g53: b.g53,
            changed: b.changed,
        })
        .collect()
}

/// "a Z word", "an X word".
fn word_of(axis: Axis) -> String {
    let letter = axis.letter() as char;
    let article = if matches!(letter, 'X' | 'A' | 'U') {
        "an"
    } else {
        "a"
    };
    format!("{article} {letter} word")
}

/// The move of a block that has a word of one of the corrected `axes`
/// (`None` without such a word, or when the word is a dwell time, as
/// Fanuc's `G4 X`).
fn axis_move(
    block: &Block,
    index: usize,
    events: &[Event],
    end_min: f64,
    axes: &[Axis],
    centres: DistanceMode,
) -> Result<Option<AxisMove>, CompensateError> {
    let mut has = [false; 3];
    for (i, &axis) in LINEAR.iter().enumerate() {
        has[i] = axes.contains(&axis) && block.word(axis.letter() as char)?.is_some();
    }
    // A move the interpreter marks `expanded` (as `compensate` reads it:
    // LinuxCNC's polar words `@ ^`, a move a block expands to) that moves a
    // corrected X or Y has no X or Y word to correct.
    let xy: Vec<Axis> = [Axis::X, Axis::Y]
        .into_iter()
        .filter(|a| axes.contains(a))
        .collect();
    let unwritten_xy = events.iter().any(|e| {
        let (from, to, words) = match &e.kind {
            EventKind::Traverse(l) | EventKind::Feed(l) => (l.from, l.to, l.words),
            EventKind::Arc(a) => (a.from, a.to, a.words),
            _ => return false,
        };
        words.expanded && xy.iter().any(|&a| to[a] != from[a])
    });
    if unwritten_xy && block.word('X')?.is_none() && block.word('Y')?.is_none() {
        return Err(CompensateError::Unsafe {
            line: block.line(),
            reason: "a move without X or Y words (polar coordinates @ ^, or a move the block expands to): \
                     the block has no X or Y word to correct"
                .into(),
        });
    }
    if !has.iter().any(|&h| h) {
        return Ok(None);
    }
    let present: Vec<Axis> = LINEAR
        .iter()
        .zip(has)
        .filter_map(|(&a, h)| h.then_some(a))
        .collect();
    let moves = |e: &&Event| {
        matches!(
            e.kind,
            EventKind::Traverse(_) | EventKind::Feed(_) | EventKind::Arc(_)
        )
    };
    if !present.contains(&Axis::Z)
        && !events.iter().any(|e| moves(&e))
        && events
            .iter()
            .any(|e| matches!(e.kind, EventKind::Dwell { .. }))
    {
        return Ok(None);
    }
    let unsafe_block = |reason: &str| CompensateError::Unsafe {
        line: block.line(),
        reason: reason.into(),
    };
    let mut found = None;
    for e in events {
        let m = match &e.kind {
            EventKind::Traverse(l) | EventKind::Feed(l) => (l.from, l.to, l.offset, l.words, false),
            EventKind::Arc(a) => {
                for &axis in &present {
                    let in_plane = match axis {
                        Axis::Z => a.plane != Plane::Xy,
                        Axis::X => a.plane == Plane::Zx,
                        _ => a.plane == Plane::Yz,
                    };
                    if in_plane {
                        let planes = match axis {
                            Axis::Z => "the ZX or YZ plane",
                            Axis::X => "the ZX plane",
                            _ => "the YZ plane",
                        };
                        return Err(unsafe_block(&format!(
                            "{} of an arc in {planes} (changing it changes the arc)",
                            word_of(axis)
                        )));
                    }
                }
                (a.from, a.to, a.offset, a.words, a.plane == Plane::Xy)
            }
            _ => continue,
        };
        if e.at.line != block.line() {
            return Err(unsafe_block(
                "a move of another line that cutter radius compensation held back to this one",
            ));
        }
        if found.is_some() {
            return Err(unsafe_block("the block holds more than one move"));
        }
        found = Some(m);
    }
    let not_target =
        |axis: Axis| unsafe_block(&format!("{} that is not a move target", word_of(axis)));
    let Some((from, to, offset, words, xy_arc)) = found else {
        return Err(not_target(present[0]));
    };
    if let Some(&axis) = present.iter().find(|&&a| !words.axes.contains(a)) {
        return Err(not_target(axis));
    }
    Ok(Some(AxisMove {
        block: index,
        end_min,
        from,
        to,
        offset,
        words,
        has,
        xy_arc,
        absolute_centres: centres == DistanceMode::Absolute,
    }))
}

/// Writes the word of `axis` (program units); a Fanuc program without
/// decimal point programming gets a decimal point, or least increments when
/// the value is whole.
fn write_word(
    block: &mut Block,
    axis: Axis,
    value: f64,
    dialect: Dialect,
    words: Programmed,
) -> Result<(), GcodeError> {
    let letter = axis.letter() as char;
    block.set_word(letter, value)?;
    let needs_point = matches!(
        dialect,
        Dialect::Fanuc {
            decimal_point_programming: false
        }
    );
    let has_point = block.word(letter)?.is_some_and(|w| w.has_point);
    if needs_point && !has_point {
        let increment = match words.units {
            crate::gcode::Units::Millimetre => 1e-3,
            crate::gcode::Units::Inch => 1e-4,
        };
        block.set_word_with(letter, (value / increment).round(), NumberFormat::Fixed(0))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::thermal::{HeightModel, InputChannel};
    use crate::sysid::Arx;

    /// First-order model at two heights: `e(k) = 0.8 e(k−1) + 0.2·g·n(k−1)/1000`.
    fn model(g_low: f64, g_high: f64) -> ThermalModel {
        let h = |z: f64, g: f64| HeightModel {
            z_mm: z,
            model: Arx::new(vec![1.0, -0.8], vec![(vec![0.2 * g], 1)]).unwrap(),
            stats: None,
        };
        let inputs = vec![InputChannel::linear("speed_rpm", 1000.0)];
        ThermalModel::new(10.0, inputs, vec![h(-100.0, g_low), h(0.0, g_high)]).unwrap()
    }

    /// Closed-form drift of [`model`] with a constant `n` from 0, at whole samples.
    fn first_order(g: f64, n: f64, k: i32) -> f64 {
        g * n / 1000.0 * (1.0 - 0.8_f64.powi(k))
    }

    fn opts(update: CorrectionUpdate) -> CompensateOptions {
        CompensateOptions {
            update,
            ..CompensateOptions::default()
        }
    }

    fn text(c: &Compensation) -> String {
        String::from_utf8(c.output.clone()).unwrap()
    }

    /// A Cartesian XYZ machine: 5 mm/s, 50 mm/s², 1000 mm/s³ on every axis.
    fn slow_xyz() -> crate::model::Machine {
        let mut m = crate::examples::xyz(1e4);
        for a in &mut m.axes {
            a.max_velocity = Some(5.0);
            a.max_acceleration = Some(50.0);
            a.max_jerk = Some(1000.0);
        }
        m
    }

    #[test]
    fn planner_times_move_the_corrections() {
        use crate::gcode::plan::{PlanOptions, Planner};
        // One height model with a 1 min sample period: below 1 min the
        // drift at 2000 rpm from t = 0 is e(t) = 0.2·g·2 · t/(1 min) (linear
        // between e(0) = 0 and e(1) = 0.2·g·n/1000), g = 1 mm per 1000 rpm.
        let h = |z: f64| HeightModel {
            z_mm: z,
            model: Arx::new(vec![1.0, -0.8], vec![(vec![0.2], 1)]).unwrap(),
            stats: None,
        };
        let inputs = vec![InputChannel::linear("speed_rpm", 1000.0)];
        let model = ThermalModel::new(1.0, inputs, vec![h(-100.0), h(0.0)]).unwrap();
        let drift = |t_s: f64| 0.4 * t_s / 60.0;
        // 20 collinear moves of 1 mm at F6000 (above the 5 mm/s limit), a
        // 1 s dwell, a 10 mm Z feed, a 30 s dwell, a 10 mm Z rapid; G61
        // (exact path: no corner here to blend, and LinuxCNC keeps the full
        // acceleration, which it halves for blending under G64).
        let mut src = String::from("G21 G90 G61\nS2000 M3\n");
        for i in 1..=20 {
            src.push_str(&format!("G1 X{i} F6000\n"));
        }
        src.push_str("G4 P1\nG1 Z-10\nG4 P30\nG0 Z-20\nM30\n");
        // Closed-form times (s) of the two Z blocks' ends. A rest-to-rest
        // move of L mm at v = 5, a = 50 (v²/a = 0.5 ≤ L) takes L/v + v/a;
        // with the jerk limit j = 1000 (a²/j = 2.5 ≤ v) L/v + v/a + a/j.
        let (v, a, j) = (5.0, 50.0, 1000.0);
        let trap = |l: f64| l / v + v / a;
        let cases = [
            // Stop after every 1 mm move.
            (Some(Planner::ExactStop), 20.0 * trap(1.0), trap(10.0)),
            // LinuxCNC keeps the speed through collinear blocks: one 20 mm move.
            (Some(Planner::Linuxcnc), trap(20.0), trap(10.0)),
            (Some(Planner::Jerk), trap(20.0) + a / j, trap(10.0) + a / j),
            // No machine: programmed feeds, rapids at 10 m/min.
            (None, 20.0 / 100.0, 10.0 / 100.0),
        ];
        let mut written = Vec::new();
        for (planner, chain, z_move) in cases {
            let rapid = if planner.is_some() {
                z_move
            } else {
                10.0 / (10_000.0 / 60.0)
            };
            let t1 = chain + 1.0 + z_move;
            let t2 = t1 + 30.0 + rapid;
            let mut o = opts(CorrectionUpdate::Continuous);
            o.timing = planner.map(|p| PlannedTiming {
                machine: slow_xyz(),
                plan: PlanOptions::new(p),
            });
            let c = compensate(&model, src.as_bytes(), &o).unwrap();
            let out = text(&c);
            let lines: Vec<&str> = out.lines().collect();
            let z_of = |l: &str| -> f64 {
                let w = l.split_whitespace().find(|w| w.starts_with('Z')).unwrap();
                w[1..].parse().unwrap()
            };
            // The planners' times agree with the closed form within 2 ms
            // (LinuxCNC's 1 ms cycle), i.e. within 0.013 µm of drift.
            for (zb, t, target, line) in [
                (c.z_blocks[0], t1, -10.0, lines[23]),
                (c.z_blocks[1], t2, -20.0, lines[25]),
            ] {
                assert!(
                    (zb.end_min * 60.0 - t).abs() < 2e-3,
                    "{planner:?}: line {} ends at {} s, not {t} s",
                    zb.line,
                    zb.end_min * 60.0
                );
                let want = target - drift(t);
                assert!(
                    (z_of(line) - want).abs() <= 0.5e-4 + drift(2e-3),
                    "{planner:?}: {line} against Z{want:.5}"
                );
            }
            written.push((z_of(lines[23]), z_of(lines[25])));
        }
        // The four timings write four different programs.
        for i in 0..written.len() {
            for k in i + 1..written.len() {
                assert!((written[i].0 - written[k].0).abs() > 1e-4, "{written:?}");
            }
        }
    }

    #[test]
    fn speed_history_means() {
        let mut h = SpeedHistory::default();
        h.set(0.0, 1000.0);
        h.set(5.0, 3000.0);
        h.set(15.0, 0.0);
        assert_eq!(h.mean(0.0, 10.0), 2000.0);
        assert_eq!(h.mean(10.0, 20.0), 1500.0);
        assert_eq!(h.mean(20.0, 30.0), 0.0);
        let p = h.programme(10.0, 3);
        assert_eq!((p.sample(0), p.sample(1)), (&[2000.0][..], &[1500.0][..]));
    }

    #[test]
    fn absolute_z_at_whole_samples_matches_closed_form() {
        // Same drift at both heights: 10 µm per 1000 rpm. Spindle 2000 rpm
        // from 0; dwell to t = 20 min exactly, then a rapid of 10 mm in Z at
        // 10 m/min (0.001 min): the block ends at t = 20.001 min.
        let m = model(0.01, 0.01);
        // The spindle keeps running after the move (no M5), so the input of
        // [20, 30) is still 2000 rpm.
        let src = "G21 G90\nS2000 M3\nG4 P1200\nG0 Z-10\nM30\n";
        let c = compensate(&m, src.as_bytes(), &opts(CorrectionUpdate::Continuous)).unwrap();
        let zb = c.z_blocks[0];
        assert_eq!(zb.line, 4);
        let t = 20.0 + 10.0 / 10_000.0;
        assert!((zb.end_min - t).abs() < 1e-12);
        // Linear between samples 2 and 3.
        let e2 = first_order(0.01, 2000.0, 2);
        let e3 = first_order(0.01, 2000.0, 3);
        let want = e2 + (t - 20.0) / 10.0 * (e3 - e2);
        assert!((zb.correction_mm - want).abs() < 1e-12);
        let z_new: f64 = text(&c)
            .lines()
            .nth(3)
            .unwrap()
            .trim_start_matches("G0 Z")
            .parse()
            .unwrap();
        assert!((z_new - (-10.0 - want)).abs() <= 0.5e-4, "{z_new}");
        // Every other line byte for byte.
        for (a, b) in text(&c)
            .lines()
            .zip(src.lines())
            .filter(|(_, b)| !b.contains('Z'))
        {
            assert_eq!(a, b);
        }
    }

    #[test]
    fn periodic_correction_is_the_drift_mid_interval() {
        let m = model(0.01, 0.01);
        // Z moves at t = 10 and 15 min (dwells), period 10: both get e(15).
        let src = "S3000 M3\nG4 P600\nG0 Z-1\nG4 P300\nG0 Z-2\n";
        let c = compensate(
            &m,
            src.as_bytes(),
            &opts(CorrectionUpdate::Periodic { period_min: 10.0 }),
        )
        .unwrap();
        let e1 = first_order(0.01, 3000.0, 1);
        let e2 = first_order(0.01, 3000.0, 2);
        let mid = 0.5 * (e1 + e2);
        for zb in &c.z_blocks {
            assert!((zb.correction_mm - mid).abs() < 1e-12, "{zb:?}");
        }
    }

    #[test]
    fn incremental_words_change_by_the_change_of_the_correction() {
        let m = model(0.01, 0.01);
        // Absolute move at t≈0+ (drift tiny), then G91 steps after dwells.
        let src = "S1000 M3\nG91\nG4 P600\nG1 Z-1 F1000\nG4 P600\nG1 Z-1\nX5\nG90 G0 Z0\n";
        let c = compensate(&m, src.as_bytes(), &opts(CorrectionUpdate::Continuous)).unwrap();
        let zb = &c.z_blocks;
        assert_eq!(zb.len(), 3);
        // Actual Z after each block = sum of the rewritten increments; it must
        // equal original target − correction of that block (± write resolution).
        let out = text(&c);
        let lines: Vec<&str> = out.lines().collect();
        let inc = |l: &str| -> f64 {
            let z = l.split_whitespace().find(|w| w.starts_with('Z')).unwrap();
            z[1..].parse().unwrap()
        };
        let z1 = inc(lines[3]);
        let z2 = z1 + inc(lines[5]);
        assert!((z1 - (-1.0 - zb[0].correction_mm)).abs() <= 0.5e-4);
        assert!((z2 - (-2.0 - zb[1].correction_mm)).abs() <= 1e-4);
        assert!(zb[1].correction_mm > zb[0].correction_mm && zb[0].correction_mm > 0.0);
        assert_eq!(c.blocks_changed(), 3);
        assert_eq!(c.changed_span_min(), Some((zb[0].end_min, zb[2].end_min)));
        let largest = zb.iter().map(|b| b.correction_mm.abs()).fold(0.0, f64::max);
        assert_eq!(c.max_correction_mm(), largest);
        assert_eq!(lines[6], "X5");
        let z3: f64 = lines[7].trim_start_matches("G90 G0 Z").parse().unwrap();
        assert!((z3 - (0.0 - zb[2].correction_mm)).abs() <= 0.5e-4);
    }

    #[test]
    fn correction_interpolates_across_heights() {
        // 10 µm/1000 rpm at z = −100, 30 µm at z = 0: at z = −50 the mean.
        let m = model(0.01, 0.03);
        let src = "S1000 M3\nG4 P600\nG0 Z-50\n";
        let c = compensate(&m, src.as_bytes(), &opts(CorrectionUpdate::Continuous)).unwrap();
        let t = c.z_blocks[0].end_min;
        let e = |g: f64| {
            let (a, b) = (first_order(g, 1000.0, 1), first_order(g, 1000.0, 2));
            a + (t - 10.0) / 10.0 * (b - a)
        };
        let want = 0.5 * (e(0.01) + e(0.03));
        assert!((c.z_blocks[0].correction_mm - want).abs() < 1e-12);
    }

    #[test]
    fn g53_left_alone_and_noted() {
        let m = model(0.01, 0.01);
        let src = "S4000 M3\nG4 P1200\nG53 G0 Z-5\nG0 Z-5\n";
        let c = compensate(&m, src.as_bytes(), &opts(CorrectionUpdate::Continuous)).unwrap();
        let out = text(&c);
        assert_eq!(out.lines().nth(2), Some("G53 G0 Z-5"));
        assert_ne!(out.lines().nth(3), Some("G0 Z-5"));
        assert!(c.z_blocks[0].g53 && !c.z_blocks[0].changed);
        assert!(c.notes.iter().any(|n| n.contains("G53") && n.contains('3')));
    }

    #[test]
    fn no_spindle_means_no_change() {
        let m = model(0.01, 0.01);
        let src = "G21 G90\r\nG0 Z10.000\nG1 Z-1.50 F100 (cut)\nM30";
        let c = compensate(&m, src.as_bytes(), &CompensateOptions::default()).unwrap();
        assert_eq!(c.output, src.as_bytes());
        assert!(!c.spindle_used && c.notes.len() == 1);
        assert_eq!(c.blocks_changed(), 0);
    }

    #[test]
    fn unsafe_blocks_and_interpreter_errors_name_the_line() {
        let m = model(0.01, 0.01);
        let run = |s: &str| compensate(&m, s.as_bytes(), &CompensateOptions::default());
        match run("S1000 M3\nG18 G0 X0 Z0\nG2 X10 Z0 I5 F100\n") {
            Err(CompensateError::Unsafe { line: 3, .. }) => {}
            other => panic!("{other:?}"),
        }
        let e = run("S1000 M3\nG0 X0 Z5\nG81 X1 Z-1 R1\n").unwrap_err();
        assert_eq!(
            match e {
                CompensateError::Gcode(g) => g.location().map(|l| l.line),
                _ => None,
            },
            Some(3)
        );
        let e = run("S1000 M3\nG1 Z-1\n").unwrap_err();
        assert!(
            matches!(&e, CompensateError::Gcode(g) if g.location().map(|l| l.line) == Some(2)),
            "{e}"
        );
    }

    #[test]
    fn fanuc_dwell_in_milliseconds_and_points_kept() {
        let m = model(0.01, 0.01);
        let o = CompensateOptions {
            dialect: Dialect::Fanuc {
                decimal_point_programming: false,
            },
            update: CorrectionUpdate::Continuous,
            ..CompensateOptions::default()
        };
        // P600000 ms = 10 min; Z-10. is −10 mm.
        let c = compensate(&m, b"S1000 M3\nG4 P600000\nG0 Z-10.\n", &o).unwrap();
        assert!((c.z_blocks[0].end_min - (10.0 + 10.0 / 10_000.0)).abs() < 1e-9);
        let out = text(&c);
        let z = out.lines().nth(2).unwrap();
        assert!(z.contains('.'), "{z}");
        let v: f64 = z.trim_start_matches("G0 Z").parse().unwrap();
        assert!((v - (-10.0 - c.z_blocks[0].correction_mm)).abs() <= 0.5e-4);
    }

    #[test]
    fn absurd_durations_are_refused() {
        let m = model(0.01, 0.01);
        let e = compensate(
            &m,
            b"S1 M3\nG1 X1000000 F0.000001\n",
            &CompensateOptions::default(),
        );
        assert!(matches!(e, Err(CompensateError::TooLong { .. })), "{e:?}");
    }

    proptest::proptest! {
        #[test]
        fn never_panics(bytes in proptest::collection::vec(proptest::prop_oneof![
            proptest::sample::select(b"GXYZSMPF0123456789.- \n".to_vec()),
            proptest::num::u8::ANY,
        ], 0..200)) {
            let m = model(0.01, 0.01);
            for update in [CorrectionUpdate::Continuous, CorrectionUpdate::Periodic { period_min: 10.0 }] {
                let _ = compensate(&m, &bytes, &opts(update));
            }
        }

        #[test]
        fn output_reparses_and_only_z_words_change(
            steps in proptest::collection::vec((0u32..3, -100.0f64..0.0, 1u32..900), 1..12),
            incremental in proptest::bool::ANY,
        ) {
            let m = model(0.01, 0.02);
            let mut src = String::from(if incremental { "S5000 M3\nG91\n" } else { "S5000 M3\n" });
            for (kind, z, dwell) in &steps {
                match kind {
                    0 => src.push_str(&format!("G4 P{dwell}\n")),
                    1 => src.push_str(&format!("G0 Z{z:.3}\n")),
                    _ => src.push_str(&format!("G1 X{dwell} Z{z:.3} F1000 (c)\n")),
                }
            }
            let c = compensate(&m, src.as_bytes(), &opts(CorrectionUpdate::Continuous)).unwrap();
            let out = String::from_utf8(c.output.clone()).unwrap();
            proptest::prop_assert!(crate::gcode::Program::parse(out.as_bytes()).is_ok());
            proptest::prop_assert_eq!(out.lines().count(), src.lines().count());
            for (a, b) in out.lines().zip(src.lines()) {
                let strip = |l: &str| l.split_whitespace().filter(|w| !w.starts_with('Z')).collect::<Vec<_>>().join(" ");
                proptest::prop_assert_eq!(strip(a), strip(b));
            }
        }
    }

    #[test]
    fn unstable_models_are_refused_and_divergent_drift_never_written() {
        // e(k) = 3 e(k−1) + …: a pole at 3.
        let h = |z: f64| HeightModel {
            z_mm: z,
            model: Arx::new(vec![1.0, -3.0], vec![(vec![0.002], 1)]).unwrap(),
            stats: None,
        };
        let inputs = vec![InputChannel::linear("speed_rpm", 1000.0)];
        let m = ThermalModel::new(10.0, inputs, vec![h(-100.0), h(0.0)]).unwrap();
        // Five hours of dwell at 2000 rpm, then a cut: 30 samples, 3^30 ≈ 2e14.
        let program = b"S2000 M3\nG0 Z0\nG4 P18000\nG1 Z-1 F100\nM5\n";
        match compensate(&m, program, &CompensateOptions::default()) {
            Err(CompensateError::Unstable { z_mm, reason }) => {
                assert_eq!(z_mm, -100.0);
                assert!(reason.contains("not stable"), "{reason}");
            }
            other => panic!("expected the unstable model refused, got {other:?}"),
        }
        let allow = CompensateOptions {
            allow_unstable: true,
            ..CompensateOptions::default()
        };
        match compensate(&m, program, &allow) {
            Err(CompensateError::Diverges { line, drift_mm }) => {
                assert_eq!(line, 4);
                assert!(drift_mm.abs() > crate::limits::MAX_ERROR_VALUE);
            }
            other => panic!("expected the divergent drift refused, got {other:?}"),
        }
        // A short program with the same model allowed stays finite and is written.
        let short = b"S2000 M3\nG0 Z0\nG4 P1200\nG1 Z-1 F100\nM5\n";
        assert!(compensate(&m, short, &allow).is_ok());
    }

    #[test]
    fn models_with_other_inputs_and_bad_options_are_refused() {
        let two = ThermalModel::new(
            10.0,
            ["speed_rpm", "ambient_c"]
                .map(|n| InputChannel::linear(n, 1.0))
                .to_vec(),
            vec![HeightModel {
                z_mm: 0.0,
                model: Arx::new(vec![1.0, -0.5], vec![(vec![1e-6], 1), (vec![1e-3], 1)]).unwrap(),
                stats: None,
            }],
        )
        .unwrap();
        match compensate(&two, b"S1000 M3\nG0 Z1\n", &CompensateOptions::default()) {
            Err(CompensateError::ModelInputs(names)) => {
                assert_eq!(names, ["speed_rpm", "ambient_c"])
            }
            other => panic!("{other:?}"),
        }
        let m = model(0.01, 0.01);
        let bad = CompensateOptions {
            rapid_feed: 0.0,
            ..CompensateOptions::default()
        };
        assert!(matches!(
            compensate(&m, b"", &bad),
            Err(CompensateError::Options(_))
        ));
        let bad = opts(CorrectionUpdate::Periodic { period_min: -1.0 });
        assert!(matches!(
            compensate(&m, b"", &bad),
            Err(CompensateError::Options(_))
        ));
    }
}

#[cfg(test)]
mod log_tests {
    //! [`compensate_log`]: drift of first-order channels in closed form.
    use super::*;
    use crate::methods::thermal::log::{
        Axis as LogAxis, ChannelModel, ChannelSpec, LengthUnit, LogInput,
    };
    use std::path::Path;

    /// Inputs: speed (scale 1000 rev/min), `t1_c` as its rise (scale 5 K);
    /// one first-order channel per `(column, axis, input, pole, b)`.
    fn model(channels: &[(&str, LogAxis, usize, f64, f64)]) -> LogModel {
        LogModel {
            period_min: 1.0,
            inputs: vec![
                LogInput {
                    column: "speed_rpm".into(),
                    rise: false,
                    square: false,
                    over: None,
                    scale: 1000.0,
                },
                LogInput {
                    column: "t1_c".into(),
                    rise: true,
                    square: false,
                    over: None,
                    scale: 5.0,
                },
            ],
            channels: channels
                .iter()
                .map(|&(column, axis, input, pole, b)| ChannelModel {
                    channel: ChannelSpec {
                        column: column.into(),
                        unit: LengthUnit::Um,
                        axis,
                    },
                    inputs: vec![input],
                    a: vec![1.0, -pole],
                    b: vec![vec![b]],
                    heldout_rms_mm: 0.0,
                    heldout_drift_rms_mm: 0.0,
                    training_rms_mm: 0.0,
                    output_error: false,
                    start_offset_mm: 0.0,
                    members: Vec::new(),
                })
                .collect(),
        }
    }

    /// X on the temperature (pole 0.8, 2 µm per scaled K), Z on the speed
    /// (pole 0.9, 1 µm per 1000 rev/min).
    fn xz() -> LogModel {
        model(&[
            ("dx_um", LogAxis::X, 1, 0.8, 0.002),
            ("dz_um", LogAxis::Z, 0, 0.9, 0.001),
        ])
    }

    /// `t1_c` 20 °C over the first minute, 25 °C after, every 15 s to `end` min.
    fn temperatures(end: f64) -> Table {
        let mut text = String::from("t_min,t1_c\n");
        let mut t = 0.0;
        while t <= end {
            text.push_str(&format!("{t},{}\n", if t < 1.0 { 20.0 } else { 25.0 }));
            t += 0.25;
        }
        Table::from_reader(Path::new("inputs.csv"), text.as_bytes()).unwrap()
    }

    /// Closed form of the period means (sample k, 1-min periods): X after
    /// the 5 K step in period 1 (scaled rise 1 from sample 1), Z under
    /// 2000 rev/min from t = 0 (scaled 2).
    fn x_sample(k: usize) -> f64 {
        // y_k = 0.8 y_{k−1} + 0.002 u_{k−1}, u_0 = 0, u_k = 1 after.
        if k <= 1 {
            0.0
        } else {
            0.002 * (1.0 - 0.8_f64.powi(k as i32 - 1)) / 0.2
        }
    }

    fn z_sample(k: usize) -> f64 {
        0.002 * (1.0 - 0.9_f64.powi(k as i32)) / 0.1
    }

    /// Sample means at the period centres, linear between them.
    fn at(sample: fn(usize) -> f64, t: f64) -> f64 {
        let pos = t - 0.5;
        if pos <= 0.0 {
            return sample(0);
        }
        let k = pos.floor() as usize;
        let f = pos - k as f64;
        sample(k) + f * (sample(k + 1) - sample(k))
    }

    fn word(line: &str, letter: char) -> f64 {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(letter))
            .unwrap()
            .parse()
            .unwrap()
    }

    fn opts(update: CorrectionUpdate) -> LogCompensateOptions {
        let mut o = LogCompensateOptions::default();
        o.compensate.update = update;
        o
    }

    const PROGRAM: &str = "G21 G90\nS2000 M3\nG4 P150\nG0 X10 Z-5\nG4 P300\nG1 X20 Z-10 F1000\nY5\nG4 P630\nG0 X0 Z0\nM30\n";

    #[test]
    fn x_and_z_words_are_the_programmed_minus_the_closed_form_drift() {
        let log = temperatures(29.75);
        for update in [
            CorrectionUpdate::Continuous,
            CorrectionUpdate::Periodic { period_min: 10.0 },
            CorrectionUpdate::Periodic { period_min: 4.0 },
        ] {
            let c = compensate_log(&xz(), PROGRAM.as_bytes(), Some(&log), &opts(update)).unwrap();
            let out = String::from_utf8(c.output.clone()).unwrap();
            let lines: Vec<&str> = out.lines().collect();
            // Lines 4, 6, 9 move X and Z; line 7 (Y) is not corrected.
            let programmed = [(4, 10.0, -5.0), (6, 20.0, -10.0), (9, 0.0, 0.0)];
            // Block ends: dwells, then the moves (rapid 10 m/min, feed 1 m/min).
            let ends = [
                2.5 + 125f64.sqrt() / 1e4,
                2.5 + 125f64.sqrt() / 1e4 + 5.0 + 125f64.sqrt() / 1e3,
                2.5 + 125f64.sqrt() / 1e4
                    + 5.0
                    + 125f64.sqrt() / 1e3
                    + 5.0 / 1e3
                    + 10.5
                    + 500f64.sqrt() / 1e4,
            ];
            assert_eq!(c.axis_blocks.len(), 6);
            for (k, &(line, x, z)) in programmed.iter().enumerate() {
                let xb = c.axis_blocks[2 * k];
                let zb = c.axis_blocks[2 * k + 1];
                assert_eq!((xb.line, xb.axis, zb.axis), (line, Axis::X, Axis::Z));
                assert!(
                    (xb.end_min - ends[k]).abs() < 1e-9,
                    "{} {}",
                    xb.end_min,
                    ends[k]
                );
                let t = match update {
                    CorrectionUpdate::Continuous => ends[k],
                    CorrectionUpdate::Periodic { period_min } => {
                        ((ends[k] / period_min).floor() + 0.5) * period_min
                    }
                };
                let (ex, ez) = (at(x_sample, t), at(z_sample, t));
                assert!(ex > 1e-4 || k == 0, "{ex}");
                let text = lines[line as usize - 1];
                let tol = 0.5e-4 + 1e-12;
                if ex.abs() >= 0.5e-4 {
                    assert!(
                        (word(text, 'X') - (x - ex)).abs() <= tol,
                        "{update:?} {text} {ex}"
                    );
                } else {
                    assert_eq!(word(text, 'X'), x);
                }
                assert!(
                    (word(text, 'Z') - (z - ez)).abs() <= tol,
                    "{update:?} {text} {ez}"
                );
                assert!((xb.correction_mm - ex).abs() < 1e-12 || ex.abs() < 0.5e-4);
                assert!((zb.correction_mm - ez).abs() < 1e-12);
            }
            assert_eq!(lines[6], "Y5");
            assert_eq!(c.z_blocks.len(), 3);
            let x = c.axis_summary(Axis::X);
            assert_eq!((x.blocks, c.axis_summary(Axis::Y).blocks), (3, 0));
            assert!(c.notes.is_empty(), "{:?}", c.notes);
        }
    }

    #[test]
    fn a_zero_model_leaves_the_program_byte_identical() {
        let zero = model(&[
            ("dx_um", LogAxis::X, 1, 0.8, 0.0),
            ("dy_um", LogAxis::Y, 0, 0.5, 0.0),
            ("dz_um", LogAxis::Z, 0, 0.9, 0.0),
        ]);
        let src = "%\n(part)\nG21 G90 G17\r\nS3000 M3\nG0 X10.000 Y-3 Z5\nG1 Z-1.5 F200\nG2 X20 Y-3 I5 J0\nG91 G1 X1 Y1 Z-0.1\nG90 G53 G0 Z0\nG4 P900\nG0 X0.0 Y0.0\nM30\n%\n";
        let c = compensate_log(
            &zero,
            src.as_bytes(),
            Some(&temperatures(20.0)),
            &opts(CorrectionUpdate::Continuous),
        )
        .unwrap();
        assert_eq!(c.output, src.as_bytes());
        assert_eq!(c.lines_changed(), 0);
        assert!(c.axis_blocks.iter().any(|b| b.axis == Axis::Y));
    }

    /// Every arc event of `program`: (start, end, centre) in X and Y.
    fn arcs(program: &str) -> Vec<([f64; 2], [f64; 2], [f64; 2])> {
        let prog = crate::gcode::Program::parse(program.as_bytes()).unwrap();
        let mut interp = Interpreter::new(InterpOptions::default());
        let mut events = Vec::new();
        for b in &prog.blocks {
            interp.execute(b, &mut events).unwrap();
        }
        events
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Arc(a) => Some((
                    [a.from[Axis::X], a.from[Axis::Y]],
                    [a.to[Axis::X], a.to[Axis::Y]],
                    [a.center[0], a.center[1]],
                )),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn xy_arcs_move_rigidly_by_the_correction_at_their_start() {
        // X on the temperature, Y on the speed: both drift during the dwells.
        let m = model(&[
            ("dx_um", LogAxis::X, 1, 0.8, 0.002),
            ("dy_um", LogAxis::Y, 0, 0.9, 0.001),
        ]);
        for src in [
            "S2000 M3\nG0 X0 Y0\nG4 P600\nG1 X10 Y0 F500\nG4 P300\nG2 X20 Y0 I5 J0\nG4 P300\nG3 X10 Y0 R5\nG1 X0\n",
            "S2000 M3\nG0 X0 Y0\nG4 P600\nG91 G1 X10 F500\nG4 P300\nG2 X10 I5 J0\nG4 P300\nG3 X-10 R5\nG1 X-10\n",
        ] {
            let c = compensate_log(
                &m,
                src.as_bytes(),
                Some(&temperatures(40.0)),
                &opts(CorrectionUpdate::Continuous),
            )
            .unwrap();
            let out = String::from_utf8(c.output.clone()).unwrap();
            let before = arcs(src);
            let after = arcs(&out);
            assert_eq!(after.len(), 2);
            // The correction in force at the start of each arc (line 4's).
            let x4 = c
                .axis_blocks
                .iter()
                .find(|b| b.line == 4 && b.axis == Axis::X)
                .unwrap();
            let y4 = c
                .axis_blocks
                .iter()
                .find(|b| b.line == 4 && b.axis == Axis::Y)
                .map_or(0.0, |b| b.correction_mm);
            assert!(x4.correction_mm > 1e-3, "{x4:?}");
            for ((s0, e0, c0), (s1, e1, c1)) in before.iter().zip(&after) {
                let r = |p: &[f64; 2], c: &[f64; 2]| (p[0] - c[0]).hypot(p[1] - c[1]);
                // The same radius at both ends (to the written resolution).
                assert!(
                    (r(s1, c1) - r(e1, c1)).abs() < 1.5e-4,
                    "{s1:?} {e1:?} {c1:?}"
                );
                for (p0, p1) in [(s0, s1), (e0, e1), (c0, c1)] {
                    assert!(
                        (p1[0] - (p0[0] - x4.correction_mm)).abs() <= 0.6e-4,
                        "{p0:?} {p1:?}"
                    );
                    assert!((p1[1] - (p0[1] - y4)).abs() <= 0.6e-4);
                }
            }
            // The next straight move takes the correction of its own time.
            let last = c
                .axis_blocks
                .iter()
                .rev()
                .find(|b| b.axis == Axis::X)
                .unwrap();
            assert!(last.correction_mm > x4.correction_mm);
            assert!(last.changed);
        }
    }

    #[test]
    fn channels_on_one_axis_missing_inputs_and_unsafe_arcs_are_refused() {
        let two_z = model(&[
            ("a_um", LogAxis::Z, 0, 0.9, 0.001),
            ("b_um", LogAxis::Z, 0, 0.5, 0.001),
        ]);
        let prog = b"S1000 M3\nG4 P600\nG0 Z-1\n";
        match compensate_log(&two_z, prog, None, &LogCompensateOptions::default()) {
            Err(CompensateError::Channels(m)) => {
                assert!(m.contains("`a_um` and `b_um` both act on Z"), "{m}")
            }
            other => panic!("{other:?}"),
        }
        let mut o = LogCompensateOptions {
            channels: vec!["b_um".into()],
            ..LogCompensateOptions::default()
        };
        let c = compensate_log(&two_z, prog, None, &o).unwrap();
        // Pole 0.5, 1 µm per scaled unit, speed 1 (scaled): at the block's
        // end (10 min + 1 mm at 10 m/min), held at 15 min: the means of samples 14 and 15.
        let t = ((c.z_blocks[0].end_min / 10.0).floor() + 0.5) * 10.0;
        let y = |k: i32| 0.002 * (1.0 - 0.5_f64.powi(k));
        assert_eq!(t, 15.0);
        assert!((c.z_blocks[0].correction_mm - 0.5 * (y(14) + y(15))).abs() < 1e-12);
        o.channels = vec!["c_um".into()];
        assert!(
            matches!(compensate_log(&two_z, prog, None, &o), Err(CompensateError::Channels(m)) if m.contains("no channel `c_um`"))
        );
        o.channels = vec!["a_um".into(), "b_um".into()];
        assert!(matches!(
            compensate_log(&two_z, prog, None, &o),
            Err(CompensateError::Channels(_))
        ));

        match compensate_log(&xz(), prog, None, &LogCompensateOptions::default()) {
            Err(e @ CompensateError::MissingInputs { .. }) => {
                let m = e.to_string();
                assert!(
                    m.contains("dx_um") && m.contains("t1_c") && !m.contains("dz_um"),
                    "{m}"
                );
            }
            other => panic!("{other:?}"),
        }
        // Only the Z channel (speed): no inputs log needed.
        let z_only = LogCompensateOptions {
            channels: vec!["dz_um".into()],
            ..LogCompensateOptions::default()
        };
        assert!(compensate_log(&xz(), prog, None, &z_only).is_ok());

        let log = temperatures(29.75);
        let run = |s: &str| {
            compensate_log(
                &xz(),
                s.as_bytes(),
                Some(&log),
                &LogCompensateOptions::default(),
            )
        };
        match run("S1000 M3\nG18 G0 X0 Z0\nG2 X10 Z0 I5 F100\n") {
            Err(CompensateError::Unsafe { line: 3, reason }) => assert!(
                reason.contains("an X word of an arc in the ZX plane"),
                "{reason}"
            ),
            other => panic!("{other:?}"),
        }
        // Polar words move X and Y with no X or Y word to correct.
        match run("S1000 M3\nG21 G0 X10 Y0 Z5\nG1 @5 ^90 F100\n") {
            Err(CompensateError::Unsafe { line: 3, reason }) => {
                assert!(reason.contains("polar"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
        // A G90.1 arc that would move is refused.
        let abs = "S1000 M3\nG90.1 G0 X0 Y0\nG4 P600\nG1 X10 F100\nG2 X20 Y0 I15 J0\n";
        assert!(matches!(
            run(abs),
            Err(CompensateError::Unsafe { line: 5, .. })
        ));
        // A bad inputs log at its line.
        let bad = Table::from_reader(
            Path::new("inputs.csv"),
            b"t_min,t1_c\n0,20\n1,x\n".as_slice(),
        )
        .unwrap();
        match compensate_log(&xz(), prog, Some(&bad), &LogCompensateOptions::default()) {
            Err(CompensateError::InputsLog(d)) => {
                assert!(d.to_string().contains("inputs.csv:3"), "{d}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_channel_with_members_corrects_by_their_median_and_needs_their_inputs() {
        use crate::methods::thermal::log::ChannelMember;
        let member = |inputs: Vec<usize>, pole: f64, b: f64| ChannelMember {
            folds: 2,
            inputs,
            a: vec![1.0, -pole],
            b: vec![vec![b]],
            heldout_rms_mm: 0.0,
            training_rms_mm: 0.0,
            output_error: false,
            start_offset_mm: 0.0,
        };
        let prog = b"S1000 M3\nG4 P600\nG0 Z-1\n";
        let z_only = LogCompensateOptions {
            channels: vec!["dz_um".into()],
            ..LogCompensateOptions::default()
        };
        // Z on the speed with gains 1, 3 and 2 µm per scaled unit, one
        // pole: the correction is the model's with 2 µm, the median.
        let mut three = xz();
        three.channels[1].members = vec![member(vec![0], 0.9, 0.003), member(vec![0], 0.9, 0.002)];
        let mut two = xz();
        two.channels[1].b = vec![vec![0.002]];
        let got = compensate_log(&three, prog, None, &z_only).unwrap();
        let want = compensate_log(&two, prog, None, &z_only).unwrap();
        assert!(want.z_blocks[0].correction_mm.abs() > 1e-4);
        assert!((got.z_blocks[0].correction_mm - want.z_blocks[0].correction_mm).abs() < 1e-15);
        // A member on the temperature makes the Z channel need the inputs log.
        let mut needs = xz();
        needs.channels[1].members = vec![member(vec![1], 0.9, 0.001)];
        match compensate_log(&needs, prog, None, &z_only) {
            Err(e @ CompensateError::MissingInputs { .. }) => {
                let m = e.to_string();
                assert!(m.contains("dz_um") && m.contains("t1_c"), "{m}");
            }
            other => panic!("{other:?}"),
        }
        assert!(compensate_log(&needs, prog, Some(&temperatures(20.0)), &z_only).is_ok());
        // An unstable member is refused as an unstable model is.
        let mut unstable = xz();
        unstable.channels[1].members = vec![member(vec![0], 1.2, 0.001)];
        assert!(matches!(
            compensate_log(&unstable, prog, None, &z_only),
            Err(CompensateError::UnstableChannel { column, .. }) if column == "dz_um"
        ));
    }

    #[test]
    fn a_short_inputs_log_holds_its_last_period_mean() {
        // The log ends at 3.75 min (4 periods: 20, 25, 25, 25 °C); the
        // program runs 20 min. Held: the rise stays 5 K, so the X drift is
        // the closed form of the constant step at every time.
        let c = compensate_log(
            &xz(),
            b"S2000 M3\nG4 P1200\nG0 X1\n",
            Some(&temperatures(3.75)),
            &opts(CorrectionUpdate::Continuous),
        )
        .unwrap();
        let b = c.axis_blocks[0];
        assert!((b.correction_mm - at(x_sample, b.end_min)).abs() < 1e-12);
        assert!(
            c.notes
                .iter()
                .any(|n| n.contains("covers 4 min") && n.contains("held")),
            "{:?}",
            c.notes
        );
    }
}
