//! The default [`BlockSolver`]: `faer` sparse Cholesky of the scalar upper triangle with the symbolic analysis
//! (AMD ordering, elimination tree) done once per run and a numeric refactorisation per step. A `nearby` solve
//! (a contact active-set change) first tries conjugate gradients preconditioned by the existing factor.

use super::{BlockSolver, LinearError};
use crate::math::Vec3;
use crate::sparse::{BlockMatrix, BlockPattern};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// `faer` sparse Cholesky with a fixed symbolic structure.
pub struct Cholesky {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    src: Vec<(u32, u8)>,
    values: Vec<f64>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    rhs: Vec<f64>,
    factored: bool,
    work: [Vec<f64>; 4],
}

impl Cholesky {
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
            col_ptr,
            row_idx,
            src,
            values,
            symbolic,
            l_values,
            mem: MemBuffer::new(req),
            rhs: vec![0.0; n],
            factored: false,
            work: std::array::from_fn(|_| vec![0.0; n]),
        })
    }
}

impl BlockSolver for Cholesky {
    fn solve(
        &mut self,
        _pattern: &BlockPattern,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &mut [Vec3],
        nearby: bool,
    ) -> Result<(f64, f64), LinearError> {
        let t0 = std::time::Instant::now();
        let n = self.rhs.len();
        for (k, v) in b.iter().enumerate() {
            self.rhs[3 * k] = v.x;
            self.rhs[3 * k + 1] = v.y;
            self.rhs[3 * k + 2] = v.z;
        }
        let node_fixed = |dof: usize| fixed[dof / 3];
        for c in 0..n {
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[p];
                let (blk, e) = self.src[p];
                let v = a.blocks[blk as usize].to_cols_array()[e as usize];
                let (fr, fc) = (node_fixed(r), node_fixed(c));
                self.values[p] = if fr || fc {
                    if r == c {
                        1.0
                    } else {
                        // Move the known column to the right-hand side (symmetric elimination).
                        if fc && !fr {
                            self.rhs[r] -= v * self.rhs[c];
                        } else if fr && !fc {
                            self.rhs[c] -= v * self.rhs[r];
                        }
                        0.0
                    }
                } else {
                    v
                };
            }
        }
        if nearby && self.factored && self.preconditioned_cg() {
            for (k, v) in b.iter_mut().enumerate() {
                *v = Vec3::new(self.rhs[3 * k], self.rhs[3 * k + 1], self.rhs[3 * k + 2]);
            }
            return Ok((0.0, t0.elapsed().as_secs_f64()));
        }
        self.factor()?;
        let t1 = std::time::Instant::now();
        let mut rhs = std::mem::take(&mut self.rhs);
        self.apply_factor(&mut rhs);
        self.rhs = rhs;
        for (k, v) in b.iter_mut().enumerate() {
            *v = Vec3::new(self.rhs[3 * k], self.rhs[3 * k + 1], self.rhs[3 * k + 2]);
        }
        Ok((t1.duration_since(t0).as_secs_f64(), t1.elapsed().as_secs_f64()))
    }

    /// Non-zeros of the factor `L`.
    fn factor_nnz(&self) -> usize {
        self.symbolic.len_val()
    }
}

impl Cholesky {
    /// Relative residual a preconditioned re-solve must reach.
    pub const NEARBY_TOLERANCE: f64 = 1e-11;
    /// Conjugate-gradient iterations allowed before refactorising.
    pub const NEARBY_ITERATIONS: usize = 10;

    fn factor(&mut self) -> Result<(), LinearError> {
        let n = self.rhs.len();
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

    /// `v ← (L Lᵀ)⁻¹ v` with the current factor.
    fn apply_factor(&mut self, v: &mut [f64]) {
        let n = v.len();
        let llt = LltRef::new(&self.symbolic, &self.l_values);
        let rhs = MatMut::from_column_major_slice_mut(v, n, 1);
        llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.mem));
    }

    /// `y = A x` with the symmetric upper CSC values.
    fn matvec(&self, x: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        for c in 0..x.len() {
            let xc = x[c];
            let mut acc = 0.0;
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let (r, v) = (self.row_idx[p], self.values[p]);
                acc += v * x[r];
                if r != c {
                    y[r] += v * xc;
                }
            }
            y[c] += acc;
        }
    }

    /// Conjugate gradients on the current values, preconditioned by the last factor; on success `self.rhs`
    /// holds the solution.
    fn preconditioned_cg(&mut self) -> bool {
        let n = self.rhs.len();
        let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        let [mut x, mut r, mut z, mut q] = std::mem::take(&mut self.work);
        let b = self.rhs.clone();
        let tol = Self::NEARBY_TOLERANCE * dot(&b, &b).sqrt();
        x.copy_from_slice(&b);
        self.apply_factor(&mut x);
        self.matvec(&x, &mut q);
        for i in 0..n {
            r[i] = b[i] - q[i];
        }
        let mut ok = dot(&r, &r).sqrt() <= tol;
        if !ok {
            z.copy_from_slice(&r);
            self.apply_factor(&mut z);
            let mut p = z.clone();
            let mut rz = dot(&r, &z);
            for _ in 0..Self::NEARBY_ITERATIONS {
                self.matvec(&p, &mut q);
                let pq = dot(&p, &q);
                if !(pq > 0.0 && pq.is_finite()) {
                    break;
                }
                let alpha = rz / pq;
                for i in 0..n {
                    x[i] += alpha * p[i];
                    r[i] -= alpha * q[i];
                }
                if dot(&r, &r).sqrt() <= tol {
                    ok = true;
                    break;
                }
                z.copy_from_slice(&r);
                self.apply_factor(&mut z);
                let rz_new = dot(&r, &z);
                let beta = rz_new / rz;
                rz = rz_new;
                for i in 0..n {
                    p[i] = z[i] + beta * p[i];
                }
            }
        }
        if ok {
            self.rhs.copy_from_slice(&x);
        }
        self.work = [x, r, z, q];
        ok
    }
}
