//! Program flow: the one driver every command uses to run a program through
//! the [`Interpreter`], with LinuxCNC 2.9's O-word statements (its G-code
//! manual, chapter "O Codes") and, in the Fanuc dialect, M98/M99
//! subprograms.
//!
//! * A program without O-words (and, in the Fanuc dialect, without M98 and
//!   subprogram `O` lines) streams line by line: a 1 GB program is never
//!   held in memory.
//! * At the first such line the rest of the program is read into memory and
//!   run with a program counter, a call stack and a loop stack: `sub` /
//!   `endsub` / `call` (arguments into `#1`–`#30`, saved and restored around
//!   the call), `return` (a value into `#<_value>`, `#<_value_returned>`),
//!   `if` / `elseif` / `else` / `endif`, `while` / `endwhile`, `do` /
//!   `while`, `repeat` / `endrepeat`, `break`, `continue`. A subroutine not
//!   defined in the program is read from `NAME.ngc` in the first directory of
//!   [`ProgramOptions::subroutine_path`] that has it (LinuxCNC's
//!   `SUBROUTINE_PATH`); its events carry the file's number
//!   ([`SourcePos::file`], see [`RunSummary::files`]).
//! * Fanuc: an `O1234` (or `:1234`) line starts a subprogram ending at
//!   `M99`; `M98 P1234 L3` calls it three times (the `P` form with the
//!   repeat count in front of four program digits is not read). `M99` in
//!   the main program (endless repeat) is refused.
//! * LinuxCNC runs the same numbered programs its own way: M98 searches
//!   forward from the call for the `O1234` line, a program line met in the
//!   flow does nothing, and `M99` of the main program ends it (as M2, as
//!   LinuxCNC's standalone interpreter). `o#<n> call` and `O[expr] call`
//!   compute the label.
//! * `(DEBUG,…)`, `(PRINT,…)`, `(ABORT,…)` and `(MSG,…)` comments go to
//!   [`ProgramOptions::messages`], the first three with `#n` / `#<name>`
//!   replaced by their values as LinuxCNC prints them (six decimals unless
//!   a `%d`, `%f` or `%.Nf` says otherwise; an undefined name prints
//!   `######`); as in LinuxCNC only the last comment of a line runs. An
//!   `(ABORT,…)` comment then stops the program with an error naming its
//!   line, before the block's other words run.
//! * Python is not run: `(py,…)`, `(pyrun,…)`, `(pyreload)` and a line
//!   starting `;py,` are refused as unsupported, and so is a call of a
//!   subroutine found nowhere when the INI names a Python module.
//! * Every executed block counts against [`ProgramOptions::max_blocks`]; a
//!   program that runs longer (an endless loop) stops with an error naming
//!   the line. Subroutine calls nest at most [`MAX_CALL_DEPTH`] deep.

use std::collections::HashMap;
use std::fmt;
use std::io::BufRead;
use std::path::PathBuf;
use std::sync::Arc;

use super::dialect::Dialect;
use super::error::{GcodeError, Location};
use super::event::Event;
use super::expr;
use super::interp::Interpreter;
use super::parameters::{Parameters, normalise_name};
use super::stream::BlockReader;
use super::syntax::{Block, CommentKind, Item, Value};

/// Deepest nesting of subroutine calls (LinuxCNC: 10 levels).
pub const MAX_CALL_DEPTH: usize = 10;

/// Default bound on the number of blocks one program may execute
/// ([`ProgramOptions::max_blocks`]): about a minute of interpretation.
pub const DEFAULT_MAX_BLOCKS: u64 = crate::limits::MAX_EXECUTED_BLOCKS;

/// A `(DEBUG,…)`, `(PRINT,…)`, `(ABORT,…)` or `(MSG,…)` message.
#[derive(Debug, Clone, PartialEq)]
pub struct Message {
    /// Which comment.
    pub kind: MessageKind,
    /// The text after the comma, parameters replaced by their values.
    pub text: String,
    /// The file (`None`: the program itself) and line it comes from.
    pub file: Option<PathBuf>,
    /// 1-based line.
    pub line: u64,
}

/// Which comment produced a [`Message`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MessageKind {
    /// `(DEBUG,…)`: an operator message in LinuxCNC.
    Debug,
    /// `(PRINT,…)`: printed on LinuxCNC's standard error.
    Print,
    /// `(ABORT,…)`: the message, then the program stops with an error.
    Abort,
    /// `(MSG,…)`: an operator message, its text as written (parameters
    /// not replaced).
    Msg,
}

/// Where messages go: a callback (the CLI prints them on stderr), or nowhere.
#[derive(Clone, Default)]
pub struct MessageSink(Option<Arc<MessageFn>>);

/// The callback type of a [`MessageSink`].
pub type MessageFn = dyn Fn(&Message) + Send + Sync;

impl MessageSink {
    /// A sink calling `f` with every message.
    pub fn new(f: impl Fn(&Message) + Send + Sync + 'static) -> Self {
        MessageSink(Some(Arc::new(f)))
    }

    fn send(&self, m: &Message) {
        if let Some(f) = &self.0 {
            f(m);
        }
    }
}

/// Two sinks are equal when they are the same callback (or both none).
impl PartialEq for MessageSink {
    fn eq(&self, other: &Self) -> bool {
        match (&self.0, &other.0) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

impl fmt::Debug for MessageSink {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0.is_some() {
            "MessageSink(callback)"
        } else {
            "MessageSink(none)"
        })
    }
}

/// Program-level settings: parameters at start, subroutine search path,
/// bounds, where messages go.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramOptions {
    /// Parameters at program start (e.g. read from a var file).
    pub parameters: Arc<Parameters>,
    /// Directories searched, in order, for `NAME.ngc` of a called
    /// subroutine the program does not define.
    pub subroutine_path: Vec<PathBuf>,
    /// Most blocks one program may execute (loops included).
    pub max_blocks: u64,
    /// `(DEBUG,…)` / `(PRINT,…)` messages.
    pub messages: MessageSink,
    /// Read the input after the end of a streamed program into
    /// [`RunSummary::rest`] (for a caller that copies it, as `compensate`
    /// does). Off by default: the driver stops reading at the end, so a
    /// caller that only interprets (statistics, interpolation) neither reads
    /// nor holds the rest of a long file.
    pub keep_rest: bool,
    /// The module of the INI's `[PYTHON] TOPLEVEL` (LinuxCNC's embedded
    /// Python), if any. mtwin runs no Python: with it set, a call of a
    /// subroutine that is neither in the program nor a file on the
    /// subroutine path is refused as an unsupported Python o-word
    /// subroutine (LinuxCNC would look for it in that module).
    pub python: Option<PathBuf>,
}

impl Default for ProgramOptions {
    fn default() -> Self {
        ProgramOptions {
            parameters: Arc::new(Parameters::new()),
            subroutine_path: Vec::new(),
            max_blocks: DEFAULT_MAX_BLOCKS,
            messages: MessageSink::default(),
            keep_rest: false,
            python: None,
        }
    }
}

impl ProgramOptions {
    /// Applies a LinuxCNC INI file (its text; `dir` is its folder): its
    /// numeric entries become readable as `#<_ini[section]name>` (see
    /// [`Parameters::load_ini`]) and the directories of its
    /// `[RS274NGC] SUBROUTINE_PATH` (separated by `:`, a relative one taken
    /// from `dir`, where LinuxCNC runs) are searched after those already in
    /// [`ProgramOptions::subroutine_path`]; its `[PYTHON] TOPLEVEL` (taken
    /// from `dir` too) becomes [`ProgramOptions::python`].
    pub fn apply_ini(&mut self, text: &str, dir: &std::path::Path) {
        Arc::make_mut(&mut self.parameters).load_ini(text);
        let ini = super::linuxcnc_ini::LinuxcncIni::parse(text);
        if let Some(path) = ini.get("RS274NGC", "SUBROUTINE_PATH") {
            for d in path.split(':').filter(|d| !d.trim().is_empty()) {
                self.subroutine_path.push(dir.join(d.trim()));
            }
        }
        if let Some(top) = ini.get("PYTHON", "TOPLEVEL").filter(|t| !t.is_empty()) {
            self.python = Some(dir.join(top));
        }
    }
}

/// One executed block as the driver hands it to its caller.
#[derive(Debug)]
pub struct Step<'a> {
    /// The block (its line is [`Block::line`] in file [`Step::file`]).
    pub block: &'a Block,
    /// The events it produced (none for O-word lines).
    pub events: &'a [Event],
    /// The interpreter after the block.
    pub interp: &'a Interpreter,
    /// 0: the program; n ≥ 1: `RunSummary::files[n - 1]`.
    pub file: u32,
    /// Whether the block runs from the held program (O-word flow) rather
    /// than streaming; such a block may run several times.
    pub held: bool,
}

/// What a run leaves besides the steps.
#[derive(Debug, Default)]
pub struct RunSummary {
    /// The lines of the program from the first O-word (or M98) line on, held
    /// in memory to run them (empty for a streamed program), in source order.
    pub held: Vec<Block>,
    /// Subroutine files read, in the order of their file number (1, 2, ...).
    pub files: Vec<PathBuf>,
    /// Blocks executed (each run of a block counts).
    pub executed: u64,
    /// The input after the end of a streamed program (M2, M30, closing
    /// `%`), unread: callers copy it as it is, as LinuxCNC never reads it.
    /// Empty when the program ran to the end of the input or was held, and
    /// unless [`ProgramOptions::keep_rest`] asks for it.
    pub rest: Vec<u8>,
}

/// Runs the program read from `input` on `interp`, calling `sink` with every
/// executed block.
pub fn run_program<R, E, F>(
    mut input: R,
    interp: &mut Interpreter,
    opts: &ProgramOptions,
    dialect: Dialect,
    mut sink: F,
) -> Result<RunSummary, E>
where
    R: BufRead,
    E: From<GcodeError>,
    F: FnMut(&Step<'_>) -> Result<(), E>,
{
    // Only this shim is compiled for each caller's reader, sink and error
    // types; the runner itself once, for a `dyn` reader and sink.
    let mut failed: Option<E> = None;
    let r = run_stream(&mut input, interp, opts, dialect, &mut |step: &Step<'_>| {
        sink(step).map_err(|e| {
            failed = Some(e);
            Stop::Sink
        })
    });
    match r {
        Ok(summary) => Ok(summary),
        Err(Stop::Gcode(e)) => Err(e.into()),
        Err(Stop::Sink) => Err(failed.expect("a sink that stopped the run left its error")),
    }
}

/// Why [`run_stream`] stopped: an error of the program, or the sink's own
/// (kept by [`run_program`], which knows its type).
#[derive(Debug)]
enum Stop {
    Gcode(GcodeError),
    Sink,
}

impl From<GcodeError> for Stop {
    fn from(e: GcodeError) -> Stop {
        Stop::Gcode(e)
    }
}

/// The sink of [`run_stream`]: each step of the run.
type StepSink<'s> = dyn FnMut(&Step<'_>) -> Result<(), Stop> + 's;

