//! The measurement methods: thin wrappers over the library's entry points, each
//! doing what the matching CLI command does short of writing files.

use std::path::{Path, PathBuf};

use mtwin::gcode::{self, GcodeError};
use mtwin::io::{Diagnostic, Diagnostics, Table};
use mtwin::methods::thermal::log::{ChannelSpec, InputSpec};
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
    m.add_function(wrap_pyfunction!(thermal_fit_log, m)?)?;
    m.add_function(wrap_pyfunction!(thermal_predict_log, m)?)?;
    m.add_function(wrap_pyfunction!(gcode_stats, m)?)?;
    m.add_function(wrap_pyfunction!(ballbar_setup_error, m)?)?;
    m.add_function(wrap_pyfunction!(ballbar_identify, m)?)?;
    m.add_function(wrap_pyfunction!(ballbar_circular, m)?)?;
    m.add_function(wrap_pyfunction!(skiving_setup_error, m)?)?;
    m.add_function(wrap_pyfunction!(servo_fit, m)?)?;
    m.add_function(wrap_pyfunction!(positioning_evaluate, m)?)?;
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

/// A thermal error: problems in an input file as `InputError`, the rest as
/// `ValueError`.
fn thermal_error(py: Python<'_>, e: thermal::ThermalError) -> PyErr {
    match e {
        thermal::ThermalError::Input(d) => input_error(py, &d),
        other => value_error(other),
    }
}

/// `folds` of `thermal_fit_log`: one number of held-out blocks or several.
#[derive(FromPyObject)]
enum FoldCounts {
    One(usize),
    Many(Vec<usize>),
}

/// `mtwin thermal fit --log`: one drift model per channel of a wide machine
/// log (CSV: `t_s` or `t_min`, the drift channels, the inputs), chosen by
/// held-out simulation error. `drift` and `inputs` are the CLI's `--drift`
/// and `--inputs` items (`"ch1_um:Z"`, `"t1_c"`, `"speed_rpm:square"`, …);
/// `folds` one number of held-out blocks or a list (each channel then
/// predicted by the median of the models of every count); `ambient` a
/// column or `"auto"`, and `also_plain` keeps the models of the plain rises
/// beside those over it (the CLI's `--ambient`, `--also-plain`). Returns
/// `(model_toml, doc)`: the model file text `thermal_predict_log` and
/// `thermal compensate` read, and the `ThermalLogFitDoc`.
#[pyfunction]
#[pyo3(signature = (
    log, drift, inputs, period_min = 1.0, train_until_min = None, folds = FoldCounts::One(3),
    max_order = 2, max_inputs = 6, ambient = None, lags = false, input_rule = "pooled",
    search = "forward", start_offset = false, also_plain = false
))]
#[allow(clippy::too_many_arguments)]
fn thermal_fit_log(
    py: Python<'_>,
    log: PathBuf,
    drift: Vec<String>,
    inputs: Vec<String>,
    period_min: f64,
    train_until_min: Option<f64>,
    folds: FoldCounts,
    max_order: usize,
    max_inputs: usize,
    ambient: Option<String>,
    lags: bool,
    input_rule: &str,
    search: &str,
    start_offset: bool,
    also_plain: bool,
) -> PyResult<(String, Py<PyAny>)> {
    fn named(what: &'static str) -> impl Fn(String) -> PyErr {
        move |e| PyValueError::new_err(format!("{what}: {e}"))
    }
    let mut options = thermal::LogFitRunOptions::default();
    options.channels = drift
        .iter()
        .map(|s| ChannelSpec::parse(s).map_err(named("drift")))
        .collect::<PyResult<_>>()?;
    options.inputs = inputs
        .iter()
        .map(|s| InputSpec::parse(s).map_err(named("inputs")))
        .collect::<PyResult<_>>()?;
    options.period_min = period_min;
    options.train_until_min = train_until_min;
    let folds = match folds {
        FoldCounts::One(k) => vec![k],
        FoldCounts::Many(v) => v,
    };
    let Some((&first, rest)) = folds.split_first() else {
        return Err(PyValueError::new_err(
            "folds: give a number of held-out blocks or a list of them",
        ));
    };
    options.fit.folds = first;
    options.fit.ensemble_folds = rest.to_vec();
    options.fit.max_order = max_order;
    options.fit.max_inputs = max_inputs;
    options.fit.lags = lags;
    options.fit.rule = input_rule.parse().map_err(named("input_rule"))?;
    options.fit.search = search.parse().map_err(named("search"))?;
    options.fit.start_offset = start_offset;
    options.ambient = ambient
        .map(|a| a.parse().map_err(named("ambient")))
        .transpose()?;
    options.also_plain = also_plain;
    options.validate().map_err(value_error)?;
    let run = py
        .detach(|| thermal::run_fit_log(&log, &options, &mut |_| {}))
        .map_err(|e| thermal_error(py, e))?;
    Ok((run.model_toml, document(py, "ThermalLogFitDoc", &run.doc)?))
}

