//! The measurement methods: thin wrappers over the library's entry points, each
//! doing what the matching CLI command does short of writing files.

use std::path::{Path, PathBuf};

use mtwin::gcode::{self, GcodeError};
use mtwin::io::{Diagnostic, Diagnostics, Table};
use mtwin::methods::thermal::{self, ThermalFitOptions};
use mtwin::methods::tracker::validate::ValidateOptions;
use mtwin::methods::tracker::{self, IdentifyInputs, IdentifyOptions, TrackerPoint};
use mtwin::model::{ParameterSet, machine_to_toml, read_poses};
use mtwin::nalgebra::Vector3;
use numpy::PyReadonlyArray2;
use numpy::PyUntypedArrayMethods;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::convert::{diag, document, input_error, rows, value_error};
use crate::machine::Machine;

/// Add the method functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(tracker_identify, m)?)?;
    m.add_function(wrap_pyfunction!(tracker_validate, m)?)?;
    m.add_function(wrap_pyfunction!(thermal_fit, m)?)?;
    m.add_function(wrap_pyfunction!(thermal_predict, m)?)?;
    m.add_function(wrap_pyfunction!(gcode_stats, m)?)?;
    m.add_function(wrap_pyfunction!(ballbar_setup_error, m)?)?;
    Ok(())
}

/// Tracker points from a CSV file (axis columns and `x, y, z`, as the CLI reads
/// them) or an (N, axes + 3) array (axis positions then measured x, y, z).
fn tracker_points(
    py: Python<'_>,
    m: &Machine,
    data: &Bound<'_, PyAny>,
) -> PyResult<(Vec<TrackerPoint>, String)> {
    let n = m.inner.n_axes();
    if let Ok(a) = data.extract::<PyReadonlyArray2<'_, f64>>() {
        let r = rows(&a, n + 3, "data")?;
        let pts = r
            .as_slice()
            .chunks_exact(n + 3)
            .map(|row| TrackerPoint {
                q: row[..n].to_vec(),
                measured: Vector3::new(row[n], row[n + 1], row[n + 2]),
            })
            .collect();
        return Ok((pts, format!("<array of {} rows>", a.shape()[0])));
    }
    let path: PathBuf = data.extract().map_err(|_| {
        PyValueError::new_err("data must be a CSV file path or an (N, axes + 3) float64 array")
    })?;
    let t = diag(py, Table::read(&path))?;
    let poses = diag(py, read_poses(&t, &m.inner, true))?;
    let xyz = diag(py, t.number_rows(&mtwin::io::columns::TRACKER_MEASURED))?;
    let pts = poses
        .into_iter()
        .zip(xyz)
        .map(|(q, p)| TrackerPoint {
            q,
            measured: Vector3::new(p[0], p[1], p[2]),
        })
        .collect();
    Ok((pts, path.display().to_string()))
}

/// `mtwin tracker identify`: identify the errors named by `fit` (e.g.
/// `"pdge:cheb3,location"`) of `machine` from measured tool tips.
///
/// `data` is a CSV file (axis columns and measured `x, y, z`, mm in W) or an
/// (N, axes + 3) float64 array of the same columns. With `registration`, a rigid
/// tracker → W registration is fitted too. Returns `(identified, doc)`: the machine
/// with the identified values written in, and the `TrackerIdentifyDoc` (parameters,
/// residuals, identifiability, warnings) of `--format json`.
#[pyfunction]
#[pyo3(signature = (machine, data, fit, registration = false))]
fn tracker_identify(
    py: Python<'_>,
    machine: &Machine,
    data: &Bound<'_, PyAny>,
    fit: &str,
    registration: bool,
) -> PyResult<(Machine, Py<PyAny>)> {
    let params = ParameterSet::from_spec(&machine.inner, fit)
        .map_err(|e| PyValueError::new_err(format!("fit: {e}")))?;
    let (points, name) = tracker_points(py, machine, data)?;
    let mut options = IdentifyOptions::default();
    options.registration = registration;
    let inputs = IdentifyInputs {
        machine: &machine.inner,
        params: &params,
        points: &points,
    };
    let (id, doc) = py
        .detach(|| tracker::identify::run(&inputs, &options, &|_| {}))
        .map_err(|e| PyValueError::new_err(format!("cannot identify from {name}: {e}")))?;
    // Read the identified machine back from its file text, so that it is exactly the
    // machine `mtwin tracker identify --out` writes.
    let text = machine_to_toml(&id.machine, &[]).map_err(value_error)?;
    let path = PathBuf::from(format!("identified from {name}"));
    let m = diag(py, mtwin::model::parse_machine(&path, &text))?;
    Ok((
        Machine::new(m, path),
        document(py, "TrackerIdentifyDoc", &doc)?,
    ))
}

