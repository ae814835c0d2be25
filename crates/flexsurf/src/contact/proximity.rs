//! Proximity between the sheet's own faces (self-collision, issue 19): the simulated surface is the
//! triangulated grid of every panel (each cell split along its `(i, j)–(i+1, j+1)` diagonal), and two of its
//! elements are close when a node lies within a distance of a triangle, or an edge within it of another edge.
//! Elements that share a node (a node and a triangle it is a corner of, two edges with a common end) are never
//! pairs: they touch by construction. Every other pair of a flat grid is at least `h/√2` apart (a cell's
//! diagonal and the next cell's corner), so a thickness under half the shortest grid edge finds no contact in a
//! flat sheet, and a fold as sharp as one cell is still held apart.
//!
//! - **Broad phase**: bounding volume hierarchies (parry's [`Bvh`]) over the triangles' and the edges' bounding
//!   boxes (grown by the distance sought, or swept over a step's motion), queried with each node's and each
//!   edge's box in parallel; a [`Broad`] kept from one step to the next is refit to the moved boxes and rebuilt
//!   only when its queries have grown [`REBUILD`] times as costly as after its last build ([`Tree`]). A query
//!   yields exactly the leaves whose boxes overlap its box, whatever the tree's shape, and each query's hits are
//!   sorted, so candidate pairs come out in one order whatever the thread count and the tree's history.
//! - **Narrow phase**: parry's point–triangle projection (with the barycentric coordinates of the closest point)
//!   and segment–segment closest points.
//! - **Continuous detection**: conservative advancement along the straight paths of a step: the distance of a
//!   pair cannot fall faster than its nodes' relative speed, so stepping the time by (distance − tolerance) /
//!   speed never steps over a crossing, at any speed.

use crate::math::Vec3;
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::math::Vector;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy, BvhNode, BvhWorkspace};
use parry3d_f64::query::details::closest_points_segment_segment_with_locations_nD;
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::shape::Triangle;
use rayon::prelude::*;
use std::cell::Cell;

/// A box: its lower and upper corners.
pub type Bounds = (Vec3, Vec3);

/// The triangles and edges of the panels' grids over the model's nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Faces {
    /// Triangles (model nodes), two per grid cell.
    pub triangles: Vec<[usize; 3]>,
    /// Edges (model nodes, the smaller first), each once: the cells' sides and diagonals.
    pub edges: Vec<[usize; 2]>,
    /// Number of model nodes.
    nodes: usize,
    /// Each node's representative under the identification of nodes about to be joined (a sewing phase's
    /// pairs, [`Faces::with_joined`]); empty: every node is its own.
    joined: Vec<usize>,
    /// The first node of a rigid body's surface ([`Faces::against_body`]): nodes from here on are the body's
    /// fixed vertices, and only pairs of a body element with a sheet element count; `nodes` when there is none.
    fixed_from: usize,
}

/// Two elements of the surface that are close: a node and a triangle, or two edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub enum Pair {
    /// Node `0` against triangle `1` (an index of [`Faces::triangles`]).
    PointFace(usize, usize),
    /// Edge `0` against edge `1` (indices of [`Faces::edges`], the smaller first).
    EdgeEdge(usize, usize),
}

/// The closest points of a pair: its four nodes and the weights whose combination `Σ wₖ xₖ` is the vector from
/// the second element's closest point to the first's, and the distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// The pair.
    pub pair: Pair,
    /// Its nodes.
    pub nodes: [usize; 4],
    /// The weights of the difference vector.
    pub weights: [f64; 4],
    /// The difference vector `Σ wₖ xₖ`.
    pub delta: Vec3,
}

impl Closest {
    /// Distance between the closest points.
    pub fn distance(&self) -> f64 {
        self.delta.length()
    }
}

fn v(p: Vec3) -> Vector {
    Vector::new(p.x, p.y, p.z)
}

impl Faces {
    /// The faces of grids given as their cells' corners (model nodes), over `nodes` model nodes.
    pub fn new(nodes: usize, cells: impl Iterator<Item = [usize; 4]>) -> Self {
        let mut faces =
            Faces { triangles: Vec::new(), edges: Vec::new(), nodes, joined: Vec::new(), fixed_from: nodes };
        for c in cells {
            faces.triangles.push([c[0], c[1], c[3]]);
            faces.triangles.push([c[0], c[3], c[2]]);
            for (a, b) in [(0, 1), (0, 2), (1, 3), (2, 3), (0, 3)] {
                faces.edges.push([c[a].min(c[b]), c[a].max(c[b])]);
            }
        }
        faces.edges.sort_unstable();
        faces.edges.dedup();
        faces
    }