/// `mtwin thermal predict --log`: a log model (`model`, a TOML file from
/// `thermal_fit_log`) predicting a wide log (`log`) from its start with its
/// inputs alone. Returns `(table, doc)`: an (N, 1 + channels) array of
/// `t_min` (period centres) and each channel in its unit (the CSV the CLI
/// writes), and the `ThermalLogPredictDoc`.
#[pyfunction]
fn thermal_predict_log<'py>(
    py: Python<'py>,
    model: PathBuf,
    log: PathBuf,
) -> PyResult<(Bound<'py, numpy::PyArray2<f64>>, Py<PyAny>)> {
    let run = py
        .detach(|| {
            thermal::run_predict_log(&model, &log, &thermal::LogPredictRunOptions::default())
        })
        .map_err(|e| thermal_error(py, e))?;
    let cols = run.columns.len();
    let flat: Vec<f64> = run.rows.iter().flatten().copied().collect();
    let arr = numpy::ndarray::Array2::from_shape_vec((run.rows.len(), cols), flat)
        .expect("one value per column in every row");
    Ok((
        numpy::IntoPyArray::into_pyarray(arr, py),
        document(py, "ThermalLogPredictDoc", &run.doc)?,
    ))
}

/// A G-code error as `InputError` at its file, line and column.
pub fn gcode_error(py: Python<'_>, program: &Path, e: &GcodeError) -> PyErr {
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
/// move is checked against the travels along its length (`tcp`: the program is in tool-tip
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
    // With a machine: statistics, travel check and the planned time (as
    // `gcode stats --machine` gives it, the default planner) from one run of
    // the interpreter.
    let inner = machine.map(|m| &m.inner);
    let st = py.detach(|| match (inner, check.as_mut()) {
        (Some(m), Some(c)) => {
            let mut io = gcode::InterpolateOptions::new(1e9);
            io.interp = opts.interp.clone();
            io.force_tcp = tcp;
            gcode::stats_planned(input, &opts, c, m, &io).map(|(mut st, t)| {
                st.planned_time = t.ok();
                st
            })
        }
        _ => gcode::stats(input, &opts),
    });
    let st = st.map_err(|e| gcode_error(py, &program, &e))?;
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

/// `mtwin ballbar identify`: the eight position-independent errors (PIGEs) of
/// the A and C axes of a trunnion from static ballbar readings. `mode1` … `mode4`
/// are the mode files (CSV `angle_deg,length_mm`; at least one); `machine` the
/// nominal model (default: the example `ac-trunnion`); `length`, `zb1c`, `zb1a`
/// the rig (mm) and `ex`, `ey` the tool ball's set-up error (mm, from
/// `ballbar_setup_error`). Returns `(identified, doc)`: the machine with the
/// identified PIGEs (what `--out` writes) and the `BallbarIdentifyDoc`.
#[pyfunction]
#[pyo3(signature = (mode1 = None, mode2 = None, mode3 = None, mode4 = None, machine = None, length = 100.0, zb1c = 100.0, zb1a = 100.0, ex = 0.0, ey = 0.0))]
#[allow(clippy::too_many_arguments)]
fn ballbar_identify(
    py: Python<'_>,
    mode1: Option<PathBuf>,
    mode2: Option<PathBuf>,
    mode3: Option<PathBuf>,
    mode4: Option<PathBuf>,
    machine: Option<&Machine>,
    length: f64,
    zb1c: f64,
    zb1a: f64,
    ex: f64,
    ey: f64,
) -> PyResult<(Machine, Py<PyAny>)> {
    use mtwin::methods::ballbar::{self, IdentifyInputs, IdentifyOptions, Rig};
    let files = [mode1, mode2, mode3, mode4];
    if files.iter().all(|f| f.is_none()) {
        return Err(PyValueError::new_err("give at least one of mode1 … mode4"));
    }
    let bundled;
    let m = match machine {
        Some(m) => &m.inner,
        None => {
            bundled = diag(py, mtwin::examples::machine("ac-trunnion.toml"))?;
            &bundled
        }
    };
    let mut data = Vec::new();
    let mut problems = Diagnostics::default();
    for f in &files {
        data.push(match f {
            Some(p) => match ballbar::read_mode_file(p) {
                Ok(d) => Some(d),
                Err(d) => {
                    problems.0.extend(d.0);
                    None
                }
            },
            None => None,
        });
    }
    if !problems.is_empty() {
        return Err(input_error(py, &problems));
    }
    let modes = [0, 1, 2, 3].map(|i| data[i].as_ref());
    let rig = Rig {
        length,
        zb1c,
        zb1a,
        setup: ballbar::SetupError { ex, ey },
    };
    let inputs = IdentifyInputs {
        machine: m,
        rig,
        modes,
    };
    let (id, doc) = py
        .detach(|| ballbar::identify::run(&inputs, &IdentifyOptions::default()))
        .map_err(value_error)?;
    let text = machine_to_toml(&id.machine, &[]).map_err(value_error)?;
    let path = PathBuf::from("identified from ballbar readings");
    let identified = diag(py, mtwin::model::parse_machine(&path, &text))?;
    Ok((
        Machine::new(identified, path),
        document(py, "BallbarIdentifyDoc", &doc)?,
    ))
}

/// One circular-test trace: a CSV file `angle_deg,deviation_um` or an (N, 2) array.
fn circular_trace(
    py: Python<'_>,
    data: &Bound<'_, PyAny>,
) -> PyResult<mtwin::methods::ballbar::circular::Trace> {
    let rows: Vec<Vec<f64>> = if let Ok(a) = data.extract::<PyReadonlyArray2<'_, f64>>() {
        let r = rows(&a, 2, "trace")?;
        r.as_slice().chunks_exact(2).map(<[f64]>::to_vec).collect()
    } else {
        let path: PathBuf = data.extract().map_err(|_| {
            PyValueError::new_err("a trace must be a CSV file path or an (N, 2) float64 array")
        })?;
        let t = diag(py, Table::read(&path))?;
        diag(py, t.number_rows(&mtwin::io::columns::BALLBAR_CIRCULAR))?
    };
    Ok(mtwin::methods::ballbar::circular::Trace {
        angle_deg: rows.iter().map(|r| r[0]).collect(),
        deviation_um: rows.iter().map(|r| r[1]).collect(),
    })
}

