//! What `mtwin model check` reports about a machine file: its chains, axes and
//! error terms, as one typed document ([`ModelCheckDoc`]).

use std::fmt;

use serde::{Deserialize, Serialize};

use super::{Component, Machine};

/// One axis of a checked machine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisSummary {
    /// Unit direction of the axis (machine frame).
    pub direction: Vec<f64>,
    /// `linear` or `rotary`.
    pub kind: String,
    /// The axis name, e.g. `X`, `C`.
    pub name: String,
    /// A point of the axis line (mm, machine frame).
    pub origin: Vec<f64>,
    /// True when the axis has a servo table.
    pub servo: bool,
    /// Travel `[min, max]` (mm or deg).
    pub travel: [f64; 2],
}

/// One geometric error term of a checked machine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorTermSummary {
    /// The form of a PDGE (e.g. `cheb3`), or the value and unit of a location error.
    pub form: String,
    /// ISO 230-1 name, e.g. `EXX`, `EY0A`.
    pub name: String,
}

/// `mtwin model check`: a summary of a valid machine model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelCheckDoc {
    /// Every axis, in file order.
    pub axes: Vec<AxisSummary>,
    /// Number of scalar error parameters.
    pub error_terms: usize,
    /// Every PDGE and every non-zero location error.
    pub errors: Vec<ErrorTermSummary>,
    /// The checked file, as given.
    #[serde(default)]
    pub file: String,
    /// The machine's name.
    pub name: String,
    /// Always true: a file with problems gives an error instead.
    pub ok: bool,
    /// Axis names from the base to the tool.
    pub tool_chain: Vec<String>,
    /// Axis names from the base to the workpiece.
    pub workpiece_chain: Vec<String>,
}

impl ModelCheckDoc {
    /// The summary of `m`, read from `file`.
    pub fn new(m: &Machine, file: &str) -> Self {
        let chain = |c: &[usize]| c.iter().map(|&i| m.axes[i].name.clone()).collect();
        let mut errors = Vec::new();
        for a in &m.axes {
            for c in Component::ALL {
                if let Some(f) = &a.errors.pdge[c.index()] {
                    errors.push(ErrorTermSummary {
                        name: format!("E{}{}", c.letter(), a.name),
                        form: f.form().label(),
                    });
                }
            }
            for c in Component::ALL {
                let v = a.errors.location[c.index()];
                if v != 0.0 {
                    let unit = if c.is_rotation() { "rad" } else { "mm" };
                    errors.push(ErrorTermSummary {
                        name: format!("E{}0{}", c.letter(), a.name),
                        form: format!("{} {unit}", crate::io::fmt_f64(v)),
                    });
                }
            }
        }
        ModelCheckDoc {
            axes: m
                .axes
                .iter()
                .map(|a| AxisSummary {
                    direction: a.direction.as_slice().to_vec(),
                    kind: a.kind.as_str().to_string(),
                    name: a.name.clone(),
                    origin: a.origin.as_slice().to_vec(),
                    servo: a.servo.is_some(),
                    travel: a.travel,
                })
                .collect(),
            error_terms: m.n_error_terms(),
            errors,
            file: file.to_string(),
            name: m.name.clone(),
            ok: true,
            tool_chain: chain(&m.tool_chain),
            workpiece_chain: chain(&m.workpiece_chain),
        }
    }
}

impl fmt::Display for ModelCheckDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}: OK — \"{}\"", self.file, self.name)?;
        let chain = |c: &[String]| {
            if c.is_empty() {
                "(empty)".to_string()
            } else {
                c.join(" → ")
            }
        };
        writeln!(f, "  tool chain:      M → {} → T", chain(&self.tool_chain))?;
        writeln!(
            f,
            "  workpiece chain: M → {} → W",
            chain(&self.workpiece_chain)
        )?;
        writeln!(
            f,
            "\n  axis  kind    direction           origin (mm)               travel"
        )?;
        for a in &self.axes {
            let v = |x: &[f64]| format!("[{}, {}, {}]", x[0], x[1], x[2]);
            let unit = if a.kind == "rotary" { "deg" } else { "mm" };
            writeln!(
                f,
                "  {:<5} {:<7} {:<19} {:<25} [{}, {}] {}{}",
                a.name,
                a.kind,
                v(&a.direction),
                v(&a.origin),
                a.travel[0],
                a.travel[1],
                unit,
                if a.servo { "  servo" } else { "" }
            )?;
        }
        if self.errors.is_empty() {
            writeln!(f, "\n  no geometric errors (a nominal machine)")?;
        } else {
            writeln!(f, "\n  {} geometric error terms:", self.error_terms)?;
            for chunk in self.errors.chunks(4) {
                let line: Vec<String> = chunk
                    .iter()
                    .map(|e| format!("{:<6} {:<18}", e.name, e.form))
                    .collect();
                writeln!(f, "    {}", line.join(" "))?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_document_round_trips_through_json() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/machines/ac-trunnion-with-errors.toml"
        );
        let m = crate::model::read_machine(std::path::Path::new(path)).unwrap();
        let doc = ModelCheckDoc::new(&m, "ac-trunnion-with-errors.toml");
        assert_eq!(doc.axes.len(), m.axes.len());
        assert!(!doc.errors.is_empty());
        let back: ModelCheckDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&doc).unwrap()).unwrap();
        assert_eq!(back, doc);
        assert_eq!(back.to_string(), doc.to_string());
    }
}
