//! Lexer: one line of bytes to the items of a block, keeping byte spans so
//! that the line can be written back unchanged.
//!
//! The rules are LinuxCNC's RS-274/NGC ones: letters are case-insensitive,
//! spaces and tabs are allowed anywhere outside comments (even inside a
//! number, `X1 2.5` is `X12.5`), `( )` comments end on the same line and do
//! not nest, `;` comments run to the end of the line, `/` as the first
//! character is block delete and a line starting with `%` marks the program
//! start/end. `@` and `^` are word letters (LinuxCNC's polar distance
//! and angle). Values that are expressions (`[..]`, functions such as
//! `sin[..]`) or parameters (`#5`, `#<name>`) and O-word statements are kept
//! as such, so every such program still round-trips; the interpreter
//! evaluates constant expressions and rejects the rest as unsupported.

use super::error::GcodeError;
use super::syntax::{CommentKind, Item, Span, Value, Word};

/// Unary functions of RS-274/NGC expressions (upper case).
const FUNCTIONS: [&[u8]; 14] = [
    b"ABS", b"ACOS", b"ASIN", b"ATAN", b"COS", b"EXP", b"FIX", b"FUP", b"ROUND", b"LN", b"SIN",
    b"SQRT", b"TAN", b"EXISTS",
];

/// Whitespace between words: space, tab, and a carriage return that is not
/// part of the line end.
pub(crate) fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// Splits `text` (one line, without its line end) into items, appended to
/// `items`. `line` is only used for error locations.
pub(crate) fn lex(text: &[u8], line: u64, items: &mut Vec<Item>) -> Result<(), GcodeError> {
    let mut lx = Lexer {
        b: text,
        i: 0,
        line,
    };
    let mut first = true;
    // Nothing but a block delete '/' read yet: where a line number may stand.
    let mut at_start = true;
    loop {
        lx.skip_space();
        let Some(c) = lx.peek() else { break };
        let start = lx.i;
        match c {
            b'(' => {
                let end = lx.paren_comment_end()?;
                items.push(Item::Comment {
                    kind: CommentKind::Paren,
                    span: Span::new(start, end),
                });
                lx.i = end;
            }
            b';' => {
                items.push(Item::Comment {
                    kind: CommentKind::Semicolon,
                    span: Span::new(start, text.len()),
                });
                lx.i = text.len();
            }
            b'%' if first => {
                items.push(Item::Percent { at: start });
                lx.i += 1;
            }
            b'/' if first => {
                items.push(Item::BlockDelete { at: start });
                lx.i += 1;
            }
            // Fanuc: `:1234` is the program number line `O1234` (ISO code);
            // read as an O-word, which the LinuxCNC dialect refuses.
            b':' if at_start => {
                items.push(Item::OWord {
                    span: Span::new(start, text.len()),
                });
                lx.i = text.len();
            }
            b'#' => {
                lx.parameter()?;
                lx.skip_space();
                if lx.peek() != Some(b'=') {
                    return Err(lx.err("a parameter reference must be followed by '=' here"));
                }
                lx.i += 1;
                lx.real_value()?;
                items.push(Item::Assignment {
                    span: Span::new(start, lx.i),
                });
            }
            // LinuxCNC's polar coordinates: `@` the distance, `^` the angle.
            c if c.is_ascii_alphabetic() || c == b'@' || c == b'^' => {
                let letter = c.to_ascii_uppercase();
                if letter == b'O' {
                    // An O-word statement (sub, call, if, while, ...) runs to the
                    // end of the line; its comments are part of it.
                    items.push(Item::OWord {
                        span: Span::new(start, text.len()),
                    });
                    lx.i = text.len();
                } else {
                    lx.i += 1;
                    if letter == b'N' {
                        lx.line_number(at_start)?;
                    }
                    let (value, span, has_point) = lx.real_value()?;
                    items.push(Item::Word(Word {
                        letter,
                        at: start,
                        value,
                        span,
                        has_point,
                    }));
                }
            }
            _ => {
                return Err(lx.err(format!("unexpected character {}", show_byte(c))));
            }
        }
        // Only a first item can be a block delete (a later '/' is refused above).
        at_start &= first && c == b'/';
        first = false;
    }
    Ok(())
}

