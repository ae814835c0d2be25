//! The scene file's data: plain serde types for every table of a scene (`deny_unknown_fields`), every default
//! in [`defaults`], and the JSON schema of the format (`flexsurf schema`, through `schemars`). Nothing here
//! checks a value beyond its type: [`SceneSpec::build`] (in `build.rs`) does. The `[material]` and `[garment]`
//! tables have their types in `material.rs` and `garment.rs`.

use super::error::{parse_toml, SceneError};
use super::garment::GarmentSpec;
use super::initial::InitialSpec;
use super::material::{MaterialSpec, Preset};
use super::pattern::PatternUse;
use crate::grid::Topology;
use crate::integrate::statics;
use crate::integrate::{linsolve::SolverKind, Method, Scheme, StepParams};
use crate::io::{self, MeshWriter};
use crate::material::Calibration;
use crate::model::ModelKind;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Every default of the scene format, in one place.
pub mod defaults {
    /// Gravity (m/s²).
    pub const GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];
    /// Time step (s).
    pub const DT: f64 = crate::integrate::StepParams::DT;
    /// Friction's slip speed `ε_v` (m/s).
    pub const SLIP_SPEED: f64 = crate::potential::contact::ContactParams::SLIP_SPEED;
    /// Contact offset `δ` (m).
    pub const CONTACT_OFFSET: f64 = 0.005;
    /// `self_contact.thickness` (m).
    pub const SELF_THICKNESS: f64 = 0.004;
    /// Coulomb friction coefficient.
    pub const CONTACT_FRICTION: f64 = 0.0;
    /// Coons sub-quads per cell edge in frames and pictures.
    pub const COONS_SUBDIVISIONS: usize = 4;
    /// Size of one picture of the snapshot panel (pixels).
    pub const IMAGE_SIZE: [u32; 2] = [480, 360];
    /// Resolution of the raster that measures the projected (footprint) area.
    pub const FOOTPRINT_RESOLUTION: usize = 1024;
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
    /// The sheet (`[sheet]`), or several (`[[sheet]]`, one panel each, in node order): size, nodes,
    /// placement, topology. Exactly one of `sheet`, `garment` and `pattern` is given.
    #[serde(default)]
    pub sheet: Option<Sheets>,
    /// A garment (a skirt) fitted onto the obstacles, in place of `sheet`.
    #[serde(default)]
    pub garment: Option<GarmentSpec>,
    /// A garment sewn from a pattern file (`[pattern]`), in place of `sheet`.
    #[serde(default)]
    pub pattern: Option<PatternUse>,
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
    /// Contact of the sheet with itself and between sheets (`[self_contact]`; off without the table).
    #[serde(default)]
    pub self_contact: Option<SelfContactSpec>,
    /// The initial condition: velocity, angular velocity, positions from a frame.
    #[serde(default)]
    pub initial: InitialSpec,
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

/// `[sheet]`, one table, or `[[sheet]]`, an array of them (several sheets in one model, each its own panel).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum Sheets {
    /// One `[sheet]` table.
    One(SheetSpec),
    /// `[[sheet]]` tables.
    Many(Vec<SheetSpec>),
}

impl Sheets {
    /// The sheets, in node order.
    pub fn list(&self) -> &[SheetSpec] {
        match self {
            Sheets::One(s) => std::slice::from_ref(s),
            Sheets::Many(v) => v,
        }
    }

    /// The first sheet, to change (benchmarks and tests resize the shipped scenes).
    pub fn first_mut(&mut self) -> &mut SheetSpec {
        match self {
            Sheets::One(s) => s,
            Sheets::Many(v) => &mut v[0],
        }
    }

    /// The key of `field` of sheet `i` in messages: `sheet.nodes` for a `[sheet]` table, `sheet[1].nodes` for
    /// the second `[[sheet]]`.
    pub fn key(&self, i: usize, field: &str) -> String {
        match self {
            Sheets::One(_) => format!("sheet.{field}"),
            Sheets::Many(_) => format!("sheet[{i}].{field}"),
        }
    }
}

/// A table reads as one sheet, an array of tables as several; the inner errors keep their own keys and spans
/// (an untagged enum would report only that no variant matched).
impl<'de> Deserialize<'de> for Sheets {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = Sheets;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a `[sheet]` table or `[[sheet]]` tables")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Sheets, A::Error> {
                SheetSpec::deserialize(serde::de::value::MapAccessDeserializer::new(map)).map(Sheets::One)
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> Result<Sheets, A::Error> {
                Vec::deserialize(serde::de::value::SeqAccessDeserializer::new(seq)).map(Sheets::Many)
            }
        }
        d.deserialize_any(Visitor)
    }
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
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum IntegratorKind {
    /// Linearised implicit step with `H⁺` (default).
    #[default]
    Linearized,
    /// The paper's literal lagged-coefficient step.
    Lagged,
    /// Second-order BDF2 with `H⁺`: little numerical damping.
    Bdf2,
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
            IntegratorKind::Bdf2 => "bdf2",
            IntegratorKind::Static => "static",
        }
    }

    /// The run this kind asks for, with time step `dt` and linear solver `solver`.
    pub fn method(&self, dt: f64, solver: SolverKind) -> Method {
        let dynamic = |scheme| Method::Dynamic(StepParams { dt, scheme, solver, ..StepParams::default() });
        match self {
            IntegratorKind::Linearized => dynamic(Scheme::Linearized),
            IntegratorKind::Lagged => dynamic(Scheme::Lagged),
            IntegratorKind::Bdf2 => dynamic(Scheme::Bdf2),
            IntegratorKind::Static => Method::Static(statics::StaticOptions::default()),
        }
    }
}

