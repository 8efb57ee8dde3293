use std::io::Read;
use std::path::{Path, PathBuf};

use super::{Diagnostic, Diagnostics};

/// A CSV file as mtwin reads it: UTF-8, comma separated, one header row, `#` comment
/// lines and blank lines ignored, columns matched by header name.
///
/// Cells are kept as text with the line they came from, so a bad cell can be reported
/// with file, line and column when a command asks for it as a number.
#[derive(Debug, Clone)]
pub struct Table {
    path: PathBuf,
    headers: Vec<String>,
    header_line: usize,
    rows: Vec<Vec<String>>,
    lines: Vec<usize>,
}

/// A column found by name: its 0-based index and its header text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Column {
    /// 0-based index of the field in each row.
    pub index: usize,
}

impl Table {
    /// Read a CSV file. `path` is also the name used in messages.
    pub fn read(path: &Path) -> Result<Table, Diagnostics> {
        let file = std::fs::File::open(path)
            .map_err(|e| Diagnostic::whole(path, format!("cannot open the file: {e}")))?;
        Self::from_reader(path, file)
    }

    /// Read CSV text from `reader`; `path` names it in messages.
    pub fn from_reader<R: Read>(path: &Path, mut reader: R) -> Result<Table, Diagnostics> {
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .map_err(|e| Diagnostic::whole(path, format!("cannot read the file: {e}")))?;
        let text = match String::from_utf8(bytes) {
            Ok(t) => t,
            Err(e) => {
                let upto = &e.as_bytes()[..e.utf8_error().valid_up_to()];
                let line = upto.iter().filter(|&&b| b == b'\n').count() + 1;
                return Err(Diagnostic::at_line(path, line, "the line is not valid UTF-8").into());
            }
        };
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let mut diags = Diagnostics::default();
        let mut headers: Option<(Vec<String>, usize)> = None;
        let mut rows = Vec::new();
        let mut lines = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let trimmed = raw.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let fields = match split_fields(raw) {
                Ok(f) => f,
                Err(col) => {
                    diags.push(Diagnostic::at(
                        path,
                        line,
                        col,
                        "a quoted field is not closed",
                    ));
                    continue;
                }
            };
            match &headers {
                None => {
                    for (k, name) in fields.iter().enumerate() {
                        if name.is_empty() {
                            diags.push(Diagnostic::at(
                                path,
                                line,
                                k + 1,
                                "the header has an empty column name",
                            ));
                        } else if fields[..k].contains(name) {
                            diags.push(Diagnostic::at(
                                path,
                                line,
                                k + 1,
                                format!("the header names column `{name}` twice"),
                            ));
                        }
                    }
                    headers = Some((fields, line));
                }
                Some((h, _)) => {
                    if fields.len() != h.len() {
                        diags.push(Diagnostic::at_line(
                            path,
                            line,
                            format!(
                                "the row has {} fields but the header has {}",
                                fields.len(),
                                h.len()
                            ),
                        ));
                        continue;
                    }
                    rows.push(fields);
                    lines.push(line);
                }
            }
        }
        let Some((headers, header_line)) = headers else {
            diags.push(Diagnostic::whole(
                path,
                "the file is empty: a header row is needed",
            ));
            return Err(diags);
        };
        diags.into_result(Table {
            path: path.to_path_buf(),
            headers,
            header_line,
            rows,
            lines,
        })
    }

    /// The file this table was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Header names in file order.
    pub fn headers(&self) -> &[String] {
        &self.headers
    }

    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// True when the file has a header but no data row.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// 1-based line in the file of data row `row`.
    pub fn line(&self, row: usize) -> usize {
        self.lines[row]
    }

    /// The column named `name`, if present.
    pub fn column(&self, name: &str) -> Option<Column> {
        self.headers
            .iter()
            .position(|h| h == name)
            .map(|index| Column { index })
    }

    /// The columns named `names`; one diagnostic listing every missing column otherwise.
    pub fn require(&self, names: &[&str]) -> Result<Vec<Column>, Diagnostic> {
        require_columns(&self.path, self.header_line, &self.headers, names)
    }

    /// 1-based line of the header row.
    pub fn header_line(&self) -> usize {
        self.header_line
    }

    /// The text of a cell.
    pub fn text(&self, row: usize, col: Column) -> &str {
        &self.rows[row][col.index]
    }

    /// A cell as a finite number, or a diagnostic with file, line and column.
    pub fn number(&self, row: usize, col: Column) -> Result<f64, Diagnostic> {
        parse_number(
            &self.path,
            self.lines[row],
            col.index,
            &self.headers[col.index],
            self.text(row, col),
        )
    }

    /// A whole column as finite numbers; every bad cell is reported.
    pub fn numbers(&self, col: Column) -> Result<Vec<f64>, Diagnostics> {
        let mut out = Vec::with_capacity(self.len());
        let mut diags = Diagnostics::default();
        for r in 0..self.len() {
            match self.number(r, col) {
                Ok(v) => out.push(v),
                Err(d) => diags.push(d),
            }
        }
        diags.into_result(out)
    }

    /// Several columns by name as numbers, row-major (`out[row][k]` for `names[k]`).
    pub fn number_rows(&self, names: &[&str]) -> Result<Vec<Vec<f64>>, Diagnostics> {
        let cols = self.require(names)?;
        let mut diags = Diagnostics::default();
        let mut out = Vec::with_capacity(self.len());
        for r in 0..self.len() {
            let mut row = Vec::with_capacity(cols.len());
            for &c in &cols {
                match self.number(r, c) {
                    Ok(v) => row.push(v),
                    Err(d) => diags.push(d),
                }
            }
            out.push(row);
        }
        diags.into_result(out)
    }

    /// A diagnostic at data row `row` (its line), for checks made by the caller.
    pub fn row_error(&self, row: usize, message: impl Into<String>) -> Diagnostic {
        Diagnostic::at_line(&self.path, self.lines[row], message)
    }

    /// A diagnostic at data row `row`, column `col`.
    pub fn cell_error(&self, row: usize, col: Column, message: impl Into<String>) -> Diagnostic {
        Diagnostic::at(&self.path, self.lines[row], col.index + 1, message)
    }
}

