//! The S-shaped test piece (ISO 10791-7:2020, annex on the S-shaped test
//! piece; proposed by Chengdu Aircraft Industrial, see Wang et al., Proc.
//! IMechE B 229 (2015) 0954405414560780): a thin wall whose flank is a ruled
//! surface between a lower and an upper S-shaped guide curve, machined by
//! flank milling. The closing and opening bevel along the S makes every
//! axis of a five-axis machine reverse and accelerate, which is why the
//! digital-twin patent \[R5\] (docs/references.md) predicts its contour errors.
//!
//! **Geometry used here (an approximation).** The standard defines the two
//! guide curves by tabulated points joined by splines; those coordinates
//! are not reproduced. Here both curves are one period of a sine in the
//! plane `z = const` of the workpiece frame W (mm):
//!
//! ```text
//! lower(s) = ( L·(s − ½),        (W/2)·sin 2π(s − ½),              0 )
//! upper(s) = ( rL·L·(s − ½),     rW·(W/2)·sin 2π(s − ½) − H·tan λ,  H ),   s ∈ [0, 1]
//! ```
//!
//! with the defaults of the same order as the standard's piece: length
//! `L` = 160 mm, S width `W` = 40 mm, height `H` = 30 mm, the upper curve
//! shortened `rL` = 0.875 and narrowed `rW` = 0.8, and leaning `λ` = 15°
//! towards −y, so the ruling never stands vertical (a vertical tool axis is
//! a singular pose of an AC table: C would be undefined), and its inclination
//! varies between about 10.7° and 23.9° from z while its horizontal
//! direction swings back and forth about z. `--scale` multiplies `L`, `W` and `H`.
//!
//! **Tool.** The tool tip follows the lower curve and the tool axis (from the
//! tip towards the spindle) lies along the ruling `upper(s) − lower(s)`;
//! the tool is the machine model's (`[tool]` tip), no radius offset is
//! applied: the program is the flank's generating line, not a cutter-
//! compensated path.

use std::f64::consts::PI;

use nalgebra::Vector3;
use thiserror::Error;

use crate::gcode::{Axis, Dialect, ProgramEnd, ProgramWriter, WriteError, WriterOptions};
use crate::kinematics::{IkError, IkOptions, IkTarget, Kinematics};
use crate::model::{AxisKind, Machine};

/// The S-shaped test piece's dimensions (mm, degrees), see the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SShape {
    /// Length `L` of the lower curve along x, mm.
    pub length: f64,
    /// Width `W` of the lower S (peak to peak along y), mm.
    pub width: f64,
    /// Height `H` of the upper curve above the lower one, mm.
    pub height: f64,
    /// Upper-curve length over lower-curve length `rL`.
    pub top_length_ratio: f64,
    /// Upper-curve width over lower-curve width `rW`.
    pub top_width_ratio: f64,
    /// Lean `λ` of the wall towards −y, degrees.
    pub lean_deg: f64,
}

impl Default for SShape {
    fn default() -> Self {
        SShape {
            length: 160.0,
            width: 40.0,
            height: 30.0,
            top_length_ratio: 0.875,
            top_width_ratio: 0.8,
            lean_deg: 15.0,
        }
    }
}

impl SShape {
    /// The piece with `L`, `W`, `H` multiplied by `factor`.
    pub fn scaled(self, factor: f64) -> SShape {
        SShape {
            length: self.length * factor,
            width: self.width * factor,
            height: self.height * factor,
            ..self
        }
    }

    /// Point of the lower guide curve at `s ∈ [0, 1]`, W, mm.
    pub fn lower(&self, s: f64) -> Vector3<f64> {
        Vector3::new(
            self.length * (s - 0.5),
            0.5 * self.width * (2.0 * PI * (s - 0.5)).sin(),
            0.0,
        )
    }

    /// Point of the upper guide curve at `s ∈ [0, 1]`, W, mm.
    pub fn upper(&self, s: f64) -> Vector3<f64> {
        Vector3::new(
            self.top_length_ratio * self.length * (s - 0.5),
            self.top_width_ratio * 0.5 * self.width * (2.0 * PI * (s - 0.5)).sin()
                - self.height * self.lean_deg.to_radians().tan(),
            self.height,
        )
    }

    /// Unit ruling direction at `s` (lower → upper): the tool axis.
    pub fn ruling(&self, s: f64) -> Vector3<f64> {
        (self.upper(s) - self.lower(s)).normalize()
    }

    fn check(&self) -> Result<(), SShapeError> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if !(ok(self.length)
            && ok(self.width)
            && ok(self.height)
            && ok(self.top_length_ratio)
            && ok(self.top_width_ratio)
            && self.lean_deg.is_finite()
            && self.lean_deg.abs() < 80.0)
        {
            return Err(SShapeError::Dimensions(format!("{self:?}")));
        }
        Ok(())
    }
}

