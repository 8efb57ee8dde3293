//! Throughput of `methods::compensate` on a synthetic five-axis program
//! (plain, non-TCP: X Y Z A C axis words, short feed moves, comments) with the
//! AC trunnion error model; bytes of input per second on one core. Then the
//! corpus's real five-axis TCP program (boat), when `../shared` is present.
//!
//!     cargo bench -p mtwin-bench --bench compensate

use std::hint::black_box;
use std::io::Write;
use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mtwin::methods::compensate::{CompensateOptions, Compensator};
use mtwin::model::read_machine;

/// `lines` feed moves along a tilted helix-like finishing path.
fn synthetic_program(lines: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(lines * 48);
    out.extend_from_slice(
        b"%\n(synthetic five-axis program)\nG21 G90 G17 G94\nG0 X40 Y0 Z-50 A20 C0\nG1 F1500\n",
    );
    for i in 0..lines {
        let t = i as f64 * 2e-3;
        let (x, y, z) = (
            40.0 * t.cos(),
            40.0 * t.sin(),
            -50.0 - 0.01 * i as f64 % 20.0,
        );
        let (a, c) = (20.0 + 10.0 * (t * 0.1).sin(), (i as f64 * 0.05) % 300.0);
        if i % 50 == 0 {
            writeln!(out, "(pass {})", i / 50).unwrap();
        }
        writeln!(out, "G1 X{x:.4} Y{y:.4} Z{z:.4} A{a:.4} C{c:.4}").unwrap();
    }
    out.extend_from_slice(b"M30\n%\n");
    out
}

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines/ac-trunnion-with-errors.toml");
    let machine = read_machine(&path).expect("example machine");
    let comp = Compensator::new(&machine, CompensateOptions::default()).expect("axis names");
    let program = synthetic_program(20_000);
    let mut out = Vec::with_capacity(program.len() * 2);
    let mut g = c.benchmark_group("compensate");
    g.throughput(Throughput::Bytes(program.len() as u64));
    g.sample_size(10);
    g.bench_function("ac-trunnion five-axis program", |b| {
        b.iter(|| {
            out.clear();
            let s = comp
                .run(black_box(&program[..]), &mut out)
                .expect("compensates");
            black_box(s.blocks_changed)
        })
    });
    g.finish();

    // A real five-axis CAM program: the LinuxCNC corpus boat (TCP, M428), on
    // the same machine with zero work offsets (docs/gcode.md, "Corpus programs").
    let boat = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/corpus/gcode/linuxcnc/boat-xyzac.ngc");
    let Ok(boat) = std::fs::read(&boat) else {
        eprintln!(
            "skipping compensate/corpus boat: {} not found (../shared/corpus is absent)",
            boat.display()
        );
        return;
    };
    let mut opts = CompensateOptions::default();
    opts.max_correction = 2.0;
    let comp = Compensator::new(&machine, opts).expect("axis names");
    let mut g = c.benchmark_group("compensate");
    g.throughput(Throughput::Bytes(boat.len() as u64));
    g.sample_size(20);
    g.bench_function("corpus boat-xyzac.ngc (TCP)", |b| {
        b.iter(|| {
            out.clear();
            let s = comp
                .run(black_box(&boat[..]), &mut out)
                .expect("compensates");
            black_box(s.blocks_changed)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