/// The columns of `headers` (the header row at `line` of `path`) named `names`; one
/// diagnostic listing every missing column otherwise.
pub(super) fn require_columns(
    path: &Path,
    line: usize,
    headers: &[String],
    names: &[&str],
) -> Result<Vec<Column>, Diagnostic> {
    let find = |n: &str| headers.iter().position(|h| h == n);
    let missing: Vec<&str> = names
        .iter()
        .copied()
        .filter(|n| find(n).is_none())
        .collect();
    if missing.is_empty() {
        Ok(names
            .iter()
            .filter_map(|n| find(n).map(|index| Column { index }))
            .collect())
    } else {
        Err(Diagnostic::at_line(
            path,
            line,
            format!(
                "missing column{} {} (the header has: {})",
                if missing.len() > 1 { "s" } else { "" },
                missing
                    .iter()
                    .map(|m| format!("`{m}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                headers.join(", ")
            ),
        ))
    }
}

/// The cell text `s` of column `name` (0-based `index`) at `line` of `path` as a finite
/// number, or a diagnostic saying why not.
pub(super) fn parse_number(
    path: &Path,
    line: usize,
    index: usize,
    name: &str,
    s: &str,
) -> Result<f64, Diagnostic> {
    let bound = if super::columns::TIME.contains(&name) {
        crate::limits::MAX_ABS_TIME
    } else {
        crate::limits::MAX_ABS_VALUE
    };
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v.abs() <= bound => Ok(v),
        Ok(v) if v.is_finite() => Err(Diagnostic::at(
            path,
            line,
            index + 1,
            format!(
                "column `{name}` holds {}, beyond the largest magnitude accepted ({}): no quantity in these files is that large",
                crate::limits::fmt_message_number(v),
                crate::limits::fmt_message_number(bound)
            ),
        )),
        Ok(_) => Err(Diagnostic::at(
            path,
            line,
            index + 1,
            format!("column `{name}` holds `{s}`, which is not a finite number"),
        )),
        Err(_) if s.is_empty() => Err(Diagnostic::at(
            path,
            line,
            index + 1,
            format!("column `{name}` is empty; a number is needed"),
        )),
        Err(_) => Err(Diagnostic::at(
            path,
            line,
            index + 1,
            format!("column `{name}` holds `{s}`, which is not a number"),
        )),
    }
}

/// Split one CSV line into trimmed fields; `"` quotes a field (`""` inside is a quote).
/// Returns the 1-based column of an unclosed quote as the error.
pub(super) fn split_fields(line: &str) -> Result<Vec<String>, usize> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut chars = line.char_indices().peekable();
    let mut in_quotes = false;
    let mut quote_col = 0;
    while let Some((i, c)) = chars.next() {
        if in_quotes {
            if c == '"' {
                if matches!(chars.peek(), Some((_, '"'))) {
                    cur.push('"');
                    chars.next();
                } else {
                    in_quotes = false;
                }
            } else {
                cur.push(c);
            }
        } else if c == ',' {
            out.push(cur.trim().to_string());
            cur.clear();
        } else if c == '"' && cur.trim().is_empty() {
            cur.clear();
            in_quotes = true;
            quote_col = line[..i].chars().count() + 1;
        } else {
            cur.push(c);
        }
    }
    if in_quotes {
        return Err(quote_col);
    }
    out.push(cur.trim().to_string());
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parse(s: &str) -> Result<Table, Diagnostics> {
        Table::from_reader(Path::new("t.csv"), s.as_bytes())
    }

    #[test]
    fn comments_blanks_and_order_free_columns() {
        let t = parse("# a comment\n\ny, x\n1, 2\n# mid\n\n3,4\n").unwrap();
        assert_eq!(t.len(), 2);
        let x = t.column("x").unwrap();
        assert_eq!(t.numbers(x).unwrap(), vec![2.0, 4.0]);
        assert_eq!(t.line(0), 4);
        assert_eq!(t.line(1), 7);
    }

    #[test]
    fn bad_cell_has_line_and_column() {
        let t = parse("x,y\n1,2\n3,abc\n").unwrap();
        let e = t.number(1, t.column("y").unwrap()).unwrap_err();
        assert_eq!((e.line, e.column), (3, Some(2)));
        assert!(e.to_string().starts_with("t.csv:3:2:"), "{e}");
        let e = t.number(0, t.column("x").unwrap());
        assert_eq!(e.unwrap(), 1.0);
        let t = parse("x\nNaN\n").unwrap();
        assert!(t.number(0, t.column("x").unwrap()).is_err());
    }

    /// Finite numbers beyond the magnitude bound are refused at their cell
    /// (1e308 would overflow every square and sum downstream); the bound
    /// itself is accepted.
    #[test]
    fn magnitude_bound_at_the_cell() {
        let t = parse("x,y\n1e15,-1e15\n2,1e308\n1e16,0\n").unwrap();
        let (x, y) = (t.column("x").unwrap(), t.column("y").unwrap());
        assert_eq!(t.number(0, x).unwrap(), 1e15);
        assert_eq!(t.number(0, y).unwrap(), -1e15);
        let e = t.number(1, y).unwrap_err();
        assert_eq!((e.line, e.column), (3, Some(2)));
        assert!(
            e.message.contains("1e308") && e.message.contains("1e15"),
            "{e}"
        );
        assert!(t.number(2, x).is_err());
    }

    /// Time columns take raw epoch timestamps in µs and ns (to 1e19); other
    /// columns keep the 1e15 bound, and a time column refuses beyond 1e19.
    #[test]
    fn time_columns_take_epoch_timestamps() {
        let t = parse(
            "t_s,t_min,x\n1732550000123456789,1732550000123456,0\n1e19,-1e19,1.7e18\n1e20,0,0\n",
        )
        .unwrap();
        let [ts, tm, x] = ["t_s", "t_min", "x"].map(|n| t.column(n).unwrap());
        assert_eq!(t.number(0, ts).unwrap(), 1_732_550_000_123_456_789_f64);
        assert_eq!(t.number(0, tm).unwrap(), 1_732_550_000_123_456_f64);
        assert_eq!(t.number(1, ts).unwrap(), 1e19);
        assert_eq!(t.number(1, tm).unwrap(), -1e19);
        let e = t.number(1, x).unwrap_err();
        assert!(
            e.message.contains("1.7e18") && e.message.contains("1e15"),
            "{e}"
        );
        let e = t.number(2, ts).unwrap_err();
        assert!(
            e.message.contains("1e20") && e.message.contains("1e19"),
            "{e}"
        );
    }

    #[test]
    fn missing_column_lists_them() {
        let t = parse("x,y\n1,2\n").unwrap();
        let e = t.require(&["x", "z", "w"]).unwrap_err();
        assert!(
            e.message.contains("`z`") && e.message.contains("`w`"),
            "{e}"
        );
    }

    #[test]
    fn ragged_row_and_empty_file() {
        let e = parse("x,y\n1\n").unwrap_err();
        assert_eq!(e.0[0].line, 2);
        assert!(parse("").is_err());
        assert!(parse("# only comments\n").is_err());
    }

    proptest! {
        #[test]
        fn never_panics(s in ".{0,200}") {
            if let Ok(t) = parse(&s) {
                for h in t.headers().to_vec() {
                    let c = t.column(&h).unwrap();
                    let _ = t.numbers(c);
                }
            }
        }

        #[test]
        fn never_panics_bytes(b in proptest::collection::vec(any::<u8>(), 0..200)) {
            let _ = Table::from_reader(Path::new("b.csv"), &b[..]);
        }
    }
}
