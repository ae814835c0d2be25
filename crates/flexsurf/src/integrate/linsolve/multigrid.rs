//! Conjugate gradients preconditioned by a geometric multigrid V-cycle on the parametric grid's hierarchy
//! ([`BlockSolver`]), for grids where a factorisation's fill (memory growing faster than the nodes, work like
//! `n^1.4`) dominates a step.
//!
//! - **Hierarchy.** Each level halves the node count of every direction that has enough nodes: the even nodes
//!   of a free direction and its last node, or the even nodes of a periodic one, are the coarse nodes; an odd
//!   node takes half of each neighbour (linear interpolation on the parametric grid, wrapping around a
//!   periodic direction). The prolongation `P` is the tensor product of the two directions', with the rows
//!   of fixed nodes zero, so the coarse corrections never move a pinned node. Levels are added until
//!   [`Multigrid::COARSEST_NODES`] nodes or no direction can be halved.
//! - **Coarse operators** are Galerkin's `A_c = Pᵀ A P` of the 3×3-block matrix, computed from a recipe built
//!   once (for each coarse block, the fine blocks and weights that sum into it, in a fixed order) and refilled
//!   in place for each solve; whatever couples nodes (the grid's stencils, seams, springs) is carried.
//! - **Smoothing** is block Gauss–Seidel by grid lines ([`super::lines`]): the `u1` lines then the `u2` lines
//!   before the coarse correction, the same in reverse after it, so the V-cycle is a symmetric positive definite
//!   preconditioner; the coarsest level is solved by sparse Cholesky. Point smoothers measured 5–10× more
//!   iterations on fabrics (docs/performance.md): their membrane is far stiffer in tension than in shear.
//! - **Conjugate gradients** ([`super::cg`]) start from the caller's guess (the stepper passes the previous
//!   step's increment) and stop at the relative residual [`super::ITERATIVE_TOLERANCE`].

use super::cholesky::Cholesky;
use super::lines::{self, grid_lines, LineSmoother};
use super::{BlockSolver, LinearError, Reduced, Reuse, SolveStats, SolverKind};
use crate::grid::{Grid, Topology};
use crate::math::{skew, Mat3, Vec3};
use crate::model::Panel;
use crate::sparse::{BlockMatrix, BlockPattern};
use rayon::prelude::*;
use std::time::Instant;

/// A tuning knob from the environment (exploration only).
fn knob(name: &str, default: f64) -> f64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// Block nodes of a coarse point: its translations, then its rotations.
const PER_POINT: usize = 2;

/// A row of the rigid-body modes (or of a prolongation) of one block node: a `3 × 6` matrix as its columns
/// 0–2 and 3–5.
type Row6 = [Mat3; 2];

/// Power iterations estimating the spectral radius of `D⁻¹ A` for the prolongation's smoothing.
const POWER_STEPS: usize = 10;

/// Rows per chunk of a parallel row operation.
const ROW_CHUNK: usize = 1024;

/// One direction's aggregation: the aggregate of each fine index, runs of three consecutive indices (the last
/// run two or four long).
#[derive(Debug, Clone)]
struct Agg1d {
    coarse: usize,
    of: Vec<u32>,
}

impl Agg1d {
    /// Each index its own aggregate (a direction too short to group).
    fn identity(count: usize) -> Self {
        Self { coarse: count, of: (0..count as u32).collect() }
    }

    /// Runs of three, or `None` for fewer than four indices.
    fn group(count: usize) -> Option<Self> {
        let run = knob("FS_AGG", 3.0) as usize;
        if count < run + 1 {
            return None;
        }
        let coarse = count / run + usize::from(count % run >= 2);
        Some(Self { coarse, of: (0..count).map(|i| (i / run).min(coarse - 1) as u32).collect() })
    }
}

/// One panel's grid on one level, and the level's point of each of its nodes that it owns (a node joined by a
/// seam belongs to the first panel that has it; the coarse levels' panels own all their points, panel after
/// panel).
#[derive(Debug, Clone)]
struct Shape {
    m: usize,
    n: usize,
    topology: [Topology; 2],
    nodes: Vec<Option<u32>>,
}

impl Shape {
    /// The panels of a model on the finest level.
    fn of_panels(panels: &[Panel]) -> Vec<Shape> {
        let mut owned = std::collections::BTreeSet::new();
        let shape = |p: &Panel| {
            let nodes = p.nodes().iter().map(|&k| owned.insert(k).then_some(k as u32)).collect();
            Shape { m: p.grid.m, n: p.grid.n, topology: p.grid.topology, nodes }
        };
        panels.iter().map(shape).collect()
    }

