//! LinuxCNC as a differential reference: every program is run both by
//! mtwin's interpreter and by `rs274`, LinuxCNC's standalone interpreter
//! (Debian package `linuxcnc-uspace`), and the two must agree on whether the
//! program is accepted, on every move end (to the 4 decimals `rs274` prints,
//! in its program units), on arc centres and turns, on every feed and on
//! every dwell.
//!
//! Programs: the corpus (`shared/corpus/gcode/linuxcnc`), every program of
//! the conformance suite (`shared/corpus/gcode-conformance/linuxcnc-interp`),
//! LinuxCNC's example programs ([`NCFILES`]) and [`GENERATED`] programs from a seeded generator of the language mtwin
//! supports ([`FEATURES`]: one generator per language feature; add a feature
//! by adding an entry).
//!
//! Each program is classified: both agree (same moves and feeds, or both
//! refuse it); mtwin refuses it as unsupported (a known gap, tallied by
//! feature); or a disagreement (the first difference is printed). The test
//! prints the tally and fails on any disagreement.
//!
//! `rs274` is looked up on `PATH` (or `MTWIN_RS274`). Without it the test
//! prints a note and passes, unless `MTWIN_REQUIRE_RS274=1` (as `.ci/run`
//! sets), where its absence fails the test.
//!
//! How `rs274` is set up (files written to a temporary folder): an INI that
//! maps the corpus's kinematics-switch M-codes M428, M429 and M430 to empty
//! subroutines (as the corpus machine's remaps, without their effect on the
//! interpreter); a tool table (lengths read as inches); a parameter file
//! with the work offsets G54..G59.3 (lengths read as inches, whatever the
//! program units); `-b` so that `/` blocks are skipped, as mtwin's default.
//! Each worker runs rs274 with its own `HOME` (rs274 keeps a memory-mapped
//! copy of the tool table there).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use mtwin::gcode::{
    self, Axes, Axis, AxisMask, EventKind, Feed, GcodeError, InterpOptions, UnknownMCode,
};

/// Longest run and largest output of one rs274 process.
const RS274_SECONDS: Duration = Duration::from_secs(60);
const RS274_MAX_OUTPUT: u64 = 8 << 20;

/// LinuxCNC's own example programs, as Debian's `linuxcnc-uspace` installs
/// them (GPL: read in place, never copied). Required with
/// `MTWIN_REQUIRE_RS274=1`: the package that brings `rs274` brings them.
const NCFILES: &str = "/usr/share/linuxcnc/ncfiles";

/// Number of generated programs.
const GENERATED: u64 = 1200;
/// Seed of the first generated program (program k uses SEED + k).
const SEED: u64 = 0x5eed_2024;
/// Number of generated programs in rotated coordinate systems
/// ([`generate_rotated`]).
const ROTATED: u64 = 150;
/// Seed of the first of them.
const ROTATED_SEED: u64 = 0x0a0a_2026;

// ---------------------------------------------------------------------------
// The reference set-up shared by both interpreters.

/// Tool table: number and length, inch (as rs274 reads a `.tbl`).
const TOOLS: &[(u32, f64)] = &[(1, 0.0), (2, 0.1), (4, 0.7)];

/// Tool diameters (cutter radius compensation), same order, inch.
const TOOL_DIAMETERS: [f64; 3] = [0.25, 0.5, 0.125];

/// Work offsets G54..G59.3, X Y Z in inch (as rs274 reads its var file).
const WORK_OFFSETS: [[f64; 3]; 9] = [
    [0.0, 0.0, 0.0],
    [1.0, 2.0, -0.5],
    [-3.25, 0.5, 1.125],
    [0.4, -1.6, 0.0],
    [10.0, 0.0, -2.0],
    [-0.0625, 0.3125, 0.75],
    [2.0, 2.0, 2.0],
    [-1.0, -1.0, 0.25],
    [0.0, 5.5, -0.125],
];

fn ini_text(subs: &Path) -> String {
    case_ini_text(subs, None, "")
}

/// The INI of a program: [`ini_text`]'s, with the program's own `subs`
/// folder searched after the shared one and the extra sections a
/// conformance case reads (`#<_ini[…]>` values). mtwin reads the same text.
fn case_ini_text(subs: &Path, case_subs: Option<&Path>, sections: &str) -> String {
    let path = match case_subs {
        Some(c) => format!("{}:{}", subs.display(), c.display()),
        None => subs.display().to_string(),
    };
    format!(
        "[RS274NGC]\nSUBROUTINE_PATH = {}\n\
         REMAP = M428 modalgroup=10 ngc=m428\n\
         REMAP = M429 modalgroup=10 ngc=m429\n\
         REMAP = M430 modalgroup=10 ngc=m430\n{sections}",
        path
    )
}

fn tool_table_text() -> String {
    let mut s: String = TOOLS
        .iter()
        .zip(TOOL_DIAMETERS)
        .map(|((t, z), d)| format!("T{t} P{t} Z{z} D{d}\n"))
        .collect();
    s.push_str(&lathe_tool_lines());
    s
}

fn var_text() -> String {
    let mut s = String::from("5220 1.0\n");
    for (k, o) in WORK_OFFSETS.iter().enumerate() {
        for (i, v) in o.iter().enumerate() {
            writeln!(s, "{} {v}", 5221 + 20 * k + i).unwrap();
        }
    }
    s
}

fn mtwin_options() -> InterpOptions {
    let mut work_offsets = [Axes::ZERO; 9];
    for (w, o) in work_offsets.iter_mut().zip(WORK_OFFSETS.iter()) {
        for (x, v) in w.0.iter_mut().zip(o.iter()).take(3) {
            *x = v * 25.4;
        }
    }
    let mut opts = InterpOptions::default();
    opts.unknown_m = UnknownMCode::Reject;
    opts.tools = TOOLS.iter().map(|&(t, z)| (t, z * 25.4)).collect();
    for (&(t, _), d) in TOOLS.iter().zip(TOOL_DIAMETERS) {
        let mut tool = opts.tools.get(t).unwrap().clone();
        tool.diameter = d * 25.4;
        opts.tools.insert(tool);
    }
    opts.work_offsets = work_offsets;
    // rs274's machine is X Y Z A B C whatever the INI says (its canon's
    // axis mask): it refuses U, V and W words.
    opts.machine_axes = AxisMask::EMPTY;
    for a in [Axis::X, Axis::Y, Axis::Z, Axis::A, Axis::B, Axis::C] {
        opts.machine_axes.insert(a);
    }
    add_lathe_tools(&mut opts);
    opts
}

/// The temporary folder with the INI, tool table, var file and subroutines.
struct Setup {
    _dir: tempfile::TempDir,
    exe: PathBuf,
    ini: PathBuf,
    tbl: PathBuf,
    root: PathBuf,
    /// The shared subroutine folder (the M428–M430 remaps).
    subs: PathBuf,
}

fn rs274_exe() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("MTWIN_RS274") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("rs274"))
        .find(|p| p.is_file())
}

fn setup() -> Option<Setup> {
    let required = std::env::var("MTWIN_REQUIRE_RS274").is_ok_and(|v| v == "1");
    let Some(exe) = rs274_exe() else {
        assert!(
            !required,
            "MTWIN_REQUIRE_RS274=1 but LinuxCNC's rs274 is not on PATH \
             (Debian: apt-get install linuxcnc-uspace)"
        );
        eprintln!(
            "skipped: LinuxCNC's rs274 is not on PATH (apt-get install linuxcnc-uspace; \
             set MTWIN_REQUIRE_RS274=1 to make this a failure)"
        );
        return None;
    };
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_path_buf();
    let subs = root.join("subs");
    std::fs::create_dir(&subs).unwrap();
    for m in [428, 429, 430] {
        std::fs::write(
            subs.join(format!("m{m}.ngc")),
            format!("o<m{m}> sub\no<m{m}> endsub\nM2\n"),
        )
        .unwrap();
    }
    let ini = root.join("mtwin.ini");
    std::fs::write(&ini, ini_text(&subs)).unwrap();
    let tbl = root.join("tools.tbl");
    std::fs::write(&tbl, tool_table_text()).unwrap();
    Some(Setup {
        _dir: dir,
        exe,
        ini,
        tbl,
        root,
        subs,
    })
}

// ---------------------------------------------------------------------------
// What both interpreters did, in one form.

/// A move: straight traverse, straight feed or arc, in mm and degree.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Move {
        kind: &'static str,
        /// X Y Z A B C end, mm and degree.
        end: [f64; 6],
        /// Arc: centre in the plane (first, second axis) and turns.
        arc: Option<([f64; 2], i32)>,
        /// The feed LinuxCNC's canon would receive, in program units per
        /// minute at the move (inverse time: length times F), or per
        /// revolution; `None` for a traverse.
        feed: Option<f64>,
        /// mm per program unit at the move (1 or 25.4), for the tolerances.
        scale: f64,
    },
    Dwell(f64),
}

/// What a program gave: the steps before the end or the refusal.
#[derive(Debug)]
struct Outcome {
    steps: Vec<Step>,
    /// `None`: accepted; `Some(message)`: refused.
    refused: Option<String>,
    /// mtwin only: refused as unsupported (the feature named).
    unsupported: Option<String>,
}

/// The offsets rs274 prints (mm and degree): machine X Y Z =
/// R·(program + G92) + work offset + tool offset, R the XY rotation.
#[derive(Default)]
struct Frame {
    g5x: [f64; 6],
    g92: [f64; 6],
    tool: [f64; 6],
    /// Degrees about Z.
    rotation: f64,
}

impl Frame {
    fn to_machine(&self, p: &[f64; 6]) -> [f64; 6] {
        let q: [f64; 6] = std::array::from_fn(|i| p[i] + self.g92[i]);
        let (sn, cs) = self.rotation.to_radians().sin_cos();
        let mut m = q;
        m[0] = q[0] * cs - q[1] * sn;
        m[1] = q[0] * sn + q[1] * cs;
        std::array::from_fn(|i| m[i] + self.g5x[i] + self.tool[i])
    }

    fn program_point(&self, m: &[f64; 6]) -> [f64; 6] {
        let q: [f64; 6] = std::array::from_fn(|i| m[i] - self.g5x[i] - self.tool[i]);
        let (sn, cs) = self.rotation.to_radians().sin_cos();
        let mut p = q;
        p[0] = q[0] * cs + q[1] * sn;
        p[1] = -q[0] * sn + q[1] * cs;
        std::array::from_fn(|i| p[i] - self.g92[i])
    }
}

/// Parses rs274's canonical calls (`   12 N..... NAME(args)`). Feeds are
/// made canonical as LinuxCNC's motion controller takes them: the rate of
/// SET_FEED_RATE times the length unit in force when it was set (mm/min),
/// except for a move of rotary axes only, which takes the rate as deg/min.
/// Straight moves of no length are left out (LinuxCNC makes one at G40).
fn parse_canon(text: &str) -> Vec<Step> {
    let mut steps = Vec::new();
    let mut scale = 1.0;
    // SET_FEED_RATE value and the length unit when it was set.
    let (mut rate, mut rate_scale) = (0.0, 1.0);
    let mut at = [0.0; 6];
    // Work axes of the arc plane: first, second, normal (X 0, Y 1, Z 2).
    let mut plane = [0, 1, 2];
    // Spindle-synchronised (G33, G33.1): the advance per revolution, mm.
    let mut sync: Option<f64> = None;
    // The program point where the machine is (`at` is the last printed
    // end): a change of work, G92 or tool offset or of rotation moves it.
    let mut frame = Frame::default();
    let mut pos = [0.0; 6];
    // After a STRAIGHT_PROBE: per axis X Y Z, the point rs274's canon backed
    // off to and the probe's end (mm), while later moves print the former.
    let mut backed_off: [Option<(f64, f64)>; 3] = [None; 3];
    // X Y Z as rs274 last printed them (mm), backed-off points included.
    let mut printed = [0.0; 3];
    for line in text.lines() {
        let Some((head, args)) = line.split_once('(') else {
            continue;
        };
        let Some(name) = head.split_whitespace().last() else {
            continue;
        };
        let args = args.trim_end().strip_suffix(')').unwrap_or(args);
        let nums = || -> Vec<f64> {
            args.split([',', ' '])
                .filter(|a| !a.is_empty())
                .map(|a| a.parse().unwrap_or(f64::NAN))
                .collect()
        };
        match name {
            "USE_LENGTH_UNITS" => scale = if args.contains("INCH") { 25.4 } else { 1.0 },
            "SET_FEED_RATE" => (rate, rate_scale) = (nums()[0], scale),
            "SELECT_PLANE" => {
                plane = match args {
                    a if a.contains("XZ") => [2, 0, 1],
                    a if a.contains("YZ") => [1, 2, 0],
                    _ => [0, 1, 2],
                }
            }
            "DWELL" => steps.push(Step::Dwell(nums()[0])),
            "SET_G5X_OFFSET" | "SET_G92_OFFSET" | "USE_TOOL_LENGTH_OFFSET" | "SET_XY_ROTATION" => {
                let machine = frame.to_machine(&pos);
                let v = nums();
                let mut o = [0.0; 6];
                let first = usize::from(name == "SET_G5X_OFFSET");
                for (i, oi) in o.iter_mut().enumerate() {
                    let x = v.get(first + i).copied().unwrap_or(0.0);
                    *oi = if i < 3 { x * scale } else { x };
                }
                match name {
                    "SET_G5X_OFFSET" => frame.g5x = o,
                    "SET_G92_OFFSET" => frame.g92 = o,
                    "USE_TOOL_LENGTH_OFFSET" => frame.tool = o,
                    _ => frame.rotation = v[0],
                }
                pos = frame.program_point(&machine);
            }
            "START_SPEED_FEED_SYNC" => sync = Some(nums()[0] * scale),
            "STOP_SPEED_FEED_SYNCH" => sync = None,
            "RIGID_TAP" => {
                backed_off = [None; 3];
                // To X Y Z and back to the start (where the program point
                // stays), at K per revolution: one step, its end the tap's.
                let v = nums();
                let mut end = at;
                for i in 0..3 {
                    end[i] = v[i] * scale;
                }
                steps.push(Step::Move {
                    kind: "tap",
                    end,
                    arc: None,
                    feed: sync,
                    scale,
                });
            }
            // A probe: a feed to its end, where mtwin's probe (which does
            // not trip, #5070 = 0, as rs274 reports) leaves the tool.
            // rs274's canon (saicanon.cc) then backs the point off 0.01 in
            // (0.254 mm in G21) towards the probe's start, a model of a
            // tripped probe of its own: a later move that leaves an axis
            // unprogrammed prints the backed-off coordinate, read here as
            // the probe's end.
            "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" | "STRAIGHT_PROBE" => {
                let v = nums();
                let mut end = [0.0; 6];
                for i in 0..6 {
                    end[i] = if i < 3 { v[i] * scale } else { v[i] };
                }
                let raw = [end[0], end[1], end[2]];
                for (i, b) in backed_off.iter_mut().enumerate() {
                    match *b {
                        Some((backed, probe_end)) if (end[i] - backed).abs() < 1.3e-3 => {
                            end[i] = probe_end;
                        }
                        _ => *b = None,
                    }
                }
                if name == "STRAIGHT_PROBE" {
                    let d: Vec<f64> = (0..3).map(|i| printed[i] - raw[i]).collect();
                    let dist = d.iter().map(|x| x * x).sum::<f64>().sqrt();
                    let back = if scale == 1.0 { 0.254 } else { 0.01 * scale };
                    // An axis this probe does not move keeps its earlier
                    // backed-off coordinate in rs274.
                    for i in 0..3 {
                        if dist > 0.0 && d[i] != 0.0 {
                            backed_off[i] = Some((raw[i] + back * d[i] / dist, end[i]));
                        }
                    }
                    for i in 0..3 {
                        printed[i] = backed_off[i].map_or(raw[i], |b| b.0);
                    }
                } else {
                    printed = raw;
                }
                // Still: equal to the 4 printed decimals (of inch or mm).
                let same = |i: usize| (end[i] - at[i]).abs() < 1.3e-3;
                let (xyz_still, abc_still) = ((0..3).all(same), (3..6).all(same));
                // The feed of a rotary-only move (deg/min) is told from the
                // true start.
                let xyz_moved = (0..3).any(|i| (end[i] - pos[i]).abs() >= 1.3e-3);
                at = end;
                pos = end;
                if xyz_still && abc_still {
                    continue;
                }
                let traverse = name == "STRAIGHT_TRAVERSE";
                let feed = match sync {
                    Some(k) => k,
                    None if !xyz_moved => rate,
                    None => rate * rate_scale,
                };
                steps.push(Step::Move {
                    kind: if traverse { "traverse" } else { "feed" },
                    end,
                    arc: None,
                    feed: (!traverse).then_some(feed),
                    scale,
                });
            }
            "ARC_FEED" => {
                backed_off = [None; 3];
                // first_end, second_end, first_axis, second_axis, rotation,
                // axis_end_point, a, b, c: the plane's axes in the order
                // of its normal (XY: X Y Z; XZ: Z X Y; YZ: Y Z X).
                let v = nums();
                let end = [v[0] * scale, v[1] * scale, v[5] * scale, v[6], v[7], v[8]];
                steps.push(Step::Move {
                    kind: "arc",
                    end,
                    arc: Some(([v[2] * scale, v[3] * scale], v[4] as i32)),
                    feed: Some(rate * rate_scale),
                    scale,
                });
                for (k, &i) in plane.iter().enumerate() {
                    at[i] = end[k];
                }
                at[3..].copy_from_slice(&end[3..]);
                printed.copy_from_slice(&at[..3]);
                pos = at;
            }
            _ => {}
        }
    }
    steps
}

