//! LinuxCNC interpreter conformance: every case of
//! `shared/corpus/gcode-conformance/linuxcnc-interp` whose program this
//! interpreter supports must produce the motion of the case's `expected`
//! trace (STRAIGHT_TRAVERSE, STRAIGHT_FEED, ARC_FEED, compared in mm after
//! the trace's own USE_LENGTH_UNITS) and its MESSAGE calls (the texts of
//! `(DEBUG,…)` and `(MSG,…)` comments, blanks collapsed as the trace has
//! them), every `good/` program must be accepted and every `bad/` program
//! must be rejected.
//!
//! A case whose trace ends without PROGRAM_END or FINISH is one LinuxCNC
//! refuses: mtwin must refuse it too, after the same motion.
//!
//! The corpus keeps each case's program, trace and subroutine folder but not
//! the `test.ini` LinuxCNC's test runs `rs274` with; [`case_ini`] gives the
//! INI text those cases use (`[RS274NGC] SUBROUTINE_PATH = subs`, the
//! `#<_ini[…]>` values), read through `ProgramOptions::apply_ini`.
//!
//! Cases whose programs use what this interpreter does not implement are
//! rejected by it with an "unsupported" error; they are listed in
//! [`SKIPPED`] with the reason, and the test checks that this list is
//! exactly the set of cases the interpreter turns down, so it cannot go
//! stale silently.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use mtwin::gcode::{self, EventKind, GcodeError, InterpOptions, UnknownMCode};

/// Cases that now run (parameters, O-word flow) but do not give LinuxCNC's
/// result yet, with the reason; each must still fail, so the list cannot go
/// stale.
const KNOWN_FAILURES: &[(&str, &str)] = &[
    (
        "m98m99/04-M98-but-no-sub",
        "LinuxCNC after 2.9 writes FINISH before its error 'Failed to find sub'; \
         mtwin refuses the call, as rs274 2.9 (the differential reference) does",
    ),
    (
        "m98m99/11-main-program-oword/test-illegal-sub-after-percent.ngc",
        "LinuxCNC after 2.9 writes FINISH before its error 'Failed to find sub'; \
         mtwin refuses the call, as rs274 2.9 (the differential reference) does",
    ),
    (
        "m98m99/11-main-program-oword/test-illegal-end-main-with-eof.ngc",
        "a program without M2, M30 or closing %: LinuxCNC refuses it, mtwin reads it \
         to its last line (docs/gcode.md, known differences)",
    ),
    (
        "machine-coord-params",
        "its trace (LinuxCNC after 2.9, which has #5021-#5029) has no motion and no \
         program end; rs274 2.9 runs it as mtwin does",
    ),
    (
        "nested-sub-in-file-error",
        "LinuxCNC after 2.9 refuses a call of a second subroutine defined in a \
         subroutine file; rs274 2.9 (the differential reference) and mtwin run it",
    ),
    (
        "rotation/abs-pts",
        "its trace (LinuxCNC after 2.9) keeps only the messages, no motion and no \
         program end; rs274 2.9 runs it as mtwin does",
    ),
];

/// Cases whose motion is LinuxCNC's but whose `(DEBUG,…)` messages print
/// parameters mtwin reads otherwise: offsets LinuxCNC keeps in its INI's
/// user units, which mtwin keeps in mm and `rs274` (the traces'
/// interpreter) in inches; each must still differ, so the list cannot go
/// stale.
const KNOWN_MESSAGE_DIFFERENCES: &[(&str, &str)] = &[
    (
        "g10/g10-l1-l10",
        "#5401-#5403 (tool table entry of the tool in the spindle) in mm, \
         LinuxCNC's user units; rs274 keeps them in inches",
    ),
    (
        "g10/g10-l11",
        "#5403 (tool table Z of the tool in the spindle) in mm; rs274 keeps it in inches",
    ),
    (
        "unit-conversion",
        "#5221-#5226 (work offsets) and #5211-#5216 (G92 offsets) in mm, \
         LinuxCNC's user units; rs274 keeps them in inches",
    ),
];

/// Cases whose `expected` trace LinuxCNC's test writes with `rs274 -n 0`
/// (continue after an error: the interpreter drops the failed line, unwinds
/// the calls and reads the next line of the program), with the error mtwin
/// stops at and why. mtwin stops at the first error, as LinuxCNC's
/// controller and `rs274` by default (`-n 2`, the differential reference)
/// do: the test checks the error and the file it is in, and that the
/// motion and the messages before it are the start of the trace's.
const CONTINUED_AFTER_ERROR: &[(&str, &str, &str, &str)] = &[(
    "oword-unwind",
    "Attempt to divide by zero",
    "fail.ngc",
    "its trace runs both calls of o<fail> (each: the message, then the division by \
     zero in fail.ngc) and reaches M2; mtwin stops at the first error",
)];

