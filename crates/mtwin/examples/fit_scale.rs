//! The identification engine at scale, for whole-process timing with `/usr/bin/time`:
//!
//! `cargo build --release --example fit_scale -p mtwin`
//! `/usr/bin/time -f "%U s user %e s wall" target/release/examples/fit_scale 100000 32`
//!
//! Simulates N laser-tracker points (1 µm noise) of the AC trunnion with all 41 error terms
//! of the [R5] example, then identifies `pdge:cheb<D>,location` (30·(D+1) + 30 parameters: 1 020 for
//! D = 32) with [`mtwin::methods::tracker::identify`] on the normal-equation path.
//! `FIT_SCALE_ROWS=1` forms Jacobian rows instead of using the factored Jacobian;
//! `FIT_SCALE_VERBOSE=1` prints every progress report.

use std::path::Path;
use std::time::Instant;

use mtwin::methods::tracker::simulate::{random_poses, simulate};
use mtwin::methods::tracker::{IdentifyOptions, identify};
use mtwin::model::ParameterSet;
use rand::SeedableRng;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let deg: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(32);
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines/ac-trunnion-with-errors.toml");
    let truth = mtwin::model::read_machine(&path).expect("example machine");
    let nominal = truth.nominal();
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let poses = random_poses(&nominal, n, &mut rng);
    let points = simulate(&truth, &poses, 0.001, &mut rng);
    let params = ParameterSet::from_spec(&nominal, &format!("pdge:cheb{deg},location"))
        .expect("specification");
    let t = Instant::now();
    let verbose = std::env::var_os("FIT_SCALE_VERBOSE").is_some();
    let mut options = IdentifyOptions::default();
    // FIT_SCALE_ROWS=1: form Jacobian rows instead of using the factored Jacobian.
    options.fit.factored = std::env::var_os("FIT_SCALE_ROWS").is_none();
    let id = identify(&nominal, &params, &points, &options, &|p| {
        if verbose || !matches!(p, mtwin::fit::Progress::Evaluating { .. }) {
            eprintln!("{:8.3} s  {p:?}", t.elapsed().as_secs_f64())
        }
    })
    .expect("identification");
    println!(
        "{n} points: {:.2} s wall; {} mm",
        t.elapsed().as_secs_f64(),
        id.report.summary()
    );
}