/// Runs rs274 on `program`; `work` is a private scratch folder.
/// `program` written to `work`/`file`, run by `rs274` (the shared INI) and
/// by mtwin: (mtwin's outcome, rs274's).
fn run_both(
    setup: &Setup,
    work: &Path,
    file: impl AsRef<Path>,
    program: &str,
) -> (Outcome, Outcome) {
    let path = work.join(file);
    std::fs::write(&path, program).unwrap();
    (
        run_mtwin(program.as_bytes(), None),
        run_rs274(setup, &path, work, None),
    )
}

fn run_rs274(s: &Setup, program: &Path, work: &Path, ini: Option<&str>) -> Outcome {
    let ini = match ini {
        Some(text) => {
            let p = work.join("case.ini");
            std::fs::write(&p, text).unwrap();
            p
        }
        None => s.ini.clone(),
    };
    let var = work.join("params.var");
    std::fs::write(&var, var_text()).unwrap();
    let out_path = work.join("canon.txt");
    let err_path = work.join("stderr.txt");
    let mut child = Command::new(&s.exe)
        .arg("-i")
        .arg(&ini)
        .arg("-t")
        .arg(&s.tbl)
        .arg("-v")
        .arg(&var)
        .arg("-b")
        .arg("-g")
        .arg(program)
        .current_dir(work)
        // rs274 maps its tool table to `$HOME/.tool.mmap`: one per worker,
        // or parallel runs break each other (SIGBUS).
        .env("HOME", work)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out_path).unwrap())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .expect("run rs274");
    // Programs that loop for ever (the conformance suite has some) are
    // stopped after RS274_SECONDS or RS274_MAX_OUTPUT bytes of output.
    let t0 = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        let size = std::fs::metadata(&out_path).map_or(0, |m| m.len());
        if t0.elapsed() > RS274_SECONDS || size > RS274_MAX_OUTPUT {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let stdout = match status {
        Some(_) => std::fs::read_to_string(&out_path).unwrap_or_default(),
        None => String::new(),
    };
    let stderr = std::fs::read_to_string(&err_path).unwrap_or_default();
    let refused = match status {
        None => Some(format!(
            "rs274 stopped after {:.0} s or {} MB of output (a program that does not end)",
            RS274_SECONDS.as_secs_f64(),
            RS274_MAX_OUTPUT >> 20
        )),
        Some(st) if !st.success() => Some(format!(
            "{} ({st})",
            stderr
                .lines()
                .filter(|l| l.trim() != "executing")
                .collect::<Vec<_>>()
                .join(" | ")
        )),
        Some(_) => None,
    };
    Outcome {
        steps: parse_canon(&stdout),
        refused,
        unsupported: None,
    }
}

/// The feed LinuxCNC's motion controller takes for a move (see
/// [`parse_canon`]), from mtwin's feed: mm/min, or deg/min for a move of
/// rotary axes only. Inverse time: LinuxCNC's rate is the move length times
/// F (at least 0.1), the length in program units along XYZ, or along ABC
/// for a rotary-only move; helical length for an arc.
fn canonical_feed(feed: Feed, xyz_mm: f64, abc_deg: f64, scale: f64) -> Option<f64> {
    let rotary_only = xyz_mm == 0.0 && abc_deg > 0.0;
    match feed {
        Feed::Rapid => None,
        Feed::PerMinute(f) => Some(f),
        Feed::InverseTime(f) => {
            let raw = if rotary_only {
                (f * abc_deg).max(0.1)
            } else {
                (f * xyz_mm / scale).max(0.1)
            };
            Some(if rotary_only { raw } else { raw * scale })
        }
        Feed::PerRevolution { mm_per_rev, .. } => Some(mm_per_rev),
    }
}

/// Work X Y of a move event back in the program's (unrotated) frame: events
/// give them rotated by the coordinate system rotation `deg` (G10 L2 R).
pub(crate) fn unrotate(p: &Axes, deg: f64) -> Axes {
    let mut q = *p;
    if deg != 0.0 {
        let (s, c) = (-deg).to_radians().sin_cos();
        q.0[0] = p.0[0] * c - p.0[1] * s;
        q.0[1] = p.0[0] * s + p.0[1] * c;
    }
    q
}

fn run_mtwin(program: &[u8], ini: Option<(&str, &Path)>) -> Outcome {
    let mut steps = Vec::new();
    let mut opts = mtwin_options();
    if let Some((text, dir)) = ini {
        opts.program.apply_ini(text, dir);
    }
    // The last end in program coordinates: a move that ends where the last
    // one did is left out, by the same rule as the rs274 side (a change of
    // work offset between them moves the machine, not the program point).
    let mut at = [0.0; 6];
    // The rotation in force (G10 L2 R): rs274 prints program coordinates.
    let mut rot = 0.0;
    let result = gcode::interpret(program, opts, |_, events| {
        for (k, e) in events.iter().enumerate() {
            match &e.kind {
                EventKind::WorkOffset { rotation, .. } => rot = *rotation,
                // G33.1: the tap down is one step (as rs274's RIGID_TAP),
                // the retract back to its start none.
                EventKind::Feed(m)
                    if m.words.expanded
                        && matches!(m.feed, Feed::PerRevolution { .. })
                        && k > 0
                        && matches!(events[k - 1].kind, EventKind::Feed(p)
                            if p.words.expanded && p.from == m.to && p.to == m.from) =>
                {
                    if let Some(Step::Move { kind, .. }) = steps.last_mut() {
                        *kind = "tap";
                    }
                    at.copy_from_slice(&unrotate(&m.to, rot).0[..6]);
                }
                EventKind::Traverse(m) | EventKind::Feed(m) => {
                    let mut m = *m;
                    m.from = unrotate(&m.from, rot);
                    m.to = unrotate(&m.to, rot);
                    let d = m.to.sub(&m.from);
                    let (xyz, abc) = (d.xyz_norm(), d.abc_norm());
                    let still = (0..6).all(|i| (m.to.0[i] - at[i]).abs() < 1.3e-3);
                    at.copy_from_slice(&m.to.0[..6]);
                    if still {
                        continue;
                    }
                    let scale = m.words.units.mm_per_unit();
                    let traverse = matches!(e.kind, EventKind::Traverse(_));
                    let mut end = [0.0; 6];
                    end.copy_from_slice(&m.to.0[..6]);
                    steps.push(Step::Move {
                        kind: if traverse { "traverse" } else { "feed" },
                        end,
                        arc: None,
                        feed: canonical_feed(m.feed, xyz, abc, scale),
                        scale,
                    });
                }
                EventKind::Arc(a) => {
                    let mut a = *a;
                    a.from = unrotate(&a.from, rot);
                    a.to = unrotate(&a.to, rot);
                    let c = unrotate(
                        &Axes([a.center[0], a.center[1], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                        rot,
                    );
                    a.center[0] = c.0[0];
                    a.center[1] = c.0[1];
                    at.copy_from_slice(&a.to.0[..6]);
                    let scale = a.words.units.mm_per_unit();
                    let (p, q, n) = a.plane.axes();
                    let abc = a.to.sub(&a.from).abc_norm();
                    steps.push(Step::Move {
                        kind: "arc",
                        end: [a.to[p], a.to[q], a.to[n], a.to.0[3], a.to.0[4], a.to.0[5]],
                        arc: Some(([a.center[p.index()], a.center[q.index()]], a.turns)),
                        feed: canonical_feed(a.feed, a.xyz_length(), abc, scale),
                        scale,
                    });
                }
                EventKind::Dwell { seconds } => steps.push(Step::Dwell(*seconds)),
                _ => {}
            }
        }
        Ok(())
    });
    let (refused, unsupported) = match result {
        Ok(()) => (None, None),
        Err(e @ GcodeError::Unsupported { .. }) => {
            let what = match &e {
                GcodeError::Unsupported { what, .. } => what.clone(),
                _ => unreachable!(),
            };
            (Some(e.to_string()), Some(what))
        }
        Err(e) => (Some(e.to_string()), None),
    };
    Outcome {
        steps,
        refused,
        unsupported,
    }
}

/// The first difference between two step lists, if any.
fn first_difference(ours: &[Step], theirs: &[Step]) -> Option<String> {
    for (k, (a, b)) in ours.iter().zip(theirs).enumerate() {
        let close = |x: f64, y: f64, tol: f64| (x - y).abs() <= tol;
        let ok = match (a, b) {
            (Step::Dwell(x), Step::Dwell(y)) => close(*x, *y, 0.6e-4),
            (
                Step::Move {
                    kind: k1,
                    end: e1,
                    arc: a1,
                    feed: f1,
                    scale: s1,
                },
                Step::Move {
                    kind: k2,
                    end: e2,
                    arc: a2,
                    feed: f2,
                    ..
                },
            ) => {
                // rs274 prints 4 decimals in program units.
                let tol_len = 0.6e-4 * s1 + 1e-9;
                let tol_ang = 0.6e-4;
                k1 == k2
                    && (0..6).all(|i| close(e1[i], e2[i], if i < 3 { tol_len } else { tol_ang }))
                    && match (a1, a2) {
                        (None, None) => true,
                        (Some((c1, t1)), Some((c2, t2))) => {
                            t1 == t2 && close(c1[0], c2[0], tol_len) && close(c1[1], c2[1], tol_len)
                        }
                        _ => false,
                    }
                    && match (f1, f2) {
                        (None, None) => true,
                        (Some(x), Some(y)) => close(*x, *y, 1.6e-3 + 1e-5 * y.abs()),
                        _ => false,
                    }
            }
            _ => false,
        };
        if !ok {
            return Some(format!("step {k}: mtwin {a:?}, rs274 {b:?}"));
        }
    }
    (ours.len() != theirs.len()).then(|| {
        format!(
            "mtwin {} steps, rs274 {} (next: mtwin {:?}, rs274 {:?})",
            ours.len(),
            theirs.len(),
            ours.get(theirs.len()),
            theirs.get(ours.len())
        )
    })
}

/// Programs rs274 refuses and mtwin accepts on purpose: the start of
/// rs274's message and the reason.
///
/// Not generated, as the differences are in the moves (listed in the
/// G-code documentation): an R arc whose end is its start to rounding
/// (LinuxCNC compares exactly and runs an arc of a chord of rounding noise;
/// mtwin refuses it), and G93 full circles and arcs of P > 1 turns
/// (LinuxCNC's rate leaves the full turns out, so the move does not last
/// 1/F minutes; mtwin's does).
const KNOWN_DIFFERENCES: &[(&str, &str)] = &[
    (
        "File ended with no percent sign or program end",
        "mtwin reads a program without M2, M30 or closing % to its last line",
    ),
    (
        "R word with no g code that uses it",
        "mtwin reads R with G64 (the blend tolerance of LinuxCNC after 2.9, as the \
         conformance case g64-r-planner expects); rs274 2.9 does not",
    ),
];

/// Programs that run and still differ from rs274, by path prefix, with the
/// reason. Each must still disagree, so the list cannot go stale.
const KNOWN_FLOW_DIFFERENCES: &[(&str, &str)] = &[
    (
        "linuxcnc-interp/nested-sub-error/",
        "a subroutine defined inside a subroutine: rs274 2.9 runs it (and reads the \
         caller's arguments in it), mtwin refuses it as LinuxCNC after 2.9 does",
    ),
    (
        // `T4 M6 G43` after a G53 move: rs274 re-reads its canon's last
        // point after M6 and misses the offset G43 sets (RS274_QUIRKS, "a
        // tool length offset changed before M6"); the next move leaving Z
        // unprogrammed shows it.
        "ncfiles/mmount.ngc",
        "rs274 re-reads its canon's last point after M6 and misses the tool length \
         offset of the G43 on the M6 line",
    ),
];

enum Verdict {
    Agree,
    Known(&'static str),
    Unsupported(String),
    Disagree(String),
}

/// The feature an unsupported block is tallied under: the G-code numbers
/// generalised away ("canned cycle G81" → "canned cycle"), an M-code kept
/// ("M-code M190": each unknown M-code is its own feature).
fn feature_of(what: &str) -> String {
    let is_g_number = |w: &str| {
        w.len() > 1 && w.starts_with('G') && w[1..].bytes().all(|b| b.is_ascii_digit() || b == b'.')
    };
    let words: Vec<&str> = what
        .split_whitespace()
        .filter(|w| !is_g_number(w))
        .collect();
    if words.is_empty() {
        what.to_string()
    } else {
        words.join(" ")
    }
}

#[test]
fn unsupported_features_are_named_in_the_tally() {
    assert_eq!(feature_of("canned cycle G81"), "canned cycle");
    assert_eq!(feature_of("M-code M190"), "M-code M190");
    assert_eq!(feature_of("G5.2"), "G5.2");
}

fn classify(ours: &Outcome, theirs: &Outcome) -> Verdict {
    if let Some(what) = &ours.unsupported {
        // The motion before the unsupported block must still be LinuxCNC's.
        let n = ours.steps.len().min(theirs.steps.len());
        if let Some(d) = first_difference(&ours.steps[..n], &theirs.steps[..n]) {
            return Verdict::Disagree(format!("before the unsupported block ({what}): {d}"));
        }
        return Verdict::Unsupported(feature_of(what));
    }
    match (&ours.refused, &theirs.refused) {
        (None, Some(e)) => {
            if let Some((_, why)) = KNOWN_DIFFERENCES.iter().find(|(m, _)| e.contains(m)) {
                return match first_difference(&ours.steps, &theirs.steps) {
                    None => Verdict::Known(why),
                    Some(d) => Verdict::Disagree(format!("{why}; and {d}")),
                };
            }
            return Verdict::Disagree(format!("rs274 refuses ({e}), mtwin accepts"));
        }
        (Some(e), None) => return Verdict::Disagree(format!("mtwin refuses ({e}), rs274 accepts")),
        _ => {}
    }
    match first_difference(&ours.steps, &theirs.steps) {
        None => Verdict::Agree,
        Some(d) => Verdict::Disagree(match (&ours.refused, &theirs.refused) {
            (Some(a), Some(b)) => format!("both refuse (mtwin: {a}; rs274: {b}), {d}"),
            _ => d,
        }),
    }
}

// ---------------------------------------------------------------------------
// The generator.

/// A small deterministic generator (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in 0..n.
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 <= p
    }
    fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len() as u64) as usize]
    }
}

