//! Penalty contact with the obstacles (docs/model.md §10): for the signed distance `d` along an obstacle's
//! outward normal `ν` and the contact offset `δ`, a pressure `c (δ − d)` when `d < δ`, applied as a force per
//! node times the node's rest area (so `c` is N/m³ and contact does not depend on the grid): energy
//! `½ c a (δ − d)²`, stiffness `c a ν νᵀ` in the step's matrix (implicit contact, with `d` linearised about the
//! detection point). Coulomb friction is implicit too: a lagged dissipative potential ([`super::friction`]) for
//! every node touching at the start of a step, with its value, gradient and positive semi-definite Hessian in
//! the step. The active set is found by [`Term::prepare`] and corrected by [`Term::refine`] after each solve;
//! the obstacles' geometry lives in [`crate::contact`].

use super::face_samples::FaceSamples;
use super::friction::{FrictionLaw, Lagged, Misfit, MODEL_TOLERANCE};
use super::{ActiveSet, Context, Part, Scratch, Stage, Term, TermInfo};
use crate::contact::{closest_cached, first_hit, passes_inside, ContactCache, Obstacle};
use crate::energy::Sink;
use crate::math::{outer, Mat3, Vec3};
use serde::Serialize;

/// Penalty contact parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ContactParams {
    /// Penalty `c` (N/m³: pressure per penetration depth).
    pub stiffness: f64,
    /// Contact offset `δ` (m): contact starts at distance `δ`.
    pub offset: f64,
    /// Coulomb friction coefficient μ (0 = frictionless).
    pub friction: f64,
    /// Slip speed `ε_v` (m/s) below which friction is static (smoothed): a node held by friction creeps at
    /// most at this speed ([`super::friction`]).
    pub slip_speed: f64,
}

impl Default for ContactParams {
    /// No contact force (stiffness, offset and friction 0) and the default slip speed.
    fn default() -> Self {
        Self { stiffness: 0.0, offset: 0.0, friction: 0.0, slip_speed: Self::SLIP_SPEED }
    }
}

impl ContactParams {
    /// Default slip speed `ε_v` (m/s): a sheet held on a slope creeps at most 0.3 mm in 3 s.
    pub const SLIP_SPEED: f64 = 1e-4;

    /// How many times the fabric's weight per area the default stiffness carries with half the offset.
    pub const PRESSURE_RATIO: f64 = 100.0;

    /// The default penalty for a fabric of areal density `density` (kg/m²) under `gravity` and the offset
    /// `offset` (> 0): `c = 2 · 100 ρ g / δ`, so a contact pressure of 100 times the fabric's weight per area
    /// compresses the layer by half the offset (docs/model.md §10), as IPC scales its barrier stiffness by the
    /// weight and the distance. Without gravity, standard gravity sets the scale.
    pub fn default_stiffness(density: f64, gravity: crate::math::Vec3, offset: f64) -> f64 {
        let g = if gravity.length() > 0.0 { gravity.length() } else { 9.80665 };
        2.0 * Self::PRESSURE_RATIO * density * g / offset
    }
}

/// The sheet's side of a contact: up to four nodes with signed weights, whose combination `Σ wₖ x_{nodes[k]}`
/// is the point whose distance the contact measures. A node against an obstacle is one node of weight 1; a
/// point against a face of the sheet is the point minus the face's barycentric combination (four nodes), two
/// edges the difference of their two points (four nodes).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Stencil {
    /// Node indices (the first `len` are used).
    pub nodes: [usize; 4],
    /// Their weights.
    pub weights: [f64; 4],
    /// How many nodes.
    pub len: u8,
}

impl Stencil {
    /// One node of weight 1.
    pub const fn node(k: usize) -> Self {
        Self { nodes: [k, 0, 0, 0], weights: [1.0, 0.0, 0.0, 0.0], len: 1 }
    }

    /// Up to four nodes with their weights.
    pub fn of(nodes: &[usize], weights: &[f64]) -> Self {
        let len = nodes.len().min(weights.len()).min(4);
        let mut s = Self { nodes: [0; 4], weights: [0.0; 4], len: len as u8 };
        s.nodes[..len].copy_from_slice(&nodes[..len]);
        s.weights[..len].copy_from_slice(&weights[..len]);
        s
    }

    /// The nodes and weights in use.
    pub fn terms(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.nodes.iter().copied().zip(self.weights.iter().copied()).take(self.len as usize)
    }

    /// The first node (the node of a node's contact).
    pub fn first(&self) -> usize {
        self.nodes[0]
    }

    /// Adds the gradient `g` and Hessian `h` of an energy of the stencil's point into `sink`: node `a` takes
    /// `w_a g` (unless fixed), the block of nodes `(a, b)` takes `w_a w_b h` (the diagonal ones through the
    /// pattern, the others as the step's extra pairs).
    pub fn spread(&self, g: Vec3, h: Mat3, cx: &Context, sink: &mut Sink) {
        for (a, wa) in self.terms() {
            if let Some(grad) = sink.grad.as_deref_mut() {
                if !cx.fixed[a] {
                    grad[a] += g * wa;
                }
            }
            for (b, wb) in self.terms() {
                if a == b {
                    sink.add_block(cx.diag[a], a, a, h * (wa * wb));
                } else if a < b {
                    sink.add_pair(a, b, h * (wa * wb));
                }
            }
        }
    }

