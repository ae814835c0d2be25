//! The nonlinear part of the elastic energy (docs/model.md §4.5): for a direction with a measured law
//! `ψ = ½ k x² + φ(x)` ([`crate::material::law`]), the linear terms ([`super::membrane`], [`super::bending`])
//! carry `½ k x²` with `k` the law's smallest slope, and the terms here add the excess `φ`, so that the total
//! energy of the direction is exactly `ψ`.
//!
//! **Where the law is applied.** Where the material frame is aligned with the grid everywhere (the warp along
//! `u1` or `u2` on an orthogonal grid), each strain of scheme S is one material strain: the membrane's excess
//! is `½ w φ(E)` on each of a cell's four edge strains (so a full weight on an interior edge, half on a free
//! boundary one, as the linear stretch energy) and `w φ(γ)` at its centre; the bending's excess is
//! `w φ(K)` on each nodal normal curvature with the linear energy's weights. Otherwise (a bias cut, a polar
//! grid) the material strains and curvatures exist only at cells, from the cell averages: the membrane's
//! excess is `w Σ φ_r((T Ā s)_r)` and the bending's `w Σ φ_r((T κ̄)_r)` over the cell's averaged normal
//! curvatures and its twist (the twist has no law). Both reduce to the linear energy for a straight-line law.
//!
//! **Operators.** Exact: `Σ c φ''(m) ∇m ∇mᵀ + Σ c φ'(m) ∇²m`. Projected: the first sum (positive
//! semi-definite, since `φ'' = N' − k ≥ 0`), plus for the membrane the positive part of each strain's excess
//! stress stiffness (Reflected: its absolute value); for bending the first sum alone. Secant: the membrane's
//! positive stress part only, the bending's first sum with frozen normals. So the excess follows the
//! conventions of the linear terms.

use super::bending::{cell_frame, cell_normal_stencils, node_frame, CellFrame, Point, MEASURES};
use super::frame::{Frame, Warp};
use super::membrane::stress_part;
use super::parallel::{assemble, Item, Local, Pool};
use super::{Operator, Sink};
use crate::grid::Grid;
use crate::material::law::{Curve, Laws};
use crate::math::{diag, outer, Mat3, Vec3};
use crate::ops::{second, tangent, CellOps, MAX_SUPPORT};
use crate::sparse::BlockPattern;

/// One law applied to a linear combination `m = gᵀ s` of a quadrature item's strains, with weight `c`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Use<const N: usize> {
    /// Which law: 0 warp, 1 weft, 2 shear (membrane); 0 warp, 1 weft (bending).
    law: usize,
    c: f64,
    g: [f64; N],
    /// The reference of the measure (a hysteresis's lagged state; 0 for an elastic law).
    m0: f64,
}

/// What a term applies to its measures: the elastic laws' excess, or a rate-independent hysteresis.
#[derive(Debug, Clone)]
enum LawSet {
    /// The laws with the stiffness of their quadratic parts.
    Elastic { curves: Vec<Option<Curve>>, k: Vec<f64> },
    /// Friction-like dissipation `H f₀(|m − m₀|)` per law, `H` the half loop width (0: none), `f₀` the
    /// smoothed absolute value of [`crate::potential::friction`] with smoothing length `eps`.
    Hysteresis { h: Vec<f64>, eps: f64 },
}

impl LawSet {
    fn new(curves: &[Option<&Curve>]) -> Self {
        let curves: Vec<Option<Curve>> = curves.iter().map(|c| c.cloned()).collect();
        let k = curves.iter().map(|c| c.as_ref().map_or(0.0, Curve::min_slope)).collect();
        Self::Elastic { curves, k }
    }

    /// Whether law `l` contributes.
    fn has(&self, l: usize) -> bool {
        match self {
            Self::Elastic { curves, .. } => curves[l].is_some(),
            Self::Hysteresis { h, .. } => h[l] > 0.0,
        }
    }

