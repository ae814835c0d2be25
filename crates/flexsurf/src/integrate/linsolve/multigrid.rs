//! Conjugate gradients preconditioned by a geometric multigrid cycle on the parametric grid's hierarchy
//! ([`BlockSolver`]), for grids where a factorisation's fill (memory growing faster than the nodes, work like
//! `n^1.4`) dominates a step.
//!
//! - **Hierarchy.** Each level halves the node count of every direction that has enough nodes: the even nodes
//!   of a free direction and its last node, or the even nodes of a periodic one, are the coarse nodes; an odd
//!   node takes half of each neighbour (linear interpolation on the parametric grid, wrapping around a
//!   periodic direction). The prolongation `P` is the tensor product of the two directions', with the rows
//!   of fixed nodes zero, so the coarse corrections never move a pinned node. Levels are added until
//!   [`Multigrid::COARSEST_NODES`] nodes (at least one on models of more than [`Multigrid::COARSENED_NODES`]) or no
//!   direction can be halved. Each panel of a garment is halved on its
//!   own grid, and sewn panels share their coarse nodes where a seam's joined node is a coarse node of both, as
//!   they share the fine ones: each coarse level is sewn as the fine one is (a tube of two gores then solves in
//!   the iterations of a periodic tube at every refinement; docs/performance.md, "Coarse nodes shared at seams").
//! - **Rotations.** On a curved sheet a fine node is not at its parents' centroid, so linear interpolation of
//!   Cartesian increments moves it off a rigid rotation of its parents (by `θ × (x − x̄)`): each block of `P` adds
//!   the rotation fitted to the parents' increments (least squares) times the node's offset from their
//!   centroid, which carries every rigid motion exactly (the twist about the line of two parents excepted) with
//!   the same sparsity (`Level::rotations`). The positions are the panels' rest shapes, or those given by
//!   [`BlockSolver::set_positions`].
//! - **Smoothed prolongation.** Each `P` is then smoothed by one damped Jacobi step on the finer level's matrix,
//!   kept on its own sparsity (`P ← P − ω D⁻¹ A P` at `P`'s entries, each row re-summed to the identity so that
//!   translations stay exact; `Level::smooth`, [`Multigrid::SMOOTHING`]): the columns' energy falls where linear
//!   interpolation leaves it high (a wrinkled or curved sheet's bending), without widening `P` or the coarse
//!   stencils, so an iteration costs what it did. Smoothed aggregation's wider smoothed `P` cut the iterations
//!   as far but its coarse operators cost more than they saved (docs/performance.md).
//! - **Coarse operators** are Galerkin's `A_c = Pᵀ A P` of the 3×3-block matrix, computed from a recipe built
//!   once (for each coarse block, the fine blocks and the blocks of `P` that multiply them, in a fixed order)
//!   and refilled in place for each solve but a re-solve ([`Reuse::Nearby`]: the matrix changed in a few
//!   diagonal blocks, which the refilled finest smoother sees; the coarse levels are kept, the same iterations
//!   at a fifth less set-up on the 321² sheet touching the ball); whatever couples nodes (the grid's stencils,
//!   seams, springs) is carried, the step's pairs between faces (blocks outside the pattern) included: each level
//!   keeps those of its parents that its pattern does not couple as extra blocks of its own.
//! - **Smoothing** is block Gauss–Seidel by grid lines ([`super::lines`]): the `u1` lines then the `u2` lines
//!   before the coarse correction, the same in reverse after it, so the cycle is a symmetric positive definite
//!   preconditioner; the coarsest level is solved by sparse Cholesky. Point smoothers measured 5–10× more
//!   iterations on fabrics (docs/performance.md): their membrane is far stiffer in tension than in shear.
//! - **Cycles.** Each coarse level's correction is one cycle of the levels below it (a V-cycle) on hierarchies
//!   of fewer than [`Multigrid::W_CYCLE_LEVELS`] levels, two from there (a W-cycle: the second on the residual
//!   the first leaves, [`Cycle`]). The V-cycle's iterations grow with the grid (17, 25, 33 and 37 from zero
//!   to 1e-11 on the sheet touching the ball at 161², 321², 481² and 641²), the W-cycle's far less (15, 18, 20,
//!   21) at about 1.5 times the cost an iteration, which pays from six levels (docs/performance.md).
//! - **Conjugate gradients** ([`super::cg`]) start from the caller's guess (the stepper passes the previous
//!   step's increment) and stop at the relative residual they are asked for (the stepper's: a forcing term,
//!   [`super::CONTACT_STEP_TOLERANCE`]), or [`super::ITERATIVE_TOLERANCE`].

use super::cholesky::Cholesky;
use super::lines::{grid_lines, LineSmoother};
use super::{BlockSolver, LinearError, Reduced, Reuse, SolveStats, SolverKind};
use crate::grid::{Grid, Topology};
use crate::math::{skew, Mat3, Vec3};
use crate::model::Panel;
use crate::sparse::{BlockMatrix, BlockPattern, ExtraBlocks};
use rayon::prelude::*;
use std::time::Instant;

/// One direction's coarsening: for each fine index, up to two coarse indices and weights.
#[derive(Debug, Clone)]
struct Transfer1d {
    coarse: usize,
    parents: Vec<[(usize, f64); 2]>,
    count: Vec<u8>,
    /// For each coarse index, the fine index at its place (whose only parent it is).
    at: Vec<usize>,
}

impl Transfer1d {
    /// The identity (a direction too short to halve).
    fn identity(count: usize) -> Self {
        let parents = (0..count).map(|i| [(i, 1.0), (0, 0.0)]).collect();
        Self { coarse: count, parents, count: vec![1; count], at: (0..count).collect() }
    }