/// What the generator knows of the program so far, to write valid blocks.
#[derive(Clone)]
struct GenState {
    inch: bool,
    incremental: bool,
    arc_absolute: bool,
    /// 0 XY, 1 ZX, 2 YZ.
    plane: usize,
    /// 0 G94, 1 G93, 2 G95.
    feed_mode: usize,
    feed_set: bool,
    /// Work system index 0..9.
    system: usize,
    /// Machine position X Y Z (mm, exact as written) and A B C (degree).
    machine: [f64; 6],
    /// M3 or M4 with a spindle speed in force.
    spindle: bool,
}

impl GenState {
    fn scale(&self) -> f64 {
        if self.inch { 25.4 } else { 1.0 }
    }
    /// Work position in program units (linear) and degree.
    fn work(&self, i: usize) -> f64 {
        if i < 3 {
            (self.machine[i] - WORK_OFFSETS[self.system][i] * 25.4) / self.scale()
        } else {
            self.machine[i]
        }
    }
    fn set_work(&mut self, i: usize, v: f64) {
        self.machine[i] = if i < 3 {
            v * self.scale() + WORK_OFFSETS[self.system][i] * 25.4
        } else {
            v
        };
    }
}

struct Gen {
    rng: Rng,
    st: GenState,
    lines: Vec<String>,
    line_number: u32,
}

/// Rounds to the 4 decimals the generator writes.
fn r4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

