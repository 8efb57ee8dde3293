//! Helpers shared by subcommands: loading inputs with messages that name the file.

use std::path::Path;

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
