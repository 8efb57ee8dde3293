//! Geometric compensation of part programs: every move target is replaced by
//! the axis positions that make the identified (actual) machine reach the
//! nominal target.
//!
//! * Plain programs (axis words are machine axis positions after offsets):
//!   the target is the nominal forward kinematics of the programmed axes; on a
//!   five-axis machine with five axes it is the tool tip **and** the tool axis
//!   (every axis free), otherwise the tip only (linear axes free).
//! * TCP programs (X Y Z is the tool tip in W, rotaries given): the target is
//!   the programmed tip with the nominal tool axis at the programmed rotaries;
//!   the new block keeps TCP semantics: X Y Z = nominal tip of the corrected
//!   axes, rotaries = corrected rotaries.
//!
//! A feed move whose compensated straight line leaves the nominal path by more
//! than `tol` mm at its midpoint is split there, recursively; an arc is kept
//! (end words corrected) when its correction is nearly uniform, else converted
//! to lines (with a note). Every byte of an unchanged word is kept. The
//! program is read and written block by block.

pub mod doc;
mod path;

pub use doc::CompensateDoc;

use std::collections::HashMap;
use std::io::{BufRead, Write};

use nalgebra::Vector3;

use crate::gcode::program_flow::{Step, run_program};
use crate::gcode::timing::lerp;
use crate::gcode::{
    Axes, Axis, AxisLetterError, Block, BlockWriter, Dialect, DistanceMode, EventKind, Feed,
    GcodeError, InterpOptions, Interpreter, Item, NumberFormat, ProgramOptions, Programmed, Value,
};
use crate::kinematics::{IkError, IkJacobian, IkOptions, IkTarget, Kinematics};
use crate::model::{AxisKind, Machine};
use path::NominalPath;

/// Largest rotary correction accepted from a tip-and-axis solution, degree;
/// above it the pose is taken as singular (see [`Summary::axis_not_corrected`]).
const MAX_ROTARY: f64 = 0.5;

/// Largest number of halvings of one move.
const MAX_DEPTH: u32 = 24;

/// Compensation settings.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct CompensateOptions {
    /// Largest allowed deviation of the compensated path from the nominal
    /// path, mm (drives subdivision).
    pub tol: f64,
    /// Largest allowed correction of one target, mm (Euclidean norm of the
    /// linear axis changes).
    pub max_correction: f64,
    /// Decimals written in new numbers (program units; 4 = 0.1 µm in mm).
    pub decimals: u8,
    /// How the program is interpreted (offsets, tools, TCP M-codes, ...).
    pub interp: InterpOptions,
}

impl Default for CompensateOptions {
    fn default() -> Self {
        CompensateOptions {
            tol: 0.001,
            max_correction: 0.5,
            decimals: 4,
            interp: InterpOptions::default(),
        }
    }
}

/// What a run did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Summary {
    /// Blocks read.
    pub blocks: u64,
    /// Blocks whose text changed (not counting inserted ones).
    pub blocks_changed: u64,
    /// Moves split into several blocks.
    pub blocks_subdivided: u64,
    /// Blocks inserted by subdivision.
    pub blocks_inserted: u64,
    /// Arcs converted to lines.
    pub arcs_converted: u64,
    /// Largest correction of a target, mm (norm of the linear axis changes).
    pub largest_correction: f64,
    /// Line of the largest correction (0 when there was no move).
    pub largest_correction_line: u64,
    /// Largest rotary axis correction, degree.
    pub largest_rotary_correction: f64,
    /// Targets near a singular pose (tool axis along a rotary axis) where
    /// only the tip was corrected, with the linear axes.
    pub axis_not_corrected: u64,
    /// Largest remaining deviation at a checked midpoint, mm.
    pub largest_midpoint_deviation: f64,
    /// Plain sentences about what was rewritten beyond end words.
    pub notes: Vec<String>,
}

