//! Skiving: the workpiece set-up error (centre offset and tilt) from twelve
//! simulated touch-offs on the gear blank.
//!
//! `cargo run -p mtwin --example skiving`

use mtwin::methods::skiving::{self, Geometry, SetupError, program::Plan};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Blank and tool geometry (mm), the standard touch plan.
    let g = Geometry::new(80.0, 150.0, 40.0, 60.0)?;
    let plan = Plan::standard(0.0, &g).touches(&g)?;
    // The set-up error to find: 30 µm / -20 µm offset, 200 / -100 µrad tilt.
    let truth = SetupError {
        dgx: 0.03,
        dgy: -0.02,
        exz: 2e-4,
        ezy: -1e-4,
    };
    let touches = skiving::simulate::simulate(
        &plan,
        &g,
        &truth,
        Some(skiving::simulate::Noise {
            sigma: 0.001,
            seed: 1,
        }),
    )?;
    let sol = skiving::identify(&touches, &g, &skiving::Options::with_noise(Some(0.001)))?;
    let e = sol.estimate;
    println!("{} touches, 1 µm noise", touches.len());
    println!("dgx {:+.2} µm (true {:+.2})", e.dgx * 1e3, truth.dgx * 1e3);
    println!("dgy {:+.2} µm (true {:+.2})", e.dgy * 1e3, truth.dgy * 1e3);
    println!(
        "exz {:+.1} µrad (true {:+.1})",
        e.exz * 1e6,
        truth.exz * 1e6
    );
    println!(
        "ezy {:+.1} µrad (true {:+.1})",
        e.ezy * 1e6,
        truth.ezy * 1e6
    );
    Ok(())
}
