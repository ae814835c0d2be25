//! Node-block sparse symmetric matrices. The static pattern (which node pairs couple through the stencils of
//! the model's terms) is fixed once per model; values are `3×3` blocks for node pairs `i ≤ j`, added in place
//! through block ids that each term precomputes. [`BlockPattern::csc_upper`] gives the scalar upper-triangle
//! layout the solver fills.
//!
//! A step may also couple node pairs outside the static pattern (contact between two faces of the sheet): those
//! go into the matrix's [`ExtraBlocks`], a set of off-diagonal blocks keyed by node pair (its values are cleared
//! with the matrix, its pairs kept), so a solver re-analyses its structure only when the set changes
//! ([`ExtraBlocks::generation`]): when a pair joins, or when clearing the matrix drops the pairs the last
//! assembly left at zero once they are the majority ([`ExtraBlocks::prune`]; a pile's layers that have parted
//! would otherwise stay in the factor's structure for the rest of the run). Products include the extra blocks;
//! with none, every operation is the static pattern's alone, in the same order.

use crate::math::{Mat3, Vec3};
use std::collections::HashMap;

/// Block sparsity: for each column node `j`, the sorted row nodes `i ≤ j` it couples to (`j` itself last).
#[derive(Debug, Clone)]
pub struct BlockPattern {
    n: usize,
    col_start: Vec<usize>,
    rows: Vec<usize>,
}

impl BlockPattern {
    /// The pattern with every `(i, i)` and the given pairs (either order).
    pub fn from_pairs(n: usize, pairs: impl IntoIterator<Item = (usize, usize)>) -> Self {
        let mut cols: Vec<Vec<usize>> = (0..n).map(|j| vec![j]).collect();
        for (a, b) in pairs {
            let (i, j) = if a <= b { (a, b) } else { (b, a) };
            cols[j].push(i);
        }
        let mut col_start = Vec::with_capacity(n + 1);
        let mut rows = Vec::new();
        col_start.push(0);
        for mut c in cols {
            c.sort_unstable();
            c.dedup();
            rows.extend(c);
            col_start.push(rows.len());
        }
        Self { n, col_start, rows }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.n
    }

    /// Number of stored blocks.
    pub fn blocks(&self) -> usize {
        self.rows.len()
    }

    /// Block id of `(i, j)` with `i ≤ j`. Panics if the pair is not in the pattern (a programming error).
    pub fn find(&self, i: usize, j: usize) -> usize {
        self.get(i, j).expect("node pair outside the sparsity pattern")
    }

    /// Block id of node pair `(i, j)` (either order), `None` when the pattern does not couple them.
    pub fn get(&self, i: usize, j: usize) -> Option<usize> {
        let (i, j) = if i <= j { (i, j) } else { (j, i) };
        let r = &self.rows[self.col_start[j]..self.col_start[j + 1]];
        r.binary_search(&i).ok().map(|k| self.col_start[j] + k)
    }

    /// The node graph's upper triangle in compressed columns: column pointers and row nodes (sorted, the
    /// diagonal last), one entry a block.
    pub fn csc_nodes(&self) -> (&[usize], &[usize]) {
        (&self.col_start, &self.rows)
    }

