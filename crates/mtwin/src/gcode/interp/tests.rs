use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use super::*;
use crate::gcode::stream::Program;

fn run_with(src: &str, opts: InterpOptions) -> Result<Vec<Event>, GcodeError> {
    let program = Program::parse(src.as_bytes())?;
    let mut it = Interpreter::new(opts);
    let mut out = Vec::new();
    for b in &program.blocks {
        it.execute(b, &mut out)?;
    }
    Ok(out)
}

fn run(src: &str) -> Vec<Event> {
    run_with(src, InterpOptions::default()).unwrap()
}

fn moves(events: &[Event]) -> Vec<EventKind> {
    events
        .iter()
        .filter(|e| {
            matches!(
                e.kind,
                EventKind::Traverse(_) | EventKind::Feed(_) | EventKind::Arc(_)
            )
        })
        .map(|e| e.kind)
        .collect()
}

fn arc(kind: &EventKind) -> &ArcMove {
    match kind {
        EventKind::Arc(a) => a,
        other => panic!("not an arc: {other:?}"),
    }
}

fn lin(kind: &EventKind) -> &Linear {
    match kind {
        EventKind::Traverse(m) | EventKind::Feed(m) => m,
        other => panic!("not a straight move: {other:?}"),
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

#[test]
fn full_circle_in_xy() {
    let m = moves(&run("G0 X10 Y0\nG2 X10 Y0 I-10 J0 F100\n"));
    let a = arc(&m[1]);
    assert_eq!(a.center, [0.0, 0.0, 0.0]);
    assert_eq!(a.turns, -1);
    assert!(close(a.sweep(), -2.0 * PI));
    assert!(close(a.xyz_length(), 2.0 * PI * 10.0));
    assert_eq!(a.feed, Feed::PerMinute(100.0));
}

#[test]
fn zx_plane_uses_k_and_i_and_turns_about_plus_y() {
    // G18: first axis Z, second X, normal +Y. From (X0, Z10) about the
    // origin to (X10, Z0): in (z, x) that is (10, 0) to (0, 10), a quarter
    // turn counter-clockwise about +Y, i.e. G3.
    let m = moves(&run("G18 G0 X0 Z10\nG3 X10 Z0 K-10 F50\n"));
    let a = arc(&m[1]);
    assert_eq!(a.plane, Plane::Zx);
    assert_eq!(a.center, [0.0, 0.0, 0.0]);
    assert!(close(a.sweep(), FRAC_PI_2));
    assert_eq!(a.normal(), [0.0, 1.0, 0.0]);
    // A J word is out of the ZX plane.
    assert!(
        run_with(
            "G18 G0 X0 Z10\nG3 X10 Z0 K-10 J1 F50\n",
            InterpOptions::default()
        )
        .is_err()
    );
}

#[test]
fn helix_in_yz_with_turns_and_r_format() {
    // G19 plane: (y, z), normal +X. Two full turns plus nothing, rising 6 in X.
    let m = moves(&run("G19 G0 Y5 Z0\nG2 Y5 Z0 X6 J-5 P2 F10\n"));
    let a = arc(&m[1]);
    assert_eq!(a.turns, -2);
    assert!(close(a.sweep(), -4.0 * PI));
    assert!(close(a.xyz_length(), (4.0 * PI * 5.0f64).hypot(6.0)));
    // R format: half circle of radius 5 from (0,0) to (10,0), G2 goes over +Y.
    let m = moves(&run("G0 X0 Y0\nG2 X10 Y0 R5 F10\n"));
    let a = arc(&m[1]);
    assert!(close(a.center[0], 5.0) && close(a.center[1], 0.0));
    assert!(close(a.sweep(), -PI));
}

#[test]
fn units_distance_and_absolute_arc_centres() {
    let m = moves(&run("G20 G91 G0 X1 Y2\nX1\nG90 G90.1 G3 X0 Y0 I1 J1 F10\n"));
    let (l0, l1) = (lin(&m[0]), lin(&m[1]));
    assert!(close(l0.to[Axis::X], 25.4) && close(l0.to[Axis::Y], 50.8));
    assert!(close(l1.to[Axis::X], 50.8));
    let a = arc(&m[2]);
    assert!(close(a.center[0], 25.4) && close(a.center[1], 25.4));
    // Feed in inch/min is converted to mm/min.
    assert_eq!(a.feed, Feed::PerMinute(10.0 * 25.4));
}

#[test]
fn work_offsets_g53_and_tool_length() {
    let mut opts = InterpOptions::default();
    opts.work_offsets[1][Axis::X] = 100.0; // G55
    opts.work_offsets[1][Axis::Z] = -50.0;
    opts.tools.insert(crate::gcode::Tool::with_length(3, 20.0));
    let src = "G55 G0 X1 Z0\nG53 G0 Z-10\nT3 M6\nG43 H3\nG0 Z0\nG49 G0 Z0\n";
    let m = moves(&run_with(src, opts).unwrap());
    let l = lin(&m[0]);
    assert!(
        close(l.to[Axis::X] + l.offset[Axis::X], 101.0),
        "machine X = work + offset"
    );
    assert!(close(l.to[Axis::Z] + l.offset[Axis::Z], -50.0));
    let g53 = lin(&m[1]);
    assert!(g53.words.g53);
    assert!(
        close(g53.to[Axis::Z] + g53.offset[Axis::Z], -10.0),
        "G53 Z is machine Z"
    );
    assert!(close(g53.to[Axis::Z], 40.0));
    let tlo = lin(&m[2]);
    assert!(close(tlo.offset[Axis::Z], -50.0 + 20.0));
    assert!(
        close(tlo.from[Axis::Z], 40.0 - 20.0),
        "G43 keeps the machine position"
    );
    assert!(close(tlo.to[Axis::Z] + tlo.offset[Axis::Z], -30.0));
    assert!(close(lin(&m[3]).offset[Axis::Z], -50.0));
}

#[test]
fn word_value_recovers_the_written_word() {
    let mut opts = InterpOptions::default();
    opts.work_offsets[0][Axis::Z] = -7.0;
    let src = "G20 G0 Z1.5\nG91 G1 Z-0.25 F10\nG90 G53 G0 Z-2\n";
    let events = run_with(src, opts).unwrap();
    let written = [1.5, -0.25, -2.0];
    for (kind, w) in moves(&events).iter().zip(written) {
        let l = lin(kind);
        assert!(close(
            l.words
                .word_value(Axis::Z, &l.from, l.to[Axis::Z], &l.offset),
            w
        ));
    }
}

#[test]
fn rotary_rollover_follows_linuxcnc() {
    let mut opts = InterpOptions::default();
    opts.wrapped_rotary.insert(Axis::C);
    let m = moves(&run_with("G0 C350\nC10\nC-350\nC-0\n", opts).unwrap());
    let c: Vec<f64> = m.iter().map(|k| lin(k).to[Axis::C]).collect();
    // 350 → +10 goes forward to 370; -350 goes backwards to the angle 10
    // (mod 360) below 370, i.e. 10; -0 goes backwards to 0.
    assert_eq!(c, [350.0, 370.0, 10.0, 0.0]);
    assert!(
        run_with(
            "G0 C360\n",
            InterpOptions {
                wrapped_rotary: {
                    let mut m = AxisMask::EMPTY;
                    m.insert(Axis::C);
                    m
                },
                ..Default::default()
            }
        )
        .is_err()
    );
}

/// The commands LinuxCNC's task waits for motion before are events, in
/// its order within a block (outputs and input waits, tool change,
/// spindle, orientation, coolant; stops after the motion).
#[test]
fn task_waits_are_events() {
    use TaskWait::*;
    let ev = run(
        "T1 M6\nM8\nG0 X1 M9\nM7\nM19\nM64 P0\nM65 P0\nM66 P0 L0\nM68 E0 Q1\nM62 P0\nM0\nM1\nM60\nT2 M6 M3 M64 P1 M8\nG0 X2 M1\nM61 Q0\nM30\n",
    );
    let waits: Vec<(u64, TaskWait)> = ev
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Wait(w) => Some((e.at.line, w)),
            _ => None,
        })
        .collect();
    let want = vec![
        (1, ToolChange),
        (2, FloodOn),
        (3, MistOff),
        (3, FloodOff),
        (4, MistOn),
        (5, SpindleOrient),
        (6, Output),
        (7, Output),
        (8, InputWait),
        (9, Output),
        (11, Pause),
        (12, Pause),
        (13, Pause),
        (14, Output),
        (14, ToolChange),
        (14, FloodOn),
        (15, Pause),
        (16, ToolNumber),
    ];
    assert_eq!(waits, want);
    // M9 before the move of its block, M1 after it.
    let k = |line: u64| {
        ev.iter()
            .position(|e| e.at.line == line && matches!(e.kind, EventKind::Traverse(_)))
            .unwrap()
    };
    let w = |line: u64| {
        ev.iter()
            .position(|e| e.at.line == line && matches!(e.kind, EventKind::Wait(_)))
            .unwrap()
    };
    assert!(w(3) < k(3) && k(15) < w(15));
    // The spindle start of line 14 comes between its tool change and coolant.
    let spindle = ev
        .iter()
        .position(|e| e.at.line == 14 && matches!(e.kind, EventKind::Spindle(_)))
        .unwrap();
    assert!(ev[spindle - 1].kind == EventKind::Wait(ToolChange));
    assert!(ev[spindle + 1].kind == EventKind::Wait(FloodOn));
}

