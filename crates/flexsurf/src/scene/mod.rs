//! Scenes: the typed TOML description of a run (sheet or garment, material, model, time step, integrator,
//! obstacles, contact, pins, springs, output) and its validation into a [`Model`](crate::model::Model) and an
//! initial [`State`](crate::state::State).
//!
//! It sits between the physics and the front ends, and does one job: read a scene, check it, build it. Running
//! a built [`Scene`] and writing its outputs is the runner layer above it. Every error names the file, the dotted
//! key (`time.dt`, `obstacle[0].sphere.radius`) and what is wrong. The format is documented in `docs/scenes.md`.
//!
//! - `spec.rs`: [`SceneSpec`] and the types of its tables, plain serde data (`deny_unknown_fields`), every
//!   default in [`defaults`], and the JSON schema ([`SceneSpec::json_schema`]).
//! - [`material`]: `[material]` and material files (presets, SI, KES-F and FAST units) resolved to SI constants.
//! - [`initial`]: `[initial]`, the initial velocities and positions.
//! - [`motion`]: `[[pin]] motion`, pinned sets carried along a prescribed rigid motion.
//! - [`garment`]: `[garment]`, its check, and the call into [`crate::garment`], which builds the skirt.
//! - [`pattern`]: pattern files (`garments/*.toml`) and `[pattern]`, a garment sewn from one
//!   ([`crate::garment::pattern`], [`crate::garment::sewing`]).
//! - `values.rs`: the check of every value of a scene (each key once), into the parts a model is built from.
//! - `build.rs`: [`SceneSpec::build`], which checks every value and builds the [`Scene`] (model, initial state,
//!   run settings), and [`SceneSpec::check_with`], which checks without building the model.
//! - [`ranges`]: the range table, one entry per numeric key: its sign rule, its hard bounds (an error beyond)
//!   and, for the fabric's physical quantities, its usual range in SI and KES-F units (a [`SceneWarning`]
//!   beyond).
//! - `validate.rs`: the one value checker the other files share, so a check reads the same wherever it is made.
//! - `error.rs`: [`SceneError`], [`SceneWarning`] and the TOML reader that locates parse errors.
//! - [`spans`]: the dotted key at a byte offset of TOML text, from the parser's spans, for those errors.
//! - [`arcsim`]: ARCSim's measured-material JSON files (`arcsim = "file.json"` in `[material]` or a material
//!   file) read into the per-direction laws.
//! - [`budget`]: the size and memory estimate checked before anything large is allocated.

pub mod arcsim;
pub mod budget;
mod build;
mod error;
pub mod garment;
pub mod initial;
pub mod material;
pub mod motion;
pub mod pattern;
pub use crate::ranges;
pub mod spans;
mod spec;
mod validate;
mod values;

pub use budget::Limits;
pub use build::{Scene, SceneReport, SewingInfo};
pub(crate) use error::parse_toml;
pub use error::{SceneError, SceneWarning};
pub use garment::{GarmentInfo, GarmentKind, GarmentSpec, WaistFit, Warp};
pub use initial::{InitialCondition, InitialSpec};
pub use material::{MaterialSpec, Preset, Units};
pub use pattern::{PatternSpec, PatternUse};
pub use spec::{
    defaults, BuiltinBody, ContactSpec, FrameFormat, Initial, IntegratorKind, IntegratorSpec, MeshSpec, ModelSpec,
    MotionSpec, NamedSet, NodeSetSpec, NurbsSpec, ObstacleSpec, OutputSpec, PlaneSpec, SceneSpec, SheetSpec, Sheets,
    SphereSpec, SpringSpec, SpringTarget, TimeSpec,
};

use std::path::Path;

/// Reads, parses and builds the scene file at `path`.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    load_with(path, &Limits::default())
}

/// As [`load`] with the resource `limits`.
pub fn load_with(path: &Path, limits: &Limits) -> Result<Scene, SceneError> {
    SceneSpec::load(path)?.build_with(path, limits)
}

/// Reads, parses and checks the scene file at `path` with the resource `limits`, without building its model
/// ([`SceneSpec::check_with`]).
pub fn check_with(path: &Path, limits: &Limits) -> Result<SceneReport, SceneError> {
    SceneSpec::load(path)?.check_with(path, limits)
}
