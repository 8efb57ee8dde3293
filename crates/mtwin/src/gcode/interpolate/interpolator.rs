//! The interpolator: one segment per move or dwell, its geometry, path
//! speed limits and samples (rest to rest, or through a planner's joins).

use super::*;

/// The geometry of a move in work coordinates as a function of `s ∈ [0, 1]`.
#[derive(Debug, Clone, Copy)]
pub(super) enum Geom {
    Line {
        from: Axes,
        to: Axes,
    },
    Arc {
        arc: ArcMove,
        g: Geometry,
    },
    /// A `linuxcnc` blend arc: XYZ = `center + r (cos(φs) e1 + sin(φs) e2)`,
    /// the other axes at `from`.
    Blend {
        from: Axes,
        center: [f64; 3],
        e1: [f64; 3],
        e2: [f64; 3],
        r: f64,
        phi: f64,
    },
}

impl Geom {
    pub(super) fn at(&self, s: f64) -> Axes {
        match self {
            Geom::Line { from, to } => lerp(from, to, s),
            Geom::Arc { arc, g } => arc::point_at(arc, g, s),
            Geom::Blend {
                from,
                center,
                e1,
                e2,
                r,
                phi,
            } => {
                let mut x = *from;
                let (c, sn) = ((phi * s).cos(), (phi * s).sin());
                for (i, a) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
                    x[a] = center[i] + r * (c * e1[i] + sn * e2[i]);
                }
                x
            }
        }
    }
}

/// Unit XYZ direction of travel of `geom` at `u ∈ [0, 1]` (zero when XYZ
/// does not move), by a central difference.
pub(super) fn direction(geom: &Geom, u: f64) -> [f64; 3] {
    let h = 1e-6;
    let (a, b) = ((u - h).max(0.0), (u + h).min(1.0));
    let (p, q) = (geom.at(a), geom.at(b));
    let d = [
        q[Axis::X] - p[Axis::X],
        q[Axis::Y] - p[Axis::Y],
        q[Axis::Z] - p[Axis::Z],
    ];
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if n > 0.0 {
        [d[0] / n, d[1] / n, d[2] / n]
    } else {
        [0.0; 3]
    }
}

/// A block of motion.
pub(super) enum Path {
    /// Straight in axis space.
    Joint { q0: Vec<f64>, q1: Vec<f64> },
    /// A programmed move.
    Work {
        geom: Box<Geom>,
        offset: Axes,
        tcp: bool,
    },
    /// Standing still (a dwell).
    Hold { q: Vec<f64> },
}

/// A queued block: its path, the length of its path parameter (the path
/// parameter `s ∈ [0, len]` maps to `s / len` along the path), its line.
pub(super) struct Block {
    pub(super) path: Path,
    pub(super) len: f64,
    pub(super) line: u64,
}

/// What the `linuxcnc` join rules need of the last queued block.
#[derive(Clone, Copy)]
pub(super) struct Tail {
    pub(super) side: linuxcnc::Side,
    pub(super) mode: PathMode,
    pub(super) tcp: bool,
    pub(super) offset: Axes,
    pub(super) speed: Speed,
}

/// The speed and acceleration inputs of a `linuxcnc` block, before its
/// joins are known.
#[derive(Clone, Copy)]
pub(super) struct Speed {
    pub(super) len: f64,
    /// Highest speed by the axis limits and the cycle, per s.
    pub(super) v_ini: f64,
    /// Requested speed (feed × override, or the rapid speed), within the
    /// trajectory limit, per s.
    pub(super) v_req: f64,
    /// Acceleration by the axis limits, per s².
    pub(super) a_base: f64,
    /// Effective radius of an arc.
    pub(super) r_eff: Option<f64>,
    /// The acceleration is halved by a parabolic blend before or after.
    pub(super) halved: bool,
    /// Acceleration reduction of a tangent kink before or after.
    pub(super) kink: f64,
}

impl Speed {
    /// Target speed and tangential acceleration.
    fn limits(&self) -> Limits {
        let a = self.a_base * (1.0 - self.kink) * if self.halved { 0.5 } else { 1.0 };
        let (v_max, ratio) = match self.r_eff {
            Some(r) if a.is_finite() => linuxcnc::arc_speed_and_ratio(self.v_ini, a, r),
            _ => (self.v_ini, 1.0),
        };
        Limits {
            len: self.len,
            v: self.v_req.min(v_max),
            a: a * ratio,
        }
    }
}

/// Sub-steps of the finite-difference derivative bounds under TCP.
const FD_STEPS: usize = 16;