    /// `Σ wₖ x_{nodes[k]}`.
    pub fn point(&self, x: &[Vec3]) -> Vec3 {
        let mut p = x[self.nodes[0]] * self.weights[0];
        for (k, w) in self.terms().skip(1) {
            p += x[k] * w;
        }
        p
    }
}

/// What a contact is against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Other {
    /// An obstacle (the deepest one at the point).
    Obstacle,
    /// The sheet itself or another panel (the stencil holds both sides).
    Sheet,
}

/// One contact, whatever the other side is: the sheet's [`Stencil`], with the signed distance linearised
/// about a reference point, `d(x) ≈ distance + normal·(Σ wₖ xₖ − reference)`.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    /// The sheet's nodes and weights.
    pub stencil: Stencil,
    /// What the contact is against.
    pub other: Other,
    /// Outward normal.
    pub normal: Vec3,
    /// Penalty force magnitude at the current position, `c a (δ − d)` (N); negative for a contact predicted
    /// from the motion that is not yet touching.
    pub force: f64,
    /// Stiffness `c a` along the normal (N/m).
    pub stiffness: f64,
    /// Signed distance at the reference point.
    pub distance: f64,
    /// Where the distance was evaluated.
    pub reference: Vec3,
}

impl Contact {
    /// Contact of `node` at position `x` with an obstacle, the distance `d` and normal `n` evaluated at
    /// `reference`.
    pub fn new(node: usize, x: Vec3, reference: Vec3, d: f64, n: Vec3, params: &ContactParams, area: f64) -> Self {
        let stiffness = params.stiffness * area;
        let force = stiffness * (params.offset - d - n.dot(x - reference));
        Self {
            stencil: Stencil::node(node),
            other: Other::Obstacle,
            normal: n,
            force,
            stiffness,
            distance: d,
            reference,
        }
    }

    /// The node of a node's contact (the stencil's first).
    #[inline]
    pub fn node(&self) -> usize {
        self.stencil.first()
    }

    /// Linearised signed distance with the stencil's point at `p`.
    #[inline]
    pub fn gap(&self, p: Vec3) -> f64 {
        self.distance + self.normal.dot(p - self.reference)
    }

    /// Force vector on the stencil's point (each node takes its weight's share).
    #[inline]
    pub fn force_vector(&self) -> Vec3 {
        self.normal * self.force
    }

    /// Stiffness block `c a ν νᵀ` of the stencil's point (node pair `(a, b)` takes `w_a w_b` of it).
    #[inline]
    pub fn stiffness_block(&self) -> Mat3 {
        outer(self.normal, self.normal) * self.stiffness
    }

    /// Penalty energy `½ c a (δ − d)²` (zero while not touching).
    #[inline]
    pub fn energy(&self) -> f64 {
        let f = self.force.max(0.0);
        0.5 * f * f / self.stiffness
    }

    /// Adds the contact's gradient and stiffness into `sink`: each stencil node's share of the force, the
    /// diagonal blocks through the pattern, the blocks between the stencil's nodes as the step's extra pairs.
    pub fn add_to(&self, cx: &Context, sink: &mut Sink) {
        let (f, h) = (self.force_vector(), self.stiffness_block());
        if self.stencil.len == 1 {
            let k = self.node();
            if let Some(g) = sink.grad.as_deref_mut() {
                if !cx.fixed[k] {
                    g[k] -= f;
                }
            }
            sink.add_block(cx.diag[k], k, k, h);
            return;
        }
        self.stencil.spread(-f, h, cx, sink);
    }
}

/// The energy of `contacts` into `sink` (value, gradient, stiffness: each record's [`Contact::add_to`]);
/// returns it. The one assembly of a list of records, whatever term holds it.
pub fn add_all(contacts: &[Contact], cx: &Context, sink: &mut Sink) -> f64 {
    let mut total = 0.0;
    for c in contacts {
        let e = c.energy();
        sink.energy += e;
        total += e;
    }
    for c in contacts {
        c.add_to(cx, sink);
    }
    total
}

/// Whether every record's stencil is valid for a model of `nodes` nodes (a checkpoint's is checked before use).
pub(crate) fn records_fit(contacts: &[Contact], nodes: usize) -> bool {
    contacts.iter().all(|c| (1..=4).contains(&c.stencil.len) && c.stencil.nodes.iter().all(|&k| k < nodes))
}

/// A term's scratch of type `T` encoded for a checkpoint (`None`: an empty scratch); `what` names the state in
/// messages.
pub(crate) fn save_scratch<T: Serialize + 'static>(scratch: &Scratch, what: &str) -> Result<Option<Vec<u8>>, String> {
    match scratch.get::<T>() {
        Some(c) => postcard::to_stdvec(c).map(Some).map_err(|e| format!("cannot encode the {what}: {e}")),
        None if scratch.0.is_none() => Ok(None),
        None => Err(format!("the {what} is of another kind")),
    }
}

