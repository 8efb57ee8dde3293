//! Compensation: corrected axis commands from the identified model by inverse
//! kinematics. The target of a commanded pose is where the nominal machine
//! would put the tool: the identified machine is driven there.
//!
//! Position only (the choice of the source paper \[R2\]) moves the linear axes; position and tool
//! axis is used where the machine can do it ([`Machine::orients_tool`]:
//! two rotary axes of five; all axes move).

use serde::Serialize;

use crate::kinematics::{IkError, IkOptions, IkTarget, Kinematics};
use crate::model::{AxisKind, Machine};

/// What the correction matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CompensationMode {
    /// Tool tip only, linear axes moved.
    Position,
    /// Tool tip and tool axis, all axes moved.
    PositionAndAxis,
}

impl CompensationMode {
    /// The mode `machine` allows (see the module documentation).
    pub fn for_machine(machine: &Machine) -> CompensationMode {
        if machine.orients_tool() {
            CompensationMode::PositionAndAxis
        } else {
            CompensationMode::Position
        }
    }
}

/// One corrected command.
#[derive(Debug, Clone, PartialEq)]
pub struct Corrected {
    /// Corrected axis positions (mm, degree).
    pub q: Vec<f64>,
    /// Tip error the identified model predicts at the commanded pose, mm.
    pub error_before: f64,
    /// Tip error the identified model predicts at the corrected pose, mm.
    pub error_after: f64,
    /// Tool-axis angle error predicted at the corrected pose, rad (0 in
    /// position mode, where it is not controlled, it is still reported).
    pub axis_error_after: f64,
}

/// Corrects commands with the identified machine.
pub struct PointCompensator {
    nominal: Kinematics,
    actual: Kinematics,
    mode: CompensationMode,
    free: Vec<bool>,
    options: IkOptions,
}

impl PointCompensator {
    /// A compensator for `identified` in the mode it allows.
    pub fn new(identified: &Machine) -> Self {
        let mode = CompensationMode::for_machine(identified);
        let free = identified
            .axes
            .iter()
            .map(|a| mode == CompensationMode::PositionAndAxis || a.kind == AxisKind::Linear)
            .collect();
        Self {
            nominal: Kinematics::nominal(identified),
            actual: Kinematics::new(identified),
            mode,
            free,
            options: IkOptions {
                tip_tolerance: 1e-9,
                axis_tolerance: 1e-11,
                ..IkOptions::default()
            },
        }
    }

    /// The mode in use.
    pub fn mode(&self) -> CompensationMode {
        self.mode
    }

