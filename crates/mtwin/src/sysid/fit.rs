use nalgebra::{DMatrix, DVector};

use super::{Arx, ArxOrders, SysidError};

/// One experiment: an output signal and its input signals, sampled together
/// at the same period. Runs are independent: a fit never builds a regressor
/// from samples of two different runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    output: Vec<f64>,
    inputs: Vec<Vec<f64>>,
}

impl Run {
    /// A run; every input must have as many samples as the output, all finite.
    pub fn new(output: Vec<f64>, inputs: Vec<Vec<f64>>) -> Result<Run, SysidError> {
        for (i, u) in inputs.iter().enumerate() {
            if u.len() != output.len() {
                return Err(SysidError::LengthMismatch {
                    input: i,
                    expected: output.len(),
                    found: u.len(),
                });
            }
            if u.iter().any(|v| !v.is_finite()) {
                return Err(SysidError::NotFinite {
                    what: format!("input {i} of a run"),
                });
            }
        }
        if output.iter().any(|v| !v.is_finite()) {
            return Err(SysidError::NotFinite {
                what: "the output of a run".into(),
            });
        }
        Ok(Run { output, inputs })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.output.len()
    }

    /// True for a run without samples.
    pub fn is_empty(&self) -> bool {
        self.output.is_empty()
    }

    /// The output signal.
    pub fn output(&self) -> &[f64] {
        &self.output
    }

    /// Input `i`.
    pub fn input(&self, i: usize) -> &[f64] {
        &self.inputs[i]
    }

    /// Number of inputs.
    pub fn n_inputs(&self) -> usize {
        self.inputs.len()
    }

    /// All inputs as slices, in order.
    pub fn input_slices(&self) -> Vec<&[f64]> {
        self.inputs.iter().map(Vec::as_slice).collect()
    }
}

/// What a fit assumes about the samples before each run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Start {
    /// Every run starts from rest: output and inputs are zero before sample 0
    /// (a cold machine, an axis at rest on deviations from its first
    /// command). Every sample is a regression row.
    AtRest,
    /// Nothing is assumed: regression rows start at sample
    /// `max(first, max lag)` of every run, so no regressor reaches before the
    /// run.
    From(usize),
}

impl Start {
    fn first_row(self, orders: &ArxOrders) -> usize {
        match self {
            Start::AtRest => 0,
            Start::From(s) => s.max(orders.max_lag()),
        }
    }
}

/// Statistics of a least-squares ARX fit. RMS values are in the unit of the output.
#[derive(Debug, Clone, PartialEq)]
pub struct FitStats {
    /// Regression rows `N` (over all runs).
    pub samples: usize,
    /// Parameters `d`.
    pub params: usize,
    /// `V`: mean squared one-step residual (sum of squares / N).
    pub loss: f64,
    /// Akaike's final prediction error `V·(1 + d/N)/(1 − d/N)`.
    pub fpe: f64,
    /// Akaike's information criterion `N·ln V + 2d`.
    pub aic: f64,
    /// RMS of the one-step residual over the regression rows (`√V`).
    pub one_step_rms: f64,
    /// RMS of measured minus simulated output, every run simulated from rest
    /// from its inputs alone, over all samples of all runs.
    pub simulation_rms: f64,
    /// Largest pole modulus of the fitted model.
    pub spectral_radius: f64,
}

impl FitStats {
    /// Akaike's final prediction error `V·(1 + d/N)/(1 − d/N)` of a loss `V`
    /// over `N` samples with `d` parameters.
    pub fn fpe_of(loss: f64, samples: usize, params: usize) -> f64 {
        let ratio = params as f64 / samples as f64;
        loss * (1.0 + ratio) / (1.0 - ratio)
    }

    /// Akaike's information criterion `N·ln V + 2d`.
    pub fn aic_of(loss: f64, samples: usize, params: usize) -> f64 {
        samples as f64 * loss.ln() + 2.0 * params as f64
    }
}

/// A fitted ARX model with its statistics and parameter covariance.
#[derive(Debug, Clone)]
pub struct ArxFit {
    /// The fitted model.
    pub model: Arx,
    /// Fit statistics.
    pub stats: FitStats,
    /// Covariance of `θ` (order of [`Arx::params`]): `σ²·(ΦᵀΦ)⁻¹` with
    /// `σ² = SSR/(N − d)`.
    pub covariance: DMatrix<f64>,
}

