//! Reading and writing the data files (docs/guide.md): CSV tables matched by
//! header name, span-aware reading of the TOML model files (machine, servo,
//! thermal), full-precision number formatting, and all-or-nothing output files
//! ([`Outputs`]).
//!
//! Every reader reports problems as a [`Diagnostic`] naming the file, the
//! line and (where it applies) the column, so the CLI can print one plain
//! sentence per problem.

pub mod columns;
mod diagnostic;
mod number;
mod outputs;
mod rows;
mod table;
pub(crate) mod toml;
pub(crate) mod toml_write;

pub use diagnostic::{Diagnostic, Diagnostics};
pub use number::{fmt_f64, nan_if_null, write_csv_row};
pub use outputs::{
    Outputs, Plan, remove_temporaries_and_exit, remove_temporaries_then_exit, stdout_closed,
    stdout_is_output, write_atomic, write_atomic_with,
};
pub use rows::CsvRows;
pub use table::{Column, Table};
pub use toml_write::TomlWriteError;
