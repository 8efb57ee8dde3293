//! Output-error refinement of an ARX estimate.
//!
//! ARX least squares minimises the *equation* error
//! `A(q)·y(k) − B(q)·u(k)`: with white noise `e` on the measured output the
//! regressors `y(k−i)` carry that noise, so the estimate is biased (the noise
//! enters as `A(q)·e`, coloured, correlated with the regressors). For a servo
//! sampled at 1 kHz whose poles sit close to 1, 0.2 µm of encoder noise is
//! enough to move a free-run simulation by several µm.
//!
//! The output-error (OE) estimate minimises instead the *simulation* error
//!
//! ```text
//! r(k) = ŷ(k; θ) − y(k),   ŷ(k) = −Σ_{i=1..na} a_i·ŷ(k−i) + Σ_u Σ_j b_{u,j}·u(k−j−nk_u)
//! ```
//!
//! in which only the inputs (noise-free commands) drive the model, so white
//! output noise stays white and uncorrelated with the model: the estimate is
//! consistent (Ljung, *System Identification*, 2nd ed., sections 4.2 and 7.3). The
//! cost is non-convex in `a`, so it is minimised by the crate's
//! Levenberg–Marquardt engine ([`crate::fit`]) started from the ARX estimate,
//! which lies close to the optimum when the noise is small.
//!
//! Initial state: no assumption about the state before the log. Residual
//! rows are `k = L..N` (`L` = the largest lag of the structures compared);
//! the `na` simulated outputs `ŷ(L−na..L−1)` before them are estimated with
//! the model (started at the measured outputs). Taking them as measured
//! instead would put their noise into a slowly decaying transient: with
//! poles near 1 a noisy initial velocity integrates into an error many times
//! the noise.
//!
//! The Jacobian is exact: the sensitivities `ψ_p(k) = ∂ŷ(k)/∂θ_p` obey the
//! same recursion filtered by `1/A(q)`:
//! `ψ_{a_i}(k) = −ŷ(k−i) − Σ_l a_l·ψ_{a_i}(k−l)` and
//! `ψ_{b_{u,j}}(k) = u(k−j−nk_u) − Σ_l a_l·ψ_{b_{u,j}}(k−l)`.

use std::ops::Range;
use std::sync::{Arc, Mutex};

use faer::MatMut;

use super::order::selection_of;
use super::{
    Arx, ArxFit, ArxOrders, Criterion, FitStats, OrderGrid, OrderSelection, Run, Start, SysidError,
    fit_arx,
};
use crate::fit::{self, BlockLayout, Model, Parameter};

/// The simulation-error residuals of one run for a fixed ARX structure, as
/// a [`fit::Model`] over `θ = [a_1..a_na, b_{0,0}.., b_{1,0}.., …, ŷ(L−1), …, ŷ(L−na)]`
/// (the parameters in the order of [`Arx::params`], then the initial
/// simulated outputs). Residuals in the unit of the output.
pub struct OutputErrorModel<'a> {
    run: &'a Run,
    orders: ArxOrders,
    first: usize,
    /// Simulated outputs beyond this magnitude count as diverged (the
    /// remaining rows are frozen there, so the cost stays finite and the
    /// engine rejects the step).
    bound: f64,
    cache: Mutex<Option<Arc<Simulation>>>,
}

impl<'a> OutputErrorModel<'a> {
    /// The model of `run` with structure `orders`; residual rows start at
    /// sample `first.max(orders.max_lag())`.
    pub fn new(run: &'a Run, orders: ArxOrders, first: usize) -> Result<Self, SysidError> {
        if run.n_inputs() != orders.inputs.len() {
            return Err(SysidError::InputCount {
                expected: orders.inputs.len(),
                found: run.n_inputs(),
            });
        }
        let first = first.max(orders.max_lag());
        let rows = run.len().saturating_sub(first);
        if rows <= orders.n_params() {
            return Err(SysidError::TooFewSamples {
                rows,
                params: orders.n_params(),
            });
        }
        let peak = (0..run.n_inputs())
            .flat_map(|i| run.input(i).iter())
            .chain(run.output())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        Ok(OutputErrorModel {
            run,
            orders,
            first,
            bound: 1e6 * (peak + 1.0),
            cache: Mutex::new(None),
        })
    }

