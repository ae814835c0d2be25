//! Quasi-static equilibrium (docs/model.md §9): minimises the total potential
//! `Π(x) = E_h(x) − Σ m g·x + contact penalty + springs` ([`crate::potential`], the same assembly as the time
//! step) over the free nodes by Newton's method: the exact Hessian where it is positive definite, else the
//! positive semi-definite one (plus a Levenberg shift when needed), with a backtracking (Armijo) line search on
//! `Π`. Convergence is judged on the residual force relative to the largest load. A potential with a
//! non-conservative term (the Terzopoulos force) has no `Π` to minimise and is refused.

use super::linsolve::{LinearSolver, SolverKind};
use crate::energy::Operator;
use crate::math::{diag, Vec3};
use crate::model::Model;
use crate::potential::{Want, Workspace};
use serde::Serialize;
use thiserror::Error;

/// Failure of the static solve.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum StaticError {
    /// Newton did not reach the tolerance.
    #[error("static solve did not converge: relative residual {residual:.3e} after {iterations} Newton iterations")]
    NotConverged {
        /// Iterations made.
        iterations: usize,
        /// Relative residual reached.
        residual: f64,
    },
    /// A term of the potential is not the gradient of an energy: there is no potential to minimise.
    #[error(
        "static solve: the {term} force is not the gradient of an energy, so it has no equilibrium potential; \
         use a dynamic integrator (integrator = \"linearized\") or the tfs model"
    )]
    NonConservative {
        /// The term.
        term: &'static str,
    },
    /// A linear solve failed even with regularisation.
    #[error("static solve: {0}")]
    Linear(#[from] super::linsolve::LinearError),
}

/// Options of the Newton solver.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StaticOptions {
    /// Stop when `|r|∞ ≤ tolerance · (largest nodal external load)`.
    pub tolerance: f64,
    /// Newton iteration limit.
    pub max_iterations: usize,
}

impl Default for StaticOptions {
    fn default() -> Self {
        Self { tolerance: 1e-9, max_iterations: 200 }
    }
}

/// Result of a converged static solve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StaticReport {
    /// Newton iterations taken.
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
    /// Final total potential (J).
    pub potential: f64,
}

/// Newton solver workspace for one model.
pub struct StaticSolver {
    solver: LinearSolver,
    ws: Workspace,
    /// Try the exact Hessian first (see [`StaticSolver::solve`]).
    exact: bool,
}

impl StaticSolver {
    /// Analyses the model's pattern.
    pub fn new(model: &Model) -> Result<Self, StaticError> {
        Ok(Self {
            solver: LinearSolver::new(SolverKind::Cholesky, model.potential.pattern())?,
            ws: Workspace::new(&model.potential),
            exact: true,
        })
    }

    /// Total potential and (optionally) its gradient over free nodes (written into `grad`), from cold contact
    /// queries.
    pub fn potential(model: &Model, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        Self::potential_in(&mut Workspace::new(&model.potential), model, x, grad)
    }

    fn potential_in(ws: &mut Workspace, model: &Model, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        ws.cold();
        let want = if grad.is_some() { Want::GRADIENT } else { Want::VALUE };
        let values = model.potential.assemble(x, &model.potential.context(None), None, want, ws);
        if let Some(g) = grad {
            g.copy_from_slice(&ws.grad);
        }
        values.total
    }

    /// The matrix at `x` (into the workspace): the Hessian approximation `op` of every term.
    fn assemble(&mut self, model: &Model, x: &[Vec3], op: Operator) {
        self.ws.cold();
        let want = Want { grad: false, hess: Some(op) };
        model.potential.assemble(x, &model.potential.context(None), None, want, &mut self.ws);
    }

    /// Size of the matrix entries, for relative shifts.
    fn scale(&self) -> f64 {
        self.ws.matrix.blocks.iter().map(|b| b.abs().to_cols_array()[0]).fold(0.0, f64::max)
    }

    /// Subtracts `s I` from every diagonal block.
    fn unshift(&mut self, model: &Model, s: f64) {
        for d in model.potential.diag_ids() {
            self.ws.matrix.blocks[*d as usize] -= diag(s);
        }
    }

    /// Adds `s I` to every diagonal block.
    fn shift(&mut self, model: &Model, s: f64) {
        for d in model.potential.diag_ids() {
            self.ws.matrix.blocks[*d as usize] += diag(s);
        }
    }

