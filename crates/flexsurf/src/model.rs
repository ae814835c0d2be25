//! What stays fixed during a run: the grid and rest shape, the fabric, the lumped masses and damping, and the
//! total potential ([`Potential`]: the elastic terms, gravity and loads, springs, contact, and the pinned nodes).
//!
//! A [`Model`] is built once, through one validated path: fill a [`ModelBuilder`] (by a scene or by hand) and
//! call [`ModelBuilder::build`]. Afterwards it is read by the integrators; between steps a script may move a
//! pinned node ([`Model::move_pin`]) or a spring's target ([`Model::set_spring_target`]), nothing else.

use crate::contact::proximity::Faces;
use crate::contact::Obstacle;
use crate::energy::frame::Warp;
use crate::grid::Grid;
use crate::material::{Fabric, Stiffness};
use crate::math::{finite, Vec3};
use crate::potential::body_contact::BodyContact;
use crate::potential::contact::{ContactParams, PenaltyContact};
use crate::potential::external::External;
use crate::potential::face_samples::FaceSamples;
use crate::potential::self_contact::{SelfContact, SelfContactParams};
use crate::potential::springs::Springs;
use crate::potential::{elastic, Part, Pins, Potential, Term};
use crate::seam::{self, PanelView, Seam, SeamedEdges, Welds};
use crate::state::State;
use serde::Serialize;
use thiserror::Error;

pub use crate::potential::elastic::{ElasticOptions, ModelKind};
pub use crate::potential::springs::Spring;

/// Energies of a configuration, by term.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Energies {
    /// Membrane (stretch and shear), J.
    pub membrane: f64,
    /// Bending and twist, J.
    pub bending: f64,
}

/// Rest area per node: each cell's rest area `|c1 × c2| h1 h2` (bilinear cell tangents of the rest shape)
/// shared equally by its four corners. For a flat rectangular grid this is the trapezoid area `h1 h2` (halved
/// on edges, quartered at corners); for a cone or any other non-rectangular pattern it is the true share.
pub fn rest_areas(grid: &Grid, rest: &[Vec3]) -> Vec<f64> {
    let mut area = vec![0.0; grid.len()];
    for (i, j) in grid.cells() {
        let c = grid.cell(i, j);
        let c1 = (rest[c[1]] - rest[c[0]] + rest[c[3]] - rest[c[2]]) * 0.5;
        let c2 = (rest[c[2]] - rest[c[0]] + rest[c[3]] - rest[c[1]]) * 0.5;
        let a = c1.cross(c2).length();
        for k in c {
            area[k] += 0.25 * a;
        }
    }
    area
}

/// A model that cannot be built: the builder's field and what is wrong.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("model: `{field}`: {message}")]
pub struct ModelError {
    /// The builder field.
    pub field: &'static str,
    /// What is wrong.
    pub message: String,
}

fn model_error(field: &'static str, message: String) -> ModelError {
    ModelError { field, message }
}

/// One panel of a [`ModelBuilder`]: its grid, its rest shape (one position per node of the grid, in the grid's
/// order) and its material frame and rest-shape options.
#[derive(Debug, Clone)]
pub struct PanelSpec {
    /// The panel's parametric grid.
    pub grid: Grid,
    /// Rest shape, one position per node of the panel.
    pub rest: Vec<Vec3>,
    /// Warp direction and rest-shape options.
    pub options: ElasticOptions,
    /// The panel's own fabric, when it is not the builder's (a garment of several fabrics).
    pub material: Option<PanelMaterial>,
}

/// A panel's own fabric: its constants (density and damping for the masses) and calibrated stiffness (its
/// membrane and bending terms). The seams' bending across panels and nonlinear laws stay the builder's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanelMaterial {
    /// The fabric's constants.
    pub fabric: Fabric,
    /// Its calibrated coefficients.
    pub stiffness: Stiffness,
}

