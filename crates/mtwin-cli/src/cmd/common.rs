//! Helpers shared by subcommands: loading inputs with messages that name the file.

use std::path::Path;

use mtwin::gcode::Dialect;
use mtwin::io::{Diagnostics, Table};
use mtwin::model::{Machine, read_machine};

/// Turn the library's diagnostics into one error whose text lists every problem.
pub fn diag(d: Diagnostics) -> anyhow::Error {
    anyhow::anyhow!("{d}")
}

/// Read and validate a machine model file.
pub fn load_machine(path: &Path) -> anyhow::Result<Machine> {
    read_machine(path).map_err(diag)
}

/// Read a CSV table.
pub fn load_table(path: &Path) -> anyhow::Result<Table> {
    Table::read(path).map_err(diag)
}

/// The controller whose reading of a program is reproduced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum DialectArg {
    /// LinuxCNC: `G4 P` in seconds, G90.1/G91.1 arc-centre modes.
    #[default]
    Linuxcnc,
    /// Fanuc: `G4 P` in milliseconds, `G4 X` in seconds, arc centres always
    /// incremental, numbers without a decimal point in least increments
    /// (0.001 mm) unless `--decimal-point`.
    Fanuc,
}

/// How a part program is read (`--dialect`, `--decimal-point`).
#[derive(Debug, Clone, clap::Args)]
pub struct DialectArgs {
    /// The controller whose reading of the program is reproduced.
    #[arg(long, value_enum, default_value_t)]
    pub dialect: DialectArg,
    /// With `--dialect fanuc`: a number without a decimal point is in mm or
    /// degrees (decimal point programming, Fanuc parameter DPI), not in least
    /// increments.
    #[arg(long)]
    pub decimal_point: bool,
}

impl DialectArgs {
    /// The library's dialect.
    pub fn dialect(&self) -> Dialect {
        match self.dialect {
            DialectArg::Linuxcnc => Dialect::LinuxCnc,
            DialectArg::Fanuc => Dialect::Fanuc {
                decimal_point_programming: self.decimal_point,
            },
        }
    }
}
