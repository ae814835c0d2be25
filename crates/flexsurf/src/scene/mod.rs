//! Scenes: the typed TOML description of a run (sheet, material, model, time step, integrator, obstacles,
//! contact, pins, springs, output) and its validation into a [`Model`] and an initial [`State`].
//!
//! It sits between the physics and the front ends: [`SceneSpec`] is plain serde data (`deny_unknown_fields`,
//! defaults in [`defaults`], a JSON schema through `schemars`), [`SceneSpec::build`] checks every value and builds
//! a [`Scene`], and [`run`] drives a scene into an output directory. Every error names the file, the dotted key
//! (`time.dt`, `obstacle[0].sphere.radius`) and what is wrong. The format is documented in `docs/scenes.md`.

pub mod garment;
pub mod keys;
pub mod material;
pub mod run;

use crate::contact::nurbs::NurbsBody;
use crate::contact::trimesh::TriMeshBody;
use crate::contact::{mannequin, Obstacle};
use crate::grid::{Grid, Topology};
use crate::integrate::statics::StaticOptions;
use crate::integrate::{linsolve::SolverKind, Method, Scheme, StepParams};
use crate::material::{Calibration, Stiffness};
use crate::math::{Mat3, Vec3};
use crate::model::{ElasticOptions, Model, ModelBuilder, ModelKind, Spring};
use crate::potential::contact::ContactParams;
use crate::state::State;
pub use garment::{GarmentInfo, GarmentKind, GarmentSpec, WaistFit, Warp};
pub use material::{MaterialSpec, Preset, Units};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;

/// Every default of the scene format, in one place.
pub mod defaults {
    /// Gravity (m/s²).
    pub const GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];
    /// Time step (s).
    pub const DT: f64 = 0.01;
    /// Penalty contact stiffness `c` (N/m³).
    pub const CONTACT_STIFFNESS: f64 = 1e4;
    /// Contact offset `δ` (m).
    pub const CONTACT_OFFSET: f64 = 0.005;
    /// Coulomb friction coefficient.
    pub const CONTACT_FRICTION: f64 = 0.0;
    /// Coons sub-quads per cell edge in frames and pictures.
    pub const COONS_SUBDIVISIONS: usize = 4;
    /// Size of one picture of the snapshot panel (pixels).
    pub const IMAGE_SIZE: [u32; 2] = [480, 360];
    /// Resolution of the raster that measures the projected (footprint) area.
    pub const FOOTPRINT_RESOLUTION: usize = 1024;
}

/// A scene that cannot be read or used. Each message names the file and the dotted key.
#[derive(Debug, Error)]
pub enum SceneError {
    /// The file cannot be read.
    #[error("{file}: cannot read the file")]
    Io {
        /// The file.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// Malformed TOML, an unknown key, a missing key, or a value of the wrong type or an unknown name.
    #[error("{file}:{line}:{column}: `{key}`: {message}")]
    Parse {
        /// The file.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column (1-based).
        column: usize,
        /// Dotted key path.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A value that parses but cannot be used (non-finite, non-positive, out of range, inconsistent).
    #[error("{file}: `{key}`: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// Dotted key path.
        key: String,
        /// What is wrong.
        message: String,
    },
}

impl SceneError {
    pub(crate) fn io(file: &Path, source: std::io::Error) -> Self {
        SceneError::Io { file: file.display().to_string(), source }
    }

    pub(crate) fn invalid(file: &Path, key: String, message: String) -> Self {
        SceneError::Invalid { file: file.display().to_string(), key, message }
    }

    /// The dotted key the error is about (empty for an unreadable file).
    pub fn key(&self) -> &str {
        match self {
            SceneError::Io { .. } => "",
            SceneError::Parse { key, .. } | SceneError::Invalid { key, .. } => key,
        }
    }
}

/// Parses TOML text read from `file` into `T`, turning the error span into a line, a column and a key path.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, file: &Path) -> Result<T, SceneError> {
    toml::from_str(text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        let (line, column) = keys::line_col(text, span.start);
        let message = e.message().trim().to_string();
        let mut key = keys::key_at(text, span.start);
        if let Some(field) = message.strip_prefix("missing field `").and_then(|s| s.split('`').next()) {
            key = if key.is_empty() { field.to_string() } else { format!("{key}.{field}") };
        }
        if key.is_empty() {
            key = "(top level)".to_string();
        }
        SceneError::Parse { file: file.display().to_string(), line, column, key, message }
    })
}

