//! mtwin: machine-tool accuracy.
pub mod fit;
pub mod gcode;
pub mod sysid;
