//! The Rust side of `python/benchmarks/predict_1m.py`: `Kinematics::poses` (what
//! `mtwin predict` and Python's `Machine.predict` call) on N random poses of
//! ac-trunnion-with-errors, all cores, best of R runs.
//!
//! `cargo build --release -p mtwin --example predict_1m`
//! `target/release/examples/predict_1m [N=1000000] [R=5]`

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args
        .next()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let runs: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(5);
    let m = mtwin::examples::machine("ac-trunnion-with-errors").expect("example machine");
    let k = mtwin::kinematics::Kinematics::new(&m);
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |lo: f64, hi: f64| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
    };
    let mut qs = Vec::with_capacity(n * m.n_axes());
    for _ in 0..n {
        for a in &m.axes {
            qs.push(next(a.travel[0], a.travel[1]));
        }
    }
    let _ = k.poses(&qs[..1000 * m.n_axes()]);
    let mut best = f64::INFINITY;
    let mut check = 0.0;
    for _ in 0..runs {
        let t = std::time::Instant::now();
        let p = k.poses(&qs);
        best = best.min(t.elapsed().as_secs_f64());
        check += p[n / 2].tip.x;
    }
    // The same, then the poses flattened into one (N, 6) float64 buffer of
    // `x, y, z, i, j, k` rows, as the Python binding does before handing the
    // buffer to NumPy (the part of Python's time that is not the library's call).
    let mut best_flat = f64::INFINITY;
    for _ in 0..runs {
        let t = std::time::Instant::now();
        let p = k.poses(&qs);
        let mut flat = Vec::with_capacity(p.len() * 6);
        for q in &p {
            flat.extend_from_slice(q.tip.as_slice());
            flat.extend_from_slice(q.axis.as_slice());
        }
        best_flat = best_flat.min(t.elapsed().as_secs_f64());
        check += flat[3 * n];
    }
    std::hint::black_box(check);
    println!(
        "rust: Kinematics::poses then flattened to (N, 6), best of {runs}: {:.1} ms",
        best_flat * 1e3
    );
    println!(
        "rust: Kinematics::poses {n} poses, best of {runs}: {:.1} ms",
        best * 1e3
    );
}
