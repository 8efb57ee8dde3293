//! The one G-code writer of the library: every program mtwin generates
//! (ballbar tests, skiving touch-off, thermal measurement, S-shaped test
//! piece, tracker poses, servo excitation) is written block by block through
//! a [`ProgramWriter`], which owns what depends on the controller
//! ([`Dialect`]):
//!
//! * **Numbers.** At most [`WriterOptions::decimals`] decimals (default 4
//!   for LinuxCNC, 3 for Fanuc: its least input increment of 0.001 mm and
//!   0.001°), trailing zeros trimmed, never an exponent (G-code has none),
//!   never `-0`. Fanuc: every real-valued word (axes, `I J K R`, `F`, the
//!   `G4 X` dwell) keeps a decimal point (`X10.`), because a Fanuc control
//!   without decimal point programming reads `X10` as 10 least increments
//!   (0.010 mm); a Fanuc word has at most 8 digits (±99999.999 mm), and
//!   `S` is an integer. A non-finite value, or one a dialect cannot carry,
//!   is an error ([`WriteError`]), never written.
//! * **Dwell.** LinuxCNC `G4 P` in seconds; Fanuc `G4 X` in seconds with a
//!   decimal point, to 1 ms (Fanuc's `G4 P` is an integer of milliseconds
//!   and is not used).
//! * **Probing.** LinuxCNC `G38.2` (error if nothing is touched), Fanuc
//!   `G31` (skip).
//! * **Comments.** In parentheses; neither dialect can carry parentheses
//!   inside a comment (LinuxCNC refuses nested comments, a `)` ends it), so
//!   they are written as `[` `]`. Fanuc comments are upper case ASCII; `%`
//!   (the tape end on a Fanuc control) is written as `PCT`. A line break in
//!   a comment is an error. A LinuxCNC comment that would read as an active
//!   comment (`MSG,`, `DEBUG,`, `PRINT,`, `LOG…`, `PROBEOPEN`, …) is an
//!   error: write such lines with [`ProgramWriter::statement`].
//! * **Program start and end.** `%` first; Fanuc an `O` program number
//!   after it when one is given; `M30` (or `M2`) and `%` last.
//! * **Line numbers** (optional, [`WriterOptions::line_numbers`]): `N` on
//!   every block but the `%` and `O` lines, at most 99999 (five digits, as
//!   RS-274/NGC and Fanuc allow).
//!
//! ```
//! use mtwin::gcode::{Dialect, ProgramEnd, ProgramWriter};
//!
//! let fanuc = Dialect::Fanuc { decimal_point_programming: false };
//! let mut w = ProgramWriter::new(fanuc);
//! w.start(Some(1234)).unwrap();
//! w.comment("dwell (1.5 s) at X10").unwrap();
//! w.block().g(21).g(90).g(94).write().unwrap();
//! w.linear(&[('X', 10.0), ('Y', -0.00001)], Some(500.0)).unwrap();
//! w.dwell(1.5).unwrap();
//! w.end(ProgramEnd::M30).unwrap();
//! assert_eq!(
//!     w.finish(),
//!     "%\nO1234\n(DWELL [1.5 S] AT X10)\nG21 G90 G94\nG1 X10. Y0. F500.\nG4 X1.5\nM30\n%\n"
//! );
//! ```

use std::fmt::Write as _;

use super::dialect::Dialect;
use super::syntax::NumberFormat;

/// How numbers and blocks are written, beside the dialect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct WriterOptions {
    /// Decimals of real-valued words (mm, degree, mm/min, s), trailing
    /// zeros trimmed. Fanuc accepts digits below its least input increment
    /// only as rounding, and at most 8 digits per word.
    pub decimals: u8,
    /// `N` line numbers: the first number and the step (`None`: no numbers).
    pub line_numbers: Option<(u32, u32)>,
}

impl WriterOptions {
    /// The default options of `dialect`: 4 decimals for LinuxCNC (0.1 µm,
    /// 0.0001°), 3 for Fanuc (its least input increment), no line numbers.
    pub fn of(dialect: Dialect) -> Self {
        WriterOptions {
            decimals: match dialect {
                Dialect::LinuxCnc => 4,
                Dialect::Fanuc { .. } => 3,
            },
            line_numbers: None,
        }
    }

    /// These options with `decimals` decimals.
    pub fn with_decimals(mut self, decimals: u8) -> Self {
        self.decimals = decimals;
        self
    }

