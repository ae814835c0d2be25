//! Gravity and constant nodal loads: the potential `−Σ f_k·x_k` of the fixed forces `f_k = m_k g + p_k`
//! (the paper's `p`); zero Hessian.

use super::{Context, Part, Scratch, Stage, Term, TermInfo};
use crate::energy::Sink;
use crate::math::Vec3;

/// Constant external forces on the nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct External {
    force: Vec<Vec3>,
    /// Each node's weight or load, the larger (N).
    nodal: Vec<f64>,
    weight_scale: f64,
    load_scale: f64,
}

impl External {
    /// Gravity `g` on the lumped masses `mass` plus the loads `loads` (N).
    pub fn new(gravity: Vec3, mass: &[f64], loads: &[Vec3]) -> Self {
        let force = mass.iter().zip(loads).map(|(&m, &p)| gravity * m + p).collect();
        let nodal = mass.iter().zip(loads).map(|(&m, p)| (gravity * m).length().max(p.length())).collect();
        let weight_scale = mass.iter().map(|&m| (gravity * m).length()).fold(0.0, f64::max);
        let load_scale = loads.iter().map(|p| p.length()).fold(0.0, f64::max);
        Self { force, nodal, weight_scale, load_scale }
    }

    /// The force on each node (N).
    pub fn forces(&self) -> &[Vec3] {
        &self.force
    }

    /// Each node's weight `|m_k g|` or load `|p_k|`, the larger (N): the largest over a panel's nodes is the
    /// scale of the contact steps' correction threshold ([`crate::integrate::StepParams::contact_correction`]).
    pub fn nodal_scales(&self) -> &[f64] {
        &self.nodal
    }
}

impl Term for External {
    fn info(&self) -> TermInfo {
        TermInfo::new("gravity and loads", Stage::Field, Part::Load)
    }
    fn evaluate(&self, x: &[Vec3], _cx: &Context, _scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let v = -(0..x.len()).map(|k| self.force[k].dot(x[k])).sum::<f64>();
        if let Some(g) = sink.grad.as_deref_mut() {
            for (gk, f) in g.iter_mut().zip(&self.force) {
                *gk -= *f;
            }
        }
        sink.energy += v;
        v
    }
    /// The largest nodal weight or load.
    fn load_scale(&self, _length: f64) -> f64 {
        self.weight_scale.max(self.load_scale)
    }
}
