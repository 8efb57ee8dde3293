//! Gradient `Jᵀr` and normal matrix `JᵀJ` from a factored Jacobian
//! `J[i, o_f + k] = G[i, f]·β_g(b)[k]` (see [`Factored`]), without ever
//! forming Jacobian rows.
//!
//! For a pair of groups `(g, h)` and a set of blocks `b = 1..P`:
//!
//! `JᵀJ[o_f + k, o_f' + l] = Σ_b W_b[f, f']·β_g(b)[k]·β_h(b)[l]`,
//! `W_b[f, f'] = Σ_{i∈b} G[i, f]·G[i, f']`,
//!
//! i.e. one matrix product `Wᵀ·Z` of the `P × (F_g·F_h)` weights with the
//! `P × (K_g·K_h)` basis outer products. On the diagonal pairs (`g = h`)
//! only the function pairs `f ≤ f'` are formed (the rest is the mirror
//! image). The blocks are cut into tiles of a few hundred that rayon
//! processes in parallel, each with sequential matrix products into its own
//! accumulator (the tiles' `Z` stay in cache), and the accumulators are
//! summed per chunk; summation order differs from the dense path only by
//! rounding.

use std::ops::Range;

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

use super::problem::{BlockLayout, FactorGroup, Factored};

/// Blocks per tile (a tile's basis outer products, `K_g·K_h × TILE`, stay
/// in cache: 33² × 256 doubles = 2.2 MB for degree-32 series).
const TILE_BLOCKS: usize = 256;

/// One pair of groups `(g, h)`, `g ≥ h`.
struct Pair {
    g: usize,
    h: usize,
    /// Function pairs `(a, b)` (indices within the groups), the rows of
    /// the pair's accumulator.
    funcs: Vec<(usize, usize)>,
}

/// The fixed structure of a factored problem.
pub(crate) struct Plan {
    groups: Vec<FactorGroup>,
    /// First function of every group, plus the total `F`.
    fstart: Vec<usize>,
    /// First basis entry of every group, plus the total.
    bstart: Vec<usize>,
    pairs: Vec<Pair>,
}

impl Plan {
    pub fn new(groups: Vec<FactorGroup>) -> Self {
        let mut fstart = vec![0];
        let mut bstart = vec![0];
        for g in &groups {
            fstart.push(fstart[fstart.len() - 1] + g.offsets.len());
            bstart.push(bstart[bstart.len() - 1] + g.basis_len);
        }
        let mut pairs = Vec::new();
        for g in 0..groups.len() {
            for h in 0..=g {
                let (fg, fh) = (groups[g].offsets.len(), groups[h].offsets.len());
                let funcs = (0..fg)
                    .flat_map(|a| (0..fh).map(move |b| (a, b)))
                    .filter(|&(a, b)| g != h || a <= b)
                    .collect();
                pairs.push(Pair { g, h, funcs });
            }
        }
        Self {
            groups,
            fstart,
            bstart,
            pairs,
        }
    }

    /// Number of functions `F`.
    fn functions(&self) -> usize {
        self.fstart[self.fstart.len() - 1]
    }

    /// Basis values per block.
    fn basis_width(&self) -> usize {
        self.bstart[self.bstart.len() - 1]
    }

    /// θ column of entry `k` of function `a` of group `g`.
    fn column(&self, g: usize, a: usize, k: usize) -> usize {
        self.groups[g].offsets[a] + k
    }
}

/// Partial sums: the gradient and, if asked, one matrix per pair.
pub(crate) struct Sums {
    pub g: Vec<f64>,
    /// Per pair: `funcs.len() × K_g·K_h`, column-major.
    m: Vec<Mat<f64>>,
}

impl Sums {
    fn new(plan: &Plan, n: usize, normal: bool) -> Self {
        let m = if normal {
            plan.pairs
                .iter()
                .map(|p| {
                    Mat::zeros(
                        p.funcs.len(),
                        plan.groups[p.g].basis_len * plan.groups[p.h].basis_len,
                    )
                })
                .collect()
        } else {
            Vec::new()
        };
        Self { g: vec![0.0; n], m }
    }

    fn add(mut self, other: Sums) -> Self {
        self.g.iter_mut().zip(&other.g).for_each(|(a, b)| *a += b);
        for (a, b) in self.m.iter_mut().zip(&other.m) {
            *a += b;
        }
        self
    }