fn show_byte(c: u8) -> String {
    if c.is_ascii_graphic() {
        format!("'{}'", c as char)
    } else {
        format!("byte 0x{c:02x}")
    }
}

struct Lexer<'a> {
    b: &'a [u8],
    i: usize,
    line: u64,
}

impl Lexer<'_> {
    fn peek(&self) -> Option<u8> {
        self.b.get(self.i).copied()
    }

    fn skip_space(&mut self) {
        while self.peek().is_some_and(is_space) {
            self.i += 1;
        }
    }

    #[cold]
    #[inline(never)]
    fn err(&self, message: impl Into<String>) -> GcodeError {
        GcodeError::syntax(self.line, self.i + 1, message)
    }

    /// Checks the line number after an `N` at `self.i` as LinuxCNC reads
    /// it: only at the start of the block (after an optional `/`), and an
    /// unsigned integer, optionally with a fraction (`N10`, `N10.5`), never
    /// a sign, expression or parameter.
    fn line_number(&self, at_start: bool) -> Result<(), GcodeError> {
        if !at_start {
            return Err(GcodeError::syntax(
                self.line,
                self.i,
                "a line number (N word) may only start the block",
            ));
        }
        let mut j = self.i;
        while self.b.get(j).copied().is_some_and(is_space) {
            j += 1;
        }
        if !self.b.get(j).is_some_and(u8::is_ascii_digit) {
            return Err(GcodeError::syntax(
                self.line,
                j + 1,
                "a line number (N word) must be an unsigned integer",
            ));
        }
        Ok(())
    }

    /// End (exclusive) of the `( )` comment starting at `self.i`.
    fn paren_comment_end(&self) -> Result<usize, GcodeError> {
        for (k, &c) in self.b[self.i + 1..].iter().enumerate() {
            match c {
                b')' => return Ok(self.i + 1 + k + 1),
                b'(' => {
                    return Err(GcodeError::syntax(
                        self.line,
                        self.i + 1 + k + 1,
                        "nested comment: '(' inside a ( ) comment",
                    ));
                }
                _ => {}
            }
        }
        Err(self.err("comment '(' is not closed on this line"))
    }

    /// Reads a value after a word letter or '='; returns it with the span of
    /// its text (from its first to its last non-space byte) and whether a
    /// number had a decimal point.
    fn real_value(&mut self) -> Result<(Value, Span, bool), GcodeError> {
        self.skip_space();
        let start = self.i;
        if let Some(plain) = self.plain_number(start) {
            return Ok(plain);
        }
        let mut j = self.i;
        // Optional sign, possibly followed by spaces.
        if matches!(self.peek(), Some(b'+' | b'-')) {
            j += 1;
            while self.b.get(j).copied().is_some_and(is_space) {
                j += 1;
            }
        }
        match self.b.get(j).copied() {
            Some(b'0'..=b'9' | b'.') => self.number(start),
            Some(b'[') => {
                self.i = j;
                self.bracket()?;
                Ok((Value::Expression, Span::new(start, self.i), false))
            }
            Some(b'#') => {
                self.i = j;
                self.parameter()?;
                Ok((Value::Parameter, Span::new(start, self.i), false))
            }
            Some(c) if c.is_ascii_alphabetic() => {
                self.function_call(j, "a word letter must be followed by a number")?;
                Ok((Value::Expression, Span::new(start, self.i), false))
            }
            _ => {
                self.i = j;
                Err(self.err("a word letter must be followed by a number"))
            }
        }
    }

    /// A function call `NAME[..]` (`ATAN[..]/[..]`) whose name starts at
    /// `j`; `not_function` is the error when the letters there name none.
    fn function_call(&mut self, j: usize, not_function: &str) -> Result<(), GcodeError> {
        let name_end = j + self.b[j..]
            .iter()
            .take_while(|c| c.is_ascii_alphabetic())
            .count();
        let name = self.b[j..name_end].to_ascii_uppercase();
        if !FUNCTIONS.contains(&name.as_slice()) {
            self.i = j;
            return Err(self.err(not_function));
        }
        self.i = name_end;
        self.skip_space();
        if self.peek() != Some(b'[') {
            return Err(self.err("a function name must be followed by '['"));
        }
        self.bracket()?;
        if name == b"ATAN" {
            self.skip_space();
            if self.peek() == Some(b'/') {
                self.i += 1;
                self.skip_space();
                if self.peek() != Some(b'[') {
                    return Err(self.err("ATAN[..] must be followed by /[..]"));
                }
                self.bracket()?;
            }
        }
        Ok(())
    }

    /// A number starting at `start` (sign, digits, one '.', spaces allowed
    /// between the characters). Short decimals are converted while scanning
    /// (see [`fast_decimal`]); others by the standard parser.
    fn number(&mut self, start: usize) -> Result<(Value, Span, bool), GcodeError> {
        if let Some(plain) = self.plain_number(start) {
            return Ok(plain);
        }
        let b = self.b;
        let mut j = start;
        let mut end = start; // exclusive end of the last significant byte
        let mut has_point = false;
        let mut has_digit = false;
        let mut spaced = false;
        let mut negative = false;
        let mut mantissa: u64 = 0;
        let mut significant = 0u32;
        let mut decimals = 0usize;
        if let Some(&c @ (b'+' | b'-')) = b.get(j) {
            negative = c == b'-';
            j += 1;
            end = j;
        }
        while j < b.len() {
            let c = b[j];
            if c.is_ascii_digit() {
                has_digit = true;
                if mantissa != 0 || c != b'0' {
                    significant += 1;
                }
                if significant <= 15 {
                    mantissa = mantissa * 10 + u64::from(c - b'0');
                }
                decimals += usize::from(has_point);
                j += 1;
                end = j;
            } else if c == b'.' {
                if has_point {
                    self.i = j;
                    return Err(self.err("a number has two decimal points"));
                }
                has_point = true;
                j += 1;
                end = j;
            } else if is_space(c) {
                j += 1;
                spaced = true;
            } else {
                break;
            }
        }
        if !has_digit {
            self.i = start;
            return Err(self.err("a number needs at least one digit"));
        }
        let text = &b[start..end];
        let value = if significant <= 15 && decimals < POW10.len() {
            let v = mantissa as f64 / POW10[decimals];
            Some(if negative { -v } else { v })
        } else if spaced {
            let compact: Vec<u8> = text.iter().copied().filter(|&c| !is_space(c)).collect();
            parse_f64(&compact)
        } else {
            parse_f64(text)
        };
        self.i = end;
        match value {
            Some(v) => Ok((Value::Number(v), Span::new(start, end), has_point)),
            None => {
                self.i = start;
                Err(self.err("malformed number"))
            }
        }
    }

    /// [`Self::number`] of the common case, in one pass without branches
    /// per byte besides the digit test: an optional sign, then at most 15
    /// digits (leading zeros included) with at most one point, no space
    /// inside, not followed by spaces and more of the number. The value is
    /// that of the general path's fast case ([`fast_decimal`]), bit for bit.
    /// `None` for anything else, which the general path then reads (and
    /// reports errors of).
    #[inline]
    fn plain_number(&mut self, start: usize) -> Option<(Value, Span, bool)> {
        let b = self.b;
        let mut j = start;
        let negative = match b.get(j) {
            Some(b'-') => {
                j += 1;
                true
            }
            Some(b'+') => {
                j += 1;
                false
            }
            _ => false,
        };
        let mut mantissa: u64 = 0;
        let first = j;
        while let Some(&c) = b.get(j)
            && c.is_ascii_digit()
        {
            // Wrapping: more than 15 digits are refused below.
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
            j += 1;
        }
        let mut digits = j - first;
        let mut decimals = 0;
        let has_point = b.get(j) == Some(&b'.');
        if has_point {
            j += 1;
            let fraction = j;
            while let Some(&c) = b.get(j)
                && c.is_ascii_digit()
            {
                mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
                j += 1;
            }
            decimals = j - fraction;
            digits += decimals;
        }
        if digits == 0 || digits > 15 {
            return None;
        }
        match b.get(j) {
            // A second point: an error the general path reports.
            Some(b'.') => return None,
            // Spaces may stand inside a number (`X1 2.5`): only when no
            // digit or point follows them does the number end here.
            Some(&c) if is_space(c) => {
                let mut k = j + 1;
                while b.get(k).copied().is_some_and(is_space) {
                    k += 1;
                }
                if matches!(b.get(k), Some(b'0'..=b'9' | b'.')) {
                    return None;
                }
            }
            _ => {}
        }
        // Exact: mantissa < 10^15 < 2^53 and decimals ≤ 15 (see `fast_decimal`).
        let v = mantissa as f64 / POW10[decimals];
        self.i = j;
        Some((
            Value::Number(if negative { -v } else { v }),
            Span::new(start, j),
            has_point,
        ))
    }

    /// A balanced `[ ... ]` starting at `self.i`.
    fn bracket(&mut self) -> Result<(), GcodeError> {
        let open = self.i;
        let mut depth = 0usize;
        while let Some(c) = self.peek() {
            match c {
                b'[' => depth += 1,
                b']' => {
                    depth -= 1;
                    if depth == 0 {
                        self.i += 1;
                        return Ok(());
                    }
                }
                b'(' | b';' => break,
                _ => {}
            }
            self.i += 1;
        }
        Err(GcodeError::syntax(
            self.line,
            open + 1,
            "'[' is not closed on this line",
        ))
    }

    /// A parameter reference `#n`, `#<name>`, `#[..]`, `##n` or, as
    /// LinuxCNC reads any value after `#`, a function call
    /// (`#atan[1]/[1]` is `#45`) at `self.i`.
    fn parameter(&mut self) -> Result<(), GcodeError> {
        self.i += 1; // '#'
        self.skip_space();
        match self.peek() {
            Some(b'<') => match self.b[self.i..].iter().position(|&c| c == b'>') {
                Some(k) => {
                    self.i += k + 1;
                    Ok(())
                }
                None => Err(self.err("parameter name '<' is not closed by '>'")),
            },
            Some(b'[') => self.bracket(),
            Some(b'#') => self.parameter(),
            Some(b'0'..=b'9') => self.number(self.i).map(|_| ()),
            Some(c) if c.is_ascii_alphabetic() => self.function_call(
                self.i,
                "'#' must be followed by a parameter number or <name>",
            ),
            _ => Err(self.err("'#' must be followed by a parameter number or <name>")),
        }
    }
}