/// Everything a [`Model`] is made of, filled in before [`ModelBuilder::build`] validates it and builds the
/// potential. `pinned`, `loads` start empty-handed (no pins, zero loads) with one entry per panel node (every
/// panel's nodes, panel after panel); `springs` name panel nodes too. Without seams these are the model's
/// nodes; with seams the model numbers the joined nodes once ([`crate::seam::weld`]): a joined node is pinned
/// when either side is, and carries the sum of the sides' loads.
#[derive(Debug, Clone)]
pub struct ModelBuilder {
    /// The panels (one for a single sheet), in node order.
    pub panels: Vec<PanelSpec>,
    /// The fabric.
    pub fabric: Fabric,
    /// Calibrated coefficients.
    pub stiffness: Stiffness,
    /// Which elastic model.
    pub kind: ModelKind,
    /// Gravity (m/s²).
    pub gravity: Vec3,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Contact parameters (used when there are obstacles).
    pub contact: ContactParams,
    /// Pinned nodes, held exactly at their position.
    pub pinned: Vec<bool>,
    /// Constraint springs.
    pub springs: Vec<Spring>,
    /// Constant external nodal loads (N), beyond gravity (the paper's `p`).
    pub loads: Vec<Vec3>,
    /// Further terms of the potential (appended to their stage).
    pub extra_terms: Vec<Box<dyn Term>>,
    /// Seams joining panel edges node to node ([`crate::seam`]).
    pub seams: Vec<Seam>,
    /// Contact of the sheet with itself and between panels (`None`: off).
    pub self_contact: Option<SelfContactParams>,
    /// Panel-node pairs that self-contact takes as one node (a sewing phase's pairs, about to be joined:
    /// [`Faces::with_joined`]); empty outside sewing.
    pub self_contact_joined: Vec<(usize, usize)>,
    /// Obstacle contact also at points of the faces between the nodes ([`crate::potential::face_samples`]).
    pub contact_faces: bool,
    /// Nonlinear laws of the fabric (`None`: linear). The stiffness must carry their quadratic parts
    /// ([`crate::material::law::Laws::apply`] on the fabric, `kes` calibration; checked by `build`).
    pub laws: Option<std::sync::Arc<crate::material::law::Laws>>,
}

impl ModelBuilder {
    /// A builder of one panel `grid` with rest shape `rest` and no obstacles, pins, springs or loads; warp
    /// along `u1` (see [`ModelBuilder::options`]).
    pub fn new(
        grid: Grid,
        rest: Vec<Vec3>,
        fabric: Fabric,
        stiffness: Stiffness,
        kind: ModelKind,
        gravity: Vec3,
    ) -> Self {
        let n = grid.len();
        Self {
            panels: vec![PanelSpec { grid, rest, options: ElasticOptions::default(), material: None }],
            fabric,
            stiffness,
            kind,
            gravity,
            obstacles: Vec::new(),
            contact: ContactParams::default(),
            pinned: vec![false; n],
            springs: Vec::new(),
            loads: vec![Vec3::ZERO; n],
            extra_terms: Vec::new(),
            seams: Vec::new(),
            self_contact: None,
            self_contact_joined: Vec::new(),
            contact_faces: false,
            laws: None,
        }
    }

    /// The same builder with explicit [`ElasticOptions`] (warp direction, flat pattern) for its last panel.
    pub fn options(mut self, options: ElasticOptions) -> Self {
        if let Some(p) = self.panels.last_mut() {
            p.options = options;
        }
        self
    }

    /// The same builder with one more panel (its nodes follow the others'); `pinned` and `loads` grow by the
    /// panel's nodes (not pinned, no load).
    pub fn panel(mut self, grid: Grid, rest: Vec<Vec3>, options: ElasticOptions) -> Self {
        let n = grid.len();
        self.panels.push(PanelSpec { grid, rest, options, material: None });
        self.pinned.extend(std::iter::repeat_n(false, n));
        self.loads.extend(std::iter::repeat_n(Vec3::ZERO, n));
        self
    }

    /// The same builder with one more seam.
    pub fn seam(mut self, seam: Seam) -> Self {
        self.seams.push(seam);
        self
    }

    /// Number of panel nodes of every panel together (before seams join any).
    pub fn nodes(&self) -> usize {
        self.panels.iter().map(|p| p.grid.len()).sum()
    }

    /// The model's numbering of the panel nodes, the seams joined.
    fn welds(&self) -> Result<Welds, ModelError> {
        let grids: Vec<Grid> = self.panels.iter().map(|p| p.grid).collect();
        seam::weld(&grids, &self.seams).map_err(|e| model_error("seams", e.to_string()))
    }

