//! LinuxCNC joint compensation files and trunnion kinematics parameters.
//!
//! A compensation file (`[JOINT_n] COMP_FILE`) has one line per point,
//! `nominal forward reverse`, nominal positions ascending, at most 256 lines,
//! no header and no comment: LinuxCNC's loader stops at the first line that
//! is not three numbers. With `COMP_FILE_TYPE = 1` the second and third
//! numbers are corrections added to the joint command when moving forward
//! and in reverse (mtwin writes the same value in both: it has no backlash
//! model); between points LinuxCNC interpolates linearly. `BACKLASH` is
//! ignored for a joint that has a compensation file.
//!
//! **Carries** per linear joint one correction along that joint as a function
//! of its own position: what the whole model predicts along the reference
//! line of that axis (the positioning error plus the effect of the other
//! errors on that line), nothing across the axis and nothing that depends on
//! two axes at once. On an XYZAC or XYZBC trunnion (`xyzac-trt-kins`,
//! `xyzbc-trt-kins`) the positions of the two rotary axis lines go into the
//! kinematics parameters (`kinematics.hal`): the two offsets of each line
//! across its direction; tilts of the lines and the errors of the rotary
//! axes' motion are not carried.

use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use super::{
    Correction, ExportError, ExportOptions, Exported, Format, dropped_except, fixed, line_tables,
    linear_axes, linear_letter, parse_number, reference_pose,
};
use crate::io::Diagnostic;
use crate::kinematics::Kinematics;
use crate::model::{AxisKind, Component, ErrorFunction, ErrorName, Machine};

/// LinuxCNC reads at most this many lines of a compensation file.
pub const MAX_LINES: usize = 256;

/// File name of axis `name`'s compensation file.
pub fn comp_file_name(name: &str) -> String {
    format!("comp_{name}.txt")
}

/// Which LinuxCNC trunnion kinematics a machine matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trunnion {
    /// `xyzac-trt-kins`: A (about x) tilting the table, C (about z) on it.
    Xyzac,
    /// `xyzbc-trt-kins`: B (about y) tilting the table, C (about z) on it.
    Xyzbc,
}

impl Trunnion {
    /// The HAL component name.
    pub fn kins(self) -> &'static str {
        match self {
            Trunnion::Xyzac => "xyzac-trt-kins",
            Trunnion::Xyzbc => "xyzbc-trt-kins",
        }
    }

    /// The machine's trunnion, if it is one: linear X, Y, Z along the machine
    /// axes on the tool side, the workpiece chain a tilting axis (A about x or
    /// B about y) carrying C about z.
    pub fn of(machine: &Machine) -> Option<Trunnion> {
        let lin = linear_axes(machine);
        if lin.len() != 3 || machine.tool_chain.len() != 3 || machine.workpiece_chain.len() != 2 {
            return None;
        }
        if lin.iter().any(|&i| {
            !machine.tool_chain.contains(&i)
                || linear_letter(machine, i)
                    .is_none_or(|(c, _)| c.letter().to_string() != machine.axes[i].name)
        }) {
            return None;
        }
        let (t, c) = (
            &machine.axes[machine.workpiece_chain[0]],
            &machine.axes[machine.workpiece_chain[1]],
        );
        let along = |a: &crate::model::Axis, k: usize| {
            a.kind == AxisKind::Rotary && (a.direction[k].abs() - 1.0).abs() < 1e-9
        };
        if c.name != "C" || !along(c, 2) {
            return None;
        }
        match t.name.as_str() {
            "A" if along(t, 0) => Some(Trunnion::Xyzac),
            "B" if along(t, 1) => Some(Trunnion::Xyzbc),
            _ => None,
        }
    }

    /// The location errors of the rotary axes the kinematics parameters carry:
    /// the offsets of each axis line across its direction.
    pub fn carried(self) -> [ErrorName; 4] {
        let (t, off) = match self {
            Trunnion::Xyzac => ("A", [Component::Ty, Component::Tz]),
            Trunnion::Xyzbc => ("B", [Component::Tx, Component::Tz]),
        };
        [
            ErrorName::location(off[0], t),
            ErrorName::location(off[1], t),
            ErrorName::location(Component::Tx, "C"),
            ErrorName::location(Component::Ty, "C"),
        ]
    }
}

