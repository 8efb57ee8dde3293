//! Trajectory planning: how fast a program's moves run and how they join.
//!
//! * [`Planner::ExactStop`] (`exact-stop`): every block starts and ends at
//!   rest (rest-to-rest trapezoids in a normalised path parameter); the
//!   limits are the **joint** limits (`Axis::max_velocity`,
//!   `Axis::max_acceleration` of each machine axis), also under TCP, where
//!   the path derivatives are estimated by finite differences and multiplied
//!   by [`PlanOptions::derivative_margin`].
//! * [`Planner::Linuxcnc`] (`linuxcnc`): LinuxCNC 2.9's planner rules
//!   ([`linuxcnc`]): limits on the **world** axes (the program's X Y Z A B C
//!   U V W, i.e. the tool tip in W under TCP), look-ahead over
//!   [`PlanOptions::lookahead`] blocks ([`lookahead`]), tangent junctions
//!   without stopping, circular blend arcs or parabolic blends under G64
//!   within the P tolerance, G64 Q merging ([`naive_cam`]), G61/G61.1 stops
//!   at corners/every block, task waits (a stop and a stand-still) at
//!   spindle, TCP, tool, coolant and I/O commands
//!   ([`crate::gcode::TaskWait`]).
//! * [`Planner::Jerk`] (`jerk`): the jerk-limited time law of [`jerk`] along
//!   each chain of moves between stops, sampled densely in joint space
//!   (`crate::gcode::dense_paths`, points at most [`PlanOptions::jerk_step`]
//!   apart); limits on the **joints** (`max_velocity`, `max_acceleration`,
//!   `max_jerk` of every machine axis), also under TCP; G61.1 stops at every
//!   block, G61 at corners, and every chain ends where LinuxCNC's task
//!   waits (spindle, TCP, tool, coolant and I/O commands); under G64 a corner between two moves (lines or
//!   arcs) is blended by a curve within P (a quarter of the step without P)
//!   where that is faster than stopping, other corners (reversals) are
//!   rounded by the joint spline within about a quarter of the step (and
//!   within P when given).
//!
//! Nothing is kept in reserve beyond what [`PlanOptions`] states.

pub mod jerk;
pub mod linuxcnc;
pub mod lookahead;
pub mod naive_cam;
pub mod profile;

use std::fmt;
use std::str::FromStr;

/// Which trajectory planner moves the machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Planner {
    /// Stop at every block end; joint limits (see the module documentation).
    #[default]
    ExactStop,
    /// LinuxCNC 2.9's trajectory planner (see [`linuxcnc`]).
    Linuxcnc,
    /// Jerk-limited, time-optimal within the joint limits (see [`jerk`]).
    Jerk,
}

impl Planner {
    /// The names accepted by [`FromStr`], in order.
    pub const NAMES: &'static [&'static str] = &["exact-stop", "linuxcnc", "jerk"];
}

impl fmt::Display for Planner {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Planner::ExactStop => "exact-stop",
            Planner::Linuxcnc => "linuxcnc",
            Planner::Jerk => "jerk",
        })
    }
}

/// An unknown planner name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown planner `{0}` (expected one of: exact-stop, linuxcnc, jerk)")]
pub struct UnknownPlanner(pub String);

impl FromStr for Planner {
    type Err = UnknownPlanner;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "exact-stop" => Ok(Planner::ExactStop),
            "linuxcnc" => Ok(Planner::Linuxcnc),
            "jerk" => Ok(Planner::Jerk),
            _ => Err(UnknownPlanner(s.to_string())),
        }
    }
}

