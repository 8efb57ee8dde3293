//! Squareness and scale mismatch of a circular test into the machine model
//! (`mtwin ballbar circular --update-model`, docs/ballbar.md).
//!
//! The model's own circular test is computed first: the tool tip of the
//! machine model at `N` points of a circle of radius R in the test plane
//! about the reference pose (linear axes in the middle of their travel,
//! rotary axes at 0, or the middle of their travel when 0 is outside it),
//! read as a ballbar would read it (distance from the nominal centre), and
//! fitted with the signatures of the squareness (`(α·R/2)·sin 2θ`) and scale
//! mismatch (`(k/2)·cos 2θ`) together with the set-up terms (centre offset,
//! radius offset). The model is then changed so that its own test shows the
//! measured values (two Newton steps on sensitivities found by finite
//! differences, so every chain order and axis direction is handled by the
//! kinematics itself):
//!
//! * **squareness** — the location error rotating one of the plane's two
//!   axes about the plane normal (`EC0<axis>` in XY, `EA0<axis>` in YZ,
//!   `EB0<axis>` in ZX, rad), on whichever of the two axes the rotation
//!   changes the angle between them (in a serial chain the one farther from
//!   the base: rotating the other turns both together);
//! * **scale mismatch** — a linear term `c·q` added to each plane axis's
//!   positioning error along its own direction (`EXX`, `EYY`, … in mm), the
//!   two slopes chosen so that the mismatch is the measured one and the
//!   common scale (which the ballbar cannot tell from its length) does not
//!   change.
//!
//! A model that already predicts some squareness or mismatch is changed by
//! the difference only: the new model's own circular test gives the measured
//! values.

use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};

use super::circular::{CircularDoc, Plane};
use crate::kinematics::Kinematics;
use crate::model::{AxisKind, Component, ErrorFunction, ErrorName, Machine};

/// Points on the model's circle.
const N: usize = 720;

/// One error the update changed.
#[derive(Debug, Clone, PartialEq)]
pub struct Change {
    /// The error, e.g. `EC0X` or `EXX`.
    pub error: ErrorName,
    /// What was added: rad for a location rotation, the slope (mm/mm) of a
    /// linear term for a positioning error.
    pub added: f64,
    /// The change in words: the new and old value of a location rotation
    /// (µrad), the slope of the linear term added to a positioning error
    /// (µm/m; its other terms are kept).
    pub note: String,
}

/// The squareness (µm/m) and scale mismatch (µm) the model's own circular
/// test shows in `plane` at radius `radius_mm` (see the module documentation).
pub fn model_signature(
    machine: &Machine,
    plane: Plane,
    radius_mm: f64,
) -> Result<(f64, f64, f64), String> {
    let setup = Setup::new(machine, plane, radius_mm)?;
    Ok(setup.fit(machine))
}

struct Setup {
    r: f64,
    q0: Vec<f64>,
    /// Plane axis indices and the sign of their motion of the tool in W.
    axes: [(usize, f64); 2],
    centre: Vector3<f64>,
}

impl Setup {
    fn new(machine: &Machine, plane: Plane, r: f64) -> Result<Setup, String> {
        if !(r.is_finite() && r > 0.0) {
            return Err("the radius must be positive".into());
        }
        let q0: Vec<f64> = machine
            .axes
            .iter()
            .map(|a| match a.kind {
                AxisKind::Rotary if a.in_travel(0.0) => 0.0,
                _ => 0.5 * (a.travel[0] + a.travel[1]),
            })
            .collect();
        let nom = Kinematics::nominal(machine);
        let t0 = nom.pose(&q0).tip;
        let [ia, ib, _] = plane.indices();
        let find = |k: usize| -> Result<(usize, f64), String> {
            for (i, ax) in machine.axes.iter().enumerate() {
                if ax.kind != AxisKind::Linear {
                    continue;
                }
                let mut q = q0.clone();
                q[i] += 1.0;
                let d = nom.pose(&q).tip - t0;
                if (d[k].abs() - 1.0).abs() < 1e-6 && d.norm() < 1.0 + 1e-6 {
                    let half = 0.5 * (ax.travel[1] - ax.travel[0]);
                    if r > half {
                        return Err(format!(
                            "a circle of radius {} mm does not fit in the travel of axis {} ({} to {} mm)",
                            crate::io::fmt_f64(r),
                            ax.name,
                            crate::io::fmt_f64(ax.travel[0]),
                            crate::io::fmt_f64(ax.travel[1])
                        ));
                    }
                    return Ok((i, d[k].signum()));
                }
            }
            Err(format!(
                "no linear axis of the machine moves the tool along {} of the workpiece",
                ['x', 'y', 'z'][k]
            ))
        };
        let axes = [find(ia)?, find(ib)?];
        Ok(Setup {
            r,
            q0,
            axes,
            centre: t0,
        })
    }

