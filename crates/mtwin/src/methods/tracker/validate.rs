//! Before/after statistics of the tool-tip error at check poses, per
//! direction and for the distance (tables 6–9 of the source paper \[R2\]): the error of the
//! nominal model (measured − nominal) against the error left by the
//! identified model (measured − identified prediction).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::model::TrackerPoint;
use crate::kinematics::Kinematics;
use crate::model::Machine;

/// Max, mean and standard deviation of `|e|` over the points (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Largest `|e|`.
    #[serde(deserialize_with = "crate::io::nan_if_null")]
    pub max: f64,
    /// Mean of `|e|`.
    #[serde(deserialize_with = "crate::io::nan_if_null")]
    pub mean: f64,
    /// Population standard deviation of `|e|`.
    #[serde(deserialize_with = "crate::io::nan_if_null")]
    pub std: f64,
}

impl Stats {
    /// Statistics of the magnitudes `values` (empty: all zero).
    pub fn of(values: impl Iterator<Item = f64>) -> Stats {
        let v: Vec<f64> = values.map(f64::abs).collect();
        if v.is_empty() {
            return Stats {
                max: 0.0,
                mean: 0.0,
                std: 0.0,
            };
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
        Stats {
            max: v.iter().copied().fold(0.0, f64::max),
            mean,
            std: var.sqrt(),
        }
    }

    /// Relative change `after/before − 1` of each statistic, in percent
    /// (−81 means 81 % smaller). `NaN` where `before` is 0.
    pub fn change(before: &Stats, after: &Stats) -> Stats {
        let c = |b: f64, a: f64| 100.0 * (a / b - 1.0);
        Stats {
            max: c(before.max, after.max),
            mean: c(before.mean, after.mean),
            std: c(before.std, after.std),
        }
    }
}

/// Statistics per direction x, y, z (W) and of the distance `|Δp|`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Of the x component (W).
    pub x: Stats,
    /// Of the y component (W).
    pub y: Stats,
    /// Of the z component (W).
    pub z: Stats,
    /// Of the distance `|Δp|`.
    pub distance: Stats,
}

impl ErrorStats {
    /// Statistics of the error vectors `e` (mm).
    pub fn of(e: &[Vector3<f64>]) -> ErrorStats {
        ErrorStats {
            x: Stats::of(e.iter().map(|v| v.x)),
            y: Stats::of(e.iter().map(|v| v.y)),
            z: Stats::of(e.iter().map(|v| v.z)),
            distance: Stats::of(e.iter().map(|v| v.norm())),
        }
    }

    /// Per-statistic change from `before` to `after`, percent.
    pub fn change(before: &ErrorStats, after: &ErrorStats) -> ErrorStats {
        ErrorStats {
            x: Stats::change(&before.x, &after.x),
            y: Stats::change(&before.y, &after.y),
            z: Stats::change(&before.z, &after.z),
            distance: Stats::change(&before.distance, &after.distance),
        }
    }

    /// RMS of the distance, `√(mean² + std²)` (mm).
    pub fn rms(&self) -> f64 {
        self.distance.mean.hypot(self.distance.std)
    }
}

/// A validation at check poses.
#[derive(Debug, Clone, Serialize)]
pub struct Validation {
    /// Number of check points.
    pub points: usize,
    /// Measured − nominal model.
    pub before: ErrorStats,
    /// Measured − identified model.
    pub after: ErrorStats,
    /// `after/before − 1`, percent.
    pub change: ErrorStats,
    /// Per point, measured − nominal (mm, W).
    #[serde(skip)]
    pub errors_before: Vec<Vector3<f64>>,
    /// Per point, measured − identified (mm, W).
    #[serde(skip)]
    pub errors_after: Vec<Vector3<f64>>,
}

/// Compares the nominal and the identified model of `identified` with the
/// measured points (given in W).
pub fn validate(identified: &Machine, points: &[TrackerPoint]) -> Validation {
    let nominal = Kinematics::nominal(identified);
    let model = Kinematics::new(identified);
    let errors_before: Vec<Vector3<f64>> = points
        .iter()
        .map(|p| p.measured - nominal.pose(&p.q).tip)
        .collect();
    let errors_after: Vec<Vector3<f64>> = points
        .iter()
        .map(|p| p.measured - model.pose(&p.q).tip)
        .collect();
    let before = ErrorStats::of(&errors_before);
    let after = ErrorStats::of(&errors_after);
    Validation {
        points: points.len(),
        before,
        after,
        change: ErrorStats::change(&before, &after),
        errors_before,
        errors_after,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_known_values() {
        // |e| = 1, 3: max 3, mean 2, population std 1.
        let s = Stats::of([-1.0, 3.0].into_iter());
        assert_eq!((s.max, s.mean, s.std), (3.0, 2.0, 1.0));
        let e = [Vector3::new(3.0, 0.0, 4.0), Vector3::new(0.0, -6.0, 8.0)];
        let st = ErrorStats::of(&e);
        assert_eq!(st.distance.mean, 7.5);
        assert_eq!(st.y.max, 6.0);
        let half = Stats::of([0.5, 1.5].into_iter());
        assert_eq!(Stats::change(&s, &half).mean, -50.0);
        // rms of |e| = 5, 10: √((25 + 100)/2).
        assert!((st.rms() - 62.5f64.sqrt()).abs() < 1e-12);
    }
}

/// Options of [`run`]: none yet.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct ValidateOptions {}

/// `mtwin tracker validate`: the validation ([`validate`]) of the identified
/// machine at the check points and its document.
pub fn run(
    identified: &Machine,
    points: &[TrackerPoint],
    _options: &ValidateOptions,
) -> (Validation, super::TrackerValidateDoc) {
    let v = validate(identified, points);
    let doc = super::TrackerValidateDoc::from(&v);
    (v, doc)
}