impl ArxFit {
    /// Standard uncertainties of `θ` (order of [`Arx::params`]).
    pub fn std_params(&self) -> Vec<f64> {
        self.covariance
            .diagonal()
            .iter()
            .map(|v| v.max(0.0).sqrt())
            .collect()
    }

    /// Standard uncertainties of `a_1..a_na`.
    pub fn std_a(&self) -> Vec<f64> {
        self.std_params()[..self.model.a().len() - 1].to_vec()
    }

    /// Standard uncertainties of `b_0..b_nb` of input `input`.
    pub fn std_b(&self, input: usize) -> Vec<f64> {
        let s = self.std_params();
        let mut at = self.model.a().len() - 1;
        for i in 0..input {
            at += self.model.b(i).len();
        }
        s[at..at + self.model.b(input).len()].to_vec()
    }
}

/// Build the regression `y = Φ θ` over all runs. Rows of one run use only
/// samples of that run (or zeros before it with [`Start::AtRest`]).
pub(crate) fn regression(
    runs: &[Run],
    orders: &ArxOrders,
    start: Start,
) -> Result<(DMatrix<f64>, DVector<f64>), SysidError> {
    let first = start.first_row(orders);
    for r in runs {
        if r.n_inputs() != orders.inputs.len() {
            return Err(SysidError::InputCount {
                expected: orders.inputs.len(),
                found: r.n_inputs(),
            });
        }
    }
    let rows: usize = runs.iter().map(|r| r.len().saturating_sub(first)).sum();
    let d = orders.n_params();
    let mut phi = DMatrix::<f64>::zeros(rows, d);
    let mut y = DVector::<f64>::zeros(rows);
    let mut row = 0;
    for r in runs {
        for k in first..r.len() {
            y[row] = r.output[k];
            for i in 1..=orders.na {
                if let Some(t) = k.checked_sub(i) {
                    phi[(row, i - 1)] = -r.output[t];
                }
            }
            let mut col = orders.na;
            for (o, u) in orders.inputs.iter().zip(&r.inputs) {
                for j in 0..=o.nb {
                    if let Some(t) = k.checked_sub(j + o.nk) {
                        phi[(row, col)] = u[t];
                    }
                    col += 1;
                }
            }
            row += 1;
        }
    }
    Ok((phi, y))
}

/// Least-squares fit of an ARX model of structure `orders` over `runs`.
///
/// The regression `y = Φθ` is solved by Householder QR of `Φ` with its
/// columns scaled to unit norm (never the normal equations); a column set
/// whose reciprocal condition (smallest over largest diagonal of R) is below
/// 1e-10 is reported as [`SysidError::RankDeficient`].
pub fn fit_arx(runs: &[Run], orders: &ArxOrders, start: Start) -> Result<ArxFit, SysidError> {
    let (phi, y) = regression(runs, orders, start)?;
    let (n, d) = phi.shape();
    if n <= d {
        return Err(SysidError::TooFewSamples { rows: n, params: d });
    }
    let (theta, cov_unscaled, ssr) = least_squares(phi, y)?;
    let model = Arx::from_params(orders, theta.as_slice());
    let loss = ssr / n as f64;
    let sigma2 = ssr / (n - d) as f64;
    let covariance = cov_unscaled * sigma2;
    let mut sim_ss = 0.0;
    let mut sim_n = 0usize;
    for r in runs {
        let sim = model.simulate(&r.input_slices())?;
        sim_ss += sim
            .iter()
            .zip(&r.output)
            .map(|(s, m)| (m - s) * (m - s))
            .sum::<f64>();
        sim_n += r.len();
    }
    let stats = FitStats {
        fpe: FitStats::fpe_of(loss, n, d),
        aic: FitStats::aic_of(loss, n, d),
        samples: n,
        params: d,
        loss,
        one_step_rms: loss.sqrt(),
        simulation_rms: if sim_n > 0 {
            (sim_ss / sim_n as f64).sqrt()
        } else {
            0.0
        },
        spectral_radius: model.stability().spectral_radius(),
    };
    Ok(ArxFit {
        model,
        stats,
        covariance,
    })
}

