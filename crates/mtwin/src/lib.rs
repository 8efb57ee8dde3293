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

// Index loops over small fixed-size arrays are the clearest form of numeric kernels.
#![allow(clippy::needless_range_loop)]

pub mod fit;
pub mod gcode;
pub mod io;
pub mod kinematics;
pub mod limits;
pub mod methods;
pub mod model;
pub mod report;
pub mod sysid;

/// Re-export of the linear-algebra crate used in the public API (vectors, matrices).
pub use nalgebra;
