//! The display surface (the paper's eq. 55–56, corrected): one bicubic Hermite (Coons) patch per grid cell,
//! built from the node positions `x`, the nodal tangents `T1x`, `T2x` and the nodal twist `T12x` at the four
//! corners. Neighbouring patches share the corner data of their common edge, so the surface is C¹ across cell
//! boundaries, and it interpolates the nodes exactly.
//!
//! Within cell `(i, j)` the local parameters are `t1, t2 ∈ [0, 1]` with `u1 = (i + t1) h1`, `u2 = (j + t2) h2`,
//! so `∂x/∂t1 = h1 ∂x/∂u1`, `∂x/∂t2 = h2 ∂x/∂u2` and `∂²x/∂t1∂t2 = h1 h2 ∂²x/∂u1∂u2`.

use super::mesh::TriMesh;
use crate::grid::Grid;
use crate::math::Vec3;
use crate::ops::{nodal_tangents, nodal_twist};
use thiserror::Error;

/// Invalid input to [`CoonsSurface::try_new`].
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum SurfaceError {
    /// `x` does not have one position per grid node.
    #[error("grid has {expected} nodes but {got} positions were given")]
    PositionCount {
        /// `grid.len()`.
        expected: usize,
        /// `x.len()`.
        got: usize,
    },
}

/// Cubic Hermite basis `[f0, f1, g0, g1](t)`.
#[inline]
fn basis(t: f64) -> [f64; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [2.0 * t3 - 3.0 * t2 + 1.0, -2.0 * t3 + 3.0 * t2, t3 - 2.0 * t2 + t, t3 - t2]
}

/// Derivatives `[f0', f1', g0', g1'](t)` of the Hermite basis.
#[inline]
fn basis_dt(t: f64) -> [f64; 4] {
    let t2 = t * t;
    [6.0 * t2 - 6.0 * t, -6.0 * t2 + 6.0 * t, 3.0 * t2 - 4.0 * t + 1.0, 3.0 * t2 - 2.0 * t]
}

/// A point of the display surface with its local partial derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Position.
    pub point: Vec3,
    /// `∂x/∂t1` (cell-local parameter; divide by `h1` for `∂x/∂u1`).
    pub d1: Vec3,
    /// `∂x/∂t2` (cell-local parameter; divide by `h2` for `∂x/∂u2`).
    pub d2: Vec3,
}

impl SurfacePoint {
    /// Unit normal `d1 × d2 / |d1 × d2|`, or `None` where the patch is degenerate.
    pub fn normal(&self) -> Option<Vec3> {
        self.d1.cross(self.d2).try_normalize()
    }
}

/// The C¹ piecewise bicubic Hermite surface through a deformed grid.
#[derive(Debug, Clone)]
pub struct CoonsSurface {
    grid: Grid,
    /// Node positions.
    x: Vec<Vec3>,
    /// `h1 T1x` per node.
    a: Vec<Vec3>,
    /// `h2 T2x` per node.
    b: Vec<Vec3>,
    /// `h1 h2 T12x` per node.
    c: Vec<Vec3>,
}

