//! Tests of the kinematics engine against closed forms, finite differences and round trips.

use std::path::{Path, PathBuf};

use nalgebra::{Rotation3, Unit, Vector3};

use super::*;
use crate::model::{Component, ErrorFunction, Machine, read_machine};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines")
        .join(name)
}

fn load(name: &str) -> Machine {
    read_machine(&example(name)).unwrap_or_else(|e| panic!("{e}"))
}

/// Deterministic pseudo-random poses inside the travels.
pub(super) fn poses(m: &Machine, n: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut s = seed;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            m.axes
                .iter()
                .map(|a| a.travel[0] + (a.travel[1] - a.travel[0]) * (0.05 + 0.9 * next()))
                .collect()
        })
        .collect()
}

fn rot(axis: Vector3<f64>, deg: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Unit::new_normalize(axis), deg.to_radians())
}

/// The nominal AC trunnion by hand: tool at (x, y, z) in M, table turned by Rx(a)·Rz(c)
/// about lines through the origin, workpiece origin (0, 0, −150).
fn ac_nominal_by_hand(q: &[f64]) -> (Vector3<f64>, Vector3<f64>) {
    let (y, x, z, a, c) = (q[0], q[1], q[2], q[3], q[4]);
    let r_mw = rot(Vector3::x(), a) * rot(Vector3::z(), c);
    let t_mw = r_mw * Vector3::new(0.0, 0.0, -150.0);
    let tip_m = Vector3::new(x, y, z);
    (
        r_mw.inverse() * (tip_m - t_mw),
        r_mw.inverse() * Vector3::z(),
    )
}

#[test]
fn zero_errors_give_the_nominal_pose() {
    let m = load("ac-trunnion.toml");
    let k = Kinematics::new(&m);
    for q in poses(&m, 200, 1) {
        let p = k.pose(&q);
        let (tip, axis) = ac_nominal_by_hand(&q);
        assert!((p.tip - tip).norm() < 1e-12, "{q:?}");
        assert!((p.axis - axis).norm() < 1e-15);
    }
    // And the error-free kinematics of the machine with errors is the same nominal one.
    let me = load("ac-trunnion-with-errors.toml");
    let kn = Kinematics::nominal(&me);
    for q in poses(&m, 50, 2) {
        assert!((kn.pose(&q).tip - ac_nominal_by_hand(&q).0).norm() < 1e-12);
    }
}

#[test]
fn a_pure_positioning_error_shifts_the_tip_by_exactly_that_amount() {
    let mut m = load("ac-trunnion.toml");
    let ix = m.axis_index("X").unwrap();
    m.axes[ix].errors.pdge[Component::Tx.index()] = Some(ErrorFunction::Constant(0.0123));
    let iz = m.axis_index("Z").unwrap();
    m.axes[iz].errors.pdge[Component::Tz.index()] = Some(ErrorFunction::Poly(vec![0.0, 1e-5]));
    let k = Kinematics::new(&m);
    for q in poses(&m, 100, 3) {
        let (tip, _) = ac_nominal_by_hand(&q);
        let r_wm = (rot(Vector3::x(), q[3]) * rot(Vector3::z(), q[4])).inverse();
        let shift_m = Vector3::new(0.0123, 0.0, 1e-5 * q[2]);
        assert!((k.pose(&q).tip - (tip + r_wm * shift_m)).norm() < 1e-12);
    }
}

