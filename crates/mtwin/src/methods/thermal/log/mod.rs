//! Wide machine logs: one row per time stamp, a time column (`t_s` or
//! `t_min`), several drift channels (each with its unit and the axis it
//! acts on), and input columns (spindle speed, temperatures). Such a log is
//! averaged onto the model's sample grid, and one ARX model per channel is
//! chosen by what it predicts: its simulation error from cold on a held-out
//! block at the end of the training time, never its one-step error.
//!
//! Conventions:
//!
//! * time since the log's first row (a log whose first time is not 0 is
//!   read from its first row, with a note), min;
//! * sample `k` is the mean over `[kT, (k+1)T)` of every column (missing
//!   cells, empty or `NaN`, are left out of the mean with a note; a bin
//!   without any value of a column, or a time gap longer than the period, is
//!   an error at its line);
//! * a drift channel is its change since the first sample, converted to mm;
//!   a temperature input (`rise`) is its change since the first sample, K;
//!   other inputs are used as they are (speed in rev/min);
//! * every input is divided by its largest training magnitude (stored with
//!   the model), acts from the next sample on (`nk = 1`), and the model
//!   starts at rest (`e = 0`, inputs 0 before the first sample).
//!
//! **Selection.** Inputs are chosen by forward selection: starting with no
//! input, the input whose addition gives the lowest held-out simulation
//! RMS is added, as long as it lowers that RMS by at least
//! [`LogFitOptions::min_gain`]; for every input set the orders `na ∈
//! 0..=max`, `nb ∈ 0..=max` (one `nb` for all inputs) are tried. The work
//! grows with (inputs × steps × orders), never with a product over inputs.
//! Unstable candidates and candidates whose static gain from an input
//! exceeds [`LogFitOptions::gain_bound`] times the largest training drift
//! (per unit of the scaled input) are discarded. The chosen structure is
//! refitted on all training samples and refined by output-error
//! minimisation (kept only when it lowers the simulation error and stays
//! stable). After the forward pass, a backward pass removes any input
//! whose removal raises the held-out RMS by less than `min_gain` (one picked
//! early and made redundant by a later one). With [`InputSearch::Exchange`]
//! the search goes on: one chosen input exchanged for one not chosen, or a
//! pair of inputs added together when no exchange helps (two inputs that
//! explain the drift only together), then the forward and backward passes
//! again; the work grows with the square of the inputs. With
//! [`InputRule::EveryBlock`] an input must also lower the simulation error
//! in every held-out block to be added (and to be kept by the backward
//! pass): a slowly wandering sensor that matches one block's residual by
//! chance can lower the pooled figure while raising the other blocks'.
//! With [`InputRule::SameSign`] moreover every input of the structure must
//! have a static gain of one sign in every fold's fit: a wandering sensor
//! that lowers every block's error by matching each fit span's residual is
//! given whichever sign that span needs.
//!
//! **Work saved without changing a choice.** In each step the input sets'
//! least-squares structures are judged first, then their output-error
//! refinements, taken up in the order of the sets' least-squares RMS. The
//! blocks' squared errors only add up, so a refinement stops at the first
//! block after which its pooled RMS is already above a bound it must beat:
//! the step's acceptance limit (`1 − min_gain` times the current RMS), the
//! RMS of a set already judged and accepted in the step, or the better
//! structure already found for the same set. Such a refinement could not
//! have been chosen, so the fit is the one the full judgement of every set
//! gives, to the bit (test
//! `refinements_cut_short_by_the_steps_bound_change_no_choice`), for about
//! half the work with several blocks.
//!
//! **Several cuts** ([`LogFitOptions::ensemble_folds`], none by default).
//! On a short record which inputs the held-out blocks favour depends on
//! where the blocks are cut. With further numbers of blocks each channel is
//! chosen and fitted once per number; the models are kept together
//! ([`ChannelModel::members`]) and the channel is predicted by the
//! per-sample median of their simulations ([`ChannelModel::simulate`]), so
//! one cut whose sensors extrapolate badly does not decide. A fit on other
//! candidate inputs (the temperatures as given beside those over an ambient
//! sensor) joins the same way ([`LogModel::join`]).
//!
//! **Start offset** ([`LogFitOptions::start_offset`], off by default). A
//! drift channel is counted from its first period mean, one measurement
//! with its noise; that noise is an offset on every later sample, which a
//! model from rest can only explain through its inputs (a slowly wandering
//! sensor, or biased gains). With the option each channel's model also
//! estimates that offset: for a sum of lags as one more least-squares
//! regressor (0 at the first sample, 1 after it), for an ARX structure as
//! the mean simulation residual after the first sample (each held-out
//! block is judged with the offset of its fold's fit samples). The
//! measured channel is then predicted as the first period mean plus the
//! offset plus the simulated drift ([`predict_log`]); the drift since the
//! cold start ([`LogModel::simulate`], what a compensation corrects) holds
//! no offset.
//!
//! **Sums of first-order lags** ([`LogFitOptions::lags`], off by default).
//! Each channel may also be modelled as `Σ_i Σ_τ g_{i,τ}·lag_τ(u_i)`: every
//! input through one or two first-order lags whose time constants `τ` the
//! channel's inputs share, a gain per input and lag (stored as the
//! equivalent ARX model, `na` = number of lags, so the model file is the
//! same). Why: on a simulated truth with time constants of 20 and 180
//! periods, the ARX least-squares estimate started from the equation error
//! lands the output-error refinement in a local minimum (one pole near 1,
//! one near 0) in five of six noise draws, *even with the true inputs
//! given*: its held-out error was 2.0–4.6 times the truth's own. With the
//! time constants fixed, the simulated output is linear in the gains, so
//! least squares on the lagged inputs *is* the output-error fit (convex,
//! from rest as the model is used), and each held-out block's simulation
//! error follows exactly from Gram matrices over sample prefixes (cheap).
//! The time constants are taken from a grid (5, 15, 45, 135, 405 min,
//! singles and pairs), the best refined by a coordinate search on the
//! held-out error; after selection the chosen structure's time constants
//! are refined once more on all training samples (their simulation error),
//! its gains fitted there. A lag structure competes with the ARX orders of
//! the same input set by the same held-out RMS.
//!
//! **Where things are.** `spec.rs`: the channel and input specifications
//! (`ch1_um:Z`, `t5_c:over=t1_c`); `ambient.rs`: temperatures over an
//! ambient sensor and its choice; `read.rs`: the log read and averaged onto
//! the grid; `options.rs`: the fit's options and rules; `cross_validation.rs`:
//! the folds and the held-out simulation error; `orders.rs`: the best ARX
//! orders of an input set; `lags.rs`: the sums of first-order lags;
//! `select.rs`: the input search; `fit.rs`: the fit of every channel (once
//! per cut); `model.rs`: the fitted model, its median of members and its
//! model file; `predict.rs`: prediction and scores.

mod ambient;
mod cross_validation;
mod fit;
mod lags;
mod model;
mod options;
mod orders;
mod predict;
mod read;
mod select;
mod spec;
#[cfg(test)]
mod tests;

pub use ambient::{AmbientChoice, inputs_over_ambient, least_correlated_rise};
pub use fit::{LogFit, fit_log, fit_log_with};
pub use model::{ChannelMember, ChannelModel, LogInput, LogModel};
pub use options::{InputRule, InputSearch, LogFitOptions, MAX_LOG_FITS, parse_fold_counts};
pub use predict::{ChannelScore, at_time, predict_log, predict_log_range, score};
pub use read::{LogData, read_log};
pub use spec::{Axis, ChannelSpec, InputSpec, LengthUnit};
