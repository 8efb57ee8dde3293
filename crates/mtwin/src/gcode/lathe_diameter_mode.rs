//! Lathe diameter and radius mode (G7, G8) as LinuxCNC 2.9 reads it.
//!
//! In diameter mode (G7) every X word is a diameter: the interpreter reads
//! half its value wherever an X word is read — the end of G0, G1, G2, G3,
//! G33, G33.1 and G76 moves (absolute and incremental), G53 moves, the
//! waypoint of G28/G30, probing, canned cycles, G92/G52, G10 L1/L2/L10/L11/L20
//! and G43.1. Nothing else is halved: an arc's centre (I, K, absolute or
//! incremental) and its radius R are read as written. G76 halves its I, J
//! and K (drive line, first cut, thread depth) in diameter mode. Positions
//! (and what the interpreter reports) stay radii. G8 (radius mode, the
//! start-up mode) reads X as written.
//!
//! A G7 or G8 on the line of the move applies to its words (LinuxCNC halves
//! or doubles the X word it already read when the mode changes). For G76
//! the change of mode rescales I, J and K once more, on top of the cycle's
//! own halving in diameter mode: a `G7 G76 …` from radius mode reads I, J
//! and K at a quarter, a `G8 G76 …` from diameter mode at twice their
//! value (checked against LinuxCNC 2.9's `rs274`; see docs/gcode.md).
//!
//! The factors are computed here; the interpreter applies them to the words
//! of each block before it runs it.

use super::codes::GCode;

/// The diameter mode after a block: `before` the mode in force, `code`
/// the block's G7 or G8 (or none). `true`: diameter mode (G7).
pub fn mode_after(before: bool, code: Option<GCode>) -> bool {
    match code {
        Some(GCode::G7) => true,
        Some(GCode::G8) => false,
        _ => before,
    }
}

/// The factor the X words of a block are read with: ½ in diameter mode
/// (the mode after the block's G7/G8), 1 in radius mode.
pub fn x_factor(after: bool) -> f64 {
    if after { 0.5 } else { 1.0 }
}

/// The factor G76's I, J and K are read with, from the mode before the
/// block and after its G7/G8: the change of mode rescales them (½ to
/// diameter, 2 to radius) and the cycle halves them in diameter mode.
pub fn threading_ijk_factor(before: bool, after: bool) -> f64 {
    let change = match (before, after) {
        (false, true) => 0.5,
        (true, false) => 2.0,
        _ => 1.0,
    };
    change * x_factor(after)
}

