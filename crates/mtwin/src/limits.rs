//! Bounds on what a user can ask for: sizes that set memory, disk or run time,
//! and magnitudes of values read from files. Every size a user gives is
//! checked against these bounds before anything is allocated or written, so
//! a typing error (`--ts 1e-12`, `--levels 100000000`) ends with a clear
//! message instead of exhausting the machine. The table of bounds is in
//! `docs/guide.md` ("Limits").

use std::fmt;

/// Largest magnitude of a number read from a data file (CSV cell, TOML value).
/// Lengths are mm, times s, temperatures °C: nothing physical in these files
/// comes near 1e15, and with this bound squares and sums of squares of any
/// data set stay far from `f64` overflow (1e308).
pub const MAX_ABS_VALUE: f64 = 1e15;

/// Largest magnitude of a time in a time column (`t_s`, `t_min`, see
/// [`crate::io::columns::TIME`]): wider than [`MAX_ABS_VALUE`] so that a raw
/// epoch timestamp reads — in µs (1.7e15) or ns (1.7e18, up to the year
/// 2286). Times are used through their differences (sample period,
/// sampling checks), so the magnitude does not reach a square or a sum of
/// squares. The value is read in the column's unit as written (a `t_s`
/// column of epoch nanoseconds gives a sample period in nanoseconds).
pub const MAX_ABS_TIME: f64 = 1e19;

/// Largest magnitude of an error function (mm or rad) or of its derivative
/// (per mm or per degree) anywhere over its axis travel.
pub const MAX_ERROR_VALUE: f64 = 1e6;

/// Most samples (rows) of one generated time series or trajectory: about
/// 1 GB of CSV and a few GB of memory at most.
pub const MAX_SAMPLES: u64 = 10_000_000;

/// Most points of one generated measurement program (ballbar arcs, thermal
/// steps, S-shape segments): a G-code file of a few hundred MB at most.
pub const MAX_PROGRAM_POINTS: u64 = 1_000_000;

/// Highest model order of a system-identification fit (servo and thermal).
/// Orders above this are far beyond what a machine axis or a thermal
/// response needs and cost memory and time growing with the square.
pub const MAX_MODEL_ORDER: u64 = 20;

/// Longest dead time, in samples, of a servo model or a servo fit.
pub const MAX_DELAY_SAMPLES: u64 = 100_000;

/// Most candidate model structures one fit may try (orders × delays ×
/// input subsets).
pub const MAX_FIT_CANDIDATES: u64 = 100_000;

/// Most candidate positions a tracker plan may rank.
pub const MAX_TRACKER_CANDIDATES: u64 = 100_000;

/// Most work units (candidates × selected positions) of a tracker plan: about
/// a minute on one core.
pub const MAX_TRACKER_WORK: u64 = 200_000_000;

/// Most repeats (L word) of one canned-cycle block: each repeat is a few
/// moves held in memory until the block is done (a G84 repeat takes about
/// 7.4 KB: `G84 … L10000` peaks 74 MB above an empty program), so this bound
/// keeps one block within about 75 MB (real programs repeat a cycle a few
/// hundred times at most).
pub const MAX_CYCLE_REPEATS: u64 = 10_000;

/// At most this many pecks (G73/G83) in one canned-cycle block, all repeats
/// together: a peck is three moves, and a block's moves are held until the
/// block ends, so this bound keeps one block within a few tens of MB (a deep
/// hole of 100 mm at Q 0.1 mm is 1 000 pecks).
pub const MAX_CYCLE_PECKS: u64 = 10_000;

/// Most passes of one G76 threading-cycle block: a pass is four to six
/// moves held until the block ends, so this bound keeps one block within a
/// few tens of MB (a fine thread of 2 mm depth cut 0.01 mm a pass is 200
/// passes).
pub const MAX_THREADING_PASSES: u64 = 10_000;

/// Most blocks one G-code program may execute, loops and subroutine calls
/// counted each time they run (about a minute of interpretation): a program
/// whose loop never ends stops with an error instead of running forever.
pub const MAX_EXECUTED_BLOCKS: u64 = 100_000_000;

