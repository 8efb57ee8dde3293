//! Error functions (docs/machine-model.md): how an error component varies with its axis position.

/// The value of one error component as a function of its axis position `q`
/// (mm for a linear axis, degree for a rotary one). Values are mm for translations and
/// rad for rotations.
#[derive(Debug, Clone, PartialEq)]
pub enum ErrorFunction {
    /// A constant.
    Constant(f64),
    /// Power polynomial `Σ c_k q^k`.
    Poly(Vec<f64>),
    /// Chebyshev series of the first kind `Σ c_k T_k(u)`, `u = (2q − lo − hi)/(hi − lo)` over the
    /// axis travel `[lo, hi]`.
    Cheb(Vec<f64>),
    /// Piecewise linear through `(q_k, e_k)`, `q` strictly increasing, held constant outside.
    Table {
        /// Axis positions, strictly increasing.
        q: Vec<f64>,
        /// Error values at those positions.
        e: Vec<f64>,
    },
}

/// The shape of an error function without its values: what a fit asks for.
#[derive(Debug, Clone, PartialEq)]
pub enum Form {
    /// One constant.
    Constant,
    /// Power polynomial of the given degree (degree + 1 coefficients).
    Poly(usize),
    /// Chebyshev series of the given degree (degree + 1 coefficients).
    Cheb(usize),
    /// Table with values at the given positions.
    Table(Vec<f64>),
}

impl Form {
    /// Number of coefficients of this form.
    pub fn n_coeffs(&self) -> usize {
        match self {
            Form::Constant => 1,
            Form::Poly(d) | Form::Cheb(d) => d + 1,
            Form::Table(q) => q.len(),
        }
    }

    /// The zero function of this form.
    pub fn zero(&self) -> ErrorFunction {
        match self {
            Form::Constant => ErrorFunction::Constant(0.0),
            Form::Poly(d) => ErrorFunction::Poly(vec![0.0; d + 1]),
            Form::Cheb(d) => ErrorFunction::Cheb(vec![0.0; d + 1]),
            Form::Table(q) => ErrorFunction::Table {
                q: q.clone(),
                e: vec![0.0; q.len()],
            },
        }
    }

    /// Short text of the form as used in fit specifications (`cheb3`, `poly2`, `const`).
    pub fn label(&self) -> String {
        match self {
            Form::Constant => "const".into(),
            Form::Poly(d) => format!("poly{d}"),
            Form::Cheb(d) => format!("cheb{d}"),
            Form::Table(q) => format!("table{}", q.len()),
        }
    }

    /// Name of coefficient `k` (`c0`, `c1`, … or `q=…` for tables).
    pub fn coeff_label(&self, k: usize) -> String {
        match self {
            Form::Constant => String::new(),
            Form::Poly(_) | Form::Cheb(_) => format!("c{k}"),
            Form::Table(q) => format!("q{}", crate::io::fmt_f64(q[k])),
        }
    }
}

/// Normalised Chebyshev argument for travel `[lo, hi]`.
#[inline]
fn cheb_u(q: f64, travel: [f64; 2]) -> f64 {
    (2.0 * q - travel[0] - travel[1]) / (travel[1] - travel[0])
}

impl ErrorFunction {
    /// The form of this function.
    pub fn form(&self) -> Form {
        match self {
            ErrorFunction::Constant(_) => Form::Constant,
            ErrorFunction::Poly(c) => Form::Poly(c.len().saturating_sub(1)),
            ErrorFunction::Cheb(c) => Form::Cheb(c.len().saturating_sub(1)),
            ErrorFunction::Table { q, .. } => Form::Table(q.clone()),
        }
    }

    /// The coefficients (the constant, the polynomial/Chebyshev coefficients, the table values).
    pub fn coeffs(&self) -> &[f64] {
        match self {
            ErrorFunction::Constant(c) => std::slice::from_ref(c),
            ErrorFunction::Poly(c) | ErrorFunction::Cheb(c) => c,
            ErrorFunction::Table { e, .. } => e,
        }
    }

    /// Mutable coefficients, in the order of [`ErrorFunction::coeffs`].
    pub fn coeffs_mut(&mut self) -> &mut [f64] {
        match self {
            ErrorFunction::Constant(c) => std::slice::from_mut(c),
            ErrorFunction::Poly(c) | ErrorFunction::Cheb(c) => c,
            ErrorFunction::Table { e, .. } => e,
        }
    }

