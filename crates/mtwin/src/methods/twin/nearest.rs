//! The exact global nearest point on the command tool-tip polyline (docs/twin.md).
//!
//! The polyline runs through the command samples `p_0, p_1, …, p_{N−1}` (tool
//! tips in W, mm); segment `k` joins `p_k` and `p_{k+1}`. For a query point
//! `P` (an actual tool tip) belonging to sample `j`, the nearest point is
//! searched over **every** segment of the trajectory:
//!
//! 1. the time-matched segments `j−1` and `j` give an upper bound `d0` on the
//!    nearest distance;
//! 2. a bounding-volume hierarchy over runs of [`LEAF`] consecutive segments
//!    (`TimeTree`) yields every run whose box lies within `d0 + slack` of
//!    `P`; a segment within `d0` of `P` lies in such a box, so no candidate is
//!    missed (a proven bound, not a search window);
//! 3. the exact point-to-segment distance of every segment of those runs.
//!
//! The hierarchy groups runs by time, not by space: node `i` of level `l + 1`
//! bounds nodes `BRANCH·i .. BRANCH·(i+1)` of level `l`. A tool path is
//! continuous, so runs close in time are close in space and the boxes stay
//! tight; building it needs no sorting (linear time, in parallel), which is
//! what makes a new path for every twin run cheap.
//!
//! A shortcut with the same proof skips the tree for most queries: every run
//! `i` knows its *clearance* `c_i`, the smallest distance from its box to the
//! box of any run more than [`WINDOW`] runs away in time (capped at
//! [`CLEARANCE_CAP_MM`]). If `dist(P, box_i) + r < c_i`, a segment within `r`
//! of `P` lies in a box within `r + dist(P, box_i) < c_i` of box `i` (triangle
//! inequality), hence in a run of the window `i ± WINDOW`, which is searched
//! exhaustively instead.
//!
//! Ties: every candidate within [`TIE_MM`] of the smallest distance is equally
//! near; the one closest in time to the actual sample wins (time measured in
//! samples: the point at parameter `u` of segment `k` is at time `k + u`).
//! A segment shorter than [`TIE_MM`] (machine at rest, a rotary-only move
//! under TCP) has all its points equally near, so its point closest in time
//! is taken: `u = clamp(j − k, 0, 1)`.

use nalgebra::Vector3;

/// Distances within this many mm of the smallest one are ties (docs/twin.md).
pub const TIE_MM: f64 = 1e-12;

/// Segments per leaf of the hierarchy: consecutive segments are close in space, so
/// one box holds a short run of them (fewer nodes, a cheap exhaustive check inside).
pub const LEAF: usize = 8;

/// Children per node of the hierarchy.
pub const BRANCH: usize = 8;

/// Runs on each side of the time-matched run searched by the clearance shortcut.
pub const WINDOW: usize = 2;

/// Largest clearance looked for, mm (beyond it the tree is used).
pub const CLEARANCE_CAP_MM: f64 = 2.0;

/// Extra half-width added to the query radius, mm: covers rounding in the computed
/// distances so that a segment at exactly `d0` is never lost.
const SLACK_MM: f64 = 1e-9;

/// An axis-aligned box, mm in W.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Aabb {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Aabb {
    /// The box holding no point (the identity of [`Aabb::union`]).
    const EMPTY: Aabb = Aabb {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };

    /// The smallest box holding `points`.
    fn around(points: &[Vector3<f64>]) -> Aabb {
        let mut b = Aabb::EMPTY;
        for p in points {
            for c in 0..3 {
                b.lo[c] = b.lo[c].min(p[c]);
                b.hi[c] = b.hi[c].max(p[c]);
            }
        }
        b
    }

    /// The smallest box holding both boxes.
    fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            lo: std::array::from_fn(|c| self.lo[c].min(o.lo[c])),
            hi: std::array::from_fn(|c| self.hi[c].max(o.hi[c])),
        }
    }

    /// Squared distance from the box to the point `p`, mm² (0 inside).
    #[inline]
    fn point_distance2(&self, p: &Vector3<f64>) -> f64 {
        let mut s = 0.0;
        for c in 0..3 {
            let d = (self.lo[c] - p[c]).max(p[c] - self.hi[c]).max(0.0);
            s += d * d;
        }
        s
    }

    /// Squared distance between two boxes, mm² (0 when they meet).
    #[inline]
    fn box_distance2(&self, o: &Aabb) -> f64 {
        let mut s = 0.0;
        for c in 0..3 {
            let d = (o.lo[c] - self.hi[c]).max(self.lo[c] - o.hi[c]).max(0.0);
            s += d * d;
        }
        s
    }
}