    /// The faces of a triangle mesh over `nodes` nodes: its triangles and their edges, each once (the
    /// display mesh kept apart, [`crate::runner::apart`]).
    pub fn of_triangles(nodes: usize, triangles: &[[usize; 3]]) -> Self {
        let mut edges: Vec<[usize; 2]> = triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .filter(|&(a, b)| a != b)
            .map(|(a, b)| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        Faces { triangles: triangles.to_vec(), edges, nodes, joined: Vec::new(), fixed_from: nodes }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.nodes
    }

    /// The pairs between the sheet of `self` and a rigid body's surface (`vertices`, `triangles`), numbered after
    /// the sheet's nodes: each body vertex against each sheet triangle, and each body edge against each sheet
    /// edge (a sheet node against a body triangle is the nodes' own obstacle contact). The body's vertices are
    /// nodes `self.nodes()..`, fixed: positions passed to these faces hold them after the sheet's
    /// ([`Faces::fixed_from`]).
    pub fn against_body(&self, vertices: usize, triangles: &[[usize; 3]]) -> Self {
        let n = self.nodes;
        let mut body: Vec<[usize; 2]> = triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .filter(|&(a, b)| a < vertices && b < vertices && a != b)
            .map(|(a, b)| [n + a.min(b), n + a.max(b)])
            .collect();
        body.sort_unstable();
        body.dedup();
        Faces {
            triangles: self.triangles.clone(),
            edges: self.edges.iter().copied().chain(body).collect(),
            nodes: n + vertices,
            // A body vertex is its own representative (beyond the list).
            joined: self.joined.clone(),
            fixed_from: n,
        }
    }

    /// The first fixed node (a rigid body's vertex, [`Faces::against_body`]); [`Faces::nodes`] when none is.
    pub fn fixed_from(&self) -> usize {
        self.fixed_from
    }

    /// The same faces with the nodes of each pair of `pairs` taken as one node (and so, transitively, every
    /// chain of pairs): elements that would share a node once the pairs are joined are neighbours and never a
    /// contact. A sewing phase's self-contact uses it, so the pairs being pulled together and the faces around
    /// them are not held apart, while every other element pair is. Pairs naming a node out of range are skipped.
    pub fn with_joined(mut self, pairs: &[(usize, usize)]) -> Self {
        let mut rep: Vec<usize> = (0..self.nodes).collect();
        fn root(rep: &mut [usize], mut k: usize) -> usize {
            while rep[k] != k {
                rep[k] = rep[rep[k]];
                k = rep[k];
            }
            k
        }
        for &(a, b) in pairs.iter().filter(|&&(a, b)| a < self.nodes && b < self.nodes) {
            let (ra, rb) = (root(&mut rep, a), root(&mut rep, b));
            rep[ra.max(rb)] = ra.min(rb);
        }
        for k in 0..self.nodes {
            rep[k] = root(&mut rep, k);
        }
        self.joined = rep;
        self
    }

    /// Node `k`'s representative: the smallest node it is joined with ([`Faces::with_joined`]), else `k`.
    pub fn representative(&self, k: usize) -> usize {
        self.joined.get(k).copied().unwrap_or(k)
    }

    /// True for a pair of elements that share a node, or would once the joined pairs are joined (never a
    /// contact).
    pub fn excluded(&self, pair: Pair) -> bool {
        let r = |k: usize| self.representative(k);
        if self.fixed_from < self.nodes {
            // Against a body: a body vertex and a sheet triangle, or a body edge and a sheet edge.
            let fixed = |k: usize| k >= self.fixed_from;
            return match pair {
                Pair::PointFace(p, t) => !fixed(p) || self.triangles[t].iter().any(|&k| fixed(k)),
                Pair::EdgeEdge(e, f) => fixed(self.edges[e][0]) == fixed(self.edges[f][0]),
            };
        }
        match pair {
            Pair::PointFace(p, t) => self.triangles[t].iter().any(|&k| r(k) == r(p)),
            Pair::EdgeEdge(e, f) => {
                let ([a, b], [c, d]) = (self.edges[e].map(r), self.edges[f].map(r));
                a == c || a == d || b == c || b == d
            }
        }
    }

    /// The pair's closest points at `x`.
    pub fn closest(&self, pair: Pair, x: &[Vec3]) -> Closest {
        let nodes = self.pair_nodes(pair);
        closest_of(pair, nodes, nodes.map(|k| x[k]))
    }

    /// The nodes of a pair's two elements.
    fn pair_nodes(&self, pair: Pair) -> [usize; 4] {
        match pair {
            Pair::PointFace(p, t) => {
                let [a, b, c] = self.triangles[t];
                [p, a, b, c]
            }
            Pair::EdgeEdge(e, f) => {
                let ([a, b], [c, d]) = (self.edges[e], self.edges[f]);
                [a, b, c, d]
            }
        }
    }

    /// Every pair (not neighbours) whose elements' boxes at `x`, grown by `radius`, or swept from `x` to `to`
    /// when given, overlap: the candidates, sorted (trees built for this search alone).
    pub fn candidates(&self, x: &[Vec3], to: Option<&[Vec3]>, radius: f64) -> Vec<Pair> {
        self.candidates_in(&mut Broad::default(), x, to, radius)
    }

    /// [`Faces::candidates`] through the trees of `broad`, refit to this search's boxes (or built, when they
    /// hold other elements or have degraded: [`Tree::update`]). The candidates do not depend on the trees.
    pub fn candidates_in(&self, broad: &mut Broad, x: &[Vec3], to: Option<&[Vec3]>, radius: f64) -> Vec<Pair> {
        self.candidates_of(broad, &Self::node_boxes(x, to), radius)
    }

    /// Each node's box over its positions in `x` and, when given, `to`.
    pub fn node_boxes(x: &[Vec3], to: Option<&[Vec3]>) -> Vec<Bounds> {
        match to {
            Some(to) => x.iter().zip(to).map(|(a, b)| (a.min(*b), a.max(*b))).collect(),
            None => x.iter().map(|a| (*a, *a)).collect(),
        }
    }

    /// Every pair (not neighbours) whose elements' boxes, the union of their nodes' boxes `nodes` grown by
    /// `radius`, overlap, sorted, through the trees of `broad` ([`Faces::candidates_in`]).
    pub fn candidates_of(&self, broad: &mut Broad, nodes: &[Bounds], radius: f64) -> Vec<Pair> {
        let grow = Vec3::splat(0.5 * radius);
        let bound = |ks: &[usize]| -> Bounds {
            let (lo, hi) = union(nodes, ks);
            (lo - grow, hi + grow)
        };
        // Against a body only its vertices are points of a pair: the sheet's nodes query nothing.
        let first = if self.fixed_from < self.nodes { self.fixed_from } else { 0 };
        let far = (Vec3::splat(f64::INFINITY), Vec3::splat(f64::NEG_INFINITY));
        let points: Vec<Bounds> = (0..self.nodes())
            .into_par_iter()
            .with_min_len(1024)
            .map(|k| if k < first { far } else { bound(&[k]) })
            .collect();
        let tris: Vec<Bounds> = self.triangles.par_iter().with_min_len(1024).map(|t| bound(t)).collect();
        let edges: Vec<Bounds> = self.edges.par_iter().with_min_len(1024).map(|e| bound(e)).collect();
        broad.triangles.update(&tris);
        broad.edges.update(&edges);
        let point_face = broad.triangles.overlaps(&points, &tris, |p, t| !self.excluded(Pair::PointFace(p, t)));
        let edge_edge = broad.edges.overlaps(&edges, &edges, |e, f| e < f && !self.excluded(Pair::EdgeEdge(e, f)));
        // Sorted already (each query's hits sorted, the queries in order, point–face pairs first); a sort of a
        // sorted list is one pass.
        let mut out: Vec<Pair> = point_face
            .into_iter()
            .map(|(p, t)| Pair::PointFace(p, t))
            .chain(edge_edge.into_iter().map(|(e, f)| Pair::EdgeEdge(e, f)))
            .collect();
        out.sort_unstable();
        out
    }

    /// The pairs closer than `radius` at `x`, with their closest points, in the candidates' order.
    pub fn close(&self, x: &[Vec3], radius: f64) -> Vec<Closest> {
        self.close_in(&mut Broad::default(), x, radius)
    }

    /// [`Faces::close`] through the trees of `broad` ([`Faces::candidates_in`]); the answer does not depend on
    /// the trees.
    pub fn close_in(&self, broad: &mut Broad, x: &[Vec3], radius: f64) -> Vec<Closest> {
        let candidates = self.candidates_in(broad, x, None, radius);
        self.close_among(&candidates, x, radius, false)
    }

    /// The pairs of `candidates` closer than `radius` at `x` (with `boxes`, those whose elements' boxes at `x`,
    /// grown by half the radius, overlap are measured, the others skipped as the broad phase would), in their
    /// order.
    pub fn close_among(&self, candidates: &[Pair], x: &[Vec3], radius: f64, boxes: bool) -> Vec<Closest> {
        self.close_among_except(candidates, &[], x, radius, boxes)
    }

    /// [`Faces::close_among`] without the pairs of `held` (sorted), which are not measured.
    pub fn close_among_except(
        &self,
        candidates: &[Pair],
        held: &[Pair],
        x: &[Vec3],
        radius: f64,
        boxes: bool,
    ) -> Vec<Closest> {
        let near = if boxes { Some(Near::new(self, Self::node_boxes(x, None), radius)) } else { None };
        candidates
            .par_iter()
            .with_min_len(256)
            .filter(|&&pair| near.as_ref().is_none_or(|n| n.near(pair)) && held.binary_search(&pair).is_err())
            .map(|&pair| self.closest(pair, x))
            .filter(|c| c.distance() < radius)
            .collect()
    }

    /// Whether every node of `x` lies within `slack` (in each coordinate) of the box of its positions in `from`
    /// and `to`: then every pair within `radius` at `x` is among the candidates of `from → to` for the radius
    /// `radius + 2 slack` ([`Faces::candidates`]).
    pub fn within(x: &[Vec3], from: &[Vec3], to: &[Vec3], slack: f64) -> bool {
        from.len() == to.len() && Self::within_boxes(x, &Self::node_boxes(from, Some(to)), slack)
    }

    /// Whether every node of `x` lies within `slack` (in each coordinate) of its box of `boxes`
    /// ([`Faces::node_boxes`]): then every pair within `radius` at `x` is among the candidates of those boxes
    /// for the radius `radius + 2 slack` ([`Faces::candidates_of`]).
    pub fn within_boxes(x: &[Vec3], boxes: &[Bounds], slack: f64) -> bool {
        let s = Vec3::splat(slack);
        x.len() == boxes.len()
            && x.iter().zip(boxes).all(|(p, (lo, hi))| p.cmpge(*lo - s).all() && p.cmple(*hi + s).all())
    }

    /// The first pair whose distance falls to `tolerance` or below along the straight paths from `from` to
    /// `to` (conservative advancement), with the fraction of the step where it does; `None` when every pair
    /// stays farther apart. A pair that would need more than [`Faces::ADVANCE_STEPS`] advancements counts as
    /// one that meets (the caller splits the step).
    pub fn first_touch(&self, from: &[Vec3], to: &[Vec3], tolerance: f64) -> Option<(Pair, f64)> {
        let candidates = self.candidates(from, Some(to), tolerance);
        self.first_touch_among(&candidates, from, to, tolerance)
    }

    /// [`Faces::first_touch`] among `candidates`, which must hold every pair whose elements' boxes swept from
    /// `from` to `to` come within `tolerance` (those whose swept boxes do not are skipped here).
    pub fn first_touch_among(
        &self,
        candidates: &[Pair],
        from: &[Vec3],
        to: &[Vec3],
        tolerance: f64,
    ) -> Option<(Pair, f64)> {
        let hits = self.touching_among(candidates, from, to, tolerance);
        hits.into_iter().min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
    }

    /// Every pair of `candidates` whose distance falls to `tolerance` or below along the straight paths from
    /// `from` to `to`, with the fraction of the step where it first does, in the candidates' order (the same
    /// requirement on the candidates as [`Faces::first_touch_among`]).
    pub fn touching_among(&self, candidates: &[Pair], from: &[Vec3], to: &[Vec3], tolerance: f64) -> Vec<(Pair, f64)> {
        let swept = Near::new(self, Self::node_boxes(from, Some(to)), tolerance);
        candidates
            .par_iter()
            .with_min_len(256)
            .filter(|&&pair| swept.near(pair))
            .filter_map(|&pair| self.advance(pair, from, to, tolerance).map(|t| (pair, t)))
            .collect()
    }

    /// The pair's closest points with its nodes at the fraction `t` of their straight paths from `from` to `to`.
    pub fn closest_along(&self, pair: Pair, from: &[Vec3], to: &[Vec3], t: f64) -> Closest {
        let nodes = self.pair_nodes(pair);
        closest_of(pair, nodes, nodes.map(|k| from[k] + (to[k] - from[k]) * t))
    }

    /// The first edge (an index of [`Faces::edges`]) that passes through a triangle it shares no node with at
    /// `x` (an index of [`Faces::triangles`]): a surface that intersects itself, which no step may start from.
    /// Only proper crossings count ([`segment_crosses`]): an edge touching a triangle or lying in its plane
    /// does not.
    pub fn crossing(&self, x: &[Vec3]) -> Option<(usize, usize)> {
        self.crossings(x).into_iter().next()
    }

    /// Every edge that passes through a triangle it shares no node with at `x`, as [`Faces::crossing`]
    /// finds the first: `(edge, triangle)`, sorted.
    pub fn crossings(&self, x: &[Vec3]) -> Vec<(usize, usize)> {
        self.crossings_in(&mut Tree::default(), x)
    }

    /// [`Faces::crossings`] through `tree`, refit to the triangles' boxes at `x` (or built: [`Tree::update`]);
    /// the answer does not depend on the tree.
    pub fn crossings_in(&self, tree: &mut Tree, x: &[Vec3]) -> Vec<(usize, usize)> {
        let Near { edges, triangles: tris, .. } = Near::new(self, Self::node_boxes(x, None), 0.0);
        tree.update(&tris);
        let r = |k: usize| self.representative(k);
        let apart = |e: usize, t: usize| {
            let [a, b] = self.edges[e];
            !self.triangles[t].iter().any(|&k| r(k) == r(a) || r(k) == r(b))
        };
        let mut pairs = tree.overlaps(&edges, &tris, apart);
        pairs.retain(|&(e, t)| {
            let [a, b] = self.edges[e];
            segment_crosses(x[a], x[b], self.triangles[t].map(|k| x[k]))
        });
        pairs
    }

    /// Most conservative-advancement steps for one pair.
    pub const ADVANCE_STEPS: usize = 64;

    /// Conservative advancement of one pair from `from` to `to`: the time in `[0, 1]` where its distance first
    /// falls to `tolerance`, or `None`.
    fn advance(&self, pair: Pair, from: &[Vec3], to: &[Vec3], tolerance: f64) -> Option<f64> {
        let nodes = self.pair_nodes(pair);
        let motion: [Vec3; 4] = nodes.map(|k| to[k] - from[k]);
        // The distance changes no faster than the largest motion of one side plus the other side's.
        let (one, other) = match pair {
            Pair::PointFace(..) => (motion[0].length(), motion[1..].iter().map(|m| m.length()).fold(0.0, f64::max)),
            Pair::EdgeEdge(..) => {
                (motion[0].length().max(motion[1].length()), motion[2].length().max(motion[3].length()))
            }
        };
        let speed = one + other;
        let mut t = 0.0;
        for _ in 0..Self::ADVANCE_STEPS {
            let at: [Vec3; 4] = std::array::from_fn(|k| from[nodes[k]] + motion[k] * t);
            let d = distance(pair, at);
            if d <= tolerance {
                return Some(t);
            }
            if speed * (1.0 - t) <= d - tolerance {
                return None;
            }
            // Advance by at least a hundredth of the remaining distance's worth, so a pair that stays just
            // above the tolerance ends in the step budget (and is then reported as meeting).
            t += ((d - 0.9 * tolerance) / speed).max(1e-9);
            if t >= 1.0 {
                return None;
            }
        }
        Some(t)
    }
}

/// The weights of a pair's difference vector with its four nodes at `p` (a node and a triangle's three, or two
/// edges' two each).
fn weights(pair: Pair, p: [Vec3; 4]) -> [f64; 4] {
    match pair {
        Pair::PointFace(..) => {
            let tri = Triangle::new(v(p[1]), v(p[2]), v(p[3]));
            let (_, location) = tri.project_local_point_and_get_location(v(p[0]), false);
            let w = location.barycentric_coordinates().unwrap_or([1.0 / 3.0; 3]);
            [1.0, -w[0], -w[1], -w[2]]
        }
        Pair::EdgeEdge(..) => {
            let (l1, l2) = closest_points_segment_segment_with_locations_nD((&v(p[0]), &v(p[1])), (&v(p[2]), &v(p[3])));
            let (s, t) = (l1.barycentric_coordinates(), l2.barycentric_coordinates());
            [s[0], s[1], -t[0], -t[1]]
        }
    }
}

/// The distance of a pair with its four nodes at `p`.
fn distance(pair: Pair, p: [Vec3; 4]) -> f64 {
    let w = weights(pair, p);
    (p[0] * w[0] + p[1] * w[1] + p[2] * w[2] + p[3] * w[3]).length()
}

/// The closest points of a pair of nodes `nodes` at positions `p`: their weights and `Σ wₖ pₖ`.
fn closest_of(pair: Pair, nodes: [usize; 4], p: [Vec3; 4]) -> Closest {
    let weights = weights(pair, p);
    let delta = p.iter().zip(&weights).fold(Vec3::ZERO, |acc, (&q, &w)| acc + q * w);
    Closest { pair, nodes, weights, delta }
}

/// Whether the segment `p–q` passes through the triangle `t`: its ends strictly on opposite sides of the
/// triangle's plane and the point where it meets the plane strictly inside the triangle.
fn segment_crosses(p: Vec3, q: Vec3, t: [Vec3; 3]) -> bool {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let (dp, dq) = (n.dot(p - t[0]), n.dot(q - t[0]));
    if !(dp > 0.0 && dq < 0.0 || dp < 0.0 && dq > 0.0) {
        return false;
    }
    let r = p + (q - p) * (dp / (dp - dq));
    (0..3).all(|i| n.dot((t[(i + 1) % 3] - t[i]).cross(r - t[i])) > 0.0)
}

/// The box of the nodes `ks`: the union of their boxes in `nodes` (a node not there adds nothing).
fn union(nodes: &[Bounds], ks: &[usize]) -> Bounds {
    ks.iter().fold((Vec3::splat(f64::INFINITY), Vec3::splat(f64::NEG_INFINITY)), |(lo, hi), &k| {
        let (l, h) = nodes.get(k).copied().unwrap_or((lo, hi));
        (lo.min(l), hi.max(h))
    })
}

/// The boxes of a surface's nodes, triangles and edges in one configuration (or swept over two), for the box
/// test of a pair before its closest points are measured.
struct Near {
    nodes: Vec<Bounds>,
    triangles: Vec<Bounds>,
    edges: Vec<Bounds>,
    /// The gap two boxes may leave and still be near.
    radius: f64,
}

impl Near {
    fn new(faces: &Faces, nodes: Vec<Bounds>, radius: f64) -> Self {
        let triangles = faces.triangles.par_iter().with_min_len(1024).map(|t| union(&nodes, t)).collect();
        let edges = faces.edges.par_iter().with_min_len(1024).map(|e| union(&nodes, e)).collect();
        Near { nodes, triangles, edges, radius }
    }

