//! Writing TOML files (machine model, `SERVO.toml`, thermal model) through
//! `toml_edit`, so that keys and strings are quoted and escaped by one rule
//! (toml_edit's) and every file written is valid TOML.
//!
//! Numbers are written at full precision in their shortest round-trip form
//! (`0.1`, `2.6e-7`, always with a `.` or an exponent so they read back as
//! floats). A non-finite number is refused with a [`TomlWriteError`] that
//! names its key: the readers take finite numbers only, so a file holding
//! `nan` or `inf` could not be read back.

use toml_edit::{Array, DocumentMut, InlineTable, Item, Table, Value};

/// A value that cannot be written: a non-finite number (NaN or ±infinity).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "cannot write `{key}` = {}: a TOML file written by mtwin holds finite numbers only",
    crate::limits::fmt_message_number(*.value)
)]
pub struct TomlWriteError {
    /// Where the number would go, e.g. `axes.X.errors.EXX.poly[2]`.
    pub key: String,
    /// The number.
    pub value: f64,
}

/// A float value at full precision; `key` names it if it is not finite.
pub(crate) fn float(key: &str, x: f64) -> Result<Value, TomlWriteError> {
    if !x.is_finite() {
        return Err(TomlWriteError {
            key: key.to_string(),
            value: x,
        });
    }
    let s = super::fmt_f64(x);
    let text = if s.contains(['.', 'e', 'E']) {
        s
    } else {
        format!("{s}.0")
    };
    // Parsing keeps this text as the value's representation (shortest
    // round-trip, exponent form for very large or small magnitudes).
    let mut v: Value = text
        .parse()
        .expect("the shortest round-trip form of a finite f64 is a TOML float");
    v.decor_mut().clear();
    Ok(v)
}

/// An array of floats, `[1.0, 0.5]`; element `i` is named `key[i]` if it is not finite.
pub(crate) fn floats(key: &str, xs: &[f64]) -> Result<Value, TomlWriteError> {
    let mut a = Array::new();
    for (i, &x) in xs.iter().enumerate() {
        a.push_formatted(float(&format!("{key}[{i}]"), x)?);
    }
    a.fmt();
    Ok(Value::Array(a))
}

/// An array of arrays of floats, `[[1.0, 2.0], [3.0]]`.
pub(crate) fn float_rows(key: &str, rows: &[Vec<f64>]) -> Result<Value, TomlWriteError> {
    let mut a = Array::new();
    for (i, r) in rows.iter().enumerate() {
        a.push_formatted(floats(&format!("{key}[{i}]"), r)?);
    }
    a.fmt();
    Ok(Value::Array(a))
}

/// An array of strings, quoted and escaped by toml_edit.
pub(crate) fn strings<'a>(xs: impl IntoIterator<Item = &'a str>) -> Value {
    Value::Array(Array::from_iter(xs))
}

/// An integer.
pub(crate) fn int(i: impl Into<i64>) -> Value {
    Value::from(i.into())
}

/// An array of integers.
pub(crate) fn ints(xs: impl IntoIterator<Item = i64>) -> Value {
    Value::Array(Array::from_iter(xs))
}

/// An inline table `{ k = v, … }` of the given entries, in order.
pub(crate) fn inline(entries: impl IntoIterator<Item = (&'static str, Value)>) -> Value {
    let mut t = InlineTable::new();
    for (k, v) in entries {
        t.insert(k, v);
    }
    t.fmt();
    Value::InlineTable(t)
}

/// Sets `key = value` in `t`, with `# comment` after the value when given.
pub(crate) fn set(t: &mut Table, key: &str, mut value: Value, comment: Option<&str>) {
    if let Some(c) = comment {
        value.decor_mut().set_suffix(format!("  # {c}"));
    }
    t.insert(key, Item::Value(value));
}

/// Indents every key of `t` and its header by two spaces (how the files
/// show the tables that belong to an array element, such as `[axes.errors]`).
pub(crate) fn indent(t: &mut Table) {
    t.decor_mut().set_prefix("  ");
    for (mut k, _) in t.iter_mut() {
        k.leaf_decor_mut().set_prefix("  ");
    }
}

/// A blank line before the header of `t`.
pub(crate) fn blank_line_before(t: &mut Table) {
    t.decor_mut().set_prefix("\n");
}

/// The document text with `lines` first as `#` comments (each line of a
/// multi-line entry becomes its own comment line; control characters, which
/// a TOML comment cannot hold, become spaces).
pub(crate) fn with_header(doc: &DocumentMut, lines: &[&str]) -> String {
    let mut s = String::new();
    for l in lines.iter().flat_map(|l| l.split('\n')) {
        s.push_str("# ");
        s.extend(
            l.chars()
                .map(|c| if c.is_control() && c != '\t' { ' ' } else { c }),
        );
        s.push('\n');
    }
    s.push_str(&doc.to_string());
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_are_shortest_round_trip_and_non_finite_refused() {
        for (x, text) in [
            (1.0, "1.0"),
            (-0.25, "-0.25"),
            (2.6e-7, "2.6e-7"),
            (0.1 + 0.2, "0.30000000000000004"),
            (1e300, "1e300"),
            (-0.0, "-0.0"),
        ] {
            let v = float("k", x).unwrap();
            assert_eq!(v.to_string(), text);
            let back: Value = text.parse().unwrap();
            assert_eq!(back.as_float(), Some(x));
        }
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let e = float("a.b", x).unwrap_err();
            assert_eq!(e.key, "a.b");
            assert!(e.to_string().starts_with("cannot write `a.b` = "), "{e}");
        }
        let e = float_rows("b", &[vec![1.0], vec![2.0, f64::NAN]]).unwrap_err();
        assert_eq!(e.key, "b[1][1]");
        assert_eq!(
            float_rows("b", &[vec![1.0, 2.5], vec![]])
                .unwrap()
                .to_string(),
            "[[1.0, 2.5], []]"
        );
    }

    #[test]
    fn header_comments_and_table_layout() {
        let mut doc = DocumentMut::new();
        set(
            doc.as_table_mut(),
            "a b",
            strings(["x\"y", "z\n"]),
            Some("note"),
        );
        let mut t = Table::new();
        set(&mut t, "k", float("t.k", 3.0).unwrap(), None);
        blank_line_before(&mut t);
        doc.insert("t", Item::Table(t));
        let s = with_header(&doc, &["one", "two\nthree\r"]);
        // The quoting of keys and strings is toml_edit's choice; the layout is ours.
        assert!(s.starts_with("# one\n# two\n# three \n\"a b\" = ["), "{s}");
        assert!(s.ends_with("]  # note\n\n[t]\nk = 3.0\n"), "{s}");
        let back: DocumentMut = s.parse().unwrap();
        let arr = back["a b"].as_array().unwrap();
        assert_eq!(arr.get(1).and_then(Value::as_str), Some("z\n"));
    }
}
