//! The thermal measurement programme as G-code (the procedure of the
//! source paper \[R4\]): a cold reference pass of the spindle probe over the
//! ball array, then the spindle speed programme, interrupted every sample
//! period by a probing pass over the balls.
//!
//! **Ball array.** Ball `i` (centre in work coordinates, mm) is at
//! `(x0 + i·pitch, y, z_i)`, one ball per requested height: a stepped
//! array whose balls are all reachable from above. Each ball is probed on
//! its top, in −Z: rapid to `z_i + r + approach`, probing move to
//! `z_i + r − overtravel` at the probing feed (`G38.2` for LinuxCNC, `G31`
//! skip for Fanuc), rapid back to the safe height
//! `max_i(z_i + r) + clearance`. The drift at height `z_i` is the cold
//! pass's touched Z minus the touched Z of the pass (reference minus new
//! reading): when the tool moves by `e` in +Z relative to the work, the
//! probe touches the ball top `b` at the indicated `b − e`, so the touched
//! Z falls by `e`, and `cold − touched = e` is the drift of the model
//! (the one `thermal compensate` removes by writing `Z − e`). LinuxCNC
//! writes `#5063` of every touch to `thermal-probe.csv` with `(LOG,…)`; on
//! Fanuc read `#5063` after each `G31` as your control's macro practice
//! prescribes — the program holds no macro statements. A training file may
//! give the touched shift itself (`probe_shift_mm` = touched − cold) in
//! place of `drift_mm`; the fit then takes `drift = −probe_shift`.
//!
//! **Timing.** Pass `k` starts at exactly `t_k = k·T` after the end of the
//! initial positioning (the time estimate of the program: rapids at the
//! given rapid rate, probing moves timed to their end point at the
//! probing feed, dwells): between passes the spindle runs the programme
//! for `T − p` (`p` the pass duration, which must be shorter than `T`) as
//! dwells, split where the speed changes. The spindle is stopped (`M5`,
//! oriented `M19`) during a pass, as with a probe in the spindle; the speed
//! history is therefore zero during the passes. The programme's speed `j`
//! holds over `[j·step, (j+1)·step)` minutes; the last pass is at the last
//! multiple of `T` within the programme's duration.
//!
//! **Timing on a machine** ([`thermal_program_on`]): the trajectory planner
//! of a [`PlannedTiming`] times the written program on the machine
//! (accelerations, stops and the planner's waits at M3/M5/M19 included,
//! rapids at the machine's `rapid_feed`); the dwell that follows each pass
//! is shortened by what the pass and the spindle commands took beyond the
//! estimate, so that pass `k` still starts at `k·T` by the planner's clock.

use thiserror::Error;

use crate::gcode::{Dialect, ProgramEnd, ProgramWriter, WriteError};

use super::compensate::PlannedTiming;

/// The ball array (mm, work coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct BallArray {
    /// X of the first ball.
    pub x0: f64,
    /// X spacing between consecutive balls.
    pub pitch: f64,
    /// Y of every ball.
    pub y: f64,
    /// Z of every ball centre, one ball per height.
    pub heights: Vec<f64>,
    /// Ball diameter.
    pub diameter: f64,
}

impl BallArray {
    /// Centre of ball `i`.
    pub fn centre(&self, i: usize) -> [f64; 3] {
        [self.x0 + i as f64 * self.pitch, self.y, self.heights[i]]
    }

    /// Z of the top of ball `i`.
    pub fn top(&self, i: usize) -> f64 {
        self.heights[i] + 0.5 * self.diameter
    }
}

/// Probing motion (mm, mm/min).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct ProbeMotion {
    /// Start of the probing move above the ball top.
    pub approach: f64,
    /// End of the probing move below the ball top (if nothing is touched).
    pub overtravel: f64,
    /// Safe height above the highest ball top.
    pub clearance: f64,
    /// Probing feed, mm/min.
    pub feed: f64,
    /// Rapid rate assumed for the timing, mm/min (the `--rapid` of `gcode stats`).
    pub rapid_feed: f64,
}

impl Default for ProbeMotion {
    fn default() -> Self {
        ProbeMotion {
            approach: 2.0,
            overtravel: 1.0,
            clearance: 10.0,
            feed: 100.0,
            rapid_feed: crate::model::DEFAULT_RAPID_FEED,
        }
    }
}

