//! `mtwin testpiece s-shape` end to end: the documented commands run, the
//! program interpolates within travel, travel violations exit 1 without output.

use crate::common::*;

#[test]
fn docs_walkthrough_runs_and_the_tip_feed_holds() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let ran = run_doc("testpiece.md", p);
    assert_eq!(ran.len(), 5, "{ran:?}");
    // G93 at 600 mm/min: the program's feed time is the tip path over the feed.
    let summary: serde_json::Value = serde_json::from_str(&ran[1].1).unwrap();
    let path = summary["tip_path_mm"].as_f64().unwrap();
    // The document is exactly the library's `SShapeProgramDoc`.
    let doc: mtwin::methods::testpiece::SShapeProgramDoc =
        serde_json::from_str(&ran[1].1).expect("stdout is an SShapeProgramDoc");
    assert_eq!((doc.tip_path_mm, doc.poses), (path, doc.segments + 1));
    // 200 chords of the lower curve are shorter than the curve, by less than
    // the chord error; the curve length (Simpson, independent) bounds them.
    let n = 20000;
    let speed = |s: f64| {
        let dx = 160.0;
        let dy = 20.0 * 2.0 * std::f64::consts::PI * (2.0 * std::f64::consts::PI * (s - 0.5)).cos();
        (dx * dx + dy * dy).sqrt()
    };
    let h = 1.0 / n as f64;
    let curve: f64 = (0..n)
        .map(|i| {
            let a = i as f64 * h;
            h / 6.0 * (speed(a) + 4.0 * speed(a + h / 2.0) + speed(a + h))
        })
        .sum();
    assert!(
        path < curve && path > curve * (1.0 - 1e-3),
        "{path} vs {curve}"
    );
    let stats: serde_json::Value = serde_json::from_str(&ran[2].1).unwrap();
    let feed_time = stats["feed_time_s"].as_f64().unwrap();
    let want = path / 600.0 * 60.0;
    assert!(
        (feed_time - want).abs() < 1e-4 * want,
        "{feed_time} vs {want}"
    );
    for f in ["s.nc", "s93.nc", "s-tcp.nc", "s-tcp.csv"] {
        assert!(p.join(f).exists(), "{f}");
    }
}

#[test]
fn out_of_travel_exits_1_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let machine = example("ac-trunnion.toml");
    let o = mtwin(
        p,
        &[
            "testpiece",
            "s-shape",
            "--machine",
            &machine,
            "--scale",
            "10",
            "--out",
            "big.nc",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("outside its travel"), "{}", stderr(&o));
    assert!(!p.join("big.nc").exists());
    let o = mtwin(p, &["testpiece", "s-shape", "--help"]);
    assert!(stdout(&o).contains("Example:"));
}
