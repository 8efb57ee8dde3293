//! LinuxCNC's parameter file (the `.var` file named by `PARAMETER_FILE` in its
//! ini): one parameter a line, `NUMBER VALUE` separated by blanks, numbers
//! ascending. LinuxCNC reads it at start and writes it back at exit with
//! every parameter the file listed plus the required persistent ones
//! (G28/G30 homes 5161–5169 and 5181–5189, G92 offsets 5210–5219, the
//! selected coordinate system 5220, the nine coordinate systems 5221–5389),
//! each as `%d\t%f` (six decimals). Lines that do not start with a number
//! are ignored, as LinuxCNC ignores them.
//!
//! Values are kept as written: lengths are in the machine's length units
//! (mm for mtwin's machines; LinuxCNC's `rs274` reads them in its ini's
//! units).

use std::io::{BufRead, Write};

use super::error::GcodeError;
use super::parameters::{MAX_NUMBERED, Parameters};

/// Reads a var file into a fresh parameter store. Errors name the line
/// (`Location` column 0 = the whole line).
pub fn read_var_file<R: BufRead>(input: R) -> Result<Parameters, GcodeError> {
    let mut p = Parameters::new();
    let mut last: u32 = 0;
    for (k, line) in input.lines().enumerate() {
        let line = line?;
        let lineno = k as u64 + 1;
        let mut fields = line.split_ascii_whitespace();
        let (Some(n), Some(v)) = (fields.next(), fields.next()) else {
            continue;
        };
        // LinuxCNC reads "%d %lf": a line whose first two fields are not an
        // integer and a number is skipped.
        let (Ok(n), Ok(v)) = (n.parse::<i64>(), v.parse::<f64>()) else {
            continue;
        };
        if n < 1 || n >= i64::from(MAX_NUMBERED) {
            return Err(GcodeError::invalid(
                lineno,
                0,
                format!("Parameter number out of range: {n}"),
            ));
        }
        let n = n as u32;
        if n <= last {
            return Err(GcodeError::invalid(
                lineno,
                0,
                format!("Parameter file out of order: {n} after {last}"),
            ));
        }
        if !v.is_finite() {
            return Err(GcodeError::invalid(
                lineno,
                0,
                format!("parameter {n} is not a finite number"),
            ));
        }
        last = n;
        // In range by the check above.
        let _ = p.set(n, v);
        p.mark_listed(n);
    }
    Ok(p)
}

/// Writes the persistent parameters of `p` in LinuxCNC's format.
pub fn write_var_file<W: Write>(p: &Parameters, mut out: W) -> std::io::Result<()> {
    for n in p.persistent_numbers() {
        writeln!(out, "{n}\t{:.6}", p.get(n))?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_listed_and_required() {
        let text = "5161\t1.500000\n5221 -10.25\n# a comment line\n6 3\n";
        let err = read_var_file(text.as_bytes()).unwrap_err();
        assert!(err.to_string().contains("out of order"), "{err}");

        let text = "6\t3.000000\n5161\t1.500000\nnot a parameter\n5221 -10.25\n5400 2\n";
        let p = read_var_file(text.as_bytes()).unwrap();
        assert_eq!(
            (p.get(6), p.get(5161), p.get(5221), p.get(5400)),
            (3.0, 1.5, -10.25, 2.0)
        );
        let mut out = Vec::new();
        write_var_file(&p, &mut out).unwrap();
        let written = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = written.lines().collect();
        // The 110 required ones plus the listed 6 and 5400.
        assert_eq!(lines.len(), 110 + 2);
        assert_eq!(lines[0], "6\t3.000000");
        assert!(lines.contains(&"5221\t-10.250000"));
        assert!(lines.contains(&"5400\t2.000000"));
        assert!(!lines.contains(&"5390\t0.000000"));
        // Reading what was written gives the same store values.
        let q = read_var_file(written.as_bytes()).unwrap();
        for n in 1..MAX_NUMBERED {
            assert_eq!(p.get(n), q.get(n), "#{n}");
        }
        let mut again = Vec::new();
        write_var_file(&q, &mut again).unwrap();
        assert_eq!(String::from_utf8(again).unwrap(), written);
    }

    #[test]
    fn range_is_checked() {
        assert!(read_var_file("5602 1\n".as_bytes()).is_err());
        assert!(read_var_file("0 1\n".as_bytes()).is_err());
    }
}
