//! Triangle-mesh obstacles read from Wavefront OBJ, with signed distance through [`parry3d_f64`]: the closest
//! point comes from parry's BVH point projection, and the side from the angle-weighted pseudo-normal of the
//! closest feature (face, edge or vertex; Bærentzen & Aanæs), which is exact for a closed, consistently
//! oriented mesh. Faces must be counter-clockwise seen from outside (the OBJ convention), so that
//! `(b − a) × (c − a)` points out of the body. Units are metres.

use crate::contact::nurbs::Hint;
use crate::contact::shape::{Look, Shape};
use crate::math::Vec3;
use parry3d_f64::math::Vector;
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::shape::{TriMesh as ParryTriMesh, TriMeshFlags};
#[cfg(feature = "app")]
use std::path::Path;
use thiserror::Error;

/// What is wrong with a mesh or an OBJ file.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TriMeshError {
    /// The file could not be read.
    #[error("{file}: cannot read the file: {message}")]
    Io {
        /// File name.
        file: String,
        /// The system's message.
        message: String,
    },
    /// A malformed `v` or `f` line.
    #[error("{file}:{line}: {message}")]
    Syntax {
        /// File name.
        file: String,
        /// Line number (1-based).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The mesh is not a closed, consistently oriented surface: a body needs an inside.
    #[error(
        "{file}: the mesh is not closed ({edges} edges are not shared by exactly two triangles of opposite \
         orientation, e.g. between vertices {first:?}): an obstacle mesh must bound a solid"
    )]
    Open {
        /// File name.
        file: String,
        /// Edges that are open, non-manifold or inconsistently oriented.
        edges: usize,
        /// One of them (1-based vertex numbers, as in the file).
        first: (u32, u32),
    },
    /// The triangles wind clockwise seen from outside (the enclosed volume is negative).
    #[error(
        "{file}: the mesh is inside out (its enclosed volume is {volume:.3e} m³ with the faces' winding): list each \
         face's vertices counter-clockwise seen from outside"
    )]
    InsideOut {
        /// File name.
        file: String,
        /// Signed volume (m³).
        volume: f64,
    },
    /// A stray vertex far from the rest, or an enclosed volume lost in round-off (a flat mesh): the winding
    /// cannot be told.
    #[error(
        "{file}: the mesh's orientation cannot be told: its farthest vertex, {vertex} (1-based, as in the file), \
         is {distance:.3e} m from the mesh's median point, over 100 times the other vertices' typical distance, or \
         its enclosed volume is lost in round-off: a stray vertex, or a flat mesh?"
    )]
    Degenerate {
        /// File name.
        file: String,
        /// The vertex farthest from the median point (1-based).
        vertex: usize,
        /// Its distance (m).
        distance: f64,
    },
    /// A vertex coordinate is NaN or infinite.
    /// Written 1-based, as an OBJ file numbers its vertices (and as the other errors here do).
    #[error("vertex {} (1-based) is not finite", .index + 1)]
    NonFiniteVertex {
        /// Vertex index (0-based).
        index: usize,
    },
    /// A triangle refers to a missing vertex; written 1-based, as an OBJ file numbers them.
    #[error(
        "triangle {} refers to vertex {} (1-based), but there are {vertices} vertices",
        .triangle + 1,
        u64::from(*.index) + 1
    )]
    IndexOutOfRange {
        /// Triangle number (0-based).
        triangle: usize,
        /// The vertex index (0-based).
        index: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// No triangles.
    #[error("{0}: the mesh has no triangles")]
    Empty(String),
    /// More vertices than a `u32` index can address.
    #[error("the mesh has {0} vertices; at most u32::MAX are addressable")]
    TooManyVertices(usize),
}

/// A rigid obstacle bounded by a closed triangle mesh.
#[derive(Clone)]
pub struct TriMeshBody {
    mesh: ParryTriMesh,
}

impl std::fmt::Debug for TriMeshBody {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TriMeshBody")
            .field("vertices", &self.mesh.vertices().len())
            .field("triangles", &self.mesh.indices().len())
            .finish()
    }
}

#[inline]
fn to_parry(p: Vec3) -> Vector {
    Vector::new(p.x, p.y, p.z)
}

#[inline]
fn from_parry(p: Vector) -> Vec3 {
    Vec3::new(p.x, p.y, p.z)
}

/// Parses one OBJ face index (`7`, `7/1`, `7//3`, `7/1/3`; negative = relative to the end) to 0-based.
fn face_index(token: &str, vertices: usize) -> Result<u32, String> {
    let first = token.split('/').next().unwrap_or("");
    let i: i64 = first.parse().map_err(|_| "a vertex index is not an integer".to_string())?;
    let zero_based = match i {
        0 => return Err("vertex index 0 (OBJ indices start at 1)".to_string()),
        i if i > 0 => i - 1,
        i => vertices as i64 + i,
    };
    u32::try_from(zero_based).map_err(|_| format!("vertex index {i} is out of range"))
}