    /// Grids of `(m, n, topology)` owning their points, panel after panel.
    fn contiguous(grids: impl Iterator<Item = (usize, usize, [Topology; 2])>) -> Vec<Shape> {
        let mut offset = 0u32;
        grids
            .map(|(m, n, topology)| {
                let nodes = (offset..offset + (m * n) as u32).map(Some).collect();
                offset += (m * n) as u32;
                Shape { m, n, topology, nodes }
            })
            .collect()
    }

    /// Owned points.
    fn owned(&self) -> usize {
        self.nodes.iter().flatten().count()
    }

    /// The `u1` lines and the `u2` lines of every panel, over the points it owns, each point as its
    /// `per_point` block nodes in a row.
    fn lines(shapes: &[Shape], per_point: usize) -> [Vec<Vec<u32>>; 2] {
        let per = per_point as u32;
        [0, 1].map(|d| {
            shapes
                .iter()
                .flat_map(|s| {
                    grid_lines(s.m, s.n, d, s.topology[d]).into_iter().map(|l| {
                        l.iter()
                            .filter_map(|&k| s.nodes[k as usize])
                            .flat_map(|p| (0..per).map(move |b| per * p + b))
                            .collect::<Vec<u32>>()
                    })
                })
                .filter(|l| !l.is_empty())
                .collect()
        })
    }

    /// The two directions' aggregations, or `None` when neither direction can be grouped.
    fn aggregate(&self) -> Option<(Agg1d, Agg1d)> {
        let a1 = Agg1d::group(self.m);
        let a2 = Agg1d::group(self.n);
        if a1.is_none() && a2.is_none() {
            return None;
        }
        Some((a1.unwrap_or_else(|| Agg1d::identity(self.m)), a2.unwrap_or_else(|| Agg1d::identity(self.n))))
    }
}

/// A symmetric block matrix's pattern by rows (both triangles): each entry's column and the upper block it
/// reads (transposed for a lower entry), and each row's diagonal block.
#[derive(Debug, Clone)]
struct Rows {
    start: Vec<u32>,
    col: Vec<u32>,
    src: Vec<(u32, bool)>,
    diag: Vec<u32>,
}

impl Rows {
    fn new(pattern: &BlockPattern) -> Self {
        let n = pattern.nodes();
        let rows = pattern.block_rows();
        let mut per_row: Vec<Vec<(u32, u32, bool)>> = vec![Vec::new(); n];
        let mut diag = vec![0u32; n];
        for j in 0..n {
            let (s, e) = pattern.column(j);
            diag[j] = (e - 1) as u32;
            for (blk, &i) in rows.iter().enumerate().take(e).skip(s) {
                per_row[i].push((j as u32, blk as u32, false));
                if i != j {
                    per_row[j].push((i as u32, blk as u32, true));
                }
            }
        }
        let mut start = Vec::with_capacity(n + 1);
        let (mut col, mut src) = (Vec::new(), Vec::new());
        start.push(0);
        for mut r in per_row {
            r.sort_unstable_by_key(|e| e.0);
            for (c, blk, t) in r {
                col.push(c);
                src.push((blk, t));
            }
            start.push(col.len() as u32);
        }
        Self { start, col, src, diag }
    }

    #[inline]
    fn range(&self, k: usize) -> std::ops::Range<usize> {
        self.start[k] as usize..self.start[k + 1] as usize
    }

    /// Entry `e`'s block of `a`.
    #[inline]
    fn block(&self, a: &BlockMatrix, e: usize) -> Mat3 {
        let (blk, t) = self.src[e];
        let m = a.blocks[blk as usize];
        if t {
            m.transpose()
        } else {
            m
        }
    }
}

/// One level below the finest: its operator, the prolongation from it to the level above, its smoother and
/// vectors.
#[derive(Clone)]
struct Level {
    pattern: BlockPattern,
    a: BlockMatrix,
    /// The finer level's matrix by rows.
    rows: Rows,
    /// Each finer block node's aggregate (this level's point), `u32::MAX` for a fixed node.
    agg: Vec<u32>,
    /// The finer block nodes of each aggregate, in order.
    m_start: Vec<u32>,
    members: Vec<u32>,
    /// The tentative prolongation's row of each finer block node (the orthonormalised rigid-body modes of its
    /// aggregate).
    t: Vec<Row6>,
    /// This level's rigid-body modes, each block node's row (the aggregates' triangular factors).
    null: Vec<Row6>,
    /// This level's unknowns whose tentative column vanished (a degenerate aggregate), per block node.
    dead: Vec<[bool; 3]>,
    /// `D⁻¹`, the inverses of the finer level's diagonal blocks (zero on fixed nodes).
    dinv: Vec<Mat3>,
    /// The smoothed prolongation `P`, by finer block node: its entries' points here and blocks.
    p_start: Vec<u32>,
    p_point: Vec<u32>,
    p: Vec<Row6>,
    smoother: LineSmoother,
    b: Vec<Vec3>,
    x: Vec<Vec3>,
    r: Vec<Vec3>,
}

