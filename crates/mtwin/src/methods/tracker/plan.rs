//! Measurement planning: which of a set of candidate poses to measure.
//!
//! Greedy D-optimal selection on the column-scaled Jacobian of the tool tip
//! at the nominal machine. With `A_c` the 3×n scaled block of candidate c and
//! `M = δI + Σ_selected A_sᵀA_s`, each step adds the candidate maximising
//! `log det M`, i.e. `log det(I₃ + A_c M⁻¹ A_cᵀ)` (matrix determinant
//! lemma). `M⁻¹` and every candidate's `S_c = A_c M⁻¹ A_cᵀ` are updated by
//! the Woodbury identity after each pick, `O(N·n)` per step. The small
//! ridge `δ` makes the criterion defined while fewer poses than parameters
//! are chosen and lets it ignore directions no candidate can see.

use nalgebra::{DMatrix, Matrix3, Vector3};

use rand::{Rng, SeedableRng};

use super::identify::{IdentifyOptions, TrackerIdentifyError, identify};
use super::model::{TrackerModel, TrackerPoint};
use super::simulate::simulate;
use crate::fit::FitReport;
use crate::fit::{Model, problem::BlockLayout};
use crate::gcode::{Axis, Dialect, ProgramEnd, ProgramWriter, WriteError};
use crate::model::{Machine, ParameterSet};

/// Ridge added to the scaled information matrix (columns have unit norm
/// over all candidates).
pub const RIDGE: f64 = 1e-6;

/// The scaled 3×n blocks of every candidate pose (nominal machine, columns
/// of unit norm over all candidates; zero columns stay zero).
pub fn scaled_blocks(
    machine: &Machine,
    params: &ParameterSet,
    candidates: &[Vec<f64>],
) -> Vec<DMatrix<f64>> {
    let nominal = machine.nominal();
    let points: Vec<TrackerPoint> = candidates
        .iter()
        .map(|q| TrackerPoint {
            q: q.clone(),
            measured: Vector3::zeros(),
        })
        .collect();
    let model = TrackerModel::new(&nominal, params, &points, false);
    let n = model.len();
    let rows = BlockLayout::uniform("c", points.len(), 3).rows();
    let mut j = faer::Mat::<f64>::zeros(rows, n);
    let theta = vec![0.0; n];
    model.jacobian(&theta, 0..rows, j.as_mut());
    let norms: Vec<f64> = (0..n)
        .map(|c| (0..rows).map(|r| j[(r, c)].powi(2)).sum::<f64>().sqrt())
        .collect();
    let max = norms.iter().copied().fold(0.0, f64::max);
    (0..points.len())
        .map(|b| {
            DMatrix::from_fn(3, n, |x, c| {
                if norms[c] > 1e-13 * max {
                    j[(3 * b + x, c)] / norms[c]
                } else {
                    0.0
                }
            })
        })
        .collect()
}

/// `log det(δI + Σ_{s∈selected} A_sᵀA_s)` computed directly (Cholesky).
pub fn log_det(blocks: &[DMatrix<f64>], selected: &[usize]) -> f64 {
    let n = blocks.first().map_or(0, |b| b.ncols());
    let mut m = DMatrix::<f64>::identity(n, n) * RIDGE;
    for &s in selected {
        m += blocks[s].transpose() * &blocks[s];
    }
    match m.cholesky() {
        Some(c) => 2.0 * c.l().diagonal().iter().map(|d| d.ln()).sum::<f64>(),
        None => f64::NEG_INFINITY,
    }
}

/// Greedy D-optimal choice of `k` of the candidate blocks (indices in the
/// order picked; ties go to the lower index). `k` is clamped to the number of
/// candidates.
pub fn select_d_optimal(blocks: &[DMatrix<f64>], k: usize) -> Vec<usize> {
    let nc = blocks.len();
    let k = k.min(nc);
    let n = blocks.first().map_or(0, |b| b.ncols());
    let mut minv = DMatrix::<f64>::identity(n, n) / RIDGE;
    let mut s: Vec<Matrix3<f64>> = blocks
        .iter()
        .map(|a| {
            let p = a * a.transpose() / RIDGE;
            Matrix3::from_fn(|r, c| p[(r, c)])
        })
        .collect();
    let mut taken = vec![false; nc];
    let mut out = Vec::with_capacity(k);
    for _ in 0..k {
        let mut best = (f64::NEG_INFINITY, usize::MAX);
        for c in 0..nc {
            if taken[c] {
                continue;
            }
            let g = (Matrix3::identity() + s[c]).determinant().ln();
            if g > best.0 {
                best = (g, c);
            }
        }
        let c = best.1;
        if c == usize::MAX {
            break;
        }
        taken[c] = true;
        out.push(c);
        let u = &minv * blocks[c].transpose(); // n×3
        let Some(w) = (Matrix3::identity() + s[c]).try_inverse() else {
            break;
        };
        let wd = DMatrix::from_fn(3, 3, |r, q| w[(r, q)]);
        minv -= &u * &wd * u.transpose();
        for d in 0..nc {
            if !taken[d] {
                let bd = &blocks[d] * &u; // 3×3
                let b3 = Matrix3::from_fn(|r, q| bd[(r, q)]);
                s[d] -= b3 * w * b3.transpose();
            }
        }
    }
    out
}

