//! The G-code engine: a lossless parser and writer, a modal interpreter for
//! RS-274/NGC without parameters and control flow (as LinuxCNC 2.9 runs
//! it), and program statistics.
//!
//! * [`Block`] / [`BlockReader`] / [`BlockWriter`] / [`Program`]: one line is
//!   one block holding its exact bytes, so writing an unchanged program
//!   reproduces it byte for byte; [`Block::set_word`] edits one word and
//!   keeps every other byte. Reading streams line by line (a 1 GB program is
//!   never held in memory).
//! * [`Interpreter`]: blocks in, canonical [`Event`]s out (mm, degree,
//!   mm/min, s), each with its [`SourcePos`] and what the block wrote
//!   ([`Programmed`]) so that a rewriter can change exactly the word behind a
//!   coordinate. Runs motion (G0–G3, probing, G53), canned cycles (G73,
//!   G74, G81–G89 with G98/G99 and L), offsets (G54–G59.3, G10 L2/L20,
//!   G92/G92.1/G92.2/G92.3, G52, G28/G30 and their .1), tools (T, M6, G43,
//!   G43.1, G43.2, G49, G10 L1/L10/L11 with a [`ToolTable`] read from
//!   LinuxCNC's `.tbl` format), cutter radius compensation (G40, G41, G42,
//!   G41.1, G42.1: moves held back one block for the next corner),
//!   spindle-synchronised moves (G33, G33.1 rigid tapping, fed at K per
//!   spindle revolution) and stops at M2/M30 or the closing `%`.
//!   Expressions and parameters ([`Parameters`]: numbered,
//!   named local and global, read from a LinuxCNC var file with
//!   [`read_var_file`]) are evaluated as LinuxCNC does; everything outside
//!   the supported language (G76, splines,
//!   ...) is an [`GcodeError::Unsupported`]
//!   error naming the line. G-codes are the [`GCode`] type. Dialects:
//!   [`Dialect`] (LinuxCNC, Fanuc).
//! * [`run_program`] ([`program_flow`]): the one driver every command uses:
//!   O-word subroutines and loops, external subroutine files, Fanuc-style
//!   M98/M99 programs, `(DEBUG,…)`/`(PRINT,…)` messages; a program without
//!   O-words and M98/M99 streams, one with them is held in memory from its
//!   first such line.
//!   `compensate` keeps the program's structure and refuses a line whose
//!   runs need different corrections (see docs/gcode.md).
//! * [`stats`]: counts, path lengths, axis travel and ranges, estimated time.
//! * [`interpolate`] / [`Interpolator`]: axis command samples at a fixed
//!   period along a program on a machine model (feeds, G93, rapids, dwells,
//!   trapezoidal profiles within the axis velocity and acceleration limits,
//!   TCP through the nominal inverse kinematics), streamed to a callback.
//! * [`timing`]: the motion rules both use (the path a feed applies to, the
//!   duration of a move at a feed, of a rapid, straight interpolation).
//! * Machine travel checks during statistics plug in through
//!   [`MotionObserver`].
//! * [`ProgramWriter`]: the one writer of generated programs (numbers,
//!   decimal points, dwell, probing, comments, start and end per
//!   [`Dialect`]).
//!
//! ```
//! use mtwin::gcode::{self, Block, StatsOptions};
//!
//! let program = "G21 G90 G94\nG1 X10 Y0 F600 (cut)\nG1 Y10\nM30\n";
//! let st = gcode::stats(program.as_bytes(), &StatsOptions::default()).unwrap();
//! assert_eq!(st.feed_length, 20.0);
//! assert_eq!(st.feed_time, 2.0); // 20 mm at 600 mm/min
//!
//! let mut block = Block::parse(b"G1 X10  Y0 F600 (cut)\n", 2).unwrap();
//! block.set_word('Z', -1.25).unwrap();
//! assert_eq!(block.text(), b"G1 X10  Y0 Z-1.25 F600 (cut)");
//! ```

mod arc;
mod axes;
mod codes;
mod cutter_comp;
mod dialect;
pub mod doc;
mod error;
mod event;
mod expr;
mod interp;
// Being rewritten with the motion planner; documented there.
#[allow(missing_docs)]
mod interpolate;
mod lathe_diameter_mode;
mod lexer;
pub mod linuxcnc_ini;
pub mod parameters;
pub mod plan;
mod profile;
pub mod program_flow;
#[warn(missing_docs)]
mod program_writer;
#[warn(missing_docs)]
mod stats;
mod stream;
mod syntax;
mod threading_cycle;
#[warn(missing_docs)]
pub mod timing;
mod tool_table;
mod travel;
pub mod var_file;

pub use axes::{Axes, Axis, AxisLetterError, AxisMask};
pub use codes::{GCode, ModalGroup};
pub use dialect::Dialect;
pub use doc::{AxisRangeDoc, GcodeInterpolateDoc, GcodeStatsDoc, TravelViolationDoc};
pub use error::{GcodeError, Location};
pub use event::{
    ArcMove, DistanceMode, Event, EventKind, Feed, FeedMode, Linear, PathMode, Plane, Programmed,
    SourcePos, SpindleState, TaskWait, Units,
};
pub use interp::{InterpOptions, Interpreter, ModalState, MotionMode, RetractMode, UnknownMCode};
pub use interpolate::{
    DensePath, InterpolateError, InterpolateOptions, InterpolationSummary, Interpolator,
    LineEndTimes, Sample, dense_paths, interpolate, jerk_limits, line_end_times, planned_duration,
    planned_duration_with,
};
pub use parameters::Parameters;
pub use profile::Trapezoid;
pub use program_flow::{
    Message, MessageKind, MessageSink, ProgramOptions, RunSummary, Step, run_program,
};
pub use program_writer::{
    ArcDirection, BlockBuilder, ProgramEnd, ProgramWriter, WriteError, WriterOptions,
};
pub use stats::{
    AxisRange, MotionObserver, ProgramStats, StatsOptions, stats, stats_planned, stats_with,
};
pub use stream::{BlockReader, BlockWriter, Program};
pub use syntax::{Block, CommentKind, Item, LineEnd, NumberFormat, Span, Value, Word};
pub use tool_table::{Tool, ToolTable, ToolTableError};
pub use travel::{TravelCheck, TravelViolation};
pub use var_file::{read_var_file, write_var_file};

/// Interprets a whole program from `input` (streaming, or held in memory
/// from its first O-word line on: see [`program_flow`]), calling `sink`
/// with each executed block and the events it produced (possibly none).
pub fn interpret<R, F>(input: R, opts: InterpOptions, mut sink: F) -> Result<(), GcodeError>
where
    R: std::io::BufRead,
    F: FnMut(&Block, &[Event]) -> Result<(), GcodeError>,
{
    let program = opts.program.clone();
    let dialect = opts.dialect;
    let mut interp = Interpreter::new(opts);
    run_program(input, &mut interp, &program, dialect, |step: &Step<'_>| {
        sink(step.block, step.events)
    })?;
    Ok(())
}
