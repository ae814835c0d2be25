//! Block-Jacobi preconditioned conjugate gradients on the block matrix, a [`BlockSolver`] without a factor:
//! the inverse 3×3 diagonal blocks precondition, fixed unknowns are moved to the right-hand side. A reference
//! for the better preconditioners: its iteration count grows with the grid's stiffness.

use super::{apply_fixed, cg, eliminate_fixed, BlockSolver, LinearError, Reuse, SolveStats, SolverKind};
use crate::math::{Mat3, Vec3};
use crate::sparse::{BlockMatrix, BlockPattern};
use std::time::Instant;

/// Block-Jacobi preconditioned conjugate gradients.
pub struct Pcg {
    pattern: BlockPattern,
    diag: Vec<usize>,
    inv: Vec<Mat3>,
    rhs: Vec<Vec3>,
    scratch: Vec<Vec3>,
    work: cg::Work,
    /// Relative residual tolerance.
    pub tolerance: f64,
}

impl Pcg {
    /// Buffers for `pattern`.
    pub fn new(pattern: &BlockPattern) -> Self {
        let n = pattern.nodes();
        Self {
            pattern: pattern.clone(),
            diag: (0..n).map(|k| pattern.find(k, k)).collect(),
            inv: vec![Mat3::IDENTITY; n],
            rhs: vec![Vec3::ZERO; n],
            scratch: vec![Vec3::ZERO; n],
            work: cg::Work::new(n),
            tolerance: 1e-10,
        }
    }
}

impl BlockSolver for Pcg {
    fn solve(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        _reuse: Reuse,
    ) -> Result<SolveStats, LinearError> {
        let t0 = Instant::now();
        let n = b.len();
        for k in 0..n {
            self.inv[k] = if fixed[k] { Mat3::IDENTITY } else { a.blocks[self.diag[k]].inverse() };
        }
        eliminate_fixed(&self.pattern, a, fixed, b, x, &mut self.rhs, &mut self.scratch);
        let t1 = Instant::now();
        let any = fixed.iter().any(|&f| f);
        let (pattern, inv, scratch) = (&self.pattern, &self.inv, &mut self.scratch);
        let iterations = cg::solve(
            |v, out| apply_fixed(pattern, a, fixed, any, v, out, scratch),
            |r, out| out.iter_mut().zip(r).zip(inv).for_each(|((o, r), m)| *o = *m * *r),
            &self.rhs,
            x,
            self.tolerance,
            20 * n + 100,
            &mut self.work,
        )?;
        Ok(SolveStats::since(t0, t1, iterations, false))
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Pcg
    }
}