/// The trunnion parameters of LinuxCNC's `xyzac-trt-kins` / `xyzbc-trt-kins`
/// (HAL pins of the same names), mm, in joint coordinates (the tool tip's
/// position in the machine frame less its position at the zero pose).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrtParameters {
    /// `x-rot-point`.
    pub x_rot_point: f64,
    /// `y-rot-point`.
    pub y_rot_point: f64,
    /// `z-rot-point`.
    pub z_rot_point: f64,
    /// `x-offset` (used by xyzbc).
    pub x_offset: f64,
    /// `y-offset` (used by xyzac).
    pub y_offset: f64,
    /// `z-offset`.
    pub z_offset: f64,
    /// `tool-offset`: 0, the machine file's tool tip is the controlled point.
    pub tool_offset: f64,
}

/// A point of the line axis `axis` turns the table about, in the machine
/// frame, found as the fixed point of the table's motion when that axis
/// turns by 90° from the zero pose.
fn rotation_line_point(k: &Kinematics, n_axes: usize, axis: usize) -> Vector3<f64> {
    let q0 = vec![0.0; n_axes];
    let mut q1 = q0.clone();
    q1[axis] = 90.0;
    let rel = k
        .workpiece_frame(&q1)
        .compose(&k.workpiece_frame(&q0).inverse());
    let a: Matrix3<f64> = rel.r - Matrix3::identity();
    let svd = a.svd(true, true);
    svd.solve(&(-rel.t), 1e-12)
        .unwrap_or_else(|_| Vector3::zeros())
}

impl TrtParameters {
    /// The parameters of `machine` (its rotary axis lines as the model puts them).
    pub fn of(machine: &Machine, trunnion: Trunnion) -> TrtParameters {
        let k = Kinematics::new(machine);
        let n = machine.n_axes();
        let tilt = machine.workpiece_chain[0];
        let c = machine.workpiece_chain[1];
        let tip = machine.tool_tip;
        let pt = rotation_line_point(&k, n, tilt) - tip;
        let pc = rotation_line_point(&k, n, c) - tip;
        match trunnion {
            Trunnion::Xyzac => TrtParameters {
                x_rot_point: pc.x,
                y_rot_point: pc.y,
                z_rot_point: pt.z,
                x_offset: 0.0,
                y_offset: pt.y - pc.y,
                z_offset: 0.0,
                tool_offset: 0.0,
            },
            Trunnion::Xyzbc => TrtParameters {
                x_rot_point: pc.x,
                y_rot_point: pc.y,
                z_rot_point: pt.z,
                x_offset: pt.x - pc.x,
                y_offset: 0.0,
                z_offset: 0.0,
                tool_offset: 0.0,
            },
        }
    }

    /// The `setp` lines of `kinematics.hal`.
    pub fn hal(&self, trunnion: Trunnion) -> String {
        let k = trunnion.kins();
        let mut s = format!(
            "# Trunnion kinematics parameters written by mtwin export ({k}), mm.\n\
             # The rotary axis lines as the identified model puts them; remove the\n\
             # tool-offset line if your configuration nets it to motion.tooloffset.z.\n"
        );
        for (pin, v) in [
            ("x-rot-point", self.x_rot_point),
            ("y-rot-point", self.y_rot_point),
            ("z-rot-point", self.z_rot_point),
            ("x-offset", self.x_offset),
            ("y-offset", self.y_offset),
            ("z-offset", self.z_offset),
            ("tool-offset", self.tool_offset),
        ] {
            s.push_str(&format!("setp {k}.{pin} {}\n", fixed(v, 6)));
        }
        s
    }
}

