//! Penalty contact with the obstacles (docs/model.md §10): for the signed distance `d` along an obstacle's
//! outward normal `ν` and the contact offset `δ`, a pressure `c (δ − d)` when `d < δ`, applied as a force per
//! node times the node's rest area (so `c` is N/m³ and contact does not depend on the grid): energy
//! `½ c a (δ − d)²`, stiffness `c a ν νᵀ` in the step's matrix (implicit contact, with `d` linearised about the
//! detection point). Coulomb friction acts, explicitly, on the tangential velocity of the step's start (only in
//! a dynamic step). The active set is found by [`Term::prepare`] and corrected by [`Term::refine`] after each
//! solve; the obstacles' geometry lives in [`crate::contact`].

use super::{Context, Part, Scratch, Stage, Term, TermInfo};
use crate::contact::{closest_cached, ContactCache, Obstacle};
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
}

/// One node's contact, with the signed distance linearised about a reference point:
/// `d(x) ≈ distance + normal·(x − reference)`.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    /// Node index.
    pub node: usize,
    /// Outward normal.
    pub normal: Vec3,
    /// Penalty force magnitude at the node's current position, `c a (δ − d)` (N); negative for a contact
    /// predicted from the node's motion that is not yet touching.
    pub force: f64,
    /// Stiffness `c a` along the normal (N/m).
    pub stiffness: f64,
    /// Signed distance at the reference point.
    pub distance: f64,
    /// Where the distance was evaluated.
    pub reference: Vec3,
}

impl Contact {
    /// Contact of `node` at position `x`, with the distance `d` and normal `n` evaluated at `reference`.
    pub fn new(node: usize, x: Vec3, reference: Vec3, d: f64, n: Vec3, params: &ContactParams, area: f64) -> Self {
        let stiffness = params.stiffness * area;
        let force = stiffness * (params.offset - d - n.dot(x - reference));
        Self { node, normal: n, force, stiffness, distance: d, reference }
    }

    /// Linearised signed distance at `x`.
    #[inline]
    pub fn gap(&self, x: Vec3) -> f64 {
        self.distance + self.normal.dot(x - self.reference)
    }

    /// Force vector on the node.
    #[inline]
    pub fn force_vector(&self) -> Vec3 {
        self.normal * self.force
    }

    /// Stiffness block `c a ν νᵀ`.
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
}

/// Active contacts of positions `x` (node areas `area`), deepest obstacle per node.
pub fn detect(obstacles: &[Obstacle], params: &ContactParams, area: &[f64], x: &[Vec3], out: &mut Vec<Contact>) {
    let mut cache = ContactCache::new(obstacles.len(), x.len());
    detect_predicted(obstacles, params, area, x, x, &mut cache, out);
}

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
        let Some((d, n)) = closest_cached(obstacles, cache, k, p, reach) else {
            // Every obstacle is farther than `reach` (bounding boxes): record that as the lower bound.
            cache.record(k, p, reach);
            continue;
        };
        cache.record(k, p, d);
        if d < params.offset {
            out.push(Contact::new(k, p, p, d, n, params, area[k]));
        } else if d - motion < params.offset {
            if let Some((dq, nq)) = closest_cached(obstacles, cache, k, q, params.offset) {
                if dq < params.offset {
                    out.push(Contact::new(k, p, q, dq, nq, params, area[k]));
                }
            }
        }
    }
}

/// Coulomb friction on a contact node moving with velocity `v` (mass `m`, step `dt`): opposes the tangential
/// velocity with magnitude `μ F_n`, capped so that it cannot reverse the tangential motion within one step.
#[inline]
pub fn friction(contact: &Contact, mu: f64, v: Vec3, m: f64, dt: f64) -> Vec3 {
    if mu <= 0.0 {
        return Vec3::ZERO;
    }
    let vt = v - contact.normal * v.dot(contact.normal);
    let speed = vt.length();
    if speed == 0.0 {
        return Vec3::ZERO;
    }
    let mag = (mu * contact.force.max(0.0)).min(m * speed / dt);
    -vt / speed * mag
}

/// Penalty contact of the sheet's nodes (rest areas `area`) with `obstacles`.
#[derive(Debug, Clone)]
pub struct PenaltyContact {
    obstacles: Vec<Obstacle>,
    params: ContactParams,
    area: Vec<f64>,
}

/// The contact term's scratch: the warm-start cache of the closest-point queries and the active set.
/// Serialisable: it carries over between steps, so a checkpoint holds it (`potential/warm.rs`).
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct ContactScratch {
    cache: ContactCache,
    contacts: Vec<Contact>,
    predicted: Vec<Vec3>,
    has_contact: Vec<bool>,
}

impl PenaltyContact {
    /// Contact with `obstacles` under `params`, nodes of rest area `area`.
    pub fn new(obstacles: Vec<Obstacle>, params: ContactParams, area: Vec<f64>) -> Self {
        Self { obstacles, params, area }
    }

