//! The smoother of a [`super::multigrid`] level: symmetric block Gauss–Seidel by grid lines. A fabric's
//! membrane is stiff along the warp and the weft and soft in shear (tensile/shear stiffness 100–400 for the
//! paper's cotton), so the step matrix couples a node's motion along `u1` hundreds of times more strongly to
//! its `u1` neighbours than to its `u2` ones, and the other way round for the weft: point smoothers leave
//! such errors rough, line smoothers remove them (the classic remedy for anisotropy, Trottenberg et al.,
//! *Multigrid*, §5.1). Each line's three components are solved together, so the stiff direction may point
//! anywhere in space (a draped sheet).
//!
//! A level's nodes are `m × n` (flat index `i + m j`). The `u1` lines (fixed `j`) are swept, then the `u2`
//! lines; the post-smoothing sweeps the same lines in the reverse order, so the cycle stays symmetric. Each
//! line's matrix is a principal submatrix (SPD) with a banded structure, factorised by a banded Cholesky at each
//! refill; a periodic line (or one closed on itself by a seam) is taken whole in zig-zag order, at twice the
//! bandwidth, rather than in halves, whose cuts left the stiff coupling along the ring to the Gauss–Seidel
//! sweep ([`split_far`]). Masked nodes (pinned) are never changed. The matrix's blocks outside its pattern (pairs
//! between faces) enter every residual, and a line's diagonal the norms of those it takes from the sweep before
//! ([`Family::lumps`]), so the smoother stays a contraction however stiff they are; nodes held together by them
//! are then relaxed two by two ([`Glued`]), so two layers pressed together move as one.
//!
//! The matrix is kept here by rows (both triangles), so the residuals of a line and the products run row by
//! row, split over rayon's threads with each row summed in a fixed order. A colour's residuals are computed
//! through the rows in node order and then gathered line by line: a `u2` line visited node by node would jump a
//! grid row between its rows, which memory prefetching does not follow (docs/performance.md).

use crate::math::{Mat3, Vec3};
use crate::sparse::{BlockMatrix, BlockPattern};
use rayon::prelude::*;

/// Rows per chunk of a parallel row operation.
const ROW_CHUNK: usize = 1024;

/// A symmetric block matrix by rows, refilled from the upper-triangle [`BlockMatrix`], its blocks rounded to
/// `f32`: the smoother is a preconditioner, and halving the bytes it streams halves its time (memory-bound).
/// Every product and sum runs in `f64`; conjugate gradients use the exact matrix.
#[derive(Debug, Clone)]
pub(crate) struct RowMatrix {
    start: Vec<u32>,
    col: Vec<u32>,
    /// For each entry: the upper block it copies, and whether transposed (a lower entry).
    src: Vec<(u32, bool)>,
    blocks: Vec<glam::Mat3>,
    /// The matrix's blocks outside the pattern ([`crate::sparse::ExtraBlocks`]: pairs between faces), by rows.
    extra: ExtraRows,
}

/// The extra blocks of a matrix by rows (both triangles), rebuilt when its set of pairs changes and refilled
/// with the rows. Without them the smoother and the coarse levels saw a self-contact pair's stiffness on its
/// nodes' diagonal blocks but not the coupling between them, a preconditioner of another matrix
/// (docs/performance.md, "Pairs between faces in the multigrid").
#[derive(Debug, Clone, Default)]
struct ExtraRows {
    /// The pairs the rows were built for, in the matrix's slot order.
    pairs: Vec<(usize, usize)>,
    start: Vec<u32>,
    col: Vec<u32>,
    /// For each entry: the extra block's slot, and whether transposed (the pair's second node's row).
    src: Vec<(u32, bool)>,
    blocks: Vec<glam::Mat3>,
}

impl ExtraRows {
    /// Rebuilds the rows when `a`'s pairs are not those they were built for, and refills their blocks.
    fn refill(&mut self, a: &BlockMatrix, n: usize) {
        if a.extra.pairs() != self.pairs.as_slice() {
            self.pairs = a.extra.pairs().to_vec();
            (self.start, self.col, self.src) = by_rows(n, self.pairs.iter().copied());
            if self.pairs.is_empty() {
                self.start.clear();
            }
            self.blocks = vec![glam::Mat3::ZERO; self.col.len()];
        }
        gather(&a.extra.blocks, &self.src, &mut self.blocks);
    }

    /// Whether the matrix has no extra blocks (then no rows are built).
    #[inline]
    fn is_empty(&self) -> bool {
        self.start.is_empty()
    }

