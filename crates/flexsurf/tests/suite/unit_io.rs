//! Unit tests of the library, io area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `io::atomic` (`src/io/atomic.rs`).
mod atomic {
    use flexsurf::io::atomic::*;
    use std::fs;
    use std::io;
    use std::path::Path;

    use crate::scratch_dir;

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn writes_and_replaces() {
        let d = scratch_dir("atomic");
        let p = d.join("out.txt");
        write_atomic(&p, b"first").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"first");
        write_atomic_with(&p, |w| {
            w.write_all(b"second ")?;
            write!(w, "{}", 42)
        })
        .unwrap();
        assert_eq!(fs::read_to_string(&p).unwrap(), "second 42");
        assert_eq!(entries(&d), vec!["out.txt".to_string()]);
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn failure_leaves_old_file_and_no_temp() {
        let d = scratch_dir("atomic-fail");
        let p = d.join("out.txt");
        write_atomic(&p, b"old").unwrap();
        let err = write_atomic_with(&p, |w| {
            w.write_all(b"partial new contents")?;
            Err(io::Error::other("interrupted"))
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "interrupted");
        assert_eq!(fs::read(&p).unwrap(), b"old");
        assert_eq!(entries(&d), vec!["out.txt".to_string()]);
        // A missing directory is an error, not a panic.
        assert!(write_atomic(d.join("missing/dir/x.txt"), b"x").is_err());
        assert!(write_atomic(Path::new("/"), b"x").is_err());
        fs::remove_dir_all(&d).unwrap();
    }
}

/// The tests of `io::dxf` (`src/io/dxf.rs`).
mod dxf {
    use flexsurf::io::dxf::internals::{piece_point, reversed, signed_area, with_arcs, Raw};
    use flexsurf::io::dxf::*;

    fn bezier(p: [f64; 2], c: [[f64; 2]; 2], q: [f64; 2], t: f64) -> [f64; 2] {
        let u = 1.0 - t;
        let f = |k: usize| u * u * u * p[k] + 3.0 * u * u * t * c[0][k] + 3.0 * u * t * t * c[1][k] + t * t * t * q[k];
        [f(0), f(1)]
    }

    #[test]
    fn a_bulge_becomes_beziers_on_its_circle() {
        // A half disc of radius 1: the straight diameter from (1, 0) to (−1, 0), then the arc back through (0, −1)
        // (bulge 1: a half turn, counter-clockwise from (−1, 0)).
        let raw: Raw = vec![([1.0, 0.0], 0.0), ([-1.0, 0.0], 1.0)];
        let v = with_arcs(&raw).unwrap();
        assert_eq!(v.len(), 3, "{v:?}");
        let n = v.len();
        for i in 0..n {
            let (p, w) = (v[(i + n - 1) % n].at, v[i]);
            if let Some(c) = w.curve {
                for k in 0..=8 {
                    let b = bezier(p, c, w.at, k as f64 / 8.0);
                    let r = b[0].hypot(b[1]);
                    assert!((r - 1.0).abs() < 3e-4, "radius {r} at {b:?}");
                    assert!(b[1] <= 1e-12, "the arc goes through y < 0: {b:?}");
                }
            }
        }
        assert!(signed_area(&v) > 0.0);
    }

    #[test]
    fn a_clockwise_outline_is_reversed_with_its_arcs() {
        let square: Raw = vec![([0.0, 0.0], 0.0), ([0.0, 1.0], 0.0), ([1.0, 1.0], -0.4), ([1.0, 0.0], 0.0)];
        let v = with_arcs(&square).unwrap();
        assert!(signed_area(&v) < 0.0);
        let r = reversed(&v);
        assert!(signed_area(&r) > 0.0);
        // The same curve: every piece's points, reversed, are the original piece's.
        let n = r.len();
        let pieces = |v: &[DxfVertex]| {
            let mut s: Vec<[i64; 2]> = Vec::new();
            for i in 0..v.len() {
                let p = v[(i + v.len() - 1) % v.len()].at;
                let c = v[i].curve.unwrap_or([p, v[i].at]);
                for k in 1..8 {
                    let b = bezier(p, c, v[i].at, k as f64 / 8.0);
                    s.push([(b[0] * 1e9).round() as i64, (b[1] * 1e9).round() as i64]);
                }
            }
            s.sort_unstable();
            s
        };
        assert_eq!(n, v.len());
        assert_eq!(pieces(&v), pieces(&r));
    }

