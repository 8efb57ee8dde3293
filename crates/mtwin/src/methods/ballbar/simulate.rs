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
