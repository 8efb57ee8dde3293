//! ISO 230-4 circular test: G, H, F in closed form, and every diagnostic
//! recovered from traces simulated with known errors (displacement models,
//! exact radius, noise), one at a time and all together.

use mtwin::methods::ballbar::circular::{CircularDoc, CircularOptions, Plane, Trace, circular};
use mtwin::methods::ballbar::circular_sim::{CircularErrors, simulate_circular};

fn opts() -> CircularOptions {
    CircularOptions {
        radius_mm: 150.0,
        cyclic_pitch_mm: 10.0,
        spike_width_deg: 3.0,
        plane: Plane::Xy,
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
    within(d.get("backlash_x_um"), e.backlash_x_um, "backlash x");
    within(d.get("backlash_y_um"), e.backlash_y_um, "backlash y");
    within(
        d.get("lateral_play_x_um"),
        e.lateral_play_x_um,
        "lateral play x",
    );
    within(
        d.get("lateral_play_y_um"),
        e.lateral_play_y_um,
        "lateral play y",
    );
    within(
        d.get("reversal_spike_x_um"),
        e.reversal_spike_x_um,
        "spike x",
    );
    within(
        d.get("reversal_spike_y_um"),
        e.reversal_spike_y_um,
        "spike y",
    );
    within(
        d.get("cyclic_error_x_um"),
        e.cyclic_error_x_um.abs(),
        "cyclic x",
    );
    within(
        d.get("cyclic_error_y_um"),
        e.cyclic_error_y_um.abs(),
        "cyclic y",
    );
    within(
        d.get("servo_mismatch_um"),
        e.servo_mismatch_um,
        "servo mismatch",
    );
    within(
        d.get("squareness_um_per_m"),
        e.squareness_um_per_m,
        "squareness",
    );
    within(
        d.get("straightness_x_um"),
        e.straightness_x_um,
        "straightness x",
    );
    within(
        d.get("straightness_y_um"),
        e.straightness_y_um,
        "straightness y",
    );
    within(
        d.get("scale_mismatch_um"),
        e.scale_mismatch_um,
        "scale mismatch",
    );
    within(d.get("centre_x_um"), e.centre_x_um, "centre x");
    within(d.get("centre_y_um"), e.centre_y_um, "centre y");
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
        servos: None,
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
    assert_eq!(d.get("squareness_um_per_m"), None);
    assert_eq!(d.get("servo_mismatch_um"), None);
    assert!(d.h_um.is_none());
}

#[test]
fn the_plane_names_the_axes_of_the_keys() {
    let e = CircularErrors {
        backlash_x_um: 8.0,
        straightness_y_um: -5.0,
        ..Default::default()
    };
    for (plane, first, second) in [
        (Plane::Xy, "x", "y"),
        (Plane::Yz, "y", "z"),
        (Plane::Zx, "z", "x"),
    ] {
        let o = CircularOptions { plane, ..opts() };
        let cw = simulate_circular(&e, &o, false, 3600, 0.2, 7);
        let ccw = simulate_circular(&e, &o, true, 3600, 0.2, 7);
        let d = circular(Some(&cw), Some(&ccw), &o).unwrap();
        let v = serde_json::to_value(&d).unwrap();
        let key = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
        assert!((key(&format!("backlash_{first}_um")) - 8.0).abs() < 0.5);
        assert!((key(&format!("straightness_{second}_um")) + 5.0).abs() < 0.5);
        assert!(key(&format!("backlash_{second}_um")).abs() < 0.5);
        assert_eq!(v["plane"], plane.as_str());
        // the third axis's letter names no diagnostic
        let third = ["x", "y", "z"]
            .into_iter()
            .find(|l| *l != first && *l != second)
            .unwrap();
        assert!(
            v.as_object()
                .unwrap()
                .keys()
                .all(|k| !k.contains(&format!("_{third}_"))),
            "{v}"
        );
        assert_eq!(d.ranking[0].key, format!("backlash_{first}_um"));
        // the document reads back
        let back: CircularDoc = serde_json::from_value(v).unwrap();
        assert_eq!(back, d);
    }
}

/// Squareness α and scale mismatch k measured in each plane into the
/// nominal AC trunnion (tool chain Y → X → Z): closed forms of the location
/// rotation (first order: a rotation γ of the farther axis about the normal
/// gives the ballbar signature of α = ±γ, sign by the plane) and of the
/// slopes (the mismatch is the difference of the two slopes times R).
#[test]
fn squareness_and_scale_mismatch_into_the_machine_model() {
    use mtwin::methods::ballbar::circular_model::{model_signature, update_machine};
    use mtwin::model::{Component, ErrorFunction};
    let machine = mtwin::examples::machine("ac-trunnion").unwrap();
    let (alpha, k) = (40.0, 10.0);
    let e = CircularErrors {
        squareness_um_per_m: alpha,
        scale_mismatch_um: k,
        backlash_x_um: 6.0,
        servo_mismatch_um: 5.0,
        ..Default::default()
    };
    let slope = |m: &mtwin::model::Machine, axis: &str, c: Component| -> f64 {
        let ax = &m.axes[m.axis_index(axis).unwrap()];
        match ax.errors.pdge[c.index()].as_ref() {
            Some(ErrorFunction::Poly(p)) => p[1],
            f => panic!("{axis}: {f:?}"),
        }
    };
    // (plane, axis rotated, its normal component, sign of γ against α, first, second axis)
    for (plane, rot, normal, sign, a, b) in [
        (
            Plane::Xy,
            "X",
            Component::Rz,
            1.0,
            ("X", Component::Tx),
            ("Y", Component::Ty),
        ),
        (
            Plane::Yz,
            "Z",
            Component::Rx,
            -1.0,
            ("Y", Component::Ty),
            ("Z", Component::Tz),
        ),
        (
            Plane::Zx,
            "Z",
            Component::Ry,
            1.0,
            ("Z", Component::Tz),
            ("X", Component::Tx),
        ),
    ] {
        let o = CircularOptions { plane, ..opts() };
        let cw = simulate_circular(&e, &o, false, 3600, 0.2, 11);
        let ccw = simulate_circular(&e, &o, true, 3600, 0.2, 11);
        let d = circular(Some(&cw), Some(&ccw), &o).unwrap();
        let (m, changes) = update_machine(&machine, &d).unwrap();
        assert_eq!(changes.len(), 3, "{changes:?}");
        let gamma = m.axes[m.axis_index(rot).unwrap()].errors.location[normal.index()];
        let want = sign * alpha * 1e-6;
        assert!(
            (gamma - want).abs() <= 0.05 * want.abs(),
            "{plane:?}: {gamma} vs {want}"
        );
        let (ca, cb) = (slope(&m, a.0, a.1), slope(&m, b.0, b.1));
        let want_diff = k * 1e-3 / o.radius_mm;
        assert!(
            ((ca - cb) - want_diff).abs() <= 0.05 * want_diff,
            "{plane:?}: {ca} − {cb} vs {want_diff}"
        );
        // no common scale: (ca + cb)/2 is the scale the ballbar cannot see
        assert!((ca + cb).abs() < 1e-3 * want_diff, "{plane:?}: {ca} + {cb}");
        // the updated model's own circular test shows what was measured
        let (sq, km, _) = model_signature(&m, plane, o.radius_mm).unwrap();
        assert!((sq - d.get("squareness_um_per_m").unwrap()).abs() < 1e-6 * alpha);
        assert!((km - d.get("scale_mismatch_um").unwrap()).abs() < 1e-6 * k);
        assert!(m.validate().is_ok());
    }
    // one direction: squareness is not separable, nothing is guessed
    let o = opts();
    let ccw = simulate_circular(&e, &o, true, 3600, 0.2, 11);
    let d = circular(None, Some(&ccw), &o).unwrap();
    let err = update_machine(&machine, &d).unwrap_err();
    assert!(err.contains("not separable"), "{err}");
    // a circle larger than the travel
    let big = CircularOptions {
        radius_mm: 400.0,
        ..opts()
    };
    let cw = simulate_circular(&e, &big, false, 3600, 0.2, 11);
    let ccw = simulate_circular(&e, &big, true, 3600, 0.2, 11);
    let d = circular(Some(&cw), Some(&ccw), &big).unwrap();
    let err = update_machine(&machine, &d).unwrap_err();
    assert!(err.contains("does not fit"), "{err}");
}

/// A first-order lag of time constant `tau` (s) sampled at `ts`: `y(k) = p·y(k−1)
/// + (1 − p)·u(k−1)`, `p = exp(−ts/tau)`.
fn first_order(tau: f64, ts: f64) -> mtwin::sysid::Servo {
    let p = (-ts / tau).exp();
    mtwin::sysid::Servo::new(ts, vec![0.0, 1.0 - p], vec![1.0, -p], 0).unwrap()
}

/// Servo mismatch from two servo models: the diagnostic equals the mismatch
/// the two lags imply at that feed and radius. Closed form: on a circle of
/// angular speed ω = v/R each axis follows its command with the phase lag
/// φ = −arg H(e^{jωts}), H(z) = (1 − p)z⁻¹/(1 − p z⁻¹); the first axis
/// lagging the second by φ₁ − φ₂ puts the point R·(φ₁ − φ₂) behind along the
/// path: the servo mismatch m. For small ω·τ, m ≈ v·(τ₁ − τ₂) (plus ts/2 of
/// each discrete lag, common to both).
#[test]
fn servo_models_give_the_servo_mismatch_of_their_lags() {
    use mtwin::methods::ballbar::circular_sim::ServoPair;
    let ts = 0.001;
    let (feed, r) = (2000.0, 150.0);
    let v = feed / 60.0;
    let omega = v / r;
    let phase_lag = |tau: f64| {
        let p: f64 = (-ts / tau).exp();
        let w = omega * ts;
        // arg H = −w − arg(1 − p e^{−jw})
        let (re, im) = (1.0 - p * w.cos(), p * w.sin());
        w + im.atan2(re)
    };
    for (tau1, tau2) in [(0.012, 0.0123), (0.015, 0.010), (0.008, 0.008)] {
        let e = CircularErrors {
            servos: Some(ServoPair {
                first: first_order(tau1, ts),
                second: first_order(tau2, ts),
                feed_mm_min: feed,
            }),
            ..Default::default()
        };
        let o = opts();
        let cw = simulate_circular(&e, &o, false, 3600, 0.1, 5);
        let ccw = simulate_circular(&e, &o, true, 3600, 0.1, 5);
        let d = circular(Some(&cw), Some(&ccw), &o).unwrap();
        let want = r * 1e3 * (phase_lag(tau1) - phase_lag(tau2));
        let approx = v * 1e3 * (tau1 - tau2);
        assert!(
            (want - approx).abs() < 0.01 * approx.abs().max(1.0),
            "closed forms: {want} vs {approx}"
        );
        within(d.get("servo_mismatch_um"), want, "servo mismatch");
        within(d.get("squareness_um_per_m"), 0.0, "squareness");
    }
}

/// Scale mismatch from two servo models of different lags (closed form of
/// `circular_sim::servo_signature`, recomputed here from the discrete
/// first-order lag): on a circle at ω = v/R each axis follows its command
/// through `H(e^{jw}) = (1 − p)e^{−jw}/(1 − p e^{−jw})`, `w = ω·ts`; the
/// diagnosis sees `k = R·Re(H₁² − H₂²)/(2√μ)`, `μ = (|H₁|² + |H₂|²)/2`. The
/// radius difference of the axes alone, `R·(|H₁| − |H₂|)`, is about a third
/// of it and fails the check.
#[test]
fn servo_models_give_the_scale_mismatch_of_their_gains_and_phases() {
    use mtwin::methods::ballbar::circular_sim::{ServoPair, servo_signature};
    let ts = 0.001;
    let (feed, r) = (6000.0, 50.0);
    let omega = feed / 60.0 / r;
    let h = |tau: f64| {
        let p: f64 = (-ts / tau).exp();
        let w = omega * ts;
        let (c, s) = (w.cos(), w.sin());
        // (1 − p)(c − i s) / (1 − p c + i p s)
        let (nr, ni) = ((1.0 - p) * c, -(1.0 - p) * s);
        let (dr, di) = (1.0 - p * c, p * s);
        let den = dr * dr + di * di;
        ((nr * dr + ni * di) / den, (ni * dr - nr * di) / den)
    };
    let o = CircularOptions {
        radius_mm: r,
        ..opts()
    };
    for (tau1, tau2) in [(0.012, 0.008), (0.006, 0.014)] {
        let ((a1, b1), (a2, b2)) = (h(tau1), h(tau2));
        let re_d = (a1 * a1 - b1 * b1) - (a2 * a2 - b2 * b2);
        let mu = 0.5 * (a1 * a1 + b1 * b1 + a2 * a2 + b2 * b2);
        let want = r * 1e3 * re_d / (2.0 * mu.sqrt());
        let pair = ServoPair {
            first: first_order(tau1, ts),
            second: first_order(tau2, ts),
            feed_mm_min: feed,
        };
        let sig = servo_signature(&pair, r);
        assert!(
            (sig.scale_mismatch_um - want).abs() < 1e-9 * want.abs(),
            "{sig:?} vs {want}"
        );
        // the continuous first-order form with τ + ts/2 (the hold's delay)
        let cont = |tau: f64| {
            let u: f64 = omega * (tau + ts / 2.0);
            (1.0 - u * u) / (1.0 + u * u).powi(2)
        };
        let approx = r * 1e3 * (cont(tau1) - cont(tau2)) / 2.0;
        assert!(
            (approx - want).abs() < 0.02 * want.abs(),
            "{approx} vs {want}"
        );
        let e = CircularErrors {
            servos: Some(pair),
            ..Default::default()
        };
        let cw = simulate_circular(&e, &o, false, 3600, 0.1, 9);
        let ccw = simulate_circular(&e, &o, true, 3600, 0.1, 9);
        let d = circular(Some(&cw), Some(&ccw), &o).unwrap();
        assert!(want.abs() > 10.0, "a scale effect to see: {want}");
        within(d.get("scale_mismatch_um"), want, "scale mismatch");
        within(
            d.get("servo_mismatch_um"),
            sig.servo_mismatch_um,
            "servo mismatch",
        );
        // the amplitude ratios alone are not it
        let amp = r * 1e3 * ((a1 * a1 + b1 * b1).sqrt() - (a2 * a2 + b2 * b2).sqrt());
        let got = d.get("scale_mismatch_um").unwrap();
        assert!((got - amp).abs() > 0.5 * amp.abs(), "{got} vs {amp}");
    }
}