fn num(v: f64) -> String {
    let s = format!("{:.4}", r4(v));
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

const AXIS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

impl Gen {
    fn emit(&mut self, words: String) {
        self.lines.push(words);
    }

    /// A feed word for a feed move: always in G93 and after a feed mode
    /// change (both reset the rate), else now and then; rarely left out
    /// where it is needed (both interpreters must then refuse).
    fn feed_word(&mut self) -> String {
        let needed = !self.st.feed_set || self.st.feed_mode == 1;
        if (needed && !self.rng.chance(0.01)) || self.rng.chance(0.2) {
            self.st.feed_set = true;
            let f = match self.st.feed_mode {
                0 => *self.rng.pick(&[60.0, 250.0, 600.0, 1234.5, 3000.0]),
                1 => *self.rng.pick(&[0.5, 2.0, 10.0, 120.0]),
                _ => *self.rng.pick(&[0.05, 0.1, 0.25]),
            };
            format!(" F{}", num(f))
        } else {
            String::new()
        }
    }

    /// Axis words to a new target (work program units), updating the state.
    fn target_words(&mut self, axes: &[usize]) -> String {
        let mut s = String::new();
        for &i in axes {
            let v = if i < 3 {
                let span = if self.st.inch { 4.0 } else { 100.0 };
                r4((self.rng.below(20001) as f64 / 10000.0 - 1.0) * span)
            } else {
                self.rng.below(721) as f64 * 0.5 - 180.0
            };
            let w = if self.st.incremental {
                v - r4(self.st.work(i))
            } else {
                v
            };
            // Incremental: the end is where the written word takes it.
            let end = if self.st.incremental {
                self.st.work(i) + r4(w)
            } else {
                v
            };
            self.st.set_work(i, end);
            write!(s, " {}{}", AXIS[i], num(w)).unwrap();
        }
        s
    }

    fn some_axes(&mut self, rotary: bool) -> Vec<usize> {
        let n = if rotary { 6 } else { 3 };
        let mut v: Vec<usize> = (0..n).filter(|_| self.rng.chance(0.5)).collect();
        if v.is_empty() {
            v.push(self.rng.below(n as u64) as usize);
        }
        v
    }
}

/// Pythagorean vectors (a, b, c) with a² + b² = c².
const TRIPLES: &[(f64, f64, f64)] = &[
    (3.0, 4.0, 5.0),
    (5.0, 12.0, 13.0),
    (8.0, 15.0, 17.0),
    (7.0, 24.0, 25.0),
    (20.0, 21.0, 29.0),
    (12.0, 16.0, 20.0),
    (0.0, 5.0, 5.0),
];

/// One vector of length c of a triple, any sign and order.
fn triple_vector(rng: &mut Rng, t: (f64, f64, f64)) -> [f64; 2] {
    let (mut a, mut b) = if rng.chance(0.5) {
        (t.0, t.1)
    } else {
        (t.1, t.0)
    };
    if rng.chance(0.5) {
        a = -a;
    }
    if rng.chance(0.5) {
        b = -b;
    }
    [a, b]
}

fn gen_traverse(g: &mut Gen) {
    let rotary = g.rng.chance(0.2);
    let axes = g.some_axes(rotary);
    let t = g.target_words(&axes);
    g.emit(format!("G0{t}"));
}

fn gen_line(g: &mut Gen) {
    let rotary = g.rng.chance(0.25);
    let axes = g.some_axes(rotary);
    let t = g.target_words(&axes);
    let f = g.feed_word();
    g.emit(format!("G1{t}{f}"));
}

/// LinuxCNC's polar words in G17 (in G18/G19, where both refuse them, a
/// plain line instead): `@` the distance from the program origin and `^`
/// the angle from +X (degree), in G90 those of the end (one alone keeps the
/// start's other), in G91 added to the start's (`@` first, then `^`); G0 or
/// G1, now and then a Z word. Never from within 0.01 unit of the origin,
/// where the start's angle is that of a rounding residue (rs274 and mtwin
/// would each be right about a different residue) — from there both words
/// in G90.
fn gen_polar(g: &mut Gen) {
    if g.st.plane != 0 {
        gen_line(g);
        return;
    }
    let span = if g.st.inch { 4.0 } else { 100.0 };
    let (x, y) = (g.st.work(0), g.st.work(1));
    let near_origin = x.hypot(y) < 0.01;
    let distance = |g: &mut Gen| r4((0.05 + g.rng.below(951) as f64 / 1000.0) * span);
    let angle = |g: &mut Gen| g.rng.below(1440) as f64 * 0.25 - 180.0;
    let polar = |r: f64, t: f64| (r * t.to_radians().cos(), r * t.to_radians().sin());
    let mut words = String::new();
    let mut g90 = "";
    let variant = if near_origin { 0 } else { g.rng.below(3) };
    let end = if !g.st.incremental || near_origin {
        if g.st.incremental {
            g90 = "G90 ";
        }
        let (r0, t0) = (x.hypot(y), y.atan2(x).to_degrees());
        let (r, t) = match variant {
            0 => (distance(g), angle(g)),
            1 => (distance(g), t0),
            _ => (r0, angle(g)),
        };
        if variant != 2 {
            write!(words, " @{}", num(r)).unwrap();
        }
        if variant != 1 {
            write!(words, " ^{}", num(t)).unwrap();
        }
        polar(r, t)
    } else {
        let (mut ex, mut ey) = (x, y);
        if variant != 2 {
            // Never through the origin: at most half the distance inwards.
            let r = ex.hypot(ey);
            let d = r4((g.rng.below(1001) as f64 / 1000.0 - 0.5) * r.min(span));
            write!(words, " @{}", num(d)).unwrap();
            (ex, ey) = polar(r + d, ey.atan2(ex).to_degrees());
        }
        if variant != 1 {
            let t = angle(g);
            write!(words, " ^{}", num(t)).unwrap();
            (ex, ey) = polar(ex.hypot(ey), ey.atan2(ex).to_degrees() + t);
        }
        (ex, ey)
    };
    g.st.set_work(0, end.0);
    g.st.set_work(1, end.1);
    let z = if g.rng.chance(0.3) {
        if !g90.is_empty() {
            // The Z word is read in G90 too.
            let v = r4((g.rng.below(2001) as f64 / 1000.0 - 1.0) * span);
            g.st.set_work(2, v);
            format!(" Z{}", num(v))
        } else {
            g.target_words(&[2])
        }
    } else {
        String::new()
    };
    if g.rng.chance(0.3) {
        g.emit(format!("{g90}G0{words}{z}"));
    } else {
        let f = g.feed_word();
        g.emit(format!("{g90}G1{words}{z}{f}"));
    }
    if !g90.is_empty() {
        g.emit("G91".into());
    }
}

/// G2/G3 in the current plane, centre by I J K (incremental or absolute
/// per G91.1/G90.1) or by R, sometimes helical, sometimes with P turns.
fn gen_arc(g: &mut Gen) {
    let (p, q, n) = [(0, 1, 2), (2, 0, 1), (1, 2, 0)][g.st.plane];
    let t = *g.rng.pick(TRIPLES);
    let k = *g.rng.pick(&[0.1, 0.25, 0.5, 1.0, 2.0]) / if g.st.inch { 10.0 } else { 1.0 };
    let to_c = triple_vector(&mut g.rng, t);
    let mut to_e = triple_vector(&mut g.rng, t);
    // Full circles only by I J K and not in G93 (see KNOWN_DIFFERENCES).
    let use_r = g.rng.chance(0.3);
    // The end is the start when to_e = −to_c: a full circle.
    if (use_r || g.st.feed_mode == 1) && to_e == [-to_c[0], -to_c[1]] {
        to_e = [-to_c[1], -to_c[0]];
    }
    // Absolute end or centre words are written to 4 decimals: start from
    // a point so written (a traverse 1 unit away) if the current one is not.
    let written = |v: f64| (v - r4(v)).abs() < 1e-9;
    let needs_start = (!g.st.incremental || g.st.arc_absolute)
        && !(written(g.st.work(p)) && written(g.st.work(q)));
    if needs_start {
        let mut s = String::from("G90 G0");
        for i in [p, q] {
            let v = r4(g.st.work(i)) + 1.0;
            g.st.set_work(i, v);
            write!(s, " {}{}", AXIS[i], num(v)).unwrap();
        }
        g.emit(s);
        if g.st.incremental {
            g.emit("G91".into());
        }
    }
    let start = [g.st.work(p), g.st.work(q)];
    let center = [start[0] + to_c[0] * k, start[1] + to_c[1] * k];
    let end = [center[0] + to_e[0] * k, center[1] + to_e[1] * k];
    let cw = g.rng.chance(0.5);
    let mut s = String::from(if cw { "G2" } else { "G3" });
    for (j, &i) in [p, q].iter().enumerate() {
        let w = if g.st.incremental {
            end[j] - start[j]
        } else {
            end[j]
        };
        // Full circles leave the end words out now and then.
        if w.abs() > 1e-9 || !g.st.incremental || g.rng.chance(0.5) {
            write!(s, " {}{}", AXIS[i], num(w)).unwrap();
        }
        g.st.set_work(
            i,
            if g.st.incremental {
                start[j] + r4(w)
            } else {
                r4(w)
            },
        );
    }
    if g.rng.chance(0.3) {
        let d = *g.rng.pick(&[-1.5, -0.2, 0.5, 2.0]) / if g.st.inch { 10.0 } else { 1.0 };
        let v = r4(g.st.work(n)) + d;
        let w = if g.st.incremental { d } else { v };
        write!(s, " {}{}", AXIS[n], num(w)).unwrap();
        g.st.set_work(n, v);
    }
    if g.rng.chance(0.15) {
        // A rotary axis turning with the arc.
        let a = 3 + g.rng.below(3) as usize;
        let v = g.rng.below(361) as f64 - 180.0;
        let w = if g.st.incremental {
            v - g.st.work(a)
        } else {
            v
        };
        write!(s, " {}{}", AXIS[a], num(w)).unwrap();
        g.st.set_work(
            a,
            if g.st.incremental {
                g.st.work(a) + r4(w)
            } else {
                v
            },
        );
    }
    let letters = [['I', 'J'], ['K', 'I'], ['J', 'K']][g.st.plane];
    let full = (end[0] - start[0]).abs() < 1e-9 && (end[1] - start[1]).abs() < 1e-9;
    if use_r {
        // R: + for the short way, − for the long way (either is valid here).
        let r = t.2 * k;
        let r = if g.rng.chance(0.5) { r } else { -r };
        write!(s, " R{}", num(r)).unwrap();
    } else {
        for (j, l) in letters.iter().enumerate() {
            let v = if g.st.arc_absolute {
                center[j]
            } else {
                center[j] - start[j]
            };
            if v.abs() > 1e-9 || g.rng.chance(0.5) {
                write!(s, " {l}{}", num(v)).unwrap();
            }
        }
        if g.st.feed_mode != 1 && (full || g.rng.chance(0.1)) {
            let turns = *g.rng.pick(&[1, 2, 3]);
            write!(s, " P{turns}").unwrap();
        }
    }
    s.push_str(&g.feed_word());
    g.emit(s);
}

fn gen_plane(g: &mut Gen) {
    g.st.plane = g.rng.below(3) as usize;
    let code = ["G17", "G18", "G19"][g.st.plane];
    g.emit(code.into());
}

fn gen_units(g: &mut Gen) {
    g.st.inch = g.rng.chance(0.5);
    g.emit(if g.st.inch { "G20" } else { "G21" }.into());
}

fn gen_distance(g: &mut Gen) {
    if g.rng.chance(0.5) {
        g.st.incremental = g.rng.chance(0.5);
        g.emit(if g.st.incremental { "G91" } else { "G90" }.into());
    } else {
        g.st.arc_absolute = g.rng.chance(0.5);
        g.emit(if g.st.arc_absolute { "G90.1" } else { "G91.1" }.into());
    }
}

fn gen_work_system(g: &mut Gen) {
    g.st.system = g.rng.below(9) as usize;
    let code = [
        "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
    ][g.st.system];
    g.emit(code.into());
}

/// G53 G0/G1 to machine coordinates (absolute only: G53 with G91 is refused
/// by both, tried now and then).
fn gen_g53(g: &mut Gen) {
    let axes = g.some_axes(false);
    let motion = if g.rng.chance(0.5) { "G0" } else { "G1" };
    let mut s = format!("G53 {motion}");
    if g.st.incremental && !g.rng.chance(0.1) {
        g.st.incremental = false;
        g.emit("G90".into());
    }
    for i in axes {
        let span = if g.st.inch { 4.0 } else { 100.0 };
        let v = r4((g.rng.below(2001) as f64 / 1000.0 - 1.0) * span);
        g.st.machine[i] = v * g.st.scale();
        write!(s, " {}{}", AXIS[i], num(v)).unwrap();
    }
    if motion == "G1" {
        s.push_str(&g.feed_word());
    }
    g.emit(s);
}

fn gen_feed_mode(g: &mut Gen) {
    g.st.feed_mode = g.rng.below(3) as usize;
    g.st.feed_set = false;
    let code = ["G94", "G93", "G95"][g.st.feed_mode];
    if g.st.feed_mode == 2 && g.rng.chance(0.7) {
        let s = *g.rng.pick(&[500, 1000, 2400]);
        g.st.spindle = true;
        g.emit(format!("{code} S{s} M3"));
    } else {
        g.emit(code.into());
    }
}

/// G33 (spindle-synchronised move) or G33.1 (rigid tap, back to the
/// start), K per revolution, G33.1 now and then with I (retract speed
/// factor); the spindle started first unless it turns (now and then left
/// stopped or without a speed: both refuse, or mtwin cannot time it).
fn gen_spindle_sync(g: &mut Gen) {
    if !g.st.spindle || g.rng.chance(0.1) {
        match g.rng.below(40) {
            0 => g.emit("M5".into()),
            1 => g.emit("S0 M3".into()),
            k => {
                let s = *g.rng.pick(&[300, 800, 1500]);
                g.emit(format!("S{s} M{}", if k % 2 == 0 { 3 } else { 4 }));
                g.st.spindle = true;
            }
        }
    }
    let k = *g.rng.pick(&[0.5, 1.0, 1.25, 2.0]) / if g.st.inch { 25.0 } else { 1.0 };
    if g.rng.chance(0.4) {
        // G33.1: along X Y Z (Z mostly), the position unchanged after.
        let saved = g.st.machine;
        let axes: Vec<usize> = if g.rng.chance(0.7) {
            vec![2]
        } else {
            g.some_axes(false)
        };
        let t = g.target_words(&axes);
        g.st.machine = saved;
        let i = if g.rng.chance(0.3) {
            format!(" I{}", num(*g.rng.pick(&[0.5, 1.0, 2.0, 3.5])))
        } else {
            String::new()
        };
        g.emit(format!("G33.1{t} K{}{i}", num(k)));
    } else {
        let axes = g.some_axes(false);
        let t = g.target_words(&axes);
        g.emit(format!("G33{t} K{}", num(k)));
    }
}

/// G76 (threading cycle): the passes from the current X Z along Z to the
/// block's Z (now and then X and Y words too: the end after the passes),
/// internal or external (I of either sign), first cut J, full depth K
/// (2 to 12 times J), now and then a compound angle Q, spring passes H (H-1:
/// none at the full depth), a degression R, tapers E with L; the spindle
/// started first unless it turns (now and then left stopped: both refuse).
fn gen_threading(g: &mut Gen) {
    if !g.st.spindle && !g.rng.chance(0.05) {
        let s = *g.rng.pick(&[200, 600, 1200]);
        let m = if g.rng.chance(0.7) { 3 } else { 4 };
        g.emit(format!("S{s} M{m}"));
        g.st.spindle = true;
    }
    let u = if g.st.inch { 1.0 / 25.4 } else { 1.0 };
    let pitch = *g.rng.pick(&[0.5, 1.0, 1.25, 1.5, 2.0]) * u;
    let mut axes = vec![2];
    if g.rng.chance(0.2) {
        axes.insert(0, 0);
    }
    if g.rng.chance(0.1) {
        axes.insert(1, 1);
    }
    let t = g.target_words(&axes);
    let i = *g.rng.pick(&[-1.0, -0.5, 0.25, 0.8]) * u;
    let j = *g.rng.pick(&[0.05, 0.1, 0.2]) * u;
    let k = j * (2 + g.rng.below(11)) as f64;
    let mut w = format!("G76 P{}{t} I{} J{} K{}", num(pitch), num(i), num(j), num(k));
    if g.rng.chance(0.4) {
        write!(w, " Q{}", num(*g.rng.pick(&[29.5, 30.0, 15.0, -10.0]))).unwrap();
    }
    if g.rng.chance(0.3) {
        write!(w, " H{}", g.rng.pick(&[-1, 0, 1, 3])).unwrap();
    }
    if g.rng.chance(0.3) {
        write!(w, " R{}", num(*g.rng.pick(&[0.5, 1.0, 1.5, 2.0]))).unwrap();
    }
    if g.rng.chance(0.3) {
        let e = *g.rng.pick(&[0.5, 1.0, 2.0]) * u;
        write!(w, " E{} L{}", num(e), g.rng.below(4)).unwrap();
    }
    g.emit(w);
}

fn gen_dwell(g: &mut Gen) {
    let p = *g.rng.pick(&[0.0, 0.25, 1.0, 2.5]);
    g.emit(format!("G4 P{}", num(p)));
}

fn gen_comment(g: &mut Gen) {
    let c = *g.rng.pick(&[
        "(roughing)",
        "; finishing pass",
        "(MSG, hello)",
        "( T1 D=6 )",
    ]);
    g.emit(c.into());
}

/// A generator of one language feature: it writes one or more blocks and
/// keeps [`GenState`] up to date. Weights are relative.
type Feature = (&'static str, u32, fn(&mut Gen));

/// The features of generated programs (add yours here).
const FEATURES: &[Feature] = &[
    ("traverse", 6, gen_traverse),
    ("line", 10, gen_line),
    ("polar", 3, gen_polar),
    ("arc", 10, gen_arc),
    ("plane", 2, gen_plane),
    ("units", 2, gen_units),
    ("distance", 2, gen_distance),
    ("work system", 2, gen_work_system),
    ("G53", 1, gen_g53),
    ("feed mode", 2, gen_feed_mode),
    ("dwell", 1, gen_dwell),
    ("spindle sync", 2, gen_spindle_sync),
    ("threading", 2, gen_threading),
    ("comment", 1, gen_comment),
];

/// Number of generated programs of cutter radius compensation
/// ([`generate_comp`]).
const COMP: u64 = 150;
/// Seed of the first of them.
const COMP_SEED: u64 = 0xc0c0_2026;

/// Program `seed` of cutter radius compensation on a shape that does not
/// gouge: a convex polygon of 4 to 8 corners on a circle (gaps of 30° to
/// 120°, radius 25 to 60 tool radii), some edges outward arcs (R format,
/// 3° to 8° of bulge, so each corner stays convex), cut outside or inside,
/// either way round; G17 or G18, mm or inch, absolute or incremental; the
/// radius from G41.1/G42.1 D, from the tool table (G41/G42 Dn) or from the
/// tool in the spindle (T M6, G41/G42); entry from one radial distance of
/// 3 to 6 tool radii outside (or from the centre, inside), now and then an
/// overlap past the first corner, exit after G40 (on its line or the next).
fn generate_comp(seed: u64) -> String {
    let mut rng = Rng(seed);
    let inch = rng.chance(0.3);
    // Program units per mm.
    let u = if inch { 1.0 / 25.4 } else { 1.0 };
    let g18 = rng.chance(0.2);
    let (l1, l2, ln) = if g18 {
        ('Z', 'X', 'Y')
    } else {
        ('X', 'Y', 'Z')
    };
    let mut out = format!(
        "{} {} G90 G94 G40\n",
        if inch { "G20" } else { "G21" },
        if g18 { "G18" } else { "G17" }
    );
    // Tool radius (mm) and the words that give it.
    let (r, comp_words) = match rng.below(3) {
        0 => {
            let d = *rng.pick(&[2.0, 4.0, 6.0, 10.0]);
            (d / 2.0, format!(".1 D{}", num(d * u)))
        }
        k => {
            let i = rng.below(3) as usize;
            let (t, _) = TOOLS[i];
            let r = TOOL_DIAMETERS[i] * 25.4 / 2.0;
            if k == 1 {
                (r, format!(" D{t}"))
            } else {
                writeln!(out, "T{t} M6").unwrap();
                (r, String::new())
            }
        }
    };
    // Corners: n angles with gaps of 30° to 120°.
    let n = 4 + rng.below(5) as usize;
    let gaps = loop {
        let raw: Vec<f64> = (0..n)
            .map(|_| 1.0 + rng.below(1000) as f64 / 1000.0)
            .collect();
        let sum: f64 = raw.iter().sum();
        let g: Vec<f64> = raw.iter().map(|x| x * 360.0 / sum).collect();
        if g.iter().all(|&x| (30.0..=120.0).contains(&x)) {
            break g;
        }
    };
    let big = r * (25.0 + rng.below(36) as f64);
    let c = [
        (rng.below(1001) as f64 / 10.0 - 50.0),
        (rng.below(1001) as f64 / 10.0 - 50.0),
    ];
    let phase = rng.below(360) as f64;
    let ccw = rng.chance(0.5);
    let mut angles = Vec::new();
    let mut a = phase;
    for g in &gaps {
        angles.push(a);
        a += g;
    }
    if !ccw {
        angles.reverse();
    }
    // Corners in program units, as written (4 decimals).
    let pt = |deg: f64, dist: f64| {
        let t = deg.to_radians();
        [
            r4((c[0] + dist * t.cos()) * u),
            r4((c[1] + dist * t.sin()) * u),
        ]
    };
    let corners: Vec<[f64; 2]> = angles.iter().map(|&d| pt(d, big)).collect();
    let inside = rng.chance(0.5);
    // Tool left of a counter-clockwise path is inside.
    let left = inside == ccw;
    let entry_dist = big + r * (3.0 + rng.below(4) as f64);
    let start = if inside {
        [r4(c[0] * u), r4(c[1] * u)]
    } else {
        pt(angles[0], entry_dist)
    };
    let feed = *rng.pick(&[200.0, 500.0, 1200.0]) * u;
    writeln!(out, "G0 {l1}{} {l2}{}", num(start[0]), num(start[1])).unwrap();
    writeln!(out, "G0 {ln}{}", num(5.0 * u)).unwrap();
    writeln!(out, "G1 {ln}{} F{}", num(-u), num(feed)).unwrap();
    writeln!(out, "G4{}{comp_words}", if left { "1" } else { "2" }).unwrap();
    let incremental = rng.chance(0.25);
    if incremental {
        out.push_str("G91\n");
    }
    let mut at = start;
    let mut to = |out: &mut String, code: &str, p: [f64; 2], tail: &str| {
        let w = if incremental {
            [p[0] - at[0], p[1] - at[1]]
        } else {
            p
        };
        writeln!(out, "{code} {l1}{} {l2}{}{tail}", num(w[0]), num(w[1])).unwrap();
        at = p;
    };
    to(&mut out, "G1", corners[0], "");
    let overlap = rng.chance(0.3);
    let edges = n + usize::from(overlap);
    for k in 0..edges {
        let (a, b) = (corners[k % n], corners[(k + 1) % n]);
        if rng.chance(0.3) {
            // Bulging outward: centre on the inner side.
            let chord = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            let bulge = (3.0 + rng.below(6) as f64).to_radians();
            let rho = chord / (2.0 * bulge.sin());
            let code = if ccw { "G3" } else { "G2" };
            to(&mut out, code, b, &format!(" R{}", num(rho)));
        } else {
            to(&mut out, "G1", b, "");
        }
    }
    let last_angle = angles[edges % n];
    let exit = if inside {
        [r4(c[0] * u), r4(c[1] * u)]
    } else {
        pt(last_angle, entry_dist)
    };
    match rng.below(3) {
        0 => {
            out.push_str("G40\n");
            to(&mut out, "G1", exit, "");
        }
        1 => to(&mut out, "G40 G1", exit, ""),
        _ => to(&mut out, "G40 G0", exit, ""),
    }
    if incremental {
        out.push_str("G90\n");
    }
    writeln!(out, "G0 {ln}{}\nM2", num(5.0 * u)).unwrap();
    out
}

/// Program `seed` in rotated coordinate systems (G10 L2 R, mm): systems
/// given offsets and rotations (of the active one too), traverses, feeds
/// and incremental XY arcs in them, G92 on top (and G92.1), switches of
/// system, G53 and G28 moves, G10 L20 of the active system, tool changes,
/// G43 (with and without H) and G49, tool offsets set by G10 L10 and L11;
/// then M2.
///
/// The program loads a tool first, every later tool change follows a
/// traverse to all of X, Y and Z, and G43 never shares a line with M6:
/// two habits of rs274's standalone canon (2.9) that LinuxCNC's controller
/// does not have would otherwise decide the result.
/// [`rs274_standalone_quirks_the_generator_avoids`] shows both:
///
/// * rs274 starts with pocket 1 as the current pocket (its canon's tool
///   slot starts at 1) but an empty spindle entry: G10 L1/L10/L11 of tool 1
///   then also writes the spindle entry, which a later G43 applies; mtwin
///   starts with no tool in the spindle (as the controller with no tool
///   loaded).
/// * rs274's canon remembers the last point it was sent and does not move
///   it when a tool length offset or the XY rotation changes; after M6 the
///   interpreter re-reads its point from there (`read_inputs` after a tool
///   change), a stale point. LinuxCNC's controller re-reads the machine
///   position; mtwin keeps it.
fn generate_rotated(seed: u64) -> String {
    let mut rng = Rng(seed);
    let mut out = String::from("G21 G90 G17 G94 F600\n");
    let v = |rng: &mut Rng, span: f64| r4((rng.below(2001) as f64 / 1000.0 - 1.0) * span);
    let systems = [
        "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
    ];
    let tools = [1, 2, 4];
    writeln!(out, "T{} M6", rng.pick(&tools)).unwrap();
    // An M61 since the last M6: rs274's spindle entry is not the tool in
    // the spindle, so G43 names its tool by H.
    let mut m61 = false;
    let xyz = |rng: &mut Rng| {
        format!(
            "G0 X{} Y{} Z{}",
            num(v(rng, 80.0)),
            num(v(rng, 80.0)),
            num(v(rng, 20.0))
        )
    };
    for _ in 0..4 + rng.below(16) {
        let line = match rng.below(15) {
            0 | 1 => {
                let mut l = format!("G10 L2 P{}", rng.below(10));
                if rng.chance(0.7) {
                    write!(
                        l,
                        " X{} Y{}",
                        num(v(&mut rng, 50.0)),
                        num(v(&mut rng, 50.0))
                    )
                    .unwrap();
                }
                if rng.chance(0.3) {
                    write!(l, " Z{}", num(v(&mut rng, 20.0))).unwrap();
                }
                // Degrees to 0.1, either sign, now and then a whole turn or more.
                let r = r4((rng.below(14401) as f64 - 7200.0) / 10.0);
                write!(l, " R{}", num(if rng.chance(0.1) { 0.0 } else { r })).unwrap();
                l
            }
            2 => rng.pick(&systems).to_string(),
            3 => format!(
                "G0 X{} Y{} Z{}",
                num(v(&mut rng, 80.0)),
                num(v(&mut rng, 80.0)),
                num(v(&mut rng, 20.0))
            ),
            4 => format!("G1 X{} Y{}", num(v(&mut rng, 80.0)), num(v(&mut rng, 80.0))),
            5 => {
                // From the current point: centre at (i, j), the end `sweep`
                // further round the circle.
                let r = 1.0 + rng.below(300) as f64 / 10.0;
                let phi = (rng.below(360) as f64).to_radians();
                let sweep = (10.0 + rng.below(330) as f64).to_radians();
                let ccw = rng.chance(0.5);
                let (i, j) = (-r * phi.cos(), -r * phi.sin());
                let end = if ccw { phi + sweep } else { phi - sweep };
                let (dx, dy) = (i + r * end.cos(), j + r * end.sin());
                format!(
                    "G91 G{} X{} Y{} I{} J{}\nG90",
                    if ccw { 3 } else { 2 },
                    num(r4(dx)),
                    num(r4(dy)),
                    num(r4(i)),
                    num(r4(j))
                )
            }
            6 => {
                if rng.chance(0.25) {
                    "G92.1".to_string()
                } else {
                    format!(
                        "G92 X{} Y{}",
                        num(v(&mut rng, 30.0)),
                        num(v(&mut rng, 30.0))
                    )
                }
            }
            7 => format!(
                "G53 G0 X{} Y{}",
                num(v(&mut rng, 60.0)),
                num(v(&mut rng, 60.0))
            ),
            8 => "G28".to_string(),
            9 => format!(
                "G10 L20 P0 X{} Y{}",
                num(v(&mut rng, 40.0)),
                num(v(&mut rng, 40.0))
            ),
            10 => {
                m61 = false;
                format!("{}\nT{} M6", xyz(&mut rng), rng.pick(&tools))
            }
            11 => match rng.below(4) {
                1 => "G49".to_string(),
                _ if m61 => format!("G43 H{}", rng.pick(&tools)),
                0 => "G43".to_string(),
                _ => format!("G43 H{}", rng.pick(&[0, 1, 2, 4])),
            },
            12 => {
                // M61 after a traverse to X Y Z; now and then G43 on its
                // line (the new tool's entry, or with Q0 the spindle's,
                // still the tool before: not after another M61), then a
                // traverse to X Y Z (rs274 re-reads a stale point after
                // M61 too).
                let q = *rng.pick(&[0, 1, 2, 4]);
                let mut l = format!("{}\nM61 Q{q}", xyz(&mut rng));
                if (q != 0 || !m61) && rng.chance(0.5) {
                    write!(l, " G43\n{}", xyz(&mut rng)).unwrap();
                }
                m61 = true;
                l
            }
            _ => {
                // G10 L10 (the active system) or L11 (G59.3): one to three
                // of X, Y, Z.
                let mut l = format!("G10 L{} P{}", rng.pick(&[10, 11]), rng.pick(&tools));
                let mask = 1 + rng.below(7);
                for (bit, axis, span) in [(1, 'X', 20.0), (2, 'Y', 20.0), (4, 'Z', 10.0)] {
                    if mask & bit != 0 {
                        write!(l, " {axis}{}", num(v(&mut rng, span))).unwrap();
                    }
                }
                l
            }
        };
        out.push_str(&line);
        out.push('\n');
    }
    out.push_str("G92.1\nG54\nM2\n");
    out
}

/// Program `seed`: a start-up line, 5..40 features, then M2 or M30.
/// Blocks get line numbers, trailing comments and `/` (block delete: the
/// state is then restored, as both skip the block) at random.
fn generate(seed: u64) -> String {
    let mut g = Gen {
        rng: Rng(seed),
        st: GenState {
            inch: false,
            incremental: false,
            arc_absolute: false,
            plane: 0,
            feed_mode: 0,
            feed_set: false,
            system: 0,
            machine: [0.0; 6],
            spindle: false,
        },
        lines: Vec::new(),
        line_number: 0,
    };
    g.emit("G17 G21 G90 G94 G54".into());
    let total: u32 = FEATURES.iter().map(|f| f.1).sum();
    let n = 5 + g.rng.below(36);
    for _ in 0..n {
        let mut pick = g.rng.below(u64::from(total)) as u32;
        let feature = FEATURES
            .iter()
            .find(|f| {
                if pick < f.1 {
                    true
                } else {
                    pick -= f.1;
                    false
                }
            })
            .unwrap();
        let deleted = g.rng.chance(0.04);
        let saved = g.st.clone();
        let first = g.lines.len();
        (feature.2)(&mut g);
        if deleted {
            g.st = saved;
        }
        for k in first..g.lines.len() {
            let mut prefix = String::new();
            if deleted {
                prefix.push('/');
            }
            if g.rng.chance(0.15) {
                g.line_number += 10;
                write!(prefix, "N{} ", g.line_number).unwrap();
            }
            let mut l = format!("{prefix}{}", g.lines[k]);
            if g.rng.chance(0.1) {
                l.push_str(" (note)");
            }
            g.lines[k] = l;
        }
    }
    // LinuxCNC requires a program end (see KNOWN_DIFFERENCES).
    let end = if g.rng.chance(0.5) { "M2" } else { "M30" };
    g.emit(end.into());
    let mut s = g.lines.join("\n");
    s.push('\n');
    s
}

// ---------------------------------------------------------------------------
// The test.

/// A program to run: a name and its file.
struct Case {
    name: String,
    path: PathBuf,
    /// The program's own INI text (a conformance case with a `subs` folder
    /// or `#<_ini[…]>` values), else the shared one.
    ini: Option<String>,
}

fn ngc_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    for e in entries {
        if e.is_dir() {
            ngc_files(&e, out);
        } else if e.extension().is_some_and(|x| x == "ngc") {
            out.push(e);
        }
    }
}

#[test]
fn differential_against_linuxcnc_rs274() {
    let Some(setup) = setup() else { return };
    let mut cases = Vec::new();
    let required = std::env::var("MTWIN_REQUIRE_RS274").is_ok_and(|v| v == "1");
    let ncfiles = Path::new(NCFILES);
    assert!(
        !required || ncfiles.is_dir(),
        "MTWIN_REQUIRE_RS274=1 but LinuxCNC's example programs {NCFILES} are missing \
         (Debian: apt-get install linuxcnc-uspace)"
    );
    let dirs = ["corpus/gcode", "corpus/gcode-conformance/linuxcnc-interp"]
        .into_iter()
        .filter_map(crate::shared::shared_dir)
        .chain(ncfiles.is_dir().then(|| ncfiles.to_path_buf()));
    for dir in dirs {
        let mut files = Vec::new();
        ngc_files(&dir, &mut files);
        for path in files {
            let name = path
                .strip_prefix(dir.parent().unwrap())
                .unwrap()
                .to_string_lossy()
                .into_owned();
            // A conformance case: its folder name relative to the suite.
            let case = path
                .parent()
                .and_then(|p| p.strip_prefix(&dir).ok())
                .map(|p| p.to_string_lossy().into_owned())
                .unwrap_or_default();
            let case_subs = path.parent().map(|p| p.join("subs")).filter(|p| p.is_dir());
            let sections = crate::gcode_conformance::case_ini_sections(&case);
            let ini = (case_subs.is_some() || !sections.is_empty())
                .then(|| case_ini_text(&setup.subs, case_subs.as_deref(), sections));
            cases.push(Case { name, path, ini });
        }
    }
    let gen_dir = setup.root.join("generated");
    std::fs::create_dir(&gen_dir).unwrap();
    // Each generator: its file prefix, its case label, how many programs
    // and from which random seed.
    type Generator = (&'static str, &'static str, u64, u64, fn(u64) -> String);
    let generators: [Generator; 5] = [
        ("g", "generated", GENERATED, SEED, generate),
        ("r", "rotated", ROTATED, ROTATED_SEED, generate_rotated),
        ("c", "compensation", COMP, COMP_SEED, generate_comp),
        ("l", "lathe random", LATHE, LATHE_SEED, generate_lathe),
        (
            "t",
            "lathe tool",
            LATHE_COMP,
            LATHE_COMP_SEED,
            generate_lathe_comp,
        ),
    ];
    for (prefix, label, count, seed, gen_program) in generators {
        for k in 0..count {
            let path = gen_dir.join(format!("{prefix}{k:05}.ngc"));
            std::fs::write(&path, gen_program(seed + k)).unwrap();
            cases.push(Case {
                name: format!("{label} seed {:#x}", seed + k),
                path,
                ini: None,
            });
        }
    }

    let verdicts: Mutex<Vec<(usize, Verdict)>> = Mutex::new(Vec::new());
    // Compensation programs rs274 refuses or runs with few moves (each
    // must be a real compensated profile).
    let comp_short: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let next = AtomicUsize::new(0);
    // rs274 spends most of its run time idle (start-up and exit): more
    // processes than cores keep the test short.
    let workers = 8;
    std::thread::scope(|scope| {
        for w in 0..workers {
            let (cases, setup, verdicts, next, comp_short) =
                (&cases, &setup, &verdicts, &next, &comp_short);
            scope.spawn(move || {
                let work = setup.root.join(format!("work{w}"));
                std::fs::create_dir(&work).unwrap();
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(case) = cases.get(i) else { break };
                    let bytes = std::fs::read(&case.path).unwrap();
                    let theirs = run_rs274(setup, &case.path, &work, case.ini.as_deref());
                    let dir = case.path.parent().unwrap_or(Path::new("."));
                    let ours = run_mtwin(&bytes, case.ini.as_deref().map(|t| (t, dir)));
                    if case.name.starts_with("compensation")
                        && (theirs.refused.is_some() || theirs.steps.len() < 8)
                    {
                        comp_short.lock().unwrap().push(format!(
                            "{}: {} moves, {:?}",
                            case.name,
                            theirs.steps.len(),
                            theirs.refused
                        ));
                    }
                    let v = classify(&ours, &theirs);
                    if let (Verdict::Disagree(_), Some(keep)) =
                        (&v, std::env::var_os("MTWIN_RS274_KEEP"))
                    {
                        let to = Path::new(&keep).join(format!("case{i:05}.ngc"));
                        std::fs::write(to, &bytes).unwrap();
                    }
                    verdicts.lock().unwrap().push((i, v));
                }
            });
        }
    });
    let mut verdicts = verdicts.into_inner().unwrap();
    verdicts.sort_by_key(|v| v.0);

    let mut agree = 0;
    let mut agree_generated = 0;
    let mut agree_rotated = 0;
    let mut agree_comp = 0;
    let mut agree_lathe = 0;
    let mut agree_lathe_comp = 0;
    let mut unsupported: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut known: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    let mut disagreements = Vec::new();
    let mut flow_known_seen = vec![false; KNOWN_FLOW_DIFFERENCES.len()];
    for (i, v) in &verdicts {
        let name = &cases[*i].name;
        if let Verdict::Disagree(d) = v
            && let Some(k) = KNOWN_FLOW_DIFFERENCES
                .iter()
                .position(|(p, _)| name.starts_with(p))
        {
            flow_known_seen[k] = true;
            eprintln!("  known flow difference {name}: {d}");
            known
                .entry(KNOWN_FLOW_DIFFERENCES[k].1)
                .or_default()
                .push(name.clone());
            continue;
        }
        match v {
            Verdict::Agree => {
                agree += 1;
                agree_generated += usize::from(name.starts_with("generated"));
                agree_rotated += usize::from(name.starts_with("rotated"));
                agree_comp += usize::from(name.starts_with("compensation"));
                agree_lathe += usize::from(name.starts_with("lathe random seed"));
                agree_lathe_comp += usize::from(name.starts_with("lathe tool"));
            }
            Verdict::Known(why) => known.entry(why).or_default().push(name.clone()),
            Verdict::Unsupported(f) => unsupported.entry(f.clone()).or_default().push(name.clone()),
            Verdict::Disagree(d) => disagreements.push(format!("{name}: {d}")),
        }
    }
    for (k, seen) in flow_known_seen.iter().enumerate() {
        assert!(
            *seen,
            "KNOWN_FLOW_DIFFERENCES is out of date: {} agrees now",
            KNOWN_FLOW_DIFFERENCES[k].0
        );
    }
    let n_unsupported: usize = unsupported.values().map(Vec::len).sum();
    eprintln!(
        "rs274 differential: {} programs ({} generated, {} in rotated systems, {} of cutter \
         compensation, {} lathe, {} of lathe-tool compensation), {agree} agree \
         ({agree_generated} generated, {agree_rotated} rotated, {agree_comp} compensation, \
         {agree_lathe} lathe, {agree_lathe_comp} lathe tool), {n_unsupported} unsupported by \
         mtwin, {} disagreements",
        cases.len(),
        GENERATED,
        ROTATED,
        COMP,
        LATHE,
        LATHE_COMP,
        disagreements.len()
    );
    for (f, names) in &unsupported {
        eprintln!("  unsupported {f}: {} ({})", names.len(), names.join(", "));
    }
    for (why, names) in &known {
        eprintln!(
            "  known difference ({why}): {} ({})",
            names.len(),
            names.join(", ")
        );
    }
    for d in &disagreements {
        eprintln!("  DISAGREE {d}");
    }
    assert!(
        disagreements.is_empty(),
        "{} disagreements with rs274 (listed above); first: {}",
        disagreements.len(),
        disagreements[0]
    );
    assert!(
        agree_generated * 10 >= GENERATED as usize * 9,
        "too few generated programs agree: {agree_generated} of {GENERATED}"
    );
    // Programs in rotated systems agree, or mtwin refuses them for a G10
    // that changes the rotation of the active system (or G10 L20 in it)
    // under a G92 offset, where LinuxCNC's interpreter and motion disagree.
    let unsupported_rotated: usize = unsupported
        .iter()
        .filter(|(f, _)| f.contains("while a offset is in force"))
        .map(|(_, names)| names.iter().filter(|n| n.starts_with("rotated")).count())
        .sum();
    assert_eq!(
        agree_rotated + unsupported_rotated,
        ROTATED as usize,
        "programs in rotated systems that agree or are refused as documented"
    );
    let comp_short = comp_short.into_inner().unwrap();
    assert!(comp_short.is_empty(), "{}", comp_short.join("\n"));
    assert_eq!(
        agree_comp, COMP as usize,
        "every generated program of cutter compensation agrees"
    );
    assert_eq!(
        agree_lathe, LATHE as usize,
        "every generated lathe program (G7/G8) agrees"
    );
    assert_eq!(
        agree_lathe_comp, LATHE_COMP as usize,
        "every generated program of lathe-tool compensation agrees"
    );
    assert!(
        agree_rotated * 10 >= ROTATED as usize * 8,
        "too few programs in rotated systems agree: {agree_rotated} of {ROTATED}"
    );
}

