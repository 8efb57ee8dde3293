use std::ops::RangeInclusive;

use super::{ArxFit, ArxOrders, FitStats, InputOrder, Run, Start, SysidError, fit_arx};

/// The information criterion that picks the orders.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Criterion {
    /// Akaike's final prediction error `V·(1 + d/N)/(1 − d/N)` (Ljung,
    /// *System Identification*, listed in `docs/references.md`).
    #[default]
    Fpe,
    /// Akaike's information criterion `N·ln V + 2d`.
    Aic,
}

impl Criterion {
    /// The criterion's value for a fit.
    pub fn value(self, stats: &FitStats) -> f64 {
        match self {
            Criterion::Fpe => stats.fpe,
            Criterion::Aic => stats.aic,
        }
    }
}

/// The orders tried for one input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputGrid {
    /// Values of `nb` tried.
    pub nb: RangeInclusive<usize>,
    /// Values of the delay `nk` tried.
    pub nk: RangeInclusive<usize>,
}

/// A grid of ARX structures: every combination of `na` and of each input's
/// `nb` and `nk`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OrderGrid {
    /// Values of `na` tried.
    pub na: RangeInclusive<usize>,
    /// One entry per input.
    pub inputs: Vec<InputGrid>,
}

impl OrderGrid {
    /// `na ∈ 1..=max`, every input `nb ∈ 0..=max` with the fixed delays `nk`.
    pub fn up_to(max: usize, nk: &[usize]) -> OrderGrid {
        OrderGrid {
            na: 1..=max.max(1),
            inputs: nk
                .iter()
                .map(|&k| InputGrid {
                    nb: 0..=max,
                    nk: k..=k,
                })
                .collect(),
        }
    }

    /// Every structure of the grid, `na` varying slowest.
    pub fn structures(&self) -> Vec<ArxOrders> {
        let mut out: Vec<ArxOrders> = self
            .na
            .clone()
            .map(|na| ArxOrders {
                na,
                inputs: Vec::new(),
            })
            .collect();
        for g in &self.inputs {
            let mut next = Vec::new();
            for o in &out {
                for nb in g.nb.clone() {
                    for nk in g.nk.clone() {
                        let mut o = o.clone();
                        o.inputs.push(InputOrder { nb, nk });
                        next.push(o);
                    }
                }
            }
            out = next;
        }
        out
    }

    /// The largest lag of any structure in the grid.
    pub fn max_lag(&self) -> usize {
        self.structures()
            .iter()
            .map(ArxOrders::max_lag)
            .max()
            .unwrap_or(0)
    }

    /// The largest number of parameters of any structure in the grid.
    pub fn max_params(&self) -> usize {
        self.structures()
            .iter()
            .map(ArxOrders::n_params)
            .max()
            .unwrap_or(0)
    }
}

/// One row of the order table.
#[derive(Debug, Clone)]
pub struct GridRow {
    /// The structure tried.
    pub orders: ArxOrders,
    /// Its fit statistics, or why it could not be fitted.
    pub outcome: Result<FitStats, SysidError>,
}

impl GridRow {
    /// True when the fit succeeded and its model is stable.
    pub fn is_stable_fit(&self) -> bool {
        self.outcome
            .as_ref()
            .is_ok_and(|s| s.spectral_radius < 1.0 - 1e-9)
    }
}

/// The result of an order search: the whole table and the chosen fit.
#[derive(Debug, Clone)]
pub struct OrderSelection {
    /// Every structure of the grid with its outcome, in grid order.
    pub table: Vec<GridRow>,
    /// The criterion used.
    pub criterion: Criterion,
    /// Index into `table` of the chosen structure.
    pub best: usize,
    /// The chosen fit.
    pub fit: ArxFit,
}

impl OrderSelection {
    /// Index of the row minimising `criterion` among stable fits (or among all
    /// fits when none is stable).
    pub fn best_by(&self, criterion: Criterion) -> Option<usize> {
        best_index(&self.table, criterion)
    }

    /// The grid table as JSON: one object per structure with its orders and
    /// either its statistics or its `error`; the chosen one has `"chosen": true`.
    pub fn table_json(&self) -> serde_json::Value {
        serde_json::to_value(self.table_doc()).expect("grid rows serialise")
    }

    /// The grid table as typed rows ([`GridRowDoc`]), in grid order.
    pub fn table_doc(&self) -> Vec<GridRowDoc> {
        self.table
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let s = r.outcome.as_ref().ok();
                // JSON has no NaN or infinity: a statistic that is not finite
                // (the simulation of an unstable model diverges) is absent.
                let finite = |x: f64| x.is_finite().then_some(x);
                GridRowDoc {
                    aic: s.and_then(|s| finite(s.aic)),
                    chosen: i == self.best,
                    error: r.outcome.as_ref().err().map(|e| e.to_string()),
                    fpe: s.and_then(|s| finite(s.fpe)),
                    na: r.orders.na,
                    nb: r.orders.inputs.iter().map(|o| o.nb).collect(),
                    nk: r.orders.inputs.iter().map(|o| o.nk).collect(),
                    one_step_rms: s.and_then(|s| finite(s.one_step_rms)),
                    params: s.map(|s| s.params),
                    samples: s.map(|s| s.samples),
                    simulation_rms: s.and_then(|s| finite(s.simulation_rms)),
                    stable: s.map(|_| r.is_stable_fit()),
                }
            })
            .collect()
    }

    /// The grid table as aligned text, the chosen row marked `*`; RMS values
    /// in the data's unit.
    pub fn table_text(&self) -> String {
        grid_text(&self.table_doc())
    }
}

