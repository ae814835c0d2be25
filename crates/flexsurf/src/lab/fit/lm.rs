//! A bounded Levenberg–Marquardt least-squares solver on a few parameters, and the statistics of its end point
//! (standard errors from the Jacobian, identifiability from its singular values), with `faer`'s dense algebra.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

/// Residuals `r(θ)` (already divided by their uncertainties) and the Jacobian `∂r/∂θ` (row per residual).
pub type Evaluation = (Vec<f64>, Vec<Vec<f64>>);

/// Options of [`minimise`].
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Iterations (accepted or rejected steps) at most.
    pub max_iterations: usize,
    /// Stop when no parameter moves by more than this (θ units) in an accepted step.
    pub step_tolerance: f64,
    /// Also stop when an accepted step lowers the cost `½ Σ r²` (residuals in their uncertainties) by less than
    /// this while the cost is below ½: the residuals are then all within a standard deviation and a change of
    /// `2 × cost_tolerance` in `χ²` moves the parameters by about `√(2 cost_tolerance)` of their standard
    /// errors. A target that is not a smooth function of the parameters (a drape that switches between
    /// equilibria) has a floor of the cost that the step tolerance alone never reaches.
    pub cost_tolerance: f64,
}

/// Where [`minimise`] ended.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The parameters.
    pub theta: Vec<f64>,
    /// Residuals and Jacobian there.
    pub at: Evaluation,
    /// Iterations made.
    pub iterations: usize,
    /// Evaluations made.
    pub evaluations: usize,
    /// The step or the cost tolerance was met (else the iteration limit or a vanishing gradient ended it).
    pub converged: bool,
}

