//! G64 corner blends of the `jerk` planner between a line and an arc or two
//! arcs (work coordinates, all nine axes; the tolerance in XYZ, mm).
//!
//! # The curve
//!
//! Let `A(σ)` be the incoming move continued past its end and `B(σ)` the
//! outgoing move continued before its start, both with the corner at
//! `σ = 0` and `σ` in XYZ path length (mm) of the move (a helix is
//! traversed at constant speed in its parameter; an arc whose end radius
//! differs from its start radius, the interpreter's spiral, nearly so).
//! The blend of size `d` is, for `λ ∈ [0, 1]` and `σ = d (2λ − 1)`,
//!
//! `P(λ) = (1 − w(λ)) A(σ) + w(λ) B(σ)`, `w(λ) = 10λ³ − 15λ⁴ + 6λ⁵`
//!
//! (the quintic smoothstep: `w' = w'' = 0` at both ends). At `λ = 0`,
//! `P = A(−d)`, `P' = 2d A'`, `P'' = 4d² A''`; at `λ = 1` the same with `B`:
//! the blend leaves the incoming move and joins the outgoing one with the
//! same position, tangent and curvature (C² in the path parameter).
//!
//! # Distance to the programmed path
//!
//! For `λ ≤ 1/2`, `A(σ)` with `σ ∈ [−d, 0]` is a point of the programmed
//! incoming move and `P − A(σ) = w (B(σ) − A(σ))`. By Taylor's theorem,
//! `|B(σ) − A(σ)| ≤ |σ| Δ + σ² K`, with `Δ = |B'(0) − A'(0)|` (XYZ) and
//! `K = (M_A + M_B) / 2`, `M` the largest XYZ `|X''(σ)|` of a move over the
//! stretch used. With `x = 1 − 2λ`, `|σ| = d x`, the distance is at most
//! `G1 d Δ + G2 d² K`, `G1 = max w(λ)(1 − 2λ) ≈ 0.070553`,
//! `G2 = max w(λ)(1 − 2λ)² ≈ 0.026658` (over `λ ∈ [0, 1/2]`; symmetrically
//! with `1 − w` and `B` for `λ ≥ 1/2`). [`size`] takes the largest `d`
//! that keeps this bound within the tolerance `P` (and at most half of
//! each move).

use crate::gcode::axes::{Axes, Axis};

/// Upper bound of `max w(λ)(1 − 2λ)` over `λ ∈ [0, 1/2]` (0.0705529…).
pub(crate) const G1: f64 = 0.070_56;
/// Upper bound of `max w(λ)(1 − 2λ)²` over `λ ∈ [0, 1/2]` (0.0266575…).
pub(crate) const G2: f64 = 0.026_66;

/// The quintic smoothstep `10λ³ − 15λ⁴ + 6λ⁵`.
pub(crate) fn smoothstep(l: f64) -> f64 {
    l * l * l * (10.0 + l * (-15.0 + 6.0 * l))
}

/// In-plane part of an arc: the interpreter's spiral from radius `r0` to
/// `r1` about `center` in the plane of `p`, `q`, from angle `a0` by `sweep`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Circle {
    p: Axis,
    q: Axis,
    center: [f64; 2],
    r0: f64,
    r1: f64,
    a0: f64,
    sweep: f64,
}

/// A programmed move as a curve of `u` (0 at its start, 1 at its end; the
/// formula continued beyond), with its XYZ length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Curve {
    from: Axes,
    to: Axes,
    arc: Option<Circle>,
    len: f64,
}

impl Curve {
    /// A straight move of XYZ length `len` (> 0).
    pub(crate) fn line(from: Axes, to: Axes, len: f64) -> Curve {
        Curve {
            from,
            to,
            arc: None,
            len,
        }
    }

