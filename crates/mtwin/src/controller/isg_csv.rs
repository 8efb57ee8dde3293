//! Beckhoff TwinCAT / ISG volumetric compensation: the `ISG_CSV` parameter
//! file and the compensation list (`.lis`) that names it.
//!
//! An `ISG_CSV` file holds blocks of whitespace-separated columns. A block
//! starts with a header row: argument axes first (`X`), then parameter names
//! — the component errors of an axis in ISO 230-1 names (`EXX EYX EZX EAX EBX
//! ECX`) or location errors without the leading `E` (`Y0A` is mtwin's
//! `EY0A`). The rows below give the argument (mm, or degree for a rotary
//! axis) and the values (mm for translations, rad for rotations). `//` starts
//! a comment, a line starting with `#` opens a new block with its own header.
//!
//! **Carries** every position-dependent error of every axis as a table and
//! every location error: the whole ISO 230-1 model of a serial machine with
//! three linear axes X, Y, Z and up to three rotary axes A, B, C. The control
//! corrects the tool position (not its orientation) with the linear axes.
//! Switched on in the part program with `#VOLCOMP ON`.

use std::path::Path;

use super::{
    ExportError, ExportOptions, Exported, Format, check_iso_axes, fixed, nonzero_errors,
    parse_number, tabulated,
};
use crate::io::Diagnostic;
use crate::model::{Chain, Component, ErrorFunction, ErrorName, Machine};

/// Name of the compensation list `--to isg` writes.
pub const LIS_FILE: &str = "volcomp.lis";
/// Name of the `ISG_CSV` parameter file `--to isg` writes.
pub const CSV_FILE: &str = "volcomp.csv";

/// One block of an `ISG_CSV` file: its header names and its rows of numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// Column names, argument axes first.
    pub header: Vec<String>,
    /// Rows, as many numbers as header names each.
    pub rows: Vec<Vec<f64>>,
    /// 1-based line of the header.
    pub line: usize,
}

/// Strip a `//` comment.
fn strip_comment(line: &str) -> &str {
    line.find("//").map_or(line, |k| &line[..k])
}

/// Column (1-based, in characters) of byte offset `at` in `line`.
fn col(line: &str, at: usize) -> usize {
    line[..at].chars().count() + 1
}

/// Whitespace-separated tokens with their byte offsets.
fn tokens(line: &str) -> impl Iterator<Item = (usize, &str)> {
    line.split_whitespace()
        .map(move |t| (t.as_ptr() as usize - line.as_ptr() as usize, t))
}

/// Read the blocks of an `ISG_CSV` file. `file` names it in messages.
pub fn parse(text: &str, file: &Path) -> Result<Vec<Block>, Diagnostic> {
    let mut blocks: Vec<Block> = Vec::new();
    let mut open = true; // the next non-empty line is a header
    for (n, raw) in text.lines().enumerate() {
        let line_no = n + 1;
        let body = strip_comment(raw);
        let trimmed = body.trim_start();
        if let Some(rest) = trimmed.strip_prefix('#') {
            open = true;
            if !rest.trim().is_empty() {
                // `#` followed by a header on the same line.
                let header: Vec<String> = rest.split_whitespace().map(String::from).collect();
                blocks.push(Block {
                    header,
                    rows: Vec::new(),
                    line: line_no,
                });
                open = false;
            }
            continue;
        }
        if trimmed.is_empty() {
            continue;
        }
        if open {
            let header: Vec<String> = body.split_whitespace().map(String::from).collect();
            for (at, t) in tokens(body) {
                if parse_number(t).is_some() {
                    return Err(Diagnostic::at(
                        file,
                        line_no,
                        col(body, at),
                        format!(
                            "expected a header row naming the columns (e.g. `X EXX EYX`), found the number `{t}`"
                        ),
                    ));
                }
            }
            blocks.push(Block {
                header,
                rows: Vec::new(),
                line: line_no,
            });
            open = false;
            continue;
        }
        let block = blocks.last_mut().expect("a block is open");
        let mut row = Vec::with_capacity(block.header.len());
        for (at, t) in tokens(body) {
            match parse_number(t) {
                Some(v) => row.push(v),
                None => {
                    return Err(Diagnostic::at(
                        file,
                        line_no,
                        col(body, at),
                        format!("`{t}` is not a finite number"),
                    ));
                }
            }
        }
        if row.len() != block.header.len() {
            return Err(Diagnostic::at(
                file,
                line_no,
                1,
                format!(
                    "this row has {} values, the header on line {} names {} columns",
                    row.len(),
                    block.line,
                    block.header.len()
                ),
            ));
        }
        block.rows.push(row);
    }
    Ok(blocks)
}

