//! Interpolation with the jerk-limited planner: the machine's joint limits,
//! the dense paths planned and sampled, travel checked.

use super::*;

/// The joint limits of `machine` for the `jerk` planner: every axis needs
/// `max_acceleration` and `max_jerk` (`max_velocity` may be absent: no
/// limit). The error names the first axis and key missing.
pub fn jerk_limits(machine: &Machine) -> Result<JointLimits, InterpolateError> {
    let mut lim = JointLimits {
        v: Vec::new(),
        a: Vec::new(),
        j: Vec::new(),
    };
    for axis in &machine.axes {
        let unit = match axis.kind {
            AxisKind::Linear => "mm",
            AxisKind::Rotary => "deg",
        };
        for (key, value, power) in [
            ("max_acceleration", axis.max_acceleration, "²"),
            ("max_jerk", axis.max_jerk, "³"),
        ] {
            if value.is_none() {
                return Err(InterpolateError::MissingLimit {
                    axis: axis.name.clone(),
                    key,
                    unit: format!("{unit}/s{power}"),
                });
            }
        }
        lim.v.push(axis.max_velocity.unwrap_or(f64::INFINITY));
        lim.a.push(axis.max_acceleration.unwrap_or(f64::INFINITY));
        lim.j.push(axis.max_jerk.unwrap_or(f64::INFINITY));
    }
    Ok(lim)
}

/// Plans and samples the stretches of the `jerk` planner on one clock.
struct JerkRun<'a, F> {
    pub(super) machine: &'a Machine,
    pub(super) limits: JointLimits,
    pub(super) opts: &'a InterpolateOptions,
    /// Index of the next sample.
    pub(super) k: u64,
    /// Start of the next stretch, s.
    pub(super) t0: f64,
    pub(super) q: Vec<f64>,
    pub(super) line: u64,
    pub(super) samples: u64,
    pub(super) sink: F,
    /// `(line, end time)` of every move and stretch, when asked for.
    pub(super) ends: Option<Vec<(u64, f64)>>,
}

