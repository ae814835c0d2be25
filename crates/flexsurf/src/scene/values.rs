//! Checking a scene's values: [`SceneSpec::checked`] checks every key of a parsed scene once, with one
//! [`Validator`] and its entry of the range table (in the order the tables are listed in `docs/scenes.md`:
//! time, obstacles, contact, material, gravity, sheet or garment, initial, pins, springs, output), and returns
//! the [`Checked`] parts a model is built from: the files it names are read, the grid and the initial shape are
//! made (a garment is fitted onto the obstacles), and the shape is checked to start outside the obstacles. The
//! model itself (its elastic terms, the large allocation) is made by `build.rs`; `flexsurf check` stops here.

use super::budget::{self, Estimate, Limits};
use super::garment::GarmentSpec;
use super::initial::InitialCondition;
use super::material::relative_to;
use super::motion::MotionParams;
use super::pattern::LoadedPattern;
use super::ranges;
use super::spec::{BuiltinBody, IntegratorKind, MotionSpec, ObstacleSpec, SceneSpec, SheetSpec, Sheets, SpringTarget};
use super::validate::Validator;
use super::SceneError;
use crate::contact::nurbs::NurbsBody;
use crate::contact::trimesh::TriMeshBody;
use crate::contact::{mannequin, Obstacle};
use crate::garment::GarmentShape;
use crate::grid::{Grid, Topology};
use crate::material::{Fabric, Stiffness};
use crate::math::{Mat3, Vec3};
use crate::potential::contact::ContactParams;
use crate::potential::elastic::ModelKind;
use crate::potential::self_contact::SelfContactParams;
use std::path::Path;
use std::sync::Arc;

/// The checked sheet(s) or garment, before the model is built.
pub(crate) enum Body<'s> {
    /// `[sheet]` or `[[sheet]]`: each sheet's grid and rest positions, and the initial positions of all of them
    /// (sheet after sheet).
    Sheets { sheets: Vec<(Grid, Vec<Vec3>)>, initial: Vec<Vec3> },
    /// A `[garment]` and its built geometry.
    Garment { spec: &'s GarmentSpec, shape: GarmentShape },
    /// A `[pattern]`: its panels (grids, flat rest shapes) and seams, and the placed positions of every panel
    /// (panel after panel), before sewing.
    Pattern { pattern: LoadedPattern, initial: Vec<Vec3> },
}

impl Body<'_> {
    /// The grids of the panels, in node order, with the index of each one's first node.
    pub(crate) fn grids(&self) -> Vec<(Grid, usize)> {
        let mut offset = 0;
        let grids: Vec<Grid> = match self {
            Body::Sheets { sheets, .. } => sheets.iter().map(|(g, _)| *g).collect(),
            Body::Garment { shape, .. } => vec![shape.grid],
            Body::Pattern { pattern, .. } => pattern.built.panels.iter().map(|p| p.grid).collect(),
        };
        grids
            .into_iter()
            .map(|g| {
                offset += g.len();
                (g, offset - g.len())
            })
            .collect()
    }

    /// The grid of a body of one panel; `None` for several sheets.
    pub(crate) fn grid(&self) -> Option<Grid> {
        match self.grids().as_slice() {
            [(g, _)] => Some(*g),
            _ => None,
        }
    }

    /// The initial positions.
    pub(crate) fn initial(&self) -> &[Vec3] {
        match self {
            Body::Sheets { initial, .. } | Body::Pattern { initial, .. } => initial,
            Body::Garment { shape, .. } => &shape.initial,
        }
    }

    /// Replaces the initial positions (the rest shape stays).
    fn set_initial(&mut self, x: Vec<Vec3>) {
        match self {
            Body::Sheets { initial, .. } | Body::Pattern { initial, .. } => *initial = x,
            Body::Garment { shape, .. } => shape.initial = x,
        }
    }
}

/// A checked `[[spring]]`: its nodes, its target point (`None`: each node's initial position), its stiffness.
pub(crate) struct SpringSet {
    pub(crate) nodes: Vec<usize>,
    pub(crate) target: Option<Vec3>,
    pub(crate) stiffness: f64,
}

