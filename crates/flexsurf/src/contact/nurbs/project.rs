//! Closest-point projection on one patch: clamped (projected) Newton with a backtracking line search from the
//! local minima of a cell's sample grid, pruned by the cells' boxes, and the [`Hint`] (warm start) and
//! [`Projection`] (answer) of a body query in [`super::body`].

use super::patch::{Cell, NurbsPatch, SAMPLES_PER_SPAN};
use crate::math::Vec3;
use crate::surface::mesh::Aabb;

/// Newton iterations per patch projection.
const NEWTON_ITERATIONS: usize = 40;
/// Step halvings in the backtracking line search.
const HALVINGS: usize = 30;
/// Newton stops when a step moves the surface point less than this (m).
const STEP_TOLERANCE: f64 = 1e-13;

/// Warm start of a projection: the patch and parameters of the previous closest point.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Hint {
    /// Patch index in the body.
    pub patch: usize,
    /// Parameter `u`.
    pub u: f64,
    /// Parameter `v`.
    pub v: f64,
}

/// The closest point of a body to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Closest surface point.
    pub point: Vec3,
    /// Outward unit normal of the surface at `point`.
    pub normal: Vec3,
    /// Signed distance (positive outside).
    pub distance: f64,
    /// Patch index in the body.
    pub patch: usize,
    /// Parameter `u` of `point` on the patch.
    pub u: f64,
    /// Parameter `v` of `point` on the patch.
    pub v: f64,
}

impl Projection {
    /// The warm start for the next query of the same node.
    #[inline]
    pub fn hint(&self) -> Hint {
        Hint { patch: self.patch, u: self.u, v: self.v }
    }
}

impl NurbsPatch {
    /// Nearest sample of a cell: `(u, v, squared distance)`.
    pub(super) fn nearest_sample(cell: &Cell, p: Vec3) -> (f64, f64, f64) {
        let mut best = (cell.u[0], cell.v[0], f64::INFINITY);
        for &(u, v, s) in &cell.samples {
            let d2 = (s - p).length_squared();
            if d2 < best.2 {
                best = (u, v, d2);
            }
        }
        best
    }

    /// Runs Newton from every sample of `cell` that is a local minimum of the distance among its grid
    /// neighbours and may lead to a point closer than `*best_d2` (its distance less the cell's cover radius);
    /// `explored` cells (already searched from a hint) only from samples that beat `*best_d2` outright. Each
    /// result goes to `found`, which returns the new best squared distance.
    pub(super) fn search_cell(
        &self,
        cell: &Cell,
        p: Vec3,
        best_d2: f64,
        explored: bool,
        found: &mut dyn FnMut((f64, f64, Vec3, f64)) -> f64,
    ) {
        const N: usize = SAMPLES_PER_SPAN + 1;
        let mut d2 = [0.0; N * N];
        for (d, s) in d2.iter_mut().zip(&cell.samples) {
            *d = (s.2 - p).length_squared();
        }
        let mut best_d2 = best_d2;
        for i in 0..N {
            for j in 0..N {
                let x = d2[i * N + j];
                let local = (i == 0 || x <= d2[(i - 1) * N + j])
                    && (i + 1 == N || x <= d2[(i + 1) * N + j])
                    && (j == 0 || x <= d2[i * N + j - 1])
                    && (j + 1 == N || x <= d2[i * N + j + 1]);
                if !local {
                    continue;
                }
                let hopeless = if explored { x >= best_d2 } else { x.sqrt() - cell.cover >= best_d2.sqrt() };
                if hopeless {
                    continue;
                }
                let (u, v, _) = cell.samples[i * N + j];
                best_d2 = found(self.project_from(p, u, v));
            }
        }
    }

