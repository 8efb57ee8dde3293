//! Thermal: fit the spindle-speed-driven Z drift model from simulated
//! probing runs, then compensate a program that runs the spindle for 30 min.
//!
//! `cargo run -p mtwin --example thermal`

use mtwin::methods::thermal::{self, ThermalFitOptions, TruthMachine};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The "real" machine and three training runs (speeds per sample period)
    // probed at four heights with 0.1 µm noise.
    let truth = TruthMachine::demo();
    let heights = [-50.0, -150.0, -250.0, -350.0];
    let runs = vec![
        ("const4000", vec![4000.0; 48]),
        ("const8000", vec![8000.0; 48]),
        (
            "steps",
            [2000.0, 6000.0, 0.0, 8000.0, 4000.0, 1000.0, 7000.0, 3000.0]
                .iter()
                .flat_map(|&s| [s; 6])
                .collect(),
        ),
    ];
    let csv = truth.training_csv(&runs, &heights, 1e-4, 11);
    let table = mtwin::io::Table::from_reader(std::path::Path::new("TRAIN.csv"), csv.as_bytes())?;
    let data = thermal::training_from_table(&table, &[])?;
    let model = thermal::fit(&data, &ThermalFitOptions::default())?.model;
    for h in model.heights() {
        let rms = h.stats.as_ref().map_or(f64::NAN, |s| s.simulation_rms_mm);
        println!("z = {:6.1} mm: simulation rms {:.2} µm", h.z_mm, rms * 1e3);
    }

    // A program: spindle at 6000 rev/min, a face at Z-100 before and after 30 min.
    let program = "G21 G90 G94\nS6000 M3\nG0 X0 Y0 Z5\nG1 Z-100 F500\nG1 X50 F1000\nG0 Z5\n\
                   G4 P1800\nG1 Z-100 F500\nG1 X0 F1000\nG0 Z5\nM5\nM30\n";
    let comp = thermal::compensate(
        &model,
        program.as_bytes(),
        &thermal::CompensateOptions::default(),
    )?;
    for b in comp.z_blocks.iter().filter(|b| b.changed) {
        println!(
            "line {:2} at {:5.1} min: predicted drift compensated {:+.2} µm",
            b.line,
            b.end_min,
            b.correction_mm * 1e3
        );
    }
    Ok(())
}