#[test]
fn a_probe_that_fails_without_contact_must_move() {
    // LinuxCNC 2.9 (its standalone rs274 run on each): G38.2 and G38.4
    // to their start on every axis are refused; G38.3 and G38.5 there
    // run; any other end runs, however close (0.009 in, 0.2 mm, an A
    // move alone).
    let opts = InterpOptions::default;
    for (src, ok) in [
        ("G21 G0 X0 Y0 Z0\nG38.2 Z-0.2 F100\nM2\n", true),
        ("G20 G0 X0 Y0 Z0\nG38.2 Z-0.009 F100\nM2\n", true),
        ("G21 G0 X0 Y0 Z0\nG38.2 A0.1 F100\nM2\n", true),
        ("G21 G0 X0 Y0 Z0\nG38.2 Z0 F100\nM2\n", false),
        ("G21 G0 X0 Y0 Z0\nG91 G38.4 X0 F100\nM2\n", false),
        ("G21 G0 X0 Y0 Z0\nG38.3 X0 Z0 F100\nM2\n", true),
        ("G21 G0 X0 Y0 Z0\nG91 G38.5 Z0 F100\nM2\n", true),
    ] {
        match run_with(src, opts()) {
            Ok(_) => assert!(ok, "{src} accepted"),
            Err(e) => {
                assert!(!ok, "{src}: {e}");
                let m = e.to_string();
                assert!(m.contains("Start point too close to probe point"), "{m}");
                // The column of the G38 word on line 2.
                let col = src.lines().nth(1).unwrap().find("G38").unwrap() + 1;
                assert!(m.contains(&format!("line 2, column {col}")), "{m}");
            }
        }
    }
    let e = run_with("G21 G95 S100 M3\nG38.2 Z-1 F1\nM2\n", opts()).unwrap_err();
    assert!(
        e.to_string()
            .contains("Cannot probe with feed per rev mode"),
        "{e}"
    );
}

#[test]
fn a_probe_runs_to_its_end_without_contact() {
    // #5061–#5069: the end in program units and the frame the probe ran
    // in (G55 X 1 in, G92 X0 at X 1: program X 0.5 is machine 2.5);
    // #5070 = 0 (not tripped), whatever the program set before. The
    // G1 reads them: X 0.5 + 1 = 1.5 in, Y 0.7 + 100·0, Z -0.5 in.
    let mut opts = InterpOptions::default();
    opts.work_offsets[1][Axis::X] = 25.4;
    let src = "G20 G55 G0 X1 Y1 Z1\nG92 X0\n#5070=1\nF10 G38.2 X0.5 Y0.7 Z-0.5\n\
               G1 X[#5061+1] Y[#5062+#5070*100] Z#5063\nM2\n";
    let ev = run_with(src, opts).unwrap();
    let got = ends(&ev);
    let want = [0.5 * 25.4, 0.7 * 25.4, -0.5 * 25.4];
    let probe = got[got.len() - 2].1;
    let last = got[got.len() - 1].1;
    for i in 0..3 {
        assert!(close(probe[i], want[i]), "{got:?}");
    }
    assert!(close(last[0], 1.5 * 25.4), "{got:?}");
    assert!(
        close(last[1], want[1]) && close(last[2], want[2]),
        "{got:?}"
    );
}

#[test]
fn modes_events_and_tcp() {
    let ev =
        run("M428\nG93 G1 X1 F2\nG94 F300 S1000 M3\nG4 P1.5\nM429\nG43.4 H0\nG49\nM30\nG0 X99\n");
    let kinds: Vec<EventKind> = ev.iter().map(|e| e.kind).collect();
    assert!(kinds.contains(&EventKind::Tcp(true)));
    assert!(matches!(
        kinds[3],
        EventKind::Feed(Linear {
            feed: Feed::InverseTime(2.0),
            tcp: true,
            ..
        })
    ));
    assert!(kinds.contains(&EventKind::FeedRate(300.0)));
    assert!(kinds.contains(&EventKind::SpindleSpeed { rpm: 1000.0 }));
    assert!(kinds.contains(&EventKind::Spindle(SpindleState::Clockwise)));
    assert!(kinds.contains(&EventKind::Dwell { seconds: 1.5 }));
    let tcp: Vec<bool> = kinds
        .iter()
        .filter_map(|k| {
            if let EventKind::Tcp(on) = k {
                Some(*on)
            } else {
                None
            }
        })
        .collect();
    assert_eq!(tcp, [true, false, true, false]);
    assert_eq!(
        kinds.last(),
        Some(&EventKind::ProgramEnd),
        "nothing after M30"
    );
    assert_eq!(
        ev[0].at,
        SourcePos {
            line: 1,
            block: 0,
            file: 0
        }
    );
    assert_eq!(
        ev.last().unwrap().at,
        SourcePos {
            line: 8,
            block: 7,
            file: 0
        }
    );
}

#[test]
fn rejections_name_the_line() {
    let cases = [
        // G76 without a spindle speed (no time), or with it stopped.
        ("M3\nG76 P1 Z-1 I-0.1 J0.1 K0.2\n", 2, true),
        ("G0 X0\nG76 P1 Z-1 I-0.1 J0.1 K0.2\n", 2, false),
        // G33/G33.1: K missing, F with it, spindle stopped, no axis,
        // I with G33 (LinuxCNC's errors); no spindle speed, rotary
        // word on G33.1, compensation on, K ≤ 0 (cannot be timed).
        ("S100 M3\nG33 Z-1\n", 2, false),
        ("S100 M3\nG33 Z-1 K1 F10\n", 2, false),
        ("S100 M3\nM5\nG33.1 Z-1 K1\n", 3, false),
        ("S100 M3\nG33 K1\n", 2, false),
        ("S100 M3\nG33 I1 Z-1 K1\n", 2, false),
        ("M3\nG33 Z-1 K1\n", 2, true),
        ("S100 M3\nG33.1 Z-1 A1 K1\n", 2, true),
        (
            "S100 M3\nG0 X-5\nG41.1 D1\nG1 X5 F10\nG33 X10 K1\n",
            5,
            true,
        ),
        ("S100 M4\nG33 Z-1 K0\n", 2, true),
        // Cutter radius compensation: entry not longer than the radius,
        // plane change while on, G19, G41.1 without D.
        ("G41.1 D4\nG0 X1\n", 2, false),
        ("G41.1 D4\nG0 X10\nG18\n", 3, false),
        ("G19 G41.1 D4\n", 1, false),
        ("G41.1\n", 1, false),
        // Not with a coordinate system rotation (G10 L2 R) in force.
        ("G10 L2 P1 R30\nG0 X1\nG41.1 D4\n", 3, true),
        ("G1 X1\n", 1, false),             // zero feed
        ("G93\nG1 X1 F1\nX2\n", 3, false), // inverse time needs F each move
        ("X1\n", 1, false),                // no motion mode
        ("G0 G1 X1\n", 1, false),          // one modal group twice
        ("G0 X1 X2\n", 1, false),          // two X words
        ("o100 sub\n", 1, true),
        ("G1 X1 I2 F1\n", 1, false),    // I without arc
        ("G2 X1 F1\n", 1, false),       // no IJKR
        ("G2 X1 I1 R1 F1\n", 1, false), // mixed formats
        ("G2 X30 R10 F1\n", 1, false),  // radius too small
        ("M123\n", 1, true),
        ("G53 G91 G0 X1\n", 1, false),
        ("G43 H7\n", 1, false), // tool not in the table
    ];
    for (src, line, unsupported) in cases {
        let err = run_with(src, InterpOptions::default()).expect_err(src);
        assert_eq!(err.location().map(|l| l.line), Some(line), "{src}: {err}");
        assert_eq!(
            matches!(err, GcodeError::Unsupported { .. }),
            unsupported,
            "{src}: {err}"
        );
    }
    let ignore = InterpOptions {
        unknown_m: UnknownMCode::Ignore,
        ..Default::default()
    };
    assert!(run_with("M123\n", ignore).is_ok());
}

#[test]
fn fanuc_dwell_and_integer_words() {
    let fanuc = InterpOptions {
        dialect: Dialect::Fanuc {
            decimal_point_programming: false,
        },
        ..Default::default()
    };
    let ev = run_with(
        "G4 P1500\nG4 X2.5\nG4 X2500\nG4 U750\nG0 X10 Y10.\n",
        fanuc.clone(),
    )
    .unwrap();
    let dwell: Vec<f64> = ev
        .iter()
        .filter_map(|e| {
            if let EventKind::Dwell { seconds } = e.kind {
                Some(seconds)
            } else {
                None
            }
        })
        .collect();
    // P in ms; X/U with a point in s, without one in 0.001 s.
    assert_eq!(dwell, [1.5, 2.5, 2.5, 0.75]);
    let l = lin(&moves(&ev)[0]).to;
    assert!(close(l[Axis::X], 0.01) && close(l[Axis::Y], 10.0));
    assert!(matches!(
        run_with("G90.1\n", fanuc),
        Err(GcodeError::Unsupported { .. })
    ));
    // LinuxCNC: P in seconds.
    let ev = run("G4 P1.5\n");
    assert_eq!(ev[0].kind, EventKind::Dwell { seconds: 1.5 });
}