/// Restores a term's scratch of type `T` from a checkpoint's `saved` bytes (`None`: an empty scratch), after
/// `fits` says it fits the model (else its message, after "the saved {what} does not fit the model").
pub(crate) fn restore_scratch<T: serde::de::DeserializeOwned + Send + 'static>(
    saved: Option<&[u8]>,
    scratch: &mut Scratch,
    what: &str,
    fits: impl FnOnce(&T) -> Result<(), String>,
) -> Result<(), String> {
    match saved {
        None => scratch.clear(),
        Some(bytes) => {
            let c: T = postcard::from_bytes(bytes).map_err(|e| format!("cannot decode the {what}: {e}"))?;
            fits(&c).map_err(|model| format!("the saved {what} does not fit the model ({model})"))?;
            scratch.set(c);
        }
    }
    Ok(())
}

/// Active contacts of positions `x` (node areas `area`), deepest obstacle per node.
pub fn detect(obstacles: &[Obstacle], params: &ContactParams, area: &[f64], x: &[Vec3], out: &mut Vec<Contact>) {
    let mut cache = ContactCache::new(obstacles.len(), x.len());
    detect_predicted(obstacles, params, area, x, x, &mut cache, out);
}

/// How many times a step's reach [`detect_predicted`]'s queries look (docs/performance.md, "Contact queries
/// that look ahead": on `scenes/skirt.toml` the contact stage 0.62 → 0.28 s, alike from 1.5 to 5).
const LOOK_AHEAD: f64 = 2.0;

/// Contact candidates for a step from `x` whose motion is predicted to reach `predicted`: nodes already inside
/// the contact layer (linearised at `x`), and nodes whose predicted position is inside it (linearised there),
/// so that a node fast enough to cross the whole layer in one step is caught.
pub fn detect_predicted(
    obstacles: &[Obstacle],
    params: &ContactParams,
    area: &[f64],
    x: &[Vec3],
    predicted: &[Vec3],
    cache: &mut ContactCache,
    out: &mut Vec<Contact>,
) {
    out.clear();
    if params.stiffness <= 0.0 || obstacles.is_empty() {
        return;
    }
    cache.ensure(obstacles.len(), x.len());
    for (k, (&p, &q)) in x.iter().zip(predicted).enumerate() {
        // Only obstacles within reach of this step's motion matter.
        let motion = (q - p).length();
        let reach = params.offset + motion;
        if cache.lower_bound(k, p) >= reach {
            continue;
        }
        // The query looks farther than the step can reach, so that the bound it leaves lets the next detections
        // skip a node near an obstacle but out of reach (a skirt's hem by the legs) until it has moved that
        // much: a query that finds nothing within `reach` costs about what one that finds the distance does.
        let radius = reach * LOOK_AHEAD;
        let Some((d, n)) = closest_cached(obstacles, cache, k, p, radius) else {
            // Every obstacle is farther than `radius` (bounding boxes): record that as the lower bound.
            cache.record(k, p, radius);
            continue;
        };
        // An obstacle farther than `radius` declined the query, so the nearest answer bounds the others' distance
        // only up to `radius` (a far floor plane's answer is not the mannequin's).
        cache.record(k, p, d.min(radius));
        if d >= reach {
            continue;
        }
        if d < params.offset {
            out.push(Contact::new(k, p, p, d, n, params, area[k]));
        } else if d - motion < params.offset {
            if let Some((at, dh, nh)) = entry(obstacles, cache, k, p, q, params.offset) {
                out.push(Contact::new(k, p, at, dh, nh, params, area[k]));
            }
        }
    }
}

/// Whether point `k` (of `cache`) moving from `p` to `q` went below an obstacle's surface on the way while
/// outside at both ends (passed through it).
fn passed_through(obstacles: &[Obstacle], cache: &mut ContactCache, k: usize, p: Vec3, q: Vec3, skin: f64) -> bool {
    let reach = (q - p).length();
    if cache.lower_bound(k, p) > reach {
        return false;
    }
    let Some((dp, _)) = closest_cached(obstacles, cache, k, p, reach) else { return false };
    let Some((dq, _)) = closest_cached(obstacles, cache, k, q, f64::INFINITY) else { return false };
    dp > 0.0 && dq > 0.0 && passes_inside(obstacles, cache, k, p, q, skin)
}

/// The face samples' contacts at `y` (and its predicted motion in `s.predicted`) into `s`: those of samples none
/// of whose nodes has a contact.
fn detect_samples(
    obstacles: &[Obstacle],
    params: &ContactParams,
    samples: &FaceSamples,
    y: &[Vec3],
    s: &mut ContactScratch,
) {
    let mut node_contact = vec![false; y.len()];
    for c in &s.contacts {
        node_contact[c.node()] = true;
    }
    let (at, predicted) = (samples.positions(y), samples.positions(&s.predicted));
    let mut found = Vec::new();
    detect_predicted(obstacles, params, &samples.area, &at, &predicted, &mut s.sample_cache, &mut found);
    s.sample_ids.clear();
    s.sample_contacts.clear();
    for c in found.into_iter().filter(|c| samples.counts(c.node(), &node_contact)) {
        s.sample_ids.push(c.node());
        s.sample_contacts.push(Contact { stencil: samples.stencils[c.node()], ..c });
    }
}

