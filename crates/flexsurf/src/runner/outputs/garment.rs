//! The welded garment: at every output step of a model with seams, one mesh of the whole garment with the
//! seams' vertices merged (the frame's display mesh through [`crate::runner::fields::weld`]), as
//! `garment/garment_NNNNN.obj`. Models without seams write nothing.

use super::{Context, Frame, Output, OutputState};
use crate::runner::fields::weld;
use crate::runner::{io_err, RunError};
use crate::scene::{FrameFormat, Scene};
use std::path::PathBuf;

/// The folder of the garment meshes, relative to the output folder.
pub const GARMENT_DIR: &str = "garment";

/// The garment mesh file of `step`, relative to the output folder.
pub fn garment_file(step: usize) -> String {
    format!("{GARMENT_DIR}/garment_{step:05}.obj")
}

/// The welded garment output.
pub struct Garment<'a> {
    scene: &'a Scene,
    out: PathBuf,
    steps: Vec<usize>,
}

impl<'a> Garment<'a> {
    /// The garment meshes of the run `cx` (none without seams).
    pub fn new(cx: &Context<'a>) -> Self {
        let steps = if cx.scene.model.seams.is_empty() { Vec::new() } else { cx.steps.clone() };
        Self { scene: cx.scene, out: cx.out.clone(), steps }
    }
}

impl Output for Garment<'_> {
    fn name(&self) -> &'static str {
        "garment"
    }

    fn files(&self) -> Vec<String> {
        self.steps.iter().map(|&s| garment_file(s)).collect()
    }

    fn start(&mut self, _saved: Option<&OutputState>) -> Result<(), RunError> {
        if self.steps.is_empty() {
            return Ok(());
        }
        let dir = self.out.join(GARMENT_DIR);
        std::fs::create_dir_all(&dir).map_err(io_err(&dir))
    }

    fn record(&mut self, frame: &Frame<'_>) -> Result<(), RunError> {
        let Some(display) = frame.mesh.filter(|_| self.steps.binary_search(&frame.state.step).is_ok()) else {
            return Ok(());
        };
        // The frame's display mesh (bulges already cut apart), welded along the seams.
        let mesh = weld(&self.scene.model, display, self.scene.output.coons_subdivisions);
        let path = self.out.join(garment_file(frame.state.step));
        super::frames::write_mesh(&path, &mesh, FrameFormat::Obj).map_err(io_err(&path))
    }

    fn save(&self) -> Result<OutputState, RunError> {
        OutputState::of(&())
    }
}