/// Text of blocks: each block after the first opened by `#`, a comment line
/// before each header.
pub fn write(blocks: &[(String, Block)]) -> String {
    let mut s = String::new();
    for (k, (comment, b)) in blocks.iter().enumerate() {
        if k > 0 {
            s.push_str("#\n");
        }
        for c in comment.lines() {
            s.push_str("// ");
            s.push_str(c);
            s.push('\n');
        }
        s.push_str(&b.header.join(" "));
        s.push('\n');
        for r in &b.rows {
            let cells: Vec<String> = r
                .iter()
                .enumerate()
                .map(|(j, &v)| cell(&b.header[j], v))
                .collect();
            s.push_str(&cells.join(" "));
            s.push('\n');
        }
    }
    s
}

/// A value in a column: arguments with 6 decimals, translations (mm) with 9,
/// rotations (rad) with 12.
fn cell(name: &str, v: f64) -> String {
    let rotation = match volumetric_name(name) {
        Some(n) => n.component.is_rotation(),
        None => return fixed(v, 6),
    };
    fixed(v, if rotation { 12 } else { 9 })
}

/// The mtwin error named by a volumetric column: `EXY` (a component error)
/// or `X0A` (a location error, written without `E`). `None` for an argument.
pub fn volumetric_name(name: &str) -> Option<ErrorName> {
    if name.starts_with('E')
        && let Ok(n) = name.parse::<ErrorName>()
        && !n.is_location()
    {
        return Some(n);
    }
    let n: ErrorName = format!("E{name}").parse().ok()?;
    n.is_location().then_some(n)
}

/// The column name of an error: `EXY` for a PDGE, `X0A` for a location error.
pub fn column_name(n: &ErrorName) -> String {
    if n.is_location() {
        n.to_string()[1..].to_string()
    } else {
        n.to_string()
    }
}

/// The blocks of a machine: one block of location errors (when any is
/// non-zero), then per axis with position-dependent errors one block over
/// `machine`'s tables (see [`super::tabulated`]).
pub fn machine_blocks(tab: &Machine) -> Vec<(String, Block)> {
    let mut out = Vec::new();
    let locations: Vec<ErrorName> = nonzero_errors(tab)
        .into_iter()
        .filter(|n| n.is_location())
        .collect();
    if !locations.is_empty() {
        let row = locations
            .iter()
            .map(|n| tab.error_value(n, 0.0).unwrap_or(0.0))
            .collect();
        out.push((
            "location errors of the axes (mm, rad)".to_string(),
            Block {
                header: locations.iter().map(column_name).collect(),
                rows: vec![row],
                line: 0,
            },
        ));
    }
    for ax in &tab.axes {
        let present: Vec<Component> = Component::ALL
            .into_iter()
            .filter(|c| ax.errors.pdge[c.index()].is_some())
            .collect();
        let Some(q) = present
            .iter()
            .find_map(|c| match &ax.errors.pdge[c.index()] {
                Some(ErrorFunction::Table { q, .. }) => Some(q.clone()),
                _ => None,
            })
        else {
            continue;
        };
        let mut header = vec![ax.name.clone()];
        header.extend(
            present
                .iter()
                .map(|&c| ErrorName::pdge(c, &ax.name).to_string()),
        );
        let rows = q
            .iter()
            .map(|&v| {
                let mut r = vec![v];
                r.extend(present.iter().map(|&c| ax.pdge_at(c, v)));
                r
            })
            .collect();
        out.push((
            format!(
                "component errors of axis {} over its position ({}; errors mm, rad)",
                ax.name,
                ax.kind.unit()
            ),
            Block {
                header,
                rows,
                line: 0,
            },
        ));
    }
    out
}