#[test]
fn block_delete_and_percent() {
    let m = moves(&run("%\n/G0 X5\nG0 Y1\n%\n"));
    assert_eq!(m.len(), 1);
    let keep = InterpOptions {
        skip_deleted_blocks: false,
        ..Default::default()
    };
    assert_eq!(moves(&run_with("/G0 X5\n", keep).unwrap()).len(), 1);
}

/// Words no code of the block reads are refused as LinuxCNC refuses
/// them; the same words are accepted beside the codes that read them.
#[test]
fn unused_words_are_refused_like_linuxcnc() {
    let err = |src: &str| match run_with(src, InterpOptions::default()) {
        Err(GcodeError::Invalid { at, message }) => (at.column, message),
        other => panic!("{src}: expected an invalid block, got {other:?}"),
    };
    // `X1e3` is X1 and E3: refused, with the exponent explained.
    let (col, m) = err("G1 X1e3 F100\n");
    assert_eq!(col, 6, "{m}");
    assert!(m.starts_with("E word with no G76, M66, M67 or M68"), "{m}");
    assert!(m.contains("no exponent"), "{m}");
    let (col, m) = err("G1 X10 E5 F100\n");
    assert_eq!(col, 8);
    assert!(m.starts_with("E word") && !m.contains("exponent"), "{m}");
    let (col, m) = err("G1 X10 Q5 F100\n");
    assert_eq!(col, 8);
    assert!(m.starts_with("Q word with no"), "{m}");
    assert!(err("G1 X10 P2 F100\n").1.starts_with("P word with no"));
    assert!(err("G0 X1 L2\n").1.starts_with("L word with no"));
    assert!(err("G0 X1 D1\n").1.starts_with("D word with no"));
    assert!(err("G0 X1 H1\n").1.starts_with("H word with no G43"));
    // Beside the codes that read them the words are fine.
    for ok in [
        "G4 P1\n",
        "G64 P0.01 Q0.01\n",
        "G2 X10 I5 P2 F100\n",
        "M66 P0 L0 Q1\n",
        "M68 E0 Q1\n",
        "M61 Q0\n",
        "G43 H0\n",
        "N10 G0 X1\n",
        "/N10.5 G0 X1\n",
    ] {
        run_with(ok, InterpOptions::default()).unwrap_or_else(|e| panic!("{ok}: {e}"));
    }
}

/// A line number only starts a block and is an unsigned integer.
#[test]
fn line_numbers_as_linuxcnc_reads_them() {
    for bad in [
        "G0 N10 X1\n",
        "N-5 G0 X1\n",
        "N[1] G0 X1\n",
        "(c) N1 G0 X1\n",
    ] {
        assert!(
            matches!(
                Program::parse(bad.as_bytes()),
                Err(GcodeError::Syntax { .. })
            ),
            "{bad} must be a syntax error"
        );
    }
    // `N1e5` is N1 followed by an E word nothing reads.
    assert!(matches!(
        run_with("N1e5\n", InterpOptions::default()),
        Err(GcodeError::Invalid { .. })
    ));
}
/// Move ends (work X Y Z) and kinds, for the expansion tests.
fn ends(events: &[Event]) -> Vec<(char, [f64; 3])> {
    moves(events)
        .iter()
        .map(|k| match k {
            EventKind::Traverse(l) => ('R', l.to.xyz()),
            EventKind::Feed(l) => ('F', l.to.xyz()),
            EventKind::Arc(a) => ('A', a.to.xyz()),
            _ => unreachable!(),
        })
        .collect()
}

fn assert_ends(got: &[(char, [f64; 3])], want: &[(char, [f64; 3])]) {
    assert_eq!(got.len(), want.len(), "{got:?}\n{want:?}");
    for (g, w) in got.iter().zip(want) {
        assert_eq!(g.0, w.0, "{got:?}\n{want:?}");
        for k in 0..3 {
            assert!(close(g.1[k], w.1[k]), "{got:?}\n{want:?}");
        }
    }
}

#[test]
fn g80_shares_a_line_with_a_motion_code() {
    // LinuxCNC's read_g: G80 beside another motion code is ignored.
    let m = moves(&run("G0 G17 G40 G49 G80 G90 X1\n"));
    assert!(close(lin(&m[0]).to[Axis::X], 1.0));
    assert!(matches!(m[0], EventKind::Traverse(_)));
    let m = moves(&run("G80 G1 X2 F100\n"));
    assert!(matches!(m[0], EventKind::Feed(_)));
    // G80 alone with axis words: no motion mode.
    assert!(run_with("G80 X1\n", InterpOptions::default()).is_err());
    // Fanuc: G80 has its own group; the line reads the same.
    let fanuc = InterpOptions {
        dialect: Dialect::Fanuc {
            decimal_point_programming: true,
        },
        ..Default::default()
    };
    let m = moves(&run_with("G0 G80 X1.\n", fanuc.clone()).unwrap());
    assert!(close(lin(&m[0]).to[Axis::X], 1.0));
    // Two codes of one motion group are still refused.
    assert!(run_with("G0 G1 X1\n", fanuc).is_err());
}

#[test]
fn reading_stops_at_the_program_end() {
    // After M30 nothing is interpreted (the callers stop reading).
    let text = "G0 X1\nM30\nPost Process Timed at; 32 Min, 50.0 sec\n";
    let mut got = Vec::new();
    crate::gcode::interpret(text.as_bytes(), InterpOptions::default(), |_, e| {
        got.extend_from_slice(e);
        Ok(())
    })
    .unwrap();
    assert_eq!(moves(&got).len(), 1);
    // A file starting with '%' ends at the next '%' line.
    let text = "\n%\nG0 X1\n%\nthis is not G-code\n";
    let mut n = 0;
    crate::gcode::interpret(text.as_bytes(), InterpOptions::default(), |_, e| {
        n += moves(e).len();
        Ok(())
    })
    .unwrap();
    assert_eq!(n, 1);
    // Without a leading '%' a '%' line does not end the program.
    assert_eq!(moves(&run("G0 X1\n%\nG0 X2\n")).len(), 2);
}

/// The system parameters read LinuxCNC's values, derived by hand: a
/// G54 offset X5, the machine at X8 (work X3), G92 X1 there (offset
/// 3 − 1 = 2, work X1), tool 2 (length 7) loaded and applied (work Z
/// 0 − 7 = −7).
#[test]
fn system_parameters_follow_the_state() {
    let mut opts = InterpOptions::default();
    let mut t2 = crate::gcode::Tool::with_length(2, 7.0);
    t2.offset[Axis::X] = 0.5;
    t2.diameter = 6.0;
    opts.tools.insert(t2);
    let mut it = Interpreter::new(opts);
    let src = "G10 L2 P1 X5\nG0 X3\nG92 X1\nT2 M6 G43\nG28.1\nG20\nG55\n";
    let program = Program::parse(src.as_bytes()).unwrap();
    let mut ev = Vec::new();
    let p = |it: &Interpreter, n: u32| it.parameters().get(n);
    for (k, b) in program.blocks.iter().enumerate() {
        it.execute(b, &mut ev).unwrap();
        match k {
            0 => {
                assert_eq!(p(&it, 5221), 5.0);
                assert_eq!(p(&it, 5420), -5.0, "machine 0 in G54 X5");
            }
            1 => assert_eq!(p(&it, 5420), 3.0),
            2 => {
                assert_eq!((p(&it, 5210), p(&it, 5211)), (1.0, 2.0));
                assert_eq!(p(&it, 5420), 1.0);
                assert_eq!(p(&it, 5400), 0.0, "no tool yet");
            }
            3 => {
                assert_eq!(p(&it, 5400), 2.0);
                assert_eq!((p(&it, 5401), p(&it, 5403)), (0.5, 7.0));
                assert_eq!(p(&it, 5410), 6.0);
                // G43 applies X0.5 too: work X 1 − 0.5, Z 0 − 7.
                assert_eq!((p(&it, 5420), p(&it, 5422)), (0.5, -7.0));
            }
            4 => {
                // Machine X 5 + 2 + 0.5 + 0.5 = 8, Z −7 + 7 = 0.
                assert_eq!((p(&it, 5161), p(&it, 5163)), (8.0, 0.0));
            }
            5 => {
                // The point in inches; offsets stay in mm.
                assert!((p(&it, 5420) - 0.5 / 25.4).abs() < 1e-12);
                assert!((p(&it, 5422) + 7.0 / 25.4).abs() < 1e-12);
                assert_eq!((p(&it, 5221), p(&it, 5211), p(&it, 5403)), (5.0, 2.0, 7.0));
                assert_eq!(p(&it, 5220), 1.0);
            }
            _ => {
                assert_eq!(p(&it, 5220), 2.0);
                // G55 has no offset: work X = machine 8 − G92 2 − tool 0.5.
                assert!((p(&it, 5420) - 5.5 / 25.4).abs() < 1e-12);
            }
        }
    }
    // A program cannot set them by assignment (mtwin would not use the
    // value as LinuxCNC does); the current point it may (LinuxCNC
    // overwrites it before the next line).
    for (bad, col) in [("#5221=1\n", 1), ("G0 X1 #5400=3\n", 7), ("#5161=0\n", 1)] {
        let e = run_with(bad, InterpOptions::default()).unwrap_err();
        assert!(matches!(e, GcodeError::Unsupported { .. }), "{bad}: {e}");
        assert!(
            e.to_string().contains(&format!("line 1, column {col}")),
            "{bad}: {e}"
        );
    }
    run_with("#5420=3\n#5231=1\n#5399=1\n", InterpOptions::default()).unwrap();
    // Homes and G92 come from the var file at start (5210 = 1: applied).
    let mut opts = InterpOptions::default();
    let mut start = Parameters::new();
    for (n, v) in [
        (5161, 10.0),
        (5183, -4.0),
        (5210, 1.0),
        (5211, 2.0),
        (5221, 1.0),
    ] {
        start.set(n, v).unwrap();
    }
    opts.work_offsets = start.work_offsets();
    opts.program.parameters = std::sync::Arc::new(start);
    let mut it = Interpreter::new(opts);
    assert_eq!(
        (p(&it, 5161), p(&it, 5183), p(&it, 5211)),
        (10.0, -4.0, 2.0)
    );
    assert_eq!(p(&it, 5420), -3.0, "machine 0 − G54 1 − G92 2");
    let b = Program::parse(b"G28\n").unwrap();
    let mut ev = Vec::new();
    it.execute(&b.blocks[0], &mut ev).unwrap();
    assert_eq!(p(&it, 5420), 7.0, "machine 10 − 1 − 2");
}

