//! Reading and writing the data files of 00 §6: CSV tables matched by
//! header name, span-aware reading of the TOML model files (machine, servo,
//! thermal), full-precision number formatting, and atomic output files.
//!
//! Every reader reports problems as a [`Diagnostic`] naming the file, the
//! line and (where it applies) the column, so the CLI can print one plain
//! sentence per problem.

mod atomic;
mod diagnostic;
mod number;
mod rows;
mod table;
pub(crate) mod toml;

pub use atomic::{write_atomic, write_atomic_with};
pub use diagnostic::{Diagnostic, Diagnostics};
pub use number::{fmt_f64, nan_if_null, write_csv_row};
pub use rows::CsvRows;
pub use table::{Column, Table};