/// A whole scene file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// A name for summaries (default: the file stem).
    #[serde(default)]
    pub name: Option<String>,
    /// Free text.
    #[serde(default)]
    pub description: Option<String>,
    /// How measured constants become energy coefficients (`kes`, default, or `paper`).
    #[serde(default)]
    pub calibration: Calibration,
    /// Gravity (m/s²), default `[0, 0, -9.81]`.
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// The sheet: size, nodes, placement, topology. Exactly one of `sheet` and `garment` is given.
    #[serde(default)]
    pub sheet: Option<SheetSpec>,
    /// A garment (a skirt) fitted onto the obstacles, in place of `sheet`.
    #[serde(default)]
    pub garment: Option<GarmentSpec>,
    /// The fabric (default: the `paper-cotton` preset).
    #[serde(default = "default_material")]
    pub material: MaterialSpec,
    /// The deformation model.
    #[serde(default)]
    pub model: ModelSpec,
    /// Time step, steps and output cadence.
    pub time: TimeSpec,
    /// Time-stepping scheme and linear solver.
    #[serde(default)]
    pub integrator: IntegratorSpec,
    /// Rigid obstacles (`[[obstacle]]`).
    #[serde(default, rename = "obstacle")]
    pub obstacles: Vec<ObstacleSpec>,
    /// Penalty contact with the obstacles.
    #[serde(default)]
    pub contact: ContactSpec,
    /// Pinned nodes (`[[pin]]`), held exactly at their initial position.
    #[serde(default, rename = "pin")]
    pub pins: Vec<NodeSetSpec>,
    /// Constraint springs (`[[spring]]`).
    #[serde(default, rename = "spring")]
    pub springs: Vec<SpringSpec>,
    /// What a run writes.
    #[serde(default)]
    pub output: OutputSpec,
}

fn default_gravity() -> [f64; 3] {
    defaults::GRAVITY
}

fn default_material() -> MaterialSpec {
    MaterialSpec { preset: Some(Preset::PaperCotton), ..MaterialSpec::default() }
}

/// The sheet: a rectangle of `size` metres with `nodes` grid nodes, centred at `center`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SheetSpec {
    /// Pattern lengths `[L1, L2]` along u1 (warp) and u2 (weft), metres. Along a periodic direction, the
    /// circumference.
    pub size: [f64; 2],
    /// Nodes `[M, N]` along u1 and u2, at least 3 each.
    pub nodes: [usize; 2],
    /// Position of the sheet's centre (m), default the origin.
    #[serde(default)]
    pub center: [f64; 3],
    /// `free` or `periodic` per direction, default both `free`. One periodic direction rolls the sheet into a
    /// cylinder about the z axis (radius circumference/2π), the other direction running along z.
    #[serde(default)]
    pub topology: [Topology; 2],
    /// Initial rotation about the x, then y, then z axis through the centre (degrees), default none. The
    /// rotated flat sheet is its own rest shape.
    #[serde(default)]
    pub rotate_deg: [f64; 3],
}

/// `[model]`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// `tfs` (the paper's model, default) or `terzopoulos`.
    #[serde(default)]
    pub kind: ModelKind,
}

/// `[time]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// Time step Δt (s), default 0.01.
    #[serde(default = "default_dt")]
    pub dt: f64,
    /// Number of steps.
    pub steps: usize,
    /// Write a frame every this many steps (and at step 0 and the last step); default: only the first and last.
    #[serde(default)]
    pub output_every: Option<usize>,
}

fn default_dt() -> f64 {
    defaults::DT
}

// The `integrator.kind` of a scene: a time-stepping scheme, or `static` for a static solve (the doc line
// below is the JSON schema's text, kept as it was).
/// The time-stepping scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorKind {
    /// Linearised implicit step with `H⁺` (default).
    #[default]
    Linearized,
    /// The paper's literal lagged-coefficient step.
    Lagged,
    /// No time stepping: the quasi-static equilibrium (drape) by projected Newton ([`statics`]). A run then
    /// writes the initial and the equilibrium frame.
    Static,
}