/// `mtwin tracker validate`: measured tool tips at check poses (`data` as in
/// `tracker_identify`) against the nominal and the identified (`machine`) model.
#[pyfunction]
fn tracker_validate(
    py: Python<'_>,
    machine: &Machine,
    data: &Bound<'_, PyAny>,
) -> PyResult<Py<PyAny>> {
    let (points, name) = tracker_points(py, machine, data)?;
    if points.is_empty() {
        return Err(PyValueError::new_err(format!("{name}: no data rows")));
    }
    let (_, doc) =
        py.detach(|| tracker::validate::run(&machine.inner, &points, &ValidateOptions::default()));
    document(py, "TrackerValidateDoc", &doc)
}

/// `mtwin thermal fit`: an ARX thermal-drift model from training data (CSV
/// `t_min,speed_rpm,z_mm,drift_mm`, optional `run`). Returns `(model_toml, doc)`:
/// the model file text `thermal predict` reads, and the `ThermalFitDoc`.
#[pyfunction]
#[pyo3(signature = (data, max_order = 4, speed_model = "linear", extra_inputs = Vec::new()))]
fn thermal_fit(
    py: Python<'_>,
    data: PathBuf,
    max_order: usize,
    speed_model: &str,
    extra_inputs: Vec<String>,
) -> PyResult<(String, Py<PyAny>)> {
    let options = ThermalFitOptions {
        max_order,
        speed_model: speed_model
            .parse()
            .map_err(|e: String| PyValueError::new_err(format!("speed_model: {e}")))?,
        extra_inputs,
        ..ThermalFitOptions::default()
    };
    options.validate().map_err(value_error)?;
    let training = diag(py, thermal::read_training(&data, &options.extra_inputs))?;
    let fit = py
        .detach(|| thermal::fit(&training, &options))
        .map_err(value_error)?;
    let text = fit.model.to_toml().map_err(value_error)?;
    let doc = thermal::ThermalFitDoc::new(&fit, "", &[]);
    Ok((text, document(py, "ThermalFitDoc", &doc)?))
}

/// `mtwin thermal predict`: the drift of a thermal model (`model`, a TOML file
/// from `thermal_fit`) under a speed programme (`speed`, CSV `t_min,speed_rpm`)
/// at heights `z` (mm). Returns `(table, doc)`: an (N, 3) array of `t_min, z_mm,
/// drift_mm` rows (the CSV the CLI writes) and the `ThermalPredictDoc`.
#[pyfunction]
fn thermal_predict<'py>(
    py: Python<'py>,
    model: PathBuf,
    speed: PathBuf,
    z: Vec<f64>,
) -> PyResult<(Bound<'py, numpy::PyArray2<f64>>, Py<PyAny>)> {
    if let Some(h) = z.iter().find(|h| !h.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "z: {h} is not a height in mm"
        )));
    }
    let m = diag(py, thermal::read_model(&model))?;
    let programme = diag(py, thermal::read_programme(&speed, &m))?;
    let p = py.detach(|| thermal::predict(&m, &programme, &z));
    if let Some(r) = p.rows.iter().find(|r| r.iter().any(|v| !v.is_finite())) {
        return Err(PyValueError::new_err(format!(
            "{}: the predicted drift overflows at t = {} min, z = {} mm (the model is unstable or its coefficients too large)",
            model.display(),
            r[0],
            r[1]
        )));
    }
    let warnings = p.warnings(&m);
    let doc = thermal::ThermalPredictDoc::new(&p, &z, "", warnings);
    let flat: Vec<f64> = p.rows.iter().flatten().copied().collect();
    let arr =
        numpy::ndarray::Array2::from_shape_vec((p.rows.len(), 3), flat).expect("3 values per row");
    Ok((
        numpy::IntoPyArray::into_pyarray(arr, py),
        document(py, "ThermalPredictDoc", &doc)?,
    ))
}