/// After a solve proposing `y + delta`: face samples (none of whose nodes has a contact, `s.has_contact`) that
/// end in the layer or pass through an obstacle get a contact, as nodes do. True when one was missed by more
/// than `tolerance` (or any, when the step had no contact force, `empty`).
#[allow(clippy::too_many_arguments)]
fn refine_samples(
    obstacles: &[Obstacle],
    params: &ContactParams,
    samples: &FaceSamples,
    y: &[Vec3],
    delta: &[Vec3],
    tolerance: f64,
    empty: bool,
    s: &mut ContactScratch,
) -> bool {
    let mut held = vec![false; samples.len()];
    s.sample_ids.iter().for_each(|&i| held[i] = true);
    let mut changed = false;
    for (i, st) in samples.stencils.iter().enumerate() {
        if held[i] || !samples.counts(i, &s.has_contact) {
            continue;
        }
        let (p, step) = (st.point(y), st.point(delta));
        if s.sample_cache.lower_bound(i, p) >= params.offset + step.length() {
            continue;
        }
        if let Some((at, d, n)) = entry(obstacles, &mut s.sample_cache, i, p, p + step, params.offset) {
            let c = Contact { stencil: *st, ..Contact::new(i, p, at, d, n, params, samples.area[i]) };
            let missed = c.stiffness * (params.offset - c.gap(p + step));
            changed |= empty || missed > tolerance || d <= 0.0;
            s.sample_ids.push(i);
            s.sample_contacts.push(c);
        }
    }
    changed
}

/// Where a node moving from `p` to `q` needs a contact, as (linearisation point, distance, normal) there: at
/// `q` when it ends in the contact layer no deeper than the offset below the surface (its own closest point is
/// the right one); at the first point of the path inside the layer when it ends deeper, or ends outside after
/// passing through the obstacle (continuous detection: a node that would cross the whole obstacle within the
/// step is caught where it enters); `None` for a path that stays outside the obstacle and ends outside the layer.
fn entry(
    obstacles: &[Obstacle],
    cache: &mut ContactCache,
    k: usize,
    p: Vec3,
    q: Vec3,
    offset: f64,
) -> Option<(Vec3, f64, Vec3)> {
    let layer_entry =
        |cache: &mut ContactCache| first_hit(obstacles, cache, k, p, q, offset).map(|(_, a, d, n)| (a, d, n));
    match closest_cached(obstacles, cache, k, q, offset) {
        Some((d, n)) if d < offset && d >= -offset => Some((q, d, n)),
        Some((d, _)) if d < offset => layer_entry(cache),
        // Ends outside the layer: a contact only if the path went through the obstacle on the way.
        _ => {
            // It cannot have gone below the surface unless it moved farther than its distance from it.
            let reach = (q - p).length();
            let near = cache.lower_bound(k, p) < reach
                && closest_cached(obstacles, cache, k, p, reach).is_some_and(|(d, _)| d < reach);
            if near && passes_inside(obstacles, cache, k, p, q, 1e-3 * offset.max(1e-9)) {
                layer_entry(cache)
            } else {
                None
            }
        }
    }
}

/// Most friction re-linearisations per assembly.
pub(crate) const FRICTION_ROUNDS: usize = 1;

/// Penalty contact of the sheet's nodes (rest areas `area`) with `obstacles`.
#[derive(Debug, Clone)]
pub struct PenaltyContact {
    obstacles: Vec<Obstacle>,
    params: ContactParams,
    area: Vec<f64>,
    /// Points of the sheet's faces checked too ([`super::face_samples`]); `None`: nodes only.
    samples: Option<FaceSamples>,
    /// The obstacles the samples are checked against: all but the meshes, whose own vertices and edges meet
    /// the sheet's faces exactly ([`super::body_contact`]; frictionless samples there would hold the sheet off
    /// them, in the thicker layer, and take their friction away).
    sampled: Vec<Obstacle>,
}

/// The contact term's scratch: the warm-start cache of the closest-point queries and the active set.
/// Serialisable: it carries over between steps, so a checkpoint holds it (`potential/warm.rs`).
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct ContactScratch {
    cache: ContactCache,
    contacts: Vec<Contact>,
    predicted: Vec<Vec3>,
    has_contact: Vec<bool>,
    /// Friction data lagged from the start of the step.
    lagged: Vec<Lagged>,
    /// Friction re-linearisations since the last assembly.
    relinearized: usize,
    /// Quasi-static friction of a static solve (not part of a step's checkpoint).
    #[serde(skip)]
    statics: Option<StaticLag>,
    /// The closest-point cache of the face samples.
    sample_cache: ContactCache,
    /// The face samples in contact and their records.
    sample_ids: Vec<usize>,
    sample_contacts: Vec<Contact>,
    /// How far the node contacts' linear models the last solve used were, at the iterate the last assembly
    /// found the contacts again, from the penalty there: the largest force error over the nodes relative to the
    /// largest contact force (0 for a step's first assembly).
    #[serde(skip)]
    linear_error: f64,
    /// The records before the last detection ([`ContactScratch::linear_error`]).
    #[serde(skip)]
    previous: Vec<Contact>,
    /// The records are held ([`ActiveSet::hold`]): assemblies keep them instead of detecting.
    #[serde(skip)]
    held: bool,
}

