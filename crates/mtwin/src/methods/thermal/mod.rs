//! Thermal drift of the tool relative to the workpiece in +Z, driven by the
//! spindle speed (`docs/references.md` \[R4\]): one ARX model per measured height, interpolated across
//! heights, fitted from probing runs and used to predict the drift of a new
//! speed programme (and, through [`ThermalPredictor`], to pre-compensate NC
//! programs).
//!
//! Conventions:
//!
//! * drift `e(t, z)` in mm, time in minutes (`t_min`), speed in rev/min,
//!   heights `z` in mm;
//! * the sample period `T` is the probing period (the source paper \[R4\]: 10 min);
//! * an input value given at `t = kT` holds over `[kT, (k+1)T)`, so it acts on
//!   the drift from `(k+1)T` on: every input of a thermal model has a delay
//!   `nk ≥ 1`. The model of 04, `e(t) = Σ a_i e(t−i) + Σ_{i=0..m} b_i n(t−i)`,
//!   is this one with its `n(t−i)` the speed over the period ending at `t−i`,
//!   i.e. `nk = 1`; the `a` coefficients are stored as the polynomial
//!   `[1, a_1, …]` of [`crate::sysid::Arx`] (signs opposite to 04's sum);
//! * a run starts cold: `e = 0` and every input `= 0` before `t = 0`;
//! * inputs are divided by a per-input scale (the largest training value) so
//!   the coefficients are of comparable size; the scale is stored with the model.

mod compensate;
mod data;
pub mod doc;
mod file;
pub mod log;
mod model;
mod predict;
mod program;
pub mod run;
mod speed_model;
mod synthetic;

pub use compensate::{
    AxisBlock, AxisSummary, CompensateError, CompensateOptions, Compensation, CorrectionUpdate,
    LogCompensateOptions, PlannedTiming, SpeedHistory, ZBlock, compensate, compensate_log,
};
pub use data::{TrainingData, read_training, training_from_table};
pub use doc::{
    CompensateAxisDoc, InputChannelDoc, LogChannelDoc, LogMemberDoc, LogPredictedChannelDoc,
    LogSelectionStepDoc, LogTestDoc, PredictedHeightDoc, SpeedModelDoc, ThermalCompensateDoc,
    ThermalFitDoc, ThermalHeightDoc, ThermalLogFitDoc, ThermalLogPredictDoc, ThermalPredictDoc,
    ThermalSimulateDoc,
};
pub use file::{model_from_toml_str, read_model};
pub use model::{
    Drift, HeightModel, HeightRange, HeightStats, InputChannel, ThermalModel, ThermalPredictor,
};
pub use predict::{
    HeightReport, Prediction, Programme, SimulatedData, ThermalFit, ThermalFitOptions, fit,
    fit_csv, predict, read_programme, simulate,
};
pub use program::{
    BallArray, ProbeMotion, ThermalProgram, ThermalProgramError, pass_seconds, thermal_program,
    thermal_program_on,
};
pub use run::{
    Ambient, FitRun, FitRunOptions, LogFitProgress, LogFitRun, LogFitRunOptions, LogPredictRun,
    LogPredictRunOptions, PredictRun, PredictRunOptions, is_log_model, plot_file_name, run_fit,
    run_fit_log, run_predict, run_predict_log,
};
pub use speed_model::{REQUIRED_GAIN, SpeedModel, SpeedModelChoice, choose_speed_model};
pub use synthetic::TruthMachine;

use crate::io::Diagnostics;
use crate::sysid::SysidError;

/// Why a thermal command failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ThermalError {
    /// Problems in an input file, each with file and line.
    #[error("{0}")]
    Input(#[from] Diagnostics),
    /// The model of one height could not be identified.
    #[error("the drift at z = {} mm could not be modelled: {source}", crate::limits::fmt_message_number(*.z_mm))]
    Fit {
        /// The height, mm.
        z_mm: f64,
        /// What failed.
        source: SysidError,
    },
    /// A model that breaks an invariant (built in code, not read from a file).
    #[error("invalid thermal model: {0}")]
    Model(String),
    /// An option outside its domain or beyond a bound of [`crate::limits`].
    #[error("{0}")]
    Options(String),
    /// A prediction overflowed (an unstable model, or coefficients too
    /// large): nothing is to be written. The text names the model file.
    #[error("{0}")]
    Diverged(String),
    /// `auto` could not compare the speed models.
    #[error("cannot choose the speed model: {0}")]
    SpeedModel(String),
    /// Writing an output file failed.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}
