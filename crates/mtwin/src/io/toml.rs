//! Span-aware reading of the TOML model files (machine, servo, thermal):
//! every problem becomes a [`Diagnostic`] with the file and the line of the
//! offending key or value, and reading goes on so that all problems are
//! reported at once. Each file's schema lives with its domain module
//! (`model::toml_read`, `sysid::servo_fit`, `methods::thermal::file`); the
//! primitives they share live here.

use std::ops::Range;
use std::path::Path;

use toml_edit::{ImDocument, Item, TableLike};

use crate::io::{Diagnostic, Diagnostics};

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

/// Collects the problems of one file while values are read from it.
pub(crate) struct Reader<'a> {
    pub path: &'a Path,
    /// Byte offset of the start of every line.
    line_starts: Vec<usize>,
    pub diags: Diagnostics,
}

impl<'a> Reader<'a> {
    pub fn new(path: &'a Path, text: &str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Reader {
            path,
            line_starts,
            diags: Diagnostics::default(),
        }
    }

    /// 1-based line of a span (0, "the whole file", when unknown).
    pub fn line(&self, span: Option<Range<usize>>) -> usize {
        span.map_or(0, |s| self.line_starts.partition_point(|&l| l <= s.start))
    }

    pub fn error(&mut self, span: Option<Range<usize>>, message: impl Into<String>) {
        let line = self.line(span);
        self.diags
            .push(Diagnostic::at_line(self.path, line, message));
    }

    /// Span of key `key` of `table` (else of its value).
    pub fn key_span(table: &dyn TableLike, key: &str) -> Option<Range<usize>> {
        table
            .get_key_value(key)
            .and_then(|(k, item)| k.span().or_else(|| item.span()))
    }

    /// Report every key of `table` not in `allowed`.
    pub fn check_keys(&mut self, table: &dyn TableLike, allowed: &[&str], what: &str) {
        for (key, _) in table.iter() {
            if !allowed.contains(&key) {
                let span = Self::key_span(table, key);
                self.error(
                    span,
                    format!(
                        "unknown key `{key}` in {what} (allowed: {})",
                        allowed.join(", ")
                    ),
                );
            }
        }
    }

    /// A required item; a missing one is reported at `at` (the table's line).
    pub fn required<'t>(
        &mut self,
        table: &'t dyn TableLike,
        key: &str,
        what: &str,
        at: Option<Range<usize>>,
    ) -> Option<&'t Item> {
        let item = table.get(key);
        if item.is_none() {
            self.error(at, format!("{what} lacks the key `{key}`"));
        }
        item
    }

    /// A finite number (integer or float).
    pub fn number(&mut self, item: &Item, key: &str) -> Option<f64> {
        let v = item
            .as_float()
            .or_else(|| item.as_integer().map(|i| i as f64));
        match v {
            Some(v) if v.is_finite() => Some(v),
            _ => {
                self.error(
                    item.span(),
                    format!("`{key}` must be a finite number, not {}", item.type_name()),
                );
                None
            }
        }
    }

    /// A non-negative integer.
    pub fn count(&mut self, item: &Item, key: &str) -> Option<usize> {
        match item.as_integer() {
            Some(i) if i >= 0 => usize::try_from(i).ok(),
            _ => {
                self.error(
                    item.span(),
                    format!("`{key}` must be a non-negative integer"),
                );
                None
            }
        }
    }

    /// A string.
    pub fn string(&mut self, item: &Item, key: &str) -> Option<String> {
        match item.as_str() {
            Some(s) => Some(s.to_string()),
            None => {
                self.error(
                    item.span(),
                    format!("`{key}` must be a string, not {}", item.type_name()),
                );
                None
            }
        }
    }

    /// An array of finite numbers.
    pub fn numbers(&mut self, item: &Item, key: &str) -> Option<Vec<f64>> {
        let Some(arr) = item.as_array() else {
            self.error(
                item.span(),
                format!(
                    "`{key}` must be an array of numbers, not {}",
                    item.type_name()
                ),
            );
            return None;
        };
        let mut out = Vec::with_capacity(arr.len());
        let mut ok = true;
        for v in arr.iter() {
            match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
                Some(x) if x.is_finite() => out.push(x),
                _ => {
                    let span = v.span().or_else(|| item.span());
                    self.error(
                        span,
                        format!("every element of `{key}` must be a finite number"),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }

    /// An array of arrays of finite numbers.
    pub fn number_rows(&mut self, item: &Item, key: &str) -> Option<Vec<Vec<f64>>> {
        let Some(arr) = item.as_array() else {
            self.error(
                item.span(),
                format!("`{key}` must be an array of arrays of numbers"),
            );
            return None;
        };
        let mut out = Vec::with_capacity(arr.len());
        let mut ok = true;
        for v in arr.iter() {
            match v.as_array() {
                Some(inner) => {
                    let row: Option<Vec<f64>> = inner
                        .iter()
                        .map(|x| {
                            x.as_float()
                                .or_else(|| x.as_integer().map(|i| i as f64))
                                .filter(|x| x.is_finite())
                        })
                        .collect();
                    match row {
                        Some(r) => out.push(r),
                        None => {
                            self.error(
                                v.span(),
                                format!("every element of `{key}` must be a finite number"),
                            );
                            ok = false;
                        }
                    }
                }
                None => {
                    self.error(
                        v.span(),
                        format!("every element of `{key}` must be an array of numbers"),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }
}

/// Full-precision text that TOML reads as a float (`1` becomes `1.0`).
pub(crate) fn fmt_f64_float(v: f64) -> String {
    let s = crate::io::fmt_f64(v);
    if s.contains(['.', 'e', 'E']) || !v.is_finite() {
        s
    } else {
        format!("{s}.0")
    }
}
