//! Forward kinematics throughput on one core, for whole-process timing with `/usr/bin/time`:
//!
//! `cargo build --release --example fk_throughput -p mtwin`
//! `/usr/bin/time -f "%U s user" target/release/examples/fk_throughput 20000000 [single|batch]`
//!
//! Evaluates N poses of the AC trunnion with all 41 error terms of the [R5] example on one thread,
//! random poses from a xorshift generator (included in the time): `single` calls
//! `Kinematics::pose` per pose, `batch` (default) fills blocks of 4096 positions and calls
//! `Kinematics::poses_into`.

use std::path::Path;

use mtwin::kinematics::ToolPose;
use nalgebra::Vector3;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args
        .next()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000);
    let batch = args.next().as_deref() != Some("single");
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines/ac-trunnion-with-errors.toml");
    let m = mtwin::model::read_machine(&path).expect("example machine");
    let k = mtwin::kinematics::Kinematics::new(&m);
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |lo: f64, hi: f64| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
    };
    let mut acc = 0.0;
    let t = std::time::Instant::now();
    if batch {
        const BLOCK: usize = 4096;
        let mut qs = vec![0.0; BLOCK * 5];
        let zero = ToolPose {
            tip: Vector3::zeros(),
            axis: Vector3::zeros(),
        };
        let mut out = vec![zero; BLOCK];
        let mut done = 0;
        while done < n {
            let b = BLOCK.min(n - done);
            for q in qs[..5 * b].chunks_exact_mut(5) {
                for (v, a) in q.iter_mut().zip(&m.axes) {
                    *v = next(a.travel[0], a.travel[1]);
                }
            }
            k.poses_into(&qs[..5 * b], &mut out[..b]);
            acc += out[..b].iter().map(|p| p.tip.x + p.axis.z).sum::<f64>();
            done += b;
        }
    } else {
        let mut q = [0.0; 5];
        for _ in 0..n {
            for (v, a) in q.iter_mut().zip(&m.axes) {
                *v = next(a.travel[0], a.travel[1]);
            }
            let p = k.pose(&q);
            acc += p.tip.x + p.axis.z;
        }
    }
    let dt = t.elapsed().as_secs_f64();
    println!(
        "{n} poses ({}) in {dt:.3} s wall: {:.2} million poses/s (checksum {acc:.6e})",
        if batch { "batch" } else { "single" },
        n as f64 / dt / 1e6
    );
}
