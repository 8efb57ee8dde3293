//! Measurement models: the trait every identification implements, the
//! block layout of its residuals, and [`Stack`], which joins several models
//! that share one parameter vector.
//!
//! Conventions:
//! * the residual vector `r(θ)` has `m` rows, grouped into *blocks* (a
//!   laser-tracker point is a block of 3 rows, a ballbar reading a block of
//!   1); the engine minimises the cost `½‖r(θ)‖²`;
//! * residuals are in the unit of the measurement (mm for tool-tip
//!   coordinates); a model that wants weights divides its rows by their
//!   standard deviation itself, so that all rows are comparable;
//! * the Jacobian is `J = ∂r/∂θ` (`m × n`), exact, supplied by the model.

use std::ops::Range;

use faer::MatMut;
use faer::reborrow::ReborrowMut;

use super::FitError;

/// One unknown of a measurement model.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// Name shown in reports, e.g. `EXX.c1` or `EY0A`.
    pub name: String,
    /// Typical magnitude of the parameter in its own unit (e.g. 1e-3 mm for
    /// a straightness coefficient, 1e-5 rad for a squareness), if known.
    /// It only enters the decision whether a Jacobian column is zero to
    /// rounding; see [`crate::fit::identifiability`].
    pub scale: Option<f64>,
}

impl Parameter {
    /// A parameter without a known typical scale.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            scale: None,
        }
    }

    /// A parameter with a typical scale (positive, in the parameter's unit).
    pub fn with_scale(name: impl Into<String>, scale: f64) -> Self {
        Self {
            name: name.into(),
            scale: Some(scale),
        }
    }
}

/// How the `m` residual rows are cut into blocks, and which labelled group
/// each block belongs to (per-group residual statistics are reported).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BlockLayout {
    /// Row offset of every block, plus the total row count at the end.
    starts: Vec<usize>,
    /// Group index of every block.
    group: Vec<usize>,
    /// Group labels, indexed by group.
    labels: Vec<String>,
}

impl Default for BlockLayout {
    fn default() -> Self {
        Self::new()
    }
}

impl BlockLayout {
    /// An empty layout; add blocks with [`BlockLayout::push_group`].
    pub fn new() -> Self {
        Self {
            starts: vec![0],
            group: Vec::new(),
            labels: Vec::new(),
        }
    }

    /// `count` blocks of `size` rows each, all in one group `label`.
    pub fn uniform(label: impl Into<String>, count: usize, size: usize) -> Self {
        Self::new().push_group(label, count, size)
    }

    /// Appends `count` blocks of `size` rows to the group `label` (created
    /// if it does not exist yet). Blocks of size 0 are ignored.
    pub fn push_group(mut self, label: impl Into<String>, count: usize, size: usize) -> Self {
        if size == 0 || count == 0 {
            return self;
        }
        let label = label.into();
        let g = self.group_index(&label);
        for _ in 0..count {
            let last = self.rows();
            self.starts.push(last + size);
            self.group.push(g);
        }
        self
    }

    /// Appends all blocks of `other` (groups merged by label).
    pub fn append(mut self, other: &BlockLayout) -> Self {
        for b in 0..other.blocks() {
            let g = self.group_index(&other.labels[other.group[b]]);
            let last = self.rows();
            self.starts.push(last + other.block_rows(b).len());
            self.group.push(g);
        }
        self
    }

    fn group_index(&mut self, label: &str) -> usize {
        match self.labels.iter().position(|l| l == label) {
            Some(g) => g,
            None => {
                self.labels.push(label.to_owned());
                self.labels.len() - 1
            }
        }
    }

    /// Total number of residual rows `m`.
    pub fn rows(&self) -> usize {
        // `starts` always holds at least the leading 0.
        self.starts[self.starts.len() - 1]
    }

    /// Number of blocks.
    pub fn blocks(&self) -> usize {
        self.group.len()
    }

    /// Rows of block `b`.
    pub fn block_rows(&self, b: usize) -> Range<usize> {
        self.starts[b]..self.starts[b + 1]
    }

    /// Group index of block `b`.
    pub fn block_group(&self, b: usize) -> usize {
        self.group[b]
    }

