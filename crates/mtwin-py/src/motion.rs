//! The part-program methods: `gcode interpolate`, `twin predict` and
//! `compensate`, each over the library's entry point as the CLI calls it, with
//! the tables as NumPy arrays and the programs as text.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use mtwin::gcode::plan::{PlanOptions, Planner};
use mtwin::gcode::{self, Axis, InterpOptions, InterpolateError, InterpolateOptions};
use mtwin::io::{Diagnostic, Diagnostics};
use mtwin::methods::compensate::{CompensateError, CompensateOptions};
use mtwin::methods::twin::{self, Commands, PredictOptions, Sources, TwinError};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::convert::{document, input_error};
use crate::machine::Machine;

/// Add the functions and the table column names to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(gcode_interpolate, m)?)?;
    m.add_function(wrap_pyfunction!(twin_predict, m)?)?;
    m.add_function(wrap_pyfunction!(compensate, m)?)?;
    m.add("TWIN_COLUMNS", mtwin::report::twin::COLUMNS.to_vec())?;
    Ok(())
}

/// `file:line:col: message` as `InputError` (the CLI's `located`): a whole
/// block at fault is column 1; no line, the whole file.
pub fn located(py: Python<'_>, file: &Path, line: Option<u64>, column: u32, msg: String) -> PyErr {
    let d = match line {
        Some(l) => Diagnostic::at(file, l as usize, column.max(1) as usize, msg),
        None => Diagnostic::whole(file, msg),
    };
    input_error(py, &Diagnostics::from(d))
}

/// A program that cannot be opened, as `InputError` on the whole file.
fn unreadable(py: Python<'_>, program: &Path, e: &std::io::Error) -> PyErr {
    input_error(
        py,
        &Diagnostic::whole(program, format!("cannot read the program: {e}")).into(),
    )
}

/// Interpreter options (LinuxCNC dialect) with the G54 work offsets `offsets`
/// (`{"X": 10.0, …}`, mm and degrees), as `--offset X=10`, for a program
/// run on `machine` (a word of an axis it lacks is refused, as LinuxCNC).
fn interp_options(
    offsets: Option<HashMap<String, f64>>,
    machine: &mtwin::model::Machine,
) -> PyResult<InterpOptions> {
    let mut o = InterpOptions::default();
    o.machine_axes = mtwin::gcode::AxisMask::of_machine(machine);
    for (name, value) in offsets.unwrap_or_default() {
        let axis = Axis::from_name(name.trim()).ok_or_else(|| {
            PyValueError::new_err(format!(
                "offsets: `{name}` is not an axis letter (X Y Z A B C U V W)"
            ))
        })?;
        if !value.is_finite() {
            return Err(PyValueError::new_err(format!(
                "offsets: {name} = {value} is not a number"
            )));
        }
        o.work_offsets[0][axis] = value;
    }
    Ok(o)
}

/// The planner settings of `--planner` and `--feed-override`.
fn plan_options(planner: &str, feed_override: f64) -> PyResult<PlanOptions> {
    let p = match planner {
        "exact-stop" => Planner::ExactStop,
        "linuxcnc" => Planner::Linuxcnc,
        other => {
            return Err(PyValueError::new_err(format!(
                "planner must be \"exact-stop\" or \"linuxcnc\", got {other:?}"
            )));
        }
    };
    let mut o = PlanOptions::new(p);
    o.feed_override = feed_override;
    Ok(o)
}

/// An (N, cols) array from flat row-major values.
fn table<'py>(py: Python<'py>, flat: Vec<f64>, cols: usize) -> Bound<'py, PyArray2<f64>> {
    let rows = flat.len() / cols.max(1);
    Array2::from_shape_vec((rows, cols), flat)
        .expect("whole rows")
        .into_pyarray(py)
}

