//! The motion rules shared by [`stats`](super::stats) and
//! [`interpolate`](super::interpolate): which path a feed applies to, the
//! programmed duration of a move, the duration of a rapid at the rapid
//! rates, and the straight interpolation between two positions.
//!
//! The rules are LinuxCNC's (RS-274/NGC, see `docs/references.md`):
//!
//! * A per-minute feed (G94) or a per-revolution feed (G95, mm/rev × rev/min)
//!   applies to the XYZ path; when X, Y and Z do not move, to the UVW path;
//!   when those do not move either, to the rotary axes (deg/min).
//! * An inverse-time feed (G93) `F` means the move lasts `1/F` min,
//!   whatever its length.
//! * A zero, negative or non-finite feed on a feed move is an error (LinuxCNC
//!   refuses "G1 with zero feed rate"), never an infinite time; so is a G95
//!   move with the spindle stopped.

use super::axes::{Axes, Axis};
use super::event::Feed;

/// Movement of an axis group below which it counts as not moving, mm or
/// degree.
const STILL: f64 = 1e-9;

/// A move that cannot be timed: its message, without the line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct TimingError(pub String);

/// The path a feed applies to, mm (degree when only rotary axes move): the
/// XYZ length `xyz` of the move (the arc length for an arc), else the UVW
/// length of the displacement `d`, else its ABC length.
pub fn feed_path(xyz: f64, d: &Axes) -> f64 {
    if xyz > STILL {
        xyz
    } else if d.uvw_norm() > STILL {
        d.uvw_norm()
    } else {
        d.abc_norm()
    }
}

/// Programmed duration of a move, s: `feed` applied to [`feed_path`]
/// (`Feed::Rapid` at `rapid_feed`, mm/min), or `60/F` s for an inverse-time
/// feed `F` (1/min).
pub fn move_seconds(feed: Feed, xyz: f64, d: &Axes, rapid_feed: f64) -> Result<f64, TimingError> {
    let path = feed_path(xyz, d);
    let per_minute = |f: f64, what: &str| -> Result<f64, TimingError> {
        if f > 0.0 && f.is_finite() {
            Ok(60.0 * path / f)
        } else {
            Err(TimingError(format!("cannot move at {what} of {f} mm/min")))
        }
    };
    match feed {
        Feed::Rapid => per_minute(rapid_feed, "a rapid feed"),
        Feed::PerMinute(f) => per_minute(f, "a feed"),
        Feed::InverseTime(f) if f > 0.0 && f.is_finite() => Ok(60.0 / f),
        Feed::InverseTime(f) => Err(TimingError(format!(
            "cannot move at an inverse-time feed of {f} 1/min"
        ))),
        Feed::PerRevolution { rpm, .. } if !(rpm > 0.0 && rpm.is_finite()) => {
            Err(TimingError(format!(
                "cannot time a feed-per-revolution move with the spindle speed at {rpm} rev/min"
            )))
        }
        Feed::PerRevolution { mm_per_rev, rpm } => {
            per_minute(mm_per_rev * rpm, "a feed (per revolution × spindle speed)")
        }
    }
}

/// Duration of a rapid (G0) of displacement `d`, s, without acceleration:
/// the slowest of the XYZ path and the UVW path at `rapid_feed` (mm/min) and
/// the largest rotary axis move at `rapid_feed_rotary` (deg/min).
pub fn rapid_seconds(d: &Axes, rapid_feed: f64, rapid_feed_rotary: f64) -> f64 {
    let rot = [Axis::A, Axis::B, Axis::C]
        .iter()
        .map(|&a| d[a].abs())
        .fold(0.0, f64::max);
    let minutes = (d.xyz_norm() / rapid_feed)
        .max(d.uvw_norm() / rapid_feed)
        .max(rot / rapid_feed_rotary);
    60.0 * minutes
}

