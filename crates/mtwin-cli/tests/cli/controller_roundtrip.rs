//! Export → import round trips of the controller tables, within the error of
//! linear interpolation between table points, and the residual of tables
//! that carry every error of a model.
//!
//! The bound is derived independently of the code: linear interpolation of a
//! function `e` between points `h` apart is off by at most `h²/8·max|e''|`.
//! For a cubic `c0 + c1 q + c2 q² + c3 q³` on `[lo, hi]`, `|e''| = |2 c2 + 6 c3 q|`
//! is largest at an end of the range. Files round numbers to 1e-9 mm and
//! 1e-12 rad, which the tolerance adds.

use mtwin::controller::{self, ExportOptions, Format, ResidualOptions, isg_csv, linuxcnc_comp};
use mtwin::model::{AxisKind, Component, ErrorFunction, ErrorName, Machine};

/// Interpolation bound of cubic `c` over `travel` with spacing `h`.
fn bound(c: &[f64; 4], travel: [f64; 2], h: f64) -> f64 {
    let e2 = |q: f64| (2.0 * c[2] + 6.0 * c[3] * q).abs();
    h * h / 8.0 * e2(travel[0]).max(e2(travel[1]))
}

/// The AC trunnion with cubic PDGEs on every axis and some location errors.
fn model() -> (Machine, Vec<(ErrorName, [f64; 4])>) {
    let mut m = mtwin::examples::machine("ac-trunnion").unwrap();
    let mut cubics = Vec::new();
    for (k, ax) in m.axes.clone().iter().enumerate() {
        for c in Component::ALL {
            // Sizes: ~10 µm over the travel, ~20 µrad for rotations.
            let span = (ax.travel[1] - ax.travel[0]) / 2.0;
            let s = if c.is_rotation() { 2e-5 } else { 1e-2 };
            let w = 1.0 + 0.1 * (k * 6 + c.index()) as f64;
            let coeffs = [
                0.1 * s * w,
                0.3 * s / span,
                -0.5 * s * w / (span * span),
                0.4 * s / (span * span * span),
            ];
            m.axes[k].errors.pdge[c.index()] = Some(ErrorFunction::Poly(coeffs.to_vec()));
            cubics.push((ErrorName::pdge(c, &ax.name), coeffs));
        }
    }
    let set = |m: &mut Machine, n: &str, v: f64| {
        let n: ErrorName = n.parse().unwrap();
        let i = m.axis_index(&n.axis).unwrap();
        m.axes[i].errors.location[n.component.index()] = v;
    };
    set(&mut m, "EY0A", 0.021);
    set(&mut m, "EZ0A", -0.017);
    set(&mut m, "EB0A", 8.7e-5);
    set(&mut m, "EX0C", 0.014);
    set(&mut m, "EC0Y", 3.2e-5);
    (m, cubics)
}

fn write_all(dir: &std::path::Path, files: &[(String, String)]) {
    for (n, t) in files {
        std::fs::write(dir.join(n), t).unwrap();
    }
}

fn volumetric_round_trip(format: Format) {
    let (m, cubics) = model();
    let h_mm = 20.0;
    let h_deg = 10.0;
    let opts = ExportOptions {
        spacing_mm: Some(h_mm),
        spacing_deg: Some(h_deg),
        ..Default::default()
    };
    let e = controller::export(&m, format, &opts).unwrap();
    assert!(e.dropped.is_empty());
    let dir = tempfile::tempdir().unwrap();
    write_all(dir.path(), &e.files);
    let back = isg_csv::import(&dir.path().join(isg_csv::LIS_FILE), &m.nominal()).unwrap();
    for (name, c) in &cubics {
        let ax = &m.axes[m.axis_index(&name.axis).unwrap()];
        let h = if ax.kind == AxisKind::Linear {
            h_mm
        } else {
            h_deg
        };
        let tol = bound(c, ax.travel, h)
            + if name.component.is_rotation() {
                1e-12
            } else {
                1e-9
            };
        let mut worst: f64 = 0.0;
        for k in 0..=997 {
            let q = ax.travel[0] + (ax.travel[1] - ax.travel[0]) * k as f64 / 997.0;
            let d = (back.error_value(name, q).unwrap() - m.error_value(name, q).unwrap()).abs();
            worst = worst.max(d);
        }
        assert!(worst <= tol, "{format:?} {name}: {worst:e} > {tol:e}");
        // And the tables are not trivially exact: a cubic leaves a visible error.
        assert!(worst > 0.0, "{name}");
    }
    for ax in &m.axes {
        for c in Component::ALL {
            assert_eq!(
                back.axes[back.axis_index(&ax.name).unwrap()]
                    .errors
                    .location[c.index()],
                ax.errors.location[c.index()],
                "E{}0{}",
                c.letter(),
                ax.name
            );
        }
    }
}

