//! LinuxCNC's tool table (`.tbl`): one tool per line,
//! `T1 P1 X0 Y0 Z12.5 D6 ;comment`.
//!
//! Fields (LinuxCNC's tool table format): `T` tool number and `P` pocket
//! (both unsigned integers, required), `X Y Z A B C U V W` the tool's
//! offsets along each axis, `D` the diameter, `I` the front angle, `J` the
//! back angle (lathe), `Q` the orientation (lathe, integer 0–9); a `;`
//! starts the remark. Lines starting with `;` and blank lines are ignored.
//! Lengths are in the machine's units (LinuxCNC's `[TRAJ]LINEAR_UNITS`),
//! given to [`ToolTable::parse`]; angles in degrees.

use std::collections::BTreeMap;

use super::axes::{Axes, Axis};
use super::event::Units;

/// One tool of the table, lengths in mm, angles in degrees.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct Tool {
    /// Tool number (`T`).
    pub number: u32,
    /// Pocket number (`P`).
    pub pocket: u32,
    /// Offsets along every axis (`X`..`W`), mm / degree: `Z` is the tool
    /// length offset G43 applies.
    pub offset: Axes,
    /// Diameter (`D`), mm.
    pub diameter: f64,
    /// Front angle (`I`), degree.
    pub front_angle: f64,
    /// Back angle (`J`), degree.
    pub back_angle: f64,
    /// Orientation (`Q`, lathe).
    pub orientation: u8,
    /// The remark after `;`, trimmed.
    pub remark: String,
}

impl Tool {
    /// A tool with only a length offset along Z, mm (pocket = tool number).
    pub fn with_length(number: u32, length: f64) -> Tool {
        let mut offset = Axes::ZERO;
        offset[Axis::Z] = length;
        Tool {
            number,
            pocket: number,
            offset,
            ..Tool::default()
        }
    }
}

/// A bad line of a tool table: 1-based line and byte column.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{line}:{column}: {message}")]
pub struct ToolTableError {
    /// 1-based line.
    pub line: usize,
    /// 1-based byte column of the faulty field.
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

/// The tools by number.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ToolTable {
    tools: BTreeMap<u32, Tool>,
}

impl ToolTable {
    /// An empty table.
    pub fn new() -> ToolTable {
        ToolTable::default()
    }

    /// Reads a table whose lengths are in `units`. Every field must be a
    /// known letter followed by a number (LinuxCNC skips such a line; here
    /// it is an error naming the field), T and P are required, tool and
    /// pocket numbers unique.
    pub fn parse(text: &str, units: Units) -> Result<ToolTable, ToolTableError> {
        let scale = units.mm_per_unit();
        let mut table = ToolTable::new();
        let mut pockets: BTreeMap<u32, u32> = BTreeMap::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let err = |column: usize, message: String| ToolTableError {
                line,
                column,
                message,
            };
            let (fields, remark) = match raw.find(';') {
                Some(k) => (&raw[..k], raw[k + 1..].trim()),
                None => (raw, ""),
            };
            if fields.trim().is_empty() {
                continue;
            }
            let mut tool = Tool {
                remark: remark.to_string(),
                ..Tool::default()
            };
            let (mut t, mut p) = (None, None);
            let mut seen = [false; 26];
            let mut start = 0;
            for token in fields.split([' ', '\t']) {
                let column = start + 1;
                start += token.len() + 1;
                if token.is_empty() {
                    continue;
                }
                let letter = token.as_bytes()[0].to_ascii_uppercase();
                let value = &token[1..];
                if !letter.is_ascii_uppercase() {
                    return Err(err(column, format!("unknown field '{token}'")));
                }
                let slot = &mut seen[usize::from(letter - b'A')];
                if *slot {
                    return Err(err(
                        column,
                        format!("more than one {} field", letter as char),
                    ));
                }
                *slot = true;
                let real = || {
                    value
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| {
                            err(
                                column,
                                format!("{} needs a number, found '{value}'", letter as char),
                            )
                        })
                };
                let int = || {
                    value.parse::<u32>().map_err(|_| {
                        err(
                            column,
                            format!(
                                "{} needs an unsigned integer, found '{value}'",
                                letter as char
                            ),
                        )
                    })
                };
                match letter {
                    b'T' => t = Some(int()?),
                    b'P' => p = Some(int()?),
                    b'D' => tool.diameter = real()?.abs() * scale,
                    b'I' => tool.front_angle = real()?,
                    b'J' => tool.back_angle = real()?,
                    b'Q' => {
                        let q = int()?;
                        if q > 9 {
                            return Err(err(
                                column,
                                format!("Q (orientation) is 0 to 9, found {q}"),
                            ));
                        }
                        tool.orientation = q as u8;
                    }
                    l => {
                        let Some(axis) = Axis::from_letter(l) else {
                            return Err(err(column, format!("unknown field '{token}'")));
                        };
                        let v = real()?;
                        tool.offset[axis] = if axis.is_rotary() { v } else { v * scale };
                    }
                }
            }
            let Some(number) = t else {
                return Err(err(1, "tool number (T) missing".into()));
            };
            let Some(pocket) = p else {
                return Err(err(1, "pocket number (P) missing".into()));
            };
            if table.tools.contains_key(&number) {
                return Err(err(1, format!("tool {number} listed twice")));
            }
            if let Some(other) = pockets.insert(pocket, number) {
                return Err(err(
                    1,
                    format!("pocket {pocket} holds tools {other} and {number}"),
                ));
            }
            tool.number = number;
            tool.pocket = pocket;
            table.tools.insert(number, tool);
        }
        Ok(table)
    }

    /// The tool with this number.
    pub fn get(&self, number: u32) -> Option<&Tool> {
        self.tools.get(&number)
    }

    /// Adds or replaces a tool.
    pub fn insert(&mut self, tool: Tool) {
        self.tools.insert(tool.number, tool);
    }

    /// The tool with this number, created empty (pocket = number) if absent.
    pub fn entry(&mut self, number: u32) -> &mut Tool {
        self.tools.entry(number).or_insert_with(|| Tool {
            number,
            pocket: number,
            ..Tool::default()
        })
    }

    /// The tools in number order.
    pub fn iter(&self) -> impl Iterator<Item = &Tool> {
        self.tools.values()
    }

    /// Number of tools.
    pub fn len(&self) -> usize {
        self.tools.len()
    }

    /// Whether the table is empty.
    pub fn is_empty(&self) -> bool {
        self.tools.is_empty()
    }
}