/// Why a program cannot be compensated.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CompensateError {
    /// The program could not be read, interpreted or edited.
    #[error(transparent)]
    Gcode(#[from] GcodeError),
    /// Inverse kinematics failed (no solution, or outside travel).
    #[error("line {line}: {source}")]
    Ik {
        /// Line of the program.
        line: u64,
        /// Why the inverse kinematics failed.
        #[source]
        source: IkError,
    },
    /// A correction is above the limit.
    #[error(
        "line {line}: the correction of {} µm exceeds the limit of {} µm (--max-correction)",
        crate::limits::fmt_message_fixed(*.correction_um, 1),
        crate::limits::fmt_message_fixed(*.limit_um, 1)
    )]
    TooLarge {
        /// Line of the program.
        line: u64,
        /// The correction, µm.
        correction_um: f64,
        /// The limit (`max_correction`), µm.
        limit_um: f64,
    },
    /// Splitting did not bring the path within tolerance.
    #[error(
        "line {line}: the compensated path still deviates by {} µm after {MAX_DEPTH} halvings",
        crate::limits::fmt_message_fixed(*.deviation_um, 2)
    )]
    NoConvergence {
        /// Line of the program.
        line: u64,
        /// Deviation left after the last halving, µm.
        deviation_um: f64,
    },
    /// The machine's axes are not one G-code axis letter each.
    #[error(transparent)]
    AxisName(#[from] AxisLetterError),
    /// Writing failed.
    #[error("cannot write the program: {0}")]
    Io(#[from] std::io::Error),
    /// An option out of its domain: `option` names the field of
    /// [`CompensateOptions`] (`tol`, `max_correction`).
    #[error("{option} {problem}")]
    Setting {
        /// The option.
        option: &'static str,
        /// What is wrong, as "must be …, not …".
        problem: String,
    },
}

impl CompensateError {
    /// 1-based source line of the problem, if it has one.
    pub fn line(&self) -> Option<u64> {
        match self {
            CompensateError::Gcode(e) => e.location().map(|l| l.line),
            CompensateError::Ik { line, .. }
            | CompensateError::TooLarge { line, .. }
            | CompensateError::NoConvergence { line, .. } => Some(*line),
            _ => None,
        }
    }

    /// 1-based column of the problem (0 when the whole block is at fault).
    pub fn column(&self) -> u32 {
        match self {
            CompensateError::Gcode(e) => e.location().map_or(0, |l| l.column),
            _ => 0,
        }
    }

    /// What went wrong, without the location (for callers that print the
    /// location themselves, as `file:line:col: message`); the text of
    /// [`Display`](std::fmt::Display) is `line N: ` and this.
    pub fn message(&self) -> String {
        let fixed = crate::limits::fmt_message_fixed;
        match self {
            CompensateError::Gcode(e) => e.message(),
            CompensateError::Ik { source, .. } => source.to_string(),
            CompensateError::TooLarge {
                correction_um,
                limit_um,
                ..
            } => format!(
                "the correction of {} µm exceeds the limit of {} µm (--max-correction)",
                fixed(*correction_um, 1),
                fixed(*limit_um, 1)
            ),
            CompensateError::NoConvergence { deviation_um, .. } => format!(
                "the compensated path still deviates by {} µm after {MAX_DEPTH} halvings",
                fixed(*deviation_um, 2)
            ),
            other => other.to_string(),
        }
    }
}

impl CompensateOptions {
    /// Checks the options: `tol` and `max_correction` positive and finite.
    pub fn validate(&self) -> Result<(), CompensateError> {
        let num = crate::limits::fmt_message_number;
        for (option, value) in [("tol", self.tol), ("max_correction", self.max_correction)] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(CompensateError::Setting {
                    option,
                    problem: format!("must be a positive number of mm, not {}", num(value)),
                });
            }
        }
        Ok(())
    }
}

/// `mtwin compensate`: the program read from `input` compensated for the
/// actual `machine` ([`compensate`]) and written to `output`, with its
/// document (`out` left empty for the caller, who knows where `output`
/// goes).
pub fn run<R: BufRead, W: Write>(
    machine: &Machine,
    input: R,
    output: W,
    options: &CompensateOptions,
) -> Result<(Summary, CompensateDoc), CompensateError> {
    options.validate()?;
    let summary = compensate(machine, input, output, options)?;
    let doc = CompensateDoc::new(&summary, "");
    Ok((summary, doc))
}

/// Compensates the program read from `input` for the actual `machine` and
/// writes it to `output`, block by block.
pub fn compensate<R: BufRead, W: Write>(
    machine: &Machine,
    input: R,
    output: W,
    opts: &CompensateOptions,
) -> Result<Summary, CompensateError> {
    Compensator::new(machine, opts.clone())?.run(input, output)
}

/// Nominal and actual kinematics of one machine with the axis map to G-code
/// letters; reusable over many programs.
#[derive(Debug, Clone)]
pub struct Compensator {
    nominal: Kinematics,
    actual: Kinematics,
    /// G-code axis of each machine axis.
    letters: Vec<Axis>,
    linear: Vec<bool>,
    all: Vec<bool>,
    /// Target the tool axis too (five-axis machine with five axes).
    full_pose: bool,
    ik: IkOptions,
    opts: CompensateOptions,
}

/// One compensated point.
#[derive(Debug, Clone)]
struct Point {
    /// Nominal program coordinates.
    p: Axes,
    /// Nominal machine axes.
    q_nom: Vec<f64>,
    /// Compensated program coordinates.
    new_p: Axes,
    /// Compensated machine axes (`None` at the program start, which is not a
    /// target).
    q_act: Option<Vec<f64>>,
    /// Derivatives of the actual pose at `q_act`'s last iterate, for chord
    /// steps at the next target (boxed: points are moved often, the
    /// derivatives and their factor are most of a point's size).
    jac: Option<Box<IkJacobian>>,
}

impl Point {
    /// Where the inverse kinematics of the next point starts.
    fn warm_start(&self) -> WarmStart<'_> {
        WarmStart {
            q_nom: &self.q_nom,
            q_act: self.q_act.as_deref(),
            jac: self.jac.as_deref(),
        }
    }
}

