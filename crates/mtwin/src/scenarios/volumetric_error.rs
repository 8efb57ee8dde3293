//! The machine model: volumetric error of a machine with geometric errors
//! over poses spread through its travels, and inverse kinematics on it that
//! puts the tool back on the nominal targets.

use std::fmt;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Inner, Result, ScenarioError, since};
use crate::kinematics::{IkOptions, IkTarget, Kinematics};
use crate::model::Machine;
use crate::report::html::{Block, Section};
use crate::report::sections;

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// Poses spread through the travels ([`spread_poses`]).
    pub poses: usize,
    /// How many of them (the first) are compensated by inverse kinematics.
    pub ik_poses: usize,
}

impl Default for Options {
    /// The demo's: 20 000 poses, 2 000 by inverse kinematics.
    fn default() -> Self {
        Options {
            poses: 20_000,
            ik_poses: 2000,
        }
    }
}

/// Deterministic poses spread over the travels of `m` (mm, degree): pose `k`
/// (1-based) has on axis `i` the van der Corput radical inverse of `k` in
/// the `i`-th prime base (2, 3, 5, …, 19, then again), scaled to the travel;
/// a low-discrepancy (Halton) sequence.
pub fn spread_poses(m: &Machine, n: usize) -> Vec<Vec<f64>> {
    const PRIMES: [f64; 8] = [2.0, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0, 19.0];
    (1..=n)
        .map(|k| {
            m.axes
                .iter()
                .enumerate()
                .map(|(i, a)| {
                    let (mut f, mut r, mut x) = (1.0, 0.0, k as f64);
                    let b = PRIMES[i % PRIMES.len()];
                    while x > 0.0 {
                        f /= b;
                        r += f * (x % b);
                        x = (x / b).floor();
                    }
                    a.travel[0] + (a.travel[1] - a.travel[0]) * r
                })
                .collect()
        })
        .collect()
}

/// The volumetric error summary (`machine` in the demo's JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VolumetricErrorDoc {
    /// Axes of the machine.
    pub axes: usize,
    /// Geometric error terms of the machine.
    pub error_terms: usize,
    /// Forward kinematics with errors, poses per second of wall-clock time.
    pub fk_poses_per_s: f64,
    /// Largest tool-tip distance from its nominal target after inverse
    /// kinematics on the actual machine, mm.
    pub ik_max_error_mm: f64,
    /// Poses solved by inverse kinematics.
    pub ik_poses: usize,
    /// Largest angle between the actual and nominal tool axis, rad.
    pub max_axis_error_rad: f64,
    /// Largest tool-tip distance between the actual and nominal machine, mm.
    pub max_error_mm: f64,
    /// The machine's name.
    pub name: String,
    /// Poses evaluated.
    pub poses: usize,
    /// RMS of the tool-tip distance, mm.
    pub rms_error_mm: f64,
    /// Wall-clock time of the run, s.
    pub seconds: f64,
}

impl VolumetricErrorDoc {
    /// The step's heading.
    pub fn title(&self) -> String {
        format!(
            "Machine model: {} ({} axes, {} geometric error terms)",
            self.name, self.axes, self.error_terms
        )
    }
}

impl fmt::Display for VolumetricErrorDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "volumetric error over {} poses: max {:.1} µm, RMS {:.1} µm; tool axis max {:.1} µrad",
            self.poses,
            self.max_error_mm * 1e3,
            self.rms_error_mm * 1e3,
            self.max_axis_error_rad * 1e6
        )?;
        writeln!(
            f,
            "exact forward kinematics with errors: {:.1} million poses/s; inverse kinematics of {} poses leaves {:.1e} mm",
            self.fk_poses_per_s / 1e6,
            self.ik_poses,
            self.ik_max_error_mm
        )
    }
}

/// What [`run`] found.
#[derive(Debug, Clone)]
pub struct VolumetricErrorRun {
    /// The summary.
    pub doc: VolumetricErrorDoc,
    /// The machine.
    pub machine: Machine,
}

/// Evaluates the volumetric error of `machine` (with its geometric errors)
/// against its nominal model at [`spread_poses`], and compensates the first
/// `ik_poses` by inverse kinematics on the actual machine (all axes free,
/// tip and tool axis targeted). Poses whose inverse kinematics fails are
/// left out of `ik_poses`.
pub fn run(machine: &Machine, opts: &Options) -> Result<VolumetricErrorRun> {
    run_inner(machine, opts).map_err(ScenarioError::new)
}

fn run_inner(m: &Machine, opts: &Options) -> Inner<VolumetricErrorRun> {
    let t0 = Instant::now();
    if opts.poses == 0 {
        return Err("the volumetric error needs at least one pose".into());
    }
    let k = Kinematics::new(m);
    let kn = Kinematics::nominal(m);
    let poses = spread_poses(m, opts.poses);
    let flat: Vec<f64> = poses.iter().flatten().copied().collect();
    let t = Instant::now();
    let actual = k.poses(&flat);
    let dt = since(t);
    let nominal = kn.poses(&flat);
    let (mut max, mut sum2, mut amax) = (0.0f64, 0.0, 0.0f64);
    for (a, n) in actual.iter().zip(&nominal) {
        let e = (a.tip - n.tip).norm();
        max = max.max(e);
        sum2 += e * e;
        amax = amax.max(a.axis.cross(&n.axis).norm().atan2(a.axis.dot(&n.axis)));
    }
    let rms = (sum2 / poses.len() as f64).sqrt();
    let all = vec![true; m.n_axes()];
    let (mut worst, mut done) = (0.0f64, 0);
    for q in poses.iter().take(opts.ik_poses) {
        let target = kn.pose(q);
        let Ok(sol) = k.inverse(
            &IkTarget {
                tip: target.tip,
                axis: Some(target.axis),
            },
            q,
            &all,
            &IkOptions::default(),
        ) else {
            continue;
        };
        worst = worst.max((k.pose(&sol).tip - target.tip).norm());
        done += 1;
    }
    Ok(VolumetricErrorRun {
        doc: VolumetricErrorDoc {
            axes: m.n_axes(),
            error_terms: m.n_error_terms(),
            fk_poses_per_s: poses.len() as f64 / dt,
            ik_max_error_mm: worst,
            ik_poses: done,
            max_axis_error_rad: amax,
            max_error_mm: max,
            name: m.name.clone(),
            poses: poses.len(),
            rms_error_mm: rms,
            seconds: since(t0),
        },
        machine: m.clone(),
    })
}

impl VolumetricErrorRun {
    /// The report section: the machine model with the volumetric error.
    pub fn sections(&self) -> Vec<Section> {
        let d = &self.doc;
        let mut s = sections::machine::section(
            &self.machine,
            "machine",
            "Machine model: AC double-turntable with errors",
        );
        s.blocks.insert(
            1,
            Block::Text(format!(
                "Volumetric error over {} poses spread through the work volume: largest {:.1} µm, RMS {:.1} µm; \
                 tool-axis error up to {:.1} µrad. Inverse kinematics on the actual machine brings {} poses \
                 onto their nominal targets to {:.1e} mm.",
                d.poses,
                d.max_error_mm * 1e3,
                d.rms_error_mm * 1e3,
                d.max_axis_error_rad * 1e6,
                d.ik_poses,
                d.ik_max_error_mm
            )),
        );
        vec![s]
    }
}
