//! ISO 230-2 positioning: the real ecmc run (`../shared/corpus/positioning/
//! ecmc-muts-b02-x`) checked against a computation written here from the
//! standard's formulas, the raw log against the extracted table, and bad input.

use std::path::{Path, PathBuf};

use mtwin::methods::positioning::{self, InputFormat, LogOptions, Options};

fn real_dir() -> Option<PathBuf> {
    crate::shared::shared_dir("corpus/positioning/ecmc-muts-b02-x")
}

/// `(targets, fwd[i][j], bwd[i][j])` read by hand from the `.dat` file, mm.
fn parse_dat_by_hand(path: &Path) -> (Vec<f64>, Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut tgt = vec![f64::NAN; 9];
    let mut fwd = vec![vec![f64::NAN; 5]; 9];
    let mut bwd = vec![vec![f64::NAN; 5]; 9];
    for l in text.lines() {
        let Some((k, v)) = l.split_once('=') else {
            continue;
        };
        let Some(ix) = k.strip_suffix(']').and_then(|k| k.split_once('[')) else {
            continue;
        };
        let v: f64 = v.trim().parse().unwrap();
        let idx: Vec<usize> = ix.1.split(',').map(|s| s.parse().unwrap()).collect();
        match ix.0 {
            "TGT_DATA" => tgt[idx[0] - 1] = v,
            "REF_DATA_FWD" => fwd[idx[0] - 1][idx[1] - 1] = v,
            "REF_DATA_BWD" => bwd[idx[0] - 1][idx[1] - 1] = v,
            _ => {}
        }
    }
    (tgt, fwd, bwd)
}

struct Figures {
    a: f64,
    b: f64,
    e: f64,
    m: f64,
    r: f64,
    r_up: f64,
    r_down: f64,
    e_up: f64,
    e_down: f64,
    a_up: f64,
    a_down: f64,
}

/// ISO 230-2 written out in the plainest way, µm.
fn by_hand(tgt: &[f64], up: &[Vec<f64>], down: &[Vec<f64>]) -> Figures {
    let n = up[0].len() as f64;
    let stat = |p: &Vec<f64>, t: f64| {
        let x: Vec<f64> = p.iter().map(|v| (v - t) * 1000.0).collect();
        let mut sum = 0.0;
        for v in &x {
            sum += v;
        }
        let mean = sum / n;
        let mut ss = 0.0;
        for v in &x {
            ss += (v - mean) * (v - mean);
        }
        (mean, (ss / (n - 1.0)).sqrt())
    };
    let mut f = Figures {
        a: 0.0,
        b: 0.0,
        e: 0.0,
        m: 0.0,
        r: 0.0,
        r_up: 0.0,
        r_down: 0.0,
        e_up: 0.0,
        e_down: 0.0,
        a_up: 0.0,
        a_down: 0.0,
    };
    let (mut hi_u, mut lo_u, mut hi_d, mut lo_d) = (-1e9, 1e9, -1e9, 1e9);
    let (mut ahi_u, mut alo_u, mut ahi_d, mut alo_d) = (-1e9, 1e9, -1e9, 1e9);
    let (mut hi_m, mut lo_m) = (-1e9, 1e9);
    for i in 0..tgt.len() {
        let (mu, su) = stat(&up[i], tgt[i]);
        let (md, sd) = stat(&down[i], tgt[i]);
        let bi = mu - md;
        f.b = f64::max(f.b, bi.abs());
        f.r_up = f64::max(f.r_up, 4.0 * su);
        f.r_down = f64::max(f.r_down, 4.0 * sd);
        let ri = f64::max(2.0 * su + 2.0 * sd + bi.abs(), f64::max(4.0 * su, 4.0 * sd));
        f.r = f64::max(f.r, ri);
        hi_u = f64::max(hi_u, mu);
        lo_u = f64::min(lo_u, mu);
        hi_d = f64::max(hi_d, md);
        lo_d = f64::min(lo_d, md);
        ahi_u = f64::max(ahi_u, mu + 2.0 * su);
        alo_u = f64::min(alo_u, mu - 2.0 * su);
        ahi_d = f64::max(ahi_d, md + 2.0 * sd);
        alo_d = f64::min(alo_d, md - 2.0 * sd);
        hi_m = f64::max(hi_m, (mu + md) / 2.0);
        lo_m = f64::min(lo_m, (mu + md) / 2.0);
    }
    f.e_up = hi_u - lo_u;
    f.e_down = hi_d - lo_d;
    f.e = f64::max(hi_u, hi_d) - f64::min(lo_u, lo_d);
    f.a_up = ahi_u - alo_u;
    f.a_down = ahi_d - alo_d;
    f.a = f64::max(ahi_u, ahi_d) - f64::min(alo_u, alo_d);
    f.m = hi_m - lo_m;
    f
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (tolerance {tol})");
}

