//! The Python package (pyproject.toml, crates/mtwin-py, python/) built and tested
//! from `cargo test`: the wheel is built by maturin into the shared target folder,
//! installed into a virtual environment under it, and `python/tests` run by pytest
//! against the `mtwin` binary of this build (the bit-for-bit comparisons with the CLI).
//!
//! Needs Python 3 (with `venv` and `pip`). Without a `python3`, the test prints why
//! and passes, unless `MTWIN_REQUIRE_PYTHON=1` (set by `.ci/run`), where it fails.
//! `MTWIN_PYTHON` names another interpreter. The virtual environment gets maturin,
//! numpy, pyarrow and pytest from the package index once (or uses those already there).
//!
//! The Spark fleet tests (`python/tests/test_spark.py`, Spark in local mode) run in
//! the same test, beside the rest of the suite (a second pytest process started as
//! soon as the wheel is installed), when the virtual environment has pyspark and Java
//! is on the machine; the test does not install pyspark (a 300 MB download): without
//! it or Java the Spark tests are left out with a message, unless
//! `MTWIN_REQUIRE_SPARK=1` (set by `.ci/run`, which installs both first), where
//! that fails.

use crate::common::*;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

fn require() -> bool {
    std::env::var("MTWIN_REQUIRE_PYTHON").is_ok_and(|v| v == "1")
}

fn require_spark() -> bool {
    std::env::var("MTWIN_REQUIRE_SPARK").is_ok_and(|v| v == "1")
}

/// Why the Spark tests cannot run with the virtual environment's `python`, if they
/// cannot: pyspark missing from it, or no Java (`$JAVA_HOME/bin/java` or `java`).
fn spark_missing(python: &Path) -> Option<String> {
    let pyspark = Command::new(python)
        .args(["-c", "import pyspark, pandas"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !pyspark {
        return Some(format!(
            "pyspark or pandas is not installed in {} \
             (`{} -m pip install \"pyspark>=4,<5\" \"pandas<3\"`)",
            python.display(),
            python.display()
        ));
    }
    let java = std::env::var_os("JAVA_HOME")
        .map(|h| PathBuf::from(h).join("bin/java"))
        .unwrap_or_else(|| "java".into());
    let ok = Command::new(&java)
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    (!ok).then(|| {
        format!(
            "no Java ({} -version fails; pyspark 4 needs Java 17+)",
            java.display()
        )
    })
}

/// `python -m pytest -q` on `args` in the repository, against this build's `mtwin`.
fn pytest(python: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(python);
    c.current_dir(repo())
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .args(args)
        .env("MTWIN_BIN", env!("CARGO_BIN_EXE_mtwin"));
    c
}

/// Check a finished pytest run: it passed and skipped nothing.
fn check_pytest(what: &str, o: &std::process::Output, secs: f64) {
    let out = String::from_utf8_lossy(&o.stdout);
    eprintln!(
        "python: {what} took {secs:.1} s\n{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{what} failed ({})", o.status);
    assert!(
        out.contains(" passed") && !out.contains(" skipped"),
        "every test of {what} must run: {out}"
    );
}

/// The target folder `cargo test` builds into (shared with the wheel build).
fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) => {
            let d = PathBuf::from(d);
            if d.is_absolute() { d } else { repo().join(d) }
        }
        None => repo().join("target"),
    }
}

