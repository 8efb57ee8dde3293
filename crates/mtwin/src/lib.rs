//! mtwin: the accuracy of machine tools.
//!
//! The library holds the domain: the machine model and its geometric errors
//! ([`model`]), exact kinematics ([`kinematics`]), least-squares identification
//! ([`fit`]), ARX system identification ([`sysid`]), the G-code engine
//! ([`gcode`]), the measurement methods built on them ([`methods`]) and
//! reports. It has no command-line or terminal dependencies.
//!
//! Units follow the project conventions: mm, degrees for rotary axis
//! positions, rad for small angular errors, s for time, rev/min for spindle
//! speed.
//!
//! # Quick start
//!
//! Load a bundled example machine ([`examples`]), compute a tool pose, and
//! identify location errors from simulated laser-tracker measurements:
//!
//! ```
//! use mtwin::kinematics::Kinematics;
//! use mtwin::methods::tracker::{self, IdentifyOptions, simulate};
//! use mtwin::model::ParameterSet;
//! use rand::SeedableRng;
//!
//! let machine = mtwin::examples::machine("afp-gantry").unwrap();
//! machine.validate().unwrap();
//!
//! // Tool tip and tool axis in the workpiece frame W at one pose (mm, degree).
//! let q = [1000.0, 500.0, -200.0, 10.0, -5.0, 30.0];
//! let pose = Kinematics::new(&machine).pose(&q);
//! assert!((pose.axis.norm() - 1.0).abs() < 1e-12);
//!
//! // A "true" machine with 20 µm / 20 µrad location errors, measured at
//! // 60 random poses with 1 µm noise, then identified from the nominal model.
//! let params = ParameterSet::from_spec(&machine, "location").unwrap();
//! let mut truth = machine.clone();
//! let theta: Vec<f64> = params
//!     .is_rotation()
//!     .iter()
//!     .map(|&rot| if rot { 2e-5 } else { 0.02 })
//!     .collect();
//! params.set(&mut truth, &theta);
//! let mut rng = rand::rngs::StdRng::seed_from_u64(7);
//! let poses = simulate::random_poses(&machine, 60, &mut rng);
//! let points = simulate::simulate_seeded(&truth, &poses, 0.001, 1);
//! let id = tracker::identify(&machine, &params, &points, &IdentifyOptions::default(), &|_| {})
//!     .unwrap();
//! // The identified machine predicts the truth's tips to the noise level.
//! let (k_id, k_true) = (Kinematics::new(&id.machine), Kinematics::new(&truth));
//! for q in &poses {
//!     assert!((k_id.pose(q).tip - k_true.pose(q).tip).norm() < 0.005);
//! }
//! ```

// Index loops over small fixed-size arrays are the clearest form of numeric kernels.
#![allow(clippy::needless_range_loop)]
#![warn(missing_docs)]

pub mod controller;
pub mod examples;
pub mod fit;
pub mod gcode;
pub mod io;
pub mod kinematics;
pub mod limits;
pub mod methods;
pub mod model;
pub mod par;
pub mod report;
pub mod scenarios;
pub mod sysid;

/// Re-export of the dense linear-algebra crate used in the public API (`Mat`, `Col`).
pub use faer;
/// Re-export of the linear-algebra crate used in the public API (vectors, matrices).
pub use nalgebra;

#[cfg(test)]
mod test_support;