#[test]
fn real_ecmc_table_figures_match_a_computation_written_in_the_test() {
    let Some(dir) = real_dir() else { return };
    let dat = dir.join("target_x_ISO230.dat");
    let doc = positioning::run(&dat, &Options::default()).expect("the real table reads");
    let (tgt, fwd, bwd) = parse_dat_by_hand(&dat);
    let f = by_hand(&tgt, &fwd, &bwd);
    assert_eq!((doc.targets, doc.cycles), (9, 5));
    for (got, want, what) in [
        (doc.a_um, f.a, "A"),
        (doc.a_up_um, f.a_up, "A_up"),
        (doc.a_down_um, f.a_down, "A_down"),
        (doc.b_um, f.b, "B"),
        (doc.e_um, f.e, "E"),
        (doc.e_up_um, f.e_up, "E_up"),
        (doc.e_down_um, f.e_down, "E_down"),
        (doc.m_um, f.m, "M"),
        (doc.r_um, f.r, "R"),
        (doc.r_up_um, f.r_up, "R_up"),
        (doc.r_down_um, f.r_down, "R_down"),
    ] {
        close(got, want, 1e-9, what);
    }
    // The figures of the tool's own report that are right (it prints mm to
    // 5 decimals): A, M and B agree; its "forward" table holds the readings
    // of the backward (decreasing) approaches, so its E_fwd, R_fwd are E↓,
    // R↓ here, and its E (= its E_fwd) and R (= max of R_fwd, R_bwd) are not
    // the ISO 230-2 E and R.
    close(doc.a_um, 135.27, 0.01, "A against the report");
    close(doc.m_um, 93.65, 0.01, "M against the report");
    close(doc.b_um, 33.58, 0.01, "B against the report");
    close(
        doc.e_down_um,
        90.65,
        0.01,
        "E_down against the report's E_fwd",
    );
    close(doc.e_up_um, 98.03, 0.01, "E_up against the report's E_bwd");
    close(
        doc.r_down_um,
        28.31,
        0.01,
        "R_down against the report's R_fwd",
    );
    assert!(doc.e_um > doc.e_up_um.max(doc.e_down_um) + 20.0);
    assert!(
        doc.r_um > 50.0,
        "R = max Ri includes the reversal: {}",
        doc.r_um
    );
}

#[test]
fn real_ecmc_raw_log_agrees_with_the_extracted_table() {
    let Some(dir) = real_dir() else { return };
    let log = dir.join("x_230_2_edit.log");
    // Scaling of the triangulation sensor as the tool's report gives it.
    let opts = Options {
        format: InputFormat::Log,
        log: LogOptions {
            reference: Some("IOC_TEST:ILD_DownSample".into()),
            command: Some("TARGET_DU:X-PosCmd".into()),
            gain: -1.0035779146,
            offset: 50.3193131396,
            ..LogOptions::default()
        },
    };
    let doc = positioning::run(&log, &opts).expect("the raw log reads");
    assert_eq!((doc.targets, doc.cycles), (9, 5));
    let (tgt, fwd, bwd) = parse_dat_by_hand(&dir.join("target_x_ISO230.dat"));
    // The table holds the last single sample before each test-number mark;
    // the log reader averages the dwell: the two agree to a few µm.
    for (i, row) in doc.per_target.iter().enumerate() {
        close(row.target_mm, tgt[i], 1e-12, "target");
        for j in 0..5 {
            close(
                row.deviations_up_um[j],
                (fwd[i][j] - tgt[i]) * 1000.0,
                3.0,
                "x↑ij",
            );
            close(
                row.deviations_down_um[j],
                (bwd[i][j] - tgt[i]) * 1000.0,
                3.0,
                "x↓ij",
            );
        }
    }
    let notes = doc.notes.join("\n");
    assert!(notes.contains("-20.5 mm (not a target) ×5"), "{notes}");
    assert!(notes.contains("20.5 mm (not a target) ×5"), "{notes}");
    assert!(notes.contains("first command"), "{notes}");
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn csv_table_gives_closed_form_figures() {
    // Two targets, two cycles: deviations chosen so every figure is a sum by eye.
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "run.csv",
        "target_mm,direction,cycle,deviation_um\n\
         0,up,1,1\n0,up,2,3\n0,down,1,-1\n0,down,2,-1\n\
         100,up,1,10\n100,up,2,10\n100,down,1,4\n100,down,2,6\n",
    );
    let doc = positioning::run(&p, &Options::default()).unwrap();
    let s = std::f64::consts::SQRT_2; // std of {1,3} and of {4,6}
    // x̄↑ = 2, 10; x̄↓ = -1, 5; B = 3, 5
    close(doc.b_um, 5.0, 1e-12, "B");
    close(doc.b_mean_um, 4.0, 1e-12, "B mean");
    close(doc.e_up_um, 8.0, 1e-12, "E up");
    close(doc.e_down_um, 6.0, 1e-12, "E down");
    close(doc.e_um, 11.0, 1e-12, "E");
    close(doc.m_um, 7.5 - 0.5, 1e-12, "M");
    close(doc.r_up_um, 4.0 * s, 1e-12, "R up");
    close(doc.r_down_um, 4.0 * s, 1e-12, "R down");
    close(doc.r_um, (2.0 * s + 5.0).max(3.0 + 2.0 * s), 1e-12, "R");
    close(doc.a_um, 10.0 - (-1.0), 1e-12, "A");
    close(doc.a_up_um, 10.0 - (2.0 - 2.0 * s), 1e-12, "A up");
    // the plot carries both directions
    let svg = positioning::plot_svg(&doc);
    assert!(svg.contains("class=\"mean-up\"") && svg.contains("class=\"readings-down\""));
}

