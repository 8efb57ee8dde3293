//! ISO 230-4 circular test: G, H, F in closed form, and every diagnostic
//! recovered from traces simulated with known errors (displacement models,
//! exact radius, noise), one at a time and all together.

use mtwin::methods::ballbar::circular::{CircularDoc, CircularOptions, Trace, circular};
use mtwin::methods::ballbar::circular_sim::{CircularErrors, simulate_circular};

fn opts() -> CircularOptions {
    CircularOptions {
        radius_mm: 150.0,
        cyclic_pitch_mm: 10.0,
        spike_width_deg: 3.0,
    }
}

fn run(e: &CircularErrors, noise: f64) -> CircularDoc {
    let o = opts();
    let cw = simulate_circular(e, &o, false, 3600, noise, 7);
    let ccw = simulate_circular(e, &o, true, 3600, noise, 7);
    circular(Some(&cw), Some(&ccw), &o).unwrap()
}

fn within(got: Option<f64>, want: f64, what: &str) {
    let got = got.unwrap_or_else(|| panic!("{what} not reported"));
    let tol = (0.05 * want.abs()).max(0.5);
    assert!(
        (got - want).abs() <= tol,
        "{what}: {got} vs {want} (tolerance {tol})"
    );
}

fn check_all(d: &CircularDoc, e: &CircularErrors) {
    within(d.backlash_x_um, e.backlash_x_um, "backlash x");
    within(d.backlash_y_um, e.backlash_y_um, "backlash y");
    within(d.lateral_play_x_um, e.lateral_play_x_um, "lateral play x");
    within(d.lateral_play_y_um, e.lateral_play_y_um, "lateral play y");
    within(d.reversal_spike_x_um, e.reversal_spike_x_um, "spike x");
    within(d.reversal_spike_y_um, e.reversal_spike_y_um, "spike y");
    within(d.cyclic_error_x_um, e.cyclic_error_x_um.abs(), "cyclic x");
    within(d.cyclic_error_y_um, e.cyclic_error_y_um.abs(), "cyclic y");
    within(d.servo_mismatch_um, e.servo_mismatch_um, "servo mismatch");
    within(d.squareness_um_per_m, e.squareness_um_per_m, "squareness");
    within(d.straightness_x_um, e.straightness_x_um, "straightness x");
    within(d.straightness_y_um, e.straightness_y_um, "straightness y");
    within(d.scale_mismatch_um, e.scale_mismatch_um, "scale mismatch");
    within(d.centre_x_um, e.centre_x_um, "centre x");
    within(d.centre_y_um, e.centre_y_um, "centre y");
}

#[test]
fn each_diagnostic_alone_is_recovered() {
    type Set = Box<dyn Fn(&mut CircularErrors)>;
    let cases: Vec<(&str, Set)> = vec![
        ("backlash_x_um", Box::new(|e| e.backlash_x_um = 8.0)),
        ("backlash_y_um", Box::new(|e| e.backlash_y_um = -6.0)),
        ("lateral_play_x_um", Box::new(|e| e.lateral_play_x_um = 5.0)),
        ("lateral_play_y_um", Box::new(|e| e.lateral_play_y_um = 4.0)),
        (
            "reversal_spike_x_um",
            Box::new(|e| e.reversal_spike_x_um = 7.0),
        ),
        (
            "reversal_spike_y_um",
            Box::new(|e| e.reversal_spike_y_um = 9.0),
        ),
        ("cyclic_error_x_um", Box::new(|e| e.cyclic_error_x_um = 3.0)),
        ("cyclic_error_y_um", Box::new(|e| e.cyclic_error_y_um = 2.5)),
        (
            "servo_mismatch_um",
            Box::new(|e| e.servo_mismatch_um = 12.0),
        ),
        (
            "squareness_um_per_m",
            Box::new(|e| e.squareness_um_per_m = 40.0),
        ),
        ("straightness_x_um", Box::new(|e| e.straightness_x_um = 6.0)),
        (
            "straightness_y_um",
            Box::new(|e| e.straightness_y_um = -5.0),
        ),
        (
            "scale_mismatch_um",
            Box::new(|e| e.scale_mismatch_um = 10.0),
        ),
    ];
    for (name, set) in cases {
        let mut e = CircularErrors {
            cyclic_phase_deg: 30.0,
            ..Default::default()
        };
        set(&mut e);
        let d = run(&e, 0.2);
        check_all(&d, &e);
        assert!(d.inseparable.is_empty(), "{name}: {:?}", d.inseparable);
        // the largest fitted signature is the error put in
        assert_eq!(d.ranking[0].key, name, "ranking {:?}", d.ranking);
    }
}

#[test]
fn all_diagnostics_together_are_recovered() {
    let e = CircularErrors {
        backlash_x_um: 8.0,
        backlash_y_um: -6.0,
        lateral_play_x_um: 5.0,
        lateral_play_y_um: 4.0,
        reversal_spike_x_um: 7.0,
        reversal_spike_y_um: 9.0,
        cyclic_error_x_um: 3.0,
        cyclic_error_y_um: 2.5,
        cyclic_phase_deg: 30.0,
        servo_mismatch_um: 12.0,
        squareness_um_per_m: 40.0,
        straightness_x_um: 6.0,
        straightness_y_um: -5.0,
        scale_mismatch_um: 10.0,
        centre_x_um: 20.0,
        centre_y_um: -15.0,
        radius_offset_um: 3.0,
    };
    let d = run(&e, 0.3);
    check_all(&d, &e);
    assert!(d.residual_rms_um < 0.5, "residual {}", d.residual_rms_um);
}

#[test]
fn g_h_f_in_closed_form() {
    // Δr = 2 + 5 cos 2θ (ccw), 2 + 5 cos 2θ + 3 (cw): G = 10 each, H = 3, F = 10.
    let mk = |off: f64| Trace {
        angle_deg: (0..720).map(|k| k as f64 * 0.5).collect(),
        deviation_um: (0..720)
            .map(|k| 2.0 + off + 5.0 * (2.0 * (k as f64 * 0.5).to_radians()).cos())
            .collect(),
    };
    let d = circular(Some(&mk(3.0)), Some(&mk(0.0)), &opts()).unwrap();
    assert!((d.g_um - 10.0).abs() < 1e-9, "G {}", d.g_um);
    assert!((d.h_um.unwrap() - 3.0).abs() < 1e-9, "H {:?}", d.h_um);
    assert!((d.f_um - 10.0).abs() < 1e-9 && (d.f_min_um + 3.0).abs() < 1e-9);
}

#[test]
fn one_direction_reports_what_it_cannot_tell_apart() {
    let e = CircularErrors {
        squareness_um_per_m: 40.0,
        ..Default::default()
    };
    let o = opts();
    let ccw = simulate_circular(&e, &o, true, 3600, 0.1, 3);
    let d = circular(None, Some(&ccw), &o).unwrap();
    let flat: Vec<&str> = d.inseparable.iter().flatten().map(String::as_str).collect();
    assert!(
        flat.contains(&"servo_mismatch_um") && flat.contains(&"squareness_um_per_m"),
        "{:?}",
        d.inseparable
    );
    assert_eq!(d.squareness_um_per_m, None);
    assert_eq!(d.servo_mismatch_um, None);
    assert!(d.h_um.is_none());
}