    /// `Σ_c E_pc x_c` over the extra blocks of row `p` (the rows built: some pairs).
    #[inline]
    fn row_dot(&self, p: usize, x: &[Vec3]) -> Vec3 {
        let r = self.start[p] as usize..self.start[p + 1] as usize;
        self.blocks[r.clone()].iter().zip(&self.col[r]).fold(Vec3::ZERO, |s, (m, &c)| s + m.as_dmat3() * x[c as usize])
    }

    /// Bytes one pass over the rows reads.
    fn bytes(&self) -> usize {
        self.blocks.len() * (std::mem::size_of::<glam::Mat3>() + 4) + self.start.len() * 4
    }
}

/// The rows (both triangles) of symmetric blocks on node pairs `(i, j)`, `i ≤ j`, the `k`-th pair's block being
/// block `k`: the row starts, each entry's column node, and its block and whether that is read transposed (a lower
/// entry), each row by column. The pattern's rows and the extra blocks' rows are built alike.
fn by_rows(n: usize, pairs: impl Iterator<Item = (usize, usize)>) -> (Vec<u32>, Vec<u32>, Vec<(u32, bool)>) {
    let mut per_row: Vec<Vec<(u32, u32, bool)>> = vec![Vec::new(); n];
    for (k, (i, j)) in pairs.enumerate() {
        per_row[i].push((j as u32, k as u32, false));
        if i != j {
            per_row[j].push((i as u32, k as u32, true));
        }
    }
    let mut start = Vec::with_capacity(n + 1);
    let (mut col, mut src) = (Vec::new(), Vec::new());
    start.push(0);
    for mut r in per_row {
        r.sort_unstable_by_key(|e| e.0);
        for (c, k, t) in r {
            col.push(c);
            src.push((k, t));
        }
        start.push(col.len() as u32);
    }
    (start, col, src)
}

/// `out[e]`: the block `src[e]` of `blocks` (transposed where marked), rounded to `f32`; over the threads for many.
fn gather(blocks: &[Mat3], src: &[(u32, bool)], out: &mut [glam::Mat3]) {
    let fill = |(out, &(k, t)): (&mut glam::Mat3, &(u32, bool))| {
        let m = blocks[k as usize];
        *out = if t { m.transpose() } else { m }.as_mat3();
    };
    if out.len() > ROW_CHUNK * 16 {
        out.par_iter_mut().zip(src.par_iter()).with_min_len(ROW_CHUNK * 16).for_each(fill);
    } else {
        out.iter_mut().zip(src.iter()).for_each(fill);
    }
}

impl RowMatrix {
    fn new(pattern: &BlockPattern) -> Self {
        let rows = pattern.block_rows();
        let pairs = (0..pattern.nodes()).flat_map(|j| {
            let (s, e) = pattern.column(j);
            rows[s..e].iter().map(move |&i| (i, j))
        });
        let (start, col, src) = by_rows(pattern.nodes(), pairs);
        let blocks = vec![glam::Mat3::ZERO; col.len()];
        Self { start, col, src, blocks, extra: ExtraRows::default() }
    }

    /// Bytes one pass over the rows reads: the `f32` blocks, their column indices and the row starts.
    fn bytes(&self) -> usize {
        self.blocks.len() * (std::mem::size_of::<glam::Mat3>() + 4) + self.start.len() * 4 + self.extra.bytes()
    }

    fn refill(&mut self, a: &BlockMatrix) {
        self.extra.refill(a, self.start.len() - 1);
        gather(&a.blocks, &self.src, &mut self.blocks);
    }

    #[inline]
    fn row(&self, p: usize) -> std::ops::Range<usize> {
        self.start[p] as usize..self.start[p + 1] as usize
    }

    /// `Σ_c A_pc x_c` over row `p`, the even and the odd entries in two sums added at the end (two chains of
    /// additions instead of one: the row's latency halves, and the order stays fixed).
    #[inline]
    fn row_dot(&self, p: usize, x: &[Vec3]) -> Vec3 {
        let r = self.row(p);
        let (blocks, cols) = (&self.blocks[r.clone()], &self.col[r]);
        let term = |m: &glam::Mat3, c: u32| m.as_dmat3() * x[c as usize];
        let (mut even, mut odd) = (Vec3::ZERO, Vec3::ZERO);
        for (m, c) in blocks.chunks_exact(2).zip(cols.chunks_exact(2)) {
            even += term(&m[0], c[0]);
            odd += term(&m[1], c[1]);
        }
        if let (Some(m), Some(&c)) =
            (blocks.chunks_exact(2).remainder().first(), cols.chunks_exact(2).remainder().first())
        {
            even += term(m, c);
        }
        if self.extra.is_empty() {
            even + odd
        } else {
            even + odd + self.extra.row_dot(p, x)
        }
    }

