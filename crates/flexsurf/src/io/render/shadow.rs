//! Shadows: an orthographic depth map of the shadow-casting triangles seen from the directional light, as
//! fine as the supersampled image (up to a limit), and the bilinearly filtered visibility test that
//! [`super::shade`] multiplies the diffuse term by.

use super::raster::raster_triangle;
use super::scene::{plane_basis, Tri};
use crate::math::Vec3;
use crate::surface::mesh::Aabb;

/// Largest shadow map resolution (texels per side); the map is as fine as the supersampled image, up to this.
pub(super) const SHADOW_MAX: usize = 1024;

/// Orthographic depth map seen from the light.
pub(super) struct ShadowMap {
    ax: Vec3,
    ay: Vec3,
    az: Vec3,
    x0: f64,
    y0: f64,
    /// Texels per world unit.
    scale: f64,
    /// Texels per side.
    size: usize,
    pub(super) depth: Vec<f32>,
}

impl ShadowMap {
    pub(super) fn build(tris: &[Tri], light: Vec3, size: usize, mut depth: Vec<f32>) -> Option<Self> {
        let az = -light;
        let (ax, ay) = plane_basis(az);
        let pts =
            tris.iter().filter(|t| t.casts_shadow).flat_map(|t| t.p).map(|p| Vec3::new(p.dot(ax), p.dot(ay), 0.0));
        let b = Aabb::from_points(pts)?;
        let extent = b.size().x.max(b.size().y).max(1e-9) * 1.04;
        let (x0, y0) = (b.center().x - 0.5 * extent, b.center().y - 0.5 * extent);
        let scale = size as f64 / extent;
        depth.clear();
        depth.resize(size * size, f32::INFINITY);
        let mut sm = Self { ax, ay, az, x0, y0, scale, size, depth };
        for t in tris.iter().filter(|t| t.casts_shadow) {
            let s = t.p.map(|p| sm.project(p));
            raster_triangle([[s[0].x, s[0].y], [s[1].x, s[1].y], [s[2].x, s[2].y]], size, size, |k, w| {
                let d = (w[0] * s[0].z + w[1] * s[1].z + w[2] * s[2].z) as f32;
                if d < sm.depth[k] {
                    sm.depth[k] = d;
                }
            });
        }
        Some(sm)
    }

    /// Texel coordinates (x, y) and depth along the light (z).
    fn project(&self, p: Vec3) -> Vec3 {
        Vec3::new((p.dot(self.ax) - self.x0) * self.scale, (p.dot(self.ay) - self.y0) * self.scale, p.dot(self.az))
    }

    /// World size of a texel.
    pub(super) fn texel(&self) -> f64 {
        1.0 / self.scale
    }

    /// Fraction of light reaching `p`: the four nearest texels' depth tests, bilinearly weighted.
    pub(super) fn visibility(&self, p: Vec3) -> f64 {
        let q = self.project(p);
        let depth = q.z - 1.5 * self.texel();
        let (fx, fy) = (q.x - 0.5, q.y - 0.5);
        let (cx, cy) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - cx, fy - cy);
        let (cx, cy) = (cx as i64, cy as i64);
        let n = self.size as i64;
        let lit = |x: i64, y: i64| -> f64 {
            let inside = (0..n).contains(&x) && (0..n).contains(&y);
            if !inside || depth <= f64::from(self.depth[(y * n + x) as usize]) {
                1.0
            } else {
                0.0
            }
        };
        let top = lit(cx, cy) * (1.0 - tx) + lit(cx + 1, cy) * tx;
        let bottom = lit(cx, cy + 1) * (1.0 - tx) + lit(cx + 1, cy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }
}
