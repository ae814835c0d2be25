//! Proximity between the sheet's own faces (self-collision, issue 19): the simulated surface is the
//! triangulated grid of every panel (each cell split along its `(i, j)–(i+1, j+1)` diagonal), and two of its
//! elements are close when a node lies within a distance of a triangle, or an edge within it of another edge.
//! Elements that share a node (a node and a triangle it is a corner of, two edges with a common end) are never
//! pairs: they touch by construction. Every other pair of a flat grid is at least `h/√2` apart (a cell's
//! diagonal and the next cell's corner), so a thickness under half the shortest grid edge finds no contact in a
//! flat sheet, and a fold as sharp as one cell is still held apart.
//!
//! - **Broad phase**: a uniform grid of cells of one size over the elements' bounding boxes (grown by the
//!   distance sought, or swept over a step's motion), kept as a sorted list of (cell, element) keys, so that
//!   candidate pairs come out in one order whatever the thread count.
//! - **Narrow phase**: parry's point–triangle projection (with the barycentric coordinates of the closest point)
//!   and segment–segment closest points.
//! - **Continuous detection**: conservative advancement along the straight paths of a step: the distance of a
//!   pair cannot fall faster than its nodes' relative speed, so stepping the time by (distance − tolerance) /
//!   speed never steps over a crossing, at any speed.

