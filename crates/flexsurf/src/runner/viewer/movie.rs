//! A movie of a run folder, made from its `animation.glb`: the cloth and the obstacles shaded by the software
//! renderer from one camera, sampled at a fixed rate in simulated time (positions blended linearly between the
//! written frames, as the glTF animation plays), each picture titled with the scene, model and time, with a
//! floor, scale bar and axes. Written as an animated GIF (the `image` crate's GIF encoder), or as PNG pictures
//! for `ffmpeg` to turn into an MP4.

use super::ViewError;
use crate::io::render::{self, annotate, Drawable, Picture};
use crate::math::Vec3;
use crate::runner::outputs::glb::GLB_FILE;
use crate::runner::outputs::snapshots::{CLOTH_COLOR, OBSTACLE_COLOR, PLANE_COLOR};
use crate::surface::{Aabb, TriMesh};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A run read back from its `animation.glb`.
pub struct GlbRun {
    /// Scene name and model, for titles.
    pub title: String,
    /// The cloth at each written frame (with normals).
    pub frames: Vec<(f64, TriMesh)>,
    /// Obstacles: mesh and whether it is a ground plane.
    pub obstacles: Vec<(TriMesh, bool)>,
}

fn invalid(path: &Path, message: impl Into<String>) -> ViewError {
    ViewError::Invalid { path: path.to_path_buf(), message: message.into() }
}

/// A parsed `.glb`: its JSON document and its binary chunk.
struct GlbDoc<'a> {
    path: &'a Path,
    doc: Value,
    bin: &'a [u8],
}

impl<'a> GlbDoc<'a> {
    /// Splits the checked `.glb` `bytes` into the JSON document and the binary chunk.
    fn parse(path: &'a Path, bytes: &'a [u8]) -> Result<Self, ViewError> {
        let u32_at = |at: usize| -> Option<usize> {
            bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
        };
        let json_len = u32_at(12).ok_or_else(|| invalid(path, "truncated header"))?;
        let doc: Value = serde_json::from_slice(
            bytes.get(20..20usize.saturating_add(json_len)).ok_or_else(|| invalid(path, "truncated"))?,
        )
        .map_err(|e| invalid(path, format!("its JSON chunk: {e}")))?;
        let bin_len = u32_at(20 + json_len).ok_or_else(|| invalid(path, "no BIN chunk"))?;
        let bin_at = 28 + json_len;
        let bin =
            bytes.get(bin_at..bin_at.saturating_add(bin_len)).ok_or_else(|| invalid(path, "truncated BIN chunk"))?;
        Ok(Self { path, doc, bin })
    }

    /// The 4-byte words of an accessor (every accessor flexsurf writes is f32 or u32).
    fn words(&self, acc: &Value) -> Result<Vec<[u8; 4]>, ViewError> {
        let (doc, path) = (&self.doc, self.path);
        let i = acc.as_u64().ok_or_else(|| invalid(path, "an accessor index is not a number"))? as usize;
        let a = &doc["accessors"][i];
        let v = &doc["bufferViews"][a["bufferView"].as_u64().unwrap_or(u64::MAX) as usize];
        let components: u64 = match a["type"].as_str() {
            Some("SCALAR") => 1,
            Some("VEC2") => 2,
            Some("VEC3") => 3,
            _ => return Err(invalid(path, format!("accessor {i}: unsupported type"))),
        };
        let past = || invalid(path, format!("accessor {i} runs past the buffer"));
        let offset = |x: &Value| x["byteOffset"].as_u64().unwrap_or(0);
        let at = offset(v).checked_add(offset(a)).ok_or_else(past)?;
        let end = a["count"].as_u64().unwrap_or(0).checked_mul(4 * components).and_then(|b| b.checked_add(at));
        let range = usize::try_from(at).ok().zip(end.and_then(|e| usize::try_from(e).ok())).ok_or_else(past)?;
        let raw = self.bin.get(range.0..range.1).ok_or_else(past)?;
        Ok(raw.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect())
    }

    fn floats(&self, acc: &Value) -> Result<Vec<f32>, ViewError> {
        Ok(self.words(acc)?.into_iter().map(f32::from_le_bytes).collect())
    }

