//! Python bindings of the mtwin library: a thin layer of PyO3 functions over the
//! library's public API. Arrays come and go as NumPy arrays (C-contiguous float64
//! input is read in place, never copied); results are the library's serde
//! documents handed to `mtwin.Document` (python/mtwin/_document.py); every
//! problem with an input is raised as `mtwin.InputError` with file, line and column.
//!
//! Units as in the library: mm, degrees for rotary axis positions, rad for small
//! angular errors, s, rev/min.

use pyo3::prelude::*;

mod convert;
mod machine;
mod methods;
mod motion;

/// The extension module `mtwin._mtwin` (re-exported by the `mtwin` package).
#[pymodule]
fn _mtwin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<machine::Machine>()?;
    m.add_function(wrap_pyfunction!(machine::example_names, m)?)?;
    m.add_function(wrap_pyfunction!(machine::_rows_address, m)?)?;
    methods::register(m)?;
    motion::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