#[test]
fn isg_round_trip_within_interpolation_bound() {
    volumetric_round_trip(Format::Isg);
}

#[test]
fn etalon_round_trip_within_interpolation_bound() {
    volumetric_round_trip(Format::Etalon);
}

/// Positioning errors only (EXX, EYY, EZZ cubic): the per-axis formats carry
/// them completely.
fn positioning_model() -> (Machine, Vec<(ErrorName, [f64; 4])>) {
    let mut m = mtwin::examples::machine("ac-trunnion").unwrap();
    let mut cubics = Vec::new();
    for (n, c) in [
        ("EXX", [0.002, 1e-5, -4e-8, 6e-11]),
        ("EYY", [-0.001, -2e-5, 5e-8, 3e-11]),
        ("EZZ", [0.0, 8e-6, 3e-8, -5e-11]),
    ] {
        let n: ErrorName = n.parse().unwrap();
        let i = m.axis_index(&n.axis).unwrap();
        m.axes[i].errors.pdge[n.component.index()] = Some(ErrorFunction::Poly(c.to_vec()));
        cubics.push((n, c));
    }
    (m, cubics)
}

#[test]
fn linuxcnc_round_trip_within_interpolation_bound() {
    let (m, cubics) = positioning_model();
    let h = 15.0;
    let opts = ExportOptions {
        spacing_mm: Some(h),
        ..Default::default()
    };
    let e = controller::export(&m, Format::LinuxCnc, &opts).unwrap();
    assert!(e.dropped.is_empty(), "{:?}", e.dropped);
    let names: Vec<&str> = e.files.iter().map(|f| f.0.as_str()).collect();
    assert_eq!(
        names,
        [
            "comp_X.txt",
            "comp_Y.txt",
            "comp_Z.txt",
            "kinematics.hal",
            "README.txt"
        ]
    );
    let dir = tempfile::tempdir().unwrap();
    write_all(dir.path(), &e.files);
    let back = linuxcnc_comp::import(dir.path(), &m.nominal()).unwrap();
    for (name, c) in &cubics {
        let ax = &m.axes[m.axis_index(&name.axis).unwrap()];
        let tol = bound(c, ax.travel, h) + 1e-9;
        for k in 0..=500 {
            let q = ax.travel[0] + (ax.travel[1] - ax.travel[0]) * k as f64 / 500.0;
            let d = (back.error_value(name, q).unwrap() - m.error_value(name, q).unwrap()).abs();
            assert!(d <= tol, "{name} at {q}: {d:e} > {tol:e}");
        }
    }
    // The residual of the tables on the machine is within the same bound
    // (three axes, each off by at most its bound), the uncompensated error
    // is not.
    let r = controller::residual(&m, &e.correction, &ResidualOptions::default());
    let total: f64 = cubics
        .iter()
        .map(|(n, c)| bound(c, m.axes[m.axis_index(&n.axis).unwrap()].travel, h) + 1e-9)
        .map(|b| b * b)
        .sum::<f64>()
        .sqrt();
    assert!(
        r.max_um <= total * 1000.0,
        "{} µm > {} µm",
        r.max_um,
        total * 1000.0
    );
    assert!(r.uncompensated_max_um > 10.0, "{}", r.uncompensated_max_um);
    assert!(r.full_model_max_um < 1e-3, "{}", r.full_model_max_um);
    // Siemens EEC carries the same.
    let eec = controller::export(&m, Format::SiemensEec, &opts).unwrap();
    let r_eec = controller::residual(&m, &eec.correction, &ResidualOptions::default());
    assert!(r_eec.max_um <= total * 1000.0 + 1e-3, "{}", r_eec.max_um);
}

