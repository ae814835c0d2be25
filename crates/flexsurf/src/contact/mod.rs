//! Obstacle geometry: rigid obstacles (planes, balls, NURBS bodies, triangle meshes, and any user [`Shape`])
//! answer signed distance and outward normal at a point, warm-started through a [`ContactCache`]. The contact
//! *law* (penalty pressure, friction) is a term of the total potential: [`crate::potential::contact`].
//!
//! Every kind of obstacle is a [`Shape`] in its own file ([`plane`], [`sphere`], [`nurbs`], [`trimesh`]);
//! [`Obstacle`] names the built-in ones for scene files and delegates every query to them, and
//! [`Obstacle::Custom`] carries any other shape.

use crate::math::Vec3;
use std::sync::Arc;

use nurbs::{Hint, NurbsBody};
use trimesh::TriMeshBody;

pub mod mannequin;
pub mod nurbs;
pub mod plane;
pub mod proximity;
pub mod shape;
pub mod sphere;
pub mod trimesh;

pub use plane::Plane;
pub use shape::{Look, Shape};
pub use sphere::Sphere;

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
    /// Any other shape (equal only to itself: the same `Arc`).
    Custom(Arc<dyn Shape>),
}

impl PartialEq for Obstacle {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Obstacle::Plane { point: a, normal: b }, Obstacle::Plane { point: c, normal: d }) => a == c && b == d,
            (Obstacle::Sphere { center: a, radius: r }, Obstacle::Sphere { center: c, radius: s }) => a == c && r == s,
            (Obstacle::Nurbs(a), Obstacle::Nurbs(b)) => Arc::ptr_eq(a, b) || a == b,
            (Obstacle::Mesh(a), Obstacle::Mesh(b)) => Arc::ptr_eq(a, b),
            (Obstacle::Custom(a), Obstacle::Custom(b)) => Arc::ptr_eq(a, b),
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
    /// the obstacle is certainly farther than `radius` from `p` ([`Shape::distance_within`] of its shape).
    #[inline]
    pub fn distance_hinted(&self, p: Vec3, hint: &mut Option<Hint>, radius: f64) -> Option<(f64, Vec3)> {
        self.distance_hinted_above(p, hint, radius, f64::NEG_INFINITY)
    }

    /// [`Obstacle::distance_hinted`] for a point whose signed distance is known to be at least `floor`
    /// ([`Shape::distance_within_above`]).
    #[inline]
    pub fn distance_hinted_above(
        &self,
        p: Vec3,
        hint: &mut Option<Hint>,
        radius: f64,
        floor: f64,
    ) -> Option<(f64, Vec3)> {
        match self {
            Obstacle::Plane { point, normal } => {
                Plane { point: *point, normal: *normal }.distance_within(p, hint, radius)
            }
            Obstacle::Sphere { center, radius: r } => {
                Sphere { center: *center, radius: *r }.distance_within(p, hint, radius)
            }
            Obstacle::Nurbs(body) => body.distance_within_above(p, hint, radius, floor),
            Obstacle::Mesh(body) => body.distance_within_above(p, hint, radius, floor),
            Obstacle::Custom(shape) => shape.distance_within_above(p, hint, radius, floor),
        }
    }

    /// Calls `f` with the obstacle's shape.
    pub fn with_shape<R>(&self, f: impl FnOnce(&dyn Shape) -> R) -> R {
        match self {
            Obstacle::Plane { point, normal } => f(&Plane { point: *point, normal: *normal }),
            Obstacle::Sphere { center, radius } => f(&Sphere { center: *center, radius: *radius }),
            Obstacle::Nurbs(body) => f(body.as_ref()),
            Obstacle::Mesh(body) => f(body.as_ref()),
            Obstacle::Custom(shape) => f(shape.as_ref()),
        }
    }

    /// The same obstacle with lengths scaled by `lambda` ([`Shape::scaled`]: analytic obstacles only; `None`
    /// for bodies).
    pub fn scaled(&self, lambda: f64) -> Option<Self> {
        self.with_shape(|s| s.scaled(lambda))
    }

    /// How the obstacle is drawn ([`Shape::look`]).
    pub fn look(&self) -> Option<Look> {
        self.with_shape(|s| s.look())
    }
}

/// Warm-start state of the closest-point queries: the last (patch, u, v) per obstacle and node, and per node
/// the distance found at the last detection with the position it was found at. Signed distance is 1-Lipschitz,
/// so `d(q) ≥ d(p) − |q − p|` lets later queries of a node that cannot have reached the contact layer be skipped.
/// A body's last query of each node is also kept with its answer ([`Recall`]), for the step's repeated queries.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct ContactCache {
    hints: Vec<Option<Hint>>,
    nodes: usize,
    dist: Vec<f64>,
    at: Vec<Vec3>,
    /// Not saved: a resumed run recomputes what it would have recalled, to the same bits.
    #[serde(skip)]
    recall: Vec<Option<Recall>>,
}

/// A body's last closest-point query of one node, with its answer. A query is a function of its point, its
/// radius and its warm start alone, so one asked again with the same three (to the bit) has this answer: a
/// step asks a node's distance at its start position again while it refines its contacts, with the warm start
/// the first query left (on the skirt of `scenes/skirt.toml`, 17 % of the mannequin's queries).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Recall {
    p: [u64; 3],
    radius: u64,
    hint: Option<(usize, u64, u64)>,
    answer: Option<(f64, Vec3)>,
    hint_after: Option<Hint>,
}

