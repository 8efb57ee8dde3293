//! Double-ballbar identification of the eight location errors (PIGEs) of the
//! rotary axes of a double-turntable machine (\[R1\] in docs/references.md): A tilting about x,
//! carrying C turning about z.
//!
//! * [`setup`]: the tool-ball set-up error `(eX, eY)` from spindle-rotation
//!   readings;
//! * [`mode`]: the four measurement modes as measurement models on the exact
//!   kinematics (`B2(α) = A(α)·A(0)⁻¹·B2(0)`), implementing
//!   [`crate::fit::Model`];
//! * [`closed_form`]: the first-order forms of \[R1\] (eqs 19–22), the start of
//!   the fit and a cross-check of the exact model;
//! * [`identify`](mod@identify): the joint nonlinear least squares over the modes given;
//! * [`sensitivity`], [`program`](mod@program), [`simulate`]: table 2 of \[R1\], the
//!   G-code test programs, and synthetic readings for planning.
//!
//! Units: mm, rad for the errors, degrees for axis angles.

#[warn(missing_docs)]
pub mod circular;
#[warn(missing_docs)]
pub mod circular_model;
#[warn(missing_docs)]
pub mod circular_sim;
pub mod closed_form;
pub mod data;
pub mod doc;
pub mod identify;
pub mod mode;
pub mod plot;
pub mod program;
pub mod sensitivity;
pub mod setup;
pub mod simulate;

use std::fmt;

use nalgebra::Vector3;

use crate::model::{AxisKind, Component, Machine};

pub use closed_form::{first_order_delta_l, start_values};
pub use data::{ModeData, read_mode_file, write_mode_file};
pub use doc::{
    BallbarIdentifyDoc, BallbarProgramDoc, BallbarSensitivityDoc, BallbarSetupDoc,
    BallbarSimulateDoc, PerMode, PerPige,
};
pub use identify::{
    BallbarIdentifyError, Compensation, Identification, IdentifyInputs, IdentifyOptions,
    Unresolved, identify,
};
pub use mode::{BallbarMode, ModeModel, Rig, Trunnion, TrunnionError, Unknowns, predicted_reading};
pub use program::{ProgramError, ProgramSpec, program};
pub use sensitivity::{
    SensitivityInputs, SensitivityOptions, SensitivityRow, delta_l_curve, sensitivity_table,
};
pub use setup::{SetupError, SetupErrorInput, SetupErrorProblem, SetupOptions, setup_error};
pub use simulate::{
    SimulateInputs, SimulateOptions, SimulationSpec, angle_range, default_angles, simulate_mode,
    simulate_modes,
};

/// One of the eight location errors of the rotary axes (ISO 230-1 names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Pige {
    /// Offset of the A-axis line in y of M (mm).
    EY0A,
    /// Offset of the A-axis line in z of M (mm).
    EZ0A,
    /// Tilt of the A-axis line about y (rad).
    EB0A,
    /// Tilt of the A-axis line about z (rad).
    EC0A,
    /// Offset of the C-axis line in x of the A frame (mm).
    EX0C,
    /// Offset of the C-axis line in y of the A frame (mm).
    EY0C,
    /// Tilt of the C-axis line about x (rad).
    EA0C,
    /// Tilt of the C-axis line about y (rad).
    EB0C,
}

impl Pige {
    /// All eight, in the order of every `[f64; 8]` indexed by PIGE.
    pub const ALL: [Pige; 8] = [
        Pige::EY0A,
        Pige::EZ0A,
        Pige::EB0A,
        Pige::EC0A,
        Pige::EX0C,
        Pige::EY0C,
        Pige::EA0C,
        Pige::EB0C,
    ];

    /// Index 0..8 in [`Pige::ALL`] order.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The ISO name, e.g. `EY0A`.
    pub fn name(self) -> &'static str {
        [
            "EY0A", "EZ0A", "EB0A", "EC0A", "EX0C", "EY0C", "EA0C", "EB0C",
        ][self.index()]
    }

    /// The PIGE named `name`.
    pub fn from_name(name: &str) -> Option<Pige> {
        Pige::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The rotary axis it belongs to: `'A'` or `'C'`.
    pub fn axis(self) -> char {
        if self.index() < 4 { 'A' } else { 'C' }
    }

    /// The error component (translation or rotation) in the axis' location transform.
    pub fn component(self) -> Component {
        match self {
            Pige::EY0A | Pige::EY0C => Component::Ty,
            Pige::EZ0A => Component::Tz,
            Pige::EX0C => Component::Tx,
            Pige::EA0C => Component::Rx,
            Pige::EB0A | Pige::EB0C => Component::Ry,
            Pige::EC0A => Component::Rz,
        }
    }

    /// True for the four tilts (rad), false for the four offsets (mm).
    pub fn is_tilt(self) -> bool {
        self.component().is_rotation()
    }

    /// Unit of the value: `"mm"` or `"rad"`.
    pub fn unit(self) -> &'static str {
        if self.is_tilt() { "rad" } else { "mm" }
    }
}

impl fmt::Display for Pige {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Values of the eight PIGEs (mm for offsets, rad for tilts), indexed by [`Pige`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Piges(pub [f64; 8]);

impl Piges {
    /// The value of `p`.
    pub fn get(&self, p: Pige) -> f64 {
        self.0[p.index()]
    }

    /// Sets the value of `p`.
    pub fn set(&mut self, p: Pige, v: f64) {
        self.0[p.index()] = v;
    }

    /// The eight values read from `machine`'s A and C axes.
    pub fn from_machine(machine: &Machine, t: &Trunnion) -> Piges {
        let mut out = Piges::default();
        for p in Pige::ALL {
            out.set(
                p,
                machine.axes[t.axis_of(p)].errors.location[p.component().index()],
            );
        }
        out
    }

    /// Writes the eight values into `machine`'s A and C axes (the other four
    /// location components of A and C are left as they are).
    pub fn write_to(&self, machine: &mut Machine, t: &Trunnion) {
        for p in Pige::ALL {
            machine.axes[t.axis_of(p)].errors.location[p.component().index()] = self.get(p);
        }
    }
}

/// Checks that `axis` of `machine` is a rotary axis named `name`.
pub(crate) fn rotary_named(machine: &Machine, name: &str) -> Option<usize> {
    machine
        .axis_index(name)
        .filter(|&i| machine.axes[i].kind == AxisKind::Rotary)
}

/// The point of line `(o1, d1)` closest to line `(o2, d2)` (`o1` when parallel).
pub(crate) fn closest_point(
    o1: &Vector3<f64>,
    d1: &Vector3<f64>,
    o2: &Vector3<f64>,
    d2: &Vector3<f64>,
) -> Vector3<f64> {
    let w = o1 - o2;
    let (a, b, c) = (d1.dot(d1), d1.dot(d2), d2.dot(d2));
    let (d, e) = (d1.dot(&w), d2.dot(&w));
    let den = a * c - b * b;
    if den.abs() <= 1e-12 * a * c {
        return *o1;
    }
    let s = (b * e - c * d) / den;
    o1 + d1 * s
}
