//! The obstacle extension point: a [`Shape`] answers the signed distance and outward normal of a point within a
//! search radius (warm-started through a NURBS [`Hint`] slot it may ignore), may scale its lengths, and says how
//! it looks ([`Look`]) so that pictures can draw it without this module knowing the renderer. The built-in
//! shapes are [`super::plane::Plane`], [`super::sphere::Sphere`], [`super::nurbs::NurbsBody`] and
//! [`super::trimesh::TriMeshBody`]; a new kind of obstacle is one file implementing [`Shape`], used as
//! [`Obstacle::Custom`]`(Arc::new(MyShape { .. }))`.

use super::nurbs::Hint;
use super::Obstacle;
use crate::math::Vec3;
use crate::surface::mesh::TriMesh;

/// How an obstacle is drawn in pictures (see `runner::outputs::obstacle_drawables`).
#[derive(Debug, Clone, PartialEq)]
pub enum Look {
    /// A ball.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f64,
    },
    /// An unbounded ground plane.
    Plane {
        /// A point on the plane.
        point: Vec3,
        /// Outward unit normal.
        normal: Vec3,
    },
    /// A closed surface given as a triangle mesh with normals.
    Mesh(TriMesh),
}

/// A rigid obstacle's geometry.
pub trait Shape: Send + Sync + std::fmt::Debug {
    /// Signed distance of `p` (positive outside) and the outward unit normal at the closest surface point, or
    /// `None` when the surface is certainly farther than `radius` from `p` (`radius` may be infinite). A shape
    /// may answer `Some` beyond `radius`. `hint` is this (obstacle, node) pair's warm-start slot: shapes with an
    /// iterative query read and update it, others ignore it.
    fn distance_within(&self, p: Vec3, hint: &mut Option<Hint>, radius: f64) -> Option<(f64, Vec3)>;

    /// [`Shape::distance_within`] for a point whose signed distance is known to be at least `floor` (a bound
    /// from an earlier query: the distance is 1-Lipschitz), which a shape may use to skip work; the answer is
    /// the same. The default ignores it.
    fn distance_within_above(&self, p: Vec3, hint: &mut Option<Hint>, radius: f64, floor: f64) -> Option<(f64, Vec3)> {
        let _ = floor;
        self.distance_within(p, hint, radius)
    }

    /// The same obstacle with every length scaled by `lambda`, or `None` (the default) when it cannot be scaled.
    fn scaled(&self, _lambda: f64) -> Option<Obstacle> {
        None
    }

    /// How to draw the shape; `None` (the default) leaves it out of pictures.
    fn look(&self) -> Option<Look> {
        None
    }
}
