//! Forward kinematics throughput on one core, for whole-process timing with `/usr/bin/time`:
//!
//! `cargo build --release --example fk_throughput -p mtwin`
//! `/usr/bin/time -f "%U s user" target/release/examples/fk_throughput 20000000`
//!
//! Evaluates N poses of the AC trunnion with all 41 error terms of spec 05 on one thread.

use std::path::Path;

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000);
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines/ac-trunnion-with-errors.toml");
    let m = mtwin::model::read_machine(&path).expect("example machine");
    let k = mtwin::kinematics::Kinematics::new(&m);
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut q = [0.0; 5];
    let mut acc = 0.0;
    let t = std::time::Instant::now();
    for _ in 0..n {
        for (i, a) in m.axes.iter().enumerate() {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            q[i] = a.travel[0]
                + (a.travel[1] - a.travel[0]) * ((s >> 11) as f64 / (1u64 << 53) as f64);
        }
        let p = k.pose(&q);
        acc += p.tip.x + p.axis.z;
    }
    let dt = t.elapsed().as_secs_f64();
    println!(
        "{n} poses in {dt:.3} s wall: {:.2} million poses/s (checksum {acc:.6e})",
        n as f64 / dt / 1e6
    );
}
