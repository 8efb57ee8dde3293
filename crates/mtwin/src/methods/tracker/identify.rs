//! Identification of the geometric errors from tool-tip measurements: checks
//! the input, runs the least-squares engine on [`TrackerModel`] and writes the
//! identified values into a copy of the machine. Parameters the points do
//! not determine individually are gauge-fixed: set to the prior (0 by
//! default, or a previous calibration) plus their share of the combinations
//! the points determine (see [`crate::fit::gauge`]).

use nalgebra::{Matrix3, Vector3};

use super::model::{TrackerModel, TrackerPoint};
use crate::fit::{self, FitError, FitReport, Progress};
use crate::kinematics::Kinematics;
use crate::model::{Machine, ParameterSet};

/// Settings of an identification.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct IdentifyOptions {
    /// Fit the tracker-to-W registration (6 parameters) with the errors.
    pub registration: bool,
    /// Settings of the least-squares engine (including its parallelism,
    /// `fit.par`). The default excludes outlier points (a blocked beam)
    /// from a second fit; they are reported in `report.outliers`; and it
    /// gauge-fixes the solution (`fit.gauge` is [`fit::Gauge::Start`]: the
    /// errors the points do not determine are pulled to 0, or to `prior`)
    /// and sets badly determined directions to the same prior
    /// (`fit.truncation` is `std=10`, see [`DEFAULT_TRUNCATION_STD`] and
    /// [`fit::truncation`]).
    pub fit: fit::Options,
    /// Name of the file the caller writes the identified machine to,
    /// reported by the document of [`run`].
    pub out: String,
    /// The gauge's prior: a previous calibration of the same machine (same
    /// axes) whose values of the fitted errors the unidentifiable
    /// directions are pulled to. `None` (default): 0, the minimum-norm
    /// solution in the scaled parameters. The registration is pulled to its
    /// start (the best rigid fit) either way. Ignored when `fit.gauge` is
    /// [`fit::Gauge::Pivoted`]. See the documentation of [`fit::gauge`].
    pub prior: Option<Machine>,
}

/// The default rank rule's bound ([`fit::Truncation::Uncertainty`]): a
/// direction whose standard uncertainty would exceed 10 typical scales
/// (10 µm, 100 µrad) in some error is set to the prior.
pub const DEFAULT_TRUNCATION_STD: f64 = 10.0;

/// The inputs of [`run`].
#[derive(Debug, Clone, Copy)]
pub struct IdentifyInputs<'a> {
    /// Nominal geometry (and errors not being fitted).
    pub machine: &'a Machine,
    /// What to fit.
    pub params: &'a ParameterSet,
    /// Axis positions (mm, degree) and measured tool tips (mm, W or the tracker frame).
    pub points: &'a [TrackerPoint],
}

/// `mtwin tracker identify`: the identification ([`identify`]; `progress`
/// is told how far the engine got) and its document.
pub fn run(
    inputs: &IdentifyInputs<'_>,
    options: &IdentifyOptions,
    progress: &dyn Fn(Progress),
) -> Result<(Identification, super::TrackerIdentifyDoc), TrackerIdentifyError> {
    let id = identify(
        inputs.machine,
        inputs.params,
        inputs.points,
        options,
        progress,
    )?;
    let doc = super::TrackerIdentifyDoc::new(&id, inputs.points.len(), &options.out);
    Ok((id, doc))
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        let mut fit = fit::Options::default();
        fit.outliers.exclude = true;
        // Gauge-fixed: the confounded errors are pulled to 0 (or `prior`),
        // and so are the directions whose standard uncertainty would exceed
        // 10 typical scales (10 µm, 100 µrad) in some error: on the demo
        // gantry this drops the same 8 directions for every bound from 10
        // to 100 (docs/tracker.md, "Badly determined directions").
        fit.gauge = fit::Gauge::Start;
        fit.truncation = fit::Truncation::Uncertainty(DEFAULT_TRUNCATION_STD);
        Self {
            registration: false,
            fit,
            out: String::new(),
            prior: None,
        }
    }
}

/// Why an identification could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TrackerIdentifyError {
    /// No points were given.
    #[error("there are no measured points")]
    NoPoints,
    /// A point has the wrong number of axis positions.
    #[error("point {point} has {got} axis positions but the machine has {expected} axes")]
    AxisCount {
        /// Index of the point.
        point: usize,
        /// Axis positions it has.
        got: usize,
        /// Axes of the machine.
        expected: usize,
    },
    /// A point holds a non-finite number.
    #[error("point {point} holds a value that is not a finite number")]
    NonFinite {
        /// Index of the point.
        point: usize,
    },
    /// An axis position is outside the axis travel.
    #[error(
        "point {point}: axis {axis} at {} is outside its travel [{}, {}]",
        crate::limits::fmt_message_number(*.value),
        crate::limits::fmt_message_number(*.lo),
        crate::limits::fmt_message_number(*.hi)
    )]
    OutOfTravel {
        /// Index of the point.
        point: usize,
        /// The axis.
        axis: String,
        /// The position (mm or degrees).
        value: f64,
        /// Lower end of the travel.
        lo: f64,
        /// Upper end of the travel.
        hi: f64,
    },
    /// Too few points for the identifiable parameters.
    #[error(
        "{points} measured points cannot determine the {rank} identifiable parameters (need more points than that)"
    )]
    TooFewPoints {
        /// Points given.
        points: usize,
        /// Identifiable parameters (rank of the Jacobian).
        rank: usize,
    },
    /// The prior machine does not have the machine's axes.
    #[error(
        "the prior machine has axes {prior} but the machine has {machine}: a prior must be a calibration of the same machine"
    )]
    PriorAxes {
        /// Axis names of the prior, comma-separated.
        prior: String,
        /// Axis names of the machine, comma-separated.
        machine: String,
    },
    /// The least-squares engine failed.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// The pose program of a plan could not be written.
    #[error("cannot write the pose program: {0}")]
    Program(#[from] crate::gcode::WriteError),
}