    /// Closest point of the patch to `p` by clamped (projected) Newton on `½|S(u, v) − p|²` from `(u, v)`, with
    /// the exact Hessian (second derivatives) when positive definite, Gauss–Newton otherwise, an active set at
    /// the domain's edges and a backtracking line search. Returns `(u, v, S(u, v), squared distance)`; the
    /// minimum is local: start near the answer (or use [`NurbsPatch::closest`]).
    pub fn project_from(&self, p: Vec3, u: f64, v: f64) -> (f64, f64, Vec3, f64) {
        let ([u0, u1], [v0, v1]) = self.domain();
        let mut u = if u.is_finite() { u.clamp(u0, u1) } else { u0 };
        let mut v = if v.is_finite() { v.clamp(v0, v1) } else { v0 };
        let mut d = self.derivatives(u, v);
        let mut r = d.point - p;
        let mut f = r.length_squared();
        for _ in 0..NEWTON_ITERATIONS {
            let gu = d.du.dot(r);
            let gv = d.dv.dot(r);
            let fix_u = (u <= u0 && gu > 0.0) || (u >= u1 && gu < 0.0);
            let fix_v = (v <= v0 && gv > 0.0) || (v >= v1 && gv < 0.0);
            let (guu, guv, gvv) = (d.du.length_squared(), d.du.dot(d.dv), d.dv.length_squared());
            let (huu, huv, hvv) = (guu + d.duu.dot(r), guv + d.duv.dot(r), gvv + d.dvv.dot(r));
            let (mut su, mut sv) = match (fix_u, fix_v) {
                (true, true) => break,
                (false, true) => (newton_1d(gu, huu, guu), 0.0),
                (true, false) => (0.0, newton_1d(gv, hvv, gvv)),
                (false, false) => newton_2d(gu, gv, [huu, huv, hvv], [guu, guv, gvv]),
            };
            if !(su.is_finite() && sv.is_finite()) || (su == 0.0 && sv == 0.0) {
                break;
            }
            // Converged when the (clamped) step would move the point less than the tolerance.
            let (cu, cv) = ((u + su).clamp(u0, u1) - u, (v + sv).clamp(v0, v1) - v);
            if (d.du * cu + d.dv * cv).length() <= STEP_TOLERANCE {
                break;
            }
            let mut moved = None;
            for _ in 0..HALVINGS {
                let un = (u + su).clamp(u0, u1);
                let vn = (v + sv).clamp(v0, v1);
                let dn = self.derivatives(un, vn);
                let rn = dn.point - p;
                let fnew = rn.length_squared();
                // Accept descent, and rounding-level increases once converged (f is flat to second order there).
                if fnew <= f + 8.0 * f64::EPSILON * f {
                    moved = Some((dn.point - d.point).length());
                    (u, v, d, r, f) = (un, vn, dn, rn, fnew);
                    break;
                }
                su *= 0.5;
                sv *= 0.5;
            }
            match moved {
                Some(step) if step > STEP_TOLERANCE => {}
                _ => break,
            }
        }
        (u, v, d.point, f)
    }

    /// Closest point of the patch to `p`: Newton started from the nearest sample of every knot span that may
    /// hold a closer point than found so far: `(u, v, S(u, v), squared distance)`.
    pub fn closest(&self, p: Vec3) -> (f64, f64, Vec3, f64) {
        let ([u0, _], [v0, _]) = self.domain();
        let mut best = (u0, v0, self.point(u0, v0), f64::INFINITY);
        best.3 = (best.2 - p).length_squared();
        for cell in &self.cells {
            if box_distance2(&cell.bbox, p) > best.3 {
                continue;
            }
            self.search_cell(cell, p, best.3, false, &mut |r| {
                if r.3 < best.3 {
                    best = r;
                }
                best.3
            });
        }
        best
    }
}

#[inline]
fn newton_1d(g: f64, h: f64, gn: f64) -> f64 {
    if h > 0.0 {
        -g / h
    } else if gn > 0.0 {
        -g / gn
    } else {
        0.0
    }
}

#[inline]
fn newton_2d(gu: f64, gv: f64, h: [f64; 3], gn: [f64; 3]) -> (f64, f64) {
    let solve = |m: [f64; 3]| {
        let det = m[0] * m[2] - m[1] * m[1];
        (m[0] > 0.0 && det > 1e-14 * m[0] * m[2])
            .then(|| ((-gu * m[2] + gv * m[1]) / det, (gu * m[1] - gv * m[0]) / det))
    };
    if let Some(s) = solve(h) {
        return s;
    }
    let reg = 1e-12 * (gn[0] + gn[2]);
    if let Some(s) = solve([gn[0] + reg, gn[1], gn[2] + reg]) {
        return s;
    }
    (newton_1d(gu, 0.0, gn[0]), newton_1d(gv, 0.0, gn[2]))
}

/// True when `(u, v)` lies in the cell's parameter rectangle.
#[inline]
pub(super) fn in_cell(c: &Cell, u: f64, v: f64) -> bool {
    c.u[0] <= u && u <= c.u[1] && c.v[0] <= v && v <= c.v[1]
}

/// Squared distance from `p` to a box (0 inside).
#[inline]
pub(super) fn box_distance2(b: &Aabb, p: Vec3) -> f64 {
    (p.clamp(b.min, b.max) - p).length_squared()
}