/// The X word (program units) that reads as `radius` in the given mode:
/// twice the radius in diameter mode. Used by the program rewriters.
pub fn x_word(radius: f64, diameter: bool) -> f64 {
    if diameter { 2.0 * radius } else { radius }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mode_follows_the_last_code() {
        assert!(!mode_after(false, None));
        assert!(mode_after(true, None));
        assert!(mode_after(false, Some(GCode::G7)));
        assert!(mode_after(true, Some(GCode::G7)));
        assert!(!mode_after(true, Some(GCode::G8)));
        assert!(!mode_after(false, Some(GCode::G8)));
        // Codes of other groups leave it.
        assert!(mode_after(true, Some(GCode::G18)));
    }

    #[test]
    fn x_words_are_diameters_in_g7() {
        // A part of 30 mm diameter: the X word 30 reads as a 15 mm radius,
        // and the rewriter writes the radius back as the diameter.
        assert_eq!(30.0 * x_factor(true), 15.0);
        assert_eq!(30.0 * x_factor(false), 30.0);
        assert_eq!(x_word(15.0, true), 30.0);
        assert_eq!(x_word(15.0, false), 15.0);
    }

    #[test]
    fn g76_ijk_factors_as_linuxcnc_2_9_applies_them() {
        // Hand-derived from rs274 2.9 runs of `G76 P1 Z-10 I-2 J0.2 K1`
        // from the radius X0: first pass at X = X0 + I·f − J·f.
        // G8 throughout, from X5: 2.8 = 5 − 2 − 0.2 → f = 1.
        assert_eq!(threading_ijk_factor(false, false), 1.0);
        // G7 throughout, from X10: 8.9 = 10 − 1 − 0.1 → f = ½.
        assert_eq!(threading_ijk_factor(true, true), 0.5);
        // `G7 G76` from G8, from X10: 9.45 = 10 − 0.5 − 0.05 → f = ¼.
        assert_eq!(threading_ijk_factor(false, true), 0.25);
        // `G8 G76` from G7, from X10: 5.6 = 10 − 4 − 0.4 → f = 2.
        assert_eq!(threading_ijk_factor(true, false), 2.0);
    }

    use crate::gcode::{Axis, Dialect, Event, EventKind, GcodeError, InterpOptions, interpret};

    fn events(src: &str, opts: InterpOptions) -> Result<Vec<Event>, GcodeError> {
        let mut out = Vec::new();
        interpret(src.as_bytes(), opts, |_, ev| {
            out.extend_from_slice(ev);
            Ok(())
        })?;
        Ok(out)
    }

    /// Move ends X Z (and for arcs the centre X Z), work coordinates, mm.
    fn ends(src: &str) -> Vec<([f64; 2], Option<[f64; 2]>)> {
        events(src, InterpOptions::default())
            .unwrap()
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Traverse(m) | EventKind::Feed(m) => {
                    Some(([m.to[Axis::X], m.to[Axis::Z]], None))
                }
                EventKind::Arc(a) => Some((
                    [a.to[Axis::X], a.to[Axis::Z]],
                    Some([a.center[0], a.center[2]]),
                )),
                _ => None,
            })
            .collect()
    }

    fn assert_ends(got: &[([f64; 2], Option<[f64; 2]>)], want: &[([f64; 2], Option<[f64; 2]>)]) {
        assert_eq!(got.len(), want.len(), "{got:?}");
        for (g, w) in got.iter().zip(want) {
            let close = |a: [f64; 2], b: [f64; 2]| (0..2).all(|i| (a[i] - b[i]).abs() < 1e-9);
            assert!(close(g.0, w.0), "{g:?} against {w:?}");
            match (g.1, w.1) {
                (None, None) => {}
                (Some(a), Some(b)) => assert!(close(a, b), "{g:?} against {w:?}"),
                _ => panic!("{g:?} against {w:?}"),
            }
        }
    }

    #[test]
    fn the_interpreter_reads_x_words_as_diameters_in_g7() {
        let got = ends(
            "G21 G18 G90 G94 F100\nG0 X10 Z0\nG7\nG0 X10\nG1 X20 Z-5\nG91 G1 X4 Z-1\nG90\n\
             G0 X26 Z-6\nG2 X26 Z-14 I8 K-4\nG8 G0 X12\nG7 G0 X60\nM2\n",
        );
        assert_ends(
            &got,
            &[
                ([10.0, 0.0], None),
                // X10 is a diameter: radius 5.
                ([5.0, 0.0], None),
                ([10.0, -5.0], None),
                // Incremental X4: 2 more.
                ([12.0, -6.0], None),
                ([13.0, -6.0], None),
                // I8 is not halved: centre X 13 + 8 = 21, Z −6 − 4 = −10;
                // radius √(8² + 4²) to both ends.
                ([13.0, -14.0], Some([21.0, -10.0])),
                // G8 on the line: X12 is a radius; G7 on the line: X60 is a
                // diameter.
                ([12.0, -14.0], None),
                ([30.0, -14.0], None),
            ],
        );
    }

    #[test]
    fn offsets_set_by_x_words_are_radii() {
        let ev = events(
            "G21 G18 G90\nG7\nG0 X44 Z0\nG92 X10\nG0 X20\nG92.1\nG10 L2 P1 X10\nG0 X20\nM2\n",
            InterpOptions::default(),
        )
        .unwrap();
        let to: Vec<f64> = ev
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Traverse(m) => Some(m.to[Axis::X] + m.offset[Axis::X]),
                _ => None,
            })
            .collect();
        // Machine X: 22; G92 X10 makes 22 read 5 (offset 17), X20 → 10 + 17;
        // G54 X10 is 5 mm, X20 → 10 + 5.
        assert_eq!(to.len(), 3);
        for (g, w) in to.iter().zip([22.0, 27.0, 15.0]) {
            assert!((g - w).abs() < 1e-9, "{to:?}");
        }
    }

    #[test]
    fn rewritten_x_words_are_diameters_again() {
        let ev = events(
            "G21 G18 G90\nG7\nG1 X30 Z-2 F100\nG91 G1 X-4 Z-1\nM2\n",
            InterpOptions::default(),
        )
        .unwrap();
        let lines: Vec<_> = ev
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Feed(m) => Some(*m),
                _ => None,
            })
            .collect();
        let w0 = lines[0]
            .words
            .word_value(Axis::X, &lines[0].from, 15.0, &lines[0].offset);
        let w1 = lines[1]
            .words
            .word_value(Axis::X, &lines[1].from, 13.0, &lines[1].offset);
        assert_eq!((w0, w1), (30.0, -4.0));
        assert_eq!(
            lines[1]
                .words
                .word_value(Axis::Z, &lines[1].from, -3.0, &lines[1].offset),
            -1.0
        );
    }

    #[test]
    fn g7_and_g8_share_no_line_and_stay_refused_in_fanuc() {
        let e = events("G18 G7 G8 X10\nM2\n", InterpOptions::default()).unwrap_err();
        assert!(
            e.to_string().contains("two G-codes of one modal group"),
            "{e}"
        );
        let opts = InterpOptions {
            dialect: Dialect::Fanuc {
                decimal_point_programming: true,
            },
            ..InterpOptions::default()
        };
        let e = events("G18 G7 X10\nM30\n", opts).unwrap_err();
        assert!(matches!(e, GcodeError::Unsupported { .. }), "{e}");
        assert!(e.to_string().contains("line 1, column 5"), "{e}");
    }
}
