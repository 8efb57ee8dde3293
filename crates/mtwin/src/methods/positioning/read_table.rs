//! Plain CSV positioning table: one row per measured approach.
//!
//! ```text
//! target_mm,direction,cycle,measured_mm
//! 0,up,1,0.0012
//! 0,down,1,-0.0031
//! ```
//!
//! Columns: `target_mm`; `direction` (`up`/`+`/`fwd`/`forward` for the
//! approach from below, `down`/`-`/`bwd`/`backward` from above); optional
//! `cycle` (1-based; without it the rows of a target and direction are the
//! cycles in file order); and exactly one of `measured_mm` (actual position),
//! `deviation_mm` or `deviation_um` (actual − target).

use std::path::Path;

use super::iso230_2::{Entry, Run, assemble};
use crate::io::{Diagnostic, Diagnostics, Table};

/// Read a CSV positioning table (layout in the module documentation).
pub fn read_table(path: &Path) -> Result<Run, Diagnostics> {
    let table = Table::read(path)?;
    let cols = table.require(&["target_mm", "direction"])?;
    let (target, dir) = (cols[0], cols[1]);
    let cycle = table.column("cycle");
    let values: Vec<(&str, _)> = ["measured_mm", "deviation_mm", "deviation_um"]
        .into_iter()
        .filter_map(|n| table.column(n).map(|c| (n, c)))
        .collect();
    if values.len() != 1 {
        return Err(Diagnostic::at(
            path,
            table.header_line(),
            1,
            "the table needs exactly one of the columns measured_mm, deviation_mm, deviation_um",
        )
        .into());
    }
    let (kind, value) = values[0];
    let mut diags = Diagnostics::default();
    let mut entries = Vec::with_capacity(table.len());
    for r in 0..table.len() {
        let t = table.number(r, target);
        let v = table.number(r, value);
        let up = match table.text(r, dir).trim().to_ascii_lowercase().as_str() {
            "up" | "+" | "fwd" | "forward" | "positive" => Some(true),
            "down" | "-" | "bwd" | "backward" | "negative" => Some(false),
            other => {
                diags.push(table.cell_error(
                    r,
                    dir,
                    format!("direction must be up or down, not `{other}`"),
                ));
                None
            }
        };
        let c = match cycle {
            None => Ok(None),
            Some(c) => table.number(r, c).and_then(|x| {
                if x >= 1.0 && x.fract() == 0.0 && x < 1e9 {
                    Ok(Some(x as usize))
                } else {
                    Err(table.cell_error(r, c, "cycle must be a whole number from 1"))
                }
            }),
        };
        match (t, v, up, c) {
            (Ok(t), Ok(v), Some(up), Ok(cycle)) => entries.push(Entry {
                target_mm: t,
                up,
                cycle,
                deviation_mm: match kind {
                    "measured_mm" => v - t,
                    "deviation_mm" => v,
                    _ => v / 1000.0,
                },
                line: table.line(r),
                col: 1,
            }),
            (t, v, _, c) => {
                for d in [t.err(), v.err(), c.err()].into_iter().flatten() {
                    diags.push(d);
                }
            }
        }
    }
    diags.into_result(())?;
    assemble(path, &entries, Vec::new())
}