    #[test]
    fn a_split_keeps_the_outline_and_finds_its_points() {
        // The half disc: its arc split where the outline passes nearest (0.6, −0.8): the new vertex lies on
        // the circle there, and both halves stay on it.
        let raw: Raw = vec![([1.0, 0.0], 0.0), ([-1.0, 0.0], 1.0)];
        let mut v = with_arcs(&raw).unwrap();
        let (i, t, d) = nearest_on_outline(&v, [0.6, -0.8]).unwrap();
        assert!(v[i].curve.is_some() && d < 3e-4, "{i} {t} {d}");
        let k = split_piece(&mut v, i, t);
        assert!((v[k].at[0] - 0.6).abs() < 3e-4 && (v[k].at[1] + 0.8).abs() < 3e-4, "{:?}", v[k]);
        let n = v.len();
        for j in [k, (k + 1) % n] {
            for s in 0..=8 {
                let p = piece_point(&v, j, s as f64 / 8.0);
                assert!((p[0].hypot(p[1]) - 1.0).abs() < 3e-4, "piece {j} at {s}/8: {p:?}");
            }
        }
        // A straight piece: the foot of the perpendicular.
        let mut v = with_arcs(&vec![([0.0, 0.0], 0.0), ([2.0, 0.0], 0.0), ([2.0, 1.0], 0.0)]).unwrap();
        let (i, t, d) = nearest_on_outline(&v, [0.5, 0.1]).unwrap();
        assert!((i, (t - 0.25).abs() < 1e-12, (d - 0.1).abs() < 1e-12) == (1, true, true), "{i} {t} {d}");
        let k = split_piece(&mut v, i, t);
        assert_eq!((v.len(), v[k].at, v[k].curve), (4, [0.5, 0.0], None));
    }
}

/// The tests of `io::gltf` (`src/io/gltf.rs`).
mod gltf {
    use crate::scratch_dir;
    use flexsurf::io::gltf::*;
    use flexsurf::testing::test_mesh;

    /// The standard base64 alphabet (RFC 4648), the encoder's.
    const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

    fn base64_decode(s: &str) -> Vec<u8> {
        let val = |c: u8| B64.iter().position(|&b| b == c).unwrap() as u32;
        let bytes: Vec<u8> = s.bytes().collect();
        let mut out = Vec::new();
        for q in bytes.chunks(4) {
            let pad = q.iter().filter(|&&c| c == b'=').count();
            let n = q.iter().fold(0u32, |acc, &c| (acc << 6) | if c == b'=' { 0 } else { val(c) });
            out.extend_from_slice(&n.to_be_bytes()[1..4 - pad]);
        }
        out
    }

    #[test]
    fn base64_known_vectors() {
        for (raw, enc) in
            [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v"), ("foob", "Zm9vYg=="), ("foobar", "Zm9vYmFy")]
        {
            assert_eq!(base64_encode(raw.as_bytes()), enc);
            assert_eq!(base64_decode(enc), raw.as_bytes());
        }
        let all: Vec<u8> = (0..=255).collect();
        assert_eq!(base64_decode(&base64_encode(&all)), all);
    }

    #[test]
    fn round_trip() {
        let mesh = test_mesh();
        let d = scratch_dir("gltf");
        let p = d.join("m.gltf");
        write_gltf(&p, &mesh, [0.8, 0.2, 0.2, 1.0]).unwrap();
        let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        assert_eq!(doc["asset"]["version"], "2.0");
        let acc = doc["accessors"].as_array().unwrap();
        assert_eq!(acc[0]["count"], mesh.vertex_count());
        assert_eq!(acc[2]["count"], 3 * mesh.triangle_count());
        let bb = mesh.bbox().unwrap();
        assert_eq!(acc[0]["max"][2].as_f64().unwrap() as f32, bb.max.z as f32);
        assert_eq!(acc[0]["min"][0].as_f64().unwrap() as f32, bb.min.x as f32);
        let uri = doc["buffers"][0]["uri"].as_str().unwrap();
        let bin = base64_decode(uri.strip_prefix("data:application/octet-stream;base64,").unwrap());
        assert_eq!(bin.len() as u64, doc["buffers"][0]["byteLength"].as_u64().unwrap());
        let views = doc["bufferViews"].as_array().unwrap();
        let f = |at: usize| f32::from_le_bytes(bin[at..at + 4].try_into().unwrap());
        let u = |at: usize| u32::from_le_bytes(bin[at..at + 4].try_into().unwrap());
        let (pos, nrm, idx) = (0, views[1]["byteOffset"].as_u64().unwrap() as usize, views[2]["byteOffset"].as_u64());
        let idx = idx.unwrap() as usize;
        let k = 3;
        assert_eq!(f(pos + 12 * k + 4), mesh.positions[k].y as f32);
        assert_eq!(f(nrm + 12 * k + 8), mesh.normals[k].z as f32);
        let t = mesh.triangle_count() - 1;
        assert_eq!(u(idx + 12 * t + 8), mesh.triangles[t][2]);
        assert_eq!(idx + 12 * mesh.triangle_count(), bin.len());
        std::fs::remove_dir_all(&d).unwrap();
    }
}

/// The tests of `io::input` (`src/io/input.rs`).
mod input {
    use flexsurf::io::input::*;

