//! Bending energy of scheme S (docs/model.md §5): normal curvatures `B11 = n·T11x`, `B22 = n·T22x` at nodes with
//! the paper's 3-point second differences and nodal normals from (51)–(52) (one-sided on free edges), and the
//! twist `B12` at cell centres from the bilinear cell tangents. The rest curvature `B⁰` comes from the same
//! operators on the rest shape, so a curved rest shape holds with zero force.
//!
//! Per quadrature point `W = ½ κᵀ D κ` over its curvature changes `κ = B − B⁰` (one or two at nodes; at cells
//! the twist alone, or with the cell-averaged normal curvatures where the material frame is not aligned with the
//! grid, see `split`).

use super::curvature::NormalCurvature;
use super::frame::{Frame, Warp};
use super::parallel::{assemble, Item, Local, Pool};
use super::{Operator, Sink};
use crate::grid::Grid;
use crate::material::Stiffness;
use crate::math::{outer, Mat3, Vec3};
use crate::ops::{combine, second, tangent, CellOps, Support, MAX_SUPPORT};
use crate::sparse::BlockPattern;

type Coefs = [f64; MAX_SUPPORT];

/// Most curvature measures at one quadrature point: the normal curvatures and, at cells where the material
/// frame is not aligned with the grid, the twist together with cell averages of the normal curvatures.
pub(crate) const MEASURES: usize = 3;

/// One quadrature point: a normal from tangents `a`, `b` and up to [`MEASURES`] curvature measures `n·v_m`.
#[derive(Debug, Clone)]
pub(crate) struct Point {
    pub(crate) support: Support,
    pub(crate) a: Coefs,
    pub(crate) b: Coefs,
    pub(crate) v: [Coefs; MEASURES],
    pub(crate) count: usize,
    pub(crate) rest: [f64; MEASURES],
    /// Weighted stiffness `w D` of the measures.
    pub(crate) d: [[f64; MEASURES]; MEASURES],
    pub(crate) blocks: Vec<u32>,
}

/// Bending (curvature and twist) energy of the whole grid.
#[derive(Clone)]
pub struct Bending {
    pub(crate) points: Vec<Point>,
    /// Most support nodes and operator blocks of one point (the strides of the parallel assembly's buffers).
    pub(crate) strides: (usize, usize),
    /// Buffers of the parallel assembly.
    pub(crate) pool: Pool,
}

/// The data alone (the assembly's buffers are not part of the term; run fingerprints hash this).
impl std::fmt::Debug for Bending {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bending").field("points", &self.points).finish()
    }
}

/// The parametric bending stiffness `C` on `(κ11, κ22, 2κ12)` split into the part carried by the nodal normal
/// curvatures and the part carried by the cell twist: `½ κᵀ C κ = ½ κₙᵀ S κₙ + ½ (gᵀ κ)² / C₃₃` with
/// `κₙ = (κ11, κ22)`, `S = Cₙₙ − c cᵀ / C₃₃` (the Schur complement, PSD when `C` is) and `g = (c, C₃₃)`,
/// `c = (C₁₃, C₂₃)`. When the frame is aligned with the grid `c = 0`: the twist term is `½ C₃₃ (2κ12)²` alone.
fn split(c: &[[f64; 3]; 3], aligned: bool) -> ([[f64; 2]; 2], [f64; 3]) {
    let nn = [[c[0][0], c[0][1]], [c[1][0], c[1][1]]];
    let d = c[2][2];
    if aligned || d <= 0.0 {
        return (nn, [0.0, 0.0, d]);
    }
    let cv = [c[0][2], c[1][2]];
    let mut s = nn;
    for r in 0..2 {
        for q in 0..2 {
            s[r][q] -= cv[r] * cv[q] / d;
        }
    }
    (s, [cv[0], cv[1], d])
}

impl Bending {
    /// Renumbers the nodes: local node `k` becomes `map[k]` (a panel's nodes in the model, welded across its
    /// seams). Where two local nodes become one model node their coefficients are summed into one slot.
    pub fn map_nodes(&mut self, map: &[usize]) {
        for p in &mut self.points {
            *p = p.mapped(map);
        }
    }
}

impl Bending {
    /// Builds the quadrature points of `grid` with rest shape `rest` and stiffness `s`, warp along `u1`.
    pub fn new(grid: &Grid, rest: &[Vec3], s: &Stiffness) -> Self {
        Self::with_warp_angle(grid, rest, s, 0.0)
    }