/// A size or value a user gave that is beyond a bound: names what was given
/// (`what`, e.g. "the number of levels"), the value and the bound. When the
/// value comes from fields of a library options struct, `fields` names them
/// (e.g. `["max_order", "max_delay"]` of `ServoFitOptions`) so a front end
/// can name its own spelling of each through [`LimitError::naming`].
#[derive(Debug, Clone, PartialEq)]
pub struct LimitError {
    /// What was asked for, in words.
    pub what: String,
    /// The options fields (Rust names in the library's options) whose values
    /// set `value`: one for a plain option, several for a product of options;
    /// empty when the value does not come from options (a file, a program).
    pub fields: &'static [&'static str],
    /// The value asked for (or implied by the options).
    pub value: f64,
    /// The bound it exceeds.
    pub bound: f64,
    /// Why the bound exists and what to do instead.
    pub why: &'static str,
}

impl fmt::Display for LimitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} is {}, above the limit of {}: {}",
            self.what,
            fmt_message_number(self.value),
            fmt_message_number(self.bound),
            self.why
        )
    }
}

impl std::error::Error for LimitError {}

impl LimitError {
    /// The same error with `what` spelled as the caller's names of the
    /// option fields: `names` maps each field of [`LimitError::fields`] to
    /// its spelling (a CLI flag such as `--max-order`). One field becomes its
    /// name (`--max-order is 10000, …`); several keep the words and add their
    /// names joined by ` × ` (`the number of structures (--max-order ×
    /// --max-delay) is …`). A field missing from `names` keeps `what` as is.
    pub fn naming(mut self, names: &[(&str, &str)]) -> LimitError {
        let spelled: Option<Vec<&str>> = self
            .fields
            .iter()
            .map(|f| names.iter().find(|(k, _)| k == f).map(|(_, v)| *v))
            .collect();
        match spelled.as_deref() {
            None | Some([]) => {}
            Some([one]) => self.what = (*one).to_string(),
            Some(many) => self.what = format!("{} ({})", self.what, many.join(" × ")),
        }
        self
    }
}

/// Checks that `value` (a count or size, may be non-integral when implied by
/// a division) is at most `bound`; a non-finite value is beyond every bound.
pub fn check(what: &str, value: f64, bound: u64, why: &'static str) -> Result<(), LimitError> {
    check_fields(&[], what, value, bound, why)
}

/// [`check`] of a value set by the options fields `fields` (Rust names of
/// the fields of a library options struct, see [`LimitError::fields`]).
pub fn check_fields(
    fields: &'static [&'static str],
    what: &str,
    value: f64,
    bound: u64,
    why: &'static str,
) -> Result<(), LimitError> {
    if value.is_finite() && value <= bound as f64 {
        Ok(())
    } else {
        Err(LimitError {
            what: what.to_string(),
            fields,
            value,
            bound: bound as f64,
            why,
        })
    }
}

/// One number format for messages: the shortest text that reads back to the
/// same value, in scientific notation when the magnitude is ≥ 1e9 or < 1e-5
/// (so 1e308 is `1e308`, not 309 digits); `NaN`, `inf`, `-inf` otherwise.
pub fn fmt_message_number(x: f64) -> String {
    if !x.is_finite() {
        return crate::io::fmt_f64(x);
    }
    let a = x.abs();
    if a != 0.0 && !(1e-5..1e9).contains(&a) {
        // `{:e}` of Rust is the shortest round-trip mantissa.
        format!("{x:e}")
    } else {
        crate::io::fmt_f64(x)
    }
}

