//! End-to-end identification on the AFP gantry with a known synthetic truth.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng, rngs::StdRng};

use super::*;
use crate::fit::Unidentifiable;
use crate::methods::tracker::simulate::{body_diagonal_poses, random_poses, simulate};
use crate::methods::tracker::validate::{ErrorStats, validate};
use crate::model::{ErrorFunction, read_machine};

/// Smooth PDGEs that are not cubic (Chebyshev degree 5, coefficients halving
/// with the order) and location errors: 30 µm / 30 µrad leading terms.
fn truth(m: &Machine, rng: &mut StdRng) -> Machine {
    let mut t = m.clone();
    for a in &mut t.axes {
        for c in 0..6 {
            let amp = if c < 3 { 0.03 } else { 3e-5 };
            let coeffs = (0..6)
                .map(|k| amp * 0.5f64.powi(k) * rng.gen_range(-1.0..1.0))
                .collect();
            a.errors.pdge[c] = Some(ErrorFunction::Cheb(coeffs));
            a.errors.location[c] = if c < 3 { 0.05 } else { 5e-5 } * rng.gen_range(-1.0..1.0);
        }
    }
    t
}

/// Tips of `m` with the error part θ of `params` written in.
fn tips(m: &Machine, params: &ParameterSet, theta: &[f64], poses: &[Vec<f64>]) -> Vec<f64> {
    let mut mm = m.clone();
    params.set(&mut mm, theta);
    let k = Kinematics::new(&mm);
    poses
        .iter()
        .flat_map(|q| k.pose(q).tip.iter().copied().collect::<Vec<_>>())
        .collect()
}

/// Jacobian of the tips at θ = 0 by central differences (independent of the
/// model's analytic Jacobian).
fn fd_jacobian(m: &Machine, params: &ParameterSet, poses: &[Vec<f64>]) -> DMatrix<f64> {
    let n = params.len();
    let rot = params.is_rotation();
    let mut j = DMatrix::zeros(3 * poses.len(), n);
    for c in 0..n {
        let h = if rot[c] { 1e-6 } else { 1e-3 };
        let mut t = vec![0.0; n];
        t[c] = h;
        let p = tips(m, params, &t, poses);
        t[c] = -h;
        let q = tips(m, params, &t, poses);
        for r in 0..p.len() {
            j[(r, c)] = (p[r] - q[r]) / (2.0 * h);
        }
    }
    j
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / (v.len() / 3) as f64).sqrt()
}

