//! All-or-nothing output files.
//!
//! A command declares its inputs and every output up front ([`Outputs::plan`]);
//! [`Plan::begin`] refuses, before any work, an output that is the same file
//! as an input (same device and inode, so through hard links and symbolic
//! links too), an output given twice, and an output whose folder does not
//! exist. Each output file is then written to a temporary file
//! `.mtwin-XXXXXX.tmp` in its target's folder, and [`Outputs::commit`]
//! renames them all only once every one is complete. Dropping an uncommitted
//! [`Outputs`] (an error, a `?`) removes the temporaries; a program that
//! handles SIGINT/SIGTERM calls [`remove_temporaries_and_exit`] to do the same
//! from its signal handler.
//!
//! How a target is written:
//!
//! * `-`, `/dev/stdout` (`/dev/fd/1`, `/proc/self/fd/1`): streamed to
//!   standard output; `/dev/stderr` likewise to standard error;
//! * an existing character or block device, FIFO or socket, and any path
//!   under `/dev/fd/` or `/proc/`: opened and written in place (streamed, no
//!   temporary file: a device cannot be replaced by a file);
//! * a symbolic link: followed, the final target is replaced, the link kept;
//! * a regular file: replaced by rename; an existing file keeps its
//!   permission bits (and owner and group where allowed), a new file gets
//!   `0666 & !umask` like any file a shell redirection creates.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// Temporary files and created folders of every uncommitted [`Outputs`] of
/// the process, for [`remove_temporaries_and_exit`].
struct Live {
    files: Vec<PathBuf>,
    dirs: Vec<PathBuf>,
}

static LIVE: Mutex<Live> = Mutex::new(Live {
    files: Vec::new(),
    dirs: Vec::new(),
});

fn live() -> MutexGuard<'static, Live> {
    LIVE.lock().unwrap_or_else(PoisonError::into_inner)
}

fn forget(list: &mut Vec<PathBuf>, p: &Path) {
    if let Some(i) = list.iter().rposition(|q| q == p) {
        list.swap_remove(i);
    }
}

static STDOUT_IS_OUTPUT: AtomicBool = AtomicBool::new(false);
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Remove every temporary file and every folder created for an uncommitted
/// [`Outputs`] of this process, then exit with `code`. Meant for a closed
/// standard output; see [`remove_temporaries_then_exit`].
pub fn remove_temporaries_and_exit(code: i32) -> ! {
    remove_temporaries_then_exit(|| {}, code)
}

/// Remove every temporary file and every folder created for an uncommitted
/// [`Outputs`] of this process, run `end` (which may end the process, e.g.
/// by raising a signal again with its default action), then exit with
/// `code`. Meant for a signal handler thread. The registry stays locked until
/// the process is gone, so no commit can start (or be half done) after the
/// clean-up: a commit already under way finishes first, and its outputs are
/// then complete.
pub fn remove_temporaries_then_exit(end: impl FnOnce(), code: i32) -> ! {
    let mut g = live();
    for f in g.files.drain(..) {
        let _ = fs::remove_file(&f);
    }
    for d in g.dirs.drain(..).rev() {
        let _ = fs::remove_dir(&d);
    }
    end();
    std::process::exit(code)
}

/// True once an [`Outputs`] of this process has standard output as one of
/// its outputs (`--out -`): printed results then belong on standard error.
pub fn stdout_is_output() -> bool {
    STDOUT_IS_OUTPUT.load(Ordering::Relaxed)
}

/// True once an output streamed to standard output met a closed pipe.
pub fn stdout_closed() -> bool {
    STDOUT_CLOSED.load(Ordering::Relaxed)
}

/// The inputs and outputs of one command, before any work: see
/// [`Outputs::plan`].
#[derive(Debug, Default, Clone)]
pub struct Plan {
    inputs: Vec<PathBuf>,
    outputs: Vec<PathBuf>,
    folders: Vec<PathBuf>,
}

