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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{scratch_dir, test_mesh};

    /// Minimal reader for what `write_ply_to` produces: (vertex rows, faces).
    fn read_back(bytes: &[u8]) -> (Vec<Vec<f32>>, Vec<Vec<u32>>) {
        let end = b"end_header\n";
        let pos = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
        let header = std::str::from_utf8(&bytes[..pos]).unwrap();
        let (mut nv, mut nf, mut props, mut ascii) = (0, 0, 0, false);
        for line in header.lines() {
            let t: Vec<&str> = line.split_whitespace().collect();
            match t.as_slice() {
                ["format", f, "1.0"] => ascii = *f == "ascii",
                ["element", "vertex", n] => nv = n.parse().unwrap(),
                ["element", "face", n] => nf = n.parse().unwrap(),
                ["property", "float", _] => props += 1,
                _ => {}
            }
        }
        let body = &bytes[pos..];
        let (mut verts, mut faces) = (Vec::new(), Vec::new());
        if ascii {
            let text = std::str::from_utf8(body).unwrap();
            let mut lines = text.lines();
            for _ in 0..nv {
                verts.push(lines.next().unwrap().split(' ').map(|s| s.parse().unwrap()).collect());
            }
            for _ in 0..nf {
                let f: Vec<u32> = lines.next().unwrap().split(' ').map(|s| s.parse().unwrap()).collect();
                assert_eq!(f[0], 3);
                faces.push(f[1..].to_vec());
            }
            assert!(lines.next().is_none());
        } else {
            let mut at = 0;
            let mut take4 = || {
                let b: [u8; 4] = body[at..at + 4].try_into().unwrap();
                at += 4;
                b
            };
            for _ in 0..nv {
                verts.push((0..props).map(|_| f32::from_le_bytes(take4())).collect());
            }
            let mut at2 = nv * props * 4;
            for _ in 0..nf {
                assert_eq!(body[at2], 3);
                let f = (0..3)
                    .map(|c| u32::from_le_bytes(body[at2 + 1 + 4 * c..at2 + 5 + 4 * c].try_into().unwrap()))
                    .collect();
                faces.push(f);
                at2 += 13;
            }
            assert_eq!(at2, body.len());
        }
        (verts, faces)
    }

    #[test]
    fn round_trip_both_formats() {
        let mesh = test_mesh();
        let d = scratch_dir("ply");
        for format in [PlyFormat::Ascii, PlyFormat::BinaryLittleEndian] {
            let p = d.join(format!("m-{format:?}.ply"));
            write_ply(&p, &mesh, format).unwrap();
            let (verts, faces) = read_back(&std::fs::read(&p).unwrap());
            assert_eq!(verts.len(), mesh.vertex_count());
            assert_eq!(faces.len(), mesh.triangle_count());
            for (k, v) in verts.iter().enumerate() {
                assert_eq!(v.len(), 6);
                assert_eq!(v[0], mesh.positions[k].x as f32);
                assert_eq!(v[2], mesh.positions[k].z as f32);
                assert_eq!(v[4], mesh.normals[k].y as f32);
            }
            for (k, f) in faces.iter().enumerate() {
                assert_eq!(&f[..], &mesh.triangles[k][..]);
            }
        }
        std::fs::remove_dir_all(&d).unwrap();
    }
}