/// Multigrid-preconditioned conjugate gradients.
pub struct Multigrid {
    /// The finest level's system with the fixed unknowns eliminated, and conjugate gradients on it.
    system: Reduced,
    /// The panels on the finest level.
    shapes: Vec<Shape>,
    /// The finest level's rigid-body modes at the positions given (the rest shape until
    /// [`BlockSolver::set_positions`]).
    fine_null: Vec<Row6>,
    /// The finest level's smoother (and its matrix by rows), built at the first solve.
    fine: Option<LineSmoother>,
    coarse: Coarse,
    /// The fixed set the hierarchy was built for.
    built_fixed: Vec<bool>,
}

/// The levels below the finest and the V-cycle's scratch.
struct Coarse {
    levels: Vec<Level>,
    coarsest: Option<Cholesky>,
    fine_r: Vec<Vec3>,
    line_rhs: Vec<f64>,
}

/// Each node's row of the six rigid-body modes at positions `x`: the three translations and the rotations about
/// the nodes' centroid, `θ × (x − c)`.
fn rigid_modes(x: &[Vec3]) -> Vec<Row6> {
    let center = x.iter().fold(Vec3::ZERO, |s, p| s + *p) / x.len().max(1) as f64;
    x.iter().map(|p| [Mat3::IDENTITY, skew(center - *p)]).collect()
}

impl Multigrid {
    /// Levels are added while the coarsest has more block nodes than this.
    pub const COARSEST_NODES: usize = 800;
    /// Most conjugate-gradient iterations of one solve.
    pub const MAX_ITERATIONS: usize = 200;

    /// Buffers for `pattern` on a model's `panels` (the hierarchy is built at the first solve, for its fixed
    /// set): each panel is aggregated on its own grid, a node joined by a seam with the first panel that has
    /// it; the Galerkin products carry every coupling between panels to the coarse levels. The rigid-body
    /// modes are those of the panels' rest shapes until [`BlockSolver::set_positions`].
    pub fn new(pattern: &BlockPattern, panels: &[Panel]) -> Result<Self, LinearError> {
        let shapes = Shape::of_panels(panels);
        let mut x = vec![Vec3::ZERO; pattern.nodes()];
        for (panel, shape) in panels.iter().zip(&shapes) {
            for (p, node) in panel.rest().iter().zip(&shape.nodes) {
                if let Some(k) = node.and_then(|k| x.get_mut(k as usize)) {
                    *k = *p;
                }
            }
        }
        Self::on_shapes(pattern, shapes, &x)
    }

    /// As [`Multigrid::new`] for one grid whose nodes are the pattern's, at positions `x`.
    pub fn on_grid(pattern: &BlockPattern, grid: &Grid, x: &[Vec3]) -> Result<Self, LinearError> {
        Self::on_shapes(pattern, Shape::contiguous(std::iter::once((grid.m, grid.n, grid.topology))), x)
    }

    fn on_shapes(pattern: &BlockPattern, shapes: Vec<Shape>, x: &[Vec3]) -> Result<Self, LinearError> {
        let n = pattern.nodes();
        let owned: usize = shapes.iter().map(Shape::owned).sum();
        if owned != n || x.len() != n || shapes.iter().flat_map(|s| s.nodes.iter().flatten()).any(|&k| k as usize >= n)
        {
            return Err(LinearError::Symbolic(format!(
                "the multigrid solver needs one unknown and one position per panel node ({owned} nodes, {n} \
                 unknowns, {} positions)",
                x.len()
            )));
        }
        Ok(Self {
            system: Reduced::new(pattern),
            shapes,
            fine_null: rigid_modes(x),
            fine: None,
            coarse: Coarse { levels: Vec::new(), coarsest: None, fine_r: vec![Vec3::ZERO; n], line_rhs: Vec::new() },
            built_fixed: Vec::new(),
        })
    }

    /// Number of levels, the finest included.
    pub fn levels(&self) -> usize {
        self.coarse.levels.len() + 1
    }