impl IntegratorKind {
    /// Name used in scenes and summaries.
    pub fn name(&self) -> &'static str {
        match self {
            IntegratorKind::Linearized => "linearized",
            IntegratorKind::Lagged => "lagged",
            IntegratorKind::Static => "static",
        }
    }

    /// The run this kind asks for, with time step `dt` and linear solver `solver`.
    pub fn method(&self, dt: f64, solver: SolverKind) -> Method {
        let dynamic = |scheme| Method::Dynamic(StepParams { dt, scheme, solver, ..StepParams::default() });
        match self {
            IntegratorKind::Linearized => dynamic(Scheme::Linearized),
            IntegratorKind::Lagged => dynamic(Scheme::Lagged),
            IntegratorKind::Static => Method::Static(StaticOptions::default()),
        }
    }
}

/// `[integrator]`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `linearized` (default, unconditionally stable) or `lagged` (the paper's literal scheme, needs tiny steps).
    #[serde(default)]
    pub kind: IntegratorKind,
    /// `cholesky` (default) or `pcg`.
    #[serde(default)]
    pub solver: SolverKind,
}

/// A rigid obstacle, written `sphere = { ... }`, `plane = { ... }`, `nurbs = { ... }` or `mesh = { ... }` inside
/// `[[obstacle]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ObstacleSpec {
    /// A solid ball.
    Sphere(SphereSpec),
    /// A half-space.
    Plane(PlaneSpec),
    /// A closed body of NURBS patches: a body file or a built-in body.
    Nurbs(NurbsSpec),
    /// A closed triangle mesh from a Wavefront OBJ file.
    Mesh(MeshSpec),
}

/// A built-in body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum BuiltinBody {
    /// The paper's 22-patch lower-body mannequin (`docs/mannequin.md`).
    Mannequin,
}

/// A NURBS body: exactly one of `file` (a body file in the format of `bodies/mannequin.toml`, relative to the
/// scene file) and `builtin`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NurbsSpec {
    /// Body file, relative to the scene file.
    #[serde(default)]
    pub file: Option<PathBuf>,
    /// `mannequin`: the built-in mannequin.
    #[serde(default)]
    pub builtin: Option<BuiltinBody>,
}

/// A closed triangle mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Wavefront OBJ file, relative to the scene file.
    pub file: PathBuf,
}

/// A solid ball.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Centre (m).
    pub center: [f64; 3],
    /// Radius (m).
    pub radius: f64,
}

/// The half-space below a plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlaneSpec {
    /// A point on the plane (m).
    pub point: [f64; 3],
    /// Outward normal (normalised on load), default `[0, 0, 1]`.
    #[serde(default = "default_normal")]
    pub normal: [f64; 3],
}

fn default_normal() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

/// `[contact]`: penalty pressure `c (δ − d)` below distance `δ`, times the node's area.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ContactSpec {
    /// Penalty `c`, pressure per penetration depth (N/m³), default 1e4.
    pub stiffness: f64,
    /// Contact offset `δ` (m), default 0.005.
    pub offset: f64,
    /// Coulomb friction coefficient μ, default 0.
    pub friction: f64,
}

impl Default for ContactSpec {
    fn default() -> Self {
        Self {
            stiffness: defaults::CONTACT_STIFFNESS,
            offset: defaults::CONTACT_OFFSET,
            friction: defaults::CONTACT_FRICTION,
        }
    }
}

/// A named set of nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub enum NamedSet {
    /// The four corners (free directions only).
    #[serde(rename = "corners")]
    Corners,
    /// The edge u1 = 0 (nodes `[0, j]`).
    #[serde(rename = "edge_u1_0")]
    EdgeU1Start,
    /// The edge u1 = L1 (nodes `[M−1, j]`).
    #[serde(rename = "edge_u1_1")]
    EdgeU1End,
    /// The edge u2 = 0 (nodes `[i, 0]`).
    #[serde(rename = "edge_u2_0")]
    EdgeU2Start,
    /// The edge u2 = L2 (nodes `[i, N−1]`).
    #[serde(rename = "edge_u2_1")]
    EdgeU2End,
    /// Every node.
    #[serde(rename = "all")]
    All,
}

/// Nodes given by a named set and/or explicit `[i, j]` pairs (`i` along u1, `j` along u2, from 0).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NodeSetSpec {
    /// A named set.
    #[serde(default)]
    pub set: Option<NamedSet>,
    /// Explicit nodes `[[i, j], ...]`.
    #[serde(default)]
    pub nodes: Vec<[usize; 2]>,
}

/// The word `initial`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Initial {
    /// Each node's initial position.
    Initial,
}

