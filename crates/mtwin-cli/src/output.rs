//! Output conventions shared by every subcommand (00 §7): `--format json` prints
//! machine-readable JSON on stdout and nothing else; notes, warnings and progress
//! go to stderr; output files are written atomically.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::ValueEnum;

static QUIET: AtomicBool = AtomicBool::new(false);

/// Silence notes and progress (`--quiet`).
pub fn set_quiet(q: bool) {
    QUIET.store(q, Ordering::Relaxed);
}

/// True under `--quiet`.
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// How a subcommand prints its numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum Format {
    /// Tables and sentences for people.
    #[default]
    Human,
    /// One JSON document on stdout, nothing else on stdout.
    Json,
}

/// A note for the user on stderr (suppressed by `--quiet`).
pub fn note(msg: impl AsRef<str>) {
    if !quiet() {
        eprintln!("note: {}", msg.as_ref());
    }
}

/// A warning on stderr (always shown: it may change how a result is read).
pub fn warn(msg: impl AsRef<str>) {
    eprintln!("warning: {}", msg.as_ref());
}

/// Print an error and its causes on stderr.
pub fn print_error(e: &anyhow::Error) {
    eprintln!("error: {e}");
    for cause in e.chain().skip(1) {
        eprintln!("  caused by: {cause}");
    }
}

/// Print a JSON value on stdout (pretty, one document).
pub fn print_json(v: &serde_json::Value) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}

/// Print a result document: its `Display` text for people, or exactly
/// `serde_json::to_string_pretty(doc)` for `--format json`.
pub fn print_doc<D>(doc: &D, format: Format) -> anyhow::Result<()>
where
    D: serde::Serialize + std::fmt::Display,
{
    match format {
        Format::Json => println!("{}", serde_json::to_string_pretty(doc)?),
        Format::Human => print!("{doc}"),
    }
    Ok(())
}

/// A progress bar on stderr when stderr is a terminal and not `--quiet`; hidden otherwise.
pub fn progress(len: u64, what: &str) -> indicatif::ProgressBar {
    if quiet() || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} ({eta})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

/// A spinner on stderr for work whose length is not known in advance (a
/// program being read, a plan being searched); ticks by itself, hidden when
/// stderr is not a terminal or under `--quiet`. Clear it with
/// `finish_and_clear` before printing results.
pub fn spinner(what: &str) -> indicatif::ProgressBar {
    if quiet() || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new_spinner();
    pb.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    pb.set_message(what.to_string());
    pb.enable_steady_tick(std::time::Duration::from_millis(120));
    pb
}

/// Files at least this large show a progress bar while they are processed
/// (about a second of work for the slowest readers, 1 MB/s).
const PROGRESS_BYTES: u64 = 1 << 20;

/// A buffered reader of `path` that advances a byte progress bar on stderr
/// (shown for files of 1 MB or more, on a terminal, without `--quiet`).
/// Clear the bar with `finish_and_clear` when done.
pub fn open_with_progress(
    path: &std::path::Path,
    what: &str,
) -> anyhow::Result<(
    std::io::BufReader<indicatif::ProgressBarIter<std::fs::File>>,
    indicatif::ProgressBar,
)> {
    use anyhow::Context;
    let f = std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let len = f.metadata().map(|m| m.len()).unwrap_or(0);
    let bar = if len >= PROGRESS_BYTES && !quiet() && std::io::stderr().is_terminal() {
        let pb = indicatif::ProgressBar::new(len);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "{msg:>12} [{bar:40}] {bytes}/{total_bytes} ({eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        pb.set_message(what.to_string());
        pb
    } else {
        indicatif::ProgressBar::hidden()
    };
    Ok((std::io::BufReader::new(bar.wrap_read(f)), bar))
}
