//! The frames: the display mesh of every panel (merged into one mesh) at every output step, as
//! `frames/frame_NNNNN.EXT` in the scene's frame format (OBJ, PLY or glTF, [`FrameFormat::writer`]).

use super::{Context, Frame, Output, OutputState, RunOutput};
use crate::runner::{io_err, RunError};
use crate::scene::{FrameFormat, Scene};
use crate::surface::TriMesh;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The folder of the frames, relative to the output folder.
pub const FRAMES_DIR: &str = "frames";

/// One written frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// Step.
    pub step: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Path relative to the output directory.
    pub file: String,
}

/// The frame file of `step` in `format`, relative to the output folder.
pub fn frame_file(step: usize, format: FrameFormat) -> String {
    format!("{FRAMES_DIR}/frame_{step:05}.{}", format.extension())
}

/// Writes `mesh` in `format` (atomically; see [`FrameFormat::writer`]).
pub fn write_mesh(path: &Path, mesh: &TriMesh, format: FrameFormat) -> std::io::Result<()> {
    (format.writer().write)(path, mesh)
}

/// The frames output.
pub struct Frames<'a> {
    scene: &'a Scene,
    out: PathBuf,
    steps: Vec<usize>,
    written: Vec<FrameRecord>,
}

impl<'a> Frames<'a> {
    /// The frames of the run `cx`.
    pub fn new(cx: &Context<'a>) -> Self {
        Self { scene: cx.scene, out: cx.out.clone(), steps: cx.steps.clone(), written: Vec::new() }
    }
}

impl Output for Frames<'_> {
    fn name(&self) -> &'static str {
        "frames"
    }

    fn files(&self) -> Vec<String> {
        self.steps.iter().map(|&s| frame_file(s, self.scene.output.format)).collect()
    }

    fn start(&mut self, saved: Option<&OutputState>) -> Result<(), RunError> {
        self.written = OutputState::or_default(saved, self.name())?;
        let most = self.steps.len();
        let sane = |f: &FrameRecord| f.time.is_finite() && !f.file.contains("..") && !f.file.starts_with('/');
        if self.written.len() > most || !self.written.iter().all(sane) {
            return Err(OutputState::misfit(
                self.name(),
                format!("more than the run's {most} frames, or not frame files"),
            ));
        }
        Ok(())
    }

    fn record(&mut self, frame: &Frame<'_>) -> Result<(), RunError> {
        let Some(mesh) = frame.mesh else { return Ok(()) };
        let (step, time) = (frame.state.step, frame.state.time);
        let file = frame_file(step, self.scene.output.format);
        let path = self.out.join(&file);
        write_mesh(&path, mesh, self.scene.output.format).map_err(io_err(&path))?;
        self.written.push(FrameRecord { step, time, file });
        Ok(())
    }

    fn save(&self) -> Result<OutputState, RunError> {
        OutputState::of(&self.written)
    }

    fn report(&self, run: &mut RunOutput) {
        run.summary.frames.clone_from(&self.written);
    }
}
