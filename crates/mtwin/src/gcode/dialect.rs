//! Where controllers read the same words differently, within what this
//! interpreter supports.

/// The controller family whose reading of a program is reproduced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Dialect {
    /// LinuxCNC RS-274/NGC: `G4 P` in seconds, `G90.1`/`G91.1` arc-centre
    /// modes, every number is a value in program units.
    #[default]
    LinuxCnc,
    /// Fanuc-style: `G4 X` or `G4 U` in seconds, `G4 P` in milliseconds
    /// (an integer); arc centres are always incremental (no G90.1/G91.1).
    Fanuc {
        /// `true` ("pocket calculator" input, parameter DPI set): `X10`
        /// means 10 mm. `false` (the Fanuc default): a dimension word written
        /// without a decimal point is in least input increments, `X10` being
        /// 0.010 mm (or 0.0010 in; 0.010° for a rotary axis).
        decimal_point_programming: bool,
    },
}

impl Dialect {
    /// Whether G90.1/G91.1 (absolute/incremental arc centres) exist.
    pub fn has_arc_distance_modes(self) -> bool {
        matches!(self, Dialect::LinuxCnc)
    }

    /// Value of a dimension word (axis, I J K, R) in program units, from the
    /// written number and whether it had a decimal point. `inch` selects the
    /// least increment of an inch program (0.0001 in instead of 0.001 mm);
    /// `rotary` that of a rotary axis (0.001°).
    pub fn dimension(self, written: f64, has_point: bool, inch: bool, rotary: bool) -> f64 {
        match self {
            Dialect::Fanuc {
                decimal_point_programming: false,
            } if !has_point => {
                let increment = if inch && !rotary { 1e-4 } else { 1e-3 };
                written * increment
            }
            _ => written,
        }
    }
}

/// How a block's dwell words read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum DwellWord {
    /// LinuxCNC `P`, seconds.
    PSeconds,
    /// Fanuc `P`, milliseconds.
    PMilliseconds,
    /// Fanuc `X`/`U`, seconds.
    XSeconds,
}

impl DwellWord {
    /// Dwell in seconds from the word value.
    pub(crate) fn seconds(self, value: f64) -> f64 {
        match self {
            DwellWord::PSeconds | DwellWord::XSeconds => value,
            DwellWord::PMilliseconds => value / 1000.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fanuc_integer_words_are_least_increments() {
        let f = Dialect::Fanuc {
            decimal_point_programming: false,
        };
        assert_eq!(f.dimension(10.0, false, false, false), 10.0 * 0.001);
        assert_eq!(f.dimension(10.0, true, false, false), 10.0);
        assert_eq!(f.dimension(10.0, false, true, false), 10.0 * 0.0001);
        assert_eq!(f.dimension(10.0, false, true, true), 10.0 * 0.001);
        let calc = Dialect::Fanuc {
            decimal_point_programming: true,
        };
        assert_eq!(calc.dimension(10.0, false, false, false), 10.0);
        assert_eq!(Dialect::LinuxCnc.dimension(10.0, false, false, false), 10.0);
    }

    #[test]
    fn dwell_units() {
        assert_eq!(DwellWord::PMilliseconds.seconds(1500.0), 1.5);
        assert_eq!(DwellWord::PSeconds.seconds(1.5), 1.5);
    }
}
