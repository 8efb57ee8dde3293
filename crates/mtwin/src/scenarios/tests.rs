//! The scenarios against their known truths, and the demo document's JSON
//! round trip.

use super::*;
use crate::examples::machine;
use crate::gcode::InterpOptions;

/// `|identified − truth| ≤ k·σ` for a standard uncertainty σ.
fn within(what: &str, identified: f64, truth: f64, sigma: f64, k: f64) {
    assert!(sigma > 0.0 && sigma.is_finite(), "{what}: σ = {sigma}");
    assert!(
        (identified - truth).abs() <= k * sigma,
        "{what}: identified {identified}, truth {truth}, σ {sigma}"
    );
}

#[test]
fn first_feed_line_is_the_interpreters_first_feed_move() {
    let line = |p: &str| five_axis_twin::first_feed_line(p.as_bytes(), &InterpOptions::default());
    // A block number before G1; G1 packed against its words; G1 not the
    // first word; a modal continuation (no G word on the moving line).
    assert_eq!(line("G21 G90\nN10 G1 X1 F100\n").unwrap(), Some(2));
    assert_eq!(line("G0 X0\nG1X5F100\n").unwrap(), Some(2));
    assert_eq!(line("G0 X0\nG90 G01 X5 F100\n").unwrap(), Some(2));
    assert_eq!(
        line("G0 X0 Y0\nG1 F100 (set the mode)\nX5\nX6\n").unwrap(),
        Some(3)
    );
    // Arcs are feed moves; rapids, dwells and comments naming G1 are not.
    assert_eq!(
        line("G17 G0 X1 Y0\nG4 P1\nG2 X2 Y0 I0.5 J0 F100\n").unwrap(),
        Some(3)
    );
    assert_eq!(line("(G1 X5 is in a comment)\nG0 X1\nM30\n").unwrap(), None);
    // The bundled five-axis program cuts from its `G1 Z5 F1500`, line 8.
    let p = five_axis_compensation::S_CURVE_PROGRAM;
    let expected = p.lines().position(|l| l.starts_with("G1 Z5")).unwrap() as u64 + 1;
    assert_eq!(line(p).unwrap(), Some(expected));
    // A program the interpreter refuses is an error, not "no cut".
    assert!(line("G0 X0\nG1 X1 Q\n").is_err());
}

#[test]
fn spread_poses_are_the_halton_sequence_over_the_travels() {
    let m = machine("ac-trunnion").unwrap();
    let poses = volumetric_error::spread_poses(&m, 6);
    let at =
        |i: usize, r: f64| m.axes[i].travel[0] + r * (m.axes[i].travel[1] - m.axes[i].travel[0]);
    // Radical inverses: 1 → 1/2 (base 2), 1/3 (base 3); 2 → 1/4, 2/3;
    // 3 → 3/4; 6 in base 5 is 11 → 1/5 + 1/25.
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
    assert!(close(poses[0][0], at(0, 0.5)) && close(poses[0][1], at(1, 1.0 / 3.0)));
    assert!(close(poses[1][0], at(0, 0.25)) && close(poses[1][1], at(1, 2.0 / 3.0)));
    assert!(close(poses[2][0], at(0, 0.75)));
    assert!(close(poses[5][2], at(2, 0.24)));
    for q in &poses {
        for (a, v) in m.axes.iter().zip(q) {
            assert!(a.in_travel(*v));
        }
    }
}

#[test]
fn volumetric_error_is_zero_on_the_nominal_machine_and_ik_closes_it() {
    let opts = volumetric_error::Options {
        poses: 400,
        ik_poses: 50,
    };
    let nominal = volumetric_error::run(&machine("ac-trunnion").unwrap(), &opts).unwrap();
    assert_eq!(nominal.doc.poses, 400);
    assert!(
        nominal.doc.max_error_mm < 1e-12,
        "{}",
        nominal.doc.max_error_mm
    );
    assert!(nominal.doc.max_axis_error_rad < 1e-12);
    let real = volumetric_error::run(&machine("ac-trunnion-with-errors").unwrap(), &opts).unwrap();
    let d = &real.doc;
    assert!(d.max_error_mm > 0.01 && d.rms_error_mm <= d.max_error_mm);
    assert_eq!(d.ik_poses, 50);
    assert!(d.ik_max_error_mm < 1e-9, "{}", d.ik_max_error_mm);
    assert_eq!((d.axes, d.error_terms), (5, real.machine.n_error_terms()));
}

