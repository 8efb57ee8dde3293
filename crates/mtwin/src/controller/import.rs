//! Controller tables read back into a machine model (`mtwin import`,
//! docs/controller-tables.md).
//!
//! Volumetric files (`ISG_CSV`, Etalon) name their errors: each table becomes
//! that error as an [`ErrorFunction::Table`], each value that location error.
//! Per-axis tables (LinuxCNC, Siemens EEC and CEC) hold corrections; each
//! becomes the error its correction cancels on a nominal machine:
//!
//! * a LinuxCNC `comp_<AXIS>.txt` or an EEC table of axis `X`: the
//!   positioning error `EXX`;
//! * a CEC table with input axis `X` and output axis `Y`: the straightness
//!   `EYX`.
//!
//! Every error a file sets replaces the same error of the model imported
//! into; the other errors are kept.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::{Format, isg_csv, linear_axes, linear_letter, reference_pose};
use crate::io::Diagnostic;
use crate::kinematics::Kinematics;
use crate::model::{AxisKind, Component, ErrorFunction, ErrorName, Machine};

/// A machine model with imported tables, and the errors the files changed.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    /// The model.
    pub machine: Machine,
    /// The errors whose function or value differs from the model imported
    /// into, in axis order.
    pub changed: Vec<ErrorName>,
}

/// Read `files` of `format` into a copy of `machine`.
///
/// * `Isg`, `Etalon`: compensation lists (`.lis`, the files they name are read
///   from the list's folder) or parameter files of the format itself.
/// * `LinuxCnc`: compensation files; the axis comes from a name
///   `comp_<AXIS>.txt` or from an `AXIS=` before the path (`X=xcomp.txt`).
/// * `SiemensEec`, `SiemensCec`: initialisation programs; machine axes
///   `AX1`, `AX2`, … are the machine's axes in the order X Y Z A B C, as
///   `mtwin export` numbers them.
pub fn import(
    format: Format,
    files: &[PathBuf],
    machine: &Machine,
) -> Result<Imported, Diagnostic> {
    let mut m = machine.clone();
    for f in files {
        match format {
            Format::Isg | Format::Etalon if f.extension().is_some_and(|e| e == "lis") => {
                m = isg_csv::import(f, &m)?;
            }
            Format::Isg => {
                let text = read(f)?;
                isg_csv::apply(&mut m, &isg_csv::parse(&text, f)?, f)?;
            }
            Format::Etalon => {
                let text = read(f)?;
                super::etalon::apply(&mut m, &super::etalon::parse(&text, f)?, f)?;
            }
            Format::LinuxCnc => {
                let (axis, path) = linuxcnc_axis(f)?;
                let i = m.axis_index(&axis).ok_or_else(|| {
                    Diagnostic::whole(
                        &path,
                        format!(
                            "axis {axis} is not an axis of the machine ({})",
                            m.axis_names().join(", ")
                        ),
                    )
                })?;
                let rows = super::linuxcnc_comp::parse(&read(&path)?, &path)?;
                if rows.len() < 2 {
                    return Err(Diagnostic::whole(&path, "a table needs at least two lines"));
                }
                set_from_correction(
                    &mut m,
                    i,
                    i,
                    rows.iter().map(|r| r[0]).collect(),
                    rows.iter().map(|r| r[1]).collect(),
                    &path,
                    1,
                )?;
            }
            Format::SiemensEec => {
                let text = read(f)?;
                let tables = super::siemens_eec::parse(&text, f)?;
                for t in &tables {
                    if tables
                        .iter()
                        .any(|o| o.axis == t.axis && o.encoder != t.encoder && o.line < t.line)
                    {
                        return Err(Diagnostic::at_line(
                            f,
                            t.line,
                            format!(
                                "a second encoder table of {}: mtwin reads one per axis",
                                t.axis
                            ),
                        ));
                    }
                    let i = axis_of_id(&m, &t.axis, f, t.line)?;
                    let q = positions(t.min, t.max, t.step, t.values.len(), f, t.line)?;
                    // The value is the error to take out: the correction is its negative.
                    let c = t.values.iter().map(|v| -v).collect();
                    set_from_correction(&mut m, i, i, q, c, f, t.line)?;
                }
            }
            Format::SiemensCec => {
                let text = read(f)?;
                for t in super::siemens_cec::parse(&text, f)? {
                    if t.direction != 0 {
                        return Err(Diagnostic::at_line(
                            f,
                            t.line,
                            format!(
                                "table {} applies in one direction of travel only ($AN_CEC_DIRECTION = {}); a machine model has no direction",
                                t.table, t.direction
                            ),
                        ));
                    }
                    if t.mult_by_table != 0 {
                        return Err(Diagnostic::at_line(
                            f,
                            t.line,
                            format!(
                                "table {} is multiplied by table {} ($AN_CEC_MULT_BY_TABLE): a product of tables is not an ISO 230-1 error",
                                t.table, t.mult_by_table
                            ),
                        ));
                    }
                    let i = axis_of_id(&m, &t.input, f, t.line)?;
                    let o = axis_of_id(&m, &t.output, f, t.line)?;
                    if i == o {
                        return Err(Diagnostic::at_line(
                            f,
                            t.line,
                            format!(
                                "table {}: input and output are both {}; the positioning along an axis is EEC's",
                                t.table, t.input
                            ),
                        ));
                    }
                    let q = positions(t.min, t.max, t.step, t.values.len(), f, t.line)?;
                    set_from_correction(&mut m, i, o, q, t.values.clone(), f, t.line)?;
                }
            }
        }
    }
    let changed = changed(machine, &m);
    Ok(Imported {
        machine: m,
        changed,
    })
}

