//! `mtwin.Machine`: the machine model, forward and inverse kinematics and Jacobians
//! on NumPy arrays.

use std::path::PathBuf;

use mtwin::kinematics::{IkOptions, IkTarget, Kinematics};
use mtwin::nalgebra::Vector3;
use numpy::ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use crate::convert::{diag, document, rows, value_error};

/// A machine model (see docs/machine-model.md): axes, chains and geometric errors.
///
/// Read one with `Machine.from_file`, `Machine.from_str`, `Machine.from_dict` or
/// `Machine.example`. Axis positions are in the machine file's axis order
/// (`Machine.axis_names`), mm for linear and degrees for rotary axes; tool poses are
/// the tool tip `x, y, z` (mm) and the unit tool axis `i, j, k` in the workpiece frame W.
#[pyclass(module = "mtwin", frozen)]
pub struct Machine {
    pub inner: mtwin::model::Machine,
    pub path: PathBuf,
    kin: Kinematics,
}

impl Machine {
    pub fn new(inner: mtwin::model::Machine, path: PathBuf) -> Self {
        let kin = Kinematics::new(&inner);
        Machine { inner, path, kin }
    }

    /// Tool poses of `kin` (this machine's kinematics, with or without its errors)
    /// at the (N, axes) `poses`: an (N, 6) array of tip `x, y, z` and axis `i, j, k`,
    /// computed in parallel with the GIL released.
    fn tool_poses<'py>(
        &self,
        py: Python<'py>,
        kin: &Kinematics,
        poses: &PyReadonlyArray2<'py, f64>,
        check_travel: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.inner.n_axes();
        let r = rows(poses, n, "poses")?;
        let qs = r.as_slice();
        if n == 0 {
            let flat: Vec<f64> = py.detach(|| {
                kin.poses(qs)
                    .iter()
                    .flat_map(|p| p.tip.iter().chain(p.axis.iter()).copied())
                    .collect()
            });
            let rows = flat.len() / 6;
            return Ok(Array2::from_shape_vec((rows, 6), flat)
                .expect("6 values per pose")
                .into_pyarray(py));
        }
        // The (N, 6) array NumPy gets, zero-filled by `calloc` (fresh pages from the
        // kernel, no pass over them), computed into in place: blocks of BLOCK poses in
        // parallel, each checked (finite, in travel) and then computed by
        // `Kinematics::poses_into` straight into its rows, as `Kinematics::poses`
        // does (the same blocks, so the same bits). No second buffer, no copy, one
        // pass over the input.
        const BLOCK: usize = 1024;
        let count = qs.len() / n;
        let array = PyArray2::<f64>::zeros(py, [count, 6], false);
        let mut rw = array.readwrite();
        let out = tool_pose_rows(rw.as_slice_mut().expect("a new C-contiguous array"));
        let axes = &self.inner.axes;
        let bad = py.detach(|| {
            out.par_chunks_mut(BLOCK)
                .zip(qs.par_chunks(n * BLOCK))
                .enumerate()
                .find_map_first(|(b, (o, q))| {
                    if let Some(e) = pose_error(axes, b * BLOCK, q, check_travel) {
                        return Some(e);
                    }
                    kin.poses_into(q, o);
                    None
                })
        });
        drop(rw);
        match bad {
            Some(e) => Err(PyValueError::new_err(e)),
            None => Ok(array),
        }
    }

    /// Check that every pose is finite and (with `check_travel`) inside the travels,
    /// naming the row and axis of the first that is not.
    fn check_poses(&self, qs: &[f64], check_travel: bool) -> PyResult<()> {
        match pose_error(&self.inner.axes, 0, qs, check_travel) {
            Some(e) => Err(PyValueError::new_err(e)),
            None => Ok(()),
        }
    }
}

/// The first of the poses `qs` (rows of one value per axis; the first is pose `first`)
/// that is not finite or (with `check_travel`) outside a travel, as a message naming
/// its row and axis.
fn pose_error(
    axes: &[mtwin::model::Axis],
    first: usize,
    qs: &[f64],
    check_travel: bool,
) -> Option<String> {
    for (r, q) in qs.chunks_exact(axes.len().max(1)).enumerate() {
        for (a, &v) in axes.iter().zip(q) {
            if !v.is_finite() {
                return Some(format!("pose {}: axis {} is {v}", first + r, a.name));
            }
            if check_travel && !a.in_travel(v) {
                return Some(format!(
                    "pose {}: axis {} at {v} {} is outside its travel [{}, {}]",
                    first + r,
                    a.name,
                    a.kind.unit(),
                    a.travel[0],
                    a.travel[1]
                ));
            }
        }
    }
    None
}

