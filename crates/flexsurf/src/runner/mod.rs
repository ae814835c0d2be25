//! Running a built [`Scene`] into an output directory: the layer above [`crate::scene`] (which only reads and
//! builds scenes) that the CLI and the tests call. [`run_scene`] steps the scene with [`crate::sim::run`] (or
//! solves it with the static solver) and hands every step to the run's outputs ([`outputs`]: the frames,
//! `energy.csv`, the VTK series, `animation.glb`, `snapshots.png`, each an [`Output`]), then writes
//! `summary.json` last. Every file is written atomically ([`crate::io::atomic`]), so a run that fails (a
//! diverging step) leaves only complete files behind, and no `summary.json` of its own.
//!
//! - [`outputs`]: the [`Output`] trait and the standard outputs, one file each.
//! - [`fields`]: the display surface of every panel and its per-vertex fields, shared by the outputs.
//! - [`summary`]: `summary.json` and the measures of the final configuration.
//! - [`manifest`]: the output folder's `manifest.json`: refusing, overwriting and cleaning safely.
//! - [`checkpoint`]: `checkpoint.bin`, written every `--checkpoint-every` steps and when stopped, and resumed.
//! - [`provenance`]: the version, command line, input hashes, material and solver settings of a summary.
//! - [`viewer`]: `view.html` and the movies of a run folder, read back from the files the outputs wrote (it
//!   sits above the outputs; nothing here depends on it).
//!
//! `energy.csv` is appended and flushed row by row as the run goes, so a kill keeps the history so far.

pub mod apart;
pub mod checkpoint;
pub mod fields;
pub mod manifest;
pub mod outputs;
pub mod plots;
pub mod provenance;
mod run;
pub mod summary;
pub mod viewer;

pub use outputs::frames::write_mesh;
pub use outputs::{
    obstacle_drawables, output_steps, render_frame, view_for, Context, Frame, FrameRecord, Output, OutputState,
    Snapshot, CLOTH_COLOR, MAX_SNAPSHOTS, OBSTACLE_COLOR, PLANE_COLOR,
};
pub use provenance::Provenance;
pub use summary::{waist_drift, FinalState, Summary};

use crate::integrate::StepError;
use crate::io::atomic;
use crate::scene::Scene;
use crate::state::State;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use thiserror::Error;

/// The summary's file name in the output folder: written last, its presence means the run completed.
pub const SUMMARY_FILE: &str = "summary.json";

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
    /// A pinned set could not be moved along its `[[pin]] motion`.
    #[error("pin motion: {0}")]
    Motion(#[from] crate::model::ModelError),
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
            scene.method(),
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

/// As [`run_scene_observed`], with `options`: the output folder's manifest ([`manifest`]), periodic and
/// on-stop checkpoints, resuming ([`checkpoint`]), and provenance in the summary.
pub fn run_scene_with(
    scene: &Scene,
    out: &Path,
    options: &RunOptions,
    observe: impl FnMut(&State),
) -> Result<RunOutput, RunError> {
    run_scene_with_outputs(scene, out, options, Vec::new(), observe)
}

/// As [`run_scene_with`], with the outputs `extra` besides the standard ones ([`outputs::standard`]): their
/// files are claimed, they record every step, are saved in checkpoints and finish with the others.
pub fn run_scene_with_outputs<'a>(
    scene: &'a Scene,
    out: &'a Path,
    options: &'a RunOptions,
    extra: Vec<Box<dyn Output + 'a>>,
    mut observe: impl FnMut(&State),
) -> Result<RunOutput, RunError> {
    run::run(scene, out, options, extra, &mut observe)
}

fn remove_if_present(path: &Path) -> Result<(), RunError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(io_err(path)(e)),
        _ => Ok(()),
    }
}

/// Writes `text` to `path` atomically, creating its directory.
pub fn write_text(path: &Path, text: &str) -> Result<(), RunError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    }
    atomic::write_atomic_with(path, |w: &mut dyn Write| w.write_all(text.as_bytes())).map_err(io_err(path))
}