#[test]
fn held_out_prediction_matches_an_independent_least_squares_fit() {
    let m = crate::examples::machine("afp-gantry").unwrap();
    let mut rng = StdRng::seed_from_u64(2026);
    let truth = truth(&m, &mut rng);
    let params = ParameterSet::from_spec(&m, "pdge:cheb3,location").unwrap();
    let fit_poses = random_poses(&m, 180, &mut rng);
    let mut check_poses = random_poses(&m, 100, &mut rng);
    let diagonal = body_diagonal_poses(&m, 25);
    check_poses.extend(diagonal.iter().cloned());
    let fit_pts = simulate(&truth, &fit_poses, 0.010, &mut rng);
    let check_pts = simulate(&truth, &check_poses, 0.010, &mut rng);

    let id = identify(&m, &params, &fit_pts, &IdentifyOptions::default(), &|_| {}).unwrap();
    let ours = validate(&id.machine, &check_pts);

    // Independent reference: minimum-norm least squares on the problem
    // linearised at the nominal machine, Jacobian by finite differences,
    // columns scaled to unit norm, nalgebra SVD.
    let zero = vec![0.0; params.len()];
    let nominal_fit = tips(&m, &params, &zero, &fit_poses);
    let meas: Vec<f64> = fit_pts
        .iter()
        .flat_map(|p| p.measured.iter().copied().collect::<Vec<_>>())
        .collect();
    let j = fd_jacobian(&m, &params, &fit_poses);
    let d: Vec<f64> = (0..j.ncols())
        .map(|c| j.column(c).norm().max(1e-300))
        .collect();
    let mut js = j.clone();
    for c in 0..js.ncols() {
        js.column_mut(c).scale_mut(1.0 / d[c]);
    }
    let r = DVector::from_iterator(
        meas.len(),
        meas.iter().zip(&nominal_fit).map(|(a, b)| a - b),
    );
    let svd = js.svd(true, true);
    let smax = svd.singular_values.max();
    let ys = svd.solve(&r, 1e-9 * smax).unwrap();
    let theta_ref: Vec<f64> = (0..ys.len()).map(|c| ys[c] / d[c]).collect();
    let jh = fd_jacobian(&m, &params, &check_poses);
    let nominal_check = tips(&m, &params, &zero, &check_poses);
    let pred = &jh * DVector::from_vec(theta_ref);
    let meas_check: Vec<f64> = check_pts
        .iter()
        .flat_map(|p| p.measured.iter().copied().collect::<Vec<_>>())
        .collect();
    let ref_res: Vec<f64> = (0..meas_check.len())
        .map(|i| meas_check[i] - nominal_check[i] - pred[i])
        .collect();
    let ref_rms = rms(&ref_res);
    let (before, after) = (ours.before.rms(), ours.after.rms());
    eprintln!(
        "held-out RMS |Δp|: nominal {:.1} µm, identified {:.1} µm, reference lstsq {:.1} µm; rank {} of {}",
        before * 1e3,
        after * 1e3,
        ref_rms * 1e3,
        id.report.identifiability.rank,
        params.len()
    );
    assert!(after <= 1.2 * ref_rms, "{after} vs reference {ref_rms}");
    assert!(after <= 0.2 * before, "{after} vs nominal {before}");

    // The table of the source paper [R2]: body diagonals.
    let diag = validate(&id.machine, &check_pts[100..]);
    let ch = ErrorStats::change(&diag.before, &diag.after);
    eprintln!(
        "body diagonals |Δp|: max {:+.0} %, mean {:+.0} %, std {:+.0} % (source paper [R2]: −70 %, −81 %, −81 %)",
        ch.distance.max, ch.distance.mean, ch.distance.std
    );
    assert!(
        ch.distance.mean < -70.0 && ch.distance.max < -50.0,
        "{ch:?}"
    );
}

/// The 162-parameter model of the source paper \[R2\]: cubic Chebyshev PDGEs, three squareness
/// errors, five location errors per rotary axis.
const SEED_SPEC: &str = "pdge:cheb3,EC0Y,EB0Z,EA0Z,EX0B,EZ0B,EA0B,EB0B,EC0B,EY0A,EZ0A,EA0A,EB0A,EC0A,EX0C,EY0C,EA0C,EB0C,EC0C";

#[test]
fn verdict_names_the_confounded_parameters_of_the_source_paper_model() {
    let m = crate::examples::machine("afp-gantry").unwrap();
    let params = ParameterSet::from_spec(&m, SEED_SPEC).unwrap();
    assert_eq!(params.len(), 162);
    let mut rng = StdRng::seed_from_u64(5);
    let poses = random_poses(&m, 120, &mut rng);
    let pts = simulate(&m, &poses, 0.001, &mut rng);
    let id = identify(&m, &params, &pts, &IdentifyOptions::default(), &|_| {}).unwrap();
    let ident = &id.report.identifiability;
    let labels = params.labels();
    let idx = |l: &str| labels.iter().position(|x| x == l).unwrap();
    let why = |l: &str| id.report.estimates[idx(l)].unidentifiable;

    // By hand: the tip lies on the C axis, so a rotation of the C frame
    // about its own axis moves nothing: ECC (all coefficients) and EC0C.
    for l in ["ECC.c0", "ECC.c1", "ECC.c2", "ECC.c3", "EC0C"] {
        assert_eq!(why(l), Some(Unidentifiable::ZeroColumn), "{l}");
    }
    // By hand: the constant terms of EXX, EXY, EXZ all shift the tip by the
    // same vector along x at every pose (X is first in the chain and Y, Z
    // carry no rotation at the zero pose of their own errors): at most one of
    // the three is estimated, and their differences are null directions.
    for axis in ["X", "Y", "Z"] {
        let group: Vec<usize> = ["X", "Y", "Z"]
            .iter()
            .map(|a| idx(&format!("E{axis}{a}.c0")))
            .collect();
        let estimated = group.iter().filter(|&&j| ident.is_estimated(j)).count();
        assert!(estimated <= 1, "{axis}: {estimated}");
        // e_a − e_b lies in the span of the reported null space.
        let nulls: Vec<&Vec<f64>> = ident.null_space.iter().map(|c| &c.scaled).collect();
        for &b in &group[1..] {
            let mut v = vec![0.0; params.len()];
            v[group[0]] = std::f64::consts::FRAC_1_SQRT_2;
            v[b] = -std::f64::consts::FRAC_1_SQRT_2;
            let mut rest = v.clone();
            for n in &nulls {
                let dot: f64 = n.iter().zip(&v).map(|(a, b)| a * b).sum();
                for k in 0..rest.len() {
                    rest[k] -= dot * n[k];
                }
            }
            let left = rest.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!(left < 1e-6, "E{axis}: residual {left}");
        }
    }
    assert!(ident.rank < 162 - 5 - 6);
    // Parameters the data do not see stay exactly at the prior 0 in the
    // identified machine; every unidentifiable one is listed by the gauge.
    let back = params.get(&id.machine);
    let gauge = id.report.gauge.as_ref().unwrap();
    for (j, e) in id.report.estimates.iter().enumerate() {
        if e.unidentifiable == Some(Unidentifiable::ZeroColumn) {
            assert_eq!(back[j], 0.0, "{}", e.name);
        }
        if e.unidentifiable.is_some() {
            assert!(gauge.parameters.iter().any(|g| g.index == j), "{}", e.name);
        }
    }
}