#[test]
fn volumetric_residual_is_within_the_interpolation_bound() {
    // A machine with positioning errors only, on a grid that puts the
    // evaluation points between table points: the tip error left by the
    // ISG tables is the interpolation error of the three axes.
    let (m, cubics) = positioning_model();
    let h = 40.0;
    let opts = ExportOptions {
        spacing_mm: Some(h),
        ..Default::default()
    };
    let e = controller::export(&m, Format::Isg, &opts).unwrap();
    let r = controller::residual(&m, &e.correction, &ResidualOptions::default());
    let total: f64 = cubics
        .iter()
        .map(|(n, c)| bound(c, m.axes[m.axis_index(&n.axis).unwrap()].travel, h))
        .map(|b| b * b)
        .sum::<f64>()
        .sqrt();
    assert!(
        r.max_um <= total * 1000.0 * 1.001 + 1e-3,
        "{} > {}",
        r.max_um,
        total * 1000.0
    );
    assert!(r.max_um < r.uncompensated_max_um / 10.0);
}

/// Siemens EEC: export → import gives back the positioning errors within the
/// interpolation bound (the values are the errors themselves, 1e-6 mm
/// rounding).
#[test]
fn siemens_eec_round_trip_within_interpolation_bound() {
    let (m, cubics) = positioning_model();
    let h = 15.0;
    let opts = ExportOptions {
        spacing_mm: Some(h),
        ..Default::default()
    };
    let e = controller::export(&m, Format::SiemensEec, &opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    write_all(dir.path(), &e.files);
    let back = controller::import(
        Format::SiemensEec,
        &[dir.path().join(&e.files[0].0)],
        &m.nominal(),
    )
    .unwrap();
    let names: Vec<String> = back.changed.iter().map(|n| n.to_string()).collect();
    assert_eq!(names, ["EYY", "EXX", "EZZ"], "in axis order Y X Z");
    for (name, c) in &cubics {
        let ax = &m.axes[m.axis_index(&name.axis).unwrap()];
        let tol = bound(c, ax.travel, h) + 1e-6;
        for k in 0..=500 {
            let q = ax.travel[0] + (ax.travel[1] - ax.travel[0]) * k as f64 / 500.0;
            let d = (back.machine.error_value(name, q).unwrap() - m.error_value(name, q).unwrap())
                .abs();
            assert!(d <= tol, "{name} at {q}: {d:e} > {tol:e}");
        }
    }
}

/// Siemens CEC: straightness cubics that are zero at the middle of their
/// axis' range (CEC tables are zero at the reference pose) come back within
/// the interpolation bound.
#[test]
fn siemens_cec_round_trip_within_interpolation_bound() {
    let mut m = mtwin::examples::machine("ac-trunnion").unwrap();
    let mut cubics = Vec::new();
    for (n, c1, c2, c3) in [
        ("EYX", 1e-5, -4e-8, 6e-11),
        ("EZX", -2e-5, 5e-8, 3e-11),
        ("EXY", 8e-6, 3e-8, -5e-11),
        ("EZY", 3e-6, -2e-8, 4e-11),
        ("EXZ", -6e-6, 4e-8, 2e-11),
        ("EYZ", 5e-6, 6e-8, -3e-11),
    ] {
        let n: ErrorName = n.parse().unwrap();
        let i = m.axis_index(&n.axis).unwrap();
        let mid = 0.5 * (m.axes[i].travel[0] + m.axes[i].travel[1]);
        let c0 = -(c1 * mid + c2 * mid * mid + c3 * mid * mid * mid);
        let c = [c0, c1, c2, c3];
        m.axes[i].errors.pdge[n.component.index()] = Some(ErrorFunction::Poly(c.to_vec()));
        cubics.push((n, c));
    }
    let h = 20.0;
    let opts = ExportOptions {
        spacing_mm: Some(h),
        ..Default::default()
    };
    let e = controller::export(&m, Format::SiemensCec, &opts).unwrap();
    assert!(e.dropped.is_empty(), "{:?}", e.dropped);
    let dir = tempfile::tempdir().unwrap();
    write_all(dir.path(), &e.files);
    let back = controller::import(
        Format::SiemensCec,
        &[dir.path().join(&e.files[0].0)],
        &m.nominal(),
    )
    .unwrap();
    assert_eq!(back.changed.len(), 6);
    for (name, c) in &cubics {
        let ax = &m.axes[m.axis_index(&name.axis).unwrap()];
        let tol = bound(c, ax.travel, h) + 1e-6;
        let mut worst: f64 = 0.0;
        for k in 0..=500 {
            let q = ax.travel[0] + (ax.travel[1] - ax.travel[0]) * k as f64 / 500.0;
            let d = (back.machine.error_value(name, q).unwrap() - m.error_value(name, q).unwrap())
                .abs();
            worst = worst.max(d);
        }
        assert!(worst <= tol, "{name}: {worst:e} > {tol:e}");
    }
}

/// An EEC program in the layout of the vendor's documentation, written by
/// hand: three points 1 mm apart from −200 mm on the first axis.
#[test]
fn siemens_eec_documented_layout_reads_into_the_positioning_error() {
    let text = "%_N_AX_EEC_INI\n\
                CHANDATA(1)\n\
                $AA_ENC_COMP[0,0,AX1]=0.003 ; 1st compensation value\n\
                $AA_ENC_COMP[0,1,AX1]=0.01\n\
                $AA_ENC_COMP[0,2,AX1]=0.012\n\
                $AA_ENC_COMP_STEP[0,AX1]=1.0\n\
                $AA_ENC_COMP_MIN[0,AX1]=-200.0\n\
                $AA_ENC_COMP_MAX[0,AX1]=-198.0\n\
                $AA_ENC_COMP_IS_MODULO[0,AX1]=0\n\
                M17\n";
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("AX_EEC.INI");
    std::fs::write(&p, text).unwrap();
    let m = mtwin::examples::machine("ac-trunnion").unwrap();
    let back = controller::import(Format::SiemensEec, std::slice::from_ref(&p), &m).unwrap();
    // AX1 is X (axes numbered X Y Z A C); the value is the error to take out.
    let exx: ErrorName = "EXX".parse().unwrap();
    let x = back.machine.axis_index("X").unwrap();
    assert_eq!(
        back.machine.axes[x].errors.pdge[exx.component.index()],
        Some(ErrorFunction::Table {
            q: vec![-200.0, -199.0, -198.0],
            e: vec![0.003, 0.01, 0.012],
        })
    );
    // A step that does not fit MIN/MAX and the point count: file:line.
    let bad = text.replace("STEP[0,AX1]=1.0", "STEP[0,AX1]=1.5");
    std::fs::write(&p, bad).unwrap();
    let err = controller::import(Format::SiemensEec, std::slice::from_ref(&p), &m)
        .unwrap_err()
        .to_string();
    assert!(err.contains("AX_EEC.INI:3:"), "{err}");
    assert!(err.contains("_STEP is 1.5"), "{err}");
}

/// A CEC table applying in one direction of travel has no place in a machine
/// model: refused at its line.
#[test]
fn siemens_cec_one_direction_table_is_refused() {
    let text = "%_N_NC_CEC_INI\nCHANDATA(1)\n\
                $AN_CEC[0,0]=0.0\n$AN_CEC[0,1]=0.002\n\
                $AN_CEC_INPUT_AXIS[0]=AX1\n$AN_CEC_OUTPUT_AXIS[0]=AX3\n\
                $AN_CEC_STEP[0]=100.0\n$AN_CEC_MIN[0]=0.0\n$AN_CEC_MAX[0]=100.0\n\
                $AN_CEC_DIRECTION[0]=1\nM17\n";
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("NC_CEC.INI");
    std::fs::write(&p, text).unwrap();
    let m = mtwin::examples::machine("ac-trunnion").unwrap();
    let err = controller::import(Format::SiemensCec, std::slice::from_ref(&p), &m)
        .unwrap_err()
        .to_string();
    assert!(err.contains("NC_CEC.INI:3:"), "{err}");
    assert!(err.contains("one direction"), "{err}");
    // Both directions: Z over X, the value added to Z cancels EZX = −value.
    std::fs::write(&p, text.replace("DIRECTION[0]=1", "DIRECTION[0]=0")).unwrap();
    let back = controller::import(Format::SiemensCec, std::slice::from_ref(&p), &m).unwrap();
    let ezx: ErrorName = "EZX".parse().unwrap();
    assert!((back.machine.error_value(&ezx, 100.0).unwrap() + 0.002).abs() < 1e-15);
    assert!((back.machine.error_value(&ezx, 50.0).unwrap() + 0.001).abs() < 1e-15);
}
