//! Running a built [`Scene`] into an output directory: the layer above [`crate::scene`] (which only reads and
//! builds scenes) that the CLI and the tests call. [`run_scene`] steps the scene with [`crate::sim::run`] (or
//! solves it with the static solver), and writes a Coons-tessellated frame at every output step, `energy.csv`
//! (every step), `summary.json` and `snapshots.png`. Every file is written atomically ([`crate::io::atomic`]),
//! so a run that fails (a diverging step) leaves only complete files behind, and no `summary.json` of its own.
//!
//! - [`outputs`]: frames, the energy rows, the snapshot pictures and the camera shared by them.
//! - [`summary`]: `summary.json` and the measures of the final configuration.
//! - [`manifest`]: the output folder's `manifest.json`: refusing, overwriting and cleaning safely.
//! - [`checkpoint`]: `checkpoint.bin`, written every `--checkpoint-every` steps and when stopped, and resumed.
//! - [`provenance`]: the version, command line, input hashes, material and solver settings of a summary.
//!
//! `energy.csv` is appended and flushed row by row as the run goes, so a kill keeps the history so far.

pub mod animation;
pub mod checkpoint;
pub mod fields;
pub mod manifest;
pub mod outputs;
pub mod plots;
pub mod provenance;
pub mod summary;

pub use outputs::{
    obstacle_drawables, output_steps, render_frame, view_for, write_mesh, FrameRecord, Snapshot, CLOTH_COLOR,
    MAX_SNAPSHOTS, OBSTACLE_COLOR, PLANE_COLOR,
};
pub use provenance::Provenance;
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
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
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
    /// The output folder cannot be used as it is (another run's outputs, files of unknown origin, a link).
    #[error("{}: {message}", path.display())]
    Folder {
        /// The folder or file.
        path: PathBuf,
        /// What is wrong and what to do.
        message: String,
    },
    /// A value became NaN or infinite; `stage` says where (a step, the static solve, the final state).
    #[error("non-finite values after {stage}: the scene's numbers are beyond what the model can compute")]
    NonFinite {
        /// Where.
        stage: String,
    },
    /// A run cannot be resumed.
    #[error("{0}")]
    Resume(String),
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

/// How [`run_scene_with`] runs: the output folder policy, checkpoints, resuming, stopping, provenance.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Remove the outputs of another run in the folder (exactly the files its manifest lists) instead of
    /// refusing.
    pub overwrite: bool,
    /// Write a checkpoint every this many steps (none: only when stopped).
    pub checkpoint_every: Option<usize>,
    /// Continue the run whose checkpoint is in the output folder.
    pub resume: bool,
    /// Set (by a signal handler) to stop the run after the current step: a checkpoint and a summary marked
    /// `"interrupted": true` are written.
    pub stop: Option<Arc<AtomicBool>>,
    /// The command line, for the summary's provenance.
    pub command_line: Vec<String>,
    /// The files read to build the scene, with their hashes ([`crate::io::input::recording`]).
    pub inputs: Vec<crate::io::input::InputFile>,
}

/// The fingerprint of a run of `scene`: SHA-256 of everything that determines its results (model, initial
/// state, time stepping, outputs, the library version), not of its name or file path. A checkpoint is resumed
/// only by a run of the same fingerprint.
pub fn fingerprint(scene: &Scene) -> String {
    use sha2::Digest;
    struct Hasher(sha2::Sha256);
    impl std::fmt::Write for Hasher {
        fn write_str(&mut self, s: &str) -> std::fmt::Result {
            self.0.update(s.as_bytes());
            Ok(())
        }
    }
    let mut h = Hasher(sha2::Sha256::new());
    let _ = std::fmt::Write::write_fmt(
        &mut h,
        format_args!(
            "flexsurf {}\n{:?}\n{:?}\n{:?} {} {} {:?} {:?} {:?} {:?} {:?}",
            env!("CARGO_PKG_VERSION"),
            scene.model,
            scene.state,
            scene.dt.to_bits(),
            scene.steps,
            scene.output_every,
            scene.method,
            scene.calibration,
            scene.material,
            scene.output,
            scene.garment
        ),
    );
    crate::io::input::hex(&h.0.finalize())
}

/// Runs `scene` and writes its outputs into `out` (created if missing). `progress(step)` is called after
/// every step. Does not modify `scene`. The folder policy is [`RunOptions::default`]'s: a folder with another
/// run's outputs is refused.
pub fn run_scene(scene: &Scene, out: &Path, mut progress: impl FnMut(usize)) -> Result<RunOutput, RunError> {
    run_scene_with(scene, out, &RunOptions::default(), |state| progress(state.step))
}

/// As [`run_scene`], calling `observe(state)` after every step with the state just reached (the Python
/// bindings keep the positions of the output steps this way). The outputs are those of [`run_scene`].
pub fn run_scene_observed(scene: &Scene, out: &Path, observe: impl FnMut(&State)) -> Result<RunOutput, RunError> {
    run_scene_with(scene, out, &RunOptions::default(), observe)
}

