//! Contact of the sheet with itself and between panels (issue 19): penalty contact between the triangulated
//! surface's elements ([`crate::contact::proximity`]) that come within the contact thickness `δ` of each
//! other, a node and a triangle or two edges, in the same step and the same records as obstacle contact.
//!
//! Each close pair is one [`Contact`] with a four-node [`Stencil`]: the weights of its closest points (a node
//! minus the barycentric point of a triangle, the difference of two edges' points), so that `Σ wₖ xₖ` is the
//! vector between them. The sheet is two-sided, so the direction is taken from the step's start (the pair's
//! difference vector there, whose side cannot have changed: no crossing is ever accepted), and the gap
//! `n·Σ wₖ xₖ` is linear in the positions: energy `½ c a (δ − gap)²`, its gradient and its Gauss–Newton
//! stiffness `c a n nᵀ` spread over the stencil by `wₖ wₗ` (action equals reaction: the weights sum to zero).
//! The active set is found at the step's start and target, and refined after each solve as for obstacles.
//!
//! **Layer friction.** Coulomb friction between layers is the obstacles' law ([`super::friction`]) on the
//! relative slip of a pair's two points: for a pair touching at the step's start, with its normal force `λ` and
//! normal lagged there, the potential `μ λ f₀(|u|)` of the tangential part `u = P Σ wₖ (yₖ − xₖ)` of the
//! stencil's displacement over the step, spread over the stencil by its weights, so each side takes the
//! opposite force (action equals reaction) and a layer dragged along by another slides or sticks as Coulomb
//! says. Its coefficient is the cloth–cloth `μ` of [`SelfContactParams::friction`], apart from the
//! cloth–obstacle one of `[contact]`. The same linear models (tangent while sliding, majorant while sticking)
//! and re-linearisations as for obstacles. A static solve has no layer friction (it has no step to slip over).
//!
//! **Intersection-free.** After a step, every pair is followed along the straight paths of its nodes by
//! conservative advancement ([`Faces::first_touch`]): a pair that would come within `10⁻³ δ` of touching
//! fails the step as tunnelled, and the stepper retakes it as two half steps. So the triangulated surface
//! never passes through itself; the displayed Coons surface stays within its deviation from the triangles
//! (second order in the grid spacing) of it, so a thickness larger than that deviation keeps it clear too.

use super::contact::{add_all, records_fit, restore_scratch, save_scratch, Contact, Other, Stencil, FRICTION_ROUNDS};
use super::friction::{FrictionLaw, Lagged, Misfit, MODEL_TOLERANCE};
use super::{ActiveSet, Context, Motion, Part, Scratch, Stage, Term, TermInfo};
use crate::contact::proximity::{Bounds, Broad, Closest, Faces, Pair};
use crate::energy::Sink;
use crate::math::Vec3;
use serde::Serialize;

/// Self-contact parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SelfContactParams {
    /// Penalty `c` (N/m³: pressure per compression of the layer).
    pub stiffness: f64,
    /// Contact thickness `δ` (m): two elements of the sheet push apart closer than this.
    pub thickness: f64,
    /// Coulomb coefficient `μ` between layers of cloth (0 = frictionless).
    pub friction: f64,
    /// Slip speed `ε_v` (m/s) below which layer friction is static (smoothed), as for obstacles.
    pub slip_speed: f64,
}

impl SelfContactParams {
    /// Frictionless self-contact of penalty `stiffness` and thickness `thickness`.
    pub fn frictionless(stiffness: f64, thickness: f64) -> Self {
        Self { stiffness, thickness, friction: 0.0, slip_speed: super::contact::ContactParams::SLIP_SPEED }
    }
}

/// Self-contact of the panels' surface.
#[derive(Debug, Clone)]
pub struct SelfContact {
    faces: Faces,
    params: SelfContactParams,
    area: Vec<f64>,
    /// A rigid body's vertices, nodes `area.len()..` of `faces` ([`Faces::against_body`]); empty for the sheet
    /// against itself.
    fixed: Vec<Vec3>,
}

