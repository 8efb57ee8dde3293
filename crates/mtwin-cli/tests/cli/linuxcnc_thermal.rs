//! Live thermal compensation on LinuxCNC: the files `mtwin export --thermal
//! … --to linuxcnc` writes (`mtwin_thermal.py`, `thermal.hal`,
//! `thermal-README.txt`) put into LinuxCNC 2.9's simulator the way a user
//! does: the files beside the ini, and the README's ini lines added to it
//! (`[HAL] HALFILE = thermal.hal`, `[AXIS_Z] OFFSET_AV_RATIO`); the harness
//! only adds sampling (and, for the replay, the streamer). The Z external
//! offset LinuxCNC applies is compared with `mtwin thermal predict`
//! ([`run_predict`]) on the period means of the inputs the simulator's pins
//! held.
//!
//! The test models have a period of 0.025 min (1.5 s), so a run of tens of
//! seconds spans a dozen periods; the component's clock is the servo
//! thread's time (`thermal.hal`'s `integ`), so a period is 1500 servo
//! periods however late the non-realtime simulator runs.

use mtwin::controller::linuxcnc_thermal::{self, CLOCK_NAME, RESOLUTION_MM};
use mtwin::methods::thermal::{
    HeightModel, InputChannel, PredictRunOptions, ThermalModel, run_predict,
};
use mtwin::sysid::Arx;

use crate::linuxcnc_sim::{SHORT, SimSetup, Trace, available, run_or_panic};

/// The test models' period, min (1.5 s).
const PERIOD_MIN: f64 = 0.025;
/// Z held by the programs, mm.
const Z_MM: f64 = 20.0;

/// The two-height model of docs/thermal-compensation.md (its 10 min period
/// shortened to [`PERIOD_MIN`]), heights moved into the simulator's Z travel
/// (±120 mm), with an optional temperature input `t5_c` (scale 40 °C).
fn model(temperature: bool) -> ThermalModel {
    let h = |z: f64, b: [f64; 2]| {
        let mut inputs = vec![(b.to_vec(), 1)];
        if temperature {
            inputs.push((vec![0.0004, -0.0003], 1));
        }
        HeightModel {
            z_mm: z,
            model: Arx::new(vec![1.0, -1.605827, 0.627089], inputs).unwrap(),
            stats: None,
        }
    };
    let mut inputs = vec![InputChannel::linear("speed_rpm", 8000.0)];
    if temperature {
        inputs.push(InputChannel::linear("t5_c", 40.0));
    }
    ThermalModel::new(
        PERIOD_MIN,
        inputs,
        vec![
            h(-100.0, [-0.0062836, 0.0057508]),
            h(100.0, [-0.0070963, 0.0062955]),
        ],
    )
    .unwrap()
}

/// The extra columns the tests sample, after one column per model input.
const CLOCK: usize = 0;
const COUNTS: usize = 1;
const DRIFT: usize = 2;
const SAMPLE: usize = 3;
const TIME: usize = 4;
const Z: usize = 5;
const EOFFSET: usize = 6;
const HOMED: usize = 7;