/// `energy.csv`, appended and flushed to the system row by row as the run goes (a kill keeps every row
/// written; a resumed run truncates it to the checkpoint's length).
struct EnergyLog {
    file: std::fs::File,
    path: PathBuf,
    bytes: u64,
}

impl EnergyLog {
    fn create(path: &Path) -> Result<Self, RunError> {
        let file = std::fs::File::create(path).map_err(io_err(path))?;
        Ok(Self { file, path: path.to_path_buf(), bytes: 0 })
    }

    fn resume(path: &Path, bytes: u64) -> Result<Self, RunError> {
        let file = std::fs::OpenOptions::new().append(true).open(path).map_err(io_err(path))?;
        let len = file.metadata().map_err(io_err(path))?.len();
        if len < bytes {
            let message = format!("is {len} bytes, shorter than the {bytes} it had at the checkpoint");
            return Err(RunError::Io { path: path.to_path_buf(), source: std::io::Error::other(message) });
        }
        file.set_len(bytes).map_err(io_err(path))?;
        Ok(Self { file, path: path.to_path_buf(), bytes })
    }

    /// Appends the rows in `text` and empties it.
    fn drain(&mut self, text: &mut String) -> Result<(), RunError> {
        if !text.is_empty() {
            self.file.write_all(text.as_bytes()).map_err(io_err(&self.path))?;
            self.bytes += text.len() as u64;
            text.clear();
        }
        Ok(())
    }
}

fn remove_if_present(path: &Path) -> Result<(), RunError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(io_err(path)(e)),
        _ => Ok(()),
    }
}

/// Adds the statistics of one stretch of steps to `total`.
fn merge(total: &mut sim::RunStats, part: &sim::RunStats) {
    total.steps += part.steps;
    total.wall_seconds += part.wall_seconds;
    total.max_penetration_seen = total.max_penetration_seen.max(part.max_penetration_seen);
    total.max_contacts = total.max_contacts.max(part.max_contacts);
}

/// The positions of the pictured steps so far (for checkpoints): (step, time, positions).
type Pictured = Vec<(usize, f64, Vec<crate::math::Vec3>)>;

