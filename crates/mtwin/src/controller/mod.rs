//! Compensation tables for real controllers (docs/controller-tables.md): an
//! identified machine model written in the table formats controllers load,
//! read back where the format allows, and the volumetric error the exported
//! tables leave.
//!
//! | format | module | what it carries |
//! |---|---|---|
//! | Beckhoff / ISG volumetric (`ISG_CSV` + `.lis`) | [`isg_csv`] | every PDGE of every axis as a table, every location error |
//! | Etalon exchange (vendor variant) | [`etalon`] | the same as ISG |
//! | LinuxCNC `COMP_FILE` type 1 (+ trunnion kinematics) | [`linuxcnc_comp`] | one correction per linear joint along itself; the rotary axis-line offsets of a trunnion |
//! | LinuxCNC live thermal compensation (a HAL component) | [`linuxcnc_thermal`] | a thermal drift model of `mtwin thermal fit` driving the Z external offset |
//! | Siemens 840D sl EEC | [`siemens_eec`] | one correction per linear axis along itself |
//! | Siemens 840D sl CEC | [`siemens_cec`] | one linear axis' correction as a function of another's position (straightness, sag, squareness) |
//!
//! Heidenhain and Fanuc controls have compensation tables too, but their
//! public documentation does not give a complete file layout: mtwin writes
//! none for them.
//!
//! Per-axis formats (LinuxCNC, EEC, CEC) do not carry individual ISO 230-1
//! errors: they carry what the whole model predicts along one line per axis
//! (the *reference lines* through the middle of the linear ranges, rotary axes
//! at zero). That is a combination the measurement determines even when the
//! individual errors of an identification are confounded. The volumetric
//! formats (ISG, Etalon) carry the individual errors; [`residual`] says what
//! either leaves. [`import()`] reads every format back into a machine model.

pub mod etalon;
pub mod import;
pub mod isg_csv;
pub mod linuxcnc_comp;
pub mod linuxcnc_thermal;
pub mod residual;
pub mod siemens_cec;
pub mod siemens_eec;

use nalgebra::{DMatrix, Vector3};

use crate::kinematics::Kinematics;
use crate::model::{AxisKind, Component, ErrorFunction, ErrorName, Machine};

pub use import::{Imported, import};
pub use residual::{Residual, ResidualOptions, residual};

/// A controller table format mtwin writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Beckhoff TwinCAT / ISG kernel volumetric compensation: `ISG_CSV` files and a `.lis` list.
    Isg,
    /// Etalon exchange format ("vendor" variant), read by the same volumetric compensation.
    Etalon,
    /// LinuxCNC joint compensation files (`COMP_FILE_TYPE = 1`) and trunnion kinematics parameters.
    LinuxCnc,
    /// Siemens 840D sl leadscrew / encoder error compensation (EEC).
    SiemensEec,
    /// Siemens 840D sl sag and angularity compensation (CEC).
    SiemensCec,
}

impl Format {
    /// Every format, in the order of `--to`'s choices.
    pub const ALL: [Format; 5] = [
        Format::Isg,
        Format::Etalon,
        Format::LinuxCnc,
        Format::SiemensEec,
        Format::SiemensCec,
    ];

    /// The name used by `mtwin export --to` and in documents.
    pub fn name(self) -> &'static str {
        match self {
            Format::Isg => "isg",
            Format::Etalon => "etalon",
            Format::LinuxCnc => "linuxcnc",
            Format::SiemensEec => "siemens-eec",
            Format::SiemensCec => "siemens-cec",
        }
    }

    /// The format called `name` (see [`Format::name`]).
    pub fn from_name(name: &str) -> Option<Format> {
        Format::ALL.into_iter().find(|f| f.name() == name)
    }

    /// One sentence: what the format can carry.
    pub fn carries(self) -> &'static str {
        match self {
            Format::Isg | Format::Etalon => {
                "all six position-dependent errors of each axis (tables over its position, mm / rad) and all location errors; the controller corrects the tool tip with the linear axes"
            }
            Format::LinuxCnc => {
                "per linear joint one correction along that joint as a function of its own position (COMP_FILE_TYPE 1); on an XYZAC/XYZBC trunnion also the positions of the rotary axis lines (kinematics parameters)"
            }
            Format::SiemensEec => {
                "per linear axis one correction along that axis as a function of its own position"
            }
            Format::SiemensCec => {
                "per pair of linear axes one correction of the output axis as a function of the input axis' position (straightness, sag, squareness); not the positioning along the axis itself"
            }
        }
    }

    /// Default table spacing for linear axes, mm.
    pub fn default_spacing_mm(self) -> f64 {
        10.0
    }

    /// The most points one table may have (LinuxCNC's loader reads at most 256 lines).
    pub fn max_points(self) -> usize {
        match self {
            Format::LinuxCnc => 256,
            _ => 2000,
        }
    }
}