    fn validate(&self) -> Result<(), ModelError> {
        if self.panels.is_empty() {
            return Err(model_error("panels", "a model needs at least one panel".into()));
        }
        for (p, panel) in self.panels.iter().enumerate() {
            let (len, n) = (panel.rest.len(), panel.grid.len());
            if len != n {
                return Err(model_error("rest", format!("panel {p} has {len} rest positions for a grid of {n} nodes")));
            }
            if let Some(k) = panel.rest.iter().position(|p| !finite(*p)) {
                return Err(model_error("rest", format!("node {k} of panel {p} is not finite")));
            }
        }
        let n = self.nodes();
        for (field, len) in [("pinned", self.pinned.len()), ("loads", self.loads.len())] {
            if len != n {
                return Err(model_error(field, format!("has {len} entries for a model of {n} nodes")));
            }
        }
        if let Some(k) = self.loads.iter().position(|p| !finite(*p)) {
            return Err(model_error("loads", format!("node {k} is not finite")));
        }
        // The sign rules of the range table (models built by hand, in scaled units, may leave its bounds).
        use crate::ranges::{self, Range};
        let sign = |field: &'static str, range: &Range, v: f64| match range.sign_problem(v, true) {
            Some(p) => Err(model_error(field, p)),
            None => Ok(()),
        };
        self.gravity.to_array().iter().try_for_each(|&g| sign("gravity", &ranges::GRAVITY, g))?;
        for s in &self.springs {
            if s.node >= n || !finite(s.target) {
                return Err(model_error(
                    "springs",
                    format!("spring at node {} (target {}) is outside the grid or not finite", s.node, s.target),
                ));
            }
            sign("springs", &ranges::SPRING_STIFFNESS, s.stiffness)?;
        }
        let c = &self.contact;
        // A builder's contact stiffness may be 0 (no contact force, the default).
        let stiffness = Range { rule: ranges::Rule::NonNegative, ..ranges::CONTACT_STIFFNESS };
        sign("contact.stiffness", &stiffness, c.stiffness)?;
        if !self.obstacles.is_empty() {
            sign("contact.slip_speed", &ranges::SLIP_SPEED, c.slip_speed)?;
        }
        sign("contact.offset", &ranges::CONTACT_OFFSET, c.offset)?;
        sign("contact.friction", &ranges::FRICTION, c.friction)?;
        self.validate_self_contact()?;
        self.validate_laws()
    }

    /// The linear terms carry the quadratic part of each law: the stiffness coefficient of a direction with a
    /// curve is the curve's smallest slope.
    fn validate_laws(&self) -> Result<(), ModelError> {
        let Some(laws) = &self.laws else { return Ok(()) };
        if let Some(p) = self.panels.iter().position(|p| p.material.is_some()) {
            let message = format!("panel {p} has its own fabric: nonlinear laws need one fabric for every panel");
            return Err(model_error("laws", message));
        }
        let s = &self.stiffness;
        let pairs = [
            ("tensile warp", laws.tensile_warp.as_ref(), s.a11),
            ("tensile weft", laws.tensile_weft.as_ref(), s.a22),
            ("shear", laws.shear.as_ref(), s.a66),
            ("bending warp", laws.bending_warp.as_ref(), s.d11),
            ("bending weft", laws.bending_weft.as_ref(), s.d22),
        ];
        for (name, curve, coef) in pairs {
            if let Some(c) = curve {
                let k = c.min_slope();
                if (coef - k).abs() > 1e-12 * k || (name.starts_with("tensile") && s.a12 != 0.0) {
                    let message = format!(
                        "the {name} curve's quadratic part {k:e} is not the stiffness's {coef:e} (apply the laws to \
                         the fabric with `Laws::apply` and calibrate with `kes`)"
                    );
                    return Err(model_error("laws", message));
                }
            }
        }
        Ok(())
    }

    /// Self-contact's stiffness and thickness are positive, and the thickness under half the shortest rest
    /// edge (closer elements than that are grid neighbours, which never count as contacts).
    fn validate_self_contact(&self) -> Result<(), ModelError> {
        let Some(p) = self.self_contact else { return Ok(()) };
        if !(p.stiffness > 0.0 && p.stiffness.is_finite()) {
            return Err(model_error("self_contact.stiffness", format!("{} is not a positive stiffness", p.stiffness)));
        }
        let shortest =
            self.panels.iter().flat_map(|p| cell_edges(&p.grid, &p.rest)).map(|e| e.2).fold(f64::INFINITY, f64::min);
        if !(p.thickness > 0.0 && p.thickness < 0.5 * shortest) {
            let message = format!(
                "{} m is not a thickness between 0 and half the shortest grid edge ({:.4} m)",
                p.thickness,
                0.5 * shortest
            );
            return Err(model_error("self_contact.thickness", message));
        }
        Ok(())
    }

    /// Validates and builds the model: masses and damping from the rest areas, and the potential's terms in
    /// order (membrane, bending, gravity and loads; springs; contact; then `extra_terms` in their stages).
    pub fn build(self) -> Result<Model, ModelError> {
        self.validate()?;
        let welds = self.welds()?;
        let n = welds.nodes;
        let panels: Vec<Panel> = self
            .panels
            .iter()
            .zip(&welds.maps)
            .map(|(p, map)| Panel { grid: p.grid, nodes: map.clone(), rest: p.rest.clone(), warp: p.options.warp() })
            .collect();
        let welded = |p: &[f64]| -> Vec<f64> { scatter_add(&panels, p, n) };
        let areas: Vec<Vec<f64>> = self.panels.iter().map(|p| rest_areas(&p.grid, &p.rest)).collect();
        let area = welded(&areas.concat());
        // Each panel's share of a node's area carries that panel's density and damping.
        let per_area = |f: fn(&Fabric) -> f64| -> Vec<f64> {
            let of = |p: &PanelSpec| f(p.material.as_ref().map_or(&self.fabric, |m| &m.fabric));
            welded(
                &self.panels.iter().zip(&areas).flat_map(|(p, a)| a.iter().map(move |a| a * of(p))).collect::<Vec<_>>(),
            )
        };
        let mass: Vec<f64> = per_area(|f| f.density);
        let damping = per_area(|f| f.damping);
        let mut terms = self.elastic_terms(&panels);
        let loads = scatter_add(&panels, &self.loads, n);
        terms.push(Box::new(External::new(self.gravity, &mass, &loads)));
        let all = welds.maps.concat();
        let node = |k: usize| all[k];
        if !self.springs.is_empty() {
            let springs = self.springs.iter().map(|s| Spring { node: node(s.node), ..*s }).collect();
            terms.push(Box::new(Springs::new(springs)));
        }
        // The triangulated surface, built once for the terms that take it.
        let sheet = (self.contact_faces || self.self_contact.is_some()).then(|| faces(&panels, n));
        let with_faces = sheet.as_ref().filter(|_| self.contact_faces);
        if let Some(sheet) = with_faces.filter(|_| self.contact.stiffness > 0.0) {
            terms.extend(body_contacts(&self.obstacles, &self.contact, sheet, &area));
        }
        if !self.obstacles.is_empty() {
            let contact = PenaltyContact::new(self.obstacles, self.contact, area.clone());
            terms.push(Box::new(match with_faces {
                Some(sheet) => contact.with_samples(FaceSamples::new(sheet, &area)),
                None => contact,
            }));
        }
        if let Some(params) = self.self_contact {
            let joined: Vec<(usize, usize)> = (self.self_contact_joined.iter())
                .filter(|&&(a, b)| a < all.len() && b < all.len())
                .map(|&(a, b)| (node(a), node(b)))
                .collect();
            let sheet = sheet.unwrap_or_else(|| faces(&panels, n));
            terms.push(Box::new(SelfContact::new(sheet.with_joined(&joined), params, area.clone())));
        }
        terms.extend(self.extra_terms);
        let mut pinned = vec![false; n];
        for (k, &p) in self.pinned.iter().enumerate() {
            pinned[node(k)] |= p;
        }
        let potential = Potential::new(n, terms, Pins::from_flags(pinned));
        let rest = first_of(&panels, &self.panels.iter().flat_map(|p| p.rest.iter().copied()).collect::<Vec<_>>(), n);
        Ok(Model {
            panels,
            rest,
            fabric: self.fabric,
            stiffness: self.stiffness,
            kind: self.kind,
            seams: self.seams,
            mass,
            damping,
            area,
            gravity: self.gravity,
            potential,
        })
    }
}

