//! The flared circle skirt (the paper's demo 2): a periodic grid, `u1` around the waist and `u2` down, whose
//! pattern is a cone of the waist girth at the top, the hem girth at the bottom and the given length along every
//! generatrix. The cone is the rest shape used as a flat pattern (its metric, zero rest curvature); the initial
//! shape is the cone with its waist row fitted onto the body ([`super::fit`]) and straight generatrices from the
//! fitted waist to the hem.

use super::fit::{self, WaistFit};
use super::{GarmentError, GarmentShape};
use crate::contact::Obstacle;
use crate::grid::{Grid, Topology};
use crate::math::Vec3;
use std::f64::consts::TAU;

/// A skirt pattern and its placement. Lengths are positive and finite, the waist height and the axis finite
/// (the caller checks them; [`SkirtPattern::shape`] checks the rest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkirtPattern {
    /// Girth of the waist edge of the pattern (m).
    pub waist_girth: f64,
    /// Girth of the hem (m).
    pub hem_girth: f64,
    /// Length from waist to hem along the fabric (m).
    pub length: f64,
    /// Height `z` of the waist row (m).
    pub waist_height: f64,
    /// Nodes `[M, N]`: `M` around (periodic), `N` from waist to hem; at least 3 each.
    pub nodes: [usize; 2],
    /// The vertical axis `[x, y]` the skirt is centred on (m).
    pub axis: [f64; 2],
    /// How the waist row is placed on the body.
    pub waist_fit: WaistFit,
}

/// The pattern's cone about a vertical axis: radius `rw` at the waist height `z0`, `rh` a height `drop` below.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    /// A point of the axis at `z = 0` (m).
    pub axis: Vec3,
    /// Waist height (m).
    pub z0: f64,
    /// Waist radius (m).
    pub rw: f64,
    /// Hem radius (m).
    pub rh: f64,
    /// Height from waist to hem (m).
    pub drop: f64,
    /// Generatrices (nodes around).
    pub m: usize,
    /// Nodes along a generatrix.
    pub n: usize,
}

impl Cone {
    /// Horizontal unit direction of generatrix `i`.
    pub fn dir(&self, i: usize) -> Vec3 {
        let a = TAU * i as f64 / self.m as f64;
        Vec3::new(a.cos(), a.sin(), 0.0)
    }

    /// Fraction of the way down of node row `j` (0 at the waist, 1 at the hem).
    pub fn t_of(&self, j: usize) -> f64 {
        j as f64 / (self.n - 1) as f64
    }

    /// The point of generatrix `i` a fraction `t` of the way down.
    pub fn point(&self, i: usize, t: f64) -> Vec3 {
        self.axis + self.dir(i) * (self.rw + (self.rh - self.rw) * t) + Vec3::new(0.0, 0.0, self.z0 - self.drop * t)
    }

    /// The point at the waist height at angle `a` around the axis and distance `r` from it.
    pub fn waist_point(&self, a: f64, r: f64) -> Vec3 {
        self.axis + Vec3::new(a.cos(), a.sin(), 0.0) * r + Vec3::new(0.0, 0.0, self.z0)
    }

    /// The point a fraction `t` of the way along the straight line from `from` (a fitted waist point of
    /// generatrix `i`) to the cone's hem point of generatrix `i`.
    pub fn generatrix(&self, from: Vec3, i: usize, t: f64) -> Vec3 {
        from + (self.point(i, 1.0) - from) * t
    }
}

impl SkirtPattern {
    /// The periodic grid and the cone of the pattern.
    pub fn cone(&self) -> Result<(Grid, Cone), GarmentError> {
        let [m, n] = self.nodes;
        if m < 3 || n < 3 {
            return Err(GarmentError::TooFewNodes { nodes: self.nodes });
        }
        let (waist, hem, length) = (self.waist_girth, self.hem_girth, self.length);
        let (rw, rh) = (waist / TAU, hem / TAU);
        let flare = (rh - rw).abs();
        if length < flare {
            return Err(GarmentError::TooShort { length, flare });
        }
        let drop = (length * length - flare * flare).sqrt();
        let grid = Grid::new(m, n, waist / m as f64, length / (n - 1) as f64, [Topology::Periodic, Topology::Free])
            .map_err(GarmentError::Grid)?;
        let axis = Vec3::new(self.axis[0], self.axis[1], 0.0);
        Ok((grid, Cone { axis, z0: self.waist_height, rw, rh, drop, m, n }))
    }

    /// Builds the grid, the rest cone and the initial shape fitted against `obstacles` with contact offset
    /// `offset`.
    pub fn shape(&self, obstacles: &[Obstacle], offset: f64) -> Result<GarmentShape, GarmentError> {
        let (grid, cone) = self.cone()?;
        let rest: Vec<Vec3> = (0..grid.len())
            .map(|k| {
                let (i, j) = grid.coords(k);
                cone.point(i, cone.t_of(j))
            })
            .collect();
        let waist = fit::fit_waist(&cone, self.waist_fit, self.waist_girth, obstacles, offset)?;
        let waist_strain = waist.perimeter / self.waist_girth - 1.0;
        let initial: Vec<Vec3> = (0..grid.len())
            .map(|k| {
                let (i, j) = grid.coords(k);
                cone.generatrix(waist.points[i], i, cone.t_of(j))
            })
            .collect();
        let min_distance = fit::clearance(&cone, &waist.points, obstacles)?;
        let waist_nodes = (0..cone.m).map(|i| grid.index(i, 0)).collect();
        Ok(GarmentShape { grid, rest, initial, waist_nodes, waist_fitted: waist.fitted, waist_strain, min_distance })
    }
}