    fn indices(&self, acc: &Value) -> Result<Vec<[u32; 3]>, ViewError> {
        let w: Vec<u32> = self.words(acc)?.into_iter().map(u32::from_le_bytes).collect();
        Ok(w.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// The first primitive of the mesh of `node`.
    fn primitive(&self, node: &Value) -> &Value {
        &self.doc["meshes"][node["mesh"].as_u64().unwrap_or(u64::MAX) as usize]["primitives"][0]
    }

    /// The mesh of a primitive's positions, normals and indices.
    fn mesh(&self, prim: &Value) -> Result<TriMesh, ViewError> {
        Ok(TriMesh {
            positions: vec3s(self.floats(&prim["attributes"]["POSITION"])?),
            normals: vec3s(self.floats(&prim["attributes"]["NORMAL"])?),
            triangles: self.indices(&prim["indices"])?,
        })
    }
}

fn vec3s(v: Vec<f32>) -> Vec<Vec3> {
    v.chunks_exact(3).map(|c| Vec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]))).collect()
}

/// An error naming `what` where a position or normal of `mesh` is not finite: a frame is the base plus its
/// morph target summed in `f32`, which can overflow where both are finite ([`finite_floats`] checks the
/// file's own values).
fn finite(path: &Path, what: &str, mesh: &TriMesh) -> Result<(), ViewError> {
    let bad = |v: &[Vec3]| v.iter().position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()));
    if let Some(k) = bad(&mesh.positions) {
        return Err(invalid(path, format!("{what}: vertex {k}'s position is not finite (the file is damaged)")));
    }
    if let Some(k) = bad(&mesh.normals) {
        return Err(invalid(path, format!("{what}: vertex {k}'s normal is not finite (the file is damaged)")));
    }
    Ok(())
}

/// An error where any value of a float accessor (positions, normals, the colouring fields, texture
/// coordinates, the animation's times and weights) is not finite.
fn finite_floats(g: &GlbDoc<'_>) -> Result<(), ViewError> {
    const FLOAT: u64 = 5126;
    let accessors = g.doc["accessors"].as_array().map_or(0, Vec::len);
    for i in 0..accessors {
        if g.doc["accessors"][i]["componentType"].as_u64() != Some(FLOAT) {
            continue;
        }
        if let Some(k) = g.floats(&Value::from(i))?.iter().position(|x| !x.is_finite()) {
            return Err(invalid(g.path, format!("accessor {i}: value {k} is not finite (the file is damaged)")));
        }
    }
    Ok(())
}

/// The cloth at each frame: the base mesh plus that frame's morph target (added in single precision, as a
/// glTF viewer does), at the frame's time.
fn cloth_frames(g: &GlbDoc<'_>, cloth_node: usize) -> Result<Vec<(f64, TriMesh)>, ViewError> {
    let prim = g.primitive(&g.doc["nodes"][cloth_node]);
    let base = g.floats(&prim["attributes"]["POSITION"])?;
    let base_n = g.floats(&prim["attributes"]["NORMAL"])?;
    let triangles = g.indices(&prim["indices"])?;
    if triangles.iter().flatten().any(|&v| v as usize >= base.len() / 3) {
        return Err(invalid(g.path, "a cloth index is out of range"));
    }
    let frames = &g.doc["extras"]["flexsurf"]["frames"];
    let times: Vec<f64> =
        frames.as_array().map_or(vec![0.0], |f| f.iter().map(|x| x["time"].as_f64().unwrap_or(0.0)).collect());
    let targets = prim["targets"].as_array().cloned().unwrap_or_default();
    if targets.len() + 1 != times.len() {
        return Err(invalid(g.path, format!("{} frames but {} morph targets", times.len(), targets.len())));
    }
    let mut out = Vec::new();
    for (k, &t) in times.iter().enumerate() {
        let (mut p, mut n) = (base.clone(), base_n.clone());
        if k > 0 {
            let (dp, dn) = (g.floats(&targets[k - 1]["POSITION"])?, g.floats(&targets[k - 1]["NORMAL"])?);
            if dp.len() != p.len() || dn.len() != n.len() {
                return Err(invalid(g.path, format!("morph target {} has the wrong size", k - 1)));
            }
            p.iter_mut().zip(&dp).for_each(|(a, d)| *a += d);
            n.iter_mut().zip(&dn).for_each(|(a, d)| *a += d);
        }
        let mesh = TriMesh { positions: vec3s(p), normals: vec3s(n), triangles: triangles.clone() };
        finite(g.path, &format!("the cloth at frame {k}"), &mesh)?;
        out.push((t, mesh));
    }
    Ok(out)
}

