//! `mtwin gcode interpolate` / `stats`: output format, values against closed
//! forms, errors with file:line:col and no partial output, and the commands
//! of docs/gcode.md.

use crate::common::*;

fn write(dir: &std::path::Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

fn csv(path: &std::path::Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn interpolate_writes_equally_spaced_samples_on_the_line() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "line.nc", "G1 X30 Y40 F600\n");
    let o = mtwin(
        dir.path(),
        &[
            "gcode",
            "interpolate",
            "--machine",
            &example("ac-trunnion.toml"),
            "line.nc",
            "--ts",
            "0.01",
            "--out",
            "cmd.csv",
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (header, rows) = csv(&dir.path().join("cmd.csv"));
    assert_eq!(header, "t_s,Y,X,Z,A,C");
    for (k, r) in rows.iter().enumerate() {
        assert!((r[0] - k as f64 * 0.01).abs() < 1e-9);
        // On the line from 0 to (30, 40): y = 4/3 x.
        assert!((r[1] - 4.0 / 3.0 * r[2]).abs() < 1e-9);
    }
    assert_eq!(&rows.last().unwrap()[1..], &[40.0, 30.0, 0.0, 0.0, 0.0]);
    // 50 mm at 10 mm/s = 5 s, plus the ramp: Y (4/5 of the path) limits the
    // path acceleration to 5000·5/4 mm/s², adding 10/(5000·5/4) s.
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let d = v["duration_s"].as_f64().unwrap();
    assert!((d - (5.0 + 10.0 / (5000.0 * 1.25))).abs() < 1e-9, "{d}");
    // The JSON is the library's `GcodeInterpolateDoc`, whose text is the human output.
    let doc: mtwin::gcode::GcodeInterpolateDoc =
        serde_json::from_str(&stdout(&o)).expect("stdout is a GcodeInterpolateDoc");
    assert_eq!(serde_json::to_value(&doc).unwrap(), v);
    assert_eq!(
        (doc.samples, doc.out.as_str()),
        (rows.len() as u64, "cmd.csv")
    );
    let human = mtwin(
        dir.path(),
        &[
            "gcode",
            "interpolate",
            "--machine",
            &example("ac-trunnion.toml"),
            "line.nc",
            "--ts",
            "0.01",
            "--out",
            "cmd.csv",
        ],
    );
    assert_eq!(human.status.code(), Some(0), "{}", stderr(&human));
    assert_eq!(stdout(&human), doc.to_string());
}

#[test]
fn errors_name_the_line_and_leave_no_output() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "bad.nc", "G1 X1 F600\nG1 X1Q\n");
    write(dir.path(), "far.nc", "G1 X10 F6000\nG1 X1000\n");
    let m = example("ac-trunnion.toml");
    let o = mtwin(
        dir.path(),
        &[
            "gcode",
            "interpolate",
            "--machine",
            &m,
            "bad.nc",
            "--out",
            "c.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("bad.nc:2:7"), "{}", stderr(&o));
    let o = mtwin(
        dir.path(),
        &[
            "gcode",
            "interpolate",
            "--machine",
            &m,
            "far.nc",
            "--out",
            "c.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("far.nc:2:") && e.contains("axis X") && e.contains("[-300, 300]"),
        "{e}"
    );
    assert!(!dir.path().join("c.csv").exists());
    let o = mtwin(dir.path(), &["gcode", "stats", "bad.nc"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("bad.nc:2:7"), "{}", stderr(&o));
}

#[test]
fn stats_reports_travel_violations() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "far.nc", "G1 X10 F600\nG1 X400 Y30\nG1 X0 Y0\n");
    // The JSON is the library's `GcodeStatsDoc`, whose text is the human output.
    let machine = example("ac-trunnion.toml");
    let (doc, v) = json_round_trip::<mtwin::gcode::GcodeStatsDoc>(
        dir.path(),
        &["gcode", "stats", "far.nc", "--machine", &machine],
    );
    assert_eq!(v["travel_violations"], 1);
    assert_eq!(v["violations"][0]["line"], 2);
    assert_eq!(v["violations"][0]["axis"], "X");
    // 10 + hypot(390, 30) + hypot(400, 30) mm.
    let len = 10.0 + 390f64.hypot(30.0) + 400f64.hypot(30.0);
    assert!((v["feed_length_mm"].as_f64().unwrap() - len).abs() < 1e-9);
    assert_eq!(doc.program, "far.nc");
    assert_eq!(doc.unreachable_lines.as_deref(), Some(&[][..]));

    // --strict: the same report, then exit code 1 naming the count.
    let strict = |prog: &str| {
        mtwin(
            dir.path(),
            &[
                "gcode",
                "stats",
                prog,
                "--machine",
                &example("ac-trunnion.toml"),
                "--strict",
            ],
        )
    };
    let o = strict("far.nc");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("far.nc:2: axis X at 400"),
        "{}",
        stdout(&o)
    );
    assert!(
        stderr(&o).contains("far.nc:2:1: axis X reaches 400 along the move")
            && stderr(&o).contains("1 move(s) outside the travel"),
        "{}",
        stderr(&o)
    );
    write(dir.path(), "near.nc", "G1 X10 F600\nG1 X0 Y0\n");
    let o = strict("near.nc");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Machine axes of the nominal `ac-trunnion` for the tool tip `tip` in W at
/// A, C (deg), in closed form: tip_W = (0, 0, 150) + Rz(−C)·Rx(−A)·(X, Y, Z)
/// (docs/machine-model.md), so (X, Y, Z) = Rx(A)·Rz(C)·(tip − (0, 0, 150)).
fn trunnion_xyz(tip: [f64; 3], a_deg: f64, c_deg: f64) -> [f64; 3] {
    let (a, c) = (a_deg.to_radians(), c_deg.to_radians());
    let v = [tip[0], tip[1], tip[2] - 150.0];
    let r = [
        v[0] * c.cos() - v[1] * c.sin(),
        v[0] * c.sin() + v[1] * c.cos(),
        v[2],
    ];
    [
        r[0],
        r[1] * a.cos() - r[2] * a.sin(),
        r[1] * a.sin() + r[2] * a.cos(),
    ]
}

#[test]
fn stats_tcp_machine_ranges_are_the_inverse_kinematics_along_the_moves() {
    let dir = tempfile::tempdir().unwrap();
    // Tip held at (10, 0, 5) in W, A = 30°, C turning from −45° to 45°.
    write(
        dir.path(),
        "turn.nc",
        "G0 X10 Y0 Z5 A30 C-45\nG1 C45 F1000\n",
    );
    let (_, v) = json_round_trip::<mtwin::gcode::GcodeStatsDoc>(
        dir.path(),
        &[
            "gcode",
            "stats",
            "turn.nc",
            "--tcp",
            "--machine",
            &example("ac-trunnion.toml"),
        ],
    );
    // The closed form, densely along the turn (the first rapid goes straight
    // in axis space from the start to its end, which is C = −45°).
    let n = 200_000;
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for k in 0..=n {
        let c = -45.0 + 90.0 * k as f64 / n as f64;
        let q = trunnion_xyz([10.0, 0.0, 5.0], 30.0, c);
        for i in 0..3 {
            lo[i] = lo[i].min(q[i]);
            hi[i] = hi[i].max(q[i]);
        }
    }
    // X = 10 cos C peaks at C = 0 between the ends (7.07 mm at both ends).
    assert!((hi[0] - 10.0).abs() < 1e-9 && (lo[0] - 50f64.sqrt()).abs() < 1e-9);
    for (i, name) in ["X", "Y", "Z"].into_iter().enumerate() {
        let m = &v["axes"][name]["machine"];
        let (mlo, mhi) = (m[0].as_f64().unwrap(), m[1].as_f64().unwrap());
        assert!(
            (mlo - lo[i]).abs() < 1e-7 && (mhi - hi[i]).abs() < 1e-7,
            "{name}: machine [{mlo}, {mhi}], closed form [{}, {}]",
            lo[i],
            hi[i]
        );
    }
    // The program coordinates stay the tip's.
    assert_eq!(v["axes"]["X"]["work"][1], 10.0);
}

#[test]
fn stats_strict_finds_a_tcp_move_beyond_travel_between_its_ends() {
    let dir = tempfile::tempdir().unwrap();
    // The tip held at (250, 250, 0) while C turns 90°: X, Y = Rz(C)·(250,
    // 250) is (250, 250) and (−250, 250) at the ends, inside ±300 mm, but
    // Y = 250·√2 = 353.55 mm at C = 45°. At (200, 200, 0) the radius is
    // 282.8 mm: inside all along.
    write(
        dir.path(),
        "mid.nc",
        "G0 X250 Y250 Z0 A0 C0\nG1 C90 F2000\n",
    );
    write(dir.path(), "ok.nc", "G0 X200 Y200 Z0 A0 C0\nG1 C90 F2000\n");
    let machine = example("ac-trunnion.toml");
    let stats = |prog: &str| {
        mtwin(
            dir.path(),
            &[
                "gcode",
                "stats",
                prog,
                "--tcp",
                "--machine",
                &machine,
                "--strict",
                "--format",
                "json",
            ],
        )
    };
    let o = stats("mid.nc");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("mid.nc:2:1: axis Y reaches 353.55"),
        "{}",
        stderr(&o)
    );
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["travel_violations"], 1);
    let y = v["violations"][0]["value"].as_f64().unwrap();
    assert!((y - 250.0 * 2f64.sqrt()).abs() < 1e-7, "{y}");
    let o = stats("ok.nc");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // `gcode interpolate` refuses and accepts the same two programs.
    let interp = |prog: &str| {
        mtwin(
            dir.path(),
            &[
                "gcode",
                "interpolate",
                "--machine",
                &machine,
                prog,
                "--tcp",
                "--out",
                "cmd.csv",
            ],
        )
    };
    let o = interp("mid.nc");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("mid.nc:2:") && stderr(&o).contains("axis Y reaches"));
    assert_eq!(interp("ok.nc").status.code(), Some(0));
}