/// [`run_program`] for a `dyn` reader and sink.
fn run_stream(
    input: &mut dyn BufRead,
    interp: &mut Interpreter,
    opts: &ProgramOptions,
    dialect: Dialect,
    sink: &mut StepSink<'_>,
) -> Result<RunSummary, Stop> {
    let mut reader = BlockReader::new(input);
    let mut block = Block::default();
    let mut events = Vec::new();
    let mut summary = RunSummary::default();
    let fanuc = matches!(dialect, Dialect::Fanuc { .. });
    // Fanuc: the program-number line at the top (before any word) is a name.
    let mut seen_words = false;
    while !interp.ended() && reader.read_block(&mut block)? {
        let scan = FlowScan::of(&block, interp.parameters());
        let trigger = if fanuc {
            let t = (scan.oword && seen_words) || scan.m98_m99;
            seen_words |= scan.words;
            t
        } else {
            // LinuxCNC runs Fanuc-style M98/M99 subprograms too.
            scan.oword || scan.m98_m99
        };
        if trigger && !interp.ended() {
            let mut held = vec![std::mem::take(&mut block)];
            // A line that does not parse is an error only if it runs (text
            // after the program end is never read by LinuxCNC).
            let mut bad = HashMap::new();
            // LinuxCNC reads nothing after the closing `%` of a program that
            // opens with one (a subroutine defined there is not found).
            let percent = interp.percent_opened();
            loop {
                match reader.read_block(&mut block) {
                    Ok(false) => break,
                    Ok(true) if percent && block.is_percent() && block.items().len() == 1 => {
                        held.push(std::mem::take(&mut block));
                        break;
                    }
                    Ok(true) => held.push(std::mem::take(&mut block)),
                    Err(e @ GcodeError::Syntax { .. }) => {
                        bad.insert(held.len(), e);
                        held.push(std::mem::take(&mut block));
                    }
                    Err(e) => return Err(e.into()),
                }
            }
            let mut flow = Flow {
                codes: vec![Code::new_with_bad(held, 0, fanuc, bad)?],
                files: Vec::new(),
                opts,
                fanuc,
                executed: summary.executed,
                entering_elseif: false,
                m98_found: HashMap::new(),
                recorded: std::collections::HashSet::new(),
            };
            flow.run(interp, sink)?;
            interp.finish()?;
            summary.executed = flow.executed;
            summary.files = flow.files;
            summary.held = flow.codes.swap_remove(0).blocks;
            return Ok(summary);
        }
        if fanuc && !interp.ended() && scan.oword {
            // The program number at the top: nothing to execute (but
            // nothing else may stand on its line).
            parse_stmt(&block, true)?;
            summary.executed += 1;
            sink(&Step {
                block: &block,
                events: &[],
                interp,
                file: 0,
                held: false,
            })?;
            continue;
        }
        summary.executed += 1;
        events.clear();
        if scan.comments && !interp.ended() {
            interp.parameters_mut().set_line(block.line());
            messages(&block, interp.parameters(), opts, None)?;
        }
        interp.set_source_file(0);
        interp.execute(&block, &mut events)?;
        sink(&Step {
            block: &block,
            events: &events,
            interp,
            file: 0,
            held: false,
        })?;
    }
    interp.finish()?;
    if interp.ended() && opts.keep_rest {
        std::io::Read::read_to_end(&mut reader.into_inner(), &mut summary.rest)
            .map_err(GcodeError::from)?;
    }
    Ok(summary)
}

/// What the program driver looks for in each block, found in one pass
/// over its items.
struct FlowScan {
    /// An O-word statement.
    oword: bool,
    /// An `M98` or `M99` word (a Fanuc-style subprogram call or return).
    m98_m99: bool,
    /// Any word.
    words: bool,
    /// A `( )` comment (which may be a `(DEBUG,…)` message) or a `;`
    /// comment at the start of the line (which may be `;py,`).
    comments: bool,
}

impl FlowScan {
    fn of(block: &Block, params: &Parameters) -> FlowScan {
        let mut scan = FlowScan {
            oword: false,
            m98_m99: false,
            words: false,
            comments: false,
        };
        for item in block.items() {
            match item {
                Item::OWord { .. } => scan.oword = true,
                Item::Comment {
                    kind: CommentKind::Paren,
                    ..
                } => scan.comments = true,
                // A line starting `;py,` (refused by `messages`).
                Item::Comment {
                    kind: CommentKind::Semicolon,
                    span,
                } if span.start == 0 => scan.comments = true,
                Item::Word(w) => {
                    scan.words = true;
                    if w.letter == b'M' && !scan.m98_m99 {
                        scan.m98_m99 = word_value(block, w, params)
                            .is_ok_and(|v| [98.0, 99.0].iter().any(|code| (v - code).abs() < 1e-9));
                    }
                }
                _ => {}
            }
        }
        scan
    }
}

fn word_value(block: &Block, w: &super::syntax::Word, params: &Parameters) -> Result<f64, String> {
    match w.value {
        Value::Number(v) => Ok(v),
        Value::Expression | Value::Parameter => {
            expr::eval(block.value_text(w).as_bytes(), params).map_err(|e| e.to_string())
        }
    }
}

/// Sends the `(DEBUG,…)` / `(PRINT,…)` / `(ABORT,…)` / `(MSG,…)` comment
/// of a block (its last); an `(ABORT,…)` one then stops the program with
/// its text as the error. A comment LinuxCNC runs as Python is refused.
fn messages(
    block: &Block,
    params: &Parameters,
    opts: &ProgramOptions,
    file: Option<&PathBuf>,
) -> Result<(), GcodeError> {
    // LinuxCNC keeps one comment per line, the last in parentheses: only
    // that one runs.
    let mut last = None;
    for item in block.items() {
        match item {
            Item::Comment {
                kind: CommentKind::Paren,
                span,
            } => last = Some(span),
            // LinuxCNC runs a line that starts with `;py,` as Python.
            Item::Comment {
                kind: CommentKind::Semicolon,
                span,
            } if span.start == 0 && block.text().starts_with(b";py,") => {
                return Err(python_comment(block.line(), 1, ";py,"));
            }
            _ => {}
        }
    }
    let Some(span) = last else {
        return Ok(());
    };
    let inner = &block.text()[span.start + 1..span.end - 1];
    // Most comments are none of these: one look at the first byte after
    // the leading (ASCII) white space tells, without decoding the text.
    let first = inner
        .iter()
        .find(|&&c| !matches!(c, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r'));
    if first.is_none_or(|&c| {
        c.is_ascii() && !matches!(c.to_ascii_uppercase(), b'D' | b'P' | b'A' | b'M')
    }) {
        return Ok(());
    }
    let s = String::from_utf8_lossy(inner);
    let trimmed = s.trim_start();
    let upper = trimmed.get(..6).unwrap_or(trimmed).to_ascii_uppercase();
    let (kind, text) = if upper.starts_with("MSG,") {
        // Shown as it is, parameters not replaced.
        (MessageKind::Msg, trimmed[4..].to_string())
    } else {
        let kind = match upper.as_str() {
            "DEBUG," => MessageKind::Debug,
            "PRINT," => MessageKind::Print,
            "ABORT," => MessageKind::Abort,
            _ => {
                let lower = trimmed.get(..8).unwrap_or(trimmed).to_ascii_lowercase();
                if let Some(p) = ["py,", "pyrun,", "pyreload"]
                    .into_iter()
                    .find(|p| lower.starts_with(p))
                {
                    return Err(python_comment(
                        block.line(),
                        span.start + 1,
                        &format!("({p}…)"),
                    ));
                }
                return Ok(());
            }
        };
        // LinuxCNC 2.9 shows `(DEBUG,…)` only while #5599 is above 0.
        if kind == MessageKind::Debug && params.get(5599) <= 0.0 {
            return Ok(());
        }
        (kind, substitute(&trimmed[6..], params))
    };
    opts.messages.send(&Message {
        kind,
        text: text.clone(),
        file: file.cloned(),
        line: block.line(),
    });
    if kind == MessageKind::Abort {
        return Err(GcodeError::invalid(
            block.line(),
            span.start + 1,
            format!("program aborted by (ABORT,…):{text}"),
        ));
    }
    Ok(())
}

/// The refusal of a comment LinuxCNC runs as Python (`(py,…)`,
/// `(pyrun,…)`, `(pyreload)`, a line starting `;py,`).
fn python_comment(line: u64, column: usize, what: &str) -> GcodeError {
    GcodeError::unsupported(
        line,
        column,
        format!("embedded Python {what} comment: LinuxCNC runs it as Python, mtwin runs no Python"),
    )
}

/// The text of a `(DEBUG,…)`, `(PRINT,…)` or `(ABORT,…)` comment with `#n`
/// and `#<name>` replaced by their values, as LinuxCNC formats them: six
/// decimals, or as the last `%d` (none), `%f` (four) or `%.Nf` (N) before
/// them in the comment says; a value within 0.0001 of zero prints as zero; a
/// parameter number beyond 5601 or an unset name prints `######`. A `%`
/// before anything else stays, `%.` without `Nf` prints `.`; a `#` before
/// anything else, or a name not closed by `>`, stays as written.
pub(crate) fn substitute(text: &str, params: &Parameters) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut decimals = 6usize;
    let mut i = 0;
    while i < b.len() {
        let value = match b[i] {
            b'%' => {
                match (b.get(i + 1), b.get(i + 2), b.get(i + 3)) {
                    (Some(b'd'), ..) => (decimals, i) = (0, i + 2),
                    (Some(b'f'), ..) => (decimals, i) = (4, i + 2),
                    (Some(b'.'), Some(d), Some(b'f')) if d.is_ascii_digit() => {
                        (decimals, i) = (usize::from(d - b'0'), i + 4);
                    }
                    (Some(b'.'), ..) => {
                        out.push('.');
                        i += 2;
                    }
                    _ => {
                        out.push('%');
                        i += 1;
                    }
                }
                continue;
            }
            b'#' if b.get(i + 1).is_some_and(u8::is_ascii_digit) => {
                let digits = b[i + 1..].iter().take_while(|c| c.is_ascii_digit()).count();
                let n: Option<u32> = text[i + 1..i + 1 + digits].parse().ok();
                i += 1 + digits;
                // #0 is LinuxCNC's parameter 0, never set.
                n.filter(|&n| n < super::parameters::MAX_NUMBERED)
                    .map(|n| if n == 0 { 0.0 } else { params.get(n) })
            }
            b'#' if b.get(i + 1) == Some(&b'<') => {
                let Some(k) = b[i + 2..].iter().position(|&c| c == b'>') else {
                    out.push_str(&text[i..]);
                    break;
                };
                let name = normalise_name(&text[i + 2..i + 2 + k]);
                i += k + 3;
                params.get_named(&name).ok()
            }
            _ => {
                let ch = text[i..].chars().next().unwrap_or(' ');
                out.push(ch);
                i += ch.len_utf8();
                continue;
            }
        };
        match value {
            Some(v) => {
                let v = if v.abs() < 1e-4 { 0.0 } else { v };
                out.push_str(&format!("{v:.decimals$}"));
            }
            None => out.push_str("######"),
        }
    }
    out
}

/// O-word statement kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Sub,
    EndSub,
    Call,
    Return,
    If,
    ElseIf,
    Else,
    EndIf,
    While,
    EndWhile,
    Do,
    DoWhile,
    Repeat,
    EndRepeat,
    Break,
    Continue,
    /// Fanuc `O1234`: start of a subprogram (or the main program's name).
    Program,
}

const KEYWORDS: [(&str, Kind); 16] = [
    ("endsub", Kind::EndSub),
    ("endif", Kind::EndIf),
    ("endwhile", Kind::EndWhile),
    ("endrepeat", Kind::EndRepeat),
    ("elseif", Kind::ElseIf),
    ("else", Kind::Else),
    ("sub", Kind::Sub),
    ("call", Kind::Call),
    ("return", Kind::Return),
    ("if", Kind::If),
    ("while", Kind::While),
    ("do", Kind::Do),
    ("repeat", Kind::Repeat),
    ("break", Kind::Break),
    ("continue", Kind::Continue),
    ("", Kind::Program),
];

/// One parsed O-word line.
#[derive(Debug, Clone)]
struct Stmt {
    label: String,
    /// A label computed when the statement runs (`o#<n> call`,
    /// `O[#2 * 10] call`): the byte range of its expression in the block.
    label_expr: Option<(usize, usize)>,
    kind: Kind,
    /// Byte offset in the block text of what follows the keyword.
    rest: usize,
    /// 1-based column of the `O`.
    column: usize,
    /// Linked statements: for if/elseif/else the next branch and the endif;
    /// for loops their start and end; for sub its endsub; for break and
    /// continue the loop's start and end; for a Fanuc program its M99.
    a: usize,
    b: usize,
}

