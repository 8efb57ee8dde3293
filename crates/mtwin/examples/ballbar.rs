//! Ballbar: the eight location errors (PIGEs) of the AC trunnion's rotary
//! axes from four simulated ballbar modes.
//!
//! `cargo run -p mtwin --example ballbar`

use mtwin::fit::Options;
use mtwin::methods::ballbar::{
    self, BallbarMode, ModeData, Piges, Rig, SimulationSpec, Trunnion, angle_range, simulate_modes,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The truth: the nominal trunnion with the PIGEs of the example machine with errors.
    let nominal = mtwin::examples::machine("ac-trunnion")?;
    let with_errors = mtwin::examples::machine("ac-trunnion-with-errors")?;
    let t = Trunnion::of(&nominal)?;
    let true_piges = Piges::from_machine(&with_errors, &Trunnion::of(&with_errors)?);
    let mut truth = nominal.clone();
    true_piges.write_to(&mut truth, &t);

    // Every mode over its angle range, 0.3 µm noise on the bar length.
    let rig = Rig::source_paper();
    let specs: Vec<(BallbarMode, SimulationSpec)> = BallbarMode::ALL
        .iter()
        .map(|&m| {
            let angles = if m.moves_a() {
                angle_range(-90.0, 90.0, 10.0)
            } else {
                angle_range(0.0, 360.0, 10.0)
            };
            (
                m,
                SimulationSpec {
                    rig,
                    noise: 0.0003,
                    angles_deg: angles,
                },
            )
        })
        .collect();
    let data = simulate_modes(&truth, &specs, 1)?;
    let refs: [Option<&ModeData>; 4] = [0, 1, 2, 3].map(|i| Some(&data[i]));
    let id = ballbar::identify(&nominal, &rig, &refs, &Options::default())?;

    println!("PIGE   true (mm or rad)   identified");
    for p in ballbar::Pige::ALL {
        println!(
            "{:<6} {:>+16.3e} {:>+12.3e}",
            p.name(),
            true_piges.get(p),
            id.piges.get(p)
        );
    }
    Ok(())
}
