//! Simulated touch-offs: for given true set-up errors, the machine
//! coordinate at which each planned probing move makes contact, solving the
//! exact contact condition along the probe axis (the other axes held).
//!
//! Along −Z the top-face condition `gP_z(z) = 0` is affine in `z` (one
//! Newton step is exact); along −Y the side condition `ρ(y) = rg` is
//! solved by Newton's method from the nominal contact, with the root on the
//! +Y side (where `∂ρ/∂y > 0`). Optional Gaussian noise (seeded) is added to
//! the probed coordinate, as a probe's trigger repeatability would.

use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};

use super::chain::{Geometry, SetupError, probe_direction};
use super::program::{PlannedTouch, ProbeAxis};
use super::touch::{Contact, Touch};

/// Seeded Gaussian noise on the probed coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// Standard deviation, mm (≥ 0).
    pub sigma: f64,
    /// Seed of the random numbers (same seed, same noise).
    pub seed: u64,
}

/// Why a contact could not be found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SimulateError {
    /// The probing move runs parallel to the surface.
    #[error("touch {touch}: the probing move runs parallel to the surface; no contact")]
    Grazing {
        /// Index of the touch.
        touch: usize,
    },
    /// No contact along the probe axis.
    #[error("touch {touch}: no contact found along the probe axis")]
    NoContact {
        /// Index of the touch.
        touch: usize,
    },
    /// The noise σ (mm) is not finite or negative.
    #[error("the noise sigma {} mm must be finite and not negative", crate::limits::fmt_message_number(*.0))]
    Noise(f64),
}

/// The recorded touches of `plan` on a workpiece with set-up errors `truth`.
pub fn simulate(
    plan: &[PlannedTouch],
    g: &Geometry,
    truth: &SetupError,
    noise: Option<Noise>,
) -> Result<Vec<Touch>, SimulateError> {
    let mut rng_normal = match noise {
        Some(n) if !(n.sigma.is_finite() && n.sigma >= 0.0) => {
            return Err(SimulateError::Noise(n.sigma));
        }
        Some(n) if n.sigma > 0.0 => Some((
            StdRng::seed_from_u64(n.seed),
            // sigma is finite and positive: the distribution exists.
            Normal::new(0.0, n.sigma).map_err(|_| SimulateError::Noise(n.sigma))?,
        )),
        _ => None,
    };
    let mut out = Vec::with_capacity(plan.len());
    for (i, p) in plan.iter().enumerate() {
        let mut t = p.nominal();
        solve_contact(&mut t, g, truth, p.probe).map_err(|e| match e {
            Failure::Grazing => SimulateError::Grazing { touch: i + 1 },
            Failure::NoContact => SimulateError::NoContact { touch: i + 1 },
        })?;
        if let Some((rng, normal)) = rng_normal.as_mut() {
            let e = normal.sample(rng);
            match p.probe {
                ProbeAxis::MinusZ => t.at.z += e,
                ProbeAxis::MinusY => t.at.y += e,
            }
        }
        out.push(t);
    }
    Ok(out)
}

enum Failure {
    Grazing,
    NoContact,
}

