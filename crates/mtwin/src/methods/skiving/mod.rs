//! Workpiece set-up (pose) error of a power-skiving machine from touch-offs
//! (after \[R3\] in docs/references.md).
//!
//! * [`chain`]: the exact chain `M_gt = M_xg'⁻¹·M_xt` with the four unknowns
//!   `δgx, δgy` (mm), `εxz, εzy` (rad);
//! * [`touch`]: a touch-off as a measurement model (top-face or
//!   side-cylinder condition, exact) for the least-squares engine
//!   [`crate::fit`];
//! * [`closed_form`]: first-order closed forms derived from the chain;
//! * [`program`]: the touch-off plan and its G-code;
//! * [`simulate`]: touches for known set-up errors, contact solved exactly;
//! * [`identify`]: the exact least-squares solution with uncertainties and
//!   per-touch consistency flags.

pub mod chain;
pub mod closed_form;
pub mod doc;
pub mod program;
pub mod simulate;
pub mod touch;

use faer::Mat;
use nalgebra::{DMatrix, Matrix4};

pub use chain::{AxisPositions, Geometry, SetupError};
pub use touch::{Contact, ToolPoint, Touch, TouchModel};

use crate::fit::{self, FitError, FitReport, Model};

/// Touch noise (mm) assumed for flagging inconsistent touches when no
/// noise level is given: a typical repeatability of a touch-off.
pub const DEFAULT_FLAG_NOISE_MM: f64 = 0.002;

/// A touch whose standardized residual exceeds this is flagged.
pub const FLAG_THRESHOLD: f64 = 3.0;

/// Settings of [`identify`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub struct Options {
    /// Known standard deviation of one touch (mm, along the probing
    /// direction). When given, the uncertainties are `σ·√diag((JᵀJ)⁻¹)`;
    /// otherwise `σ` is estimated from the residuals (few degrees of
    /// freedom: see [`Uncertainty::coverage_factor_95`]).
    pub noise: Option<f64>,
}

impl Options {
    /// Settings with the known standard deviation of one touch, mm (`None`:
    /// estimated from the residuals).
    pub fn with_noise(noise: Option<f64>) -> Self {
        Options { noise }
    }
}

/// Where the standard uncertainties come from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum UncertaintyBasis {
    /// A known touch noise σ (mm): a 2σ interval is a 95 % interval.
    KnownNoise {
        /// σ, mm.
        sigma: f64,
    },
    /// σ estimated from the residuals with `dof` degrees of freedom: a 95 %
    /// interval is the Student-t factor `t(0.975, dof)` times the
    /// uncertainty (4.30 for six touches).
    Residuals {
        /// σ estimated, mm.
        sigma: f64,
        /// Degrees of freedom (touches − 4).
        dof: usize,
    },
}

/// Standard uncertainties of `[dgx, dgy, exz, ezy]` (mm, mm, rad, rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Uncertainty {
    /// Standard uncertainties of `[dgx, dgy, exz, ezy]` (mm, mm, rad, rad).
    pub std: [f64; 4],
    /// Where σ comes from.
    pub basis: UncertaintyBasis,
}

impl Uncertainty {
    /// The factor that turns a standard uncertainty into a 95 % interval.
    pub fn coverage_factor_95(&self) -> f64 {
        match self.basis {
            UncertaintyBasis::KnownNoise { .. } => 1.959_963_984_540_054,
            UncertaintyBasis::Residuals { dof, .. } => student_t_975(dof),
        }
    }
}

/// What the other touches say about one touch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TouchFlag {
    /// Its residual is consistent with the noise.
    #[serde(rename = "ok")]
    Consistent,
    /// Its standardized residual exceeds [`FLAG_THRESHOLD`]: the touch (or
    /// its partner, e.g. the other face touch at the same table angle) is
    /// inconsistent with the others.
    #[serde(rename = "inconsistent")]
    Inconsistent,
    /// No other touch checks it (leverage 1: its residual is zero whatever
    /// it measured, and an error in it goes straight into the estimate).
    #[serde(rename = "unchecked")]
    Unchecked,
}

