//! The files of a run besides `summary.json`: a Coons-tessellated frame at every output step (OBJ, PLY or
//! glTF), one `energy.csv` row per step, and `snapshots.png`, a panel of shaded pictures of up to
//! [`MAX_SNAPSHOTS`] output steps with the obstacles, all from one camera.

use super::{io_err, RunError};
use crate::contact::Look;
use crate::io::render::{self, Drawable, View};
use crate::math::Vec3;
use crate::model::Model;
use crate::scene::{FrameFormat, Scene};
use crate::sim;
use crate::state::State;
use crate::surface::{Aabb, CoonsSurface, TriMesh};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Most pictures in `snapshots.png`; with more output steps an evenly spread subset is drawn.
pub const MAX_SNAPSHOTS: usize = 8;
/// Cloth colour in pictures (sRGB).
pub const CLOTH_COLOR: [u8; 3] = [196, 86, 62];
/// Obstacle colour in pictures (sRGB).
pub const OBSTACLE_COLOR: [u8; 3] = [150, 160, 175];
/// Ground plane colour in pictures (sRGB).
pub const PLANE_COLOR: [u8; 3] = [215, 215, 215];

/// One written frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrameRecord {
    /// Step.
    pub step: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Path relative to the output directory.
    pub file: String,
}

/// The Coons mesh of one output step, kept for pictures.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// Step.
    pub step: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Coons-tessellated mesh with normals.
    pub mesh: TriMesh,
}

/// The output steps of a run: 0, every `every` steps, and the last step.
pub fn output_steps(steps: usize, every: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..=steps).step_by(every.max(1)).collect();
    if v.last() != Some(&steps) {
        v.push(steps);
    }
    v
}

/// At most `max` entries of `all`, evenly spread, first and last included.
pub(super) fn spread(all: &[usize], max: usize) -> Vec<usize> {
    if all.len() <= max || max < 2 {
        return all.to_vec();
    }
    let mut v: Vec<usize> = (0..max).map(|i| all[i * (all.len() - 1) / (max - 1)]).collect();
    v.dedup();
    v
}

/// What a run records as it goes: the energy rows, the frames written and the meshes kept for pictures.
pub(super) struct Recorder<'a> {
    scene: &'a Scene,
    frames_dir: PathBuf,
    /// Steps that write a frame (sorted).
    outputs: Vec<usize>,
    /// Steps pictured in `snapshots.png`.
    pictured: Vec<usize>,
    /// `energy.csv` so far.
    pub csv: String,
    /// Frames written.
    pub frames: Vec<FrameRecord>,
    /// Meshes of the pictured steps.
    pub snapshots: Vec<Snapshot>,
    /// The VTK series and the frames of `animation.glb` (see [`super::animation`]).
    pub anim: Option<super::animation::AnimationRecorder>,
}

impl<'a> Recorder<'a> {
    /// A recorder writing frames of `scene` into `frames_dir` at the steps `outputs`.
    pub fn new(scene: &'a Scene, frames_dir: PathBuf, outputs: Vec<usize>) -> Self {
        // As many pictures as fill whole rows of the panel (see `render::grid_layout`), evenly spread.
        let pictured = spread(&outputs, render::grid_layout(outputs.len()).0.min(MAX_SNAPSHOTS));
        let csv = String::from("step,time,kinetic,membrane,bending,potential\n");
        Self { scene, frames_dir, outputs, pictured, csv, frames: Vec::new(), snapshots: Vec::new(), anim: None }
    }

    /// Records `state`: its energy row, and its frame (and picture mesh) at an output step.
    pub fn record(&mut self, state: &State) -> Result<(), RunError> {
        let (scene, model) = (self.scene, &self.scene.model);
        // Only the energies: penetration and strain of every step are not written, so not computed here.
        csv_row(&mut self.csv, &sim::energies(model, state));
        if self.outputs.binary_search(&state.step).is_ok() {
            let mesh = CoonsSurface::new(&model.grid, &state.x).tessellate(scene.output.coons_subdivisions);
            let name = format!("frame_{:05}.{}", state.step, scene.output.format.extension());
            let path = self.frames_dir.join(&name);
            write_mesh(&path, &mesh, scene.output.format).map_err(io_err(&path))?;
            if let Some(anim) = &mut self.anim {
                anim.record(model, state, &mesh)?;
            }
            self.frames.push(FrameRecord { step: state.step, time: state.time, file: format!("frames/{name}") });
            if self.pictured.contains(&state.step) {
                self.snapshots.push(Snapshot { step: state.step, time: state.time, mesh });
            }
        }
        Ok(())
    }
}

