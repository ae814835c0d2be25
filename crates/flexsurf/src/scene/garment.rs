//! Garments: `[garment]` in place of `[sheet]`. A skirt (the paper's demo 2, MODEL.md §8.2) is a periodic grid,
//! `u1` around the waist and `u2` down, whose pattern is a flared circle skirt: a cone of the waist girth at the
//! top, the hem girth at the bottom and the given length along every generatrix. The cone is the rest shape
//! used as a flat pattern (its metric, zero rest curvature). The initial shape is the cone with its waist row
//! fitted onto the body: a waist node whose circle point lies within the contact offset of an obstacle moves
//! radially outward until it is at the offset, and the generatrix from it to the hem stays straight. The waist
//! row is held by springs to these initial positions.

use super::{Initial, SceneError};
use crate::contact::{self, Obstacle};
use crate::grid::{Grid, Topology};
use crate::math::Vec3;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, TAU};
use std::path::Path;

/// Default waist spring stiffness (N/m per node), the paper's `k = 80`.
pub const WAIST_SPRINGS: f64 = 80.0;
/// Samples per grid segment when the initial shape is checked against the obstacles along the generatrices.
pub const GENERATRIX_SAMPLES: usize = 4;
/// Farthest a waist node is moved outward to clear the body (m).
pub const MAX_WAIST_FIT: f64 = 1.0;
/// Points per waist node (at least [`MIN_WAIST_SAMPLES`] in all) on which the fitted waist curve is found.
pub const WAIST_SAMPLES_PER_NODE: usize = 4;
/// Fewest points of the fitted waist curve.
pub const MIN_WAIST_SAMPLES: usize = 256;
/// Bisection steps of the radial search for the body surface (from a 1 cm bracket: well below 1e-9 m).
const WAIST_BISECTIONS: usize = 32;

/// Which garment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum GarmentKind {
    /// A flared circle skirt hanging from the waist.
    Skirt,
}

/// Direction of the warp (the fabric's stronger direction, `tensile_warp`) on the garment.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Warp {
    /// Along the generatrices, waist to hem (`u2`; default).
    #[default]
    Vertical,
    /// Around the body (`u1`).
    Horizontal,
}

impl Warp {
    /// Angle of the warp from the `u1` tangent (radians).
    pub fn angle(&self) -> f64 {
        match self {
            Warp::Vertical => FRAC_PI_2,
            Warp::Horizontal => 0.0,
        }
    }
}

/// How the waist row is placed on the body.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum WaistFit {
    /// The waist circle of the pattern; a node closer to the body than the contact offset moves radially outward
    /// until it is at the offset (default).
    #[default]
    Outward,
    /// Every waist node moves radially (in or out) onto the body surface plus the contact offset: a fitted
    /// waistband. The pattern's waist girth should then match the girth of that curve.
    Body,
}

/// `[garment]`: a skirt pattern, its placement and its waist springs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GarmentSpec {
    /// `skirt`.
    pub kind: GarmentKind,
    /// Girth of the waist edge of the pattern (m).
    pub waist_girth: f64,
    /// Girth of the hem (m); larger than the waist for a flared skirt.
    pub hem_girth: f64,
    /// Length from waist to hem along the fabric (m); at least `|hem − waist| / 2π`.
    pub length: f64,
    /// Height `z` of the waist row (m).
    pub waist_height: f64,
    /// Nodes `[M, N]`: `M` around (periodic, at least 3), `N` from waist to hem (at least 3).
    pub nodes: [usize; 2],
    /// The vertical axis `[x, y]` the skirt is centred on (m), default `[0, 0]`.
    #[serde(default)]
    pub axis: [f64; 2],
    /// `vertical` (default) or `horizontal`: the warp direction on the garment.
    #[serde(default)]
    pub warp: Warp,
    /// `outward` (default) or `body`: how the waist row is placed on the body.
    #[serde(default)]
    pub waist_fit: WaistFit,
    /// Stiffness of each waist node's spring (N/m per node), default 80.
    #[serde(default = "default_waist_springs")]
    pub waist_springs: f64,
    /// Where the waist springs pull: `"initial"` (each waist node's fitted initial position; the only choice).
    #[serde(default = "default_initial")]
    pub waist_target: Initial,
}

fn default_waist_springs() -> f64 {
    WAIST_SPRINGS
}

fn default_initial() -> Initial {
    Initial::Initial
}