    /// The block `(p, c)`, zero when not stored.
    fn get(&self, p: usize, c: usize) -> Mat3 {
        let r = self.row(p);
        match self.col[r.clone()].binary_search(&(c as u32)) {
            Ok(k) => self.blocks[r.start + k].as_dmat3(),
            Err(_) => Mat3::ZERO,
        }
    }

    /// `out = f(p, row p · x)` for every row, over the threads for long vectors.
    fn rows_map(&self, x: &[Vec3], out: &mut [Vec3], f: impl Fn(usize, Vec3) -> Vec3 + Sync) {
        if out.len() > ROW_CHUNK {
            out.par_chunks_mut(ROW_CHUNK).enumerate().for_each(|(c, chunk)| {
                for (k, o) in chunk.iter_mut().enumerate() {
                    let p = c * ROW_CHUNK + k;
                    *o = f(p, self.row_dot(p, x));
                }
            });
        } else {
            for (p, o) in out.iter_mut().enumerate() {
                *o = f(p, self.row_dot(p, x));
            }
        }
    }
}

/// One line (or a piece of one): its nodes in the order of its band, and its banded factor.
#[derive(Debug, Clone)]
struct Segment {
    nodes: Vec<u32>,
    /// Half-bandwidth in scalars, `3 R + 2` for couplings `R` positions apart in `nodes`.
    w: usize,
    /// Where each node's residual is in its colour's [`Family::sorted`] order.
    gather: Vec<u32>,
    /// Lower band of the scalar Cholesky factor, `(3 len) × (w + 1)`: entry `(i, i − d)` at `i (w + 1) + d`, each
    /// diagonal entry as its reciprocal; factorised in `f64`, stored in `f32` (read twice a cycle: half the
    /// bytes), as the rows the smoother reads are.
    band: Vec<f32>,
}

/// The lines of one direction, ordered by colour: segments of one colour share no coupling, so they are
/// relaxed at the same time (over rayon's threads) with the same result as one after the other.
#[derive(Debug, Clone)]
struct Family {
    segments: Vec<Segment>,
    /// The colours' ranges in `segments`.
    colors: Vec<std::ops::Range<usize>>,
    /// Each colour's nodes in increasing order: a colour's residuals are computed in this order, through the
    /// matrix's rows as they lie in memory (a line across the rows' order, node by node, would jump a grid row
    /// at every node).
    sorted: Vec<Vec<u32>>,
    /// Scalars of scratch per segment (three per node of the longest).
    stride: usize,
    /// Each node's colour (`u32::MAX`: on no segment).
    color_of: Vec<u32>,
}

/// Symmetric line Gauss–Seidel of one level.
#[derive(Debug, Clone)]
pub(crate) struct LineSmoother {
    rows: RowMatrix,
    families: [Family; 2],
    masked: Vec<bool>,
    /// Nodes held together by pairs between faces, relaxed two by two after the lines.
    glued: Glued,
}

/// Pairs of nodes matched along their stiffest extra blocks (two layers held together), each relaxed as one
/// 6 × 6 system after the line sweeps (before them in the post-smoothing, in reverse order): the layers' glued
/// motion, which a line's relaxation takes from the sweep before, moves as one there.
#[derive(Debug, Clone, Default)]
struct Glued {
    pairs: Vec<(u32, u32)>,
    /// Per pair: `A_pp⁻¹`, `A_pq`, `A_pp⁻¹ A_pq`, the Schur complement's inverse `(A_qq − A_qp A_pp⁻¹ A_pq)⁻¹`.
    blocks: Vec<[Mat3; 4]>,
}

