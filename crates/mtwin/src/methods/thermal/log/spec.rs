//! The column specifications of a wide log: drift channels (column, unit,
//! axis) and inputs (level, rise, square, rise over another sensor).

use serde::{Deserialize, Serialize};

/// The axis a drift channel displaces the tool along (relative to the work, +).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Axis {
    /// X.
    X,
    /// Y.
    Y,
    /// Z.
    Z,
}

impl std::str::FromStr for Axis {
    type Err = String;
    fn from_str(s: &str) -> Result<Axis, String> {
        match s.trim() {
            "X" | "x" => Ok(Axis::X),
            "Y" | "y" => Ok(Axis::Y),
            "Z" | "z" => Ok(Axis::Z),
            other => Err(format!("`{other}` is not an axis (X, Y or Z)")),
        }
    }
}

/// Length unit of a drift channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LengthUnit {
    /// Millimetres.
    #[serde(rename = "mm")]
    Mm,
    /// Micrometres.
    #[serde(rename = "um")]
    Um,
}

impl LengthUnit {
    /// Millimetres per unit.
    pub fn mm(self) -> f64 {
        match self {
            LengthUnit::Mm => 1.0,
            LengthUnit::Um => 1e-3,
        }
    }

    /// The unit from a column name ending in `_um` or `_mm`.
    pub fn from_column(name: &str) -> Option<LengthUnit> {
        if name.ends_with("_um") {
            Some(LengthUnit::Um)
        } else if name.ends_with("_mm") {
            Some(LengthUnit::Mm)
        } else {
            None
        }
    }
}

/// One drift channel of a log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelSpec {
    /// Column name.
    pub column: String,
    /// Unit of the column's values.
    pub unit: LengthUnit,
    /// Axis along which a positive value displaces the tool relative to the work.
    pub axis: Axis,
}

impl ChannelSpec {
    /// `COLUMN:AXIS` or `COLUMN:UNIT:AXIS` (unit `um` or `mm`; without it the
    /// column must end in `_um` or `_mm`).
    pub fn parse(text: &str) -> Result<ChannelSpec, String> {
        let parts: Vec<&str> = text.split(':').map(str::trim).collect();
        let (column, unit, axis) = match parts.as_slice() {
            [c, a] => (*c, LengthUnit::from_column(c), *a),
            [c, u, a] => (
                *c,
                match *u {
                    "um" | "µm" => Some(LengthUnit::Um),
                    "mm" => Some(LengthUnit::Mm),
                    _ => return Err(format!("`{u}` is not a length unit (um or mm) in `{text}`")),
                },
                *a,
            ),
            _ => {
                return Err(format!(
                    "`{text}`: give a drift channel as COLUMN:AXIS or COLUMN:UNIT:AXIS, e.g. ch1_um:Z"
                ));
            }
        };
        let unit = unit.ok_or_else(|| {
            format!("`{text}`: the column's name does not end in _um or _mm; give the unit, e.g. {column}:um:Z")
        })?;
        if column.is_empty() {
            return Err(format!("`{text}`: the column name is empty"));
        }
        Ok(ChannelSpec {
            column: column.to_string(),
            unit,
            axis: axis.parse()?,
        })
    }
}

/// One input column of a log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputSpec {
    /// Column name.
    pub column: String,
    /// Use the change since the first sample (temperatures), not the value.
    pub rise: bool,
    /// Use the square of the value (of each period mean), e.g. of the
    /// spindle speed, for heat that grows faster than the speed.
    #[serde(default)]
    pub square: bool,
    /// Use the difference `column − over` row by row (e.g. a temperature
    /// over an ambient sensor's, °C), as its rise since the start: a sensor
    /// that follows the room as much as the machine then says only how much
    /// warmer than the room its part of the machine has become.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub over: Option<String>,
}

impl InputSpec {
    /// `COLUMN`, `COLUMN:rise`, `COLUMN:level`, `COLUMN:square` or
    /// `COLUMN:over=OTHER`; without a suffix a column ending in `_c` (a
    /// temperature, °C) is taken as its rise since the start. `square` uses
    /// the square of the value (as a level), so `speed_rpm,speed_rpm:square`
    /// offers the speed and its square as two candidate inputs. `over=OTHER`
    /// uses the rise of `COLUMN − OTHER` since the start (a temperature over
    /// an ambient sensor).
    pub fn parse(text: &str) -> Result<InputSpec, String> {
        let (column, kind) = match text.split_once(':') {
            Some((c, k)) => (c.trim(), Some(k.trim())),
            None => (text.trim(), None),
        };
        if column.is_empty() {
            return Err(format!("`{text}`: the column name is empty"));
        }
        let mut over = None;
        let (rise, square) = match kind {
            None => (column.ends_with("_c"), false),
            Some("rise") => (true, false),
            Some("level") => (false, false),
            Some("square") => (false, true),
            Some(k) if k.starts_with("over=") => {
                let other = k["over=".len()..].trim();
                if other.is_empty() || other.contains(':') {
                    return Err(format!(
                        "`{text}`: give the reference column after over=, e.g. t5_c:over=t1_c"
                    ));
                }
                if other == column {
                    return Err(format!("`{text}`: a column cannot be taken over itself"));
                }
                over = Some(other.to_string());
                (true, false)
            }
            Some(k) => {
                return Err(format!(
                    "`{k}` in `{text}`: say rise, level, square or over=COLUMN"
                ));
            }
        };
        Ok(InputSpec {
            column: column.to_string(),
            rise,
            square,
            over,
        })
    }

    /// The name the input is known by: its column, with `:square` when
    /// squared or `:over=OTHER` when taken over another column (the text
    /// [`InputSpec::parse`] reads back).
    pub fn name(&self) -> String {
        input_name(&self.column, self.square, self.over.as_deref())
    }
}

/// The one spelling of an input's name ([`InputSpec::name`], [`LogInput::name`](super::LogInput::name)).
pub(super) fn input_name(column: &str, square: bool, over: Option<&str>) -> String {
    match (square, over) {
        (_, Some(o)) => format!("{column}:over={o}"),
        (true, None) => format!("{column}:square"),
        (false, None) => column.to_string(),
    }
}