/// A second difference of TCP joint positions up to `FD_NOISE + 64·ε·|q|`
/// (mm or deg) is rounding, not curvature, and counts as zero. The positions
/// come from the inverse kinematics, solved to 1e-11 mm (and 1e-13 rad),
/// with rounding of a few ε·|q|: three of them make a second difference
/// below 4·(1e-11 + ε·|q|), 25 times below the bound. Without it, a joint
/// path that is affine in `s` (a TCP line with the rotary axes held) had a
/// second derivative of pure noise, and its path acceleration was halved or
/// not (`amax/(2·D1)` against `amax/D1`) with the rounding of the block's
/// ends. A real curvature below the bound adds at most
/// `1e-9·FD_STEPS²·ṡ² ≈ 2.6e-7·ṡ²` (mm/s² or deg/s²; ṡ in 1/s) to a joint's
/// acceleration: 0.26 mm/s² for a 0.1 mm block at 6 m/min.
const FD_NOISE: f64 = 1e-9;
/// Axis-space distance below which a move's start is the current position.
pub(super) const SAME_POSITION: f64 = 1e-7;

/// Streams samples for the events given to it (see the module documentation).
pub struct Interpolator<'m> {
    pub(super) machine: &'m Machine,
    pub(super) kin: Kinematics,
    pub(super) letters: Vec<Axis>,
    pub(super) linear: Vec<bool>,
    pub(super) opts: InterpolateOptions,
    /// Axis positions at the end of the last queued block.
    pub(super) q: Vec<f64>,
    /// Scratch axis positions (the last sample, the IK start).
    pub(super) buf: Vec<f64>,
    /// Index of the next sample.
    pub(super) k: u64,
    pub(super) line: u64,
    pub(super) summary: InterpolationSummary,
    pub(super) world: linuxcnc::WorldLimits,
    pub(super) queue: Lookahead<Block>,
    pub(super) active: VecDeque<Planned<Block>>,
    pub(super) mode: PathMode,
    pub(super) tail: Option<Tail>,
    pub(super) cam: NaiveCam,
    /// Spindle turning, and its programmed speed (rev/min).
    pub(super) spindle: (bool, f64),
    /// `(line, end time)` of every planned segment, when asked for
    /// ([`line_end_times`]).
    pub(super) ends: Option<Vec<(u64, f64)>>,
}

impl<'m> Interpolator<'m> {
    /// An interpolator for `machine` (its nominal kinematics is used for
    /// TCP), starting at `opts.interp.initial_machine_position`.
    pub fn new(machine: &'m Machine, opts: &InterpolateOptions) -> Result<Self, InterpolateError> {
        if !(opts.ts > 0.0 && opts.ts.is_finite()) {
            return Err(InterpolateError::Period(opts.ts));
        }
        let p = &opts.plan;
        if !(p.feed_override > 0.0 && p.feed_override.is_finite()) {
            return Err(InterpolateError::Plan(format!(
                "the feed override must be a positive fraction, not {}",
                p.feed_override
            )));
        }
        if !(p.derivative_margin >= 1.0 && p.derivative_margin.is_finite()) {
            return Err(InterpolateError::Plan(format!(
                "the derivative margin must be a number ≥ 1, not {}",
                p.derivative_margin
            )));
        }
        if !(p.cycle_time > 0.0 && p.cycle_time.is_finite()) || p.lookahead == 0 {
            return Err(InterpolateError::Plan(
                "the planner cycle time must be positive and the look-ahead at least one block"
                    .into(),
            ));
        }
        if p.planner == Planner::Jerk {
            return Err(InterpolateError::Plan(
                "the jerk planner plans whole chains of moves at once: use `interpolate` or `dense_paths`, not an `Interpolator`".into(),
            ));
        }
        let letters = Axis::of_machine(machine)?;
        let q: Vec<f64> = letters
            .iter()
            .map(|&l| opts.interp.initial_machine_position[l])
            .collect();
        let mut opts = opts.clone();
        if opts.force_tcp {
            opts.interp.tcp_at_start = true;
        }
        let mut vel = [f64::INFINITY; 9];
        let mut acc = [f64::INFINITY; 9];
        for (axis, l) in machine.axes.iter().zip(&letters) {
            vel[l.index()] = axis.max_velocity.unwrap_or(f64::INFINITY);
            acc[l.index()] = axis.max_acceleration.unwrap_or(f64::INFINITY);
        }
        let depth = match opts.plan.planner {
            Planner::ExactStop => 1,
            _ => opts.plan.lookahead,
        };
        Ok(Interpolator {
            machine,
            kin: Kinematics::nominal(machine),
            linear: machine
                .axes
                .iter()
                .map(|a| a.kind == AxisKind::Linear)
                .collect(),
            letters,
            buf: q.clone(),
            q,
            opts,
            k: 0,
            line: 0,
            summary: InterpolationSummary::default(),
            world: linuxcnc::WorldLimits {
                vel,
                acc,
                v_traj: machine.rapid_feed / 60.0,
            },
            queue: Lookahead::new(depth),
            active: VecDeque::new(),
            mode: PathMode::DEFAULT,
            tail: None,
            cam: NaiveCam::new(),
            spindle: (false, 0.0),
            ends: None,
        })
    }