/// What was written.
#[derive(Debug, Clone, PartialEq)]
pub struct ThermalProgram {
    /// The program text.
    pub text: String,
    /// Probing passes (the cold one included).
    pub passes: usize,
    /// Duration of one pass, s.
    pub pass_s: f64,
    /// Programme duration (speeds × step), min.
    pub duration_min: f64,
    /// Time of the program from the start of the cold pass to its end, s.
    pub time_s: f64,
    /// Each pass's first (its comment) and last line, 1-based.
    pass_lines: Vec<(usize, usize)>,
}

/// Why the program could not be written.
#[derive(Debug, Error, PartialEq)]
#[non_exhaustive]
pub enum ThermalProgramError {
    /// A setting out of range.
    #[error("{0}")]
    Setting(String),
    /// A probing pass does not fit in a sample period.
    #[error(
        "one probing pass takes {} s, not shorter than the sample period {} s: \
         fewer balls, a faster probing feed or a longer period",
        crate::limits::fmt_message_fixed(*.pass_s, 1),
        crate::limits::fmt_message_fixed(*.period_s, 1)
    )]
    PassTooLong {
        /// Pass duration, s.
        pass_s: f64,
        /// Period, s.
        period_s: f64,
    },
    /// A value the G-code writer cannot write.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// The planner could not time the program on the machine (its message).
    #[error("the planner cannot time the program on the machine: {0}")]
    Planner(String),
}

/// Duration of one probing pass (s): rapid path at `motion.rapid_feed`, probing
/// moves at `motion.feed`, from and back to `(x0, y, safe height)`.
pub fn pass_seconds(balls: &BallArray, motion: &ProbeMotion) -> f64 {
    let safe = safe_height(balls, motion);
    let mut rapid = 0.0;
    let mut at = balls.x0;
    for i in 0..balls.heights.len() {
        let [x, _, _] = balls.centre(i);
        rapid += (x - at).abs() + 2.0 * (safe - (balls.top(i) + motion.approach));
        rapid += motion.approach + motion.overtravel; // back up from the probing end
        at = x;
    }
    rapid += (at - balls.x0).abs();
    let probing = balls.heights.len() as f64 * (motion.approach + motion.overtravel);
    60.0 * (rapid / motion.rapid_feed + probing / motion.feed)
}

fn safe_height(balls: &BallArray, motion: &ProbeMotion) -> f64 {
    (0..balls.heights.len())
        .map(|i| balls.top(i))
        .fold(f64::NEG_INFINITY, f64::max)
        + motion.clearance
}

/// Write the measurement programme: `speeds` (rev/min, 0 = spindle off)
/// each held `step_min` minutes, sampled every `period_min` minutes.
pub fn thermal_program(
    balls: &BallArray,
    motion: &ProbeMotion,
    speeds: &[f64],
    step_min: f64,
    period_min: f64,
    dialect: Dialect,
) -> Result<ThermalProgram, ThermalProgramError> {
    let pass_s = pass_seconds(balls, motion);
    write_program(
        balls,
        motion,
        speeds,
        step_min,
        period_min,
        dialect,
        pass_s,
        &[],
    )
}

/// [`thermal_program`] timed by the planner of `timing` on its machine (see
/// the module documentation): every pass starts at `k·T` by the planner's
/// clock (to the 1 ms the dwells are written to); `pass_s` is the longest
/// pass and `time_s` the planner's time from the start of the cold pass to
/// the end. `motion.rapid_feed` is replaced by the machine's.
pub fn thermal_program_on(
    balls: &BallArray,
    motion: &ProbeMotion,
    speeds: &[f64],
    step_min: f64,
    period_min: f64,
    dialect: Dialect,
    timing: &PlannedTiming,
) -> Result<ThermalProgram, ThermalProgramError> {
    let motion = ProbeMotion {
        rapid_feed: timing.machine.rapid_feed,
        ..*motion
    };
    let estimate = pass_seconds(balls, &motion);
    let first = write_program(
        balls,
        &motion,
        speeds,
        step_min,
        period_min,
        dialect,
        estimate,
        &[],
    )?;
    let period_s = period_min * 60.0;
    let t = pass_times(&first.text, &first.pass_lines, dialect, timing)?;
    let longest = t.passes.iter().map(|p| p.1 - p.0).fold(0.0, f64::max);
    if longest >= period_s {
        return Err(ThermalProgramError::PassTooLong {
            pass_s: longest,
            period_s,
        });
    }
    // Deviation of each pass start from k·T; the dwells after pass k lose
    // the growth of the deviation up to pass k + 1.
    let dev: Vec<f64> = t
        .passes
        .iter()
        .enumerate()
        .map(|(k, p)| p.0 - t.passes[0].0 - k as f64 * period_s)
        .collect();
    let fix: Vec<f64> = dev.windows(2).map(|w| w[1] - w[0]).collect();
    let mut p = write_program(
        balls, &motion, speeds, step_min, period_min, dialect, estimate, &fix,
    )?;
    let t = pass_times(&p.text, &p.pass_lines, dialect, timing)?;
    p.pass_s = t.passes.iter().map(|p| p.1 - p.0).fold(0.0, f64::max);
    p.time_s = t.duration - t.passes[0].0;
    Ok(p)
}

