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
use super::lines::{grid_lines, LineSmoother};
use super::{BlockSolver, LinearError, Reduced, Reuse, SolveStats, SolverKind};
use crate::grid::{Grid, Topology};
use crate::math::{Mat3, Vec3};
use crate::model::Panel;
use crate::sparse::{BlockMatrix, BlockPattern};
use std::time::Instant;

/// One direction's coarsening: for each fine index, up to two coarse indices and weights.
#[derive(Debug, Clone)]
struct Transfer1d {
    coarse: usize,
    parents: Vec<[(usize, f64); 2]>,
    count: Vec<u8>,
}

impl Transfer1d {
    /// The identity (a direction too short to halve).
    fn identity(count: usize) -> Self {
        Self { coarse: count, parents: (0..count).map(|i| [(i, 1.0), (0, 0.0)]).collect(), count: vec![1; count] }
    }

    /// Halving `count` nodes of a free or periodic direction, or `None` when it has too few.
    fn halve(count: usize, topology: Topology) -> Option<Self> {
        let periodic = topology == Topology::Periodic;
        if count < if periodic { 6 } else { 5 } {
            return None;
        }
        // Coarse nodes: the even indices, plus the last index of a free direction of even count.
        let mut index = vec![usize::MAX; count];
        let mut coarse = 0;
        for (i, slot) in index.iter_mut().enumerate() {
            if i % 2 == 0 || (!periodic && i == count - 1) {
                *slot = coarse;
                coarse += 1;
            }
        }
        let mut parents = vec![[(0, 0.0); 2]; count];
        let mut counts = vec![0u8; count];
        for i in 0..count {
            if index[i] != usize::MAX {
                parents[i][0] = (index[i], 1.0);
                counts[i] = 1;
            } else {
                // An odd index: both neighbours are coarse (the last one of a free direction always is).
                let next = (i + 1) % count;
                parents[i] = [(index[i - 1], 0.5), (index[next], 0.5)];
                counts[i] = 2;
            }
        }
        Some(Self { coarse, parents, count: counts })
    }

    fn parents(&self, i: usize) -> &[(usize, f64)] {
        &self.parents[i][..self.count[i] as usize]
    }
}

/// How a fine block enters a coarse one, in the two low bits of a recipe's entry: `w A_ij`.
const PLAIN: u32 = 0;
/// `w A_ijᵀ`.
const TRANSPOSED: u32 = 1;
/// `w (A_ij + A_ijᵀ)` (both fine orderings land on one coarse diagonal block).
const SYMMETRIZED: u32 = 2;

/// The Galerkin product of one level: coarse block `c` is the sum over the entries
/// `start[c]..start[c + 1]` of `weight · op(A_fine[entry >> 2])`, `op` by the entry's two low bits. The weights
/// are products of the transfers' 1 and ½, exact in `f32`.
#[derive(Debug, Clone)]
struct Recipe {
    start: Vec<u32>,
    entry: Vec<u32>,
    weight: Vec<f32>,
}

/// One panel's grid on one level, and the level's node of each of its nodes that it owns (a node joined by a
/// seam belongs to the first panel that has it; the coarse levels' panels own all their nodes, panel after
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

    /// Grids of `(m, n, topology)` owning their nodes, panel after panel.
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

    /// Owned nodes.
    fn owned(&self) -> usize {
        self.nodes.iter().flatten().count()
    }

    /// The `u1` lines and the `u2` lines of every panel, over the nodes it owns.
    fn lines(shapes: &[Shape]) -> [Vec<Vec<u32>>; 2] {
        [0, 1].map(|d| {
            shapes
                .iter()
                .flat_map(|s| {
                    grid_lines(s.m, s.n, d, s.topology[d])
                        .into_iter()
                        .map(|l| l.iter().filter_map(|&k| s.nodes[k as usize]).collect::<Vec<u32>>())
                })
                .filter(|l| !l.is_empty())
                .collect()
        })
    }

    /// The two directions' halvings, or `None` when neither direction can be halved.
    fn halve(&self) -> Option<(Transfer1d, Transfer1d)> {
        let t1 = Transfer1d::halve(self.m, self.topology[0]);
        let t2 = Transfer1d::halve(self.n, self.topology[1]);
        if t1.is_none() && t2.is_none() {
            return None;
        }
        Some((t1.unwrap_or_else(|| Transfer1d::identity(self.m)), t2.unwrap_or_else(|| Transfer1d::identity(self.n))))
    }
}

