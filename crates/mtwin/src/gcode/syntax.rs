//! The lossless syntax tree: a [`Block`] is one line of the program with its
//! exact bytes, its line end and the items found in it, each with the byte
//! span it came from. Writing a block writes its bytes, so an unchanged
//! program is reproduced byte for byte; editing a word splices only that
//! word's value.

use std::fmt::Write as _;
use std::io::{self, Write};

use super::error::GcodeError;
use super::lexer;

/// A half-open byte range `start..end` within a block's text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Span {
    /// First byte, 0-based.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

impl Span {
    pub(crate) const fn new(start: usize, end: usize) -> Self {
        Span { start, end }
    }

    /// The span after the bytes from `from` on moved by `delta`: a span
    /// starting at or after `from` moves; one ending exactly at `from` (and
    /// starting before it) stays, since it lies before the edit.
    fn shifted(self, from: usize, delta: isize) -> Span {
        let mv = |p: usize| p.saturating_add_signed(delta);
        let start = if self.start >= from {
            mv(self.start)
        } else {
            self.start
        };
        let end = if self.end > from || self.start >= from {
            mv(self.end)
        } else {
            self.end
        };
        Span { start, end }
    }
}

/// The value of a word as written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// A literal number (spaces inside it removed), in program units.
    Number(f64),
    /// An expression such as `[1+2]` or `sin[30]` (not evaluated).
    Expression,
    /// A parameter reference such as `#5` or `#<depth>` (not evaluated).
    Parameter,
}

/// A letter with its value, e.g. `X-1.5`, `g1`, `N10`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Word {
    /// Upper-case letter (the text keeps the original case).
    pub letter: u8,
    /// Byte offset of the letter in the block text.
    pub at: usize,
    /// The value.
    pub value: Value,
    /// Span of the value text, from its first to its last non-space byte.
    pub span: Span,
    /// Whether the number was written with a decimal point (Fanuc reads
    /// `X10` and `X10.` differently).
    pub has_point: bool,
}

impl Word {
    /// The literal number, if the value is one.
    pub fn number(&self) -> Option<f64> {
        match self.value {
            Value::Number(v) => Some(v),
            Value::Expression | Value::Parameter => None,
        }
    }
}

/// The two comment forms.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommentKind {
    /// `( ... )`, possibly between words.
    Paren,
    /// `; ...` to the end of the line.
    Semicolon,
}

/// One item of a block; whitespace between items is not an item but is
/// kept in the block text.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Item {
    /// A letter and its value.
    Word(Word),
    /// A comment, span including its delimiters.
    Comment {
        /// Parenthesised or to the end of the line.
        kind: CommentKind,
        /// Where it lies in the block's text.
        span: Span,
    },
    /// `/` as the first character: block delete.
    BlockDelete {
        /// Byte offset of the `/`.
        at: usize,
    },
    /// `%` as the first character: program start/end marker.
    Percent {
        /// Byte offset of the `%`.
        at: usize,
    },
    /// An O-word statement (`o100 sub`, `O1 if [..]`), to the end of the line.
    OWord {
        /// The statement's bytes in the block's text.
        span: Span,
    },
    /// A parameter assignment `#n = value`.
    Assignment {
        /// The assignment's bytes in the block's text.
        span: Span,
    },
}

/// How a line ended in the source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineEnd {
    /// Last line of a file that does not end with a newline.
    #[default]
    None,
    /// `\n`.
    Lf,
    /// `\r\n`.
    CrLf,
}

impl LineEnd {
    /// The bytes of the line end.
    pub fn as_bytes(self) -> &'static [u8] {
        match self {
            LineEnd::None => b"",
            LineEnd::Lf => b"\n",
            LineEnd::CrLf => b"\r\n",
        }
    }
}

