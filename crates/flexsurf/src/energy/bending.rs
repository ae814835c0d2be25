//! Bending energy of scheme S (MODEL.md §4): normal curvatures `B11 = n·T11x`, `B22 = n·T22x` at nodes with
//! the paper's 3-point second differences and nodal normals from (51)–(52) (one-sided on free edges), and the
//! twist `B12` at cell centres from the bilinear cell tangents. The rest curvature `B⁰` comes from the same
//! operators on the rest shape, so a curved rest shape holds with zero force.
//!
//! Per quadrature point `W = ½ κᵀ D κ` over its one or two curvature changes `κ = B − B⁰`.

use super::curvature::NormalCurvature;
use super::frame::{Frame, Warp};
use super::{local_blocks, local_pairs, Energy, Operator, Sink};
use crate::grid::Grid;
use crate::material::Stiffness;
use crate::math::{outer, Mat3, Vec3};
use crate::ops::{combine, second, tangent, CellOps, Support, MAX_SUPPORT};
use crate::sparse::BlockPattern;

type Coefs = [f64; MAX_SUPPORT];

/// One quadrature point: a normal from tangents `a`, `b` and one or two curvature measures `n·v_m`.
#[derive(Debug, Clone)]
pub(crate) struct Point {
    pub(crate) support: Support,
    pub(crate) a: Coefs,
    pub(crate) b: Coefs,
    pub(crate) v: [Coefs; 2],
    pub(crate) count: usize,
    pub(crate) rest: [f64; 2],
    /// Weighted stiffness `w D` of the measures.
    pub(crate) d: [[f64; 2]; 2],
    pub(crate) blocks: Vec<u32>,
}

/// Bending (curvature and twist) energy of the whole grid.
#[derive(Debug, Clone)]
pub struct Bending {
    pub(crate) points: Vec<Point>,
    aligned: bool,
}

impl Bending {
    /// Builds the quadrature points of `grid` with rest shape `rest` and stiffness `s`, warp along `u1`.
    pub fn new(grid: &Grid, rest: &[Vec3], s: &Stiffness) -> Self {
        Self::with_warp_angle(grid, rest, s, 0.0)
    }

    /// As [`Bending::new`] with the warp at `warp_angle` from the `u1` tangent. Curvatures are measured in the
    /// material frame, `K = J⁻ᵀ κ J⁻¹`; the bending stiffness is pulled back to the parametric curvatures. The
    /// normal curvatures live at nodes and the twist at cells, so the pull-back is exact when the frame is
    /// aligned with the grid (`J` diagonal: arc-length, polar or conical grids with the warp along a grid
    /// direction); otherwise the coupling between twist and normal curvatures is not represented, which
    /// [`Bending::aligned`] reports so that callers can refuse such a set-up.
    pub fn with_warp_angle(grid: &Grid, rest: &[Vec3], s: &Stiffness, warp_angle: f64) -> Self {
        Self::with_warp(grid, rest, s, Warp::Angle(warp_angle))
    }

    /// As [`Bending::with_warp_angle`] with the warp given by a [`Warp`].
    pub fn with_warp(grid: &Grid, rest: &[Vec3], s: &Stiffness, warp: Warp) -> Self {
        let dv = [[s.d11, s.d12, 0.0], [s.d12, s.d22, 0.0], [0.0, 0.0, s.d66]];
        let mut points = Vec::new();
        let mut aligned = true;
        let w = grid.h1 * grid.h2;
        for k in 0..grid.len() {
            let (i, j) = grid.coords(k);
            let mut sup = Support::default();
            sup.slot(k);
            let a = sup.scatter(&tangent(grid, 0, i, j));
            let b = sup.scatter(&tangent(grid, 1, i, j));
            let frame = Frame::with_warp(combine(&sup, &a, rest), combine(&sup, &b, rest), warp);
            aligned &= frame.is_aligned();
            let c = frame.pull_back(&dv);
            let mut v = [[0.0; MAX_SUPPORT]; 2];
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
                continue;
            }
            let mut d = [[0.0; 2]; 2];
            for (m, &(km, wm)) in kinds.iter().enumerate() {
                for (q, &(kq, wq)) in kinds.iter().enumerate() {
                    d[m][q] = c[km][kq] * (wm * wq).sqrt();
                }
            }
            points.push(Point::new(sup, a, b, v, count, d, rest));
        }
        for (i, j) in grid.cells() {
            let ops = CellOps::new(grid, i, j);
            let mut sup = Support::default();
            let st = |c: &[f64; 4]| -> Vec<(usize, f64)> { (0..4).map(|q| (ops.nodes[q], c[q])).collect() };
            let a = sup.scatter(&st(&ops.c1));
            let b = sup.scatter(&st(&ops.c2));
            let tw = sup.scatter(&st(&ops.twist));
            let frame = Frame::with_warp(combine(&sup, &a, rest), combine(&sup, &b, rest), warp);
            aligned &= frame.is_aligned();
            // F ⊃ ½ C'₃₃ (2κ12)² = ½ (4 C'₃₃) κ12²; C'₃₃ = D66 for J = I.
            let d = [[4.0 * frame.pull_back(&dv)[2][2] * w * frame.area, 0.0], [0.0, 0.0]];
            points.push(Point::new(sup, a, b, [tw, [0.0; MAX_SUPPORT]], 1, d, rest));
        }
        Self { points, aligned }
    }

    /// Sets the rest curvature `B⁰` to zero everywhere: the rest shape then only defines the metric (a garment
    /// cut from a flat pattern and sewn into a cone or cylinder is bent at rest).
    pub fn flatten_rest_curvature(&mut self) {
        for p in &mut self.points {
            p.rest = [0.0; 2];
        }
    }

    /// True when every quadrature point's material frame is aligned with the grid (see
    /// [`Bending::with_warp_angle`]).
    pub fn aligned(&self) -> bool {
        self.aligned
    }
}

