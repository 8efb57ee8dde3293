//! Ballbar readings of one mode: the file `angle_deg,length_mm` (docs/ballbar.md).

use std::path::{Path, PathBuf};

use crate::io::{Diagnostic, Diagnostics, Table};

/// Fewest readings a mode needs: three first-order coefficients, the bar
/// length and at least one degree of freedom to judge the fit.
pub const MIN_READINGS: usize = 5;

/// The readings of one mode: the moving axis' angle (degrees) and the
/// absolute bar reading (mm), in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeData {
    /// Where the readings came from (used in messages), if from a file.
    pub source: Option<PathBuf>,
    /// Angle of the moving rotary axis, degrees.
    pub angles_deg: Vec<f64>,
    /// Absolute bar readings, mm.
    pub lengths: Vec<f64>,
}

impl ModeData {
    /// Readings from vectors, checked as a file would be (no file or line in
    /// the messages).
    pub fn new(angles_deg: Vec<f64>, lengths: Vec<f64>) -> Result<ModeData, Diagnostics> {
        let d = ModeData {
            source: None,
            angles_deg,
            lengths,
        };
        let path = Path::new("<readings>");
        let lines: Vec<usize> = (1..=d.angles_deg.len()).collect();
        d.check(path, &lines, 1)?;
        Ok(d)
    }

    /// Number of readings.
    pub fn len(&self) -> usize {
        self.angles_deg.len()
    }

    /// True when there are no readings.
    pub fn is_empty(&self) -> bool {
        self.angles_deg.is_empty()
    }

    /// The reading at angle 0°.
    pub fn reading_at_zero(&self) -> Option<f64> {
        self.angles_deg
            .iter()
            .position(|&a| a == 0.0)
            .map(|i| self.lengths[i])
    }

    fn check(&self, path: &Path, lines: &[usize], header_line: usize) -> Result<(), Diagnostics> {
        let mut diags = Diagnostics::default();
        if self.angles_deg.len() != self.lengths.len() {
            diags.push(Diagnostic::whole(
                path,
                "the numbers of angles and lengths differ",
            ));
            return Err(diags);
        }
        if self.len() < MIN_READINGS {
            diags.push(Diagnostic::at_line(
                path,
                header_line,
                format!(
                    "only {} reading{}; a mode needs at least {MIN_READINGS}",
                    self.len(),
                    if self.len() == 1 { "" } else { "s" }
                ),
            ));
        }
        let mut order: Vec<usize> = (0..self.len()).collect();
        order.sort_by(|&a, &b| self.angles_deg[a].total_cmp(&self.angles_deg[b]));
        for w in order.windows(2) {
            let (a, b) = (w[0].min(w[1]), w[0].max(w[1]));
            if self.angles_deg[a] == self.angles_deg[b] {
                diags.push(Diagnostic::at_line(
                    path,
                    lines[b],
                    format!(
                        "angle {}° appears twice (also on line {}); give one reading per angle",
                        crate::limits::fmt_message_number(self.angles_deg[b]),
                        lines[a]
                    ),
                ));
            }
        }
        for (i, &l) in self.lengths.iter().enumerate() {
            if l <= 0.0 {
                diags.push(Diagnostic::at_line(
                    path,
                    lines[i],
                    format!(
                        "length_mm is {}, but a bar reading is a positive length",
                        crate::limits::fmt_message_number(l)
                    ),
                ));
            }
        }
        if !self.is_empty() && self.reading_at_zero().is_none() {
            diags.push(Diagnostic::at_line(
                path,
                header_line,
                format!(
                    "no reading at angle 0° (rows on lines {}–{}); the bar is set at 0°, so \
                     that reading is required",
                    lines[0],
                    lines[lines.len() - 1]
                ),
            ));
        }
        diags.into_result(())
    }
}

/// Writes readings as a mode file (`angle_deg,length_mm`, full precision).
pub fn write_mode_file(w: &mut dyn std::io::Write, data: &ModeData) -> std::io::Result<()> {
    writeln!(
        w,
        "{}",
        crate::io::columns::header(&crate::io::columns::BALLBAR_MODE)
    )?;
    for (a, l) in data.angles_deg.iter().zip(&data.lengths) {
        crate::io::write_csv_row(w, &[*a, *l])?;
    }
    Ok(())
}

