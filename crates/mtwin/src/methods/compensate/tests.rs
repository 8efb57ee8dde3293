use std::path::Path;

use nalgebra::Vector3;

use super::path::NominalPath;
use super::*;
use crate::gcode::{self, AxisLetterError, EventKind};
use crate::model::{parse_machine, read_machine};

fn example(name: &str) -> Machine {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/machines")
        .join(name);
    read_machine(&p).expect("example machine reads")
}

fn run(machine: &Machine, program: &[u8], opts: &CompensateOptions) -> (Vec<u8>, Summary) {
    let mut out = Vec::new();
    let s = compensate(machine, program, &mut out, opts).expect("compensation succeeds");
    (out, s)
}

/// Five-axis program without TCP: lines, a long line, rotary moves,
/// incremental moves and a half circle. Every block of the source carries a
/// comment; inserted blocks do not.
const PLAIN: &str = "G21 G90 G94 (setup)\r\n\
G0 X10 Y20 Z-50 A10 C0 (1)\r\n\
G1 X150. Y-80 Z-60 F1000 (2)\r\n\
G1 X-150 (3 long)\r\n\
G1 A30 C45 (4 rotaries)\r\n\
G1 X100 Y100 Z-100 A20 C200 (5)\r\n\
G91 G1 X-20 Y5 (6 incremental)\r\n\
G90 G2 X120 Y105 I20 J0 (7 half circle)\r\n\
X160 Y105 I20 J0 (8 modal arc)\r\n\
G1 X0 Y0 Z-20 (9)\r\n\
M30 (end)\r\n";

/// TCP program: X Y Z is the tip in W.
const TCP: &str = "G21 G90 G94 (setup)\n\
M428 (tcp on)\n\
G0 X0 Y0 Z50 A0 C0 (1)\n\
G1 X40 Y-30 Z10 F800 (2)\n\
G1 X-60 Y30 Z5 A25 C-40 (3)\n\
G1 X-20 Y60 Z0 A-35 C120 (4)\n\
M429 (tcp off)\n\
M30 (end)\n";

/// One move of a program, with whether its block was tagged by a comment.
struct Mv {
    path: NominalPath,
    tcp: bool,
    feed: bool,
    tagged: bool,
}

fn moves(program: &[u8], opts: &InterpOptions) -> Vec<Mv> {
    let mut out = Vec::new();
    gcode::interpret(program, opts.clone(), |block, events| {
        let tagged = block.text().contains(&b'(');
        for e in events {
            let (path, tcp, feed) = match e.kind {
                EventKind::Traverse(m) => (NominalPath::line(&m), m.tcp, false),
                EventKind::Feed(m) => (NominalPath::line(&m), m.tcp, true),
                EventKind::Arc(a) => (NominalPath::arc(&a), a.tcp, true),
                _ => continue,
            };
            out.push(Mv {
                path,
                tcp,
                feed,
                tagged,
            });
        }
        Ok(())
    })
    .expect("program interprets");
    out
}

/// Independent simulation: what a controller does with a program point.
struct Sim {
    nominal: Kinematics,
    actual: Kinematics,
    letters: Vec<Axis>,
    linear: Vec<bool>,
}

impl Sim {
    fn new(m: &Machine) -> Sim {
        Sim {
            nominal: Kinematics::nominal(m),
            actual: Kinematics::new(m),
            letters: m
                .axes
                .iter()
                .map(|a| Axis::from_letter(a.name.as_bytes()[0]).unwrap())
                .collect(),
            linear: m.axes.iter().map(|a| a.kind == AxisKind::Linear).collect(),
        }
    }

    /// Machine axes that the nominal controller commands for a program point.
    fn axes(&self, p: &Axes, tcp: bool) -> Vec<f64> {
        let q: Vec<f64> = self.letters.iter().map(|&g| p[g]).collect();
        if !tcp {
            return q;
        }
        let t = IkTarget {
            tip: Vector3::from(p.xyz()),
            axis: None,
        };
        self.nominal
            .inverse(&t, &q, &self.linear, &IkOptions::default())
            .unwrap()
    }