/// Where a spring pulls.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum SpringTarget {
    /// `"initial"`: each node's own initial position.
    Initial(Initial),
    /// One point (m) for all the spring's nodes.
    Point([f64; 3]),
}

/// `[[spring]]`: force `k (target − x)` on each node of the set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SpringSpec {
    /// A named set.
    #[serde(default)]
    pub set: Option<NamedSet>,
    /// Explicit nodes `[[i, j], ...]`.
    #[serde(default)]
    pub nodes: Vec<[usize; 2]>,
    /// `"initial"` (default) or a point `[x, y, z]`.
    #[serde(default = "default_target")]
    pub target: SpringTarget,
    /// Stiffness k per node (N/m).
    pub stiffness: f64,
}

fn default_target() -> SpringTarget {
    SpringTarget::Initial(Initial::Initial)
}

/// Mesh format of the frames.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum FrameFormat {
    /// Wavefront OBJ with normals (default).
    #[default]
    Obj,
    /// Binary little-endian PLY with normals.
    Ply,
    /// glTF 2.0 with embedded buffers.
    Gltf,
}

impl FrameFormat {
    /// File extension.
    pub fn extension(&self) -> &'static str {
        match self {
            FrameFormat::Obj => "obj",
            FrameFormat::Ply => "ply",
            FrameFormat::Gltf => "gltf",
        }
    }
}

/// `[output]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    /// Coons sub-quads per cell edge in frames and pictures, default 4.
    pub coons_subdivisions: usize,
    /// Pixel size `[width, height]` of one picture of the snapshot panel, default `[480, 360]`.
    pub image_size: [u32; 2],
    /// Mesh format of the frames: `obj` (default), `ply` or `gltf`.
    pub format: FrameFormat,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            coons_subdivisions: defaults::COONS_SUBDIVISIONS,
            image_size: defaults::IMAGE_SIZE,
            format: FrameFormat::Obj,
        }
    }
}

/// A validated scene, ready to run.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Name for summaries.
    pub name: String,
    /// The scene file (for messages).
    pub file: PathBuf,
    /// The model.
    pub model: Model,
    /// The initial state.
    pub state: State,
    /// Time step (s).
    pub dt: f64,
    /// Steps to take.
    pub steps: usize,
    /// Frame cadence (steps).
    pub output_every: usize,
    /// A dynamic integration (its step parameters) or a static solve.
    pub method: Method,
    /// Calibration used.
    pub calibration: Calibration,
    /// Material name.
    pub material: String,
    /// Output settings.
    pub output: OutputSpec,
    /// The garment, for garment scenes.
    pub garment: Option<GarmentInfo>,
}

impl Scene {
    /// The step parameters of a dynamic scene (of a static one: the defaults with the scene's `dt`).
    pub fn step_params(&self) -> StepParams {
        match self.method {
            Method::Dynamic(p) => p,
            Method::Static(_) => StepParams::with_dt(self.dt),
        }
    }

    /// The linear solver of the run (a static solve always factorises).
    pub fn solver(&self) -> SolverKind {
        match self.method {
            Method::Dynamic(p) => p.solver,
            Method::Static(_) => SolverKind::Cholesky,
        }
    }
}

/// Reads, parses and builds the scene file at `path`.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    SceneSpec::load(path)?.build(path)
}

