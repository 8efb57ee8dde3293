//! Interpolating the corpus impeller (LinuxCNC `impeller-7bl-xyzac.ngc`,
//! 4510 lines of G93 TCP five-axis moves) at 1 ms on the AC trunnion example
//! (C travel widened to ±36000° as in the corpus's xyzac-trt.ini), samples
//! consumed by a counter; and planning plus sampling the boat
//! (`boat-xyzac.ngc`, M428 TCP) at 1 ms under `--planner linuxcnc` with
//! xyzac-trt's limits, once and repeated 10 and 100 times (look-ahead cost
//! linear in the program length: the ×10 run should take ten times as long,
//! the ×100 run a hundred times; the ×100 run, 56.7 M samples, is sampled
//! flat: ten runs of one iteration each), and the same once and 10 times
//! under `--planner jerk` (jerk limits 3000 mm/s³ and deg/s³).
//!
//!     cargo bench -p mtwin-bench --bench interpolate
//!
//! Skipped with a message when /work/shared (the corpus) is absent.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};
use mtwin::gcode::plan::{PlanOptions, Planner};
use mtwin::gcode::{InterpolateOptions, interpolate};
use mtwin::model::{AxisKind, read_machine};

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
    // The boat under the linuxcnc planner, xyzac-trt limits.
    let boat = root.join("../../../shared/corpus/gcode/linuxcnc/boat-xyzac.ngc");
    if let Ok(text) = std::fs::read_to_string(&boat) {
        let mut m = machine.clone();
        for a in m.axes.iter_mut() {
            let lin = a.kind == AxisKind::Linear;
            a.max_velocity = Some(if lin { 20.0 } else { 30.0 });
            a.max_acceleration = Some(300.0);
            a.max_jerk = Some(3000.0);
        }
        m.rapid_feed = 35.0 * 60.0;
        // Repeating the program body: M2 only at the end, M428 once.
        let body: String = text
            .lines()
            .filter(|l| !l.trim_start().starts_with('%') && !l.contains("M2") && !l.contains("M30"))
            .map(|l| format!("{l}\n"))
            .collect();
        for (planner, reps) in [
            (Planner::Linuxcnc, 1usize),
            (Planner::Linuxcnc, 10),
            (Planner::Jerk, 1),
            (Planner::Jerk, 10),
            (Planner::Linuxcnc, 100),
        ] {
            let mut opts = InterpolateOptions::new(0.001);
            opts.plan = PlanOptions::new(planner);
            opts.check_travel = false;
            // The ×100 boat needs more samples than the default bound.
            opts.max_samples = u64::MAX;
            let prog = body.repeat(reps) + "M2\n";
            if reps >= 100 {
                g.sampling_mode(SamplingMode::Flat);
            }
            g.bench_function(format!("boat_{planner}_1ms_x{reps}"), |b| {
                b.iter(|| {
                    let mut n = 0u64;
                    let s = interpolate(prog.as_bytes(), &m, &opts, |s| {
                        n += 1;
                        black_box(s.q);
                        Ok(())
                    })
                    .expect("the boat interpolates");
                    black_box((n, s))
                })
            });
        }
    } else {
        eprintln!("skipping the boat: {} is absent", boat.display());
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
