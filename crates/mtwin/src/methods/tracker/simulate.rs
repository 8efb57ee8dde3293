//! Synthetic tracker measurements: poses in the travel, the four body
//! diagonals, and measured tips of a known ("truth") machine with Gaussian
//! noise.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::model::TrackerPoint;
use crate::kinematics::Kinematics;
use crate::model::{AxisKind, Machine};

/// `n` poses drawn uniformly in the travel of every axis (mm, degree).
pub fn random_poses<R: Rng>(machine: &Machine, n: usize, rng: &mut R) -> Vec<Vec<f64>> {
    (0..n)
        .map(|_| {
            machine
                .axes
                .iter()
                .map(|a| rng.gen_range(a.travel[0]..=a.travel[1]))
                .collect()
        })
        .collect()
}

/// Where a rotary axis rests on a body diagonal: 0 when in travel, else the
/// middle of its travel.
fn rest(t: [f64; 2]) -> f64 {
    if t[0] <= 0.0 && 0.0 <= t[1] {
        0.0
    } else {
        0.5 * (t[0] + t[1])
    }
}

/// `per_diagonal` poses evenly spaced (ends included) on each of the four body
/// diagonals of the box spanned by the first three linear axes; the other axes
/// rest (0 or mid-travel). Diagonal `d > 0` runs the linear axis `d − 1`
/// backwards. Fewer than three linear axes: the diagonals of what there is.
pub fn body_diagonal_poses(machine: &Machine, per_diagonal: usize) -> Vec<Vec<f64>> {
    let linear: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| machine.axes[i].kind == AxisKind::Linear)
        .take(3)
        .collect();
    let mut out = Vec::with_capacity(4 * per_diagonal);
    for d in 0..4 {
        for k in 0..per_diagonal {
            let s = if per_diagonal > 1 {
                k as f64 / (per_diagonal - 1) as f64
            } else {
                0.5
            };
            let q = machine
                .axes
                .iter()
                .enumerate()
                .map(|(i, a)| match linear.iter().position(|&l| l == i) {
                    Some(p) => {
                        let u = if d > 0 && p == d - 1 { 1.0 - s } else { s };
                        a.travel[0] + u * (a.travel[1] - a.travel[0])
                    }
                    None => rest(a.travel),
                })
                .collect();
            out.push(q);
        }
    }
    out
}

/// The tips of `truth` at `poses` (W, mm) plus independent Gaussian noise of
/// standard deviation `noise` (mm) on every coordinate.
///
/// # Panics
/// If `noise` is negative or not finite.
pub fn simulate<R: Rng>(
    truth: &Machine,
    poses: &[Vec<f64>],
    noise: f64,
    rng: &mut R,
) -> Vec<TrackerPoint> {
    let kin = Kinematics::new(truth);
    let normal = Normal::new(0.0, noise).expect("noise is a finite non-negative number");
    poses
        .iter()
        .map(|q| {
            let tip = kin.pose(q).tip;
            let e = Vector3::new(normal.sample(rng), normal.sample(rng), normal.sample(rng));
            TrackerPoint {
                q: q.clone(),
                measured: tip + e,
            }
        })
        .collect()
}

/// [`simulate`] with a generator seeded by `seed` (reproducible).
pub fn simulate_seeded(
    truth: &Machine,
    poses: &[Vec<f64>],
    noise: f64,
    seed: u64,
) -> Vec<TrackerPoint> {
    simulate(
        truth,
        poses,
        noise,
        &mut rand::rngs::StdRng::seed_from_u64(seed),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diagonals_join_opposite_corners() {
        let m = crate::examples::machine("afp-gantry").unwrap();
        let d = body_diagonal_poses(&m, 3);
        assert_eq!(d.len(), 12);
        assert_eq!(d[0], vec![0.0, 0.0, -1000.0, 0.0, 0.0, 0.0]);
        assert_eq!(d[2], vec![8000.0, 3500.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(d[3], vec![8000.0, 0.0, -1000.0, 0.0, 0.0, 0.0]);
        assert_eq!(d[5], vec![0.0, 3500.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(d[4], vec![4000.0, 1750.0, -500.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn noise_has_the_requested_spread_and_poses_stay_in_travel() {
        let m = crate::examples::machine("afp-gantry").unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let poses = random_poses(&m, 400, &mut rng);
        assert!(poses.iter().all(|q| m.out_of_travel(q).is_none()));
        let pts = simulate(&m, &poses, 0.01, &mut rng);
        let kin = Kinematics::new(&m);
        let dev: Vec<f64> = pts
            .iter()
            .flat_map(|p| {
                let d = p.measured - kin.pose(&p.q).tip;
                [d.x, d.y, d.z]
            })
            .collect();
        let sd = (dev.iter().map(|v| v * v).sum::<f64>() / dev.len() as f64).sqrt();
        // 1200 samples: the estimate is within ±6 % (3σ ≈ 3/√2400) of 0.010.
        assert!((sd - 0.01).abs() < 0.0006, "{sd}");
    }
}

/// Options of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct SimulateOptions {
    /// Standard deviation of the tracker noise per coordinate, mm (default 0.010).
    pub noise: f64,
    /// Seed of the random numbers (same seed, same points; default 1).
    pub seed: u64,
    /// Name of the file the caller writes the points to, reported by the document.
    pub out: String,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        Self {
            noise: 0.010,
            seed: 1,
            out: String::new(),
        }
    }
}

/// `mtwin tracker simulate`: the measured tool tips (W, mm) of `machine` at
/// `poses` (mm, degree) with seeded noise ([`simulate_seeded`]) and the document.
pub fn run(
    machine: &Machine,
    poses: &[Vec<f64>],
    options: &SimulateOptions,
) -> (Vec<TrackerPoint>, super::TrackerSimulateDoc) {
    let points = simulate_seeded(machine, poses, options.noise, options.seed);
    let doc = super::TrackerSimulateDoc {
        noise: options.noise,
        out: options.out.clone(),
        points: points.len(),
        seed: options.seed,
    };
    (points, doc)
}
