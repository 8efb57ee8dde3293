//! The nominal path of one move in program coordinates (work coordinates plus
//! offsets: machine axis positions for a plain program, the tool tip in W and
//! the rotary positions under TCP), as a function of a parameter `s ∈ [0, 1]`.

use crate::gcode::timing::lerp;
use crate::gcode::{ArcMove, Axes, Axis, Linear};

/// Where a move goes, parameterised from its start (`s = 0`) to its end (`s = 1`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum NominalPath {
    /// A straight line between two points in program coordinates.
    Line { from: Axes, to: Axes },
    /// A circular or helical arc: in-plane angle and radius change linearly
    /// with `s`, every other axis moves linearly.
    Arc {
        from: Axes,
        to: Axes,
        /// Centre, program coordinates (in-plane components used).
        center: [f64; 3],
        /// First and second in-plane axes.
        plane: (Axis, Axis),
        /// Start angle, rad.
        angle0: f64,
        /// Signed sweep, rad.
        sweep: f64,
        /// Start and end radius, mm.
        radius: (f64, f64),
    },
}

impl NominalPath {
    /// The path of a straight move.
    pub(crate) fn line(m: &Linear) -> Self {
        NominalPath::Line {
            from: m.from.add(&m.offset),
            to: m.to.add(&m.offset),
        }
    }

    /// The path of an arc.
    pub(crate) fn arc(m: &ArcMove) -> Self {
        let from = m.from.add(&m.offset);
        let to = m.to.add(&m.offset);
        let (a1, a2, _) = m.plane.axes();
        let off = [m.offset[Axis::X], m.offset[Axis::Y], m.offset[Axis::Z]];
        let center = [
            m.center[0] + off[0],
            m.center[1] + off[1],
            m.center[2] + off[2],
        ];
        let c = |a: Axis| center[a.index()];
        let (u0, v0) = (from[a1] - c(a1), from[a2] - c(a2));
        let (u1, v1) = (to[a1] - c(a1), to[a2] - c(a2));
        NominalPath::Arc {
            from,
            to,
            center,
            plane: (a1, a2),
            angle0: v0.atan2(u0),
            sweep: m.sweep(),
            radius: (u0.hypot(v0), u1.hypot(v1)),
        }
    }

    /// The point at parameter `s`, program coordinates.
    pub(crate) fn at(&self, s: f64) -> Axes {
        match *self {
            NominalPath::Line { from, to } => lerp(&from, &to, s),
            NominalPath::Arc {
                from,
                to,
                center,
                plane: (a1, a2),
                angle0,
                sweep,
                radius: (r0, r1),
            } => {
                let mut p = lerp(&from, &to, s);
                let (sin, cos) = (angle0 + s * sweep).sin_cos();
                let r = r0 + s * (r1 - r0);
                p[a1] = center[a1.index()] + r * cos;
                p[a2] = center[a2.index()] + r * sin;
                p
            }
        }
    }
}
