//! Cutter radius compensation (G40, G41, G42, G41.1, G42.1): the tool
//! centre path offset by the tool radius from the programmed contour, as
//! LinuxCNC's interpreter computes it (its documented behaviour and its
//! `convert_straight_comp*`, `convert_arc_comp*` and move queue; see
//! docs/gcode.md and docs/references.md).
//!
//! Compensation works in the plane of G17 (XY) or G18 (ZX, first axis Z,
//! second X), in that plane's own 2D coordinates: "left" is the side a
//! quarter turn counter-clockwise about the plane normal from the
//! direction of travel.
//!
//! How LinuxCNC does it, and so this module:
//!
//! * The first move after G41/G42 (the entry move) goes to the point one
//!   tool radius from the programmed end, perpendicular to the line from
//!   the start (a straight entry must be longer than the radius; an arc
//!   entry keeps the tool tangent to an arc through the programmed end).
//! * Every later move ends one radius from its programmed end, normal to the
//!   programmed path there. Where two moves meet at an outside (convex)
//!   corner an arc about the programmed corner is inserted (a straight
//!   traverse for G0); at an inside (concave) corner the previous move is
//!   cut short where the two offset paths meet, so that move is held back
//!   (one block of look-ahead) until the next move is known.
//! * Errors where the tool cannot follow (gouging, an arc smaller than the
//!   tool, a corner the tool does not fit in) stop the program, with
//!   LinuxCNC's sentences.
//! * G40 ends compensation: the held move keeps its end, and the next move
//!   (which must be straight) starts there.
//!
//! Events of held moves (and every event that follows them, in order) are
//! kept by [`CutterComp`] between blocks and given to the caller with the
//! block that completes them, each still tagged with the block it came
//! from.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use super::axes::{Axes, Axis};
use super::error::GcodeError;
use super::event::{ArcMove, Event, EventKind, Feed, Linear, Plane, Programmed, SourcePos, Units};

/// Angle within which two directions count as the same, rad (LinuxCNC's
/// `TOLERANCE_CONCAVE_CORNER`).
const SMALL: f64 = 0.05;

/// LinuxCNC's `TOLERANCE_EQUAL`.
const TOLERANCE_EQUAL: f64 = 0.0001;

/// Side of the programmed path the tool is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    /// G41, G41.1.
    Left,
    /// G42, G42.1.
    Right,
}

impl Side {
    fn opposite(self) -> Side {
        match self {
            Side::Left => Side::Right,
            Side::Right => Side::Left,
        }
    }

    /// Whether the tool is inside an arc of `turn` (positive
    /// counter-clockwise) on this side.
    fn inside(self, turn: i32) -> bool {
        (self == Side::Left && turn > 0) || (self == Side::Right && turn < 0)
    }
}

/// What a held move keeps besides its event: the direction of the
/// programmed motion (straight) or its sweep (arc), for the gouging checks
/// when its end is moved.
#[derive(Debug, Clone, Copy)]
enum Held {
    Straight { dir: [f64; 2] },
    Arc { sweep: f64 },
}

/// The first held move as the corner rules read it.
#[derive(Debug, Clone, Copy)]
enum Front {
    Straight,
    Arc {
        center: [f64; 2],
        end: [f64; 2],
        turn: i32,
    },
}

/// Everything about a compensated move but its geometry.
#[derive(Debug, Clone, Copy)]
pub(crate) struct MoveInfo {
    /// The block of the move.
    pub at: SourcePos,
    /// Column of the error, if one is found.
    pub column: usize,
    /// The plane (G17 or G18).
    pub plane: Plane,
    /// Program units (LinuxCNC's tolerances depend on them).
    pub units: Units,
    /// Work offset plus tool offset.
    pub offset: Axes,
    /// TCP on.
    pub tcp: bool,
    /// What the block wrote.
    pub words: Programmed,
    /// The feed (`Feed::Rapid` for G0).
    pub feed: Feed,
}

impl MoveInfo {
    fn invalid(&self, message: impl Into<String>) -> GcodeError {
        GcodeError::invalid(self.at.line, self.column, message)
    }

    fn axes(&self) -> (Axis, Axis, Axis) {
        self.plane.axes()
    }

    fn words(&self) -> Programmed {
        Programmed {
            expanded: true,
            ..self.words
        }
    }

    fn straight(&self, rapid: bool, from: Axes, to: Axes) -> Event {
        let lin = Linear {
            from,
            to,
            offset: self.offset,
            feed: if rapid { Feed::Rapid } else { self.feed },
            tcp: self.tcp,
            words: self.words(),
        };
        Event {
            at: self.at,
            kind: if rapid {
                EventKind::Traverse(lin)
            } else {
                EventKind::Feed(lin)
            },
        }
    }

    fn arc(&self, from: Axes, to: Axes, center: [f64; 2], turns: i32) -> Event {
        let (p, q, _) = self.axes();
        let mut c = from.xyz();
        c[p.index()] = center[0];
        c[q.index()] = center[1];
        Event {
            at: self.at,
            kind: EventKind::Arc(ArcMove {
                from,
                to,
                center: c,
                plane: self.plane,
                turns,
                offset: self.offset,
                feed: self.feed,
                tcp: self.tcp,
                words: self.words(),
            }),
        }
    }
}

/// Plane coordinates of a position.
fn in_plane(pos: &Axes, plane: Plane) -> [f64; 2] {
    let (p, q, _) = plane.axes();
    [pos[p], pos[q]]
}

/// `pos` with its plane coordinates set to `xy`.
fn with_plane(mut pos: Axes, plane: Plane, xy: [f64; 2]) -> Axes {
    let (p, q, _) = plane.axes();
    pos[p] = xy[0];
    pos[q] = xy[1];
    pos
}

fn polar(origin: [f64; 2], r: f64, angle: f64) -> [f64; 2] {
    [origin[0] + r * angle.cos(), origin[1] + r * angle.sin()]
}