/// How new numbers are written into a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NumberFormat {
    /// At most this many decimals, trailing zeros (and a bare point) removed:
    /// `Fixed(4)` writes 12.345 as `12.345`, 2.0 as `2`, 1/3 as `0.3333`.
    Fixed(u8),
    /// [`NumberFormat::Fixed`] that always keeps a decimal point (`2.0` is
    /// written `2.`): for controllers that read a number without a point in
    /// least increments (Fanuc without decimal point programming).
    FixedPoint(u8),
    /// The shortest decimal text that reads back to the same `f64`, never
    /// with an exponent (G-code has none).
    Shortest,
}

impl Default for NumberFormat {
    /// Four decimals: 0.1 µm in mm, 0.36 arcsec in degree.
    fn default() -> Self {
        NumberFormat::Fixed(4)
    }
}

impl NumberFormat {
    /// Appends `v` (finite) to `out`.
    pub fn write(self, v: f64, out: &mut String) {
        match self {
            NumberFormat::Fixed(d) => write_fixed(v, d, out),
            NumberFormat::FixedPoint(d) => {
                let start = out.len();
                write_fixed(v, d, out);
                if !out[start..].contains('.') {
                    out.push('.');
                }
            }
            // Display of f64 is shortest round-trip and never uses an
            // exponent; -0 is written as 0.
            NumberFormat::Shortest if v == 0.0 => out.push('0'),
            NumberFormat::Shortest => {
                let _ = write!(out, "{v}");
            }
        }
    }
}

/// "00", "01", …, "99": two decimal digits per lookup.
const DIGIT_PAIRS: &[u8; 200] = b"00010203040506070809101112131415161718192021222324252627282930313233343536373839404142434445464748495051525354555657585960616263646566676869707172737475767778798081828384858687888990919293949596979899";

/// Appends `v` with at most `decimals` decimals, trailing zeros removed.
/// Integer arithmetic when `|v|·10^decimals` fits exactly in an `f64`
/// integer (the common case), else the standard formatter.
fn write_fixed(v: f64, decimals: u8, out: &mut String) {
    const POW10: [f64; 16] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
    ];
    let d = usize::from(decimals);
    let scaled = POW10
        .get(d)
        .map_or(f64::INFINITY, |scale| (v.abs() * scale).round());
    if scaled >= 9.0e15 {
        let start = out.len();
        let _ = write!(out, "{v:.d$}");
        if out[start..].contains('.') {
            let trimmed = out.trim_end_matches('0').trim_end_matches('.').len();
            out.truncate(trimmed);
        }
        return;
    }
    let n = scaled as u64;
    let p = 10u64.pow(u32::from(decimals));
    let (mut int, mut frac) = (n / p, n % p);
    // Digits from the right into a stack buffer (at most '-', 16 integer digits, '.'
    // and 15 decimals), two at a time from a table, then one append.
    let mut buf = [0u8; 40];
    let mut i = buf.len();
    // Writes `k` (< 100) as two digits before `buf[i]`.
    fn pair(buf: &mut [u8; 40], i: &mut usize, k: u64) {
        *i -= 2;
        let k = 2 * k as usize;
        buf[*i..*i + 2].copy_from_slice(&DIGIT_PAIRS[k..k + 2]);
    }
    if frac != 0 {
        let mut width = d;
        while frac % 10 == 0 {
            frac /= 10;
            width -= 1;
        }
        while width >= 2 {
            pair(&mut buf, &mut i, frac % 100);
            frac /= 100;
            width -= 2;
        }
        if width == 1 {
            i -= 1;
            buf[i] = b'0' + frac as u8;
        }
        i -= 1;
        buf[i] = b'.';
    }
    while int >= 10 {
        pair(&mut buf, &mut i, int % 100);
        int /= 100;
    }
    // The leftmost digit of an odd count, or the 0 of a zero integer part
    // (nothing written for it yet).
    if int != 0 || i == buf.len() || buf[i] == b'.' {
        i -= 1;
        buf[i] = b'0' + int as u8;
    }
    if n != 0 && v < 0.0 {
        i -= 1;
        buf[i] = b'-';
    }
    // Only ASCII digits, '.' and '-' were written, so the check cannot fail; on at most
    // 40 bytes it costs a few nanoseconds.
    out.push_str(std::str::from_utf8(&buf[i..]).expect("ASCII digits"));
}

