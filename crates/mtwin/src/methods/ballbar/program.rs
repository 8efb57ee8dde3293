//! The four test programs (G-code) for a static-mode ballbar: the linear
//! axes place the tool ball B1, then the moving rotary axis steps through
//! the angles with a dwell at each step while the instrument takes its
//! reading. Dwell and numbers as the dialect of [`ProgramSpec::dialect`]
//! writes them ([`ProgramWriter`]), rotary feed in deg/min under G94.
//!
//! Every move is written with `G53`: positions are the model's axis
//! positions, which are the controller's machine coordinates, so no work
//! offset (G54 …) and no tool length offset takes part — LinuxCNC's G53
//! suspends both. This is deliberate: with `G54` an operator who had set the
//! work offset to the part (on `ac-trunnion` the workpiece origin is 150 mm
//! below the pivot) would drive the ball into the table. What the program
//! needs is stated in its header: the model's axis zero is the controller's
//! machine zero, and the model's tool tip (`[tool] tip`) is the centre of
//! the tool ball.

use super::mode::{BallbarMode, Rig, Trunnion, TrunnionError};
use crate::gcode::{Dialect, ProgramEnd, ProgramWriter, WriteError};
use crate::model::Machine;

/// What a program is for.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramSpec {
    /// The rig geometry and set-up error (places the tool ball).
    pub rig: Rig,
    /// Angles of the moving axis, degrees, in the order visited; must contain 0.
    pub angles_deg: Vec<f64>,
    /// Dwell at each step, s.
    pub dwell_s: f64,
    /// Rotary feed, deg/min.
    pub feed: f64,
    /// The controller the program is written for.
    pub dialect: Dialect,
}

/// Why a program cannot be written.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ProgramError {
    /// The machine is not a double turntable with A carrying C.
    #[error(transparent)]
    Machine(#[from] TrunnionError),
    /// The machine has no linear axis of this name (`X`, `Y` or `Z`).
    #[error("the machine has no linear axis named {0}")]
    MissingLinear(&'static str),
    /// A position of the program leaves the travel of its axis.
    #[error(
        "{axis} = {} is outside its travel [{}, {}]",
        crate::limits::fmt_message_number(*.value),
        crate::limits::fmt_message_number(*.lo),
        crate::limits::fmt_message_number(*.hi)
    )]
    OutOfTravel {
        /// The axis.
        axis: String,
        /// The position (mm or degrees).
        value: f64,
        /// Lower end of the travel.
        lo: f64,
        /// Upper end of the travel.
        hi: f64,
    },
    /// The angle list does not contain 0°.
    #[error("the angle list must contain 0° (the bar is set there)")]
    NoZero,
    /// The dwell or the feed is not positive.
    #[error(
        "the dwell ({} s) and feed ({} deg/min) must be positive",
        crate::limits::fmt_message_number(*.dwell),
        crate::limits::fmt_message_number(*.feed)
    )]
    BadTiming {
        /// Dwell at each step, s.
        dwell: f64,
        /// Rotary feed, deg/min.
        feed: f64,
    },
    /// Writing the program failed.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// The G-code program of `mode` for `machine`.
pub fn program(
    machine: &Machine,
    mode: BallbarMode,
    spec: &ProgramSpec,
) -> Result<String, ProgramError> {
    let t = Trunnion::of(machine)?;
    if !spec.angles_deg.contains(&0.0) {
        return Err(ProgramError::NoZero);
    }
    if !(spec.dwell_s > 0.0 && spec.feed > 0.0) {
        return Err(ProgramError::BadTiming {
            dwell: spec.dwell_s,
            feed: spec.feed,
        });
    }
    // Nominal B1 (no set-up error: the program commands the spindle axis).
    let nominal = Rig {
        setup: Default::default(),
        ..spec.rig
    };
    let b1 = t.pivot + mode.tool_ball(&nominal);
    let d = b1 - machine.tool_tip;
    let mut lin = Vec::new();
    for (name, l) in [("X", 'X'), ("Y", 'Y'), ("Z", 'Z')] {
        let i = machine
            .axis_index(name)
            .filter(|&i| machine.axes[i].kind == crate::model::AxisKind::Linear)
            .ok_or(ProgramError::MissingLinear(name))?;
        let ax = &machine.axes[i];
        let v = d.dot(&ax.direction);
        check(name, v, ax.travel)?;
        lin.push((l, v));
    }
    let moving = &machine.axes[if mode.moves_a() { t.a } else { t.c }];
    for &a in &spec.angles_deg {
        check(mode.axis_name(), a, moving.travel)?;
    }
    let (axis, other) = if mode.moves_a() {
        ("A", "C")
    } else {
        ("C", "A")
    };
    let letter = if mode.moves_a() { 'A' } else { 'C' };
    let bar = if mode.moves_a() { "-Y" } else { "+X" };
    let mut w = ProgramWriter::new(spec.dialect);
    // Numbers inside comments as the writer writes the words.
    let f = |v: f64| w.plain(v);
    let header = [
        format!(
            "mtwin ballbar test, mode {}: {w_axis} turns, {other} = 0, other axes still",
            mode.number(),
            w_axis = axis
        ),
        format!(
            "bar {} mm along {bar} at {axis} = 0; tool ball B1 at X{} Y{} Z{} of M",
            f(spec.rig.length)?,
            f(b1.x)?,
            f(b1.y)?,
            f(b1.z)?
        ),
        format!(
            "static ballbar: take one reading during each dwell of {} s; {} steps",
            w.plain(spec.dwell_s)?,
            spec.angles_deg.len()
        ),
        "every move is G53, in machine coordinates: work offsets such as G54 and the tool".into(),
        "length offset are ignored. The machine zero must be the model's axis zero, and the".into(),
        "model's tool tip must be the centre of the tool ball; check both before running.".into(),
    ];
    w.start(None)?;
    for line in &header {
        w.comment(line)?;
    }
    w.block().g(21).g(90).g(94).g(17).write()?;
    w.block()
        .g(53)
        .g(0)
        .axes(&[('A', 0.0), ('C', 0.0)])
        .write()?;
    w.block().g(53).g(0).axes(&lin).write()?;
    w.block()
        .m(0)
        .comment(&format!(
            "mount the bar: B2 on the table, {bar} of B1, then start the instrument"
        ))
        .write()?;
    for &a in &spec.angles_deg {
        w.block()
            .g(53)
            .g(1)
            .axes(&[(letter, a)])
            .feed(spec.feed)
            .write()?;
        w.dwell(spec.dwell_s)?;
    }
    w.block()
        .g(53)
        .g(1)
        .axes(&[(letter, 0.0)])
        .feed(spec.feed)
        .write()?;
    w.block().m(0).comment("remove the bar").write()?;
    w.end(ProgramEnd::M30)?;
    Ok(w.finish())
}

