//! Live thermal compensation on LinuxCNC: the HAL component `mtwin export
//! --thermal … --to linuxcnc` writes (`mtwin_thermal.py`, `thermal.hal`, the
//! ini lines of `thermal-README.txt`) loaded into LinuxCNC 2.9's simulator;
//! a program spins the spindle at known speeds while Z holds still, and the
//! Z external offset LinuxCNC applies is compared with mtwin's own
//! prediction of the drift for the same speed history
//! ([`ThermalPredictor`](mtwin::methods::thermal::ThermalPredictor)).
//!
//! The model's period is 10 min; the component runs it as a time lapse
//! (`--period-s`) on the servo thread's clock (`--clock-pin`, an `integ` of
//! 1 on the servo thread), so that a period is a fixed number of servo
//! periods however late the non-realtime simulator runs.

use mtwin::controller::linuxcnc_thermal::{self, RESOLUTION_MM};
use mtwin::methods::thermal::{HeightModel, InputChannel, ThermalModel};
use mtwin::sysid::Arx;

use crate::linuxcnc_sim::{SHORT, SimSetup, available, run_or_panic};

/// Model time lapse: one model period (10 min) lasts this long, s.
const PERIOD_S: f64 = 1.5;
/// The component's poll interval, s (wall clock).
const POLL_S: f64 = 0.005;

/// The two-height model of docs/thermal-compensation.md, heights moved into
/// the simulator's Z travel (±120 mm).
fn model() -> ThermalModel {
    let h = |z: f64, b: [f64; 2]| HeightModel {
        z_mm: z,
        model: Arx::new(vec![1.0, -1.605827, 0.627089], vec![(b.to_vec(), 1)]).unwrap(),
        stats: None,
    };
    ThermalModel::new(
        10.0,
        vec![InputChannel::linear("speed_rpm", 8000.0)],
        vec![
            h(-100.0, [-0.0062836, 0.0057508]),
            h(100.0, [-0.0070963, 0.0062955]),
        ],
    )
    .unwrap()
}

/// The columns the test samples besides the standard ones, in order.
const SPEED: usize = 0;
const CLOCK: usize = 1;
const COUNTS: usize = 2;
const DRIFT: usize = 3;
const SAMPLE: usize = 4;
const TIME: usize = 5;
const Z: usize = 6;
const EOFFSET: usize = 7;

/// The simulator set-up from the exported files: the component beside the
/// ini, thermal.hal's lines (the `loadusr` line with the time-lapse
/// options), the `[AXIS_Z]` lines of the README, the servo clock and the
/// signals to sample.
fn setup_from_export(files: &[(String, String)]) -> SimSetup {
    let mut setup = SimSetup::default();
    let mut section = String::new();
    let mut loaded = false;
    for (name, text) in files {
        match name.as_str() {
            "mtwin_thermal.py" => setup = setup.file(name, text.clone()),
            "thermal.hal" => {
                for line in text.lines().filter(|l| !l.starts_with('#')) {
                    if line.starts_with("loadusr ") {
                        loaded = true;
                        setup = setup.hal(format!(
                            "{line} --period-s {PERIOD_S} --clock-pin --poll-s {POLL_S}"
                        ));
                    } else {
                        setup = setup.hal(line);
                    }
                }
            }
            "thermal-README.txt" => {
                for line in text.lines().map(str::trim) {
                    if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                        section = s.to_string();
                    } else if let Some((k, v)) = line.split_once(" = ")
                        && section == "AXIS_Z"
                    {
                        setup = setup.ini(&section, k.trim(), v.trim());
                    }
                }
            }
            other => panic!("unexpected file {other}"),
        }
    }
    assert!(loaded, "thermal.hal loads the component");
    assert!(
        setup.ini.iter().any(|e| e.1 == "OFFSET_AV_RATIO"),
        "the README gives OFFSET_AV_RATIO"
    );
    setup
        .hal("loadrt integ names=mtwin-clock")
        .hal("addf mtwin-clock servo-thread")
        .hal("setp mtwin-clock.in 1")
        .hal("net mtwin-thermal-clock mtwin-clock.out => mtwin-thermal.clock-s")
        .hal("net mtwin-t-drift mtwin-thermal.drift-mm")
        .hal("net mtwin-t-sample mtwin-thermal.sample")
        .hal("net mtwin-t-time mtwin-thermal.time-s")
        .hal("net mtwin-t-z mtwin-thermal.z-mm")
        .hal("net mtwin-t-eoffset axis.z.eoffset")
        .sample('f', "mtwin-thermal-speed")
        .sample('f', "mtwin-thermal-clock")
        .sample('s', "mtwin-thermal-counts")
        .sample('f', "mtwin-t-drift")
        .sample('s', "mtwin-t-sample")
        .sample('f', "mtwin-t-time")
        .sample('f', "mtwin-t-z")
        .sample('f', "mtwin-t-eoffset")
}