impl Glued {
    /// Matches each node (in order) with its unmatched partner of the stiffest extra block, and inverts each
    /// pair's system.
    fn refill(&mut self, rows: &RowMatrix, masked: &[bool]) {
        self.pairs.clear();
        self.blocks.clear();
        let extra = &rows.extra;
        if extra.is_empty() {
            return;
        }
        let n = masked.len();
        let mut matched = masked.to_vec();
        for p in 0..n {
            if matched[p] {
                continue;
            }
            let r = extra.start[p] as usize..extra.start[p + 1] as usize;
            let best = extra.col[r.clone()]
                .iter()
                .zip(&extra.blocks[r])
                .filter(|(&q, _)| !matched[q as usize])
                .map(|(&q, e)| (frobenius(e), q, e))
                .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
            let Some((_, q, e)) = best else { continue };
            let (a, c, b) = (rows.get(p, p), rows.get(q as usize, q as usize), e.as_dmat3());
            let ainv = a.inverse();
            let k = ainv * b;
            let sinv = (c - b.transpose() * k).inverse();
            if !(ainv.is_finite() && sinv.is_finite()) {
                continue;
            }
            matched[p] = true;
            matched[q as usize] = true;
            self.pairs.push((p as u32, q));
            self.blocks.push([ainv, b, k, sinv]);
        }
    }

    /// Relaxes every pair in turn (`forward`: in order, else in reverse): `x_S += A_SS⁻¹ (b − A x)_S`.
    fn relax(&self, rows: &RowMatrix, b: &[Vec3], x: &mut [Vec3], forward: bool) {
        let mut one = |(&(p, q), m): (&(u32, u32), &[Mat3; 4])| {
            let (p, q) = (p as usize, q as usize);
            let (r1, r2) = (b[p] - rows.row_dot(p, x), b[q] - rows.row_dot(q, x));
            let y1 = m[0] * r1;
            let d2 = m[3] * (r2 - m[1].transpose() * y1);
            x[p] += y1 - m[2] * d2;
            x[q] += d2;
        };
        match forward {
            true => self.pairs.iter().zip(&self.blocks).for_each(&mut one),
            false => self.pairs.iter().zip(&self.blocks).rev().for_each(&mut one),
        }
    }
}

/// The Frobenius norm of a stored block (a bound of its spectral norm), in `f64`.
fn frobenius(m: &glam::Mat3) -> f64 {
    m.to_cols_array().iter().map(|&v| f64::from(v) * f64::from(v)).sum::<f64>().sqrt()
}

/// Couplings farther apart than this along a line split it (a line closed on itself through a seam).
const FAR: usize = 4;

/// Each node's segment and position in it (`u32::MAX`: none).
fn positions(n: usize, lines: &[Vec<u32>]) -> (Vec<u32>, Vec<u32>) {
    let (mut seg_of, mut pos) = (vec![u32::MAX; n], vec![0u32; n]);
    for (s, nodes) in lines.iter().enumerate() {
        for (k, &p) in nodes.iter().enumerate() {
            seg_of[p as usize] = s as u32;
            pos[p as usize] = k as u32;
        }
    }
    (seg_of, pos)
}

/// Per segment, the widest coupling along it (positions apart), and the pairs of segments that couple.
fn couplings(pattern: &BlockPattern, lines: &[Vec<u32>]) -> (Vec<usize>, Vec<(u32, u32)>) {
    let n = pattern.nodes();
    let (seg_of, pos) = positions(n, lines);
    let rows = pattern.block_rows();
    let mut reach = vec![0; lines.len()];
    let mut edges = Vec::new();
    for j in 0..n {
        let (s, e) = pattern.column(j);
        for &i in &rows[s..e] {
            let (si, sj) = (seg_of[i], seg_of[j]);
            if si == u32::MAX || sj == u32::MAX {
                continue;
            }
            if si == sj {
                let r = &mut reach[si as usize];
                *r = (*r).max((pos[i] as i64 - pos[j] as i64).unsigned_abs() as usize);
            } else {
                edges.push((si.min(sj), si.max(sj)));
            }
        }
    }
    (reach, edges)
}

/// A line's nodes in zig-zag order, `(0, n − 1, 1, n − 2, …)`: on a line closed on itself (a periodic grid's
/// ring, a panel joined to itself by a seam) neighbours `R` apart along the ring, across the closure
/// included, are at most `2 R` positions apart, so the whole ring is one banded solve of twice the bandwidth.
fn zigzag(line: &[u32]) -> Vec<u32> {
    let n = line.len();
    (0..n).map(|k| if k % 2 == 0 { line[k / 2] } else { line[n - 1 - k / 2] }).collect()
}

