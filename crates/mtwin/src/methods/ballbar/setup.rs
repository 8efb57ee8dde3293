//! The set-up error of the tool ball (eqs 23–26 of the source paper \[R1\]).
//!
//! The tool ball B1 sits in a cup on the spindle; clamping leaves its centre
//! off the spindle axis by `(eX, eY)` in M. With the bar mounted along +X at
//! spindle angle 0°, turning the spindle gives the readings `L` (at 0°),
//! `Lmax`, `Lmin` and `θ2`, the spindle angle of `Lmin` in the M3 sense
//! (clockwise seen from +Z). Then `R = (Lmax − Lmin)/2` is the eccentricity,
//! and in the triangle spindle axis O – B1 – B2 (sides `R`, `L`, `Lmin + R`)
//! the angle φ at B1 gives `eX = −R cos φ`, `eY = ±R sin φ` (+ when
//! `0° < θ2 ≤ 180°`).

/// The tool-ball set-up error, mm in M.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SetupError {
    /// Offset of the tool-ball centre from the spindle axis along x (mm).
    pub ex: f64,
    /// Offset along y (mm).
    pub ey: f64,
}

/// The spindle-rotation readings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetupErrorInput {
    /// Bar reading at spindle angle 0° (mm).
    pub length: f64,
    /// Largest reading over a spindle turn (mm).
    pub lmax: f64,
    /// Smallest reading over a spindle turn (mm).
    pub lmin: f64,
    /// Spindle angle of the smallest reading, degrees, M3 sense.
    pub theta2_deg: f64,
}

/// Why readings give no set-up error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SetupErrorProblem {
    /// A reading is not a positive finite length.
    #[error("{what} is {}, but it must be a positive finite length in mm", crate::limits::fmt_message_number(*.value))]
    NotALength {
        /// Which reading (L, Lmax, Lmin).
        what: &'static str,
        /// Its value, mm.
        value: f64,
    },
    /// θ2 (degrees) is not finite.
    #[error("theta2 is {}, which is not a finite angle", crate::limits::fmt_message_number(*.0))]
    BadAngle(f64),
    /// The largest reading is below the smallest.
    #[error("Lmax ({} mm) is smaller than Lmin ({} mm)", crate::limits::fmt_message_number(*.lmax), crate::limits::fmt_message_number(*.lmin))]
    MaxBelowMin {
        /// Largest reading, mm.
        lmax: f64,
        /// Smallest reading, mm.
        lmin: f64,
    },
    /// The three readings give no triangle (|cos φ| > 1).
    #[error(
        "the readings describe no triangle: cos φ = {} is outside [−1, 1] \
         (L = {} mm, Lmax = {} mm, Lmin = {} mm); check that L was read at 0° \
         and Lmax/Lmin over a full spindle turn",
        crate::limits::fmt_message_fixed(*.cos_phi, 6),
        crate::limits::fmt_message_number(*.length),
        crate::limits::fmt_message_number(*.lmax),
        crate::limits::fmt_message_number(*.lmin)
    )]
    NoTriangle {
        /// The cosine computed from the readings.
        cos_phi: f64,
        /// Bar reading at 0°, mm.
        length: f64,
        /// Largest reading, mm.
        lmax: f64,
        /// Smallest reading, mm.
        lmin: f64,
    },
}

