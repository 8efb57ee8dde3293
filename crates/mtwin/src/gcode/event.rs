//! Canonical events: what a program asks the machine to do, in canonical
//! units (mm, degree, mm/min, s, rev/min), each tagged with the block it came
//! from and with what that block wrote, so a rewriter can edit exactly the
//! word behind a coordinate.

use super::arc;
use super::axes::{Axes, Axis, AxisMask};

/// Where an event comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SourcePos {
    /// 1-based line number.
    pub line: u64,
    /// 0-based index of the block among the blocks given to the interpreter
    /// (one block per line, so `line - 1` when every line was given; each
    /// run of a block in a loop or subroutine counts).
    pub block: u64,
    /// The file: 0 the program, n ≥ 1 the n-th subroutine file read
    /// (`RunSummary::files`).
    pub file: u32,
}

/// Length units of the program text.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Units {
    /// G21.
    #[default]
    Millimetre,
    /// G20.
    Inch,
}

impl Units {
    /// mm per program length unit.
    pub fn mm_per_unit(self) -> f64 {
        match self {
            Units::Millimetre => 1.0,
            Units::Inch => 25.4,
        }
    }
}

/// G90/G91.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DistanceMode {
    /// G90: coordinates are positions.
    #[default]
    Absolute,
    /// G91: coordinates are distances from the current position.
    Incremental,
}

/// Arc plane: G17 (XY, normal +Z), G18 (ZX, normal +Y), G19 (YZ, normal +X).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Plane {
    /// G17: the XY plane, arcs about +Z.
    #[default]
    Xy,
    /// G18: the ZX plane, arcs about +Y.
    Zx,
    /// G19: the YZ plane, arcs about +X.
    Yz,
}

impl Plane {
    /// The first and second in-plane axes and the normal axis, ordered so
    /// that first × second = normal (LinuxCNC's ARC_FEED order).
    pub fn axes(self) -> (Axis, Axis, Axis) {
        match self {
            Plane::Xy => (Axis::X, Axis::Y, Axis::Z),
            Plane::Zx => (Axis::Z, Axis::X, Axis::Y),
            Plane::Yz => (Axis::Y, Axis::Z, Axis::X),
        }
    }

    /// Unit normal of the plane in the work frame.
    pub fn normal(self) -> [f64; 3] {
        match self {
            Plane::Xy => [0.0, 0.0, 1.0],
            Plane::Zx => [0.0, 1.0, 0.0],
            Plane::Yz => [1.0, 0.0, 0.0],
        }
    }
}

/// G93/G94/G95.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FeedMode {
    /// G93: F is the inverse of the move time, 1/min.
    InverseTime,
    /// G94: F is a speed, mm/min (deg/min for rotary-only moves).
    #[default]
    UnitsPerMinute,
    /// G95: F is mm per spindle revolution.
    UnitsPerRevolution,
}

/// The feed of one move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feed {
    /// Rapid traverse (G0) at the machine's rapid rate.
    Rapid,
    /// mm/min along the XYZ path (UVW if XYZ is still, deg/min along ABC if
    /// only rotary axes move), as LinuxCNC applies it.
    PerMinute(f64),
    /// The move lasts 1/f minutes (G93).
    InverseTime(f64),
    /// mm per revolution at the given spindle speed in rev/min (G95).
    PerRevolution {
        /// Feed per spindle revolution, mm.
        mm_per_rev: f64,
        /// Spindle speed, rev/min.
        rpm: f64,
    },
}

/// Spindle direction (M3/M4/M5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpindleState {
    /// M3: turning clockwise.
    Clockwise,
    /// M4: turning counter-clockwise.
    CounterClockwise,
    /// M5 (and at program start): stopped.
    #[default]
    Stopped,
}

/// What the block wrote for a move: enough to rewrite it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Programmed {
    /// The axes that had a word in the block.
    pub axes: AxisMask,
    /// The block was G53 (machine coordinates).
    pub g53: bool,
    /// Distance mode of the block.
    pub distance: DistanceMode,
    /// Length units of the block.
    pub units: Units,
    /// The move is one of several that one block expands to (a canned
    /// cycle, the two moves of G28/G30): its end is not what the block's
    /// words say, so no word can be rewritten to move it. Also set for the
    /// spindle-synchronised moves (G33, the tap and retract of G33.1),
    /// which a rewriter must not split into G1 pieces, and for a move by
    /// LinuxCNC's polar words `@ ^` (its X Y end has no X or Y word).
    pub expanded: bool,
    /// The block was read in lathe diameter mode (G7): its X word is a
    /// diameter, twice the X position it moves to.
    pub x_diameter: bool,
}