    /// `(value, first, second derivative)` of law `l` at `m` (the measure minus its reference).
    #[inline]
    fn excess(&self, l: usize, m: f64) -> (f64, f64, f64) {
        match self {
            Self::Elastic { curves, k } => match &curves[l] {
                Some(c) => c.excess(m, k[l]),
                None => (0.0, 0.0, 0.0),
            },
            Self::Hysteresis { h, eps } => {
                let (s, e) = (m.abs(), *eps);
                let (f, f1, f2) = if s < e {
                    (
                        -s * s * s / (3.0 * e * e) + s * s / e + e / 3.0,
                        2.0 * s / e - s * s / (e * e),
                        2.0 / e - 2.0 * s / (e * e),
                    )
                } else {
                    (s, 1.0, 0.0)
                };
                (h[l] * f, h[l] * f1 * m.signum(), h[l] * f2)
            }
        }
    }
}

/// A hysteresis reference `m0` dragged by the measure `m`: to `m ∓ eps` when further than `eps` from it (the
/// element slid; it sits at the edge of its stick range), else unchanged (it sticks).
fn dragged(m0: f64, m: f64, eps: f64) -> f64 {
    let d = m - m0;
    if d.abs() > eps {
        m - eps * d.signum()
    } else {
        m0
    }
}

/// Which material strain a parametric strain of an aligned frame is, and its scale: the row `r ∈ {0, 1}` of
/// the Voigt map with the larger entry in column `col`.
fn aligned_row(t: &[[f64; 3]; 3], col: usize) -> (usize, f64) {
    if t[0][col].abs() >= t[1][col].abs() {
        (0, t[0][col])
    } else {
        (1, t[1][col])
    }
}

/// Strains per cell, as in the membrane: bottom/top `E11`, left/right `E22`, centre `γ`.
const NS: usize = 5;

#[derive(Debug, Clone)]
struct Cell {
    nodes: [usize; 4],
    alpha: [[f64; 4]; NS],
    beta: [[f64; 4]; NS],
    scale: [f64; NS],
    rest: [f64; NS],
    uses: Vec<Use<NS>>,
    blocks: Vec<u32>,
}

/// The membrane's nonlinear excess.
#[derive(Clone)]
pub struct NonlinearMembrane {
    cells: Vec<Cell>,
    laws: LawSet,
    pool: Pool,
}

impl std::fmt::Debug for NonlinearMembrane {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NonlinearMembrane").field("cells", &self.cells).field("laws", &self.laws).finish()
    }
}

impl NonlinearMembrane {
    /// The excess of the membrane laws of `laws` on `grid` with rest shape `rest` and warp `warp`; `None`
    /// when no membrane direction has a law.
    pub fn new(grid: &Grid, rest: &[Vec3], laws: &Laws, warp: Warp) -> Option<Self> {
        let set = LawSet::new(&laws.membrane());
        Self::build(grid, rest, set, warp)
    }

    /// The shear hysteresis `2HG` (`half_width` = HG, N/m) of a sheet whose lagged state is `reference`: the
    /// dissipation `HG f₀(|γ − γ_ref|)` per cell (smoothing `eps` in γ), rate-independent, so a trellis shear
    /// cycle shows a loop of width 2HG in the shear force. A quasi-static loading path is a sequence of static
    /// solves, each with the previous equilibrium as its reference (docs/model.md §4.6).
    pub fn shear_hysteresis(
        grid: &Grid,
        rest: &[Vec3],
        half_width: f64,
        eps: f64,
        warp: Warp,
        reference: &[Vec3],
    ) -> Option<Self> {
        let set = LawSet::Hysteresis { h: vec![0.0, 0.0, half_width], eps };
        let mut term = Self::build(grid, rest, set, warp)?;
        term.set_reference(reference, eps);
        Some(term)
    }

    /// A hysteresis's lagged state: the shear of `reference` (positions indexed as the term's nodes) and the
    /// smoothing length `eps`. No effect on elastic laws.
    pub fn set_reference(&mut self, reference: &[Vec3], eps: f64) {
        let LawSet::Hysteresis { eps: e, .. } = &mut self.laws else { return };
        *e = eps;
        for c in &mut self.cells {
            let s = c.strains(reference);
            for u in &mut c.uses {
                u.m0 = (0..NS).map(|a| u.g[a] * s[a]).sum();
            }
        }
    }

