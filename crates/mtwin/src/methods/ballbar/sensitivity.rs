//! Which PIGE moves which mode, and by how much (table 2 of the source paper \[R1\]),
//! computed on the exact model: one PIGE at a time set to a given size on
//! the nominal machine with an ideal set-up, `ΔL(α) = L(α) − L(0)` over each
//! mode's angles.

use super::mode::{BallbarMode, Geometry, Rig, Trunnion, TrunnionError};
use super::{Pige, Piges};
use crate::kinematics::Kinematics;
use crate::model::Machine;

/// One row of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct SensitivityRow {
    /// The PIGE applied alone.
    pub pige: Pige,
    /// The error size applied (mm or rad).
    pub size: f64,
    /// Largest `|ΔL|` over the angles of each mode (mm).
    pub peak: [f64; 4],
}

/// `ΔL(α)` (mm) of `mode` at `angles_deg` with `piges` on `machine`'s
/// nominal geometry and the set-up of `rig`.
pub fn delta_l_curve(
    machine: &Machine,
    t: &Trunnion,
    mode: BallbarMode,
    rig: &Rig,
    piges: &Piges,
    angles_deg: &[f64],
) -> Vec<f64> {
    let mut m = machine.nominal();
    piges.write_to(&mut m, t);
    let kin = Kinematics::new(&m);
    let g = Geometry::new(&kin, t, mode, rig);
    let l0 = g.reading(rig.length, 0.0);
    angles_deg
        .iter()
        .map(|&a| g.reading(rig.length, a) - l0)
        .collect()
}

/// The table: for every PIGE, its size (`offset` mm for offsets, `tilt` rad
/// for tilts) and the peak `|ΔL|` it causes in each mode over `angles[mode]`
/// (`rig.setup` is ignored: the table is for an ideal set-up).
pub fn sensitivity_table(
    machine: &Machine,
    rig: &Rig,
    offset: f64,
    tilt: f64,
    angles: &[Vec<f64>; 4],
) -> Result<Vec<SensitivityRow>, TrunnionError> {
    let t = Trunnion::of(machine)?;
    let ideal = Rig {
        setup: Default::default(),
        ..*rig
    };
    Ok(Pige::ALL
        .iter()
        .map(|&p| {
            let size = if p.is_tilt() { tilt } else { offset };
            let mut piges = Piges::default();
            piges.set(p, size);
            let mut peak = [0.0; 4];
            for m in BallbarMode::ALL {
                peak[m.index()] = delta_l_curve(machine, &t, m, &ideal, &piges, &angles[m.index()])
                    .into_iter()
                    .fold(0.0_f64, |a, v| a.max(v.abs()));
            }
            SensitivityRow {
                pige: p,
                size,
                peak,
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::ballbar::identify::sees;
    use crate::methods::ballbar::simulate::angle_range;
    use crate::model::parse_machine;
    use std::path::Path;

    fn setup() -> (Machine, [Vec<f64>; 4]) {
        let m = parse_machine(
            Path::new("ac-trunnion.toml"),
            include_str!("../../../../../examples/machines/ac-trunnion.toml"),
        )
        .unwrap();
        let a = angle_range(-90.0, 90.0, 5.0);
        let c = angle_range(0.0, 360.0, 5.0);
        (m, [a.clone(), a, c.clone(), c])
    }

    #[test]
    fn reproduces_table_2_of_the_source_paper() {
        // Seed table 1: offsets 10 µm, tilts 0.005°.
        let (m, angles) = setup();
        let tilt = 0.005_f64.to_radians();
        let rows = sensitivity_table(&m, &Rig::source_paper(), 0.010, tilt, &angles).unwrap();
        for r in &rows {
            for mode in BallbarMode::ALL {
                let peak = r.peak[mode.index()];
                if sees(mode, r.pige) {
                    // First order: an offset moves ΔL by up to ~its size (a full sine or
                    // 1 − cos swing), a tilt by ~Z·tilt ≈ 8.7 µm.
                    assert!(peak > 5e-3, "{} must move {}: {peak}", r.pige, mode.label());
                } else {
                    // Blank in table 2: nothing beyond rounding and L·tilt² ~ 1e-6 mm.
                    assert!(
                        peak < 1e-6,
                        "{} must not move {}: {peak}",
                        r.pige,
                        mode.label()
                    );
                }
            }
        }
        // Tilts do not move modes 1 and 3 at all (B1 on both axis lines): exactly zero
        // but for rounding.
        for r in rows.iter().filter(|r| r.pige.is_tilt()) {
            assert!(r.peak[0] < 1e-12 && r.peak[2] < 1e-12, "{r:?}");
        }
    }

    #[test]
    fn ey0a_and_ey0c_act_identically_in_mode_three() {
        let (m, angles) = setup();
        let t = Trunnion::of(&m).unwrap();
        let mut a = Piges::default();
        a.set(Pige::EY0A, 0.01);
        let mut c = Piges::default();
        c.set(Pige::EY0C, 0.01);
        let ca = delta_l_curve(
            &m,
            &t,
            BallbarMode::Three,
            &Rig::source_paper(),
            &a,
            &angles[2],
        );
        let cc = delta_l_curve(
            &m,
            &t,
            BallbarMode::Three,
            &Rig::source_paper(),
            &c,
            &angles[2],
        );
        for (x, y) in ca.iter().zip(&cc) {
            assert!((x - y).abs() < 1e-12);
        }
        // And it is the sine of the first-order form, ΔL3 = 0.01·sin α, up to the
        // second-order 0.01²/(2·100) ≈ 5e-7 mm.
        for (al, x) in angles[2].iter().zip(&ca) {
            assert!((x - 0.01 * al.to_radians().sin()).abs() < 2e-6);
        }
    }
}

/// The inputs of [`run`]: the nominal machine and the rig geometry (its
/// set-up error is ignored: the table is for an ideal set-up).
#[derive(Debug, Clone, Copy)]
pub struct SensitivityInputs<'a> {
    /// The machine (a double turntable, A carrying C).
    pub machine: &'a Machine,
    /// Bar length and tool-ball placements (mm).
    pub rig: Rig,
}

/// Options of [`run`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct SensitivityOptions {
    /// Size of the offsets, mm (default 0.010).
    pub offset: f64,
    /// Size of the tilts, rad (default 0.005° = 8.7266e-5 rad).
    pub tilt: f64,
    /// Angles of each mode, degrees, in [`BallbarMode::ALL`] order (default
    /// −90…90° by 5° for the A modes 1 and 2, 0…360° by 5° for the C modes 3 and 4).
    pub angles_deg: [Vec<f64>; 4],
}

impl Default for SensitivityOptions {
    fn default() -> Self {
        Self {
            offset: 0.010,
            tilt: 0.005_f64.to_radians(),
            angles_deg: super::simulate::default_angles(),
        }
    }
}

/// `mtwin ballbar sensitivity`: which PIGE moves which mode, and by how
/// much ([`sensitivity_table`]), as its document.
pub fn run(
    inputs: &SensitivityInputs<'_>,
    options: &SensitivityOptions,
) -> Result<super::BallbarSensitivityDoc, TrunnionError> {
    let rows = sensitivity_table(
        inputs.machine,
        &inputs.rig,
        options.offset,
        options.tilt,
        &options.angles_deg,
    )?;
    Ok(super::BallbarSensitivityDoc::from(rows.as_slice()))
}