impl Programmed {
    /// The word value (program units) that makes the move end at `end`
    /// (work coordinates, mm/deg) on `axis`, given the move's start and the
    /// offset of its event. Rotary rollover is not undone.
    pub fn word_value(&self, axis: Axis, from: &Axes, end: f64, offset: &Axes) -> f64 {
        let scale = if axis.is_rotary() {
            1.0
        } else {
            self.units.mm_per_unit()
        };
        let canonical = if self.g53 {
            end + offset[axis]
        } else {
            match self.distance {
                DistanceMode::Absolute => end,
                DistanceMode::Incremental => end - from[axis],
            }
        };
        let value = canonical / scale;
        if axis == Axis::X {
            super::lathe_diameter_mode::x_word(value, self.x_diameter)
        } else {
            value
        }
    }
}

/// A straight move (traverse or feed). Positions are in the active work
/// coordinate system (what LinuxCNC's canon receives), mm and degree.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linear {
    /// Start position, work coordinates.
    pub from: Axes,
    /// End position, work coordinates.
    pub to: Axes,
    /// Work offset plus tool length offset: machine coordinates (identity
    /// kinematics) are `to + offset`.
    pub offset: Axes,
    /// The feed.
    pub feed: Feed,
    /// Tool centre point control was on (XYZ is the tool tip in the work frame).
    pub tcp: bool,
    /// What the block wrote.
    pub words: Programmed,
}

/// A circular or helical move about an axis parallel to the plane normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcMove {
    /// Start position, work coordinates.
    pub from: Axes,
    /// End position, work coordinates.
    pub to: Axes,
    /// Centre, work X Y Z; its normal-axis coordinate is that of `from`.
    pub center: [f64; 3],
    /// The plane.
    pub plane: Plane,
    /// Signed number of turns: positive counter-clockwise about the plane
    /// normal (G3), negative clockwise (G2); |turns| − 1 full circles are
    /// added to the shortest sweep in that direction (LinuxCNC's `rotation`).
    pub turns: i32,
    /// Work offset plus tool length offset, as in [`Linear::offset`].
    pub offset: Axes,
    /// The feed.
    pub feed: Feed,
    /// Tool centre point control was on.
    pub tcp: bool,
    /// What the block wrote.
    pub words: Programmed,
}

impl ArcMove {
    /// Unit normal of the arc (the rotation axis direction for positive turns).
    pub fn normal(&self) -> [f64; 3] {
        self.plane.normal()
    }

    /// In-plane radius at the start, mm.
    pub fn radius(&self) -> f64 {
        arc::geometry(self).radius
    }

    /// Signed swept angle about the normal, rad.
    pub fn sweep(&self) -> f64 {
        arc::geometry(self).sweep
    }

    /// Length of the helical XYZ path, mm (the in-plane radius may change
    /// linearly from start to end, as in LinuxCNC).
    pub fn xyz_length(&self) -> f64 {
        arc::geometry(self).xyz_length()
    }
}

/// Path control mode (G61, G61.1, G64), as LinuxCNC documents it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathMode {
    /// G61: exact path. Every block ends on its programmed end point; a
    /// planner may keep the speed through blocks that continue in the same
    /// direction, and stops at corners.
    ExactPath,
    /// G61.1: exact stop. The machine stops at the end of every block.
    ExactStop,
    /// G64: blending, with the path tolerance `p` (mm, `None`: as fast as
    /// possible, no tolerance) and the naive-CAM tolerance `q` (mm,
    /// `None`: collinear straight feeds are not merged).
    Blend {
        /// Path tolerance, mm.
        p: Option<f64>,
        /// Naive-CAM (collinear merge) tolerance, mm.
        q: Option<f64>,
    },
}

impl PathMode {
    /// LinuxCNC's mode at start-up: G64 without tolerances.
    pub const DEFAULT: PathMode = PathMode::Blend { p: None, q: None };
}

