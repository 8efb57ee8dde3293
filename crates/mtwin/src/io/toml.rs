//! Span-aware reading of small TOML files (machine model, `SERVO.toml`,
//! thermal model): every problem becomes a [`Diagnostic`] with the file and
//! the line of the offending key or value, and reading goes on so that all
//! problems are reported at once. Writing is in [`super::toml_write`].
//!
//! Messages name the value read by a `what` phrase chosen by the caller
//! (e.g. "`ts`" or "`origin` of [workpiece] (mm)").

use std::ops::Range;
use std::path::Path;

use nalgebra::Vector3;
use toml_edit::{Array, ImDocument, Item, TableLike, Value};

use super::{Diagnostic, Diagnostics};

/// Byte range of a key or value in the file text (`None`: unknown, the whole file).
pub(crate) type Span = Option<Range<usize>>;

/// Parse `text`; a syntax error becomes one diagnostic at its line.
pub(crate) fn parse<'t>(path: &Path, text: &'t str) -> Result<ImDocument<&'t str>, Diagnostics> {
    ImDocument::parse(text).map_err(|e| {
        let line = e.span().map_or(0, |s| line_of(text, s.start));
        let msg = e.message().trim().trim_end_matches('.').to_string();
        Diagnostics::from(Diagnostic::at_line(
            path,
            line,
            format!("not valid TOML: {msg}"),
        ))
    })
}

/// 1-based line of byte `offset` in `text`.
pub(crate) fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Something a number can be read from: a table entry ([`Item`]) or an array element ([`Value`]).
pub(crate) trait Node {
    /// The value, `None` for a table.
    fn as_toml_value(&self) -> Option<&Value>;
    /// Where it is.
    fn node_span(&self) -> Span;
    /// Its TOML type in words ("string", "table", …).
    fn node_type(&self) -> &'static str;
}

impl Node for Item {
    fn as_toml_value(&self) -> Option<&Value> {
        self.as_value()
    }
    fn node_span(&self) -> Span {
        self.span()
    }
    fn node_type(&self) -> &'static str {
        self.type_name()
    }
}

impl Node for Value {
    fn as_toml_value(&self) -> Option<&Value> {
        Some(self)
    }
    fn node_span(&self) -> Span {
        self.span()
    }
    fn node_type(&self) -> &'static str {
        self.type_name()
    }
}

/// A number within [`crate::limits::MAX_ABS_VALUE`]; `None` for anything else.
fn finite(v: &Value) -> Option<f64> {
    let x = match v {
        Value::Float(f) => *f.value(),
        Value::Integer(i) => *i.value() as f64,
        _ => return None,
    };
    crate::model::rules::why_not_number(x)
        .is_none()
        .then_some(x)
}

/// Why `v` is not accepted as a number, after `must be ` / `is `.
fn why_not_number(v: &Value) -> String {
    let x = match v {
        Value::Float(f) => *f.value(),
        Value::Integer(i) => *i.value() as f64,
        _ => return format!("a finite number, not {}", v.type_name()),
    };
    crate::model::rules::why_not_number(x).unwrap_or_default()
}

/// Collects the problems of one file while values are read from it.
pub(crate) struct TomlReader<'a> {
    path: &'a Path,
    line_starts: Vec<usize>,
    /// The problems found so far.
    pub diags: Diagnostics,
}