#[test]
fn registration_recovers_a_known_tracker_frame() {
    let m = crate::examples::machine("afp-gantry").unwrap();
    let mut rng = StdRng::seed_from_u64(11);
    let poses = random_poses(&m, 40, &mut rng);
    // Tracker frame: W = Rx(a)·Ry(b)·Rz(c)·T + t, so T = Rᵀ(W − t).
    let g = [1200.0, -300.0, 50.0, 0.02, -0.4, 2.5];
    let r = crate::kinematics::transform::rxyz(g[3], g[4], g[5]);
    let t = nalgebra::Vector3::new(g[0], g[1], g[2]);
    let mut pts = simulate(&m, &poses, 0.0, &mut rng);
    for p in &mut pts {
        p.measured = r.transpose() * (p.measured - t);
    }
    let params = ParameterSet::from_spec(&m, "EXX:cheb2,EYY:cheb2").unwrap();
    let opts = IdentifyOptions {
        registration: true,
        ..Default::default()
    };
    let id = identify(&m, &params, &pts, &opts, &|_| {}).unwrap();
    let got = id.registration.unwrap();
    // EXX.c0, EYY.c0 are confounded with tx, ty; the fitted transform still
    // maps the points exactly, and the rotation is recovered.
    for k in 3..6 {
        assert!((got[k] - g[k]).abs() < 1e-9, "{k}: {} vs {}", got[k], g[k]);
    }
    assert!(id.report.rms().1 < 1e-8);
}

#[test]
fn bad_points_are_rejected() {
    let m = crate::examples::machine("afp-gantry").unwrap();
    let params = ParameterSet::from_spec(&m, "location").unwrap();
    let opts = IdentifyOptions::default();
    let p = |q: Vec<f64>| super::super::model::TrackerPoint {
        q,
        measured: nalgebra::Vector3::zeros(),
    };
    assert_eq!(
        identify(&m, &params, &[], &opts, &|_| {}).unwrap_err(),
        TrackerIdentifyError::NoPoints
    );
    let e = identify(
        &m,
        &params,
        &[p(vec![9000.0, 0.0, 0.0, 0.0, 0.0, 0.0])],
        &opts,
        &|_| {},
    );
    assert!(
        matches!(e, Err(TrackerIdentifyError::OutOfTravel { point: 0, .. })),
        "{e:?}"
    );
    let e = identify(
        &m,
        &params,
        &[p(vec![f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0])],
        &opts,
        &|_| {},
    );
    assert!(
        matches!(e, Err(TrackerIdentifyError::NonFinite { point: 0 })),
        "{e:?}"
    );
    let mut rng = StdRng::seed_from_u64(1);
    let pts = simulate(&m, &random_poses(&m, 3, &mut rng), 0.01, &mut rng);
    let e = identify(&m, &params, &pts, &opts, &|_| {});
    assert!(
        matches!(e, Err(TrackerIdentifyError::TooFewPoints { points: 3, .. })),
        "{e:?}"
    );
}

