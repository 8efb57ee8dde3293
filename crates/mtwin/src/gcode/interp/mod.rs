//! The modal interpreter: blocks in, canonical [`Event`]s out, following
//! LinuxCNC's RS-274/NGC reading for the part of the language it supports.
//!
//! [`Interpreter::execute`] reads and checks a block (every word's value,
//! one code per modal group, no word that nothing reads), then runs one
//! step per kind of code in LinuxCNC's order of execution (its
//! `execute_block`, `convert_m` and `convert_g`): feed mode, feed rate,
//! spindle speed, tool select, tool change, spindle direction, TCP
//! M-codes, dwell, plane, length units, cutter compensation, tool length
//! offset, coordinate system, path control, distance mode, arc distance
//! mode, retract mode, the non-modal codes (G10, G28, G30, G52, G92),
//! G92.1/G92.2/G92.3, motion (canned cycles included), and last the stops
//! (M0, M1, M2, M30, M60).
//!
//! Expressions and parameters are evaluated ([`Parameters`]); a line's
//! assignments take effect after the whole line is read, before its codes
//! run. O-word lines are program flow, run by
//! [`run_program`](super::program_flow::run_program), not here. Anything
//! else outside the supported language (lathe cycles G70–G72,
//! splines, ...) is an
//! [`GcodeError::Unsupported`] error naming the line: never skipped.
//!
//! **Where things are.** This file: the interpreter's state and options,
//! [`Interpreter::execute`] and the order of its steps. `check.rs`: a
//! block's codes and words read and checked; `modal_steps.rs`: the steps
//! that set modal state (feed, speed, tools, plane, units, offsets, distance
//! modes, …); `non_modal.rs`: G10, G28/G30, G52 and the G92 family;
//! `canned_cycles.rs`: G73, G74, G81 … G89; `motion.rs`: G53, moves, arcs,
//! probes, spindle-synchronised moves, G76 and the stops;
//! `cutter_radius.rs`: G40/G41/G42 (the offset path itself is
//! [`cutter_comp`](super::cutter_comp)).
//!
//! The short steps carry `#[inline]`: they live in other modules (so in
//! other code units) than `run`, which calls each once per block, and
//! without the hint the split into files made `gcode stats` about 5 %
//! slower (BENCHMARKS.md, "The interpreter split into files").

use super::arc::{self, ArcError};
use super::axes::{Axes, Axis, AxisMask};
use super::codes::{GCode, ModalGroup};
use super::cutter_comp::{self, CutterComp, MoveInfo, Side};
use super::dialect::{Dialect, DwellWord};
use super::error::GcodeError;
use super::event::{
    ArcMove, DistanceMode, Event, EventKind, Feed, FeedMode, Linear, PathMode, Plane, Programmed,
    SourcePos, SpindleState, TaskWait, Units,
};
use super::expr::{self, Target};
use super::lathe_diameter_mode;
use super::parameters::{Parameters, is_state_parameter};
use super::program_flow::ProgramOptions;
use super::syntax::{Block, Item, Value, Word};
use super::threading_cycle;
use super::tool_table::ToolTable;

mod canned_cycles;
mod check;
mod cutter_radius;
mod modal_steps;
mod motion;
mod non_modal;
#[cfg(test)]
mod tests;

/// What unknown M-codes do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UnknownMCode {
    /// Stop with an unsupported-code error (default: nothing silent).
    #[default]
    Reject,
    /// Ignore them (user M-codes without a motion meaning).
    Ignore,
}

/// Interpreter settings given by the caller. Build it from
/// [`InterpOptions::default`] and change the fields you need
/// (`InterpOptions { dialect, ..InterpOptions::default() }` inside this
/// crate; field assignment on a default value outside it).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct InterpOptions {
    /// Controller dialect.
    pub dialect: Dialect,
    /// Offsets of G54, G55, G56, G57, G58, G59, G59.1, G59.2, G59.3
    /// (machine coordinates of the work origin), mm and degree.
    pub work_offsets: [Axes; 9],
    /// Rotations about Z of the XY plane of G54 … G59.3 (G10 L2 R;
    /// LinuxCNC's parameters 5230, 5250, …, 5390), degrees,
    /// counter-clockwise seen from +Z.
    pub work_rotations: [f64; 9],
    /// Tool table (LinuxCNC's `.tbl`, [`ToolTable::parse`]) for T, M6,
    /// G43, G43.2, G43.4 and G10 L1/L10/L11 (which change the
    /// interpreter's copy).
    pub tools: ToolTable,
    /// M-code that turns tool centre point control on (LinuxCNC remap in the
    /// corpus: M428); `None` for no such code.
    pub tcp_on_m: Option<u32>,
    /// M-code that turns it off (corpus: M429).
    pub tcp_off_m: Option<u32>,
    /// TCP on from the start (a program written for TCP).
    pub tcp_at_start: bool,
    /// Rotary axes with rollover (LinuxCNC `WRAPPED_ROTARY`): absolute
    /// positions in (−360, 360) whose sign gives the direction of travel.
    pub wrapped_rotary: AxisMask,
    /// Skip blocks starting with `/` (LinuxCNC's default switch setting).
    pub skip_deleted_blocks: bool,
    /// Units at program start.
    pub initial_units: Units,
    /// Machine position at program start (mm, degree).
    pub initial_machine_position: Axes,
    /// What to do with M-codes this interpreter does not know.
    pub unknown_m: UnknownMCode,
    /// Parameters at start (var file), subroutine search path, bounds.
    pub program: ProgramOptions,
    /// The axes the machine has (LinuxCNC's `[TRAJ] COORDINATES`): a word
    /// of another axis letter is refused wherever it stands, as LinuxCNC's
    /// reader refuses the letter of an axis its configuration lacks ("Bad
    /// character 'w' used"). All nine by default.
    pub machine_axes: AxisMask,
}