/// Reads a mode file: CSV with columns `angle_deg` and `length_mm` (docs/ballbar.md).
/// Every problem is reported with file and line: non-numeric cells, a
/// missing 0° reading, duplicate angles, fewer than [`MIN_READINGS`] rows.
pub fn read_mode_file(path: &Path) -> Result<ModeData, Diagnostics> {
    let table = Table::read(path)?;
    parse_table(&table)
}

/// [`read_mode_file`] on CSV text (`path` names it in messages).
pub fn parse_mode_text(path: &Path, text: &str) -> Result<ModeData, Diagnostics> {
    let table = Table::from_reader(path, text.as_bytes())?;
    parse_table(&table)
}

fn parse_table(table: &Table) -> Result<ModeData, Diagnostics> {
    let rows = table.number_rows(&crate::io::columns::BALLBAR_MODE)?;
    let lines: Vec<usize> = (0..table.len()).map(|r| table.line(r)).collect();
    let d = ModeData {
        source: Some(table.path().to_path_buf()),
        angles_deg: rows.iter().map(|r| r[0]).collect(),
        lengths: rows.iter().map(|r| r[1]).collect(),
    };
    d.check(table.path(), &lines, table.header_line())?;
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ModeData, String> {
        parse_mode_text(Path::new("m1.csv"), text).map_err(|d| d.to_string())
    }

    #[test]
    fn write_then_read_round_trips() {
        let d = ModeData::new(
            vec![0.0, 5.0, 10.0, 15.0, 20.0],
            vec![100.1, 100.0 + 1e-7, 99.9, 100.0, 1.0 / 3.0],
        )
        .unwrap();
        let mut buf = Vec::new();
        write_mode_file(&mut buf, &d).unwrap();
        let back = parse(std::str::from_utf8(&buf).unwrap()).unwrap();
        assert_eq!(back.angles_deg, d.angles_deg);
        assert_eq!(back.lengths, d.lengths);
    }

    #[test]
    fn reads_columns_by_name_with_comments() {
        let d = parse(
            "# mode 1\nlength_mm,angle_deg\n100.001,0\n100.002,5\n\n100.003,10\n100,15\n99.9,20\n",
        )
        .unwrap();
        assert_eq!(d.angles_deg, vec![0.0, 5.0, 10.0, 15.0, 20.0]);
        assert_eq!(d.lengths[0], 100.001);
        assert_eq!(d.reading_at_zero(), Some(100.001));
    }

    #[test]
    fn each_bad_input_is_named_with_file_and_line() {
        let e = parse("angle_deg,length_mm\n5,100\n10,100\n15,100\n20,100\n25,100\n").unwrap_err();
        assert!(
            e.contains("m1.csv:1") && e.contains("no reading at angle 0"),
            "{e}"
        );
        let e = parse("angle_deg,length_mm\n0,100\n5,100\n5,100\n15,100\n20,100\n").unwrap_err();
        assert!(
            e.contains("m1.csv:4") && e.contains("appears twice (also on line 3)"),
            "{e}"
        );
        let e = parse("angle_deg,length_mm\n0,100\n5,100\n").unwrap_err();
        assert!(
            e.contains("m1.csv:1") && e.contains("only 2 readings"),
            "{e}"
        );
        let e = parse("angle_deg,length_mm\n0,100\n5,abc\n10,100\n15,100\n20,100\n").unwrap_err();
        assert!(
            e.contains("m1.csv:3:2") && e.contains("not a number"),
            "{e}"
        );
        let e = parse("angle,length_mm\n0,100\n").unwrap_err();
        assert!(e.contains("missing column `angle_deg`"), "{e}");
    }

    proptest::proptest! {
        #[test]
        fn parser_never_panics(text in "[0-9a-z,.\\-#\n ]{0,200}") {
            let _ = parse(&text);
        }
    }
}