    /// The settings in force (with `interp.tcp_at_start` set when TCP is forced).
    pub fn options(&self) -> &InterpolateOptions {
        &self.opts
    }

    /// Axis positions at the end of the moves given so far, machine axis order.
    pub fn position(&self) -> &[f64] {
        &self.q
    }

    /// Interpolates one event, handing the samples it makes ready to `sink`
    /// (with look-ahead, the samples of a move come once the moves after it
    /// are known, or at [`Interpolator::finish`]).
    pub fn push<F>(&mut self, event: &Event, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        self.line = event.at.line;
        let force = self.opts.force_tcp;
        // G64 Q under `linuxcnc`: straight feeds merge (plan::naive_cam).
        if let (Planner::Linuxcnc, PathMode::Blend { q: Some(q), .. }) =
            (self.opts.plan.planner, self.mode)
            && q > 0.0
            && let EventKind::Feed(m) = &event.kind
            && !matches!(m.feed, Feed::InverseTime(_))
        {
            for (m, line) in self.cam.see(m, self.line, q).into_iter().flatten() {
                self.line = line;
                self.linear_move(&m, force, sink)?;
            }
            return Ok(());
        }
        if !matches!(event.kind, EventKind::FeedRate(_))
            && let Some((m, line)) = self.cam.flush()
        {
            self.line = line;
            self.linear_move(&m, force, sink)?;
            self.line = event.at.line;
        }
        match &event.kind {
            EventKind::Traverse(m) | EventKind::Feed(m) => self.linear_move(m, force, sink),
            EventKind::Arc(a) => {
                let geom = Geom::Arc {
                    arc: *a,
                    g: arc::geometry(a),
                };
                self.work_move(geom, &a.from, &a.to, a.offset, a.feed, a.tcp || force, sink)
            }
            EventKind::Dwell { seconds } if *seconds > 0.0 => {
                self.summary.dwell_time += seconds;
                let block = Block {
                    path: Path::Hold { q: self.q.clone() },
                    len: *seconds,
                    line: self.line,
                };
                let lim = Limits {
                    len: *seconds,
                    v: 1.0,
                    a: f64::INFINITY,
                };
                self.enqueue(block, lim, None, sink)
            }
            EventKind::PathControl(mode) => {
                self.mode = *mode;
                Ok(())
            }
            EventKind::SpindleSpeed { rpm } => {
                let before = self.spindle.1;
                self.spindle.1 = *rpm;
                if self.spindle.0 && before != *rpm {
                    let wait = (rpm - before).abs() / self.opts.plan.spindle_accel;
                    return self.task_pause(wait, sink);
                }
                Ok(())
            }
            EventKind::Spindle(state) => {
                let on = !matches!(state, SpindleState::Stopped);
                let ramp = if on && !self.spindle.0 {
                    self.spindle.1.abs() / self.opts.plan.spindle_accel
                } else {
                    0.0
                };
                self.spindle.0 = on;
                self.task_pause(self.opts.plan.task_wait.max(ramp), sink)
            }
            EventKind::Tcp(_) => self.task_pause(self.opts.plan.task_wait, sink),
            EventKind::Wait(w) => {
                let wait = if w.through_io() {
                    self.opts.plan.io_wait
                } else {
                    self.opts.plan.task_wait
                };
                self.task_pause(wait, sink)
            }
            _ => Ok(()),
        }
    }