/// Lagged Coulomb friction in a static solve (docs/model.md §9, §10.2): the tangential displacement from
/// `anchor` (the configuration the solve started from) of each node in `lagged` (node, normal, `μλ`, from the
/// last outer iteration), with the smoothing length `slip`.
#[derive(Debug, Clone, Default)]
struct StaticLag {
    anchor: Vec<Vec3>,
    lagged: Vec<(usize, Vec3, f64)>,
    slip: f64,
}

impl ContactScratch {
    /// Whether the scratch fits a model of `obstacles` obstacles and `nodes` nodes, `samples` face samples checked
    /// against `sampled` of the obstacles (every vector's size, every node index): a checkpoint's is checked
    /// before use.
    pub(crate) fn fits(&self, obstacles: usize, nodes: usize, (sampled, samples): (usize, usize)) -> bool {
        self.sample_cache.fits(sampled, samples)
            && self.sample_ids.len() == self.sample_contacts.len()
            && self.sample_ids.iter().all(|&i| i < samples)
            && records_fit(&self.sample_contacts, nodes)
            && self.cache.fits(obstacles, nodes)
            && self.predicted.len() == nodes
            && self.has_contact.len() == nodes
            && records_fit(&self.contacts, nodes)
            && self.lagged.iter().all(|l| l.node < nodes)
    }
}

impl PenaltyContact {
    /// Contact with `obstacles` under `params`, nodes of rest area `area`.
    pub fn new(obstacles: Vec<Obstacle>, params: ContactParams, area: Vec<f64>) -> Self {
        Self { obstacles, params, area, samples: None, sampled: Vec::new() }
    }

    /// The same contact, also between the nodes: at the `samples` of the sheet's faces.
    pub fn with_samples(mut self, samples: FaceSamples) -> Self {
        self.samples = Some(samples);
        self.sampled = self.obstacles.iter().filter(|o| !matches!(o, Obstacle::Mesh(_))).cloned().collect();
        self
    }

    fn sample_count(&self) -> usize {
        self.samples.as_ref().map_or(0, FaceSamples::len)
    }

    /// The contact parameters.
    pub fn params(&self) -> &ContactParams {
        &self.params
    }

    /// The obstacles.
    pub fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }

    fn fresh(&self) -> ContactScratch {
        let n = self.area.len();
        ContactScratch {
            cache: ContactCache::new(self.obstacles.len(), n),
            contacts: Vec::new(),
            predicted: vec![Vec3::ZERO; n],
            has_contact: vec![false; n],
            lagged: Vec::new(),
            relinearized: 0,
            statics: None,
            sample_cache: ContactCache::new(self.sampled.len(), self.sample_count()),
            sample_ids: Vec::new(),
            sample_contacts: Vec::new(),
            linear_error: 0.0,
            previous: Vec::new(),
            held: false,
        }
    }

    fn scratch<'s>(&self, scratch: &'s mut Scratch) -> &'s mut ContactScratch {
        scratch.get_or(|| self.fresh())
    }

    /// The active contacts held in `scratch`.
    pub fn contacts<'s>(&self, scratch: &'s mut Scratch) -> &'s [Contact] {
        &self.scratch(scratch).contacts
    }
}

impl Term for PenaltyContact {
    fn info(&self) -> TermInfo {
        TermInfo::new("penalty contact", Stage::Contact, Part::Contact)
    }

    fn evaluate(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let s = self.scratch(scratch);
        let mut total = add_all(&s.contacts, cx, sink) + add_all(&s.sample_contacts, cx, sink);
        match (cx.motion, &s.statics) {
            (None, Some(f)) => total += static_friction(f, y, cx, sink),
            (Some(m), _) => total += step_friction(&s.lagged, self.params.slip_speed * m.dt, y, m.x, cx, sink),
            (None, None) => {}
        }
        total
    }

    fn active_set(&self) -> Option<&dyn ActiveSet> {
        Some(self)
    }

    fn save(&self, scratch: &Scratch) -> Result<Option<Vec<u8>>, String> {
        save_scratch::<ContactScratch>(scratch, "contact state")
    }

    fn restore(&self, saved: Option<&[u8]>, scratch: &mut Scratch) -> Result<(), String> {
        let (obstacles, nodes, samples) = (self.obstacles.len(), self.area.len(), self.sample_count());
        let sampled = self.sampled.len();
        restore_scratch(saved, scratch, "contact state", |c: &ContactScratch| {
            let fits = c.fits(obstacles, nodes, (sampled, samples));
            fits.then_some(()).ok_or_else(|| format!("{obstacles} obstacles, {nodes} nodes, {samples} face samples"))
        })
    }
}

