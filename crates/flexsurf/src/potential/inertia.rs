//! The dynamic step's own term: inertia and damping, `½ m α |y − ŷ|² + ½ c β |y − z|²` per node with the
//! scheme's target `ŷ`, damping centre `z` and coefficients `α`, `β` ([`super::Motion`]), whose gradient is
//! `m α (y − ŷ) + c β (y − z)` and Hessian `(m α + c β) I`. For central differences this is the paper's
//! (46)–(48): gradient `m (y − 2x_t + x⁻)/Δt² + c (y − x⁻)/(2Δt)`. Without a motion (a static solve) it is zero.

use super::{Context, Part, Scratch, Stage, Term, TermInfo};
use crate::energy::Sink;
use crate::math::{diag, Vec3};

/// Inertia and damping with the lumped masses and damping coefficients of the step's [`super::Motion`].
#[derive(Debug, Clone, Copy)]
pub struct Inertia;

impl Term for Inertia {
    fn info(&self) -> TermInfo {
        TermInfo::new("inertia", Stage::Inertia, Part::Inertia)
    }
    fn evaluate(&self, y: &[Vec3], cx: &Context, _scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let Some(motion) = cx.motion else { return 0.0 };
        let (alpha, beta) = (motion.inertia, motion.damp);
        let mut total = 0.0;
        for k in 0..y.len() {
            let (m, c) = (motion.mass[k] * alpha, motion.damping[k] * beta);
            let a = y[k] - motion.target[k];
            let b = y[k] - motion.damp_center[k];
            total += 0.5 * (m * a.length_squared() + c * b.length_squared());
            if let Some(g) = sink.grad.as_deref_mut() {
                g[k] += a * m + b * c;
            }
            sink.add_block(cx.diag[k], k, k, diag(m + c));
        }
        sink.energy += total;
        total
    }
}