/// [`fmt_message_number`] at a fixed number of decimals, for messages that
/// round (`12.81 µm`): `{:.decimals$}` while the magnitude is below 1e9,
/// otherwise the scientific form with `decimals` digits after the point (so
/// 1e308 at one decimal is `1.0e308`, not 311 characters).
pub fn fmt_message_fixed(x: f64, decimals: usize) -> String {
    if x.is_finite() && x.abs() < 1e9 {
        format!("{x:.decimals$}")
    } else if x.is_finite() {
        format!("{x:.decimals$e}")
    } else {
        crate::io::fmt_f64(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_message_numbers_are_short() {
        assert_eq!(fmt_message_fixed(12.814, 2), "12.81");
        assert_eq!(fmt_message_fixed(-0.26, 1), "-0.3");
        assert_eq!(fmt_message_fixed(1e308, 1), "1.0e308");
        assert_eq!(fmt_message_fixed(-3.25e12, 2), "-3.25e12");
        assert_eq!(fmt_message_fixed(f64::INFINITY, 1), "inf");
        assert!(fmt_message_fixed(f64::MAX, 6).len() < 20);
    }

    #[test]
    fn message_numbers_are_short_and_round_trip() {
        for (x, text) in [
            (1e308, "1e308"),
            (-2.5e20, "-2.5e20"),
            (0.001, "0.001"),
            (0.0010000000000000009, "0.0010000000000000009"),
            (3e-9, "3e-9"),
            (123456.0, "123456"),
            (3e12, "3e12"),
            (0.0, "0"),
        ] {
            let s = fmt_message_number(x);
            assert_eq!(s, text);
            assert_eq!(s.parse::<f64>().unwrap(), x);
        }
        assert!(fmt_message_number(f64::MAX).len() < 30);
    }

    #[test]
    fn check_refuses_beyond_the_bound_and_non_finite() {
        assert!(check("n", 10.0, 10, "").is_ok());
        let e = check("the number of levels", 1e8, 1000, "fewer levels").unwrap_err();
        assert_eq!(
            e.to_string(),
            "the number of levels is 100000000, above the limit of 1000: fewer levels"
        );
        assert!(check("n", f64::INFINITY, 10, "").is_err());
        assert!(check("n", f64::NAN, 10, "").is_err());
    }

    #[test]
    fn naming_spells_the_fields_by_the_callers_table() {
        let names = [("max_order", "--max-order"), ("max_delay", "--max-delay")];
        let one = check_fields(&["max_order"], "the largest order", 30.0, 20, "why").unwrap_err();
        assert_eq!(
            one.naming(&names).to_string(),
            "--max-order is 30, above the limit of 20: why"
        );
        let two = check_fields(
            &["max_order", "max_delay"],
            "the structures",
            3e5,
            100_000,
            "w",
        )
        .unwrap_err();
        assert_eq!(
            two.naming(&names).to_string(),
            "the structures (--max-order × --max-delay) is 300000, above the limit of 100000: w"
        );
        // A field the table does not know, or no field: the words stay.
        let other = check_fields(&["select"], "the selection", 30.0, 20, "w").unwrap_err();
        assert_eq!(other.clone().naming(&names), other);
        let plain = check("the levels", 30.0, 20, "w").unwrap_err();
        assert_eq!(plain.clone().naming(&names), plain);
    }
}

/// Property-test strategies for numbers the file readers accept.
#[cfg(test)]
pub(crate) mod strategies {
    use proptest::prelude::*;

    /// Any finite number within [`super::MAX_ABS_VALUE`], the bound every
    /// reader applies: all bit patterns of normal, subnormal and zero numbers,
    /// those beyond the bound folded into it by the (exact) remainder.
    pub fn finite() -> impl Strategy<Value = f64> {
        (prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO).prop_map(|v| {
            if v.abs() <= super::MAX_ABS_VALUE {
                v
            } else {
                v % super::MAX_ABS_VALUE
            }
        })
    }

    /// A positive number within the bound.
    pub fn positive() -> impl Strategy<Value = f64> {
        finite()
            .prop_map(f64::abs)
            .prop_filter("positive", |v| *v > 0.0)
    }

    /// A number of magnitude below `scale` with the bit variety of
    /// [`finite`] (for error coefficients that must stay small over a travel).
    pub fn small(scale: f64) -> impl Strategy<Value = f64> {
        finite().prop_map(move |v| v % scale)
    }
}
