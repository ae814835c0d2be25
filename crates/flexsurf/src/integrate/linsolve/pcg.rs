//! Block-Jacobi preconditioned conjugate gradients on the block matrix, a [`BlockSolver`] without a factor:
//! the inverse 3×3 diagonal blocks precondition, fixed unknowns are moved to the right-hand side.

use super::{BlockSolver, LinearError};
use crate::math::{Mat3, Vec3};
use crate::sparse::{BlockMatrix, BlockPattern};

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
}

impl BlockSolver for Pcg {
    fn solve(
        &mut self,
        pattern: &BlockPattern,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &mut [Vec3],
        _nearby: bool,
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
