//! Contact of the sheet's faces with a rigid triangle-mesh body's own vertices and edges (issue 19): the exact
//! complement of the nodes' obstacle contact ([`super::contact`]), so that a feature of a body narrower than
//! the grid (a blade, a corner, a thin rod modelled as a mesh) cannot pass through a face between nodes.
//!
//! The nodes' contact measures each sheet node against the body's triangles; this term measures each body
//! vertex against the sheet's triangles and each body edge against the sheet's edges, which together with it
//! are every vertex–face and edge–edge pair of the two triangulated surfaces. It is the self-contact machinery
//! ([`SelfContact::against_body`]) with the body's vertices as fixed nodes after the sheet's: the same
//! penalty `½ c a (δ − gap)²` on a gap linear in the sheet's positions (the pair's direction from the step's
//! start, the body's share a constant), the same active set, the same conservative advancement of every pair
//! along the step (a pair that would come within `10⁻³ δ` of touching fails the step, which is halved), and the
//! cloth–obstacle Coulomb friction on the sheet's side of each pair. Its thickness `δ` is half the contact
//! offset, so that where the nodes rest on the body (inside their offset) the faces between them only add a
//! force where the body comes nearer to a face than half the layer: between nodes, not under them.

use super::self_contact::{SelfContact, SelfContactParams};
use super::{ActiveSet, Context, Part, Scratch, Stage, Term, TermInfo};
use crate::contact::proximity::Faces;
use crate::contact::trimesh::TriMeshBody;
use crate::energy::Sink;
use crate::math::Vec3;

/// Contact of the sheet's faces with one mesh body's vertices and edges.
#[derive(Debug, Clone)]
pub struct BodyContact {
    pairs: SelfContact,
}

impl BodyContact {
    /// The contact of the sheet's `faces` (nodes of rest area `area`) with `body`, of penalty `stiffness`
    /// (N/m³), thickness `thickness` (m), Coulomb `friction` and slip speed `slip_speed` (m/s).
    pub fn new(faces: &Faces, body: &TriMeshBody, params: SelfContactParams, area: Vec<f64>) -> Self {
        let mesh = body.to_mesh();
        let triangles: Vec<[usize; 3]> = mesh.triangles.iter().map(|t| t.map(|k| k as usize)).collect();
        Self { pairs: SelfContact::against_body(faces, mesh.positions, &triangles, params, area) }
    }

    /// The parameters.
    pub fn params(&self) -> &SelfContactParams {
        self.pairs.params()
    }

    /// The body's vertices, numbered after the sheet's nodes in [`BodyContact::faces`].
    pub fn vertices(&self) -> &[Vec3] {
        self.pairs.body_vertices()
    }

    /// The sheet's faces and the body's, the body's vertices numbered after the sheet's nodes.
    pub fn faces(&self) -> &Faces {
        self.pairs.faces()
    }
}

impl Term for BodyContact {
    fn info(&self) -> TermInfo {
        TermInfo::new("body features", Stage::Contact, Part::Contact)
    }

    fn evaluate(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        self.pairs.evaluate(y, cx, scratch, sink)
    }

    fn active_set(&self) -> Option<&dyn ActiveSet> {
        Some(self)
    }

    fn save(&self, scratch: &Scratch) -> Result<Option<Vec<u8>>, String> {
        self.pairs.save(scratch)
    }

    fn restore(&self, saved: Option<&[u8]>, scratch: &mut Scratch) -> Result<(), String> {
        self.pairs.restore(saved, scratch)
    }
}

impl ActiveSet for BodyContact {
    fn prepare(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch) {
        self.pairs.prepare(y, cx, scratch);
    }

    fn model_error(&self, y: &[Vec3], cx: &Context, scratch: &mut Scratch) -> super::friction::Misfit {
        self.pairs.model_error(y, cx, scratch)
    }

    fn refine(&self, y: &[Vec3], delta: &[Vec3], cx: &Context, scratch: &mut Scratch) -> bool {
        self.pairs.refine(y, delta, cx, scratch)
    }

    fn tunnelled(&self, from: &[Vec3], to: &[Vec3], scratch: &mut Scratch) -> Option<usize> {
        self.pairs.tunnelled(from, to, scratch)
    }

    fn active(&self, scratch: &Scratch) -> usize {
        self.pairs.active(scratch)
    }

    fn engaged(&self, scratch: &Scratch) -> bool {
        self.pairs.engaged(scratch)
    }

    fn can_hold(&self, x: &[Vec3], scratch: &Scratch) -> bool {
        self.pairs.can_hold(x, scratch)
    }

    fn convergent(&self) -> bool {
        self.pairs.convergent()
    }

    fn slip_speed(&self) -> f64 {
        self.pairs.slip_speed()
    }

    fn coulomb(&self, x: &[Vec3]) -> Vec<(usize, Vec3, f64)> {
        self.pairs.coulomb(x)
    }

    fn violation(&self, x: &[Vec3], cx: &Context, scratch: &mut Scratch) -> f64 {
        self.pairs.violation(x, cx, scratch)
    }
}