#[test]
fn g92_family_shifts_the_program_frame() {
    // Machine at X10; G92 X0 makes it read 0: axis offset 10.
    let src = "G0 X10\nG92 X0\nG0 X5\nG92.2\nG0 X5\nG92.3\nG0 X1\nG92.1\nG0 X1\n";
    let mut it = Interpreter::new(InterpOptions::default());
    let program = Program::parse(src.as_bytes()).unwrap();
    let mut ev = Vec::new();
    for (k, b) in program.blocks.iter().enumerate() {
        it.execute(b, &mut ev).unwrap();
        if k == 1 {
            assert_eq!(it.state().axis_offset[Axis::X], 10.0);
            assert_eq!(it.state().g92_saved[Axis::X], 10.0);
            assert!(it.state().g92_applied);
            assert_eq!(it.state().position[Axis::X], 0.0);
        }
    }
    let m = moves(&ev);
    let machine = |k: usize| lin(&m[k]).to[Axis::X] + lin(&m[k]).offset[Axis::X];
    assert!(close(machine(1), 15.0), "G92: X5 is machine 15");
    assert!(close(machine(2), 5.0), "G92.2: offsets off");
    assert!(close(machine(3), 11.0), "G92.3: restored from 5211");
    assert!(close(machine(4), 1.0), "G92.1: off");
    assert_eq!(it.state().g92_saved, Axes::ZERO, "G92.1 clears 5211-5219");
    // G92 in inch, with a work offset: offset = machine - work - value.
    let mut opts = InterpOptions::default();
    opts.work_offsets[0][Axis::Y] = 100.0;
    let m = moves(&run_with("G20 G0 Y1\nG92 Y0\nG0 Y2\n", opts).unwrap());
    let l = lin(&m[1]);
    assert!(close(
        l.to[Axis::Y] + l.offset[Axis::Y],
        100.0 + 25.4 + 50.8
    ));
    // G52 sets the offset itself.
    let m = moves(&run("G0 X1\nG52 X5\nG0 X1\n"));
    let l = lin(&m[1]);
    assert!(close(l.to[Axis::X] + l.offset[Axis::X], 6.0));
    // G92 needs axis words and no motion code beside it.
    assert!(run_with("G92\n", InterpOptions::default()).is_err());
    assert!(run_with("G1 G92 X1 F10\n", InterpOptions::default()).is_err());
}

#[test]
fn g10_l2_l20_set_work_offsets() {
    // G10 L2 P2 then G55 (a CAM set-up): machine = work + offset.
    let m = moves(&run("G10 L2 P2 X100 Y50 Z-20\nG55 G0 X1 Y2 Z3\n"));
    let l = lin(&m[0]);
    let machine = l.to.add(&l.offset);
    assert!(close(machine[Axis::X], 101.0) && close(machine[Axis::Y], 52.0));
    assert!(close(machine[Axis::Z], -17.0));
    // L2 P0 changes the active system at once; the tool stays where it is.
    let m = moves(&run("G0 X10\nG10 L2 P0 X4\nG0 X0\n"));
    let l = lin(&m[1]);
    assert!(close(l.from[Axis::X], 6.0) && close(l.offset[Axis::X], 4.0));
    // L20: the current position reads X3 in G54: offset = 10 - 3.
    let mut it = Interpreter::new(InterpOptions::default());
    let mut ev = Vec::new();
    for b in &Program::parse(b"G0 X10\nG10 L20 P1 X3\n").unwrap().blocks {
        it.execute(b, &mut ev).unwrap();
    }
    assert_eq!(it.state().work_offsets[0][Axis::X], 7.0);
    assert_eq!(it.state().position[Axis::X], 3.0);
    run("G10 L2 P1 X1 R0\n");
    for bad in [
        "G10 L2 P10 X1\n",
        "G10 L3 P1 X1\n",
        "G10 L2 P1.5 X1\n",
        "G0 G10 L2 P1 X1\n",
    ] {
        assert!(run_with(bad, InterpOptions::default()).is_err(), "{bad}");
    }
}

/// The state after running `src` (work position, machine position).
fn state_after(src: &str) -> ModalState {
    let mut it = Interpreter::new(InterpOptions::default());
    let mut ev = Vec::new();
    for b in &Program::parse(src.as_bytes()).unwrap().blocks {
        it.execute(b, &mut ev).unwrap();
    }
    it.state().clone()
}

#[test]
fn g10_l2_r_rotates_the_xy_plane() {
    let near = |a: f64, b: f64| (a - b).abs() < 1e-12;
    let xy = |v: &Axes| (v[Axis::X], v[Axis::Y]);
    // Machine = R·program + offset: R90 takes (3, 4) to (-4, 3).
    let m = moves(&run("G10 L2 P1 X2 R90\nG0 X3 Y4\n"));
    let l = lin(&m[0]);
    let machine = l.to.add(&l.offset);
    assert!(near(machine[Axis::X], -2.0) && near(machine[Axis::Y], 3.0));
    assert!(near(l.to[Axis::X], -4.0) && near(l.to[Axis::Y], 3.0));
    // Setting the rotation of the active system keeps the machine point:
    // (3, 4) in an unrotated G54 reads R(-90)·((3, 4) - (2, 0)) = (4, -1).
    let st = state_after("G0 X3 Y4\nG10 L2 P1 X2 R90\n");
    let (x, y) = xy(&st.position);
    assert!(near(x, 4.0) && near(y, -1.0), "{x} {y}");
    assert_eq!(st.rotation, 90.0);
    // Switching systems: machine (10, 0) in G55 (X5, R90) reads (0, -5).
    let st = state_after("G10 L2 P2 X5 R90\nG0 X10 Y0\nG55\n");
    let (x, y) = xy(&st.position);
    assert!(near(x, 0.0) && near(y, -5.0), "{x} {y}");
    // G92 is in the rotated frame: machine = R·(program + G92) + G5x.
    let st = state_after("G10 L2 P1 R90\nG0 X1 Y0\nG92 X0 Y0\nG0 X1\nG10 L2 P2 R0\nG55\n");
    let (x, y) = xy(&st.position);
    // Machine R90·(2, 0) = (0, 2); G55 has the G92 offset (1, 0) too.
    assert!(near(x, -1.0) && near(y, 2.0), "{x} {y}");
    // G53 to machine (10, 0) with G54 at X2 R90: R(-90)·(8, 0) = (0, -8).
    let st = state_after("G10 L2 P1 X2 R90\nG53 G0 X10 Y0\n");
    let (x, y) = xy(&st.position);
    assert!(near(x, 0.0) && near(y, -8.0), "{x} {y}");
    // G10 L20 in a rotated system: the current point reads the values.
    let st = state_after("G10 L2 P1 X2 R90\nG0 X3 Y4\nG10 L20 P1 X0 Y0\n");
    let (x, y) = xy(&st.work_offsets[0]);
    assert!(near(x, -2.0) && near(y, 3.0), "{x} {y}");
    // G28 to machine zero: R(-90)·((0, 0) - (2, 0)) = (0, 2).
    let st = state_after("G10 L2 P1 X2 R90\nG0 X3 Y4\nG28\n");
    let (x, y) = xy(&st.position);
    assert!(near(x, 0.0) && near(y, 2.0), "{x} {y}");
    // An XY arc turns with the plane: centre (1, 0) -> (0, 1), end
    // (1, 1) -> (-1, 1); its turns are unchanged.
    let m = moves(&run("G10 L2 P1 R90\nG0 X2 Y0\nG3 X1 Y1 I-1 F100\n"));
    let a = arc(&m[1]);
    assert!(near(a.center[0], 0.0) && near(a.center[1], 1.0));
    assert!(near(a.to[Axis::X], -1.0) && near(a.to[Axis::Y], 1.0));
    assert_eq!(a.turns, 1);
    // Refused: arcs of other planes, TCP.
    for bad in [
        "G10 L2 P1 R30\nG18 G2 X1 Z1 R1 F100\n",
        "G10 L2 P1 R30\nM428\nG0 X1\n",
        "G0 X1\nG92 X0\nG10 L2 P0 R30\n",
        "G10 L2 P1 R30\nG92 Y2\nG10 L20 P1 X0\n",
    ] {
        assert!(
            matches!(
                run_with(bad, InterpOptions::default()),
                Err(GcodeError::Unsupported { .. })
            ),
            "{bad}"
        );
    }
}

