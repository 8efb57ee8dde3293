//! Axis positions read from a CSV table whose columns are named by the machine's axes.

use super::Machine;
use crate::io::{Diagnostic, Diagnostics, Table};

/// Axis positions of every row of `table`, in the machine's axis order (mm, degree).
///
/// Every axis of the machine must have a column; other columns are ignored. With
/// `check_travel`, a position outside its axis travel is an error naming the line and column.
pub fn read_poses(
    table: &Table,
    machine: &Machine,
    check_travel: bool,
) -> Result<Vec<Vec<f64>>, Diagnostics> {
    let names = machine.axis_names();
    let cols = table.require(&names)?;
    if table.is_empty() {
        return Err(Diagnostic::at_line(
            table.path(),
            table.header_line(),
            "the file has a header but no poses",
        )
        .into());
    }
    let mut diags = Diagnostics::default();
    let mut out = Vec::with_capacity(table.len());
    for r in 0..table.len() {
        let mut q = Vec::with_capacity(cols.len());
        for (i, &c) in cols.iter().enumerate() {
            match table.number(r, c) {
                Ok(v) => {
                    let a = &machine.axes[i];
                    if check_travel && !a.in_travel(v) {
                        diags.push(table.cell_error(
                            r,
                            c,
                            format!(
                                "axis {} at {} {} is outside its travel [{}, {}]",
                                a.name,
                                crate::limits::fmt_message_number(v),
                                a.kind.unit(),
                                crate::limits::fmt_message_number(a.travel[0]),
                                crate::limits::fmt_message_number(a.travel[1])
                            ),
                        ));
                    }
                    q.push(v);
                }
                Err(d) => diags.push(d),
            }
        }
        out.push(q);
    }
    diags.into_result(out)
}
