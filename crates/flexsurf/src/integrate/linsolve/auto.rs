//! The automatic choice on mid-size grids, a [`BlockSolver`] that holds two: sparse Cholesky for the steps with
//! contact, multigrid for the steps without contact that Newton iterates with inexact solves (docs/model.md
//! §8.5, "Inexact corrections"). Measured on the tumbling sheet (`flexsurf bench --workload tumble`,
//! docs/performance.md "Which solver `auto` takes"): multigrid takes such a step 1.4× faster than Cholesky at
//! 51², 2.2× at 81² and 101², even at 41²; a step one exact solve converges (a free fall) is cheaper on
//! Cholesky below about 200², and so is a contact step (a drop's impact and sliding: 1.35× faster at 161² since
//! Cholesky's re-solves stop at the contact steps' tolerance); above [`super::AUTO_MULTIGRID_NODES`] multigrid
//! takes every step.
//!
//! The stepper says which kind of step comes ([`BlockSolver::set_free_motion`]) before the step's first solve;
//! the choice holds for the whole step (its re-solves and corrections). Both solvers are deterministic and the
//! choice depends only on the run's own history (carried in checkpoints), so the run is too.

use super::{BlockSolver, Cholesky, LinearError, Multigrid, Reuse, SolveStats, SolverKind};
use crate::math::Vec3;
use crate::model::Panel;
use crate::sparse::{BlockMatrix, BlockPattern};

/// Cholesky for contact steps and for steps without contact that one exact solve converges, multigrid for the
/// steps without contact that Newton iterates.
pub struct Auto {
    direct: Cholesky,
    /// `None` where the model's unknowns are not all grid nodes of its panels (multigrid cannot coarsen them):
    /// then every step takes Cholesky.
    iterative: Option<Multigrid>,
    /// The solves since the last [`BlockSolver::set_free_motion`] belong to a step without contact.
    free: bool,
    /// They are multigrid's.
    on_iterative: bool,
    /// The next step without contact takes multigrid.
    prefer_iterative: bool,
    /// Fresh solves (the linearised step and its Newton corrections) since the last call.
    fresh: usize,
}

impl Auto {
    /// Both solvers for `pattern` on the model's `panels` (Cholesky's symbolic analysis done here, the
    /// multigrid hierarchy built at its first solve).
    pub fn new(pattern: &BlockPattern, panels: &[Panel]) -> Result<Self, LinearError> {
        Ok(Self {
            direct: Cholesky::new(pattern)?,
            iterative: Multigrid::new(pattern, panels).ok(),
            free: false,
            on_iterative: false,
            prefer_iterative: false,
            fresh: 0,
        })
    }

    /// The solver of the coming solves.
    fn active(&self) -> &dyn BlockSolver {
        match (&self.iterative, self.on_iterative) {
            (Some(iterative), true) => iterative,
            _ => &self.direct,
        }
    }

    /// [`Auto::active`], to solve with.
    fn active_mut(&mut self) -> &mut dyn BlockSolver {
        match (&mut self.iterative, self.on_iterative) {
            (Some(iterative), true) => iterative,
            _ => &mut self.direct,
        }
    }

    /// Whether the next step without contact takes multigrid, from the last one's Newton iterations: a step
    /// that one exact solve converged (free fall, a sheet at rest) costs one factorisation, which beats the two
    /// or more inexact solves multigrid then needs (its first is loose); a step that Newton had to correct
    /// (rotations: the tumbling sheet needs 2–3 corrections) is cheaper on multigrid. So a Cholesky step with
    /// a correction hands the next to multigrid, and a multigrid step converged in at most one correction
    /// hands it back.
    fn pick(&self) -> bool {
        match (self.free && self.fresh > 0, self.on_iterative) {
            (true, true) => self.fresh > 2,
            (true, false) => self.fresh > 1,
            (false, _) => self.prefer_iterative,
        }
    }
}

impl BlockSolver for Auto {
    fn solve_to(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        reuse: Reuse,
        tolerance: Option<f64>,
    ) -> Result<SolveStats, LinearError> {
        self.fresh += usize::from(reuse == Reuse::Fresh);
        self.active_mut().solve_to(a, fixed, b, x, reuse, tolerance)
    }

    fn set_positions(&mut self, x: &[Vec3]) {
        if let Some(iterative) = &mut self.iterative {
            iterative.set_positions(x);
        }
    }

    fn set_free_motion(&mut self, free: bool) {
        self.prefer_iterative = self.pick();
        self.free = free;
        self.on_iterative = self.iterative.is_some() && free && self.prefer_iterative;
        self.fresh = 0;
    }

    fn iterative_next(&self) -> bool {
        self.pick()
    }

    fn set_iterative_next(&mut self, iterative: bool) {
        (self.prefer_iterative, self.free, self.on_iterative, self.fresh) = (iterative, false, false, 0);
    }

    fn iteration_bytes(&self) -> usize {
        self.active().iteration_bytes()
    }

    fn factor_nnz(&self) -> usize {
        self.direct.factor_nnz()
    }

    /// The solver of the coming solves.
    fn kind(&self) -> SolverKind {
        self.active().kind()
    }
}