impl Default for InterpOptions {
    fn default() -> Self {
        InterpOptions {
            dialect: Dialect::LinuxCnc,
            work_offsets: [Axes::ZERO; 9],
            work_rotations: [0.0; 9],
            tools: ToolTable::new(),
            tcp_on_m: Some(428),
            tcp_off_m: Some(429),
            tcp_at_start: false,
            wrapped_rotary: AxisMask::EMPTY,
            skip_deleted_blocks: true,
            initial_units: Units::Millimetre,
            initial_machine_position: Axes::ZERO,
            unknown_m: UnknownMCode::Reject,
            program: ProgramOptions::default(),
            machine_axes: AxisMask::ALL,
        }
    }
}

/// Active motion mode (modal group 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MotionMode {
    /// G0.
    Rapid,
    /// G1 (and the probing moves).
    Linear,
    /// G2.
    ArcClockwise,
    /// G3.
    ArcCounterClockwise,
    /// A canned cycle: G73, G74, G81 ... G89.
    Cycle(GCode),
    /// G33: spindle-synchronised straight motion (K per revolution).
    SpindleSync,
    /// G33.1: rigid tapping (to the end at K per revolution and back).
    RigidTap,
    /// G76: the threading cycle (passes synchronised to the spindle).
    Threading,
}

/// Where a canned cycle retracts to at the end of each repeat. The
/// program starts in G99 in the LinuxCNC dialect (as LinuxCNC's
/// interpreter), in G98 in the Fanuc one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RetractMode {
    /// G98: the level the tool was at before the cycle (if above R).
    InitialLevel,
    /// G99: the R level.
    RLevel,
}

/// The modal state between blocks.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalState {
    /// G20/G21.
    pub units: Units,
    /// G90/G91.
    pub distance: DistanceMode,
    /// G90.1/G91.1 (arc centres absolute / incremental).
    pub arc_distance: DistanceMode,
    /// G93/G94/G95.
    pub feed_mode: FeedMode,
    /// G17/G18/G19.
    pub plane: Plane,
    /// G0..G3, G33, G33.1 or a canned cycle, `None` after G80 and at start.
    pub motion: Option<MotionMode>,
    /// Feed rate, canonical (mm/min, 1/min or mm/rev).
    pub feed: f64,
    /// Spindle speed, rev/min.
    pub spindle_rpm: f64,
    /// Spindle direction.
    pub spindle: SpindleState,
    /// Selected coordinate system, 1..=9 (G54 = 1).
    pub work_system: u8,
    /// Tool length offset in force, mm.
    pub tool_length: f64,
    /// Tool in the spindle (after M6).
    pub tool: u32,
    /// Tool selected by T.
    pub selected_tool: u32,
    /// TCP on.
    pub tcp: bool,
    /// Current position in work coordinates, mm/deg.
    pub position: Axes,
    /// Work offset plus G92 offset plus tool offset: machine = position +
    /// offset, the position's X Y rotated first by `rotation` (and the
    /// G92 offset in the offset rotated too: LinuxCNC's machine point is
    /// R·(position + G92) + work offset + tool offset).
    pub offset: Axes,
    /// Offsets of G54 ... G59.3 in force: the options' ones as changed by
    /// G10 L2/L20 (parameters 5221 ... 5389), mm/deg.
    pub work_offsets: [Axes; 9],
    /// Rotations about Z of G54 ... G59.3 (G10 L2 R), degrees.
    pub work_rotations: [f64; 9],
    /// Rotation about Z of the selected system in force, degrees.
    pub rotation: f64,
    /// G92 axis offsets in force, mm/deg.
    pub axis_offset: Axes,
    /// The G92 offsets kept for G92.3 (parameters 5211–5219), mm/deg.
    pub g92_saved: Axes,
    /// Whether the G92 offsets are applied (parameter 5210).
    pub g92_applied: bool,
    /// G28 home position, machine coordinates (parameters 5161–5169), mm/deg.
    pub g28_home: Axes,
    /// G30 home position, machine coordinates (parameters 5181–5189), mm/deg.
    pub g30_home: Axes,
    /// Tool offset in force (G43, G43.1, G43.2), every axis, mm/deg;
    /// `tool_length` is its Z.
    pub tool_offset: Axes,
    /// G98/G99.
    pub retract: RetractMode,
    /// Lathe diameter mode (G7; `false`: radius mode, G8): X words are
    /// read as diameters. Positions stay radii.
    pub lathe_diameter: bool,
}

