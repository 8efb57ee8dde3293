//! ISO 230-1 error names (docs/machine-model.md), parsed once into a typed [`ErrorName`].

use std::fmt;
use std::str::FromStr;

/// One of the six rigid-body components of an error motion.
///
/// Translations are in mm, rotations in rad. The letter is the one ISO 230-1 uses
/// after the leading `E`: `X`, `Y`, `Z` for translations along x, y, z and `A`, `B`, `C`
/// for rotations about x, y, z.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Component {
    /// Translation along x (mm).
    Tx,
    /// Translation along y (mm).
    Ty,
    /// Translation along z (mm).
    Tz,
    /// Rotation about x (rad).
    Rx,
    /// Rotation about y (rad).
    Ry,
    /// Rotation about z (rad).
    Rz,
}

impl Component {
    /// All six in the order used by every array indexed by component: X, Y, Z, A, B, C.
    pub const ALL: [Component; 6] = [
        Component::Tx,
        Component::Ty,
        Component::Tz,
        Component::Rx,
        Component::Ry,
        Component::Rz,
    ];

    /// Index 0..6 in [`Component::ALL`] order.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The ISO letter (`X`, `Y`, `Z`, `A`, `B`, `C`).
    pub fn letter(self) -> char {
        ['X', 'Y', 'Z', 'A', 'B', 'C'][self.index()]
    }

    /// The component with ISO letter `c` (upper case).
    pub fn from_letter(c: char) -> Option<Component> {
        Some(match c {
            'X' => Component::Tx,
            'Y' => Component::Ty,
            'Z' => Component::Tz,
            'A' => Component::Rx,
            'B' => Component::Ry,
            'C' => Component::Rz,
            _ => return None,
        })
    }

    /// True for the three rotations (values in rad), false for translations (mm).
    pub fn is_rotation(self) -> bool {
        self.index() >= 3
    }
}

/// Whether an error is a position-dependent function of the axis' own position (PDGE) or
/// a constant location error of the axis (PIGE, the `0` names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ErrorKind {
    /// Position-dependent geometric error, e.g. `EXX`, `ECC`.
    Pdge,
    /// Position-independent (location) error, e.g. `EY0A`, `EC0Y`.
    Location,
}

/// A parsed ISO 230-1 error name such as `EXX`, `EBY`, `EY0A`, `EC0Y`.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ErrorName {
    /// PDGE or location.
    pub kind: ErrorKind,
    /// Which of the six components.
    pub component: Component,
    /// The axis it belongs to (the axis name of the machine model).
    pub axis: String,
}

/// Why a text is not an error name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ErrorNameError {
    /// Does not start with `E`.
    #[error("`{0}` is not an ISO 230-1 error name: it must start with `E` (e.g. `EXX`, `EY0A`)")]
    NoE(String),
    /// The component letter is not X, Y, Z, A, B or C.
    #[error(
        "`{0}` is not an ISO 230-1 error name: the letter after `E` must be X, Y, Z, A, B or C"
    )]
    BadComponent(String),
    /// Nothing after the component (and the optional `0`).
    #[error("`{0}` is not an ISO 230-1 error name: the axis name is missing")]
    NoAxis(String),
}

impl ErrorName {
    /// A PDGE name, e.g. `ErrorName::pdge(Component::Tx, "X")` is `EXX`.
    pub fn pdge(component: Component, axis: &str) -> Self {
        Self {
            kind: ErrorKind::Pdge,
            component,
            axis: axis.to_string(),
        }
    }

    /// A location name, e.g. `ErrorName::location(Component::Ty, "A")` is `EY0A`.
    pub fn location(component: Component, axis: &str) -> Self {
        Self {
            kind: ErrorKind::Location,
            component,
            axis: axis.to_string(),
        }
    }

    /// True for a location (constant) error.
    pub fn is_location(&self) -> bool {
        self.kind == ErrorKind::Location
    }
}

impl FromStr for ErrorName {
    type Err = ErrorNameError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut chars = s.chars();
        if chars.next() != Some('E') {
            return Err(ErrorNameError::NoE(s.to_string()));
        }
        let component = chars
            .next()
            .and_then(Component::from_letter)
            .ok_or_else(|| ErrorNameError::BadComponent(s.to_string()))?;
        let rest = chars.as_str();
        let (kind, axis) = match rest.strip_prefix('0') {
            Some(a) => (ErrorKind::Location, a),
            None => (ErrorKind::Pdge, rest),
        };
        if axis.is_empty() {
            return Err(ErrorNameError::NoAxis(s.to_string()));
        }
        Ok(ErrorName {
            kind,
            component,
            axis: axis.to_string(),
        })
    }
}

impl fmt::Display for ErrorName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let zero = if self.is_location() { "0" } else { "" };
        write!(f, "E{}{}{}", self.component.letter(), zero, self.axis)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_iso_names() {
        let n: ErrorName = "EXX".parse().unwrap();
        assert_eq!(n, ErrorName::pdge(Component::Tx, "X"));
        let n: ErrorName = "EY0A".parse().unwrap();
        assert_eq!(n, ErrorName::location(Component::Ty, "A"));
        let n: ErrorName = "EC0Y".parse().unwrap();
        assert_eq!(
            (n.kind, n.component, n.axis.as_str()),
            (ErrorKind::Location, Component::Rz, "Y")
        );
        let n: ErrorName = "ECC".parse().unwrap();
        assert_eq!(n, ErrorName::pdge(Component::Rz, "C"));
        assert!("XXX".parse::<ErrorName>().is_err());
        assert!("EQX".parse::<ErrorName>().is_err());
        assert!("EX".parse::<ErrorName>().is_err());
        assert!("EX0".parse::<ErrorName>().is_err());
    }

    #[test]
    fn display_round_trips() {
        for s in ["EXX", "EYX", "EBZ", "EX0C", "EA0C", "EC0Y", "EZ0A", "EXX2"] {
            assert_eq!(s.parse::<ErrorName>().unwrap().to_string(), s);
        }
    }
}