/// One level below the finest: its operator, the transfer from the level above, its smoother and vectors.
struct Level {
    pattern: BlockPattern,
    a: BlockMatrix,
    recipe: Recipe,
    /// For each node of the finer level: its parents here (node, weight), as rows of `P`.
    p_start: Vec<u32>,
    p_node: Vec<u32>,
    p_weight: Vec<f64>,
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

impl Multigrid {
    /// Levels are added while the coarsest has more nodes than this.
    pub const COARSEST_NODES: usize = 800;
    /// Most conjugate-gradient iterations of one solve.
    pub const MAX_ITERATIONS: usize = 200;

    /// Buffers for `pattern` on a model's `panels` (the hierarchy is built at the first solve, for its fixed
    /// set): each panel is coarsened on its own grid, a node joined by a seam with the first panel that has it;
    /// the Galerkin products carry every coupling between panels to the coarse levels.
    pub fn new(pattern: &BlockPattern, panels: &[Panel]) -> Result<Self, LinearError> {
        Self::on_shapes(pattern, Shape::of_panels(panels))
    }

    /// As [`Multigrid::new`] for one grid whose nodes are the pattern's.
    pub fn on_grid(pattern: &BlockPattern, grid: &Grid) -> Result<Self, LinearError> {
        Self::on_shapes(pattern, Shape::contiguous(std::iter::once((grid.m, grid.n, grid.topology))))
    }

    fn on_shapes(pattern: &BlockPattern, shapes: Vec<Shape>) -> Result<Self, LinearError> {
        let n = pattern.nodes();
        let owned: usize = shapes.iter().map(Shape::owned).sum();
        if owned != n || shapes.iter().flat_map(|s| s.nodes.iter().flatten()).any(|&k| k as usize >= n) {
            return Err(LinearError::Symbolic(format!(
                "the multigrid solver needs one unknown per panel node ({owned} nodes, {n} unknowns)"
            )));
        }
        Ok(Self {
            system: Reduced::new(pattern),
            shapes,
            fine: None,
            coarse: Coarse { levels: Vec::new(), coarsest: None, fine_r: vec![Vec3::ZERO; n], line_rhs: Vec::new() },
            built_fixed: Vec::new(),
        })
    }

    /// Number of levels, the finest included.
    pub fn levels(&self) -> usize {
        self.coarse.levels.len() + 1
    }