#[test]
fn bad_runs_are_clear_errors_with_file_line_column() {
    let dir = tempfile::tempdir().unwrap();
    let one = write(
        dir.path(),
        "one.csv",
        "target_mm,direction,measured_mm\n0,up,0.001\n0,up,0.002\n10,up,10.001\n10,up,10.0\n",
    );
    let e = positioning::run(&one, &Options::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("one.csv:2:1: one direction only"), "{e}");

    let dat = write(
        dir.path(),
        "short.dat",
        "UNIT=mm\nCYCLES=2\nTGT_DATA[1]=0\nTGT_DATA[2]=5\n\
         REF_DATA_FWD[1,1]=0.001\nREF_DATA_FWD[1,2]=0.002\nREF_DATA_FWD[2,1]=5.001\n\
         REF_DATA_BWD[1,1]=0\nREF_DATA_BWD[1,2]=0\nREF_DATA_BWD[2,1]=5\nREF_DATA_BWD[2,2]=5\n",
    );
    let e = positioning::run(&dat, &Options::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("short.dat:7:1: cycles of unequal length"), "{e}");

    // A log whose move to 2 mm stops at 1 mm.
    let mut log = String::new();
    let mut t = 0.0;
    let mut add = |name: &str, v: f64, log: &mut String| {
        t += 0.1;
        log.push_str(&format!("{name} 2024-01-01 00:00:{t:09.6} {v}\n"));
    };
    for (c, r) in [(0.0, 0.0), (1.0, 1.0), (2.0, 1.0), (0.0, 0.0)] {
        add("CMD", c, &mut log);
        for _ in 0..4 {
            add("REF", r, &mut log);
        }
    }
    let p = write(dir.path(), "run.log", &log);
    let opts = Options {
        format: InputFormat::Auto,
        log: LogOptions {
            reference: Some("REF".into()),
            command: Some("CMD".into()),
            targets_mm: Some(vec![0.0, 1.0, 2.0]),
            ..LogOptions::default()
        },
    };
    let e = positioning::run(&p, &opts).unwrap_err().to_string();
    assert!(
        e.contains("run.log:11:32: target 2 mm never reached"),
        "{e}"
    );
}

#[test]
fn rtx_capture_dwells_become_approaches() {
    // 100 Hz capture: for each of 2 cycles, 0 → 10 → 20 → 20.5 → 20 → 10 → 0 → -0.5 → (next);
    // each dwell 1 s at target + known deviation, moves 0.5 s linear.
    let dev =
        |t: f64, up: bool, c: usize| (if up { 0.002 } else { -0.003 }) + t * 1e-4 + c as f64 * 1e-4;
    let mut x: Vec<f64> = Vec::new();
    let mut at = 0.0_f64;
    let mut go = |to: f64, hold: f64, x: &mut Vec<f64>| {
        for k in 1..=50 {
            x.push(at + (to - at) * k as f64 / 50.0);
        }
        x.extend(std::iter::repeat_n(to + hold, 100));
        at = to + hold;
    };
    go(-0.5, 0.0, &mut x);
    for c in 0..2 {
        for t in [0.0, 10.0, 20.0] {
            go(t, dev(t, true, c), &mut x);
        }
        go(20.5, 0.0, &mut x);
        for t in [20.0, 10.0, 0.0] {
            go(t, dev(t, false, c), &mut x);
        }
        go(-0.5, 0.0, &mut x);
    }
    let mut bytes =
        b"HEADER::\r\nOwner: test\r\nSample rate: 100\r\nActual sample rate: 100\r\nData:\r\n"
            .to_vec();
    for v in &x {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes.extend_from_slice(b"EOF::\r\n");
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cap.rtx");
    std::fs::write(&p, &bytes).unwrap();
    let opts = Options {
        format: InputFormat::Auto,
        log: LogOptions {
            targets_mm: Some(vec![0.0, 10.0, 20.0]),
            ..LogOptions::default()
        },
    };
    let doc = positioning::run(&p, &opts).unwrap();
    assert_eq!((doc.targets, doc.cycles), (3, 2));
    for (i, t) in [0.0, 10.0, 20.0].iter().enumerate() {
        for c in 0..2 {
            close(
                doc.per_target[i].deviations_up_um[c],
                dev(*t, true, c) * 1000.0,
                1e-6,
                "up",
            );
            close(
                doc.per_target[i].deviations_down_um[c],
                dev(*t, false, c) * 1000.0,
                1e-6,
                "down",
            );
        }
    }
    // no targets given: a clear error
    let e = positioning::run(&p, &Options::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("give the target positions"), "{e}");
}
