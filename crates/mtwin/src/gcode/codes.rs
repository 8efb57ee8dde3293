//! G-codes as a type: every code LinuxCNC 2.9 knows (plus Fanuc's G31 skip
//! and the G43.4 tool centre point code of the corpus' remaps), its modal
//! group, and whether this interpreter runs it.

use std::fmt;

use super::dialect::Dialect;

macro_rules! gcodes {
    ($($(#[$doc:meta])* $name:ident = $tenths:literal),* $(,)?) => {
        /// A G-code, named after how it is written with the dot as an
        /// underscore (`G90_1` is `G90.1`); [`fmt::Display`] writes `G90.1`.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[allow(non_camel_case_types)]
        #[non_exhaustive]
        pub enum GCode {
            $($(#[$doc])* $name),*
        }

        impl GCode {
            /// Every known code, in numeric order.
            pub const ALL: &'static [GCode] = &[$(GCode::$name),*];

            /// The number times ten (`G43.4` → 434).
            pub fn tenths(self) -> u16 {
                match self {
                    $(GCode::$name => $tenths),*
                }
            }

            /// The code with this number times ten, if it is known.
            pub fn from_tenths(tenths: u16) -> Option<GCode> {
                match tenths {
                    $($tenths => Some(GCode::$name),)*
                    _ => None,
                }
            }
        }
    };
}

gcodes! {
    /// Rapid traverse.
    G0 = 0,
    /// Straight feed.
    G1 = 10,
    /// Clockwise arc.
    G2 = 20,
    /// Counter-clockwise arc.
    G3 = 30,
    /// Dwell.
    G4 = 40,
    /// Cubic spline.
    G5 = 50,
    /// Quadratic spline.
    G5_1 = 51,
    /// NURBS block start.
    G5_2 = 52,
    /// NURBS block end.
    G5_3 = 53,
    /// Lathe diameter mode.
    G7 = 70,
    /// Lathe radius mode.
    G8 = 80,
    /// Set offsets and tool table entries (with L).
    G10 = 100,
    /// XY plane.
    G17 = 170,
    /// UV plane.
    G17_1 = 171,
    /// ZX plane.
    G18 = 180,
    /// WU plane.
    G18_1 = 181,
    /// YZ plane.
    G19 = 190,
    /// VW plane.
    G19_1 = 191,
    /// Inch.
    G20 = 200,
    /// Millimetre.
    G21 = 210,
    /// Return to the G28 home position.
    G28 = 280,
    /// Store the G28 home position.
    G28_1 = 281,
    /// Return to the G30 home position.
    G30 = 300,
    /// Store the G30 home position.
    G30_1 = 301,
    /// Fanuc skip function (a probing move).
    G31 = 310,
    /// Spindle-synchronised motion.
    G33 = 330,
    /// Rigid tapping.
    G33_1 = 331,
    /// Probe toward the workpiece, error if no contact.
    G38_2 = 382,
    /// Probe toward the workpiece.
    G38_3 = 383,
    /// Probe away from the workpiece, error if no loss of contact.
    G38_4 = 384,
    /// Probe away from the workpiece.
    G38_5 = 385,
    /// Cutter radius compensation off.
    G40 = 400,
    /// Cutter radius compensation left.
    G41 = 410,
    /// Dynamic cutter radius compensation left.
    G41_1 = 411,
    /// Cutter radius compensation right.
    G42 = 420,
    /// Dynamic cutter radius compensation right.
    G42_1 = 421,
    /// Tool length offset from the tool table.
    G43 = 430,
    /// Dynamic tool length offset.
    G43_1 = 431,
    /// Additional tool length offset.
    G43_2 = 432,
    /// Tool centre point control (five-axis).
    G43_4 = 434,
    /// Cancel tool length offset.
    G49 = 490,
    /// Local coordinate system offset.
    G52 = 520,
    /// Move in machine coordinates.
    G53 = 530,
    /// Coordinate system 1.
    G54 = 540,
    /// Coordinate system 2.
    G55 = 550,
    /// Coordinate system 3.
    G56 = 560,
    /// Coordinate system 4.
    G57 = 570,
    /// Coordinate system 5.
    G58 = 580,
    /// Coordinate system 6.
    G59 = 590,
    /// Coordinate system 7.
    G59_1 = 591,
    /// Coordinate system 8.
    G59_2 = 592,
    /// Coordinate system 9.
    G59_3 = 593,
    /// Exact path mode.
    G61 = 610,
    /// Exact stop mode.
    G61_1 = 611,
    /// Path blending.
    G64 = 640,
    /// Lathe finishing cycle.
    G70 = 700,
    /// Lathe roughing cycle.
    G71 = 710,
    /// Lathe roughing cycle, variant 1.
    G71_1 = 711,
    /// Lathe roughing cycle, variant 2.
    G71_2 = 712,
    /// Lathe facing cycle.
    G72 = 720,
    /// Lathe facing cycle, variant 1.
    G72_1 = 721,
    /// Lathe facing cycle, variant 2.
    G72_2 = 722,
    /// Drilling cycle with chip breaking.
    G73 = 730,
    /// Left-hand tapping cycle.
    G74 = 740,
    /// Threading cycle.
    G76 = 760,
    /// Cancel canned cycle.
    G80 = 800,
    /// Drilling cycle.
    G81 = 810,
    /// Drilling cycle with dwell.
    G82 = 820,
    /// Peck drilling cycle.
    G83 = 830,
    /// Right-hand tapping cycle.
    G84 = 840,
    /// Boring cycle, feed out.
    G85 = 850,
    /// Boring cycle, spindle stop, rapid out.
    G86 = 860,
    /// Back boring cycle.
    G87 = 870,
    /// Boring cycle, spindle stop, manual out.
    G88 = 880,
    /// Boring cycle, dwell, feed out.
    G89 = 890,
    /// Absolute distance mode.
    G90 = 900,
    /// Absolute arc centres.
    G90_1 = 901,
    /// Incremental distance mode.
    G91 = 910,
    /// Incremental arc centres.
    G91_1 = 911,
    /// Set the axis offsets so the current point has the given coordinates.
    G92 = 920,
    /// Reset the axis offsets to zero and zero parameters 5211–5219.
    G92_1 = 921,
    /// Reset the axis offsets to zero, keeping the parameters.
    G92_2 = 922,
    /// Restore the axis offsets from parameters 5211–5219.
    G92_3 = 923,
    /// Inverse time feed mode.
    G93 = 930,
    /// Units per minute feed mode.
    G94 = 940,
    /// Units per revolution feed mode.
    G95 = 950,
    /// Constant surface speed.
    G96 = 960,
    /// Spindle speed in rev/min.
    G97 = 970,
    /// Canned cycle retract to the initial level.
    G98 = 980,
    /// Canned cycle retract to the R level.
    G99 = 990,
}

/// Modal groups (LinuxCNC's numbering in the comments).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ModalGroup {
    /// 0: non-modal codes (G4, G10, G28, G30, G52, G53, G92).
    NonModal,
    /// 1: motion.
    Motion,
    /// 2: plane.
    Plane,
    /// 3: distance mode.
    Distance,
    /// 4: arc centre distance mode.
    ArcDistance,
    /// 5: feed rate mode.
    FeedMode,
    /// 6: units.
    Units,
    /// 7: cutter radius compensation.
    CutterComp,
    /// 8: tool length offset.
    ToolLength,
    /// 10: canned cycle return mode.
    Retract,
    /// 12: coordinate system.
    CoordSystem,
    /// 13: path control.
    PathControl,
    /// 14: spindle speed mode.
    SpindleMode,
    /// 15: lathe diameter mode.
    LatheDiameter,
    /// 16: whether the G92 offsets apply (G92.1, G92.2, G92.3).
    G92Applied,
    /// Fanuc: G80 alone in its group (canned cycle cancel).
    CycleCancel,
}

impl GCode {
    /// The code of a G word's value, if it is a known code (`90.1` →
    /// [`GCode::G90_1`]). Values are rounded to tenths as LinuxCNC's
    /// `read_g` does (within 0.001 of a tenth).
    pub fn from_value(value: f64) -> Option<GCode> {
        let tenths = value * 10.0;
        let rounded = tenths.round();
        if (tenths - rounded).abs() > 1e-3 || !(0.0..=9999.0).contains(&rounded) {
            return None;
        }
        GCode::from_tenths(rounded as u16)
    }

    /// The modal group the code belongs to in `dialect` (LinuxCNC's
    /// `_gees` table; in the Fanuc dialect G80 has its own group).
    pub fn group(self, dialect: Dialect) -> ModalGroup {
        use GCode::*;
        match self {
            G80 if dialect != Dialect::LinuxCnc => ModalGroup::CycleCancel,
            G4 | G10 | G28 | G28_1 | G30 | G30_1 | G52 | G53 | G92 | G5_3 => ModalGroup::NonModal,
            G0 | G1 | G2 | G3 | G5 | G5_1 | G5_2 | G31 | G33 | G33_1 | G38_2 | G38_3 | G38_4
            | G38_5 | G70 | G71 | G71_1 | G71_2 | G72 | G72_1 | G72_2 | G73 | G74 | G76 | G80
            | G81 | G82 | G83 | G84 | G85 | G86 | G87 | G88 | G89 => ModalGroup::Motion,
            G17 | G17_1 | G18 | G18_1 | G19 | G19_1 => ModalGroup::Plane,
            G90 | G91 => ModalGroup::Distance,
            G90_1 | G91_1 => ModalGroup::ArcDistance,
            G93 | G94 | G95 => ModalGroup::FeedMode,
            G20 | G21 => ModalGroup::Units,
            G40 | G41 | G41_1 | G42 | G42_1 => ModalGroup::CutterComp,
            G43 | G43_1 | G43_2 | G43_4 | G49 => ModalGroup::ToolLength,
            G98 | G99 => ModalGroup::Retract,
            G54 | G55 | G56 | G57 | G58 | G59 | G59_1 | G59_2 | G59_3 => ModalGroup::CoordSystem,
            G61 | G61_1 | G64 => ModalGroup::PathControl,
            G96 | G97 => ModalGroup::SpindleMode,
            G7 | G8 => ModalGroup::LatheDiameter,
            G92_1 | G92_2 | G92_3 => ModalGroup::G92Applied,
        }
    }

    /// Why this interpreter does not run the code, or `None` if it does.
    pub fn unsupported(self) -> Option<&'static str> {
        use GCode::*;
        Some(match self {
            G70 | G71 | G71_1 | G71_2 | G72 | G72_1 | G72_2 => "lathe cycle",
            G5 | G5_1 | G5_2 | G5_3 => "spline / NURBS motion",
            G96 => "constant surface speed",
            G17_1 | G18_1 | G19_1 => "UVW plane selection",
            _ => return None,
        })
    }

    /// Whether the code is a probing move (G38.2–G38.5, Fanuc G31): read as
    /// a straight feed to its end point, the path and time if nothing is
    /// touched.
    pub fn is_probe(self) -> bool {
        matches!(
            self,
            GCode::G31 | GCode::G38_2 | GCode::G38_3 | GCode::G38_4 | GCode::G38_5
        )
    }

    /// Whether the code is a canned cycle (G73, G74, G81 ... G89).
    pub fn is_cycle(self) -> bool {
        use GCode::*;
        matches!(
            self,
            G73 | G74 | G81 | G82 | G83 | G84 | G85 | G86 | G87 | G88 | G89
        )
    }

    /// Whether the non-modal code reads the axis words (G10, G28, G30,
    /// G52, G92), so that no motion code may share its line.
    pub fn covets_axes(self) -> bool {
        matches!(
            self,
            GCode::G10 | GCode::G28 | GCode::G30 | GCode::G52 | GCode::G92
        )
    }
}

impl fmt::Display for GCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = self.tenths();
        if t.is_multiple_of(10) {
            write!(f, "G{}", t / 10)
        } else {
            write!(f, "G{}.{}", t / 10, t % 10)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_through_their_numbers() {
        for &g in GCode::ALL {
            assert_eq!(GCode::from_tenths(g.tenths()), Some(g));
            // The variant name is the written code with '.' as '_'.
            assert_eq!(format!("{g:?}").replace('_', "."), g.to_string());
            let value: f64 = g.to_string()[1..].parse().unwrap();
            assert_eq!(GCode::from_value(value), Some(g));
        }
        assert_eq!(GCode::G90_1.to_string(), "G90.1");
        assert_eq!(GCode::from_value(90.1), Some(GCode::G90_1));
        assert_eq!(GCode::from_value(12.0), None);
        assert_eq!(GCode::from_value(1.05), None);
        assert_eq!(GCode::from_value(-1.0), None);
    }

    #[test]
    fn groups_follow_linuxcnc() {
        let lc = Dialect::LinuxCnc;
        assert_eq!(GCode::G80.group(lc), ModalGroup::Motion);
        let fanuc = Dialect::Fanuc {
            decimal_point_programming: true,
        };
        assert_eq!(GCode::G80.group(fanuc), ModalGroup::CycleCancel);
        assert_eq!(GCode::G92_1.group(lc), ModalGroup::G92Applied);
        assert_eq!(GCode::G53.group(lc), ModalGroup::NonModal);
        assert_eq!(GCode::G43_4.group(lc), ModalGroup::ToolLength);
    }
}