    /// The full `n × n` normal matrix (both halves).
    pub fn normal(&self, plan: &Plan, n: usize) -> Mat<f64> {
        let mut nm = Mat::<f64>::zeros(n, n);
        for (p, m) in plan.pairs.iter().zip(&self.m) {
            let kh = plan.groups[p.h].basis_len;
            for (row, &(a, b)) in p.funcs.iter().enumerate() {
                for c in 0..m.ncols() {
                    let (k, l) = (c / kh, c % kh);
                    let (i, j) = (plan.column(p.g, a, k), plan.column(p.h, b, l));
                    let v = m[(row, c)];
                    nm[(i, j)] = v;
                    nm[(j, i)] = v;
                }
            }
        }
        nm
    }
}

/// Per-thread working memory: partial sums and scratch buffers, kept for a
/// whole pass so that tiles allocate nothing.
pub(crate) struct Slot {
    sums: Sums,
    g: Vec<f64>,
    basis: Vec<f64>,
    wt: Vec<f64>,
    zt: Vec<f64>,
    s: Vec<f64>,
}

/// One [`Slot`] per rayon worker (plus one for a caller outside the pool).
pub(crate) struct Slots(Vec<std::sync::Mutex<Slot>>);

impl Slots {
    pub fn new(plan: &Plan, n: usize, normal: bool) -> Self {
        let count = rayon::current_num_threads() + 1;
        Self(
            (0..count)
                .map(|_| {
                    std::sync::Mutex::new(Slot {
                        sums: Sums::new(plan, n, normal),
                        g: Vec::new(),
                        basis: Vec::new(),
                        wt: Vec::new(),
                        zt: Vec::new(),
                        s: Vec::new(),
                    })
                })
                .collect(),
        )
    }

    /// The sum over all slots.
    pub fn total(self) -> Option<Sums> {
        self.0
            .into_iter()
            .map(|m| m.into_inner().unwrap_or_else(|e| e.into_inner()).sums)
            .reduce(Sums::add)
    }
}

/// Evaluates the model over `rows` (whole blocks) into the residual slice
/// `r` (zeroed rows for excluded blocks) and adds to the sums in `slots`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn accumulate(
    model: &dyn Factored,
    plan: &Plan,
    layout: &BlockLayout,
    included: &[bool],
    theta: &[f64],
    rows: Range<usize>,
    r: &mut [f64],
    slots: &Slots,
) {
    if rows.is_empty() {
        return;
    }
    // Tiles of TILE_BLOCKS blocks.
    let first = layout.block_of_row(rows.start);
    let last = layout.block_of_row(rows.end - 1) + 1;
    let mut tiles: Vec<(Range<usize>, &mut [f64])> = Vec::new();
    let mut rest = r;
    for b in (first..last).step_by(TILE_BLOCKS) {
        let e = (b + TILE_BLOCKS).min(last);
        let len = layout.block_rows(e - 1).end - layout.block_rows(b).start;
        let (a, tail) = rest.split_at_mut(len);
        tiles.push((b..e, a));
        rest = tail;
    }
    let each = |(blocks, r): (Range<usize>, &mut [f64])| {
        // Sequential work runs outside the pool (or on one of its threads,
        // alone): the last slot, or that thread's.
        let k = match rayon::current_thread_index() {
            Some(i) => i.min(slots.0.len() - 2),
            None => slots.0.len() - 1,
        };
        // Only this thread uses slot k (or, outside the pool, the last one).
        let mut slot = slots.0[k].lock().unwrap_or_else(|e| e.into_inner());
        tile(model, plan, layout, included, theta, blocks, r, &mut slot);
    };
    if crate::par::sequential() {
        tiles.into_iter().for_each(each);
    } else {
        tiles.into_par_iter().for_each(each);
    }
}

