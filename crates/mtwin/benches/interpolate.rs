//! Interpolating the corpus impeller (LinuxCNC `impeller-7bl-xyzac.ngc`,
//! 4510 lines of G93 TCP five-axis moves) at 1 ms on the AC trunnion example
//! (C travel widened to ±36000° as in the corpus's xyzac-trt.ini), samples
//! consumed by a counter.
//!
//!     cargo bench -p mtwin --bench interpolate
//!
//! Skipped with a message when /work/shared (the corpus) is absent.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use mtwin::gcode::{InterpolateOptions, interpolate};
use mtwin::model::read_machine;

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let program = root.join("../../../shared/corpus/gcode/linuxcnc/impeller-7bl-xyzac.ngc");
    let Ok(text) = std::fs::read(&program) else {
        eprintln!("skipping: {} is absent", program.display());
        return;
    };
    let mut machine = read_machine(&root.join("../../examples/machines/ac-trunnion.toml"))
        .expect("the example machine reads");
    let c_axis = machine.axis_index("C").expect("the example has a C axis");
    machine.axes[c_axis].travel = [-36000.0, 36000.0];
    let opts = InterpolateOptions::new(0.001);
    let mut g = c.benchmark_group("interpolate");
    g.sample_size(10);
    g.bench_function("impeller_tcp_1ms", |b| {
        b.iter(|| {
            let mut n = 0u64;
            let s = interpolate(&text[..], &machine, &opts, |s| {
                n += 1;
                black_box(s.q);
                Ok(())
            })
            .expect("the impeller interpolates");
            black_box((n, s))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
