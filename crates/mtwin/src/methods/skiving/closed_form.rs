//! First-order closed forms of the set-up errors, derived from the chain of
//! [`super::chain`] (a cross-check of the exact solution, never a
//! substitute).
//!
//! With `a = b = 0` the tool point `tP = (0, t, 0)` (`t = 0` face centre,
//! `t = −rt` tip) is at `(0, y + t, z)` in the machine frame; let
//! `(qx, qy) = RZ(−c)·(−x, y + t)` be its nominal position over the table
//! centre, and `ζ = z + h` its height over the nominal top face.
//! Expanding `gP = RX(−εzy)·RY(−εxz)·(q − (δgx, δgy, 0))` to first order in
//! the four unknowns (dropping products such as `εxz·δgx`):
//!
//! ```text
//! gP_x ≈ qx − δgx − εxz·ζ      gP_y ≈ qy − δgy + εzy·ζ      gP_z ≈ ζ + εxz·qx − εzy·qy
//! ```
//!
//! * a top touch (`gP_z = 0`) gives `εxz·qx − εzy·qy = −ζ` (tilts only);
//! * a side touch (`√(gP_x² + gP_y²) = rg`, linearised about `(qx, qy)`,
//!   `ρ₀ = √(qx² + qy²)`) gives
//!   `qx·δgx + qy·δgy = ρ₀(ρ₀ − rg) − εxz·ζ·qx + εzy·ζ·qy`.
//!
//! The tilts come from the top touches by least squares, then the offsets
//! from the side touches. For the six touches of the plan at `x = 0`
//! (faces at `y = ±f`) this is
//!
//! ```text
//! εzy = (z₁ − z₂)/(y₁ − y₂)          εxz = −(z₄ − z₅)/(y₄ − y₅)
//! δgy = y₃ − rt − rg + εzy·(h + z₃)  δgx = y₆ − rt − rg − εxz·(h + z₆)
//! ```
//!
//! (the patent's \[R3\] eq. 8 has `εxz` in the `δgy` formula: with this chain the
//! tilt that moves a +Y side point is the one about X, `εzy`). The dropped
//! terms are of order `ε·δ`, `ε²·ζ` and `δ²/rg`: well below a micrometre
//! and a microradian for set-up errors of 0.05 mm and 3e-4 rad.

use nalgebra::{Matrix2, Vector2};

use super::chain::{Geometry, SetupError};
use super::touch::{Contact, Touch};

/// The four formulas of the standard six-touch plan at `x = 0`, for
/// printing beside the exact solution.
pub const STANDARD_FORMULAS: [(&str, &str); 4] = [
    ("dgx", "y6 - rt - rg - exz*(h + z6)"),
    ("dgy", "y3 - rt - rg + ezy*(h + z3)"),
    ("exz", "-(z4 - z5)/(y4 - y5)"),
    ("ezy", "(z1 - z2)/(y1 - y2)"),
];

/// Why the first-order forms do not apply.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ClosedFormError {
    /// A touch (index) was made with the tool swivelled (a or b ≠ 0).
    #[error("touch {0} has a or b different from 0; the closed forms assume a = b = 0")]
    Swivelled(usize),
    /// The top touches do not determine both tilts.
    #[error(
        "the top touches do not determine both tilts (they need two table angles or two y positions each)"
    )]
    Tilts,
    /// The side touches do not determine both offsets.
    #[error(
        "the side touches do not determine both offsets (they need two table angles, e.g. c = 0° and 90°)"
    )]
    Offsets,
}

/// The set-up errors from the first-order forms above.
pub fn first_order(touches: &[Touch], g: &Geometry) -> Result<SetupError, ClosedFormError> {
    let mut tilt_n = Matrix2::zeros();
    let mut tilt_b = Vector2::zeros();
    let mut sides = Vec::new();
    for (i, t) in touches.iter().enumerate() {
        if t.at.a != 0.0 || t.at.b != 0.0 {
            return Err(ClosedFormError::Swivelled(i + 1));
        }
        let py = t.at.y + t.point.position(g).y;
        let (s, c) = t.at.c.to_radians().sin_cos();
        // RZ(−c)·(−x, py)
        let (qx, qy) = (-c * t.at.x + s * py, s * t.at.x + c * py);
        let zeta = t.at.z + g.h();
        match t.contact {
            Contact::Top => {
                let row = Vector2::new(qx, -qy);
                tilt_n += row * row.transpose();
                tilt_b += row * (-zeta);
            }
            Contact::Side => sides.push((qx, qy, zeta)),
        }
    }
    let tilts = solve2(tilt_n, tilt_b).ok_or(ClosedFormError::Tilts)?;
    let (exz, ezy) = (tilts.x, tilts.y);
    let mut n = Matrix2::zeros();
    let mut b = Vector2::zeros();
    for (qx, qy, zeta) in sides {
        let rho = qx.hypot(qy);
        let row = Vector2::new(qx, qy);
        let rhs = rho * (rho - g.rg()) - exz * zeta * qx + ezy * zeta * qy;
        n += row * row.transpose();
        b += row * rhs;
    }
    let off = solve2(n, b).ok_or(ClosedFormError::Offsets)?;
    Ok(SetupError {
        dgx: off.x,
        dgy: off.y,
        exz,
        ezy,
    })
}

