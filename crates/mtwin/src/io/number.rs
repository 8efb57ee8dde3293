use std::io::{self, Write};

/// The shortest text that reads back to the same `f64` (data files are never rounded).
///
/// Integral values are written without a trailing `.0` only when that text still
/// parses back to the same value, which it always does; NaN and infinities are
/// written as `NaN`, `inf`, `-inf`.
pub fn fmt_f64(x: f64) -> String {
    if x.is_finite() {
        let mut buf = ryu::Buffer::new();
        let s = buf.format_finite(x);
        s.strip_suffix(".0").unwrap_or(s).to_string()
    } else if x.is_nan() {
        "NaN".to_string()
    } else if x > 0.0 {
        "inf".to_string()
    } else {
        "-inf".to_string()
    }
}

/// Write one CSV row of numbers at full precision, comma separated, newline terminated.
pub fn write_csv_row<W: Write + ?Sized>(w: &mut W, values: &[f64]) -> io::Result<()> {
    let mut buf = ryu::Buffer::new();
    for (i, &v) in values.iter().enumerate() {
        if i > 0 {
            w.write_all(b",")?;
        }
        if v.is_finite() {
            let s = buf.format_finite(v);
            w.write_all(s.strip_suffix(".0").unwrap_or(s).as_bytes())?;
        } else {
            w.write_all(fmt_f64(v).as_bytes())?;
        }
    }
    w.write_all(b"\n")
}

/// Reads a JSON number, or `null` as NaN: JSON has no NaN, and `serde_json`
/// writes a non-finite `f64` as `null`, so documents that may hold one (a
/// relative change over a zero) read back through this.
pub fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    use serde::Deserialize;
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shortest_round_trip() {
        for &x in &[
            0.1,
            -0.0403,
            1e-7,
            123456.789,
            1.0 / 3.0,
            2.0,
            -5e-310,
            1e300,
        ] {
            let s = fmt_f64(x);
            assert_eq!(s.parse::<f64>().unwrap(), x, "{s}");
        }
        assert_eq!(fmt_f64(2.0), "2");
        assert_eq!(fmt_f64(0.1), "0.1");
    }

    #[test]
    fn row() {
        let mut v = Vec::new();
        write_csv_row(&mut v, &[1.0, 0.25, -3e-9]).unwrap();
        assert_eq!(String::from_utf8(v).unwrap(), "1,0.25,-3e-9\n");
    }
}