/// The planner's start and end time (s) of every pass of a written
/// programme, and its duration.
struct PassTimes {
    passes: Vec<(f64, f64)>,
    duration: f64,
}

fn pass_times(
    text: &str,
    pass_lines: &[(usize, usize)],
    dialect: Dialect,
    timing: &PlannedTiming,
) -> Result<PassTimes, ThermalProgramError> {
    let mut o = crate::gcode::InterpolateOptions::new(1.0);
    o.interp.dialect = dialect;
    o.plan = timing.plan;
    let times = crate::gcode::line_end_times(text.as_bytes(), &timing.machine, &o)
        .map_err(|e| ThermalProgramError::Planner(e.to_string()))?;
    let by_line = times.by_line();
    // The end of the motion up to each line (1-based), carried over lines
    // without motion.
    let lines: Vec<&str> = text.lines().collect();
    let mut upto = vec![0.0_f64; lines.len() + 1];
    for n in 1..=lines.len() {
        upto[n] = upto[n - 1].max(by_line.get(&(n as u64)).copied().unwrap_or(0.0));
    }
    // A pass runs from the end of the motion before its comment line to
    // the end of its last line (the rapid back to the first ball's X).
    let passes = pass_lines
        .iter()
        .map(|&(first, last)| (upto[first - 1], upto[last]))
        .collect();
    Ok(PassTimes {
        passes,
        duration: times.duration,
    })
}

