//! A scanned drape placed in the drape meter's frame: a rigid motion of the scan, estimated from the scan's
//! principal axes and a search of turns about the support's axis, then fitted beside the material constants.
//!
//! A scanner gives the drape in its own frame: the support's axis tilted, the disc anywhere, the folds at any
//! angle about the axis. The meter's frame has the disc's centre at the origin, its axis along z and its top at
//! z = 0. The placement of a scan point `s` is
//!
//! `s ↦ origin + shift + Rz(a) Ry(b) Rx(c) · base · (s − centre)`,
//!
//! where `centre`, `base` and `origin` come from [`estimate`] (fixed during the fit) and the six parameters
//! `(a, b, c, shift)` start at zero and are fitted: small turns about the meter's axes through the placed
//! centroid, and a shift (m). Their derivatives are closed form ([`Placement::derivatives`]); the symmetric
//! Chamfer residuals hold the nearest points fixed, as for the constants.

use super::targets::DrapeSurface;
use crate::math::{Mat3, Vec3};
use serde::Serialize;

/// How a shape target's scan is placed in the drape meter's frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Align {
    /// The scan is already in the meter's frame (disc centre at the origin, axis z, disc top at z = 0).
    None,
    /// A rigid motion of the scan is fitted with the constants, started from [`estimate`].
    #[default]
    Rigid,
}

/// The number of fitted placement parameters.
pub const PARAMETERS: usize = 6;

/// The placement parameters' names in a report: turns (rad) about the meter's z, y and x axes through the placed
/// centroid, and the shift (m).
pub const NAMES: [&str; PARAMETERS] =
    ["align.turn_z", "align.turn_y", "align.turn_x", "align.shift_x", "align.shift_y", "align.shift_z"];

/// The fixed part of a scan's placement ([`estimate`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Placement {
    /// The scan point turned about (the scan's centroid, scan frame).
    pub centre: Vec3,
    /// The rotation of the estimate.
    pub base: Mat3,
    /// Where the centre goes (meter frame).
    pub origin: Vec3,
    /// Where the estimate came from: the scan as given, or its principal axis turned by this many degrees.
    pub seed: Seed,
}

/// The candidate an estimate kept.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Seed {
    /// The scan as given.
    AsGiven,
    /// The scan's axis of least spread taken as the support's, its flat top as the disc, turned by this many
    /// degrees about the axis.
    PrincipalAxis(f64),
}

/// Rotation about z by `a`, and its derivative in `a`.
fn rz(a: f64) -> (Mat3, Mat3) {
    let (s, c) = a.sin_cos();
    let m = Mat3::from_cols(Vec3::new(c, s, 0.0), Vec3::new(-s, c, 0.0), Vec3::Z);
    let d = Mat3::from_cols(Vec3::new(-s, c, 0.0), Vec3::new(-c, -s, 0.0), Vec3::ZERO);
    (m, d)
}

/// Rotation about y by `b`, and its derivative.
fn ry(b: f64) -> (Mat3, Mat3) {
    let (s, c) = b.sin_cos();
    let m = Mat3::from_cols(Vec3::new(c, 0.0, -s), Vec3::Y, Vec3::new(s, 0.0, c));
    let d = Mat3::from_cols(Vec3::new(-s, 0.0, -c), Vec3::ZERO, Vec3::new(c, 0.0, -s));
    (m, d)
}

/// Rotation about x by `c`, and its derivative.
fn rx(c: f64) -> (Mat3, Mat3) {
    let (s, co) = c.sin_cos();
    let m = Mat3::from_cols(Vec3::X, Vec3::new(0.0, co, s), Vec3::new(0.0, -s, co));
    let d = Mat3::from_cols(Vec3::ZERO, Vec3::new(0.0, -s, co), Vec3::new(0.0, -co, -s));
    (m, d)
}

/// The mean of `points` (not empty).
fn centroid(points: &[Vec3]) -> Vec3 {
    points.iter().fold(Vec3::ZERO, |a, p| a + *p) / points.len().max(1) as f64
}

impl Placement {
    /// The scan as given (the identity).
    pub fn as_given(scan: &[Vec3]) -> Self {
        let c = centroid(scan);
        Self { centre: c, base: Mat3::IDENTITY, origin: c, seed: Seed::AsGiven }
    }

    /// The rotation at parameters `p` (`p[..3]` the turns).
    pub fn rotation(&self, p: &[f64]) -> Mat3 {
        rz(p[0]).0 * ry(p[1]).0 * rx(p[2]).0 * self.base
    }

    /// The placement at `p` as `s ↦ m s + v`.
    pub fn affine(&self, p: &[f64]) -> (Mat3, Vec3) {
        let m = self.rotation(p);
        (m, self.origin + Vec3::new(p[3], p[4], p[5]) - m * self.centre)
    }

    /// The scan placed at `p`.
    pub fn placed(&self, p: &[f64], scan: &[Vec3]) -> Vec<Vec3> {
        let (m, v) = self.affine(p);
        scan.iter().map(|s| m * *s + v).collect()
    }

