//! What stays fixed during a run: the grid, the elastic model (paper or Terzopoulos), lumped masses and
//! damping, gravity, obstacles, pins and springs. A [`Model`] is built once (by `scene` or by hand) and read
//! by the integrators.

use crate::contact::{ContactParams, Obstacle};
use crate::energy::frame::Warp;
use crate::energy::{bending::Bending, membrane::Membrane, terzopoulos, Energy, Sink};
use crate::grid::Grid;
use crate::material::{Fabric, Stiffness};
use crate::math::Vec3;
use crate::sparse::BlockPattern;
use serde::{Deserialize, Serialize};

/// Which deformation model computes the elastic force.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    /// The paper's model: the exact gradient of the discrete energy (default).
    #[default]
    Tfs,
    /// Terzopoulos & Fleischer: bending through `x_ij` instead of `n`, no H term.
    Terzopoulos,
}

impl ModelKind {
    /// Name as used in scene files and summaries.
    pub fn name(&self) -> &'static str {
        match self {
            ModelKind::Tfs => "tfs",
            ModelKind::Terzopoulos => "terzopoulos",
        }
    }
}

/// Energies of a configuration, by term.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Energies {
    /// Membrane (stretch and shear), J.
    pub membrane: f64,
    /// Bending and twist, J.
    pub bending: f64,
}

/// How the rest shape defines the stress-free state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ElasticOptions {
    /// Warp direction, radians from the `u1` tangent of the rest shape (ignored when `warp_direction` is set).
    pub warp_angle: f64,
    /// Warp along this fixed direction of the rest shape instead (a polar grid of one flat piece of fabric).
    pub warp_direction: Option<Vec3>,
    /// The rest shape is a flat pattern wrapped into shape (a sewn garment): it gives the metric `G⁰` only, and
    /// the rest curvature is zero.
    pub flat_pattern: bool,
}

/// Elastic part of a model: membrane and bending on one sparsity pattern.
#[derive(Debug, Clone)]
pub struct Elastic {
    /// Which model.
    pub kind: ModelKind,
    /// Membrane term.
    pub membrane: Membrane,
    /// Bending term.
    pub bending: Bending,
    /// Block pattern of the Hessian (all stencils).
    pub pattern: BlockPattern,
}

impl Elastic {
    /// Builds both terms on `grid` with rest shape `rest`, warp along `u1`.
    pub fn new(grid: &Grid, rest: &[Vec3], stiffness: &Stiffness, kind: ModelKind) -> Self {
        Self::with_warp_angle(grid, rest, stiffness, kind, 0.0)
    }

    /// Both terms with the warp at `warp_angle` (radians) from the `u1` tangent of the rest shape.
    pub fn with_warp_angle(
        grid: &Grid,
        rest: &[Vec3],
        stiffness: &Stiffness,
        kind: ModelKind,
        warp_angle: f64,
    ) -> Self {
        Self::with_options(grid, rest, stiffness, kind, &ElasticOptions { warp_angle, ..Default::default() })
    }

    /// Both terms with explicit [`ElasticOptions`].
    pub fn with_options(
        grid: &Grid,
        rest: &[Vec3],
        stiffness: &Stiffness,
        kind: ModelKind,
        options: &ElasticOptions,
    ) -> Self {
        let warp = match options.warp_direction {
            Some(d) => Warp::Direction(d),
            None => Warp::Angle(options.warp_angle),
        };
        let mut membrane = Membrane::with_warp(grid, rest, stiffness, warp);
        let mut bending = Bending::with_warp(grid, rest, stiffness, warp);
        if options.flat_pattern {
            bending.flatten_rest_curvature();
        }
        let pairs = membrane.pairs().into_iter().chain(bending.pairs());
        let pattern = BlockPattern::from_pairs(grid.len(), pairs);
        membrane.bind(&pattern);
        bending.bind(&pattern);
        Self { kind, membrane, bending, pattern }
    }

    /// Adds `∂E/∂x` (for Terzopoulos: minus its force) and the requested operator; returns the energies.
    pub fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> Energies {
        let membrane = self.membrane.evaluate(x, sink);
        let bending = match self.kind {
            ModelKind::Tfs => self.bending.evaluate(x, sink),
            ModelKind::Terzopoulos => terzopoulos::bending(&self.bending, x, sink),
        };
        Energies { membrane, bending }
    }
}