impl TouchFlag {
    /// A short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            TouchFlag::Consistent => "ok",
            TouchFlag::Inconsistent => "inconsistent",
            TouchFlag::Unchecked => "unchecked",
        }
    }
}

/// The identified set-up error.
#[derive(Debug, Clone)]
pub struct Solution {
    /// The identified set-up error.
    pub estimate: SetupError,
    /// `None` when σ can be neither given nor estimated (as many touches
    /// as unknowns and no known noise).
    pub uncertainty: Option<Uncertainty>,
    /// Residual of every touch at the solution (mm), in input order.
    pub residuals: Vec<f64>,
    /// Leverage `hᵢᵢ` of every touch (0…1).
    pub leverage: Vec<f64>,
    /// `rᵢ/(σ_flag·√(1 − hᵢᵢ))`, `None` for unchecked touches.
    pub standardized: Vec<Option<f64>>,
    /// The noise level used for the flags (mm).
    pub flag_noise: f64,
    /// What the other touches say about every touch, in input order.
    pub flags: Vec<TouchFlag>,
    /// The engine's report (convergence, identifiability, warnings).
    pub fit: FitReport,
}

/// Why the set-up error cannot be identified.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SkivingIdentifyError {
    /// Fewer touches (the count) than the four unknowns.
    #[error(
        "{0} touches cannot determine 4 unknowns; at least 4 (the standard plan has 6) are needed"
    )]
    TooFewTouches(usize),
    /// The touches leave these unknowns undetermined.
    #[error("the touches do not determine {}; add touches at another table angle or y position", .0.join(", "))]
    NotIdentifiable(Vec<String>),
    /// The given noise σ (mm) is not a positive finite number.
    #[error("the noise sigma {} mm must be a positive finite number", crate::limits::fmt_message_number(*.0))]
    Noise(f64),
    /// The least-squares iteration did not converge (the engine's reason).
    #[error("the least-squares solution did not converge: {0}")]
    NotConverged(String),
    /// The least-squares engine failed.
    #[error(transparent)]
    Fit(#[from] FitError),
}

/// `mtwin skiving setup-error`: the least-squares set-up error of
/// `touches` on the workpiece `g` ([`identify`] with `options`), the
/// first-order closed form where it applies ([`closed_form::first_order`])
/// and the document. The document's rows are numbered by touch (1, 2, …);
/// a caller that read the touches from a file sets their lines and the
/// document's `source`.
#[allow(clippy::type_complexity)]
pub fn run(
    touches: &[Touch],
    g: &Geometry,
    options: &Options,
) -> Result<
    (
        Solution,
        Result<SetupError, closed_form::ClosedFormError>,
        doc::SkivingSetupDoc,
    ),
    SkivingIdentifyError,
> {
    let s = identify(touches, g, options)?;
    let first = closed_form::first_order(touches, g);
    let mut d = doc::SkivingSetupDoc::new(&s, first.as_ref().ok().copied(), touches.len());
    d.first_order_not_applicable = first.as_ref().err().map(|e| e.to_string());
    d.rows = touches
        .iter()
        .enumerate()
        .map(|(i, t)| doc::TouchRowDoc {
            line: i + 1,
            c_deg: t.at.c,
            point: t.point.name().into(),
            contact: t.contact.name().into(),
        })
        .collect();
    Ok((s, first, d))
}

