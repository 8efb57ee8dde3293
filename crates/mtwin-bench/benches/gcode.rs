//! Throughput of the G-code engine on a synthetic five-axis program
//! (generated here: G93 moves with X Y Z A C words, comments, line numbers).
//!
//!     cargo bench -p mtwin-bench --bench gcode
//!
//! Times are the CPU time of the benchmark thread where Linux reports it
//! (`/proc/thread-self/schedstat`), so a busy machine does not inflate them;
//! elsewhere wall time.

use std::hint::black_box;
use std::io::Write;
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mtwin::gcode::{self, Block, BlockReader, StatsOptions};

/// About `lines` blocks of a TCP five-axis finishing program.
fn synthetic_program(lines: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(lines * 64);
    out.extend_from_slice(
        b"%\n(synthetic five-axis program)\nM428 ;TCP on\nG21 G90 G17 G40 G54\nG93\nS12000 M3\n",
    );
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut rnd = || {
        // xorshift64: reproducible pseudo-random digits without a dependency.
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for i in 0..lines {
        let t = i as f64 * 1e-3;
        let (x, y, z) = (
            40.0 * t.cos() + rnd(),
            40.0 * t.sin() - rnd(),
            -5.0 + 2.0 * rnd(),
        );
        let (a, c) = (-30.0 * (t * 0.1).sin(), (i as f64 * 0.05) % 360.0);
        if i % 50 == 0 {
            writeln!(out, "N{i} (pass {})", i / 50).unwrap();
        }
        writeln!(
            out,
            "G1 X{x:.3} Y{y:.3} Z{z:.3} A{a:.3} C{c:.3} F{:.1}",
            200.0 + 100.0 * rnd()
        )
        .unwrap();
    }
    out.extend_from_slice(b"M429 ;TCP off\nM30\n%\n");
    out
}

/// CPU time consumed by this thread so far, if the OS reports it.
fn thread_cpu_time() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = s.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(ns))
}

/// Runs `f` `iters` times; CPU time of the thread if known, else wall time.
fn timed<F: FnMut()>(iters: u64, mut f: F) -> Duration {
    let (cpu0, wall0) = (thread_cpu_time(), Instant::now());
    for _ in 0..iters {
        f();
    }
    match (cpu0, thread_cpu_time()) {
        (Some(a), Some(b)) => b - a,
        _ => wall0.elapsed(),
    }
}

fn benches(c: &mut Criterion) {
    let program = synthetic_program(200_000);
    let mut group = c.benchmark_group("gcode");
    group.throughput(Throughput::Bytes(program.len() as u64));
    group.sample_size(10);

    group.bench_function("parse", |b| {
        b.iter_custom(|iters| {
            timed(iters, || {
                let mut reader = BlockReader::new(&program[..]);
                let mut block = Block::default();
                let mut words = 0usize;
                while reader.read_block(&mut block).unwrap() {
                    words += block.words().count();
                }
                black_box(words);
            })
        })
    });

    group.bench_function("parse+rewrite Z", |b| {
        let mut out = Vec::with_capacity(program.len() + program.len() / 8);
        b.iter_custom(|iters| {
            timed(iters, || {
                out.clear();
                let mut reader = BlockReader::new(&program[..]);
                let mut block = Block::default();
                while reader.read_block(&mut block).unwrap() {
                    if let Ok(Some(z)) = block.word('Z') {
                        let v = z.number().unwrap_or(0.0) + 0.0125;
                        block.set_word('Z', v).unwrap();
                    }
                    block.write_to(&mut out).unwrap();
                }
                black_box(out.len());
            })
        })
    });

    group.bench_function("stats", |b| {
        let opts = StatsOptions::default();
        b.iter_custom(|iters| {
            timed(iters, || {
                black_box(gcode::stats(&program[..], &opts).unwrap().feed_time);
            })
        })
    });
    group.finish();
}

criterion_group!(gcode_benches, benches);
criterion_main!(gcode_benches);
