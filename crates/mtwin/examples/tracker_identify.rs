//! Laser tracker: identify the AFP gantry's errors (cubic PDGEs and
//! location errors) from 180 simulated tip measurements on D-optimal poses,
//! then check the identified model on the body diagonals.
//!
//! `cargo run -p mtwin --example tracker_identify`

use mtwin::methods::tracker::{self, IdentifyOptions};
use mtwin::model::ParameterSet;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let truth = mtwin::examples::machine("afp-gantry-with-errors")?;
    let model = mtwin::examples::machine("afp-gantry")?;
    let params = ParameterSet::from_spec(&model, "pdge:cheb3,location")?;
    // 180 of 1000 candidate poses, measured with 10 µm noise.
    let plan = tracker::plan::plan(&model, &params, 1000, 180, 0.010, 1)?;
    let points = tracker::simulate::simulate_seeded(&truth, &plan.poses, 0.010, 1);
    let id = tracker::identify(
        &model,
        &params,
        &points,
        &IdentifyOptions::default(),
        &|_| {},
    )?;
    println!(
        "{} parameters, rank {}, residual rms {:.4} mm",
        params.len(),
        id.report.identifiability.rank,
        id.report.groups.first().map_or(f64::NAN, |g| g.rms_after)
    );
    // Held-out poses: the body diagonals of the work volume.
    let check = tracker::simulate::body_diagonal_poses(&model, 25);
    let measured = tracker::simulate::simulate_seeded(&truth, &check, 0.010, 2);
    let v = tracker::validate(&id.machine, &measured);
    println!(
        "body diagonals ({} points): largest tip error {:.3} mm before, {:.3} mm after",
        v.points, v.before.distance.max, v.after.distance.max
    );
    Ok(())
}
