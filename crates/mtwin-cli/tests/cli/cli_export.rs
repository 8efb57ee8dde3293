//! `mtwin export`: the contract of the output folder and of `--format json`.

use crate::common::{example, mtwin, stderr, stdout};

fn three_numbers_ascending(text: &str) -> usize {
    let mut last = f64::NEG_INFINITY;
    let mut n = 0;
    for line in text.lines() {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|t| t.parse::<f64>().expect("a number"))
            .collect();
        assert_eq!(v.len(), 3, "`{line}`");
        assert!(v[0] > last, "`{line}` does not ascend");
        last = v[0];
        n += 1;
    }
    assert!(n <= 256);
    n
}

#[test]
fn linuxcnc_on_the_trunnion_writes_comp_files_hal_and_readme() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("comp");
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--to",
            "linuxcnc",
            "--out",
            out.to_str().unwrap(),
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let lc = &v["linuxcnc"];
    let (max, rms) = (
        lc["max_um"].as_f64().unwrap(),
        lc["rms_um"].as_f64().unwrap(),
    );
    assert!(max > 0.0 && rms > 0.0 && rms <= max);
    assert!(!lc["dropped"].as_array().unwrap().is_empty());
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "README.txt",
            "comp_X.txt",
            "comp_Y.txt",
            "comp_Z.txt",
            "kinematics.hal"
        ]
    );
    for axis in ["X", "Y", "Z"] {
        let t = std::fs::read_to_string(out.join(format!("comp_{axis}.txt"))).unwrap();
        assert_eq!(three_numbers_ascending(&t), 61, "{axis}: 600 mm at 10 mm");
    }
    let hal = std::fs::read_to_string(out.join("kinematics.hal")).unwrap();
    for pin in [
        "x-rot-point",
        "y-rot-point",
        "z-rot-point",
        "y-offset",
        "z-offset",
        "tool-offset",
    ] {
        assert!(
            hal.lines()
                .any(|l| l.starts_with(&format!("setp xyzac-trt-kins.{pin} "))),
            "{pin}"
        );
    }
    let readme = std::fs::read_to_string(out.join("README.txt")).unwrap();
    for line in [
        "[JOINT_0]",
        "COMP_FILE = comp_X.txt",
        "COMP_FILE_TYPE = 1",
        "BACKLASH",
    ] {
        assert!(readme.contains(line), "{line}");
    }
}

#[test]
fn linuxcnc_on_the_gantry_has_no_trunnion_kinematics() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--machine",
            &example("afp-gantry-with-errors.toml"),
            "--to",
            "linuxcnc",
            "--out",
            "out",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!dir.path().join("out/kinematics.hal").exists());
    // 8000 mm of X at 10 mm would be 801 lines: capped at LinuxCNC's 256.
    let t = std::fs::read_to_string(dir.path().join("out/comp_X.txt")).unwrap();
    assert_eq!(three_numbers_ascending(&t), 256);
    assert!(stdout(&o).contains("not carried:"), "{}", stdout(&o));
}

#[test]
fn isg_writes_the_list_and_the_files_it_names() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--to",
            "isg,siemens-eec",
            "--out",
            "out",
            "--spacing",
            "25",
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    for f in ["isg", "siemens-eec"] {
        assert!(v[f]["max_um"].as_f64().is_some(), "{f}");
        assert!(v[f]["rms_um"].as_f64().is_some(), "{f}");
    }
    let lis = std::fs::read_to_string(dir.path().join("out/isg/volcomp.lis")).unwrap();
    let named: Vec<&str> = lis
        .lines()
        .filter_map(|l| l.strip_prefix("file[0] "))
        .collect();
    assert_eq!(named, ["volcomp.csv"]);
    assert!(lis.lines().any(|l| l == "file_format[0] ISG_CSV"));
    assert!(lis.lines().any(|l| l == "workpiece_axes 2"));
    // The vendor's spelling, and the chain from the workpiece (C on A) to the
    // base and on to the tool (Y, X, Z).
    assert!(lis.lines().any(|l| l == "Interpolation GRID"));
    assert!(lis.lines().any(|l| l == "chain CAYXZ"));
    let csv = std::fs::read_to_string(dir.path().join("out/isg").join(named[0])).unwrap();
    assert!(csv.lines().any(|l| l == "X EXX EYX EZX EAX EBX ECX"));
    assert!(dir.path().join("out/siemens-eec/AX_EEC.INI").exists());
}

