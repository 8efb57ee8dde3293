//! The `key=value` data files of the open-source ecmc motion-test tools
//! (ISO 230-2 input): `#` comments, then
//!
//! * `UNIT=mm` (or `um`; optional, default mm), `CYCLES=n`, `POSITIONS=m`
//!   (optional, checked against the data when given);
//! * `TGT_DATA[i]=P` the target position `i` (1-based);
//! * `REF_DATA_FWD[i,j]=x` the reference (actual) position at target `i` in
//!   cycle `j` approached in the forward (increasing, ↑) direction,
//!   `REF_DATA_BWD[i,j]` the same from the backward (decreasing, ↓) side.
//!
//! Other keys (`DEC`, `REF_PV`, `TEST_PV`, `TGT_SET_PV`, …) are ignored.

use std::collections::BTreeMap;
use std::path::Path;

use super::iso230_2::{Entry, Run, assemble};
use crate::io::{Diagnostic, Diagnostics};

fn parse_indices(s: &str) -> Option<Vec<usize>> {
    s.split(',')
        .map(|p| p.trim().parse::<usize>().ok().filter(|&v| v >= 1))
        .collect()
}

fn parse_value(s: &str) -> Option<f64> {
    let s = s.trim();
    s.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Read an ecmc ISO 230-2 `.dat` file (layout in the module documentation).
pub fn read_dat(path: &Path) -> Result<Run, Diagnostics> {
    let bytes = std::fs::read(path)
        .map_err(|e| Diagnostic::whole(path, format!("cannot read the file: {e}")))?;
    let text = String::from_utf8_lossy(&bytes);
    let mut diags = Diagnostics::default();
    let mut scale = 1.0; // to mm
    let mut cycles: Option<(usize, usize)> = None; // (value, line)
    let mut positions: Option<(usize, usize)> = None;
    let mut targets: BTreeMap<usize, (f64, usize)> = BTreeMap::new();
    // (i, j, up, value, line, col)
    let mut refs: Vec<(usize, usize, bool, f64, usize, usize)> = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let t = raw.trim_start();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let lead = raw.len() - t.len();
        let Some(eq) = t.find('=') else {
            diags.push(Diagnostic::at(path, line, lead + 1, "expected `KEY=value`"));
            continue;
        };
        let key = t[..eq].trim();
        let value = &t[eq + 1..];
        let vcol = lead + eq + 2;
        let (name, idx) = match key.find('[') {
            Some(b) if key.ends_with(']') => (&key[..b], Some(&key[b + 1..key.len() - 1])),
            _ => (key, None),
        };
        let bad_value = |what: &str| Diagnostic::at(path, line, vcol, what.to_string());
        match (name, idx) {
            ("UNIT", None) => match value.trim() {
                "mm" => scale = 1.0,
                "um" | "µm" => scale = 1e-3,
                other => diags.push(bad_value(&format!("UNIT must be mm or um, not `{other}`"))),
            },
            ("CYCLES" | "POSITIONS", None) => match value.trim().parse::<usize>() {
                Ok(v) if v >= 1 => {
                    if name == "CYCLES" {
                        cycles = Some((v, line));
                    } else {
                        positions = Some((v, line));
                    }
                }
                _ => diags.push(bad_value(&format!("{name} must be a whole number from 1"))),
            },
            ("TGT_DATA", Some(ix)) => match (parse_indices(ix).as_deref(), parse_value(value)) {
                (Some([i]), Some(v)) => {
                    if let Some((_, first)) = targets.insert(*i, (v, line)) {
                        diags.push(Diagnostic::at(
                            path,
                            line,
                            lead + 1,
                            format!("TGT_DATA[{i}] is given twice (first at line {first})"),
                        ));
                    }
                }
                (Some([_]), None) => diags.push(bad_value("the target position must be a number")),
                _ => diags.push(Diagnostic::at(
                    path,
                    line,
                    lead + 1,
                    "TGT_DATA takes one index from 1: TGT_DATA[i]",
                )),
            },
            ("REF_DATA_FWD" | "REF_DATA_BWD", Some(ix)) => {
                match (parse_indices(ix).as_deref(), parse_value(value)) {
                    (Some([i, j]), Some(v)) => {
                        refs.push((*i, *j, name == "REF_DATA_FWD", v, line, lead + 1))
                    }
                    (Some([_, _]), None) => {
                        diags.push(bad_value("the reference position must be a number"))
                    }
                    _ => diags.push(Diagnostic::at(
                        path,
                        line,
                        lead + 1,
                        format!("{name} takes two indices from 1: {name}[i,j]"),
                    )),
                }
            }
            _ => {}
        }
    }
    diags.into_result(())?;
    let mut diags = Diagnostics::default();
    let mut entries = Vec::with_capacity(refs.len());
    for &(i, j, up, v, line, col) in &refs {
        let Some(&(target, _)) = targets.get(&i) else {
            diags.push(Diagnostic::at(
                path,
                line,
                col,
                format!("no TGT_DATA[{i}] gives the target of this reading"),
            ));
            continue;
        };
        if let Some((n, nl)) = cycles
            && j > n
        {
            diags.push(Diagnostic::at(
                path,
                line,
                col,
                format!("cycle {j} is beyond CYCLES={n} (line {nl})"),
            ));
            continue;
        }
        entries.push(Entry {
            target_mm: target * scale,
            up,
            cycle: Some(j),
            deviation_mm: (v - target) * scale,
            line,
            col,
        });
    }
    if let Some((m, ml)) = positions
        && targets.len() != m
    {
        diags.push(Diagnostic::at(
            path,
            ml,
            1,
            format!(
                "POSITIONS={m} but the file gives {} target position(s)",
                targets.len()
            ),
        ));
    }
    for (i, &(_, line)) in &targets {
        if !refs.iter().any(|r| r.0 == *i) {
            diags.push(Diagnostic::at(
                path,
                line,
                1,
                format!("target {i} has no REF_DATA_FWD or REF_DATA_BWD reading"),
            ));
        }
    }
    if let Some((n, nl)) = cycles {
        for (i, &(_, tl)) in &targets {
            for up in [true, false] {
                let got = refs.iter().filter(|r| r.0 == *i && r.2 == up).count();
                if got != 0 && got != n {
                    let at = refs
                        .iter()
                        .rfind(|r| r.0 == *i && r.2 == up)
                        .map(|r| (r.4, r.5))
                        .unwrap_or((tl, 1));
                    diags.push(Diagnostic::at(
                        path,
                        at.0,
                        at.1,
                        format!(
                            "cycles of unequal length: target {i} has {got} {} reading(s), CYCLES={n} (line {nl})",
                            if up { "REF_DATA_FWD" } else { "REF_DATA_BWD" }
                        ),
                    ));
                }
            }
        }
    }
    diags.into_result(())?;
    assemble(path, &entries, Vec::new())
}
