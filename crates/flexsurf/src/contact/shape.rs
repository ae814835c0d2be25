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

    /// The same obstacle with every length scaled by `lambda`, or `None` (the default) when it cannot be scaled.
    fn scaled(&self, _lambda: f64) -> Option<Obstacle> {
        None
    }

    /// How to draw the shape; `None` (the default) leaves it out of pictures.
    fn look(&self) -> Option<Look> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;
    use crate::integrate::{StepParams, Stepper};
    use crate::material::{Calibration, Fabric, Stiffness};
    use crate::model::{ModelBuilder, ModelKind};
    use crate::potential::contact::ContactParams;
    use crate::state::State;
    use std::sync::Arc;

    /// An axis-aligned box, written here as a user of the library would.
    #[derive(Debug)]
    struct Cuboid {
        min: Vec3,
        max: Vec3,
    }

    impl Shape for Cuboid {
        fn distance_within(&self, p: Vec3, _hint: &mut Option<Hint>, _radius: f64) -> Option<(f64, Vec3)> {
            let c = (self.min + self.max) * 0.5;
            let q = (p - c).abs() - (self.max - self.min) * 0.5;
            let outside = q.max(Vec3::ZERO);
            if outside.length() > 0.0 {
                let n = outside * (p - c).signum();
                return Some((outside.length(), n / n.length()));
            }
            // Inside: the nearest face.
            let a = (0..3).max_by(|&i, &j| q[i].total_cmp(&q[j])).unwrap_or(2);
            let mut n = Vec3::ZERO;
            n[a] = (p - c)[a].signum();
            Some((q[a], n))
        }
    }

    #[test]
    fn a_custom_shape_pushes_the_cloth_out() {
        let fabric = Fabric::paper_cotton();
        let s = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
        let g = Grid::sheet(5, 5, 0.4, 0.4).unwrap();
        let rest = g.flat_positions(0.0);
        let mut b = ModelBuilder::new(g, rest.clone(), fabric, s, ModelKind::Tfs, Vec3::ZERO);
        let cuboid = Cuboid { min: Vec3::new(-0.1, -0.1, -0.5), max: Vec3::new(0.1, 0.1, 0.001) };
        b.obstacles.push(Obstacle::Custom(Arc::new(cuboid)));
        b.contact = ContactParams { stiffness: 1e4, offset: 0.005, friction: 0.0, ..ContactParams::default() };
        let model = b.build().unwrap();
        let centre = (0..rest.len()).min_by(|&i, &j| rest[i].length().total_cmp(&rest[j].length())).unwrap();
        let before = model.obstacles()[0].distance(rest[centre]).0;
        assert!(before < 0.0, "the centre node starts inside the box");
        let mut state = State::at_rest(rest);
        let mut stepper = Stepper::new(&model, &StepParams::with_dt(0.01)).unwrap();
        let info = stepper.step(&model, &mut state).unwrap();
        assert!(info.contacts > 0);
        let after = model.obstacles()[0].distance(state.x[centre]).0;
        assert!(after > before && state.x[centre].z > 0.0, "pushed out: {before} -> {after}");
        assert!(model.obstacles()[0].scaled(2.0).is_none() && model.obstacles()[0].look().is_none());
    }
}
