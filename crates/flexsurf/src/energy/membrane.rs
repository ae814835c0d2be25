//! Membrane energy of scheme S (docs/model.md §5, §A6): stretch `G11`, `G22` on grid edges by compact
//! differences (the quadratic patch at `t = ±½`), shear `G12` at cell centres from the bilinear tangents.
//!
//! Each cell owns its two `u1`-edges, two `u2`-edges and its centre; per cell
//! `W = ½ w [C11 mean(E11²) + C22 mean(E22²) + (cross and shear terms of the averaged strains)]` with the
//! 3×3 stiffness `C` of `(E11, E22, γ)`, so an interior edge gets full weight from its two cells and a free
//! boundary edge half, exactly as scheme S, and Poisson coupling stays positive definite.

use super::frame::{Frame, Warp};
use super::parallel::{assemble, Item, Local, Pool};
use super::{Operator, Sink};
use crate::grid::Grid;
use crate::material::Stiffness;
use crate::math::{diag, outer, Mat3, Vec3};
use crate::ops::CellOps;
use crate::sparse::BlockPattern;

/// Strains per cell: bottom/top `E11`, left/right `E22`, centre engineering shear `γ`.
const NS: usize = 5;

/// One cell's quadrature data.
#[derive(Debug, Clone)]
struct Cell {
    nodes: [usize; 4],
    /// Strain `s = ½ scale (α·x)·(β·x) − rest`.
    alpha: [[f64; 4]; NS],
    beta: [[f64; 4]; NS],
    scale: [f64; NS],
    rest: [f64; NS],
    /// Weighted stiffness of the 5 strains (PSD).
    q: [[f64; NS]; NS],
    blocks: Vec<u32>,
}

/// Membrane (stretch and shear) energy of the whole grid.
#[derive(Clone)]
pub struct Membrane {
    cells: Vec<Cell>,
    /// Buffers of the parallel assembly.
    pool: Pool,
}

/// The data alone (the assembly's buffers are not part of the term; run fingerprints hash this).
impl std::fmt::Debug for Membrane {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Membrane").field("cells", &self.cells).finish()
    }
}

impl Membrane {
    /// Builds the cells of `grid` with rest state `rest` (stress-free by construction) and stiffness `s`, warp
    /// along `u1`.
    pub fn new(grid: &Grid, rest: &[Vec3], s: &Stiffness) -> Self {
        Self::with_warp_angle(grid, rest, s, 0.0)
    }

    /// As [`Membrane::new`] with the warp at `warp_angle` (radians) from the `u1` tangent of the rest shape.
    /// Strains are measured in the material frame of the rest shape (`E = J⁻ᵀ ε J⁻¹`), so any smooth
    /// parametrisation of the pattern (polar, conical, rotated) gives the same physics.
    pub fn with_warp_angle(grid: &Grid, rest: &[Vec3], s: &Stiffness, warp_angle: f64) -> Self {
        Self::with_warp(grid, rest, s, Warp::Angle(warp_angle))
    }

    /// As [`Membrane::new`] with the warp given by a [`Warp`] (an angle from `u1` or a fixed direction).
    pub fn with_warp(grid: &Grid, rest: &[Vec3], s: &Stiffness, warp: Warp) -> Self {
        Self::with_options(grid, rest, s, warp, false)
    }