/// Table grids of an export.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExportOptions {
    /// Spacing of the table points on linear axes, mm (default: the format's, 10 mm).
    pub spacing_mm: Option<f64>,
    /// Spacing of the table points on rotary axes, degree (default 5°).
    pub spacing_deg: Option<f64>,
    /// Table ranges by axis name (default: the axis travel).
    pub ranges: Vec<(String, [f64; 2])>,
}

/// One correction table of a per-axis controller: the value added to the
/// command of axis `output` as a function of the commanded position of axis
/// `input` (linearly interpolated, held constant outside the points).
#[derive(Debug, Clone, PartialEq)]
pub struct JointTable {
    /// Index of the axis whose position is the table argument.
    pub input: usize,
    /// Index of the axis whose command is corrected.
    pub output: usize,
    /// Argument positions, mm, strictly increasing.
    pub q: Vec<f64>,
    /// Corrections added to the command, mm.
    pub c: Vec<f64>,
}

impl JointTable {
    /// The correction at argument position `q`.
    pub fn eval(&self, q: f64) -> f64 {
        ErrorFunction::Table {
            q: self.q.clone(),
            e: self.c.clone(),
        }
        .eval(q, [0.0, 1.0])
    }
}

/// How the controller applies what was exported (for [`residual()`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Correction {
    /// Volumetric compensation: the controller knows this machine model (the
    /// tables and the location errors) and moves the linear axes so that the
    /// modelled tool tip is where the nominal machine would put it.
    Volumetric(Machine),
    /// Joint tables: the controller's own kinematics (`kinematics`: nominal,
    /// or with the exported trunnion parameters) give the joint commands,
    /// then each table's correction is added to its output joint.
    Joint {
        /// The kinematic model the controller uses.
        kinematics: Machine,
        /// The correction tables.
        tables: Vec<JointTable>,
    },
}

/// The result of writing one format.
#[derive(Debug, Clone, PartialEq)]
pub struct Exported {
    /// The format.
    pub format: Format,
    /// The files, as (file name in the output folder, contents).
    pub files: Vec<(String, String)>,
    /// What the tables carry: error names, or for per-axis formats the tables
    /// (`comp_X: X along X`).
    pub carried: Vec<String>,
    /// Non-zero errors of the model that no table carries (their effect on the
    /// reference lines is folded into per-axis tables).
    pub dropped: Vec<String>,
    /// How a controller applies the tables.
    pub correction: Correction,
}

impl Exported {
    /// A volumetric export: the table `tab` carries every non-zero error of
    /// `machine`, none is dropped.
    pub(crate) fn volumetric(
        format: Format,
        files: Vec<(String, String)>,
        machine: &Machine,
        tab: Machine,
    ) -> Self {
        Self {
            format,
            files,
            carried: nonzero_errors(machine)
                .iter()
                .map(|n| n.to_string())
                .collect(),
            dropped: Vec::new(),
            correction: Correction::Volumetric(tab),
        }
    }
}

/// Why a machine cannot be exported in a format.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// The machine does not fit the format.
    #[error("{format} cannot carry this machine: {reason}")]
    Unsupported {
        /// `--to` name of the format.
        format: &'static str,
        /// Why.
        reason: String,
    },
    /// A grid option is unusable.
    #[error("{0}")]
    Grid(String),
}

