//! End-to-end tests of the engine on problems with a known truth.

// Parameter-by-parameter comparisons read best with an index.
#![allow(clippy::needless_range_loop)]

use std::ops::Range;

use faer::{Mat, MatMut};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::*;

/// `r = A·θ − y`, blocks of `block` rows, all in group `label`.
struct Linear {
    a: Mat<f64>,
    y: Vec<f64>,
    block: usize,
    label: String,
    params: Vec<Parameter>,
}

impl Linear {
    fn new(a: Mat<f64>, y: Vec<f64>, block: usize) -> Self {
        let params = (0..a.ncols())
            .map(|j| Parameter::new(format!("p{j}")))
            .collect();
        Self {
            a,
            y,
            block,
            label: "data".into(),
            params,
        }
    }
}

impl Model for Linear {
    fn parameters(&self) -> Vec<Parameter> {
        self.params.clone()
    }
    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform(self.label.clone(), self.a.nrows() / self.block, self.block)
    }
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        if let Some(out) = r {
            for (o, i) in out.iter_mut().zip(rows.clone()) {
                *o = (0..self.a.ncols())
                    .map(|j| self.a[(i, j)] * theta[j])
                    .sum::<f64>()
                    - self.y[i];
            }
        }
        if let Some(mut out) = j {
            for (k, i) in rows.enumerate() {
                for j in 0..self.a.ncols() {
                    out[(k, j)] = self.a[(i, j)];
                }
            }
        }
    }
}

/// Random matrix with entries uniform in [−1, 1].
fn random_matrix(rng: &mut StdRng, m: usize, n: usize) -> Mat<f64> {
    Mat::from_fn(m, n, |_, _| rng.gen_range(-1.0..1.0))
}

fn apply(a: &Mat<f64>, theta: &[f64]) -> Vec<f64> {
    (0..a.nrows())
        .map(|i| (0..a.ncols()).map(|j| a[(i, j)] * theta[j]).sum())
        .collect()
}

/// Distance of points from a circle: θ = (cx, cy, R), `r_i = ‖p_i − c‖ − R`.
struct Circle {
    points: Vec<[f64; 2]>,
    /// Deliberately wrong Jacobian (sign of ∂r/∂cy flipped), for the checker.
    wrong: bool,
}

impl Model for Circle {
    fn parameters(&self) -> Vec<Parameter> {
        vec![
            Parameter::new("cx"),
            Parameter::new("cy"),
            Parameter::new("R"),
        ]
    }
    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform("circle", self.points.len(), 1)
    }
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        if let Some(out) = r {
            let t = theta;
            for (o, i) in out.iter_mut().zip(rows.clone()) {
                let [x, y] = self.points[i];
                *o = (x - t[0]).hypot(y - t[1]) - t[2];
            }
        }
        if let Some(mut out) = j {
            let t = theta;
            for (k, i) in rows.enumerate() {
                let [x, y] = self.points[i];
                let d = (x - t[0]).hypot(y - t[1]);
                out[(k, 0)] = -(x - t[0]) / d;
                out[(k, 1)] = if self.wrong { 1.0 } else { -1.0 } * (y - t[1]) / d;
                out[(k, 2)] = -1.0;
            }
        }
    }
}

/// `y = A·exp(−k·t) + c`, θ = (A, k, c).
struct Decay {
    t: Vec<f64>,
    y: Vec<f64>,
}

impl Model for Decay {
    fn parameters(&self) -> Vec<Parameter> {
        vec![
            Parameter::new("A"),
            Parameter::new("k"),
            Parameter::new("c"),
        ]
    }
    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform("decay", self.t.len(), 1)
    }
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        if let Some(out) = r {
            let th = theta;
            for (o, i) in out.iter_mut().zip(rows.clone()) {
                *o = th[0] * (-th[1] * self.t[i]).exp() + th[2] - self.y[i];
            }
        }
        if let Some(mut out) = j {
            let th = theta;
            for (k, i) in rows.enumerate() {
                let e = (-th[1] * self.t[i]).exp();
                out[(k, 0)] = e;
                out[(k, 1)] = -th[0] * self.t[i] * e;
                out[(k, 2)] = 1.0;
            }
        }
    }
}

/// Linear part plus a mild quadratic term: `r = A·θ + ½·β·(b·θ)²·w − y`.
struct Mild {
    lin: Linear,
    b: Vec<f64>,
    w: Vec<f64>,
    beta: f64,
}

impl Model for Mild {
    fn parameters(&self) -> Vec<Parameter> {
        self.lin.parameters()
    }
    fn layout(&self) -> BlockLayout {
        self.lin.layout()
    }
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        if let Some(out) = r {
            let th = theta;
            self.lin.residuals(th, rows.clone(), out);
            let s: f64 = self.b.iter().zip(th).map(|(a, b)| a * b).sum();
            for (o, i) in out.iter_mut().zip(rows.clone()) {
                *o += 0.5 * self.beta * s * s * self.w[i];
            }
        }
        if let Some(mut out) = j {
            let th = theta;
            self.lin.jacobian(th, rows.clone(), out.as_mut());
            let s: f64 = self.b.iter().zip(th).map(|(a, b)| a * b).sum();
            for (k, i) in rows.enumerate() {
                for j in 0..self.b.len() {
                    out[(k, j)] += self.beta * s * self.b[j] * self.w[i];
                }
            }
        }
    }
}

fn dense() -> Options {
    Options {
        strategy: Strategy::Dense,
        ..Options::default()
    }
}

