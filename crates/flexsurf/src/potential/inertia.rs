//! The dynamic step's own term: inertia and damping of the central-difference equation (the paper's (46)–(48)),
//! `½ m |y − 2x_t + x⁻|²/Δt² + ¼ c |y − x⁻|²/Δt` per node, whose gradient is
//! `m (y − 2x_t + x⁻)/Δt² + c (y − x⁻)/(2Δt)` and Hessian `(m/Δt² + c/(2Δt)) I`. It reads the motion from the
//! [`Context`]; without one (a static solve) it is zero.

use super::{Context, Part, Scratch, Stage, Term, TermInfo};
use crate::energy::Sink;
use crate::math::{diag, Vec3};

/// Inertia and damping with the lumped masses and damping coefficients of the step's [`super::Motion`].
#[derive(Debug, Clone, Copy)]
pub struct Inertia;

impl Term for Inertia {
    fn info(&self) -> TermInfo {
        TermInfo { name: "inertia", stage: Stage::Inertia, part: Part::Inertia }
    }
    fn evaluate(&self, y: &[Vec3], cx: &Context, _scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let Some(motion) = cx.motion else { return 0.0 };
        let (idt, idt2) = (1.0 / motion.dt, 1.0 / (motion.dt * motion.dt));
        let mut total = 0.0;
        for k in 0..y.len() {
            let (m, c) = (motion.mass[k], motion.damping[k]);
            let (yk, x, xm) = (y[k], motion.x[k], motion.x_prev[k]);
            let a = y[k] - x * 2.0 + xm;
            let b = yk - xm;
            total += 0.5 * m * idt2 * a.length_squared() + 0.25 * c * idt * b.length_squared();
            if let Some(g) = sink.grad.as_deref_mut() {
                g[k] += (yk - x * 2.0 + xm) * (m * idt2);
                g[k] += (yk - xm) * (0.5 * c * idt);
            }
            sink.add_block(cx.diag[k], k, k, diag(m * idt2 + 0.5 * c * idt));
        }
        sink.energy += total;
        total
    }
}
