//! Benchmarks of the least-squares engine.
//!
//! * `fit/tracker_162x540`: a synthetic laser-tracker identification of the
//!   size of the source paper [R2] (162 parameters: 6 axes × 6 PDGEs × Chebyshev c0..c3 plus
//!   18 constants; 180 points × 3 coordinates), with the second-order
//!   rotation term making it nonlinear and the Chebyshev constant terms of
//!   parallel translations confounded, as in the real problem. Dense path.
//! * `fit/dense_1000x300000`: 1 000 parameters, 100 000 points (300 000
//!   residual rows), a dense Jacobian of smooth random columns (Chebyshev
//!   polynomials of random coordinates); normal-equation path with Jacobian
//!   rows (a model without a factored Jacobian).
//! * `fit/trunnion_cheb32_1020x300000`: the scale target of issue 3 on the
//!   real measurement model: `pdge:cheb32,location` (1 020 parameters) of the
//!   AC trunnion from 100 000 simulated tracker points (1 µm noise) by
//!   [`identify`]: normal-equation path, factored Jacobian.
//! * `tracker/afp_simulate_identify_180`: the tracker workflow end to end on
//!   the AFP gantry of [R2]: simulate 180 random poses of
//!   `afp-gantry-with-errors.toml` (10 µm noise) and identify
//!   `pdge:cheb3,location` (162 parameters, dense path).
//!
//! Run: `cargo bench -p mtwin-bench --bench fit` (or name one benchmark).

use std::ops::Range;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use faer::MatMut;
use faer::reborrow::ReborrowMut;
use mtwin::fit::{BlockLayout, Model, Options, Parameter, Strategy, check_jacobian, fit};
use mtwin::methods::tracker::simulate::{random_poses, simulate};
use mtwin::methods::tracker::{IdentifyOptions, TrackerPoint, identify};
use mtwin::model::{Machine, ParameterSet, read_machine};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