/// The previous target, from which the inverse kinematics of the next one
/// starts: its nominal axes start the nominal (TCP) solution, and its
/// correction `q_act − q_nom` the actual one. Corrections vary slowly along a
/// program, so the warm start saves about one Newton iteration per target.
#[derive(Clone, Copy)]
struct WarmStart<'a> {
    q_nom: &'a [f64],
    q_act: Option<&'a [f64]>,
    jac: Option<&'a IkJacobian>,
}

impl Compensator {
    /// Prepares the kinematics of `machine` (its errors are the actual machine).
    pub fn new(machine: &Machine, opts: CompensateOptions) -> Result<Self, CompensateError> {
        let letters = Axis::of_machine(machine)?;
        let linear: Vec<bool> = machine
            .axes
            .iter()
            .map(|a| a.kind == AxisKind::Linear)
            .collect();
        Ok(Compensator {
            nominal: Kinematics::nominal(machine),
            actual: Kinematics::new(machine),
            full_pose: machine.orients_tool(),
            all: vec![true; letters.len()],
            letters,
            linear,
            // A thousandth of half the last written decimal (50 pm in mm
            // with 4 decimals), the tool axis to the same over a 1 m lever.
            ik: IkOptions {
                tip_tolerance: 0.5e-3 * 10f64.powi(-i32::from(opts.decimals)),
                axis_tolerance: 0.5e-6 * 10f64.powi(-i32::from(opts.decimals)),
                // Near a singular pose the tip-and-axis solve cannot converge:
                // find out in a few steps, not fifty (the tip-only fallback decides).
                stall_ratio: Some(0.5),
                ..IkOptions::default()
            },
            opts,
        })
    }

