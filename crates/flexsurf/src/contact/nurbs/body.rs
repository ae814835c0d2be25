//! A rigid body of NURBS patches grouped into closed parts: its bounding boxes, signed distance (positive
//! outside the union of the parts), closest point over all patches with a warm start and a search radius,
//! transforms and tessellation. Patch-level projection is in [`super::project`], file I/O in [`super::format`].

use super::error::NurbsError;
use super::patch::NurbsPatch;
use super::project::{box_distance2, in_cell, Hint, Projection};
use crate::contact::shape::{Look, Shape};
use crate::math::Vec3;
use crate::surface::mesh::{Aabb, TriMesh};

/// A named group of patches forming one closed (or closed enough) surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Name (e.g. `"torso"`).
    pub name: String,
    /// Indices of its patches in the body.
    pub patches: Vec<usize>,
    /// Union of its patches' bounding boxes.
    pub bbox: Aabb,
}

/// A rigid body bounded by NURBS patches, grouped into parts (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct NurbsBody {
    pub(super) name: String,
    pub(super) patches: Vec<NurbsPatch>,
    pub(super) part_of: Vec<usize>,
    pub(super) parts: Vec<Part>,
    pub(super) bbox: Aabb,
}

impl NurbsBody {
    /// A body from `(part name, patch)` pairs; patches keep their order (patch indices in [`Hint`] and
    /// [`Projection`] refer to it) and parts are numbered in order of first appearance.
    pub fn new(name: impl Into<String>, patches: Vec<(String, NurbsPatch)>) -> Result<Self, NurbsError> {
        if patches.is_empty() {
            return Err(NurbsError::Empty);
        }
        Ok(Self::from_nonempty(name, patches))
    }

    /// `Err(NurbsError::Open)` naming the first side of a patch where the body does not close up (it does not
    /// bound a solid, as an obstacle must): a side that no other patch continues, that does not fold back onto
    /// itself, is not collapsed to a point and is not inside another part (`closed.rs`). Open surfaces are
    /// valid bodies for queries; scenes refuse them as obstacles.
    pub fn check_closed(&self) -> Result<(), NurbsError> {
        match super::closed::open_side(self) {
            Some((patch, side)) => Err(NurbsError::Open { patch, side: super::closed::SIDES[side] }),
            None => Ok(()),
        }
    }

    /// [`NurbsBody::new`] for a list known to be non-empty.
    pub(crate) fn from_nonempty(name: impl Into<String>, patches: Vec<(String, NurbsPatch)>) -> Self {
        let mut parts: Vec<Part> = Vec::new();
        let mut part_of = Vec::with_capacity(patches.len());
        let mut list = Vec::with_capacity(patches.len());
        for (k, (part, patch)) in patches.into_iter().enumerate() {
            let idx = match parts.iter().position(|p| p.name == part) {
                Some(i) => i,
                None => {
                    parts.push(Part { name: part, patches: Vec::new(), bbox: patch.bbox });
                    parts.len() - 1
                }
            };
            parts[idx].patches.push(k);
            parts[idx].bbox = parts[idx].bbox.union(patch.bbox);
            part_of.push(idx);
            list.push(patch);
        }
        let bbox = parts.iter().map(|p| p.bbox).reduce(Aabb::union).unwrap_or(Aabb::point(Vec3::ZERO));
        Self { name: name.into(), patches: list, part_of, parts, bbox }
    }

    /// The body mapped by `x ↦ scale · x + offset` (orientation is kept, so `scale` must be positive; units
    /// stay metres: use it to place a body in a scene or to rescale a figure).
    pub fn transformed(&self, scale: f64, offset: Vec3) -> Result<Self, NurbsError> {
        if !(scale.is_finite() && scale > 0.0 && offset.is_finite()) {
            return Err(NurbsError::Transform { scale });
        }
        let mut patches = Vec::with_capacity(self.patches.len());
        for (k, p) in self.patches.iter().enumerate() {
            let points = p.points.iter().map(|&x| scale * x + offset).collect();
            let weights = p.rational.then(|| p.weights.clone());
            let q = NurbsPatch::new(p.degree(), p.ku.knots.clone(), p.kv.knots.clone(), points, weights)
                .map_err(|e| NurbsError::Patch { index: k, cause: Box::new(e) })?;
            patches.push((self.parts[self.part_of[k]].name.clone(), q));
        }
        Self::new(self.name.clone(), patches)
    }