impl Plan {
    /// A file (or folder) the command reads. Inputs that do not exist are
    /// ignored here (the reader reports them).
    pub fn input(mut self, path: impl AsRef<Path>) -> Self {
        self.inputs.push(path.as_ref().to_path_buf());
        self
    }

    /// Several inputs (`Option<PathBuf>` works too: `.inputs(a.machine.as_ref())`).
    pub fn inputs<P: AsRef<Path>>(mut self, paths: impl IntoIterator<Item = P>) -> Self {
        self.inputs
            .extend(paths.into_iter().map(|p| p.as_ref().to_path_buf()));
        self
    }

    /// A file the command writes, exactly as it will be passed to
    /// [`Outputs::write_with`].
    pub fn output(mut self, path: impl AsRef<Path>) -> Self {
        self.outputs.push(path.as_ref().to_path_buf());
        self
    }

    /// Several outputs (`.outputs(a.plot.as_ref())` for an optional one).
    pub fn outputs<P: AsRef<Path>>(mut self, paths: impl IntoIterator<Item = P>) -> Self {
        self.outputs
            .extend(paths.into_iter().map(|p| p.as_ref().to_path_buf()));
        self
    }

    /// A folder for outputs, created (with its missing parents) by
    /// [`Plan::begin`] if absent, and removed again if the outputs are not
    /// committed and it is still empty.
    pub fn folder(mut self, path: impl AsRef<Path>) -> Self {
        self.folders.push(path.as_ref().to_path_buf());
        self
    }

    /// Several folders (`.folders(&a.plot)` for an optional one).
    pub fn folders<P: AsRef<Path>>(mut self, paths: impl IntoIterator<Item = P>) -> Self {
        self.folders
            .extend(paths.into_iter().map(|p| p.as_ref().to_path_buf()));
        self
    }