/// `mtwin gcode interpolate`: the part program at `program` sampled every `ts`
/// seconds on `machine`. Returns `(samples, doc)`: an (N, 1 + axes) array of
/// `t_s` then the axis commands in the machine file's order (mm, degrees) — the
/// rows of the CLI's CMD.csv — and the `GcodeInterpolateDoc`. `tcp` treats every
/// move as a TCP move; `offsets` sets G54 (`{"X": 10.0}`); `check_travel=False`
/// keeps samples outside the travels (`--no-travel-check`). Errors in the
/// program raise `InputError` with file, line and column.
#[pyfunction]
#[pyo3(signature = (program, machine, ts = 0.001, tcp = false, offsets = None, check_travel = true, planner = "exact-stop", feed_override = 1.0))]
#[allow(clippy::too_many_arguments)]
fn gcode_interpolate<'py>(
    py: Python<'py>,
    program: PathBuf,
    machine: &Machine,
    ts: f64,
    tcp: bool,
    offsets: Option<HashMap<String, f64>>,
    check_travel: bool,
    planner: &str,
    feed_override: f64,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Py<PyAny>)> {
    let m = &machine.inner;
    let mut opts = InterpolateOptions::new(ts);
    opts.interp = interp_options(offsets, &machine.inner)?;
    opts.force_tcp = tcp;
    opts.check_travel = check_travel;
    opts.plan = plan_options(planner, feed_override)?;
    let file = std::fs::File::open(&program).map_err(|e| unreadable(py, &program, &e))?;
    let input = std::io::BufReader::new(file);
    let cols = m.n_axes() + 1;
    let r = py.detach(|| {
        let mut flat = Vec::new();
        gcode::interpolate(input, m, &opts, |s| {
            flat.push(s.t);
            flat.extend_from_slice(s.q);
            Ok(())
        })
        .map(|s| (s, flat))
    });
    let (summary, flat) =
        r.map_err(|e: InterpolateError| located(py, &program, e.line(), e.column(), e.message()))?;
    let doc = gcode::GcodeInterpolateDoc::new(&summary, ts, "");
    Ok((
        table(py, flat, cols),
        document(py, "GcodeInterpolateDoc", &doc)?,
    ))
}

/// `mtwin twin predict`: the five-axis digital twin of trajectory error.
///
/// The commands are either `commands`, a CMD.csv (`t_s` and one column per axis),
/// or `gcode`, a program interpolated every `ts` seconds (`tcp`: a TCP program
/// from its start; `offsets`, `check_travel`, `planner`, `feed_override` as in
/// `gcode_interpolate`). `only` keeps one error source (`"servo"` or
/// `"geometry"`); `breakdown` also runs each alone. Returns `(table, doc)`: an
/// (N, 15) array with the columns `TWIN_COLUMNS` (the CLI's PRED.csv: `t_s`,
/// command and actual tool tip (mm) and axis in W, `tip_error` (mm),
/// `axis_error` (rad)) and the `TwinPredictDoc`.
#[pyfunction]
#[pyo3(signature = (machine, commands = None, gcode = None, tcp = false, ts = 0.001, offsets = None, check_travel = true, planner = "exact-stop", feed_override = 1.0, only = None, breakdown = false))]
#[allow(clippy::too_many_arguments)]
fn twin_predict<'py>(
    py: Python<'py>,
    machine: &Machine,
    commands: Option<PathBuf>,
    gcode: Option<PathBuf>,
    tcp: bool,
    ts: f64,
    offsets: Option<HashMap<String, f64>>,
    check_travel: bool,
    planner: &str,
    feed_override: f64,
    only: Option<&str>,
    breakdown: bool,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Py<PyAny>)> {
    let mut options = PredictOptions::default();
    options.sources = match only {
        None => Sources::All,
        Some("servo") => Sources::Servo,
        Some("geometry") => Sources::Geometry,
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "only must be \"servo\" or \"geometry\", got {other:?}"
            )));
        }
    };
    if breakdown && only.is_some() {
        return Err(PyValueError::new_err(
            "breakdown runs every source: give only or breakdown, not both",
        ));
    }
    options.breakdown = breakdown;
    let (path, opts) = match (commands, gcode) {
        (Some(c), None) => (c, None),
        (None, Some(g)) => {
            let mut o = InterpolateOptions::new(ts);
            o.interp = interp_options(offsets, &machine.inner)?;
            o.interp.tcp_at_start = tcp;
            o.check_travel = check_travel;
            o.plan = plan_options(planner, feed_override)?;
            (g, Some(o))
        }
        _ => {
            return Err(PyValueError::new_err(
                "give the commands (a CMD.csv) or a G-code program, one of the two",
            ));
        }
    };
    let cmds = match &opts {
        Some(o) => Commands::Gcode { opts: o },
        None => Commands::Csv { path: &path },
    };
    let m = &machine.inner;
    let r = py.detach(|| {
        let mut flat = Vec::new();
        twin::run(
            m,
            cmds,
            || std::fs::File::open(&path).map(std::io::BufReader::new),
            &options,
            |s| {
                flat.extend_from_slice(&twin::pred_row(s));
                Ok(())
            },
            &mut |_, _| {},
        )
        .map(|r| (r, flat))
    });
    let (run, flat) = r.map_err(|e| match e {
        TwinError::Program(e) if opts.is_some() => {
            located(py, &path, e.line(), e.column(), e.message())
        }
        TwinError::Input(d) => input_error(py, &Diagnostics::from(d)),
        TwinError::Read(e) => unreadable(py, &path, &e),
        e => PyValueError::new_err(e.to_string()),
    })?;
    let cols = mtwin::report::twin::COLUMNS.len();
    Ok((
        table(py, flat, cols),
        document(py, "TwinPredictDoc", &run.doc)?,
    ))
}

