//! The first-order forms of the source paper \[R1\] (eqs 19–22), written as
//! `ΔL(α) = a·(1 − cos α) + b·sin α`:
//!
//! | mode | `a` | `b` |
//! |---|---|---|
//! | 1 | `EY0A − eY` | `−EZ0A` |
//! | 2 | `EY0A − eY + ZB1C·EC0A` | `ZB1C·EB0A − EZ0A` |
//! | 3 | `eX − EX0C` | `EY0A + EY0C − eY` |
//! | 4 | `eX − EX0C − ZB1A·(EB0A + EB0C)` | `EY0A + EY0C − eY − ZB1A·EA0C` |
//!
//! They hold for the orientation of \[R1\] (A about +x, C about +z) and are
//! used for the start of the joint fit and to cross-check the exact model.

use nalgebra::{Matrix3, Vector3};

use super::data::ModeData;
use super::mode::{BallbarMode, Rig};
use super::{Pige, Piges};

/// The first-order coefficients `(a, b)` of `mode` for `piges` on `rig`.
pub fn coefficients(mode: BallbarMode, piges: &Piges, rig: &Rig) -> (f64, f64) {
    let g = |p: Pige| piges.get(p);
    let (ex, ey) = (rig.setup.ex, rig.setup.ey);
    match mode {
        BallbarMode::One => (g(Pige::EY0A) - ey, -g(Pige::EZ0A)),
        BallbarMode::Two => (
            g(Pige::EY0A) - ey + rig.zb1c * g(Pige::EC0A),
            rig.zb1c * g(Pige::EB0A) - g(Pige::EZ0A),
        ),
        BallbarMode::Three => (ex - g(Pige::EX0C), g(Pige::EY0A) + g(Pige::EY0C) - ey),
        BallbarMode::Four => (
            ex - g(Pige::EX0C) - rig.zb1a * (g(Pige::EB0A) + g(Pige::EB0C)),
            g(Pige::EY0A) + g(Pige::EY0C) - ey - rig.zb1a * g(Pige::EA0C),
        ),
    }
}

/// First-order `ΔL(α) = L(α) − L(0)` (mm) of `mode` at `alpha_deg`.
pub fn first_order_delta_l(mode: BallbarMode, alpha_deg: f64, piges: &Piges, rig: &Rig) -> f64 {
    let (a, b) = coefficients(mode, piges, rig);
    let (s, c) = alpha_deg.to_radians().sin_cos();
    a * (1.0 - c) + b * s
}

/// Linear least-squares fit of `reading = ℓ + a·(1 − cos α) + b·sin α` to
/// one mode's readings: `(ℓ, a, b)`, or `None` when the angles do not
/// separate the three terms.
pub fn fit_coefficients(data: &ModeData) -> Option<(f64, f64, f64)> {
    let mut n = Matrix3::zeros();
    let mut rhs = Vector3::zeros();
    for (&al, &l) in data.angles_deg.iter().zip(&data.lengths) {
        let (s, c) = al.to_radians().sin_cos();
        let row = Vector3::new(1.0, 1.0 - c, s);
        n += row * row.transpose();
        rhs += row * l;
    }
    let x = n.cholesky()?.solve(&rhs);
    x.iter()
        .all(|v| v.is_finite())
        .then_some((x[0], x[1], x[2]))
}

