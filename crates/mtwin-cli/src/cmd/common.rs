//! Helpers shared by subcommands: loading inputs with messages that name the file.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;
use mtwin::gcode::{Dialect, GcodeError, Message, MessageKind, MessageSink, ProgramOptions};
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
    /// LinuxCNC parameter file (`.var`) giving numbered parameters at start
    /// (work offsets 5221…, G28/G30 homes, ...). Read only: mtwin never
    /// writes it back.
    #[arg(long, value_name = "FILE")]
    pub var_file: Option<PathBuf>,
    /// Directory searched for `NAME.ngc` of a called subroutine the program
    /// does not define (LinuxCNC's SUBROUTINE_PATH); repeatable, searched in order.
    #[arg(long = "subroutine-path", value_name = "DIR")]
    pub subroutine_path: Vec<PathBuf>,
    /// Most blocks the program may execute, loops and calls counted each
    /// run (an endless loop stops with an error).
    #[arg(long, value_name = "N", default_value_t = mtwin::limits::MAX_EXECUTED_BLOCKS)]
    pub max_blocks: u64,
}

impl DialectArgs {
    /// Program options: the var file's parameters, the subroutine path, the
    /// block bound; `(DEBUG,…)`/`(PRINT,…)` messages printed on stderr as
    /// `FILE:LINE: DEBUG: text`.
    pub fn program_options(&self, program: &Path) -> anyhow::Result<ProgramOptions> {
        let mut o = ProgramOptions::default();
        if let Some(path) = &self.var_file {
            let f = std::fs::File::open(path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            let p = mtwin::gcode::read_var_file(std::io::BufReader::new(f))
                .map_err(|e| located_error(path, &e))?;
            o.parameters = Arc::new(p);
        }
        o.subroutine_path = self.subroutine_path.clone();
        o.max_blocks = self.max_blocks;
        let program = program.to_path_buf();
        o.messages = MessageSink::new(move |m: &Message| {
            let file = m.file.as_ref().unwrap_or(&program);
            let kind = match m.kind {
                MessageKind::Debug => "DEBUG",
                MessageKind::Print => "PRINT",
            };
            eprintln!("{}:{}: {kind}: {}", file.display(), m.line, m.text);
        });
        Ok(o)
    }

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

/// `file:line:col: message` for a G-code error of the program at `path` (or
/// of the subroutine file it happened in).
pub fn located_error(path: &Path, e: &GcodeError) -> anyhow::Error {
    let file = e.file().unwrap_or(path);
    match e.location() {
        Some(at) => anyhow::anyhow!("{}:{}:{}: {e}", file.display(), at.line, at.column.max(1)),
        None => anyhow::anyhow!("{}: {e}", file.display()),
    }
}
