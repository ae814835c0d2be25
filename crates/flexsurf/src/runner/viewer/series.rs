//! A run in progress has no `animation.glb` yet, but its VTK series grows frame by frame: `animation.pvd`
//! (rewritten after each frame), `vtk/frame_NNNNN.vtu` and `vtk/obstacles.vtu`. This module reads those back
//! (through `vtkio`) and builds the same `.glb` bytes the run would write at its end, so the viewer shows the
//! frames written so far.

use super::ViewError;
use crate::io::glb::{self, Animation, GlbFrame, GlbMesh};
use crate::math::Vec3;
use crate::runner::fields::FrameFields;
use crate::runner::outputs::glb::{GLB_CLOTH_COLOR, GLB_OBSTACLE_COLOR, GLB_PLANE_COLOR};
use crate::runner::outputs::vtk::{OBSTACLES_VTU, PVD_FILE};
use crate::surface::TriMesh;
use std::path::Path;
use vtkio::model::{Attribute, DataSet, IOBuffer, UnstructuredGridPiece, VertexNumbers};

fn invalid(path: &Path, message: impl Into<String>) -> ViewError {
    ViewError::Invalid { path: path.to_path_buf(), message: message.into() }
}

/// `(time, file)` of each `DataSet` of a `.pvd` collection.
fn pvd_entries(path: &Path, text: &str) -> Result<Vec<(f64, String)>, ViewError> {
    let attr = |tag: &str, name: &str| -> Option<String> {
        let key = format!("{name}=\"");
        let at = tag.find(&key)? + key.len();
        Some(tag[at..].split('"').next()?.to_string())
    };
    let mut out = Vec::new();
    for tag in text.split("<DataSet").skip(1) {
        let t = attr(tag, "timestep").and_then(|t| t.parse::<f64>().ok());
        let f = attr(tag, "file");
        match (t, f) {
            (Some(t), Some(f)) => out.push((t, f)),
            _ => return Err(invalid(path, "a DataSet without a numeric timestep and a file")),
        }
    }
    if out.is_empty() {
        return Err(invalid(path, "lists no frames yet"));
    }
    Ok(out)
}

/// The first piece of an unstructured grid file.
fn piece(path: &Path) -> Result<UnstructuredGridPiece, ViewError> {
    super::check_regular(path, super::MAX_ANIMATION_BYTES)?;
    let vtk = vtkio::Vtk::import(path).map_err(|e| invalid(path, format!("not a readable .vtu: {e}")))?;
    let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        return Err(invalid(path, "not an unstructured grid"));
    };
    let first = pieces.into_iter().next().ok_or_else(|| invalid(path, "no piece"))?;
    first.into_loaded_piece_data(None).map_err(|e| invalid(path, format!("{e}")))
}

fn f32s(path: &Path, b: &IOBuffer, what: &str) -> Result<Vec<f32>, ViewError> {
    b.clone().into_vec::<f32>().ok_or_else(|| invalid(path, format!("{what} is not single precision")))
}

fn triangles(path: &Path, p: &UnstructuredGridPiece) -> Result<Vec<[u32; 3]>, ViewError> {
    let VertexNumbers::XML { connectivity, offsets } = &p.cells.cell_verts else {
        return Err(invalid(path, "cells are not in the XML layout"));
    };
    if offsets.iter().enumerate().any(|(k, &o)| o != 3 * (k as u64 + 1)) || connectivity.len() != 3 * offsets.len() {
        return Err(invalid(path, "cells are not all triangles"));
    }
    let n = p.num_points() as u64;
    if connectivity.iter().any(|&v| v >= n) {
        return Err(invalid(path, "a cell refers to a point beyond the points"));
    }
    Ok(connectivity.chunks_exact(3).map(|c| [c[0] as u32, c[1] as u32, c[2] as u32]).collect())
}

fn array<'a>(p: &'a UnstructuredGridPiece, name: &str) -> Option<&'a IOBuffer> {
    p.data.point.iter().chain(&p.data.cell).find_map(|a| match a {
        Attribute::DataArray(a) if a.name == name => Some(&a.data),
        _ => None,
    })
}