    /// Group labels, indexed by group.
    pub fn labels(&self) -> &[String] {
        &self.labels
    }

    /// The block that contains row `row`.
    pub fn block_of_row(&self, row: usize) -> usize {
        self.starts.partition_point(|&s| s <= row) - 1
    }

    /// Cuts the rows into consecutive chunks of about `target` rows that
    /// begin and end on block boundaries (a chunk holds at least one block).
    pub fn chunks(&self, target: usize) -> Vec<Range<usize>> {
        let mut out = Vec::new();
        let mut b = 0;
        while b < self.blocks() {
            let start = self.starts[b];
            let mut e = b + 1;
            while e < self.blocks() && self.starts[e + 1] - start <= target.max(1) {
                e += 1;
            }
            out.push(start..self.starts[e]);
            b = e;
        }
        out
    }
}

/// A measurement model: residuals and their exact Jacobian.
///
/// The engine only ever asks for row ranges that begin and end on block
/// boundaries of [`Model::layout`], possibly from several threads at once
/// (hence `Sync`), and never needs the whole Jacobian at once on the
/// normal-equation path.
pub trait Model: Sync {
    /// The unknowns θ, in order (`n` of them).
    fn parameters(&self) -> Vec<Parameter>;

    /// The block layout of the `m` residual rows.
    fn layout(&self) -> BlockLayout;

    /// Residual rows `rows` at θ into `r` (`r.len() == rows.len()`) and/or
    /// the Jacobian rows `rows` into `j` (`rows.len() × n`, every entry
    /// must be written), whichever is given: the one method a model
    /// implements. Both at once share the work (the kinematic chain is
    /// evaluated once for both).
    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    );

    /// Residual rows `rows` at θ into `out` ([`Model::evaluate`] without a
    /// Jacobian).
    fn residuals(&self, theta: &[f64], rows: Range<usize>, out: &mut [f64]) {
        self.evaluate(theta, rows, Some(out), None);
    }

    /// Jacobian rows `rows` at θ into `out` ([`Model::evaluate`] without
    /// residuals).
    fn jacobian(&self, theta: &[f64], rows: Range<usize>, out: MatMut<'_, f64>) {
        self.evaluate(theta, rows, None, Some(out));
    }

    /// Residuals and Jacobian together ([`Model::evaluate`] with both).
    fn residuals_and_jacobian(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: &mut [f64],
        j: MatMut<'_, f64>,
    ) {
        self.evaluate(theta, rows, Some(r), Some(j));
    }

    /// The Jacobian in factored form, if the model has one (see
    /// [`Factored`]); the normal-equation path then never forms Jacobian
    /// rows.
    fn factored(&self) -> Option<&dyn Factored> {
        None
    }
}

/// Functions sharing one basis vector in a [`Factored`] Jacobian.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FactorGroup {
    /// Length `K` of the basis vector (e.g. degree + 1 of a Chebyshev
    /// series; 1 for constants).
    pub basis_len: usize,
    /// First θ column of every function of the group; function `f` owns the
    /// `K` columns `offsets[f]..offsets[f] + K`.
    pub offsets: Vec<usize>,
}

/// A Jacobian that factors as `J[i, o_f + k] = G[i, f] · β_g(b)[k]`: every
/// parameter column belongs to exactly one *function* `f` (an error
/// component), of a group `g` of functions that share the basis vector
/// `β_g(b)` (`K_g` values, depending only on the block `b` of row `i`, e.g.
/// the Chebyshev polynomials of one axis position), and `G[i, f]` is the
/// derivative of residual row `i` with respect to the function's value.
///
/// Then `JᵀJ = Σ_b Σ_{g,h} (Σ_{i∈b} G[i,f]·G[i,f']) ⊗ β_g(b)·β_h(b)ᵀ`:
/// per block one outer product of basis vectors serves all function pairs
/// of two groups, which costs `Σ_{g,h} F_g F_h K_g K_h` per block instead
/// of `rows·n²` for dense rows (about three times less for three-row
/// tracker points), and `Jᵀr` costs `O(n)` per block.
pub trait Factored: Sync {
    /// The groups; functions are numbered group by group in this order.
    /// Together the groups must cover every parameter column once.
    fn groups(&self) -> Vec<FactorGroup>;

