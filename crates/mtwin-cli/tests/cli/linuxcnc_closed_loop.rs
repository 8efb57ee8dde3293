//! The loop closed on LinuxCNC: the files `mtwin export --to linuxcnc`
//! writes for the demo trunnion (`ac-trunnion-with-errors`) loaded into
//! LinuxCNC 2.9's simulator, a short five-axis program run under TCP, and the
//! drive commands it sends (`joint.N.motor-pos-cmd`) compared with what mtwin
//! predicts the compensated controller commands: the joint commands of the
//! controller kinematics the export describes (mtwin's inverse kinematics of
//! the world commands, with the exported trunnion parameters), plus each
//! joint's table interpolated at its command.
//!
//! The simulator set-up and sampling are `linuxcnc_sim`'s (docs/linuxcnc.md).

use mtwin::controller::{self, Correction, ExportOptions, Format, JointTable};
use mtwin::kinematics::{IkOptions, IkTarget, Kinematics};
use nalgebra::Vector3;

use crate::linuxcnc_sim::{AXES, SHORT, SimSetup, available, interpolated, run_or_panic};

/// The set-up that loads the exported files: every file beside the ini, the
/// `[JOINT_n]` lines of the export's README.txt as ini entries, and the
/// `setp` lines of kinematics.hal as HAL commands. The sample configuration
/// drives `y-offset` and `z-offset` from signals (`:y-offset`, `:z-offset`)
/// and `tool-offset` from `motion.tooloffset.z` (README.txt says to drop that
/// line then): the first two become `sets`, the last is checked to be 0 and
/// left to the configuration (no tool is loaded).
fn setup_from_export(files: &[(String, String)]) -> SimSetup {
    let mut setup = SimSetup::default();
    let mut section = String::new();
    let mut joints = 0;
    for (name, text) in files {
        match name.as_str() {
            "README.txt" => {
                for line in text.lines() {
                    let line = line.trim();
                    if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                        section = s.to_string();
                    } else if let Some((k, v)) = line.split_once(" = ")
                        && section.starts_with("JOINT_")
                    {
                        setup = setup.ini(&section, k.trim(), v.trim());
                        joints += usize::from(k.trim() == "COMP_FILE");
                    }
                }
            }
            "kinematics.hal" => {
                for line in text.lines().filter(|l| l.starts_with("setp ")) {
                    let mut t = line.split_whitespace().skip(1);
                    let (pin, v) = (t.next().unwrap(), t.next().unwrap());
                    let param = pin.strip_prefix("xyzac-trt-kins.").expect("xyzac kins");
                    match param {
                        "y-offset" | "z-offset" => setup = setup.hal(format!("sets :{param} {v}")),
                        "tool-offset" => assert_eq!(v.parse::<f64>().unwrap(), 0.0),
                        // x-offset is xyzbc's; the xyzac component has none.
                        "x-offset" => assert_eq!(v.parse::<f64>().unwrap(), 0.0),
                        _ => setup = setup.hal(line.to_string()),
                    }
                }
            }
            _ => {}
        }
        if name.ends_with(".txt") && name != "README.txt" {
            setup = setup.file(name, text.clone());
        }
    }
    assert_eq!(joints, 3, "README.txt names a comp file per linear joint");
    setup
}