/// Solve `min |y − Φθ|` by QR with unit-norm columns. Returns `θ`,
/// `(ΦᵀΦ)⁻¹` and the residual sum of squares.
fn least_squares(
    mut phi: DMatrix<f64>,
    y: DVector<f64>,
) -> Result<(DVector<f64>, DMatrix<f64>, f64), SysidError> {
    let (n, d) = phi.shape();
    if phi.iter().any(|v| !v.is_finite()) || y.iter().any(|v| !v.is_finite()) {
        return Err(SysidError::NotFinite {
            what: "the regression".into(),
        });
    }
    let mut scale = vec![1.0; d];
    for (j, s) in scale.iter_mut().enumerate() {
        let norm = phi.column(j).norm();
        if norm == 0.0 {
            return Err(SysidError::RankDeficient {
                params: d,
                rcond: 0.0,
            });
        }
        *s = norm;
        phi.column_mut(j).unscale_mut(norm);
    }
    let qr = phi.qr();
    let r = qr.r();
    let diag: Vec<f64> = r.diagonal().iter().map(|v| v.abs()).collect();
    let max = diag.iter().copied().fold(0.0, f64::max);
    let min = diag.iter().copied().fold(f64::INFINITY, f64::min);
    let rcond = if max > 0.0 { min / max } else { 0.0 };
    if rcond < 1e-10 {
        return Err(SysidError::RankDeficient { params: d, rcond });
    }
    let mut qty = y.clone();
    qr.q_tr_mul(&mut qty);
    let ssr = qty.rows(d, n - d).norm_squared();
    let head = qty.rows(0, d).into_owned();
    let z = r
        .solve_upper_triangular(&head)
        .ok_or(SysidError::RankDeficient { params: d, rcond })?;
    let r_inv = r
        .solve_upper_triangular(&DMatrix::identity(d, d))
        .ok_or(SysidError::RankDeficient { params: d, rcond })?;
    let mut cov = &r_inv * r_inv.transpose();
    let theta = DVector::from_iterator(d, z.iter().zip(&scale).map(|(v, s)| v / s));
    for i in 0..d {
        for j in 0..d {
            cov[(i, j)] /= scale[i] * scale[j];
        }
    }
    Ok((theta, cov, ssr))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sysid::InputOrder;
    use rand::{Rng, SeedableRng, rngs::StdRng};
    use rand_distr::StandardNormal;

    fn truth() -> Arx {
        // Poles 0.9 ± 0.2i (stable), two inputs.
        Arx::new(
            vec![1.0, -1.8, 0.85],
            vec![(vec![0.4, -0.2, 0.1], 1), (vec![0.3], 2)],
        )
        .unwrap()
    }

    /// A run of the truth with white equation noise `sigma` (noise enters the
    /// ARX equation, so least squares is consistent).
    fn run(model: &Arx, n: usize, sigma: f64, rng: &mut StdRng) -> Run {
        let u1: Vec<f64> = (0..n)
            .map(|_| rng.sample::<f64, _>(StandardNormal))
            .collect();
        let u2: Vec<f64> = (0..n)
            .map(|_| if rng.r#gen::<bool>() { 1.0 } else { -1.0 })
            .collect();
        let mut y = vec![0.0; n];
        for k in 0..n {
            let e: f64 = rng.sample::<f64, _>(StandardNormal) * sigma;
            y[k] = model.equation(k, &y, &[&u1, &u2]) + e;
        }
        Run::new(y, vec![u1, u2]).unwrap()
    }

    #[test]
    fn noise_free_recovery_is_exact() {
        let m = truth();
        let mut rng = StdRng::seed_from_u64(1);
        let runs = [run(&m, 150, 0.0, &mut rng), run(&m, 90, 0.0, &mut rng)];
        for start in [Start::AtRest, Start::From(0)] {
            let f = fit_arx(&runs, &m.orders(), start).unwrap();
            for (a, b) in f.model.params().iter().zip(m.params()) {
                assert!((a - b).abs() < 1e-9, "{a} vs {b}");
            }
            assert!(f.stats.simulation_rms < 1e-9);
        }
    }

    #[test]
    fn regressors_never_cross_a_run_boundary() {
        // Two runs concatenated into one would make row 0 of run 2 depend on
        // the end of run 1; kept apart, an at-rest fit is exact even though
        // run 2 starts from rest with a very different end state of run 1.
        let m = truth();
        let mut rng = StdRng::seed_from_u64(2);
        let r1 = run(&m, 100, 0.0, &mut rng);
        let r2 = run(&m, 100, 0.0, &mut rng);
        let (phi, _) = regression(&[r1.clone(), r2.clone()], &m.orders(), Start::AtRest).unwrap();
        // First row of run 2 (row 100): all lagged regressors are zero, only b_0 of
        // input 1 with nk = 1 is also zero, so the whole row is zero.
        assert!(phi.row(100).iter().all(|&v| v == 0.0));
        let joined = Run::new(
            [r1.output(), r2.output()].concat(),
            vec![
                [r1.input(0), r2.input(0)].concat(),
                [r1.input(1), r2.input(1)].concat(),
            ],
        )
        .unwrap();
        let sep = fit_arx(&[r1, r2], &m.orders(), Start::AtRest).unwrap();
        let one = fit_arx(&[joined], &m.orders(), Start::AtRest).unwrap();
        assert!(sep.stats.loss < 1e-20);
        assert!(
            one.stats.loss > 1e-8,
            "joining runs must break the exact fit"
        );
    }

    #[test]
    fn uncertainties_cover_the_truth() {
        // Over many seeds, each parameter lies within 2σ of the truth about 95 % of the time.
        let m = truth();
        let theta = m.params();
        let (mut inside, mut total) = (0usize, 0usize);
        for seed in 0..150 {
            let mut rng = StdRng::seed_from_u64(1000 + seed);
            let runs = [run(&m, 300, 0.05, &mut rng), run(&m, 200, 0.05, &mut rng)];
            let f = fit_arx(&runs, &m.orders(), Start::AtRest).unwrap();
            for ((est, sd), tru) in f.model.params().iter().zip(f.std_params()).zip(&theta) {
                total += 1;
                if (est - tru).abs() <= 2.0 * sd {
                    inside += 1;
                }
            }
        }
        let p = inside as f64 / total as f64;
        // Binomial σ over 900 trials ≈ 0.007: the band is ±3.5σ around 0.954.
        assert!((0.93..=0.98).contains(&p), "coverage {p}");
    }

    #[test]
    fn uncertainty_matches_closed_form_for_a_mean() {
        // y(k) = b_0 · 1 + e: the fit of b_0 is the mean, σ_b0 = s/√N.
        let y = [1.0, 2.0, 4.0, 3.0, 5.0];
        let run = Run::new(y.to_vec(), vec![vec![1.0; 5]]).unwrap();
        let o = ArxOrders {
            na: 0,
            inputs: vec![InputOrder { nb: 0, nk: 0 }],
        };
        let f = fit_arx(&[run], &o, Start::AtRest).unwrap();
        let mean = 3.0;
        let s2 = y.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / 4.0;
        assert!((f.model.b(0)[0] - mean).abs() < 1e-14);
        assert!((f.std_b(0)[0] - (s2 / 5.0).sqrt()).abs() < 1e-14);
        assert!((f.stats.loss - s2 * 4.0 / 5.0).abs() < 1e-14);
    }

    #[test]
    fn degenerate_data_are_errors() {
        let o = ArxOrders {
            na: 1,
            inputs: vec![InputOrder { nb: 1, nk: 0 }],
        };
        let run = Run::new(vec![0.0, 1.0], vec![vec![1.0, 1.0]]).unwrap();
        assert!(matches!(
            fit_arx(&[run], &o, Start::AtRest),
            Err(SysidError::TooFewSamples { .. })
        ));
        // A constant input with nb = 1 gives two identical columns (after the first row).
        let run = Run::new((0..20).map(f64::from).collect(), vec![vec![1.0; 20]]).unwrap();
        assert!(matches!(
            fit_arx(&[run], &o, Start::From(1)),
            Err(SysidError::RankDeficient { .. })
        ));
        assert!(Run::new(vec![1.0], vec![vec![]]).is_err());
    }
}