/// One file's blocks with their statements and links.
#[derive(Debug)]
struct Code {
    blocks: Vec<Block>,
    stmts: Vec<Option<Stmt>>,
    subs: HashMap<String, usize>,
    /// LinuxCNC dialect: the `O1234` program lines and `sub` statements of
    /// each label, in source order (what M98 searches forward for).
    numbered: HashMap<String, Vec<usize>>,
    file: u32,
    /// Lines that did not parse (by index): their error if they run.
    bad: HashMap<usize, GcodeError>,
}

fn err_at(file: u32, files: &[PathBuf], e: GcodeError) -> GcodeError {
    match file.checked_sub(1).and_then(|k| files.get(k as usize)) {
        Some(p) => GcodeError::InFile {
            path: p.clone(),
            error: Box::new(e),
        },
        None => e,
    }
}

impl Code {
    fn new(blocks: Vec<Block>, file: u32, fanuc: bool) -> Result<Code, GcodeError> {
        Code::new_with_bad(blocks, file, fanuc, HashMap::new())
    }

    fn new_with_bad(
        blocks: Vec<Block>,
        file: u32,
        fanuc: bool,
        bad: HashMap<usize, GcodeError>,
    ) -> Result<Code, GcodeError> {
        let mut stmts: Vec<Option<Stmt>> = Vec::with_capacity(blocks.len());
        for (i, b) in blocks.iter().enumerate() {
            stmts.push(if bad.contains_key(&i) {
                None
            } else {
                parse_stmt(b, fanuc)?
            });
        }
        let mut code = Code {
            blocks,
            stmts,
            subs: HashMap::new(),
            numbered: HashMap::new(),
            file,
            bad,
        };
        code.link(fanuc)?;
        Ok(code)
    }

    fn err(&self, idx: usize, column: usize, msg: impl Into<String>) -> GcodeError {
        GcodeError::invalid(self.blocks[idx].line(), column, msg)
    }

    /// Matches every opening statement with its closing ones by label.
    fn link(&mut self, fanuc: bool) -> Result<(), GcodeError> {
        // Open constructs: (statement index, kind, label).
        let mut open: Vec<usize> = Vec::new();
        let mut seen_words = false;
        for i in 0..self.stmts.len() {
            let Some(st) = self.stmts[i].clone() else {
                seen_words |= self.blocks[i].words().next().is_some();
                continue;
            };
            let col = st.column;
            let top_matches = |open: &Vec<usize>, stmts: &Vec<Option<Stmt>>, kinds: &[Kind]| {
                open.last()
                    .and_then(|&j| stmts[j].as_ref())
                    .is_some_and(|o| o.label == st.label && kinds.contains(&o.kind))
            };
            if !fanuc && matches!(st.kind, Kind::Program | Kind::Sub) {
                self.numbered.entry(st.label.clone()).or_default().push(i);
            }
            match st.kind {
                Kind::Program => {
                    if !fanuc {
                        // LinuxCNC: a program line reached in the flow does
                        // nothing; M98 runs from it to its M99.
                        self.set(i, usize::MAX, usize::MAX);
                        continue;
                    }
                    if !seen_words {
                        // The main program's name: nothing to skip.
                        self.set(i, usize::MAX, usize::MAX);
                        continue;
                    }
                    let end = (i + 1..self.blocks.len())
                        .find(|&k| {
                            self.blocks[k]
                                .words()
                                .any(|w| w.letter == b'M' && w.number() == Some(99.0))
                        })
                        .ok_or_else(|| {
                            self.err(i, col, format!("subprogram O{} has no M99", st.label))
                        })?;
                    self.set(i, end, end);
                    self.subs.insert(st.label.clone(), i);
                }
                Kind::Sub => {
                    if open.iter().any(|&j| self.kind(j) == Kind::Sub) {
                        return Err(self.err(i, col, "subroutine definition inside a subroutine"));
                    }
                    open.push(i);
                }
                Kind::EndSub => {
                    if !top_matches(&open, &self.stmts, &[Kind::Sub]) {
                        return Err(self.err(
                            i,
                            col,
                            format!("o{} endsub without a matching o{} sub", st.label, st.label),
                        ));
                    }
                    let s = open.pop().unwrap_or(i);
                    self.set(s, i, i);
                    if self.subs.insert(st.label.clone(), s).is_some() {
                        return Err(self.err(
                            s,
                            col,
                            format!("subroutine o{} defined twice", st.label),
                        ));
                    }
                }
                Kind::While if top_matches(&open, &self.stmts, &[Kind::Do]) => {
                    // `o1 while` closing `o1 do`.
                    let d = open.pop().unwrap_or(i);
                    if let Some(s) = self.stmts[i].as_mut() {
                        s.kind = Kind::DoWhile;
                    }
                    self.set(d, d, i);
                    self.set(i, d, i);
                }
                Kind::If | Kind::While | Kind::Do | Kind::Repeat => open.push(i),
                Kind::ElseIf | Kind::Else | Kind::EndIf => {
                    if !top_matches(&open, &self.stmts, &[Kind::If, Kind::ElseIf, Kind::Else]) {
                        let kw = keyword(st.kind);
                        return Err(self.err(
                            i,
                            col,
                            format!("o{} {kw} without a matching o{} if", st.label, st.label),
                        ));
                    }
                    let prev = open.pop().unwrap_or(i);
                    if self.kind(prev) == Kind::Else && st.kind != Kind::EndIf {
                        return Err(self.err(
                            i,
                            col,
                            format!(
                                "o{} {} after o{} else",
                                st.label,
                                keyword(st.kind),
                                st.label
                            ),
                        ));
                    }
                    self.set_a(prev, i);
                    if st.kind == Kind::EndIf {
                        // Every branch of the chain learns where the endif is.
                        let mut k = self.if_start(prev);
                        loop {
                            let next = self.stmts[k].as_ref().map_or(i, |s| s.a);
                            self.set_b(k, i);
                            if next == i {
                                break;
                            }
                            k = next;
                        }
                    } else {
                        self.set_b(i, prev);
                        open.push(i);
                    }
                }
                Kind::EndWhile | Kind::EndRepeat => {
                    let want = if st.kind == Kind::EndWhile {
                        Kind::While
                    } else {
                        Kind::Repeat
                    };
                    if !top_matches(&open, &self.stmts, &[want]) {
                        let kw = keyword(st.kind);
                        return Err(self.err(
                            i,
                            col,
                            format!(
                                "o{} {kw} without a matching o{} {}",
                                st.label,
                                st.label,
                                keyword(want)
                            ),
                        ));
                    }
                    let s = open.pop().unwrap_or(i);
                    self.set(s, s, i);
                    self.set(i, s, i);
                }
                Kind::Break | Kind::Continue => {
                    let Some(&j) = open.iter().rev().find(|&&j| {
                        self.stmts[j].as_ref().is_some_and(|o| {
                            o.label == st.label
                                && matches!(o.kind, Kind::While | Kind::Do | Kind::Repeat)
                        })
                    }) else {
                        return Err(self.err(
                            i,
                            col,
                            format!(
                                "o{} {} outside a loop o{}",
                                st.label,
                                keyword(st.kind),
                                st.label
                            ),
                        ));
                    };
                    // Linked once the loop closes.
                    self.set(i, j, usize::MAX);
                }
                Kind::Call | Kind::Return | Kind::DoWhile => {}
            }
        }
        if let Some(&j) = open.last() {
            let st = self.stmts[j].as_ref().map_or(String::new(), |s| {
                format!("o{} {}", s.label, keyword(s.kind))
            });
            return Err(self.err(
                j,
                self.stmts[j].as_ref().map_or(0, |s| s.column),
                format!("{st} is not closed"),
            ));
        }
        // Break/continue: the end of their loop.
        for i in 0..self.stmts.len() {
            if matches!(self.kind_opt(i), Some(Kind::Break | Kind::Continue)) {
                let start = self.stmts[i].as_ref().map_or(0, |s| s.a);
                let end = self.stmts[start].as_ref().map_or(0, |s| s.b);
                self.set_b(i, end);
            }
        }
        Ok(())
    }

    fn kind(&self, i: usize) -> Kind {
        self.kind_opt(i).unwrap_or(Kind::Program)
    }

    fn kind_opt(&self, i: usize) -> Option<Kind> {
        self.stmts[i].as_ref().map(|s| s.kind)
    }

    fn if_start(&self, mut k: usize) -> usize {
        while matches!(self.kind_opt(k), Some(Kind::ElseIf | Kind::Else)) {
            k = self.stmts[k].as_ref().map_or(k, |s| s.b);
        }
        k
    }

    fn set(&mut self, i: usize, a: usize, b: usize) {
        if let Some(s) = self.stmts[i].as_mut() {
            s.a = a;
            s.b = b;
        }
    }

    fn set_a(&mut self, i: usize, a: usize) {
        if let Some(s) = self.stmts[i].as_mut() {
            s.a = a;
        }
    }

    fn set_b(&mut self, i: usize, b: usize) {
        if let Some(s) = self.stmts[i].as_mut() {
            s.b = b;
        }
    }
}

fn keyword(k: Kind) -> &'static str {
    match k {
        Kind::DoWhile => "while",
        _ => KEYWORDS
            .iter()
            .find(|(_, kk)| *kk == k)
            .map_or("", |(w, _)| w),
    }
}

/// Parses the O-word statement of a block, if it has one.
fn parse_stmt(block: &Block, fanuc: bool) -> Result<Option<Stmt>, GcodeError> {
    let Some(span) = block.items().iter().find_map(|i| match i {
        Item::OWord { span } => Some(*span),
        _ => None,
    }) else {
        return Ok(None);
    };
    let line = block.line();
    let text = block.text();
    let colon = text[span.start] == b':';
    if colon && !fanuc {
        return Err(GcodeError::syntax(
            line,
            span.start + 1,
            "unexpected character ':' (a ':1234' program number line is Fanuc's; use O1234)",
        ));
    }
    if block.words().any(|w| w.letter != b'N') {
        return Err(GcodeError::invalid(
            line,
            span.start + 1,
            "an O-word statement cannot share its line with other words",
        ));
    }
    let mut i = span.start + 1;
    let skip = |i: &mut usize| {
        while text.get(*i).is_some_and(|c| matches!(c, b' ' | b'\t')) {
            *i += 1;
        }
    };
    skip(&mut i);
    let mut label_expr = None;
    let label = match text.get(i) {
        // A computed label (LinuxCNC reads any value after O): `o#<n>`,
        // `o#5`, `O[#2 * 10]`; evaluated when the statement runs.
        Some(b'#' | b'[') => {
            let s = i;
            i = value_end(text, i, span.end).ok_or_else(|| {
                GcodeError::syntax(line, s + 1, "O-word label expression is not closed")
            })?;
            label_expr = Some((s, i));
            String::from_utf8_lossy(&text[s..i]).into_owned()
        }
        Some(b'<') => {
            let Some(k) = text[i..span.end].iter().position(|&c| c == b'>') else {
                return Err(GcodeError::syntax(
                    line,
                    i + 1,
                    "O-word name '<' is not closed by '>'",
                ));
            };
            let name = normalise_name(&String::from_utf8_lossy(&text[i + 1..i + k]));
            i += k + 1;
            name
        }
        Some(c) if c.is_ascii_digit() => {
            let s = i;
            while text
                .get(i)
                .is_some_and(|c| c.is_ascii_digit() || matches!(c, b' ' | b'\t'))
            {
                i += 1;
            }
            let digits: String = String::from_utf8_lossy(&text[s..i])
                .chars()
                .filter(char::is_ascii_digit)
                .collect();
            // o0100 and o100 are one label (LinuxCNC reads an integer).
            let trimmed = digits.trim_start_matches('0');
            if trimmed.is_empty() {
                "0".to_string()
            } else {
                trimmed.to_string()
            }
        }
        _ => {
            return Err(GcodeError::syntax(
                line,
                i + 1,
                "an O-word needs a number or a <name>",
            ));
        }
    };
    skip(&mut i);
    let kw_start = i;
    // LinuxCNC removes blanks before reading a line, so `end sub` is
    // `endsub` and `else if` is `elseif`.
    let mut kw = Vec::new();
    let mut j = i;
    while let Some(&c) = text.get(j) {
        if c.is_ascii_alphabetic() {
            kw.push(c.to_ascii_lowercase());
            i = j + 1;
        } else if !matches!(c, b' ' | b'\t') {
            break;
        }
        j += 1;
    }
    let kind = KEYWORDS
        .iter()
        .find(|(w, _)| w.as_bytes() == kw.as_slice())
        .map(|(_, k)| *k);
    let Some(kind) = kind else {
        if fanuc {
            return Err(GcodeError::syntax(
                line,
                kw_start + 1,
                format!(
                    "a program number line (O{label}) holds nothing but the number and comments"
                ),
            ));
        }
        return Err(GcodeError::syntax(
            line,
            kw_start + 1,
            format!(
                "unknown O-word statement '{}'",
                String::from_utf8_lossy(&kw)
            ),
        ));
    };
    if colon && (kind != Kind::Program || !label.bytes().all(|c| c.is_ascii_digit())) {
        return Err(GcodeError::syntax(
            line,
            span.start + 1,
            "':' must be followed by a program number and nothing else (':1234' is O1234)",
        ));
    }
    if label_expr.is_some() && kind != Kind::Call {
        return Err(GcodeError::unsupported(
            line,
            span.start + 1,
            format!(
                "a computed O-word label (o{label}) other than on call (on {})",
                if kind == Kind::Program {
                    "a program number line"
                } else {
                    keyword(kind)
                }
            ),
        ));
    }
    Ok(Some(Stmt {
        label,
        label_expr,
        kind,
        rest: i,
        column: span.start + 1,
        a: usize::MAX,
        b: usize::MAX,
    }))
}