/// Runs `scene` into `out` as [`run_scene_observed`] does, with `options`: the output folder's manifest
/// ([`manifest`]), periodic and on-stop checkpoints, resuming ([`checkpoint`]), and provenance in the summary.
pub fn run_scene_with(
    scene: &Scene,
    out: &Path,
    options: &RunOptions,
    mut observe: impl FnMut(&State),
) -> Result<RunOutput, RunError> {
    let model = &scene.model;
    let fp = fingerprint(scene);
    let is_static = matches!(scene.method, Method::Static(_));
    if options.resume && is_static {
        return Err(RunError::Resume("a static solve has no checkpoint to resume from".into()));
    }
    let resume = if options.resume {
        Some(checkpoint::read(out, &fp).and_then(|ck| checkpoint::validated(ck, scene))?)
    } else {
        None
    };
    let mut folder = manifest::Folder::open(out, &fp, options.overwrite, resume.is_some())?;
    // A static solve writes the initial state and the equilibrium (as step 1).
    let outputs = if is_static { vec![0, 1] } else { output_steps(scene.steps, scene.output_every) };
    // Every file this run may write is claimed before any is written.
    let ext = scene.output.format.extension();
    let mut planned: Vec<String> = outputs.iter().map(|s| format!("frames/frame_{s:05}.{ext}")).collect();
    planned.extend(["energy.csv", "energy.png", "snapshots.png", "summary.json"].map(String::from));
    planned.extend(outputs.iter().map(|s| format!("{}/frame_{s:05}.vtu", animation::VTK_DIR)));
    planned.extend([animation::GLB_FILE, animation::PVD_FILE, animation::OBSTACLES_VTU].map(String::from));
    if !is_static {
        planned.push(checkpoint::CHECKPOINT.to_string());
    }
    folder.claim(&planned)?;
    // A summary left by an earlier attempt would claim this run completed.
    remove_if_present(&out.join("summary.json"))?;

    let mut rec = Recorder::new(scene, out.join("frames"), outputs);
    let mut anim = animation::AnimationRecorder::new(scene, out, &scene.state.x)?;
    if let Some(ck) = &resume {
        anim.restore(ck.animation.clone());
    }
    rec.anim = Some(anim);
    let csv_path = out.join("energy.csv");
    let mut pictured: Pictured = Vec::new();
    let (mut state, mut energy) = match &resume {
        None => {
            let mut log = EnergyLog::create(&csv_path)?;
            rec.record(&scene.state)?;
            if !rec.snapshots.is_empty() {
                pictured.push((scene.state.step, scene.state.time, scene.state.x.clone()));
            }
            log.drain(&mut rec.csv)?;
            (scene.state.clone(), log)
        }
        Some(ck) => {
            rec.csv.clear();
            for (step, time, file) in &ck.frames {
                rec.frames.push(FrameRecord { step: *step, time: *time, file: file.clone() });
            }
            for (step, time, x) in &ck.pictured {
                let mesh = CoonsSurface::new(&model.grid, x).tessellate(scene.output.coons_subdivisions);
                rec.snapshots.push(Snapshot { step: *step, time: *time, mesh });
            }
            pictured.clone_from(&ck.pictured);
            (ck.state.clone(), EnergyLog::resume(&csv_path, ck.energy_bytes)?)
        }
    };

    let mut failure: Option<RunError> = None;
    let mut interrupted = false;
    let mut timings = Counters::default();
    let (stats, static_report) = match scene.method {
        Method::Static(options) => {
            let (stats, report) = solve_static(model, &options, &mut state, &mut rec, &mut observe)?;
            energy.drain(&mut rec.csv)?;
            (Ok(stats), Some(report))
        }
        Method::Dynamic(params) => {
            let mut stepper = Stepper::new(model, &params)?;
            let mut total = sim::RunStats { steps: 0, wall_seconds: 0.0, max_penetration_seen: 0.0, max_contacts: 0 };
            if let Some(ck) = &resume {
                stepper
                    .restore(&ck.warm, ck.counters.into())
                    .and_then(|()| stepper.restore_solver(&ck.solver))
                    .map_err(|e| RunError::Resume(format!("cannot restore the checkpoint: {e}")))?;
                total = ck.stats.into();
            }
            let mut step_error = None;
            while state.step < scene.steps && !interrupted && failure.is_none() {
                let left = scene.steps - state.step;
                let chunk = match options.checkpoint_every {
                    Some(every) if every > 0 => (every - state.step % every).min(left),
                    _ => left,
                };
                let result = sim::run(model, &mut state, &mut stepper, chunk, |st, _info| {
                    if let Some(k) = st.x.iter().position(|p| !crate::math::finite(*p)) {
                        failure = Some(RunError::NonFinite { stage: format!("step {} (node {k})", st.step) });
                        return ControlFlow::Break(());
                    }
                    observe(st);
                    let pictures = rec.snapshots.len();
                    if let Err(e) = rec.record(st).and_then(|()| energy.drain(&mut rec.csv)) {
                        failure = Some(e);
                        return ControlFlow::Break(());
                    }
                    if rec.snapshots.len() > pictures {
                        pictured.push((st.step, st.time, st.x.clone()));
                    }
                    if options.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst)) {
                        interrupted = true;
                        return ControlFlow::Break(());
                    }
                    ControlFlow::Continue(())
                });
                match result {
                    Ok(part) => merge(&mut total, &part),
                    Err(e) => {
                        step_error = Some(e);
                        break;
                    }
                }
                let due = options.checkpoint_every.is_some_and(|e| e > 0 && state.step % e == 0);
                if failure.is_none() && state.step < scene.steps && (interrupted || due) {
                    let (warm, counters) = checkpoint::stepper_state(&stepper, &checkpoint::path_in(out))?;
                    let ck = checkpoint::Checkpoint {
                        fingerprint: fp.clone(),
                        state: state.clone(),
                        warm,
                        counters,
                        solver: stepper.solver_warm(),
                        stats: total.into(),
                        frames: rec.frames.iter().map(|f| (f.step, f.time, f.file.clone())).collect(),
                        pictured: pictured.clone(),
                        animation: rec.anim.as_ref().map(|a| a.frames().to_vec()).unwrap_or_default(),
                        energy_bytes: energy.bytes,
                    };
                    checkpoint::write(out, &ck)?;
                }
            }
            timings = stepper.counters;
            (step_error.map_or(Ok(total), Err), None)
        }
    };
    // The energy history up to a failure is still useful; it is complete as far as it goes.
    let stats = stats?;
    if let Some(e) = failure {
        return Err(e);
    }

    let final_mesh = CoonsSurface::new(&model.grid, &state.x).tessellate(scene.output.coons_subdivisions);
    let Recorder { frames, snapshots, anim, .. } = rec;
    let provenance = Provenance::of(scene, options, &fp, resume.as_ref().map(|ck| ck.state.step));
    let done = Finished { stats, timings, static_report, frames, interrupted, provenance };
    let summary = summary::summarize(scene, &state, &final_mesh, done);
    if let Some(field) = summary::non_finite(&summary) {
        return Err(RunError::NonFinite { stage: format!("the final state (summary field `{field}`)") });
    }
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

    // The summary last: its presence means the run completed (or, marked `interrupted`, stopped cleanly).
    let path = out.join("summary.json");
    atomic::write_atomic(&path, json.as_bytes()).map_err(io_err(&path))?;
    if !interrupted {
        // A finished run needs no checkpoint.
        remove_if_present(&checkpoint::path_in(out))?;
        folder.complete()?;
    }
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
    // The solver's own report may look converged (0 iterations, residual 0) when its arithmetic overflowed.
    if let Some(k) = state.x.iter().position(|p| !crate::math::finite(*p)) {
        return Err(RunError::NonFinite { stage: format!("the static solve (node {k})") });
    }
    if !(report.residual.is_finite() && report.potential.is_finite()) {
        return Err(RunError::NonFinite { stage: "the static solve (its residual or potential)".into() });
    }
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
