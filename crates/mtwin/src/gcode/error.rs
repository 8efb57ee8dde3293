//! Errors of the G-code engine: every one names the line (1-based) and, where
//! a byte of the line is at fault, the column (1-based, in bytes).

use std::io;

/// Where in the source a problem is: 1-based line and 1-based byte column
/// (0 when the whole block is at fault).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Location {
    /// 1-based line number in the file.
    pub line: u64,
    /// 1-based byte column in the line, 0 when the problem is the block as a whole.
    pub column: u32,
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.column == 0 {
            write!(f, "line {}", self.line)
        } else {
            write!(f, "line {}, column {}", self.line, self.column)
        }
    }
}

/// Everything that can go wrong reading, interpreting or measuring a program.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GcodeError {
    /// The bytes do not form a block (bad character, unclosed comment, word
    /// letter without a value, ...).
    #[error("syntax error at {at}: {message}")]
    Syntax {
        /// Where in the program.
        at: Location,
        /// What is wrong.
        message: String,
    },
    /// Valid RS-274/NGC that this interpreter does not implement (O-words,
    /// expressions, parameters, canned cycles, ...). Never silently skipped.
    #[error("unsupported {what} at {at}")]
    Unsupported {
        /// Where in the program.
        at: Location,
        /// What is not supported (e.g. `cutter compensation G41`).
        what: String,
    },
    /// A block that a controller would reject (arc radius mismatch, G1
    /// without feed rate, two codes of one modal group, ...).
    #[error("invalid block at {at}: {message}")]
    Invalid {
        /// Where in the program.
        at: Location,
        /// Why a controller would reject the block.
        message: String,
    },
    /// A word edit that cannot be done (non-finite value, ambiguous word).
    #[error("cannot edit block: {0}")]
    Edit(String),
    /// Reading or writing the program failed.
    #[error("I/O error: {0}")]
    Io(#[from] io::Error),
    /// An error in a subroutine file the program called (its location is
    /// in that file).
    #[error("{error}")]
    InFile {
        /// The subroutine file.
        path: std::path::PathBuf,
        /// The error, located in `path`.
        error: Box<GcodeError>,
    },
}

impl GcodeError {
    /// Location of the problem, if it has one.
    pub fn location(&self) -> Option<Location> {
        match self {
            GcodeError::Syntax { at, .. }
            | GcodeError::Unsupported { at, .. }
            | GcodeError::Invalid { at, .. } => Some(*at),
            GcodeError::Edit(_) | GcodeError::Io(_) => None,
            GcodeError::InFile { error, .. } => error.location(),
        }
    }

    /// What went wrong, without the location (for callers that print the
    /// location themselves, as `file:line:col: message`).
    pub fn message(&self) -> String {
        match self {
            GcodeError::Syntax { message, .. } => format!("syntax error: {message}"),
            GcodeError::Unsupported { what, .. } => format!("unsupported {what}"),
            GcodeError::Invalid { message, .. } => format!("invalid block: {message}"),
            GcodeError::Edit(_) | GcodeError::Io(_) => self.to_string(),
            GcodeError::InFile { error, .. } => error.message(),
        }
    }

    /// The subroutine file the error is in, when it is not in the program.
    pub fn file(&self) -> Option<&std::path::Path> {
        match self {
            GcodeError::InFile { path, .. } => Some(path),
            _ => None,
        }
    }

    pub(crate) fn syntax(line: u64, column: usize, message: impl Into<String>) -> Self {
        GcodeError::Syntax {
            at: Location {
                line,
                column: col32(column),
            },
            message: message.into(),
        }
    }

    pub(crate) fn unsupported(line: u64, column: usize, what: impl Into<String>) -> Self {
        GcodeError::Unsupported {
            at: Location {
                line,
                column: col32(column),
            },
            what: what.into(),
        }
    }

    pub(crate) fn invalid(line: u64, column: usize, message: impl Into<String>) -> Self {
        GcodeError::Invalid {
            at: Location {
                line,
                column: col32(column),
            },
            message: message.into(),
        }
    }
}

fn col32(column: usize) -> u32 {
    u32::try_from(column).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod message_tests {
    use super::*;

    #[test]
    fn message_leaves_the_location_to_the_caller() {
        let e = GcodeError::syntax(3, 5, "bad");
        assert_eq!(e.message(), "syntax error: bad");
        assert_eq!(e.location().map(|l| (l.line, l.column)), Some((3, 5)));
        let e = GcodeError::unsupported(12, 0, "canned cycle G81");
        assert_eq!(e.message(), "unsupported canned cycle G81");
        assert!(!e.message().contains("12"));
    }
}