impl CoonsSurface {
    /// The surface through positions `x` (one per node of `grid`), with tangents and twist from
    /// [`crate::ops::nodal_tangents`] and [`crate::ops::nodal_twist`].
    ///
    /// # Panics
    /// If `x.len() != grid.len()`; use [`CoonsSurface::try_new`] for unchecked input.
    pub fn new(grid: &Grid, x: &[Vec3]) -> Self {
        match Self::try_new(grid, x) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        }
    }

    /// Like [`CoonsSurface::new`], but reports a position count mismatch as an error.
    pub fn try_new(grid: &Grid, x: &[Vec3]) -> Result<Self, SurfaceError> {
        if x.len() != grid.len() {
            return Err(SurfaceError::PositionCount { expected: grid.len(), got: x.len() });
        }
        let tan = nodal_tangents(grid, x);
        let twist = nodal_twist(grid, x);
        Ok(Self::from_derivatives(grid, x, &tan, &twist))
    }

    /// The surface from explicit nodal data: `tangents[k] = (T1x, T2x)` and `twist[k] = T12x` in physical
    /// parameter units (per metre of `u1`, `u2`). All slices must have `grid.len()` entries.
    ///
    /// # Panics
    /// If a slice has the wrong length.
    pub fn from_derivatives(grid: &Grid, x: &[Vec3], tangents: &[(Vec3, Vec3)], twist: &[Vec3]) -> Self {
        assert!(
            x.len() == grid.len() && tangents.len() == grid.len() && twist.len() == grid.len(),
            "nodal data must have one entry per grid node"
        );
        let (h1, h2) = (grid.h1, grid.h2);
        Self {
            grid: *grid,
            x: x.to_vec(),
            a: tangents.iter().map(|t| t.0 * h1).collect(),
            b: tangents.iter().map(|t| t.1 * h2).collect(),
            c: twist.iter().map(|&t| t * (h1 * h2)).collect(),
        }
    }

    /// The grid the surface was built on.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Number of cells (patches) along u1 and u2: `grid.spans(0)`, `grid.spans(1)`.
    pub fn cells(&self) -> (usize, usize) {
        (self.grid.spans(0), self.grid.spans(1))
    }

    /// Position and local partials of cell `(ci, cj)` at `(t1, t2) ∈ [0, 1]²`.
    ///
    /// # Panics
    /// If the cell is outside `0..grid.spans(0)` × `0..grid.spans(1)`.
    pub fn eval(&self, ci: usize, cj: usize, t1: f64, t2: f64) -> SurfacePoint {
        let (s1, s2) = self.cells();
        assert!(ci < s1 && cj < s2, "cell ({ci}, {cj}) outside the {s1}×{s2} cells");
        // Corners in the order [(0,0), (1,0), (0,1), (1,1)] = index a + 2b.
        let nodes = self.grid.cell(ci, cj);
        let (f, fd) = (basis(t1), basis_dt(t1));
        let (g, gd) = (basis(t2), basis_dt(t2));
        let mut point = Vec3::ZERO;
        let mut d1 = Vec3::ZERO;
        let mut d2 = Vec3::ZERO;
        for (corner, &k) in nodes.iter().enumerate() {
            let (ia, ib) = (corner & 1, corner >> 1);
            let (p, a, b, c) = (self.x[k], self.a[k], self.b[k], self.c[k]);
            // Value/derivative basis in t1: f[ia] (position weight), f[2 + ia] (tangent weight).
            let (u0, u1, du0, du1) = (f[ia], f[2 + ia], fd[ia], fd[2 + ia]);
            let (v0, v1, dv0, dv1) = (g[ib], g[2 + ib], gd[ib], gd[2 + ib]);
            point += p * (u0 * v0) + a * (u1 * v0) + b * (u0 * v1) + c * (u1 * v1);
            d1 += p * (du0 * v0) + a * (du1 * v0) + b * (du0 * v1) + c * (du1 * v1);
            d2 += p * (u0 * dv0) + a * (u1 * dv0) + b * (u0 * dv1) + c * (u1 * dv1);
        }
        SurfacePoint { point, d1, d2 }
    }

    /// Tessellates every cell into `k × k` sub-quads (two triangles each; `k = 0` is treated as 1).
    ///
    /// Vertices are shared along cell boundaries and wrap in periodic directions, so the mesh has
    /// `(spans1·k + δ1) × (spans2·k + δ2)` vertices with `δ = 1` for a free direction and `0` for a periodic one,
    /// and `2 k² · cells` triangles. Vertex `(a, b)` has index `a + na·b`. Normals are `∂x/∂t1 × ∂x/∂t2`
    /// normalised; where that vanishes (a degenerate patch), the area-weighted face normal is used instead.
    pub fn tessellate(&self, k: usize) -> TriMesh {
        let k = k.max(1);
        let (s1, s2) = self.cells();
        let count = |d: usize, s: usize| s * k + usize::from(!self.grid.periodic(d));
        let (na, nb) = (count(0, s1), count(1, s2));
        let locate = |v: usize, s: usize| -> (usize, f64) {
            let c = (v / k).min(s - 1);
            (c, (v - c * k) as f64 / k as f64)
        };
        let mut positions = Vec::with_capacity(na * nb);
        let mut normals = Vec::with_capacity(na * nb);
        let mut degenerate = Vec::new();
        for vb in 0..nb {
            let (cj, t2) = locate(vb, s2);
            for va in 0..na {
                let (ci, t1) = locate(va, s1);
                let sp = self.eval(ci, cj, t1, t2);
                positions.push(sp.point);
                match sp.normal() {
                    Some(n) => normals.push(n),
                    None => {
                        degenerate.push(positions.len() - 1);
                        normals.push(Vec3::Z);
                    }
                }
            }
        }
        let mut triangles = Vec::with_capacity(2 * s1 * s2 * k * k);
        let idx = |a: usize, b: usize| ((a % na) + na * (b % nb)) as u32;
        for qb in 0..s2 * k {
            for qa in 0..s1 * k {
                let (v00, v10, v01, v11) = (idx(qa, qb), idx(qa + 1, qb), idx(qa, qb + 1), idx(qa + 1, qb + 1));
                triangles.push([v00, v10, v11]);
                triangles.push([v00, v11, v01]);
            }
        }
        let mut mesh = TriMesh { positions, normals, triangles };
        if !degenerate.is_empty() {
            let fallback = mesh.face_averaged_normals();
            for v in degenerate {
                mesh.normals[v] = fallback[v];
            }
        }
        mesh
    }
}