/// Start values from the modes present (`data[mode.index()]`), solving the
/// table above in the order of \[R1\] (mode 1 → A offsets, 2 → A tilts,
/// 3 → C offsets, 4 → C tilts). PIGEs a missing mode would give start at 0.
/// Also returns the bar length of each mode (the nominal length when absent).
pub fn start_values(data: &[Option<&ModeData>; 4], rig: &Rig) -> (Piges, [f64; 4]) {
    let mut p = Piges::default();
    let mut lengths = [rig.length; 4];
    let (ex, ey) = (rig.setup.ex, rig.setup.ey);
    let mut coef = [None; 4];
    for m in BallbarMode::ALL {
        if let Some((l, a, b)) = data[m.index()].and_then(fit_coefficients) {
            lengths[m.index()] = l;
            coef[m.index()] = Some((a, b));
        }
    }
    if let Some((a, b)) = coef[0] {
        p.set(Pige::EY0A, a + ey);
        p.set(Pige::EZ0A, -b);
    }
    if let Some((a, b)) = coef[1] {
        p.set(Pige::EC0A, (a - p.get(Pige::EY0A) + ey) / rig.zb1c);
        p.set(Pige::EB0A, (b + p.get(Pige::EZ0A)) / rig.zb1c);
    }
    if let Some((a, b)) = coef[2] {
        p.set(Pige::EX0C, ex - a);
        p.set(Pige::EY0C, b - p.get(Pige::EY0A) + ey);
    }
    if let Some((a, b)) = coef[3] {
        p.set(
            Pige::EB0C,
            (ex - p.get(Pige::EX0C) - a) / rig.zb1a - p.get(Pige::EB0A),
        );
        p.set(
            Pige::EA0C,
            (p.get(Pige::EY0A) + p.get(Pige::EY0C) - ey - b) / rig.zb1a,
        );
    }
    (p, lengths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::ballbar::mode::{Trunnion, predicted_reading};
    use crate::methods::ballbar::setup::SetupError;
    use crate::model::parse_machine;
    use std::path::Path;

    fn machine() -> crate::model::Machine {
        parse_machine(
            Path::new("ac-trunnion.toml"),
            include_str!("../../../../../examples/machines/ac-trunnion.toml"),
        )
        .unwrap()
    }

    /// The exact model agrees with the first-order forms up to second
    /// order: halving every error (and the set-up error) quarters the gap.
    #[test]
    fn exact_model_agrees_with_the_first_order_forms_to_second_order() {
        let truth = Piges([
            0.02, -0.015, 8.7e-5, -6.1e-5, 0.014, -0.026, 4.4e-5, -9.3e-5,
        ]);
        let setup = SetupError {
            ex: -0.0403,
            ey: -0.0765,
        };
        let gap = |k: f64| {
            let mut m = machine();
            let t = Trunnion::of(&m).unwrap();
            let p = Piges(truth.0.map(|v| v * k));
            p.write_to(&mut m, &t);
            let rig = Rig {
                setup: SetupError {
                    ex: setup.ex * k,
                    ey: setup.ey * k,
                },
                ..Rig::source_paper()
            };
            let mut worst = 0.0f64;
            for mode in BallbarMode::ALL {
                for al in [-90.0, -45.0, 30.0, 90.0, 135.0, 270.0] {
                    if mode.moves_a() && !(-90.0..=90.0).contains(&al) {
                        continue;
                    }
                    let exact = predicted_reading(&m, &t, mode, &rig, 100.0, al) - 100.0;
                    let lin = first_order_delta_l(mode, al, &p, &rig);
                    // Signs and sizes must match at first order.
                    assert!(lin.abs() > 1e-4 * k, "{mode:?} {al}: {lin}");
                    worst = worst.max((exact - lin).abs());
                }
            }
            worst
        };
        let (g1, g2) = (gap(1.0), gap(0.5));
        // Second order: (set-up error)²/L ≈ 0.087²/100 ≈ 8e-5 mm dominates.
        assert!(g1 < 3e-4, "second-order gap {g1} mm");
        let ratio = g1 / g2;
        assert!((3.5..4.5).contains(&ratio), "gap ratio {ratio}");
    }

    #[test]
    fn coefficients_are_recovered_from_noise_free_first_order_readings() {
        let rig = Rig {
            setup: SetupError {
                ex: 0.01,
                ey: -0.02,
            },
            ..Rig::source_paper()
        };
        let truth = Piges([
            0.02, -0.015, 8.7e-5, -6.1e-5, 0.014, -0.026, 4.4e-5, -9.3e-5,
        ]);
        let sets: Vec<ModeData> = BallbarMode::ALL
            .iter()
            .map(|&m| {
                let angles: Vec<f64> = (-18..=18).map(|k| k as f64 * 5.0).collect();
                let lengths = angles
                    .iter()
                    .map(|&a| 100.003 + first_order_delta_l(m, a, &truth, &rig))
                    .collect();
                ModeData {
                    source: None,
                    angles_deg: angles,
                    lengths,
                }
            })
            .collect();
        let (p, l) = start_values(
            &[
                Some(&sets[0]),
                Some(&sets[1]),
                Some(&sets[2]),
                Some(&sets[3]),
            ],
            &rig,
        );
        for q in Pige::ALL {
            assert!(
                (p.get(q) - truth.get(q)).abs() < 1e-11,
                "{q}: {} {}",
                p.get(q),
                truth.get(q)
            );
        }
        assert!(l.iter().all(|&x| (x - 100.003).abs() < 1e-11));
    }
}
