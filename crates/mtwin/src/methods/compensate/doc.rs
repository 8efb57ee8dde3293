//! `mtwin compensate --format json` as a typed document ([`CompensateDoc`]),
//! which `mtwin report --compensate` reads back.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::Summary;

/// What the geometric compensation of a part program changed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompensateDoc {
    /// Arcs converted to line segments.
    pub arcs_converted: u64,
    /// Targets near the singular pose: tip corrected, tool axis not.
    pub axis_not_corrected: u64,
    /// Blocks read.
    pub blocks: u64,
    /// Blocks whose axis words changed.
    pub blocks_changed: u64,
    /// Blocks inserted by subdivision.
    pub blocks_inserted: u64,
    /// Moves split.
    pub blocks_subdivided: u64,
    /// Line of the largest correction.
    pub largest_correction_line: u64,
    /// Largest linear correction (µm).
    pub largest_correction_um: f64,
    /// Largest deviation left at a checked midpoint (µm).
    pub largest_midpoint_deviation_um: f64,
    /// Largest rotary correction (deg).
    pub largest_rotary_correction_deg: f64,
    /// Things the user should know.
    pub notes: Vec<String>,
    /// The program written.
    pub out: String,
}

impl CompensateDoc {
    /// The document of a run summarised by `s`, written to `out`.
    pub fn new(s: &Summary, out: &str) -> Self {
        CompensateDoc {
            arcs_converted: s.arcs_converted,
            axis_not_corrected: s.axis_not_corrected,
            blocks: s.blocks,
            blocks_changed: s.blocks_changed,
            blocks_inserted: s.blocks_inserted,
            blocks_subdivided: s.blocks_subdivided,
            largest_correction_line: s.largest_correction_line,
            largest_correction_um: s.largest_correction * 1e3,
            largest_midpoint_deviation_um: s.largest_midpoint_deviation * 1e3,
            largest_rotary_correction_deg: s.largest_rotary_correction,
            notes: s.notes.clone(),
            out: out.to_string(),
        }
    }
}

impl fmt::Display for CompensateDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} blocks → {}\nblocks changed {}, subdivided {} (+{} blocks), arcs converted {}\nlargest correction {:.2} µm (line {}), rotary {:.5}°",
            self.blocks,
            self.out,
            self.blocks_changed,
            self.blocks_subdivided,
            self.blocks_inserted,
            self.arcs_converted,
            self.largest_correction_um,
            self.largest_correction_line,
            self.largest_rotary_correction_deg
        )?;
        if self.axis_not_corrected > 0 {
            writeln!(
                f,
                "{} targets near the singular pose: tip corrected, tool axis not",
                self.axis_not_corrected
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::compensate::{CompensateOptions, Compensator};
    use crate::model::parse_machine;

    #[test]
    fn the_document_round_trips_from_a_real_run() {
        let m = parse_machine(
            std::path::Path::new("ac-trunnion-with-errors.toml"),
            include_str!("../../../../../examples/machines/ac-trunnion-with-errors.toml"),
        )
        .unwrap();
        let program = "G90 G21\nG0 X10 Y5 Z20 A0 C0\nG1 X20 Y10 Z15 A10 C30 F500\nM2\n";
        let comp = Compensator::new(&m, CompensateOptions::default()).unwrap();
        let mut out = Vec::new();
        let s = comp.run(program.as_bytes(), &mut out).unwrap();
        let doc = CompensateDoc::new(&s, "out.ngc");
        assert_eq!(doc.blocks, s.blocks);
        assert!(doc.blocks_changed > 0 && doc.largest_correction_um > 0.0);
        let text = serde_json::to_string_pretty(&doc).unwrap();
        assert_eq!(serde_json::from_str::<CompensateDoc>(&text).unwrap(), doc);
        assert!(
            doc.to_string()
                .starts_with(&format!("{} blocks → out.ngc\n", s.blocks))
        );
    }
}