/// A G-code error as `InputError` at its file, line and column.
fn gcode_error(py: Python<'_>, program: &Path, e: &GcodeError) -> PyErr {
    let file = e.file().unwrap_or(program);
    let d = match e.location() {
        Some(at) => Diagnostic::at(
            file,
            at.line as usize,
            at.column.max(1) as usize,
            e.message(),
        ),
        None => Diagnostic::whole(file, e.message()),
    };
    input_error(py, &Diagnostics::from(d))
}

/// `mtwin gcode stats`: statistics and time estimate of the part program at
/// `program` (LinuxCNC dialect). With `machine`, its rapid feed is used and every
/// move end is checked against the travels (`tcp`: the program is in tool-tip
/// coordinates from the start, as `--tcp`). Returns the `GcodeStatsDoc`. Errors
/// in the program raise `InputError` with the file, line and column.
#[pyfunction]
#[pyo3(signature = (program, machine = None, tcp = false))]
fn gcode_stats(
    py: Python<'_>,
    program: PathBuf,
    machine: Option<&Machine>,
    tcp: bool,
) -> PyResult<Py<PyAny>> {
    let mut opts = gcode::StatsOptions::default();
    if let Some(m) = machine {
        opts.rapid_feed = m.inner.rapid_feed;
    }
    opts.interp.tcp_at_start = tcp;
    let file = std::fs::File::open(&program).map_err(|e| {
        input_error(
            py,
            &Diagnostic::whole(&program, format!("cannot read the program: {e}")).into(),
        )
    })?;
    let input = std::io::BufReader::new(file);
    let mut check = machine.map(|m| {
        let mut c = gcode::TravelCheck::new(&m.inner);
        c.force_tcp = tcp;
        c
    });
    let st = py.detach(|| match check.as_mut() {
        Some(c) => gcode::stats_with(input, &opts, c),
        None => gcode::stats(input, &opts),
    });
    let mut st = st.map_err(|e| gcode_error(py, &program, &e))?;
    if let Some(m) = machine {
        // The planned time, as `gcode stats --machine` gives it (the default planner).
        let mut io = gcode::InterpolateOptions::new(1e9);
        io.interp = opts.interp.clone();
        io.force_tcp = tcp;
        let file = std::fs::File::open(&program).map_err(|e| {
            input_error(
                py,
                &Diagnostic::whole(&program, format!("cannot read the program: {e}")).into(),
            )
        })?;
        let input = std::io::BufReader::new(file);
        st.planned_time = py
            .detach(|| gcode::planned_duration(input, &m.inner, &io))
            .ok();
    }
    let doc = gcode::GcodeStatsDoc::new(
        &program.display().to_string(),
        &st,
        machine.map(|m| &m.inner),
        check.as_ref(),
    );
    document(py, "GcodeStatsDoc", &doc)
}

/// `mtwin ballbar setup-error`: the set-up error of the tool ball from the bar
/// readings over one spindle turn: `length` at spindle angle 0°, the largest
/// `lmax` and smallest `lmin` reading (mm), `theta2` the spindle angle of the
/// smallest (degrees, M3 sense). Returns the `BallbarSetupDoc`.
#[pyfunction]
fn ballbar_setup_error(
    length: f64,
    lmax: f64,
    lmin: f64,
    theta2: f64,
    py: Python<'_>,
) -> PyResult<Py<PyAny>> {
    use mtwin::methods::ballbar::{self, SetupErrorInput, SetupOptions};
    let doc = ballbar::setup::run(
        &SetupErrorInput {
            length,
            lmax,
            lmin,
            theta2_deg: theta2,
        },
        &SetupOptions::default(),
    )
    .map_err(value_error)?;
    document(py, "BallbarSetupDoc", &doc)
}
