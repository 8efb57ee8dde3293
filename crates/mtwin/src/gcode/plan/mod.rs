//! Motion planning along a programmed path (see docs/gcode.md).
pub mod jerk;