/// Moves `t` along the probe axis until its contact condition holds
/// exactly (to 1e-12 mm).
fn solve_contact(
    t: &mut Touch,
    g: &Geometry,
    e: &SetupError,
    probe: ProbeAxis,
) -> Result<(), Failure> {
    let axis = match probe {
        ProbeAxis::MinusZ => 2,
        ProbeAxis::MinusY => 1,
    };
    for _ in 0..60 {
        let r = t.residual(g, e);
        let d = probe_direction(&t.at, g, e, axis);
        let slope = match t.contact {
            Contact::Top => d.z,
            Contact::Side => {
                let p = t.point_in_workpiece(g, e);
                (p.x * d.x + p.y * d.y) / p.x.hypot(p.y)
            }
        };
        if slope.is_nan() || slope.abs() <= 1e-6 {
            return Err(Failure::Grazing);
        }
        // Step limited to 5 mm so Newton cannot jump to the far side.
        let step = (-r / slope).clamp(-5.0, 5.0);
        match probe {
            ProbeAxis::MinusZ => t.at.z += step,
            ProbeAxis::MinusY => t.at.y += step,
        }
        if step.abs() < 1e-12 {
            return if t.residual(g, e).abs() < 1e-10 {
                Ok(())
            } else {
                Err(Failure::NoContact)
            };
        }
    }
    Err(Failure::NoContact)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::skiving::program::Plan;

    fn geometry() -> Geometry {
        Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap()
    }

    const TRUTH: SetupError = SetupError {
        dgx: 0.037,
        dgy: -0.041,
        exz: 2.6e-4,
        ezy: -2.2e-4,
    };

    #[test]
    fn simulated_touches_satisfy_their_conditions_exactly() {
        let g = geometry();
        let plan = Plan::standard(0.0, &g).touches(&g).unwrap();
        let t = simulate(&plan, &g, &TRUTH, None).unwrap();
        for (ti, p) in t.iter().zip(&plan) {
            assert!(ti.residual(&g, &TRUTH).abs() < 1e-11);
            // Only the probed coordinate moved.
            match p.probe {
                ProbeAxis::MinusZ => assert_eq!(ti.at.y, p.y),
                ProbeAxis::MinusY => assert_eq!(ti.at.z, p.z),
            }
        }
    }

    #[test]
    fn first_touch_matches_a_hand_derivation() {
        // Touch 1 (c = 0, face centre at machine (0, f, z), workpiece centre at
        // X = 0): gP_z = −sin εzy·(f − δgy) + cos εzy·(sin εxz·(−δgx) + cos εxz·(z + h)) = 0.
        let g = geometry();
        let plan = Plan::standard(0.0, &g).touches(&g).unwrap();
        let t = simulate(&plan, &g, &TRUTH, None).unwrap();
        let f = plan[0].y;
        let (s2, c2) = TRUTH.ezy.sin_cos();
        let (s1, c1) = TRUTH.exz.sin_cos();
        let z = (s2 * (f - TRUTH.dgy) / c2 + s1 * TRUTH.dgx) / c1 - g.h();
        assert!((t[0].at.z - z).abs() < 1e-12, "{} vs {z}", t[0].at.z);
    }

    #[test]
    fn noise_is_seeded_and_on_the_probe_axis() {
        let g = geometry();
        let plan = Plan::standard(0.0, &g).touches(&g).unwrap();
        let clean = simulate(&plan, &g, &TRUTH, None).unwrap();
        let n = Some(Noise {
            sigma: 1e-3,
            seed: 7,
        });
        let a = simulate(&plan, &g, &TRUTH, n).unwrap();
        let b = simulate(&plan, &g, &TRUTH, n).unwrap();
        assert_eq!(a, b);
        for (x, c) in a.iter().zip(&clean) {
            let moved = (x.at.y - c.at.y).abs() + (x.at.z - c.at.z).abs();
            assert!(moved > 0.0 && moved < 6e-3);
            assert!(x.at.y == c.at.y || x.at.z == c.at.z);
        }
        assert!(
            simulate(
                &plan,
                &g,
                &TRUTH,
                Some(Noise {
                    sigma: -1.0,
                    seed: 0
                })
            )
            .is_err()
        );
    }
}

/// Options of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct SimulateOptions {
    /// Standard deviation of the touch noise along the probing direction, mm (default 0).
    pub sigma: f64,
    /// Seed of the first pass; pass `r` uses `seed + r` (default 1).
    pub seed: u64,
    /// How many times the plan is touched (default 1).
    pub repeat: u32,
    /// Name of the file the caller writes the touches to, reported by the document.
    pub out: String,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        Self {
            sigma: 0.0,
            seed: 1,
            repeat: 1,
            out: String::new(),
        }
    }
}

/// `mtwin skiving simulate`: the touches of `plan` on the workpiece `g`
/// set up with the error `truth`, `options.repeat` times with seeded noise
/// ([`simulate`]), and the document.
pub fn run(
    plan: &[PlannedTouch],
    g: &Geometry,
    truth: &SetupError,
    options: &SimulateOptions,
) -> Result<(Vec<Touch>, super::doc::SkivingSimulateDoc), SimulateError> {
    let mut touches = Vec::new();
    for r in 0..options.repeat {
        let noise = Some(Noise {
            sigma: options.sigma,
            seed: options.seed.wrapping_add(u64::from(r)),
        });
        touches.extend(simulate(plan, g, truth, noise)?);
    }
    let doc = super::doc::SkivingSimulateDoc {
        out: options.out.clone(),
        touches: touches.len(),
    };
    Ok((touches, doc))
}