/// Cases skipped (the interpreter reports "unsupported") and why.
const SKIPPED: &[(&str, &str)] = &[
    ("compile", "no single program file (several or none)"),
    ("g71-endless-loop", "lathe cycle G71.1"),
    ("g71-endless-loop2", "constant surface speed G96"),
    ("g71-endless-loop_2", "constant surface speed G96"),
    ("g71-with-g70", "lathe cycle G71.1"),
    ("g72-facing", "lathe cycle G72"),
    ("g72-missing-iteration", "lathe cycle G72"),
    (
        "m98m99/09-disable-fanuc-subs",
        "no single program file (several or none)",
    ),
    ("plug/absolute", "no single program file (several or none)"),
    ("plug/filename", "no single program file (several or none)"),
    ("plug/relative", "no single program file (several or none)"),
    // Python: the LinuxCNC test's INI names a Python module (subs.py, not
    // in the corpus); mtwin runs no Python and refuses, naming the line.
    ("pymove", "Python o-word subroutine o<canonmove> call"),
    ("python-self", "embedded Python ;py, comment"),
    ("value-returned", "embedded Python ;py, comment"),
];

/// The INI sections (besides `[RS274NGC]`) of LinuxCNC's `test.ini` of a
/// case (not kept in the corpus): the values its `#<_ini[…]>` parameters
/// read.
pub(crate) fn case_ini_sections(name: &str) -> &'static str {
    match name {
        "iniparam" | "iniparam-failassign" => {
            "[VARS]\nTOOLCHANGE_X = 10\nTOOLCHANGE_Y = 20\nTOOLCHANGE_Z = 30\n"
        }
        "abort-hot-comment" => "[A]\nVALUE= 3.14\n",
        "pymove" => {
            "[PYTHON]\nPATH_PREPEND=.\nTOPLEVEL = subs.py\n\
             [CONFIG]\nXPOS = 33\nYPOS = 45\nZPOS = 78\n"
        }
        "python-self" | "value-returned" => "[PYTHON]\nPATH_PREPEND=.\nTOPLEVEL=subs.py\n",
        _ => "",
    }
}

/// The INI text a case runs with: `SUBROUTINE_PATH = subs` for a case with
/// a `subs` folder (as LinuxCNC's test INIs of those cases say) and the
/// sections of [`case_ini_sections`].
fn case_ini(name: &str, dir: &Path) -> Option<String> {
    let subs = if dir.join("subs").is_dir() {
        "[RS274NGC]\nSUBROUTINE_PATH=subs\n"
    } else {
        ""
    };
    let text = format!("{subs}{}", case_ini_sections(name));
    (!text.is_empty()).then_some(text)
}

/// Whether LinuxCNC refused the case: its trace has no program end.
fn expected_refused(trace: &str) -> bool {
    !(trace.contains("PROGRAM_END()") || trace.contains("FINISH()"))
}

fn root() -> Option<PathBuf> {
    crate::shared::shared_dir("corpus/gcode-conformance/linuxcnc-interp")
}

/// One motion call: name and arguments in LinuxCNC's order, mm and degree.
type Call = (String, Vec<f64>);

/// Motion calls of an `expected` trace, converted to mm.
fn expected_motion(text: &str) -> Vec<Call> {
    let mut inch = false;
    let mut calls = Vec::new();
    for line in text.lines() {
        // Lines read `N..... CALL(args)`, some traces prefix a counter.
        if line.contains("USE_LENGTH_UNITS(") {
            inch = line.contains("INCHES");
            continue;
        }
        let Some((name, args)) = [
            "STRAIGHT_TRAVERSE",
            "STRAIGHT_FEED",
            "ARC_FEED",
            "RIGID_TAP",
        ]
        .iter()
        .find_map(|n| line.split_once(&format!(" {n}(")).map(|(_, a)| (*n, a))) else {
            continue;
        };
        let args: Vec<f64> = args
            .trim_end()
            .trim_end_matches(')')
            .split(',')
            .map(|a| {
                a.trim()
                    .parse()
                    .unwrap_or_else(|_| panic!("bad trace line {line}"))
            })
            .collect();
        let s = if inch { 25.4 } else { 1.0 };
        // Linear arguments: straight: x y z (0..3) and u v w (6..9);
        // arc: ends and centre (0..4), axis end (5), u v w (9..12).
        let linear = |i: usize| match name {
            "ARC_FEED" => i < 4 || i == 5 || i >= 9,
            _ => !(3..6).contains(&i),
        };
        let args = args
            .iter()
            .enumerate()
            .map(|(i, v)| if linear(i) { v * s } else { *v })
            .collect();
        calls.push((name.to_string(), args));
    }
    calls
}