/// Why the program could not be written.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SShapeError {
    /// A dimension is not positive and finite (or the lean is not within ±80°).
    #[error("the S-shaped piece needs positive finite dimensions and a lean within ±80°: {0}")]
    Dimensions(String),
    /// Too few segments or a bad feed.
    #[error("{0}")]
    Options(String),
    /// The machine cannot be programmed this way.
    #[error("{0}")]
    Machine(String),
    /// A pose is out of reach or outside the travel.
    #[error("pose {index} (s = {s:.4}: tip {tip} mm, axis {axis}) cannot be reached")]
    Pose {
        /// 0-based pose index.
        index: usize,
        /// Curve parameter.
        s: f64,
        /// Tip, W, mm (formatted).
        tip: String,
        /// Tool axis (formatted).
        axis: String,
        /// What the inverse kinematics said.
        source: Box<IkError>,
    },
    /// A value the G-code writer cannot write.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// How the program is written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SShapeProgram {
    /// Straight segments along the curve (`segments + 1` poses).
    pub segments: usize,
    /// Feed of the tool tip along the lower curve, mm/min.
    pub feed: f64,
    /// `G93` inverse-time feed (`F` = 1/minutes of each segment, from the
    /// tip path length) instead of `G94`.
    pub inverse_time: bool,
    /// A TCP program (`G43.4 H0` … `G49`: X Y Z are the tool tip in W,
    /// rotary words are axis angles) instead of joint-space axis words.
    pub tcp: bool,
    /// The controller the program is written for: LinuxCNC with 6 decimals
    /// (1 nm, 1e-6°), Fanuc with its 3 (a Fanuc word has at most 8 digits).
    pub dialect: Dialect,
}

impl Default for SShapeProgram {
    fn default() -> Self {
        SShapeProgram {
            segments: 200,
            feed: 1000.0,
            inverse_time: false,
            tcp: false,
            dialect: Dialect::LinuxCnc,
        }
    }
}

/// The joint positions (machine axis order, mm and degrees) of the
/// `segments + 1` poses `s = i/segments`, from the machine's *nominal*
/// inverse kinematics, each started at the previous solution (the first at
/// the zero pose), so the rotary axes move continuously; every pose within
/// the travel.
pub fn s_shape_poses(
    machine: &Machine,
    shape: &SShape,
    segments: usize,
) -> Result<Vec<Vec<f64>>, SShapeError> {
    shape.check()?;
    if let Err(e) = crate::limits::check(
        "the number of segments",
        segments as f64,
        crate::limits::MAX_PROGRAM_POINTS,
        "each segment is a block of the program and an inverse-kinematics solve",
    ) {
        return Err(SShapeError::Options(e.to_string()));
    }
    if segments == 0 {
        return Err(SShapeError::Options(
            "at least one segment is needed".into(),
        ));
    }
    let rotary = machine
        .axes
        .iter()
        .filter(|a| a.kind == AxisKind::Rotary)
        .count();
    if rotary < 2 {
        return Err(SShapeError::Machine(format!(
            "the S-shaped piece needs a five-axis machine (two rotary axes); `{}` has {rotary}",
            machine.name
        )));
    }
    let kin = Kinematics::nominal(machine);
    let free = vec![true; kin.n_axes()];
    let opts = IkOptions::default();
    let mut q = vec![0.0; kin.n_axes()];
    let mut out = Vec::with_capacity(segments + 1);
    for i in 0..=segments {
        let s = i as f64 / segments as f64;
        let target = IkTarget {
            tip: shape.lower(s),
            axis: Some(shape.ruling(s)),
        };
        q = kin
            .inverse(&target, &q, &free, &opts)
            .map_err(|source| SShapeError::Pose {
                index: i,
                s,
                tip: format!("{:.4?}", target.tip.as_slice()),
                axis: format!("{:.6?}", shape.ruling(s).as_slice()),
                source: Box::new(source),
            })?;
        out.push(q.clone());
    }
    Ok(out)
}