    /// Whether the pair's two boxes come within the radius of each other.
    fn near(&self, pair: Pair) -> bool {
        let far = (Vec3::splat(f64::INFINITY), Vec3::splat(f64::NEG_INFINITY));
        let (a, b) = match pair {
            Pair::PointFace(p, t) => (self.nodes.get(p), self.triangles.get(t)),
            Pair::EdgeEdge(e, f) => (self.edges.get(e), self.edges.get(f)),
        };
        let ((lo1, hi1), (lo2, hi2)) = (a.copied().unwrap_or(far), b.copied().unwrap_or(far));
        let r = Vec3::splat(self.radius);
        lo1.cmple(hi2 + r).all() && lo2.cmple(hi1 + r).all()
    }
}

/// How many times as many tree nodes per query and per overlap found a refit [`Tree`]'s search may test as the
/// first search after its last build before it is rebuilt.
pub const REBUILD: f64 = 1.5;

/// A bounding volume hierarchy over a list of boxes (parry's [`Bvh`], built by binned surface-area heuristic),
/// kept from one search to the next: [`Tree::update`] refits it to the boxes' new extents (the same tree, each
/// node's box recomputed from its children's, in one pass) and builds it anew only when the boxes are other
/// elements or the refit tree has degraded. The measure of degradation is the cost a search actually paid:
/// the tree nodes its queries tested per query and per overlap found ([`Tree::overlaps`]); once a search after
/// a refit costs more than [`REBUILD`] times the first search after the build, the next update rebuilds.
/// Queries yield exactly the leaves whose boxes overlap theirs, so the rule changes the cost, never a result.
#[derive(Clone, Default)]
pub struct Tree {
    bvh: Bvh,
    workspace: BvhWorkspace,
    leaves: usize,
    /// Node tests per query and overlap of the first search after the last build (0 until one ran).
    built: f64,
    /// The same of the last search.
    last: f64,
    /// Builds so far.
    pub builds: usize,
    /// Refits so far.
    pub refits: usize,
}

impl std::fmt::Debug for Tree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tree")
            .field("leaves", &self.leaves)
            .field("built", &self.built)
            .field("last", &self.last)
            .field("builds", &self.builds)
            .field("refits", &self.refits)
            .finish()
    }
}

