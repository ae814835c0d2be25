//! Indexed triangle meshes: the common currency between the display surface ([`super::coons`]), the file
//! writers ([`crate::io`]) and the software renderer ([`crate::io::render`]).

use crate::math::Vec3;
use thiserror::Error;

/// A structural problem with a [`TriMesh`] that makes it unfit for writing or drawing.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum MeshError {
    /// `normals` is neither empty nor one per vertex.
    #[error("mesh has {positions} positions but {normals} normals")]
    NormalCount {
        /// Number of positions.
        positions: usize,
        /// Number of normals.
        normals: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has {positions} vertices")]
    IndexOutOfRange {
        /// Triangle number.
        triangle: usize,
        /// The offending vertex index.
        index: u32,
        /// Number of positions.
        positions: usize,
    },
    /// More vertices than a `u32` index can address.
    #[error("mesh has {0} vertices; at most u32::MAX are addressable")]
    TooManyVertices(usize),
}

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The box of a single point.
    pub fn point(p: Vec3) -> Self {
        Self { min: p, max: p }
    }

    /// The box of the finite points of an iterator, or `None` if there are none.
    pub fn from_points<I: IntoIterator<Item = Vec3>>(points: I) -> Option<Self> {
        points.into_iter().filter(|p| p.is_finite()).fold(None, |acc: Option<Aabb>, p| {
            Some(match acc {
                None => Aabb::point(p),
                Some(b) => b.include(p),
            })
        })
    }

    /// This box grown to contain `p`.
    pub fn include(self, p: Vec3) -> Self {
        Self { min: self.min.min(p), max: self.max.max(p) }
    }

    /// The smallest box containing both.
    pub fn union(self, other: Aabb) -> Self {
        Self { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Edge lengths `max − min`.
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// Half the length of the diagonal: the radius of the circumscribed sphere.
    pub fn radius(&self) -> f64 {
        0.5 * self.size().length()
    }
}

/// An indexed triangle mesh with optional per-vertex unit normals.
///
/// Triangles are counter-clockwise seen from the side the normals point to.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex unit normals: empty, or one per position.
    pub normals: Vec<Vec3>,
    /// Vertex indices, three per triangle.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// An empty mesh.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// True when there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// True when there is one normal per vertex.
    pub fn has_normals(&self) -> bool {
        !self.positions.is_empty() && self.normals.len() == self.positions.len()
    }

    /// Checks index ranges and the normal count.
    pub fn validate(&self) -> Result<(), MeshError> {
        let n = self.positions.len();
        if n > u32::MAX as usize {
            return Err(MeshError::TooManyVertices(n));
        }
        if !self.normals.is_empty() && self.normals.len() != n {
            return Err(MeshError::NormalCount { positions: n, normals: self.normals.len() });
        }
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&v| v as usize >= n) {
                return Err(MeshError::IndexOutOfRange { triangle: t, index, positions: n });
            }
        }
        Ok(())
    }

    /// Bounding box of the finite vertex positions, or `None` for an empty mesh.
    pub fn bbox(&self) -> Option<Aabb> {
        Aabb::from_points(self.positions.iter().copied())
    }

    /// Corner positions of triangle `t`, or `None` if it refers to a missing vertex.
    pub fn triangle(&self, t: usize) -> Option<[Vec3; 3]> {
        let tri = self.triangles.get(t)?;
        let p = |k: u32| self.positions.get(k as usize).copied();
        Some([p(tri[0])?, p(tri[1])?, p(tri[2])?])
    }

    /// Sum of the triangle areas (triangles with missing vertices are skipped).
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .filter_map(|t| self.triangle(t))
            .map(|[a, b, c]| 0.5 * (b - a).cross(c - a).length())
            .sum()
    }

    /// Area-weighted vertex normals from the triangles (zero-area neighbourhoods get `+z`).
    pub fn face_averaged_normals(&self) -> Vec<Vec3> {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in 0..self.triangles.len() {
            if let Some([a, b, c]) = self.triangle(t) {
                let n = (b - a).cross(c - a);
                if n.is_finite() {
                    for &v in &self.triangles[t] {
                        acc[v as usize] += n;
                    }
                }
            }
        }
        acc.into_iter().map(|n| n.try_normalize().unwrap_or(Vec3::Z)).collect()
    }

    /// Replaces `normals` by [`TriMesh::face_averaged_normals`].
    pub fn recompute_normals(&mut self) {
        self.normals = self.face_averaged_normals();
    }

    /// Appends another mesh (its normals are recomputed from faces if either mesh lacks them).
    pub fn append(&mut self, other: &TriMesh) {
        let both_normals = (self.positions.is_empty() || self.has_normals()) && other.has_normals();
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.triangles.extend(other.triangles.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
        if both_normals {
            self.normals.extend_from_slice(&other.normals);
        } else {
            self.recompute_normals();
        }
    }
}