#[test]
fn g10_l1_l10_l11_set_tool_entries() {
    let opts = InterpOptions {
        tools: [(1, 10.0)].into_iter().collect(),
        ..Default::default()
    };
    let mut it = Interpreter::new(opts.clone());
    let mut ev = Vec::new();
    let src = "G10 L1 P1 Z25 R3\nT1 M6 G43\nG0 Z0\nG10 L10 P1 Z5\nG10 L11 P1 Z7\n";
    for b in &Program::parse(src.as_bytes()).unwrap().blocks {
        it.execute(b, &mut ev).unwrap();
    }
    // After L1 the table holds Z25, diameter 6; G43 applies it.
    let m = moves(&ev);
    assert!(close(lin(&m[0]).offset[Axis::Z], 25.0));
    // L10: the current position (Z0 with the tool's 25) reads Z5 with
    // this tool: length = 0 + 25 - 5 = 20. L11 the same in G59.3 (zero).
    let t = it.tools().get(1).unwrap();
    assert!(close(t.offset[Axis::Z], 25.0 - 7.0));
    assert!(close(t.diameter, 6.0));
    assert!(
        run_with("G10 L1 P2 Z1\n", opts.clone()).is_err(),
        "tool 2 not in table"
    );
    assert!(run_with("G10 L1 P1\n", opts).is_err(), "no offsets");
}

/// Runs `src` and returns the interpreter (its tool table and state).
fn interp_after(src: &str, opts: InterpOptions) -> Interpreter {
    let mut it = Interpreter::new(opts);
    let mut ev = Vec::new();
    for b in &Program::parse(src.as_bytes()).unwrap().blocks {
        it.execute(b, &mut ev).unwrap();
    }
    it
}

#[test]
fn g10_l10_l11_in_a_rotated_system_make_the_point_read_the_words() {
    let xy = |v: &Axes| (v[Axis::X], v[Axis::Y]);
    let opts = InterpOptions {
        tools: [(1, 0.0), (2, 3.0)].into_iter().collect(),
        ..Default::default()
    };
    // G54 at (10, 5) turned 30°, tool 1 (no offset) at work (3, 4, 2):
    // machine = R30·(3, 4) + (10, 5). After G10 L10 X1 Y2 Z0.5 and G43
    // the same machine point must read (1, 2, 0.5): machine =
    // R30·(1, 2) + (10, 5) + tool, so tool = R30·((3, 4) − (1, 2)) and
    // its Z is 2 − 0.5.
    let (sn, cs) = 30f64.to_radians().sin_cos();
    let rot = |x: f64, y: f64| (x * cs - y * sn, x * sn + y * cs);
    let src = "G10 L2 P1 X10 Y5 R30\nG0 X3 Y4 Z2\nT1 M6 G43\nG10 L10 P1 X1 Y2 Z0.5\nG43\n";
    let it = interp_after(src, opts.clone());
    let t = it.tools().get(1).unwrap().offset;
    let (tx, ty) = rot(2.0, 2.0);
    assert!(close(t[Axis::X], tx) && close(t[Axis::Y], ty), "{t:?}");
    assert!(close(t[Axis::Z], 1.5));
    let (x, y) = xy(&it.state().position);
    assert!(close(x, 1.0) && close(y, 2.0) && close(it.state().position[Axis::Z], 0.5));
    // X alone: the new X reading along the rotated X axis, the old
    // offset's part along the rotated Y axis kept. The point (work
    // (1, 2) with the tool's R30·(2, 2)) is R30·(3, 4) from the origin
    // and must read X7: the offset becomes R30·(3 − 7, 0) plus the
    // old R30·(0, 2).
    let it = interp_after(&format!("{src}G10 L10 P1 X7\nG43\n"), opts.clone());
    let t = it.tools().get(1).unwrap().offset;
    let (ax, ay) = rot(-4.0, 0.0);
    let (bx, by) = rot(0.0, 2.0);
    assert!(
        close(t[Axis::X], ax + bx) && close(t[Axis::Y], ay + by),
        "{t:?}"
    );
    let (x, y) = xy(&it.state().position);
    assert!(close(x, 7.0) && close(y, 2.0), "{x} {y}");
    // Y alone, with a G92 offset in force: the point still reads the
    // word (G92 shifts both readings alike).
    let src2 = "G10 L2 P1 X10 Y5 R30\nG0 X3 Y4\nG92 X0 Y0\nT1 M6 G43\nG10 L10 P1 Y-2\nG43\n";
    let it = interp_after(src2, opts.clone());
    let (x, y) = xy(&it.state().position);
    assert!(close(x, 0.0) && close(y, -2.0), "{x} {y}");
    // L11: the words are read in G59.3 (turned 90°, origin (1, 1)):
    // after L11 X0 Y0 Z0 and G59.3 G43 the point reads (0, 0, 0).
    let src3 = "G10 L2 P9 X1 Y1 R90\nG10 L2 P1 X10 Y5 R30\nG0 X3 Y4 Z2\nT2 M6 G43\nG10 L11 P2 X0 Y0 Z0\nG59.3 G43\n";
    let it = interp_after(src3, opts);
    let p = it.state().position;
    assert!(
        close(p[Axis::X], 0.0) && close(p[Axis::Y], 0.0) && close(p[Axis::Z], 0.0),
        "{p:?}"
    );
}

#[test]
fn g28_g30_go_through_the_waypoint_home() {
    // G28.1 stores the machine position; G28 Z5 goes to Z5 then home Z.
    let mut opts = InterpOptions::default();
    opts.work_offsets[0][Axis::Z] = -100.0;
    let src = "G0 X1 Y2 Z50\nG28.1\nG0 X7 Y8 Z0\nG91 G28 Z5\nG90 G30\n";
    let ev = run_with(src, opts).unwrap();
    let e = ends(&ev);
    assert_ends(
        &e[2..],
        &[
            ('R', [7.0, 8.0, 5.0]),   // waypoint, incremental
            ('R', [7.0, 8.0, 50.0]),  // home on Z only (machine -50)
            ('R', [7.0, 8.0, 50.0]),  // G30: no words, waypoint here
            ('R', [0.0, 0.0, 100.0]), // G30 home is machine zero
        ],
    );
}

#[test]
fn tool_table_g43_variants() {
    let opts = InterpOptions {
        tools: ToolTable::parse("T1 P1 Z10\nT2 P2 Z20 X1\n", Units::Millimetre).unwrap(),
        ..Default::default()
    };
    let ev = run_with(
        "T1 M6\nG43\nG0 Z0\nG43 H2\nG0 Z0\nG43.2 H1\nG0 Z0\nG43.1 Z3\nG0 Z0\nG43.2 Z1\nG0 Z0\nG49\nG0 Z0\n",
        opts.clone(),
    )
    .unwrap();
    let offs: Vec<(f64, f64)> = moves(&ev)
        .iter()
        .map(|k| (lin(k).offset[Axis::X], lin(k).offset[Axis::Z]))
        .collect();
    assert_eq!(
        offs,
        // G43.2 with axis words moves in the modal G0 too (LinuxCNC's
        // enhance_block), G43.1 does not.
        [
            (0.0, 10.0),
            (1.0, 20.0),
            (1.0, 30.0),
            (1.0, 3.0),
            (1.0, 4.0),
            (1.0, 4.0),
            (0.0, 0.0)
        ]
    );
    for bad in ["G43 H3\n", "G43.2\n", "G43.2 H1 Z1\n", "T1 M6 G43 H-1\n"] {
        assert!(run_with(bad, opts.clone()).is_err(), "{bad}");
    }
    // H0 is the tool in the spindle (LinuxCNC's tool index 0, checked
    // against rs274 2.9): tool 2 (X1 Z20), then added once more by
    // G43.2; with no tool loaded, no offset.
    let ev = run_with("T2 M6\nG43 H0\nG0 Z0\nG43.2 H0\nG0 Z0\n", opts.clone()).unwrap();
    let offs: Vec<(f64, f64)> = moves(&ev)
        .iter()
        .map(|k| (lin(k).offset[Axis::X], lin(k).offset[Axis::Z]))
        .collect();
    assert_eq!(offs, [(1.0, 20.0), (2.0, 40.0)]);
    let ev = run_with("G43 H0\nG0 Z0\n", opts).unwrap();
    assert_eq!(lin(&moves(&ev)[0]).offset[Axis::Z], 0.0);
}

