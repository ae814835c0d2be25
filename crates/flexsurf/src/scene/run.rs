//! Running a [`Scene`] into an output directory: steps it with [`crate::sim::run`], writes a Coons-tessellated
//! frame at every output step, `energy.csv` (every step), `summary.json` and `snapshots.png`. Every file is
//! written atomically ([`crate::io::atomic`]), so a run that fails (a diverging step) leaves only complete
//! files behind, and no `summary.json` of its own.

use super::{FrameFormat, Scene};
use crate::contact::Obstacle;
use crate::integrate::statics::{StaticReport, StaticSolver};
use crate::integrate::{Counters, Method, StepError, Stepper};
use crate::io::render::{self, Drawable, View};
use crate::io::{atomic, PlyFormat};
use crate::math::Vec3;
use crate::model::Model;
use crate::sim::{self, Diagnostics};
use crate::surface::{Aabb, CoonsSurface, TriMesh};
use serde::Serialize;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Most pictures in `snapshots.png`; with more output steps an evenly spread subset is drawn.
pub const MAX_SNAPSHOTS: usize = 8;
/// Cloth colour in pictures (sRGB).
pub const CLOTH_COLOR: [u8; 3] = [196, 86, 62];
/// Obstacle colour in pictures (sRGB).
pub const OBSTACLE_COLOR: [u8; 3] = [150, 160, 175];
/// Ground plane colour in pictures (sRGB).
pub const PLANE_COLOR: [u8; 3] = [215, 215, 215];

/// Why a run stopped.
#[derive(Debug, Error)]
pub enum RunError {
    /// An output file or directory could not be written.
    #[error("cannot write {}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The step failed (divergence or a failed solve); the message carries the step number and a hint.
    #[error(transparent)]
    Step(#[from] StepError),
    /// The static equilibrium solve failed.
    #[error(
        "{0} (hint: a static solve needs an equilibrium to find: the sheet held by pins or springs, or resting on \
         a support it cannot slide off without friction; for a drop or a slide use `integrator.kind = \"linearized\"`)"
    )]
    Static(crate::integrate::statics::StaticError),
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RunError + '_ {
    move |source| RunError::Io { path: path.to_path_buf(), source }
}

/// The configuration at the end of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FinalState {
    /// Lowest node height (m).
    pub min_z: f64,
    /// Highest node height (m).
    pub max_z: f64,
    /// Mean node position (m).
    pub centroid: [f64; 3],
    /// Bounding box of the Coons mesh, low corner (m).
    pub bbox_min: [f64; 3],
    /// Bounding box of the Coons mesh, high corner (m).
    pub bbox_max: [f64; 3],
    /// Area of the union of the Coons mesh's triangles projected onto the xy plane (m²), measured on a raster
    /// of `projected_area_resolution²` cells over the footprint's bounding box.
    pub projected_area_xy: f64,
    /// Raster cells per side used for `projected_area_xy`.
    pub projected_area_resolution: usize,
    /// Kinetic energy (J).
    pub kinetic_energy: f64,
    /// Membrane energy (J).
    pub membrane_energy: f64,
    /// Bending energy (J).
    pub bending_energy: f64,
    /// Gravitational potential energy (J).
    pub potential_energy: f64,
    /// Deepest penetration into an obstacle (m).
    pub max_penetration: f64,
    /// Largest engineering edge strain.
    pub max_strain: f64,
}

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

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Scene name.
    pub scene: String,
    /// `tfs` or `terzopoulos`.
    pub model: String,
    /// `linearized` or `lagged`.
    pub integrator: String,
    /// `cholesky` or `pcg`.
    pub solver: String,
    /// `kes` or `paper`.
    pub calibration: String,
    /// Material name.
    pub material: String,
    /// Nodes `[M, N]`.
    pub grid: [usize; 2],
    /// Time step (s).
    pub dt: f64,
    /// Steps taken.
    pub steps: usize,
    /// Frame cadence (steps).
    pub output_every: usize,
    /// `steps · dt` (s).
    pub simulated_seconds: f64,
    /// Wall time of the time stepping only (s), from [`sim::RunStats`].
    pub wall_seconds: f64,
    /// `steps / wall_seconds`.
    pub steps_per_second: f64,
    /// Per-stage wall times of the stepper (s).
    pub timings: Counters,
    /// Deepest penetration after any step (m).
    pub max_penetration_seen: f64,
    /// Most simultaneous contacts.
    pub max_contacts: usize,
    /// Garment scenes: the largest distance of a waist node from its spring target at the end (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waist_drift_max: Option<f64>,
    /// Garment scenes: waist nodes moved outward onto the body when the garment was placed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waist_fitted: Option<usize>,
    /// Garment scenes: strain of the fitted waist row against the pattern's waist girth.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waist_strain: Option<f64>,
    /// Garment scenes: smallest signed distance of the initial shape from the obstacles (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_min_distance: Option<f64>,
    /// `integrator = "static"`: Newton iterations, final relative residual (residual force over the largest
    /// load) and total potential.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub static_solve: Option<StaticReport>,
    /// Frames written.
    pub frames: Vec<FrameRecord>,
    /// The final configuration.
    #[serde(rename = "final")]
    pub final_state: FinalState,
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

