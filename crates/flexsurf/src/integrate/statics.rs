//! Quasi-static equilibrium (MODEL.md §5, "Implicit Newton and static"): minimises the total potential
//! `Π(x) = E_h(x) − Σ m g·x + contact penalty + springs` over the free nodes by Newton's method with the
//! PSD-projected Hessian (plus a Levenberg shift when needed) and a backtracking (Armijo) line search on `Π`.
//! Convergence is judged on the residual force relative to the total external load.

use super::linsolve::{LinearSolver, SolverKind};
use crate::contact;
use crate::energy::{Operator, Sink};
use crate::math::{diag, Vec3};
use crate::model::Model;
use crate::sparse::BlockMatrix;
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
    matrix: BlockMatrix,
    diag: Vec<u32>,
    /// Try the exact Hessian first (see [`StaticSolver::solve`]).
    exact: bool,
}

impl StaticSolver {
    /// Analyses the model's pattern.
    pub fn new(model: &Model) -> Result<Self, StaticError> {
        let p = &model.elastic.pattern;
        Ok(Self {
            solver: LinearSolver::new(SolverKind::Cholesky, p)?,
            matrix: BlockMatrix::zeros(p),
            diag: (0..model.grid.len()).map(|k| p.find(k, k) as u32).collect(),
            exact: true,
        })
    }

    /// Total potential and (optionally) its gradient over free nodes.
    pub fn potential(model: &Model, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        let mut contacts = Vec::new();
        contact::detect(&model.obstacles, &model.contact, &model.area, x, &mut contacts);
        let mut total = 0.0;
        let has_grad = grad.is_some();
        let mut g = grad;
        let e = match g.as_deref_mut() {
            Some(gr) => model.elastic.evaluate(x, &mut Sink::grad(gr)),
            None => model.elastic.evaluate(x, &mut Sink::none()),
        };
        total += e.membrane + e.bending + model.potential(x);
        for c in &contacts {
            total += c.energy();
        }
        for s in &model.springs {
            total += 0.5 * s.stiffness * (x[s.node] - s.target).length_squared();
        }
        if has_grad {
            let gr = g.expect("gradient buffer");
            for k in 0..gr.len() {
                gr[k] -= model.external_force(k);
            }
            for c in &contacts {
                gr[c.node] -= c.force_vector();
            }
            for s in &model.springs {
                gr[s.node] += (x[s.node] - s.target) * s.stiffness;
            }
            for (k, &p) in model.pinned.iter().enumerate() {
                if p {
                    gr[k] = Vec3::ZERO;
                }
            }
        }
        total
    }

    /// The step matrix at `x`: elastic Hessian (`op`), contact and spring stiffness.
    fn assemble(&mut self, model: &Model, x: &[Vec3], contacts: &mut Vec<contact::Contact>, op: Operator) {
        self.matrix.clear();
        model.elastic.evaluate(x, &mut Sink { grad: None, hess: Some((&mut self.matrix, op)) });
        contact::detect(&model.obstacles, &model.contact, &model.area, x, contacts);
        for c in contacts.iter() {
            self.matrix.blocks[self.diag[c.node] as usize] += c.stiffness_block();
        }
        for s in &model.springs {
            self.matrix.blocks[self.diag[s.node] as usize] += diag(s.stiffness);
        }
    }

    /// Size of the matrix entries, for relative shifts.
    fn scale(&self) -> f64 {
        self.matrix.blocks.iter().map(|b| b.abs().to_cols_array()[0]).fold(0.0, f64::max)
    }

