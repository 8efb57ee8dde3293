//! Output conventions shared by every subcommand (see docs/guide.md): `--format json` prints
//! machine-readable JSON on stdout and nothing else; notes, warnings and progress
//! go to stderr; output files are written all-or-nothing (`mtwin::io::Outputs`).
//!
//! Standard output is written only through [`print_out`] / [`write_stdout`]
//! (the crate's `print!`/`println!` call them): a closed pipe there ends the
//! command quietly with [`EXIT_CLOSED_PIPE`], after removing the temporary
//! files of unfinished outputs. SIGINT, SIGTERM and SIGHUP remove them too,
//! then end the process by the signal ([`remove_temporaries_on_signals`]).

use std::io::{IsTerminal, Write};
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
    // A cause whose text the message above already holds (an error that
    // shows its source's message) is not repeated.
    let mut shown = e.to_string();
    for cause in e.chain().skip(1) {
        let text = cause.to_string();
        if !shown.contains(&text) {
            eprintln!("  caused by: {text}");
            shown = text;
        }
    }
}

/// Exit status when standard output is a closed pipe (`mtwin … | head -1`):
/// 128 + SIGPIPE, what a shell reports for a program that the closed pipe
/// killed, so `set -o pipefail` scripts see that the results were cut short.
pub const EXIT_CLOSED_PIPE: u8 = 141;

/// Write printed results on stdout. A closed pipe ends the process quietly
/// with [`EXIT_CLOSED_PIPE`]; any other failure to write prints one error and
/// exits 1; temporary output files are removed first either way. When an
/// output file is stdout itself (`--out -`), printed results go to stderr so
/// that stdout carries the file alone.
pub fn print_out(args: std::fmt::Arguments<'_>) {
    if mtwin::io::stdout_is_output() {
        print_err(args);
        return;
    }
    if let Err(e) = std::io::stdout().lock().write_fmt(args) {
        stdout_failed(e);
    }
}

/// Write raw bytes on stdout, as [`print_out`].
pub fn write_stdout(bytes: &[u8]) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(bytes).and_then(|()| out.flush()) {
        stdout_failed(e);
    }
}

/// Flush what is still buffered for stdout (before the exit status is chosen).
pub fn flush_stdout() {
    if let Err(e) = std::io::stdout().lock().flush() {
        stdout_failed(e);
    }
}

fn stdout_failed(e: std::io::Error) -> ! {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        mtwin::io::remove_temporaries_and_exit(i32::from(EXIT_CLOSED_PIPE));
    }
    print_err(format_args!(
        "error: cannot write to standard output: {e}\n"
    ));
    mtwin::io::remove_temporaries_and_exit(1)
}

/// Write on stderr; a failure to (a closed pipe) is ignored: there is nowhere
/// left to report it.
pub fn print_err(args: std::fmt::Arguments<'_>) {
    let _ = std::io::stderr().lock().write_fmt(args);
}

/// True when a command failed because its standard output (or an output
/// FIFO) is a closed pipe: the command then ends quietly.
pub fn is_closed_pipe(e: &anyhow::Error) -> bool {
    mtwin::io::stdout_closed()
        || e.chain().any(|c| {
            c.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
        })
}

/// Catch SIGINT, SIGTERM and SIGHUP on a thread of their own: remove the
/// temporary files (and created folders) of unfinished outputs, then end the
/// process by the same signal with its default action, so that a shell
/// reports 130, 143 or 129 and a script stops on Ctrl-C as it would for any
/// program (exit 128 + the signal number should that fail). An output
/// already being renamed into place finishes first, so a signal never leaves
/// part of a command's outputs replaced.
pub fn remove_temporaries_on_signals() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        // A signal the process was started with ignored (`nohup`, SIGINT for
        // a script's background job) stays ignored.
        let caught: Vec<i32> = [SIGINT, SIGTERM, SIGHUP]
            .into_iter()
            .filter(|&s| !ignored(s))
            .collect();
        let (ready, wait) = std::sync::mpsc::channel();
        // The handlers are registered on the thread itself, so a thread that
        // cannot be started leaves the default actions in place.
        let spawned = std::thread::Builder::new()
            .name("signals".into())
            .spawn(move || {
                let signals = signal_hook::iterator::Signals::new(&caught);
                let _ = ready.send(());
                if let Ok(mut signals) = signals
                    && let Some(sig) = signals.forever().next()
                {
                    mtwin::io::remove_temporaries_then_exit(
                        || {
                            let _ = signal_hook::low_level::emulate_default_handler(sig);
                        },
                        128 + sig,
                    );
                }
            });
        if spawned.is_ok() {
            let _ = wait.recv();
        }
    }
}