#[test]
fn exported_thermal_component_drives_the_z_offset_as_mtwin_predicts() {
    if !available() {
        return;
    }
    let m = model();
    let files = linuxcnc_thermal::export(&m).unwrap();
    let setup = setup_from_export(&files);
    // 6000 rev/min for 9 s (six periods), 2000 for 6 s, stopped for 6 s; Z
    // holds at 20 mm (between the heights, weight 0.6 on z = 100).
    let program = "G21 G90 G94\nG0 X0 Y0 Z20\nS6000 M3\nG4 P9\nS2000\nG4 P6\nM5\nG4 P6\nM2\n";
    let t = run_or_panic("thermal", program, &setup, SHORT);
    let x = &t.extra;
    let dt = t.period;
    assert_eq!(x.len(), t.samples.len());
    assert_eq!(x[0][SPEED], 0.0, "the spindle is off when sampling starts");
    assert_eq!(x[x.len() - 1][SPEED], 0.0, "and off at the end");

    // The speed history in the component's clock: each sampled value holds
    // for one servo period from its clock value.
    let period = PERIOD_S;
    let last_clock = x[x.len() - 1][CLOCK];
    let n_periods = (last_clock / period).floor() as usize + 2;
    let mut means = vec![0.0; n_periods];
    // Largest speed jump inside each period (for the bound).
    let mut jump = vec![0.0f64; n_periods];
    for (i, r) in x.iter().enumerate() {
        let k = (r[CLOCK] / period).floor() as usize;
        means[k] += r[SPEED] * dt / period;
        if i > 0 {
            jump[k] += (r[SPEED] - x[i - 1][SPEED]).abs();
        }
    }
    // The servo clock advances one period per row.
    for w in x.windows(2) {
        assert!(
            ((w[1][CLOCK] - w[0][CLOCK]) - dt).abs() < 1e-9,
            "clock step"
        );
    }
    // mtwin's prediction of that history: e(kT) at the measured heights.
    let mut p = m.predictor();
    let mut drifts = vec![p.drifts().to_vec()];
    for &s in &means {
        p.advance(&[s]);
        drifts.push(p.drifts().to_vec());
    }

    // The component's poll interval in clock time (largest gap between
    // the clock values it reports).
    let mut gap = 0.0f64;
    let mut last = x[0][TIME];
    let mut since = 0usize;
    for r in x {
        if r[TIME] != last {
            gap = gap.max(r[TIME] - last);
            last = r[TIME];
            since = 0;
        } else {
            since += 1;
            gap = gap.max(since as f64 * dt);
        }
    }
    // The component holds the speed it read at a poll until the next one,
    // the test one servo period: a jump of size J inside period j moves the
    // period's mean by at most δ_j = J·(gap + dt)/T. The drift e(kT) then
    // moves by at most Σ_j |h(k − j)|·δ_j/scale, h the model's response to
    // a unit input in period 0 (largest of the heights; the interpolation
    // across heights is a convex combination).
    let n = drifts.len();
    let impulse: Vec<Vec<f64>> = m
        .heights()
        .iter()
        .map(|h| {
            let mut u = vec![0.0; n];
            u[0] = 1.0;
            h.model.simulate(&[&u]).unwrap()
        })
        .collect();
    let scale = m.inputs()[0].scale;
    let bound_mean: Vec<f64> = jump.iter().map(|j| j * (gap + dt) / period).collect();
    let bound: Vec<f64> = (0..n)
        .map(|k| {
            impulse
                .iter()
                .map(|h| {
                    (0..k.min(bound_mean.len()))
                        .map(|j| h[k - j].abs() * bound_mean[j] / scale)
                        .sum::<f64>()
                })
                .fold(0.0, f64::max)
                + 1e-12
        })
        .collect();
    let bound_drift = bound.iter().copied().fold(0.0, f64::max);

    let av_ratio: f64 = setup
        .ini
        .iter()
        .find(|e| e.1 == "OFFSET_AV_RATIO")
        .map(|e| e.2.parse().unwrap())
        .unwrap();
    let tiny_dp = av_ratio * 300.0 * dt * dt * 0.001 + 1e-12;
    let (mut worst_model, mut worst_counts, mut worst_applied) = (0.0f64, 0.0f64, 0.0f64);
    let (mut settled, mut max_offset) = (0usize, 0.0f64);
    let mut worst_applied_counts = 0.0f64;
    let mut steps = 0usize;
    let mut quiet = 0usize;
    for (i, r) in x.iter().enumerate() {
        let k = r[SAMPLE] as usize;
        assert!(k < drifts.len(), "sample {k} beyond the run");
        // The component's drift is mtwin's e(kT) at its tool height.
        let want = m.interpolate(&drifts[k], r[Z]).mm;
        let d = (r[DRIFT] - want).abs();
        worst_model = worst_model.max(d);
        assert!(
            d <= bound[k],
            "row {i}, sample {k}: component off mtwin by {d} mm (bound {})",
            bound[k]
        );
        // Its counts are minus the drift in units of the resolution.
        worst_counts = worst_counts.max((r[COUNTS] * RESOLUTION_MM + r[DRIFT]).abs());
        // The offset LinuxCNC applies, once its ramp has settled (0.1 s
        // without a change of the counts).
        if i > 0 && r[COUNTS] != x[i - 1][COUNTS] {
            steps += 1;
            quiet = 0;
        } else {
            quiet += 1;
        }
        if quiet > 100 {
            settled += 1;
            let e = (r[EOFFSET] + want).abs();
            worst_applied = worst_applied.max(e);
            assert!(
                e <= bound[k] + 0.5 * RESOLUTION_MM + tiny_dp,
                "row {i}: applied offset off mtwin by {e} mm"
            );
            // LinuxCNC moves the offset with its single-axis planner
            // (simple_tp), which stops once within TINY_DP = max_acc ·
            // period² · 0.001 of the request, max_acc being OFFSET_AV_RATIO
            // times the axis' MAX_ACCELERATION (300 mm/s² here).
            let d = (r[EOFFSET] - r[COUNTS] * RESOLUTION_MM).abs();
            worst_applied_counts = worst_applied_counts.max(d);
            assert!(
                d <= tiny_dp,
                "row {i}: applied {} for counts {}",
                r[EOFFSET],
                r[COUNTS]
            );
        }
        max_offset = max_offset.max(r[EOFFSET].abs());
        // While the spindle turns Z holds at 20 mm, moved only by the offset.
        if r[SPEED] > 0.0 {
            assert!((r[Z] - 20.0).abs() < 1e-3, "row {i}: z {}", r[Z]);
        }
    }
    eprintln!(
        "thermal: {} rows, {} model periods of {period} s, poll gap {gap:.4} s, {steps} offset changes, \
         largest offset {:.3} µm; component vs mtwin {:.2e} µm (bound {:.2e} µm), counts {:.2e} µm, \
         applied vs mtwin {:.2e} µm on {settled} settled rows, applied vs counts {:.2e} µm",
        x.len(),
        n_periods,
        max_offset * 1e3,
        worst_model * 1e3,
        bound_drift * 1e3,
        worst_counts * 1e3,
        worst_applied * 1e3,
        worst_applied_counts * 1e3
    );
    // The drift is not nothing: several µm, changing every period.
    assert!(max_offset > 2e-3, "largest offset {max_offset} mm");
    assert!(steps >= 8, "{steps} offset changes");
    assert!(
        settled > x.len() / 2,
        "{settled} settled rows of {}",
        x.len()
    );
    assert!(
        worst_counts <= 0.5 * RESOLUTION_MM + 1e-12,
        "counts off by {worst_counts} mm"
    );
    // The target the live compensation is held to: the offset LinuxCNC
    // applies equals mtwin's prediction within 0.1 µm.
    assert!(
        worst_applied <= 1e-4,
        "applied offset off mtwin by {worst_applied} mm (target 0.1 µm)"
    );
}