fn cost(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

/// `(JᵀJ, Jᵀr)`.
fn normal(at: &Evaluation, n: usize) -> (Mat<f64>, Vec<f64>) {
    let (r, j) = at;
    let a = Mat::from_fn(n, n, |p, q| j.iter().map(|row| row[p] * row[q]).sum());
    let g = (0..n).map(|p| j.iter().zip(r).map(|(row, r)| row[p] * r).sum()).collect();
    (a, g)
}

/// The Levenberg–Marquardt step `(A + μ (diag A + ε)) δ = −g` on the parameters not held (`held`: at a bound
/// the gradient pushes against; their step is zero), `None` where the matrix cannot be factorised.
fn step(a: &Mat<f64>, g: &[f64], mu: f64, held: &[bool]) -> Option<Vec<f64>> {
    let idx: Vec<usize> = (0..g.len()).filter(|&p| !held[p]).collect();
    let n = idx.len();
    let mut out = vec![0.0; g.len()];
    if n == 0 {
        return Some(out);
    }
    let big = idx.iter().map(|&p| a[(p, p)]).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    let m = Mat::from_fn(n, n, |p, q| {
        let (p, q) = (idx[p], idx[q]);
        if p == q {
            a[(p, p)] + mu * (a[(p, p)] + 1e-12 * big)
        } else {
            a[(p, q)]
        }
    });
    let llt = m.llt(Side::Lower).ok()?;
    let rhs = Mat::from_fn(n, 1, |p, _| -g[idx[p]]);
    let d = llt.solve(&rhs);
    for (k, &p) in idx.iter().enumerate() {
        out[p] = d[(k, 0)];
    }
    Some(out)
}

/// Minimises `½|r(θ)|²` over `lower ≤ θ ≤ upper` from `theta` (clamped into the box): Levenberg–Marquardt
/// with Marquardt's diagonal scaling, parameters on a bound that the gradient pushes against held there, each
/// trial point projected onto the bounds, accepted when it lowers the cost (a trial the model cannot evaluate
/// counts as rejected).
pub fn minimise<E>(
    theta: &[f64],
    (lower, upper): (&[f64], &[f64]),
    opts: Options,
    mut eval: impl FnMut(&[f64]) -> Result<Evaluation, E>,
) -> Result<Outcome, E> {
    let n = theta.len();
    let clamp = |t: Vec<f64>| -> Vec<f64> { t.iter().enumerate().map(|(p, v)| v.clamp(lower[p], upper[p])).collect() };
    let mut theta = clamp(theta.to_vec());
    let mut at = eval(&theta)?;
    let (mut evaluations, mut iterations, mut mu, mut converged) = (1, 0, 1e-3, false);
    let mut failures = 0;
    while iterations < opts.max_iterations {
        iterations += 1;
        let (a, g) = normal(&at, n);
        if g.iter().all(|v| *v == 0.0) {
            converged = true;
            break;
        }
        let held: Vec<bool> =
            (0..n).map(|p| (theta[p] <= lower[p] && g[p] > 0.0) || (theta[p] >= upper[p] && g[p] < 0.0)).collect();
        let Some(d) = step(&a, &g, mu, &held) else {
            mu *= 10.0;
            continue;
        };
        let trial = clamp(theta.iter().zip(&d).map(|(t, d)| t + d).collect());
        let moved = trial.iter().zip(&theta).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        if moved == 0.0 {
            converged = true;
            break;
        }
        evaluations += 1;
        // A trial point the model cannot evaluate (a solve that fails far from the start) is a rejected step;
        // three in a row end the fit with the error.
        let next = match eval(&trial) {
            Ok(next) => {
                failures = 0;
                next
            }
            Err(e) if failures >= 2 => return Err(e),
            Err(_) => {
                failures += 1;
                mu = (mu * 10.0).min(1e12);
                continue;
            }
        };
        let (before, after) = (cost(&at.0), cost(&next.0));
        if after < before {
            (theta, at) = (trial, next);
            mu = (mu / 3.0).max(1e-12);
            if moved < opts.step_tolerance || (before < 0.5 && before - after < opts.cost_tolerance) {
                converged = true;
                break;
            }
        } else {
            if moved < opts.step_tolerance {
                converged = true;
                break;
            }
            mu = (mu * 4.0).min(1e12);
        }
    }
    Ok(Outcome { theta, at, iterations, evaluations, converged })
}

/// The statistics of a least-squares end point with Jacobian `j` (rows: residuals divided by their
/// uncertainties; columns: parameters).
#[derive(Debug, Clone)]
pub struct Statistics {
    /// Singular values of `j`, largest first (as many as parameters; zeros beyond the number of residuals).
    pub singular_values: Vec<f64>,
    /// Standard error of each parameter, `√((JᵀJ)⁻¹)ᵢᵢ` (the uncertainties' σ² already in `J`); infinite for a
    /// parameter in a direction the data do not determine.
    pub standard_errors: Vec<f64>,
    /// Each parameter lies (by more than 10 % of its weight) in a right singular direction whose singular value
    /// is below `rank_tolerance` times the largest.
    pub degenerate: Vec<bool>,
    /// Those right singular directions (unit vectors in the parameters): moving the parameters along one leaves
    /// the residuals unchanged to first order.
    pub null_directions: Vec<Vec<f64>>,
}

/// [`Statistics`] of `j` (`n` parameters): singular values below `rank_tolerance` times the largest count as zero.
pub fn statistics(j: &[Vec<f64>], n: usize, rank_tolerance: f64) -> Statistics {
    let m = j.len();
    // Rows padded with zeros to at least n, so the SVD's V is n × n.
    let rows = m.max(n);
    let a = Mat::from_fn(rows, n, |p, q| if p < m { j[p][q] } else { 0.0 });
    let Ok(svd) = a.svd() else {
        return Statistics {
            singular_values: vec![f64::NAN; n],
            standard_errors: vec![f64::INFINITY; n],
            degenerate: vec![true; n],
            null_directions: Vec::new(),
        };
    };
    let (s, v) = (svd.S(), svd.V());
    let sv: Vec<f64> = (0..n).map(|k| s[k]).collect();
    let top = sv.iter().copied().fold(0.0, f64::max);
    let mut se2 = vec![0.0; n];
    let mut degenerate = vec![false; n];
    let mut null_directions = Vec::new();
    for k in 0..n {
        // NaN singular values count as zero.
        let zero = sv[k].is_nan() || sv[k] <= rank_tolerance * top;
        if zero {
            null_directions.push((0..n).map(|p| v[(p, k)]).collect());
        }
        for p in 0..n {
            let w = v[(p, k)] * v[(p, k)];
            if zero {
                if w > 0.01 {
                    degenerate[p] = true;
                    se2[p] = f64::INFINITY;
                }
            } else {
                se2[p] += w / (sv[k] * sv[k]);
            }
        }
    }
    let standard_errors = se2.iter().map(|v| v.sqrt()).collect();
    Statistics { singular_values: sv, standard_errors, degenerate, null_directions }
}