    /// As [`Bending::new`] with the warp at `warp_angle` from the `u1` tangent. Curvatures are measured in the
    /// material frame, `K = J⁻ᵀ κ J⁻¹`; the bending stiffness is pulled back to the parametric curvatures `C`.
    /// The normal curvatures live at nodes and the twist at cells; when the frame is not aligned with the grid
    /// (`J` neither diagonal nor anti-diagonal: a bias cut, a polar grid of one piece of fabric) `C` couples
    /// them, and the coupling is carried at the cells, with the normal curvatures averaged over a pair of the
    /// cell's corners (see `split`).
    pub fn with_warp_angle(grid: &Grid, rest: &[Vec3], s: &Stiffness, warp_angle: f64) -> Self {
        Self::with_warp(grid, rest, s, Warp::Angle(warp_angle))
    }

    /// As [`Bending::with_warp_angle`] with the warp given by a [`Warp`].
    pub fn with_warp(grid: &Grid, rest: &[Vec3], s: &Stiffness, warp: Warp) -> Self {
        Self::selected(grid, rest, s, warp, |_| true, |_, _| true)
    }

    /// As [`Bending::with_warp`] with the quadrature points of the nodes `k` for which `node(k)` holds and
    /// of the cells `(i, j)` for which `cell(i, j)` holds only (a panel leaves the points on its seams to the
    /// seam's own strip, `crate::seam`).
    pub(crate) fn selected(
        grid: &Grid,
        rest: &[Vec3],
        s: &Stiffness,
        warp: Warp,
        node: impl Fn(usize) -> bool,
        cell: impl Fn(usize, usize) -> bool,
    ) -> Self {
        let dv = [[s.d11, s.d12, 0.0], [s.d12, s.d22, 0.0], [0.0, 0.0, s.d66]];
        let mut points: Vec<Point> =
            (0..grid.len()).filter(|&k| node(k)).filter_map(|k| node_point(grid, rest, &dv, warp, k)).collect();
        points.extend(grid.cells().filter(|&(i, j)| cell(i, j)).map(|(i, j)| cell_point(grid, rest, &dv, warp, i, j)));
        Self::from_points(points)
    }

    /// The term of these quadrature points.
    fn from_points(points: Vec<Point>) -> Self {
        let len = points.iter().map(|p| p.support.len).max().unwrap_or(0);
        Self { points, strides: (len.max(1), (len * (len + 1) / 2).max(1)), pool: Pool::default() }
    }

    /// The points of several terms in one (in their order).
    pub(crate) fn joined(parts: Vec<Bending>) -> Self {
        Self::from_points(parts.into_iter().flat_map(|b| b.points).collect())
    }

    /// Sets the rest curvature `B⁰` to zero everywhere: the rest shape then only defines the metric (a garment
    /// cut from a flat pattern and sewn into a cone or cylinder is bent at rest).
    pub fn flatten_rest_curvature(&mut self) {
        for p in &mut self.points {
            p.rest = [0.0; MEASURES];
        }
    }
}

/// The support of node `k`'s quadrature point (the node and its tangents' stencils), the tangents'
/// coefficients on it and the material frame there (warp at `warp`); the bending and the nonlinear bending
/// terms build their nodal points on it.
pub(crate) fn node_frame(
    grid: &Grid,
    rest: &[Vec3],
    warp: Warp,
    k: usize,
) -> (Support, [f64; MAX_SUPPORT], [f64; MAX_SUPPORT], Frame) {
    let (i, j) = grid.coords(k);
    let mut sup = Support::default();
    sup.slot(k);
    let a = sup.scatter(&tangent(grid, 0, i, j));
    let b = sup.scatter(&tangent(grid, 1, i, j));
    let frame = Frame::with_warp(combine(&sup, &a, rest), combine(&sup, &b, rest), warp);
    (sup, a, b, frame)
}

