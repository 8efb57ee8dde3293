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

use super::chain::AxisPositions;
use super::chain::Geometry;
use super::touch::{Contact, ToolPoint, Touch};
use crate::gcode::{Dialect, ProgramEnd, ProgramWriter, WriteError};

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

impl PlannedTouch {
    /// The touch as planned: the axes where the plan holds them (`a = b = 0`),
    /// with the nominal contact position on the probe axis.
    pub fn nominal(&self) -> Touch {
        Touch {
            at: AxisPositions {
                x: self.x,
                y: self.y,
                z: self.z,
                a: 0.0,
                b: 0.0,
                c: self.c,
            },
            point: self.point,
            contact: self.contact,
        }
    }
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
    #[error(
        "x = {} mm puts the tool beside the workpiece (|x| must be below rg = {} mm)",
        crate::limits::fmt_message_number(*.x),
        crate::limits::fmt_message_number(*.rg)
    )]
    XOutside {
        /// x held, mm.
        x: f64,
        /// Workpiece radius rg, mm.
        rg: f64,
    },
    /// The face offset (mm) is not positive or leaves the top face (limit rg + rt, mm).
    #[error(
        "the face offset {} mm must be positive and leave the tool over the top face (below rg + rt = {} mm)",
        crate::limits::fmt_message_number(*.0),
        crate::limits::fmt_message_number(*.1)
    )]
    FaceOffset(f64, f64),
    /// The side depth (mm) is not positive.
    #[error("the side depth {} mm must be positive", crate::limits::fmt_message_number(*.0))]
    SideDepth(f64),
    /// A quantity is not a positive finite number.
    #[error("{name} = {} must be a positive finite number", crate::limits::fmt_message_number(*.value))]
    NotPositive {
        /// The quantity.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A quantity is not finite.
    #[error("{name} = {} is not a finite number", crate::limits::fmt_message_number(*.value))]
    NotFinite {
        /// The quantity.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// Writing the program failed.
    #[error(transparent)]
    Write(#[from] WriteError),
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

    /// The six planned touches in the order of the patent's table (`docs/references.md` [R3]).
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

/// Writes the touch-off program for `plan` in `dialect` (LinuxCNC: `G38.2`
/// probing moves, results `#5061…#5066` written to a CSV log with
/// `(LOGOPEN)`/`(LOG)`; Fanuc: program `O9100`, `G31` skip, Macro B results
/// `#5061…#5063` copied to common variables `#501…` and printed with
/// `DPRNT`, alarm if no contact). Coordinates are machine coordinates of
/// this method (the frame of `M_xt`, `M_xg'`), written by
/// [`ProgramWriter`].
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
    let safe_z = -g.h() + motion.clearance;
    let fanuc = matches!(dialect, Dialect::Fanuc { .. });
    let mut w = ProgramWriter::new(dialect);
    w.start(Some(9100))?;
    w.comment("mtwin skiving touch-off program: workpiece set-up error, see docs/skiving.md")?;
    w.comment(&format!(
        "x={} h={} L={} rt={} rg={} face offset={} side depth={}",
        plan.x,
        g.h(),
        g.l(),
        g.rt(),
        g.rg(),
        plan.face_offset,
        plan.side_depth
    ))?;
    w.comment(&format!(
        "approach={} overtravel={} clearance={} feed={} mm/min",
        motion.approach, motion.overtravel, motion.clearance, motion.feed
    ))?;
    w.block().g(21).g(90).g(94).g(17).write()?;
    if fanuc {
        w.statement("POPEN")?;
    } else {
        use crate::io::columns::{SKIVING_TOUCH_LABELS, SKIVING_TOUCH_POSITION, header};
        w.statement("(LOGOPEN,skiving-touches.csv)")?;
        w.statement(&format!(
            "(LOG,{},{})",
            header(&SKIVING_TOUCH_POSITION),
            header(&SKIVING_TOUCH_LABELS)
        ))?;
    }
    w.rapid(&[('Z', safe_z)])?;
    for (i, t) in touches.iter().enumerate() {
        w.comment(&format!(
            "touch {}: c={} tool {} on the {} face",
            i + 1,
            t.c,
            t.point.name(),
            t.contact.name()
        ))?;
        w.rapid(&[('A', 0.0), ('B', 0.0), ('C', t.c)])?;
        let (letter, start, target) = match t.probe {
            ProbeAxis::MinusZ => {
                w.rapid(&[('X', t.x), ('Y', t.y)])?;
                w.rapid(&[('Z', t.z + motion.approach)])?;
                ('Z', t.z + motion.approach, t.z - motion.overtravel)
            }
            ProbeAxis::MinusY => {
                w.rapid(&[('X', t.x), ('Y', t.y + motion.approach)])?;
                w.rapid(&[('Z', t.z)])?;
                ('Y', t.y + motion.approach, t.y - motion.overtravel)
            }
        };
        w.probe(&[(letter, target)], motion.feed)?;
        if fanuc {
            let var = if letter == 'Z' { "#5063" } else { "#5062" };
            // The no-contact test compares with the target as written.
            w.statement(&format!(
                "IF[ABS[{var}-[{}]] LT 0.0005] THEN #3000=1 (NO CONTACT TOUCH {})",
                w.number(letter, target)?,
                i + 1
            ))?;
            let base = 501 + 3 * i;
            for (k, v) in ["#5061", "#5062", "#5063"].iter().enumerate() {
                w.statement(&format!("#{}={v}", base + k))?;
            }
            w.statement(&format!(
                "DPRNT[#{}[44]*#{}[44]*#{}[44]*0*0*{}*{}*{}]",
                base,
                base + 1,
                base + 2,
                t.c,
                t.point.name().to_uppercase(),
                t.contact.name().to_uppercase()
            ))?;
        } else {
            w.statement(&format!(
                "(LOG,#5061,#5062,#5063,#5064,#5065,#5066,{},{})",
                t.point.name(),
                t.contact.name()
            ))?;
        }
        // Back off along the probe axis, then up to the safe height.
        w.rapid(&[(letter, start)])?;
        w.rapid(&[('Z', safe_z)])?;
    }
    if fanuc {
        w.statement("PCLOS")?;
        w.end(ProgramEnd::M30)?;
    } else {
        w.statement("(LOGCLOSE)")?;
        w.end(ProgramEnd::M2)?;
    }
    Ok(w.finish())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::skiving::chain::SetupError;

    fn geometry() -> Geometry {
        Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap()
    }

    #[test]
    fn planned_contacts_satisfy_the_conditions_at_zero_error() {
        let g = geometry();
        for x in [0.0, 3.5, -12.0] {
            for p in Plan::standard(x, &g).touches(&g).unwrap() {
                let t = p.nominal();
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
        let fanuc = Dialect::Fanuc {
            decimal_point_programming: false,
        };
        // Written to 4 decimals (LinuxCNC) or 3 (Fanuc).
        for (dialect, probe, tol) in [(Dialect::LinuxCnc, "G38.2", 5e-5), (fanuc, "G31", 5e-4)] {
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
                assert!((target - (nominal - m.overtravel)).abs() <= tol, "{line}");
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
