//! The modal interpreter: blocks in, canonical [`Event`]s out, following
//! LinuxCNC's RS-274/NGC reading for the motion subset it supports.
//!
//! Order of execution within a block (LinuxCNC's): feed mode, feed rate,
//! spindle speed, tool select/change, spindle direction, TCP M-codes, dwell,
//! plane, units, cutter compensation off, tool length offset, coordinate
//! system, path control, distance modes, motion, program end.
//!
//! Constant expressions (`[1+2]`, `sqrt[2]`) are evaluated. Anything
//! outside the subset (O-words, parameters, canned cycles, G10/G28/G92,
//! cutter compensation, ...) is an
//! [`GcodeError::Unsupported`] error naming the line: never skipped.

use std::collections::BTreeMap;

use super::arc::{self, ArcError};
use super::axes::{Axes, Axis, AxisMask};
use super::dialect::{Dialect, DwellWord};
use super::error::GcodeError;
use super::event::{
    ArcMove, DistanceMode, Event, EventKind, Feed, FeedMode, Linear, Plane, Programmed, SourcePos,
    SpindleState, Units,
};
use super::expr::{self, ExprError};
use super::syntax::{Block, Item, Value, Word};

/// Tool number → tool length offset along Z, mm (the caller's tool table).
pub type ToolTable = BTreeMap<u32, f64>;

/// What unknown M-codes do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UnknownMCode {
    /// Stop with an unsupported-code error (default: nothing silent).
    #[default]
    Reject,
    /// Ignore them (user M-codes without a motion meaning).
    Ignore,
}

/// Interpreter settings given by the caller.
#[derive(Debug, Clone, PartialEq)]
pub struct InterpOptions {
    /// Controller dialect.
    pub dialect: Dialect,
    /// Offsets of G54, G55, G56, G57, G58, G59, G59.1, G59.2, G59.3
    /// (machine coordinates of the work origin), mm and degree.
    pub work_offsets: [Axes; 9],
    /// Tool table for G43 H / G43.4 H.
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
}

impl Default for InterpOptions {
    fn default() -> Self {
        InterpOptions {
            dialect: Dialect::LinuxCnc,
            work_offsets: [Axes::ZERO; 9],
            tools: ToolTable::new(),
            tcp_on_m: Some(428),
            tcp_off_m: Some(429),
            tcp_at_start: false,
            wrapped_rotary: AxisMask::EMPTY,
            skip_deleted_blocks: true,
            initial_units: Units::Millimetre,
            initial_machine_position: Axes::ZERO,
            unknown_m: UnknownMCode::Reject,
        }
    }
}

/// Active motion mode (modal group 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionMode {
    Rapid,
    Linear,
    ArcClockwise,
    ArcCounterClockwise,
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
    /// G0..G3, `None` after G80 and at start.
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
    /// Work offset plus tool length offset (machine = position + offset).
    pub offset: Axes,
}

/// Modal groups of the supported G-codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Group {
    NonModal,
    Motion,
    Plane,
    Distance,
    ArcDistance,
    FeedMode,
    Units,
    CutterComp,
    ToolLength,
    Retract,
    CoordSystem,
    PathControl,
    SpindleMode,
}

/// A supported G-code, in tenths (G43.4 = 434).
fn g_group(code: u32) -> Option<Group> {
    Some(match code {
        40 | 530 => Group::NonModal,
        // Probing (LinuxCNC G38.2–G38.5, Fanuc G31 skip) reads as a straight
        // feed move to its end point: the path and time if nothing is touched.
        0 | 10 | 20 | 30 | 800 | 310 | 382..=385 => Group::Motion,
        170 | 180 | 190 => Group::Plane,
        900 | 910 => Group::Distance,
        901 | 911 => Group::ArcDistance,
        930 | 940 | 950 => Group::FeedMode,
        200 | 210 => Group::Units,
        400 => Group::CutterComp,
        430 | 434 | 490 => Group::ToolLength,
        980 | 990 => Group::Retract,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => Group::CoordSystem,
        610 | 611 | 640 => Group::PathControl,
        970 => Group::SpindleMode,
        _ => return None,
    })
}