/// M-codes accepted without a motion meaning.
#[inline]
fn m_ignored(code: u32) -> bool {
    matches!(code, 0 | 1 | 7 | 8 | 9 | 19 | 48..=53 | 60 | 62..=68 | 70..=73)
}

#[derive(Debug, Clone, Copy, Default)]
struct Letter {
    value: f64,
    has_point: bool,
    column: usize,
}

/// Words of one block, sorted by letter.
#[derive(Debug, Default)]
struct BlockWords {
    g: Vec<(GCode, usize)>,
    m: Vec<(u32, usize)>,
    /// Bit [`letter_slot`]`(l)` set: the block has letter `l` (`letters`
    /// holds its word). Clearing the bits empties the table: the entries of
    /// letters not present are stale and never read.
    present: u32,
    letters: [Letter; 28],
}

/// Where a word letter (`A`–`Z`, `@`, `^`) is filed in [`BlockWords`].
#[inline]
fn letter_slot(l: u8) -> usize {
    match l {
        b'@' => 26,
        b'^' => 27,
        _ => usize::from(l - b'A'),
    }
}

impl BlockWords {
    #[inline]
    fn get(&self, l: u8) -> Option<&Letter> {
        let i = letter_slot(l);
        (self.present & (1 << i) != 0).then(|| &self.letters[i])
    }

    /// Whether the block has a polar coordinate word (`@` or `^`).
    #[inline]
    fn polar(&self) -> bool {
        self.get(b'@').is_some() || self.get(b'^').is_some()
    }

    #[inline]
    fn has_m(&self, codes: &[u32]) -> bool {
        self.m.iter().any(|(c, _)| codes.contains(c))
    }
}

/// A code and the 1-based column of its word.
type At<T> = (T, usize);

/// The codes of one block, one per modal group, after reading and checking.
#[derive(Debug, Default, Clone, Copy)]
struct Codes {
    non_modal: Option<At<GCode>>,
    motion: Option<At<GCode>>,
    plane: Option<At<GCode>>,
    distance: Option<At<GCode>>,
    arc_distance: Option<At<GCode>>,
    feed_mode: Option<At<GCode>>,
    units: Option<At<GCode>>,
    cutter_comp: Option<At<GCode>>,
    tool_length: Option<At<GCode>>,
    retract: Option<At<GCode>>,
    coord_system: Option<At<GCode>>,
    path_control: Option<At<GCode>>,
    spindle_mode: Option<At<GCode>>,
    lathe_diameter: Option<At<GCode>>,
    g92_applied: Option<At<GCode>>,
    cycle_cancel: Option<At<GCode>>,
    /// M0, M1, M2, M30, M60.
    m_stop: Option<At<u32>>,
    /// M3, M4, M5.
    m_spindle: Option<At<u32>>,
    /// The configured TCP on/off M-codes.
    m_tcp: Option<At<u32>>,
    /// M6 (tool change) or M61 (set the tool number), one modal group.
    m_tool_change: Option<At<u32>>,
}

impl Codes {
    #[inline]
    fn slot(&mut self, group: ModalGroup) -> &mut Option<At<GCode>> {
        match group {
            ModalGroup::NonModal => &mut self.non_modal,
            ModalGroup::Motion => &mut self.motion,
            ModalGroup::Plane => &mut self.plane,
            ModalGroup::Distance => &mut self.distance,
            ModalGroup::ArcDistance => &mut self.arc_distance,
            ModalGroup::FeedMode => &mut self.feed_mode,
            ModalGroup::Units => &mut self.units,
            ModalGroup::CutterComp => &mut self.cutter_comp,
            ModalGroup::ToolLength => &mut self.tool_length,
            ModalGroup::Retract => &mut self.retract,
            ModalGroup::CoordSystem => &mut self.coord_system,
            ModalGroup::PathControl => &mut self.path_control,
            ModalGroup::SpindleMode => &mut self.spindle_mode,
            ModalGroup::LatheDiameter => &mut self.lathe_diameter,
            ModalGroup::G92Applied => &mut self.g92_applied,
            ModalGroup::CycleCancel => &mut self.cycle_cancel,
        }
    }