#[test]
fn a_blocked_beam_is_reported_and_left_out() {
    let m = crate::examples::machine("afp-gantry").unwrap();
    let mut rng = StdRng::seed_from_u64(21);
    let truth = truth(&m, &mut rng);
    let params = ParameterSet::from_spec(&m, "pdge:cheb2,location").unwrap();
    let poses = random_poses(&m, 120, &mut rng);
    let clean = simulate(&truth, &poses, 0.005, &mut rng);
    let mut dirty = clean.clone();
    dirty[17].measured.y += 0.5;
    let opts = IdentifyOptions::default();
    let a = identify(&m, &params, &clean, &opts, &|_| {}).unwrap();
    let b = identify(&m, &params, &dirty, &opts, &|_| {}).unwrap();
    let flagged: Vec<usize> = b.report.outliers.flagged.iter().map(|o| o.block).collect();
    assert_eq!(flagged, vec![17]);
    assert!(b.report.outliers.flagged[0].excluded);
    // Without point 17 the fit is the clean one minus one point: its
    // predictions agree with the clean fit to well within the noise.
    let check = random_poses(&m, 50, &mut rng);
    let pa = tips(&a.machine, &ParameterSet::from_list(vec![]), &[], &check);
    let pb = tips(&b.machine, &ParameterSet::from_list(vec![]), &[], &check);
    let diff: Vec<f64> = pa.iter().zip(&pb).map(|(x, y)| x - y).collect();
    assert!(rms(&diff) < 0.005, "{}", rms(&diff));
}

/// The factored normal equations (JᵀJ from the component derivatives and
/// the per-axis basis outer products, never forming Jacobian rows) must give
/// what forming the rows gives, to rounding, and the same solution as the
/// dense SVD path. Five-axis trunnion, Chebyshev degree 6 with a second basis
/// group on Z, location errors; with a registration in a rotated tracker frame
/// (the constant group's registration columns) against the row path, and
/// without (condition ≈ 1e4, where normal equations lose ≈ 1e-8) against the
/// dense path. The registration case has a blocked beam, which both paths
/// must flag and leave out of the refit (masked rows in the factored sums).
#[test]
fn factored_normal_equations_agree_with_jacobian_rows_and_the_dense_path() {
    use crate::fit::{FitReport, Options, Strategy};
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines");
    let truth = read_machine(&dir.join("ac-trunnion-with-errors.toml")).unwrap();
    let m = read_machine(&dir.join("ac-trunnion.toml")).unwrap();
    let mut rng = StdRng::seed_from_u64(314);
    let params = ParameterSet::from_spec(&m, "pdge:cheb6,location,EXZ:cheb2").unwrap();
    let poses = random_poses(&m, 1000, &mut rng);
    let in_w = simulate(&truth, &poses, 0.002, &mut rng);
    let g = [30.0, -20.0, 5.0, 0.01, -0.02, 0.3];
    let r = crate::kinematics::transform::rxyz(g[3], g[4], g[5]);
    let t = nalgebra::Vector3::new(g[0], g[1], g[2]);
    let mut in_t = in_w.clone();
    for p in &mut in_t {
        p.measured = r.transpose() * (p.measured - t);
    }
    // A blocked beam at point 417, flagged and left out of a second fit:
    // the factored path must mask its rows like the row path.
    in_t[417].measured.x += 0.2;
    let run = |pts: &[TrackerPoint], registration: bool, strategy: Strategy, factored: bool| {
        let opts = IdentifyOptions {
            registration,
            // The pivoted solution: this test compares the linear algebra of
            // the paths, not the gauge fixing.
            fit: Options {
                strategy,
                factored,
                gauge: crate::fit::Gauge::Pivoted,
                ..IdentifyOptions::default().fit
            },
            ..IdentifyOptions::default()
        };
        identify(&m, &params, pts, &opts, &|_| {}).unwrap().report
    };
    let same = |a: &FitReport, b: &FitReport, tol: f64| {
        assert_eq!(a.identifiability.rank, b.identifiability.rank);
        assert_eq!(
            a.identifiability.unidentifiable,
            b.identifiability.unidentifiable
        );
        assert!(a.identifiability.rank < a.estimates.len());
        for (j, e) in a.estimates.iter().enumerate() {
            match e.uncertainty {
                Some(u) => {
                    let d = (a.theta[j] - b.theta[j]).abs();
                    assert!(d < tol * u, "θ{j}: {d} > {tol}·{u}");
                }
                // Not estimated: both keep the start value.
                None => assert_eq!(a.theta[j], b.theta[j]),
            }
        }
        let rel =
            (a.convergence.final_cost - b.convergence.final_cost).abs() / b.convergence.final_cost;
        assert!(rel < 1e-9, "{rel}");
    };
    // With the registration: factored against Jacobian rows.
    let rows = run(&in_t, true, Strategy::NormalEquations, false);
    let fact = run(&in_t, true, Strategy::NormalEquations, true);
    for rep in [&rows, &fact] {
        let flagged: Vec<(usize, bool)> = rep
            .outliers
            .flagged
            .iter()
            .map(|o| (o.block, o.excluded))
            .collect();
        assert_eq!(flagged, vec![(417, true)]);
    }
    // EXZ is overridden to degree 2: a second basis group on axis Z.
    assert_eq!(fact.estimates.len(), 5 * 6 * 7 - 7 + 3 + 30 + 6);
    // The same spectrum of the scaled JᵀJ at the start, compared as
    // eigenvalues λ = s², which both hold to ≈ n·ε·λ_max.
    let (sf, sr) = (
        &fact.identifiability.singular_values,
        &rows.identifiability.singular_values,
    );
    assert_eq!(sf.len(), sr.len());
    for (a, b) in sf.iter().zip(sr) {
        assert!((a * a - b * b).abs() <= 1e-11 * sr[0] * sr[0], "{a} vs {b}");
    }
    // Both stop at the cost tolerance (1e-12 relative): a cost within
    // δ = 1e-12·cost ≈ 1e-12·dof·σ²/2 of the minimum leaves θ within
    // √(2δ)/σ ≈ √(dof·1e-12) ≈ 6e-5 standard uncertainties of it.
    same(&fact, &rows, 1e-4);
    // Without: factored against the dense SVD path.
    let dense = run(&in_w, false, Strategy::Dense, false);
    let fact = run(&in_w, false, Strategy::NormalEquations, true);
    // Condition ≈ 1e4: normal equations lose ≈ κ²·ε ≈ 1e-8 relative.
    assert!(fact.condition_number < 1e5, "{}", fact.condition_number);
    same(&fact, &dense, 1e-4);
}