    /// A hysteresis's lagged state dragged to `x` (the next step's start): each reference `m₀` further than
    /// `eps` from its measure `m` at `x` moves to `m ∓ eps`, the edge of the stick range; one within `eps`
    /// stays (docs/model.md §4.6). No effect on elastic laws.
    pub fn drag_reference(&mut self, x: &[Vec3], eps: f64) {
        let LawSet::Hysteresis { eps: e, .. } = &mut self.laws else { return };
        *e = eps;
        for c in &mut self.cells {
            let s = c.strains(x);
            for u in &mut c.uses {
                u.m0 = dragged(u.m0, (0..NS).map(|a| u.g[a] * s[a]).sum(), eps);
            }
        }
    }

    /// The references `m₀` of every use, in order (a hysteresis's lagged state, for a checkpoint).
    pub fn references(&self) -> Vec<f64> {
        self.cells.iter().flat_map(|c| c.uses.iter().map(|u| u.m0)).collect()
    }

    /// Sets the references of [`Self::references`] and the smoothing `eps`; false (and nothing set) when
    /// `m0` has not one value per use.
    pub fn set_references(&mut self, m0: &[f64], eps: f64) -> bool {
        let LawSet::Hysteresis { eps: e, .. } = &mut self.laws else { return false };
        if m0.len() != self.cells.iter().map(|c| c.uses.len()).sum::<usize>() {
            return false;
        }
        *e = eps;
        let mut it = m0.iter();
        for u in self.cells.iter_mut().flat_map(|c| c.uses.iter_mut()) {
            u.m0 = it.next().copied().unwrap_or(u.m0);
        }
        true
    }

    fn build(grid: &Grid, rest: &[Vec3], set: LawSet, warp: Warp) -> Option<Self> {
        if !(0..3).any(|l| set.has(l)) {
            return None;
        }
        let cell_frame = |ops: &CellOps| {
            let comb = |c: &[f64; 4]| (0..4).fold(Vec3::ZERO, |acc, k| acc + rest[ops.nodes[k]] * c[k]);
            Frame::with_warp(comb(&ops.c1), comb(&ops.c2), warp)
        };
        let aligned = grid.cells().all(|(i, j)| cell_frame(&CellOps::new(grid, i, j)).is_aligned());
        let cells = grid
            .cells()
            .map(|(i, j)| {
                let ops = CellOps::new(grid, i, j);
                let alpha = [ops.e1[0], ops.e1[1], ops.e2[0], ops.e2[1], ops.c1];
                let beta = [ops.e1[0], ops.e1[1], ops.e2[0], ops.e2[1], ops.c2];
                let scale = [1.0, 1.0, 1.0, 1.0, 2.0];
                let x0: [Vec3; 4] = ops.nodes.map(|k| rest[k]);
                let comb = |c: &[f64; 4]| (0..4).fold(Vec3::ZERO, |acc, k| acc + x0[k] * c[k]);
                let restv: [f64; NS] = std::array::from_fn(|a| 0.5 * scale[a] * comb(&alpha[a]).dot(comb(&beta[a])));
                let frame = cell_frame(&ops);
                let (t, w) = (frame.voigt(), grid.h1 * grid.h2 * frame.area);
                let mut uses = Vec::new();
                if aligned {
                    for a in 0..4 {
                        let (r, tr) = aligned_row(&t, a / 2);
                        let mut g = [0.0; NS];
                        g[a] = tr;
                        uses.push(Use { law: r, c: 0.5 * w, g, m0: 0.0 });
                    }
                    let mut g = [0.0; NS];
                    g[4] = t[2][2];
                    uses.push(Use { law: 2, c: w, g, m0: 0.0 });
                } else {
                    // Rows of T Ā: the material strains of the cell averages.
                    for (r, row) in t.iter().enumerate() {
                        let g = [0.5 * row[0], 0.5 * row[0], 0.5 * row[1], 0.5 * row[1], row[2]];
                        uses.push(Use { law: r, c: w, g, m0: 0.0 });
                    }
                }
                uses.retain(|u| set.has(u.law));
                Cell { nodes: ops.nodes, alpha, beta, scale, rest: restv, uses, blocks: Vec::new() }
            })
            .collect();
        Some(Self { cells, laws: set, pool: Pool::default() })
    }