/// `MESSAGE("…")` texts of an `expected` trace, in order, blanks
/// collapsed (LinuxCNC's tests pass the trace through awk, which rebuilds
/// each line with single blanks).
fn expected_messages(text: &str) -> Vec<String> {
    text.lines()
        .filter_map(|l| l.split_once(" MESSAGE(\"")?.1.strip_suffix("\")"))
        .map(collapse)
        .collect()
}

/// The words of `text` joined by single blanks.
fn collapse(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Whether our messages are the trace's (blanks collapsed).
fn same_messages(ours: &[String], expected: &[String]) -> Result<(), String> {
    let ours: Vec<String> = ours.iter().map(|m| collapse(m)).collect();
    match ours.iter().zip(expected).position(|(a, b)| a != b) {
        None if ours.len() == expected.len() => Ok(()),
        k => {
            let k = k.unwrap_or(ours.len().min(expected.len()));
            Err(format!(
                "messages: {} of {}, first difference at {k}: {:?}, expected {:?}",
                ours.len(),
                expected.len(),
                ours.get(k),
                expected.get(k)
            ))
        }
    }
}

/// Motion calls of a run: all of them, or those before the block that
/// failed and the error.
type Motion = Result<Vec<Call>, (Vec<Call>, GcodeError)>;

/// Motion calls of our interpreter, in LinuxCNC's argument order: all of
/// them, or those before the block that failed and the error.
fn our_motion(program: &[u8], dir: &Path, ini: Option<&str>) -> Motion {
    run_ours(program, dir, ini).0
}

/// [`our_motion`], and the texts of the `(DEBUG,…)` and `(MSG,…)` messages
/// sent (LinuxCNC's MESSAGE calls).
fn run_ours(program: &[u8], dir: &Path, ini: Option<&str>) -> (Motion, Vec<String>) {
    // The tool lengths LinuxCNC's test tool table gives (USE_TOOL_LENGTH_OFFSET
    // in the traces of g72-facing, in mm, and g76, 0.7 in).
    // Tool 1 with zero offsets: the test.tbl of LinuxCNC's g10 cases.
    let tools = [(1, 0.0), (2, 2.54), (4, 0.7 * 25.4)].into_iter().collect();
    let mut opts = InterpOptions::default();
    opts.unknown_m = UnknownMCode::Reject;
    opts.tools = tools;
    // Tool 1's diameter, 1/16 in: the cutter radius compensation of
    // cam-nisley (`G42 D1`) offsets its entry move by 1/32 in in the trace.
    let mut t1 = opts.tools.get(1).unwrap().clone();
    t1.diameter = 0.0625 * 25.4;
    opts.tools.insert(t1);
    // Subroutine files of a case sit next to its program.
    opts.program.subroutine_path = vec![dir.to_path_buf()];
    if let Some(ini) = ini {
        opts.program.apply_ini(ini, dir);
    }
    let messages = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let sent = messages.clone();
    opts.program.messages = gcode::MessageSink::new(move |m: &gcode::Message| {
        if matches!(m.kind, gcode::MessageKind::Debug | gcode::MessageKind::Msg) {
            sent.lock().unwrap().push(m.text.clone());
        }
    });
    let mut calls: Vec<Call> = Vec::new();
    // The rotation (G10 L2 R) in force: events give X Y rotated by it,
    // LinuxCNC's canonical calls the program's.
    let mut rot = 0.0;
    let result = gcode::interpret(program, opts, |_, events| {
        for (k, e) in events.iter().enumerate() {
            let abc = |p: &gcode::Axes| [p.0[3], p.0[4], p.0[5]];
            match &e.kind {
                EventKind::WorkOffset { rotation, .. } => rot = *rotation,
                // G33.1: the tap and its retract are LinuxCNC's one
                // RIGID_TAP(x, y, z) call.
                EventKind::Feed(m)
                    if m.words.expanded
                        && k > 0
                        && matches!(events[k - 1].kind, EventKind::Feed(p)
                            if p.words.expanded && p.from == m.to && p.to == m.from) =>
                {
                    if let Some(last) = calls.last_mut() {
                        last.0 = "RIGID_TAP".to_string();
                        last.1.truncate(3);
                    }
                }
                EventKind::Traverse(m) | EventKind::Feed(m) => {
                    let mut m = *m;
                    m.to = crate::rs274::unrotate(&m.to, rot);
                    let name = if matches!(e.kind, EventKind::Traverse(_)) {
                        "STRAIGHT_TRAVERSE"
                    } else {
                        "STRAIGHT_FEED"
                    };
                    calls.push((name.to_string(), m.to.0[..6].to_vec()));
                }
                EventKind::Arc(a) => {
                    let mut a = *a;
                    a.to = crate::rs274::unrotate(&a.to, rot);
                    let c = crate::rs274::unrotate(
                        &gcode::Axes([a.center[0], a.center[1], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                        rot,
                    );
                    a.center[0] = c.0[0];
                    a.center[1] = c.0[1];
                    let (p, q, n) = a.plane.axes();
                    let mut v = vec![
                        a.to[p],
                        a.to[q],
                        a.center[p.index()],
                        a.center[q.index()],
                        f64::from(a.turns),
                        a.to[n],
                    ];
                    v.extend(abc(&a.to));
                    calls.push(("ARC_FEED".to_string(), v));
                }
                _ => {}
            }
        }
        Ok(())
    });
    let messages = messages.lock().unwrap().clone();
    match result {
        Ok(()) => (Ok(calls), messages),
        Err(e) => (Err((calls, e)), messages),
    }
}

fn same(ours: &[Call], expected: &[Call]) -> Result<(), String> {
    if ours.len() != expected.len() {
        return Err(format!(
            "{} motion calls, expected {}",
            ours.len(),
            expected.len()
        ));
    }
    for (k, ((n1, a1), (n2, a2))) in ours.iter().zip(expected).enumerate() {
        if n1 != n2 {
            return Err(format!("call {k}: {n1}, expected {n2}"));
        }
        // The trace prints 4 decimals in program units (≤ 0.5e-4 in = 1.27e-3 mm).
        for (i, (x, y)) in a1.iter().zip(a2).enumerate() {
            if (x - y).abs() > 1.3e-3 {
                return Err(format!(
                    "call {k} {n1} argument {i}: {x}, expected {y}\n ours {a1:?}\n expected {a2:?}"
                ));
            }
        }
    }
    Ok(())
}

/// The program of a case folder: `test.ngc`, else its only `.ngc` file.
fn program_of(dir: &Path) -> Option<PathBuf> {
    let test = dir.join("test.ngc");
    if test.is_file() {
        return Some(test);
    }
    let ngc: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "ngc"))
        .collect();
    (ngc.len() == 1).then(|| ngc[0].clone())
}

/// The programs of a case folder with several `.ngc` files and their
/// traces, when its `expected` file can be split: sections headed
/// `Legal test NAME:` / `Illegal test NAME:` (the program
/// `test-legal-NAME.ngc` / `test-illegal-NAME.ngc`), or one trace per
/// program in file name order, each starting at its call counter 1.
fn programs_of(dir: &Path) -> Option<Vec<(PathBuf, String)>> {
    let mut ngc: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "ngc"))
        .collect();
    ngc.sort();
    if ngc.len() < 2 {
        return None;
    }
    let text = String::from_utf8_lossy(&std::fs::read(dir.join("expected")).ok()?).into_owned();
    let header = |l: &str| -> Option<String> {
        let (kind, rest) = l.split_once(" test ")?;
        let name = rest.strip_suffix(':')?;
        matches!(kind, "Legal" | "Illegal")
            .then(|| format!("test-{}-{name}.ngc", kind.to_ascii_lowercase()))
    };
    let mut sections: Vec<(Option<String>, String)> = Vec::new();
    for line in text.lines() {
        if let Some(file) = header(line) {
            sections.push((Some(file), String::new()));
            continue;
        }
        let first_call = line.trim_start().starts_with("1 N.....");
        if first_call
            && sections
                .last()
                .is_none_or(|(f, t)| f.is_none() && !t.is_empty())
        {
            sections.push((None, String::new()));
        }
        if let Some((_, t)) = sections.last_mut() {
            t.push_str(line);
            t.push('\n');
        }
    }
    if sections.len() != ngc.len() {
        return None;
    }
    if sections.iter().all(|(f, _)| f.is_some()) {
        sections
            .into_iter()
            .map(|(f, t)| {
                let p = dir.join(f?);
                p.is_file().then_some((p, t))
            })
            .collect()
    } else if sections.iter().all(|(f, _)| f.is_none()) {
        Some(
            ngc.into_iter()
                .zip(sections.into_iter().map(|(_, t)| t))
                .collect(),
        )
    } else {
        None
    }
}