#[test]
fn bad_options_exit_1_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--to",
            "linuxcnc",
            "--out",
            "out",
            "--range",
            "Q=0:100",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("axis Q"), "{}", stderr(&o));
    assert!(!dir.path().join("out").exists());
    // A machine the format cannot name: ISG needs X, Y, Z and A, B, C.
    let bad = dir.path().join("m.toml");
    let text = std::fs::read_to_string(example("ac-trunnion.toml"))
        .unwrap()
        .replace("name = \"C\"", "name = \"W\"")
        .replace("\"C\"]", "\"W\"]");
    std::fs::write(&bad, text).unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--machine",
            "m.toml",
            "--to",
            "isg",
            "--out",
            "out",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("isg cannot carry"), "{}", stderr(&o));
    assert!(!dir.path().join("out").exists());
}

/// A thermal model file (the two-height model of docs/thermal-compensation.md).
const THERMAL: &str = "period_min = 10.0\n\n[[inputs]]\nname = \"speed_rpm\"\nscale = 8000.0\n\n\
[[heights]]\nz_mm = -350.0\na = [1.0, -1.605827, 0.627089]\nb = [[-0.0062836, 0.0057508]]\nnk = [1]\n\n\
[[heights]]\nz_mm = -50.0\na = [1.0, -1.605827, 0.627089]\nb = [[-0.0070963, 0.0062955]]\nnk = [1]\n";

#[test]
fn thermal_model_becomes_a_hal_component_beside_the_tables() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("thermal.toml"), THERMAL).unwrap();
    // The thermal model alone: no --machine, only its files.
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--thermal",
            "thermal.toml",
            "--to",
            "linuxcnc",
            "--out",
            "live",
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let t = &v["thermal"];
    assert_eq!(t["component"], "mtwin-thermal");
    assert_eq!(t["period_min"], 10.0);
    assert_eq!(t["inputs"], serde_json::json!(["speed_rpm"]));
    assert_eq!(t["heights_mm"], serde_json::json!([-350.0, -50.0]));
    assert!(v.get("linuxcnc").is_none());
    let mut names: Vec<String> = std::fs::read_dir(dir.path().join("live"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["mtwin_thermal.py", "thermal-README.txt", "thermal.hal"]
    );
    let py = std::fs::read_to_string(dir.path().join("live/mtwin_thermal.py")).unwrap();
    // The coefficients of the file, as written there.
    for c in [
        "-1.605827",
        "0.627089",
        "-0.0062836",
        "0.0057508",
        "-0.0070963",
        "0.0062955",
    ] {
        assert!(py.contains(c), "{c} missing from the component");
    }
    let hal = std::fs::read_to_string(dir.path().join("live/thermal.hal")).unwrap();
    assert!(
        hal.contains("loadusr -Wn mtwin-thermal /usr/bin/python3 mtwin_thermal.py --clock-pin\n")
    );
    assert!(
        hal.contains("net mtwin-thermal-clock mtwin-thermal-clock.out => mtwin-thermal.clock-s\n")
    );
    // With a machine: the tables and the component together.
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--thermal",
            "thermal.toml",
            "--to",
            "linuxcnc",
            "--out",
            "both",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for f in [
        "comp_X.txt",
        "README.txt",
        "mtwin_thermal.py",
        "thermal.hal",
    ] {
        assert!(dir.path().join("both").join(f).exists(), "{f}");
    }
    // Only LinuxCNC takes a thermal model; nothing is written otherwise.
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--machine",
            &example("ac-trunnion-with-errors.toml"),
            "--thermal",
            "thermal.toml",
            "--to",
            "isg",
            "--out",
            "no",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("only `--to linuxcnc`"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("no").exists());
    // A bad model file: file:line:col, exit 1, nothing written.
    std::fs::write(
        dir.path().join("bad.toml"),
        THERMAL.replace("period_min = 10.0", "period_min = -1.0"),
    )
    .unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "export",
            "--thermal",
            "bad.toml",
            "--to",
            "linuxcnc",
            "--out",
            "no",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("bad.toml:1:"), "{}", stderr(&o));
    assert!(!dir.path().join("no").exists());
    // Neither a machine nor a thermal model.
    let o = mtwin(dir.path(), &["export", "--to", "linuxcnc", "--out", "no"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