/// Adds one tile of blocks to the slot's sums.
#[allow(clippy::too_many_arguments)]
fn tile(
    model: &dyn Factored,
    plan: &Plan,
    layout: &BlockLayout,
    included: &[bool],
    theta: &[f64],
    blocks: Range<usize>,
    r: &mut [f64],
    slot: &mut Slot,
) {
    let Slot {
        sums,
        g: gbuf,
        basis: bbuf,
        wt,
        zt,
        s,
    } = slot;
    let f = plan.functions();
    let bw = plan.basis_width();
    let row0 = layout.block_rows(blocks.start).start;
    let nrows = r.len();
    let nb = blocks.len();
    // Row-major G (row i at i·F) and basis (block p at p·bw).
    gbuf.clear();
    gbuf.resize(nrows * f, 0.0);
    bbuf.clear();
    bbuf.resize(nb * bw, 0.0);
    model.residuals_and_factors(
        theta,
        row0..row0 + nrows,
        r,
        MatMut::from_column_major_slice_mut(gbuf, f, nrows).transpose_mut(),
        MatMut::from_column_major_slice_mut(bbuf, bw, nb).transpose_mut(),
    );
    for b in blocks.clone() {
        if !included[b] {
            for i in layout.block_rows(b) {
                r[i - row0] = 0.0;
                gbuf[(i - row0) * f..(i - row0 + 1) * f].fill(0.0);
            }
        }
    }
    let block_rows = |p: usize| {
        let br = layout.block_rows(blocks.start + p);
        br.start - row0..br.end - row0
    };
    // Gradient: s_f = Σ_{i∈b} G[i, f]·r_i, then g[o_f + k] += s_f·β_g[k].
    s.clear();
    s.resize(f, 0.0);
    for p in 0..nb {
        s.fill(0.0);
        for i in block_rows(p) {
            let gi = &gbuf[i * f..(i + 1) * f];
            s.iter_mut().zip(gi).for_each(|(a, &x)| *a += x * r[i]);
        }
        let beta = &bbuf[p * bw..(p + 1) * bw];
        for (gi, grp) in plan.groups.iter().enumerate() {
            let bg = &beta[plan.bstart[gi]..plan.bstart[gi + 1]];
            for (a, &o) in grp.offsets.iter().enumerate() {
                let sf = s[plan.fstart[gi] + a];
                sums.g[o..o + grp.basis_len]
                    .iter_mut()
                    .zip(bg)
                    .for_each(|(x, &y)| *x += sf * y);
            }
        }
    }
    if sums.m.is_empty() {
        return;
    }
    for (pair, m) in plan.pairs.iter().zip(sums.m.iter_mut()) {
        let (kg, kh) = (plan.groups[pair.g].basis_len, plan.groups[pair.h].basis_len);
        let (fg, fh) = (
            plan.fstart[pair.g]..plan.fstart[pair.g + 1],
            plan.fstart[pair.h]..plan.fstart[pair.h + 1],
        );
        let diagonal = pair.g == pair.h;
        let nf = pair.funcs.len();
        // Wᵀ: nf × nb, column p holds W_p over the function pairs (a, b),
        // b fastest, b ≥ a on the diagonal.
        wt.clear();
        wt.resize(nf * nb, 0.0);
        for (p, col) in wt.chunks_exact_mut(nf).enumerate() {
            for i in block_rows(p) {
                let gi = &gbuf[i * f..(i + 1) * f];
                let (ga, gb) = (&gi[fg.clone()], &gi[fh.clone()]);
                let mut pos = 0;
                for (a, &x) in ga.iter().enumerate() {
                    let gb = if diagonal { &gb[a..] } else { gb };
                    col[pos..pos + gb.len()]
                        .iter_mut()
                        .zip(gb)
                        .for_each(|(w, &y)| *w += x * y);
                    pos += gb.len();
                }
            }
        }
        // Zᵀ: kg·kh × nb, column p holds β_g ⊗ β_h (l fastest).
        zt.clear();
        zt.resize(kg * kh * nb, 0.0);
        let (bg0, bh0) = (plan.bstart[pair.g], plan.bstart[pair.h]);
        for (p, col) in zt.chunks_exact_mut(kg * kh).enumerate() {
            let beta = &bbuf[p * bw..(p + 1) * bw];
            let (bg, bh) = (&beta[bg0..bg0 + kg], &beta[bh0..bh0 + kh]);
            for (row, &x) in col.chunks_exact_mut(kh).zip(bg) {
                row.iter_mut().zip(bh).for_each(|(z, &y)| *z = x * y);
            }
        }
        matmul(
            m.as_mut(),
            Accum::Add,
            MatRef::from_column_major_slice(wt, nf, nb),
            MatRef::from_column_major_slice(zt, kg * kh, nb).transpose(),
            1.0,
            Par::Seq,
        );
    }
}

/// The structure for `model`, checked: every column covered exactly once.
pub(crate) fn plan_for(model: &dyn Factored, n: usize) -> Option<Plan> {
    let groups = model.groups();
    let mut seen = vec![false; n];
    for g in &groups {
        for &o in &g.offsets {
            for c in o..o + g.basis_len {
                if c >= n || seen[c] {
                    return None;
                }
                seen[c] = true;
            }
        }
    }
    seen.iter().all(|&s| s).then(|| Plan::new(groups))
}