/// `[integrator]`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `linearized` (default, unconditionally stable), `bdf2`, `lagged` (the paper's literal scheme, needs tiny
    /// steps) or `static`.
    #[serde(default)]
    pub kind: IntegratorKind,
    /// `auto` (default), `cholesky`, `multigrid` or `pcg`.
    #[serde(default)]
    pub solver: SolverKind,
    /// Most Newton iterations of a time step, its linearised step included (default 4, from 1 to 100;
    /// docs/model.md §8.5): more converge the steps Newton's method converges slowly (a sheet's folds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub newton_iterations: Option<usize>,
    /// Residual, relative to a step's own force scale, at which its Newton iterations stop (default 1e-6, from
    /// 1e-12 to 0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub newton_tolerance: Option<f64>,
    /// Relative residual at which the linear solves of a contact step stop where they are iterative (default
    /// 1e-6, from 1e-12 to 1e-2): tighter makes a run with friction a smoother function of its inputs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_solve_tolerance: Option<f64>,
}

/// The allowed `integrator.newton_iterations`.
pub const NEWTON_ITERATIONS: std::ops::RangeInclusive<usize> = 1..=100;
/// The allowed `integrator.newton_tolerance`.
pub const NEWTON_TOLERANCE: std::ops::RangeInclusive<f64> = 1e-12..=0.1;
/// The allowed `integrator.contact_solve_tolerance`.
pub const CONTACT_SOLVE_TOLERANCE: std::ops::RangeInclusive<f64> = 1e-12..=1e-2;

impl IntegratorSpec {
    /// The run this table asks for, with time step `dt`: [`IntegratorKind::method`] with the Newton and
    /// contact solve settings given.
    pub fn method(&self, dt: f64) -> Method {
        match self.kind.method(dt, self.solver) {
            Method::Dynamic(p) => Method::Dynamic(StepParams {
                newton_iterations: self.newton_iterations.unwrap_or(p.newton_iterations),
                newton_tolerance: self.newton_tolerance.unwrap_or(p.newton_tolerance),
                contact_solve_tolerance: self.contact_solve_tolerance.unwrap_or(p.contact_solve_tolerance),
                ..p
            }),
            m => m,
        }
    }
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
    /// The mannequin with an upper body: torso to the neck, shoulders and two arms in an A-pose
    /// (`docs/mannequin.md`).
    #[serde(rename = "mannequin_upper")]
    MannequinUpper,
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

/// `[contact]`: penalty pressure `c (δ − d)` below distance `δ`, times the node's area, and Coulomb friction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ContactSpec {
    /// Penalty `c`, pressure per penetration depth (N/m³). Default: from the fabric's weight and the offset,
    /// `c = 200 ρ g / δ` (a pressure of 100 times the fabric's weight per area compresses the layer by half).
    pub stiffness: Option<f64>,
    /// Contact offset `δ` (m), default 0.005.
    pub offset: f64,
    /// Coulomb friction coefficient μ, default 0.
    pub friction: f64,
    /// Slip speed `ε_v` (m/s) below which friction holds (smoothed static friction), default 1e-4.
    pub slip_speed: f64,
    /// The sheet's faces touch the bodies too: points of the faces between the nodes against every obstacle,
    /// and a mesh body's own vertices and edges against the sheet's triangles and edges (a thin feature of a
    /// body cannot pass through a face between nodes), default false.
    pub faces: bool,
}

impl Default for ContactSpec {
    fn default() -> Self {
        Self {
            stiffness: None,
            offset: defaults::CONTACT_OFFSET,
            friction: defaults::CONTACT_FRICTION,
            slip_speed: defaults::SLIP_SPEED,
            faces: false,
        }
    }
}

/// `[self_contact]`: the sheet's elements (nodes, edges, triangles of its grid) push apart closer than the
/// thickness, so it never passes through itself or another sheet.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SelfContactSpec {
    /// Contact thickness (m), under half the shortest grid edge; default 0.004.
    pub thickness: f64,
    /// Penalty (N/m³). Default: as `[contact]`'s, from the fabric's weight over the thickness.
    pub stiffness: Option<f64>,
    /// Coulomb coefficient between layers of cloth (cloth–cloth; `[contact] friction` is cloth–obstacle);
    /// default 0 (frictionless).
    pub friction: f64,
    /// Slip speed (m/s) below which layer friction holds (smoothed static friction); default 1e-4.
    pub slip_speed: f64,
}

