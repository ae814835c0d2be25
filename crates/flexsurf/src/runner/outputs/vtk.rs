//! The ParaView series of a run, written as it goes: `vtk/frame_NNNNN.vtu` at every animation step (the display
//! surface of every panel, merged, with point data `velocity`, `strain`, `contact_pressure` and `uv`),
//! `vtk/obstacles.vtu` once at the start, and `animation.pvd`, the time series, rewritten after every frame (so
//! a run in progress opens too, and the viewer shows it).

use super::{Context, Frame, Output, OutputState};
use crate::io::vtk::{self, PointData, Surface};
use crate::math::Vec3;
use crate::runner::fields::{display_topology, obstacle_meshes, DisplayTopology};
use crate::runner::{io_err, RunError};
use crate::scene::Scene;
use crate::surface::{Aabb, TriMesh};
use std::path::PathBuf;

/// The ParaView collection, relative to the output folder.
pub const PVD_FILE: &str = "animation.pvd";
/// The folder of the `.vtu` files.
pub const VTK_DIR: &str = "vtk";
/// The obstacles' `.vtu`, relative to the output folder.
pub const OBSTACLES_VTU: &str = "vtk/obstacles.vtu";

/// The `.vtu` of the animation step `step`, relative to the output folder.
pub fn vtu_file(step: usize) -> String {
    format!("{VTK_DIR}/frame_{step:05}.vtu")
}

/// The obstacles of `scene` as meshes, framed around its initial shape (the same at every start).
pub(super) fn scene_obstacles(scene: &Scene) -> Vec<(String, TriMesh, bool)> {
    let around = Aabb::from_points(scene.state.x.iter().copied()).unwrap_or(Aabb { min: Vec3::ZERO, max: Vec3::ZERO });
    obstacle_meshes(&scene.model, &around)
}

/// The VTK series output.
pub struct VtkSeries<'a> {
    scene: &'a Scene,
    out: PathBuf,
    /// The animation steps: one `.vtu` each.
    steps: Vec<usize>,
    topology: DisplayTopology,
    /// The series so far: (time, file).
    pvd: Vec<(f64, String)>,
}

impl<'a> VtkSeries<'a> {
    /// The series of the run `cx`.
    pub fn new(cx: &Context<'a>) -> Self {
        let topology = display_topology(&cx.scene.model.panels, cx.scene.output.coons_subdivisions.max(1));
        Self { scene: cx.scene, out: cx.out.clone(), steps: cx.animation.clone(), topology, pvd: Vec::new() }
    }

    fn write_obstacles(&self) -> Result<(), RunError> {
        let mut all = TriMesh::new();
        let mut ids = Vec::new();
        for (k, (_, m, _)) in scene_obstacles(self.scene).iter().enumerate() {
            all.append(m);
            ids.extend(std::iter::repeat_n(k as u32, m.triangle_count()));
        }
        let points: Vec<[f32; 3]> = all.positions.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
        let s =
            Surface { points: &points, triangles: &all.triangles, point_data: &[], cell_ids: Some(("obstacle", &ids)) };
        let path = self.out.join(OBSTACLES_VTU);
        vtk::write_vtu(&path, &s, "flexsurf obstacles").map_err(io_err(&path))
    }
}

impl Output for VtkSeries<'_> {
    fn name(&self) -> &'static str {
        "vtk"
    }

    fn files(&self) -> Vec<String> {
        let frames = self.steps.iter().map(|&s| vtu_file(s));
        frames.chain([PVD_FILE, OBSTACLES_VTU].map(String::from)).collect()
    }

    fn start(&mut self, saved: Option<&OutputState>) -> Result<(), RunError> {
        let dir = self.out.join(VTK_DIR);
        std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
        self.pvd = OutputState::or_default(saved, self.name())?;
        self.write_obstacles()
    }

    fn record(&mut self, frame: &Frame<'_>) -> Result<(), RunError> {
        let (Some(f), st) = (frame.fields(), frame.state) else { return Ok(()) };
        let name = vtu_file(st.step);
        let data = [
            PointData::Vector("velocity", &f.velocity),
            PointData::Scalar("strain", &f.strain),
            PointData::Scalar("contact_pressure", &f.pressure),
            PointData::Pair("uv", &self.topology.uv),
        ];
        let s =
            Surface { points: &f.positions, triangles: &self.topology.triangles, point_data: &data, cell_ids: None };
        let path = self.out.join(&name);
        vtk::write_vtu(&path, &s, &format!("flexsurf step {} t = {} s", st.step, st.time)).map_err(io_err(&path))?;
        self.pvd.push((st.time, name));
        let pvd = self.out.join(PVD_FILE);
        vtk::write_pvd(&pvd, &self.pvd).map_err(io_err(&pvd))
    }

    fn save(&self) -> Result<OutputState, RunError> {
        OutputState::of(&self.pvd)
    }
}