/// A bounding-volume hierarchy whose leaves are given in time order: level 0
/// holds the leaf boxes, node `i` of level `l + 1` bounds nodes
/// `BRANCH·i .. BRANCH·(i+1)` of level `l`, up to a top level of at most
/// [`BRANCH`] nodes.
#[derive(Debug, Clone)]
struct TimeTree {
    levels: Vec<Vec<Aabb>>,
}

impl TimeTree {
    fn new(leaves: Vec<Aabb>) -> TimeTree {
        let mut levels = vec![leaves];
        while let Some(top) = levels.last().filter(|t| t.len() > BRANCH) {
            let up: Vec<Aabb> = crate::par::map_chunks_init(
                top,
                BRANCH,
                64,
                || (),
                |_, _, c| c.iter().fold(Aabb::EMPTY, |a, b| a.union(b)),
            );
            levels.push(up);
        }
        TimeTree { levels }
    }

    /// The leaf boxes, in time order.
    fn leaves(&self) -> &[Aabb] {
        &self.levels[0]
    }

    /// Depth-first walk: `enter(level, index, box)` is called for a node whose parent
    /// was entered (every top-level node is offered); it returns whether to go on
    /// into the node's children. Leaves are level 0. The tree is implicit, so the
    /// walk needs no stack: the next node is the first child, else the next sibling,
    /// else the next sibling of the nearest ancestor that has one.
    #[inline]
    fn walk(&self, mut enter: impl FnMut(usize, usize, &Aabb) -> bool) {
        let top = self.levels.len() - 1;
        if self.levels[top].is_empty() {
            return;
        }
        let (mut l, mut i) = (top, 0);
        loop {
            if enter(l, i, &self.levels[l][i]) && l > 0 {
                l -= 1;
                i *= BRANCH;
                continue;
            }
            loop {
                i += 1;
                if l == top {
                    if i < self.levels[top].len() {
                        break;
                    }
                    return;
                }
                if i % BRANCH != 0 && i < self.levels[l].len() {
                    break;
                }
                // The parent's children are done: continue after the parent.
                l += 1;
                i = (i - 1) / BRANCH;
            }
        }
    }
}

/// The nearest point found for one query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// The nearest point `P_c` on the polyline, in W, mm.
    pub point: Vector3<f64>,
    /// The command tool axis at `P_c`: linear interpolation between the segment's
    /// end-sample axes, renormalised (unit vector in W).
    pub axis: Vector3<f64>,
    /// Segment index `k` (0 when the polyline has a single sample).
    pub segment: usize,
    /// Parameter along the segment, 0..=1.
    pub u: f64,
    /// `|P − P_c|`, mm.
    pub distance: f64,
}

/// The command tool-tip polyline with its tool axes and spatial index.
///
/// Memory: 48 bytes per sample for tips and axes, plus about 64 bytes per
/// [`LEAF`] segments for the hierarchy and the clearances.
#[derive(Debug, Clone)]
pub struct CommandPath {
    tips: Vec<Vector3<f64>>,
    axes: Vec<Vector3<f64>>,
    /// Leaf `i` bounds the run of segments `LEAF·i .. LEAF·(i+1)` (fewer at the end).
    tree: TimeTree,
    /// Clearance of each run (see the module documentation), mm.
    clearance: Vec<f64>,
}

/// One candidate point on a segment.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    d: f64,
    gap: f64,
    k: usize,
    u: f64,
}

impl CommandPath {
    /// The polyline through `tips` (mm, W) with unit tool `axes` (W), one per command
    /// sample, in time order.
    ///
    /// # Panics
    /// When `tips` and `axes` differ in length.
    pub fn new(tips: Vec<Vector3<f64>>, axes: Vec<Vector3<f64>>) -> Self {
        assert_eq!(tips.len(), axes.len(), "one tool axis per tool tip");
        let n_seg = tips.len().saturating_sub(1);
        let leaf_index: Vec<usize> = (0..n_seg.div_ceil(LEAF)).collect();
        let leaves: Vec<Aabb> = crate::par::map(&leaf_index, 1024, |_, &i| {
            Aabb::around(&tips[i * LEAF..=((i + 1) * LEAF).min(n_seg)])
        });
        let tree = TimeTree::new(leaves);
        let cap2 = CLEARANCE_CAP_MM * CLEARANCE_CAP_MM;
        let clearance = crate::par::map(tree.leaves(), 256, |i, b| {
            let mut best2 = cap2;
            tree.walk(|level, o, node| {
                let d2 = node.box_distance2(b);
                if d2 >= best2 {
                    return false;
                }
                if level == 0 && o.abs_diff(i) > WINDOW {
                    best2 = d2;
                }
                true
            });
            best2.sqrt()
        });
        CommandPath {
            tips,
            axes,
            tree,
            clearance,
        }
    }