#[test]
fn a_rotary_location_tilt_turns_points_about_the_tilted_line() {
    // C tilted by EA0C = ε about x, everything else nominal, A = 0: the table point that
    // sits at W coordinates w is at Rx(ε)·Rz(c)·(w + o_W) in M, an exact rotation about the
    // tilted C line; so the tool at M position p sees W coordinates Rz(−c)·Rx(−ε)·p − o_W.
    let eps = 2.0e-4;
    let mut m = load("ac-trunnion.toml");
    let ic = m.axis_index("C").unwrap();
    m.axes[ic].errors.location[Component::Rx.index()] = eps;
    let k = Kinematics::new(&m);
    for q in poses(&m, 100, 4) {
        let q = [q[0], q[1], q[2], 0.0, q[4]];
        let p_m = Vector3::new(q[1], q[0], q[2]);
        let r = Rotation3::from_axis_angle(&Vector3::x_axis(), eps) * rot(Vector3::z(), q[4]);
        let expect = r.inverse() * p_m - Vector3::new(0.0, 0.0, -150.0);
        assert!((k.pose(&q).tip - expect).norm() < 1e-12);
        // The radius about the tilted line is preserved: the exact rotation moves the point
        // at radius r along a circle of radius r.
        let line = Rotation3::from_axis_angle(&Vector3::x_axis(), eps) * Vector3::z();
        let w_in_m = |c: f64| {
            Rotation3::from_axis_angle(&Vector3::x_axis(), eps)
                * rot(Vector3::z(), c)
                * Vector3::new(100.0, 0.0, -150.0)
        };
        let radius = |v: Vector3<f64>| (v - line * line.dot(&v)).norm();
        assert!((radius(w_in_m(q[4])) - radius(w_in_m(0.0))).abs() < 1e-12);
    }
}

#[test]
fn rotation_parts_are_orthonormal() {
    for name in [
        "ac-trunnion-with-errors.toml",
        "afp-gantry-with-errors.toml",
        "skiving-with-errors.toml",
    ] {
        let m = load(name);
        let k = Kinematics::new(&m);
        for q in poses(&m, 50, 5) {
            let t = k.tool_in_workpiece(&q);
            assert!((t.r.transpose() * t.r - nalgebra::Matrix3::identity()).norm() < 1e-12);
            assert!((t.r.determinant() - 1.0).abs() < 1e-12);
            // The fast point/vector path equals the full transform.
            let p = k.pose(&q);
            assert!((t.t - p.tip).norm() < 1e-9, "{name}");
            assert!((t.r * m.tool_direction - p.axis).norm() < 1e-12);
            assert!((p.axis.norm() - 1.0).abs() < 1e-12);
        }
    }
}

fn add_to_component(m: &mut Machine, axis: usize, slot: usize, h: f64) {
    let e = &mut m.axes[axis].errors;
    if slot >= 6 {
        e.location[slot - 6] += h;
        return;
    }
    e.pdge[slot] = Some(match e.pdge[slot].take() {
        None => ErrorFunction::Constant(h),
        Some(ErrorFunction::Constant(c)) => ErrorFunction::Constant(c + h),
        Some(ErrorFunction::Poly(mut c)) => {
            c[0] += h;
            ErrorFunction::Poly(c)
        }
        Some(ErrorFunction::Cheb(mut c)) => {
            c[0] += h;
            ErrorFunction::Cheb(c)
        }
        Some(ErrorFunction::Table { q, e }) => ErrorFunction::Table {
            q,
            e: e.iter().map(|v| v + h).collect(),
        },
    });
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(scale)
}

