//! The excitation program of one axis (docs/servo.md): back-and-forth steps
//! of growing amplitude about the middle of the travel, each followed by a
//! dwell, so that a log of the commanded and encoder positions holds
//! step-like settling at several amplitudes for [`super::fit_servo`].
//!
//! Units: mm (degree for a rotary axis), mm/min (deg/min), s.

use thiserror::Error;

use crate::gcode::{Dialect, ProgramEnd, ProgramWriter, WriteError};
use crate::limits::LimitError;

/// What the excitation program does.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct ExcitationOptions {
    /// Axis letter (X, Y, Z, A, B, C, U, V or W; case-insensitive).
    pub axis: String,
    /// Allowed travel `[min, max]` (mm or degree): every move stays inside it.
    pub travel: [f64; 2],
    /// Feed of the moves, mm/min (deg/min).
    pub feed: f64,
    /// Amplitude levels: level `k` moves to `±k/levels` of the half travel
    /// about the middle, `k = 1..=levels`.
    pub levels: usize,
    /// Dwell after every move, s (0: none).
    pub dwell_s: f64,
    /// The controller dialect of the program.
    pub dialect: Dialect,
}

impl ExcitationOptions {
    /// Five levels, a dwell of 0.5 s, LinuxCNC.
    pub fn new(axis: &str, travel: [f64; 2], feed: f64) -> Self {
        ExcitationOptions {
            axis: axis.to_owned(),
            travel,
            feed,
            levels: 5,
            dwell_s: 0.5,
            dialect: Dialect::LinuxCnc,
        }
    }
}