impl FromIterator<(u32, f64)> for ToolTable {
    /// Tools with only a Z length, mm: `[(1, 50.0)].into_iter().collect()`.
    fn from_iter<I: IntoIterator<Item = (u32, f64)>>(iter: I) -> Self {
        let mut t = ToolTable::new();
        for (n, l) in iter {
            t.insert(Tool::with_length(n, l));
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_linuxcnc_lines_in_machine_units() {
        let text = "; header line\nT1 P1 Z0.511 D0.125 ;1/8 end mill\n\nT2  P5 X0.1 Z1 A10 ;\nT99999 P2 Z0.1 Q3 I95 J155\n";
        let t = ToolTable::parse(text, Units::Inch).unwrap();
        assert_eq!(t.len(), 3);
        let t1 = t.get(1).unwrap();
        assert!((t1.offset[Axis::Z] - 0.511 * 25.4).abs() < 1e-12);
        assert!((t1.diameter - 0.125 * 25.4).abs() < 1e-12);
        assert_eq!(t1.remark, "1/8 end mill");
        let t2 = t.get(2).unwrap();
        assert_eq!(t2.pocket, 5);
        assert!((t2.offset[Axis::X] - 2.54).abs() < 1e-12);
        assert_eq!(t2.offset[Axis::A], 10.0, "angles are not scaled");
        let t3 = t.get(99999).unwrap();
        assert_eq!(
            (t3.orientation, t3.front_angle, t3.back_angle),
            (3, 95.0, 155.0)
        );
        let mm = ToolTable::parse("T3 P3 Z-12.5\n", Units::Millimetre).unwrap();
        assert_eq!(mm.get(3).unwrap().offset[Axis::Z], -12.5);
    }

    #[test]
    fn bad_lines_name_line_and_column() {
        let cases = [
            ("T1 P1 Z1x\n", 1, 7, "Z needs a number"),
            ("T1 P1\nT2 P2 K4\n", 2, 7, "unknown field"),
            ("P1 Z1\n", 1, 1, "tool number (T) missing"),
            ("T1 Z1\n", 1, 1, "pocket number (P) missing"),
            ("T1 P1\nT1 P2\n", 2, 1, "listed twice"),
            ("T1 P1\nT2 P1\n", 2, 1, "pocket 1 holds"),
            ("T-1 P1\n", 1, 1, "unsigned integer"),
            ("T1 P1 Z1 Z2\n", 1, 10, "more than one Z"),
            ("T1 P1 Q12\n", 1, 7, "0 to 9"),
        ];
        for (text, line, column, msg) in cases {
            let e = ToolTable::parse(text, Units::Millimetre).unwrap_err();
            assert_eq!((e.line, e.column), (line, column), "{text}: {e}");
            assert!(e.message.contains(msg), "{text}: {e}");
        }
    }
}