/// Quasi-static friction: the smoothed law itself about the solve's start, for the lagged limits.
fn static_friction(f: &StaticLag, y: &[Vec3], cx: &Context, sink: &mut Sink) -> f64 {
    let mut total = 0.0;
    for &(k, normal, limit) in &f.lagged {
        if cx.fixed[k] {
            continue;
        }
        let l = Lagged { node: k, limit, normal, at: Vec3::ZERO, majorant: false };
        let law = FrictionLaw { limit, eps: f.slip };
        let u = l.tangential(y[k] - f.anchor[k]);
        let e = law.energy(u.length());
        sink.energy += e;
        total += e;
        if let Some(g) = sink.grad.as_deref_mut() {
            g[k] += law.gradient(u);
        }
        sink.add_block(cx.diag[k], k, k, law.hessian(u, l.projector()));
    }
    total
}

/// How far the contacts `before` (the records the last solve used, their linear models evaluated at `y`) are
/// from the penalty forces of `after` (the records found again at `y`): the largest difference of a node's force
/// vector, relative to the largest force of either. Both lists hold node contacts in node order, one a node (as
/// detection and [`ActiveSet::refine`] leave them), so they are merged in one pass.
fn linear_error(before: &[Contact], after: &[Contact], offset: f64, y: &[Vec3]) -> f64 {
    let (mut i, mut j) = (0, 0);
    let (mut largest, mut worst) = (0.0f64, 0.0f64);
    while i < before.len() || j < after.len() {
        let (p, q) = (before.get(i), after.get(j));
        let (kp, kq) = (p.map_or(usize::MAX, Contact::node), q.map_or(usize::MAX, Contact::node));
        let linear = match p {
            Some(c) if kp <= kq => {
                i += 1;
                c.normal * (c.stiffness * (offset - c.gap(y[kp]))).max(0.0)
            }
            _ => Vec3::ZERO,
        };
        let found = match q {
            Some(c) if kq <= kp => {
                j += 1;
                c.normal * c.force.max(0.0)
            }
            _ => Vec3::ZERO,
        };
        largest = largest.max(linear.length()).max(found.length());
        worst = worst.max((linear - found).length());
    }
    if largest > 0.0 {
        worst / largest
    } else {
        0.0
    }
}

/// A step's friction: each lagged contact's model about its linearisation, the slip measured from `x`.
fn step_friction(lagged: &[Lagged], eps: f64, y: &[Vec3], x: &[Vec3], cx: &Context, sink: &mut Sink) -> f64 {
    let mut total = 0.0;
    for l in lagged {
        let k = l.node;
        let law = FrictionLaw { limit: l.limit, eps };
        let u = l.tangential(y[k] - x[k]);
        let (e, g0, h0) = l.model(&law, u);
        sink.energy += e;
        total += e;
        if let Some(g) = sink.grad.as_deref_mut() {
            g[k] += g0;
        }
        sink.add_block(cx.diag[k], k, k, h0);
    }
    total
}

impl ActiveSet for PenaltyContact {
    /// Detects the contacts at `y`: nodes inside the contact layer and, in the first assembly of a step, nodes
    /// whose target `ŷ` is inside it. The first assembly of a step also lags the friction data: the normal
    /// force and normal of every touching contact, and the predicted tangential displacement `P (ŷ − x_t)`
    /// about which the first solve linearises the friction.
    fn prepare(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch) {
        let s = self.scratch(scratch);
        for (k, p) in s.predicted.iter_mut().enumerate() {
            *p = match cx.motion {
                Some(m) if m.predict => m.target[k],
                _ => y[k],
            };
        }
        // The last solve's records are kept aside (in a buffer reused from step to step) to measure their
        // linear models against the contacts found again here.
        if s.held {
            // The refinement's records, their forces at the iterate (the penalty of their linearised gaps).
            let offset = self.params.offset;
            for c in s.contacts.iter_mut().chain(s.sample_contacts.iter_mut()) {
                c.force = c.stiffness * (offset - c.gap(c.stencil.point(y)));
            }
            s.linear_error = 0.0;
        } else {
            std::mem::swap(&mut s.contacts, &mut s.previous);
            let (obstacles, params, area) = (&self.obstacles, &self.params, &self.area);
            detect_predicted(obstacles, params, area, y, &s.predicted, &mut s.cache, &mut s.contacts);
            let iterate = cx.motion.is_some_and(|m| !m.predict);
            s.linear_error = if iterate { linear_error(&s.previous, &s.contacts, self.params.offset, y) } else { 0.0 };
            if let Some(samples) = &self.samples {
                detect_samples(&self.sampled, &self.params, samples, y, s);
            }
        }
        s.relinearized = 0;
        match cx.motion {
            Some(m) if m.predict => {
                s.lagged.clear();
                if self.params.friction > 0.0 {
                    let eps = self.params.slip_speed * m.dt;
                    // Friction is lagged on node contacts (obstacles); a face contact's slip is relative.
                    let nodes = s.contacts.iter().filter(|c| c.stencil.len == 1);
                    for c in nodes.filter(|c| c.force > 0.0 && !cx.fixed[c.node()]) {
                        let k = c.node();
                        let mut l = Lagged {
                            node: k,
                            limit: self.params.friction * c.force,
                            normal: c.normal,
                            at: Vec3::ZERO,
                            majorant: false,
                        };
                        // The first solve linearises about the slip the node's motion predicts.
                        l.predict(m.x[k] - m.x_prev[k], m.v[k], m.v_prev[k], m.dt, eps);
                        s.lagged.push(l);
                    }
                }
            }
            // A Newton iteration linearises about the iterate.
            Some(m) => {
                let eps = self.params.slip_speed * m.dt;
                for l in &mut s.lagged {
                    let u = l.tangential(y[l.node] - m.x[l.node]);
                    if m.exact {
                        l.exact(u);
                    } else {
                        l.linearize(u, eps, false);
                    }
                }
            }
            None => s.lagged.clear(),
        }
    }