/// What [`run_scene`] returns besides the files.
#[derive(Debug, Clone)]
pub struct RunOutput {
    /// The summary written to `summary.json`.
    pub summary: Summary,
    /// Meshes of the snapshot steps (at most [`MAX_SNAPSHOTS`]).
    pub snapshots: Vec<Snapshot>,
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
fn spread(all: &[usize], max: usize) -> Vec<usize> {
    if all.len() <= max || max < 2 {
        return all.to_vec();
    }
    let mut v: Vec<usize> = (0..max).map(|i| all[i * (all.len() - 1) / (max - 1)]).collect();
    v.dedup();
    v
}

/// Runs `scene` and writes its outputs into `out` (created if missing). `progress(step)` is called after
/// every step. Does not modify `scene`.
pub fn run_scene(scene: &Scene, out: &Path, mut progress: impl FnMut(usize)) -> Result<RunOutput, RunError> {
    let model = &scene.model;
    let frames_dir = out.join("frames");
    std::fs::create_dir_all(&frames_dir).map_err(io_err(&frames_dir))?;
    // A summary left by an earlier run in the same directory would claim this run completed.
    let summary_path = out.join("summary.json");
    match std::fs::remove_file(&summary_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io_err(&summary_path)(e)),
        _ => {}
    }
    // A static solve writes the initial state and the equilibrium (as step 1).
    let outputs = if matches!(scene.method, Method::Static(_)) {
        vec![0, 1]
    } else {
        output_steps(scene.steps, scene.output_every)
    };
    let pictured = spread(&outputs, MAX_SNAPSHOTS);
    let k = scene.output.coons_subdivisions;

    let mut state = scene.state.clone();
    let mut counters = Counters::default();
    let mut frames = Vec::new();
    let mut snapshots = Vec::new();
    let mut csv = String::from("step,time,kinetic,membrane,bending,potential\n");
    let mut failure: Option<RunError> = None;

    let mut record = |state: &crate::state::State, csv: &mut String| -> Result<(), RunError> {
        // Only the energies: penetration and strain of every step are not written, so not computed here.
        csv_row(csv, &sim::energies(model, state, scene.dt));
        if outputs.binary_search(&state.step).is_ok() {
            let mesh = CoonsSurface::new(&model.grid, &state.x).tessellate(k);
            let name = format!("frame_{:05}.{}", state.step, scene.output.format.extension());
            let path = frames_dir.join(&name);
            write_mesh(&path, &mesh, scene.output.format).map_err(io_err(&path))?;
            frames.push(FrameRecord { step: state.step, time: state.time, file: format!("frames/{name}") });
            if pictured.contains(&state.step) {
                snapshots.push(Snapshot { step: state.step, time: state.time, mesh });
            }
        }
        Ok(())
    };

    record(&state, &mut csv)?;
    let mut static_report = None;
    let stats = match scene.method {
        Method::Static(options) => {
            let t = std::time::Instant::now();
            let report = StaticSolver::new(model)
                .and_then(|mut s| s.solve(model, &mut state.x, &options))
                .map_err(RunError::Static)?;
            let wall = t.elapsed().as_secs_f64();
            state.x_prev.copy_from_slice(&state.x);
            state.step = 1;
            static_report = Some(report);
            progress(1);
            record(&state, &mut csv)?;
            Ok(sim::RunStats {
                steps: 0,
                wall_seconds: wall,
                max_penetration_seen: crate::integrate::max_penetration(model, &state.x),
                max_contacts: 0,
            })
        }
        Method::Dynamic(params) => {
            let mut stepper = Stepper::new(model, &params)?;
            let stats = sim::run(model, &mut state, &mut stepper, scene.steps, |st, _info| {
                progress(st.step);
                match record(st, &mut csv) {
                    Ok(()) => ControlFlow::Continue(()),
                    Err(e) => {
                        failure = Some(e);
                        ControlFlow::Break(())
                    }
                }
            });
            counters = stepper.counters;
            stats
        }
    };
    // The energy history up to a failure is still useful; it is complete as far as it goes.
    let csv_path = out.join("energy.csv");
    atomic::write_atomic(&csv_path, csv.as_bytes()).map_err(io_err(&csv_path))?;
    let stats = stats?;
    if let Some(e) = failure {
        return Err(e);
    }