/// The result of [`identify`].
#[derive(Debug, Clone)]
pub struct Identification {
    /// The input machine with the identified values written in.
    pub machine: Machine,
    /// What was fitted (the error part of θ).
    pub params: ParameterSet,
    /// The fit: estimates (errors, then registration), identifiability,
    /// uncertainties, residuals.
    pub report: FitReport,
    /// Registration `[tx, ty, tz (mm), a, b, c (rad)]`, tracker → W, if fitted.
    pub registration: Option<[f64; 6]>,
}

/// Checks the points against the machine: axis count, finite values, travel.
pub fn check_points(
    machine: &Machine,
    points: &[TrackerPoint],
) -> Result<(), TrackerIdentifyError> {
    if points.is_empty() {
        return Err(TrackerIdentifyError::NoPoints);
    }
    for (k, p) in points.iter().enumerate() {
        if p.q.len() != machine.n_axes() {
            return Err(TrackerIdentifyError::AxisCount {
                point: k,
                got: p.q.len(),
                expected: machine.n_axes(),
            });
        }
        if p.q.iter().any(|v| !v.is_finite()) || p.measured.iter().any(|v| !v.is_finite()) {
            return Err(TrackerIdentifyError::NonFinite { point: k });
        }
        if let Some((i, v)) = machine.out_of_travel(&p.q) {
            let a = &machine.axes[i];
            return Err(TrackerIdentifyError::OutOfTravel {
                point: k,
                axis: a.name.clone(),
                value: v,
                lo: a.travel[0],
                hi: a.travel[1],
            });
        }
    }
    Ok(())
}

/// The rigid transform (as `[tx, ty, tz, a, b, c]` of `Rx(a)·Ry(b)·Rz(c)`)
/// that best maps `from` onto `to` (Kabsch / Horn, least squares).
pub fn best_rigid(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> [f64; 6] {
    let n = from.len().max(1) as f64;
    let cf = from.iter().sum::<Vector3<f64>>() / n;
    let ct = to.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (f, t) in from.iter().zip(to) {
        h += (f - cf) * (t - ct).transpose();
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return [ct.x - cf.x, ct.y - cf.y, ct.z - cf.z, 0.0, 0.0, 0.0];
    };
    let mut d = Matrix3::identity();
    if (vt.transpose() * u.transpose()).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = vt.transpose() * d * u.transpose();
    let t = ct - r * cf;
    // R = Rx(a)·Ry(b)·Rz(c): R02 = sin b, R12 = −sin a cos b, R22 = cos a cos b,
    // R01 = −cos b sin c, R00 = cos b cos c.
    let b = r[(0, 2)].clamp(-1.0, 1.0).asin();
    let a = (-r[(1, 2)]).atan2(r[(2, 2)]);
    let c = (-r[(0, 1)]).atan2(r[(0, 0)]);
    [t.x, t.y, t.z, a, b, c]
}

/// Identifies `params` of `machine` from `points` (see the module
/// documentation). The errors of `params` start from 0; the machine's other
/// errors are kept. With a registration, its start is the best rigid fit of
/// the measured points onto the nominal tips.
pub fn identify(
    machine: &Machine,
    params: &ParameterSet,
    points: &[TrackerPoint],
    options: &IdentifyOptions,
    progress: &dyn Fn(Progress),
) -> Result<Identification, TrackerIdentifyError> {
    check_points(machine, points)?;
    let model = TrackerModel::new(machine, params, points, options.registration);
    let mut theta0 = vec![0.0; model.len()];
    if options.registration {
        let kin = Kinematics::new(&model.machine_at(&theta0));
        let to: Vec<Vector3<f64>> = points.iter().map(|p| kin.pose(&p.q).tip).collect();
        let from: Vec<Vector3<f64>> = points.iter().map(|p| p.measured).collect();
        let g = best_rigid(&from, &to);
        theta0[params.len()..].copy_from_slice(&g);
    }
    let mut fit_options = options.fit.clone();
    if let (Some(prior), fit::Gauge::Start | fit::Gauge::Prior(_)) =
        (&options.prior, &options.fit.gauge)
    {
        let names = |m: &Machine| {
            m.axes
                .iter()
                .map(|a| a.name.as_str())
                .collect::<Vec<_>>()
                .join(",")
        };
        if names(prior) != names(machine) {
            return Err(TrackerIdentifyError::PriorAxes {
                prior: names(prior),
                machine: names(machine),
            });
        }
        let mut p = theta0.clone();
        p[..params.len()].copy_from_slice(&params.get(prior));
        fit_options.gauge = fit::Gauge::Prior(p);
    }
    let report = fit::fit_with_progress(&model, &theta0, &fit_options, progress)?;
    let rank = report.identifiability.rank;
    if points.len() < rank || report.degrees_of_freedom == 0 {
        return Err(TrackerIdentifyError::TooFewPoints {
            points: points.len(),
            rank,
        });
    }
    let machine = model.machine_at(&report.theta);
    let registration = options.registration.then(|| {
        let mut g = [0.0; 6];
        g.copy_from_slice(&report.theta[params.len()..]);
        g
    });
    Ok(Identification {
        machine,
        params: params.clone(),
        report,
        registration,
    })
}

#[cfg(test)]
#[path = "identify_tests.rs"]
mod tests;