/// Vertices and fan-triangulated faces of OBJ text (`v` and `f` lines; everything else is ignored).
pub(crate) fn parse_obj(text: &str, file: &str) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), TriMeshError> {
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let syntax = |message: String| TriMeshError::Syntax { file: file.to_string(), line: n + 1, message };
        let line = raw.split('#').next().unwrap_or("");
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("v") => {
                let mut c = [0.0; 3];
                for (axis, x) in c.iter_mut().enumerate() {
                    let t = tokens.next().ok_or_else(|| syntax("a vertex needs x y z".to_string()))?;
                    // The message names the field, not its text: a file's contents are never echoed.
                    *x = t.parse().map_err(|_| syntax(format!("coordinate {} is not a number", axis + 1)))?;
                    // `inf` and `nan` parse as numbers, and no finite shape has them.
                    if !f64::is_finite(*x) {
                        return Err(syntax(format!("coordinate {} is not finite", axis + 1)));
                    }
                }
                vertices.push(Vec3::from_array(c));
            }
            Some("f") => {
                let idx =
                    tokens.map(|t| face_index(t, vertices.len())).collect::<Result<Vec<_>, _>>().map_err(syntax)?;
                if idx.len() < 3 {
                    return Err(syntax(format!("a face needs at least 3 vertices, got {}", idx.len())));
                }
                for k in 1..idx.len() - 1 {
                    triangles.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok((vertices, triangles))
}

/// A closed, consistently oriented surface with positive enclosed volume: every directed edge once and its
/// reverse once (vertices at the same position are one vertex).
fn check_closed(vertices: &[Vec3], triangles: &[[u32; 3]], file: &str) -> Result<(), TriMeshError> {
    use std::collections::HashMap;
    let mut id: HashMap<[u64; 3], u32> = HashMap::new();
    let canon: Vec<u32> = vertices
        .iter()
        .enumerate()
        .map(|(i, v)| *id.entry([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]).or_insert(i as u32))
        .collect();
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        let c = t.map(|i| canon[i as usize]);
        for e in 0..3 {
            *directed.entry((c[e], c[(e + 1) % 3])).or_insert(0) += 1;
        }
    }
    let mut bad: Vec<(u32, u32)> = directed
        .iter()
        .filter(|(&(a, b), &n)| a != b && (n != 1 || directed.get(&(b, a)) != Some(&1)))
        .map(|(&(a, b), _)| (a.min(b) + 1, a.max(b) + 1))
        .collect();
    bad.sort_unstable();
    bad.dedup();
    if let Some(&first) = bad.first() {
        return Err(TriMeshError::Open { file: file.to_string(), edges: bad.len(), first });
    }
    // The signed volume about the vertices' median point (not the origin: far coordinates would cancel), and
    // how much of it round-off could be.
    let median = |axis: usize| {
        let mut v: Vec<f64> = vertices.iter().map(|p| p[axis]).collect();
        v.sort_unstable_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let r = Vec3::new(median(0), median(1), median(2));
    let (mut volume, mut magnitude) = (0.0, 0.0);
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize] - r);
        let v = a.dot(b.cross(c)) / 6.0;
        volume += v;
        magnitude += v.abs();
    }
    let lost = !volume.is_finite() || volume.abs() <= 1e3 * f64::EPSILON * magnitude;
    if lost || volume < 0.0 {
        // A stray vertex far from the rest (its faces folded over the others, or its coordinates swamping the
        // sum) is named rather than called a winding fault.
        let mut d: Vec<f64> = vertices.iter().map(|p| (*p - r).length()).collect();
        let far = (0..d.len()).fold(0, |m, k| if d[k] > d[m] { k } else { m });
        let distance = d[far];
        d.sort_unstable_by(f64::total_cmp);
        let typical = d[d.len() / 2];
        if lost || distance > 100.0 * typical {
            return Err(TriMeshError::Degenerate { file: file.to_string(), vertex: far + 1, distance });
        }
    }
    if volume < 0.0 {
        return Err(TriMeshError::InsideOut { file: file.to_string(), volume });
    }
    Ok(())
}

impl TriMeshBody {
    /// A body from vertices and counter-clockwise (seen from outside) triangles.
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self, TriMeshError> {
        Self::build(vertices, triangles, "mesh")
    }