    /// The body's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The patches.
    pub fn patches(&self) -> &[NurbsPatch] {
        &self.patches
    }

    /// The parts.
    pub fn parts(&self) -> &[Part] {
        &self.parts
    }

    /// Index of the part that patch `patch` belongs to (`None` when out of range).
    pub fn part_of(&self, patch: usize) -> Option<usize> {
        self.part_of.get(patch).copied()
    }

    /// Bounding box of all control nets.
    pub fn bbox(&self) -> Aabb {
        self.bbox
    }

    /// Signed distance of `p` (positive outside) and the outward normal at the closest point.
    pub fn distance(&self, p: Vec3) -> (f64, Vec3) {
        let c = self.closest(p, None);
        (c.distance, c.normal)
    }

    /// Closest point, outward normal and signed distance of `p` for the union of the parts (see the module
    /// documentation), warm-started from `hint` (the previous answer's [`Projection::hint`]). Hints with an
    /// unknown patch or non-finite parameters are ignored. For a non-finite `p` the distance is NaN.
    pub fn closest(&self, p: Vec3, hint: Option<Hint>) -> Projection {
        match self.closest_within(p, hint, f64::INFINITY) {
            Some(c) => c,
            None => {
                let ([u, _], [v, _]) = self.patches[0].domain();
                Projection { point: self.patches[0].point(u, v), normal: Vec3::Z, distance: f64::NAN, patch: 0, u, v }
            }
        }
    }

    /// Like [`NurbsBody::closest`] but only looks at patches whose control-net bounding box is within `radius`
    /// of `p`: `None` when no surface point is that close (a contact query with `radius` a little above the
    /// contact offset skips far patches at the cost of one box test each).
    pub fn closest_within(&self, p: Vec3, hint: Option<Hint>, radius: f64) -> Option<Projection> {
        if !p.is_finite() {
            return None;
        }
        let hint = hint.filter(|h| h.patch < self.patches.len() && h.u.is_finite() && h.v.is_finite());
        let first = hint.map(|h| self.part_of[h.patch]);
        let r2 = radius * radius;
        let mut best: Option<Projection> = None;
        let order = first.into_iter().chain((0..self.parts.len()).filter(|&i| Some(i) != first));
        for part in order {
            let bd2 = box_distance2(&self.parts[part].bbox, p);
            if bd2 > r2 {
                continue;
            }
            if let Some(b) = &best {
                // Outside the part's box the part's signed distance is at least the box distance.
                if bd2 > 0.0 && bd2.sqrt() >= b.distance {
                    continue;
                }
            }
            let h = hint.filter(|h| self.part_of[h.patch] == part);
            if let Some(c) = self.closest_in_part_within(part, p, h, radius) {
                if best.is_none_or(|b| c.distance < b.distance) {
                    best = Some(c);
                }
            }
        }
        best
    }

    /// Closest point of part `part` alone (its signed distance), warm-started from `hint` when it names one
    /// of the part's patches. `None` for an unknown part or a non-finite `p`.
    pub fn closest_in_part(&self, part: usize, p: Vec3, hint: Option<Hint>) -> Option<Projection> {
        if part >= self.parts.len() || !p.is_finite() {
            return None;
        }
        let hint = hint.filter(|h| self.part_of.get(h.patch) == Some(&part) && h.u.is_finite() && h.v.is_finite());
        self.closest_in_part_within(part, p, hint, f64::INFINITY)
    }