    /// `linuxcnc`: the machine stops and stands still for `wait` s (LinuxCNC's
    /// task waiting for the motion queue to empty before a spindle, TCP,
    /// coolant, tool or I/O command, and for the spindle to reach its
    /// speed); with no wait it still stops (no blend across the command).
    fn task_pause<F>(&mut self, wait: f64, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        match self.opts.plan.planner {
            // Before the first move the machine has not started: LinuxCNC's
            // run time counts from the first motion.
            Planner::Linuxcnc
                if wait > 0.0
                    && wait.is_finite()
                    && self.summary.moves + self.summary.transitions > 0 =>
            {
                let block = Block {
                    path: Path::Hold { q: self.q.clone() },
                    len: wait,
                    line: self.line,
                };
                let lim = Limits {
                    len: wait,
                    v: 1.0,
                    a: f64::INFINITY,
                };
                self.enqueue(block, lim, None, sink)
            }
            Planner::Linuxcnc => {
                self.end_chain();
                self.tail = None;
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Plans and samples what is still queued, emits the last sample (at
    /// the first `k·ts` not before the end) and returns the summary.
    pub fn finish<F>(self, sink: &mut F) -> Result<InterpolationSummary, InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        self.finish_with_ends(sink).map(|(s, _)| s)
    }

    /// [`Interpolator::finish`], also handing back the `(line, end time)` of
    /// every planned segment when they were recorded.
    pub(super) fn finish_with_ends<F>(
        mut self,
        sink: &mut F,
    ) -> Result<(InterpolationSummary, Vec<(u64, f64)>), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        if let Some((m, line)) = self.cam.flush() {
            self.line = line;
            let force = self.opts.force_tcp;
            self.linear_move(&m, force, sink)?;
        }
        self.end_chain();
        while let Some(p) = self.queue.pop_flush() {
            self.start(p, sink)?;
        }
        let end = self.active.iter().map(|p| p.t1()).fold(0.0, f64::max);
        self.emit_until(end, sink)?;
        let t = self.k as f64 * self.opts.ts;
        let sample = Sample {
            t,
            q: &self.q,
            line: self.active.back().map_or(self.line, |p| p.payload.line),
        };
        sink(&sample).map_err(InterpolateError::Sink)?;
        self.summary.samples += 1;
        self.summary.duration = end;
        Ok((self.summary, self.ends.take().unwrap_or_default()))
    }

    fn linear_move<F>(
        &mut self,
        m: &Linear,
        force: bool,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let geom = Geom::Line {
            from: m.from,
            to: m.to,
        };
        self.work_move(geom, &m.from, &m.to, m.offset, m.feed, m.tcp || force, sink)
    }

    #[allow(clippy::too_many_arguments)]
    fn work_move<F>(
        &mut self,
        geom: Geom,
        from: &Axes,
        to: &Axes,
        offset: Axes,
        feed: Feed,
        tcp: bool,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let d = to.sub(from);
        let still = match geom {
            Geom::Line { .. } | Geom::Blend { .. } => d.0.iter().all(|&x| x == 0.0),
            Geom::Arc { g, .. } => g.sweep == 0.0 && d.0.iter().all(|&x| x == 0.0),
        };
        self.check_axes(&geom, &d, still)?;
        let path = Path::Work {
            geom: Box::new(geom),
            offset,
            tcp,
        };
        // Join the current position to the move's start if they differ.
        let mut start = self.q.clone();
        self.eval(&path, 0.0, &mut start)?;
        let gap = start
            .iter()
            .zip(&self.q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if gap > SAME_POSITION && tcp && matches!(feed, Feed::Rapid) && !still {
            // The first rapid after TCP is switched on: the program's idea of the
            // tip (its last programmed numbers) is not where the tool is, so the
            // whole rapid goes straight in axis space to its end, instead of
            // diving to the programmed start first.
            let mut end = self.q.clone();
            self.eval(&path, 1.0, &mut end)?;
            self.transition(end, sink)?;
            self.summary.moves += 1;
            return Ok(());
        }
        if gap > SAME_POSITION {
            self.transition(start.clone(), sink)?;
        }
        self.q.copy_from_slice(&start);
        if still {
            return Ok(());
        }
        let xyz = match geom {
            Geom::Line { .. } | Geom::Blend { .. } => d.xyz_norm(),
            Geom::Arc { g, .. } => g.xyz_length(),
        };
        let mut seconds = self.feed_seconds(feed, xyz, &d)?;
        if !matches!(feed, Feed::Rapid) {
            seconds /= self.opts.plan.feed_override;
        }
        match self.opts.plan.planner {
            Planner::ExactStop => {
                let lim = self.exact_limits(&path, seconds)?;
                let block = Block {
                    path,
                    len: 1.0,
                    line: self.line,
                };
                self.enqueue(block, lim, None, sink)?;
            }
            _ => {
                let ml = match geom {
                    Geom::Line { .. } | Geom::Blend { .. } => linuxcnc::straight(&d, &self.world),
                    Geom::Arc { arc, g } => {
                        let (p, q, n) = arc.plane.axes();
                        let shape = linuxcnc::ArcShape {
                            plane: (p, q),
                            radius: (g.radius, g.end_radius),
                            sweep: g.sweep,
                            normal_len: d[n],
                        };
                        linuxcnc::arc(&d, &shape, xyz, &self.world)
                    }
                };
                let len = if matches!(geom, Geom::Arc { .. }) {
                    xyz
                } else {
                    ml.len
                };
                if len.is_nan() || len <= 0.0 {
                    return Ok(());
                }
                let v_ini = ml.v.min(len / self.opts.plan.cycle_time);
                let mut v_req = match feed {
                    Feed::Rapid => v_ini,
                    _ => len / seconds,
                };
                if !ml.pure_rotary {
                    v_req = v_req.min(self.world.v_traj);
                }
                let speed = Speed {
                    len,
                    v_ini,
                    v_req,
                    a_base: ml.a,
                    r_eff: match geom {
                        Geom::Arc { arc, g } => Some(
                            linuxcnc::ArcShape {
                                plane: (arc.plane.axes().0, arc.plane.axes().1),
                                radius: (g.radius, g.end_radius),
                                sweep: g.sweep,
                                normal_len: 0.0,
                            }
                            .effective_radius(),
                        ),
                        Geom::Line { .. } | Geom::Blend { .. } => None,
                    },
                    halved: false,
                    kink: 0.0,
                };
                let lim = speed.limits();
                let side = linuxcnc::Side {
                    dir: direction(&geom, 0.0),
                    rotary: ml.rotary,
                    circular: matches!(geom, Geom::Arc { .. }),
                    v: lim.v,
                    a: lim.a,
                    len,
                    nominal: len,
                    v_req,
                    v_max: v_ini,
                    tolerance: match self.mode {
                        PathMode::Blend { p: Some(p), .. } => p,
                        _ => 0.0,
                    },
                };
                let tail = Tail {
                    side,
                    mode: self.mode,
                    tcp,
                    offset,
                    speed,
                };
                let block = Block {
                    path,
                    len,
                    line: self.line,
                };
                self.enqueue(block, lim, Some(tail), sink)?;
                if let Some(t) = self.tail.as_mut() {
                    // The join rules see the end direction of this block next time.
                    t.side.dir = direction(&geom, 1.0);
                }
            }
        }
        let mut end = self.q.clone();
        if let Some((b, _, _)) = self.queue.last_mut() {
            let path = std::mem::replace(&mut b.path, Path::Hold { q: Vec::new() });
            let r = self.eval(&path, 1.0, &mut end);
            if let Some((b, _, _)) = self.queue.last_mut() {
                b.path = path;
            }
            r?;
        }
        self.check_travel(&end, 0.0)?;
        self.q.copy_from_slice(&end);
        self.summary.moves += 1;
        Ok(())
    }

    /// Axes the program moves must exist on the machine.
    pub(super) fn check_axes(
        &self,
        geom: &Geom,
        d: &Axes,
        still: bool,
    ) -> Result<(), InterpolateError> {
        for axis in Axis::ALL {
            let moved = match geom {
                Geom::Arc { arc, .. } => {
                    let (p, q, _) = arc.plane.axes();
                    d[axis] != 0.0 || axis == p || axis == q
                }
                Geom::Line { .. } | Geom::Blend { .. } => d[axis] != 0.0,
            };
            if moved && !still && !self.letters.contains(&axis) {
                return Err(InterpolateError::MissingAxis {
                    line: self.line,
                    letter: char::from(axis.letter()),
                });
            }
        }
        Ok(())
    }

    /// Queues a straight axis-space move from the current position to `end`
    /// at the rapid rate (stops before and after).
    fn transition<F>(&mut self, end: Vec<f64>, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let joint = Path::Joint {
            q0: self.q.clone(),
            q1: end.clone(),
        };
        let minutes = self.joint_rapid_minutes(&self.q, &end);
        let lim = self.exact_limits(&joint, 60.0 * minutes)?;
        let block = Block {
            path: joint,
            len: 1.0,
            line: self.line,
        };
        self.enqueue(block, lim, None, sink)?;
        self.check_travel(&end, 0.0)?;
        self.q.copy_from_slice(&end);
        self.summary.transitions += 1;
        Ok(())
    }

    /// Queues a block, joining it to the one before by the planner's rules
    /// (`tail`: the block's join data for `linuxcnc`; `None`: stops before
    /// and after), and samples what becomes ready.
    fn enqueue<F>(
        &mut self,
        block: Block,
        mut lim: Limits,
        tail: Option<Tail>,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let mut tail = tail;
        let joinable = match (&self.tail, &tail) {
            (Some(prev), Some(next)) => prev.tcp == next.tcp && prev.offset == next.offset,
            _ => false,
        };
        if !joinable {
            self.end_chain();
        }
        if let (true, Some(prev), Some(next)) = (joinable, self.tail.as_mut(), tail.as_mut()) {
            let set = linuxcnc::JoinSettings {
                cycle_time: self.opts.plan.cycle_time,
                kink_ratio: self.opts.plan.kink_ratio,
                acc_xyz: [self.world.acc[0], self.world.acc[1], self.world.acc[2]],
                vel_xyz: [self.world.vel[0], self.world.vel[1], self.world.vel[2]],
                max_feed_scale: self.opts.plan.max_feed_override,
            };
            let rule = linuxcnc::join(prev.mode, &prev.side, &next.side, &set);
            if let Some(arc) = rule.arc {
                return self.blend_arc(block, tail, arc, sink);
            }
            for (t, f) in [(&mut *prev, rule.a_prev), (&mut *next, rule.a_next)] {
                if f == 0.5 {
                    t.speed.halved = true;
                } else if f < 1.0 {
                    t.speed.kink = t.speed.kink.max(1.0 - f);
                }
            }
            let prev_lim = prev.speed.limits();
            lim = next.speed.limits();
            if let Some((_, l, j)) = self.queue.last_mut() {
                *l = prev_lim;
                *j = Some(rule.join);
            }
        }
        self.tail = tail;
        self.queue.push(block, lim);
        while let Some(p) = self.queue.pop_ready() {
            self.start(p, sink)?;
        }
        Ok(())
    }

    /// Queues a `linuxcnc` blend arc between the last queued straight block
    /// and `block` (straight too), trimming both by `arc.trim`, then
    /// `block`; all joins tangent.
    fn blend_arc<F>(
        &mut self,
        mut block: Block,
        tail: Option<Tail>,
        arc: linuxcnc::BlendArc,
        sink: &mut F,
    ) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        let (Some(prev), Some(mut next)) = (self.tail.take(), tail) else {
            return Ok(());
        };
        let mut prev = prev;
        let (u1, u2) = (prev.side.dir, next.side.dir);
        let trim = arc.trim;
        let cycle = self.opts.plan.cycle_time;
        let v_arc = arc.v_max;
        let shorten = |t: &mut Tail, b: &mut Block| {
            let rest = t.speed.len - trim;
            // What is left shorter than 4 cycles at the arc's speed LinuxCNC
            // runs as part of the arc: no per-cycle speed cap on it.
            if rest > 4.0 * cycle * v_arc {
                t.speed.v_ini = t.speed.v_ini.min(rest / cycle);
            }
            t.speed.len = rest.max(1e-9);
            t.side.len = t.speed.len;
            b.len = t.speed.len;
        };
        // The corner and the arc's start and end, work coordinates.
        let corner = match self.queue.last_mut() {
            Some((b, _, _)) => match &mut b.path {
                Path::Work { geom, .. } => match geom.as_mut() {
                    Geom::Line { to, .. } => {
                        let c = [to[Axis::X], to[Axis::Y], to[Axis::Z]];
                        for (i, a) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
                            to[a] = c[i] - u1[i] * trim;
                        }
                        c
                    }
                    _ => return Err(InterpolateError::Plan("blend arc after a non-line".into())),
                },
                _ => return Err(InterpolateError::Plan("blend arc after a non-line".into())),
            },
            None => return Err(InterpolateError::Plan("blend arc without a block".into())),
        };
        let from = match &mut block.path {
            Path::Work { geom, .. } => match geom.as_mut() {
                Geom::Line { from, .. } => {
                    let f0 = *from;
                    for (i, a) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
                        from[a] = corner[i] + u2[i] * trim;
                    }
                    f0
                }
                _ => return Err(InterpolateError::Plan("blend arc before a non-line".into())),
            },
            _ => return Err(InterpolateError::Plan("blend arc before a non-line".into())),
        };
        let dist = arc.radius / (arc.phi / 2.0).cos();
        let center: [f64; 3] = std::array::from_fn(|i| corner[i] + arc.normal[i] * dist);
        let start: [f64; 3] = std::array::from_fn(|i| corner[i] - u1[i] * trim);
        let e1: [f64; 3] = std::array::from_fn(|i| (start[i] - center[i]) / arc.radius);
        let geom = Geom::Blend {
            from,
            center,
            e1,
            e2: u1,
            r: arc.radius,
            phi: arc.phi,
        };
        let (v, a) = arc.limits();
        let arc_block = Block {
            path: Path::Work {
                geom: Box::new(geom),
                offset: prev.offset,
                tcp: prev.tcp,
            },
            len: arc.len(),
            line: self.queue.last_mut().map_or(self.line, |(b, _, _)| b.line),
        };
        if let Some((b, l, j)) = self.queue.last_mut() {
            shorten(&mut prev, b);
            *l = prev.speed.limits();
            *j = Some(Join::Tangent { v });
        }
        self.queue.push(
            arc_block,
            Limits {
                len: arc.len(),
                v,
                a,
            },
        );
        if let Some((_, _, j)) = self.queue.last_mut() {
            *j = Some(Join::Tangent { v });
        }
        shorten(&mut next, &mut block);
        let lim = next.speed.limits();
        self.tail = Some(next);
        self.queue.push(block, lim);
        while let Some(p) = self.queue.pop_ready() {
            self.start(p, sink)?;
        }
        Ok(())
    }