    /// Solves for equilibrium starting from `x` (pinned nodes stay where they are).
    pub fn solve(&mut self, model: &Model, x: &mut [Vec3], opts: &StaticOptions) -> Result<StaticReport, StaticError> {
        if let Some(term) = model.potential.non_conservative() {
            return Err(StaticError::NonConservative { term });
        }
        let n = x.len();
        let load = Self::force_scale(model, x);
        let mut grad = vec![Vec3::ZERO; n];
        let mut step = vec![Vec3::ZERO; n];
        let mut trial = x.to_vec();
        let mut shift: f64 = 0.0;
        for it in 0..opts.max_iterations {
            grad.fill(Vec3::ZERO);
            let pi = Self::potential_in(&mut self.ws, model, x, Some(&mut grad));
            let res = grad.iter().map(|g| g.abs().max_element()).fold(0.0, f64::max) / load;
            if res <= opts.tolerance {
                return Ok(StaticReport { iterations: it, residual: res, potential: pi });
            }
            if !self.direction(model, x, &grad, &mut step, &mut shift) {
                return Err(StaticError::NotConverged { iterations: it, residual: res });
            }
            let slope: f64 = grad.iter().zip(&step).map(|(g, d)| g.dot(*d)).sum();
            // Newton decrement at round-off of Π: no further progress is representable.
            if -slope <= 1e-13 * pi.abs().max(f64::MIN_POSITIVE) && res <= opts.tolerance.sqrt() {
                return Ok(StaticReport { iterations: it, residual: res, potential: pi });
            }
            if !self.line_search(model, x, &step, pi, slope, &mut trial) {
                // No decrease possible at this precision.
                return Err(StaticError::NotConverged { iterations: it, residual: res });
            }
            x.copy_from_slice(&trial);
        }
        grad.fill(Vec3::ZERO);
        let _ = Self::potential_in(&mut self.ws, model, x, Some(&mut grad));
        let res = grad.iter().map(|g| g.abs().max_element()).fold(0.0, f64::max) / load;
        Err(StaticError::NotConverged { iterations: opts.max_iterations, residual: res })
    }

    /// Force scale of the residual: the largest external load or spring force scale, or (for a problem driven by
    /// prescribed positions) the largest elastic force at the start, pinned nodes included.
    fn force_scale(model: &Model, x: &[Vec3]) -> f64 {
        let mut grad = vec![Vec3::ZERO; x.len()];
        model.elastic(x, Some(&mut grad));
        grad.iter()
            .map(|g| g.length())
            .fold(model.potential.load_scale(None, model.length_scale()), f64::max)
            .max(f64::MIN_POSITIVE)
    }

    /// The Newton direction into `step`: with the exact Hessian where it is positive definite (quadratic
    /// convergence near a stable equilibrium); where Cholesky meets a non-positive pivot or the direction does not
    /// descend, with the positive semi-definite Hessian and a Levenberg shift (`shift`, grown on failure and
    /// relaxed after success) instead. False if no direction was found.
    fn direction(&mut self, model: &Model, x: &[Vec3], grad: &[Vec3], step: &mut [Vec3], shift: &mut f64) -> bool {
        if self.exact {
            self.assemble(model, x, Operator::Exact);
            let scale = self.scale();
            self.shift(model, 1e-12 * scale);
            if self.solve_for(model, grad, step) {
                let slope: f64 = grad.iter().zip(step.iter()).map(|(g, d)| g.dot(*d)).sum();
                if slope < 0.0 {
                    return true;
                }
            }
        }
        self.assemble(model, x, Operator::Projected);
        // A tiny relative shift keeps free rigid modes (no pins) solvable; grown on failure.
        let scale = self.scale();
        for attempt in 0..8 {
            let s = if attempt == 0 { shift.max(1e-12 * scale) } else { (*shift * 10.0).max(1e-8 * scale) };
            self.shift(model, s);
            if self.solve_for(model, grad, step) {
                *shift = s * 0.1;
                return true;
            }
            self.unshift(model, s);
            *shift = s;
        }
        false
    }

    /// Solves the assembled matrix for `step = −A⁻¹ grad`; false if the factorisation fails.
    fn solve_for(&mut self, model: &Model, grad: &[Vec3], step: &mut [Vec3]) -> bool {
        for (s, g) in step.iter_mut().zip(grad) {
            *s = -*g;
        }
        self.solver.solve(model.potential.pattern(), &self.ws.matrix, model.pinned(), step, false).is_ok()
    }

    /// Armijo backtracking on Π along `step` from `x` (value `pi`, slope `slope`): the accepted point in `trial`.
    fn line_search(
        &mut self,
        model: &Model,
        x: &[Vec3],
        step: &[Vec3],
        pi: f64,
        slope: f64,
        trial: &mut [Vec3],
    ) -> bool {
        let mut alpha = 1.0;
        for _ in 0..30 {
            for k in 0..x.len() {
                trial[k] = x[k] + step[k] * alpha;
            }
            let pt = Self::potential_in(&mut self.ws, model, trial, None);
            if pt.is_finite() && pt <= pi + 1e-4 * alpha * slope {
                return true;
            }
            alpha *= 0.5;
        }
        false
    }
}