/// The lines with every one whose couplings reach farther than [`FAR`] along it first put in zig-zag order
/// ([`zigzag`]: a line closed on itself, whose two ends couple, stays whole), then every one that still reaches
/// farther split in halves, until none does. Split in halves, a closed line left the coupling across its cuts to
/// the Gauss–Seidel sweep between colours, which the stiff membrane along the ring made the multigrid's
/// bottleneck (a 96 × 24 tube: 43 iterations with halves, 10 whole; docs/performance.md, "Periodic lines solved
/// whole").
fn split_far(pattern: &BlockPattern, lines: Vec<Vec<u32>>) -> Vec<Vec<u32>> {
    let far = |r: usize, l: &[u32]| r > FAR && l.len() >= 4;
    let (reach, _) = couplings(pattern, &lines);
    let mut lines: Vec<Vec<u32>> =
        lines.into_iter().zip(reach).map(|(l, r)| if far(r, &l) { zigzag(&l) } else { l }).collect();
    loop {
        let (reach, _) = couplings(pattern, &lines);
        if !reach.iter().zip(&lines).any(|(&r, l)| far(r, l)) {
            return lines;
        }
        lines = lines
            .into_iter()
            .zip(reach)
            .flat_map(|(l, r)| {
                if far(r, &l) {
                    let half = l.len() / 2;
                    vec![l[..half].to_vec(), l[half..].to_vec()]
                } else {
                    vec![l]
                }
            })
            .collect();
    }
}

impl Family {
    fn new(pattern: &BlockPattern, lines: Vec<Vec<u32>>) -> Self {
        let lines = split_far(pattern, lines);
        // The widest coupling along a segment, and which segments couple, from the pattern.
        let (reaches, mut edges) = couplings(pattern, &lines);
        edges.sort_unstable();
        edges.dedup();
        let count = lines.len();
        let mut adjacent: Vec<Vec<u32>> = vec![Vec::new(); count];
        for &(a, b) in &edges {
            adjacent[a as usize].push(b);
            adjacent[b as usize].push(a);
        }
        // Greedy colouring in segment order (deterministic).
        let mut color = vec![usize::MAX; count];
        for s in 0..count {
            let used: Vec<usize> =
                adjacent[s].iter().map(|&t| color[t as usize]).filter(|&c| c != usize::MAX).collect();
            color[s] = (0..).find(|c| !used.contains(c)).unwrap_or(0);
        }
        let colors_n = color.iter().copied().max().map_or(0, |c| c + 1);
        let stride = 3 * lines.iter().map(Vec::len).max().unwrap_or(0);
        let mut tagged: Vec<(usize, Vec<u32>, usize)> =
            lines.into_iter().zip(reaches).enumerate().map(|(s, (l, r))| (color[s], l, r)).collect();
        tagged.sort_by_key(|t| t.0);
        let mut colors = Vec::with_capacity(colors_n);
        let mut begin = 0;
        for c in 0..colors_n {
            let end = begin + tagged[begin..].iter().take_while(|t| t.0 == c).count();
            colors.push(begin..end);
            begin = end;
        }
        let mut segments: Vec<Segment> = tagged
            .into_iter()
            .map(|(_, nodes, reach)| {
                let w = 3 * reach + 2;
                Segment { band: vec![0.0; 3 * nodes.len() * (w + 1)], gather: Vec::new(), nodes, w }
            })
            .collect();
        let sorted = colors
            .iter()
            .map(|c| {
                let mut nodes: Vec<u32> = segments[c.clone()].iter().flat_map(|s| s.nodes.iter().copied()).collect();
                nodes.sort_unstable();
                for seg in &mut segments[c.clone()] {
                    seg.gather = seg.nodes.iter().map(|p| nodes.binary_search(p).unwrap_or(0) as u32).collect();
                }
                nodes
            })
            .collect();
        let mut color_of = vec![u32::MAX; pattern.nodes()];
        for (c, range) in colors.iter().enumerate() {
            for p in segments[range.clone()].iter().flat_map(|s| &s.nodes) {
                color_of[*p as usize] = c as u32;
            }
        }
        Self { segments, colors, sorted, stride, color_of }
    }