/// One block (line) of a program: its exact bytes and the items in them.
#[derive(Debug, Default, PartialEq)]
pub struct Block {
    text: Vec<u8>,
    eol: LineEnd,
    items: Vec<Item>,
    line: u64,
}

impl Clone for Block {
    fn clone(&self) -> Self {
        Block {
            text: self.text.clone(),
            eol: self.eol,
            items: self.items.clone(),
            line: self.line,
        }
    }

    /// Copies `source` into this block's buffers (no allocation once they
    /// are large enough: a rewriter copying every block reuses one).
    fn clone_from(&mut self, source: &Self) {
        self.text.clone_from(&source.text);
        self.eol = source.eol;
        self.items.clone_from(&source.items);
        self.line = source.line;
    }
}

impl Block {
    /// Parses one line. `text` may end with `\n` or `\r\n` (kept as the line
    /// end); `line` is the 1-based line number used in errors.
    pub fn parse(text: &[u8], line: u64) -> Result<Block, GcodeError> {
        let mut block = Block::default();
        block.reparse_from(text, line)?;
        Ok(block)
    }

    /// Parses a line into this block, reusing its buffers.
    pub(crate) fn reparse_from(&mut self, text: &[u8], line: u64) -> Result<(), GcodeError> {
        self.text.clear();
        self.text.extend_from_slice(text);
        if let Some(k) = split_eol(text).0.iter().position(|&c| c == b'\n') {
            self.items.clear();
            self.line = line;
            return Err(GcodeError::syntax(
                line,
                k + 1,
                "a block cannot contain a line feed",
            ));
        }
        self.parse_own_text(line)
    }

    /// The buffer a reader fills with the next line before
    /// [`Block::parse_own_text`] (saves one copy per line).
    pub(crate) fn text_buffer(&mut self) -> &mut Vec<u8> {
        self.text.clear();
        &mut self.text
    }

    /// Parses the line held in the text buffer (line end included; no other
    /// line feed).
    pub(crate) fn parse_own_text(&mut self, line: u64) -> Result<(), GcodeError> {
        let (body_len, eol) = {
            let (body, eol) = split_eol(&self.text);
            (body.len(), eol)
        };
        self.text.truncate(body_len);
        self.eol = eol;
        self.line = line;
        self.items.clear();
        // Readers split at line feeds and `reparse_from` checks, so the body
        // holds none.
        lexer::lex(&self.text, line, &mut self.items)
    }

    /// 1-based line number in the source.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// The block text without its line end.
    pub fn text(&self) -> &[u8] {
        &self.text
    }

    /// The line end.
    pub fn line_end(&self) -> LineEnd {
        self.eol
    }

    /// The items, in source order.
    pub fn items(&self) -> &[Item] {
        &self.items
    }

    /// The words, in source order.
    pub fn words(&self) -> impl Iterator<Item = &Word> {
        self.items.iter().filter_map(|it| match it {
            Item::Word(w) => Some(w),
            _ => None,
        })
    }

    /// The only word with this letter (case-insensitive); `None` when there
    /// is none, an error when there are several.
    pub fn word(&self, letter: char) -> Result<Option<&Word>, GcodeError> {
        let up = ascii_letter(letter)?;
        let mut found = None;
        for w in self.words().filter(|w| w.letter == up) {
            if found.is_some() {
                return Err(GcodeError::Edit(format!(
                    "line {} has more than one {} word",
                    self.line, up as char
                )));
            }
            found = Some(w);
        }
        Ok(found)
    }

    /// The original text of a word's value (e.g. `-1.50`, `[#1+2]`).
    pub fn value_text(&self, word: &Word) -> &str {
        // Value spans only ever cover ASCII bytes (the lexer checks them).
        std::str::from_utf8(&self.text[word.span.start..word.span.end]).unwrap_or("")
    }

    /// Whether the block starts with block delete `/`.
    pub fn is_block_delete(&self) -> bool {
        matches!(self.items.first(), Some(Item::BlockDelete { .. }))
    }

