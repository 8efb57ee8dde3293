//! Siemens SINUMERIK 840D sl sag and angularity compensation (CEC, the
//! interpolatory compensation between two axes).
//!
//! An initialisation program of system-variable assignments, one table `t`
//! each: `$AN_CEC[t,N]` the compensation value at point `N` (mm, added to the
//! output axis), `$AN_CEC_INPUT_AXIS[t]` the base axis whose position is the
//! argument, `$AN_CEC_OUTPUT_AXIS[t]` the compensated axis, `$AN_CEC_STEP`,
//! `_MIN`, `_MAX` (spacing, first and last position, mm), `_DIRECTION` (0:
//! both directions of travel), `_MULT_BY_TABLE` (0: no product with another
//! table) and `_IS_MODULO`; the program ends with `M17`. The number of points
//! is set by machine data MD18342 (outside this file).
//!
//! **Carries** per ordered pair of linear axes (input ≠ output) the
//! correction of the output axis as a function of the input axis' position:
//! straightness, sag and squareness as the model predicts them along the
//! input axis' reference line, zero at the reference pose. It does not carry
//! the positioning along an axis itself (that is EEC's, [`super::siemens_eec`]).

use std::path::Path;

use super::siemens_eec::{ax_id, index, number, parse_assignments};
use super::{
    Correction, ExportError, ExportOptions, Exported, Format, dropped_except, fixed, line_tables,
    linear_axes, linear_letter,
};
use crate::io::Diagnostic;
use crate::model::{ErrorName, Machine};

/// Name of the file `--to siemens-cec` writes.
pub const CEC_FILE: &str = "NC_CEC.INI";

/// One CEC table read back.
#[derive(Debug, Clone, PartialEq)]
pub struct CecTable {
    /// Table index `t`.
    pub table: usize,
    /// Base (input) axis identifier.
    pub input: String,
    /// Compensated (output) axis identifier.
    pub output: String,
    /// First position, mm.
    pub min: f64,
    /// Last position, mm.
    pub max: f64,
    /// Spacing, mm.
    pub step: f64,
    /// 0, 1 or −1.
    pub direction: i32,
    /// Compensation values at `min + k·step`, mm, added to the output axis.
    pub values: Vec<f64>,
    /// `$AN_CEC_MULT_BY_TABLE`: 0, or the table this one is multiplied by.
    pub mult_by_table: usize,
    /// 1-based line of the table's first assignment.
    pub line: usize,
}

/// Read a CEC initialisation program.
pub fn parse(text: &str, file: &Path) -> Result<Vec<CecTable>, Diagnostic> {
    let mut tables: Vec<CecTable> = Vec::new();
    for a in parse_assignments(text, file)? {
        let t = index(&a, 0, file)?;
        let pos = match tables.iter().position(|x| x.table == t) {
            Some(p) => p,
            None => {
                tables.push(CecTable {
                    table: t,
                    input: String::new(),
                    output: String::new(),
                    min: f64::NAN,
                    max: f64::NAN,
                    step: f64::NAN,
                    direction: 0,
                    values: Vec::new(),
                    mult_by_table: 0,
                    line: a.line,
                });
                tables.len() - 1
            }
        };
        let tb = &mut tables[pos];
        match a.name.as_str() {
            "$AN_CEC" => {
                let k = index(&a, 1, file)?;
                if k != tb.values.len() {
                    return Err(Diagnostic::at_line(
                        file,
                        a.line,
                        format!(
                            "point {k} of table {t} out of order (expected {})",
                            tb.values.len()
                        ),
                    ));
                }
                tb.values.push(number(&a, file)?);
            }
            "$AN_CEC_INPUT_AXIS" => tb.input = a.value.clone(),
            "$AN_CEC_OUTPUT_AXIS" => tb.output = a.value.clone(),
            "$AN_CEC_STEP" => tb.step = number(&a, file)?,
            "$AN_CEC_MIN" => tb.min = number(&a, file)?,
            "$AN_CEC_MAX" => tb.max = number(&a, file)?,
            "$AN_CEC_DIRECTION" => tb.direction = number(&a, file)? as i32,
            "$AN_CEC_MULT_BY_TABLE" => {
                let v = number(&a, file)?;
                if v < 0.0 || v.fract() != 0.0 {
                    return Err(Diagnostic::at_line(
                        file,
                        a.line,
                        format!(
                            "$AN_CEC_MULT_BY_TABLE must be a table number, got {}",
                            a.value
                        ),
                    ));
                }
                tb.mult_by_table = v as usize;
            }
            "$AN_CEC_IS_MODULO" => {}
            other => {
                return Err(Diagnostic::at_line(
                    file,
                    a.line,
                    format!("`{other}` is not a CEC variable"),
                ));
            }
        }
    }
    Ok(tables)
}