    /// Whether the block has `code`: a code stands in the slot of its
    /// modal group, which is the same in every dialect except for G80
    /// (motion in LinuxCNC, its own group in Fanuc's), so only that slot
    /// (or G80's two) is looked at.
    #[inline]
    fn has(&self, code: GCode) -> bool {
        let is = |s: &Option<At<GCode>>| s.is_some_and(|(c, _)| c == code);
        if code == GCode::G80 {
            return is(&self.motion) || is(&self.cycle_cancel);
        }
        let slot = match code.group(Dialect::LinuxCnc) {
            ModalGroup::NonModal => &self.non_modal,
            ModalGroup::Motion => &self.motion,
            ModalGroup::Plane => &self.plane,
            ModalGroup::Distance => &self.distance,
            ModalGroup::ArcDistance => &self.arc_distance,
            ModalGroup::FeedMode => &self.feed_mode,
            ModalGroup::Units => &self.units,
            ModalGroup::CutterComp => &self.cutter_comp,
            ModalGroup::ToolLength => &self.tool_length,
            ModalGroup::Retract => &self.retract,
            ModalGroup::CoordSystem => &self.coord_system,
            ModalGroup::PathControl => &self.path_control,
            ModalGroup::SpindleMode => &self.spindle_mode,
            ModalGroup::LatheDiameter => &self.lathe_diameter,
            ModalGroup::G92Applied => &self.g92_applied,
            ModalGroup::CycleCancel => &self.cycle_cancel,
        };
        is(slot)
    }

    /// The block's motion code other than G80 (the block moves, or sets a
    /// motion mode).
    #[inline]
    fn explicit_motion(&self) -> Option<At<GCode>> {
        self.motion.filter(|(c, _)| *c != GCode::G80)
    }

    /// The non-modal G53, if the block has it.
    #[inline]
    fn g53(&self) -> Option<usize> {
        self.non_modal
            .filter(|(c, _)| *c == GCode::G53)
            .map(|(_, col)| col)
    }
}

/// The interpreter. Feed it blocks in order with [`Interpreter::execute`].
#[derive(Debug)]
pub struct Interpreter {
    opts: InterpOptions,
    state: ModalState,
    tools: ToolTable,
    tcp_from_g43_4: bool,
    /// The tool in the spindle before the M6 or M61 of the block being run
    /// (see [`Interpreter::spindle_entry_tool`]).
    tool_before_change: u32,
    /// The F number as written (program units): LinuxCNC feeds a move of
    /// rotary axes only at F deg/min (or deg/rev) whatever the length units.
    feed_as_written: f64,
    block_index: u64,
    ended: bool,
    percent: Percent,
    cycle: CycleMemory,
    /// The word table of the block being executed, kept between blocks for
    /// its buffers (boxed: taken out and put back by pointer, not copied).
    words: Option<Box<BlockWords>>,
    params: Parameters,
    assignments: Vec<(Target, f64, usize)>,
    /// Cutter radius compensation and the moves it holds back.
    comp: CutterComp,
    /// The file of the blocks being executed (tagged on their events).
    file: u32,
    /// Whether the block being executed may change the state behind the
    /// system parameters other than the current point (homes, G92, work
    /// offsets, coordinate system, tool): they are rewritten after it.
    state_params_stale: bool,
}

/// Whether the program uses `%` lines (LinuxCNC: the first non-blank line
/// is `%` alone; reading then stops at the next `%` line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Percent {
    BeforeFirstLine,
    Used,
    NotUsed,
}

/// What a canned cycle remembers for the next block of the same cycle
/// (LinuxCNC's `cycle_*` settings), canonical units.
#[derive(Debug, Clone, Copy, Default)]
struct CycleMemory {
    /// R level.
    r: f64,
    /// Bottom: the block's word of the plane's normal axis, canonical
    /// (in G91 measured from R).
    bottom: f64,
    /// Dwell, s.
    p: f64,
    /// Peck, mm.
    q: f64,
    /// G87 offsets I J K.
    ijk: [f64; 3],
    /// The level before the first cycle of a series (LinuxCNC's
    /// `cycle_il`), reset by any other motion.
    initial_level: Option<f64>,
}

/// What every step of a block needs: its line, its position and its events.
struct Step<'a> {
    line: u64,
    at: SourcePos,
    out: &'a mut Vec<Event>,
}

impl Step<'_> {
    #[inline]
    fn emit(&mut self, kind: EventKind) {
        self.out.push(Event { at: self.at, kind });
    }

    #[inline]
    fn invalid(&self, column: usize, message: impl Into<String>) -> GcodeError {
        GcodeError::invalid(self.line, column, message)
    }
}