fn run(cmd: &mut Command, what: &str) {
    let t0 = Instant::now();
    let o = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot start: {e}"));
    eprintln!("python: {what} took {:.1} s", t0.elapsed().as_secs_f64());
    assert!(
        o.status.success(),
        "{what} failed ({}):\n{}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn python() -> Option<String> {
    let py = std::env::var("MTWIN_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&py)
        .args(["-c", "import sys, venv; assert sys.version_info >= (3, 9)"])
        .output()
        .is_ok_and(|o| o.status.success());
    ok.then_some(py)
}

/// A virtual environment under the target folder with what the build and the tests need.
fn venv(py: &str, dir: &Path) -> PathBuf {
    let bin = dir.join("bin/python");
    if !bin.exists() {
        run(
            Command::new(py).args(["-m", "venv"]).arg(dir),
            "python3 -m venv",
        );
    }
    let have = Command::new(&bin)
        .args([
            "-c",
            "import numpy, pytest, pyarrow, shutil, sys; sys.exit(shutil.which('maturin', path=sys.argv[1]) is None)",
        ])
        .arg(dir.join("bin"))
        .output()
        .is_ok_and(|o| o.status.success());
    if !have {
        run(
            Command::new(&bin).args([
                "-m",
                "pip",
                "install",
                "-q",
                "maturin>=1.9,<2",
                "numpy",
                "pytest",
                "pyarrow",
            ]),
            "pip install maturin numpy pytest pyarrow",
        );
    }
    bin
}

#[test]
fn python_package_builds_installs_and_passes_its_tests() {
    let Some(py) = python() else {
        assert!(
            !require(),
            "MTWIN_REQUIRE_PYTHON=1 but no Python 3 with venv (python3 or $MTWIN_PYTHON)"
        );
        eprintln!("SKIPPED python tests: no Python 3 with venv found (set MTWIN_PYTHON)");
        return;
    };
    let target = target_dir();
    let env_dir = target.join("py-venv");
    let bin = venv(&py, &env_dir);
    let wheels = target.join("py-wheels");
    let _ = std::fs::remove_dir_all(&wheels);
    // The wheel is built (dev profile: dependencies at opt-level 2 as for `cargo test`)
    // into the same target folder, so the dependencies `cargo test` compiled are
    // reused where their features agree. (`--profile test` would make cargo build a
    // test harness, not the extension module.)
    let mut maturin = Command::new(env_dir.join("bin/maturin"));
    // `RUSTC_BOOTSTRAP` as this test build had it: cargo keeps it in every unit's
    // fingerprint, so running this binary with it set (libtest's `-Z
    // unstable-options --report-time`) would otherwise rebuild every dependency.
    match option_env!("RUSTC_BOOTSTRAP") {
        Some(v) => maturin.env("RUSTC_BOOTSTRAP", v),
        None => maturin.env_remove("RUSTC_BOOTSTRAP"),
    };
    run(
        maturin
            .current_dir(repo())
            // `align-test-build`: the same dependency features as this test build, so
            // that the library and its dependencies are not compiled a second time.
            .args(["build", "--features", "align-test-build", "--interpreter"])
            .arg(&bin)
            .arg("--out")
            .arg(&wheels)
            .env("CARGO_TARGET_DIR", &target)
            .env("VIRTUAL_ENV", &env_dir),
        "maturin build (the wheel)",
    );
    let wheel = std::fs::read_dir(&wheels)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "whl"))
        .expect("maturin wrote a wheel");
    let name = wheel.file_name().unwrap().to_string_lossy().into_owned();
    assert!(name.contains("abi3"), "not an abi3 wheel: {name}");
    run(
        Command::new(&bin)
            .args([
                "-m",
                "pip",
                "install",
                "-q",
                "--no-deps",
                "--force-reinstall",
            ])
            .arg(&wheel),
        "pip install the wheel",
    );
    // The Spark tests start first, in their own pytest process: most of their time
    // is the JVM's and Spark's start-up, which then overlaps the rest of the suite.
    let spark = match spark_missing(&bin) {
        None => {
            // Its output goes to files (read at the end), so that a full pipe never
            // holds it up while the other run goes on.
            let log = |ext: &str| {
                let p = target.join(format!("py-spark-pytest.{ext}"));
                (std::fs::File::create(&p).unwrap(), p)
            };
            let ((out, out_path), (err, err_path)) = (log("out"), log("err"));
            let child = pytest(&bin, &["python/tests/test_spark.py"])
                .env("MTWIN_REQUIRE_SPARK", "1")
                .stdout(out)
                .stderr(err)
                .spawn()
                .expect("pytest (Spark) starts");
            Some((child, Instant::now(), out_path, err_path))
        }
        Some(why) => {
            assert!(!require_spark(), "MTWIN_REQUIRE_SPARK=1 but {why}");
            eprintln!("SKIPPED the Spark fleet tests (python/tests/test_spark.py): {why}");
            None
        }
    };
    let t0 = Instant::now();
    let o = pytest(
        &bin,
        &["python/tests", "--ignore=python/tests/test_spark.py"],
    )
    .output()
    .expect("pytest runs");
    let secs = t0.elapsed().as_secs_f64();
    // (The Spark run is waited for before either is checked: no process left behind.)
    let spark = spark.map(|(mut child, t0, out_path, err_path)| {
        let status = child.wait().expect("pytest (Spark) finishes");
        let o = std::process::Output {
            status,
            stdout: std::fs::read(out_path).unwrap(),
            stderr: std::fs::read(err_path).unwrap(),
        };
        (o, t0.elapsed().as_secs_f64())
    });
    check_pytest("pytest python/tests", &o, secs);
    if let Some((o, secs)) = spark {
        check_pytest("pytest python/tests/test_spark.py", &o, secs);
    }
}
