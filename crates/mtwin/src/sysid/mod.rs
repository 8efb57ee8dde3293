//! ARX system identification: linear discrete-time models of an output driven
//! by one or several exogenous inputs, fitted by least squares.
//!
//! The model (docs/servo.md, and the thermal model of docs/thermal.md with the sign of the `a` coefficients flipped):
//!
//! ```text
//! y(k) = −Σ_{i=1..na} a_i·y(k−i) + Σ_u Σ_{j=0..nb_u} b_{u,j}·u(k−j−nk_u),   a_0 = 1
//! ```
//!
//! * [`Arx`]: the model, one-step prediction, free-run simulation, poles and
//!   stability, a streaming [`ArxStepper`];
//! * [`fit_arx`]: least squares (Householder QR, never the normal equations)
//!   over one or several [`Run`]s, each from its own initial state, with the
//!   coefficient standard uncertainties and the fit statistics;
//! * [`select_orders`]: FPE and AIC over a grid of orders, with the whole
//!   grid table;
//! * [`Servo`]: the per-axis transfer function of docs/servo.md (`[axes.servo]`),
//!   run on deviations from the first command, with its bandwidth and
//!   following error, and [`fit_servo`] which identifies it from a log;
//! * [`excitation_program`]: the G-code program that records such a log;
//! * [`run_fit`], [`run_simulate`], [`run_excitation`]: the `mtwin servo`
//!   methods, options in and a document out.
//!
//! Units are those of the data: the module never rescales outputs; inputs
//! and outputs keep whatever unit the caller gives them.

mod arx;
mod error;
mod excitation;
mod fit;
mod order;
mod output_error;
pub(crate) mod sampling;
mod servo;
mod servo_doc;
mod servo_fit;
mod servo_run;

pub use arx::{Arx, ArxOrders, ArxStepper, InputOrder, Stability};
pub use error::SysidError;
pub use excitation::{ExcitationError, ExcitationOptions, excitation_program, excitation_targets};
pub use fit::{ArxFit, FitStats, Run, Start, fit_arx};
pub use order::{
    Criterion, GridRow, GridRowDoc, InputGrid, OrderGrid, OrderSelection, grid_text, select_orders,
};
pub use output_error::{
    OutputErrorFit, OutputErrorModel, fit_output_error, fit_output_error_par,
    select_orders_output_error,
};
pub use servo::{Servo, ServoStepper};
pub use servo_doc::{OrdersDoc, ServoExcitationDoc, ServoFitDoc, ServoSimulateDoc};
pub(crate) use servo_fit::read_servo_table;
pub use servo_fit::{
    ServoFit, ServoFitError, ServoFitOptions, ServoLog, fit_servo, fit_servo_csv, read_servo_log,
    read_servo_toml, servo_from_toml_str,
};
pub use servo_run::{
    FitRunOptions, SimulateRunError, SimulateRunOptions, read_servo_commands, run_excitation,
    run_fit, run_simulate,
};
