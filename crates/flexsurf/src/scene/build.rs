//! Building a scene: [`SceneSpec::build`] checks every value (`values.rs`, with the range table) and only then
//! builds the [`Model`] and the initial [`State`] of a [`Scene`], all in one place (`assemble`).
//! [`SceneSpec::check_with`] checks the same without building the model (`flexsurf check`: it answers from the
//! sizes and the checked values, without the model's large allocation).

use super::budget::{Estimate, Limits};
use super::error::SceneWarning;
use super::garment::GarmentInfo;
use super::initial;
use super::motion::PinMotion;
use super::pattern::LoadedPattern;
use super::spec::{IntegratorSpec, OutputSpec, SceneSpec};
use super::validate::{Validator, Warnings};
use super::values::{Body, Checked, Parts, SpringSet};
use super::SceneError;
use crate::garment::pattern::BuiltPattern;
use crate::garment::sewing::{sew_coarse, sew_observed, SewError, SewReport};
use crate::integrate::{self, linsolve::SolverKind, Method, StepParams};
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::Vec3;
use crate::model::{ElasticOptions, Model, ModelBuilder, ModelKind, Spring};
use crate::state::State;
use std::path::{Path, PathBuf};

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
    /// Time step (s): the one copy; [`Scene::method`] and [`Scene::step_params`] carry it.
    pub dt: f64,
    /// Steps to take.
    pub steps: usize,
    /// Frame cadence (steps).
    pub output_every: usize,
    /// The animation's cadence (steps): `output.animation_every` or its default ([`super::budget::animation_every`]).
    pub animation_every: usize,
    /// The time-stepping scheme (or a static solve) and the linear solver.
    pub integrator: IntegratorSpec,
    /// Calibration used.
    pub calibration: Calibration,
    /// Material name.
    pub material: String,
    /// Output settings.
    pub output: OutputSpec,
    /// The garment, for garment scenes.
    pub garment: Option<GarmentInfo>,
    /// The sewing phase, for `[pattern]` scenes.
    pub sewing: Option<SewingInfo>,
    /// The pinned sets carried along prescribed motions (`[[pin]] motion`).
    pub motions: Vec<PinMotion>,
    /// The values outside the usual range of fabrics (valid, but most often a unit slip); front ends print them.
    pub warnings: Vec<SceneWarning>,
}

/// What `flexsurf check` reports of a scene whose every value is checked (its model is not built).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneReport {
    /// Grid nodes `[M, N]` (of the first sheet when there are several).
    pub nodes: [usize; 2],
    /// Sheets (panels).
    pub sheets: usize,
    /// The deformation model.
    pub model: ModelKind,
    /// The run: the time-stepping scheme, or `static`.
    pub method: Method,
    /// Time step (s).
    pub dt: f64,
    /// Steps to take.
    pub steps: usize,
    /// Obstacles.
    pub obstacles: usize,
    /// Pinned nodes (each counted once).
    pub pinned: usize,
    /// Constraint springs (one per node of each `[[spring]]`, and the garment's waist springs).
    pub springs: usize,
    /// Material name.
    pub material: String,
    /// The estimated memory of a run.
    pub estimate: Estimate,
    /// The values outside the usual range of fabrics.
    pub warnings: Vec<SceneWarning>,
}

/// What a checked scene assembles into: the model, the initial positions, the garment, the pins' motions and
/// the sewing phase of a `[pattern]` scene.
type Assembled = (Model, Vec<Vec3>, Option<GarmentInfo>, Vec<PinMotion>, Option<SewingInfo>);

impl Scene {
    /// The run: a dynamic integration with its step parameters (time step [`Scene::dt`]), or a static solve.
    pub fn method(&self) -> Method {
        self.integrator.method(self.dt)
    }

    /// The step parameters of a dynamic scene (of a static one: the defaults with the scene's `dt`).
    pub fn step_params(&self) -> StepParams {
        match self.method() {
            Method::Dynamic(p) => p,
            Method::Static(_) => StepParams::with_dt(self.dt),
        }
    }

    /// Moves the pinned sets of [`Scene::motions`] in `state` to their positions at the end of the coming step
    /// (of [`Scene::dt`]): the runner calls it before each step.
    pub fn drive(&self, state: &mut State) -> Result<(), crate::model::ModelError> {
        super::motion::drive(&self.motions, &self.model, state, self.dt)
    }