    /// The corrected command for the commanded axis positions `q`.
    pub fn correct(&self, q: &[f64]) -> Result<Corrected, IkError> {
        let want = self.nominal.pose(q);
        let target = IkTarget {
            tip: want.tip,
            axis: (self.mode == CompensationMode::PositionAndAxis).then_some(want.axis),
        };
        let error_before = (self.actual.pose(q).tip - want.tip).norm();
        let qc = self.actual.inverse(&target, q, &self.free, &self.options)?;
        let got = self.actual.pose(&qc);
        Ok(Corrected {
            error_before,
            error_after: (got.tip - want.tip).norm(),
            axis_error_after: got
                .axis
                .cross(&want.axis)
                .norm()
                .atan2(got.axis.dot(&want.axis)),
            q: qc,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::read_machine;

    fn example(name: &str) -> Machine {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/machines")
            .join(name);
        read_machine(&p).unwrap()
    }

    #[test]
    fn gantry_correction_shifts_linear_axes_by_minus_the_error() {
        let m = example("afp-gantry-with-errors.toml");
        let c = PointCompensator::new(&m);
        assert_eq!(c.mode(), CompensationMode::Position);
        let q = [4000.0, 1500.0, -400.0, 20.0, -10.0, 45.0];
        let r = c.correct(&q).unwrap();
        assert!(r.error_after < 1e-8, "{}", r.error_after);
        assert_eq!(&r.q[3..], &q[3..]);
        // First order: the linear shift is minus the predicted error (axes
        // are x, y, z); the second-order remainder is error × angular error.
        let e = Kinematics::new(&m).pose(&q).tip - Kinematics::nominal(&m).pose(&q).tip;
        assert!((e.norm() - r.error_before).abs() < 1e-12);
        for k in 0..3 {
            assert!(
                (r.q[k] - q[k] + e[k]).abs() < 1e-3 * e.norm().max(1e-3),
                "{k}"
            );
        }
    }

    #[test]
    fn five_axis_correction_matches_tip_and_tool_axis() {
        let m = example("ac-trunnion-with-errors.toml");
        let c = PointCompensator::new(&m);
        assert_eq!(c.mode(), CompensationMode::PositionAndAxis);
        let q: Vec<f64> = m
            .axes
            .iter()
            .map(|a| a.travel[0] + 0.37 * (a.travel[1] - a.travel[0]))
            .collect();
        let r = c.correct(&q).unwrap();
        assert!(r.error_after < 1e-8 && r.axis_error_after < 1e-10, "{r:?}");
        assert!(r.error_before > 1e-4);
    }
}

/// Options of [`run`].
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct CompensatePointsOptions {
    /// Name of the file the caller writes the corrected poses to, reported by the document.
    pub out: String,
}

/// A pose that cannot be corrected: its index in the input and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("cannot compensate pose {index}: {source}")]
pub struct PointError {
    /// Index of the pose (0-based).
    pub index: usize,
    /// Why the inverse kinematics failed.
    #[source]
    pub source: IkError,
}

/// `mtwin tracker compensate-points`: the corrected command of every pose
/// (mm, degree; [`PointCompensator::correct`]) and the document.
pub fn run(
    identified: &Machine,
    poses: &[Vec<f64>],
    options: &CompensatePointsOptions,
) -> Result<(Vec<Corrected>, super::CompensatePointsDoc), PointError> {
    let c = PointCompensator::new(identified);
    let mut out = Vec::with_capacity(poses.len());
    let (mut before, mut after) = (0.0f64, 0.0f64);
    for (index, q) in poses.iter().enumerate() {
        let r = c
            .correct(q)
            .map_err(|source| PointError { index, source })?;
        before = before.max(r.error_before);
        after = after.max(r.error_after);
        out.push(r);
    }
    let doc = super::CompensatePointsDoc {
        max_error_after: after,
        max_error_before: before,
        mode: c.mode(),
        out: options.out.clone(),
        poses: out.len(),
    };
    Ok((out, doc))
}

#[cfg(test)]
mod run_tests {
    use super::*;
    use crate::methods::tracker::simulate::{self, SimulateOptions};
    use crate::methods::tracker::{IdentifyInputs, IdentifyOptions, identify, validate};
    use crate::model::ParameterSet;
    use rand::SeedableRng;

    /// The run functions chain on a known truth: tips simulated without
    /// noise by `simulate::run`, location errors identified by
    /// `identify::run`, validated by `validate::run` (the identified model
    /// predicts the measured tips), and `compensate::run` corrects poses so
    /// that the identified model puts the tip on the nominal one.
    #[test]
    fn simulate_identify_validate_compensate() {
        let nominal = crate::examples::machine("ac-trunnion").unwrap();
        let params = ParameterSet::from_spec(&nominal, "location").unwrap();
        let mut truth = nominal.clone();
        let theta: Vec<f64> = params
            .is_rotation()
            .iter()
            .map(|&rot| if rot { 3e-5 } else { 0.02 })
            .collect();
        params.set(&mut truth, &theta);
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let poses = simulate::random_poses(&nominal, 80, &mut rng);
        let options = SimulateOptions {
            noise: 0.0,
            out: "fit.csv".into(),
            ..Default::default()
        };
        let (points, doc) = simulate::run(&truth, &poses, &options);
        assert_eq!((doc.points, doc.out.as_str()), (80, "fit.csv"));
        let id_options = IdentifyOptions {
            out: "id.toml".into(),
            ..Default::default()
        };
        let (id, _) = identify::run(
            &IdentifyInputs {
                machine: &nominal,
                params: &params,
                points: &points,
            },
            &id_options,
            &|_| {},
        )
        .unwrap();
        let (v, vdoc) = validate::run(&id.machine, &points, &Default::default());
        assert!(v.after.distance.max < 1e-6, "{}", v.after.distance.max);
        assert!(v.before.distance.max > 0.01);
        assert_eq!(vdoc, crate::methods::tracker::TrackerValidateDoc::from(&v));
        let c_options = CompensatePointsOptions {
            out: "corrected.csv".into(),
        };
        let (corrected, cdoc) = run(&id.machine, &poses, &c_options).unwrap();
        assert_eq!((cdoc.poses, cdoc.out.as_str()), (80, "corrected.csv"));
        assert!(cdoc.max_error_after < 1e-6, "{}", cdoc.max_error_after);
        let (k_id, k_nom) = (Kinematics::new(&id.machine), Kinematics::nominal(&nominal));
        for (c, q) in corrected.iter().zip(&poses) {
            assert!((k_id.pose(&c.q).tip - k_nom.pose(q).tip).norm() < 1e-6);
        }
    }
}