    /// (squareness µm/m, scale mismatch µm, radius offset µm) of `m`'s circle.
    fn fit(&self, m: &Machine) -> (f64, f64, f64) {
        let k = Kinematics::new(m);
        let mut ata = SMatrix::<f64, 5, 5>::zeros();
        let mut atb = SVector::<f64, 5>::zeros();
        for n in 0..N {
            let th = 2.0 * std::f64::consts::PI * n as f64 / N as f64;
            let (sn, cs) = th.sin_cos();
            let mut q = self.q0.clone();
            q[self.axes[0].0] += self.axes[0].1 * self.r * cs;
            q[self.axes[1].0] += self.axes[1].1 * self.r * sn;
            let d = (k.pose(&q).tip - self.centre).norm() - self.r;
            let row = SVector::<f64, 5>::from([
                0.5 * self.r * 1e-3 * (2.0 * th).sin(),
                0.5 * (2.0 * th).cos(),
                cs,
                sn,
                1.0,
            ]);
            ata += row * row.transpose();
            atb += row * (d * 1e3);
        }
        let p = ata.lu().solve(&atb).unwrap_or_else(SVector::zeros);
        (p[0], p[1], p[4])
    }
}

/// `f + c·q` as an error function of the same kind where it can be (a table
/// stays a table, exactly, since both are linear between its points).
fn add_slope(f: Option<&ErrorFunction>, c: f64, travel: [f64; 2]) -> ErrorFunction {
    match f {
        None => ErrorFunction::Poly(vec![0.0, c]),
        Some(ErrorFunction::Constant(v)) => ErrorFunction::Poly(vec![*v, c]),
        Some(ErrorFunction::Poly(p)) => {
            let mut p = p.clone();
            p.resize(p.len().max(2), 0.0);
            p[1] += c;
            ErrorFunction::Poly(p)
        }
        Some(ErrorFunction::Cheb(a)) => {
            // q = (hi + lo)/2 + (hi − lo)/2 · u
            let mut a = a.clone();
            a.resize(a.len().max(2), 0.0);
            a[0] += c * 0.5 * (travel[0] + travel[1]);
            a[1] += c * 0.5 * (travel[1] - travel[0]);
            ErrorFunction::Cheb(a)
        }
        Some(ErrorFunction::Table { q, e }) => ErrorFunction::Table {
            q: q.clone(),
            e: q.iter().zip(e).map(|(q, e)| e + c * q).collect(),
        },
    }
}

/// The component along a linear axis's own direction.
fn own_component(m: &Machine, i: usize) -> Component {
    let d = m.axes[i].direction;
    let k = (0..3)
        .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
        .unwrap_or(0);
    Component::ALL[k]
}

fn with_slope(m: &Machine, i: usize, c: f64) -> Machine {
    let mut m = m.clone();
    let comp = own_component(&m, i);
    let ax = &mut m.axes[i];
    let travel = ax.travel;
    let f = add_slope(ax.errors.pdge[comp.index()].as_ref(), c, travel);
    ax.errors.pdge[comp.index()] = Some(f);
    m
}

fn with_rotation(m: &Machine, i: usize, normal: Component, g: f64) -> Machine {
    let mut m = m.clone();
    m.axes[i].errors.location[normal.index()] += g;
    m
}