fn dir(from: [f64; 2], to: [f64; 2]) -> f64 {
    (to[1] - from[1]).atan2(to[0] - from[0])
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Signed sweep from `s` to `e` about `c` for `turn` turns (positive
/// counter-clockwise), as LinuxCNC's `find_turn`.
fn find_turn(s: [f64; 2], c: [f64; 2], turn: i32, e: [f64; 2]) -> f64 {
    if turn == 0 {
        return 0.0;
    }
    let mut alpha = dir(c, s);
    let mut beta = dir(c, e);
    if turn > 0 {
        if beta <= alpha {
            beta += TAU;
        }
        beta - alpha + f64::from(turn - 1) * TAU
    } else {
        if alpha <= beta {
            alpha += TAU;
        }
        beta - alpha + f64::from(turn + 1) * TAU
    }
}

/// The feed of a compensated move in inverse time (G93): LinuxCNC feeds
/// every move of the block (corner arc included) at the programmed
/// length times F, at least 0.1 program units per minute, so the move takes
/// the programmed time only where compensation does not change its length.
/// `length` is the programmed length in mm (degree for a move of rotary
/// axes only, `rotary` set).
pub(crate) fn inverse_time_feed(f: f64, length: f64, rotary: bool, units: Units) -> Feed {
    if rotary {
        return Feed::PerMinute((length * f).max(0.1));
    }
    let scale = units.mm_per_unit();
    Feed::PerMinute((length / scale * f).max(0.1) * scale)
}

/// Length of a programmed straight move for its inverse-time feed, as
/// LinuxCNC's `find_straight_length`: XYZ if they move, else UVW, else the
/// rotary axes (degree; the flag says so).
pub(crate) fn straight_length(from: &Axes, to: &Axes, units: Units) -> (f64, bool) {
    let d = to.sub(from);
    let tiny = 1e-7 * units.mm_per_unit();
    let moved = |axes: [Axis; 3]| axes.iter().any(|&a| d[a].abs() > tiny);
    if moved([Axis::X, Axis::Y, Axis::Z]) {
        (d.xyz_norm(), false)
    } else if moved([Axis::U, Axis::V, Axis::W]) {
        (d.uvw_norm(), false)
    } else {
        (d.abc_norm(), true)
    }
}

/// Length of a programmed arc for its inverse-time feed, as LinuxCNC's
/// `find_arc_length`: radius at the start times the sweep, with the
/// normal-axis travel `rise` as a helix.
pub(crate) fn arc_length(s: [f64; 2], c: [f64; 2], turn: i32, e: [f64; 2], rise: f64) -> f64 {
    let r = dist(c, s);
    let theta = find_turn(s, c, turn, e);
    if rise == 0.0 {
        r * theta.abs()
    } else {
        (r * theta).hypot(rise)
    }
}

/// The compensation state and its queue of held events.
#[derive(Debug, Clone)]
pub(crate) struct CutterComp {
    side: Option<Side>,
    /// Tool radius, mm (never negative: a negative one switches the side).
    radius: f64,
    /// No move made since compensation was turned on.
    first_move: bool,
    /// The programmed position (LinuxCNC's `program_x`...): where the
    /// contour is, while the interpreter's position is the tool's.
    programmed: Axes,
    /// The move after G40 must be straight.
    arc_not_allowed: bool,
    /// Where the tool is: the end of the last move made or held (it differs
    /// from the interpreter's position once a held move's end is moved).
    tool: Axes,
    /// After G40: the tool's offset from the position the interpreter
    /// resumes from, taken by the next move's start.
    exit_delta: Option<Axes>,
    /// Held events between blocks (moves and whatever followed them).
    carried: Vec<Event>,
    /// Within a block: index in the block's events where the held ones start.
    queue_start: Option<usize>,
    /// The held moves: index relative to `queue_start`, and what they keep.
    held: Vec<(usize, Held)>,
    /// LinuxCNC's queue end point (the start of the held moves) and whether
    /// it is set.
    endpoint: [f64; 2],
    endpoint_valid: bool,
    /// What LinuxCNC's corner rules read as the first held move when none
    /// is held (after M0/M1/M60 emptied the queue): the first move of the
    /// last queue released.
    stale_front: Option<Front>,
    /// A lathe tool's control point from its nose centre (X, Z, mm; zero
    /// for a mill tool): every compensated move is made with the nose
    /// centre path moved by it ([`lathe_tool_origin`]).
    origin_shift: [f64; 2],
    /// The first held move is the entry move: its start is where the tool
    /// was, not a point of the compensated path.
    entry_held: bool,
}

/// The orientation of a G41.1/G42.1 `L` word, or LinuxCNC's error: a
/// whole number (within 0.0001), not negative; 10 and above (no
/// orientation LinuxCNC shifts) read as 10.
pub(crate) fn lathe_orientation(l: f64) -> Result<u8, &'static str> {
    if l < 0.0 {
        return Err("Negative l word used");
    }
    if (l - l.round()).abs() > 1e-4 {
        return Err("Non integer value for integer");
    }
    Ok(l.round().min(10.0) as u8)
}

/// Where LinuxCNC 2.9 puts a lathe tool's control point (its imaginary
/// tip) relative to the centre of its nose radius `r`, in G18, for the
/// tool orientation of the tool table (`Q`) or of G41.1/G42.1 `L`:
/// (ΔX, ΔZ) in mm. Orientations 1–4 are the corner tools (tip at a corner
/// of the square about the nose: 1 −X +Z, 2 −X −Z, 3 +X −Z, 4 +X +Z),
/// 5–8 the tips on an axis (5 +Z, 6 −X, 7 −Z, 8 +X); 0 and 9 (a mill tool,
/// a nose centred on the control point) none. Compensation moves the nose
/// centre; the machine is commanded to the centre plus this shift.
pub(crate) fn lathe_tool_origin(orientation: u8, r: f64) -> [f64; 2] {
    let dx = match orientation {
        1 | 2 | 6 => -r,
        3 | 4 | 8 => r,
        _ => 0.0,
    };
    let dz = match orientation {
        2 | 3 | 7 => -r,
        1 | 4 | 5 => r,
        _ => 0.0,
    };
    [dx, dz]
}

/// The state a failing block restores ([`CutterComp::undo_point`]).
#[derive(Debug)]
pub(crate) enum Undo {
    /// Compensation off with nothing held: the fields a block can change.
    Off {
        first_move: bool,
        arc_not_allowed: bool,
        exit_delta: Option<Axes>,
        endpoint_valid: bool,
    },
    /// Any other state: all of it.
    All(Box<CutterComp>),
}

impl Default for CutterComp {
    fn default() -> Self {
        CutterComp {
            side: None,
            radius: 0.0,
            first_move: true,
            programmed: Axes::ZERO,
            arc_not_allowed: false,
            tool: Axes::ZERO,
            exit_delta: None,
            carried: Vec::new(),
            queue_start: None,
            held: Vec::new(),
            endpoint: [0.0; 2],
            endpoint_valid: false,
            stale_front: None,
            origin_shift: [0.0; 2],
            entry_held: false,
        }
    }
}

impl CutterComp {
    /// Compensation is on (G41/G42 in force, whatever the radius).
    pub(crate) fn is_on(&self) -> bool {
        self.side.is_some()
    }

    /// Compensation is on with a radius: moves are offset.
    pub(crate) fn engaged(&self) -> bool {
        self.side.is_some() && self.radius > 0.0
    }

    /// No move since compensation was turned on (the next is the entry move).
    pub(crate) fn first_move(&self) -> bool {
        self.first_move
    }

    /// The move after G40 must be straight.
    pub(crate) fn arc_not_allowed(&self) -> bool {
        self.arc_not_allowed
    }

    /// A straight move (G0, G1) clears the rule above.
    pub(crate) fn straight_move_started(&mut self) {
        self.arc_not_allowed = false;
    }

    /// The line of the first held event, if events are held.
    pub(crate) fn held_line(&self) -> Option<u64> {
        self.carried.first().map(|e| e.at.line)
    }

    /// The position the block's axis words are read from: the programmed
    /// position (XYZ) while compensation is on after its entry move, else
    /// `pos` (LinuxCNC's `find_ends`).
    pub(crate) fn base(&self, pos: &Axes) -> Axes {
        let mut b = *pos;
        if self.side.is_some() && !self.first_move {
            for a in [Axis::X, Axis::Y, Axis::Z] {
                b[a] = self.programmed[a];
            }
        }
        b
    }

    /// Where the next move starts: `pos`, plus the tool's offset after G40
    /// (taken once).
    #[inline]
    pub(crate) fn physical_start(&mut self, pos: &Axes) -> Axes {
        self.entry_held = true;
        match self.exit_delta.take() {
            Some(d) => pos.add(&d),
            None => *pos,
        }
    }

    /// What restores this state if the block about to run fails
    /// ([`CutterComp::undo`]); `switching`: the block has a G40, G41, G42,
    /// G41.1 or G42.1. Compensation that is off, holds nothing and is not
    /// switched on by the block (almost every block of most programs) can
    /// only lose its after-G40 rules ([`Self::straight_move_started`],
    /// [`Self::physical_start`]) and have its queue marked released
    /// ([`Self::stop`]): those few fields are kept instead of a copy of
    /// the whole state. A new step that changes another field of such a
    /// state must be added to [`Undo::Off`].
    #[inline]
    pub(crate) fn undo_point(&self, switching: bool) -> Undo {
        let quiet = !switching
            && self.side.is_none()
            && self.carried.is_empty()
            && self.held.is_empty()
            && self.queue_start.is_none();
        if quiet {
            Undo::Off {
                first_move: self.first_move,
                arc_not_allowed: self.arc_not_allowed,
                exit_delta: self.exit_delta,
                endpoint_valid: self.endpoint_valid,
            }
        } else {
            Undo::All(Box::new(self.clone()))
        }
    }

    /// Puts back the state [`CutterComp::undo_point`] kept.
    pub(crate) fn undo(&mut self, undo: Undo) {
        match undo {
            Undo::Off {
                first_move,
                arc_not_allowed,
                exit_delta,
                endpoint_valid,
            } => {
                self.side = None;
                self.first_move = first_move;
                self.arc_not_allowed = arc_not_allowed;
                self.exit_delta = exit_delta;
                self.endpoint_valid = endpoint_valid;
            }
            Undo::All(saved) => *self = *saved,
        }
    }

    /// Called before a block runs: its events go after the held ones.
    pub(crate) fn begin_block(&mut self, out: &mut Vec<Event>) {
        if !self.carried.is_empty() {
            self.queue_start = Some(out.len());
            out.append(&mut self.carried);
        }
    }

    /// Called after a block ran: the events still held leave `out` until a
    /// later block releases them.
    #[inline]
    pub(crate) fn end_block(&mut self, out: &mut Vec<Event>) {
        if let Some(start) = self.queue_start.take() {
            self.carried = out.split_off(start);
        }
    }

    /// Checks LinuxCNC makes before reading the D word of G41/G42.
    pub(crate) fn check_turn_on(
        &self,
        plane: Plane,
        line: u64,
        column: usize,
    ) -> Result<(), GcodeError> {
        if plane == Plane::Yz {
            return Err(GcodeError::invalid(
                line,
                column,
                "Cutter radius compensation allowed only in XY, XZ planes",
            ));
        }
        if self.side.is_some() {
            return Err(GcodeError::invalid(
                line,
                column,
                "Cannot turn cutter radius comp on when on",
            ));
        }
        Ok(())
    }

    /// G41/G42 (`side`) with a tool radius in mm; a negative radius puts
    /// the tool on the other side. `orientation`: the lathe tool's (1–8; 0
    /// or 9 a mill tool), whose control point the moves are shifted to in
    /// G18 ([`lathe_tool_origin`]).
    pub(crate) fn turn_on(&mut self, side: Side, radius: f64, orientation: u8, plane: Plane) {
        let (side, radius) = if radius < 0.0 {
            (side.opposite(), -radius)
        } else {
            (side, radius)
        };
        self.side = Some(side);
        self.radius = radius;
        self.origin_shift = if plane == Plane::Zx {
            lathe_tool_origin(orientation, radius)
        } else {
            [0.0; 2]
        };
    }

    /// The lathe tool's shift as a move of X and Z.
    fn shift_axes(&self) -> Axes {
        let mut d = Axes::ZERO;
        d[Axis::X] = self.origin_shift[0];
        d[Axis::Z] = self.origin_shift[1];
        d
    }

    /// G40: the held move keeps its end; the interpreter resumes from the
    /// programmed position (`pos` is set to it) and the next move starts
    /// where the tool is.
    pub(crate) fn turn_off(
        &mut self,
        pos: &mut Axes,
        plane: Plane,
        out: &mut [Event],
        line: u64,
        column: usize,
    ) -> Result<(), GcodeError> {
        if self.engaged() && !self.first_move {
            let c = in_plane(pos, plane);
            self.move_endpoint_and_flush(c, plane, Units::Millimetre, out, line, column)?;
            self.flush(out, plane);
            // The machine is at the lathe tool's control point.
            let tool = self.tool.add(&self.shift_axes());
            for a in [Axis::X, Axis::Y, Axis::Z] {
                pos[a] = self.programmed[a];
            }
            let delta = tool.sub(pos);
            self.exit_delta = (delta.xyz_norm() > 0.0).then_some(delta);
            self.arc_not_allowed = true;
        }
        self.side = None;
        self.first_move = true;
        Ok(())
    }

    /// M0, M1, M2, M30, M60 release the held moves as they are; M2 and M30
    /// (`end`) also turn compensation off.
    pub(crate) fn stop(
        &mut self,
        pos: &Axes,
        plane: Plane,
        end: bool,
        out: &mut [Event],
        line: u64,
    ) -> Result<(), GcodeError> {
        let c = in_plane(pos, plane);
        self.move_endpoint_and_flush(c, plane, Units::Millimetre, out, line, 0)?;
        self.flush(out, plane);
        if end {
            self.side = None;
            self.first_move = true;
        }
        Ok(())
    }

    // ---------------------------------------------------------------------
    // The queue.

    fn enqueue(&mut self, out: &mut Vec<Event>, event: Event, held: Held) {
        let start = *self.queue_start.get_or_insert(out.len());
        self.held.push((out.len() - start, held));
        if let EventKind::Traverse(m) | EventKind::Feed(m) = &event.kind {
            self.tool = m.to;
        } else if let EventKind::Arc(a) = &event.kind {
            self.tool = a.to;
        }
        out.push(event);
    }

    fn front(&self, out: &[Event], plane: Plane) -> Front {
        let Some((start, &(k, _))) = self.queue_start.zip(self.held.first()) else {
            return self.stale_front.unwrap_or(Front::Straight);
        };
        match &out[start + k].kind {
            EventKind::Arc(a) => Front::Arc {
                center: {
                    let (p, q, _) = plane.axes();
                    [a.center[p.index()], a.center[q.index()]]
                },
                end: in_plane(&a.to, plane),
                turn: a.turns,
            },
            _ => Front::Straight,
        }
    }

    /// Releases every held event (LinuxCNC's `dequeue_canons`), moved to a
    /// lathe tool's control point (the entry move from where the tool was).
    fn flush(&mut self, out: &mut [Event], plane: Plane) {
        self.endpoint_valid = false;
        if let Some(start) = self.queue_start
            && !self.held.is_empty()
        {
            self.stale_front = Some(self.front(out, plane));
            if self.origin_shift != [0.0; 2] {
                let d = self.shift_axes();
                for (k, &(i, _)) in self.held.iter().enumerate() {
                    let keep_from = k == 0 && self.entry_held;
                    match &mut out[start + i].kind {
                        EventKind::Traverse(m) | EventKind::Feed(m) => {
                            if !keep_from {
                                m.from = m.from.add(&d);
                            }
                            m.to = m.to.add(&d);
                        }
                        EventKind::Arc(a) => {
                            if !keep_from {
                                a.from = a.from.add(&d);
                            }
                            a.to = a.to.add(&d);
                            a.center[Axis::X.index()] += d[Axis::X];
                            a.center[Axis::Z.index()] += d[Axis::Z];
                        }
                        _ => {}
                    }
                }
            }
        }
        self.entry_held = false;
        self.queue_start = None;
        self.held.clear();
    }

    fn set_endpoint(&mut self, xy: [f64; 2]) {
        self.endpoint = xy;
        self.endpoint_valid = true;
    }

    /// Moves the end of every held move to `xy` (plane coordinates), checks
    /// that none turns back or sweeps further than programmed (the tool
    /// would gouge), and releases them (LinuxCNC's
    /// `move_endpoint_and_flush`).
    fn move_endpoint_and_flush(
        &mut self,
        xy: [f64; 2],
        plane: Plane,
        units: Units,
        out: &mut [Event],
        line: u64,
        column: usize,
    ) -> Result<(), GcodeError> {
        let Some(start) = self.queue_start else {
            return Ok(());
        };
        if self.held.is_empty() {
            return Ok(());
        }
        let (p, q, _) = plane.axes();
        let err = |m: &str| GcodeError::invalid(line, column, m);
        for (k, &(i, held)) in self.held.iter().enumerate() {
            let ev = &mut out[start + i];
            match (&mut ev.kind, held) {
                (EventKind::Arc(a), Held::Arc { sweep }) => {
                    let c = [a.center[p.index()], a.center[q.index()]];
                    let r1 = dist(in_plane(&a.to, plane), c);
                    let r2 = dist(xy, c);
                    let turn = a.turns;
                    let l2 = find_turn(self.endpoint, c, turn, xy);
                    if (r1 - r2).abs() > 0.01 * units.mm_per_unit() {
                        return Err(err(&format!(
                            "cutter compensation made an invalid arc with mismatched radii r1 {r1:.4} mm r2 {r2:.4} mm"
                        )));
                    }
                    // 0.001 in or 0.0254 mm: both are 0.0254 mm.
                    if sweep != 0.0 && self.endpoint_valid && l2.abs() > sweep.abs() + 0.0254 {
                        return Err(err(
                            "Arc move in concave corner cannot be reached by the tool without gouging",
                        ));
                    }
                    if k > 0 {
                        a.from[p] = xy[0];
                        a.from[q] = xy[1];
                    }
                    a.to[p] = xy[0];
                    a.to[q] = xy[1];
                }
                (EventKind::Traverse(m) | EventKind::Feed(m), Held::Straight { dir }) => {
                    let d2 = [xy[0] - self.endpoint[0], xy[1] - self.endpoint[1]];
                    let dot = dir[0] * d2[0] + dir[1] * d2[1];
                    if self.endpoint_valid && dot < 0.0 {
                        return Err(err(if m.feed == Feed::Rapid {
                            "Straight traverse in concave corner cannot be reached by the tool without gouging"
                        } else {
                            "Straight feed in concave corner cannot be reached by the tool without gouging"
                        }));
                    }
                    if k > 0 {
                        m.from[p] = xy[0];
                        m.from[q] = xy[1];
                    }
                    m.to[p] = xy[0];
                    m.to[q] = xy[1];
                }
                _ => unreachable!("held moves are straight moves or arcs"),
            }
        }
        self.tool[p] = xy[0];
        self.tool[q] = xy[1];
        self.flush(out, plane);
        self.set_endpoint(xy);
        Ok(())
    }

    // ---------------------------------------------------------------------
    // Moves.

    /// A straight move (G0 if `rapid`, else G1) to the programmed `to`
    /// (work coordinates, mm), compensated; `pos` is the tool position,
    /// updated.
    pub(crate) fn straight(
        &mut self,
        rapid: bool,
        to: Axes,
        info: &MoveInfo,
        pos: &mut Axes,
        out: &mut Vec<Event>,
    ) -> Result<(), GcodeError> {
        let side = self.side.expect("compensation is on");
        let r = self.radius;
        let plane = info.plane;
        let pp = in_plane(&to, plane);
        let c = in_plane(pos, plane);
        if self.first_move {
            // The entry move.
            if dist(pp, c) <= r {
                return Err(info.invalid(
                    "Length of cutter compensation entry move is not greater than the tool radius",
                ));
            }
            let alpha = dir(c, pp)
                + if side == Side::Left {
                    FRAC_PI_2
                } else {
                    -FRAC_PI_2
                };
            let end = polar(pp, r, alpha);
            self.set_endpoint(c);
            self.tool = self.physical_start(pos);
            let ev = info.straight(rapid, self.tool, with_plane(to, plane, end));
            self.enqueue(
                out,
                ev,
                Held::Straight {
                    dir: [alpha.cos(), alpha.sin()],
                },
            );
            self.first_move = false;
            *pos = with_plane(to, plane, end);
            self.programmed = to;
            return Ok(());
        }
        let op = in_plane(&self.programmed, plane);
        if pp == op {
            // No motion in the plane: the tool stays where it is in it.
            let ev = info.straight(rapid, self.tool, with_plane(to, plane, c));
            self.enqueue(out, ev, Held::Straight { dir: [0.0, 0.0] });
            *pos = with_plane(to, plane, c);
            self.programmed = to;
            return Ok(());
        }
        let mut theta = dir(op, c);
        let mut alpha = dir(op, pp);
        let (beta, gamma) = match side {
            Side::Left => {
                if theta < alpha {
                    theta += TAU;
                }
                (theta - alpha - FRAC_PI_2, FRAC_PI_2)
            }
            Side::Right => {
                if alpha < theta {
                    alpha += TAU;
                }
                (alpha - theta - FRAC_PI_2, -FRAC_PI_2)
            }
        };
        let end = polar(pp, r, alpha + gamma);
        let mid = polar(op, r, alpha + gamma);
        let front = self.front(out, plane);
        let concave = if !(-SMALL..=PI + SMALL).contains(&beta) {
            true
        } else {
            // An "h" shape: over the round part, then along the straight
            // one; LinuxCNC keeps the tool above and to the side.
            beta > PI - SMALL
                && !self.held.is_empty()
                && matches!(front, Front::Arc { turn, .. }
                    if (side == Side::Right && turn > 0) || (side == Side::Left && turn < 0))
        };
        let units = info.units;
        let (line, column) = (info.at.line, info.column);
        if !concave && beta > SMALL {
            // Outside corner: an arc about the programmed corner (a
            // straight traverse for G0).
            self.move_endpoint_and_flush(c, plane, units, out, line, column)?;
            let (_, _, n) = plane.axes();
            let mut corner = with_plane(to, plane, mid);
            corner[n] = pos[n];
            if rapid {
                let ev = info.straight(true, self.tool, corner);
                self.enqueue(out, ev, Held::Straight { dir: [0.0, 0.0] });
            } else {
                let turn = if side == Side::Left { -1 } else { 1 };
                let ev = info.arc(self.tool, corner, op, turn);
                self.enqueue(out, ev, Held::Arc { sweep: 0.0 });
            }
            self.flush(out, plane);
            self.set_endpoint(mid);
        } else if concave {
            let mid = match front {
                Front::Straight => {
                    // Line to line: back along the compensated path to where
                    // the two offset lines meet.
                    let halfcorner = (beta + PI) / 2.0;
                    if halfcorner == 0.0 {
                        return Err(info.invalid(
                            "Zero degree inside corner is invalid for cutter compensation",
                        ));
                    }
                    let retreat = r / halfcorner.tan();
                    polar(c, retreat, theta + gamma)
                }
                Front::Arc {
                    center,
                    end: prev_end,
                    turn,
                } => {
                    // Arc to line: where the offset arc meets the offset
                    // line.
                    let oldrad = dist(center, prev_end);
                    let base_dir = dir(op, pp);
                    let theta = if turn > 0 {
                        base_dir + FRAC_PI_2
                    } else {
                        base_dir - FRAC_PI_2
                    };
                    let phi = dir(op, center);
                    let inside = side.inside(turn);
                    let oldrad_uncomp = if inside { oldrad + r } else { oldrad - r };
                    let d = oldrad_uncomp * (theta - phi).cos();
                    let l = if inside { d - r } else { d + r } / oldrad;
                    if !(-1.0..=1.0).contains(&l) {
                        return Err(info.invalid(
                            "Arc to straight motion makes a corner the compensated tool can't fit in without gouging",
                        ));
                    }
                    let angle = if inside == (turn > 0) {
                        -l.acos() + theta + PI
                    } else {
                        l.acos() + theta + PI
                    };
                    polar(center, oldrad, angle)
                }
            };
            self.move_endpoint_and_flush(mid, plane, units, out, line, column)?;
        } else {
            // Straight on (or a tangent arc to line).
            self.flush(out, plane);
            self.set_endpoint(c);
        }
        let ev = info.straight(rapid, self.tool, with_plane(to, plane, end));
        self.enqueue(
            out,
            ev,
            Held::Straight {
                dir: [pp[0] - op[0], pp[1] - op[1]],
            },
        );
        *pos = with_plane(to, plane, end);
        self.programmed = to;
        Ok(())
    }

    /// Checks of an arc entry move before its centre is found (LinuxCNC's
    /// order): the programmed end more than a radius away, and for an R
    /// arc (`r_word`, mm) with the tool inside, R larger than the tool.
    pub(crate) fn check_arc_entry(
        &self,
        start: [f64; 2],
        end: [f64; 2],
        ccw: bool,
        r_word: Option<f64>,
        info: &MoveInfo,
    ) -> Result<(), GcodeError> {
        if dist(end, start) <= self.radius {
            return Err(info.invalid(
                "Radius of cutter compensation entry arc is not greater than the tool radius",
            ));
        }
        let side = self.side.expect("compensation is on");
        if let Some(rw) = r_word
            && rw.abs() <= self.radius
            && side.inside(if ccw { 1 } else { -1 })
        {
            return Err(info.invalid("Tool radius not less than arc radius with comp"));
        }
        Ok(())
    }

    /// An arc (`turns` positive counter-clockwise, LinuxCNC's `turn`) about
    /// `center` (plane coordinates, found from the programmed start) to the
    /// programmed `to`, compensated; `pos` is the tool position, updated.
    pub(crate) fn arc(
        &mut self,
        turns: i32,
        center: [f64; 2],
        to: Axes,
        info: &MoveInfo,
        pos: &mut Axes,
        out: &mut Vec<Event>,
    ) -> Result<(), GcodeError> {
        let side = self.side.expect("compensation is on");
        let r = self.radius;
        let plane = info.plane;
        let e = in_plane(&to, plane);
        let c = in_plane(pos, plane);
        let inside = side.inside(turns);
        let tool_not_less = || info.invalid("Tool radius not less than arc radius with comp");
        if self.first_move {
            // The entry arc: the tool stays tangent to an arc through the
            // programmed end that touches the tool where it is.
            if dist(center, c) <= r && inside {
                return Err(tool_not_less());
            }
            let gamma = if inside {
                dir(e, center)
            } else {
                dir(center, e)
            };
            self.first_move = false;
            self.programmed = to;
            let end = polar(e, r, gamma);
            let b_len = dist(c, end) / 2.0;
            let ab_ang = dir(end, center);
            let a_ang = dir(end, c) - ab_ang;
            if a_ang.cos().abs() < TOLERANCE_EQUAL {
                return Err(tool_not_less());
            }
            let c_len = b_len / a_ang.cos();
            let new_center = polar(end, c_len, ab_ang);
            let spiral = match info.units {
                Units::Inch => 2.0 * 0.001 * std::f64::consts::SQRT_2 * 25.4,
                Units::Millimetre => 2.0 * 0.01 * std::f64::consts::SQRT_2,
            };
            if (dist(new_center, end) - dist(new_center, c)).abs() > spiral {
                return Err(info.invalid("Bug in tool radius comp"));
            }
            self.tool = self.physical_start(pos);
            let end_pos = with_plane(to, plane, end);
            let ev = info.arc(self.tool, end_pos, new_center, turns);
            self.enqueue(
                out,
                ev,
                Held::Arc {
                    sweep: find_turn(c, new_center, turns, end),
                },
            );
            *pos = end_pos;
            return Ok(());
        }
        let op = in_plane(&self.programmed, plane);
        let arc_radius = dist(center, e);
        let mut theta = dir(op, c);
        theta = if side == Side::Left {
            theta - FRAC_PI_2
        } else {
            theta + FRAC_PI_2
        };
        let mut delta = dir(op, center);
        let alpha = if turns > 0 {
            delta - FRAC_PI_2
        } else {
            delta + FRAC_PI_2
        };
        let mut beta = if side == Side::Left {
            theta - alpha
        } else {
            alpha - theta
        };
        if beta > 1.5 * PI {
            beta -= TAU;
        } else if beta < -FRAC_PI_2 {
            beta += TAU;
        }
        let gamma = if inside {
            if arc_radius <= r {
                return Err(tool_not_less());
            }
            dir(e, center)
        } else {
            delta += PI;
            dir(center, e)
        };
        let new_end = polar(e, r, gamma);
        let sweep = find_turn(op, center, turns, e);
        let (line, column) = (info.at.line, info.column);
        let units = info.units;
        let end_pos = with_plane(to, plane, new_end);
        if !(-SMALL..=PI + SMALL).contains(&beta) || ((beta - PI).abs() < SMALL && !inside) {
            // Inside corner.
            let mid = match self.front(out, plane) {
                Front::Straight => {
                    // Line to arc.
                    let cy = arc_radius * (beta - FRAC_PI_2).sin();
                    let gouge = || {
                        info.invalid(
                            "Arc move in concave corner cannot be reached by the tool without gouging",
                        )
                    };
                    let (dist_from_center, angle) = if inside {
                        let d = arc_radius - r;
                        let l = (cy + r) / d;
                        if !(-1.0..=1.0).contains(&l) {
                            return Err(gouge());
                        }
                        (
                            d,
                            if turns > 0 {
                                theta + l.asin()
                            } else {
                                theta - l.asin()
                            },
                        )
                    } else {
                        let d = arc_radius + r;
                        let l = (cy - r) / d;
                        if !(-1.0..=1.0).contains(&l) {
                            return Err(gouge());
                        }
                        (
                            d,
                            if turns > 0 {
                                theta + PI - l.asin()
                            } else {
                                theta + PI + l.asin()
                            },
                        )
                    };
                    polar(center, dist_from_center, angle)
                }
                Front::Arc {
                    center: prev_center,
                    end: prev_end,
                    turn: prev_turn,
                } => {
                    // Arc to arc: where the two offset arcs meet.
                    let oldrad = dist(prev_center, prev_end);
                    let newrad = if inside {
                        arc_radius - r
                    } else {
                        arc_radius + r
                    };
                    let arc_cc = dist(prev_center, center);
                    if oldrad == 0.0 || arc_cc == 0.0 {
                        return Err(info.invalid(
                            "Arc to arc motion is invalid because the arcs have the same center",
                        ));
                    }
                    let a = (oldrad * oldrad + arc_cc * arc_cc - newrad * newrad)
                        / (2.0 * oldrad * arc_cc);
                    if !(-1.0..=1.0).contains(&a) {
                        return Err(info.invalid(
                            "Arc to arc motion makes a corner the compensated tool can't fit in without gouging",
                        ));
                    }
                    let pullback = a.acos();
                    let cc_dir = dir(prev_center, center);
                    let dir = if side.inside(prev_turn) == (turns > 0) {
                        cc_dir + pullback
                    } else {
                        cc_dir - pullback
                    };
                    polar(prev_center, oldrad, dir)
                }
            };
            self.move_endpoint_and_flush(mid, plane, units, out, line, column)?;
            let ev = info.arc(self.tool, end_pos, center, turns);
            self.enqueue(out, ev, Held::Arc { sweep });
        } else if beta > SMALL {
            // Outside corner: an arc about the programmed corner first.
            let mid = polar(op, r, delta);
            self.flush(out, plane);
            let (_, _, n) = plane.axes();
            let mut corner = with_plane(to, plane, mid);
            corner[n] = pos[n];
            let turn = if side == Side::Left { -1 } else { 1 };
            let ev = info.arc(self.tool, corner, op, turn);
            self.enqueue(out, ev, Held::Arc { sweep: 0.0 });
            self.flush(out, plane);
            self.set_endpoint(mid);
            let ev = info.arc(self.tool, end_pos, center, turns);
            self.enqueue(out, ev, Held::Arc { sweep });
        } else {
            // Tangent: straight on.
            self.flush(out, plane);
            self.set_endpoint(c);
            let ev = info.arc(self.tool, end_pos, center, turns);
            self.enqueue(out, ev, Held::Arc { sweep });
        }
        self.programmed = to;
        *pos = end_pos;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::gcode::error::GcodeError;
    use crate::gcode::event::{Event, EventKind};
    use crate::gcode::interp::{InterpOptions, Interpreter};
    use crate::gcode::stream::Program;

    /// Runs `src` block by block; the events of each block, or its error.
    fn blocks(src: &str) -> Vec<Result<Vec<Event>, GcodeError>> {
        let program = Program::parse(src.as_bytes()).unwrap();
        let mut it = Interpreter::new(InterpOptions::default());
        program
            .blocks
            .iter()
            .map(|b| {
                let mut out = Vec::new();
                it.execute(b, &mut out).map(|()| out)
            })
            .collect()
    }

    /// The events of the blocks, `None` for a failing one.
    fn events(src: &str) -> Vec<Option<Vec<EventKind>>> {
        blocks(src)
            .into_iter()
            .map(|r| r.ok().map(|ev| ev.into_iter().map(|e| e.kind).collect()))
            .collect()
    }

    /// A contour left of the path, then G40 alone on its line.
    const ENTRY_AND_EXIT: &str =
        "G21 G90 G17 G94 F100\nG0 X0 Y0\nG41.1 D2 G1 X10 Y0\nG1 X10 Y10\nG40\n";

    #[test]
    fn a_failing_block_after_g40_leaves_the_exit_rules() {
        // After G40 the next move must be straight and starts where the tool
        // is. A block that fails in its move (G93 without F) must keep both:
        // the program goes on exactly as if that block were not there.
        let tail = "G94 G1 X0 Y0 F100\nG3 X0 Y0 I-5 J0\n";
        let without = events(&format!("{ENTRY_AND_EXIT}{tail}"));
        let with = events(&format!("{ENTRY_AND_EXIT}G93 G1 X5 Y5\n{tail}"));
        assert_eq!(with[5], None, "G93 without F is refused");
        assert_eq!(with[..5], without[..5]);
        assert_eq!(with[6..], without[5..]);
        // The straight move after G40 starts where the tool is, not at the
        // programmed (10, 10): left of the last move (+Y) by the radius, 1
        // (G41.1's D is the diameter).
        let Some(EventKind::Feed(m)) = without[5].as_ref().and_then(|e| e.last()) else {
            panic!("a straight feed: {:?}", without[5]);
        };
        assert_eq!((m.from.0[0], m.from.0[1]), (9.0, 10.0));
        // An arc right after the failed block is still refused.
        let arc = blocks(&format!(
            "{ENTRY_AND_EXIT}G93 G1 X5 Y5\nG94 G3 X0 Y10 I-5 J0 F100\n"
        ));
        let e = arc[6].as_ref().unwrap_err().to_string();
        assert!(e.contains("must be straight, not an arc"), "{e}");
    }

    #[test]
    fn a_failing_block_that_turned_compensation_on_leaves_it_off() {
        // G41.1 runs before the move, which fails (G93 without F): the next
        // move is not compensated (made at once, to its programmed end).
        let ev =
            events("G21 G90 G17 G94 F100\nG0 X0 Y0\nG41.1 D2 G93 G1 X10 Y0\nG94 G1 X10 Y0 F100\n");
        assert_eq!(ev[2], None);
        let moves: Vec<_> = ev[3]
            .iter()
            .flatten()
            .filter_map(|k| match k {
                EventKind::Feed(m) => Some(m),
                _ => None,
            })
            .collect();
        assert_eq!(moves.len(), 1, "{:?}", ev[3]);
        assert_eq!((moves[0].to.0[0], moves[0].to.0[1]), (10.0, 0.0));
        assert_eq!((moves[0].from.0[0], moves[0].from.0[1]), (0.0, 0.0));
    }

    #[test]
    fn lathe_tool_origins_follow_the_orientation() {
        use super::lathe_tool_origin;
        let r = 0.5;
        // Corner tools: the tip at a corner of the square about the nose.
        assert_eq!(lathe_tool_origin(1, r), [-r, r]);
        assert_eq!(lathe_tool_origin(2, r), [-r, -r]);
        assert_eq!(lathe_tool_origin(3, r), [r, -r]);
        assert_eq!(lathe_tool_origin(4, r), [r, r]);
        // Tips on an axis.
        assert_eq!(lathe_tool_origin(5, r), [0.0, r]);
        assert_eq!(lathe_tool_origin(6, r), [-r, 0.0]);
        assert_eq!(lathe_tool_origin(7, r), [0.0, -r]);
        assert_eq!(lathe_tool_origin(8, r), [r, 0.0]);
        // Mill tools and a nose on the control point.
        for o in [0, 9, 10] {
            assert_eq!(lathe_tool_origin(o, r), [0.0, 0.0]);
        }
        assert_eq!(super::lathe_orientation(3.0), Ok(3));
        assert_eq!(super::lathe_orientation(-1.0), Err("Negative l word used"));
        assert_eq!(
            super::lathe_orientation(2.5),
            Err("Non integer value for integer")
        );
    }

    /// The ends and starts (X Z) of the straight moves of `src`.
    fn lathe_ends(src: &str) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let ev: Vec<EventKind> = events(src).into_iter().flatten().flatten().collect();
        ev.iter()
            .filter_map(|k| match k {
                EventKind::Feed(m) | EventKind::Traverse(m) => {
                    Some(([m.to.0[0], m.to.0[2]], [m.from.0[0], m.from.0[2]]))
                }
                _ => None,
            })
            .unzip()
    }

    #[test]
    fn a_lathe_tool_moves_its_control_point_by_the_orientation() {
        // G18 (plane coordinates Z, X), tool right of the path, radius 1
        // (D2). The entry from X20 Z0 runs along −X to X10: right of it is
        // −Z, so the nose centre would end at Z −1 X 10; the next move runs
        // along −Z, right of it +X: an inside corner, where the two offset
        // lines Z = −1 and X = 11 meet, so the entry ends at X11 Z−1 and the
        // second move at X11 Z−10. After G40 the move goes to X20 Z−10.
        let program = |l: u8| {
            format!(
                "G21 G18 G90 G94 F100\nG0 X20 Z0\nG42.1 D2 L{l} G1 X10 Z0\nG1 X10 Z-10\nG40\nG1 X20 Z-10\nM2\n"
            )
        };
        let close =
            |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9;
        let (mill, starts) = lathe_ends(&program(0));
        let want = [[20.0, 0.0], [11.0, -1.0], [11.0, -10.0], [20.0, -10.0]];
        assert_eq!(mill.len(), 4, "{mill:?}");
        for (g, w) in mill.iter().zip(want) {
            assert!(close(*g, w), "{mill:?}");
        }
        assert!(close(starts[3], [11.0, -10.0]), "{starts:?}");
        for l in 1..=8u8 {
            let (lathe, st) = lathe_ends(&program(l));
            let d = super::lathe_tool_origin(l, 1.0);
            let moved = |p: [f64; 2]| [p[0] + d[0], p[1] + d[1]];
            assert_eq!(lathe.len(), 4);
            // The traverse before and the move after G40 go to the
            // programmed points; the entry starts where the tool was;
            // both compensated ends move by the orientation's shift, and
            // the move after G40 starts from the shifted end.
            assert!(
                close(lathe[0], want[0]) && close(lathe[3], want[3]),
                "L{l}: {lathe:?}"
            );
            assert!(close(st[1], want[0]), "L{l}: {st:?}");
            for k in 1..3 {
                assert!(close(lathe[k], moved(want[k])), "L{l} move {k}: {lathe:?}");
            }
            assert!(
                close(st[2], moved(want[1])) && close(st[3], moved(want[2])),
                "L{l}: {st:?}"
            );
        }
    }
}
