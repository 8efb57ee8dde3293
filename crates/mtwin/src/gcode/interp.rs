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
fn letter_slot(l: u8) -> usize {
    match l {
        b'@' => 26,
        b'^' => 27,
        _ => usize::from(l - b'A'),
    }
}

impl BlockWords {
    fn get(&self, l: u8) -> Option<&Letter> {
        let i = letter_slot(l);
        (self.present & (1 << i) != 0).then(|| &self.letters[i])
    }

    /// Whether the block has a polar coordinate word (`@` or `^`).
    fn polar(&self) -> bool {
        self.get(b'@').is_some() || self.get(b'^').is_some()
    }

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
    fn explicit_motion(&self) -> Option<At<GCode>> {
        self.motion.filter(|(c, _)| *c != GCode::G80)
    }

    /// The non-modal G53, if the block has it.
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
    pub fn state(&self) -> &ModalState {
        &self.state
    }

    /// The parameters (numbered, named) after the blocks executed so far.
    pub fn parameters(&self) -> &Parameters {
        &self.params
    }

    /// The parameters, for program flow (subroutine arguments, returns).
    pub fn parameters_mut(&mut self) -> &mut Parameters {
        &mut self.params
    }

    /// Whether the program has ended: M2/M30 was executed, or the closing
    /// `%` of a program that starts with `%` was read. Later blocks are
    /// ignored; callers stop reading there (LinuxCNC reads no further, so
    /// text after the end is never an error).
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// Whether the program started with a `%` line (so that the next `%`
    /// line ends it).
    pub(crate) fn percent_opened(&self) -> bool {
        self.percent == Percent::Used
    }

    /// The tool table as the program has changed it (G10 L1/L10/L11).
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

