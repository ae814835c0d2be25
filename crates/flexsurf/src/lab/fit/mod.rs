//! `flexsurf fit`: the material constants that explain measured targets (Peirce bending lengths from the virtual
//! cantilever, KES-F characteristic values, the Cusick drape coefficient, a scanned drape's shape), with exact
//! gradients by the adjoint of the static solve
//! ([`adjoint`]), a bounded Levenberg–Marquardt fit in the logarithms of the constants ([`lm`]), the constants'
//! standard errors from the Jacobian, and which of them the targets do not determine.

pub mod adjoint;
pub mod calib;
pub mod input;
mod lm;
pub mod targets;

pub use calib::Constant;
pub use targets::{evaluate, Instrument, KesValue, Quantity, Target, Warm};

use super::LabError;
use crate::material::{Calibration, Fabric};
use serde::Serialize;

/// A constant the fit may change, within bounds (SI, `0 < lower ≤ upper`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Free {
    /// The constant.
    pub constant: Constant,
    /// Least value.
    pub lower: f64,
    /// Greatest value.
    pub upper: f64,
}

/// A fit: the starting material, the free constants and the targets.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitProblem {
    /// The material the fit starts from (its other constants stay).
    pub fabric: Fabric,
    /// The calibration (only `kes`).
    pub calibration: Calibration,
    /// The free constants.
    pub free: Vec<Free>,
    /// What to explain.
    pub targets: Vec<Target>,
    /// The virtual cantilever's grids.
    pub instrument: Instrument,
    /// Levenberg–Marquardt iterations at most.
    pub max_iterations: usize,
    /// The scanned drape of a [`Quantity::Shape`] target (m, in the drape meter's frame; empty without one).
    #[serde(skip)]
    pub scan: Vec<crate::math::Vec3>,
    /// A measured Cusick node count, checked after the fit against the drape of the fitted constants (not a
    /// least-squares target: an integer has no derivative; see [`NodeCheck`]).
    pub cusick_nodes: Option<usize>,
}

/// The Cusick node count after a fit: the measured count against the fitted constants' drape. A count is an
/// integer, piecewise constant in the constants with jumps where a fold appears, so it has no gradient for
/// Levenberg–Marquardt and no Gaussian uncertainty; it is reported beside the fit (a disagreement says the
/// drape's fold pattern is not explained, whatever the DC's residual) rather than fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct NodeCheck {
    /// The measured node count.
    pub measured: usize,
    /// The fitted constants' drape's node count.
    pub model: usize,
}

/// A standard error above this (in the constant's logarithm: the data fix it to no better than a factor of
/// e^1.0 ≈ 2.7) marks the constant as not identifiable from the targets.
pub const UNIDENTIFIABLE_LOG_ERROR: f64 = 1.0;
/// Singular values of the scaled Jacobian below this times the largest count as zero.
pub const RANK_TOLERANCE: f64 = 1e-8;

/// One fitted constant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedConstant {
    /// Its key.
    pub name: &'static str,
    /// The starting value (SI).
    pub start: f64,
    /// The fitted value (SI).
    pub value: f64,
    /// Its standard error (SI; infinite when not identifiable in a degenerate direction), `value · σ(ln value)`.
    pub standard_error: f64,
    /// The standard error of its logarithm (the relative standard error).
    pub log_standard_error: f64,
    /// The targets determine it: no degenerate direction and a relative standard error below
    /// [`UNIDENTIFIABLE_LOG_ERROR`].
    pub identifiable: bool,
    /// It ended on a bound.
    pub at_bound: bool,
}

/// A target after the fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Residual {
    /// What it measures.
    pub target: String,
    /// The measured value (SI).
    pub measured: f64,
    /// The model's value with the fitted constants (SI).
    pub model: f64,
    /// The measurement's uncertainty (SI).
    pub sigma: f64,
    /// `(model − measured) / sigma`.
    pub normalised: f64,
}

/// What [`fit`] found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    /// The free constants.
    pub constants: Vec<FittedConstant>,
    /// The targets.
    pub residuals: Vec<Residual>,
    /// `Σ normalised²`.
    pub chi_squared: f64,
    /// Targets minus free constants.
    pub degrees_of_freedom: i64,
    /// Singular values of the Jacobian of the normalised residuals in the constants' logarithms.
    pub singular_values: Vec<f64>,
    /// The constants the targets do not determine.
    pub not_identifiable: Vec<&'static str>,
    /// The combinations the targets do not determine at all: each a unit direction in the constants'
    /// logarithms (`(key, weight)`), along which the targets do not change to first order (e.g. bending, shear
    /// and weight scaled together leave bending lengths and drape unchanged).
    pub null_directions: Vec<Vec<(&'static str, f64)>>,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// Model evaluations (each with its gradients).
    pub evaluations: usize,
    /// The step tolerance was met.
    pub converged: bool,
    /// Wall time (s).
    pub seconds: f64,
    /// The fitted material.
    pub fabric: Fabric,
    /// The Cusick node count check, when the fit file gives a count.
    pub cusick_nodes: Option<NodeCheck>,
}

