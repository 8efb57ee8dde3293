//! The machine model: a base carrying a tool chain and a workpiece chain of axes.

use nalgebra::Vector3;

use super::{Component, ErrorFunction, ErrorName};

/// Linear or rotary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisKind {
    /// Moves its child by `q·d` (q in mm).
    Linear,
    /// Turns its child by `q` degrees about the line through `origin` along `d` (right-hand rule).
    Rotary,
}

impl AxisKind {
    /// `linear` or `rotary`, as in the machine file.
    pub fn as_str(self) -> &'static str {
        match self {
            AxisKind::Linear => "linear",
            AxisKind::Rotary => "rotary",
        }
    }

    /// Unit of the axis position in files: `mm` or `deg`.
    pub fn unit(self) -> &'static str {
        match self {
            AxisKind::Linear => "mm",
            AxisKind::Rotary => "deg",
        }
    }
}

/// The geometric errors of one axis (ISO 230-1, docs/machine-model.md): up to six position-dependent functions and six
/// location constants. Missing components are zero.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AxisErrors {
    /// PDGEs indexed by [`Component::index`]: `EX<ax>`, `EY<ax>`, `EZ<ax>` (mm), `EA<ax>`,
    /// `EB<ax>`, `EC<ax>` (rad), functions of the axis position.
    pub pdge: [Option<ErrorFunction>; 6],
    /// Location errors indexed by [`Component::index`]: `EX0<ax>` … (mm) and `EA0<ax>` … (rad).
    pub location: [f64; 6],
}

impl AxisErrors {
    /// True when every error is zero.
    pub fn is_zero(&self) -> bool {
        self.location.iter().all(|&v| v == 0.0)
            && self
                .pdge
                .iter()
                .all(|f| f.as_ref().is_none_or(|f| f.is_zero()))
    }

    /// True when some PDGE is present and not identically zero.
    pub fn has_pdge(&self) -> bool {
        self.pdge
            .iter()
            .any(|f| f.as_ref().is_some_and(|f| !f.is_zero()))
    }
}

/// A servo model `y(k) = −Σ a_i y(k−i) + Σ b_j u(k−j−nk)` (docs/servo.md), as stored in `[axes.servo]`.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoTable {
    /// Sample period, s.
    pub ts: f64,
    /// Numerator `b_0..b_nb`.
    pub b: Vec<f64>,
    /// Denominator `a_0..a_na` with `a_0 = 1`.
    pub a: Vec<f64>,
    /// Input delay in samples.
    pub nk: usize,
}

/// One axis of the machine.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Name used for CSV columns and error names (`X`, `A`, …).
    pub name: String,
    /// Linear or rotary.
    pub kind: AxisKind,
    /// Unit direction in M at the zero pose.
    pub direction: Vector3<f64>,
    /// A point on the nominal axis line (rotary) or the axis frame origin, in M at the zero pose (mm).
    pub origin: Vector3<f64>,
    /// Travel `[lo, hi]`, mm or degree, `lo < hi`.
    pub travel: [f64; 2],
    /// Geometric errors.
    pub errors: AxisErrors,
    /// Velocity limit for the interpolator, mm/s or deg/s.
    pub max_velocity: Option<f64>,
    /// Acceleration limit for the interpolator, mm/s² or deg/s².
    pub max_acceleration: Option<f64>,
    /// Jerk limit for the jerk-limited planner, mm/s³ or deg/s³.
    pub max_jerk: Option<f64>,
    /// Servo model of the axis, if identified.
    pub servo: Option<ServoTable>,
}

impl Axis {
    /// An error-free axis.
    pub fn new(
        name: &str,
        kind: AxisKind,
        direction: [f64; 3],
        origin: [f64; 3],
        travel: [f64; 2],
    ) -> Self {
        Axis {
            name: name.to_string(),
            kind,
            direction: Vector3::from(direction),
            origin: Vector3::from(origin),
            travel,
            errors: AxisErrors::default(),
            max_velocity: None,
            max_acceleration: None,
            max_jerk: None,
            servo: None,
        }
    }

    /// True when `q` lies within the travel (inclusive, with a tolerance of 1e-9 of the span).
    pub fn in_travel(&self, q: f64) -> bool {
        let tol = 1e-9 * (self.travel[1] - self.travel[0]).abs().max(1.0);
        q >= self.travel[0] - tol && q <= self.travel[1] + tol
    }

    /// The value of error `component` of kind PDGE at position `q` (0 when absent).
    pub fn pdge_at(&self, component: Component, q: f64) -> f64 {
        self.errors.pdge[component.index()]
            .as_ref()
            .map_or(0.0, |f| f.eval(q, self.travel))
    }
}

/// Which chain an axis belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chain {
    /// Base → spindle.
    Tool,
    /// Base → table.
    Workpiece,
}

