//! The material frame of the rest state (docs/model.md §6): with `J` the 2×2 Jacobian from parameters to the
//! orthonormal warp/weft axes of the flat pattern, strains and curvatures in physical units are
//! `E = J⁻ᵀ ε J⁻¹`, `K = J⁻ᵀ κ J⁻¹`. For an arc-length grid with the warp along `u1`, `J = I`.

use crate::math::Vec3;

/// Where the warp runs in the rest shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Warp {
    /// At this angle (radians) from the `u1` tangent, towards `u2`.
    Angle(f64),
    /// Along this fixed direction (projected onto each point's tangent plane).
    Direction(Vec3),
}

impl Default for Warp {
    fn default() -> Self {
        Warp::Angle(0.0)
    }
}

/// `J⁻¹` and `|det J|` at one quadrature point of the rest shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// `P = J⁻¹`, rows: parameter directions, columns: material axes (warp, weft).
    pub p: [[f64; 2]; 2],
    /// `|det J|`: rest area per unit parameter area.
    pub area: f64,
}

impl Frame {
    /// Frame from the rest tangents `∂X/∂u1`, `∂X/∂u2`, with the warp at `warp_angle` (radians) from the
    /// `u1` tangent, measured towards `u2` in the tangent plane.
    pub fn new(c1: Vec3, c2: Vec3, warp_angle: f64) -> Self {
        let t1 = c1.normalize_or_zero();
        let nrm = c1.cross(c2).normalize_or_zero();
        let t2 = nrm.cross(t1);
        let (s, c) = warp_angle.sin_cos();
        let warp = t1 * c + t2 * s;
        let weft = nrm.cross(warp);
        let j = [[warp.dot(c1), warp.dot(c2)], [weft.dot(c1), weft.dot(c2)]];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        let p = [[j[1][1] / det, -j[0][1] / det], [-j[1][0] / det, j[0][0] / det]];
        Self { p, area: det.abs() }
    }

    /// Frame from the rest tangents with the warp along the fixed direction `warp` (e.g. the x axis of a flat
    /// pattern), projected onto the tangent plane: for polar or other curvilinear grids of one piece of fabric.
    pub fn with_direction(c1: Vec3, c2: Vec3, warp: Vec3) -> Self {
        let t1 = c1.normalize_or_zero();
        let nrm = c1.cross(c2).normalize_or_zero();
        let t2 = nrm.cross(t1);
        let w = warp - nrm * warp.dot(nrm);
        Self::new(c1, c2, w.dot(t2).atan2(w.dot(t1)))
    }

    /// Frame for a [`Warp`] choice.
    pub fn with_warp(c1: Vec3, c2: Vec3, warp: Warp) -> Self {
        match warp {
            Warp::Angle(a) => Self::new(c1, c2, a),
            Warp::Direction(d) => Self::with_direction(c1, c2, d),
        }
    }

    /// Voigt map `T`: `(E11, E22, γ) = T (ε11, ε22, 2ε12)` for `E = Pᵀ ε P`.
    pub fn voigt(&self) -> [[f64; 3]; 3] {
        let p = &self.p;
        // Columns: images of ε11 = 1, ε22 = 1, and 2ε12 = 1.
        let cols = [
            [p[0][0] * p[0][0], p[0][1] * p[0][1], 2.0 * p[0][0] * p[0][1]],
            [p[1][0] * p[1][0], p[1][1] * p[1][1], 2.0 * p[1][0] * p[1][1]],
            [p[0][0] * p[1][0], p[0][1] * p[1][1], p[0][0] * p[1][1] + p[1][0] * p[0][1]],
        ];
        let mut t = [[0.0; 3]; 3];
        for (c, col) in cols.iter().enumerate() {
            for r in 0..3 {
                t[r][c] = col[r];
            }
        }
        t
    }

    /// `Tᵀ C T`: a stiffness on `(E11, E22, γ)` expressed on the parametric strains.
    pub fn pull_back(&self, c: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let t = self.voigt();
        let mut out = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                let mut v = 0.0;
                for r in 0..3 {
                    for s in 0..3 {
                        v += t[r][a] * c[r][s] * t[s][b];
                    }
                }
                out[a][b] = v;
            }
        }
        out
    }

    /// True when the parametrisation is orthogonal and its directions are the warp and weft, in either order
    /// (`J` diagonal, or anti-diagonal for the warp along `u2`): the pulled-back stiffness then has no
    /// coupling between normal strains (curvatures) and shear (twist).
    pub fn is_aligned(&self) -> bool {
        let p = &self.p;
        let (diag, anti) = (p[0][0].abs() + p[1][1].abs(), p[0][1].abs() + p[1][0].abs());
        diag.min(anti) <= 1e-9 * diag.max(anti)
    }
}