fn csv_row(csv: &mut String, d: &sim::EnergyRecord) {
    use std::fmt::Write as _;
    let _ = writeln!(
        csv,
        "{},{},{:.9e},{:.9e},{:.9e},{:.9e}",
        d.step, d.time, d.kinetic, d.energies.membrane, d.energies.bending, d.potential
    );
}

/// Writes `mesh` in `format` (atomically; see [`FrameFormat::writer`]).
pub fn write_mesh(path: &Path, mesh: &TriMesh, format: FrameFormat) -> std::io::Result<()> {
    (format.writer().write)(path, mesh)
}

/// Writes `snapshots.png` into `out`: the pictures of `snapshots`, `image_size` pixels each, with a scale bar
/// and axes, in whole rows ([`render::grid_layout`]), under the title `title`.
pub(super) fn write_snapshots(
    out: &Path,
    model: &Model,
    snapshots: &[Snapshot],
    image_size: [u32; 2],
    title: &str,
) -> Result<(), RunError> {
    let view = view_for(model, snapshots.iter().map(|s| &s.mesh));
    let [w, h] = image_size;
    let images: Vec<_> = snapshots
        .iter()
        .map(|s| {
            let mut img = render_frame(model, &s.mesh, &view, w, h);
            render::annotate::scale_bar(&mut img, &view);
            render::annotate::axis_triad(&mut img, &view);
            img
        })
        .collect();
    let labels: Vec<String> = snapshots.iter().map(|s| format!("step {}   t = {:.2} s", s.step, s.time)).collect();
    let png = out.join("snapshots.png");
    let columns = render::grid_layout(images.len()).1;
    let panel = render::with_title(&render::panel(&images, &labels, columns), title);
    render::save_png(&png, &panel).map_err(io_err(&png))
}

/// Drawables of a model's obstacles (those with a [`Look`]).
pub fn obstacle_drawables(model: &Model) -> Vec<Drawable<'static>> {
    model
        .obstacles()
        .iter()
        .filter_map(|o| o.look())
        .map(|look| match look {
            Look::Sphere { center, radius } => Drawable::sphere(center, radius, OBSTACLE_COLOR),
            Look::Plane { point, normal } => Drawable::plane(point, normal, PLANE_COLOR),
            Look::Mesh(mesh) => Drawable::owned_mesh(mesh, OBSTACLE_COLOR),
        })
        .collect()
}

/// One camera that frames all `meshes` and the model's bounded obstacles.
pub fn view_for<'a>(model: &Model, meshes: impl Iterator<Item = &'a TriMesh>) -> View {
    let obstacles = obstacle_drawables(model);
    let bbox = meshes.filter_map(TriMesh::bbox).chain(obstacles.iter().filter_map(Drawable::bbox)).reduce(Aabb::union);
    render::default_view_for(&bbox.unwrap_or(Aabb { min: Vec3::splat(-0.5), max: Vec3::splat(0.5) }))
}

/// A shaded picture of `mesh` with the model's obstacles, standing on a floor: a scene without a ground plane
/// gets one (for the picture only) under its lowest bounded obstacle, so the shadows show where things are.
pub fn render_frame(model: &Model, mesh: &TriMesh, view: &View, width: u32, height: u32) -> image::RgbImage {
    let mut drawables = vec![Drawable::mesh(mesh, CLOTH_COLOR)];
    let obstacles = obstacle_drawables(model);
    let has_plane = obstacles.iter().any(|d| matches!(d, Drawable::Plane { .. }));
    if !has_plane {
        let bounded = obstacles.iter().filter_map(Drawable::bbox).reduce(Aabb::union);
        if let Some(b) = bounded {
            let (c, z) = (b.center(), b.min.z - 1e-3 * b.radius().max(1e-6));
            drawables.push(Drawable::plane(Vec3::new(c.x, c.y, z), Vec3::Z, PLANE_COLOR));
        }
    }
    drawables.extend(obstacles);
    render::render(view, &drawables, width, height)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_steps_and_their_spread() {
        assert_eq!(output_steps(300, 100), vec![0, 100, 200, 300]);
        assert_eq!(output_steps(250, 100), vec![0, 100, 200, 250]);
        assert_eq!(spread(&(0..=20).collect::<Vec<_>>(), 5), vec![0, 5, 10, 15, 20]);
    }

    #[test]
    fn every_frame_format_writes_a_file_named_after_it() {
        let dir = crate::io::scratch_dir("frame-formats");
        let mesh = crate::io::test_mesh();
        for format in [FrameFormat::Obj, FrameFormat::Ply, FrameFormat::Gltf] {
            let path = dir.join(format!("mesh.{}", format.extension()));
            write_mesh(&path, &mesh, format).unwrap();
            assert!(std::fs::metadata(&path).unwrap().len() > 0);
            assert_eq!(serde_json::to_value(format).unwrap().as_str(), Some(format.extension()));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