    /// True when every coefficient is exactly zero.
    pub fn is_zero(&self) -> bool {
        self.coeffs().iter().all(|&c| c == 0.0)
    }

    /// Value at axis position `q`; `travel` is the axis travel (used by `cheb`).
    #[inline]
    pub fn eval(&self, q: f64, travel: [f64; 2]) -> f64 {
        match self {
            ErrorFunction::Constant(c) => *c,
            ErrorFunction::Poly(c) => c.iter().rev().fold(0.0, |acc, &ck| acc * q + ck),
            ErrorFunction::Cheb(c) => clenshaw(c, cheb_u(q, travel)),
            ErrorFunction::Table { q: qs, e } => table_eval(qs, e, q),
        }
    }

    /// Derivative with respect to the axis position, d value / d q (per mm or per degree).
    pub fn deriv(&self, q: f64, travel: [f64; 2]) -> f64 {
        match self {
            ErrorFunction::Constant(_) => 0.0,
            ErrorFunction::Poly(c) => {
                let mut acc = 0.0;
                for (k, &ck) in c.iter().enumerate().skip(1).rev() {
                    acc = acc * q + k as f64 * ck;
                }
                acc
            }
            ErrorFunction::Cheb(c) => {
                let u = cheb_u(q, travel);
                let dudq = 2.0 / (travel[1] - travel[0]);
                // d T_k / du = k U_{k-1}(u); U by its recurrence.
                let (mut u_prev, mut u_cur) = (0.0, 1.0); // U_{-1}, U_0
                let mut acc = 0.0;
                for (k, &ck) in c.iter().enumerate().skip(1) {
                    acc += ck * k as f64 * u_cur;
                    let next = 2.0 * u * u_cur - u_prev;
                    u_prev = u_cur;
                    u_cur = next;
                }
                acc * dudq
            }
            ErrorFunction::Table { q: qs, e } => {
                let n = qs.len();
                if n < 2 || q <= qs[0] || q >= qs[n - 1] {
                    return 0.0;
                }
                let k = qs.partition_point(|&x| x <= q).clamp(1, n - 1);
                (e[k] - e[k - 1]) / (qs[k] - qs[k - 1])
            }
        }
    }

    /// The derivative of the value at `q` with respect to every coefficient, written to
    /// `out` (length = number of coefficients). The value is linear in its coefficients, so
    /// these are the basis functions at `q`.
    pub fn basis(&self, q: f64, travel: [f64; 2], out: &mut [f64]) {
        self.form().basis(q, travel, out)
    }
}

impl Form {
    /// Basis functions of this form at `q` (see [`ErrorFunction::basis`]).
    pub fn basis(&self, q: f64, travel: [f64; 2], out: &mut [f64]) {
        match self {
            Form::Constant => out[0] = 1.0,
            Form::Poly(_) => {
                let mut p = 1.0;
                for o in out.iter_mut() {
                    *o = p;
                    p *= q;
                }
            }
            Form::Cheb(_) => {
                let u = cheb_u(q, travel);
                let (mut t0, mut t1) = (1.0, u);
                for (k, o) in out.iter_mut().enumerate() {
                    if k == 0 {
                        *o = 1.0;
                    } else {
                        *o = t1;
                        let t2 = 2.0 * u * t1 - t0;
                        t0 = t1;
                        t1 = t2;
                    }
                }
            }
            Form::Table(qs) => {
                out.iter_mut().for_each(|o| *o = 0.0);
                let n = qs.len();
                if n == 0 {
                    return;
                }
                if q <= qs[0] {
                    out[0] = 1.0;
                } else if q >= qs[n - 1] {
                    out[n - 1] = 1.0;
                } else {
                    let k = qs.partition_point(|&x| x <= q).clamp(1, n - 1);
                    let w = (q - qs[k - 1]) / (qs[k] - qs[k - 1]);
                    out[k - 1] = 1.0 - w;
                    out[k] = w;
                }
            }
        }
    }
}

/// Σ c_k T_k(u) by Clenshaw's recurrence.
#[inline]
fn clenshaw(c: &[f64], u: f64) -> f64 {
    match c.len() {
        0 => 0.0,
        1 => c[0],
        _ => {
            let (mut b1, mut b2) = (0.0, 0.0);
            for &ck in c[1..].iter().rev() {
                let b0 = 2.0 * u * b1 - b2 + ck;
                b2 = b1;
                b1 = b0;
            }
            c[0] + u * b1 - b2
        }
    }
}