/// `mtwin ballbar circular`: ISO 230-4 circular test — circular hysteresis H,
/// circular deviations G and F and the diagnosis (backlash, squareness, …) from
/// the clockwise (`cw`) and/or counter-clockwise (`ccw`) trace, each a CSV file
/// `angle_deg,deviation_um` or an (N, 2) array of the same columns (angle
/// counter-clockwise from +X in the test plane, degrees; deviation µm).
/// `radius` (the bar length) and `cyclic_pitch` (screw lead) in mm,
/// `spike_width` (decay angle of a reversal spike) in degrees; `plane` `"xy"`,
/// `"yz"` or `"zx"` names the axes of the diagnostics. Returns the
/// `CircularDoc`.
#[pyfunction]
#[pyo3(signature = (radius, cw = None, ccw = None, cyclic_pitch = 10.0, spike_width = 3.0, plane = "xy"))]
fn ballbar_circular(
    py: Python<'_>,
    radius: f64,
    cw: Option<&Bound<'_, PyAny>>,
    ccw: Option<&Bound<'_, PyAny>>,
    cyclic_pitch: f64,
    spike_width: f64,
    plane: &str,
) -> PyResult<Py<PyAny>> {
    use mtwin::methods::ballbar::circular::{CircularOptions, Plane, circular};
    let plane = match plane.to_ascii_lowercase().as_str() {
        "xy" => Plane::Xy,
        "yz" => Plane::Yz,
        "zx" => Plane::Zx,
        other => {
            return Err(PyValueError::new_err(format!(
                "plane `{other}`: expected xy, yz or zx"
            )));
        }
    };
    let cw = cw.map(|d| circular_trace(py, d)).transpose()?;
    let ccw = ccw.map(|d| circular_trace(py, d)).transpose()?;
    let o = CircularOptions {
        radius_mm: radius,
        cyclic_pitch_mm: cyclic_pitch,
        spike_width_deg: spike_width,
        plane,
    };
    let doc = circular(cw.as_ref(), ccw.as_ref(), &o).map_err(PyValueError::new_err)?;
    document(py, "CircularDoc", &doc)
}

