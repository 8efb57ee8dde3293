//! How every command writes its outputs: an output that is an input is
//! refused before any work, outputs appear all together or not at all, no
//! temporary file is left after an error, SIGINT or SIGTERM, a closed
//! standard output ends the command quietly, devices and `-` are streamed,
//! symbolic links are followed, modes follow the umask.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common::{example, mtwin, stderr, stdout};

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_mtwin")
}

/// Every entry of `dir` whose name is a temporary output file.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".mtwin-") && n.ends_with(".tmp"))
        .collect()
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn assert_refused(o: &Output, what: &str) {
    assert_eq!(o.status.code(), Some(1), "{what}: {}", stderr(o));
    let e = stderr(o);
    assert!(!e.contains("panicked"), "{what}: {e}");
    assert!(e.starts_with("error: "), "{what}: {e}");
}

/// Files with a content of their own: whatever a refused command does, they
/// must keep it byte for byte.
fn plant(dir: &Path, files: &[&str]) {
    for f in files {
        std::fs::write(dir.join(f), format!("original content of {f}\n")).unwrap();
    }
}

fn intact(dir: &Path, files: &[&str]) {
    for f in files {
        let p = dir.join(f);
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            format!("original content of {f}\n"),
            "{} was changed",
            p.display()
        );
    }
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = example("ac-trunnion-with-errors.toml");
    std::fs::copy(&m, d.join("m.toml")).unwrap();
    let inputs = [
        "p.csv",
        "mode1.csv",
        "d.csv",
        "s.ngc",
        "fc.nc",
        "c.csv",
        "thermal.toml",
        "identified.toml",
    ];
    plant(d, &inputs);
    #[cfg(unix)]
    {
        std::fs::hard_link(d.join("p.csv"), d.join("hard.csv")).unwrap();
        std::os::unix::fs::symlink("p.csv", d.join("soft.csv")).unwrap();
    }
    let machine_before = std::fs::read(d.join("m.toml")).unwrap();
    let cases: &[(&str, &[&str], &str)] = &[
        (
            "predict",
            &[
                "predict",
                "--machine",
                "m.toml",
                "--data",
                "p.csv",
                "--out",
                "p.csv",
            ],
            "p.csv",
        ),
        (
            "predict through a hard link",
            &[
                "predict",
                "--machine",
                "m.toml",
                "--data",
                "p.csv",
                "--out",
                "hard.csv",
            ],
            "p.csv",
        ),
        (
            "predict through a symbolic link",
            &[
                "predict",
                "--machine",
                "m.toml",
                "--data",
                "soft.csv",
                "--out",
                "p.csv",
            ],
            "soft.csv",
        ),
        (
            "predict, a dotted path",
            &[
                "predict",
                "--machine",
                "m.toml",
                "--data",
                "p.csv",
                "--out",
                "./p.csv",
            ],
            "p.csv",
        ),
        (
            "ballbar identify",
            &[
                "ballbar",
                "identify",
                "--mode1",
                "mode1.csv",
                "--length",
                "100",
                "--zb1c",
                "100",
                "--zb1a",
                "100",
                "--ex",
                "0",
                "--ey",
                "0",
                "--out",
                "mode1.csv",
            ],
            "mode1.csv",
        ),
        (
            "identify",
            &[
                "identify",
                "--machine",
                "m.toml",
                "--data",
                "d.csv",
                "--fit",
                "location",
                "--out",
                "m.toml",
            ],
            "m.toml",
        ),
        (
            "compensate, the program",
            &[
                "compensate",
                "--machine",
                "m.toml",
                "--program",
                "s.ngc",
                "--out",
                "s.ngc",
            ],
            "s.ngc",
        ),
        (
            "compensate, the machine",
            &[
                "compensate",
                "--machine",
                "m.toml",
                "--program",
                "s.ngc",
                "--out",
                "m.toml",
            ],
            "m.toml",
        ),
        (
            "thermal compensate",
            &[
                "thermal",
                "compensate",
                "--model",
                "thermal.toml",
                "--program",
                "fc.nc",
                "--out",
                "fc.nc",
            ],
            "fc.nc",
        ),
        (
            "thermal compensate, the plot",
            &[
                "thermal",
                "compensate",
                "--model",
                "thermal.toml",
                "--program",
                "fc.nc",
                "--out",
                "new.nc",
                "--plot",
                "thermal.toml",
            ],
            "thermal.toml",
        ),
        (
            "gcode interpolate",
            &[
                "gcode",
                "interpolate",
                "--machine",
                "m.toml",
                "s.ngc",
                "--out",
                "s.ngc",
            ],
            "s.ngc",
        ),
        (
            "twin predict",
            &[
                "twin",
                "predict",
                "--machine",
                "m.toml",
                "--commands",
                "c.csv",
                "--out",
                "c.csv",
            ],
            "c.csv",
        ),
        (
            "report",
            &[
                "report",
                "--machine",
                "identified.toml",
                "--out",
                "identified.toml",
            ],
            "identified.toml",
        ),
        (
            "compensate-points",
            &[
                "compensate-points",
                "--machine",
                "m.toml",
                "--data",
                "p.csv",
                "--out",
                "p.csv",
            ],
            "p.csv",
        ),
        (
            "simulate tracker",
            &[
                "simulate",
                "tracker",
                "--machine",
                "m.toml",
                "--poses",
                "p.csv",
                "--out",
                "p.csv",
            ],
            "p.csv",
        ),
        (
            "validate, the plot",
            &[
                "validate",
                "--machine",
                "m.toml",
                "--data",
                "d.csv",
                "--plot",
                "d.csv",
            ],
            "d.csv",
        ),
        (
            "servo simulate",
            &[
                "servo",
                "simulate",
                "--servo",
                "thermal.toml",
                "--commands",
                "c.csv",
                "--out",
                "c.csv",
            ],
            "c.csv",
        ),
    ];
    for (what, args, input) in cases {
        let o = mtwin(d, args);
        assert_refused(&o, what);
        let e = stderr(&o);
        assert!(
            e.contains("same file as the input") && e.contains(input),
            "{what}: {e}"
        );
        intact(d, &inputs);
        assert_eq!(
            std::fs::read(d.join("m.toml")).unwrap(),
            machine_before,
            "{what}"
        );
        assert!(temporaries(d).is_empty(), "{what}: {:?}", temporaries(d));
    }
    #[cfg(unix)]
    assert!(
        std::fs::symlink_metadata(d.join("soft.csv"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
}

#[test]
fn a_failing_second_output_leaves_no_first_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let gantry = example("afp-gantry.toml");
    let plan = |csv: &str, gcode: &str| {
        mtwin(
            d,
            &[
                "plan",
                "tracker",
                "--machine",
                &gantry,
                "--fit",
                "location",
                "--candidates",
                "200",
                "--select",
                "40",
                "--out-csv",
                csv,
                "--out-gcode",
                gcode,
            ],
        )
    };
    // A folder that does not exist: refused before the work.
    let o = plan("p.csv", "no/such/dir/p.nc");
    assert_refused(&o, "missing folder");
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));
    assert!(names(d).is_empty(), "{:?}", names(d));
    // A second output that fails while it is written (a full disk): the first,
    // already complete, is not put in place, and its previous content stays.
    plant(d, &["p.csv"]);
    #[cfg(target_os = "linux")]
    {
        let o = plan("p.csv", "/dev/full");
        assert_refused(&o, "full disk");
        assert!(stderr(&o).contains("/dev/full"), "{}", stderr(&o));
        intact(d, &["p.csv"]);
        assert!(temporaries(d).is_empty(), "{:?}", names(d));
    }
    // An existing file given as the plot folder.
    let ex = example("ac-trunnion-with-errors.toml");
    let o = mtwin(
        d,
        &[
            "twin",
            "predict",
            "--machine",
            &ex,
            "--commands",
            "c.csv",
            "--out",
            "pred.csv",
            "--plot",
            "p.csv",
        ],
    );
    assert_refused(&o, "twin --plot FILE");
    assert!(stderr(&o).contains("not a folder"), "{}", stderr(&o));
    intact(d, &["p.csv"]);
    // A plot folder below a file.
    let o = mtwin(
        d,
        &[
            "ballbar",
            "identify",
            "--mode1",
            "m1.csv",
            "--length",
            "100",
            "--zb1c",
            "100",
            "--zb1a",
            "100",
            "--ex",
            "0",
            "--ey",
            "0",
            "--out",
            "id.toml",
            "--plot",
            "p.csv/plots",
        ],
    );
    assert_refused(&o, "ballbar --plot below a file");
    assert_eq!(names(d), ["p.csv"]);
    // Both written when both can be.
    let o = plan("p.csv", "p.nc");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(names(d), ["p.csv", "p.nc"]);
    let csv = std::fs::read_to_string(d.join("p.csv")).unwrap();
    assert_eq!(csv.lines().count(), 41, "header and 40 poses");
}