/// Checks the problem: free constants distinct with `0 < lower ≤ upper`, targets with finite values and positive
/// uncertainties.
pub fn check(p: &FitProblem) -> Result<(), LabError> {
    let bad = |m: String| Err(LabError::Input(format!("fit: {m}")));
    if p.free.is_empty() {
        return bad("no constant is free".into());
    }
    if p.targets.is_empty() {
        return bad("no target".into());
    }
    for (i, f) in p.free.iter().enumerate() {
        let key = f.constant.key();
        if p.free[..i].iter().any(|g| g.constant == f.constant) {
            return bad(format!("`{key}` is free twice"));
        }
        if !(f.lower.is_finite() && f.upper.is_finite() && f.lower > 0.0 && f.lower <= f.upper) {
            return bad(format!("`{key}`: bounds {} to {} must be finite with 0 < lower ≤ upper", f.lower, f.upper));
        }
        calib::jacobian(&p.fabric, f.constant, p.calibration)?;
    }
    let shapes = p.targets.iter().filter(|t| t.quantity == Quantity::Shape).count();
    if shapes > 1 || (shapes == 1 && p.scan.is_empty()) {
        return bad("a shape target needs the scan's points, and a fit takes one shape".into());
    }
    for t in &p.targets {
        if !(t.value.is_finite() && t.sigma.is_finite() && t.sigma > 0.0) {
            return bad(format!("target `{}`: its value must be finite and its sigma positive", t.quantity.name()));
        }
    }
    Ok(())
}

/// `f` with the free constants at `exp(θ)`.
fn with_theta(f: &Fabric, free: &[Free], theta: &[f64]) -> Fabric {
    let mut f = *f;
    for (c, t) in free.iter().zip(theta) {
        c.constant.set(&mut f, t.exp());
    }
    f
}

/// Fits the free constants of `p` to its targets.
pub fn fit(p: &FitProblem) -> Result<FitReport, LabError> {
    check(p)?;
    let t0 = std::time::Instant::now();
    let consts: Vec<Constant> = p.free.iter().map(|f| f.constant).collect();
    let start: Vec<f64> = p.free.iter().map(|f| f.constant.get(&p.fabric).unwrap_or(f64::NAN).ln()).collect();
    let lower: Vec<f64> = p.free.iter().map(|f| f.lower.ln()).collect();
    let upper: Vec<f64> = p.free.iter().map(|f| f.upper.ln()).collect();
    let mut warm = Warm::default();
    let residuals = |theta: &[f64]| -> Result<lm::Evaluation, LabError> {
        let f = with_theta(&p.fabric, &p.free, theta);
        let (values, rows) = evaluate(&f, p.calibration, &consts, &p.targets, &p.instrument, &mut warm)?;
        let scale = |row: &[f64], sigma: f64| -> Vec<f64> {
            row.iter().zip(theta).map(|(d, th)| d * th.exp() / sigma).collect()
        };
        let (mut r, mut j) = (Vec::new(), Vec::new());
        for ((v, row), t) in values.iter().zip(&rows).zip(&p.targets) {
            if t.quantity != Quantity::Shape {
                r.push((v - t.value) / t.sigma);
                j.push(scale(row, t.sigma));
            }
        }
        if let Some(t) = p.targets.iter().find(|t| t.quantity == Quantity::Shape) {
            let (sr, rows) = targets::shape_residuals(&f, p.calibration, &consts, &p.instrument, &mut warm, &p.scan)?;
            r.extend(sr.iter().map(|v| v / t.sigma));
            j.extend(rows.iter().map(|row| scale(row, t.sigma)));
        }
        Ok((r, j))
    };
    let opts = lm::Options { max_iterations: p.max_iterations, step_tolerance: 1e-10 };
    let out = lm::minimise(&start, (&lower, &upper), opts, residuals)?;
    let mut r = report(p, &out, t0.elapsed().as_secs_f64());
    if let Some(measured) = p.cusick_nodes {
        let model = targets::drape_nodes(&r.fabric, p.calibration, &p.instrument)?;
        r.cusick_nodes = Some(NodeCheck { measured, model });
        r.seconds = t0.elapsed().as_secs_f64();
    }
    Ok(r)
}

fn report(p: &FitProblem, out: &lm::Outcome, seconds: f64) -> FitReport {
    let n = p.free.len();
    let stats = lm::statistics(&out.at.1, n, RANK_TOLERANCE);
    let constants: Vec<FittedConstant> = p
        .free
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let value = out.theta[k].exp();
            let se = stats.standard_errors[k];
            FittedConstant {
                name: f.constant.key(),
                start: f.constant.get(&p.fabric).unwrap_or(f64::NAN),
                value,
                standard_error: value * se,
                log_standard_error: se,
                identifiable: !stats.degenerate[k] && se < UNIDENTIFIABLE_LOG_ERROR,
                at_bound: value <= f.lower * (1.0 + 1e-12) || value >= f.upper * (1.0 - 1e-12),
            }
        })
        .collect();
    // The scalar targets' residuals first, in order, then the shape's components.
    let mut scalar = out.at.0.iter();
    let residuals: Vec<Residual> = p
        .targets
        .iter()
        .map(|t| {
            let r = if t.quantity == Quantity::Shape {
                let m = p.targets.iter().filter(|t| t.quantity != Quantity::Shape).count();
                out.at.0[m..].iter().map(|r| r * r).sum::<f64>().sqrt()
            } else {
                scalar.next().copied().unwrap_or(f64::NAN)
            };
            Residual {
                target: t.quantity.name(),
                measured: t.value,
                model: t.value + r * t.sigma,
                sigma: t.sigma,
                normalised: r,
            }
        })
        .collect();
    let null_directions = stats
        .null_directions
        .iter()
        .map(|d| p.free.iter().zip(d).map(|(f, w)| (f.constant.key(), *w)).collect())
        .collect();
    FitReport {
        null_directions,
        not_identifiable: constants.iter().filter(|c| !c.identifiable).map(|c| c.name).collect(),
        constants,
        chi_squared: out.at.0.iter().map(|r| r * r).sum(),
        degrees_of_freedom: p.targets.len() as i64 - n as i64,
        residuals,
        singular_values: stats.singular_values,
        iterations: out.iterations,
        evaluations: out.evaluations,
        converged: out.converged,
        seconds,
        fabric: with_theta(&p.fabric, &p.free, &out.theta),
        cusick_nodes: None,
    }
}
