//! The planar reference of the cantilever test: the inextensible heavy elastica, solved by shooting with the
//! shared [`rk4`](super::rk4) integrator. It is independent of the plate model; the procedure compares the
//! strip's chord angle with it and starts the plate's Newton solve from its shape.

use super::rk4::rk4;

/// The inextensible heavy elastica with `q = w L³ / K`, in units of the overhang `L`: `θ'' = −q (1 − σ) cos θ`
/// on `σ ∈ [0, 1]`, `θ(0) = 0`, `θ'(1) = 0` (θ measured downwards), solved by shooting on `θ'(0)` (RK4,
/// [`Elastica::STEPS`] steps, bisection). Positions `(x, −z)` along the arc are kept at every step.
#[derive(Debug, Clone)]
pub struct Elastica {
    /// `(x, drop)` at `σ = i / STEPS`, `i = 0..=STEPS`.
    pub profile: Vec<(f64, f64)>,
}

impl Elastica {
    /// RK4 steps over the strip.
    pub const STEPS: usize = 2000;

    /// Solves the elastica for `q`.
    pub fn new(q: f64) -> Self {
        // θ'(0) ∈ [0, q] brackets θ'(1) = 0.
        let (mut lo, mut hi) = (0.0, q.max(1e-9));
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if Self::shoot(q, mid, false).0 > 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Self { profile: Self::shoot(q, 0.5 * (lo + hi), true).1 }
    }

    /// Integrates with θ'(0) = a on the state `(θ, θ', x, drop)`; returns θ'(1) and, if `keep`, the profile.
    fn shoot(q: f64, a: f64, keep: bool) -> (f64, Vec<(f64, f64)>) {
        let hs = 1.0 / Self::STEPS as f64;
        let rhs = |s: f64, y: &[f64; 4]| -> [f64; 4] {
            let (th, om) = (y[0], y[1]);
            [om, -q * (1.0 - s) * th.cos(), th.cos(), th.sin()]
        };
        let mut profile = Vec::with_capacity(if keep { Self::STEPS + 1 } else { 0 });
        if keep {
            profile.push((0.0, 0.0));
        }
        let end = rk4([0.0, a, 0.0, 0.0], hs, Self::STEPS, rhs, |y| {
            if keep {
                profile.push((y[2], y[3]));
            }
        });
        (end[1], profile)
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