    /// Number of command samples.
    pub fn len(&self) -> usize {
        self.tips.len()
    }

    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.tips.is_empty()
    }

    /// Command tool tip of sample `k`, mm in W.
    pub fn tip(&self, k: usize) -> Vector3<f64> {
        self.tips[k]
    }

    /// Command tool axis of sample `k` (unit, W).
    pub fn axis(&self, k: usize) -> Vector3<f64> {
        self.axes[k]
    }

    /// Distance from `p` to segment `k` and the parameter of the nearest point, with the
    /// time gap to sample time `j`.
    #[inline]
    fn candidate(&self, p: &Vector3<f64>, k: usize, j: f64) -> Candidate {
        let a = self.tips[k];
        let d = self.tips[k + 1] - a;
        let len2 = d.norm_squared();
        let u = if len2 <= TIE_MM * TIE_MM {
            // Every point of the segment is equally near: the one closest in time.
            (j - k as f64).clamp(0.0, 1.0)
        } else {
            ((p - a).dot(&d) / len2).clamp(0.0, 1.0)
        };
        let dist = (p - (a + d * u)).norm();
        Candidate {
            d: dist,
            gap: (k as f64 + u - j).abs(),
            k,
            u,
        }
    }

    /// The exact nearest point to `p` (mm, W) over the whole polyline, for the actual
    /// sample `j` (its index, which sets the time-matched bound and breaks ties).
    /// `scratch` is reused between calls to avoid allocation.
    ///
    /// # Panics
    /// When the polyline is empty.
    pub fn nearest(
        &self,
        p: &Vector3<f64>,
        j: usize,
        scratch: &mut Vec<(f64, f64, usize, f64)>,
    ) -> Nearest {
        let n = self.tips.len();
        assert!(n > 0, "the command polyline is empty");
        if n == 1 {
            return Nearest {
                point: self.tips[0],
                axis: self.axes[0],
                segment: 0,
                u: 0.0,
                distance: (p - self.tips[0]).norm(),
            };
        }
        let jf = j as f64;
        let last = n - 2;
        let j = j.min(n - 1);
        let mut d0 = f64::INFINITY;
        for k in [j.saturating_sub(1), j.min(last)] {
            d0 = d0.min(self.candidate(p, k, jf).d);
        }
        let r = d0 + TIE_MM + SLACK_MM + 1e-15 * (p.amax() + d0);
        let r2 = r * r;
        scratch.clear();
        let mut dmin = f64::INFINITY;
        // A segment within r of P lies in a box within r of P: boxes farther away
        // hold no candidate (exact, not a heuristic).
        let mut visit_run = |i: usize| {
            for k in i * LEAF..((i + 1) * LEAF).min(last + 1) {
                let c = self.candidate(p, k, jf);
                if c.d <= r {
                    dmin = dmin.min(c.d);
                    scratch.push((c.d, c.gap, c.k, c.u));
                }
            }
        };
        let leaves = self.tree.leaves();
        let ri = j.min(last) / LEAF;
        if leaves[ri].point_distance2(p).sqrt() + r < self.clearance[ri] {
            let hi = (ri + WINDOW).min(leaves.len() - 1);
            for i in ri.saturating_sub(WINDOW)..=hi {
                if leaves[i].point_distance2(p) <= r2 {
                    visit_run(i);
                }
            }
        } else {
            self.tree.walk(|level, i, node| {
                if node.point_distance2(p) > r2 {
                    return false;
                }
                if level == 0 {
                    visit_run(i);
                }
                true
            });
        }
        let mut best: Option<Candidate> = None;
        for &(d, gap, k, u) in scratch.iter() {
            if d <= dmin + TIE_MM {
                let closer = best.is_none_or(|b| gap < b.gap || (gap == b.gap && k < b.k));
                if closer {
                    best = Some(Candidate { d, gap, k, u });
                }
            }
        }
        // The time-matched segments are always inside the cube, so `best` exists.
        let c = best.unwrap_or_else(|| self.candidate(p, j.min(last), jf));
        self.at(c.k, c.u, c.d)
    }

    /// The point, interpolated axis and distance at parameter `u` of segment `k`.
    fn at(&self, k: usize, u: f64, distance: f64) -> Nearest {
        let a = self.tips[k];
        let point = a + (self.tips[k + 1] - a) * u;
        let o = self.axes[k] * (1.0 - u) + self.axes[k + 1] * u;
        let norm = o.norm();
        let axis = if norm > 1e-300 {
            o / norm
        } else {
            self.axes[k]
        };
        Nearest {
            point,
            axis,
            segment: k,
            u,
            distance,
        }
    }
}

