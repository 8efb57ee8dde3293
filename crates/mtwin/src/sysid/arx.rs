use nalgebra::{Complex, DMatrix};

use super::SysidError;

/// Orders of one exogenous input: `nb + 1` coefficients `b_0..b_nb`, applied
/// after a pure delay of `nk` samples (`b_j` multiplies `u(k−j−nk)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct InputOrder {
    /// Highest `b` index (the input has `nb + 1` coefficients).
    pub nb: usize,
    /// Input delay, samples.
    pub nk: usize,
}

/// The structure of an ARX model: `na` autoregressive coefficients and the
/// orders of every input.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct ArxOrders {
    /// Number of `a` coefficients after `a_0 = 1`.
    pub na: usize,
    /// One entry per input.
    pub inputs: Vec<InputOrder>,
}

impl ArxOrders {
    /// Number of free parameters `d = na + Σ (nb + 1)`.
    pub fn n_params(&self) -> usize {
        self.na + self.inputs.iter().map(|o| o.nb + 1).sum::<usize>()
    }

    /// The largest lag any regressor reaches back (samples).
    pub fn max_lag(&self) -> usize {
        self.inputs
            .iter()
            .map(|o| o.nb + o.nk)
            .fold(self.na, usize::max)
    }

    /// `{"na": …, "nb": […], "nk": […]}`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "na": self.na,
            "nb": self.inputs.iter().map(|o| o.nb).collect::<Vec<_>>(),
            "nk": self.inputs.iter().map(|o| o.nk).collect::<Vec<_>>(),
        })
    }

    /// True when no input acts on the output at the same sample (every `nk ≥ 1`).
    pub fn is_strictly_proper(&self) -> bool {
        self.inputs.iter().all(|o| o.nk >= 1)
    }
}

impl std::fmt::Display for ArxOrders {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "na={}", self.na)?;
        for (i, o) in self.inputs.iter().enumerate() {
            if self.inputs.len() == 1 {
                write!(f, " nb={} nk={}", o.nb, o.nk)?;
            } else {
                write!(f, " nb{i}={} nk{i}={}", o.nb, o.nk)?;
            }
        }
        Ok(())
    }
}

/// Where the poles of the model lie.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stability {
    /// Every pole strictly inside the unit circle.
    Stable {
        /// Largest pole modulus (< 1).
        spectral_radius: f64,
    },
    /// A pole on or outside the unit circle: simulations drift off or grow
    /// without bound.
    Unstable {
        /// Largest pole modulus (≥ 1 − 1e-9).
        spectral_radius: f64,
    },
}

impl Stability {
    /// True for [`Stability::Stable`].
    pub fn is_stable(&self) -> bool {
        matches!(self, Stability::Stable { .. })
    }

    /// Largest pole modulus.
    pub fn spectral_radius(&self) -> f64 {
        match *self {
            Stability::Stable { spectral_radius } | Stability::Unstable { spectral_radius } => {
                spectral_radius
            }
        }
    }

    /// A plain sentence for an unstable model, `None` for a stable one.
    pub fn warning(&self) -> Option<String> {
        match *self {
            Stability::Stable { .. } => None,
            Stability::Unstable { spectral_radius } => Some(format!(
                "the model is not stable: a pole has modulus {} (>= 1), so a \
                 simulation does not settle and long predictions are meaningless",
                crate::limits::fmt_message_fixed(spectral_radius, 6)
            )),
        }
    }
}

/// A multi-input ARX model
/// `y(k) = −Σ_{i=1..na} a_i·y(k−i) + Σ_u Σ_{j=0..nb_u} b_{u,j}·u(k−j−nk_u)`.
///
/// Invariants (checked by [`Arx::new`]): `a[0] == 1`, every input has at least
/// one `b` coefficient, every coefficient is finite.
#[derive(Debug, Clone, PartialEq)]
pub struct Arx {
    a: Vec<f64>,
    b: Vec<Vec<f64>>,
    nk: Vec<usize>,
}

impl Arx {
    /// A model from `a = [1, a_1, …, a_na]` and, per input, `(b_0..b_nb, nk)`.
    pub fn new(a: Vec<f64>, inputs: Vec<(Vec<f64>, usize)>) -> Result<Arx, SysidError> {
        let a0 = a.first().copied().unwrap_or(f64::NAN);
        if a0 != 1.0 {
            return Err(SysidError::LeadingA(a0));
        }
        if a.iter().any(|v| !v.is_finite()) {
            return Err(SysidError::NotFinite {
                what: "the `a` polynomial".into(),
            });
        }
        let mut b = Vec::with_capacity(inputs.len());
        let mut nk = Vec::with_capacity(inputs.len());
        for (i, (bi, ki)) in inputs.into_iter().enumerate() {
            if bi.is_empty() {
                return Err(SysidError::EmptyB { input: i });
            }
            if bi.iter().any(|v| !v.is_finite()) {
                return Err(SysidError::NotFinite {
                    what: format!("the `b` coefficients of input {i}"),
                });
            }
            b.push(bi);
            nk.push(ki);
        }
        Ok(Arx { a, b, nk })
    }

