//! What the renderer draws: the [`Drawable`]s (cloth meshes, spheres, ground planes) with their default
//! colours and bounding boxes, the meshes standing for the analytic obstacles, and the flat list of
//! world-space triangles that [`super::frame`] projects and [`super::shadow`] casts shadows from.

use super::shade::linear_rgb;
use crate::math::Vec3;
use crate::surface::mesh::{Aabb, TriMesh};
use std::borrow::Cow;

/// Default cloth colour (sRGB).
pub const CLOTH_COLOR: [u8; 3] = [66, 118, 189];
/// Default sphere colour (sRGB).
pub const SPHERE_COLOR: [u8; 3] = [196, 96, 74];
/// Default ground colour (sRGB).
pub const GROUND_COLOR: [u8; 3] = [214, 210, 200];
/// Default background colour (sRGB).
pub const BACKGROUND_COLOR: [u8; 3] = [246, 247, 249];

/// The union of the bounding boxes of the drawables (planes, being infinite, are left out).
pub fn bbox_of(drawables: &[Drawable<'_>]) -> Option<Aabb> {
    drawables.iter().filter_map(Drawable::bbox).reduce(Aabb::union)
}

/// Something to draw.
#[derive(Debug, Clone)]
pub enum Drawable<'a> {
    /// A triangle mesh (cloth) with a base colour; drawn two-sided.
    Mesh {
        /// The mesh; its normals are used when it has one per vertex, face normals otherwise.
        mesh: Cow<'a, TriMesh>,
        /// Base colour (sRGB).
        color: [u8; 3],
    },
    /// A sphere obstacle.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f64,
        /// Base colour (sRGB).
        color: [u8; 3],
    },
    /// An infinite ground plane, drawn as a checkered square sized to the rest of the scene.
    Plane {
        /// A point on the plane.
        point: Vec3,
        /// Plane normal.
        normal: Vec3,
        /// Base colour (sRGB).
        color: [u8; 3],
    },
}

impl<'a> Drawable<'a> {
    /// A borrowed mesh.
    pub fn mesh(mesh: &'a TriMesh, color: [u8; 3]) -> Self {
        Self::Mesh { mesh: Cow::Borrowed(mesh), color }
    }

    /// An owned mesh.
    pub fn owned_mesh(mesh: TriMesh, color: [u8; 3]) -> Self {
        Self::Mesh { mesh: Cow::Owned(mesh), color }
    }

    /// A sphere.
    pub fn sphere(center: Vec3, radius: f64, color: [u8; 3]) -> Self {
        Self::Sphere { center, radius, color }
    }

    /// A ground plane.
    pub fn plane(point: Vec3, normal: Vec3, color: [u8; 3]) -> Self {
        Self::Plane { point, normal, color }
    }

    /// Bounding box, or `None` for a plane or empty or invalid geometry.
    pub fn bbox(&self) -> Option<Aabb> {
        match self {
            Self::Mesh { mesh, .. } => mesh.bbox(),
            Self::Sphere { center, radius, .. } => {
                let r = Vec3::splat(radius.abs());
                (center.is_finite() && radius.is_finite()).then(|| Aabb { min: *center - r, max: *center + r })
            }
            Self::Plane { .. } => None,
        }
    }
}

/// A UV sphere: `stacks` rings from pole to pole, `slices` segments round, outward normals, counter-clockwise
/// seen from outside.
pub fn uv_sphere(center: Vec3, radius: f64, stacks: usize, slices: usize) -> TriMesh {
    let (stacks, slices) = (stacks.max(2), slices.max(3));
    let mut mesh = TriMesh::new();
    for i in 0..=stacks {
        let th = std::f64::consts::PI * i as f64 / stacks as f64;
        for j in 0..=slices {
            let ph = std::f64::consts::TAU * j as f64 / slices as f64;
            let n = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            mesh.positions.push(center + n * radius);
            mesh.normals.push(n);
        }
    }
    let id = |i: usize, j: usize| (i * (slices + 1) + j) as u32;
    for i in 0..stacks {
        for j in 0..slices {
            let (v00, v10, v01, v11) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
            if i + 1 < stacks {
                mesh.triangles.push([v00, v10, v11]);
            }
            if i > 0 {
                mesh.triangles.push([v00, v11, v01]);
            }
        }
    }
    mesh
}