/// The runs of `[..]` arguments of a call, split at the comments between
/// them (`[1] (note) [2]` is `[1]` and `[2]`, as LinuxCNC reads a call),
/// and where the arguments and comments end in `text`; `None` when a
/// bracket or a comment is not closed.
fn call_arguments(text: &[u8]) -> Option<(Vec<&[u8]>, usize)> {
    let mut runs = Vec::new();
    let (mut start, mut i) = (0, 0);
    loop {
        while text.get(i).is_some_and(|c| matches!(c, b' ' | b'\t')) {
            i += 1;
        }
        match text.get(i) {
            Some(b'[') => i = value_end(text, i, text.len())?,
            Some(b'(') => {
                runs.push(&text[start..i]);
                i += text[i..].iter().position(|&c| c == b')')? + 1;
                start = i;
            }
            _ => break,
        }
    }
    runs.push(&text[start..i]);
    Some((runs, i))
}

/// End (exclusive) of the parameter reference (`#n`, `#<name>`, `#[..]`,
/// `##..`) or `[..]` expression starting at `i`, within `text[..end]`.
fn value_end(text: &[u8], mut i: usize, end: usize) -> Option<usize> {
    match text.get(i)? {
        b'[' => {
            let mut depth = 0usize;
            while i < end {
                match text[i] {
                    b'[' => depth += 1,
                    b']' => {
                        depth -= 1;
                        if depth == 0 {
                            return Some(i + 1);
                        }
                    }
                    _ => {}
                }
                i += 1;
            }
            None
        }
        b'#' => {
            i += 1;
            while text.get(i).is_some_and(|c| matches!(c, b' ' | b'\t')) {
                i += 1;
            }
            match text.get(i)? {
                b'<' => {
                    let k = text[i..end].iter().position(|&c| c == b'>')?;
                    Some(i + k + 1)
                }
                b'[' | b'#' => value_end(text, i, end),
                c if c.is_ascii_digit() => {
                    while text
                        .get(i)
                        .is_some_and(|c| c.is_ascii_digit() || *c == b'.')
                    {
                        i += 1;
                    }
                    Some(i)
                }
                _ => None,
            }
        }
        _ => None,
    }
}

struct Frame {
    code: usize,
    ret: usize,
    ret_code: usize,
    saved: Option<[f64; super::parameters::SUB_ARGS]>,
    loops_base: usize,
    /// Fanuc M98 L: runs left after this one, and where the body starts.
    repeat: u64,
    start: usize,
}

struct Loop {
    code: usize,
    start: usize,
    remaining: u64,
}

struct Flow<'a> {
    codes: Vec<Code>,
    files: Vec<PathBuf>,
    opts: &'a ProgramOptions,
    fanuc: bool,
    executed: u64,
    /// The next statement is an `elseif` reached because the branch before
    /// it was not taken (evaluate it) rather than after a taken branch.
    entering_elseif: bool,
    /// LinuxCNC dialect: the programs M98 has found, by code and label
    /// (later calls go back to them).
    m98_found: HashMap<(usize, String), usize>,
    /// LinuxCNC dialect: `sub` statements (code, index) the flow has
    /// passed or called; reaching one again is an error, as in LinuxCNC.
    recorded: std::collections::HashSet<(usize, usize)>,
}