    fn build(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>, file: &str) -> Result<Self, TriMeshError> {
        if vertices.len() > u32::MAX as usize {
            return Err(TriMeshError::TooManyVertices(vertices.len()));
        }
        if let Some(index) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(TriMeshError::NonFiniteVertex { index });
        }
        if triangles.is_empty() {
            return Err(TriMeshError::Empty(file.to_string()));
        }
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertices.len()) {
                return Err(TriMeshError::IndexOutOfRange { triangle: t, index, vertices: vertices.len() });
            }
        }
        check_closed(&vertices, &triangles, file)?;
        let verts = vertices.into_iter().map(to_parry).collect();
        let flags = TriMeshFlags::ORIENTED | TriMeshFlags::MERGE_DUPLICATE_VERTICES;
        let mesh =
            ParryTriMesh::with_flags(verts, triangles, flags).map_err(|_| TriMeshError::Empty(file.to_string()))?;
        Ok(Self { mesh })
    }

    /// Parses OBJ text (`v x y z` and `f i j k …` lines, polygons fan-triangulated; `vt`, `vn`, groups,
    /// materials and comments are ignored); `file` names it in errors.
    pub fn from_obj_str(text: &str, file: &str) -> Result<Self, TriMeshError> {
        let (vertices, triangles) = parse_obj(text, file)?;
        Self::build(vertices, triangles, file)
    }

    /// Loads an OBJ file.
    #[cfg(feature = "app")]
    pub fn from_obj(path: impl AsRef<Path>) -> Result<Self, TriMeshError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let text = crate::io::input::read_text(path)
            .map_err(|e| TriMeshError::Io { file: file.clone(), message: e.to_string() })?;
        Self::from_obj_str(&text, &file)
    }

    /// Number of vertices (after merging duplicates).
    pub fn vertex_count(&self) -> usize {
        self.mesh.vertices().len()
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.mesh.indices().len()
    }

    /// Closest surface point, signed distance (positive outside) and outward normal of `p`. The normal is
    /// `±(p − q)/|p − q|` (pointing out of the body), or the closest triangle's normal when `p` is on the
    /// surface. A non-finite `p` gives a NaN distance.
    pub fn closest(&self, p: Vec3) -> (Vec3, f64, Vec3) {
        if !p.is_finite() {
            return (p, f64::NAN, Vec3::Z);
        }
        let (proj, (tri, _)) = self.mesh.project_local_point_and_get_location(to_parry(p), false);
        self.answer(p, proj, tri)
    }

    /// [`TriMeshBody::closest`] if the surface is within `radius` of `p` (a finite point), else `None`: the
    /// same search, its subtrees farther than `radius` not visited.
    fn closest_within(&self, p: Vec3, radius: f64) -> Option<(Vec3, f64, Vec3)> {
        let found = self.mesh.project_local_point_and_get_location_with_max_dist(to_parry(p), false, radius);
        found.map(|(proj, (tri, _))| self.answer(p, proj, tri))
    }

    /// The closest point, signed distance and normal of `p` from its projection `proj` on triangle `tri`.
    fn answer(&self, p: Vec3, proj: parry3d_f64::query::PointProjection, tri: u32) -> (Vec3, f64, Vec3) {
        let q = from_parry(proj.point);
        let delta = p - q;
        let dist = delta.length();
        let sign = if proj.is_inside { -1.0 } else { 1.0 };
        let face = self.mesh.triangle(tri).normal().map(from_parry).unwrap_or(Vec3::Z);
        let normal = if dist > 1e-12 * (1.0 + q.length()) { delta * (sign / dist) } else { face };
        (q, sign * dist, normal)
    }

    /// The body as a display mesh (vertices after merging, face-averaged normals).
    pub fn to_mesh(&self) -> crate::surface::mesh::TriMesh {
        let positions = self.mesh.vertices().iter().map(|v| from_parry(*v)).collect();
        let triangles = self.mesh.indices().to_vec();
        let mut m = crate::surface::mesh::TriMesh { positions, normals: Vec::new(), triangles };
        m.recompute_normals();
        m
    }

    /// Signed distance of `p` (positive outside) and the outward normal (see [`TriMeshBody::closest`]).
    pub fn distance(&self, p: Vec3) -> (f64, Vec3) {
        let (_, d, n) = self.closest(p);
        (d, n)
    }
}

/// The body as an obstacle (the hint is not used). Nothing within the radius leaves a point either far outside
/// or deeper than the radius inside: the unbounded query tells them apart where the bound `floor` does not.
impl Shape for TriMeshBody {
    fn distance_within(&self, p: Vec3, hint: &mut Option<Hint>, radius: f64) -> Option<(f64, Vec3)> {
        self.distance_within_above(p, hint, radius, f64::NEG_INFINITY)
    }

    fn distance_within_above(&self, p: Vec3, _hint: &mut Option<Hint>, radius: f64, floor: f64) -> Option<(f64, Vec3)> {
        if p.is_finite() && radius.is_finite() {
            if let Some((_, d, n)) = self.closest_within(p, radius) {
                return Some((d, n));
            }
            if floor > -radius {
                return None;
            }
        }
        Some(self.distance(p))
    }

    fn look(&self) -> Option<Look> {
        Some(Look::Mesh(self.to_mesh()))
    }
}