#[test]
fn the_same_output_twice_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "plan",
            "tracker",
            "--machine",
            &example("afp-gantry.toml"),
            "--fit",
            "location",
            "--candidates",
            "200",
            "--select",
            "40",
            "--out-csv",
            "p.txt",
            "--out-gcode",
            "./p.txt",
        ],
    );
    assert_refused(&o, "twice");
    assert!(stderr(&o).contains("same output file"), "{}", stderr(&o));
    assert!(names(dir.path()).is_empty());
}

/// A program of one slow move: 6 000 000 samples at 1 ms, about 200 MB of
/// axis commands — long enough to be interrupted while it is written.
fn slow_program(dir: &Path) -> PathBuf {
    let p = dir.join("slow.nc");
    std::fs::write(&p, "G21 G90 G94\nG1 X100 F1\nM30\n").unwrap();
    p
}

/// Start `gcode interpolate` of the slow program, wait until its temporary
/// output has grown past 1 MB, send `signal`, and return the exit code.
#[cfg(unix)]
fn interrupt_a_long_write(signal: &str) -> (std::process::ExitStatus, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    slow_program(d);
    std::fs::write(d.join("cmd.csv"), "previous output\n").unwrap();
    let mut command = Command::new(bin());
    command
        .args(["gcode", "interpolate", "--machine"])
        .arg(example("ac-trunnion.toml"))
        .args(["slow.nc", "--ts", "0.001", "--out", "cmd.csv"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    // The signal as a terminal's Ctrl-C or a `kill` delivers it, whatever
    // the test runner inherited: started in the background of a
    // non-interactive shell (as a CI script may start it), it has SIGINT
    // ignored, and the tool rightly keeps an inherited ignored signal
    // ignored (`an_ignored_signal_stays_ignored`).
    use std::os::unix::process::CommandExt;
    // SAFETY: between fork and exec the closure calls only `signal`, which
    // is async-signal-safe, and allocates nothing.
    unsafe {
        command.pre_exec(|| {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            libc::signal(libc::SIGTERM, libc::SIG_DFL);
            Ok(())
        });
    }
    let mut child = command.spawn().unwrap();
    let start = Instant::now();
    loop {
        let big = std::fs::read_dir(d).unwrap().any(|e| {
            let e = e.unwrap();
            e.file_name().to_string_lossy().starts_with(".mtwin-")
                && e.metadata().map(|m| m.len() > 1 << 20).unwrap_or(false)
        });
        if big {
            break;
        }
        if let Some(s) = child.try_wait().unwrap() {
            panic!("finished before it could be interrupted: {s}");
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no temporary file grew"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    // Sent directly, not by a `kill` process: starting one on a loaded
    // machine can take longer than the rest of the write.
    let sig = match signal {
        "INT" => libc::SIGINT,
        "TERM" => libc::SIGTERM,
        other => panic!("no signal SIG{other} in this test"),
    };
    let pid = libc::pid_t::try_from(child.id()).unwrap();
    // SAFETY: `kill` with the pid of a child this test started and has not
    // yet waited for (so the pid cannot have been reused).
    assert_eq!(unsafe { libc::kill(pid, sig) }, 0, "kill -{signal}");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("still running 60 s after SIG{signal}");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = String::new();
    use std::io::Read;
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        temporaries(d).is_empty(),
        "left after SIG{signal}: {:?}",
        names(d)
    );
    assert_eq!(
        std::fs::read_to_string(d.join("cmd.csv")).unwrap(),
        "previous output\n",
        "the previous output must stay whole"
    );
    assert_eq!(names(d), ["cmd.csv", "slow.nc"]);
    (status, dir)
}

#[cfg(unix)]
#[test]
fn sigint_and_sigterm_leave_no_temporary_file() {
    use std::os::unix::process::ExitStatusExt;
    // Ended by the signal itself (a shell reports 130 and 143).
    let (status, _d) = interrupt_a_long_write("INT");
    assert_eq!(status.signal(), Some(2), "{status}");
    let (status, _d) = interrupt_a_long_write("TERM");
    assert_eq!(status.signal(), Some(15), "{status}");
    // And as a shell sees it.
    let dir = tempfile::tempdir().unwrap();
    slow_program(dir.path());
    let script = "\"$0\" gcode interpolate --machine \"$1\" slow.nc --ts 0.001 --out cmd.csv & \
                  pid=$!; \
                  while ! ls -a | grep -q '^.mtwin-'; do sleep 0.01; done; \
                  sleep 0.05; kill -TERM $pid; wait $pid; echo \"status $?\"";
    let o = Command::new("sh")
        .args(["-c", script, bin(), &example("ac-trunnion.toml")])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(stdout(&o).trim(), "status 143", "{}", stderr(&o));
    assert_eq!(names(dir.path()), ["slow.nc"]);
}

#[test]
fn an_error_during_a_long_write_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Samples are written as they are interpolated; the travel check stops
    // the run at the second move, after the first move's samples.
    std::fs::write(
        d.join("bad.nc"),
        "G21 G90 G94\nG1 X10 F100\nG1 X1000 F100\nM30\n",
    )
    .unwrap();
    std::fs::write(d.join("cmd.csv"), "previous output\n").unwrap();
    let o = mtwin(
        d,
        &[
            "gcode",
            "interpolate",
            "--machine",
            &example("ac-trunnion.toml"),
            "bad.nc",
            "--ts",
            "0.001",
            "--out",
            "cmd.csv",
        ],
    );
    assert_refused(&o, "travel");
    assert!(stderr(&o).contains("bad.nc:3"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(d.join("cmd.csv")).unwrap(),
        "previous output\n"
    );
    assert_eq!(names(d), ["bad.nc", "cmd.csv"]);
}

/// Run `args` with a standard output whose reading end is already closed.
#[cfg(unix)]
fn with_closed_stdout(cwd: &Path, args: &[&str]) -> Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    Command::new(bin())
        .args(args)
        .current_dir(cwd)
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

#[cfg(unix)]
#[test]
fn a_closed_stdout_ends_the_command_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = example("ac-trunnion.toml");
    std::fs::write(d.join("p.csv"), "X,Y,Z,A,C\n1,2,3,4,5\n").unwrap();
    let cases: &[&[&str]] = &[
        &["completions", "bash"],
        &["ballbar", "sensitivity"],
        &["ballbar", "sensitivity", "--format", "json"],
        &[
            "ballbar",
            "setup-error",
            "--length",
            "100",
            "--lmax",
            "100.1",
            "--lmin",
            "99.9",
            "--theta2",
            "242",
        ],
        &["model", "check", &m],
        &[
            "predict",
            "--machine",
            &m,
            "--data",
            "p.csv",
            "--out",
            "pred.csv",
        ],
        &["predict", "--machine", &m, "--data", "p.csv", "--out", "-"],
    ];
    for args in cases {
        let o = with_closed_stdout(d, args);
        let e = stderr(&o);
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        assert!(!e.contains("error"), "{args:?}: {e}");
        assert_eq!(o.status.code(), Some(141), "{args:?}: {e}");
        assert!(temporaries(d).is_empty(), "{args:?}: {:?}", names(d));
    }
    // The file output was complete before the summary met the closed pipe.
    assert_eq!(
        std::fs::read_to_string(d.join("pred.csv"))
            .unwrap()
            .lines()
            .count(),
        2
    );
    // A closed stdout that is one of two outputs: neither is written.
    let o = with_closed_stdout(
        d,
        &[
            "plan",
            "tracker",
            "--machine",
            &example("afp-gantry.toml"),
            "--fit",
            "location",
            "--candidates",
            "200",
            "--select",
            "40",
            "--out-csv",
            "-",
            "--out-gcode",
            "p.nc",
        ],
    );
    assert_eq!(o.status.code(), Some(141), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
    assert_eq!(names(d), ["p.csv", "pred.csv"]);
    // Help printed to a closed pipe is not a panic either.
    let o = with_closed_stdout(d, &["--help"]);
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    assert_ne!(o.status.code(), Some(101));
}

#[cfg(unix)]
#[test]
fn dev_null_stays_a_character_device() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.csv"), "X,Y,Z,A,C\n1,2,3,4,5\n").unwrap();
    let o = mtwin(
        d,
        &[
            "predict",
            "--machine",
            &example("ac-trunnion.toml"),
            "--data",
            "p.csv",
            "--out",
            "/dev/null",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let t = std::fs::metadata("/dev/null").unwrap().file_type();
    assert!(t.is_char_device(), "/dev/null is no longer a device");
    assert!(temporaries(Path::new("/dev")).is_empty());
    assert_eq!(names(d), ["p.csv"]);
}

#[test]
fn dash_streams_to_stdout() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.csv"), "X,Y,Z,A,C\n1,2,3,4,5\n0,0,0,0,0\n").unwrap();
    let args = |out: &str| -> Vec<String> {
        [
            "predict",
            "--machine",
            &example("ac-trunnion.toml"),
            "--data",
            "p.csv",
            "--out",
            out,
        ]
        .map(String::from)
        .to_vec()
    };
    let a = args("file.csv");
    let o = mtwin(d, &a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let file = std::fs::read_to_string(d.join("file.csv")).unwrap();
    for out in ["-", "/dev/stdout"] {
        let a = args(out);
        let o = mtwin(d, &a.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(o.status.success(), "{out}: {}", stderr(&o));
        // Stdout carries the file alone; the summary went to stderr.
        assert_eq!(stdout(&o), file, "{out}");
        assert!(stderr(&o).contains("2 poses"), "{out}: {}", stderr(&o));
    }
    assert_eq!(names(d), ["file.csv", "p.csv"], "no file named `-`");
}

#[cfg(unix)]
#[test]
fn a_symbolic_link_is_followed_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("results")).unwrap();
    std::fs::write(d.join("results/pred.csv"), "old\n").unwrap();
    std::os::unix::fs::symlink("results/pred.csv", d.join("latest.csv")).unwrap();
    std::fs::write(d.join("p.csv"), "X,Y,Z,A,C\n1,2,3,4,5\n").unwrap();
    let o = mtwin(
        d,
        &[
            "predict",
            "--machine",
            &example("ac-trunnion.toml"),
            "--data",
            "p.csv",
            "--out",
            "latest.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let link = std::fs::symlink_metadata(d.join("latest.csv")).unwrap();
    assert!(link.file_type().is_symlink(), "the link was replaced");
    let text = std::fs::read_to_string(d.join("results/pred.csv")).unwrap();
    assert!(
        text.starts_with("Y,X,Z,A,C,x,y,z,i,j,k\n") || text.contains(",x,y,z,i,j,k"),
        "{text}"
    );
    assert_eq!(text.lines().count(), 2);
    assert!(temporaries(d).is_empty() && temporaries(&d.join("results")).is_empty());
}

#[cfg(unix)]
#[test]
fn modes_follow_the_umask_and_existing_files_keep_theirs() {
    use std::os::unix::fs::PermissionsExt;
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.csv"), "X,Y,Z,A,C\n1,2,3,4,5\n").unwrap();
    std::fs::write(d.join("kept.csv"), "old\n").unwrap();
    std::fs::set_permissions(d.join("kept.csv"), std::fs::Permissions::from_mode(0o644)).unwrap();
    let m = example("ac-trunnion.toml");
    for (umask, out, want) in [
        ("022", "new022.csv", 0o644),
        ("027", "new027.csv", 0o640),
        ("077", "new077.csv", 0o600),
        ("077", "kept.csv", 0o644),
    ] {
        let script =
            format!("umask {umask}; exec \"$0\" predict --machine \"$1\" --data p.csv --out {out}");
        let o = Command::new("sh")
            .args(["-c", &script, bin(), &m])
            .current_dir(d)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(mode(&d.join(out)), want, "umask {umask}, {out}");
    }
    assert!(
        std::fs::read_to_string(d.join("kept.csv"))
            .unwrap()
            .contains(",x,y,z")
    );
}

#[test]
fn folders_of_several_outputs_are_created_only_on_success() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // ballbar program writes four programs into a new folder.
    let o = mtwin(d, &["ballbar", "program", "--out", "programs/ballbar"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        names(&d.join("programs/ballbar")),
        ["mode1.ngc", "mode2.ngc", "mode3.ngc", "mode4.ngc"]
    );
    // A failing run creates no folder.
    let o = mtwin(
        d,
        &["ballbar", "simulate", "--noise", "-1", "--out", "sim/data"],
    );
    assert_refused(&o, "negative noise");
    assert!(!d.join("sim").exists(), "{:?}", names(d));
}

/// `nohup` (SIGHUP ignored by the parent) keeps working: a SIGHUP does not
/// stop the command.
#[cfg(unix)]
#[test]
fn an_ignored_signal_stays_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    slow_program(d);
    let script = "trap '' HUP; \"$0\" gcode interpolate --machine \"$1\" slow.nc --ts 0.001 --out cmd.csv >/dev/null & \
                  pid=$!; \
                  while ! ls -a | grep -q '^.mtwin-'; do sleep 0.01; done; \
                  kill -HUP $pid; wait $pid; echo \"status $?\"";
    let o = Command::new("sh")
        .args(["-c", script, bin(), &example("ac-trunnion.toml")])
        .current_dir(d)
        .output()
        .unwrap();
    assert_eq!(stdout(&o).trim(), "status 0", "{}", stderr(&o));
    assert_eq!(names(d), ["cmd.csv", "slow.nc"]);
    let lines = std::fs::read_to_string(d.join("cmd.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(lines, 6_000_002 + 1, "header and every sample");
}