/// One structure of an order search as a document: its orders, then either
/// its fit statistics or the `error` that stopped its fit. Fields are in
/// alphabetical order (the order of the JSON keys).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GridRowDoc {
    /// Akaike's information criterion.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aic: Option<f64>,
    /// Whether this structure was chosen.
    pub chosen: bool,
    /// Why the structure could not be fitted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Final prediction error (data unit²).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fpe: Option<f64>,
    /// Number of `a` coefficients after `a_0 = 1`.
    pub na: usize,
    /// Highest `b` index, per input.
    pub nb: Vec<usize>,
    /// Input delay (samples), per input.
    pub nk: Vec<usize>,
    /// One-step-ahead prediction RMS (data unit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub one_step_rms: Option<f64>,
    /// Free parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub params: Option<usize>,
    /// Regression rows used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Simulation RMS (data unit); absent when the simulation diverges.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulation_rms: Option<f64>,
    /// Whether the fitted model is stable.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stable: Option<bool>,
}

impl GridRowDoc {
    /// The orders of the row.
    pub fn orders(&self) -> ArxOrders {
        super::OrdersDoc {
            na: self.na,
            nb: self.nb.clone(),
            nk: self.nk.clone(),
        }
        .orders()
    }
}

/// The grid rows as aligned text (as [`OrderSelection::table_text`]).
pub fn grid_text(rows: &[GridRowDoc]) -> String {
    let mut out = format!(
        "  {:<28} {:>6} {:>3} {:>12} {:>10} {:>12} {:>12} {:>6}\n",
        "orders", "N", "d", "FPE", "AIC", "one-step RMS", "sim RMS", "stable"
    );
    for r in rows {
        let mark = if r.chosen { '*' } else { ' ' };
        let orders = r.orders().to_string();
        let num = |x: Option<f64>| x.map_or_else(|| "-".to_string(), |x| format!("{x:.4e}"));
        match (r.samples, r.params) {
            (Some(n), Some(d)) => out.push_str(&format!(
                "{mark} {orders:<28} {n:>6} {d:>3} {:>12} {:>10} {:>12} {:>12} {:>6}\n",
                num(r.fpe),
                r.aic.map_or_else(|| "-".to_string(), |x| format!("{x:.1}")),
                num(r.one_step_rms),
                r.simulation_rms
                    .map_or_else(|| "diverges".to_string(), |x| format!("{x:.4e}")),
                if r.stable == Some(true) { "yes" } else { "NO" }
            )),
            _ => out.push_str(&format!(
                "{mark} {orders:<28} not fitted: {}\n",
                r.error.as_deref().unwrap_or("no statistics")
            )),
        }
    }
    out
}

fn best_index(table: &[GridRow], criterion: Criterion) -> Option<usize> {
    let pick = |stable_only: bool| {
        table
            .iter()
            .enumerate()
            .filter(|(_, r)| !stable_only || r.is_stable_fit())
            .filter_map(|(i, r)| r.outcome.as_ref().ok().map(|s| (i, criterion.value(s))))
            .filter(|(_, v)| v.is_finite())
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    };
    pick(true).or_else(|| pick(false))
}

/// Fit every structure of `grid` and choose the one minimising `criterion`.
///
/// All structures are compared on the same regression rows: with
/// [`Start::From`]`(s)` every fit starts at `max(s, grid.max_lag())`. Stable
/// models are preferred: the chosen structure is the best stable one, and
/// only when no fit of the grid is stable the best of all (check
/// `fit.model.stability()`).
pub fn select_orders(
    runs: &[Run],
    grid: &OrderGrid,
    criterion: Criterion,
    start: Start,
) -> Result<OrderSelection, SysidError> {
    let start = match start {
        Start::AtRest => Start::AtRest,
        Start::From(s) => Start::From(s.max(grid.max_lag())),
    };
    let structures = grid.structures();
    if structures.is_empty() {
        return Err(SysidError::NoOrderFits("the grid is empty".into()));
    }
    let fits: Vec<Result<ArxFit, SysidError>> =
        crate::par::map(&structures, 1, |_, o| fit_arx(runs, o, start));
    selection_of(structures, fits, criterion)
}

