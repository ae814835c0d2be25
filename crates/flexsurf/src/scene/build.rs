//! Building a scene: [`SceneSpec::build`] checks every value of a parsed scene with one [`Validator`] (in the
//! order the tables are listed in `docs/scenes.md`: time, obstacles, contact, material, gravity, sheet or
//! garment, pins, springs, output) and only then builds the [`Model`] and the initial [`State`] of a [`Scene`],
//! all in one place (`assemble`).

use super::budget::Limits;
use super::garment::{GarmentInfo, GarmentSpec};
use super::initial;
use super::material::relative_to;
use super::spec::{BuiltinBody, ObstacleSpec, OutputSpec, SceneSpec, SheetSpec, SpringTarget};
use super::validate::Validator;
use super::SceneError;
use crate::contact::nurbs::NurbsBody;
use crate::contact::trimesh::TriMeshBody;
use crate::contact::{mannequin, Obstacle};
use crate::garment::GarmentShape;
use crate::grid::{Grid, Topology};
use crate::integrate::{linsolve::SolverKind, Method, StepParams};
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::{Mat3, Vec3};
use crate::model::{ElasticOptions, Model, ModelBuilder, Spring};
use crate::potential::contact::ContactParams;
use crate::state::State;
use std::path::{Path, PathBuf};
use std::sync::Arc;

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

/// The checked sheet or garment, before the model is built.
enum Body<'s> {
    /// A `[sheet]`: its grid and its rest (and initial) positions.
    Sheet { grid: Grid, rest: Vec<Vec3>, initial: Vec<Vec3> },
    /// A `[garment]` and its built geometry.
    Garment { spec: &'s GarmentSpec, shape: GarmentShape },
}

/// The sheet must not start inside an obstacle deeper than the contact offset (the penalty would throw it out
/// violently, or hold it inside): an error naming the obstacle, the count and the deepest node.
fn starts_outside(v: &Validator<'_>, model: &Model, x: &[Vec3]) -> Result<(), SceneError> {
    let offset = model.contact_params().map_or(0.0, |c| c.offset);
    for (i, o) in model.obstacles().iter().enumerate() {
        let (mut count, mut deepest, mut at) = (0usize, 0.0_f64, 0usize);
        for (k, p) in x.iter().enumerate() {
            if let Some((d, _)) = o.distance_hinted(*p, &mut None, offset) {
                if d < -offset {
                    count += 1;
                    if -d > deepest {
                        (deepest, at) = (-d, k);
                    }
                }
            }
        }
        if count > 0 {
            let (a, b) = model.grid.coords(at);
            return Err(v.bad(
                &format!("obstacle[{i}]"),
                format!(
                    "{count} of the sheet's {} nodes start inside this obstacle, deeper than the contact offset \
                     ({offset} m); the deepest, node [{a}, {b}], is {deepest:.4} m inside: move the sheet or the \
                     obstacle",
                    x.len()
                ),
            ));
        }
    }
    Ok(())
}

impl Body<'_> {
    fn grid(&self) -> &Grid {
        match self {
            Body::Sheet { grid, .. } => grid,
            Body::Garment { shape, .. } => &shape.grid,
        }
    }

    /// Replaces the initial positions (the rest shape stays).
    fn set_initial(&mut self, x: Vec<Vec3>) {
        match self {
            Body::Sheet { initial, .. } => *initial = x,
            Body::Garment { shape, .. } => shape.initial = x,
        }
    }
}

/// A checked `[[spring]]`: its nodes, its target point (`None`: each node's initial position), its stiffness.
struct SpringSet {
    nodes: Vec<usize>,
    target: Option<Vec3>,
    stiffness: f64,
}

/// Everything the model is built from, every value checked.
struct Parts<'s> {
    body: Body<'s>,
    fabric: Fabric,
    stiffness: Stiffness,
    gravity: Vec3,
    obstacles: Vec<Obstacle>,
    contact: ContactParams,
    pins: Vec<Vec<usize>>,
    springs: Vec<SpringSet>,
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

impl SceneSpec {
    /// Validates every value and builds the model and initial state. `scene_path` is the file the spec came
    /// from: material files are found relative to it, and it names errors.
    pub fn build(&self, scene_path: &Path) -> Result<Scene, SceneError> {
        self.build_with(scene_path, &Limits::default())
    }

