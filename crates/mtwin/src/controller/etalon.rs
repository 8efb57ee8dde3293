//! Etalon exchange format ("vendor" variant), as read by the Beckhoff / ISG
//! volumetric compensation (`file_format[j] ETALON_EXCHANGE`).
//!
//! INI-like: each parameter is a block opened by its name in brackets. A
//! location error (`[C0B]`, mtwin's `EC0B`) holds `VALUE = number`; a
//! component error (`[EXY]`) holds `Gridpoints = { … }`, rows of `position
//! value` inside the braces. `//` starts a comment. Values in mm and rad,
//! positions in mm or degree.
//!
//! **Carries** the same as `ISG_CSV`: every position-dependent error as a
//! table over its axis and every location error.

use std::path::Path;

use super::isg_csv::{self, column_name, volumetric_name};
use super::{
    ExportError, ExportOptions, Exported, Format, check_iso_axes, fixed, nonzero_errors,
    parse_number, tabulated,
};
use crate::io::Diagnostic;
use crate::model::{Component, ErrorFunction, ErrorName, Machine};

/// Name of the Etalon file `--to etalon` writes (with [`isg_csv::LIS_FILE`]).
pub const ETALON_FILE: &str = "volcomp.etalon";

/// One parameter of an Etalon file.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// The name in brackets (`C0B`, `EXY`).
    pub name: String,
    /// `VALUE = v`.
    pub value: Option<f64>,
    /// `Gridpoints = { q v … }`.
    pub grid: Vec<(f64, f64)>,
    /// 1-based line of the `[name]`.
    pub line: usize,
}

/// Read the parameters of an Etalon exchange file.
pub fn parse(text: &str, file: &Path) -> Result<Vec<Parameter>, Diagnostic> {
    let mut out: Vec<Parameter> = Vec::new();
    let mut in_grid = false;
    for (n, raw) in text.lines().enumerate() {
        let line_no = n + 1;
        let body = raw.find("//").map_or(raw, |k| &raw[..k]).trim();
        if body.is_empty() {
            continue;
        }
        if in_grid {
            if body.starts_with('}') {
                in_grid = false;
                continue;
            }
            let t: Vec<&str> = body.split_whitespace().collect();
            let (Some(q), Some(v)) = (
                t.first().and_then(|s| parse_number(s)),
                t.get(1).and_then(|s| parse_number(s)),
            ) else {
                return Err(Diagnostic::at(
                    file,
                    line_no,
                    raw.len() - raw.trim_start().len() + 1,
                    "a grid point is two numbers: position value",
                ));
            };
            if t.len() != 2 {
                return Err(Diagnostic::at_line(
                    file,
                    line_no,
                    "a grid point is two numbers: position value",
                ));
            }
            out.last_mut()
                .expect("grid inside a block")
                .grid
                .push((q, v));
            continue;
        }
        if let Some(rest) = body.strip_prefix('[') {
            let name = rest.strip_suffix(']').ok_or_else(|| {
                Diagnostic::at_line(file, line_no, "a block name must end with `]`")
            })?;
            out.push(Parameter {
                name: name.trim().to_string(),
                value: None,
                grid: Vec::new(),
                line: line_no,
            });
            continue;
        }
        let Some((key, value)) = body.split_once('=') else {
            return Err(Diagnostic::at_line(
                file,
                line_no,
                format!("expected `[NAME]`, `VALUE = …` or `Gridpoints = {{`, found `{body}`"),
            ));
        };
        let Some(p) = out.last_mut() else {
            return Err(Diagnostic::at_line(
                file,
                line_no,
                "a value before any `[NAME]` block",
            ));
        };
        match key.trim().to_ascii_lowercase().as_str() {
            "value" => {
                p.value = Some(parse_number(value.trim()).ok_or_else(|| {
                    Diagnostic::at_line(
                        file,
                        line_no,
                        format!("`{}` is not a finite number", value.trim()),
                    )
                })?);
            }
            "gridpoints" => {
                let v = value.trim();
                if !v.starts_with('{') {
                    return Err(Diagnostic::at_line(
                        file,
                        line_no,
                        "Gridpoints must open with `{`",
                    ));
                }
                in_grid = !v.ends_with('}');
            }
            other => {
                return Err(Diagnostic::at_line(
                    file,
                    line_no,
                    format!("unknown key `{other}` (VALUE and Gridpoints are read)"),
                ));
            }
        }
    }
    if in_grid {
        return Err(Diagnostic::whole(
            file,
            "the last Gridpoints block is not closed by `}`",
        ));
    }
    Ok(out)
}

