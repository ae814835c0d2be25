//! Whether a body bounds a solid. At points along every side of every patch the surface is continued a short
//! step beyond the side, along the patch's own outward tangent: where the body is closed that point lies on the
//! surface of the patch's part again, to second order in the step (another patch continues it, the same patch closes on
//! itself, or the patch folds over onto itself as the mannequin's "pillow" ends do: docs/mannequin.md). A side
//! collapsed to a point (a pole) and a side inside another part of the body (a leg's open top rim inside the
//! torso) need no continuation. A body with any other free side does not bound a solid: beyond that edge its
//! signed distance takes the edge's normal, and cloth coming from behind the surface there would be pushed
//! sideways or held "inside".

use super::body::NurbsBody;
use crate::math::Vec3;

/// Points of each side that are continued (fractions of its parameter range).
const SAMPLES: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];
/// The tolerance of "on the surface", as a fraction of the body's bounding-box diagonal.
const TOLERANCE: f64 = 1e-3;
/// The step beyond a side, in tolerances: an open side leaves the continued point this many tolerances off the
/// surface, a closed one within a tolerance where the step is small against the surface's radii of curvature
/// (`step² / 2r`: at most 0.5 of the upper mannequin's 1.6 mm tolerance for its 3.2 mm step over the tight fold
/// of an arm's closed wrist end, where a step of four tolerances left up to 2.2 mm).
const STEP: f64 = 2.0;

/// A side's tangent this much shorter than the derivative across it vanishes (the roundoff of a zero).
const DEGENERATE: f64 = 1e-9;

/// The sides of a patch, in the order [`open_side`] reports them.
pub const SIDES: [&str; 4] = ["u = min", "u = max", "v = min", "v = max"];

/// The first side (patch index, side index in [`SIDES`]) that is not closed; `None` where the body bounds a solid.
pub fn open_side(body: &NurbsBody) -> Option<(usize, usize)> {
    let tol = TOLERANCE * (body.bbox().max - body.bbox().min).length();
    (0..body.patches().len())
        .flat_map(|k| (0..4).map(move |side| (k, side)))
        .find(|&(k, side)| !closed(body, k, side, tol))
}

/// Whether side `side` of patch `k` is closed (see the module's documentation).
fn closed(body: &NurbsBody, k: usize, side: usize, tol: f64) -> bool {
    let patch = &body.patches()[k];
    let ([u0, u1], [v0, v1]) = patch.domain();
    let at = |f: f64| {
        let along = |a: f64, b: f64| a + (b - a) * f;
        let (u, v, sign, across_u) = match side {
            0 => (u0, along(v0, v1), -1.0, true),
            1 => (u1, along(v0, v1), 1.0, true),
            2 => (along(u0, u1), v0, -1.0, false),
            _ => (along(u0, u1), v1, 1.0, false),
        };
        let d = patch.derivatives(u, v);
        let (across, along_side) = if across_u { (d.du, d.dv) } else { (d.dv, d.du) };
        if along_side.length() <= DEGENERATE * across.length() {
            // The side's own tangent vanishes (a fold's end point, where the side turns back): no direction
            // across it.
            return (d.point, Vec3::ZERO);
        }
        // The outward tangent: across the side, made perpendicular to it.
        let t = along_side.normalize_or_zero();
        (d.point, (across - t * across.dot(t)).normalize_or_zero() * sign)
    };
    let first = at(0.0).0;
    if (0..=8).all(|i| (at(f64::from(i) / 8.0).0 - first).length() <= tol) {
        return true; // a pole
    }
    SAMPLES.iter().all(|&f| {
        let (q, out) = at(f);
        // A tangent that vanishes there (a fold's end point) says nothing: the neighbouring samples decide.
        out == Vec3::ZERO || on_own_part(body, k, q + out * (STEP * tol), tol) || inside_another_part(body, k, q, tol)
    })
}

/// Whether `q` is within `tol` of the surface of the part of patch `patch` (each part is closed by itself: the
/// body is their union, and where parts overlap the union's surface is not the part's).
fn on_own_part(body: &NurbsBody, patch: usize, q: Vec3, tol: f64) -> bool {
    let own = body.part_of(patch).unwrap_or(0);
    body.closest_in_part(own, q, None).is_some_and(|c| c.distance.abs() <= tol)
}

/// Whether `q` (on patch `patch`) is deeper than `tol` inside a part of `body` other than the patch's own.
fn inside_another_part(body: &NurbsBody, patch: usize, q: Vec3, tol: f64) -> bool {
    let own = body.part_of(patch);
    (0..body.parts().len())
        .filter(|&p| Some(p) != own)
        .any(|p| body.closest_in_part(p, q, None).is_some_and(|c| c.distance < -tol))
}