fn read(p: &Path) -> Result<String, Diagnostic> {
    std::fs::read_to_string(p).map_err(|e| Diagnostic::whole(p, format!("cannot read: {e}")))
}

/// The axis and path of a LinuxCNC compensation file argument.
fn linuxcnc_axis(f: &Path) -> Result<(String, PathBuf), Diagnostic> {
    let s = f.to_string_lossy();
    if let Some((axis, path)) = s.split_once('=')
        && !axis.is_empty()
        && !axis.contains(['/', '\\'])
    {
        return Ok((axis.to_string(), PathBuf::from(path)));
    }
    let name = f.file_name().map(|n| n.to_string_lossy().into_owned());
    name.as_deref()
        .and_then(|n| n.strip_prefix("comp_"))
        .and_then(|n| n.strip_suffix(".txt"))
        .filter(|a| !a.is_empty())
        .map(|a| (a.to_string(), f.to_path_buf()))
        .ok_or_else(|| {
            Diagnostic::whole(
                f,
                "name the file comp_<AXIS>.txt or give its axis as AXIS=PATH (X=xcomp.txt)",
            )
        })
}

/// The machine axis of a Siemens axis identifier `AXn` (the n-th axis in the
/// order X Y Z A B C).
fn axis_of_id(m: &Machine, id: &str, file: &Path, line: usize) -> Result<usize, Diagnostic> {
    (0..m.n_axes())
        .find(|&i| super::siemens_eec::ax_id(m, i) == id)
        .filter(|&i| m.axes[i].kind == AxisKind::Linear)
        .ok_or_else(|| {
            Diagnostic::at_line(
                file,
                line,
                format!(
                    "`{id}` is not a linear axis of the machine (AX1, AX2, … number the axes {} in the order X Y Z A B C)",
                    m.axis_names().join(", ")
                ),
            )
        })
}