/// A machine model (docs/machine-model.md).
#[derive(Debug, Clone, PartialEq)]
pub struct Machine {
    /// Human-readable name.
    pub name: String,
    /// All axes, in file order. Axis positions are passed to the kinematics in this order.
    pub axes: Vec<Axis>,
    /// Indices into `axes`, base → spindle.
    pub tool_chain: Vec<usize>,
    /// Indices into `axes`, base → table.
    pub workpiece_chain: Vec<usize>,
    /// Tool tip in M at the zero pose (mm).
    pub tool_tip: Vector3<f64>,
    /// Unit tool-axis direction, tip towards spindle.
    pub tool_direction: Vector3<f64>,
    /// Workpiece frame origin in M at the zero pose (mm).
    pub workpiece_origin: Vector3<f64>,
    /// Rapid feed for G0, mm/min; [`DEFAULT_RAPID_FEED`] when the machine
    /// file has no `rapid_feed`. Every timing of a rapid (G-code statistics,
    /// interpolation, thermal programs) uses this one rate.
    pub rapid_feed: f64,
}

/// Default rapid feed, mm/min (10 m/min).
pub const DEFAULT_RAPID_FEED: f64 = 10000.0;

impl Machine {
    /// Number of axes.
    pub fn n_axes(&self) -> usize {
        self.axes.len()
    }

    /// Checks a machine built in code with the checks `mtwin model check`
    /// runs on a machine file (chains, axis names and kinds, directions,
    /// error functions, servo tables, rapid feed, finite numbers), so a
    /// [`Machine`] that passes is one a file could hold.
    ///
    /// The check is done in memory with the same rules (and messages) the
    /// file reader ([`parse_machine`](super::parse_machine)) applies to each
    /// value it reads. Each problem is one [`Diagnostic`](crate::io::Diagnostic)
    /// on the machine as a whole, named `<machine NAME>`, its message the
    /// reader's (keys name the place).
    ///
    /// ```
    /// let mut m = mtwin::examples::machine("ac-trunnion").unwrap();
    /// assert!(m.validate().is_ok());
    /// m.rapid_feed = -1.0;
    /// let e = m.validate().unwrap_err();
    /// assert!(e.to_string().contains("rapid_feed"), "{e}");
    /// ```
    pub fn validate(&self) -> Result<(), crate::io::Diagnostics> {
        use crate::io::{Diagnostic, Diagnostics};
        let file = std::path::PathBuf::from(format!("<machine {}>", self.name));
        let problems = super::rules::machine_problems(self);
        if problems.is_empty() {
            Ok(())
        } else {
            Err(Diagnostics(
                problems
                    .into_iter()
                    .map(|m| Diagnostic::whole(&file, m))
                    .collect(),
            ))
        }
    }

    /// Number of rotary axes.
    pub fn n_rotary(&self) -> usize {
        self.axes
            .iter()
            .filter(|a| a.kind == AxisKind::Rotary)
            .count()
    }

    /// Whether a correction can orient the tool as well as place its tip:
    /// exactly five axes of which two are rotary (three linear), so that
    /// the five constraints of tip position and tool-axis direction fix all
    /// axes. Compensation moves the tool axis too only on such a machine
    /// (the tracker's and the program's compensation alike); elsewhere it
    /// moves the linear axes and leaves the rotary axes as commanded.
    pub fn orients_tool(&self) -> bool {
        self.n_axes() == 5 && self.n_rotary() == 2
    }

    /// Index of the axis called `name`.
    pub fn axis_index(&self, name: &str) -> Option<usize> {
        self.axes.iter().position(|a| a.name == name)
    }

    /// Axis names in axis order.
    pub fn axis_names(&self) -> Vec<&str> {
        self.axes.iter().map(|a| a.name.as_str()).collect()
    }

    /// The chain axis `i` is in.
    pub fn chain_of(&self, i: usize) -> Chain {
        if self.tool_chain.contains(&i) {
            Chain::Tool
        } else {
            Chain::Workpiece
        }
    }

    /// A copy with every geometric error removed (the nominal machine).
    pub fn nominal(&self) -> Machine {
        let mut m = self.clone();
        for a in &mut m.axes {
            a.errors = AxisErrors::default();
        }
        m
    }

    /// The current value of error `name` at axis position `q` (location errors ignore `q`).
    /// `None` when the axis does not exist.
    pub fn error_value(&self, name: &ErrorName, q: f64) -> Option<f64> {
        let ax = &self.axes[self.axis_index(&name.axis)?];
        Some(if name.is_location() {
            ax.errors.location[name.component.index()]
        } else {
            ax.pdge_at(name.component, q)
        })
    }

    /// The first axis position outside its travel, as `(axis index, value)`.
    pub fn out_of_travel(&self, q: &[f64]) -> Option<(usize, f64)> {
        self.axes
            .iter()
            .zip(q)
            .enumerate()
            .find(|(_, (a, v))| !a.in_travel(**v))
            .map(|(i, (_, v))| (i, *v))
    }

    /// Total number of error terms present and not identically zero (a PDGE counts once).
    pub fn n_error_terms(&self) -> usize {
        self.axes
            .iter()
            .map(|a| {
                a.errors.location.iter().filter(|&&v| v != 0.0).count()
                    + a.errors
                        .pdge
                        .iter()
                        .filter(|f| f.as_ref().is_some_and(|f| !f.is_zero()))
                        .count()
            })
            .sum()
    }
}
