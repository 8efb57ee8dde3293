//! The parameter vector view of "the errors being fitted": which error components of which
//! axes, in which form, and how a vector θ maps to and from a [`Machine`].
//!
//! A fit specification (docs/tracker.md) is a comma-separated list: `pdge:chebN` / `pdge:polyN` (all six
//! PDGEs of every axis), `location` (all six location errors of every axis), or single names
//! `EXX:cheb3`, `ECC:poly2`, `EXX:const`, `EY0A`. Later items override earlier ones for the
//! same error.

use std::fmt;

use super::{Component, ErrorFunction, ErrorKind, ErrorName, Form, Machine};

/// One error component being fitted, with its form.
#[derive(Debug, Clone, PartialEq)]
pub struct FittedError {
    /// The error.
    pub name: ErrorName,
    /// Index of its axis in the machine.
    pub axis: usize,
    /// Its form (always [`Form::Constant`] for a location error).
    pub form: Form,
    /// Index of its first coefficient in θ.
    pub offset: usize,
}

impl FittedError {
    /// Slot of this error in the per-axis component arrays of the kinematics Jacobian:
    /// 0..6 for PDGE components, 6..12 for location components.
    pub fn slot(&self) -> usize {
        self.name.component.index() + if self.name.is_location() { 6 } else { 0 }
    }
}

/// A problem with a fit specification.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SpecError {
    /// An empty item or an empty specification.
    #[error("the fit specification is empty (e.g. `pdge:cheb3,location` or `EXX:cheb3,EY0A`)")]
    Empty,
    /// Unknown form text.
    #[error("`{0}`: unknown form (use cheb<N>, poly<N> or const, e.g. `EXX:cheb3`)")]
    BadForm(String),
    /// Not a group and not an error name.
    #[error("`{item}`: {reason}")]
    BadItem {
        /// The item.
        item: String,
        /// Why.
        reason: String,
    },
    /// The name refers to an axis the machine does not have.
    #[error("`{item}` names axis `{axis}`, which the machine does not have (axes: {axes})")]
    UnknownAxis {
        /// The item.
        item: String,
        /// The axis part.
        axis: String,
        /// The machine's axes.
        axes: String,
    },
}

/// The ordered set of fitted error coefficients: θ.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterSet {
    errors: Vec<FittedError>,
    len: usize,
}

fn parse_form(s: &str) -> Result<Form, SpecError> {
    let deg = |p: &str| {
        s.strip_prefix(p)
            .and_then(|d| d.parse::<usize>().ok())
            .filter(|&d| d <= 64)
    };
    if s == "const" {
        Ok(Form::Constant)
    } else if let Some(d) = deg("cheb") {
        Ok(Form::Cheb(d))
    } else if let Some(d) = deg("poly") {
        Ok(Form::Poly(d))
    } else {
        Err(SpecError::BadForm(s.to_string()))
    }
}

impl ParameterSet {
    /// Build θ from a fit specification for `machine`.
    pub fn from_spec(machine: &Machine, spec: &str) -> Result<ParameterSet, SpecError> {
        // (name, axis, form) in order of first mention; later items replace the form.
        let mut list: Vec<(ErrorName, usize, Form)> = Vec::new();
        let mut put = |name: ErrorName, axis: usize, form: Form| {
            if let Some(e) = list.iter_mut().find(|e| e.0 == name) {
                e.2 = form;
            } else {
                list.push((name, axis, form));
            }
        };
        let items: Vec<&str> = spec
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .collect();
        if items.is_empty() {
            return Err(SpecError::Empty);
        }
        let axes = machine.axis_names().join(", ");
        for item in items {
            if let Some(f) = item.strip_prefix("pdge:") {
                let form = parse_form(f)?;
                for (i, a) in machine.axes.iter().enumerate() {
                    for c in Component::ALL {
                        put(ErrorName::pdge(c, &a.name), i, form.clone());
                    }
                }
            } else if item == "location" {
                for (i, a) in machine.axes.iter().enumerate() {
                    for c in Component::ALL {
                        put(ErrorName::location(c, &a.name), i, Form::Constant);
                    }
                }
            } else {
                let (n, f) = match item.split_once(':') {
                    Some((n, f)) => (n, Some(f)),
                    None => (item, None),
                };
                let name: ErrorName =
                    n.parse().map_err(|e: super::error_name::ErrorNameError| {
                        SpecError::BadItem {
                            item: item.into(),
                            reason: e.to_string(),
                        }
                    })?;
                let axis =
                    machine
                        .axis_index(&name.axis)
                        .ok_or_else(|| SpecError::UnknownAxis {
                            item: item.into(),
                            axis: name.axis.clone(),
                            axes: axes.clone(),
                        })?;
                let form = match (name.kind, f) {
                    (ErrorKind::Location, None) | (ErrorKind::Location, Some("const")) => {
                        Form::Constant
                    }
                    (ErrorKind::Location, Some(_)) => {
                        return Err(SpecError::BadItem {
                            item: item.into(),
                            reason: "a location error is a constant and takes no form".into(),
                        });
                    }
                    (ErrorKind::Pdge, Some(f)) => parse_form(f)?,
                    (ErrorKind::Pdge, None) => {
                        return Err(SpecError::BadItem {
                            item: item.into(),
                            reason: format!("give the form of this PDGE, e.g. `{n}:cheb3`"),
                        });
                    }
                };
                put(name, axis, form);
            }
        }
        Ok(Self::from_list(list))
    }

