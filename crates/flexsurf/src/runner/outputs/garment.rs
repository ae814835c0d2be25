//! The welded garment: at every output step of a model with seams, one mesh of the whole garment with the
//! seams' vertices merged (the frame's display mesh through [`crate::runner::fields::weld`]), as
//! `garment/garment_NNNNN.obj`, with each display vertex's pattern coordinates as texture coordinates (metres
//! along its panel's grain and across it, [`crate::runner::fields::display_topology`]; a seam's welded vertex
//! keeps one on each side). Models without seams write nothing.

use super::{Context, Frame, Output, OutputState};
use crate::io::obj::write_obj_textured;
use crate::runner::fields::{display_topology, weld};
use crate::runner::{io_err, RunError};
use crate::scene::Scene;
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
    /// The display vertices' pattern coordinates.
    uv: Vec<[f32; 2]>,
}

impl<'a> Garment<'a> {
    /// The garment meshes of the run `cx` (none without seams).
    pub fn new(cx: &Context<'a>) -> Self {
        let steps = if cx.scene.model.seams.is_empty() { Vec::new() } else { cx.steps.clone() };
        let uv = if steps.is_empty() {
            Vec::new()
        } else {
            display_topology(&cx.scene.model.panels, cx.scene.output.coons_subdivisions.max(1)).uv
        };
        Self { scene: cx.scene, out: cx.out.clone(), steps, uv }
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
        write_obj_textured(&path, &mesh, &self.uv, &display.triangles).map_err(io_err(&path))
    }

    fn save(&self) -> Result<OutputState, RunError> {
        OutputState::of(&())
    }
}
