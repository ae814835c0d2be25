//! Running a built [`Scene`] into an output directory: the layer above [`crate::scene`] (which only reads and
//! builds scenes) that the CLI and the tests call. [`run_scene`] steps the scene with [`crate::sim::run`] (or
//! solves it with the static solver), and writes a Coons-tessellated frame at every output step, `energy.csv`
//! (every step), `summary.json` and `snapshots.png`. Every file is written atomically ([`crate::io::atomic`]),
//! so a run that fails (a diverging step) leaves only complete files behind, and no `summary.json` of its own.
//!
//! - [`outputs`]: frames, the energy rows, the snapshot pictures and the camera shared by them.
//! - [`summary`]: `summary.json` and the measures of the final configuration.

pub mod animation;
pub mod fields;
pub mod outputs;
pub mod plots;
pub mod summary;

pub use outputs::{
    obstacle_drawables, output_steps, render_frame, view_for, write_mesh, FrameRecord, Snapshot, CLOTH_COLOR,
    MAX_SNAPSHOTS, OBSTACLE_COLOR, PLANE_COLOR,
};
pub use summary::{waist_drift, FinalState, Summary};

use crate::integrate::statics::{StaticOptions, StaticReport, StaticSolver};
use crate::integrate::{Counters, Method, StepError, Stepper};
use crate::io::atomic;
use crate::model::Model;
use crate::scene::Scene;
use crate::sim;
use crate::state::State;
use crate::surface::CoonsSurface;
use outputs::Recorder;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use summary::Finished;
use thiserror::Error;

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
    /// The static equilibrium solve failed (the message carries the hint that fits the failure).
    #[error(transparent)]
    Static(crate::integrate::statics::StaticError),
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RunError + '_ {
    move |source| RunError::Io { path: path.to_path_buf(), source }
}

/// What [`run_scene`] returns besides the files.
#[derive(Debug, Clone)]
pub struct RunOutput {
    /// The summary written to `summary.json`.
    pub summary: Summary,
    /// Meshes of the snapshot steps (at most [`MAX_SNAPSHOTS`]).
    pub snapshots: Vec<Snapshot>,
}

/// Creates `out/frames` and removes a `summary.json` left in `out`; returns the frames directory.
fn prepare(out: &Path) -> Result<PathBuf, RunError> {
    let frames_dir = out.join("frames");
    std::fs::create_dir_all(&frames_dir).map_err(io_err(&frames_dir))?;
    // A summary left by an earlier run in the same directory would claim this run completed.
    let summary_path = out.join("summary.json");
    match std::fs::remove_file(&summary_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io_err(&summary_path)(e)),
        _ => {}
    }
    Ok(frames_dir)
}

/// Runs `scene` and writes its outputs into `out` (created if missing). `progress(step)` is called after
/// every step. Does not modify `scene`.
pub fn run_scene(scene: &Scene, out: &Path, mut progress: impl FnMut(usize)) -> Result<RunOutput, RunError> {
    run_scene_observed(scene, out, |state| progress(state.step))
}

/// As [`run_scene`], calling `observe(state)` after every step with the state just reached (the Python
/// bindings keep the positions of the output steps this way). The outputs are those of [`run_scene`].
pub fn run_scene_observed(scene: &Scene, out: &Path, mut observe: impl FnMut(&State)) -> Result<RunOutput, RunError> {
    let model = &scene.model;
    let frames_dir = prepare(out)?;
    // A static solve writes the initial state and the equilibrium (as step 1).
    let outputs = if matches!(scene.method, Method::Static(_)) {
        vec![0, 1]
    } else {
        output_steps(scene.steps, scene.output_every)
    };
    let mut rec = Recorder::new(scene, frames_dir, outputs);
    rec.anim = Some(animation::AnimationRecorder::new(scene, out, &scene.state.x)?);
    let mut state = scene.state.clone();
    let mut failure: Option<RunError> = None;
    let mut timings = Counters::default();

    rec.record(&state)?;
    let (stats, static_report) = match scene.method {
        Method::Static(options) => {
            let (stats, report) = solve_static(model, &options, &mut state, &mut rec, &mut observe)?;
            (Ok(stats), Some(report))
        }
        Method::Dynamic(params) => {
            let mut stepper = Stepper::new(model, &params)?;
            let stats = sim::run(model, &mut state, &mut stepper, scene.steps, |st, _info| {
                observe(st);
                match rec.record(st) {
                    Ok(()) => ControlFlow::Continue(()),
                    Err(e) => {
                        failure = Some(e);
                        ControlFlow::Break(())
                    }
                }
            });
            timings = stepper.counters;
            (stats, None)
        }
    };
    // The energy history up to a failure is still useful; it is complete as far as it goes.
    let csv_path = out.join("energy.csv");
    atomic::write_atomic(&csv_path, rec.csv.as_bytes()).map_err(io_err(&csv_path))?;
    let stats = stats?;
    if let Some(e) = failure {
        return Err(e);
    }

    let final_mesh = CoonsSurface::new(&model.grid, &state.x).tessellate(scene.output.coons_subdivisions);
    let Recorder { frames, snapshots, anim, .. } = rec;
    let done = Finished { stats, timings, static_report, frames };
    let summary = summary::summarize(scene, &state, &final_mesh, done);
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| RunError::Io { path: out.join("summary.json"), source: std::io::Error::other(e) })?;
    let title = format!(
        "{}  ·  {} model  ·  {} steps  ·  t = {:.2} s",
        scene.name,
        plots::model_label(model.kind.name()),
        summary.steps,
        summary.simulated_seconds
    );
    outputs::write_snapshots(out, model, &snapshots, scene.output.image_size, &title)?;
    if let Some(anim) = &anim {
        anim.finish(&plots::run_info(scene, &summary))?;
    }
    plots::write_energy_png(out, scene)?;

    // The summary last: its presence means the run completed.
    let path = out.join("summary.json");
    atomic::write_atomic(&path, json.as_bytes()).map_err(io_err(&path))?;
    Ok(RunOutput { summary, snapshots })
}

/// `integrator = "static"`: solves for the equilibrium from `state`, records it as step 1 and reports it.
fn solve_static(
    model: &Model,
    options: &StaticOptions,
    state: &mut State,
    rec: &mut Recorder<'_>,
    progress: &mut impl FnMut(&State),
) -> Result<(sim::RunStats, StaticReport), RunError> {
    let t = std::time::Instant::now();
    let report =
        StaticSolver::new(model).and_then(|mut s| s.solve(model, &mut state.x, options)).map_err(RunError::Static)?;
    let wall = t.elapsed().as_secs_f64();
    state.x_prev.copy_from_slice(&state.x);
    state.v.iter_mut().chain(state.v_prev.iter_mut()).for_each(|v| *v = crate::math::Vec3::ZERO);
    state.step = 1;
    progress(state);
    rec.record(state)?;
    let stats = sim::RunStats {
        steps: 0,
        wall_seconds: wall,
        max_penetration_seen: crate::integrate::max_penetration(model, &state.x),
        max_contacts: 0,
    };
    Ok((stats, report))
}

/// Writes `text` to `path` atomically, creating its directory.
pub fn write_text(path: &Path, text: &str) -> Result<(), RunError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    }
    atomic::write_atomic_with(path, |w: &mut dyn Write| w.write_all(text.as_bytes())).map_err(io_err(path))
}