#[test]
fn linear_problem_recovers_the_exact_solution() {
    let mut rng = StdRng::seed_from_u64(1);
    let a = random_matrix(&mut rng, 60, 5);
    let truth = [0.3, -1.2, 2.5, 1e-3, -7.0];
    let y = apply(&a, &truth);
    let model = Linear::new(a, y, 3);
    let rep = fit(&model, &[0.0; 5], &dense()).unwrap();
    for (e, t) in rep.theta.iter().zip(&truth) {
        assert!((e - t).abs() < 1e-12, "{e} vs {t}");
    }
    assert!(rep.convergence.reason.converged());
    assert_eq!(rep.identifiability.rank, 5);
    assert!(rep.warnings.is_empty(), "{:?}", rep.warnings);
    assert!(rep.groups[0].rms_after < 1e-12);
    // RMS before: the data themselves, since θ0 = 0 gives r = −y.
    let ry = (apply(&model.a, &truth).iter().map(|x| x * x).sum::<f64>() / 60.0).sqrt();
    assert!((rep.groups[0].rms_before - ry).abs() < 1e-12 * ry);
}

#[test]
fn circle_converges_from_a_poor_start() {
    let truth = [1.5, -2.0, 3.0];
    let points = (0..24)
        .map(|i| {
            // Only a 200° arc: a harder, less symmetric problem.
            let a = (i as f64) * 200f64.to_radians() / 23.0;
            [truth[0] + truth[2] * a.cos(), truth[1] + truth[2] * a.sin()]
        })
        .collect();
    let model = Circle {
        points,
        wrong: false,
    };
    // Centre 3 away from the truth, radius a third of it.
    let rep = fit(&model, &[0.0, 0.5, 1.0], &dense()).unwrap();
    assert!(rep.convergence.reason.converged(), "{:?}", rep.convergence);
    for (e, t) in rep.theta.iter().zip(&truth) {
        assert!((e - t).abs() < 1e-9, "{e} vs {t}");
    }
    assert!(rep.convergence.final_cost < 1e-20);
    assert!(rep.convergence.initial_cost > 1.0);
}

#[test]
fn exponential_decay_converges_from_a_poor_start() {
    let truth = [5.0, 0.7, -1.0];
    let t: Vec<f64> = (0..40).map(|i| i as f64 * 0.25).collect();
    let y = t
        .iter()
        .map(|&t| truth[0] * (-truth[1] * t).exp() + truth[2])
        .collect();
    let model = Decay { t, y };
    // Amplitude a fifth, rate four times too fast, offset wrong in sign.
    // (With a negative amplitude the problem slides off towards k → 0, a
    // genuine valley of this cost, not a failure of the engine.)
    for strategy in [Strategy::Dense, Strategy::NormalEquations] {
        let opts = Options {
            strategy,
            ..Options::default()
        };
        let rep = fit(&model, &[1.0, 2.8, 1.0], &opts).unwrap();
        assert!(rep.convergence.reason.converged(), "{:?}", rep.convergence);
        for (e, tr) in rep.theta.iter().zip(&truth) {
            assert!((e - tr).abs() < 1e-7, "{strategy:?}: {e} vs {tr}");
        }
    }
}

#[test]
fn confounded_pair_is_reported_and_one_is_fixed() {
    let mut rng = StdRng::seed_from_u64(3);
    let mut a = random_matrix(&mut rng, 45, 4);
    for i in 0..45 {
        a[(i, 2)] = a[(i, 1)];
    }
    let truth = [0.5, 1.0, 2.0, -0.25];
    let y = apply(&a, &truth);
    let mut model = Linear::new(a, y, 3);
    model.params[1] = Parameter::new("EXX.c0");
    model.params[2] = Parameter::new("EX0Y");
    let start = [0.0, 0.0, 0.0, 0.0];
    let rep = fit(&model, &start, &dense()).unwrap();
    let id = &rep.identifiability;
    assert_eq!(id.rank, 3);
    assert_eq!(id.null_space.len(), 1);
    let v = &id.null_space[0].scaled;
    let h = 0.5f64.sqrt();
    assert!(
        (v[1] - h).abs() < 1e-10 && (v[2] + h).abs() < 1e-10,
        "{v:?}"
    );
    assert!(v[0].abs() < 1e-10 && v[3].abs() < 1e-10);
    assert_eq!(id.null_space[0].describe(), "EXX.c0 − 1.0000·EX0Y ≈ 0");
    // The relation of the fixed parameter: column 2 equals column 1.
    assert_eq!(id.relations.len(), 1);
    let rel = &id.relations[0].scaled;
    assert!(
        (rel[2].abs() - h).abs() < 1e-10 && (rel[1] + rel[2]).abs() < 1e-10,
        "{rel:?}"
    );
    // Ties go to the first listed: EX0Y is fixed at its start value and
    // EXX.c0 carries the sum.
    assert_eq!(id.unidentifiable, vec![(2, Unidentifiable::Confounded)]);
    assert_eq!(rep.theta[2], start[2]);
    assert!((rep.theta[1] - (truth[1] + truth[2])).abs() < 1e-12);
    assert!((rep.theta[0] - truth[0]).abs() < 1e-12);
    assert!((rep.theta[3] - truth[3]).abs() < 1e-12);
    assert_eq!(rep.unidentifiable_names(), vec!["EX0Y"]);
    assert!(rep.warnings.contains(&Warning::RankDeficient {
        rank: 3,
        parameters: 4
    }));
    assert!(rep.estimates[2].uncertainty.is_none());
    // The fixed-parameter solution is a least-squares solution: its
    // residuals vanish like the truth's, and its minimum-norm counterpart
    // (θ1 = θ2 = (θ1 + θ2)/2) differs only along the null vector.
    assert!(rep.convergence.final_cost < 1e-24);
}