/// The rows of a compensation file: `(nominal, forward, reverse)`. Like
/// LinuxCNC, reading stops at the first line that is not three numbers;
/// unlike it, such a line before the end is an error here (it would silently
/// drop the rest of the table), as are positions that do not ascend and more
/// than [`MAX_LINES`] lines.
pub fn parse(text: &str, file: &Path) -> Result<Vec<[f64; 3]>, Diagnostic> {
    let mut rows: Vec<[f64; 3]> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.is_empty() && text.lines().skip(n).all(|l| l.trim().is_empty()) {
            break;
        }
        let v: Vec<f64> = t.iter().filter_map(|s| parse_number(s)).collect();
        if t.len() != 3 || v.len() != 3 {
            return Err(Diagnostic::at(
                file,
                n + 1,
                1,
                "a compensation line is three numbers: nominal forward reverse (LinuxCNC stops reading here)",
            ));
        }
        if let Some(last) = rows.last()
            && v[0] <= last[0]
        {
            return Err(Diagnostic::at(
                file,
                n + 1,
                1,
                "nominal positions must ascend from line to line",
            ));
        }
        rows.push([v[0], v[1], v[2]]);
    }
    if rows.len() > MAX_LINES {
        return Err(Diagnostic::whole(
            file,
            format!("{} lines: LinuxCNC reads at most {MAX_LINES}", rows.len()),
        ));
    }
    Ok(rows)
}

/// Text of a compensation file (type 1): `nominal correction correction`.
pub fn write(q: &[f64], c: &[f64]) -> String {
    let mut s = String::new();
    for (q, c) in q.iter().zip(c) {
        let c = fixed(*c, 9);
        s.push_str(&format!("{} {c} {c}\n", fixed(*q, 6)));
    }
    s
}

/// Read the `comp_<AXIS>.txt` files of `dir` back into a copy of `machine`:
/// each file sets the positioning error of its linear axis (along the axis'
/// own direction) to the table that its correction cancels on the reference
/// line, as an [`ErrorFunction::Table`]. The forward column is used.
pub fn import(dir: &Path, machine: &Machine) -> Result<Machine, Diagnostic> {
    let mut m = machine.clone();
    let q0 = reference_pose(machine, &Default::default());
    let nominal = Kinematics::new(&machine.nominal());
    for i in linear_axes(machine) {
        let name = machine.axes[i].name.clone();
        let path = dir.join(comp_file_name(&name));
        if !path.exists() {
            continue;
        }
        let text = std::fs::read_to_string(&path)
            .map_err(|e| Diagnostic::whole(&path, format!("cannot read: {e}")))?;
        let rows = parse(&text, &path)?;
        if rows.len() < 2 {
            return Err(Diagnostic::whole(&path, "a table needs at least two lines"));
        }
        let (comp, _) = linear_letter(machine, i).ok_or_else(|| {
            Diagnostic::whole(
                &path,
                format!("axis {name} does not run along a machine axis"),
            )
        })?;
        // Tip motion per mm of joint, and per mm of the positioning error.
        let mut qp = q0.clone();
        qp[i] += 1.0;
        let jv = nominal.pose(&qp).tip - nominal.pose(&q0).tip;
        let mut unit = machine.nominal();
        unit.axes[i].errors.pdge[comp.index()] = Some(ErrorFunction::Constant(1.0));
        let gv = Kinematics::new(&unit).pose(&q0).tip - nominal.pose(&q0).tip;
        let ratio = jv.dot(&gv) / gv.dot(&gv);
        m.axes[i].errors.pdge[comp.index()] = Some(ErrorFunction::Table {
            q: rows.iter().map(|r| r[0]).collect(),
            e: rows.iter().map(|r| -r[1] * ratio).collect(),
        });
    }
    Ok(m)
}