    /// The derivatives of the placed point of `s` in the six parameters at `p`.
    pub fn derivatives(&self, p: &[f64], s: Vec3) -> [Vec3; PARAMETERS] {
        let ((z, dz), (y, dy), (x, dx)) = (rz(p[0]), ry(p[1]), rx(p[2]));
        let u = self.base * (s - self.centre);
        [dz * (y * (x * u)), z * (dy * (x * u)), z * (y * (dx * u)), Vec3::X, Vec3::Y, Vec3::Z]
    }
}

/// At most this many scan points enter the estimate's search (every k-th, in order).
const SEARCH_POINTS: usize = 2000;
/// Turns about the axis tried by the estimate (every 5°).
const TURNS: usize = 72;

/// The unit eigenvector of the least eigenvalue of the scan's covariance (its axis of least spread).
fn least_spread_axis(points: &[Vec3], c: Vec3) -> Vec3 {
    let mut cov = [[0.0; 3]; 3];
    for p in points {
        let d = *p - c;
        for (i, row) in cov.iter_mut().enumerate() {
            for (j, e) in row.iter_mut().enumerate() {
                *e += d[i] * d[j];
            }
        }
    }
    let m = faer::Mat::from_fn(3, 3, |i, j| cov[i][j]);
    match m.self_adjoint_eigen(faer::Side::Lower) {
        Ok(e) => {
            let (s, v) = (e.S(), e.U());
            let k = (0..3).fold(0, |k, j| if s[j] < s[k] { j } else { k });
            Vec3::new(v[(0, k)], v[(1, k)], v[(2, k)]).normalize_or(Vec3::Z)
        }
        Err(_) => Vec3::Z,
    }
}

/// A scan's principal-axis frame: its axis of least spread taken as the support's, oriented so that the top
/// (the disc) is the extreme nearer the centroid (the drape hangs below it), through the centroid (a drape's
/// folds spread about the axis; the fit corrects the rest), the highest point at the disc's top. (The points
/// near the top are no guide to the axis: a tilt left by the principal axis puts them on one side of the clamp.)
struct Principal {
    /// The scan's centroid.
    centre: Vec3,
    /// The rotation taking the axis to z.
    to_z: Mat3,
    /// The disc's top in the rotated frame about the centroid.
    top: Vec3,
}

impl Principal {
    fn new(scan: &[Vec3]) -> Self {
        let c = centroid(scan);
        let mut n = least_spread_axis(scan, c);
        let (lo, hi) = scan
            .iter()
            .map(|p| (*p - c).dot(n))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), h| (lo.min(h), hi.max(h)));
        let hi = if hi > -lo {
            n = -n;
            -lo
        } else {
            hi
        };
        let to_z = Mat3::from_quat(glam::DQuat::from_rotation_arc(n, Vec3::Z));
        Self { centre: c, to_z, top: Vec3::new(0.0, 0.0, hi) }
    }

    /// The placement turned by `deg` degrees about the axis.
    fn turned(&self, deg: f64) -> Placement {
        let turn = rz(deg.to_radians()).0;
        Placement {
            centre: self.centre,
            base: turn * self.to_z,
            origin: -(turn * self.top),
            seed: Seed::PrincipalAxis(deg),
        }
    }
}

/// The mean squared distance of the placed scan points `scan` to the surface of `drape`: the shape target's
/// first term. (Its second, a node's distance to its nearest scan point, is left out of the search: for a scan
/// no denser than the grid it jumps as a turn moves the scan points past the nodes, and makes basins of a
/// degree or two, where the distance to the surface varies smoothly with the turn.)
fn distance(scan: &[Vec3], drape: &DrapeSurface) -> f64 {
    scan.iter().map(|s| (drape.closest(*s).2 - *s).length_squared()).sum::<f64>() / scan.len().max(1) as f64
}

/// The placement of `scan` to start a fit from: of the scan as given and its principal-axis placements
/// turned every 5° about the axis ([`Principal`]), the one nearest `drape` (the starting constants' drape) by the
/// mean squared distance of at most [`SEARCH_POINTS`] scan points to its surface, its turn then refined to
/// 0.2°. Ties keep the earlier candidate (the scan as given first).
pub fn estimate(scan: &[Vec3], drape: &DrapeSurface) -> Placement {
    let stride = scan.len().div_ceil(SEARCH_POINTS).max(1);
    let sample: Vec<Vec3> = scan.iter().step_by(stride).copied().collect();
    let cost = |p: &Placement| distance(&p.placed(&[0.0; PARAMETERS], &sample), drape);
    let given = Placement::as_given(scan);
    let principal = Principal::new(scan);
    let mut best = (cost(&given), given);
    let keep = |best: &mut (f64, Placement), p: Placement| {
        let d = cost(&p);
        if d < best.0 {
            *best = (d, p);
        }
    };
    for k in 0..TURNS {
        keep(&mut best, principal.turned(360.0 * k as f64 / TURNS as f64));
    }
    // The turn refined about the best coarse one: to 1°, then to 0.2°.
    for step in [1.0, 0.2] {
        if let Seed::PrincipalAxis(deg) = best.1.seed {
            for k in [-4.0, -3.0, -2.0, -1.0, 1.0, 2.0, 3.0, 4.0] {
                keep(&mut best, principal.turned(deg + k * step));
            }
        }
    }
    best.1
}