impl Interpreter {
    /// A fresh interpreter in the start-up state (G17 G21 G90 G91.1 G94 G54,
    /// no motion mode, feed 0, spindle stopped, TCP per options).
    pub fn new(opts: InterpOptions) -> Self {
        let opts_params = opts.program.parameters.clone();
        // LinuxCNC starts with the homes and the G92 offsets of its var file
        // (5161–5169, 5181–5189; 5211–5219, applied when 5210 is not 0).
        let from = |first: u32| Axes(std::array::from_fn(|j| opts_params.get(first + j as u32)));
        let g92_saved = from(5211);
        let g92_applied = opts_params.get(5210) != 0.0;
        let axis_offset = if g92_applied { g92_saved } else { Axes::ZERO };
        let rotation = opts.work_rotations[0];
        let mut g92 = axis_offset;
        rotate_xy(&mut g92, rotation);
        let offset = opts.work_offsets[0].add(&g92);
        let mut position = opts.initial_machine_position.sub(&offset);
        rotate_xy(&mut position, -rotation);
        let state = ModalState {
            units: opts.initial_units,
            distance: DistanceMode::Absolute,
            arc_distance: DistanceMode::Incremental,
            feed_mode: FeedMode::UnitsPerMinute,
            plane: Plane::Xy,
            motion: None,
            feed: 0.0,
            spindle_rpm: 0.0,
            spindle: SpindleState::Stopped,
            work_system: 1,
            tool_length: 0.0,
            tool: 0,
            selected_tool: 0,
            tcp: opts.tcp_at_start,
            position,
            offset,
            work_offsets: opts.work_offsets,
            work_rotations: opts.work_rotations,
            rotation,
            axis_offset,
            g92_saved,
            g92_applied,
            g28_home: from(5161),
            g30_home: from(5181),
            tool_offset: Axes::ZERO,
            // LinuxCNC's interpreter starts in G99 (its set-up's
            // `retract_mode(R_PLANE)`); Fanuc controls power on in G98.
            retract: match opts.dialect {
                Dialect::LinuxCnc => RetractMode::RLevel,
                Dialect::Fanuc { .. } => RetractMode::InitialLevel,
            },
            lathe_diameter: false,
        };
        let mut it = Interpreter {
            tools: opts.tools.clone(),
            opts,
            state,
            tcp_from_g43_4: false,
            tool_before_change: 0,
            feed_as_written: 0.0,
            block_index: 0,
            ended: false,
            percent: Percent::BeforeFirstLine,
            cycle: CycleMemory::default(),
            words: Some(Box::default()),
            params: (*opts_params).clone(),
            assignments: Vec::new(),
            comp: CutterComp::default(),
            file: 0,
            state_params_stale: true,
        };
        // LinuxCNC's reset sets #5599 (the `(DEBUG,…)` switch) to 1 at
        // every program start, whatever its var file says.
        it.params.set_state(5599, 1.0);
        it.write_state_parameters();
        it
    }

    /// Writes the numbered parameters LinuxCNC 2.9 keeps from its state
    /// ([`is_state_parameter`]), as it holds them before reading a line:
    /// the current point 5420–5428 in program units (X Y Z U V W in the
    /// units of G20/G21, A B C in degrees; the point in the selected
    /// coordinate system, after G92, rotation and tool offset, as the
    /// program's words address it) always; the others when the block could
    /// have changed them: the homes 5161–5169 and 5181–5189 (machine
    /// coordinates), the G92 offsets 5211–5219 (kept through G92.2 for
    /// G92.3) with 5210 (1 when applied), 5220 (the system in force, 1 …
    /// 9), the nine systems 5221 + 20·k + axis with their rotation
    /// 5230 + 20·k (degrees), the tool in the spindle 5400 and its table
    /// entry: offsets 5401–5409, diameter 5410, front and back angles
    /// 5411–5412, orientation 5413 (all 0 without a tool). These are in
    /// the machine's units, mm and degrees, whatever G20/G21 (LinuxCNC keeps
    /// them in its INI's user units).
    fn write_state_parameters(&mut self) {
        let per_unit = 1.0 / self.state.units.mm_per_unit();
        for (j, a) in Axis::ALL.into_iter().enumerate() {
            let p = self.state.position[a];
            let v = if a.is_rotary() { p } else { p * per_unit };
            self.params.set_state(5420 + j as u32, v);
        }
        if !self.state_params_stale {
            return;
        }
        self.state_params_stale = false;
        let st = &self.state;
        let p = &mut self.params;
        let mut axes = |first: u32, v: &Axes| {
            for (j, x) in v.0.iter().enumerate() {
                p.set_state(first + j as u32, *x);
            }
        };
        axes(5161, &st.g28_home);
        axes(5181, &st.g30_home);
        axes(5211, &st.g92_saved);
        for (k, o) in st.work_offsets.iter().enumerate() {
            axes(5221 + 20 * k as u32, o);
        }
        for (k, r) in st.work_rotations.iter().enumerate() {
            p.set_state(5230 + 20 * k as u32, *r);
        }
        p.set_state(5210, if st.g92_applied { 1.0 } else { 0.0 });
        p.set_state(5220, f64::from(st.work_system));
        let tool = self.tools.get(st.tool).filter(|_| st.tool > 0);
        p.set_state(5400, tool.map_or(0.0, |t| f64::from(t.number)));
        let offset = tool.map_or(Axes::ZERO, |t| t.offset);
        for (j, x) in offset.0.iter().enumerate() {
            p.set_state(5401 + j as u32, *x);
        }
        p.set_state(5410, tool.map_or(0.0, |t| t.diameter));
        p.set_state(5411, tool.map_or(0.0, |t| t.front_angle));
        p.set_state(5412, tool.map_or(0.0, |t| t.back_angle));
        p.set_state(5413, tool.map_or(0.0, |t| f64::from(t.orientation)));
    }