    /// Renumbers the nodes (as [`super::membrane::Membrane::map_nodes`]).
    pub fn map_nodes(&mut self, map: &[usize]) {
        for c in &mut self.cells {
            c.nodes = c.nodes.map(|k| map[k]);
        }
    }

    /// The node pairs whose Hessian block this term touches.
    pub fn pairs(&self) -> Vec<(usize, usize)> {
        super::parallel::pairs(&self.cells)
    }

    /// Precomputes block ids for a pattern that contains [`Self::pairs`].
    pub fn bind(&mut self, pattern: &BlockPattern) {
        super::parallel::bind(&mut self.cells, pattern);
    }

    /// Adds gradient and operator into `sink`; returns the excess energy.
    pub fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> f64 {
        assemble(&self.cells, &self.pool, (4, 10), 0.0, sink, |cell, out| cell.evaluate(x, &self.laws, out))
    }
}

impl Item for Cell {
    fn nodes(&self) -> &[usize] {
        &self.nodes
    }
    fn blocks(&self) -> &[u32] {
        &self.blocks
    }
    fn set_blocks(&mut self, blocks: Vec<u32>) {
        self.blocks = blocks;
    }
}

impl Cell {
    /// The cell's five strains at `x`.
    fn strains(&self, x: &[Vec3]) -> [f64; NS] {
        let xl: [Vec3; 4] = self.nodes.map(|k| x[k]);
        let comb = |c: &[f64; 4]| xl[0] * c[0] + xl[1] * c[1] + xl[2] * c[2] + xl[3] * c[3];
        std::array::from_fn(|a| 0.5 * self.scale[a] * comb(&self.alpha[a]).dot(comb(&self.beta[a])) - self.rest[a])
    }

    fn evaluate(&self, x: &[Vec3], laws: &LawSet, out: Local) -> f64 {
        let xl: [Vec3; 4] = self.nodes.map(|k| x[k]);
        let comb = |c: &[f64; 4]| xl[0] * c[0] + xl[1] * c[1] + xl[2] * c[2] + xl[3] * c[3];
        let p: [Vec3; NS] = std::array::from_fn(|a| comb(&self.alpha[a]));
        let r: [Vec3; NS] = std::array::from_fn(|a| comb(&self.beta[a]));
        let s: [f64; NS] = std::array::from_fn(|a| 0.5 * self.scale[a] * p[a].dot(r[a]) - self.rest[a]);
        let mut energy = 0.0;
        let mut sigma = [0.0; NS];
        let mut curv = [0.0; NS];
        for (u, cv) in self.uses.iter().zip(curv.iter_mut()) {
            let m: f64 = (0..NS).map(|a| u.g[a] * s[a]).sum::<f64>() - u.m0;
            let (f, f1, f2) = laws.excess(u.law, m);
            energy += u.c * f;
            for a in 0..NS {
                sigma[a] += u.c * f1 * u.g[a];
            }
            *cv = u.c * f2;
        }
        if out.energy_only() {
            return energy;
        }
        let mut ds = [[Vec3::ZERO; 4]; NS];
        for a in 0..NS {
            for k in 0..4 {
                ds[a][k] = (r[a] * self.alpha[a][k] + p[a] * self.beta[a][k]) * (0.5 * self.scale[a]);
            }
        }
        if let Some(g) = out.grad {
            for k in 0..4 {
                g[k] = (0..NS).fold(Vec3::ZERO, |f, a| f + ds[a][k] * sigma[a]);
            }
        }
        if let Some((h, op)) = out.hess {
            self.hessian(h, op, &ds, &sigma, &curv);
        }
        energy
    }