/// What rs274's standalone canon does that LinuxCNC's controller does not,
/// and which [`generate_rotated`] therefore avoids: each program, the end
/// of its last move as mtwin runs it and as rs274 does (program X Y Z, mm;
/// hand-derived).
const RS274_QUIRKS: &[(&str, &str, [f64; 3], [f64; 3])] = &[
    (
        // Tool 2 is 0.1 in = 2.54 mm long: after G43 H2 the point at
        // machine Z 10 reads Z 7.46, and M6 keeps the offset in force.
        // rs274 re-reads the point its canon was last sent (Z 10).
        "a tool length offset changed before M6",
        "G21 G90\nT1 M6\nG0 X0 Y0 Z10\nG43 H2\nT1 M6\nG0 X5\nM2\n",
        [5.0, 0.0, 7.46],
        [5.0, 0.0, 10.0],
    ),
    (
        // Turning G54 by 90° makes machine (10, 0) read (0, -10); rs274
        // re-reads its canon's (10, 0) after M6.
        "a rotation changed before M6",
        "G21 G90\nT1 M6\nG0 X10 Y0 Z0\nG10 L2 P1 R90\nT1 M6\nG0 Z1\nM2\n",
        [0.0, -10.0, 1.0],
        [10.0, 0.0, 1.0],
    ),
    (
        // No tool loaded: G43 applies none in mtwin; rs274 starts with
        // pocket 1 current, so G10 L1 P1 also wrote its spindle entry and
        // G43 applies tool 1's new 0.5 mm.
        "no tool loaded, G10 L1 of tool 1, G43",
        "G21 G90\nG10 L1 P1 Z0.5\nG43\nG0 X1\nM2\n",
        [1.0, 0.0, 0.0],
        [1.0, 0.0, -0.5],
    ),
    (
        // M61 Q4 declares tool 4 (0.7 in = 17.78 mm) in the spindle; a G43
        // on a later line applies it in mtwin and the controller (its I/O
        // controller copies tool 4's entry into the spindle's). rs274's
        // canon only notes the pocket, its spindle entry keeps tool 2
        // (2.54 mm).
        "M61, then G43 on a later line",
        "G21 G90\nT2 M6\nM61 Q4\nG43\nG0 X1\nM2\n",
        [1.0, 0.0, -17.78],
        [1.0, 0.0, -2.54],
    ),
    (
        // G43.1 Z3 in mm at machine Z 0: the point reads Z -3 mm. At G20
        // the interpreter re-reads the offset from its canon: the
        // controller's answers 3 mm in inches (0.1181), rs274's the number
        // 3, now inches. After G49 the point reads 0 (mtwin, controller)
        // or 3 in - 3 mm = 2.8819 in (rs274); G91 Z0.1 then ends at 0.1 in
        // = 2.54 mm or 2.9819 in = 75.74 mm.
        "a G43.1 offset across G20, then G49",
        "G21 G90\nG43.1 Z3\nG20\nG49\nG91 G0 Z0.1\nG90\nM2\n",
        [0.0, 0.0, 2.54],
        [0.0, 0.0, 75.74],
    ),
];