    /// Compensates one program (see [`compensate`]).
    pub fn run<R: BufRead, W: Write>(
        &self,
        input: R,
        output: W,
    ) -> Result<Summary, CompensateError> {
        let mut writer = BlockWriter::new(output);
        let mut interp = Interpreter::new(self.opts.interp.clone());
        let mut run = RunState {
            new_pos: self.opts.interp.initial_machine_position,
            q_nom: self.axes_of(&self.opts.interp.initial_machine_position),
            last: None,
            lost_arc: None,
            summary: Summary::default(),
        };
        let mut inserted = Vec::new();
        // The copy of each block that is edited (its buffers reused).
        let mut block = Block::default();
        // Lines of the held part (O-word flow) as every run of them left them:
        // a line that runs several times must come out the same each time.
        let mut held: HashMap<u64, (Block, Vec<Block>)> = HashMap::new();
        // The text after the program end is copied as it is.
        let program = ProgramOptions {
            keep_rest: true,
            ..self.opts.interp.program.clone()
        };
        let flow = run_program(
            input,
            &mut interp,
            &program,
            self.opts.interp.dialect,
            |step: &Step<'_>| -> Result<(), CompensateError> {
                run.summary.blocks += 1;
                block.clone_from(step.block);
                inserted.clear();
                let changed = self.edit_block(
                    step.events,
                    step.interp,
                    &mut block,
                    &mut inserted,
                    &mut run,
                )?;
                if !step.held {
                    if changed {
                        run.summary.blocks_changed += 1;
                    }
                    writer.write_block(&block)?;
                    for b in &inserted {
                        writer.write_block(b)?;
                    }
                    return Ok(());
                }
                let line = block.line();
                if step.file != 0 {
                    if changed {
                        return Err(GcodeError::unsupported(
                            line,
                            1,
                            "a correction inside a subroutine file (only the program is rewritten; copy the subroutine into the program)",
                        )
                        .into());
                    }
                    return Ok(());
                }
                match held.get(&line) {
                    Some((b, ins)) if b.text() != block.text() || *ins != inserted => {
                        return Err(GcodeError::unsupported(
                            line,
                            1,
                            "corrections of a line that runs more than once (a loop or subroutine) differ between its runs; one rewritten line cannot hold them (write the program without loops and subroutines)",
                        )
                        .into());
                    }
                    Some(_) => {}
                    None => {
                        held.insert(line, (block.clone(), inserted.clone()));
                    }
                }
                Ok(())
            },
        )?;
        for block in &flow.held {
            match held.get(&block.line()) {
                Some((b, ins)) if b.text() != block.text() || !ins.is_empty() => {
                    run.summary.blocks_changed += 1;
                    writer.write_block(b)?;
                    for i in ins {
                        writer.write_block(i)?;
                    }
                }
                _ => writer.write_block(block)?,
            }
        }
        // After the end of the program (M2, M30, closing '%') the text is
        // copied unread, as LinuxCNC never reads it.
        let trailer = flow.rest;
        // Its lines count as blocks of the file, as before reading stopped
        // at the end.
        run.summary.blocks += (trailer.iter().filter(|&&b| b == b'\n').count()
            + usize::from(!trailer.is_empty() && !trailer.ends_with(b"\n")))
            as u64;
        writer.copy_raw(&trailer[..])?;
        writer.into_inner()?;
        Ok(run.summary)
    }

    /// Corrects the moves of one executed block in `block` (a copy of it),
    /// appending split-off blocks to `inserted`; whether the block changed.
    fn edit_block(
        &self,
        events: &[crate::gcode::Event],
        interp: &Interpreter,
        block: &mut Block,
        inserted: &mut Vec<Block>,
        run: &mut RunState,
    ) -> Result<bool, CompensateError> {
        let before = block.text().len();
        let mut changed = false;
        for ev in events {
            let line = ev.at.line;
            match ev.kind {
                EventKind::Traverse(m) | EventKind::Feed(m) if m.words.expanded => {
                    let mv = Move::from_linear(&m, line);
                    self.expanded_move(&mv, run)?;
                }
                EventKind::Arc(a) if a.words.expanded => {
                    let mv = Move::from_arc(&a, line);
                    self.expanded_move(&mv, run)?;
                }
                EventKind::Traverse(m) | EventKind::Feed(m) => {
                    let split = matches!(ev.kind, EventKind::Feed(_));
                    let mv = Move::from_linear(&m, line);
                    changed |= self.do_move(&mv, split, block, inserted, run)?;
                }
                EventKind::Arc(a) => {
                    let mv = Move::from_arc(&a, line);
                    let arc_code = if a.turns > 0 { 3 } else { 2 };
                    if run.lost_arc.is_some() && motion_word(block).is_none() {
                        prepend(block, &format!("G{arc_code} "))?;
                        run.summary.notes.push(format!(
                            "line {line}: G{arc_code} written again (the previous arc became lines)"
                        ));
                        changed = true;
                    }
                    let arc_distance = interp.state().arc_distance;
                    changed |= self.do_arc(&mv, arc_code, arc_distance, block, inserted, run)?;
                }
                _ => {}
            }
        }
        if motion_word(block).is_some()
            && !events.iter().any(|e| matches!(e.kind, EventKind::Arc(_)))
        {
            run.lost_arc = None;
        }
        let changed = changed || block.text().len() != before;
        if (changed || !inserted.is_empty()) && interp.state().rotation != 0.0 {
            // The words of a rotated system (G10 L2 R) are not along the
            // machine axes the corrections are computed on.
            return Err(GcodeError::unsupported(
                events.first().map_or(0, |e| e.at.line),
                0,
                "correction of a move in a rotated coordinate system (G10 L2 R)",
            )
            .into());
        }
        Ok(changed)
    }

    /// Machine axis positions of program coordinates `p` (plain program).
    fn axes_of(&self, p: &Axes) -> Vec<f64> {
        self.axes_in(p, &mut [0.0; 9]).to_vec()
    }

    /// [`Compensator::axes_of`] into a stack buffer (a machine has at most one axis per
    /// letter, so at most nine), for the hot paths that need it only briefly.
    fn axes_in<'b>(&self, p: &Axes, buf: &'b mut [f64; 9]) -> &'b [f64] {
        for (b, &g) in buf.iter_mut().zip(&self.letters) {
            *b = p[g];
        }
        &buf[..self.letters.len()]
    }

    /// Nominal axes, then the compensated point, for nominal program point `p`.
    fn point(
        &self,
        p: &Axes,
        tcp: bool,
        from: WarmStart<'_>,
        line: u64,
        summary: &mut Summary,
    ) -> Result<Point, CompensateError> {
        let ik_err = |source| CompensateError::Ik { line, source };
        let free = if self.full_pose {
            &self.all
        } else {
            &self.linear
        };
        let (q_nom, target) = if tcp {
            let q0: Vec<f64> = self
                .letters
                .iter()
                .zip(&self.linear)
                .zip(from.q_nom)
                .map(|((&g, &lin), &s)| if lin { s } else { p[g] })
                .collect();
            let tip = Vector3::from(p.xyz());
            let q_nom = self
                .nominal
                .inverse(&IkTarget { tip, axis: None }, &q0, &self.linear, &self.ik)
                .map_err(ik_err)?;
            let axis = self.nominal.pose(&q_nom).axis;
            (
                q_nom,
                IkTarget {
                    tip,
                    axis: self.full_pose.then_some(axis),
                },
            )
        } else {
            let q_nom = self.axes_of(p);
            let pose = self.nominal.pose(&q_nom);
            (
                q_nom,
                IkTarget {
                    tip: pose.tip,
                    axis: self.full_pose.then_some(pose.axis),
                },
            )
        };
        let mut jac = from.jac.copied();
        let warm = from.q_act.and_then(|q_act| {
            let mut q: Vec<f64> = q_nom
                .iter()
                .zip(q_act.iter().zip(from.q_nom))
                .map(|(&n, (&a, &an))| n + (a - an))
                .collect();
            self.actual
                .inverse_warm(&target, &mut q, free, &self.ik, &mut jac)
                .ok()
                .map(|()| q)
        });
        // A warm solution far from the nominal rotaries (near a singular pose)
        // is not taken: the cold start from the nominal axes decides there.
        let full = match warm {
            Some(q) if target.axis.is_none() || self.rotary_change(&q, &q_nom) <= MAX_ROTARY => {
                Ok(q)
            }
            _ => {
                jac = None;
                let mut q = q_nom.clone();
                self.actual
                    .inverse_warm(&target, &mut q, free, &self.ik, &mut jac)
                    .map(|()| q)
            }
        };
        let q_act = match full {
            Ok(q) if target.axis.is_none() || self.rotary_change(&q, &q_nom) <= MAX_ROTARY => q,
            _ if target.axis.is_some() => {
                // Near a singular pose (tool axis along a rotary axis) the
                // tool axis cannot be corrected by a small rotary move:
                // correct the tip with the linear axes only.
                summary.axis_not_corrected += 1;
                jac = None;
                let tip_only = IkTarget {
                    axis: None,
                    ..target
                };
                self.actual
                    .inverse(&tip_only, &q_nom, &self.linear, &self.ik)
                    .map_err(ik_err)?
            }
            other => other.map_err(ik_err)?,
        };
        let mut lin2 = 0.0;
        let mut rot: f64 = 0.0;
        for i in 0..q_nom.len() {
            let d = q_act[i] - q_nom[i];
            if self.linear[i] {
                lin2 += d * d;
            } else {
                rot = rot.max(d.abs());
            }
        }
        let corr = lin2.sqrt();
        if corr > self.opts.max_correction {
            return Err(CompensateError::TooLarge {
                line,
                correction_um: corr * 1e3,
                limit_um: self.opts.max_correction * 1e3,
            });
        }
        if corr > summary.largest_correction {
            summary.largest_correction = corr;
            summary.largest_correction_line = line;
        }
        summary.largest_rotary_correction = summary.largest_rotary_correction.max(rot);
        let mut new_p = *p;
        for (i, &g) in self.letters.iter().enumerate() {
            if !(tcp && matches!(g, Axis::X | Axis::Y | Axis::Z)) {
                new_p[g] = q_act[i];
            }
        }
        if tcp {
            let tip = self.nominal.pose(&q_act).tip;
            new_p[Axis::X] = tip.x;
            new_p[Axis::Y] = tip.y;
            new_p[Axis::Z] = tip.z;
        }
        Ok(Point {
            p: *p,
            q_nom,
            new_p,
            q_act: Some(q_act),
            jac: jac.map(Box::new),
        })
    }

    /// Deviation, mm, between the nominal tip at program point `nominal` and
    /// the actual tip when the machine executes program point `executed`.
    fn deviation(
        &self,
        nominal: &Axes,
        executed: &Axes,
        tcp: bool,
        start: &[f64],
        line: u64,
    ) -> Result<f64, CompensateError> {
        if tcp {
            let q0: Vec<f64> = self
                .letters
                .iter()
                .zip(&self.linear)
                .zip(start)
                .map(|((&g, &lin), &s)| if lin { s } else { executed[g] })
                .collect();
            let tip = Vector3::from(executed.xyz());
            let q_exec = self
                .nominal
                .inverse(&IkTarget { tip, axis: None }, &q0, &self.linear, &self.ik)
                .map_err(|source| CompensateError::Ik { line, source })?;
            let want = Vector3::from(nominal.xyz());
            return Ok((self.actual.pose(&q_exec).tip - want).norm());
        }
        let mut buf = [0.0; 9];
        let want = self.nominal.pose(self.axes_in(nominal, &mut buf)).tip;
        let q_exec = self.axes_in(executed, &mut buf);
        Ok((self.actual.pose(q_exec).tip - want).norm())
    }

    /// Splits `[a, b]` of `mv` until every checked midpoint is within `tol`;
    /// pushes the interior points in order.
    ///
    /// `fade` (mm) is the machine's error at the start of the move when that
    /// start is not compensated (the position the program starts from, where
    /// the machine is, not a target): along the move that error fades
    /// linearly to the compensated end and no split can remove it, so a
    /// midpoint is accepted within `tol + fade · (1 − s)`.
    #[allow(clippy::too_many_arguments)]
    fn refine(
        &self,
        mv: &Move,
        (sa, a): (f64, &Point),
        (sb, b): (f64, &Point),
        depth: u32,
        fade: f64,
        out: &mut Vec<(f64, Point)>,
        summary: &mut Summary,
    ) -> Result<(), CompensateError> {
        let sm = 0.5 * (sa + sb);
        let nominal = mv.path.at(sm);
        let executed = lerp(&a.new_p, &b.new_p, 0.5);
        let dev = self.deviation(&nominal, &executed, mv.tcp, &a.q_nom, mv.line)?;
        if dev <= self.opts.tol + fade * (1.0 - sm) {
            summary.largest_midpoint_deviation = summary.largest_midpoint_deviation.max(dev);
            return Ok(());
        }
        if depth >= MAX_DEPTH {
            return Err(CompensateError::NoConvergence {
                line: mv.line,
                deviation_um: dev * 1e3,
            });
        }
        let m = self.point(&nominal, mv.tcp, a.warm_start(), mv.line, summary)?;
        self.refine(mv, (sa, a), (sm, &m), depth + 1, fade, out, summary)?;
        out.push((sm, m.clone()));
        let m = out.last().map(|(_, p)| p.clone()).unwrap_or(m);
        self.refine(mv, (sm, &m), (sb, b), depth + 1, fade, out, summary)
    }

    /// The machine's error (mm) at the start of `mv` when that start is the
    /// uncompensated position the program starts from, with a note saying
    /// so; 0 for a compensated start.
    fn start_fade(
        &self,
        mv: &Move,
        start: &Point,
        summary: &mut Summary,
    ) -> Result<f64, CompensateError> {
        if start.q_act.is_some() {
            return Ok(0.0);
        }
        let e = self.deviation(&start.p, &start.new_p, mv.tcp, &start.q_nom, mv.line)?;
        if e > self.opts.tol {
            summary.notes.push(format!(
                "line {}: the first feed move starts from the start position, which is not compensated \
                 (the machine's error there is {:.2} µm): the path fades from that error to the \
                 compensated end of the move; begin the program with a rapid (G0) move to the \
                 start of the cut so that every feed move starts from a compensated point",
                mv.line,
                e * 1e3
            ));
        }
        Ok(e)
    }

    /// A move one block expands to (canned cycle, G28/G30, cutter radius
    /// compensation, G33/G33.1, whose moves must not be split or re-coded)
    /// or a move by polar words `@ ^` (no X or Y word to rewrite):
    /// no word of the block ends it, so a correction cannot
    /// be written; refused unless none is needed.
    fn expanded_move(&self, mv: &Move, run: &mut RunState) -> Result<(), CompensateError> {
        let (_, end) = self.ends(mv, run)?;
        if Axis::ALL
            .iter()
            .any(|&a| (end.new_p[a] - end.p[a]).abs() > 1e-6)
        {
            return Err(GcodeError::unsupported(
                mv.line,
                0,
                "correction of a move a canned cycle, G28/G30, cutter radius compensation \
                 or a spindle-synchronised G33/G33.1 expands to, or of a move by polar words @ ^ \
                 (one block, several moves or an offset path, or no X Y word: no word to rewrite); \
                 write the moves as G0/G1/G2/G3 with X Y words without them first",
            )
            .into());
        }
        run.reached(end);
        Ok(())
    }

    /// The compensated start and end of a move.
    fn ends(&self, mv: &Move, run: &mut RunState) -> Result<(Point, Point), CompensateError> {
        let p0 = mv.path.at(0.0);
        let start = match run.last.take() {
            Some(pt) if close(&pt.p, &p0) => pt,
            Some(pt) => self.point(&p0, mv.tcp, pt.warm_start(), mv.line, &mut run.summary)?,
            // The start of the program is where the machine is, not a target.
            None => {
                let q_nom = if mv.tcp {
                    run.q_nom.clone()
                } else {
                    self.axes_of(&p0)
                };
                Point {
                    p: p0,
                    q_nom,
                    new_p: p0,
                    q_act: None,
                    jac: None,
                }
            }
        };
        let end = self.point(
            &mv.path.at(1.0),
            mv.tcp,
            start.warm_start(),
            mv.line,
            &mut run.summary,
        )?;
        Ok((start, end))
    }

    /// The points a move between its compensated ends `start` and `end` is
    /// split at ([`Self::refine`] from the whole move, with the start's fade).
    fn split(
        &self,
        mv: &Move,
        start: &Point,
        end: &Point,
        summary: &mut Summary,
    ) -> Result<Vec<(f64, Point)>, CompensateError> {
        let fade = self.start_fade(mv, start, summary)?;
        let mut pieces = Vec::new();
        self.refine(mv, (0.0, start), (1.0, end), 0, fade, &mut pieces, summary)?;
        Ok(pieces)
    }

    /// A straight move: end words corrected, split where needed.
    fn do_move(
        &self,
        mv: &Move,
        split: bool,
        block: &mut Block,
        inserted: &mut Vec<Block>,
        run: &mut RunState,
    ) -> Result<bool, CompensateError> {
        let (start, end) = self.ends(mv, run)?;
        let pieces = if split {
            self.split(mv, &start, &end, &mut run.summary)?
        } else {
            Vec::new()
        };
        let changed = self.emit(mv, block, inserted, &pieces, &end, run)?;
        run.reached(end);
        Ok(changed)
    }

    /// An arc: kept with corrected end words when the correction is nearly
    /// uniform along it, else converted to lines.
    fn do_arc(
        &self,
        mv: &Move,
        code: u8,
        arc_distance: DistanceMode,
        block: &mut Block,
        inserted: &mut Vec<Block>,
        run: &mut RunState,
    ) -> Result<bool, CompensateError> {
        let (start, end) = self.ends(mv, run)?;
        let d0 = start.new_p.sub(&start.p);
        let d1 = end.new_p.sub(&end.p);
        let n = match mv.path {
            NominalPath::Arc { sweep, .. } => {
                (sweep.abs() / (std::f64::consts::PI / 8.0)).ceil().max(4.0) as usize
            }
            NominalPath::Line { .. } => 4,
        };
        let mut keep = true;
        let mut worst: f64 = 0.0;
        for k in 1..n {
            let s = k as f64 / n as f64;
            let nominal = mv.path.at(s);
            let executed = nominal.add(&lerp(&d0, &d1, s));
            let dev = self.deviation(&nominal, &executed, mv.tcp, &start.q_nom, mv.line)?;
            worst = worst.max(dev);
            if dev > self.opts.tol {
                keep = false;
                break;
            }
        }
        if keep {
            run.summary.largest_midpoint_deviation =
                run.summary.largest_midpoint_deviation.max(worst);
            let mut changed = false;
            if arc_distance == DistanceMode::Absolute {
                // Absolute centres move with the start.
                let scale = mv.words.units.mm_per_unit();
                for (letter, axis) in [('I', Axis::X), ('J', Axis::Y), ('K', Axis::Z)] {
                    if d0[axis].abs() > self.threshold(scale)
                        && let Some(v) = block.word(letter)?.and_then(|w| w.number())
                    {
                        block.set_word_with(letter, v + d0[axis] / scale, self.format())?;
                        changed = true;
                    }
                }
            }
            changed |= self.emit(mv, block, inserted, &[], &end, run)?;
            run.reached(end);
            return Ok(changed);
        }
        let pieces = self.split(mv, &start, &end, &mut run.summary)?;
        to_line(block, code)?;
        for letter in ['I', 'J', 'K', 'R', 'P'] {
            block.remove_word(letter)?;
        }
        run.lost_arc = Some(code);
        run.summary.arcs_converted += 1;
        run.summary.notes.push(format!(
            "line {}: arc converted to {} lines (its correction varies by more than the tolerance)",
            mv.line,
            pieces.len() + 1
        ));
        self.emit(mv, block, inserted, &pieces, &end, run)?;
        run.reached(end);
        Ok(true)
    }

    /// Largest rotary axis change between two axis vectors, degree.
    fn rotary_change(&self, a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .zip(&self.linear)
            .filter(|(_, lin)| !**lin)
            .map(|((x, y), _)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    /// How new numbers are written: with a decimal point always when the
    /// dialect reads a number without one in least increments.
    fn format(&self) -> NumberFormat {
        match self.opts.interp.dialect {
            Dialect::Fanuc {
                decimal_point_programming: false,
            } => NumberFormat::FixedPoint(self.opts.decimals),
            _ => NumberFormat::Fixed(self.opts.decimals),
        }
    }

    /// Half a unit of the last written decimal, in mm (or degree) for a word
    /// whose unit is `scale` mm.
    fn threshold(&self, scale: f64) -> f64 {
        0.5 * 10f64.powi(-i32::from(self.opts.decimals)) * scale
    }

    /// Writes the end words of the original block (its first piece when
    /// split) and the inserted blocks of the other pieces.
    fn emit(
        &self,
        mv: &Move,
        block: &mut Block,
        inserted: &mut Vec<Block>,
        pieces: &[(f64, Point)],
        end: &Point,
        run: &mut RunState,
    ) -> Result<bool, CompensateError> {
        let inverse_time = match mv.feed {
            Feed::InverseTime(f) => Some(f),
            _ => None,
        };
        let mut s_prev = 0.0;
        let mut changed = false;
        let targets = pieces
            .iter()
            .map(|(s, p)| (*s, p))
            .chain(std::iter::once((1.0, end)));
        for (k, (s, pt)) in targets.enumerate() {
            if k == 0 {
                changed |= self.set_end_words(mv, block, pt, run)?;
                if !pieces.is_empty() {
                    if let Some(f) = inverse_time {
                        block.set_word_with('F', f / (s - s_prev), self.format())?;
                    }
                    run.summary.blocks_subdivided += 1;
                    changed = true;
                }
            } else {
                let mut text = String::from(if mv.words.g53 { "G53 G1" } else { "G1" });
                let mut b = Block::parse(text.as_bytes(), mv.line)?;
                let mut words = mv.words;
                words.axes = Default::default();
                let piece = Move { words, ..*mv };
                self.set_end_words(&piece, &mut b, pt, run)?;
                if let Some(f) = inverse_time {
                    b.set_word_with('F', f / (s - s_prev), self.format())?;
                }
                text.clear();
                text.push_str(std::str::from_utf8(b.text()).unwrap_or(""));
                let mut bytes = text.into_bytes();
                bytes.extend_from_slice(block.line_end().as_bytes());
                inserted.push(Block::parse(&bytes, mv.line)?);
                run.summary.blocks_inserted += 1;
            }
            s_prev = s;
        }
        Ok(changed)
    }

    /// Sets the axis words of `block` so that the new program ends at
    /// `pt.new_p`, writing only the words that differ from what it would do
    /// anyway; updates the new program's position.
    fn set_end_words(
        &self,
        mv: &Move,
        block: &mut Block,
        pt: &Point,
        run: &mut RunState,
    ) -> Result<bool, CompensateError> {
        let mut changed = false;
        let nominal_end = mv.path.at(1.0);
        let from_work = run.new_pos.sub(&mv.offset);
        let mut reached = run.new_pos;
        for &g in &self.letters {
            let scale = if g.is_rotary() {
                1.0
            } else {
                mv.words.units.mm_per_unit()
            };
            let thr = self.threshold(scale);
            let want = pt.new_p[g];
            let modal = if mv.words.axes.contains(g) {
                // The word as written: the nominal end of the whole move.
                nominal_end[g]
            } else {
                run.new_pos[g]
            };
            if (want - modal).abs() <= thr {
                reached[g] = modal;
                continue;
            }
            let value = mv
                .words
                .word_value(g, &from_work, want - mv.offset[g], &mv.offset);
            block.set_word_with(char::from(g.letter()), value, self.format())?;
            reached[g] = want;
            changed = true;
        }
        run.new_pos = reached;
        Ok(changed)
    }
}

/// One move being compensated.
#[derive(Debug, Clone, Copy)]
struct Move {
    path: NominalPath,
    tcp: bool,
    words: Programmed,
    offset: Axes,
    feed: Feed,
    line: u64,
}

impl Move {
    /// A straight move (G0/G1) of the interpreter's events, from `line`.
    fn from_linear(m: &crate::gcode::Linear, line: u64) -> Self {
        Move {
            path: NominalPath::line(m),
            tcp: m.tcp,
            words: m.words,
            offset: m.offset,
            feed: m.feed,
            line,
        }
    }

    /// An arc (G2/G3) of the interpreter's events, from `line`.
    fn from_arc(a: &crate::gcode::ArcMove, line: u64) -> Self {
        Move {
            path: NominalPath::arc(a),
            tcp: a.tcp,
            words: a.words,
            offset: a.offset,
            feed: a.feed,
            line,
        }
    }
}

/// State carried from block to block.
#[derive(Debug)]
struct RunState {
    /// Position of the new program, program coordinates (work + offset).
    new_pos: Axes,
    /// Nominal axes at the last target (start of TCP inverse kinematics).
    q_nom: Vec<f64>,
    /// The last compensated target.
    last: Option<Point>,
    /// An arc mode (2 or 3) that a conversion to lines removed.
    lost_arc: Option<u8>,
    summary: Summary,
}

impl RunState {
    /// A move has reached its compensated end `end`.
    fn reached(&mut self, end: Point) {
        self.q_nom.clone_from(&end.q_nom);
        self.last = Some(end);
    }
}

/// Two program points within 1 nm / 1e-9 degree on every axis.
fn close(a: &Axes, b: &Axes) -> bool {
    a.0.iter().zip(&b.0).all(|(x, y)| (x - y).abs() <= 1e-9)
}

/// The motion word (G0..G3 or G80) of a block, if any.
fn motion_word(block: &Block) -> Option<f64> {
    block
        .words()
        .filter(|w| w.letter == b'G')
        .filter_map(|w| w.number())
        .find(|&v| [0.0, 1.0, 2.0, 3.0, 80.0].contains(&v))
}

/// Rewrites the block's G2/G3 word as G1 (keeping every other byte).
fn to_line(block: &mut Block, code: u8) -> Result<(), CompensateError> {
    let w = block.items().iter().find_map(|it| match it {
        Item::Word(w) if w.letter == b'G' && w.value == Value::Number(f64::from(code)) => Some(*w),
        _ => None,
    });
    let Some(w) = w else {
        // A modal arc: make the block a line explicitly.
        return prepend(block, "G1 ");
    };
    let mut bytes = block.text()[..w.at].to_vec();
    bytes.extend_from_slice(&block.text()[w.at..=w.at]);
    bytes.push(b'1');
    bytes.extend_from_slice(&block.text()[w.span.end..]);
    bytes.extend_from_slice(block.line_end().as_bytes());
    *block = Block::parse(&bytes, block.line())?;
    Ok(())
}

/// Puts `prefix` before the block's text.
fn prepend(block: &mut Block, prefix: &str) -> Result<(), CompensateError> {
    let mut bytes = prefix.as_bytes().to_vec();
    bytes.extend_from_slice(block.text());
    bytes.extend_from_slice(block.line_end().as_bytes());
    *block = Block::parse(&bytes, block.line())?;
    Ok(())
}

#[cfg(test)]
mod tests;