/// Put the tables and location errors of `blocks` into `machine`: a block
/// whose first column is an axis of the machine gives that axis' component
/// errors as [`ErrorFunction::Table`]s; a block of location errors sets them
/// from its (single) row. Other columns are refused.
pub fn apply(machine: &mut Machine, blocks: &[Block], file: &Path) -> Result<(), Diagnostic> {
    for b in blocks {
        let first = &b.header[0];
        if let Some(i) = machine.axis_index(first) {
            if b.rows.len() < 2 {
                return Err(Diagnostic::at_line(
                    file,
                    b.line,
                    format!("the table over axis {first} needs at least two rows"),
                ));
            }
            let q: Vec<f64> = b.rows.iter().map(|r| r[0]).collect();
            if let Some(k) = q.windows(2).position(|w| w[1] <= w[0]) {
                return Err(Diagnostic::at_line(
                    file,
                    b.line + 1 + k,
                    format!("the positions of axis {first} must increase from row to row"),
                ));
            }
            for (j, name) in b.header.iter().enumerate().skip(1) {
                let n = volumetric_name(name)
                    .filter(|n| !n.is_location() && n.axis == *first)
                    .ok_or_else(|| {
                        Diagnostic::at_line(
                            file,
                            b.line,
                            format!(
                                "column `{name}` is not a component error of axis {first} (expected E<X|Y|Z|A|B|C>{first}); tables over several axes are not read"
                            ),
                        )
                    })?;
                let e = b.rows.iter().map(|r| r[j]).collect();
                machine.axes[i].errors.pdge[n.component.index()] =
                    Some(ErrorFunction::Table { q: q.clone(), e });
            }
        } else {
            if b.rows.len() != 1 {
                return Err(Diagnostic::at_line(
                    file,
                    b.line,
                    "a block of location errors must have exactly one row",
                ));
            }
            for (j, name) in b.header.iter().enumerate() {
                let n = volumetric_name(name)
                    .filter(|n| n.is_location())
                    .ok_or_else(|| {
                        Diagnostic::at_line(
                            file,
                            b.line,
                            format!(
                                "column `{name}` is neither an axis of the machine ({}) nor a location error such as `Y0A`",
                                machine.axis_names().join(", ")
                            ),
                        )
                    })?;
                let i = machine.axis_index(&n.axis).ok_or_else(|| {
                    Diagnostic::at_line(
                        file,
                        b.line,
                        format!(
                            "`{name}` names axis {}, which the machine does not have",
                            n.axis
                        ),
                    )
                })?;
                machine.axes[i].errors.location[n.component.index()] = b.rows[0][j];
            }
        }
    }
    Ok(())
}

/// The parameter files a compensation list names, with their formats
/// (`ISG_CSV`, `ETALON_EXCHANGE`), in index order.
pub fn parse_lis(text: &str, file: &Path) -> Result<Vec<(String, String)>, Diagnostic> {
    let mut files: Vec<(usize, String, usize)> = Vec::new();
    let mut formats: Vec<(usize, String)> = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("");
        let line = strip_comment(line);
        let mut it = line.split_whitespace();
        let (Some(key), value) = (it.next(), it.next()) else {
            continue;
        };
        let index = |prefix: &str| -> Option<Result<usize, Diagnostic>> {
            let rest = key.strip_prefix(prefix)?.strip_prefix('[')?;
            Some(
                rest.strip_suffix(']')
                    .and_then(|k| k.parse::<usize>().ok())
                    .ok_or_else(|| {
                        Diagnostic::at(
                            file,
                            n + 1,
                            1,
                            format!("`{key}` needs an index: {prefix}[0]"),
                        )
                    }),
            )
        };
        if let Some(k) = index("file") {
            let v = value
                .ok_or_else(|| Diagnostic::at_line(file, n + 1, "the file name is missing"))?;
            files.push((k?, v.to_string(), n + 1));
        } else if let Some(k) = index("file_format") {
            let v = value
                .ok_or_else(|| Diagnostic::at_line(file, n + 1, "the file format is missing"))?;
            formats.push((k?, v.to_string()));
        }
    }
    files.sort_by_key(|f| f.0);
    files
        .into_iter()
        .map(|(k, name, line)| {
            let fmt = formats
                .iter()
                .find(|f| f.0 == k)
                .map(|f| f.1.clone())
                .ok_or_else(|| {
                    Diagnostic::at_line(file, line, format!("file[{k}] has no file_format[{k}]"))
                })?;
            Ok((name, fmt))
        })
        .collect()
}

