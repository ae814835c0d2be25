//! The Terzopoulos–Fleischer model the paper corrects (docs/model.md §11): the same grid, quadrature and membrane as
//! [`super::membrane`], but bending enters as `∂_ij(β_ij x_ij)` with `β = P` (the moment of the same
//! calibrated coefficients): the unit normal `n` is replaced by `x_ij` and the variation of `n` (the paper's H)
//! is dropped. Its force is not the gradient of an energy; its operator is the lagged secant
//! `Σ D_ijᵀ diag(β⁺) D_ij`, the same for x, y and z.

use super::bending::{Bending, Point};
use super::parallel::{assemble, Local};
use super::Sink;
use crate::math::{diag, Vec3};

/// Adds the Terzopoulos bending force (as a "gradient", i.e. minus the force) and its lagged operator into
/// `sink`; returns the bending energy of the same curvatures (a diagnostic: the force is not its gradient).
/// Large grids are assembled in parallel, with the same result as the serial loop.
pub fn bending(bend: &Bending, x: &[Vec3], sink: &mut Sink) -> f64 {
    assemble(&bend.points, &bend.pool, bend.strides, 0.0, sink, |p, out| point(p, x, out))
}

/// One point's energy, and into `out` its force contributions (one per support node) and lagged operator blocks.
#[inline]
fn point(p: &Point, x: &[Vec3], out: Local) -> f64 {
    let (_a, _b, _nc, vs, kappa) = p.kernels(x);
    let (mom, e) = p.moments(&kappa);
    let len = p.support.len;
    if let Some(g) = out.grad {
        for k in 0..len {
            let mut f = Vec3::ZERO;
            for m in 0..p.count {
                f += vs[m] * (mom[m] * p.v[m][k]);
            }
            g[k] = f;
        }
    }
    if let Some((h, _op)) = out.hess {
        let mut id = 0;
        for k in 0..len {
            for l in k..len {
                let mut s = 0.0;
                for m in 0..p.count {
                    s += mom[m].max(0.0) * p.v[m][k] * p.v[m][l];
                }
                h[id] = diag(s);
                id += 1;
            }
        }
    }
    e
}