    /// The file of the blocks executed next, tagged on their events
    /// ([`SourcePos::file`]: 0 the program, n ≥ 1 the n-th subroutine
    /// file); set by [`run_program`](super::program_flow::run_program).
    pub fn set_source_file(&mut self, file: u32) {
        self.file = file;
    }

    /// Called at the end of the input of a program that did not end with
    /// M2, M30 or a closing `%`: refuses it when cutter radius
    /// compensation still holds moves back (the last compensated moves
    /// would never be made).
    pub fn finish(&mut self) -> Result<(), GcodeError> {
        match self.comp.held_line() {
            Some(line) if !self.ended => Err(GcodeError::invalid(
                line,
                0,
                "the program ends with cutter radius compensation on and no M2, M30 or G40: \
                 the moves from this line on are held back for the next corner and never made",
            )),
            _ => Ok(()),
        }
    }

    /// The modal state after the blocks executed so far.
    #[inline]
    pub fn state(&self) -> &ModalState {
        &self.state
    }

    /// The parameters (numbered, named) after the blocks executed so far.
    #[inline]
    pub fn parameters(&self) -> &Parameters {
        &self.params
    }

    /// The parameters, for program flow (subroutine arguments, returns).
    #[inline]
    pub fn parameters_mut(&mut self) -> &mut Parameters {
        &mut self.params
    }

    /// Whether the program has ended: M2/M30 was executed, or the closing
    /// `%` of a program that starts with `%` was read. Later blocks are
    /// ignored; callers stop reading there (LinuxCNC reads no further, so
    /// text after the end is never an error).
    #[inline]
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// Whether the program started with a `%` line (so that the next `%`
    /// line ends it).
    #[inline]
    pub(crate) fn percent_opened(&self) -> bool {
        self.percent == Percent::Used
    }

    /// The tool table as the program has changed it (G10 L1/L10/L11).
    #[inline]
    pub fn tools(&self) -> &ToolTable {
        &self.tools
    }

    /// Executes one block, appending its events to `out`. On error the state
    /// is that before the failing step; the error names the line.
    pub fn execute(&mut self, block: &Block, out: &mut Vec<Event>) -> Result<(), GcodeError> {
        let at = SourcePos {
            line: block.line(),
            block: self.block_index,
            file: self.file,
        };
        self.block_index += 1;
        if self.ended {
            return Ok(());
        }
        self.params.set_line(block.line());
        if self.percent == Percent::BeforeFirstLine && !block.text().trim_ascii().is_empty() {
            if block.is_percent() && block.items().len() == 1 {
                self.percent = Percent::Used;
                return Ok(());
            }
            self.percent = Percent::NotUsed;
        } else if self.percent == Percent::Used && block.is_percent() && block.items().len() == 1 {
            if self.comp.held_line().is_some() {
                // LinuxCNC stops reading there and never makes them.
                return Err(GcodeError::unsupported(
                    block.line(),
                    1,
                    "closing % while cutter radius compensation holds moves back (LinuxCNC drops \
                     them; turn compensation off with G40, or end with M2 or M30, before the %)",
                ));
            }
            self.ended = true;
            return Ok(());
        }
        if self.opts.skip_deleted_blocks && block.is_block_delete() {
            return Ok(());
        }
        let mut w = self.words.take().unwrap_or_default();
        if let Err(e) = self.collect(block, &mut w) {
            self.words = Some(w);
            return Err(e);
        }
        // LinuxCNC sets a line's parameters after reading the whole line (every
        // value on it read the old ones) and before executing it.
        if !self.assignments.is_empty() {
            for (target, value, column) in self.assignments.drain(..) {
                if let Target::Numbered(n @ (5161..=5413)) = target
                    && is_state_parameter(n)
                {
                    self.words = Some(w);
                    return Err(GcodeError::unsupported(
                        block.line(),
                        column,
                        format!(
                            "assignment to #{n}: LinuxCNC keeps it from its state (homes, G92 \
                             and work offsets, coordinate system, tool) and uses the value \
                             written later; mtwin does not (set it with G10, G28.1, G30.1, \
                             G92, G5x or M6)"
                        ),
                    ));
                }
                let r = match target {
                    Target::Numbered(n) => self.params.set(n, value),
                    Target::Named(name) => self.params.set_named(&name, value),
                };
                if let Err(e) = r {
                    self.words = Some(w);
                    return Err(GcodeError::invalid(block.line(), column, e.to_string()));
                }
            }
        }
        // Moves held back by cutter compensation come first; what is still
        // held after the block is kept for the next one. A failing block
        // leaves the compensation as it found it.
        let switching = w.g.iter().any(|&(c, _)| {
            matches!(
                c,
                GCode::G40 | GCode::G41 | GCode::G41_1 | GCode::G42 | GCode::G42_1
            )
        });
        let undo = self.comp.undo_point(switching);
        self.comp.begin_block(out);
        let mut step = Step {
            line: block.line(),
            at,
            out,
        };
        let r = self.run(block, &mut w, &mut step);
        self.words = Some(w);
        match r {
            Ok(()) => {
                self.comp.end_block(out);
                self.write_state_parameters();
            }
            Err(_) => self.comp.undo(undo),
        }
        r
    }

