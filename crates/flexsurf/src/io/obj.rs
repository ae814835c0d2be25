//! Wavefront OBJ output of a [`TriMesh`]: `v` positions, `vn` normals and `f a//a b//b c//c` faces (1-based).

use super::atomic::write_atomic_with;
use super::{invalid, MeshWriter};
use crate::surface::mesh::TriMesh;
use std::io::{self, Write};
use std::path::Path;

/// Writes `mesh` as OBJ text to `w`. Normals are written (and referenced by the faces) when the mesh has one per
/// vertex. Numbers use Rust's shortest round-trip formatting, so reading them back gives the same `f64`.
pub fn write_obj_to(w: &mut dyn Write, mesh: &TriMesh) -> io::Result<()> {
    mesh.validate().map_err(invalid)?;
    let normals = write_vertices(w, mesh, &[])?;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| v + 1);
        if normals {
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        } else {
            writeln!(w, "f {a} {b} {c}")?;
        }
    }
    Ok(())
}

/// Writes `mesh` with texture coordinates to an OBJ file at `path`, atomically: `vt` lines from `uv` and faces
/// `f a/ta/na …` whose texture corners are `uv_triangles` (one per triangle of `mesh`), so a vertex shared by
/// two texture islands (a garment's seam, welded) keeps a texture coordinate on each side. Normals as in
/// [`write_obj_to`].
pub fn write_obj_textured(
    path: impl AsRef<Path>,
    mesh: &TriMesh,
    uv: &[[f32; 2]],
    uv_triangles: &[[u32; 3]],
) -> io::Result<()> {
    mesh.validate().map_err(invalid)?;
    if uv_triangles.len() != mesh.triangles.len() || uv_triangles.iter().flatten().any(|&t| t as usize >= uv.len()) {
        return Err(invalid(format!(
            "{} texture triangles into {} texture coordinates for a mesh of {} triangles",
            uv_triangles.len(),
            uv.len(),
            mesh.triangles.len()
        )));
    }
    write_atomic_with(path, |w| {
        let normals = write_vertices(w, mesh, uv)?;
        for (t, u) in mesh.triangles.iter().zip(uv_triangles) {
            let ([a, b, c], [ta, tb, tc]) = (t.map(|v| v + 1), u.map(|v| v + 1));
            if normals {
                writeln!(w, "f {a}/{ta}/{a} {b}/{tb}/{b} {c}/{tc}/{c}")?;
            } else {
                writeln!(w, "f {a}/{ta} {b}/{tb} {c}/{tc}")?;
            }
        }
        Ok(())
    })
}

/// The header, `v`, `vt` (from `uv`) and `vn` lines (normals when the mesh has one per vertex); returns whether
/// it wrote normals.
fn write_vertices(w: &mut dyn Write, mesh: &TriMesh, uv: &[[f32; 2]]) -> io::Result<bool> {
    writeln!(w, "# flexsurf mesh: {} vertices, {} triangles", mesh.vertex_count(), mesh.triangle_count())?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for t in uv {
        writeln!(w, "vt {} {}", t[0], t[1])?;
    }
    let normals = mesh.has_normals();
    if normals {
        for n in &mesh.normals {
            writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
        }
    }
    Ok(normals)
}

/// OBJ frames: `.obj`, [`write_obj`].
pub const WRITER: MeshWriter = MeshWriter { extension: "obj", write: |path, mesh| write_obj(path, mesh) };

/// Writes `mesh` to an OBJ file at `path`, atomically.
pub fn write_obj(path: impl AsRef<Path>, mesh: &TriMesh) -> io::Result<()> {
    mesh.validate().map_err(invalid)?;
    write_atomic_with(path, |w| write_obj_to(w, mesh))
}