    /// Check every output against the inputs and the file system, then
    /// create the declared folders and one temporary file per output file.
    /// Nothing is created when a check fails.
    pub fn begin(self) -> io::Result<Outputs> {
        // 1. Folders: each existing one must be a folder, each missing one creatable.
        let mut to_create: Vec<PathBuf> = Vec::new();
        for f in &self.folders {
            match fs::metadata(f) {
                Ok(m) if m.is_dir() => {}
                Ok(_) => {
                    return Err(refuse(format!(
                        "{} exists and is not a folder",
                        f.display()
                    )));
                }
                Err(_) => {
                    let mut missing = vec![f.clone()];
                    let mut cur = f.as_path();
                    while let Some(parent) = cur.parent().filter(|p| !p.as_os_str().is_empty()) {
                        match fs::metadata(parent) {
                            Ok(m) if m.is_dir() => break,
                            Ok(_) => {
                                return Err(refuse(format!(
                                    "cannot create the folder {}: {} is not a folder",
                                    f.display(),
                                    parent.display()
                                )));
                            }
                            Err(_) => missing.push(parent.to_path_buf()),
                        }
                        cur = parent;
                    }
                    for m in missing.into_iter().rev() {
                        if !to_create.contains(&m) {
                            to_create.push(m);
                        }
                    }
                }
            }
        }

        // 2. Inputs: their identities.
        let inputs: Vec<(PathBuf, FileId)> = self
            .inputs
            .iter()
            .filter_map(|p| Some((p.clone(), FileId::of(p)?)))
            .collect();

        // 3. Outputs: what each is, refused if it is an input or given twice.
        let mut targets: Vec<Target> = Vec::with_capacity(self.outputs.len());
        for given in &self.outputs {
            let kind = classify(given, &to_create)?;
            if let Some(id) = FileId::of(given)
                && matches!(kind, Kind::File { .. })
                && let Some((input, _)) = inputs.iter().find(|(_, i)| *i == id)
            {
                return Err(refuse(format!(
                    "refusing to write {}: it is the same file as the input {}; choose another output",
                    given.display(),
                    input.display()
                )));
            }
            for t in &targets {
                if kind.same_target(&t.kind) {
                    return Err(refuse(format!(
                        "{} and {} are the same output file; give each output its own file",
                        t.given.display(),
                        given.display()
                    )));
                }
            }
            targets.push(Target {
                given: given.clone(),
                kind,
            });
        }

        // 4. Create the folders, then the temporaries.
        let mut out = Outputs {
            targets: Vec::new(),
            created_dirs: Vec::new(),
            committed: false,
        };
        for d in to_create {
            let mut g = live();
            match fs::create_dir(&d) {
                Ok(()) => {
                    g.dirs.push(d.clone());
                    out.created_dirs.push(d);
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && d.is_dir() => {}
                Err(e) => {
                    return Err(io::Error::new(
                        e.kind(),
                        format!("cannot create the folder {}: {e}", d.display()),
                    ));
                }
            }
        }
        for mut t in targets {
            if let Kind::File { path, tmp, .. } = &mut t.kind {
                *tmp = Some(Temp::create(path).map_err(|e| {
                    io::Error::new(e.kind(), format!("cannot write {}: {e}", t.given.display()))
                })?);
            }
            if matches!(t.kind, Kind::Stdout) {
                STDOUT_IS_OUTPUT.store(true, Ordering::Relaxed);
            }
            out.targets.push(t);
        }
        Ok(out)
    }
}

fn refuse(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

/// The outputs of one command, written all-or-nothing (see the module
/// documentation).
#[derive(Debug)]
pub struct Outputs {
    targets: Vec<Target>,
    created_dirs: Vec<PathBuf>,
    committed: bool,
}

#[derive(Debug)]
struct Target {
    given: PathBuf,
    kind: Kind,
}

#[derive(Debug)]
enum Kind {
    /// Standard output.
    Stdout,
    /// Standard error.
    Stderr,
    /// A device, FIFO or socket: opened and written in place.
    Stream(PathBuf),
    /// A regular file (new or existing) at `path` (symbolic links resolved).
    File {
        path: PathBuf,
        /// Permission bits, owner and group of the file being replaced.
        existing: Option<Existing>,
        tmp: Option<Temp>,
        written: bool,
    },
}

#[derive(Debug, Clone, Copy)]
struct Existing {
    #[cfg(unix)]
    mode: u32,
    #[cfg(unix)]
    uid: u32,
    #[cfg(unix)]
    gid: u32,
}

impl Kind {
    fn same_target(&self, other: &Kind) -> bool {
        match (self, other) {
            (Kind::Stdout, Kind::Stdout) => true,
            (Kind::File { path: a, .. }, Kind::File { path: b, .. }) => {
                same_path(a, b)
                    || matches!((FileId::of(a), FileId::of(b)), (Some(x), Some(y)) if x == y)
            }
            _ => false,
        }
    }
}

/// Two paths naming the same directory entry (their folders canonicalised).
fn same_path(a: &Path, b: &Path) -> bool {
    let norm = |p: &Path| {
        let dir = folder_of(p);
        let dir = fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
        dir.join(p.file_name().unwrap_or_default())
    };
    a == b || norm(a) == norm(b)
}

fn folder_of(p: &Path) -> &Path {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

const STDOUT_NAMES: [&str; 4] = ["-", "/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"];
const STDERR_NAMES: [&str; 3] = ["/dev/stderr", "/dev/fd/2", "/proc/self/fd/2"];

fn classify(given: &Path, to_create: &[PathBuf]) -> io::Result<Kind> {
    if STDOUT_NAMES.iter().any(|n| given == Path::new(n)) {
        return Ok(Kind::Stdout);
    }
    if STDERR_NAMES.iter().any(|n| given == Path::new(n)) {
        return Ok(Kind::Stderr);
    }
    if given.starts_with("/dev/fd") || given.starts_with("/proc") {
        return Ok(Kind::Stream(given.to_path_buf()));
    }
    if let Ok(m) = fs::metadata(given) {
        if m.is_dir() {
            return Err(refuse(format!(
                "cannot write {}: it is a folder, not a file",
                given.display()
            )));
        }
        if !m.is_file() {
            return Ok(Kind::Stream(given.to_path_buf()));
        }
    }
    let path = resolve_links(given)?;
    let dir = folder_of(&path);
    let dir_ok = match fs::metadata(dir) {
        Ok(m) => m.is_dir(),
        Err(_) => to_create.iter().any(|c| same_path_lexically(c, dir)),
    };
    if !dir_ok {
        return Err(refuse(format!(
            "cannot write {}: the folder {} does not exist",
            given.display(),
            dir.display()
        )));
    }
    let existing = fs::metadata(&path).ok().map(|m| existing_of(&m));
    Ok(Kind::File {
        path,
        existing,
        tmp: None,
        written: false,
    })
}

fn same_path_lexically(a: &Path, b: &Path) -> bool {
    a.components().eq(b.components())
}

#[cfg(unix)]
fn existing_of(m: &fs::Metadata) -> Existing {
    use std::os::unix::fs::MetadataExt;
    Existing {
        mode: m.mode() & 0o777,
        uid: m.uid(),
        gid: m.gid(),
    }
}

#[cfg(not(unix))]
fn existing_of(_: &fs::Metadata) -> Existing {
    Existing {}
}

/// The final target of a chain of symbolic links (the path itself when it
/// is not a link; a dangling link's target, to be created).
fn resolve_links(given: &Path) -> io::Result<PathBuf> {
    let mut cur = given.to_path_buf();
    for _ in 0..40 {
        match fs::symlink_metadata(&cur) {
            Ok(m) if m.file_type().is_symlink() => {
                let to = fs::read_link(&cur)?;
                cur = if to.is_absolute() {
                    to
                } else {
                    folder_of(&cur).join(to)
                };
            }
            _ => return Ok(cur),
        }
    }
    Err(refuse(format!(
        "cannot write {}: too many levels of symbolic links",
        given.display()
    )))
}

/// Identity of a file: device and inode (through links).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct FileId {
    dev: u64,
    ino: u64,
}

impl FileId {
    #[cfg(unix)]
    fn of(p: &Path) -> Option<FileId> {
        use std::os::unix::fs::MetadataExt;
        let m = fs::metadata(p).ok()?;
        Some(FileId {
            dev: m.dev(),
            ino: m.ino(),
        })
    }

    #[cfg(not(unix))]
    fn of(p: &Path) -> Option<FileId> {
        use std::hash::{Hash, Hasher};
        let c = fs::canonicalize(p).ok()?;
        let mut h = std::collections::hash_map::DefaultHasher::new();
        c.hash(&mut h);
        Some(FileId {
            dev: 0,
            ino: h.finish(),
        })
    }
}

/// A registered temporary file, removed when dropped unless renamed.
#[derive(Debug)]
struct Temp {
    path: Option<PathBuf>,
    file: File,
}

impl Temp {
    fn create(target: &Path) -> io::Result<Temp> {
        let mut b = tempfile::Builder::new();
        b.prefix(".mtwin-").suffix(".tmp");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // The kernel applies the umask to this mode, as for `>` in a shell.
            b.permissions(fs::Permissions::from_mode(0o666));
        }
        let mut g = live();
        let (file, path) = b
            .tempfile_in(folder_of(target))?
            .keep()
            .map_err(|e| e.error)?;
        g.files.push(path.clone());
        Ok(Temp {
            path: Some(path),
            file,
        })
    }

    /// Rename onto `target`; the caller holds the registry.
    fn rename(&mut self, target: &Path, g: &mut Live) -> io::Result<()> {
        if let Some(p) = &self.path {
            fs::rename(p, target)?;
            forget(&mut g.files, p);
            self.path = None;
        }
        Ok(())
    }

    /// Remove; the caller holds the registry.
    fn remove(&mut self, g: &mut Live) {
        if let Some(p) = self.path.take() {
            let _ = fs::remove_file(&p);
            forget(&mut g.files, &p);
        }
    }
}

impl Drop for Temp {
    fn drop(&mut self) {
        if self.path.is_some() {
            let mut g = live();
            self.remove(&mut g);
        }
    }
}

/// Sets [`stdout_closed`] when standard output meets a closed pipe.
struct StdoutWriter<W: Write>(W);

fn note_closed<T>(r: io::Result<T>) -> io::Result<T> {
    if let Err(e) = &r
        && e.kind() == io::ErrorKind::BrokenPipe
    {
        STDOUT_CLOSED.store(true, Ordering::Relaxed);
    }
    r
}

impl<W: Write> Write for StdoutWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        note_closed(self.0.write(buf))
    }
    fn flush(&mut self) -> io::Result<()> {
        note_closed(self.0.flush())
    }
}