/// `(eX, eY)` from the spindle-rotation readings (docs/ballbar.md).
pub fn setup_error(input: &SetupErrorInput) -> Result<SetupError, SetupErrorProblem> {
    let SetupErrorInput {
        length,
        lmax,
        lmin,
        theta2_deg,
    } = *input;
    for (what, value) in [("L", length), ("Lmax", lmax), ("Lmin", lmin)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(SetupErrorProblem::NotALength { what, value });
        }
    }
    if !theta2_deg.is_finite() {
        return Err(SetupErrorProblem::BadAngle(theta2_deg));
    }
    if lmax < lmin {
        return Err(SetupErrorProblem::MaxBelowMin { lmax, lmin });
    }
    let r = 0.5 * (lmax - lmin);
    if r == 0.0 {
        // The ball turns on the spindle axis: no eccentricity.
        return Ok(SetupError::default());
    }
    let cos_phi = (r * r + length * length - (lmin + r).powi(2)) / (2.0 * r * length);
    if cos_phi.is_nan() || cos_phi.abs() > 1.0 + 1e-12 {
        return Err(SetupErrorProblem::NoTriangle {
            cos_phi,
            length,
            lmax,
            lmin,
        });
    }
    let cos_phi = cos_phi.clamp(-1.0, 1.0);
    let sin_phi = (1.0 - cos_phi * cos_phi).sqrt();
    let t = theta2_deg.rem_euclid(360.0);
    let sign = if t > 0.0 && t <= 180.0 { 1.0 } else { -1.0 };
    Ok(SetupError {
        ex: -r * cos_phi,
        ey: sign * r * sin_phi,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spindle-rotation readings of a ball at `(ex, ey)` with the bar along +X
    /// at 0°, found by sampling a full M3 (clockwise) turn every 0.001°.
    fn readings(ex: f64, ey: f64, l: f64) -> SetupErrorInput {
        let b2 = (ex + l, ey);
        let mut lmax = f64::MIN;
        let (mut lmin, mut theta2) = (f64::MAX, 0.0);
        for k in 0..360_000 {
            let th = (k as f64 * 0.001_f64).to_radians();
            // Clockwise seen from +Z: rotation by −θ.
            let (s, c) = (-th).sin_cos();
            let b1 = (c * ex - s * ey, s * ex + c * ey);
            let d = ((b2.0 - b1.0).powi(2) + (b2.1 - b1.1).powi(2)).sqrt();
            lmax = lmax.max(d);
            if d < lmin {
                lmin = d;
                theta2 = k as f64 * 0.001;
            }
        }
        SetupErrorInput {
            length: l,
            lmax,
            lmin,
            theta2_deg: theta2,
        }
    }

    #[test]
    fn recovers_a_known_offset_in_every_quadrant() {
        for (ex, ey) in [
            (-0.0403, -0.0765),
            (0.05, 0.02),
            (-0.03, 0.06),
            (0.07, -0.01),
        ] {
            let e = setup_error(&readings(ex, ey, 100.0)).unwrap();
            // Sampling at 0.001° leaves ~1e-11 mm in Lmin; the angle only picks the sign.
            assert!((e.ex - ex).abs() < 1e-6, "{ex} {ey}: {e:?}");
            assert!((e.ey - ey).abs() < 1e-6, "{ex} {ey}: {e:?}");
        }
    }

    #[test]
    fn source_paper_machine_by_hand() {
        // R = 0.1, L = 100 and Lmin + R = |OB2| with the ball at (−0.06, −0.08):
        // |OB2|² = 99.94² + 0.08², φ from the cosine rule, eX = −R cos φ = −0.06.
        let ob2 = (99.94_f64.powi(2) + 0.0064).sqrt();
        let input = SetupErrorInput {
            length: 100.0,
            lmax: ob2 + 0.1,
            lmin: ob2 - 0.1,
            theta2_deg: 233.13,
        };
        let e = setup_error(&input).unwrap();
        assert!(
            (e.ex + 0.06).abs() < 1e-12 && (e.ey + 0.08).abs() < 1e-12,
            "{e:?}"
        );
    }

    #[test]
    fn rejects_readings_that_form_no_triangle() {
        let bad = SetupErrorInput {
            length: 100.0,
            lmax: 100.5,
            lmin: 99.5,
            theta2_deg: 10.0,
        };
        // R = 0.5, |OB2| = 100: cos φ = 0.25/100 → fine; make Lmin absurd instead.
        assert!(setup_error(&bad).is_ok());
        let bad = SetupErrorInput {
            lmin: 90.0,
            lmax: 90.2,
            ..bad
        };
        assert!(matches!(
            setup_error(&bad),
            Err(SetupErrorProblem::NoTriangle { .. })
        ));
        let swapped = SetupErrorInput {
            lmax: 99.0,
            lmin: 100.0,
            ..bad
        };
        assert!(matches!(
            setup_error(&swapped),
            Err(SetupErrorProblem::MaxBelowMin { .. })
        ));
        let neg = SetupErrorInput {
            length: -1.0,
            ..bad
        };
        assert!(matches!(
            setup_error(&neg),
            Err(SetupErrorProblem::NotALength { .. })
        ));
    }
}

/// Options of [`run`]: none yet; the readings are the inputs.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct SetupOptions {}

/// `mtwin ballbar setup-error`: the tool-ball set-up error (eX, eY, mm) from
/// the readings of one spindle turn, as its document.
pub fn run(
    input: &SetupErrorInput,
    _options: &SetupOptions,
) -> Result<super::BallbarSetupDoc, SetupErrorProblem> {
    setup_error(input).map(super::BallbarSetupDoc::from)
}