#[test]
fn relations_are_sparse_null_directions() {
    // Two independent confoundings: p3 = p0 + 2·p1 and p4 = p2 (columns).
    let mut rng = StdRng::seed_from_u64(33);
    let mut a = random_matrix(&mut rng, 50, 6);
    for i in 0..50 {
        a[(i, 3)] = a[(i, 0)] + 2.0 * a[(i, 1)];
        a[(i, 4)] = a[(i, 2)];
    }
    let y = apply(&a, &[1.0; 6]);
    let model = Linear::new(a.clone(), y, 1);
    for strategy in [Strategy::Dense, Strategy::NormalEquations] {
        let opts = Options {
            strategy,
            ..Options::default()
        };
        let rep = fit(&model, &[0.0; 6], &opts).unwrap();
        let id = &rep.identifiability;
        assert_eq!(id.rank, 4, "{strategy:?}");
        assert_eq!(id.null_space.len(), 2);
        assert_eq!(id.relations.len(), 2);
        for rel in &id.relations {
            // J·δθ = 0 along the relation, checked on the raw matrix.
            let jd = apply(&a, &rel.direction);
            let dn = rel.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!(jd.iter().all(|x| x.abs() < 1e-9 * dn), "{jd:?}");
            // Sparse: at most the three columns of one confounding.
            let support = rel.scaled.iter().filter(|x| x.abs() > 1e-9).count();
            assert!(support == 2 || support == 3, "{:?}", rel.scaled);
        }
        // Fixing two parameters still reproduces the data exactly.
        assert!(rep.convergence.final_cost < 1e-20);
    }
}

#[test]
fn zero_column_is_unidentifiable_but_a_small_informative_one_is_not() {
    let mut rng = StdRng::seed_from_u64(4);
    let m = 90;
    let mut a = random_matrix(&mut rng, m, 4);
    for i in 0..m {
        // Column 0 is large (a lever of 1000 mm per rad).
        a[(i, 0)] *= 1e3;
        // Column 2: a parameter in a huge unit, column norm ~1e-9 but it
        // moves the data by ~1e-3 at its true value 1e6.
        a[(i, 2)] *= 1e-9;
        // Column 3: zero to rounding (a lever that should be exactly 0).
        a[(i, 3)] *= 1e-19;
    }
    let truth = [1e-3, 0.2, 1e6, 0.0];
    let mut noise = StdRng::seed_from_u64(40);
    let nd = Normal::new(0.0, 1e-9).unwrap();
    let y: Vec<f64> = apply(&a, &truth)
        .into_iter()
        .map(|v| v + nd.sample(&mut noise))
        .collect();
    let model = Linear::new(a, y, 1);
    for strategy in [Strategy::Dense, Strategy::NormalEquations] {
        let opts = Options {
            strategy,
            ..Options::default()
        };
        let rep = fit(&model, &[0.0; 4], &opts).unwrap();
        assert_eq!(
            rep.identifiability.unidentifiable,
            vec![(3, Unidentifiable::ZeroColumn)],
            "{strategy:?}"
        );
        assert_eq!(rep.identifiability.rank, 3);
        // Column 2 is estimated, to its uncertainty.
        let u = rep.estimates[2].uncertainty.unwrap();
        assert!(u < 1e-2 * truth[2]);
        assert!((rep.theta[2] - truth[2]).abs() < 5.0 * u);
        assert_eq!(rep.theta[3], 0.0);
    }
}

#[test]
fn two_sigma_coverage_is_about_95_percent() {
    let (m, n, sigma) = (30, 3, 0.1);
    let mut rng = StdRng::seed_from_u64(5);
    let a = random_matrix(&mut rng, m, n);
    let truth = [1.0, -2.0, 0.5];
    let clean = apply(&a, &truth);
    let nd = Normal::new(0.0, sigma).unwrap();
    let (mut inside, mut total, mut sigma_sum) = (0, 0, 0.0);
    let runs = 400;
    for seed in 0..runs {
        let mut r = StdRng::seed_from_u64(1000 + seed);
        let y = clean.iter().map(|v| v + nd.sample(&mut r)).collect();
        let model = Linear::new(a.clone(), y, 1);
        let rep = fit(&model, &[0.0; 3], &dense()).unwrap();
        sigma_sum += rep.sigma.unwrap();
        for j in 0..n {
            let u = rep.estimates[j].uncertainty.unwrap();
            total += 1;
            if (rep.theta[j] - truth[j]).abs() <= 2.0 * u {
                inside += 1;
            }
        }
    }
    let frac = inside as f64 / total as f64;
    // With σ estimated on 27 degrees of freedom the 2σ̂ coverage is the
    // Student-t value 94.5 %; binomial spread over 1200 trials is 0.7 %.
    assert!((0.925..=0.965).contains(&frac), "coverage {frac}");
    let mean_sigma = sigma_sum / runs as f64;
    assert!(
        (mean_sigma - sigma).abs() < 0.03 * sigma,
        "mean σ̂ {mean_sigma}"
    );
}

#[test]
fn outlier_block_is_flagged_and_excluded_on_request() {
    let mut rng = StdRng::seed_from_u64(6);
    let (points, n) = (60, 6);
    let a = random_matrix(&mut rng, 3 * points, n);
    let truth = [0.1, 0.2, -0.3, 0.4, -0.5, 0.6];
    let nd = Normal::new(0.0, 0.001).unwrap();
    let mut y: Vec<f64> = apply(&a, &truth)
        .into_iter()
        .map(|v| v + nd.sample(&mut rng))
        .collect();
    // A blocked beam on point 17: 0.05 mm off in every coordinate.
    y[51..54].iter_mut().for_each(|v| *v += 0.05);
    let model = Linear::new(a, y, 3);
    let report_only = fit(&model, &vec![0.0; n], &dense()).unwrap();
    assert_eq!(report_only.outliers.flagged.len(), 1);
    assert_eq!(report_only.outliers.flagged[0].block, 17);
    assert!(!report_only.outliers.flagged[0].excluded);
    assert!(report_only.warnings.contains(&Warning::Outliers {
        flagged: 1,
        excluded: 0
    }));
    let opts = Options {
        outliers: OutlierRule {
            exclude: true,
            ..OutlierRule::default()
        },
        ..dense()
    };
    let rep = fit(&model, &vec![0.0; n], &opts).unwrap();
    assert_eq!(rep.outliers.flagged.len(), 1);
    assert_eq!(rep.outliers.flagged[0].block, 17);
    assert!(rep.outliers.flagged[0].excluded);
    assert_eq!(rep.groups[0].excluded_blocks, 1);
    assert_eq!(rep.groups[0].blocks, points - 1);
    assert_eq!(rep.degrees_of_freedom, 3 * (points - 1) - n);
    // Without the blocked beam σ̂ is the noise level and every estimate is
    // within 4 standard uncertainties of the truth.
    assert!((rep.sigma.unwrap() - 0.001).abs() < 0.0003);
    for j in 0..n {
        let u = rep.estimates[j].uncertainty.unwrap();
        assert!((rep.theta[j] - truth[j]).abs() < 4.0 * u);
    }
    // The excluded block's residual at the solution still shows the 0.05.
    let r = &rep.residuals[51..54];
    assert!(r.iter().all(|x| (x + 0.05).abs() < 0.01), "{r:?}");
}