/// A garment's built geometry.
#[derive(Debug, Clone)]
pub struct GarmentShape {
    /// The periodic grid.
    pub grid: Grid,
    /// Rest shape: the unfitted cone (the pattern's metric).
    pub rest: Vec<Vec3>,
    /// Initial shape: the cone with its waist row fitted onto the obstacles.
    pub initial: Vec<Vec3>,
    /// Waist row node indices (`[i, 0]`).
    pub waist_nodes: Vec<usize>,
    /// Waist nodes moved (outward to clear the obstacles, or onto the body).
    pub waist_fitted: usize,
    /// Strain of the fitted waist row against the pattern's waist girth (its girth / `waist_girth` − 1).
    pub waist_strain: f64,
    /// Smallest signed distance from the obstacles of the initial shape, over its nodes and
    /// [`GENERATRIX_SAMPLES`] points per segment of every generatrix (m; infinite without obstacles).
    pub min_distance: f64,
}

/// What the run reports about a garment scene.
#[derive(Debug, Clone, PartialEq)]
pub struct GarmentInfo {
    /// `skirt`.
    pub kind: GarmentKind,
    /// Waist row node indices.
    pub waist_nodes: Vec<usize>,
    /// Waist nodes moved onto the body.
    pub waist_fitted: usize,
    /// Strain of the fitted waist row against the pattern's waist girth.
    pub waist_strain: f64,
    /// Smallest signed distance of the initial shape from the obstacles (m).
    pub initial_min_distance: f64,
}

/// Smallest signed distance of `p` from the obstacles (infinite without obstacles).
fn distance(obstacles: &[Obstacle], p: Vec3) -> f64 {
    contact::closest(obstacles, p).map_or(f64::INFINITY, |(d, _)| d)
}

impl GarmentSpec {
    /// Checks the values and builds the grid, the rest cone and the fitted initial shape against `obstacles`
    /// with contact offset `offset`. `file` names errors.
    pub fn shape(&self, obstacles: &[Obstacle], offset: f64, file: &Path) -> Result<GarmentShape, SceneError> {
        let bad = |key: &str, message: String| SceneError::invalid(file, format!("garment.{key}"), message);
        let positive = |key: &str, v: f64| -> Result<f64, SceneError> {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(bad(key, format!("{v} m must be a positive, finite length")))
            }
        };
        let waist = positive("waist_girth", self.waist_girth)?;
        let hem = positive("hem_girth", self.hem_girth)?;
        let length = positive("length", self.length)?;
        if !self.waist_height.is_finite() {
            return Err(bad("waist_height", format!("{} m must be finite", self.waist_height)));
        }
        if !self.axis.iter().all(|c| c.is_finite()) {
            return Err(bad("axis", format!("{:?} must be two finite numbers", self.axis)));
        }
        if !(self.waist_springs.is_finite() && self.waist_springs > 0.0) {
            return Err(bad("waist_springs", format!("{} N/m must be positive and finite", self.waist_springs)));
        }
        let [m, n] = self.nodes;
        if m < 3 || n < 3 {
            return Err(bad("nodes", format!("[{m}, {n}]: at least 3 nodes are needed in each direction")));
        }
        let (rw, rh) = (waist / TAU, hem / TAU);
        let flare = (rh - rw).abs();
        if length < flare {
            return Err(bad(
                "length",
                format!(
                    "{length} m is shorter than the radial distance from waist to hem, |hem_girth − waist_girth|/2π \
                     = {flare:.4} m: no cone has this pattern; lengthen the skirt or bring the girths closer"
                ),
            ));
        }
        let drop = (length * length - flare * flare).sqrt();
        let grid = Grid::new(m, n, waist / m as f64, length / (n - 1) as f64, [Topology::Periodic, Topology::Free])
            .map_err(|e| bad("nodes", e.to_string()))?;
        let axis = Vec3::new(self.axis[0], self.axis[1], 0.0);
        let z0 = self.waist_height;
        let dir = |i: usize| {
            let a = TAU * i as f64 / m as f64;
            Vec3::new(a.cos(), a.sin(), 0.0)
        };
        let t_of = |j: usize| j as f64 / (n - 1) as f64;
        let cone = |i: usize, t: f64| axis + dir(i) * (rw + (rh - rw) * t) + Vec3::new(0.0, 0.0, z0 - drop * t);
        let rest: Vec<Vec3> = (0..grid.len())
            .map(|k| {
                let (i, j) = grid.coords(k);
                cone(i, t_of(j))
            })
            .collect();