    /// The model of structure `orders` with parameters
    /// `θ = [a_1..a_na, b_{0,0}..b_{0,nb_0}, b_{1,0}..]` (the order [`Arx::params`] uses).
    ///
    /// # Panics
    /// If `theta.len() != orders.n_params()` (a programming error).
    pub fn from_params(orders: &ArxOrders, theta: &[f64]) -> Arx {
        assert_eq!(
            theta.len(),
            orders.n_params(),
            "parameter vector does not match the orders"
        );
        let mut a = Vec::with_capacity(orders.na + 1);
        a.push(1.0);
        a.extend_from_slice(&theta[..orders.na]);
        let mut at = orders.na;
        let mut b = Vec::with_capacity(orders.inputs.len());
        for o in &orders.inputs {
            b.push(theta[at..at + o.nb + 1].to_vec());
            at += o.nb + 1;
        }
        Arx {
            a,
            b,
            nk: orders.inputs.iter().map(|o| o.nk).collect(),
        }
    }

    /// The free parameters `θ = [a_1..a_na, b_{0,·}, b_{1,·}, …]`.
    pub fn params(&self) -> Vec<f64> {
        let mut t = self.a[1..].to_vec();
        for bi in &self.b {
            t.extend_from_slice(bi);
        }
        t
    }

    /// The structure of this model.
    pub fn orders(&self) -> ArxOrders {
        ArxOrders {
            na: self.a.len() - 1,
            inputs: self
                .b
                .iter()
                .zip(&self.nk)
                .map(|(b, &nk)| InputOrder {
                    nb: b.len() - 1,
                    nk,
                })
                .collect(),
        }
    }

    /// `[1, a_1, …, a_na]`.
    pub fn a(&self) -> &[f64] {
        &self.a
    }

    /// `b_0..b_nb` of input `input`.
    pub fn b(&self, input: usize) -> &[f64] {
        &self.b[input]
    }

    /// Delay of input `input`, samples.
    pub fn nk(&self, input: usize) -> usize {
        self.nk[input]
    }

    /// Number of exogenous inputs.
    pub fn n_inputs(&self) -> usize {
        self.b.len()
    }

    /// The same model with every input delay reduced by one sample, i.e. the
    /// model of `w(k) = y(k+1)`. `None` when some input has `nk = 0`.
    pub fn advanced(&self) -> Option<Arx> {
        if self.nk.contains(&0) {
            return None;
        }
        Some(Arx {
            a: self.a.clone(),
            b: self.b.clone(),
            nk: self.nk.iter().map(|k| k - 1).collect(),
        })
    }

    fn check_inputs(&self, len: usize, inputs: &[&[f64]]) -> Result<(), SysidError> {
        if inputs.len() != self.b.len() {
            return Err(SysidError::InputCount {
                expected: self.b.len(),
                found: inputs.len(),
            });
        }
        for (i, u) in inputs.iter().enumerate() {
            if u.len() != len {
                return Err(SysidError::LengthMismatch {
                    input: i,
                    expected: len,
                    found: u.len(),
                });
            }
        }
        Ok(())
    }

    /// Free-run simulation from rest: outputs and inputs are zero before
    /// sample 0, and only the inputs drive the model. `inputs[u][k]` is input
    /// `u` at sample `k`; all inputs must have the same length.
    pub fn simulate(&self, inputs: &[&[f64]]) -> Result<Vec<f64>, SysidError> {
        let len = inputs.first().map_or(0, |u| u.len());
        self.check_inputs(len, inputs)?;
        let mut stepper = self.stepper();
        let mut sample = vec![0.0; inputs.len()];
        Ok((0..len)
            .map(|k| {
                for (s, u) in sample.iter_mut().zip(inputs) {
                    *s = u[k];
                }
                stepper.push(&sample)
            })
            .collect())
    }

    /// One-step-ahead prediction `ŷ(k)` from the measured outputs `y(k−i)` and
    /// the inputs; values before sample 0 are taken as zero (a run from rest).
    pub fn predict(&self, output: &[f64], inputs: &[&[f64]]) -> Result<Vec<f64>, SysidError> {
        self.check_inputs(output.len(), inputs)?;
        Ok((0..output.len())
            .map(|k| self.equation(k, output, inputs))
            .collect())
    }