/// What one export wrote and what it leaves (`mtwin export --format json`,
/// one per format).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExportDoc {
    /// `--to` name of the format.
    pub format: String,
    /// Largest tool-tip error left by the tables over the workspace grid, µm.
    pub max_um: f64,
    /// RMS tool-tip error left by the tables over the workspace grid, µm.
    pub rms_um: f64,
    /// The files written, relative to the output folder.
    pub files: Vec<String>,
    /// What the format can carry.
    pub carries: String,
    /// What the tables carry.
    pub carried: Vec<String>,
    /// Non-zero errors of the model no table carries.
    pub dropped: Vec<String>,
    /// The residual in full: where the maximum is, and the errors without
    /// compensation and with the full model.
    pub residual: Residual,
}

impl ExportDoc {
    /// The document of `exported` with its residual `r`; `prefix` is put
    /// before each file name (the output folder relative to `--out`).
    pub fn new(exported: &Exported, r: Residual, prefix: &str) -> Self {
        ExportDoc {
            format: exported.format.name().to_string(),
            max_um: r.max_um,
            rms_um: r.rms_um,
            files: exported
                .files
                .iter()
                .map(|(n, _)| format!("{prefix}{n}"))
                .collect(),
            carries: exported.format.carries().to_string(),
            carried: exported.carried.clone(),
            dropped: exported.dropped.clone(),
            residual: r,
        }
    }
}

impl std::fmt::Display for ExportDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = &self.residual;
        writeln!(f, "{}: wrote {}", self.format, self.files.join(", "))?;
        writeln!(f, "  carries: {}", self.carries)?;
        writeln!(f, "  carried: {}", self.carried.join("; "))?;
        if self.dropped.is_empty() {
            writeln!(f, "  not carried: nothing")?;
        } else {
            writeln!(f, "  not carried: {}", self.dropped.join(", "))?;
        }
        let at: Vec<String> = r.at.iter().map(|v| crate::io::fmt_f64(*v)).collect();
        writeln!(
            f,
            "  volumetric error over {} poses (max / RMS, µm): after export {:.2} / {:.2} (max at {}), uncompensated {:.2} / {:.2}, full model {:.3} / {:.3}",
            r.poses,
            self.max_um,
            self.rms_um,
            at.join(" "),
            r.uncompensated_max_um,
            r.uncompensated_rms_um,
            r.full_model_max_um,
            r.full_model_rms_um
        )
    }
}

/// Write `machine` in `format`.
pub fn export(
    machine: &Machine,
    format: Format,
    opts: &ExportOptions,
) -> Result<Exported, ExportError> {
    for (name, _) in &opts.ranges {
        if machine.axis_index(name).is_none() {
            return Err(ExportError::Grid(format!(
                "--range names axis {name}, which the machine does not have (axes: {})",
                machine.axis_names().join(", ")
            )));
        }
    }
    match format {
        Format::Isg => isg_csv::export(machine, opts),
        Format::Etalon => etalon::export(machine, opts),
        Format::LinuxCnc => linuxcnc_comp::export(machine, opts),
        Format::SiemensEec => siemens_eec::export(machine, opts),
        Format::SiemensCec => siemens_cec::export(machine, opts),
    }
}

/// The table points of axis `i`: its range (option or travel) split evenly
/// with a spacing no larger than asked, and at most `max_points` points.
pub fn axis_grid(
    machine: &Machine,
    i: usize,
    opts: &ExportOptions,
    max_points: usize,
) -> Result<Vec<f64>, ExportError> {
    let ax = &machine.axes[i];
    let [lo, hi] = opts
        .ranges
        .iter()
        .find(|(n, _)| *n == ax.name)
        .map_or(ax.travel, |(_, r)| *r);
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(ExportError::Grid(format!(
            "the range of axis {} must be two finite numbers LO < HI, got {lo}:{hi}",
            ax.name
        )));
    }
    let spacing = match ax.kind {
        AxisKind::Linear => opts.spacing_mm.unwrap_or(10.0),
        AxisKind::Rotary => opts.spacing_deg.unwrap_or(5.0),
    };
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(ExportError::Grid(format!(
            "the table spacing must be a positive number, got {spacing}"
        )));
    }
    let n = (((hi - lo) / spacing - 1e-9).ceil() as usize + 1).clamp(2, max_points.max(2));
    Ok((0..n)
        .map(|k| {
            if k + 1 == n {
                hi
            } else {
                lo + (hi - lo) * k as f64 / (n - 1) as f64
            }
        })
        .collect())
}

