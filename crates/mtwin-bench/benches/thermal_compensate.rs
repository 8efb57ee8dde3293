//! Thermal pre-compensation of a face-milling program of 100 000 blocks
//! (every other block a Z move), corrections updated continuously.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mtwin::methods::thermal::{
    CompensateOptions, CorrectionUpdate, HeightModel, InputChannel, ThermalModel, compensate,
};
use mtwin::sysid::Arx;

fn model() -> ThermalModel {
    let h = |z: f64, g: f64| HeightModel {
        z_mm: z,
        model: Arx::new(vec![1.0, -0.8], vec![(vec![0.2 * g], 1)]).unwrap(),
        stats: None,
    };
    let inputs = vec![InputChannel::linear("speed_rpm", 1000.0)];
    ThermalModel::new(10.0, inputs, vec![h(-350.0, -0.002), h(-50.0, -0.005)]).unwrap()
}

fn bench(c: &mut Criterion) {
    let mut src = String::from("G21 G90 G94\nS6000 M3\n");
    for i in 0..50_000 {
        let x = if i % 2 == 0 { 200 } else { 0 };
        src.push_str(&format!(
            "G1 X{x} Y{} Z-50.{} F2000\nG1 Y{}\n",
            i % 100,
            i % 10,
            i % 100 + 1
        ));
    }
    let m = model();
    let mut opts = CompensateOptions::default();
    opts.update = CorrectionUpdate::Continuous;
    let mut g = c.benchmark_group("thermal_compensate");
    g.throughput(Throughput::Bytes(src.len() as u64));
    g.sample_size(10);
    g.bench_function("100k_blocks_continuous", |b| {
        b.iter(|| compensate(&m, src.as_bytes(), &opts).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