/// M61 Qn declares tool n in the spindle without a change (LinuxCNC
/// 2.9's CHANGE_TOOL_NUMBER, its I/O controller loading n's entry into
/// the spindle's): a later G43 (no H, or H0) applies n's offsets and
/// #5400–#5413 read n; M61 keeps the selected tool and the offset in
/// force. Table: tool 1 Z10, tool 2 X1 Z20 (mm).
#[test]
fn m61_sets_the_tool_in_the_spindle_without_a_change() {
    let opts = InterpOptions {
        tools: ToolTable::parse("T1 P1 Z10\nT2 P2 Z20 X1 D6\n", Units::Millimetre).unwrap(),
        ..Default::default()
    };
    let offsets = |src: &str| -> Vec<(f64, f64)> {
        moves(&run_with(src, opts.clone()).unwrap())
            .iter()
            .map(|k| (lin(k).offset[Axis::X], lin(k).offset[Axis::Z]))
            .collect()
    };
    // G43 after M61 Q2 applies tool 2, on its line or later; H0 too.
    assert_eq!(offsets("T1 M6\nM61 Q2\nG43\nG0 Z0\n"), [(1.0, 20.0)]);
    assert_eq!(offsets("M61 Q2 G43\nG0 Z0\n"), [(1.0, 20.0)]);
    assert_eq!(offsets("T1 M6\nM61 Q2\nG43 H0\nG0 Z0\n"), [(1.0, 20.0)]);
    // The offset in force stays until a G43; M6 loads the selected
    // tool 1 again; Q0 empties the spindle.
    assert_eq!(offsets("T2 M6 G43\nM61 Q1\nG0 Z0\n"), [(1.0, 20.0)]);
    assert_eq!(offsets("T1 M6\nM61 Q2\nM6\nG43\nG0 Z0\n"), [(0.0, 10.0)]);
    assert_eq!(offsets("T2 M6\nM61 Q0\nG43\nG0 Z0\n"), [(0.0, 0.0)]);
    // On the line of an M6 or M61, LinuxCNC's spindle entry (H0, and
    // G43 when the new tool is 0) is still the tool loaded before; G43
    // without H reads the new tool's entry (as rs274 2.9 does).
    assert_eq!(offsets("T1 M6\nT2 M6 G43 H0\nG0 Z0\n"), [(0.0, 10.0)]);
    assert_eq!(offsets("T1 M6\nM61 Q2 G43 H0\nG0 Z0\n"), [(0.0, 10.0)]);
    assert_eq!(offsets("T1 M6\nM61 Q2 G43.2 H0\nG0 Z0\n"), [(0.0, 10.0)]);
    assert_eq!(
        offsets("T1 M6\nM61 Q2 G43 H0\nG43 H0\nG0 Z0\n"),
        [(1.0, 20.0)]
    );
    assert_eq!(offsets("T2 M6\nM61 Q0 G43\nG0 Z0\n"), [(1.0, 20.0)]);
    assert_eq!(offsets("T2 M6\nT0 M6 G43\nG0 Z0\n"), [(1.0, 20.0)]);
    assert_eq!(offsets("T1 M6\nT2 M6 G43\nG0 Z0\n"), [(1.0, 20.0)]);
    // Q rounds to the nearest integer (LinuxCNC's round_to_int).
    assert_eq!(offsets("M61 Q1.6 G43\nG0 Z0\n"), [(1.0, 20.0)]);
    assert_eq!(offsets("M61 Q-0.4 G43\nG0 Z0\n"), [(0.0, 0.0)]);
    // The parameters read the tool from the line after M61.
    let it = interp_after("T1 M6\nM61 Q2\n", opts.clone());
    let p = |n: u32| it.parameters().get(n);
    assert_eq!((it.state().tool, it.state().selected_tool), (2, 1));
    assert_eq!((p(5400), p(5401), p(5403), p(5410)), (2.0, 1.0, 20.0, 6.0));
    let it = interp_after("T2 M6\nM61 Q0\n", opts.clone());
    assert_eq!(
        (it.parameters().get(5400), it.parameters().get(5403)),
        (0.0, 0.0)
    );
    // Errors, worded as LinuxCNC 2.9's.
    let err = |src: &str| match run_with(src, opts.clone()) {
        Err(GcodeError::Invalid { at, message }) => (at.column, message),
        other => panic!("{src}: expected an invalid block, got {other:?}"),
    };
    let need = "Need non-negative Q-word to specify tool number with M61";
    assert_eq!(err("M61\n"), (1, need.to_string()));
    assert_eq!(err("G0 X1 M61 Q-0.6\n"), (11, need.to_string()));
    assert_eq!(
        err("M61 Q3\n"),
        (
            5,
            "Requested tool 3 not found in the tool table".to_string()
        )
    );
    assert!(
        err("M61 Q1 M6\n")
            .1
            .starts_with("two M-codes of one modal group")
    );
    // T of a tool the table does not hold, as rs274 2.9 refuses it; T0
    // is no tool; without a table any T is taken.
    assert_eq!(
        err("G0 X1 T3\n"),
        (
            7,
            "Requested tool 3 not found in the tool table".to_string()
        )
    );
    assert_eq!(offsets("T2 M6\nT0 M6\nG43\nG0 Z0\n"), [(0.0, 0.0)]);
    run_with("T3 M6\n", InterpOptions::default()).unwrap();
}

/// G33 moves at K per revolution of S; G33.1 taps to the end and back
/// (the retract at I times the speed), leaving the position where it
/// was; stats time them as length / (K × S).
#[test]
fn g33_and_rigid_tap_run_at_k_per_revolution() {
    let src = "G21 S600 M3\nG0 X1 Z5\nG33 Z-10 K1.5\nG91 G33 X2 Z-3 K0.5\nG90 G20\n\
               G33.1 Z-1 K0.05 I2\nG33.1 Z-0.5 K0.05 I0.5\nG21 G1 X0 F10\n";
    let m = moves(&run(src));
    assert_eq!(m.len(), 8, "{m:?}");
    let feed = |k: &EventKind| match lin(k).feed {
        Feed::PerRevolution { mm_per_rev, rpm } => (mm_per_rev, rpm),
        f => panic!("not per revolution: {f:?}"),
    };
    assert_eq!(lin(&m[1]).to.xyz(), [1.0, 0.0, -10.0]);
    assert_eq!(feed(&m[1]), (1.5, 600.0));
    let l2 = lin(&m[2]);
    assert!(close(l2.to[Axis::X], 3.0) && close(l2.to[Axis::Z], -13.0));
    assert_eq!(feed(&m[2]), (0.5, 600.0));
    // Taps: 25.4 mm down at 0.05 in = 1.27 mm per revolution, back at
    // twice the speed; I below 1 is 1.
    let (down, up) = (lin(&m[3]), lin(&m[4]));
    assert!(close(down.to[Axis::Z], -25.4) && close(down.from[Axis::Z], -13.0));
    assert_eq!((down.from, down.to), (up.to, up.from));
    let (k, rpm) = feed(&m[3]);
    assert!(close(k, 1.27) && rpm == 600.0);
    assert_eq!(feed(&m[4]).1, 1200.0);
    assert_eq!(feed(&m[6]).1, 600.0);
    assert!(close(lin(&m[5]).to[Axis::Z], -12.7));
    assert!(m[3..7].iter().all(|k| lin(k).words.expanded));
    // The feed after the taps starts where they started.
    assert_eq!(lin(&m[7]).from, lin(&m[2]).to);

    // Time: 15 mm at 1.5 mm/rev × 600 rev/min = 1 s; the tap 20 mm at
    // 1 mm/rev × 600 down (2 s) and × 1200 up (1 s).
    let opts = super::super::stats::StatsOptions::default();
    let st = super::super::stats::stats(
        "S600 M3\nG0 Z5\nG33 Z-10 K1.5\nG33.1 Z-30 K1 I2\nM2\n".as_bytes(),
        &opts,
    )
    .unwrap();
    assert!((st.feed_time - 4.0).abs() < 1e-9, "{}", st.feed_time);
}

