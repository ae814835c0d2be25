//! A placed panel wrapped onto the body's **offset surface** (the points at a given distance outside the
//! obstacles), after its wrap onto a cylinder or cone, row by row around the placement's axis:
//!
//! 1. every node's line to the axis (perpendicular to it) is traced to its first point at the offset from the
//!    body, coming in from the cylinder; a node already closer to the body than the offset (a cylinder cut
//!    through it) is traced out along the same line instead;
//! 2. the row is then pulled taut like a string: each node goes to where its line leaves the convex hull
//!    (across the axis) of the row's traced points and the axis, so a node whose line passes between two parts
//!    of the body (between the legs, between an arm and the torso) lies on the chord across the gap instead of
//!    falling through it, and the row has no jumps. A node outside the angular span of the row's traced points
//!    (beyond the body's extent in its row) stays where the wrap put it, as does every node of a row that
//!    meets no body.
//!
//! The rows are the grid's lines of nodes that turn most about the axis. The trace is **sphere tracing**: with
//! `g(p) = d(p) − offset` and `d` the obstacles' signed distance (1-Lipschitz), a step of `g` along the line
//! cannot pass the offset surface, so the first crossing is found from outside, and a step of `−g` from inside.
//!
//! The placed panel is not the pattern's isometric image any more (it is compressed where the body is narrower
//! than the cylinder); the rest metric stays the flat pattern's, so the sewing phase relaxes it.

use super::pattern::Placement;
use crate::contact::{closest, Obstacle};
use crate::grid::Grid;
use crate::math::Vec3;

/// A node closer than this (m) to the offset surface is on it.
pub const TOLERANCE: f64 = 1e-6;

/// The smallest step of the trace (m): a line grazing the offset surface moves on by at least this much, so
/// the trace ends; it then stops at most this far inside the offset.
const LEAST_STEP: f64 = 1e-5;

/// Steps of the trace before a node is left where it is.
const MOST_STEPS: usize = 4000;

/// How far (m) a node inside the offset surface is looked for its way out, beyond its distance to the axis.
const OUT_REACH: f64 = 1.0;

/// The point of the line from `q` towards `axis_point` at `offset` from `obstacles` (see the module): `None`
/// when the line meets no body before the axis (from outside) or no way out within reach (from inside), or a
/// distance is not a number.
pub fn onto_offset_surface(q: Vec3, axis_point: Vec3, offset: f64, obstacles: &[Obstacle]) -> Option<Vec3> {
    let reach = (axis_point - q).length();
    let inward = (axis_point - q).try_normalize()?;
    let g = |p: Vec3| closest(obstacles, p).map(|(d, _)| d - offset);
    let g0 = g(q)?;
    if !g0.is_finite() {
        return None;
    }
    // From outside: in along the line; from inside: out along it, the gap's sign turned.
    let (dir, sign, limit) = if g0 > 0.0 { (inward, 1.0, reach) } else { (-inward, -1.0, reach + OUT_REACH) };
    let mut t = 0.0;
    let mut gap = sign * g0;
    for _ in 0..MOST_STEPS {
        if gap < TOLERANCE {
            return Some(q + dir * t);
        }
        t += gap.max(LEAST_STEP);
        if t > limit {
            return None;
        }
        gap = sign * g(q + dir * t)?;
        if gap.is_nan() {
            return None;
        }
    }
    None
}

/// Moves the nodes of a placed panel (`placed`, on `grid`) onto the offset surface at `offset` from
/// `obstacles`, row by row around the axis of `placement` (see the module); returns how many nodes moved. A
/// flat placement, or positions that are not one per node of `grid`, move nothing.
pub fn wrap_onto_body(
    placed: &mut [Vec3],
    grid: &Grid,
    placement: &Placement,
    offset: f64,
    obstacles: &[Obstacle],
) -> usize {
    let Some(axis) = placement.axis_direction().filter(|_| placed.len() == grid.len()) else { return 0 };
    let frame = Frame::about(axis);
    let mut moved = 0;
    for row in rows_around(placed, grid, placement, &frame) {
        moved += wrap_row(placed, &row, placement, &frame, offset, obstacles);
    }
    moved
}

/// Two directions across the axis `e3`, so a node's place about the axis is a point of the plane.
struct Frame {
    e1: Vec3,
    e2: Vec3,
}

impl Frame {
    fn about(e3: Vec3) -> Self {
        let e1 = e3.any_orthonormal_vector();
        Self { e1, e2: e3.cross(e1) }
    }

    /// `v` (across the axis) in the plane's coordinates.
    fn flat(&self, v: Vec3) -> [f64; 2] {
        [v.dot(self.e1), v.dot(self.e2)]
    }
}