fn case_dirs(dir: &Path, root: &Path, out: &mut Vec<(String, PathBuf)>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    if dir.join("expected").is_file() {
        let name = dir
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .into_owned();
        out.push((name, dir.to_path_buf()));
    }
    for e in entries {
        if e.is_dir() {
            case_dirs(&e, root, out);
        }
    }
}

#[test]
fn linuxcnc_conformance() {
    let Some(root) = root() else { return };
    let mut cases = Vec::new();
    case_dirs(&root, &root, &mut cases);
    let mut skipped: BTreeMap<String, String> = BTreeMap::new();
    let mut failures = Vec::new();
    let mut passed = Vec::new();
    let mut prefix_checked = Vec::new();

    // (name, folder, program, trace): one per program.
    let mut programs = Vec::new();
    for (name, dir) in &cases {
        if let Some(program) = program_of(dir) {
            let expected_text =
                String::from_utf8_lossy(&std::fs::read(dir.join("expected")).unwrap()).into_owned();
            programs.push((name.clone(), dir, program, expected_text));
        } else if let Some(list) = programs_of(dir) {
            for (program, expected_text) in list {
                let file = program.file_name().unwrap().to_string_lossy().into_owned();
                programs.push((format!("{name}/{file}"), dir, program, expected_text));
            }
        } else {
            skipped.insert(
                name.clone(),
                "no single program file (several or none)".into(),
            );
        }
    }
    let mut continued_seen = vec![false; CONTINUED_AFTER_ERROR.len()];
    for (name, dir, program, expected_text) in &programs {
        let (name, dir) = (name, *dir);
        let bytes = std::fs::read(program).unwrap();
        if let Some(k) = CONTINUED_AFTER_ERROR.iter().position(|c| c.0 == name) {
            continued_seen[k] = true;
            let (_, error, file, why) = CONTINUED_AFTER_ERROR[k];
            let (result, messages) = run_ours(&bytes, dir, case_ini(name, dir).as_deref());
            let expected = expected_motion(expected_text);
            let expected_messages = expected_messages(expected_text);
            match result {
                Err((ours, e))
                    if !matches!(e, GcodeError::Unsupported { .. })
                        && e.to_string().contains(error)
                        && e.file().is_some_and(|f| f.ends_with(file)) =>
                {
                    let n = ours.len().min(expected.len());
                    if let Err(m) = same(&ours, &expected[..n]).and_then(|()| {
                        (ours.len() <= expected.len()
                            && (!messages.is_empty() || expected_messages.is_empty())
                            && same_messages(
                                &messages,
                                &expected_messages[..messages.len().min(expected_messages.len())],
                            )
                            .is_ok())
                        .then_some(())
                        .ok_or(format!(
                            "messages {messages:?}, the trace's {expected_messages:?}"
                        ))
                    }) {
                        failures.push(format!("{name}: before its first error: {m}"));
                    } else {
                        eprintln!(
                            "{name}: stops at its first error ({file}: {e}; {} messages, \
                             {} motions before it): {why}",
                            messages.len(),
                            ours.len()
                        );
                        passed.push(format!("{name} (to its first error)"));
                    }
                }
                Err((_, e)) => failures.push(format!("{name}: refused, but with {e}")),
                Ok(_) => failures.push(format!("{name}: accepted, no {error}")),
            }
            continue;
        }
        let refused = expected_refused(expected_text);
        let (result, messages) = run_ours(&bytes, dir, case_ini(name, dir).as_deref());
        match result {
            Ok(_) if refused => {
                failures.push(format!("{name}: accepted, but LinuxCNC refuses it"));
            }
            // The motion, and the messages of (DEBUG,…) and (MSG,…).
            Ok(ours) => match same(&ours, &expected_motion(expected_text))
                .and_then(|()| same_messages(&messages, &expected_messages(expected_text)))
            {
                Ok(()) => passed.push(name.clone()),
                Err(e) => failures.push(format!("{name}: {e}")),
            },
            // Unsupported: the motion up to the unsupported block must still
            // be the start of LinuxCNC's.
            Err((ours, e @ GcodeError::Unsupported { .. })) => {
                let expected = expected_motion(expected_text);
                let n = ours.len().min(expected.len());
                if let Err(m) = same(&ours, &expected[..n]) {
                    failures.push(format!("{name}: before the unsupported block: {m}"));
                }
                if n > 0 {
                    prefix_checked.push(format!("{name} ({n})"));
                }
                skipped.insert(name.clone(), e.to_string());
            }
            // Refused by both: the motion before must be LinuxCNC's.
            Err((ours, _)) if refused => match same(&ours, &expected_motion(expected_text))
                .and_then(|()| same_messages(&messages, &expected_messages(expected_text)))
            {
                Ok(()) => passed.push(name.clone()),
                Err(e) if e.starts_with("messages:") => failures.push(format!("{name}: {e}")),
                Err(e) => failures.push(format!("{name}: refused by both, but {e}")),
            },
            Err((_, e)) => failures.push(format!("{name}: rejected: {e}")),
        }
    }

    // good/: accepted; bad/: rejected.
    for (folder, must_fail) in [("good", false), ("bad", true)] {
        let mut files: Vec<PathBuf> = std::fs::read_dir(root.join(folder))
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "ngc"))
            .collect();
        files.sort();
        for f in files {
            let name = format!("{folder}/{}", f.file_name().unwrap().to_string_lossy());
            match (
                our_motion(&std::fs::read(&f).unwrap(), &root.join(folder), None),
                must_fail,
            ) {
                (Err((_, e @ GcodeError::Unsupported { .. })), _) => {
                    skipped.insert(name, e.to_string());
                }
                (Err(_), true) | (Ok(_), false) => passed.push(name),
                (Ok(_), true) => {
                    failures.push(format!("{name}: accepted, but LinuxCNC rejects it"))
                }
                (Err((_, e)), false) => failures.push(format!("{name}: rejected: {e}")),
            }
        }
    }

    eprintln!("passed ({}): {passed:?}", passed.len());
    eprintln!("motion before the unsupported block matched (motions): {prefix_checked:?}");
    for (k, v) in &skipped {
        eprintln!("skipped {k}: {v}");
    }
    let mut messages_seen = vec![false; KNOWN_MESSAGE_DIFFERENCES.len()];
    failures.retain(|f| {
        let Some(k) = KNOWN_MESSAGE_DIFFERENCES.iter().position(|(p, _)| {
            f.strip_prefix(p)
                .is_some_and(|r| r.starts_with(": messages:"))
        }) else {
            return true;
        };
        messages_seen[k] = true;
        eprintln!(
            "known message difference (not kept: {}): {f}",
            KNOWN_MESSAGE_DIFFERENCES[k].1
        );
        false
    });
    for (k, seen) in messages_seen.iter().enumerate() {
        assert!(
            *seen,
            "KNOWN_MESSAGE_DIFFERENCES is out of date: {} prints LinuxCNC's messages now",
            KNOWN_MESSAGE_DIFFERENCES[k].0
        );
    }
    let mut known_seen = vec![false; KNOWN_FAILURES.len()];
    failures.retain(
        |f| match KNOWN_FAILURES.iter().position(|(p, _)| f.starts_with(p)) {
            Some(k) => {
                known_seen[k] = true;
                eprintln!("known failure ({}): {f}", KNOWN_FAILURES[k].1);
                false
            }
            None => true,
        },
    );
    assert!(
        failures.is_empty(),
        "conformance failures:\n{}",
        failures.join("\n")
    );
    for (k, seen) in continued_seen.iter().enumerate() {
        assert!(
            *seen,
            "CONTINUED_AFTER_ERROR names a case not found: {}",
            CONTINUED_AFTER_ERROR[k].0
        );
    }
    for (k, seen) in known_seen.iter().enumerate() {
        assert!(
            *seen,
            "KNOWN_FAILURES is out of date: {} passes now",
            KNOWN_FAILURES[k].0
        );
    }
    let listed: BTreeMap<String, String> = SKIPPED
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let listed_names: Vec<&String> = listed.keys().collect();
    let skipped_names: Vec<&String> = skipped.keys().collect();
    assert_eq!(
        skipped_names, listed_names,
        "the SKIPPED list is out of date"
    );
    for (name, reason) in &listed {
        assert!(
            skipped[name].contains(reason.as_str()),
            "{name}: skipped because {}, listed as {reason}",
            skipped[name]
        );
    }
    assert!(
        passed.len() >= 5,
        "too few conformance cases pass: {passed:?}"
    );
}