/// A checkered square of `tiles × tiles` tiles (two triangles each) in the plane through `center` with normal
/// `normal`, side `2 half`; the second return value is the per-triangle shade factor (1 or 0.86).
pub fn checkered_square(center: Vec3, normal: Vec3, half: f64, tiles: usize) -> (TriMesh, Vec<f64>) {
    let n = normal.try_normalize().unwrap_or(Vec3::Z);
    let (e1, e2) = plane_basis(n);
    let tiles = tiles.max(1);
    let step = 2.0 * half / tiles as f64;
    let mut mesh = TriMesh::new();
    for b in 0..=tiles {
        for a in 0..=tiles {
            mesh.positions.push(center + e1 * (a as f64 * step - half) + e2 * (b as f64 * step - half));
            mesh.normals.push(n);
        }
    }
    let mut shade = Vec::with_capacity(2 * tiles * tiles);
    let id = |a: usize, b: usize| (a + (tiles + 1) * b) as u32;
    for b in 0..tiles {
        for a in 0..tiles {
            mesh.triangles.push([id(a, b), id(a + 1, b), id(a + 1, b + 1)]);
            mesh.triangles.push([id(a, b), id(a + 1, b + 1), id(a, b + 1)]);
            let s = if (a + b) % 2 == 0 { 1.0 } else { 0.86 };
            shade.extend([s, s]);
        }
    }
    (mesh, shade)
}

/// Orthonormal `(e1, e2)` with `e1 × e2 = n` for a unit `n`.
pub(super) fn plane_basis(n: Vec3) -> (Vec3, Vec3) {
    let a = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let e1 = (a - n * a.dot(n)).normalize();
    (e1, n.cross(e1))
}

/// A world-space triangle ready to draw.
pub(super) struct Tri {
    pub(super) p: [Vec3; 3],
    pub(super) n: [Vec3; 3],
    pub(super) color: [f64; 3],
    pub(super) casts_shadow: bool,
}

/// Collects the triangles of all drawables.
pub(super) fn gather(drawables: &[Drawable<'_>]) -> Vec<Tri> {
    let content = bbox_of(drawables);
    let capacity =
        drawables.iter().map(|d| if let Drawable::Mesh { mesh, .. } = d { mesh.triangle_count() } else { 4096 });
    let mut tris = Vec::with_capacity(capacity.sum());
    let mut push_mesh = |mesh: &TriMesh, color: [f64; 3], shade: Option<&[f64]>, casts: bool| {
        let normals: Cow<'_, [Vec3]> =
            if mesh.has_normals() { Cow::Borrowed(&mesh.normals) } else { Cow::Owned(mesh.face_averaged_normals()) };
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let Some(p) = mesh.triangle(t) else { continue };
            if !p.iter().all(|v| v.is_finite()) {
                continue;
            }
            let n = tri.map(|v| normals[v as usize]);
            let s = shade.and_then(|s| s.get(t)).copied().unwrap_or(1.0);
            tris.push(Tri { p, n, color: color.map(|c| c * s), casts_shadow: casts });
        }
    };
    for d in drawables {
        match d {
            Drawable::Mesh { mesh, color } => push_mesh(mesh, linear_rgb(*color), None, true),
            Drawable::Sphere { center, radius, color } => {
                if center.is_finite() && radius.is_finite() && *radius > 0.0 {
                    push_mesh(&uv_sphere(*center, *radius, 32, 64), linear_rgb(*color), None, true);
                }
            }
            Drawable::Plane { point, normal, color } => {
                let Some(n) = normal.try_normalize() else { continue };
                if !point.is_finite() {
                    continue;
                }
                let (c, half) = match content {
                    Some(b) => (b.center() - n * (b.center() - *point).dot(n), 6.0 * b.radius().max(1e-6)),
                    None => (*point, 1.0),
                };
                let (mesh, shade) = checkered_square(c, n, half, 24);
                push_mesh(&mesh, linear_rgb(*color), Some(&shade), false);
            }
        }
    }
    tris
}