#[test]
fn normal_equation_path_agrees_with_the_dense_path() {
    let mut rng = StdRng::seed_from_u64(7);
    let (m, n) = (3000, 40);
    let mut a = random_matrix(&mut rng, m, n);
    for i in 0..m {
        a[(i, 31)] = a[(i, 30)];
    }
    let truth: Vec<f64> = (0..n).map(|j| (j as f64 * 0.37).sin()).collect();
    let nd = Normal::new(0.0, 0.01).unwrap();
    let b: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let w: Vec<f64> = (0..m).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let mut model = Mild {
        lin: Linear::new(a, vec![0.0; m], 3),
        b,
        w,
        beta: 0.05,
    };
    let mut clean = vec![0.0; m];
    model.lin.y = vec![0.0; m];
    model.residuals(&truth, 0..m, &mut clean);
    model.lin.y = clean.iter().map(|v| v + nd.sample(&mut rng)).collect();
    let d = fit(&model, &vec![0.0; n], &dense()).unwrap();
    let opts = Options {
        strategy: Strategy::NormalEquations,
        chunk_rows: 700,
        ..Options::default()
    };
    let ne = fit(&model, &vec![0.0; n], &opts).unwrap();
    assert_eq!(ne.strategy, Strategy::NormalEquations);
    assert_eq!(d.identifiability.rank, n - 1);
    assert_eq!(ne.identifiability.rank, n - 1);
    assert_eq!(
        d.identifiability.unidentifiable,
        ne.identifiability.unidentifiable
    );
    for j in 0..n {
        let (ud, un) = (d.estimates[j].uncertainty, ne.estimates[j].uncertainty);
        match (ud, un) {
            (Some(ud), Some(un)) => {
                assert!((d.theta[j] - ne.theta[j]).abs() < 1e-3 * ud, "θ{j}");
                // The normal path takes the covariance from the last JᵀJ it
                // formed (here at the start: the steps were predicted well
                // enough to reuse it), the dense path from the solution; on
                // this mildly nonlinear model they differ by ~0.1 %, far
                // below the statistical spread of an uncertainty estimated
                // from 3000 rows (1/√(2·dof) ≈ 1.3 %).
                assert!((ud - un).abs() < 5e-3 * ud, "u{j}: {ud} vs {un}");
            }
            (None, None) => assert_eq!(d.theta[j], ne.theta[j]),
            _ => panic!("parameter {j} estimated on one path only"),
        }
    }
    let rel =
        (d.convergence.final_cost - ne.convergence.final_cost).abs() / d.convergence.final_cost;
    assert!(rel < 1e-9, "{rel}");
}

#[test]
fn jacobian_checker_accepts_exact_and_catches_wrong() {
    let points = (0..10)
        .map(|i| [(i as f64).cos() * 2.0 + 0.3, (i as f64).sin() * 2.0 - 0.1])
        .collect::<Vec<_>>();
    let theta = [0.1, 0.2, 1.9];
    let good = Circle {
        points: points.clone(),
        wrong: false,
    };
    let c = check_jacobian(&good, &theta).unwrap();
    assert!(c.passes(1e-7), "{c:?}");
    let bad = Circle {
        points,
        wrong: true,
    };
    let c = check_jacobian(&bad, &theta).unwrap();
    assert!(!c.passes(1e-3));
    assert_eq!(c.worst.1, 1);
    // The error of a flipped sign is twice the entry.
    assert!(c.max_rel_error > 1.0);
}

#[test]
fn stacked_models_share_parameters_and_report_per_group() {
    let mut rng = StdRng::seed_from_u64(8);
    let truth = [1.0, 2.0, 3.0];
    let nd = Normal::new(0.0, 0.01).unwrap();
    let mut make = |label: &str, rows: usize, sd: f64| {
        let a = random_matrix(&mut rng, rows, 3);
        let y = apply(&a, &truth)
            .into_iter()
            .map(|v| v + sd / 0.01 * nd.sample(&mut rng))
            .collect();
        let mut l = Linear::new(a, y, 1);
        l.label = label.into();
        l
    };
    let m1 = make("mode1", 40, 0.01);
    let m2 = make("mode2", 30, 0.0);
    let stack = Stack::new(vec![&m1, &m2]).unwrap();
    let rep = fit(&stack, &[0.0; 3], &dense()).unwrap();
    assert_eq!(rep.groups.len(), 2);
    assert_eq!(rep.groups[0].label, "mode1");
    assert_eq!(rep.groups[0].rows, 40);
    assert_eq!(rep.groups[1].rows, 30);
    // Mode 1 carries the noise, mode 2 (noise-free) fits to the small
    // parameter error only.
    assert!(rep.groups[0].rms_after > 3.0 * rep.groups[1].rms_after);
    for (e, t) in rep.theta.iter().zip(&truth) {
        assert!((e - t).abs() < 0.02);
    }
    // The stack's Jacobian is the two parts one above the other.
    let c = check_jacobian(&stack, &[0.5, 0.5, 0.5]).unwrap();
    assert!(c.passes(1e-8));
    // Parts with other parameters are refused.
    let mut m3 = make("mode3", 5, 0.0);
    m3.params[0] = Parameter::new("other");
    assert!(matches!(
        Stack::new(vec![&m1, &m3]),
        Err(FitError::StackParameters { part: 1 })
    ));
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let model = Linear::new(Mat::zeros(3, 2), vec![0.0; 3], 1);
    assert_eq!(
        fit(&model, &[0.0], &dense()).unwrap_err(),
        FitError::ParameterCount {
            expected: 2,
            got: 1
        }
    );
    assert!(matches!(
        fit(&model, &[f64::NAN, 0.0], &dense()),
        Err(FitError::NonFiniteStart { .. })
    ));
    // All columns zero: nothing to estimate, reported as such.
    let rep = fit(&model, &[0.0, 0.0], &dense()).unwrap();
    assert_eq!(rep.identifiability.rank, 0);
    assert_eq!(rep.convergence.reason, StopReason::NothingToEstimate);
}