/// Chebyshev values `T_0..T_{deg}` at `u` into `out`.
fn chebyshev(u: f64, out: &mut [f64]) {
    if out.is_empty() {
        return;
    }
    out[0] = 1.0;
    if out.len() > 1 {
        out[1] = u;
    }
    for k in 2..out.len() {
        out[k] = 2.0 * u * out[k - 1] - out[k - 2];
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Synthetic tracker problem: tool-tip error
/// `Σ translations + ω × l + ½ ω × (ω × l)` with
/// `ω = Σ rotation PDGEs`, every PDGE a Chebyshev series in its axis'
/// normalised position, plus 18 constants acting like squareness errors.
struct Tracker {
    /// Per point: normalised axis positions (6) and the lever `l` (mm).
    poses: Vec<([f64; 6], [f64; 3])>,
    measured: Vec<f64>,
    params: Vec<Parameter>,
}

const AXES: usize = 6;
const COEFFS: usize = 4;
const PDGE: usize = AXES * 6 * COEFFS;

impl Tracker {
    fn new(points: usize, seed: u64) -> Self {
        let mut rng = StdRng::seed_from_u64(seed);
        let poses: Vec<([f64; 6], [f64; 3])> = (0..points)
            .map(|_| {
                let u = std::array::from_fn(|_| rng.gen_range(-1.0..1.0));
                let l = [
                    rng.gen_range(-200.0..200.0),
                    rng.gen_range(-200.0..200.0),
                    -500.0 + rng.gen_range(-50.0..50.0),
                ];
                (u, l)
            })
            .collect();
        let comps = ["EX", "EY", "EZ", "EA", "EB", "EC"];
        let axes = ["X", "Y", "Z", "B", "A", "C"];
        let mut params = Vec::new();
        for ax in axes {
            for (c, comp) in comps.iter().enumerate() {
                for k in 0..COEFFS {
                    let scale = if c < 3 { 1e-3 } else { 1e-5 };
                    params.push(Parameter::with_scale(format!("{comp}{ax}.c{k}"), scale));
                }
            }
        }
        for ax in axes {
            for comp in ["EX0", "EY0", "EZ0"] {
                params.push(Parameter::with_scale(format!("{comp}{ax}"), 1e-5));
            }
        }
        let mut t = Self {
            poses,
            measured: vec![0.0; 3 * points],
            params,
        };
        let truth: Vec<f64> = (0..t.params.len())
            .map(|j| t.params[j].scale.unwrap_or(1.0) * rng.gen_range(-3.0..3.0))
            .collect();
        let mut clean = vec![0.0; 3 * points];
        t.residuals(&truth, 0..3 * points, &mut clean);
        let noise = Normal::new(0.0, 0.002).unwrap();
        t.measured = clean.iter().map(|v| v + noise.sample(&mut rng)).collect();
        t
    }

    /// Basis of point `p`: per parameter, its translation (for PDGE
    /// translations and constants) or rotation (rotation PDGEs) direction.
    fn point(&self, theta: &[f64], p: usize, r: &mut [f64; 3], jac: Option<&mut [[f64; 3]]>) {
        let (u, l) = self.poses[p];
        let mut t = [[0.0; COEFFS]; AXES];
        for a in 0..AXES {
            chebyshev(u[a], &mut t[a]);
        }
        let mut trans = [0.0; 3];
        let mut omega = [0.0; 3];
        for a in 0..AXES {
            for c in 0..6 {
                for k in 0..COEFFS {
                    let v = theta[(a * 6 + c) * COEFFS + k] * t[a][k];
                    if c < 3 {
                        trans[c] += v;
                    } else {
                        omega[c - 3] += v;
                    }
                }
            }
        }
        // Constants: a squareness-like error moving the tip in direction
        // `c` proportional to the position of another axis (× 1000 mm).
        for a in 0..AXES {
            for c in 0..3 {
                trans[c] += theta[PDGE + a * 3 + c] * 1000.0 * u[(a + c + 1) % AXES];
            }
        }
        let wl = cross(omega, l);
        let wwl = cross(omega, wl);
        for i in 0..3 {
            r[i] = trans[i] + wl[i] + 0.5 * wwl[i];
        }
        if let Some(jac) = jac {
            // d/dω of ω×l + ½ ω×(ω×l) applied to e_c:
            // e_c×l + ½ (e_c×(ω×l) + ω×(e_c×l)).
            let mut drot = [[0.0; 3]; 3];
            for (c, d) in drot.iter_mut().enumerate() {
                let mut e = [0.0; 3];
                e[c] = 1.0;
                let el = cross(e, l);
                let a1 = cross(e, wl);
                let a2 = cross(omega, el);
                for i in 0..3 {
                    d[i] = el[i] + 0.5 * (a1[i] + a2[i]);
                }
            }
            for (a, ta) in t.iter().enumerate() {
                for c in 0..6 {
                    for (k, &tk) in ta.iter().enumerate() {
                        let j = (a * 6 + c) * COEFFS + k;
                        jac[j] = if c < 3 {
                            let mut v = [0.0; 3];
                            v[c] = tk;
                            v
                        } else {
                            drot[c - 3].map(|x| x * tk)
                        };
                    }
                }
            }
            for a in 0..AXES {
                for c in 0..3 {
                    let mut v = [0.0; 3];
                    v[c] = 1000.0 * u[(a + c + 1) % AXES];
                    jac[PDGE + a * 3 + c] = v;
                }
            }
        }
    }
}

impl Model for Tracker {
    fn parameters(&self) -> Vec<Parameter> {
        self.params.clone()
    }
    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform("tracker", self.poses.len(), 3)
    }
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        if let Some(out) = r {
            for (b, p) in (rows.start / 3..rows.end / 3).enumerate() {
                let mut r = [0.0; 3];
                self.point(theta, p, &mut r, None);
                for i in 0..3 {
                    out[3 * b + i] = r[i] - self.measured[3 * p + i];
                }
            }
        }
        if let Some(mut out) = j {
            let mut jac = vec![[0.0; 3]; self.params.len()];
            for (b, p) in (rows.start / 3..rows.end / 3).enumerate() {
                let mut r = [0.0; 3];
                self.point(theta, p, &mut r, Some(&mut jac));
                for (j, v) in jac.iter().enumerate() {
                    for i in 0..3 {
                        out[(3 * b + i, j)] = v[i];
                    }
                }
            }
        }
    }
}

/// Dense linear problem `r = J·θ − y` with `J[(p, c), j] =
/// W[c][j]·T_{k_j}(u_{p, a_j})`, `k_j = j / 3`, `a_j = j mod 3`.
struct Smooth {
    u: Vec<[f64; 3]>,
    w: [Vec<f64>; 3],
    y: Vec<f64>,
    n: usize,
}