    /// Reads the words of a block: their values, one per letter.
    fn collect(&mut self, block: &Block, w: &mut BlockWords) -> Result<(), GcodeError> {
        let line = block.line();
        w.g.clear();
        w.m.clear();
        w.present = 0;
        self.assignments.clear();
        for item in block.items() {
            match item {
                Item::Word(word) => {
                    collect_word(block, word, w, &self.params, self.opts.machine_axes)?;
                }
                Item::OWord { span } => {
                    return Err(GcodeError::unsupported(
                        line,
                        span.start + 1,
                        "O-word statement (subroutines and control flow)",
                    ));
                }
                Item::Assignment { span } => {
                    let text = &block.text()[span.start..span.end];
                    let (target, value) = expr::assignment(text, &self.params).map_err(|e| {
                        GcodeError::invalid(
                            line,
                            span.start + 1,
                            format!("{e} in {}", String::from_utf8_lossy(text)),
                        )
                    })?;
                    self.assignments.push((target, value, span.start + 1));
                }
                Item::Percent { .. } if block.words().next().is_some() => {
                    return Err(GcodeError::invalid(line, 0, "words on a '%' line"));
                }
                Item::Comment { .. } | Item::BlockDelete { .. } | Item::Percent { .. } => {}
            }
        }
        Ok(())
    }

    /// One block: read and check, then each step in LinuxCNC's order.
    fn run(&mut self, block: &Block, w: &mut BlockWords, s: &mut Step) -> Result<(), GcodeError> {
        // Filled in place: returned by value, the table (about 0.3 KB) was
        // copied out of the result for every block.
        let mut codes = Codes::default();
        self.read_codes(w, s.line, &mut codes)?;
        self.check_words(block, w, &codes, s.line)?;
        self.check_polar(w, &codes, s.line)?;
        if codes.non_modal.is_some()
            || codes.coord_system.is_some()
            || codes.g92_applied.is_some()
            || codes.m_tool_change.is_some()
        {
            self.state_params_stale = true;
        }
        self.read_diameters(w, &codes);
        let w = &*w;
        // Every step but F, S, T and motion acts on a G-code other than the
        // motion one or on an M-code: a block with neither (most blocks of a
        // CAM program) skips them with this one test instead of a call each.
        let settings = !w.m.is_empty() || w.g.len() > usize::from(codes.motion.is_some());
        if settings {
            self.set_feed_mode(&codes, s);
        }
        self.set_feed_rate(w, s)?;
        self.set_spindle_speed(w, s)?;
        self.select_tool(w, s)?;
        if settings {
            self.m_codes_with_comp(w, s)?;
            self.task_waits(w, s, &[64, 65, 66, 68]);
            self.change_tool(w, &codes, s)?;
            self.set_spindle_direction(&codes, s);
            self.task_waits(w, s, &[19, 7, 8, 9]);
            self.switch_tcp_by_m_code(&codes, s);
            self.dwell(w, &codes, s)?;
            self.set_plane(&codes, s)?;
            self.set_length_units(&codes, s);
            self.set_lathe_diameter_mode(&codes);
            self.cutter_compensation(w, &codes, s)?;
            self.set_tool_length_offset(w, &codes, s)?;
            self.select_coordinate_system(&codes, s)?;
            self.set_path_control(w, &codes, s)?;
            self.set_distance_mode(&codes);
            self.set_arc_distance_mode(&codes);
            self.set_retract_mode(&codes, s)?;
            self.non_modal(w, &codes, s)?;
            self.set_g92_applied(&codes, s)?;
            self.check_g53(w, &codes, s)?;
        }
        self.motion(w, &codes, s)?;
        if settings {
            self.stop(&codes, s)?;
        }
        Ok(())
    }
}

