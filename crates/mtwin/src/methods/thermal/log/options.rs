//! The options of the log fit, checked and bounded before any work.

use super::cross_validation::Candidate;
use crate::methods::thermal::ThermalError;
use serde::{Deserialize, Serialize};

/// Options of [`fit_log`](super::fit_log).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct LogFitOptions {
    /// Largest `na` and `nb` tried (`0..=max_order` each).
    pub max_order: usize,
    /// Most inputs one channel may use.
    pub max_inputs: usize,
    /// Held-out blocks of the blocked cross-validation the structures are
    /// chosen by: the training samples are cut into this many + 1
    /// contiguous blocks; each block after the first is held out in turn,
    /// the model fitted on all blocks before it and simulated from the
    /// start, and the held-out errors of all blocks pooled. `1`: a single
    /// block of [`LogFitOptions::holdout`] at the end instead.
    pub folds: usize,
    /// Further numbers of held-out blocks (each 1 to 50, none equal to
    /// `folds` or repeated): each channel's structure is also chosen and
    /// fitted with each of them, the models kept as the channel's members
    /// ([`ChannelModel::members`](super::ChannelModel::members)), and the channel is predicted by the
    /// per-sample median of all its models. Which inputs the held-out
    /// blocks favour on a short record depends on where the blocks are
    /// cut; the median of the choices made with several cuts does not rest
    /// on one of them. Empty by default (one model per channel); each
    /// entry costs a whole fit more.
    pub ensemble_folds: Vec<usize>,
    /// With `folds` = 1: fraction of the training samples, at their end,
    /// held out to choose by.
    pub holdout: f64,
    /// An input is added only if it lowers the held-out RMS by this fraction.
    pub min_gain: f64,
    /// Largest static gain (mm per unit of scaled input) as a multiple of the
    /// largest training drift magnitude.
    pub gain_bound: f64,
    /// Held-out RMS above this fraction of the held-out drift RMS is warned about.
    pub warn_ratio: f64,
    /// Also offer sums of first-order lags (one or two time constants
    /// shared by the channel's inputs, a gain per input and lag) as
    /// candidate structures beside the ARX order grid ([`best_lags`](super::lags::best_lags)). Off
    /// by default (the documented real-record figures are fitted without).
    pub lags: bool,
    /// When an input is worth adding (and keeping): see [`InputRule`].
    pub rule: InputRule,
    /// How the input sets are searched: see [`InputSearch`].
    pub search: InputSearch,
    /// Estimate each channel's start offset with its model (a constant
    /// from the second sample on, [`ChannelModel::start_offset_mm`](super::ChannelModel::start_offset_mm)): the
    /// drift is counted from the first period mean, a measurement with its
    /// noise, and that noise is otherwise an offset on every later sample
    /// that the inputs are made to explain. Off by default (the documented
    /// real-record figures are fitted without).
    pub start_offset: bool,
    /// Parallelism: the candidate inputs of a selection step are judged in
    /// parallel (each candidate's fits on one thread);
    /// [`Par::Seq`](crate::par::Par::Seq) on the calling thread only. Both
    /// give the same models (every candidate is computed alone and the best
    /// taken in input order).
    pub par: crate::par::Par,
}

impl Default for LogFitOptions {
    fn default() -> Self {
        LogFitOptions {
            max_order: 2,
            max_inputs: 6,
            folds: 3,
            ensemble_folds: Vec::new(),
            holdout: 1.0 / 3.0,
            min_gain: 0.02,
            gain_bound: 10.0,
            warn_ratio: 0.5,
            lags: false,
            rule: InputRule::Pooled,
            search: InputSearch::Forward,
            start_offset: false,
            par: crate::par::Par::rayon(0),
        }
    }
}

