//! The touch-off plan of \[R3\] (docs/references.md) and the G-code program
//! that carries it out with probing moves.
//!
//! The six touches, all at `X = x`, `a = b = 0`:
//!
//! | # | c | point | contact | held | probed along |
//! |---|---|---|---|---|---|
//! | 1 | 0° | face | top | `y = +f` | −Z, nominal `z = −h` |
//! | 2 | 0° | face | top | `y = −f` | −Z |
//! | 3 | 0° | tip | side | `z = −h − d` | −Y, nominal `y = rt + √(rg² − x²)` |
//! | 4 | 90° | face | top | `y = +f` | −Z |
//! | 5 | 90° | face | top | `y = −f` | −Z |
//! | 6 | 90° | tip | side | `z = −h − d` | −Y |
//!
//! (`f` the face offset, `d` the side depth below the top face.) The
//! nominal positions follow from the chain at zero set-up error.

use std::fmt::Write as _;

use super::chain::Geometry;
use super::touch::{Contact, ToolPoint};

/// The machine axis a touch is probed along (always towards the
/// workpiece, i.e. in the negative direction).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProbeAxis {
    /// Down along −Z onto the top face.
    MinusZ,
    /// Along −Y onto the side (the tool is on the +Y side).
    MinusY,
}

/// One planned touch: the axis positions held, and the nominal contact
/// position along the probe axis (mm, degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedTouch {
    /// `x` held, mm.
    pub x: f64,
    /// `y` held (top) or nominal contact `y` (side), mm.
    pub y: f64,
    /// Nominal contact `z` (top) or `z` held (side), mm.
    pub z: f64,
    /// Rotary table angle, degrees (`a = b = 0`).
    pub c: f64,
    /// The point of the tool that touches.
    pub point: ToolPoint,
    /// The workpiece surface touched.
    pub contact: Contact,
    /// The axis and direction of the probing move.
    pub probe: ProbeAxis,
}

/// Where the six touches are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plan {
    /// X position held during all touches, mm (`|x| < rg`).
    pub x: f64,
    /// `|y|` of the face touches, mm (`0 < f`, and the tool must overlap
    /// the top face: `f < rg + rt`). The tilt lever is `2f`.
    pub face_offset: f64,
    /// Depth of the side touches below the top face, mm (`> 0`).
    pub side_depth: f64,
}

/// Why a plan or program cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// The x held puts the tool beside the workpiece.
    #[error("x = {x} mm puts the tool beside the workpiece (|x| must be below rg = {rg} mm)")]
    XOutside {
        /// x held, mm.
        x: f64,
        /// Workpiece radius rg, mm.
        rg: f64,
    },
    /// The face offset (mm) is not positive or leaves the top face (limit rg + rt, mm).
    #[error(
        "the face offset {0} mm must be positive and leave the tool over the top face (below rg + rt = {1} mm)"
    )]
    FaceOffset(f64, f64),
    /// The side depth (mm) is not positive.
    #[error("the side depth {0} mm must be positive")]
    SideDepth(f64),
    /// A quantity is not a positive finite number.
    #[error("{name} = {value} must be a positive finite number")]
    NotPositive {
        /// The quantity.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A quantity is not finite.
    #[error("{name} = {value} is not a finite number")]
    NotFinite {
        /// The quantity.
        name: &'static str,
        /// Its value.
        value: f64,
    },
}

impl Plan {
    /// The plan of the patent \[R3\] at `x`: face touches at `y = ±rg/2`, side touches 10 mm
    /// below the top face.
    pub fn standard(x: f64, g: &Geometry) -> Self {
        Self {
            x,
            face_offset: g.rg() / 2.0,
            side_depth: 10.0,
        }
    }

    /// The six planned touches in the order of the spec's table.
    pub fn touches(&self, g: &Geometry) -> Result<Vec<PlannedTouch>, PlanError> {
        for (name, value) in [
            ("x", self.x),
            ("face offset", self.face_offset),
            ("side depth", self.side_depth),
        ] {
            if !value.is_finite() {
                return Err(PlanError::NotFinite { name, value });
            }
        }
        if self.x.abs() >= g.rg() {
            return Err(PlanError::XOutside {
                x: self.x,
                rg: g.rg(),
            });
        }
        if !(self.face_offset > 0.0 && self.face_offset < g.rg() + g.rt()) {
            return Err(PlanError::FaceOffset(self.face_offset, g.rg() + g.rt()));
        }
        if self.side_depth <= 0.0 {
            return Err(PlanError::SideDepth(self.side_depth));
        }
        let top = |c: f64, y: f64| PlannedTouch {
            x: self.x,
            y,
            z: -g.h(),
            c,
            point: ToolPoint::Face,
            contact: Contact::Top,
            probe: ProbeAxis::MinusZ,
        };
        // Tip at machine (0, y − rt, z); the workpiece axis at X = x:
        // radial distance √(x² + (y − rt)²) = rg at c = 0 and at c = 90°.
        let side = |c: f64| PlannedTouch {
            x: self.x,
            y: g.rt() + (g.rg() * g.rg() - self.x * self.x).sqrt(),
            z: -g.h() - self.side_depth,
            c,
            point: ToolPoint::Tip,
            contact: Contact::Side,
            probe: ProbeAxis::MinusY,
        };
        let f = self.face_offset;
        Ok(vec![
            top(0.0, f),
            top(0.0, -f),
            side(0.0),
            top(90.0, f),
            top(90.0, -f),
            side(90.0),
        ])
    }
}