    /// The right-hand side of the model equation at sample `k` with the given
    /// past outputs; indices before 0 count as zero.
    pub(crate) fn equation(&self, k: usize, output: &[f64], inputs: &[&[f64]]) -> f64 {
        let mut acc = 0.0;
        for (i, &ai) in self.a.iter().enumerate().skip(1) {
            if let Some(t) = k.checked_sub(i) {
                acc -= ai * output[t];
            }
        }
        for ((bu, &nk), u) in self.b.iter().zip(&self.nk).zip(inputs) {
            for (j, &bj) in bu.iter().enumerate() {
                if let Some(t) = k.checked_sub(j + nk) {
                    acc += bj * u[t];
                }
            }
        }
        acc
    }

    /// Roots of `z^na + a_1 z^(na−1) + … + a_na` (eigenvalues of the companion matrix).
    pub fn poles(&self) -> Vec<Complex<f64>> {
        polynomial_roots(&self.a)
    }

    /// Whether every pole lies strictly inside the unit circle (margin 1e-9).
    pub fn stability(&self) -> Stability {
        let spectral_radius = self.poles().iter().map(|p| p.norm()).fold(0.0, f64::max);
        if spectral_radius < 1.0 - 1e-9 {
            Stability::Stable { spectral_radius }
        } else {
            Stability::Unstable { spectral_radius }
        }
    }

    /// Static gain from input `input` to the output, `B(1)/A(1)` (infinite
    /// when `A(1) = 0`).
    pub fn dc_gain(&self, input: usize) -> f64 {
        self.b[input].iter().sum::<f64>() / self.a.iter().sum::<f64>()
    }

    /// A streaming simulator from rest: push one input sample, get one output.
    pub fn stepper(&self) -> ArxStepper {
        ArxStepper {
            y_past: History::new(self.a.len() - 1),
            u_past: self
                .b
                .iter()
                .zip(&self.nk)
                .map(|(b, &nk)| History::new(b.len() + nk))
                .collect(),
            model: self.clone(),
        }
    }
}

/// The roots of the monic polynomial `z^n + c_1 z^(n−1) + … + c_n` given as
/// `[1, c_1, …, c_n]`.
pub(crate) fn polynomial_roots(coeffs: &[f64]) -> Vec<Complex<f64>> {
    let n = coeffs.len().saturating_sub(1);
    if n == 0 {
        return Vec::new();
    }
    let mut m = DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        m[(0, j)] = -coeffs[j + 1];
    }
    for i in 1..n {
        m[(i, i - 1)] = 1.0;
    }
    m.complex_eigenvalues().iter().copied().collect()
}

/// Streaming free-run simulation of an [`Arx`] model from rest: memory is
/// bounded by the model orders, so trajectories of any length can be run.
#[derive(Debug, Clone)]
pub struct ArxStepper {
    model: Arx,
    /// `y(k−1), y(k−2), …` newest first.
    y_past: History,
    /// Per input `u(k), u(k−1), …` newest first (after the push of sample k).
    u_past: Vec<History>,
}

/// The last `len` values of a signal, newest first, initially zero. A mirrored
/// ring buffer (every value stored at `i` and `i + len`), so the window is always
/// one contiguous slice and a push moves nothing.
#[derive(Debug, Clone)]
struct History {
    buf: Vec<f64>,
    /// Index of the newest value.
    head: usize,
    len: usize,
}

impl History {
    fn new(len: usize) -> History {
        History {
            buf: vec![0.0; 2 * len],
            head: 0,
            len,
        }
    }

    /// Make `v` the newest value, dropping the oldest.
    #[inline]
    fn push(&mut self, v: f64) {
        if self.len == 0 {
            return;
        }
        self.head = if self.head == 0 {
            self.len - 1
        } else {
            self.head - 1
        };
        self.buf[self.head] = v;
        self.buf[self.head + self.len] = v;
    }

    /// The values, newest first.
    #[inline]
    fn values(&self) -> &[f64] {
        &self.buf[self.head..self.head + self.len]
    }
}

impl ArxStepper {
    /// Feed the inputs of the next sample (`inputs[u]`, one value per input,
    /// in the model's input order) and return the output at that sample.
    ///
    /// # Panics
    /// If `inputs.len()` differs from the model's number of inputs.
    pub fn push(&mut self, inputs: &[f64]) -> f64 {
        assert_eq!(
            inputs.len(),
            self.u_past.len(),
            "one value per model input is needed"
        );
        for (hist, &u) in self.u_past.iter_mut().zip(inputs) {
            hist.push(u);
        }
        let mut y = 0.0;
        for (ai, yp) in self.model.a[1..].iter().zip(self.y_past.values()) {
            y -= ai * yp;
        }
        for ((bu, &nk), hist) in self.model.b.iter().zip(&self.model.nk).zip(&self.u_past) {
            for (bj, u) in bu.iter().zip(&hist.values()[nk..]) {
                y += bj * u;
            }
        }
        self.y_past.push(y);
        y
    }