/// Why a known G-code is not supported.
fn g_unsupported(code: u32) -> &'static str {
    match code {
        100..=102 => "setting offsets",
        280 | 281 | 300 | 301 => "return to home position",
        920 | 921 | 922 | 923 | 520 => "axis offsets",
        410 | 411 | 420 | 421 => "cutter radius compensation",
        330 | 331 | 760 => "spindle-synchronised motion",
        730 | 740 | 810..=890 => "canned cycle",
        700..=720 => "lathe cycle",
        50 | 51 | 52 | 53 | 55 | 61 | 62 | 63 => "spline / NURBS motion",
        431 | 432 => "dynamic tool length offset",
        960 => "constant surface speed",
        70 | 80 => "lathe diameter/radius mode",
        _ => "G-code",
    }
}

/// M-codes accepted without a motion meaning.
fn m_ignored(code: u32) -> bool {
    matches!(code, 0 | 1 | 6 | 7 | 8 | 9 | 19 | 48..=53 | 60 | 61..=68 | 70..=73)
}

#[derive(Debug, Clone, Copy, Default)]
struct Letter {
    value: f64,
    has_point: bool,
    column: usize,
    present: bool,
}

/// Words of one block, sorted by letter.
#[derive(Debug, Default)]
struct BlockWords {
    g: Vec<(u32, usize)>,
    m: Vec<(u32, usize)>,
    letters: [Letter; 26],
}

impl BlockWords {
    fn get(&self, l: u8) -> Option<&Letter> {
        let x = &self.letters[usize::from(l - b'A')];
        x.present.then_some(x)
    }
}

/// The interpreter. Feed it blocks in order with [`Interpreter::execute`].
#[derive(Debug)]
pub struct Interpreter {
    opts: InterpOptions,
    state: ModalState,
    tcp_from_g43_4: bool,
    /// The F number as written (program units): LinuxCNC feeds a move of
    /// rotary axes only at F deg/min (or deg/rev) whatever the length units.
    feed_as_written: f64,
    block_index: u64,
    ended: bool,
    words: BlockWords,
}

