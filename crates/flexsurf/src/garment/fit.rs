//! Fitting a garment onto the body. The waist curve is found as a function of the angle around the axis (a
//! radial search for the contact offset from the obstacles), the waist nodes are placed at equal arc length
//! along it, so the waistband is evenly stretched, and the straight generatrices from the fitted waist to the hem
//! are checked against the obstacles.

use super::skirt::Cone;
use super::GarmentError;
use crate::contact::{self, Obstacle};
use crate::math::Vec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

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

/// How the waist row is placed on the body.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "app", derive(schemars::JsonSchema))]
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

/// The fitted waist row.
#[derive(Debug, Clone, PartialEq)]
pub struct FittedWaist {
    /// One point per generatrix, at equal arc length along the fitted waist curve.
    pub points: Vec<Vec3>,
    /// Waist nodes moved (outward to clear the obstacles, or onto the body).
    pub fitted: usize,
    /// Length of the fitted waist curve (m); the pattern's waist girth when nothing moved.
    pub perimeter: f64,
}

/// Smallest signed distance of `p` from the obstacles (infinite without obstacles).
pub fn distance(obstacles: &[Obstacle], p: Vec3) -> f64 {
    contact::closest(obstacles, p).map_or(f64::INFINITY, |(d, _)| d)
}

/// Distance from the axis of the fitted waist curve at angle `a`: the pattern's waist radius when it clears the
/// obstacles by `offset` (`Outward`), else the smallest radius beyond the start that does, found by bracketing
/// and bisection.
pub fn waist_radius(
    cone: &Cone,
    fit: WaistFit,
    a: f64,
    obstacles: &[Obstacle],
    offset: f64,
) -> Result<f64, GarmentError> {
    let (rw, z0) = (cone.rw, cone.z0);
    let clear = |r: f64| distance(obstacles, cone.waist_point(a, r)) >= offset;
    let start = match fit {
        WaistFit::Outward if clear(rw) => return Ok(rw),
        WaistFit::Outward => rw,
        WaistFit::Body if clear(0.0) => return Err(GarmentError::NoBodyOnAxis { waist_height: z0 }),
        WaistFit::Body => 0.0,
    };
    let (mut lo, mut hi) = (start, start + 0.01);
    while !clear(hi) {
        lo = hi;
        hi = start + 2.0 * (hi - start);
        if hi - start > MAX_WAIST_FIT {
            return Err(GarmentError::CannotClear { waist_height: z0, angle: a });
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
}

/// Fits the waist curve of `cone` onto the obstacles and places one waist point per generatrix at equal arc
/// length along it. `waist_girth` is the pattern's waist girth.
pub fn fit_waist(
    cone: &Cone,
    fit: WaistFit,
    waist_girth: f64,
    obstacles: &[Obstacle],
    offset: f64,
) -> Result<FittedWaist, GarmentError> {
    let (m, rw) = (cone.m, cone.rw);
    let samples = (WAIST_SAMPLES_PER_NODE * m).max(MIN_WAIST_SAMPLES);
    let mut radii = Vec::with_capacity(samples + 1);
    for s in 0..samples {
        radii.push(waist_radius(cone, fit, TAU * s as f64 / samples as f64, obstacles, offset)?);
    }
    let moved = |r: f64| (r - rw).abs() > 1e-12;
    if !radii.iter().any(|&r| moved(r)) {
        // Nothing to fit: the pattern's own waist circle.
        return Ok(FittedWaist {
            points: (0..m).map(|i| cone.point(i, 0.0)).collect(),
            fitted: 0,
            perimeter: waist_girth,
        });
    }
    radii.push(radii[0]);
    let curve: Vec<Vec3> =
        radii.iter().enumerate().map(|(s, &r)| cone.waist_point(TAU * s as f64 / samples as f64, r)).collect();
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
    Ok(FittedWaist { points, fitted, perimeter })
}

/// Smallest signed distance from the obstacles of the straight generatrices from `waist` (one point per
/// generatrix) to the hem of `cone`, over [`GENERATRIX_SAMPLES`] points per grid segment; an error when it is
/// negative (the initial shape passes inside the body).
pub fn clearance(cone: &Cone, waist: &[Vec3], obstacles: &[Obstacle]) -> Result<f64, GarmentError> {
    let (m, n) = (cone.m, cone.n);
    let mut min_distance = f64::INFINITY;
    let mut worst = (0, 0.0);
    for i in 0..m {
        for s in 0..=GENERATRIX_SAMPLES * (n - 1) {
            let t = s as f64 / (GENERATRIX_SAMPLES * (n - 1)) as f64;
            let d = distance(obstacles, cone.generatrix(waist[i], i, t));
            if d < min_distance {
                min_distance = d;
                worst = (i, t);
            }
        }
    }
    if min_distance < 0.0 {
        let point = cone.generatrix(waist[worst.0], worst.0, worst.1);
        return Err(GarmentError::InsideBody { depth: -min_distance, generatrix: worst.0, down: worst.1, point });
    }
    Ok(min_distance)
}