/// The motion mode a group-1 code sets (G80 excluded).
#[inline]
fn motion_mode(code: GCode) -> MotionMode {
    match code {
        GCode::G0 => MotionMode::Rapid,
        GCode::G2 => MotionMode::ArcClockwise,
        GCode::G3 => MotionMode::ArcCounterClockwise,
        GCode::G33 => MotionMode::SpindleSync,
        GCode::G33_1 => MotionMode::RigidTap,
        GCode::G76 => MotionMode::Threading,
        c if c.is_cycle() => MotionMode::Cycle(c),
        // G1 and the probing moves.
        _ => MotionMode::Linear,
    }
}

/// LinuxCNC's `unwrap_rotary`: absolute target of a wrapped rotary axis,
/// the sign of the programmed value giving the direction.
/// Rotates X Y of `a` by `deg` degrees about Z (counter-clockwise seen
/// from +Z, LinuxCNC's `rotate`); no change at all for 0.
#[inline]
fn rotate_xy(a: &mut Axes, deg: f64) {
    if deg == 0.0 {
        return;
    }
    let (sn, cs) = deg.to_radians().sin_cos();
    let (x, y) = (a[Axis::X], a[Axis::Y]);
    a[Axis::X] = x * cs - y * sn;
    a[Axis::Y] = x * sn + y * cs;
}

fn unwrap_rotary(commanded: f64, current: f64) -> Result<f64, String> {
    if commanded <= -360.0 || commanded >= 360.0 {
        return Err(format!(
            "invalid absolute position {commanded} for a wrapped rotary axis"
        ));
    }
    let d = (current / 360.0).floor();
    let mut result = commanded % 360.0 + d * 360.0;
    let negative = commanded.is_sign_negative();
    if !negative && result < current {
        result += 360.0;
    }
    if negative && result > current {
        result -= 360.0;
    }
    Ok(result)
}

fn nonneg_int(l: Letter, line: u64, name: &str) -> Result<u32, GcodeError> {
    if l.value < 0.0 || l.value.fract() != 0.0 || l.value > f64::from(u32::MAX) {
        return Err(GcodeError::invalid(
            line,
            l.column,
            format!("{name} word must be a non-negative integer"),
        ));
    }
    Ok(l.value as u32)
}

/// The value of a word: its number, or its expression (parameters
/// included) evaluated.
fn word_value(block: &Block, word: &Word, params: &Parameters) -> Result<f64, GcodeError> {
    match word.value {
        Value::Number(v) => Ok(v),
        Value::Expression | Value::Parameter => {
            expr::eval(block.value_text(word).as_bytes(), params).map_err(|e| {
                GcodeError::invalid(
                    block.line(),
                    word.span.start + 1,
                    format!("{e} in {}", block.value_text(word)),
                )
            })
        }
    }
}

/// Files one word of a block: G- and M-codes in order, every other letter
/// at most once; the letter of an axis outside `machine_axes` is refused.
fn collect_word(
    block: &Block,
    word: &Word,
    w: &mut BlockWords,
    params: &Parameters,
    machine_axes: AxisMask,
) -> Result<(), GcodeError> {
    let line = block.line();
    let col = word.at + 1;
    if let Some(axis) = Axis::from_letter(word.letter)
        && !machine_axes.contains(axis)
    {
        return Err(GcodeError::invalid(
            line,
            col,
            format!(
                "{0} word: the machine has no {0} axis (LinuxCNC: \"Bad character '{1}' used\")",
                word.letter as char,
                word.letter.to_ascii_lowercase() as char
            ),
        ));
    }
    let value = word_value(block, word, params)?;
    match word.letter {
        b'G' => {
            let code = GCode::from_value(value).ok_or_else(|| {
                GcodeError::unsupported(line, col, format!("G-code G{}", block.value_text(word)))
            })?;
            w.g.push((code, col));
        }
        b'M' => {
            if value.fract() != 0.0 || !(0.0..=9999.0).contains(&value) {
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("M-code M{}", block.value_text(word)),
                ));
            }
            w.m.push((value as u32, col));
        }
        b'N' => {}
        l => {
            let i = letter_slot(l);
            if w.present & (1 << i) != 0 && matches!(l, b'@' | b'^') {
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!(
                        "a second {} word in the block (LinuxCNC 2.9 reads the last one without an error)",
                        l as char
                    ),
                ));
            }
            if w.present & (1 << i) != 0 {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    format!("more than one {} word in the block", l as char),
                ));
            }
            w.present |= 1 << i;
            w.letters[i] = Letter {
                value,
                has_point: word.has_point,
                column: col,
            };
        }
    }
    Ok(())
}