/// The term's scratch: the active pairs and the configuration their directions come from.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct SelfScratch {
    pairs: Vec<Pair>,
    contacts: Vec<Contact>,
    /// The step's start (or the static solve's configuration): the pairs' sides.
    start: Vec<Vec3>,
    /// Layer friction lagged from the step's start: the stencil of each pair touching there and its law.
    lagged: Vec<(Stencil, Lagged)>,
    /// Friction re-linearisations since the last assembly.
    relinearized: usize,
    /// The step's candidate pairs: those whose elements' boxes swept from the start to the target come within
    /// the thickness and twice the [`SLACK`] (every close pair of a configuration within the slack of the
    /// swept boxes is among them), with the nodes' boxes they were swept over (grown to take in any
    /// configuration of the step that left them: [`SelfContact::cover`]).
    #[serde(skip)]
    candidates: Option<(Vec<Pair>, Vec<Bounds>)>,
    /// The broad phase's trees, refit each step to its swept boxes (rebuilt when they degrade).
    #[serde(skip)]
    broad: Broad,
    /// The last refinement changed the pairs (or their friction): a re-solve takes the change, not a held
    /// correction ([`ActiveSet::can_hold`]).
    #[serde(skip)]
    changed: bool,
}

/// How far (a multiple of the thickness, per coordinate) a configuration may leave a step's swept boxes and
/// still be searched among the step's candidate pairs.
const SLACK: f64 = 1.0;

/// Fraction of the thickness at which continuous detection calls two elements touching.
pub const TOUCH: f64 = 1e-3;

impl SelfContact {
    /// Self-contact of `faces` under `params`, nodes of rest area `area`.
    pub fn new(faces: Faces, params: SelfContactParams, area: Vec<f64>) -> Self {
        Self { faces, params, area, fixed: Vec::new() }
    }

    /// Contact of the sheet `faces` with a rigid body's surface (`vertices`, `triangles`): each body vertex
    /// against the sheet's triangles and each body edge against its edges ([`Faces::against_body`]), under
    /// `params` (its friction the cloth–obstacle `μ`); the body's side stays put.
    pub fn against_body(
        faces: &Faces,
        vertices: Vec<Vec3>,
        triangles: &[[usize; 3]],
        params: SelfContactParams,
        area: Vec<f64>,
    ) -> Self {
        Self { faces: faces.against_body(vertices.len(), triangles), params, area, fixed: vertices }
    }

    /// The rigid body's vertices (nodes `faces().fixed_from()..` of the faces); empty for the sheet against
    /// itself.
    pub fn body_vertices(&self) -> &[Vec3] {
        &self.fixed
    }