    /// As [`Membrane::with_warp`]; with `condensed`, the stretch that differs between a cell's opposite edges
    /// is resisted by the fabric's tensile modulus along them ([`condensed`]) instead of the full stiffness of
    /// that strain (`ElasticOptions::condensed_stretch`).
    pub fn with_options(grid: &Grid, rest: &[Vec3], s: &Stiffness, warp: Warp, condensed: bool) -> Self {
        let cells = grid
            .cells()
            .map(|(i, j)| {
                let ops = CellOps::new(grid, i, j);
                let alpha = [ops.e1[0], ops.e1[1], ops.e2[0], ops.e2[1], ops.c1];
                let beta = [ops.e1[0], ops.e1[1], ops.e2[0], ops.e2[1], ops.c2];
                let scale = [1.0, 1.0, 1.0, 1.0, 2.0];
                let x0: [Vec3; 4] = ops.nodes.map(|k| rest[k]);
                let comb = |c: &[f64; 4]| (0..4).fold(Vec3::ZERO, |acc, k| acc + x0[k] * c[k]);
                let mut restv = [0.0; NS];
                for a in 0..NS {
                    restv[a] = 0.5 * scale[a] * comb(&alpha[a]).dot(comb(&beta[a]));
                }
                // Material stiffness on (E11, E22, γ), pulled back to the parametric strains: C' = Tᵀ C T.
                let frame = Frame::with_warp(comb(&ops.c1), comb(&ops.c2), warp);
                let c = frame.pull_back(&[[s.a11, s.a12, 0.0], [s.a12, s.a22, 0.0], [0.0, 0.0, s.a66]]);
                let w = grid.h1 * grid.h2 * frame.area;
                // Averaging map A (3×5) from the 5 strains to the cell's (E11, E22, γ).
                let avg = [[0.5, 0.5, 0.0, 0.0, 0.0], [0.0, 0.0, 0.5, 0.5, 0.0], [0.0, 0.0, 0.0, 0.0, 1.0]];
                let mut q = [[0.0; NS]; NS];
                for a in 0..NS {
                    for b in 0..NS {
                        let mut v = 0.0;
                        for r in 0..3 {
                            for t in 0..3 {
                                v += avg[r][a] * c[r][t] * avg[t][b];
                            }
                        }
                        q[a][b] = w * v;
                    }
                }
                // mean(E²) − mean(E)² = ¼ (E_b − E_t)²: restores the edge-wise stretch energy.
                let edge = |i: usize| if condensed { self::condensed(&c, i) } else { c[i][i] };
                for (p, m, cc) in [(0, 1, edge(0)), (2, 3, edge(1))] {
                    let k = 0.25 * w * cc;
                    q[p][p] += k;
                    q[m][m] += k;
                    q[p][m] -= k;
                    q[m][p] -= k;
                }
                Cell { nodes: ops.nodes, alpha, beta, scale, rest: restv, q, blocks: Vec::new() }
            })
            .collect();
        Self { cells, pool: Pool::default() }
    }
}

/// The stiffness of strain `i` of `c` (on `(E11, E22, γ)`) with the other two free to relax, `1 / (c⁻¹)ᵢᵢ`
/// (the Schur complement of the other two): for an edge of the grid, the fabric's tensile modulus along it.
/// `c[i][i]` itself where the other two carry no stiffness of their own (a singular block: nothing to relax).
pub fn condensed(c: &[[f64; 3]; 3], i: usize) -> f64 {
    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
    let det = c[j][j] * c[k][k] - c[j][k] * c[k][j];
    if det <= 0.0 {
        return c[i][i];
    }
    // c[i][i] − [c_ij c_ik] B⁻¹ [c_ji c_ki]ᵀ with B the (j, k) block.
    let sol = [(c[k][k] * c[j][i] - c[j][k] * c[k][i]) / det, (c[j][j] * c[k][i] - c[k][j] * c[j][i]) / det];
    c[i][i] - c[i][j] * sol[0] - c[i][k] * sol[1]
}

/// The kernel interface; the [`crate::potential::Term`] impl in `potential/elastic.rs` wraps it.
impl Membrane {
    /// Renumbers the nodes: local node `k` becomes `map[k]` (a panel's nodes in the model, welded across its
    /// seams; a cell's four corners stay four distinct nodes, as every grid has at least three nodes a side).
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

