//! Look-ahead over a bounded window of blocks: the backward pass (the
//! highest speed at each junction from which every later block can still
//! slow down to its limits, down to rest at the end of the window) and the
//! forward pass (the speed each block can actually reach from its entry
//! speed), giving each block a [`Profile`] and a start time.
//!
//! * A block joins the next by a [`Join`]: a stop, a tangent junction (the
//!   speed is continuous and at most the junction's speed), or a parabolic
//!   blend (the block ends at rest, and the next starts from rest while this
//!   one is still decelerating: the two displacements add, as in LinuxCNC's
//!   parabolic blending).
//! * The window holds at most `depth` blocks: a block is planned when
//!   `depth` more are queued behind it (or at the end of the program), the
//!   last queued block assumed to end at rest. Memory is bounded by `depth`
//!   and the work per block by `depth`, so planning time is linear in the
//!   program length.

use std::collections::VecDeque;

use super::profile::Profile;

/// How a block joins the next one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Join {
    /// The machine stops at the junction.
    Stop,
    /// The speed is continuous through the junction, at most `v`.
    Tangent {
        /// Highest junction speed, length units per s.
        v: f64,
    },
    /// Parabolic blend: this block ends at rest and the next one starts from
    /// rest once this block's speed, on its final deceleration, falls below
    /// `v`; the displacements of both add while they overlap.
    Blend {
        /// Speed below which the next block starts, length units per s.
        v: f64,
    },
}

/// The limits of one block along its path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Path length (mm, deg, or 1 for a path normalised to `[0, 1]`).
    pub len: f64,
    /// Highest path speed, length units per s.
    pub v: f64,
    /// Path acceleration and deceleration, length units per s² (may be infinite).
    pub a: f64,
}

struct Item<P> {
    payload: P,
    lim: Limits,
    join: Option<Join>,
}

/// A planned block: its payload, profile and start time (s).
#[derive(Debug, Clone)]
pub struct Planned<P> {
    /// What the caller queued with the block.
    pub payload: P,
    /// Speed profile along the block's path.
    pub profile: Profile,
    /// Start time, s.
    pub t0: f64,
    /// How it joins the next block.
    pub join: Join,
}

impl<P> Planned<P> {
    /// End time, s.
    pub fn t1(&self) -> f64 {
        self.t0 + self.profile.duration()
    }
}

/// The bounded look-ahead window (see the module documentation).
pub struct Lookahead<P> {
    items: VecDeque<Item<P>>,
    depth: usize,
    /// Entry speed of the next block to plan.
    v_in: f64,
    /// End time, join and profile of the last planned block.
    prev: Option<(f64, f64, Join, Profile)>,
}

impl<P> Lookahead<P> {
    /// A window of `depth` (at least 1) blocks.
    pub fn new(depth: usize) -> Self {
        Lookahead {
            items: VecDeque::new(),
            depth: depth.max(1),
            v_in: 0.0,
            prev: None,
        }
    }

    /// Blocks queued and not yet planned.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether no block is queued.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// The last queued block, its limits and join (to set the join when the
    /// next block is known).
    pub fn last_mut(&mut self) -> Option<(&mut P, &mut Limits, &mut Option<Join>)> {
        self.items
            .back_mut()
            .map(|i| (&mut i.payload, &mut i.lim, &mut i.join))
    }

    /// Queues a block; the join of the block before it must be set first
    /// ([`Lookahead::last_mut`]), otherwise it is a stop.
    pub fn push(&mut self, payload: P, lim: Limits) {
        if let Some(last) = self.items.back_mut()
            && last.join.is_none()
        {
            last.join = Some(Join::Stop);
        }
        self.items.push_back(Item {
            payload,
            lim,
            join: None,
        });
    }

    /// Plans the first queued block if the window is full.
    pub fn pop_ready(&mut self) -> Option<Planned<P>> {
        if self.items.len() > self.depth {
            self.plan_front()
        } else {
            None
        }
    }

    /// Plans the first queued block whatever the window holds (the end of
    /// the program, or a stop the caller knows of): the last block ends at rest.
    pub fn pop_flush(&mut self) -> Option<Planned<P>> {
        if let Some(last) = self.items.back_mut() {
            last.join = Some(Join::Stop);
        }
        self.plan_front()
    }