/// The simulator set-up from the exported files as a user installs them:
/// the files beside the ini and the README's ini lines added to it. Then
/// the test's `hal` lines (run after the configuration's HAL files), and
/// sampling of the signals `inputs` (one per model input, in order), the
/// component's clock and outputs, the applied offset and whether every
/// joint is homed.
fn setup_from_export(files: &[(String, String)], hal: &[String], inputs: &[&str]) -> SimSetup {
    let mut setup = SimSetup::default();
    let mut section = String::new();
    let mut readme = false;
    for (name, text) in files {
        setup = setup.file(name, text.clone());
        if name == linuxcnc_thermal::README_FILE {
            readme = true;
            for line in text.lines().map(str::trim) {
                if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                    section = s.to_string();
                } else if let Some((k, v)) = line.split_once(" = ")
                    && !section.is_empty()
                {
                    setup = setup.ini_add(&section, k.trim(), v.trim());
                }
            }
        }
    }
    assert!(readme, "the export writes the README");
    assert!(
        setup.ini_added.iter().any(
            |e| (e.0.as_str(), e.1.as_str(), e.2.as_str()) == ("HAL", "HALFILE", "thermal.hal")
        ),
        "the README adds [HAL] HALFILE = thermal.hal: {:?}",
        setup.ini_added
    );
    assert!(
        setup.ini_added.iter().any(|e| e.1 == "OFFSET_AV_RATIO"),
        "the README gives OFFSET_AV_RATIO"
    );
    for l in hal {
        setup = setup.hal(l.clone());
    }
    let setup = setup
        .hal("net mtwin-t-drift mtwin-thermal.drift-mm")
        .hal("net mtwin-t-sample mtwin-thermal.sample")
        .hal("net mtwin-t-time mtwin-thermal.time-s")
        .hal("net mtwin-t-z mtwin-thermal.z-mm")
        .hal("net mtwin-t-eoffset axis.z.eoffset")
        .hal("net mtwin-t-homed motion.is-all-homed");
    let mut setup = inputs.iter().fold(setup, |s, sig| s.sample('f', sig));
    for (ty, sig) in [
        ('f', CLOCK_NAME),
        ('s', "mtwin-thermal-counts"),
        ('f', "mtwin-t-drift"),
        ('s', "mtwin-t-sample"),
        ('f', "mtwin-t-time"),
        ('f', "mtwin-t-z"),
        ('f', "mtwin-t-eoffset"),
        ('b', "mtwin-t-homed"),
    ] {
        setup = setup.sample(ty, sig);
    }
    setup
}

/// What [`compare_with_predict`] measured.
#[derive(Debug)]
struct Compared {
    /// Periods spanned by the run.
    periods: usize,
    /// Largest gap between the component's polls, s.
    gap: f64,
    /// Largest bound on the component's drift against the prediction, mm.
    bound: f64,
    /// Component's drift against `mtwin thermal predict`, mm.
    model: f64,
    /// Applied offset against minus the prediction on settled rows, mm.
    applied: f64,
    /// Rows where the offset had settled.
    settled: usize,
    /// Rows not read across one of the component's polls (checked whole).
    checked: usize,
    /// Changes of the counts.
    steps: usize,
    /// Largest applied offset, mm.
    max_offset: f64,
    /// Rows sampled while a joint was not homed.
    unhomed: usize,
    /// The period means of the inputs, one row per period.
    means: Vec<Vec<f64>>,
}

impl Compared {
    /// Prints what was measured (`what`: the run's name; `rows`: its sampled
    /// rows) and asserts the live compensation's targets: a drift of several
    /// µm changing at least every period, the offset settled on more than half
    /// the rows, and the applied offset within 0.1 µm of `thermal predict`.
    fn print_and_check(&self, what: &str, rows: usize) {
        let c = self;
        eprintln!(
            "{what}: {rows} rows, {} periods of {} s, poll gap {:.4} s, {} offset changes, \
             largest offset {:.3} µm; component vs thermal predict {:.2e} µm (bound {:.2e} µm), \
             applied vs thermal predict {:.2e} µm on {} settled rows; drift and counts checked \
             on {} rows; {} rows with a joint not homed",
            c.periods,
            PERIOD_MIN * 60.0,
            c.gap,
            c.steps,
            c.max_offset * 1e3,
            c.model * 1e3,
            c.bound * 1e3,
            c.applied * 1e3,
            c.settled,
            c.checked,
            c.unhomed
        );
        assert!(c.max_offset > 2e-3, "largest offset {} mm", c.max_offset);
        assert!(c.steps >= 8, "{} offset changes", c.steps);
        assert!(c.settled > rows / 2, "{} settled rows", c.settled);
        assert!(c.checked > rows / 2, "drift checked on {} rows", c.checked);
        // The target the live compensation is held to: 0.1 µm.
        assert!(
            c.applied <= 1e-4,
            "applied offset off by {} mm (target 0.1 µm)",
            c.applied
        );
    }
}

