//! The five-axis digital twin of trajectory error (after \[R5\] in docs/references.md).
//!
//! Axis commands at the servo period ([`commands`]) → command tool tip and axis in W
//! by nominal forward kinematics → per-axis servo models (encoder positions) →
//! forward kinematics with the geometric errors → actual tool tip and axis in W →
//! the exact global nearest point on the command tool-tip polyline ([`nearest`]),
//! the tool-tip error `ε_p` (mm) and the tool-axis error `ε_o` (rad)
//! ([`pipeline`]). [`plot`] draws the results.
//!
//! Memory: the command polyline (tips and axes, 48 bytes per sample, plus its
//! box hierarchy and clearances, about 8 bytes per sample) is held for the global search; actual
//! samples are spooled to a temporary file (56 bytes per sample on disk) and
//! rows are streamed to the caller.

pub mod breakdown;
pub mod commands;
pub mod doc;
pub mod nearest;
pub mod pipeline;
pub mod plot;
pub mod run;

#[cfg(test)]
mod tests;

pub use breakdown::{Commands, breakdown, predict};
pub use commands::{predict_csv, predict_gcode};
pub use doc::{BySourceDoc, StretchDoc, TwinBreakdownDoc, TwinErrorsDoc, TwinPredictDoc, dominant};
pub use nearest::{CommandPath, Nearest, angle_between};
pub use pipeline::{At, Bin, Predictor, Progress, Sources, Twin, TwinSample, TwinSummary};
pub use run::{PLOT_FILES, PredictOptions, PredictRun, pred_row, run};

use crate::gcode::InterpolateError;
use crate::io::Diagnostic;
use crate::sysid::SysidError;

/// Why the twin could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TwinError {
    /// A problem in CMD.csv (file, line, column).
    #[error("{0}")]
    Input(#[from] Diagnostic),
    /// The G-code program could not be interpolated (see its line).
    #[error(transparent)]
    Program(InterpolateError),
    /// The command period is not a positive number.
    #[error("the command period must be a positive number of seconds, not {}", crate::limits::fmt_message_number(*.0))]
    Period(f64),
    /// A servo model runs at another period than the commands.
    #[error(
        "axis {axis}: its servo model runs at ts = {} s but the commands come every {} s; identify the servo at the command period",
        crate::limits::fmt_message_number(*.servo),
        crate::limits::fmt_message_number(*.commands)
    )]
    ServoPeriod {
        /// Axis name.
        axis: String,
        /// The servo's sample period, s.
        servo: f64,
        /// The command period, s.
        commands: f64,
    },
    /// A `[axes.servo]` table is not a valid model.
    #[error("axis {axis}: servo model: {source}")]
    Servo {
        /// Axis name.
        axis: String,
        /// What is wrong.
        source: SysidError,
    },
    /// The number of axis values does not match the machine.
    #[error("{found} axis values left over: the machine has {expected} axes")]
    AxisCount {
        /// Axes of the machine.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// No command sample at all.
    #[error("there is no command sample")]
    Empty,
    /// The temporary spool of actual samples failed.
    #[error("temporary spool file: {0}")]
    Spool(std::io::Error),
    /// The input could not be opened or read again (a breakdown reads it
    /// once per run).
    #[error("cannot read the input: {0}")]
    Read(std::io::Error),
    /// The caller's sink failed (writing the output).
    #[error("{0}")]
    Sink(std::io::Error),
}
