//! The planar reference of the cantilever test: the inextensible heavy elastica, solved by shooting with the
//! shared [`rk4`](super::rk4) integrator. It is independent of the plate model; the procedure compares the
//! strip's chord angle with it and starts the plate's Newton solve from its shape.

use super::rk4::rk4;
use std::f64::consts::FRAC_PI_2;

/// The smallest angle from the vertical at the tip the shooting tries (rad): a strip of `q` up to 1e6 hangs at a
/// larger one (about `e^{−2√q/3}`).
const MIN_TIP: f64 = 1e-300;

/// The largest `q = w L³ / K` of the cantilever test: an overhang of 10 times `(K/w)^{1/3}`, where the strip hangs
/// at 87.3°, within 2.7° of the vertical. Beyond it the clamp's boundary layer (`1/√q` of the overhang) spans less
/// than two of the coarse strip's 64 cells, and the plate's static solve failed at some overhangs (22 times on
/// the silk-like polyester's warp) between others where it converged; up to it the plate converged within 0.02° of
/// the elastica along warp and weft on every shipped fabric. The elastica's own shooting holds to `q` of 1e6.
pub const MAX_Q: f64 = 1e3;

/// The inextensible heavy elastica with `q = w L³ / K`, in units of the overhang `L`: `θ'' = −q (1 − σ) cos θ`
/// on `σ ∈ [0, 1]`, `θ(0) = 0`, `θ'(1) = 0` (θ measured downwards), solved by shooting from the tip on its angle
/// (RK4, [`Elastica::STEPS`] steps, bisection: [`Elastica::new`]). Positions `(x, −z)` along the arc are kept at
/// every step.
#[derive(Debug, Clone)]
pub struct Elastica {
    /// `(x, drop)` at `σ = i / STEPS`, `i = 0..=STEPS`.
    pub profile: Vec<(f64, f64)>,
}

impl Elastica {
    /// RK4 steps over the strip.
    pub const STEPS: usize = 2000;

    /// Solves the elastica for `q`, shooting from the tip: with `ε = π/2 − θ` (the strip's angle from the
    /// vertical) and `t = 1 − σ`, `ε_tt = q t sin ε` with `ε(0) = ε_tip`, `ε_t(0) = 0`, and `ε(1) = π/2` at the
    /// clamp. Below π/2, ε grows along `t`, and the more the larger `ε_tip` (the right-hand side grows with ε), so
    /// the shots whose ε reaches π/2 before the clamp are those of too large an `ε_tip`, and bisection on
    /// `ln ε_tip` finds the hanging strip for any `q`, however closely it hangs to the vertical (`ε_tip` falls
    /// like `e^{−2√q/3}`). Shooting from the clamp on θ'(0) by the sign of θ'(1) stopped on strips that loop once
    /// `q` exceeds about 100 (19.6° at `q` = 200 instead of 83.6°), and the plate's Newton solve, started from
    /// that shape, failed.
    pub fn new(q: f64) -> Self {
        let (mut lo, mut hi) = (MIN_TIP.ln(), FRAC_PI_2.ln());
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if Self::shoot(q, mid.exp(), false).0 > FRAC_PI_2 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Self { profile: Self::shoot(q, (0.5 * (lo + hi)).exp(), true).1 }
    }

    /// Integrates from the tip with `ε(tip) = tip` on the state `(ε, ε_t, x, drop)` (x and drop from the tip);
    /// returns the largest ε on the way (ε at the clamp unless the shot passed π/2 before it: a strip that
    /// loops past the horizontal and back) and, if `keep`, the profile from the clamp.
    fn shoot(q: f64, tip: f64, keep: bool) -> (f64, Vec<(f64, f64)>) {
        let ht = 1.0 / Self::STEPS as f64;
        let rhs = |t: f64, y: &[f64; 4]| -> [f64; 4] {
            let (e, et) = (y[0], y[1]);
            [et, q * t * e.sin(), -e.sin(), -e.cos()]
        };
        let mut back = Vec::with_capacity(if keep { Self::STEPS + 1 } else { 0 });
        if keep {
            back.push((0.0, 0.0));
        }
        let mut top = tip;
        let end = rk4([tip, 0.0, 0.0, 0.0], ht, Self::STEPS, rhs, |y| {
            top = top.max(y[0]);
            if keep {
                back.push((y[2], y[3]));
            }
        });
        // From the clamp: σ = 1 − t, positions relative to the clamp's.
        let profile = back.iter().rev().map(|&(x, d)| (x - end[2], d - end[3])).collect();
        (top, profile)
    }

    /// Chord angle below horizontal (degrees).
    pub fn chord_deg(&self) -> f64 {
        let (x, drop) = self.profile[Self::STEPS];
        drop.atan2(x).to_degrees().abs()
    }

    /// `(x, drop)` at arc length `σ ∈ [0, 1]` (linear between steps).
    pub fn at(&self, sigma: f64) -> (f64, f64) {
        let t = sigma.clamp(0.0, 1.0) * Self::STEPS as f64;
        let i = (t.floor() as usize).min(Self::STEPS - 1);
        let f = t - i as f64;
        let (a, b) = (self.profile[i], self.profile[i + 1]);
        (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1))
    }
}

/// Chord angle (degrees) of the inextensible heavy elastica with `q = w L³ / K` ([`Elastica`]).
pub fn elastica_chord_deg(q: f64) -> f64 {
    Elastica::new(q).chord_deg()
}
