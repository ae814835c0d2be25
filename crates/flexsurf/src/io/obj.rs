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
    writeln!(w, "# flexsurf mesh: {} vertices, {} triangles", mesh.vertex_count(), mesh.triangle_count())?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    let normals = mesh.has_normals();
    if normals {
        for n in &mesh.normals {
            writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
        }
    }
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

/// OBJ frames: `.obj`, [`write_obj`].
pub const WRITER: MeshWriter = MeshWriter { extension: "obj", write: |path, mesh| write_obj(path, mesh) };

/// Writes `mesh` to an OBJ file at `path`, atomically.
pub fn write_obj(path: impl AsRef<Path>, mesh: &TriMesh) -> io::Result<()> {
    mesh.validate().map_err(invalid)?;
    write_atomic_with(path, |w| write_obj_to(w, mesh))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::scratch_dir;
    use crate::io::test_mesh;
    use crate::math::Vec3;

    #[test]
    fn round_trip() {
        let mesh = test_mesh();
        let d = scratch_dir("obj");
        let p = d.join("m.obj");
        write_obj(&p, &mesh).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        let (mut v, mut vn, mut f) = (Vec::new(), Vec::new(), Vec::new());
        for line in text.lines() {
            let mut it = line.split_whitespace();
            match it.next() {
                Some("v") => v.push(it.map(|s| s.parse::<f64>().unwrap()).collect::<Vec<_>>()),
                Some("vn") => vn.push(it.map(|s| s.parse::<f64>().unwrap()).collect::<Vec<_>>()),
                Some("f") => f.push(
                    it.map(|s| {
                        let (a, b) = s.split_once("//").unwrap();
                        assert_eq!(a, b);
                        a.parse::<u32>().unwrap() - 1
                    })
                    .collect::<Vec<_>>(),
                ),
                _ => {}
            }
        }
        assert_eq!(v.len(), mesh.vertex_count());
        assert_eq!(vn.len(), mesh.vertex_count());
        assert_eq!(f.len(), mesh.triangle_count());
        for (k, p) in mesh.positions.iter().enumerate() {
            assert_eq!(Vec3::new(v[k][0], v[k][1], v[k][2]), *p);
        }
        assert_eq!(Vec3::new(vn[2][0], vn[2][1], vn[2][2]), mesh.normals[2]);
        for (k, t) in mesh.triangles.iter().enumerate() {
            assert_eq!(&f[k][..], &t[..]);
        }
        // An invalid mesh is an error, and nothing is written.
        let mut bad = mesh.clone();
        bad.triangles.push([0, 1, 99]);
        let q = d.join("bad.obj");
        assert_eq!(write_obj(&q, &bad).unwrap_err().kind(), io::ErrorKind::InvalidInput);
        assert!(!q.exists());
        std::fs::remove_dir_all(&d).unwrap();
    }
}
