//! `snapshots.png`: a panel of shaded pictures of up to [`MAX_SNAPSHOTS`] output steps (every panel of the
//! cloth, with the obstacles, all from one camera), and the camera and drawing shared with the demo's
//! comparison and the viewer's movies.

use super::{Context, Frame, Output, OutputState, RunOutput};
use crate::contact::Look;
use crate::io::render::{self, Drawable, View};
use crate::math::Vec3;
use crate::model::Model;
use crate::runner::fields::display_mesh;
use crate::runner::plots::model_label;
use crate::runner::{io_err, RunError, Summary};
use crate::scene::Scene;
use crate::surface::{Aabb, TriMesh};
use std::path::{Path, PathBuf};

/// The pictures, relative to the output folder.
pub const SNAPSHOTS_PNG: &str = "snapshots.png";
/// Most pictures in `snapshots.png`; with more output steps an evenly spread subset is drawn.
pub const MAX_SNAPSHOTS: usize = 8;
/// Cloth colour in pictures (sRGB).
pub const CLOTH_COLOR: [u8; 3] = [196, 86, 62];
/// Obstacle colour in pictures (sRGB).
pub const OBSTACLE_COLOR: [u8; 3] = [150, 160, 175];
/// Ground plane colour in pictures (sRGB).
pub const PLANE_COLOR: [u8; 3] = [215, 215, 215];

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

/// At most `max` entries of `all`, evenly spread, first and last included.
fn spread(all: &[usize], max: usize) -> Vec<usize> {
    if all.len() <= max || max < 2 {
        return all.to_vec();
    }
    let mut v: Vec<usize> = (0..max).map(|i| all[i * (all.len() - 1) / (max - 1)]).collect();
    v.dedup();
    v
}

/// The positions of a pictured step, as a checkpoint keeps them: (step, time, node positions).
type Pictured = (usize, f64, Vec<Vec3>);

/// The snapshots output: the meshes of the pictured steps, drawn at the end.
pub struct Snapshots<'a> {
    scene: &'a Scene,
    out: PathBuf,
    /// Steps pictured (as many as fill whole rows of the panel, evenly spread over the output steps).
    steps: Vec<usize>,
    pictured: Vec<Pictured>,
    snapshots: Vec<Snapshot>,
}

impl<'a> Snapshots<'a> {
    /// The pictures of the run `cx`.
    pub fn new(cx: &Context<'a>) -> Self {
        // As many pictures as fill whole rows of the panel (see `render::grid_layout`), evenly spread.
        let steps = spread(&cx.steps, render::grid_layout(cx.steps.len()).0.min(MAX_SNAPSHOTS));
        Self { scene: cx.scene, out: cx.out.clone(), steps, pictured: Vec::new(), snapshots: Vec::new() }
    }
}

impl Output for Snapshots<'_> {
    fn name(&self) -> &'static str {
        "snapshots"
    }

    fn files(&self) -> Vec<String> {
        vec![SNAPSHOTS_PNG.to_string()]
    }

    fn start(&mut self, saved: Option<&OutputState>) -> Result<(), RunError> {
        self.pictured = OutputState::or_default(saved, self.name())?;
        let (model, k) = (&self.scene.model, self.scene.output.coons_subdivisions);
        let n = model.nodes();
        let fits = |x: &[crate::math::Vec3]| x.len() == n && x.iter().all(|p| crate::math::finite(*p));
        if self.pictured.len() > MAX_SNAPSHOTS || !self.pictured.iter().all(|(_, t, x)| t.is_finite() && fits(x)) {
            return Err(OutputState::misfit(self.name(), format!("pictures that are not {n} finite node positions")));
        }
        self.snapshots = self
            .pictured
            .iter()
            .map(|(step, time, x)| Snapshot { step: *step, time: *time, mesh: display_mesh(model, x, k) })
            .collect();
        Ok(())
    }

    fn record(&mut self, frame: &Frame<'_>) -> Result<(), RunError> {
        let (Some(mesh), st) = (frame.mesh, frame.state) else { return Ok(()) };
        if self.steps.contains(&st.step) {
            self.pictured.push((st.step, st.time, st.x.clone()));
            self.snapshots.push(Snapshot { step: st.step, time: st.time, mesh: mesh.clone() });
        }
        Ok(())
    }

    fn save(&self) -> Result<OutputState, RunError> {
        OutputState::of(&self.pictured)
    }

    fn report(&self, run: &mut RunOutput) {
        run.snapshots.clone_from(&self.snapshots);
    }

    fn finish(&mut self, summary: &Summary) -> Result<(), RunError> {
        let scene = self.scene;
        let model = model_label(scene.model.kind.name());
        // A static solve has no time: its title says how it converged, its panels what they show.
        let (title, labels): (String, Vec<String>) = match &summary.static_solve {
            Some(r) => (
                format!(
                    "{}  ·  {model} model  ·  static solve: {} Newton iterations, residual {:.1e}",
                    scene.name, r.iterations, r.residual
                ),
                self.snapshots.iter().map(|s| if s.step == 0 { "start" } else { "equilibrium" }.to_string()).collect(),
            ),
            None => (
                format!(
                    "{}  ·  {model} model  ·  {} steps  ·  t = {:.2} s",
                    scene.name, summary.steps, summary.simulated_seconds
                ),
                self.snapshots.iter().map(|s| format!("step {}   t = {:.2} s", s.step, s.time)).collect(),
            ),
        };
        write_snapshots(&self.out, &scene.model, &self.snapshots, scene.output.image_size, &title, &labels)
    }
}

/// Writes `snapshots.png` into `out`: the pictures of `snapshots`, `image_size` pixels each, with a scale bar
/// and axes, in whole rows ([`render::grid_layout`]), under the title `title`.
fn write_snapshots(
    out: &Path,
    model: &Model,
    snapshots: &[Snapshot],
    image_size: [u32; 2],
    title: &str,
    labels: &[String],
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
    let png = out.join(SNAPSHOTS_PNG);
    let columns = render::grid_layout(images.len()).1;
    let panel = render::with_title(&render::panel(&images, labels, columns), title);
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

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    /// `spread`.
    pub fn spread(all: &[usize], max: usize) -> Vec<usize> {
        super::spread(all, max)
    }
}