use crate::math::Vec3;
use parry3d_f64::math::Vector;
use parry3d_f64::query::details::closest_points_segment_segment_with_locations_nD;
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::shape::Triangle;
use rayon::prelude::*;

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
        let mut faces = Faces { triangles: Vec::new(), edges: Vec::new(), nodes, joined: Vec::new() };
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

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.nodes
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
        let weights = weights(pair, nodes.map(|k| x[k]));
        Closest { pair, nodes, weights, delta: combine(&nodes, &weights, x) }
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
    /// when given, overlap: the candidates, sorted.
    pub fn candidates(&self, x: &[Vec3], to: Option<&[Vec3]>, radius: f64) -> Vec<Pair> {
        let bound = |nodes: &[usize]| -> (Vec3, Vec3) {
            let mut lo = Vec3::splat(f64::INFINITY);
            let mut hi = Vec3::splat(f64::NEG_INFINITY);
            for &k in nodes {
                for p in std::iter::once(x[k]).chain(to.map(|t| t[k])) {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
            }
            (lo - Vec3::splat(0.5 * radius), hi + Vec3::splat(0.5 * radius))
        };
        let nodes: Vec<(Vec3, Vec3)> = (0..self.nodes()).map(|k| bound(&[k])).collect();
        let tris: Vec<(Vec3, Vec3)> = self.triangles.iter().map(|t| bound(t)).collect();
        let edges: Vec<(Vec3, Vec3)> = self.edges.iter().map(|e| bound(e)).collect();
        let size = tris.iter().map(|(lo, hi)| (*hi - *lo).max_element()).fold(radius, f64::max).max(f64::MIN_POSITIVE);
        let mut out: Vec<Pair> = overlaps(&nodes, &tris, size, false)
            .into_iter()
            .map(|(p, t)| Pair::PointFace(p, t))
            .chain(overlaps(&edges, &edges, size, true).into_iter().map(|(e, f)| Pair::EdgeEdge(e, f)))
            .filter(|&pair| !self.excluded(pair))
            .collect();
        out.sort_unstable();
        out
    }

    /// The pairs closer than `radius` at `x`, with their closest points, in the candidates' order.
    pub fn close(&self, x: &[Vec3], radius: f64) -> Vec<Closest> {
        let candidates = self.candidates(x, None, radius);
        self.close_among(&candidates, x, radius, false)
    }

    /// The pairs of `candidates` closer than `radius` at `x` (with `boxes`, those whose elements' boxes at `x`,
    /// grown by half the radius, overlap are measured, the others skipped as the broad phase would), in their
    /// order.
    pub fn close_among(&self, candidates: &[Pair], x: &[Vec3], radius: f64, boxes: bool) -> Vec<Closest> {
        let near = |pair: Pair| -> bool {
            let nodes = self.pair_nodes(pair);
            let split = if matches!(pair, Pair::PointFace(..)) { 1 } else { 2 };
            let bound = |ks: &[usize]| {
                let lo = ks.iter().fold(Vec3::splat(f64::INFINITY), |a, &k| a.min(x[k]));
                let hi = ks.iter().fold(Vec3::splat(f64::NEG_INFINITY), |a, &k| a.max(x[k]));
                (lo, hi)
            };
            let ((lo1, hi1), (lo2, hi2)) = (bound(&nodes[..split]), bound(&nodes[split..]));
            lo1.cmple(hi2 + Vec3::splat(radius)).all() && lo2.cmple(hi1 + Vec3::splat(radius)).all()
        };
        candidates
            .par_iter()
            .with_min_len(256)
            .filter(|&&pair| !boxes || near(pair))
            .map(|&pair| self.closest(pair, x))
            .filter(|c| c.distance() < radius)
            .collect()
    }

    /// Whether every node of `x` lies within `slack` (in each coordinate) of the box of its positions in `from`
    /// and `to`: then every pair within `radius` at `x` is among the candidates of `from → to` for the radius
    /// `radius + 2 slack` ([`Faces::candidates`]).
    pub fn within(x: &[Vec3], from: &[Vec3], to: &[Vec3], slack: f64) -> bool {
        let s = Vec3::splat(slack);
        x.iter().zip(from).zip(to).all(|((p, a), b)| p.cmpge(a.min(*b) - s).all() && p.cmple(a.max(*b) + s).all())
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
        let swept_near = |pair: Pair| -> bool {
            let nodes = self.pair_nodes(pair);
            let split = if matches!(pair, Pair::PointFace(..)) { 1 } else { 2 };
            let bound = |ks: &[usize]| {
                let lo = ks.iter().fold(Vec3::splat(f64::INFINITY), |a, &k| a.min(from[k]).min(to[k]));
                let hi = ks.iter().fold(Vec3::splat(f64::NEG_INFINITY), |a, &k| a.max(from[k]).max(to[k]));
                (lo, hi)
            };
            let ((lo1, hi1), (lo2, hi2)) = (bound(&nodes[..split]), bound(&nodes[split..]));
            lo1.cmple(hi2 + Vec3::splat(tolerance)).all() && lo2.cmple(hi1 + Vec3::splat(tolerance)).all()
        };
        let hits: Vec<(Pair, f64)> = candidates
            .par_iter()
            .with_min_len(256)
            .filter(|&&pair| swept_near(pair))
            .filter_map(|&pair| self.advance(pair, from, to, tolerance).map(|t| (pair, t)))
            .collect();
        hits.into_iter().min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
    }

    /// The first edge (an index of [`Faces::edges`]) that passes through a triangle it shares no node with at
    /// `x` (an index of [`Faces::triangles`]): a surface that intersects itself, which no step may start from.
    /// Only proper crossings count ([`segment_crosses`]): an edge touching a triangle or lying in its plane
    /// does not.
    pub fn crossing(&self, x: &[Vec3]) -> Option<(usize, usize)> {
        let bound = |nodes: &[usize]| {
            let lo = nodes.iter().fold(Vec3::splat(f64::INFINITY), |a, &k| a.min(x[k]));
            let hi = nodes.iter().fold(Vec3::splat(f64::NEG_INFINITY), |a, &k| a.max(x[k]));
            (lo, hi)
        };
        let edges: Vec<(Vec3, Vec3)> = self.edges.iter().map(|e| bound(e)).collect();
        let tris: Vec<(Vec3, Vec3)> = self.triangles.iter().map(|t| bound(t)).collect();
        let size = tris.iter().map(|(lo, hi)| (*hi - *lo).max_element()).fold(f64::MIN_POSITIVE, f64::max);
        overlaps(&edges, &tris, size, false).into_iter().find(|&(e, t)| {
            let ([a, b], tri) = (self.edges[e], self.triangles[t]);
            let r = |k: usize| self.representative(k);
            if tri.iter().any(|&k| r(k) == r(a) || r(k) == r(b)) {
                return false;
            }
            segment_crosses(x[a], x[b], tri.map(|k| x[k]))
        })
    }

    /// Most conservative-advancement steps for one pair.
    pub const ADVANCE_STEPS: usize = 64;

    /// Conservative advancement of one pair from `from` to `to`: the time in `[0, 1]` where its distance first
    /// falls to `tolerance`, or `None`.
    fn advance(&self, pair: Pair, from: &[Vec3], to: &[Vec3], tolerance: f64) -> Option<f64> {
        let nodes = self.pair_nodes(pair);
        let motion: Vec<Vec3> = nodes.iter().map(|&k| to[k] - from[k]).collect();
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

/// `Σ wₖ x_{nodes[k]}`.
fn combine(nodes: &[usize; 4], weights: &[f64; 4], x: &[Vec3]) -> Vec3 {
    nodes.iter().zip(weights).fold(Vec3::ZERO, |acc, (&k, &w)| acc + x[k] * w)
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

/// The integer cells of a uniform grid of cells of `size` that the box `lo..hi` overlaps.
fn cells_of((lo, hi): &(Vec3, Vec3), size: f64) -> impl Iterator<Item = [i64; 3]> {
    let cell = |p: f64| (p / size).floor() as i64;
    let (l, h) = ([cell(lo.x), cell(lo.y), cell(lo.z)], [cell(hi.x), cell(hi.y), cell(hi.z)]);
    (l[0]..=h[0]).flat_map(move |i| (l[1]..=h[1]).flat_map(move |j| (l[2]..=h[2]).map(move |k| [i, j, k])))
}

/// The (cell key, element) entries of boxes on a uniform grid of cells of `size`, sorted.
fn bins(boxes: &[(Vec3, Vec3)], size: f64) -> Vec<([i64; 3], u32)> {
    let mut out: Vec<([i64; 3], u32)> =
        boxes.iter().enumerate().flat_map(|(e, b)| cells_of(b, size).map(move |key| (key, e as u32))).collect();
    out.sort_unstable();
    out
}

/// The pairs `(a, b)` of boxes of `first` and `second` that overlap (with `same`, the two lists are one and
/// only `a < b` is kept), each once.
fn overlaps(first: &[(Vec3, Vec3)], second: &[(Vec3, Vec3)], size: f64, same: bool) -> Vec<(usize, usize)> {
    let table = bins(second, size);
    let overlap = |a: &(Vec3, Vec3), b: &(Vec3, Vec3)| a.0.cmple(b.1).all() && b.0.cmple(a.1).all();
    let mut pairs: Vec<(usize, usize)> = first
        .par_iter()
        .enumerate()
        .with_min_len(256)
        .flat_map_iter(|(a, boxa)| {
            let mut found = Vec::new();
            for key in cells_of(boxa, size) {
                let start = table.partition_point(|e| e.0 < key);
                for &(k, b) in &table[start..] {
                    if k != key {
                        break;
                    }
                    let b = b as usize;
                    if (!same || a < b) && overlap(boxa, &second[b]) {
                        found.push((a, b));
                    }
                }
            }
            found
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> (Faces, Vec<Vec3>) {
        // 3 × 3 nodes, 2 × 2 cells, spacing 1.
        let idx = |i: usize, j: usize| i + 3 * j;
        let cells =
            (0..2).flat_map(|j| (0..2).map(move |i| [idx(i, j), idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1)]));
        let x = (0..9).map(|k| Vec3::new((k % 3) as f64, (k / 3) as f64, 0.0)).collect();
        (Faces::new(9, cells), x)
    }

    #[test]
    fn a_flat_sheet_has_no_close_pairs_below_its_half_diagonal() {
        let (faces, x) = square();
        assert_eq!(faces.triangles.len(), 8);
        assert_eq!(faces.edges.len(), 16);
        assert!(faces.close(&x, 0.7).is_empty());
        let close = faces.close(&x, 1.5);
        assert!(!close.is_empty());
        assert!(close.iter().all(|c| c.distance() >= std::f64::consts::FRAC_1_SQRT_2 - 1e-12));
    }

    /// A step's candidates (swept from the start to a target, the radius grown by twice a slack) find the same
    /// close pairs and the same first touch as the whole broad phase, for any configuration within the slack.
    #[test]
    fn a_steps_candidates_find_what_the_broad_phase_finds() {
        let (faces, flat) = square();
        // Folded: the corner node 8 over the first cell, then moving through it.
        let mut start = flat.clone();
        start[8] = Vec3::new(0.4, 0.3, 0.3);
        let mut target = start.clone();
        target[8] = Vec3::new(0.5, 0.2, -0.2);
        let (radius, slack) = (0.2, 0.2);
        let candidates = faces.candidates(&start, Some(&target), radius + 2.0 * slack);
        for (k, z) in [0.25, 0.1, 0.0, -0.15, -0.35].iter().enumerate() {
            let mut x = target.clone();
            x[8] = Vec3::new(0.45, 0.25 + 0.01 * k as f64, *z);
            assert!(Faces::within(&x, &start, &target, slack));
            let pairs = |c: Vec<Closest>| c.into_iter().map(|c| c.pair).collect::<Vec<_>>();
            assert_eq!(
                pairs(faces.close_among(&candidates, &x, radius, true)),
                pairs(faces.close(&x, radius)),
                "z = {z}"
            );
            assert_eq!(
                faces.first_touch_among(&candidates, &start, &x, 1e-4),
                faces.first_touch(&start, &x, 1e-4),
                "z = {z}"
            );
        }
        let mut far = target.clone();
        far[8].z -= 0.5;
        assert!(!Faces::within(&far, &start, &target, slack));
    }

    #[test]
    fn a_node_above_a_face_is_close_and_crossing_is_caught() {
        let (faces, mut x) = square();
        // Fold node 8 (corner (2, 2)) over the first cell, 0.1 above it.
        x[8] = Vec3::new(0.4, 0.3, 0.1);
        let close = faces.close(&x, 0.2);
        assert!(close.iter().any(|c| c.pair == Pair::PointFace(8, 0) || c.pair == Pair::PointFace(8, 1)), "{close:?}");
        let c = close.iter().find(|c| matches!(c.pair, Pair::PointFace(8, _))).unwrap();
        assert!((c.distance() - 0.1).abs() < 1e-12);
        let mut to = x.clone();
        to[8] = Vec3::new(0.4, 0.3, -0.5);
        let (_, t) = faces.first_touch(&x, &to, 1e-4).expect("the node passes through the face");
        // The node reaches 1e-4 above the face at t = (0.1 − 1e-4) / 0.6 (its edges may meet others earlier).
        assert!(t < 0.1 / 0.6, "t = {t}");
        let node = faces.advance(Pair::PointFace(8, 0), &x, &to, 1e-4).expect("the node meets the face");
        // Conservative advancement stops at or inside the tolerance, never past the face.
        assert!(((0.1 - 1e-4) / 0.6 - 1e-12..0.1 / 0.6).contains(&node), "t = {node}");
        to[8] = Vec3::new(0.4, 0.3, 0.05);
        assert!(faces.first_touch(&x, &to, 1e-4).is_none());
    }
}