/// Planner settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct PlanOptions {
    /// The planner ([`Planner::ExactStop`] by default).
    pub planner: Planner,
    /// Feed override, a fraction (1 = as programmed): multiplies the
    /// programmed feed of feed moves (G1/G2/G3, all feed modes), never
    /// rapids, never above the axis limits.
    pub feed_override: f64,
    /// `exact-stop` under TCP: factor on the finite-difference estimates of
    /// the joint path derivatives (16 sub-steps per move), a reserve for
    /// what the sub-steps miss. Default 1.1 (joint peaks at up to 1/1.1 of
    /// their limits); 1 uses the estimates as they are.
    pub derivative_margin: f64,
    /// `linuxcnc`: blocks of look-ahead (LinuxCNC's
    /// `[TRAJ] ARC_BLEND_OPTIMIZATION_DEPTH`, default 50).
    pub lookahead: usize,
    /// `linuxcnc`: trajectory cycle, s (LinuxCNC's servo period, default
    /// 0.001): a block moves at most its length per cycle.
    pub cycle_time: f64,
    /// `linuxcnc`: LinuxCNC's `[TRAJ] ARC_BLEND_KINK_RATIO` (default 0.1).
    pub kink_ratio: f64,
    /// `jerk`: largest distance between the points of the dense joint path
    /// of a chain of moves, in path units (mm; deg for rotary-only moves).
    /// Default 0.1. Under G64 a corner between two moves (lines or arcs)
    /// is blended within P (a quarter of the step without `G64 P`, see
    /// docs/gcode.md) where that is faster than stopping; a reversal is
    /// rounded by the joint spline through these points, by at most about
    /// a quarter of the step; with `G64 P` the step is at most 4·P (never
    /// below 0.001).
    pub jerk_step: f64,
    /// `jerk`: the time-law settings ([`jerk::JerkOptions`]; by default
    /// the full joint limits, nothing held back).
    pub jerk: jerk::JerkOptions,
    /// `linuxcnc`: the highest feed override the blend arcs are sized for
    /// (LinuxCNC's `[DISPLAY] MAX_FEED_OVERRIDE`, default 1; its
    /// simulator configurations use 2). It sets the arcs' size, not their
    /// speed, which stays the programmed feed.
    pub max_feed_override: f64,
    /// `linuxcnc`: seconds the machine stands still where LinuxCNC's task
    /// waits for the motion queue to empty before a spindle start or stop
    /// or a TCP switch (M428/M429) and then queues motion again; default
    /// 0.02 (two cycles of LinuxCNC's 10 ms task, as measured on its
    /// simulator, see docs/linuxcnc.md); 0 for none.
    pub task_wait: f64,
    /// `linuxcnc`: seconds the machine stands still at a command LinuxCNC
    /// 2.9 hands to its separate I/O controller and waits for (M6 tool
    /// change, M7/M8 coolant on, M9 mist and flood off, each;
    /// `TaskWait::through_io`), instead of [`PlanOptions::task_wait`];
    /// default 0.07 (measured on LinuxCNC 2.9's simulator: 43–65 ms
    /// standing at an M7 or M8, 165–168 ms at an M9, which is two commands;
    /// see docs/gcode.md); 0 for none (the machine still stops there).
    pub io_wait: f64,
    /// `linuxcnc`: spindle acceleration, rev/min per s: a spindle start
    /// or speed change waits `|Δ speed| / spindle_accel` (LinuxCNC's feed
    /// moves wait for the spindle to be at speed); infinite (the default)
    /// for no wait. LinuxCNC's simulated spindle: 5000.
    pub spindle_accel: f64,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            planner: Planner::default(),
            feed_override: 1.0,
            derivative_margin: 1.1,
            lookahead: 50,
            cycle_time: 0.001,
            kink_ratio: 0.1,
            jerk_step: 0.1,
            jerk: jerk::JerkOptions::default(),
            max_feed_override: 1.0,
            task_wait: 0.02,
            io_wait: 0.07,
            spindle_accel: f64::INFINITY,
        }
    }
}

impl PlanOptions {
    /// Default settings for `planner`.
    pub fn new(planner: Planner) -> Self {
        PlanOptions {
            planner,
            ..PlanOptions::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for n in Planner::NAMES {
            assert_eq!(n.parse::<Planner>().unwrap().to_string(), *n);
        }
        assert!("jerk-free".parse::<Planner>().is_err());
    }
}