    /// These options with line numbers `first`, `first + step`, ….
    pub fn with_line_numbers(mut self, first: u32, step: u32) -> Self {
        self.line_numbers = Some((first, step));
        self
    }
}

/// Why a block cannot be written.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WriteError {
    /// A word's value is NaN or infinite.
    #[error("{letter} = {value} is not a finite number; nothing is written")]
    NotFinite {
        /// The word letter.
        letter: char,
        /// The value.
        value: f64,
    },
    /// A word needs more digits than the dialect reads.
    #[error("{letter}{text} has more than {max} digits, more than the controller reads")]
    TooManyDigits {
        /// The word letter.
        letter: char,
        /// The number as it would be written.
        text: String,
        /// The most digits allowed.
        max: usize,
    },
    /// A number for the text of a comment is NaN or infinite.
    #[error("{0} in a comment is not a finite number; nothing is written")]
    NotFiniteInText(f64),
    /// A negative dwell time.
    #[error("the dwell {0} s is negative")]
    NegativeDwell(f64),
    /// A letter that is not a word of G-code, or not allowed where it was given.
    #[error("`{letter}` cannot be written here: {why}")]
    Letter {
        /// The letter.
        letter: char,
        /// What it should have been.
        why: &'static str,
    },
    /// Comment or statement text the dialect cannot carry.
    #[error("the text `{text}` cannot be written as a comment or statement: {why}")]
    Text {
        /// The text.
        text: String,
        /// Why.
        why: &'static str,
    },
    /// A machine's axis names are not one G-code letter each.
    #[error(transparent)]
    AxisNames(#[from] super::axes::AxisLetterError),
    /// The line numbers ran past 99999.
    #[error("line number {0} is above 99999, the largest a controller reads")]
    LineNumber(u64),
}

/// How the program ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgramEnd {
    /// `M2`: program end.
    M2,
    /// `M30`: program end and rewind (the usual end of a part program).
    M30,
}

/// Direction of a circular move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArcDirection {
    /// `G2`, clockwise seen from the positive plane normal.
    Clockwise,
    /// `G3`, counter-clockwise.
    CounterClockwise,
}

/// Largest number of digits of a Fanuc word (±99999.999 mm at 0.001 mm).
const FANUC_DIGITS: usize = 8;

/// Values from this magnitude on do not fit a Fanuc word in mm (8 digits
/// at the least increment of 0.001 mm).
const FANUC_LARGEST: f64 = 99_999.999_5;

/// Letters of axis words, in the order of [`super::Axis`].
const AXIS_LETTERS: &str = "XYZABCUVW";

/// Comments LinuxCNC executes (the text after `(`, spaces removed, upper
/// case, starting with one of these).
const LINUXCNC_ACTIVE: [&str; 10] = [
    "MSG,",
    "DEBUG,",
    "PRINT,",
    "LOG,",
    "LOGOPEN,",
    "LOGAPPEND,",
    "LOGCLOSE",
    "PROBEOPEN",
    "PROBECLOSE",
    "PYRUN",
];

/// Writes a G-code program block by block in one [`Dialect`]; see the
/// module documentation for what it owns. Every method that writes checks
/// its values first and writes nothing on an error.
#[derive(Debug, Clone)]
pub struct ProgramWriter {
    dialect: Dialect,
    opts: WriterOptions,
    out: String,
    next_n: Option<u64>,
}

impl ProgramWriter {
    /// A writer for `dialect` with its default [`WriterOptions`].
    pub fn new(dialect: Dialect) -> Self {
        Self::with_options(dialect, WriterOptions::of(dialect))
    }

    /// A writer for `dialect` with `opts`.
    pub fn with_options(dialect: Dialect, opts: WriterOptions) -> Self {
        ProgramWriter {
            dialect,
            opts,
            out: String::new(),
            next_n: opts.line_numbers.map(|(first, _)| u64::from(first)),
        }
    }

    /// The dialect written.
    pub fn dialect(&self) -> Dialect {
        self.dialect
    }

    /// The options.
    pub fn options(&self) -> WriterOptions {
        self.opts
    }

    /// The program written so far.
    pub fn text(&self) -> &str {
        &self.out
    }

    /// The program.
    pub fn finish(self) -> String {
        self.out
    }

    fn fanuc(&self) -> bool {
        matches!(self.dialect, Dialect::Fanuc { .. })
    }

