//! One rational B-spline surface patch: validation of degrees, knots, control points and weights, the cells
//! (knot span pairs with their control-point boxes and sample grids) that [`super::project`] prunes and starts
//! Newton from, and evaluation of points, first and second partial derivatives (the rational quotient rule of
//! NURBS Book A4.4) and outward unit normals.

use super::basis::{Knots, ORDER_MAX};
use super::error::{Direction, NurbsError};
use crate::math::Vec3;
use crate::surface::mesh::Aabb;

/// Samples per knot span and direction of the grid that starts Newton and prunes spans.
pub(super) const SAMPLES_PER_SPAN: usize = 6;

/// Point, first and second partial derivatives of a surface at one parameter pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceDerivatives {
    /// `S(u, v)`.
    pub point: Vec3,
    /// `∂S/∂u`.
    pub du: Vec3,
    /// `∂S/∂v`.
    pub dv: Vec3,
    /// `∂²S/∂u²`.
    pub duu: Vec3,
    /// `∂²S/∂u∂v`.
    pub duv: Vec3,
    /// `∂²S/∂v²`.
    pub dvv: Vec3,
}

/// One rational B-spline surface patch.
#[derive(Debug, Clone, PartialEq)]
pub struct NurbsPatch {
    pub(super) ku: Knots,
    pub(super) kv: Knots,
    pub(super) points: Vec<Vec3>,
    pub(super) weights: Vec<f64>,
    /// Homogeneous control points `(w P, w)`.
    pub(super) homogeneous: Vec<[f64; 4]>,
    pub(super) rational: bool,
    pub(super) bbox: Aabb,
    /// One cell per knot span pair, for pruning and starting Newton.
    pub(super) cells: Vec<Cell>,
}

/// One knot span pair `[u_a, u_b] × [v_a, v_b]` of a patch: the bounding box of the control points that
/// define it (local convex hull property), a grid of surface samples and how far any surface point of the
/// cell can be from its nearest sample.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Cell {
    pub(super) bbox: Aabb,
    pub(super) samples: Vec<(f64, f64, Vec3)>,
    pub(super) cover: f64,
    pub(super) u: [f64; 2],
    pub(super) v: [f64; 2],
}

impl NurbsPatch {
    /// A patch of degrees `degree = [p, q]` with knot vectors `knots_u` (`nu + p + 1` knots) and `knots_v`
    /// (`nv + q + 1`), `nu · nv` control points in row-major order (`points[i · nv + j]`) and optional weights
    /// (same order; all 1 when `None`).
    pub fn new(
        degree: [usize; 2],
        knots_u: Vec<f64>,
        knots_v: Vec<f64>,
        points: Vec<Vec3>,
        weights: Option<Vec<f64>>,
    ) -> Result<Self, NurbsError> {
        let ku = Knots::new(Direction::U, degree[0], knots_u)?;
        let kv = Knots::new(Direction::V, degree[1], knots_v)?;
        let (nu, nv) = (ku.count, kv.count);
        let expected = nu * nv;
        if points.len() != expected {
            return Err(NurbsError::PointCount { nu, nv, expected, got: points.len() });
        }
        if let Some(index) = points.iter().position(|p| !p.is_finite()) {
            return Err(NurbsError::NonFinitePoint { index });
        }
        let weights = weights.unwrap_or_else(|| vec![1.0; expected]);
        if weights.len() != expected {
            return Err(NurbsError::WeightCount { expected, got: weights.len() });
        }
        if let Some(index) = weights.iter().position(|w| !(w.is_finite() && *w > 0.0)) {
            return Err(NurbsError::Weight { index, value: weights[index] });
        }
        let homogeneous = points.iter().zip(&weights).map(|(p, &w)| [w * p.x, w * p.y, w * p.z, w]).collect();
        let rational = weights.iter().any(|&w| w != 1.0);
        let bbox = points.iter().fold(Aabb::point(points[0]), |b, &p| b.include(p));
        let mut patch = Self { ku, kv, points, weights, homogeneous, rational, bbox, cells: Vec::new() };
        patch.cells = patch.make_cells();
        Ok(patch)
    }

