//! The jerk-limited planner on a long path: a 100 000-point five-joint
//! TCP-like helix (X, Y, Z, a rotary joint turning with the tool and a
//! nodding one), planned, then sampled at 1 kHz (positions of every joint,
//! consumed by a sum).
//!
//!     cargo bench -p mtwin-bench --bench jerk

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use mtwin::gcode::plan::jerk::{JerkOptions, JointLimits, JointPath, plan};

fn helix(points: usize) -> JointPath {
    let (radius, pitch, turns) = (40.0, 0.5, 200.0);
    let mut q = Vec::with_capacity(points * 5);
    let mut s = Vec::with_capacity(points);
    let mut prev = [0.0; 3];
    for k in 0..points {
        let th = turns * std::f64::consts::TAU * k as f64 / (points - 1) as f64;
        let p = [radius * th.cos(), radius * th.sin(), pitch * th];
        q.extend_from_slice(&[p[0], p[1], p[2], th.to_degrees(), 20.0 * (0.1 * th).sin()]);
        let d = if k == 0 {
            0.0
        } else {
            ((p[0] - prev[0]).powi(2) + (p[1] - prev[1]).powi(2) + (p[2] - prev[2]).powi(2)).sqrt()
        };
        s.push(s.last().copied().unwrap_or(0.0) + d);
        prev = p;
    }
    JointPath::new(5, s, q, vec![100.0; points]).expect("the helix is a valid path")
}

fn bench(c: &mut Criterion) {
    let path = helix(100_000);
    let limits = JointLimits {
        v: vec![200.0, 200.0, 100.0, 360.0, 90.0],
        a: vec![2000.0, 2000.0, 1000.0, 3600.0, 900.0],
        j: vec![40000.0, 40000.0, 20000.0, 72000.0, 18000.0],
    };
    let opts = JerkOptions::default();
    let mut g = c.benchmark_group("jerk");
    g.sample_size(10);
    g.bench_function("plan_helix_100k_points", |b| {
        b.iter(|| black_box(plan(&path, &limits, &opts).expect("the helix plans")))
    });
    let law = plan(&path, &limits, &opts).expect("the helix plans");
    g.bench_function("sample_helix_1khz", |b| {
        b.iter(|| {
            let mut s = law.sampler(0.001);
            let mut out = [0.0; 5];
            let mut sum = 0.0;
            while s.next_into(&mut out).is_some() {
                sum += out[0];
            }
            black_box(sum)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
