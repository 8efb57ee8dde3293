//! Conversions between the library's types and Python objects: diagnostics →
//! `mtwin.InputError`, serde documents → `mtwin.Document`, arrays.

use std::fmt::Display;

use mtwin::io::{Diagnostic, Diagnostics};
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyList;
use serde::Serialize;

/// `mtwin.InputError(message, file, line, column, problems)` for the library's diagnostics:
/// the first problem gives file, line and column; `problems` lists them all as
/// `(file, line, column, message)` tuples. Line 0 / column `None` when the problem
/// concerns the whole file.
pub fn input_error(py: Python<'_>, d: &Diagnostics) -> PyErr {
    match build_input_error(py, d) {
        Ok(e) => e,
        Err(e) => e,
    }
}

fn build_input_error(py: Python<'_>, d: &Diagnostics) -> PyResult<PyErr> {
    let cls = py.import("mtwin._errors")?.getattr("InputError")?;
    let problems = PyList::empty(py);
    for p in &d.0 {
        problems.append((
            p.file.display().to_string(),
            p.line,
            p.column,
            p.message.clone(),
        ))?;
    }
    let first: Option<&Diagnostic> = d.0.first();
    let (file, line, column) = match first {
        Some(p) => (p.file.display().to_string(), p.line, p.column),
        None => (String::new(), 0, None),
    };
    let value = cls.call1((d.to_string(), file, line, column, problems))?;
    Ok(PyErr::from_value(value))
}

/// Turn a library result with diagnostics into a Python result.
pub fn diag<T>(py: Python<'_>, r: Result<T, Diagnostics>) -> PyResult<T> {
    r.map_err(|d| input_error(py, &d))
}

/// A plain library error (anything `Display`) as `ValueError`.
pub fn value_error(e: impl Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The serde document `doc` as `mtwin.Document(kind, data, text)`: `data` is the
/// document converted field by field (pythonize: structs → dicts, sequences → lists,
/// f64 → float bit for bit), `text` the library's human summary (its `Display`).
pub fn document<T: Serialize + Display>(
    py: Python<'_>,
    kind: &str,
    doc: &T,
) -> PyResult<Py<PyAny>> {
    document_text(py, kind, doc, &doc.to_string())
}

/// [`document`] for a document without `Display` (or with a caller-made summary).
pub fn document_text<T: Serialize>(
    py: Python<'_>,
    kind: &str,
    doc: &T,
    text: &str,
) -> PyResult<Py<PyAny>> {
    let data = pythonize::pythonize(py, doc).map_err(value_error)?;
    let cls = py.import("mtwin._document")?.getattr("Document")?;
    Ok(cls.call1((kind, data, text))?.unbind())
}

/// Rows of an (N, k) float64 array with `k == cols`, as one flat row-major slice when
/// the array is C-contiguous (borrowed in place, no copy), else as a copy.
pub enum Rows<'a> {
    /// The array's own memory.
    Borrowed(&'a [f64]),
    /// A row-major copy (non-contiguous or transposed input).
    Owned(Vec<f64>),
}

impl Rows<'_> {
    /// The flat row-major values.
    pub fn as_slice(&self) -> &[f64] {
        match self {
            Rows::Borrowed(s) => s,
            Rows::Owned(v) => v,
        }
    }
}

/// Read `a` as rows of `cols` values; `what` names the argument in errors.
pub fn rows<'a>(a: &'a PyReadonlyArray2<'_, f64>, cols: usize, what: &str) -> PyResult<Rows<'a>> {
    let shape = a.shape();
    if shape[1] != cols {
        return Err(PyValueError::new_err(format!(
            "{what} must have {cols} columns, got an array of shape ({}, {})",
            shape[0], shape[1]
        )));
    }
    // `as_slice` also accepts Fortran order (memory order ≠ row order): only a
    // C-contiguous array is read in place.
    Ok(match a.as_slice() {
        Ok(s) if a.is_c_contiguous() => Rows::Borrowed(s),
        _ => Rows::Owned(a.as_array().iter().copied().collect()),
    })
}