    /// Tip and axis the programmer meant at a program point.
    fn wanted(&self, p: &Axes, tcp: bool) -> (Vector3<f64>, Vector3<f64>) {
        let pose = self.nominal.pose(&self.axes(p, tcp));
        (pose.tip, pose.axis)
    }

    /// Tip and axis the actual machine reaches.
    fn reached(&self, p: &Axes, tcp: bool) -> (Vector3<f64>, Vector3<f64>) {
        let pose = self.actual.pose(&self.axes(p, tcp));
        (pose.tip, pose.axis)
    }
}

/// Distance from `x` to the segment `[a, b]`.
fn to_segment(x: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = b - a;
    let t = if d.norm_squared() > 0.0 {
        ((x - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + d * t - x).norm()
}

/// Checks the compensated program `new` against the nominal program `old` on
/// the actual machine; returns the largest end and midpoint deviations, mm,
/// and the largest tool-axis angle at ends away from A = 0, rad.
fn check(m: &Machine, old: &[u8], new: &[u8], opts: &InterpOptions) -> (f64, f64, f64) {
    let sim = Sim::new(m);
    let old_moves = moves(old, opts);
    let new_moves = moves(new, opts);
    // Ends of source blocks, matched in order.
    let old_tagged: Vec<&Mv> = old_moves.iter().filter(|m| m.tagged).collect();
    let new_tagged: Vec<&Mv> = new_moves
        .iter()
        .enumerate()
        .filter(|(k, _)| {
            // The end of a source block is the end of its last piece.
            new_moves.get(k + 1).is_none_or(|n| n.tagged)
        })
        .map(|(_, m)| m)
        .collect();
    assert_eq!(old_tagged.len(), new_tagged.len());
    let mut worst_end: f64 = 0.0;
    let mut worst_axis: f64 = 0.0;
    for (o, n) in old_tagged.iter().zip(&new_tagged) {
        let (tip, axis) = sim.wanted(&o.path.at(1.0), o.tcp);
        let (t2, a2) = sim.reached(&n.path.at(1.0), n.tcp);
        worst_end = worst_end.max((t2 - tip).norm());
        // At A = 0 the tool axis lies along C: its tilt is not corrected.
        if o.path.at(1.0)[Axis::A].abs() > 1.0 {
            worst_axis = worst_axis.max(a2.angle(&axis));
        }
    }
    // Midpoints of every new feed move against the nominal path polylines.
    const N: usize = 4096;
    let polylines: Vec<Vec<Vector3<f64>>> = old_moves
        .iter()
        .filter(|m| m.feed)
        .map(|m| {
            (0..=N)
                .map(|k| sim.wanted(&m.path.at(k as f64 / N as f64), m.tcp).0)
                .collect()
        })
        .collect();
    let mut worst_mid: f64 = 0.0;
    for n in new_moves.iter().filter(|m| m.feed) {
        let (x, _) = sim.reached(&n.path.at(0.5), n.tcp);
        let d = polylines
            .iter()
            .flat_map(|pl| pl.windows(2).map(|w| to_segment(&x, &w[0], &w[1])))
            .fold(f64::INFINITY, f64::min);
        worst_mid = worst_mid.max(d);
    }
    (worst_end, worst_mid, worst_axis)
}

/// Rounding of written numbers: half of 1e-4 mm on three axes.
const ROUNDING: f64 = 0.5e-4 * 1.74;

#[test]
fn zero_error_model_leaves_programs_byte_identical() {
    let m = example("ac-trunnion.toml");
    let opts = CompensateOptions::default();
    for prog in [PLAIN, TCP] {
        let (out, s) = run(&m, prog.as_bytes(), &opts);
        assert_eq!(String::from_utf8(out).unwrap(), prog);
        assert_eq!(s.blocks_changed, 0);
        assert_eq!(s.blocks_inserted, 0);
        assert_eq!(s.largest_correction, 0.0);
    }
}

#[test]
fn zero_error_model_leaves_the_corpus_boat_identical() {
    let Some(p) = crate::test_support::shared_dir("corpus/gcode/linuxcnc/boat-xyzac.ngc") else {
        return;
    };
    let text = std::fs::read(&p).unwrap();
    let m = example("ac-trunnion.toml");
    let (out, s) = run(&m, &text, &CompensateOptions::default());
    assert!(out == text, "boat-xyzac.ngc changed");
    assert_eq!(s.blocks_changed, 0);
}

#[test]
fn known_errors_plain_program_reaches_nominal_on_the_actual_machine() {
    let m = example("ac-trunnion-with-errors.toml");
    // Correcting the tool axis far from the rotary axes moves the linear axes
    // by up to 0.7 mm here.
    let opts = CompensateOptions {
        max_correction: 2.0,
        ..CompensateOptions::default()
    };
    // Without compensation the actual machine misses by far more than tol.
    let (end0, _, axis0) = check(&m, PLAIN.as_bytes(), PLAIN.as_bytes(), &opts.interp);
    assert!(end0 > 10.0 * opts.tol, "uncompensated error {end0}");
    assert!(axis0 > 1e-5, "uncompensated axis error {axis0}");
    let (out, s) = run(&m, PLAIN.as_bytes(), &opts);
    assert!(s.blocks_changed >= 8);
    let (end, mid, axis) = check(&m, PLAIN.as_bytes(), &out, &opts.interp);
    assert!(end <= opts.tol + ROUNDING, "end deviation {end}");
    assert!(mid <= opts.tol + ROUNDING, "midpoint deviation {mid}");
    // Rotary words are rounded to 1e-4 degree (1.7e-6 rad).
    assert!(axis < 2e-6, "tool axis deviation {axis}");
}

#[test]
fn known_errors_tcp_program_keeps_tcp_semantics() {
    let m = example("ac-trunnion-with-errors.toml");
    let opts = CompensateOptions::default();
    let (end0, _, axis0) = check(&m, TCP.as_bytes(), TCP.as_bytes(), &opts.interp);
    assert!(end0 > 10.0 * opts.tol, "uncompensated error {end0}");
    assert!(axis0 > 1e-5, "uncompensated axis error {axis0}");
    let (out, _) = run(&m, TCP.as_bytes(), &opts);
    let (end, mid, axis) = check(&m, TCP.as_bytes(), &out, &opts.interp);
    assert!(end <= opts.tol + ROUNDING, "end deviation {end}");
    assert!(mid <= opts.tol + ROUNDING, "midpoint deviation {mid}");
    // Rotary words are rounded to 1e-4 degree (1.7e-6 rad).
    assert!(axis < 2e-6, "tool axis deviation {axis}");
}

/// Three linear axes, straightness of X in Y: δy = c·x² (c in 1/mm).
fn parabola_machine(c: f64) -> Machine {
    let text = format!(
        r#"name = "parabola"
tool_chain = ["X", "Y", "Z"]
workpiece_chain = []
[tool]
tip = [0.0, 0.0, 0.0]
direction = [0.0, 0.0, 1.0]
[workpiece]
origin = [0.0, 0.0, 0.0]
[[axes]]
name = "X"
kind = "linear"
direction = [1.0, 0.0, 0.0]
travel = [-400.0, 400.0]
  [axes.errors]
  EYX = {{ poly = [0.0, 0.0, {c}] }}
[[axes]]
name = "Y"
kind = "linear"
direction = [0.0, 1.0, 0.0]
travel = [-400.0, 400.0]
[[axes]]
name = "Z"
kind = "linear"
direction = [0.0, 0.0, 1.0]
travel = [-400.0, 400.0]
"#
    );
    parse_machine(Path::new("parabola.toml"), &text).expect("machine parses")
}

#[test]
fn subdivision_matches_the_chord_error_of_a_parabola() {
    // Chord of length h under δy = c x²: midpoint error c h²/4. With c = 2e-6
    // and tol = 1 µm, 600 mm needs h ≤ 44.7 mm: 16 equal halvings (37.5 mm).
    let m = parabola_machine(2e-6);
    let opts = CompensateOptions::default();
    let prog = "G0 X-300 Y0 Z0\nG1 X300 F500\n";
    let (out, s) = run(&m, prog.as_bytes(), &opts);
    assert_eq!(s.blocks_subdivided, 1);
    assert_eq!(s.blocks_inserted, 15);
    let text = String::from_utf8(out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2 + 15);
    // Every piece end: Y = −c x² (the correction cancels the straightness),
    // to half the last written decimal plus the inverse kinematics' tolerance
    // (a thousandth of it: −c·225² = −0.10125 is a rounding tie).
    for l in &lines[1..] {
        let b = Block::parse(l.as_bytes(), 1).unwrap();
        let x = b.word('X').unwrap().and_then(|w| w.number()).unwrap();
        let y = b.word('Y').unwrap().and_then(|w| w.number()).unwrap();
        assert!((y + 2e-6 * x * x).abs() <= 0.5e-4 * 1.001, "x {x} y {y}");
        assert!(((x + 300.0) / 37.5).fract().abs() < 1e-9);
    }
    // A shorter tolerance-free move (50 mm: c h²/4 = 1.25 µm) splits once.
    let (_, s) = run(&m, b"G0 X0 Y0 Z0\nG1 X50 F500\n", &opts);
    assert_eq!(s.blocks_inserted, 1);
    let (_, s) = run(&m, b"G0 X0 Y0 Z0\nG1 X40 F500\n", &opts);
    assert_eq!(s.blocks_inserted, 0);
}

#[test]
fn inverse_time_feed_is_split_with_the_pieces() {
    let m = parabola_machine(2e-6);
    let opts = CompensateOptions::default();
    let (out, _) = run(&m, b"G0 X0 Y0 Z0\nG93 G1 X50 F2\n", &opts);
    let text = String::from_utf8(out).unwrap();
    // Two halves of a 1/2-minute move: 1/4 minute each, F = 4.
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3);
    assert!(lines[1].contains("F4") && lines[2].contains("F4"), "{text}");
}

#[test]
fn refuses_corrections_above_the_limit_naming_the_line() {
    let m = example("ac-trunnion-with-errors.toml");
    let opts = CompensateOptions {
        max_correction: 1e-4,
        ..CompensateOptions::default()
    };
    let err = compensate(&m, PLAIN.as_bytes(), Vec::new(), &opts).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("line 2:") && msg.contains("exceeds the limit"),
        "{msg}"
    );
}