    /// Builds the hierarchy (aggregates, patterns, smoothers) for the fixed set `fixed`.
    fn build(&mut self, fixed: &[bool]) -> Result<(), LinearError> {
        let c = &mut self.coarse;
        c.levels.clear();
        let mut shapes = self.shapes.clone();
        self.fine = Some(LineSmoother::new(self.system.pattern(), Shape::lines(&shapes, 1), fixed, lines::FAR));
        let mut free: Vec<bool> = fixed.iter().map(|&f| !f).collect();
        let (mut nodes, mut per_point) = (self.system.pattern().nodes(), 1);
        while nodes > knob("FS_COARSEST", Self::COARSEST_NODES as f64) as usize {
            let aggs: Vec<(Agg1d, Agg1d)> = match shapes.iter().map(Shape::aggregate).collect() {
                Some(t) => t,
                None if shapes.len() == 1 => break,
                // Several panels: group those that can, keep the others.
                None => shapes
                    .iter()
                    .map(|s| s.aggregate().unwrap_or_else(|| (Agg1d::identity(s.m), Agg1d::identity(s.n))))
                    .collect(),
            };
            let coarse = Shape::contiguous(shapes.iter().zip(&aggs).map(|(s, a)| (a.0.coarse, a.1.coarse, s.topology)));
            let points: usize = coarse.iter().map(Shape::owned).sum();
            if PER_POINT * points >= nodes {
                break;
            }
            let agg = aggregates(&free, per_point, &shapes, &aggs, &coarse);
            let fine = c.levels.last().map_or(self.system.pattern(), |l| &l.pattern);
            let level = Level::new(fine, agg, points, Shape::lines(&coarse, PER_POINT));
            free = vec![true; level.pattern.nodes()];
            (shapes, nodes, per_point) = (coarse, PER_POINT * points, PER_POINT);
            c.levels.push(level);
        }
        c.coarsest = match c.levels.last() {
            Some(last) => Some(Cholesky::new(&last.pattern)?),
            None => None,
        };
        let fine_len = self.fine.as_ref().map_or(0, LineSmoother::scratch_len);
        let longest = c.levels.iter().map(|l| l.smoother.scratch_len()).fold(fine_len, usize::max);
        c.line_rhs = vec![0.0; longest];
        self.built_fixed.clear();
        self.built_fixed.extend_from_slice(fixed);
        Ok(())
    }
}

/// Each finer block node's aggregate (a point of `coarse`), `u32::MAX` for the nodes not `free`; a finer point
/// has `per_point` block nodes.
fn aggregates(
    free: &[bool],
    per_point: usize,
    shapes: &[Shape],
    aggs: &[(Agg1d, Agg1d)],
    coarse: &[Shape],
) -> Vec<u32> {
    let mut agg = vec![u32::MAX; free.len()];
    for ((s, (a1, a2)), c) in shapes.iter().zip(aggs).zip(coarse) {
        for (local, node) in s.nodes.iter().enumerate() {
            let Some(p) = node else { continue };
            let (i, j) = (local % s.m, local / s.m);
            let target = c.nodes[a1.of[i] as usize + a1.coarse * a2.of[j] as usize].unwrap_or(u32::MAX);
            for b in 0..per_point {
                let k = per_point * *p as usize + b;
                if free[k] {
                    agg[k] = target;
                }
            }
        }
    }
    agg
}

impl Coarse {
    /// Refills the coarse levels from `a` (the finest's) and its rigid-body modes `null`, their smoothers, and
    /// factorises the coarsest.
    fn refill(&mut self, a: &BlockMatrix, null: &[Row6]) -> Result<(), LinearError> {
        for l in 0..self.levels.len() {
            let (above, below) = self.levels.split_at_mut(l);
            let (fine, fine_null) = above.last().map_or((a, null), |lv| (&lv.a, &lv.null[..]));
            below[0].refill(fine, fine_null);
        }
        if let (Some(chol), Some(last)) = (self.coarsest.as_mut(), self.levels.last()) {
            chol.factorize(&last.a)?;
        }
        Ok(())
    }

    /// `out ≈ A⁻¹ r`: one V-cycle from zero, `fine` the finest level's smoother.
    fn v_cycle(&mut self, fine: &LineSmoother, r: &[Vec3], out: &mut [Vec3]) {
        fine.pre(r, out, &mut self.line_rhs);
        let extra = knob("FS_SWEEPS", 1.0) as usize > 1;
        if extra {
            fine.post(r, out, &mut self.line_rhs);
        }
        if !self.levels.is_empty() {
            fine.residual(r, out, &mut self.fine_r);
            self.levels[0].restrict(&self.fine_r);
            cycle(&mut self.levels, self.coarsest.as_mut(), &mut self.line_rhs);
            self.levels[0].prolong_add(out);
        }
        if extra {
            fine.forward(r, out, &mut self.line_rhs);
        }
        fine.post(r, out, &mut self.line_rhs);
    }
}

/// The V-cycle below the finest level: `levels[0].x ≈ A₀⁻¹ levels[0].b`.
fn cycle(levels: &mut [Level], coarsest: Option<&mut Cholesky>, line_rhs: &mut [f64]) {
    let Some((first, rest)) = levels.split_first_mut() else { return };
    if rest.is_empty() {
        if let Some(chol) = coarsest {
            chol.apply(&first.b, &mut first.x);
        }
        return;
    }
    first.smoother.pre(&first.b, &mut first.x, line_rhs);
    first.smoother.residual(&first.b, &first.x, &mut first.r);
    rest[0].restrict(&first.r);
    cycle(rest, coarsest, line_rhs);
    rest[0].prolong_add(&mut first.x);
    first.smoother.post(&first.b, &mut first.x, line_rhs);
}