    /// What the term's saved state is called in errors.
    fn what(&self) -> &'static str {
        if self.fixed.is_empty() {
            "self-contact state"
        } else {
            "body-contact state"
        }
    }

    /// `x` (the sheet's nodes) followed by the body's fixed vertices, when there is a body and `x` lacks them.
    fn with_fixed<'a>(&self, x: &'a [Vec3]) -> std::borrow::Cow<'a, [Vec3]> {
        if self.fixed.is_empty() || x.len() != self.area.len() {
            std::borrow::Cow::Borrowed(x)
        } else {
            std::borrow::Cow::Owned(x.iter().chain(&self.fixed).copied().collect())
        }
    }

    /// The broad phase's tree builds and refits so far in `scratch` (both trees; 0 before the first search).
    pub fn broad_updates(scratch: &Scratch) -> (usize, usize) {
        scratch.get::<SelfScratch>().map_or((0, 0), |s| {
            let (t, e) = (&s.broad.triangles, &s.broad.edges);
            (t.builds + e.builds, t.refits + e.refits)
        })
    }

    /// The parameters.
    pub fn params(&self) -> &SelfContactParams {
        &self.params
    }

    /// The surface's faces.
    pub fn faces(&self) -> &Faces {
        &self.faces
    }

    fn scratch<'s>(&self, scratch: &'s mut Scratch) -> &'s mut SelfScratch {
        scratch.get_or(SelfScratch::default)
    }

    /// The active contacts held in `scratch`.
    pub fn contacts<'s>(&self, scratch: &'s mut Scratch) -> &'s [Contact] {
        &self.scratch(scratch).contacts
    }

    /// The contact of a close pair, its direction from `start`, its force that of its linear gap at `at` (the
    /// configuration the step's system is linearised at, wherever the pair was found: a pair found at the
    /// step's target or at a proposal carries there the force it would have where the solve starts from, as
    /// an obstacle's contact does, not the force at the place it was found).
    fn record(&self, c: &Closest, start: &[Vec3], at: &[Vec3]) -> Contact {
        let full = Stencil::of(&c.nodes, &c.weights);
        let before = full.point(start);
        let normal = if before.length() > 1e-12 * self.params.thickness {
            before.normalize()
        } else {
            c.delta.normalize_or(Vec3::Z)
        };
        let distance = normal.dot(c.delta);
        let (stencil, area, reference) = if self.fixed.is_empty() {
            // A node carries its own area; an edge pair the mean of its four nodes' halves.
            let area = match c.pair {
                Pair::PointFace(p, _) => self.area[p],
                Pair::EdgeEdge(..) => 0.125 * c.nodes.iter().map(|&k| self.area[k]).sum::<f64>(),
            };
            (full, area, c.delta)
        } else {
            self.body_share(c)
        };
        let stiffness = self.params.stiffness * area;
        let mut contact = Contact {
            stencil,
            other: if self.fixed.is_empty() { Other::Sheet } else { Other::Obstacle },
            normal,
            force: 0.0,
            stiffness,
            distance,
            reference,
        };
        contact.force = self.force_at(&contact, at);
        contact
    }

    /// The force of a contact's linear gap with the nodes at `x` (negative outside the layer).
    fn force_at(&self, c: &Contact, x: &[Vec3]) -> f64 {
        c.stiffness * (self.params.thickness - c.gap(c.stencil.point(x)))
    }

    /// A pair against a body: the sheet's nodes of it as the stencil, the area its penalty takes (below), and
    /// the reference `delta − (the body's fixed share of it)`, so that the gap `distance + normal·(p −
    /// reference)` of the stencil's point `p` is the pair's.
    fn body_share(&self, c: &Closest) -> (Stencil, f64, Vec3) {
        let n = self.area.len();
        let (mut nodes, mut weights, mut body) = (Vec::with_capacity(4), Vec::with_capacity(4), Vec3::ZERO);
        for (&k, &w) in c.nodes.iter().zip(&c.weights) {
            if k < n {
                nodes.push(k);
                weights.push(w);
            } else {
                body += self.fixed[k - n] * w;
            }
        }
        // A body's vertex (a corner) carries the load of a patch of cloth about a grid spacing `h` wide at one
        // point of a layer `δ` thin: the nodes' pressure law over their area times `h/δ` keeps its compression
        // like theirs. An edge carries it along a line: half the mean area, as the sheet's own edge pairs (the
        // `h/δ` stiffness there made a plate sliding on two rails chatter).
        let mean = nodes.iter().map(|&k| self.area[k]).sum::<f64>() / nodes.len().max(1) as f64;
        let area = match c.pair {
            Pair::PointFace(..) => mean * mean.sqrt() / self.params.thickness,
            Pair::EdgeEdge(..) => 0.5 * mean,
        };
        (Stencil::of(&nodes, &weights), area, c.delta - body)
    }

    /// The pairs closer than the thickness at `x` and not yet held: among the step's candidates
    /// ([`SelfContact::cover`]) during a step, else (a static solve) from the broad phase at `x`.
    fn close(&self, s: &mut SelfScratch, x: &[Vec3]) -> Vec<Closest> {
        let thickness = self.params.thickness;
        if self.cover(s, x) {
            if let Some((pairs, _)) = &s.candidates {
                return self.faces.close_among_except(pairs, &s.pairs, x, thickness, true);
            }
        }
        let candidates = self.faces.candidates_in(&mut s.broad, x, None, thickness);
        self.faces.close_among_except(&candidates, &s.pairs, x, thickness, false)
    }

    /// Whether the step's candidates hold every pair close at `x`: true when a step's candidates are held and
    /// `x` is within their slack, or after sweeping them anew (through the refit trees) over their nodes' boxes
    /// grown to take in `x` when it is not; the new ones stand for the rest of the step (the boxes only grow,
    /// so a step sweeps anew at most once per configuration that leaves all the earlier ones' slack). False
    /// without a step's candidates.
    fn cover(&self, s: &mut SelfScratch, x: &[Vec3]) -> bool {
        let thickness = self.params.thickness;
        let Some((_, boxes)) = &mut s.candidates else { return false };
        if boxes.len() != x.len() {
            return false;
        }
        if !Faces::within_boxes(x, boxes, SLACK * thickness) {
            for ((lo, hi), p) in boxes.iter_mut().zip(x) {
                (*lo, *hi) = (lo.min(*p), hi.max(*p));
            }
            let radius = (1.0 + 2.0 * SLACK) * thickness;
            let pairs = self.faces.candidates_of(&mut s.broad, boxes, radius);
            s.candidates = Some((pairs, std::mem::take(boxes)));
        }
        true
    }

    /// Adds the close pairs of `x` not yet held, as contacts linearised at `y`; returns the largest force one
    /// would have had at `at` (the proposal a solve missed them at).
    fn add_close(&self, s: &mut SelfScratch, x: &[Vec3], y: &[Vec3], at: &[Vec3]) -> f64 {
        let mut missed: f64 = 0.0;
        let fresh = self.close(s, x);
        for c in &fresh {
            let contact = self.record(c, &s.start, y);
            missed = missed.max(self.force_at(&contact, at));
            s.contacts.push(contact);
            s.pairs.push(c.pair);
        }
        if !fresh.is_empty() {
            sort(s);
        }
        missed
    }

    /// Against a body: the step's candidate pairs that come within the thickness somewhere on the straight
    /// paths from the step's start to its target `to` and are not held, each as a contact with its closest
    /// points where it first does (continuous detection, as the nodes' obstacle contact enters at the first
    /// point of a path inside the layer): a sheet that would pass a body's edge or vertex within one step is
    /// caught where it reaches it, whatever its speed.
    fn add_entered(&self, s: &mut SelfScratch, to: &[Vec3], y: &[Vec3]) {
        let Some((pairs, _)) = &s.candidates else { return };
        let (from, thickness) = (&s.start, self.params.thickness);
        let entered: Vec<(Pair, Contact)> = (self.faces.touching_among(pairs, from, to, thickness).into_iter())
            .filter(|(pair, _)| s.pairs.binary_search(pair).is_err())
            .map(|(pair, t)| (pair, self.record(&self.faces.closest_along(pair, from, to, t), from, y)))
            .collect();
        if !entered.is_empty() {
            for (pair, c) in entered {
                s.pairs.push(pair);
                s.contacts.push(c);
            }
            sort(s);
        }
    }
}