/// `flat`, a C-contiguous (N, 6) float64 buffer, as N tool poses (`ToolPose` is
/// `repr(C)`: tip `x, y, z` then axis `i, j, k`, six `f64` without padding).
fn tool_pose_rows(flat: &mut [f64]) -> &mut [mtwin::kinematics::ToolPose] {
    use mtwin::kinematics::ToolPose;
    const _: () = assert!(
        std::mem::size_of::<ToolPose>() == 6 * std::mem::size_of::<f64>()
            && std::mem::align_of::<ToolPose>() == std::mem::align_of::<f64>()
    );
    assert!(flat.len().is_multiple_of(6) && flat.as_ptr().cast::<ToolPose>().is_aligned());
    // SAFETY: ToolPose is six f64 (size and alignment checked above, `repr(C)` of two
    // `repr(C)` nalgebra vectors of three f64), every bit pattern is a valid f64, the
    // pointer is aligned, and the new slice covers exactly the memory of `flat`, whose
    // unique borrow it takes over.
    unsafe { std::slice::from_raw_parts_mut(flat.as_mut_ptr().cast(), flat.len() / 6) }
}

fn from_text(py: Python<'_>, text: &str, path: &str) -> PyResult<Machine> {
    let p = PathBuf::from(path);
    let m = diag(py, mtwin::model::parse_machine(&p, text))?;
    Ok(Machine::new(m, p))
}

/// Inline tables and arrays of inline tables of `t` as tables and arrays of tables,
/// `depth` levels deep.
fn expand_tables(t: &mut toml_edit::Table, depth: usize) {
    if depth == 0 {
        return;
    }
    for (_, item) in t.iter_mut() {
        let taken = std::mem::take(item);
        let mut new = match taken.into_table() {
            Ok(tab) => toml_edit::Item::Table(tab),
            Err(other) => match other.into_array_of_tables() {
                Ok(a) => toml_edit::Item::ArrayOfTables(a),
                Err(other) => other,
            },
        };
        match &mut new {
            toml_edit::Item::Table(tab) => expand_tables(tab, depth - 1),
            toml_edit::Item::ArrayOfTables(a) => {
                for tab in a.iter_mut() {
                    expand_tables(tab, depth - 1);
                }
            }
            _ => {}
        }
        *item = new;
    }
}

/// The address of the float64 values that `Machine.predict` (and every function
/// taking an (N, cols) array) computes from: the array's own data pointer when it is
/// C-contiguous (read in place), another one for a copy. For the zero-copy test.
#[pyfunction]
pub fn _rows_address(a: PyReadonlyArray2<'_, f64>, cols: usize) -> PyResult<usize> {
    let r = rows(&a, cols, "array")?;
    Ok(r.as_slice().as_ptr() as usize)
}

/// Names of the bundled example machines (`Machine.example(name)`).
#[pyfunction]
pub fn example_names() -> Vec<&'static str> {
    mtwin::examples::NAMES.to_vec()
}