    /// First sample with a residual row.
    pub fn first_row(&self) -> usize {
        self.first
    }

    /// Number of parameters: the ARX parameters, then the `na` initial values.
    fn n_all(&self) -> usize {
        self.orders.n_params() + self.orders.na
    }

    /// The start vector: the ARX parameters `arx` and the measured outputs
    /// as initial values.
    pub fn start_vector(&self, arx: &[f64]) -> Vec<f64> {
        let mut t = arx.to_vec();
        t.extend((1..=self.orders.na).map(|i| self.run.output()[self.first - i]));
        t
    }

    /// The simulation at θ over the whole run, with the sensitivities when
    /// `with_psi`. Every parallel task of one engine pass asks for the same
    /// θ, so the last simulation is cached (the recursion is sequential:
    /// without the cache each task would re-simulate from the start).
    fn simulation(&self, theta: &[f64], with_psi: bool) -> Arc<Simulation> {
        let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(c) = cache.as_ref()
            && c.theta == theta
            && (c.with_psi || !with_psi)
        {
            return Arc::clone(c);
        }
        let sim = Arc::new(self.simulate(theta, with_psi));
        *cache = Some(Arc::clone(&sim));
        sim
    }

    fn simulate(&self, theta: &[f64], with_psi: bool) -> Simulation {
        let o = &self.orders;
        let (na, dm, d) = (o.na, o.n_params(), self.n_all());
        let y = self.run.output();
        let n = y.len();
        let a = &theta[..na];
        // Before `first` the measured output, except the last `na` samples,
        // which are the free initial values.
        let mut yhat: Vec<f64> = y[..self.first].to_vec();
        for i in 1..=na {
            yhat[self.first - i] = theta[dm + i - 1];
        }
        yhat.reserve(n - self.first);
        let mut psi: Vec<f64> = if with_psi {
            vec![0.0; n * d]
        } else {
            Vec::new()
        };
        if with_psi {
            for i in 1..=na {
                psi[(self.first - i) * d + dm + i - 1] = 1.0;
            }
        }
        let mut diverged = false;
        let mut psi_diverged = false;
        // Per input: its coefficients `b_{u,0..=nb}` and samples, so that
        // `u(k − j − nk)` for `j = 0..=nb` is the window ending at `k − nk`.
        let terms: Vec<(&[f64], &[f64], usize)> = o
            .inputs
            .iter()
            .enumerate()
            .scan(na, |col, (u_i, oi)| {
                let b = &theta[*col..*col + oi.nb + 1];
                *col += oi.nb + 1;
                Some((b, self.run.input(u_i), oi.nk))
            })
            .collect();
        for k in self.first..n {
            let v = next_output(&terms, a, &yhat, k);
            if diverged || !(v.is_finite() && v.abs() <= self.bound) {
                diverged = true;
                yhat.push(self.bound);
                continue;
            }
            yhat.push(v);
            if with_psi {
                let (past, now) = psi.split_at_mut(k * d);
                let now = &mut now[..d];
                for (i, p) in now[..na].iter_mut().enumerate() {
                    *p = -yhat[k - i - 1];
                }
                let mut col = na;
                for (u_i, oi) in o.inputs.iter().enumerate() {
                    let u = self.run.input(u_i);
                    for j in 0..=oi.nb {
                        now[col] = u[k - j - oi.nk];
                        col += 1;
                    }
                }
                for (l, al) in a.iter().enumerate() {
                    let back = k - l - 1;
                    let prev = &past[back * d..back * d + d];
                    for (p, q) in now.iter_mut().zip(prev) {
                        *p -= al * q;
                    }
                }
                if now
                    .iter()
                    .any(|p| !(p.is_finite() && p.abs() <= self.bound))
                {
                    diverged = true;
                    psi_diverged = true;
                    now.fill(0.0);
                }
            }
        }
        if diverged {
            // A diverging model: large finite residuals, no slope, so the
            // engine rejects the step that led here.
            psi.fill(0.0);
        }
        Simulation {
            theta: theta.to_vec(),
            with_psi,
            psi_diverged,
            yhat,
            psi,
        }
    }
}