    /// Solves for equilibrium starting from `x` (pinned nodes stay where they are).
    pub fn solve(&mut self, model: &Model, x: &mut [Vec3], opts: &StaticOptions) -> Result<StaticReport, StaticError> {
        let n = x.len();
        // Force scale of the residual: the largest external load, spring force scale, or (for a problem driven
        // by prescribed positions) the largest elastic force at the start, pinned nodes included.
        let mut grad = vec![Vec3::ZERO; n];
        model.elastic.evaluate(x, &mut Sink::grad(&mut grad));
        let load = (0..n)
            .map(|k| model.external_force(k).length())
            .chain(model.springs.iter().map(|s| s.stiffness * model.length_scale() * 1e-3))
            .chain(grad.iter().map(|g| g.length()))
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut step = vec![Vec3::ZERO; n];
        let mut trial = x.to_vec();
        let mut contacts = Vec::new();
        let mut shift: f64 = 0.0;
        for it in 0..opts.max_iterations {
            grad.fill(Vec3::ZERO);
            let pi = Self::potential(model, x, Some(&mut grad));
            let res = grad.iter().map(|g| g.abs().max_element()).fold(0.0, f64::max) / load;
            if res <= opts.tolerance {
                return Ok(StaticReport { iterations: it, residual: res, potential: pi });
            }
            // Newton with the exact Hessian where it is positive definite (quadratic convergence near a stable
            // equilibrium); where Cholesky meets a non-positive pivot or the direction does not descend, the
            // PSD-projected Hessian with a Levenberg shift instead.
            let mut solved = false;
            if self.exact {
                self.assemble(model, x, &mut contacts, Operator::Exact);
                let scale = self.scale();
                for d in &self.diag {
                    self.matrix.blocks[*d as usize] += diag(1e-12 * scale);
                }
                for k in 0..n {
                    step[k] = -grad[k];
                }
                if self.solver.solve(&model.elastic.pattern, &self.matrix, &model.pinned, &mut step, false).is_ok() {
                    let slope: f64 = grad.iter().zip(&step).map(|(g, d)| g.dot(*d)).sum();
                    solved = slope < 0.0;
                }
            }
            if !solved {
                self.assemble(model, x, &mut contacts, Operator::Projected);
                // A tiny relative shift keeps free rigid modes (no pins) solvable; grown on failure.
                let scale = self.scale();
                for attempt in 0..8 {
                    let s = if attempt == 0 { shift.max(1e-12 * scale) } else { (shift * 10.0).max(1e-8 * scale) };
                    for d in &self.diag {
                        self.matrix.blocks[*d as usize] += diag(s);
                    }
                    for k in 0..n {
                        step[k] = -grad[k];
                    }
                    match self.solver.solve(&model.elastic.pattern, &self.matrix, &model.pinned, &mut step, false) {
                        Ok(_) => {
                            solved = true;
                            shift = s * 0.1;
                            break;
                        }
                        Err(_) => {
                            for d in &self.diag {
                                self.matrix.blocks[*d as usize] -= diag(s);
                            }
                            shift = s;
                        }
                    }
                }
            }
            if !solved {
                return Err(StaticError::NotConverged { iterations: it, residual: res });
            }
            // Armijo backtracking on Π along the Newton direction.
            let slope: f64 = grad.iter().zip(&step).map(|(g, d)| g.dot(*d)).sum();
            // Newton decrement at round-off of Π: no further progress is representable.
            if -slope <= 1e-13 * pi.abs().max(f64::MIN_POSITIVE) && res <= opts.tolerance.sqrt() {
                return Ok(StaticReport { iterations: it, residual: res, potential: pi });
            }
            let mut alpha = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                for k in 0..n {
                    trial[k] = x[k] + step[k] * alpha;
                }
                let pt = Self::potential(model, &trial, None);
                if pt.is_finite() && pt <= pi + 1e-4 * alpha * slope {
                    accepted = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !accepted {
                // No decrease possible at this precision: accept the tiny step if the residual is near round-off.
                return Err(StaticError::NotConverged { iterations: it, residual: res });
            }
            x.copy_from_slice(&trial);
        }
        grad.fill(Vec3::ZERO);
        let _ = Self::potential(model, x, Some(&mut grad));
        let res = grad.iter().map(|g| g.abs().max_element()).fold(0.0, f64::max) / load;
        Err(StaticError::NotConverged { iterations: opts.max_iterations, residual: res })
    }
}
