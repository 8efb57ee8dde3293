//! Digital twin: predict the tool-tip error of a short program on the AC
//! trunnion with its servos and geometric errors (bundled
//! `ac-trunnion-twin`), all sources and geometry alone.
//!
//! `cargo run -p mtwin --example twin`

use mtwin::gcode::InterpolateOptions;
use mtwin::methods::twin::{self, Sources, Twin};

/// A square at 2000 mm/min with a C move, no TCP.
const PROGRAM: &str = "G21 G90 G94 G17
G0 X0 Y0 Z10 A0 C0
G1 Z0 F1000
G1 X30 F2000
G1 Y30
G1 X0 C30
G1 Y0
G0 Z10
M30
";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let machine = mtwin::examples::machine("ac-trunnion-twin")?;
    for sources in [Sources::All, Sources::Geometry] {
        let model = Twin::new(&machine, sources)?;
        let summary = twin::predict_gcode(
            &model,
            &machine,
            PROGRAM.as_bytes(),
            &InterpolateOptions::new(0.001),
            |_| Ok(()),
            &mut |_| {},
        )?;
        println!(
            "{sources:?}: {} samples over {:.3} mm, tip error max {:.2} µm, rms {:.2} µm",
            summary.samples,
            summary.path_length,
            summary.tip_error_max * 1e3,
            summary.tip_error_rms * 1e3
        );
    }
    Ok(())
}