impl SceneSpec {
    /// Reads and parses a scene file (no validation beyond types: see [`SceneSpec::build`]).
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::io(path, source))?;
        Self::from_toml(&text, path)
    }

    /// Parses scene text; `file` names it in messages.
    pub fn from_toml(text: &str, file: &Path) -> Result<Self, SceneError> {
        parse_toml(text, file)
    }

    /// The JSON schema of the scene format.
    pub fn json_schema() -> serde_json::Value {
        serde_json::to_value(schemars::schema_for!(SceneSpec)).unwrap_or(serde_json::Value::Null)
    }

    /// Validates every value and builds the model and initial state. `scene_path` is the file the spec came
    /// from: material files are found relative to it, and it names errors.
    pub fn build(&self, scene_path: &Path) -> Result<Scene, SceneError> {
        let file = scene_path;
        let bad = |key: &str, message: String| SceneError::invalid(file, key.to_string(), message);
        let finite3 = |key: &str, v: [f64; 3]| -> Result<Vec3, SceneError> {
            if v.iter().all(|c| c.is_finite()) {
                Ok(Vec3::from_array(v))
            } else {
                Err(bad(key, format!("{v:?} must be three finite numbers")))
            }
        };
        let positive = |key: &str, v: f64, unit: &str| -> Result<f64, SceneError> {
            if !v.is_finite() {
                Err(bad(key, format!("{v} {unit} must be a finite number")))
            } else if v <= 0.0 {
                Err(bad(key, format!("{v} {unit} must be positive")))
            } else {
                Ok(v)
            }
        };
        let non_negative = |key: &str, v: f64, unit: &str| -> Result<f64, SceneError> {
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                Err(bad(key, format!("{v} {unit} must be finite and non-negative")))
            }
        };

        // Time.
        let dt = positive("time.dt", self.time.dt, "s")?;
        if self.time.steps == 0 {
            return Err(bad("time.steps", "must be at least 1".into()));
        }
        let output_every = self.time.output_every.unwrap_or(self.time.steps);
        if output_every == 0 {
            return Err(bad("time.output_every", "must be at least 1".into()));
        }

        // Obstacles and contact (a garment is fitted onto the obstacles, so they come first).
        let mut obstacles = Vec::with_capacity(self.obstacles.len());
        for (i, o) in self.obstacles.iter().enumerate() {
            obstacles.push(self.obstacle(i, o, file)?);
        }
        let contact = ContactParams {
            stiffness: positive("contact.stiffness", self.contact.stiffness, "N/m³")?,
            offset: non_negative("contact.offset", self.contact.offset, "m")?,
            friction: non_negative("contact.friction", self.contact.friction, "")?,
        };

        // Material.
        let material = self.material.resolve(file, "material")?;
        let stiffness = Stiffness::calibrate(&material.fabric, self.calibration)
            .map_err(|e| bad("calibration", format!("{e} (with `calibration = \"{:?}\"`)", self.calibration)))?;
        let gravity = finite3("gravity", self.gravity)?;

        // Sheet or garment: grid, rest shape, initial shape, model.
        let (mut model, initial, garment) = match (&self.sheet, &self.garment) {
            (Some(_), Some(_)) => {
                return Err(bad("garment", "give exactly one of `[sheet]` and `[garment]`, not both".into()));
            }
            (None, None) => {
                return Err(bad("sheet", "give exactly one of `[sheet]` and `[garment]`; neither is present".into()));
            }
            (Some(s), None) => {
                let grid = self.sheet_grid(s, file)?;
                let center = finite3("sheet.center", s.center)?;
                let angles = finite3("sheet.rotate_deg", s.rotate_deg)?;
                let rest = initial_positions(&grid, center, angles);
                let model = ModelBuilder::new(grid, rest.clone(), material.fabric, stiffness, self.model.kind, gravity);
                (model, rest, None)
            }
            (None, Some(g)) => {
                let shape = g.shape(&obstacles, contact.offset, file)?;
                let options = ElasticOptions { warp_angle: g.warp.angle(), flat_pattern: true, ..Default::default() };
                let mut model = ModelBuilder::with_options(
                    shape.grid,
                    shape.rest,
                    material.fabric,
                    stiffness,
                    self.model.kind,
                    gravity,
                    &options,
                );
                for &k in &shape.waist_nodes {
                    model.springs.push(Spring { node: k, target: shape.initial[k], stiffness: g.waist_springs });
                }
                let info = GarmentInfo {
                    kind: g.kind,
                    waist_nodes: shape.waist_nodes,
                    waist_fitted: shape.waist_fitted,
                    waist_strain: shape.waist_strain,
                    initial_min_distance: shape.min_distance,
                };
                (model, shape.initial, Some(info))
            }
        };
        let grid = model.grid;
        let rest = initial.clone();
        model.obstacles = obstacles;
        model.contact = contact;

        // Pins and springs.
        for (i, pin) in self.pins.iter().enumerate() {
            for k in node_set(&grid, pin.set, &pin.nodes, &format!("pin[{i}]"), file)? {
                model.pinned[k] = true;
            }
        }
        for (i, sp) in self.springs.iter().enumerate() {
            let key = format!("spring[{i}]");
            let stiffness = positive(&format!("{key}.stiffness"), sp.stiffness, "N/m")?;
            let target = match sp.target {
                SpringTarget::Initial(_) => None,
                SpringTarget::Point(p) => Some(finite3(&format!("{key}.target"), p)?),
            };
            for k in node_set(&grid, sp.set, &sp.nodes, &key, file)? {
                model.springs.push(Spring { node: k, target: target.unwrap_or(rest[k]), stiffness });
            }
        }

        // Output.
        if !(1..=64).contains(&self.output.coons_subdivisions) {
            return Err(bad("output.coons_subdivisions", "must be between 1 and 64".into()));
        }
        let [w, h] = self.output.image_size;
        if !(16..=8192).contains(&w) || !(16..=8192).contains(&h) {
            return Err(bad("output.image_size", format!("[{w}, {h}]: each side must be between 16 and 8192 pixels")));
        }

        let name = self
            .name
            .clone()
            .unwrap_or_else(|| file.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned()));
        let model = model.build().map_err(|e| bad(e.field, e.message))?;
        Ok(Scene {
            name,
            file: file.to_path_buf(),
            model,
            state: State::at_rest(rest),
            dt,
            steps: self.time.steps,
            output_every,
            method: self.integrator.kind.method(dt, self.integrator.solver),
            calibration: self.calibration,
            material: material.name,
            output: self.output,
            garment,
        })
    }

    /// The grid of a `[sheet]`.
    fn sheet_grid(&self, s: &SheetSpec, file: &Path) -> Result<Grid, SceneError> {
        let bad = |key: &str, message: String| SceneError::invalid(file, key.to_string(), message);
        let positive = |v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else if v.is_finite() {
                Err(bad("sheet.size", format!("{v} m must be positive")))
            } else {
                Err(bad("sheet.size", format!("{v} m must be a finite number")))
            }
        };
        let l1 = positive(s.size[0])?;
        let l2 = positive(s.size[1])?;
        for (d, &count) in s.nodes.iter().enumerate() {
            if count < 3 {
                return Err(bad(
                    "sheet.nodes",
                    format!("direction u{} has {count} nodes; at least 3 are needed", d + 1),
                ));
            }
        }
        if s.topology == [Topology::Periodic; 2] {
            return Err(bad("sheet.topology", "both directions periodic (a torus) is not supported".into()));
        }
        let [m, n] = s.nodes;
        let spacing = |l: f64, count: usize, t: Topology| match t {
            Topology::Free => l / (count - 1) as f64,
            Topology::Periodic => l / count as f64,
        };
        Grid::new(m, n, spacing(l1, m, s.topology[0]), spacing(l2, n, s.topology[1]), s.topology)
            .map_err(|e| bad("sheet.nodes", e.to_string()))
    }

    /// Builds obstacle `i`; body files are found relative to `file`.
    fn obstacle(&self, i: usize, o: &ObstacleSpec, file: &Path) -> Result<Obstacle, SceneError> {
        let bad = |key: String, message: String| SceneError::invalid(file, key, message);
        let finite3 = |key: String, v: [f64; 3]| -> Result<Vec3, SceneError> {
            if v.iter().all(|c| c.is_finite()) {
                Ok(Vec3::from_array(v))
            } else {
                Err(bad(key, format!("{v:?} must be three finite numbers")))
            }
        };
        let relative = |p: &Path| file.parent().map_or_else(|| p.to_path_buf(), |d| d.join(p));
        Ok(match o {
            ObstacleSpec::Sphere(sp) => {
                let key = format!("obstacle[{i}].sphere.radius");
                if !(sp.radius.is_finite() && sp.radius > 0.0) {
                    let what = if sp.radius.is_finite() { "must be positive" } else { "must be a finite number" };
                    return Err(bad(key, format!("{} m {what}", sp.radius)));
                }
                Obstacle::Sphere {
                    center: finite3(format!("obstacle[{i}].sphere.center"), sp.center)?,
                    radius: sp.radius,
                }
            }
            ObstacleSpec::Plane(p) => {
                let key = format!("obstacle[{i}].plane.normal");
                let normal = finite3(key.clone(), p.normal)?;
                if normal.length() == 0.0 {
                    return Err(bad(key, "the normal must not be zero".into()));
                }
                Obstacle::Plane {
                    point: finite3(format!("obstacle[{i}].plane.point"), p.point)?,
                    normal: normal.normalize(),
                }
            }
            ObstacleSpec::Nurbs(spec) => match (&spec.file, spec.builtin) {
                (Some(_), Some(_)) | (None, None) => {
                    return Err(bad(
                        format!("obstacle[{i}].nurbs"),
                        "give exactly one of `file` (a body file) and `builtin` (\"mannequin\")".into(),
                    ));
                }
                (None, Some(BuiltinBody::Mannequin)) => Obstacle::Nurbs(Arc::new(mannequin::generate())),
                (Some(f), None) => {
                    let path = relative(f);
                    let body = NurbsBody::from_file(&path)
                        .map_err(|e| bad(format!("obstacle[{i}].nurbs.file"), naming(&path, e.to_string())))?;
                    Obstacle::Nurbs(Arc::new(body))
                }
            },
            ObstacleSpec::Mesh(spec) => {
                let path = relative(&spec.file);
                let body = TriMeshBody::from_obj(&path)
                    .map_err(|e| bad(format!("obstacle[{i}].mesh.file"), naming(&path, e.to_string())))?;
                Obstacle::Mesh(Arc::new(body))
            }
        })
    }
}

