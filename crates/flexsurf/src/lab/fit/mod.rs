//! `flexsurf fit`: the material constants that explain measured targets (Peirce bending lengths from the virtual
//! cantilever, KES-F characteristic values, the Cusick drape coefficient, a scanned drape's shape), with exact
//! gradients by the adjoint of the static solve
//! ([`adjoint`]), a bounded Levenberg–Marquardt fit in the logarithms of the constants ([`lm`]), the constants'
//! standard errors from the Jacobian, and which of them the targets do not determine.

pub mod adjoint;
pub mod align;
pub mod calib;
pub mod input;
pub mod lm;
pub mod targets;

pub use align::Align;
pub use calib::Constant;
pub use targets::{evaluate, Instrument, KesValue, Quantity, Target, Warm};

use super::LabError;
use crate::material::{Calibration, Fabric};
use crate::math::Vec3;
use align::{Placement, PARAMETERS};
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
    pub scan: Vec<Vec3>,
    /// How the scan is placed in the meter's frame (as given, or a rigid motion fitted; [`align`]).
    pub align: Align,
    /// A measured Cusick node count, checked after the fit against the drape of the fitted constants (not a
    /// least-squares target: an integer has no derivative; see [`NodeCheck`]).
    pub cusick_nodes: Option<usize>,
    /// The material file's warnings (constants outside the usual range of fabrics), for front ends to print; the
    /// report (`fit.json`, Python's `fit(...)["problem"]`) keeps them as the messages printed.
    #[serde(serialize_with = "as_messages")]
    pub warnings: Vec<crate::scene::SceneWarning>,
}

/// Warnings as the messages a front end prints.
fn as_messages<S: serde::Serializer>(w: &[crate::scene::SceneWarning], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(w.iter().map(ToString::to_string))
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
/// The fit ends when an accepted step lowers `½ χ²` by less than this with every target within its uncertainty
/// (`lm::Options::cost_tolerance`): the constants then move by about a twentieth of their standard errors a
/// step. A Cusick DC jumps by about 0.1 point where the drape changes equilibrium under a change of the shear,
/// which leaves the cost a floor of about 1e-3 that the step tolerance never reaches (docs/materials.md,
/// "Fitting").
pub const COST_TOLERANCE: f64 = 1e-3;

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
    /// Singular values of the Jacobian of the normalised residuals in the constants' logarithms (and the scan's
    /// placement parameters, [`align::NAMES`], when it is fitted).
    pub singular_values: Vec<f64>,
    /// The constants the targets do not determine.
    pub not_identifiable: Vec<&'static str>,
    /// The combinations the targets do not determine at all: each a unit direction in the constants'
    /// logarithms and the placement's parameters (`(key, weight)`), along which the targets do not change to first order (e.g. bending, shear
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
    /// The scan's fitted placement, when a shape target's scan is aligned ([`Align::Rigid`]).
    pub alignment: Option<Alignment>,
}

/// A scan's fitted placement in the drape meter's frame: `s ↦ matrix · s + offset` (scan frame to meter frame).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Alignment {
    /// The rotation (rows).
    pub matrix: [[f64; 3]; 3],
    /// The translation (m).
    pub offset: [f64; 3],
    /// The angle between the scan's z axis and the meter's axis (degrees).
    pub tilt_degrees: f64,
    /// Where the fit started: the scan as given, or its principal axis turned about the axis.
    pub seed: align::Seed,
    /// The fitted parameters ([`align::NAMES`]: turns in rad, shifts in m, from the seed).
    pub parameters: [f64; PARAMETERS],
    /// Their standard errors (infinite where the targets do not determine them, e.g. the turn of a drape
    /// without folds).
    pub standard_errors: [f64; PARAMETERS],
}

/// The most a target's value may be in units of its uncertainty: no measurement is known to a relative 1e-12, and
/// beyond it the normalised residual `(model − value)/sigma` keeps no digits of the model (a value of 1e300 with a
/// sigma of 0.1 reported its model as 0 and a χ² of infinity).
pub const MAX_PRECISION: f64 = 1e12;