/// `ŷ(k) = Σ_u Σ_j b_{u,j}·u(k−j−nk_u) − Σ_i a_i·ŷ(k−i)`, summed in that
/// order (inputs, then lags, each from the nearest sample back).
#[inline]
fn next_output(terms: &[(&[f64], &[f64], usize)], a: &[f64], yhat: &[f64], k: usize) -> f64 {
    let mut v = 0.0;
    for &(b, u, nk) in terms {
        let window = &u[k + 1 - nk - b.len()..=k - nk];
        for (bj, uj) in b.iter().zip(window.iter().rev()) {
            v += bj * uj;
        }
    }
    let past = &yhat[k - a.len()..k];
    for (ai, yi) in a.iter().zip(past.iter().rev()) {
        v -= ai * yi;
    }
    v
}

/// One simulation of [`OutputErrorModel`] at θ.
struct Simulation {
    theta: Vec<f64>,
    with_psi: bool,
    /// The sensitivities left their bound, which froze `yhat` from there on
    /// (a simulation of the output alone may have gone further).
    psi_diverged: bool,
    /// `ŷ(k)`, every sample of the run.
    yhat: Vec<f64>,
    /// `∂ŷ(k)/∂θ`, `d` per sample (empty without sensitivities).
    psi: Vec<f64>,
}

impl Model for OutputErrorModel<'_> {
    fn parameters(&self) -> Vec<Parameter> {
        let mut p: Vec<Parameter> = (1..=self.orders.na)
            .map(|i| Parameter::new(format!("a{i}")))
            .collect();
        let several = self.orders.inputs.len() > 1;
        for (u, o) in self.orders.inputs.iter().enumerate() {
            for j in 0..=o.nb {
                p.push(Parameter::new(if several {
                    format!("b{u}_{j}")
                } else {
                    format!("b{j}")
                }));
            }
        }
        p.extend((1..=self.orders.na).map(|i| Parameter::new(format!("y0[-{i}]"))));
        p
    }

    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform("samples", self.run.len() - self.first, 1)
    }

    /// The residuals come from a simulation of the output alone, the
    /// Jacobian from one with the sensitivities (whose divergence also stops
    /// the simulated output there). When both are asked for, one simulation
    /// with the sensitivities gives both unless its sensitivities diverged
    /// (then the residuals come from a simulation of the output alone, as
    /// when they are asked for by themselves). The Jacobian is copied a row
    /// at a time when its rows are contiguous (the engine's transposed
    /// storage), a column at a time when its columns are.
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        jac: Option<MatMut<'_, f64>>,
    ) {
        let first = self.first + rows.start;
        let with_psi = jac.is_some().then(|| self.simulation(theta, true));
        if let Some(r) = r {
            let sim = match &with_psi {
                Some(sim) if !sim.psi_diverged => Arc::clone(sim),
                _ => self.simulation(theta, false),
            };
            let y = self.run.output();
            for (row, v) in r.iter_mut().enumerate().take(rows.len()) {
                let k = first + row;
                *v = sim.yhat[k] - y[k];
            }
        }
        if let (Some(mut jm), Some(sim)) = (jac, with_psi) {
            let d = self.n_all();
            let psi_rows = sim.psi[first * d..(first + rows.len()) * d].chunks_exact(d);
            if jm.col_stride() == 1 {
                for (row, src) in psi_rows.enumerate() {
                    let dst = jm.as_mut().row_mut(row).try_as_row_major_mut();
                    dst.expect("unit column stride")
                        .as_slice_mut()
                        .copy_from_slice(src);
                }
            } else {
                for c in 0..d {
                    match jm.as_mut().col_mut(c).try_as_col_major_mut() {
                        Some(col) => {
                            let col = col.as_slice_mut();
                            for (row, v) in col.iter_mut().enumerate() {
                                *v = sim.psi[(first + row) * d + c];
                            }
                        }
                        None => {
                            for row in 0..rows.len() {
                                jm[(row, c)] = sim.psi[(first + row) * d + c];
                            }
                        }
                    }
                }
            }
        }
    }
}

