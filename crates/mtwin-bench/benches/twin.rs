//! The digital twin end to end (servo models, kinematics with the 41 error terms,
//! exact global nearest point, summary): samples per second on the AC trunnion with
//! errors and five servo models (`examples/machines/ac-trunnion-twin.toml`), on a
//! five-axis raster at 1 ms of 10k, 100k, 1M and 3.6M samples (an hour at 1 kHz; growth
//! with length). Rows go to a sink that sums the errors (no CSV formatting).
//!
//!     cargo bench -p mtwin-bench --bench twin

use std::hint::black_box;
use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use mtwin::methods::twin::{Sources, Twin};
use mtwin::model::read_machine;

/// `n` samples of a five-axis finishing-like trajectory at 1 ms: X sweeps ±50 mm once a
/// second, Y steps over 0.5 mm per pass, Z waves, A and C turn slowly. Passes do not
/// lie on each other, as in a real program.
pub fn trajectory(n: usize) -> Vec<f64> {
    use std::f64::consts::PI;
    let mut q = Vec::with_capacity(5 * n);
    for k in 0..n {
        let t = k as f64 * 0.001;
        q.extend_from_slice(&[
            -250.0 + 0.5 * t,
            50.0 * (PI * t).sin(),
            5.0 * (0.7 * t).sin() - 20.0,
            20.0 * (2.0 * PI * 0.01 * t).sin(),
            30.0 * (2.0 * PI * 0.013 * t).sin(),
        ]);
    }
    q
}

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let machine = read_machine(&root.join("../../examples/machines/ac-trunnion-twin.toml"))
        .expect("the example machine reads");
    assert_eq!(machine.n_error_terms(), 41);
    let twin = Twin::new(&machine, Sources::All).expect("the servo models are valid");
    let mut g = c.benchmark_group("twin");
    g.sample_size(10);
    for n in [10_000usize, 100_000, 1_000_000, 3_600_000] {
        let qs = trajectory(n);
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::new("predict", n), &qs, |b, qs| {
            b.iter(|| {
                let mut p = twin.start(0.001).expect("1 ms servos");
                for (k, q) in qs.chunks_exact(5).enumerate() {
                    p.push(k as f64 * 0.001, q).expect("spool");
                }
                let mut sum = 0.0;
                let s = p
                    .finish(
                        |r| {
                            sum += r.tip_error + r.axis_error;
                            Ok(())
                        },
                        &mut |_| {},
                    )
                    .expect("runs");
                black_box((sum, s))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