    /// For each node, the summed norms (Frobenius) of its extra blocks to nodes of its own colour, which a colour's
    /// relaxation takes from the values before it rather than solving them with its lines (the colouring is the
    /// pattern's; pairs between faces come and go with the steps, and a Galerkin level smears them onto nearby
    /// nodes of one line). Added to the lines' diagonal blocks `M` it keeps every relaxation a contraction in the
    /// energy norm however stiff the pairs are: with `E` the colour's extra blocks and `L` these sums,
    /// `L − E` is positive semidefinite (each block's `[[‖E‖ I, −E], [−Eᵀ, ‖E‖ I]]` is), so the lines' matrices
    /// `A_cc − E + L ≥ A_cc` stay positive definite (without it a line of a coarse level whose own couplings
    /// are only part of a pair's rank-one stiffness was indefinite) and `2 M − A_cc = A_cc + 2 (L − E)` is too: the
    /// cycle stays a positive definite preconditioner. Empty without extra blocks.
    fn lumps(&self, extra: &ExtraRows) -> Vec<f64> {
        if extra.is_empty() {
            return Vec::new();
        }
        (0..self.color_of.len())
            .map(|p| {
                let r = extra.start[p] as usize..extra.start[p + 1] as usize;
                let own = |&(_, &q): &(&glam::Mat3, &u32)| self.color_of[q as usize] == self.color_of[p];
                extra.blocks[r.clone()].iter().zip(&extra.col[r]).filter(own).map(|(m, _)| frobenius(m)).sum::<f64>()
            })
            .collect()
    }

    /// Scratch scalars for relaxing the largest colour: its segments' right-hand sides, then its residuals in
    /// node order.
    fn scratch_len(&self) -> usize {
        self.colors.iter().zip(&self.sorted).map(|(c, s)| c.len() * self.stride + 3 * s.len()).max().unwrap_or(0)
    }
}

/// The lines along direction `d` (0: `u1`, fixed `j`; 1: `u2`, fixed `i`) of an `m × n` grid, in grid order; a
/// periodic one, whose ends couple, is put in zig-zag order by [`LineSmoother::new`] ([`split_far`]).
pub(crate) fn grid_lines(m: usize, n: usize, d: usize) -> Vec<Vec<u32>> {
    let (count, len) = if d == 0 { (n, m) } else { (m, n) };
    let node = |line: usize, k: usize| if d == 0 { (k + m * line) as u32 } else { (line + m * k) as u32 };
    (0..count).map(|line| (0..len).map(|k| node(line, k)).collect()).collect()
}

impl LineSmoother {
    /// The smoother of a level with `pattern` relaxing `lines` (the `u1` lines and the `u2` lines of its
    /// panels, each node on one line of each); `masked` nodes are never changed.
    pub(crate) fn new(pattern: &BlockPattern, lines: [Vec<Vec<u32>>; 2], masked: &[bool]) -> Self {
        let [first, second] = lines;
        let families = [Family::new(pattern, first), Family::new(pattern, second)];
        Self { rows: RowMatrix::new(pattern), families, masked: masked.to_vec(), glued: Glued::default() }
    }

    /// Row `p` of the level's matrix as the last refill stored it (`f32` blocks): its column nodes and blocks.
    pub(crate) fn row(&self, p: usize) -> (&[u32], &[glam::Mat3]) {
        let r = self.rows.row(p);
        (&self.rows.col[r.clone()], &self.rows.blocks[r])
    }

    /// Copies `a` and factorises every line.
    pub(crate) fn refill(&mut self, a: &BlockMatrix) {
        self.rows.refill(a);
        self.glued.refill(&self.rows, &self.masked);
        let (rows, masked) = (&self.rows, &self.masked);
        for family in &mut self.families {
            let lumps = family.lumps(&rows.extra);
            family
                .segments
                .par_iter_mut()
                .with_min_len(16)
                .for_each_init(Vec::new, |band, seg| factor_segment(rows, masked, &lumps, seg, band));
        }
    }

    /// `r = b − A x` (masked rows zero).
    pub(crate) fn residual(&self, b: &[Vec3], x: &[Vec3], r: &mut [Vec3]) {
        let masked = &self.masked;
        self.rows.rows_map(x, r, |p, ax| if masked[p] { Vec3::ZERO } else { b[p] - ax });
    }

    /// Bytes the pre-smoothing, the residual after it and the post-smoothing read and write (docs/performance.md,
    /// "Bytes an iteration"): five passes over the rows (each family's sweep reaches every row once, before and
    /// after the coarse correction, and the residual once; the pre-smoothing's first colour, which starts from
    /// zero and skips its products, is counted: an upper bound), every line's band factor and gather indices
    /// twice (solved before and after), and twelve passes over the level's vectors (`b`, `x`, the residual and
    /// the lines' right-hand sides).
    pub(crate) fn cycle_bytes(&self) -> usize {
        let lines: usize = self
            .families
            .iter()
            .flat_map(|f| &f.segments)
            .map(|s| s.band.len() * 4 + (s.gather.len() + s.nodes.len()) * 4)
            .sum();
        5 * self.rows.bytes() + 2 * lines + 12 * self.masked.len() * std::mem::size_of::<Vec3>()
    }

