//! The ISO 230-2:2014 evaluation of a positioning run ([ISO230-2] in
//! docs/references.md). With `x↑ij = P↑ij − Pi` the deviation at target `i`
//! (of `m`) in cycle `j` (of `n`), approached from below (↑), and `x↓ij` from
//! above (↓):
//!
//! * mean unidirectional deviation `x̄↑i = (1/n) Σj x↑ij` (and ↓), mean
//!   bidirectional deviation `x̄i = (x̄↑i + x̄↓i)/2`;
//! * reversal value `Bi = x̄↑i − x̄↓i`, reversal of the axis `B = max |Bi|`,
//!   mean reversal `B̄ = (1/m) Σi Bi`;
//! * estimator of the unidirectional standard uncertainty
//!   `s↑i = sqrt( Σj (x↑ij − x̄↑i)² / (n − 1) )` (and ↓);
//! * unidirectional repeatability `R↑i = 4 s↑i` (and ↓), bidirectional
//!   `Ri = max(2s↑i + 2s↓i + |Bi|, R↑i, R↓i)`; of the axis `R↑ = max R↑i`,
//!   `R↓ = max R↓i`, `R = max Ri`;
//! * systematic positioning error `E↑ = max x̄↑i − min x̄↑i` (and ↓), `E =
//!   max(x̄↑i, x̄↓i) − min(x̄↑i, x̄↓i)` over both directions;
//! * mean bidirectional positioning error (the range of the mean
//!   bidirectional deviation) `M = max x̄i − min x̄i`;
//! * accuracy `A↑ = max(x̄↑i + 2s↑i) − min(x̄↑i − 2s↑i)` (and ↓), `A =
//!   max(x̄↑i + 2s↑i, x̄↓i + 2s↓i) − min(x̄↑i − 2s↑i, x̄↓i − 2s↓i)`.

use std::path::Path;

use super::doc::{PositioningDoc, TargetRow};
use crate::io::{Diagnostic, Diagnostics};

/// A positioning run: measured deviations (actual − target, mm) per target,
/// direction and cycle. `up_mm[i][j]` is the approach from below (increasing
/// position) to `targets_mm[i]` in cycle `j`; every target has the same number
/// of cycles in both directions.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Where the run came from (file name), for the document.
    pub source: String,
    /// Target positions, mm, increasing.
    pub targets_mm: Vec<f64>,
    /// Deviations approaching from below (↑), mm, `[target][cycle]`.
    pub up_mm: Vec<Vec<f64>>,
    /// Deviations approaching from above (↓), mm, `[target][cycle]`.
    pub down_mm: Vec<Vec<f64>>,
    /// What the reader dropped or assumed, one sentence each.
    pub notes: Vec<String>,
}

/// One measured approach as a reader finds it, with where it was found.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Entry {
    pub target_mm: f64,
    pub up: bool,
    /// 1-based cycle when the format numbers them; `None`: order of appearance.
    pub cycle: Option<usize>,
    pub deviation_mm: f64,
    pub line: usize,
    pub col: usize,
}

fn same_target(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
}

/// Group the entries of a file into a [`Run`]: both directions present, every
/// target and direction with the same number of cycles (at least two), no
/// cycle given twice. Each problem names the line of the entry concerned.
pub(crate) fn assemble(
    path: &Path,
    entries: &[Entry],
    notes: Vec<String>,
) -> Result<Run, Diagnostics> {
    if entries.is_empty() {
        return Err(Diagnostic::whole(path, "no measured positions in the file").into());
    }
    for (up, name) in [(true, "↑ (increasing)"), (false, "↓ (decreasing)")] {
        if !entries.iter().any(|e| e.up == up) {
            let first = &entries[0];
            return Err(Diagnostic::at(
                path,
                first.line,
                first.col,
                format!(
                    "one direction only: the run has no {name} approaches; ISO 230-2 needs every target approached from both sides"
                ),
            )
            .into());
        }
    }
    let mut targets: Vec<f64> = Vec::new();
    for e in entries {
        if !targets.iter().any(|&t| same_target(t, e.target_mm)) {
            targets.push(e.target_mm);
        }
    }
    targets.sort_by(f64::total_cmp);
    let mut diags = Diagnostics::default();
    // [target][dir] -> entries in cycle order
    let mut groups: Vec<[Vec<&Entry>; 2]> = vec![[Vec::new(), Vec::new()]; targets.len()];
    for e in entries {
        let i = targets
            .iter()
            .position(|&t| same_target(t, e.target_mm))
            .unwrap_or(0);
        groups[i][usize::from(!e.up)].push(e);
    }
    for g in &mut groups {
        for list in g.iter_mut() {
            if list.iter().all(|e| e.cycle.is_some()) {
                list.sort_by_key(|e| e.cycle);
                for w in list.windows(2) {
                    if w[0].cycle == w[1].cycle {
                        diags.push(Diagnostic::at(
                            path,
                            w[1].line,
                            w[1].col,
                            format!(
                                "cycle {} of this target and direction is given twice (first at line {})",
                                w[1].cycle.unwrap_or(0),
                                w[0].line
                            ),
                        ));
                    }
                }
            }
        }
    }
    let n = groups
        .iter()
        .flat_map(|g| g.iter().map(Vec::len))
        .max()
        .unwrap_or(0);
    for (i, g) in groups.iter().enumerate() {
        for (d, list) in g.iter().enumerate() {
            if list.len() != n {
                let at = list
                    .last()
                    .copied()
                    .or_else(|| g[1 - d].first().copied())
                    .unwrap_or(&entries[0]);
                diags.push(Diagnostic::at(
                    path,
                    at.line,
                    at.col,
                    format!(
                        "cycles of unequal length: target {} mm has {} {} approach(es), other targets have {n}",
                        crate::io::fmt_f64(targets[i]),
                        list.len(),
                        if d == 0 { "↑" } else { "↓" }
                    ),
                ));
            }
        }
    }
    if diags.is_empty() && n < 2 {
        let e = &entries[0];
        diags.push(Diagnostic::at(
            path,
            e.line,
            e.col,
            "one cycle only: the standard uncertainty needs at least two approaches per target and direction (ISO 230-2 asks for five)",
        ));
    }
    diags.into_result(())?;
    let pick = |d: usize| -> Vec<Vec<f64>> {
        groups
            .iter()
            .map(|g| g[d].iter().map(|e| e.deviation_mm).collect())
            .collect()
    };
    Ok(Run {
        source: path.display().to_string(),
        targets_mm: targets,
        up_mm: pick(0),
        down_mm: pick(1),
        notes,
    })
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Sample standard deviation (divisor `n − 1`).
fn std_dev(x: &[f64]) -> f64 {
    let m = mean(x);
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() as f64 - 1.0)).sqrt()
}