/// `--to siemens-cec`.
pub(crate) fn export(machine: &Machine, opts: &ExportOptions) -> Result<Exported, ExportError> {
    let lin = linear_axes(machine);
    if lin.len() < 2 {
        return Err(ExportError::Unsupported {
            format: Format::SiemensCec.name(),
            reason: "the machine needs two linear axes for a table between axes".into(),
        });
    }
    let kin = machine.nominal();
    let tables = line_tables(machine, &kin, opts, Format::SiemensCec.max_points(), |i| {
        lin.iter().copied().filter(|&o| o != i).collect()
    })?;
    let mut s = format!(
        "%_N_NC_CEC_INI\n\
         ; Sag/angularity compensation of {} written by mtwin export.\n\
         ; Values in mm, added to the output axis. Set MD18342 to at least the\n\
         ; number of points; enable each table with $SN_CEC_TABLE_ENABLE.\n",
        machine.name
    );
    s.push_str("CHANDATA(1)\n");
    let mut carried = Vec::new();
    let mut carried_names = Vec::new();
    for (t, tb) in tables.iter().enumerate() {
        let (ia, oa) = (ax_id(machine, tb.input), ax_id(machine, tb.output));
        let (iname, oname) = (&machine.axes[tb.input].name, &machine.axes[tb.output].name);
        s.push_str(&format!(
            "; table {t}: {oname} ({oa}) over {iname} ({ia})\n"
        ));
        for (k, c) in tb.c.iter().enumerate() {
            s.push_str(&format!("$AN_CEC[{t},{k}]={}\n", fixed(*c, 6)));
        }
        let n = tb.q.len();
        let step = (tb.q[n - 1] - tb.q[0]) / (n - 1) as f64;
        s.push_str(&format!("$AN_CEC_INPUT_AXIS[{t}]={ia}\n"));
        s.push_str(&format!("$AN_CEC_OUTPUT_AXIS[{t}]={oa}\n"));
        s.push_str(&format!("$AN_CEC_STEP[{t}]={}\n", fixed(step, 6)));
        s.push_str(&format!("$AN_CEC_MIN[{t}]={}\n", fixed(tb.q[0], 6)));
        s.push_str(&format!("$AN_CEC_MAX[{t}]={}\n", fixed(tb.q[n - 1], 6)));
        s.push_str(&format!("$AN_CEC_DIRECTION[{t}]=0\n"));
        s.push_str(&format!("$AN_CEC_MULT_BY_TABLE[{t}]=0\n"));
        s.push_str(&format!("$AN_CEC_IS_MODULO[{t}]=0\n"));
        carried.push(format!("table {t}: {oname} over {iname} ({n} points)"));
        if let Some((c, _)) = linear_letter(machine, tb.output) {
            carried_names.push(ErrorName::pdge(c, iname));
        }
    }
    s.push_str("M17\n");
    let tables = tables
        .into_iter()
        .map(|mut t| {
            t.c.iter_mut()
                .for_each(|c| *c = fixed(*c, 6).parse::<f64>().unwrap_or(*c));
            t
        })
        .collect();
    Ok(Exported {
        format: Format::SiemensCec,
        files: vec![(CEC_FILE.to_string(), s)],
        carried,
        dropped: dropped_except(machine, &carried_names),
        correction: Correction::Joint {
            kinematics: kin,
            tables,
        },
    })
}