/// Layer friction lagged at the step's start: every pair touching there (not wholly fixed), its limit `μ λ` and
/// normal, linearised about the slip the pair's motion predicts (as for obstacles: the last step's relative slip
/// when it stuck, else `(v + ½ a Δt) Δt` of the relative velocity).
fn lag_friction(params: &SelfContactParams, s: &mut SelfScratch, m: &Motion, fixed: &[bool]) {
    s.lagged.clear();
    if params.friction <= 0.0 {
        return;
    }
    let eps = params.slip_speed * m.dt;
    for c in s.contacts.iter().filter(|c| c.force > 0.0) {
        if c.stencil.terms().all(|(k, _)| fixed[k]) {
            continue;
        }
        let mut l = Lagged {
            node: c.stencil.first(),
            limit: params.friction * c.force,
            normal: c.normal,
            at: Vec3::ZERO,
            majorant: false,
        };
        let st = &c.stencil;
        l.predict(st.point(m.x) - st.point(m.x_prev), st.point(m.v), st.point(m.v_prev), m.dt, eps);
        s.lagged.push((c.stencil, l));
    }
}

/// The layer friction's models into `sink`, the slips measured from `x`; returns their energy.
fn layer_friction(
    lagged: &[(Stencil, Lagged)],
    eps: f64,
    y: &[Vec3],
    x: &[Vec3],
    cx: &Context,
    sink: &mut Sink,
) -> f64 {
    let mut total = 0.0;
    for (st, l) in lagged {
        let law = FrictionLaw { limit: l.limit, eps };
        let (e, g, h) = l.model(&law, l.tangential(st.point(y) - st.point(x)));
        sink.energy += e;
        total += e;
        st.spread(g, h, cx, sink);
    }
    total
}