fn triples(v: &[f32]) -> Vec<[f32; 3]> {
    v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// The `.glb` bytes of the frames the VTK series of `dir` holds so far, and how many frames that is.
pub fn glb_from_series(dir: &Path, info: &serde_json::Value) -> Result<(Vec<u8>, usize), ViewError> {
    let pvd = dir.join(PVD_FILE);
    let bytes = super::read_limited(&pvd, crate::io::input::MAX_INPUT_BYTES)?;
    let text = String::from_utf8_lossy(&bytes);
    let entries = pvd_entries(&pvd, &text)?;
    let mut frames = Vec::new();
    let (mut tris, mut uv) = (Vec::new(), Vec::new());
    for (k, (time, file)) in entries.iter().enumerate() {
        let path = dir.join(file);
        if !Path::new(file).components().all(|c| matches!(c, std::path::Component::Normal(_))) {
            return Err(invalid(&pvd, format!("lists {file}, which is not a file inside the run folder")));
        }
        let p = piece(&path)?;
        let n = p.num_points();
        let positions = triples(&f32s(&path, &p.points, "points")?);
        let field = |name: &str, comps: usize| -> Result<Vec<f32>, ViewError> {
            let v =
                f32s(&path, array(&p, name).ok_or_else(|| invalid(&path, format!("no point data {name:?}")))?, name)?;
            if v.len() != comps * n {
                return Err(invalid(&path, format!("point data {name:?} has {} values for {n} points", v.len())));
            }
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(invalid(
                    &path,
                    format!("point data {name:?}: value {i} is not finite (the file is damaged)"),
                ));
            }
            Ok(v)
        };
        if let Some(i) = positions.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
            return Err(invalid(&path, format!("point {i} is not finite (the file is damaged)")));
        }
        let t = triangles(&path, &p)?;
        if k == 0 {
            let w = field("uv", 2)?;
            uv = w.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
            tris = t;
        } else if t != tris || n != uv.len() {
            return Err(invalid(&path, "its triangles differ from the first frame's"));
        }
        let mesh = TriMesh {
            positions: positions.iter().map(|p| Vec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))).collect(),
            normals: Vec::new(),
            triangles: tris.clone(),
        };
        let normals = mesh.face_averaged_normals().iter().map(|n| [n.x as f32, n.y as f32, n.z as f32]).collect();
        let step = file.rsplit('_').next().and_then(|s| s.trim_end_matches(".vtu").parse().ok()).unwrap_or(k);
        frames.push(FrameFields {
            step,
            time: *time,
            positions,
            normals,
            velocity: triples(&field("velocity", 3)?),
            strain: field("strain", 1)?,
            pressure: field("contact_pressure", 1)?,
        });
    }
    let obstacles = read_obstacles(&dir.join(OBSTACLES_VTU))?;
    let glb_frames: Vec<GlbFrame<'_>> = frames.iter().map(FrameFields::glb).collect();
    let anim = Animation {
        triangles: &tris,
        uv: &uv,
        frames: &glb_frames,
        obstacles: &obstacles,
        cloth_color: GLB_CLOTH_COLOR,
        info,
    };
    let bytes =
        glb::glb_bytes(&anim).map_err(|e| invalid(&pvd, format!("the series does not make an animation: {e}")))?;
    Ok((bytes, frames.len()))
}

/// The obstacles of `vtk/obstacles.vtu`, split by their `obstacle` cell data; a part of two triangles is the
/// square standing for a ground plane.
fn read_obstacles(path: &Path) -> Result<Vec<GlbMesh>, ViewError> {
    if !path.exists() {
        return Ok(Vec::new());
    }
    let p = piece(path)?;
    let points = triples(&f32s(path, &p.points, "points")?);
    let tris = triangles(path, &p)?;
    let ids: Vec<u32> = match array(&p, "obstacle") {
        Some(b) => b.clone().into_vec::<u32>().ok_or_else(|| invalid(path, "cell data \"obstacle\" is not UInt32"))?,
        None => vec![0; tris.len()],
    };
    if ids.len() != tris.len() {
        return Err(invalid(path, "cell data \"obstacle\" does not match the cells"));
    }
    let mut out = Vec::new();
    for id in 0..=ids.iter().copied().max().unwrap_or(0) {
        let mut mesh = TriMesh::new();
        let mut map = std::collections::HashMap::new();
        for (t, _) in tris.iter().zip(&ids).filter(|(_, &i)| i == id) {
            let mut tri = [0u32; 3];
            for (c, &v) in t.iter().enumerate() {
                tri[c] = *map.entry(v).or_insert_with(|| {
                    let q = points[v as usize];
                    mesh.positions.push(Vec3::new(f64::from(q[0]), f64::from(q[1]), f64::from(q[2])));
                    (mesh.positions.len() - 1) as u32
                });
            }
            mesh.triangles.push(tri);
        }
        if mesh.triangles.is_empty() {
            continue;
        }
        mesh.recompute_normals();
        let plane = mesh.triangle_count() == 2;
        out.push(GlbMesh {
            name: format!("obstacle_{id}_{}", if plane { "plane" } else { "mesh" }),
            mesh,
            color: if plane { GLB_PLANE_COLOR } else { GLB_OBSTACLE_COLOR },
        });
    }
    Ok(out)
}