/// The nodal quadrature point of node `k`: its normal curvatures `κ11`, `κ22` (those its 3-point second
/// differences exist for) with the Schur-complement stiffness; `None` where neither exists.
fn node_point(grid: &Grid, rest: &[Vec3], dv: &[[f64; 3]; 3], warp: Warp, k: usize) -> Option<Point> {
    let w = grid.h1 * grid.h2;
    let (i, j) = grid.coords(k);
    let (mut sup, a, b, frame) = node_frame(grid, rest, warp, k);
    let (c, _) = split(&frame.pull_back(dv), frame.is_aligned());
    let mut v = [[0.0; MAX_SUPPORT]; MEASURES];
    // (measure kind 0 = κ11 or 1 = κ22, quadrature weight): B11 with trapezoid weight across u2,
    // B22 across u1.
    let mut kinds: Vec<(usize, f64)> = Vec::new();
    if let Some(st) = second(grid, 0, i, j) {
        v[kinds.len()] = sup.scatter(&st);
        kinds.push((0, w * frame.area * grid.trapezoid(1, j)));
    }
    if let Some(st) = second(grid, 1, i, j) {
        v[kinds.len()] = sup.scatter(&st);
        kinds.push((1, w * frame.area * grid.trapezoid(0, i)));
    }
    let count = kinds.len();
    if count == 0 {
        return None;
    }
    let mut d = [[0.0; MEASURES]; MEASURES];
    for (m, &(km, wm)) in kinds.iter().enumerate() {
        for (q, &(kq, wq)) in kinds.iter().enumerate() {
            d[m][q] = c[km][kq] * (wm * wq).sqrt();
        }
    }
    Some(Point::new(sup, a, b, v, count, d, rest))
}

/// A cell's quadrature point before its curvatures: the cell's operators, the support of its four corners,
/// the tangents' and the twist's coefficients on it and the material frame there.
pub(crate) struct CellFrame {
    pub(crate) ops: CellOps,
    pub(crate) sup: Support,
    pub(crate) a: [f64; MAX_SUPPORT],
    pub(crate) b: [f64; MAX_SUPPORT],
    pub(crate) twist: [f64; MAX_SUPPORT],
    pub(crate) frame: Frame,
}

/// The [`CellFrame`] of cell `(i, j)` (warp at `warp`); the bending and the nonlinear bending terms build their
/// cell points on it.
pub(crate) fn cell_frame(grid: &Grid, rest: &[Vec3], warp: Warp, i: usize, j: usize) -> CellFrame {
    let ops = CellOps::new(grid, i, j);
    let mut sup = Support::default();
    let st = |c: &[f64; 4]| -> Vec<(usize, f64)> { (0..4).map(|q| (ops.nodes[q], c[q])).collect() };
    let a = sup.scatter(&st(&ops.c1));
    let b = sup.scatter(&st(&ops.c2));
    let twist = sup.scatter(&st(&ops.twist));
    let frame = Frame::with_warp(combine(&sup, &a, rest), combine(&sup, &b, rest), warp);
    CellFrame { ops, sup, a, b, twist, frame }
}

/// The quadrature point of cell `(i, j)`: the twist alone where the material frame is aligned with the grid,
/// else the twist with the cell's averaged normal curvatures and the rank-one rest of the stiffness.
fn cell_point(grid: &Grid, rest: &[Vec3], dv: &[[f64; 3]; 3], warp: Warp, i: usize, j: usize) -> Point {
    let w = grid.h1 * grid.h2;
    let CellFrame { ops, mut sup, a, b, twist: tw, frame } = cell_frame(grid, rest, warp, i, j);
    let (_, g) = split(&frame.pull_back(dv), frame.is_aligned());
    let wc = w * frame.area;
    let mut v = [tw, [0.0; MAX_SUPPORT], [0.0; MAX_SUPPORT]];
    let mut d = [[0.0; MEASURES]; MEASURES];
    if g[0] == 0.0 && g[1] == 0.0 {
        // F ⊃ ½ C₃₃ (2κ12)² = ½ (4 C₃₃) κ12².
        d[0][0] = 4.0 * g[2] * w * frame.area;
        return Point::new(sup, a, b, v, 1, d, rest);
    }
    // ½ (gᵀκ)²/C₃₃ over (2κ12, κ11, κ22): measures (κ12, κ̄11, κ̄22), weights (2C₃₃, C₁₃, C₂₃).
    let gm = [2.0 * g[2], g[0], g[1]];
    [v[1], v[2]] = cell_normal_stencils(grid, &ops, &mut sup);
    for m in 0..MEASURES {
        for q in 0..MEASURES {
            d[m][q] = gm[m] * gm[q] / g[2] * wc;
        }
    }
    Point::new(sup, a, b, v, MEASURES, d, rest)
}

