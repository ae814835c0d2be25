//! Obstacles and the penalty contact of MODEL.md §6: for signed distance `d` along the obstacle's outward
//! normal `ν` and contact offset `δ`, a pressure `c (δ − d)` when `d < δ`, applied as a force per node times the
//! node's rest area (so `c` is N/m³ and contact does not depend on the grid). Its stiffness `c a ν νᵀ` enters
//! the step's matrix (implicit contact). Coulomb friction acts on the tangential velocity.

use crate::math::{outer, Mat3, Vec3};
use serde::Serialize;
use std::sync::Arc;

use nurbs::{Hint, NurbsBody};
use trimesh::TriMeshBody;

pub mod mannequin;
pub mod nurbs;
pub mod trimesh;

/// A rigid obstacle with a signed distance.
#[derive(Debug, Clone)]
pub enum Obstacle {
    /// Half-space below the plane through `point` with outward `normal`.
    Plane {
        /// A point on the plane.
        point: Vec3,
        /// Outward unit normal.
        normal: Vec3,
    },
    /// Solid ball.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f64,
    },
    /// A closed body of NURBS patches (the mannequin).
    Nurbs(Arc<NurbsBody>),
    /// A closed triangle mesh (scanned or modelled bodies).
    Mesh(Arc<TriMeshBody>),
}

impl PartialEq for Obstacle {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Obstacle::Plane { point: a, normal: b }, Obstacle::Plane { point: c, normal: d }) => a == c && b == d,
            (Obstacle::Sphere { center: a, radius: r }, Obstacle::Sphere { center: c, radius: s }) => a == c && r == s,
            (Obstacle::Nurbs(a), Obstacle::Nurbs(b)) => Arc::ptr_eq(a, b) || a == b,
            (Obstacle::Mesh(a), Obstacle::Mesh(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

impl Obstacle {
    /// Signed distance of `p` (positive outside) and the outward normal at the closest point (a cold query).
    #[inline]
    pub fn distance(&self, p: Vec3) -> (f64, Vec3) {
        self.distance_hinted(p, &mut None, f64::INFINITY).unwrap_or((f64::INFINITY, Vec3::Z))
    }

    /// Signed distance and outward normal, warm-started from and updating `hint` (NURBS bodies), or `None` when
    /// the obstacle is certainly farther than `radius` from `p`.
    #[inline]
    pub fn distance_hinted(&self, p: Vec3, hint: &mut Option<Hint>, radius: f64) -> Option<(f64, Vec3)> {
        match self {
            Obstacle::Plane { point, normal } => Some(((p - *point).dot(*normal), *normal)),
            Obstacle::Sphere { center, radius: r } => {
                let d = p - *center;
                let len = d.length();
                let n = if len > 0.0 { d / len } else { Vec3::Z };
                Some((len - r, n))
            }
            Obstacle::Nurbs(body) => {
                let pr = match body.closest_within(p, *hint, radius) {
                    Some(pr) => pr,
                    None => {
                        // Nothing within `radius`: either far outside, or deeper than `radius` inside the body,
                        // which a bounded query cannot tell apart. Inside the body's box, ask without a bound.
                        let b = body.bbox();
                        let inside_box = (0..3).all(|a| p[a] >= b.min[a] && p[a] <= b.max[a]);
                        if !inside_box {
                            return None;
                        }
                        let pr = body.closest(p, *hint);
                        if pr.distance >= radius || pr.distance.is_nan() {
                            return None;
                        }
                        pr
                    }
                };
                *hint = Some(pr.hint());
                Some((pr.distance, pr.normal))
            }
            Obstacle::Mesh(body) => Some(body.distance(p)),
        }
    }

    /// The same obstacle with lengths scaled by `lambda` (analytic obstacles only; `None` for bodies).
    pub fn scaled(&self, lambda: f64) -> Option<Self> {
        match self {
            Obstacle::Plane { point, normal } => Some(Obstacle::Plane { point: *point * lambda, normal: *normal }),
            Obstacle::Sphere { center, radius } => {
                Some(Obstacle::Sphere { center: *center * lambda, radius: radius * lambda })
            }
            Obstacle::Nurbs(_) | Obstacle::Mesh(_) => None,
        }
    }
}

/// Warm-start state of the closest-point queries: the last (patch, u, v) per obstacle and node, and per node
/// the distance found at the last detection with the position it was found at. Signed distance is 1-Lipschitz,
/// so `d(q) ≥ d(p) − |q − p|` lets later queries of a node that cannot have reached the contact layer be skipped.
#[derive(Debug, Clone, Default)]
pub struct ContactCache {
    hints: Vec<Option<Hint>>,
    nodes: usize,
    dist: Vec<f64>,
    at: Vec<Vec3>,
}

impl ContactCache {
    /// Empty hints for `obstacles` × `nodes`.
    pub fn new(obstacles: usize, nodes: usize) -> Self {
        Self {
            hints: vec![None; obstacles * nodes],
            nodes,
            dist: vec![f64::NEG_INFINITY; nodes],
            at: vec![Vec3::ZERO; nodes],
        }
    }

    fn ensure(&mut self, obstacles: usize, nodes: usize) {
        if self.hints.len() != obstacles * nodes || self.nodes != nodes {
            *self = Self::new(obstacles, nodes);
        }
    }

    /// A lower bound of node `k`'s signed distance at `p` from its last detection (−∞ if none).
    #[inline]
    pub fn lower_bound(&self, k: usize, p: Vec3) -> f64 {
        self.dist[k] - (p - self.at[k]).length()
    }

    #[inline]
    fn record(&mut self, k: usize, p: Vec3, d: f64) {
        self.dist[k] = d;
        self.at[k] = p;
    }
}

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
#[derive(Debug, Clone, Copy)]
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

/// Deepest obstacle at `p`: signed distance and outward normal (`None` without obstacles).
#[inline]
pub fn closest(obstacles: &[Obstacle], p: Vec3) -> Option<(f64, Vec3)> {
    obstacles.iter().map(|o| o.distance(p)).min_by(|a, b| a.0.total_cmp(&b.0))
}

/// Deepest obstacle at node `k`'s position `p`, warm-started from the cache; obstacles farther than
/// `radius` are skipped (`None` when all are).
#[inline]
pub fn closest_cached(
    obstacles: &[Obstacle],
    cache: &mut ContactCache,
    k: usize,
    p: Vec3,
    radius: f64,
) -> Option<(f64, Vec3)> {
    let nodes = cache.nodes;
    let mut best: Option<(f64, Vec3)> = None;
    for (o, obstacle) in obstacles.iter().enumerate() {
        if let Some((d, n)) = obstacle.distance_hinted(p, &mut cache.hints[o * nodes + k], radius) {
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, n));
            }
        }
    }
    best
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_and_plane_distances() {
        let s = Obstacle::Sphere { center: Vec3::ZERO, radius: 0.3 };
        let (d, n) = s.distance(Vec3::new(0.0, 0.0, 0.5));
        assert!((d - 0.2).abs() < 1e-15 && (n - Vec3::Z).length() < 1e-15);
        let p = Obstacle::Plane { point: Vec3::new(0.0, 0.0, -1.0), normal: Vec3::Z };
        assert!((p.distance(Vec3::new(3.0, 1.0, -1.5)).0 + 0.5).abs() < 1e-15);
    }

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
