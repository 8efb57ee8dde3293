//! Dense paths for the jerk-limited planner: a program's moves walked into
//! chains of closely spaced joint positions, with corner blends and the
//! affine shortcut of TCP moves.

use super::*;

/// A chain of programmed moves between two stops, sampled densely in joint
/// space: the input of a planner that times a whole chain at once (a
/// jerk-limited one).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DensePath {
    /// Path parameter at each point: the cumulative path length along the
    /// chain, each move counting its XYZ length (else UVW, else ABC, as the
    /// feed does), mm (deg for rotary-only moves). Starts at 0, increasing.
    pub s: Vec<f64>,
    /// Axis positions at each point, machine axis order (mm, deg); under
    /// TCP from the nominal inverse kinematics, the tip exactly on the
    /// programmed path.
    pub q: Vec<Vec<f64>>,
    /// Highest path speed at each point, path units per s: the programmed
    /// feed (× feed override; G93 and G95 as speeds), the machine's
    /// `rapid_feed` for rapids and as the trajectory limit of non-rotary
    /// moves. The point closes the move it ends; the first point takes the
    /// first move's cap.
    pub v_cap: Vec<f64>,
    /// Source line of the move each point ends (the first: the first move's).
    pub line: Vec<u64>,
}

/// The walker's chain of moves: [`DensePath`] with the points one after
/// the other in one vector (`q[k * n + i]` is axis `i` at point `k`), so
/// that a point costs no allocation and the planner takes the vectors as
/// they are.
#[derive(Debug, Clone, Default)]
pub(super) struct Chain {
    pub(super) s: Vec<f64>,
    pub(super) q: Vec<f64>,
    pub(super) v_cap: Vec<f64>,
    pub(super) line: Vec<u64>,
}

impl Chain {
    /// Appends a point.
    fn push(&mut self, s: f64, q: &[f64], v: f64, line: u64) {
        self.s.push(s);
        self.q.extend_from_slice(q);
        self.v_cap.push(v);
        self.line.push(line);
    }

    /// Removes the last point of `n` axes.
    fn pop(&mut self, n: usize) {
        self.s.pop();
        self.q.truncate(self.q.len().saturating_sub(n));
        self.v_cap.pop();
        self.line.pop();
    }

    /// The chain as a [`DensePath`] of `n` axes.
    fn dense(&self, n: usize) -> DensePath {
        DensePath {
            s: self.s.clone(),
            q: self.q.chunks(n).map(|c| c.to_vec()).collect(),
            v_cap: self.v_cap.clone(),
            line: self.line.clone(),
        }
    }
}

/// One stretch of a program under the `jerk` planner: the machine is at rest
/// before and after it.
#[derive(Debug)]
pub(super) enum Stretch<'a> {
    /// A chain of programmed moves (the receiver may take its vectors).
    Chain(&'a mut Chain),
    /// A straight axis-space move at the rapid rate (see the module
    /// documentation on transitions).
    Transition {
        q0: &'a [f64],
        q1: &'a [f64],
        line: u64,
    },
    /// Standing still at `q` for `seconds` (a dwell).
    Dwell {
        q: &'a [f64],
        seconds: f64,
        line: u64,
    },
}

/// Joint-space direction change (rad) above which G61 (exact path) stops
/// between two moves under the `jerk` planner.
const CORNER_ANGLE: f64 = 1.0f64.to_radians();
/// Smallest dense-path step that `G64 P` may ask for.
const MIN_JERK_STEP: f64 = 1e-3;

/// The last straight move of a chain (program coordinates), for the corner
/// blend of the next one under G64.
#[derive(Debug, Clone, Copy)]
pub(super) struct LastLine {
    pub(super) from: Axes,
    pub(super) to: Axes,
    pub(super) offset: Axes,
    pub(super) tcp: bool,
    /// Path length (XYZ), mm.
    pub(super) len: f64,
    /// Length taken from its start by a corner blend, mm.
    pub(super) cut0: f64,
    /// The move as a curve (a line or an arc) for blends next to arcs.
    pub(super) curve: Curve,
}

/// What to do at a corner between two moves under G64.
enum Corner {
    /// No corner (collinear) or nothing to blend: go on.
    None,
    /// Blended: the fraction of the new move the blend took.
    Blend(f64),
    /// Stop at the corner: blending within the tolerance is slower.
    Stop,
}

/// Points of a G64 corner blend between two straight moves under the `jerk`
/// planner, at least.
const BLEND_POINTS: usize = 16;

