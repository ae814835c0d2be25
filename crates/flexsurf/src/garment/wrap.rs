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
    // Each node's foot on the axis and its angle about it, once.
    let mut about = Vec::with_capacity(placed.len());
    for q in placed.iter() {
        let Some(foot) = placement.axis_point(*q) else { return 0 };
        let across = [(*q - foot).dot(frame.e1), (*q - foot).dot(frame.e2)];
        about.push((foot, across[1].atan2(across[0])));
    }
    let mut moved = 0;
    for row in rows_around(&about, grid) {
        moved += wrap_row(placed, &row, &about, &frame, offset, obstacles);
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
}

/// An angle turned into `[−π, π]`.
fn turned(a: f64) -> f64 {
    a - std::f64::consts::TAU * (a / std::f64::consts::TAU).round()
}

/// The grid's lines of nodes that run around the axis (of its two directions, the one whose steps turn most
/// about it, from each node's angle in `about`), each in order.
fn rows_around(about: &[(Vec3, f64)], grid: &Grid) -> Vec<Vec<usize>> {
    let turn = |a: usize, b: usize| turned(about[b].1 - about[a].1).abs();
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
    about: &[(Vec3, f64)],
    frame: &Frame,
    offset: f64,
    obstacles: &[Obstacle],
) -> usize {
    // Each node's angle from the row's middle node's, and its traced point's distance from the axis.
    let reference = about[row[row.len() / 2]].1;
    let lines: Vec<(usize, f64, Option<f64>)> = row
        .iter()
        .map(|&k| {
            let foot = about[k].0;
            let traced = onto_offset_surface(placed[k], foot, offset, obstacles).map(|p| (p - foot).length());
            (k, turned(about[k].1 - reference), traced)
        })
        .collect();
    // The hull of the traced points and the axis (the origin), and the angles the traced lines span.
    let mut points = vec![[0.0, 0.0]];
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &(_, phi, traced) in &lines {
        if let Some(r) = traced {
            points.push([r * phi.cos(), r * phi.sin()]);
            (lo, hi) = (lo.min(phi), hi.max(phi));
        }
    }
    let hull = convex_hull(points);
    let mut moved = 0;
    for (k, phi, traced) in lines {
        // A hull of fewer than three points (one traced line, or all on one line through the axis) has no
        // edge a line leaves it by: a traced node then keeps its traced point.
        let r = reach_of(&hull, [phi.cos(), phi.sin()]).max(traced.unwrap_or(0.0));
        if phi < lo || phi > hi || r <= 0.0 {
            continue;
        }
        let phi = phi + reference;
        let p = about[k].0 + r * (phi.cos() * frame.e1 + phi.sin() * frame.e2);
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