    /// How far the friction force at `y` is from the linear model the last assembly solved with, relative to
    /// the largest Coulomb limit `μλ` of the step's contacts (largest over the nodes).
    fn model_error(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch) -> Misfit {
        let mut misfit = Misfit::default();
        let Some(m) = cx.motion else { return misfit };
        let eps = self.params.slip_speed * m.dt;
        let s = self.scratch(scratch);
        let scale = s.lagged.iter().map(|l| l.limit).fold(0.0, f64::max);
        for l in &s.lagged {
            let law = FrictionLaw { limit: l.limit, eps };
            let u = l.tangential(y[l.node] - m.x[l.node]);
            misfit.add(l.model_error(&law, u) / scale);
        }
        misfit
    }

    /// Active-set update after a solve giving the correction `delta` of `y`: a contact stays if its linearised
    /// gap at the new position is inside the layer; a node that ends inside the layer without a contact gets
    /// one, linearised at its new position.
    fn refine(&self, y: &[Vec3], delta: &[Vec3], cx: &Context, scratch: &mut Scratch) -> bool {
        if self.obstacles.is_empty() || self.params.stiffness <= 0.0 {
            return false;
        }
        let params = &self.params;
        let s = self.scratch(scratch);
        // A change of the contact set costs a re-solve only where the force the solve got wrong is more than
        // `MODEL_TOLERANCE` of the largest contact force of the step (as for friction's models): a node that
        // barely left the layer kept a tiny pull, one that barely entered missed a tiny push.
        let largest = s.contacts.iter().map(|c| c.force.abs()).fold(0.0, f64::max);
        let tolerance = MODEL_TOLERANCE * largest;
        let mut changed = false;
        let mut keep = |c: &Contact| {
            let gap = c.gap(c.stencil.point(y) + c.stencil.point(delta));
            let keep = gap < params.offset;
            if !keep && c.stiffness * (gap - params.offset) > tolerance {
                changed = true;
            }
            keep
        };
        s.contacts.retain(&mut keep);
        let kept: Vec<bool> = s.sample_contacts.iter().map(&mut keep).collect();
        let mut flags = kept.iter();
        s.sample_ids.retain(|_| *flags.next().unwrap_or(&false));
        let mut flags = kept.iter();
        s.sample_contacts.retain(|_| *flags.next().unwrap_or(&false));
        s.has_contact.iter_mut().for_each(|f| *f = false);
        for c in &s.contacts {
            s.has_contact[c.node()] = true;
        }
        for k in 0..y.len() {
            if s.has_contact[k] || cx.fixed[k] {
                continue;
            }
            let q = y[k] + delta[k];
            if s.cache.lower_bound(k, y[k]) >= params.offset + delta[k].length() {
                continue;
            }
            if let Some((at, d, n)) = entry(&self.obstacles, &mut s.cache, k, y[k], q, params.offset) {
                let c = Contact::new(k, y[k], at, d, n, params, self.area[k]);
                // The push the solve missed at the proposal (or the whole crossing, caught from the path).
                let missed = c.stiffness * (params.offset - c.gap(q));
                if largest == 0.0 || missed > tolerance || d <= 0.0 {
                    changed = true;
                }
                s.contacts.push(c);
            }
        }
        s.contacts.sort_by_key(|c| c.node());
        if let Some(samples) = &self.samples {
            changed |= refine_samples(&self.sampled, params, samples, y, delta, tolerance, largest == 0.0, s);
        }
        // Friction whose linear model is off at the proposal is re-linearised there (at most
        // `FRICTION_ROUNDS` times per assembly: each costs a re-solve).
        if let Some(m) = cx.motion.filter(|m| !m.exact && s.relinearized < FRICTION_ROUNDS) {
            s.relinearized += 1;
            let eps = params.slip_speed * m.dt;
            let scale = s.lagged.iter().map(|l| l.limit).fold(0.0, f64::max);
            for l in &mut s.lagged {
                let law = FrictionLaw { limit: l.limit, eps };
                let u = l.tangential(y[l.node] + delta[l.node] - m.x[l.node]);
                if l.model_error(&law, u) > MODEL_TOLERANCE * scale {
                    l.linearize(u, eps, false);
                    changed = true;
                }
            }
        }
        changed
    }

