//! Pre-compensation of an NC program for thermal drift (the compensation of
//! `docs/references.md` \[R4\]: the program rewritten before machining).
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
//!    (k+1)T)` of the model is the model input of that sample.
//! 3. The drift `e(t, z)` is predicted at every measured height on the sample
//!    grid, linear in time between samples and interpolated across heights
//!    ([`ThermalModel::interpolate`]); `z` is the machine Z of the block's
//!    target (work Z + work offset + tool length offset), mm.
//! 4. Z targets are moved to `Z − c`, `c = e(t_c, Z)` the correction:
//!    * continuous update: `t_c` is the time the block ends;
//!    * periodic update (period `P`, the source paper \[R4\]: 10 min): the correction is
//!      held over `[kP, (k+1)P)` and `t_c = (k + ½)·P`, the middle of the
//!      interval (the whole program is known ahead, so the held value is the
//!      one closest to the drift over the interval).
//!
//! Rewriting rules:
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
//! * a block the rewriter cannot change safely is an error naming the line:
//!   Z words of arcs in the ZX or YZ plane (the arc geometry would change),
//!   several moves in one block; canned cycles and everything else outside
//!   the interpreter's subset are already errors of the interpreter.
//!
//! A program that never turns the spindle on is returned unchanged, with a
//! note.

use crate::gcode::{
    Axis, Block, Dialect, DistanceMode, Event, EventKind, GcodeError, InterpOptions, Interpreter,
    NumberFormat, Plane, ProgramStats, Programmed, SpindleState, StatsOptions,
};

use super::model::ThermalModel;
use super::predict::Programme;

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

/// Result of [`compensate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Compensation {
    /// The compensated program text.
    pub output: Vec<u8>,
    /// Every block with a Z word, in order.
    pub z_blocks: Vec<ZBlock>,
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

