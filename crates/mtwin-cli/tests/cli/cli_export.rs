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
