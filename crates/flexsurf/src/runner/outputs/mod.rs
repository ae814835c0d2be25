//! The files of a run, each kind an [`Output`]: it names the files it will write ([`Output::files`], claimed
//! in the manifest before any is written), records the steps ([`Output::record`]), saves and restores its own
//! state for checkpoints ([`Output::save`], [`Output::start`]), reports into what the run returns
//! ([`Output::report`]) and writes what needs the whole run ([`Output::finish`]). The runner only loops over
//! the list [`standard`] builds; each output's file names are defined once, in its own file:
//!
//! - [`frames`]: a Coons-tessellated frame at every output step (`frames/frame_NNNNN.obj`, `.ply` or `.gltf`);
//! - [`energy`]: `energy.csv`, one row per step, appended and flushed as the run goes, and `energy.png`;
//! - [`snapshots`]: `snapshots.png`, shaded pictures of up to [`MAX_SNAPSHOTS`] output steps;
//! - [`vtk`]: the ParaView series `vtk/frame_NNNNN.vtu` at every animation step, `animation.pvd` and
//!   `vtk/obstacles.vtu`;
//! - [`glb`]: `animation.glb`, the animated glTF of every animation step, written at the end.
//!
//! The output steps (`time.output_every`) have a frame file and may be pictured; the animation steps
//! (`output.animation_every`, every output step among them) are the frames of the animation and its fields.
//!
//! Adding an output is one file here (a type implementing [`Output`]) and one line in [`standard`].

pub mod energy;
pub mod frames;
pub mod garment;
pub mod glb;
pub mod snapshots;
pub mod vtk;

pub use frames::FrameRecord;
pub use snapshots::{
    obstacle_drawables, render_frame, view_for, Snapshot, CLOTH_COLOR, MAX_SNAPSHOTS, OBSTACLE_COLOR, PLANE_COLOR,
};

use super::apart::{display_mesh_with, ApartCache};
use super::fields::{frame_fields, FrameFields};
use super::{RunError, RunOutput, Summary};
use crate::scene::Scene;
use crate::state::State;
use crate::surface::TriMesh;
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::cell::OnceCell;
use std::path::PathBuf;

/// One kind of output of a run (see the module documentation for the order of the calls).
pub trait Output {
    /// The output's name: the key of its state in a checkpoint.
    fn name(&self) -> &'static str;

    /// Every file it may write, relative to the output folder; the runner claims them all in the manifest
    /// before any is written.
    fn files(&self) -> Vec<String>;

    /// Prepares its files before the first step is recorded: a fresh run (`None`), or a resumed one with the
    /// state [`Output::save`] gave at the checkpoint.
    fn start(&mut self, saved: Option<&OutputState>) -> Result<(), RunError>;

    /// Records a step (every step; [`Frame::mesh`] is there at the output steps, [`Frame::fields`] at the
    /// animation steps).
    fn record(&mut self, frame: &Frame<'_>) -> Result<(), RunError>;

    /// Its state for a checkpoint: what [`Output::start`] needs to go on byte-identically.
    fn save(&self) -> Result<OutputState, RunError>;

    /// Adds what it recorded to what the run returns (the summary's frames, the snapshots), before the
    /// summary is checked and written.
    fn report(&self, _run: &mut RunOutput) {}

    /// Writes the files that need the whole run (pictures, the animation), with the run's summary.
    fn finish(&mut self, _summary: &Summary) -> Result<(), RunError> {
        Ok(())
    }
}

/// An output's state in a checkpoint, serialised by the output itself ([`postcard`] bytes).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct OutputState(Vec<u8>);

impl OutputState {
    /// The state holding `value`.
    pub fn of<T: Serialize>(value: &T) -> Result<Self, RunError> {
        postcard::to_stdvec(value)
            .map(Self)
            .map_err(|e| RunError::Resume(format!("cannot encode an output's checkpoint state: {e}")))
    }

    /// The value [`OutputState::of`] stored, for the output `name`.
    pub fn get<T: DeserializeOwned>(&self, name: &str) -> Result<T, RunError> {
        postcard::from_bytes(&self.0)
            .map_err(|e| RunError::Resume(format!("cannot restore the state of output `{name}`: {e}")))
    }

    /// The value in `saved` (a resumed run) or the default (a fresh run), for the output `name`.
    pub fn or_default<T: DeserializeOwned + Default>(saved: Option<&Self>, name: &str) -> Result<T, RunError> {
        saved.map_or_else(|| Ok(T::default()), |s| s.get(name))
    }

    /// The error of a restored state that does not fit the run (a damaged or forged checkpoint).
    pub fn misfit(name: &str, what: String) -> RunError {
        RunError::Resume(format!("the checkpoint does not fit the scene (the `{name}` output's state: {what})"))
    }
}

/// What the outputs of a run share: the scene, the folder, the output steps and the animation steps.
#[derive(Debug, Clone)]
pub struct Context<'a> {
    /// The scene run.
    pub scene: &'a Scene,
    /// The output folder.
    pub out: PathBuf,
    /// The output steps (sorted): the steps with a frame file.
    pub steps: Vec<usize>,
    /// The animation steps (sorted, every output step among them): the frames of the animation.
    pub animation: Vec<usize>,
}