    /// An arc: every axis linear from `from` to `to` except the plane axes
    /// `p`, `q`, at `center + r (cos a, sin a)` with `r` from `r0` to `r1`
    /// and `a` from `a0` by `sweep` (rad); `len` its XYZ length (> 0).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn arc(
        from: Axes,
        to: Axes,
        (p, q): (Axis, Axis),
        center: [f64; 2],
        (r0, r1): (f64, f64),
        a0: f64,
        sweep: f64,
        len: f64,
    ) -> Curve {
        Curve {
            from,
            to,
            arc: Some(Circle {
                p,
                q,
                center,
                r0,
                r1,
                a0,
                sweep,
            }),
            len,
        }
    }

    /// True for a straight move.
    pub(crate) fn is_line(&self) -> bool {
        self.arc.is_none()
    }

    fn at_u(&self, u: f64) -> Axes {
        let mut x = Axes(std::array::from_fn(|i| {
            self.from.0[i] + (self.to.0[i] - self.from.0[i]) * u
        }));
        if let Some(c) = &self.arc {
            let a = c.a0 + c.sweep * u;
            let r = c.r0 + (c.r1 - c.r0) * u;
            x[c.p] = c.center[0] + r * a.cos();
            x[c.q] = c.center[1] + r * a.sin();
        }
        x
    }

    /// `dX/du`.
    fn d1_u(&self, u: f64) -> Axes {
        let mut x = self.to.sub(&self.from);
        if let Some(c) = &self.arc {
            let a = c.a0 + c.sweep * u;
            let r = c.r0 + (c.r1 - c.r0) * u;
            let dr = c.r1 - c.r0;
            x[c.p] = dr * a.cos() - r * c.sweep * a.sin();
            x[c.q] = dr * a.sin() + r * c.sweep * a.cos();
        }
        x
    }

    /// An upper bound of the XYZ `|d²X/dσ²|` for `u ∈ [−1/2, 3/2]`.
    fn d2_bound(&self) -> f64 {
        match &self.arc {
            None => 0.0,
            Some(c) => {
                let dr = (c.r1 - c.r0).abs();
                let r = c.r0.abs().max(c.r1.abs()) + dr / 2.0;
                (2.0 * dr * c.sweep.abs() + r * c.sweep * c.sweep) / (self.len * self.len)
            }
        }
    }

    /// The point `σ` mm of XYZ path from the end (negative: before it).
    pub(crate) fn near_end(&self, sigma: f64) -> Axes {
        self.at_u(1.0 + sigma / self.len)
    }

    /// The point `σ` mm of XYZ path from the start.
    pub(crate) fn near_start(&self, sigma: f64) -> Axes {
        self.at_u(sigma / self.len)
    }

    /// `dX/dσ` at the end.
    fn tangent_end(&self) -> Axes {
        let d = self.d1_u(1.0);
        Axes(std::array::from_fn(|i| d.0[i] / self.len))
    }

    /// `dX/dσ` at the start.
    fn tangent_start(&self) -> Axes {
        let d = self.d1_u(0.0);
        Axes(std::array::from_fn(|i| d.0[i] / self.len))
    }
}