/// Largest |error| of the translation PDGEs (EX, EY, EZ) of axis `axis`
/// over its travel (mm).
fn max_translation_curve(m: &Machine, axis: &str) -> f64 {
    let a = m.axes.iter().find(|a| a.name == axis).unwrap();
    let mut worst = 0.0f64;
    for c in 0..3 {
        if let Some(f) = &a.errors.pdge[c] {
            for k in 0..=100 {
                let q = a.travel[0] + (a.travel[1] - a.travel[0]) * k as f64 / 100.0;
                worst = worst.max(f.eval(q, a.travel).abs());
            }
        }
    }
    worst
}

/// The demo's gantry step (`scenarios::gantry_tracker` with its defaults:
/// 180 D-optimal poses of 1000, 10 µm noise, `pdge:cheb3,location`, known
/// truth `afp-gantry-with-errors`), identified with and without gauge
/// fixing.
#[test]
fn demo_gantry_gauge_fixed_solution_against_the_truth() {
    use crate::methods::tracker::simulate::simulate_seeded;
    let model = crate::examples::machine("afp-gantry").unwrap();
    let truth = crate::examples::machine("afp-gantry-with-errors").unwrap();
    let opts = crate::scenarios::gantry_tracker::Options::default();
    let params = ParameterSet::from_spec(&model, &opts.spec).unwrap();
    let plan = crate::methods::tracker::plan::plan(
        &model,
        &params,
        opts.candidates,
        opts.poses,
        opts.noise,
        opts.seeds[0],
    )
    .unwrap();
    let points = simulate_seeded(&truth, &plan.poses, opts.noise, opts.seeds[0]);
    // The gauge alone (no truncation of badly determined directions).
    let mut gopts = IdentifyOptions::default();
    gopts.fit.truncation = crate::fit::Truncation::Off;
    let gauged = identify(&model, &params, &points, &gopts, &|_| {}).unwrap();
    let mut popts = IdentifyOptions::default();
    popts.fit.gauge = crate::fit::Gauge::Pivoted;
    let pivoted = identify(&model, &params, &points, &popts, &|_| {}).unwrap();
    let n = params.len();
    let rank = gauged.report.identifiability.rank;

    // 1. The predictions at the measured poses do not change.
    let q: Vec<Vec<f64>> = points.iter().map(|p| p.q.clone()).collect();
    let zero = vec![0.0; n];
    let tg = tips(&model, &params, &gauged.report.theta, &q);
    let tp = tips(&model, &params, &pivoted.report.theta, &q);
    let dmax = tg
        .iter()
        .zip(&tp)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let moved = gauged
        .report
        .theta
        .iter()
        .zip(&pivoted.report.theta)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!("gauge moved parameters by up to {moved:.3e}, tips by {dmax:.3e} mm");
    assert!(
        moved > 1e-2,
        "the pivoted solution is not min-norm: {moved}"
    );
    // Within the Levenberg–Marquardt convergence of the restarted fit:
    // below 1 % of the 10 µm noise.
    assert!(dmax < 1e-4, "{dmax} mm");

    // 2. Independent truth: the minimum-norm representative of the true
    // errors, θ_t − D⁻¹·N·Nᵀ·D·θ_t, with N the null space of the
    // column-scaled finite-difference Jacobian at the nominal machine
    // (nalgebra SVD).
    let theta_t = params.get(&truth);
    let j = fd_jacobian(&model, &params, &q);
    let d: Vec<f64> = (0..n).map(|c| j.column(c).norm()).collect();
    let dmax_col = d.iter().copied().fold(0.0, f64::max);
    let live: Vec<usize> = (0..n).filter(|&c| d[c] > 1e-9 * dmax_col).collect();
    let mut js = DMatrix::zeros(j.nrows(), live.len());
    for (k, &c) in live.iter().enumerate() {
        js.set_column(k, &(j.column(c) / d[c]));
    }
    let (rows, cols) = js.shape();
    let svd = js.svd(false, true);
    let vt = svd.v_t.unwrap();
    let smax = svd.singular_values.max();
    let null: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&i| svd.singular_values[i] <= 1e-7 * smax)
        .collect();
    // (with fewer rows than columns, missing singular values are zero too)
    assert!(rows >= cols);
    assert_eq!(live.len() - null.len(), rank, "rank of the FD Jacobian");
    let y_t: Vec<f64> = live.iter().map(|&c| d[c] * theta_t[c]).collect();
    let mut y_g = y_t.clone();
    for &i in &null {
        let v = vt.row(i);
        let a: f64 = (0..live.len()).map(|k| v[k] * y_t[k]).sum();
        for k in 0..live.len() {
            y_g[k] -= a * v[k];
        }
    }
    let mut theta_g = zero.clone();
    for (k, &c) in live.iter().enumerate() {
        theta_g[c] = y_g[k] / d[c];
    }
    let mut worst = (0.0f64, String::new());
    for (c, e) in gauged.report.estimates.iter().enumerate() {
        if !live.contains(&c) {
            // Unseen by the data: at the prior.
            assert_eq!(e.value, 0.0, "{}", e.name);
            continue;
        }
        let s = e.uncertainty.expect("gauge-fixed uncertainty");
        let z = (e.value - theta_g[c]).abs() / s;
        if z > worst.0 {
            worst = (z, e.name.clone());
        }
        assert!(
            z < 5.0,
            "{}: {} vs min-norm truth {} (σ {s}, truth {})",
            e.name,
            e.value,
            theta_g[c],
            theta_t[c]
        );
    }
    eprintln!(
        "largest |estimate − min-norm truth| / σ: {:.2} ({})",
        worst.0, worst.1
    );

    // 3. The numbers the issue quotes: EXX.c0 and the B-axis translation
    // curves, before (pivoted) and after (gauge-fixed), against the truth.
    let ix = params_index(&gauged, "EXX.c0");
    let (eg, ep) = (&gauged.report.estimates[ix], &pivoted.report.estimates[ix]);
    eprintln!(
        "EXX.c0: pivoted {:.1} ± {:.1} µm, gauge-fixed {:.1} ± {:.1} µm, min-norm truth {:.1} µm, truth {:.1} µm",
        ep.value * 1e3,
        ep.uncertainty.unwrap_or(f64::NAN) * 1e3,
        eg.value * 1e3,
        eg.uncertainty.unwrap() * 1e3,
        theta_g[ix] * 1e3,
        theta_t[ix] * 1e3
    );
    let (bg, bp, bt) = (
        max_translation_curve(&gauged.machine, "B"),
        max_translation_curve(&pivoted.machine, "B"),
        max_translation_curve(&truth, "B"),
    );
    eprintln!(
        "max |B translation curve|: pivoted {:.1} µm, gauge-fixed {:.1} µm, truth {:.1} µm",
        bp * 1e3,
        bg * 1e3,
        bt * 1e3
    );
    // The gauge takes out the null-space part only; what remains of the
    // B curves lies in weakly determined (ill-conditioned, not null)
    // directions, within k·σ of the minimum-norm truth as checked above.
    assert!(bp > 0.3, "{bp}");
    assert!(bg < bp, "{bg} vs {bp}");

    // The body diagonals of the demo (not measured: the gauge may change
    // predictions there).
    let diagonals = body_diagonal_poses(&model, opts.per_diagonal);
    let check = simulate_seeded(&truth, &diagonals, opts.noise, opts.seeds[1]);
    for (what, id) in [("pivoted", &pivoted), ("gauge-fixed", &gauged)] {
        let v = validate(&id.machine, &check);
        eprintln!(
            "{what}: body diagonals |Δp| max {:.1} → {:.1} µm ({:.0} %), mean {:.1} → {:.1} µm ({:.0} %)",
            v.before.distance.max * 1e3,
            v.after.distance.max * 1e3,
            v.change.distance.max,
            v.before.distance.mean * 1e3,
            v.after.distance.mean * 1e3,
            v.change.distance.mean
        );
    }

    // 4. The report: groups and determined combinations, whose values the
    // gauge does not change (checked on the pivoted solution).
    let g = gauged.report.gauge.as_ref().unwrap();
    assert_eq!(g.null_dimension, n - rank);
    for grp in g
        .groups
        .iter()
        .filter(|x| x.parameters.iter().any(|p| p == "EXX.c0"))
    {
        eprintln!(
            "group of EXX.c0: {} parameters, {} undetermined",
            grp.parameters.len(),
            grp.undetermined
        );
        for c in grp.determined.iter().take(3) {
            eprintln!("  {}", crate::methods::tracker::doc::sentence(c));
        }
    }
}

