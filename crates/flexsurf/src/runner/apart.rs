//! The displayed surface kept apart (issue 19). Self-contact guarantees the grid's triangles (each cell split
//! along its `(i, j)–(i+1, j+1)` diagonal) never pass through each other; the surface the outputs show is the
//! Coons surface through the same nodes ([`crate::surface::CoonsSurface`]), which bulges off those triangles
//! by up to about a cell's curvature times its size squared over eight. In a sharp fold, where two layers lie
//! a thickness apart, the bulges of the two layers can cross although their triangles do not.
//!
//! Every display vertex is therefore written as its point on the grid's triangle (the flat refinement: the
//! same parameters `(t1, t2)` in the cell, on the triangle of the cell they fall in) plus a share `s` of its
//! Coons bulge, `s` the bilinear blend of per-node shares over the vertex's cell, so the shown surface stays
//! continuous across cells. All shares start at 1 (the Coons surface itself). While two display elements
//! that share no vertex (a vertex and a triangle, two edges) are closer than a tolerance, or a display edge
//! passes through a display triangle, the shares of every node of the cells of both elements are halved, and
//! set to 0 below 1/16 (at once after eight passes; after sixteen every share is 0). With every share at 0
//! the display mesh is the flat refinement of the grid's triangles: each display triangle lies in one grid
//! triangle (its sub-quads are split along the same diagonal), so where the grid's triangles are apart the
//! display's are too, and the loop ends there at the latest. Where the guaranteed surface itself touches (two
//! grid triangles that share a node, which self-contact does not hold apart, folded onto each other), the
//! shares reach 0 and that is what is shown.
//!
//! The tolerance, a millionth of the display's finest parameter spacing (`min(h1, h2) / k`), covers the
//! rounding of the floating-point crossing test: a crossing it misses passes within rounding of an element's
//! edge or vertex, so a vertex–triangle or edge–edge distance falls under the tolerance. The search is the
//! self-contact's own proximity ([`Faces::close`], [`Faces::crossings`]); the test suite checks the result
//! with an exact intersection test written apart from it.

use super::fields::{coons_mesh, display_counts, display_stencils, seam_vertex_pairs};
use crate::contact::proximity::{Broad, Faces, Tree};
use crate::math::Vec3;
use crate::model::Model;
use crate::potential::self_contact::SelfContact;
use crate::surface::TriMesh;

/// The least share a halving leaves; a share at or below it goes to 0 next (1 → 1/2 → … → 1/16 → 0).
const LEAST: f64 = 1.0 / 16.0;

/// Passes after which the nodes of elements still meeting lose their whole bulge at once; after twice as
/// many every node does (the flat refinement), so a search ends within `2 PATIENCE + 1` passes. A fold
/// usually settles in two.
const PATIENCE: usize = 8;

/// Each display vertex's model nodes and bilinear weights, its point on the grid's triangle and its bulge
/// (Coons point minus that point).
struct Bulges {
    corners: Vec<[usize; 4]>,
    weights: Vec<[f64; 4]>,
    flat: Vec<Vec3>,
    bulge: Vec<Vec3>,
}

impl Bulges {
    fn new(model: &Model, x: &[Vec3], k: usize, curved: &TriMesh) -> Self {
        let (mut corners, mut weights, mut flat) = (Vec::new(), Vec::new(), Vec::new());
        for (panel, stencil) in model.panels.iter().zip(display_stencils(&model.panels, k)) {
            for (cell, w) in stencil {
                let nodes = cell.map(|c| panel.global(c));
                let p = nodes.map(|n| x[n]);
                let (t1, t2) = (w[1] + w[3], w[2] + w[3]);
                flat.push(if t1 >= t2 {
                    p[0] + (p[1] - p[0]) * t1 + (p[3] - p[1]) * t2
                } else {
                    p[0] + (p[2] - p[0]) * t2 + (p[3] - p[2]) * t1
                });
                corners.push(nodes);
                weights.push(w);
            }
        }
        let bulge = curved.positions.iter().zip(&flat).map(|(&c, &f)| c - f).collect();
        Self { corners, weights, flat, bulge }
    }

    /// The display positions with the nodes' shares `share`.
    fn positions(&self, share: &[f64]) -> Vec<Vec3> {
        (0..self.flat.len())
            .map(|v| {
                let s: f64 = self.corners[v].iter().zip(&self.weights[v]).map(|(&n, &w)| w * share[n]).sum();
                self.flat[v] + self.bulge[v] * s
            })
            .collect()
    }
}

/// The display vertices of the pairs that are too close at `x` or cross, sorted and each once.
fn offending(faces: &Faces, (broad, crossing): (&mut Broad, &mut Tree), x: &[Vec3], tolerance: f64) -> Vec<usize> {
    let mut vertices: Vec<usize> = faces
        .close_in(broad, x, tolerance)
        .into_iter()
        .flat_map(|c| c.nodes)
        .chain(faces.crossings_in(crossing, x).into_iter().flat_map(|(e, t)| {
            let ([a, b], [c, d, f]) = (faces.edges[e], faces.triangles[t]);
            [a, b, c, d, f]
        }))
        .collect();
    vertices.sort_unstable();
    vertices.dedup();
    vertices
}