#[test]
fn trunnion_ballbar_recovers_the_eight_piges_within_their_uncertainty() {
    let run = trunnion_ballbar::run(
        &machine("ac-trunnion").unwrap(),
        &machine("ac-trunnion-with-errors").unwrap(),
        &Default::default(),
    )
    .unwrap();
    let d = &run.doc;
    assert_eq!(d.piges.len(), 8);
    for p in &d.piges {
        within(&p.name, p.identified, p.truth, p.uncertainty.unwrap(), 4.0);
    }
    // The truth's largest offset is what is identified before compensation;
    // after it, what is left is the noise (a few standard uncertainties).
    let offsets = |f: fn(&trunnion_ballbar::PigeCheckDoc) -> f64| {
        d.piges
            .iter()
            .filter(|p| ["EY0A", "EZ0A", "EX0C", "EY0C"].contains(&p.name.as_str()))
            .map(f)
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let sigma = d
        .piges
        .iter()
        .filter_map(|p| p.uncertainty)
        .fold(0.0, f64::max);
    assert!((d.largest_offset_before_mm - offsets(|p| p.truth)).abs() < 4.0 * sigma);
    assert!(d.largest_offset_after_mm < 4.0 * sigma);
    assert_eq!(d.readings, 2 * 37 + 2 * 73);
    assert!(d.largest_deviation_after_mm < d.largest_deviation_before_mm);
}

#[test]
fn skiving_setup_recovers_the_truth_within_its_uncertainty() {
    let opts = skiving_setup::Options::default();
    let run = skiving_setup::run(&opts).unwrap();
    let d = &run.doc;
    let u = d.uncertainty.unwrap();
    let t = opts.truth;
    within("dgx", d.dgx, t.dgx, u.dgx, 4.0);
    within("dgy", d.dgy, t.dgy, u.dgy, 4.0);
    within("exz", d.exz, t.exz, u.exz, 4.0);
    within("ezy", d.ezy, t.ezy, u.ezy, 4.0);
    assert_eq!(d.truth, t);
    assert_eq!(d.touches, 12);
}

#[test]
fn gantry_tracker_model_is_at_the_noise_on_the_body_diagonals() {
    let opts = gantry_tracker::Options::default();
    let run = gantry_tracker::run(
        &machine("afp-gantry-with-errors").unwrap(),
        &machine("afp-gantry").unwrap(),
        &opts,
    )
    .unwrap();
    let d = &run.doc;
    assert_eq!(d.diagonal_points, 4 * opts.per_diagonal);
    // Pure noise of σ per coordinate has a mean |Δp| of σ·2√(2/π) ≈ 1.6 σ:
    // the identified model is within twice that, the nominal far outside.
    let noise_mean = opts.noise * 2.0 * (2.0 / std::f64::consts::PI).sqrt();
    assert!(
        d.diagonal_mean_mm[1] < 2.0 * noise_mean,
        "{:?}",
        d.diagonal_mean_mm
    );
    assert!(
        d.diagonal_mean_mm[0] > 5.0 * noise_mean,
        "{:?}",
        d.diagonal_mean_mm
    );
    let change = 100.0 * (d.diagonal_mean_mm[1] / d.diagonal_mean_mm[0] - 1.0);
    assert!((change - d.diagonal_change_mean_percent).abs() < 1e-9);
    assert_eq!(d.poses, opts.poses);
}

#[test]
fn thermal_faces_program_and_compensation() {
    let run = thermal_faces::run(&Default::default()).unwrap();
    let d = &run.doc;
    // The program: 4 header blocks, two faces of 43, 5 speed steps with a
    // dwell each, the speed back, 3 closing blocks.
    assert_eq!(run.program.lines().count(), 104);
    assert_eq!(d.program_blocks, 104);
    // An hour of dwells plus two faces of 4100 mm at F2000 and a 55 mm
    // plunge at F500, plus the rapids.
    let cutting = 60.0 + 2.0 * (4100.0 / 2000.0 + 55.0 / 500.0);
    assert!(d.program_minutes > cutting && d.program_minutes < cutting + 0.1);
    assert!(d.face_difference_compensated_mm < 0.5 * d.face_difference_mm);
    assert_eq!((d.heights, d.runs), (4, 3));
}

#[test]
fn sine_sweep_follows_its_closed_form_phase() {
    let (ts, n, f0, f1, amp) = (0.001, 4000, 0.5, 8.0, 20.0);
    let s = servo_identification::sine_sweep(ts, n, f0, f1, amp);
    assert_eq!(s.len(), n);
    for k in [0usize, 1, 999, 2500, 3999] {
        let kf = k as f64;
        let phase = 2.0
            * std::f64::consts::PI
            * ts
            * ((kf + 1.0) * f0 + (f1 - f0) / n as f64 * kf * (kf + 1.0) / 2.0);
        assert!((s[k] - amp * phase.sin()).abs() < 1e-9, "sample {k}");
    }
}

/// Every scenario on the demo's inputs; the servos against the closed-form
/// lag of a unit-gain double pole with one sample of delay,
/// `ts·(1 + 2p/(1 − p))`; the twin's geometric part compensated to the
/// compensation's tolerance; the demo document through JSON and back.
#[test]
fn demo_scenarios_recover_their_truths_and_the_doc_round_trips() {
    let trunnion = machine("ac-trunnion").unwrap();
    let errors = machine("ac-trunnion-with-errors").unwrap();
    let servo_opts = servo_identification::Options::default();
    let servo = servo_identification::run(&errors, &servo_opts).unwrap();
    for (k, a) in servo.doc.axis.iter().enumerate() {
        let p = servo_opts.poles[k];
        let lag = servo_opts.ts * (1.0 + 2.0 * p / (1.0 - p));
        assert!((a.true_velocity_lag_s - lag).abs() < 1e-12, "{}", a.axis);
        assert!((a.velocity_lag_s.unwrap() - lag).abs() < 1e-6, "{}", a.axis);
        assert!(servo.twin.axes[k].servo.is_some());
    }
    let comp_opts = five_axis_compensation::Options::default();
    let compensate = five_axis_compensation::run(
        &errors,
        "s-curve-5axis.ngc",
        five_axis_compensation::S_CURVE_PROGRAM.as_bytes(),
        &comp_opts,
    )
    .unwrap();
    let twin = five_axis_twin::run(
        &servo.twin,
        five_axis_compensation::S_CURVE_PROGRAM.as_bytes(),
        &compensate.output,
    )
    .unwrap();
    let t = &twin.doc;
    // The geometric error left while cutting is within the compensation's
    // tolerance (twice, for the nearest-point search between samples).
    assert!(t.geometry_only.compensated.tip_error_max < 2.0 * comp_opts.compensate.tol);
    assert!(t.geometry_only.original.tip_error_max > 10.0 * comp_opts.compensate.tol);
    // Samples at k·ts: those before the cut are t_cut/ts.
    assert_eq!(
        t.samples - t.cutting_samples,
        (t.cutting_from_s / t.sample_period_s).round() as usize
    );
    // Positioning: the table equals the truth EXX at the targets within the
    // noise of a mean of 10 readings (0.5 µm / √10, 5σ).
    let positioning = axis_positioning::run(&errors, &trunnion, &Default::default()).unwrap();
    let p = &positioning.doc;
    assert_eq!(p.error, "EXX");
    assert!(p.largest_table_error_um < 5.0 * 0.5 / 10f64.sqrt(), "{p:?}");
    assert!(p.largest_truth_um > 5.0, "{p:?}");
    // Reversal B within 5σ of the 4 µm simulated (σ of a difference of two means of 5).
    assert!(
        (p.b_um - 4.0).abs() < 5.0 * 0.5 * (0.4f64).sqrt() + 0.5,
        "{p:?}"
    );
    // Circular test through the identified servos: each diagnostic within 5 % or 0.5 µm.
    let circ = circular_test::run(&servo.twin, &trunnion, &Default::default()).unwrap();
    for r in &circ.doc.recovered {
        let v = r.value.unwrap_or_else(|| panic!("{} not separable", r.key));
        assert!(
            (v - r.truth).abs() <= (0.05 * r.truth.abs()).max(0.5),
            "{}: {v} vs {}",
            r.key,
            r.truth
        );
    }
    assert_eq!(circ.doc.model_changes.len(), 3);
    let doc = DemoDoc {
        ballbar: trunnion_ballbar::run(&trunnion, &errors, &Default::default())
            .unwrap()
            .doc,
        circular: circ.doc,
        positioning: positioning.doc,
        compensate: compensate.doc,
        machine: volumetric_error::run(
            &errors,
            &volumetric_error::Options {
                poses: 100,
                ik_poses: 10,
            },
        )
        .unwrap()
        .doc,
        report: "out/report.html".into(),
        seconds: 1.5,
        servo: servo.doc,
        skiving: skiving_setup::run(&Default::default()).unwrap().doc,
        thermal: thermal_faces::run(&Default::default()).unwrap().doc,
        tracker: gantry_tracker::run(
            &machine("afp-gantry-with-errors").unwrap(),
            &machine("afp-gantry").unwrap(),
            &Default::default(),
        )
        .unwrap()
        .doc,
        twin: twin.doc,
    };
    let json = serde_json::to_string(&doc).unwrap();
    let back: DemoDoc = serde_json::from_str(&json).unwrap();
    assert_eq!(back, doc);
    // The keys of the demo's JSON before the documents were typed stay.
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    for (step, key) in [
        ("ballbar", "largest_offset_after_mm"),
        ("compensate", "blocks_changed"),
        ("compensate", "out"),
        ("machine", "ik_max_error_mm"),
        ("servo", "largest_velocity_lag_error_s"),
        ("skiving", "truth"),
        ("thermal", "face_difference_compensated_mm"),
        ("tracker", "diagonal_change_mean_percent"),
        ("twin", "geometry_only"),
        ("positioning", "largest_table_error_um"),
        ("circular", "recovered"),
    ] {
        assert!(v[step].get(key).is_some(), "{step}.{key}");
        assert!(v[step]["seconds"].is_number(), "{step}.seconds");
    }
    // The printed summary: the heading, ten numbered steps, the report.
    let text = doc.to_string();
    assert!(text.starts_with(DEMO_HEADING));
    for k in 1..=10 {
        assert!(text.contains(&format!("\n{k}. ")), "step {k}");
    }
    assert!(text.ends_with("report → out/report.html\n"));
}