/// The points of the coarse pattern's blocks from the finer pattern by `rows` and the prolongation's structure:
/// every pair `(c, d)` with `P_kc`, `A_kj`, `P_jd` stored for some `k`, `j`, as the two points' block nodes.
fn coarse_pattern(rows: &Rows, p_start: &[u32], p_point: &[u32], points: usize) -> BlockPattern {
    let mut keys: Vec<u64> = Vec::new();
    let mut ap: Vec<u32> = Vec::new();
    let mut mark = vec![u32::MAX; points];
    for k in 0..p_start.len() - 1 {
        let pk = &p_point[p_start[k] as usize..p_start[k + 1] as usize];
        if pk.is_empty() {
            continue;
        }
        ap.clear();
        for e in rows.range(k) {
            let j = rows.col[e] as usize;
            for &d in &p_point[p_start[j] as usize..p_start[j + 1] as usize] {
                if mark[d as usize] != k as u32 {
                    mark[d as usize] = k as u32;
                    ap.push(d);
                }
            }
        }
        keys.extend(pk.iter().flat_map(|&c| ap.iter().filter(move |&&d| c <= d).map(move |&d| u64::from(d) << 32 | u64::from(c))));
        if keys.len() > 1 << 22 {
            keys.sort_unstable();
            keys.dedup();
        }
    }
    keys.sort_unstable();
    keys.dedup();
    let pairs = keys.into_iter().flat_map(|key| {
        let (c, d) = (2 * (key & 0xffff_ffff) as usize, 2 * (key >> 32) as usize);
        let all = [(c, d), (c + 1, d), (c, d + 1), (c + 1, d + 1)];
        all.into_iter().filter(move |&(i, j)| c != d || (i, j) == (c, c + 1))
    });
    BlockPattern::from_pairs(PER_POINT * points, pairs)
}

impl Level {
    /// The level below a finer one of pattern `fine` whose block nodes form the aggregates `agg` (`u32::MAX`:
    /// fixed) of `points` points, smoothed by `lines`.
    fn new(fine: &BlockPattern, agg: Vec<u32>, points: usize, lines: [Vec<Vec<u32>>; 2]) -> Self {
        let rows = Rows::new(fine);
        let nf = fine.nodes();
        let mut m_start = vec![0u32; points + 1];
        for &a in agg.iter().filter(|&&a| a != u32::MAX) {
            m_start[a as usize + 1] += 1;
        }
        for c in 0..points {
            m_start[c + 1] += m_start[c];
        }
        let mut fill = m_start.clone();
        let mut members = vec![0u32; m_start[points] as usize];
        for (k, &a) in agg.iter().enumerate().filter(|(_, &a)| a != u32::MAX) {
            members[fill[a as usize] as usize] = k as u32;
            fill[a as usize] += 1;
        }
        let (mut p_start, mut p_point) = (vec![0u32], Vec::new());
        for k in 0..nf {
            if agg[k] != u32::MAX {
                let mut pts: Vec<u32> =
                    rows.range(k).map(|e| agg[rows.col[e] as usize]).filter(|&a| a != u32::MAX).collect();
                pts.sort_unstable();
                pts.dedup();
                p_point.extend(pts);
            }
            p_start.push(p_point.len() as u32);
        }
        let pattern = coarse_pattern(&rows, &p_start, &p_point, points);
        let n = pattern.nodes();
        let smoother = LineSmoother::new(&pattern, lines, &vec![false; n], 2 * lines::FAR + 1);
        let zero6 = [Mat3::ZERO; 2];
        Self {
            a: BlockMatrix::zeros(&pattern),
            pattern,
            rows,
            agg,
            m_start,
            members,
            t: vec![zero6; nf],
            null: vec![zero6; n],
            dead: vec![[false; 3]; n],
            dinv: vec![Mat3::ZERO; nf],
            p: vec![zero6; p_point.len()],
            p_start,
            p_point,
            smoother,
            b: vec![Vec3::ZERO; n],
            x: vec![Vec3::ZERO; n],
            r: vec![Vec3::ZERO; n],
        }
    }

    /// Refills the level from the finer level's matrix `fine` and rigid-body modes `fine_null`: the tentative
    /// prolongation, its smoothing by damped block Jacobi, the Galerkin product and the smoother.
    fn refill(&mut self, fine: &BlockMatrix, fine_null: &[Row6]) {
        self.tentative(fine_null);
        for (k, d) in self.dinv.iter_mut().enumerate() {
            let m = fine.blocks[self.rows.diag[k] as usize];
            let inv = m.inverse();
            *d = if self.agg[k] != u32::MAX && m.determinant() > 0.0 && inv.is_finite() { inv } else { Mat3::ZERO };
        }
        let rho = self.spectral_radius(fine);
        let omega = if rho > 0.0 && rho.is_finite() { knob("FS_OMEGA", 1.0) * 4.0 / (3.0 * rho) } else { 0.0 };
        self.smooth(fine, omega);
        self.galerkin(fine);
        self.smoother.refill(&self.a);
    }