#[test]
fn component_jacobians_match_central_differences() {
    for name in [
        "ac-trunnion-with-errors.toml",
        "afp-gantry-with-errors.toml",
        "skiving-with-errors.toml",
    ] {
        let m = load(name);
        let k = Kinematics::new(&m);
        for q in poses(&m, 6, 6) {
            let jac = k.jacobian(&q);
            assert!((jac.pose.tip - k.pose(&q).tip).norm() < 1e-9);
            for i in 0..m.n_axes() {
                for slot in 0..SLOTS {
                    let h = if slot % 6 >= 3 { 1e-6 } else { 1e-4 };
                    let (mut mp, mut mm) = (m.clone(), m.clone());
                    add_to_component(&mut mp, i, slot, h);
                    add_to_component(&mut mm, i, slot, -h);
                    let (pp, pm) = (Kinematics::new(&mp).pose(&q), Kinematics::new(&mm).pose(&q));
                    let fd_tip = (pp.tip - pm.tip) / (2.0 * h);
                    let fd_ax = (pp.axis - pm.axis) / (2.0 * h);
                    let d = jac.components[i][slot];
                    // The scale of a tip derivative is the lever arm (mm/rad) or 1 (mm/mm).
                    let scale = if slot % 6 >= 3 { 1000.0 } else { 1.0 };
                    for r in 0..3 {
                        assert!(
                            close(d[r], fd_tip[r], scale),
                            "{name} axis {i} slot {slot} tip {r}: {} vs {}",
                            d[r],
                            fd_tip[r]
                        );
                        assert!(
                            close(d[3 + r], fd_ax[r], 1.0),
                            "{name} axis {i} slot {slot} axis {r}: {} vs {}",
                            d[3 + r],
                            fd_ax[r]
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn position_jacobians_match_central_differences() {
    for name in [
        "ac-trunnion-with-errors.toml",
        "afp-gantry-with-errors.toml",
        "skiving-with-errors.toml",
    ] {
        let m = load(name);
        let k = Kinematics::new(&m);
        for q in poses(&m, 10, 7) {
            let jac = k.jacobian(&q);
            for i in 0..m.n_axes() {
                let h = 1e-4;
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[i] += h;
                qm[i] -= h;
                let (pp, pm) = (k.pose(&qp), k.pose(&qm));
                let fd_tip = (pp.tip - pm.tip) / (2.0 * h);
                let fd_ax = (pp.axis - pm.axis) / (2.0 * h);
                let d = jac.positions[i];
                for r in 0..3 {
                    assert!(
                        close(d[r], fd_tip[r], 1.0),
                        "{name} axis {i} tip {r}: {} vs {}",
                        d[r],
                        fd_tip[r]
                    );
                    assert!(
                        close(d[3 + r], fd_ax[r], 1e-3),
                        "{name} axis {i} axis {r}: {} vs {}",
                        d[3 + r],
                        fd_ax[r]
                    );
                }
            }
        }
    }
}

#[test]
fn inverse_of_forward_round_trips_on_every_example() {
    for name in [
        "ac-trunnion-with-errors.toml",
        "afp-gantry-with-errors.toml",
        "skiving-with-errors.toml",
    ] {
        let m = load(name);
        let k = Kinematics::new(&m);
        let kn = Kinematics::nominal(&m);
        let linear: Vec<bool> = m
            .axes
            .iter()
            .map(|a| a.kind == crate::model::AxisKind::Linear)
            .collect();
        let all = vec![true; m.n_axes()];
        for q in poses(&m, 40, 8) {
            // Position only, linear axes free: reach the nominal tip with the actual machine.
            let nominal = kn.pose(&q);
            let target = IkTarget {
                tip: nominal.tip,
                axis: None,
            };
            let sol = k
                .inverse(&target, &q, &linear, &IkOptions::default())
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!((k.pose(&sol).tip - nominal.tip).norm() < 1e-9, "{name}");
            // Round trip: FK of q, then IK from a perturbed start, must give back q.
            let actual = k.pose(&q);
            let start: Vec<f64> = q
                .iter()
                .enumerate()
                .map(|(i, v)| if linear[i] { v + 0.5 } else { v + 0.2 })
                .collect();
            let with_axis = IkTarget {
                tip: actual.tip,
                axis: Some(actual.axis),
            };
            let n_rot = linear.iter().filter(|l| !**l).count();
            let free = if n_rot >= 2 && n_rot + 3 <= 5 {
                all.clone()
            } else {
                linear.clone()
            };
            let tgt = if free == all {
                with_axis
            } else {
                IkTarget {
                    tip: actual.tip,
                    axis: None,
                }
            };
            let start = if free == all {
                start
            } else {
                q.iter()
                    .enumerate()
                    .map(|(i, v)| if linear[i] { v + 0.5 } else { *v })
                    .collect()
            };
            let back = k
                .inverse(&tgt, &start, &free, &IkOptions::default())
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!((k.pose(&back).tip - actual.tip).norm() < 1e-9, "{name}");
            for i in 0..q.len() {
                assert!(
                    (back[i] - q[i]).abs() < 1e-8,
                    "{name} axis {i}: {} vs {}",
                    back[i],
                    q[i]
                );
            }
        }
    }
}

#[test]
fn inverse_reports_leaving_the_travel() {
    let m = load("ac-trunnion-with-errors.toml");
    let k = Kinematics::new(&m);
    let q = [0.0, 299.9999, 0.0, 0.0, 0.0];
    let target = IkTarget {
        tip: Kinematics::nominal(&m).pose(&q).tip + Vector3::new(1.0, 0.0, 0.0),
        axis: None,
    };
    let free = [true, true, true, false, false];
    let e = k
        .inverse(&target, &q, &free, &IkOptions::default())
        .unwrap_err();
    assert!(
        matches!(e, IkError::OutOfTravel { ref axis, .. } if axis == "X"),
        "{e}"
    );
    assert!(e.to_string().contains("outside its travel"));
}

#[test]
fn batch_equals_single_poses() {
    let m = load("ac-trunnion-with-errors.toml");
    let k = Kinematics::new(&m);
    let ps = poses(&m, 5000, 9);
    let flat: Vec<f64> = ps.iter().flatten().copied().collect();
    let batch = k.poses(&flat);
    assert_eq!(batch.len(), ps.len());
    for (q, b) in ps.iter().zip(&batch) {
        assert_eq!(k.pose(q), *b);
    }
}

#[test]
fn compiled_error_functions_equal_the_definitions() {
    // The fast path (power series in the normalised argument) must give the same values as
    // evaluating each error function by its definition (Clenshaw, Horner, tables).
    for name in [
        "ac-trunnion-with-errors.toml",
        "afp-gantry-with-errors.toml",
        "skiving-with-errors.toml",
    ] {
        let m = load(name);
        let k = Kinematics::new(&m);
        for (i, a) in m.axes.iter().enumerate() {
            for t in 0..=20 {
                let q = a.travel[0] + (a.travel[1] - a.travel[0]) * t as f64 / 20.0;
                let fast = k.axes[i].pdge_values(q);
                for c in Component::ALL {
                    let exact = a.pdge_at(c, q);
                    assert!(
                        (fast[c.index()] - exact).abs() <= 1e-15 + 1e-13 * exact.abs(),
                        "{name} {} {c:?} q={q}",
                        a.name
                    );
                }
            }
        }
    }
}

/// The three example machines with errors, plus the AC trunnion with table-form errors on
/// X and C (which take the general, per-function path) and large error angles on C (which
/// take the `f64::sin_cos` branch of the small-angle series).
pub(super) fn fast_path_machines() -> Vec<(String, Machine)> {
    let mut out: Vec<(String, Machine)> = [
        "ac-trunnion-with-errors.toml",
        "afp-gantry-with-errors.toml",
        "skiving-with-errors.toml",
    ]
    .iter()
    .map(|n| (n.to_string(), load(n)))
    .collect();
    let mut m = load("ac-trunnion-with-errors.toml");
    let ix = m.axis_index("X").unwrap();
    m.axes[ix].errors.pdge[Component::Ty.index()] = Some(ErrorFunction::Table {
        q: vec![-300.0, -100.0, 50.0, 300.0],
        e: vec![0.004, -0.002, 0.001, 0.006],
    });
    m.axes[ix].errors.pdge[Component::Rz.index()] = Some(ErrorFunction::Table {
        q: vec![-300.0, 0.0, 300.0],
        e: vec![2e-5, -1e-5, 3e-5],
    });
    let ic = m.axis_index("C").unwrap();
    m.axes[ic].errors.pdge[Component::Rx.index()] = Some(ErrorFunction::Poly(vec![0.02, 1e-4]));
    out.push(("ac-trunnion with tables".into(), m));
    out
}

#[test]
fn fast_forward_kinematics_equals_the_full_transform_route() {
    for (name, m) in fast_path_machines() {
        let k = Kinematics::new(&m);
        for q in poses(&m, 300, 21) {
            // Reference: compose every A_i as a full rigid transform, T_WT = T_MW⁻¹·T_MT.
            let t = k.tool_in_workpiece(&q);
            let p = k.pose(&q);
            // 1e-12 mm, relative to metres of reach (the AFP gantry's 8 m).
            let tol = 1e-12 * (1.0 + t.t.norm() / 1000.0);
            assert!(
                (t.t - p.tip).norm() < tol,
                "{name} {q:?}: {}",
                (t.t - p.tip).norm()
            );
            assert!((t.r * m.tool_direction - p.axis).norm() < 1e-14, "{name}");
            assert!((p.axis.norm() - 1.0).abs() < 1e-14, "{name}");
        }
    }
}

#[test]
fn batch_kernel_is_bit_for_bit_the_single_pose() {
    for (name, m) in fast_path_machines() {
        let k = Kinematics::new(&m);
        // LANES·k + 3 poses: full lane groups, a remainder, and more than
        // one parallel block of 1024.
        let ps = poses(&m, super::lanes::LANES * 300 + 3, 22);
        let flat: Vec<f64> = ps.iter().flatten().copied().collect();
        let zero = ToolPose {
            tip: Vector3::zeros(),
            axis: Vector3::zeros(),
        };
        let mut out = vec![zero; ps.len()];
        k.poses_into(&flat, &mut out);
        let par = k.poses(&flat);
        for ((q, a), b) in ps.iter().zip(&out).zip(&par) {
            assert_eq!(k.pose(q), *a, "{name}");
            assert_eq!(a, b, "{name}");
        }
    }
}

#[test]
fn position_derivatives_equal_the_full_jacobian() {
    for (name, m) in fast_path_machines() {
        let k = Kinematics::new(&m);
        let mut d = [[0.0; 6]; super::tangent::MAX_AXES];
        for q in poses(&m, 60, 23) {
            let pose = k.pose_and_position_derivatives(&q, &mut d);
            let jac = k.jacobian(&q);
            let reach = 1.0 + pose.tip.norm() / 1000.0;
            assert!((pose.tip - jac.pose.tip).norm() < 1e-12 * reach, "{name}");
            assert!((pose.axis - jac.pose.axis).norm() < 1e-14, "{name}");
            for i in 0..m.n_axes() {
                let size = jac.positions[i].iter().fold(1.0f64, |s, v| s.max(v.abs()));
                for r in 0..6 {
                    let (a, b) = (d[i][r], jac.positions[i][r]);
                    assert!(
                        (a - b).abs() < 1e-13 * size,
                        "{name} axis {i} row {r}: {a} vs {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn fixed_size_inverse_gives_the_reference_solutions() {
    for (name, m) in fast_path_machines() {
        let k = Kinematics::new(&m);
        let kn = Kinematics::nominal(&m);
        let linear: Vec<bool> = m
            .axes
            .iter()
            .map(|a| a.kind == crate::model::AxisKind::Linear)
            .collect();
        let all = vec![true; m.n_axes()];
        for q in poses(&m, 30, 24) {
            let opts = IkOptions::default();
            // Tip only, linear axes free (actual and nominal machine: affine, one step).
            for kin in [&k, &kn] {
                let t = IkTarget {
                    tip: kn.pose(&q).tip + Vector3::new(0.3, -0.2, 0.1),
                    axis: None,
                };
                let fast = kin.inverse(&t, &q, &linear, &opts);
                let reference = kin.inverse_dynamic(&t, &q, &linear, &opts);
                match (fast, reference) {
                    (Ok(a), Ok(b)) => {
                        for i in 0..a.len() {
                            assert!((a[i] - b[i]).abs() < 1e-9, "{name}: {a:?} vs {b:?}");
                        }
                        assert!((kin.pose(&a).tip - t.tip).norm() < 1e-9);
                    }
                    (Err(a), Err(b)) => {
                        assert_eq!(std::mem::discriminant(&a), std::mem::discriminant(&b))
                    }
                    (a, b) => panic!("{name}: {a:?} vs {b:?}"),
                }
            }
            // Tip and axis, every axis free (minimum-norm steps where there are more
            // unknowns than rows).
            let actual = k.pose(&q);
            let t = IkTarget {
                tip: actual.tip,
                axis: Some(actual.axis),
            };
            let start: Vec<f64> = q.iter().map(|v| v + 0.1).collect();
            let fast = k.inverse(&t, &start, &all, &opts);
            let reference = k.inverse_dynamic(&t, &start, &all, &opts);
            match (fast, reference) {
                (Ok(a), Ok(b)) => {
                    let p = k.pose(&a);
                    assert!((p.tip - t.tip).norm() < 1e-9, "{name}");
                    assert!((p.axis - actual.axis).norm() < 1e-12, "{name}");
                    // With six axes the tip-and-axis problem is redundant (rank 5): both
                    // reach the target, at points of the solution set that may differ.
                    if m.n_axes() <= 5 {
                        for i in 0..a.len() {
                            assert!((a[i] - b[i]).abs() < 1e-8, "{name}: {a:?} vs {b:?}");
                        }
                    }
                }
                (Err(a), Err(b)) => {
                    assert_eq!(std::mem::discriminant(&a), std::mem::discriminant(&b))
                }
                (a, b) => panic!("{name}: {a:?} vs {b:?}"),
            }
        }
    }
}

#[test]
fn fixed_size_inverse_keeps_the_error_behaviour() {
    let m = load("ac-trunnion-with-errors.toml");
    let k = Kinematics::new(&m);
    let q = [10.0, 20.0, -30.0, 15.0, 40.0];
    let free = [true, true, true, false, false];
    let target = IkTarget {
        tip: k.pose(&q).tip + Vector3::new(0.5, 0.5, 0.5),
        axis: None,
    };
    // Too few iterations: not converged, with the same residuals as the reference.
    let opts = IkOptions {
        max_iterations: 1,
        ..IkOptions::default()
    };
    let a = k.inverse(&target, &q, &free, &opts).unwrap_err();
    let b = k.inverse_dynamic(&target, &q, &free, &opts).unwrap_err();
    match (&a, &b) {
        (
            IkError::NotConverged {
                iterations: ia,
                tip_residual: ra,
                ..
            },
            IkError::NotConverged {
                iterations: ib,
                tip_residual: rb,
                ..
            },
        ) => {
            assert_eq!(ia, ib);
            assert!(
                *ra > 0.0 && (ra - rb).abs() < 1e-9 + 1e-6 * rb,
                "{ra} vs {rb}"
            );
        }
        _ => panic!("{a:?} / {b:?}"),
    }
    // No free axis.
    assert_eq!(
        k.inverse(&target, &q, &[false; 5], &IkOptions::default()),
        Err(IkError::NoFreeAxis)
    );
    // Singular pose: A = 0, tool axis along C; tip and axis with every axis free. The
    // Jacobian loses rank (C and the tool axis), the minimum-norm step still converges.
    let q0 = [10.0, 20.0, -30.0, 0.0, 40.0];
    let actual = k.pose(&q0);
    let t = IkTarget {
        tip: actual.tip,
        axis: Some(actual.axis),
    };
    let start = [10.2, 19.9, -30.1, 0.0, 40.0];
    let a = k.inverse(&t, &start, &[true; 5], &IkOptions::default());
    let b = k.inverse_dynamic(&t, &start, &[true; 5], &IkOptions::default());
    match (a, b) {
        (Ok(a), Ok(b)) => {
            assert!((k.pose(&a).tip - t.tip).norm() < 1e-9);
            for i in 0..5 {
                assert!((a[i] - b[i]).abs() < 1e-7, "{a:?} vs {b:?}");
            }
        }
        (a, b) => assert_eq!(a.is_err(), b.is_err(), "{a:?} vs {b:?}"),
    }
}

#[test]
fn warm_inverse_along_a_path_equals_the_cold_solution() {
    // Targets along a smooth five-axis path, each solved from the previous
    // solution with the previous derivatives (chord steps): every one on its
    // target and equal to the Newton solution from the same start.
    let m = load("ac-trunnion-with-errors.toml");
    let k = Kinematics::new(&m);
    let opts = IkOptions::default();
    let all = [true; 5];
    let q_at = |s: f64| {
        [
            40.0 * s.cos(),
            40.0 * s.sin(),
            -50.0 + 5.0 * s,
            20.0 + 10.0 * s,
            30.0 * s,
        ]
    };
    let mut q = q_at(0.0).to_vec();
    let mut jac = None;
    for i in 1..=200 {
        let pose = k.pose(&q_at(i as f64 * 5e-3));
        let t = IkTarget {
            tip: pose.tip,
            axis: Some(pose.axis),
        };
        let cold = k.inverse(&t, &q, &all, &opts).expect("cold");
        k.inverse_warm(&t, &mut q, &all, &opts, &mut jac)
            .expect("warm");
        assert!(jac.is_some());
        let p = k.pose(&q);
        assert!((p.tip - t.tip).norm() <= opts.tip_tolerance);
        assert!(p.axis.cross(&t.axis.unwrap()).norm() <= 2.0 * opts.axis_tolerance);
        for (a, b) in q.iter().zip(&cold) {
            assert!((a - b).abs() < 1e-9, "{q:?} vs {cold:?}");
        }
    }
}

#[test]
fn a_kept_jacobian_serves_other_free_axes_and_rows() {
    // One kept Jacobian (and its factored step solver) passed between solves that
    // alternate tip-only targets with the linear axes free and full-pose targets with
    // all axes free: each solve must refactor for its own problem and reach its target.
    let m = load("ac-trunnion-with-errors.toml");
    let k = Kinematics::new(&m);
    let opts = IkOptions::default();
    let all = [true; 5];
    let linear = [true, true, true, false, false];
    let mut q = vec![40.0, 0.0, -50.0, 20.0, 0.0];
    let mut jac = None;
    for i in 1..=60 {
        let s = i as f64 * 1e-2;
        let want = [
            40.0 * s.cos(),
            40.0 * s.sin(),
            -50.0,
            20.0 + 5.0 * s,
            30.0 * s,
        ];
        let pose = k.pose(&want);
        let full = i % 2 == 0;
        let t = IkTarget {
            tip: pose.tip,
            axis: full.then_some(pose.axis),
        };
        if !full {
            // The rotaries are not free: put them where the target needs them.
            q[3] = want[3];
            q[4] = want[4];
        }
        let free = if full { &all } else { &linear };
        k.inverse_warm(&t, &mut q, free, &opts, &mut jac)
            .expect("converges");
        let p = k.pose(&q);
        assert!((p.tip - t.tip).norm() <= opts.tip_tolerance, "step {i}");
        if full {
            assert!(p.axis.cross(&pose.axis).norm() <= 2.0 * opts.axis_tolerance);
        }
        for (a, b) in q.iter().zip(&want) {
            assert!((a - b).abs() < 1e-8, "step {i}: {q:?} vs {want:?}");
        }
    }
}

#[test]
fn a_stall_ratio_gives_up_early_at_an_unreachable_axis() {
    let m = load("ac-trunnion-with-errors.toml");
    let k = Kinematics::new(&m);
    let all = [true; 5];
    let stall = IkOptions {
        stall_ratio: Some(0.5),
        ..IkOptions::default()
    };
    // A = 0: the tool axis lies along C. A tool axis tilted 0.1 mrad towards
    // the C-rotated X direction needs C a quarter turn away: out of reach of
    // small steps, and the solve says so in a few iterations, not fifty.
    let q = [10.0, 20.0, -30.0, 0.0, 40.0];
    let pose = k.pose(&q);
    let c = 40f64.to_radians();
    let sideways = Vector3::new(c.cos(), -c.sin(), 0.0);
    let t = IkTarget {
        tip: pose.tip,
        axis: Some((pose.axis + 1e-4 * sideways).normalize()),
    };
    match k.inverse(&t, &q, &all, &stall) {
        Err(IkError::NotConverged { iterations, .. }) => assert!(iterations <= 6, "{iterations}"),
        Ok(sol) => panic!("converged to {sol:?}"),
        Err(e) => panic!("{e}"),
    }
    // A reachable target from a cold start still converges with the ratio set.
    let q0 = [10.0, 20.0, -30.0, 15.0, 40.0];
    let pose = k.pose(&q0);
    let t = IkTarget {
        tip: pose.tip,
        axis: Some(pose.axis),
    };
    let start: Vec<f64> = q0.iter().map(|v| v + 0.1).collect();
    let sol = k.inverse(&t, &start, &all, &stall).expect("reachable");
    for (a, b) in sol.iter().zip(&q0) {
        assert!((a - b).abs() < 1e-8, "{sol:?}");
    }
}