#[pymethods]
impl Machine {
    /// Read and check a machine file (TOML). Raises `InputError` (file, line, column)
    /// for every problem in it.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let m = diag(py, mtwin::model::read_machine(&path))?;
        Ok(Machine::new(m, path))
    }

    /// Read a machine from TOML text; `path` names it in error messages.
    #[staticmethod]
    #[pyo3(signature = (text, path = "<string>"))]
    fn from_str(py: Python<'_>, text: &str, path: &str) -> PyResult<Self> {
        from_text(py, text, path)
    }

    /// Read a machine from a dict of the machine file's structure (what `tomllib.load`
    /// gives for a machine file, or `Machine.to_dict()`); `path` names it in errors
    /// (line numbers then refer to the TOML text of the dict, `Machine.to_toml`-like).
    #[staticmethod]
    #[pyo3(signature = (data, path = "<dict>"))]
    fn from_dict(py: Python<'_>, data: &Bound<'_, PyDict>, path: &str) -> PyResult<Self> {
        let value: serde_json::Value = pythonize::depythonize(data.as_any()).map_err(|e| {
            PyValueError::new_err(format!("{path}: not a machine-file structure: {e}"))
        })?;
        let mut doc = toml_edit::ser::to_document(&value).map_err(|e| {
            PyValueError::new_err(format!("{path}: not a machine-file structure: {e}"))
        })?;
        // The serialiser writes inline tables; a machine file has `[tool]`,
        // `[[axes]]` and `[axes.errors]` tables (the error functions stay inline).
        expand_tables(doc.as_table_mut(), 2);
        from_text(py, &doc.to_string(), path)
    }

    /// A bundled example machine (`example_names()`), e.g. `"ac-trunnion-with-errors"`.
    #[staticmethod]
    fn example(py: Python<'_>, name: &str) -> PyResult<Self> {
        let m = diag(py, mtwin::examples::machine(name))?;
        let base = name.strip_suffix(".toml").unwrap_or(name);
        Ok(Machine::new(
            m,
            PathBuf::from(format!("examples/machines/{base}.toml")),
        ))
    }

    /// The file (or the name given) the machine was read from.
    #[getter]
    fn path(&self) -> String {
        self.path.display().to_string()
    }

    /// Axis names in the machine file's order: the columns of pose arrays.
    #[getter]
    fn axis_names(&self) -> Vec<String> {
        self.inner
            .axis_names()
            .iter()
            .map(|s| s.to_string())
            .collect()
    }

    /// Number of axes.
    #[getter]
    fn n_axes(&self) -> usize {
        self.inner.n_axes()
    }

    /// Axis travels as an (axes, 2) array of [low, high] (mm, deg).
    #[getter]
    fn travels<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let n = self.inner.n_axes();
        let mut a = Array2::zeros((n, 2));
        for (i, ax) in self.inner.axes.iter().enumerate() {
            a[[i, 0]] = ax.travel[0];
            a[[i, 1]] = ax.travel[1];
        }
        a.into_pyarray(py)
    }

    /// The machine as machine-file TOML text (reads back to the same machine).
    fn to_toml(&self) -> PyResult<String> {
        mtwin::model::machine_to_toml(&self.inner, &[]).map_err(value_error)
    }

    /// The machine as a dict of the machine file's structure (`from_dict` reads it back).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = self.to_toml()?;
        py.import("tomllib")
            .or_else(|_| py.import("tomli"))?
            .call_method1("loads", (text,))
    }

    /// `model check`'s document: chains, axes and errors of the machine.
    fn check(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let doc = mtwin::model::ModelCheckDoc::new(&self.inner, &self.path.display().to_string());
        document(py, "ModelCheckDoc", &doc)
    }

    fn __repr__(&self) -> String {
        format!(
            "Machine({:?}, axes={:?})",
            self.path.display().to_string(),
            self.inner.axis_names()
        )
    }

    /// Actual tool poses at `poses`, an (N, axes) float64 array in the machine file's
    /// axis order (mm, deg): an (N, 6) array of tip `x, y, z` (mm) and unit tool axis
    /// `i, j, k` in W, with the machine's errors — the very numbers `mtwin predict` writes.
    ///
    /// A C-contiguous float64 array is read in place (no copy); the computation runs
    /// in parallel with the GIL released. With `check_travel` (as `mtwin predict`), a
    /// position outside its axis travel raises `ValueError`; non-finite positions always do.
    #[pyo3(signature = (poses, check_travel = true))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        poses: PyReadonlyArray2<'py, f64>,
        check_travel: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.tool_poses(py, &self.kin, &poses, check_travel)
    }

    /// Tool poses of the nominal machine (no errors) at `poses`, as `predict`.
    #[pyo3(signature = (poses, check_travel = true))]
    fn predict_nominal<'py>(
        &self,
        py: Python<'py>,
        poses: PyReadonlyArray2<'py, f64>,
        check_travel: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let nominal = Kinematics::nominal(&self.inner);
        self.tool_poses(py, &nominal, &poses, check_travel)
    }

    /// Exact derivatives of the tool pose with respect to the axis positions at `poses`
    /// ((N, axes) float64): an (N, 6, axes) array, `J[n, r, a]` = d(x, y, z, i, j, k)[r] /
    /// d q[a], per mm for linear and per degree for rotary axes, including the change of
    /// each axis's position-dependent errors along it. Parallel, GIL released.
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        poses: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let n = self.inner.n_axes();
        let r = rows(&poses, n, "poses")?;
        let qs = r.as_slice();
        self.check_poses(qs, false)?;
        let kin = &self.kin;
        let count = qs.len() / n.max(1);
        let out = py.detach(|| {
            let mut out = vec![0.0; count * 6 * n];
            out.par_chunks_mut(6 * n.max(1))
                .zip(qs.par_chunks(n.max(1)))
                .for_each(|(o, q)| {
                    let j = kin.jacobian(q);
                    for (a, d) in j.positions.iter().enumerate() {
                        for r in 0..6 {
                            o[r * n + a] = d[r];
                        }
                    }
                });
            out
        });
        Ok(Array3::from_shape_vec((count, 6, n), out)
            .expect("6·axes values per pose")
            .into_pyarray(py))
    }

    /// Inverse kinematics: axis positions that put the tool on `targets`, an (N, 3)
    /// array of tips `x, y, z` (mm, in W) or (N, 6) of tips and tool axes `i, j, k`
    /// (normalised here). Each solve starts from `start` ((axes,) array; default: the
    /// middle of every travel) or, with `warm`, from the previous solution. `free`
    /// ((axes,) booleans) says which axes may move (default: all with a tool axis
    /// target, the linear ones with a tip-only target). Returns an (N, axes) array;
    /// a target that cannot be reached raises `ValueError` naming it, or gives a row
    /// of NaN with `on_error="nan"`. Parallel unless `warm`, GIL released.
    #[pyo3(signature = (targets, start = None, free = None, warm = false, check_travel = true, on_error = "raise"))]
    #[allow(clippy::too_many_arguments)]
    fn inverse<'py>(
        &self,
        py: Python<'py>,
        targets: PyReadonlyArray2<'py, f64>,
        start: Option<PyReadonlyArray1<'py, f64>>,
        free: Option<Vec<bool>>,
        warm: bool,
        check_travel: bool,
        on_error: &str,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.inner.n_axes();
        let width = targets.shape()[1];
        let r = rows(&targets, width, "targets")?;
        if width != 3 && width != 6 {
            return Err(PyValueError::new_err(format!(
                "targets must have 3 (x, y, z) or 6 (x, y, z, i, j, k) columns, got {width}"
            )));
        }
        let raise = match on_error {
            "raise" => true,
            "nan" => false,
            other => {
                return Err(PyValueError::new_err(format!(
                    "on_error must be \"raise\" or \"nan\", got {other:?}"
                )));
            }
        };
        let start: Vec<f64> = match start {
            Some(s) => {
                let s = s.as_array().to_vec();
                if s.len() != n {
                    return Err(PyValueError::new_err(format!(
                        "start must have {n} values, got {}",
                        s.len()
                    )));
                }
                s
            }
            None => self
                .inner
                .axes
                .iter()
                .map(|a| 0.5 * (a.travel[0] + a.travel[1]))
                .collect(),
        };
        let free: Vec<bool> = match free {
            Some(f) if f.len() != n => {
                return Err(PyValueError::new_err(format!(
                    "free must have {n} values, got {}",
                    f.len()
                )));
            }
            Some(f) => f,
            None => self
                .inner
                .axes
                .iter()
                .map(|a| width == 6 || a.kind == mtwin::model::AxisKind::Linear)
                .collect(),
        };
        let mut opts = IkOptions::default();
        opts.check_travel = check_travel;
        let ts = r.as_slice();
        let kin = &self.kin;
        let solve = |t: &[f64], q: &mut [f64], jac: &mut Option<_>| {
            let axis = (width == 6).then(|| Vector3::new(t[3], t[4], t[5]).normalize());
            let target = IkTarget {
                tip: Vector3::new(t[0], t[1], t[2]),
                axis,
            };
            kin.inverse_warm(&target, q, &free, &opts, jac)
        };
        let count = ts.len() / width;
        let result: Result<Vec<f64>, (usize, String)> = py.detach(|| {
            let mut out = vec![0.0; count * n];
            let fail = |i: usize, e: mtwin::kinematics::IkError, q: &mut [f64]| {
                if raise {
                    Err((i, e.to_string()))
                } else {
                    q.fill(f64::NAN);
                    Ok(())
                }
            };
            if warm {
                let mut prev = start.clone();
                let mut jac = None;
                for (i, (q, t)) in out.chunks_mut(n).zip(ts.chunks(width)).enumerate() {
                    q.copy_from_slice(&prev);
                    match solve(t, q, &mut jac) {
                        Ok(()) => prev.copy_from_slice(q),
                        Err(e) => {
                            jac = None;
                            fail(i, e, q)?
                        }
                    }
                }
            } else {
                out.par_chunks_mut(n)
                    .zip(ts.par_chunks(width))
                    .enumerate()
                    .try_for_each(|(i, (q, t))| {
                        q.copy_from_slice(&start);
                        match solve(t, q, &mut None) {
                            Ok(()) => Ok(()),
                            Err(e) => fail(i, e, q),
                        }
                    })?;
            }
            Ok(out)
        });
        let out = result.map_err(|(i, e)| PyValueError::new_err(format!("target {i}: {e}")))?;
        Ok(Array2::from_shape_vec((count, n), out)
            .expect("axes values per target")
            .into_pyarray(py))
    }
}