#[test]
fn stats_with_a_machine_interprets_the_program_once() {
    let dir = tempfile::tempdir().unwrap();
    // Each run of the interpreter prints the message once on stderr.
    write(
        dir.path(),
        "msg.nc",
        "G1 X10 F600\n(PRINT,interpreted)\nG1 X0\n",
    );
    let o = mtwin(
        dir.path(),
        &[
            "gcode",
            "stats",
            "msg.nc",
            "--machine",
            &example("ac-trunnion.toml"),
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        stderr(&o).matches("interpreted").count(),
        1,
        "{}",
        stderr(&o)
    );
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    // The planned time (stops at both ends of each 10 mm move) is longer
    // than the 2 s at the programmed feed.
    assert!(v["total_time_s"].as_f64().unwrap() > 2.0);
    assert_eq!(v["blocks"], 3);
}

#[test]
fn documented_walkthrough_ends_where_it_started() {
    let dir = tempfile::tempdir().unwrap();
    let ran = crate::common::run_doc("gcode.md", dir.path());
    assert_eq!(ran.len(), 6, "{ran:?}");
    // Read the Fanuc way, the square's numbers (no decimal point) are in
    // least increments: a thousand times smaller.
    let json = |k: usize| -> serde_json::Value { serde_json::from_str(&ran[k].1).unwrap() };
    let (linuxcnc, fanuc) = (json(1), json(4));
    let len = |v: &serde_json::Value| v["feed_length_mm"].as_f64().unwrap();
    assert!((len(&linuxcnc) / len(&fanuc) - 1000.0).abs() < 1e-6);
    // The square closes: its last command sample is back at the origin.
    let (_, rows) = csv(&dir.path().join("cmd.csv"));
    let last = rows.last().unwrap();
    assert_eq!(&last[1..4], &[0.0, 0.0, 0.0]);
    // The generated program of the dialect section is written for Fanuc.
    let exc = std::fs::read_to_string(dir.path().join("exc.nc")).unwrap();
    assert!(exc.contains("G4 X0.5") && !exc.contains("G4 P"), "{exc}");
}

#[test]
fn fanuc_dialect_reads_numbers_without_a_point_in_least_increments() {
    let dir = tempfile::tempdir().unwrap();
    // X10000 is 10 mm for Fanuc without decimal point programming, 10000 mm
    // for LinuxCNC; X5. is 5 mm for both; G4 P1500 is 1.5 s for Fanuc.
    write(
        dir.path(),
        "f.nc",
        "G21 G90\nG1 X10000 F600\nG1 X5.\nG4 P1500\n",
    );
    let stats = |extra: &[&str]| -> serde_json::Value {
        let args = [&["gcode", "stats", "f.nc", "--format", "json"][..], extra].concat();
        let o = mtwin(dir.path(), &args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        serde_json::from_str(&stdout(&o)).unwrap()
    };
    let fanuc = stats(&["--dialect", "fanuc"]);
    assert!(
        (fanuc["feed_length_mm"].as_f64().unwrap() - 15.0).abs() < 1e-9,
        "{fanuc}"
    );
    assert!((fanuc["dwell_time_s"].as_f64().unwrap() - 1.5).abs() < 1e-12);
    let dpi = stats(&["--dialect", "fanuc", "--decimal-point"]);
    assert!((dpi["feed_length_mm"].as_f64().unwrap() - (10000.0 + 9995.0)).abs() < 1e-9);
    let linuxcnc = stats(&[]);
    assert!((linuxcnc["dwell_time_s"].as_f64().unwrap() - 1500.0).abs() < 1e-9);
}

/// Parameters, subroutines, loops and the var file through `gcode stats`.
mod program_flow {
    use super::*;

    /// A 10 mm square cut at three depths by a subroutine called from a loop.
    const SQUARES: &str = "G21 G90 G94\n\
o<square> sub (#1 side, #2 depth)\n\
G1 Z#2 F600\n\
G1 X#1\n\
G1 Y#1\n\
G1 X0\n\
G1 Y0\n\
o<square> endsub\n\
G0 X0 Y0 Z5\n\
#<z> = -1\n\
o1 repeat [3]\n\
o<square> call [10] [#<z>]\n\
#<z> = [#<z> - 1]\n\
o1 endrepeat\n\
G0 Z5\n\
(PRINT, last z=#<z>)\n\
M2\n";

    fn stats_json(dir: &std::path::Path, args: &[&str]) -> serde_json::Value {
        let mut all = vec!["gcode", "stats", "--format", "json"];
        all.extend_from_slice(args);
        let o = mtwin(dir, &all);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        serde_json::from_str(&stdout(&o)).unwrap()
    }

    #[test]
    fn stats_runs_a_subroutine_called_from_a_loop() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "squares.ngc", SQUARES);
        let o = mtwin(
            dir.path(),
            &["gcode", "stats", "--format", "json", "squares.ngc"],
        );
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        // Rapids: Z0 → 5 and -3 → 5. Feeds: 5 → -1, -1 → -2, -2 → -3 down,
        // and three 40 mm squares.
        assert_eq!(v["rapid_moves"], 2);
        assert_eq!(v["linear_moves"], 15);
        assert!((v["rapid_length_mm"].as_f64().unwrap() - 13.0).abs() < 1e-9);
        assert!((v["feed_length_mm"].as_f64().unwrap() - 128.0).abs() < 1e-9);
        assert!((v["feed_time_s"].as_f64().unwrap() - 128.0 / 10.0).abs() < 1e-9);
        assert_eq!(v["axes"]["Z"]["work"], serde_json::json!([-3.0, 5.0]));
        assert_eq!(v["axes"]["X"]["work"], serde_json::json!([0.0, 10.0]));
        assert!(
            stderr(&o).contains("squares.ngc:16: PRINT:  last z=-4.000000"),
            "{}",
            stderr(&o)
        );
    }

    #[test]
    fn var_file_and_subroutine_path() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("subs")).unwrap();
        // #31 and the G54 X offset (5221).
        write(
            dir.path(),
            "p.var",
            "31\t2.500000\n5161\t0.000000\n5221\t100.000000\n",
        );
        write(
            dir.path(),
            "subs/up.ngc",
            "o<up> sub\nG0 Z[#1 + #31]\no<up> endsub\n",
        );
        write(dir.path(), "p.ngc", "G0 X#31\no<up> call [1]\nM2\n");
        let v = stats_json(
            dir.path(),
            &["p.ngc", "--var-file", "p.var", "--subroutine-path", "subs"],
        );
        // From machine X 0 (work X -100) to work X 2.5 (machine 102.5), then
        // Z up by 1 + 2.5.
        assert!((v["rapid_length_mm"].as_f64().unwrap() - (102.5 + 3.5)).abs() < 1e-9);
        assert_eq!(v["axes"]["X"]["machine"][1], 102.5);
        assert_eq!(v["axes"]["Z"]["work"][1], 3.5);
        // The var file is read, never written.
        assert_eq!(
            std::fs::read_to_string(dir.path().join("p.var")).unwrap(),
            "31\t2.500000\n5161\t0.000000\n5221\t100.000000\n"
        );
        // Without the path the subroutine is unknown.
        let o = mtwin(
            dir.path(),
            &["gcode", "stats", "p.ngc", "--var-file", "p.var"],
        );
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains("p.ngc:2:1: "), "{}", stderr(&o));
        assert!(stderr(&o).contains("up.ngc"), "{}", stderr(&o));
    }

    #[test]
    fn ini_file_values_subroutine_path_and_abort() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("cfg/subs")).unwrap();
        write(
            dir.path(),
            "cfg/m.ini",
            "[RS274NGC]\nSUBROUTINE_PATH = subs\n[VARS]\nSAFE_Z = 12.5\n",
        );
        write(
            dir.path(),
            "cfg/subs/up.ngc",
            "o<up> sub\nG0 Z#<_ini[vars]safe_z>\no<up> endsub\n",
        );
        write(
            dir.path(),
            "p.ngc",
            "G0 X#<_ini[VARS]SAFE_Z>\no<up> call\nM2\n",
        );
        let v = stats_json(dir.path(), &["p.ngc", "--ini", "cfg/m.ini"]);
        // X to 12.5, then Z up 12.5: the INI value, the subroutine found on
        // the INI's path relative to the INI's folder.
        assert!((v["rapid_length_mm"].as_f64().unwrap() - 25.0).abs() < 1e-9);
        assert_eq!(v["axes"]["Z"]["work"][1], 12.5);
        write(
            dir.path(),
            "a.ngc",
            "G0 X1\n(ABORT, z=#<_ini[vars]safe_z>)\nG0 X2\nM2\n",
        );
        let o = mtwin(
            dir.path(),
            &["gcode", "stats", "a.ngc", "--ini", "cfg/m.ini"],
        );
        assert_eq!(o.status.code(), Some(1));
        assert!(
            stderr(&o).contains("a.ngc:2: ABORT:  z=12.500000"),
            "{}",
            stderr(&o)
        );
        assert!(stderr(&o).contains("a.ngc:2:1: "), "{}", stderr(&o));
        assert!(o.stdout.is_empty());
    }

    #[test]
    fn bad_flow_is_located() {
        let dir = tempfile::tempdir().unwrap();
        for (name, text, at, what) in [
            (
                "unclosed.ngc",
                "G0 X1\no<a> sub\nG0 X2\n",
                "unclosed.ngc:2:1: ",
                "not closed",
            ),
            (
                "endwhile.ngc",
                "G0 X1\n  o7 endwhile\n",
                "endwhile.ngc:2:3: ",
                "without a matching",
            ),
            (
                "undefined.ngc",
                "G0 X#<nope>\n",
                "undefined.ngc:1:5: ",
                "#<nope> not defined",
            ),
            (
                "endless.ngc",
                "o1 while [1]\nG0 X1\no1 endwhile\n",
                "endless.ngc:",
                "more than 1000 blocks",
            ),
        ] {
            write(dir.path(), name, text);
            let o = mtwin(
                dir.path(),
                &["gcode", "stats", name, "--max-blocks", "1000"],
            );
            assert_eq!(o.status.code(), Some(1), "{name}");
            let e = stderr(&o);
            assert!(e.contains(at) && e.contains(what), "{name}: {e}");
        }
    }
}