/// Powers of ten exactly representable in an `f64`.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Exact fast path for short decimals (Clinger): with at most 15
/// significant digits and at most 22 decimals, `mantissa / 10^k` is one
/// correctly rounded division of two exactly representable numbers, so it
/// equals the correctly rounded value of the decimal. `None` otherwise.
/// `text` holds a sign, digits, at most one point and spaces.
pub(crate) fn fast_decimal(text: &[u8]) -> Option<f64> {
    let mut mantissa: u64 = 0;
    let mut digits = 0u32;
    let mut decimals = 0usize;
    let mut in_fraction = false;
    let mut negative = false;
    for &c in text {
        match c {
            b'0'..=b'9' => {
                if mantissa != 0 || c != b'0' {
                    digits += 1;
                }
                if digits > 15 {
                    return None;
                }
                mantissa = mantissa * 10 + u64::from(c - b'0');
                decimals += usize::from(in_fraction);
            }
            b'.' => in_fraction = true,
            b'-' => negative = true,
            _ => {}
        }
    }
    let v = mantissa as f64 / *POW10.get(decimals)?;
    Some(if negative { -v } else { v })
}

/// Parses an ASCII decimal number (sign, digits, at most one point).
fn parse_f64(text: &[u8]) -> Option<f64> {
    // The lexer only passes ASCII, so this cannot fail; stay total anyway.
    let s = std::str::from_utf8(text).ok()?;
    let v: f64 = s.parse().ok()?;
    v.is_finite().then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The value, span and point flag of the one word of `line`.
    fn one_word(line: &str) -> Result<(f64, Span, bool), GcodeError> {
        let mut items = Vec::new();
        lex(line.as_bytes(), 1, &mut items)?;
        match items.as_slice() {
            [Item::Word(w)] => match w.value {
                Value::Number(v) => Ok((v, w.span, w.has_point)),
                _ => panic!("{line}: not a number"),
            },
            other => panic!("{line}: {other:?}"),
        }
    }

    #[test]
    fn numbers_read_as_the_standard_parser_reads_them() {
        // Plain numbers (one pass) and every form the general path reads:
        // spaces inside, after the sign, 16+ digits, trailing spaces.
        for (text, compact) in [
            ("40.498", "40.498"),
            ("-0.000", "-0.000"),
            ("+.5", "+.5"),
            ("7.", "7."),
            ("0012", "0012"),
            ("123456789012345", "123456789012345"),
            ("1234567890.12345", "1234567890.12345"),
            ("0.1234567890123456789", "0.1234567890123456789"),
            ("12345678901234567890123", "12345678901234567890123"),
            ("1 2.5", "12.5"),
            ("1 .5", "1.5"),
            ("- 5", "-5"),
            ("3.25  ", "3.25"),
            ("3.25\t", "3.25"),
        ] {
            let line = format!("X{text}");
            let (v, span, point) = one_word(&line).unwrap();
            let want: f64 = compact.parse().unwrap();
            assert_eq!(v.to_bits(), want.to_bits(), "{line}");
            assert_eq!(point, compact.contains('.'), "{line}");
            let trimmed = line.trim_end().len();
            assert_eq!((span.start, span.end), (1, trimmed), "{line}");
        }
        // A word after the number ends it, spaces or not.
        let mut items = Vec::new();
        lex(b"X1.5Y-2 Z3", 1, &mut items).unwrap();
        let values: Vec<f64> = items
            .iter()
            .map(|i| match i {
                Item::Word(Word {
                    value: Value::Number(v),
                    ..
                }) => *v,
                _ => panic!(),
            })
            .collect();
        assert_eq!(values, [1.5, -2.0, 3.0]);
        for bad in ["X1.2.3", "X1. 2.3", "X.", "X-"] {
            assert!(one_word(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn fast_path_agrees_with_the_standard_parser() {
        for t in [
            "0",
            "-0.5",
            "123.456",
            ".001",
            "7.",
            "999999999999999",
            "0.1234567890123456789012",
            "-12.3456",
        ] {
            let std: f64 = t.parse().unwrap();
            match fast_decimal(t.as_bytes()) {
                Some(v) => assert_eq!(v.to_bits(), std.to_bits(), "{t}"),
                None => assert!(t.len() > 16, "{t} should take the fast path"),
            }
        }
        assert_eq!(fast_decimal(b"- 1 2.5"), Some(-12.5));
        assert_eq!(
            fast_decimal(b"1234567890123456"),
            None,
            "16 digits: exactness not guaranteed"
        );
    }
}