impl ModelBuilder {
    /// The elastic terms of every panel on its own grid and rest shape, numbered as the model's nodes, and the
    /// bending points the seams put back across them (one more term of the same name).
    fn elastic_terms(&self, panels: &[Panel]) -> Vec<Box<dyn Term>> {
        let mut terms = Vec::new();
        for (p, (spec, panel)) in self.panels.iter().zip(panels).enumerate() {
            let seamed = SeamedEdges::of(p, &spec.grid, &self.seams);
            let (grid, rest, options) = (&spec.grid, &spec.rest, &spec.options);
            let stiffness = spec.material.as_ref().map_or(&self.stiffness, |m| &m.stiffness);
            let own = seamed.clone();
            terms.extend(elastic::panel_terms(grid, rest, stiffness, self.kind, options, &panel.nodes, own));
            if let Some(laws) = &self.laws {
                terms.extend(elastic::nonlinear_terms(grid, rest, laws, options, &panel.nodes, seamed));
            }
        }
        if !self.seams.is_empty() {
            let views: Vec<PanelView<'_>> =
                panels.iter().map(|p| PanelView { grid: &p.grid, rest: &p.rest, map: &p.nodes }).collect();
            let warp = |p: usize| (self.panels[p].options.warp(), self.panels[p].options.flat_pattern);
            let bending = seam::seam_bending(&self.seams, &views, &self.stiffness, warp);
            terms.push(elastic::bending_term(bending, self.kind));
            if let Some(laws) = &self.laws {
                let warp = |p: usize| self.panels[p].options.warp();
                terms.extend(elastic::seam_hysteresis(&self.seams, &views, laws, warp));
            }
        }
        terms
    }
}