    /// Builds the hierarchy (patterns, recipes, transfers, smoothers) for the fixed set `fixed`.
    fn build(&mut self, fixed: &[bool]) -> Result<(), LinearError> {
        let c = &mut self.coarse;
        c.levels.clear();
        let mut shapes = self.shapes.clone();
        self.fine = Some(LineSmoother::new(self.system.pattern(), Shape::lines(&shapes), fixed));
        let mut free: Vec<bool> = fixed.iter().map(|&f| !f).collect();
        let mut nodes = self.system.pattern().nodes();
        while nodes > Self::COARSEST_NODES {
            let transfers: Vec<(Transfer1d, Transfer1d)> = match shapes.iter().map(Shape::halve).collect() {
                Some(t) => t,
                None if shapes.len() == 1 => break,
                // Several panels: halve those that can, keep the others.
                None => shapes
                    .iter()
                    .map(|s| s.halve().unwrap_or_else(|| (Transfer1d::identity(s.m), Transfer1d::identity(s.n))))
                    .collect(),
            };
            let coarse =
                Shape::contiguous(shapes.iter().zip(&transfers).map(|(s, t)| (t.0.coarse, t.1.coarse, s.topology)));
            let coarse_nodes: usize = coarse.iter().map(Shape::owned).sum();
            if coarse_nodes == nodes {
                break;
            }
            let fine = c.levels.last().map_or(self.system.pattern(), |l| &l.pattern);
            let level = Level::new(fine, &free, &shapes, &transfers, &coarse);
            free = vec![true; level.pattern.nodes()];
            (shapes, nodes) = (coarse, coarse_nodes);
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

impl Coarse {
    /// Refills the coarse operators from `a` (the finest's), their smoothers, and factorises the coarsest.
    fn refill(&mut self, a: &BlockMatrix) -> Result<(), LinearError> {
        for l in 0..self.levels.len() {
            let (above, below) = self.levels.split_at_mut(l);
            let fine = above.last().map_or(a, |lv| &lv.a);
            let level = &mut below[0];
            level.galerkin(fine);
            level.smoother.refill(&level.a);
        }
        if let (Some(chol), Some(last)) = (self.coarsest.as_mut(), self.levels.last()) {
            chol.factorize(&last.a)?;
        }
        Ok(())
    }

    /// `out ≈ A⁻¹ r`: one V-cycle from zero, `fine` the finest level's smoother.
    fn v_cycle(&mut self, fine: &LineSmoother, r: &[Vec3], out: &mut [Vec3]) {
        fine.pre(r, out, &mut self.line_rhs);
        if !self.levels.is_empty() {
            fine.residual(r, out, &mut self.fine_r);
            self.levels[0].restrict(&self.fine_r);
            cycle(&mut self.levels, self.coarsest.as_mut(), &mut self.line_rhs);
            self.levels[0].prolong_add(out);
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

impl Level {
    /// A copy with the transfer and fresh vectors (tests).
    #[cfg(test)]
    fn clone_shape(&self) -> Self {
        Self {
            pattern: self.pattern.clone(),
            a: self.a.clone(),
            recipe: self.recipe.clone(),
            p_start: self.p_start.clone(),
            p_node: self.p_node.clone(),
            p_weight: self.p_weight.clone(),
            smoother: self.smoother.clone(),
            b: self.b.clone(),
            x: self.x.clone(),
            r: self.r.clone(),
        }
    }

    /// The level below a fine level of panels `shapes` (`free`: nodes with a row in `P`) with the transfers of
    /// each panel's two directions, onto the panels `coarse`.
    fn new(
        fine: &BlockPattern,
        free: &[bool],
        shapes: &[Shape],
        transfers: &[(Transfer1d, Transfer1d)],
        coarse: &[Shape],
    ) -> Self {
        let nodes = coarse.iter().map(Shape::owned).sum();
        let (p_start, p_node, p_weight) = prolongation(free, shapes, transfers, coarse);
        let parents =
            |k: usize| (p_start[k] as usize..p_start[k + 1] as usize).map(|e| (p_node[e] as usize, p_weight[e]));
        let (pattern, recipe) = recipe(nodes, galerkin_entries(fine, parents));
        let smoother = LineSmoother::new(&pattern, Shape::lines(coarse), &vec![false; nodes]);
        Self {
            a: BlockMatrix::zeros(&pattern),
            pattern,
            recipe,
            p_start,
            p_node,
            p_weight,
            smoother,
            b: vec![Vec3::ZERO; nodes],
            x: vec![Vec3::ZERO; nodes],
            r: vec![Vec3::ZERO; nodes],
        }
    }

    /// `A = Pᵀ A_fine P` in place.
    fn galerkin(&mut self, fine: &BlockMatrix) {
        let r = &self.recipe;
        for (c, out) in self.a.blocks.iter_mut().enumerate() {
            let mut acc = Mat3::ZERO;
            for e in r.start[c] as usize..r.start[c + 1] as usize {
                let code = r.entry[e];
                let m = fine.blocks[(code >> 2) as usize];
                let m = match code & 3 {
                    PLAIN => m,
                    TRANSPOSED => m.transpose(),
                    _ => m + m.transpose(), // SYMMETRIZED
                };
                acc += m * f64::from(r.weight[e]);
            }
            *out = acc;
        }
    }

    /// `b = Pᵀ r_fine`, `x = 0`.
    fn restrict(&mut self, fine_r: &[Vec3]) {
        self.b.iter_mut().for_each(|v| *v = Vec3::ZERO);
        for (k, r) in fine_r.iter().enumerate() {
            for e in self.p_start[k] as usize..self.p_start[k + 1] as usize {
                self.b[self.p_node[e] as usize] += *r * self.p_weight[e];
            }
        }
        self.x.iter_mut().for_each(|v| *v = Vec3::ZERO);
    }

    /// `x_fine += P x`.
    fn prolong_add(&self, fine_x: &mut [Vec3]) {
        for (k, x) in fine_x.iter_mut().enumerate() {
            for e in self.p_start[k] as usize..self.p_start[k + 1] as usize {
                *x += self.x[self.p_node[e] as usize] * self.p_weight[e];
            }
        }
    }
}

/// The rows of `P` of a fine level of panels `shapes` (`free`: the nodes that have one) onto the panels
/// `coarse`: for each node, the tensor product of its owning panel's two directions' parents, as (row starts,
/// coarse nodes, weights) in the fine level's node order.
fn prolongation(
    free: &[bool],
    shapes: &[Shape],
    transfers: &[(Transfer1d, Transfer1d)],
    coarse: &[Shape],
) -> (Vec<u32>, Vec<u32>, Vec<f64>) {
    let mut rows: Vec<Vec<(u32, f64)>> = vec![Vec::new(); free.len()];
    for ((s, (t1, t2)), c) in shapes.iter().zip(transfers).zip(coarse) {
        let mc = t1.coarse;
        for (local, node) in s.nodes.iter().enumerate() {
            let Some(k) = node.map(|k| k as usize).filter(|&k| free[k]) else { continue };
            let (i, j) = (local % s.m, local / s.m);
            for &(ci, wi) in t1.parents(i) {
                for &(cj, wj) in t2.parents(j) {
                    rows[k].push((c.nodes[ci + mc * cj].expect("coarse panels own their nodes"), wi * wj));
                }
            }
        }
    }
    let mut p_start = Vec::with_capacity(free.len() + 1);
    p_start.push(0u32);
    let (mut p_node, mut p_weight) = (Vec::new(), Vec::new());
    for row in rows {
        for (node, w) in row {
            p_node.push(node);
            p_weight.push(w);
        }
        p_start.push(p_node.len() as u32);
    }
    (p_start, p_node, p_weight)
}

/// Every (coarse block key, fine block and kind, weight) of `Pᵀ A P`, sorted: the coarse pattern and the
/// recipe. The key orders coarse blocks by column then row, the pattern's own block order; ties are ordered by
/// the fine block, so the sums' order is fixed.
fn galerkin_entries<I: Iterator<Item = (usize, f64)>>(
    fine: &BlockPattern,
    parents: impl Fn(usize) -> I,
) -> Vec<(u64, u32, f32)> {
    let rows = fine.block_rows();
    let mut entries: Vec<(u64, u32, f32)> = Vec::new();
    for j in 0..fine.nodes() {
        let (s, e) = fine.column(j);
        for blk in s..e {
            let i = rows[blk];
            for (ci, wi) in parents(i) {
                for (cj, wj) in parents(j) {
                    let (lo, hi, kind) = if i == j {
                        if ci > cj {
                            continue;
                        }
                        (ci, cj, PLAIN)
                    } else if ci < cj {
                        (ci, cj, PLAIN)
                    } else if ci > cj {
                        (cj, ci, TRANSPOSED)
                    } else {
                        (ci, ci, SYMMETRIZED)
                    };
                    entries.push(((hi as u64) << 32 | lo as u64, (blk as u32) << 2 | kind, (wi * wj) as f32));
                }
            }
        }
    }
    entries.sort_unstable_by_key(|e| (e.0, e.1));
    entries
}

/// The coarse pattern of `nodes` nodes and the recipe of its blocks from the sorted Galerkin `entries`.
fn recipe(nodes: usize, entries: Vec<(u64, u32, f32)>) -> (BlockPattern, Recipe) {
    let split = |key: u64| ((key & 0xffff_ffff) as usize, (key >> 32) as usize);
    let mut groups = Vec::new();
    for (k, e) in entries.iter().enumerate() {
        if k == 0 || e.0 != entries[k - 1].0 {
            groups.push(k);
        }
    }
    groups.push(entries.len());
    let pattern = BlockPattern::from_pairs(nodes, groups[..groups.len() - 1].iter().map(|&g| split(entries[g].0)));
    // Coarse nodes whose children are all fixed have a diagonal block from `from_pairs` and no entries.
    let mut start = vec![0u32; pattern.blocks() + 1];
    let mut range = vec![(0usize, 0usize); pattern.blocks()];
    for g in groups.windows(2) {
        let (lo, hi) = split(entries[g[0]].0);
        range[pattern.find(lo, hi)] = (g[0], g[1]);
    }
    let mut entry = Vec::with_capacity(entries.len());
    let mut weight = Vec::with_capacity(entries.len());
    for (b, &(s, e)) in range.iter().enumerate() {
        for x in &entries[s..e] {
            entry.push(x.1);
            weight.push(x.2);
        }
        start[b + 1] = entry.len() as u32;
    }
    (pattern, Recipe { start, entry, weight })
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
        let Self { system, fine, coarse, .. } = self;
        let Some(fine) = fine.as_mut() else { unreachable!("built above") };
        fine.refill(a);
        coarse.refill(a)?;
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

    /// The step matrix of the 41×41 ball drop after a few steps (contacts and friction in it).
    fn step_matrix(n: usize, topology: [Topology; 2]) -> (BlockPattern, BlockMatrix, Grid) {
        let scene = crate::bench::ball_drop(n).unwrap();
        let mut state = scene.state.clone();
        let mut stepper = Stepper::new(&scene.model, &scene.step_params()).unwrap();
        stepper.assemble(&scene.model, &state);
        for _ in 0..3 {
            stepper.step(&scene.model, &mut state).unwrap();
        }
        stepper.assemble(&scene.model, &state);
        let grid = Grid { topology, ..scene.model.panels[0].grid };
        (scene.model.potential.pattern().clone(), stepper.matrix().clone(), grid)
    }

    #[test]
    fn coarse_operators_are_galerkin_products() {
        for topology in [[Topology::Free; 2], [Topology::Periodic, Topology::Free]] {
            let (pattern, a, grid) = step_matrix(41, topology);
            let fixed = vec![false; pattern.nodes()];
            let mut mg = Multigrid::on_grid(&pattern, &grid).unwrap();
            mg.build(&fixed).unwrap();
            mg.coarse.refill(&a).unwrap();
            let level = &mg.coarse.levels[0];
            let nc = level.pattern.nodes();
            let mut seed = 7;
            let v: Vec<Vec3> = (0..nc).map(|_| Vec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed))).collect();
            // P v, A P v, Pᵀ A P v.
            let mut pv = vec![Vec3::ZERO; pattern.nodes()];
            let mut lv = Level { x: v.clone(), ..level.clone_shape() };
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
        let (pattern, a, grid) = step_matrix(41, [Topology::Free; 2]);
        let mut fixed = vec![false; pattern.nodes()];
        fixed[5] = true;
        fixed[700] = true;
        let mut seed = 3;
        let b: Vec<Vec3> =
            (0..pattern.nodes()).map(|_| Vec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed))).collect();
        let mut x_direct = vec![Vec3::ZERO; b.len()];
        Cholesky::new(&pattern).unwrap().solve(&a, &fixed, &b, &mut x_direct, Reuse::Fresh).unwrap();
        let mut x = vec![Vec3::ZERO; b.len()];
        let stats = Multigrid::on_grid(&pattern, &grid).unwrap().solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap();
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
