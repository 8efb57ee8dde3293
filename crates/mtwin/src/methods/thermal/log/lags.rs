//! Sums of first-order lags: candidates whose held-out error follows from
//! least squares on lagged inputs (see the module documentation of `log`).

use super::cross_validation::{Fold, HeldOut};
use super::options::LogFitOptions;
use crate::sysid::{Arx, ArxOrders, InputOrder};

/// Time constants (min) of the first-order lags tried for sum-of-lags
/// candidates: singles and pairs of these, then refined.
pub(super) const LAG_GRID_MIN: [f64; 5] = [5.0, 15.0, 45.0, 135.0, 405.0];

/// The ARX orders of a sum of `lags` first-order lags per input:
/// `na = lags` (the product of the lags' denominators), `nb + 1 = lags`.
pub(super) fn lag_orders(inputs: usize, lags: usize) -> ArxOrders {
    ArxOrders {
        na: lags,
        inputs: (0..inputs)
            .map(|_| InputOrder {
                nb: lags.saturating_sub(1),
                nk: 1,
            })
            .collect(),
    }
}

/// The pole of a first-order lag of time constant `tau` (model periods).
fn lag_pole(tau: f64) -> f64 {
    (-1.0 / tau).exp()
}

/// A unit-gain first-order lag of `u` from rest, one sample late:
/// `x(0) = 0`, `x(k) = p·x(k−1) + (1 − p)·u(k−1)`.
fn lowpass(u: &[f64], p: f64) -> Vec<f64> {
    let mut x = Vec::with_capacity(u.len());
    let mut s = 0.0;
    for &v in u {
        x.push(s);
        s = p * s + (1.0 - p) * v;
    }
    x
}

/// The regressors of a sum-of-lags model over the first `n` samples: for
/// each input of `inputs`, its lag of each time constant of `taus`
/// (input-major); with `offset`, then a column that is 0 at sample 0 and 1
/// after it (the start offset, [`LogFitOptions::start_offset`]).
pub(super) fn lag_columns(
    u: &[Vec<f64>],
    inputs: &[usize],
    taus: &[f64],
    n: usize,
    offset: bool,
) -> Vec<Vec<f64>> {
    let mut cols: Vec<Vec<f64>> = inputs
        .iter()
        .flat_map(|&i| taus.iter().map(move |&t| lowpass(&u[i][..n], lag_pole(t))))
        .collect();
    if offset {
        cols.push(offset_column(n));
    }
    cols
}

/// The start offset's regressor over `n` samples: 0 at sample 0 (where the
/// drift since the first sample is 0 by construction), 1 after it.
fn offset_column(n: usize) -> Vec<f64> {
    (0..n).map(|k| if k == 0 { 0.0 } else { 1.0 }).collect()
}

/// The Gram matrices `Σ z zᵀ` of `z = [columns…, y]` over the samples
/// `0..k` for every `k` of `at` (ascending).
pub(super) fn prefix_grams(
    cols: &[Vec<f64>],
    y: &[f64],
    at: &[usize],
) -> Vec<nalgebra::DMatrix<f64>> {
    let c = cols.len() + 1;
    let end = at.last().copied().unwrap_or(0);
    let mut g = vec![0.0; c * c];
    let mut z = vec![0.0; c];
    let mut out = Vec::with_capacity(at.len());
    let mut next = 0;
    for k in 0..=end {
        while next < at.len() && at[next] == k {
            out.push(nalgebra::DMatrix::from_fn(c, c, |a, b| {
                g[a.max(b) * c + a.min(b)]
            }));
            next += 1;
        }
        if k == end {
            break;
        }
        for (j, col) in cols.iter().enumerate() {
            z[j] = col[k];
        }
        z[c - 1] = y[k];
        for a in 0..c {
            let za = z[a];
            for (gb, zb) in g[a * c..a * c + a + 1].iter_mut().zip(&z) {
                *gb += za * zb;
            }
        }
    }
    out
}

