//! Siemens SINUMERIK 840D sl leadscrew / encoder error compensation (EEC).
//!
//! An initialisation program `%_N_AX_EEC_INI` of system-variable
//! assignments: `$AA_ENC_COMP[e,N,AXi]` the compensation value at point `N`
//! of encoder `e` of machine axis `AXi`, with `$AA_ENC_COMP_STEP`, `_MIN`,
//! `_MAX` (the point spacing and the first and last positions, mm) and
//! `_IS_MODULO`; the program ends with `M17`. A positive value moves the axis
//! in the negative direction, so the value is the error to take out. The
//! number of points is set by machine data MD38000, the compensation is
//! enabled by MD32700 (both outside this file).
//!
//! **Carries** per linear axis one correction along that axis as a function
//! of its own position, the same content as a LinuxCNC compensation file (the
//! model's prediction along the axis' reference line); nothing across the
//! axis (see [`super::siemens_cec`]).

use std::path::Path;

use super::{
    Correction, ExportError, ExportOptions, Exported, Format, dropped_except, fixed, line_tables,
    linear_axes, linear_letter, parse_number,
};
use crate::io::Diagnostic;
use crate::model::{ErrorName, Machine};

/// Name of the file `--to siemens-eec` writes.
pub const EEC_FILE: &str = "AX_EEC.INI";

/// One assignment `NAME[arg,…]=value` of a SINUMERIK initialisation program.
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    /// The variable, e.g. `$AA_ENC_COMP`.
    pub name: String,
    /// The indices in brackets, as written (`0`, `12`, `AX1`).
    pub args: Vec<String>,
    /// The right-hand side, as written.
    pub value: String,
    /// 1-based line.
    pub line: usize,
}

/// Read the assignments of an initialisation program; `%_N_…` headers,
/// `CHANDATA(…)`, `M17`/`M30` and `;` comments are skipped.
pub fn parse_assignments(text: &str, file: &Path) -> Result<Vec<Assignment>, Diagnostic> {
    let mut out = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = raw.split(';').next().unwrap_or("").trim();
        if line.is_empty()
            || line.starts_with('%')
            || line.starts_with("CHANDATA")
            || line == "M17"
            || line == "M30"
        {
            continue;
        }
        let bad = |m: &str| Diagnostic::at(file, n + 1, raw.len() - raw.trim_start().len() + 1, m);
        let (lhs, rhs) = line
            .split_once('=')
            .ok_or_else(|| bad("expected an assignment `$NAME[…]=value`"))?;
        let (name, rest) = lhs
            .trim()
            .split_once('[')
            .ok_or_else(|| bad("expected `[` after the variable name"))?;
        let args = rest
            .strip_suffix(']')
            .ok_or_else(|| bad("expected `]` before `=`"))?;
        out.push(Assignment {
            name: name.trim().to_string(),
            args: args.split(',').map(|a| a.trim().to_string()).collect(),
            value: rhs.trim().to_string(),
            line: n + 1,
        });
    }
    Ok(out)
}

/// A number on the right-hand side of an assignment.
pub(crate) fn number(a: &Assignment, file: &Path) -> Result<f64, Diagnostic> {
    parse_number(&a.value).ok_or_else(|| {
        Diagnostic::at_line(
            file,
            a.line,
            format!("`{}` is not a finite number", a.value),
        )
    })
}

/// An index in brackets.
pub(crate) fn index(a: &Assignment, k: usize, file: &Path) -> Result<usize, Diagnostic> {
    a.args
        .get(k)
        .and_then(|s| s.parse::<usize>().ok())
        .ok_or_else(|| {
            Diagnostic::at_line(
                file,
                a.line,
                format!("{}: index {} must be a whole number", a.name, k + 1),
            )
        })
}

/// One EEC table read back.
#[derive(Debug, Clone, PartialEq)]
pub struct EecTable {
    /// Machine axis identifier (`AX1`).
    pub axis: String,
    /// Encoder index.
    pub encoder: usize,
    /// First position, mm.
    pub min: f64,
    /// Last position, mm.
    pub max: f64,
    /// Spacing, mm.
    pub step: f64,
    /// Compensation values at `min + k·step` (the error: positive moves the axis negative), mm.
    pub values: Vec<f64>,
    /// 1-based line of the table's first assignment.
    pub line: usize,
}