    fn plan_front(&mut self) -> Option<Planned<P>> {
        // The first junction that is not tangent (or the end of the window,
        // taken as a stop) bounds the backward pass.
        let n = self.items.len();
        if n == 0 {
            return None;
        }
        let mut k = 0;
        while k + 1 < n && matches!(self.items[k].join, Some(Join::Tangent { .. })) {
            k += 1;
        }
        // Backward pass: highest end speed of block 0.
        let mut cap_end = 0.0f64;
        for i in (1..=k).rev() {
            let it = &self.items[i];
            let start = if it.lim.a.is_infinite() {
                it.lim.v
            } else {
                it.lim
                    .v
                    .min((cap_end * cap_end + 2.0 * it.lim.a * it.lim.len).sqrt())
            };
            let jv = match self.items[i - 1].join {
                Some(Join::Tangent { v }) => v,
                _ => 0.0,
            };
            cap_end = start.min(jv).min(self.items[i - 1].lim.v);
        }
        let item = self.items.pop_front()?;
        let join = item.join.unwrap_or(Join::Stop);
        let profile = Profile::new(item.lim.len, self.v_in, cap_end, item.lim.v, item.lim.a);
        let t0 = match self.prev {
            None => 0.0,
            Some((p0, p1, Join::Blend { v }, p)) => {
                let overlap = if p.accel().is_finite() {
                    v.min(p.peak()) / p.accel()
                } else {
                    0.0
                };
                (p1 - overlap).max(p0)
            }
            Some((_, p1, _, _)) => p1,
        };
        self.v_in = match join {
            Join::Tangent { .. } => profile.end_speeds().1,
            _ => 0.0,
        };
        let t1 = t0 + profile.duration();
        self.prev = Some((t0, t1, join, profile));
        Some(Planned {
            payload: item.payload,
            profile,
            t0,
            join,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim(len: f64) -> Limits {
        Limits {
            len,
            v: 10.0,
            a: 100.0,
        }
    }

    fn run(lens: &[f64], join: Join, depth: usize) -> Vec<Planned<usize>> {
        let mut q = Lookahead::new(depth);
        let mut out = Vec::new();
        for (i, &l) in lens.iter().enumerate() {
            if let Some((_, _, j)) = q.last_mut() {
                *j = Some(join);
            }
            q.push(i, lim(l));
            while let Some(p) = q.pop_ready() {
                out.push(p);
            }
        }
        while let Some(p) = q.pop_flush() {
            out.push(p);
        }
        out
    }

    #[test]
    fn tangent_chain_takes_the_time_of_one_move() {
        // 10 blocks of 5: one move of 50 at v = 10, a = 100 takes
        // 50/10 + 10/100 = 5.1 s.
        let p = run(&[5.0; 10], Join::Tangent { v: 10.0 }, 50);
        let end = p.last().unwrap().t1();
        assert!((end - 5.1).abs() < 1e-12, "{end}");
        // Stops at every block: 10 × (0.5 + 0.1).
        let p = run(&[5.0; 10], Join::Stop, 50);
        assert!((p.last().unwrap().t1() - 6.0).abs() < 1e-12);
    }

    #[test]
    fn a_short_window_stays_safe_and_slower() {
        // Window of 2 blocks of 0.1 behind the one planned: at most
        // √(2·a·0.2) at its end, and √(2·a·0.3) within it (it can always
        // stop by the end of the window).
        let p = run(&[0.1; 40], Join::Tangent { v: 10.0 }, 2);
        for b in &p {
            assert!(b.profile.end_speeds().1 <= (2.0 * 100.0 * 0.2f64).sqrt() + 1e-9);
            assert!(b.profile.peak() <= (2.0 * 100.0 * 0.3f64).sqrt() + 1e-9);
        }
        let long = run(&[0.1; 40], Join::Tangent { v: 10.0 }, 100);
        assert!(p.last().unwrap().t1() > long.last().unwrap().t1());
        // Each block starts where the one before ends, at the same speed.
        for w in p.windows(2) {
            assert!((w[0].t1() - w[1].t0).abs() < 1e-12);
            assert!((w[0].profile.end_speeds().1 - w[1].profile.end_speeds().0).abs() < 1e-12);
        }
    }

    #[test]
    fn blends_overlap_by_the_deceleration_below_the_blend_speed() {
        // Two blocks of 10, rest to rest 1.1 s each; the second starts when
        // the first has slowed to 5: 5/100 = 0.05 s before its end.
        let p = run(&[10.0, 10.0], Join::Blend { v: 5.0 }, 50);
        assert!((p[1].t0 - (1.1 - 0.05)).abs() < 1e-12, "{}", p[1].t0);
        assert!((p[1].t1() - 2.15).abs() < 1e-12);
    }
}