        // Fit the waist curve onto the obstacles as a function of the angle around the axis, then place the waist
        // nodes at equal arc length along it, so the waistband is evenly stretched (by `waist_strain`).
        let radius_at = |a: f64| -> Result<f64, SceneError> {
            let d = Vec3::new(a.cos(), a.sin(), 0.0);
            let at = |r: f64| axis + d * r + Vec3::new(0.0, 0.0, z0);
            let clear = |r: f64| distance(obstacles, at(r)) >= offset;
            let start = match self.waist_fit {
                WaistFit::Outward if clear(rw) => return Ok(rw),
                WaistFit::Outward => rw,
                WaistFit::Body if clear(0.0) => {
                    return Err(bad(
                        "waist_fit",
                        format!(
                            "`body`: there is no body on the skirt's axis at the waist height z = {z0} m to fit the \
                             waist onto; use `outward` or move `waist_height` or `axis`"
                        ),
                    ));
                }
                WaistFit::Body => 0.0,
            };
            let (mut lo, mut hi) = (start, start + 0.01);
            while !clear(hi) {
                lo = hi;
                hi = start + 2.0 * (hi - start);
                if hi - start > MAX_WAIST_FIT {
                    return Err(bad(
                        "waist_height",
                        format!(
                            "the waist row at z = {z0} m cannot be placed outside the body: it would move more than \
                             {MAX_WAIST_FIT} m outward at {:.0}° around the axis",
                            a.to_degrees()
                        ),
                    ));
                }
            }
            for _ in 0..WAIST_BISECTIONS {
                let mid = 0.5 * (lo + hi);
                if clear(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            Ok(hi)
        };
        let samples = (WAIST_SAMPLES_PER_NODE * m).max(MIN_WAIST_SAMPLES);
        let mut radii = Vec::with_capacity(samples + 1);
        for s in 0..samples {
            radii.push(radius_at(TAU * s as f64 / samples as f64)?);
        }
        let moved = |r: f64| (r - rw).abs() > 1e-12;
        let (waist_points, waist_fitted, perimeter) = if !radii.iter().any(|&r| moved(r)) {
            // Nothing to fit: the pattern's own waist circle.
            ((0..m).map(|i| cone(i, 0.0)).collect::<Vec<_>>(), 0, waist)
        } else {
            radii.push(radii[0]);
            let curve: Vec<Vec3> = radii
                .iter()
                .enumerate()
                .map(|(s, &r)| {
                    let a = TAU * s as f64 / samples as f64;
                    axis + Vec3::new(a.cos(), a.sin(), 0.0) * r + Vec3::new(0.0, 0.0, z0)
                })
                .collect();
            let mut arc = vec![0.0];
            for w in curve.windows(2) {
                arc.push(arc[arc.len() - 1] + (w[1] - w[0]).length());
            }
            let perimeter = arc[samples];
            let (mut points, mut fitted, mut seg) = (Vec::with_capacity(m), 0, 0);
            for i in 0..m {
                let target = perimeter * i as f64 / m as f64;
                while seg + 1 < samples && arc[seg + 1] < target {
                    seg += 1;
                }
                let span = arc[seg + 1] - arc[seg];
                let f = if span > 0.0 { (target - arc[seg]) / span } else { 0.0 };
                points.push(curve[seg] + (curve[seg + 1] - curve[seg]) * f);
                if moved(radii[seg]) || moved(radii[seg + 1]) {
                    fitted += 1;
                }
            }
            (points, fitted, perimeter)
        };
        let waist_strain = perimeter / waist - 1.0;

        // Straight generatrices from the fitted waist to the (evenly spaced) hem of the cone.
        let along = |i: usize, t: f64| waist_points[i] + (cone(i, 1.0) - waist_points[i]) * t;
        let initial: Vec<Vec3> = (0..grid.len())
            .map(|k| {
                let (i, j) = grid.coords(k);
                along(i, t_of(j))
            })
            .collect();
        let mut min_distance = f64::INFINITY;
        let mut worst = (0, 0.0);
        for i in 0..m {
            for s in 0..=GENERATRIX_SAMPLES * (n - 1) {
                let t = s as f64 / (GENERATRIX_SAMPLES * (n - 1)) as f64;
                let d = distance(obstacles, along(i, t));
                if d < min_distance {
                    min_distance = d;
                    worst = (i, t);
                }
            }
        }
        if min_distance < 0.0 {
            let p = along(worst.0, worst.1);
            return Err(SceneError::invalid(
                file,
                "garment".into(),
                format!(
                    "the initial skirt passes {:.4} m inside the body (generatrix {}, {:.0}% of the way down, at \
                     [{:.3}, {:.3}, {:.3}] m): give a larger `hem_girth` (more flare) or `waist_girth`, or move \
                     `waist_height`",
                    -min_distance,
                    worst.0,
                    100.0 * worst.1,
                    p.x,
                    p.y,
                    p.z
                ),
            ));
        }
        let waist_nodes = (0..m).map(|i| grid.index(i, 0)).collect();
        Ok(GarmentShape { grid, rest, initial, waist_nodes, waist_fitted, waist_strain, min_distance })
    }
}