impl Flow<'_> {
    fn run(&mut self, interp: &mut Interpreter, sink: &mut StepSink<'_>) -> Result<(), Stop> {
        let mut frames: Vec<Frame> = Vec::new();
        let mut loops: Vec<Loop> = Vec::new();
        let mut events = Vec::new();
        let (mut c, mut pc) = (0usize, 0usize);
        while !interp.ended() {
            if let Some(e) = self.codes[c].bad.remove(&pc) {
                return Err(err_at(self.codes[c].file, &self.files, e).into());
            }
            let Some(block) = self.codes[c].blocks.get(pc) else {
                if frames.is_empty() {
                    return Ok(());
                }
                let file = self.codes[c].file;
                let line = self.codes[c].blocks.last().map_or(0, Block::line);
                return Err(err_at(
                    file,
                    &self.files,
                    GcodeError::invalid(line, 0, "the file ended inside a subroutine (no endsub)"),
                )
                .into());
            };
            self.executed += 1;
            if self.executed > self.opts.max_blocks {
                let e = GcodeError::invalid(
                    block.line(),
                    0,
                    format!(
                        "more than {} blocks executed: an endless loop? (the bound is the maximum number of executed blocks)",
                        self.opts.max_blocks
                    ),
                );
                return Err(err_at(self.codes[c].file, &self.files, e).into());
            }
            let file = self.codes[c].file;
            let fail = |files: &[PathBuf], e: GcodeError| -> Stop { err_at(file, files, e).into() };
            let line = block.line();
            interp.parameters_mut().set_line(line);
            let Some(st) = self.codes[c].stmts[pc].clone() else {
                // An ordinary block (or Fanuc-style M98/M99).
                if !interp.ended()
                    && let Some((call, col)) = self
                        .fanuc_call(block, interp.parameters())
                        .map_err(|e| fail(&self.files, e))?
                {
                    if matches!(call, FanucCall::M99) && !self.fanuc {
                        match frames.last() {
                            // LinuxCNC's standalone interpreter ends the
                            // program at an M99 of the main program (its
                            // task would run it again, endlessly).
                            None => {
                                let end =
                                    Block::parse(b"M2", line).map_err(|e| fail(&self.files, e))?;
                                events.clear();
                                interp
                                    .execute(&end, &mut events)
                                    .map_err(|e| fail(&self.files, e))?;
                                for e in &mut events {
                                    e.at.file = file;
                                }
                                sink(&Step {
                                    block,
                                    events: &events,
                                    interp,
                                    file,
                                    held: true,
                                })?;
                                continue;
                            }
                            Some(f) if f.saved.is_some() => {
                                return Err(fail(
                                    &self.files,
                                    GcodeError::invalid(
                                        line,
                                        col,
                                        "M99 inside an O-word subroutine (it ends with endsub or return)",
                                    ),
                                ));
                            }
                            Some(_) => {}
                        }
                    }
                    {
                        sink(&Step {
                            block,
                            events: &[],
                            interp,
                            file,
                            held: true,
                        })?;
                        match call {
                            FanucCall::M98(prog, count) => {
                                let target = if self.fanuc {
                                    self.codes[0].subs.get(&prog).map(|&s| (0, s)).ok_or_else(
                                        || format!("M98: no subprogram O{prog} in the program"),
                                    )
                                } else {
                                    self.m98_target(c, pc, &prog)
                                };
                                let (tc, start) = target.map_err(|m| {
                                    fail(&self.files, GcodeError::invalid(line, col, m))
                                })?;
                                if frames.len() >= MAX_CALL_DEPTH {
                                    return Err(fail(
                                        &self.files,
                                        GcodeError::invalid(
                                            line,
                                            col,
                                            format!(
                                                "subprogram calls nested deeper than {MAX_CALL_DEPTH}"
                                            ),
                                        ),
                                    ));
                                }
                                if count == 0 {
                                    pc += 1;
                                    continue;
                                }
                                frames.push(Frame {
                                    code: tc,
                                    ret: pc + 1,
                                    ret_code: c,
                                    saved: None,
                                    loops_base: loops.len(),
                                    repeat: count - 1,
                                    start: start + 1,
                                });
                                c = tc;
                                pc = start + 1;
                            }
                            FanucCall::M99 => {
                                let Some(f) = frames.last_mut() else {
                                    return Err(fail(
                                        &self.files,
                                        GcodeError::unsupported(
                                            line,
                                            col,
                                            "M99 in the main program (an endless repeat of the program)",
                                        ),
                                    ));
                                };
                                if f.repeat > 0 {
                                    f.repeat -= 1;
                                    pc = f.start;
                                    c = f.code;
                                } else {
                                    let f = frames.pop().unwrap_or(Frame {
                                        code: 0,
                                        ret: usize::MAX,
                                        ret_code: 0,
                                        saved: None,
                                        loops_base: 0,
                                        repeat: 0,
                                        start: 0,
                                    });
                                    loops.truncate(f.loops_base);
                                    c = f.ret_code;
                                    pc = f.ret;
                                }
                            }
                        }
                        continue;
                    }
                }
                events.clear();
                let path = file
                    .checked_sub(1)
                    .and_then(|k| self.files.get(k as usize))
                    .cloned();
                messages(block, interp.parameters(), self.opts, path.as_ref())
                    .map_err(|e| fail(&self.files, e))?;
                // Events are tagged with their file (those cutter
                // compensation held back keep the file they came from).
                interp.set_source_file(file);
                interp
                    .execute(block, &mut events)
                    .map_err(|e| fail(&self.files, e))?;
                sink(&Step {
                    block,
                    events: &events,
                    interp,
                    file,
                    held: true,
                })?;
                pc += 1;
                continue;
            };
            sink(&Step {
                block,
                events: &[],
                interp,
                file,
                held: true,
            })?;
            let rest = &block.text()[st.rest..];
            let col = st.column;
            let params = interp.parameters();
            let args = |what: &str| -> Result<Vec<f64>, GcodeError> {
                // A call's arguments may have comments between them (LinuxCNC
                // reads `[1] (note) [2]` as two arguments).
                let bad =
                    |e: expr::ExprError| GcodeError::invalid(line, st.rest + 1, e.to_string());
                let (v, end) = if st.kind == Kind::Call {
                    let Some((runs, end)) = call_arguments(rest) else {
                        return Err(GcodeError::syntax(
                            line,
                            st.rest + 1,
                            "a call argument '[' or a comment '(' is not closed",
                        ));
                    };
                    let mut v = Vec::new();
                    for run in runs {
                        v.extend(expr::bracket_list(run, params).map_err(bad)?.0);
                    }
                    (v, end)
                } else {
                    expr::bracket_list(rest, params).map_err(bad)?
                };
                let tail = &rest[end..];
                if !tail.is_empty() && !matches!(tail[0], b'(' | b';') {
                    return Err(GcodeError::syntax(
                        line,
                        st.rest + end + 1,
                        format!("unexpected text after the {what} arguments"),
                    ));
                }
                Ok(v)
            };
            let cond = |what: &str| -> Result<bool, GcodeError> {
                let v = args(what)?;
                match v.as_slice() {
                    [x] => Ok(*x != 0.0),
                    _ => Err(GcodeError::invalid(
                        line,
                        st.rest + 1,
                        format!("o{} {what} needs one [condition]", st.label),
                    )),
                }
            };
            match st.kind {
                Kind::Sub => {
                    // LinuxCNC records a definition when the flow passes it
                    // or a call finds it; meeting it again is an error.
                    if !self.fanuc && !self.recorded.insert((c, pc)) {
                        return Err(fail(
                            &self.files,
                            GcodeError::invalid(
                                line,
                                col,
                                format!(
                                    "sub o{} found in illegal location: the program reaches a \
                                     definition after calling it, or a second time",
                                    st.label
                                ),
                            ),
                        ));
                    }
                    pc = st.a + 1;
                }
                Kind::Program => {
                    pc = if st.a == usize::MAX { pc + 1 } else { st.a + 1 };
                }
                Kind::EndSub | Kind::Return => {
                    let v = args(keyword(st.kind)).map_err(|e| fail(&self.files, e))?;
                    let Some(f) = frames.pop() else {
                        return Err(fail(
                            &self.files,
                            GcodeError::invalid(
                                line,
                                col,
                                format!(
                                    "o{} {} outside a subroutine call",
                                    st.label,
                                    keyword(st.kind)
                                ),
                            ),
                        ));
                    };
                    let p = interp.parameters_mut();
                    if let Some(saved) = &f.saved {
                        p.leave_call(saved);
                    }
                    let _ = p.set_named("_value_returned", if v.is_empty() { 0.0 } else { 1.0 });
                    // LinuxCNC clears the value when none is returned.
                    let _ = p.set_named("_value", v.first().copied().unwrap_or(0.0));
                    loops.truncate(f.loops_base);
                    c = f.ret_code;
                    pc = f.ret;
                }
                Kind::Call => {
                    let v = args("call").map_err(|e| fail(&self.files, e))?;
                    let label = match st.label_expr {
                        None => st.label.clone(),
                        Some((a, b)) => computed_label(&block.text()[a..b], params)
                            .map_err(|m| fail(&self.files, GcodeError::invalid(line, a + 1, m)))?,
                    };
                    if frames.len() >= MAX_CALL_DEPTH {
                        return Err(fail(
                            &self.files,
                            GcodeError::invalid(
                                line,
                                col,
                                format!(
                                    "Too many nested levels of subroutine calls: o{} call at a depth of {MAX_CALL_DEPTH}",
                                    st.label
                                ),
                            ),
                        ));
                    }
                    let (tc, start) = self.find_sub(c, &label).map_err(|e| {
                        fail(
                            &self.files,
                            match e {
                                SubNotRun::Invalid(m) => GcodeError::invalid(line, col, m),
                                SubNotRun::Unsupported(m) => GcodeError::unsupported(line, col, m),
                            },
                        )
                    })?;
                    self.recorded.insert((tc, start));
                    let saved = interp.parameters_mut().enter_call(&v);
                    let _ = interp.parameters_mut().set_named("_value_returned", 0.0);
                    frames.push(Frame {
                        code: tc,
                        ret: pc + 1,
                        ret_code: c,
                        saved: Some(saved),
                        loops_base: loops.len(),
                        repeat: 0,
                        start: start + 1,
                    });
                    c = tc;
                    pc = start + 1;
                }
                Kind::If | Kind::ElseIf => {
                    if st.kind == Kind::ElseIf && !self.entering_elseif {
                        // Reached after a taken branch: skip to endif.
                        pc = st.b + 1;
                        continue;
                    }
                    self.entering_elseif = false;
                    if cond(keyword(st.kind)).map_err(|e| fail(&self.files, e))? {
                        pc += 1;
                    } else {
                        let next = st.a;
                        match self.codes[c].kind_opt(next) {
                            Some(Kind::ElseIf) => {
                                self.entering_elseif = true;
                                pc = next;
                            }
                            _ => pc = next + 1,
                        }
                    }
                }
                Kind::Else => pc = st.b + 1,
                Kind::EndIf => pc += 1,
                Kind::While => {
                    let on_top = loops.last().is_some_and(|l| l.code == c && l.start == pc);
                    if cond("while").map_err(|e| fail(&self.files, e))? {
                        if !on_top {
                            loops.push(Loop {
                                code: c,
                                start: pc,
                                remaining: 0,
                            });
                        }
                        pc += 1;
                    } else {
                        if on_top {
                            loops.pop();
                        }
                        pc = st.b + 1;
                    }
                }
                Kind::EndWhile => pc = st.a,
                Kind::Do => {
                    if !loops.last().is_some_and(|l| l.code == c && l.start == pc) {
                        loops.push(Loop {
                            code: c,
                            start: pc,
                            remaining: 0,
                        });
                    }
                    pc += 1;
                }
                Kind::DoWhile => {
                    if cond("while").map_err(|e| fail(&self.files, e))? {
                        pc = st.a + 1;
                    } else {
                        if loops.last().is_some_and(|l| l.code == c && l.start == st.a) {
                            loops.pop();
                        }
                        pc += 1;
                    }
                }
                Kind::Repeat => {
                    let v = args("repeat").map_err(|e| fail(&self.files, e))?;
                    let [n] = v.as_slice() else {
                        return Err(fail(
                            &self.files,
                            GcodeError::invalid(
                                line,
                                st.rest + 1,
                                format!("o{} repeat needs one [count]", st.label),
                            ),
                        ));
                    };
                    // LinuxCNC counts with the integer part.
                    let n = n.trunc();
                    if n >= 1.0 {
                        loops.push(Loop {
                            code: c,
                            start: pc,
                            remaining: n.min(u64::MAX as f64) as u64,
                        });
                        pc += 1;
                    } else {
                        pc = st.b + 1;
                    }
                }
                Kind::EndRepeat => {
                    let top = loops.last_mut().filter(|l| l.code == c && l.start == st.a);
                    match top {
                        Some(l) if l.remaining > 1 => {
                            l.remaining -= 1;
                            pc = st.a + 1;
                        }
                        _ => {
                            loops.pop();
                            pc += 1;
                        }
                    }
                }
                Kind::Break | Kind::Continue => {
                    let start = st.a;
                    let Some(k) = loops.iter().rposition(|l| l.code == c && l.start == start)
                    else {
                        return Err(fail(
                            &self.files,
                            GcodeError::invalid(
                                line,
                                col,
                                format!("o{} {} outside its loop", st.label, keyword(st.kind)),
                            ),
                        ));
                    };
                    let start_kind = self.codes[c].kind(start);
                    if st.kind == Kind::Break {
                        loops.truncate(k);
                        pc = st.b + 1;
                    } else {
                        loops.truncate(k + 1);
                        pc = match start_kind {
                            Kind::While => start,
                            // do: the closing while decides; repeat: endrepeat counts.
                            _ => st.b,
                        };
                    }
                }
            }
        }
        Ok(())
    }

    fn fanuc_call(
        &self,
        block: &Block,
        params: &Parameters,
    ) -> Result<Option<(FanucCall, usize)>, GcodeError> {
        let line = block.line();
        let mut m = None;
        for w in block.words().filter(|w| w.letter == b'M') {
            let v =
                word_value(block, w, params).map_err(|e| GcodeError::invalid(line, w.at + 1, e))?;
            if v == 98.0 || v == 99.0 {
                m = Some((v as u32, w.at + 1));
            }
        }
        let Some((code, col)) = m else {
            return Ok(None);
        };
        if let Some(w) = block
            .words()
            .find(|w| !matches!(w.letter, b'N' | b'M' | b'P' | b'L'))
        {
            return Err(GcodeError::unsupported(
                line,
                w.at + 1,
                format!("M{code} with other words on its line"),
            ));
        }
        if block.words().filter(|w| w.letter == b'M').count() > 1 {
            return Err(GcodeError::unsupported(
                line,
                col,
                format!("M{code} with other M-codes on its line"),
            ));
        }
        if code == 99 {
            return Ok(Some((FanucCall::M99, col)));
        }
        let value = |l: u8| -> Result<Option<f64>, GcodeError> {
            match block.words().find(|w| w.letter == l) {
                Some(w) => word_value(block, w, params)
                    .map(Some)
                    .map_err(|e| GcodeError::invalid(line, w.at + 1, e)),
                None => Ok(None),
            }
        };
        let Some(p) = value(b'P')? else {
            return Err(GcodeError::invalid(
                line,
                col,
                "M98 needs P (the subprogram number)",
            ));
        };
        let count = value(b'L')?.unwrap_or(1.0);
        if p < 0.0 || p.fract() != 0.0 || count < 0.0 || count.fract() != 0.0 {
            return Err(GcodeError::invalid(
                line,
                col,
                "M98 P and L must be non-negative integers",
            ));
        }
        Ok(Some((
            FanucCall::M98(format!("{}", p as u64), count as u64),
            col,
        )))
    }

    /// LinuxCNC dialect: the code and statement index of the program line
    /// `O<label>` an M98 in code `c` at `pc` runs: one an earlier M98 found,
    /// else the first after the call (LinuxCNC searches the file forward).
    fn m98_target(&mut self, c: usize, pc: usize, label: &str) -> Result<(usize, usize), String> {
        if let Some(&s) = self.m98_found.get(&(c, label.to_string())) {
            return Ok((c, s));
        }
        let code = &self.codes[c];
        let Some(&s) = code
            .numbered
            .get(label)
            .and_then(|v| v.iter().find(|&&k| k > pc))
        else {
            return Err(format!(
                "M98 P{label}: no program line O{label} after the call (LinuxCNC searches \
                 forward from the call to the end of the file)"
            ));
        };
        if code.kind(s) == Kind::Sub {
            return Err(format!(
                "M98 P{label}: o{label} is an O-word subroutine, called with o{label} call"
            ));
        }
        self.m98_found.insert((c, label.to_string()), s);
        Ok((c, s))
    }

    /// The code and statement index of subroutine `label`: the program's own
    /// definitions first, then the calling file's, then `label.ngc` on the
    /// search path (read once).
    fn find_sub(&mut self, from: usize, label: &str) -> Result<(usize, usize), SubNotRun> {
        if let Some(&s) = self.codes[0].subs.get(label) {
            return Ok((0, s));
        }
        if let Some(&s) = self.codes[from].subs.get(label) {
            return Ok((from, s));
        }
        if let Some(k) = (1..self.codes.len()).find(|&k| self.codes[k].subs.contains_key(label)) {
            return Ok((k, self.codes[k].subs[label]));
        }
        if !self.fanuc
            && self.codes[from]
                .numbered
                .get(label)
                .is_some_and(|v| v.iter().any(|&k| self.codes[from].kind(k) == Kind::Program))
        {
            return Err(SubNotRun::Invalid(format!(
                "O{label} is a program line (Fanuc style), called with M98 P{label}, not o{label} call"
            )));
        }
        let name = format!("{label}.ngc");
        let Some(path) = self
            .opts
            .subroutine_path
            .iter()
            .map(|d| d.join(&name))
            .find(|p| p.is_file())
        else {
            if let Some(module) = &self.opts.python {
                // LinuxCNC would look for it in the Python module first.
                return Err(SubNotRun::Unsupported(format!(
                    "Python o-word subroutine o<{label}> call: o<{label}> is neither in \
                     the program nor on the subroutine path, and mtwin runs no Python (the \
                     INI's [PYTHON] TOPLEVEL {})",
                    module.display()
                )));
            }
            return Err(SubNotRun::Invalid(format!(
                "Unable to open file {name}: subroutine o<{label}> is not defined in the program and no directory of the subroutine path has {name}"
            )));
        };
        let file = self.files.len() as u32 + 1;
        self.files.push(path.clone());
        let bytes = std::fs::read(&path)
            .map_err(|e| SubNotRun::Invalid(format!("cannot read {}: {e}", path.display())))?;
        let blocks = BlockReader::new(&bytes[..])
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| SubNotRun::Invalid(format!("{}:{}", path.display(), located_text(&e))))?;
        let code = Code::new(blocks, file, self.fanuc)
            .map_err(|e| SubNotRun::Invalid(format!("{}:{}", path.display(), located_text(&e))))?;
        let Some(&s) = code.subs.get(label) else {
            return Err(SubNotRun::Invalid(format!(
                "{} does not define o<{label}> sub",
                path.display()
            )));
        };
        self.codes.push(code);
        Ok((self.codes.len() - 1, s))
    }
}

