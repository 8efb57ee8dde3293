//! Measurement methods built on the model, the kinematics and the fit engine.

pub mod tracker;