/// An output-error fit: the model, its statistics (the `loss`, `fpe`, `aic`
/// of [`FitStats`] are those of the *simulation* error over the residual
/// rows) and the covariance of `θ` from the Levenberg–Marquardt solution.
#[derive(Debug, Clone)]
pub struct OutputErrorFit {
    /// The refined model, as an [`ArxFit`] (`stats.loss` = mean squared
    /// simulation error; `one_step_rms` is still the one-step predictor's).
    pub fit: ArxFit,
    /// The equation-error (ARX) fit it started from.
    pub start: ArxFit,
    /// True when the engine reported convergence.
    pub converged: bool,
}

/// Refine the ARX fit of structure `orders` on `run` by minimising the
/// simulation error, residual rows from `first.max(orders.max_lag())`.
///
/// The refined model is kept only when its simulation cost is not larger
/// than the ARX start's and it is stable whenever the start is; otherwise
/// the ARX estimate is returned unchanged (with OE statistics).
pub fn fit_output_error(
    run: &Run,
    orders: &ArxOrders,
    first: usize,
) -> Result<OutputErrorFit, SysidError> {
    fit_output_error_par(run, orders, first, crate::par::Par::rayon(0))
}

/// [`fit_output_error`] with the parallelism `par` of the Levenberg–Marquardt
/// engine: [`Par::Seq`](crate::par::Par::Seq) when the caller runs many
/// small refinements in parallel itself (one engine per thread, no nested
/// parallel loops).
pub fn fit_output_error_par(
    run: &Run,
    orders: &ArxOrders,
    first: usize,
    par: crate::par::Par,
) -> Result<OutputErrorFit, SysidError> {
    let model = OutputErrorModel::new(run, orders.clone(), first)?;
    let start = fit_arx(
        std::slice::from_ref(run),
        orders,
        Start::From(model.first_row()),
    )?;
    let dm = orders.n_params();
    let theta0 = model.start_vector(&start.model.params());
    // The ARX start is close; a relative cost change of 1e-9 is far below
    // what the noise lets the data decide.
    let options = fit::Options {
        strategy: fit::Strategy::Dense,
        cost_tolerance: 1e-9,
        step_tolerance: 1e-8,
        max_iterations: 50,
        par,
        ..fit::Options::default()
    };
    let cost = |theta: &[f64]| {
        let m = run.len() - model.first_row();
        let mut r = vec![0.0; m];
        model.residuals(theta, 0..m, &mut r);
        r.iter().map(|v| v * v).sum::<f64>()
    };
    let cost0 = cost(&theta0);
    let (theta, covariance, converged) = match fit::fit(&model, &theta0, &options) {
        Ok(rep) => {
            let candidate = Arx::from_params(orders, &rep.theta[..dm]);
            let keep = cost(&rep.theta) <= cost0
                && (candidate.stability().is_stable() || !start.model.stability().is_stable());
            if keep {
                // Parameters the engine left fixed get zero variance; the
                // initial values are left out.
                let cov = rep.covariance.as_ref().map(|c| {
                    let mut m = nalgebra::DMatrix::zeros(dm, dm);
                    for (a, &i) in c.estimated.iter().enumerate() {
                        for (b, &j) in c.estimated.iter().enumerate() {
                            if i < dm && j < dm {
                                m[(i, j)] = c.matrix[(a, b)];
                            }
                        }
                    }
                    m
                });
                (rep.theta, cov, rep.convergence.reason.converged())
            } else {
                (theta0.clone(), None, false)
            }
        }
        // A refinement that cannot run leaves the ARX estimate.
        Err(_) => (theta0.clone(), None, false),
    };
    let arx = Arx::from_params(orders, &theta[..dm]);
    let m = run.len() - model.first_row();
    let d = dm;
    let sim = arx.simulate(&run.input_slices())?;
    // The model is used from rest (docs/servo.md), not from the initial state estimated
    // here: a structure whose estimated initial state hides a slow mode would
    // look good on the fitted residuals and simulate badly from rest. The
    // criterion's loss is the larger of the two mean squares over the rows.
    let from_rest = sim[model.first_row()..]
        .iter()
        .zip(&run.output()[model.first_row()..])
        .map(|(s, y)| (s - y) * (s - y))
        .sum::<f64>()
        / m as f64;
    let loss = (cost(&theta) / m as f64).max(from_rest);
    let predicted = arx.predict(run.output(), &run.input_slices())?;
    let one_step = predicted[model.first_row()..]
        .iter()
        .zip(&run.output()[model.first_row()..])
        .map(|(p, y)| (p - y) * (p - y))
        .sum::<f64>()
        / m as f64;
    let sim_ms = sim
        .iter()
        .zip(run.output())
        .map(|(s, y)| (s - y) * (s - y))
        .sum::<f64>()
        / run.len() as f64;
    let stats = FitStats {
        samples: m,
        params: d,
        loss,
        fpe: FitStats::fpe_of(loss, m, d),
        aic: FitStats::aic_of(loss, m, d),
        one_step_rms: one_step.sqrt(),
        simulation_rms: sim_ms.sqrt(),
        spectral_radius: arx.stability().spectral_radius(),
    };
    let covariance = covariance.unwrap_or_else(|| start.covariance.clone());
    Ok(OutputErrorFit {
        fit: ArxFit {
            model: arx,
            stats,
            covariance,
        },
        start,
        converged,
    })
}