/// The size `d` (mm of XYZ path taken from each move) of the blend from
/// `a` into `b` within `tol` (mm) of the programmed path, at most half of
/// each move; `None` when there is no corner to blend (the tangents of
/// all axes agree within 1e-12 per mm: the joint spline keeps such a
/// junction smooth) or the path reverses (XYZ tangents more than about
/// 177° apart).
pub(crate) fn size(a: &Curve, b: &Curve, tol: f64) -> Option<f64> {
    let (ta, tb) = (a.tangent_end(), b.tangent_start());
    let turn = (0..9)
        .map(|i| (tb.0[i] - ta.0[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    let (na, nb) = (ta.xyz_norm(), tb.xyz_norm());
    let cos = (0..3).map(|i| ta.0[i] * tb.0[i]).sum::<f64>() / (na * nb);
    // False for NaN too.
    let corner = turn > 1e-12 && cos >= -0.999 && tol > 0.0;
    if !corner {
        return None;
    }
    let delta = tb.sub(&ta).xyz_norm();
    let k = 0.5 * (a.d2_bound() + b.d2_bound());
    // G1 Δ d + G2 K d² = tol, the positive root in a stable form.
    let g = G1 * delta;
    let d = 2.0 * tol / (g + (g * g + 4.0 * G2 * k * tol).sqrt());
    let d = d.min(a.len / 2.0).min(b.len / 2.0);
    (d.is_finite() && d > 0.0).then_some(d)
}

/// The blend point at `λ ∈ [0, 1]` (see the module documentation).
pub(crate) fn point(a: &Curve, b: &Curve, d: f64, lambda: f64) -> Axes {
    let sigma = d * (2.0 * lambda - 1.0);
    let w = smoothstep(lambda);
    let (pa, pb) = (a.near_end(sigma), b.near_start(sigma));
    Axes(std::array::from_fn(|i| pa.0[i] + w * (pb.0[i] - pa.0[i])))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xy(x: f64, y: f64) -> Axes {
        let mut a = Axes([0.0; 9]);
        a[Axis::X] = x;
        a[Axis::Y] = y;
        a
    }

    #[test]
    fn the_bound_constants_bound_the_smoothstep_maxima() {
        let (mut m1, mut m2) = (0.0f64, 0.0f64);
        for k in 0..=1_000_000 {
            let l = 0.5 * k as f64 / 1e6;
            let (w, x) = (smoothstep(l), 1.0 - 2.0 * l);
            m1 = m1.max(w * x);
            m2 = m2.max(w * x * x);
        }
        // The grid maximum is within 1e-12 of the true one (the functions'
        // slopes vanish there); the constants lie just above.
        assert!(G1 >= m1 && G1 - m1 < 1e-5, "{m1}");
        assert!(G2 >= m2 && G2 - m2 < 1e-5, "{m2}");
        assert_eq!(smoothstep(0.0), 0.0);
        assert_eq!(smoothstep(1.0), 1.0);
    }

    #[test]
    fn line_into_quarter_circle_is_c2_at_both_ends_and_within_tol() {
        // Line along +X to (10, 0), then a G3 quarter circle of radius 5
        // about (10, 5): tangent continuous; and a G2 one about (10, −5)
        // starting upwards: a 90° corner.
        let line = Curve::line(xy(0.0, 0.0), xy(10.0, 0.0), 10.0);
        let up = Curve::arc(
            xy(10.0, 0.0),
            xy(5.0, 5.0),
            (Axis::X, Axis::Y),
            [10.0, 5.0],
            (5.0, 5.0),
            -std::f64::consts::FRAC_PI_2,
            std::f64::consts::PI,
            5.0 * std::f64::consts::PI,
        );
        assert_eq!(size(&line, &up, 0.1), None, "tangent: nothing to blend");
        // Corner: arc of radius 5 about (15, 0) from (10, 0), going up (+Y)
        // then turning right (clockwise).
        let arc = Curve::arc(
            xy(10.0, 0.0),
            xy(15.0, 5.0),
            (Axis::X, Axis::Y),
            [15.0, 0.0],
            (5.0, 5.0),
            std::f64::consts::PI,
            -std::f64::consts::FRAC_PI_2,
            2.5 * std::f64::consts::PI,
        );
        for tol in [0.01, 0.1, 0.5] {
            let d = size(&line, &arc, tol).unwrap();
            // Distance of blend points to the programmed line and circle,
            // computed here from the geometry.
            let mut worst = 0.0f64;
            for k in 0..=2000 {
                let p = point(&line, &arc, d, k as f64 / 2000.0);
                let (x, y) = (p[Axis::X], p[Axis::Y]);
                let to_line = if x <= 10.0 { y.abs() } else { f64::INFINITY };
                let ang = (y - 0.0).atan2(x - 15.0);
                let on_arc = ang >= std::f64::consts::FRAC_PI_2 - 1e-12;
                let to_arc = if on_arc {
                    ((x - 15.0).hypot(y) - 5.0).abs()
                } else {
                    f64::INFINITY
                };
                worst = worst.max(to_line.min(to_arc).min((x - 10.0).hypot(y)));
            }
            assert!(worst <= tol, "tol {tol}: {worst}");
            assert!(worst > 0.2 * tol, "tol {tol}: {worst} (bound not wasteful)");
            // Position, tangent and curvature at the ends by finite
            // differences in λ: equal to the moves' own, scaled by 2d.
            let h = 1e-4;
            let f = |l: f64| point(&line, &arc, d, l);
            let d1 = |l: f64| f(l + h).sub(&f(l - h));
            let d2 = |l: f64| {
                let (a, b, c) = (f(l - h), f(l), f(l + h));
                Axes(std::array::from_fn(|i| a.0[i] - 2.0 * b.0[i] + c.0[i]))
            };
            // At λ = 0: on the line, direction +X, no curvature.
            let s = d1(0.0);
            assert!((s[Axis::X] / (2.0 * h) - 2.0 * d).abs() < 1e-6 * d);
            assert!(s[Axis::Y].abs() / (2.0 * h) < 1e-6 * d);
            assert!(d2(0.0).xyz_norm() / (h * h) < 1e-4);
            // At λ = 1: on the arc at σ = d, tangent and curvature 1/5 of
            // the arc (|P''| = (2d)² / r).
            let end = f(1.0);
            assert!(((end[Axis::X] - 15.0).hypot(end[Axis::Y]) - 5.0).abs() < 1e-12);
            let v = d1(1.0).xyz_norm() / (2.0 * h);
            assert!((v - 2.0 * d).abs() < 1e-6 * d, "{v} {d}");
            let acc = d2(1.0).xyz_norm() / (h * h);
            assert!(
                (acc - 4.0 * d * d / 5.0).abs() < 1e-3 * acc.max(1e-3),
                "{acc}"
            );
        }
    }
}