/// Compares a run with `mtwin thermal predict`: the inputs the pins held
/// (the first `m.columns().len()` extra columns, each value holding for one
/// servo period from its clock value) are averaged over the model's
/// periods, written as `SPEED.csv` beside the model file and predicted by
/// [`run_predict`] at the model's heights and [`Z_MM`]. Asserts, row by row:
/// the component's drift equals the prediction at its tool height within
/// the bound its polls allow, its counts are minus the drift in nm, and once
/// the offset has settled (0.1 s without a change of the counts) the offset
/// LinuxCNC applies is minus the prediction within that bound plus half a
/// count plus LinuxCNC's stopping tolerance, and the counts within the
/// stopping tolerance.
fn compare_with_predict(t: &Trace, m: &ThermalModel, av_ratio: f64) -> Compared {
    let nin = m.columns().len();
    let x: Vec<&[f64]> = t.extra.iter().map(|r| &r[nin..]).collect();
    let u: Vec<&[f64]> = t.extra.iter().map(|r| &r[..nin]).collect();
    let dt = t.period;
    assert_eq!(x.len(), t.samples.len());
    // The servo clock advances one period per row.
    for (i, w) in x.windows(2).enumerate() {
        assert!(
            ((w[1][CLOCK] - w[0][CLOCK]) - dt).abs() < 1e-9,
            "clock step at row {i}: {} then {}",
            w[0][CLOCK],
            w[1][CLOCK]
        );
    }
    let period = m.period_min() * 60.0;
    let last_clock = x[x.len() - 1][CLOCK];
    let n_periods = (last_clock / period).floor() as usize + 2;
    let mut means = vec![vec![0.0; nin]; n_periods];
    // Sum of the jumps of each input inside each period (for the bound).
    let mut jump = vec![vec![0.0f64; nin]; n_periods];
    for (i, r) in x.iter().enumerate() {
        let k = (r[CLOCK] / period).floor() as usize;
        for c in 0..nin {
            means[k][c] += u[i][c] * dt / period;
            if i > 0 {
                jump[k][c] += (u[i][c] - u[i - 1][c]).abs();
            }
        }
    }

    // `mtwin thermal predict` on those means.
    let dir = tempfile::tempdir().unwrap();
    let model_path = dir.path().join("thermal.toml");
    m.write(&model_path).unwrap();
    let mut csv = format!("t_min,{}\n", m.columns().join(","));
    for (k, v) in means.iter().enumerate() {
        let v: Vec<String> = v.iter().map(|x| format!("{x}")).collect();
        csv += &format!("{},{}\n", k as f64 * m.period_min(), v.join(","));
    }
    let speed_path = dir.path().join("speed.csv");
    std::fs::write(&speed_path, csv).unwrap();
    let zs: Vec<f64> = m.heights().iter().map(|h| h.z_mm).collect();
    let (z_lo, z_hi) = (zs[0], zs[zs.len() - 1]);
    assert!(z_lo < Z_MM && Z_MM < z_hi);
    let mut options = PredictRunOptions::default();
    options.heights = vec![z_lo, Z_MM, z_hi];
    let run = run_predict(&model_path, &speed_path, &options).unwrap();
    let rows = &run.prediction.rows;
    assert_eq!(rows.len(), 3 * n_periods);
    // Prediction at period k: e(kT) at Z_MM, and its slope across heights.
    let at = |k: usize| -> (f64, f64) {
        let r = &rows[3 * k..3 * k + 3];
        assert!((r[1][0] - k as f64 * m.period_min()).abs() < 1e-9);
        (r[1][2], (r[2][2] - r[0][2]) / (z_hi - z_lo))
    };

    // The component's poll interval in clock time (largest gap between
    // the clock values it reports).
    let mut gap = 0.0f64;
    let mut last = x[0][TIME];
    let mut since = 0usize;
    for r in &x {
        if r[TIME] != last {
            gap = gap.max(r[TIME] - last);
            last = r[TIME];
            since = 0;
        } else {
            since += 1;
            gap = gap.max(since as f64 * dt);
        }
    }
    // The component holds the value it read at a poll until the next one,
    // the test one servo period: a jump of size J inside period j moves the
    // period's mean by at most δ_j = J·(gap + dt)/T. The drift e(kT) then
    // moves by at most Σ_inputs Σ_j |h(k − j)|·δ_j/scale, h the model's
    // response to a unit of that input in period 0 (largest of the
    // heights; the interpolation across heights is a convex combination).
    let n = n_periods + 1;
    let bound: Vec<f64> = (0..n)
        .map(|k| {
            m.heights()
                .iter()
                .map(|h| {
                    let mut b = 0.0;
                    for (c, ch) in m.inputs().iter().enumerate() {
                        assert_eq!(ch.power, 1, "the bound is for linear inputs");
                        let col = m.columns().iter().position(|n| *n == ch.name).unwrap();
                        let mut unit = vec![vec![0.0; n]; m.inputs().len()];
                        unit[c][0] = 1.0;
                        let refs: Vec<&[f64]> = unit.iter().map(Vec::as_slice).collect();
                        let imp = h.model.simulate(&refs).unwrap();
                        b += (0..k.min(n_periods))
                            .map(|j| {
                                imp[k - j].abs() * jump[j][col] * (gap + dt) / period / ch.scale
                            })
                            .sum::<f64>();
                    }
                    b
                })
                .fold(0.0, f64::max)
                + 1e-12
        })
        .collect();
    let bound_max = bound.iter().copied().fold(0.0, f64::max);

    // LinuxCNC moves the offset with its single-axis planner (simple_tp),
    // which stops once within TINY_DP = max_acc · period² · 0.001 of the
    // request, max_acc being OFFSET_AV_RATIO times the axis'
    // MAX_ACCELERATION (300 mm/s² here).
    let tiny_dp = av_ratio * 300.0 * dt * dt * 0.001 + 1e-12;
    let mut c = Compared {
        periods: n_periods,
        gap,
        bound: bound_max,
        model: 0.0,
        applied: 0.0,
        settled: 0,
        checked: 0,
        steps: 0,
        max_offset: 0.0,
        unhomed: 0,
        means: means.clone(),
    };
    let mut quiet = 0usize;
    // Rows since every joint was homed (0 while one is not), and the
    // counts when homing began.
    let mut homed_for = 0usize;
    let mut held: Option<f64> = None;
    for (i, r) in x.iter().enumerate() {
        // LinuxCNC drops changes of the counts while a joint is not homed;
        // the component holds them then, and follows the drift again at
        // its first poll once every joint is (a poll gap later at most).
        if r[HOMED] != 0.0 {
            homed_for += 1;
            held = None;
        } else {
            homed_for = 0;
            let h = *held.get_or_insert(x[i.saturating_sub(1)][COUNTS]);
            assert_eq!(
                r[COUNTS], h,
                "row {i}: the counts changed while a joint was not homed"
            );
            c.unhomed += 1;
        }
        let following = homed_for as f64 * dt > gap + dt;
        // The component, a userspace process, writes its pins one after
        // the other while the servo thread samples them, so a row may mix
        // values from before and after one of its polls (seen: the drift of
        // a new period beside the counts of the last), and under load the
        // process may be descheduled between two writes for longer than a
        // servo period. It writes `sample` first and `time-s` last, so a
        // row read in the middle of a poll that crossed a period end has
        // sample k beside a time outside period k. Checked: the rows whose
        // sample and time agree (as the component computes k: the largest
        // with k·T <= time) and whose outputs all hold into the next row;
        // as each poll's values hold for several servo periods (polls 5 ms
        // or more apart), every poll's values are.
        let k = r[SAMPLE] as usize;
        let consistent = k as f64 * period <= r[TIME] && r[TIME] < (k + 1) as f64 * period;
        let whole = following
            && consistent
            && x.get(i + 1).is_some_and(|n| {
                [COUNTS, DRIFT, SAMPLE, TIME, Z]
                    .iter()
                    .all(|&j| n[j] == r[j])
            });
        if whole {
            c.checked += 1;
        }
        assert!(k < n_periods, "sample {k} beyond the run");
        let (e, slope) = at(k);
        // The height the component read differs from Z_MM by the offset
        // (µm): the prediction there, by the slope across heights.
        let want = e + slope * (r[Z] - Z_MM);
        let d = (r[DRIFT] - want).abs();
        c.model = c.model.max(d);
        assert!(
            !whole || d <= bound[k] + 1e-12,
            "row {i}, sample {k}: component off `thermal predict` by {d} mm (bound {})",
            bound[k]
        );
        let dc = (r[COUNTS] * RESOLUTION_MM + r[DRIFT]).abs();
        assert!(
            !whole || dc <= 0.5 * RESOLUTION_MM + 1e-12,
            "row {i}: counts off by {dc} mm"
        );
        if i > 0 && r[COUNTS] != x[i - 1][COUNTS] {
            c.steps += 1;
            quiet = 0;
        } else {
            quiet += 1;
        }
        if quiet > 100 && following {
            c.settled += 1;
            let a = (r[EOFFSET] + want).abs();
            c.applied = c.applied.max(a);
            assert!(
                a <= bound[k] + 0.5 * RESOLUTION_MM + tiny_dp,
                "row {i}: applied offset off `thermal predict` by {a} mm"
            );
            let d = (r[EOFFSET] - r[COUNTS] * RESOLUTION_MM).abs();
            assert!(
                d <= tiny_dp,
                "row {i}: applied {} for counts {}",
                r[EOFFSET],
                r[COUNTS]
            );
        }
        c.max_offset = c.max_offset.max(r[EOFFSET].abs());
        // The prediction across heights is linear between the two ends.
        assert!(z_lo <= r[Z] && r[Z] <= z_hi, "row {i}: z {}", r[Z]);
    }
    c
}

