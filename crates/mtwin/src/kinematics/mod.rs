//! The one kinematics engine of mtwin: exact forward kinematics with geometric errors,
//! exact Jacobians with respect to error components and axis positions, and inverse
//! kinematics on the actual (erroneous) machine.
//!
//! Frames and conventions are those of docs/machine-model.md: `T_ab` maps coordinates in b
//! to a; the tool pose is reported in the workpiece frame W.

mod chain;
mod ik;
mod jacobian;
mod lanes;
pub mod predict;
mod tangent;
pub mod transform;

pub use chain::{Kinematics, ToolPose};
pub use ik::{IkError, IkJacobian, IkOptions, IkTarget};
pub use jacobian::{PoseDerivative, PoseJacobian, SLOTS};
pub use lanes::{LANES, sin_cos_deg};
pub use predict::{PREDICT_COLUMNS, PredictDoc};
pub use transform::Rigid;

#[cfg(test)]
mod tests;