    /// The last queued block stops at its end: under G64 (its term
    /// condition stays a blend with nothing to blend into) LinuxCNC runs it
    /// at half acceleration, as it does every block that blends.
    fn end_chain(&mut self) {
        if let Some(prev) = self.tail.as_mut()
            && matches!(prev.mode, PathMode::Blend { .. })
            && !prev.speed.halved
        {
            prev.speed.halved = true;
            let lim = prev.speed.limits();
            if let Some((_, l, _)) = self.queue.last_mut() {
                *l = lim;
            }
        }
    }

    /// Samples up to the start of the planned block `p`, then makes it active.
    fn start<F>(&mut self, p: Planned<Block>, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        self.emit_until(p.t0, sink)?;
        if let Some(ends) = &mut self.ends {
            ends.push((p.payload.line, p.t1()));
        }
        self.active.push_back(p);
        Ok(())
    }

    /// Minutes of an axis-space transition at the rapid rate.
    fn joint_rapid_minutes(&self, q0: &[f64], q1: &[f64]) -> f64 {
        let (mut lin, mut rot) = (0.0f64, 0.0f64);
        for (i, (a, b)) in q0.iter().zip(q1).enumerate() {
            if self.linear[i] {
                lin += (b - a).powi(2);
            } else {
                rot += (b - a).powi(2);
            }
        }
        let path = if lin > 0.0 { lin.sqrt() } else { rot.sqrt() };
        path / self.machine.rapid_feed
    }