#[test]
fn rs274_standalone_quirks_the_generator_avoids() {
    let Some(setup) = setup() else { return };
    let work = setup.root.join("quirks");
    std::fs::create_dir(&work).unwrap();
    for (k, (name, program, ours_end, theirs_end)) in RS274_QUIRKS.iter().enumerate() {
        let (ours, theirs) = run_both(&setup, &work, format!("quirk{k}.ngc"), program);
        assert!(theirs.refused.is_none() && ours.refused.is_none(), "{name}");
        for (who, outcome, want) in [("mtwin", &ours, ours_end), ("rs274", &theirs, theirs_end)] {
            let Some(Step::Move { end, .. }) = outcome.steps.last() else {
                panic!("{name}: {who} made no move");
            };
            for i in 0..3 {
                assert!(
                    (end[i] - want[i]).abs() < 1e-3,
                    "{name}: {who} ends at {end:?}, expected {want:?}"
                );
            }
        }
        // With the remedy the generators use (a tool loaded first, a move
        // to X Y Z right before M6, G43 with the tool's H after M61, G49
        // before a change of units) the two agree.
        let fixed = program
            .replace("G21 G90\n", "G21 G90\nT1 M6\n")
            .replace("T1 M6\nG0 X5", "G0 X0 Y0 Z10\nT1 M6\nG0 X5")
            .replace("R90\nT1 M6", "R90\nG0 X0 Y-10 Z0\nT1 M6")
            .replace("M61 Q4\nG43\n", "M61 Q4\nG43 H4\n")
            .replace("G20\nG49\n", "G49\nG20\n");
        let (ours, theirs) = run_both(&setup, &work, format!("fixed{k}.ngc"), &fixed);
        assert!(
            matches!(classify(&ours, &theirs), Verdict::Agree),
            "{name}: with the remedy, {fixed:?}: {:?}",
            first_difference(&ours.steps, &theirs.steps)
        );
    }
}

/// M61 where rs274's canon habit (its spindle entry not loaded by M61)
/// does not decide: G43 on the M61 line (the new tool's entry; with Q0, or
/// with H0, the spindle's entry, still the tool loaded before), G43 with
/// the tool's H on a later line, M6 after M61 (the tool T selected), Q
/// rounded to the nearest integer, in G20 too; and the refusals (no Q,
/// Q < 0, a tool not in the table, M61 beside M6). `G53 G0 Z0` then ends at
/// program Z = -(the offset applied): tools 1, 2, 4 are 0, 2.54 and 17.78
/// mm long. Each must agree with rs274 and end at the hand-derived point
/// (X Y Z, mm).
const M61_CASES: &[(&str, Option<[f64; 3]>)] = &[
    (
        "G21\nT1 M6\nG0 X1 Y2 Z3\nM61 Q4 G43\nG53 G0 Z0\n",
        Some([1.0, 2.0, -17.78]),
    ),
    (
        "G21\nT2 M6\nG0 X1 Y2 Z3\nM61 Q0 G43\nG53 G0 Z0\n",
        Some([1.0, 2.0, -2.54]),
    ),
    (
        "G21\nT2 M6\nG0 X1 Y2 Z3\nM61 Q4 G43 H0\nG53 G0 Z0\n",
        Some([1.0, 2.0, -2.54]),
    ),
    (
        "G21\nT1 M6\nG0 X1 Y2 Z3\nM61 Q2\nG43 H2\nG53 G0 Z0\n",
        Some([1.0, 2.0, -2.54]),
    ),
    (
        "G21\nT1 M6\nG0 X1 Y2 Z3\nM61 Q4\nG0 X1 Y2 Z3\nM6\nG43\nG53 G0 Z0\n",
        Some([1.0, 2.0, 0.0]),
    ),
    (
        "G21\nT4 M6\nG0 X1 Y2 Z3\nM61 Q1.6 G43\nG53 G0 Z0\n",
        Some([1.0, 2.0, -2.54]),
    ),
    (
        "G20\nT1 M6\nG0 X1 Y2 Z3\nM61 Q4 G43\nG53 G0 Z0\n",
        Some([25.4, 50.8, -17.78]),
    ),
    ("G21\nM61\n", None),
    ("G21\nM61 Q-1\n", None),
    ("G21\nM61 Q3\n", None),
    ("G21\nM61 Q2 M6\n", None),
];

#[test]
fn m61_agrees_with_rs274() {
    let Some(setup) = setup() else { return };
    let work = setup.root.join("m61");
    std::fs::create_dir(&work).unwrap();
    for (k, (body, want)) in M61_CASES.iter().enumerate() {
        let program = format!("G90 G17\n{body}M2\n");
        let (ours, theirs) = run_both(&setup, &work, format!("m61-{k}.ngc"), &program);
        assert!(
            matches!(classify(&ours, &theirs), Verdict::Agree),
            "{program:?}: {:?} / {:?}: {:?}",
            ours.refused,
            theirs.refused,
            first_difference(&ours.steps, &theirs.steps)
        );
        match want {
            None => assert!(ours.refused.is_some(), "{program:?} must be refused"),
            Some(w) => {
                let Some(Step::Move { end, .. }) = ours.steps.last() else {
                    panic!("{program:?}: no move");
                };
                for i in 0..3 {
                    assert!(
                        (end[i] - w[i]).abs() < 1e-9,
                        "{program:?}: {end:?}, expected {w:?}"
                    );
                }
            }
        }
    }
}

/// What LinuxCNC's controller does where rs274's standalone canon differs
/// (see [`RS274_QUIRKS`]), run on LinuxCNC 2.9's simulator (machine
/// coordinates, its tool table: tool 1 Z0, tool 2 Z15 mm), and mtwin the
/// same: after `M61 Q2` a G43 applies tool 2 and #5400 reads 2 (the rest at
/// machine X 2, Z 15); a G43.1 Z3 offset set in mm keeps its 3 mm across
/// G20, so after G49 `G91 G0 Z0.1` ends at machine Z 2.54 (rs274's number
/// kept would give 75.74).
#[test]
fn the_controller_runs_m61_and_g43_1_across_units_as_mtwin() {
    if !crate::linuxcnc_sim::available() {
        return;
    }
    let head = "G21 G90 G17\nG10 L2 P1 X0 Y0 Z0 R0\nG54 G92.1 G49\nG0 X0 Y0 Z0\n";
    let programs = [
        (
            "m61",
            format!("{head}T1 M6\nM61 Q2\nG43\nG0 X#5400 Y0 Z0\nG49\nG0 X0 Y0 Z0\nM2\n"),
            [2.0, 15.0],
        ),
        (
            "g43.1-g20",
            format!("{head}G43.1 Z3\nG20\nG49\nG91 G0 Z0.1\nG90 G21\nM2\n"),
            [0.0, 2.54],
        ),
    ];
    let mut opts = InterpOptions::default();
    opts.tools = [(1, 0.0), (2, 15.0)].into_iter().collect();
    for (name, program, [x, z]) in programs {
        let t = crate::linuxcnc_sim::run_or_panic(
            name,
            &program,
            &crate::linuxcnc_sim::SimSetup::default(),
            crate::linuxcnc_sim::SHORT,
        );
        let highest = t
            .samples
            .iter()
            .map(|s| s.world)
            .fold([f64::MIN; 5], |a, w| {
                std::array::from_fn(|i| a[i].max(w[i]))
            });
        assert!(
            (highest[0] - x).abs() < 1e-6 && (highest[2] - z).abs() < 1e-6,
            "{name}: the simulator reached X {} Z {}, expected X {x} Z {z}",
            highest[0],
            highest[2]
        );
        let mut ours = [f64::MIN; 3];
        gcode::interpret(program.as_bytes(), opts.clone(), |_, events| {
            for e in events {
                if let EventKind::Traverse(m) = &e.kind {
                    let machine = m.to.add(&m.offset);
                    for (o, v) in ours.iter_mut().zip(&machine.0) {
                        *o = o.max(*v);
                    }
                }
            }
            Ok(())
        })
        .unwrap();
        assert!(
            (ours[0] - x).abs() < 1e-9 && (ours[2] - z).abs() < 1e-9,
            "{name}: mtwin reached {ours:?}, expected X {x} Z {z}"
        );
    }
}

/// Moves computed from the system parameters LinuxCNC keeps (current point
/// #5420–#5422 and `#<_x>`, in program units; coordinate system #5220;
/// tool #5400) agree with rs274's. The ends are derived by hand: G55 at
/// X5 Y3 Z8 gives X6 Y6 Z6 (#5220 = 2), then X6 + tool 2 = 8 and Y 6 − 1;
/// after G92 X0 Y0 the point reads 0 0, so X1 Y2; in G20 X reads
/// 1/25.4 in, and X[#5420+0.1] is 0.1 in + 1 mm = 3.54 mm.
#[test]
fn system_parameters_agree_with_rs274() {
    let Some(setup) = setup() else { return };
    let work = setup.root.join("sysparams");
    std::fs::create_dir(&work).unwrap();
    let program = "G21 G90 G17\nG0 X0 Y0 Z10\nT2 M6\nG0 X0 Y0 Z10\nG55\nG0 X5 Y3 Z8\n\
                   G1 F100 X[#5420+1] Y[#5421*2] Z[#5422-#5220]\nG0 X[#<_x>+#5400] Y[#5421-1]\n\
                   G92 X0 Y0\nG0 X[#5420+1] Y[#5421+2]\nG20\nG0 X[#5420+0.1]\nM2\n";
    let (ours, theirs) = run_both(&setup, &work, "sysparams.ngc", program);
    assert!(
        matches!(classify(&ours, &theirs), Verdict::Agree),
        "{:?} / {:?}: {:?}",
        ours.refused,
        theirs.refused,
        first_difference(&ours.steps, &theirs.steps)
    );
    let ends: Vec<[f64; 6]> = ours
        .steps
        .iter()
        .filter_map(|s| match s {
            Step::Move { end, .. } => Some(*end),
            Step::Dwell(_) => None,
        })
        .collect();
    let want: [[f64; 3]; 4] = [
        [6.0, 6.0, 6.0],
        [8.0, 5.0, 6.0],
        [1.0, 2.0, 6.0],
        [3.54, 2.0, 6.0],
    ];
    let got = &ends[ends.len() - 4..];
    for (g, w) in got.iter().zip(want) {
        for i in 0..3 {
            assert!((g[i] - w[i]).abs() < 1e-9, "{got:?} vs {want:?}");
        }
    }
}

#[test]
fn canon_parser_reads_units_feeds_and_arcs() {
    // Hand-written rs274 output: inch, a feed, an arc and a dwell.
    let text = "    1 N..... USE_LENGTH_UNITS(CANON_UNITS_INCHES)\n\
                \x20   2 N..... SET_FEED_RATE(10.0000)\n\
                \x20   3 N0010  STRAIGHT_FEED(1.0000, 2.0000, 0.5000, 90.0000, 0.0000, 0.0000)\n\
                \x20   4 N..... ARC_FEED(2.0000, 0.0000, 1.0000, 0.0000, -1, 0.5000, 0.0000, 0.0000, 0.0000)\n\
                \x20   5 N..... DWELL(1.5000)\n";
    let steps = parse_canon(text);
    assert_eq!(
        steps,
        vec![
            Step::Move {
                kind: "feed",
                end: [25.4, 50.8, 12.7, 90.0, 0.0, 0.0],
                arc: None,
                feed: Some(254.0),
                scale: 25.4,
            },
            Step::Move {
                kind: "arc",
                end: [50.8, 0.0, 12.7, 0.0, 0.0, 0.0],
                arc: Some(([25.4, 0.0], -1)),
                feed: Some(254.0),
                scale: 25.4,
            },
            Step::Dwell(1.5),
        ]
    );
}