/// The grid's lines of nodes that run around the axis (of its two directions, the one whose steps turn most
/// about it), each in order.
fn rows_around(placed: &[Vec3], grid: &Grid, placement: &Placement, frame: &Frame) -> Vec<Vec<usize>> {
    let angle = |k: usize| {
        let q = placement.axis_point(placed[k]).map_or([0.0, 0.0], |a| frame.flat(placed[k] - a));
        q[1].atan2(q[0])
    };
    let turn = |a: usize, b: usize| {
        let d = angle(b) - angle(a);
        (d - std::f64::consts::TAU * (d / std::f64::consts::TAU).round()).abs()
    };
    let (m, n) = (grid.m, grid.n);
    let along_u1: f64 = (0..n)
        .flat_map(|j| (1..m).map(move |i| (i, j)))
        .map(|(i, j)| turn(grid.index(i - 1, j), grid.index(i, j)))
        .sum();
    let along_u2: f64 = (0..m)
        .flat_map(|i| (1..n).map(move |j| (i, j)))
        .map(|(i, j)| turn(grid.index(i, j - 1), grid.index(i, j)))
        .sum();
    if along_u1 / (m.max(2) - 1) as f64 >= along_u2 / (n.max(2) - 1) as f64 {
        (0..n).map(|j| (0..m).map(|i| grid.index(i, j)).collect()).collect()
    } else {
        (0..m).map(|i| (0..n).map(|j| grid.index(i, j)).collect()).collect()
    }
}

/// One row around the axis: each node's line traced onto the offset surface, then the row pulled taut over
/// the body like a string: every node goes to where its line meets the boundary of the convex hull (across the
/// axis) of the row's traced points and the axis, so a node whose line passes between two parts of the body
/// (between the legs) lies on the chord across the gap, and the row has no jumps. A node outside the angular
/// span of the row's traced points stays where it is.
fn wrap_row(
    placed: &mut [Vec3],
    row: &[usize],
    placement: &Placement,
    frame: &Frame,
    offset: f64,
    obstacles: &[Obstacle],
) -> usize {
    // Each node's foot on the axis, its direction across the axis (as an angle from the row's middle node's)
    // and its traced point's distance from the axis.
    let mid = row[row.len() / 2];
    let reference = placement.axis_point(placed[mid]).map_or([1.0, 0.0], |a| frame.flat(placed[mid] - a));
    let reference = reference[1].atan2(reference[0]);
    let mut lines = Vec::with_capacity(row.len());
    for &k in row {
        let Some(foot) = placement.axis_point(placed[k]) else { return 0 };
        let across = frame.flat(placed[k] - foot);
        let phi = across[1].atan2(across[0]) - reference;
        let phi = phi - std::f64::consts::TAU * (phi / std::f64::consts::TAU).round();
        let traced = onto_offset_surface(placed[k], foot, offset, obstacles).map(|p| (p - foot).length());
        lines.push((k, foot, phi, traced));
    }
    let hits: Vec<[f64; 2]> =
        lines.iter().filter_map(|&(_, _, phi, r)| r.map(|r| [r * phi.cos(), r * phi.sin()])).collect();
    let Some((lo, hi)) = lines
        .iter()
        .filter(|l| l.3.is_some())
        .map(|l| l.2)
        .fold(None, |s: Option<(f64, f64)>, p| Some(s.map_or((p, p), |(a, b)| (a.min(p), b.max(p)))))
    else {
        return 0;
    };
    let mut points = hits;
    points.push([0.0, 0.0]);
    let hull = convex_hull(points);
    let mut moved = 0;
    for (k, foot, phi, traced) in lines {
        // A hull of fewer than three points (one traced line, or all on one line through the axis) has no
        // edge a line leaves it by: a traced node then keeps its traced point.
        let r = reach_of(&hull, [phi.cos(), phi.sin()]).max(traced.unwrap_or(0.0));
        if phi < lo || phi > hi || r <= 0.0 {
            continue;
        }
        let phi = phi + reference;
        let p = foot + r * (phi.cos() * frame.e1 + phi.sin() * frame.e2);
        moved += usize::from(p != placed[k]);
        placed[k] = p;
    }
    moved
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain).
fn convex_hull(mut points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * points.len());
    for pass in [points.clone(), points.into_iter().rev().collect()] {
        let start = hull.len();
        for p in pass {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// How far from the origin the ray along the unit `u` leaves the convex polygon `hull` (which holds the
/// origin): the largest `t` where `t u` is on one of its edges (0 when none is met).
fn reach_of(hull: &[[f64; 2]], u: [f64; 2]) -> f64 {
    let mut reach: f64 = 0.0;
    for (i, &a) in hull.iter().enumerate() {
        let b = hull[(i + 1) % hull.len()];
        let e = [b[0] - a[0], b[1] - a[1]];
        // t u = a + s e: solve by Cramer's rule.
        let det = u[0] * (-e[1]) - u[1] * (-e[0]);
        if det.abs() < 1e-300 {
            continue;
        }
        let t = (a[0] * (-e[1]) - a[1] * (-e[0])) / det;
        let s = (u[0] * a[1] - u[1] * a[0]) / det;
        if (-1e-12..=1.0 + 1e-12).contains(&s) && t > reach {
            reach = t;
        }
    }
    reach
}