/// LinuxCNC joint numbers: the axes in the order X Y Z A B C (as
/// `coordinates=XYZAC` numbers them).
pub(crate) fn joint_numbers(machine: &Machine) -> Vec<(usize, usize)> {
    let mut idx: Vec<usize> = (0..machine.n_axes()).collect();
    let order = |i: &usize| {
        "XYZABCUVW"
            .find(machine.axes[*i].name.as_str())
            .unwrap_or(99)
    };
    idx.sort_by_key(order);
    idx.into_iter().enumerate().map(|(j, i)| (i, j)).collect()
}

/// `--to linuxcnc`.
pub(crate) fn export(machine: &Machine, opts: &ExportOptions) -> Result<Exported, ExportError> {
    let lin = linear_axes(machine);
    if lin.is_empty() {
        return Err(ExportError::Unsupported {
            format: Format::LinuxCnc.name(),
            reason: "the machine has no linear axis".into(),
        });
    }
    let trunnion = Trunnion::of(machine);
    let mut kin = machine.nominal();
    let mut carried_names: Vec<ErrorName> = Vec::new();
    if let Some(t) = trunnion {
        for n in t.carried() {
            let i = machine.axis_index(&n.axis).expect("trunnion axis");
            kin.axes[i].errors.location[n.component.index()] =
                machine.axes[i].errors.location[n.component.index()];
            carried_names.push(n);
        }
    }
    let joints = joint_numbers(machine);
    let mut tables = line_tables(machine, &kin, opts, MAX_LINES, |i| vec![i])?;
    tables.sort_by_key(|t| {
        joints
            .iter()
            .find(|(i, _)| *i == t.input)
            .map_or(0, |p| p.1)
    });
    let mut files = Vec::new();
    let mut carried = Vec::new();
    let mut readme = format!(
        "Compensation for {} written by mtwin export.\n\n\
         Copy the comp_<AXIS>.txt files next to the machine's .ini file and add\n\
         to the [JOINT_n] section of each corrected joint (joint numbers below\n\
         assume coordinates in the order XYZABC; change them to your configuration's):\n\n",
        machine.name
    );
    for t in &tables {
        let name = &machine.axes[t.input].name;
        let file = comp_file_name(name);
        files.push((file.clone(), write(&t.q, &t.c)));
        let j = joints
            .iter()
            .find(|(i, _)| *i == t.input)
            .map_or(0, |p| p.1);
        readme.push_str(&format!(
            "[JOINT_{j}]\nCOMP_FILE = {file}\nCOMP_FILE_TYPE = 1\n\n"
        ));
        carried.push(format!(
            "{file}: correction of {name} along {name} over {name} ({} points)",
            t.q.len()
        ));
        if let Some((c, _)) = linear_letter(machine, t.input) {
            carried_names.push(ErrorName::pdge(c, name));
        }
    }
    readme.push_str(
        "COMP_FILE_TYPE 1: each line is `nominal forward reverse`, the corrections\n\
         added to the joint command. BACKLASH is ignored for a joint with a\n\
         COMP_FILE. Each table is what the identified model predicts along the\n\
         reference line of its axis (the other axes in the middle of their\n\
         ranges, rotary axes at 0).\n",
    );
    if let Some(t) = trunnion {
        let p = TrtParameters::of(&kin, t);
        files.push(("kinematics.hal".to_string(), p.hal(t)));
        readme.push_str(&format!(
            "\nkinematics.hal: the {} parameters (rotary axis lines). Load it after\n\
             the kinematics module, e.g. in [HAL] HALFILE = kinematics.hal, and keep\n\
             conventional-directions as your configuration sets it.\n",
            t.kins()
        ));
        carried.push(format!(
            "kinematics.hal: {} ({})",
            t.carried().map(|n| n.to_string()).join(", "),
            t.kins()
        ));
    }
    files.push(("README.txt".to_string(), readme));
    Ok(Exported {
        format: Format::LinuxCnc,
        files,
        carried,
        dropped: dropped_except(machine, &carried_names),
        correction: Correction::Joint {
            kinematics: kin,
            tables,
        },
    })
}