/// `mtwin compensate`: the part program `program` (G-code text; `path` names it
/// in errors) rewritten so that the actual `machine` (its errors) reaches the
/// nominal targets. `tol`: largest deviation of the compensated path from the
/// nominal one (mm); `max_correction`: largest accepted correction of one target
/// (mm); `tcp`, `offsets` as in `gcode_interpolate`. Returns `(text, doc)`: the
/// compensated program — the file `mtwin compensate --out` writes — and the
/// `CompensateDoc` (its `notes` say what was rewritten beyond end words).
#[pyfunction]
#[pyo3(signature = (machine, program, tol = 0.001, max_correction = 0.5, tcp = false, offsets = None, path = "<string>"))]
#[allow(clippy::too_many_arguments)]
fn compensate(
    py: Python<'_>,
    machine: &Machine,
    program: &str,
    tol: f64,
    max_correction: f64,
    tcp: bool,
    offsets: Option<HashMap<String, f64>>,
    path: &str,
) -> PyResult<(String, Py<PyAny>)> {
    let file = PathBuf::from(path);
    let mut opts = CompensateOptions::default();
    opts.tol = tol;
    opts.max_correction = max_correction;
    opts.interp = interp_options(offsets, &machine.inner)?;
    opts.interp.tcp_at_start = tcp;
    let m = &machine.inner;
    let r = py.detach(|| {
        let mut out = Vec::new();
        mtwin::methods::compensate::run(m, program.as_bytes(), &mut out, &opts)
            .map(|(_, doc)| (out, doc))
    });
    let (out, doc) = r.map_err(|e| match e {
        CompensateError::Setting { option, problem } => {
            PyValueError::new_err(format!("{option} {problem}"))
        }
        CompensateError::Gcode(e) => crate::methods::gcode_error(py, &file, &e),
        CompensateError::AxisName(e) => {
            PyValueError::new_err(format!("{}: {e}", machine.path.display()))
        }
        CompensateError::Io(e) => PyValueError::new_err(format!("cannot write the program: {e}")),
        e => located(py, &file, e.line(), e.column(), e.message()),
    })?;
    let text = String::from_utf8(out)
        .map_err(|e| PyValueError::new_err(format!("the compensated program: {e}")))?;
    Ok((text, document(py, "CompensateDoc", &doc)?))
}