/// The grid edges of `grid` as local node pairs with their lengths in `rest`: each cell's four edges, cell by
/// cell (an edge shared by two cells comes twice).
fn cell_edges<'a>(grid: &'a Grid, rest: &'a [Vec3]) -> impl Iterator<Item = (usize, usize, f64)> + 'a {
    grid.cells().flat_map(move |(i, j)| {
        let c = grid.cell(i, j);
        [(0, 1), (0, 2), (1, 3), (2, 3)].map(|(a, b)| (c[a], c[b], (rest[c[b]] - rest[c[a]]).length()))
    })
}

/// The contact of the sheet's faces with each mesh body's own vertices and edges ([`BodyContact`]), of the
/// obstacles' penalty and friction and half their offset.
fn body_contacts(obstacles: &[Obstacle], contact: &ContactParams, sheet: &Faces, area: &[f64]) -> Vec<Box<dyn Term>> {
    let params = SelfContactParams {
        stiffness: contact.stiffness,
        thickness: 0.5 * contact.offset,
        friction: contact.friction,
        slip_speed: contact.slip_speed,
    };
    let meshes = obstacles.iter().filter_map(|o| if let Obstacle::Mesh(body) = o { Some(body) } else { None });
    meshes.map(|body| Box::new(BodyContact::new(sheet, body, params, area.to_vec())) as Box<dyn Term>).collect()
}

/// The triangulated surface of every panel over the model's `n` nodes.
fn faces(panels: &[Panel], n: usize) -> Faces {
    Faces::new(n, panels.iter().flat_map(|p| p.grid.cells().map(move |(i, j)| p.grid.cell(i, j).map(|k| p.global(k)))))
}

/// Sums per-panel-node values into the model's nodes (a joined node gets both sides' shares).
fn scatter_add<T: Copy + std::ops::AddAssign + Default>(panels: &[Panel], values: &[T], n: usize) -> Vec<T> {
    let mut out = vec![T::default(); n];
    let all = panels.iter().flat_map(|p| p.nodes.iter().copied());
    for (k, v) in all.zip(values) {
        out[k] += *v;
    }
    out
}

/// Per-panel-node values onto the model's nodes, a joined node taking its first panel node's value.
fn first_of<T: Copy + Default>(panels: &[Panel], values: &[T], n: usize) -> Vec<T> {
    let mut out = vec![T::default(); n];
    let mut seen = vec![false; n];
    let all = panels.iter().flat_map(|p| p.nodes.iter().copied());
    for (k, v) in all.zip(values) {
        if !std::mem::replace(&mut seen[k], true) {
            out[k] = *v;
        }
    }
    out
}