/// Put the parameters into `machine`: grid tables become
/// [`ErrorFunction::Table`]s of the component error, values set location errors.
pub fn apply(machine: &mut Machine, params: &[Parameter], file: &Path) -> Result<(), Diagnostic> {
    for p in params {
        let n = volumetric_name(&p.name).ok_or_else(|| {
            Diagnostic::at_line(
                file,
                p.line,
                format!("`[{}]` is not an ISO 230-1 error name", p.name),
            )
        })?;
        let i = machine.axis_index(&n.axis).ok_or_else(|| {
            Diagnostic::at_line(
                file,
                p.line,
                format!(
                    "`[{}]` names axis {}, which the machine does not have",
                    p.name, n.axis
                ),
            )
        })?;
        if n.is_location() {
            let v = p.value.ok_or_else(|| {
                Diagnostic::at_line(file, p.line, format!("`[{}]` has no VALUE", p.name))
            })?;
            machine.axes[i].errors.location[n.component.index()] = v;
        } else {
            if p.grid.len() < 2 {
                return Err(Diagnostic::at_line(
                    file,
                    p.line,
                    format!("`[{}]` needs Gridpoints with at least two points", p.name),
                ));
            }
            if p.grid.windows(2).any(|w| w[1].0 <= w[0].0) {
                return Err(Diagnostic::at_line(
                    file,
                    p.line,
                    format!("the Gridpoints positions of `[{}]` must increase", p.name),
                ));
            }
            machine.axes[i].errors.pdge[n.component.index()] = Some(ErrorFunction::Table {
                q: p.grid.iter().map(|g| g.0).collect(),
                e: p.grid.iter().map(|g| g.1).collect(),
            });
        }
    }
    Ok(())
}

/// Text of a machine whose PDGEs are tables (see [`super::tabulated`]).
pub fn write(tab: &Machine) -> String {
    let mut s = format!(
        "// Etalon exchange parameters of {} written by mtwin export.\n\
         // Errors in ISO 230-1 names, mtwin's sign convention (docs/machine-model.md).\n",
        tab.name
    );
    for n in nonzero_errors(tab).iter().filter(|n| n.is_location()) {
        let v = tab.error_value(n, 0.0).unwrap_or(0.0);
        let d = if n.component.is_rotation() { 12 } else { 9 };
        s.push_str(&format!("[{}]\nVALUE = {}\n", column_name(n), fixed(v, d)));
    }
    for ax in &tab.axes {
        for c in Component::ALL {
            let Some(ErrorFunction::Table { q, e }) = &ax.errors.pdge[c.index()] else {
                continue;
            };
            let name = ErrorName::pdge(c, &ax.name).to_string();
            let d = if c.is_rotation() { 12 } else { 9 };
            s.push_str(&format!("[{name}]\nGridpoints = {{\n"));
            for (q, e) in q.iter().zip(e) {
                s.push_str(&format!("    {} {}\n", fixed(*q, 6), fixed(*e, d)));
            }
            s.push_str(&format!("}}  // end of {name}\n"));
        }
    }
    s
}

/// `--to etalon`.
pub(crate) fn export(machine: &Machine, opts: &ExportOptions) -> Result<Exported, ExportError> {
    check_iso_axes(machine, Format::Etalon)?;
    let tab = tabulated(machine, opts, Format::Etalon.max_points())?;
    let files = vec![
        (
            isg_csv::LIS_FILE.to_string(),
            isg_csv::lis_text(machine, &[(ETALON_FILE, "ETALON_EXCHANGE")]),
        ),
        (ETALON_FILE.to_string(), write(&tab)),
    ];
    Ok(Exported::volumetric(Format::Etalon, files, machine, tab))
}
