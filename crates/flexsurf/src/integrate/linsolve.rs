//! The step's sparse symmetric positive definite solve: supernodal/simplicial Cholesky from `faer` with the
//! symbolic analysis (AMD ordering, elimination tree) done once per run and a numeric refactorisation per step,
//! or block-Jacobi preconditioned conjugate gradients on the block matrix. Fixed (pinned) unknowns are
//! eliminated symmetrically so the matrix stays SPD.

use crate::math::{Mat3, Vec3};
use crate::sparse::{BlockMatrix, BlockPattern};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Failure of the linear solve.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum LinearError {
    /// The symbolic analysis failed (out of memory).
    #[error("symbolic factorisation failed: {0}")]
    Symbolic(String),
    /// The matrix was not numerically positive definite.
    #[error("the step matrix is not positive definite (pivot {index})")]
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

/// A solver bound to one block pattern.
pub enum LinearSolver {
    /// Sparse Cholesky.
    Cholesky(Box<Cholesky>),
    /// PCG.
    Pcg(Pcg),
}

impl LinearSolver {
    /// Analyses `pattern` for `kind`.
    pub fn new(kind: SolverKind, pattern: &BlockPattern) -> Result<Self, LinearError> {
        Ok(match kind {
            SolverKind::Cholesky => LinearSolver::Cholesky(Box::new(Cholesky::new(pattern)?)),
            SolverKind::Pcg => LinearSolver::Pcg(Pcg::new(pattern)),
        })
    }

    /// Solves `A x = b` in place (`b` becomes `x`) for the unknowns not fixed; fixed unknowns keep the value in
    /// `b` (their prescribed increment), and their columns are moved to the right-hand side.
    /// With `nearby`, `A` differs little from the last factorised matrix (a few diagonal blocks: a contact
    /// active-set change); the Cholesky solver then first tries conjugate gradients preconditioned by the
    /// existing factor and refactorises only if that does not converge quickly.
    /// Returns (factor seconds, solve seconds).
    pub fn solve(
        &mut self,
        pattern: &BlockPattern,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &mut [Vec3],
        nearby: bool,
    ) -> Result<(f64, f64), LinearError> {
        match self {
            LinearSolver::Cholesky(c) => c.solve(a, fixed, b, nearby),
            LinearSolver::Pcg(p) => p.solve(pattern, a, fixed, b),
        }
    }
}

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

    /// Non-zeros of the factor `L`.
    pub fn factor_nnz(&self) -> usize {
        self.symbolic.len_val()
    }

    fn solve(
        &mut self,
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
}

impl Cholesky {
    /// Relative residual a preconditioned re-solve must reach.
    pub const NEARBY_TOLERANCE: f64 = 1e-11;
    /// Conjugate-gradient iterations allowed before refactorising.
    pub const NEARBY_ITERATIONS: usize = 30;

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

/// Block-Jacobi preconditioned conjugate gradients.
pub struct Pcg {
    diag: Vec<usize>,
    inv: Vec<Mat3>,
    r: Vec<Vec3>,
    z: Vec<Vec3>,
    p: Vec<Vec3>,
    q: Vec<Vec3>,
    /// Relative residual tolerance.
    pub tolerance: f64,
    /// Iterations of the last solve.
    pub last_iterations: usize,
}

impl Pcg {
    /// Buffers for `pattern`.
    pub fn new(pattern: &BlockPattern) -> Self {
        let n = pattern.nodes();
        Self {
            diag: (0..n).map(|k| pattern.find(k, k)).collect(),
            inv: vec![Mat3::IDENTITY; n],
            r: vec![Vec3::ZERO; n],
            z: vec![Vec3::ZERO; n],
            p: vec![Vec3::ZERO; n],
            q: vec![Vec3::ZERO; n],
            tolerance: 1e-10,
            last_iterations: 0,
        }
    }

    fn apply(&mut self, pattern: &BlockPattern, a: &BlockMatrix, fixed: &[bool], x: &[Vec3], out: &mut [Vec3]) {
        out.iter_mut().for_each(|v| *v = Vec3::ZERO);
        let xm: Vec<Vec3> = x.iter().zip(fixed).map(|(v, &f)| if f { Vec3::ZERO } else { *v }).collect();
        a.mul_add(pattern, &xm, out);
        for (k, o) in out.iter_mut().enumerate() {
            if fixed[k] {
                *o = x[k];
            }
        }
    }

    fn solve(
        &mut self,
        pattern: &BlockPattern,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &mut [Vec3],
    ) -> Result<(f64, f64), LinearError> {
        let t0 = std::time::Instant::now();
        let n = b.len();
        for k in 0..n {
            self.inv[k] = if fixed[k] { Mat3::IDENTITY } else { a.blocks[self.diag[k]].inverse() };
        }
        // Right-hand side with the fixed values' columns moved over: b' = b − A x_fixed.
        let xf: Vec<Vec3> = (0..n).map(|k| if fixed[k] { b[k] } else { Vec3::ZERO }).collect();
        let mut ax = vec![Vec3::ZERO; n];
        a.mul_add(pattern, &xf, &mut ax);
        let rhs: Vec<Vec3> = (0..n).map(|k| if fixed[k] { b[k] } else { b[k] - ax[k] }).collect();
        let t1 = std::time::Instant::now();
        let norm = |v: &[Vec3]| v.iter().map(|w| w.length_squared()).sum::<f64>().sqrt();
        let dot = |u: &[Vec3], v: &[Vec3]| u.iter().zip(v).map(|(a, b)| a.dot(*b)).sum::<f64>();
        let bnorm = norm(&rhs).max(f64::MIN_POSITIVE);
        let mut x: Vec<Vec3> = xf.clone();
        let mut q = std::mem::take(&mut self.q);
        self.apply(pattern, a, fixed, &x, &mut q);
        for k in 0..n {
            self.r[k] = rhs[k] - q[k];
            self.z[k] = self.inv[k] * self.r[k];
        }
        self.p.copy_from_slice(&self.z);
        let mut rz = dot(&self.r, &self.z);
        let max_iter = 20 * n + 100;
        let mut iters = 0;
        let mut res = norm(&self.r) / bnorm;
        while res > self.tolerance && iters < max_iter {
            let p = self.p.clone();
            self.apply(pattern, a, fixed, &p, &mut q);
            let alpha = rz / dot(&p, &q);
            for k in 0..n {
                x[k] += p[k] * alpha;
                self.r[k] -= q[k] * alpha;
                self.z[k] = self.inv[k] * self.r[k];
            }
            let rz_new = dot(&self.r, &self.z);
            let beta = rz_new / rz;
            rz = rz_new;
            for k in 0..n {
                self.p[k] = self.z[k] + self.p[k] * beta;
            }
            res = norm(&self.r) / bnorm;
            iters += 1;
        }
        self.q = q;
        self.last_iterations = iters;
        if res > self.tolerance || !res.is_finite() {
            return Err(LinearError::NotConverged { iters, residual: res });
        }
        b.copy_from_slice(&x);
        Ok((t1.duration_since(t0).as_secs_f64(), t1.elapsed().as_secs_f64()))
    }
}