#[test]
fn g76_threads_in_spindle_synchronised_passes() {
    // From X10 Z5 to Z-20: depths 1.4, 1.8, 2 (I-1 J0.4 K1), each pass
    // back, in, along Z at 1.5 mm/rev, out; then to the end point X3 Y2.
    let src = "G18 G0 X10 Z5\nS500 M3\nG76 P1.5 X3 Y2 Z-20 I-1 J0.4 K1\nG1 X0 F100\n";
    let m = moves(&run(src));
    assert_eq!(m.len(), 1 + 3 * 4 + 1 + 1, "{m:?}");
    for (k, depth) in [1.4, 1.8, 2.0].into_iter().enumerate() {
        let p = &m[1 + 4 * k..5 + 4 * k];
        let back = 10.0 - depth + 2.0;
        let xz = |e: &EventKind| (lin(e).to[Axis::X], lin(e).to[Axis::Z]);
        let near = |a: (f64, f64), b: (f64, f64)| close(a.0, b.0) && close(a.1, b.1);
        assert!(matches!(p[0], EventKind::Traverse(_)) && near(xz(&p[0]), (back, 5.0)));
        assert!(matches!(p[1], EventKind::Traverse(_)) && near(xz(&p[1]), (10.0 - depth, 5.0)));
        assert!(matches!(p[2], EventKind::Feed(_)) && near(xz(&p[2]), (10.0 - depth, -20.0)));
        assert_eq!(
            lin(&p[2]).feed,
            Feed::PerRevolution {
                mm_per_rev: 1.5,
                rpm: 500.0
            }
        );
        assert!(matches!(p[3], EventKind::Traverse(_)) && near(xz(&p[3]), (back, -20.0)));
        assert!(
            p.iter()
                .all(|e| lin(e).words.expanded && lin(e).to[Axis::Y] == 0.0)
        );
    }
    assert_eq!(lin(&m[13]).to.xyz(), [3.0, 2.0, -20.0]);
    assert_eq!(lin(&m[14]).from.xyz(), [3.0, 2.0, -20.0]);
    // Time: three passes of 25 mm at 1.5 mm/rev × 500 rev/min = 2 s each.
    let opts = super::super::stats::StatsOptions::default();
    let st = super::super::stats::stats(
        "G18 G0 X10 Z5\nS500 M3\nG76 P1.5 Z-20 I-1 J0.4 K1\nM2\n".as_bytes(),
        &opts,
    )
    .unwrap();
    assert!((st.feed_time - 6.0).abs() < 1e-9, "{}", st.feed_time);
    // Incremental Z, inch: the thread ends 1 in below the start.
    let m = moves(&run(
        "G20 G0 X1 Z0\nS500 M3\nG91 G76 P0.1 Z-1 I-0.05 J0.01 K0.03\n",
    ));
    let last = lin(m.last().unwrap());
    assert!(close(last.to[Axis::Z], -25.4) && close(last.to[Axis::X], 25.4));
    // Refused as LinuxCNC refuses them, and what cannot be timed.
    for (bad, unsupported) in [
        ("S500 M3\nG76 Z-1 I-1 J0.1 K0.5\n", false),       // no P
        ("S500 M3\nG76 P-1 Z-1 I-1 J0.1 K0.5\n", false),   // P-1 is "no P"
        ("S500 M3\nG76 P1 Z-1 I-1 K0.5\n", false),         // no J
        ("S500 M3\nG76 P1 I-1 J0.1 K0.5\n", false),        // no axis
        ("S500 M3\nG76 P1 Z-1 I0 J0.1 K0.5\n", false),     // I = 0
        ("S500 M3\nG76 P1 Z-1 I-1 J0.5 K0.5\n", false),    // K = J
        ("S500 M3\nG76 P1 Z-1 A1 I-1 J0.1 K0.5\n", false), // rotary
        ("S500 M3\nG76 P1 Z-1 I-1 J0.1 K0.5 L-1\n", false),
        ("S500 M3\nG76 P1 Z-1 I-1 J0.1 K0.5 H1.5\n", false),
        ("G76 P1 Z-1 I-1 J0.1 K0.5\n", false), // spindle stopped
        (
            "S500 M3\nG41.1 D1\nG1 X5 F100\nG76 P1 Z-1 I-1 J0.1 K0.5\n",
            false,
        ),
        ("S500 M3\nG76 P1 Z-1 I-1 J0.00005 K1\n", false), // 20 000 passes
        ("S500 M3\nG76 P0 Z-1 I-1 J0.1 K0.5\n", true),
        ("M3\nG76 P1 Z-1 I-1 J0.1 K0.5\n", true),
    ] {
        let err = run_with(bad, InterpOptions::default()).expect_err(bad);
        assert_eq!(
            matches!(err, GcodeError::Unsupported { .. }),
            unsupported,
            "{bad}: {err}"
        );
    }
    // Modal: a later line with axis words runs G76 again (and needs P).
    assert!(
        run_with(
            "S500 M3\nG76 P1 Z-1 I-1 J0.1 K0.5\nZ-2\n",
            InterpOptions::default()
        )
        .is_err()
    );
}

/// LinuxCNC's polar coordinates: end points by hand (distance `@`,
/// angle `^` in degrees from +X), the G91 one as rs274 prints it.
#[test]
fn polar_words_stand_for_x_and_y() {
    let (c45, s45) = (5.0 * FRAC_PI_4.cos(), 5.0 * FRAC_PI_4.sin());
    let src = "G21 G90 G0 X10 Y0 Z0\n\
               G1 @5 ^90 F100\n\
               ^-90\n\
               @2\n\
               G91 ^90\n\
               @3\n\
               G90 G0 X3 Y4\n\
               G91 G1 @5 ^90\n\
               G90 G18 G0 @5 ^45 Z1\n\
               G17\n\
               G20 G0 @2 ^180\n\
               M2\n";
    assert_ends(
        &ends(&run(src)),
        &[
            ('R', [10.0, 0.0, 0.0]),
            ('F', [0.0, 5.0, 0.0]),
            ('F', [0.0, -5.0, 0.0]),
            ('F', [0.0, -2.0, 0.0]),
            ('F', [2.0, 0.0, 0.0]),
            ('F', [5.0, 0.0, 0.0]),
            ('R', [3.0, 4.0, 0.0]),
            // r 5 + 5, angle atan2(4, 3) + 90°.
            ('F', [-8.0, 6.0, 0.0]),
            // The plane checked is the one before the block (G17).
            ('R', [c45, s45, 1.0]),
            ('R', [-50.8, 0.0, 1.0]),
        ],
    );
}

#[test]
fn polar_canned_cycles_place_the_holes() {
    // G90: the hole at @5 ^45. G91 with L4: each repeat turns the hole
    // by ^90 about the origin, from (10, 0): (0, 10), (-10, 0),
    // (0, -10), (10, 0); R 5 - 4 = 1, bottom 1 - 2 = -1.
    let (c45, s45) = (5.0 * FRAC_PI_4.cos(), 5.0 * FRAC_PI_4.sin());
    let src = "G21 G90 G0 X10 Y0 Z5\nG81 @5 ^45 R1 Z-1 F100\nG80 G0 X10 Y0 Z5\n\
               G91 G81 ^90 R-4 Z-2 L4\nG80\nM2\n";
    let holes: Vec<[f64; 3]> = ends(&run(src))
        .into_iter()
        .filter(|(k, _)| *k == 'F')
        .map(|(_, p)| p)
        .collect();
    let want = [
        [c45, s45, -1.0],
        [0.0, 10.0, -1.0],
        [-10.0, 0.0, -1.0],
        [0.0, -10.0, -1.0],
        [10.0, 0.0, -1.0],
    ];
    assert_eq!(holes.len(), want.len(), "{holes:?}");
    for (h, w) in holes.iter().zip(want) {
        assert!((0..3).all(|i| close(h[i], w[i])), "{holes:?}");
    }
}

#[test]
fn polar_words_are_refused_as_linuxcnc_refuses_them() {
    for (src, message) in [
        (
            "G21 G0 X0 Y0\nG1 @5 F100\n",
            "Must specify angle in polar coordinate if at the origin",
        ),
        (
            "G21 G0 X0 Y0\nG91 G1 ^5 F100\n",
            "G91 motion with polar coordinates is indeterminate",
        ),
        (
            "G21 G0 X0 Y0\nG91 G1 @5 F100\n",
            "Incremental motion with polar coordinates is indeterminate",
        ),
        (
            "G18\nG17 G0 @5 ^0\n",
            "Cannot use polar coordinate except in G17 plane",
        ),
        (
            "G0 X1\nG0 X1 @5\n",
            "Cannot specify both polar coordinate and X word",
        ),
        (
            "G0 X1\nG0 ^5 Y1\n",
            "Cannot specify both polar coordinate and Y word",
        ),
        (
            "G0 X1\nG28 @5\n",
            "Polar coordinates can only be used for motion",
        ),
        (
            "G0 X1\nG10 L2 P1 @5\n",
            "Polar coordinates can only be used for motion",
        ),
        (
            "G0 X1\nG53 G0 @5\n",
            "Cannot use polar coordinates with G53",
        ),
        ("G0 X1\nG80 @5\n", "Cannot use axis values with G80"),
    ] {
        let e = run_with(src, InterpOptions::default()).unwrap_err();
        assert!(e.to_string().contains(message), "{src}: {e}");
        assert!(e.to_string().contains("line 2"), "{src}: {e}");
    }
    // LinuxCNC 2.9 reads the last of two @ words without an error:
    // refused as unsupported, never read one way or the other.
    let e = run_with("G0 X1\nG0 @1 @2\n", InterpOptions::default()).unwrap_err();
    assert!(matches!(e, GcodeError::Unsupported { .. }), "{e}");
    let fanuc = InterpOptions {
        dialect: Dialect::Fanuc {
            decimal_point_programming: true,
        },
        ..InterpOptions::default()
    };
    let e = run_with("G0 X1\nG0 @1 ^2\n", fanuc).unwrap_err();
    assert!(matches!(e, GcodeError::Unsupported { .. }), "{e}");
}