/// `OFFSET_AV_RATIO` as the README set it.
fn av_ratio(setup: &SimSetup) -> f64 {
    setup
        .ini_added
        .iter()
        .find(|e| e.1 == "OFFSET_AV_RATIO")
        .map(|e| e.2.parse().unwrap())
        .unwrap()
}

#[test]
fn exported_thermal_component_drives_the_z_offset_as_mtwin_predicts() {
    if !available() {
        return;
    }
    let m = model(false);
    let files = linuxcnc_thermal::export(&m).unwrap();
    // The speed input as thermal.hal connects it: the commanded spindle speed.
    let setup = setup_from_export(&files, &[], &["mtwin-thermal-speed"]);
    // 6000 rev/min for 6 s (four periods), 2000 for 4.5 s, stopped for
    // 4.5 s; Z holds at 20 mm (between the heights, weight 0.6 on z = 100).
    let program = "G21 G90 G94\nG0 X0 Y0 Z20\nS6000 M3\nG4 P6\nS2000\nG4 P4.5\nM5\nG4 P4.5\nM2\n";
    let t = run_or_panic("thermal", program, &setup, SHORT);
    let speed: Vec<f64> = t.extra.iter().map(|r| r[0]).collect();
    assert_eq!(speed[0], 0.0, "the spindle is off when sampling starts");
    assert_eq!(speed[speed.len() - 1], 0.0, "and off at the end");
    assert!(speed.contains(&6000.0) && speed.contains(&2000.0));
    let c = compare_with_predict(&t, &m, av_ratio(&setup));
    c.print_and_check("thermal", t.extra.len());
}