/// What measuring `poses` with tracker noise `noise` (mm, standard deviation
/// per coordinate, > 0) would identify: the identification of a simulated
/// measurement of the nominal machine, with the uncertainties rescaled from
/// the residual spread of that simulation to exactly `noise`.
pub fn expected<R: Rng>(
    machine: &Machine,
    params: &ParameterSet,
    poses: &[Vec<f64>],
    noise: f64,
    rng: &mut R,
) -> Result<FitReport, TrackerIdentifyError> {
    let nominal = machine.nominal();
    let points = simulate(&nominal, poses, noise, rng);
    // The pivoted basic solution: unidentifiable parameters get no expected
    // uncertainty.
    let mut options = IdentifyOptions::default();
    options.fit.gauge = crate::fit::Gauge::Pivoted;
    let id = identify(&nominal, params, &points, &options, &|_| {})?;
    let mut report = id.report;
    if let Some(s) = report.sigma.filter(|&s| s > 0.0) {
        for e in &mut report.estimates {
            e.uncertainty = e.uncertainty.map(|u| u * noise / s);
        }
    }
    Ok(report)
}

/// A measurement plan: chosen poses and what they would identify.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The chosen poses, in the order picked (mm, degree).
    pub poses: Vec<Vec<f64>>,
    /// Expected identification (see [`expected`]).
    pub expected: FitReport,
}

/// Checks the size of a plan before any work: at most
/// [`crate::limits::MAX_TRACKER_CANDIDATES`] candidates, and the selection
/// work (`candidates × select`, each step of the D-optimal selection scores
/// every candidate) at most [`crate::limits::MAX_TRACKER_WORK`]. The
/// error's [`fields`](crate::limits::LimitError::fields) are `candidates` and
/// `select`, the names of the arguments of [`plan`].
pub fn check_plan_size(candidates: usize, select: usize) -> Result<(), crate::limits::LimitError> {
    crate::limits::check_fields(
        &["candidates"],
        "the number of candidates",
        candidates as f64,
        crate::limits::MAX_TRACKER_CANDIDATES,
        "every candidate holds a Jacobian; use fewer candidates",
    )?;
    crate::limits::check_fields(
        &["candidates", "select"],
        "candidates × selected poses",
        candidates as f64 * select as f64,
        crate::limits::MAX_TRACKER_WORK,
        "the selection scores every candidate for every selected pose; use fewer candidates or select fewer poses",
    )
}

/// Draws `candidates` poses uniformly in the travel (seeded), keeps the
/// `select` D-optimal ones and evaluates them with [`expected`].
pub fn plan(
    machine: &Machine,
    params: &ParameterSet,
    candidates: usize,
    select: usize,
    noise: f64,
    seed: u64,
) -> Result<Plan, TrackerIdentifyError> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let cands = super::simulate::random_poses(machine, candidates, &mut rng);
    let blocks = scaled_blocks(machine, params, &cands);
    let chosen = select_d_optimal(&blocks, select);
    let poses: Vec<Vec<f64>> = chosen.iter().map(|&c| cands[c].clone()).collect();
    let expected = expected(machine, params, &poses, noise, &mut rng)?;
    Ok(Plan { poses, expected })
}

