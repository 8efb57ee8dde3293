//! The user guide cannot rot: every page of `docs/` is run by the
//! documentation convention (see `common::run_doc`), each in a fresh empty
//! folder, and the guide's pages must show commands.

mod common;

use common::{repo, run_doc};

fn pages() -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(repo().join("docs"))
        .unwrap()
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            name.ends_with(".md").then_some(name)
        })
        .collect();
    v.sort();
    v
}

#[test]
fn every_page_of_the_guide_runs() {
    let pages = pages();
    assert!(pages.len() >= 9, "{pages:?}");
    // Pages in parallel (each in its own folder): the commands are small.
    let handles: Vec<_> = pages
        .into_iter()
        .map(|page| {
            std::thread::spawn(move || {
                let dir = tempfile::tempdir().unwrap();
                let ran = run_doc(&page, dir.path());
                (page, ran.len())
            })
        })
        .collect();
    let mut failed = Vec::new();
    let mut total = 0;
    for h in handles {
        match h.join() {
            Ok((_, n)) => total += n,
            Err(e) => failed.push(
                e.downcast_ref::<String>()
                    .cloned()
                    .unwrap_or_else(|| "a page panicked".into()),
            ),
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n\n"));
    assert!(total >= 40, "only {total} documented commands ran");
}

#[test]
fn the_guide_pages_show_their_commands() {
    // Pages written as walkthroughs must run at least one command each.
    for page in ["guide.md", "report.md"] {
        let dir = tempfile::tempdir().unwrap();
        let ran = run_doc(page, dir.path());
        assert!(!ran.is_empty(), "docs/{page} runs no command");
    }
}
