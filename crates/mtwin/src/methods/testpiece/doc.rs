//! `mtwin testpiece s-shape --format json` as a typed document
//! ([`SShapeProgramDoc`]).

use std::fmt;

use serde::{Deserialize, Serialize};

/// The ISO 10791-7 S-shaped piece program written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SShapeProgramDoc {
    /// Cutting time at the feed (s).
    pub cutting_time_s: f64,
    /// Feed (mm/min).
    pub feed_mm_min: f64,
    /// Height of the piece (mm).
    pub height_mm: f64,
    /// Inverse-time feed (G93) used.
    pub inverse_time: bool,
    /// Length of the piece (mm).
    pub length_mm: f64,
    /// The program written.
    pub out: String,
    /// Poses (segments + 1).
    pub poses: usize,
    /// Segments of the path.
    pub segments: usize,
    /// A TCP program (tool tip in W) rather than joint space.
    pub tcp: bool,
    /// Length of the tool-tip path (mm).
    pub tip_path_mm: f64,
    /// Width of the piece (mm).
    pub width_mm: f64,
}

impl fmt::Display for SShapeProgramDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "S-shaped piece {:.1} x {:.1} x {:.1} mm, {} segments, tip path {:.2} mm at F{} ({:.1} s) → {}",
            self.length_mm,
            self.width_mm,
            self.height_mm,
            self.segments,
            self.tip_path_mm,
            self.feed_mm_min,
            self.cutting_time_s,
            self.out
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_document_round_trips() {
        let d = SShapeProgramDoc {
            cutting_time_s: 600.0 / 1000.0 * 60.0,
            feed_mm_min: 1000.0,
            height_mm: 30.0,
            inverse_time: false,
            length_mm: 150.0,
            out: "s.ngc".into(),
            poses: 101,
            segments: 100,
            tcp: true,
            tip_path_mm: 600.0,
            width_mm: 100.0,
        };
        let back: SShapeProgramDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        assert_eq!(
            d.to_string(),
            "S-shaped piece 150.0 x 100.0 x 30.0 mm, 100 segments, tip path 600.00 mm at F1000 (36.0 s) → s.ngc\n"
        );
    }
}