/// `--tool-table`: G43 H1 takes tool 1's Z from the table (machine Z =
/// program Z + 12.5); a bad table line is `file:line:col`, exit 1.
/// `--block-delete off` runs the `/` blocks.
#[test]
fn tool_table_and_block_delete_options() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "tools.tbl",
        "; mill\nT1 P1 Z12.5 D6 ;end mill\n",
    );
    write(dir.path(), "bad.tbl", "T1 P1\nT2 P2 Zx\n");
    write(
        dir.path(),
        "p.nc",
        "T1 M6\nG43 H1\nG0 Z0\n/G1 X10 F600\nM30\nPost Process Timed at; 32 Min\n",
    );
    let stats = |extra: &[&str]| {
        let mut args = vec!["gcode", "stats", "p.nc", "--format", "json"];
        args.extend_from_slice(extra);
        mtwin(dir.path(), &args)
    };
    // Without a table, tool 1 is unknown: refused with the line.
    let o = stats(&[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("p.nc:2:"), "{}", stderr(&o));
    let o = stats(&["--tool-table", "tools.tbl"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(
        v["feed_length_mm"].as_f64(),
        Some(0.0),
        "the / block is skipped"
    );
    let o = stats(&["--tool-table", "tools.tbl", "--block-delete", "off"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["feed_length_mm"].as_f64(), Some(10.0));
    let o = stats(&["--tool-table", "bad.tbl"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("bad.tbl:2:7: Z needs a number"),
        "{}",
        stderr(&o)
    );
}

/// A word of an axis the machine lacks is refused by every command that
/// reads a program on a machine, as LinuxCNC refuses it ("Bad character
/// 'w' used"): the AC trunnion has X Y Z A C, no B and no W. Without a
/// machine all nine axes are read; a LinuxCNC INI's `[TRAJ] COORDINATES`
/// sets them as LinuxCNC's task does (no COORDINATES: X Y Z).
#[test]
fn words_of_axes_the_machine_lacks_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = example("ac-trunnion.toml");
    let twin = example("ac-trunnion-twin.toml");
    write(d, "w.nc", "G21 G90\nG1 X1 Y1 Z1 W2 F100\nM2\n");
    write(d, "b.nc", "G21 G90\nG1 X1 F100\n  G0 B5\nM2\n");
    for (prog, at, letter) in [("w.nc", "w.nc:2:13:", 'W'), ("b.nc", "b.nc:3:6:", 'B')] {
        let msg = format!("{at} invalid block: {letter} word: the machine has no {letter} axis");
        let runs: [&[&str]; 4] = [
            &["gcode", "stats", prog, "--machine", &m, "--format", "json"],
            &[
                "gcode",
                "interpolate",
                "--machine",
                &m,
                prog,
                "--out",
                "out.csv",
            ],
            &[
                "compensate",
                "--machine",
                &m,
                "--program",
                prog,
                "--out",
                "out.csv",
            ],
            &[
                "twin",
                "predict",
                "--machine",
                &twin,
                "--gcode",
                prog,
                "--out",
                "out.csv",
            ],
        ];
        for args in runs {
            expect_failure(d, args, &msg, "out.csv");
        }
        // Without a machine: all nine axes.
        mtwin_ok(d, &["gcode", "stats", prog]);
    }
    // LinuxCNC's INI: COORDINATES with W accepts W and refuses A.
    write(d, "xyzw.ini", "[TRAJ]\nCOORDINATES = X Y Z W\n");
    write(d, "xyz.ini", "[TRAJ]\nLINEAR_UNITS = mm\n");
    write(d, "a.nc", "G1 X1 A3 F100\n");
    mtwin_ok(d, &["gcode", "stats", "w.nc", "--ini", "xyzw.ini"]);
    for ini in ["xyzw.ini", "xyz.ini"] {
        expect_failure(
            d,
            &["gcode", "stats", "a.nc", "--ini", ini],
            "a.nc:1:7: invalid block: A word: the machine has no A axis",
            "out.csv",
        );
    }
    expect_failure(
        d,
        &["gcode", "stats", "w.nc", "--ini", "xyz.ini"],
        "w.nc:2:13: invalid block: W word",
        "out.csv",
    );
    // Machine and INI: the axes of both (the trunnion's A refused by the INI).
    expect_failure(
        d,
        &[
            "gcode",
            "stats",
            "a.nc",
            "--machine",
            &m,
            "--ini",
            "xyzw.ini",
        ],
        "a.nc:1:7: invalid block: A word",
        "out.csv",
    );
}