    /// Halving `count` nodes of a free or periodic direction, or `None` when it has too few.
    fn halve(count: usize, topology: Topology) -> Option<Self> {
        let periodic = topology == Topology::Periodic;
        if count < if periodic { 6 } else { 5 } {
            return None;
        }
        // Coarse nodes: the even indices, plus the last index of a free direction of even count.
        let mut index = vec![usize::MAX; count];
        let mut at = Vec::with_capacity(count / 2 + 2);
        for (i, slot) in index.iter_mut().enumerate() {
            if i % 2 == 0 || (!periodic && i == count - 1) {
                *slot = at.len();
                at.push(i);
            }
        }
        let coarse = at.len();
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
        Some(Self { coarse, parents, count: counts, at })
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

/// The Galerkin product of one level: coarse block `c` is the sum over the entries `start[c]..start[c + 1]`
/// of `op(P_iᵀ A_fine[entry >> 2] P_j)`, `op` by the entry's two low bits, `P_i` and `P_j` the prolongation's
/// blocks `pi` and `pj` of the entry.
#[derive(Debug, Clone)]
struct Recipe {
    start: Vec<u32>,
    entry: Vec<u32>,
    pi: Vec<u32>,
    pj: Vec<u32>,
}

/// One panel's grid on one level, and the level's node of each of its nodes that it owns (a node joined by a
/// seam belongs to the first panel that has it, on every level: [`Shape::coarsen`]).
#[derive(Debug, Clone)]
struct Shape {
    m: usize,
    n: usize,
    topology: [Topology; 2],
    nodes: Vec<Option<u32>>,
    /// The level's node of each of its nodes, owned or not (a joined node's owner's).
    ids: Vec<u32>,
}

impl Shape {
    /// The panels of a model on the finest level.
    fn of_panels(panels: &[Panel]) -> Vec<Shape> {
        let mut owned = std::collections::BTreeSet::new();
        let shape = |p: &Panel| {
            let nodes = p.nodes().iter().map(|&k| owned.insert(k).then_some(k as u32)).collect();
            let ids = p.nodes().iter().map(|&k| k as u32).collect();
            Shape { m: p.grid.m, n: p.grid.n, topology: p.grid.topology, nodes, ids }
        };
        panels.iter().map(shape).collect()
    }

    /// Grids of `(m, n, topology)` owning their nodes, panel after panel.
    fn contiguous(grids: impl Iterator<Item = (usize, usize, [Topology; 2])>) -> Vec<Shape> {
        let mut offset = 0u32;
        grids
            .map(|(m, n, topology)| {
                let ids: Vec<u32> = (offset..offset + (m * n) as u32).collect();
                offset += (m * n) as u32;
                Shape { m, n, topology, nodes: ids.iter().copied().map(Some).collect(), ids }
            })
            .collect()
    }

    /// The coarse panels of the panels `shapes` halved by their `transfers`. A coarse node at a fine node that
    /// another panel owns (a seam's joined node) is the owner's coarse node there where the owner keeps one, so
    /// that sewn panels share their coarse seam nodes as they share the fine ones and the coarse levels stay sewn;
    /// every other coarse node is its panel's own, numbered panel after panel (a one-panel model's coarse grid in
    /// its own order). A joined node's owner comes first (ownership goes to the first panel, and within a panel to
    /// the first place), so its coarse node is numbered before it is looked up. Also each coarse node's source: the
    /// finer level's node at its place (whose position it takes).
    fn coarsen(shapes: &[Shape], transfers: &[(Transfer1d, Transfer1d)]) -> (Vec<Shape>, Vec<u32>) {
        let mut coarse_of = std::collections::HashMap::new();
        let mut source = Vec::new();
        let mut panel = |(s, (t1, t2)): (&Shape, &(Transfer1d, Transfer1d))| {
            let (mut nodes, mut ids) = (Vec::with_capacity(t1.coarse * t2.coarse), Vec::new());
            for &fj in &t2.at {
                for &fi in &t1.at {
                    let f = fi + s.m * fj;
                    let next = source.len() as u32;
                    let shared = s.nodes[f].is_none().then(|| coarse_of.get(&s.ids[f]).copied()).flatten();
                    nodes.push(shared.is_none().then_some(next));
                    ids.push(shared.unwrap_or(next));
                    if shared.is_none() {
                        coarse_of.entry(s.ids[f]).or_insert(next);
                        source.push(s.ids[f]);
                    }
                }
            }
            Shape { m: t1.coarse, n: t2.coarse, topology: s.topology, nodes, ids }
        };
        let coarse = shapes.iter().zip(transfers).map(&mut panel).collect();
        (coarse, source)
    }

    /// Owned nodes.
    fn owned(&self) -> usize {
        self.nodes.iter().flatten().count()
    }

    /// The `u1` lines and the `u2` lines of every panel, over the nodes it owns, each continued through a seam
    /// into the line of the same family that another panel has there ([`join_at_seams`]).
    fn lines(shapes: &[Shape]) -> [Vec<Vec<u32>>; 2] {
        [0, 1].map(|d| {
            let pieces = shapes.iter().flat_map(|s| {
                grid_lines(s.m, s.n, d).into_iter().map(|l| {
                    let beyond =
                        |k: Option<&u32>| k.filter(|&&k| s.nodes[k as usize].is_none()).map(|&k| s.ids[k as usize]);
                    let nodes = l.iter().filter_map(|&k| s.nodes[k as usize]).collect::<Vec<u32>>();
                    PanelLine { nodes, before: beyond(l.first()), after: beyond(l.last()) }
                })
            });
            join_at_seams(pieces.filter(|l| !l.nodes.is_empty()).collect())
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
#[derive(Clone)]
struct Level {
    pattern: BlockPattern,
    a: BlockMatrix,
    recipe: Recipe,
    /// For each node of the finer level: its parents here (node, weight), as rows of `P`, and the blocks of
    /// those rows (the weight times the identity, plus the rotation correction).
    p_start: Vec<u32>,
    p_node: Vec<u32>,
    p_weight: Vec<f64>,
    p_block: Vec<Mat3>,
    /// For each node here, the finer level's node at the same place (its position is this node's).
    source: Vec<u32>,
    /// This level's node positions.
    pos: Vec<Vec3>,
    smoother: LineSmoother,
    b: Vec<Vec3>,
    x: Vec<Vec3>,
    r: Vec<Vec3>,
    /// A W-cycle's right-hand side and first correction, kept while it solves again (empty in a V-cycle and on
    /// the coarsest level).
    held: [Vec<Vec3>; 2],
}

/// How each coarse level's correction is solved within a cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cycle {
    /// By one cycle of the levels below it, from zero.
    V,
    /// By two: the second on the residual the first leaves, its result added (symmetric, as the V-cycle).
    W,
}

/// Multigrid-preconditioned conjugate gradients.
pub struct Multigrid {
    /// The finest level's system with the fixed unknowns eliminated, and conjugate gradients on it.
    system: Reduced,
    /// The panels on the finest level.
    shapes: Vec<Shape>,
    /// The finest level's node positions: the panels' rest shapes until [`BlockSolver::set_positions`].
    positions: Vec<Vec3>,
    /// The finest level's smoother (and its matrix by rows), built at the first solve.
    fine: Option<LineSmoother>,
    coarse: Coarse,
    /// The fixed set the hierarchy was built for.
    built_fixed: Vec<bool>,
    /// The cycle asked for ([`Multigrid::with_cycle`]); `None`: by the hierarchy's depth.
    cycle: Option<Cycle>,
}

/// The levels below the finest and the cycle's scratch.
struct Coarse {
    levels: Vec<Level>,
    coarsest: Option<Cholesky>,
    fine_r: Vec<Vec3>,
    line_rhs: Vec<f64>,
    /// The cycle of this hierarchy.
    cycle: Cycle,
    /// The prolongations' smoothing weight ([`Multigrid::with_smoothing`]).
    smoothing: f64,
}

impl Multigrid {
    /// Levels are added while the coarsest has more nodes than this.
    pub const COARSEST_NODES: usize = 800;
    /// A model of fewer than [`Multigrid::COARSEST_NODES`] nodes but more than this still gets one coarse level:
    /// without it the preconditioner is the line smoother alone, whose iterations grow with the model's curvature
    /// (measured on 2026-12-06, `flexsurf run scenes/X.toml --solver multigrid --steps 30`: the four-gore skirt
    /// 38.0 → 13.7 iterations a solve, the straight skirt 43.8 → 11.4, `scenes/skirt.toml`'s 392-node skirt 21.9
    /// → 7.8, each faster). Larger models keep their hierarchy.
    pub const COARSENED_NODES: usize = 100;
    /// Most conjugate-gradient iterations of one solve.
    pub const MAX_ITERATIONS: usize = 200;
    /// Levels (the finest included) from which the hierarchy takes W-cycles ([`Cycle`]). Measured on the sheet
    /// touching the ball (docs/performance.md): at 161² (four levels) the W-cycle's iterations cost more than
    /// they save, at 321² (five) as much, at 481² and 641² (six) it is 5–14 % faster from zero to 1e-11 and
    /// 11 % on the bench's steps (their solves to 1e-6) at 641².
    pub const W_CYCLE_LEVELS: usize = 6;

    /// The weight `ω` of the damped Jacobi step that smooths each prolongation on its own sparsity
    /// ([`Multigrid::with_smoothing`]). Below `2 / ρ(D⁻¹A)` (ρ measured 1.8–2.6 on the step matrices of the
    /// touching sheet and the skirt) the step damps every mode of `P`'s columns; measured on 2026-12-06
    /// (docs/performance.md, "A prolongation smoothed on its own sparsity"): the wrinkled 81² drop's solve 50 → 29
    /// iterations, `skirt_fine`'s 18.8 → 13.6 a solve, the touching sheet 17 → 17 at 161² and 25 → 26 at 321².
    pub const SMOOTHING: f64 = 0.75;

    /// Buffers for `pattern` on a model's `panels` (the hierarchy is built at the first solve, for its fixed
    /// set): each panel is coarsened on its own grid, a node joined by a seam with the first panel that has it;
    /// the Galerkin products carry every coupling between panels to the coarse levels.
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
        Self::on_shapes(pattern, shapes, x)
    }

    /// As [`Multigrid::new`] for one grid whose nodes are the pattern's, at positions `x`.
    pub fn on_grid(pattern: &BlockPattern, grid: &Grid, x: &[Vec3]) -> Result<Self, LinearError> {
        Self::on_shapes(pattern, Shape::contiguous(std::iter::once((grid.m, grid.n, grid.topology))), x.to_vec())
    }

    fn on_shapes(pattern: &BlockPattern, shapes: Vec<Shape>, positions: Vec<Vec3>) -> Result<Self, LinearError> {
        let n = pattern.nodes();
        let owned: usize = shapes.iter().map(Shape::owned).sum();
        if owned != n
            || positions.len() != n
            || shapes.iter().flat_map(|s| s.nodes.iter().flatten()).any(|&k| k as usize >= n)
        {
            return Err(LinearError::Symbolic(format!(
                "the multigrid solver needs one unknown and one position per panel node ({owned} nodes, {n} \
                 unknowns, {} positions)",
                positions.len()
            )));
        }
        Ok(Self {
            system: Reduced::new(pattern),
            shapes,
            positions,
            fine: None,
            coarse: Coarse {
                levels: Vec::new(),
                coarsest: None,
                fine_r: vec![Vec3::ZERO; n],
                line_rhs: Vec::new(),
                cycle: Cycle::V,
                smoothing: Self::SMOOTHING,
            },
            built_fixed: Vec::new(),
            cycle: None,
        })
    }

    /// The same solver with every hierarchy it builds taking `cycle`, whatever its depth.
    pub fn with_cycle(mut self, cycle: Cycle) -> Self {
        self.cycle = Some(cycle);
        self
    }

    /// The same solver with its prolongations smoothed by a damped Jacobi step of weight `omega` (0: the plain
    /// interpolation with its fitted rotations; default [`Multigrid::SMOOTHING`]).
    pub fn with_smoothing(mut self, omega: f64) -> Self {
        self.coarse.smoothing = omega;
        self
    }

    /// The cycle of the hierarchy built at the last solve.
    pub fn cycle(&self) -> Cycle {
        self.coarse.cycle
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
        while nodes > Self::COARSEST_NODES || (c.levels.is_empty() && nodes > Self::COARSENED_NODES) {
            let transfers: Vec<(Transfer1d, Transfer1d)> = match shapes.iter().map(Shape::halve).collect() {
                Some(t) => t,
                None if shapes.len() == 1 => break,
                // Several panels: halve those that can, keep the others.
                None => shapes
                    .iter()
                    .map(|s| s.halve().unwrap_or_else(|| (Transfer1d::identity(s.m), Transfer1d::identity(s.n))))
                    .collect(),
            };
            let (coarse, source) = Shape::coarsen(&shapes, &transfers);
            let coarse_nodes: usize = coarse.iter().map(Shape::owned).sum();
            if coarse_nodes == nodes {
                break;
            }
            let fine = c.levels.last().map_or(self.system.pattern(), |l| &l.pattern);
            let level = Level::new(fine, &free, &shapes, &transfers, &coarse, source);
            free = vec![true; level.pattern.nodes()];
            (shapes, nodes) = (coarse, coarse_nodes);
            c.levels.push(level);
        }
        c.coarsest = match c.levels.last() {
            Some(last) => Some(Cholesky::new(&last.pattern)?),
            None => None,
        };
        let deep = c.levels.len() + 1 >= Self::W_CYCLE_LEVELS;
        c.cycle = self.cycle.unwrap_or(if deep { Cycle::W } else { Cycle::V });
        let held = if c.cycle == Cycle::W { c.levels.len().saturating_sub(1) } else { 0 };
        for level in &mut c.levels[..held] {
            level.held = [level.b.clone(), level.x.clone()];
        }
        let fine_len = self.fine.as_ref().map_or(0, LineSmoother::scratch_len);
        let longest = c.levels.iter().map(|l| l.smoother.scratch_len()).fold(fine_len, usize::max);
        c.line_rhs = vec![0.0; longest];
        self.built_fixed.clear();
        self.built_fixed.extend_from_slice(fixed);
        Ok(())
    }
}

impl Coarse {
    /// Refills the coarse operators from `a` (the finest's) with the prolongations at the finest level's
    /// positions `x`, their smoothers, and factorises the coarsest.
    fn refill(&mut self, a: &BlockMatrix, x: &[Vec3], finest: &LineSmoother) -> Result<(), LinearError> {
        for l in 0..self.levels.len() {
            let (above, below) = self.levels.split_at_mut(l);
            let (fine, fine_x) = above.last().map_or((a, x), |lv| (&lv.a, &lv.pos[..]));
            let rows = above.last().map_or(finest, |lv| &lv.smoother);
            let level = &mut below[0];
            level.rotations(fine_x);
            if self.smoothing != 0.0 {
                level.smooth(rows, self.smoothing);
            }
            level.galerkin(fine);
            level.smoother.refill(&level.a);
        }
        if let (Some(chol), Some(last)) = (self.coarsest.as_mut(), self.levels.last()) {
            chol.factorize(&last.a)?;
        }
        Ok(())
    }

    /// `out ≈ A⁻¹ r`: one cycle from zero, `fine` the finest level's smoother.
    fn precondition(&mut self, fine: &LineSmoother, r: &[Vec3], out: &mut [Vec3]) {
        fine.pre(r, out, &mut self.line_rhs);
        if !self.levels.is_empty() {
            fine.residual(r, out, &mut self.fine_r);
            self.levels[0].restrict(&self.fine_r);
            correct(&mut self.levels, self.coarsest.as_mut(), &mut self.line_rhs, self.cycle);
            self.levels[0].prolong_add(out);
        }
        fine.post(r, out, &mut self.line_rhs);
    }
}

/// `levels[0].x ≈ A₀⁻¹ levels[0].b`: one cycle of `levels` from zero, and in a W-cycle, where `levels[0]` is
/// not the coarsest (solved exactly), a second on the residual the first leaves, added to it.
fn correct(levels: &mut [Level], mut coarsest: Option<&mut Cholesky>, line_rhs: &mut [f64], kind: Cycle) {
    cycle(levels, coarsest.as_deref_mut(), line_rhs, kind);
    if kind == Cycle::V || levels.len() < 2 {
        return;
    }
    let first = &mut levels[0];
    first.smoother.residual(&first.b, &first.x, &mut first.r);
    // Keep `b` and the first cycle's `x`; solve again with the residual as the right-hand side.
    let [held_b, held_x] = &mut first.held;
    std::mem::swap(held_b, &mut first.b);
    std::mem::swap(&mut first.b, &mut first.r);
    std::mem::swap(held_x, &mut first.x);
    cycle(levels, coarsest, line_rhs, kind);
    let first = &mut levels[0];
    let [held_b, held_x] = &mut first.held;
    first.x.iter_mut().zip(held_x.iter()).for_each(|(x, h)| *x += *h);
    std::mem::swap(held_b, &mut first.b);
}

/// One cycle below the finest level from zero: `levels[0].x ≈ A₀⁻¹ levels[0].b`.
fn cycle(levels: &mut [Level], coarsest: Option<&mut Cholesky>, line_rhs: &mut [f64], kind: Cycle) {
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
    correct(rest, coarsest, line_rhs, kind);
    rest[0].prolong_add(&mut first.x);
    first.smoother.post(&first.b, &mut first.x, line_rhs);
}

impl Level {
    /// Bytes one application of `P` (or `Pᵀ`) reads: its blocks, weights and parent indices, and its row starts.
    fn transfer_bytes(&self) -> usize {
        self.p_block.len() * std::mem::size_of::<Mat3>()
            + self.p_weight.len() * 8
            + (self.p_node.len() + self.p_start.len()) * 4
    }

    /// The level below a fine level of panels `shapes` (`free`: nodes with a row in `P`) with the transfers of
    /// each panel's two directions, onto the panels `coarse` whose nodes are at the fine nodes `source`
    /// ([`Shape::coarsen`]).
    fn new(
        fine: &BlockPattern,
        free: &[bool],
        shapes: &[Shape],
        transfers: &[(Transfer1d, Transfer1d)],
        coarse: &[Shape],
        source: Vec<u32>,
    ) -> Self {
        let nodes = coarse.iter().map(Shape::owned).sum();
        let (p_start, p_node, p_weight) = prolongation(free, shapes, transfers, coarse);
        let parents = |k: usize| (p_start[k] as usize..p_start[k + 1] as usize).map(|e| (p_node[e] as usize, e));
        let (pattern, recipe) = recipe(nodes, galerkin_entries(fine, parents));
        let smoother = LineSmoother::new(&pattern, Shape::lines(coarse), &vec![false; nodes]);
        Self {
            a: BlockMatrix::zeros(&pattern),
            pattern,
            recipe,
            p_block: p_weight.iter().map(|&w| Mat3::from_diagonal(Vec3::splat(w))).collect(),
            p_start,
            p_node,
            p_weight,
            source,
            pos: vec![Vec3::ZERO; nodes],
            smoother,
            b: vec![Vec3::ZERO; nodes],
            x: vec![Vec3::ZERO; nodes],
            r: vec![Vec3::ZERO; nodes],
            held: [Vec::new(), Vec::new()],
        }
    }

    /// The blocks of `P` at the finer level's positions `fine_x` (and this level's positions, taken from
    /// them): a fine node `k` between the coarse nodes `c` (weights `w_c`, centroid `x̄`) follows
    /// `u_k = Σ w_c u_c + θ × (x_k − x̄)`, with `θ` the rotation that best fits the parents' displacements
    /// (least squares: `Σ |u_c − ū − θ × (x_c − x̄)|²`), so that every rigid motion of the parents is
    /// interpolated exactly (the rotation about the line of two parents excepted). Blocks
    /// `w_c I + [x_k − x̄]× G⁻¹ [x_c − x̄]×ᵀ`, `G = Σ [x_c − x̄]×ᵀ [x_c − x̄]×`.
    fn rotations(&mut self, fine_x: &[Vec3]) {
        for (p, &k) in self.pos.iter_mut().zip(&self.source) {
            *p = fine_x[k as usize];
        }
        for (k, xk) in fine_x.iter().enumerate() {
            let range = self.p_start[k] as usize..self.p_start[k + 1] as usize;
            let (nodes, weights) = (&self.p_node[range.clone()], &self.p_weight[range.clone()]);
            let center = nodes.iter().zip(weights).fold(Vec3::ZERO, |s, (&c, &w)| s + self.pos[c as usize] * w);
            let arm = |c: u32| skew(self.pos[c as usize] - center);
            let g = nodes.iter().fold(Mat3::ZERO, |g, &c| g + arm(c).transpose() * arm(c));
            let trace = g.x_axis.x + g.y_axis.y + g.z_axis.z;
            // `G⁻¹`, or for two parents `2 / |e|² = 2 / tr G`, `G`'s inverse on the plane normal to their line `e` (the
            // twist about `e` is not determined; the arms' products lie in that plane).
            let fit = match nodes.len() {
                2 => Mat3::from_diagonal(Vec3::splat(2.0 / trace)),
                _ if g.determinant() > 1e-9 * (trace / 3.0).powi(3) => g.inverse(),
                _ => Mat3::ZERO,
            };
            let usable = nodes.len() > 1 && trace > 0.0 && fit.is_finite();
            let lever = skew(*xk - center) * fit;
            for (out, (&c, &w)) in self.p_block[range].iter_mut().zip(nodes.iter().zip(weights)) {
                let identity = Mat3::from_diagonal(Vec3::splat(w));
                *out = if usable { identity + lever * arm(c).transpose() } else { identity };
            }
        }
    }

    /// One damped Jacobi step on the prolongation, kept on its own sparsity: `P ← P − ω D⁻¹ (A P)` at `P`'s
    /// entries (`A` the finer level's matrix as its smoother `rows` holds it, `D` its diagonal blocks), then each
    /// row's blocks re-summed to the identity along its interpolation weights, so that translations stay exact (a
    /// fine node at a coarse node keeps its identity row: only the interpolated nodes' rows change).
    /// The smoothing lowers the energy of `P`'s columns where linear interpolation leaves it high (a wrinkled or
    /// curved sheet's bending, which the coarse space then carries) without widening `P` or the coarse stencils
    /// (docs/performance.md, "A prolongation smoothed on its own sparsity").
    fn smooth(&mut self, rows: &LineSmoother, omega: f64) {
        let (p_start, p_node, p_block, p_weight) = (&self.p_start, &self.p_node, &self.p_block, &self.p_weight);
        let entry_of = |j: usize, c: u32| {
            (p_start[j] as usize..p_start[j + 1] as usize).find(|&f| p_node[f] == c).map(|f| p_block[f])
        };
        let smoothed_row = |k: usize| -> Vec<Mat3> {
            let range = p_start[k] as usize..p_start[k + 1] as usize;
            // A row of one parent (a fine node at a coarse node, weight 1) would be re-summed back to the identity.
            if range.len() < 2 {
                return p_block[range].to_vec();
            }
            let (cols, blocks) = rows.row(k);
            let diagonal = cols.iter().position(|&c| c as usize == k).map(|i| blocks[i].as_dmat3().inverse());
            let Some(dinv) = diagonal.filter(|d| d.is_finite()) else { return p_block[range].to_vec() };
            let a: Vec<Mat3> = blocks.iter().map(glam::Mat3::as_dmat3).collect();
            let mut out: Vec<Mat3> = range
                .clone()
                .map(|e| {
                    let c = p_node[e];
                    let ap = cols.iter().zip(&a).fold(Mat3::ZERO, |acc, (&j, m)| match entry_of(j as usize, c) {
                        Some(pj) => acc + *m * pj,
                        None => acc,
                    });
                    p_block[e] - dinv * ap * omega
                })
                .collect();
            let deficit = Mat3::IDENTITY - out.iter().fold(Mat3::ZERO, |s, m| s + *m);
            for (o, &w) in out.iter_mut().zip(&p_weight[range]) {
                *o += deficit * w;
            }
            out
        };
        let n = p_start.len() - 1;
        let smoothed: Vec<Mat3> = (0..n).into_par_iter().with_min_len(256).flat_map_iter(smoothed_row).collect();
        self.p_block = smoothed;
    }

    /// `A = Pᵀ A_fine P` in place: the pattern's blocks by the recipe, then the fine extra blocks (pairs between
    /// faces), each into the coarse block of its parents' pair, an extra block of this level where the coarse
    /// pattern does not couple them. The level's extra pairs are made afresh from the fine matrix's at each
    /// refill (the coarsest factorisation is analysed again only when they change, [`ExtraBlocks::replace`]):
    /// kept from refill to refill, as they were, they depended on the run's history beyond the step matrix,
    /// and a resumed run on multigrid ended its frames in other last bits than the uninterrupted run.
    fn galerkin(&mut self, fine: &BlockMatrix) {
        self.galerkin_pattern(fine);
        let mut extra = ExtraBlocks::default();
        let p = |k: usize| self.p_start[k] as usize..self.p_start[k + 1] as usize;
        for (&(i, j), m) in fine.extra.pairs().iter().zip(&fine.extra.blocks) {
            for ei in p(i) {
                for ej in p(j) {
                    let (ci, cj) = (self.p_node[ei] as usize, self.p_node[ej] as usize);
                    // `∂²/∂x_ci ∂x_cj` of the pair's coupling.
                    let b = self.p_block[ei].transpose() * *m * self.p_block[ej];
                    match self.pattern.get(ci, cj) {
                        Some(id) if ci == cj => self.a.blocks[id] += b + b.transpose(),
                        Some(id) => self.a.blocks[id] += if ci < cj { b } else { b.transpose() },
                        None => extra.add(ci, cj, b),
                    }
                }
            }
        }
        self.a.extra.replace(extra);
    }

    /// The pattern's part of [`Level::galerkin`].
    fn galerkin_pattern(&mut self, fine: &BlockMatrix) {
        let (r, p) = (&self.recipe, &self.p_block);
        for (c, out) in self.a.blocks.iter_mut().enumerate() {
            let mut acc = Mat3::ZERO;
            for e in r.start[c] as usize..r.start[c + 1] as usize {
                let code = r.entry[e];
                let m = p[r.pi[e] as usize].transpose() * fine.blocks[(code >> 2) as usize] * p[r.pj[e] as usize];
                acc += match code & 3 {
                    PLAIN => m,
                    TRANSPOSED => m.transpose(),
                    _ => m + m.transpose(), // SYMMETRIZED
                };
            }
            *out = acc;
        }
    }

    /// `b = Pᵀ r_fine`, `x = 0`.
    fn restrict(&mut self, fine_r: &[Vec3]) {
        self.b.iter_mut().for_each(|v| *v = Vec3::ZERO);
        for (k, r) in fine_r.iter().enumerate() {
            for e in self.p_start[k] as usize..self.p_start[k + 1] as usize {
                self.b[self.p_node[e] as usize] += self.p_block[e].transpose() * *r;
            }
        }
        self.x.iter_mut().for_each(|v| *v = Vec3::ZERO);
    }

    /// `x_fine += P x`.
    fn prolong_add(&self, fine_x: &mut [Vec3]) {
        for (k, x) in fine_x.iter_mut().enumerate() {
            for e in self.p_start[k] as usize..self.p_start[k + 1] as usize {
                *x += self.p_block[e] * self.x[self.p_node[e] as usize];
            }
        }
    }
}

/// A panel's grid line over the nodes it owns, and the nodes another panel owns just beyond its first and its
/// last place (a seam's joined nodes), through which it continues into that panel's line.
struct PanelLine {
    nodes: Vec<u32>,
    before: Option<u32>,
    after: Option<u32>,
}

/// The lines of one family with every line that continues through a seam into another panel's line (one whose
/// end is the joined node just beyond it) joined to it, end to end, in chains or, where the chain closes (a
/// skirt's gores around the body), in rings that the smoother takes whole ([`super::lines`]); lines without
/// such a neighbour come out as they came, in their order. Cut at the seams, a garment's hoop lines left their
/// stiff coupling across each seam to the Gauss–Seidel sweep, as a periodic ring's halves did (docs/performance.md,
/// "Periodic lines solved whole").
fn join_at_seams(lines: Vec<PanelLine>) -> Vec<Vec<u32>> {
    let mut end_of = std::collections::HashMap::new();
    for (t, l) in lines.iter().enumerate() {
        end_of.entry(l.nodes[0]).or_insert((t, 0));
        end_of.entry(l.nodes[l.nodes.len() - 1]).or_insert((t, 1));
    }
    // Each line end's neighbour (line, end), at most one each.
    let mut partner: Vec<Option<(usize, usize)>> = vec![None; 2 * lines.len()];
    for (t, l) in lines.iter().enumerate() {
        for (side, link) in [(0, l.before), (1, l.after)] {
            let Some(&(u, end)) = link.and_then(|k| end_of.get(&k)) else { continue };
            if u != t && partner[2 * t + side].is_none() && partner[2 * u + end].is_none() {
                partner[2 * t + side] = Some((u, end));
                partner[2 * u + end] = Some((t, side));
            }
        }
    }
    let mut visited = vec![false; lines.len()];
    // The chain entered at line `t` through its end `enter`, each line oriented so that it is entered first.
    let walk = |visited: &mut [bool], mut t: usize, mut enter: usize| {
        let mut chain = Vec::new();
        loop {
            visited[t] = true;
            match enter {
                0 => chain.extend_from_slice(&lines[t].nodes),
                _ => chain.extend(lines[t].nodes.iter().rev()),
            }
            match partner[2 * t + 1 - enter] {
                Some((u, end)) if !visited[u] => (t, enter) = (u, end),
                _ => return chain,
            }
        }
    };
    let mut out = Vec::with_capacity(lines.len());
    for t in 0..lines.len() {
        if !visited[t] && (partner[2 * t].is_none() || partner[2 * t + 1].is_none()) {
            let enter = usize::from(partner[2 * t].is_some());
            out.push(walk(&mut visited, t, enter));
        }
    }
    // What is left closes on itself.
    for t in 0..lines.len() {
        if !visited[t] {
            out.push(walk(&mut visited, t, 0));
        }
    }
    out
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
                    // A parent shared through a seam may be reached twice (a ring of two coarse nodes).
                    let parent = c.ids[ci + mc * cj];
                    match rows[k].iter_mut().find(|(c, _)| *c == parent) {
                        Some((_, w)) => *w += wi * wj,
                        None => rows[k].push((parent, wi * wj)),
                    }
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

/// Every (coarse block key, fine block and kind, the two prolongation blocks) of `Pᵀ A P`, sorted: the coarse
/// pattern and the recipe. The key orders coarse blocks by column then row, the pattern's own block order; ties
/// are ordered by the fine block, so the sums' order is fixed. `parents(k)`: `k`'s coarse nodes and the
/// prolongation's entries.
fn galerkin_entries<I: Iterator<Item = (usize, usize)>>(
    fine: &BlockPattern,
    parents: impl Fn(usize) -> I,
) -> Vec<(u64, u32, (u32, u32))> {
    let rows = fine.block_rows();
    let mut entries: Vec<(u64, u32, (u32, u32))> = Vec::new();
    for j in 0..fine.nodes() {
        let (s, e) = fine.column(j);
        for blk in s..e {
            let i = rows[blk];
            for (ci, ei) in parents(i) {
                for (cj, ej) in parents(j) {
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
                    entries.push(((hi as u64) << 32 | lo as u64, (blk as u32) << 2 | kind, (ei as u32, ej as u32)));
                }
            }
        }
    }
    entries.sort_unstable_by_key(|e| (e.0, e.1, e.2));
    entries
}

/// The coarse pattern of `nodes` nodes and the recipe of its blocks from the sorted Galerkin `entries`.
fn recipe(nodes: usize, entries: Vec<(u64, u32, (u32, u32))>) -> (BlockPattern, Recipe) {
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
    let (mut pi, mut pj) = (Vec::with_capacity(entries.len()), Vec::with_capacity(entries.len()));
    for (b, &(s, e)) in range.iter().enumerate() {
        for x in &entries[s..e] {
            entry.push(x.1);
            pi.push(x.2 .0);
            pj.push(x.2 .1);
        }
        start[b + 1] = entry.len() as u32;
    }
    (pattern, Recipe { start, entry, pi, pj })
}

impl BlockSolver for Multigrid {
    fn solve_to(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        reuse: Reuse,
        tolerance: Option<f64>,
    ) -> Result<SolveStats, LinearError> {
        let t0 = Instant::now();
        // A re-solve's matrix differs from the last solve's in a few diagonal blocks (an active set's change, a
        // friction re-linearisation): the finest level's smoother is refilled, the coarse levels are kept.
        let mut keep = reuse == Reuse::Nearby;
        if self.built_fixed != fixed || self.fine.is_none() {
            self.build(fixed)?;
            keep = false;
        }
        let Self { system, fine, coarse, positions, .. } = self;
        let Some(fine) = fine.as_mut() else { unreachable!("built above") };
        fine.refill(a);
        if !keep {
            coarse.refill(a, positions, fine)?;
        }
        system.eliminate(a, fixed, b, x);
        let t1 = Instant::now();
        let fine = &*fine;
        let iterations = system.cg(
            a,
            fixed,
            x,
            |r, out| coarse.precondition(fine, r, out),
            tolerance.unwrap_or(super::ITERATIVE_TOLERANCE),
            Self::MAX_ITERATIONS,
        )?;
        Ok(SolveStats::since(t0, t1, iterations, true))
    }

    /// The conjugate gradients' own bytes, the finest level's smoothing, and on each level below the transfers
    /// `Pᵀ` and `P` (their blocks, weights and indices) and its smoothing, or on the coarsest its factor's
    /// forward and backward solves (values and row indices).
    fn iteration_bytes(&self) -> usize {
        let Some(fine) = &self.fine else { return 0 };
        // `calls`: the corrections of a level an iteration makes (each a restriction and a prolongation);
        // `visits`: its cycles (two a correction in a W-cycle, the second after a residual).
        let (mut calls, mut below) = (1, 0);
        let levels = &self.coarse.levels;
        for (l, level) in levels.iter().enumerate() {
            if l + 1 == levels.len() {
                let coarsest = self.coarse.coarsest.as_ref().map_or(0, |c| 2 * c.factor_nnz() * 16);
                below += calls * (2 * level.transfer_bytes() + coarsest);
                break;
            }
            let visits = if self.coarse.cycle == Cycle::W { 2 * calls } else { calls };
            below += calls * 2 * level.transfer_bytes()
                + visits * level.smoother.cycle_bytes()
                + (visits - calls) * level.smoother.residual_bytes();
            calls = visits;
        }
        self.system.iteration_bytes() + fine.cycle_bytes() + below
    }

    fn set_positions(&mut self, x: &[Vec3]) {
        if x.len() == self.positions.len() {
            self.positions.copy_from_slice(x);
        }
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Multigrid
    }
}

/// The hierarchy's internals, for the unit tests in the suite (`tests/suite/unit_integrate.rs`); feature
/// `testing` only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    use super::{BlockMatrix, BlockPattern, Level, LinearError, Multigrid, Vec3};

    /// A coarse level's operator, its node positions and the parents of the finer level's nodes (the rows of
    /// the prolongation `P`: node `k`'s parents are `p_node[p_start[k]..p_start[k + 1]]`).
    pub struct LevelView<'a> {
        /// The level's block pattern.
        pub pattern: &'a BlockPattern,
        /// The level's Galerkin operator.
        pub a: &'a BlockMatrix,
        /// Where each finer node's parents start in `p_node`.
        pub p_start: &'a [u32],
        /// The parents.
        pub p_node: &'a [u32],
        /// The level's node positions.
        pub pos: &'a [Vec3],
    }

    /// Builds the hierarchy for the fixed set `fixed`.
    pub fn build(mg: &mut Multigrid, fixed: &[bool]) -> Result<(), LinearError> {
        mg.build(fixed)
    }

    /// Refills the finest level's smoother from `a` (after [`build`]).
    pub fn refill_fine(mg: &mut Multigrid, a: &BlockMatrix) {
        mg.fine.as_mut().expect("the hierarchy is built").refill(a);
    }

    /// Refills the coarse operators from `a` with the prolongations at the finest positions `x` (after
    /// [`refill_fine`]).
    pub fn refill_coarse(mg: &mut Multigrid, a: &BlockMatrix, x: &[Vec3]) -> Result<(), LinearError> {
        let fine = mg.fine.as_ref().expect("the hierarchy is built");
        mg.coarse.refill(a, x, fine)
    }

    /// `out ≈ A⁻¹ r`: one cycle from zero with the finest level's smoother.
    pub fn cycle(mg: &mut Multigrid, r: &[Vec3], out: &mut [Vec3]) {
        let fine = mg.fine.as_ref().expect("the hierarchy is built");
        mg.coarse.precondition(fine, r, out);
    }

    /// Coarse level `l`.
    pub fn level(mg: &Multigrid, l: usize) -> LevelView<'_> {
        let lv = &mg.coarse.levels[l];
        LevelView { pattern: &lv.pattern, a: &lv.a, p_start: &lv.p_start, p_node: &lv.p_node, pos: &lv.pos }
    }

    /// `fine_x += P x` from coarse level `l` with its unknowns `x`.
    pub fn prolong_add(mg: &Multigrid, l: usize, x: &[Vec3], fine_x: &mut [Vec3]) {
        let lv = Level { x: x.to_vec(), ..mg.coarse.levels[l].clone() };
        lv.prolong_add(fine_x);
    }

    /// `Pᵀ fine_r` onto coarse level `l`.
    pub fn restrict(mg: &Multigrid, l: usize, fine_r: &[Vec3]) -> Vec<Vec3> {
        let mut lv: Level = mg.coarse.levels[l].clone();
        lv.restrict(fine_r);
        lv.b
    }
}