    /// For residual rows `rows` (whole blocks) at θ: the residuals into `r`,
    /// `G` into `g` (`rows.len() × F`, F functions in group order, every
    /// entry written) and the basis vectors of every block into `basis`
    /// (`blocks × Σ K_g`, groups side by side in order).
    fn residuals_and_factors(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: &mut [f64],
        g: MatMut<'_, f64>,
        basis: MatMut<'_, f64>,
    );
}

/// Several models stacked into one problem over the same parameter vector
/// (e.g. the four ballbar modes sharing the location errors). Every part
/// must declare the same parameters (names in the same order); a part
/// simply writes zero Jacobian columns for the parameters it does not see.
/// Each part's blocks keep their group labels, so give the parts distinct
/// labels (`mode1`, …) to get per-part residual statistics.
pub struct Stack<'a> {
    parts: Vec<&'a dyn Model>,
    /// First residual row of each part, plus the total.
    offsets: Vec<usize>,
    layout: BlockLayout,
    parameters: Vec<Parameter>,
}

impl<'a> Stack<'a> {
    /// Stacks `parts`, in order. Fails if there is no part or if the
    /// parts' parameter lists differ.
    pub fn new(parts: Vec<&'a dyn Model>) -> Result<Self, FitError> {
        let first = parts.first().ok_or(FitError::NoResiduals)?;
        let parameters = first.parameters();
        let mut layout = BlockLayout::new();
        let mut offsets = vec![0];
        for (i, part) in parts.iter().enumerate() {
            let p = part.parameters();
            if p.len() != parameters.len()
                || p.iter().zip(&parameters).any(|(a, b)| a.name != b.name)
            {
                return Err(FitError::StackParameters { part: i });
            }
            let l = part.layout();
            layout = layout.append(&l);
            offsets.push(layout.rows());
        }
        Ok(Self {
            parts,
            offsets,
            layout,
            parameters,
        })
    }

    /// Calls `f(part, local rows, offset into the caller's rows)` for every
    /// part that overlaps `rows`.
    fn for_parts(
        &self,
        rows: Range<usize>,
        mut f: impl FnMut(&dyn Model, Range<usize>, Range<usize>),
    ) {
        for (k, part) in self.parts.iter().enumerate() {
            let (lo, hi) = (self.offsets[k], self.offsets[k + 1]);
            let a = rows.start.max(lo);
            let b = rows.end.min(hi);
            if a < b {
                f(*part, a - lo..b - lo, a - rows.start..b - rows.start);
            }
        }
    }
}

impl Model for Stack<'_> {
    fn parameters(&self) -> Vec<Parameter> {
        self.parameters.clone()
    }

    fn layout(&self) -> BlockLayout {
        self.layout.clone()
    }

    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        mut r: Option<&mut [f64]>,
        mut j: Option<MatMut<'_, f64>>,
    ) {
        self.for_parts(rows, |part, local, dst| {
            let r = r.as_deref_mut().map(|r| &mut r[dst.clone()]);
            let j = j.as_mut().map(|j| {
                let n = j.ncols();
                j.rb_mut().submatrix_mut(dst.start, 0, dst.len(), n)
            });
            part.evaluate(theta, local, r, j)
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_rows_blocks_and_groups() {
        let l = BlockLayout::uniform("tracker", 4, 3).push_group("ballbar", 2, 1);
        assert_eq!(l.rows(), 14);
        assert_eq!(l.blocks(), 6);
        assert_eq!(l.block_rows(4), 12..13);
        assert_eq!(l.labels(), &["tracker".to_owned(), "ballbar".to_owned()]);
        assert_eq!(l.block_group(5), 1);
        assert_eq!(l.block_of_row(0), 0);
        assert_eq!(l.block_of_row(5), 1);
        assert_eq!(l.block_of_row(13), 5);
    }

    #[test]
    fn chunks_cover_rows_on_block_boundaries() {
        let l = BlockLayout::uniform("p", 10, 3);
        let c = l.chunks(7);
        assert_eq!(c, vec![0..6, 6..12, 12..18, 18..24, 24..30]);
        // A chunk target smaller than a block still makes progress.
        assert_eq!(l.chunks(1).len(), 10);
    }
}
