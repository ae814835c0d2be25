//! Stanford PLY output of a [`TriMesh`], ASCII or binary little-endian: vertex `x y z` (and `nx ny nz` when the
//! mesh has normals) as 32-bit `float`, faces as `list uchar uint vertex_indices`.

use super::atomic::write_atomic_with;
use super::{invalid, MeshWriter};
use crate::surface::mesh::TriMesh;
use std::io::{self, Write};
use std::path::Path;

/// PLY body encoding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlyFormat {
    /// Human-readable text.
    Ascii,
    /// Compact binary, little-endian.
    #[default]
    BinaryLittleEndian,
}

/// Writes `mesh` as PLY to `w`.
pub fn write_ply_to(w: &mut dyn Write, mesh: &TriMesh, format: PlyFormat) -> io::Result<()> {
    mesh.validate().map_err(invalid)?;
    let normals = mesh.has_normals();
    let fmt = match format {
        PlyFormat::Ascii => "ascii",
        PlyFormat::BinaryLittleEndian => "binary_little_endian",
    };
    writeln!(w, "ply\nformat {fmt} 1.0\ncomment flexsurf mesh")?;
    writeln!(w, "element vertex {}", mesh.vertex_count())?;
    writeln!(w, "property float x\nproperty float y\nproperty float z")?;
    if normals {
        writeln!(w, "property float nx\nproperty float ny\nproperty float nz")?;
    }
    writeln!(w, "element face {}", mesh.triangle_count())?;
    writeln!(w, "property list uchar uint vertex_indices\nend_header")?;
    let vertex = |k: usize| -> Vec<f32> {
        let p = mesh.positions[k];
        let mut v = vec![p.x as f32, p.y as f32, p.z as f32];
        if normals {
            let n = mesh.normals[k];
            v.extend([n.x as f32, n.y as f32, n.z as f32]);
        }
        v
    };
    match format {
        PlyFormat::Ascii => {
            for k in 0..mesh.vertex_count() {
                let v: Vec<String> = vertex(k).iter().map(|c| c.to_string()).collect();
                writeln!(w, "{}", v.join(" "))?;
            }
            for t in &mesh.triangles {
                writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?;
            }
        }
        PlyFormat::BinaryLittleEndian => {
            let mut buf = Vec::with_capacity(mesh.vertex_count() * 24 + mesh.triangle_count() * 13);
            for k in 0..mesh.vertex_count() {
                vertex(k).iter().for_each(|c| buf.extend_from_slice(&c.to_le_bytes()));
            }
            for t in &mesh.triangles {
                buf.push(3u8);
                t.iter().for_each(|v| buf.extend_from_slice(&v.to_le_bytes()));
            }
            w.write_all(&buf)?;
        }
    }
    Ok(())
}

/// PLY frames: `.ply`, [`write_ply`] in binary little-endian.
pub const WRITER: MeshWriter =
    MeshWriter { extension: "ply", write: |path, mesh| write_ply(path, mesh, PlyFormat::BinaryLittleEndian) };

/// Writes `mesh` to a PLY file at `path`, atomically.
pub fn write_ply(path: impl AsRef<Path>, mesh: &TriMesh, format: PlyFormat) -> io::Result<()> {
    mesh.validate().map_err(invalid)?;
    write_atomic_with(path, |w| write_ply_to(w, mesh, format))
}