impl Interpreter {
    /// A fresh interpreter in the start-up state (G17 G21 G90 G91.1 G94 G54,
    /// no motion mode, feed 0, spindle stopped, TCP per options).
    pub fn new(opts: InterpOptions) -> Self {
        let offset = opts.work_offsets[0];
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
            position: opts.initial_machine_position.sub(&offset),
            offset,
        };
        Interpreter {
            opts,
            state,
            tcp_from_g43_4: false,
            feed_as_written: 0.0,
            block_index: 0,
            ended: false,
            words: BlockWords::default(),
        }
    }

    /// The modal state after the blocks executed so far.
    pub fn state(&self) -> &ModalState {
        &self.state
    }

    /// Whether M2/M30 was executed (later blocks are then ignored).
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// Executes one block, appending its events to `out`. On error the state
    /// is that before the failing step; the error names the line.
    pub fn execute(&mut self, block: &Block, out: &mut Vec<Event>) -> Result<(), GcodeError> {
        let at = SourcePos {
            line: block.line(),
            block: self.block_index,
        };
        self.block_index += 1;
        if self.ended || (self.opts.skip_deleted_blocks && block.is_block_delete()) {
            return Ok(());
        }
        self.collect(block)?;
        let mut w = std::mem::take(&mut self.words);
        let r = self.run(block, &mut w, at, out);
        self.words = w;
        r
    }

    fn collect(&mut self, block: &Block) -> Result<(), GcodeError> {
        let line = block.line();
        let w = &mut self.words;
        w.g.clear();
        w.m.clear();
        w.letters = [Letter::default(); 26];
        for item in block.items() {
            match item {
                Item::Word(word) => collect_word(block, word, w)?,
                Item::OWord { span } => {
                    return Err(GcodeError::unsupported(
                        line,
                        span.start + 1,
                        "O-word statement (subroutines and control flow)",
                    ));
                }
                Item::Assignment { span } => {
                    return Err(GcodeError::unsupported(
                        line,
                        span.start + 1,
                        "parameter assignment",
                    ));
                }
                Item::Percent { .. } if block.words().next().is_some() => {
                    return Err(GcodeError::invalid(line, 0, "words on a '%' line"));
                }
                Item::Comment { .. } | Item::BlockDelete { .. } | Item::Percent { .. } => {}
            }
        }
        Ok(())
    }

    fn run(
        &mut self,
        block: &Block,
        w: &mut BlockWords,
        at: SourcePos,
        out: &mut Vec<Event>,
    ) -> Result<(), GcodeError> {
        let line = block.line();
        let invalid = |column: usize, m: String| GcodeError::invalid(line, column, m);

        // Modal groups of G-codes.
        let mut groups: Vec<(Group, u32, usize)> = Vec::with_capacity(w.g.len());
        for &(code, col) in &w.g {
            let Some(group) = g_group(code) else {
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("{} {}", g_unsupported(code), g_name(code)),
                ));
            };
            if let Some(&(_, other, _)) = groups.iter().find(|(g, _, _)| *g == group) {
                return Err(invalid(
                    col,
                    format!(
                        "two G-codes of one modal group: {} and {}",
                        g_name(other),
                        g_name(code)
                    ),
                ));
            }
            if !self.opts.dialect.has_arc_distance_modes() && group == Group::ArcDistance {
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("{} in this dialect", g_name(code)),
                ));
            }
            groups.push((group, code, col));
        }
        let g_of = |group: Group| {
            groups
                .iter()
                .find(|(g, _, _)| *g == group)
                .map(|&(_, c, col)| (c, col))
        };
        let has_g = |code: u32| groups.iter().any(|&(_, c, _)| c == code);

        // M-codes: at most one per modal group.
        let mut m_stop = None;
        let mut m_spindle = None;
        let mut m_tcp = None;
        let mut m_toolchange = false;
        for &(code, col) in &w.m {
            let slot = match code {
                0 | 1 | 2 | 30 | 60 => &mut m_stop,
                3..=5 => &mut m_spindle,
                c if Some(c) == self.opts.tcp_on_m || Some(c) == self.opts.tcp_off_m => &mut m_tcp,
                6 => {
                    m_toolchange = true;
                    continue;
                }
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
                return Err(invalid(
                    col,
                    format!("two M-codes of one modal group: M{other} and M{code}"),
                ));
            }
            *slot = Some((code, col));
        }

        let letter = |l: u8| w.get(l).copied();
        let dialect = self.opts.dialect;

        // 1-2. Feed mode and feed rate.
        if let Some((code, _)) = g_of(Group::FeedMode) {
            let mode = match code {
                930 => FeedMode::InverseTime,
                940 => FeedMode::UnitsPerMinute,
                _ => FeedMode::UnitsPerRevolution,
            };
            // LinuxCNC sets the feed rate to zero at every G93, G94 or G95,
            // even of the mode already in force: F must follow.
            self.state.feed = 0.0;
            self.feed_as_written = 0.0;
            self.state.feed_mode = mode;
            out.push(Event {
                at,
                kind: EventKind::FeedMode(mode),
            });
        }
        if let Some(f) = letter(b'F') {
            if f.value < 0.0 {
                return Err(invalid(f.column, "negative F word".into()));
            }
            let scale = match self.state.feed_mode {
                FeedMode::InverseTime => 1.0,
                _ => self.state.units.mm_per_unit(),
            };
            self.state.feed = f.value * scale;
            self.feed_as_written = f.value;
            out.push(Event {
                at,
                kind: EventKind::FeedRate(self.state.feed),
            });
        }
        // 3. Spindle speed.
        if let Some(s) = letter(b'S') {
            if s.value < 0.0 {
                return Err(invalid(s.column, "negative spindle speed".into()));
            }
            self.state.spindle_rpm = s.value;
            out.push(Event {
                at,
                kind: EventKind::SpindleSpeed { rpm: s.value },
            });
        }
        // 4. Tool select and change.
        if let Some(t) = letter(b'T') {
            self.state.selected_tool = nonneg_int(t, line, "T")?;
        }
        if m_toolchange {
            self.state.tool = self.state.selected_tool;
        }
        // 5. Spindle direction.
        if let Some((code, _)) = m_spindle {
            let dir = match code {
                3 => SpindleState::Clockwise,
                4 => SpindleState::CounterClockwise,
                _ => SpindleState::Stopped,
            };
            self.state.spindle = dir;
            out.push(Event {
                at,
                kind: EventKind::Spindle(dir),
            });
        }
        // 6. TCP by M-code (kinematics switch remaps).
        if let Some((code, _)) = m_tcp {
            let on = Some(code) == self.opts.tcp_on_m;
            self.state.tcp = on;
            self.tcp_from_g43_4 = false;
            out.push(Event {
                at,
                kind: EventKind::Tcp(on),
            });
        }
        // 7. Dwell.
        let dwell = has_g(40);
        if dwell {
            let seconds = self.dwell_seconds(w, line)?;
            out.push(Event {
                at,
                kind: EventKind::Dwell { seconds },
            });
        }
        // 8. Plane.
        if let Some((code, _)) = g_of(Group::Plane) {
            self.state.plane = match code {
                170 => Plane::Xy,
                180 => Plane::Zx,
                _ => Plane::Yz,
            };
        }
        // 9. Units.
        if let Some((code, _)) = g_of(Group::Units) {
            self.state.units = if code == 200 {
                Units::Inch
            } else {
                Units::Millimetre
            };
            out.push(Event {
                at,
                kind: EventKind::Units(self.state.units),
            });
        }
        // 10. Tool length offset and TCP by G43.4/G49.
        if let Some((code, col)) = g_of(Group::ToolLength) {
            let length = match code {
                490 => 0.0,
                _ => {
                    let tool = match letter(b'H') {
                        Some(h) => nonneg_int(h, line, "H")?,
                        None => self.state.tool,
                    };
                    if tool == 0 {
                        0.0
                    } else {
                        *self.opts.tools.get(&tool).ok_or_else(|| {
                            invalid(col, format!("tool {tool} is not in the tool table"))
                        })?
                    }
                }
            };
            self.set_tool_length(length);
            out.push(Event {
                at,
                kind: EventKind::ToolLengthOffset { length },
            });
            let tcp = match code {
                434 => Some(true),
                490 if self.tcp_from_g43_4 => Some(false),
                _ => None,
            };
            if let Some(on) = tcp {
                self.state.tcp = on;
                self.tcp_from_g43_4 = on;
                out.push(Event {
                    at,
                    kind: EventKind::Tcp(on),
                });
            }
        }
        // 11. Coordinate system.
        if let Some((code, _)) = g_of(Group::CoordSystem) {
            let system: u8 = match code {
                540 => 1,
                550 => 2,
                560 => 3,
                570 => 4,
                580 => 5,
                590 => 6,
                591 => 7,
                592 => 8,
                _ => 9,
            };
            self.state.work_system = system;
            let offset = self.opts.work_offsets[usize::from(system - 1)];
            self.set_offsets(offset, self.state.tool_length);
            out.push(Event {
                at,
                kind: EventKind::WorkOffset { system, offset },
            });
        }
        // 12. Distance modes.
        if let Some((code, _)) = g_of(Group::Distance) {
            self.state.distance = if code == 900 {
                DistanceMode::Absolute
            } else {
                DistanceMode::Incremental
            };
        }
        if let Some((code, _)) = g_of(Group::ArcDistance) {
            self.state.arc_distance = if code == 901 {
                DistanceMode::Absolute
            } else {
                DistanceMode::Incremental
            };
        }
        // 13. Motion.
        let motion_code = g_of(Group::Motion);
        if let Some((800, _)) = motion_code {
            self.state.motion = None;
        } else if let Some((code, _)) = motion_code {
            self.state.motion = Some(match code {
                0 => MotionMode::Rapid,
                10 | 310 | 382..=385 => MotionMode::Linear,
                20 => MotionMode::ArcClockwise,
                _ => MotionMode::ArcCounterClockwise,
            });
        }
        let mut axes = AxisMask::EMPTY;
        let mut target = [0.0; 9];
        for axis in Axis::ALL {
            if let Some(a) = letter(axis.letter()) {
                if dwell && dialect != Dialect::LinuxCnc && axis == Axis::X {
                    continue; // Fanuc G4 X: the dwell time.
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
        if let Some((code @ (310 | 382..=385), col)) = motion_code
            && axes.is_empty()
        {
            let name = if code == 310 { "G31" } else { "G38.x" };
            return Err(invalid(col, format!("probing {name} without axis words")));
        }
        let g53 = g_of(Group::NonModal).filter(|(c, _)| *c == 530);
        let explicit_motion = motion_code.is_some_and(|(c, _)| c != 800);
        if let Some((_, col)) = g53 {
            if axes.is_empty() {
                return Err(invalid(col, "G53 without axis words".into()));
            }
            if !matches!(
                self.state.motion,
                Some(MotionMode::Rapid | MotionMode::Linear)
            ) {
                return Err(invalid(col, "G53 needs G0 or G1".into()));
            }
        }
        if !axes.is_empty() || explicit_motion {
            match self.state.motion {
                None if !axes.is_empty() => {
                    return Err(invalid(
                        0,
                        "axis words without a motion mode (G0, G1, G2 or G3)".into(),
                    ));
                }
                None => {}
                Some(mode) => {
                    self.motion(mode, w, axes, target, g53.map(|(_, c)| c), line, at, out)?
                }
            }
        }
        // I J K without an arc.
        let arc_now = axes_or_motion(&axes, motion_code)
            && matches!(
                self.state.motion,
                Some(MotionMode::ArcClockwise | MotionMode::ArcCounterClockwise)
            );
        if let Some(r) = letter(b'R') {
            // R is read by G2/G3, G64 (blend tolerance) and M19 (orientation).
            let g64 = has_g(640);
            let m19 = w.m.iter().any(|&(c, _)| c == 19);
            if g64 && m19 {
                return Err(invalid(
                    r.column,
                    "R word is ambiguous on a line with both G64 and M19 - use separate lines"
                        .into(),
                ));
            }
            if !(arc_now || g64 || m19) {
                return Err(invalid(
                    r.column,
                    "R word with no g code that uses it".into(),
                ));
            }
        }
        if !arc_now {
            for l in [b'I', b'J', b'K'] {
                if let Some(x) = letter(l) {
                    return Err(invalid(
                        x.column,
                        format!("{} word with no G2 or G3 to use it", l as char),
                    ));
                }
            }
        }
        self.check_word_use(block, w, &has_g, arc_now, line)?;
        // 14. Program end.
        if let Some((2 | 30, _)) = m_stop {
            self.ended = true;
            out.push(Event {
                at,
                kind: EventKind::ProgramEnd,
            });
        }
        Ok(())
    }

    /// Refuses D, E, H, L, P and Q words that no code of the block reads, as
    /// LinuxCNC does ("E word with no G76, M66, M67 or M68 to use it", ...):
    /// a word nothing reads is a typing error, never silently dropped. Only
    /// the codes this interpreter accepts are listed (canned cycles, G10 and
    /// cutter compensation are refused before this check).
    fn check_word_use(
        &self,
        block: &Block,
        w: &BlockWords,
        has_g: &dyn Fn(u32) -> bool,
        arc_now: bool,
        line: u64,
    ) -> Result<(), GcodeError> {
        let has_m = |codes: &[u32]| w.m.iter().any(|(c, _)| codes.contains(c));
        let checks: [(u8, bool, &str); 6] = [
            (b'D', false, "D word with no G41, G42 or G96 to use it"),
            (
                b'E',
                has_m(&[66, 67, 68]),
                "E word with no G76, M66, M67 or M68 to use it",
            ),
            (
                b'H',
                has_g(430) || has_g(434),
                "H word with no G43 to use it",
            ),
            (
                b'L',
                has_m(&[66]),
                "L word with no G10, cutter compensation, canned cycle or M66 to use it",
            ),
            (
                b'P',
                has_g(40)
                    || has_g(640)
                    || arc_now
                    || has_m(&[19, 50, 51, 52, 53, 62, 63, 64, 65, 66]),
                "P word with no G2, G3, G4, G64, M19, M50-M53 or M62-M66 to use it",
            ),
            (
                b'Q',
                has_g(640) || has_m(&[19, 61, 66, 67, 68]),
                "Q word with no G64, M19, M61, M66, M67, M68 or canned cycle to use it",
            ),
        ];
        for (l, used, message) in checks {
            let Some(x) = w.get(l) else { continue };
            if used {
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

    fn dwell_seconds(&self, w: &BlockWords, line: u64) -> Result<f64, GcodeError> {
        let (word, value) = match self.opts.dialect {
            Dialect::LinuxCnc => (DwellWord::PSeconds, w.get(b'P')),
            Dialect::Fanuc { .. } => match (w.get(b'X').or(w.get(b'U')), w.get(b'P')) {
                (Some(x), _) => (DwellWord::XSeconds, Some(x)),
                (None, p) => (DwellWord::PMilliseconds, p),
            },
        };
        let v = value.ok_or_else(|| GcodeError::invalid(line, 0, "dwell time missing with G4"))?;
        if v.value < 0.0 {
            return Err(GcodeError::invalid(line, v.column, "negative dwell time"));
        }
        Ok(word.seconds(v.value))
    }

    fn set_tool_length(&mut self, length: f64) {
        self.state.tool_length = length;
        let work = self.opts.work_offsets[usize::from(self.state.work_system - 1)];
        self.set_offsets(work, length);
    }

    /// Changes the offsets keeping the machine position.
    fn set_offsets(&mut self, work: Axes, tool_length: f64) {
        let machine = self.state.position.add(&self.state.offset);
        let mut offset = work;
        offset[Axis::Z] += tool_length;
        self.state.offset = offset;
        self.state.position = machine.sub(&offset);
    }

    #[allow(clippy::too_many_arguments)]
    fn motion(
        &mut self,
        mode: MotionMode,
        w: &BlockWords,
        axes: AxisMask,
        target: [f64; 9],
        g53: Option<usize>,
        line: u64,
        at: SourcePos,
        out: &mut Vec<Event>,
    ) -> Result<(), GcodeError> {
        let st = &self.state;
        let from = st.position;
        let mut to = from;
        if let Some(col) = g53 {
            if !matches!(mode, MotionMode::Rapid | MotionMode::Linear) {
                return Err(GcodeError::invalid(line, col, "G53 needs G0 or G1"));
            }
            if st.distance == DistanceMode::Incremental {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    "G53 is not allowed with G91",
                ));
            }
        }
        for axis in axes.iter() {
            let v = target[axis.index()];
            to[axis] = if g53.is_some() {
                v - st.offset[axis]
            } else if st.distance == DistanceMode::Incremental {
                from[axis] + v
            } else if self.opts.wrapped_rotary.contains(axis) {
                unwrap_rotary(v, from[axis]).map_err(|m| {
                    GcodeError::invalid(line, w.get(axis.letter()).map_or(0, |l| l.column), m)
                })?
            } else {
                v
            };
        }
        let words = Programmed {
            axes,
            g53: g53.is_some(),
            distance: st.distance,
            units: st.units,
        };
        let feed = || -> Result<Feed, GcodeError> {
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
        };
        let kind = match mode {
            MotionMode::Rapid | MotionMode::Linear => {
                if axes.is_empty() {
                    return Ok(());
                }
                let lin = |feed| Linear {
                    from,
                    to,
                    offset: st.offset,
                    feed,
                    tcp: st.tcp,
                    words,
                };
                if mode == MotionMode::Rapid {
                    EventKind::Traverse(lin(Feed::Rapid))
                } else {
                    let d = to.sub(&from);
                    let rotary_only =
                        d.xyz_norm() == 0.0 && d.uvw_norm() == 0.0 && d.abc_norm() > 0.0;
                    let f = match feed()? {
                        Feed::PerMinute(_) if rotary_only => Feed::PerMinute(self.feed_as_written),
                        Feed::PerRevolution { rpm, .. } if rotary_only => Feed::PerRevolution {
                            mm_per_rev: self.feed_as_written,
                            rpm,
                        },
                        f => f,
                    };
                    EventKind::Feed(lin(f))
                }
            }
            MotionMode::ArcClockwise | MotionMode::ArcCounterClockwise => {
                // No axis words: with I, J or K a full circle about the
                // current point (as LinuxCNC 2.9 runs it), else an error.
                if axes.is_empty() {
                    let ijk = [b'I', b'J', b'K'].iter().any(|&l| w.get(l).is_some());
                    if w.get(b'R').is_some() || !ijk {
                        return Err(GcodeError::invalid(
                            line,
                            0,
                            "All axes missing with motion code",
                        ));
                    }
                }
                let feed = feed()?;
                let ccw = mode == MotionMode::ArcCounterClockwise;
                let (center, turns) = self.arc_center(w, &from, &to, ccw, line)?;
                let st = &self.state;
                EventKind::Arc(ArcMove {
                    from,
                    to,
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
        out.push(Event { at, kind });
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

fn axes_or_motion(axes: &AxisMask, motion: Option<(u32, usize)>) -> bool {
    !axes.is_empty() || motion.is_some_and(|(c, _)| c != 800)
}

/// LinuxCNC's `unwrap_rotary`: absolute target of a wrapped rotary axis,
/// the sign of the programmed value giving the direction.
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

fn g_name(code: u32) -> String {
    if code.is_multiple_of(10) {
        format!("G{}", code / 10)
    } else {
        format!("G{}.{}", code / 10, code % 10)
    }
}

fn collect_word(block: &Block, word: &Word, w: &mut BlockWords) -> Result<(), GcodeError> {
    let line = block.line();
    let col = word.at + 1;
    let value = match word.value {
        Value::Number(v) => v,
        Value::Expression => match expr::eval(block.value_text(word).as_bytes()) {
            Ok(v) => v,
            Err(ExprError::Parameter) => {
                return Err(GcodeError::unsupported(
                    line,
                    word.span.start + 1,
                    format!("expression with parameters {}", block.value_text(word)),
                ));
            }
            Err(ExprError::Invalid(m)) => {
                return Err(GcodeError::invalid(
                    line,
                    word.span.start + 1,
                    format!("{m} in {}", block.value_text(word)),
                ));
            }
        },
        Value::Parameter => {
            return Err(GcodeError::unsupported(
                line,
                word.span.start + 1,
                format!("parameter {}", block.value_text(word)),
            ));
        }
    };
    match word.letter {
        b'G' => {
            let tenths = value * 10.0;
            if (tenths - tenths.round()).abs() > 1e-6 || !(0.0..=9999.0).contains(&tenths) {
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("G-code G{}", block.value_text(word)),
                ));
            }
            w.g.push((tenths.round() as u32, col));
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
            let slot = &mut w.letters[usize::from(l - b'A')];
            if slot.present {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    format!("more than one {} word in the block", l as char),
                ));
            }
            *slot = Letter {
                value,
                has_point: word.has_point,
                column: col,
                present: true,
            };
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{FRAC_PI_2, PI};

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
        opts.tools.insert(3, 20.0);
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
        assert_eq!(ev[0].at, SourcePos { line: 1, block: 0 });
        assert_eq!(ev.last().unwrap().at, SourcePos { line: 8, block: 7 });
    }

    #[test]
    fn rejections_name_the_line() {
        let cases = [
            ("G0 X0\nG81 X1 Z-1 R1\n", 2, true),
            ("G1 X1\n", 1, false),             // zero feed
            ("G93\nG1 X1 F1\nX2\n", 3, false), // inverse time needs F each move
            ("X1\n", 1, false),                // no motion mode
            ("G0 G1 X1\n", 1, false),          // one modal group twice
            ("G0 X1 X2\n", 1, false),          // two X words
            ("G0 X#1\n", 1, true),             // parameter
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
        let ev = run_with("G4 P1500\nG4 X2.5\nG0 X10 Y10.\n", fanuc.clone()).unwrap();
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
        assert_eq!(dwell, [1.5, 2.5]);
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
            "M61 Q1\n",
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
}