fn params_index(id: &Identification, name: &str) -> usize {
    id.report
        .estimates
        .iter()
        .position(|e| e.name == name)
        .unwrap()
}

/// Largest |identified − truth| of the translation PDGEs (EX, EY, EZ) of
/// every axis over its travel (mm), and the axis where.
fn max_translation_curve_error(m: &Machine, truth: &Machine) -> (f64, String) {
    let mut worst = (0.0f64, String::new());
    for (a, t) in m.axes.iter().zip(&truth.axes) {
        for c in 0..3 {
            for k in 0..=100 {
                let q = a.travel[0] + (a.travel[1] - a.travel[0]) * k as f64 / 100.0;
                let e = a.errors.pdge[c]
                    .as_ref()
                    .map_or(0.0, |f| f.eval(q, a.travel));
                let et = t.errors.pdge[c]
                    .as_ref()
                    .map_or(0.0, |f| f.eval(q, t.travel));
                if (e - et).abs() > worst.0 {
                    worst = (
                        (e - et).abs(),
                        format!("{}{}", ["EX", "EY", "EZ"][c], a.name),
                    );
                }
            }
        }
    }
    worst
}

/// The demo's gantry step with the default rank rule (`std=10`): the
/// badly determined directions go to 0, and the values the issue quotes
/// come close to the truth while the predictions do not change.
#[test]
fn demo_gantry_truncated_solution_against_the_truth() {
    use crate::methods::tracker::simulate::simulate_seeded;
    let model = crate::examples::machine("afp-gantry").unwrap();
    let truth = crate::examples::machine("afp-gantry-with-errors").unwrap();
    let opts = crate::scenarios::gantry_tracker::Options::default();
    let params = ParameterSet::from_spec(&model, &opts.spec).unwrap();
    let plan = crate::methods::tracker::plan::plan(
        &model,
        &params,
        opts.candidates,
        opts.poses,
        opts.noise,
        opts.seeds[0],
    )
    .unwrap();
    let points = simulate_seeded(&truth, &plan.poses, opts.noise, opts.seeds[0]);
    let diagonals = body_diagonal_poses(&model, opts.per_diagonal);
    let check = simulate_seeded(&truth, &diagonals, opts.noise, opts.seeds[1]);
    let theta_t = params.get(&truth);
    let run = |rule: &str| {
        let mut o = IdentifyOptions::default();
        o.fit.truncation = rule.parse().unwrap();
        identify(&model, &params, &points, &o, &|_| {}).unwrap()
    };
    let default = identify(
        &model,
        &params,
        &points,
        &IdentifyOptions::default(),
        &|_| {},
    )
    .unwrap();
    let off = run("off");
    let ix = params_index(&default, "EXX.c0");
    let mut rows = Vec::new();
    for (rule, id) in [
        ("off", &off),
        ("std=10 (default)", &default),
        ("std=100", &run("std=100")),
        ("std=3", &run("std=3")),
        ("rcond=1e-2", &run("rcond=1e-2")),
        ("rcond=1e-1", &run("rcond=1e-1")),
    ] {
        let e = &id.report.estimates[ix];
        let v = validate(&id.machine, &check);
        let (w, at) = max_translation_curve_error(&id.machine, &truth);
        let g = id.report.gauge.as_ref().unwrap();
        let (_, ra) = id.report.rms();
        eprintln!(
            "{rule:>16}: dropped {:2}, residual RMS {:.2} µm, EXX.c0 {:6.1} ± {:5.1} µm, max |B curve| {:6.1} µm, max curve error {:5.1} µm ({at}), diagonals max {:.0} %, mean {:.0} %",
            g.dropped.len(),
            ra * 1e3,
            e.value * 1e3,
            e.uncertainty.unwrap_or(f64::NAN) * 1e3,
            max_translation_curve(&id.machine, "B") * 1e3,
            w * 1e3,
            v.change.distance.max,
            v.change.distance.mean,
        );
        rows.push((g.dropped.len(), ra, e.value, v.change.distance.mean));
    }
    eprintln!(
        "truth: EXX.c0 {:.1} µm, max |B curve| {:.1} µm",
        theta_t[ix] * 1e3,
        max_translation_curve(&truth, "B") * 1e3
    );
    let g = default.report.gauge.as_ref().unwrap();
    assert_eq!(g.truncation, "std=10");
    assert!(!g.dropped.is_empty());
    // The figures: EXX.c0 (truth 0) within 10 µm, the B-axis
    // translation curves (truth 28 µm) below 100 µm — against −73 ± 78 µm
    // and 752 µm with the gauge alone.
    let exx = default.report.estimates[ix].value;
    assert!((exx - theta_t[ix]).abs() < 0.010, "EXX.c0 {exx}");
    let b = max_translation_curve(&default.machine, "B");
    assert!(b < 0.1, "B curves {b}");
    assert!(max_translation_curve(&off.machine, "B") > 0.3);
    // Predictions at the measured poses barely move (the reported cost):
    // the residual RMS rises by less than 1 % of the 10 µm noise…
    let (ra_off, ra) = (rows[0].1, rows[1].1);
    assert!(ra - ra_off < 0.1e-3, "{ra} vs {ra_off}");
    let total: f64 = g
        .dropped
        .iter()
        .map(|d| d.rms_change.powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        (g.truncation_rms_change - total).abs() < 0.1 * total + 1e-6,
        "{} vs {total}",
        g.truncation_rms_change
    );
    // …and the body diagonals (not measured) improve as much.
    assert!((rows[1].3 - rows[0].3).abs() < 2.0, "{rows:?}");
    // Every dropped direction: below the bound's singular value, its
    // shift within its bias bound, and a cost below the noise.
    let sigma = default.report.sigma.unwrap();
    for d in &g.dropped {
        assert!(d.shift.abs() <= d.bias_bound + 1e-15, "{d:?}");
        assert!(d.rms_change < sigma, "{d:?}");
    }
    // The same directions for bounds from 10 to 100 typical scales.
    assert_eq!(rows[2].0, rows[1].0, "{rows:?}");
}