    let d = sim::diagnose(model, &state, scene.dt, 0);
    let final_mesh = CoonsSurface::new(&model.grid, &state.x).tessellate(k);
    let summary = Summary {
        scene: scene.name.clone(),
        model: model.kind.name().to_string(),
        integrator: scene.method.name().to_string(),
        solver: format!("{:?}", scene.solver()).to_lowercase(),
        calibration: format!("{:?}", scene.calibration).to_lowercase(),
        material: scene.material.clone(),
        grid: [model.grid.m, model.grid.n],
        dt: scene.dt,
        steps: stats.steps,
        output_every: scene.output_every,
        simulated_seconds: state.time,
        wall_seconds: stats.wall_seconds,
        steps_per_second: if stats.wall_seconds > 0.0 { stats.steps as f64 / stats.wall_seconds } else { 0.0 },
        timings: counters,
        max_penetration_seen: stats.max_penetration_seen,
        max_contacts: stats.max_contacts,
        waist_drift_max: scene.garment.as_ref().map(|g| waist_drift(model, &g.waist_nodes, &state.x)),
        waist_fitted: scene.garment.as_ref().map(|g| g.waist_fitted),
        waist_strain: scene.garment.as_ref().map(|g| g.waist_strain),
        initial_min_distance: scene.garment.as_ref().map(|g| g.initial_min_distance),
        static_solve: static_report,
        frames,
        final_state: final_state(model, &state.x, &final_mesh, &d),
    };
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| RunError::Io { path: out.join("summary.json"), source: std::io::Error::other(e) })?;

    let view = view_for(model, snapshots.iter().map(|s| &s.mesh));
    let [w, h] = scene.output.image_size;
    let images: Vec<_> = snapshots.iter().map(|s| render_frame(model, &s.mesh, &view, w, h)).collect();
    let labels: Vec<String> = snapshots.iter().map(|s| format!("step {}  t = {:.2} s", s.step, s.time)).collect();
    let png = out.join("snapshots.png");
    render::save_png(&png, &render::panel(&images, &labels, images.len().min(4))).map_err(io_err(&png))?;

    // The summary last: its presence means the run completed.
    let path = out.join("summary.json");
    atomic::write_atomic(&path, json.as_bytes()).map_err(io_err(&path))?;
    Ok(RunOutput { summary, snapshots })
}

/// Largest distance of a spring-held node among `nodes` from its spring's target (m; 0 without such springs).
pub fn waist_drift(model: &Model, nodes: &[usize], x: &[Vec3]) -> f64 {
    model
        .springs()
        .iter()
        .filter(|s| nodes.contains(&s.node))
        .map(|s| (x[s.node] - s.target).length())
        .fold(0.0, f64::max)
}

fn csv_row(csv: &mut String, d: &sim::EnergyRecord) {
    use std::fmt::Write as _;
    let _ = writeln!(
        csv,
        "{},{},{:.9e},{:.9e},{:.9e},{:.9e}",
        d.step, d.time, d.kinetic, d.energies.membrane, d.energies.bending, d.potential
    );
}

/// Writes `mesh` in `format` (atomically).
pub fn write_mesh(path: &Path, mesh: &TriMesh, format: FrameFormat) -> std::io::Result<()> {
    match format {
        FrameFormat::Obj => crate::io::write_obj(path, mesh),
        FrameFormat::Ply => crate::io::write_ply(path, mesh, PlyFormat::BinaryLittleEndian),
        FrameFormat::Gltf => crate::io::write_gltf(path, mesh, [0.77, 0.34, 0.24, 1.0]),
    }
}

fn final_state(model: &Model, x: &[Vec3], mesh: &TriMesh, d: &Diagnostics) -> FinalState {
    let n = x.len().max(1) as f64;
    let centroid = x.iter().fold(Vec3::ZERO, |a, p| a + *p) / n;
    let bbox = mesh.bbox().unwrap_or(Aabb { min: Vec3::ZERO, max: Vec3::ZERO });
    let res = super::defaults::FOOTPRINT_RESOLUTION;
    FinalState {
        min_z: x.iter().map(|p| p.z).fold(f64::INFINITY, f64::min),
        max_z: x.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max),
        centroid: centroid.to_array(),
        bbox_min: bbox.min.to_array(),
        bbox_max: bbox.max.to_array(),
        projected_area_xy: projected_area_xy(mesh, res),
        projected_area_resolution: res,
        kinetic_energy: d.kinetic,
        membrane_energy: d.energies.membrane,
        bending_energy: d.energies.bending,
        potential_energy: d.potential,
        max_penetration: d.max_penetration,
        max_strain: model.max_strain(x),
    }
}