/// Least-squares gains from a Gram matrix of `[columns…, y]` (a tiny ridge,
/// relative to the largest diagonal, keeps a column that is zero on the
/// fit span from making it singular).
pub(super) fn solve_gains(g: &nalgebra::DMatrix<f64>) -> Option<Vec<f64>> {
    let c = g.nrows() - 1;
    let mut a = g.view((0, 0), (c, c)).into_owned();
    let rhs = g.view((0, c), (c, 1)).into_owned();
    let ridge = 1e-12 * (0..c).map(|i| a[(i, i)]).fold(0.0f64, f64::max).max(1e-300);
    for i in 0..c {
        a[(i, i)] += ridge;
    }
    let x = a.cholesky()?.solve(&rhs);
    let x: Vec<f64> = x.iter().copied().collect();
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// `vᵀ G v` with `v = [gains…, −1]`: the residual sum of squares of the
/// gains over the samples of the Gram matrix `g`.
fn residual_ss(g: &nalgebra::DMatrix<f64>, gains: &[f64]) -> f64 {
    let v: Vec<f64> = gains.iter().copied().chain([-1.0]).collect();
    let mut s = 0.0;
    for (a, va) in v.iter().enumerate() {
        for (b, vb) in v.iter().enumerate() {
            s += va * g[(a, b)] * vb;
        }
    }
    s.max(0.0)
}

/// Every input's static gain (the sum of its lags' gains) within the bound
/// (a start offset after the inputs' gains is not a gain).
fn lag_gains_ok(
    gains: &[f64],
    inputs: usize,
    lags: usize,
    options: &LogFitOptions,
    y_max: f64,
) -> bool {
    let bound = options.gain_bound * y_max.max(1e-12);
    gains[..inputs * lags]
        .chunks(lags)
        .all(|g| g.iter().sum::<f64>().abs() <= bound)
}

/// Pooled held-out RMS of the sum-of-lags model with time constants `taus`
/// over the folds (as [`cv_rms`](super::cross_validation::cv_rms): each fold's gains fitted by least squares
/// on its fit samples, its test block simulated from rest). With the time
/// constants fixed the simulated output is linear in the gains, so the
/// least-squares fit *is* the output-error fit and the test block's
/// simulation error follows from Gram matrices over sample prefixes.
pub(super) fn lag_cv(
    y: &[f64],
    u: &[Vec<f64>],
    inputs: &[usize],
    taus: &[f64],
    folds: &[Fold],
    options: &LogFitOptions,
    y_max: f64,
) -> Option<HeldOut> {
    if !folds
        .iter()
        .all(|f| f.fit.len() == 1 && f.fit[0].start == 0)
    {
        return None;
    }
    let mut at: Vec<usize> = folds
        .iter()
        .flat_map(|f| [f.fit[0].end, f.test.start, f.test.end])
        .collect();
    at.sort_unstable();
    at.dedup();
    let n = *at.last()?;
    let cols = lag_columns(u, inputs, taus, n, options.start_offset);
    let grams = prefix_grams(&cols, y, &at);
    let g = |k: usize| &grams[at.binary_search(&k).unwrap_or(0)];
    let mut held = HeldOut::new();
    for f in folds {
        let gains = solve_gains(g(f.fit[0].end))?;
        if !lag_gains_ok(&gains, inputs.len(), taus.len(), options, y_max) {
            return None;
        }
        held.ss
            .push(residual_ss(&(g(f.test.end) - g(f.test.start)), &gains));
        held.n.push(f.test.len());
        held.gains.push(
            gains[..inputs.len() * taus.len()]
                .chunks(taus.len())
                .map(|g| g.iter().sum())
                .collect(),
        );
    }
    held.finite()
}

/// Time constants acceptable together: each at least one period, at most
/// `longest`, and neighbours at least a factor 1.2 apart (closer lags are
/// nearly the same regressor).
fn lags_valid(taus: &[f64], longest: f64) -> bool {
    let mut t = taus.to_vec();
    t.sort_by(f64::total_cmp);
    t.iter().all(|&v| (1.0..=longest).contains(&v)) && t.windows(2).all(|w| w[1] >= 1.2 * w[0])
}

/// The best sum-of-lags model of `inputs`: every single time constant and
/// pair of the grid `grid` (model periods) judged by [`lag_cv`], then the
/// best refined by a coordinate search on the logarithm of each time
/// constant (steps ×1.6, ×1.26, ×1.12, ×1.06, each way), judged the same
/// way. Returns the time constants (ascending) and their held-out errors.
pub(super) fn best_lags(
    y: &[f64],
    u: &[Vec<f64>],
    inputs: &[usize],
    folds: &[Fold],
    options: &LogFitOptions,
    y_max: f64,
    grid: &[f64],
) -> Option<(Vec<f64>, HeldOut)> {
    let mut sets: Vec<Vec<f64>> = grid.iter().map(|&t| vec![t]).collect();
    for (i, &a) in grid.iter().enumerate() {
        for &b in &grid[i + 1..] {
            sets.push(vec![a, b]);
        }
    }
    let longest = 4.0 * y.len() as f64;
    let mut best: Option<(Vec<f64>, HeldOut)> = None;
    for set in sets {
        if !lags_valid(&set, longest) {
            continue;
        }
        if let Some(e) = lag_cv(y, u, inputs, &set, folds, options, y_max)
            && best.as_ref().is_none_or(|b| e.rms() < b.1.rms())
        {
            best = Some((set, e));
        }
    }
    let (mut taus, mut e) = best?;
    let mut step = 1.6f64;
    for _ in 0..4 {
        for i in 0..taus.len() {
            for f in [step, 1.0 / step] {
                let mut t = taus.clone();
                t[i] *= f;
                if !lags_valid(&t, longest) {
                    continue;
                }
                if let Some(et) = lag_cv(y, u, inputs, &t, folds, options, y_max)
                    && et.rms() < e.rms()
                {
                    (taus, e) = (t, et);
                }
            }
        }
        step = step.sqrt();
    }
    taus.sort_by(f64::total_cmp);
    Some((taus, e))
}

/// The time constants `taus` of a chosen sum-of-lags structure refined on
/// all `n` training samples: a coordinate search on the logarithm of each
/// (steps ×1.6 down to ×1.006, each way) minimising the simulation error
/// over the training samples, the gains fitted by least squares for each
/// trial (with the time constants it is an output-error fit; the structure
/// itself was chosen by the held-out blocks, whose first fits see only a
/// quarter of the samples).
pub(super) fn refine_lags(
    y: &[f64],
    u: &[Vec<f64>],
    inputs: &[usize],
    taus: &[f64],
    n: usize,
    offset: bool,
) -> Vec<f64> {
    let longest = 4.0 * y.len() as f64;
    let cost = |t: &[f64]| -> Option<f64> {
        let cols = lag_columns(u, inputs, t, n, offset);
        let g = prefix_grams(&cols, y, &[n]);
        let gains = solve_gains(&g[0])?;
        Some(residual_ss(&g[0], &gains))
    };
    let mut taus = taus.to_vec();
    let Some(mut e) = cost(&taus) else {
        return taus;
    };
    let mut step = 1.6f64;
    for _ in 0..7 {
        for i in 0..taus.len() {
            for f in [step, 1.0 / step] {
                let mut t = taus.clone();
                t[i] *= f;
                if !lags_valid(&t, longest) {
                    continue;
                }
                if let Some(et) = cost(&t)
                    && et < e
                {
                    (taus, e) = (t, et);
                }
            }
        }
        step = step.sqrt();
    }
    taus.sort_by(f64::total_cmp);
    taus
}

/// The sum-of-lags model as an ARX model (`nk = 1`): per input `i`,
/// `Σ_p g_{i,p}·(1 − p)·q⁻¹ / (1 − p·q⁻¹)` over the lags' poles `p`, on the
/// common denominator `Π_p (1 − p·q⁻¹)`. `gains` input-major, as
/// [`lag_columns`].
pub(super) fn lags_to_arx(taus: &[f64], gains: &[f64], n_inputs: usize) -> Option<Arx> {
    let poles: Vec<f64> = taus.iter().map(|&t| lag_pole(t)).collect();
    // poly · (1 − r·q⁻¹)
    let times = |poly: &[f64], r: f64| -> Vec<f64> {
        let mut out = vec![0.0; poly.len() + 1];
        for (i, &c) in poly.iter().enumerate() {
            out[i] += c;
            out[i + 1] -= r * c;
        }
        out
    };
    let a = poles.iter().fold(vec![1.0], |acc, &r| times(&acc, r));
    let b = (0..n_inputs)
        .map(|i| {
            let mut b = vec![0.0; poles.len()];
            for (j, &pj) in poles.iter().enumerate() {
                let others = poles
                    .iter()
                    .enumerate()
                    .filter(|&(l, _)| l != j)
                    .fold(vec![1.0], |acc, (_, &r)| times(&acc, r));
                let g = gains[i * poles.len() + j] * (1.0 - pj);
                for (m, c) in others.iter().enumerate() {
                    b[m] += g * c;
                }
            }
            (b, 1)
        })
        .collect();
    Arx::new(a, b).ok()
}
