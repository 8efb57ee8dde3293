//! The input selection of one channel: forward, backward and exchange steps
//! under the input rule.

use super::cross_validation::{Bound, Candidate};
use super::options::{InputSearch, LogFitOptions};
use super::orders::Judge;

/// The input selection of one channel: forward steps (the input whose
/// addition lowers the held-out RMS most, if the rule accepts it), then a
/// backward pass (an input whose removal costs less than `min_gain` goes),
/// then, with [`InputSearch::Exchange`], moves: the best replacement of
/// one chosen input by one not chosen or, when the rule accepts none over
/// the current set, the best pair of inputs added together, after which
/// the forward and backward passes run again (at most `max_inputs` moves,
/// and no more than there are inputs: the cap [`LogFitOptions::validate`]
/// counts, and what ends the search, since a backward removal may raise
/// the held-out RMS again).
/// `judge` judges each input set ([`Judge`]);
/// the path records each step (`name` added, `-name` removed, `old>new`
/// exchanged, `a+b` added together) with the held-out RMS after it.
pub(super) fn select_inputs(
    n_inputs: usize,
    names: &[String],
    options: &LogFitOptions,
    judge: &Judge,
    progress: &mut dyn FnMut(usize),
) -> (Option<Candidate>, Vec<(String, f64)>) {
    let rule = |old: &Candidate, new: &Candidate| options.rule.improves(old, new, options.min_gain);
    // A change is accepted only below (1 − min_gain) times the current RMS
    // (every rule asks that first): the step's starting bound.
    let limit = |old: Option<&Candidate>| {
        old.map_or(f64::INFINITY, |c| (1.0 - options.min_gain) * c.heldout_rms)
    };
    let best = |sets: Vec<Vec<usize>>, limit: f64, accept: &(dyn Fn(&Candidate) -> bool + Sync)| {
        best_set(sets, options.par, judge, limit, accept)
    };
    let mut chosen: Option<Candidate> = None;
    let mut path = Vec::new();
    let mut moves = 0;
    loop {
        // Forward steps.
        loop {
            let current: Vec<usize> = chosen.as_ref().map_or(Vec::new(), |c| c.inputs.clone());
            let remaining: Vec<usize> = (0..n_inputs).filter(|j| !current.contains(j)).collect();
            if remaining.is_empty() || current.len() >= options.max_inputs {
                break;
            }
            let sets = remaining
                .iter()
                .map(|&j| [current.as_slice(), &[j]].concat())
                .collect();
            let step = best(sets, limit(chosen.as_ref()), &|cand| {
                chosen.as_ref().is_none_or(|c| rule(c, cand))
            });
            let Some((k, cand)) = step else { break };
            path.push((names[remaining[k]].clone(), cand.heldout_rms));
            chosen = Some(cand);
            progress(path.len());
        }
        // Backward pass: an input whose removal costs less than `min_gain`
        // (an input picked early that a later one made redundant) goes.
        while let Some(c) = chosen.as_ref().filter(|c| c.inputs.len() > 1) {
            let sets = c
                .inputs
                .iter()
                .map(|&j| c.inputs.iter().copied().filter(|&i| i != j).collect())
                .collect();
            let Some((k, d)) = best(sets, f64::INFINITY, &|d| !rule(d, c)) else {
                break;
            };
            path.push((format!("-{}", names[c.inputs[k]]), d.heldout_rms));
            chosen = Some(d);
        }
        if options.search != InputSearch::Exchange || moves >= options.max_inputs.min(n_inputs) {
            break;
        }
        let Some(c) = chosen.as_ref() else { break };
        let out: Vec<usize> = (0..n_inputs).filter(|j| !c.inputs.contains(j)).collect();
        // Exchanges: one chosen input replaced by one not chosen.
        let swaps: Vec<(usize, usize)> = (0..c.inputs.len())
            .flat_map(|p| out.iter().map(move |&j| (p, j)))
            .collect();
        let sets = swaps
            .iter()
            .map(|&(p, j)| {
                let mut set = c.inputs.clone();
                set[p] = j;
                set
            })
            .collect();
        let step = match best(sets, limit(Some(c)), &|d| rule(c, d)) {
            Some((k, d)) => {
                let (p, j) = swaps[k];
                Some((format!("{}>{}", names[c.inputs[p]], names[j]), d))
            }
            // Else a pair of inputs added together.
            None if c.inputs.len() + 2 <= options.max_inputs => {
                let pairs: Vec<(usize, usize)> = out
                    .iter()
                    .enumerate()
                    .flat_map(|(a, &i)| out[a + 1..].iter().map(move |&j| (i, j)))
                    .collect();
                let sets = pairs
                    .iter()
                    .map(|&(i, j)| [c.inputs.as_slice(), &[i, j]].concat())
                    .collect();
                best(sets, limit(Some(c)), &|d| rule(c, d)).map(|(k, d)| {
                    let (i, j) = pairs[k];
                    (format!("{}+{}", names[i], names[j]), d)
                })
            }
            None => None,
        };
        let Some((name, d)) = step else { break };
        path.push((name, d.heldout_rms));
        chosen = Some(d);
        moves += 1;
        progress(path.len());
    }
    (chosen, path)
}

/// The set of `sets` with the lowest held-out RMS among those whose
/// structure `accept` takes, with its index, ties to the earlier set: the
/// choice of a sequential loop over the sets. Every set is judged alone,
/// each set's fits on one thread: first the least-squares structures of
/// all sets ([`Judge::rank`], in parallel), then their refinements
/// ([`Judge::best`]), taken up in the order of the sets' best
/// least-squares RMS, so that the likely choices are judged first and the
/// step's [`Bound`] falls early. The bound starts at `limit` (no set at or
/// above it is accepted) and falls to each accepted set's RMS; the order
/// and the bound change how much work is done, not the choice.
fn best_set(
    sets: Vec<Vec<usize>>,
    par: crate::par::Par,
    judge: &Judge,
    limit: f64,
    accept: &(dyn Fn(&Candidate) -> bool + Sync),
) -> Option<(usize, Candidate)> {
    let bound = Bound::new(limit);
    crate::par::here(par, || {
        let ranked = crate::par::map(&sets, 1, |_, set| judge.rank(set));
        let mut order: Vec<usize> = (0..sets.len()).collect();
        // Sets without an admissible least-squares structure last (a sum
        // of lags may still be found for them).
        let first = |k: &usize| ranked[*k].first().map_or(f64::INFINITY, |c| c.heldout_rms);
        order.sort_by(|a, b| first(a).total_cmp(&first(b)));
        crate::par::map_in_turn(&order, |_, &k| {
            let c = judge.best(&sets[k], &ranked[k], &bound)?;
            let taken = accept(&c);
            if taken {
                bound.lower(c.heldout_rms);
            }
            Some((k, c, taken))
        })
    })
    .into_iter()
    .flatten()
    .filter(|&(_, _, taken)| taken)
    .map(|(k, c, _)| (k, c))
    .min_by(|a, b| {
        a.1.heldout_rms
            .total_cmp(&b.1.heldout_rms)
            .then(a.0.cmp(&b.0))
    })
}