/// The obstacles: every node with a mesh but the cloth's, and whether it is a ground plane.
fn obstacles(g: &GlbDoc<'_>, cloth_node: usize) -> Result<Vec<(TriMesh, bool)>, ViewError> {
    let mut out = Vec::new();
    for (i, node) in g.doc["nodes"].as_array().into_iter().flatten().enumerate() {
        if i == cloth_node || node.get("mesh").is_none() {
            continue;
        }
        let mesh = g.mesh(g.primitive(node))?;
        mesh.validate().map_err(|e| invalid(g.path, format!("obstacle node {i}: {e}")))?;
        finite(g.path, &format!("obstacle node {i}"), &mesh)?;
        out.push((mesh, node["name"].as_str().is_some_and(|s| s.ends_with("_plane"))));
    }
    Ok(out)
}

/// Reads the `animation.glb` that flexsurf wrote into `dir`.
pub fn read_glb_run(dir: &Path) -> Result<GlbRun, ViewError> {
    let path = dir.join(GLB_FILE);
    let bytes = match super::read_limited(&path, super::MAX_ANIMATION_BYTES) {
        Ok(b) => b,
        Err(ViewError::Io { cause, .. }) if cause.kind() == std::io::ErrorKind::NotFound => {
            return Err(ViewError::NoAnimation(path))
        }
        Err(e) => return Err(e),
    };
    glb_run_from(&path, &bytes)
}

/// Checks the `animation.glb` `bytes` read from `path` as the viewer's page needs it, without building its
/// frames: its structure, and every float value finite (flexsurf writes none that is not, so a file holding
/// one was damaged, and the page would draw it silently wrong).
pub fn check_glb_values(path: &Path, bytes: &[u8]) -> Result<(), ViewError> {
    super::check_glb(path, bytes)?;
    finite_floats(&GlbDoc::parse(path, bytes)?)
}

/// The run in the `animation.glb` `bytes` read from `path`, checked: its structure, its indices and that every
/// position and normal is finite.
pub fn glb_run_from(path: &Path, bytes: &[u8]) -> Result<GlbRun, ViewError> {
    super::check_glb(path, bytes)?;
    let g = GlbDoc::parse(path, bytes)?;
    let ext = &g.doc["extras"]["flexsurf"];
    let cloth_node = ext["cloth_node"].as_u64().ok_or_else(|| invalid(path, "no extras.flexsurf.cloth_node"))? as usize;
    finite_floats(&g)?;
    let frames = cloth_frames(&g, cloth_node)?;
    let obstacles = obstacles(&g, cloth_node)?;
    let info = &ext["info"];
    let model = match info["model"].as_str() {
        Some("tfs") => "TFS model",
        Some("terzopoulos") => "Terzopoulos model",
        _ => "flexsurf",
    };
    let title = format!("{}  ·  {model}", info["scene"].as_str().unwrap_or("run"));
    Ok(GlbRun { title, frames, obstacles })
}

/// The cloth at simulated time `t`: the written frames blended linearly, as the glTF animation plays.
fn cloth_at(run: &GlbRun, t: f64) -> TriMesh {
    let f = &run.frames;
    let k = f.iter().rposition(|(ft, _)| *ft <= t).unwrap_or(0);
    if k + 1 >= f.len() || f[k + 1].0 <= f[k].0 {
        return f[k].1.clone();
    }
    let s = (t - f[k].0) / (f[k + 1].0 - f[k].0);
    let (a, b) = (&f[k].1, &f[k + 1].1);
    let mut m = a.clone();
    for (p, q) in m.positions.iter_mut().zip(&b.positions) {
        *p = *p * (1.0 - s) + *q * s;
    }
    for (n, q) in m.normals.iter_mut().zip(&b.normals) {
        *n = (*n * (1.0 - s) + *q * s).try_normalize().unwrap_or(Vec3::Z);
    }
    m
}