/// One recorded step: the state and, at an output step, its display mesh; at an animation step, its fields.
pub struct Frame<'a> {
    /// The state reached.
    pub state: &'a State,
    /// The Coons-tessellated display mesh of every panel (merged), at an output step only.
    pub mesh: Option<&'a TriMesh>,
    /// The same mesh at every animation step (an output step included).
    display: Option<&'a TriMesh>,
    scene: &'a Scene,
    fields: OnceCell<FrameFields>,
}

impl Frame<'_> {
    /// The display fields of an animation step (every output step is one), computed once for all outputs;
    /// `None` between animation steps.
    pub fn fields(&self) -> Option<&FrameFields> {
        let mesh = self.display?;
        let k = self.scene.output.coons_subdivisions.max(1);
        Some(self.fields.get_or_init(|| frame_fields(&self.scene.model, self.state, mesh, k)))
    }
}

/// The standard outputs of a run, in the order they claim, record and finish: one line each.
pub fn standard<'a>(cx: &Context<'a>) -> Vec<Box<dyn Output + 'a>> {
    vec![
        Box::new(frames::Frames::new(cx)),
        Box::new(energy::Energy::new(cx)),
        Box::new(snapshots::Snapshots::new(cx)),
        Box::new(vtk::VtkSeries::new(cx)),
        Box::new(glb::GlbAnimation::new(cx)),
        Box::new(garment::Garment::new(cx)),
    ]
}

/// The outputs of one run, driven together by the runner.
pub(crate) struct Outputs<'a> {
    cx: Context<'a>,
    list: Vec<Box<dyn Output + 'a>>,
    /// The display meshes' searches kept from frame to frame.
    apart: ApartCache,
}

impl<'a> Outputs<'a> {
    /// The outputs `list` of the run `cx`.
    pub fn new(cx: Context<'a>, list: Vec<Box<dyn Output + 'a>>) -> Self {
        Self { cx, list, apart: ApartCache::default() }
    }

    /// Every file of every output, in their order.
    pub fn files(&self) -> Vec<String> {
        self.list.iter().flat_map(|o| o.files()).collect()
    }

    /// Starts every output: fresh, or from the states of a checkpoint (by output name).
    pub fn start(&mut self, saved: Option<&[(String, OutputState)]>) -> Result<(), RunError> {
        for o in &mut self.list {
            let state = match saved {
                None => None,
                Some(all) => Some(all.iter().find(|(n, _)| n == o.name()).map(|(_, s)| s).ok_or_else(|| {
                    RunError::Resume(format!("the checkpoint holds no state of the output `{}`", o.name()))
                })?),
            };
            o.start(state)?;
        }
        Ok(())
    }

    /// Records `state` in every output, with its display mesh at an animation step (and as the frame's mesh at
    /// an output step).
    pub fn record(&mut self, state: &State) -> Result<(), RunError> {
        let scene = self.cx.scene;
        let k = scene.output.coons_subdivisions;
        let animated = self.cx.animation.binary_search(&state.step).is_ok();
        let display = animated.then(|| display_mesh_with(&scene.model, &state.x, k, &mut self.apart));
        let mesh = display.as_ref().filter(|_| self.cx.steps.binary_search(&state.step).is_ok());
        let frame = Frame { state, mesh, display: display.as_ref(), scene, fields: OnceCell::new() };
        self.list.iter_mut().try_for_each(|o| o.record(&frame))
    }

    /// The states of every output for a checkpoint, by name.
    pub fn save(&self) -> Result<Vec<(String, OutputState)>, RunError> {
        self.list.iter().map(|o| Ok((o.name().to_string(), o.save()?))).collect()
    }

    /// Lets every output report into `run`.
    pub fn report(&self, run: &mut RunOutput) {
        self.list.iter().for_each(|o| o.report(run));
    }

    /// Finishes every output.
    pub fn finish(&mut self, summary: &Summary) -> Result<(), RunError> {
        self.list.iter_mut().try_for_each(|o| o.finish(summary))
    }
}

/// The output steps of a run: 0, every `every` steps, and the last step.
pub fn output_steps(steps: usize, every: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..=steps).step_by(every.max(1)).collect();
    if v.last() != Some(&steps) {
        v.push(steps);
    }
    v
}

/// The animation steps of a run: 0, every `animation_every` steps, every output step and the last step.
pub fn animation_steps(steps: usize, output_every: usize, animation_every: usize) -> Vec<usize> {
    let mut v = output_steps(steps, animation_every);
    v.extend(output_steps(steps, output_every));
    v.sort_unstable();
    v.dedup();
    v
}
