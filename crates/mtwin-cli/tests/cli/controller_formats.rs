//! Controller table formats: files written in each vendor's documented layout
//! (examples written for these tests after the vendors' descriptions, see
//! docs/controller-tables.md) are read, and what mtwin writes reads back.

use std::path::Path;

use mtwin::controller::{
    self, ExportOptions, Format, etalon, isg_csv, linuxcnc_comp, siemens_cec, siemens_eec,
};
use mtwin::model::{ErrorFunction, ErrorName, Machine};

fn trunnion() -> Machine {
    mtwin::examples::machine("ac-trunnion").unwrap()
}

fn value(m: &Machine, name: &str, q: f64) -> f64 {
    m.error_value(&name.parse::<ErrorName>().unwrap(), q)
        .unwrap()
}

/// An ISG_CSV file in the documented layout: comments, a block of location
/// errors (one row), a `#` break, a block of component errors over X.
const ISG_EXAMPLE: &str = "\
// location errors only in this block
Y0A Z0A X0C Y0C
0.012 -0.004 0.0065 0.002
#
// X is the argument, then component errors of X
X EXX EYX EZX EAX EBX ECX
-100.0 0.003 -0.001 0.0 0.00001 0.0 -0.000002
0.0    0.001  0.0   0.002 0.0 0.000004 0.0
// a comment between rows
100.0  -0.002 0.004 0.001 -0.00001 0.0 0.000002
# Z EZZ
-400 0.0
200 0.006
";

#[test]
fn isg_csv_documented_layout_reads_and_writes_back() {
    let file = Path::new("example.csv");
    let blocks = isg_csv::parse(ISG_EXAMPLE, file).unwrap();
    assert_eq!(blocks.len(), 3);
    assert_eq!(blocks[0].header, ["Y0A", "Z0A", "X0C", "Y0C"]);
    assert_eq!(blocks[1].header[0], "X");
    assert_eq!(blocks[1].rows.len(), 3);
    assert_eq!(blocks[2].header, ["Z", "EZZ"]);
    let mut m = trunnion();
    isg_csv::apply(&mut m, &blocks, file).unwrap();
    assert_eq!(value(&m, "EY0A", 0.0), 0.012);
    assert_eq!(value(&m, "EX0C", 0.0), 0.0065);
    // Linear interpolation between the rows, by hand.
    assert!((value(&m, "EXX", -50.0) - 0.002).abs() < 1e-15);
    assert!((value(&m, "EYX", 50.0) - 0.002).abs() < 1e-15);
    assert!((value(&m, "EAX", 25.0) - (-0.0000025)).abs() < 1e-18);
    assert!((value(&m, "EZZ", -100.0) - 0.003).abs() < 1e-15);
    // Written by mtwin and read again: the same model.
    let text = isg_csv::write(&isg_csv::machine_blocks(&m));
    let again = isg_csv::parse(&text, file).unwrap();
    let mut m2 = trunnion();
    isg_csv::apply(&mut m2, &again, file).unwrap();
    assert_eq!(m2, m);
}

#[test]
fn isg_csv_bad_input_names_the_place() {
    let file = Path::new("bad.csv");
    let e = isg_csv::parse("X EXX\n0 0.1\n10 abc\n", file).unwrap_err();
    assert_eq!(e.to_string(), "bad.csv:3:4: `abc` is not a finite number");
    let e = isg_csv::parse("X EXX\n0 0.1 0.2\n", file).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("bad.csv:2:1: this row has 3 values"),
        "{e}"
    );
    let e = isg_csv::parse("0 0.1\n", file).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("bad.csv:1:1: expected a header row"),
        "{e}"
    );
    let mut m = trunnion();
    let blocks = isg_csv::parse("X EXX\n10 0.1\n0 0.2\n", file).unwrap();
    let e = isg_csv::apply(&mut m, &blocks, file).unwrap_err();
    assert!(e.to_string().contains("must increase"), "{e}");
    let blocks = isg_csv::parse("X EXY\n0 0.1\n10 0.2\n", file).unwrap();
    assert!(isg_csv::apply(&mut m, &blocks, file).is_err());
}

/// An Etalon exchange file in the documented ("vendor") layout.
const ETALON_EXAMPLE: &str = "\
// each parameter in its own block
[C0A]
VALUE = 0.000021
[Y0C]
VALUE = -0.0035
// a lookup table over Y
[EXY]
Gridpoints = {
    -300.0 -0.0012
    0.0 0.0004
    300.0 0.0010
}  // end of EXY
";