/// `message` about the body file `path`, prefixed with the path unless it already names it.
fn naming(path: &Path, message: String) -> String {
    let name = path.display().to_string();
    if message.contains(&name) {
        message
    } else {
        format!("{name}: {message}")
    }
}

/// Initial (and rest) positions: a flat sheet rotated by `angles` (degrees, x then y then z) and centred at
/// `center`, or a cylinder about the z axis when one direction is periodic.
fn initial_positions(grid: &Grid, center: Vec3, angles: Vec3) -> Vec<Vec3> {
    let rot = Mat3::from_rotation_z(angles.z.to_radians())
        * Mat3::from_rotation_y(angles.y.to_radians())
        * Mat3::from_rotation_x(angles.x.to_radians());
    let local: Vec<Vec3> = if grid.periodic(0) || grid.periodic(1) {
        // Periodic direction p wraps around z; the other direction q runs along z, centred.
        let (p, q) = if grid.periodic(0) { (0, 1) } else { (1, 0) };
        let circumference = grid.spacing(p) * grid.count(p) as f64;
        let radius = circumference / std::f64::consts::TAU;
        let height = grid.spacing(q) * (grid.count(q) - 1) as f64;
        (0..grid.len())
            .map(|k| {
                let ij = grid.coords(k);
                let (a, b) = if p == 0 { ij } else { (ij.1, ij.0) };
                let theta = std::f64::consts::TAU * a as f64 / grid.count(p) as f64;
                Vec3::new(radius * theta.cos(), radius * theta.sin(), b as f64 * grid.spacing(q) - 0.5 * height)
            })
            .collect()
    } else {
        grid.flat_positions(0.0)
    };
    local.into_iter().map(|p| rot * p + center).collect()
}