/// True when `sig` is ignored (inherited from the parent).
#[cfg(unix)]
fn ignored(sig: i32) -> bool {
    // SAFETY: `sigaction` with a null new action only reads the current
    // disposition into `old`, a valid, zero-initialised (plain C data)
    // out-parameter.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(sig, std::ptr::null(), &mut old) == 0 && old.sa_sigaction == libc::SIG_IGN
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

/// Rows per Parquet row group (about 5 MB of a 13-column table): bounds the
/// memory of a long table while keeping the groups large enough to read fast.
const PARQUET_ROW_GROUP: usize = 1 << 16;

/// True when `path` names a Parquet file (`.parquet`, any case): tables are
/// then written as Parquet instead of CSV.
pub fn is_parquet(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}

/// A table of numbers written row by row: CSV (a header line, then the rows
/// with shortest round-trip numbers) or, for a `.parquet` output, Parquet
/// with one required float64 column per CSV column, of the same names and
/// values bit for bit (uncompressed; rows in groups of 65 536).
pub enum TableWriter<'w> {
    /// CSV text.
    Csv(&'w mut dyn Write),
    /// Parquet: the columns of the current row group, flushed to `out` group by group.
    Parquet {
        out: &'w mut dyn Write,
        file: Box<parquet::file::writer::SerializedFileWriter<Vec<u8>>>,
        columns: Vec<Vec<f64>>,
    },
}

fn parquet_error(e: parquet::errors::ParquetError) -> std::io::Error {
    std::io::Error::other(format!("Parquet: {e}"))
}

impl<'w> TableWriter<'w> {
    /// Start the table `path` (its extension chooses the format) with the
    /// column names `columns` on `out`.
    pub fn new(
        path: &std::path::Path,
        out: &'w mut dyn Write,
        columns: &[&str],
    ) -> std::io::Result<Self> {
        if !is_parquet(path) {
            writeln!(out, "{}", columns.join(","))?;
            return Ok(TableWriter::Csv(out));
        }
        use parquet::basic::{Repetition, Type as Physical};
        use parquet::schema::types::Type;
        use std::sync::Arc;
        let fields = columns
            .iter()
            .map(|name| {
                Type::primitive_type_builder(name, Physical::DOUBLE)
                    .with_repetition(Repetition::REQUIRED)
                    .build()
                    .map(Arc::new)
            })
            .collect::<Result<Vec<_>, _>>()
            .map_err(parquet_error)?;
        let schema = Type::group_type_builder("schema")
            .with_fields(fields)
            .build()
            .map_err(parquet_error)?;
        let props = parquet::file::properties::WriterProperties::builder()
            .set_dictionary_enabled(false)
            .set_created_by(format!("mtwin {}", env!("CARGO_PKG_VERSION")))
            .build();
        let file = parquet::file::writer::SerializedFileWriter::new(
            Vec::new(),
            Arc::new(schema),
            Arc::new(props),
        )
        .map_err(parquet_error)?;
        Ok(TableWriter::Parquet {
            out,
            file: Box::new(file),
            columns: vec![Vec::with_capacity(PARQUET_ROW_GROUP); columns.len()],
        })
    }

    /// Write one row (as many values as columns).
    pub fn row(&mut self, values: &[f64]) -> std::io::Result<()> {
        match self {
            TableWriter::Csv(w) => mtwin::io::write_csv_row(*w, values),
            TableWriter::Parquet { columns, .. } => {
                debug_assert_eq!(values.len(), columns.len());
                for (c, v) in columns.iter_mut().zip(values) {
                    c.push(*v);
                }
                if columns
                    .first()
                    .is_some_and(|c| c.len() >= PARQUET_ROW_GROUP)
                {
                    self.flush_group()?;
                }
                Ok(())
            }
        }
    }

    /// Write the buffered rows as one row group and pass its bytes on.
    fn flush_group(&mut self) -> std::io::Result<()> {
        let TableWriter::Parquet { out, file, columns } = self else {
            return Ok(());
        };
        if columns.first().is_none_or(|c| c.is_empty()) {
            return Ok(());
        }
        let mut group = file.next_row_group().map_err(parquet_error)?;
        for c in columns.iter_mut() {
            let mut col = group
                .next_column()
                .map_err(parquet_error)?
                .ok_or_else(|| std::io::Error::other("Parquet: fewer columns than values"))?;
            col.typed::<parquet::data_type::DoubleType>()
                .write_batch(c, None, None)
                .map_err(parquet_error)?;
            col.close().map_err(parquet_error)?;
            c.clear();
        }
        group.close().map_err(parquet_error)?;
        file.flush()?;
        // The writer counts the bytes itself: taking them out of its buffer
        // leaves its offsets right.
        out.write_all(&std::mem::take(file.inner_mut()))
    }

    /// End the table (a Parquet file gets its last row group and its footer).
    pub fn finish(mut self) -> std::io::Result<()> {
        self.flush_group()?;
        match self {
            TableWriter::Csv(_) => Ok(()),
            TableWriter::Parquet { out, file, .. } => {
                let rest = (*file).into_inner().map_err(parquet_error)?;
                out.write_all(&rest)
            }
        }
    }
}
