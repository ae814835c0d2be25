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
