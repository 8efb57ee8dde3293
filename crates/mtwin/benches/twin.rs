//! The digital twin end to end (servo models, kinematics with the 41 error terms,
//! exact global nearest point, summary): samples per second on the AC trunnion with
//! errors and five servo models (`examples/machines/ac-trunnion-twin.toml`), on a
//! smooth five-axis trajectory at 1 ms of 10k, 100k and 1M samples (growth with
//! length). Rows go to a sink that sums the errors (no CSV formatting).
//!
//!     cargo bench -p mtwin --bench twin

use std::hint::black_box;
use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use mtwin::methods::twin::{Sources, Twin};
use mtwin::model::read_machine;

/// `n` samples of a five-axis trajectory: sums of two sines per axis, inside the travels.
fn trajectory(n: usize) -> Vec<f64> {
    let waves = [
        [(0.31, 0.2, 40.0), (1.1, 1.0, 20.0)],
        [(0.27, 2.1, 50.0), (0.9, 0.3, 15.0)],
        [(0.19, 0.7, 30.0), (1.3, 2.2, 10.0)],
        [(0.23, 1.4, 30.0), (0.7, 0.1, 10.0)],
        [(0.11, 0.5, 120.0), (0.5, 1.9, 40.0)],
    ];
    let mut q = Vec::with_capacity(5 * n);
    for k in 0..n {
        let t = k as f64 * 0.001;
        for w in &waves {
            q.push(
                w.iter()
                    .map(|(f, ph, a)| a * (2.0 * std::f64::consts::PI * f * t + ph).sin())
                    .sum(),
            );
        }
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
    for n in [10_000usize, 100_000, 1_000_000] {
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
