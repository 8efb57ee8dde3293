//! Servo section (\[R5\]) from the JSON of `mtwin servo fit --format json`
//! (one document per axis): transfer function, orders, bandwidth, velocity lag.

use super::fmt;
use crate::report::html::{Block, Section, Table, Verdict};
use crate::sysid::ServoFitDoc;

/// The servo section from `(axis name, servo fit JSON)` pairs.
pub fn section(fits: &[(String, ServoFitDoc)]) -> Section {
    let mut s = Section::new("servo", "Servo: axis transfer functions");
    s.push(Block::Text(
        "Discrete transfer function from command to encoder position per axis, \
         y(k) = −Σ a_i·y(k−i) + Σ b_j·u(k−j−nk): fitted by least squares (ARX), refined on the \
         simulation error (output error, which encoder noise does not bias), orders chosen by an \
         information criterion on the simulation error."
            .into(),
    ));
    let mut t = Table::new(
        "Identified servos",
        &[
            "axis",
            "ts (s)",
            "na, nb, nk",
            "simulation RMS (µm or mdeg)",
            "bandwidth (Hz)",
            "velocity lag (ms)",
            "static gain",
            "stable",
        ],
    );
    let mut warnings = Vec::new();
    for (axis, v) in fits {
        let na = v.a.len().saturating_sub(1);
        let nb = v.b.len().saturating_sub(1);
        let stable = v.stable;
        for w in &v.warnings {
            warnings.push(format!("{axis}: {w}"));
        }
        if !stable {
            warnings.push(format!("{axis}: the model is unstable"));
        }
        t.row(vec![
            axis.clone(),
            fmt(Some(v.ts), 4),
            format!("{na}, {nb}, {}", v.nk),
            fmt(Some(v.simulation_rms * 1e3), 3),
            fmt(v.bandwidth_hz, 1),
            fmt(v.velocity_lag_s.map(|l| l * 1e3), 3),
            fmt(Some(v.dc_gain), 4),
            if stable { "yes" } else { "no" }.into(),
        ]);
    }
    s.push(Block::Table(t));
    s.push(Block::Verdict {
        verdict: if warnings.is_empty() {
            Verdict::Good
        } else {
            Verdict::Caution
        },
        title: if warnings.is_empty() {
            "Every servo model is stable and reaches a held command.".into()
        } else {
            "Servo models with reservations:".into()
        },
        lines: warnings,
    });
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orders_come_from_the_polynomial_lengths() {
        let v = serde_json::json!({"ts": 0.001, "b": [0.1, 0.05], "a": [1.0, -0.85], "nk": 1,
            "simulation_rms": 2e-4, "bandwidth_hz": 30.0, "velocity_lag_s": 0.004, "dc_gain": 1.0,
            "stable": true, "warnings": [], "criterion": "aic", "estimator": "output_error",
            "following_error_at_max_velocity": 0.001, "grid": [], "max_velocity": 100.0,
            "one_step_rms": 1e-5, "orders": {"na": 1, "nb": [1], "nk": [1]}, "samples": 1000,
            "spectral_radius": 0.85});
        let doc: ServoFitDoc = serde_json::from_value(v).unwrap();
        let s = section(&[("X".into(), doc)]);
        let Block::Table(t) = &s.blocks[1] else {
            panic!()
        };
        assert_eq!(t.rows[0][2], "1, 1, 1");
        assert_eq!(t.rows[0][3], "0.200");
        assert_eq!(t.rows[0][5], "4.000");
    }
}