#[test]
fn etalon_documented_layout_reads_and_writes_back() {
    let file = Path::new("example.etalon");
    let params = etalon::parse(ETALON_EXAMPLE, file).unwrap();
    assert_eq!(params.len(), 3);
    assert_eq!(params[0].name, "C0A");
    assert_eq!(params[0].value, Some(0.000021));
    assert_eq!(
        params[2].grid,
        [(-300.0, -0.0012), (0.0, 0.0004), (300.0, 0.0010)]
    );
    let mut m = trunnion();
    etalon::apply(&mut m, &params, file).unwrap();
    assert_eq!(value(&m, "EC0A", 0.0), 0.000021);
    assert_eq!(value(&m, "EY0C", 0.0), -0.0035);
    assert!((value(&m, "EXY", -150.0) - (-0.0004)).abs() < 1e-15);
    let text = etalon::write(&m);
    let mut m2 = trunnion();
    etalon::apply(&mut m2, &etalon::parse(&text, file).unwrap(), file).unwrap();
    assert_eq!(m2, m);
    // Unclosed table and unknown names are refused with the place.
    let e = etalon::parse("[EXY]\nGridpoints = {\n0 1\n", file).unwrap_err();
    assert!(e.to_string().contains("not closed"), "{e}");
    let bad = etalon::parse("[QQQ]\nVALUE = 1\n", file).unwrap();
    let e = etalon::apply(&mut m2, &bad, file).unwrap_err();
    assert!(
        e.to_string().starts_with("example.etalon:1: `[QQQ]`"),
        "{e}"
    );
}

#[test]
fn linuxcnc_comp_file_layout() {
    // LinuxCNC's layout: three numbers a line, ascending, no header.
    let file = Path::new("comp_X.txt");
    let text = "-100.0 0.0021 0.0021\n0.0 0.0 0.0\n100.0 -0.003 -0.0025\n";
    let rows = linuxcnc_comp::parse(text, file).unwrap();
    assert_eq!(
        rows,
        [
            [-100.0, 0.0021, 0.0021],
            [0.0, 0.0, 0.0],
            [100.0, -0.003, -0.0025]
        ]
    );
    let written = linuxcnc_comp::write(&[-100.0, 0.0, 100.0], &[0.0021, 0.0, -0.003]);
    for line in written.lines() {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|t| t.parse().unwrap())
            .collect();
        assert_eq!(v.len(), 3, "{line}");
        assert_eq!(v[1], v[2]);
    }
    assert_eq!(
        linuxcnc_comp::parse(&written, file).unwrap()[2],
        [100.0, -0.003, -0.003]
    );
    // A header (LinuxCNC would stop there), a descending line, 257 lines: refused.
    assert!(linuxcnc_comp::parse("nominal forward reverse\n0 0 0\n", file).is_err());
    assert!(linuxcnc_comp::parse("0 0 0\n-1 0 0\n", file).is_err());
    let long: String = (0..257).map(|k| format!("{k} 0 0\n")).collect();
    assert!(linuxcnc_comp::parse(&long, file).is_err());
    let ok: String = (0..256).map(|k| format!("{k} 0 0\n")).collect();
    assert_eq!(linuxcnc_comp::parse(&ok, file).unwrap().len(), 256);
}

/// A machine with one known error function added.
fn with(name: &str, f: ErrorFunction) -> Machine {
    let mut m = trunnion();
    let n: ErrorName = name.parse().unwrap();
    let i = m.axis_index(&n.axis).unwrap();
    m.axes[i].errors.pdge[n.component.index()] = Some(f);
    m
}

#[test]
fn siemens_eec_layout_holds_the_axis_error() {
    // EXX = 1e-5·x + 2e-8·x²: EEC's value is the error itself (a positive
    // value moves the axis negative, taking the error out).
    let exx = |x: f64| 1e-5 * x + 2e-8 * x * x;
    let m = with("EXX", ErrorFunction::Poly(vec![0.0, 1e-5, 2e-8]));
    let e = controller::export(&m, Format::SiemensEec, &ExportOptions::default()).unwrap();
    let (name, text) = &e.files[0];
    assert_eq!(name, "AX_EEC.INI");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "%_N_AX_EEC_INI");
    assert!(lines.contains(&"CHANDATA(1)"));
    assert_eq!(*lines.last().unwrap(), "M17");
    let tables = siemens_eec::parse(text, Path::new(name)).unwrap();
    let x = tables.iter().find(|t| t.axis == "AX1").expect("X is AX1");
    assert_eq!((x.min, x.max, x.step), (-300.0, 300.0, 10.0));
    assert_eq!(x.values.len(), 61);
    for (k, v) in x.values.iter().enumerate() {
        let q = x.min + k as f64 * x.step;
        assert!((v - exx(q)).abs() < 1e-6, "q={q}: {v} vs {}", exx(q));
    }
    // Y and Z carry nothing.
    for t in tables.iter().filter(|t| t.axis != "AX1") {
        assert!(t.values.iter().all(|v| v.abs() < 1e-6), "{}", t.axis);
    }
}