    /// The tentative prolongation: each aggregate's rows of the finer rigid-body modes orthonormalised
    /// (classical Gram–Schmidt twice, a column left zero when it vanishes), and this level's modes, the
    /// triangular factors.
    fn tentative(&mut self, fine_null: &[Row6]) {
        let col = |b: &Row6, c: usize| b[c / 3].col(c % 3);
        let mut q: Vec<[Vec3; 6]> = Vec::new();
        for a in 0..self.m_start.len() - 1 {
            let members = &self.members[self.m_start[a] as usize..self.m_start[a + 1] as usize];
            q.clear();
            q.extend(members.iter().map(|&k| std::array::from_fn(|c| col(&fine_null[k as usize], c))));
            let mut r = [[0.0f64; 6]; 6];
            let modes = knob("FS_MODES", 6.0) as usize;
            for c in 0..6 {
                if c >= modes {
                    q.iter_mut().for_each(|v| v[c] = Vec3::ZERO);
                }
                let norm0 = q.iter().map(|v| v[c].length_squared()).sum::<f64>().sqrt();
                for _ in 0..2 {
                    for (l, rl) in r.iter_mut().enumerate().take(c) {
                        let d: f64 = q.iter().map(|v| v[l].dot(v[c])).sum();
                        rl[c] += d;
                        q.iter_mut().for_each(|v| v[c] -= v[l] * d);
                    }
                }
                let norm = q.iter().map(|v| v[c].length_squared()).sum::<f64>().sqrt();
                let alive = norm > 1e-8 * norm0 && norm.is_finite();
                r[c][c] = if alive { norm } else { 0.0 };
                let s = if alive { 1.0 / norm } else { 0.0 };
                q.iter_mut().for_each(|v| v[c] *= s);
            }
            for (&k, v) in members.iter().zip(&q) {
                self.t[k as usize] = [Mat3::from_cols(v[0], v[1], v[2]), Mat3::from_cols(v[3], v[4], v[5])];
            }
            for s in 0..PER_POINT {
                let blk = |c0: usize| {
                    let v = |c: usize| Vec3::new(r[3 * s][c0 + c], r[3 * s + 1][c0 + c], r[3 * s + 2][c0 + c]);
                    Mat3::from_cols(v(0), v(1), v(2))
                };
                self.null[PER_POINT * a + s] = [blk(0), blk(3)];
                self.dead[PER_POINT * a + s] = [0, 1, 2].map(|i| r[3 * s + i][3 * s + i] == 0.0);
            }
        }
    }

    /// `out = D⁻¹ A v` on the finer level (zero on fixed nodes), over the threads by rows.
    fn jacobi_product(&self, fine: &BlockMatrix, v: &[Vec3], out: &mut [Vec3]) {
        let row = |k: usize| self.dinv[k] * self.rows.range(k).fold(Vec3::ZERO, |s, e| s + self.rows.block(fine, e) * v[self.rows.col[e] as usize]);
        out.par_chunks_mut(ROW_CHUNK).enumerate().for_each(|(c, chunk)| {
            for (i, o) in chunk.iter_mut().enumerate() {
                *o = row(c * ROW_CHUNK + i);
            }
        });
    }

    /// The spectral radius of `D⁻¹ A` on the finer level's free nodes, by power iteration from a fixed vector.
    fn spectral_radius(&self, fine: &BlockMatrix) -> f64 {
        let n = self.agg.len();
        let mut v: Vec<Vec3> = (0..n)
            .map(|k| {
                let h = |s: usize| ((k * 7919 + s * 104_729) % 1009) as f64 / 1009.0 - 0.5;
                if self.agg[k] == u32::MAX { Vec3::ZERO } else { Vec3::new(h(1), h(2), h(3)) }
            })
            .collect();
        let mut w = vec![Vec3::ZERO; n];
        let mut parts = Vec::new();
        let mut rho = 0.0;
        for _ in 0..POWER_STEPS {
            let nv = super::cg::dot(&mut parts, &v, &v).sqrt();
            self.jacobi_product(fine, &v, &mut w);
            let nw = super::cg::dot(&mut parts, &w, &w).sqrt();
            if !(nw > 0.0 && nw.is_finite() && nv > 0.0) {
                break;
            }
            rho = nw / nv;
            v.iter_mut().zip(&w).for_each(|(v, w)| *v = *w / nw);
        }
        rho
    }