/// Python for the check below: loads the exported component with a stand-in
/// `hal` module, feeds its model four polls per period (the values of
/// period k read at kT, kT + T/4, …) and prints the drift at each height
/// asked after every period, as JSON.
const OFFLINE: &str = r#"
import importlib.util, json, sys, types
sys.modules["hal"] = types.ModuleType("hal")
spec = importlib.util.spec_from_file_location("mtwin_thermal", sys.argv[1])
mod = importlib.util.module_from_spec(spec)
spec.loader.exec_module(mod)
T = 60.0
th = mod.Thermal(mod.MODEL, T)
rows = json.loads(sys.argv[2])
zs = json.loads(sys.argv[3])
out = []
for k, values in enumerate(rows):
    for j in range(4):
        th.advance(k * T + j * T / 4, values)
    out.append([th.drift(z) for z in zs])
th.advance(len(rows) * T, [0.0] * len(rows[0]))
out.append([th.drift(z) for z in zs])
print(json.dumps(out))
"#;

/// The component's model (Python) against mtwin's predictor on a model with
/// two inputs (the speed linear and squared, and a temperature with a delay
/// of two periods), period means of held values, interpolation across three
/// heights and outside them. Needs a Python 3 (`/usr/bin/python3`, which
/// `linuxcnc-uspace` brings); without one the check is skipped unless
/// `MTWIN_REQUIRE_LINUXCNC=1`.
#[test]
fn component_model_steps_as_mtwins_predictor() {
    let python = ["/usr/bin/python3", "python3"].into_iter().find(|p| {
        std::process::Command::new(p)
            .arg("-c")
            .arg("import json")
            .output()
            .is_ok_and(|o| o.status.success())
    });
    let Some(python) = python else {
        assert!(
            std::env::var("MTWIN_REQUIRE_LINUXCNC").as_deref() != Ok("1"),
            "MTWIN_REQUIRE_LINUXCNC=1 but there is no python3"
        );
        eprintln!("skipped: no python3");
        return;
    };
    let h = |z: f64, g: f64| HeightModel {
        z_mm: z,
        model: Arx::new(
            vec![1.0, -1.2, 0.35],
            vec![
                (vec![0.004 * g, -0.001], 1),
                (vec![0.002 * g], 1),
                (vec![0.0005, 0.0002], 2),
            ],
        )
        .unwrap(),
        stats: None,
    };
    let m = ThermalModel::new(
        5.0,
        vec![
            InputChannel::linear("speed_rpm", 8000.0),
            InputChannel {
                name: "speed_rpm".into(),
                scale: 8000.0,
                power: 2,
            },
            InputChannel::linear("t_spindle_c", 20.0),
        ],
        vec![h(-200.0, 1.0), h(0.0, 1.5), h(-50.0, 0.7)],
    )
    .unwrap();
    let files = linuxcnc_thermal::export(&m).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let py = dir.path().join("mtwin_thermal.py");
    std::fs::write(&py, &files[0].1).unwrap();
    let rows: Vec<[f64; 2]> = (0..40)
        .map(|k| {
            let s = [0.0, 6000.0, 3000.0, 8000.0, 0.0][(k / 7) % 5];
            [s, 20.0 + 0.3 * k as f64]
        })
        .collect();
    let zs = [-300.0, -200.0, -120.0, -50.0, -10.0, 0.0, 40.0];
    let out = std::process::Command::new(python)
        .arg("-c")
        .arg(OFFLINE)
        .arg(&py)
        .arg(serde_json::to_string(&rows).unwrap())
        .arg(serde_json::to_string(&zs).unwrap())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let got: Vec<Vec<f64>> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(got.len(), rows.len() + 1);
    let mut p = m.predictor();
    let mut worst = 0.0f64;
    let mut biggest = 0.0f64;
    // Python's row k is the drift once period k has been read at kT, i.e.
    // e(kT) (the values of period k act from (k+1)T on).
    for (k, g) in got.iter().enumerate() {
        for (z, v) in zs.iter().zip(g) {
            let want = p.drift(*z).mm;
            worst = worst.max((v - want).abs());
            biggest = biggest.max(want.abs());
        }
        if k < rows.len() {
            p.advance(&rows[k]);
        }
    }
    eprintln!("component model vs predictor: {worst:.2e} mm over drifts up to {biggest:.3} mm");
    assert!(biggest > 0.01, "drift {biggest}");
    // Means of four held quarters differ from the value by rounding only.
    assert!(worst < 1e-14, "component off the predictor by {worst} mm");
}