impl<F> JerkRun<'_, F>
where
    F: FnMut(&Sample<'_>) -> io::Result<()>,
{
    /// Plans `path` and emits its samples before its end.
    fn law(&mut self, path: &JointPath, lines: &[u64]) -> Result<(), InterpolateError> {
        let law = jerk::plan(path, &self.limits, &self.opts.plan.jerk)
            .map_err(|e| InterpolateError::Plan(format!("line {}: {e}", lines[0])))?;
        let end = self.t0 + law.duration();
        self.bound(end, *lines.last().unwrap_or(&0))?;
        if let Some(ends) = &mut self.ends {
            // Each move ends at its last point: the time the law's path
            // parameter reaches it (bisection; the law never goes back).
            let s = path.s();
            for i in 0..lines.len() {
                if i + 1 < lines.len() && lines[i + 1] == lines[i] {
                    continue;
                }
                let t = if i + 1 == lines.len() {
                    law.duration()
                } else {
                    let (mut lo, mut hi) = (0.0, law.duration());
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        if law.s(mid) >= s[i] {
                            hi = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    hi
                };
                ends.push((lines[i], self.t0 + t));
            }
        }
        let mut cur = law.cursor();
        let mut out = vec![0.0; path.joints()];
        let s = path.s();
        let mut idx = 0;
        loop {
            let t = self.k as f64 * self.opts.ts;
            if t >= end {
                break;
            }
            let sp = cur.at_clock(self.k as f64, self.opts.ts, self.t0, &mut out);
            while idx + 1 < s.len() && s[idx] < sp {
                idx += 1;
            }
            self.emit(t, &out, lines[idx])?;
        }
        self.t0 = end;
        self.q.copy_from_slice(path.q(path.points() - 1));
        self.line = *lines.last().unwrap_or(&self.line);
        Ok(())
    }

    fn bound(&self, end: f64, line: u64) -> Result<(), InterpolateError> {
        if end / self.opts.ts >= self.opts.max_samples as f64 {
            return Err(InterpolateError::TooManySamples {
                line,
                t: end,
                ts: self.opts.ts,
                max: self.opts.max_samples,
            });
        }
        Ok(())
    }

    fn emit(&mut self, t: f64, q: &[f64], line: u64) -> Result<(), InterpolateError> {
        if self.opts.check_travel {
            travel_error(self.machine, q, t, line)?;
        }
        (self.sink)(&Sample { t, q, line }).map_err(InterpolateError::Sink)?;
        self.k += 1;
        self.samples += 1;
        Ok(())
    }

    fn stretch(&mut self, st: Stretch<'_>) -> Result<(), InterpolateError> {
        match st {
            Stretch::Chain(c) => {
                let n = self.q.len();
                let (s, q, cap) = (
                    std::mem::take(&mut c.s),
                    std::mem::take(&mut c.q),
                    std::mem::take(&mut c.v_cap),
                );
                let path = JointPath::new(n, s, q, cap)
                    .map_err(|e| InterpolateError::Plan(format!("line {}: {e}", c.line[0])))?;
                self.law(&path, &c.line)
            }
            Stretch::Transition { q0, q1, line } => {
                // Path length as the rapid rate counts it: the linear axes,
                // else the rotary ones.
                let (mut lin, mut rot) = (0.0f64, 0.0f64);
                for (i, (a, b)) in q0.iter().zip(q1).enumerate() {
                    if self.machine.axes[i].kind == AxisKind::Linear {
                        lin += (b - a).powi(2);
                    } else {
                        rot += (b - a).powi(2);
                    }
                }
                let len = if lin > 0.0 { lin.sqrt() } else { rot.sqrt() };
                if len.is_nan() || len <= 0.0 {
                    return Ok(());
                }
                let v = self.machine.rapid_feed / 60.0;
                let q: Vec<f64> = q0.iter().chain(q1).copied().collect();
                let path = JointPath::new(q0.len(), vec![0.0, len], q, vec![v, v])
                    .map_err(|e| InterpolateError::Plan(format!("line {line}: {e}")))?;
                self.law(&path, &[line, line])
            }
            Stretch::Dwell { q, seconds, line } => {
                let end = self.t0 + seconds;
                self.bound(end, line)?;
                self.q.copy_from_slice(q);
                loop {
                    let t = self.k as f64 * self.opts.ts;
                    if t >= end {
                        break;
                    }
                    let q = self.q.clone();
                    self.emit(t, &q, line)?;
                }
                if let Some(ends) = &mut self.ends {
                    ends.push((line, end));
                }
                self.t0 = end;
                self.line = line;
                Ok(())
            }
        }
    }
}

/// An [`InterpolateError::OutOfTravel`] when `q` leaves an axis travel.
pub(super) fn travel_error(
    machine: &Machine,
    q: &[f64],
    t: f64,
    line: u64,
) -> Result<(), InterpolateError> {
    match travel::first_outside(machine, q) {
        None => Ok(()),
        Some(i) => {
            let axis = &machine.axes[i];
            Err(InterpolateError::OutOfTravel {
                line,
                axis: axis.name.clone(),
                value: q[i],
                unit: match axis.kind {
                    AxisKind::Linear => "mm",
                    AxisKind::Rotary => "deg",
                },
                t,
                lo: axis.travel[0],
                hi: axis.travel[1],
            })
        }
    }
}

/// [`interpolate`] under the `jerk` planner: each stretch between stops is
/// one jerk-limited motion ([`jerk::plan`]) along its dense joint path.
pub(super) fn interpolate_jerk<R, F>(
    input: R,
    machine: &Machine,
    opts: &InterpolateOptions,
    sink: F,
    hook: Option<&mut Hook<'_>>,
    ends: Option<&mut Vec<(u64, f64)>>,
) -> Result<InterpolationSummary, InterpolateError>
where
    R: BufRead,
    F: FnMut(&Sample<'_>) -> io::Result<()>,
{
    let (limits, walker) =
        match jerk_limits(machine).and_then(|l| Ok((l, Walker::new(machine, opts)?))) {
            Ok(x) => x,
            Err(e) => return without_planner(input, opts, hook, e),
        };
    let q = walker.ip.q.clone();
    let mut run = JerkRun {
        machine,
        limits,
        opts,
        k: 0,
        t0: 0.0,
        q,
        line: 0,
        samples: 0,
        sink,
        ends: ends.is_some().then(Vec::new),
    };
    let mut summary = walker.run(input, |st| run.stretch(st), hook)?;
    let t = run.k as f64 * opts.ts;
    let q = run.q.clone();
    (run.sink)(&Sample {
        t,
        q: &q,
        line: run.line,
    })
    .map_err(InterpolateError::Sink)?;
    summary.samples = run.samples + 1;
    summary.duration = run.t0;
    if let (Some(ends), Some(planned)) = (ends, run.ends) {
        *ends = planned;
    }
    Ok(summary)
}