    /// `P = (I − ω D⁻¹ A) T` row by row.
    fn smooth(&mut self, fine: &BlockMatrix, omega: f64) {
        let Self { rows, agg, t, dinv, p_start, p_point, p, .. } = self;
        for k in 0..agg.len() {
            let range = p_start[k] as usize..p_start[k + 1] as usize;
            if range.is_empty() {
                continue;
            }
            let (pts, acc) = (&p_point[range.clone()], &mut p[range]);
            acc.iter_mut().for_each(|m| *m = [Mat3::ZERO; 2]);
            for e in rows.range(k) {
                let j = rows.col[e] as usize;
                let Some(slot) = pts.iter().position(|&q| q == agg[j]) else { continue };
                let f = rows.block(fine, e);
                acc[slot][0] += f * t[j][0];
                acc[slot][1] += f * t[j][1];
            }
            let scale = dinv[k] * -omega;
            for (m, &pt) in acc.iter_mut().zip(pts) {
                let own = if pt == agg[k] { t[k] } else { [Mat3::ZERO; 2] };
                *m = [own[0] + scale * m[0], own[1] + scale * m[1]];
            }
        }
    }

    /// `A = Pᵀ A_fine P` in place, row by finer row (the sums in a fixed order), with a unit diagonal on the
    /// dead unknowns.
    fn galerkin(&mut self, fine: &BlockMatrix) {
        let Self { pattern, a, rows, p_start, p_point, p, dead, .. } = self;
        a.blocks.iter_mut().for_each(|b| *b = Mat3::ZERO);
        let mut slot = vec![u32::MAX; dead.len() / PER_POINT];
        let mut ap: Vec<(u32, Row6)> = Vec::new();
        for k in 0..p_start.len() - 1 {
            let pk = p_start[k] as usize..p_start[k + 1] as usize;
            if pk.is_empty() {
                continue;
            }
            ap.clear();
            for e in rows.range(k) {
                let j = rows.col[e] as usize;
                let f = rows.block(fine, e);
                for q in p_start[j] as usize..p_start[j + 1] as usize {
                    let (d, m) = (p_point[q], [f * p[q][0], f * p[q][1]]);
                    match slot[d as usize] {
                        u32::MAX => {
                            slot[d as usize] = ap.len() as u32;
                            ap.push((d, m));
                        }
                        s => {
                            let g = &mut ap[s as usize].1;
                            g[0] += m[0];
                            g[1] += m[1];
                        }
                    }
                }
            }
            ap.iter().for_each(|&(d, _)| slot[d as usize] = u32::MAX);
            for q in pk {
                let (c, pc) = (p_point[q] as usize, [p[q][0].transpose(), p[q][1].transpose()]);
                for &(d, g) in ap.iter().filter(|(d, _)| c <= *d as usize) {
                    let d = d as usize;
                    let i0 = pattern.find(2 * c, 2 * d);
                    let i1 = pattern.find(2 * c, 2 * d + 1);
                    a.blocks[i0] += pc[0] * g[0];
                    a.blocks[i1] += pc[0] * g[1];
                    a.blocks[i1 + 1] += pc[1] * g[1];
                    if c < d {
                        a.blocks[i0 + 1] += pc[1] * g[0];
                    }
                }
            }
        }
        for (k, dead) in dead.iter().enumerate() {
            let (_, e) = pattern.column(k);
            for (i, _) in dead.iter().enumerate().filter(|(_, &d)| d) {
                a.blocks[e - 1].col_mut(i)[i] = 1.0;
            }
        }
    }

    /// `b = Pᵀ r_fine`, `x = 0`.
    fn restrict(&mut self, fine_r: &[Vec3]) {
        self.b.iter_mut().for_each(|v| *v = Vec3::ZERO);
        for (k, r) in fine_r.iter().enumerate() {
            for e in self.p_start[k] as usize..self.p_start[k + 1] as usize {
                let c = PER_POINT * self.p_point[e] as usize;
                self.b[c] += self.p[e][0].transpose() * *r;
                self.b[c + 1] += self.p[e][1].transpose() * *r;
            }
        }
        self.x.iter_mut().for_each(|v| *v = Vec3::ZERO);
    }

    /// `x_fine += P x`.
    fn prolong_add(&self, fine_x: &mut [Vec3]) {
        let row = |k: usize| {
            (self.p_start[k] as usize..self.p_start[k + 1] as usize).fold(Vec3::ZERO, |s, e| {
                let c = PER_POINT * self.p_point[e] as usize;
                s + self.p[e][0] * self.x[c] + self.p[e][1] * self.x[c + 1]
            })
        };
        fine_x.par_chunks_mut(ROW_CHUNK).enumerate().for_each(|(c, chunk)| {
            for (i, x) in chunk.iter_mut().enumerate() {
                *x += row(c * ROW_CHUNK + i);
            }
        });
    }
}