    /// The contact parameters.
    pub fn params(&self) -> &ContactParams {
        &self.params
    }

    fn scratch<'s>(&self, scratch: &'s mut Scratch) -> &'s mut ContactScratch {
        let n = self.area.len();
        let o = self.obstacles.len();
        scratch.get_or(|| ContactScratch {
            cache: ContactCache::new(o, n),
            contacts: Vec::new(),
            predicted: vec![Vec3::ZERO; n],
            has_contact: vec![false; n],
        })
    }

    /// The active contacts held in `scratch`.
    pub fn contacts<'s>(&self, scratch: &'s mut Scratch) -> &'s [Contact] {
        &self.scratch(scratch).contacts
    }
}

impl Term for PenaltyContact {
    fn info(&self) -> TermInfo {
        TermInfo { name: "penalty contact", stage: Stage::Contact, part: Part::Contact }
    }

    /// Detects the contacts at `y`: nodes inside the contact layer and, in the first assembly of a step, nodes
    /// whose extrapolated position `2x_t − x⁻` is inside it.
    fn prepare(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch) {
        let s = self.scratch(scratch);
        for (k, p) in s.predicted.iter_mut().enumerate() {
            *p = match cx.motion {
                Some(m) if m.predict => m.x[k] * 2.0 - m.x_prev[k],
                _ => y[k],
            };
        }
        detect_predicted(&self.obstacles, &self.params, &self.area, y, &s.predicted, &mut s.cache, &mut s.contacts);
    }

    fn evaluate(&self, _y: &[Vec3], cx: &Context, scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let s = self.scratch(scratch);
        let mut total = 0.0;
        for c in &s.contacts {
            let e = c.energy();
            sink.energy += e;
            total += e;
        }
        for c in &s.contacts {
            let k = c.node;
            // Friction (in a step only) is an explicit force from the step's start velocity and the contact's
            // normal force: not the gradient of an energy, and not in the matrix (docs/model.md §10).
            let force = match cx.motion {
                Some(m) if !cx.fixed[k] => {
                    let v = (m.x[k] - m.x_prev[k]) / m.dt;
                    c.force_vector() + friction(c, self.params.friction, v, m.mass[k], m.dt)
                }
                _ => c.force_vector(),
            };
            if let Some(g) = sink.grad.as_deref_mut() {
                if !cx.fixed[k] {
                    g[k] -= force;
                }
            }
            sink.add_block(cx.diag[k], k, k, c.stiffness_block());
        }
        total
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
        let before = s.contacts.len();
        s.contacts.retain(|c| c.gap(y[c.node] + delta[c.node]) < params.offset);
        let mut changed = s.contacts.len() != before;
        s.has_contact.iter_mut().for_each(|f| *f = false);
        for c in &s.contacts {
            s.has_contact[c.node] = true;
        }
        for k in 0..y.len() {
            if s.has_contact[k] || cx.fixed[k] {
                continue;
            }
            let q = y[k] + delta[k];
            if s.cache.lower_bound(k, q) >= params.offset {
                continue;
            }
            if let Some((d, n)) = closest_cached(&self.obstacles, &mut s.cache, k, q, params.offset) {
                if d < params.offset {
                    s.contacts.push(Contact::new(k, y[k], q, d, n, params, self.area[k]));
                    changed = true;
                }
            }
        }
        if changed {
            s.contacts.sort_by_key(|c| c.node);
        }
        changed
    }

    fn active(&self, scratch: &Scratch) -> usize {
        match scratch.0.as_ref().and_then(|b| b.downcast_ref::<ContactScratch>()) {
            Some(s) => s.contacts.iter().filter(|c| c.force > 0.0).count(),
            None => 0,
        }
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

    fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn penalty_force_and_friction() {
        let s = Obstacle::Sphere { center: Vec3::ZERO, radius: 1.0 };
        let params = ContactParams { stiffness: 100.0, offset: 0.01, friction: 0.5 };
        let mut out = Vec::new();
        detect(&[s], &params, &[0.5, 0.5], &[Vec3::new(0.0, 0.0, 0.995), Vec3::new(0.0, 0.0, 2.0)], &mut out);
        assert_eq!(out.len(), 1);
        // c a (δ − d) = 100 · 0.5 · (0.01 + 0.005).
        assert!((out[0].force - 0.75).abs() < 1e-12);
        let f = friction(&out[0], 0.5, Vec3::new(1.0, 0.0, 0.0), 1.0, 0.01);
        assert!((f + Vec3::new(0.375, 0.0, 0.0)).length() < 1e-12);
        // Capped: a slow node is stopped, not reversed.
        let f = friction(&out[0], 0.5, Vec3::new(1e-4, 0.0, 0.0), 1.0, 0.01);
        assert!((f.x + 1e-2).abs() < 1e-12);
    }
}