/// One panel of a model: a parametric grid over the model's flat node vectors.
///
/// A model holds one or more panels (a sheet, the pieces of a garment). Panel `p`'s local node `k`
/// (`Grid::index` order) is the model's node `global(k)`: without seams the panels follow each other without
/// gaps (`offset + k`); a node joined by a seam to an earlier panel node has that node's number.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// The panel's parametric grid.
    pub grid: Grid,
    /// The model's node of each local node.
    nodes: Vec<usize>,
    /// The panel's own rest shape (two panels joined by a seam may place the joined node differently: flat
    /// pieces sewn together).
    rest: Vec<Vec3>,
    /// Where the warp runs in the rest shape (the display's UVs follow it).
    warp: Warp,
}

impl Panel {
    /// A panel of `grid` over the model's nodes `offset..offset + grid.len()`, with rest shape `rest`.
    pub fn contiguous(grid: Grid, offset: usize, rest: Vec<Vec3>) -> Self {
        Self { grid, nodes: (offset..offset + grid.len()).collect(), rest, warp: Warp::default() }
    }

    /// The same panel with its warp running as `warp` says (the default: along `u1`).
    pub fn with_warp(self, warp: Warp) -> Self {
        Self { warp, ..self }
    }

    /// Where the warp runs in the rest shape.
    pub fn warp(&self) -> Warp {
        self.warp
    }

    /// The model's node of each local node.
    pub fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    /// The model's index of the panel's local node `k`.
    #[inline]
    pub fn global(&self, k: usize) -> usize {
        self.nodes[k]
    }

    /// The panel's rest shape, in its grid's node order.
    pub fn rest(&self) -> &[Vec3] {
        &self.rest
    }

    /// This panel's values of a per-node vector of the model, in its grid's node order.
    pub fn gather<T: Copy>(&self, all: &[T]) -> Vec<T> {
        self.nodes.iter().map(|&k| all[k]).collect()
    }
}

/// Everything that stays fixed during a run.
#[derive(Debug, Clone)]
pub struct Model {
    /// The panels, in node order (one for a single sheet).
    pub panels: Vec<Panel>,
    /// Rest shape of every panel (also the initial shape unless a scene says otherwise).
    pub rest: Vec<Vec3>,
    /// The fabric.
    pub fabric: Fabric,
    /// Calibrated coefficients.
    pub stiffness: Stiffness,
    /// Which elastic model.
    pub kind: ModelKind,
    /// The seams joining the panels' edges.
    pub seams: Vec<Seam>,
    /// Lumped node masses ρ·area (kg).
    pub mass: Vec<f64>,
    /// Lumped node damping γ·area (kg/s).
    pub damping: Vec<f64>,
    /// Rest area per node (m²).
    pub area: Vec<f64>,
    /// Gravity (m/s²).
    pub gravity: Vec3,
    /// The total potential and the pinned nodes.
    pub potential: Potential,
}

impl Model {
    /// Number of nodes of every panel together.
    pub fn nodes(&self) -> usize {
        self.rest.len()
    }

    /// The grid of a model of one panel without seams (a single sheet, its nodes the grid's); `None` for a
    /// model of several panels or a seamed one. For the features that are defined on one grid (the virtual
    /// textile tests, the Python arrays).
    pub fn sheet_grid(&self) -> Option<&Grid> {
        match self.panels.as_slice() {
            [one] if self.seams.is_empty() => Some(&one.grid),
            _ => None,
        }
    }

    /// Per-panel-node values (every panel's nodes, panel after panel, as a [`ModelBuilder`] numbers them) onto
    /// the model's nodes, a node joined by a seam taking its first panel node's value (initial positions and
    /// velocities given per panel).
    pub fn from_panel_nodes<T: Copy + Default>(&self, values: &[T]) -> Vec<T> {
        first_of(&self.panels, values, self.nodes())
    }

    /// Total mass (kg).
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    /// A model node named for messages: `sheet p node [i, j]` (the first panel holding it; `node [i, j]` for a
    /// model of one panel).
    pub fn describe_node(&self, k: usize) -> String {
        for (p, panel) in self.panels.iter().enumerate() {
            if let Some(local) = panel.nodes().iter().position(|&g| g == k) {
                let (i, j) = panel.grid.coords(local);
                return if self.panels.len() == 1 {
                    format!("node [{i}, {j}]")
                } else {
                    format!("sheet {p} node [{i}, {j}]")
                };
            }
        }
        format!("node {k}")
    }