    /// The operator: material part `Σ c φ'' ∇m ∇mᵀ` (not secant) and the stress part of `sigma`.
    fn hessian(&self, h: &mut [Mat3], op: Operator, ds: &[[Vec3; 4]; NS], sigma: &[f64; NS], curv: &[f64; NS]) {
        let mut geo = [[0.0; 4]; 4];
        for a in 0..NS {
            let (al, be, sc) = (&self.alpha[a], &self.beta[a], self.scale[a]);
            match op {
                Operator::Exact => {
                    for k in 0..4 {
                        for l in 0..4 {
                            geo[k][l] += sigma[a] * 0.5 * sc * (al[k] * be[l] + be[k] * al[l]);
                        }
                    }
                }
                _ => stress_part(&mut geo, al, be, 0.5 * sc * sigma[a], op == Operator::Reflected),
            }
        }
        // ∇_k m for each use.
        let grads: Vec<[Vec3; 4]> = self
            .uses
            .iter()
            .map(|u| std::array::from_fn(|k| (0..NS).fold(Vec3::ZERO, |acc, a| acc + ds[a][k] * u.g[a])))
            .collect();
        let mut id = 0;
        for k in 0..4 {
            for l in k..4 {
                let mut m = diag(geo[k][l]);
                if op != Operator::Secant {
                    for (gm, c) in grads.iter().zip(curv) {
                        m += outer(gm[k], gm[l]) * *c;
                    }
                }
                h[id] = m;
                id += 1;
            }
        }
    }
}

/// The bending's nonlinear excess.
#[derive(Clone)]
pub struct NonlinearBending {
    points: Vec<(Point, Vec<Use<MEASURES>>)>,
    laws: LawSet,
    strides: (usize, usize),
    pool: Pool,
}

impl std::fmt::Debug for NonlinearBending {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NonlinearBending").field("points", &self.points).field("laws", &self.laws).finish()
    }
}

impl Item for (Point, Vec<Use<MEASURES>>) {
    fn nodes(&self) -> &[usize] {
        self.0.support.nodes()
    }
    fn blocks(&self) -> &[u32] {
        &self.0.blocks
    }
    fn set_blocks(&mut self, blocks: Vec<u32>) {
        self.0.blocks = blocks;
    }
}

impl NonlinearBending {
    /// The excess of the bending laws of `laws` at the nodes `k` with `node(k)` and the cells with
    /// `cell(i, j)` (as [`super::bending::Bending`]'s selection); `None` when no bending direction has a law.
    pub fn new(
        grid: &Grid,
        rest: &[Vec3],
        laws: &Laws,
        warp: Warp,
        node: impl Fn(usize) -> bool,
        cell: impl Fn(usize, usize) -> bool,
    ) -> Option<Self> {
        let set = LawSet::new(&laws.bending());
        Self::build(grid, rest, set, warp, node, cell)
    }

    /// The bending hysteresis `2HB` (`half_width` = HB per direction, warp and weft, moment per width in N) of
    /// a sheet whose lagged state is `reference`: the dissipation `HB f₀(|K − K_ref|)` (smoothing `eps` in
    /// curvature) where the elastic bending laws sit, rate-independent: a bending cycle shows a loop of width
    /// 2HB in the moment (docs/model.md §4.6).
    pub fn hysteresis(
        grid: &Grid,
        rest: &[Vec3],
        half_width: [f64; 2],
        eps: f64,
        warp: Warp,
        reference: &[Vec3],
    ) -> Option<Self> {
        Self::hysteresis_selected(grid, rest, half_width, eps, warp, reference, |_| true, |_, _| true)
    }

    /// [`Self::hysteresis`] at the nodes `k` with `node(k)` and the cells with `cell(i, j)` only (as
    /// [`Self::new`]'s selection: a panel without its seamed edges, or a seam's strip).
    #[allow(clippy::too_many_arguments)]
    pub fn hysteresis_selected(
        grid: &Grid,
        rest: &[Vec3],
        half_width: [f64; 2],
        eps: f64,
        warp: Warp,
        reference: &[Vec3],
        node: impl Fn(usize) -> bool,
        cell: impl Fn(usize, usize) -> bool,
    ) -> Option<Self> {
        let set = LawSet::Hysteresis { h: half_width.to_vec(), eps };
        let mut term = Self::build(grid, rest, set, warp, node, cell)?;
        term.set_reference(reference, eps);
        Some(term)
    }

