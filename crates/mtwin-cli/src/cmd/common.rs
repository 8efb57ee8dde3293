//! Helpers shared by subcommands: loading inputs with messages that name the file.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;
use mtwin::gcode::{
    AxisMask, Dialect, GcodeError, InterpOptions, Message, MessageKind, MessageSink,
    ProgramOptions, ToolTable, Units,
};
use mtwin::io::{Diagnostics, Table};
use mtwin::model::{Machine, read_machine};

/// Turn the library's diagnostics into one error whose text lists every problem.
pub fn diag(d: Diagnostics) -> anyhow::Error {
    anyhow::anyhow!("{d}")
}

/// Read and validate a machine model file.
/// An error naming the option `name` unless `v` is a finite positive number.
pub fn positive(name: &str, v: f64) -> anyhow::Result<()> {
    if !(v.is_finite() && v > 0.0) {
        anyhow::bail!(
            "{name} must be positive, not {}",
            mtwin::limits::fmt_message_number(v)
        );
    }
    Ok(())
}

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

/// Block delete switch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum OnOff {
    /// Blocks starting with `/` are skipped (LinuxCNC's GUI default).
    #[default]
    On,
    /// Blocks starting with `/` run.
    Off,
}

/// How a part program is read, shared by every command that reads one
/// (`--dialect`, `--decimal-point`, `--tool-table`, `--block-delete`).
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
    /// LinuxCNC INI file: its numeric entries are the program's
    /// `#<_ini[section]name>` parameters and its `[RS274NGC] SUBROUTINE_PATH`
    /// (relative directories from the INI's folder) is searched after
    /// `--subroutine-path`.
    #[arg(long, value_name = "FILE")]
    pub ini: Option<PathBuf>,
    /// Directory searched for `NAME.ngc` of a called subroutine the program
    /// does not define (LinuxCNC's SUBROUTINE_PATH); repeatable, searched in order.
    #[arg(long = "subroutine-path", value_name = "DIR")]
    pub subroutine_path: Vec<PathBuf>,
    /// Most blocks the program may execute, loops and calls counted each
    /// run (an endless loop stops with an error).
    #[arg(long, value_name = "N", default_value_t = mtwin::limits::MAX_EXECUTED_BLOCKS)]
    pub max_blocks: u64,
    /// LinuxCNC tool table (`.tbl`: `T1 P1 Z12.5 D6 ;remark`, lengths in mm)
    /// for T, M6, G43 Hn, G43.2 Hn and G10 L1/L10/L11.
    #[arg(long, value_name = "FILE")]
    pub tool_table: Option<PathBuf>,
    /// Block delete switch: `on` skips blocks starting with `/`.
    #[arg(long, value_enum, default_value_t)]
    pub block_delete: OnOff,
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
        if let Some(path) = &self.ini {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            let dir = path.parent().unwrap_or(Path::new("."));
            o.apply_ini(&text, dir);
        }
        o.max_blocks = self.max_blocks;
        let program = program.to_path_buf();
        o.messages = MessageSink::new(move |m: &Message| {
            let file = m.file.as_ref().unwrap_or(&program);
            let kind = match m.kind {
                MessageKind::Debug => "DEBUG",
                MessageKind::Print => "PRINT",
                MessageKind::Abort => "ABORT",
                MessageKind::Msg => "MSG",
            };
            eprintln!("{}:{}: {kind}: {}", file.display(), m.line, m.text);
        });
        Ok(o)
    }

    /// The tool table of `--tool-table` (empty without it); a bad line is
    /// `file:line:col: message`.
    pub fn tools(&self) -> anyhow::Result<ToolTable> {
        let Some(path) = &self.tool_table else {
            return Ok(ToolTable::new());
        };
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        ToolTable::parse(&text, Units::Millimetre)
            .map_err(|e| anyhow::anyhow!("{}:{e}", path.display()))
    }

    /// The axes a program may name (LinuxCNC's axis mask): those of the
    /// machine model, and of `--ini`'s `[TRAJ] COORDINATES` when the INI
    /// has a `[TRAJ]` section (both: the axes in both); all nine without
    /// either. A word of another axis is refused as LinuxCNC refuses it.
    pub fn machine_axes(&self, machine: Option<&Machine>) -> anyhow::Result<AxisMask> {
        let mut mask = machine.map_or(AxisMask::ALL, AxisMask::of_machine);
        if let Some(path) = &self.ini {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            if let Some(m) = AxisMask::of_linuxcnc_ini(&text) {
                mask = mask.intersection(m);
            }
        }
        Ok(mask)
    }

    /// Whether blocks starting with `/` are skipped.
    pub fn skip_deleted_blocks(&self) -> bool {
        self.block_delete == OnOff::On
    }

    /// Sets the dialect, tool table and block delete switch of `o`.
    pub fn apply(&self, o: &mut InterpOptions) -> anyhow::Result<()> {
        o.dialect = self.dialect();
        o.tools = self.tools()?;
        o.skip_deleted_blocks = self.skip_deleted_blocks();
        Ok(())
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

/// The controller a generated program is written for (`--dialect`): every
/// number is written with a decimal point, so a Fanuc control reads it the
/// same with and without decimal point programming.
#[derive(Debug, Clone, clap::Args)]
pub struct WriteDialectArgs {
    /// The controller the program is written for (LinuxCNC: `G4 P` in
    /// seconds; Fanuc: `G4 X` in seconds, every number with a decimal point,
    /// upper-case comments).
    #[arg(long, value_enum, default_value_t)]
    pub dialect: DialectArg,
}

impl WriteDialectArgs {
    /// The library's dialect.
    pub fn dialect(&self) -> Dialect {
        match self.dialect {
            DialectArg::Linuxcnc => Dialect::LinuxCnc,
            DialectArg::Fanuc => Dialect::Fanuc {
                decimal_point_programming: false,
            },
        }
    }
}

/// `file:line:col: message` for a G-code error of the program at `path` (or
/// of the subroutine file it happened in).
pub fn located_error(path: &Path, e: &GcodeError) -> anyhow::Error {
    let file = e.file().unwrap_or(path);
    let at = e.location();
    super::gcode::located(
        file,
        at.map(|a| a.line),
        at.map_or(0, |a| a.column),
        e.message(),
    )
}

/// `--planner`: the trajectory planner that times the moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum PlannerArg {
    /// Stop at every block end; joint velocity and acceleration limits.
    #[default]
    ExactStop,
    /// LinuxCNC 2.9's planner: world-axis limits, look-ahead, G61/G61.1/G64 blending.
    Linuxcnc,
    /// Jerk-limited: joint velocity, acceleration and jerk limits (`max_jerk`
    /// on every axis of the machine file), also under TCP.
    Jerk,
}

