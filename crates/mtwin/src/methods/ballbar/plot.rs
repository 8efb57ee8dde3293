//! Polar plots of ΔL per mode (figure 11 of the source paper \[R1\]): the measured readings,
//! the fit of the identified model, and the prediction after compensating
//! the four axis-line offsets (the tilts remain).

use super::Pige;
use super::data::ModeData;
use super::identify::Identification;
use super::mode::{BallbarMode, predicted_reading};
use crate::report::svg::{Series, polar};

/// The SVG of `mode`: measured `ΔL = reading − ℓ`, fitted, and after
/// compensating EY0A, EZ0A, EX0C, EY0C (µm rings). `None` when the mode did
/// not take part.
pub fn polar_plot(id: &Identification, mode: BallbarMode, data: &ModeData) -> Option<String> {
    let ell = id.lengths[mode.index()]?;
    let measured: Vec<(f64, f64)> = data
        .angles_deg
        .iter()
        .zip(&data.lengths)
        .map(|(&a, &l)| (a, l - ell))
        .collect();
    let mut dense: Vec<f64> = Vec::new();
    let lo = data
        .angles_deg
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let hi = data
        .angles_deg
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let n = 360;
    for k in 0..=n {
        dense.push(lo + (hi - lo) * k as f64 / n as f64);
    }
    let fitted: Vec<(f64, f64)> = dense
        .iter()
        .map(|&a| (a, id.fitted_delta_l(mode, a).unwrap_or(f64::NAN)))
        .collect();
    let mut comp = id.machine.clone();
    let mut p = id.piges;
    for q in [Pige::EY0A, Pige::EZ0A, Pige::EX0C, Pige::EY0C] {
        p.set(q, 0.0);
    }
    p.write_to(&mut comp, &id.trunnion);
    let after: Vec<(f64, f64)> = dense
        .iter()
        .map(|&a| {
            (
                a,
                predicted_reading(&comp, &id.trunnion, mode, &id.rig, ell, a) - ell,
            )
        })
        .collect();
    let series = [
        Series {
            name: "measured ΔL".into(),
            points: measured,
            color: "#d62728".into(),
            markers: true,
        },
        Series {
            name: "fitted (identified PIGEs)".into(),
            points: fitted,
            color: "#1f77b4".into(),
            markers: false,
        },
        Series {
            name: "predicted after compensating the four offsets".into(),
            points: after,
            color: "#2ca02c".into(),
            markers: false,
        },
    ];
    Some(polar(
        &format!(
            "Ballbar {} ({} turns): ΔL = L(α) − ℓ",
            mode.label(),
            mode.axis_name()
        ),
        &series,
        "µm",
        1e3,
    ))
}
