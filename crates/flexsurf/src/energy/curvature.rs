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

#[cfg(test)]
mod tests {
    use super::*;

    fn b_of(z: &[f64; 9]) -> f64 {
        let a = Vec3::new(z[0], z[1], z[2]);
        let b = Vec3::new(z[3], z[4], z[5]);
        let v = Vec3::new(z[6], z[7], z[8]);
        NormalCurvature::new(a, b, v).value
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let z0 = [1.1, 0.2, -0.3, 0.1, 0.9, 0.4, 0.5, -0.7, 2.0];
        let (a, b, v) =
            (Vec3::new(z0[0], z0[1], z0[2]), Vec3::new(z0[3], z0[4], z0[5]), Vec3::new(z0[6], z0[7], z0[8]));
        let k = NormalCurvature::new(a, b, v);
        let grad: Vec<f64> = [k.da, k.db, k.dv].iter().flat_map(|g| [g.x, g.y, g.z]).collect();
        let h = k.hessian(a, b);
        let eps = 1e-6;
        for i in 0..9 {
            let mut zp = z0;
            let mut zm = z0;
            zp[i] += eps;
            zm[i] -= eps;
            let fd = (b_of(&zp) - b_of(&zm)) / (2.0 * eps);
            assert!((fd - grad[i]).abs() < 1e-8, "gradient {i}: {fd} vs {}", grad[i]);
            let gp = NormalCurvature::new(
                Vec3::new(zp[0], zp[1], zp[2]),
                Vec3::new(zp[3], zp[4], zp[5]),
                Vec3::new(zp[6], zp[7], zp[8]),
            );
            let gm = NormalCurvature::new(
                Vec3::new(zm[0], zm[1], zm[2]),
                Vec3::new(zm[3], zm[4], zm[5]),
                Vec3::new(zm[6], zm[7], zm[8]),
            );
            let dp: Vec<f64> = [gp.da, gp.db, gp.dv].iter().flat_map(|g| [g.x, g.y, g.z]).collect();
            let dm: Vec<f64> = [gm.da, gm.db, gm.dv].iter().flat_map(|g| [g.x, g.y, g.z]).collect();
            for j in 0..9 {
                let fd = (dp[j] - dm[j]) / (2.0 * eps);
                let an = h[j / 3][i / 3].col(i % 3)[j % 3];
                assert!((fd - an).abs() < 1e-7, "hessian ({j},{i}): {fd} vs {an}");
            }
        }
    }
}