    /// The linear solver of the run (a static solve always factorises).
    pub fn solver(&self) -> SolverKind {
        match self.method() {
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
        self.build_observed(scene_path, limits, &mut |_, _| {})
    }

    /// As [`SceneSpec::build_with`], calling `observe` with the open model and its positions at the start of a
    /// `[pattern]` scene's sewing phase and after each of its steps (never for other scenes).
    pub fn build_observed(
        &self,
        scene_path: &Path,
        limits: &Limits,
        observe: &mut dyn FnMut(&crate::model::Model, &[crate::math::Vec3]),
    ) -> Result<Scene, SceneError> {
        let file = scene_path;
        let warnings = Warnings::default();
        let v = Validator::new(file, &warnings);
        let Checked { parts, dt, output_every, animation_every, condition, material, .. } = self.checked(&v, limits)?;
        let (model, initial, garment, motions, sewing) = self.assemble(&v, parts, observe)?;
        let integrator = self.integrator;
        let state = match integrator.method(dt) {
            Method::Static(_) => State::at_rest(initial),
            Method::Dynamic(p) => {
                let velocities = initial::velocities(&initial, &model.mass, model.pinned(), &condition);
                // A sewn garment starts without the accelerations of its joined state (the join leaves the
                // cells at the seams out of balance): `start_unaccelerated`.
                match sewing {
                    Some(_) => integrate::start_unaccelerated(&model, initial, velocities, p.dt)
                        .map_err(|e| v.bad("pattern", sewn_start_problem(&e)))?,
                    None => integrate::start(&model, initial, velocities, p.dt)
                        .map_err(|e| v.bad("initial", e.to_string()))?,
                }
            }
        };
        Ok(Scene {
            name: self.display_name(file),
            file: file.to_path_buf(),
            model,
            state,
            dt,
            steps: self.time.steps,
            output_every,
            animation_every,
            integrator,
            calibration: self.calibration,
            material,
            output: self.output,
            garment,
            motions,
            sewing,
            warnings: warnings.into_inner(),
        })
    }

    /// Checks every value, file and size of the scene as [`SceneSpec::build_with`] does (the garment fitted,
    /// the shape checked to start outside the obstacles), without building the model or the initial state:
    /// the answer comes before the model's large allocation, whatever `limits` allow.
    pub fn check_with(&self, scene_path: &Path, limits: &Limits) -> Result<SceneReport, SceneError> {
        let warnings = Warnings::default();
        let v = Validator::new(scene_path, &warnings);
        let Checked { parts, dt, material, estimate, .. } = self.checked(&v, limits)?;
        let grids = parts.body.grids();
        let mut pinned = vec![false; parts.body.initial().len()];
        parts.pins.iter().flatten().for_each(|&k| pinned[k] = true);
        let waist = match &parts.body {
            Body::Garment { shape, .. } => shape.waist_nodes.len(),
            Body::Sheets { .. } => 0,
            Body::Pattern { pattern, .. } => pattern.holds.len(),
        };
        Ok(SceneReport {
            nodes: [grids[0].0.m, grids[0].0.n],
            sheets: grids.len(),
            model: self.model.kind,
            method: self.integrator.method(dt),
            dt,
            steps: self.time.steps,
            obstacles: parts.obstacles.len(),
            pinned: pinned.iter().filter(|&&p| p).count(),
            springs: waist + parts.springs.iter().map(|s| s.nodes.len()).sum::<usize>(),
            material,
            estimate,
            warnings: warnings.into_inner(),
        })
    }

    /// The scene's `name`, else the file stem.
    fn display_name(&self, file: &Path) -> String {
        self.name
            .clone()
            .unwrap_or_else(|| file.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned()))
    }

