//! The preconditioned conjugate-gradient loop every iterative solver shares, on node vectors, with the vector
//! operations split over rayon's threads in chunks of a fixed size: a dot product is the sum of the chunks'
//! partial sums in chunk order, so the result does not depend on the number of threads.

use super::LinearError;
use crate::math::Vec3;
use rayon::prelude::*;

/// Nodes per chunk of a parallel vector operation (fixed: the reduction order must not depend on threads).
pub const CHUNK: usize = 4096;

/// `Σ u·v` with a fixed reduction order; `parts` holds the chunks' partial sums (kept between calls).
pub fn dot(parts: &mut Vec<f64>, u: &[Vec3], v: &[Vec3]) -> f64 {
    if u.len() <= CHUNK {
        return u.iter().zip(v).map(|(a, b)| a.dot(*b)).sum();
    }
    u.par_chunks(CHUNK)
        .zip(v.par_chunks(CHUNK))
        .map(|(a, b)| a.iter().zip(b).map(|(p, q)| p.dot(*q)).sum::<f64>())
        .collect_into_vec(parts);
    parts.iter().sum()
}

/// `y[k] = f(y[k], x[k])` for every node, over the threads in chunks for long vectors.
pub fn update(y: &mut [Vec3], x: &[Vec3], f: impl Fn(Vec3, Vec3) -> Vec3 + Sync) {
    if y.len() <= CHUNK {
        y.iter_mut().zip(x).for_each(|(y, x)| *y = f(*y, *x));
    } else {
        y.par_chunks_mut(CHUNK)
            .zip(x.par_chunks(CHUNK))
            .for_each(|(y, x)| y.iter_mut().zip(x).for_each(|(y, x)| *y = f(*y, *x)));
    }
}

/// Scratch vectors of the loop, kept between solves.
#[derive(Debug, Clone, Default)]
pub struct Work {
    r: Vec<Vec3>,
    z: Vec<Vec3>,
    p: Vec<Vec3>,
    q: Vec<Vec3>,
    parts: Vec<f64>,
}

impl Work {
    /// Vectors of `n` nodes.
    pub fn new(n: usize) -> Self {
        Self {
            r: vec![Vec3::ZERO; n],
            z: vec![Vec3::ZERO; n],
            p: vec![Vec3::ZERO; n],
            q: vec![Vec3::ZERO; n],
            parts: Vec::new(),
        }
    }
}

/// Solves `A x = b` from the guess in `x` until `‖b − A x‖ ≤ tol ‖b‖`, at most `max_iter` iterations, with
/// `apply(v, out)`: `out = A v` and `precondition(r, out)`: `out ≈ A⁻¹ r` (symmetric positive definite).
/// Returns the iterations made; on failure `x` holds the last iterate.
pub fn solve(
    mut apply: impl FnMut(&[Vec3], &mut [Vec3]),
    mut precondition: impl FnMut(&[Vec3], &mut [Vec3]),
    b: &[Vec3],
    x: &mut [Vec3],
    tol: f64,
    max_iter: usize,
    w: &mut Work,
) -> Result<usize, LinearError> {
    let Work { r, z, p, q, parts } = w;
    let bnorm = dot(parts, b, b).sqrt();
    if bnorm == 0.0 {
        x.iter_mut().for_each(|v| *v = Vec3::ZERO);
        return Ok(0);
    }
    apply(x, q);
    r.copy_from_slice(b);
    update(r, q, |r, q| r - q);
    let target = tol * bnorm;
    let mut res = dot(parts, r, r).sqrt();
    if !res.is_finite() {
        return Err(LinearError::NotConverged { iters: 0, residual: res / bnorm });
    }
    if res <= target {
        return Ok(0);
    }
    precondition(r, z);
    p.copy_from_slice(z);
    let mut rz = dot(parts, r, z);
    for iter in 1..=max_iter {
        apply(p, q);
        let pq = dot(parts, p, q);
        if !(pq > 0.0 && pq.is_finite() && rz.is_finite()) {
            return Err(LinearError::NotConverged { iters: iter, residual: res / bnorm });
        }
        let alpha = rz / pq;
        update(x, p, |x, p| x + p * alpha);
        update(r, q, |r, q| r - q * alpha);
        res = dot(parts, r, r).sqrt();
        if res <= target {
            return Ok(iter);
        }
        if !res.is_finite() {
            break;
        }
        precondition(r, z);
        let rz_new = dot(parts, r, z);
        let beta = rz_new / rz;
        rz = rz_new;
        update(p, z, |p, z| z + p * beta);
    }
    Err(LinearError::NotConverged { iters: max_iter, residual: res / bnorm })
}