    /// Programmed duration of a move, s ([`timing::move_seconds`]).
    pub(super) fn feed_seconds(
        &self,
        feed: Feed,
        xyz: f64,
        d: &Axes,
    ) -> Result<f64, InterpolateError> {
        timing::move_seconds(feed, xyz, d, self.machine.rapid_feed).map_err(|e| {
            InterpolateError::Feed {
                line: self.line,
                message: e.0,
            }
        })
    }

    /// Work coordinates plus offset of a programmed move at `u ∈ [0, 1]`.
    pub(super) fn world(geom: &Geom, offset: &Axes, u: f64) -> Axes {
        let w = geom.at(u);
        Axes(std::array::from_fn(|i| w.0[i] + offset.0[i]))
    }

    /// Axis positions of the world position `w` (machine position under
    /// TCP: the tip plus the rotary axes) into `out`, which holds the
    /// previous positions (the IK start under TCP).
    pub(super) fn joints(
        &self,
        w: &Axes,
        tcp: bool,
        out: &mut [f64],
    ) -> Result<(), InterpolateError> {
        travel::machine_position(
            &self.kin,
            |i| Some(self.letters[i]),
            &self.linear,
            w,
            tcp,
            out,
        )
        .map_err(|source| InterpolateError::Ik {
            line: self.line,
            x: w[Axis::X],
            y: w[Axis::Y],
            z: w[Axis::Z],
            source,
        })
    }