impl Default for PathMode {
    fn default() -> Self {
        PathMode::DEFAULT
    }
}

/// A command that LinuxCNC 2.9's task layer runs only once the motion queue
/// is empty (its task waits for motion before it, `emcTaskCheckPreconditions`):
/// the machine comes to rest there, so no planner blends across it. Besides
/// these, M3/M4/M5 ([`EventKind::Spindle`]), S ([`EventKind::SpindleSpeed`]),
/// G4 ([`EventKind::Dwell`]), the TCP switch ([`EventKind::Tcp`]) and the
/// program end wait too.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TaskWait {
    /// M6: tool change (through the I/O controller).
    ToolChange,
    /// M61: the tool number in the spindle set without a change (through
    /// the I/O controller; the interpreter then re-reads the machine).
    ToolNumber,
    /// M7: mist coolant on (through the I/O controller).
    MistOn,
    /// M9: mist coolant off (through the I/O controller; M9 is mist off,
    /// then flood off).
    MistOff,
    /// M8: flood coolant on (through the I/O controller).
    FloodOn,
    /// M9: flood coolant off (through the I/O controller).
    FloodOff,
    /// M19: spindle orientation, and its wait until oriented.
    SpindleOrient,
    /// M64/M65 (digital) and M68 (analog): an output set at once, not
    /// synchronised with motion as M62/M63/M67 are.
    Output,
    /// M66: wait for an input.
    InputWait,
    /// M0 (program stop), M1 (optional stop), M60 (pallet change stop):
    /// the program may pause until the operator resumes it; that time is
    /// no part of any estimate.
    Pause,
}

impl TaskWait {
    /// Whether LinuxCNC 2.9 hands the command to its separate I/O controller
    /// (`[EMCIO]`, tool and coolant commands) and waits for it to report
    /// done; the others the task or the motion controller runs.
    pub fn through_io(self) -> bool {
        matches!(
            self,
            TaskWait::ToolChange
                | TaskWait::ToolNumber
                | TaskWait::MistOn
                | TaskWait::MistOff
                | TaskWait::FloodOn
                | TaskWait::FloodOff
        )
    }
}

/// Kinds of canonical event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EventKind {
    /// G0, or G53 G0.
    Traverse(Linear),
    /// G1, or G53 G1; also G33 and the tap and retract of G33.1, fed at
    /// [`Feed::PerRevolution`] K at the spindle speed (the retract at I
    /// times it).
    Feed(Linear),
    /// G2/G3.
    Arc(ArcMove),
    /// G4, s.
    Dwell {
        /// Duration, s.
        seconds: f64,
    },
    /// S, rev/min.
    SpindleSpeed {
        /// Spindle speed, rev/min.
        rpm: f64,
    },
    /// M3/M4/M5.
    Spindle(SpindleState),
    /// G93/G94/G95.
    FeedMode(FeedMode),
    /// F, canonical: mm/min (G94), 1/min (G93), mm/rev (G95).
    FeedRate(f64),
    /// TCP on or off (G43.4/G49, or the configured M-codes).
    Tcp(bool),
    /// G20/G21.
    Units(Units),
    /// G54..G59.3 selected: system number 1..=9 and its offset, mm/deg.
    WorkOffset {
        /// Coordinate system number, 1 (G54) to 9 (G59.3).
        system: u8,
        /// Its offset, mm (degree for rotary axes).
        offset: Axes,
        /// Its rotation about Z (G10 L2 R), degrees: move events give X Y
        /// rotated by it (machine = position + offset).
        rotation: f64,
    },
    /// G43/G43.4/G49: tool length offset along Z now in force, mm.
    ToolLengthOffset {
        /// Tool length offset along Z, mm.
        length: f64,
    },
    /// G61, G61.1 or G64 (P and Q converted to mm).
    PathControl(PathMode),
    /// A command the machine waits at, at rest (M6, M7, M8, M9, M19,
    /// M64–M66, M68, M0, M1, M60): see [`TaskWait`].
    Wait(TaskWait),
    /// M2/M30.
    ProgramEnd,
}

/// One canonical event and its source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event {
    /// The block that produced the event.
    pub at: SourcePos,
    /// What happened.
    pub kind: EventKind,
}