    /// Build θ from an explicit list of errors and forms.
    pub fn from_list(list: Vec<(ErrorName, usize, Form)>) -> ParameterSet {
        let mut offset = 0;
        let errors = list
            .into_iter()
            .map(|(name, axis, form)| {
                let e = FittedError {
                    name,
                    axis,
                    offset,
                    form,
                };
                offset += e.form.n_coeffs();
                e
            })
            .collect();
        ParameterSet {
            errors,
            len: offset,
        }
    }

    /// Number of parameters (length of θ).
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when nothing is fitted.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The fitted errors.
    pub fn errors(&self) -> &[FittedError] {
        &self.errors
    }

    /// Label of every parameter: `EY0A`, `EXX.c2` (Chebyshev/poly coefficient), in θ order.
    pub fn labels(&self) -> Vec<String> {
        let mut out = Vec::with_capacity(self.len);
        for e in &self.errors {
            for k in 0..e.form.n_coeffs() {
                if matches!(e.form, Form::Constant) {
                    out.push(e.name.to_string());
                } else {
                    out.push(format!("{}.{}", e.name, e.form.coeff_label(k)));
                }
            }
        }
        out
    }

    /// True for parameters that are rotations (rad), false for translations (mm), in θ order.
    pub fn is_rotation(&self) -> Vec<bool> {
        let mut out = Vec::with_capacity(self.len);
        for e in &self.errors {
            out.extend(std::iter::repeat_n(
                e.name.component.is_rotation(),
                e.form.n_coeffs(),
            ));
        }
        out
    }

    /// The current θ of `machine`: coefficients of errors whose stored form matches, 0 otherwise.
    pub fn get(&self, machine: &Machine) -> Vec<f64> {
        let mut theta = vec![0.0; self.len];
        for e in &self.errors {
            let ax = &machine.axes[e.axis];
            let c = e.name.component.index();
            match e.name.kind {
                ErrorKind::Location => theta[e.offset] = ax.errors.location[c],
                ErrorKind::Pdge => {
                    if let Some(f) = &ax.errors.pdge[c]
                        && f.form() == e.form
                    {
                        theta[e.offset..e.offset + e.form.n_coeffs()].copy_from_slice(f.coeffs());
                    }
                }
            }
        }
        theta
    }

    /// Write θ into `machine`: each fitted error is replaced by the function of its form with
    /// these coefficients (whatever the machine held before for that error).
    pub fn set(&self, machine: &mut Machine, theta: &[f64]) {
        assert_eq!(theta.len(), self.len, "θ has the wrong length");
        for e in &self.errors {
            let ax = &mut machine.axes[e.axis];
            let c = e.name.component.index();
            let coeffs = &theta[e.offset..e.offset + e.form.n_coeffs()];
            match e.name.kind {
                ErrorKind::Location => ax.errors.location[c] = coeffs[0],
                ErrorKind::Pdge => {
                    let mut f: ErrorFunction = e.form.zero();
                    f.coeffs_mut().copy_from_slice(coeffs);
                    ax.errors.pdge[c] = Some(f);
                }
            }
        }
    }

    /// Basis values of every parameter at axis positions `q` (length n): `∂ error / ∂ θ_j`
    /// for the error that θ_j belongs to, written to `out` (length = `len()`).
    pub fn basis(&self, machine: &Machine, q: &[f64], out: &mut [f64]) {
        for e in &self.errors {
            let n = e.form.n_coeffs();
            let ax = &machine.axes[e.axis];
            e.form
                .basis(q[e.axis], ax.travel, &mut out[e.offset..e.offset + n]);
        }
    }
}

impl fmt::Display for ParameterSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts: Vec<String> = self
            .errors
            .iter()
            .map(|e| {
                if e.name.is_location() {
                    e.name.to_string()
                } else {
                    format!("{}:{}", e.name, e.form.label())
                }
            })
            .collect();
        write!(f, "{}", parts.join(","))
    }
}
