use std::io::BufRead;
use std::path::{Path, PathBuf};

use super::table::{parse_number, require_columns, split_fields};
use super::{Column, Diagnostic};

/// A CSV file read row by row, for inputs too long to hold as a [`Table`](super::Table):
/// the same rules (UTF-8, one header row, `#` comment lines and blank lines skipped,
/// columns matched by header name), the same messages, but only one line in memory.
///
/// Reading stops at the first problem, reported with file, line and column.
#[derive(Debug)]
pub struct CsvRows<R> {
    path: PathBuf,
    reader: R,
    headers: Vec<String>,
    header_line: usize,
    line: usize,
    buf: String,
}

impl<R: BufRead> CsvRows<R> {
    /// Read the header row from `reader`; `path` names the input in messages.
    pub fn new(path: &Path, reader: R) -> Result<Self, Diagnostic> {
        let mut rows = CsvRows {
            path: path.to_path_buf(),
            reader,
            headers: Vec::new(),
            header_line: 0,
            line: 0,
            buf: String::new(),
        };
        let Some(fields) = rows.next_fields()? else {
            return Err(Diagnostic::whole(
                path,
                "the file is empty: a header row is needed",
            ));
        };
        for (k, name) in fields.iter().enumerate() {
            if name.is_empty() {
                return Err(Diagnostic::at(
                    path,
                    rows.line,
                    k + 1,
                    "the header has an empty column name",
                ));
            }
            if fields[..k].contains(name) {
                return Err(Diagnostic::at(
                    path,
                    rows.line,
                    k + 1,
                    format!("the header names column `{name}` twice"),
                ));
            }
        }
        rows.headers = fields;
        rows.header_line = rows.line;
        Ok(rows)
    }

    /// The input's name in messages.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// 1-based line of the header row.
    pub fn header_line(&self) -> usize {
        self.header_line
    }

    /// 1-based line of the row read last.
    pub fn line(&self) -> usize {
        self.line
    }

    /// The columns named `names`; one diagnostic listing every missing column otherwise.
    pub fn require(&self, names: &[&str]) -> Result<Vec<Column>, Diagnostic> {
        require_columns(&self.path, self.header_line, &self.headers, names)
    }

    /// The fields of the next data line, `None` at the end.
    fn next_fields(&mut self) -> Result<Option<Vec<String>>, Diagnostic> {
        loop {
            self.buf.clear();
            let n = self.reader.read_line(&mut self.buf).map_err(|e| {
                let msg = if e.kind() == std::io::ErrorKind::InvalidData {
                    "the line is not valid UTF-8".to_string()
                } else {
                    format!("cannot read the file: {e}")
                };
                Diagnostic::at_line(&self.path, self.line + 1, msg)
            })?;
            if n == 0 {
                return Ok(None);
            }
            self.line += 1;
            let raw = if self.line == 1 {
                self.buf.strip_prefix('\u{feff}').unwrap_or(&self.buf)
            } else {
                &self.buf
            };
            let raw = raw.trim_end_matches(['\n', '\r']);
            let trimmed = raw.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            return split_fields(raw).map(Some).map_err(|col| {
                Diagnostic::at(&self.path, self.line, col, "a quoted field is not closed")
            });
        }
    }

    /// The next data row's `cols` as finite numbers into `out` (cleared first); `false`
    /// at the end of the file.
    pub fn next_numbers(
        &mut self,
        cols: &[Column],
        out: &mut Vec<f64>,
    ) -> Result<bool, Diagnostic> {
        out.clear();
        let Some(fields) = self.next_fields()? else {
            return Ok(false);
        };
        if fields.len() != self.headers.len() {
            return Err(Diagnostic::at_line(
                &self.path,
                self.line,
                format!(
                    "the row has {} fields but the header has {}",
                    fields.len(),
                    self.headers.len()
                ),
            ));
        }
        for c in cols {
            out.push(parse_number(
                &self.path,
                self.line,
                c.index,
                &self.headers[c.index],
                &fields[c.index],
            )?);
        }
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::Table;

    #[test]
    fn reads_like_a_table_row_by_row() {
        let text = "\u{feff}# comment\nt_s, X ,Y\n\n0,1,2\n# more\n0.5,\"3\",4e-3\n";
        let p = Path::new("cmd.csv");
        let t = Table::from_reader(p, text.as_bytes()).unwrap();
        let mut r = CsvRows::new(p, text.as_bytes()).unwrap();
        assert_eq!(r.header_line(), t.header_line());
        let cols = r.require(&["Y", "t_s"]).unwrap();
        let want = t.number_rows(&["Y", "t_s"]).unwrap();
        let mut row = Vec::new();
        let mut got = Vec::new();
        while r.next_numbers(&cols, &mut row).unwrap() {
            got.push(row.clone());
        }
        assert_eq!(got, want);
        assert_eq!(r.line(), 6);
    }

    #[test]
    fn problems_name_line_and_column() {
        let p = Path::new("cmd.csv");
        let e = CsvRows::new(p, "t_s,X\n".as_bytes())
            .unwrap()
            .require(&["t_s", "Y"]);
        assert!(
            e.unwrap_err()
                .to_string()
                .starts_with("cmd.csv:1: missing column `Y`")
        );
        let mut r = CsvRows::new(p, "t_s,X\n0,1\n1,x\n".as_bytes()).unwrap();
        let cols = r.require(&["t_s", "X"]).unwrap();
        let mut row = Vec::new();
        assert!(r.next_numbers(&cols, &mut row).unwrap());
        let e = r.next_numbers(&cols, &mut row).unwrap_err();
        assert_eq!((e.line, e.column), (3, Some(2)));
        let mut r = CsvRows::new(p, "t_s,X\n0\n".as_bytes()).unwrap();
        assert!(
            r.next_numbers(&cols, &mut row)
                .unwrap_err()
                .to_string()
                .contains("1 fields")
        );
        assert!(CsvRows::new(p, "# only\n".as_bytes()).is_err());
    }
}