#[test]
fn refuses_targets_outside_travel_naming_the_line() {
    let m = example("ac-trunnion.toml");
    let prog = "G21 G90\nG1 X10 F100\nG1 X350\n";
    let err = compensate(
        &m,
        prog.as_bytes(),
        Vec::new(),
        &CompensateOptions::default(),
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("line 3:") && msg.contains("outside its travel"),
        "{msg}"
    );
}

#[test]
fn arc_path_runs_from_start_to_end_on_the_circle() {
    let opts = InterpOptions::default();
    let ms = moves(b"G0 X10 Y0 Z0\nG3 X-10 Y0 I-10 J0 Z4 F100\n", &opts);
    let p = ms[1].path;
    let at = |s: f64| p.at(s);
    assert!((at(0.0)[Axis::X] - 10.0).abs() < 1e-12);
    assert!((at(1.0)[Axis::X] + 10.0).abs() < 1e-12 && at(1.0)[Axis::Y].abs() < 1e-12);
    // Counter-clockwise half circle: the midpoint is (0, 10), Z halfway.
    let m = at(0.5);
    assert!(m[Axis::X].abs() < 1e-12 && (m[Axis::Y] - 10.0).abs() < 1e-12);
    assert!((m[Axis::Z] - 2.0).abs() < 1e-12);
}