    /// Non-empty knot spans `(a, b, span index)` of a knot vector.
    fn spans(k: &Knots) -> Vec<(f64, f64, usize)> {
        (k.degree..k.count).filter(|&i| k.knots[i] < k.knots[i + 1]).map(|i| (k.knots[i], k.knots[i + 1], i)).collect()
    }

    fn make_cells(&self) -> Vec<Cell> {
        let (p, q, nv) = (self.ku.degree, self.kv.degree, self.kv.count);
        let n = SAMPLES_PER_SPAN;
        let mut cells = Vec::new();
        for &(ua, ub, su) in &Self::spans(&self.ku) {
            for &(va, vb, sv) in &Self::spans(&self.kv) {
                let mut bbox = Aabb::point(self.points[(su - p) * nv + sv - q]);
                for i in su - p..=su {
                    for j in sv - q..=sv {
                        bbox = bbox.include(self.points[i * nv + j]);
                    }
                }
                let mut samples = Vec::with_capacity((n + 1) * (n + 1));
                for a in 0..=n {
                    let u = if a == n { ub } else { ua + (ub - ua) * a as f64 / n as f64 };
                    for b in 0..=n {
                        let v = if b == n { vb } else { va + (vb - va) * b as f64 / n as f64 };
                        samples.push((u, v, self.point(u, v)));
                    }
                }
                // Half the longest diagonal of a sample quad, with a safety factor for the curvature between
                // samples: every surface point of the cell is about this close to a sample.
                let mut cover: f64 = 0.0;
                for a in 0..n {
                    for b in 0..n {
                        let at = |i: usize, j: usize| samples[i * (n + 1) + j].2;
                        let d1 = (at(a, b) - at(a + 1, b + 1)).length();
                        let d2 = (at(a + 1, b) - at(a, b + 1)).length();
                        cover = cover.max(d1).max(d2);
                    }
                }
                cells.push(Cell { bbox, samples, cover: 0.6 * cover, u: [ua, ub], v: [va, vb] });
            }
        }
        cells
    }

    /// Degrees `[p, q]`.
    pub fn degree(&self) -> [usize; 2] {
        [self.ku.degree, self.kv.degree]
    }

    /// Control net size `[nu, nv]`.
    pub fn size(&self) -> [usize; 2] {
        [self.ku.count, self.kv.count]
    }

    /// Knot vector along `u`.
    pub fn knots_u(&self) -> &[f64] {
        &self.ku.knots
    }

    /// Knot vector along `v`.
    pub fn knots_v(&self) -> &[f64] {
        &self.kv.knots
    }

    /// Control points, row-major (`[i · nv + j]`).
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// Weights, row-major.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// True when some weight differs from 1.
    pub fn is_rational(&self) -> bool {
        self.rational
    }

    /// Parameter domain `([u_min, u_max], [v_min, v_max])`.
    pub fn domain(&self) -> ([f64; 2], [f64; 2]) {
        let (a, b) = self.ku.domain();
        let (c, d) = self.kv.domain();
        ([a, b], [c, d])
    }

    /// Bounding box of the control net; it contains the patch (convex hull property).
    pub fn bbox(&self) -> Aabb {
        self.bbox
    }