    /// The model and its initial positions from checked parts: the one place a scene constructs a [`Model`]
    /// (the garment's waist springs first, then obstacles, contact, pins and the `[[spring]]` tables; a
    /// pattern's garment is sewn last).
    fn assemble(
        &self,
        v: &Validator<'_>,
        parts: Parts<'_>,
        observe: &mut dyn FnMut(&crate::model::Model, &[Vec3]),
    ) -> Result<Assembled, SceneError> {
        let Parts {
            body,
            fabric,
            stiffness,
            laws,
            gravity,
            obstacles,
            contact,
            self_contact,
            contact_faces,
            pins,
            motions,
            springs,
        } = parts;
        let mut pattern = None;
        let (mut model, initial, garment) = match body {
            Body::Sheets { sheets, initial } => {
                let mut sheets = sheets.into_iter();
                let Some((grid, rest)) = sheets.next() else { return Err(v.bad("sheet", "no sheet".into())) };
                let mut model = ModelBuilder::new(grid, rest, fabric, stiffness, self.model.kind, gravity);
                for (grid, rest) in sheets {
                    model = model.panel(grid, rest, ElasticOptions::default());
                }
                (model, initial, None)
            }
            Body::Pattern { pattern: loaded, initial } => {
                let model = pattern_model(&loaded, fabric, stiffness, self.model.kind, gravity)
                    .ok_or_else(|| v.bad("pattern", "no panel".into()))?;
                pattern = Some(loaded);
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
        model.self_contact = self_contact;
        model.contact_faces = contact_faces;
        model.laws = laws;
        let motions = motions.iter().map(|(i, p)| PinMotion::new(pins[*i].clone(), &initial, p)).collect();
        constrain(&mut model, pins, springs, &initial);
        let Some(pattern) = pattern else {
            let model = model.build().map_err(|e| v.bad(e.field, e.message))?;
            return Ok((model, initial, garment, motions, None));
        };
        if !motions.is_empty() {
            // The pins' nodes are the panels'; sewing joins and renumbers them.
            return Err(v.bad("pin", "a pin's `motion` is not supported in a [pattern] scene (yet)".into()));
        }
        let sewn = sew(v, &model, &pattern, initial, observe)?;
        warn_if_open(v, &sewn.report, pattern.sewing.gap);
        let info = SewingInfo::new(&pattern, sewn.report);
        Ok((sewn.model, sewn.x, None, motions, Some(info)))
    }
}

/// The open (unsewn) model of a pattern's panels, each with its grid, flat rest shape, warp and own fabric if it
/// has one; `None` without panels.
fn pattern_model(
    loaded: &LoadedPattern,
    fabric: Fabric,
    stiffness: Stiffness,
    kind: ModelKind,
    gravity: Vec3,
) -> Option<ModelBuilder> {
    panels_model(&loaded.built, &loaded.materials, fabric, stiffness, kind, gravity)
}

/// The open model of the panels of `built`, their fabrics `materials` (`None`: `fabric`).
fn panels_model(
    built: &BuiltPattern,
    materials: &[Option<crate::model::PanelMaterial>],
    fabric: Fabric,
    stiffness: Stiffness,
    kind: ModelKind,
    gravity: Vec3,
) -> Option<ModelBuilder> {
    let mut panels = built.panels.iter();
    let first = panels.next()?;
    let mut model =
        ModelBuilder::new(first.grid, first.flat.clone(), fabric, stiffness, kind, gravity).options(first.options);
    for p in panels {
        model = model.panel(p.grid, p.flat.clone(), p.options);
    }
    for (spec, material) in model.panels.iter_mut().zip(materials) {
        spec.material = *material;
    }
    Some(model)
}

/// Why a sewn garment cannot start: the sewing phase (self-contact is off while it runs) left it passing
/// through itself, which no setting of `initial` can mend.
fn sewn_start_problem(e: &integrate::StepError) -> String {
    match e {
        integrate::StepError::Intersecting { edge_from, edge_to, triangle } => format!(
            "the sewn garment passes through itself: the edge from {edge_from} to {edge_to} crosses the triangle of \
             {triangle}; the sewing phase (which runs without self-contact) pulled the cloth through itself: place \
             the panels so that no panel lies between the two edges of a seam"
        ),
        e => format!("the sewn garment cannot start: {e}"),
    }
}

/// Sews the pattern's garment from the panel nodes' placed positions `initial` on the open model `model`: on
/// its own grid, or on the coarser grid of `sewing_edge_length` and carried onto it.
fn sew(
    v: &Validator<'_>,
    model: &ModelBuilder,
    pattern: &LoadedPattern,
    initial: Vec<Vec3>,
    observe: &mut dyn FnMut(&crate::model::Model, &[Vec3]),
) -> Result<crate::garment::sewing::Sewn, SceneError> {
    let built = &pattern.built;
    let sewn = match &pattern.coarse {
        None => sew_observed(model, &built.seams, initial, &pattern.holds, &pattern.sewing, observe),
        Some(coarse) => {
            if model.pinned.iter().any(|&p| p) || !model.springs.is_empty() {
                let message = "a scene with `[[pin]]` or `[[spring]]` tables sews on the pattern's own grid (their \
                               nodes are its nodes): remove `sewing_edge_length`";
                return Err(v.bad("pattern.sewing_edge_length", message.into()));
            }
            let (fabric, stiffness) = (model.fabric, model.stiffness);
            let mut open = panels_model(coarse, &pattern.materials, fabric, stiffness, model.kind, model.gravity)
                .ok_or_else(|| v.bad("pattern", "no panel".into()))?;
            open.obstacles = model.obstacles.clone();
            open.contact = model.contact;
            open.self_contact = model.self_contact;
            open.contact_faces = model.contact_faces;
            open.laws = model.laws.clone();
            let x0 = coarse.panels.iter().flat_map(|q| q.placed.iter().copied()).collect();
            let panels = (&coarse.panels[..], &built.panels[..]);
            let coarse = (&open, &coarse.seams[..], x0);
            sew_coarse(model, &built.seams, &pattern.holds, coarse, panels, &pattern.sewing, observe)
        }
    };
    sewn.map_err(|e| match e {
        SewError::Model(e) => v.bad(e.field, e.message),
        SewError::Step(e) => v.bad("pattern", format!("the sewing phase failed: {e}")),
        SewError::Carry(e) => v.bad("pattern.sewing_edge_length", e.to_string()),
    })
}

/// Warns when the sewing phase's steps ran out before every seam's gap was below `gap` (the seams are joined
/// anyway, each pair at its midpoint).
fn warn_if_open(v: &Validator<'_>, report: &SewReport, gap: f64) {
    if report.largest_gap() < gap {
        return;
    }
    let (seam, widest) = report.gaps.iter().enumerate().fold((0, 0.0), |a, (k, &g)| if g > a.1 { (k, g) } else { a });
    v.warn(
        "pattern.sewing_steps",
        format!(
            "the seams did not close in {} sewing steps: seam {seam} was joined {:.2} mm apart (`sewing_gap` {:.2} \
             mm; let out {} times where the contact held it open), which moves its nodes half that at the join; \
             give more `sewing_steps` or stiffer sewing springs, or check the placement",
            report.steps,
            widest * 1e3,
            gap * 1e3,
            report.backoffs
        ),
    );
}

/// Pins the nodes of `pins` and adds the springs of `springs` (an `"initial"` target at `initial`) to `model`.
fn constrain(model: &mut ModelBuilder, pins: Vec<Vec<usize>>, springs: Vec<SpringSet>, initial: &[Vec3]) {
    for k in pins.into_iter().flatten() {
        model.pinned[k] = true;
    }
    for sp in springs {
        for k in sp.nodes {
            model.springs.push(Spring { node: k, target: sp.target.unwrap_or(initial[k]), stiffness: sp.stiffness });
        }
    }
}

/// What a `[pattern]` scene reports of its pattern and its sewing.
#[derive(Debug, Clone, PartialEq)]
pub struct SewingInfo {
    /// The pattern's name.
    pub pattern: String,
    /// The pattern file.
    pub file: PathBuf,
    /// The panels' names, in node order.
    pub panels: Vec<String>,
    /// Each seam's lengths of its two edges (m).
    pub seam_lengths: Vec<[f64; 2]>,
    /// Smallest to largest Jacobian of each panel's Coons map.
    pub distortion: Vec<f64>,
    /// The sewing phase.
    pub report: SewReport,
}

impl SewingInfo {
    fn new(pattern: &LoadedPattern, report: SewReport) -> Self {
        let built = &pattern.built;
        Self {
            pattern: pattern.name.clone(),
            file: pattern.file.clone(),
            panels: built.panels.iter().map(|p| p.name.clone()).collect(),
            seam_lengths: built.seam_lengths.clone(),
            distortion: built.panels.iter().map(|p| p.jacobian[0] / p.jacobian[1]).collect(),
            report,
        }
    }
}