fn fill_and_flush<W: Write, E: From<io::Error>>(
    w: W,
    fill: impl FnOnce(&mut dyn Write) -> Result<(), E>,
) -> Result<(), E> {
    let mut w = BufWriter::with_capacity(1 << 16, w);
    fill(&mut w)?;
    w.flush()?;
    Ok(())
}

impl Outputs {
    /// Start declaring a command's inputs and outputs.
    ///
    /// ```no_run
    /// # fn main() -> std::io::Result<()> {
    /// use std::io::Write;
    /// let mut out = mtwin::io::Outputs::plan()
    ///     .input("poses.csv")
    ///     .output("pred.csv")
    ///     .output("pred.svg")
    ///     .begin()?; // refused here if pred.csv is poses.csv
    /// out.write_with("pred.csv", |w| w.write_all(b"x,y\n"))?;
    /// out.write("pred.svg", b"<svg/>")?;
    /// out.commit()?; // both appear, or neither
    /// # Ok(()) }
    /// ```
    pub fn plan() -> Plan {
        Plan::default()
    }

    /// Write the content of the declared output `path` (the same path as
    /// given to [`Plan::output`]). A file is staged in its temporary file
    /// (writing it again replaces the staged content); a stream is written
    /// now.
    pub fn write_with<E: From<io::Error>>(
        &mut self,
        path: impl AsRef<Path>,
        fill: impl FnOnce(&mut dyn Write) -> Result<(), E>,
    ) -> Result<(), E> {
        let path = path.as_ref();
        let Some(t) = self.targets.iter_mut().find(|t| t.given == path) else {
            return Err(io::Error::other(format!(
                "{} was not declared as an output of this command",
                path.display()
            ))
            .into());
        };
        match &mut t.kind {
            Kind::Stdout => fill_and_flush(StdoutWriter(io::stdout().lock()), fill),
            Kind::Stderr => fill_and_flush(io::stderr().lock(), fill),
            Kind::Stream(p) => {
                let f = OpenOptions::new().write(true).open(p)?;
                fill_and_flush(f, fill)
            }
            Kind::File { tmp, written, .. } => {
                let Some(tmp) = tmp else {
                    return Err(io::Error::other("output already committed").into());
                };
                *written = false;
                if tmp.file.metadata()?.len() > 0 {
                    use std::io::Seek;
                    tmp.file.set_len(0)?;
                    tmp.file.rewind()?;
                }
                fill_and_flush(&tmp.file, fill)?;
                *written = true;
                Ok(())
            }
        }
    }