/// Writes the programme with passes `pass_s` long by the program clock;
/// after pass `k` the clock advances by `fix[k]` more (s), shortening the
/// dwells that follow.
#[allow(clippy::too_many_arguments)]
fn write_program(
    balls: &BallArray,
    motion: &ProbeMotion,
    speeds: &[f64],
    step_min: f64,
    period_min: f64,
    dialect: Dialect,
    pass_s: f64,
    fix: &[f64],
) -> Result<ThermalProgram, ThermalProgramError> {
    let bad = |m: String| Err(ThermalProgramError::Setting(m));
    let pos = |v: f64| v.is_finite() && v > 0.0;
    if balls.heights.is_empty() || balls.heights.iter().any(|z| !z.is_finite()) {
        return bad("at least one finite ball height is needed".into());
    }
    if !(pos(balls.diameter)
        && balls.x0.is_finite()
        && balls.y.is_finite()
        && balls.pitch.is_finite())
    {
        return bad("the ball array needs a positive diameter and finite positions".into());
    }
    for (name, v) in [
        ("approach", motion.approach),
        ("overtravel", motion.overtravel),
        ("clearance", motion.clearance),
        ("probing feed", motion.feed),
        ("rapid rate", motion.rapid_feed),
        ("step duration", step_min),
        ("sample period", period_min),
    ] {
        if !pos(v) {
            return bad(format!("the {name} must be positive, not {v}"));
        }
    }
    if speeds.is_empty() || speeds.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
        return bad("the speed programme needs speeds >= 0 rev/min".into());
    }
    let period_s = period_min * 60.0;
    if pass_s >= period_s {
        return Err(ThermalProgramError::PassTooLong { pass_s, period_s });
    }
    let duration_min = step_min * speeds.len() as f64;
    let passes_f = (duration_min / period_min + 1e-9).floor() + 1.0;
    crate::limits::check(
        "the number of probing passes (step duration × speeds / sample period)",
        passes_f,
        crate::limits::MAX_PROGRAM_POINTS / 100,
        "each pass is a block of probing moves in the program; shorten the steps or lengthen the period",
    )
    .map_err(|e| ThermalProgramError::Setting(e.to_string()))?;
    let passes = passes_f as usize;
    let safe = safe_height(balls, motion);
    let fanuc = matches!(dialect, Dialect::Fanuc { .. });
    let mut w = ProgramWriter::new(dialect);
    let list = |w: &ProgramWriter, values: &[f64]| -> Result<String, WriteError> {
        Ok(values
            .iter()
            .map(|v| w.plain(*v))
            .collect::<Result<Vec<_>, _>>()?
            .join(" "))
    };
    // No Fanuc program number (O…): give it one when loading the program.
    w.start(None)?;
    w.comment("mtwin thermal program: thermal drift measurement, see docs/thermal.md")?;
    w.comment(&format!(
        "{} balls at z = {} mm, diameter {} mm; sample every {} min; {} passes",
        balls.heights.len(),
        list(&w, &balls.heights)?,
        w.plain(balls.diameter)?,
        w.plain(period_min)?,
        passes
    ))?;
    w.comment(&format!(
        "speeds {} rev/min, {} min each; spindle stopped during the passes",
        list(&w, speeds)?,
        w.plain(step_min)?
    ))?;
    w.block().g(21).g(90).g(94).g(17).write()?;
    w.block().m(5).write()?;
    if !fanuc {
        w.statement("(LOGOPEN,thermal-probe.csv)")?;
        w.statement("(LOG,pass,ball,z_ball_mm,z_touch_mm)")?;
    }
    w.rapid(&[('Z', safe)])?;
    w.rapid(&[('X', balls.x0), ('Y', balls.y)])?;
    // Dwells are written to 1 ms; `clock` is the program time written so
    // far (as the control reads the dwells), so the rounding never
    // accumulates over the passes.
    let mut clock = 0.0;
    let dwell = |w: &mut ProgramWriter, clock: &mut f64, until: f64| -> Result<(), WriteError> {
        let v = ((until - *clock) * 1e3).round() / 1e3;
        if v > 0.0 {
            *clock += w.dwell(v)?;
        }
        Ok(())
    };
    let mut running: Option<f64> = None;
    let mut pass_lines = Vec::with_capacity(passes);
    let lines_written = |w: &ProgramWriter| w.text().matches('\n').count();
    for k in 0..passes {
        let first = lines_written(&w) + 1;
        w.comment(&format!(
            "pass {k} at t = {} min",
            w.plain(k as f64 * period_min)?
        ))?;
        if running.take().is_some_and(|v| v > 0.0) {
            w.block().m(5).write()?;
        }
        w.block().m(19).write()?;
        for i in 0..balls.heights.len() {
            let [x, _, z] = balls.centre(i);
            let top = balls.top(i);
            w.rapid(&[('X', x)])?;
            w.rapid(&[('Z', top + motion.approach)])?;
            w.probe(&[('Z', top - motion.overtravel)], motion.feed)?;
            if !fanuc {
                w.statement(&format!("(LOG,{k},{i},{},#5063)", w.plain(z)?))?;
            }
            w.rapid(&[('Z', safe)])?;
        }
        w.rapid(&[('X', balls.x0)])?;
        pass_lines.push((first, lines_written(&w)));
        clock += pass_s + fix.get(k).copied().unwrap_or(0.0);
        if k + 1 == passes {
            break;
        }
        // Spindle programme from the end of this pass to the next one.
        let (mut a, b) = (k as f64 * period_s + pass_s, (k + 1) as f64 * period_s);
        while a < b - 1e-9 {
            let j = ((a / 60.0 / step_min) + 1e-12).floor() as usize;
            let speed = speeds.get(j).copied().unwrap_or(0.0);
            let end = (((j + 1) as f64) * step_min * 60.0).min(b);
            if running != Some(speed) {
                if speed > 0.0 {
                    w.block().spindle_speed(speed).m(3).write()?;
                } else if running.is_some_and(|v| v > 0.0) {
                    w.block().m(5).write()?;
                }
                running = Some(speed);
            }
            dwell(&mut w, &mut clock, end)?;
            a = end;
        }
    }
    if !fanuc {
        w.statement("(LOGCLOSE)")?;
    }
    w.end(ProgramEnd::M30)?;
    let s = w.finish();
    Ok(ThermalProgram {
        text: s,
        passes,
        pass_s,
        duration_min,
        time_s: (passes - 1) as f64 * period_s + pass_s,
        pass_lines,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::{InterpOptions, StatsOptions, stats};

    fn balls() -> BallArray {
        BallArray {
            x0: -100.0,
            pitch: 50.0,
            y: 20.0,
            heights: vec![-50.0, -150.0, -250.0, -350.0],
            diameter: 25.4,
        }
    }

    fn time_of(text: &str, dialect: Dialect) -> f64 {
        let o = StatsOptions {
            interp: InterpOptions {
                dialect,
                ..InterpOptions::default()
            },
            ..StatsOptions::default()
        };
        stats(text.as_bytes(), &o).unwrap().total_time()
    }

    const FANUC: Dialect = Dialect::Fanuc {
        decimal_point_programming: false,
    };

    #[test]
    fn passes_start_every_period_and_the_programme_lasts_its_duration() {
        let b = balls();
        let m = ProbeMotion::default();
        // Steps of 25 min are not a multiple of the 10 min period.
        let speeds = [2000.0, 0.0, 6000.0, 4000.0];
        // Every number is written with a decimal point for Fanuc, so the
        // program reads the same with and without decimal point programming.
        let calculator = Dialect::Fanuc {
            decimal_point_programming: true,
        };
        for dialect in [Dialect::LinuxCnc, FANUC, calculator] {
            let p = thermal_program(&b, &m, &speeds, 25.0, 10.0, dialect).unwrap();
            // 100 min of programme: passes at 0, 10, …, 100 min.
            assert_eq!(p.passes, 11);
            // One pass, by hand: rapids between balls (3 × 50 mm there, 150
            // back), down and up to each ball, probing 3 mm per ball.
            let safe = -50.0 + 12.7 + 10.0;
            let mut rapid = 300.0;
            for z in [-50.0, -150.0, -250.0, -350.0] {
                let top: f64 = z + 12.7;
                rapid += (safe - (top + 2.0)) + (safe - (top - 1.0));
            }
            let want_pass = 60.0 * (rapid / 10_000.0 + 4.0 * 3.0 / 100.0);
            assert!(
                (p.pass_s - want_pass).abs() < 1e-9,
                "{} vs {want_pass}",
                p.pass_s
            );
            // The engine's time estimate up to the start of every pass.
            let lines: Vec<&str> = p.text.lines().collect();
            let starts: Vec<usize> = lines
                .iter()
                .enumerate()
                .filter(|(_, l)| l.to_uppercase().starts_with("(PASS "))
                .map(|(i, _)| i)
                .collect();
            assert_eq!(starts.len(), 11);
            let t0 = time_of(&lines[..starts[0]].join("\n"), dialect);
            for (k, &at) in starts.iter().enumerate() {
                let t = time_of(&lines[..at].join("\n"), dialect) - t0;
                assert!((t - k as f64 * 600.0).abs() < 6e-4, "pass {k} at {t} s");
            }
            let total = time_of(&p.text, dialect) - t0;
            assert!((total - (1000.0 * 6.0 + want_pass)).abs() < 1e-3, "{total}");
            assert!((p.time_s - total).abs() < 1e-3);
            // Probing moves: 4 per pass, to the ball tops minus the overtravel.
            let probe = if dialect != Dialect::LinuxCnc {
                "G31 Z"
            } else {
                "G38.2 Z"
            };
            let targets: Vec<f64> = lines
                .iter()
                .filter_map(|l| l.strip_prefix(probe))
                .map(|r| r.split_whitespace().next().unwrap().parse().unwrap())
                .collect();
            assert_eq!(targets.len(), 44);
            for (j, t) in targets.iter().enumerate() {
                let want = b.heights[j % 4] + 12.7 - 1.0;
                assert!((t - want).abs() < 1e-9);
            }
            // Speeds in order: 2000 (0–25), off (25–50), 6000, 4000.
            // The spindle restarts after every pass (it stops for probing):
            // 2000 after the passes at 0, 10, 20; off after 30, 40; 6000
            // after 50, 60, 70; 4000 at 75 (inside the 70–80 interval) and
            // after 80, 90.
            let mut s_words: Vec<&str> = lines
                .iter()
                .filter(|l| l.starts_with('S'))
                .copied()
                .collect();
            assert_eq!(s_words.len(), 3 + 3 + 3);
            s_words.dedup();
            assert_eq!(s_words, vec!["S2000 M3", "S6000 M3", "S4000 M3"]);
        }
    }

    /// Pass starts (s) of a written programme by the planner of `timing`:
    /// the end of the motion before each `(pass` comment line.
    fn planned_pass_starts(text: &str, timing: &PlannedTiming) -> Vec<f64> {
        let mut o = crate::gcode::InterpolateOptions::new(1.0);
        o.plan = timing.plan;
        let t = crate::gcode::line_end_times(text.as_bytes(), &timing.machine, &o).unwrap();
        let by_line = t.by_line();
        let mut upto = 0.0_f64;
        let mut starts = Vec::new();
        for (i, l) in text.lines().enumerate() {
            if l.to_uppercase().starts_with("(PASS ") {
                starts.push(upto);
            }
            upto = upto.max(by_line.get(&(i as u64 + 1)).copied().unwrap_or(0.0));
        }
        starts
    }

    #[test]
    fn on_a_machine_passes_start_every_period_by_the_planners_clock() {
        use crate::gcode::plan::{PlanOptions, Planner};
        let mut machine = crate::examples::xyz(1e4);
        for a in &mut machine.axes {
            a.max_velocity = Some(50.0);
            a.max_acceleration = Some(100.0);
            a.max_jerk = Some(2000.0);
        }
        let speeds = [2000.0, 0.0, 6000.0, 4000.0];
        for planner in [Planner::ExactStop, Planner::Linuxcnc, Planner::Jerk] {
            let timing = PlannedTiming {
                machine: machine.clone(),
                plan: PlanOptions::new(planner),
            };
            let m = ProbeMotion::default();
            let p = thermal_program_on(
                &balls(),
                &m,
                &speeds,
                25.0,
                10.0,
                Dialect::LinuxCnc,
                &timing,
            )
            .unwrap();
            let starts = planned_pass_starts(&p.text, &timing);
            assert_eq!(starts.len(), 11);
            for (k, t) in starts.iter().enumerate() {
                let d = t - starts[0] - 600.0 * k as f64;
                assert!(d.abs() < 1.5e-3, "{planner}: pass {k} off by {d} s");
            }
            // The accelerations make a pass longer than the estimate at the
            // machine's rapid rate, and the estimate's programme drifts.
            let at_rapid = ProbeMotion {
                rapid_feed: machine.rapid_feed,
                ..m
            };
            assert!(p.pass_s > pass_seconds(&balls(), &at_rapid), "{planner}");
            let plain =
                thermal_program(&balls(), &at_rapid, &speeds, 25.0, 10.0, Dialect::LinuxCnc)
                    .unwrap();
            let s = planned_pass_starts(&plain.text, &timing);
            let drift = s[10] - s[0] - 6000.0;
            assert!(
                drift > 0.1,
                "{planner}: the estimate's last pass only {drift} s late"
            );
            eprintln!(
                "{planner}: pass {:.3} s (estimate {:.3} s); without the planner the last pass is {drift:.3} s late",
                p.pass_s,
                pass_seconds(&balls(), &at_rapid)
            );
        }
    }

    #[test]
    fn bad_settings_are_refused() {
        let b = balls();
        let m = ProbeMotion::default();
        let slow = ProbeMotion { feed: 1.0, ..m };
        assert!(matches!(
            thermal_program(&b, &slow, &[1000.0], 60.0, 1.0, Dialect::LinuxCnc),
            Err(ThermalProgramError::PassTooLong { .. })
        ));
        assert!(thermal_program(&b, &m, &[], 60.0, 10.0, Dialect::LinuxCnc).is_err());
        assert!(thermal_program(&b, &m, &[-1.0], 60.0, 10.0, Dialect::LinuxCnc).is_err());
        assert!(thermal_program(&b, &m, &[1000.0], 60.0, 0.0, Dialect::LinuxCnc).is_err());
        let none = BallArray {
            heights: vec![],
            ..b
        };
        assert!(thermal_program(&none, &m, &[1000.0], 60.0, 10.0, Dialect::LinuxCnc).is_err());
    }
}