    /// Whether the block is a `%` line.
    pub fn is_percent(&self) -> bool {
        matches!(self.items.first(), Some(Item::Percent { .. }))
    }

    /// Writes the block and its line end.
    pub fn write_to<W: Write>(&self, out: &mut W) -> io::Result<()> {
        out.write_all(&self.text)?;
        out.write_all(self.eol.as_bytes())
    }

    /// Sets the value of the word `letter` (e.g. `'Z'`) to `value` with the
    /// default [`NumberFormat`], keeping every other byte; inserts the word
    /// if the block has none (see [`Block::set_word_with`]).
    pub fn set_word(&mut self, letter: char, value: f64) -> Result<(), GcodeError> {
        self.set_word_with(letter, value, NumberFormat::default())
    }

    /// As [`Block::set_word`] with an explicit number format. A new word is
    /// inserted after the axis word that precedes it in X Y Z A B C U V W
    /// order (or before the first one that follows it), else after the last
    /// word, before trailing comments, separated by a space when the block
    /// separates its words with spaces.
    pub fn set_word_with(
        &mut self,
        letter: char,
        value: f64,
        format: NumberFormat,
    ) -> Result<(), GcodeError> {
        if !value.is_finite() {
            return Err(GcodeError::Edit(format!(
                "{letter} value {value} is not finite"
            )));
        }
        let up = ascii_letter(letter)?;
        if matches!(up, b'O') {
            return Err(GcodeError::Edit("O-words cannot be set".into()));
        }
        if self.is_percent() {
            return Err(GcodeError::Edit(format!(
                "line {} is a '%' line: it takes no words",
                self.line
            )));
        }
        let mut index = None;
        for (k, it) in self.items.iter().enumerate() {
            if matches!(it, Item::Word(w) if w.letter == up) {
                if index.is_some() {
                    return Err(GcodeError::Edit(format!(
                        "line {} has more than one {} word",
                        self.line, up as char
                    )));
                }
                index = Some(k);
            }
        }
        // One formatting buffer per thread: no allocation per edit.
        thread_local!(static DIGITS: std::cell::RefCell<String> = const { std::cell::RefCell::new(String::new()) });
        DIGITS.with_borrow_mut(|digits| {
            digits.clear();
            format.write(value, digits);
            let digits = digits.as_str();
            match index.map(|k| (k, self.items[k])) {
                Some((k, Item::Word(w))) => {
                    self.splice(w.span, digits.as_bytes());
                    if let Item::Word(word) = &mut self.items[k] {
                        word.value = Value::Number(parse_back(digits, value));
                        word.has_point = digits.contains('.');
                        word.span.end = word.span.start + digits.len();
                    }
                    Ok(())
                }
                _ => self.insert_word(up, letter, digits, value),
            }
        })
    }

    /// Removes the word `letter` (and the spaces before it); returns whether
    /// there was one.
    pub fn remove_word(&mut self, letter: char) -> Result<bool, GcodeError> {
        let up = ascii_letter(letter)?;
        let Some(w) = self.word(letter)?.copied() else {
            return Ok(false);
        };
        let mut start = w.at;
        while start > 0 && lexer::is_space(self.text[start - 1]) {
            start -= 1;
        }
        if start == 0 {
            // Keep the block's leading text; drop the spaces after the word instead.
            start = w.at;
        }
        let mut end = w.span.end;
        if start == w.at {
            while end < self.text.len() && lexer::is_space(self.text[end]) {
                end += 1;
            }
        }
        let k = self
            .items
            .iter()
            .position(|it| matches!(it, Item::Word(x) if x.letter == up))
            .ok_or_else(|| GcodeError::Edit("word vanished".into()))?;
        self.items.remove(k);
        self.splice(Span::new(start, end), b"");
        Ok(true)
    }

