//! The solid ball obstacle: signed distance to a sphere, normal along the ray from the centre. One of the
//! built-in [`Shape`]s behind [`Obstacle::Sphere`].

use super::nurbs::Hint;
use super::shape::{Look, Shape};
use super::Obstacle;
use crate::math::Vec3;

/// Solid ball.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f64,
}

impl Shape for Sphere {
    /// The normal at the centre itself is `+z`.
    #[inline]
    fn distance_within(&self, p: Vec3, _hint: &mut Option<Hint>, _radius: f64) -> Option<(f64, Vec3)> {
        let d = p - self.center;
        let len = d.length();
        let n = if len > 0.0 { d / len } else { Vec3::Z };
        Some((len - self.radius, n))
    }

    fn scaled(&self, lambda: f64) -> Option<Obstacle> {
        Some(Obstacle::Sphere { center: self.center * lambda, radius: self.radius * lambda })
    }

    fn look(&self) -> Option<Look> {
        Some(Look::Sphere { center: self.center, radius: self.radius })
    }
}

impl From<Sphere> for Obstacle {
    fn from(s: Sphere) -> Self {
        Obstacle::Sphere { center: s.center, radius: s.radius }
    }
}