    /// The model being run.
    pub fn model(&self) -> &Arx {
        &self.model
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> Arx {
        Arx::new(
            vec![1.0, -1.5, 0.7],
            vec![(vec![0.5, 0.25], 1), (vec![-0.3], 0)],
        )
        .unwrap()
    }

    #[test]
    fn invariants_are_checked() {
        assert_eq!(
            Arx::new(vec![0.9], vec![(vec![1.0], 0)]),
            Err(SysidError::LeadingA(0.9))
        );
        assert!(matches!(
            Arx::new(vec![1.0], vec![(vec![], 0)]),
            Err(SysidError::EmptyB { input: 0 })
        ));
        assert!(Arx::new(vec![1.0, f64::NAN], vec![(vec![1.0], 0)]).is_err());
    }

    #[test]
    fn params_round_trip() {
        let m = model();
        let o = m.orders();
        assert_eq!(o.n_params(), 2 + 2 + 1);
        assert_eq!(o.max_lag(), 2);
        assert_eq!(Arx::from_params(&o, &m.params()), m);
    }

    #[test]
    fn impulse_response_matches_hand_recursion() {
        // y(k) = 1.5 y(k-1) - 0.7 y(k-2) + 0.5 u1(k-1) + 0.25 u1(k-2) - 0.3 u2(k)
        let m = model();
        let u1 = [1.0, 0.0, 0.0, 0.0, 0.0];
        let u2 = [0.0, 0.0, 2.0, 0.0, 0.0];
        let y = m.simulate(&[&u1, &u2]).unwrap();
        let y0 = 0.0;
        let y1 = 0.5;
        let y2 = 1.5 * y1 + 0.25 - 0.6;
        let y3 = 1.5 * y2 - 0.7 * y1;
        let y4 = 1.5 * y3 - 0.7 * y2;
        for (got, want) in y.iter().zip([y0, y1, y2, y3, y4]) {
            assert!((got - want).abs() < 1e-15, "{got} vs {want}");
        }
        // One-step prediction with the simulated output as measurement is the simulation.
        let p = m.predict(&y, &[&u1, &u2]).unwrap();
        for (a, b) in p.iter().zip(&y) {
            assert!((a - b).abs() < 1e-15);
        }
    }

    #[test]
    fn poles_of_a_known_polynomial() {
        // (z - 0.5)(z - 0.8) = z² - 1.3 z + 0.4
        let m = Arx::new(vec![1.0, -1.3, 0.4], vec![(vec![1.0], 1)]).unwrap();
        let mut p: Vec<f64> = m.poles().iter().map(|c| c.re).collect();
        p.sort_by(f64::total_cmp);
        assert!((p[0] - 0.5).abs() < 1e-12 && (p[1] - 0.8).abs() < 1e-12);
        assert!(m.stability().is_stable());
        // z² - 2 r cosφ z + r², r = 1.1: unstable complex pair.
        let r: f64 = 1.1;
        let m = Arx::new(
            vec![1.0, -2.0 * r * 0.3f64.cos(), r * r],
            vec![(vec![1.0], 1)],
        )
        .unwrap();
        let s = m.stability();
        assert!(!s.is_stable());
        assert!((s.spectral_radius() - r).abs() < 1e-12);
        assert!(s.warning().is_some());
    }

    #[test]
    fn dc_gain_is_the_settled_step_response() {
        let m = model();
        let n = 400;
        let y = m.simulate(&[&vec![1.0; n], &vec![0.0; n]]).unwrap();
        assert!((y[n - 1] - m.dc_gain(0)).abs() < 1e-9);
        assert!((m.dc_gain(0) - 0.75 / 0.2).abs() < 1e-12);
    }

    #[test]
    fn advanced_model_is_shifted_output() {
        let m = Arx::new(vec![1.0, -0.9], vec![(vec![0.1, 0.05], 2)]).unwrap();
        let u: Vec<f64> = (0..20).map(|k| (k as f64 * 0.7).sin()).collect();
        let y = m.simulate(&[&u]).unwrap();
        let w = m.advanced().unwrap().simulate(&[&u]).unwrap();
        for k in 0..19 {
            assert!((w[k] - y[k + 1]).abs() < 1e-15);
        }
        assert!(model().advanced().is_none());
    }

    #[test]
    fn wrong_input_shapes_are_errors() {
        let m = model();
        assert!(matches!(
            m.simulate(&[&[1.0]]),
            Err(SysidError::InputCount {
                expected: 2,
                found: 1
            })
        ));
        assert!(matches!(
            m.simulate(&[&[1.0, 2.0], &[1.0]]),
            Err(SysidError::LengthMismatch {
                input: 1,
                expected: 2,
                found: 1
            })
        ));
    }
}