    /// The content staged so far for the declared output file `path` (for a
    /// command whose later step reads what an earlier one wrote).
    pub fn staged(&self, path: impl AsRef<Path>) -> io::Result<Vec<u8>> {
        let path = path.as_ref();
        match self
            .targets
            .iter()
            .find(|t| t.given == path)
            .map(|t| &t.kind)
        {
            Some(Kind::File {
                tmp: Some(Temp { path: Some(p), .. }),
                written: true,
                ..
            }) => fs::read(p),
            _ => Err(io::Error::new(
                io::ErrorKind::NotFound,
                format!("{} has not been written yet", path.display()),
            )),
        }
    }

    /// Write `bytes` as the content of the declared output `path`.
    pub fn write(&mut self, path: impl AsRef<Path>, bytes: &[u8]) -> io::Result<()> {
        self.write_with(path, |w| w.write_all(bytes))
    }

    /// Replace every written output file by its temporary file. Declared
    /// files that were not written are left as they were. The renames run
    /// with the registry held, so a signal arriving meanwhile waits for them.
    pub fn commit(mut self) -> io::Result<()> {
        let mut g = live();
        let mut result = Ok(());
        let mut renamed: Vec<String> = Vec::new();
        for t in &mut self.targets {
            let Kind::File {
                path,
                existing,
                tmp: Some(tmp),
                written,
            } = &mut t.kind
            else {
                continue;
            };
            if !*written || result.is_err() {
                tmp.remove(&mut g);
                continue;
            }
            if let Some(e) = existing {
                e.apply(&tmp.file);
            }
            if let Err(e) = tmp.rename(path, &mut g) {
                let done = if renamed.is_empty() {
                    String::new()
                } else {
                    format!(" (already written: {})", renamed.join(", "))
                };
                result = Err(io::Error::new(
                    e.kind(),
                    format!("cannot write {}: {e}{done}", t.given.display()),
                ));
                tmp.remove(&mut g);
            } else {
                renamed.push(t.given.display().to_string());
            }
        }
        for d in &self.created_dirs {
            forget(&mut g.dirs, d);
        }
        self.created_dirs.clear();
        self.committed = true;
        result
    }
}

