//! Machine travel checks of a program's moves, as a [`MotionObserver`] for
//! [`stats_with`](super::stats_with).

use nalgebra::Vector3;

use super::arc;
use super::axes::{Axes, Axis};
use super::error::GcodeError;
use super::event::{Event, EventKind};
use super::stats::MotionObserver;
use super::syntax::Block;
use crate::kinematics::{IkOptions, IkTarget, Kinematics};
use crate::model::{AxisKind, Machine};

/// One axis position outside its travel.
#[derive(Debug, Clone, PartialEq)]
pub struct TravelViolation {
    /// Source line (1-based).
    pub line: u64,
    /// Machine axis name.
    pub axis: String,
    /// The position, mm or degree.
    pub value: f64,
    /// The travel `[lo, hi]`.
    pub travel: [f64; 2],
}

/// Checks the move end points (and the extreme points of arcs) against the
/// machine travels. Without TCP a machine axis is the G-code axis of the
/// same name plus the event offset. Under TCP (in the event, or
/// [`TravelCheck::force_tcp`]) the rotary axes are so too and the linear
/// axes come from the nominal inverse kinematics at the move ends (tip =
/// X Y Z + offset in W); points between the ends are not checked then (the
/// interpolator checks every sample).
pub struct TravelCheck<'m> {
    machine: &'m Machine,
    letters: Vec<Option<Axis>>,
    linear: Vec<bool>,
    kin: Kinematics,
    q: Vec<f64>,
    /// Treat every move as a TCP move.
    pub force_tcp: bool,
    /// Violations found, at most [`TravelCheck::KEEP`] of them.
    pub violations: Vec<TravelViolation>,
    /// Number of violations found (including those not kept).
    pub count: u64,
    /// TCP end points where inverse kinematics failed (line numbers, first
    /// [`TravelCheck::KEEP`]).
    pub unreachable: Vec<u64>,
}

impl<'m> TravelCheck<'m> {
    /// Most violations kept in [`TravelCheck::violations`].
    pub const KEEP: usize = 1000;

    /// A check against `machine` (axes whose names are not G-code letters are
    /// not checked).
    pub fn new(machine: &'m Machine) -> Self {
        TravelCheck {
            machine,
            letters: machine
                .axes
                .iter()
                .map(|a| Axis::from_name(&a.name))
                .collect(),
            linear: machine
                .axes
                .iter()
                .map(|a| a.kind == AxisKind::Linear)
                .collect(),
            kin: Kinematics::nominal(machine),
            q: vec![0.0; machine.n_axes()],
            force_tcp: false,
            violations: Vec::new(),
            count: 0,
            unreachable: Vec::new(),
        }
    }

    fn check(&mut self, line: u64, work: &Axes, offset: &Axes, tcp: bool) {
        for (i, l) in self.letters.iter().enumerate() {
            if let Some(l) = l {
                self.q[i] = work[*l] + offset[*l];
            }
        }
        if tcp {
            let tip = Vector3::new(
                work[Axis::X] + offset[Axis::X],
                work[Axis::Y] + offset[Axis::Y],
                work[Axis::Z] + offset[Axis::Z],
            );
            let opts = IkOptions {
                check_travel: false,
                ..IkOptions::default()
            };
            match self
                .kin
                .inverse(&IkTarget { tip, axis: None }, &self.q, &self.linear, &opts)
            {
                Ok(q) => self.q = q,
                Err(_) => {
                    if self.unreachable.len() < Self::KEEP {
                        self.unreachable.push(line);
                    }
                    return;
                }
            }
        }
        for (axis, &value) in self.machine.axes.iter().zip(&self.q) {
            if !axis.in_travel(value) {
                self.count += 1;
                if self.violations.len() < Self::KEEP {
                    self.violations.push(TravelViolation {
                        line,
                        axis: axis.name.clone(),
                        value,
                        travel: axis.travel,
                    });
                }
            }
        }
    }
}

impl MotionObserver for TravelCheck<'_> {
    fn observe(&mut self, _: &Block, event: &Event) -> Result<(), GcodeError> {
        let line = event.at.line;
        match &event.kind {
            EventKind::Traverse(m) | EventKind::Feed(m) => {
                let tcp = m.tcp || self.force_tcp;
                self.check(line, &m.to, &m.offset, tcp);
            }
            EventKind::Arc(a) => {
                let tcp = a.tcp || self.force_tcp;
                let (p, q, _) = a.plane.axes();
                for pt in arc::plane_points(a) {
                    let mut x = a.from;
                    x[p] = pt[0];
                    x[q] = pt[1];
                    self.check(line, &x, &a.offset, tcp);
                }
                self.check(line, &a.to, &a.offset, tcp);
            }
            _ => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::{StatsOptions, stats_with};
    use crate::model::Axis as MAxis;

    #[test]
    fn arc_extremes_out_of_travel_are_found() {
        let x = MAxis::new(
            "X",
            AxisKind::Linear,
            [1.0, 0.0, 0.0],
            [0.0; 3],
            [-5.0, 100.0],
        );
        let y = MAxis::new(
            "Y",
            AxisKind::Linear,
            [0.0, 1.0, 0.0],
            [0.0; 3],
            [-100.0, 100.0],
        );
        let m = Machine {
            name: "xy".into(),
            axes: vec![x, y],
            tool_chain: vec![0, 1],
            workpiece_chain: vec![],
            tool_tip: Vector3::zeros(),
            tool_direction: Vector3::z(),
            workpiece_origin: Vector3::zeros(),
            rapid_feed: 1000.0,
        };
        // A half circle about the origin from (0, 10) to (0, -10) through
        // -X reaches X = -10 at its extreme, though both ends have X = 0.
        let prog = "G0 X0 Y10\nG3 X0 Y-10 I0 J-10 F100\n";
        let mut check = TravelCheck::new(&m);
        stats_with(prog.as_bytes(), &StatsOptions::default(), &mut check).unwrap();
        assert_eq!(check.count, 1);
        let v = &check.violations[0];
        assert_eq!((v.line, v.axis.as_str()), (2, "X"));
        assert!((v.value + 10.0).abs() < 1e-12);
    }
}