#[test]
fn exported_comp_files_and_trunnion_parameters_drive_linuxcnc_as_mtwin_predicts() {
    if !available() {
        return;
    }
    let m = mtwin::examples::machine("ac-trunnion-with-errors").unwrap();
    // The same function `mtwin export --to linuxcnc` calls, default options.
    let e = controller::export(&m, Format::LinuxCnc, &ExportOptions::default()).unwrap();
    let Correction::Joint { kinematics, tables } = &e.correction else {
        panic!("LinuxCNC is a joint-table format")
    };
    let setup = setup_from_export(&e.files);
    // Tilt and turn the table with the tip off the axis lines, under TCP
    // (M428), within the sample configuration's limits.
    let program = "G21 G90 G94 G64 P0.01\nM428\nG0 X5 Y5 Z20 A0 C0\n\
                   G1 X15 Y-8 Z15 A-10 C20 F900\nG1 X-10 Y8 Z5 A8 C-15\n\
                   G1 X10 Y-5 Z5 A0 C0\nM429\nM2\n";
    let t = run_or_panic("closed loop", program, &setup, SHORT);

    // mtwin's controller model: the kinematics the export describes. World
    // X Y Z of LinuxCNC are the tip in the table frame less its value at
    // the zero pose (at A = C = 0 the joints are the world position).
    let kin = Kinematics::new(kinematics);
    let idx: Vec<usize> = AXES
        .iter()
        .map(|a| kinematics.axis_index(&a.to_uppercase()).unwrap())
        .collect();
    let tip0 = kin.pose(&[0.0; 5]).tip;
    let mut opts = IkOptions::default();
    opts.check_travel = false;
    let raw: Vec<[f64; 5]> = t
        .samples
        .iter()
        .map(|s| {
            let w = s.world;
            let mut q0 = vec![0.0; 5];
            q0[idx[3]] = w[3];
            q0[idx[4]] = w[4];
            let mask: Vec<bool> = (0..5).map(|i| i != idx[3] && i != idx[4]).collect();
            let target = IkTarget {
                tip: Vector3::new(w[0], w[1], w[2]) + tip0,
                axis: None,
            };
            let q = kin
                .inverse(&target, &q0, &mask, &opts)
                .unwrap_or_else(|e| panic!("inverse kinematics of {w:?}: {e}"));
            std::array::from_fn(|j| q[idx[j]])
        })
        .collect();
    let table = |j: usize| -> &JointTable {
        tables
            .iter()
            .find(|t| t.input == idx[j] && t.output == idx[j])
            .unwrap_or_else(|| panic!("no table for joint {j}"))
    };
    let (mut worst_joint, mut worst_motor, mut worst_table) = (0.0f64, 0.0f64, 0.0f64);
    let (mut settled, mut compared, mut turned) = (0usize, 0usize, 0usize);
    // LinuxCNC starts applying a joint's table when the joint first moves
    // (`backlash-corr` is 0 before): compare from there on.
    let first_move: Vec<usize> = (0..3)
        .map(|j| {
            t.samples
                .iter()
                .position(|s| s.joint_vel[j] != 0.0)
                .expect("every linear joint moves")
        })
        .collect();
    let before: Vec<f64> = (0..3)
        .map(|j| {
            t.samples[..first_move[j]]
                .iter()
                .map(|s| s.corr[j].abs())
                .fold(0.0, f64::max)
        })
        .collect();
    eprintln!(
        "closed loop: first motion of X Y Z at samples {first_move:?}, largest correction before it {before:?} mm"
    );
    let mut worst_at = (0, 0);
    for i in 3..t.samples.len() {
        let s = &t.samples[i];
        let q = interpolated(&raw, i);
        turned += usize::from(s.world[3].abs() > 1.0);
        for (qj, sj) in q.iter().zip(&s.joint) {
            worst_joint = worst_joint.max((qj - sj).abs());
        }
        for j in (0..3).filter(|&j| i >= first_move[j]) {
            // The correction LinuxCNC took from the exported file at its
            // own joint command: the table mtwin holds, interpolated there.
            let d = (s.corr[j] - table(j).eval(s.joint[j])).abs();
            if d > worst_table {
                worst_table = d;
                worst_at = (i, j);
            }
            compared += 1;
            // Slew limiting of the correction (backlash-filt) lags a fast
            // change; compare the drive command where it has settled.
            if (s.corr_filt[j] - s.corr[j]).abs() < 1e-12 {
                settled += 1;
                let want = q[j] + table(j).eval(q[j]);
                worst_motor = worst_motor.max((s.motor[j] - want).abs());
            }
        }
        // Rotary joints carry no table.
        assert_eq!(s.motor[3], s.joint[3]);
        assert_eq!(s.motor[4], s.joint[4]);
    }
    eprintln!(
        "closed loop: {} samples ({turned} with A turned), {settled} of {compared} settled; \
         joint {worst_joint:.2e}, table {worst_table:.2e}, motor {worst_motor:.2e} mm",
        t.samples.len()
    );
    let (wi, wj) = worst_at;
    let w = &t.samples[wi];
    eprintln!(
        "closed loop: largest table difference at sample {wi}, joint {wj}: command {}, velocity {}, correction {}, table {}",
        w.joint[wj],
        w.joint_vel[wj],
        w.corr[wj],
        table(wj).eval(w.joint[wj])
    );
    assert!(turned > 1000, "only {turned} samples with the table tilted");
    assert!(settled > compared * 9 / 10, "{settled} of {compared}");
    // kinematics.hal holds the parameters to 6 decimals: each of the five
    // is off by at most 5e-7 mm, and a point of a rotary axis line moves a
    // joint command by at most twice its error (|(I − R)δ| ≤ 2|δ|), so the
    // joint commands agree to 2·5·5e-7 = 5e-6 mm (plus 1e-9 of inverse
    // kinematics and interpolation).
    let tol_joint = 5e-6 + 1e-9;
    assert!(worst_joint < tol_joint, "joints off by {worst_joint} mm");
    // The comp files hold the values to 1e-9 mm.
    assert!(worst_table < 2e-9, "table off by {worst_table} mm");
    // The drive command: the joint bound plus the table's change over it
    // (slopes below 1e-3) plus the file rounding.
    assert!(
        worst_motor < tol_joint * 1.001 + 2e-9,
        "motor commands off by {worst_motor} mm"
    );
    // The compensation is not nothing: the tables move the drives by more
    // than the tolerance.
    let biggest = (0..3)
        .map(|j| {
            t.samples
                .iter()
                .map(|s| (s.motor[j] - s.joint[j]).abs())
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    assert!(biggest > 1e-3, "largest correction {biggest} mm");
}