/// The G64 corner blend of the `jerk` planner between a straight move along
/// the unit direction `e1` (per mm of XYZ path) ending at the corner `c`
/// and one along `e2` leaving it: the quintic Bézier curve with the control
/// points `c − d e1`, `c − d e1 / 2`, `c`, `c`, `c + d e2 / 2`, `c + d e2`,
/// at `λ` in [0, 1]. Three control points on each line make the curve
/// meet the lines with the same tangent and zero curvature (C² with the
/// lines, so the joint spline through it needs no speed drop at its ends).
/// For `λ ≤ 1/2` the curve point is `x1 + d (b4/2 + b5) e2`, with `x1` on
/// the incoming line within `d` of the corner and `b_k` the Bernstein
/// polynomials; `b4/2 + b5 ≤ 7/64` there (at `λ = 1/2`); symmetrically for
/// `λ ≥ 1/2`. So the curve stays within `7 d / 64` of the programmed path:
/// `d = 64 P / 7` keeps it within the tolerance `P`.
fn corner_blend(c: &Axes, e1: &Axes, e2: &Axes, d: f64, lambda: f64) -> Axes {
    let (l, m) = (lambda, 1.0 - lambda);
    let b0 = m.powi(5);
    let b1 = 5.0 * l * m.powi(4);
    let b4 = 5.0 * l.powi(4) * m;
    let b5 = l.powi(5);
    let (w1, w2) = (d * (b0 + b1 / 2.0), d * (b4 / 2.0 + b5));
    Axes(std::array::from_fn(|i| {
        c.0[i] - w1 * e1.0[i] + w2 * e2.0[i]
    }))
}

/// The points of [`corner_blend`] at `λ = j / nb`, `j = 0..=nb`.
fn pts_blend_iter<'a>(
    c: &'a Axes,
    e1: &'a Axes,
    e2: &'a Axes,
    d: f64,
    nb: usize,
) -> impl Iterator<Item = Axes> + 'a {
    (0..=nb).map(move |j| corner_blend(c, e1, e2, d, j as f64 / nb as f64))
}

/// The TCP solve of a machine with three linear axes while its other axes
/// stand still, as the affine map it is: with the rotary axes fixed the
/// nominal tip is affine in the linear axes (see
/// `Kinematics::solve_tip_by_three_linear_axes`), so the linear axes are
/// affine in the tip, `x(p) = x0 + M (p − p0)`. Built from four solves
/// (at `p0` and 1 mm along X, Y, Z) and checked at a fifth point; then a
/// point costs a 3×3 product instead of a forward kinematics with
/// derivatives. Equal to solving each point to rounding.
#[derive(Debug, Clone)]
pub(super) struct AffineTcp {
    /// The positions of the other axes it holds for (all axes; the linear
    /// ones not used).
    pub(super) fixed: Vec<f64>,
    pub(super) p0: [f64; 3],
    pub(super) x0: [f64; 3],
    /// `m[k][c]`: linear axis `lin[k]` per mm of the tip along `c`.
    pub(super) m: [[f64; 3]; 3],
    /// False when the map did not check out (the general solve is used).
    pub(super) ok: bool,
}

/// The last [`AffineTcp`] map and the other axes of the last point solved
/// without one.
#[derive(Debug, Clone, Default)]
pub(super) struct AffineCache {
    pub(super) map: Option<AffineTcp>,
    pub(super) miss: Option<Vec<f64>>,
}

/// Axis positions of the world position `w` into `out` as
/// [`Interpolator::joints`], through the cached affine map under TCP on a
/// machine of three linear axes (see [`AffineTcp`]).
fn fast_joints(
    ip: &Interpolator<'_>,
    cache: &RefCell<AffineCache>,
    w: &Axes,
    tcp: bool,
    out: &mut [f64],
) -> Result<(), InterpolateError> {
    let Some(lin) = (if tcp {
        super::travel::three_linear(&ip.linear)
    } else {
        None
    }) else {
        return ip.joints(w, tcp, out);
    };
    for (i, o) in out.iter_mut().enumerate() {
        if !ip.linear[i] {
            *o = w[ip.letters[i]];
        }
    }
    let tip = [w[Axis::X], w[Axis::Y], w[Axis::Z]];
    let same = |c: &AffineTcp| {
        c.fixed
            .iter()
            .zip(out.iter())
            .enumerate()
            .all(|(i, (a, b))| ip.linear[i] || a == b)
    };
    let hit = matches!(&cache.borrow().map, Some(c) if same(c));
    if !hit {
        // Built at the second point with the same other axes (a point
        // alone costs one solve, as without the map).
        let again = cache.borrow().miss.as_ref().is_some_and(|m| {
            m.iter()
                .zip(out.iter())
                .enumerate()
                .all(|(i, (a, b))| ip.linear[i] || a == b)
        });
        if !again {
            match &mut cache.borrow_mut().miss {
                Some(m) if m.len() == out.len() => m.copy_from_slice(out),
                m => *m = Some(out.to_vec()),
            }
            return ip.joints(w, tcp, out);
        }
        let built = affine_tcp(ip, lin, w, out);
        *cache.borrow_mut() = AffineCache {
            map: Some(built),
            miss: None,
        };
    }
    let c = cache.borrow();
    let c = &c.map;
    let Some(c) = c.as_ref().filter(|c| c.ok) else {
        return ip.joints(w, tcp, out);
    };
    let d = [tip[0] - c.p0[0], tip[1] - c.p0[1], tip[2] - c.p0[2]];
    for (k, &i) in lin.iter().enumerate() {
        out[i] = c.x0[k] + (c.m[k][0] * d[0] + c.m[k][1] * d[1] + c.m[k][2] * d[2]);
    }
    Ok(())
}