impl Point {
    fn new(support: Support, a: Coefs, b: Coefs, v: [Coefs; 2], count: usize, d: [[f64; 2]; 2], rest: &[Vec3]) -> Self {
        let mut p = Self { support, a, b, v, count, rest: [0.0; 2], d, blocks: Vec::new() };
        let (av, bv) = (combine(&p.support, &p.a, rest), combine(&p.support, &p.b, rest));
        for m in 0..count {
            p.rest[m] = NormalCurvature::new(av, bv, combine(&p.support, &p.v[m], rest)).value;
        }
        p
    }

    /// Tangents, curvature kernels and curvature changes at `x`.
    #[inline]
    pub(crate) fn kernels(&self, x: &[Vec3]) -> (Vec3, Vec3, [NormalCurvature; 2], [Vec3; 2], [f64; 2]) {
        let a = combine(&self.support, &self.a, x);
        let b = combine(&self.support, &self.b, x);
        let mut vs = [Vec3::ZERO; 2];
        let mut kappa = [0.0; 2];
        let mut nc = [NormalCurvature::new(a, b, Vec3::ZERO); 2];
        for m in 0..self.count {
            vs[m] = combine(&self.support, &self.v[m], x);
            nc[m] = NormalCurvature::new(a, b, vs[m]);
            kappa[m] = nc[m].value - self.rest[m];
        }
        (a, b, nc, vs, kappa)
    }

    /// Moments `P = D κ` and the energy `½ κᵀ D κ`.
    #[inline]
    pub(crate) fn moments(&self, kappa: &[f64; 2]) -> ([f64; 2], f64) {
        let mut p = [0.0; 2];
        let mut e = 0.0;
        for m in 0..self.count {
            for q in 0..self.count {
                p[m] += self.d[m][q] * kappa[q];
            }
            e += 0.5 * kappa[m] * p[m];
        }
        (p, e)
    }

    fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> f64 {
        let (a, b, nc, _vs, kappa) = self.kernels(x);
        let (mom, energy) = self.moments(&kappa);
        if sink.grad.is_none() && sink.hess.is_none() {
            return energy;
        }
        let len = self.support.len;
        // g[m][k] = ∂κ_m/∂x_k.
        let mut g = [[Vec3::ZERO; MAX_SUPPORT]; 2];
        for m in 0..self.count {
            for k in 0..len {
                g[m][k] = nc[m].da * self.a[k] + nc[m].db * self.b[k] + nc[m].dv * self.v[m][k];
            }
        }
        if let Some(gr) = sink.grad.as_deref_mut() {
            for k in 0..len {
                let mut f = Vec3::ZERO;
                for m in 0..self.count {
                    f += g[m][k] * mom[m];
                }
                gr[self.support.nodes[k]] += f;
            }
        }
        if let Some((h, op)) = sink.hess.as_mut() {
            let exact: Vec<[[Mat3; 3]; 3]> = if *op == Operator::Exact {
                (0..self.count).map(|m| nc[m].hessian(a, b)).collect()
            } else {
                Vec::new()
            };
            let mut id = 0;
            for k in 0..len {
                for l in k..len {
                    let mut blk = Mat3::ZERO;
                    for m in 0..self.count {
                        for q in 0..self.count {
                            let dmq = self.d[m][q];
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
                        if *op == Operator::Exact && mom[m] != 0.0 {
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
                    h.add(self.blocks[id], self.support.nodes[k], self.support.nodes[l], blk);
                    id += 1;
                }
            }
        }
        energy
    }
}

impl Energy for Bending {
    fn pairs(&self) -> Vec<(usize, usize)> {
        self.points.iter().flat_map(|p| local_pairs(p.support.nodes()).collect::<Vec<_>>()).collect()
    }

    fn bind(&mut self, pattern: &BlockPattern) {
        for p in &mut self.points {
            p.blocks = local_blocks(pattern, p.support.nodes());
        }
    }

    fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> f64 {
        self.points.iter().map(|p| p.evaluate(x, sink)).sum()
    }
}
