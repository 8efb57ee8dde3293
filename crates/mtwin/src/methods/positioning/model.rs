//! The positioning error of an axis into the machine model
//! (`mtwin positioning evaluate --update-model`, docs/positioning.md).
//!
//! The mean bidirectional deviation `x̄i` of each target (actual − target,
//! the ISO 230-2 sign) becomes the axis's positioning error as a table error
//! function (`ErrorFunction::Table`, docs/machine-model.md): `q = Pi`,
//! `e = x̄i`. The model's PDGE `E_i(q) = Trans(EX, EY, EZ)·Rx(EA)·Ry(EB)·Rz(EC)`
//! moves the axis frame from its nominal place `q·d` to `q·d + (EX, EY, EZ)`,
//! so an axis along +x with `EXX(q) = e` stands at `q + e`: the same sign as
//! ISO 230-2's deviation. For an axis along −x (or −y, −z) the error along
//! the axis's own motion is `−EX<axis>`, and the table holds `−x̄i`.
//!
//! Which component: a linear axis along machine axis x, y or z gets
//! `EX<axis>`, `EY<axis>` or `EZ<axis>` (mm; the run's deviations are mm);
//! a rotary axis about x, y or z gets `EA<axis>`, `EB<axis>` or `EC<axis>`
//! (rad; the run's positions and deviations of a rotary axis are read as
//! degrees where a linear axis has mm, so a deviation column in µm holds
//! millidegrees). An axis not along a machine axis is refused: its
//! positioning error is not one component.

use super::PositioningDoc;
use crate::model::{AxisKind, Component, ErrorFunction, ErrorName, Machine};

/// What [`update_machine`] put into the model.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelUpdate {
    /// The error written, e.g. `EXX`.
    pub error: ErrorName,
    /// Table positions (the run's targets), mm or degree.
    pub q: Vec<f64>,
    /// Table values, mm or rad.
    pub e: Vec<f64>,
    /// True when the model had a non-zero function for this error before (replaced).
    pub replaced: bool,
}