/// Rest area per node: each cell's rest area `|c1 × c2| h1 h2` (bilinear cell tangents of the rest shape)
/// shared equally by its four corners. For a flat rectangular grid this is the trapezoid area `h1 h2` (halved
/// on edges, quartered at corners); for a cone or any other non-rectangular pattern it is the true share.
pub fn rest_areas(grid: &Grid, rest: &[Vec3]) -> Vec<f64> {
    let mut area = vec![0.0; grid.len()];
    for (i, j) in grid.cells() {
        let c = grid.cell(i, j);
        let c1 = (rest[c[1]] - rest[c[0]] + rest[c[3]] - rest[c[2]]) * 0.5;
        let c2 = (rest[c[2]] - rest[c[0]] + rest[c[3]] - rest[c[1]]) * 0.5;
        let a = c1.cross(c2).length();
        for k in c {
            area[k] += 0.25 * a;
        }
    }
    area
}

/// A spring holding a node near a target (the skirt's waist): force `k (target − x)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spring {
    /// Node.
    pub node: usize,
    /// Target point.
    pub target: Vec3,
    /// Stiffness (N/m).
    pub stiffness: f64,
}

/// Everything that stays fixed during a run.
#[derive(Debug, Clone)]
pub struct Model {
    /// The parametric grid.
    pub grid: Grid,
    /// Rest shape (also the initial shape unless a scene says otherwise).
    pub rest: Vec<Vec3>,
    /// The fabric.
    pub fabric: Fabric,
    /// Calibrated coefficients.
    pub stiffness: Stiffness,
    /// Elastic model.
    pub elastic: Elastic,
    /// Lumped node masses ρ·area (kg).
    pub mass: Vec<f64>,
    /// Lumped node damping γ·area (kg/s).
    pub damping: Vec<f64>,
    /// Rest area per node (m²).
    pub area: Vec<f64>,
    /// Gravity (m/s²).
    pub gravity: Vec3,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Contact parameters.
    pub contact: ContactParams,
    /// Pinned nodes, held exactly at their position.
    pub pinned: Vec<bool>,
    /// Constraint springs.
    pub springs: Vec<Spring>,
    /// Constant external nodal loads (N), beyond gravity (the paper's `p`).
    pub loads: Vec<Vec3>,
}

impl Model {
    /// A model with no obstacles, pins or springs; the rest shape is `rest`.
    pub fn new(
        grid: Grid,
        rest: Vec<Vec3>,
        fabric: Fabric,
        stiffness: Stiffness,
        kind: ModelKind,
        gravity: Vec3,
    ) -> Self {
        Self::with_options(grid, rest, fabric, stiffness, kind, gravity, &ElasticOptions::default())
    }

    /// As [`Model::new`] with explicit [`ElasticOptions`] (warp angle, flat pattern).
    pub fn with_options(
        grid: Grid,
        rest: Vec<Vec3>,
        fabric: Fabric,
        stiffness: Stiffness,
        kind: ModelKind,
        gravity: Vec3,
        options: &ElasticOptions,
    ) -> Self {
        let elastic = Elastic::with_options(&grid, &rest, &stiffness, kind, options);
        let area = rest_areas(&grid, &rest);
        let mass = area.iter().map(|a| a * fabric.density).collect();
        let damping = area.iter().map(|a| a * fabric.damping).collect();
        let n = grid.len();
        Self {
            grid,
            rest,
            fabric,
            stiffness,
            elastic,
            mass,
            damping,
            area,
            gravity,
            obstacles: Vec::new(),
            contact: ContactParams { stiffness: 0.0, offset: 0.0, friction: 0.0 },
            pinned: vec![false; n],
            springs: Vec::new(),
            loads: vec![Vec3::ZERO; n],
        }
    }

    /// Total mass (kg).
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    /// Potential energy of gravity and the constant loads, `−Σ (m g + p)·x` (J).
    pub fn potential(&self, x: &[Vec3]) -> f64 {
        -(0..x.len()).map(|k| self.external_force(k).dot(x[k])).sum::<f64>()
    }

    /// Constant external force on node `k`: gravity plus load (N).
    #[inline]
    pub fn external_force(&self, k: usize) -> Vec3 {
        self.gravity * self.mass[k] + self.loads[k]
    }

    /// A length scale of the sheet (diagonal of the rest pattern), for bounds and tolerances.
    pub fn length_scale(&self) -> f64 {
        let l1 = self.grid.h1 * self.grid.spans(0) as f64;
        let l2 = self.grid.h2 * self.grid.spans(1) as f64;
        (l1 * l1 + l2 * l2).sqrt()
    }

    /// Largest engineering stretch `|ℓ/ℓ₀ − 1|` over all grid edges.
    pub fn max_strain(&self, x: &[Vec3]) -> f64 {
        let g = &self.grid;
        let mut worst: f64 = 0.0;
        for (i, j) in g.cells() {
            let c = g.cell(i, j);
            for (a, b) in [(c[0], c[1]), (c[0], c[2]), (c[1], c[3]), (c[2], c[3])] {
                let l0 = (self.rest[b] - self.rest[a]).length();
                let l = (x[b] - x[a]).length();
                worst = worst.max((l / l0 - 1.0).abs());
            }
        }
        worst
    }
}