impl Default for SelfContactSpec {
    fn default() -> Self {
        Self { thickness: defaults::SELF_THICKNESS, stiffness: None, friction: 0.0, slip_speed: defaults::SLIP_SPEED }
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

/// Nodes given by a named set and/or explicit `[i, j]` pairs (`i` along u1, `j` along u2, from 0), on the
/// sheet `sheet` (default 0, the first; for `[[sheet]]` scenes).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NodeSetSpec {
    /// Which sheet (from 0) of a `[[sheet]]` scene, default 0.
    #[serde(default)]
    pub sheet: usize,
    /// A named set.
    #[serde(default)]
    pub set: Option<NamedSet>,
    /// Explicit nodes `[[i, j], ...]`.
    #[serde(default)]
    pub nodes: Vec<[usize; 2]>,
    /// A prescribed rigid motion of the pinned set (`[[pin]]` only).
    #[serde(default)]
    pub motion: Option<MotionSpec>,
}

/// `[[pin]] motion`: the pinned set turned about an axis and shifted, over `seconds` along a smooth step
/// (zero velocity at its start and end), then held.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// Turns about the axis (signed, right-handed); default 0.
    #[serde(default)]
    pub turns: f64,
    /// The rotation's axis (any non-zero length); default `[0, 0, 1]`.
    #[serde(default)]
    pub axis: Option<[f64; 3]>,
    /// The rotation's centre (m); default the set's centroid at the start.
    #[serde(default)]
    pub center: Option<[f64; 3]>,
    /// The whole translation (m); default `[0, 0, 0]`.
    #[serde(default)]
    pub shift: [f64; 3],
    /// The motion's duration (s).
    pub seconds: f64,
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
    /// Which sheet (from 0) of a `[[sheet]]` scene, default 0.
    #[serde(default)]
    pub sheet: usize,
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
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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
    /// The format's extension and writer: the one table of the frame formats.
    pub fn writer(self) -> MeshWriter {
        match self {
            FrameFormat::Obj => io::obj::WRITER,
            FrameFormat::Ply => io::ply::WRITER,
            FrameFormat::Gltf => io::gltf::WRITER,
        }
    }

    /// File extension.
    pub fn extension(&self) -> &'static str {
        self.writer().extension
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
    /// A frame of the animation (`animation.glb`, the VTK series, the viewer) every this many steps, besides
    /// every output step; default: about 20 frames per simulated second (every 5 steps at Δt = 0.01 s), thinned
    /// to at most 60 frames and 24 MiB of frame data (docs/scenes.md).
    pub animation_every: Option<usize>,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            coons_subdivisions: defaults::COONS_SUBDIVISIONS,
            image_size: defaults::IMAGE_SIZE,
            format: FrameFormat::Obj,
            animation_every: None,
        }
    }
}

impl SceneSpec {
    /// Reads and parses a scene file (no validation beyond types: see [`SceneSpec::build`]).
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text = crate::io::input::read_text(path).map_err(|source| SceneError::io(path, source))?;
        Self::from_toml(&text, path)
    }

    /// Parses scene text; `file` names it in messages.
    pub fn from_toml(text: &str, file: &Path) -> Result<Self, SceneError> {
        parse_toml(text, file).map_err(obstacle_kind)
    }

    /// The JSON schema of the scene format.
    pub fn json_schema() -> serde_json::Value {
        serde_json::to_value(schemars::schema_for!(SceneSpec)).unwrap_or(serde_json::Value::Null)
    }
}

/// An `[[obstacle]]` entry with no kind or several (`sphere` and `plane` in one table) is reported with the kinds
/// there are: the parser's own message ("wanted exactly 1 element, found 0 elements") names neither. The kinds
/// are the parser's list for an unknown one, so they follow [`ObstacleSpec`].
fn obstacle_kind(e: SceneError) -> SceneError {
    let SceneError::Parse { file, line, column, key, message } = e else { return e };
    let entry =
        key.strip_prefix("obstacle[").and_then(|k| k.strip_suffix(']')).is_some_and(|n| n.parse::<usize>().is_ok());
    let found = match message.strip_prefix("wanted exactly 1 element, ") {
        Some(m) if m.starts_with("found 0") => Some("none"),
        Some(m) if m.starts_with("more than 1") => Some("several"),
        _ => None,
    };
    let (true, Some(found)) = (entry, found) else { return SceneError::Parse { file, line, column, key, message } };
    let listed = toml::from_str::<ObstacleSpec>("unknown = 1").err().map(|e| e.message().to_string());
    let kinds = listed.as_deref().and_then(|m| m.split_once("expected ")).map_or("a kind", |(_, k)| k.trim());
    let message = format!(
        "an obstacle is exactly {kinds} (`sphere = {{ center = [0, 0, 0], radius = 0.3 }}`, …); this one names {found}"
    );
    SceneError::Parse { file, line, column, key, message }
}
