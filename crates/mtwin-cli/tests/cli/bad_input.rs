//! The bad-input suite: the mtwin binary over a table of hostile cases
//! (files a hostile or careless user could give, sizes that would exhaust
//! the machine, values that overflow). Every case says what must happen —
//! refused with exit 1, a message naming the problem and no output written,
//! or accepted with checked content — and runs under a timeout.
//!
//! Every case's error output must print numbers short (no run of digits
//! longer than `MAX_NUMBER_CHARS`: 1e308 is `1e308`, not 309 digits).
//!
//! Outcomes are counted by category and printed as
//! `cases tried N, panics 0, silent-wrong 0, partial 0, hangs 0, wrong-outcome 0`;
//! any non-zero figure fails the test. The figures are in docs/guide.md
//! ("Bad input").

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Longest a case may run (debug build, shared CI machine).
const TIMEOUT: Duration = Duration::from_secs(60);

/// What a case must do.
enum Expect {
    /// Exit 1; stderr holds every one of these (case-insensitive); none of
    /// the case's outputs exists afterwards.
    Refused(&'static [&'static str]),
    /// Exit 2 (a usage error of the argument parser) with this text.
    Usage(&'static str),
    /// Exit 0; `check` is given the case folder and stdout and returns the
    /// problem found, if any.
    Accepted(fn(&Path, &str) -> Option<String>),
}

struct Case {
    /// Category of the hostile input, for the listing.
    category: &'static str,
    /// Files written into the case folder first: (name, bytes).
    files: &'static [(&'static str, &'static [u8])],
    /// Commands run first in the folder (each must exit 0), e.g. to simulate data.
    setup: &'static [&'static [&'static str]],
    /// The command line (after `mtwin`); `@M:name` is replaced by the path
    /// of an example machine file.
    args: &'static [&'static str],
    /// Output files or folders that must not exist after a refusal.
    outputs: &'static [&'static str],
    expect: Expect,
}

/// A small machine: X (linear, ±100 mm) and C (rotary) with errors.
const MACHINE: &[u8] = br#"name = "t"
tool_chain = ["X"]
workpiece_chain = ["C"]
[tool]
tip = [0, 0, 0]
direction = [0, 0, 1]
[workpiece]
origin = [0, 0, -10]
[[axes]]
name = "X"
kind = "linear"
direction = [1, 0, 0]
travel = [-100, 100]
  [axes.errors]
  EXX = { cheb = [0.0, 0.004] }
[[axes]]
name = "C"
kind = "rotary"
direction = [0, 0, 1]
origin = [0, 0, 0]
travel = [-360, 360]
"#;

// Variants of MACHINE, spelled out (no const string replace in std).
const MACHINE_CHEB_OVERFLOW: &[u8] = br#"name = "t"
tool_chain = ["X"]
workpiece_chain = ["C"]
[tool]
tip = [0, 0, 0]
direction = [0, 0, 1]
[workpiece]
origin = [0, 0, -10]
[[axes]]
name = "X"
kind = "linear"
direction = [1, 0, 0]
travel = [-100, 100]
  [axes.errors]
  EXX = { cheb = [0, 1e308, 1e308] }
[[axes]]
name = "C"
kind = "rotary"
direction = [0, 0, 1]
origin = [0, 0, 0]
travel = [-360, 360]
"#;

const MACHINE_CHEB_SUM_OVERFLOW: &[u8] = br#"name = "t"
tool_chain = ["X"]
workpiece_chain = ["C"]
[tool]
tip = [0, 0, 0]
direction = [0, 0, 1]
[workpiece]
origin = [0, 0, -10]
[[axes]]
name = "X"
kind = "linear"
direction = [1, 0, 0]
travel = [-100, 100]
  [axes.errors]
  EXX = { poly = [0, 0, 0, 0, 0, 0, 0, 0, 1e10] }
[[axes]]
name = "C"
kind = "rotary"
direction = [0, 0, 1]
origin = [0, 0, 0]
travel = [-360, 360]
"#;

