use thiserror::Error;

/// Why an ARX model could not be built, fitted or run.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SysidError {
    /// The `a` polynomial must start with `a_0 = 1`.
    #[error("the first `a` coefficient must be 1 (a_0 = 1), not {}", crate::limits::fmt_message_number(*.0))]
    LeadingA(f64),
    /// An input has no `b` coefficient.
    #[error("input {input} has no `b` coefficient (at least b_0 is needed)")]
    EmptyB {
        /// 0-based input index.
        input: usize,
    },
    /// A coefficient or a data value is NaN or infinite.
    #[error("{what} holds a value that is not a finite number")]
    NotFinite {
        /// What holds it, in words.
        what: String,
    },
    /// The sample period must be positive.
    #[error("the sample period must be positive and finite, not {}", crate::limits::fmt_message_number(*.0))]
    BadPeriod(f64),
    /// A run or a call gives the wrong number of input signals.
    #[error("the model has {expected} input(s) but {found} were given")]
    InputCount {
        /// Inputs of the model.
        expected: usize,
        /// Inputs given.
        found: usize,
    },
    /// An input signal is not as long as the output.
    #[error("input {input} has {found} samples but the output has {expected}")]
    LengthMismatch {
        /// 0-based input index.
        input: usize,
        /// Samples of the output.
        expected: usize,
        /// Samples of the input.
        found: usize,
    },
    /// Fewer regression rows than parameters (plus one, to estimate the noise).
    #[error(
        "{rows} usable samples cannot determine {params} parameters (more than {params} are needed)"
    )]
    TooFewSamples {
        /// Regression rows available.
        rows: usize,
        /// Parameters of the model.
        params: usize,
    },
    /// The regressor columns are (numerically) linearly dependent.
    #[error(
        "the data do not determine all {params} parameters (the regressors are linearly dependent, \
         reciprocal condition {rcond:.1e}): lower the orders or excite the system more"
    )]
    RankDeficient {
        /// Parameters of the model.
        params: usize,
        /// Ratio of the smallest to the largest diagonal of R (columns normalised).
        rcond: f64,
    },
    /// A grid of orders with nothing to try, or where every order failed.
    #[error("no model of the order grid could be fitted: {0}")]
    NoOrderFits(String),
    /// A property that needs a nonzero static gain.
    #[error("{0}")]
    Degenerate(String),
    /// An option outside its domain (an order of 0, ...); the text names it.
    #[error("{0}")]
    BadOption(String),
    /// A size beyond the bounds of [`crate::limits`].
    #[error("{0}")]
    Limit(#[from] crate::limits::LimitError),
}