/// The program text (see [`SShapeProgram`]): a header, `G21 G90` and the
/// feed mode (`G43.4 H0` for TCP), a rapid `G0` to the first pose, one
/// `G1` per segment, `G49` after a TCP program, `M30`.
/// Words are written in machine axis order with 6 decimals for LinuxCNC
/// (mm, degrees, `F` too; 3 for Fanuc), trailing zeros trimmed, by
/// [`ProgramWriter`].
/// The approach to and the retract from the part are left to the user.
pub fn s_shape_program(
    machine: &Machine,
    shape: &SShape,
    opts: &SShapeProgram,
) -> Result<String, SShapeError> {
    if !(opts.feed.is_finite() && opts.feed > 0.0) {
        return Err(SShapeError::Options(format!(
            "the feed must be positive, not {} mm/min",
            opts.feed
        )));
    }
    let letters: Vec<char> = Axis::of_machine(machine)
        .map_err(|e| SShapeError::Machine(e.to_string()))?
        .into_iter()
        .map(|g| char::from(g.letter()))
        .collect();
    if opts.tcp
        && ["X", "Y", "Z"]
            .iter()
            .any(|n| !machine.axes.iter().any(|a| a.name == *n))
    {
        return Err(SShapeError::Machine(
            "a TCP program needs linear axes named X, Y and Z".into(),
        ));
    }
    let poses = s_shape_poses(machine, shape, opts.segments)?;
    let n = opts.segments;
    // LinuxCNC: 6 decimals (1 nm, 1e-6°); Fanuc: its least increment.
    let writer_options = match opts.dialect {
        Dialect::LinuxCnc => WriterOptions::of(Dialect::LinuxCnc).with_decimals(6),
        fanuc => WriterOptions::of(fanuc),
    };
    let mut w = ProgramWriter::with_options(opts.dialect, writer_options);
    let words = |i: usize, tcp: bool| -> Vec<(char, f64)> {
        let q = &poses[i];
        let mut out = Vec::new();
        if tcp {
            let tip = shape.lower(i as f64 / n as f64);
            out.extend(['X', 'Y', 'Z'].into_iter().zip(tip.iter().copied()));
            for (a, (l, v)) in machine.axes.iter().zip(letters.iter().zip(q)) {
                if a.kind == AxisKind::Rotary {
                    out.push((*l, *v));
                }
            }
        } else {
            out.extend(letters.iter().copied().zip(q.iter().copied()));
        }
        out
    };
    let header = format!(
        "L {} W {} H {} mm, top ratios {} {}, lean {} deg, {} segments",
        w.plain(shape.length)?,
        w.plain(shape.width)?,
        w.plain(shape.height)?,
        w.plain(shape.top_length_ratio)?,
        w.plain(shape.top_width_ratio)?,
        w.plain(shape.lean_deg)?,
        n
    );
    w.start(None)?;
    w.comment("mtwin testpiece s-shape: ISO 10791-7 style S-shaped piece, flank milling")?;
    w.comment(&header)?;
    w.comment(&format!(
        "machine: {}; {}",
        machine.name,
        if opts.tcp {
            "TCP program: X Y Z = tool tip in W, G43.4 on, G49 off"
        } else {
            "joint-space axis words from the nominal inverse kinematics"
        }
    ))?;
    w.block()
        .g(21)
        .g(90)
        .g(if opts.inverse_time { 93 } else { 94 })
        .write()?;
    // TCP on before the rapid: a G-code position written before G43.4 would
    // be taken as a tool tip afterwards.
    if opts.tcp {
        w.block().g_sub(43, 4).int('H', 0).write()?;
    }
    w.rapid(&words(0, opts.tcp))?;
    for i in 1..=n {
        let feed = if opts.inverse_time {
            let len =
                (shape.lower(i as f64 / n as f64) - shape.lower((i - 1) as f64 / n as f64)).norm();
            Some(opts.feed / len)
        } else if i == 1 {
            Some(opts.feed)
        } else {
            None
        };
        w.linear(&words(i, opts.tcp), feed)?;
    }
    if opts.tcp {
        w.block().g(49).write()?;
    }
    if opts.inverse_time {
        w.block().g(94).write()?;
    }
    w.end(ProgramEnd::M30)?;
    Ok(w.finish())
}

/// `mtwin testpiece s-shape`: the program of `shape` on `machine`
/// ([`s_shape_program`]) and its document (`out` left empty for the
/// caller). The cutting time is the lower curve's polyline length at the
/// feed.
pub fn run(
    machine: &Machine,
    shape: &SShape,
    opts: &SShapeProgram,
) -> Result<(String, super::SShapeProgramDoc), SShapeError> {
    let text = s_shape_program(machine, shape, opts)?;
    let n = opts.segments as f64;
    let length: f64 = (1..=opts.segments)
        .map(|i| (shape.lower(i as f64 / n) - shape.lower((i - 1) as f64 / n)).norm())
        .sum();
    let doc = super::SShapeProgramDoc {
        cutting_time_s: length / opts.feed * 60.0,
        feed_mm_min: opts.feed,
        height_mm: shape.height,
        inverse_time: opts.inverse_time,
        length_mm: shape.length,
        out: String::new(),
        poses: opts.segments + 1,
        segments: opts.segments,
        tcp: opts.tcp,
        tip_path_mm: length,
        width_mm: shape.width,
    };
    Ok((text, doc))
}

#[cfg(test)]
mod tests;