/// Everything the model is built from, every value checked.
pub(crate) struct Parts<'s> {
    pub(crate) body: Body<'s>,
    pub(crate) fabric: Fabric,
    pub(crate) stiffness: Stiffness,
    /// The fabric's nonlinear laws, if it has any.
    pub(crate) laws: Option<std::sync::Arc<crate::material::law::Laws>>,
    pub(crate) gravity: Vec3,
    pub(crate) obstacles: Vec<Obstacle>,
    pub(crate) contact: ContactParams,
    pub(crate) self_contact: Option<SelfContactParams>,
    /// `contact.faces`.
    pub(crate) contact_faces: bool,
    pub(crate) pins: Vec<Vec<usize>>,
    /// The pins' motions, by pin.
    pub(crate) motions: Vec<(usize, MotionParams)>,
    pub(crate) springs: Vec<SpringSet>,
}

/// The pins, their motions by pin, and the springs.
type Constraints = (Vec<Vec<usize>>, Vec<(usize, MotionParams)>, Vec<SpringSet>);

/// A checked `[[pin]] motion` (`key`).
fn motion(v: &Validator<'_>, key: &str, m: &MotionSpec) -> Result<MotionParams, SceneError> {
    let vector = |range, name: &str, p: [f64; 3]| v.numbers(range, &format!("{key}.{name}"), p).map(Vec3::from_array);
    let axis = vector(&ranges::MOTION_AXIS, "axis", m.axis.unwrap_or([0.0, 0.0, 1.0]))?;
    if axis.length() == 0.0 {
        return Err(v.bad(&format!("{key}.axis"), "the axis must not be zero".into()));
    }
    Ok(MotionParams {
        turns: v.number(&ranges::MOTION_TURNS, &format!("{key}.turns"), m.turns)?,
        axis,
        center: m.center.map(|c| vector(&ranges::MOTION_POINT, "center", c)).transpose()?,
        shift: vector(&ranges::MOTION_POINT, "shift", m.shift)?,
        seconds: v.number(&ranges::MOTION_SECONDS, &format!("{key}.seconds"), m.seconds)?,
    })
}

/// A scene whose every value is checked: the parts of its model and its run settings.
pub(crate) struct Checked<'s> {
    pub(crate) parts: Parts<'s>,
    pub(crate) dt: f64,
    pub(crate) output_every: usize,
    pub(crate) animation_every: usize,
    pub(crate) condition: InitialCondition,
    pub(crate) material: String,
    pub(crate) estimate: Estimate,
}