    /// Axis positions at `s ∈ [0, 1]` along `path` into `out` (which holds the
    /// previous positions, used as the IK start under TCP).
    pub(super) fn eval(
        &self,
        path: &Path,
        s: f64,
        out: &mut [f64],
    ) -> Result<(), InterpolateError> {
        match path {
            Path::Joint { q0, q1 } => {
                for i in 0..out.len() {
                    out[i] = if s >= 1.0 {
                        q1[i]
                    } else {
                        q0[i] + (q1[i] - q0[i]) * s
                    };
                }
                Ok(())
            }
            Path::Hold { q } => {
                out.copy_from_slice(q);
                Ok(())
            }
            Path::Work { geom, offset, tcp } => {
                let w = Self::world(geom, offset, s);
                self.joints(&w, *tcp, out)
            }
        }
    }

    /// Bounds `(D1, D2)` on `|dq/ds|` and `|d²q/ds²|` per machine axis.
    fn derivative_bounds(&self, path: &Path) -> Result<(Vec<f64>, Vec<f64>), InterpolateError> {
        let n = self.q.len();
        let mut d1 = vec![0.0; n];
        let mut d2 = vec![0.0; n];
        let margin = self.opts.plan.derivative_margin;
        match path {
            Path::Hold { .. } => {}
            Path::Joint { q0, q1 } => {
                for i in 0..n {
                    d1[i] = (q1[i] - q0[i]).abs();
                }
            }
            Path::Work {
                geom, tcp: false, ..
            } => {
                let (from, to) = match geom.as_ref() {
                    Geom::Line { from, to } => (from, to),
                    Geom::Arc { arc, .. } => (&arc.from, &arc.to),
                    Geom::Blend { from, .. } => (from, from),
                };
                for (i, &l) in self.letters.iter().enumerate() {
                    d1[i] = (to[l] - from[l]).abs();
                }
                if let Geom::Blend { r, phi, .. } = geom.as_ref() {
                    for (i, &l) in self.letters.iter().enumerate() {
                        if matches!(l, Axis::X | Axis::Y | Axis::Z) {
                            d1[i] = r * phi;
                            d2[i] = r * phi * phi;
                        }
                    }
                }
                if let Geom::Arc { arc, g } = geom.as_ref() {
                    // q = c + r(s)·cos(a0 + φ s): |q'| ≤ |Δr| + r·|φ|,
                    // |q''| ≤ 2|Δr·φ| + r·φ².
                    let (p, q, _) = arc.plane.axes();
                    let dr = (g.end_radius - g.radius).abs();
                    let r = g.radius.max(g.end_radius);
                    let phi = g.sweep.abs();
                    for (i, &l) in self.letters.iter().enumerate() {
                        if l == p || l == q {
                            d1[i] = dr + r * phi;
                            d2[i] = 2.0 * dr * phi + r * phi * phi;
                        }
                    }
                }
            }
            Path::Work { tcp: true, .. } => {
                // Finite differences over FD_STEPS sub-steps, times the margin.
                let h = 1.0 / FD_STEPS as f64;
                let mut pts = Vec::with_capacity(FD_STEPS + 1);
                let mut cur = self.q.clone();
                for j in 0..=FD_STEPS {
                    self.eval(path, j as f64 * h, &mut cur)?;
                    pts.push(cur.clone());
                }
                // Per axis, the rounding level of a second difference.
                let mut noise = vec![FD_NOISE; n];
                for p in &pts {
                    for (z, q) in noise.iter_mut().zip(p) {
                        *z = z.max(FD_NOISE + 64.0 * f64::EPSILON * q.abs());
                    }
                }
                for j in 0..FD_STEPS {
                    for i in 0..n {
                        let v = (pts[j + 1][i] - pts[j][i]).abs() / h;
                        d1[i] = f64::max(d1[i], margin * v);
                        if j > 0 {
                            let dd = (pts[j + 1][i] - 2.0 * pts[j][i] + pts[j - 1][i]).abs();
                            if dd > noise[i] {
                                d2[i] = f64::max(d2[i], margin * dd / (h * h));
                            }
                        }
                    }
                }
            }
        }
        Ok((d1, d2))
    }