/// A copy of `machine` whose own circular test in the plane of `doc` shows the
/// squareness and scale mismatch `doc` measured (see the module
/// documentation), and the changes made. Errors (a sentence) when `doc` has
/// no value for either (not separable in its set-up), the plane's axes are
/// not linear axes along the workpiece axes, or the circle does not fit in
/// their travel.
pub fn update_machine(
    machine: &Machine,
    doc: &CircularDoc,
) -> Result<(Machine, Vec<Change>), String> {
    let want_sq = doc.get("squareness_um_per_m").ok_or(
        "the squareness is not separable in this set-up (one direction only?); the model is not updated",
    )?;
    let want_k = doc
        .get("scale_mismatch_um")
        .ok_or("the scale mismatch is not separable in this set-up; the model is not updated")?;
    let setup = Setup::new(machine, doc.plane, doc.radius_mm)?;
    let normal = Component::ALL[3 + doc.plane.indices()[2]];
    let [(ia, _), (ib, _)] = setup.axes;
    let (sq0, _, _) = setup.fit(machine);
    // Which axis's rotation changes the angle between the two.
    let h = 1e-5;
    let sens = |i: usize| (setup.fit(&with_rotation(machine, i, normal, h)).0 - sq0) / h;
    let (sa, sb) = (sens(ia), sens(ib));
    let (rot_axis, s_rot) = if sb.abs() >= sa.abs() {
        (ib, sb)
    } else {
        (ia, sa)
    };
    if s_rot.abs() < 1e-3 {
        return Err(
            "no location rotation of the two axes changes their squareness in this machine".into(),
        );
    }
    // Scale: responses of (mismatch, radius offset) to a unit slope of h on each axis.
    let mut m = machine.clone();
    let mut gamma = 0.0;
    let mut slopes = [0.0; 2];
    for _ in 0..2 {
        let (sq, k, r) = setup.fit(&m);
        let resp = |i: usize| {
            let (_, k1, r1) = setup.fit(&with_slope(&m, i, h));
            Vector2::new((k1 - k) / h, (r1 - r) / h)
        };
        let (ra, rb) = (resp(ia), resp(ib));
        let jac = Matrix2::from_columns(&[ra, rb]);
        let c = jac
            .lu()
            .solve(&Vector2::new(want_k - k, 0.0))
            .ok_or("the scale mismatch of the two axes cannot be told apart in this machine")?;
        let dg = (want_sq - sq) / s_rot;
        m = with_rotation(&m, rot_axis, normal, dg);
        m = with_slope(&m, ia, c[0]);
        m = with_slope(&m, ib, c[1]);
        gamma += dg;
        slopes[0] += c[0];
        slopes[1] += c[1];
    }
    let rot_name = ErrorName::location(normal, &machine.axes[rot_axis].name);
    let mut changes = vec![Change {
        error: rot_name,
        added: gamma,
        note: format!(
            "{:.3} µrad (was {:.3})",
            1e6 * m.axes[rot_axis].errors.location[normal.index()],
            1e6 * machine.axes[rot_axis].errors.location[normal.index()]
        ),
    }];
    for (k, i) in [ia, ib].into_iter().enumerate() {
        changes.push(Change {
            error: ErrorName::pdge(own_component(machine, i), &machine.axes[i].name),
            added: slopes[k],
            note: format!("linear term {:.3} µm/m added", slopes[k] * 1e6),
        });
    }
    Ok((m, changes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_added_to_every_kind_of_function() {
        let travel = [-100.0, 300.0];
        let c = 2e-5;
        for f in [
            None,
            Some(ErrorFunction::Constant(0.001)),
            Some(ErrorFunction::Poly(vec![0.001, 0.0, 1e-8])),
            Some(ErrorFunction::Cheb(vec![0.001, 0.002, 0.0005])),
            Some(ErrorFunction::Table {
                q: vec![-100.0, 0.0, 300.0],
                e: vec![0.0, 0.003, -0.001],
            }),
        ] {
            let g = add_slope(f.as_ref(), c, travel);
            for q in [-100.0, -50.0, 0.0, 120.0, 300.0] {
                let before = f.as_ref().map_or(0.0, |f| f.eval(q, travel));
                let got = g.eval(q, travel) - before;
                assert!((got - c * q).abs() < 1e-15, "{f:?} at {q}: {got}");
            }
        }
    }
}