/// The order table of `fits` (one per structure, in order) and the one
/// minimising `criterion`, preferring stable models.
pub(super) fn selection_of(
    structures: Vec<ArxOrders>,
    fits: Vec<Result<ArxFit, SysidError>>,
    criterion: Criterion,
) -> Result<OrderSelection, SysidError> {
    let table: Vec<GridRow> = structures
        .into_iter()
        .zip(&fits)
        .map(|(orders, f)| GridRow {
            orders,
            outcome: f.as_ref().map(|f| f.stats.clone()).map_err(Clone::clone),
        })
        .collect();
    let Some(best) = best_index(&table, criterion) else {
        let first_err = fits
            .iter()
            .find_map(|f| f.as_ref().err())
            .map_or_else(String::new, ToString::to_string);
        return Err(SysidError::NoOrderFits(first_err));
    };
    let fit = fits
        .into_iter()
        .nth(best)
        .and_then(Result::ok)
        .ok_or_else(|| SysidError::NoOrderFits("the chosen structure has no fit".into()))?;
    Ok(OrderSelection {
        table,
        criterion,
        best,
        fit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sysid::Arx;
    use rand::{Rng, SeedableRng, rngs::StdRng};
    use rand_distr::StandardNormal;

    #[test]
    fn grid_enumerates_every_combination() {
        let g = OrderGrid {
            na: 1..=2,
            inputs: vec![
                InputGrid {
                    nb: 0..=2,
                    nk: 1..=1,
                },
                InputGrid {
                    nb: 0..=1,
                    nk: 0..=1,
                },
            ],
        };
        let s = g.structures();
        assert_eq!(s.len(), 2 * 3 * 2 * 2);
        let unique: std::collections::HashSet<_> = s.iter().cloned().collect();
        assert_eq!(unique.len(), s.len());
        assert_eq!(g.max_lag(), 3);
        assert_eq!(g.max_params(), 2 + 3 + 2);
    }

    fn data(seed: u64) -> Vec<Run> {
        let truth = Arx::new(vec![1.0, -1.5, 0.7], vec![(vec![1.0, 0.5], 1)]).unwrap();
        let mut rng = StdRng::seed_from_u64(seed);
        (0..2)
            .map(|_| {
                let n = 400;
                let u: Vec<f64> = (0..n).map(|_| rng.sample(StandardNormal)).collect();
                let mut y = vec![0.0; n];
                for k in 0..n {
                    let e: f64 = rng.sample(StandardNormal);
                    y[k] = truth.equation(k, &y, &[&u]) + 0.1 * e;
                }
                Run::new(y, vec![u]).unwrap()
            })
            .collect()
    }

    #[test]
    fn fpe_and_aic_find_the_true_orders() {
        // True structure na = 2, nb = 1, nk = 1. Information criteria do not
        // under-fit a well excited system; they over-fit now and then, so count.
        let grid = OrderGrid::up_to(4, &[1]);
        let seeds = 20;
        for criterion in [Criterion::Fpe, Criterion::Aic] {
            let mut exact = 0;
            for seed in 0..seeds {
                let sel = select_orders(&data(seed), &grid, criterion, Start::AtRest).unwrap();
                let o = &sel.table[sel.best].orders;
                assert!(o.na >= 2 && o.inputs[0].nb >= 1, "under-fit {o}");
                if o.na == 2 && o.inputs[0].nb == 1 {
                    exact += 1;
                }
                assert_eq!(sel.table.len(), 4 * 5);
            }
            assert!(
                exact * 10 >= seeds * 6,
                "{criterion:?} found the true orders in {exact}/{seeds} seeds"
            );
        }
    }

    #[test]
    fn table_holds_failures_and_criteria_agree_with_stats() {
        let runs = data(7);
        let grid = OrderGrid::up_to(2, &[1]);
        let sel = select_orders(&runs, &grid, Criterion::Fpe, Start::From(0)).unwrap();
        for row in &sel.table {
            let s = row.outcome.as_ref().unwrap();
            // Every row uses the same rows: N = 2 × (400 − max lag 3).
            assert_eq!(s.samples, 2 * (400 - 3));
            let (n, d) = (s.samples as f64, s.params as f64);
            assert!((s.fpe - s.loss * (n + d) / (n - d)).abs() <= 1e-12 * s.fpe);
            assert!((s.aic - (n * s.loss.ln() + 2.0 * d)).abs() < 1e-9);
        }
        let json = sel.table_json();
        assert_eq!(json.as_array().unwrap().len(), sel.table.len());
        assert_eq!(json[sel.best]["chosen"], true);
        assert_eq!(json[0]["na"], 1);
        assert_eq!(
            sel.table_text()
                .lines()
                .filter(|l| l.starts_with('*'))
                .count(),
            1
        );
        let best = sel.table[sel.best].outcome.as_ref().unwrap().fpe;
        assert!(
            sel.table
                .iter()
                .all(|r| r.outcome.as_ref().unwrap().fpe >= best)
        );
        let tiny = vec![Run::new(vec![0.0; 3], vec![vec![1.0; 3]]).unwrap()];
        assert!(matches!(
            select_orders(&tiny, &grid, Criterion::Fpe, Start::AtRest),
            Err(SysidError::NoOrderFits(_))
        ));
    }
}
