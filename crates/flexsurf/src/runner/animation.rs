//! The standard animated outputs of a run, written beside the frames at the same cadence (`output_every`):
//!
//! - `vtk/frame_NNNNN.vtu` at every output step (display surface, point data `velocity`, `strain`,
//!   `contact_pressure`, `uv`), `vtk/obstacles.vtu` once, and `animation.pvd`, the ParaView time series,
//!   rewritten after every frame (so a run in progress opens too);
//! - `animation.glb` at the end: the animated glTF of [`crate::io::glb`] with the obstacles.
//!
//! The `.glb` needs every frame, so the frames' display fields are kept in memory (single precision: about
//! 52 bytes per display vertex and frame).

use super::fields::{display_topology, frame_fields, DisplayTopology, FrameFields};
use super::{io_err, RunError};
use crate::contact::Look;
use crate::io::glb::{self, Animation, GlbFrame, GlbMesh};
use crate::io::render::{checkered_square, uv_sphere};
use crate::io::vtk::{self, PointData, Surface};
use crate::math::Vec3;
use crate::model::Model;
use crate::scene::Scene;
use crate::state::State;
use crate::surface::{Aabb, TriMesh};
use std::path::{Path, PathBuf};

/// File names of the animated outputs, relative to the output directory.
pub const GLB_FILE: &str = "animation.glb";
/// The ParaView collection.
pub const PVD_FILE: &str = "animation.pvd";
/// The folder of the `.vtu` files.
pub const VTK_DIR: &str = "vtk";
/// The obstacles' `.vtu`, relative to the output directory.
pub const OBSTACLES_VTU: &str = "vtk/obstacles.vtu";

/// Base colour (linear RGBA) of the cloth in the `.glb`.
pub const GLB_CLOTH_COLOR: [f64; 4] = [0.55, 0.09, 0.05, 1.0];
/// Base colour (linear RGBA) of the obstacles in the `.glb`.
pub const GLB_OBSTACLE_COLOR: [f64; 4] = [0.30, 0.35, 0.43, 1.0];
/// Base colour (linear RGBA) of a ground plane in the `.glb`.
pub const GLB_PLANE_COLOR: [f64; 4] = [0.68, 0.68, 0.66, 1.0];

/// Triangle meshes standing for the model's obstacles, for files and viewers: a sphere as a fine UV sphere, a
/// plane as a square twice the size of `around` (the cloth's extent) centred under it, a mesh as itself.
/// Returns (name, mesh, is a plane).
pub fn obstacle_meshes(model: &Model, around: &Aabb) -> Vec<(String, TriMesh, bool)> {
    let half = (around.size().x.max(around.size().y).max(around.size().z) * 1.5).max(0.5);
    model
        .obstacles()
        .iter()
        .filter_map(|o| o.look())
        .enumerate()
        .map(|(k, look)| match look {
            Look::Sphere { center, radius } => {
                (format!("obstacle_{k}_sphere"), uv_sphere(center, radius, 32, 64), false)
            }
            Look::Plane { point, normal } => {
                let n = normal.try_normalize().unwrap_or(Vec3::Z);
                let c = around.center();
                let c = c - n * (c - point).dot(n);
                (format!("obstacle_{k}_plane"), checkered_square(c, n, half, 1).0, true)
            }
            Look::Mesh(mesh) => (format!("obstacle_{k}_mesh"), mesh, false),
        })
        .collect()
}

/// Records the display fields of the output steps and writes the VTK series as it goes.
pub(super) struct AnimationRecorder {
    out: PathBuf,
    k: usize,
    topology: DisplayTopology,
    frames: Vec<FrameFields>,
    pvd: Vec<(f64, String)>,
    obstacles: Vec<(String, TriMesh, bool)>,
}

