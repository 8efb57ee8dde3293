//! The column names of every CSV file mtwin writes and reads, defined once:
//! each writer prints these names as its header and each reader asks for
//! them, so the two cannot drift apart. Units are in the names (`_mm`, `_s`,
//! `_min`, `_deg`, `_rpm`); the file formats are described in docs/guide.md.
//!
//! Files whose columns depend on the machine (pose files, `gcode
//! interpolate` output, tracker points) start with the machine's axis names
//! and end with the fixed columns below.

/// Time in seconds (servo logs, command series, interpolated programs).
pub const T_S: &str = "t_s";
/// Time in minutes (thermal logs, speed programmes, drift predictions).
pub const T_MIN: &str = "t_min";
/// The time columns: their values may be larger than other numbers
/// ([`crate::limits::MAX_ABS_TIME`]) so raw epoch timestamps read.
pub const TIME: [&str; 2] = [T_S, T_MIN];

/// A servo log, `LOG.csv` of `servo simulate` and `servo fit`: time (s),
/// commanded and measured (encoder) position (mm).
pub const SERVO_LOG: [&str; 3] = [T_S, SERVO_COMMAND, "feedback_mm"];
/// The commanded position of a servo log, and the default column that
/// `servo simulate` reads from its commands file (mm).
pub const SERVO_COMMAND: &str = "command_mm";

/// Height (mm) of a thermal drift sample.
pub const Z_MM: &str = "z_mm";
/// Measured or predicted thermal drift (mm).
pub const DRIFT_MM: &str = "drift_mm";
/// Alternative to [`DRIFT_MM`] in thermal training data: the probe's touched
/// Z minus the cold pass's (mm), i.e. minus the drift (the probe trips at
/// `b − e` when the tool has grown by `e` in +Z).
pub const PROBE_SHIFT_MM: &str = "probe_shift_mm";
/// Spindle speed (rev/min), the first input of a thermal model.
pub const SPEED_RPM: &str = "speed_rpm";
/// A thermal drift prediction, `DRIFT.csv` of `thermal predict`.
pub const THERMAL_PREDICTION: [&str; 3] = [T_MIN, Z_MM, DRIFT_MM];

/// Ballbar readings of one mode: table angle (deg) and bar length (mm).
pub const BALLBAR_MODE: [&str; 2] = ["angle_deg", "length_mm"];
/// A circular-test trace (ISO 230-4) of `ballbar circular` and
/// `ballbar simulate-circular`: angle counter-clockwise from +X in the test
/// plane (deg), deviation of the measured radius from the nominal (µm).
pub const BALLBAR_CIRCULAR: [&str; 2] = ["angle_deg", "deviation_um"];

/// Skiving touches: the numeric columns, machine positions at each touch
/// (mm, deg).
pub const SKIVING_TOUCH_POSITION: [&str; 6] = ["x", "y", "z", "a", "b", "c"];
/// Skiving touches: the label columns after the positions, `point`
/// (`face`|`tip`) and `contact` (`top`|`side`).
pub const SKIVING_TOUCH_LABELS: [&str; 2] = ["point", "contact"];

/// Tracker points: the measured tool tip (mm) after the axis columns.
pub const TRACKER_MEASURED: [&str; 3] = ["x", "y", "z"];
/// Tracker compensation: predicted tip error before and after correction
/// (mm) and the tool-axis error after (rad), after the corrected axis columns.
pub const TRACKER_COMPENSATED: [&str; 3] = ["error_before", "error_after", "axis_error_after"];

/// A CSV header line (without the newline) of `names`.
pub fn header(names: &[&str]) -> String {
    names.join(",")
}