    /// Reads the G- and M-codes of a block into `codes` (empty on entry), one per modal group,
    /// refusing unknown and unsupported codes and two codes of one group
    /// (LinuxCNC's `read_g`: G80 may share the line with another motion
    /// code, which wins).
    fn read_codes(&self, w: &BlockWords, line: u64, codes: &mut Codes) -> Result<(), GcodeError> {
        let dialect = self.opts.dialect;
        for &(code, col) in &w.g {
            if let Some(why) = code.unsupported() {
                return Err(GcodeError::unsupported(line, col, format!("{why} {code}")));
            }
            if matches!(code, GCode::G33 | GCode::G33_1) && dialect != Dialect::LinuxCnc {
                // Fanuc's G33 takes the lead from F, not K.
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("spindle-synchronised motion {code} in this dialect"),
                ));
            }
            if matches!(code, GCode::G7 | GCode::G8) && dialect != Dialect::LinuxCnc {
                // Fanuc's G7 is not LinuxCNC's diameter mode.
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("lathe diameter/radius mode {code} in this dialect"),
                ));
            }
            let group = code.group(dialect);
            if group == ModalGroup::ArcDistance && !dialect.has_arc_distance_modes() {
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("{code} in this dialect"),
                ));
            }
            let slot = codes.slot(group);
            match *slot {
                None => *slot = Some((code, col)),
                Some((other, _)) => {
                    if group == ModalGroup::Motion && code == GCode::G80 {
                        // G80 beside another motion code is ignored.
                    } else if group == ModalGroup::Motion && other == GCode::G80 {
                        *slot = Some((code, col));
                    } else {
                        return Err(GcodeError::invalid(
                            line,
                            col,
                            format!("two G-codes of one modal group: {other} and {code}"),
                        ));
                    }
                }
            }
        }
        // M-codes: at most one per modal group.
        for &(code, col) in &w.m {
            let slot = match code {
                0 | 1 | 2 | 30 | 60 => &mut codes.m_stop,
                3..=5 => &mut codes.m_spindle,
                c if Some(c) == self.opts.tcp_on_m || Some(c) == self.opts.tcp_off_m => {
                    &mut codes.m_tcp
                }
                6 | 61 => &mut codes.m_tool_change,
                c if m_ignored(c) => continue,
                98 | 99 => {
                    return Err(GcodeError::unsupported(
                        line,
                        col,
                        format!("subprogram call M{code}"),
                    ));
                }
                _ => match self.opts.unknown_m {
                    UnknownMCode::Ignore => continue,
                    UnknownMCode::Reject => {
                        return Err(GcodeError::unsupported(
                            line,
                            col,
                            format!("M-code M{code}"),
                        ));
                    }
                },
            };
            if let Some((other, _)) = *slot {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    format!("two M-codes of one modal group: M{other} and M{code}"),
                ));
            }
            *slot = Some((code, col));
        }
        if let Some((code, col)) = codes.non_modal
            && code.covets_axes()
        {
            if let Some((motion, _)) = codes.explicit_motion() {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    format!(
                        "Cannot use two G codes that both use axis values: {code} and {motion}"
                    ),
                ));
            }
            let any_axis = Axis::ALL.iter().any(|a| w.get(a.letter()).is_some());
            if !any_axis && matches!(code, GCode::G52 | GCode::G92) {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    format!("All axes missing with {code}"),
                ));
            }
        }
        if let Some((code, col)) = codes.motion
            && code.is_probe()
            && !Axis::ALL.iter().any(|a| w.get(a.letter()).is_some())
            && !w.polar()
        {
            let name = if code == GCode::G31 { "G31" } else { "G38.x" };
            return Err(GcodeError::invalid(
                line,
                col,
                format!("probing {name} without axis words"),
            ));
        }
        Ok(())
    }

    /// Whether a non-motion code of the block reads its axis words (G10,
    /// G28, G30, G52, G92, G43.1).
    fn axes_consumed(&self, codes: &Codes) -> bool {
        codes.non_modal.is_some_and(|(c, _)| c.covets_axes()) || codes.has(GCode::G43_1)
    }

    /// The motion mode the block's axis words will use: its own motion
    /// code, else the modal one.
    fn motion_to_be(&self, codes: &Codes) -> Option<MotionMode> {
        if codes.motion.is_none() && self.axes_consumed(codes) {
            return None;
        }
        match codes.motion {
            Some((GCode::G80, _)) => None,
            Some((code, _)) => Some(motion_mode(code)),
            None => self.state.motion,
        }
    }

    /// Refuses words that no code of the block reads, as LinuxCNC's
    /// `check_other_codes` does: I J K without an arc, R outside arcs, G64
    /// and M19, and D, E, H, L, P, Q ("E word with no G76, M66, M67 or M68
    /// to use it", ...): a word nothing reads is a typing error, never
    /// silently dropped. Only the codes this interpreter accepts are listed.
    fn check_words(
        &self,
        block: &Block,
        w: &BlockWords,
        codes: &Codes,
        line: u64,
    ) -> Result<(), GcodeError> {
        let any_axis = Axis::ALL.iter().any(|a| w.get(a.letter()).is_some()) || w.polar();
        let moving = any_axis || codes.explicit_motion().is_some();
        let to_be = self.motion_to_be(codes);
        let arc_now = moving
            && matches!(
                to_be,
                Some(MotionMode::ArcClockwise | MotionMode::ArcCounterClockwise)
            );
        let cycle_now = match to_be {
            Some(MotionMode::Cycle(c)) if moving => Some(c),
            _ => None,
        };
        let cycle_in = |cs: &[GCode]| cycle_now.is_some_and(|c| cs.contains(&c));
        // G33 and G33.1 read K (and G33.1 I, the retract speed factor).
        let sync_now =
            moving && matches!(to_be, Some(MotionMode::SpindleSync | MotionMode::RigidTap));
        let tap_now = sync_now && to_be == Some(MotionMode::RigidTap);
        // G76 reads I J K, E, H, L, P, Q and R.
        let thread_now = moving && to_be == Some(MotionMode::Threading);
        if let Some((GCode::G33 | GCode::G33_1 | GCode::G76, col)) = codes.motion
            && !any_axis
        {
            return Err(GcodeError::invalid(
                line,
                col,
                "All axes missing with motion code",
            ));
        }
        let g10 = codes.has(GCode::G10);
        if let Some(r) = w.get(b'R') {
            // R is read by G2/G3, G64 (blend tolerance) and M19 (orientation).
            let g64 = codes.has(GCode::G64);
            let m19 = w.has_m(&[19]);
            if g64 && m19 {
                return Err(GcodeError::invalid(
                    line,
                    r.column,
                    "R word is ambiguous on a line with both G64 and M19 - use separate lines",
                ));
            }
            if !(arc_now || g64 || m19 || g10 || cycle_now.is_some() || thread_now) {
                return Err(GcodeError::invalid(
                    line,
                    r.column,
                    "R word with no g code that uses it",
                ));
            }
        }
        if !arc_now && !cycle_in(&[GCode::G87]) && !thread_now {
            for l in [b'I', b'J', b'K'] {
                if (l != b'K' && g10) || (l == b'K' && sync_now) || (l == b'I' && tap_now) {
                    continue;
                }
                if let Some(x) = w.get(l) {
                    return Err(GcodeError::invalid(
                        line,
                        x.column,
                        format!("{} word with no G2 or G3 to use it", l as char),
                    ));
                }
            }
        }
        let comp_on = codes.cutter_comp.is_some_and(|(c, _)| c != GCode::G40);
        // Whether a code of the block reads the letter: worked out only for
        // a letter the block has (most blocks have none of these).
        let checks: [(u8, &dyn Fn() -> bool, &str); 6] = [
            (
                b'D',
                &|| comp_on,
                "D word with no G41, G41.1, G42, G42.1 or G96 to use it",
            ),
            (
                b'E',
                &|| w.has_m(&[66, 67, 68]) || sync_now || thread_now,
                "E word with no G76, M66, M67 or M68 to use it",
            ),
            (
                b'H',
                &|| {
                    codes.has(GCode::G43)
                        || codes.has(GCode::G43_2)
                        || codes.has(GCode::G43_4)
                        || thread_now
                },
                "H word with no G43 or G76 to use it",
            ),
            (
                b'L',
                &|| w.has_m(&[66]) || g10 || cycle_now.is_some() || comp_on || thread_now,
                "L word with no G10, cutter compensation, canned cycle or M66 to use it",
            ),
            (
                b'P',
                &|| {
                    codes.has(GCode::G4)
                        || codes.has(GCode::G64)
                        || arc_now
                        || g10
                        || thread_now
                        || cycle_in(&[
                            GCode::G74,
                            GCode::G82,
                            GCode::G84,
                            GCode::G86,
                            GCode::G88,
                            GCode::G89,
                        ])
                        || w.has_m(&[19, 50, 51, 52, 53, 62, 63, 64, 65, 66])
                },
                "P word with no G2, G3, G4, G64, M19, M50-M53 or M62-M66 to use it",
            ),
            (
                b'Q',
                &|| {
                    codes.has(GCode::G64)
                        || w.has_m(&[19, 61, 66, 67, 68])
                        || g10
                        || thread_now
                        || cycle_in(&[GCode::G73, GCode::G83])
                },
                "Q word with no G64, M19, M61, M66, M67, M68 or canned cycle to use it",
            ),
        ];
        if sync_now {
            if w.get(b'K').is_none() {
                return Err(GcodeError::invalid(
                    line,
                    0,
                    "K word missing with g33/g33.1",
                ));
            }
            if let Some(f) = w.get(b'F') {
                return Err(GcodeError::invalid(
                    line,
                    f.column,
                    "F word used with a g33/g33.1",
                ));
            }
        }
        if thread_now {
            // LinuxCNC's P "missing" is its unset value, -1.
            if w.get(b'P').is_none_or(|p| p.value == -1.0) {
                return Err(GcodeError::invalid(line, 0, "P word missing with G76"));
            }
            if [b'I', b'J', b'K'].iter().any(|&l| w.get(l).is_none()) {
                return Err(GcodeError::invalid(
                    line,
                    0,
                    "I, J, or K words missing with G76",
                ));
            }
        }
        for (l, used, message) in checks {
            let Some(x) = w.get(l) else { continue };
            if used() {
                continue;
            }
            let mut message = message.to_string();
            // `X1e3`: the E (or D) was meant as an exponent.
            let at = x.column - 1;
            let text = block.text();
            if matches!(l, b'E' | b'D')
                && at > 0
                && text.get(at - 1).is_some_and(u8::is_ascii_digit)
            {
                message.push_str(
                    " (G-code numbers have no exponent: `1e3` reads as 1 followed by an E word)",
                );
            }
            return Err(GcodeError::invalid(line, x.column, message));
        }
        Ok(())
    }

    /// LinuxCNC's polar coordinates, `@` (distance from the origin of the
    /// program frame, program units) and `^` (angle from +X, degrees,
    /// counter-clockwise seen from +Z), which stand for the X and Y words
    /// of a motion: the checks of LinuxCNC 2.9's `enhance_block` and
    /// `find_ends` that need no position. The plane checked is the one in
    /// force before the block (as LinuxCNC checks it).
    fn check_polar(&self, w: &BlockWords, codes: &Codes, line: u64) -> Result<(), GcodeError> {
        let Some(first) = [b'@', b'^']
            .iter()
            .filter_map(|&l| w.get(l))
            .map(|l| l.column)
            .min()
        else {
            return Ok(());
        };
        let invalid = |m: &str| Err(GcodeError::invalid(line, first, m));
        if self.opts.dialect != Dialect::LinuxCnc {
            return Err(GcodeError::unsupported(
                line,
                first,
                "polar coordinates (@, ^) in this dialect",
            ));
        }
        if !(self.opts.machine_axes.contains(Axis::X) && self.opts.machine_axes.contains(Axis::Y)) {
            return invalid("Cannot use polar coordinate on a machine lacking X or Y axes");
        }
        if self.state.plane != Plane::Xy {
            return invalid("Cannot use polar coordinate except in G17 plane");
        }
        for l in [b'X', b'Y'] {
            if let Some(x) = w.get(l) {
                return Err(GcodeError::invalid(
                    line,
                    x.column,
                    format!(
                        "Cannot specify both polar coordinate and {} word",
                        l as char
                    ),
                ));
            }
        }
        if let Some((GCode::G80, col)) = codes.motion
            && !self.axes_consumed(codes)
        {
            return Err(GcodeError::invalid(
                line,
                col,
                "Cannot use axis values with G80",
            ));
        }
        if self.motion_to_be(codes).is_none() || self.axes_consumed(codes) {
            return invalid("Polar coordinates can only be used for motion");
        }
        if let Some(col) = codes.g53() {
            return Err(GcodeError::invalid(
                line,
                col,
                "Cannot use polar coordinates with G53",
            ));
        }
        Ok(())
    }

    /// The X Y end (mm, program frame) of a single move with polar words,
    /// from `[x, y]`, the point the move starts from (the programmed one
    /// under cutter radius compensation), as LinuxCNC 2.9's `find_ends`:
    /// in G90 `@` and `^` are the end's distance and angle, the missing one
    /// kept from the start (a distance alone at the origin is an error); in
    /// G91 `@` is added to the start's distance and `^` to its angle (an
    /// error at the origin).
    fn polar_end(
        &self,
        w: &BlockWords,
        [x, y]: [f64; 2],
        s: &Step,
    ) -> Result<(f64, f64), GcodeError> {
        let scale = self.state.units.mm_per_unit();
        let distance = w.get(b'@').map(|l| l.value * scale);
        let angle = w.get(b'^').map(|l| l.value.to_radians());
        let at_origin = x == 0.0 && y == 0.0;
        let polar = |r: f64, t: f64| (r * t.cos(), r * t.sin());
        match self.state.distance {
            DistanceMode::Absolute => match (distance, angle) {
                (Some(r), Some(t)) => Ok(polar(r, t)),
                (Some(_), None) if at_origin => {
                    Err(s.invalid(0, "Must specify angle in polar coordinate if at the origin"))
                }
                (Some(r), None) => Ok(polar(r, y.atan2(x))),
                (None, Some(t)) => Ok(polar(x.hypot(y), t)),
                (None, None) => Ok((x, y)), // not a polar block
            },
            DistanceMode::Incremental => {
                let (mut x, mut y) = (x, y);
                if let Some(d) = distance {
                    if x == 0.0 && y == 0.0 {
                        return Err(s.invalid(
                            0,
                            "Incremental motion with polar coordinates is indeterminate when at the origin",
                        ));
                    }
                    (x, y) = polar(x.hypot(y) + d, y.atan2(x));
                }
                if let Some(t) = angle {
                    if x == 0.0 && y == 0.0 {
                        return Err(s.invalid(
                            0,
                            "G91 motion with polar coordinates is indeterminate when at the origin",
                        ));
                    }
                    (x, y) = polar(x.hypot(y), y.atan2(x) + t);
                }
                Ok((x, y))
            }
        }
    }

    /// G93, G94, G95. Each clears the feed rate.
    fn set_feed_mode(&mut self, codes: &Codes, s: &mut Step) {
        let Some((code, _)) = codes.feed_mode else {
            return;
        };
        let mode = match code {
            GCode::G93 => FeedMode::InverseTime,
            GCode::G94 => FeedMode::UnitsPerMinute,
            _ => FeedMode::UnitsPerRevolution,
        };
        // LinuxCNC sets the feed rate to zero at every G93, G94 or G95, even
        // of the mode already in force: F must follow.
        self.state.feed = 0.0;
        self.feed_as_written = 0.0;
        self.state.feed_mode = mode;
        s.emit(EventKind::FeedMode(mode));
    }

    /// F, in canonical units (mm/min, 1/min, mm/rev).
    fn set_feed_rate(&mut self, w: &BlockWords, s: &mut Step) -> Result<(), GcodeError> {
        let Some(f) = w.get(b'F') else {
            return Ok(());
        };
        if f.value < 0.0 {
            return Err(s.invalid(f.column, "negative F word"));
        }
        let scale = match self.state.feed_mode {
            FeedMode::InverseTime => 1.0,
            _ => self.state.units.mm_per_unit(),
        };
        self.state.feed = f.value * scale;
        self.feed_as_written = f.value;
        s.emit(EventKind::FeedRate(self.state.feed));
        Ok(())
    }

    /// S, rev/min.
    fn set_spindle_speed(&mut self, w: &BlockWords, s: &mut Step) -> Result<(), GcodeError> {
        let Some(sw) = w.get(b'S') else {
            return Ok(());
        };
        if sw.value < 0.0 {
            return Err(s.invalid(sw.column, "negative spindle speed"));
        }
        self.state.spindle_rpm = sw.value;
        s.emit(EventKind::SpindleSpeed { rpm: sw.value });
        Ok(())
    }

    /// T: the tool the next M6 loads. With a tool table, a tool other than
    /// 0 must be in it (LinuxCNC refuses T of a tool its table does not
    /// hold); without one, any tool is taken (its offsets are then unknown:
    /// G43 of it is refused).
    fn select_tool(&mut self, w: &BlockWords, s: &Step) -> Result<(), GcodeError> {
        if let Some(t) = w.get(b'T') {
            let n = nonneg_int(*t, s.line, "T")?;
            if n != 0 && !self.tools.is_empty() && self.tools.get(n).is_none() {
                return Err(s.invalid(
                    t.column,
                    format!("Requested tool {n} not found in the tool table"),
                ));
            }
            self.state.selected_tool = n;
        }
        Ok(())
    }

    /// M6: the selected tool goes into the spindle. M61 Qn: tool `n` is
    /// declared in the spindle without a change (LinuxCNC's
    /// CHANGE_TOOL_NUMBER: its entry becomes the spindle's, so a later G43
    /// without H or with H0 applies it, and `#5400`–`#5413` read it from
    /// the next line); Q0 empties the spindle. Q is rounded to the nearest
    /// integer, as LinuxCNC's `round_to_int`; M61 changes neither the tool
    /// T selected nor the tool offset in force.
    fn change_tool(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        match codes.m_tool_change {
            Some((6, _)) => {
                self.refuse_with_comp(
                    s,
                    0,
                    "Cannot change tools with cutter radius compensation on",
                )?;
                self.tool_before_change = self.state.tool;
                self.state.tool = self.state.selected_tool;
                s.emit(EventKind::Wait(TaskWait::ToolChange));
            }
            Some((_, col)) => {
                let q = w.get(b'Q');
                let need = "Need non-negative Q-word to specify tool number with M61";
                let Some(q) = q else {
                    return Err(s.invalid(col, need));
                };
                let n = (q.value + 0.5).floor();
                if !(0.0..=f64::from(u32::MAX)).contains(&n) {
                    return Err(s.invalid(q.column, need));
                }
                let n = n as u32;
                if n != 0 && self.tools.get(n).is_none() {
                    return Err(s.invalid(
                        q.column,
                        format!("Requested tool {n} not found in the tool table"),
                    ));
                }
                self.tool_before_change = self.state.tool;
                self.state.tool = n;
                s.emit(EventKind::Wait(TaskWait::ToolNumber));
            }
            None => {}
        }
        Ok(())
    }

    /// The tool whose entry LinuxCNC's interpreter holds as the spindle's
    /// (its tool index 0, read by G43 H0, G43.2 H0, and G41/G42 without D
    /// or with D0) while this block runs: the tool in the spindle, except
    /// on the line of an M6 or M61, where LinuxCNC re-reads the entry only
    /// at the next line, so it is still the tool loaded before (checked
    /// with `rs274` 2.9: `T2 M6`, then `T4 M6 G43 H0` applies tool 2).
    fn spindle_entry_tool(&self, codes: &Codes) -> u32 {
        if codes.m_tool_change.is_some() {
            self.tool_before_change
        } else {
            self.state.tool
        }
    }

    /// The tool G43 and G43.4 without H apply: the spindle's entry, but on
    /// the line of an M6 or M61 the new tool's own entry (LinuxCNC reads
    /// the pocket changed to), unless that is tool 0 (its pocket is the
    /// spindle's entry, still the tool loaded before).
    fn g43_default_tool(&self, codes: &Codes) -> u32 {
        if codes.m_tool_change.is_some() && self.state.tool != 0 {
            self.state.tool
        } else {
            self.spindle_entry_tool(codes)
        }
    }

    /// The block's M-codes among `codes` that LinuxCNC's task waits for
    /// motion to end at ([`TaskWait`]), in the order of `codes` (M9 is mist
    /// off, then flood off).
    fn task_waits(&mut self, w: &BlockWords, s: &mut Step, codes: &[u32]) {
        if w.m.is_empty() {
            return;
        }
        for &c in codes {
            if !w.m.iter().any(|&(m, _)| m == c) {
                continue;
            }
            let waits: &[TaskWait] = match c {
                7 => &[TaskWait::MistOn],
                8 => &[TaskWait::FloodOn],
                9 => &[TaskWait::MistOff, TaskWait::FloodOff],
                19 => &[TaskWait::SpindleOrient],
                66 => &[TaskWait::InputWait],
                _ => &[TaskWait::Output],
            };
            for &k in waits {
                s.emit(EventKind::Wait(k));
            }
        }
    }

    /// An error `message` at `column` while cutter radius compensation is
    /// on (LinuxCNC refuses these codes then).
    fn refuse_with_comp(&self, s: &Step, column: usize, message: &str) -> Result<(), GcodeError> {
        if self.comp.is_on() {
            return Err(s.invalid(column, message));
        }
        Ok(())
    }

    /// M-codes accepted without a motion meaning that LinuxCNC refuses
    /// while cutter radius compensation is on (overrides, outputs, inputs).
    fn m_codes_with_comp(&self, w: &BlockWords, s: &Step) -> Result<(), GcodeError> {
        if !self.comp.is_on() {
            return Ok(());
        }
        let enable = w.get(b'P').is_none_or(|p| p.value != 0.0);
        for &(code, col) in &w.m {
            let message = match code {
                48 => "Cannot enable overrides with cutter radius compensation on",
                49 => "Cannot disable overrides with cutter radius compensation on",
                50..=53 if enable => "Cannot enable overrides with cutter radius compensation on",
                50..=53 => "Cannot disable overrides with cutter radius compensation on",
                62 => "Cannot set motion output with cutter radius compensation on",
                63 => "Cannot set motion digital output with cutter radius compensation on",
                64 | 65 => "Cannot set auxiliary digital output with cutter radius compensation on",
                66 if w.get(b'P').is_some() => {
                    "Cannot wait for digital input with cutter radius compensation on"
                }
                66 => "Cannot wait for analog input with cutter radius compensation on",
                67 => "Cannot set motion analog output with cutter radius compensation on",
                68 => "Cannot set auxiliary analog output with cutter radius compensation on",
                _ => continue,
            };
            return Err(s.invalid(col, message));
        }
        Ok(())
    }

    /// M3, M4, M5.
    fn set_spindle_direction(&mut self, codes: &Codes, s: &mut Step) {
        let Some((code, _)) = codes.m_spindle else {
            return;
        };
        let dir = match code {
            3 => SpindleState::Clockwise,
            4 => SpindleState::CounterClockwise,
            _ => SpindleState::Stopped,
        };
        self.state.spindle = dir;
        s.emit(EventKind::Spindle(dir));
    }

    /// The configured TCP M-codes (kinematics switch remaps).
    fn switch_tcp_by_m_code(&mut self, codes: &Codes, s: &mut Step) {
        let Some((code, _)) = codes.m_tcp else {
            return;
        };
        let on = Some(code) == self.opts.tcp_on_m;
        self.state.tcp = on;
        self.tcp_from_g43_4 = false;
        s.emit(EventKind::Tcp(on));
    }

    /// G4.
    fn dwell(&mut self, w: &BlockWords, codes: &Codes, s: &mut Step) -> Result<(), GcodeError> {
        if !codes.has(GCode::G4) {
            return Ok(());
        }
        let (word, value) = match self.opts.dialect {
            Dialect::LinuxCnc => (DwellWord::PSeconds, w.get(b'P')),
            Dialect::Fanuc { .. } => match (w.get(b'X').or(w.get(b'U')), w.get(b'P')) {
                (Some(x), _) => (DwellWord::XSeconds, Some(x)),
                (None, p) => (DwellWord::PMilliseconds, p),
            },
        };
        let v = value.ok_or_else(|| s.invalid(0, "dwell time missing with G4"))?;
        if v.value < 0.0 {
            return Err(s.invalid(v.column, "negative dwell time"));
        }
        // Fanuc `G4 X` without a decimal point (and without decimal point
        // programming) is in least increments of 0.001 s, as a dimension
        // word of a metric program: `G4 X2500` is 2.5 s.
        let value = match word {
            DwellWord::XSeconds => self
                .opts
                .dialect
                .dimension(v.value, v.has_point, false, false),
            _ => v.value,
        };
        s.emit(EventKind::Dwell {
            seconds: word.seconds(value),
        });
        Ok(())
    }

    /// G17, G18, G19.
    fn set_plane(&mut self, codes: &Codes, s: &Step) -> Result<(), GcodeError> {
        if let Some((code, col)) = codes.plane {
            let plane = match code {
                GCode::G17 => Plane::Xy,
                GCode::G18 => Plane::Zx,
                _ => Plane::Yz,
            };
            if plane != self.state.plane {
                self.refuse_with_comp(
                    s,
                    col,
                    "Cannot change planes with cutter radius compensation on",
                )?;
            }
            self.state.plane = plane;
        }
        Ok(())
    }

    /// G61, G61.1, G64 with its P and Q (program units, converted to mm;
    /// absent or zero means none, as in LinuxCNC).
    fn set_path_control(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.path_control else {
            return Ok(());
        };
        self.refuse_with_comp(
            s,
            col,
            "Cannot change control mode with cutter radius compensation on",
        )?;
        let mm = self.state.units.mm_per_unit();
        let tol = |letter: u8| {
            w.get(letter)
                .map(|v| v.value * mm)
                .filter(|v| *v > 0.0 && v.is_finite())
        };
        let mode = match code {
            GCode::G61 => PathMode::ExactPath,
            GCode::G61_1 => PathMode::ExactStop,
            _ => PathMode::Blend {
                p: tol(b'P'),
                q: tol(b'Q'),
            },
        };
        s.emit(EventKind::PathControl(mode));
        Ok(())
    }

    /// G20, G21.
    fn set_length_units(&mut self, codes: &Codes, s: &mut Step) {
        if let Some((code, _)) = codes.units {
            self.state.units = if code == GCode::G20 {
                Units::Inch
            } else {
                Units::Millimetre
            };
            s.emit(EventKind::Units(self.state.units));
        }
    }

    /// Group 15: G7 (diameter mode), G8 (radius mode).
    fn set_lathe_diameter_mode(&mut self, codes: &Codes) {
        self.state.lathe_diameter = lathe_diameter_mode::mode_after(
            self.state.lathe_diameter,
            codes.lathe_diameter.map(|(c, _)| c),
        );
    }

    /// In diameter mode (after the block's G7/G8) the X word is read as half
    /// its value, and G76's I, J, K as LinuxCNC 2.9 scales them
    /// ([`lathe_diameter_mode`]).
    fn read_diameters(&self, w: &mut BlockWords, codes: &Codes) {
        let before = self.state.lathe_diameter;
        let after = lathe_diameter_mode::mode_after(before, codes.lathe_diameter.map(|(c, _)| c));
        if !before && !after {
            return;
        }
        let mut scale = |l: u8, f: f64| {
            let i = letter_slot(l);
            if w.present & (1 << i) != 0 {
                w.letters[i].value *= f;
            }
        };
        scale(b'X', lathe_diameter_mode::x_factor(after));
        if self.motion_to_be(codes) == Some(MotionMode::Threading) {
            let f = lathe_diameter_mode::threading_ijk_factor(before, after);
            for l in [b'I', b'J', b'K'] {
                scale(l, f);
            }
        }
    }

    /// G43 (H defaults to the tool in the spindle), G43.1 (dynamic: the
    /// axis words), G43.2 (added: H's tool or the axis words), G43.4 (TCP),
    /// G49.
    fn set_tool_length_offset(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.tool_length else {
            return Ok(());
        };
        self.refuse_with_comp(
            s,
            col,
            "Cannot change tool offset with cutter radius compensation on",
        )?;
        let table_offset = |this: &Self, tool: u32| -> Result<Axes, GcodeError> {
            if tool == 0 {
                return Ok(Axes::ZERO);
            }
            this.tools
                .get(tool)
                .map(|t| t.offset)
                .ok_or_else(|| s.invalid(col, format!("tool {tool} is not in the tool table")))
        };
        let h = w
            .get(b'H')
            .map(|h| nonneg_int(*h, s.line, "H"))
            .transpose()?;
        let (axes, values) = self.axis_words(w, codes);
        let offset = match code {
            GCode::G49 => Axes::ZERO,
            // H0 is the tool in the spindle: LinuxCNC's tool index 0 is
            // the spindle's entry.
            GCode::G43 | GCode::G43_4 => match h {
                Some(0) => table_offset(self, self.spindle_entry_tool(codes))?,
                Some(tool) => table_offset(self, tool)?,
                None => table_offset(self, self.g43_default_tool(codes))?,
            },
            GCode::G43_1 => {
                let mut o = self.state.tool_offset;
                for a in axes.iter() {
                    o[a] = values[a.index()];
                }
                o
            }
            _ => {
                // G43.2
                if h.is_some() && !axes.is_empty() {
                    return Err(s.invalid(col, "G43.2: Can not have both H and axis words"));
                }
                let added = match h {
                    Some(0) => table_offset(self, self.spindle_entry_tool(codes))?,
                    Some(tool) => table_offset(self, tool)?,
                    None if axes.is_empty() => {
                        return Err(s.invalid(col, "G43.2: No axes specified and H word missing"));
                    }
                    None => {
                        let mut o = Axes::ZERO;
                        for a in axes.iter() {
                            o[a] = values[a.index()];
                        }
                        o
                    }
                };
                self.state.tool_offset.add(&added)
            }
        };
        self.state.tool_offset = offset;
        self.state.tool_length = offset[Axis::Z];
        self.apply_offsets();
        s.emit(EventKind::ToolLengthOffset {
            length: offset[Axis::Z],
        });
        let tcp = match code {
            GCode::G43_4 => Some(true),
            GCode::G49 if self.tcp_from_g43_4 => Some(false),
            _ => None,
        };
        if let Some(on) = tcp {
            self.state.tcp = on;
            self.tcp_from_g43_4 = on;
            s.emit(EventKind::Tcp(on));
        }
        Ok(())
    }

    /// G54 ... G59.3.
    fn select_coordinate_system(&mut self, codes: &Codes, s: &mut Step) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.coord_system else {
            return Ok(());
        };
        self.refuse_with_comp(
            s,
            col,
            "Cannot change coordinate systems with cutter radius compensation on",
        )?;
        let system: u8 = match code {
            GCode::G54 => 1,
            GCode::G55 => 2,
            GCode::G56 => 3,
            GCode::G57 => 4,
            GCode::G58 => 5,
            GCode::G59 => 6,
            GCode::G59_1 => 7,
            GCode::G59_2 => 8,
            _ => 9,
        };
        self.state.work_system = system;
        let offset = self.state.work_offsets[usize::from(system - 1)];
        self.apply_offsets();
        s.emit(EventKind::WorkOffset {
            system,
            offset,
            rotation: self.state.rotation,
        });
        Ok(())
    }

    /// G90, G91.
    fn set_distance_mode(&mut self, codes: &Codes) {
        if let Some((code, _)) = codes.distance {
            self.state.distance = if code == GCode::G90 {
                DistanceMode::Absolute
            } else {
                DistanceMode::Incremental
            };
        }
    }

    /// G90.1, G91.1.
    fn set_arc_distance_mode(&mut self, codes: &Codes) {
        if let Some((code, _)) = codes.arc_distance {
            self.state.arc_distance = if code == GCode::G90_1 {
                DistanceMode::Absolute
            } else {
                DistanceMode::Incremental
            };
        }
    }

    /// G98, G99.
    fn set_retract_mode(&mut self, codes: &Codes, s: &Step) -> Result<(), GcodeError> {
        if let Some((code, col)) = codes.retract {
            self.refuse_with_comp(
                s,
                col,
                "Cannot change retract mode with cutter radius compensation on",
            )?;
            self.state.retract = if code == GCode::G98 {
                RetractMode::InitialLevel
            } else {
                RetractMode::RLevel
            };
        }
        Ok(())
    }

    /// The non-modal codes of group 0 that change state or move: G10, G28,
    /// G28.1, G30, G30.1, G52, G92 (G4 and G53 have their own steps).
    fn non_modal(&mut self, w: &BlockWords, codes: &Codes, s: &mut Step) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.non_modal else {
            return Ok(());
        };
        const AXIS_OFFSETS: &str = "Cannot change axis offsets with cutter radius comp";
        match code {
            GCode::G28 | GCode::G30 => {
                self.refuse_with_comp(s, col, "Cannot use g28 or g30 with cutter radius comp")?
            }
            GCode::G28_1 | GCode::G30_1 => self.refuse_with_comp(
                s,
                col,
                "Cannot set reference point with cutter compensation in effect",
            )?,
            GCode::G52 | GCode::G92 => self.refuse_with_comp(s, col, AXIS_OFFSETS)?,
            _ => {}
        }
        match code {
            GCode::G10 => self.g10(w, codes, col, s),
            GCode::G28 | GCode::G30 => self.go_home(code, w, codes, s),
            GCode::G28_1 => {
                self.state.g28_home = self.home_to_store();
                Ok(())
            }
            GCode::G30_1 => {
                self.state.g30_home = self.home_to_store();
                Ok(())
            }
            GCode::G52 | GCode::G92 => {
                let (axes, values) = self.axis_words(w, codes);
                self.check_wrapped(w, axes, &values, s)?;
                for a in axes.iter() {
                    let v = values[a.index()];
                    self.state.axis_offset[a] = if code == GCode::G92 {
                        self.state.position[a] + self.state.axis_offset[a] - v
                    } else {
                        v
                    };
                }
                self.apply_offsets();
                self.state.g92_saved = self.state.axis_offset;
                self.state.g92_applied = true;
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Refuses absolute values of wrapped rotary axes outside (−360, 360).
    fn check_wrapped(
        &self,
        w: &BlockWords,
        axes: AxisMask,
        values: &[f64; 9],
        s: &Step,
    ) -> Result<(), GcodeError> {
        for a in axes.iter() {
            let v = values[a.index()];
            if self.opts.wrapped_rotary.contains(a) && (v <= -360.0 || v >= 360.0) {
                let col = w.get(a.letter()).map_or(0, |l| l.column);
                return Err(s.invalid(
                    col,
                    format!("Invalid absolute position {v} for wrapped rotary axis {a:?}"),
                ));
            }
        }
        Ok(())
    }

    /// The machine position G28.1/G30.1 store (wrapped rotary axes in
    /// [0, 360)).
    fn home_to_store(&self) -> Axes {
        let mut m = self.to_machine(&self.state.position);
        for a in self.opts.wrapped_rotary.iter() {
            m[a] = m[a].rem_euclid(360.0);
        }
        m
    }

    /// G28, G30: a rapid to the axis words (the waypoint, in the current
    /// frame and distance mode), then a rapid to the stored home position
    /// on the axes named (all axes if none is named). Both moves are made
    /// even when they have no length, as LinuxCNC's canonical calls are.
    fn go_home(
        &mut self,
        code: GCode,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let (axes, values) = self.axis_words(w, codes);
        let from = self.state.position;
        let mut waypoint = from;
        for a in axes.iter() {
            let v = values[a.index()];
            waypoint[a] = match self.state.distance {
                DistanceMode::Incremental => from[a] + v,
                DistanceMode::Absolute if self.opts.wrapped_rotary.contains(a) => {
                    unwrap_rotary(v, from[a])
                        .map_err(|m| s.invalid(w.get(a.letter()).map_or(0, |l| l.column), m))?
                }
                DistanceMode::Absolute => v,
            };
        }
        let mut words = self.programmed(axes, false);
        words.expanded = true;
        self.push_straight(true, waypoint, words, s)?;
        let home = if code == GCode::G28 {
            self.state.g28_home
        } else {
            self.state.g30_home
        };
        let mut end = waypoint;
        if self.state.rotation == 0.0 {
            let home_work = home.sub(&self.state.offset);
            for a in Axis::ALL {
                if axes.is_empty() || axes.contains(a) {
                    end[a] = home_work[a];
                }
            }
        } else {
            // The axes named go to their machine home, the others keep
            // their machine position; back to the rotated frame.
            let mut m = self.to_machine(&waypoint);
            for a in Axis::ALL {
                if axes.is_empty() || axes.contains(a) {
                    m[a] = home[a];
                }
            }
            end = self.to_work(&m);
        }
        self.push_straight(true, end, self.programmed(AxisMask::EMPTY, true), s)
    }

    /// What the block wrote for a move, in the current modes.
    fn programmed(&self, axes: AxisMask, expanded: bool) -> Programmed {
        Programmed {
            axes,
            g53: false,
            distance: self.state.distance,
            units: self.state.units,
            expanded,
            x_diameter: self.state.lathe_diameter,
        }
    }

    /// A straight move from the current position to `to` (work
    /// coordinates): a rapid, or a feed at the current feed (units per
    /// minute or per revolution, as canned cycles feed).
    fn push_straight(
        &mut self,
        rapid: bool,
        to: Axes,
        words: Programmed,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let st = &self.state;
        let feed = if rapid {
            Feed::Rapid
        } else {
            match st.feed_mode {
                FeedMode::UnitsPerRevolution => Feed::PerRevolution {
                    mm_per_rev: st.feed,
                    rpm: st.spindle_rpm,
                },
                _ => Feed::PerMinute(st.feed),
            }
        };
        self.check_rotation(s)?;
        let start = self.comp.physical_start(&st.position);
        let lin = Linear {
            from: self.event_point(&start),
            to: self.event_point(&to),
            offset: st.offset,
            feed,
            tcp: st.tcp,
            words,
        };
        self.state.position = to;
        s.emit(if rapid {
            EventKind::Traverse(lin)
        } else {
            EventKind::Feed(lin)
        });
        Ok(())
    }

    /// G10: L2 and L20 set the offset of a coordinate system (P1 ... P9,
    /// P0 the active one), L1, L10 and L11 a tool table entry (P the tool).
    fn g10(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        col: usize,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let l = w
            .get(b'L')
            .filter(|l| matches!(l.value, 1.0 | 2.0 | 10.0 | 11.0 | 20.0))
            .ok_or_else(|| s.invalid(col, "Line with G10 does not have L1, L10, L11, L2, or L20"))?
            .value as u32;
        let p = w.get(b'P').map_or(0.0, |p| p.value);
        let p_int = p.round();
        if (p - p_int).abs() > 0.0002 {
            return Err(s.invalid(col, "P value not an integer with G10"));
        }
        let (axes, values) = self.axis_words(w, codes);
        let st = &self.state;
        // The current position as it would read in `system` (LinuxCNC's
        // find_current_in_system), without rotation.
        let in_system = |system: usize| -> Axes {
            let mut c = st
                .position
                .add(&st.axis_offset)
                .add(&st.work_offsets[usize::from(st.work_system - 1)])
                .sub(&st.work_offsets[system - 1]);
            if st.g92_applied {
                c = c.sub(&st.g92_saved);
            }
            c
        };
        match l {
            2 | 20 => {
                if !(0.0..=9.0).contains(&p_int) {
                    return Err(s.invalid(col, format!("P value out of range (0-9) with G10 L{l}")));
                }
                if w.get(b'I').is_some() || w.get(b'J').is_some() {
                    return Err(s.invalid(col, "I J words not allowed with G10 L2"));
                }
                let rotation = match w.get(b'R') {
                    Some(r) if l == 20 => {
                        return Err(s.invalid(r.column, "R not allowed in G10 L20"));
                    }
                    // Degrees, whatever the length units.
                    Some(r) => Some(r.value),
                    None => None,
                };
                if l == 20 {
                    self.check_wrapped(w, axes, &values, s)?;
                }
                let system = if p_int == 0.0 {
                    usize::from(st.work_system)
                } else {
                    p_int as usize
                };
                let active = system == usize::from(st.work_system);
                if active {
                    self.refuse_with_comp(
                        s,
                        col,
                        "Cannot change the active coordinate system with cutter radius compensation on",
                    )?;
                }
                let rotated = st.rotation != 0.0 || st.work_rotations[system - 1] != 0.0;
                // LinuxCNC's interpreter re-reads the current point
                // without the G92 offset when the rotation of the active
                // system changes (or G10 L20 sets a rotated one), while its
                // motion keeps the machine point: the two disagree, so
                // mtwin refuses rather than pick one.
                let g92 = st.axis_offset[Axis::X] != 0.0 || st.axis_offset[Axis::Y] != 0.0;
                let new_rotation = rotation.is_some_and(|r| r != st.rotation);
                if active && g92 && (new_rotation || (l == 20 && rotated)) {
                    return Err(GcodeError::unsupported(
                        s.line,
                        col,
                        format!(
                            "G10 L{l} {} of the active coordinate system while a G92 offset is in force",
                            if l == 20 {
                                "in a rotated system"
                            } else {
                                "changing the rotation"
                            }
                        ),
                    ));
                }
                if l == 20 && rotated && !active {
                    return Err(GcodeError::unsupported(
                        s.line,
                        col,
                        "G10 L20 of a coordinate system other than the active one with a rotation (G10 L2 R) in force",
                    ));
                }
                let current = in_system(system);
                let mut offset = st.work_offsets[system - 1];
                if l == 20 && rotated {
                    // The active system: the origin moves by the rotated
                    // difference between the current point and the values
                    // (LinuxCNC: the machine point stays, reading them).
                    let mut delta = Axes::ZERO;
                    for a in axes.iter() {
                        delta[a] = current[a] - values[a.index()];
                    }
                    rotate_xy(&mut delta, st.rotation);
                    offset = offset.add(&delta);
                } else {
                    for a in axes.iter() {
                        let v = values[a.index()];
                        offset[a] = if l == 20 {
                            current[a] + offset[a] - v
                        } else {
                            v
                        };
                    }
                }
                self.state.work_offsets[system - 1] = offset;
                if let Some(r) = rotation {
                    self.state.work_rotations[system - 1] = r;
                }
                if active {
                    self.apply_offsets();
                    s.emit(EventKind::WorkOffset {
                        system: system as u8,
                        offset,
                        rotation: self.state.rotation,
                    });
                }
                Ok(())
            }
            _ => {
                if p_int < 1.0 {
                    return Err(s.invalid(col, format!("P value out of range with G10 L{l}")));
                }
                let tool = p_int as u32;
                if axes.is_empty() && [b'R', b'Q', b'I', b'J'].iter().all(|&c| w.get(c).is_none()) {
                    return Err(s.invalid(col, "G10 L1 without offsets has no effect"));
                }
                if self.tools.get(tool).is_none() {
                    return Err(s.invalid(col, format!("tool {tool} is not in the tool table")));
                }
                let offset = if l == 1 {
                    let mut o = self.tools.get(tool).map_or(Axes::ZERO, |t| t.offset);
                    for a in axes.iter() {
                        o[a] = values[a.index()];
                    }
                    o
                } else {
                    self.tool_offset_reading(l, tool, axes, &values)
                };
                let scale = self.state.units.mm_per_unit();
                let r = w.get(b'R').map(|r| r.value * scale);
                let q = w.get(b'Q').map(|q| q.value);
                let (i, j) = (w.get(b'I').map(|x| x.value), w.get(b'J').map(|x| x.value));
                let entry = self.tools.entry(tool);
                entry.offset = offset;
                if let Some(r) = r {
                    entry.diameter = (2.0 * r).abs();
                }
                if let Some(q) = q {
                    if !(0.0..=9.0).contains(&q) || q.fract() != 0.0 {
                        return Err(s.invalid(col, "Q (orientation) must be 0 to 9 with G10 L1"));
                    }
                    entry.orientation = q as u8;
                }
                if let Some(i) = i {
                    entry.front_angle = i;
                }
                if let Some(j) = j {
                    entry.back_angle = j;
                }
                Ok(())
            }
        }
    }

    /// The current point as it reads in coordinate system `system` (1 ... 9)
    /// with no tool offset (LinuxCNC's `find_current_in_system_without_tlo`):
    /// the machine point without the tool offset in force, taken into
    /// `system`'s origin and rotation, less the G92 offsets if applied.
    fn current_in_system_without_tool(&self, system: usize) -> Axes {
        let st = &self.state;
        let mut c = st.position.add(&st.axis_offset);
        rotate_xy(&mut c, st.rotation);
        c = c
            .add(&st.work_offsets[usize::from(st.work_system - 1)])
            .add(&st.tool_offset)
            .sub(&st.work_offsets[system - 1]);
        rotate_xy(&mut c, -st.work_rotations[system - 1]);
        if st.g92_applied {
            c = c.sub(&st.g92_saved);
        }
        c
    }

    /// The tool offsets G10 L10 (L11) sets for `tool`: those with which the
    /// current point reads the axis words in the active system (in G59.3,
    /// without its G92 offsets), as LinuxCNC's `convert_setup_tool` computes
    /// them. X and Y are the difference turned by the system's rotation
    /// (G10 L2 R); with only one of them written, the entry keeps the part
    /// of its old X Y offset along the other (rotated) axis. Axes not
    /// written keep the entry's offsets.
    fn tool_offset_reading(&self, l: u32, tool: u32, axes: AxisMask, values: &[f64; 9]) -> Axes {
        let st = &self.state;
        let system = if l == 11 {
            9
        } else {
            usize::from(st.work_system)
        };
        let mut current = self.current_in_system_without_tool(system);
        if l == 11 && st.g92_applied {
            current = current.add(&st.g92_saved);
        }
        let rotation = st.work_rotations[system - 1];
        let old = self.tools.get(tool).map_or(Axes::ZERO, |t| t.offset);
        let mut offset = old;
        for a in axes.iter() {
            offset[a] = current[a] - values[a.index()];
        }
        let (x, y) = (axes.contains(Axis::X), axes.contains(Axis::Y));
        if x || y {
            // The new part along the written axes, turned into the machine
            // frame, plus the old part along the other one.
            let mut new = Axes::ZERO;
            let mut kept = Axes::ZERO;
            kept[Axis::X] = old[Axis::X];
            kept[Axis::Y] = old[Axis::Y];
            rotate_xy(&mut kept, -rotation);
            if x {
                new[Axis::X] = current[Axis::X] - values[Axis::X.index()];
                kept[Axis::X] = 0.0;
            }
            if y {
                new[Axis::Y] = current[Axis::Y] - values[Axis::Y.index()];
                kept[Axis::Y] = 0.0;
            }
            rotate_xy(&mut new, rotation);
            rotate_xy(&mut kept, rotation);
            offset[Axis::X] = new[Axis::X] + kept[Axis::X];
            offset[Axis::Y] = new[Axis::Y] + kept[Axis::Y];
        }
        offset
    }

    /// G92.1 and G92.2 (axis offsets to zero; G92.1 also clears the kept
    /// values), G92.3 (restore the kept values).
    fn set_g92_applied(&mut self, codes: &Codes, s: &Step) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.g92_applied else {
            return Ok(());
        };
        self.refuse_with_comp(s, col, "Cannot change axis offsets with cutter radius comp")?;
        if code == GCode::G92_3 {
            self.state.axis_offset = self.state.g92_saved;
            self.state.g92_applied = true;
        } else {
            self.state.axis_offset = Axes::ZERO;
            self.state.g92_applied = false;
            if code == GCode::G92_1 {
                self.state.g92_saved = Axes::ZERO;
            }
        }
        self.apply_offsets();
        Ok(())
    }

    /// A canned cycle (G73, G74, G81 ... G89) in the active plane, as the
    /// straight moves, dwells and spindle commands LinuxCNC's
    /// `convert_cycle_*` produce, repeated L times (in G91 each repeat
    /// moves by the in-plane words). `previous` is the motion mode before
    /// the block: words a cycle remembers may be left out only when it is
    /// the same cycle.
    fn canned_cycle(
        &mut self,
        code: GCode,
        previous: Option<MotionMode>,
        w: &BlockWords,
        axes: AxisMask,
        target: [f64; 9],
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let st = &self.state;
        let same = previous == Some(MotionMode::Cycle(code));
        if st.feed <= 0.0 {
            return Err(s.invalid(0, "Cannot feed with zero feed rate"));
        }
        if st.feed_mode == FeedMode::InverseTime {
            return Err(s.invalid(0, "Cannot use inverse time feed with canned cycles"));
        }
        let (p, q, n) = st.plane.axes();
        let plane = match st.plane {
            Plane::Xy => "XY",
            Plane::Zx => "XZ",
            Plane::Yz => "YZ",
        };
        for a in axes.iter() {
            if a.is_rotary() || matches!(a, Axis::U | Axis::V | Axis::W) {
                let col = w.get(a.letter()).map_or(0, |l| l.column);
                return Err(s.invalid(
                    col,
                    format!("Cannot put {a:?} in a canned cycle in the {plane} plane"),
                ));
            }
        }
        let scale = st.units.mm_per_unit();
        let r_word = match w.get(b'R') {
            Some(r) => r.value * scale,
            None if same => self.cycle.r,
            None => {
                return Err(s.invalid(0, "R clearance plane unspecified in canned cycle"));
            }
        };
        let repeats = match w.get(b'L') {
            None => 1,
            Some(l) => {
                let n = nonneg_int(*l, s.line, "L")?;
                if n == 0 {
                    return Err(s.invalid(l.column, "Cannot do zero repeats of canned cycle"));
                }
                if u64::from(n) > crate::limits::MAX_CYCLE_REPEATS {
                    return Err(s.invalid(
                        l.column,
                        format!(
                            "L{n}: at most {} repeats of a canned cycle in one block (a bound of mtwin on the memory one block may take)",
                            crate::limits::MAX_CYCLE_REPEATS
                        ),
                    ));
                }
                n
            }
        };
        if !same && !axes.contains(n) {
            return Err(s.invalid(
                0,
                format!("{n:?} value unspecified in {plane} plane canned cycle"),
            ));
        }
        let bottom_word = if axes.contains(n) {
            target[n.index()]
        } else {
            self.cycle.bottom
        };
        let mut current_cc = st.position[n];
        let mut old_cc = *self.cycle.initial_level.get_or_insert(current_cc);
        let (mut aa, mut bb) = (st.position[p], st.position[q]);
        let (mut da, mut db) = (0.0, 0.0);
        let st_distance = st.distance;
        // Polar words (XY plane only): in G90 the hole's distance and angle
        // from the origin, the missing one from the current point (no
        // error at the origin, unlike a single move); in G91 added to the
        // distance and angle of each repeat's hole.
        let distance_word = w.get(b'@').map(|l| l.value * scale);
        let angle_word = w.get(b'^').map(|l| l.value);
        let (r, cc) = match st.distance {
            DistanceMode::Absolute => {
                if axes.contains(p) {
                    aa = target[p.index()];
                }
                if axes.contains(q) {
                    bb = target[q.index()];
                }
                if distance_word.is_some() || angle_word.is_some() {
                    let radius = distance_word.unwrap_or(aa.hypot(bb));
                    let theta = angle_word.map_or(bb.atan2(aa), f64::to_radians);
                    (aa, bb) = (radius * theta.cos(), radius * theta.sin());
                }
                (r_word, bottom_word)
            }
            DistanceMode::Incremental => {
                if axes.contains(p) {
                    da = target[p.index()];
                }
                if axes.contains(q) {
                    db = target[q.index()];
                }
                let r = r_word + old_cc;
                (r, r + bottom_word)
            }
        };
        if r < cc {
            return Err(s.invalid(0, format!("R less than {n:?} in cycle in {plane} plane")));
        }
        // Cycle words, checked before any move.
        let dwell = |this: &Self| -> Result<f64, GcodeError> {
            match w.get(b'P') {
                Some(pw) => Ok(pw.value),
                None if same || matches!(code, GCode::G74 | GCode::G84) => Ok(this.cycle.p),
                None => Err(s.invalid(0, format!("Dwell time P word missing with {code}"))),
            }
        };
        let mut params = self.cycle;
        match code {
            GCode::G82 | GCode::G86 | GCode::G88 | GCode::G89 | GCode::G74 | GCode::G84 => {
                params.p = dwell(self)?;
            }
            GCode::G73 | GCode::G83 => {
                params.q = match w.get(b'Q') {
                    Some(qw) => qw.value * scale,
                    None if same => self.cycle.q,
                    None => return Err(s.invalid(0, format!("Q word missing with {code}"))),
                };
                if params.q <= 0.0 {
                    return Err(s.invalid(0, "Negative or zero Q value used"));
                }
            }
            GCode::G87 => {
                for (k, l) in [b'I', b'J', b'K'].into_iter().enumerate() {
                    match w.get(l) {
                        Some(x) => params.ijk[k] = x.value * scale,
                        None if same => {}
                        None => {
                            return Err(
                                s.invalid(0, format!("{} word missing with G87", l as char))
                            );
                        }
                    }
                }
            }
            _ => {}
        }
        let spindle = self.state.spindle;
        match (code, spindle) {
            (
                GCode::G84 | GCode::G74 | GCode::G86 | GCode::G87 | GCode::G88,
                SpindleState::Stopped,
            ) => {
                return Err(s.invalid(0, format!("Spindle not turning in {code}")));
            }
            (GCode::G84, SpindleState::CounterClockwise) => {
                return Err(s.invalid(0, "Spindle turning counterclockwise in G84"));
            }
            (GCode::G74, SpindleState::Clockwise) => {
                return Err(s.invalid(0, "Spindle turning clockwise in G74"));
            }
            _ => {}
        }
        let words = self.programmed(axes, true);
        let at = |this: &Self, a: f64, b: f64, c: f64| {
            let mut to = this.state.position;
            to[p] = a;
            to[q] = b;
            to[n] = c;
            to
        };
        // Below the R level: straight up to it first.
        if old_cc < r {
            let to = at(self, self.state.position[p], self.state.position[q], r);
            self.push_straight(true, to, words, s)?;
            old_cc = r;
            current_cc = old_cc;
        }
        let clear = match self.state.retract {
            RetractMode::RLevel => r,
            RetractMode::InitialLevel => old_cc,
        };
        if matches!(code, GCode::G73 | GCode::G83) {
            // Pecks of one hole times the repeats: bounded before any move
            // is made, as the repeats are (huge R or tiny Q would otherwise
            // expand one block without end).
            let pecks = ((r - cc) / params.q).ceil() * f64::from(repeats);
            if pecks.is_nan() || pecks > crate::limits::MAX_CYCLE_PECKS as f64 {
                let column = w.get(b'Q').map_or(0, |q| q.column);
                return Err(s.invalid(
                    column,
                    format!(
                        "{code} from R {r} to {cc} by Q {} ({repeats} repeats): more than {} pecks in one block (a bound of mtwin on the memory one block may take)",
                        params.q,
                        crate::limits::MAX_CYCLE_PECKS
                    ),
                ));
            }
        }
        for repeat in (1..=repeats).rev() {
            aa += da;
            bb += db;
            if st_distance == DistanceMode::Incremental {
                for (d, turn) in [(distance_word, 0.0), (None, angle_word.unwrap_or(0.0))] {
                    let d = d.unwrap_or(0.0);
                    if d == 0.0 && turn == 0.0 {
                        continue;
                    }
                    if aa == 0.0 && bb == 0.0 {
                        return Err(s.invalid(
                            0,
                            "Incremental motion with polar coordinates is indeterminate when at the origin",
                        ));
                    }
                    let radius = aa.hypot(bb) + d;
                    let theta = bb.atan2(aa) + turn.to_radians();
                    (aa, bb) = (radius * theta.cos(), radius * theta.sin());
                }
            }
            if repeat == repeats && current_cc > r {
                self.push_straight(true, at(self, aa, bb, current_cc), words, s)?;
                self.push_straight(true, at(self, aa, bb, r), words, s)?;
            } else {
                self.push_straight(true, at(self, aa, bb, clear), words, s)?;
                if clear > r {
                    self.push_straight(true, at(self, aa, bb, r), words, s)?;
                }
            }
            self.cycle_body(code, &params, [aa, bb], r, clear, cc, words, s)?;
        }
        let mut end = self.state.position;
        end[p] = aa;
        end[q] = bb;
        end[n] = clear;
        self.state.position = end;
        self.cycle = CycleMemory {
            r: r_word,
            bottom: bottom_word,
            initial_level: self.cycle.initial_level,
            ..params
        };
        Ok(())
    }

    /// The moves of one repeat of a canned cycle at (`a`, `b`) in the plane,
    /// from the R level `r` to the bottom `bottom` and back to `clear`.
    #[allow(clippy::too_many_arguments)]
    fn cycle_body(
        &mut self,
        code: GCode,
        params: &CycleMemory,
        [a, b]: [f64; 2],
        r: f64,
        clear: f64,
        bottom: f64,
        words: Programmed,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let (p, q, n) = self.state.plane.axes();
        let at = |this: &Self, x: f64, y: f64, z: f64| {
            let mut to = this.state.position;
            to[p] = x;
            to[q] = y;
            to[n] = z;
            to
        };
        let feed = |this: &mut Self, z: f64, s: &mut Step| {
            let to = at(this, a, b, z);
            this.push_straight(false, to, words, s)
        };
        let rapid = |this: &mut Self, z: f64, s: &mut Step| {
            let to = at(this, a, b, z);
            this.push_straight(true, to, words, s)
        };
        let spindle = |this: &mut Self, dir: SpindleState, s: &mut Step| {
            this.state.spindle = dir;
            s.emit(EventKind::Spindle(dir));
        };
        let dir = self.state.spindle;
        // G73/G83 back off 0.010 inch (0.254 mm) above the last depth.
        const RAPID_DELTA: f64 = 0.254;
        match code {
            GCode::G81 => {
                feed(self, bottom, s)?;
                rapid(self, clear, s)?;
            }
            GCode::G82 => {
                feed(self, bottom, s)?;
                s.emit(EventKind::Dwell { seconds: params.p });
                rapid(self, clear, s)?;
            }
            GCode::G73 | GCode::G83 => {
                let mut depth = r - params.q;
                while depth > bottom {
                    feed(self, depth, s)?;
                    if code == GCode::G83 {
                        rapid(self, r, s)?;
                    }
                    rapid(self, depth + RAPID_DELTA, s)?;
                    let next = depth - params.q;
                    if next >= depth {
                        // Q below the resolution of the depth's number.
                        return Err(s.invalid(
                            0,
                            format!("Q {} too small to move from depth {depth}", params.q),
                        ));
                    }
                    depth = next;
                }
                feed(self, bottom, s)?;
                rapid(self, clear, s)?;
            }
            GCode::G74 | GCode::G84 => {
                let (reverse, forward) = if code == GCode::G84 {
                    (SpindleState::CounterClockwise, SpindleState::Clockwise)
                } else {
                    (SpindleState::Clockwise, SpindleState::CounterClockwise)
                };
                // LinuxCNC 2.9 (and later) passes the tapping feeds' end
                // points to its plane mapping in another order than the
                // other cycles: in G18 and G19 the two feeds go along
                // another axis than the cycle's. Reproduced as it runs.
                let tap = |this: &mut Self, z: f64, s: &mut Step| {
                    let mut to = this.state.position;
                    match this.state.plane {
                        Plane::Xy => (to[p], to[q], to[n]) = (a, b, z),
                        Plane::Yz => (to[n], to[p], to[q]) = (b, z, a),
                        Plane::Zx => (to[q], to[n], to[p]) = (z, a, b),
                    }
                    this.push_straight(false, to, words, s)
                };
                tap(self, bottom, s)?;
                spindle(self, SpindleState::Stopped, s);
                spindle(self, reverse, s);
                s.emit(EventKind::Dwell { seconds: params.p });
                tap(self, clear, s)?;
                spindle(self, SpindleState::Stopped, s);
                spindle(self, forward, s);
            }
            GCode::G85 => {
                feed(self, bottom, s)?;
                feed(self, r, s)?;
                rapid(self, clear, s)?;
            }
            GCode::G86 => {
                feed(self, bottom, s)?;
                s.emit(EventKind::Dwell { seconds: params.p });
                spindle(self, SpindleState::Stopped, s);
                rapid(self, clear, s)?;
                spindle(self, dir, s);
            }
            GCode::G87 => {
                let [i, j, k] = params.ijk;
                let middle = match self.state.distance {
                    DistanceMode::Incremental => bottom + k,
                    DistanceMode::Absolute => k,
                };
                let (oa, ob) = (a + i, b + j);
                let to = at(self, oa, ob, r);
                self.push_straight(true, to, words, s)?;
                spindle(self, SpindleState::Stopped, s);
                let to = at(self, oa, ob, bottom);
                self.push_straight(true, to, words, s)?;
                rapid(self, bottom, s)?;
                spindle(self, dir, s);
                feed(self, middle, s)?;
                feed(self, bottom, s)?;
                spindle(self, SpindleState::Stopped, s);
                let to = at(self, oa, ob, bottom);
                self.push_straight(true, to, words, s)?;
                let to = at(self, oa, ob, clear);
                self.push_straight(true, to, words, s)?;
                rapid(self, clear, s)?;
                spindle(self, dir, s);
            }
            GCode::G88 => {
                // The operator retracts by hand after the program stop.
                feed(self, bottom, s)?;
                s.emit(EventKind::Dwell { seconds: params.p });
                spindle(self, SpindleState::Stopped, s);
                spindle(self, dir, s);
            }
            GCode::G89 => {
                feed(self, bottom, s)?;
                s.emit(EventKind::Dwell { seconds: params.p });
                feed(self, clear, s)?;
            }
            _ => return Err(s.invalid(0, format!("{code} is not a canned cycle"))),
        }
        Ok(())
    }

    /// G53 (non-modal): needs axis words and a straight motion mode.
    fn check_g53(&self, w: &BlockWords, codes: &Codes, s: &Step) -> Result<(), GcodeError> {
        let Some(col) = codes.g53() else {
            return Ok(());
        };
        if self.axis_words(w, codes).0.is_empty() {
            return Err(s.invalid(col, "G53 without axis words"));
        }
        let mode = self.motion_to_be(codes);
        if !matches!(mode, Some(MotionMode::Rapid | MotionMode::Linear)) {
            return Err(s.invalid(col, "G53 needs G0 or G1"));
        }
        Ok(())
    }

    /// Sets the total offset from the work, G92 and tool offsets in force,
    /// keeping the machine position.
    fn apply_offsets(&mut self) {
        let machine = self.to_machine(&self.state.position);
        let st = &mut self.state;
        st.rotation = st.work_rotations[usize::from(st.work_system - 1)];
        let mut g92 = st.axis_offset;
        rotate_xy(&mut g92, st.rotation);
        let offset = st.work_offsets[usize::from(st.work_system - 1)]
            .add(&g92)
            .add(&st.tool_offset);
        st.offset = offset;
        self.state.position = self.to_work(&machine);
    }

    /// Machine coordinates of a work position (identity kinematics).
    fn to_machine(&self, p: &Axes) -> Axes {
        let mut m = *p;
        rotate_xy(&mut m, self.state.rotation);
        m.add(&self.state.offset)
    }

    /// Work coordinates of a machine position (identity kinematics).
    fn to_work(&self, m: &Axes) -> Axes {
        let mut p = m.sub(&self.state.offset);
        rotate_xy(&mut p, -self.state.rotation);
        p
    }

    /// A work position as the events give it: X Y rotated by the rotation
    /// in force, so that machine = event position + offset.
    fn event_point(&self, p: &Axes) -> Axes {
        let mut q = *p;
        rotate_xy(&mut q, self.state.rotation);
        q
    }

    /// Refuses what this interpreter does not run in a rotated system.
    fn check_rotation(&self, s: &Step) -> Result<(), GcodeError> {
        if self.state.rotation != 0.0 && self.state.tcp {
            return Err(GcodeError::unsupported(
                s.line,
                0,
                "coordinate system rotation (G10 L2 R) with tool centre point control",
            ));
        }
        Ok(())
    }

    /// The axis words of a block in canonical units (mm, degree).
    fn axis_words(&self, w: &BlockWords, codes: &Codes) -> (AxisMask, [f64; 9]) {
        let dialect = self.opts.dialect;
        let dwell = codes.has(GCode::G4);
        let mut axes = AxisMask::EMPTY;
        let mut target = [0.0; 9];
        for axis in Axis::ALL {
            if let Some(a) = w.get(axis.letter()) {
                if dwell && dialect != Dialect::LinuxCnc && matches!(axis, Axis::X | Axis::U) {
                    continue; // Fanuc G4 X or U: the dwell time.
                }
                axes.insert(axis);
                let v = dialect.dimension(
                    a.value,
                    a.has_point,
                    self.state.units == Units::Inch,
                    axis.is_rotary(),
                );
                target[axis.index()] = if axis.is_rotary() {
                    v
                } else {
                    v * self.state.units.mm_per_unit()
                };
            }
        }
        (axes, target)
    }

    /// Group 1: sets the motion mode (G80 clears it) and moves to the axis
    /// words.
    fn motion(&mut self, w: &BlockWords, codes: &Codes, s: &mut Step) -> Result<(), GcodeError> {
        let previous = self.state.motion;
        match codes.motion {
            Some((GCode::G80, _)) => self.state.motion = None,
            Some((code, _)) => self.state.motion = Some(motion_mode(code)),
            None => {}
        }
        if codes.motion.is_some_and(|(c, _)| !c.is_cycle()) {
            // Any other motion code ends a series of cycles.
            self.cycle.initial_level = None;
        }
        let (axes, target) = self.axis_words(w, codes);
        let g53 = codes.g53();
        if codes.motion.is_none() && self.axes_consumed(codes) {
            return Ok(());
        }
        let polar = w.polar();
        if axes.is_empty() && !polar && codes.explicit_motion().is_none() {
            return Ok(());
        }
        if let Some((code, col)) = codes.motion
            && code.is_probe()
        {
            self.refuse_with_comp(s, col, "Cannot probe with cutter radius comp on")?;
        }
        match self.state.motion {
            None if !axes.is_empty() || polar => {
                Err(s.invalid(0, "axis words without a motion mode (G0, G1, G2 or G3)"))
            }
            None => Ok(()),
            Some(MotionMode::Cycle(code)) => {
                if self.comp.is_on() {
                    self.state.motion = previous;
                    return Err(
                        s.invalid(0, "Cannot use canned cycles with cutter compensation on")
                    );
                }
                let r = self.canned_cycle(code, previous, w, axes, target, s);
                if r.is_err() {
                    self.state.motion = previous;
                }
                r
            }
            Some(mode) => {
                self.cycle.initial_level = None;
                // LinuxCNC's straight probes (G38.2–G38.5), not the Fanuc G31.
                let probe = codes
                    .motion
                    .filter(|&(c, _)| c.is_probe() && c != GCode::G31);
                self.move_to(mode, w, axes, target, g53, probe, s)
            }
        }
    }

    /// One move of `mode` to the axis words. With cutter radius
    /// compensation on, the words are read from the programmed position
    /// and the move is made by [`CutterComp`]. `probe`: the block's
    /// G38.2–G38.5 and the column of its word. As LinuxCNC 2.9's
    /// `convert_probe`, a probe is refused under G95 and a G38.2 or G38.4
    /// (the kinds that fail without contact) whose end is its start on
    /// every axis ("Start point too close to probe point"); after it
    /// #5061–#5070 read [`Self::set_probe_result`].
    #[allow(clippy::too_many_arguments)]
    fn move_to(
        &mut self,
        mode: MotionMode,
        w: &BlockWords,
        axes: AxisMask,
        target: [f64; 9],
        g53: Option<usize>,
        probe: Option<(GCode, usize)>,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let line = s.line;
        let st = &self.state;
        let from = st.position;
        let base = self.comp.base(&from);
        let mut to = base;
        if let Some(col) = g53 {
            if !matches!(mode, MotionMode::Rapid | MotionMode::Linear) {
                return Err(s.invalid(col, "G53 needs G0 or G1"));
            }
            if st.distance == DistanceMode::Incremental {
                return Err(s.invalid(col, "G53 is not allowed with G91"));
            }
        }
        if g53.is_some() && st.rotation != 0.0 {
            // G53 in a rotated system: the named axes go to the machine
            // position, the others keep theirs; X Y back to the rotated frame.
            let mut m = self.to_machine(&from);
            for axis in axes.iter() {
                m[axis] = target[axis.index()];
            }
            to = self.to_work(&m);
        }
        for axis in axes.iter() {
            let v = target[axis.index()];
            to[axis] = if g53.is_some() && st.rotation != 0.0 {
                to[axis]
            } else if g53.is_some() {
                v - st.offset[axis]
            } else if st.distance == DistanceMode::Incremental {
                base[axis] + v
            } else if self.opts.wrapped_rotary.contains(axis) {
                unwrap_rotary(v, from[axis]).map_err(|m| {
                    GcodeError::invalid(line, w.get(axis.letter()).map_or(0, |l| l.column), m)
                })?
            } else {
                v
            };
        }
        let polar = w.polar();
        if polar {
            let (x, y) = self.polar_end(w, [base[Axis::X], base[Axis::Y]], s)?;
            to[Axis::X] = x;
            to[Axis::Y] = y;
        }
        if let Some((code, col)) = probe {
            if st.feed_mode == FeedMode::UnitsPerRevolution {
                return Err(s.invalid(col, "Cannot probe with feed per rev mode"));
            }
            if matches!(code, GCode::G38_2 | GCode::G38_4) && to.0 == from.0 {
                return Err(s.invalid(col, "Start point too close to probe point"));
            }
        }
        let words = Programmed {
            axes,
            g53: g53.is_some(),
            distance: st.distance,
            units: st.units,
            // No X or Y word ends a polar move: none can be rewritten.
            expanded: polar,
            x_diameter: st.lathe_diameter,
        };
        // The column an error of a compensated move names: its first axis
        // word (or polar word).
        let column = axes
            .iter()
            .next()
            .and_then(|a| w.get(a.letter()))
            .or_else(|| w.get(b'@'))
            .or_else(|| w.get(b'^'))
            .map_or(0, |l| l.column);
        let kind = match mode {
            MotionMode::Rapid | MotionMode::Linear => {
                self.comp.straight_move_started();
                let rapid = mode == MotionMode::Rapid;
                let comp = self.comp.engaged();
                if !comp && axes.is_empty() && !polar {
                    return Ok(());
                }
                let feed = if rapid {
                    Feed::Rapid
                } else {
                    // A move of rotary axes only: F is deg/min (or deg/rev)
                    // whatever the length units.
                    let d = to.sub(&base);
                    let rotary_only =
                        d.xyz_norm() == 0.0 && d.uvw_norm() == 0.0 && d.abc_norm() > 0.0;
                    match self.feed(w, line)? {
                        Feed::PerMinute(_) if rotary_only => Feed::PerMinute(self.feed_as_written),
                        Feed::PerRevolution { rpm, .. } if rotary_only => Feed::PerRevolution {
                            mm_per_rev: self.feed_as_written,
                            rpm,
                        },
                        f => f,
                    }
                };
                self.check_rotation(s)?;
                if comp {
                    if let Some(col) = g53 {
                        return Err(s.invalid(col, "Cannot use g53 with cutter radius comp"));
                    }
                    let units = self.state.units;
                    let feed = match feed {
                        Feed::InverseTime(f) => {
                            let (length, rotary) = cutter_comp::straight_length(&base, &to, units);
                            cutter_comp::inverse_time_feed(f, length, rotary, units)
                        }
                        f => f,
                    };
                    let info = self.move_info(s.at, column, words, feed);
                    return self
                        .comp
                        .straight(rapid, to, &info, &mut self.state.position, s.out);
                }
                let start = self.comp.physical_start(&from);
                let st = &self.state;
                let lin = Linear {
                    from: self.event_point(&start),
                    to: self.event_point(&to),
                    offset: st.offset,
                    feed,
                    tcp: self.state.tcp,
                    words,
                };
                if rapid {
                    EventKind::Traverse(lin)
                } else {
                    EventKind::Feed(lin)
                }
            }
            MotionMode::Cycle(code) => {
                return Err(s.invalid(0, format!("{code} is not a single move")));
            }
            MotionMode::SpindleSync | MotionMode::RigidTap => {
                return self.spindle_sync(mode, w, axes, to, words, s);
            }
            MotionMode::Threading => return self.threading_cycle(w, axes, to, words, s),
            MotionMode::ArcClockwise | MotionMode::ArcCounterClockwise => {
                if self.comp.arc_not_allowed() {
                    return Err(s.invalid(
                        0,
                        "The move just after exiting cutter compensation mode must be straight, not an arc",
                    ));
                }
                // No axis words: with I, J or K a full circle about the
                // current point (as LinuxCNC 2.9 runs it), else an error.
                let ijk = [b'I', b'J', b'K'].iter().any(|&l| w.get(l).is_some());
                if axes.is_empty() && !polar && (w.get(b'R').is_some() || !ijk) {
                    return Err(s.invalid(0, "All axes missing with motion code"));
                }
                let feed = self.feed(w, line)?;
                let ccw = mode == MotionMode::ArcCounterClockwise;
                let comp = self.comp.engaged();
                let plane = self.state.plane;
                let (p, q, n) = plane.axes();
                if comp && self.comp.first_move() {
                    let scale = self.state.units.mm_per_unit();
                    let r_word = w.get(b'R').map(|r| r.value * scale);
                    let info = self.move_info(s.at, column, words, feed);
                    self.comp.check_arc_entry(
                        [base[p], base[q]],
                        [to[p], to[q]],
                        ccw,
                        r_word,
                        &info,
                    )?;
                }
                let (mut center, turns) = self.arc_center(w, &base, &to, ccw, line)?;
                if comp {
                    let center = [center[p.index()], center[q.index()]];
                    let units = self.state.units;
                    let feed = match feed {
                        Feed::InverseTime(f) => {
                            let length = cutter_comp::arc_length(
                                [base[p], base[q]],
                                center,
                                turns,
                                [to[p], to[q]],
                                to[n] - base[n],
                            );
                            cutter_comp::inverse_time_feed(f, length, false, units)
                        }
                        f => f,
                    };
                    let info = self.move_info(s.at, column, words, feed);
                    return self.comp.arc(
                        turns,
                        center,
                        to,
                        &info,
                        &mut self.state.position,
                        s.out,
                    );
                }
                self.check_rotation(s)?;
                let start = self.comp.physical_start(&from);
                let st = &self.state;
                if st.rotation != 0.0 {
                    if st.plane != Plane::Xy {
                        return Err(GcodeError::unsupported(
                            line,
                            0,
                            "coordinate system rotation (G10 L2 R) with an arc outside the XY plane",
                        ));
                    }
                    let (sn, cs) = st.rotation.to_radians().sin_cos();
                    let [x, y, _] = center;
                    center[0] = x * cs - y * sn;
                    center[1] = x * sn + y * cs;
                }
                EventKind::Arc(ArcMove {
                    from: self.event_point(&start),
                    to: self.event_point(&to),
                    center,
                    plane: st.plane,
                    turns,
                    offset: st.offset,
                    feed,
                    tcp: st.tcp,
                    words,
                })
            }
        };
        self.state.position = to;
        s.emit(kind);
        if probe.is_some() {
            self.set_probe_result(&to);
        }
        Ok(())
    }

    /// The result of a straight probe G38.2–G38.5, as mtwin assumes it: the
    /// part is not modelled, so the probe runs to its end point without
    /// contact (as LinuxCNC's standalone interpreter `rs274` reports it).
    /// #5061–#5069 read that end (X Y Z U V W in program units, A B C in
    /// degrees, within [0, 360) on a wrapped rotary axis; the point in the
    /// coordinate system the probe ran in) and #5070 reads 0 (not tripped).
    fn set_probe_result(&mut self, end: &Axes) {
        let per_unit = 1.0 / self.state.units.mm_per_unit();
        for (j, a) in Axis::ALL.into_iter().enumerate() {
            let v = if a.is_rotary() && self.opts.wrapped_rotary.contains(a) {
                end[a].rem_euclid(360.0)
            } else if a.is_rotary() {
                end[a]
            } else {
                end[a] * per_unit
            };
            self.params.set_state(5061 + j as u32, v);
        }
        self.params.set_state(5070, 0.0);
    }

    /// G33 (a straight move at K per spindle revolution) and G33.1 (rigid
    /// tapping: to the end at K per revolution, the spindle reversed, and
    /// back to the start at I times the speed, I ≥ 1, default 1), as
    /// LinuxCNC 2.9 runs them: the spindle must turn (M3 or M4); after
    /// G33.1 the position is the start again. Refused as unsupported: a
    /// zero spindle speed or K ≤ 0 (no time for the move), cutter radius
    /// compensation on (LinuxCNC feeds such a move unsynchronised or
    /// fails), and rotary or UVW words on G33.1 (LinuxCNC taps along X Y Z
    /// and sets the other axes without moving them). Both kinds of move
    /// are marked `expanded`: a rewriter must not split or re-code them.
    fn spindle_sync(
        &mut self,
        mode: MotionMode,
        w: &BlockWords,
        axes: AxisMask,
        to: Axes,
        mut words: Programmed,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let tap = mode == MotionMode::RigidTap;
        let name = if tap { "G33.1" } else { "G33" };
        self.comp.straight_move_started();
        if self.comp.engaged() {
            return Err(GcodeError::unsupported(
                s.line,
                0,
                format!("{name} with cutter radius compensation on"),
            ));
        }
        let st = &self.state;
        if st.spindle == SpindleState::Stopped {
            return Err(s.invalid(0, format!("Spindle not turning in {name}")));
        }
        let k = w.get(b'K').map_or(0.0, |k| k.value) * st.units.mm_per_unit();
        if !(k > 0.0 && k.is_finite()) {
            return Err(GcodeError::unsupported(
                s.line,
                w.get(b'K').map_or(0, |k| k.column),
                format!("{name} with K ≤ 0 (no advance per spindle revolution to time the move)"),
            ));
        }
        let rpm = st.spindle_rpm;
        if !(rpm > 0.0 && rpm.is_finite()) {
            return Err(GcodeError::unsupported(
                s.line,
                0,
                format!("{name} with the spindle speed at 0 (no S): the move cannot be timed"),
            ));
        }
        if tap
            && let Some(a) = axes
                .iter()
                .find(|a| !matches!(a, Axis::X | Axis::Y | Axis::Z))
        {
            return Err(GcodeError::unsupported(
                s.line,
                w.get(a.letter()).map_or(0, |l| l.column),
                "G33.1 with an A, B, C, U, V or W word (LinuxCNC taps along X Y Z only)",
            ));
        }
        self.check_rotation(s)?;
        words.expanded = true;
        let start = self.comp.physical_start(&st.position);
        let feed = Feed::PerRevolution { mm_per_rev: k, rpm };
        let lin = Linear {
            from: self.event_point(&start),
            to: self.event_point(&to),
            offset: st.offset,
            feed,
            tcp: st.tcp,
            words,
        };
        s.emit(EventKind::Feed(lin));
        if tap {
            // The retract: the spindle reversed at I times the speed.
            let factor = w.get(b'I').map_or(1.0, |i| i.value).max(1.0);
            s.emit(EventKind::Feed(Linear {
                from: lin.to,
                to: lin.from,
                feed: Feed::PerRevolution {
                    mm_per_rev: k,
                    rpm: rpm * factor,
                },
                ..lin
            }));
        } else {
            self.state.position = to;
        }
        Ok(())
    }

    /// G76, LinuxCNC's threading cycle ([`threading_cycle`]): from the
    /// drive line (the current X and Z) the passes along Z to the block's Z,
    /// synchronised to the spindle at P per revolution (the tapers at their
    /// longer advance), then a rapid to the block's end point. X is the
    /// depth and Z the length whatever the plane, as in LinuxCNC. Its errors
    /// are LinuxCNC's (cutter compensation on, spindle stopped, rotary or
    /// UVW axis words that move, I = 0, J ≤ 0, K ≤ J, L negative, H or L
    /// not an integer); refused as unsupported: P ≤ 0 or no spindle speed
    /// (no time for the passes). More than
    /// [`MAX_THREADING_PASSES`](crate::limits::MAX_THREADING_PASSES) passes
    /// in one block are refused (a bound of mtwin). The moves are marked
    /// `expanded`, as a canned cycle's.
    fn threading_cycle(
        &mut self,
        w: &BlockWords,
        axes: AxisMask,
        to: Axes,
        mut words: Programmed,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        self.comp.straight_move_started();
        if self.comp.is_on() {
            return Err(s.invalid(
                0,
                "Cannot use G76 threading cycle with cutter radius compensation on",
            ));
        }
        let st = &self.state;
        if st.spindle == SpindleState::Stopped {
            return Err(s.invalid(0, "Spindle not turning in G76"));
        }
        if let Some(a) = axes
            .iter()
            .find(|&a| !matches!(a, Axis::X | Axis::Y | Axis::Z) && to[a] != st.position[a])
        {
            let col = w.get(a.letter()).map_or(0, |l| l.column);
            return Err(s.invalid(col, "Cannot move rotary axes with G76"));
        }
        let scale = st.units.mm_per_unit();
        let value = |l: u8| w.get(l).map(|x| x.value);
        let integer = |l: u8| -> Result<Option<i64>, GcodeError> {
            match w.get(l) {
                Some(x) if x.value.fract() != 0.0 || x.value.abs() > 1e9 => Err(s.invalid(
                    x.column,
                    format!("{} word must be an integer with G76", l as char),
                )),
                Some(x) => Ok(Some(x.value as i64)),
                None => Ok(None),
            }
        };
        let h = integer(b'H')?.unwrap_or(0);
        let flags = match integer(b'L')? {
            Some(l) if l < 0 => {
                return Err(s.invalid(w.get(b'L').map_or(0, |x| x.column), "Negative L word used"));
            }
            l => l.unwrap_or(0),
        };
        let pitch = value(b'P').unwrap_or(0.0) * scale;
        if !(pitch > 0.0 && pitch.is_finite()) {
            return Err(GcodeError::unsupported(
                s.line,
                w.get(b'P').map_or(0, |p| p.column),
                "G76 with P ≤ 0 (no advance per spindle revolution to time the passes)",
            ));
        }
        let rpm = st.spindle_rpm;
        if !(rpm > 0.0 && rpm.is_finite()) {
            return Err(GcodeError::unsupported(
                s.line,
                0,
                "G76 with the spindle speed at 0 (no S): the passes cannot be timed",
            ));
        }
        let thread = threading_cycle::Thread {
            pitch,
            i: value(b'I').unwrap_or(0.0) * scale,
            j: value(b'J').unwrap_or(0.0) * scale,
            k: value(b'K').unwrap_or(0.0) * scale,
            compound_deg: value(b'Q').filter(|&q| q != -1.0).unwrap_or(0.0),
            full_depth_passes: u32::try_from((h + 1).max(0)).unwrap_or(u32::MAX),
            degression: value(b'R').filter(|&r| r >= 1.0).unwrap_or(1.0),
            taper: value(b'E').map_or(0.0, |e| (e * scale).max(0.0)),
            taper_flags: u32::try_from(flags & 3).unwrap_or(0),
        };
        let start = st.position;
        let moves = thread
            .moves(
                [start[Axis::X], start[Axis::Z]],
                to[Axis::Z],
                crate::limits::MAX_THREADING_PASSES,
            )
            .map_err(|e| s.invalid(0, e.to_string()))?;
        self.check_rotation(s)?;
        words.expanded = true;
        let mut from = self.comp.physical_start(&start);
        let mut emit = |this: &Self, end: Axes, feed: Feed, s: &mut Step| {
            let lin = Linear {
                from: this.event_point(&from),
                to: this.event_point(&end),
                offset: this.state.offset,
                feed,
                tcp: this.state.tcp,
                words,
            };
            s.emit(if feed == Feed::Rapid {
                EventKind::Traverse(lin)
            } else {
                EventKind::Feed(lin)
            });
            from = end;
        };
        for m in moves {
            let (xz, feed) = match m {
                threading_cycle::ThreadMove::Rapid(p) => (p, Feed::Rapid),
                threading_cycle::ThreadMove::Sync { to, mm_per_rev } => {
                    (to, Feed::PerRevolution { mm_per_rev, rpm })
                }
            };
            let mut end = start;
            end[Axis::X] = xz[0];
            end[Axis::Z] = xz[1];
            emit(self, end, feed, s);
        }
        emit(self, to, Feed::Rapid, s);
        self.state.position = to;
        Ok(())
    }

    /// What a move of cutter radius compensation carries besides its
    /// geometry.
    fn move_info(&self, at: SourcePos, column: usize, words: Programmed, feed: Feed) -> MoveInfo {
        let st = &self.state;
        MoveInfo {
            at,
            column,
            plane: st.plane,
            units: st.units,
            offset: st.offset,
            tcp: st.tcp,
            words,
            feed,
        }
    }

    /// The feed of a G1, G2 or G3 move in the current feed mode.
    fn feed(&self, w: &BlockWords, line: u64) -> Result<Feed, GcodeError> {
        let st = &self.state;
        match st.feed_mode {
            FeedMode::UnitsPerMinute => {
                if st.feed <= 0.0 {
                    return Err(GcodeError::invalid(
                        line,
                        0,
                        "Cannot do G1, G2 or G3 with zero feed rate",
                    ));
                }
                Ok(Feed::PerMinute(st.feed))
            }
            FeedMode::InverseTime => {
                if w.get(b'F').is_none() {
                    return Err(GcodeError::invalid(
                        line,
                        0,
                        "F word missing with inverse time G1, G2 or G3 move",
                    ));
                }
                if st.feed <= 0.0 {
                    return Err(GcodeError::invalid(line, 0, "zero inverse-time feed rate"));
                }
                Ok(Feed::InverseTime(st.feed))
            }
            FeedMode::UnitsPerRevolution => {
                if st.feed <= 0.0 {
                    return Err(GcodeError::invalid(
                        line,
                        0,
                        "Cannot do G1, G2 or G3 with zero feed per revolution",
                    ));
                }
                if st.spindle_rpm <= 0.0 {
                    return Err(GcodeError::invalid(
                        line,
                        0,
                        "Cannot feed with zero spindle speed in feed per rev mode",
                    ));
                }
                Ok(Feed::PerRevolution {
                    mm_per_rev: st.feed,
                    rpm: st.spindle_rpm,
                })
            }
        }
    }

    /// M2, M30: end of program (M0, M1, M60 do not change the motion).
    /// Every stop releases the moves cutter compensation holds back, as they
    /// are; M2 and M30 also turn it off.
    fn stop(&mut self, codes: &Codes, s: &mut Step) -> Result<(), GcodeError> {
        let Some((code, _)) = codes.m_stop else {
            return Ok(());
        };
        let end = matches!(code, 2 | 30);
        let plane = self.state.plane;
        self.comp
            .stop(&self.state.position, plane, end, s.out, s.line)?;
        if end {
            self.ended = true;
            s.emit(EventKind::ProgramEnd);
        } else {
            s.emit(EventKind::Wait(TaskWait::Pause));
        }
        Ok(())
    }

    /// G40, G41, G42, G41.1, G42.1: cutter radius compensation off or on,
    /// with the radius of the D word's tool (G41, G42: the tool in the
    /// spindle without D) or half the D word (G41.1, G42.1), as LinuxCNC
    /// reads them. See [`cutter_comp`].
    fn cutter_compensation(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.cutter_comp else {
            return Ok(());
        };
        let plane = self.state.plane;
        if code == GCode::G40 {
            return self
                .comp
                .turn_off(&mut self.state.position, plane, s.out, s.line, col);
        }
        if let Dialect::Fanuc { .. } = self.opts.dialect {
            return Err(GcodeError::unsupported(
                s.line,
                col,
                format!(
                    "cutter radius compensation {code} in the Fanuc dialect (its offset numbers \
                     and start-up rules are not LinuxCNC's)"
                ),
            ));
        }
        if self.state.rotation != 0.0 {
            return Err(GcodeError::unsupported(
                s.line,
                col,
                format!(
                    "cutter radius compensation {code} in a rotated coordinate system (G10 L2 R)"
                ),
            ));
        }
        self.comp.check_turn_on(plane, s.line, col)?;
        let left = matches!(code, GCode::G41 | GCode::G41_1);
        let name = if left { 41 } else { 42 };
        let (radius, orientation) = if matches!(code, GCode::G41_1 | GCode::G42_1) {
            let d = w
                .get(b'D')
                .ok_or_else(|| s.invalid(col, format!("G{name}.1 with no D word")))?;
            let orientation = match w.get(b'L') {
                None => 0,
                Some(l) => {
                    if plane != Plane::Zx {
                        return Err(s.invalid(
                            l.column,
                            format!("G{name}.1 with L word, but plane is not G18"),
                        ));
                    }
                    cutter_comp::lathe_orientation(l.value).map_err(|m| s.invalid(l.column, m))?
                }
            };
            (d.value / 2.0 * self.state.units.mm_per_unit(), orientation)
        } else {
            let (tool, column) = match w.get(b'D') {
                None => (self.spindle_entry_tool(codes), col),
                Some(d) => {
                    // LinuxCNC: the nearest integer, within 0.0001.
                    let t = (d.value + 0.5).trunc();
                    if (t - d.value).abs() >= 0.0001 {
                        return Err(s.invalid(
                            d.column,
                            format!("G{name} requires D word to be a whole number"),
                        ));
                    }
                    if t < 0.0 {
                        return Err(s.invalid(d.column, "Negative d word tool radius index used"));
                    }
                    if t > f64::from(u32::MAX) {
                        return Err(s.invalid(
                            d.column,
                            format!("Requested tool {t} not found in the tool table"),
                        ));
                    }
                    // D0: the tool in the spindle.
                    match t as u32 {
                        0 => (self.spindle_entry_tool(codes), d.column),
                        t => (t, d.column),
                    }
                }
            };
            let (diameter, orientation) = if tool == 0 {
                (0.0, 0)
            } else {
                let t = self.tools.get(tool).ok_or_else(|| {
                    s.invalid(
                        column,
                        format!("Requested tool {tool} not found in the tool table"),
                    )
                })?;
                (t.diameter, t.orientation)
            };
            if orientation != 0 && orientation != 9 && plane != Plane::Zx {
                return Err(s.invalid(
                    col,
                    format!("G{name} with lathe tool, but plane is not G18"),
                ));
            }
            (diameter / 2.0, orientation)
        };
        let side = if left { Side::Left } else { Side::Right };
        self.comp.turn_on(side, radius, orientation, plane);
        Ok(())
    }

    /// Centre (work X Y Z) and signed turns of a G2/G3 block.
    fn arc_center(
        &self,
        w: &BlockWords,
        from: &Axes,
        to: &Axes,
        ccw: bool,
        line: u64,
    ) -> Result<([f64; 3], i32), GcodeError> {
        let st = &self.state;
        let (p, q, n) = st.plane.axes();
        let offset_letter = |a: Axis| match a {
            Axis::X => b'I',
            Axis::Y => b'J',
            _ => b'K',
        };
        let (lp, lq, ln) = (offset_letter(p), offset_letter(q), offset_letter(n));
        if let Some(x) = w.get(ln) {
            let plane = match st.plane {
                Plane::Xy => "XY",
                Plane::Zx => "XZ",
                Plane::Yz => "YZ",
            };
            return Err(GcodeError::invalid(
                line,
                x.column,
                format!("{} word given for arc in {plane} plane", ln as char),
            ));
        }
        let turns = match w.get(b'P') {
            None => 1,
            Some(pw) => {
                if pw.value.fract() != 0.0 {
                    return Err(GcodeError::invalid(
                        line,
                        pw.column,
                        "P value not an integer with G2 or G3",
                    ));
                }
                if pw.value < 1.0 || pw.value > f64::from(i32::MAX) {
                    return Err(GcodeError::invalid(
                        line,
                        pw.column,
                        "P value not positive with G2 or G3",
                    ));
                }
                pw.value as i32
            }
        };
        let s = [from[p], from[q]];
        let e = [to[p], to[q]];
        let scale = st.units.mm_per_unit();
        let dim = |l: &Letter| {
            self.opts
                .dialect
                .dimension(l.value, l.has_point, st.units == Units::Inch, false)
                * scale
        };
        let arc_err = |e: ArcError| GcodeError::invalid(line, 0, e.to_string());
        let (ip, iq, r) = (w.get(lp), w.get(lq), w.get(b'R'));
        let c = match (ip.is_some() || iq.is_some(), r) {
            (true, Some(rw)) => {
                return Err(GcodeError::invalid(
                    line,
                    rw.column,
                    "Mixed radius-ijk format for arc",
                ));
            }
            (false, None) => {
                return Err(GcodeError::invalid(
                    line,
                    0,
                    "R, I, J and K words all missing for arc",
                ));
            }
            (false, Some(rw)) => {
                arc::center_from_radius(s, e, dim(rw), ccw, st.units).map_err(arc_err)?
            }
            (true, None) => {
                if st.arc_distance == DistanceMode::Absolute {
                    // G90.1: both centre words, as LinuxCNC requires.
                    for (l, x) in [(lp, ip), (lq, iq)] {
                        if x.is_none() {
                            return Err(GcodeError::invalid(
                                line,
                                0,
                                format!("{} word missing in absolute center arc", l as char),
                            ));
                        }
                    }
                }
                let (op, oq) = (ip.map_or(0.0, dim), iq.map_or(0.0, dim));
                let c = match st.arc_distance {
                    DistanceMode::Incremental => [s[0] + op, s[1] + oq],
                    DistanceMode::Absolute => [op, oq],
                };
                arc::check_center(s, e, c, st.units).map_err(arc_err)?;
                c
            }
        };
        let mut center = from.xyz();
        center[p.index()] = c[0];
        center[q.index()] = c[1];
        Ok((center, if ccw { turns } else { -turns }))
    }
}