    /// `value` as written in a real-valued word `letter` (axes, `I J K R`,
    /// `F`, dwell): see the module documentation. The text of every number
    /// in a generated program comes from here (also for numbers inside
    /// [`ProgramWriter::statement`] lines).
    pub fn number(&self, letter: char, value: f64) -> Result<String, WriteError> {
        self.number_with(letter, value, self.opts.decimals)
    }

    fn number_with(&self, letter: char, value: f64, decimals: u8) -> Result<String, WriteError> {
        if !value.is_finite() {
            return Err(WriteError::NotFinite { letter, value });
        }
        let mut s = String::new();
        if self.fanuc() {
            NumberFormat::FixedPoint(decimals).write(value, &mut s);
            let digits = s.bytes().filter(u8::is_ascii_digit).count();
            if digits > FANUC_DIGITS || value.abs() >= FANUC_LARGEST {
                return Err(WriteError::TooManyDigits {
                    letter,
                    text: s,
                    max: FANUC_DIGITS,
                });
            }
        } else {
            NumberFormat::Fixed(decimals).write(value, &mut s);
        }
        Ok(s)
    }

    /// `value` for the text of a comment or a statement (not a word): the
    /// decimals of the words, trailing zeros trimmed, no decimal point
    /// forced, no exponent, no `-0`.
    pub fn plain(&self, value: f64) -> Result<String, WriteError> {
        if !value.is_finite() {
            return Err(WriteError::NotFiniteInText(value));
        }
        let mut s = String::new();
        NumberFormat::Fixed(self.opts.decimals).write(value, &mut s);
        Ok(s)
    }

    /// The value a control reads back from `value` written in word
    /// `letter`: `value` rounded to the written decimals.
    pub fn written(&self, letter: char, value: f64) -> Result<f64, WriteError> {
        let text = self.number(letter, value)?;
        // The text is a plain decimal number, which always parses.
        Ok(text.parse::<f64>().unwrap_or(value))
    }