/// The controller dialect of the probing moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dialect {
    /// LinuxCNC: `G38.2` (error if no contact), results `#5061…#5066`
    /// written to a CSV log with `(LOGOPEN)`/`(LOG)`.
    LinuxCnc,
    /// Fanuc Macro B: `G31` skip, results `#5061…#5063` copied to common
    /// variables `#501…` and printed with `DPRNT`; alarm if no contact.
    Fanuc,
}

/// Motion settings of the program (mm, mm/min).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Distance from the nominal contact where the probing move starts.
    pub approach: f64,
    /// Distance beyond the nominal contact where it ends if nothing is hit.
    pub overtravel: f64,
    /// Safe height above the top face for moves between touches.
    pub clearance: f64,
    /// Probing feed.
    pub feed: f64,
}

impl Default for Motion {
    fn default() -> Self {
        Self {
            approach: 2.0,
            overtravel: 1.0,
            clearance: 20.0,
            feed: 20.0,
        }
    }
}

/// Writes the touch-off program for `plan` in `dialect`. Coordinates are
/// machine coordinates of this method (the frame of `M_xt`, `M_xg'`).
pub fn program(
    plan: &Plan,
    g: &Geometry,
    motion: &Motion,
    dialect: Dialect,
) -> Result<String, PlanError> {
    for (name, value) in [
        ("approach", motion.approach),
        ("overtravel", motion.overtravel),
        ("clearance", motion.clearance),
        ("feed", motion.feed),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(PlanError::NotPositive { name, value });
        }
    }
    let touches = plan.touches(g)?;
    let n = |v: f64| format!("{v:.4}");
    let safe_z = -g.h() + motion.clearance;
    let mut s = String::new();
    let comment = |s: &mut String, text: &str| {
        let text = match dialect {
            Dialect::LinuxCnc => text.to_owned(),
            // Fanuc comments: upper case, no parentheses inside.
            Dialect::Fanuc => text.to_uppercase().replace(['(', ')'], ""),
        };
        let _ = writeln!(s, "({text})");
    };
    s.push_str("%\n");
    if dialect == Dialect::Fanuc {
        s.push_str("O9100\n");
    }
    comment(
        &mut s,
        "mtwin skiving touch-off program: workpiece set-up error, see docs/skiving.md",
    );
    comment(
        &mut s,
        &format!(
            "x={} h={} L={} rt={} rg={} face offset={} side depth={}",
            plan.x,
            g.h(),
            g.l(),
            g.rt(),
            g.rg(),
            plan.face_offset,
            plan.side_depth
        ),
    );
    comment(
        &mut s,
        &format!(
            "approach={} overtravel={} clearance={} feed={} mm/min",
            motion.approach, motion.overtravel, motion.clearance, motion.feed
        ),
    );
    s.push_str("G21 G90 G94 G17\n");
    match dialect {
        Dialect::LinuxCnc => {
            s.push_str("(LOGOPEN,skiving-touches.csv)\n(LOG,x,y,z,a,b,c,point,contact)\n")
        }
        Dialect::Fanuc => s.push_str("POPEN\n"),
    }
    let _ = writeln!(s, "G0 Z{}", n(safe_z));
    for (i, t) in touches.iter().enumerate() {
        comment(
            &mut s,
            &format!(
                "touch {}: c={} tool {} on the {} face",
                i + 1,
                t.c,
                t.point.name(),
                t.contact.name()
            ),
        );
        let _ = writeln!(s, "G0 A0 B0 C{}", n(t.c));
        let (letter, start, target) = match t.probe {
            ProbeAxis::MinusZ => {
                let _ = writeln!(s, "G0 X{} Y{}", n(t.x), n(t.y));
                let _ = writeln!(s, "G0 Z{}", n(t.z + motion.approach));
                ("Z", t.z + motion.approach, t.z - motion.overtravel)
            }
            ProbeAxis::MinusY => {
                let _ = writeln!(s, "G0 X{} Y{}", n(t.x), n(t.y + motion.approach));
                let _ = writeln!(s, "G0 Z{}", n(t.z));
                ("Y", t.y + motion.approach, t.y - motion.overtravel)
            }
        };
        let var = if letter == "Z" { "#5063" } else { "#5062" };
        match dialect {
            Dialect::LinuxCnc => {
                let _ = writeln!(s, "G38.2 {letter}{} F{}", n(target), n(motion.feed));
                let _ = writeln!(
                    s,
                    "(LOG,#5061,#5062,#5063,#5064,#5065,#5066,{},{})",
                    t.point.name(),
                    t.contact.name()
                );
            }
            Dialect::Fanuc => {
                let _ = writeln!(s, "G31 {letter}{} F{}", n(target), n(motion.feed));
                let _ = writeln!(
                    s,
                    "IF[ABS[{var}-[{}]] LT 0.0005] THEN #3000=1 (NO CONTACT TOUCH {})",
                    n(target),
                    i + 1
                );
                let base = 501 + 3 * i;
                let _ = writeln!(
                    s,
                    "#{}=#5061\n#{}=#5062\n#{}=#5063",
                    base,
                    base + 1,
                    base + 2
                );
                let _ = writeln!(
                    s,
                    "DPRNT[#{}[44]*#{}[44]*#{}[44]*0*0*{}*{}*{}]",
                    base,
                    base + 1,
                    base + 2,
                    t.c,
                    t.point.name().to_uppercase(),
                    t.contact.name().to_uppercase()
                );
            }
        }
        // Back off along the probe axis, then up to the safe height.
        let _ = writeln!(s, "G0 {letter}{}", n(start));
        let _ = writeln!(s, "G0 Z{}", n(safe_z));
    }
    match dialect {
        Dialect::LinuxCnc => s.push_str("(LOGCLOSE)\nM2\n"),
        Dialect::Fanuc => s.push_str("PCLOS\nM30\n"),
    }
    s.push_str("%\n");
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::skiving::chain::{AxisPositions, SetupError};
    use crate::methods::skiving::touch::Touch;

    fn geometry() -> Geometry {
        Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap()
    }

    #[test]
    fn planned_contacts_satisfy_the_conditions_at_zero_error() {
        let g = geometry();
        for x in [0.0, 3.5, -12.0] {
            for p in Plan::standard(x, &g).touches(&g).unwrap() {
                let t = Touch {
                    at: AxisPositions {
                        x: p.x,
                        y: p.y,
                        z: p.z,
                        a: 0.0,
                        b: 0.0,
                        c: p.c,
                    },
                    point: p.point,
                    contact: p.contact,
                };
                assert!(t.residual(&g, &SetupError::default()).abs() < 1e-12);
            }
        }
    }

    /// The straight-line moves of a program, as (letter, value) pairs per line.
    fn words(line: &str) -> Vec<(char, f64)> {
        line.split_whitespace()
            .filter_map(|w| {
                let mut c = w.chars();
                let l = c.next()?;
                c.as_str().parse().ok().map(|v| (l, v))
            })
            .collect()
    }

    #[test]
    fn probing_moves_cross_the_nominal_contact() {
        let g = geometry();
        let plan = Plan::standard(0.0, &g);
        let m = Motion::default();
        let planned = plan.touches(&g).unwrap();
        for (dialect, probe) in [(Dialect::LinuxCnc, "G38.2"), (Dialect::Fanuc, "G31")] {
            let text = program(&plan, &g, &m, dialect).unwrap();
            let probes: Vec<&str> = text.lines().filter(|l| l.starts_with(probe)).collect();
            assert_eq!(probes.len(), 6);
            for (line, p) in probes.iter().zip(&planned) {
                let w = words(line);
                let (letter, nominal) = match p.probe {
                    ProbeAxis::MinusZ => ('Z', p.z),
                    ProbeAxis::MinusY => ('Y', p.y),
                };
                let target = w.iter().find(|(l, _)| *l == letter).unwrap().1;
                assert!((target - (nominal - m.overtravel)).abs() < 1e-4, "{line}");
                assert_eq!(w.iter().find(|(l, _)| *l == 'F').unwrap().1, m.feed);
            }
        }
    }

    #[test]
    fn bad_plans_are_refused() {
        let g = geometry();
        let mut p = Plan::standard(70.0, &g);
        assert!(matches!(p.touches(&g), Err(PlanError::XOutside { .. })));
        p.x = 0.0;
        p.face_offset = 0.0;
        assert!(matches!(p.touches(&g), Err(PlanError::FaceOffset(..))));
        let m = Motion {
            feed: 0.0,
            ..Motion::default()
        };
        let p = Plan::standard(0.0, &g);
        assert!(program(&p, &g, &m, Dialect::LinuxCnc).is_err());
    }
}