    fn insert_word(
        &mut self,
        up: u8,
        letter: char,
        digits: &str,
        value: f64,
    ) -> Result<(), GcodeError> {
        use super::axes::Axis;
        let words: Vec<Word> = self.words().copied().collect();
        let order = |l: u8| Axis::from_letter(l).map(Axis::index);
        let new_order = order(up);
        // Insert after `anchor` (a word) or before `before` (a word).
        let mut after: Option<Word> = None;
        let mut before: Option<Word> = None;
        if let Some(n) = new_order {
            after = words
                .iter()
                .rev()
                .find(|w| order(w.letter).is_some_and(|o| o < n))
                .copied();
            if after.is_none() {
                before = words
                    .iter()
                    .find(|w| order(w.letter).is_some_and(|o| o > n))
                    .copied();
            }
        }
        if after.is_none() && before.is_none() {
            after = words.last().copied();
        }
        let spaced = words
            .windows(2)
            .any(|p| lexer::is_space(self.text[p[1].at - 1]))
            || words
                .first()
                .is_some_and(|w| w.at > 0 && lexer::is_space(self.text[w.at - 1]));
        let sep = if spaced || words.len() < 2 { " " } else { "" };
        let letter_text = letter.to_string();
        let (pos, bytes) = match (after, before) {
            (Some(w), _) => (w.span.end, format!("{sep}{letter_text}{digits}")),
            (None, Some(w)) => (w.at, format!("{letter_text}{digits}{sep}")),
            (None, None) => {
                // No words: after a leading '/' or at the start, before comments.
                let pos = match self.items.first() {
                    Some(Item::BlockDelete { at }) => at + 1,
                    _ => 0,
                };
                let tail = if pos < self.text.len() { " " } else { "" };
                (pos, format!("{letter_text}{digits}{tail}"))
            }
        };
        self.splice(Span::new(pos, pos), bytes.as_bytes());
        let at = if before.is_some() || after.is_none() {
            pos
        } else {
            pos + sep.len()
        };
        let word = Word {
            letter: up,
            at,
            value: Value::Number(parse_back(digits, value)),
            span: Span::new(at + 1, at + 1 + digits.len()),
            has_point: digits.contains('.'),
        };
        let k = self
            .items
            .iter()
            .position(|it| item_start(it) >= at)
            .unwrap_or(self.items.len());
        self.items.insert(k, Item::Word(word));
        Ok(())
    }

    /// Replaces the bytes of `span` by `bytes` and shifts every later span.
    fn splice(&mut self, span: Span, bytes: &[u8]) {
        let delta = bytes.len() as isize - (span.end - span.start) as isize;
        if delta == 0 {
            self.text[span.start..span.end].copy_from_slice(bytes);
            return;
        }
        let old_len = self.text.len();
        if delta > 0 {
            self.text.resize(old_len + delta.unsigned_abs(), 0);
        }
        let new_tail = span.start + bytes.len();
        self.text.copy_within(span.end..old_len, new_tail);
        self.text[span.start..new_tail].copy_from_slice(bytes);
        if delta < 0 {
            self.text.truncate(old_len - delta.unsigned_abs());
        }
        let from = span.end;
        for it in &mut self.items {
            match it {
                Item::Word(w) => {
                    if w.at >= from {
                        w.at = w.at.saturating_add_signed(delta);
                    }
                    w.span = w.span.shifted(from, delta);
                }
                Item::Comment { span: s, .. }
                | Item::OWord { span: s }
                | Item::Assignment { span: s } => {
                    *s = s.shifted(from, delta);
                }
                Item::BlockDelete { at } | Item::Percent { at } => {
                    if *at >= from {
                        *at = at.saturating_add_signed(delta);
                    }
                }
            }
        }
    }
}

fn item_start(it: &Item) -> usize {
    match it {
        Item::Word(w) => w.at,
        Item::Comment { span, .. } | Item::OWord { span } | Item::Assignment { span } => span.start,
        Item::BlockDelete { at } | Item::Percent { at } => *at,
    }
}

/// The value a formatted number reads back as (what a controller will see).
fn parse_back(digits: &str, fallback: f64) -> f64 {
    lexer::fast_decimal(digits.as_bytes())
        .or_else(|| digits.parse().ok())
        .unwrap_or(fallback)
}