/// What is wrong with a target's `sigma` for its `value` (`None` when it can be fitted): it must be positive and
/// at least the value's magnitude over [`MAX_PRECISION`].
pub fn sigma_problem(value: f64, sigma: f64) -> Option<String> {
    if !(sigma.is_finite() && sigma > 0.0) {
        return Some("must be a positive number".into());
    }
    (value.abs() > MAX_PRECISION * sigma).then(|| {
        let least = 1.0 / MAX_PRECISION;
        format!("{sigma:?} is below {least:e} of the value {value:?} (no measurement is that precise: a unit slip?)")
    })
}

/// Checks the problem: free constants distinct with `0 < lower ≤ upper` within the range a material file accepts
/// ([`Constant::bounds_problem`]), targets with finite values and positive uncertainties ([`sigma_problem`]).
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
        if let Some(problem) = f.constant.bounds_problem(f.lower, f.upper) {
            return bad(format!("`{key}`: bounds {} to {}: {problem}", f.lower, f.upper));
        }
        calib::jacobian(&p.fabric, f.constant, p.calibration)?;
    }
    let shapes = p.targets.iter().filter(|t| t.quantity == Quantity::Shape).count();
    if shapes > 1 || (shapes == 1 && p.scan.is_empty()) {
        return bad("a shape target needs the scan's points, and a fit takes one shape".into());
    }
    for t in &p.targets {
        if !t.value.is_finite() {
            return bad(format!("target `{}`: its value must be finite", t.quantity.name()));
        }
        if let Some(problem) = sigma_problem(t.value, t.sigma) {
            return bad(format!("target `{}`: its sigma {problem}", t.quantity.name()));
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

/// The placement of a shape target's scan to fit (`None`: the scan as given, nothing fitted), estimated against
/// the drape of the starting `fabric` (left in `warm` for the fit's first evaluation).
fn placement(p: &FitProblem, fabric: &Fabric, warm: &mut Warm) -> Result<Option<Placement>, LabError> {
    if p.align == Align::None || !p.targets.iter().any(|t| t.quantity == Quantity::Shape) {
        return Ok(None);
    }
    let drape = targets::drape_surface(fabric, p.calibration, &p.instrument, warm)?;
    Ok(Some(align::estimate(&p.scan, &drape)))
}

/// The normalised residuals of `p` and their Jacobian at `theta` (the free constants' logarithms, then the
/// placement's parameters when `placement` is given).
fn residuals_at(
    p: &FitProblem,
    placement: Option<&Placement>,
    theta: &[f64],
    warm: &mut Warm,
) -> Result<lm::Evaluation, LabError> {
    let n = p.free.len();
    let extra = if placement.is_some() { PARAMETERS } else { 0 };
    let f = with_theta(&p.fabric, &p.free, &theta[..n]);
    let consts: Vec<Constant> = p.free.iter().map(|f| f.constant).collect();
    let (values, rows) =
        evaluate(&f, p.calibration, &consts, &p.targets, &p.instrument, warm).map_err(|e| at(p, &f, e))?;
    let scale = |row: &[f64], sigma: f64| -> Vec<f64> {
        let mut r: Vec<f64> = row.iter().zip(theta).map(|(d, th)| d * th.exp() / sigma).collect();
        r.resize(n + extra, 0.0);
        r
    };
    let (mut r, mut j) = (Vec::new(), Vec::new());
    for ((v, row), t) in values.iter().zip(&rows).zip(&p.targets) {
        if t.quantity != Quantity::Shape {
            r.push((v - t.value) / t.sigma);
            j.push(scale(row, t.sigma));
        }
    }
    if let Some(t) = p.targets.iter().find(|t| t.quantity == Quantity::Shape) {
        let pose = &theta[n..];
        let placed = placement.map(|pl| pl.placed(pose, &p.scan));
        let scan = placed.as_deref().unwrap_or(&p.scan);
        let sr = targets::shape_residuals(&f, p.calibration, &consts, &p.instrument, warm, scan)
            .map_err(|e| at(p, &f, e))?;
        r.extend(sr.values.iter().map(|v| v / t.sigma));
        for (row, &(i, g)) in sr.rows.iter().zip(&sr.scan_terms) {
            let mut row = scale(row, t.sigma);
            if let Some(pl) = placement {
                for (k, ds) in pl.derivatives(pose, p.scan[i]).iter().enumerate() {
                    row[n + k] = g.dot(*ds) / t.sigma;
                }
            }
            j.push(row);
        }
    }
    Ok((r, j))
}

/// `cause` of a failed evaluation of the fabric `f`, with the values of `p`'s free constants there.
fn at(p: &FitProblem, f: &Fabric, cause: LabError) -> LabError {
    let value = |c: Constant| {
        c.get(f).map_or_else(
            || "Huber's rule".into(),
            |v| crate::ranges::with_unit(crate::ranges::short(v), c.range().unit),
        )
    };
    let at: Vec<String> = p.free.iter().map(|g| format!("{} = {}", g.constant.key(), value(g.constant))).collect();
    LabError::FitAt { at: at.join(", "), cause: Box::new(cause) }
}

/// Fits the free constants of `p` to its targets (and the scan's placement, [`Align::Rigid`]).
pub fn fit(p: &FitProblem) -> Result<FitReport, LabError> {
    check(p)?;
    let t0 = std::time::Instant::now();
    let mut start: Vec<f64> = p.free.iter().map(|f| f.constant.get(&p.fabric).unwrap_or(f64::NAN).ln()).collect();
    // The estimate's drape is the first evaluation's: the same fabric, to the bit.
    let mut warm = Warm::default();
    let placement = placement(p, &with_theta(&p.fabric, &p.free, &start), &mut warm)?;
    let mut lower: Vec<f64> = p.free.iter().map(|f| f.lower.ln()).collect();
    let mut upper: Vec<f64> = p.free.iter().map(|f| f.upper.ln()).collect();
    if placement.is_some() {
        // Turns within a quarter turn of the estimate, shifts within a specimen's diameter.
        let (turn, shift) = (std::f64::consts::FRAC_PI_2, p.instrument.specimen);
        start.extend([0.0; PARAMETERS]);
        lower.extend([-turn, -turn, -turn, -shift, -shift, -shift]);
        upper.extend([turn, turn, turn, shift, shift, shift]);
    }
    let residuals = |theta: &[f64]| residuals_at(p, placement.as_ref(), theta, &mut warm);
    let opts = lm::Options { max_iterations: p.max_iterations, step_tolerance: 1e-10, cost_tolerance: COST_TOLERANCE };
    let out = lm::minimise(&start, (&lower, &upper), opts, residuals)?;
    let mut r = report(p, &out, placement.as_ref());
    if let Some(measured) = p.cusick_nodes {
        let model = targets::drape_nodes(&r.fabric, p.calibration, &p.instrument)?;
        r.cusick_nodes = Some(NodeCheck { measured, model });
    }
    r.seconds = t0.elapsed().as_secs_f64();
    Ok(r)
}

/// The fitted placement of the report.
fn alignment(pl: &Placement, out: &lm::Outcome, stats: &lm::Statistics, n: usize) -> Alignment {
    let pose = &out.theta[n..];
    let (m, v) = pl.affine(pose);
    let mut parameters = [0.0; PARAMETERS];
    parameters.copy_from_slice(pose);
    let mut standard_errors = [0.0; PARAMETERS];
    standard_errors.copy_from_slice(&stats.standard_errors[n..]);
    Alignment {
        matrix: [0, 1, 2].map(|r| [0, 1, 2].map(|c| m.col(c)[r])),
        offset: v.to_array(),
        tilt_degrees: (m * Vec3::Z).dot(Vec3::Z).clamp(-1.0, 1.0).acos().to_degrees(),
        seed: pl.seed,
        parameters,
        standard_errors,
    }
}

/// The report of a fit ended at `out` (its time is set by the caller); the statistics over every fitted
/// parameter, the placement's included, so that the constants' standard errors allow for it.
fn report(p: &FitProblem, out: &lm::Outcome, placement: Option<&Placement>) -> FitReport {
    let n = p.free.len();
    let stats = lm::statistics(&out.at.1, out.theta.len(), RANK_TOLERANCE);
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
    let alignment = placement.map(|pl| alignment(pl, out, &stats, n));
    let null_directions = stats
        .null_directions
        .iter()
        .map(|d: &Vec<f64>| {
            let names = p.free.iter().map(|f| f.constant.key()).chain(align::NAMES);
            names.zip(d).map(|(k, w)| (k, *w)).collect()
        })
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
        seconds: 0.0,
        fabric: with_theta(&p.fabric, &p.free, &out.theta),
        cusick_nodes: None,
        alignment,
    }
}