/// Why the program cannot be written.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ExcitationError {
    /// An option out of its domain: `option` names the field of
    /// [`ExcitationOptions`] (`axis`, `travel`, `feed`, `levels`, `dwell`).
    #[error("{option} {problem}")]
    Setting {
        /// The option.
        option: &'static str,
        /// What is wrong, as "must be …, not …".
        problem: String,
    },
    /// Too many levels for a generated program.
    #[error(transparent)]
    Limit(#[from] LimitError),
    /// A value the G-code writer cannot write.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// The target positions of the program in order (after the move to the
/// middle): per level `k` the middle plus and minus `k/levels` of the half
/// travel, rounded inward to 1 µm (0.001°) so that the written text never
/// leaves the travel; then the middle again.
pub fn excitation_targets(travel: [f64; 2], levels: usize) -> Vec<f64> {
    let [lo, hi] = travel;
    let centre = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    let mut out = Vec::with_capacity(2 * levels + 1);
    for k in 1..=levels {
        let amp = half * k as f64 / levels as f64;
        out.push(((centre + amp) * 1e3).floor() / 1e3);
        out.push(((centre - amp) * 1e3).ceil() / 1e3);
    }
    out.push(centre);
    out
}

/// The excitation program (text), checked: one axis letter, positions inside
/// the travel, a positive feed, at least one level, a dwell `>= 0`.
pub fn excitation_program(o: &ExcitationOptions) -> Result<String, ExcitationError> {
    let setting = |option, problem: String| Err(ExcitationError::Setting { option, problem });
    let num = crate::limits::fmt_message_number;
    let axis = o.axis.trim().to_ascii_uppercase();
    let letter = match axis.as_bytes() {
        [c] if b"XYZABCUVW".contains(c) => char::from(*c),
        _ => {
            return setting(
                "axis",
                format!("must be one axis letter (X, Y, Z, A, B, C, U, V or W), not `{axis}`"),
            );
        }
    };
    let [lo, hi] = o.travel;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return setting(
            "travel",
            format!(
                "must be MIN,MAX with MIN < MAX, not {},{}",
                num(lo),
                num(hi)
            ),
        );
    }
    if !(o.feed.is_finite() && o.feed > 0.0) {
        return setting(
            "feed",
            format!("must be a positive feed in mm/min, not {}", num(o.feed)),
        );
    }
    if o.levels == 0 {
        return setting("levels", "must be at least 1".into());
    }
    crate::limits::check(
        "the number of levels",
        o.levels as f64,
        crate::limits::MAX_PROGRAM_POINTS / 4,
        "each level is two moves and two dwells of the program",
    )?;
    if !(o.dwell_s.is_finite() && o.dwell_s >= 0.0) {
        return setting(
            "dwell",
            format!("must be finite and >= 0 s, not {}", num(o.dwell_s)),
        );
    }
    let centre = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    let mut w = ProgramWriter::new(o.dialect);
    w.start(None)?;
    let header = format!(
        "mtwin servo excitation: axis {axis}, travel {} .. {}, F{}, {} levels",
        w.plain(lo)?,
        w.plain(hi)?,
        w.plain(o.feed)?,
        o.levels
    );
    w.comment(&header)?;
    w.comment(&format!(
        "log command and encoder positions of {axis} while this runs, then: mtwin servo fit"
    ))?;
    w.block().g(21).g(90).g(94).write()?;
    w.linear(&[(letter, centre)], Some(o.feed))?;
    let dwell = |w: &mut ProgramWriter| -> Result<(), WriteError> {
        if o.dwell_s > 0.0 {
            w.dwell(o.dwell_s)?;
        }
        Ok(())
    };
    dwell(&mut w)?;
    let targets = excitation_targets(o.travel, o.levels);
    for (k, pair) in targets[..2 * o.levels].chunks(2).enumerate() {
        let amp = half * (k + 1) as f64 / o.levels as f64;
        let line = format!("level {}: amplitude {}", k + 1, w.plain(amp)?);
        w.comment(&line)?;
        for &target in pair {
            w.linear(&[(letter, target)], None)?;
            dwell(&mut w)?;
        }
    }
    w.linear(&[(letter, centre)], None)?;
    dwell(&mut w)?;
    w.end(ProgramEnd::M30)?;
    Ok(w.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every axis word of the program's `G1` lines, in order.
    fn targets(p: &str) -> Vec<f64> {
        p.lines()
            .filter(|l| l.starts_with("G1 "))
            .map(|l| {
                let w = l.split_whitespace().nth(1).unwrap();
                w[1..].parse().unwrap()
            })
            .collect()
    }

    #[test]
    fn amplitudes_grow_evenly_inside_the_travel() {
        let mut o = ExcitationOptions::new("x", [-100.0, 60.0], 3000.0);
        o.levels = 4;
        o.dwell_s = 0.25;
        let p = excitation_program(&o).unwrap();
        // Centre −20, half travel 80: ±20, ±40, ±60, ±80 around −20.
        assert_eq!(
            targets(&p),
            vec![
                -20.0, 0.0, -40.0, 20.0, -60.0, 40.0, -80.0, 60.0, -100.0, -20.0
            ]
        );
        assert!(p.contains("G1 X-20 F3000"));
        assert_eq!(p.matches("G4 P0.25").count(), 10);
        assert!(p.trim_end().ends_with("M30\n%"));
    }

    #[test]
    fn bad_arguments_are_refused() {
        let bad = |f: &dyn Fn(&mut ExcitationOptions)| {
            let mut o = ExcitationOptions::new("X", [-1.0, 1.0], 100.0);
            f(&mut o);
            excitation_program(&o).unwrap_err()
        };
        let option = |e: ExcitationError| match e {
            ExcitationError::Setting { option, .. } => option,
            other => panic!("{other}"),
        };
        assert_eq!(option(bad(&|o| o.axis = "XY".into())), "axis");
        assert_eq!(option(bad(&|o| o.travel = [1.0, -1.0])), "travel");
        assert_eq!(option(bad(&|o| o.feed = 0.0)), "feed");
        assert_eq!(option(bad(&|o| o.levels = 0)), "levels");
        assert_eq!(option(bad(&|o| o.dwell_s = f64::NAN)), "dwell");
        assert!(matches!(
            bad(&|o| o.levels = usize::MAX),
            ExcitationError::Limit(_)
        ));
    }
}