/// `a + s (b − a)` per axis; exactly `b` for `s ≥ 1`.
pub fn lerp(a: &Axes, b: &Axes, s: f64) -> Axes {
    if s >= 1.0 {
        return *b;
    }
    Axes(std::array::from_fn(|i| a.0[i] + s * (b.0[i] - a.0[i])))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(pairs: &[(Axis, f64)]) -> Axes {
        let mut a = Axes::default();
        for &(axis, v) in pairs {
            a[axis] = v;
        }
        a
    }

    #[test]
    fn a_line_at_f_takes_its_length_over_f() {
        // 3-4-5 triangle: 50 mm at 600 mm/min is 5 s.
        let dx = d(&[(Axis::X, 30.0), (Axis::Y, 40.0)]);
        let t = move_seconds(Feed::PerMinute(600.0), dx.xyz_norm(), &dx, 1.0).unwrap();
        assert!((t - 5.0).abs() < 1e-12, "{t}");
        // G95: 0.1 mm/rev at 1000 rev/min is 100 mm/min: 50 mm in 30 s.
        let f = Feed::PerRevolution {
            mm_per_rev: 0.1,
            rpm: 1000.0,
        };
        let t = move_seconds(f, dx.xyz_norm(), &dx, 1.0).unwrap();
        assert!((t - 30.0).abs() < 1e-9, "{t}");
    }

    #[test]
    fn an_arc_is_timed_along_its_length() {
        // A half circle of radius 10 mm: π·10 mm at 300 mm/min.
        let len = std::f64::consts::PI * 10.0;
        let chord = d(&[(Axis::X, 20.0)]);
        let t = move_seconds(Feed::PerMinute(300.0), len, &chord, 1.0).unwrap();
        assert!((t - 60.0 * len / 300.0).abs() < 1e-12);
    }

    #[test]
    fn inverse_time_is_one_over_f_minutes_whatever_the_length() {
        for len in [0.0, 1.0, 1000.0] {
            let dx = d(&[(Axis::X, len)]);
            let t = move_seconds(Feed::InverseTime(4.0), len, &dx, 1.0).unwrap();
            assert!((t - 15.0).abs() < 1e-12);
        }
    }

    #[test]
    fn rapids_at_the_machine_rate_and_rotary_only_feeds_in_degrees() {
        let dz = d(&[(Axis::Z, 100.0)]);
        let t = move_seconds(Feed::Rapid, 100.0, &dz, 10_000.0).unwrap();
        assert!((t - 0.6).abs() < 1e-12);
        // Rapid estimate: 100 mm at 10 m/min (0.6 s) against 90° at 3600°/min (1.5 s).
        let both = d(&[(Axis::Z, 100.0), (Axis::C, -90.0)]);
        assert!((rapid_seconds(&both, 10_000.0, 3600.0) - 1.5).abs() < 1e-12);
        assert!((rapid_seconds(&dz, 10_000.0, 3600.0) - 0.6).abs() < 1e-12);
        // Rotary only at F 360: 90° in 15 s; UVW only: along UVW.
        let c = d(&[(Axis::C, 90.0)]);
        let t = move_seconds(Feed::PerMinute(360.0), 0.0, &c, 1.0).unwrap();
        assert!((t - 15.0).abs() < 1e-12);
        let uv = d(&[(Axis::U, 3.0), (Axis::V, 4.0), (Axis::C, 90.0)]);
        assert_eq!(feed_path(0.0, &uv), 5.0);
    }

    #[test]
    fn zero_negative_or_missing_feeds_are_errors_not_infinite_times() {
        let dx = d(&[(Axis::X, 1.0)]);
        for feed in [
            Feed::PerMinute(0.0),
            Feed::PerMinute(-5.0),
            Feed::PerMinute(f64::NAN),
            Feed::InverseTime(0.0),
            Feed::PerRevolution {
                mm_per_rev: 0.1,
                rpm: 0.0,
            },
            Feed::PerRevolution {
                mm_per_rev: 0.0,
                rpm: 1000.0,
            },
        ] {
            assert!(move_seconds(feed, 1.0, &dx, 1.0).is_err(), "{feed:?}");
        }
        assert!(move_seconds(Feed::Rapid, 1.0, &dx, 0.0).is_err());
    }

    #[test]
    fn lerp_ends_exactly_and_is_linear() {
        let a = d(&[(Axis::X, 1.0), (Axis::B, -10.0)]);
        let b = d(&[(Axis::X, 0.1), (Axis::B, 20.0)]);
        assert_eq!(lerp(&a, &b, 1.0), b);
        assert_eq!(lerp(&a, &b, 0.0), a);
        let m = lerp(&a, &b, 0.5);
        assert!((m[Axis::X] - 0.55).abs() < 1e-15 && (m[Axis::B] - 5.0).abs() < 1e-15);
    }
}
