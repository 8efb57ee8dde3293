//! Plots of a twin run (figures 7–9 of the patent \[R5\]): the command and actual tool path with
//! the tool-tip error coloured along it, and the tool-tip and tool-axis errors along
//! the path length. A [`PlotCollector`] keeps a bounded number of points from a
//! stream of any length.

use super::pipeline::TwinSample;
use crate::report::path3d::coloured_path;
use crate::report::svg::{Series, xy};

/// One kept point: the sample with the largest tool-tip error of its stretch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotPoint {
    /// Command path length, mm.
    pub path_length: f64,
    /// Command tool tip, mm in W.
    pub cmd_tip: [f64; 3],
    /// Actual tool tip, mm in W.
    pub tip: [f64; 3],
    /// Largest `ε_p` of the stretch, mm.
    pub tip_error: f64,
    /// Largest `ε_o` of the stretch, rad.
    pub axis_error: f64,
}

impl PlotPoint {
    fn of(s: &TwinSample) -> Self {
        PlotPoint {
            path_length: s.path_length,
            cmd_tip: s.cmd_tip.into(),
            tip: s.tip.into(),
            tip_error: s.tip_error,
            axis_error: s.axis_error,
        }
    }

    /// Merge two neighbours: the place of the one with the larger tip error, the
    /// largest of both errors (peaks are never lost).
    fn merge(a: PlotPoint, b: PlotPoint) -> PlotPoint {
        let mut m = if b.tip_error > a.tip_error { b } else { a };
        m.axis_error = a.axis_error.max(b.axis_error);
        m
    }
}

/// Keeps at most `2·limit` points of a stream: every `stride`-th stretch merged into one
/// point; when full, neighbours merge and the stride doubles.
#[derive(Debug, Clone)]
pub struct PlotCollector {
    limit: usize,
    stride: u64,
    pending: Option<(PlotPoint, u64)>,
    points: Vec<PlotPoint>,
}

impl PlotCollector {
    /// A collector keeping between `limit` and `2·limit` points (`limit ≥ 1`).
    pub fn new(limit: usize) -> Self {
        PlotCollector {
            limit: limit.max(1),
            stride: 1,
            pending: None,
            points: Vec::new(),
        }
    }

    /// Add the next sample.
    pub fn add(&mut self, s: &TwinSample) {
        let p = PlotPoint::of(s);
        let (acc, n) = match self.pending.take() {
            Some((a, n)) => (PlotPoint::merge(a, p), n + 1),
            None => (p, 1),
        };
        if n < self.stride {
            self.pending = Some((acc, n));
            return;
        }
        self.points.push(acc);
        if self.points.len() >= 2 * self.limit {
            self.points = self
                .points
                .chunks(2)
                .map(|c| c.iter().copied().reduce(PlotPoint::merge).unwrap_or(c[0]))
                .collect();
            self.stride *= 2;
        }
    }

    /// The kept points, in order.
    pub fn points(&self) -> Vec<PlotPoint> {
        let mut v = self.points.clone();
        v.extend(self.pending.map(|p| p.0));
        v
    }
}

/// (a) The command path (grey) and the actual path coloured by `ε_p` (µm), isometric.
pub fn path_svg(points: &[PlotPoint]) -> String {
    let cmd: Vec<[f64; 3]> = points.iter().map(|p| p.cmd_tip).collect();
    let act: Vec<[f64; 3]> = points.iter().map(|p| p.tip).collect();
    let err: Vec<f64> = points.iter().map(|p| p.tip_error).collect();
    coloured_path(
        "Tool path in W (isometric): command grey, actual coloured by tool-tip error",
        &cmd,
        &act,
        &err,
        "ε_p, µm",
        1e3,
    )
}

/// (b) `ε_p` (µm) along the command path length (mm).
pub fn tip_error_svg(points: &[PlotPoint]) -> String {
    xy(
        "Tool-tip trajectory error along the path",
        "command path length, mm",
        "tool-tip error ε_p, µm",
        &[Series {
            name: "ε_p".into(),
            points: points
                .iter()
                .map(|p| (p.path_length, p.tip_error * 1e3))
                .collect(),
            color: "#c0392b".into(),
            markers: false,
        }],
    )
}

/// (b) `ε_o` (µrad) along the command path length (mm).
pub fn axis_error_svg(points: &[PlotPoint]) -> String {
    xy(
        "Tool-axis trajectory error along the path",
        "command path length, mm",
        "tool-axis error ε_o, µrad",
        &[Series {
            name: "ε_o".into(),
            points: points
                .iter()
                .map(|p| (p.path_length, p.axis_error * 1e6))
                .collect(),
            color: "#2471a3".into(),
            markers: false,
        }],
    )
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    fn sample(i: u64, e: f64, a: f64) -> TwinSample {
        TwinSample {
            index: i,
            t: i as f64,
            cmd_tip: Vector3::new(i as f64, 0.0, 0.0),
            cmd_axis: Vector3::z(),
            tip: Vector3::new(i as f64, e, 0.0),
            axis: Vector3::z(),
            nearest: Vector3::new(i as f64, 0.0, 0.0),
            nearest_at: i as f64,
            tip_error: e,
            axis_error: a,
            path_length: i as f64,
        }
    }

    #[test]
    fn bounded_and_peaks_survive() {
        let mut c = PlotCollector::new(100);
        for i in 0..100_000u64 {
            let e = if i == 54_321 { 1.0 } else { 1e-3 };
            let a = if i == 77_777 { 2.0 } else { 1e-6 };
            c.add(&sample(i, e, a));
        }
        let p = c.points();
        assert!(p.len() >= 100 && p.len() <= 201, "{}", p.len());
        let top = p
            .iter()
            .max_by(|a, b| a.tip_error.total_cmp(&b.tip_error))
            .unwrap();
        assert_eq!((top.tip_error, top.path_length), (1.0, 54_321.0));
        assert_eq!(p.iter().map(|x| x.axis_error).fold(0.0, f64::max), 2.0);
        // Points stay in order along the path.
        assert!(p.windows(2).all(|w| w[0].path_length < w[1].path_length));
        let svg = tip_error_svg(&p);
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
        assert!(path_svg(&p).contains("ε_p, µm"));
        assert!(axis_error_svg(&p).contains("µrad"));
    }
}
