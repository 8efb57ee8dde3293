//! The twin run on one input, whichever its kind ([`Commands`], [`predict`]),
//! and the per-source breakdown of a run ([`breakdown`]): the same commands
//! run again with the servo alone and with the geometry alone.

use std::io::{self, BufRead};
use std::path::Path;

use super::TwinError;
use super::commands::{predict_csv, predict_gcode};
use super::doc::TwinBreakdownDoc;
use super::pipeline::{Progress, Sources, Twin, TwinSample, TwinSummary};
use crate::gcode::InterpolateOptions;
use crate::model::Machine;

/// What the twin's input is.
#[derive(Debug, Clone, Copy)]
#[non_exhaustive]
pub enum Commands<'a> {
    /// CMD.csv: `t_s` and one column per machine axis (see [`predict_csv`]);
    /// `path` names the file in messages.
    Csv {
        /// The file's name in messages.
        path: &'a Path,
    },
    /// A G-code program, interpolated with `opts` (see [`predict_gcode`]).
    Gcode {
        /// Interpolation settings (period, interpreter, travel check).
        opts: &'a InterpolateOptions,
    },
}

/// Runs the twin of `machine` keeping `sources` on the commands read from
/// `input`, rows to `sink`.
pub fn predict<R, F>(
    machine: &Machine,
    sources: Sources,
    commands: Commands<'_>,
    input: R,
    sink: F,
    progress: &mut dyn FnMut(Progress),
) -> Result<TwinSummary, TwinError>
where
    R: BufRead,
    F: FnMut(&TwinSample) -> io::Result<()>,
{
    let twin = Twin::new(machine, sources)?;
    match commands {
        Commands::Csv { path } => predict_csv(&twin, path, input, sink, progress),
        Commands::Gcode { opts } => predict_gcode(&twin, machine, input, opts, sink, progress),
    }
}

/// The breakdown of `all` (a run of every source on `commands`): the same
/// commands run with the servo alone and with the geometry alone, each read
/// afresh from `open()`. `progress` gets the source of the run it reports on.
pub fn breakdown<R, O>(
    machine: &Machine,
    commands: Commands<'_>,
    all: &TwinSummary,
    mut open: O,
    progress: &mut dyn FnMut(Sources, Progress),
) -> Result<TwinBreakdownDoc, TwinError>
where
    R: BufRead,
    O: FnMut() -> io::Result<R>,
{
    let mut run = |sources: Sources| -> Result<TwinSummary, TwinError> {
        let input = open().map_err(TwinError::Read)?;
        predict(machine, sources, commands, input, |_| Ok(()), &mut |p| {
            progress(sources, p)
        })
    };
    let servo = run(Sources::Servo)?;
    let geometry = run(Sources::Geometry)?;
    Ok(TwinBreakdownDoc::new(all, &servo, &geometry))
}
