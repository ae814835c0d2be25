//! The xy footprint of a mesh: the area of the union of its triangles projected onto the horizontal plane,
//! measured on a raster. Pure geometry on a [`TriMesh`]; the run summaries (`projected_area_xy`) and the Cusick
//! drape test (the shadow of the draped specimen) read it.

use super::mesh::TriMesh;
use crate::math::Vec3;

/// Area of the union of `mesh`'s triangles projected onto the xy plane: the fraction of the centres of a
/// `res × res` raster over the footprint's xy bounding box that fall inside some projected triangle, times the
/// box's area. The error is of order (perimeter × cell size).
pub fn projected_area_xy(mesh: &TriMesh, res: usize) -> f64 {
    let Some(bb) = mesh.bbox() else { return 0.0 };
    let res = res.max(1);
    let (x0, y0) = (bb.min.x, bb.min.y);
    let (sx, sy) = ((bb.max.x - x0) / res as f64, (bb.max.y - y0) / res as f64);
    if !(sx > 0.0 && sy > 0.0 && sx.is_finite() && sy.is_finite()) {
        return 0.0;
    }
    let mut covered = vec![false; res * res];
    let cell = |v: f64, o: f64, s: f64| ((v - o) / s - 0.5).clamp(0.0, res as f64 - 1.0);
    for t in 0..mesh.triangle_count() {
        let Some([a, b, c]) = mesh.triangle(t) else { continue };
        let area2 = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
        if area2 == 0.0 || !area2.is_finite() {
            continue;
        }
        let (lo_x, hi_x) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
        let (lo_y, hi_y) = (a.y.min(b.y).min(c.y), a.y.max(b.y).max(c.y));
        let (i0, i1) = (cell(lo_x, x0, sx).floor() as usize, cell(hi_x, x0, sx).ceil() as usize);
        let (j0, j1) = (cell(lo_y, y0, sy).floor() as usize, cell(hi_y, y0, sy).ceil() as usize);
        let edge = |p: Vec3, q: Vec3, x: f64, y: f64| ((q.x - p.x) * (y - p.y) - (x - p.x) * (q.y - p.y)) * area2;
        for j in j0..=j1 {
            let y = y0 + (j as f64 + 0.5) * sy;
            for i in i0..=i1 {
                let x = x0 + (i as f64 + 0.5) * sx;
                if edge(a, b, x, y) >= 0.0 && edge(b, c, x, y) >= 0.0 && edge(c, a, x, y) >= 0.0 {
                    covered[i + res * j] = true;
                }
            }
        }
    }
    covered.iter().filter(|&&c| c).count() as f64 * sx * sy
}