fn table_eval(qs: &[f64], e: &[f64], q: f64) -> f64 {
    let n = qs.len();
    if n == 0 {
        return 0.0;
    }
    if q <= qs[0] {
        return e[0];
    }
    if q >= qs[n - 1] {
        return e[n - 1];
    }
    let k = qs.partition_point(|&x| x <= q).clamp(1, n - 1);
    let w = (q - qs[k - 1]) / (qs[k] - qs[k - 1]);
    e[k - 1] + w * (e[k] - e[k - 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRAVEL: [f64; 2] = [-300.0, 500.0];

    fn cases() -> Vec<ErrorFunction> {
        vec![
            ErrorFunction::Constant(0.012),
            ErrorFunction::Poly(vec![0.001, 2e-6, -3e-9, 4e-12]),
            ErrorFunction::Cheb(vec![0.001, 0.004, -0.002, 0.0005, 1e-4]),
            ErrorFunction::Table {
                q: vec![-200.0, 0.0, 100.0, 400.0],
                e: vec![0.0, 0.003, -0.001, 0.002],
            },
        ]
    }

    #[test]
    fn chebyshev_matches_cosine_definition() {
        // T_k(cos t) = cos(k t): an independent closed form.
        let c = [0.3, -0.2, 0.1, 0.05, -0.025];
        let f = ErrorFunction::Cheb(c.to_vec());
        for &q in &[-300.0, -123.0, 0.0, 250.0, 500.0] {
            let u: f64 = (2.0 * q - TRAVEL[0] - TRAVEL[1]) / (TRAVEL[1] - TRAVEL[0]);
            let t = u.clamp(-1.0, 1.0).acos();
            let expect: f64 = c
                .iter()
                .enumerate()
                .map(|(k, ck)| ck * (k as f64 * t).cos())
                .sum();
            assert!((f.eval(q, TRAVEL) - expect).abs() < 1e-14);
        }
    }

    #[test]
    fn polynomial_and_table_closed_forms() {
        let f = ErrorFunction::Poly(vec![1.0, 2.0, 3.0]);
        assert_eq!(f.eval(2.0, TRAVEL), 1.0 + 4.0 + 12.0);
        assert_eq!(f.deriv(2.0, TRAVEL), 2.0 + 12.0);
        let t = ErrorFunction::Table {
            q: vec![0.0, 10.0],
            e: vec![1.0, 3.0],
        };
        assert_eq!(t.eval(5.0, TRAVEL), 2.0);
        assert_eq!(t.eval(-5.0, TRAVEL), 1.0);
        assert_eq!(t.eval(50.0, TRAVEL), 3.0);
        assert_eq!(t.deriv(5.0, TRAVEL), 0.2);
    }

    #[test]
    fn basis_reproduces_value_and_coefficient_derivative() {
        for f in cases() {
            let n = f.coeffs().len();
            let mut b = vec![0.0; n];
            for &q in &[-250.0, -100.0, 3.5, 77.0, 420.0] {
                f.basis(q, TRAVEL, &mut b);
                let v: f64 = b.iter().zip(f.coeffs()).map(|(b, c)| b * c).sum();
                assert!((v - f.eval(q, TRAVEL)).abs() < 1e-15, "{f:?}");
                // Perturb each coefficient: the value changes by exactly the basis value.
                for k in 0..n {
                    let mut g = f.clone();
                    g.coeffs_mut()[k] += 1.0;
                    let d = g.eval(q, TRAVEL) - f.eval(q, TRAVEL);
                    assert!(
                        (d - b[k]).abs() <= 1e-9 * b[k].abs().max(1.0),
                        "{f:?} k={k}"
                    );
                }
            }
        }
    }

    #[test]
    fn position_derivative_matches_finite_difference() {
        for f in cases() {
            for &q in &[-250.0, -100.0, 3.5, 77.0, 420.0] {
                let h = 1e-3;
                let fd = (f.eval(q + h, TRAVEL) - f.eval(q - h, TRAVEL)) / (2.0 * h);
                let d = f.deriv(q, TRAVEL);
                assert!(
                    (fd - d).abs() <= 1e-6 * d.abs().max(1e-9),
                    "{f:?} q={q}: {d} vs {fd}"
                );
            }
        }
    }
}
