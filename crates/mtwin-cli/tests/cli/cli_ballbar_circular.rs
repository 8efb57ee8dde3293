//! `mtwin ballbar circular` / `simulate-circular`: the JSON contract, recovery
//! through the CLI, bad input.

use std::path::Path;

use crate::common::{json, mtwin, mtwin_ok, stderr};

/// `mtwin ballbar simulate-circular --out t --radius R EXTRA…` in `dir`,
/// required to succeed.
fn simulate_circular(dir: &Path, radius: &str, extra: &[&str]) {
    let mut args = vec![
        "ballbar",
        "simulate-circular",
        "--out",
        "t",
        "--radius",
        radius,
    ];
    args.extend_from_slice(extra);
    mtwin_ok(dir, &args);
}

/// `mtwin ballbar circular` of the simulated `t/cw.csv` and `t/ccw.csv` at
/// radius R with `--format json`, required to succeed.
fn circular_json(dir: &Path, radius: &str) -> std::process::Output {
    mtwin_ok(
        dir,
        &[
            "ballbar",
            "circular",
            "--cw",
            "t/cw.csv",
            "--ccw",
            "t/ccw.csv",
            "--radius",
            radius,
            "--format",
            "json",
        ],
    )
}

#[test]
fn simulated_errors_come_back_through_the_json_contract() {
    let dir = tempfile::tempdir().unwrap();
    simulate_circular(
        dir.path(),
        "150",
        &[
            "--noise",
            "0.2",
            "--backlash-x-um",
            "8",
            "--squareness-um-per-m",
            "40",
            "--scale-mismatch-um",
            "10",
            "--centre-x-um",
            "5",
        ],
    );
    let o = circular_json(dir.path(), "150");
    let v = json(&o);
    for k in [
        "G",
        "H",
        "F",
        "backlash_y_um",
        "lateral_play_x_um",
        "reversal_spike_x_um",
        "cyclic_error_x_um",
        "servo_mismatch_um",
        "straightness_x_um",
    ] {
        assert!(v[k].is_number(), "{k} in {v}");
    }
    for (k, want) in [
        ("backlash_x_um", 8.0),
        ("squareness_um_per_m", 40.0),
        ("scale_mismatch_um", 10.0),
    ] {
        let got = v[k].as_f64().unwrap();
        assert!(
            (got - want).abs() <= (0.05 * want).max(0.5),
            "{k}: {got} vs {want}"
        );
    }
    // squareness 40 µm/m over R = 150 mm: ±3 µm of sin 2θ; the trace is not round
    assert!(v["G"].as_f64().unwrap() > 5.0);
}

#[test]
fn bad_trace_is_a_file_line_column_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("angle_deg,deviation_um\n");
    for k in 0..10 {
        csv.push_str(&format!(
            "{},{}\n",
            k * 36,
            if k == 4 { "x" } else { "0.5" }
        ));
    }
    std::fs::write(dir.path().join("cw.csv"), &csv).unwrap();
    let o = mtwin(
        dir.path(),
        &["ballbar", "circular", "--cw", "cw.csv", "--radius", "100"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("cw.csv:6:2:"), "{}", stderr(&o));
}

#[test]
fn plane_plot_and_model_update_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    simulate_circular(
        p,
        "100",
        &[
            "--noise",
            "0.1",
            "--backlash-x-um",
            "6",
            "--squareness-um-per-m",
            "50",
            "--scale-mismatch-um",
            "8",
        ],
    );
    let model = crate::common::example("ac-trunnion.toml");
    let args = |plane: &'static str, out: &'static str| {
        vec![
            "ballbar",
            "circular",
            "--cw",
            "t/cw.csv",
            "--ccw",
            "t/ccw.csv",
            "--radius",
            "100",
            "--plane",
            plane,
            "--plot",
            "c.svg",
            "--update-model",
            Box::leak(model.clone().into_boxed_str()),
            "--out-model",
            out,
            "--format",
            "json",
        ]
    };
    let o = mtwin_ok(p, &args("yz", "yz.toml"));
    let v = json(&o);
    assert_eq!(v["plane"], "yz");
    let b = v["backlash_y_um"].as_f64().unwrap();
    assert!((b - 6.0).abs() < 0.5, "{v}");
    assert!(v.get("backlash_x_um").is_none(), "{v}");
    assert!(v["backlash_z_um"].as_f64().unwrap().abs() < 0.5);
    let svg = std::fs::read_to_string(p.join("c.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("plane YZ"), "{svg}");
    assert!(svg.contains("counter-clockwise") && svg.matches("<polyline").count() >= 2);
    // YZ on the trunnion: Z is rotated about x by −α (y += α·z needs a turn of −α)
    let text = std::fs::read_to_string(p.join("yz.toml")).unwrap();
    let m = mtwin::model::parse_machine(std::path::Path::new("yz.toml"), &text).unwrap();
    let z = &m.axes[m.axis_index("Z").unwrap()];
    let gamma = z.errors.location[mtwin::model::Component::Rx.index()];
    assert!((gamma + 50e-6).abs() < 2.5e-6, "EA0Z {gamma}");
    assert!(stderr(&o).contains("EA0Z"), "{}", stderr(&o));

    // one direction: nothing written
    for f in ["c.svg", "yz.toml"] {
        std::fs::remove_file(p.join(f)).unwrap();
    }
    let mut one = args("xy", "xy.toml");
    one.drain(2..4);
    let o = mtwin(p, &one);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("not separable"), "{}", stderr(&o));
    assert!(!p.join("xy.toml").exists() && !p.join("c.svg").exists());
    // the model as its own output
    let o = mtwin(p, &args("xy", Box::leak(model.clone().into_boxed_str())));
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("same file as the input"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn servo_models_through_simulate_circular() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let ts: f64 = 0.001;
    let write = |name: &str, tau: f64| {
        let q = (-ts / tau).exp();
        std::fs::write(
            p.join(name),
            format!(
                "ts = {ts}\nb = [0.0, {}]\na = [1.0, {}]\nnk = 0\n",
                1.0 - q,
                -q
            ),
        )
        .unwrap();
    };
    let (tau_x, tau_y) = (0.016, 0.012);
    write("x.toml", tau_x);
    write("y.toml", tau_y);
    simulate_circular(
        p,
        "100",
        &[
            "--servo-model",
            "x.toml",
            "--servo-model",
            "y.toml",
            "--feed",
            "1200",
        ],
    );
    let o = circular_json(p, "100");
    let v = json(&o);
    // first-order lags at v = 20 mm/s: m ≈ v·(τx − τy) = 80 µm (continuous
    // form; the discrete lags differ by the same ts/2 each)
    let m = v["servo_mismatch_um"].as_f64().unwrap();
    let want = 1200.0 / 60.0 * (tau_x - tau_y) * 1e3;
    assert!((m - want).abs() < 0.05 * want, "{m} vs {want}");
    // one model only is a usage error
    let o = mtwin(
        p,
        &[
            "ballbar",
            "simulate-circular",
            "--out",
            "u",
            "--servo-model",
            "x.toml",
            "--feed",
            "1200",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("twice"), "{}", stderr(&o));
    assert!(!p.join("u").join("cw.csv").exists());
}
