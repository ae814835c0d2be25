//! Rasterisation: the pixel centres inside a screen triangle with their barycentric weights (also used by
//! [`super::shadow`] for the depth map), and the z-buffer pass that projects the scene's triangles through the
//! [`Camera`], clips them at the near plane and keeps the nearest primitive of every sample.

use super::camera::{clip_near, Camera, ClipVert};
use super::scene::Tri;
use crate::math::Vec3;

/// Calls `pixel(index, barycentric weights)` for every pixel centre of a `w × h` raster inside the screen
/// triangle `s` (pixel `(x, y)` has centre `(x + ½, y + ½)`, index `x + w y`).
pub(super) fn raster_triangle(s: [[f64; 2]; 3], w: usize, h: usize, mut pixel: impl FnMut(usize, [f64; 3])) {
    let area = (s[1][0] - s[0][0]) * (s[2][1] - s[0][1]) - (s[1][1] - s[0][1]) * (s[2][0] - s[0][0]);
    if !area.is_finite() || area.abs() <= 1e-12 {
        return;
    }
    let inv = 1.0 / area;
    // Normalised edge functions w_k(x, y) = a_k x + b_k y + c_k (weight of vertex k, opposite edge (k+1, k+2)).
    let coef: [[f64; 3]; 3] = std::array::from_fn(|k| {
        let (p, q) = (s[(k + 1) % 3], s[(k + 2) % 3]);
        let a = -(q[1] - p[1]) * inv;
        let b = (q[0] - p[0]) * inv;
        [a, b, -(a * p[0] + b * p[1])]
    });
    let lo = |c: usize| s[0][c].min(s[1][c]).min(s[2][c]);
    let hi = |c: usize| s[0][c].max(s[1][c]).max(s[2][c]);
    let clamp = |v: f64, n: usize| v.max(0.0).min(n as f64) as usize;
    let (x0, x1) = (clamp((lo(0) - 0.5).ceil(), w), clamp((hi(0) - 0.5).floor() + 1.0, w));
    let (y0, y1) = (clamp((lo(1) - 0.5).ceil(), h), clamp((hi(1) - 0.5).floor() + 1.0, h));
    if x0 >= x1 {
        return;
    }
    for y in y0..y1 {
        let py = y as f64 + 0.5;
        // The covered span of this row: the half-planes w_k ≥ 0 intersected along x, widened by a pixel against
        // rounding (the explicit test below decides coverage).
        let (mut xa, mut xb) = (x0 as f64 + 0.5, (x1 - 1) as f64 + 0.5);
        for c in &coef {
            let base = c[1] * py + c[2];
            if c[0] > 0.0 {
                xa = xa.max(-base / c[0] - 1.0);
            } else if c[0] < 0.0 {
                xb = xb.min(-base / c[0] + 1.0);
            } else if base < 0.0 {
                xb = f64::NEG_INFINITY;
            }
        }
        if xa.is_nan() || xb.is_nan() || xa > xb {
            continue;
        }
        let sa = ((xa - 0.5).ceil() as usize).max(x0);
        let sb = (((xb - 0.5).floor() + 1.0) as usize).min(x1);
        for x in sa..sb {
            let px = x as f64 + 0.5;
            let wk = coef.map(|c| c[0] * px + c[1] * py + c[2]);
            if wk[0] >= 0.0 && wk[1] >= 0.0 && wk[2] >= 0.0 {
                pixel(x + w * y, wk);
            }
        }
    }
}

/// A clipped, projected triangle.
pub(super) struct Prim {
    pub(super) world: [Vec3; 3],
    pub(super) normal: [Vec3; 3],
    pub(super) face: Vec3,
    pub(super) color: [f64; 3],
}

/// Inverse depth, primitive and perspective-correct barycentric weights of every sample of a `width × height`
/// raster (kept between renders, see [`super::frame`]).
#[derive(Default)]
pub(super) struct ZBuffer {
    /// Samples per row.
    pub(super) width: usize,
    height: usize,
    inv_z: Vec<f64>,
    /// The nearest primitive of each sample, `u32::MAX` where there is none.
    pub(super) prim_id: Vec<u32>,
    weights: Vec<[f32; 2]>,
}

impl ZBuffer {
    /// Empties the buffer for a `width × height` raster.
    pub(super) fn reset(&mut self, width: usize, height: usize) {
        (self.width, self.height) = (width, height);
        self.inv_z.clear();
        self.inv_z.resize(width * height, 0.0);
        self.prim_id.clear();
        self.prim_id.resize(width * height, u32::MAX);
        // Weights are only read where a primitive was written, so stale values need no clearing.
        self.weights.resize(width * height, [0.0; 2]);
    }

    /// Draws primitive `id` with screen vertices `s` and inverse depths `iz` where it is nearer than what the
    /// buffer holds.
    fn draw(&mut self, s: [[f64; 2]; 3], iz: [f64; 3], id: u32) {
        let Self { width, height, inv_z, prim_id, weights } = self;
        raster_triangle(s, *width, *height, |k, b| {
            let z = b[0] * iz[0] + b[1] * iz[1] + b[2] * iz[2];
            if z > inv_z[k] {
                inv_z[k] = z;
                prim_id[k] = id;
                weights[k] = [(b[0] * iz[0] / z) as f32, (b[1] * iz[1] / z) as f32];
            }
        });
    }

    /// Barycentric weights of the primitive at sample `k`.
    #[inline]
    pub(super) fn bary(&self, k: usize) -> [f64; 3] {
        let [b0, b1] = self.weights[k].map(f64::from);
        [b0, b1, 1.0 - b0 - b1]
    }
}

/// Clips, projects and z-buffers the triangles into `zbuf` (already [`ZBuffer::reset`] to the raster of
/// `camera`); returns the primitives the buffer's ids refer to.
pub(super) fn rasterise(tris: &[Tri], camera: &Camera, zbuf: &mut ZBuffer) -> Vec<Prim> {
    let mut prims: Vec<Prim> = Vec::with_capacity(tris.len());
    for t in tris {
        let verts: [ClipVert; 3] =
            std::array::from_fn(|k| ClipVert { c: camera.to_camera(t.p[k]), w: t.p[k], n: t.n[k] });
        let (poly, len) = clip_near(&verts, camera.near);
        if len < 3 {
            continue;
        }
        let face = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).try_normalize().unwrap_or(Vec3::Z);
        for k in 1..len - 1 {
            let tri = [poly[0], poly[k], poly[k + 1]];
            let id = prims.len() as u32;
            let s = tri.map(|v| camera.to_screen(v.c));
            let iz = tri.map(|v| 1.0 / v.c.z);
            zbuf.draw(s, iz, id);
            prims.push(Prim { world: tri.map(|v| v.w), normal: tri.map(|v| v.n), face, color: t.color });
        }
    }
    prims
}