fn check(axis: &str, value: f64, travel: [f64; 2]) -> Result<(), ProgramError> {
    if value < travel[0] || value > travel[1] {
        return Err(ProgramError::OutOfTravel {
            axis: axis.to_owned(),
            value,
            lo: travel[0],
            hi: travel[1],
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::ballbar::simulate::angle_range;
    use crate::model::parse_machine;
    use std::path::Path;

    fn machine() -> Machine {
        parse_machine(
            Path::new("ac-trunnion.toml"),
            include_str!("../../../../../examples/machines/ac-trunnion.toml"),
        )
        .unwrap()
    }

    #[test]
    fn mode_two_places_the_ball_and_dwells_at_every_step() {
        let spec = ProgramSpec {
            rig: Rig::source_paper(),
            angles_deg: angle_range(-90.0, 90.0, 5.0),
            dwell_s: 2.0,
            feed: 720.0,
            dialect: Dialect::LinuxCnc,
        };
        let p = program(&machine(), BallbarMode::Two, &spec).unwrap();
        // B1 at ZB1C = 100 along x from the C line: X100 Y0 Z0.
        assert!(p.contains("G0 X100 Y0 Z0"), "{p}");
        assert_eq!(p.matches("G4 P2").count(), 37);
        let angles: Vec<f64> = p
            .lines()
            .filter_map(|l| l.strip_prefix("G53 G1 A"))
            .map(|l| l.split(' ').next().unwrap().parse().unwrap())
            .collect();
        let mut expect = angle_range(-90.0, 90.0, 5.0);
        expect.push(0.0);
        assert_eq!(angles, expect);
        assert!(p.trim_end().ends_with("M30\n%") || p.trim_end().ends_with('%'));
    }

    /// Every move is in machine coordinates (G53), so neither G54 nor a tool
    /// length offset can move the ball: interpreted with a G54 offset of
    /// -150 mm in Z and a tool length of 50 mm, the ball still goes to the
    /// model's axis positions, and no work-offset code is in the program.
    #[test]
    fn moves_are_in_machine_coordinates_whatever_the_offsets() {
        use crate::gcode::{Axis, EventKind, InterpOptions, Interpreter, Program};
        let spec = ProgramSpec {
            rig: Rig::source_paper(),
            angles_deg: angle_range(0.0, 90.0, 45.0),
            dwell_s: 1.0,
            feed: 720.0,
            dialect: Dialect::LinuxCnc,
        };
        let p = program(&machine(), BallbarMode::Four, &spec).unwrap();
        assert!(
            !p.lines().any(|l| !l.starts_with('(') && l.contains("G54")),
            "{p}"
        );
        assert!(p.contains("G53 G0 X0 Y0 Z100"), "{p}");
        assert!(
            p.contains("machine zero must be the model's axis zero"),
            "{p}"
        );
        let mut opts = InterpOptions::default();
        opts.work_offsets[0][Axis::Z] = -150.0;
        opts.tools.insert(crate::gcode::Tool::with_length(1, 50.0));
        let program =
            Program::parse(p.replace("G21 G90", "T1 M6 G43 H1 G21 G90").as_bytes()).unwrap();
        let mut it = Interpreter::new(opts);
        let mut ev = Vec::new();
        for b in &program.blocks {
            it.execute(b, &mut ev).unwrap();
        }
        let ball = ev
            .iter()
            .find_map(|e| match &e.kind {
                EventKind::Traverse(m) if m.to[Axis::Z] + m.offset[Axis::Z] != 0.0 => {
                    Some([Axis::X, Axis::Y, Axis::Z].map(|a| m.to[a] + m.offset[a]))
                }
                _ => None,
            })
            .expect("the move to the ball position");
        let ball = (ball[0], ball[1], ball[2]);
        assert_eq!(ball, (0.0, 0.0, 100.0));
    }

    #[test]
    fn mode_four_raises_the_ball_and_rejects_out_of_travel() {
        let mut spec = ProgramSpec {
            rig: Rig::source_paper(),
            angles_deg: angle_range(0.0, 360.0, 5.0),
            dwell_s: 1.0,
            feed: 720.0,
            dialect: Dialect::LinuxCnc,
        };
        let p = program(&machine(), BallbarMode::Four, &spec).unwrap();
        assert!(p.contains("G0 X0 Y0 Z100"), "{p}");
        assert_eq!(p.matches("G1 C").count(), 74);
        spec.angles_deg = angle_range(0.0, 400.0, 5.0);
        assert!(matches!(
            program(&machine(), BallbarMode::Four, &spec),
            Err(ProgramError::OutOfTravel { .. })
        ));
    }
}
