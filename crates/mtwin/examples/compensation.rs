//! Geometric compensation: rewrite a five-axis (TCP) program so that the AC
//! trunnion with errors puts the tool where the program meant it.
//!
//! `cargo run -p mtwin --example compensation`

use mtwin::methods::compensate::{CompensateOptions, Compensator};

/// A short TCP program: a tilted line and an arc with the rotary axes moving.
const PROGRAM: &str = "G21 G90 G94 G17
G43.4 H0
G0 X0 Y0 Z20 A0 C0
G1 Z5 F500
G1 X40 Y10 A10 C20 F1000
G2 X60 Y30 I10 J10 A15 C45
G1 Z20
G49
M30
";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let machine = mtwin::examples::machine("ac-trunnion-with-errors")?;
    let mut opts = CompensateOptions::default();
    opts.max_correction = 2.0; // mm
    let comp = Compensator::new(&machine, opts)?;
    let mut out = Vec::new();
    let summary = comp.run(PROGRAM.as_bytes(), &mut out)?;
    println!(
        "{} blocks, {} changed, largest correction {:.1} µm",
        summary.blocks,
        summary.blocks_changed,
        summary.largest_correction * 1e3
    );
    println!("first blocks of the compensated program:");
    for line in String::from_utf8(out)?.lines().take(6) {
        println!("  {line}");
    }
    Ok(())
}