/// `mtwin skiving setup-error`: the four set-up errors (δgx, δgy mm; εxz, εzy
/// rad) of a power-skiving workpiece from touch-offs. `data` is the touches CSV
/// (`x,y,z,a,b,c,point,contact`; mm, degrees); `h` clamping height, `l` swing
/// length, `rt` tool tip radius, `rg` workpiece radius (mm); `noise` the known
/// standard deviation of one touch (mm; `None`: estimated); `tolerance` the
/// largest distance of a touch from its surface (mm). Returns the
/// `SkivingSetupDoc` (rows carry their CSV line numbers).
#[pyfunction]
#[pyo3(signature = (data, h, l, rt, rg, noise = None, tolerance = mtwin::methods::skiving::touch::DEFAULT_PLAUSIBILITY_MM))]
#[allow(clippy::too_many_arguments)]
fn skiving_setup_error(
    py: Python<'_>,
    data: PathBuf,
    h: f64,
    l: f64,
    rt: f64,
    rg: f64,
    noise: Option<f64>,
    tolerance: f64,
) -> PyResult<Py<PyAny>> {
    use mtwin::methods::skiving::{self, Geometry, Options, touch::read_touches};
    let g = Geometry::new(h, l, rt, rg)
        .map_err(|e| PyValueError::new_err(format!("invalid machine dimensions: {e}")))?;
    let t = diag(py, Table::read(&data))?;
    let touches = diag(py, read_touches(&t, &g, tolerance))?;
    let (_, _, mut doc) = py
        .detach(|| skiving::run(&touches, &g, &Options::with_noise(noise)))
        .map_err(|e| {
            PyValueError::new_err(format!(
                "{}: cannot identify the set-up error: {e}",
                data.display()
            ))
        })?;
    doc.source = Some(data.display().to_string());
    for (i, row) in doc.rows.iter_mut().enumerate() {
        row.line = t.line(i);
    }
    document(py, "SkivingSetupDoc", &doc)
}