impl<'a> TomlReader<'a> {
    pub fn new(path: &'a Path, text: &str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        TomlReader {
            path,
            line_starts,
            diags: Diagnostics::default(),
        }
    }

    /// Line of a span (0, "the whole file", when unknown).
    pub fn line(&self, span: Span) -> usize {
        span.map_or(0, |r| self.line_starts.partition_point(|&s| s <= r.start))
    }

    /// Report an error at `span`.
    pub fn error(&mut self, span: Span, message: impl Into<String>) {
        let line = self.line(span);
        self.diags
            .push(Diagnostic::at_line(self.path, line, message));
    }

    /// Span of key `k` of `t` (of its value when the key has none).
    pub fn key_span(t: &dyn TableLike, k: &str) -> Span {
        t.get_key_value(k)
            .and_then(|(key, item)| key.span().or_else(|| item.span()))
    }

    /// Report every key of `t` not in `allowed`, listing the allowed keys.
    pub fn check_keys(&mut self, t: &dyn TableLike, allowed: &[&str], what: &str) {
        for (k, _) in t.iter() {
            if !allowed.contains(&k) {
                self.error(
                    Self::key_span(t, k),
                    format!(
                        "unknown key `{k}` in {what} (allowed: {})",
                        allowed.join(", ")
                    ),
                );
            }
        }
    }

    /// A required entry; a missing one is reported at `at` (the table's line).
    pub fn required<'t>(
        &mut self,
        t: &'t dyn TableLike,
        k: &str,
        what: &str,
        at: Span,
    ) -> Option<&'t Item> {
        let item = t.get(k);
        if item.is_none() {
            self.error(at, format!("{what} lacks the key `{k}`"));
        }
        item
    }

    /// An optional entry that must be a value, not a table.
    pub fn value<'t>(
        &mut self,
        t: &'t dyn TableLike,
        k: &str,
        what: &str,
        at: Span,
    ) -> Option<&'t Value> {
        match t.get(k) {
            Some(Item::Value(v)) => Some(v),
            Some(other) => {
                self.error(
                    other.span().or(at),
                    format!("`{k}` in {what} must be a value, not a table"),
                );
                None
            }
            None => None,
        }
    }

    /// A required entry that must be a value, not a table.
    pub fn required_value<'t>(
        &mut self,
        t: &'t dyn TableLike,
        k: &str,
        what: &str,
        at: Span,
    ) -> Option<&'t Value> {
        self.required(t, k, what, at.clone())?;
        self.value(t, k, what, at)
    }

    /// An array; anything else is reported with `message`.
    fn array<'n, N: Node + ?Sized>(&mut self, n: &'n N, message: String) -> Option<&'n Array> {
        let arr = n.as_toml_value().and_then(Value::as_array);
        if arr.is_none() {
            self.error(n.node_span(), message);
        }
        arr
    }

    /// A finite number (integer or float).
    pub fn number(&mut self, n: &(impl Node + ?Sized), what: &str) -> Option<f64> {
        let v = n.as_toml_value().and_then(finite);
        if v.is_none() {
            let why = match n.as_toml_value() {
                Some(x) => why_not_number(x),
                None => format!("a finite number, not {}", n.node_type()),
            };
            self.error(n.node_span(), format!("{what} must be {why}"));
        }
        v
    }

    /// A non-negative integer.
    pub fn count(&mut self, n: &(impl Node + ?Sized), what: &str) -> Option<usize> {
        match n.as_toml_value().and_then(Value::as_integer) {
            Some(i) if i >= 0 => usize::try_from(i).ok(),
            _ => {
                self.error(
                    n.node_span(),
                    format!("{what} must be a non-negative integer"),
                );
                None
            }
        }
    }

    /// A string.
    pub fn string(&mut self, n: &(impl Node + ?Sized), what: &str) -> Option<String> {
        match n.as_toml_value().and_then(Value::as_str) {
            Some(s) => Some(s.to_string()),
            None => {
                self.error(
                    n.node_span(),
                    format!("{what} must be a string, not {}", n.node_type()),
                );
                None
            }
        }
    }

    /// An array of finite numbers; every bad element is reported.
    pub fn numbers(&mut self, n: &(impl Node + ?Sized), what: &str) -> Option<Vec<f64>> {
        let arr = self.array(
            n,
            format!("{what} must be an array of numbers, not {}", n.node_type()),
        )?;
        let mut out = Vec::with_capacity(arr.len());
        let mut ok = true;
        for v in arr.iter() {
            match finite(v) {
                Some(x) => out.push(x),
                None => {
                    self.error(
                        v.span().or_else(|| n.node_span()),
                        format!("every element of {what} must be {}", why_not_number(v)),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }

    /// An array of arrays of finite numbers.
    pub fn number_rows(&mut self, n: &(impl Node + ?Sized), what: &str) -> Option<Vec<Vec<f64>>> {
        let arr = self.array(n, format!("{what} must be an array of arrays of numbers"))?;
        let mut out = Vec::with_capacity(arr.len());
        let mut ok = true;
        for v in arr.iter() {
            match v.as_array() {
                Some(inner) => match inner.iter().map(finite).collect::<Option<Vec<f64>>>() {
                    Some(r) => out.push(r),
                    None => {
                        let bad = inner.iter().find(|x| finite(x).is_none());
                        self.error(
                            v.span(),
                            format!(
                                "every element of {what} must be {}",
                                bad.map_or_else(|| "a finite number".into(), why_not_number)
                            ),
                        );
                        ok = false;
                    }
                },
                None => {
                    self.error(
                        v.span(),
                        format!("every element of {what} must be an array of numbers"),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }

    /// Three finite numbers.
    pub fn vec3(&mut self, n: &(impl Node + ?Sized), what: &str) -> Option<Vector3<f64>> {
        let v = self.numbers(n, what)?;
        if v.len() != 3 {
            self.error(
                n.node_span(),
                format!("{what} must have 3 numbers, it has {}", v.len()),
            );
            return None;
        }
        Some(Vector3::new(v[0], v[1], v[2]))
    }

    /// A unit vector: three numbers with |‖d‖ − 1| ≤ `tolerance`.
    pub fn unit3(
        &mut self,
        n: &(impl Node + ?Sized),
        what: &str,
        tolerance: f64,
    ) -> Option<Vector3<f64>> {
        let d = self.vec3(n, what)?;
        let norm = d.norm();
        if (norm - 1.0).abs() > tolerance {
            self.error(
                n.node_span(),
                format!("{what} must be a unit vector, its length is {norm}"),
            );
            return None;
        }
        Some(d)
    }

    /// An array of strings with their spans; `plural` and `one` name the
    /// elements in messages ("axis names", "an axis name").
    pub fn strings(
        &mut self,
        n: &(impl Node + ?Sized),
        what: &str,
        plural: &str,
        one: &str,
    ) -> Option<Vec<(String, Span)>> {
        let arr = self.array(n, format!("{what} must be an array of {plural}"))?;
        let mut out = Vec::with_capacity(arr.len());
        for x in arr.iter() {
            match x.as_str() {
                Some(s) => out.push((s.to_string(), x.span())),
                None => {
                    self.error(
                        x.span(),
                        format!("every element of {what} must be {one} in quotes"),
                    );
                    return None;
                }
            }
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_and_messages() {
        let text = "a = 1\nb = [1, \"x\", 3]\nc = 1\nd = [1, 0, 0.5]\n";
        let p = Path::new("f.toml");
        let doc = parse(p, text).unwrap();
        let root = doc.as_table();
        let mut r = TomlReader::new(p, text);
        r.check_keys(root, &["a", "b", "d"], "the file");
        assert_eq!(r.number(&root["a"], "`a`"), Some(1.0));
        assert_eq!(r.numbers(&root["b"], "`b`"), None);
        assert_eq!(r.count(&root["a"], "`a`"), Some(1));
        assert!(r.required(root, "e", "the file", None).is_none());
        // |(1, 0, 0.5)| = √1.25 is not 1.
        assert!(r.unit3(&root["d"], "`d`", 1e-9).is_none());
        let got: Vec<(usize, &str)> = r
            .diags
            .0
            .iter()
            .map(|d| (d.line, d.message.as_str()))
            .collect();
        assert_eq!(got.len(), 4);
        assert_eq!(
            got[..3],
            [
                (3, "unknown key `c` in the file (allowed: a, b, d)"),
                (
                    2,
                    "every element of `b` must be a finite number, not string"
                ),
                (0, "the file lacks the key `e`"),
            ]
        );
        assert_eq!(
            r.diags.0[3].message,
            format!(
                "`d` must be a unit vector, its length is {}",
                1.25f64.sqrt()
            )
        );
        let e = parse(p, "a = 1\nb = [\n").unwrap_err();
        assert_eq!(e.0[0].line, 3);
        assert!(e.0[0].message.starts_with("not valid TOML"));
    }
}