/// Area of the union of `mesh`'s triangles projected onto the xy plane: the fraction of the centres of a
/// `res × res` raster over the footprint's xy bounding box that fall inside some projected triangle, times the
/// box's area. The error is of order (perimeter × cell size).
pub fn projected_area_xy(mesh: &TriMesh, res: usize) -> f64 {
    let Some(bb) = mesh.bbox() else { return 0.0 };
    let res = res.max(1);
    let (x0, y0) = (bb.min.x, bb.min.y);
    let (sx, sy) = ((bb.max.x - x0) / res as f64, (bb.max.y - y0) / res as f64);
    if !(sx > 0.0 && sy > 0.0 && sx.is_finite() && sy.is_finite()) {
        return 0.0;
    }
    let mut covered = vec![false; res * res];
    let cell = |v: f64, o: f64, s: f64| ((v - o) / s - 0.5).clamp(0.0, res as f64 - 1.0);
    for t in 0..mesh.triangle_count() {
        let Some([a, b, c]) = mesh.triangle(t) else { continue };
        let area2 = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
        if area2 == 0.0 || !area2.is_finite() {
            continue;
        }
        let (lo_x, hi_x) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
        let (lo_y, hi_y) = (a.y.min(b.y).min(c.y), a.y.max(b.y).max(c.y));
        let (i0, i1) = (cell(lo_x, x0, sx).floor() as usize, cell(hi_x, x0, sx).ceil() as usize);
        let (j0, j1) = (cell(lo_y, y0, sy).floor() as usize, cell(hi_y, y0, sy).ceil() as usize);
        let edge = |p: Vec3, q: Vec3, x: f64, y: f64| ((q.x - p.x) * (y - p.y) - (x - p.x) * (q.y - p.y)) * area2;
        for j in j0..=j1 {
            let y = y0 + (j as f64 + 0.5) * sy;
            for i in i0..=i1 {
                let x = x0 + (i as f64 + 0.5) * sx;
                if edge(a, b, x, y) >= 0.0 && edge(b, c, x, y) >= 0.0 && edge(c, a, x, y) >= 0.0 {
                    covered[i + res * j] = true;
                }
            }
        }
    }
    covered.iter().filter(|&&c| c).count() as f64 * sx * sy
}

/// Drawables of a model's obstacles.
pub fn obstacle_drawables(model: &Model) -> Vec<Drawable<'static>> {
    model
        .obstacles()
        .into_iter()
        .map(|o| match o {
            Obstacle::Sphere { center, radius } => Drawable::sphere(center, radius, OBSTACLE_COLOR),
            Obstacle::Plane { point, normal } => Drawable::plane(point, normal, PLANE_COLOR),
            Obstacle::Nurbs(body) => Drawable::owned_mesh(body.tessellate(12), OBSTACLE_COLOR),
            Obstacle::Mesh(body) => Drawable::owned_mesh(body.to_mesh(), OBSTACLE_COLOR),
        })
        .collect()
}

/// One camera that frames all `meshes` and the model's bounded obstacles.
pub fn view_for<'a>(model: &Model, meshes: impl Iterator<Item = &'a TriMesh>) -> View {
    let obstacles = obstacle_drawables(model);
    let bbox = meshes.filter_map(TriMesh::bbox).chain(obstacles.iter().filter_map(Drawable::bbox)).reduce(Aabb::union);
    render::default_view_for(&bbox.unwrap_or(Aabb { min: Vec3::splat(-0.5), max: Vec3::splat(0.5) }))
}

/// A shaded picture of `mesh` with the model's obstacles.
pub fn render_frame(model: &Model, mesh: &TriMesh, view: &View, width: u32, height: u32) -> image::RgbImage {
    let mut drawables = vec![Drawable::mesh(mesh, CLOTH_COLOR)];
    drawables.extend(obstacle_drawables(model));
    render::render(view, &drawables, width, height)
}

/// Writes `text` to `path` atomically, creating its directory.
pub fn write_text(path: &Path, text: &str) -> Result<(), RunError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    }
    atomic::write_atomic_with(path, |w: &mut dyn Write| w.write_all(text.as_bytes())).map_err(io_err(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn footprint_of_a_flat_square_and_output_steps() {
        let g = crate::grid::Grid::sheet(5, 5, 1.0, 0.5).unwrap();
        let mesh = CoonsSurface::new(&g, &g.flat_positions(0.3)).tessellate(2);
        let a = projected_area_xy(&mesh, 512);
        assert!((a - 0.5).abs() < 1e-9, "{a}");
        assert_eq!(output_steps(300, 100), vec![0, 100, 200, 300]);
        assert_eq!(output_steps(250, 100), vec![0, 100, 200, 250]);
        assert_eq!(spread(&(0..=20).collect::<Vec<_>>(), 5), vec![0, 5, 10, 15, 20]);
    }
}