impl SelfContact {
    /// Re-linearises, at the proposal `z`, the friction models that are off there by more than the tolerance
    /// of the step's largest limit (at most once per assembly: each costs a re-solve); true if any was.
    fn relinearize(&self, s: &mut SelfScratch, z: &[Vec3], m: &Motion) -> bool {
        if s.relinearized >= FRICTION_ROUNDS || s.lagged.is_empty() {
            return false;
        }
        s.relinearized += 1;
        let eps = self.params.slip_speed * m.dt;
        let scale = s.lagged.iter().map(|(_, l)| l.limit).fold(0.0, f64::max);
        let mut changed = false;
        for (st, l) in &mut s.lagged {
            let law = FrictionLaw { limit: l.limit, eps };
            let u = l.tangential(st.point(z) - st.point(m.x));
            if l.model_error(&law, u) > MODEL_TOLERANCE * scale {
                l.linearize(u, eps, false);
                changed = true;
            }
        }
        changed
    }
}

/// Keeps the pairs and their contacts sorted by pair.
fn sort(s: &mut SelfScratch) {
    let mut both: Vec<(Pair, Contact)> = s.pairs.drain(..).zip(s.contacts.drain(..)).collect();
    both.sort_by_key(|a| a.0);
    (s.pairs, s.contacts) = both.into_iter().unzip();
}

impl Term for SelfContact {
    fn info(&self) -> TermInfo {
        TermInfo::new("self contact", Stage::Contact, Part::Contact)
    }

    fn evaluate(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let s = self.scratch(scratch);
        let mut total = add_all(&s.contacts, cx, sink);
        if let Some(m) = cx.motion {
            total += layer_friction(&s.lagged, self.params.slip_speed * m.dt, y, m.x, cx, sink);
        }
        total
    }

    fn active_set(&self) -> Option<&dyn ActiveSet> {
        Some(self)
    }

    fn save(&self, scratch: &Scratch) -> Result<Option<Vec<u8>>, String> {
        save_scratch::<SelfScratch>(scratch, self.what())
    }

    fn restore(&self, saved: Option<&[u8]>, scratch: &mut Scratch) -> Result<(), String> {
        let (n, all) = (self.area.len(), self.faces.nodes());
        restore_scratch(saved, scratch, self.what(), |s: &SelfScratch| {
            let fits = s.pairs.len() == s.contacts.len()
                && (s.start.is_empty() || s.start.len() == all)
                && records_fit(&s.contacts, n)
                && s.lagged.iter().all(|(st, _)| (1..=4).contains(&st.len) && st.nodes.iter().all(|&k| k < n));
            fits.then_some(()).ok_or_else(|| format!("{n} nodes"))
        })
    }
}