/// Why a called subroutine cannot run: an error of the program, or a
/// subroutine mtwin does not run (Python).
enum SubNotRun {
    Invalid(String),
    Unsupported(String),
}

/// The label of a computed `o#<n> call` / `O[expr] call`: the value as an
/// integer (within 0.0001, LinuxCNC's tolerance), written as a number label.
fn computed_label(text: &[u8], params: &Parameters) -> Result<String, String> {
    let v = expr::eval(text, params).map_err(|e| e.to_string())?;
    let r = v.round();
    if (v - r).abs() > 1e-4 || !(0.0..=1e15).contains(&r) {
        return Err(format!(
            "O-word label {} is {v}: not a non-negative integer",
            String::from_utf8_lossy(text)
        ));
    }
    Ok(format!("{}", r as u64))
}

fn located_text(e: &GcodeError) -> String {
    match e.location() {
        Some(Location { line, column }) => format!("{line}:{}: {e}", column.max(1)),
        None => format!(" {e}"),
    }
}

enum FanucCall {
    M98(String, u64),
    M99,
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;
    use crate::gcode::{Axis, Dialect, EventKind, InterpOptions, interpret};

    /// Ends (X, Y, Z) and lines of the moves of a program.
    fn moves_with(src: &str, opts: InterpOptions) -> Result<Vec<([f64; 3], u64)>, GcodeError> {
        let mut out = Vec::new();
        interpret(src.as_bytes(), opts, |_, events| {
            for e in events {
                if let EventKind::Traverse(m) | EventKind::Feed(m) = e.kind {
                    out.push(([m.to[Axis::X], m.to[Axis::Y], m.to[Axis::Z]], e.at.line));
                }
            }
            Ok(())
        })?;
        Ok(out)
    }

    fn xs(src: &str) -> Vec<f64> {
        moves_with(src, InterpOptions::default())
            .unwrap()
            .iter()
            .map(|(p, _)| p[0])
            .collect()
    }

    fn err(src: &str) -> GcodeError {
        moves_with(src, InterpOptions::default()).unwrap_err()
    }

    #[test]
    fn assignments_take_effect_after_the_line() {
        // LinuxCNC: #1=1 #2=#1 on one line reads the old #1 (5, not 1); the
        // move of the line reads the old values too.
        assert_eq!(
            xs("#1=5\n#1=1 #2=#1 G0 X#1\nG0 X#2\nG0 X#1\n"),
            vec![5.0, 5.0, 1.0]
        );
        assert_eq!(
            xs("#<a>=2\n#<_bb>=[#<a>*3]\nG0 X[#<_bb>+#<a>]\n"),
            vec![8.0]
        );
        assert_eq!(xs("#5=3\n#[#5+1]=7\nG0 X##5 Y#4\n"), vec![0.0]);
        let e = err("G0 X#<undefined>\n");
        assert!(e.to_string().contains("#<undefined> not defined"), "{e}");
        assert_eq!(e.location().unwrap().line, 1);
    }

    #[test]
    fn subroutine_with_arguments_and_return_value() {
        let src = "o<sq> sub\n#<r> = [#1 * #1]\nG0 X#<r> Y#2\no<sq> return [#<r> + 1]\no<sq> endsub\n\
                   #1 = 9\no<sq> call [3] [4]\nG0 X#<_value> Y#1 Z#<_value_returned>\nM2\n";
        let m = moves_with(src, InterpOptions::default()).unwrap();
        // Inside: X = 3² = 9, Y = 4 (line 3); after: _value = 10, #1 restored to 9.
        assert_eq!(m, vec![([9.0, 4.0, 0.0], 3), ([10.0, 9.0, 1.0], 8)]);
    }

    #[test]
    fn comments_between_call_arguments_are_skipped() {
        // LinuxCNC reads a call's `[..]` arguments and the comments between
        // them: `[1] (note) [2] [3]` is #1 = 1, #2 = 2, #3 = 3 (the
        // flowsnake conformance program's first call has such a comment).
        let src = "o<s> sub\nG0 X#1 Y#2 Z#3\no<s> endsub\n\
                   o<s> call [1] (will this comment cause problems) [2] ( two )[1+2] (end)\nM2\n";
        let m = moves_with(src, InterpOptions::default()).unwrap();
        assert_eq!(m, vec![([1.0, 2.0, 3.0], 2)]);
        // Text other than a comment after the arguments is still refused.
        let e = err("o<s> sub\no<s> endsub\no<s> call [1] (c) X2\nM2\n");
        assert!(e.to_string().contains("after the call arguments"), "{e}");
        let e = err("o<s> sub\no<s> endsub\no<s> call [1] (c) [2\nM2\n");
        assert_eq!(e.location().unwrap().line, 3, "{e}");
    }

    #[test]
    fn value_returned_as_the_linuxcnc_case_checks_it() {
        // The G-code part of LinuxCNC's `value-returned` test, its Python
        // asserts written as moves to X = #<_value>, Y = #<_value_returned>:
        // 0 0 at the start; endsub [4711] returns 4711; a procedure clears
        // both; a `return [4712]` (labelled o100, inside o<function2>)
        // returns 4712; the procedure clears them again.
        let src = "o<function1> sub\no<function1> endsub [4711]\n\
                   o<function2> sub\no100 return [4712]\no<function2> endsub\n\
                   o<proc> sub\no<proc> endsub\n\
                   G0 X#<_value> Y#<_value_returned>\n\
                   o<function1> call\nG0 X#<_value> Y#<_value_returned>\n\
                   o<proc> call\nG0 X#<_value> Y#<_value_returned>\n\
                   o<function2> call\nG0 X#<_value> Y#<_value_returned>\n\
                   o<proc> call\nG0 X#<_value> Y#<_value_returned>\nM2\n";
        let ends: Vec<[f64; 3]> = moves_with(src, InterpOptions::default())
            .unwrap()
            .iter()
            .map(|(p, _)| *p)
            .collect();
        assert_eq!(
            ends,
            vec![
                [0.0, 0.0, 0.0],
                [4711.0, 1.0, 0.0],
                [0.0, 0.0, 0.0],
                [4712.0, 1.0, 0.0],
                [0.0, 0.0, 0.0]
            ]
        );
    }

    #[test]
    fn python_comments_and_subroutines_are_refused_as_unsupported() {
        let unsupported = |src: &str, opts: InterpOptions| match moves_with(src, opts) {
            Err(e @ GcodeError::Unsupported { .. }) => e,
            other => panic!("{src:?}: {other:?}"),
        };
        // `(py,…)`, `(pyrun,…)`, `(pyreload)` anywhere, `;py,` at the start
        // of a line: LinuxCNC runs them as Python.
        for (src, line, col) in [
            ("G0 X1\nG0 X2 (py,x = 1)\nM2\n", 2, 7),
            ("G0 X1 ( PyRun,f.py)\nM2\n", 1, 7),
            ("(pyreload)\nM2\n", 1, 1),
            ("G0 X1\n;py,import interpreter\nM2\n", 2, 1),
        ] {
            let e = unsupported(src, InterpOptions::default());
            assert!(e.to_string().contains("Python"), "{e}");
            let at = e.location().unwrap();
            assert_eq!((at.line, at.column), (line, col), "{src:?}: {e}");
        }
        // Other comments that only look alike are comments.
        assert_eq!(
            xs("G0 X1 ;py,not at the line start\n(python)\nM2\n"),
            vec![1.0]
        );
        // A call of a subroutine found nowhere: with a Python module in
        // the INI it is refused as a Python o-word subroutine, without one
        // as a missing subroutine.
        let src = "G0 X1\no<canonmove> call [1] [2] [3]\nM2\n";
        let mut opts = InterpOptions::default();
        opts.program.apply_ini(
            "[PYTHON]\nTOPLEVEL = subs.py\n",
            std::path::Path::new("/cnc"),
        );
        assert_eq!(
            opts.program.python.as_deref(),
            Some(std::path::Path::new("/cnc/subs.py"))
        );
        let e = unsupported(src, opts);
        assert!(
            e.to_string()
                .contains("Python o-word subroutine o<canonmove>"),
            "{e}"
        );
        assert_eq!(e.location().unwrap().line, 2);
        let e = err(src);
        assert!(matches!(e, GcodeError::Invalid { .. }), "{e}");
        assert!(e.to_string().contains("canonmove.ngc"), "{e}");
    }