/// Read a compensation list and the `ISG_CSV` / Etalon files it names
/// (relative to the list's folder) into a copy of `machine` (usually the
/// nominal machine): tables become [`ErrorFunction::Table`]s.
pub fn import(lis: &Path, machine: &Machine) -> Result<Machine, Diagnostic> {
    let read = |p: &Path| {
        std::fs::read_to_string(p).map_err(|e| Diagnostic::whole(p, format!("cannot read: {e}")))
    };
    let text = read(lis)?;
    let dir = lis.parent().unwrap_or(Path::new(""));
    let mut m = machine.clone();
    for (name, fmt) in parse_lis(&text, lis)? {
        let path = dir.join(&name);
        let body = read(&path)?;
        match fmt.as_str() {
            "ISG_CSV" => apply(&mut m, &parse(&body, &path)?, &path)?,
            "ETALON_EXCHANGE" => {
                super::etalon::apply(&mut m, &super::etalon::parse(&body, &path)?, &path)?
            }
            other => {
                return Err(Diagnostic::whole(
                    lis,
                    format!(
                        "file format `{other}` of {name} is not read (ISG_CSV, ETALON_EXCHANGE are)"
                    ),
                ));
            }
        }
    }
    Ok(m)
}

/// The compensation list for parameter files `files` (name, format).
pub(crate) fn lis_text(machine: &Machine, files: &[(&str, &str)]) -> String {
    let mut s = String::from(
        "# Volumetric compensation list written by mtwin export.\n\
         # Axis assignment: logical axis numbers in the order X Y Z A B C;\n\
         # change them to the control's logical axis numbers.\n",
    );
    for (i, j) in super::linuxcnc_comp::joint_numbers(machine) {
        s.push_str(&format!("{} {}\n", machine.axes[i].name, j + 1));
    }
    let n_wp = (0..machine.n_axes())
        .filter(|&i| machine.chain_of(i) == Chain::Workpiece)
        .count();
    s.push_str("# Number of axes on the workpiece side of the kinematic chain\n");
    s.push_str(&format!("workpiece_axes {n_wp}\n"));
    s.push_str(&format!(
        "# Axes in the order from the workpiece to the machine base and on to the tool\n\
         chain {}\n",
        chain(machine)
    ));
    s.push_str("Interpolation GRID\n");
    for (k, (name, fmt)) in files.iter().enumerate() {
        s.push_str(&format!("file[{k}] {name}\nfile_format[{k}] {fmt}\n"));
    }
    s.push_str("# Switch on in the part program with #VOLCOMP ON\n");
    s
}

/// The `chain` of a compensation list: the axis letters from the workpiece
/// down to the machine base, then from the base up to the tool (the
/// sequence the vendor documents for a table machine's kinematic chain,
/// `C A X Y Z`; `chain XYZCA` for a head machine).
pub fn chain(machine: &Machine) -> String {
    let name = |&i: &usize| machine.axes[i].name.clone();
    machine
        .workpiece_chain
        .iter()
        .rev()
        .map(name)
        .chain(machine.tool_chain.iter().map(name))
        .collect()
}

/// `--to isg`.
pub(crate) fn export(machine: &Machine, opts: &ExportOptions) -> Result<Exported, ExportError> {
    check_iso_axes(machine, Format::Isg)?;
    let tab = tabulated(machine, opts, Format::Isg.max_points())?;
    let mut csv = format!(
        "// Volumetric compensation parameters of {} written by mtwin export (ISG_CSV).\n\
         // Errors in ISO 230-1 names, mtwin's sign convention (docs/machine-model.md).\n",
        machine.name
    );
    csv.push_str(&write(&machine_blocks(&tab)));
    let files = vec![
        (
            LIS_FILE.to_string(),
            lis_text(machine, &[(CSV_FILE, "ISG_CSV")]),
        ),
        (CSV_FILE.to_string(), csv),
    ];
    Ok(Exported::volumetric(Format::Isg, files, machine, tab))
}