const MACHINE_CASE_DUPLICATE: &[u8] = br#"name = "t"
tool_chain = ["X"]
workpiece_chain = ["x"]
[tool]
tip = [0, 0, 0]
direction = [0, 0, 1]
[workpiece]
origin = [0, 0, -10]
[[axes]]
name = "X"
kind = "linear"
direction = [1, 0, 0]
travel = [-100, 100]
[[axes]]
name = "x"
kind = "linear"
direction = [0, 1, 0]
travel = [-100, 100]
"#;

const SERVO_HUGE_DELAY: &[u8] = b"ts = 0.001\nb = [0.0, 0.5]\na = [1.0, -0.5]\nnk = 10000000000\n";
const SERVO_UNSTABLE: &[u8] = b"ts = 0.001\nb = [0.0, 0.5]\na = [1.0, -1.5]\n";
const COMMANDS: &[u8] = b"t_s,command_mm\n0,0\n0.001,1\n0.002,2\n0.003,3\n";
const LOG_OVERFLOW: &[u8] =
    b"t_s,command_mm,feedback_mm\n0,0,0\n0.001,1,0.5\n0.002,1,1e308\n0.003,1,1\n";

fn no_problem(_: &Path, _: &str) -> Option<String> {
    None
}

fn ballbar_programs_in_machine_coordinates(dir: &Path, _: &str) -> Option<String> {
    for m in ["mode1", "mode2", "mode3", "mode4"] {
        let p = std::fs::read_to_string(dir.join(format!("p/{m}.ngc"))).ok()?;
        if !p.contains("G53 G0 ") || !p.contains("machine zero must be the model's axis zero") {
            return Some(format!("{m}.ngc is not in machine coordinates:\n{p}"));
        }
        if p.lines().any(|l| !l.starts_with('(') && l.contains("G54")) {
            return Some(format!("{m}.ngc selects G54"));
        }
    }
    None
}

fn start_position_note(dir: &Path, _: &str) -> Option<String> {
    let p = std::fs::read_to_string(dir.join("o.ngc")).ok()?;
    (!p.starts_with("G1 X10.")).then(|| format!("not a compensated move: {p}"))
}

fn mode3_hint(_: &Path, out: &str) -> Option<String> {
    (!out.contains("add mode1")).then(|| format!("no `add mode1` hint in:\n{out}"))
}

/// A thermal model with a pole at 2 (unstable) and 1200 samples of speed:
/// its prediction overflows after about 1024 samples.
const THERMAL_UNSTABLE: &[u8] = b"period_min = 10.0\n[[inputs]]\nname = \"speed_rpm\"\nscale = 1000.0\n[[heights]]\nz_mm = -50.0\na = [1.0, -2.0]\nb = [[1.0]]\nnk = [1]\n";

/// A machine whose X travel starts at -1e308 (beyond the bound on numbers in files).
const MACHINE_HUGE_TRAVEL: &[u8] = br#"name = "t"
tool_chain = ["X"]
workpiece_chain = []
[tool]
tip = [0, 0, 0]
direction = [0, 0, 1]
[workpiece]
origin = [0, 0, 0]
[[axes]]
name = "X"
kind = "linear"
direction = [1, 0, 0]
travel = [-1e308, 100]
"#;

/// A ballbar reading of -1e-300 mm: a number whose plain decimal form is 300
/// digits long.
const BALLBAR_TINY_LENGTH: &[u8] = b"angle_deg,length_mm\n0,100\n90,-1e-300\n180,100\n270,100\n";

/// The longest run of digits (with `.`) in `text`: a message printing a
/// number as 309 digits (1e308) or 300 zeros (1e-300) has one far above 20.
fn longest_number(text: &str) -> usize {
    text.split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .map(str::len)
        .max()
        .unwrap_or(0)
}

/// Longest number a message may print (`0.0010000000000000009` is 21).
const MAX_NUMBER_CHARS: usize = 24;

fn leak(s: String) -> &'static [u8] {
    Box::leak(s.into_boxed_str()).as_bytes()
}