/// Servo periods each entry of the replayed record holds (40 ms).
const HOLD: usize = 40;

/// The recorded sequence replayed: from the real record
/// `../shared/data/real/fl-thermal-first60.csv` (every 15 s), every 8th row
/// (2 min) of its first 2400 (10 h: the spindle at 0, 1250, 0 and 2500
/// rev/min), the spindle speed and the temperature `t5_c` (30.5–41.8 °C,
/// the one that moves most). `None` when the shared data is absent.
fn recorded_sequence() -> Option<Vec<[f64; 2]>> {
    let path = crate::shared::shared_dir("data/real/fl-thermal-first60.csv")?;
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (s, t) = (col("speed_rpm"), col("t5_c"));
    Some(
        lines
            .take(2400)
            .step_by(8)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                [f[s].parse().unwrap(), f[t].parse().unwrap()]
            })
            .collect(),
    )
}

#[test]
fn recorded_speed_and_temperature_streamed_into_the_pins_give_thermal_predicts_offset() {
    if !available() {
        return;
    }
    let Some(record) = recorded_sequence() else {
        return;
    };
    assert_eq!(record.len(), 300);
    let m = model(true);
    assert_eq!(m.columns(), ["speed_rpm", "t5_c"]);
    let mut files = linuxcnc_thermal::export(&m).unwrap();
    // The stream: one line per servo period (halstreamer's format: the
    // values of the streamer's pins, whitespace-separated).
    let mut stream = String::from("# speed_rpm t5_c, one line per servo period\n");
    for r in &record {
        for _ in 0..HOLD {
            stream += &format!("{} {}\n", r[0], r[1]);
        }
    }
    let n_rows = record.len() * HOLD;
    files.push(("replay.txt".into(), stream));
    // LinuxCNC's streamer on the servo thread, enabled with the sampler;
    // the speed input taken off the commanded spindle speed (thermal.hal's
    // net) and both inputs driven by the stream instead, the temperature
    // as thermal.hal's comment says to connect a sensor.
    let hal: Vec<String> = [
        format!("loadrt streamer depth={} cfg=ff", n_rows + 1000),
        "addf streamer.0 servo-thread".into(),
        "net mtwin-sample-on => streamer.0.enable".into(),
        "unlinkp mtwin-thermal.in.speed_rpm".into(),
        "net replay-speed streamer.0.pin.0 => mtwin-thermal.in.speed_rpm".into(),
        "net replay-temp streamer.0.pin.1 => mtwin-thermal.in.t5_c".into(),
        "loadusr -w halstreamer replay.txt".into(),
    ]
    .into();
    // The machine homes Z at 60 mm (its final move at 20 mm/s takes 3 s):
    // the drift from the stream, which starts with the servo thread, changes
    // at the first period mark (1.5 s) while Z is still homing, when
    // LinuxCNC drops changes of the counts.
    let setup = setup_from_export(&files, &hal, &["replay-speed", "replay-temp"])
        .ini("JOINT_2", "HOME", 60.0);
    // The stream lasts 12 s; Z holds at 20 mm for 13 s.
    let program = "G21 G90 G94\nG0 X0 Y0 Z20\nG4 P13\nM2\n";
    let t = run_or_panic("thermal replay", program, &setup, SHORT);
    // The pins held the record: the sampled rows are the stream's lines,
    // from the first (or one period later, by the order of the functions
    // on the servo thread), the last line held once the stream is out.
    let seq: Vec<[f64; 2]> = t.extra.iter().map(|r| [r[0], r[1]]).collect();
    let line = |j: usize| record[(j / HOLD).min(record.len() - 1)];
    let shift = (0..2)
        .find(|&s| (s..seq.len()).all(|i| seq[i] == line(i - s)))
        .unwrap_or_else(|| {
            let bad = (0..seq.len()).find(|&i| seq[i] != line(i)).unwrap();
            panic!(
                "row {bad}: the pins held {:?}, the stream {:?}",
                seq[bad],
                line(bad)
            )
        });
    assert!(seq[..shift].iter().all(|v| *v == [0.0, 0.0]));
    assert!(
        seq.len() >= n_rows,
        "{} rows for {n_rows} streamed",
        seq.len()
    );
    let c = compare_with_predict(&t, &m, av_ratio(&setup));
    // Homing (3.07 s of servo time for the final move alone) outlasts the
    // first period mark by far.
    assert!(
        c.unhomed as f64 * t.period > 1.5 * PERIOD_MIN * 60.0,
        "homing ended after {} rows: too soon after the first period mark",
        c.unhomed
    );
    let hot = c.means.iter().map(|v| v[1]).fold(0.0, f64::max);
    c.print_and_check(
        &format!(
            "thermal replay ({n_rows} streamed, shift {shift}, hottest period mean {hot:.2} °C)"
        ),
        seq.len(),
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