/// How a program's moves are planned, shared by the commands that time a
/// program (`--planner`, `--feed-override`, `--derivative-margin`).
#[derive(Debug, Clone, clap::Args)]
pub struct PlanArgs {
    /// Trajectory planner: `exact-stop` (stop at every block, joint limits),
    /// `linuxcnc` (LinuxCNC 2.9: world-axis limits, look-ahead, G64 blends) or
    /// `jerk` (jerk-limited through chains of moves: joint velocity,
    /// acceleration and jerk limits, `max_jerk` needed on every axis).
    #[arg(long, value_enum, default_value_t)]
    pub planner: PlannerArg,
    /// Feed override, a fraction of the programmed feed (feed moves only).
    #[arg(long, default_value_t = 1.0, value_name = "FRACTION")]
    pub feed_override: f64,
    /// exact-stop under TCP: factor on the estimated joint path derivatives
    /// (a reserve; 1 = none).
    #[arg(long, default_value_t = 1.1, value_name = "FACTOR")]
    pub derivative_margin: f64,
}

impl PlanArgs {
    /// The planner settings.
    pub fn options(&self) -> mtwin::gcode::plan::PlanOptions {
        let mut o = mtwin::gcode::plan::PlanOptions::new(match self.planner {
            PlannerArg::ExactStop => mtwin::gcode::plan::Planner::ExactStop,
            PlannerArg::Linuxcnc => mtwin::gcode::plan::Planner::Linuxcnc,
            PlannerArg::Jerk => mtwin::gcode::plan::Planner::Jerk,
        });
        o.feed_override = self.feed_override;
        o.derivative_margin = self.derivative_margin;
        o
    }

    /// Refuses a machine that lacks a limit the planner needs (`jerk`:
    /// `max_acceleration` and `max_jerk` on every axis), naming the machine
    /// file, the axis and the key.
    pub fn check_machine(
        &self,
        path: &std::path::Path,
        m: &mtwin::model::Machine,
    ) -> anyhow::Result<()> {
        if self.planner == PlannerArg::Jerk {
            mtwin::gcode::jerk_limits(m)
                .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.message()))?;
        }
        Ok(())
    }
}