#[test]
fn fanuc_program_without_decimal_points_gets_points_in_every_new_number() {
    // Fanuc without decimal point programming: `X10` is 0.010 mm. A new
    // number written without a point would be read in least increments, so
    // every rewritten word must carry one; the program must still reach the
    // nominal targets when read the Fanuc way.
    let m = example("ac-trunnion-with-errors.toml");
    let mut opts = CompensateOptions {
        max_correction: 2.0,
        ..CompensateOptions::default()
    };
    opts.interp.dialect = crate::gcode::Dialect::Fanuc {
        decimal_point_programming: false,
    };
    let program = "G21 G90 G94 (setup)\nG0 X10000 Y20000 Z-50000 A10000 C0 (1)\n\
                   G1 X150. Y-80000 Z-60. F1000 (2)\nG1 X-150000 (3)\nG1 A30. C45000 (4)\n\
                   G1 X100. Y100. Z-100. A20. C200. (5)\nM30 (end)\n";
    let (out, s) = run(&m, program.as_bytes(), &opts);
    assert!(s.blocks_changed >= 4, "{s:?}");
    let text = String::from_utf8(out.clone()).unwrap();
    let old_words: Vec<&str> = program.split_whitespace().collect();
    let mut new_words = 0;
    for w in text.split_whitespace() {
        if !old_words.contains(&w) && w.starts_with(['X', 'Y', 'Z', 'A', 'C']) {
            assert!(w.contains('.'), "`{w}` has no decimal point in\n{text}");
            new_words += 1;
        }
    }
    assert!(new_words >= 8, "{text}");
    // A whole value, which the data above need not produce, keeps its point too.
    let comp = Compensator::new(&m, opts.clone()).unwrap();
    let mut w = String::new();
    comp.format().write(150.0, &mut w);
    assert_eq!(w, "150.");
    let (end, mid, _) = check(&m, program.as_bytes(), &out, &opts.interp);
    assert!(end <= opts.tol + ROUNDING, "end deviation {end}");
    assert!(mid <= opts.tol + ROUNDING, "midpoint deviation {mid}");
}