/// The motion mode a group-1 code sets (G80 excluded).
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

#[cfg(test)]
mod tests {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    use super::*;
    use crate::gcode::stream::Program;

    fn run_with(src: &str, opts: InterpOptions) -> Result<Vec<Event>, GcodeError> {
        let program = Program::parse(src.as_bytes())?;
        let mut it = Interpreter::new(opts);
        let mut out = Vec::new();
        for b in &program.blocks {
            it.execute(b, &mut out)?;
        }
        Ok(out)
    }

    fn run(src: &str) -> Vec<Event> {
        run_with(src, InterpOptions::default()).unwrap()
    }

    fn moves(events: &[Event]) -> Vec<EventKind> {
        events
            .iter()
            .filter(|e| {
                matches!(
                    e.kind,
                    EventKind::Traverse(_) | EventKind::Feed(_) | EventKind::Arc(_)
                )
            })
            .map(|e| e.kind)
            .collect()
    }

    fn arc(kind: &EventKind) -> &ArcMove {
        match kind {
            EventKind::Arc(a) => a,
            other => panic!("not an arc: {other:?}"),
        }
    }

    fn lin(kind: &EventKind) -> &Linear {
        match kind {
            EventKind::Traverse(m) | EventKind::Feed(m) => m,
            other => panic!("not a straight move: {other:?}"),
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn full_circle_in_xy() {
        let m = moves(&run("G0 X10 Y0\nG2 X10 Y0 I-10 J0 F100\n"));
        let a = arc(&m[1]);
        assert_eq!(a.center, [0.0, 0.0, 0.0]);
        assert_eq!(a.turns, -1);
        assert!(close(a.sweep(), -2.0 * PI));
        assert!(close(a.xyz_length(), 2.0 * PI * 10.0));
        assert_eq!(a.feed, Feed::PerMinute(100.0));
    }

    #[test]
    fn zx_plane_uses_k_and_i_and_turns_about_plus_y() {
        // G18: first axis Z, second X, normal +Y. From (X0, Z10) about the
        // origin to (X10, Z0): in (z, x) that is (10, 0) to (0, 10), a quarter
        // turn counter-clockwise about +Y, i.e. G3.
        let m = moves(&run("G18 G0 X0 Z10\nG3 X10 Z0 K-10 F50\n"));
        let a = arc(&m[1]);
        assert_eq!(a.plane, Plane::Zx);
        assert_eq!(a.center, [0.0, 0.0, 0.0]);
        assert!(close(a.sweep(), FRAC_PI_2));
        assert_eq!(a.normal(), [0.0, 1.0, 0.0]);
        // A J word is out of the ZX plane.
        assert!(
            run_with(
                "G18 G0 X0 Z10\nG3 X10 Z0 K-10 J1 F50\n",
                InterpOptions::default()
            )
            .is_err()
        );
    }

    #[test]
    fn helix_in_yz_with_turns_and_r_format() {
        // G19 plane: (y, z), normal +X. Two full turns plus nothing, rising 6 in X.
        let m = moves(&run("G19 G0 Y5 Z0\nG2 Y5 Z0 X6 J-5 P2 F10\n"));
        let a = arc(&m[1]);
        assert_eq!(a.turns, -2);
        assert!(close(a.sweep(), -4.0 * PI));
        assert!(close(a.xyz_length(), (4.0 * PI * 5.0f64).hypot(6.0)));
        // R format: half circle of radius 5 from (0,0) to (10,0), G2 goes over +Y.
        let m = moves(&run("G0 X0 Y0\nG2 X10 Y0 R5 F10\n"));
        let a = arc(&m[1]);
        assert!(close(a.center[0], 5.0) && close(a.center[1], 0.0));
        assert!(close(a.sweep(), -PI));
    }

    #[test]
    fn units_distance_and_absolute_arc_centres() {
        let m = moves(&run("G20 G91 G0 X1 Y2\nX1\nG90 G90.1 G3 X0 Y0 I1 J1 F10\n"));
        let (l0, l1) = (lin(&m[0]), lin(&m[1]));
        assert!(close(l0.to[Axis::X], 25.4) && close(l0.to[Axis::Y], 50.8));
        assert!(close(l1.to[Axis::X], 50.8));
        let a = arc(&m[2]);
        assert!(close(a.center[0], 25.4) && close(a.center[1], 25.4));
        // Feed in inch/min is converted to mm/min.
        assert_eq!(a.feed, Feed::PerMinute(10.0 * 25.4));
    }

    #[test]
    fn work_offsets_g53_and_tool_length() {
        let mut opts = InterpOptions::default();
        opts.work_offsets[1][Axis::X] = 100.0; // G55
        opts.work_offsets[1][Axis::Z] = -50.0;
        opts.tools.insert(crate::gcode::Tool::with_length(3, 20.0));
        let src = "G55 G0 X1 Z0\nG53 G0 Z-10\nT3 M6\nG43 H3\nG0 Z0\nG49 G0 Z0\n";
        let m = moves(&run_with(src, opts).unwrap());
        let l = lin(&m[0]);
        assert!(
            close(l.to[Axis::X] + l.offset[Axis::X], 101.0),
            "machine X = work + offset"
        );
        assert!(close(l.to[Axis::Z] + l.offset[Axis::Z], -50.0));
        let g53 = lin(&m[1]);
        assert!(g53.words.g53);
        assert!(
            close(g53.to[Axis::Z] + g53.offset[Axis::Z], -10.0),
            "G53 Z is machine Z"
        );
        assert!(close(g53.to[Axis::Z], 40.0));
        let tlo = lin(&m[2]);
        assert!(close(tlo.offset[Axis::Z], -50.0 + 20.0));
        assert!(
            close(tlo.from[Axis::Z], 40.0 - 20.0),
            "G43 keeps the machine position"
        );
        assert!(close(tlo.to[Axis::Z] + tlo.offset[Axis::Z], -30.0));
        assert!(close(lin(&m[3]).offset[Axis::Z], -50.0));
    }

    #[test]
    fn word_value_recovers_the_written_word() {
        let mut opts = InterpOptions::default();
        opts.work_offsets[0][Axis::Z] = -7.0;
        let src = "G20 G0 Z1.5\nG91 G1 Z-0.25 F10\nG90 G53 G0 Z-2\n";
        let events = run_with(src, opts).unwrap();
        let written = [1.5, -0.25, -2.0];
        for (kind, w) in moves(&events).iter().zip(written) {
            let l = lin(kind);
            assert!(close(
                l.words
                    .word_value(Axis::Z, &l.from, l.to[Axis::Z], &l.offset),
                w
            ));
        }
    }

    #[test]
    fn rotary_rollover_follows_linuxcnc() {
        let mut opts = InterpOptions::default();
        opts.wrapped_rotary.insert(Axis::C);
        let m = moves(&run_with("G0 C350\nC10\nC-350\nC-0\n", opts).unwrap());
        let c: Vec<f64> = m.iter().map(|k| lin(k).to[Axis::C]).collect();
        // 350 → +10 goes forward to 370; -350 goes backwards to the angle 10
        // (mod 360) below 370, i.e. 10; -0 goes backwards to 0.
        assert_eq!(c, [350.0, 370.0, 10.0, 0.0]);
        assert!(
            run_with(
                "G0 C360\n",
                InterpOptions {
                    wrapped_rotary: {
                        let mut m = AxisMask::EMPTY;
                        m.insert(Axis::C);
                        m
                    },
                    ..Default::default()
                }
            )
            .is_err()
        );
    }

    /// The commands LinuxCNC's task waits for motion before are events, in
    /// its order within a block (outputs and input waits, tool change,
    /// spindle, orientation, coolant; stops after the motion).
    #[test]
    fn task_waits_are_events() {
        use TaskWait::*;
        let ev = run(
            "T1 M6\nM8\nG0 X1 M9\nM7\nM19\nM64 P0\nM65 P0\nM66 P0 L0\nM68 E0 Q1\nM62 P0\nM0\nM1\nM60\nT2 M6 M3 M64 P1 M8\nG0 X2 M1\nM61 Q0\nM30\n",
        );
        let waits: Vec<(u64, TaskWait)> = ev
            .iter()
            .filter_map(|e| match e.kind {
                EventKind::Wait(w) => Some((e.at.line, w)),
                _ => None,
            })
            .collect();
        let want = vec![
            (1, ToolChange),
            (2, FloodOn),
            (3, MistOff),
            (3, FloodOff),
            (4, MistOn),
            (5, SpindleOrient),
            (6, Output),
            (7, Output),
            (8, InputWait),
            (9, Output),
            (11, Pause),
            (12, Pause),
            (13, Pause),
            (14, Output),
            (14, ToolChange),
            (14, FloodOn),
            (15, Pause),
            (16, ToolNumber),
        ];
        assert_eq!(waits, want);
        // M9 before the move of its block, M1 after it.
        let k = |line: u64| {
            ev.iter()
                .position(|e| e.at.line == line && matches!(e.kind, EventKind::Traverse(_)))
                .unwrap()
        };
        let w = |line: u64| {
            ev.iter()
                .position(|e| e.at.line == line && matches!(e.kind, EventKind::Wait(_)))
                .unwrap()
        };
        assert!(w(3) < k(3) && k(15) < w(15));
        // The spindle start of line 14 comes between its tool change and coolant.
        let spindle = ev
            .iter()
            .position(|e| e.at.line == 14 && matches!(e.kind, EventKind::Spindle(_)))
            .unwrap();
        assert!(ev[spindle - 1].kind == EventKind::Wait(ToolChange));
        assert!(ev[spindle + 1].kind == EventKind::Wait(FloodOn));
    }

    #[test]
    fn a_probe_that_fails_without_contact_must_move() {
        // LinuxCNC 2.9 (its standalone rs274 run on each): G38.2 and G38.4
        // to their start on every axis are refused; G38.3 and G38.5 there
        // run; any other end runs, however close (0.009 in, 0.2 mm, an A
        // move alone).
        let opts = InterpOptions::default;
        for (src, ok) in [
            ("G21 G0 X0 Y0 Z0\nG38.2 Z-0.2 F100\nM2\n", true),
            ("G20 G0 X0 Y0 Z0\nG38.2 Z-0.009 F100\nM2\n", true),
            ("G21 G0 X0 Y0 Z0\nG38.2 A0.1 F100\nM2\n", true),
            ("G21 G0 X0 Y0 Z0\nG38.2 Z0 F100\nM2\n", false),
            ("G21 G0 X0 Y0 Z0\nG91 G38.4 X0 F100\nM2\n", false),
            ("G21 G0 X0 Y0 Z0\nG38.3 X0 Z0 F100\nM2\n", true),
            ("G21 G0 X0 Y0 Z0\nG91 G38.5 Z0 F100\nM2\n", true),
        ] {
            match run_with(src, opts()) {
                Ok(_) => assert!(ok, "{src} accepted"),
                Err(e) => {
                    assert!(!ok, "{src}: {e}");
                    let m = e.to_string();
                    assert!(m.contains("Start point too close to probe point"), "{m}");
                    // The column of the G38 word on line 2.
                    let col = src.lines().nth(1).unwrap().find("G38").unwrap() + 1;
                    assert!(m.contains(&format!("line 2, column {col}")), "{m}");
                }
            }
        }
        let e = run_with("G21 G95 S100 M3\nG38.2 Z-1 F1\nM2\n", opts()).unwrap_err();
        assert!(
            e.to_string()
                .contains("Cannot probe with feed per rev mode"),
            "{e}"
        );
    }

    #[test]
    fn a_probe_runs_to_its_end_without_contact() {
        // #5061–#5069: the end in program units and the frame the probe ran
        // in (G55 X 1 in, G92 X0 at X 1: program X 0.5 is machine 2.5);
        // #5070 = 0 (not tripped), whatever the program set before. The
        // G1 reads them: X 0.5 + 1 = 1.5 in, Y 0.7 + 100·0, Z -0.5 in.
        let mut opts = InterpOptions::default();
        opts.work_offsets[1][Axis::X] = 25.4;
        let src = "G20 G55 G0 X1 Y1 Z1\nG92 X0\n#5070=1\nF10 G38.2 X0.5 Y0.7 Z-0.5\n\
                   G1 X[#5061+1] Y[#5062+#5070*100] Z#5063\nM2\n";
        let ev = run_with(src, opts).unwrap();
        let got = ends(&ev);
        let want = [0.5 * 25.4, 0.7 * 25.4, -0.5 * 25.4];
        let probe = got[got.len() - 2].1;
        let last = got[got.len() - 1].1;
        for i in 0..3 {
            assert!(close(probe[i], want[i]), "{got:?}");
        }
        assert!(close(last[0], 1.5 * 25.4), "{got:?}");
        assert!(
            close(last[1], want[1]) && close(last[2], want[2]),
            "{got:?}"
        );
    }

    #[test]
    fn modes_events_and_tcp() {
        let ev = run(
            "M428\nG93 G1 X1 F2\nG94 F300 S1000 M3\nG4 P1.5\nM429\nG43.4 H0\nG49\nM30\nG0 X99\n",
        );
        let kinds: Vec<EventKind> = ev.iter().map(|e| e.kind).collect();
        assert!(kinds.contains(&EventKind::Tcp(true)));
        assert!(matches!(
            kinds[3],
            EventKind::Feed(Linear {
                feed: Feed::InverseTime(2.0),
                tcp: true,
                ..
            })
        ));
        assert!(kinds.contains(&EventKind::FeedRate(300.0)));
        assert!(kinds.contains(&EventKind::SpindleSpeed { rpm: 1000.0 }));
        assert!(kinds.contains(&EventKind::Spindle(SpindleState::Clockwise)));
        assert!(kinds.contains(&EventKind::Dwell { seconds: 1.5 }));
        let tcp: Vec<bool> = kinds
            .iter()
            .filter_map(|k| {
                if let EventKind::Tcp(on) = k {
                    Some(*on)
                } else {
                    None
                }
            })
            .collect();
        assert_eq!(tcp, [true, false, true, false]);
        assert_eq!(
            kinds.last(),
            Some(&EventKind::ProgramEnd),
            "nothing after M30"
        );
        assert_eq!(
            ev[0].at,
            SourcePos {
                line: 1,
                block: 0,
                file: 0
            }
        );
        assert_eq!(
            ev.last().unwrap().at,
            SourcePos {
                line: 8,
                block: 7,
                file: 0
            }
        );
    }

    #[test]
    fn rejections_name_the_line() {
        let cases = [
            // G76 without a spindle speed (no time), or with it stopped.
            ("M3\nG76 P1 Z-1 I-0.1 J0.1 K0.2\n", 2, true),
            ("G0 X0\nG76 P1 Z-1 I-0.1 J0.1 K0.2\n", 2, false),
            // G33/G33.1: K missing, F with it, spindle stopped, no axis,
            // I with G33 (LinuxCNC's errors); no spindle speed, rotary
            // word on G33.1, compensation on, K ≤ 0 (cannot be timed).
            ("S100 M3\nG33 Z-1\n", 2, false),
            ("S100 M3\nG33 Z-1 K1 F10\n", 2, false),
            ("S100 M3\nM5\nG33.1 Z-1 K1\n", 3, false),
            ("S100 M3\nG33 K1\n", 2, false),
            ("S100 M3\nG33 I1 Z-1 K1\n", 2, false),
            ("M3\nG33 Z-1 K1\n", 2, true),
            ("S100 M3\nG33.1 Z-1 A1 K1\n", 2, true),
            (
                "S100 M3\nG0 X-5\nG41.1 D1\nG1 X5 F10\nG33 X10 K1\n",
                5,
                true,
            ),
            ("S100 M4\nG33 Z-1 K0\n", 2, true),
            // Cutter radius compensation: entry not longer than the radius,
            // plane change while on, G19, G41.1 without D.
            ("G41.1 D4\nG0 X1\n", 2, false),
            ("G41.1 D4\nG0 X10\nG18\n", 3, false),
            ("G19 G41.1 D4\n", 1, false),
            ("G41.1\n", 1, false),
            // Not with a coordinate system rotation (G10 L2 R) in force.
            ("G10 L2 P1 R30\nG0 X1\nG41.1 D4\n", 3, true),
            ("G1 X1\n", 1, false),             // zero feed
            ("G93\nG1 X1 F1\nX2\n", 3, false), // inverse time needs F each move
            ("X1\n", 1, false),                // no motion mode
            ("G0 G1 X1\n", 1, false),          // one modal group twice
            ("G0 X1 X2\n", 1, false),          // two X words
            ("o100 sub\n", 1, true),
            ("G1 X1 I2 F1\n", 1, false),    // I without arc
            ("G2 X1 F1\n", 1, false),       // no IJKR
            ("G2 X1 I1 R1 F1\n", 1, false), // mixed formats
            ("G2 X30 R10 F1\n", 1, false),  // radius too small
            ("M123\n", 1, true),
            ("G53 G91 G0 X1\n", 1, false),
            ("G43 H7\n", 1, false), // tool not in the table
        ];
        for (src, line, unsupported) in cases {
            let err = run_with(src, InterpOptions::default()).expect_err(src);
            assert_eq!(err.location().map(|l| l.line), Some(line), "{src}: {err}");
            assert_eq!(
                matches!(err, GcodeError::Unsupported { .. }),
                unsupported,
                "{src}: {err}"
            );
        }
        let ignore = InterpOptions {
            unknown_m: UnknownMCode::Ignore,
            ..Default::default()
        };
        assert!(run_with("M123\n", ignore).is_ok());
    }

    #[test]
    fn fanuc_dwell_and_integer_words() {
        let fanuc = InterpOptions {
            dialect: Dialect::Fanuc {
                decimal_point_programming: false,
            },
            ..Default::default()
        };
        let ev = run_with(
            "G4 P1500\nG4 X2.5\nG4 X2500\nG4 U750\nG0 X10 Y10.\n",
            fanuc.clone(),
        )
        .unwrap();
        let dwell: Vec<f64> = ev
            .iter()
            .filter_map(|e| {
                if let EventKind::Dwell { seconds } = e.kind {
                    Some(seconds)
                } else {
                    None
                }
            })
            .collect();
        // P in ms; X/U with a point in s, without one in 0.001 s.
        assert_eq!(dwell, [1.5, 2.5, 2.5, 0.75]);
        let l = lin(&moves(&ev)[0]).to;
        assert!(close(l[Axis::X], 0.01) && close(l[Axis::Y], 10.0));
        assert!(matches!(
            run_with("G90.1\n", fanuc),
            Err(GcodeError::Unsupported { .. })
        ));
        // LinuxCNC: P in seconds.
        let ev = run("G4 P1.5\n");
        assert_eq!(ev[0].kind, EventKind::Dwell { seconds: 1.5 });
    }

    #[test]
    fn block_delete_and_percent() {
        let m = moves(&run("%\n/G0 X5\nG0 Y1\n%\n"));
        assert_eq!(m.len(), 1);
        let keep = InterpOptions {
            skip_deleted_blocks: false,
            ..Default::default()
        };
        assert_eq!(moves(&run_with("/G0 X5\n", keep).unwrap()).len(), 1);
    }

    /// Words no code of the block reads are refused as LinuxCNC refuses
    /// them; the same words are accepted beside the codes that read them.
    #[test]
    fn unused_words_are_refused_like_linuxcnc() {
        let err = |src: &str| match run_with(src, InterpOptions::default()) {
            Err(GcodeError::Invalid { at, message }) => (at.column, message),
            other => panic!("{src}: expected an invalid block, got {other:?}"),
        };
        // `X1e3` is X1 and E3: refused, with the exponent explained.
        let (col, m) = err("G1 X1e3 F100\n");
        assert_eq!(col, 6, "{m}");
        assert!(m.starts_with("E word with no G76, M66, M67 or M68"), "{m}");
        assert!(m.contains("no exponent"), "{m}");
        let (col, m) = err("G1 X10 E5 F100\n");
        assert_eq!(col, 8);
        assert!(m.starts_with("E word") && !m.contains("exponent"), "{m}");
        let (col, m) = err("G1 X10 Q5 F100\n");
        assert_eq!(col, 8);
        assert!(m.starts_with("Q word with no"), "{m}");
        assert!(err("G1 X10 P2 F100\n").1.starts_with("P word with no"));
        assert!(err("G0 X1 L2\n").1.starts_with("L word with no"));
        assert!(err("G0 X1 D1\n").1.starts_with("D word with no"));
        assert!(err("G0 X1 H1\n").1.starts_with("H word with no G43"));
        // Beside the codes that read them the words are fine.
        for ok in [
            "G4 P1\n",
            "G64 P0.01 Q0.01\n",
            "G2 X10 I5 P2 F100\n",
            "M66 P0 L0 Q1\n",
            "M68 E0 Q1\n",
            "M61 Q0\n",
            "G43 H0\n",
            "N10 G0 X1\n",
            "/N10.5 G0 X1\n",
        ] {
            run_with(ok, InterpOptions::default()).unwrap_or_else(|e| panic!("{ok}: {e}"));
        }
    }

    /// A line number only starts a block and is an unsigned integer.
    #[test]
    fn line_numbers_as_linuxcnc_reads_them() {
        for bad in [
            "G0 N10 X1\n",
            "N-5 G0 X1\n",
            "N[1] G0 X1\n",
            "(c) N1 G0 X1\n",
        ] {
            assert!(
                matches!(
                    Program::parse(bad.as_bytes()),
                    Err(GcodeError::Syntax { .. })
                ),
                "{bad} must be a syntax error"
            );
        }
        // `N1e5` is N1 followed by an E word nothing reads.
        assert!(matches!(
            run_with("N1e5\n", InterpOptions::default()),
            Err(GcodeError::Invalid { .. })
        ));
    }
    /// Move ends (work X Y Z) and kinds, for the expansion tests.
    fn ends(events: &[Event]) -> Vec<(char, [f64; 3])> {
        moves(events)
            .iter()
            .map(|k| match k {
                EventKind::Traverse(l) => ('R', l.to.xyz()),
                EventKind::Feed(l) => ('F', l.to.xyz()),
                EventKind::Arc(a) => ('A', a.to.xyz()),
                _ => unreachable!(),
            })
            .collect()
    }

    fn assert_ends(got: &[(char, [f64; 3])], want: &[(char, [f64; 3])]) {
        assert_eq!(got.len(), want.len(), "{got:?}\n{want:?}");
        for (g, w) in got.iter().zip(want) {
            assert_eq!(g.0, w.0, "{got:?}\n{want:?}");
            for k in 0..3 {
                assert!(close(g.1[k], w.1[k]), "{got:?}\n{want:?}");
            }
        }
    }

    #[test]
    fn g80_shares_a_line_with_a_motion_code() {
        // LinuxCNC's read_g: G80 beside another motion code is ignored.
        let m = moves(&run("G0 G17 G40 G49 G80 G90 X1\n"));
        assert!(close(lin(&m[0]).to[Axis::X], 1.0));
        assert!(matches!(m[0], EventKind::Traverse(_)));
        let m = moves(&run("G80 G1 X2 F100\n"));
        assert!(matches!(m[0], EventKind::Feed(_)));
        // G80 alone with axis words: no motion mode.
        assert!(run_with("G80 X1\n", InterpOptions::default()).is_err());
        // Fanuc: G80 has its own group; the line reads the same.
        let fanuc = InterpOptions {
            dialect: Dialect::Fanuc {
                decimal_point_programming: true,
            },
            ..Default::default()
        };
        let m = moves(&run_with("G0 G80 X1.\n", fanuc.clone()).unwrap());
        assert!(close(lin(&m[0]).to[Axis::X], 1.0));
        // Two codes of one motion group are still refused.
        assert!(run_with("G0 G1 X1\n", fanuc).is_err());
    }

    #[test]
    fn reading_stops_at_the_program_end() {
        // After M30 nothing is interpreted (the callers stop reading).
        let text = "G0 X1\nM30\nPost Process Timed at; 32 Min, 50.0 sec\n";
        let mut got = Vec::new();
        crate::gcode::interpret(text.as_bytes(), InterpOptions::default(), |_, e| {
            got.extend_from_slice(e);
            Ok(())
        })
        .unwrap();
        assert_eq!(moves(&got).len(), 1);
        // A file starting with '%' ends at the next '%' line.
        let text = "\n%\nG0 X1\n%\nthis is not G-code\n";
        let mut n = 0;
        crate::gcode::interpret(text.as_bytes(), InterpOptions::default(), |_, e| {
            n += moves(e).len();
            Ok(())
        })
        .unwrap();
        assert_eq!(n, 1);
        // Without a leading '%' a '%' line does not end the program.
        assert_eq!(moves(&run("G0 X1\n%\nG0 X2\n")).len(), 2);
    }

    /// The system parameters read LinuxCNC's values, derived by hand: a
    /// G54 offset X5, the machine at X8 (work X3), G92 X1 there (offset
    /// 3 − 1 = 2, work X1), tool 2 (length 7) loaded and applied (work Z
    /// 0 − 7 = −7).
    #[test]
    fn system_parameters_follow_the_state() {
        let mut opts = InterpOptions::default();
        let mut t2 = crate::gcode::Tool::with_length(2, 7.0);
        t2.offset[Axis::X] = 0.5;
        t2.diameter = 6.0;
        opts.tools.insert(t2);
        let mut it = Interpreter::new(opts);
        let src = "G10 L2 P1 X5\nG0 X3\nG92 X1\nT2 M6 G43\nG28.1\nG20\nG55\n";
        let program = Program::parse(src.as_bytes()).unwrap();
        let mut ev = Vec::new();
        let p = |it: &Interpreter, n: u32| it.parameters().get(n);
        for (k, b) in program.blocks.iter().enumerate() {
            it.execute(b, &mut ev).unwrap();
            match k {
                0 => {
                    assert_eq!(p(&it, 5221), 5.0);
                    assert_eq!(p(&it, 5420), -5.0, "machine 0 in G54 X5");
                }
                1 => assert_eq!(p(&it, 5420), 3.0),
                2 => {
                    assert_eq!((p(&it, 5210), p(&it, 5211)), (1.0, 2.0));
                    assert_eq!(p(&it, 5420), 1.0);
                    assert_eq!(p(&it, 5400), 0.0, "no tool yet");
                }
                3 => {
                    assert_eq!(p(&it, 5400), 2.0);
                    assert_eq!((p(&it, 5401), p(&it, 5403)), (0.5, 7.0));
                    assert_eq!(p(&it, 5410), 6.0);
                    // G43 applies X0.5 too: work X 1 − 0.5, Z 0 − 7.
                    assert_eq!((p(&it, 5420), p(&it, 5422)), (0.5, -7.0));
                }
                4 => {
                    // Machine X 5 + 2 + 0.5 + 0.5 = 8, Z −7 + 7 = 0.
                    assert_eq!((p(&it, 5161), p(&it, 5163)), (8.0, 0.0));
                }
                5 => {
                    // The point in inches; offsets stay in mm.
                    assert!((p(&it, 5420) - 0.5 / 25.4).abs() < 1e-12);
                    assert!((p(&it, 5422) + 7.0 / 25.4).abs() < 1e-12);
                    assert_eq!((p(&it, 5221), p(&it, 5211), p(&it, 5403)), (5.0, 2.0, 7.0));
                    assert_eq!(p(&it, 5220), 1.0);
                }
                _ => {
                    assert_eq!(p(&it, 5220), 2.0);
                    // G55 has no offset: work X = machine 8 − G92 2 − tool 0.5.
                    assert!((p(&it, 5420) - 5.5 / 25.4).abs() < 1e-12);
                }
            }
        }
        // A program cannot set them by assignment (mtwin would not use the
        // value as LinuxCNC does); the current point it may (LinuxCNC
        // overwrites it before the next line).
        for (bad, col) in [("#5221=1\n", 1), ("G0 X1 #5400=3\n", 7), ("#5161=0\n", 1)] {
            let e = run_with(bad, InterpOptions::default()).unwrap_err();
            assert!(matches!(e, GcodeError::Unsupported { .. }), "{bad}: {e}");
            assert!(
                e.to_string().contains(&format!("line 1, column {col}")),
                "{bad}: {e}"
            );
        }
        run_with("#5420=3\n#5231=1\n#5399=1\n", InterpOptions::default()).unwrap();
        // Homes and G92 come from the var file at start (5210 = 1: applied).
        let mut opts = InterpOptions::default();
        let mut start = Parameters::new();
        for (n, v) in [
            (5161, 10.0),
            (5183, -4.0),
            (5210, 1.0),
            (5211, 2.0),
            (5221, 1.0),
        ] {
            start.set(n, v).unwrap();
        }
        opts.work_offsets = start.work_offsets();
        opts.program.parameters = std::sync::Arc::new(start);
        let mut it = Interpreter::new(opts);
        assert_eq!(
            (p(&it, 5161), p(&it, 5183), p(&it, 5211)),
            (10.0, -4.0, 2.0)
        );
        assert_eq!(p(&it, 5420), -3.0, "machine 0 − G54 1 − G92 2");
        let b = Program::parse(b"G28\n").unwrap();
        let mut ev = Vec::new();
        it.execute(&b.blocks[0], &mut ev).unwrap();
        assert_eq!(p(&it, 5420), 7.0, "machine 10 − 1 − 2");
    }

    #[test]
    fn g92_family_shifts_the_program_frame() {
        // Machine at X10; G92 X0 makes it read 0: axis offset 10.
        let src = "G0 X10\nG92 X0\nG0 X5\nG92.2\nG0 X5\nG92.3\nG0 X1\nG92.1\nG0 X1\n";
        let mut it = Interpreter::new(InterpOptions::default());
        let program = Program::parse(src.as_bytes()).unwrap();
        let mut ev = Vec::new();
        for (k, b) in program.blocks.iter().enumerate() {
            it.execute(b, &mut ev).unwrap();
            if k == 1 {
                assert_eq!(it.state().axis_offset[Axis::X], 10.0);
                assert_eq!(it.state().g92_saved[Axis::X], 10.0);
                assert!(it.state().g92_applied);
                assert_eq!(it.state().position[Axis::X], 0.0);
            }
        }
        let m = moves(&ev);
        let machine = |k: usize| lin(&m[k]).to[Axis::X] + lin(&m[k]).offset[Axis::X];
        assert!(close(machine(1), 15.0), "G92: X5 is machine 15");
        assert!(close(machine(2), 5.0), "G92.2: offsets off");
        assert!(close(machine(3), 11.0), "G92.3: restored from 5211");
        assert!(close(machine(4), 1.0), "G92.1: off");
        assert_eq!(it.state().g92_saved, Axes::ZERO, "G92.1 clears 5211-5219");
        // G92 in inch, with a work offset: offset = machine - work - value.
        let mut opts = InterpOptions::default();
        opts.work_offsets[0][Axis::Y] = 100.0;
        let m = moves(&run_with("G20 G0 Y1\nG92 Y0\nG0 Y2\n", opts).unwrap());
        let l = lin(&m[1]);
        assert!(close(
            l.to[Axis::Y] + l.offset[Axis::Y],
            100.0 + 25.4 + 50.8
        ));
        // G52 sets the offset itself.
        let m = moves(&run("G0 X1\nG52 X5\nG0 X1\n"));
        let l = lin(&m[1]);
        assert!(close(l.to[Axis::X] + l.offset[Axis::X], 6.0));
        // G92 needs axis words and no motion code beside it.
        assert!(run_with("G92\n", InterpOptions::default()).is_err());
        assert!(run_with("G1 G92 X1 F10\n", InterpOptions::default()).is_err());
    }

    #[test]
    fn g10_l2_l20_set_work_offsets() {
        // G10 L2 P2 then G55 (a CAM set-up): machine = work + offset.
        let m = moves(&run("G10 L2 P2 X100 Y50 Z-20\nG55 G0 X1 Y2 Z3\n"));
        let l = lin(&m[0]);
        let machine = l.to.add(&l.offset);
        assert!(close(machine[Axis::X], 101.0) && close(machine[Axis::Y], 52.0));
        assert!(close(machine[Axis::Z], -17.0));
        // L2 P0 changes the active system at once; the tool stays where it is.
        let m = moves(&run("G0 X10\nG10 L2 P0 X4\nG0 X0\n"));
        let l = lin(&m[1]);
        assert!(close(l.from[Axis::X], 6.0) && close(l.offset[Axis::X], 4.0));
        // L20: the current position reads X3 in G54: offset = 10 - 3.
        let mut it = Interpreter::new(InterpOptions::default());
        let mut ev = Vec::new();
        for b in &Program::parse(b"G0 X10\nG10 L20 P1 X3\n").unwrap().blocks {
            it.execute(b, &mut ev).unwrap();
        }
        assert_eq!(it.state().work_offsets[0][Axis::X], 7.0);
        assert_eq!(it.state().position[Axis::X], 3.0);
        run("G10 L2 P1 X1 R0\n");
        for bad in [
            "G10 L2 P10 X1\n",
            "G10 L3 P1 X1\n",
            "G10 L2 P1.5 X1\n",
            "G0 G10 L2 P1 X1\n",
        ] {
            assert!(run_with(bad, InterpOptions::default()).is_err(), "{bad}");
        }
    }

    /// The state after running `src` (work position, machine position).
    fn state_after(src: &str) -> ModalState {
        let mut it = Interpreter::new(InterpOptions::default());
        let mut ev = Vec::new();
        for b in &Program::parse(src.as_bytes()).unwrap().blocks {
            it.execute(b, &mut ev).unwrap();
        }
        it.state().clone()
    }

    #[test]
    fn g10_l2_r_rotates_the_xy_plane() {
        let near = |a: f64, b: f64| (a - b).abs() < 1e-12;
        let xy = |v: &Axes| (v[Axis::X], v[Axis::Y]);
        // Machine = R·program + offset: R90 takes (3, 4) to (-4, 3).
        let m = moves(&run("G10 L2 P1 X2 R90\nG0 X3 Y4\n"));
        let l = lin(&m[0]);
        let machine = l.to.add(&l.offset);
        assert!(near(machine[Axis::X], -2.0) && near(machine[Axis::Y], 3.0));
        assert!(near(l.to[Axis::X], -4.0) && near(l.to[Axis::Y], 3.0));
        // Setting the rotation of the active system keeps the machine point:
        // (3, 4) in an unrotated G54 reads R(-90)·((3, 4) - (2, 0)) = (4, -1).
        let st = state_after("G0 X3 Y4\nG10 L2 P1 X2 R90\n");
        let (x, y) = xy(&st.position);
        assert!(near(x, 4.0) && near(y, -1.0), "{x} {y}");
        assert_eq!(st.rotation, 90.0);
        // Switching systems: machine (10, 0) in G55 (X5, R90) reads (0, -5).
        let st = state_after("G10 L2 P2 X5 R90\nG0 X10 Y0\nG55\n");
        let (x, y) = xy(&st.position);
        assert!(near(x, 0.0) && near(y, -5.0), "{x} {y}");
        // G92 is in the rotated frame: machine = R·(program + G92) + G5x.
        let st = state_after("G10 L2 P1 R90\nG0 X1 Y0\nG92 X0 Y0\nG0 X1\nG10 L2 P2 R0\nG55\n");
        let (x, y) = xy(&st.position);
        // Machine R90·(2, 0) = (0, 2); G55 has the G92 offset (1, 0) too.
        assert!(near(x, -1.0) && near(y, 2.0), "{x} {y}");
        // G53 to machine (10, 0) with G54 at X2 R90: R(-90)·(8, 0) = (0, -8).
        let st = state_after("G10 L2 P1 X2 R90\nG53 G0 X10 Y0\n");
        let (x, y) = xy(&st.position);
        assert!(near(x, 0.0) && near(y, -8.0), "{x} {y}");
        // G10 L20 in a rotated system: the current point reads the values.
        let st = state_after("G10 L2 P1 X2 R90\nG0 X3 Y4\nG10 L20 P1 X0 Y0\n");
        let (x, y) = xy(&st.work_offsets[0]);
        assert!(near(x, -2.0) && near(y, 3.0), "{x} {y}");
        // G28 to machine zero: R(-90)·((0, 0) - (2, 0)) = (0, 2).
        let st = state_after("G10 L2 P1 X2 R90\nG0 X3 Y4\nG28\n");
        let (x, y) = xy(&st.position);
        assert!(near(x, 0.0) && near(y, 2.0), "{x} {y}");
        // An XY arc turns with the plane: centre (1, 0) -> (0, 1), end
        // (1, 1) -> (-1, 1); its turns are unchanged.
        let m = moves(&run("G10 L2 P1 R90\nG0 X2 Y0\nG3 X1 Y1 I-1 F100\n"));
        let a = arc(&m[1]);
        assert!(near(a.center[0], 0.0) && near(a.center[1], 1.0));
        assert!(near(a.to[Axis::X], -1.0) && near(a.to[Axis::Y], 1.0));
        assert_eq!(a.turns, 1);
        // Refused: arcs of other planes, TCP.
        for bad in [
            "G10 L2 P1 R30\nG18 G2 X1 Z1 R1 F100\n",
            "G10 L2 P1 R30\nM428\nG0 X1\n",
            "G0 X1\nG92 X0\nG10 L2 P0 R30\n",
            "G10 L2 P1 R30\nG92 Y2\nG10 L20 P1 X0\n",
        ] {
            assert!(
                matches!(
                    run_with(bad, InterpOptions::default()),
                    Err(GcodeError::Unsupported { .. })
                ),
                "{bad}"
            );
        }
    }

    #[test]
    fn g10_l1_l10_l11_set_tool_entries() {
        let opts = InterpOptions {
            tools: [(1, 10.0)].into_iter().collect(),
            ..Default::default()
        };
        let mut it = Interpreter::new(opts.clone());
        let mut ev = Vec::new();
        let src = "G10 L1 P1 Z25 R3\nT1 M6 G43\nG0 Z0\nG10 L10 P1 Z5\nG10 L11 P1 Z7\n";
        for b in &Program::parse(src.as_bytes()).unwrap().blocks {
            it.execute(b, &mut ev).unwrap();
        }
        // After L1 the table holds Z25, diameter 6; G43 applies it.
        let m = moves(&ev);
        assert!(close(lin(&m[0]).offset[Axis::Z], 25.0));
        // L10: the current position (Z0 with the tool's 25) reads Z5 with
        // this tool: length = 0 + 25 - 5 = 20. L11 the same in G59.3 (zero).
        let t = it.tools().get(1).unwrap();
        assert!(close(t.offset[Axis::Z], 25.0 - 7.0));
        assert!(close(t.diameter, 6.0));
        assert!(
            run_with("G10 L1 P2 Z1\n", opts.clone()).is_err(),
            "tool 2 not in table"
        );
        assert!(run_with("G10 L1 P1\n", opts).is_err(), "no offsets");
    }

    /// Runs `src` and returns the interpreter (its tool table and state).
    fn interp_after(src: &str, opts: InterpOptions) -> Interpreter {
        let mut it = Interpreter::new(opts);
        let mut ev = Vec::new();
        for b in &Program::parse(src.as_bytes()).unwrap().blocks {
            it.execute(b, &mut ev).unwrap();
        }
        it
    }

    #[test]
    fn g10_l10_l11_in_a_rotated_system_make_the_point_read_the_words() {
        let xy = |v: &Axes| (v[Axis::X], v[Axis::Y]);
        let opts = InterpOptions {
            tools: [(1, 0.0), (2, 3.0)].into_iter().collect(),
            ..Default::default()
        };
        // G54 at (10, 5) turned 30°, tool 1 (no offset) at work (3, 4, 2):
        // machine = R30·(3, 4) + (10, 5). After G10 L10 X1 Y2 Z0.5 and G43
        // the same machine point must read (1, 2, 0.5): machine =
        // R30·(1, 2) + (10, 5) + tool, so tool = R30·((3, 4) − (1, 2)) and
        // its Z is 2 − 0.5.
        let (sn, cs) = 30f64.to_radians().sin_cos();
        let rot = |x: f64, y: f64| (x * cs - y * sn, x * sn + y * cs);
        let src = "G10 L2 P1 X10 Y5 R30\nG0 X3 Y4 Z2\nT1 M6 G43\nG10 L10 P1 X1 Y2 Z0.5\nG43\n";
        let it = interp_after(src, opts.clone());
        let t = it.tools().get(1).unwrap().offset;
        let (tx, ty) = rot(2.0, 2.0);
        assert!(close(t[Axis::X], tx) && close(t[Axis::Y], ty), "{t:?}");
        assert!(close(t[Axis::Z], 1.5));
        let (x, y) = xy(&it.state().position);
        assert!(close(x, 1.0) && close(y, 2.0) && close(it.state().position[Axis::Z], 0.5));
        // X alone: the new X reading along the rotated X axis, the old
        // offset's part along the rotated Y axis kept. The point (work
        // (1, 2) with the tool's R30·(2, 2)) is R30·(3, 4) from the origin
        // and must read X7: the offset becomes R30·(3 − 7, 0) plus the
        // old R30·(0, 2).
        let it = interp_after(&format!("{src}G10 L10 P1 X7\nG43\n"), opts.clone());
        let t = it.tools().get(1).unwrap().offset;
        let (ax, ay) = rot(-4.0, 0.0);
        let (bx, by) = rot(0.0, 2.0);
        assert!(
            close(t[Axis::X], ax + bx) && close(t[Axis::Y], ay + by),
            "{t:?}"
        );
        let (x, y) = xy(&it.state().position);
        assert!(close(x, 7.0) && close(y, 2.0), "{x} {y}");
        // Y alone, with a G92 offset in force: the point still reads the
        // word (G92 shifts both readings alike).
        let src2 = "G10 L2 P1 X10 Y5 R30\nG0 X3 Y4\nG92 X0 Y0\nT1 M6 G43\nG10 L10 P1 Y-2\nG43\n";
        let it = interp_after(src2, opts.clone());
        let (x, y) = xy(&it.state().position);
        assert!(close(x, 0.0) && close(y, -2.0), "{x} {y}");
        // L11: the words are read in G59.3 (turned 90°, origin (1, 1)):
        // after L11 X0 Y0 Z0 and G59.3 G43 the point reads (0, 0, 0).
        let src3 = "G10 L2 P9 X1 Y1 R90\nG10 L2 P1 X10 Y5 R30\nG0 X3 Y4 Z2\nT2 M6 G43\nG10 L11 P2 X0 Y0 Z0\nG59.3 G43\n";
        let it = interp_after(src3, opts);
        let p = it.state().position;
        assert!(
            close(p[Axis::X], 0.0) && close(p[Axis::Y], 0.0) && close(p[Axis::Z], 0.0),
            "{p:?}"
        );
    }

    #[test]
    fn g28_g30_go_through_the_waypoint_home() {
        // G28.1 stores the machine position; G28 Z5 goes to Z5 then home Z.
        let mut opts = InterpOptions::default();
        opts.work_offsets[0][Axis::Z] = -100.0;
        let src = "G0 X1 Y2 Z50\nG28.1\nG0 X7 Y8 Z0\nG91 G28 Z5\nG90 G30\n";
        let ev = run_with(src, opts).unwrap();
        let e = ends(&ev);
        assert_ends(
            &e[2..],
            &[
                ('R', [7.0, 8.0, 5.0]),   // waypoint, incremental
                ('R', [7.0, 8.0, 50.0]),  // home on Z only (machine -50)
                ('R', [7.0, 8.0, 50.0]),  // G30: no words, waypoint here
                ('R', [0.0, 0.0, 100.0]), // G30 home is machine zero
            ],
        );
    }

    #[test]
    fn tool_table_g43_variants() {
        let opts = InterpOptions {
            tools: ToolTable::parse("T1 P1 Z10\nT2 P2 Z20 X1\n", Units::Millimetre).unwrap(),
            ..Default::default()
        };
        let ev = run_with(
            "T1 M6\nG43\nG0 Z0\nG43 H2\nG0 Z0\nG43.2 H1\nG0 Z0\nG43.1 Z3\nG0 Z0\nG43.2 Z1\nG0 Z0\nG49\nG0 Z0\n",
            opts.clone(),
        )
        .unwrap();
        let offs: Vec<(f64, f64)> = moves(&ev)
            .iter()
            .map(|k| (lin(k).offset[Axis::X], lin(k).offset[Axis::Z]))
            .collect();
        assert_eq!(
            offs,
            // G43.2 with axis words moves in the modal G0 too (LinuxCNC's
            // enhance_block), G43.1 does not.
            [
                (0.0, 10.0),
                (1.0, 20.0),
                (1.0, 30.0),
                (1.0, 3.0),
                (1.0, 4.0),
                (1.0, 4.0),
                (0.0, 0.0)
            ]
        );
        for bad in ["G43 H3\n", "G43.2\n", "G43.2 H1 Z1\n", "T1 M6 G43 H-1\n"] {
            assert!(run_with(bad, opts.clone()).is_err(), "{bad}");
        }
        // H0 is the tool in the spindle (LinuxCNC's tool index 0, checked
        // against rs274 2.9): tool 2 (X1 Z20), then added once more by
        // G43.2; with no tool loaded, no offset.
        let ev = run_with("T2 M6\nG43 H0\nG0 Z0\nG43.2 H0\nG0 Z0\n", opts.clone()).unwrap();
        let offs: Vec<(f64, f64)> = moves(&ev)
            .iter()
            .map(|k| (lin(k).offset[Axis::X], lin(k).offset[Axis::Z]))
            .collect();
        assert_eq!(offs, [(1.0, 20.0), (2.0, 40.0)]);
        let ev = run_with("G43 H0\nG0 Z0\n", opts).unwrap();
        assert_eq!(lin(&moves(&ev)[0]).offset[Axis::Z], 0.0);
    }

    /// M61 Qn declares tool n in the spindle without a change (LinuxCNC
    /// 2.9's CHANGE_TOOL_NUMBER, its I/O controller loading n's entry into
    /// the spindle's): a later G43 (no H, or H0) applies n's offsets and
    /// #5400–#5413 read n; M61 keeps the selected tool and the offset in
    /// force. Table: tool 1 Z10, tool 2 X1 Z20 (mm).
    #[test]
    fn m61_sets_the_tool_in_the_spindle_without_a_change() {
        let opts = InterpOptions {
            tools: ToolTable::parse("T1 P1 Z10\nT2 P2 Z20 X1 D6\n", Units::Millimetre).unwrap(),
            ..Default::default()
        };
        let offsets = |src: &str| -> Vec<(f64, f64)> {
            moves(&run_with(src, opts.clone()).unwrap())
                .iter()
                .map(|k| (lin(k).offset[Axis::X], lin(k).offset[Axis::Z]))
                .collect()
        };
        // G43 after M61 Q2 applies tool 2, on its line or later; H0 too.
        assert_eq!(offsets("T1 M6\nM61 Q2\nG43\nG0 Z0\n"), [(1.0, 20.0)]);
        assert_eq!(offsets("M61 Q2 G43\nG0 Z0\n"), [(1.0, 20.0)]);
        assert_eq!(offsets("T1 M6\nM61 Q2\nG43 H0\nG0 Z0\n"), [(1.0, 20.0)]);
        // The offset in force stays until a G43; M6 loads the selected
        // tool 1 again; Q0 empties the spindle.
        assert_eq!(offsets("T2 M6 G43\nM61 Q1\nG0 Z0\n"), [(1.0, 20.0)]);
        assert_eq!(offsets("T1 M6\nM61 Q2\nM6\nG43\nG0 Z0\n"), [(0.0, 10.0)]);
        assert_eq!(offsets("T2 M6\nM61 Q0\nG43\nG0 Z0\n"), [(0.0, 0.0)]);
        // On the line of an M6 or M61, LinuxCNC's spindle entry (H0, and
        // G43 when the new tool is 0) is still the tool loaded before; G43
        // without H reads the new tool's entry (as rs274 2.9 does).
        assert_eq!(offsets("T1 M6\nT2 M6 G43 H0\nG0 Z0\n"), [(0.0, 10.0)]);
        assert_eq!(offsets("T1 M6\nM61 Q2 G43 H0\nG0 Z0\n"), [(0.0, 10.0)]);
        assert_eq!(offsets("T1 M6\nM61 Q2 G43.2 H0\nG0 Z0\n"), [(0.0, 10.0)]);
        assert_eq!(
            offsets("T1 M6\nM61 Q2 G43 H0\nG43 H0\nG0 Z0\n"),
            [(1.0, 20.0)]
        );
        assert_eq!(offsets("T2 M6\nM61 Q0 G43\nG0 Z0\n"), [(1.0, 20.0)]);
        assert_eq!(offsets("T2 M6\nT0 M6 G43\nG0 Z0\n"), [(1.0, 20.0)]);
        assert_eq!(offsets("T1 M6\nT2 M6 G43\nG0 Z0\n"), [(1.0, 20.0)]);
        // Q rounds to the nearest integer (LinuxCNC's round_to_int).
        assert_eq!(offsets("M61 Q1.6 G43\nG0 Z0\n"), [(1.0, 20.0)]);
        assert_eq!(offsets("M61 Q-0.4 G43\nG0 Z0\n"), [(0.0, 0.0)]);
        // The parameters read the tool from the line after M61.
        let it = interp_after("T1 M6\nM61 Q2\n", opts.clone());
        let p = |n: u32| it.parameters().get(n);
        assert_eq!((it.state().tool, it.state().selected_tool), (2, 1));
        assert_eq!((p(5400), p(5401), p(5403), p(5410)), (2.0, 1.0, 20.0, 6.0));
        let it = interp_after("T2 M6\nM61 Q0\n", opts.clone());
        assert_eq!(
            (it.parameters().get(5400), it.parameters().get(5403)),
            (0.0, 0.0)
        );
        // Errors, worded as LinuxCNC 2.9's.
        let err = |src: &str| match run_with(src, opts.clone()) {
            Err(GcodeError::Invalid { at, message }) => (at.column, message),
            other => panic!("{src}: expected an invalid block, got {other:?}"),
        };
        let need = "Need non-negative Q-word to specify tool number with M61";
        assert_eq!(err("M61\n"), (1, need.to_string()));
        assert_eq!(err("G0 X1 M61 Q-0.6\n"), (11, need.to_string()));
        assert_eq!(
            err("M61 Q3\n"),
            (
                5,
                "Requested tool 3 not found in the tool table".to_string()
            )
        );
        assert!(
            err("M61 Q1 M6\n")
                .1
                .starts_with("two M-codes of one modal group")
        );
        // T of a tool the table does not hold, as rs274 2.9 refuses it; T0
        // is no tool; without a table any T is taken.
        assert_eq!(
            err("G0 X1 T3\n"),
            (
                7,
                "Requested tool 3 not found in the tool table".to_string()
            )
        );
        assert_eq!(offsets("T2 M6\nT0 M6\nG43\nG0 Z0\n"), [(0.0, 0.0)]);
        run_with("T3 M6\n", InterpOptions::default()).unwrap();
    }

    /// G33 moves at K per revolution of S; G33.1 taps to the end and back
    /// (the retract at I times the speed), leaving the position where it
    /// was; stats time them as length / (K × S).
    #[test]
    fn g33_and_rigid_tap_run_at_k_per_revolution() {
        let src = "G21 S600 M3\nG0 X1 Z5\nG33 Z-10 K1.5\nG91 G33 X2 Z-3 K0.5\nG90 G20\n\
                   G33.1 Z-1 K0.05 I2\nG33.1 Z-0.5 K0.05 I0.5\nG21 G1 X0 F10\n";
        let m = moves(&run(src));
        assert_eq!(m.len(), 8, "{m:?}");
        let feed = |k: &EventKind| match lin(k).feed {
            Feed::PerRevolution { mm_per_rev, rpm } => (mm_per_rev, rpm),
            f => panic!("not per revolution: {f:?}"),
        };
        assert_eq!(lin(&m[1]).to.xyz(), [1.0, 0.0, -10.0]);
        assert_eq!(feed(&m[1]), (1.5, 600.0));
        let l2 = lin(&m[2]);
        assert!(close(l2.to[Axis::X], 3.0) && close(l2.to[Axis::Z], -13.0));
        assert_eq!(feed(&m[2]), (0.5, 600.0));
        // Taps: 25.4 mm down at 0.05 in = 1.27 mm per revolution, back at
        // twice the speed; I below 1 is 1.
        let (down, up) = (lin(&m[3]), lin(&m[4]));
        assert!(close(down.to[Axis::Z], -25.4) && close(down.from[Axis::Z], -13.0));
        assert_eq!((down.from, down.to), (up.to, up.from));
        let (k, rpm) = feed(&m[3]);
        assert!(close(k, 1.27) && rpm == 600.0);
        assert_eq!(feed(&m[4]).1, 1200.0);
        assert_eq!(feed(&m[6]).1, 600.0);
        assert!(close(lin(&m[5]).to[Axis::Z], -12.7));
        assert!(m[3..7].iter().all(|k| lin(k).words.expanded));
        // The feed after the taps starts where they started.
        assert_eq!(lin(&m[7]).from, lin(&m[2]).to);

        // Time: 15 mm at 1.5 mm/rev × 600 rev/min = 1 s; the tap 20 mm at
        // 1 mm/rev × 600 down (2 s) and × 1200 up (1 s).
        let opts = super::super::stats::StatsOptions::default();
        let st = super::super::stats::stats(
            "S600 M3\nG0 Z5\nG33 Z-10 K1.5\nG33.1 Z-30 K1 I2\nM2\n".as_bytes(),
            &opts,
        )
        .unwrap();
        assert!((st.feed_time - 4.0).abs() < 1e-9, "{}", st.feed_time);
    }

    #[test]
    fn g76_threads_in_spindle_synchronised_passes() {
        // From X10 Z5 to Z-20: depths 1.4, 1.8, 2 (I-1 J0.4 K1), each pass
        // back, in, along Z at 1.5 mm/rev, out; then to the end point X3 Y2.
        let src = "G18 G0 X10 Z5\nS500 M3\nG76 P1.5 X3 Y2 Z-20 I-1 J0.4 K1\nG1 X0 F100\n";
        let m = moves(&run(src));
        assert_eq!(m.len(), 1 + 3 * 4 + 1 + 1, "{m:?}");
        for (k, depth) in [1.4, 1.8, 2.0].into_iter().enumerate() {
            let p = &m[1 + 4 * k..5 + 4 * k];
            let back = 10.0 - depth + 2.0;
            let xz = |e: &EventKind| (lin(e).to[Axis::X], lin(e).to[Axis::Z]);
            let near = |a: (f64, f64), b: (f64, f64)| close(a.0, b.0) && close(a.1, b.1);
            assert!(matches!(p[0], EventKind::Traverse(_)) && near(xz(&p[0]), (back, 5.0)));
            assert!(matches!(p[1], EventKind::Traverse(_)) && near(xz(&p[1]), (10.0 - depth, 5.0)));
            assert!(matches!(p[2], EventKind::Feed(_)) && near(xz(&p[2]), (10.0 - depth, -20.0)));
            assert_eq!(
                lin(&p[2]).feed,
                Feed::PerRevolution {
                    mm_per_rev: 1.5,
                    rpm: 500.0
                }
            );
            assert!(matches!(p[3], EventKind::Traverse(_)) && near(xz(&p[3]), (back, -20.0)));
            assert!(
                p.iter()
                    .all(|e| lin(e).words.expanded && lin(e).to[Axis::Y] == 0.0)
            );
        }
        assert_eq!(lin(&m[13]).to.xyz(), [3.0, 2.0, -20.0]);
        assert_eq!(lin(&m[14]).from.xyz(), [3.0, 2.0, -20.0]);
        // Time: three passes of 25 mm at 1.5 mm/rev × 500 rev/min = 2 s each.
        let opts = super::super::stats::StatsOptions::default();
        let st = super::super::stats::stats(
            "G18 G0 X10 Z5\nS500 M3\nG76 P1.5 Z-20 I-1 J0.4 K1\nM2\n".as_bytes(),
            &opts,
        )
        .unwrap();
        assert!((st.feed_time - 6.0).abs() < 1e-9, "{}", st.feed_time);
        // Incremental Z, inch: the thread ends 1 in below the start.
        let m = moves(&run(
            "G20 G0 X1 Z0\nS500 M3\nG91 G76 P0.1 Z-1 I-0.05 J0.01 K0.03\n",
        ));
        let last = lin(m.last().unwrap());
        assert!(close(last.to[Axis::Z], -25.4) && close(last.to[Axis::X], 25.4));
        // Refused as LinuxCNC refuses them, and what cannot be timed.
        for (bad, unsupported) in [
            ("S500 M3\nG76 Z-1 I-1 J0.1 K0.5\n", false),       // no P
            ("S500 M3\nG76 P-1 Z-1 I-1 J0.1 K0.5\n", false),   // P-1 is "no P"
            ("S500 M3\nG76 P1 Z-1 I-1 K0.5\n", false),         // no J
            ("S500 M3\nG76 P1 I-1 J0.1 K0.5\n", false),        // no axis
            ("S500 M3\nG76 P1 Z-1 I0 J0.1 K0.5\n", false),     // I = 0
            ("S500 M3\nG76 P1 Z-1 I-1 J0.5 K0.5\n", false),    // K = J
            ("S500 M3\nG76 P1 Z-1 A1 I-1 J0.1 K0.5\n", false), // rotary
            ("S500 M3\nG76 P1 Z-1 I-1 J0.1 K0.5 L-1\n", false),
            ("S500 M3\nG76 P1 Z-1 I-1 J0.1 K0.5 H1.5\n", false),
            ("G76 P1 Z-1 I-1 J0.1 K0.5\n", false), // spindle stopped
            (
                "S500 M3\nG41.1 D1\nG1 X5 F100\nG76 P1 Z-1 I-1 J0.1 K0.5\n",
                false,
            ),
            ("S500 M3\nG76 P1 Z-1 I-1 J0.00005 K1\n", false), // 20 000 passes
            ("S500 M3\nG76 P0 Z-1 I-1 J0.1 K0.5\n", true),
            ("M3\nG76 P1 Z-1 I-1 J0.1 K0.5\n", true),
        ] {
            let err = run_with(bad, InterpOptions::default()).expect_err(bad);
            assert_eq!(
                matches!(err, GcodeError::Unsupported { .. }),
                unsupported,
                "{bad}: {err}"
            );
        }
        // Modal: a later line with axis words runs G76 again (and needs P).
        assert!(
            run_with(
                "S500 M3\nG76 P1 Z-1 I-1 J0.1 K0.5\nZ-2\n",
                InterpOptions::default()
            )
            .is_err()
        );
    }

    /// LinuxCNC's polar coordinates: end points by hand (distance `@`,
    /// angle `^` in degrees from +X), the G91 one as rs274 prints it.
    #[test]
    fn polar_words_stand_for_x_and_y() {
        let (c45, s45) = (5.0 * FRAC_PI_4.cos(), 5.0 * FRAC_PI_4.sin());
        let src = "G21 G90 G0 X10 Y0 Z0\n\
                   G1 @5 ^90 F100\n\
                   ^-90\n\
                   @2\n\
                   G91 ^90\n\
                   @3\n\
                   G90 G0 X3 Y4\n\
                   G91 G1 @5 ^90\n\
                   G90 G18 G0 @5 ^45 Z1\n\
                   G17\n\
                   G20 G0 @2 ^180\n\
                   M2\n";
        assert_ends(
            &ends(&run(src)),
            &[
                ('R', [10.0, 0.0, 0.0]),
                ('F', [0.0, 5.0, 0.0]),
                ('F', [0.0, -5.0, 0.0]),
                ('F', [0.0, -2.0, 0.0]),
                ('F', [2.0, 0.0, 0.0]),
                ('F', [5.0, 0.0, 0.0]),
                ('R', [3.0, 4.0, 0.0]),
                // r 5 + 5, angle atan2(4, 3) + 90°.
                ('F', [-8.0, 6.0, 0.0]),
                // The plane checked is the one before the block (G17).
                ('R', [c45, s45, 1.0]),
                ('R', [-50.8, 0.0, 1.0]),
            ],
        );
    }

    #[test]
    fn polar_canned_cycles_place_the_holes() {
        // G90: the hole at @5 ^45. G91 with L4: each repeat turns the hole
        // by ^90 about the origin, from (10, 0): (0, 10), (-10, 0),
        // (0, -10), (10, 0); R 5 - 4 = 1, bottom 1 - 2 = -1.
        let (c45, s45) = (5.0 * FRAC_PI_4.cos(), 5.0 * FRAC_PI_4.sin());
        let src = "G21 G90 G0 X10 Y0 Z5\nG81 @5 ^45 R1 Z-1 F100\nG80 G0 X10 Y0 Z5\n\
                   G91 G81 ^90 R-4 Z-2 L4\nG80\nM2\n";
        let holes: Vec<[f64; 3]> = ends(&run(src))
            .into_iter()
            .filter(|(k, _)| *k == 'F')
            .map(|(_, p)| p)
            .collect();
        let want = [
            [c45, s45, -1.0],
            [0.0, 10.0, -1.0],
            [-10.0, 0.0, -1.0],
            [0.0, -10.0, -1.0],
            [10.0, 0.0, -1.0],
        ];
        assert_eq!(holes.len(), want.len(), "{holes:?}");
        for (h, w) in holes.iter().zip(want) {
            assert!((0..3).all(|i| close(h[i], w[i])), "{holes:?}");
        }
    }

    #[test]
    fn polar_words_are_refused_as_linuxcnc_refuses_them() {
        for (src, message) in [
            (
                "G21 G0 X0 Y0\nG1 @5 F100\n",
                "Must specify angle in polar coordinate if at the origin",
            ),
            (
                "G21 G0 X0 Y0\nG91 G1 ^5 F100\n",
                "G91 motion with polar coordinates is indeterminate",
            ),
            (
                "G21 G0 X0 Y0\nG91 G1 @5 F100\n",
                "Incremental motion with polar coordinates is indeterminate",
            ),
            (
                "G18\nG17 G0 @5 ^0\n",
                "Cannot use polar coordinate except in G17 plane",
            ),
            (
                "G0 X1\nG0 X1 @5\n",
                "Cannot specify both polar coordinate and X word",
            ),
            (
                "G0 X1\nG0 ^5 Y1\n",
                "Cannot specify both polar coordinate and Y word",
            ),
            (
                "G0 X1\nG28 @5\n",
                "Polar coordinates can only be used for motion",
            ),
            (
                "G0 X1\nG10 L2 P1 @5\n",
                "Polar coordinates can only be used for motion",
            ),
            (
                "G0 X1\nG53 G0 @5\n",
                "Cannot use polar coordinates with G53",
            ),
            ("G0 X1\nG80 @5\n", "Cannot use axis values with G80"),
        ] {
            let e = run_with(src, InterpOptions::default()).unwrap_err();
            assert!(e.to_string().contains(message), "{src}: {e}");
            assert!(e.to_string().contains("line 2"), "{src}: {e}");
        }
        // LinuxCNC 2.9 reads the last of two @ words without an error:
        // refused as unsupported, never read one way or the other.
        let e = run_with("G0 X1\nG0 @1 @2\n", InterpOptions::default()).unwrap_err();
        assert!(matches!(e, GcodeError::Unsupported { .. }), "{e}");
        let fanuc = InterpOptions {
            dialect: Dialect::Fanuc {
                decimal_point_programming: true,
            },
            ..InterpOptions::default()
        };
        let e = run_with("G0 X1\nG0 @1 ^2\n", fanuc).unwrap_err();
        assert!(matches!(e, GcodeError::Unsupported { .. }), "{e}");
    }

    #[test]
    fn words_of_axes_the_machine_lacks_are_refused() {
        let mut opts = InterpOptions {
            machine_axes: AxisMask::EMPTY,
            ..InterpOptions::default()
        };
        for a in [Axis::X, Axis::Y, Axis::Z, Axis::A, Axis::B, Axis::C] {
            opts.machine_axes.insert(a);
        }
        let e = run_with("G21 G0 X1\nG1 w100 F10\nM2\n", opts.clone()).unwrap_err();
        assert!(e.to_string().contains("line 2, column 4"), "{e}");
        assert!(e.to_string().contains("Bad character 'w' used"), "{e}");
        // Also where no move reads it.
        assert!(run_with("G10 L2 P1 U1\nM2\n", opts.clone()).is_err());
        assert!(run_with("G21 G0 X1 C5\nM2\n", opts).is_ok());
        assert!(run_with("G21 G0 X1 W5\nM2\n", InterpOptions::default()).is_ok());
    }

    /// The expansions of LinuxCNC's G-code manual (canned cycles), by hand
    /// (G98 written where the retract goes to the initial level: a program
    /// starts in G99, as LinuxCNC's interpreter).
    #[test]
    fn canned_cycles_expand_as_linuxcnc() {
        // G81, absolute, G98: from Z3 (above R), rapid to XY, to R, feed to
        // bottom, rapid back to the initial level.
        let e = ends(&run("G0 X1 Y2 Z3\nG90 G98 G81 X4 Y5 Z-0.6 R1.8 F10\n"));
        assert_ends(
            &e[1..],
            &[
                ('R', [4.0, 5.0, 3.0]),
                ('R', [4.0, 5.0, 1.8]),
                ('F', [4.0, 5.0, -0.6]),
                ('R', [4.0, 5.0, 3.0]),
            ],
        );
        // The manual's incremental example: G91 G98 G81 X4 Y5 Z-0.6 R1.8 L3
        // from (1, 2, 3): R = 4.8, bottom 4.2, clear = 4.8 (initial 3 < R).
        let e = ends(&run("G0 X1 Y2 Z3\nG91 G98 G81 X4 Y5 Z-0.6 R1.8 L3 F10\n"));
        assert_ends(
            &e[1..],
            &[
                ('R', [1.0, 2.0, 4.8]),
                ('R', [5.0, 7.0, 4.8]),
                ('F', [5.0, 7.0, 4.2]),
                ('R', [5.0, 7.0, 4.8]),
                ('R', [9.0, 12.0, 4.8]),
                ('F', [9.0, 12.0, 4.2]),
                ('R', [9.0, 12.0, 4.8]),
                ('R', [13.0, 17.0, 4.8]),
                ('F', [13.0, 17.0, 4.2]),
                ('R', [13.0, 17.0, 4.8]),
            ],
        );
        // Without G98/G99 the program is in G99, as LinuxCNC's interpreter
        // starts (its `retract_mode(R_PLANE)`): back to R = 2, not to 10.
        let e = ends(&run("G0 Z10\nG81 X1 Z-1 R2 F10\n"));
        assert_eq!(e.last().map(|p| p.1[2]), Some(2.0), "{e:?}");
        // Modal: the next line reuses R and Z; G99 retracts to R.
        let e = ends(&run("G0 Z10\nG99 G81 X1 Z-1 R2 F10\nX2\nG80\n"));
        assert_ends(
            &e[1..],
            &[
                ('R', [1.0, 0.0, 10.0]),
                ('R', [1.0, 0.0, 2.0]),
                ('F', [1.0, 0.0, -1.0]),
                ('R', [1.0, 0.0, 2.0]),
                ('R', [2.0, 0.0, 2.0]),
                ('F', [2.0, 0.0, -1.0]),
                ('R', [2.0, 0.0, 2.0]),
            ],
        );
        // G83 peck Q1 from R2 to -1.5: feeds to 1, 0, -1, then -1.5; after
        // each peck a rapid to R and back down to 0.254 mm above the depth.
        let e = ends(&run("G0 Z5\nG98 G83 Z-1.5 R2 Q1 F10\n"));
        let z: Vec<(char, f64)> = e[2..].iter().map(|(k, p)| (*k, p[2])).collect();
        let want = [
            ('R', 2.0),
            ('F', 1.0),
            ('R', 2.0),
            ('R', 1.254),
            ('F', 0.0),
            ('R', 2.0),
            ('R', 0.254),
            ('F', -1.0),
            ('R', 2.0),
            ('R', -0.746),
            ('F', -1.5),
            ('R', 5.0),
        ];
        assert_eq!(z.len(), want.len(), "{z:?}");
        for (g, w) in z.iter().zip(want) {
            assert!(g.0 == w.0 && close(g.1, w.1), "{z:?}");
        }
        // G73: no return to R between pecks.
        let e = ends(&run("G98 G0 Z5\nG73 Z-0.5 R1 Q1 F10\n"));
        let z: Vec<f64> = e[2..].iter().map(|(_, p)| p[2]).collect();
        assert!(
            z.iter()
                .zip([1.0, 0.0, 0.254, -0.5, 5.0])
                .all(|(a, b)| close(*a, b)),
            "{z:?}"
        );
        // G18 (ZX plane): the cycle axis is Y.
        let e = ends(&run("G18 G98 G0 Y5\nG81 X1 Z2 Y-1 R1 F10\n"));
        assert_ends(
            &e[1..],
            &[
                ('R', [1.0, 5.0, 2.0]),
                ('R', [1.0, 1.0, 2.0]),
                ('F', [1.0, -1.0, 2.0]),
                ('R', [1.0, 5.0, 2.0]),
            ],
        );
        // G82/G89 dwell, G84 reverses the spindle.
        let ev = run("G98 G0 Z5\nM3 S100\nG84 Z-1 R1 F10\n");
        let spindle: Vec<SpindleState> = ev
            .iter()
            .filter_map(|e| match e.kind {
                EventKind::Spindle(s) => Some(s),
                _ => None,
            })
            .collect();
        use SpindleState::*;
        assert_eq!(
            spindle,
            [Clockwise, Stopped, CounterClockwise, Stopped, Clockwise]
        );
        let ev = run("G98 G0 Z5\nG82 Z-1 R1 P0.5 F10\n");
        assert!(
            ev.iter()
                .any(|e| e.kind == EventKind::Dwell { seconds: 0.5 })
        );
        // At the bounds themselves the blocks run.
        for ok in [
            "G81 X1 Z-1 R1 L10000 F10\n",
            "G83 X1 Z-1 R1 Q0.5 L2500 F10\n", // 4 pecks a hole: 10 000
        ] {
            assert!(run_with(ok, InterpOptions::default()).is_ok(), "{ok}");
        }
        // LinuxCNC's errors.
        for bad in [
            "G81 X1 Z-1 F10\n",           // no R
            "G81 X1 R1 F10\n",            // no Z
            "G81 X1 Z2 R1 F10\n",         // R below Z
            "G81 X1 Z-1 R1\n",            // zero feed
            "G81 X1 Z-1 R1 L0 F10\n",     // zero repeats
            "G81 X1 Z-1 R1 L10001 F10\n", // beyond MAX_CYCLE_REPEATS
            // Beyond MAX_CYCLE_PECKS: a huge R, a tiny Q with repeats.
            "G83 X1 Z-1 R100000000000000000000 Q1 F10\n",
            "G83 X1 Z-1 R1 Q0.0001 L1000 F10\n",
            "G83 X1 Z-1 R1 Q0.5 L2501 F10\n", // 4 pecks a hole: 10 004
            // Q below the resolution of the depth (ulp of 1e20 is 16 384).
            "G83 X1 Z100000000000000000000 R100000000000000016384 Q1 F10\n",
            "G83 X1 Z-1 R1 F10\n",    // no Q
            "G82 X1 Z-1 R1 F10\n",    // no P
            "G84 X1 Z-1 R1 F10\n",    // spindle stopped
            "G81 X1 Z-1 R1 A5 F10\n", // rotary axis
            "G93 G81 X1 Z-1 R1 F10\n",
        ] {
            assert!(run_with(bad, InterpOptions::default()).is_err(), "{bad}");
        }
    }
}