    /// Starts a block (one line); nothing is written until
    /// [`BlockBuilder::write`].
    pub fn block(&mut self) -> BlockBuilder<'_> {
        BlockBuilder {
            w: self,
            words: String::new(),
            error: None,
        }
    }

    /// Program start: `%`, and for Fanuc the program number `O<number>`
    /// when given (1 to 9999); LinuxCNC has no program numbers and ignores
    /// `number`.
    pub fn start(&mut self, number: Option<u32>) -> Result<(), WriteError> {
        let o = match number {
            Some(n) if self.fanuc() => {
                if !(1..=9999).contains(&n) {
                    return Err(WriteError::Letter {
                        letter: 'O',
                        why: "a Fanuc program number is 1 to 9999",
                    });
                }
                Some(n)
            }
            _ => None,
        };
        self.out.push_str("%\n");
        if let Some(n) = o {
            let _ = writeln!(self.out, "O{n:04}");
        }
        Ok(())
    }

    /// Program end: `M2` or `M30`, then `%`.
    pub fn end(&mut self, end: ProgramEnd) -> Result<(), WriteError> {
        self.block()
            .m(match end {
                ProgramEnd::M2 => 2,
                ProgramEnd::M30 => 30,
            })
            .write()?;
        self.out.push_str("%\n");
        Ok(())
    }

    /// A comment line (see the module documentation for the characters).
    pub fn comment(&mut self, text: &str) -> Result<(), WriteError> {
        let c = self.comment_text(text)?;
        self.line(&c)
    }

    /// `(text)` as this dialect carries it.
    fn comment_text(&self, text: &str) -> Result<String, WriteError> {
        if text.chars().any(|c| c.is_control()) {
            return Err(WriteError::Text {
                text: text.to_owned(),
                why: "a comment is one line without control characters",
            });
        }
        let mut body: String = text
            .chars()
            .map(|c| match c {
                '(' => '[',
                ')' => ']',
                c => c,
            })
            .collect();
        if self.fanuc() {
            body = body.to_ascii_uppercase().replace('%', "PCT");
            if !body.is_ascii() {
                return Err(WriteError::Text {
                    text: text.to_owned(),
                    why: "a Fanuc comment is ASCII",
                });
            }
        } else {
            let key: String = body
                .chars()
                .filter(|c| !c.is_whitespace())
                .collect::<String>()
                .to_ascii_uppercase();
            if LINUXCNC_ACTIVE.iter().any(|k| key.starts_with(k)) {
                return Err(WriteError::Text {
                    text: text.to_owned(),
                    why: "LinuxCNC would execute it as an active comment; write it as a statement",
                });
            }
        }
        Ok(format!("({body})"))
    }

    /// A line the writer does not model, written as given (with a line
    /// number when numbering): a LinuxCNC active comment such as
    /// `(LOG,#5061)`, a Fanuc macro statement such as `#501=#5061`. Format
    /// any number in it with [`ProgramWriter::number`]. A line break or a
    /// `%` at its start is an error.
    pub fn statement(&mut self, text: &str) -> Result<(), WriteError> {
        if text.chars().any(|c| c.is_control()) || text.trim_start().starts_with('%') {
            return Err(WriteError::Text {
                text: text.to_owned(),
                why: "a statement is one line without control characters, not starting with %",
            });
        }
        self.line(text)
    }

    /// Rapid move `G0` to the axis words `axes` (letter, mm or degree).
    pub fn rapid(&mut self, axes: &[(char, f64)]) -> Result<(), WriteError> {
        self.block().g(0).axes(axes).write()
    }

    /// Straight feed move `G1` to `axes`, with the feed word when `feed` is given.
    pub fn linear(&mut self, axes: &[(char, f64)], feed: Option<f64>) -> Result<(), WriteError> {
        self.block().g(1).axes(axes).feed_opt(feed).write()
    }

    /// Circular move `G2`/`G3` in the active plane to `axes`, the centre
    /// given by `centre` (`I`, `J`, `K` words: the centre minus the start,
    /// the incremental arc-centre mode that is both dialects' default).
    pub fn arc(
        &mut self,
        direction: ArcDirection,
        axes: &[(char, f64)],
        centre: &[(char, f64)],
        feed: Option<f64>,
    ) -> Result<(), WriteError> {
        let mut b = self.block().g(match direction {
            ArcDirection::Clockwise => 2,
            ArcDirection::CounterClockwise => 3,
        });
        b = b.axes(axes);
        for &(l, v) in centre {
            let l = l.to_ascii_uppercase();
            if !"IJK".contains(l) {
                b.fail(WriteError::Letter {
                    letter: l,
                    why: "an arc centre word is I, J or K",
                });
            }
            b = b.real(l, v);
        }
        b.feed_opt(feed).write()
    }

    /// Probing move to `axes` at `feed` that stops at contact: LinuxCNC
    /// `G38.2` (an error when nothing is touched), Fanuc `G31` (skip).
    pub fn probe(&mut self, axes: &[(char, f64)], feed: f64) -> Result<(), WriteError> {
        let b = self.block();
        let b = if b.w.fanuc() { b.g(31) } else { b.g_sub(38, 2) };
        b.axes(axes).feed(feed).write()
    }

    /// Dwell of `seconds`: LinuxCNC `G4 P<s>`, Fanuc `G4 X<s>.` to 1 ms.
    /// Returns the dwell as the control reads it (seconds).
    pub fn dwell(&mut self, seconds: f64) -> Result<f64, WriteError> {
        let (letter, decimals) = if self.fanuc() {
            ('X', 3)
        } else {
            ('P', self.opts.decimals)
        };
        if seconds.is_finite() && seconds < 0.0 {
            return Err(WriteError::NegativeDwell(seconds));
        }
        let text = self.number_with(letter, seconds, decimals)?;
        let read = text.parse::<f64>().unwrap_or(seconds);
        self.line(&format!("G4 {letter}{text}"))?;
        Ok(read)
    }

    /// Appends one line with its line number.
    fn line(&mut self, body: &str) -> Result<(), WriteError> {
        if let Some(n) = self.next_n {
            if n > 99_999 {
                return Err(WriteError::LineNumber(n));
            }
            let step = self.opts.line_numbers.map_or(1, |(_, s)| u64::from(s));
            self.next_n = Some(n + step);
            let _ = write!(self.out, "N{n} ");
        }
        self.out.push_str(body);
        self.out.push('\n');
        Ok(())
    }
}

/// One block being built ([`ProgramWriter::block`]): words in the order
/// given, written by [`BlockBuilder::write`]; the first bad word makes
/// `write` fail and nothing is written.
#[derive(Debug)]
pub struct BlockBuilder<'a> {
    w: &'a mut ProgramWriter,
    words: String,
    error: Option<WriteError>,
}