/// The `n` table positions of `min`, `max`, `step`: evenly spread from `min`
/// to `max`, and `step` must be their spacing (to 1e-6 relative, the
/// rounding of a written step).
fn positions(
    min: f64,
    max: f64,
    step: f64,
    n: usize,
    file: &Path,
    line: usize,
) -> Result<Vec<f64>, Diagnostic> {
    let bad = |m: String| Diagnostic::at_line(file, line, m);
    for (v, name) in [(min, "_MIN"), (max, "_MAX"), (step, "_STEP")] {
        if v.is_nan() {
            return Err(bad(format!("the table has no {name}")));
        }
    }
    if n < 2 {
        return Err(bad("a table needs at least two points".into()));
    }
    if !(max > min && step > 0.0) {
        return Err(bad(format!(
            "_MIN {min} must be below _MAX {max} and _STEP {step} positive"
        )));
    }
    let h = (max - min) / (n - 1) as f64;
    if (h - step).abs() > 1e-6 * step.max(1.0) {
        return Err(bad(format!(
            "{n} points from _MIN {min} to _MAX {max} are {h} apart, but _STEP is {step}"
        )));
    }
    Ok((0..n)
        .map(|k| if k + 1 == n { max } else { min + h * k as f64 })
        .collect())
}

/// Tip motion at the reference pose of the nominal machine for joint `o`
/// moving 1 mm, and for the translational error `comp` of axis `i` being
/// 1 mm.
fn unit_motions(m: &Machine, i: usize, comp: Component, o: usize) -> (Vector3<f64>, Vector3<f64>) {
    let q0 = reference_pose(m, &Default::default());
    let nominal = m.nominal();
    let k = Kinematics::new(&nominal);
    let mut qp = q0.clone();
    qp[o] += 1.0;
    let jv = k.pose(&qp).tip - k.pose(&q0).tip;
    let mut unit = nominal.clone();
    unit.axes[i].errors.pdge[comp.index()] = Some(ErrorFunction::Constant(1.0));
    let gv = Kinematics::new(&unit).pose(&q0).tip - k.pose(&q0).tip;
    (jv, gv)
}

/// Set the error of axis `i` along the direction of linear axis `o` to the
/// table whose correction of `o` is `c` at positions `q` of `i`: a correction
/// `c` of joint `o` cancels an error `E` when `c·jv = −E·gv` along `jv`.
fn set_from_correction(
    m: &mut Machine,
    i: usize,
    o: usize,
    q: Vec<f64>,
    c: Vec<f64>,
    file: &Path,
    line: usize,
) -> Result<(), Diagnostic> {
    let lin = linear_axes(m);
    let (Some((comp, _)), true, true) = (linear_letter(m, o), lin.contains(&i), lin.contains(&o))
    else {
        return Err(Diagnostic::at_line(
            file,
            line,
            format!(
                "axes {} and {} must be linear and run along the machine axes",
                m.axes[i].name, m.axes[o].name
            ),
        ));
    };
    let (jv, gv) = unit_motions(m, i, comp, o);
    let gain = jv.dot(&gv) / jv.dot(&jv);
    if gain.abs() < 1e-9 {
        return Err(Diagnostic::at_line(
            file,
            line,
            format!(
                "a correction of {} does not act on {}",
                m.axes[o].name,
                ErrorName::pdge(comp, &m.axes[i].name)
            ),
        ));
    }
    m.axes[i].errors.pdge[comp.index()] = Some(ErrorFunction::Table {
        q,
        e: c.iter().map(|c| -c / gain).collect(),
    });
    Ok(())
}

/// Errors of `after` that differ from `before`.
fn changed(before: &Machine, after: &Machine) -> Vec<ErrorName> {
    let mut out = Vec::new();
    for (a, b) in before.axes.iter().zip(&after.axes) {
        for c in Component::ALL {
            if a.errors.pdge[c.index()] != b.errors.pdge[c.index()] {
                out.push(ErrorName::pdge(c, &a.name));
            }
        }
        for c in Component::ALL {
            if a.errors.location[c.index()] != b.errors.location[c.index()] {
                out.push(ErrorName::location(c, &a.name));
            }
        }
    }
    out
}