    /// As [`SceneSpec::build`], with the resource `limits` (`--max-memory`) checked before anything is built.
    pub fn build_with(&self, scene_path: &Path, limits: &Limits) -> Result<Scene, SceneError> {
        let file = scene_path;
        let v = Validator::new(file);
        // Ranges and size first (issue 11): nothing below allocates for a scene that fails them.
        super::budget::check(self, &v, limits)?;

        // Time.
        let dt = v.positive("time.dt", self.time.dt, "s")?;
        v.at_least("time.steps", self.time.steps, 1)?;
        let output_every = v.at_least("time.output_every", self.time.output_every.unwrap_or(self.time.steps), 1)?;

        // Obstacles and contact (a garment is fitted onto the obstacles, so they come first).
        let mut obstacles = Vec::with_capacity(self.obstacles.len());
        for (i, o) in self.obstacles.iter().enumerate() {
            obstacles.push(obstacle(&v, i, o)?);
        }
        // Material.
        let material = self.material.resolve(file, "material")?;
        let stiffness = Stiffness::calibrate(&material.fabric, self.calibration)
            .map_err(|e| v.bad("calibration", format!("{e} (with `calibration = \"{:?}\"`)", self.calibration)))?;
        let gravity = v.finite3("gravity", self.gravity)?;

        let offset = v.non_negative("contact.offset", self.contact.offset, "m")?;
        let contact_stiffness = match self.contact.stiffness {
            Some(c) => v.positive("contact.stiffness", c, "N/m³")?,
            None if offset > 0.0 => ContactParams::default_stiffness(material.fabric.density, gravity, offset),
            None if obstacles.is_empty() => 0.0,
            None => {
                return Err(v.bad(
                    "contact.offset",
                    "is 0, so the default contact stiffness (scaled by the fabric's weight over the offset) is \
                     undefined: give a positive offset or an explicit contact.stiffness"
                        .to_string(),
                ))
            }
        };
        let contact = ContactParams {
            stiffness: contact_stiffness,
            offset,
            friction: v.non_negative("contact.friction", self.contact.friction, "")?,
            slip_speed: v.positive("contact.slip_speed", self.contact.slip_speed, "m/s")?,
        };

        // Sheet or garment, then pins and springs on its grid, then output.
        let mut body = self.body(&v, &obstacles, contact.offset)?;
        let condition = self.initial.condition(&v)?;
        if let Some(x) = self.initial.positions(&v, body.grid(), self.output.coons_subdivisions)? {
            body.set_initial(x);
        }
        let (pins, springs) = self.constraints(&v, body.grid())?;
        self.check_output(&v)?;

        let name = self
            .name
            .clone()
            .unwrap_or_else(|| file.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned()));
        let parts = Parts { body, fabric: material.fabric, stiffness, gravity, obstacles, contact, pins, springs };
        let (model, initial, garment) = self.assemble(&v, parts)?;
        starts_outside(&v, &model, &initial)?;
        let method = self.integrator.kind.method(dt, self.integrator.solver);
        let state = match method {
            Method::Static(_) => State::at_rest(initial),
            Method::Dynamic(p) => {
                let velocities = initial::velocities(&initial, &model.mass, model.pinned(), &condition);
                crate::integrate::start(&model, initial, velocities, p.dt)
                    .map_err(|e| v.bad("initial", e.to_string()))?
            }
        };
        Ok(Scene {
            name,
            file: file.to_path_buf(),
            model,
            state,
            dt,
            steps: self.time.steps,
            output_every,
            method,
            calibration: self.calibration,
            material: material.name,
            output: self.output,
            garment,
        })
    }

    /// The model and its initial positions from checked parts: the one place a scene constructs a [`Model`]
    /// (the garment's waist springs first, then obstacles, contact, pins and the `[[spring]]` tables).
    fn assemble(
        &self,
        v: &Validator<'_>,
        parts: Parts<'_>,
    ) -> Result<(Model, Vec<Vec3>, Option<GarmentInfo>), SceneError> {
        let Parts { body, fabric, stiffness, gravity, obstacles, contact, pins, springs } = parts;
        let (mut model, initial, garment) = match body {
            Body::Sheet { grid, rest, initial } => {
                let model = ModelBuilder::new(grid, rest, fabric, stiffness, self.model.kind, gravity);
                (model, initial, None)
            }
            Body::Garment { spec: g, shape } => {
                let options = ElasticOptions { warp_angle: g.warp.angle(), flat_pattern: true, ..Default::default() };
                let mut model = ModelBuilder::new(shape.grid, shape.rest, fabric, stiffness, self.model.kind, gravity)
                    .options(options);
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
        model.obstacles = obstacles;
        model.contact = contact;
        for nodes in pins {
            for k in nodes {
                model.pinned[k] = true;
            }
        }
        for sp in springs {
            for k in sp.nodes {
                model.springs.push(Spring {
                    node: k,
                    target: sp.target.unwrap_or(initial[k]),
                    stiffness: sp.stiffness,
                });
            }
        }
        let model = model.build().map_err(|e| v.bad(e.field, e.message))?;
        Ok((model, initial, garment))
    }

    /// The checked `[sheet]` or `[garment]` (exactly one is given); a garment is fitted onto `obstacles` with
    /// contact offset `offset`.
    fn body(&self, v: &Validator<'_>, obstacles: &[Obstacle], offset: f64) -> Result<Body<'_>, SceneError> {
        match (&self.sheet, &self.garment) {
            (Some(_), Some(_)) => {
                Err(v.bad("garment", "give exactly one of `[sheet]` and `[garment]`, not both".into()))
            }
            (None, None) => {
                Err(v.bad("sheet", "give exactly one of `[sheet]` and `[garment]`; neither is present".into()))
            }
            (Some(s), None) => {
                let grid = sheet_grid(v, s)?;
                let center = v.finite3("sheet.center", s.center)?;
                let angles = v.finite3("sheet.rotate_deg", s.rotate_deg)?;
                let rest = initial_positions(&grid, center, angles);
                Ok(Body::Sheet { grid, initial: rest.clone(), rest })
            }
            (None, Some(g)) => Ok(Body::Garment { spec: g, shape: g.shape(obstacles, offset, v.file())? }),
        }
    }

    /// The checked `[[pin]]` node sets and `[[spring]]` tables on `grid`.
    fn constraints(&self, v: &Validator<'_>, grid: &Grid) -> Result<(Vec<Vec<usize>>, Vec<SpringSet>), SceneError> {
        let mut pins = Vec::with_capacity(self.pins.len());
        for (i, pin) in self.pins.iter().enumerate() {
            pins.push(v.node_set(grid, pin.set, &pin.nodes, &format!("pin[{i}]"))?);
        }
        let mut springs = Vec::with_capacity(self.springs.len());
        for (i, sp) in self.springs.iter().enumerate() {
            let key = format!("spring[{i}]");
            let stiffness = v.positive(&format!("{key}.stiffness"), sp.stiffness, "N/m")?;
            let target = match sp.target {
                SpringTarget::Initial(_) => None,
                SpringTarget::Point(p) => Some(v.finite3(&format!("{key}.target"), p)?),
            };
            let nodes = v.node_set(grid, sp.set, &sp.nodes, &key)?;
            springs.push(SpringSet { nodes, target, stiffness });
        }
        Ok((pins, springs))
    }

    /// Checks `[output]`.
    fn check_output(&self, v: &Validator<'_>) -> Result<(), SceneError> {
        v.in_range("output.coons_subdivisions", self.output.coons_subdivisions, 1..=64)?;
        let [w, h] = self.output.image_size;
        let side = 16..=8192;
        v.require("output.image_size", side.contains(&w) && side.contains(&h), || {
            format!("[{w}, {h}]: each side must be between 16 and 8192 pixels")
        })
    }
}

/// The grid of a `[sheet]`.
fn sheet_grid(v: &Validator<'_>, s: &SheetSpec) -> Result<Grid, SceneError> {
    let l1 = v.positive("sheet.size", s.size[0], "m")?;
    let l2 = v.positive("sheet.size", s.size[1], "m")?;
    for (d, &count) in s.nodes.iter().enumerate() {
        v.require("sheet.nodes", count >= 3, || {
            format!("direction u{} has {count} nodes; at least 3 are needed", d + 1)
        })?;
    }
    v.require("sheet.topology", s.topology != [Topology::Periodic; 2], || {
        "both directions periodic (a torus) is not supported".into()
    })?;
    let [m, n] = s.nodes;
    let spacing = |l: f64, count: usize, t: Topology| match t {
        Topology::Free => l / (count - 1) as f64,
        Topology::Periodic => l / count as f64,
    };
    Grid::new(m, n, spacing(l1, m, s.topology[0]), spacing(l2, n, s.topology[1]), s.topology)
        .map_err(|e| v.bad("sheet.nodes", e.to_string()))
}

/// Builds obstacle `i`; body files are found relative to the scene file.
fn obstacle(v: &Validator<'_>, i: usize, o: &ObstacleSpec) -> Result<Obstacle, SceneError> {
    let relative = |p: &Path| relative_to(v.file(), p);
    Ok(match o {
        ObstacleSpec::Sphere(sp) => {
            let radius = v.positive(&format!("obstacle[{i}].sphere.radius"), sp.radius, "m")?;
            Obstacle::Sphere { center: v.finite3(&format!("obstacle[{i}].sphere.center"), sp.center)?, radius }
        }
        ObstacleSpec::Plane(p) => {
            let key = format!("obstacle[{i}].plane.normal");
            let normal = v.finite3(&key, p.normal)?;
            if normal.length() == 0.0 {
                return Err(v.bad(&key, "the normal must not be zero".into()));
            }
            Obstacle::Plane {
                point: v.finite3(&format!("obstacle[{i}].plane.point"), p.point)?,
                normal: normal.normalize(),
            }
        }
        ObstacleSpec::Nurbs(spec) => match (&spec.file, spec.builtin) {
            (Some(_), Some(_)) | (None, None) => {
                return Err(v.bad(
                    &format!("obstacle[{i}].nurbs"),
                    "give exactly one of `file` (a body file) and `builtin` (\"mannequin\")".into(),
                ));
            }
            (None, Some(BuiltinBody::Mannequin)) => Obstacle::Nurbs(Arc::new(mannequin::generate())),
            (Some(f), None) => {
                let path = relative(f);
                let body = NurbsBody::from_file(&path)
                    .map_err(|e| v.bad(&format!("obstacle[{i}].nurbs.file"), naming(&path, e.to_string())))?;
                Obstacle::Nurbs(Arc::new(body))
            }
        },
        ObstacleSpec::Mesh(spec) => {
            let path = relative(&spec.file);
            let body = TriMeshBody::from_obj(&path)
                .map_err(|e| v.bad(&format!("obstacle[{i}].mesh.file"), naming(&path, e.to_string())))?;
            Obstacle::Mesh(Arc::new(body))
        }
    })
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