/// A move with a Z word found in the first pass.
#[derive(Debug, Clone, Copy)]
struct ZMove {
    block: usize,
    end_min: f64,
    from_z: f64,
    to_z: f64,
    offset_z: f64,
    words: Programmed,
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
    let stats_opts = StatsOptions {
        interp: InterpOptions {
            dialect: options.dialect,
            program: options.program.clone(),
            tools: options.tools.clone(),
            skip_deleted_blocks: options.skip_deleted_blocks,
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
        if has_z_word(block)? {
            moves.push(z_move(block, index, &events, stats.total_time() / 60.0)?);
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
    let period = model.period_min();
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
        z_blocks: Vec::with_capacity(moves.len()),
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
    if !spindle_used {
        result.output = program.to_vec();
        result.notes.push(
            "the program never turns the spindle on (S with M3/M4): no drift, no change".into(),
        );
        result.z_blocks = moves
            .iter()
            .map(|m| ZBlock {
                line: prog.blocks[m.block].line(),
                end_min: m.end_min,
                machine_z_mm: m.to_z + m.offset_z,
                correction_mm: 0.0,
                g53: m.words.g53,
                changed: false,
            })
            .collect();
        return Ok(result);
    }

    // Pass 2: corrections and edits.
    let history = model.drift_history(&result.programme);
    let drift = |t_min: f64, z: f64| -> f64 {
        let pos = (t_min / period).max(0.0);
        let k = (pos.floor() as usize).min(history.len() - 2);
        let frac = (pos - k as f64).min(1.0);
        let values: Vec<f64> = history[k]
            .iter()
            .zip(&history[k + 1])
            .map(|(a, b)| a + frac * (b - a))
            .collect();
        model.interpolate(&values, z).mm
    };
    let mut applied = 0.0;
    let mut g53_lines = Vec::new();
    for m in &moves {
        let block = &mut prog.blocks[m.block];
        let machine_z = m.to_z + m.offset_z;
        let mut record = ZBlock {
            line: block.line(),
            end_min: m.end_min,
            machine_z_mm: machine_z,
            correction_mm: 0.0,
            g53: m.words.g53,
            changed: false,
        };
        if m.words.g53 {
            g53_lines.push(block.line());
            record.correction_mm = applied;
            result.z_blocks.push(record);
            continue;
        }
        let t_c = match options.update {
            CorrectionUpdate::Continuous => m.end_min,
            CorrectionUpdate::Periodic { period_min } => {
                ((m.end_min / period_min).floor() + 0.5) * period_min
            }
        };
        let c = drift(t_c, machine_z);
        if !(c.is_finite() && c.abs() <= crate::limits::MAX_ERROR_VALUE) {
            return Err(CompensateError::Diverges {
                line: block.line(),
                drift_mm: c,
            });
        }
        let new_end = match m.words.distance {
            DistanceMode::Absolute if c.abs() >= WRITE_TOLERANCE_MM => {
                applied = c;
                Some(m.to_z - c)
            }
            DistanceMode::Absolute => {
                applied = 0.0;
                None
            }
            DistanceMode::Incremental if (c - applied).abs() >= WRITE_TOLERANCE_MM => {
                let end = m.to_z - (c - applied);
                applied = c;
                Some(end)
            }
            DistanceMode::Incremental => None,
        };
        if let Some(end) = new_end {
            let mut from = crate::gcode::Axes::default();
            from[Axis::Z] = m.from_z;
            let mut offset = crate::gcode::Axes::default();
            offset[Axis::Z] = m.offset_z;
            let value = m.words.word_value(Axis::Z, &from, end, &offset);
            write_z(block, value, options.dialect, m.words)?;
            record.changed = true;
        }
        record.correction_mm = applied;
        result.z_blocks.push(record);
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
    result.output = prog.to_bytes();
    result.output.extend_from_slice(trailer);
    Ok(result)
}

fn has_z_word(block: &Block) -> Result<bool, GcodeError> {
    Ok(block.word('Z')?.is_some())
}

/// The Z move of a block that has a Z word.
fn z_move(
    block: &Block,
    index: usize,
    events: &[Event],
    end_min: f64,
) -> Result<ZMove, CompensateError> {
    let unsafe_block = |reason: &str| CompensateError::Unsafe {
        line: block.line(),
        reason: reason.into(),
    };
    let mut found = None;
    for e in events {
        let m = match &e.kind {
            EventKind::Traverse(l) | EventKind::Feed(l) => {
                (l.from[Axis::Z], l.to[Axis::Z], l.offset[Axis::Z], l.words)
            }
            EventKind::Arc(a) => {
                if a.plane != Plane::Xy {
                    return Err(unsafe_block(
                        "a Z word of an arc in the ZX or YZ plane (changing it changes the arc)",
                    ));
                }
                (a.from[Axis::Z], a.to[Axis::Z], a.offset[Axis::Z], a.words)
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
    let Some((from_z, to_z, offset_z, words)) = found else {
        return Err(unsafe_block("a Z word that is not a move target"));
    };
    if !words.axes.contains(Axis::Z) {
        return Err(unsafe_block("a Z word that is not a move target"));
    }
    Ok(ZMove {
        block: index,
        end_min,
        from_z,
        to_z,
        offset_z,
        words,
    })
}

/// Writes the Z word value (program units); a Fanuc program without decimal
/// point programming gets a decimal point, or least increments when the value
/// is whole.
fn write_z(
    block: &mut Block,
    value: f64,
    dialect: Dialect,
    words: Programmed,
) -> Result<(), GcodeError> {
    block.set_word('Z', value)?;
    let needs_point = matches!(
        dialect,
        Dialect::Fanuc {
            decimal_point_programming: false
        }
    );
    let has_point = block.word('Z')?.is_some_and(|w| w.has_point);
    if needs_point && !has_point {
        let increment = match words.units {
            crate::gcode::Units::Millimetre => 1e-3,
            crate::gcode::Units::Inch => 1e-4,
        };
        block.set_word_with('Z', (value / increment).round(), NumberFormat::Fixed(0))?;
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
        use crate::model::{Axis as MAxis, AxisKind, Machine};
        let axes = [("X", 0), ("Y", 1), ("Z", 2)]
            .map(|(name, i)| {
                let mut d = [0.0; 3];
                d[i] = 1.0;
                let mut a = MAxis::new(name, AxisKind::Linear, d, [0.0; 3], [-1e4, 1e4]);
                a.max_velocity = Some(5.0);
                a.max_acceleration = Some(50.0);
                a.max_jerk = Some(1000.0);
                a
            })
            .to_vec();
        Machine {
            name: "slow".into(),
            axes,
            tool_chain: vec![0, 1, 2],
            workpiece_chain: vec![],
            tool_tip: nalgebra::Vector3::zeros(),
            tool_direction: nalgebra::Vector3::z(),
            workpiece_origin: nalgebra::Vector3::zeros(),
            rapid_feed: 6000.0,
        }
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