/// The pose program in `dialect` (written by [`ProgramWriter`]): rapid-free
/// linear moves to every pose at `feed` with a dwell of `dwell_s` for the
/// tracker reading, one axis word per machine axis in machine order (mm,
/// degree). Fails if an axis name is not a G-code axis letter or a value
/// cannot be written.
pub fn gcode(
    machine: &Machine,
    poses: &[Vec<f64>],
    feed: f64,
    dwell_s: f64,
    dialect: Dialect,
) -> Result<String, WriteError> {
    let letters: Vec<char> = Axis::of_machine(machine)?
        .into_iter()
        .map(|a| char::from(a.letter()))
        .collect();
    let mut w = ProgramWriter::new(dialect);
    w.start(None)?;
    w.comment("mtwin tracker plan: measurement poses")?;
    w.block().g(90).g(21).g(94).write()?;
    for (k, q) in poses.iter().enumerate() {
        w.comment(&format!("POSE {}", k + 1))?;
        let words: Vec<(char, f64)> = letters.iter().copied().zip(q.iter().copied()).collect();
        w.linear(&words, Some(feed))?;
        w.dwell(dwell_s)?;
    }
    w.end(ProgramEnd::M30)?;
    Ok(w.finish())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::tracker::simulate::random_poses;

    #[test]
    fn greedy_choice_beats_random_subsets_and_its_updates_are_exact() {
        let m = crate::examples::machine("afp-gantry").unwrap();
        let params = ParameterSet::from_spec(&m, "pdge:cheb2,location").unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let cands = random_poses(&m, 150, &mut rng);
        let blocks = scaled_blocks(&m, &params, &cands);
        let k = 50;
        let sel = select_d_optimal(&blocks, k);
        assert_eq!(sel.len(), k);
        let mut uniq = sel.clone();
        uniq.sort();
        uniq.dedup();
        assert_eq!(uniq.len(), k);
        // The first pick maximises log det(I + A_cᵀA_c/δ) alone: check by brute force.
        let first = (0..blocks.len())
            .max_by(|&a, &b| log_det(&blocks, &[a]).total_cmp(&log_det(&blocks, &[b])))
            .unwrap();
        assert_eq!(sel[0], first);
        // Greedy with exact updates: the second pick is the brute-force best pair with the first.
        let second = (0..blocks.len())
            .filter(|&c| c != sel[0])
            .max_by(|&a, &b| {
                log_det(&blocks, &[sel[0], a]).total_cmp(&log_det(&blocks, &[sel[0], b]))
            })
            .unwrap();
        assert_eq!(sel[1], second);
        let ours = log_det(&blocks, &sel);
        for trial in 0..5 {
            let mut idx: Vec<usize> = (0..blocks.len()).collect();
            use rand::seq::SliceRandom;
            idx.shuffle(&mut rng);
            let random = log_det(&blocks, &idx[..k]);
            assert!(ours > random, "trial {trial}: {ours} vs {random}");
        }
    }

    #[test]
    fn expected_uncertainty_of_a_constant_is_noise_over_root_n() {
        // One constant x offset seen at every pose with unit sensitivity:
        // its least-squares estimate is the mean of N x readings, σ/√N.
        let m = crate::examples::machine("afp-gantry").unwrap();
        let params = ParameterSet::from_spec(&m, "EXX:const").unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let poses = random_poses(&m, 25, &mut rng);
        let r = expected(&m, &params, &poses, 0.01, &mut rng).unwrap();
        let u = r.estimates[0].uncertainty.unwrap();
        assert!((u - 0.01 / 5.0).abs() < 1e-12, "{u}");
    }

    #[test]
    fn gcode_lists_every_pose_with_a_dwell() {
        let m = crate::examples::machine("afp-gantry").unwrap();
        let g = gcode(
            &m,
            &[vec![1.0, 2.0, -3.25, 4.0, 5.0, 6.0]],
            3000.0,
            2.0,
            Dialect::LinuxCnc,
        )
        .unwrap();
        assert!(
            g.contains("(POSE 1)\nG1 X1 Y2 Z-3.25 B4 A5 C6 F3000\nG4 P2\n"),
            "{g}"
        );
        assert!(g.starts_with("%\n") && g.ends_with("M30\n%\n"), "{g}");
    }
}

/// The inputs of [`run`]: the machine and what the measurement should identify.
#[derive(Debug, Clone, Copy)]
pub struct PlanInputs<'a> {
    /// The nominal machine.
    pub machine: &'a Machine,
    /// The parameters to identify (a fit specification's set).
    pub params: &'a ParameterSet,
}

/// Options of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct PlanOptions {
    /// Random candidate poses drawn in the travel (default 1000).
    pub candidates: usize,
    /// Poses kept (default 180).
    pub select: usize,
    /// Tracker noise per coordinate, mm (default 0.010).
    pub noise: f64,
    /// Seed of the random numbers (default 1).
    pub seed: u64,
    /// Feed of the pose program, mm/min (default 2000).
    pub feed: f64,
    /// Dwell at each pose for the tracker reading, s (default 2).
    pub dwell_s: f64,
    /// The controller the pose program is written for (default LinuxCNC).
    pub dialect: Dialect,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            candidates: 1000,
            select: 180,
            noise: 0.010,
            seed: 1,
            feed: 2000.0,
            dwell_s: 2.0,
            dialect: Dialect::LinuxCnc,
        }
    }
}

/// `mtwin tracker plan`: the plan ([`plan`]), its pose program ([`gcode`])
/// and the document.
pub fn run(
    inputs: &PlanInputs<'_>,
    options: &PlanOptions,
) -> Result<(Plan, String, super::TrackerPlanDoc), TrackerIdentifyError> {
    let p = plan(
        inputs.machine,
        inputs.params,
        options.candidates,
        options.select,
        options.noise,
        options.seed,
    )?;
    let program = gcode(
        inputs.machine,
        &p.poses,
        options.feed,
        options.dwell_s,
        options.dialect,
    )?;
    let doc = super::TrackerPlanDoc::new(
        &p.expected,
        p.poses.len(),
        options.candidates,
        options.noise,
    );
    Ok((p, program, doc))
}
