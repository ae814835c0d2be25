//! The half-space obstacle: everything below a plane, with signed distance along its outward normal. One of
//! the built-in [`Shape`]s behind [`Obstacle::Plane`].

use super::nurbs::Hint;
use super::shape::{Look, Shape};
use super::Obstacle;
use crate::math::Vec3;

/// Half-space below the plane through `point` with outward `normal`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// A point on the plane.
    pub point: Vec3,
    /// Outward unit normal.
    pub normal: Vec3,
}

impl Shape for Plane {
    #[inline]
    fn distance_within(&self, p: Vec3, _hint: &mut Option<Hint>, _radius: f64) -> Option<(f64, Vec3)> {
        Some(((p - self.point).dot(self.normal), self.normal))
    }

    fn scaled(&self, lambda: f64) -> Option<Obstacle> {
        Some(Obstacle::Plane { point: self.point * lambda, normal: self.normal })
    }

    fn look(&self) -> Option<Look> {
        Some(Look::Plane { point: self.point, normal: self.normal })
    }
}

impl From<Plane> for Obstacle {
    fn from(p: Plane) -> Self {
        Obstacle::Plane { point: p.point, normal: p.normal }
    }
}
