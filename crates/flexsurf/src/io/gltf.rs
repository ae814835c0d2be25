//! Minimal glTF 2.0 output of a [`TriMesh`]: one `.gltf` JSON file with the binary buffer embedded as a base64
//! data URI, one mesh with one triangle primitive (`POSITION` with `min`/`max`, `NORMAL`, `uint32` indices) and
//! a double-sided material, so the file opens in any glTF viewer without side files.

use super::atomic::write_atomic;
use super::{invalid, MeshWriter};
use crate::math::Vec3;
use crate::surface::mesh::TriMesh;
use serde_json::json;
use std::io;
use std::path::Path;

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 (RFC 4648, with `=` padding).
pub fn base64_encode(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], chunk.get(1).copied().unwrap_or(0), chunk.get(2).copied().unwrap_or(0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(B64[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The glTF JSON document for `mesh`, with an RGBA base colour (linear, 0–1).
pub fn gltf_json(mesh: &TriMesh, base_color: [f64; 4]) -> io::Result<serde_json::Value> {
    mesh.validate().map_err(invalid)?;
    let nv = mesh.vertex_count();
    let normals: Vec<Vec3> = if mesh.has_normals() {
        mesh.normals.iter().map(|n| n.try_normalize().unwrap_or(Vec3::Z)).collect()
    } else {
        mesh.face_averaged_normals()
    };
    let f32s = |v: Vec3| [v.x as f32, v.y as f32, v.z as f32];
    let mut buf: Vec<u8> = Vec::with_capacity(24 * nv + 12 * mesh.triangle_count());
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for &p in &mesh.positions {
        let p = f32s(p);
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
            buf.extend_from_slice(&p[c].to_le_bytes());
        }
    }
    if nv == 0 {
        (lo, hi) = ([0.0; 3], [0.0; 3]);
    }
    for &n in &normals {
        f32s(n).iter().for_each(|c| buf.extend_from_slice(&c.to_le_bytes()));
    }
    for t in &mesh.triangles {
        t.iter().for_each(|v| buf.extend_from_slice(&v.to_le_bytes()));
    }
    let (pos_len, idx_len) = (12 * nv, 12 * mesh.triangle_count());
    let uri = format!("data:application/octet-stream;base64,{}", base64_encode(&buf));
    let mut primitive = json!({
        "attributes": { "POSITION": 0, "NORMAL": 1 },
        "mode": 4,
        "material": 0
    });
    let mut buffer_views = vec![
        json!({ "buffer": 0, "byteOffset": 0, "byteLength": pos_len, "target": 34962 }),
        json!({ "buffer": 0, "byteOffset": pos_len, "byteLength": pos_len, "target": 34962 }),
    ];
    let mut accessors = vec![
        json!({ "bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
                "min": lo, "max": hi }),
        json!({ "bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3" }),
    ];
    if idx_len > 0 {
        buffer_views.push(json!({ "buffer": 0, "byteOffset": 2 * pos_len, "byteLength": idx_len, "target": 34963 }));
        accessors.push(json!({ "bufferView": 2, "componentType": 5125, "count": 3 * mesh.triangle_count(),
                               "type": "SCALAR" }));
        primitive["indices"] = json!(2);
    }
    Ok(json!({
        "asset": { "version": "2.0", "generator": "flexsurf" },
        "scene": 0,
        "scenes": [ { "nodes": [0] } ],
        "nodes": [ { "mesh": 0, "name": "surface" } ],
        "meshes": [ { "name": "surface", "primitives": [primitive] } ],
        "materials": [ {
            "name": "cloth",
            "doubleSided": true,
            "pbrMetallicRoughness": { "baseColorFactor": base_color, "metallicFactor": 0.0, "roughnessFactor": 0.9 }
        } ],
        "buffers": [ { "byteLength": buf.len(), "uri": uri } ],
        "bufferViews": buffer_views,
        "accessors": accessors
    }))
}

/// Base colour factor (RGBA) of the cloth material in glTF frames.
pub const FRAME_COLOR: [f64; 4] = [0.77, 0.34, 0.24, 1.0];

/// glTF frames: `.gltf`, [`write_gltf`] with [`FRAME_COLOR`].
pub const WRITER: MeshWriter =
    MeshWriter { extension: "gltf", write: |path, mesh| write_gltf(path, mesh, FRAME_COLOR) };

/// Writes `mesh` as a self-contained `.gltf` file at `path`, atomically.
pub fn write_gltf(path: impl AsRef<Path>, mesh: &TriMesh, base_color: [f64; 4]) -> io::Result<()> {
    let doc = gltf_json(mesh, base_color)?;
    let text = serde_json::to_string(&doc).map_err(io::Error::other)?;
    write_atomic(path, text.as_bytes())
}