impl Tree {
    /// The tree over `boxes`: refit when it holds as many leaves and has not degraded, else built anew.
    pub fn update(&mut self, boxes: &[Bounds]) {
        let aabb = |&(lo, hi): &Bounds| Aabb::new(v(lo), v(hi));
        let degraded = self.built > 0.0 && self.last > REBUILD * self.built;
        if self.leaves == boxes.len() && boxes.len() > 2 && !degraded {
            for (k, b) in boxes.iter().enumerate() {
                self.bvh.insert_or_update_partially(aabb(b), k as u32, 0.0);
            }
            self.bvh.refit(&mut self.workspace);
            self.refits += 1;
        } else {
            self.bvh = Bvh::from_iter(BvhBuildStrategy::Binned, boxes.iter().map(aabb).enumerate());
            self.leaves = boxes.len();
            self.built = 0.0;
            self.builds += 1;
        }
    }

    /// The pairs `(a, b)` of a box `a` of `queries` and a box `b` of `leaves` (the boxes the tree was last
    /// updated to) that overlap and that `keep` keeps, sorted. Queries run in parallel, each its own.
    pub fn overlaps(
        &mut self,
        queries: &[Bounds],
        leaves: &[Bounds],
        keep: impl Fn(usize, usize) -> bool + Sync,
    ) -> Vec<(usize, usize)> {
        let overlap = |a: &Bounds, b: &Bounds| a.0.cmple(b.1).all() && b.0.cmple(a.1).all();
        let bvh = &self.bvh;
        let found: Vec<(Vec<(usize, usize)>, usize)> = queries
            .par_iter()
            .enumerate()
            .with_min_len(256)
            .map(|(a, boxa)| {
                let query = BvhNode::leaf(Aabb::new(v(boxa.0), v(boxa.1)), 0);
                let tests = Cell::new(0_usize);
                let mut hits: Vec<(usize, usize)> = bvh
                    .leaves(|node| {
                        tests.set(tests.get() + 1);
                        node.intersects(&query)
                    })
                    .map(|b| b as usize)
                    .filter(|&b| leaves.get(b).is_some_and(|boxb| overlap(boxa, boxb)) && keep(a, b))
                    .map(|b| (a, b))
                    .collect();
                hits.sort_unstable();
                (hits, tests.get())
            })
            .collect();
        let tests: usize = found.iter().map(|f| f.1).sum();
        let pairs: Vec<(usize, usize)> = found.into_iter().flat_map(|f| f.0).collect();
        self.last = tests as f64 / (queries.len() + pairs.len()).max(1) as f64;
        if self.built == 0.0 {
            self.built = self.last;
        }
        pairs
    }
}

/// The broad phase of a surface's pairs: trees over its triangles' and its edges' boxes, kept from one search
/// to the next ([`Faces::candidates_in`]).
#[derive(Debug, Clone, Default)]
pub struct Broad {
    /// The triangles' tree (queried with the nodes' boxes).
    pub triangles: Tree,
    /// The edges' tree (queried with the edges' boxes).
    pub edges: Tree,
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    use super::{Faces, Pair};
    use crate::math::Vec3;

    /// [`Faces`]' conservative advancement of one pair.
    pub fn advance(faces: &Faces, pair: Pair, from: &[Vec3], to: &[Vec3], tolerance: f64) -> Option<f64> {
        faces.advance(pair, from, to, tolerance)
    }
}
