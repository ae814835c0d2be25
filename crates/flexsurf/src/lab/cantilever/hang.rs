//! The solved cantilever strip as it hangs, for pictures and meshes: the plate's node columns and the elastica
//! of the same overhang, each turned into a triangle band.

use super::{Elastica, Strip};
use crate::math::Vec3;
use crate::surface::mesh::TriMesh;

/// The strip hanging at one overhang, for pictures and meshes: the finer grid's solution.
#[derive(Debug, Clone)]
pub struct Hang {
    /// Overhang (m).
    pub overhang: f64,
    /// Width (m).
    pub width: f64,
    /// Node columns from the ledge edge to the tip, each across the width.
    pub columns: Vec<[Vec3; Strip::ACROSS]>,
    /// The heavy elastica of the strip's nominal rigidity at this overhang, in units of the overhang.
    pub elastica: Elastica,
}

impl Hang {
    /// The strip as a triangle mesh (the ledge edge at x = 0).
    pub fn mesh(&self) -> TriMesh {
        ribbon(&self.columns.iter().map(|c| c.to_vec()).collect::<Vec<_>>())
    }

    /// The elastica as a band of thickness `thickness` in the vertical plane `y = offset` (a line drawn along
    /// the strip's edge in a side view).
    pub fn elastica_mesh(&self, offset: f64, thickness: f64) -> TriMesh {
        let n = 200;
        let point = |k: usize| {
            let (x, drop) = self.elastica.at(k as f64 / n as f64);
            Vec3::new(x * self.overhang, offset, -drop * self.overhang)
        };
        let cols: Vec<Vec<Vec3>> = (0..=n)
            .map(|k| {
                let p = point(k);
                let t = (point((k + 1).min(n)) - point(k.saturating_sub(1))).normalize_or_zero();
                let normal = Vec3::new(-t.z, 0.0, t.x) * (0.5 * thickness);
                vec![p - normal, p + normal]
            })
            .collect();
        ribbon(&cols)
    }
}

/// A quad strip through consecutive columns of points (same count in each), two triangles per quad.
fn ribbon(cols: &[Vec<Vec3>]) -> TriMesh {
    let across = cols.first().map_or(0, Vec::len);
    let positions: Vec<Vec3> = cols.iter().flatten().copied().collect();
    let mut triangles = Vec::new();
    for i in 0..cols.len().saturating_sub(1) {
        for a in 0..across.saturating_sub(1) {
            let k = |i: usize, a: usize| (i * across + a) as u32;
            triangles.push([k(i, a), k(i + 1, a), k(i + 1, a + 1)]);
            triangles.push([k(i, a), k(i + 1, a + 1), k(i, a + 1)]);
        }
    }
    TriMesh { positions, normals: Vec::new(), triangles }
}