fn max(it: impl Iterator<Item = f64>) -> f64 {
    it.fold(f64::NEG_INFINITY, f64::max)
}

fn min(it: impl Iterator<Item = f64>) -> f64 {
    it.fold(f64::INFINITY, f64::min)
}

/// The ISO 230-2 figures of `run` (see the module documentation for the
/// formulas). Errors (a sentence) when the run is not rectangular, has fewer
/// than two cycles or a value that is not finite.
pub fn evaluate(run: &Run) -> Result<PositioningDoc, String> {
    let m = run.targets_mm.len();
    if m == 0 {
        return Err("the run has no target".into());
    }
    if run.up_mm.len() != m || run.down_mm.len() != m {
        return Err("the run needs deviations in both directions for every target".into());
    }
    let n = run.up_mm[0].len();
    if n < 2 {
        return Err("the run needs at least two cycles".into());
    }
    if run
        .up_mm
        .iter()
        .chain(&run.down_mm)
        .any(|c| c.len() != n || c.iter().any(|v| !v.is_finite()))
    {
        return Err("cycles of unequal length or deviations that are not numbers".into());
    }
    const UM: f64 = 1000.0;
    let rows: Vec<TargetRow> = (0..m)
        .map(|i| {
            let up = &run.up_mm[i];
            let down = &run.down_mm[i];
            let (mu, md) = (mean(up), mean(down));
            let (su, sd) = (std_dev(up), std_dev(down));
            let b = mu - md;
            let (ru, rd) = (4.0 * su, 4.0 * sd);
            TargetRow {
                target_mm: run.targets_mm[i],
                mean_up_um: mu * UM,
                mean_down_um: md * UM,
                mean_um: 0.5 * (mu + md) * UM,
                s_up_um: su * UM,
                s_down_um: sd * UM,
                reversal_um: b * UM,
                r_up_um: ru * UM,
                r_down_um: rd * UM,
                r_um: (2.0 * su + 2.0 * sd + b.abs()).max(ru).max(rd) * UM,
                deviations_up_um: up.iter().map(|v| v * UM).collect(),
                deviations_down_um: down.iter().map(|v| v * UM).collect(),
            }
        })
        .collect();
    let r = &rows;
    let e_up = max(r.iter().map(|t| t.mean_up_um)) - min(r.iter().map(|t| t.mean_up_um));
    let e_down = max(r.iter().map(|t| t.mean_down_um)) - min(r.iter().map(|t| t.mean_down_um));
    let e = max(r.iter().flat_map(|t| [t.mean_up_um, t.mean_down_um]))
        - min(r.iter().flat_map(|t| [t.mean_up_um, t.mean_down_um]));
    let hi_up = |t: &TargetRow| t.mean_up_um + 2.0 * t.s_up_um;
    let lo_up = |t: &TargetRow| t.mean_up_um - 2.0 * t.s_up_um;
    let hi_down = |t: &TargetRow| t.mean_down_um + 2.0 * t.s_down_um;
    let lo_down = |t: &TargetRow| t.mean_down_um - 2.0 * t.s_down_um;
    let a_up = max(r.iter().map(hi_up)) - min(r.iter().map(lo_up));
    let a_down = max(r.iter().map(hi_down)) - min(r.iter().map(lo_down));
    let a = max(r.iter().flat_map(|t| [hi_up(t), hi_down(t)]))
        - min(r.iter().flat_map(|t| [lo_up(t), lo_down(t)]));
    Ok(PositioningDoc {
        source: run.source.clone(),
        targets: m,
        cycles: n,
        a_um: a,
        a_up_um: a_up,
        a_down_um: a_down,
        b_um: max(r.iter().map(|t| t.reversal_um.abs())),
        b_mean_um: r.iter().map(|t| t.reversal_um).sum::<f64>() / m as f64,
        e_um: e,
        e_up_um: e_up,
        e_down_um: e_down,
        m_um: max(r.iter().map(|t| t.mean_um)) - min(r.iter().map(|t| t.mean_um)),
        r_um: max(r.iter().map(|t| t.r_um)),
        r_up_um: max(r.iter().map(|t| t.r_up_um)),
        r_down_um: max(r.iter().map(|t| t.r_down_um)),
        per_target: rows,
        notes: run.notes.clone(),
    })
}