/// The angle between two vectors, rad, accurate at small angles:
/// `atan2(|a×b|, a·b)`.
#[inline]
pub fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// Exhaustive reference: every segment, the same tie rule written plainly:
    /// (segment, u, distance).
    pub(in crate::methods::twin) fn brute(
        tips: &[Vector3<f64>],
        p: &Vector3<f64>,
        j: usize,
    ) -> (usize, f64, f64) {
        let mut all = Vec::new();
        for k in 0..tips.len() - 1 {
            let (a, b) = (tips[k], tips[k + 1]);
            let d = b - a;
            let u = if d.norm() <= TIE_MM {
                (j as f64 - k as f64).clamp(0.0, 1.0)
            } else {
                ((p - a).dot(&d) / d.dot(&d)).clamp(0.0, 1.0)
            };
            all.push((k, u, (p - (a + d * u)).norm()));
        }
        let dmin = all.iter().map(|c| c.2).fold(f64::INFINITY, f64::min);
        *all.iter()
            .filter(|c| c.2 <= dmin + TIE_MM)
            .min_by(|x, y| {
                let gx = (x.0 as f64 + x.1 - j as f64).abs();
                let gy = (y.0 as f64 + y.1 - j as f64).abs();
                gx.total_cmp(&gy)
            })
            .unwrap()
    }

    /// Boxes around short random walks, in time order.
    fn random_leaves(n: usize, seed: u64) -> Vec<Aabb> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut p = Vector3::zeros();
        (0..n)
            .map(|_| {
                let a = p;
                p += Vector3::new(rng.r#gen::<f64>(), rng.r#gen(), rng.r#gen()) * 2.0
                    - Vector3::repeat(1.0);
                Aabb::around(&[a, p])
            })
            .collect()
    }

    #[test]
    fn the_walk_visits_every_node_once_and_leaves_in_time_order() {
        for n in [0, 1, 7, 8, 9, 63, 64, 65, 100, 513, 4097] {
            let tree = TimeTree::new(random_leaves(n, n as u64));
            let mut seen: Vec<Vec<usize>> = vec![Vec::new(); tree.levels.len()];
            tree.walk(|l, i, b| {
                assert_eq!(*b, tree.levels[l][i]);
                seen[l].push(i);
                true
            });
            for (l, level) in tree.levels.iter().enumerate() {
                let mut s = seen[l].clone();
                s.sort_unstable();
                assert_eq!(s, (0..level.len()).collect::<Vec<_>>(), "n {n} level {l}");
            }
            // Depth first: the leaves come in time order.
            assert!(seen[0].windows(2).all(|w| w[0] < w[1]), "n {n}");
            assert!(tree.levels.last().unwrap().len() <= BRANCH);
            // Every node bounds its children.
            for l in 1..tree.levels.len() {
                for (c, child) in tree.levels[l - 1].iter().enumerate() {
                    let parent = tree.levels[l][c / BRANCH];
                    assert_eq!(parent.union(child), parent);
                }
            }
        }
    }

    #[test]
    fn a_pruned_walk_finds_every_leaf_within_the_radius() {
        let leaves = random_leaves(3000, 5);
        let tree = TimeTree::new(leaves.clone());
        for (q, r) in [
            (Vector3::new(0.0, 0.0, 0.0), 1.0),
            (Vector3::new(3.0, -2.0, 5.0), 4.0),
            (Vector3::new(30.0, 1.0, -7.0), 0.5),
        ] {
            let mut found = Vec::new();
            tree.walk(|l, i, b| {
                let near = b.point_distance2(&q) <= r * r;
                if near && l == 0 {
                    found.push(i);
                }
                near
            });
            let brute: Vec<usize> = (0..leaves.len())
                .filter(|&i| leaves[i].point_distance2(&q) <= r * r)
                .collect();
            assert_eq!(found, brute);
        }
    }

    #[test]
    fn clearance_is_the_distance_to_the_nearest_box_outside_the_window() {
        let n = 4000;
        let tips: Vec<_> = (0..n)
            .map(|i| {
                let t = i as f64 * 0.01;
                Vector3::new(10.0 * t.sin(), 10.0 * t.cos(), 0.05 * t)
            })
            .collect();
        let path = CommandPath::new(tips, vec![Vector3::z(); n]);
        let leaves = path.tree.leaves();
        for (i, b) in leaves.iter().enumerate() {
            let brute = leaves
                .iter()
                .enumerate()
                .filter(|(o, _)| o.abs_diff(i) > WINDOW)
                .map(|(_, o)| b.box_distance2(o).sqrt())
                .fold(CLEARANCE_CAP_MM, f64::min);
            assert_eq!(path.clearance[i], brute, "run {i}");
        }
        // The helix passes within 0.05·2π mm of itself: clearances are below the cap.
        assert!(path.clearance.iter().all(|&c| c < 0.4));
    }

    #[test]
    fn finds_a_far_away_pass_of_the_path() {
        // A zig-zag: passes at y = 0, 1, 2, … joined at the ends; the query point of
        // sample j (on pass 0) is moved next to pass 5, which the time-matched bound
        // alone would never see.
        let mut tips = Vec::new();
        for pass in 0..10 {
            for i in 0..=100 {
                let x = if pass % 2 == 0 {
                    i as f64
                } else {
                    100.0 - i as f64
                };
                tips.push(Vector3::new(x, pass as f64, 0.0));
            }
        }
        let axes = vec![Vector3::z(); tips.len()];
        let path = CommandPath::new(tips.clone(), axes);
        let mut s = Vec::new();
        let p = Vector3::new(37.25, 5.0 + 1e-3, 0.0);
        let near = path.nearest(&p, 37, &mut s);
        assert!((near.distance - 1e-3).abs() < 1e-12, "{near:?}");
        assert!((near.point - Vector3::new(37.25, 5.0, 0.0)).norm() < 1e-12);
        let (k, u, d) = brute(&tips, &p, 37);
        assert_eq!((near.segment, near.u, near.distance), (k, u, d));
    }

    #[test]
    fn matches_exhaustive_search_on_a_random_curve() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let n = 3000;
        let tips: Vec<_> = (0..n)
            .map(|i| {
                let t = i as f64 * 0.01;
                Vector3::new(
                    30.0 * t.sin(),
                    20.0 * (1.7 * t).cos(),
                    5.0 * (0.3 * t).sin(),
                )
            })
            .collect();
        let axes = vec![Vector3::z(); n];
        let path = CommandPath::new(tips.clone(), axes);
        let mut s = Vec::new();
        for _ in 0..500 {
            let j = rng.gen_range(0..n);
            let off = Vector3::new(rng.r#gen::<f64>(), rng.r#gen(), rng.r#gen()) * 8.0
                - Vector3::repeat(4.0);
            let p = tips[j] + off;
            let near = path.nearest(&p, j, &mut s);
            let (k, u, d) = brute(&tips, &p, j);
            assert!(
                (near.distance - d).abs() < 1e-12,
                "{} vs {d}",
                near.distance
            );
            assert_eq!(near.segment, k);
            assert!((near.u - u).abs() < 1e-12);
        }
    }

    #[test]
    fn at_rest_the_sample_closest_in_time_wins() {
        // The tip stays at the origin while the axis turns about x by 1 mrad per sample.
        let n = 50;
        let tips = vec![Vector3::zeros(); n];
        let axes: Vec<_> = (0..n)
            .map(|k| {
                let a = 1e-3 * k as f64;
                Vector3::new(0.0, -a.sin(), a.cos())
            })
            .collect();
        let path = CommandPath::new(tips, axes.clone());
        let mut s = Vec::new();
        for j in [0, 1, 17, 48, 49] {
            let near = path.nearest(&Vector3::new(0.0, 0.0, 2e-3), j, &mut s);
            assert!((near.distance - 2e-3).abs() < 1e-15);
            assert!(
                angle_between(&near.axis, &axes[j]) < 1e-15,
                "j = {j}: {near:?}"
            );
        }
    }

    #[test]
    fn single_sample_and_small_angles() {
        let path = CommandPath::new(vec![Vector3::new(1.0, 2.0, 3.0)], vec![Vector3::z()]);
        let near = path.nearest(&Vector3::new(1.0, 2.0, 7.0), 0, &mut Vec::new());
        assert_eq!(near.distance, 4.0);
        let a = Vector3::new(0.0, 0.0, 1.0);
        let b = Vector3::new(1e-9_f64.sin(), 0.0, 1e-9_f64.cos());
        assert!((angle_between(&a, &b) - 1e-9).abs() < 1e-22);
    }
}