#[test]
fn progress_reports_passes_and_iterations() {
    use std::cell::RefCell;
    let t: Vec<f64> = (0..20).map(|i| i as f64 * 0.5).collect();
    let y = t.iter().map(|&t| 2.0 * (-0.3 * t).exp()).collect();
    let model = Decay { t, y };
    let seen = RefCell::new(Vec::new());
    let rep = fit_with_progress(&model, &[1.0, 0.1, 0.0], &dense(), &|p| {
        seen.borrow_mut().push(p)
    })
    .unwrap();
    let seen = seen.into_inner();
    let iters = seen
        .iter()
        .filter(|p| matches!(p, Progress::Iteration { .. }))
        .count();
    assert!(iters >= 1 && iters <= rep.convergence.iterations);
    assert!(seen.contains(&Progress::Analysing));
    assert!(seen.contains(&Progress::Evaluating {
        rows_done: 20,
        rows_total: 20
    }));
}

/// `A·θ − y` where column 2 is `ratio ×` column 1: θ1 and θ2 only enter
/// through `θ1 + ratio·θ2`. Noisy data, so the residuals are not zero.
fn sum_problem(ratio: f64, seed: u64) -> (Linear, [f64; 4]) {
    let mut rng = StdRng::seed_from_u64(seed);
    let m = 60;
    let mut a = random_matrix(&mut rng, m, 4);
    for i in 0..m {
        a[(i, 2)] = ratio * a[(i, 1)];
    }
    let truth = [0.5, 1.0, 2.0, -0.25];
    let nd = Normal::new(0.0, 1e-3).unwrap();
    let y = apply(&a, &truth)
        .into_iter()
        .map(|v| v + nd.sample(&mut rng))
        .collect();
    (Linear::new(a, y, 3), truth)
}

fn norm_of(a: &Mat<f64>, c: usize) -> f64 {
    (0..a.nrows())
        .map(|i| a[(i, c)].powi(2))
        .sum::<f64>()
        .sqrt()
}

#[test]
fn gauge_min_norm_splits_a_sum_in_scaled_units() {
    for strategy in [Strategy::Dense, Strategy::NormalEquations] {
        for ratio in [1.0, 2.0] {
            let (model, _) = sum_problem(ratio, 7);
            let opts = Options {
                strategy,
                gauge: Gauge::Start,
                ..Options::default()
            };
            let pivoted = fit(
                &model,
                &[0.0; 4],
                &Options {
                    gauge: Gauge::Pivoted,
                    ..opts.clone()
                },
            )
            .unwrap();
            let rep = fit(&model, &[0.0; 4], &opts).unwrap();
            // The determined sum S = θ1 + ratio·θ2, from the pivoted fit
            // (θ2 fixed at 0, θ1 carries S).
            assert_eq!(pivoted.theta[2], 0.0);
            let s = pivoted.theta[1];
            // Closed form: the scaled variables y1 = D1·θ1, y2 = D2·θ2 with
            // D2 = ratio·D1 enter as y1 + y2 = D1·S; the minimum-norm split is
            // y1 = y2 = D1·S/2, i.e. θ1 = S/2, θ2 = S/(2·ratio).
            let t = &rep.theta;
            assert!(
                (t[1] - s / 2.0).abs() < 1e-9,
                "{strategy:?} {ratio}: {t:?} S {s}"
            );
            assert!((t[2] - s / (2.0 * ratio)).abs() < 1e-9, "{t:?}");
            // The determined parameters do not move.
            assert!((t[0] - pivoted.theta[0]).abs() < 1e-9);
            assert!((t[3] - pivoted.theta[3]).abs() < 1e-9);
            // Predictions unchanged.
            let (pa, pb) = (apply(&model.a, t), apply(&model.a, &pivoted.theta));
            let dmax = pa
                .iter()
                .zip(&pb)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(dmax < 1e-10, "{dmax}");
            assert!((rep.convergence.final_cost - pivoted.convergence.final_cost).abs() < 1e-12);
            // The report: one group {p1, p2}, one null direction, the
            // determined combination θ1 + ratio·θ2 = S.
            let g = rep.gauge.as_ref().expect("gauge report");
            assert_eq!(g.kind, "start");
            assert_eq!(g.null_dimension, 1);
            assert!(g.max_residual_change < 1e-10);
            assert_eq!(g.groups.len(), 1);
            let grp = &g.groups[0];
            assert_eq!(grp.parameters, vec!["p1", "p2"]);
            assert_eq!(grp.undetermined, 1);
            assert_eq!(grp.determined.len(), 1);
            let c = &grp.determined[0];
            assert_eq!(c.terms[0].name, "p1");
            assert_eq!(c.terms[0].coefficient, 1.0);
            assert!((c.terms[1].coefficient - ratio).abs() < 1e-9, "{c:?}");
            assert!((c.value - s).abs() < 1e-9);
            // Its uncertainty is that of the pivoted fit's carrier θ1 (which
            // estimated S), and each share carries half of it (scaled units).
            let us = pivoted.estimates[1].uncertainty.unwrap();
            assert!(
                (c.uncertainty.unwrap() - us).abs() < 1e-6 * us,
                "{c:?} vs {us}"
            );
            let u1 = rep.estimates[1].uncertainty.unwrap();
            let u2 = rep.estimates[2].uncertainty.unwrap();
            assert!((u1 - us / 2.0).abs() < 1e-6 * us, "{u1} vs {us}");
            assert!((u2 - us / (2.0 * ratio)).abs() < 1e-6 * us, "{u2} vs {us}");
            // The other parameters keep their full-rank uncertainty.
            for j in [0, 3] {
                let (a, b) = (
                    rep.estimates[j].uncertainty.unwrap(),
                    pivoted.estimates[j].uncertainty.unwrap(),
                );
                assert!((a - b).abs() < 1e-6 * b, "{j}: {a} vs {b}");
            }
            // Gauge-fixed parameters are listed with their prior.
            let names: Vec<&str> = g.parameters.iter().map(|p| p.name.as_str()).collect();
            assert_eq!(names, vec!["p1", "p2"]);
            assert!(g.parameters.iter().all(|p| p.prior == 0.0));
            assert!((g.parameters[0].undetermined - 0.5).abs() < 1e-9);
            assert_eq!(c.describe(), format!("p1 + {ratio:.4}·p2"));
        }
    }
}

