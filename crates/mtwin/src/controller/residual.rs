//! What exported tables leave: the volumetric error of the machine (the full
//! model) when the controller corrects it with the tables, over a workspace
//! grid, against the error left by compensating with the full model.
//!
//! For every grid pose `q` the target is where the nominal machine puts the
//! tool tip. The controller's commands are found as the format applies its
//! tables ([`Correction`]); the full model then says where the tip really
//! goes. The distance to the target is the residual. Two references come
//! with it: the error without any compensation, and with compensation by the
//! full model itself (the linear axes moved so that the model's tip is on
//! target; zero up to the solver's tolerance unless a target is out of reach).

use serde::{Deserialize, Serialize};

use super::Correction;
use crate::kinematics::{IkOptions, IkTarget, Kinematics};
use crate::model::{AxisKind, Machine};

/// The workspace grid.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualOptions {
    /// Points per linear axis over its travel (default 5).
    pub linear_points: usize,
    /// Points per rotary axis over its travel (default 3).
    pub rotary_points: usize,
}

impl Default for ResidualOptions {
    fn default() -> Self {
        ResidualOptions {
            linear_points: 5,
            rotary_points: 3,
        }
    }
}

/// The residual volumetric error (µm) over the workspace grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Residual {
    /// Largest tool-tip error left by the tables, µm.
    pub max_um: f64,
    /// RMS tool-tip error left by the tables, µm.
    pub rms_um: f64,
    /// Axis positions (mm, deg, in axis order) where `max_um` occurs.
    pub at: Vec<f64>,
    /// Largest error without compensation, µm.
    pub uncompensated_max_um: f64,
    /// RMS error without compensation, µm.
    pub uncompensated_rms_um: f64,
    /// Largest error with compensation by the full model, µm.
    pub full_model_max_um: f64,
    /// RMS error with compensation by the full model, µm.
    pub full_model_rms_um: f64,
    /// Number of grid poses.
    pub poses: usize,
}

/// `n` evenly spaced points over `[lo, hi]`.
fn spaced(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n <= 1 {
        return vec![0.5 * (lo + hi)];
    }
    (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
        .collect()
}

/// Every pose of the workspace grid.
pub fn grid(machine: &Machine, opts: &ResidualOptions) -> Vec<Vec<f64>> {
    let per_axis: Vec<Vec<f64>> = machine
        .axes
        .iter()
        .map(|a| {
            let n = match a.kind {
                AxisKind::Linear => opts.linear_points,
                AxisKind::Rotary => opts.rotary_points,
            };
            spaced(a.travel[0], a.travel[1], n)
        })
        .collect();
    let mut poses = vec![Vec::new()];
    for values in &per_axis {
        poses = poses
            .into_iter()
            .flat_map(|p| {
                values.iter().map(move |&v| {
                    let mut q = p.clone();
                    q.push(v);
                    q
                })
            })
            .collect();
    }
    poses
}

/// Commands that put the tip of `k` on `target`, moving the linear axes
/// (and, where the machine orients the tool, keeping the tool axis too).
fn solve(k: &Kinematics, machine: &Machine, q: &[f64], tip: IkTarget) -> Vec<f64> {
    let free: Vec<bool> = machine
        .axes
        .iter()
        .map(|a| a.kind == AxisKind::Linear)
        .collect();
    let opts = IkOptions {
        check_travel: false,
        tip_tolerance: 1e-10,
        ..IkOptions::default()
    };
    let target = IkTarget {
        tip: tip.tip,
        axis: None,
    };
    // The last iterate is as good as it gets when the tolerance is not met.
    let mut out = q.to_vec();
    let _ = k.inverse_in_place(&target, &mut out, &free, &opts);
    out
}

/// The residual of `correction` on `machine` (the full model).
pub fn residual(machine: &Machine, correction: &Correction, opts: &ResidualOptions) -> Residual {
    let actual = Kinematics::new(machine);
    let nominal = Kinematics::new(&machine.nominal());
    let poses = grid(machine, opts);
    let ctrl = match correction {
        Correction::Volumetric(m) => Kinematics::new(m),
        Correction::Joint { kinematics, .. } => Kinematics::new(kinematics),
    };
    let mut sum = [0.0f64; 3];
    let mut max = [0.0f64; 3];
    let mut at = poses.first().cloned().unwrap_or_default();
    for q in &poses {
        let target = IkTarget {
            tip: nominal.pose(q).tip,
            axis: None,
        };
        let err = |cmd: &[f64]| (actual.pose(cmd).tip - target.tip).norm() * 1000.0;
        let cmd = match correction {
            Correction::Volumetric(_) => solve(&ctrl, machine, q, target),
            Correction::Joint { tables, .. } => {
                let base = solve(&ctrl, machine, q, target);
                let mut cmd = base.clone();
                for t in tables {
                    cmd[t.output] += t.eval(base[t.input]);
                }
                cmd
            }
        };
        let full = solve(&actual, machine, q, target);
        let e = [err(&cmd), err(q), err(&full)];
        if e[0] > max[0] {
            at = q.clone();
        }
        for ((s, m), v) in sum.iter_mut().zip(max.iter_mut()).zip(e) {
            *s += v * v;
            *m = m.max(v);
        }
    }
    let n = poses.len().max(1) as f64;
    Residual {
        max_um: max[0],
        rms_um: (sum[0] / n).sqrt(),
        at,
        uncompensated_max_um: max[1],
        uncompensated_rms_um: (sum[1] / n).sqrt(),
        full_model_max_um: max[2],
        full_model_rms_um: (sum[2] / n).sqrt(),
        poses: poses.len(),
    }
}