/// Builds the [`AffineTcp`] map at `w` (the other axes as `out` holds them).
fn affine_tcp(ip: &Interpolator<'_>, lin: [usize; 3], w: &Axes, out: &[f64]) -> AffineTcp {
    let mut q = out.to_vec();
    let mut solve = |d: [f64; 3]| -> Option<[f64; 3]> {
        let mut p = *w;
        p[Axis::X] += d[0];
        p[Axis::Y] += d[1];
        p[Axis::Z] += d[2];
        ip.joints(&p, true, &mut q).ok()?;
        Some(lin.map(|i| q[i]))
    };
    let mut map = AffineTcp {
        fixed: out.to_vec(),
        p0: [w[Axis::X], w[Axis::Y], w[Axis::Z]],
        x0: [0.0; 3],
        m: [[0.0; 3]; 3],
        ok: false,
    };
    let Some(x0) = solve([0.0; 3]) else {
        return map;
    };
    let mut m = [[0.0; 3]; 3];
    for c in 0..3 {
        let mut d = [0.0; 3];
        d[c] = 1.0;
        let Some(x) = solve(d) else {
            return map;
        };
        for k in 0..3 {
            m[k][c] = x[k] - x0[k];
        }
    }
    // The check: a point off the axes.
    let probe = [0.6, -0.7, 0.4];
    let Some(x) = solve(probe) else {
        return map;
    };
    map.ok = (0..3).all(|k| {
        let pred = x0[k] + m[k][0] * probe[0] + m[k][1] * probe[1] + m[k][2] * probe[2];
        (pred - x[k]).abs() <= 1e-9 * (1.0 + x[k].abs())
    }) && m.iter().flatten().all(|v| v.is_finite());
    map.x0 = x0;
    map.m = m;
    map
}

/// Cuts a program into [`Stretch`]es for the `jerk` planner (see
/// [`dense_paths`]).
pub(super) struct Walker<'m> {
    pub(super) ip: Interpolator<'m>,
    pub(super) chain: Chain,
    /// The chain's last move when it is straight (for a G64 corner blend).
    pub(super) last: Option<LastLine>,
    /// The joint limits, when the machine gives them all (a G64 corner
    /// blend that is slower than a stop is not taken).
    pub(super) limits: Option<JointLimits>,
    pub(super) opts_jerk: jerk::JerkOptions,
    /// (TCP, offset) of the chain's moves.
    pub(super) key: Option<(bool, Axes)>,
    pub(super) mode: PathMode,
    /// Joint-space direction at the end of the chain's last move.
    pub(super) end_dir: Vec<f64>,
    pub(super) step: f64,
    /// The TCP solve as an affine map while the rotary axes stand still.
    pub(super) affine: RefCell<AffineCache>,
}

impl<'m> Walker<'m> {
    pub(super) fn new(
        machine: &'m Machine,
        opts: &InterpolateOptions,
    ) -> Result<Self, InterpolateError> {
        let step = opts.plan.jerk_step;
        if !(step > 0.0 && step.is_finite()) {
            return Err(InterpolateError::Plan(format!(
                "the dense path step must be a positive length, not {step}"
            )));
        }
        let mut o = opts.clone();
        o.plan.planner = Planner::ExactStop;
        let ip = Interpolator::new(machine, &o)?;
        Ok(Walker {
            ip,
            chain: Chain::default(),
            last: None,
            limits: jerk_limits(machine).ok(),
            opts_jerk: opts.plan.jerk,
            key: None,
            mode: PathMode::DEFAULT,
            end_dir: Vec::new(),
            step,
            affine: RefCell::new(AffineCache::default()),
        })
    }

