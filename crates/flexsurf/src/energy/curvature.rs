//! The normal curvature `B = n·v` with `n = (a × b)/|a × b|` (docs/model.md §2: `B_ij = n·x_ij` with `a = x_1`,
//! `b = x_2`, `v = x_ij`), its gradient with respect to `(a, b, v)` and its exact Hessian. The variation of `n`
//! here is the discrete counterpart of the paper's garbled term H (eq. 18–21, docs/model.md §A1).

use crate::math::{outer, skew, Mat3, Vec3};

/// Value and gradient of `B(a, b, v)`.
#[derive(Debug, Clone, Copy)]
pub struct NormalCurvature {
    /// `B = n·v`.
    pub value: f64,
    /// Unit normal.
    pub normal: Vec3,
    /// `∂B/∂a = b × g`, with `g = (I − n nᵀ) v / |a × b|`.
    pub da: Vec3,
    /// `∂B/∂b = g × a`.
    pub db: Vec3,
    /// `∂B/∂v = n`.
    pub dv: Vec3,
    /// `g` and `|a × b|`, kept for the Hessian.
    g: Vec3,
    len: f64,
}

impl NormalCurvature {
    /// Evaluates `B` and its gradient. A degenerate tangent pair (`a × b = 0`) gives `B = 0`, zero gradient.
    #[inline]
    pub fn new(a: Vec3, b: Vec3, v: Vec3) -> Self {
        let nt = a.cross(b);
        let len = nt.length();
        if len <= f64::MIN_POSITIVE {
            return Self {
                value: 0.0,
                normal: Vec3::ZERO,
                da: Vec3::ZERO,
                db: Vec3::ZERO,
                dv: Vec3::ZERO,
                g: Vec3::ZERO,
                len: 0.0,
            };
        }
        let n = nt / len;
        let value = n.dot(v);
        let g = (v - n * value) / len;
        Self { value, normal: n, da: b.cross(g), db: g.cross(a), dv: n, g, len }
    }

    /// Exact Hessian blocks `H[p][q] = ∂²B/∂p∂q` for `p, q ∈ (a, b, v)`; `H[q][p] = H[p][q]ᵀ`.
    pub fn hessian(&self, a: Vec3, b: Vec3) -> [[Mat3; 3]; 3] {
        if self.len == 0.0 {
            return [[Mat3::ZERO; 3]; 3];
        }
        let n = self.normal;
        let nv = self.value;
        let inv2 = 1.0 / (self.len * self.len);
        // v recovered from g: v = g |ñ| + n (n·v).
        let v = self.g * self.len + n * nv;
        // ∂²f/∂ñ² for f = ñ·v/|ñ|.
        let hnn = (outer(n, n) * (3.0 * nv) - Mat3::IDENTITY * nv - outer(v, n) - outer(n, v)) * inv2;
        // ∂²f/∂ñ∂v = (I − n nᵀ)/|ñ|.
        let hnv = (Mat3::IDENTITY - outer(n, n)) / self.len;
        // dñ = Ja da + Jb db.
        let ja = -skew(b);
        let jb = skew(a);
        let haa = ja.transpose() * hnn * ja;
        let hbb = jb.transpose() * hnn * jb;
        // Second derivative of g·(a × b) in (a, b): M_ij = ε_ijk g_k = −[g]×.
        let hab = ja.transpose() * hnn * jb - skew(self.g);
        let hav = ja.transpose() * hnv;
        let hbv = jb.transpose() * hnv;
        [[haa, hab, hav], [hab.transpose(), hbb, hbv], [hav.transpose(), hbv.transpose(), Mat3::ZERO]]
    }
}