    /// A node whose straight path `from → to` crossed an obstacle's surface and left it again on the far side
    /// (passed through), with the obstacle-free length it travelled inside.
    fn tunnelled(&self, from: &[Vec3], to: &[Vec3], scratch: &mut Scratch) -> Option<usize> {
        if self.obstacles.is_empty() || self.params.stiffness <= 0.0 {
            return None;
        }
        let s = self.scratch(scratch);
        let skin = 1e-3 * self.params.offset.max(1e-9);
        if let Some(k) =
            (0..from.len()).find(|&k| passed_through(&self.obstacles, &mut s.cache, k, from[k], to[k], skin))
        {
            return Some(k);
        }
        let samples = self.samples.as_ref()?;
        samples.stencils.iter().enumerate().find_map(|(i, st)| {
            let (p, q) = (st.point(from), st.point(to));
            passed_through(&self.sampled, &mut s.sample_cache, i, p, q, skin).then(|| st.first())
        })
    }

    fn slip_speed(&self) -> f64 {
        if self.params.friction > 0.0 {
            self.params.slip_speed
        } else {
            0.0
        }
    }

    fn coulomb(&self, x: &[Vec3]) -> Vec<(usize, Vec3, f64)> {
        if self.params.friction <= 0.0 {
            return Vec::new();
        }
        let mut contacts = Vec::new();
        detect(&self.obstacles, &self.params, &self.area, x, &mut contacts);
        contacts
            .iter()
            .filter(|c| c.force > 0.0)
            .map(|c| (c.node(), c.normal, self.params.friction * c.force))
            .collect()
    }

    fn active(&self, scratch: &Scratch) -> usize {
        scratch
            .get::<ContactScratch>()
            .map_or(0, |s| s.contacts.iter().chain(&s.sample_contacts).filter(|c| c.force > 0.0).count())
    }

    fn linear_error(&self, scratch: &Scratch) -> f64 {
        scratch.get::<ContactScratch>().map_or(0.0, |s| s.linear_error)
    }

    fn engaged(&self, scratch: &Scratch) -> bool {
        scratch
            .get::<ContactScratch>()
            .is_some_and(|s| !s.contacts.is_empty() || !s.lagged.is_empty() || !s.sample_contacts.is_empty())
    }

    /// Deepest penetration below any obstacle's surface (0 when none), in metres.
    fn violation(&self, x: &[Vec3], _cx: &Context, scratch: &mut Scratch) -> f64 {
        let offset = self.params.offset.max(0.0);
        let s = self.scratch(scratch);
        let mut worst: f64 = 0.0;
        for (k, p) in x.iter().enumerate() {
            if s.cache.lower_bound(k, *p) >= 0.0 {
                continue;
            }
            if let Some((d, _)) = closest_cached(&self.obstacles, &mut s.cache, k, *p, offset) {
                worst = worst.max(-d);
            }
        }
        worst
    }

    fn forget(&self, scratch: &mut Scratch) {
        let statics = scratch.get_mut::<ContactScratch>().and_then(|c| c.statics.take());
        scratch.clear();
        if statics.is_some() {
            scratch.set(ContactScratch { statics, ..self.fresh() });
        }
    }

    fn can_hold(&self, x: &[Vec3], scratch: &Scratch) -> bool {
        let offset = self.params.offset;
        scratch
            .get::<ContactScratch>()
            .is_none_or(|s| s.contacts.iter().chain(&s.sample_contacts).all(|c| c.gap(c.stencil.point(x)) >= -offset))
    }

    fn hold(&self, scratch: &mut Scratch, on: bool) {
        if let Some(s) = scratch.get_mut::<ContactScratch>() {
            s.held = on;
        }
    }

    fn mark_touched(&self, scratch: &Scratch, touched: &mut [bool]) {
        let Some(s) = scratch.get::<ContactScratch>() else { return };
        for c in s.contacts.iter().chain(&s.sample_contacts) {
            c.stencil.terms().for_each(|(k, _)| touched[k] = true);
        }
        s.lagged.iter().for_each(|l| touched[l.node] = true);
    }

    fn relag(&self, x: &[Vec3], start: bool, slip_time: f64, scratch: &mut Scratch) -> bool {
        if start {
            let lagged = if self.slip_speed() > 0.0 { self.coulomb(x) } else { Vec::new() };
            let friction = !lagged.is_empty();
            let lag = StaticLag { anchor: x.to_vec(), lagged, slip: self.slip_speed() * slip_time };
            self.scratch(scratch).statics = friction.then_some(lag);
            return friction;
        }
        let next = self.coulomb(x);
        let Some(lag) = self.scratch(scratch).statics.as_mut().filter(|l| !l.lagged.is_empty()) else { return false };
        let scale = lag.lagged.iter().map(|l| l.2).fold(0.0, f64::max);
        let same = next.len() == lag.lagged.len()
            && next.iter().zip(&lag.lagged).all(|(a, b)| a.0 == b.0 && (a.2 - b.2).abs() <= 0.01 * scale);
        if !same {
            lag.lagged = next;
        }
        !same
    }
}