    /// Pinned nodes, one flag per node.
    pub fn pinned(&self) -> &[bool] {
        self.potential.fixed()
    }

    /// The obstacles of the potential.
    pub fn obstacles(&self) -> Vec<Obstacle> {
        self.potential.obstacles()
    }

    /// The parameters of the potential's contact term (`None` without obstacles).
    pub fn contact_params(&self) -> Option<ContactParams> {
        self.potential.find::<PenaltyContact>().map(|c| *c.params())
    }

    /// The springs of the potential.
    pub fn springs(&self) -> Vec<Spring> {
        self.potential.springs()
    }

    /// Moves pinned node `node` to `position` in `state`, between steps (scripted manipulation, a gripper).
    /// The node's previous position is kept, so the next step sees the pin moving at
    /// `(position − x_prev)/Δt`; the step holds the node exactly where it was put. A position outside the
    /// scenes' coordinate bound (±1e6 m, `ranges::position_problem`) is refused.
    pub fn move_pin(&self, state: &mut State, node: usize, position: Vec3) -> Result<(), ModelError> {
        if node >= self.nodes() || node >= state.x.len() {
            return Err(model_error("pinned", format!("node {node} is outside the model of {} nodes", self.nodes())));
        }
        if !self.pinned()[node] {
            return Err(model_error("pinned", format!("node {node} is not pinned")));
        }
        if let Some(problem) = crate::ranges::position_problem(position) {
            return Err(model_error("pinned", format!("node {node}'s position: {problem}")));
        }
        state.x[node] = position;
        Ok(())
    }

    /// Moves the target of spring `index` (in the order of [`Model::springs`]) to `target`, between steps
    /// (within ±1e6 m, as [`Model::move_pin`]).
    pub fn set_spring_target(&mut self, index: usize, target: Vec3) -> Result<(), ModelError> {
        if let Some(problem) = crate::ranges::position_problem(target) {
            return Err(model_error("springs", format!("spring {index}'s target: {problem}")));
        }
        if self.potential.find_mut::<Springs>().is_some_and(|s| s.set_target(index, target)) {
            Ok(())
        } else {
            let count = self.potential.springs().len();
            Err(model_error("springs", format!("spring {index} does not exist (the model has {count})")))
        }
    }

    /// Potential energy of gravity and the constant loads, `−Σ (m g + p)·x` (J).
    pub fn potential_energy(&self, x: &[Vec3]) -> f64 {
        self.potential.value_of(x, |p| p == Part::Load, None).load
    }

    /// Elastic energies at `x`, adding `∂E/∂x` (for Terzopoulos: minus its force) into `grad` when given.
    pub fn elastic(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> Energies {
        let v = self.potential.value_of(x, Part::is_elastic, grad);
        Energies { membrane: v.membrane, bending: v.bending }
    }

    /// A length scale of the sheet (diagonal of the rest pattern; the largest panel's), for bounds and
    /// tolerances.
    pub fn length_scale(&self) -> f64 {
        let diagonal = |g: &Grid| {
            let l1 = g.h1 * g.spans(0) as f64;
            let l2 = g.h2 * g.spans(1) as f64;
            (l1 * l1 + l2 * l2).sqrt()
        };
        self.panels.iter().map(|p| diagonal(&p.grid)).fold(0.0, f64::max)
    }

    /// The grid edges of every panel as model node pairs with their rest lengths (in the panel's own rest
    /// shape): each cell's four edges, cell by cell, panel after panel (an edge shared by two cells comes
    /// twice).
    pub fn edges(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        self.panels.iter().flat_map(|panel| {
            cell_edges(&panel.grid, &panel.rest).map(|(a, b, l)| (panel.global(a), panel.global(b), l))
        })
    }

    /// The triangulated surface of every panel (each cell split along its `(i, j)–(i+1, j+1)` diagonal), as
    /// self-contact sees it.
    pub fn faces(&self) -> Faces {
        faces(&self.panels, self.nodes())
    }

    /// Largest engineering stretch `|ℓ/ℓ₀ − 1|` over all grid edges of every panel.
    pub fn max_strain(&self, x: &[Vec3]) -> f64 {
        let mut worst: f64 = 0.0;
        for (a, b, l0) in self.edges() {
            let l = (x[b] - x[a]).length();
            worst = worst.max((l / l0 - 1.0).abs());
        }
        worst
    }
}
