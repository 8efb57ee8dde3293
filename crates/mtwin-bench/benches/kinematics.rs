//! Forward kinematics with errors on the AC trunnion with all 41 error terms of the [R5] example (docs/references.md).
//!
//! `cargo bench -p mtwin-bench --bench kinematics`

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mtwin::kinematics::Kinematics;
use mtwin::model::read_machine;

fn poses(n: usize, m: &mtwin::model::Machine) -> Vec<f64> {
    let mut s = 0x1234_5678_9abc_def0u64;
    let mut out = Vec::with_capacity(n * m.n_axes());
    for _ in 0..n {
        for a in &m.axes {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let r = (s >> 11) as f64 / (1u64 << 53) as f64;
            out.push(a.travel[0] + (a.travel[1] - a.travel[0]) * r);
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines/ac-trunnion-with-errors.toml");
    let m = read_machine(&path).expect("example machine");
    assert_eq!(m.n_error_terms(), 41);
    let k = Kinematics::new(&m);
    let n = 100_000;
    let qs = poses(n, &m);
    let mut g = c.benchmark_group("fk_41_terms");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("single_core", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for q in qs.chunks_exact(5) {
                let p = k.pose(black_box(q));
                acc += p.tip.x + p.axis.z;
            }
            acc
        })
    });
    let mut out = vec![k.pose(&qs[..5]); n];
    g.bench_function("batch_single_core", |b| {
        b.iter(|| k.poses_into(black_box(&qs), &mut out))
    });
    g.bench_function("batch_rayon", |b| {
        b.iter(|| k.par_poses_into(black_box(&qs), &mut out))
    });
    g.bench_function("batch_rayon_alloc", |b| b.iter(|| k.poses(black_box(&qs))));
    g.finish();
    // The Jacobian is ~100x dearer than a pose; time it on fewer poses and
    // declare that count so the reported element rate is per Jacobian.
    let nj = 10_000;
    let mut g = c.benchmark_group("jacobian_41_terms");
    g.throughput(Throughput::Elements(nj as u64));
    g.bench_function("single_core", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for q in qs[..5 * nj].chunks_exact(5) {
                acc += k.jacobian(black_box(q)).components[0][0][0];
            }
            acc
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
