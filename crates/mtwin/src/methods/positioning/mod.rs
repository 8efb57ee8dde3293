//! Linear positioning accuracy of one numerically controlled axis after
//! ISO 230-2:2014 ([ISO230-2] in docs/references.md): the axis is moved to `m`
//! target positions, each approached `n` times from below (↑, increasing
//! position) and `n` times from above (↓), and the actual position is measured
//! (laser interferometer, linear scale, triangulation sensor …).
//!
//! * [`Run`]: the measured deviations `x_ij = P_ij − P_i` per target, direction
//!   and cycle — what every reader produces;
//! * [`evaluate`]: the ISO 230-2 figures of a run, a [`PositioningDoc`];
//! * readers: [`read_table`] (plain CSV), [`read_dat`] (the `key=value` `.dat`
//!   files of the open-source ecmc motion tools), [`read_rtx`] (Renishaw
//!   dynamic captures), [`read_log`] (raw continuous logs: `NAME date time
//!   value` lines, the dwell at each target detected and averaged);
//! * [`plot_svg`]: deviation against position per direction with the ±2s band;
//! * [`update_machine`]: the mean bidirectional deviation as the axis's
//!   positioning error (a table) in a machine model.
//!
//! Units: positions in mm in the [`Run`]; every figure of the document in µm
//! (`_um`) except the target positions (mm).

pub mod doc;
pub mod iso230_2;
pub mod model;
pub mod plot;
pub mod read_dat;
pub mod read_log;
pub mod read_rtx;
pub mod read_table;

use std::path::Path;

pub use doc::{PositioningDoc, TargetRow};
pub use iso230_2::{Run, evaluate};
pub use model::{ModelUpdate, update_machine};
pub use plot::plot_svg;
pub use read_dat::read_dat;
pub use read_log::{LogOptions, read_log};
pub use read_rtx::{RtxCapture, read_rtx, read_rtx_run};
pub use read_table::read_table;

use crate::io::{Diagnostic, Diagnostics};

/// The input formats of a positioning run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InputFormat {
    /// From the file: `.csv` a table, `.dat` the ecmc format, `.rtx` a Renishaw
    /// capture, anything else a raw log.
    #[default]
    Auto,
    /// Plain CSV table ([`read_table`]).
    Csv,
    /// ecmc `key=value` data file ([`read_dat`]).
    Dat,
    /// Renishaw dynamic capture ([`read_rtx_run`]).
    Rtx,
    /// Raw continuous log ([`read_log`]).
    Log,
}

/// Options of [`run`].
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Input format (default: from the file name).
    pub format: InputFormat,
    /// Reading raw logs and captures: channels, scaling, dwell detection.
    pub log: LogOptions,
}

/// Read `path` in the format of `opts` and evaluate it after ISO 230-2.
pub fn run(path: &Path, opts: &Options) -> Result<PositioningDoc, Diagnostics> {
    let format = match opts.format {
        InputFormat::Auto => {
            let ext = path
                .extension()
                .and_then(|e| e.to_str())
                .map(|e| e.to_ascii_lowercase())
                .unwrap_or_default();
            match ext.as_str() {
                "csv" => InputFormat::Csv,
                "dat" => InputFormat::Dat,
                "rtx" => InputFormat::Rtx,
                _ => InputFormat::Log,
            }
        }
        f => f,
    };
    let run = match format {
        InputFormat::Csv => read_table(path)?,
        InputFormat::Dat => read_dat(path)?,
        InputFormat::Rtx => read_rtx_run(path, &opts.log)?,
        InputFormat::Log | InputFormat::Auto => read_log(path, &opts.log)?,
    };
    evaluate(&run).map_err(|m| Diagnostics::from(Diagnostic::whole(path, m)))
}