impl SceneSpec {
    /// Checks every value (sizes and memory first, from the sizes alone: nothing large is allocated for a scene
    /// that fails them) and returns the parts of the model.
    pub(crate) fn checked(&self, v: &Validator<'_>, limits: &Limits) -> Result<Checked<'_>, SceneError> {
        let budget::Budget { output_every, animation_every, mut estimate } = budget::check(self, v, limits)?;
        let dt = v.number(&ranges::DT, "time.dt", self.time.dt)?;
        self.check_newton(v)?;
        // Obstacles and contact (a garment is fitted onto the obstacles, so they come first).
        let mut obstacles = Vec::with_capacity(self.obstacles.len());
        for (i, o) in self.obstacles.iter().enumerate() {
            obstacles.push(obstacle(v, i, o)?);
        }
        let material = self.material.resolve_with(&v.within("material"))?;
        let stiffness = Stiffness::calibrate(&material.fabric, self.calibration)
            .map_err(|e| v.bad("calibration", format!("{e} (with `calibration = \"{:?}\"`)", self.calibration)))?;
        let used = !material.laws.is_empty() || material.laws.hysteretic();
        let laws = used.then(|| std::sync::Arc::new(material.laws.clone()));
        if laws.is_some() && self.calibration != crate::material::Calibration::Kes {
            return Err(v.bad("calibration", "a material with curves needs `calibration = \"kes\"`".into()));
        }
        let gravity = Vec3::from_array(v.numbers(&ranges::GRAVITY, "gravity", self.gravity)?);
        let contact = self.contact(v, material.fabric.density, gravity, !obstacles.is_empty())?;
        // Sheet or garment, then the initial condition, pins and springs on its grid, then output.
        let mut body = match &self.pattern {
            Some(p) if self.sheet.is_none() && self.garment.is_none() => {
                let mut pattern = p.load(v, dt, &material.name, self.calibration)?;
                // The sizes are known now: the memory estimate of the panels (the cadences do not change).
                let sizes = pattern.built.panels.iter().map(|q| ("pattern.file".to_string(), [q.grid.m, q.grid.n]));
                estimate = budget::check_sizes(self, v, limits, Some(sizes.collect()))?.estimate;
                wrap_panels(&mut pattern, &obstacles)?;
                let initial = pattern.built.panels.iter().flat_map(|q| q.placed.iter().copied()).collect();
                Body::Pattern { pattern, initial }
            }
            Some(_) => {
                return Err(v.bad("pattern", "give exactly one of `[sheet]`, `[garment]` and `[pattern]`".into()))
            }
            None => self.body(v, &obstacles, contact.offset)?,
        };
        let condition = self.initial.condition(v)?;
        if self.initial.positions.is_some() {
            let grid = body
                .grid()
                .ok_or_else(|| v.bad("initial.positions", "positions from a frame need a scene of one sheet".into()))?;
            if let Some(x) = self.initial.positions(v, &grid, self.output.coons_subdivisions)? {
                body.set_initial(x);
            }
        }
        starts_outside(v, &obstacles, contact.offset, &body)?;
        self.warn_lagged_step(v, dt, &material.fabric, &body);
        let (pins, motions, springs) = self.constraints(v, &body.grids())?;
        self.check_output(v)?;
        let self_contact = self.self_contact(v, material.fabric.density, gravity)?;
        self.warn_comparison_model(v, self_contact.is_some());
        let parts = Parts {
            body,
            fabric: material.fabric,
            stiffness,
            laws,
            gravity,
            obstacles,
            contact,
            self_contact,
            contact_faces: self.contact.faces,
            pins,
            motions,
            springs,
        };
        Ok(Checked { parts, dt, output_every, animation_every, condition, material: material.name, estimate })
    }

    /// Warns where the paper's lagged scheme, which integrates stretching explicitly, is given a `dt` above its
    /// stability limit, about `h / c` for the finest spacing `h` and the membrane's wave speed
    /// `c = √(max(A₁₁, A₂₂)/ρ)`: measured on the 21² ball drop (`h` = 5 cm, `c` = 535 m/s, the limit 9.4e-5 s), 3,000
    /// steps ran at 9e-5 and 7e-5 s, while at 1e-4, 1.3e-4 and 2e-4 s it diverged or went through the ball by step
    /// 491–771; at the shipped 0.01 s, at step 12. Before, nothing was said until it diverged.
    fn warn_lagged_step(&self, v: &Validator<'_>, dt: f64, fabric: &crate::material::Fabric, body: &Body) {
        if self.integrator.kind != IntegratorKind::Lagged {
            return;
        }
        let h = body.grids().iter().map(|(g, _)| g.spacing(0).min(g.spacing(1))).fold(f64::INFINITY, f64::min);
        let c = fabric.wave_speed();
        let limit = h / c;
        if !(limit.is_finite() && dt > limit) {
            return;
        }
        v.warn(
            "time.dt",
            format!(
                "{dt:e} s is above the lagged scheme's stability limit for this sheet, about {limit:.1e} s (its \
                 spacing {h:.3e} m over the membrane's wave speed {c:.3e} m/s): it will diverge within a few \
                 steps; use `integrator.kind = \"linearized\"` (or \"bdf2\"), or a smaller dt"
            ),
        );
    }

    /// Warns where the Terzopoulos–Fleischer comparison model meets what it was not made for: cloth that folds
    /// onto itself (`[self_contact]`) or a sewn garment (`[pattern]`). Its bending force is not the gradient of an
    /// energy, so its steps take no Newton corrections; measured on the shipped scenes, every garment, the pile,
    /// the twisted strip and the blown sheet failed with it within 1–98 steps (a node "passed through ... did not
    /// settle even in halved steps", the straight skirt's edges stretched 126 % at its first step), where the
    /// paper's model runs them; a smaller `dt` only moved the failure (the pile at a quarter of its `dt` failed
    /// after 0.27 s instead of 0.45 s).
    fn warn_comparison_model(&self, v: &Validator<'_>, self_contact: bool) {
        if self.model.kind != ModelKind::Terzopoulos || !(self_contact || self.pattern.is_some()) {
            return;
        }
        let what = if self.pattern.is_some() { "a sewn garment (`[pattern]`)" } else { "`[self_contact]`" };
        v.warn(
            "model.kind",
            format!(
                "\"terzopoulos\" is the comparison model of the paper's ball drop; with {what} its steps often fail \
                 where the cloth folds onto itself (its force is not the gradient of an energy, so they get no \
                 Newton corrections): use \"tfs\" for this scene's results"
            ),
        );
    }

    /// The checked `[contact]`; the default stiffness follows the fabric's `density` and `gravity`.
    fn contact(&self, v: &Validator<'_>, density: f64, gravity: Vec3, any: bool) -> Result<ContactParams, SceneError> {
        let c = &self.contact;
        let offset = v.number(&ranges::CONTACT_OFFSET, "contact.offset", c.offset)?;
        let stiffness = match c.stiffness {
            Some(k) => v.number(&ranges::CONTACT_STIFFNESS, "contact.stiffness", k)?,
            None if offset > 0.0 => ContactParams::default_stiffness(density, gravity, offset),
            None if !any => 0.0,
            None => {
                return Err(v.bad(
                    "contact.offset",
                    "is 0, so the default contact stiffness (scaled by the fabric's weight over the offset) is \
                     undefined: give a positive offset or an explicit contact.stiffness"
                        .to_string(),
                ))
            }
        };
        Ok(ContactParams {
            stiffness,
            offset,
            friction: v.number(&ranges::FRICTION, "contact.friction", c.friction)?,
            slip_speed: v.number(&ranges::SLIP_SPEED, "contact.slip_speed", c.slip_speed)?,
        })
    }

    /// The checked `[self_contact]`; its default stiffness follows the fabric's weight as `[contact]`'s does.
    fn self_contact(
        &self,
        v: &Validator<'_>,
        density: f64,
        gravity: Vec3,
    ) -> Result<Option<SelfContactParams>, SceneError> {
        let Some(c) = &self.self_contact else { return Ok(None) };
        let thickness = v.number(&ranges::SELF_THICKNESS, "self_contact.thickness", c.thickness)?;
        let stiffness = match c.stiffness {
            Some(k) => v.number(&ranges::SELF_STIFFNESS, "self_contact.stiffness", k)?,
            None => ContactParams::default_stiffness(density, gravity, thickness),
        };
        Ok(Some(SelfContactParams {
            stiffness,
            thickness,
            friction: v.number(&ranges::SELF_FRICTION, "self_contact.friction", c.friction)?,
            slip_speed: v.number(&ranges::SELF_SLIP_SPEED, "self_contact.slip_speed", c.slip_speed)?,
        }))
    }

    /// The checked `[sheet]` or `[garment]` (exactly one is given); a garment is fitted onto `obstacles` with
    /// contact offset `offset`.
    fn body(&self, v: &Validator<'_>, obstacles: &[Obstacle], offset: f64) -> Result<Body<'_>, SceneError> {
        match (&self.sheet, &self.garment) {
            (Some(_), Some(_)) => {
                Err(v.bad("garment", "give exactly one of `[sheet]` and `[garment]`, not both".into()))
            }
            (None, None) => {
                Err(v
                    .bad("sheet", "give exactly one of `[sheet]`, `[garment]` and `[pattern]`; none is present".into()))
            }
            (Some(list), None) => {
                if list.list().is_empty() {
                    return Err(v.bad("sheet", "`[[sheet]]` lists no sheet".into()));
                }
                let mut sheets = Vec::with_capacity(list.list().len());
                for (i, s) in list.list().iter().enumerate() {
                    let grid = sheet_grid(v, list, i, s)?;
                    let center = v.numbers(&ranges::SHEET_CENTER, &list.key(i, "center"), s.center)?;
                    let angles = v.numbers(&ranges::SHEET_ROTATE, &list.key(i, "rotate_deg"), s.rotate_deg)?;
                    sheets.push((grid, initial_positions(&grid, Vec3::from_array(center), Vec3::from_array(angles))));
                }
                let initial = sheets.iter().flat_map(|(_, rest)| rest.iter().copied()).collect();
                Ok(Body::Sheets { sheets, initial })
            }
            (None, Some(g)) => Ok(Body::Garment { spec: g, shape: g.shape(v, obstacles, offset)? }),
        }
    }

    /// The checked `[[pin]]` node sets (and their motions, by pin) and `[[spring]]` tables on the sheets'
    /// `grids` (with their first nodes).
    fn constraints(&self, v: &Validator<'_>, grids: &[(Grid, usize)]) -> Result<Constraints, SceneError> {
        let on = |sheet: usize, key: &str| {
            grids.get(sheet).copied().ok_or_else(|| {
                v.bad(&format!("{key}.sheet"), format!("sheet {sheet} does not exist (the scene has {})", grids.len()))
            })
        };
        let mut pins = Vec::with_capacity(self.pins.len());
        for (i, pin) in self.pins.iter().enumerate() {
            let key = format!("pin[{i}]");
            let (grid, offset) = on(pin.sheet, &key)?;
            let nodes = v.node_set(&grid, pin.set, &pin.nodes, &key)?;
            pins.push(nodes.into_iter().map(|k| k + offset).collect());
        }
        let motions = self.pins.iter().enumerate().filter_map(|(i, p)| p.motion.map(|m| (i, m)));
        let motions =
            motions.map(|(i, m)| Ok((i, motion(v, &format!("pin[{i}].motion"), &m)?))).collect::<Result<_, _>>()?;
        let mut springs = Vec::with_capacity(self.springs.len());
        for (i, sp) in self.springs.iter().enumerate() {
            let key = format!("spring[{i}]");
            let stiffness = v.number(&ranges::SPRING_STIFFNESS, &format!("{key}.stiffness"), sp.stiffness)?;
            let target = match sp.target {
                SpringTarget::Initial(_) => None,
                SpringTarget::Point(p) => {
                    Some(Vec3::from_array(v.numbers(&ranges::SPRING_TARGET, &format!("{key}.target"), p)?))
                }
            };
            let (grid, offset) = on(sp.sheet, &key)?;
            let nodes = v.node_set(&grid, sp.set, &sp.nodes, &key)?.into_iter().map(|k| k + offset).collect();
            springs.push(SpringSet { nodes, target, stiffness });
        }
        Ok((pins, motions, springs))
    }

    /// `integrator.newton_iterations`, `integrator.newton_tolerance` and `integrator.contact_solve_tolerance`:
    /// within their ranges, and given only for a time-stepping scheme (the static solve has its own Newton
    /// iterations).
    fn check_newton(&self, v: &Validator<'_>) -> Result<(), SceneError> {
        use super::spec::{CONTACT_SOLVE_TOLERANCE, NEWTON_ITERATIONS, NEWTON_TOLERANCE};
        let i = &self.integrator;
        let given = [
            ("newton_iterations", i.newton_iterations.is_some()),
            ("newton_tolerance", i.newton_tolerance.is_some()),
            ("contact_solve_tolerance", i.contact_solve_tolerance.is_some()),
        ];
        if let Some((key, _)) = given.iter().find(|(_, given)| *given && i.kind == IntegratorKind::Static) {
            return Err(v.bad(&format!("integrator.{key}"), "applies to time steps, not to `kind = \"static\"`".into()));
        }
        if let Some(n) = i.newton_iterations {
            v.in_range("integrator.newton_iterations", n, NEWTON_ITERATIONS)?;
        }
        let tolerances = [
            ("integrator.newton_tolerance", i.newton_tolerance, NEWTON_TOLERANCE),
            ("integrator.contact_solve_tolerance", i.contact_solve_tolerance, CONTACT_SOLVE_TOLERANCE),
        ];
        for (key, value, allowed) in tolerances {
            match value {
                Some(t) if !allowed.contains(&t) => {
                    let range = format!("must be between {:e} and {}", allowed.start(), allowed.end());
                    return Err(v.bad_value(key, t, &range));
                }
                _ => {}
            }
        }
        Ok(())
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

/// The panels of `pattern` whose placement says `onto_body` moved onto the obstacles' offset surface
/// ([`crate::garment::wrap`]); an error naming the pattern file's key when there is no obstacle to wrap onto.
fn wrap_panels(pattern: &mut LoadedPattern, obstacles: &[Obstacle]) -> Result<(), SceneError> {
    let coarse = pattern.coarse.iter_mut().flat_map(|c| c.panels.iter_mut().enumerate());
    for (p, panel) in pattern.built.panels.iter_mut().enumerate().chain(coarse) {
        let (placement, Some(offset)) = panel.placement else { continue };
        if obstacles.is_empty() {
            let key = format!("panel[{p}].placement");
            let message =
                format!("panel `{}`: `onto_body` wraps onto the scene's obstacles, and it has none", panel.name);
            return Err(SceneError::invalid(&pattern.file, key, message));
        }
        crate::garment::wrap::wrap_onto_body(&mut panel.placed, &panel.grid, &placement, offset, obstacles);
    }
    Ok(())
}

/// The sheet must not start inside an obstacle deeper than the contact offset (the penalty would throw it out
/// violently, or hold it inside): an error naming the obstacle, the count and the deepest node.
fn starts_outside(v: &Validator<'_>, obstacles: &[Obstacle], offset: f64, body: &Body<'_>) -> Result<(), SceneError> {
    let x = body.initial();
    for (i, o) in obstacles.iter().enumerate() {
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
            let grids = body.grids();
            let sheet = grids.iter().rposition(|&(_, first)| first <= at).unwrap_or(0);
            let (grid, first) = grids[sheet];
            let (a, b) = grid.coords(at - first);
            let which = if grids.len() > 1 { format!(" of sheet {sheet}") } else { String::new() };
            return Err(v.bad(
                &format!("obstacle[{i}]"),
                format!(
                    "{count} of the sheet's {} nodes start inside this obstacle, deeper than the contact offset \
                     ({offset} m); the deepest, node [{a}, {b}]{which}, is {deepest:.4} m inside: move the sheet or \
                     the obstacle",
                    x.len()
                ),
            ));
        }
    }
    Ok(())
}

/// The grid of sheet `i` of `list`.
fn sheet_grid(v: &Validator<'_>, list: &Sheets, i: usize, s: &SheetSpec) -> Result<Grid, SceneError> {
    let [l1, l2] = v.numbers(&ranges::SHEET_SIZE, &list.key(i, "size"), s.size)?;
    for (d, &count) in s.nodes.iter().enumerate() {
        v.require(&list.key(i, "nodes"), count >= 3, || {
            format!("direction u{} has {count} nodes; at least 3 are needed", d + 1)
        })?;
    }
    v.require(&list.key(i, "topology"), s.topology != [Topology::Periodic; 2], || {
        "both directions periodic (a torus) is not supported".into()
    })?;
    let [m, n] = s.nodes;
    let spacing = |l: f64, count: usize, t: Topology| match t {
        Topology::Free => l / (count - 1) as f64,
        Topology::Periodic => l / count as f64,
    };
    Grid::new(m, n, spacing(l1, m, s.topology[0]), spacing(l2, n, s.topology[1]), s.topology)
        .map_err(|e| v.bad(&list.key(i, "nodes"), e.to_string()))
}

/// Builds obstacle `i`; body files are found relative to the scene file.
fn obstacle(v: &Validator<'_>, i: usize, o: &ObstacleSpec) -> Result<Obstacle, SceneError> {
    let key = |k: &str| format!("obstacle[{i}].{k}");
    let point = |r: &ranges::Range, k: &str, p: [f64; 3]| v.numbers(r, &key(k), p).map(Vec3::from_array);
    Ok(match o {
        ObstacleSpec::Sphere(sp) => Obstacle::Sphere {
            center: point(&ranges::SPHERE_CENTER, "sphere.center", sp.center)?,
            radius: v.number(&ranges::SPHERE_RADIUS, &key("sphere.radius"), sp.radius)?,
        },
        ObstacleSpec::Plane(p) => {
            let normal = point(&ranges::PLANE_NORMAL, "plane.normal", p.normal)?;
            if normal.length() == 0.0 {
                return Err(v.bad(&key("plane.normal"), "the normal must not be zero".into()));
            }
            Obstacle::Plane { point: point(&ranges::PLANE_POINT, "plane.point", p.point)?, normal: normal.normalize() }
        }
        ObstacleSpec::Nurbs(spec) => match (&spec.file, spec.builtin) {
            (Some(_), Some(_)) | (None, None) => {
                return Err(v.bad(
                    &key("nurbs"),
                    "give exactly one of `file` (a body file) and `builtin` (\"mannequin\" or \"mannequin_upper\")"
                        .into(),
                ));
            }
            (None, Some(BuiltinBody::Mannequin)) => Obstacle::Nurbs(Arc::new(mannequin::generate())),
            (None, Some(BuiltinBody::MannequinUpper)) => Obstacle::Nurbs(Arc::new(mannequin::generate_upper())),
            (Some(f), None) => {
                let path = relative_to(v.file(), f);
                let body = NurbsBody::from_file(&path)
                    .and_then(|b| b.check_closed().map(|()| b))
                    .map_err(|e| v.bad(&key("nurbs.file"), naming(&path, e.to_string())))?;
                Obstacle::Nurbs(Arc::new(body))
            }
        },
        ObstacleSpec::Mesh(spec) => {
            let path = relative_to(v.file(), &spec.file);
            let body =
                TriMeshBody::from_obj(&path).map_err(|e| v.bad(&key("mesh.file"), naming(&path, e.to_string())))?;
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