/// Read an EEC initialisation program.
pub fn parse(text: &str, file: &Path) -> Result<Vec<EecTable>, Diagnostic> {
    let mut tables: Vec<EecTable> = Vec::new();
    for a in parse_assignments(text, file)? {
        let axis = a.args.last().cloned().unwrap_or_default();
        let encoder = index(&a, 0, file)?;
        let pos = match tables
            .iter()
            .position(|t| t.axis == axis && t.encoder == encoder)
        {
            Some(p) => p,
            None => {
                tables.push(EecTable {
                    axis: axis.clone(),
                    encoder,
                    min: f64::NAN,
                    max: f64::NAN,
                    step: f64::NAN,
                    values: Vec::new(),
                    line: a.line,
                });
                tables.len() - 1
            }
        };
        let t = &mut tables[pos];
        match a.name.as_str() {
            "$AA_ENC_COMP" => {
                let k = index(&a, 1, file)?;
                if k != t.values.len() {
                    return Err(Diagnostic::at_line(
                        file,
                        a.line,
                        format!(
                            "point {k} of {axis} out of order (expected {})",
                            t.values.len()
                        ),
                    ));
                }
                t.values.push(number(&a, file)?);
            }
            "$AA_ENC_COMP_STEP" => t.step = number(&a, file)?,
            "$AA_ENC_COMP_MIN" => t.min = number(&a, file)?,
            "$AA_ENC_COMP_MAX" => t.max = number(&a, file)?,
            "$AA_ENC_COMP_IS_MODULO" => {}
            other => {
                return Err(Diagnostic::at_line(
                    file,
                    a.line,
                    format!("`{other}` is not an EEC variable"),
                ));
            }
        }
    }
    Ok(tables)
}

/// Machine axis identifier of axis index `i` (`AX1` for the first of X, Y, Z…).
pub(crate) fn ax_id(machine: &Machine, i: usize) -> String {
    let mut idx: Vec<usize> = (0..machine.n_axes()).collect();
    idx.sort_by_key(|&k| {
        "XYZABCUVW"
            .find(machine.axes[k].name.as_str())
            .unwrap_or(99)
    });
    let n = idx.iter().position(|&k| k == i).unwrap_or(i);
    format!("AX{}", n + 1)
}

/// `--to siemens-eec`.
pub(crate) fn export(machine: &Machine, opts: &ExportOptions) -> Result<Exported, ExportError> {
    if linear_axes(machine).is_empty() {
        return Err(ExportError::Unsupported {
            format: Format::SiemensEec.name(),
            reason: "the machine has no linear axis".into(),
        });
    }
    let kin = machine.nominal();
    let tables = line_tables(machine, &kin, opts, Format::SiemensEec.max_points(), |i| {
        vec![i]
    })?;
    let mut s = format!(
        "%_N_AX_EEC_INI\n\
         ; Leadscrew/encoder error compensation of {} written by mtwin export.\n\
         ; Values in mm: the error of the axis (a positive value moves the axis negative).\n\
         ; Set MD38000 to at least the number of points, enable with MD32700 = 1.\n",
        machine.name
    );
    let mut carried = Vec::new();
    let mut carried_names = Vec::new();
    s.push_str("CHANDATA(1)\n");
    for t in &tables {
        let ax = ax_id(machine, t.input);
        let name = &machine.axes[t.input].name;
        s.push_str(&format!("; {ax} = {name}, {} points\n", t.q.len()));
        for (k, c) in t.c.iter().enumerate() {
            s.push_str(&format!("$AA_ENC_COMP[0,{k},{ax}]={}\n", fixed(-c, 6)));
        }
        let step = (t.q[t.q.len() - 1] - t.q[0]) / (t.q.len() - 1) as f64;
        s.push_str(&format!("$AA_ENC_COMP_STEP[0,{ax}]={}\n", fixed(step, 6)));
        s.push_str(&format!("$AA_ENC_COMP_MIN[0,{ax}]={}\n", fixed(t.q[0], 6)));
        s.push_str(&format!(
            "$AA_ENC_COMP_MAX[0,{ax}]={}\n",
            fixed(t.q[t.q.len() - 1], 6)
        ));
        s.push_str(&format!("$AA_ENC_COMP_IS_MODULO[0,{ax}]=0\n"));
        carried.push(format!(
            "{ax} ({name}): correction along {name} over {name} ({} points)",
            t.q.len()
        ));
        if let Some((c, _)) = linear_letter(machine, t.input) {
            carried_names.push(ErrorName::pdge(c, name));
        }
    }
    s.push_str("M17\n");
    // The controller sees the table rounded to the file's 6 decimals (1 nm).
    let tables = tables
        .into_iter()
        .map(|mut t| {
            t.c.iter_mut()
                .for_each(|c| *c = -fixed(-*c, 6).parse::<f64>().unwrap_or(-*c));
            t
        })
        .collect();
    Ok(Exported {
        format: Format::SiemensEec,
        files: vec![(EEC_FILE.to_string(), s)],
        carried,
        dropped: dropped_except(machine, &carried_names),
        correction: Correction::Joint {
            kinematics: kin,
            tables,
        },
    })
}