    #[test]
    fn value_starts_at_zero_and_a_plain_return_clears_it() {
        // LinuxCNC: #<_value> is 0 before any call; a return without a value
        // sets it (and #<_value_returned>) back to 0.
        let src = "o<f> sub\no1 if [#1 GT 0]\no<f> return [#1 * 2]\no1 endif\no<f> end sub\n\
                   G0 X#<_value> Y#<_value_returned>\no<f> call [3]\nG0 X#<_value> Y#<_value_returned>\n\
                   o<f> call [-1]\nG0 X#<_value> Y#<_value_returned> Z1\nM2\n";
        let m = moves_with(src, InterpOptions::default()).unwrap();
        let ends: Vec<[f64; 3]> = m.iter().map(|(p, _)| *p).collect();
        assert_eq!(ends, vec![[0.0; 3], [6.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    }

    #[test]
    fn keywords_may_hold_blanks() {
        let src = "#1=0\no1 while [#1 LT 2]\nG0 X#1\n#1=[#1+1]\no1 end while\n\
                   o2 if [#1 EQ 5]\nG0 Y1\no2 else if [#1 EQ 2]\nG0 Y2\no2 end if\n";
        let m = moves_with(src, InterpOptions::default()).unwrap();
        let ends: Vec<[f64; 3]> = m.iter().map(|(p, _)| *p).collect();
        assert_eq!(ends, vec![[0.0; 3], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0]]);
    }

    #[test]
    fn abort_comment_prints_and_stops() {
        let got: Arc<Mutex<Vec<(MessageKind, String)>>> = Arc::default();
        let sink = got.clone();
        let mut opts = InterpOptions::default();
        opts.program.messages = MessageSink::new(move |m: &Message| {
            sink.lock().unwrap().push((m.kind, m.text.clone()));
        });
        // The abort fires on the third run of the loop body, before the
        // move of its own line.
        let src = "#42=0\no1 while [#42 LT 5]\nG0 X#42\no2 if [#42 EQ 2]\n(abort, at #42)G0 Y9\no2 endif\n\
                   #42=[#42+1]\no1 endwhile\nM2\n";
        let mut xs = Vec::new();
        let e = interpret(src.as_bytes(), opts, |_, events| {
            for ev in events {
                if let EventKind::Traverse(m) = ev.kind {
                    xs.push((m.to[Axis::X], m.to[Axis::Y]));
                }
            }
            Ok(())
        })
        .unwrap_err();
        assert_eq!(xs, vec![(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)]);
        assert_eq!(e.location().map(|l| (l.line, l.column)), Some((5, 1)));
        assert!(
            e.to_string().contains("aborted") && e.to_string().contains(" at 2.000000"),
            "{e}"
        );
        assert_eq!(
            got.lock().unwrap().clone(),
            vec![(MessageKind::Abort, " at 2.000000".to_string())]
        );
    }

    #[test]
    fn ini_values_and_subroutine_path() {
        let dir = std::env::temp_dir().join(format!("mtwin-ini-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("subs")).unwrap();
        std::fs::write(
            dir.join("subs/tc.ngc"),
            "o<tc> sub\nG53 G0 Z#<_ini[vars]toolchange_z>\no<tc> endsub\nM2\n",
        )
        .unwrap();
        let mut opts = InterpOptions::default();
        opts.program.apply_ini(
            "[RS274NGC]\nSUBROUTINE_PATH = nope:subs\n[VARS]\nTOOLCHANGE_X = 10\nTOOLCHANGE_Z = -2.5\n",
            &dir,
        );
        assert_eq!(
            opts.program.subroutine_path,
            vec![dir.join("nope"), dir.join("subs")]
        );
        let m = moves_with(
            "G0 X#<_INI[Vars]ToolChange_X>\no<tc> call\nM2\n",
            opts.clone(),
        )
        .unwrap();
        let ends: Vec<[f64; 3]> = m.iter().map(|(p, _)| *p).collect();
        assert_eq!(ends, vec![[10.0, 0.0, 0.0], [10.0, 0.0, -2.5]]);
        let e = moves_with("#<_ini[vars]toolchange_x> = 1\n", opts.clone()).unwrap_err();
        assert!(e.to_string().contains("read-only"), "{e}");
        let e = moves_with("G0 X#<_ini[vars]nosuch>\n", opts).unwrap_err();
        assert!(e.to_string().contains("not defined"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn if_elseif_else() {
        let prog = |v: f64| {
            format!(
                "#1={v}\no1 if [#1 LT 0]\nG0 X-1\no1 elseif [#1 EQ 0]\nG0 X0\no1 elseif [#1 LT 10]\nG0 X1\no1 else\nG0 X2\no1 endif\nG0 Y1\n"
            )
        };
        for (v, x) in [(-5.0, -1.0), (0.0, 0.0), (5.0, 1.0), (50.0, 2.0)] {
            assert_eq!(xs(&prog(v)), vec![x, x], "#1 = {v}");
        }
    }

    #[test]
    fn loops_count_and_nest() {
        // while: 0, 1, 2, 3, 4.
        let w = "#1=0\no1 while [#1 LT 5]\nG0 X#1\n#1=[#1+1]\no1 endwhile\n";
        assert_eq!(xs(w), vec![0.0, 1.0, 2.0, 3.0, 4.0]);
        // do-while runs its body once even when the condition is false.
        assert_eq!(
            xs("#1=10\no2 do\nG0 X#1\n#1=[#1+1]\no2 while [#1 LT 3]\n"),
            vec![10.0]
        );
        // repeat 3 of repeat 2: 6 moves, X = 10·i + j.
        let r = "#1=0\no3 repeat [3]\n#2=0\no4 repeat [2]\nG0 X[#1*10+#2]\n#2=[#2+1]\no4 endrepeat\n#1=[#1+1]\no3 endrepeat\n";
        assert_eq!(xs(r), vec![0.0, 1.0, 10.0, 11.0, 20.0, 21.0]);
        assert_eq!(xs("o5 repeat [0]\nG0 X1\no5 endrepeat\nG0 X2\n"), vec![2.0]);
    }

    #[test]
    fn break_and_continue() {
        // Skip 2, stop after 4.
        let src = "#1=0\no1 while [1]\n#1=[#1+1]\no2 if [#1 EQ 2]\no1 continue\no2 endif\n\
                   o3 if [#1 GT 4]\no1 break\no3 endif\nG0 X#1\no1 endwhile\nG0 Y9\n";
        assert_eq!(xs(src), vec![1.0, 3.0, 4.0, 4.0]);
        // continue in repeat counts the iteration.
        let r = "#1=0\no1 repeat [4]\n#1=[#1+1]\no2 if [#1 MOD 2 EQ 0]\no1 continue\no2 endif\nG0 X#1\no1 endrepeat\n";
        assert_eq!(xs(r), vec![1.0, 3.0]);
        // break in do.
        let d =
            "#1=0\no1 do\n#1=[#1+1]\no2 if [#1 EQ 3]\no1 break\no2 endif\nG0 X#1\no1 while [1]\n";
        assert_eq!(xs(d), vec![1.0, 2.0]);
    }

    #[test]
    fn recursion_depth_and_endless_loop_are_errors() {
        let rec = "o<r> sub\no<r> call\no<r> endsub\no<r> call\nM2\n";
        let e = err(rec);
        assert!(e.to_string().contains("nested"), "{e}");
        assert_eq!(e.location().unwrap().line, 2);
        // Recursion that stops: factorial of 5 by recursion = 120.
        let fact = "o<f> sub\no1 if [#1 LE 1]\no<f> return [1]\no1 endif\no<f> call [#1-1]\no<f> return [#1 * #<_value>]\no<f> endsub\no<f> call [5]\nG0 X#<_value>\n";
        assert_eq!(xs(fact), vec![120.0]);
        let mut opts = InterpOptions::default();
        opts.program.max_blocks = 1000;
        let e = moves_with("o1 while [1]\nG0 X1\no1 endwhile\n", opts).unwrap_err();
        assert!(e.to_string().contains("more than 1000 blocks"), "{e}");
    }

    #[test]
    fn bad_structure_names_the_line() {
        for (src, line, what) in [
            ("G0 X1\no1 endwhile\n", 2, "without a matching"),
            ("o<a> sub\nG0 X1\n", 1, "not closed"),
            ("o1 if [1]\no1 endwhile\n", 2, "without a matching"),
            ("o<nope> call\n", 1, "Unable to open file nope.ngc"),
            ("o2 break\n", 1, "outside a loop"),
            ("o1 frob\n", 1, "unknown O-word statement"),
            ("o1 return\n", 1, "outside a subroutine"),
            ("o1 if\no1 endif\n", 1, "needs one [condition]"),
        ] {
            let e = err(src);
            assert!(e.to_string().contains(what), "{src:?}: {e}");
            assert_eq!(e.location().unwrap().line, line, "{src:?}: {e}");
        }
    }

    #[test]
    fn external_subroutine_file_on_the_path() {
        let dir = std::env::temp_dir().join(format!("mtwin-flow-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("probe.ngc"),
            "(a file subroutine)\no<probe> sub\nG0 X[#1*2]\no<probe> endsub\nM2\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("bad.ngc"),
            "o<bad> sub\nG0 X#<zz>\no<bad> endsub\n",
        )
        .unwrap();
        let mut opts = InterpOptions::default();
        opts.program.subroutine_path = vec![dir.join("missing"), dir.clone()];
        let mut files = Vec::new();
        interpret(
            "o<Probe> call [4]\nG0 Y1\n".as_bytes(),
            opts.clone(),
            |_, events| {
                for e in events {
                    if let EventKind::Traverse(m) = e.kind {
                        files.push((e.at.file, e.at.line, m.to[Axis::X]));
                    }
                }
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(files, vec![(1, 3, 8.0), (0, 2, 8.0)]);
        let e = moves_with("o<bad> call\n", opts).unwrap_err();
        assert_eq!(e.file(), Some(dir.join("bad.ngc").as_path()));
        assert_eq!(e.location().unwrap().line, 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn fanuc_m98_m99() {
        let opts = InterpOptions {
            dialect: Dialect::Fanuc {
                decimal_point_programming: true,
            },
            ..InterpOptions::default()
        };
        // Main: three runs of O1000 (incremental X+2 each), then one of O2000.
        let src = "%\nO0001 (MAIN)\nG21 G91\nM98 P1000 L3\nM98 P2000\nG90\nM30\nO1000\nG0 X2.\nM99\nO2000\nG0 Y5.\nM99\n%\n";
        let m = moves_with(src, opts.clone()).unwrap();
        let ends: Vec<[f64; 3]> = m.iter().map(|(p, _)| *p).collect();
        assert_eq!(
            ends,
            vec![
                [2.0, 0.0, 0.0],
                [4.0, 0.0, 0.0],
                [6.0, 0.0, 0.0],
                [6.0, 5.0, 0.0]
            ]
        );
        assert_eq!(m[0].1, 9);
        // The program number line at the top, in its forms; nothing else on it.
        for src in [
            "O1234\nG0 X1.\nM30\n",
            "%\nO1234 (PART)\nG0 X1.\nM30\n%\n",
            "O1234(X)\nG0 X1.\nM30\n",
            "N1 O0001\nG0 X1.\nM30\n",
        ] {
            let m = moves_with(src, opts.clone()).unwrap();
            assert_eq!(m.len(), 1, "{src:?}");
            assert_eq!(m[0].0[0], 1.0, "{src:?}");
        }
        let e = moves_with("O1234 G0 X1.\nM30\n", opts.clone()).unwrap_err();
        assert!(e.to_string().contains("program number line"), "{e}");
        assert_eq!(e.location().unwrap().line, 1);
        let e = moves_with("G0 X1\nM99\n", opts.clone()).unwrap_err();
        assert!(e.to_string().contains("M99 in the main program"), "{e}");
        let e = moves_with("M98 P7\nM30\n", opts).unwrap_err();
        assert!(e.to_string().contains("no subprogram O7"), "{e}");
    }

    #[test]
    fn fanuc_colon_program_numbers() {
        let opts = InterpOptions {
            dialect: Dialect::Fanuc {
                decimal_point_programming: true,
            },
            ..InterpOptions::default()
        };
        // `:1234` is `O1234`: the name at the top, a subprogram further on.
        let src = "%\n:0001 (MAIN)\nG0 X1.\nM98 P2000 L2\nM30\n:2000\nG91 G0 Y5.\nG90\nM99\n%\n";
        let m = moves_with(src, opts.clone()).unwrap();
        let ends: Vec<[f64; 3]> = m.iter().map(|(p, _)| *p).collect();
        assert_eq!(
            ends,
            vec![[1.0, 0.0, 0.0], [1.0, 5.0, 0.0], [1.0, 10.0, 0.0]]
        );
        for bad in [":12 G0 X1.\n", ":<name>\nM30\n", ":12 sub\nM30\n"] {
            let e = moves_with(bad, opts.clone()).unwrap_err();
            assert_eq!(e.location().unwrap().line, 1, "{bad:?}: {e}");
        }
        // The LinuxCNC dialect has no ':' program numbers.
        let e = err(":1234\nG0 X1\nM2\n");
        assert!(e.to_string().contains("':'"), "{e}");
        assert_eq!(e.location().unwrap().column, 1);
    }

    #[test]
    fn linuxcnc_numbered_programs_and_m98() {
        // M98 P5 L2 runs O5 twice (X+1 each, incremental), then the main
        // program goes on; O5 is found forward from the call.
        let src = "G0 X1\nM98 P5 L2\nG0 Y2\nM2\nO5\nG91 G0 X1\nG90\nM99\n";
        let m = moves_with(src, InterpOptions::default()).unwrap();
        let ends: Vec<[f64; 3]> = m.iter().map(|(p, _)| *p).collect();
        assert_eq!(
            ends,
            vec![
                [1.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [3.0, 0.0, 0.0],
                [3.0, 2.0, 0.0]
            ]
        );
        // M98 passes #1..#30 as they are (no local copy).
        assert_eq!(
            xs("#1=5\nM98 P1\nG0 X#1\nM2\nO1\n#1=[#1+1]\nM99\n"),
            vec![6.0]
        );
        // A program line met in the flow does nothing; M99 of the main
        // program ends it (as M2: a program end event, nothing after).
        let mut ended = false;
        let mut xs_seen = Vec::new();
        interpret(
            "O1 (main)\nG0 X1\nO2\nG0 X2\nM99\nG0 X3\nM2\n".as_bytes(),
            InterpOptions::default(),
            |_, events| {
                for e in events {
                    match e.kind {
                        EventKind::Traverse(m) => xs_seen.push(m.to[Axis::X]),
                        EventKind::ProgramEnd => ended = true,
                        _ => {}
                    }
                }
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(xs_seen, vec![1.0, 2.0]);
        assert!(ended);
        // Named program line.
        assert_eq!(xs("O<part>\nG0 X4\nM30\n"), vec![4.0]);
        // Backward M98 (LinuxCNC searches forward only), M98 of an O-word
        // sub, o-call of a program line, M99 in an O-word sub.
        for (src, what, line) in [
            (
                "M98 P6\nM2\nO5\nG0 Y1\nM99\nO6\nM98 P5\nM99\n",
                "no program line O5 after the call",
                7,
            ),
            ("M98 P5\nM2\nO5 sub\nO5 endsub\n", "called with o5 call", 1),
            ("O5 call\nM2\nO5\nM99\n", "called with M98 P5", 1),
            (
                "O1 call\nM2\nO1 sub\nM99\nO1 endsub\n",
                "M99 inside an O-word subroutine",
                4,
            ),
        ] {
            let e = err(src);
            assert!(e.to_string().contains(what), "{src:?}: {e}");
            assert_eq!(e.location().unwrap().line, line, "{src:?}");
        }
    }

    #[test]
    fn computed_call_labels() {
        // O[#2 * 10] is o100; o#<s> with #<s> = 2 is o2.
        let src = "#2=10\nO[#2*10] call\n#<s>=2\no#<s> call\nM2\n\
                   O100 sub\nG0 X1\nO100 endsub\no2 sub\nG0 X2\no2 endsub\n";
        assert_eq!(xs(src), vec![1.0, 2.0]);
        let e = err("#2=2\nO[#2*1.25] call\nM2\nO2 sub\nO2 endsub\n");
        assert!(e.to_string().contains("not a non-negative integer"), "{e}");
        let e = err("#1=1\no#1 sub\no#1 endsub\n");
        assert!(e.to_string().contains("computed O-word label"), "{e}");
    }

    #[test]
    fn a_sub_reached_after_its_call_is_refused() {
        // LinuxCNC: a forward call records the definition; the flow then
        // reaching it is "found in illegal location".
        let e = err("G0 X1\nO2 call\nO2 sub\nG0 Y1\nO2 endsub\nM2\n");
        assert!(e.to_string().contains("illegal location"), "{e}");
        assert_eq!(e.location().unwrap().line, 3);
        // Defined first, called later: fine.
        assert_eq!(
            xs("O2 sub\nG91 G0 X7\nG90\nO2 endsub\nO2 call\nO2 call\nM2\n"),
            vec![7.0, 14.0]
        );
    }

    #[test]
    fn function_values_after_hash() {
        // LinuxCNC reads any value after '#': atan(1/1) = 45°, sin 90° = 1.
        assert_eq!(
            moves_with(
                "#atan[1]/[1]=3\n#sin[90]=7\nG0 X#45 Y#1 Z#[atan[1]/[1]]\n",
                InterpOptions::default()
            )
            .unwrap()[0]
                .0,
            [3.0, 7.0, 3.0]
        );
    }

    #[test]
    fn debug_and_print_messages_substitute_parameters() {
        let got: Arc<Mutex<Vec<(MessageKind, String, u64)>>> = Arc::default();
        let sink = got.clone();
        let mut opts = InterpOptions::default();
        opts.program.messages = MessageSink::new(move |m: &Message| {
            sink.lock().unwrap().push((m.kind, m.text.clone(), m.line));
        });
        let src = "#1=2.5\n#<d>=-1\n(debug, one=#1 d=#<d> u=#<u>)\no1 repeat [2]\n(PRINT,#1)\no1 endrepeat\n(MSG, not this)\n";
        moves_with(src, opts).unwrap();
        let got = got.lock().unwrap().clone();
        assert_eq!(
            got,
            vec![
                (
                    MessageKind::Debug,
                    " one=2.500000 d=-1.000000 u=######".to_string(),
                    3
                ),
                (MessageKind::Print, "2.500000".to_string(), 5),
                (MessageKind::Print, "2.500000".to_string(), 5),
                (MessageKind::Msg, " not this".to_string(), 7),
            ]
        );
    }

    /// `#<_line>` reads the number of the line being read (in a
    /// subroutine or loop body, that body line), and `(DEBUG,…)` is shown
    /// only while #5599 is above 0 (1 at start); PRINT and MSG always. The
    /// messages and the move as `rs274` 2.9 prints them for this program.
    #[test]
    fn line_parameter_and_the_debug_switch() {
        let got: Arc<Mutex<Vec<(MessageKind, String, u64)>>> = Arc::default();
        let sink = got.clone();
        let mut opts = InterpOptions::default();
        opts.program.messages = MessageSink::new(move |m: &Message| {
            sink.lock().unwrap().push((m.kind, m.text.clone(), m.line));
        });
        let src = "(debug, a #<_line>)\no1 sub\n(debug, s #<_line>)\no1 endsub\n\
                   o2 repeat [2]\n(debug, r #<_line>)\no2 endrepeat\no1 call\nG0 X#<_line>\n\
                   #5599=0\n(debug, hidden)\n(PRINT, p #<_line>)\n#5599=-1\n(debug, hidden)\n\
                   #5599=0.0001\n(debug, shown)\nM2\n";
        let m = moves_with(src, opts).unwrap();
        assert_eq!(m, [([9.0, 0.0, 0.0], 9)]);
        let got = got.lock().unwrap().clone();
        let d = |t: &str, l| (MessageKind::Debug, t.to_string(), l);
        assert_eq!(
            got,
            vec![
                d(" a 1.000000", 1),
                d(" r 6.000000", 6),
                d(" r 6.000000", 6),
                d(" s 3.000000", 3),
                (MessageKind::Print, " p 12.000000".to_string(), 12),
                d(" shown", 16),
            ]
        );
        // Read only, as in LinuxCNC.
        let e = moves_with("#<_line>=3\nM2\n", InterpOptions::default()).unwrap_err();
        assert!(e.to_string().contains("read-only"), "{e}");
    }

    #[test]
    fn messages_format_as_linuxcnc_prints_them() {
        // LinuxCNC's rules (checked against rs274 2.9): only the last
        // comment of a line runs; `%d`, `%f`, `%.Nf` set the decimals of the
        // values after them (0, 4, N); `%.` without `Nf` prints `.`, `%`
        // before anything else stays; within 0.0001 of zero prints as zero;
        // #0 reads 0 and #5602 is out of range; MSG is not substituted.
        let got: Arc<Mutex<Vec<(MessageKind, String)>>> = Arc::default();
        let sink = got.clone();
        let mut opts = InterpOptions::default();
        opts.program.messages = MessageSink::new(move |m: &Message| {
            sink.lock().unwrap().push((m.kind, m.text.clone()));
        });
        let src = "#1=0.00005\n#<a>=-0.00001\n#2=1.123456789\nG0 X1 (DEBUG,a) (DEBUG,b)\n\
                   (DEBUG,x %.3 y %z #1 #<a> #0 #5602 #< A > %.2f#2 #3 %d#2)\n(MSG,m #1)\n\
                   (debug,%f#2 %.7f#2 #2 # #<a)\nM2\n";
        moves_with(src, opts).unwrap();
        let got = got.lock().unwrap().clone();
        let want = [
            (MessageKind::Debug, "b"),
            (
                MessageKind::Debug,
                "x .3 y %z 0.000000 0.000000 0.000000 ###### 0.000000 1.12 0.00 1",
            ),
            (MessageKind::Msg, "m #1"),
            (MessageKind::Debug, "1.1235 1.1234568 1.1234568 # #<a"),
        ];
        let want: Vec<(MessageKind, String)> =
            want.iter().map(|(k, t)| (*k, t.to_string())).collect();
        assert_eq!(got, want);
    }

    #[test]
    fn reading_stops_at_the_program_end() {
        let keep = ProgramOptions {
            keep_rest: true,
            ..Default::default()
        };
        let run = |src: &str| {
            let mut interp = Interpreter::new(InterpOptions::default());
            let mut lines = Vec::new();
            let s = run_program(
                src.as_bytes(),
                &mut interp,
                &keep,
                Dialect::LinuxCnc,
                |st: &Step<'_>| -> Result<(), GcodeError> {
                    lines.push(st.block.line());
                    Ok(())
                },
            );
            (s, lines)
        };
        // Streamed: nothing after M30 is read; it comes back unread.
        let (s, lines) = run("G0 X1\nM30\nX[1 +\n\u{1}junk\n");
        let s = s.unwrap();
        assert_eq!(lines, [1, 2]);
        assert_eq!(s.rest, b"X[1 +\n\x01junk\n");
        // Without `keep_rest` the rest is neither read nor held.
        let mut interp = Interpreter::new(InterpOptions::default());
        let mut input: &[u8] = b"G0 X1\nM30\nG0 X2\n";
        let s = run_program(
            &mut input,
            &mut interp,
            &ProgramOptions::default(),
            Dialect::LinuxCnc,
            |_: &Step<'_>| -> Result<(), GcodeError> { Ok(()) },
        )
        .unwrap();
        assert!(s.rest.is_empty());
        assert_eq!(input, b"G0 X2\n");
        // Held: a line after the end that does not parse is never run.
        let (s, lines) = run("o1 repeat [2]\nG0 X1\no1 endrepeat\nM2\nX[1 +\n");
        assert_eq!(s.unwrap().held.len(), 5);
        assert_eq!(lines, [1, 2, 3, 2, 3, 4]);
        // ... but one that runs is the error, naming its line.
        let (s, _) = run("o1 repeat [2]\nG0 X1\no1 endrepeat\nX[1 +\nM2\n");
        let e = s.unwrap_err();
        assert_eq!(e.location().map(|l| l.line), Some(4), "{e}");
    }

    #[test]
    fn plain_programs_stream_and_flow_programs_are_held_from_the_first_o_word() {
        let src = "G0 X1\nG0 X2\no1 repeat [2]\nG0 X3\no1 endrepeat\n";
        let mut interp = Interpreter::new(InterpOptions::default());
        let mut held_flags = Vec::new();
        let s = run_program(
            src.as_bytes(),
            &mut interp,
            &ProgramOptions::default(),
            Dialect::LinuxCnc,
            |st: &Step<'_>| -> Result<(), GcodeError> {
                held_flags.push((st.block.line(), st.held));
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(s.held.len(), 3, "lines 3 to 5 are held");
        assert_eq!(s.held[0].line(), 3);
        assert_eq!(s.executed, 2 + 1 + 2 * 2);
        assert_eq!(held_flags[..3], [(1, false), (2, false), (3, true)]);
        let mut interp = Interpreter::new(InterpOptions::default());
        let s = run_program(
            "G0 X1\n".as_bytes(),
            &mut interp,
            &ProgramOptions::default(),
            Dialect::LinuxCnc,
            |_: &Step<'_>| -> Result<(), GcodeError> { Ok(()) },
        )
        .unwrap();
        assert!(s.held.is_empty());
    }

    /// The sink's own error type through the type-erased runner: its error
    /// comes back as it was returned and stops the run at its block, in a
    /// streamed and in a held program; a program error comes back through
    /// `From<GcodeError>`.
    #[test]
    fn a_sink_error_of_its_own_type_comes_back_unchanged() {
        #[derive(Debug, PartialEq)]
        enum Mine {
            Stopped(u64),
            Program(String),
        }
        impl From<GcodeError> for Mine {
            fn from(e: GcodeError) -> Mine {
                Mine::Program(e.to_string())
            }
        }
        let run = |src: &str, stop_at: u64| {
            let mut interp = Interpreter::new(InterpOptions::default());
            let mut seen = Vec::new();
            let r = run_program(
                src.as_bytes(),
                &mut interp,
                &ProgramOptions::default(),
                Dialect::LinuxCnc,
                |st: &Step<'_>| -> Result<(), Mine> {
                    seen.push(st.block.line());
                    if st.block.line() == stop_at {
                        return Err(Mine::Stopped(stop_at));
                    }
                    Ok(())
                },
            );
            (r.map(|s| s.executed), seen)
        };
        let (r, seen) = run("G0 X1\nG0 X2\nG0 X3\n", 2);
        assert_eq!(r, Err(Mine::Stopped(2)));
        assert_eq!(seen, [1, 2]);
        let (r, seen) = run("o1 repeat [3]\nG0 X1\no1 endrepeat\nM2\n", 2);
        assert_eq!(r, Err(Mine::Stopped(2)));
        assert_eq!(seen, [1, 2]);
        let (r, seen) = run("G0 X1\nG0 X[1 +\nG0 X3\n", 0);
        match r {
            Err(Mine::Program(m)) => assert!(m.contains('2'), "{m}"),
            other => panic!("a program error, not {other:?}"),
        }
        assert_eq!(seen, [1]);
        assert_eq!(run("G0 X1\nG0 X2\n", 0).0, Ok(2));
    }
}
