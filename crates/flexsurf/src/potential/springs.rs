//! Springs holding nodes near targets (the skirt's waist): `½ k |x − target|²` per spring, Hessian `k I`.

use super::{Context, Part, Scratch, Stage, Term, TermInfo};
use crate::energy::Sink;
use crate::math::{diag, Vec3};
use serde::Serialize;

/// A spring holding a node near a target: force `k (target − x)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spring {
    /// Node.
    pub node: usize,
    /// Target point.
    pub target: Vec3,
    /// Stiffness (N/m).
    pub stiffness: f64,
}

/// A set of springs.
#[derive(Debug, Clone, PartialEq)]
pub struct Springs {
    springs: Vec<Spring>,
}

impl Springs {
    /// The springs (nodes and targets validated by the model builder).
    pub fn new(springs: Vec<Spring>) -> Self {
        Self { springs }
    }

    /// Moves the target of spring `index`; `false` when there is no such spring.
    pub fn set_target(&mut self, index: usize, target: Vec3) -> bool {
        match self.springs.get_mut(index) {
            Some(s) => {
                s.target = target;
                true
            }
            None => false,
        }
    }
}

impl Springs {
    /// The springs.
    pub fn springs(&self) -> &[Spring] {
        &self.springs
    }
}

impl Term for Springs {
    fn info(&self) -> TermInfo {
        TermInfo::new("springs", Stage::Attachment, Part::Spring)
    }
    fn evaluate(&self, x: &[Vec3], cx: &Context, _scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let mut total = 0.0;
        for s in &self.springs {
            let e = 0.5 * s.stiffness * (x[s.node] - s.target).length_squared();
            sink.energy += e;
            total += e;
            if let Some(g) = sink.grad.as_deref_mut() {
                g[s.node] += (x[s.node] - s.target) * s.stiffness;
            }
            sink.add_block(cx.diag[s.node], s.node, s.node, diag(s.stiffness));
        }
        total
    }
    /// A spring's force at a thousandth of the sheet's size.
    fn load_scale(&self, length: f64) -> f64 {
        self.springs.iter().map(|s| s.stiffness * length * 1e-3).fold(0.0, f64::max)
    }
}