/// `mtwin servo fit`: the command-to-encoder transfer function of one axis from a
/// servo log (CSV `t_s,command_mm,feedback_mm`, evenly sampled). ARX orders up to
/// `max_order`, input delays up to `max_delay` samples; the steady following
/// error is reported at `feed` (mm/min). Returns `(servo_toml, doc)`: the SERVO.toml
/// text (`ts`, `b`, `a`, `nk`: the keys of `[axes.servo]`) and the `ServoFitDoc`.
/// Problems in the log raise `InputError` with file and line.
#[pyfunction]
#[pyo3(signature = (data, max_order = 4, max_delay = 3, feed = 1000.0))]
fn servo_fit(
    py: Python<'_>,
    data: PathBuf,
    max_order: usize,
    max_delay: usize,
    feed: f64,
) -> PyResult<(String, Py<PyAny>)> {
    use mtwin::sysid::{self, FitRunOptions, ServoFitError};
    let mut options = FitRunOptions::default();
    options.fit.max_order = max_order;
    options.fit.max_delay = max_delay;
    options.feed_mm_min = Some(feed);
    let (fit, doc) = py
        .detach(|| sysid::run_fit(&data, &options))
        .map_err(|e| match e {
            ServoFitError::Input(d) => input_error(py, &d),
            e => value_error(e),
        })?;
    let text = fit.to_toml().map_err(value_error)?;
    Ok((text, document(py, "ServoFitDoc", &doc)?))
}

/// `mtwin positioning evaluate`: ISO 230-2 evaluation of a positioning run
/// (A, B, E, M, R per direction and per target; µm). `data` is a CSV table
/// (`target_mm,direction[,cycle],measured_mm|deviation_mm|deviation_um`), an
/// ecmc `.dat`, a Renishaw `.rtx` capture or a raw log (`input_format`:
/// `"auto"` from the name, `"csv"`, `"dat"`, `"rtx"`, `"log"`); the other
/// arguments are those of the CLI for logs and captures (mm, s). Returns the
/// `PositioningDoc`.
#[pyfunction]
#[pyo3(signature = (data, input_format = "auto", ref_channel = None, cmd_channel = None, ref_gain = 1.0, ref_offset = 0.0, targets = None, dwell_band = 0.005, min_dwell_samples = 3, min_dwell_s = 0.5, reach_tol = 0.1))]
#[allow(clippy::too_many_arguments)]
fn positioning_evaluate(
    py: Python<'_>,
    data: PathBuf,
    input_format: &str,
    ref_channel: Option<String>,
    cmd_channel: Option<String>,
    ref_gain: f64,
    ref_offset: f64,
    targets: Option<Vec<f64>>,
    dwell_band: f64,
    min_dwell_samples: usize,
    min_dwell_s: f64,
    reach_tol: f64,
) -> PyResult<Py<PyAny>> {
    use mtwin::methods::positioning::{self, InputFormat, LogOptions, Options};
    for (name, v) in [
        ("dwell_band", dwell_band),
        ("min_dwell_s", min_dwell_s),
        ("reach_tol", reach_tol),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} must be positive, not {v}"
            )));
        }
    }
    if !(ref_gain.is_finite() && ref_gain != 0.0 && ref_offset.is_finite()) {
        return Err(PyValueError::new_err(
            "ref_gain must be a non-zero number and ref_offset a number",
        ));
    }
    if targets
        .as_ref()
        .is_some_and(|t| t.iter().any(|v| !v.is_finite()))
    {
        return Err(PyValueError::new_err("targets must be numbers"));
    }
    let format = match input_format {
        "auto" => InputFormat::Auto,
        "csv" => InputFormat::Csv,
        "dat" => InputFormat::Dat,
        "rtx" => InputFormat::Rtx,
        "log" => InputFormat::Log,
        other => {
            return Err(PyValueError::new_err(format!(
                "input_format must be \"auto\", \"csv\", \"dat\", \"rtx\" or \"log\", got {other:?}"
            )));
        }
    };
    let opts = Options {
        format,
        log: LogOptions {
            reference: ref_channel,
            command: cmd_channel,
            gain: ref_gain,
            offset: ref_offset,
            targets_mm: targets,
            dwell_band_mm: dwell_band,
            min_dwell_samples,
            min_dwell_s,
            reach_tol_mm: reach_tol,
        },
    };
    let doc = diag(py, py.detach(|| positioning::run(&data, &opts)))?;
    document(py, "PositioningDoc", &doc)
}
