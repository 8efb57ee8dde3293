//! `mtwin gcode stats` and `mtwin gcode interpolate` results as typed
//! documents ([`GcodeStatsDoc`], [`GcodeInterpolateDoc`]): serialised for
//! `--format json`, displayed for people.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{Axis, InterpolationSummary, ProgramStats, TravelCheck};
use crate::model::Machine;

/// The range of one axis: program (work) coordinates and machine coordinates
/// (work offsets and tool length applied; with a machine, the axis positions
/// of its travel check — under TCP from the inverse kinematics, along the
/// whole move), `[min, max]` in mm or degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisRangeDoc {
    /// Machine coordinates.
    pub machine: [f64; 2],
    /// Work coordinates.
    pub work: [f64; 2],
}

/// A move that takes an axis outside its travel (the farthest value along the
/// move; one per move and axis).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TravelViolationDoc {
    /// Axis name.
    pub axis: String,
    /// 1-based line of the program.
    pub line: u64,
    /// The axis travel `[min, max]` (mm or deg).
    pub travel: [f64; 2],
    /// The position reached (mm or deg).
    pub value: f64,
}

/// `mtwin gcode stats`: counts, path lengths, estimated time (no
/// acceleration), axis ranges and, with a machine, the travel check.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GcodeStatsDoc {
    /// Arc moves (G2/G3).
    pub arc_moves: u64,
    /// Range of every axis shown, by letter.
    pub axes: BTreeMap<String, AxisRangeDoc>,
    /// Blocks read.
    pub blocks: u64,
    /// Dwell time (s).
    pub dwell_time_s: f64,
    /// Length of the feed moves (mm).
    pub feed_length_mm: f64,
    /// Time of the feed moves (s).
    pub feed_time_s: f64,
    /// Linear feed moves (G1).
    pub linear_moves: u64,
    /// Blocks with motion.
    pub motion_blocks: u64,
    /// The program read, as named on the command line.
    pub program: String,
    /// Length of the rapid moves (mm).
    pub rapid_length_mm: f64,
    /// Rapid moves (G0).
    pub rapid_moves: u64,
    /// Time of the rapid moves (s).
    pub rapid_time_s: f64,
    /// Estimated total time (s).
    pub total_time_s: f64,
    /// Moves outside the travels, counted per move and axis (with a machine).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_violations: Option<u64>,
    /// Lines whose tool tip the machine cannot reach (with a machine).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unreachable_lines: Option<Vec<u64>>,
    /// The violations recorded (with a machine).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub violations: Option<Vec<TravelViolationDoc>>,
}

impl GcodeStatsDoc {
    /// The document of `stats` of `program`. The axes shown are the
    /// machine's when one is given, else X Y Z and every other axis that moved;
    /// `check` is the travel check run with the statistics, if any.
    pub fn new(
        program: &str,
        stats: &ProgramStats,
        machine: Option<&Machine>,
        check: Option<&TravelCheck>,
    ) -> Self {
        let axes = Axis::ALL
            .iter()
            .filter(|&&ax| match machine {
                Some(m) => m.axis_index(&char::from(ax.letter()).to_string()).is_some(),
                None => {
                    ax.index() < 3 || stats.work_range[ax.index()].is_some_and(|r| r.max > r.min)
                }
            })
            .filter_map(|&ax| {
                stats.work_range[ax.index()].map(|r| {
                    // With a travel check, the positions it tested (from the
                    // inverse kinematics under TCP).
                    let checked = machine.zip(check).and_then(|(m, c)| {
                        let i = m.axis_index(&char::from(ax.letter()).to_string())?;
                        c.ranges.get(i).copied().flatten()
                    });
                    let mr = checked.or(stats.machine_range[ax.index()]).unwrap_or(r);
                    (
                        char::from(ax.letter()).to_string(),
                        AxisRangeDoc {
                            machine: [mr.min, mr.max],
                            work: [r.min, r.max],
                        },
                    )
                })
            })
            .collect();
        GcodeStatsDoc {
            arc_moves: stats.arc_moves,
            axes,
            blocks: stats.blocks,
            dwell_time_s: stats.dwell_time,
            feed_length_mm: stats.feed_length,
            feed_time_s: stats.feed_time,
            linear_moves: stats.linear_moves,
            motion_blocks: stats.motion_blocks,
            program: program.to_string(),
            rapid_length_mm: stats.rapid_length,
            rapid_moves: stats.rapid_moves,
            rapid_time_s: stats.rapid_time,
            total_time_s: stats.total_time(),
            travel_violations: check.map(|c| c.count),
            unreachable_lines: check.map(|c| c.unreachable.clone()),
            violations: check.map(|c| {
                c.violations
                    .iter()
                    .map(|v| TravelViolationDoc {
                        axis: v.axis.clone(),
                        line: v.line,
                        travel: v.travel,
                        value: v.value,
                    })
                    .collect()
            }),
        }
    }
}