/// When the forward selection adds an input (and when the backward pass
/// keeps one): the structure with the input must lower the pooled held-out
/// RMS by at least [`LogFitOptions::min_gain`], and with
/// [`InputRule::EveryBlock`] also lower the simulation error in every
/// held-out block of the cross-validation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InputRule {
    /// The pooled held-out RMS alone.
    #[default]
    Pooled,
    /// The pooled held-out RMS, and the error in every held-out block: an
    /// input must help wherever it is judged, not in one block by a margin
    /// that outweighs the others (a slowly wandering sensor that matches
    /// one stretch of the residual by chance).
    EveryBlock,
    /// [`InputRule::EveryBlock`], and every input of the structure has a
    /// static gain of the same sign in every fold's fit: a sensor that acts
    /// on the machine heats or cools it one way, while a wandering sensor
    /// that matches stretches of the residual by chance is given whichever
    /// sign each fit span needs.
    SameSign,
}

impl std::str::FromStr for InputRule {
    type Err = String;
    fn from_str(s: &str) -> Result<InputRule, String> {
        match s.trim() {
            "pooled" => Ok(InputRule::Pooled),
            "every-block" => Ok(InputRule::EveryBlock),
            "same-sign" => Ok(InputRule::SameSign),
            other => Err(format!("`{other}`: say pooled, every-block or same-sign")),
        }
    }
}

impl InputRule {
    /// Does `new` (a structure with one input more, or with an input
    /// exchanged or a pair added by the exchange search) improve on `old`?
    pub(super) fn improves(self, old: &Candidate, new: &Candidate, min_gain: f64) -> bool {
        if new.heldout_rms >= (1.0 - min_gain) * old.heldout_rms {
            return false;
        }
        match self {
            InputRule::Pooled => true,
            InputRule::EveryBlock => every_block(old, new),
            InputRule::SameSign => every_block(old, new) && same_signs(&new.gains),
        }
    }
}

/// How a channel's input set is searched (each set judged by its held-out
/// RMS, [`InputRule`] deciding whether a change is worth it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InputSearch {
    /// Forward steps, then a backward pass.
    #[default]
    Forward,
    /// Forward steps and the backward pass, then moves while one lowers
    /// the held-out RMS: the best exchange of one chosen input for one not
    /// chosen or, when no exchange does, the best pair of inputs added
    /// together; the forward and backward passes run again after each move
    /// (at most `max_inputs` moves, and no more than there are inputs). It
    /// reaches sets that no single
    /// addition reaches from the forward path (two inputs that help only
    /// together).
    Exchange,
}

impl InputSearch {
    /// The default search (documents leave it out).
    pub fn is_forward(&self) -> bool {
        *self == InputSearch::Forward
    }
}

impl std::str::FromStr for InputSearch {
    type Err = String;
    fn from_str(s: &str) -> Result<InputSearch, String> {
        match s.trim() {
            "forward" => Ok(InputSearch::Forward),
            "exchange" => Ok(InputSearch::Exchange),
            other => Err(format!("`{other}`: say forward or exchange")),
        }
    }
}

/// Largest number of candidate fits one [`fit_log`](super::fit_log) call may run.
pub const MAX_LOG_FITS: usize = 1_000_000;

