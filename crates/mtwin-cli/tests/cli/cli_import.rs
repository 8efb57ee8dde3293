//! `mtwin import`: export → import → `mtwin predict` gives the model's
//! predictions back within the error of linear interpolation between table
//! points; bad files are refused at file:line:col with no output.
//!
//! The bound is derived here, not read from the code: linear interpolation of
//! a cubic `e` between points `h` apart is off by at most `h²/8·max|e''|`, and
//! `|e''| = |2 c2 + 6 c3 q|` is largest at an end of the range. Translational
//! errors move the tool tip by their own size, so the tip differs by at most
//! the sum of the bounds of the errors; the files round values to 1e-9 mm
//! (Siemens: 1e-6 mm) per table.

use std::path::Path;

use crate::common::{example, mtwin, stderr, stdout};

/// Cubic `c` of one error of an axis with `travel`.
struct Cubic {
    name: &'static str,
    axis: &'static str,
    c: [f64; 4],
}

fn travel(axis: &str) -> [f64; 2] {
    if axis == "Z" {
        [-400.0, 200.0]
    } else {
        [-300.0, 300.0]
    }
}

/// Cubics that vanish at the middle of their axis' travel (per-axis tables
/// along a line other than the own axis are zero at the reference pose).
fn cubic(name: &'static str, axis: &'static str, c1: f64, c2: f64, c3: f64) -> Cubic {
    let [lo, hi] = travel(axis);
    let m = 0.5 * (lo + hi);
    Cubic {
        name,
        axis,
        c: [-(c1 * m + c2 * m * m + c3 * m * m * m), c1, c2, c3],
    }
}

fn bound(k: &Cubic, h: f64) -> f64 {
    let [lo, hi] = travel(k.axis);
    let e2 = |q: f64| (2.0 * k.c[2] + 6.0 * k.c[3] * q).abs();
    h * h / 8.0 * e2(lo).max(e2(hi))
}

/// The example AC trunnion with `errors` (and `extra` lines per axis).
fn machine_text(errors: &[Cubic], extra: &[(&str, &str)]) -> String {
    let text = std::fs::read_to_string(example("ac-trunnion.toml")).unwrap();
    let mut parts = text.split("[[axes]]");
    let mut out = parts.next().unwrap().to_string();
    for part in parts {
        let name = part
            .lines()
            .find_map(|l| l.trim().strip_prefix("name = "))
            .unwrap()
            .trim_matches('"')
            .to_string();
        out.push_str("[[axes]]");
        out.push_str(part.trim_end());
        out.push_str("\n  [axes.errors]\n");
        for k in errors.iter().filter(|k| k.axis == name) {
            out.push_str(&format!(
                "  {} = {{ poly = [{:e}, {:e}, {:e}, {:e}] }}\n",
                k.name, k.c[0], k.c[1], k.c[2], k.c[3]
            ));
        }
        for (axis, line) in extra {
            if *axis == name {
                out.push_str(&format!("  {line}\n"));
            }
        }
        out.push('\n');
    }
    out
}

/// Poses over the workspace: linear axes across their travel, rotary axes
/// turned.
fn poses() -> String {
    let mut s = String::from("X,Y,Z,A,C\n");
    for k in 0..60 {
        let f = |p: f64| ((k as f64 * p).sin() + 1.0) / 2.0;
        s.push_str(&format!(
            "{},{},{},{},{}\n",
            -300.0 + 600.0 * f(0.37),
            -300.0 + 600.0 * f(0.71),
            -400.0 + 600.0 * f(1.13),
            -100.0 + 200.0 * f(0.29),
            -180.0 + 360.0 * f(0.53)
        ));
    }
    s
}

/// Rows of a `mtwin predict` output: x, y, z, i, j, k.
fn predicted(dir: &Path, machine: &str, out: &str) -> Vec<[f64; 6]> {
    let o = mtwin(
        dir,
        &[
            "predict",
            "--machine",
            machine,
            "--data",
            "poses.csv",
            "--out",
            out,
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(dir.join(out)).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|t| t.parse().unwrap()).collect();
            std::array::from_fn(|k| v[5 + k])
        })
        .collect()
}