/// The ISO letter of a linear axis' direction (`X`, `Y`, `Z`) when it runs
/// along a machine axis (±), with the sign of the direction.
pub fn linear_letter(machine: &Machine, i: usize) -> Option<(Component, f64)> {
    let d = machine.axes[i].direction;
    let k = (0..3).find(|&k| (d[k].abs() - 1.0).abs() < 1e-9)?;
    Some((Component::ALL[k], d[k].signum()))
}

/// Indices of the linear axes, in axis order.
pub fn linear_axes(machine: &Machine) -> Vec<usize> {
    (0..machine.n_axes())
        .filter(|&i| machine.axes[i].kind == AxisKind::Linear)
        .collect()
}

/// Every error of `machine` that is present and not identically zero, by name.
pub fn nonzero_errors(machine: &Machine) -> Vec<ErrorName> {
    let mut out = Vec::new();
    for ax in &machine.axes {
        for c in Component::ALL {
            if ax.errors.pdge[c.index()]
                .as_ref()
                .is_some_and(|f| !f.is_zero())
            {
                out.push(ErrorName::pdge(c, &ax.name));
            }
        }
        for c in Component::ALL {
            if ax.errors.location[c.index()] != 0.0 {
                out.push(ErrorName::location(c, &ax.name));
            }
        }
    }
    out
}

/// The reference pose of the per-axis tables: linear axes in the middle of
/// their table range, rotary axes at 0 (or the middle of the travel when 0
/// is outside it).
pub fn reference_pose(machine: &Machine, opts: &ExportOptions) -> Vec<f64> {
    machine
        .axes
        .iter()
        .map(|a| {
            let [lo, hi] = opts
                .ranges
                .iter()
                .find(|(n, _)| *n == a.name)
                .map_or(a.travel, |(_, r)| *r);
            match a.kind {
                AxisKind::Rotary if a.in_travel(0.0) => 0.0,
                _ => 0.5 * (lo + hi),
            }
        })
        .collect()
}

/// Per-axis correction tables along the reference lines: for each linear
/// axis `i` (the argument) and each linear axis `o` in `outputs(i)`, the
/// correction of axis `o` that puts the tool tip of `machine` where
/// `kinematics` (the controller's model) puts it, while only `i` moves from
/// the reference pose. Corrections are the linear-axis solution of the tip
/// error through the controller model's Jacobian at the reference pose.
pub(crate) fn line_tables(
    machine: &Machine,
    kinematics: &Machine,
    opts: &ExportOptions,
    max_points: usize,
    outputs: impl Fn(usize) -> Vec<usize>,
) -> Result<Vec<JointTable>, ExportError> {
    let lin = linear_axes(machine);
    let actual = Kinematics::new(machine);
    let ctrl = Kinematics::new(kinematics);
    let q0 = reference_pose(machine, opts);
    // Tip Jacobian of the controller model w.r.t. the linear axes (finite
    // differences of 1 mm: the tip is affine in the linear axes of a model
    // whose errors are constant, and near enough otherwise).
    let mut jac = DMatrix::<f64>::zeros(3, lin.len());
    for (col, &i) in lin.iter().enumerate() {
        let mut qp = q0.clone();
        let mut qm = q0.clone();
        qp[i] += 0.5;
        qm[i] -= 0.5;
        let d = ctrl.pose(&qp).tip - ctrl.pose(&qm).tip;
        jac.set_column(col, &d);
    }
    let pinv = jac
        .clone()
        .pseudo_inverse(1e-12)
        .map_err(|e| ExportError::Grid(e.to_string()))?;
    let correction = |q: &[f64]| -> Vec<f64> {
        let e: Vector3<f64> = actual.pose(q).tip - ctrl.pose(q).tip;
        let dq = -(&pinv * e);
        dq.iter().copied().collect()
    };
    let at_ref = correction(&q0);
    let mut tables = Vec::new();
    for &i in &lin {
        let grid = axis_grid(machine, i, opts, max_points)?;
        let per_q: Vec<Vec<f64>> = grid
            .iter()
            .map(|&v| {
                let mut q = q0.clone();
                q[i] = v;
                correction(&q)
            })
            .collect();
        for o in outputs(i) {
            let col_o = lin.iter().position(|&l| l == o).expect("output is linear");
            let base = if o == i { 0.0 } else { at_ref[col_o] };
            tables.push(JointTable {
                input: i,
                output: o,
                q: grid.clone(),
                c: per_q.iter().map(|c| c[col_o] - base).collect(),
            });
        }
    }
    Ok(tables)
}