impl ActiveSet for SelfContact {
    /// The close pairs at `y` and, in the first assembly of a step, at its target `ŷ`; their directions from
    /// the step's start.
    fn prepare(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch) {
        let s = self.scratch(scratch);
        let all = self.faces.nodes();
        match cx.motion {
            Some(m) if m.predict => s.start = self.with_fixed(m.x).into_owned(),
            Some(_) if s.start.len() == all => {}
            _ => {
                s.start = self.with_fixed(y).into_owned();
                s.candidates = None;
            }
        }
        s.pairs.clear();
        s.contacts.clear();
        s.relinearized = 0;
        s.changed = false;
        let target = cx.motion.filter(|m| m.predict).map(|m| self.with_fixed(m.target));
        if let Some(target) = &target {
            let radius = (1.0 + 2.0 * SLACK) * self.params.thickness;
            let boxes = Faces::node_boxes(&s.start, Some(target));
            let pairs = self.faces.candidates_of(&mut s.broad, &boxes, radius);
            s.candidates = Some((pairs, boxes));
        } else if cx.motion.is_none() {
            s.candidates = None;
        }
        self.add_close(s, &self.with_fixed(y), y, y);
        match cx.motion {
            Some(m) if m.predict => {
                lag_friction(&self.params, s, &m, cx.fixed);
                let target = target.as_deref().unwrap_or(m.target);
                self.add_close(s, target, y, y);
                if !self.fixed.is_empty() {
                    self.add_entered(s, target, y);
                }
            }
            // A Newton iteration linearises the friction about the iterate.
            Some(m) => {
                let eps = self.params.slip_speed * m.dt;
                for (st, l) in &mut s.lagged {
                    l.linearize(l.tangential(st.point(y) - st.point(m.x)), eps, false);
                }
            }
            None => s.lagged.clear(),
        }
    }

    /// Only where the step holds no pair (none close, no lagged friction), the last refinement (at `x`)
    /// changed nothing and found no close pair among the candidates, and these were swept over a configuration
    /// within the slack of `x`: an assembly at `x` then finds no pair, as it would after a re-solve.
    fn can_hold(&self, x: &[Vec3], scratch: &Scratch) -> bool {
        let Some(s) = scratch.get::<SelfScratch>() else { return true };
        let none = !s.changed && s.pairs.is_empty() && s.contacts.is_empty() && s.lagged.is_empty();
        none && s.candidates.as_ref().is_some_and(|(_, boxes)| {
            let x = self.with_fixed(x);
            boxes.len() == x.len() && Faces::within_boxes(&x, boxes, SLACK * self.params.thickness)
        })
    }

    /// How far the layer friction at `y` is from the linear models the last assembly solved with, relative to
    /// the largest limit `μλ` of the step.
    fn model_error(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch) -> Misfit {
        let mut misfit = Misfit::default();
        let Some(m) = cx.motion else { return misfit };
        let eps = self.params.slip_speed * m.dt;
        let s = self.scratch(scratch);
        let scale = s.lagged.iter().map(|(_, l)| l.limit).fold(0.0, f64::max);
        for (st, l) in &s.lagged {
            let law = FrictionLaw { limit: l.limit, eps };
            misfit.add(l.model_error(&law, l.tangential(st.point(y) - st.point(m.x))) / scale);
        }
        misfit
    }

    /// After a solve proposing `y + delta`: a contact stays while its gap there is inside the layer; the pairs
    /// close at the proposal join. True when the forces the solve got wrong exceed the tolerance of the
    /// step's largest contact force (as for obstacles).
    fn refine(&self, y: &[Vec3], delta: &[Vec3], cx: &Context, scratch: &mut Scratch) -> bool {
        let s = self.scratch(scratch);
        let z: Vec<Vec3> = y.iter().zip(delta).map(|(a, b)| *a + *b).collect();
        let largest = s.contacts.iter().map(|c| c.force.abs()).fold(0.0, f64::max);
        let tolerance = MODEL_TOLERANCE * largest;
        let thickness = self.params.thickness;
        let mut changed = false;
        let mut kept = Vec::with_capacity(s.contacts.len());
        for (pair, c) in s.pairs.iter().zip(&s.contacts) {
            let gap = c.gap(c.stencil.point(&z));
            if gap < thickness {
                kept.push((*pair, *c));
            } else if c.stiffness * (gap - thickness) > tolerance {
                changed = true;
            }
        }
        (s.pairs, s.contacts) = kept.into_iter().unzip();
        let missed = self.add_close(s, &self.with_fixed(&z), y, &z);
        let relinearized = cx.motion.is_some_and(|m| self.relinearize(s, &z, &m));
        s.changed = changed || relinearized || (missed > tolerance && missed > 0.0);
        s.changed
    }

