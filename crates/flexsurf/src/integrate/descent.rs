//! What the static solver's trust region ([`super::statics`]) and the dynamic step's line search
//! ([`super::Stepper`]) share when they judge a step by the potential they minimise: the sufficient-decrease
//! constant, whether a predicted decrease is above the potential's round-off, and the step fraction that the
//! parabola through the potential along a rejected step asks for.

/// Sufficient decrease of the potential (Armijo): a step must lower it by this fraction of the decrease its
/// linear (or quadratic) model predicts.
pub(crate) const ARMIJO: f64 = 1e-4;

/// True when the predicted change `pred` of a potential whose value is `value` is a decrease that the
/// potential can resolve in floating point (more than 1e-14 of its magnitude); a step whose decrease it cannot
/// resolve is judged on the residual force instead.
pub(crate) fn resolvable(pred: f64, value: f64) -> bool {
    !(pred.is_nan() || pred >= 0.0 || -pred <= 1e-14 * value.abs().max(f64::MIN_POSITIVE))
}

/// The fraction of a rejected step at which the parabola through `φ(0) = phi0`, `φ'(0) = slope` (< 0) and
/// `φ(1) = phi1` is least, kept within [0.1, 0.5] (0.1 when `phi1` is not finite or the fit has no minimum).
pub(crate) fn backtrack(phi0: f64, slope: f64, phi1: f64) -> f64 {
    let fit = if phi1.is_finite() { -slope / (2.0 * (phi1 - phi0 - slope)) } else { 0.0 };
    if fit.is_finite() && fit > 0.0 {
        fit.clamp(0.1, 0.5)
    } else {
        0.1
    }
}

/// The relative tolerance of the linearised step's solve in a step Newton's method iterates (no contact at its
/// start): Newton's corrections follow, so two digits are enough (0.1 left a tumbling sheet's step
/// unconverged at the cap of 4 iterations, docs/performance.md).
pub(crate) const FIRST_FORCING: f64 = 0.01;

/// The largest forcing term: a Newton correction's linear solve always lowers its residual at least tenfold.
pub(crate) const FORCING_MAX: f64 = 0.1;

/// Eisenstat and Walker's forcing terms for inexact Newton (their second choice, `γ = 0.9`, `α = 2`): how
/// accurately each correction's linear system is solved follows how fast the Newton residual falls, so early
/// corrections are solved loosely and the last ones as tightly as the quadratic convergence needs. Where a
/// solve is iterative this saves its iterations; a direct solve is exact anyway.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Forcing {
    /// The Newton residual before the last iteration.
    previous: f64,
    /// The last forcing term (none yet).
    last: Option<f64>,
}

impl Forcing {
    /// Starts from the residual `initial` before the first iteration (the linearised step's).
    pub(crate) fn new(initial: f64) -> Self {
        Self { previous: initial, last: None }
    }

    /// The relative tolerance `η` of the linear solve of the correction from an iterate whose residual is
    /// `residual`, when Newton stops at `tolerance` (residuals in the same norm): `η = 0.9 (r_k/r_{k−1})²`,
    /// at least `0.9 η_{k−1}²` where that exceeds 0.1 (the residual's fall may have been lucky), at least
    /// `tolerance / (2 r_k)` (no more accuracy than the stop needs), at most [`FORCING_MAX`], and never below
    /// the iterative solvers' own [`super::linsolve::ITERATIVE_TOLERANCE`].
    pub(crate) fn next(&mut self, residual: f64, tolerance: f64) -> f64 {
        const GAMMA: f64 = 0.9;
        let ratio = residual / self.previous;
        let mut eta = if ratio.is_finite() { GAMMA * ratio * ratio } else { FORCING_MAX };
        if let Some(last) = self.last {
            let kept = GAMMA * last * last;
            if kept > 0.1 {
                eta = eta.max(kept);
            }
        }
        if residual > 0.0 {
            eta = eta.max(0.5 * tolerance / residual);
        }
        let eta = eta.clamp(super::linsolve::ITERATIVE_TOLERANCE, FORCING_MAX);
        self.previous = residual;
        self.last = Some(eta);
        eta
    }
}