impl AnimationRecorder {
    /// A recorder for `scene` writing into `out`; writes `vtk/obstacles.vtu` framed around `x0`.
    pub fn new(scene: &Scene, out: &Path, x0: &[Vec3]) -> Result<Self, RunError> {
        let model = &scene.model;
        let k = scene.output.coons_subdivisions.max(1);
        let dir = out.join(VTK_DIR);
        std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
        // An earlier run's animation would stand for this one until it finishes (the viewer reads the VTK
        // series of a run in progress instead).
        let glb = out.join(GLB_FILE);
        match std::fs::remove_file(&glb) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io_err(&glb)(e)),
            _ => {}
        }
        let around = Aabb::from_points(x0.iter().copied()).unwrap_or(Aabb { min: Vec3::ZERO, max: Vec3::ZERO });
        let obstacles = obstacle_meshes(model, &around);
        let rec = Self {
            out: out.to_path_buf(),
            k,

            topology: display_topology(&model.grid, k),
            frames: Vec::new(),
            pvd: Vec::new(),
            obstacles,
        };
        rec.write_obstacles_vtu()?;
        Ok(rec)
    }

    fn write_obstacles_vtu(&self) -> Result<(), RunError> {
        let mut all = TriMesh::new();
        let mut ids = Vec::new();
        for (k, (_, m, _)) in self.obstacles.iter().enumerate() {
            all.append(m);
            ids.extend(std::iter::repeat_n(k as u32, m.triangle_count()));
        }
        let points: Vec<[f32; 3]> = all.positions.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
        let s =
            Surface { points: &points, triangles: &all.triangles, point_data: &[], cell_ids: Some(("obstacle", &ids)) };
        let path = self.out.join(OBSTACLES_VTU);
        vtk::write_vtu(&path, &s, "flexsurf obstacles").map_err(io_err(&path))
    }

    /// Records the output step `state` with its display mesh `mesh`: its `.vtu` and the updated `.pvd`.
    pub fn record(&mut self, model: &Model, state: &State, mesh: &TriMesh) -> Result<(), RunError> {
        let f = frame_fields(model, state, mesh, self.k);
        let name = format!("{VTK_DIR}/frame_{:05}.vtu", state.step);
        let data = [
            PointData::Vector("velocity", &f.velocity),
            PointData::Scalar("strain", &f.strain),
            PointData::Scalar("contact_pressure", &f.pressure),
            PointData::Pair("uv", &self.topology.uv),
        ];
        let s =
            Surface { points: &f.positions, triangles: &self.topology.triangles, point_data: &data, cell_ids: None };
        let path = self.out.join(&name);
        vtk::write_vtu(&path, &s, &format!("flexsurf step {} t = {} s", state.step, state.time))
            .map_err(io_err(&path))?;
        self.pvd.push((state.time, name));
        let pvd = self.out.join(PVD_FILE);
        vtk::write_pvd(&pvd, &self.pvd).map_err(io_err(&pvd))?;
        self.frames.push(f);
        Ok(())
    }

    /// The frames recorded so far (for a checkpoint).
    pub fn frames(&self) -> &[FrameFields] {
        &self.frames
    }

    /// Continues a resumed run: the frames recorded before its checkpoint (their `.vtu` files are on disk).
    pub fn restore(&mut self, frames: Vec<FrameFields>) {
        self.pvd = frames.iter().map(|f| (f.time, format!("{VTK_DIR}/frame_{:05}.vtu", f.step))).collect();
        self.frames = frames;
    }

    /// Writes `animation.glb` of the recorded frames; `info` goes into its `extras`.
    pub fn finish(&self, info: &serde_json::Value) -> Result<(), RunError> {
        if self.frames.is_empty() {
            return Ok(());
        }
        let frames: Vec<GlbFrame<'_>> = self.frames.iter().map(FrameFields::glb).collect();
        let obstacles: Vec<GlbMesh> = self
            .obstacles
            .iter()
            .map(|(name, mesh, plane)| GlbMesh {
                name: name.clone(),
                mesh: mesh.clone(),
                color: if *plane { GLB_PLANE_COLOR } else { GLB_OBSTACLE_COLOR },
            })
            .collect();
        let anim = Animation {
            triangles: &self.topology.triangles,
            uv: &self.topology.uv,
            frames: &frames,
            obstacles: &obstacles,
            cloth_color: GLB_CLOTH_COLOR,
            info,
        };
        let path = self.out.join(GLB_FILE);
        glb::write_glb(&path, &anim).map_err(io_err(&path))
    }
}