    /// Point, first and second derivatives at `(u, v)` (clamped to the domain).
    pub fn derivatives(&self, u: f64, v: f64) -> SurfaceDerivatives {
        let (u0, u1) = self.ku.domain();
        let (v0, v1) = self.kv.domain();
        let u = u.clamp(u0, u1);
        let v = v.clamp(v0, v1);
        let (p, q) = (self.ku.degree, self.kv.degree);
        let nv = self.kv.count;
        let su = self.ku.span(u);
        let sv = self.kv.span(v);
        let bu = self.ku.ders_basis(su, u);
        let bv = self.kv.ders_basis(sv, v);
        // a[k][l]: ∂^{k+l} A / ∂u^k ∂v^l of the homogeneous surface, k + l ≤ 2.
        if !self.rational {
            return self.poly_derivatives(su, sv, &bu, &bv);
        }
        let mut a = [[[0.0f64; 4]; 3]; 3];
        for i in 0..=p {
            let row = (su - p + i) * nv + sv - q;
            let mut t = [[0.0f64; 4]; 3];
            for j in 0..=q {
                let h = &self.homogeneous[row + j];
                for (l, tl) in t.iter_mut().enumerate() {
                    let b = bv[l][j];
                    for c in 0..4 {
                        tl[c] += b * h[c];
                    }
                }
            }
            for k in 0..3 {
                let b = bu[k][i];
                for l in 0..3 - k {
                    for c in 0..4 {
                        a[k][l][c] += b * t[l][c];
                    }
                }
            }
        }
        let v3 = |x: &[f64; 4]| Vec3::new(x[0], x[1], x[2]);
        let w = a[0][0][3];
        let (wu, wv) = (a[1][0][3], a[0][1][3]);
        let (wuu, wuv, wvv) = (a[2][0][3], a[1][1][3], a[0][2][3]);
        let s = v3(&a[0][0]) / w;
        let su_ = (v3(&a[1][0]) - wu * s) / w;
        let sv_ = (v3(&a[0][1]) - wv * s) / w;
        let suu = (v3(&a[2][0]) - 2.0 * wu * su_ - wuu * s) / w;
        let suv = (v3(&a[1][1]) - wu * sv_ - wv * su_ - wuv * s) / w;
        let svv = (v3(&a[0][2]) - 2.0 * wv * sv_ - wvv * s) / w;
        SurfaceDerivatives { point: s, du: su_, dv: sv_, duu: suu, duv: suv, dvv: svv }
    }

    /// Derivatives of a polynomial patch (all weights 1) from the basis functions of spans `(su, sv)`.
    #[inline]
    fn poly_derivatives(
        &self,
        su: usize,
        sv: usize,
        bu: &[[f64; ORDER_MAX]; 3],
        bv: &[[f64; ORDER_MAX]; 3],
    ) -> SurfaceDerivatives {
        let (p, q, nv) = (self.ku.degree, self.kv.degree, self.kv.count);
        let mut out = [Vec3::ZERO; 6];
        for i in 0..=p {
            let row = &self.points[(su - p + i) * nv + sv - q..][..=q];
            let (mut t0, mut t1, mut t2) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
            for (j, &c) in row.iter().enumerate() {
                t0 += bv[0][j] * c;
                t1 += bv[1][j] * c;
                t2 += bv[2][j] * c;
            }
            out[0] += bu[0][i] * t0;
            out[1] += bu[1][i] * t0;
            out[2] += bu[0][i] * t1;
            out[3] += bu[2][i] * t0;
            out[4] += bu[1][i] * t1;
            out[5] += bu[0][i] * t2;
        }
        SurfaceDerivatives { point: out[0], du: out[1], dv: out[2], duu: out[3], duv: out[4], dvv: out[5] }
    }

    /// Surface point at `(u, v)` (clamped to the domain).
    pub fn point(&self, u: f64, v: f64) -> Vec3 {
        self.derivatives(u, v).point
    }

    /// Outward unit normal `∂u × ∂v / |∂u × ∂v|` at `(u, v)`. Where the surface is degenerate (a collapsed
    /// edge, `∂u × ∂v = 0`) it is the limit taken from slightly inside the domain.
    pub fn normal(&self, u: f64, v: f64) -> Vec3 {
        let d = self.derivatives(u, v);
        if let Some(n) = regular_normal(&d) {
            return n;
        }
        let ([u0, u1], [v0, v1]) = self.domain();
        let (uc, vc) = (0.5 * (u0 + u1), 0.5 * (v0 + v1));
        for eps in [1e-9, 1e-7, 1e-5, 1e-3] {
            let d = self.derivatives(u + eps * (uc - u), v + eps * (vc - v));
            if let Some(n) = regular_normal(&d) {
                return n;
            }
        }
        Vec3::Z
    }
}

#[inline]
fn regular_normal(d: &SurfaceDerivatives) -> Option<Vec3> {
    let n = d.du.cross(d.dv);
    let len = n.length();
    let scale = d.du.length() * d.dv.length();
    (len > 1e-10 * scale && len > 0.0 && len.is_finite()).then(|| n / len)
}