    fn flush<F>(&mut self, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(Stretch<'_>) -> Result<(), InterpolateError>,
    {
        if self.chain.s.len() > 1 {
            sink(Stretch::Chain(&mut self.chain))?;
        }
        self.chain = Chain::default();
        self.last = None;
        Ok(())
    }

    /// Unit joint-space direction of `path` at `u` (0 or 1), from a
    /// one-sided difference; zero when the joints do not move there.
    fn direction(&self, path: &Path, u: f64) -> Result<Vec<f64>, InterpolateError> {
        let h = 1e-6;
        let (a, b) = if u >= 1.0 { (1.0 - h, 1.0) } else { (0.0, h) };
        let mut qa = self.ip.q.clone();
        let mut qb = self.ip.q.clone();
        self.ip.eval(path, a, &mut qa)?;
        self.ip.eval(path, b, &mut qb)?;
        let d: Vec<f64> = qb.iter().zip(&qa).map(|(x, y)| x - y).collect();
        let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        Ok(if n > 0.0 {
            d.iter().map(|x| x / n).collect()
        } else {
            d
        })
    }

    fn event<F>(&mut self, e: &Event, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(Stretch<'_>) -> Result<(), InterpolateError>,
    {
        self.ip.line = e.at.line;
        let force = self.ip.opts.force_tcp;
        let (geom, offset, feed, tcp) = match &e.kind {
            EventKind::Traverse(m) | EventKind::Feed(m) => (
                Geom::Line {
                    from: m.from,
                    to: m.to,
                },
                m.offset,
                m.feed,
                m.tcp || force,
            ),
            EventKind::Arc(a) => (
                Geom::Arc {
                    arc: *a,
                    g: arc::geometry(a),
                },
                a.offset,
                a.feed,
                a.tcp || force,
            ),
            EventKind::PathControl(m) => {
                self.mode = *m;
                return Ok(());
            }
            EventKind::Dwell { seconds } if *seconds > 0.0 => {
                self.flush(sink)?;
                self.key = None;
                self.ip.summary.dwell_time += seconds;
                return sink(Stretch::Dwell {
                    q: &self.ip.q,
                    seconds: *seconds,
                    line: self.ip.line,
                });
            }
            // Where LinuxCNC's task waits for the motion to end, the
            // machine stops (no wait time: that is LinuxCNC's own).
            EventKind::ProgramEnd
            | EventKind::Tcp(_)
            | EventKind::Spindle(_)
            | EventKind::Wait(_) => {
                self.flush(sink)?;
                self.key = None;
                return Ok(());
            }
            _ => return Ok(()),
        };
        let (from, to) = match geom {
            Geom::Line { from, to } => (from, to),
            Geom::Arc { arc, .. } => (arc.from, arc.to),
            Geom::Blend { .. } => (geom.at(0.0), geom.at(1.0)),
        };
        let d = to.sub(&from);
        let still = match geom {
            Geom::Line { .. } => d.0.iter().all(|&x| x == 0.0),
            Geom::Arc { g, .. } => g.sweep == 0.0 && d.0.iter().all(|&x| x == 0.0),
            Geom::Blend { r, phi, .. } => r * phi == 0.0,
        };
        self.ip.check_axes(&geom, &d, still)?;
        let path = Path::Work {
            geom: Box::new(geom),
            offset,
            tcp,
        };
        let mut start = self.ip.q.clone();
        self.ip.eval(&path, 0.0, &mut start)?;
        let gap = start
            .iter()
            .zip(&self.ip.q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if gap > SAME_POSITION && tcp && matches!(feed, Feed::Rapid) && !still {
            // As `exact-stop` does: the first rapid after TCP is switched on
            // goes straight in axis space to its end.
            self.flush(sink)?;
            self.key = None;
            let mut end = self.ip.q.clone();
            self.ip.eval(&path, 1.0, &mut end)?;
            self.transition(end, sink)?;
            self.ip.summary.moves += 1;
            return Ok(());
        }
        if gap > SAME_POSITION {
            self.flush(sink)?;
            self.key = None;
            self.transition(start.clone(), sink)?;
        }
        self.ip.q.copy_from_slice(&start);
        if still {
            return Ok(());
        }
        let ml = linuxcnc::straight(&d, &self.ip.world);
        let len = match geom {
            Geom::Arc { g, .. } => g.xyz_length(),
            Geom::Blend { r, phi, .. } => r * phi,
            Geom::Line { .. } => ml.len,
        };
        if len.is_nan() || len <= 0.0 {
            return Ok(());
        }
        let exact_path = self.mode == PathMode::ExactPath;
        let corner = exact_path
            && !self.end_dir.is_empty()
            && self
                .direction(&path, 0.0)?
                .iter()
                .zip(&self.end_dir)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                < CORNER_ANGLE.cos();
        if self.key != Some((tcp, offset)) || self.mode == PathMode::ExactStop || corner {
            self.flush(sink)?;
        }
        self.key = Some((tcp, offset));
        let xyz = match geom {
            Geom::Arc { g, .. } => g.xyz_length(),
            Geom::Blend { r, phi, .. } => r * phi,
            Geom::Line { .. } => d.xyz_norm(),
        };
        let mut v = match feed {
            Feed::Rapid => self.ip.world.v_traj,
            _ => len / self.ip.feed_seconds(feed, xyz, &d)? * self.ip.opts.plan.feed_override,
        };
        if !ml.pure_rotary {
            v = v.min(self.ip.world.v_traj);
        }
        let step = match self.mode {
            PathMode::Blend { p: Some(p), .. } if p > 0.0 => {
                self.step.min(4.0 * p).max(MIN_JERK_STEP.min(self.step))
            }
            _ => self.step,
        };
        let mut line_now = match geom {
            Geom::Line { from, to }
                if d.xyz_norm() > 0.0 && (len - d.xyz_norm()).abs() <= 1e-12 * len =>
            {
                Some(LastLine {
                    from,
                    to,
                    offset,
                    tcp,
                    len,
                    cut0: 0.0,
                    curve: Curve::line(from, to, len),
                })
            }
            Geom::Arc { arc, g } if len.is_finite() && g.radius > 0.0 => {
                let (p, q, _) = arc.plane.axes();
                Some(LastLine {
                    from: arc.from,
                    to: arc.to,
                    offset,
                    tcp,
                    len,
                    cut0: 0.0,
                    curve: Curve::arc(
                        arc.from,
                        arc.to,
                        (p, q),
                        g.center,
                        (g.radius, g.end_radius),
                        g.start_angle,
                        g.sweep,
                        len,
                    ),
                })
            }
            _ => None,
        };
        // A G64 corner between two moves (lines or arcs): the blend
        // replaces the last `d` of the previous move and the first `d` of
        // this one.
        let corner = match (self.mode, self.last, line_now) {
            (PathMode::Blend { p, .. }, Some(prev), Some(cur))
                if prev.tcp == tcp && prev.offset == offset && self.chain.s.len() > 1 =>
            {
                let tol = match p {
                    Some(p) if p > 0.0 => p,
                    _ => self.step / 4.0,
                };
                let cap = v.min(*self.chain.v_cap.last().unwrap_or(&v));
                self.blend(&prev, &cur, tol, cap)?
            }
            _ => Corner::None,
        };
        let u0 = match corner {
            Corner::Blend(u0) => u0,
            Corner::Stop => {
                self.flush(sink)?;
                0.0
            }
            Corner::None => 0.0,
        };
        if let Some(l) = line_now.as_mut() {
            l.cut0 = u0 * len;
        }
        self.last = line_now;
        if self.chain.s.is_empty() {
            self.chain.push(0.0, &self.ip.q, v, self.ip.line);
        }
        let ip = &mut self.ip;
        let chain = &mut self.chain;
        // At most a step apart in path length and in every joint (mm, deg).
        let mut q = ip.q.clone();
        ip.eval(&path, 1.0, &mut q)?;
        let spread = q
            .iter()
            .zip(&ip.q)
            .map(|(a, b)| (a - b).abs())
            .fold(len * (1.0 - u0), f64::max);
        let n = (spread / step).ceil().max(1.0) as usize;
        let s0 = *chain.s.last().unwrap_or(&0.0);
        // A straight move whose joint path is straight too: the axes of
        // their letters without TCP; under TCP on three linear axes with
        // the other axes standing still (the nominal tip is then affine in
        // the linear axes, see `Kinematics::solve_tip_by_three_linear_axes`,
        // so its inverse along the line is a line). Its points are then the
        // joint positions of its ends interpolated (equal to solving each
        // point to rounding), no solve per point.
        let straight = matches!(geom, Geom::Line { .. })
            && (!tcp
                || (ip.linear.iter().filter(|l| **l).count() == 3
                    && ip
                        .linear
                        .iter()
                        .zip(q.iter().zip(&ip.q))
                        .all(|(lin, (a, b))| *lin || a == b)));
        if straight {
            // From the chain's last point (the blend's end when one took
            // the move's start) to the move's end.
            let (qa, q1) = (ip.q.clone(), q.clone());
            for j in 1..=n {
                let f = j as f64 / n as f64;
                let u = u0 + (1.0 - u0) * f;
                if j == n {
                    q.copy_from_slice(&q1);
                } else {
                    for i in 0..q.len() {
                        q[i] = qa[i] + (q1[i] - qa[i]) * f;
                    }
                }
                chain.push(s0 + len * (u - u0), &q, v, ip.line);
            }
        } else {
            q.copy_from_slice(&ip.q);
            for j in 1..=n {
                let u = u0 + (1.0 - u0) * (j as f64 / n as f64);
                let w = Interpolator::world(&geom, &offset, u);
                fast_joints(ip, &self.affine, &w, tcp, &mut q)?;
                chain.push(s0 + len * (u - u0), &q, v, ip.line);
            }
        }
        ip.check_travel(&q, 0.0)?;
        ip.q.copy_from_slice(&q);
        ip.summary.moves += 1;
        self.end_dir = if exact_path {
            self.direction(&path, 1.0)?
        } else {
            Vec::new()
        };
        Ok(())
    }

    /// Replaces the end of the chain's last move `prev` by the corner blend
    /// (see [`corner_blend`]) towards the straight move `cur`, within the
    /// tolerance `tol` (mm) of the programmed path; the blend points take
    /// the speed cap `v`. Returns the fraction of `cur` the blend took,
    /// [`Corner::None`] when there is no corner to blend (collinear moves,
    /// a reversal, too short a blend to sample), or [`Corner::Stop`] when
    /// the jerk-limited motion through the blend is slower than stopping at
    /// the corner: compared on the corner's neighbourhood (the blend and
    /// up to `d` of straight path on each side), each alternative planned
    /// rest to rest by the time law itself.
    fn blend(
        &mut self,
        prev: &LastLine,
        cur: &LastLine,
        tol: f64,
        v: f64,
    ) -> Result<Corner, InterpolateError> {
        if !(prev.curve.is_line() && cur.curve.is_line()) {
            return self.blend_curves(prev, cur, tol, v);
        }
        let dir = |m: &LastLine| {
            let d = m.to.sub(&m.from);
            Axes(std::array::from_fn(|i| d.0[i] / m.len))
        };
        let (e1, e2) = (dir(prev), dir(cur));
        let cos = (0..3).map(|i| e1.0[i] * e2.0[i]).sum::<f64>();
        let turn = (0..9)
            .map(|i| (e2.0[i] - e1.0[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        if turn <= 1e-12 || cos < -0.999 {
            return Ok(Corner::None);
        }
        let d = (64.0 * tol / 7.0).min(prev.len / 2.0).min(cur.len / 2.0);
        let nb = ((8.0 * d / self.step).ceil() as usize).max(BLEND_POINTS);
        let c = cur.from;
        let pts: Vec<Axes> = pts_blend_iter(&c, &e1, &e2, d, nb).collect();
        let chords: Vec<f64> = pts.windows(2).map(|w| w[1].sub(&w[0]).xyz_norm()).collect();
        if chords.iter().any(|x| x.is_nan() || *x <= 0.0) {
            return Ok(Corner::None);
        }
        let mut known = None;
        if let Some(lim) = &self.limits {
            // The neighbourhood: `d1`, `d2` of straight path before and
            // after the corner (at least the blend's `d`, up to `2d`).
            let d1 = (2.0 * d).min(prev.len - prev.cut0).max(d);
            let d2 = (2.0 * d).min(cur.len / 2.0).max(d);
            let world = |p: &Axes| Axes(std::array::from_fn(|i| p.0[i] + prev.offset.0[i]));
            let along = |e: &Axes, t: f64| Axes(std::array::from_fn(|i| c.0[i] + t * e.0[i]));
            let n = self.ip.q.len();
            let mut q = self.ip.q.clone();
            let joints = |pts: &[Axes], q: &mut Vec<f64>| -> Result<Vec<f64>, InterpolateError> {
                let mut out = Vec::with_capacity(pts.len() * n);
                for p in pts {
                    fast_joints(&self.ip, &self.affine, &world(p), prev.tcp, q)?;
                    out.extend_from_slice(q);
                }
                Ok(out)
            };
            let plan = |s: Vec<f64>, q: Vec<f64>| -> Option<f64> {
                let caps = vec![v; s.len()];
                let path = JointPath::new(n, s, q, caps).ok()?;
                jerk::plan(&path, lim, &self.opts_jerk)
                    .ok()
                    .map(|l| l.duration())
            };
            let mut pts = vec![along(&e1, -d1)];
            let mut s = vec![0.0];
            if d1 > d {
                pts.push(along(&e1, -d));
                s.push(d1 - d);
            }
            let s_blend = *s.last().unwrap_or(&0.0);
            for (j, p) in pts_blend_iter(&c, &e1, &e2, d, nb).enumerate().skip(1) {
                pts.push(p);
                s.push(s_blend + chords[..j].iter().sum::<f64>());
            }
            if d2 > d {
                pts.push(along(&e2, d2));
                s.push(*s.last().unwrap_or(&0.0) + d2 - d);
            }
            let qb = joints(&pts, &mut q)?;
            // The blend's points are solved once (for the splice too); the
            // ends of the stopped alternative are the neighbourhood's ends
            // and the corner, where the chain is (`self.ip.q`).
            let i0 = usize::from(d1 > d);
            known = Some(qb[i0 * n..(i0 + nb + 1) * n].to_vec());
            let (first, last) = (&qb[..n], &qb[qb.len() - n..]);
            let qa: Vec<f64> = first.iter().chain(&self.ip.q).copied().collect();
            let qc: Vec<f64> = self.ip.q.iter().chain(last).copied().collect();
            let through = plan(s, qb);
            let stop_a = plan(vec![0.0, d1], qa);
            let stop_b = plan(vec![0.0, d2], qc);
            if let (Some(t), Some(a), Some(b)) = (through, stop_a, stop_b)
                && t >= a + b
            {
                return Ok(Corner::Stop);
            }
        }
        self.splice(prev, d, &pts, &chords, v, known.as_deref())?;
        Ok(Corner::Blend(d / cur.len))
    }

    /// As [`Walker::blend`] when `prev` or `cur` is an arc: the blend of
    /// [`jblend`] (C² with both moves, within `tol` of them), its points
    /// and the neighbourhood of the corner sampled at most a step apart.
    fn blend_curves(
        &mut self,
        prev: &LastLine,
        cur: &LastLine,
        tol: f64,
        v: f64,
    ) -> Result<Corner, InterpolateError> {
        let (a, b) = (&prev.curve, &cur.curve);
        let Some(d_max) = jblend::size(a, b, tol) else {
            return Ok(Corner::None);
        };
        let d_max = d_max.min(prev.len - prev.cut0);
        let step = self.step;
        // The blend's points and chords at size `d`; `None` when degenerate.
        let points = |d: f64| -> Option<(Vec<Axes>, Vec<f64>)> {
            let nb = ((8.0 * d / step).ceil() as usize).max(BLEND_POINTS);
            let pts: Vec<Axes> = (0..=nb)
                .map(|j| jblend::point(a, b, d, j as f64 / nb as f64))
                .collect();
            let chords: Vec<f64> = pts.windows(2).map(|w| w[1].sub(&w[0]).xyz_norm()).collect();
            (!chords.iter().any(|x| x.is_nan() || *x <= 0.0)).then_some((pts, chords))
        };
        let Some(lim) = self.limits.clone() else {
            let Some((pts, chords)) = points(d_max) else {
                return Ok(Corner::None);
            };
            self.splice(prev, d_max, &pts, &chords, v, None)?;
            return Ok(Corner::Blend(d_max / cur.len));
        };
        // The neighbourhood: `d1` of the first move before the corner and
        // `d2` of the second after it (up to `2d`, the second move whole
        // where shorter: its curvature beyond the blend counts), sampled
        // at most a step apart.
        let d1 = (2.0 * d_max).min(prev.len - prev.cut0).max(d_max);
        let d2 = (2.0 * d_max).min(cur.len).max(d_max);
        let stretch = |s0: f64, s1: f64| -> Vec<f64> {
            let n = (((s1 - s0) / step).ceil() as usize).max(1);
            (0..=n)
                .map(|k| s0 + (s1 - s0) * k as f64 / n as f64)
                .collect()
        };
        let world = |p: &Axes| Axes(std::array::from_fn(|i| p.0[i] + prev.offset.0[i]));
        let n = self.ip.q.len();
        let joints = |pts: &[Axes]| -> Result<Vec<f64>, InterpolateError> {
            let mut q = self.ip.q.clone();
            let mut out = Vec::with_capacity(pts.len() * n);
            for p in pts {
                fast_joints(&self.ip, &self.affine, &world(p), prev.tcp, &mut q)?;
                out.extend_from_slice(&q);
            }
            Ok(out)
        };
        let plan = |s: Vec<f64>, q: Vec<f64>| -> Option<f64> {
            let caps = vec![v; s.len()];
            let path = JointPath::new(n, s, q, caps).ok()?;
            jerk::plan(&path, &lim, &self.opts_jerk)
                .ok()
                .map(|l| l.duration())
        };
        let sa = stretch(-d1, 0.0);
        let pa: Vec<Axes> = sa.iter().map(|&x| a.near_end(x)).collect();
        let sa: Vec<f64> = sa.iter().map(|x| x + d1).collect();
        let sc = stretch(0.0, d2);
        let pc: Vec<Axes> = sc.iter().map(|&x| b.near_start(x)).collect();
        let stop = match (plan(sa, joints(&pa)?), plan(sc, joints(&pc)?)) {
            (Some(x), Some(y)) => x + y,
            _ => f64::INFINITY,
        };
        // The largest blend within the tolerance, else a half or a quarter
        // of it (a large blend of a tight turn can be slower than a smaller
        // one), the first that is faster than stopping.
        let mut chosen = None;
        for d in [d_max, d_max / 2.0, d_max / 4.0] {
            let Some((pts, chords)) = points(d) else {
                continue;
            };
            let (mut pn, mut sn) = (Vec::new(), Vec::new());
            let before = stretch(-d1, -d);
            for &x in &before[..before.len() - 1] {
                pn.push(a.near_end(x));
                sn.push(x + d1);
            }
            let s_blend = d1 - d;
            for (j, p) in pts.iter().enumerate() {
                pn.push(*p);
                sn.push(s_blend + chords[..j].iter().sum::<f64>());
            }
            let s_after = *sn.last().unwrap_or(&0.0);
            for &x in stretch(d, d2).iter().skip(1) {
                pn.push(b.near_start(x));
                sn.push(s_after + x - d);
            }
            let through = plan(sn, joints(&pn)?);
            if through.is_some_and(|t| t < stop) {
                chosen = Some((d, pts, chords));
                break;
            }
        }
        match chosen {
            Some((d, pts, chords)) => {
                self.splice(prev, d, &pts, &chords, v, None)?;
                Ok(Corner::Blend(d / cur.len))
            }
            None => Ok(Corner::Stop),
        }
    }

    /// Replaces the last `d` of the chain by the blend points `pts` (work
    /// coordinates of `prev`'s offset and TCP; `chords` their distances;
    /// `known` their axis positions when already solved).
    fn splice(
        &mut self,
        prev: &LastLine,
        d: f64,
        pts: &[Axes],
        chords: &[f64],
        v: f64,
        known: Option<&[f64]>,
    ) -> Result<(), InterpolateError> {
        let n = self.ip.q.len();
        let chain = &mut self.chain;
        let s_c = *chain.s.last().unwrap_or(&0.0);
        let cut = s_c - d;
        while chain.s.len() > 1 && *chain.s.last().unwrap_or(&0.0) >= cut - 1e-9 * d {
            chain.pop(n);
        }
        let mut q = if chain.q.len() >= n {
            chain.q[chain.q.len() - n..].to_vec()
        } else {
            self.ip.q.clone()
        };
        let mut s = cut;
        for (j, p) in pts.iter().enumerate() {
            let w = Axes(std::array::from_fn(|i| p.0[i] + prev.offset.0[i]));
            match known {
                Some(k) if k.len() == pts.len() * n => q.copy_from_slice(&k[j * n..(j + 1) * n]),
                _ => fast_joints(&self.ip, &self.affine, &w, prev.tcp, &mut q)?,
            }
            if j > 0 {
                s += chords[j - 1];
            }
            chain.push(s, &q, v, self.ip.line);
        }
        self.ip.q.copy_from_slice(&q);
        Ok(())
    }

    /// A transition from the current position to `end`, as its own stretch.
    fn transition<F>(&mut self, end: Vec<f64>, sink: &mut F) -> Result<(), InterpolateError>
    where
        F: FnMut(Stretch<'_>) -> Result<(), InterpolateError>,
    {
        self.ip.check_travel(&end, 0.0)?;
        sink(Stretch::Transition {
            q0: &self.ip.q,
            q1: &end,
            line: self.ip.line,
        })?;
        self.ip.q.copy_from_slice(&end);
        self.ip.summary.transitions += 1;
        self.end_dir.clear();
        Ok(())
    }

    /// Runs the program through the walker; returns the moves, transitions
    /// and dwell time counted.
    pub(super) fn run<R, F>(
        mut self,
        input: R,
        mut sink: F,
        mut hook: Option<&mut Hook<'_>>,
    ) -> Result<InterpolationSummary, InterpolateError>
    where
        R: BufRead,
        F: FnMut(Stretch<'_>) -> Result<(), InterpolateError>,
    {
        let iopts = self.ip.options().interp.clone();
        for_each_event(input, &iopts, hook.as_deref_mut(), |e| {
            self.event(e, &mut sink)
        })?;
        if let Some(e) = hook.and_then(|h| h.failed.take()) {
            return Err(e);
        }
        self.flush(&mut sink)?;
        Ok(self.ip.summary)
    }
}

/// Splits the program read from `input` into chains of moves between stops
/// and hands each to `sink` as a [`DensePath`] with points at most
/// `opts.plan.jerk_step` apart in path length and in every joint (mm, deg;
/// every move end is a point; `G64 P` makes the step at most 4·P). A chain ends at every move under G61.1
/// (exact stop), at a corner under G61 (a joint-space direction change of
/// more than 1°), at a dwell, a change of TCP or of work and tool offsets, a
/// spindle, tool, coolant or I/O command ([`super::TaskWait`]), a
/// move that starts away from the last one's end (TCP switched on: the
/// axis-space transition between the two is not part of either chain), and
/// at the end of the program. The points of a chain are the axis positions
/// of the programmed path (under TCP from the nominal inverse kinematics).
/// Memory holds one chain.
pub fn dense_paths<R, F>(
    mut input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
    mut sink: F,
) -> Result<(), InterpolateError>
where
    R: BufRead,
    F: FnMut(&DensePath) -> Result<(), InterpolateError>,
{
    dense_paths_dyn(&mut input, machine, opts, &mut sink)
}

/// [`dense_paths`] for a `dyn` reader and sink (the walker compiled once).
fn dense_paths_dyn(
    input: &mut dyn BufRead,
    machine: &Machine,
    opts: &InterpolateOptions,
    sink: &mut dyn FnMut(&DensePath) -> Result<(), InterpolateError>,
) -> Result<(), InterpolateError> {
    let n = machine.axes.len();
    Walker::new(machine, opts)?.run(
        input,
        |st| match st {
            Stretch::Chain(c) => sink(&c.dense(n)),
            _ => Ok(()),
        },
        None,
    )?;
    Ok(())
}