    fn closest_in_part_within(&self, part: usize, p: Vec3, hint: Option<Hint>, radius: f64) -> Option<Projection> {
        let mut best_d2 = if radius.is_finite() { radius * radius } else { f64::INFINITY };
        let mut best: Option<(usize, f64, f64, Vec3)> = None;
        let mut consider = |k: usize, (u, v, q, d2): (f64, f64, Vec3, f64), best_d2: &mut f64| {
            if d2 < *best_d2 || best.is_none() && d2 <= *best_d2 {
                *best_d2 = d2;
                best = Some((k, u, v, q));
            }
        };
        let patches = &self.parts[part].patches;
        // The cell Newton already explored from the hint, or else the cell nearest to p, goes first.
        let mut done = None;
        if let Some(h) = hint {
            let r = self.patches[h.patch].project_from(p, h.u, h.v);
            consider(h.patch, r, &mut best_d2);
            done = self.patches[h.patch].cells.iter().position(|c| in_cell(c, r.0, r.1)).map(|c| (h.patch, c));
        } else {
            let mut first: Option<(f64, usize, usize)> = None;
            for &k in patches {
                for (ci, cell) in self.patches[k].cells.iter().enumerate() {
                    let d2 = box_distance2(&cell.bbox, p);
                    if d2 <= best_d2 && first.is_none_or(|f| d2 < f.0) {
                        first = Some((d2, k, ci));
                    }
                }
            }
            if let Some((_, k, ci)) = first {
                let (u, v, _) = NurbsPatch::nearest_sample(&self.patches[k].cells[ci], p);
                consider(k, self.patches[k].project_from(p, u, v), &mut best_d2);
                done = Some((k, ci));
            }
        }
        for &k in patches {
            let patch = &self.patches[k];
            if box_distance2(&patch.bbox, p) > best_d2 {
                continue;
            }
            for (ci, cell) in patch.cells.iter().enumerate() {
                if box_distance2(&cell.bbox, p) > best_d2 {
                    continue;
                }
                let explored = done == Some((k, ci));
                let start = best_d2;
                let mut found = |r: (f64, f64, Vec3, f64)| {
                    consider(k, r, &mut best_d2);
                    best_d2
                };
                patch.search_cell(cell, p, start, explored, &mut found);
            }
        }
        let (k, u, v, q) = best?;
        let normal = self.patches[k].normal(u, v);
        let dist = best_d2.sqrt();
        let side = (p - q).dot(normal);
        let distance = if side < 0.0 { -dist } else { dist };
        Some(Projection { point: q, normal, distance, patch: k, u, v })
    }

    /// A triangle mesh of the body: each patch sampled on an `(n + 1) × (n + 1)` parameter grid (`n ≥ 1`),
    /// with outward normals and triangles counter-clockwise seen from outside.
    pub fn tessellate(&self, n: usize) -> TriMesh {
        let n = n.max(1);
        let mut mesh = TriMesh::new();
        for patch in &self.patches {
            let base = mesh.positions.len() as u32;
            let ([u0, u1], [v0, v1]) = patch.domain();
            for i in 0..=n {
                let u = u0 + (u1 - u0) * i as f64 / n as f64;
                for j in 0..=n {
                    let v = v0 + (v1 - v0) * j as f64 / n as f64;
                    mesh.positions.push(patch.point(u, v));
                    mesh.normals.push(patch.normal(u, v));
                }
            }
            let id = |i: usize, j: usize| base + (i * (n + 1) + j) as u32;
            for i in 0..n {
                for j in 0..n {
                    mesh.triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                    mesh.triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
                }
            }
        }
        mesh
    }
}

/// The body as an obstacle: the bounded closest-point query, warm-started from and updating the hint.
impl Shape for NurbsBody {
    fn distance_within(&self, p: Vec3, hint: &mut Option<Hint>, radius: f64) -> Option<(f64, Vec3)> {
        self.distance_within_above(p, hint, radius, f64::NEG_INFINITY)
    }

    fn distance_within_above(&self, p: Vec3, hint: &mut Option<Hint>, radius: f64, floor: f64) -> Option<(f64, Vec3)> {
        let pr = match self.closest_within(p, *hint, radius) {
            Some(pr) => pr,
            None => {
                // Nothing within `radius`: either far outside, or deeper than `radius` inside the body,
                // which a bounded query cannot tell apart. Inside the body's box, ask without a bound, unless
                // `floor` rules out the inside (on the skirt of `scenes/skirt.toml` that unbounded query was a
                // third of the contact's time).
                let b = self.bbox();
                let inside_box = (0..3).all(|a| p[a] >= b.min[a] && p[a] <= b.max[a]);
                if !inside_box || floor > -radius {
                    return None;
                }
                let pr = self.closest(p, *hint);
                if pr.distance >= radius || pr.distance.is_nan() {
                    return None;
                }
                pr
            }
        };
        *hint = Some(pr.hint());
        Some((pr.distance, pr.normal))
    }

    /// Drawn as its tessellation with 12 × 12 cells a patch.
    fn look(&self) -> Option<Look> {
        Some(Look::Mesh(self.tessellate(12)))
    }
}