#[test]
fn gauge_with_a_prior_is_the_projection_onto_the_prior() {
    let ratio = 2.0;
    let (model, _) = sum_problem(ratio, 8);
    let prior = vec![10.0, 0.3, -0.7, 5.0];
    for strategy in [Strategy::Dense, Strategy::NormalEquations] {
        let opts = Options {
            strategy,
            gauge: Gauge::Prior(prior.clone()),
            ..Options::default()
        };
        let rep = fit(&model, &[0.0; 4], &opts).unwrap();
        let pivoted = fit(
            &model,
            &[0.0; 4],
            &Options {
                strategy,
                gauge: Gauge::Pivoted,
                ..Options::default()
            },
        )
        .unwrap();
        // Independently: scaled variables y = D·θ with D the column norms;
        // the null vector in y is n = (0, 1, −1, 0)/√2 (scaled columns 1 and
        // 2 are equal); y* = y − n·nᵀ·(y − y_p) from the pivoted solution.
        let d: Vec<f64> = (0..4).map(|c| norm_of(&model.a, c)).collect();
        let h = 0.5f64.sqrt();
        let nv = [0.0, h, -h, 0.0];
        let y: Vec<f64> = (0..4).map(|j| d[j] * pivoted.theta[j]).collect();
        let yp: Vec<f64> = (0..4).map(|j| d[j] * prior[j]).collect();
        let a: f64 = (0..4).map(|j| nv[j] * (y[j] - yp[j])).sum();
        for j in 0..4 {
            let expect = (y[j] - a * nv[j]) / d[j];
            assert!(
                (rep.theta[j] - expect).abs() < 1e-9,
                "{strategy:?} {j}: {} vs {expect}",
                rep.theta[j]
            );
        }
        // The prior of the determined parameters 0 and 3 is irrelevant.
        assert!((rep.theta[0] - pivoted.theta[0]).abs() < 1e-9);
        let g = rep.gauge.as_ref().unwrap();
        assert_eq!(g.kind, "prior");
        assert_eq!(g.parameters[0].prior, 0.3);
        assert_eq!(g.parameters[1].prior, -0.7);
        let (pa, pb) = (apply(&model.a, &rep.theta), apply(&model.a, &pivoted.theta));
        let dmax = pa
            .iter()
            .zip(&pb)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(dmax < 1e-10, "{dmax}");
    }
    // A prior of the wrong length is an error.
    let opts = Options {
        gauge: Gauge::Prior(vec![0.0; 3]),
        ..Options::default()
    };
    assert!(matches!(
        fit(&model, &[0.0; 4], &opts),
        Err(FitError::ParameterCount { .. })
    ));
}

/// `r_i = A·exp(−(k1 + k2)·t_i) + c − y_i`: k1 and k2 only as their sum, a
/// nonlinear model.
struct SumDecay {
    t: Vec<f64>,
    y: Vec<f64>,
}

impl Model for SumDecay {
    fn parameters(&self) -> Vec<Parameter> {
        ["A", "k1", "k2", "c"].map(Parameter::new).to_vec()
    }
    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform("decay", self.t.len(), 1)
    }
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        if let Some(out) = r {
            let th = theta;
            for (o, i) in out.iter_mut().zip(rows.clone()) {
                *o = th[0] * (-(th[1] + th[2]) * self.t[i]).exp() + th[3] - self.y[i];
            }
        }
        if let Some(mut out) = j {
            let th = theta;
            for (k, i) in rows.enumerate() {
                let e = (-(th[1] + th[2]) * self.t[i]).exp();
                out[(k, 0)] = e;
                out[(k, 1)] = -th[0] * self.t[i] * e;
                out[(k, 2)] = -th[0] * self.t[i] * e;
                out[(k, 3)] = 1.0;
            }
        }
    }
}

#[test]
fn gauge_on_a_nonlinear_model_keeps_the_predictions() {
    let t: Vec<f64> = (0..40).map(|i| i as f64 * 0.25).collect();
    let mut rng = StdRng::seed_from_u64(9);
    let nd = Normal::new(0.0, 1e-3).unwrap();
    let y = t
        .iter()
        .map(|&t| 5.0 * (-0.7 * t).exp() - 1.0 + nd.sample(&mut rng))
        .collect();
    let model = SumDecay { t, y };
    let start = [1.0, 0.5, 0.0, 0.0];
    let pivoted = fit(
        &model,
        &start,
        &Options {
            gauge: Gauge::Pivoted,
            ..dense()
        },
    )
    .unwrap();
    let gauged = Options {
        gauge: Gauge::Start,
        ..dense()
    };
    let rep = fit(&model, &start, &gauged).unwrap();
    // k1 + k2 is the rate; the split is closest to the start (0.5, 0): the
    // columns are equal, so k1 − 0.5 = k2 − 0, i.e. k1 = (rate + 0.5)/2.
    let rate = pivoted.theta[1] + pivoted.theta[2];
    assert!((rep.theta[1] + rep.theta[2] - rate).abs() < 1e-9);
    assert!(
        (rep.theta[1] - (rate + 0.5) / 2.0).abs() < 1e-9,
        "{:?}",
        rep.theta
    );
    let dmax = rep
        .residuals
        .iter()
        .zip(&pivoted.residuals)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dmax < 1e-10, "{dmax}");
}