#[test]
fn siemens_cec_layout_holds_the_straightness() {
    // EYX = 3e-8·x²: the Y correction over X is −(EYX(x) − EYX(0)).
    let m = with("EYX", ErrorFunction::Poly(vec![0.0, 0.0, 3e-8]));
    let e = controller::export(&m, Format::SiemensCec, &ExportOptions::default()).unwrap();
    let (name, text) = &e.files[0];
    assert!(text.starts_with("%_N_NC_CEC_INI\n"));
    assert!(text.ends_with("M17\n"));
    for key in [
        "$AN_CEC_DIRECTION[0]=0",
        "$AN_CEC_MULT_BY_TABLE[0]=0",
        "$AN_CEC_IS_MODULO[0]=0",
    ] {
        assert!(text.contains(key), "{key}");
    }
    let tables = siemens_cec::parse(text, Path::new(name)).unwrap();
    assert_eq!(tables.len(), 6, "every ordered pair of X, Y, Z");
    let t = tables
        .iter()
        .find(|t| t.input == "AX1" && t.output == "AX2")
        .expect("Y over X");
    assert_eq!(
        (t.min, t.max, t.step, t.direction),
        (-300.0, 300.0, 10.0, 0)
    );
    for (k, v) in t.values.iter().enumerate() {
        let q = t.min + k as f64 * t.step;
        assert!((v + 3e-8 * q * q).abs() < 1e-6, "q={q}: {v}");
    }
    for t in tables
        .iter()
        .filter(|t| !(t.input == "AX1" && t.output == "AX2"))
    {
        assert!(
            t.values.iter().all(|v| v.abs() < 1e-6),
            "{} over {}",
            t.output,
            t.input
        );
    }
    // Positioning is not CEC's: an EXX is reported as not carried.
    let m = with("EXX", ErrorFunction::Poly(vec![0.0, 1e-5]));
    let e = controller::export(&m, Format::SiemensCec, &ExportOptions::default()).unwrap();
    assert_eq!(e.dropped, ["EXX"]);
}

#[test]
fn linuxcnc_trunnion_parameters_follow_linuxcnc_kinematics() {
    // LinuxCNC's xyzac-trt forward kinematics (trtfuncs.c), written out here:
    // the world tip for joints (x, y, z, a, c) with the exported parameters
    // must be mtwin's tip in W with the same location errors, up to a
    // constant translation (the work offset).
    let mut m = trunnion();
    let set = |m: &mut Machine, n: &str, v: f64| {
        let n: ErrorName = n.parse().unwrap();
        let i = m.axis_index(&n.axis).unwrap();
        m.axes[i].errors.location[n.component.index()] = v;
    };
    set(&mut m, "EY0A", 0.021);
    set(&mut m, "EZ0A", -0.017);
    set(&mut m, "EX0C", 0.014);
    set(&mut m, "EY0C", -0.026);
    let t = linuxcnc_comp::Trunnion::of(&m).expect("an XYZAC trunnion");
    assert_eq!(t, linuxcnc_comp::Trunnion::Xyzac);
    let p = linuxcnc_comp::TrtParameters::of(&m, t);
    let fwd = |j: [f64; 5]| -> [f64; 3] {
        let (a, c) = (j[3].to_radians(), j[4].to_radians());
        let dz = p.z_offset + p.tool_offset;
        let (xr, yr, zr, dy) = (p.x_rot_point, p.y_rot_point, p.z_rot_point, p.y_offset);
        [
            c.cos() * (j[0] - xr)
                + c.sin() * a.cos() * (j[1] - dy - yr)
                + c.sin() * a.sin() * (j[2] - dz - zr)
                + c.sin() * dy
                + xr,
            -c.sin() * (j[0] - xr)
                + c.cos() * a.cos() * (j[1] - dy - yr)
                + c.cos() * a.sin() * (j[2] - dz - zr)
                + c.cos() * dy
                + yr,
            -a.sin() * (j[1] - dy - yr) + a.cos() * (j[2] - dz - zr) + dz + zr,
        ]
    };
    let k = mtwin::kinematics::Kinematics::new(&m);
    let (yi, xi, zi, ai, ci) = (0, 1, 2, 3, 4);
    assert_eq!(m.axis_names(), ["Y", "X", "Z", "A", "C"]);
    // Try the four angle-direction conventions: exactly one agrees at every
    // pose, and it is the same signs (mtwin's right-hand directions of this
    // machine file are LinuxCNC's with conventional-directions 0).
    let poses = [
        (0.0, 0.0, 0.0, 0.0, 0.0),
        (120.0, -80.0, -200.0, 30.0, 45.0),
        (-250.0, 200.0, -50.0, -90.0, 200.0),
        (10.0, 290.0, -390.0, 110.0, -300.0),
    ];
    let mut agree = Vec::new();
    for (sa, sc) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let mut offset: Option<[f64; 3]> = None;
        let mut worst: f64 = 0.0;
        for &(x, y, z, a, c) in &poses {
            let mut q = [0.0; 5];
            (q[xi], q[yi], q[zi], q[ai], q[ci]) = (x, y, z, a, c);
            let tip = k.pose(&q).tip;
            let w = fwd([x, y, z, sa * a, sc * c]);
            let d = [tip.x - w[0], tip.y - w[1], tip.z - w[2]];
            let o = *offset.get_or_insert(d);
            for (di, oi) in d.iter().zip(o) {
                worst = worst.max((di - oi).abs());
            }
        }
        eprintln!("directions A {sa:+} C {sc:+}: worst {worst:e} mm");
        if worst < 1e-9 {
            agree.push((sa, sc));
        }
    }
    assert_eq!(agree, [(1.0, 1.0)]);
}