/// The program, counts, lengths and times, one line per axis range (in
/// canonical axis order), then the travel check (its first ten violations and
/// unreachable lines as `file:line`).
impl std::fmt::Display for GcodeStatsDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{}", self.program)?;
        writeln!(
            f,
            "blocks {} ({} with motion): {} rapid, {} linear, {} arc moves",
            self.blocks, self.motion_blocks, self.rapid_moves, self.linear_moves, self.arc_moves
        )?;
        writeln!(
            f,
            "path: feed {:.3} mm, rapid {:.3} mm; estimated time {:.3} s (feed {:.3}, rapid {:.3}, dwell {:.3}; no acceleration)",
            self.feed_length_mm,
            self.rapid_length_mm,
            self.total_time_s,
            self.feed_time_s,
            self.rapid_time_s,
            self.dwell_time_s
        )?;
        for ax in Axis::ALL {
            let n = char::from(ax.letter()).to_string();
            if let Some(r) = self.axes.get(&n) {
                writeln!(
                    f,
                    "  {n}: work [{}, {}], machine [{}, {}]",
                    r.work[0], r.work[1], r.machine[0], r.machine[1]
                )?;
            }
        }
        if let Some(count) = self.travel_violations {
            let violations = self.violations.as_deref().unwrap_or_default();
            let unreachable = self.unreachable_lines.as_deref().unwrap_or_default();
            if count == 0 && unreachable.is_empty() {
                writeln!(f, "travel: every move is within the machine travels")?;
            } else {
                for v in violations.iter().take(10) {
                    writeln!(
                        f,
                        "{}:{}: axis {} at {} outside its travel [{}, {}]",
                        self.program, v.line, v.axis, v.value, v.travel[0], v.travel[1]
                    )?;
                }
                writeln!(f, "travel: {count} violation(s)")?;
                for l in unreachable.iter().take(10) {
                    writeln!(f, "{}:{l}: tool tip not reachable", self.program)?;
                }
            }
        }
        Ok(())
    }
}

/// `mtwin gcode interpolate`: the axis commands written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GcodeInterpolateDoc {
    /// Dwell time (s).
    pub dwell_s: f64,
    /// Duration of the motion (s).
    pub duration_s: f64,
    /// Moves interpolated.
    pub moves: u64,
    /// The CMD.csv written.
    pub out: String,
    /// Samples written.
    pub samples: u64,
    /// Axis-space transitions inserted (TCP switched on away from the axes).
    pub transitions: u64,
    /// Sample period (s).
    pub ts: f64,
}

impl GcodeInterpolateDoc {
    /// The document of interpolation `s` at sample period `ts` (s), written to `out`.
    pub fn new(s: &InterpolationSummary, ts: f64, out: &str) -> Self {
        GcodeInterpolateDoc {
            dwell_s: s.dwell_time,
            duration_s: s.duration,
            moves: s.moves,
            out: out.to_string(),
            samples: s.samples,
            transitions: s.transitions,
            ts,
        }
    }
}

