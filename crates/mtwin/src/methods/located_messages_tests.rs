//! The location-free `message()` of the errors whose callers print
//! `file:line:col: message`: for a located error the `Display` text is
//! `line N: ` followed by the message, and the message never names the
//! line again.

use crate::gcode::{GcodeError, InterpolateError};
use crate::kinematics::IkError;
use crate::methods::compensate::CompensateError;
use crate::methods::thermal::CompensateError as ThermalCompensateError;

/// `shown` is `line N: ` + `message`, and `message` does not name line `N`.
fn located_once(shown: String, line: u64, message: String) {
    assert_eq!(shown, format!("line {line}: {message}"));
    assert!(!message.contains(&format!("line {line}")), "{message}");
}

fn ik() -> IkError {
    IkError::NotConverged {
        iterations: 7,
        tip_residual: 1e-3,
        axis_residual: 2e-6,
    }
}

#[test]
fn interpolate_error_messages_leave_the_line_to_the_caller() {
    let errors = [
        InterpolateError::MissingAxis {
            line: 4,
            letter: 'B',
        },
        InterpolateError::Feed {
            line: 9,
            message: "G1 with a zero feed".into(),
        },
        InterpolateError::Ik {
            line: 12,
            x: 1.0,
            y: -2.5,
            z: 30.0,
            source: ik(),
        },
        InterpolateError::TooManySamples {
            line: 3,
            t: 1e6,
            ts: 0.001,
            max: 100,
        },
        InterpolateError::OutOfTravel {
            line: 21,
            axis: "X".into(),
            value: 510.5,
            unit: "mm",
            t: 0.25,
            lo: -500.0,
            hi: 500.0,
        },
    ];
    for e in errors {
        located_once(e.to_string(), e.line().unwrap(), e.message());
    }
    let m = InterpolateError::MissingAxis {
        line: 4,
        letter: 'B',
    }
    .message();
    assert_eq!(
        m,
        "the program moves axis B, which the machine does not have"
    );
    // An error without a line is its whole text.
    let e = InterpolateError::Period(-1.0);
    assert_eq!(e.message(), e.to_string());
}

#[test]
fn a_gcode_error_inside_an_interpolate_error_gives_the_gcode_message() {
    let g = crate::gcode::Block::parse(b"G1 X", 5).unwrap_err();
    let expected = g.message();
    let e = InterpolateError::Gcode(g);
    assert_eq!(e.message(), expected);
    assert!(!expected.contains("line 5"), "{expected}");
}

#[test]
fn compensate_error_messages_leave_the_line_to_the_caller() {
    let errors = [
        CompensateError::Ik {
            line: 8,
            source: ik(),
        },
        CompensateError::TooLarge {
            line: 2,
            correction_um: 612.34,
            limit_um: 500.0,
        },
        CompensateError::NoConvergence {
            line: 40,
            deviation_um: 1.5,
        },
    ];
    for e in errors {
        located_once(e.to_string(), e.line().unwrap(), e.message());
    }
    let e = CompensateError::TooLarge {
        line: 2,
        correction_um: 612.34,
        limit_um: 500.0,
    };
    assert_eq!(
        e.message(),
        "the correction of 612.3 µm exceeds the limit of 500.0 µm (--max-correction)"
    );
}

#[test]
fn thermal_compensate_error_messages_leave_the_line_to_the_caller() {
    for (e, line) in [
        (
            ThermalCompensateError::Unsafe {
                line: 6,
                reason: "Z and A in one block".into(),
            },
            6,
        ),
        (
            ThermalCompensateError::Diverges {
                line: 11,
                drift_mm: 1e9,
            },
            11,
        ),
    ] {
        located_once(e.to_string(), line, e.message());
    }
    let g: GcodeError = crate::gcode::Block::parse(b"G1 X", 3).unwrap_err();
    let expected = g.message();
    assert_eq!(ThermalCompensateError::Gcode(g).message(), expected);
}