#[test]
fn generated_programs_are_reproducible_and_varied() {
    assert_eq!(generate(SEED), generate(SEED));
    assert_ne!(generate(SEED), generate(SEED + 1));
    // Over many seeds every feature shows up.
    let text: String = (0..200).map(|k| generate(SEED + k)).collect();
    for needle in [
        "G0 ", "G1 ", "G2 ", "G3 ", " R", " I", " K", " P", "G18", "G19", "G20", "G91\n", "G90.1",
        "G55", "G59.3", "G53 ", "G93", "G95", "G4 P", "/", "N10 ", ";", "M30", "M2\n", "G33 ",
        "G33.1 ", "G76 ", " Q", " H-1", " E", " L3", " @", " ^", "G1 @", "G0 @",
    ] {
        assert!(text.contains(needle), "no {needle:?} in 200 programs");
    }
    let text: String = (0..ROTATED)
        .map(|k| generate_rotated(ROTATED_SEED + k))
        .collect();
    for needle in [
        "G10 L2 P",
        "G10 L20 P",
        "G92 X",
        "G92.1",
        "G28",
        "G53 G0",
        "G10 L10 P",
        "G10 L11 P",
        "M6\n",
        "G43\n",
        "G43 H0",
        "G43 H4",
        "G49",
        "M61 Q0\n",
        "M61 Q4\n",
        "M61 Q2 G43\n",
        "M61 Q0 G43\n",
    ] {
        assert!(
            text.contains(needle),
            "no {needle:?} in the rotated programs"
        );
    }
    assert_eq!(generate_comp(COMP_SEED), generate_comp(COMP_SEED));
    let text: String = (0..COMP).map(|k| generate_comp(COMP_SEED + k)).collect();
    for needle in [
        "G41 D", "G42 D", "G41.1 D", "G42.1 D", "G41\n", "G42\n", "M6", "G18", "G20", "G91\n",
        "G2 ", "G3 ", "G40\n", "G40 G1", "G40 G0",
    ] {
        assert!(
            text.contains(needle),
            "no {needle:?} in the compensation programs"
        );
    }
}

/// Hand-written programs of cutter radius compensation (G40, G41, G42,
/// G41.1, G42.1): each must agree with rs274 (same moves, or refused by
/// both after the same moves) and none may be unsupported.
const CUTTER_COMP_PROGRAMS: &[(&str, &str)] = &[
    (
        "square pocket, tool inside (G41.1, counter-clockwise)",
        "G21 G17 G90 G94\nG0 X0 Y0 Z5\nG1 Z-1 F200\nG41.1 D6\nG1 X20 Y0\nX20 Y20\nX0 Y20\nX0 Y0\nX20 Y0\nG40\nG1 X10 Y10\nG0 Z5\nM2\n",
    ),
    (
        "square, tool outside (G42.1, counter-clockwise): arcs at the corners",
        "G21 G17 G90 G94 F300\nG0 X-10 Y-10\nG42.1 D6\nG1 X0 Y0\nX20\nY20\nX0\nY0\nG40 G0 X-10 Y-10\nM30\n",
    ),
    (
        "profile with arcs both ways, tool from the table (G41 D2)",
        "G20 G17 G90 G94 F20\nG0 X-1 Y-1\nG41 D2\nG1 X0 Y0\nG1 X2 Y0\nG3 X4 Y2 R2\nG2 X6 Y4 I2 J0\nG1 X6 Y6\nG3 X2 Y6 I-2 J0\nG1 X0 Y4\nG1 X0 Y0\nG40\nG1 X-1 Y-1\nM2\n",
    ),
    (
        "tool in the spindle (T4 M6, G42 without D), incremental moves",
        "G21 G17 G90 G94 F500\nT4 M6\nG0 X0 Y0\nG42\nG91 G1 X30 Y0\nY25\nX-30\nG90 G1 X0 Y0\nG40 G1 X-5\nM2\n",
    ),
    (
        "arc entry, helix, Z moves and a bare G1 during compensation",
        "G21 G17 G90 G94 F400\nG0 X0 Y0 Z2\nG41.1 D5\nG3 X20 Y0 R10\nG1 Z-2\nG1\nG1 X20 Y20\nG2 X40 Y20 Z-3 I10 J0\nG1 X40 Y0\nG4 P0.5\nG40\nG0 X50 Y-10\nM2\n",
    ),
    (
        "XZ plane (G18) profile with a negative diameter (side switched)",
        "G21 G18 G90 G94 F200\nG0 X0 Z0\nG41.1 D-4\nG1 Z10 X0\nG1 Z10 X10\nG2 Z20 X20 K10 I0\nG1 Z30 X20\nG40\nG1 Z40 X30\nM2\n",
    ),
    (
        "inverse time feed with compensation (the programmed time)",
        "G20 G17 G90\nG0 X0 Y0\nG42.1 D0.8\nG93 G1 X1 F30\nY1 F20\nX-1 F20\nG3 X-1 Y2 J0.5 F10\nG94 G40 G1 X0 Y3 F25\nM2\n",
    ),
    (
        "M0 with compensation on, then an inside corner",
        "G21 G17 G90 G94 F300\nG0 X0 Y0\nG41.1 D4\nG1 X10 Y0\nM0\nG1 X10 Y10\nX0 Y10\nG40 G1 X-5 Y-5\nM2\n",
    ),
    (
        "error: a notch narrower than the tool (gouging)",
        "G21 G17 G90 G94 F300\nG0 X0 Y0\nG41.1 D10\nG1 X20 Y0\nX20 Y2\nX22 Y2\nX22 Y0\nX40 Y0\nG40 G1 X50 Y-10\nM2\n",
    ),
    (
        "error: an inside arc smaller than the tool",
        "G21 G17 G90 G94 F300\nG0 X0 Y0\nG41.1 D10\nG1 X10 Y0\nG3 X10 Y6 R3\nG40 G1 X0 Y0\nM2\n",
    ),
    (
        "error: plane change with compensation on",
        "G21 G17 G90 G94 F300\nG0 X0 Y0\nG41.1 D2\nG1 X10 Y0\nG18\nG40\nM2\n",
    ),
    (
        "error: entry move not longer than the radius",
        "G21 G17 G90 G94 F300\nG0 X0 Y0\nG41.1 D10\nG1 X3 Y0\nG40\nM2\n",
    ),
    (
        "error: an arc just after G40",
        "G21 G17 G90 G94 F300\nG0 X0 Y0\nG41.1 D2\nG1 X10 Y0\nG40\nG2 X20 Y0 R5\nM2\n",
    ),
];