impl BlockSolver for Multigrid {
    fn solve(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        _reuse: Reuse,
    ) -> Result<SolveStats, LinearError> {
        let t0 = Instant::now();
        if self.built_fixed != fixed || self.fine.is_none() {
            self.build(fixed)?;
        }
        let Self { system, fine, coarse, fine_null, .. } = self;
        let Some(fine) = fine.as_mut() else { unreachable!("built above") };
        fine.refill(a);
        coarse.refill(a, fine_null)?;
        system.eliminate(a, fixed, b, x);
        let t1 = Instant::now();
        let fine = &*fine;
        let iterations = system.cg(
            a,
            fixed,
            x,
            |r, out| coarse.v_cycle(fine, r, out),
            super::ITERATIVE_TOLERANCE,
            Self::MAX_ITERATIONS,
        )?;
        Ok(SolveStats::since(t0, t1, iterations, true))
    }

    fn set_positions(&mut self, x: &[Vec3]) {
        if x.len() == self.fine_null.len() {
            self.fine_null = rigid_modes(x);
        }
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Multigrid
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::Stepper;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }

    /// The step matrix of the 41×41 ball drop after a few steps (contacts and friction in it), the grid and
    /// the positions.
    fn step_matrix(n: usize, topology: [Topology; 2]) -> (BlockPattern, BlockMatrix, Grid, Vec<Vec3>) {
        let scene = crate::bench::ball_drop(n).unwrap();
        let mut state = scene.state.clone();
        let mut stepper = Stepper::new(&scene.model, &scene.step_params()).unwrap();
        stepper.assemble(&scene.model, &state);
        for _ in 0..3 {
            stepper.step(&scene.model, &mut state).unwrap();
        }
        stepper.assemble(&scene.model, &state);
        let grid = Grid { topology, ..scene.model.panels[0].grid };
        (scene.model.potential.pattern().clone(), stepper.matrix().clone(), grid, state.x)
    }

    #[test]
    fn coarse_operators_are_galerkin_products() {
        for topology in [[Topology::Free; 2], [Topology::Periodic, Topology::Free]] {
            let (pattern, a, grid, x) = step_matrix(41, topology);
            let fixed = vec![false; pattern.nodes()];
            let mut mg = Multigrid::on_grid(&pattern, &grid, &x).unwrap();
            mg.build(&fixed).unwrap();
            mg.coarse.refill(&a, &mg.fine_null).unwrap();
            let level = &mg.coarse.levels[0];
            let nc = level.pattern.nodes();
            let mut seed = 7;
            let v: Vec<Vec3> = (0..nc).map(|_| Vec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed))).collect();
            // P v, A P v, Pᵀ A P v.
            let mut pv = vec![Vec3::ZERO; pattern.nodes()];
            let mut lv = Level { x: v.clone(), ..level.clone() };
            lv.prolong_add(&mut pv);
            let mut apv = vec![Vec3::ZERO; pattern.nodes()];
            a.mul_add(&pattern, &pv, &mut apv);
            lv.restrict(&apv);
            let mut acv = vec![Vec3::ZERO; nc];
            level.a.mul_add(&level.pattern, &v, &mut acv);
            let scale = acv.iter().map(|w| w.length()).fold(0.0, f64::max);
            let err = acv.iter().zip(&lv.b).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
            assert!(err <= 1e-12 * scale, "{topology:?}: |A_c v − Pᵀ A P v| = {err:e} of {scale:e}");
        }
    }

    #[test]
    fn multigrid_solution_matches_the_direct_solve() {
        let (pattern, a, grid, pos) = step_matrix(41, [Topology::Free; 2]);
        let mut fixed = vec![false; pattern.nodes()];
        fixed[5] = true;
        fixed[700] = true;
        let mut seed = 3;
        let b: Vec<Vec3> =
            (0..pattern.nodes()).map(|_| Vec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed))).collect();
        let mut x_direct = vec![Vec3::ZERO; b.len()];
        Cholesky::new(&pattern).unwrap().solve(&a, &fixed, &b, &mut x_direct, Reuse::Fresh).unwrap();
        let mut x = vec![Vec3::ZERO; b.len()];
        let stats = Multigrid::on_grid(&pattern, &grid, &pos).unwrap().solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap();
        let scale = x_direct.iter().map(|w| w.length()).fold(0.0, f64::max);
        let err = x.iter().zip(&x_direct).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
        assert!(
            err <= 1e-6 * scale,
            "multigrid differs from Cholesky by {err:e} (of {scale:e}), {} iterations",
            stats.iterations
        );
        assert_eq!(x[5], b[5]);
        assert_eq!(x[700], b[700]);
        eprintln!(
            "41x41 step matrix: {} multigrid iterations, max difference {:.2e} of {:.2e}",
            stats.iterations, err, scale
        );
    }
}