/// Solves the 2×2 normal equations, `None` when they are singular
/// (relative to their size).
fn solve2(n: Matrix2<f64>, b: Vector2<f64>) -> Option<Vector2<f64>> {
    let scale = n.m11.abs().max(n.m22.abs());
    if scale.is_nan() || scale <= 0.0 || n.determinant().abs() <= 1e-12 * scale * scale {
        return None;
    }
    n.try_inverse().map(|inv| inv * b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::skiving::program::Plan;
    use crate::methods::skiving::simulate::simulate;

    fn geometry() -> Geometry {
        Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap()
    }

    const TRUTH: SetupError = SetupError {
        dgx: -0.048,
        dgy: 0.045,
        exz: -2.9e-4,
        ezy: 2.8e-4,
    };

    #[test]
    fn standard_formulas_are_what_first_order_computes() {
        let g = geometry();
        let plan = Plan::standard(0.0, &g).touches(&g).unwrap();
        let t = simulate(&plan, &g, &TRUTH, None).unwrap();
        let (y, z) = (|i: usize| t[i - 1].at.y, |i: usize| t[i - 1].at.z);
        let (h, rt, rg) = (g.h(), g.rt(), g.rg());
        let ezy = (z(1) - z(2)) / (y(1) - y(2));
        let exz = -(z(4) - z(5)) / (y(4) - y(5));
        let dgy = y(3) - rt - rg + ezy * (h + z(3));
        let dgx = y(6) - rt - rg - exz * (h + z(6));
        let f = first_order(&t, &g).unwrap();
        assert!((f.ezy - ezy).abs() < 1e-15);
        assert!((f.exz - exz).abs() < 1e-15);
        assert!((f.dgy - dgy).abs() < 1e-12);
        assert!((f.dgx - dgx).abs() < 1e-12);
    }

    #[test]
    fn first_order_is_within_its_truncation_error_of_the_truth() {
        // Dropped terms: ε·δ ≈ 1.5e-5 mm over a 60 mm lever for the tilts
        // (≈ 3e-7 rad), δ²/(2 rg) + ε²·ζ ≈ 2e-5 mm for the offsets.
        let g = geometry();
        for x in [0.0, 5.0] {
            let plan = Plan::standard(x, &g).touches(&g).unwrap();
            let t = simulate(&plan, &g, &TRUTH, None).unwrap();
            let f = first_order(&t, &g).unwrap();
            assert!((f.exz - TRUTH.exz).abs() < 1e-6, "x={x} {f:?}");
            assert!((f.ezy - TRUTH.ezy).abs() < 1e-6, "x={x} {f:?}");
            assert!((f.dgx - TRUTH.dgx).abs() < 1e-4, "x={x} {f:?}");
            assert!((f.dgy - TRUTH.dgy).abs() < 1e-4, "x={x} {f:?}");
        }
    }

    #[test]
    fn refuses_when_not_determined() {
        let g = geometry();
        let plan = Plan::standard(0.0, &g).touches(&g).unwrap();
        let t = simulate(&plan, &g, &TRUTH, None).unwrap();
        assert_eq!(first_order(&t[..3], &g), Err(ClosedFormError::Tilts));
        let no_side: Vec<Touch> = t
            .iter()
            .copied()
            .filter(|x| x.at.c == 0.0 || x.contact == Contact::Top)
            .collect();
        assert_eq!(first_order(&no_side, &g), Err(ClosedFormError::Offsets));
        let mut sw = t.clone();
        sw[2].at.a = 1.0;
        assert_eq!(first_order(&sw, &g), Err(ClosedFormError::Swivelled(3)));
    }
}