#[test]
fn cutter_compensation_agrees_with_rs274() {
    let Some(setup) = setup() else { return };
    let work = setup.root.join("comp");
    std::fs::create_dir(&work).unwrap();
    let mut failures = Vec::new();
    let mut refused_by_both = 0;
    for (k, (name, program)) in CUTTER_COMP_PROGRAMS.iter().enumerate() {
        let (ours, theirs) = run_both(&setup, &work, format!("comp{k}.ngc"), program);
        // Each program makes compensated moves before its end.
        assert!(
            name.starts_with("error") || theirs.steps.len() >= 4,
            "{name}: rs274 made {} moves ({:?})",
            theirs.steps.len(),
            theirs.refused
        );
        refused_by_both += usize::from(ours.refused.is_some() && theirs.refused.is_some());
        match classify(&ours, &theirs) {
            Verdict::Agree => {}
            Verdict::Known(why) => failures.push(format!("{name}: known difference {why}")),
            Verdict::Unsupported(f) => failures.push(format!("{name}: unsupported {f}")),
            Verdict::Disagree(d) => failures.push(format!("{name}: {d}")),
        }
        if name.starts_with("error") {
            assert!(
                ours.refused.is_some(),
                "{name}: mtwin accepts it ({:?})",
                theirs.refused
            );
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!(
        refused_by_both, 5,
        "the five error cases are refused by both"
    );
}

// ---------------------------------------------------------------------------
// Lathe diameter mode (G7/G8).

/// Number of generated lathe programs in diameter and radius mode
/// ([`generate_lathe`]).
const LATHE: u64 = 150;
/// Seed of the first of them.
const LATHE_SEED: u64 = 0x1a7e_2026;

/// What [`generate_lathe`] knows of its program: positions and offsets in
/// mm along X (radius) and Z.
struct LatheGen {
    rng: Rng,
    lines: Vec<String>,
    inch: bool,
    incremental: bool,
    arc_absolute: bool,
    diameter: bool,
    spindle: bool,
    /// Machine X Z, mm.
    machine: [f64; 2],
    /// G54 (G10 L20), G92 and G43.1 offsets, X Z, mm.
    g54: [f64; 2],
    g92: [f64; 2],
    tool: [f64; 2],
}

impl LatheGen {
    fn scale(&self) -> f64 {
        if self.inch { 25.4 } else { 1.0 }
    }
    /// The program X (radius) and Z, mm.
    fn program(&self) -> [f64; 2] {
        std::array::from_fn(|i| self.machine[i] - self.g54[i] - self.g92[i] - self.tool[i])
    }
    /// Factor of axis `i`'s word: 2 for X in diameter mode.
    fn word_factor(&self, i: usize) -> f64 {
        if i == 0 && self.diameter { 2.0 } else { 1.0 }
    }
    /// A length word for `v` mm along axis `i` (0 X, 1 Z), and the mm it
    /// reads as: 4 decimals, a diameter 3 (so that the radius has the 4
    /// decimals rs274 prints, and its rounding is not a difference).
    fn word(&self, i: usize, v: f64) -> (String, f64) {
        let f = self.word_factor(i);
        let w = if f == 2.0 {
            (v / self.scale() * f * 1e3).round() / 1e3
        } else {
            r4(v / self.scale())
        };
        (num(w), w / self.word_factor(i) * self.scale())
    }
    /// A G7 or G8 now and then (on the next block's line), switching the
    /// mode for that block's words.
    fn mode_prefix(&mut self, p: f64) -> String {
        if !self.rng.chance(p) {
            return String::new();
        }
        self.diameter = self.rng.chance(0.5);
        if self.diameter { "G7 " } else { "G8 " }.into()
    }
    /// End words of a straight move to a random point (some axes), updating
    /// the machine position.
    fn move_words(&mut self) -> String {
        let mut s = String::new();
        let both = self.rng.chance(0.5);
        let x_axis = both || self.rng.chance(0.5);
        for (i, letter) in [(0, 'X'), (1, 'Z')] {
            if (i == 0 && !x_axis) || (i == 1 && !both && x_axis) {
                continue;
            }
            let span = if i == 0 { 40.0 } else { 80.0 };
            let target = (self.rng.below(20001) as f64 / 10000.0 - 0.5) * span;
            let start = self.program()[i];
            let (w, read) = if self.incremental {
                self.word(i, target - start)
            } else {
                self.word(i, target)
            };
            let end = if self.incremental { start + read } else { read };
            self.machine[i] += end - start;
            write!(s, " {letter}{w}").unwrap();
        }
        s
    }
}

/// G2/G3 in G18 from the current point: centre by I K (incremental or,
/// after G90.1, absolute; never halved) or by R; end words X (diameter in
/// G7) and Z.
fn lathe_arc(g: &mut LatheGen) {
    let t = *g.rng.pick(TRIPLES);
    let k = *g.rng.pick(&[0.5, 1.0, 2.0]);
    // Z and X components (the plane's first axis is Z).
    let to_c = triple_vector(&mut g.rng, t);
    let mut to_e = triple_vector(&mut g.rng, t);
    // No full circle; no half circle either (R would be half the chord,
    // which the rounding of the words can make too short).
    if to_e == [-to_c[0], -to_c[1]] || to_e == to_c {
        to_e = [-to_c[1], to_c[0]];
    }
    let start = g.program();
    let center = [start[0] + to_c[1] * k, start[1] + to_c[0] * k];
    let end = [center[0] + to_e[1] * k, center[1] + to_e[0] * k];
    let prefix = g.mode_prefix(0.25);
    let mut s = format!("{prefix}{}", if g.rng.chance(0.5) { "G2" } else { "G3" });
    let mut read = [0.0; 2];
    for (i, letter) in [(0, 'X'), (1, 'Z')] {
        let (w, r) = if g.incremental {
            g.word(i, end[i] - start[i])
        } else {
            g.word(i, end[i])
        };
        read[i] = if g.incremental { start[i] + r } else { r };
        write!(s, " {letter}{w}").unwrap();
    }
    if g.rng.chance(0.3) {
        let r = t.2 * k / g.scale();
        write!(s, " R{}", num(if g.rng.chance(0.5) { r } else { -r })).unwrap();
    } else {
        for (i, letter) in [(0, 'I'), (1, 'K')] {
            let v = if g.arc_absolute {
                center[i]
            } else {
                center[i] - start[i]
            };
            write!(s, " {letter}{}", num(v / g.scale())).unwrap();
        }
    }
    g.emit_move(s, read);
}

impl LatheGen {
    fn emit_move(&mut self, s: String, end: [f64; 2]) {
        let p = self.program();
        for i in 0..2 {
            self.machine[i] += end[i] - p[i];
        }
        self.lines.push(s);
    }
}

/// Program `seed` on a lathe in G18, X a radius or, after G7, a diameter:
/// traverses and feeds in X and Z, arcs by I K (incremental or G90.1) or by
/// R, G7 and G8 alone or on the line of a move, a thread or an offset,
/// G90/G91, G20/G21, G92 X Z and G92.1, G10 L20 P1 X Z, G43.1 X Z and G49,
/// G53 G0 X, G33 and G76 threads (the spindle started first).
fn generate_lathe(seed: u64) -> String {
    let mut g = LatheGen {
        rng: Rng(seed),
        lines: vec!["G18 G21 G90 G94 G54 G91.1 F200".into()],
        inch: false,
        incremental: false,
        arc_absolute: false,
        diameter: false,
        spindle: false,
        machine: [0.0; 2],
        g54: [0.0; 2],
        g92: [0.0; 2],
        tool: [0.0; 2],
    };
    if g.rng.chance(0.7) {
        g.diameter = true;
        g.lines.push("G7".into());
    }
    let n = 8 + g.rng.below(30);
    for _ in 0..n {
        match g.rng.below(20) {
            0..=4 => {
                let prefix = g.mode_prefix(0.2);
                let code = if g.rng.chance(0.4) { "G0" } else { "G1" };
                let w = g.move_words();
                g.lines.push(format!("{prefix}{code}{w}"));
            }
            5..=7 => lathe_arc(&mut g),
            8 | 9 => {
                g.diameter = g.rng.chance(0.5);
                g.lines.push(if g.diameter { "G7" } else { "G8" }.into());
            }
            10 => {
                g.incremental = g.rng.chance(0.5);
                g.lines
                    .push(if g.incremental { "G91" } else { "G90" }.into());
            }
            11 => {
                g.arc_absolute = g.rng.chance(0.5);
                g.lines
                    .push(if g.arc_absolute { "G90.1" } else { "G91.1" }.into());
            }
            12 => {
                // rs274's standalone canon keeps a G43.1 offset's number
                // through a change of units (3 mm become 3 in; LinuxCNC's
                // controller and mtwin keep the length, see
                // RS274_QUIRKS): cancelled first.
                if g.tool != [0.0; 2] {
                    g.tool = [0.0; 2];
                    g.lines.push("G49".into());
                }
                g.inch = g.rng.chance(0.5);
                g.lines.push(format!(
                    "{} F{}",
                    if g.inch { "G20" } else { "G21" },
                    if g.inch { 8 } else { 200 }
                ));
            }
            13 => {
                // G92 X Z: the current point reads the words.
                let prefix = g.mode_prefix(0.3);
                let v1 = g.rng.below(4001) as f64 / 100.0 - 20.0;
                let (wx, rx) = g.word(0, v1);
                let v2 = g.rng.below(4001) as f64 / 100.0 - 20.0;
                let (wz, rz) = g.word(1, v2);
                let p = g.program();
                g.g92[0] += p[0] - rx;
                g.g92[1] += p[1] - rz;
                g.lines.push(format!("{prefix}G92 X{wx} Z{wz}"));
            }
            14 => {
                g.g92 = [0.0; 2];
                g.lines.push("G92.1".into());
            }
            15 => {
                // G10 L20 P1 X: G54 such that the current point reads X.
                let prefix = g.mode_prefix(0.3);
                let v3 = g.rng.below(4001) as f64 / 100.0 - 20.0;
                let (wx, rx) = g.word(0, v3);
                let p = g.program();
                g.g54[0] += p[0] - rx;
                g.lines.push(format!("{prefix}G10 L20 P1 X{wx}"));
            }
            16 => {
                if g.rng.chance(0.5) {
                    let v4 = *g.rng.pick(&[-2.0, 1.0, 3.0]);
                    let (wx, rx) = g.word(0, v4);
                    let v5 = *g.rng.pick(&[-1.0, 5.0]);
                    let (wz, rz) = g.word(1, v5);
                    g.tool = [rx, rz];
                    g.lines.push(format!("G43.1 X{wx} Z{wz}"));
                } else {
                    g.tool = [0.0; 2];
                    g.lines.push("G49".into());
                }
            }
            17 => {
                // G53 G0 X (machine coordinates; G90 only).
                if g.incremental {
                    g.incremental = false;
                    g.lines.push("G90".into());
                }
                let v6 = g.rng.below(8001) as f64 / 100.0 - 40.0;
                let (wx, rx) = g.word(0, v6);
                g.machine[0] = rx;
                g.lines.push(format!("G53 G0 X{wx}"));
            }
            _ => {
                if !g.spindle {
                    g.lines.push("S600 M3".into());
                    g.spindle = true;
                }
                let prefix = g.mode_prefix(0.4);
                let u = 1.0 / g.scale();
                let pitch = *g.rng.pick(&[1.0, 1.5, 2.0]) * u;
                // Z along the thread (and X now and then), from here.
                let start = g.program();
                let len = *g.rng.pick(&[-12.0, -6.0, 8.0]);
                let (wz, rz) = if g.incremental {
                    g.word(1, len)
                } else {
                    g.word(1, start[1] + len)
                };
                let z_end = if g.incremental { start[1] + rz } else { rz };
                if g.rng.chance(0.3) {
                    let (wx, rx) = if g.incremental {
                        g.word(0, -1.0)
                    } else {
                        g.word(0, start[0] - 1.0)
                    };
                    let x_end = if g.incremental { start[0] + rx } else { rx };
                    let k = *g.rng.pick(&[1.0, 2.0]) * u;
                    g.emit_move(
                        format!("{prefix}G33 X{wx} Z{wz} K{}", num(k)),
                        [x_end, z_end],
                    );
                } else {
                    let i = *g.rng.pick(&[-2.0, -1.0, 1.5]) * u;
                    let j = *g.rng.pick(&[0.1, 0.2]) * u;
                    let k = j * (2 + g.rng.below(6)) as f64;
                    g.emit_move(
                        format!(
                            "{prefix}G76 P{} Z{wz} I{} J{} K{}",
                            num(pitch),
                            num(i),
                            num(j),
                            num(k)
                        ),
                        [start[0], z_end],
                    );
                }
            }
        }
    }
    g.lines.push("M2".into());
    let mut s = g.lines.join("\n");
    s.push('\n');
    s
}

/// Hand-written programs of diameter mode, each run by both interpreters.
const LATHE_PROGRAMS: &[(&str, &str)] = &[
    (
        "X of moves, G91, G53, arcs by I K and R (centre words as written)",
        "G21 G18 G90 G94 F100\nG0 X10 Z0\nG7\nG0 X10 Z0\nG1 X20 Z-5\nG91 G1 X4 Z-1\nG90\n\
         G0 X24 Z-6\nG2 X24 Z-14 I8 K-4\nG0 X24 Z-6\nG90.1 G2 X24 Z-14 I20 K-10\nG91.1\n\
         G2 X24 Z-6 R5\nG53 G0 X40\nM2\n",
    ),
    (
        "G7 and G8 on the line of the move",
        "G21 G18 G90 G94 F100\nG0 X10 Z0\nG7 X60\nG8 X60\nG7\nG8 G1 X60 Z-2\nG7 G1 X60 Z-4\nM2\n",
    ),
    (
        "G92, G10 L20, G10 L2, G43.1 read X as a diameter",
        "G21 G18 G90 G94 F100\nG7\nG0 X44 Z-6\nG92 X10\nG0 X24\nG92.1\nG10 L20 P1 X10\nG0 X28\n\
         G10 L2 P1 X10\nG0 X32\nG10 L2 P1 X0\nG43.1 X2\nG0 X36\nG49\nG0 X40\nM2\n",
    ),
    (
        "G76 in G7, and with G7 or G8 on its line",
        "G21 G18 G90 G94 F100\nG0 X10 Z0\nS500 M3\nG7\nG76 P1 Z-10 I-2 J0.2 K1\nG0 X20 Z0\n\
         G8 G76 P1 Z-10 I-2 J0.2 K1\nG0 X10 Z0\nG7 G76 P1 Z-10 I-2 J0.2 K1\nG0 X20 Z0\n\
         G8\nG7 G76 P1 Z-10 I-2 J0.2 K1 X30\nM2\n",
    ),
    (
        "G33 and G28 in G7, inch",
        "G20 G18 G90 G94 F10\nG7\nG0 X2 Z0.5\nS300 M3\nG33 X1.8 Z-1 K0.05\nG28 X1\nM2\n",
    ),
    (
        "error: G7 and G8 on one line",
        "G21 G18 G90 G94 F100\nG0 X10 Z0\nG7 G8 X60\nM2\n",
    ),
];

#[test]
fn lathe_diameter_mode_agrees_with_rs274() {
    let Some(setup) = setup() else { return };
    let work = setup.root.join("lathe");
    std::fs::create_dir(&work).unwrap();
    let mut failures = Vec::new();
    for (k, (name, program)) in LATHE_PROGRAMS.iter().enumerate() {
        let (ours, theirs) = run_both(&setup, &work, format!("lathe{k}.ngc"), program);
        assert!(
            name.starts_with("error") || (theirs.refused.is_none() && theirs.steps.len() >= 3),
            "{name}: rs274 made {} moves ({:?})",
            theirs.steps.len(),
            theirs.refused
        );
        if name.starts_with("error") {
            assert!(ours.refused.is_some() && theirs.refused.is_some(), "{name}");
        }
        match classify(&ours, &theirs) {
            Verdict::Agree => {}
            Verdict::Known(why) => failures.push(format!("{name}: known difference {why}")),
            Verdict::Unsupported(f) => failures.push(format!("{name}: unsupported {f}")),
            Verdict::Disagree(d) => failures.push(format!("{name}: {d}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn generated_lathe_programs_are_reproducible_and_switch_modes() {
    // Every program of the lathe generator is run by rs274 (the bulk in
    // the differential test); here: they are reproducible, use G7 and G8
    // and put X words where diameter mode halves them.
    let programs: Vec<String> = (0..LATHE).map(|k| generate_lathe(LATHE_SEED + k)).collect();
    assert_eq!(programs[3], generate_lathe(LATHE_SEED + 3));
    let count = |p: &str| programs.iter().filter(|t| t.contains(p)).count();
    for p in [
        "G7\n", "G8\n", "G7 G1", "G7 G76", "G8 G76", "G92 X", "G10 L20", "G43.1", "G53 G0",
        "G90.1", "G20", " R",
    ] {
        assert!(count(p) >= 3, "{p:?} in only {} lathe programs", count(p));
    }
}

// ---------------------------------------------------------------------------
// Lathe tools: cutter compensation of a tool with an orientation.

/// Lathe tools in the shared tool table: tool `LATHE_TOOL_BASE + o` has
/// orientation `o` (0–9), no length, this nose diameter (inch).
const LATHE_TOOL_BASE: u32 = 20;
const LATHE_TOOL_DIAMETER: f64 = 0.04;

fn lathe_tool_lines() -> String {
    (0..10)
        .map(|o| {
            let t = LATHE_TOOL_BASE + o;
            format!("T{t} P{t} D{LATHE_TOOL_DIAMETER} Q{o}\n")
        })
        .collect()
}

fn add_lathe_tools(opts: &mut InterpOptions) {
    for o in 0..10u8 {
        let t = LATHE_TOOL_BASE + u32::from(o);
        let tool = opts.tools.entry(t);
        tool.diameter = LATHE_TOOL_DIAMETER * 25.4;
        tool.orientation = o;
    }
}

/// Number of generated programs of lathe-tool compensation
/// ([`generate_lathe_comp`]).
const LATHE_COMP: u64 = 60;
/// Seed of the first of them.
const LATHE_COMP_SEED: u64 = 0x10c0_2026;

/// Program `seed` of cutter compensation with a lathe tool: a G18 program
/// of [`generate_comp`] (the first of seeds `seed·1000 + j` that is in
/// G18), its tool made a lathe tool of orientation 0–9 (G41.1/G42.1 get an
/// `L` word; a tool number of the table, in `D` or in the spindle, becomes
/// the lathe tool of that orientation, whose nose is smaller than the
/// polygon's tool, so that nothing gouges).
fn generate_lathe_comp(seed: u64) -> String {
    let mut rng = Rng(seed);
    let o = rng.below(10) as u32;
    let program = (0..)
        .map(|j| generate_comp(seed.wrapping_mul(1000).wrapping_add(j)))
        .find(|p| p.contains("G18"))
        .unwrap();
    let t = LATHE_TOOL_BASE + o;
    let mut out = String::new();
    for line in program.lines() {
        let l = if line.starts_with("G41.1") || line.starts_with("G42.1") {
            format!("{line} L{o}")
        } else if line.starts_with("G41 D") || line.starts_with("G42 D") {
            format!("{} D{t}", &line[..3])
        } else if line.starts_with('T') && line.ends_with("M6") {
            format!("T{t} M6")
        } else {
            line.to_string()
        };
        out.push_str(&l);
        out.push('\n');
    }
    out
}

/// Hand-written programs of lathe-tool compensation, each run by both.
fn lathe_comp_programs() -> Vec<(String, String)> {
    let profile = "G0 X20 Z5\nG1 X10 Z0\nG1 Z-10\nG1 X15 Z-15\nG2 X20 Z-20 R5\nG1 X25\nG40\nG1 X30 Z-25\nM2\n";
    let mut v = Vec::new();
    for o in 0..10 {
        let t = LATHE_TOOL_BASE + o;
        for side in ["G41", "G42"] {
            v.push((
                format!("{side} of tool {t} (orientation {o}) from the spindle"),
                format!(
                    "G21 G18 G90 G94 F100\nT{t} M6\n{}",
                    profile.replacen("G1 X10 Z0", &format!("{side} G1 X10 Z0"), 1)
                ),
            ));
        }
        v.push((
            format!("G42.1 D L{o}, inch, with an M0 inside"),
            format!(
                "G20 G18 G90 G94 F4\nG0 X0.8 Z0.2\nG42.1 D0.04 L{o}\nG1 X0.4 Z0\nG1 Z-0.4\nM0\nG1 X0.6 Z-0.6\nG40 G1 X1 Z-1\nM2\n"
            ),
        ));
    }
    v.push((
        "G41 D of a lathe tool, G0 on the profile".into(),
        format!("G21 G18 G90 G94 F100\nG0 X20 Z5\nG41 D{} G0 X10 Z0\nG1 Z-10\nG0 X15 Z-12\nG40\nG0 X30\nM2\n", LATHE_TOOL_BASE + 3),
    ));
    v.push((
        "error: negative L".into(),
        "G21 G18 G90 G94 F100\nG0 X20 Z5\nG42.1 D1 L-1\nG1 X10 Z0\nG40\nM2\n".into(),
    ));
    v.push((
        "error: L not a whole number".into(),
        "G21 G18 G90 G94 F100\nG0 X20 Z5\nG42.1 D1 L2.5\nG1 X10 Z0\nG40\nM2\n".into(),
    ));
    v.push((
        "error: a lathe tool in G17".into(),
        format!(
            "G21 G17 G90 G94 F100\nG0 X20 Y5\nG41 D{}\nG1 X10 Y0\nG40\nM2\n",
            LATHE_TOOL_BASE + 2
        ),
    ));
    v
}

#[test]
fn lathe_tool_compensation_agrees_with_rs274() {
    let Some(setup) = setup() else { return };
    let work = setup.root.join("lathe_comp");
    std::fs::create_dir(&work).unwrap();
    let mut failures = Vec::new();
    let mut shifted = 0;
    for (k, (name, program)) in lathe_comp_programs().iter().enumerate() {
        let (ours, theirs) = run_both(&setup, &work, format!("lc{k}.ngc"), program);
        if name.starts_with("error") {
            assert!(
                ours.refused.is_some() && theirs.refused.is_some(),
                "{name}: {:?}",
                theirs.refused
            );
        } else {
            assert!(
                theirs.refused.is_none() && theirs.steps.len() >= 4,
                "{name}: rs274 made {} moves ({:?})",
                theirs.steps.len(),
                theirs.refused
            );
        }
        // Orientations 1–8 move the path: the first compensated end is
        // not where a mill tool's is.
        shifted += usize::from(
            name.contains("spindle")
                && !name.contains("orientation 0)")
                && !name.contains("orientation 9)"),
        );
        match classify(&ours, &theirs) {
            Verdict::Agree => {}
            Verdict::Known(why) => failures.push(format!("{name}: known difference {why}")),
            Verdict::Unsupported(f) => failures.push(format!("{name}: unsupported {f}")),
            Verdict::Disagree(d) => failures.push(format!("{name}: {d}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!(shifted, 16);
    // The generated ones (also in the differential test): every one agrees.
    let mut failures = Vec::new();
    for k in 0..LATHE_COMP {
        let program = generate_lathe_comp(LATHE_COMP_SEED + k);
        let (ours, theirs) = run_both(&setup, &work, format!("g{k}.ngc"), &program);
        if theirs.refused.is_some() || theirs.steps.len() < 8 {
            failures.push(format!(
                "seed {k}: rs274 made {} moves ({:?})",
                theirs.steps.len(),
                theirs.refused
            ));
        }
        if !matches!(classify(&ours, &theirs), Verdict::Agree) {
            failures.push(format!(
                "seed {k}: {}",
                match classify(&ours, &theirs) {
                    Verdict::Disagree(d) => d,
                    Verdict::Unsupported(f) => format!("unsupported {f}"),
                    _ => "known difference".into(),
                }
            ));
            if let Some(keep) = std::env::var_os("MTWIN_RS274_KEEP") {
                std::fs::write(
                    Path::new(&keep).join(format!("lathe_comp{k}.ngc")),
                    &program,
                )
                .unwrap();
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