    /// Adds gradient and operator into `sink` (not its running `energy`); returns the energy. Large grids are
    /// assembled in parallel, with the same result as the serial loop (see [`super::parallel`]).
    pub fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> f64 {
        assemble(&self.cells, &self.pool, (4, 10), 0.0, sink, |cell, out| cell.evaluate(x, out))
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
    /// The cell's energy, and into `out` its gradient contributions (one per corner) and operator blocks.
    #[inline]
    fn evaluate(&self, x: &[Vec3], out: Local) -> f64 {
        let xl: [Vec3; 4] = self.nodes.map(|k| x[k]);
        let comb = |c: &[f64; 4]| xl[0] * c[0] + xl[1] * c[1] + xl[2] * c[2] + xl[3] * c[3];
        let mut p = [Vec3::ZERO; NS];
        let mut r = [Vec3::ZERO; NS];
        let mut s = [0.0; NS];
        for a in 0..NS {
            p[a] = comb(&self.alpha[a]);
            r[a] = comb(&self.beta[a]);
            s[a] = 0.5 * self.scale[a] * p[a].dot(r[a]) - self.rest[a];
        }
        let mut sigma = [0.0; NS];
        let mut energy = 0.0;
        for a in 0..NS {
            for b in 0..NS {
                sigma[a] += self.q[a][b] * s[b];
            }
            energy += 0.5 * s[a] * sigma[a];
        }
        if out.energy_only() {
            return energy;
        }
        // ∇_k s_a = ½ scale (α_ak r_a + β_ak p_a).
        let mut ds = [[Vec3::ZERO; 4]; NS];
        for a in 0..NS {
            for k in 0..4 {
                ds[a][k] = (r[a] * self.alpha[a][k] + p[a] * self.beta[a][k]) * (0.5 * self.scale[a]);
            }
        }
        if let Some(g) = out.grad {
            for k in 0..4 {
                let mut f = Vec3::ZERO;
                for a in 0..NS {
                    f += ds[a][k] * sigma[a];
                }
                g[k] = f;
            }
        }
        if let Some((h, op)) = out.hess {
            self.hessian(h, op, &ds, &sigma);
        }
        energy
    }

    /// The operator `op` of this cell (material part `Σ ∇s_a Q_ab ∇s_bᵀ` unless secant, and the geometric
    /// part, exact, its positive part or its absolute value) into its 10 blocks `h`, from the strain gradients
    /// `ds` and stresses `sigma`.
    fn hessian(&self, h: &mut [Mat3], op: Operator, ds: &[[Vec3; 4]; NS], sigma: &[f64; NS]) {
        // Scalar (⊗ I3) geometric part, 4×4.
        let mut geo = [[0.0; 4]; 4];
        for a in 0..NS {
            let (al, be, sc, sg) = (&self.alpha[a], &self.beta[a], self.scale[a], sigma[a]);
            match op {
                Operator::Exact => {
                    for k in 0..4 {
                        for l in 0..4 {
                            geo[k][l] += sg * 0.5 * sc * (al[k] * be[l] + be[k] * al[l]);
                        }
                    }
                }
                _ => stress_part(&mut geo, al, be, 0.5 * sc * sg, op == Operator::Reflected),
            }
        }
        // t[a][l] = Σ_b Q_ab ∇_l s_b, so the material block (k, l) is Σ_a ∇_k s_a t[a][l]ᵀ.
        let material = op != Operator::Secant;
        let mut t = [[Vec3::ZERO; 4]; NS];
        if material {
            for a in 0..NS {
                for l in 0..4 {
                    let mut acc = Vec3::ZERO;
                    for b in 0..NS {
                        acc += ds[b][l] * self.q[a][b];
                    }
                    t[a][l] = acc;
                }
            }
        }
        let mut id = 0;
        for k in 0..4 {
            for l in k..4 {
                let mut m = diag(geo[k][l]);
                if material {
                    for a in 0..NS {
                        m += outer(ds[a][k], t[a][l]);
                    }
                }
                h[id] = m;
                id += 1;
            }
        }
    }
}

/// Adds the positive part of the rank-≤2 matrix `c (α βᵀ + β αᵀ)` to `geo`, written as
/// `c|α||β|/2 [(â+b̂)(â+b̂)ᵀ − (â−b̂)(â−b̂)ᵀ]` and keeping the term whose sign is positive; with `reflect`, its
/// absolute value: the other term too, its sign turned ([`Operator::Reflected`]).
pub(crate) fn stress_part(geo: &mut [[f64; 4]; 4], al: &[f64; 4], be: &[f64; 4], c: f64, reflect: bool) {
    let na = al.iter().map(|v| v * v).sum::<f64>().sqrt();
    let nb = be.iter().map(|v| v * v).sum::<f64>().sqrt();
    if na == 0.0 || nb == 0.0 || c == 0.0 {
        return;
    }
    let sign = if c > 0.0 { 1.0 } else { -1.0 };
    let coef = c.abs() * na * nb * 0.5;
    let halves: &[f64] = if reflect { &[sign, -sign] } else { &[sign] };
    for &half in halves {
        let u: [f64; 4] = std::array::from_fn(|k| al[k] / na + half * be[k] / nb);
        for k in 0..4 {
            for l in 0..4 {
                geo[k][l] += coef * u[k] * u[l];
            }
        }
    }
}