fn cases() -> Vec<Case> {
    use Expect::*;
    let speeds = leak(
        std::iter::once("t_min,speed_rpm\n".to_string())
            .chain((0..1200).map(|k| format!("{},1000\n", k * 10)))
            .collect(),
    );
    let thermal_files: &'static [(&'static str, &'static [u8])] = Box::leak(Box::new([
        ("th.toml", THERMAL_UNSTABLE),
        ("sp.csv", speeds),
    ]));
    vec![
        Case {
            category: "silent-wrong",
            files: thermal_files,
            setup: &[],
            args: &[
                "thermal", "predict", "--model", "th.toml", "--speed", "sp.csv", "--z", "-50",
                "--out", "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["th.toml", "overflows", "nothing written"]),
        },
        // --- G-code words LinuxCNC refuses (silent-wrong before) ---
        Case {
            category: "silent-wrong",
            files: &[("a.ngc", b"G1 X1e3 F100\n")],
            setup: &[],
            args: &[
                "gcode",
                "interpolate",
                "--machine",
                "@M:ac-trunnion.toml",
                "a.ngc",
                "--ts",
                "0.001",
                "--out",
                "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["a.ngc:1:6", "E word", "no exponent"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("a.ngc", b"G1 X10 E5 F100\n")],
            setup: &[],
            args: &["gcode", "stats", "a.ngc"],
            outputs: &[],
            expect: Refused(&["a.ngc:1:8", "E word with no"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("a.ngc", b"G1 X10 Q5 F100\n")],
            setup: &[],
            args: &["gcode", "stats", "a.ngc"],
            outputs: &[],
            expect: Refused(&["a.ngc:1:8", "Q word with no"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("a.ngc", b"N1e5\nG1 X1 F100\n")],
            setup: &[],
            args: &["gcode", "stats", "a.ngc"],
            outputs: &[],
            expect: Refused(&["a.ngc:1:3", "E word"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("a.ngc", b"G0 X1 N10\n")],
            setup: &[],
            args: &["gcode", "stats", "a.ngc"],
            outputs: &[],
            expect: Refused(&["a.ngc:1", "line number"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("a.ngc", b"G1 X10 P2 F100\n")],
            setup: &[],
            args: &["gcode", "stats", "a.ngc"],
            outputs: &[],
            expect: Refused(&["P word with no"]),
        },
        Case {
            category: "panic",
            files: &[("a.ngc", b"\xff\xfe(\x00G1 X[1/0\n((((\n")],
            setup: &[],
            args: &["gcode", "stats", "a.ngc"],
            outputs: &[],
            expect: Refused(&["a.ngc:1"]),
        },
        // --- Model files: overflow over the travel, magnitudes, duplicate names ---
        Case {
            category: "silent-wrong",
            files: &[("m.toml", MACHINE_CHEB_OVERFLOW)],
            setup: &[],
            args: &["model", "check", "m.toml"],
            outputs: &[],
            expect: Refused(&["m.toml:15", "within ±1e15"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("m.toml", MACHINE_CHEB_SUM_OVERFLOW)],
            setup: &[],
            args: &["model", "check", "m.toml"],
            outputs: &[],
            expect: Refused(&["m.toml:15", "out of range over the axis travel"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("m.toml", MACHINE_CASE_DUPLICATE)],
            setup: &[],
            args: &["model", "check", "m.toml"],
            outputs: &[],
            expect: Refused(&["m.toml", "axis `x` is defined twice"]),
        },
        Case {
            category: "accepted",
            files: &[("m.toml", MACHINE)],
            setup: &[],
            args: &["model", "check", "m.toml"],
            outputs: &[],
            expect: Accepted(no_problem),
        },
        Case {
            category: "silent-wrong",
            files: &[("p.csv", b"X,Y,Z,A,C\n")],
            setup: &[],
            args: &[
                "predict",
                "--machine",
                "@M:ac-trunnion-with-errors.toml",
                "--data",
                "p.csv",
                "--out",
                "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["p.csv:1", "no poses"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("p.csv", b"X,Y,Z,A,C\n0,0,1e308,0,0\n")],
            setup: &[],
            args: &[
                "predict",
                "--machine",
                "@M:ac-trunnion-with-errors.toml",
                "--data",
                "p.csv",
                "--out",
                "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["p.csv:2:3", "1e308", "largest magnitude"]),
        },
        // --- Numbers in messages: 1e308 in a CSV (written out in full), a
        // TOML machine file and an option; 1e-300 in a CSV. Every message
        // prints them short (checked for every case below).
        Case {
            category: "words",
            files: Box::leak(Box::new([(
                "p.csv",
                leak(format!("X,Y,Z,A,C\n0,0,1{},0,0\n", "0".repeat(308))),
            )])),
            setup: &[],
            args: &[
                "predict",
                "--machine",
                "@M:ac-trunnion-with-errors.toml",
                "--data",
                "p.csv",
                "--out",
                "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["p.csv:2:3", "holds 1e308", "largest magnitude"]),
        },
        Case {
            category: "words",
            files: &[("m.toml", MACHINE_HUGE_TRAVEL)],
            setup: &[],
            args: &["model", "check", "m.toml"],
            outputs: &[],
            expect: Refused(&["m.toml:13", "it is -1e308"]),
        },
        Case {
            category: "words",
            files: &[],
            setup: &[],
            args: &["ballbar", "simulate", "--noise", "-1e308", "--out", "d"],
            outputs: &["d"],
            expect: Refused(&["--noise -1e308"]),
        },
        Case {
            category: "words",
            files: &[("m1.csv", BALLBAR_TINY_LENGTH)],
            setup: &[],
            args: &[
                "ballbar", "identify", "--mode1", "m1.csv", "--length", "100",
            ],
            outputs: &[],
            expect: Refused(&["m1.csv:3", "length_mm is -1e-300"]),
        },
        Case {
            category: "accepted",
            files: &[("c.ngc", b"G1 X10 F100\n")],
            setup: &[],
            args: &[
                "compensate",
                "--machine",
                "@M:ac-trunnion-with-errors.toml",
                "--program",
                "c.ngc",
                "--out",
                "o.ngc",
            ],
            outputs: &[],
            expect: Accepted(start_position_note),
        },
        // --- Servo: sizes, overflow, instability ---
        Case {
            category: "hang/resource",
            files: &[("s.toml", SERVO_HUGE_DELAY), ("c.csv", COMMANDS)],
            setup: &[],
            args: &[
                "servo",
                "simulate",
                "--servo",
                "s.toml",
                "--commands",
                "c.csv",
                "--out",
                "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["s.toml:4", "nk", "limit"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("s.toml", SERVO_UNSTABLE), ("c.csv", COMMANDS)],
            setup: &[],
            args: &[
                "servo",
                "simulate",
                "--servo",
                "s.toml",
                "--commands",
                "c.csv",
                "--out",
                "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["not stable", "--allow-unstable"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("log.csv", LOG_OVERFLOW)],
            setup: &[],
            args: &["servo", "fit", "--data", "log.csv", "--out", "s.toml"],
            outputs: &["s.toml"],
            expect: Refused(&["log.csv:4", "feedback_mm", "largest magnitude"]),
        },
        Case {
            category: "silent-wrong",
            files: &[("log.csv", LOG_OVERFLOW)],
            setup: &[],
            args: &[
                "servo",
                "fit",
                "--data",
                "log.csv",
                "--max-order",
                "0",
                "--out",
                "s.toml",
            ],
            outputs: &["s.toml"],
            expect: Refused(&["--max-order", "at least 1"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "servo",
                "fit",
                "--data",
                "log.csv",
                "--max-order",
                "10000",
                "--out",
                "s.toml",
            ],
            outputs: &["s.toml"],
            expect: Refused(&["--max-order is 10000", "limit"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "servo",
                "fit",
                "--data",
                "log.csv",
                "--max-delay",
                "100000000",
                "--out",
                "s.toml",
            ],
            outputs: &["s.toml"],
            expect: Refused(&["--max-delay is 100000000", "limit"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "servo",
                "excitation",
                "--axis",
                "X",
                "--travel",
                "0,100",
                "--feed",
                "100",
                "--levels",
                "100000000",
                "--out",
                "e.nc",
            ],
            outputs: &["e.nc"],
            expect: Refused(&["--levels is 100000000", "limit"]),
        },
        Case {
            category: "words",
            files: &[],
            setup: &[],
            args: &[
                "servo",
                "excitation",
                "--axis",
                "X",
                "--travel",
                "0,100",
                "--feed",
                "-1e308",
                "--out",
                "e.nc",
            ],
            outputs: &["e.nc"],
            expect: Refused(&["not -1e308"]),
        },
        // --- Sizes of generated programs and plans ---
        Case {
            category: "hang/resource",
            files: &[("a.ngc", b"G1 X10 F100\n")],
            setup: &[],
            args: &[
                "gcode",
                "interpolate",
                "--machine",
                "@M:ac-trunnion.toml",
                "a.ngc",
                "--ts",
                "1e-12",
                "--out",
                "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["a.ngc", "number of samples", "--ts", "limit"]),
        },
        // Two moves of 6 M samples each (6000 s at 1 ms): each within the
        // per-move bound, together above it — refused before any sample.
        Case {
            category: "hang/resource",
            files: &[("a.ngc", b"G1 X100 F1\nG1 X0 F1\n")],
            setup: &[],
            args: &[
                "gcode",
                "interpolate",
                "--machine",
                "@M:ac-trunnion.toml",
                "a.ngc",
                "--ts",
                "0.001",
                "--out",
                "o.csv",
            ],
            outputs: &["o.csv"],
            expect: Refused(&["a.ngc", "estimated program duration", "limit"]),
        },
        Case {
            category: "panic",
            files: &[],
            setup: &[],
            args: &[
                "ballbar",
                "program",
                "--a-range",
                "-90,90,1e-9",
                "--out",
                "p",
            ],
            outputs: &["p"],
            expect: Refused(&["--a-range", "limit"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "plan",
                "tracker",
                "--machine",
                "@M:afp-gantry.toml",
                "--fit",
                "location",
                "--candidates",
                "100000000",
                "--select",
                "10",
                "--out-csv",
                "p.csv",
                "--out-gcode",
                "p.nc",
            ],
            outputs: &["p.csv", "p.nc"],
            expect: Refused(&["--candidates is 100000000", "limit"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "plan",
                "tracker",
                "--machine",
                "@M:afp-gantry.toml",
                "--fit",
                "location",
                "--candidates",
                "100000",
                "--select",
                "100000",
                "--out-csv",
                "p.csv",
                "--out-gcode",
                "p.nc",
            ],
            outputs: &["p.csv", "p.nc"],
            expect: Refused(&["--candidates × --select", "limit"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "thermal",
                "fit",
                "--data",
                "t.csv",
                "--max-order",
                "100000",
                "--out",
                "t.toml",
            ],
            outputs: &["t.toml"],
            expect: Refused(&["--max-order", "limit"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "thermal",
                "fit",
                "--data",
                "t.csv",
                "--extra-inputs",
                "a,b,c,d,e,f,g,h,i,j,k,l,m,n,o,p",
                "--out",
                "t.toml",
            ],
            outputs: &["t.toml"],
            expect: Refused(&["--extra-inputs", "limit"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "thermal",
                "fit",
                "--data",
                "t.csv",
                "--max-order",
                "0",
                "--out",
                "t.toml",
            ],
            outputs: &["t.toml"],
            expect: Refused(&["--max-order", "at least 1"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "thermal",
                "program",
                "--z",
                "-100",
                "--speeds",
                "1000",
                "--step-min",
                "1e9",
                "--out",
                "p.nc",
            ],
            outputs: &["p.nc"],
            expect: Refused(&["probing passes", "limit"]),
        },
        Case {
            category: "hang/resource",
            files: &[],
            setup: &[],
            args: &[
                "testpiece",
                "s-shape",
                "--machine",
                "@M:ac-trunnion.toml",
                "--segments",
                "100000000",
                "--out",
                "s.nc",
            ],
            outputs: &["s.nc"],
            expect: Refused(&["segments is 100000000", "limit"]),
        },
        // --- Ballbar findings ---
        Case {
            category: "silent-wrong",
            files: &[],
            setup: &[],
            args: &["ballbar", "sensitivity", "--ex", "0.1"],
            outputs: &[],
            expect: Usage("--ex"),
        },
        Case {
            category: "accepted",
            files: &[],
            setup: &[],
            args: &["ballbar", "program", "--out", "p"],
            outputs: &[],
            expect: Accepted(ballbar_programs_in_machine_coordinates),
        },
        Case {
            category: "accepted",
            files: &[],
            setup: &[&["ballbar", "simulate", "--out", "d"]],
            args: &[
                "ballbar",
                "identify",
                "--mode3",
                "d/mode3.csv",
                "--format",
                "json",
            ],
            outputs: &[],
            expect: Accepted(mode3_hint),
        },
        Case {
            category: "accepted",
            files: &[("a.ngc", b"N10 G4 P1\nN20 G1 X10 F100\nM66 P0 L0 Q1\n")],
            setup: &[],
            args: &["gcode", "stats", "a.ngc"],
            outputs: &[],
            expect: Accepted(no_problem),
        },
    ]
}

/// Runs `mtwin args` in `dir` with a timeout: (exit code or None on timeout, stdout, stderr).
fn run(dir: &Path, args: &[String]) -> (Option<i32>, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_mtwin"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mtwin starts");
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let ereader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code().or(Some(-1));
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    (code, reader.join().unwrap(), ereader.join().unwrap())
}

#[test]
fn hostile_inputs_are_refused_or_handled() {
    let cases = cases();
    let (mut panics, mut silent, mut partial, mut hangs, mut wrong) = (0, 0, 0, 0, 0);
    let mut report = Vec::new();
    for (k, c) in cases.iter().enumerate() {
        let dir = tempfile::tempdir().unwrap();
        for (name, bytes) in c.files {
            std::fs::write(dir.path().join(name), bytes).unwrap();
        }
        let expand = |a: &&str| match a.strip_prefix("@M:") {
            Some(name) => crate::common::example(name),
            None => a.to_string(),
        };
        for s in c.setup {
            let args: Vec<String> = s.iter().map(expand).collect();
            let (code, _, e) = run(dir.path(), &args);
            assert_eq!(code, Some(0), "case {k} setup {args:?}: {e}");
        }
        let args: Vec<String> = c.args.iter().map(expand).collect();
        let (code, out, err) = run(dir.path(), &args);
        let line = format!("case {k} [{}] mtwin {}", c.category, args.join(" "));
        let problem: Option<(&str, String)> = match code {
            None => Some(("hang", format!("no end within {TIMEOUT:?}"))),
            Some(101) => Some(("panic", err.clone())),
            _ if err.contains("panicked") => Some(("panic", err.clone())),
            _ if longest_number(&err) > MAX_NUMBER_CHARS => Some((
                "wrong-outcome",
                format!("a number longer than {MAX_NUMBER_CHARS} characters in:\n{err}"),
            )),
            Some(code) => match &c.expect {
                Expect::Refused(needles) => {
                    let low = err.to_lowercase();
                    let left: Vec<&str> = c
                        .outputs
                        .iter()
                        .copied()
                        .filter(|o| dir.path().join(o).exists())
                        .collect();
                    if code == 0 {
                        Some(("silent-wrong", format!("accepted with exit 0:\n{out}{err}")))
                    } else if !left.is_empty() {
                        Some(("partial", format!("left behind {left:?}")))
                    } else if code != 1 || !needles.iter().all(|n| low.contains(&n.to_lowercase()))
                    {
                        Some((
                            "wrong-outcome",
                            format!("exit {code}, wanted 1 and {needles:?} in:\n{err}"),
                        ))
                    } else {
                        None
                    }
                }
                Expect::Usage(needle) => (code != 2 || !err.contains(needle)).then(|| {
                    (
                        "wrong-outcome",
                        format!("exit {code}, wanted 2 and {needle}: {err}"),
                    )
                }),
                Expect::Accepted(check) => {
                    if code != 0 {
                        Some(("wrong-outcome", format!("refused with exit {code}: {err}")))
                    } else {
                        check(dir.path(), &out).map(|p| ("silent-wrong", p))
                    }
                }
            },
        };
        match &problem {
            None => report.push(format!("ok      {line}")),
            Some((kind, why)) => {
                match *kind {
                    "hang" => hangs += 1,
                    "panic" => panics += 1,
                    "partial" => partial += 1,
                    "silent-wrong" => silent += 1,
                    _ => wrong += 1,
                }
                report.push(format!("FAILED  {line}\n        {kind}: {why}"));
            }
        }
    }
    let figures = format!(
        "cases tried {}, panics {panics}, silent-wrong {silent}, partial {partial}, hangs {hangs}, wrong-outcome {wrong}",
        cases.len()
    );
    println!("{}\n{figures}", report.join("\n"));
    assert_eq!(
        panics + silent + partial + hangs + wrong,
        0,
        "{}\n{figures}",
        report.join("\n")
    );
}
