//! The step's sparse symmetric positive definite solve, the last stage of a step in [`crate::integrate`]: a
//! [`LinearSolver`] bound to the model's block pattern solves `A x = b` with the fixed (pinned) unknowns
//! eliminated symmetrically, so the matrix stays SPD. Each solver is a [`BlockSolver`] in its own file:
//!
//! - [`cholesky`]: supernodal/simplicial Cholesky from `faer`, the symbolic analysis (AMD ordering, elimination
//!   tree) done once per run and a numeric refactorisation per step (the default);
//! - [`pcg`]: block-Jacobi preconditioned conjugate gradients on the block matrix.
//!
//! A new solver is one file implementing [`BlockSolver`], a [`SolverKind`] variant and its arm in
//! [`SolverKind::solver`].

pub mod cholesky;
pub mod pcg;

use crate::math::Vec3;
use crate::sparse::{BlockMatrix, BlockPattern};
use serde::{Deserialize, Serialize};
use thiserror::Error;

pub use cholesky::Cholesky;
pub use pcg::Pcg;

/// Failure of the linear solve.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum LinearError {
    /// The symbolic analysis failed (out of memory).
    #[error("symbolic factorisation failed: {0}")]
    Symbolic(String),
    /// The matrix was not numerically positive definite.
    #[error(
        "the step matrix is not positive definite (pivot {index} of its factorisation): in a static solve part of \
         the sheet is free to move (pin it or hold it by springs); in a time step a position or coefficient is not \
         finite"
    )]
    NotPositiveDefinite {
        /// Failing column.
        index: usize,
    },
    /// Conjugate gradients did not reach the tolerance.
    #[error("conjugate gradients did not converge: residual {residual:.3e} after {iters} iterations")]
    NotConverged {
        /// Iterations made.
        iters: usize,
        /// Relative residual reached.
        residual: f64,
    },
}

/// Which linear solver the step uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum SolverKind {
    /// Sparse Cholesky, symbolic analysis once per run (default, measured faster).
    #[default]
    Cholesky,
    /// Block-Jacobi preconditioned conjugate gradients.
    Pcg,
}

impl SolverKind {
    /// A solver of this kind for `pattern` (its analysis done): the one table of the linear solvers.
    pub fn solver(self, pattern: &BlockPattern) -> Result<Box<dyn BlockSolver>, LinearError> {
        Ok(match self {
            SolverKind::Cholesky => Box::new(Cholesky::new(pattern)?),
            SolverKind::Pcg => Box::new(Pcg::new(pattern)),
        })
    }
}

/// A linear solver bound to one block pattern.
pub trait BlockSolver: Send {
    /// Solves `A x = b` in place (`b` becomes `x`) for the unknowns not fixed; fixed unknowns keep the value in
    /// `b` (their prescribed increment), and their columns are moved to the right-hand side.
    /// With `nearby`, `A` differs little from the last factorised matrix (a few diagonal blocks: a contact
    /// active-set change); the Cholesky solver then first tries conjugate gradients preconditioned by the
    /// existing factor and refactorises only if that does not converge quickly.
    /// Returns (factor seconds, solve seconds).
    fn solve(
        &mut self,
        pattern: &BlockPattern,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &mut [Vec3],
        nearby: bool,
    ) -> Result<(f64, f64), LinearError>;

    /// Non-zeros of the factor (0, the default, for a solver without one).
    fn factor_nnz(&self) -> usize {
        0
    }
}

/// A solver bound to one block pattern.
pub struct LinearSolver {
    solver: Box<dyn BlockSolver>,
}

impl LinearSolver {
    /// Analyses `pattern` for `kind`.
    pub fn new(kind: SolverKind, pattern: &BlockPattern) -> Result<Self, LinearError> {
        Ok(Self { solver: kind.solver(pattern)? })
    }
}

/// The solver's methods ([`BlockSolver::solve`], [`BlockSolver::factor_nnz`]) directly on a [`LinearSolver`].
impl std::ops::Deref for LinearSolver {
    type Target = dyn BlockSolver;
    fn deref(&self) -> &Self::Target {
        &*self.solver
    }
}

impl std::ops::DerefMut for LinearSolver {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut *self.solver
    }
}
