//! Sparse Cholesky from `faer` ([`BlockSolver`]) with the symbolic analysis (AMD ordering, elimination tree)
//! done once per run and a numeric factorisation per new matrix. A re-solve after a contact active-set change
//! or a friction re-linearisation ([`Reuse::Nearby`]: a few diagonal blocks changed) first runs conjugate
//! gradients preconditioned by the existing factor and refactorises only if they do not converge within
//! [`Cholesky::MAX_REUSE_ITERATIONS`]. Keeping the factor across steps was measured and rejected
//! (docs/performance.md): the first solve of a step always factorises, so nothing carries over between steps.

use super::{BlockSolver, LinearError, Reduced, Reuse, SolveStats, SolverKind};
use crate::math::Vec3;
use crate::sparse::{BlockMatrix, BlockPattern};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use std::time::Instant;

/// `faer` sparse Cholesky with a fixed symbolic structure and a reused factor.
pub struct Cholesky {
    system: Reduced,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    src: Vec<(u32, u8)>,
    values: Vec<f64>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    /// Scalar right-hand side / solution of the triangular solves.
    flat: Vec<f64>,
    /// A factor of a recent matrix exists.
    factored: bool,
    /// The nodes without stiffness of the coarsest level of a hierarchy.
    no_fixed: Vec<bool>,
}

impl Cholesky {
    /// Iterations a preconditioned re-solve may take before it refactorises.
    pub const MAX_REUSE_ITERATIONS: usize = 8;

    /// Symbolic analysis of the scalar upper triangle of `pattern`.
    pub fn new(pattern: &BlockPattern) -> Result<Self, LinearError> {
        let (col_ptr, row_idx, src) = pattern.csc_upper();
        let n = 3 * pattern.nodes();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic =
            factorize_symbolic_cholesky(sym, Side::Upper, SymmetricOrdering::Amd, CholeskySymbolicParams::default())
                .map_err(|e| LinearError::Symbolic(format!("{e:?}")))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let l_values = vec![0.0; symbolic.len_val()];
        let values = vec![0.0; row_idx.len()];
        Ok(Self {
            system: Reduced::new(pattern),
            col_ptr,
            row_idx,
            src,
            values,
            symbolic,
            l_values,
            mem: MemBuffer::new(req),
            flat: vec![0.0; n],
            factored: false,
            no_fixed: Vec::new(),
        })
    }

    /// Copies `a` into the scalar upper triangle with the fixed rows and columns replaced by the identity.
    fn fill(&mut self, a: &BlockMatrix, fixed: &[bool]) {
        let n = self.flat.len();
        for c in 0..n {
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[p];
                let (blk, e) = self.src[p];
                self.values[p] = if fixed[r / 3] || fixed[c / 3] {
                    if r == c {
                        1.0
                    } else {
                        0.0
                    }
                } else {
                    a.blocks[blk as usize].to_cols_array()[e as usize]
                };
            }
        }
    }

    fn factor(&mut self) -> Result<(), LinearError> {
        let n = self.flat.len();
        let mat = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx),
            &self.values,
        );
        self.factored = false;
        self.symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                mat,
                Side::Upper,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| match e {
                faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                    LinearError::NotPositiveDefinite { index }
                }
            })?;
        self.factored = true;
        Ok(())
    }
}

impl Cholesky {
    /// Factorises `a`, the coarsest level of [`super::multigrid`]: its nodes without any stiffness (every
    /// finer node under them pinned) are fixed, so they keep a zero correction.
    pub(crate) fn factorize(&mut self, a: &BlockMatrix) -> Result<(), LinearError> {
        let mut none = std::mem::take(&mut self.no_fixed);
        none.clear();
        none.extend((0..self.system.pattern().nodes()).map(|k| {
            let (s, e) = self.system.pattern().column(k);
            a.blocks[e - 1] == crate::math::Mat3::ZERO && s < e
        }));
        self.fill(a, &none);
        let result = self.factor();
        self.no_fixed = none;
        result
    }

    /// `x = (L Lᵀ)⁻¹ b` with the current factor.
    pub(crate) fn apply(&mut self, b: &[Vec3], x: &mut [Vec3]) {
        apply_factor(&self.symbolic, &self.l_values, &mut self.mem, &mut self.flat, b, x);
    }
}

/// `out = (L Lᵀ)⁻¹ r` with the factor in `l_values`.
fn apply_factor(
    symbolic: &SymbolicCholesky<usize>,
    l_values: &[f64],
    mem: &mut MemBuffer,
    flat: &mut [f64],
    r: &[Vec3],
    out: &mut [Vec3],
) {
    for (k, v) in r.iter().enumerate() {
        flat[3 * k..3 * k + 3].copy_from_slice(&v.to_array());
    }
    let n = flat.len();
    let llt = LltRef::new(symbolic, l_values);
    llt.solve_in_place_with_conj(
        Conj::No,
        MatMut::from_column_major_slice_mut(flat, n, 1),
        Par::Seq,
        MemStack::new(mem),
    );
    for (k, v) in out.iter_mut().enumerate() {
        *v = Vec3::new(flat[3 * k], flat[3 * k + 1], flat[3 * k + 2]);
    }
}

impl BlockSolver for Cholesky {
    fn solve(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        reuse: Reuse,
    ) -> Result<SolveStats, LinearError> {
        let t0 = Instant::now();
        self.system.eliminate(a, fixed, b, x);
        let mut tried = 0;
        if reuse == Reuse::Nearby && self.factored {
            let Self { system, symbolic, l_values, mem, flat, .. } = self;
            apply_factor(symbolic, l_values, mem, flat, system.rhs(), x);
            let result = system.cg(
                a,
                fixed,
                x,
                |r, out| apply_factor(symbolic, l_values, mem, flat, r, out),
                super::ITERATIVE_TOLERANCE,
                Self::MAX_REUSE_ITERATIONS,
            );
            if let Ok(iterations) = result {
                return Ok(SolveStats::since(t0, t0, iterations, false));
            }
            tried = Self::MAX_REUSE_ITERATIONS;
        }
        self.fill(a, fixed);
        self.factor()?;
        let t1 = Instant::now();
        let Self { system, symbolic, l_values, mem, flat, .. } = self;
        apply_factor(symbolic, l_values, mem, flat, system.rhs(), x);
        // The failed re-solve's iterations count, and their time is the factorisation's set-up.
        Ok(SolveStats::since(t0, t1, tried, true))
    }

    /// Non-zeros of the factor `L`.
    fn factor_nnz(&self) -> usize {
        self.symbolic.len_val()
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Cholesky
    }
}