impl Smooth {
    fn new(points: usize, n: usize, seed: u64) -> Self {
        let mut rng = StdRng::seed_from_u64(seed);
        let u = (0..points)
            .map(|_| std::array::from_fn(|_| rng.gen_range(-1.0..1.0)))
            .collect();
        let w = std::array::from_fn(|_| (0..n).map(|_| rng.gen_range(0.5..1.5)).collect());
        let mut s = Self {
            u,
            w,
            y: vec![0.0; 3 * points],
            n,
        };
        let truth: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let mut clean = vec![0.0; 3 * points];
        s.residuals(&truth, 0..3 * points, &mut clean);
        let noise = Normal::new(0.0, 0.01).unwrap();
        s.y = clean.iter().map(|v| v + noise.sample(&mut rng)).collect();
        s
    }

    /// The three Jacobian rows of point `p` into `out` (`3 × n`, row-major
    /// rows of length n); the Chebyshev values are computed once per point.
    fn point(&self, p: usize, cheb: &mut [Vec<f64>; 3], out: &mut [f64]) {
        let deg = self.n.div_ceil(3);
        for (ch, &u) in cheb.iter_mut().zip(&self.u[p]) {
            ch.resize(deg, 0.0);
            chebyshev(u, ch);
        }
        for (c, row) in out.chunks_exact_mut(self.n).enumerate() {
            let w = &self.w[c];
            for (k, o) in row.chunks_exact_mut(3).enumerate() {
                o[0] = w[3 * k] * cheb[0][k];
                o[1] = w[3 * k + 1] * cheb[1][k];
                o[2] = w[3 * k + 2] * cheb[2][k];
            }
            let tail = self.n - self.n % 3;
            for j in tail..self.n {
                row[j] = w[j] * cheb[j % 3][j / 3];
            }
        }
    }

    /// Residuals and (optionally) Jacobian rows of `rows` (whole points).
    fn eval(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: &mut [f64],
        mut jac: Option<MatMut<'_, f64>>,
    ) {
        let mut cheb = [Vec::new(), Vec::new(), Vec::new()];
        let mut buf = vec![0.0; 3 * self.n];
        for (b, p) in (rows.start / 3..rows.end / 3).enumerate() {
            self.point(p, &mut cheb, &mut buf);
            for (c, row) in buf.chunks_exact(self.n).enumerate() {
                let i = 3 * b + c;
                r[i] = row.iter().zip(theta).map(|(a, b)| a * b).sum::<f64>() - self.y[3 * p + c];
                if let Some(j) = jac.as_mut() {
                    match j.rb_mut().row_mut(i).try_as_row_major_mut() {
                        Some(dst) => dst.as_slice_mut().copy_from_slice(row),
                        None => {
                            for (col, v) in row.iter().enumerate() {
                                j[(i, col)] = *v;
                            }
                        }
                    }
                }
            }
        }
    }
}

impl Model for Smooth {
    fn parameters(&self) -> Vec<Parameter> {
        (0..self.n)
            .map(|j| Parameter::new(format!("p{j}")))
            .collect()
    }
    fn layout(&self) -> BlockLayout {
        BlockLayout::uniform("points", self.u.len(), 3)
    }
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        let mut scratch = Vec::new();
        let r = match r {
            Some(r) => r,
            None => {
                scratch.resize(rows.len(), 0.0);
                &mut scratch[..]
            }
        };
        self.eval(theta, rows, r, j);
    }
}

fn tracker(c: &mut Criterion) {
    let model = Tracker::new(180, 11);
    let theta0 = vec![0.0; model.params.len()];
    let probe: Vec<f64> = model
        .params
        .iter()
        .map(|p| p.scale.unwrap_or(1.0) * 2.0)
        .collect();
    assert!(check_jacobian(&model, &probe).unwrap().passes(1e-6));
    let mut opts = Options::default();
    opts.strategy = Strategy::Dense;
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let rep = fit(&model, &theta0, &opts).unwrap();
    eprintln!(
        "tracker: one fit {:.1} ms wall, {:.0} ms CPU",
        t.elapsed().as_secs_f64() * 1e3,
        (cpu_seconds() - cpu) * 1e3
    );
    eprintln!(
        "tracker: rank {} of {}, condition {:.3e}, {} iterations, reason {:?}, rms {:.3e} → {:.3e} mm",
        rep.identifiability.rank,
        rep.estimates.len(),
        rep.condition_number,
        rep.convergence.iterations,
        rep.convergence.reason,
        rep.rms().0,
        rep.rms().1
    );
    c.bench_function("fit/tracker_162x540", |b| {
        b.iter(|| fit(&model, &theta0, &opts).unwrap())
    });
}

/// CPU time of this process so far (user + system, s), from
/// `/proc/self/stat` (0 where unavailable). On a shared machine the wall time
/// depends on the load; the CPU time over the thread count does not.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name; utime and stime are the
    // 14th and 15th fields overall, in clock ticks (100 per second on Linux).
    let rest = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