    /// `exact-stop` limits of a block over `s ∈ [0, 1]` whose programmed
    /// duration is `seconds`: the path speed and acceleration scaled down so
    /// that no joint exceeds its limits (see the module documentation).
    fn exact_limits(&self, path: &Path, seconds: f64) -> Result<Limits, InterpolateError> {
        let (d1, d2) = self.derivative_bounds(path)?;
        let mut v = 1.0 / seconds;
        let mut a = f64::INFINITY;
        for (i, axis) in self.machine.axes.iter().enumerate() {
            if d1[i] == 0.0 && d2[i] == 0.0 {
                continue;
            }
            if let Some(vmax) = axis.max_velocity
                && d1[i] > 0.0
            {
                v = v.min(vmax / d1[i]);
            }
            if let Some(amax) = axis.max_acceleration {
                if d2[i] > 0.0 {
                    v = v.min((amax / (2.0 * d2[i])).sqrt());
                    if d1[i] > 0.0 {
                        a = a.min(amax / (2.0 * d1[i]));
                    }
                } else {
                    a = a.min(amax / d1[i]);
                }
            }
        }
        Ok(Limits { len: 1.0, v, a })
    }

    /// Axis positions at time `t` into `out` (the blocks active then; while
    /// two blocks blend, the second one's displacement adds to the first's).
    fn position_at(&mut self, t: f64, out: &mut [f64]) -> Result<u64, InterpolateError> {
        while self.active.len() > 1 && self.active[0].t1() <= t && self.active[1].t0 <= t {
            self.active.pop_front();
        }
        let started = self.active.iter().take_while(|p| p.t0 <= t).count().max(1);
        let first = &self.active[0];
        let line = self.active[started - 1].payload.line;
        let u = |p: &Planned<Block>| p.profile.s_at(t - p.t0) / p.payload.len;
        if started == 1 {
            self.eval(&first.payload.path, u(first), out)?;
            return Ok(line);
        }
        let mut w = Axes::default();
        let mut tcp = false;
        for (i, p) in self.active.iter().take(started).enumerate() {
            if let Path::Work {
                geom,
                offset,
                tcp: c,
            } = &p.payload.path
            {
                tcp = *c;
                let x = Self::world(geom, offset, u(p));
                if i == 0 {
                    w = x;
                } else {
                    let x0 = Self::world(geom, offset, 0.0);
                    for j in 0..9 {
                        w.0[j] += x.0[j] - x0.0[j];
                    }
                }
            }
        }
        self.joints(&w, tcp, out)?;
        Ok(line)
    }

    /// Emits samples `k·ts < end`.
    fn emit_until<F>(&mut self, end: f64, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(&Sample<'_>) -> io::Result<()>,
    {
        if self.active.is_empty() {
            return Ok(());
        }
        // The samples this move needs, counted before any is made.
        if end / self.opts.ts >= self.opts.max_samples as f64 {
            return Err(InterpolateError::TooManySamples {
                line: self.line,
                t: end,
                ts: self.opts.ts,
                max: self.opts.max_samples,
            });
        }
        let mut out = std::mem::take(&mut self.buf);
        let result = loop {
            let t = self.k as f64 * self.opts.ts;
            if t >= end {
                break Ok(());
            }
            let line = match self.position_at(t, &mut out) {
                Ok(l) => l,
                Err(e) => break Err(e),
            };
            if let Err(e) = self.check_travel(&out, t) {
                break Err(e);
            }
            let sample = Sample { t, q: &out, line };
            if let Err(e) = sink(&sample) {
                break Err(InterpolateError::Sink(e));
            }
            self.k += 1;
            self.summary.samples += 1;
        };
        self.buf = out;
        result
    }
    pub(super) fn check_travel(&self, q: &[f64], t: f64) -> Result<(), InterpolateError> {
        if !self.opts.check_travel {
            return Ok(());
        }
        travel_error(self.machine, q, t, self.line)
    }
}
