//! Animated glTF 2.0 binary (`.glb`) of a run: the cloth as one mesh whose frames are morph targets, played by
//! a time-sampled animation of the morph weights (linear between written frames, so Blender and three.js play
//! it at the simulated times), the obstacles as static meshes, and the cloth's UVs in the pattern's metres.
//!
//! Layout of the file:
//! - a root node `flexsurf` rotated −90° about x, so the simulation's z-up world stands upright in the y-up
//!   glTF convention (Blender's importer turns it back to z-up);
//! - node `cloth`: `POSITION`/`NORMAL` of the first frame, `TEXCOORD_0` (metres along warp and weft), `uint32`
//!   indices, one morph target (position and normal offsets) per later frame, and the animation channel on
//!   its `weights`; frame `k` has weight 1 on target `k − 1` and 0 elsewhere;
//! - one node per obstacle (`obstacle_0`, …), each a mesh with a material of its own;
//! - `extras.flexsurf` at the root: `frames` (`step`, `time`, and the accessors of that frame's per-vertex
//!   `strain` (1), `pressure` (Pa) and `velocity` (m/s), which are not mesh attributes), the field units and the
//!   cloth node index. The flexsurf viewer reads these; other tools ignore them.
//!
//! The JSON is built with `serde_json` (the document is a handful of objects; the tests parse it back with the
//! `gltf` crate, which validates it against the specification).

use super::atomic::write_atomic;
use super::invalid;
use crate::surface::mesh::TriMesh;
use serde_json::{json, Value};
use std::io;
use std::path::Path;

/// One frame of the cloth: positions, normals and fields of the display vertices.
#[derive(Debug, Clone, Copy)]
pub struct GlbFrame<'a> {
    /// Step.
    pub step: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Positions (m).
    pub positions: &'a [[f32; 3]],
    /// Unit normals.
    pub normals: &'a [[f32; 3]],
    /// Velocity (m/s).
    pub velocity: &'a [[f32; 3]],
    /// Engineering strain.
    pub strain: &'a [f32],
    /// Contact pressure (Pa).
    pub pressure: &'a [f32],
}

/// A static mesh with a name and an RGBA base colour (linear, 0–1).
#[derive(Debug, Clone)]
pub struct GlbMesh {
    /// Node and mesh name.
    pub name: String,
    /// The mesh (normals are used when it has one per vertex).
    pub mesh: TriMesh,
    /// Base colour.
    pub color: [f64; 4],
}

/// What an animated `.glb` holds.
#[derive(Debug, Clone, Copy)]
pub struct Animation<'a> {
    /// Triangles of the cloth (shared by every frame).
    pub triangles: &'a [[u32; 3]],
    /// UVs of the cloth in pattern metres.
    pub uv: &'a [[f32; 2]],
    /// The frames, in time order.
    pub frames: &'a [GlbFrame<'a>],
    /// Obstacles.
    pub obstacles: &'a [GlbMesh],
    /// Base colour of the cloth (RGBA, linear).
    pub cloth_color: [f64; 4],
    /// Anything else to store under `extras.flexsurf` (scene name, model…).
    pub info: &'a Value,
}

/// The binary chunk and the buffer views and accessors into it.
#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

impl Bin {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        let offset = self.data.len();
        self.data.extend_from_slice(bytes);
        while self.data.len() % 4 != 0 {
            self.data.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": offset, "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.views.push(v);
        self.views.len() - 1
    }