/// What keeping a display mesh apart did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Apart {
    /// Passes of the search (1: the Coons surface was apart as it was; 0: nothing to search, one subdivision).
    pub passes: usize,
    /// Model nodes whose share of the bulge was cut below 1.
    pub flattened: usize,
}

/// What the searches of [`keep_apart`] keep from one display mesh of a run to the next: the display's faces
/// (the same for every frame of a model and subdivision) and the trees of their proximity and crossing searches,
/// refit to each frame's boxes instead of built anew ([`Tree::update`]; the answers do not depend on the trees).
#[derive(Default)]
pub struct ApartCache {
    faces: Option<(usize, Faces)>,
    broad: Broad,
    crossing: Tree,
}

/// The display mesh of the node positions `x` with `k` subdivisions, the Coons surface of every panel
/// ([`coons_mesh`]), with the bulges cut where it would meet itself (module docs). Models without self-contact
/// promise nothing about their surface meeting itself and get the Coons surface as it is.
pub fn display_mesh(model: &Model, x: &[Vec3], k: usize) -> TriMesh {
    display_mesh_with(model, x, k, &mut ApartCache::default())
}

/// [`display_mesh`] with the searches' `cache` of the run's earlier frames (the same model and `k`).
pub fn display_mesh_with(model: &Model, x: &[Vec3], k: usize, cache: &mut ApartCache) -> TriMesh {
    let mut mesh = coons_mesh(&model.panels, x, k);
    if model.potential.find::<SelfContact>().is_some() {
        keep_apart_with(model, x, k, &mut mesh, cache);
    }
    mesh
}

/// Cuts the bulges of `mesh`, the Coons display mesh of `x` with `k` subdivisions ([`coons_mesh`]), until no
/// two of its elements that share no vertex meet (module docs); the normals of the vertices moved are the
/// moved mesh's face-averaged ones. A mesh or positions of another size than the model's (not its display
/// mesh) are left as they are.
pub fn keep_apart(model: &Model, x: &[Vec3], k: usize, mesh: &mut TriMesh) -> Apart {
    keep_apart_with(model, x, k, mesh, &mut ApartCache::default())
}

/// [`keep_apart`] with the searches' `cache` of the run's earlier frames.
fn keep_apart_with(model: &Model, x: &[Vec3], k: usize, mesh: &mut TriMesh, cache: &mut ApartCache) -> Apart {
    let k = k.max(1);
    let fits = x.len() == model.nodes()
        && mesh.positions.len()
            == model.panels.iter().map(|p| display_counts(&p.grid, k)).map(|(a, b)| a * b).sum::<usize>()
        && mesh.normals.len() == mesh.positions.len();
    if k == 1 || !fits {
        // One sub-quad a cell: every display vertex is a node, with no bulge to cut.
        return Apart::default();
    }
    let spacing = model.panels.iter().map(|p| p.grid.h1.min(p.grid.h2)).fold(f64::INFINITY, f64::min);
    let tolerance = 1e-6 * spacing / k as f64;
    let ApartCache { faces, broad, crossing } = cache;
    let faces = match faces {
        Some((ck, f)) if *ck == k && f.nodes() == mesh.positions.len() => f,
        slot => {
            // Another mesh: its faces anew, and trees built for them.
            let triangles: Vec<[usize; 3]> = mesh.triangles.iter().map(|t| t.map(|v| v as usize)).collect();
            let made = Faces::of_triangles(mesh.positions.len(), &triangles).with_joined(&seam_vertex_pairs(model, k));
            (*broad, *crossing) = (Broad::default(), Tree::default());
            &mut slot.insert((k, made)).1
        }
    };
    let bulges = Bulges::new(model, x, k, mesh);
    let mut share = vec![1.0_f64; x.len()];
    let mut report = Apart::default();
    let mut positions = mesh.positions.clone();
    loop {
        report.passes += 1;
        let mut nodes: Vec<usize> = offending(faces, (broad, crossing), &positions, tolerance)
            .into_iter()
            .flat_map(|v| bulges.corners[v])
            .filter(|&n| share[n] > 0.0)
            .collect();
        if nodes.is_empty() {
            break;
        }
        if report.passes > 2 * PATIENCE {
            // Still meeting after the nodes of every offending pair were cut at once for as many passes
            // again: show the grid's own triangles everywhere (the surface self-contact guarantees).
            share.fill(0.0);
            positions = bulges.positions(&share);
            break;
        }
        nodes.sort_unstable();
        nodes.dedup();
        // Halve (after a few passes that have not settled it, cut at once), down to 0 below the last halving.
        for n in nodes {
            share[n] = if share[n] > LEAST && report.passes <= PATIENCE { share[n] * 0.5 } else { 0.0 };
        }
        positions = bulges.positions(&share);
    }
    report.flattened = share.iter().filter(|&&s| s < 1.0).count();
    if report.flattened > 0 {
        mesh.positions = positions;
        let normals = mesh.face_averaged_normals();
        let moved = |v: usize| bulges.corners[v].iter().any(|&n| share[n] < 1.0);
        for (v, n) in normals.into_iter().enumerate().filter(|&(v, _)| moved(v)) {
            mesh.normals[v] = n;
        }
    }
    report
}