/// The cell's averaged normal curvatures `κ̄11`, `κ̄22` as coefficients over `sup`: `κ̄11` from the column of
/// corners (i, ·), or (i + 1, ·) on a free edge; `κ̄22` from the row (·, j) or (·, j + 1). The support stays
/// within the 3×3 nodes around corner (i, j): the symmetric average over all four corners needs 12 nodes and
/// made the Cusick test's factorisations 1.8× slower, for the same first order (alternating the choice with the
/// parity of i, j does not converge).
pub(crate) fn cell_normal_stencils(grid: &Grid, ops: &CellOps, sup: &mut Support) -> [Coefs; 2] {
    let mut v = [[0.0; MAX_SUPPORT]; 2];
    let pairs = [[[0, 2], [1, 3]], [[0, 1], [2, 3]]];
    for (dir, choice) in pairs.iter().enumerate() {
        for pair in choice {
            let st: Vec<Option<Vec<(usize, f64)>>> = pair
                .iter()
                .map(|&q| {
                    let (ci, cj) = grid.coords(ops.nodes[q]);
                    second(grid, dir, ci, cj)
                })
                .collect();
            if st.iter().all(Option::is_some) {
                let avg: Vec<(usize, f64)> = st.into_iter().flatten().flatten().map(|(k, c)| (k, 0.5 * c)).collect();
                v[dir] = sup.scatter(&avg);
                break;
            }
        }
    }
    v
}

impl Point {
    /// The same point with local node `k` renumbered `map[k]`, coefficients of nodes that become one summed.
    pub(crate) fn mapped(&self, map: &[usize]) -> Point {
        let mut support = Support::default();
        let (mut a, mut b, mut v) = ([0.0; MAX_SUPPORT], [0.0; MAX_SUPPORT], [[0.0; MAX_SUPPORT]; MEASURES]);
        for (s, &k) in self.support.nodes().iter().enumerate() {
            let before = support.len;
            let t = support.slot(map[k]);
            // A new slot takes the coefficients as they are (bit for bit), a repeated node adds its own.
            let fresh = support.len > before;
            let put = |c: &mut f64, value: f64| *c = if fresh { value } else { *c + value };
            put(&mut a[t], self.a[s]);
            put(&mut b[t], self.b[s]);
            for m in 0..MEASURES {
                put(&mut v[m][t], self.v[m][s]);
            }
        }
        Point { support, a, b, v, blocks: Vec::new(), ..self.clone() }
    }

    pub(crate) fn new(
        support: Support,
        a: Coefs,
        b: Coefs,
        v: [Coefs; MEASURES],
        count: usize,
        d: [[f64; MEASURES]; MEASURES],
        rest: &[Vec3],
    ) -> Self {
        let mut p = Self { support, a, b, v, count, rest: [0.0; MEASURES], d, blocks: Vec::new() };
        let (av, bv) = (combine(&p.support, &p.a, rest), combine(&p.support, &p.b, rest));
        for m in 0..count {
            p.rest[m] = NormalCurvature::new(av, bv, combine(&p.support, &p.v[m], rest)).value;
        }
        p
    }

    /// Tangents, curvature kernels and curvature changes at `x`.
    #[inline]
    #[allow(clippy::type_complexity)]
    pub(crate) fn kernels(
        &self,
        x: &[Vec3],
    ) -> (Vec3, Vec3, [NormalCurvature; MEASURES], [Vec3; MEASURES], [f64; MEASURES]) {
        let a = combine(&self.support, &self.a, x);
        let b = combine(&self.support, &self.b, x);
        let mut vs = [Vec3::ZERO; MEASURES];
        let mut kappa = [0.0; MEASURES];
        let mut nc = [NormalCurvature::new(a, b, Vec3::ZERO); MEASURES];
        for m in 0..self.count {
            vs[m] = combine(&self.support, &self.v[m], x);
            nc[m] = NormalCurvature::new(a, b, vs[m]);
            kappa[m] = nc[m].value - self.rest[m];
        }
        (a, b, nc, vs, kappa)
    }

    /// Moments `P = D κ` and the energy `½ κᵀ D κ`.
    #[inline]
    pub(crate) fn moments(&self, kappa: &[f64; MEASURES]) -> ([f64; MEASURES], f64) {
        let mut p = [0.0; MEASURES];
        let mut e = 0.0;
        for m in 0..self.count {
            for q in 0..self.count {
                p[m] += self.d[m][q] * kappa[q];
            }
            e += 0.5 * kappa[m] * p[m];
        }
        (p, e)
    }