impl LogFitOptions {
    /// Checks the options and the number of candidate fits for `channels`
    /// and `inputs` (one fit per channel, selection step, remaining input and
    /// order pair: bounded before any work).
    pub fn validate(&self, channels: usize, inputs: usize) -> Result<usize, ThermalError> {
        if self.max_order as u64 > crate::limits::MAX_MODEL_ORDER {
            return Err(ThermalError::Options(format!(
                "the largest order {} exceeds the limit of {}",
                self.max_order,
                crate::limits::MAX_MODEL_ORDER
            )));
        }
        if !(self.holdout > 0.0 && self.holdout < 1.0) {
            return Err(ThermalError::Options(format!(
                "the held-out fraction must be between 0 and 1, not {}",
                self.holdout
            )));
        }
        for (i, k) in self.fold_counts().enumerate() {
            if k == 0 || k > 50 {
                return Err(ThermalError::Options(format!(
                    "the number of cross-validation blocks must be 1 to 50, not {k}"
                )));
            }
            if self.fold_counts().take(i).any(|j| j == k) {
                return Err(ThermalError::Options(format!(
                    "the number of cross-validation blocks {k} is given twice"
                )));
            }
        }
        if self.max_inputs == 0 {
            return Err(ThermalError::Options(
                "a channel needs at least one input".into(),
            ));
        }
        let orders = (self.max_order + 1) * (self.max_order + 1);
        let steps = self.max_inputs.min(inputs);
        // Forward steps try every remaining input; the backward pass at most
        // as many sets again. With exchanges, each of at most `max_inputs`
        // moves tries every exchange (steps x inputs) and every pair to add
        // (inputs x (inputs - 1) / 2), and the forward and backward passes
        // run again after it.
        let folds: usize = self.fold_counts().sum();
        let passes = 2 * steps * inputs;
        let sets = match self.search {
            InputSearch::Forward => passes,
            InputSearch::Exchange => {
                let moves = self.max_inputs.min(inputs);
                passes * (1 + moves)
                    + moves * (steps * inputs + inputs * inputs.saturating_sub(1) / 2)
            }
        };
        let fits = channels * sets * orders * folds;
        if fits > MAX_LOG_FITS {
            let search = match self.search {
                InputSearch::Forward => "",
                InputSearch::Exchange => ", the exchange search",
            };
            return Err(ThermalError::Options(format!(
                "{fits} candidate fits ({channels} channels x {sets} input sets{search} x {orders} orders \
                 x {folds} cross-validation blocks) exceed the limit of {MAX_LOG_FITS}: give fewer inputs, a smaller \
                 --max-inputs, --max-order or --folds"
            )));
        }
        Ok(fits)
    }

    /// The numbers of held-out blocks fitted with: `folds`, then
    /// `ensemble_folds`.
    pub fn fold_counts(&self) -> impl Iterator<Item = usize> + '_ {
        std::iter::once(self.folds).chain(self.ensemble_folds.iter().copied())
    }
}

/// Numbers of held-out blocks as written on a command line: one number,
/// a list (`2,4,6`), a range (`2-6`) or both (`3,5-6`); the first is
/// [`LogFitOptions::folds`], the rest [`LogFitOptions::ensemble_folds`].
/// Never empty; the range and repetition checks are
/// [`LogFitOptions::validate`]'s, except that a range must ascend.
pub fn parse_fold_counts(s: &str) -> Result<Vec<usize>, String> {
    let number = |t: &str| {
        t.trim().parse::<usize>().map_err(|_| {
            format!(
                "`{}`: give whole numbers of held-out blocks, as 3, 2,4,6 or 2-6",
                t.trim()
            )
        })
    };
    let mut out = Vec::new();
    for part in s.split(',') {
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (number(a)?, number(b)?);
                if a > b {
                    return Err(format!("`{}`: a range goes up, as 2-6", part.trim()));
                }
                if b - a >= 50 {
                    return Err(format!("`{}`: at most 50 numbers of blocks", part.trim()));
                }
                out.extend(a..=b);
            }
            None => out.push(number(part)?),
        }
    }
    Ok(out)
}

/// Is the simulation error of `new` below that of `old` in every held-out block?
fn every_block(old: &Candidate, new: &Candidate) -> bool {
    old.blocks.iter().zip(&new.blocks).all(|(o, n)| n < o)
}

/// Per-fold static gains (fold × input): does every input's gain keep one
/// strict sign over all folds?
pub(super) fn same_signs(gains: &[Vec<f64>]) -> bool {
    let inputs = gains.first().map_or(0, Vec::len);
    (0..inputs).all(|i| gains.iter().all(|g| g[i] > 0.0) || gains.iter().all(|g| g[i] < 0.0))
}
