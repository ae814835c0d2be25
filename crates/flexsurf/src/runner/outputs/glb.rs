//! `animation.glb` at the end of a run: the animated glTF of [`crate::io::glb`] (the display surface of every
//! panel, merged into the one cloth mesh, at every animation step: `output.animation_every`, every output step
//! among them) with the obstacles. It needs every frame, so
//! the frames' display fields are kept in memory (single precision: about 52 bytes per display vertex and
//! frame) and in checkpoints.

use super::{vtk::scene_obstacles, Context, Frame, Output, OutputState};
use crate::io::glb::{self, Animation, GlbFrame, GlbMesh};
use crate::runner::fields::{display_topology, FrameFields};
use crate::runner::plots::run_info;
use crate::runner::{io_err, remove_if_present, RunError, Summary};
use crate::scene::Scene;
use std::path::PathBuf;

/// The animation, relative to the output folder.
pub const GLB_FILE: &str = "animation.glb";
/// Base colour (linear RGBA) of the cloth in the `.glb`.
pub const GLB_CLOTH_COLOR: [f64; 4] = [0.55, 0.09, 0.05, 1.0];
/// Base colour (linear RGBA) of the obstacles in the `.glb`.
pub const GLB_OBSTACLE_COLOR: [f64; 4] = [0.30, 0.35, 0.43, 1.0];
/// Base colour (linear RGBA) of a ground plane in the `.glb`.
pub const GLB_PLANE_COLOR: [f64; 4] = [0.68, 0.68, 0.66, 1.0];

/// The animation output.
pub struct GlbAnimation<'a> {
    scene: &'a Scene,
    out: PathBuf,
    frames: Vec<FrameFields>,
}

impl<'a> GlbAnimation<'a> {
    /// The animation of the run `cx`.
    pub fn new(cx: &Context<'a>) -> Self {
        Self { scene: cx.scene, out: cx.out.clone(), frames: Vec::new() }
    }
}

impl Output for GlbAnimation<'_> {
    fn name(&self) -> &'static str {
        "glb"
    }

    fn files(&self) -> Vec<String> {
        vec![GLB_FILE.to_string()]
    }

    fn start(&mut self, saved: Option<&OutputState>) -> Result<(), RunError> {
        // An earlier run's animation would stand for this one until it finishes (the viewer reads the VTK
        // series of a run in progress instead).
        remove_if_present(&self.out.join(GLB_FILE))?;
        self.frames = OutputState::or_default(saved, self.name())?;
        let vertices = display_topology(&self.scene.model.panels, self.scene.output.coons_subdivisions.max(1)).uv.len();
        let fits = |f: &FrameFields| {
            let sizes = [f.positions.len(), f.normals.len(), f.velocity.len(), f.strain.len(), f.pressure.len()];
            f.time.is_finite() && sizes.iter().all(|&s| s == vertices)
        };
        if !self.frames.iter().all(fits) {
            return Err(OutputState::misfit(
                self.name(),
                format!("frames not of the display mesh's {vertices} vertices"),
            ));
        }
        Ok(())
    }

    fn record(&mut self, frame: &Frame<'_>) -> Result<(), RunError> {
        if let Some(f) = frame.fields() {
            self.frames.push(f.clone());
        }
        Ok(())
    }

    fn save(&self) -> Result<OutputState, RunError> {
        OutputState::of(&self.frames)
    }

    fn finish(&mut self, summary: &Summary) -> Result<(), RunError> {
        if self.frames.is_empty() {
            return Ok(());
        }
        let topology = display_topology(&self.scene.model.panels, self.scene.output.coons_subdivisions.max(1));
        let frames: Vec<GlbFrame<'_>> = self.frames.iter().map(FrameFields::glb).collect();
        let obstacles: Vec<GlbMesh> = scene_obstacles(self.scene)
            .into_iter()
            .map(|(name, mesh, plane)| GlbMesh {
                name,
                mesh,
                color: if plane { GLB_PLANE_COLOR } else { GLB_OBSTACLE_COLOR },
            })
            .collect();
        let info = run_info(self.scene, summary);
        let anim = Animation {
            triangles: &topology.triangles,
            uv: &topology.uv,
            frames: &frames,
            obstacles: &obstacles,
            cloth_color: GLB_CLOTH_COLOR,
            info: &info,
        };
        let path = self.out.join(GLB_FILE);
        glb::write_glb(&path, &anim).map_err(io_err(&path))
    }
}