/// Export `errors` (+ `extra`) as `to` with `--spacing h`, import `files`
/// (names in the export folder; for linuxcnc `AXIS=` prefixes allowed) into
/// the nominal machine, predict both: the tips agree within the bound plus
/// `rounding` per error, and the tool axes exactly to 1e-12.
fn round_trip(
    to: &str,
    errors: &[Cubic],
    extra: &[(&str, &str)],
    files: &[&str],
    h: f64,
    rounding: f64,
) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("truth.toml"), machine_text(errors, extra)).unwrap();
    std::fs::write(d.join("poses.csv"), poses()).unwrap();
    let o = mtwin(
        d,
        &[
            "export",
            "--machine",
            "truth.toml",
            "--to",
            to,
            "--out",
            "tables",
            "--spacing",
            &h.to_string(),
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut args = vec![
        "import".to_string(),
        "--from".into(),
        to.into(),
        "--into".into(),
        example("ac-trunnion.toml"),
        "--out".into(),
        "imported.toml".into(),
        "--format".into(),
        "json".into(),
    ];
    for f in files {
        args.push(match f.split_once('=') {
            Some((axis, name)) => format!("{axis}=tables/{name}"),
            None => format!("tables/{f}"),
        });
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = mtwin(d, &args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let mut changed: Vec<String> = doc["changed"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    changed.sort();
    let mut want: Vec<String> = errors.iter().map(|k| k.name.to_string()).collect();
    want.extend(
        extra
            .iter()
            .map(|(_, l)| l.split_whitespace().next().unwrap().to_string()),
    );
    want.sort();
    assert_eq!(changed, want, "{to}");
    let truth = predicted(d, "truth.toml", "truth.csv");
    let back = predicted(d, "imported.toml", "back.csv");
    let tol: f64 = errors.iter().map(|k| bound(k, h) + rounding).sum::<f64>() + 1e-9;
    let mut worst = 0.0f64;
    for (a, b) in truth.iter().zip(&back) {
        let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        worst = worst.max(d);
        for k in 3..6 {
            assert!(
                (a[k] - b[k]).abs() < 1e-12,
                "{to}: tool axis {a:?} vs {b:?}"
            );
        }
    }
    eprintln!("{to}: tip difference {worst:.3e} mm, bound {tol:.3e} mm");
    assert!(worst <= tol, "{to}: {worst:e} > {tol:e}");
    // Interpolation is visible: the tables are not the cubics.
    assert!(worst > 0.0, "{to}");
}

fn positioning() -> Vec<Cubic> {
    vec![
        cubic("EXX", "X", 1e-5, -4e-8, 6e-11),
        cubic("EYY", "Y", -2e-5, 5e-8, 3e-11),
        cubic("EZZ", "Z", 8e-6, 3e-8, -5e-11),
    ]
}

#[test]
fn linuxcnc_export_import_predicts_within_the_interpolation_bound() {
    // One file by its conventional name, one with AXIS= (any name works then).
    round_trip(
        "linuxcnc",
        &positioning(),
        &[],
        &["comp_X.txt", "Y=comp_Y.txt", "comp_Z.txt"],
        15.0,
        1e-9,
    );
}

#[test]
fn siemens_eec_export_import_predicts_within_the_interpolation_bound() {
    round_trip(
        "siemens-eec",
        &positioning(),
        &[],
        &["AX_EEC.INI"],
        15.0,
        1e-6,
    );
}

#[test]
fn siemens_cec_export_import_predicts_within_the_interpolation_bound() {
    let straightness = vec![
        cubic("EYX", "X", 1e-5, -4e-8, 6e-11),
        cubic("EZX", "X", -2e-5, 5e-8, 3e-11),
        cubic("EXY", "Y", 8e-6, 3e-8, -5e-11),
        cubic("EZY", "Y", 3e-6, -2e-8, 4e-11),
        cubic("EXZ", "Z", -6e-6, 4e-8, 2e-11),
        cubic("EYZ", "Z", 5e-6, 6e-8, -3e-11),
    ];
    round_trip(
        "siemens-cec",
        &straightness,
        &[],
        &["NC_CEC.INI"],
        20.0,
        1e-6,
    );
}

/// Translational errors of every axis, rotary ones too, and location errors
/// (written exactly): the volumetric formats.
fn volumetric() -> (Vec<Cubic>, Vec<(&'static str, &'static str)>) {
    let mut v = positioning();
    v.push(cubic("EYX", "X", 1e-5, -4e-8, 6e-11));
    v.push(cubic("EXZ", "Z", -6e-6, 4e-8, 2e-11));
    let extra = vec![
        ("A", "EY0A = 0.021"),
        ("A", "EZ0A = -0.017"),
        ("C", "EX0C = 0.014"),
    ];
    (v, extra)
}

#[test]
fn isg_export_import_predicts_within_the_interpolation_bound() {
    let (v, extra) = volumetric();
    // Through the list, and the ISG_CSV file named directly.
    round_trip("isg", &v, &extra, &["volcomp.lis"], 20.0, 1e-9);
    round_trip("isg", &v, &extra, &["volcomp.csv"], 20.0, 1e-9);
}

#[test]
fn etalon_export_import_predicts_within_the_interpolation_bound() {
    let (v, extra) = volumetric();
    round_trip("etalon", &v, &extra, &["volcomp.etalon"], 20.0, 1e-9);
}

#[test]
fn bad_table_is_refused_at_its_line_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("comp_X.txt"),
        "-10 0.001 0.001\n0 0.002\n10 0.003 0.003\n",
    )
    .unwrap();
    let o = mtwin(
        d,
        &[
            "import",
            "--from",
            "linuxcnc",
            "--into",
            &example("ac-trunnion.toml"),
            "--out",
            "new.toml",
            "comp_X.txt",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("comp_X.txt:2:1:"), "{}", stderr(&o));
    assert!(!d.join("new.toml").exists());
    // Never over an input.
    std::fs::write(d.join("comp_X.txt"), "-10 0.001 0.001\n10 0.003 0.003\n").unwrap();
    std::fs::copy(example("ac-trunnion.toml"), d.join("m.toml")).unwrap();
    let before = std::fs::read(d.join("m.toml")).unwrap();
    let o = mtwin(
        d,
        &[
            "import",
            "--from",
            "linuxcnc",
            "--into",
            "m.toml",
            "--out",
            "m.toml",
            "comp_X.txt",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(std::fs::read(d.join("m.toml")).unwrap(), before);
    // A Siemens table whose step does not fit its range.
    std::fs::write(
        d.join("AX_EEC.INI"),
        "%_N_AX_EEC_INI\nCHANDATA(1)\n$AA_ENC_COMP[0,0,AX1]=0.001\n$AA_ENC_COMP[0,1,AX1]=0.002\n\
         $AA_ENC_COMP_STEP[0,AX1]=5\n$AA_ENC_COMP_MIN[0,AX1]=0\n$AA_ENC_COMP_MAX[0,AX1]=10\nM17\n",
    )
    .unwrap();
    let o = mtwin(
        d,
        &[
            "import",
            "--from",
            "siemens-eec",
            "--into",
            "m.toml",
            "--out",
            "new.toml",
            "AX_EEC.INI",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("AX_EEC.INI:3:"), "{}", stderr(&o));
    assert!(!d.join("new.toml").exists());
}