/// [`super::select_orders`] for the output-error estimate: every structure
/// of `grid` is fitted by ARX and refined by [`fit_output_error`], all on the
/// same residual rows (from the grid's largest lag), and `criterion` is
/// evaluated on the simulation error. Stable models are preferred.
pub fn select_orders_output_error(
    run: &Run,
    grid: &OrderGrid,
    criterion: Criterion,
) -> Result<OrderSelection, SysidError> {
    let structures = grid.structures();
    if structures.is_empty() {
        return Err(SysidError::NoOrderFits("the grid is empty".into()));
    }
    let first = grid.max_lag();
    let fits: Vec<Result<ArxFit, SysidError>> = crate::par::map(&structures, 1, |_, o| {
        fit_output_error(run, o, first).map(|f| f.fit)
    });
    selection_of(structures, fits, criterion)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};
    use rand_distr::StandardNormal;

    fn run_of(arx: &Arx, n: usize, noise: f64, seed: u64) -> Run {
        let mut rng = StdRng::seed_from_u64(seed);
        let u: Vec<f64> = (0..n)
            .map(|k| ((k / 40) as f64 * 1.7).sin() * 2.0 + 0.3 * (k as f64 * 0.05).sin())
            .collect();
        let y = arx.simulate(&[&u]).unwrap();
        let y = y
            .iter()
            .map(|v| v + noise * rng.sample::<f64, _>(StandardNormal))
            .collect();
        Run::new(y, vec![u]).unwrap()
    }

    fn truth() -> Arx {
        let (r, th) = (0.97f64, 0.04f64);
        let a = vec![1.0, -2.0 * r * th.cos(), r * r];
        let g: f64 = a.iter().sum();
        Arx::new(a, vec![(vec![0.4 * g, 0.6 * g], 1)]).unwrap()
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        // A well-damped two-input model (central differences are accurate to
        // ~1e-9 there; near the unit circle their truncation error grows).
        let mut rng = StdRng::seed_from_u64(5);
        let arx = Arx::new(
            vec![1.0, -0.9, 0.2],
            vec![(vec![0.2, 0.1], 1), (vec![0.05, -0.02, 0.01], 0)],
        )
        .unwrap();
        let u1: Vec<f64> = (0..300).map(|k| (k as f64 * 0.07).sin()).collect();
        let u2: Vec<f64> = (0..300).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let y: Vec<f64> = arx
            .simulate(&[&u1, &u2])
            .unwrap()
            .iter()
            .map(|v| v + 0.01 * rng.sample::<f64, _>(StandardNormal))
            .collect();
        let run = Run::new(y, vec![u1, u2]).unwrap();
        let model = OutputErrorModel::new(&run, arx.orders(), 4).unwrap();
        assert_eq!(model.first_row(), 4);
        assert_eq!(model.parameters().len(), 2 + 2 + 3 + 2);
        let arx_theta: Vec<f64> = arx.params().iter().map(|t| t * 1.01).collect();
        let theta = model.start_vector(&arx_theta);
        let c = fit::check_jacobian(&model, &theta).unwrap();
        assert!(c.passes(1e-7), "{c:?}");
    }

    #[test]
    fn noise_free_data_give_the_truth_exactly() {
        let arx = truth();
        let run = run_of(&arx, 2000, 0.0, 1);
        let f = fit_output_error(&run, &arx.orders(), 0).unwrap();
        for (a, b) in f.fit.model.params().iter().zip(arx.params()) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
    }

    #[test]
    fn output_noise_biases_arx_but_not_output_error() {
        // Poles near 1 and 5e-3 of output noise on ~2 of signal: the ARX
        // estimate of the pole radius is visibly biased, the OE one is not.
        let arx = truth();
        let (mut arx_err, mut oe_err) = (0.0f64, 0.0f64);
        for seed in 0..4 {
            let run = run_of(&arx, 5000, 5e-3, seed);
            let f = fit_output_error(&run, &arx.orders(), 0).unwrap();
            let gap = |m: &Arx| {
                let u = run.input(0);
                let a = m.simulate(&[u]).unwrap();
                let b = arx.simulate(&[u]).unwrap();
                let s: f64 = a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum();
                (s / u.len() as f64).sqrt()
            };
            arx_err = arx_err.max(gap(&f.start.model));
            oe_err = oe_err.max(gap(&f.fit.model));
            assert!(f.converged);
            assert!(f.fit.stats.loss <= f.start.stats.simulation_rms.powi(2) * 1.01);
        }
        assert!(oe_err < 1e-3, "OE model off the truth by {oe_err}");
        assert!(arx_err > 3.0 * oe_err, "ARX {arx_err} vs OE {oe_err}");
    }

    #[test]
    fn order_selection_finds_the_true_structure() {
        let arx = truth();
        let run = run_of(&arx, 3000, 1e-3, 7);
        let grid = OrderGrid {
            na: 1..=3,
            inputs: vec![crate::sysid::InputGrid {
                nb: 0..=2,
                nk: 0..=2,
            }],
        };
        let s = select_orders_output_error(&run, &grid, Criterion::Fpe).unwrap();
        let o = &s.table[s.best].orders;
        // FPE may add a parameter the noise happens to favour (its loss
        // differs from the true structure's by ~0.3 %), never drop one.
        assert!(
            o.na >= 2 && o.inputs[0].nk <= 1 && o.inputs[0].nb + o.inputs[0].nk >= 2,
            "{o}"
        );
        // The loss sits at the noise variance (1e-6), not at an ARX bias.
        assert!(s.fit.stats.loss < 1.05e-6, "{}", s.fit.stats.loss);
        // Held out: a different input in the excited band (steps held 50
        // samples), compared noise-free with the truth.
        let u: Vec<f64> = (0..2000)
            .map(|k| ((k / 50) as f64 * 2.3).cos() * 2.0 + 0.2 * (k as f64 * 0.11).sin())
            .collect();
        let a = s.fit.model.simulate(&[&u]).unwrap();
        let b = arx.simulate(&[&u]).unwrap();
        let gap = (a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            / 2000.0)
            .sqrt();
        assert!(gap < 5e-4, "held-out gap {gap}");
    }
}