/// Flat node indices of a named set plus explicit pairs; `key` names the table in errors.
fn node_set(
    grid: &Grid,
    set: Option<NamedSet>,
    nodes: &[[usize; 2]],
    key: &str,
    file: &Path,
) -> Result<Vec<usize>, SceneError> {
    let (m, n) = (grid.m, grid.n);
    let mut out = Vec::new();
    if let Some(set) = set {
        match set {
            NamedSet::Corners => {
                if grid.periodic(0) || grid.periodic(1) {
                    return Err(SceneError::invalid(
                        file,
                        format!("{key}.set"),
                        "`corners` needs both directions free".into(),
                    ));
                }
                out.extend([grid.index(0, 0), grid.index(m - 1, 0), grid.index(0, n - 1), grid.index(m - 1, n - 1)]);
            }
            NamedSet::EdgeU1Start => out.extend((0..n).map(|j| grid.index(0, j))),
            NamedSet::EdgeU1End => out.extend((0..n).map(|j| grid.index(m - 1, j))),
            NamedSet::EdgeU2Start => out.extend((0..m).map(|i| grid.index(i, 0))),
            NamedSet::EdgeU2End => out.extend((0..m).map(|i| grid.index(i, n - 1))),
            NamedSet::All => out.extend(0..grid.len()),
        }
    }
    for &[i, j] in nodes {
        if i >= m || j >= n {
            return Err(SceneError::invalid(
                file,
                format!("{key}.nodes"),
                format!("node [{i}, {j}] is outside the {m} × {n} grid (indices start at 0)"),
            ));
        }
        out.push(grid.index(i, j));
    }
    if out.is_empty() {
        return Err(SceneError::invalid(file, key.to_string(), "give `set` or `nodes`".into()));
    }
    Ok(out)
}
