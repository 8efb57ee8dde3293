//! Skiving set-up error: exact identification from the six touches of the
//! standard plan, and from 60 touches (ten repeats).
//!
//! `cargo bench -p mtwin-bench --bench skiving`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use mtwin::methods::skiving::program::Plan;
use mtwin::methods::skiving::simulate::{Noise, simulate};
use mtwin::methods::skiving::{Geometry, Options, SetupError, identify};

fn bench(c: &mut Criterion) {
    let g = Geometry::new(80.0, 150.0, 40.0, 60.0).expect("valid geometry");
    let plan = Plan::standard(0.0, &g).touches(&g).expect("valid plan");
    let truth = SetupError {
        dgx: 0.03,
        dgy: -0.02,
        exz: 2e-4,
        ezy: -1e-4,
    };
    let noise = |seed| Some(Noise { sigma: 1e-3, seed });
    let six = simulate(&plan, &g, &truth, noise(1)).expect("contacts");
    let mut sixty = Vec::new();
    for seed in 0..10 {
        sixty.extend(simulate(&plan, &g, &truth, noise(seed)).expect("contacts"));
    }
    let opts = Options::with_noise(Some(1e-3));
    c.bench_function("skiving identify 6 touches", |b| {
        b.iter(|| identify(black_box(&six), &g, &opts).expect("identifiable"))
    });
    c.bench_function("skiving identify 60 touches", |b| {
        b.iter(|| identify(black_box(&sixty), &g, &opts).expect("identifiable"))
    });
    c.bench_function("skiving simulate 6 touches", |b| {
        b.iter(|| simulate(black_box(&plan), &g, &truth, None).expect("contacts"))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
