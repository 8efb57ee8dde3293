//! gcode