/// One line: samples, period, moves and duration. Transitions are a warning on stderr.
impl std::fmt::Display for GcodeInterpolateDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} samples at {} s ({} moves, {:.3} s) → {}",
            self.samples, self.ts, self.moves, self.duration_s, self.out
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::{InterpolateOptions, StatsOptions, interpolate, stats, stats_with};

    /// A 10 mm square at F600 after a rapid of 5 mm, then a 1.5 s dwell.
    const SQUARE: &str = "G21 G90 G94\nG0 X0 Y5\nG0 Y0\nG1 X10 F600\nY10\nX0\nY0\nG4 P1.5\nM2\n";

    #[test]
    fn the_stats_document_holds_the_square_and_round_trips() {
        let st = stats(SQUARE.as_bytes(), &StatsOptions::default()).unwrap();
        let d = GcodeStatsDoc::new("square.nc", &st, None, None);
        // Closed form: 40 mm at 600 mm/min is 4 s; the dwell 1.5 s.
        assert!((d.feed_length_mm - 40.0).abs() < 1e-12);
        assert!((d.feed_time_s - 4.0).abs() < 1e-12);
        assert_eq!(d.dwell_time_s, 1.5);
        assert_eq!((d.rapid_moves, d.linear_moves, d.arc_moves), (2, 4, 0));
        assert_eq!(d.axes.keys().collect::<Vec<_>>(), ["X", "Y", "Z"]);
        assert_eq!(d.axes["X"].work, [0.0, 10.0]);
        assert_eq!(d.axes["Y"].work, [0.0, 10.0]);
        assert!(d.travel_violations.is_none());
        let v = serde_json::to_value(&d).unwrap();
        assert!(v.get("violations").is_none() && v.get("travel_violations").is_none());
        let back: GcodeStatsDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        let text = d.to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "square.nc");
        assert_eq!(
            lines[1],
            "blocks 9 (6 with motion): 2 rapid, 4 linear, 0 arc moves"
        );
        // Canonical order X, Y, Z; Z never moved from 0.
        assert_eq!(lines[3], "  X: work [0, 10], machine [0, 10]");
        assert_eq!(lines[5], "  Z: work [0, 0], machine [0, 0]");
        assert_eq!(lines.len(), 6);
    }

    #[test]
    fn the_stats_document_lists_travel_violations_by_line() {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/machines/ac-trunnion.toml");
        let m = crate::model::read_machine(&p).unwrap();
        let x = m.axis_index("X").unwrap();
        let hi = m.axes[x].travel[1];
        let program = format!("G0 X0 Y0\nG1 X{} F600\nM2\n", hi + 1.0);
        let mut check = TravelCheck::new(&m);
        let st = stats_with(program.as_bytes(), &StatsOptions::default(), &mut check).unwrap();
        let d = GcodeStatsDoc::new("p.nc", &st, Some(&m), Some(&check));
        assert_eq!(d.travel_violations, Some(1));
        let v = &d.violations.as_ref().unwrap()[0];
        assert_eq!((v.line, v.axis.as_str(), v.value), (2, "X", hi + 1.0));
        // The machine's axes, and those only.
        assert_eq!(d.axes.len(), m.axes.len());
        let text = d.to_string();
        assert!(
            text.contains(&format!(
                "\np.nc:2: axis X at {} outside its travel [{}, {}]\ntravel: 1 violation(s)\n",
                hi + 1.0,
                m.axes[x].travel[0],
                hi
            )),
            "{text}"
        );
        let back: GcodeStatsDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
    }

    #[test]
    fn the_interpolate_document_counts_the_samples_of_a_timed_line() {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/machines/ac-trunnion.toml");
        let m = crate::model::read_machine(&p).unwrap();
        // 10 mm at 600 mm/min is 1 s without acceleration limits; limits only add.
        let program = "G0 X0 Y0 Z0\nG1 X10 F600\nM2\n";
        let ts = 0.01;
        let s = interpolate(program.as_bytes(), &m, &InterpolateOptions::new(ts), |_| {
            Ok(())
        })
        .unwrap();
        let d = GcodeInterpolateDoc::new(&s, ts, "cmd.csv");
        assert!(d.duration_s >= 1.0, "{}", d.duration_s);
        assert_eq!(d.moves, s.moves);
        assert_eq!(
            d.to_string(),
            format!(
                "{} samples at 0.01 s ({} moves, {:.3} s) → cmd.csv\n",
                d.samples, d.moves, d.duration_s
            )
        );
        let back: GcodeInterpolateDoc =
            serde_json::from_str(&serde_json::to_string_pretty(&d).unwrap()).unwrap();
        assert_eq!(back, d);
    }
}
