//! G64 Q: LinuxCNC's "naive CAM detector", as its canonical-machining layer
//! does it (see `docs/references.md`; behaviour re-stated, no code copied).
//!
//! Under G64 with Q > 0, consecutive straight feeds are collected into a
//! chain and sent to the planner as **one** straight move from the chain's
//! start to its last point, as long as
//!
//! * every point of the chain lies within Q (mm) of the segment from the
//!   chain's start to the newest point,
//! * no rotary or UVW axis changes (a block that moves one ends the chain
//!   with itself),
//! * the newest point is not the chain's start,
//! * the chain holds at most 101 points,
//! * the feed, the feed mode, the offsets and TCP stay the same.
//!
//! Anything else (a rapid, an arc, a dwell, a mode change, the end of the
//! program) sends the chain first. The merged move keeps the feed of its
//! blocks and the program line of its last block.

use crate::gcode::axes::{Axes, Axis};
use crate::gcode::event::Linear;

/// Most points of a chain before a new point starts another (LinuxCNC's
/// limit: more than 100 chained points are not extended).
const MAX_POINTS: usize = 101;

/// A chain of straight feeds being merged.
#[derive(Debug, Clone, Default)]
pub struct NaiveCam {
    /// The first block of the chain (its start, feed and offsets) and the
    /// chained end points with their lines.
    chain: Option<(Linear, Vec<(Axes, u64)>)>,
}

fn xyz(a: &Axes) -> [f64; 3] {
    [a[Axis::X], a[Axis::Y], a[Axis::Z]]
}

/// Distance of `p` from the segment `a`–`b` (XYZ).
fn off_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let m: [f64; 3] = std::array::from_fn(|i| b[i] - a[i]);
    let mm: f64 = m.iter().map(|x| x * x).sum();
    let t = if mm > 0.0 {
        ((0..3).map(|i| m[i] * (p[i] - a[i])).sum::<f64>() / mm).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (0..3)
        .map(|i| (p[i] - a[i] - t * m[i]).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn non_xyz_same(a: &Axes, b: &Axes) -> bool {
    Axis::ALL
        .iter()
        .filter(|l| !matches!(l, Axis::X | Axis::Y | Axis::Z))
        .all(|&l| a[l] == b[l])
}

impl NaiveCam {
    /// An empty detector.
    pub fn new() -> Self {
        NaiveCam::default()
    }

    /// Whether a chain is being collected.
    pub fn is_empty(&self) -> bool {
        self.chain.is_none()
    }

    /// The merged move of the chain collected so far (and its last line),
    /// emptying the detector.
    pub fn flush(&mut self) -> Option<(Linear, u64)> {
        let (mut first, pts) = self.chain.take()?;
        let &(end, line) = pts.last()?;
        first.to = end;
        Some((first, line))
    }

    fn linkable(&self, m: &Linear, q: f64) -> bool {
        let Some((first, pts)) = &self.chain else {
            return false;
        };
        let Some((last, _)) = pts.last() else {
            return false;
        };
        if pts.len() >= MAX_POINTS
            || first.feed != m.feed
            || first.offset != m.offset
            || first.tcp != m.tcp
            || !non_xyz_same(last, &m.to)
        {
            return false;
        }
        let (b, e) = (xyz(&first.from), xyz(&m.to));
        if b == e {
            return false;
        }
        pts.iter().all(|(p, _)| off_segment(xyz(p), b, e) <= q)
    }

    /// Sees the straight feed `m` of program line `line` under G64 Q `q`
    /// (> 0): returns the merged move to send first, if `m` cannot join the
    /// chain, and the move to send after it, if `m` ends its chain itself
    /// (it moves a rotary or UVW axis).
    pub fn see(&mut self, m: &Linear, line: u64, q: f64) -> [Option<(Linear, u64)>; 2] {
        let mut out = [None, None];
        if self.chain.is_some() && !self.linkable(m, q) {
            out[0] = self.flush();
        }
        match &mut self.chain {
            Some((_, pts)) => pts.push((m.to, line)),
            None => self.chain = Some((*m, vec![(m.to, line)])),
        }
        if !non_xyz_same(&m.from, &m.to) {
            out[1] = self.flush();
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::axes::AxisMask;
    use crate::gcode::event::{DistanceMode, Feed, Programmed, Units};

    fn line(from: [f64; 3], to: [f64; 3]) -> Linear {
        let mut a = Axes::default();
        let mut b = Axes::default();
        a.0[..3].copy_from_slice(&from);
        b.0[..3].copy_from_slice(&to);
        Linear {
            from: a,
            to: b,
            offset: Axes::default(),
            feed: Feed::PerMinute(600.0),
            tcp: false,
            words: Programmed {
                axes: AxisMask::default(),
                g53: false,
                distance: DistanceMode::Absolute,
                units: Units::Millimetre,
                expanded: false,
                x_diameter: false,
            },
        }
    }

    /// Points zig-zagging ±0.004 about the X axis merge within Q 0.01 into
    /// one move from the first start to (4, 0); the next point, (5, 0.03),
    /// would leave (2, −0.004) 0.016 from the chord: a new chain.
    #[test]
    fn nearly_collinear_points_merge_within_q() {
        let mut cam = NaiveCam::new();
        let mut from = [0.0; 3];
        let mut sent = Vec::new();
        for (k, y) in [0.004, -0.004, 0.004, 0.0, 0.03].iter().enumerate() {
            let to = [(k + 1) as f64, *y, 0.0];
            for m in cam
                .see(&line(from, to), k as u64 + 1, 0.01)
                .into_iter()
                .flatten()
            {
                sent.push(m);
            }
            from = to;
        }
        sent.extend(cam.flush());
        assert_eq!(sent.len(), 2, "{sent:?}");
        assert_eq!(xyz(&sent[0].0.from), [0.0; 3]);
        assert_eq!(xyz(&sent[0].0.to), [4.0, 0.0, 0.0]);
        assert_eq!(sent[0].1, 4);
        assert_eq!(xyz(&sent[1].0.from), [4.0, 0.0, 0.0]);
        assert_eq!(xyz(&sent[1].0.to), [5.0, 0.03, 0.0]);
        assert_eq!(sent[1].1, 5);
        // A feed change ends the chain; so does a rotary move.
        let mut cam = NaiveCam::new();
        assert!(cam.see(&line([0.0; 3], [1.0, 0.0, 0.0]), 1, 0.1)[0].is_none());
        let mut m = line([1.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        m.feed = Feed::PerMinute(300.0);
        assert!(cam.see(&m, 2, 0.1)[0].is_some());
        let mut r = line([2.0, 0.0, 0.0], [3.0, 0.0, 0.0]);
        r.to[Axis::A] = 5.0;
        r.feed = Feed::PerMinute(300.0);
        let out = cam.see(&r, 3, 0.1);
        // It cannot join (A changes): the chain goes first, then the
        // rotary block alone.
        let (Some(a), Some(b)) = (out[0], out[1]) else {
            panic!("{out:?}")
        };
        assert_eq!((xyz(&a.0.to), a.1), ([2.0, 0.0, 0.0], 2));
        assert_eq!((b.0.to[Axis::A], b.1), (5.0, 3));
        assert!(cam.is_empty());
    }
}