    /// The first node of a pair whose elements would come within `10⁻³ δ` of each other on the straight
    /// paths from `from` to `to`.
    fn tunnelled(&self, from: &[Vec3], to: &[Vec3], scratch: &mut Scratch) -> Option<usize> {
        let tolerance = TOUCH * self.params.thickness;
        let (from, to) = (&*self.with_fixed(from), &*self.with_fixed(to));
        let s = self.scratch(scratch);
        // The step's candidates hold every pair whose paths come within the tolerance when the step starts
        // where they were swept from and ends within their slack (swept anew to `to` when it does not).
        let step = s.start.as_slice() == from && self.cover(s, to);
        let touch = match &s.candidates {
            Some((pairs, _)) if step => self.faces.first_touch_among(pairs, from, to, tolerance),
            _ => {
                let pairs = self.faces.candidates_in(&mut s.broad, from, Some(to), tolerance);
                self.faces.first_touch_among(&pairs, from, to, tolerance)
            }
        };
        // A sheet node of the pair (against a body, the body's vertex or edge is the other side).
        let sheet = |k: usize| k < self.area.len();
        touch.map(|(pair, _)| match pair {
            Pair::PointFace(p, t) => {
                if sheet(p) {
                    p
                } else {
                    self.faces.triangles[t][0]
                }
            }
            Pair::EdgeEdge(e, f) => {
                if sheet(self.faces.edges[e][0]) {
                    self.faces.edges[e][0]
                } else {
                    self.faces.edges[f][0]
                }
            }
        })
    }

    fn active(&self, scratch: &Scratch) -> usize {
        scratch.get::<SelfScratch>().map_or(0, |s| s.contacts.iter().filter(|c| c.force > 0.0).count())
    }

    fn engaged(&self, scratch: &Scratch) -> bool {
        scratch.get::<SelfScratch>().is_some_and(|s| !s.contacts.is_empty() || !s.lagged.is_empty())
    }

    fn convergent(&self) -> bool {
        false
    }

    fn slip_speed(&self) -> f64 {
        if self.params.friction > 0.0 {
            self.params.slip_speed
        } else {
            0.0
        }
    }

    /// Against a body, each touching pair's Coulomb limit `μλ` at `x`, shared among the sheet's nodes of the
    /// pair by their weights (the body's side is fixed): the static friction the consistent start
    /// ([`crate::integrate::start`]) holds a node at rest with. The sheet against itself has none here (its
    /// friction is relative: both sides move).
    fn coulomb(&self, x: &[Vec3]) -> Vec<(usize, Vec3, f64)> {
        if self.fixed.is_empty() || self.params.friction <= 0.0 {
            return Vec::new();
        }
        let all = self.with_fixed(x);
        let close = self.faces.close(&all, self.params.thickness);
        close
            .iter()
            .map(|c| self.record(c, &all, x))
            .filter(|c| c.force > 0.0)
            .flat_map(|c| {
                let limit = self.params.friction * c.force;
                let total: f64 = c.stencil.terms().map(|(_, w)| w.abs()).sum();
                c.stencil.terms().map(move |(k, w)| (k, c.normal, limit * w.abs() / total)).collect::<Vec<_>>()
            })
            .collect()
    }

    /// Self-contact has no penetration to measure: its distances are unsigned and no crossing is accepted.
    fn violation(&self, _x: &[Vec3], _cx: &Context, _scratch: &mut Scratch) -> f64 {
        0.0
    }
}