    /// Bytes [`LineSmoother::residual`] reads and writes: one pass over the rows and three over the vectors.
    pub(crate) fn residual_bytes(&self) -> usize {
        self.rows.bytes() + 3 * self.masked.len() * std::mem::size_of::<Vec3>()
    }

    /// Scratch scalars [`LineSmoother::pre`] and [`LineSmoother::post`] need.
    pub(crate) fn scratch_len(&self) -> usize {
        self.families.iter().map(Family::scratch_len).max().unwrap_or(0)
    }

    /// Pre-smoothing from `x = 0`: the `u1` lines, then the `u2` lines, colour by colour. `scratch` holds at
    /// least [`LineSmoother::scratch_len`] scalars.
    pub(crate) fn pre(&self, b: &[Vec3], x: &mut [Vec3], scratch: &mut [f64]) {
        x.iter_mut().for_each(|v| *v = Vec3::ZERO);
        for (f, family) in self.families.iter().enumerate() {
            for k in 0..family.colors.len() {
                // The first colour sees `x = 0`: its residual is `b`, without a product.
                self.relax(family, k, b, x, scratch, f == 0 && k == 0);
            }
        }
        self.glued.relax(&self.rows, b, x, true);
    }

    /// Post-smoothing: the adjoint of [`LineSmoother::pre`] (the `u2` lines, then the `u1` lines, the colours
    /// in reverse order).
    pub(crate) fn post(&self, b: &[Vec3], x: &mut [Vec3], scratch: &mut [f64]) {
        self.glued.relax(&self.rows, b, x, false);
        for family in self.families.iter().rev() {
            for k in (0..family.colors.len()).rev() {
                self.relax(family, k, b, x, scratch, false);
            }
        }
    }

    /// Block Gauss–Seidel on the segments of colour `color`: `x_l += A_ll⁻¹ (b − A x)_l` for each (`x = 0` on
    /// entry when `zero`, so the residual is `b`).
    fn relax(&self, family: &Family, color: usize, b: &[Vec3], x: &mut [Vec3], scratch: &mut [f64], zero: bool) {
        let segs = &family.segments[family.colors[color].clone()];
        let order = &family.sorted[color];
        let (buf, rest) = scratch.split_at_mut(segs.len() * family.stride);
        let residuals = &mut rest[..3 * order.len()];
        let (rows, masked) = (&self.rows, &self.masked);
        let xr: &[Vec3] = x;
        let fill = |(out, nodes): (&mut [f64], &[u32])| {
            for (o, &p) in out.chunks_exact_mut(3).zip(nodes) {
                let p = p as usize;
                let r = match (masked[p], zero) {
                    (true, _) => Vec3::ZERO,
                    (false, true) => b[p],
                    (false, false) => b[p] - rows.row_dot(p, xr),
                };
                o.copy_from_slice(&r.to_array());
            }
        };
        let parallel = segs.len() > 1 && order.len() > 4 * ROW_CHUNK;
        if parallel {
            residuals.par_chunks_mut(3 * ROW_CHUNK).zip(order.par_chunks(ROW_CHUNK)).for_each(fill);
        } else {
            fill((residuals, order));
        }
        let residuals: &[f64] = residuals;
        let solve = |(seg, out): (&Segment, &mut [f64])| {
            let rhs = &mut out[..3 * seg.nodes.len()];
            for (r, &g) in rhs.chunks_exact_mut(3).zip(&seg.gather) {
                r.copy_from_slice(&residuals[3 * g as usize..3 * g as usize + 3]);
            }
            band_solve(&seg.band, seg.w, rhs);
        };
        if parallel {
            segs.par_iter().zip(buf.par_chunks_mut(family.stride)).for_each(solve);
        } else {
            segs.iter().zip(buf.chunks_mut(family.stride)).for_each(solve);
        }
        for (seg, out) in segs.iter().zip(buf.chunks(family.stride)) {
            for (k, &p) in seg.nodes.iter().enumerate() {
                if !masked[p as usize] {
                    x[p as usize] += Vec3::new(out[3 * k], out[3 * k + 1], out[3 * k + 2]);
                }
            }
        }
    }
}