    /// A hysteresis's lagged state: the curvatures of `reference` (positions indexed as the term's nodes) and
    /// the smoothing length `eps`. No effect on elastic laws.
    pub fn set_reference(&mut self, reference: &[Vec3], eps: f64) {
        let LawSet::Hysteresis { eps: e, .. } = &mut self.laws else { return };
        *e = eps;
        for (p, uses) in &mut self.points {
            let kappa = p.kernels(reference).4;
            for u in uses {
                u.m0 = (0..MEASURES).map(|q| u.g[q] * kappa[q]).sum();
            }
        }
    }

    /// A hysteresis's lagged state dragged to `x` (as [`NonlinearMembrane::drag_reference`]).
    pub fn drag_reference(&mut self, x: &[Vec3], eps: f64) {
        let LawSet::Hysteresis { eps: e, .. } = &mut self.laws else { return };
        *e = eps;
        for (p, uses) in &mut self.points {
            let kappa = p.kernels(x).4;
            for u in uses {
                u.m0 = dragged(u.m0, (0..MEASURES).map(|q| u.g[q] * kappa[q]).sum(), eps);
            }
        }
    }

    /// The references `m₀` of every use, in order (a hysteresis's lagged state, for a checkpoint).
    pub fn references(&self) -> Vec<f64> {
        self.points.iter().flat_map(|(_, uses)| uses.iter().map(|u| u.m0)).collect()
    }

    /// Sets the references of [`Self::references`] and the smoothing `eps`; false (and nothing set) when
    /// `m0` has not one value per use.
    pub fn set_references(&mut self, m0: &[f64], eps: f64) -> bool {
        let LawSet::Hysteresis { eps: e, .. } = &mut self.laws else { return false };
        if m0.len() != self.points.iter().map(|(_, uses)| uses.len()).sum::<usize>() {
            return false;
        }
        *e = eps;
        let mut it = m0.iter();
        for u in self.points.iter_mut().flat_map(|(_, uses)| uses.iter_mut()) {
            u.m0 = it.next().copied().unwrap_or(u.m0);
        }
        true
    }

    fn build(
        grid: &Grid,
        rest: &[Vec3],
        set: LawSet,
        warp: Warp,
        node: impl Fn(usize) -> bool,
        cell: impl Fn(usize, usize) -> bool,
    ) -> Option<Self> {
        if !(0..2).any(|l| set.has(l)) {
            return None;
        }
        let node_frame = |k: usize| {
            let (i, j) = grid.coords(k);
            let (a, b) =
                (crate::ops::apply(&tangent(grid, 0, i, j), rest), crate::ops::apply(&tangent(grid, 1, i, j), rest));
            Frame::with_warp(a, b, warp)
        };
        let cell_frame = |i: usize, j: usize| {
            let ops = CellOps::new(grid, i, j);
            let comb = |c: &[f64; 4]| (0..4).fold(Vec3::ZERO, |acc, q| acc + rest[ops.nodes[q]] * c[q]);
            Frame::with_warp(comb(&ops.c1), comb(&ops.c2), warp)
        };
        let aligned = (0..grid.len()).all(|k| node_frame(k).is_aligned())
            && grid.cells().all(|(i, j)| cell_frame(i, j).is_aligned());
        let mut points: Vec<(Point, Vec<Use<MEASURES>>)> = if aligned {
            (0..grid.len()).filter(|&k| node(k)).filter_map(|k| node_point(grid, rest, warp, k)).collect()
        } else {
            grid.cells().filter(|&(i, j)| cell(i, j)).map(|(i, j)| cell_point(grid, rest, warp, i, j)).collect()
        };
        for (_, uses) in &mut points {
            uses.retain(|u| set.has(u.law));
        }
        points.retain(|(_, uses)| !uses.is_empty());
        let len = points.iter().map(|p| p.0.support.len).max().unwrap_or(0);
        Some(Self { points, laws: set, strides: (len.max(1), (len * (len + 1) / 2).max(1)), pool: Pool::default() })
    }