/// Columns `1, 1, x, x + 1, sin x, 2·sin x, x²` (parameters p0 … p6) on
/// `x ∈ [−1, 1]`: p0 (an offset) and p1 (a constant term) add; p3 = x + 1
/// is p2's column plus the constant; p5's column is twice p4's. Two groups:
/// {p0, p1, p2, p3} with two null directions (p0 − p1, and p1 + p2 − p3 or
/// an equivalent sparse pair) and {p4, p5} with one (p4 − 0.5·p5).
fn confounded_model(truth: &[f64; 7]) -> Linear {
    let m = 40;
    let a = Mat::<f64>::from_fn(m, 7, |i, j| {
        let x = -1.0 + 2.0 * i as f64 / (m - 1) as f64;
        match j {
            0 | 1 => 1.0,
            2 => x,
            3 => x + 1.0,
            4 => (2.0 * x).sin(),
            5 => 2.0 * (2.0 * x).sin(),
            _ => x * x,
        }
    });
    let y = apply(&a, truth);
    Linear::new(a, y, 2)
}

#[test]
fn sparse_combinations_of_known_confounds_are_found_exactly() {
    let truth = [0.4, -1.5, 2.0, 0.7, 0.3, -0.8, 1.1];
    let model = confounded_model(&truth);
    let rep = fit(
        &model,
        &[0.0; 7],
        &Options {
            gauge: Gauge::Start,
            ..dense()
        },
    )
    .unwrap();
    let g = rep.gauge.as_ref().unwrap();
    assert_eq!(g.null_dimension, 3);
    assert_eq!(g.groups.len(), 2, "{:?}", g.groups);
    let index = |name: &str| name[1..].parse::<usize>().unwrap();
    for grp in &g.groups {
        // Every undetermined direction, in parameter units, is a null
        // vector of the model matrix, with at most 3 terms.
        for d in &grp.undetermined_directions {
            assert!(d.terms.len() <= 3, "{}", d.describe());
            let mut dt = [0.0; 7];
            for t in &d.terms {
                dt[index(&t.name)] = t.coefficient;
            }
            let r = apply(&model.a, &dt);
            assert!(r.iter().all(|v| v.abs() < 1e-9), "{}: {r:?}", d.describe());
        }
        assert_eq!(grp.undetermined_directions.len(), grp.undetermined);
        // Every determined combination has the truth's value (noise-free
        // data) and involves its pivot plus the group's free parameters.
        for c in &grp.determined {
            let want: f64 = c
                .terms
                .iter()
                .map(|t| t.coefficient * truth[index(&t.name)])
                .sum();
            assert!((c.value - want).abs() < 1e-9, "{c:?} vs {want}");
            assert!(c.terms.len() <= 1 + grp.undetermined, "{c:?}");
        }
    }
    // The pair with different scales: p4 + 2·p5 determined, p4 − 0.5·p5 free.
    let pair = g
        .groups
        .iter()
        .find(|x| x.parameters == ["p4", "p5"])
        .expect("group {p4, p5}");
    assert_eq!(pair.undetermined, 1);
    let c = &pair.determined[0];
    let coef = |terms: &[CombinationTerm], name: &str| {
        let lead = terms[0].coefficient;
        terms.iter().find(|t| t.name == name).unwrap().coefficient / lead
    };
    let (a4, a5) = (coef(&c.terms, "p4"), coef(&c.terms, "p5"));
    assert!((a5 / a4 - 2.0).abs() < 1e-12, "{c:?}");
    let d = &pair.undetermined_directions[0];
    let (b4, b5) = (coef(&d.terms, "p4"), coef(&d.terms, "p5"));
    assert!((b5 / b4 + 0.5).abs() < 1e-12, "{d:?}");
    // The offset and the constant: two undetermined directions in a
    // four-parameter group, two determined combinations (the constant
    // p0 + p1 + p3 and the slope p2 + p3, in some sparse basis).
    let four = g
        .groups
        .iter()
        .find(|x| x.parameters == ["p0", "p1", "p2", "p3"])
        .expect("group {p0 … p3}");
    assert_eq!(four.undetermined, 2);
    assert_eq!(four.determined.len(), 2);
}

#[test]
fn sparsify_gives_the_reduced_row_echelon_form() {
    // Span of (1, −1, 0, 0) and (1, 0, 1, −1), given as a mixed
    // orthonormal-ish basis: their sum and difference.
    let b = Mat::<f64>::from_fn(2, 4, |r, c| {
        let u = [1.0, -1.0, 0.0, 0.0][c];
        let v = [1.0, 0.0, 1.0, -1.0][c];
        if r == 0 { u + v } else { u - v }
    });
    let rows = gauge::sparsify(&b);
    assert_eq!(rows.len(), 2);
    // Each row lies in the span (orthogonal to its complement: (1, 1, 0, 1)
    // and (0, 0, 1, 1)) and has a 1 where the other has a 0.
    for r in &rows {
        let d1 = r[0] + r[1] + r[3];
        let d2 = r[2] + r[3];
        assert!(d1.abs() < 1e-12 && d2.abs() < 1e-12, "{r:?}");
        assert!(r.iter().filter(|x| **x != 0.0).count() <= 3, "{r:?}");
    }
    // Reduced row echelon form: each row has 1 on a pivot column where the
    // other row has 0.
    let pivot = |r: &Vec<f64>| r.iter().position(|x| (x - 1.0).abs() < 1e-12).unwrap();
    let (p0, p1) = (pivot(&rows[0]), pivot(&rows[1]));
    assert_ne!(p0, p1, "{rows:?}");
    assert_eq!(rows[1][p0], 0.0, "{rows:?}");
    assert_eq!(rows[0][p1], 0.0, "{rows:?}");
}