    /// Scalar CSC structure of the upper triangle of the `3n × 3n` matrix, plus, for each scalar entry, the
    /// block id and the entry inside the block.
    pub fn csc_upper(&self) -> (Vec<usize>, Vec<usize>, Vec<(u32, u8)>) {
        let mut col_ptr = vec![0usize];
        let mut row_idx = Vec::new();
        let mut src = Vec::new();
        for j in 0..self.n {
            for b in 0..3 {
                for blk in self.col_start[j]..self.col_start[j + 1] {
                    let i = self.rows[blk];
                    let amax = if i == j { b + 1 } else { 3 };
                    for a in 0..amax {
                        row_idx.push(3 * i + a);
                        src.push((blk as u32, (3 * b + a) as u8));
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        (col_ptr, row_idx, src)
    }

    /// The block ids of column `j` (rows `i ≤ j` ascending, the diagonal last): `start..end`.
    #[inline]
    pub fn column(&self, j: usize) -> (usize, usize) {
        (self.col_start[j], self.col_start[j + 1])
    }

    /// Row node of each block (same order as block ids).
    pub fn block_rows(&self) -> &[usize] {
        &self.rows
    }

    /// Column node of every block.
    pub fn block_cols(&self) -> Vec<usize> {
        let mut out = vec![0; self.rows.len()];
        for j in 0..self.n {
            out[self.col_start[j]..self.col_start[j + 1]].fill(j);
        }
        out
    }
}

/// Off-diagonal node-pair blocks outside the static pattern, in the order their pairs first appeared.
#[derive(Debug, Clone, Default)]
pub struct ExtraBlocks {
    slots: HashMap<(usize, usize), usize>,
    pairs: Vec<(usize, usize)>,
    /// Block `s` holds rows of node `pairs[s].0`, columns of node `pairs[s].1` (`.0 < .1`).
    pub blocks: Vec<Mat3>,
    /// Changes of the set of pairs so far.
    generation: usize,
}

impl ExtraBlocks {
    /// Adds `h` = ∂²/∂x_a∂x_b (`a ≠ b`) to the pair's block, creating it when the pair is new.
    pub fn add(&mut self, a: usize, b: usize, h: Mat3) {
        let (key, h) = if a < b { ((a, b), h) } else { ((b, a), h.transpose()) };
        let slot = match self.slots.get(&key) {
            Some(&s) => s,
            None => {
                self.slots.insert(key, self.pairs.len());
                self.pairs.push(key);
                self.generation += 1;
                self.blocks.push(Mat3::ZERO);
                self.pairs.len() - 1
            }
        };
        self.blocks[slot] += h;
    }

    /// The pairs `(i, j)`, `i < j`, in slot order.
    pub fn pairs(&self) -> &[(usize, usize)] {
        &self.pairs
    }

    /// How many times the set of pairs has changed: a solver that analysed the structure at another
    /// generation analyses it again.
    pub fn generation(&self) -> usize {
        self.generation
    }

    /// Drops the pairs whose blocks are zero (none of the last assembly's terms coupled them) when they are
    /// more than half of the set, keeping the others in their order; true when it did. Held pairs cost fill in
    /// a factorisation whatever their values: measured on the 81² pile, whose layers touch and part, the set
    /// that only grew made each factorisation 3.4 times as costly as the sheet's alone.
    pub fn prune(&mut self) -> bool {
        let live = self.blocks.iter().filter(|b| **b != Mat3::ZERO).count();
        if 2 * live >= self.pairs.len() {
            return false;
        }
        let kept: Vec<((usize, usize), Mat3)> =
            self.pairs.iter().copied().zip(self.blocks.iter().copied()).filter(|(_, b)| *b != Mat3::ZERO).collect();
        (self.pairs, self.blocks) = kept.into_iter().unzip();
        self.slots = self.pairs.iter().enumerate().map(|(s, &p)| (p, s)).collect();
        self.generation += 1;
        true
    }

    /// Takes `next`'s pairs and blocks; the generation moves on only where the pairs differ (a solver that
    /// analysed the structure analyses it again only then).
    pub fn replace(&mut self, next: ExtraBlocks) {
        if next.pairs == self.pairs {
            self.blocks = next.blocks;
            return;
        }
        let generation = self.generation + 1;
        *self = next;
        self.generation = generation;
    }

    /// True when there are no extra pairs.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// The pairs in slot order with their blocks, as a checkpoint keeps them: which pairs a matrix holds, in
    /// which order, and which of them the last assembly left at zero depend on the run so far, and they decide
    /// the next steps' rounding (the products' order of summation, the factor's ordering, the next prune).
    pub fn saved(&self) -> ExtraSaved {
        ExtraSaved { pairs: self.pairs.clone(), blocks: self.blocks.iter().map(Mat3::to_cols_array).collect() }
    }

    /// The blocks of a [`ExtraBlocks::saved`] on a matrix of `nodes` nodes; an error where the saved pairs do
    /// not fit it (a node out of range, a pair not ordered or twice, counts that differ).
    pub fn from_saved(saved: &ExtraSaved, nodes: usize) -> Result<Self, String> {
        if saved.pairs.len() != saved.blocks.len() {
            return Err(format!("{} extra pairs but {} blocks", saved.pairs.len(), saved.blocks.len()));
        }
        let mut extra = Self::default();
        for (&(i, j), b) in saved.pairs.iter().zip(&saved.blocks) {
            if i >= j || j >= nodes || extra.slots.contains_key(&(i, j)) {
                return Err(format!("the extra pair ({i}, {j}) does not fit a matrix of {nodes} nodes"));
            }
            extra.add(i, j, Mat3::from_cols_array(b));
        }
        Ok(extra)
    }

    /// `y += A_extra x` (symmetric product).
    pub fn mul_add(&self, x: &[Vec3], y: &mut [Vec3]) {
        for (&(i, j), m) in self.pairs.iter().zip(&self.blocks) {
            y[i] += *m * x[j];
            y[j] += m.transpose() * x[i];
        }
    }
}

/// [`ExtraBlocks`] as a checkpoint holds them.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExtraSaved {
    /// The pairs `(i, j)`, `i < j`, in slot order.
    pub pairs: Vec<(usize, usize)>,
    /// Their blocks, column by column.
    pub blocks: Vec<[f64; 9]>,
}

/// Symmetric matrix stored as upper `3×3` node blocks on a [`BlockPattern`], plus the step's [`ExtraBlocks`].
#[derive(Debug, Clone)]
pub struct BlockMatrix {
    /// Blocks, indexed by block id; block `(i, j)`, `i ≤ j`, holds rows of node `i`, columns of node `j`.
    pub blocks: Vec<Mat3>,
    /// Blocks of node pairs outside the pattern.
    pub extra: ExtraBlocks,
}

impl BlockMatrix {
    /// Zero matrix on a pattern.
    pub fn zeros(pattern: &BlockPattern) -> Self {
        Self { blocks: vec![Mat3::ZERO; pattern.blocks()], extra: ExtraBlocks::default() }
    }

    /// Sets every block to zero. The extra pairs stay, with zero blocks, except that those the values being
    /// cleared left at zero go once they are the majority ([`ExtraBlocks::prune`]).
    pub fn clear(&mut self) {
        self.extra.prune();
        self.blocks.fill(Mat3::ZERO);
        self.extra.blocks.fill(Mat3::ZERO);
    }

    /// Adds local block `h` = ∂²/∂x_a∂x_b for global nodes `(a, b)` to block id `id`.
    #[inline]
    pub fn add(&mut self, id: u32, a: usize, b: usize, h: Mat3) {
        let blk = &mut self.blocks[id as usize];
        if a <= b {
            *blk += h;
        } else {
            *blk += h.transpose();
        }
    }

    /// `y += A x` (symmetric product), the extra blocks after the pattern's.
    pub fn mul_add(&self, pattern: &BlockPattern, x: &[Vec3], y: &mut [Vec3]) {
        for j in 0..pattern.n {
            for blk in pattern.col_start[j]..pattern.col_start[j + 1] {
                let i = pattern.rows[blk];
                let m = self.blocks[blk];
                y[i] += m * x[j];
                if i != j {
                    y[j] += m.transpose() * x[i];
                }
            }
        }
        self.extra.mul_add(x, y);
    }

    /// Dense copy (tests and small diagnostics only).
    pub fn to_dense(&self, pattern: &BlockPattern) -> Vec<Vec<f64>> {
        let n = 3 * pattern.n;
        let mut d = vec![vec![0.0; n]; n];
        for j in 0..pattern.n {
            for blk in pattern.col_start[j]..pattern.col_start[j + 1] {
                let i = pattern.rows[blk];
                let m = self.blocks[blk];
                for a in 0..3 {
                    for b in 0..3 {
                        let v = m.col(b)[a];
                        d[3 * i + a][3 * j + b] = v;
                        d[3 * j + b][3 * i + a] = v;
                    }
                }
            }
        }
        for (&(i, j), m) in self.extra.pairs().iter().zip(&self.extra.blocks) {
            for a in 0..3 {
                for b in 0..3 {
                    let v = m.col(b)[a];
                    d[3 * i + a][3 * j + b] += v;
                    d[3 * j + b][3 * i + a] += v;
                }
            }
        }
        d
    }
}

/// The full (both triangles) block-row copy of a [`BlockMatrix`]: each node's row of 3×3 blocks with its
/// column nodes, as a general sparse matrix of the step matrix's shape is stored. Its product is the unit of
/// work `flexsurf bench` divides a step by (a *matrix stream*, issue 23): every stored block and index read
/// once, one thread.
#[derive(Debug, Clone)]
pub struct BlockRows {
    row_start: Vec<usize>,
    cols: Vec<u32>,
    blocks: Vec<Mat3>,
}

impl BlockRows {
    /// The full copy of `a` on `pattern` (its extra pairs included).
    pub fn from_symmetric(a: &BlockMatrix, pattern: &BlockPattern) -> Self {
        let n = pattern.n;
        let mut rows: Vec<Vec<(usize, Mat3)>> = vec![Vec::new(); n];
        for j in 0..n {
            for blk in pattern.col_start[j]..pattern.col_start[j + 1] {
                let i = pattern.rows[blk];
                rows[i].push((j, a.blocks[blk]));
                if i != j {
                    rows[j].push((i, a.blocks[blk].transpose()));
                }
            }
        }
        for (&(i, j), m) in a.extra.pairs().iter().zip(&a.extra.blocks) {
            rows[i].push((j, *m));
            rows[j].push((i, m.transpose()));
        }
        let mut out = Self { row_start: vec![0], cols: Vec::new(), blocks: Vec::new() };
        for mut r in rows {
            r.sort_by_key(|e| e.0);
            out.cols.extend(r.iter().map(|e| e.0 as u32));
            out.blocks.extend(r.iter().map(|e| e.1));
            out.row_start.push(out.cols.len());
        }
        out
    }

    /// Rows (nodes).
    pub fn rows(&self) -> usize {
        self.row_start.len() - 1
    }

    /// Stored blocks (both triangles).
    pub fn blocks(&self) -> usize {
        self.blocks.len()
    }

    /// Bytes one product reads from the matrix (blocks, column indices, row starts).
    pub fn bytes(&self) -> usize {
        self.blocks.len() * std::mem::size_of::<Mat3>()
            + self.cols.len() * std::mem::size_of::<u32>()
            + self.row_start.len() * std::mem::size_of::<usize>()
    }

    /// `y = A x`, row by row.
    pub fn mul(&self, x: &[Vec3], y: &mut [Vec3]) {
        for (i, out) in y.iter_mut().enumerate().take(self.row_start.len() - 1) {
            let (a, b) = (self.row_start[i], self.row_start[i + 1]);
            let mut s = Vec3::ZERO;
            for (m, &j) in self.blocks[a..b].iter().zip(&self.cols[a..b]) {
                s += *m * x[j as usize];
            }
            *out = s;
        }
    }
}