/// The exact least-squares set-up error from `touches` (any number ≥ 4,
/// any table angles and swivel positions), started from the first-order
/// closed form when it applies.
pub fn identify(
    touches: &[Touch],
    g: &Geometry,
    options: &Options,
) -> Result<Solution, SkivingIdentifyError> {
    if let Some(s) = options.noise
        && !(s.is_finite() && s > 0.0)
    {
        return Err(SkivingIdentifyError::Noise(s));
    }
    let m = touches.len();
    if m < 4 {
        return Err(SkivingIdentifyError::TooFewTouches(m));
    }
    let model = TouchModel::new(touches, *g);
    let start = closed_form::first_order(touches, g)
        .map(|e| e.to_array())
        .unwrap_or([0.0; 4]);
    let fit_opts = fit::Options {
        gradient_tolerance: 1e-14,
        step_tolerance: 1e-14,
        cost_tolerance: 1e-20,
        ..fit::Options::default()
    };
    let report = fit::fit(&model, &start, &fit_opts)?;
    let missing: Vec<String> = report
        .unidentifiable_names()
        .into_iter()
        .map(str::to_owned)
        .collect();
    if !missing.is_empty() {
        return Err(SkivingIdentifyError::NotIdentifiable(missing));
    }
    if let Some(w) = report
        .warnings
        .iter()
        .find(|w| matches!(w, fit::Warning::NotConverged { .. }))
    {
        return Err(SkivingIdentifyError::NotConverged(w.to_string()));
    }
    let theta = [
        report.theta[0],
        report.theta[1],
        report.theta[2],
        report.theta[3],
    ];
    let estimate = SetupError::from_array(theta);

    // Jacobian at the solution: (JᵀJ)⁻¹ and the leverages.
    let mut jf = Mat::<f64>::zeros(m, 4);
    model.jacobian(&theta, 0..m, jf.as_mut());
    let j = DMatrix::from_fn(m, 4, |i, k| jf[(i, k)]);
    let jtj: Matrix4<f64> = (j.transpose() * &j).fixed_view::<4, 4>(0, 0).into_owned();
    let inv = jtj.try_inverse().ok_or_else(|| {
        SkivingIdentifyError::NotIdentifiable(SetupError::NAMES.map(String::from).to_vec())
    })?;
    let leverage: Vec<f64> = (0..m)
        .map(|i| {
            let row = j.row(i).transpose();
            let row = nalgebra::Vector4::new(row[0], row[1], row[2], row[3]);
            (row.transpose() * inv * row)[(0, 0)].clamp(0.0, 1.0)
        })
        .collect();
    let mut residuals = vec![0.0; m];
    model.residuals(&theta, 0..m, &mut residuals);

    let dof = m - 4;
    let ssr: f64 = residuals.iter().map(|r| r * r).sum();
    let basis = match options.noise {
        Some(sigma) => Some(UncertaintyBasis::KnownNoise { sigma }),
        None if dof > 0 => Some(UncertaintyBasis::Residuals {
            sigma: (ssr / dof as f64).sqrt(),
            dof,
        }),
        None => None,
    };
    let uncertainty = basis.map(|basis| {
        let sigma = match basis {
            UncertaintyBasis::KnownNoise { sigma } | UncertaintyBasis::Residuals { sigma, .. } => {
                sigma
            }
        };
        Uncertainty {
            std: [0, 1, 2, 3].map(|k| sigma * inv[(k, k)].max(0.0).sqrt()),
            basis,
        }
    });

    let flag_noise = options.noise.unwrap_or(DEFAULT_FLAG_NOISE_MM);
    let standardized: Vec<Option<f64>> = residuals
        .iter()
        .zip(&leverage)
        .map(|(r, h)| (*h < 1.0 - 1e-6).then(|| r / (flag_noise * (1.0 - h).sqrt())))
        .collect();
    let flags = standardized
        .iter()
        .map(|s| match s {
            None => TouchFlag::Unchecked,
            Some(t) if t.abs() > FLAG_THRESHOLD => TouchFlag::Inconsistent,
            Some(_) => TouchFlag::Consistent,
        })
        .collect();
    Ok(Solution {
        estimate,
        uncertainty,
        residuals,
        leverage,
        standardized,
        flag_noise,
        flags,
        fit: report,
    })
}

/// The 97.5 % quantile of Student's t with `dof` degrees of freedom (the
/// 95 % two-sided coverage factor): tabulated to 30, then the
/// Cornish–Fisher expansion (error below 1e-4).
pub fn student_t_975(dof: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match dof {
        0 => f64::INFINITY,
        1..=30 => T[dof - 1],
        _ => {
            let z: f64 = 1.959_963_984_540_054;
            let v = dof as f64;
            z + (z.powi(3) + z) / (4.0 * v)
                + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * v * v)
        }
    }
}

#[cfg(test)]
mod tests;
