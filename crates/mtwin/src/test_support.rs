//! Helpers shared by the unit tests. The integration-test binaries of both
//! crates include this file too (`#[path]`), so it must stay self-contained:
//! std only, nothing from the crate.

use std::path::PathBuf;

/// `rel` inside `../shared` (the real data and G-code corpus kept beside the
/// repository), or `None` with a skip note on stderr when it is absent. In CI
/// (`CI` or `MTWIN_REQUIRE_SHARED` set, as `.ci/run` does) an absent folder
/// fails the test instead, so the tests that read real data cannot pass by
/// skipping.
pub(crate) fn shared_dir(rel: &str) -> Option<PathBuf> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared")
        .join(rel);
    let required = ["MTWIN_REQUIRE_SHARED", "CI"]
        .into_iter()
        .find(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty() && s != "0" && s != "false"));
    present_or_skip(path, required)
}

/// `path` if it exists; else a panic naming `required` (the variable that
/// demands the data) or, without one, `None` and a skip note on stderr.
fn present_or_skip(path: PathBuf, required: Option<&str>) -> Option<PathBuf> {
    if path.exists() {
        return Some(path);
    }
    if let Some(var) = required {
        panic!(
            "{var} is set but {} is absent: clone the shared data beside the repository",
            path.display()
        );
    }
    eprintln!(
        "skipped: {} is absent (set MTWIN_REQUIRE_SHARED=1 to make this a failure)",
        path.display()
    );
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absent_shared_data_skips_or_fails_as_required() {
        let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        assert_eq!(
            present_or_skip(here.clone(), Some("CI")),
            Some(here.clone())
        );
        let absent = here.join("no-such-folder");
        assert_eq!(present_or_skip(absent.clone(), None), None);
        let r = std::panic::catch_unwind(|| present_or_skip(absent, Some("MTWIN_REQUIRE_SHARED")));
        assert!(r.is_err(), "a required absent folder must fail the test");
    }
}