/// Columns `u + ε·w`, `u − ε·w`, `z1`, `z2` with `u, w, z1, z2`
/// orthonormal (disjoint row supports): p0 and p1 are told apart only by
/// the ε-weak direction `(1, −1)`.
fn weak_pair(eps: f64, truth: &[f64; 4], noise: f64, seed: u64) -> Linear {
    let m = 40;
    let unit = |i: usize, k: usize| {
        if i / 10 == k { 1.0 / 10f64.sqrt() } else { 0.0 }
    };
    let a = Mat::<f64>::from_fn(m, 4, |i, j| match j {
        0 => unit(i, 0) + eps * unit(i, 1),
        1 => unit(i, 0) - eps * unit(i, 1),
        2 => unit(i, 2),
        _ => unit(i, 3),
    });
    let mut rng = StdRng::seed_from_u64(seed);
    let nd = Normal::new(0.0, noise.max(f64::MIN_POSITIVE)).unwrap();
    let y = apply(&a, truth)
        .into_iter()
        .map(|v| {
            if noise > 0.0 {
                v + nd.sample(&mut rng)
            } else {
                v
            }
        })
        .collect();
    Linear::new(a, y, 2)
}

#[test]
fn truncation_drops_a_weak_direction_toward_the_prior_with_the_stated_cost() {
    let eps = 1e-3;
    let truth = [1.0, 3.0, 0.5, -0.25];
    let model = weak_pair(eps, &truth, 0.0, 1);
    for strategy in [Strategy::Dense, Strategy::NormalEquations] {
        let base = Options {
            strategy,
            gauge: Gauge::Start,
            ..Options::default()
        };
        // Without truncation: the exact solution (full rank).
        let full = fit(&model, &[0.0; 4], &base).unwrap();
        for j in 0..4 {
            assert!((full.theta[j] - truth[j]).abs() < 1e-6, "{:?}", full.theta);
        }
        // rcond between the weak direction's ε and the strong ones' ≥ 1/√2.
        let rep = fit(
            &model,
            &[0.0; 4],
            &Options {
                truncation: Truncation::Relative(1e-2),
                ..base.clone()
            },
        )
        .unwrap();
        // Closed form: the weak direction (1, −1) goes to the prior 0, the
        // strong sum p0 + p1 = 4 stays: p0 = p1 = 2; p2, p3 untouched.
        let t = &rep.theta;
        assert!(
            (t[0] - 2.0).abs() < 1e-9 && (t[1] - 2.0).abs() < 1e-9,
            "{t:?}"
        );
        assert!((t[2] - 0.5).abs() < 1e-9 && (t[3] + 0.25).abs() < 1e-9);
        let g = rep.gauge.as_ref().unwrap();
        assert_eq!(g.truncation, "rcond=0.01");
        assert_eq!(g.dropped.len(), 1);
        let d = &g.dropped[0];
        // Relative singular value: ‖(u + εw) − (u − εw)‖/‖(u+εw) + (u−εw)‖ = ε.
        assert!(
            (d.relative_singular_value - eps).abs() < 1e-6 * eps,
            "{d:?}"
        );
        // The residual change: A·(θ_ls − θ_T) = A·(−1, 1, 0, 0) = −2ε·w,
        // RMS 2ε/√40.
        let rms = 2.0 * eps / 40f64.sqrt();
        assert!((d.rms_change - rms).abs() < 1e-6 * rms, "{d:?} vs {rms}");
        assert!((g.truncation_rms_change - rms).abs() < 1e-6 * rms);
        // p0 and p1 move by ∓1; the bound is at least the move.
        assert!((d.shift.abs() - 1.0).abs() < 1e-9, "{d:?}");
        assert!(d.bias_bound >= d.shift.abs() - 1e-12);
        // The reported covariance is the truncated one: p0 and p1 share the
        // sum's uncertainty, fully correlated.
        let c = rep.covariance.as_ref().unwrap();
        let (s0, s1) = (c.std(0).unwrap(), c.std(1).unwrap());
        assert!((c.get(0, 1).unwrap() - s0 * s1).abs() <= 1e-9 * s0 * s1 + 1e-30);
    }
}

#[test]
fn truncation_by_uncertainty_uses_the_noise_level() {
    // σ = 1e-3, ε = 1e-3: along (1, −1) p0 scatters by σ/(2ε) = 0.5; the
    // strong directions by about σ.
    let truth = [1.0, 3.0, 0.5, -0.25];
    let model = weak_pair(1e-3, &truth, 1e-3, 4);
    let run = |bound: f64| {
        fit(
            &model,
            &[0.0; 4],
            &Options {
                gauge: Gauge::Start,
                truncation: Truncation::Uncertainty(bound),
                ..dense()
            },
        )
        .unwrap()
    };
    let kept = run(5.0);
    assert!(kept.gauge.as_ref().unwrap().dropped.is_empty());
    let u0 = kept.estimates[0].uncertainty.unwrap();
    assert!((u0 / 0.5 - 1.0).abs() < 0.5, "{u0}");
    let dropped = run(0.05);
    let g = dropped.gauge.as_ref().unwrap();
    assert_eq!(g.dropped.len(), 1, "{g:?}");
    let d = &g.dropped[0];
    let s = d.component_uncertainty.unwrap();
    // The component's uncertainty in scaled units is σ/s_i; in p0 that is
    // the parameter's scatter 0.5 (within the estimate of σ).
    assert!(d.bias_bound >= 2.0 * 0.5 * 0.5, "{d:?} {s}");
    assert!((dropped.theta[0] - dropped.theta[1]).abs() < 1e-9);
    // A rule that is not one is an input error.
    for bad in ["rcond=2", "std=-1", "tikhonov", "std=x"] {
        assert!(bad.parse::<Truncation>().is_err(), "{bad}");
    }
    assert_eq!(
        "std=10".parse::<Truncation>(),
        Ok(Truncation::Uncertainty(10.0))
    );
    assert_eq!("off".parse::<Truncation>(), Ok(Truncation::Off));
}