/// A copy of `machine` with every PDGE replaced by a table over its axis grid
/// (what a volumetric controller interpolates) and the location errors kept.
pub(crate) fn tabulated(
    machine: &Machine,
    opts: &ExportOptions,
    max_points: usize,
) -> Result<Machine, ExportError> {
    let mut m = machine.clone();
    for i in 0..m.n_axes() {
        let grid = axis_grid(machine, i, opts, max_points)?;
        let ax = &mut m.axes[i];
        let travel = ax.travel;
        for f in ax.errors.pdge.iter_mut().flatten() {
            let e = grid.iter().map(|&q| f.eval(q, travel)).collect();
            *f = ErrorFunction::Table { q: grid.clone(), e };
        }
    }
    Ok(m)
}

/// Axis names a volumetric format accepts: ISO letters, at most three linear
/// axes (X, Y, Z along their machine axes) and three rotary ones.
pub(crate) fn check_iso_axes(machine: &Machine, format: Format) -> Result<(), ExportError> {
    let unsupported = |reason: String| ExportError::Unsupported {
        format: format.name(),
        reason,
    };
    for (i, a) in machine.axes.iter().enumerate() {
        let letter_ok = match a.kind {
            AxisKind::Linear => ["X", "Y", "Z"].contains(&a.name.as_str()),
            AxisKind::Rotary => ["A", "B", "C"].contains(&a.name.as_str()),
        };
        if !letter_ok {
            return Err(unsupported(format!(
                "axis {} is {}: the format names linear axes X, Y, Z and rotary axes A, B, C",
                a.name,
                a.kind.as_str()
            )));
        }
        if a.kind == AxisKind::Linear
            && linear_letter(machine, i).is_none_or(|(c, _)| c.letter().to_string() != a.name)
        {
            return Err(unsupported(format!(
                "linear axis {} does not run along the machine's {} axis",
                a.name, a.name
            )));
        }
    }
    Ok(())
}

/// Text of a number with `decimals` places, without `-0`.
pub(crate) fn fixed(x: f64, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// The per-axis formats' list of errors no table carries: every non-zero
/// error except the ones named in `carried`.
pub(crate) fn dropped_except(machine: &Machine, carried: &[ErrorName]) -> Vec<String> {
    nonzero_errors(machine)
        .into_iter()
        .filter(|n| !carried.contains(n))
        .map(|n| n.to_string())
        .collect()
}

/// Parse a number token of a controller file.
pub(crate) fn parse_number(s: &str) -> Option<f64> {
    s.parse::<f64>().ok().filter(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_the_range_evenly_within_the_spacing() {
        let m = crate::examples::machine("ac-trunnion").unwrap();
        let x = m.axis_index("X").unwrap();
        let g = axis_grid(&m, x, &ExportOptions::default(), 256).unwrap();
        assert_eq!(g.len(), 61);
        assert_eq!((g[0], g[60]), (-300.0, 300.0));
        assert!((g[1] - g[0] - 10.0).abs() < 1e-12);
        let opts = ExportOptions {
            spacing_mm: Some(7.0),
            ranges: vec![("X".into(), [-100.0, 100.0])],
            ..Default::default()
        };
        let g = axis_grid(&m, x, &opts, 256).unwrap();
        // 200 / 7 = 28.6 → 29 intervals of 6.9 mm.
        assert_eq!(g.len(), 30);
        assert!(g.windows(2).all(|w| w[1] - w[0] <= 7.0));
        // Capped at 256 points: 8000 mm at 10 mm would be 801.
        let gantry = crate::examples::machine("afp-gantry").unwrap();
        let g = axis_grid(&gantry, 0, &ExportOptions::default(), 256).unwrap();
        assert_eq!(g.len(), 256);
        assert_eq!(g[255], 8000.0);
    }

    #[test]
    fn fixed_drops_negative_zero() {
        assert_eq!(fixed(-0.0000000001, 6), "0.000000");
        assert_eq!(fixed(-0.5, 2), "-0.50");
    }
}