    /// Sets the rest curvature to zero (as [`super::bending::Bending::flatten_rest_curvature`]).
    pub fn flatten_rest_curvature(&mut self) {
        for (p, _) in &mut self.points {
            p.rest = [0.0; MEASURES];
        }
    }

    /// Renumbers the nodes: a point's support is rebuilt, coefficients of nodes that become one summed.
    pub fn map_nodes(&mut self, map: &[usize]) {
        for (p, _) in &mut self.points {
            *p = p.mapped(map);
        }
    }

    /// The node pairs whose Hessian block this term touches.
    pub fn pairs(&self) -> Vec<(usize, usize)> {
        super::parallel::pairs(&self.points)
    }

    /// Precomputes block ids for a pattern that contains [`Self::pairs`].
    pub fn bind(&mut self, pattern: &BlockPattern) {
        super::parallel::bind(&mut self.points, pattern);
    }

    /// Adds gradient and operator into `sink`; returns the excess energy.
    pub fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> f64 {
        let laws = &self.laws;
        assemble(&self.points, &self.pool, self.strides, 0.0, sink, |(p, uses), out| {
            p.evaluate_with(x, out, |kappa| {
                let (mut mom, mut energy, mut d) = ([0.0; MEASURES], 0.0, [[0.0; MEASURES]; MEASURES]);
                for u in uses {
                    let m: f64 = (0..MEASURES).map(|q| u.g[q] * kappa[q]).sum::<f64>() - u.m0;
                    let (f, f1, f2) = laws.excess(u.law, m);
                    energy += u.c * f;
                    for q in 0..MEASURES {
                        mom[q] += u.c * f1 * u.g[q];
                        for r in 0..MEASURES {
                            d[q][r] += u.c * f2 * u.g[q] * u.g[r];
                        }
                    }
                }
                (mom, energy, d)
            })
        })
    }
}

/// The nodal point of node `k` (aligned frames): its normal curvatures, each one material curvature.
fn node_point(grid: &Grid, rest: &[Vec3], warp: Warp, k: usize) -> Option<(Point, Vec<Use<MEASURES>>)> {
    let w = grid.h1 * grid.h2;
    let (i, j) = grid.coords(k);
    let (mut sup, a, b, frame) = node_frame(grid, rest, warp, k);
    let t = frame.voigt();
    let mut v = [[0.0; MAX_SUPPORT]; MEASURES];
    let mut uses = Vec::new();
    for d in 0..2 {
        if let Some(st) = second(grid, d, i, j) {
            let m = uses.len();
            v[m] = sup.scatter(&st);
            let (r, tr) = aligned_row(&t, d);
            let mut g = [0.0; MEASURES];
            g[m] = tr;
            uses.push(Use {
                law: r,
                c: w * frame.area * grid.trapezoid(1 - d, if d == 0 { j } else { i }),
                g,
                m0: 0.0,
            });
        }
    }
    let count = uses.len();
    (count > 0).then(|| (Point::new(sup, a, b, v, count, [[0.0; MEASURES]; MEASURES], rest), uses))
}

/// The cell point of cell `(i, j)` (frames not aligned): twist and averaged normal curvatures, the material
/// normal curvatures `(T κ')_r` of `κ' = (κ̄11, κ̄22, 2κ12)`.
fn cell_point(grid: &Grid, rest: &[Vec3], warp: Warp, i: usize, j: usize) -> (Point, Vec<Use<MEASURES>>) {
    let CellFrame { ops, mut sup, a, b, twist: tw, frame } = cell_frame(grid, rest, warp, i, j);
    let [v1, v2] = cell_normal_stencils(grid, &ops, &mut sup);
    let t = frame.voigt();
    let w = grid.h1 * grid.h2 * frame.area;
    let uses = (0..2).map(|r| Use { law: r, c: w, g: [2.0 * t[r][2], t[r][0], t[r][1]], m0: 0.0 }).collect();
    (Point::new(sup, a, b, [tw, v1, v2], MEASURES, [[0.0; MEASURES]; MEASURES], rest), uses)
}