#[test]
fn axes_without_a_distinct_letter_are_refused() {
    let m = example("ac-trunnion.toml");
    let mut q = m.clone();
    q.axes[0].name = "Q".into();
    match Compensator::new(&q, CompensateOptions::default()) {
        Err(CompensateError::AxisName(AxisLetterError::NotALetter(name))) => {
            assert_eq!(name, "Q")
        }
        other => panic!("{other:?}"),
    }
    // Letters are case-insensitive in G-code: `x` is X a second time.
    let mut twice = m.clone();
    let second = twice
        .axes
        .iter()
        .position(|a| a.name != "X")
        .expect("more than one axis");
    let first = twice
        .axes
        .iter()
        .position(|a| a.name == "X")
        .expect("an X axis");
    twice.axes[second].name = "x".into();
    match Compensator::new(&twice, CompensateOptions::default()) {
        Err(e @ CompensateError::AxisName(AxisLetterError::Twice { .. })) => {
            let (a, b) = if first < second {
                ("X", "x")
            } else {
                ("x", "X")
            };
            assert_eq!(
                e.to_string(),
                format!("machine axes '{a}' and '{b}' are both G-code letter X")
            );
        }
        other => panic!("{other:?}"),
    }
}

/// The simplest program, one feed move from the (uncompensated) start
/// position: its start error cannot be removed by splitting, so the move is
/// accepted with the error fading along it and a note saying what happened
/// and what to do; with a G0 to the start first, no such note.
#[test]
fn first_feed_move_from_the_start_position_is_explained_not_refused() {
    let m = example("ac-trunnion-with-errors.toml");
    let opts = CompensateOptions::default();
    let (out, s) = run(&m, b"G1 X10 F100\n", &opts);
    assert!(String::from_utf8(out).unwrap().starts_with("G1 X10."));
    assert!(
        s.notes.iter().any(|n| n
            .contains("starts from the start position, which is not compensated")
            && n.contains("G0")),
        "{:?}",
        s.notes
    );
    let (_, s) = run(&m, b"G0 X0 Y0 Z0\nG1 X10 F100\n", &opts);
    assert!(
        !s.notes.iter().any(|n| n.contains("not compensated")),
        "{:?}",
        s.notes
    );
}

/// A program with parameters, a subroutine called twice with different
/// values and a loop.
const FLOW: &str = "G21 G90 G94\r\n\
#<z> = -50 (depth)\r\n\
o<pass> sub\r\n\
G1 X[#1] Y20 Z#<_depth> F1000 (the varying line)\r\n\
o<pass> endsub\r\n\
#<_depth> = #<z>\r\n\
G0 X10 Y20 Z#<z> A10 C0 (start)\r\n\
o1 repeat [2]\r\n\
G1 X20 Y20 Z-50 F1000 (loop 1)\r\n\
G1 X10 (loop 2)\r\n\
o1 endrepeat\r\n\
o<pass> call [40]\r\n\
o<pass> call [60]\r\n\
M30\r\n";

