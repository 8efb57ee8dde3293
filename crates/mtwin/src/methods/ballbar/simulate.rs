//! Synthetic readings of the four modes, for planning and for tests.

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::data::ModeData;
use super::mode::{BallbarMode, Geometry, Rig, Trunnion, TrunnionError};
use crate::kinematics::Kinematics;
use crate::model::Machine;

/// How to simulate one mode.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationSpec {
    /// The rig geometry and set-up error.
    pub rig: Rig,
    /// Standard deviation of the reading noise (mm).
    pub noise: f64,
    /// Angles of the moving axis (degrees); must contain 0.
    pub angles_deg: Vec<f64>,
}

/// Angles `start, start + step, …` up to `end` (included when reached to
/// 1e-9°), degrees. Empty when `step` is not positive or `end < start`.
pub fn angle_range(start: f64, end: f64, step: f64) -> Vec<f64> {
    let valid = step > 0.0 && end >= start && start.is_finite() && end.is_finite();
    if !valid {
        return Vec::new();
    }
    let n = ((end - start) / step + 1e-9).floor() as usize;
    (0..=n).map(|k| start + k as f64 * step).collect()
}

/// Readings of `mode` on `machine` (its errors as they are): the exact bar
/// length `|B2(α) − B1|` with the bar set to `rig.length` at 0°, plus
/// Gaussian noise of standard deviation `spec.noise`.
pub fn simulate_mode<R: Rng + ?Sized>(
    machine: &Machine,
    trunnion: &Trunnion,
    mode: BallbarMode,
    spec: &SimulationSpec,
    rng: &mut R,
) -> ModeData {
    let noise = Normal::new(0.0, spec.noise.max(0.0)).unwrap_or_else(|_| {
        // Only a non-finite σ can fail; treat it as noise-free.
        Normal::new(0.0, 0.0).expect("σ = 0 is valid")
    });
    let kin = Kinematics::new(machine);
    let g = Geometry::new(&kin, trunnion, mode, &spec.rig);
    let lengths = spec
        .angles_deg
        .iter()
        .map(|&a| g.reading(spec.rig.length, a) + noise.sample(rng))
        .collect();
    ModeData {
        source: None,
        angles_deg: spec.angles_deg.clone(),
        lengths,
    }
}

/// Readings of several modes on `machine` with one seeded random stream
/// (reproducible: same seed, same readings).
pub fn simulate_modes(
    machine: &Machine,
    specs: &[(BallbarMode, SimulationSpec)],
    seed: u64,
) -> Result<Vec<ModeData>, TrunnionError> {
    let t = Trunnion::of(machine)?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    Ok(specs
        .iter()
        .map(|(m, s)| simulate_mode(machine, &t, *m, s, &mut rng))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_ranges_include_their_end() {
        assert_eq!(angle_range(-90.0, 90.0, 5.0).len(), 37);
        assert_eq!(angle_range(0.0, 360.0, 5.0).len(), 73);
        assert_eq!(angle_range(0.0, 7.0, 5.0), vec![0.0, 5.0]);
        assert!(angle_range(0.0, 10.0, 0.0).is_empty());
    }
}

/// The default angles of the four modes, degrees: −90…90° by 5° for the A
/// modes (1, 2), 0…360° by 5° for the C modes (3, 4).
pub fn default_angles() -> [Vec<f64>; 4] {
    let a = angle_range(-90.0, 90.0, 5.0);
    let c = angle_range(0.0, 360.0, 5.0);
    [a.clone(), a, c.clone(), c]
}

/// The inputs of [`run`]: the machine with the errors to simulate and the rig.
#[derive(Debug, Clone, Copy)]
pub struct SimulateInputs<'a> {
    /// The machine (a double turntable, A carrying C) with its errors.
    pub machine: &'a Machine,
    /// Bar length, tool-ball placements and set-up error (mm).
    pub rig: Rig,
}

/// Options of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct SimulateOptions {
    /// Standard deviation of the reading noise, mm (default 0.0003).
    pub noise: f64,
    /// Seed of the random numbers (same seed, same readings; default 1).
    pub seed: u64,
    /// Angles of each mode, degrees, in [`BallbarMode::ALL`] order (default [`default_angles`]).
    pub angles_deg: [Vec<f64>; 4],
    /// Names of the files the caller writes the four modes to, reported by the document.
    pub files: Vec<String>,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        Self {
            noise: 0.0003,
            seed: 1,
            angles_deg: default_angles(),
            files: Vec::new(),
        }
    }
}

/// `mtwin ballbar simulate`: the readings of the four modes (in
/// [`BallbarMode::ALL`] order) and the document.
pub fn run(
    inputs: &SimulateInputs<'_>,
    options: &SimulateOptions,
) -> Result<(Vec<ModeData>, super::BallbarSimulateDoc), TrunnionError> {
    let specs: Vec<(BallbarMode, SimulationSpec)> = BallbarMode::ALL
        .into_iter()
        .zip(&options.angles_deg)
        .map(|(m, angles)| {
            (
                m,
                SimulationSpec {
                    rig: inputs.rig,
                    noise: options.noise,
                    angles_deg: angles.clone(),
                },
            )
        })
        .collect();
    let data = simulate_modes(inputs.machine, &specs, options.seed)?;
    let doc = super::BallbarSimulateDoc {
        files: options.files.clone(),
        noise: options.noise,
        seed: options.seed,
    };
    Ok((data, doc))
}

#[cfg(test)]
mod run_tests {
    use super::*;
    use crate::methods::ballbar::{IdentifyInputs, IdentifyOptions, Pige, Piges, identify};

    /// The run functions chain: noise-free readings of a machine with known
    /// PIGEs, simulated by `simulate::run`, identify them through
    /// `identify::run` (the known truth), and the documents say so.
    #[test]
    fn simulated_readings_identify_the_true_piges() {
        let truth = crate::examples::machine("ac-trunnion-with-errors").unwrap();
        // The same machine with its PIGEs zeroed: its PDGEs are known to the fit.
        let mut nominal = truth.clone();
        Piges([0.0; 8]).write_to(&mut nominal, &Trunnion::of(&truth).unwrap());
        let rig = Rig::source_paper();
        let options = SimulateOptions {
            noise: 0.0,
            files: vec!["m1.csv".into()],
            ..Default::default()
        };
        let (data, doc) = run(
            &SimulateInputs {
                machine: &truth,
                rig,
            },
            &options,
        )
        .unwrap();
        assert_eq!(data.len(), 4);
        assert_eq!((doc.noise, doc.seed, doc.files.len()), (0.0, 1, 1));
        let modes = [0, 1, 2, 3].map(|i| Some(&data[i]));
        let id_options = IdentifyOptions {
            out: Some("id.toml".into()),
            ..Default::default()
        };
        let (id, doc) = identify::run(
            &IdentifyInputs {
                machine: &nominal,
                rig,
                modes,
            },
            &id_options,
        )
        .unwrap();
        assert_eq!(doc.out.as_deref(), Some("id.toml"));
        let t = Trunnion::of(&truth).unwrap();
        let want = Piges::from_machine(&truth, &t);
        for p in Pige::ALL {
            let tol = if p.is_tilt() { 1e-9 } else { 1e-6 };
            assert!(
                (id.piges.get(p) - want.get(p)).abs() < tol,
                "{}: {} vs {}",
                p.name(),
                id.piges.get(p),
                want.get(p)
            );
        }
    }
}