impl BlockBuilder<'_> {
    fn fail(&mut self, e: WriteError) {
        self.error.get_or_insert(e);
    }

    fn push(&mut self, word: &str) {
        if !self.words.is_empty() {
            self.words.push(' ');
        }
        self.words.push_str(word);
    }

    /// A G-code with an integer number (`G0`, `G21`, `G53`, …).
    pub fn g(mut self, code: u16) -> Self {
        self.push(&format!("G{code}"));
        self
    }

    /// A G-code with a decimal number (`g_sub(38, 2)` is `G38.2`, `g_sub(43, 4)` is `G43.4`).
    pub fn g_sub(mut self, code: u16, sub: u8) -> Self {
        self.push(&format!("G{code}.{sub}"));
        self
    }

    /// An M-code.
    pub fn m(mut self, code: u16) -> Self {
        self.push(&format!("M{code}"));
        self
    }

    /// An integer word such as `H0`, `T1`, `D1`.
    pub fn int(mut self, letter: char, value: u32) -> Self {
        let letter = letter.to_ascii_uppercase();
        if !"DHLT".contains(letter) {
            self.fail(WriteError::Letter {
                letter,
                why: "an integer word here is D, H, L or T (G, M, S, F and axes have their own methods)",
            });
        }
        self.push(&format!("{letter}{value}"));
        self
    }

    /// Axis words (`X Y Z A B C U V W`), mm or degree.
    pub fn axes(mut self, axes: &[(char, f64)]) -> Self {
        for &(l, v) in axes {
            let l = l.to_ascii_uppercase();
            if !AXIS_LETTERS.contains(l) {
                self.fail(WriteError::Letter {
                    letter: l,
                    why: "an axis word is X, Y, Z, A, B, C, U, V or W",
                });
            }
            self = self.real(l, v);
        }
        self
    }

    /// One real-valued word.
    fn real(mut self, letter: char, value: f64) -> Self {
        match self.w.number(letter, value) {
            Ok(text) => self.push(&format!("{letter}{text}")),
            Err(e) => self.fail(e),
        }
        self
    }

    /// The feed word `F` (mm/min, deg/min, or 1/min under G93).
    pub fn feed(self, feed: f64) -> Self {
        self.real('F', feed)
    }

    fn feed_opt(self, feed: Option<f64>) -> Self {
        match feed {
            Some(f) => self.feed(f),
            None => self,
        }
    }

    /// The spindle speed `S`, rev/min (an integer for Fanuc, rounded).
    pub fn spindle_speed(mut self, rpm: f64) -> Self {
        if !rpm.is_finite() {
            self.fail(WriteError::NotFinite {
                letter: 'S',
                value: rpm,
            });
            return self;
        }
        if rpm < 0.0 {
            self.fail(WriteError::Letter {
                letter: 'S',
                why: "a spindle speed is not negative (the direction is M3 or M4)",
            });
            return self;
        }
        if self.w.fanuc() {
            let mut s = String::new();
            NumberFormat::Fixed(0).write(rpm, &mut s);
            if s.len() > FANUC_DIGITS || rpm >= 99_999_999.5 {
                self.fail(WriteError::TooManyDigits {
                    letter: 'S',
                    text: s,
                    max: FANUC_DIGITS,
                });
                return self;
            }
            self.push(&format!("S{s}"));
            self
        } else {
            self.real('S', rpm)
        }
    }

    /// A comment at the end of the block.
    pub fn comment(mut self, text: &str) -> Self {
        match self.w.comment_text(text) {
            Ok(c) => self.push(&c),
            Err(e) => self.fail(e),
        }
        self
    }

    /// Writes the block, or nothing and the first error.
    pub fn write(self) -> Result<(), WriteError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        self.w.line(&self.words)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FANUC: Dialect = Dialect::Fanuc {
        decimal_point_programming: false,
    };

    fn one(
        dialect: Dialect,
        f: impl FnOnce(&mut ProgramWriter) -> Result<(), WriteError>,
    ) -> String {
        let mut w = ProgramWriter::new(dialect);
        f(&mut w).unwrap();
        w.finish()
    }

    #[test]
    fn linuxcnc_numbers_are_trimmed_without_exponent_or_minus_zero() {
        let t = one(Dialect::LinuxCnc, |w| {
            w.linear(
                &[
                    ('X', 10.0),
                    ('Y', -0.00001),
                    ('Z', 1e-7),
                    ('A', 1.0 / 3.0),
                    ('B', -2.5),
                    ('C', 1.23456),
                ],
                Some(1500.0),
            )?;
            w.rapid(&[('X', 1e12), ('y', -0.0)])
        });
        assert_eq!(
            t,
            "G1 X10 Y0 Z0 A0.3333 B-2.5 C1.2346 F1500\nG0 X1000000000000 Y0\n"
        );
    }

    #[test]
    fn fanuc_real_words_keep_a_decimal_point_and_eight_digits() {
        let t = one(FANUC, |w| {
            w.linear(&[('X', 10.0), ('Y', -0.0004), ('Z', -81.00049)], Some(20.0))?;
            w.rapid(&[('A', 90.0), ('C', 99_999.999)])
        });
        assert_eq!(t, "G1 X10. Y0. Z-81. F20.\nG0 A90. C99999.999\n");
        let mut w = ProgramWriter::new(FANUC);
        let e = w.rapid(&[('X', 100_000.0)]).unwrap_err();
        assert!(
            matches!(e, WriteError::TooManyDigits { letter: 'X', .. }),
            "{e}"
        );
        assert_eq!(w.text(), "", "nothing written on an error");
        // More decimals than the least increment: still 8 digits at most.
        let mut w = ProgramWriter::with_options(FANUC, WriterOptions::of(FANUC).with_decimals(6));
        w.rapid(&[('X', -12.3456789)]).unwrap();
        assert!(w.rapid(&[('X', -123.4567891)]).is_err());
        assert_eq!(w.finish(), "G0 X-12.345679\n");
        // Decimal point programming on or off: the text is the same.
        let calc = Dialect::Fanuc {
            decimal_point_programming: true,
        };
        assert_eq!(one(calc, |w| w.rapid(&[('X', 10.0)])), "G0 X10.\n");
    }

    #[test]
    fn non_finite_values_are_refused_and_nothing_is_written() {
        for d in [Dialect::LinuxCnc, FANUC] {
            let mut w = ProgramWriter::new(d);
            for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                assert!(matches!(
                    w.linear(&[('X', 1.0), ('Y', v)], Some(100.0)),
                    Err(WriteError::NotFinite { letter: 'Y', .. })
                ));
                assert!(w.linear(&[('X', 1.0)], Some(v)).is_err());
                assert!(w.dwell(v).is_err());
                assert!(w.block().spindle_speed(v).write().is_err());
                assert!(w.number('X', v).is_err());
            }
            assert!(matches!(w.dwell(-1.0), Err(WriteError::NegativeDwell(_))));
            assert_eq!(w.text(), "");
        }
    }

    #[test]
    fn dwell_words_per_dialect() {
        let mut w = ProgramWriter::new(Dialect::LinuxCnc);
        assert_eq!(w.dwell(2.0).unwrap(), 2.0);
        assert_eq!(w.dwell(0.25).unwrap(), 0.25);
        assert_eq!(w.dwell(1.23456).unwrap(), 1.2346);
        assert_eq!(w.finish(), "G4 P2\nG4 P0.25\nG4 P1.2346\n");
        let mut w = ProgramWriter::new(FANUC);
        assert_eq!(w.dwell(2.0).unwrap(), 2.0);
        assert_eq!(w.dwell(0.0015).unwrap(), 0.002);
        assert_eq!(w.dwell(600.0).unwrap(), 600.0);
        assert_eq!(w.finish(), "G4 X2.\nG4 X0.002\nG4 X600.\n");
        // Fanuc's dwell is at most 99999.999 s.
        assert!(ProgramWriter::new(FANUC).dwell(100_000.0).is_err());
    }

    #[test]
    fn probing_and_arcs_and_modal_words() {
        let t = one(Dialect::LinuxCnc, |w| {
            w.probe(&[('Z', -81.0)], 20.0)?;
            w.arc(
                ArcDirection::CounterClockwise,
                &[('X', 0.0), ('Y', 10.0)],
                &[('I', -10.0), ('J', 0.0)],
                Some(300.0),
            )?;
            w.block().g(53).g(0).axes(&[('A', 0.0)]).write()?;
            w.block().g_sub(43, 4).int('H', 0).write()?;
            w.block().spindle_speed(2000.5).m(3).write()?;
            w.block().m(0).comment("mount the bar").write()
        });
        assert_eq!(
            t,
            "G38.2 Z-81 F20\nG3 X0 Y10 I-10 J0 F300\nG53 G0 A0\nG43.4 H0\nS2000.5 M3\nM0 (mount the bar)\n"
        );
        let t = one(FANUC, |w| {
            w.probe(&[('Z', -81.0)], 20.0)?;
            w.arc(
                ArcDirection::Clockwise,
                &[('X', 0.0)],
                &[('I', -10.0)],
                None,
            )?;
            w.block().spindle_speed(2000.5).m(3).write()
        });
        assert_eq!(t, "G31 Z-81. F20.\nG2 X0. I-10.\nS2001 M3\n");
        let mut w = ProgramWriter::new(Dialect::LinuxCnc);
        assert!(matches!(
            w.rapid(&[('Q', 1.0)]),
            Err(WriteError::Letter { letter: 'Q', .. })
        ));
        assert!(
            w.arc(ArcDirection::Clockwise, &[('X', 1.0)], &[('R', 1.0)], None)
                .is_err()
        );
        assert!(w.block().int('G', 1).write().is_err());
        assert_eq!(w.text(), "");
    }

    #[test]
    fn comments_per_dialect() {
        let t = one(Dialect::LinuxCnc, |w| {
            w.comment("machine (test), 5 % of travel")
        });
        assert_eq!(t, "(machine [test], 5 % of travel)\n");
        let t = one(FANUC, |w| w.comment("machine (test), 5 % of travel"));
        assert_eq!(t, "(MACHINE [TEST], 5 PCT OF TRAVEL)\n");
        let mut w = ProgramWriter::new(Dialect::LinuxCnc);
        assert!(w.comment("two\nlines").is_err());
        assert!(w.comment(" msg, hello").is_err(), "an active comment");
        assert!(w.comment("Log, values").is_err());
        assert!(w.comment("login to the machine").is_ok());
        assert!(ProgramWriter::new(FANUC).comment("20 °C").is_err());
        assert!(ProgramWriter::new(FANUC).comment("msg, hello").is_ok());
        assert!(w.statement("(LOG,#5061)").is_ok());
        assert!(w.statement("a\nb").is_err());
        assert!(w.statement("%").is_err());
        assert_eq!(w.finish(), "(login to the machine)\n(LOG,#5061)\n");
    }

    #[test]
    fn program_start_end_and_line_numbers() {
        let mut w =
            ProgramWriter::with_options(FANUC, WriterOptions::of(FANUC).with_line_numbers(10, 10));
        w.start(Some(9100)).unwrap();
        w.comment("x").unwrap();
        w.rapid(&[('Z', 5.0)]).unwrap();
        w.end(ProgramEnd::M30).unwrap();
        assert_eq!(w.finish(), "%\nO9100\nN10 (X)\nN20 G0 Z5.\nN30 M30\n%\n");
        let mut w = ProgramWriter::new(Dialect::LinuxCnc);
        w.start(Some(9100)).unwrap();
        w.end(ProgramEnd::M2).unwrap();
        assert_eq!(w.finish(), "%\nM2\n%\n");
        assert!(ProgramWriter::new(FANUC).start(Some(10_000)).is_err());
        let mut w = ProgramWriter::with_options(
            Dialect::LinuxCnc,
            WriterOptions::of(Dialect::LinuxCnc).with_line_numbers(99_990, 10),
        );
        w.rapid(&[('X', 1.0)]).unwrap();
        assert!(matches!(
            w.rapid(&[('X', 2.0)]),
            Err(WriteError::LineNumber(100_000))
        ));
        assert_eq!(w.finish(), "N99990 G0 X1\n");
    }

    #[test]
    fn written_values_read_back() {
        let w = ProgramWriter::new(Dialect::LinuxCnc);
        assert_eq!(w.written('X', 1.23456).unwrap(), 1.2346);
        let f = ProgramWriter::new(FANUC);
        assert_eq!(f.written('X', 1.23456).unwrap(), 1.235);
        assert_eq!(f.number('X', 3.0).unwrap(), "3.");
        assert_eq!(f.plain(3.0).unwrap(), "3");
        assert_eq!(f.plain(-0.0001).unwrap(), "0");
        assert!(f.plain(f64::NAN).is_err());
    }
}