    /// The point's energy, and into `out` its gradient contributions (one per support node) and operator
    /// blocks.
    #[inline]
    fn evaluate(&self, x: &[Vec3], out: Local) -> f64 {
        self.evaluate_with(x, out, |kappa| {
            let (mom, energy) = self.moments(kappa);
            (mom, energy, self.d)
        })
    }

    /// As the point's own evaluation with the moments, energy and tangent stiffness `∂P/∂κ` of the curvature
    /// changes given by `law` (a nonlinear law's excess, `energy/nonlinear.rs`).
    #[inline]
    pub(crate) fn evaluate_with(
        &self,
        x: &[Vec3],
        out: Local,
        law: impl FnOnce(&[f64; MEASURES]) -> ([f64; MEASURES], f64, [[f64; MEASURES]; MEASURES]),
    ) -> f64 {
        let (a, b, nc, _vs, kappa) = self.kernels(x);
        let (mom, energy, d) = law(&kappa);
        if out.energy_only() {
            return energy;
        }
        let len = self.support.len;
        // g[m][k] = ∂κ_m/∂x_k.
        let mut g = [[Vec3::ZERO; MAX_SUPPORT]; MEASURES];
        for m in 0..self.count {
            for k in 0..len {
                g[m][k] = nc[m].da * self.a[k] + nc[m].db * self.b[k] + nc[m].dv * self.v[m][k];
            }
        }
        if let Some(gr) = out.grad {
            for k in 0..len {
                let mut f = Vec3::ZERO;
                for m in 0..self.count {
                    f += g[m][k] * mom[m];
                }
                gr[k] = f;
            }
        }
        if let Some((h, op)) = out.hess {
            let mut exact = [[[Mat3::ZERO; 3]; 3]; MEASURES];
            if op == Operator::Exact {
                for m in 0..self.count {
                    exact[m] = nc[m].hessian(a, b);
                }
            }
            let mut id = 0;
            for k in 0..len {
                for l in k..len {
                    let mut blk = Mat3::ZERO;
                    for m in 0..self.count {
                        for q in 0..self.count {
                            let dmq = d[m][q];
                            if dmq == 0.0 {
                                continue;
                            }
                            blk += match op {
                                // Frozen normal: κ_m ≈ n·v_m, linear in x.
                                Operator::Secant => {
                                    outer(nc[m].normal, nc[q].normal) * (dmq * self.v[m][k] * self.v[q][l])
                                }
                                _ => outer(g[m][k], g[q][l]) * dmq,
                            };
                        }
                        if op == Operator::Exact && mom[m] != 0.0 {
                            let c = [[self.a[k], self.b[k], self.v[m][k]], [self.a[l], self.b[l], self.v[m][l]]];
                            for p in 0..3 {
                                for r in 0..3 {
                                    let f = c[0][p] * c[1][r];
                                    if f != 0.0 {
                                        blk += exact[m][p][r] * (mom[m] * f);
                                    }
                                }
                            }
                        }
                    }
                    h[id] = blk;
                    id += 1;
                }
            }
        }
        energy
    }
}

/// The kernel interface; the [`crate::potential::Term`] impl in `potential/elastic.rs` wraps it.
impl Bending {
    /// The node pairs whose Hessian block this term touches.
    pub fn pairs(&self) -> Vec<(usize, usize)> {
        super::parallel::pairs(&self.points)
    }

    /// Precomputes block ids for a pattern that contains [`Self::pairs`].
    pub fn bind(&mut self, pattern: &BlockPattern) {
        super::parallel::bind(&mut self.points, pattern);
    }

    /// Adds gradient and operator into `sink` (not its running `energy`); returns the energy. Large grids are
    /// assembled in parallel, with the same result as the serial loop (see [`super::parallel`]).
    pub fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> f64 {
        // Summed from the neutral element of `f64: Sum`, as the serial `.sum()` of the points was.
        let start = std::iter::empty::<f64>().sum();
        assemble(&self.points, &self.pool, self.strides, start, sink, |p, out| p.evaluate(x, out))
    }
}

impl Item for Point {
    fn nodes(&self) -> &[usize] {
        self.support.nodes()
    }
    fn blocks(&self) -> &[u32] {
        &self.blocks
    }
    fn set_blocks(&mut self, blocks: Vec<u32>) {
        self.blocks = blocks;
    }
}