fn ascii_letter(letter: char) -> Result<u8, GcodeError> {
    if letter.is_ascii_alphabetic() {
        Ok(letter.to_ascii_uppercase() as u8)
    } else {
        Err(GcodeError::Edit(format!("{letter:?} is not a word letter")))
    }
}

fn split_eol(text: &[u8]) -> (&[u8], LineEnd) {
    match text {
        [body @ .., b'\r', b'\n'] => (body, LineEnd::CrLf),
        [body @ .., b'\n'] => (body, LineEnd::Lf),
        _ => (text, LineEnd::None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn written(b: &Block) -> Vec<u8> {
        let mut out = Vec::new();
        b.write_to(&mut out).unwrap();
        out
    }

    #[test]
    fn keeps_every_byte_and_reads_spaced_numbers() {
        let src = b"N10 g1 X - 1 2.5 (c) y#1 ; tail\r\n";
        let b = Block::parse(src, 7).unwrap();
        assert_eq!(written(&b), src);
        assert_eq!(b.line_end(), LineEnd::CrLf);
        let x = b.word('x').unwrap().unwrap();
        assert_eq!(x.number(), Some(-12.5));
        assert_eq!(b.value_text(x), "- 1 2.5");
        assert_eq!(b.word('Y').unwrap().unwrap().value, Value::Parameter);
        let kinds: Vec<&str> = b
            .items()
            .iter()
            .map(|i| match i {
                Item::Word(_) => "w",
                Item::Comment {
                    kind: CommentKind::Paren,
                    ..
                } => "(",
                Item::Comment {
                    kind: CommentKind::Semicolon,
                    ..
                } => ";",
                _ => "?",
            })
            .collect();
        assert_eq!(kinds, ["w", "w", "w", "(", "w", ";"]);
    }

    #[test]
    fn percent_block_delete_oword_and_assignment_lines() {
        assert!(Block::parse(b"%\n", 1).unwrap().is_percent());
        assert!(Block::parse(b"/G0 X1", 1).unwrap().is_block_delete());
        let o = Block::parse(b"o<sub> call [1] (x)", 1).unwrap();
        assert!(matches!(o.items(), [Item::OWord { span }] if span.end == 19));
        let a = Block::parse(b"#1 = [2 * 3] #<x>=-sin[30]", 1).unwrap();
        assert_eq!(a.items().len(), 2);
        let f = Block::parse(b"G1 X atan[1]/[2]", 1).unwrap();
        assert_eq!(f.word('X').unwrap().unwrap().value, Value::Expression);
    }

    #[test]
    fn errors_name_line_and_column() {
        let cases: [(&[u8], u32); 7] = [
            (b"G1 X1 (open", 7),
            (b"G1 X", 5),
            (b"G1 $", 4),
            // `@` is a word letter (LinuxCNC's polar distance).
            (b"G1 @", 5),
            (b"G1 X1.2.3", 8),
            (b"(a (b))", 4),
            (b"G1 X[1+2", 5),
        ];
        for (src, column) in cases {
            match Block::parse(src, 3) {
                Err(GcodeError::Syntax { at, .. }) => {
                    assert_eq!(
                        (at.line, at.column),
                        (3, column),
                        "{}",
                        String::from_utf8_lossy(src)
                    );
                }
                other => panic!("{}: {other:?}", String::from_utf8_lossy(src)),
            }
        }
    }

    #[test]
    fn set_word_replaces_only_the_value() {
        let mut b = Block::parse(b"G1 X1.000 z-2.5000 F100 (keep)\n", 1).unwrap();
        b.set_word('Z', 12.345).unwrap();
        assert_eq!(written(&b), b"G1 X1.000 z12.345 F100 (keep)\n");
        assert_eq!(b.word('Z').unwrap().unwrap().number(), Some(12.345));
        // Later spans moved with the edit.
        b.set_word('F', 250.0).unwrap();
        assert_eq!(written(&b), b"G1 X1.000 z12.345 F250 (keep)\n");
        b.set_word('X', -0.00001).unwrap();
        assert_eq!(b.text(), b"G1 X0 z12.345 F250 (keep)");
        // The block reads back the same after editing.
        assert_eq!(Block::parse(&written(&b), 1).unwrap(), b);
    }

    #[test]
    fn set_word_inserts_in_axis_order() {
        let cases: [(&[u8], char, &[u8]); 5] = [
            (b"G1X1F100", 'Y', b"G1X1Y2F100"),
            (b"G0 Z5", 'X', b"G0 X2 Z5"),
            (b"G0 X1 Y1 F3 (c)", 'A', b"G0 X1 Y1 A2 F3 (c)"),
            (b"(only a comment)", 'X', b"X2 (only a comment)"),
            (b"/G0 C4", 'B', b"/G0 B2 C4"),
        ];
        for (src, letter, expected) in cases {
            let mut b = Block::parse(src, 1).unwrap();
            b.set_word(letter, 2.0).unwrap();
            assert_eq!(b.text(), expected, "{}", String::from_utf8_lossy(src));
            assert_eq!(Block::parse(b.text(), 1).unwrap().items(), b.items());
        }
    }

    #[test]
    fn remove_word_and_edit_errors() {
        let mut b = Block::parse(b"G1 X1 Y2 Z3", 1).unwrap();
        assert!(b.remove_word('Y').unwrap());
        assert_eq!(b.text(), b"G1 X1 Z3");
        assert!(!b.remove_word('Y').unwrap());
        assert!(b.set_word('Z', f64::NAN).is_err());
        let mut g = Block::parse(b"G1 G90 X1", 1).unwrap();
        assert!(g.set_word('G', 0.0).is_err(), "two G words: ambiguous");
    }

    #[test]
    fn number_formats() {
        let f = |fmt: NumberFormat, v: f64| {
            let mut s = String::new();
            fmt.write(v, &mut s);
            s
        };
        assert_eq!(f(NumberFormat::Fixed(4), 1.0 / 3.0), "0.3333");
        assert_eq!(f(NumberFormat::Fixed(4), 2.0), "2");
        assert_eq!(f(NumberFormat::Fixed(4), 0.05), "0.05");
        assert_eq!(f(NumberFormat::Fixed(4), -1.0005), "-1.0005");
        assert_eq!(f(NumberFormat::Fixed(3), 1234567.8915), "1234567.892");
        assert_eq!(
            f(NumberFormat::Fixed(2), 1e300),
            format!("{:.2}", 1e300)
                .trim_end_matches('0')
                .trim_end_matches('.')
        );
        assert_eq!(f(NumberFormat::Fixed(4), -2.5), "-2.5");
        assert_eq!(f(NumberFormat::FixedPoint(4), 2.0), "2.");
        assert_eq!(f(NumberFormat::FixedPoint(4), -2.5), "-2.5");
        assert_eq!(f(NumberFormat::FixedPoint(4), 0.0), "0.");
        assert_eq!(f(NumberFormat::Fixed(4), -0.00001), "0");
        assert_eq!(f(NumberFormat::Shortest, 1e-7), "0.0000001");
        assert_eq!(f(NumberFormat::Shortest, 0.1 + 0.2), "0.30000000000000004");
    }

    proptest::proptest! {
        /// The digit writer against a plain reference: the rounded scaled integer in
        /// decimal, the point inserted `d` digits from the right, zeros trimmed.
        #[test]
        fn fixed_matches_the_scaled_integer(v in -1e9f64..1e9, d in 0u8..=6, tiny in proptest::bool::ANY) {
            let v = if tiny { v * 1e-9 } else { v };
            let n = (v.abs() * 10f64.powi(i32::from(d))).round() as u64;
            let digits = format!("{n:0>width$}", width = usize::from(d) + 1);
            let (int, frac) = digits.split_at(digits.len() - usize::from(d));
            let frac = frac.trim_end_matches('0');
            let mut want = String::new();
            if n != 0 && v < 0.0 {
                want.push('-');
            }
            want.push_str(int);
            if !frac.is_empty() {
                want.push('.');
                want.push_str(frac);
            }
            let mut got = String::new();
            NumberFormat::Fixed(d).write(v, &mut got);
            proptest::prop_assert_eq!(got, want);
        }
    }
}