impl ContactCache {
    /// Empty hints for `obstacles` × `nodes`.
    pub fn new(obstacles: usize, nodes: usize) -> Self {
        Self {
            hints: vec![None; obstacles * nodes],
            nodes,
            dist: vec![f64::NEG_INFINITY; nodes],
            at: vec![Vec3::ZERO; nodes],
            recall: Vec::new(),
        }
    }

    /// Whether the cache is sized for `obstacles` × `nodes` (a checkpoint's is checked before use).
    pub(crate) fn fits(&self, obstacles: usize, nodes: usize) -> bool {
        self.nodes == nodes
            && self.hints.len() == obstacles * nodes
            && self.dist.len() == nodes
            && self.at.len() == nodes
            && self.at.iter().all(|p| crate::math::finite(*p))
            && !self.dist.iter().any(|d| d.is_nan())
    }

    pub(crate) fn ensure(&mut self, obstacles: usize, nodes: usize) {
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
    pub(crate) fn record(&mut self, k: usize, p: Vec3, d: f64) {
        self.dist[k] = d;
        self.at[k] = p;
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
    // Every obstacle's signed distance is at least the nearest one's lower bound.
    let floor = cache.lower_bound(k, p);
    let mut best: Option<(f64, Vec3)> = None;
    for (o, obstacle) in obstacles.iter().enumerate() {
        let found = match obstacle {
            Obstacle::Nurbs(_) | Obstacle::Mesh(_) => {
                // Sized at a body's first query (not for planes and balls, whose queries cost less than it).
                if cache.recall.len() != cache.hints.len() {
                    cache.recall = vec![None; cache.hints.len()];
                }
                let (hint, recall) = (&mut cache.hints[o * nodes + k], &mut cache.recall[o * nodes + k]);
                recalled(obstacle, recall, hint, p, (radius, floor))
            }
            _ => obstacle.distance_hinted(p, &mut cache.hints[o * nodes + k], radius),
        };
        if let Some((d, n)) = found {
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, n));
            }
        }
    }
    best
}

/// `obstacle`'s query at `p` within `radius` from the warm start `hint`, for a point at least `floor` from every
/// obstacle ([`Obstacle::distance_hinted_above`]), or the answer `recall` kept when it was asked the same before
/// (`floor` does not change the answer); the query asked is kept in `recall`.
fn recalled(
    obstacle: &Obstacle,
    recall: &mut Option<Recall>,
    hint: &mut Option<Hint>,
    p: Vec3,
    (radius, floor): (f64, f64),
) -> Option<(f64, Vec3)> {
    let (bits, radius_bits) = ([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()], radius.to_bits());
    let asked = hint.map(|h| (h.patch, h.u.to_bits(), h.v.to_bits()));
    if let Some(r) = recall.filter(|r| r.p == bits && r.radius == radius_bits && r.hint == asked) {
        *hint = r.hint_after;
        return r.answer;
    }
    let answer = obstacle.distance_hinted_above(p, hint, radius, floor);
    *recall = Some(Recall { p: bits, radius: radius_bits, hint: asked, answer, hint_after: *hint });
    answer
}

/// Most advancement steps of [`first_hit`] along one segment.
const ADVANCE_STEPS: usize = 256;

/// Continuous collision detection of node `k` moving along the segment `p → q`: the first point where it comes
/// within `skin` (> 0) of an obstacle's surface, as `(t, point, signed distance, outward normal)` with the point
/// `p + t (q − p)`; `None` when the whole segment stays farther. Conservative advancement: the signed distance
/// is 1-Lipschitz, so from a point at distance `d` the segment is free for a length `d − skin/2`, and no
/// crossing can be stepped over whatever the speed; after [`ADVANCE_STEPS`] steps (a path grazing the layer) the
/// point reached is reported.
pub fn first_hit(
    obstacles: &[Obstacle],
    cache: &mut ContactCache,
    k: usize,
    p: Vec3,
    q: Vec3,
    skin: f64,
) -> Option<(f64, Vec3, f64, Vec3)> {
    let len = (q - p).length();
    let mut t = 0.0;
    for _ in 0..ADVANCE_STEPS {
        let x = p + (q - p) * t;
        let (d, n) = closest_cached(obstacles, cache, k, x, (1.0 - t) * len + skin)?;
        if d < skin {
            return Some((t, x, d, n));
        }
        if len == 0.0 {
            return None;
        }
        t += (d - 0.5 * skin) / len;
        if t >= 1.0 {
            return None;
        }
    }
    let x = p + (q - p) * t;
    closest_cached(obstacles, cache, k, x, f64::INFINITY).map(|(d, n)| (t, x, d, n))
}

/// True when the straight path `p → q` of node `k` goes below an obstacle's surface: the first point within
/// `skin` of a surface ([`first_hit`]) is followed, just past it or at one of eight later points of the path, by
/// a point inside.
pub fn passes_inside(obstacles: &[Obstacle], cache: &mut ContactCache, k: usize, p: Vec3, q: Vec3, skin: f64) -> bool {
    let Some((t, _, d, _)) = first_hit(obstacles, cache, k, p, q, skin) else { return false };
    if d < 0.0 {
        return true;
    }
    let len = (q - p).length();
    if len == 0.0 {
        return false;
    }
    let just_past = (t + 2.0 * skin / len).min(1.0);
    std::iter::once(just_past)
        .chain((1..=8).map(|i| t + (1.0 - t) * i as f64 / 8.0))
        .any(|s| closest_cached(obstacles, cache, k, p + (q - p) * s, 0.0).is_some_and(|(d, _)| d < 0.0))
}