/// The pictures of a movie of `run` at `fps` pictures per simulated second (at most `max` of them; a run whose
/// frames share one time gets one picture per frame), `w × h` pixels each, with their times.
pub fn movie_pictures(run: &GlbRun, fps: f64, max: usize, w: u32, h: u32) -> Vec<(f64, Picture)> {
    let (t0, t1) = (run.frames[0].0, run.frames[run.frames.len() - 1].0);
    let times: Vec<f64> = if t1 > t0 && fps > 0.0 {
        let n = (((t1 - t0) * fps).round() as usize).clamp(1, max.max(2) - 1);
        (0..=n).map(|k| t0 + (t1 - t0) * k as f64 / n as f64).collect()
    } else {
        run.frames.iter().map(|f| f.0).collect()
    };
    let meshes: Vec<TriMesh> = if t1 > t0 {
        times.iter().map(|&t| cloth_at(run, t)).collect()
    } else {
        run.frames.iter().map(|f| f.1.clone()).collect()
    };
    let mut drawables: Vec<Drawable<'_>> = Vec::new();
    let mut has_plane = false;
    for (m, plane) in &run.obstacles {
        has_plane |= *plane;
        drawables.push(Drawable::mesh(m, if *plane { PLANE_COLOR } else { OBSTACLE_COLOR }));
    }
    let bounded = run.obstacles.iter().filter(|o| !o.1).filter_map(|o| o.0.bbox()).reduce(Aabb::union);
    let all = meshes.iter().filter_map(TriMesh::bbox).chain(bounded).reduce(Aabb::union);
    let view = render::default_view_for(&all.unwrap_or(Aabb { min: Vec3::splat(-0.5), max: Vec3::splat(0.5) }));
    if let (false, Some(b)) = (has_plane, bounded) {
        let (c, z) = (b.center(), b.min.z - 1e-3 * b.radius().max(1e-6));
        drawables.push(Drawable::plane(Vec3::new(c.x, c.y, z), Vec3::Z, PLANE_COLOR));
    }
    times
        .iter()
        .zip(&meshes)
        .map(|(&t, mesh)| {
            let mut items = vec![Drawable::mesh(mesh, CLOTH_COLOR)];
            items.extend(drawables.iter().cloned());
            let mut img = render::render(&view, &items, w, h);
            annotate::scale_bar(&mut img, &view);
            annotate::axis_triad(&mut img, &view);
            (t, render::with_title(&img, &format!("{}  ·  t = {t:.2} s", run.title)))
        })
        .collect()
}

/// Writes `dir/animation.gif` of the run (looping; each picture shown for its share of simulated time, at
/// real speed) and returns its path.
pub fn write_gif(dir: &Path, fps: f64, size: (u32, u32)) -> Result<PathBuf, ViewError> {
    use image::codecs::gif::{GifEncoder, Repeat};
    use image::{Delay, Frame};
    let run = read_glb_run(dir)?;
    let pictures = movie_pictures(&run, fps, 600, size.0, size.1);
    let path = dir.join("animation.gif");
    let delay = |k: usize| -> u32 {
        let dt = pictures.get(k + 1).map_or(1.0, |n| n.0 - pictures[k].0);
        if dt > 0.0 {
            ((dt * 1000.0).round() as u32).max(20)
        } else {
            1000
        }
    };
    crate::io::atomic::write_atomic_with(&path, |w| {
        let mut enc = GifEncoder::new_with_speed(w, 10);
        enc.set_repeat(Repeat::Infinite).map_err(std::io::Error::other)?;
        for (k, (_, img)) in pictures.iter().enumerate() {
            let rgba = image::DynamicImage::ImageRgb8(img.clone()).into_rgba8();
            let frame = Frame::from_parts(rgba, 0, 0, Delay::from_numer_denom_ms(delay(k), 1));
            enc.encode_frame(frame).map_err(std::io::Error::other)?;
        }
        Ok(())
    })
    .map_err(|cause| ViewError::Io { path: path.clone(), cause })?;
    Ok(path)
}

/// Writes the movie's pictures as `frame_NNNNN.png` into `folder` (created), for `ffmpeg`.
pub fn write_pictures(dir: &Path, folder: &Path, fps: f64, size: (u32, u32)) -> Result<usize, ViewError> {
    let run = read_glb_run(dir)?;
    std::fs::create_dir_all(folder).map_err(|cause| ViewError::Io { path: folder.to_path_buf(), cause })?;
    let pictures = movie_pictures(&run, fps, 3000, size.0, size.1);
    for (k, (_, img)) in pictures.iter().enumerate() {
        let p = folder.join(format!("frame_{k:05}.png"));
        render::save_png(&p, img).map_err(|cause| ViewError::Io { path: p.clone(), cause })?;
    }
    Ok(pictures.len())
}
