//! Block-Jacobi preconditioned conjugate gradients on the block matrix, a [`BlockSolver`] without a factor:
//! the inverse 3×3 diagonal blocks precondition, fixed unknowns are moved to the right-hand side. A reference
//! for the better preconditioners: its iteration count grows with the grid's stiffness.

use super::{BlockSolver, LinearError, Reduced, Reuse, SolveStats, SolverKind};
use crate::math::{Mat3, Vec3};
use crate::sparse::{BlockMatrix, BlockPattern};
use std::time::Instant;

/// Block-Jacobi preconditioned conjugate gradients.
pub struct Pcg {
    system: Reduced,
    diag: Vec<usize>,
    inv: Vec<Mat3>,
    /// Relative residual tolerance.
    pub tolerance: f64,
}

impl Pcg {
    /// Buffers for `pattern`.
    pub fn new(pattern: &BlockPattern) -> Self {
        let n = pattern.nodes();
        Self {
            system: Reduced::new(pattern),
            diag: (0..n).map(|k| pattern.find(k, k)).collect(),
            inv: vec![Mat3::IDENTITY; n],
            tolerance: 1e-10,
        }
    }
}

impl BlockSolver for Pcg {
    fn solve_to(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        _reuse: Reuse,
        tolerance: Option<f64>,
    ) -> Result<SolveStats, LinearError> {
        let t0 = Instant::now();
        let n = b.len();
        for k in 0..n {
            self.inv[k] = if fixed[k] { Mat3::IDENTITY } else { a.blocks[self.diag[k]].inverse() };
        }
        self.system.eliminate(a, fixed, b, x);
        let t1 = Instant::now();
        let inv = &self.inv;
        let iterations = self.system.cg(
            a,
            fixed,
            x,
            |r, out| out.iter_mut().zip(r).zip(inv).for_each(|((o, r), m)| *o = *m * *r),
            tolerance.unwrap_or(self.tolerance),
            20 * n + 100,
        )?;
        Ok(SolveStats::since(t0, t1, iterations, false))
    }

    /// The conjugate gradients' own bytes and the inverse diagonal blocks.
    fn iteration_bytes(&self) -> usize {
        self.system.iteration_bytes() + self.inv.len() * std::mem::size_of::<Mat3>()
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Pcg
    }
}
