//! `mtwin model check`: exit codes, messages with line numbers, JSON.

use crate::common::*;

#[test]
fn good_file_passes_with_a_summary() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(
        dir.path(),
        &["model", "check", &example("ac-trunnion-with-errors.toml")],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let s = stdout(&o);
    assert!(
        s.contains("OK")
            && s.contains("M → Y → X → Z → T")
            && s.contains("41 geometric error terms"),
        "{s}"
    );
}

#[test]
fn json_is_the_only_stdout() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "model",
            "check",
            &example("afp-gantry.toml"),
            "--format",
            "json",
        ],
    );
    assert_eq!(o.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        v["tool_chain"],
        serde_json::json!(["X", "Y", "Z", "B", "A", "C"])
    );
    assert_eq!(v["workpiece_chain"], serde_json::json!([]));
    assert_eq!(v["axes"].as_array().unwrap().len(), 6);
    // The document is exactly the library's `ModelCheckDoc`.
    let doc: mtwin::model::ModelCheckDoc = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(doc.axes.len(), 6);
    assert!(doc.workpiece_chain.is_empty() && doc.ok);
}

#[test]
fn bad_file_names_file_and_line_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(example("ac-trunnion.toml")).unwrap();
    let bad = text
        .replacen(
            "direction = [1.0, 0.0, 0.0]",
            "direction = [1.0, 0.5, 0.0]",
            1,
        )
        .replacen(
            "max_velocity = 500.0           # mm/s",
            "max_velocity = 500.0\nspeed = 3",
            1,
        );
    let p = dir.path().join("bad.toml");
    std::fs::write(&p, &bad).unwrap();
    let line_of = |needle: &str| bad.lines().position(|l| l.contains(needle)).unwrap() + 1;
    let o = mtwin(dir.path(), &["model", "check", "bad.toml"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains(&format!("bad.toml:{}:", line_of("[1.0, 0.5, 0.0]")))
            && e.contains("unit vector"),
        "{e}"
    );
    assert!(
        e.contains(&format!("bad.toml:{}:", line_of("speed = 3")))
            && e.contains("unknown key `speed`"),
        "{e}"
    );
    assert!(stdout(&o).is_empty());
}

#[test]
fn usage_errors_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(dir.path(), &["model", "check"]);
    assert_eq!(o.status.code(), Some(2));
    let o = mtwin(dir.path(), &["no-such-command"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn missing_file_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = mtwin(dir.path(), &["model", "check", "nope.toml"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("nope.toml") && stderr(&o).contains("cannot read"));
}