    #[test]
    fn refuses_directories_large_files_and_bad_utf8_and_records_hashes() {
        let d = crate::scratch_dir("input");
        assert!(read_text(&d).unwrap_err().to_string().contains("directory"));
        let big = d.join("big.toml");
        std::fs::write(&big, vec![b'#'; 1000]).unwrap();
        let err = read_bytes_limited(&big, 999).unwrap_err().to_string();
        assert!(err.contains("1000 bytes"), "{err}");
        let bad = d.join("bad.toml");
        std::fs::write(&bad, b"a = 1\nb = \"\xff secret\"\n").unwrap();
        let err = read_text(&bad).unwrap_err().to_string();
        assert!(err.contains("byte 11") && err.contains("line 2, column 6"), "{err}");
        assert!(!err.contains("secret"));
        let good = d.join("good.toml");
        std::fs::write(&good, b"abc").unwrap();
        let (text, files) = recording(|| read_text(&good).unwrap());
        assert_eq!(text, "abc");
        assert_eq!(files.len(), 1);
        assert_eq!(files[0].sha256, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
        std::fs::remove_dir_all(&d).unwrap();
    }
}

/// The tests of `io::obj` (`src/io/obj.rs`).
mod obj {
    use crate::scratch_dir;
    use flexsurf::io::obj::*;
    use flexsurf::math::Vec3;
    use flexsurf::testing::test_mesh;
    use std::io;

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

/// The tests of `io::ply` (`src/io/ply.rs`).
mod ply {
    use crate::scratch_dir;
    use flexsurf::io::ply::*;
    use flexsurf::testing::test_mesh;

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

/// The tests of `io::vtk` (`src/io/vtk.rs`).
mod vtk {
    use crate::scratch_dir;
    use flexsurf::io::vtk::*;
    use vtkio::model::{Attribute, CellType, DataSet};
    use vtkio::Vtk;

    #[test]
    fn vtu_round_trips_through_vtkio_and_pvd_lists_the_times() {
        let d = scratch_dir("vtk");
        let points = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5], [1.0, 1.0, 0.25]];
        let tris = [[0, 1, 2], [1, 3, 2]];
        let strain = [0.0, 0.1, 0.2, 0.3];
        let vel = [[0.0, 0.0, -1.0]; 4];
        let data = [PointData::Scalar("strain", &strain), PointData::Vector("velocity", &vel)];
        let s = Surface { points: &points, triangles: &tris, point_data: &data, cell_ids: None };
        let p = d.join("f.vtu");
        write_vtu(&p, &s, "test").unwrap();
        let back = Vtk::import(&p).unwrap();
        let DataSet::UnstructuredGrid { pieces, .. } = back.data else { panic!("not an unstructured grid") };
        let piece = pieces.into_iter().next().unwrap().into_loaded_piece_data(None).unwrap();
        assert_eq!(piece.num_points(), 4);
        assert_eq!(piece.cells.types, vec![CellType::Triangle; 2]);
        let names: Vec<String> = piece
            .data
            .point
            .iter()
            .map(|a| match a {
                Attribute::DataArray(a) => a.name.clone(),
                Attribute::Field { name, .. } => name.clone(),
            })
            .collect();
        assert_eq!(names, ["strain", "velocity"]);
        if let Attribute::DataArray(a) = &piece.data.point[0] {
            assert_eq!(a.data.clone().into_vec::<f32>().unwrap(), strain.to_vec());
        }
        // Wrong sizes are errors, not panics.
        let bad = [PointData::Scalar("strain", &strain[..3])];
        assert!(write_vtu(&p, &Surface { point_data: &bad, ..s }, "x").is_err());
        assert!(write_vtu(&p, &Surface { triangles: &[[0, 1, 9]], ..s }, "x").is_err());

        let pvd = d.join("run.pvd");
        write_pvd(&pvd, &[(0.0, "vtk/a.vtu".into()), (1.5, "vtk/b.vtu".into())]).unwrap();
        let text = std::fs::read_to_string(&pvd).unwrap();
        assert!(text.contains("timestep=\"1.5e0\"") && text.contains("file=\"vtk/b.vtu\""), "{text}");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