/// Fills and factorises one segment's banded matrix (masked nodes, and nodes without stiffness, as identity), in
/// `f64` in the thread's scratch `band`, and stores the factor in `f32`.
fn factor_segment(rows: &RowMatrix, masked: &[bool], lumps: &[f64], seg: &mut Segment, band: &mut Vec<f64>) {
    let (len, w) = (seg.nodes.len(), seg.w);
    let stride = w + 1;
    band.clear();
    band.resize(seg.band.len(), 0.0);
    let reach = (w - 2) / 3;
    for a in 0..len {
        let p = seg.nodes[a] as usize;
        for back in 0..=reach.min(a) {
            let bnode = a - back;
            let q = seg.nodes[bnode] as usize;
            let block = if masked[p] || masked[q] {
                if back == 0 {
                    Mat3::IDENTITY
                } else {
                    Mat3::ZERO
                }
            } else if back == 0 && !lumps.is_empty() {
                rows.get(p, q) + Mat3::from_diagonal(Vec3::splat(lumps[p]))
            } else {
                rows.get(p, q)
            };
            // Scalar (3a + r, 3 bnode + c) with 3a + r ≥ 3 bnode + c.
            for r in 0..3 {
                for c in 0..3 {
                    let (i, j) = (3 * a + r, 3 * bnode + c);
                    if j <= i {
                        band[i * stride + (i - j)] = block.col(c)[r];
                    }
                }
            }
        }
    }
    band_factor(band, w, 3 * len);
    for (stored, v) in seg.band.iter_mut().zip(band.iter()) {
        *stored = *v as f32;
    }
}

/// In-place banded Cholesky `A = L Lᵀ` (lower band, `(i, i − d)` at `i (w + 1) + d`), each diagonal entry
/// stored as its reciprocal, so that the solves multiply. A pivot that is not positive (a node with no
/// stiffness) is replaced by the unit pivot, which keeps the smoother symmetric and positive definite.
fn band_factor(band: &mut [f64], w: usize, n: usize) {
    let stride = w + 1;
    for i in 0..n {
        let lo = i.saturating_sub(w);
        for j in lo..=i {
            let mut s = band[i * stride + (i - j)];
            for k in lo.max(j.saturating_sub(w))..j {
                s -= band[i * stride + (i - k)] * band[j * stride + (j - k)];
            }
            if i == j {
                band[i * stride] = if s > 0.0 && s.is_finite() { 1.0 / s.sqrt() } else { 1.0 };
            } else {
                band[i * stride + (i - j)] = s * band[j * stride];
            }
        }
    }
}

/// `Σ_k coef(k) x[k]` over `ks` in two sums (even and odd terms) added at the end: two chains of additions.
#[inline]
fn paired_sum(ks: std::ops::Range<usize>, coef: impl Fn(usize) -> f64, x: &[f64]) -> f64 {
    let (mut even, mut odd) = (0.0, 0.0);
    let mut k = ks.start;
    while k + 1 < ks.end {
        even += coef(k) * x[k];
        odd += coef(k + 1) * x[k + 1];
        k += 2;
    }
    if k < ks.end {
        even += coef(k) * x[k];
    }
    even + odd
}

/// `x = (L Lᵀ)⁻¹ x` with a [`band_factor`] factor. The term of the unknown found just before is added last,
/// after the others' sums, so each unknown waits on one product of the one before it (the solve is a chain).
fn band_solve<T: Copy + Into<f64>>(band: &[T], w: usize, x: &mut [f64]) {
    let n = x.len();
    let stride = w + 1;
    let at = |k: usize| -> f64 { band[k].into() };
    for i in 0..n {
        let row = i * stride;
        let mut s = x[i] - paired_sum(i.saturating_sub(w)..i.saturating_sub(1), |k| at(row + (i - k)), x);
        if i > 0 {
            s -= at(row + 1) * x[i - 1];
        }
        x[i] = s * at(row);
    }
    for i in (0..n).rev() {
        let mut s = x[i] - paired_sum((i + 2).min(n)..n.min(i + w + 1), |k| at(k * stride + (k - i)), x);
        if i + 1 < n {
            s -= at((i + 1) * stride + 1) * x[i + 1];
        }
        x[i] = s * at(i * stride);
    }
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    /// `band_factor`.
    pub fn band_factor(band: &mut [f64], w: usize, n: usize) {
        super::band_factor(band, w, n);
    }

    /// `band_solve`.
    pub fn band_solve(band: &[f64], w: usize, x: &mut [f64]) {
        super::band_solve(band, w, x);
    }
}