/// A copy of `machine` whose axis `axis` has the positioning error of `doc`
/// (the mean bidirectional deviation per target) as a table; see the module
/// documentation for the component and sign. Errors (a sentence) when the axis
/// is missing, not along a machine axis, the run has fewer than two targets,
/// or a target lies outside the axis travel.
pub fn update_machine(
    machine: &Machine,
    axis: &str,
    doc: &PositioningDoc,
) -> Result<(Machine, ModelUpdate), String> {
    let Some(i) = machine.axis_index(axis) else {
        return Err(format!(
            "the machine has no axis {axis} (its axes: {})",
            machine.axis_names().join(", ")
        ));
    };
    let ax = &machine.axes[i];
    let d = ax.direction;
    let Some(k) = (0..3).find(|&k| (d[k].abs() - 1.0).abs() < 1e-9) else {
        return Err(format!(
            "axis {axis} is not along x, y or z of the machine; its positioning error is not one error component"
        ));
    };
    let sign = d[k].signum();
    if doc.per_target.len() < 2 {
        return Err("a positioning table needs at least two targets".into());
    }
    let q: Vec<f64> = doc.per_target.iter().map(|t| t.target_mm).collect();
    if let Some(t) = q.iter().find(|&&t| !ax.in_travel(t)) {
        return Err(format!(
            "target {} {} lies outside the travel of axis {axis} ({} to {})",
            crate::io::fmt_f64(*t),
            ax.kind.unit(),
            crate::io::fmt_f64(ax.travel[0]),
            crate::io::fmt_f64(ax.travel[1])
        ));
    }
    if q.windows(2).any(|w| w[1] <= w[0]) {
        return Err("the targets must increase".into());
    }
    let (component, scale) = match ax.kind {
        // µm → mm
        AxisKind::Linear => (Component::ALL[k], 1e-3),
        // millidegree → rad
        AxisKind::Rotary => (Component::ALL[3 + k], 1e-3_f64.to_radians()),
    };
    let e: Vec<f64> = doc
        .per_target
        .iter()
        .map(|t| sign * t.mean_um * scale)
        .collect();
    let mut m = machine.clone();
    let slot = &mut m.axes[i].errors.pdge[component.index()];
    let replaced = slot.as_ref().is_some_and(|f| !f.is_zero());
    *slot = Some(ErrorFunction::Table {
        q: q.clone(),
        e: e.clone(),
    });
    Ok((
        m,
        ModelUpdate {
            error: ErrorName::pdge(component, axis),
            q,
            e,
            replaced,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::positioning::{Run, evaluate};

    fn doc(targets: &[f64], means_mm: &[f64]) -> PositioningDoc {
        // up = mean + 1 µm ± 0.5 µm, down = mean − 1 µm ± 0.5 µm: bidirectional mean = mean.
        let run = Run {
            source: "t".into(),
            targets_mm: targets.to_vec(),
            up_mm: means_mm
                .iter()
                .map(|m| vec![m + 0.0015, m + 0.0005])
                .collect(),
            down_mm: means_mm
                .iter()
                .map(|m| vec![m - 0.0015, m - 0.0005])
                .collect(),
            notes: vec![],
        };
        evaluate(&run).unwrap()
    }

    #[test]
    fn linear_axis_gets_its_own_component_and_the_sign_of_its_direction() {
        let mut m = crate::examples::machine("ac-trunnion").unwrap();
        let d = doc(&[-100.0, 0.0, 100.0], &[0.002, -0.001, 0.004]);
        let (m1, u) = update_machine(&m, "Y", &d).unwrap();
        assert_eq!(u.error.to_string(), "EYY");
        assert!(!u.replaced);
        let y = m1.axis_index("Y").unwrap();
        let f = m1.axes[y].errors.pdge[Component::Ty.index()]
            .as_ref()
            .unwrap();
        for (q, want) in [
            (-100.0, 0.002),
            (0.0, -0.001),
            (50.0, 0.0015),
            (100.0, 0.004),
        ] {
            assert!((f.eval(q, m1.axes[y].travel) - want).abs() < 1e-15, "{q}");
        }
        // the axis reversed: the table holds the opposite sign
        m.axes[y].direction = -m.axes[y].direction;
        let (m2, _) = update_machine(&m, "Y", &d).unwrap();
        let f = m2.axes[y].errors.pdge[Component::Ty.index()]
            .as_ref()
            .unwrap();
        assert!((f.eval(100.0, m2.axes[y].travel) + 0.004).abs() < 1e-15);
    }

    #[test]
    fn rotary_axis_gets_radians() {
        let m = crate::examples::machine("ac-trunnion").unwrap();
        // 3.6 millidegree at 90°
        let d = doc(&[0.0, 90.0], &[0.0, 0.0036]);
        let (m1, u) = update_machine(&m, "C", &d).unwrap();
        assert_eq!(u.error.to_string(), "ECC");
        assert!((u.e[1] - 3.6e-3_f64.to_radians()).abs() < 1e-15);
        assert!(m1.validate().is_ok());
    }

    #[test]
    fn refusals_name_the_problem() {
        let m = crate::examples::machine("ac-trunnion").unwrap();
        let d = doc(&[0.0, 500.0], &[0.0, 0.001]);
        let e = update_machine(&m, "X", &d).unwrap_err();
        assert!(e.contains("outside the travel"), "{e}");
        let e = update_machine(&m, "W", &d).unwrap_err();
        assert!(e.contains("no axis W"), "{e}");
        let mut m2 = m.clone();
        let x = m2.axis_index("X").unwrap();
        m2.axes[x].direction = nalgebra::Vector3::new(0.6, 0.8, 0.0);
        let d = doc(&[0.0, 100.0], &[0.0, 0.001]);
        let e = update_machine(&m2, "X", &d).unwrap_err();
        assert!(e.contains("not along x, y or z"), "{e}");
    }
}