#[test]
fn flow_programs_round_trip_and_varying_corrections_are_refused() {
    let m = example("ac-trunnion.toml");
    let (out, s) = run(&m, FLOW.as_bytes(), &CompensateOptions::default());
    assert_eq!(String::from_utf8(out).unwrap(), FLOW);
    assert_eq!(s.blocks_changed, 0);
    // With errors: the loop's lines run twice with the same values (kept
    // and corrected once), the subroutine's line runs with X40 and X60,
    // which one rewritten line cannot hold.
    let e = example("ac-trunnion-with-errors.toml");
    let opts = CompensateOptions {
        max_correction: 2.0,
        ..CompensateOptions::default()
    };
    let mut out = Vec::new();
    let err = compensate(&e, FLOW.as_bytes(), &mut out, &opts).unwrap_err();
    match &err {
        CompensateError::Gcode(g) => {
            assert_eq!(g.location().map(|l| l.line), Some(4), "{err}");
            assert!(g.to_string().contains("runs more than once"), "{err}");
        }
        other => panic!("{other}"),
    }
    // Without the second call every line runs with one set of values: the
    // output is the program with the loop and subroutine lines corrected in
    // place, and it reaches the nominal path on the actual machine.
    let once = FLOW.replace("o<pass> call [60]\r\n", "");
    let (out, s) = run(&e, once.as_bytes(), &opts);
    assert!(s.blocks_changed >= 3, "{s:?}");
    let text = String::from_utf8(out.clone()).unwrap();
    assert_eq!(
        text.lines().count(),
        once.lines().count() + s.blocks_inserted as usize
    );
    assert!(text.contains("o1 repeat [2]") && text.contains("o<pass> sub"));
    let (end, _, _) = check(&e, once.as_bytes(), &out, &opts.interp);
    assert!(end <= opts.tol + ROUNDING, "end deviation {end}");
}

/// Canned cycles, G28 and a footer after M30: a zero-error model copies the
/// program byte for byte; a correction that would fall on a move a cycle
/// expands to is refused, naming the block's line.
#[test]
fn cycles_round_trip_and_corrections_inside_them_are_refused() {
    let prog = "G21 G90 G94\nG0 X10 Y20 Z150\nG98 G81 X10 Y20 Z120 R130 F300\nX20\nG80\nG91 G28 Z0\nG90\nM30\nPost Process Timed at; 32 Min, 50.0 sec\n";
    let m = example("ac-trunnion.toml");
    let (out, s) = run(&m, prog.as_bytes(), &CompensateOptions::default());
    assert_eq!(String::from_utf8(out).unwrap(), prog);
    assert_eq!(s.blocks_changed, 0);
    let m = example("ac-trunnion-with-errors.toml");
    let opts = CompensateOptions {
        max_correction: 2.0,
        ..CompensateOptions::default()
    };
    let c = Compensator::new(&m, opts).unwrap();
    let err = c.run(prog.as_bytes(), Vec::new()).unwrap_err();
    match err {
        CompensateError::Gcode(GcodeError::Unsupported { at, what }) => {
            assert_eq!(at.line, 3, "{what}");
            assert!(what.contains("canned cycle"), "{what}");
        }
        other => panic!("expected a refusal, got {other}"),
    }
}

#[test]
fn moves_in_a_rotated_system_round_trip_but_are_not_corrected() {
    // A rotated system (G10 L2 R) with a zero-error model: copied byte for
    // byte; with errors: refused naming the first corrected line (its X Y
    // words are not along the machine axes the corrections are made on).
    let prog = "G21 G90 G94\nG10 L2 P1 X5 R30\nG0 X10 Y20 Z-50\nG1 X100 Y-50 Z-60 F1000\nM30\n";
    let (out, _) = run(
        &example("ac-trunnion.toml"),
        prog.as_bytes(),
        &CompensateOptions::default(),
    );
    assert_eq!(out, prog.as_bytes());
    let err = compensate(
        &example("ac-trunnion-with-errors.toml"),
        prog.as_bytes(),
        Vec::new(),
        &CompensateOptions::default(),
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(
        (msg.ends_with("at line 3") || msg.ends_with("at line 4"))
            && msg.contains("rotated coordinate system"),
        "{msg}"
    );
}