#[test]
fn words_of_axes_the_machine_lacks_are_refused() {
    let mut opts = InterpOptions {
        machine_axes: AxisMask::EMPTY,
        ..InterpOptions::default()
    };
    for a in [Axis::X, Axis::Y, Axis::Z, Axis::A, Axis::B, Axis::C] {
        opts.machine_axes.insert(a);
    }
    let e = run_with("G21 G0 X1\nG1 w100 F10\nM2\n", opts.clone()).unwrap_err();
    assert!(e.to_string().contains("line 2, column 4"), "{e}");
    assert!(e.to_string().contains("Bad character 'w' used"), "{e}");
    // Also where no move reads it.
    assert!(run_with("G10 L2 P1 U1\nM2\n", opts.clone()).is_err());
    assert!(run_with("G21 G0 X1 C5\nM2\n", opts).is_ok());
    assert!(run_with("G21 G0 X1 W5\nM2\n", InterpOptions::default()).is_ok());
}

/// The expansions of LinuxCNC's G-code manual (canned cycles), by hand
/// (G98 written where the retract goes to the initial level: a program
/// starts in G99, as LinuxCNC's interpreter).
#[test]
fn canned_cycles_expand_as_linuxcnc() {
    // G81, absolute, G98: from Z3 (above R), rapid to XY, to R, feed to
    // bottom, rapid back to the initial level.
    let e = ends(&run("G0 X1 Y2 Z3\nG90 G98 G81 X4 Y5 Z-0.6 R1.8 F10\n"));
    assert_ends(
        &e[1..],
        &[
            ('R', [4.0, 5.0, 3.0]),
            ('R', [4.0, 5.0, 1.8]),
            ('F', [4.0, 5.0, -0.6]),
            ('R', [4.0, 5.0, 3.0]),
        ],
    );
    // The manual's incremental example: G91 G98 G81 X4 Y5 Z-0.6 R1.8 L3
    // from (1, 2, 3): R = 4.8, bottom 4.2, clear = 4.8 (initial 3 < R).
    let e = ends(&run("G0 X1 Y2 Z3\nG91 G98 G81 X4 Y5 Z-0.6 R1.8 L3 F10\n"));
    assert_ends(
        &e[1..],
        &[
            ('R', [1.0, 2.0, 4.8]),
            ('R', [5.0, 7.0, 4.8]),
            ('F', [5.0, 7.0, 4.2]),
            ('R', [5.0, 7.0, 4.8]),
            ('R', [9.0, 12.0, 4.8]),
            ('F', [9.0, 12.0, 4.2]),
            ('R', [9.0, 12.0, 4.8]),
            ('R', [13.0, 17.0, 4.8]),
            ('F', [13.0, 17.0, 4.2]),
            ('R', [13.0, 17.0, 4.8]),
        ],
    );
    // Without G98/G99 the program is in G99, as LinuxCNC's interpreter
    // starts (its `retract_mode(R_PLANE)`): back to R = 2, not to 10.
    let e = ends(&run("G0 Z10\nG81 X1 Z-1 R2 F10\n"));
    assert_eq!(e.last().map(|p| p.1[2]), Some(2.0), "{e:?}");
    // Modal: the next line reuses R and Z; G99 retracts to R.
    let e = ends(&run("G0 Z10\nG99 G81 X1 Z-1 R2 F10\nX2\nG80\n"));
    assert_ends(
        &e[1..],
        &[
            ('R', [1.0, 0.0, 10.0]),
            ('R', [1.0, 0.0, 2.0]),
            ('F', [1.0, 0.0, -1.0]),
            ('R', [1.0, 0.0, 2.0]),
            ('R', [2.0, 0.0, 2.0]),
            ('F', [2.0, 0.0, -1.0]),
            ('R', [2.0, 0.0, 2.0]),
        ],
    );
    // G83 peck Q1 from R2 to -1.5: feeds to 1, 0, -1, then -1.5; after
    // each peck a rapid to R and back down to 0.254 mm above the depth.
    let e = ends(&run("G0 Z5\nG98 G83 Z-1.5 R2 Q1 F10\n"));
    let z: Vec<(char, f64)> = e[2..].iter().map(|(k, p)| (*k, p[2])).collect();
    let want = [
        ('R', 2.0),
        ('F', 1.0),
        ('R', 2.0),
        ('R', 1.254),
        ('F', 0.0),
        ('R', 2.0),
        ('R', 0.254),
        ('F', -1.0),
        ('R', 2.0),
        ('R', -0.746),
        ('F', -1.5),
        ('R', 5.0),
    ];
    assert_eq!(z.len(), want.len(), "{z:?}");
    for (g, w) in z.iter().zip(want) {
        assert!(g.0 == w.0 && close(g.1, w.1), "{z:?}");
    }
    // G73: no return to R between pecks.
    let e = ends(&run("G98 G0 Z5\nG73 Z-0.5 R1 Q1 F10\n"));
    let z: Vec<f64> = e[2..].iter().map(|(_, p)| p[2]).collect();
    assert!(
        z.iter()
            .zip([1.0, 0.0, 0.254, -0.5, 5.0])
            .all(|(a, b)| close(*a, b)),
        "{z:?}"
    );
    // G18 (ZX plane): the cycle axis is Y.
    let e = ends(&run("G18 G98 G0 Y5\nG81 X1 Z2 Y-1 R1 F10\n"));
    assert_ends(
        &e[1..],
        &[
            ('R', [1.0, 5.0, 2.0]),
            ('R', [1.0, 1.0, 2.0]),
            ('F', [1.0, -1.0, 2.0]),
            ('R', [1.0, 5.0, 2.0]),
        ],
    );
    // G82/G89 dwell, G84 reverses the spindle.
    let ev = run("G98 G0 Z5\nM3 S100\nG84 Z-1 R1 F10\n");
    let spindle: Vec<SpindleState> = ev
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Spindle(s) => Some(s),
            _ => None,
        })
        .collect();
    use SpindleState::*;
    assert_eq!(
        spindle,
        [Clockwise, Stopped, CounterClockwise, Stopped, Clockwise]
    );
    let ev = run("G98 G0 Z5\nG82 Z-1 R1 P0.5 F10\n");
    assert!(
        ev.iter()
            .any(|e| e.kind == EventKind::Dwell { seconds: 0.5 })
    );
    // At the bounds themselves the blocks run.
    for ok in [
        "G81 X1 Z-1 R1 L10000 F10\n",
        "G83 X1 Z-1 R1 Q0.5 L2500 F10\n", // 4 pecks a hole: 10 000
    ] {
        assert!(run_with(ok, InterpOptions::default()).is_ok(), "{ok}");
    }
    // LinuxCNC's errors.
    for bad in [
        "G81 X1 Z-1 F10\n",           // no R
        "G81 X1 R1 F10\n",            // no Z
        "G81 X1 Z2 R1 F10\n",         // R below Z
        "G81 X1 Z-1 R1\n",            // zero feed
        "G81 X1 Z-1 R1 L0 F10\n",     // zero repeats
        "G81 X1 Z-1 R1 L10001 F10\n", // beyond MAX_CYCLE_REPEATS
        // Beyond MAX_CYCLE_PECKS: a huge R, a tiny Q with repeats.
        "G83 X1 Z-1 R100000000000000000000 Q1 F10\n",
        "G83 X1 Z-1 R1 Q0.0001 L1000 F10\n",
        "G83 X1 Z-1 R1 Q0.5 L2501 F10\n", // 4 pecks a hole: 10 004
        // Q below the resolution of the depth (ulp of 1e20 is 16 384).
        "G83 X1 Z100000000000000000000 R100000000000000016384 Q1 F10\n",
        "G83 X1 Z-1 R1 F10\n",    // no Q
        "G82 X1 Z-1 R1 F10\n",    // no P
        "G84 X1 Z-1 R1 F10\n",    // spindle stopped
        "G81 X1 Z-1 R1 A5 F10\n", // rotary axis
        "G93 G81 X1 Z-1 R1 F10\n",
    ] {
        assert!(run_with(bad, InterpOptions::default()).is_err(), "{bad}");
    }
}