impl Existing {
    fn apply(&self, f: &File) {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // Owner and group first (allowed for root, or for a group of ours):
            // changing them may clear set-id bits, which we never copy anyway.
            let _ = std::os::unix::fs::fchown(f, Some(self.uid), Some(self.gid));
            let _ = f.set_permissions(fs::Permissions::from_mode(self.mode));
        }
        #[cfg(not(unix))]
        let _ = f;
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        let mut g = live();
        for t in &mut self.targets {
            if let Kind::File { tmp: Some(tmp), .. } = &mut t.kind {
                tmp.remove(&mut g);
            }
        }
        for d in self.created_dirs.drain(..).rev() {
            let _ = fs::remove_dir(&d);
            forget(&mut g.dirs, &d);
        }
    }
}

/// Write `bytes` to `path` all-or-nothing (one output, no declared input):
/// see [`Outputs`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Like [`write_atomic`], with the content produced by `fill`. If `fill`
/// fails, the temporary file is removed and `path` is left as it was.
pub fn write_atomic_with<E>(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> Result<(), E>,
) -> Result<(), E>
where
    E: From<io::Error>,
{
    let mut out = Outputs::plan().output(path).begin()?;
    out.write_with(path, fill)?;
    out.commit()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    fn no_temporaries(dir: &Path) {
        let left: Vec<String> = names(dir)
            .into_iter()
            .filter(|n| n.starts_with(".mtwin-"))
            .collect();
        assert!(left.is_empty(), "temporaries left: {left:?}");
    }

    #[test]
    fn failed_fill_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        let r: Result<(), io::Error> = write_atomic_with(&p, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert!(!p.exists());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
        write_atomic(&p, b"ok").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"ok");
    }

    #[test]
    fn all_outputs_appear_only_at_commit() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.svg"));
        let mut out = Outputs::plan().output(&a).output(&b).begin().unwrap();
        out.write(&a, b"first").unwrap();
        out.write(&b, b"second").unwrap();
        assert!(!a.exists() && !b.exists(), "nothing visible before commit");
        out.commit().unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"first");
        assert_eq!(fs::read(&b).unwrap(), b"second");
        assert_eq!(names(dir.path()), ["a.csv", "b.svg"]);
    }

    #[test]
    fn a_failed_second_output_leaves_the_first_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.svg"));
        fs::write(&a, b"previous").unwrap();
        let run = || -> io::Result<()> {
            let mut out = Outputs::plan().output(&a).output(&b).begin()?;
            out.write(&a, b"new")?;
            out.write_with(&b, |w| {
                w.write_all(b"half")?;
                Err(io::Error::other("the plot failed"))
            })?;
            out.commit()
        };
        assert!(run().is_err());
        assert_eq!(fs::read(&a).unwrap(), b"previous");
        assert!(!b.exists());
        no_temporaries(dir.path());
    }

    #[test]
    fn writing_again_replaces_the_staged_content() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.txt");
        let mut out = Outputs::plan().output(&a).begin().unwrap();
        out.write(&a, b"a long first version").unwrap();
        out.write(&a, b"short").unwrap();
        out.commit().unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"short");
    }

    #[test]
    fn an_unwritten_declared_output_is_left_alone() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        fs::write(&b, b"kept").unwrap();
        let mut out = Outputs::plan().output(&a).output(&b).begin().unwrap();
        out.write(&a, b"x").unwrap();
        out.commit().unwrap();
        assert_eq!(fs::read(&b).unwrap(), b"kept");
        assert_eq!(names(dir.path()), ["a", "b"]);
    }

    #[test]
    fn an_undeclared_output_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a");
        let mut out = Outputs::plan().output(&a).begin().unwrap();
        let e = out.write(dir.path().join("other"), b"x").unwrap_err();
        assert!(e.to_string().contains("not declared"), "{e}");
    }

    #[test]
    fn an_output_that_is_an_input_is_refused_through_any_name() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("poses.csv");
        fs::write(&input, b"X\n1\n").unwrap();
        let hard = dir.path().join("hard.csv");
        fs::hard_link(&input, &hard).unwrap();
        let soft = dir.path().join("soft.csv");
        #[cfg(unix)]
        std::os::unix::fs::symlink(&input, &soft).unwrap();
        let dotted = dir.path().join(".").join("poses.csv");
        for out in [&input, &hard, &soft, &dotted] {
            if !out.exists() {
                continue;
            }
            let e = Outputs::plan()
                .input(&input)
                .output(out)
                .begin()
                .unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
            let msg = e.to_string();
            assert!(msg.contains("same file as the input"), "{msg}");
            assert!(msg.contains("poses.csv"), "{msg}");
        }
        // Also when the input is named through the link.
        let e = Outputs::plan()
            .input(&hard)
            .output(&input)
            .begin()
            .unwrap_err();
        assert!(e.to_string().contains("same file"), "{e}");
        assert_eq!(fs::read(&input).unwrap(), b"X\n1\n");
        no_temporaries(dir.path());
    }

    #[test]
    fn an_output_given_twice_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        let again = dir.path().join(".").join("a.csv");
        let e = Outputs::plan()
            .output(&a)
            .output(&again)
            .begin()
            .unwrap_err();
        assert!(e.to_string().contains("same output file"), "{e}");
        let e = Outputs::plan()
            .output("-")
            .output("/dev/stdout")
            .begin()
            .unwrap_err();
        assert!(e.to_string().contains("same output file"), "{e}");
        assert!(names(dir.path()).is_empty());
    }

    #[test]
    fn a_missing_folder_is_refused_before_anything_is_created() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        let b = dir.path().join("no").join("such").join("b.nc");
        let e = Outputs::plan().output(&a).output(&b).begin().unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("does not exist"), "{msg}");
        assert!(names(dir.path()).is_empty());
        // A folder output refused too.
        let e = Outputs::plan().output(dir.path()).begin().unwrap_err();
        assert!(e.to_string().contains("is a folder"), "{e}");
    }

    #[test]
    fn a_declared_folder_is_created_and_removed_again_without_commit() {
        let dir = tempfile::tempdir().unwrap();
        let plots = dir.path().join("out").join("plots");
        let p = plots.join("mode1.svg");
        {
            let mut out = Outputs::plan().folder(&plots).output(&p).begin().unwrap();
            assert!(plots.is_dir());
            out.write(&p, b"<svg/>").unwrap();
            // dropped without commit
        }
        assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));
        let mut out = Outputs::plan().folder(&plots).output(&p).begin().unwrap();
        out.write(&p, b"<svg/>").unwrap();
        out.commit().unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"<svg/>");
        // A file where the folder should be.
        let f = dir.path().join("file");
        fs::write(&f, b"").unwrap();
        let e = Outputs::plan().folder(&f).begin().unwrap_err();
        assert!(e.to_string().contains("not a folder"), "{e}");
        let e = Outputs::plan().folder(f.join("sub")).begin().unwrap_err();
        assert!(e.to_string().contains("not a folder"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_followed_and_kept() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.csv");
        fs::write(&real, b"old").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink("real.csv", &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(
            fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read_link(&link).unwrap(), Path::new("real.csv"));
        assert_eq!(fs::read(&real).unwrap(), b"new");
        // A dangling link: its target is created.
        let dangling = dir.path().join("dangling");
        std::os::unix::fs::symlink("created.csv", &dangling).unwrap();
        write_atomic(&dangling, b"made").unwrap();
        assert_eq!(fs::read(dir.path().join("created.csv")).unwrap(), b"made");
        assert!(
            fs::symlink_metadata(&dangling)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        no_temporaries(dir.path());
    }

    #[cfg(unix)]
    #[test]
    fn dev_null_is_written_in_place() {
        use std::os::unix::fs::FileTypeExt;
        write_atomic(Path::new("/dev/null"), b"discarded").unwrap();
        let t = fs::metadata("/dev/null").unwrap().file_type();
        assert!(t.is_char_device());
    }

    #[cfg(target_os = "linux")]
    fn umask() -> u32 {
        let status = fs::read_to_string("/proc/self/status").unwrap();
        let line = status.lines().find(|l| l.starts_with("Umask:")).unwrap();
        u32::from_str_radix(line["Umask:".len()..].trim(), 8).unwrap()
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_new_file_follows_the_umask_and_an_existing_one_keeps_its_mode() {
        use std::os::unix::fs::PermissionsExt;
        let mode = |p: &Path| fs::metadata(p).unwrap().permissions().mode() & 0o7777;
        let dir = tempfile::tempdir().unwrap();
        let new = dir.path().join("new.csv");
        write_atomic(&new, b"x").unwrap();
        assert_eq!(mode(&new), 0o666 & !umask());
        for m in [0o644, 0o640, 0o600, 0o755] {
            let p = dir.path().join(format!("kept-{m:o}"));
            fs::write(&p, b"old").unwrap();
            fs::set_permissions(&p, fs::Permissions::from_mode(m)).unwrap();
            write_atomic(&p, b"new").unwrap();
            assert_eq!(mode(&p), m, "{}", p.display());
            assert_eq!(fs::read(&p).unwrap(), b"new");
        }
    }

    #[test]
    fn the_registry_holds_live_temporaries_only() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("reg.csv");
        let registered = |dir: &Path| live().files.iter().filter(|p| p.starts_with(dir)).count();
        let mut out = Outputs::plan().output(&a).begin().unwrap();
        assert_eq!(registered(dir.path()), 1);
        out.write(&a, b"x").unwrap();
        out.commit().unwrap();
        assert_eq!(registered(dir.path()), 0);
        let out = Outputs::plan().output(&a).begin().unwrap();
        assert_eq!(registered(dir.path()), 1);
        drop(out);
        assert_eq!(registered(dir.path()), 0);
        no_temporaries(dir.path());
    }
}
