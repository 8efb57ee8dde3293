//! The machine model (docs/machine-model.md): axes, chains, tool and workpiece, the ISO 230-1 geometric
//! errors with their functions, the machine file, and the parameter view used by fits.

pub mod check;
mod error_fn;
pub mod error_name;
mod machine;
mod parameters;
mod poses;
pub(crate) mod rules;
mod toml_read;
mod toml_write;

pub use check::ModelCheckDoc;
pub use error_fn::{ErrorFunction, Form};
pub use error_name::{Component, ErrorKind, ErrorName};
pub use machine::{Axis, AxisErrors, AxisKind, Chain, DEFAULT_RAPID_FEED, Machine, ServoTable};
pub use parameters::{FittedError, ParameterSet, SpecError};
pub use poses::read_poses;
pub use toml_read::{UNIT_TOLERANCE, parse_machine, read_machine};
pub use toml_write::machine_to_toml;