    /// Float accessor of `count` elements of `kind` (`SCALAR`, `VEC2`, `VEC3`) with `n` components each.
    fn floats(&mut self, values: &[f32], n: usize, kind: &str, bounds: bool, target: Option<u32>) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, target);
        let count = values.len() / n;
        let mut a = json!({ "bufferView": view, "componentType": FLOAT, "count": count, "type": kind });
        if bounds {
            let (mut lo, mut hi) = (vec![0.0_f32; n], vec![0.0_f32; n]);
            if count > 0 {
                lo = vec![f32::INFINITY; n];
                hi = vec![f32::NEG_INFINITY; n];
                for e in values.chunks_exact(n) {
                    for c in 0..n {
                        lo[c] = lo[c].min(e[c]);
                        hi[c] = hi[c].max(e[c]);
                    }
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn indices(&mut self, triangles: &[[u32; 3]]) -> usize {
        let bytes: Vec<u8> = triangles.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(
            json!({ "bufferView": view, "componentType": UNSIGNED_INT, "count": 3 * triangles.len(), "type": "SCALAR" }),
        );
        self.accessors.len() - 1
    }
}

fn flat3(v: &[[f32; 3]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

fn material(name: &str, color: [f64; 4]) -> Value {
    json!({
        "name": name,
        "doubleSided": true,
        "pbrMetallicRoughness": { "baseColorFactor": color, "metallicFactor": 0.0, "roughnessFactor": 0.9 }
    })
}

/// Checks that every frame has one value per UV vertex and every index is in range.
fn check(anim: &Animation<'_>) -> io::Result<()> {
    let n = anim.uv.len();
    if anim.frames.is_empty() {
        return Err(invalid("an animation needs at least one frame"));
    }
    for f in anim.frames {
        let lens = [f.positions.len(), f.normals.len(), f.velocity.len(), f.strain.len(), f.pressure.len()];
        if lens.iter().any(|&l| l != n) {
            return Err(invalid(format!("frame of step {}: field lengths {lens:?}, expected {n} vertices", f.step)));
        }
    }
    if anim.triangles.iter().flatten().any(|&v| v as usize >= n) {
        return Err(invalid(format!("a cloth triangle refers to a vertex beyond the {n} vertices")));
    }
    for o in anim.obstacles {
        o.mesh.validate().map_err(|e| invalid(format!("obstacle {}: {e}", o.name)))?;
    }
    Ok(())
}

/// The times of the animation: the frames' simulated times when they increase strictly (a static solve's two
/// frames share t = 0), else the frame index in seconds. The flag says which.
fn key_times(frames: &[GlbFrame<'_>]) -> (Vec<f32>, bool) {
    let t: Vec<f32> = frames.iter().map(|f| f.time as f32).collect();
    if t.windows(2).all(|w| w[1] > w[0]) {
        (t, true)
    } else {
        ((0..frames.len()).map(|k| k as f32).collect(), false)
    }
}

/// The cloth's mesh: the first frame's positions and normals, the UVs and indices, and one morph target (the
/// offsets from the first frame) per later frame. Returns the mesh and its number of targets.
fn cloth_mesh(bin: &mut Bin, anim: &Animation<'_>) -> (Value, usize) {
    let first = &anim.frames[0];
    let base_pos = flat3(first.positions);
    let base_nrm = flat3(first.normals);
    let pos = bin.floats(&base_pos, 3, "VEC3", true, Some(ARRAY_BUFFER));
    let nrm = bin.floats(&base_nrm, 3, "VEC3", false, Some(ARRAY_BUFFER));
    let uv: Vec<f32> = anim.uv.iter().flatten().copied().collect();
    let tex = bin.floats(&uv, 2, "VEC2", false, Some(ARRAY_BUFFER));
    let idx = bin.indices(anim.triangles);
    let mut targets = Vec::new();
    for f in &anim.frames[1..] {
        let dp: Vec<f32> = flat3(f.positions).iter().zip(&base_pos).map(|(a, b)| a - b).collect();
        let dn: Vec<f32> = flat3(f.normals).iter().zip(&base_nrm).map(|(a, b)| a - b).collect();
        let p = bin.floats(&dp, 3, "VEC3", true, Some(ARRAY_BUFFER));
        let n = bin.floats(&dn, 3, "VEC3", false, Some(ARRAY_BUFFER));
        targets.push(json!({ "POSITION": p, "NORMAL": n }));
    }
    let mut primitive = json!({
        "attributes": { "POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": tex },
        "indices": idx, "mode": 4, "material": 0
    });
    let mut mesh = json!({ "name": "cloth", "primitives": [] });
    let count = targets.len();
    if count > 0 {
        primitive["targets"] = json!(targets);
        mesh["weights"] = json!(vec![0.0; count]);
        mesh["extras"] = json!({ "targetNames": anim.frames[1..].iter()
            .map(|f| format!("step {}", f.step)).collect::<Vec<_>>() });
    }
    mesh["primitives"] = json!([primitive]);
    (mesh, count)
}

/// Each frame's step, time and the accessors of its fields (`extras.flexsurf.frames`).
fn frames_info(bin: &mut Bin, anim: &Animation<'_>) -> Vec<Value> {
    let mut info = Vec::new();
    for f in anim.frames {
        let strain = bin.floats(f.strain, 1, "SCALAR", true, None);
        let pressure = bin.floats(f.pressure, 1, "SCALAR", true, None);
        let velocity = bin.floats(&flat3(f.velocity), 3, "VEC3", false, None);
        info.push(json!({ "step": f.step, "time": f.time, "strain": strain, "pressure": pressure,
                          "velocity": velocity }));
    }
    info
}

/// The document's nodes, meshes and materials: the root, the cloth (`cloth`, mesh 0) and one node per
/// obstacle with a mesh and material of its own.
fn scene_graph(bin: &mut Bin, anim: &Animation<'_>, cloth: Value) -> (Vec<Value>, Vec<Value>, Vec<Value>) {
    let mut meshes = vec![cloth];
    let mut materials = vec![material("cloth", anim.cloth_color)];
    let mut nodes = vec![
        json!({ "name": "flexsurf", "rotation": [-std::f64::consts::FRAC_1_SQRT_2, 0.0, 0.0, std::f64::consts::FRAC_1_SQRT_2],
                "children": [] }),
        json!({ "name": "cloth", "mesh": 0 }),
    ];
    for o in anim.obstacles {
        let m = &o.mesh;
        let p: Vec<f32> = m.positions.iter().flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
        let normals = if m.has_normals() { m.normals.clone() } else { m.face_averaged_normals() };
        let n: Vec<f32> = normals
            .iter()
            .map(|n| n.try_normalize().unwrap_or(crate::math::Vec3::Z))
            .flat_map(|n| [n.x as f32, n.y as f32, n.z as f32])
            .collect();
        let (pa, na) =
            (bin.floats(&p, 3, "VEC3", true, Some(ARRAY_BUFFER)), bin.floats(&n, 3, "VEC3", false, Some(ARRAY_BUFFER)));
        let ia = bin.indices(&m.triangles);
        materials.push(material(&o.name, o.color));
        meshes.push(json!({ "name": o.name, "primitives": [ {
            "attributes": { "POSITION": pa, "NORMAL": na }, "indices": ia, "mode": 4, "material": materials.len() - 1
        } ] }));
        nodes.push(json!({ "name": o.name, "mesh": meshes.len() - 1 }));
    }
    nodes[0]["children"] = json!((1..nodes.len()).collect::<Vec<_>>());
    (nodes, meshes, materials)
}

/// The animation of the cloth's `targets` morph weights: frame `k` is target `k − 1` alone, sampled at the
/// frames' times ([`key_times`]); none without targets.
fn weights_animation(bin: &mut Bin, frames: &[GlbFrame<'_>], targets: usize) -> Option<Value> {
    if targets == 0 {
        return None;
    }
    let weights: Vec<f32> =
        (0..frames.len()).flat_map(|k| (0..targets).map(move |t| if t + 1 == k { 1.0 } else { 0.0 })).collect();
    let input = bin.floats(&key_times(frames).0, 1, "SCALAR", true, None);
    let output = bin.floats(&weights, 1, "SCALAR", false, None);
    Some(json!({
        "name": "simulation",
        "samplers": [ { "input": input, "output": output, "interpolation": "LINEAR" } ],
        "channels": [ { "sampler": 0, "target": { "node": 1, "path": "weights" } } ]
    }))
}

/// The binary container: header, the JSON chunk (padded with spaces) and the BIN chunk.
fn container(doc: &Value, bin: &[u8]) -> io::Result<Vec<u8>> {
    let mut text = serde_json::to_vec(doc).map_err(io::Error::other)?;
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let total =
        u32::try_from(total).map_err(|_| invalid(format!("a .glb is limited to 4 GiB; this one is {total} bytes")))?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    Ok(out)
}

/// The `.glb` bytes of `anim`.
pub fn glb_bytes(anim: &Animation<'_>) -> io::Result<Vec<u8>> {
    check(anim)?;
    let mut bin = Bin::default();
    let (cloth, targets) = cloth_mesh(&mut bin, anim);
    let frames = frames_info(&mut bin, anim);
    let (nodes, meshes, materials) = scene_graph(&mut bin, anim, cloth);
    let animation = weights_animation(&mut bin, anim.frames, targets);
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "flexsurf" },
        "scene": 0,
        "scenes": [ { "name": "run", "nodes": [0] } ],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "buffers": [ { "byteLength": bin.data.len() } ],
        "bufferViews": bin.views,
        "accessors": bin.accessors,
        "extras": { "flexsurf": {
            "cloth_node": 1,
            "up": "z",
            "animation_times_are_simulated": key_times(anim.frames).1,
            "units": { "position": "m", "uv": "m (pattern: warp, weft)", "strain": "1", "pressure": "Pa",
                       "velocity": "m/s" },
            "frames": frames,
            "info": anim.info,
        } }
    });
    if let Some(a) = animation {
        doc["animations"] = json!([a]);
    }
    container(&doc, &bin.data)
}

/// Writes `anim` as a `.glb` at `path`, atomically.
pub fn write_glb(path: impl AsRef<Path>, anim: &Animation<'_>) -> io::Result<()> {
    write_atomic(path, &glb_bytes(anim)?)
}