fn big(c: &mut Criterion) {
    // Built on first use, so that filtering this benchmark out costs nothing.
    let model: OnceLock<Smooth> = OnceLock::new();
    let theta0 = vec![0.0; 1000];
    let mut opts = Options::default();
    opts.strategy = Strategy::NormalEquations;
    let mut g = c.benchmark_group("fit");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(30));
    g.bench_function("dense_1000x300000", |b| {
        let model = model.get_or_init(|| Smooth::new(100_000, 1000, 12));
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let t = Instant::now();
                let cpu = cpu_seconds();
                let rep = fit(model, &theta0, &opts).unwrap();
                let dt = t.elapsed();
                total += dt;
                let cpu = cpu_seconds() - cpu;
                eprintln!(
                    "dense 1000x300000: {:.2} s wall, {:.2} s CPU (both threads), rank {}, condition {:.3e}, {} iterations, {} passes, {} factorizations, reason {:?}, sigma {:.4e}",
                    dt.as_secs_f64(),
                    cpu,
                    rep.identifiability.rank,
                    rep.condition_number,
                    rep.convergence.iterations,
                    rep.convergence.evaluations,
                    rep.convergence.factorizations,
                    rep.convergence.reason,
                    rep.sigma.unwrap_or(f64::NAN)
                );
            }
            total
        })
    });
    g.finish();
}

fn machine(name: &str) -> Machine {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines")
        .join(name);
    read_machine(&p).expect("example machine")
}

/// 100 000 simulated tracker points of the AC trunnion with its example
/// errors, and the nominal machine.
fn trunnion_points() -> (Machine, Vec<TrackerPoint>) {
    let truth = machine("ac-trunnion-with-errors.toml");
    let nominal = truth.nominal();
    let mut rng = StdRng::seed_from_u64(5);
    let poses = random_poses(&nominal, 100_000, &mut rng);
    let points = simulate(&truth, &poses, 0.001, &mut rng);
    (nominal, points)
}

fn scale(c: &mut Criterion) {
    let data: OnceLock<(Machine, Vec<TrackerPoint>, ParameterSet)> = OnceLock::new();
    let mut g = c.benchmark_group("fit");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(30));
    g.bench_function("trunnion_cheb32_1020x300000", |b| {
        let (m, points, params) = data.get_or_init(|| {
            let (m, points) = trunnion_points();
            let params = ParameterSet::from_spec(&m, "pdge:cheb32,location").unwrap();
            (m, points, params)
        });
        let opts = IdentifyOptions::default();
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let (t, cpu) = (Instant::now(), cpu_seconds());
                let id = identify(m, params, points, &opts, &|_| {}).unwrap();
                let dt = t.elapsed();
                total += dt;
                eprintln!(
                    "trunnion cheb32: {:.2} s wall, {:.2} s CPU (both threads), {} mm",
                    dt.as_secs_f64(),
                    cpu_seconds() - cpu,
                    id.report.summary()
                );
            }
            total
        })
    });
    g.finish();
}

fn tracker_end_to_end(c: &mut Criterion) {
    let truth = machine("afp-gantry-with-errors.toml");
    let nominal = machine("afp-gantry.toml");
    let params = ParameterSet::from_spec(&nominal, "pdge:cheb3,location").unwrap();
    let opts = IdentifyOptions::default();
    let run = |seed: u64| {
        let mut rng = StdRng::seed_from_u64(seed);
        let poses = random_poses(&nominal, 180, &mut rng);
        let points = simulate(&truth, &poses, 0.010, &mut rng);
        identify(&nominal, &params, &points, &opts, &|_| {}).unwrap()
    };
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let id = run(1);
    eprintln!(
        "tracker end to end: {:.1} ms wall, {:.0} ms CPU; {} parameters, rank {}, rms {:.1} → {:.1} µm",
        t.elapsed().as_secs_f64() * 1e3,
        (cpu_seconds() - cpu) * 1e3,
        id.report.estimates.len(),
        id.report.identifiability.rank,
        id.report.rms().0 * 1e3,
        id.report.rms().1 * 1e3
    );
    let mut seed = 0;
    c.bench_function("tracker/afp_simulate_identify_180", |b| {
        b.iter(|| {
            seed += 1;
            run(seed)
        })
    });
}

criterion_group!(benches, tracker, tracker_end_to_end, scale, big);
criterion_main!(benches);
