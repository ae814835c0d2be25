//! Obstacle contact between the nodes (issue 19): points of the sheet's faces that obstacle contact also
//! checks, so that a feature of a body thinner than the grid (a leg under a coarse skirt, a rod, a ball smaller
//! than a cell) cannot pass through a face between nodes that are all outside it.
//!
//! The samples are the centroid of every triangle of the triangulated grid ([`Faces`]) and the midpoint of
//! every edge: points `Σ wₖ xₖ` of one face or edge, so that a contact of a sample is a record with that
//! [`Stencil`] whose force each node takes its weight's share of. A sample counts only where none of its nodes
//! is in contact itself: on a surface the nodes touch, the nodes carry the contact as before (and the result
//! does not change), and the samples act where the body comes between the nodes. A sample carries half the
//! mean rest area of its nodes. Sample contacts are frictionless; their paths are checked continuously as the
//! nodes' are. Mesh bodies are not sampled: their own vertices and edges meet the faces ([`super::body_contact`]).

use super::contact::Stencil;
use crate::contact::proximity::Faces;
use crate::math::Vec3;

/// The sample points of the sheet's faces and edges.
#[derive(Debug, Clone, PartialEq)]
pub struct FaceSamples {
    /// Each sample's nodes and weights.
    pub stencils: Vec<Stencil>,
    /// Each sample's area (m²).
    pub area: Vec<f64>,
}

impl FaceSamples {
    /// The triangles' centroids and the edges' midpoints of `faces`, for nodes of rest area `area`.
    pub fn new(faces: &Faces, area: &[f64]) -> Self {
        let third = 1.0 / 3.0;
        let stencils: Vec<Stencil> = faces
            .triangles
            .iter()
            .map(|t| Stencil::of(t, &[third; 3]))
            .chain(faces.edges.iter().map(|e| Stencil::of(e, &[0.5; 2])))
            .collect();
        let area =
            stencils.iter().map(|s| 0.5 * s.terms().map(|(k, _)| area[k]).sum::<f64>() / f64::from(s.len)).collect();
        Self { stencils, area }
    }

    /// How many samples.
    pub fn len(&self) -> usize {
        self.stencils.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.stencils.is_empty()
    }

    /// The samples' positions for node positions `x`.
    pub fn positions(&self, x: &[Vec3]) -> Vec<Vec3> {
        self.stencils.iter().map(|s| s.point(x)).collect()
    }

    /// Whether sample `i` counts: none of its nodes is in contact (`node_contact`).
    pub fn counts(&self, i: usize, node_contact: &[bool]) -> bool {
        self.stencils[i].terms().all(|(k, _)| !node_contact[k])
    }
}
