//! The discrete elastic energy `E_h` (scheme S) and the Terzopoulos force it is compared with: the kernels of the
//! elastic terms of the total potential ([`crate::potential`]).
//!
//! Each term ([`membrane::Membrane`], [`bending::Bending`]) evaluates value, gradient and Hessian through one
//! private local kernel per quadrature point, so the three cannot drift apart. The Hessian comes in named
//! variants ([`Operator`]): the exact one, the positive semi-definite one used by the implicit step, and the
//! paper's lagged secant operator.

pub mod bending;
pub mod curvature;
pub mod frame;
pub mod membrane;
pub mod nonlinear;
mod parallel;
pub mod terzopoulos;

use crate::math::{Mat3, Vec3};
use crate::sparse::{BlockMatrix, BlockPattern};

/// Which second-derivative operator (Hessian approximation) to assemble. Each term documents what each variant
/// contains for it; `tests/suite/derivatives.rs` checks every one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Operator {
    /// `∇²E_h`, exact (finite-difference tested; may be indefinite).
    Exact,
    /// A positive semi-definite approximation, used by the implicit step and as the static solver's fallback:
    /// for the membrane, Gauss–Newton (`Jᵀ C J`) plus the positive part of each strain's stress (geometric)
    /// stiffness; for bending, Gauss–Newton (`Jᵀ D J` of the curvature changes) alone, the moment's second
    /// derivative term dropped; for the Terzopoulos bending, its lagged operator (docs/model.md §7).
    Projected,
    /// `Projected` with the membrane's negative stress stiffness reflected instead of dropped: each strain's
    /// geometric part `σ (α βᵀ + β αᵀ)` enters as its absolute value (its positive part plus its negative part
    /// with the sign turned), so a compressed fibre keeps the lateral stiffness `|σ|` where the projection leaves
    /// none; equal to `Projected` where every stress is a tension and for every other term. Positive
    /// semi-definite. The step's operator where contact acts (docs/model.md §8.5): the compressed folds of a
    /// draped sheet then stay near their linear model within the step, where the projection lets the linearised
    /// step throw them.
    Reflected,
    /// The paper's lagged-coefficient secant operator: frozen (tension-clamped) stresses and frozen normals,
    /// material stiffness left out (docs/model.md §A7). Used only by the `lagged` integrator.
    Secant,
}

/// Where an evaluation writes: the value (added to `energy`), the gradient (added to), and optionally an
/// operator (added to). With a `journal`, every matrix block changed through [`Sink::add_block`] is first
/// recorded, so that the change can be undone (the contact stage of a step).
pub struct Sink<'a> {
    /// `∂E/∂x`, added to.
    pub grad: Option<&'a mut [Vec3]>,
    /// Second-derivative operator, added to.
    pub hess: Option<(&'a mut BlockMatrix, Operator)>,
    /// Running total of the values of the terms evaluated into this sink.
    pub energy: f64,
    /// Old values of the blocks changed by [`Sink::add_block`].
    pub journal: Option<&'a mut Vec<(u32, Mat3)>>,
}

impl<'a> Sink<'a> {
    /// Energy only.
    pub fn none() -> Self {
        Self { grad: None, hess: None, energy: 0.0, journal: None }
    }
    /// Energy and gradient.
    pub fn grad(g: &'a mut [Vec3]) -> Self {
        Self { grad: Some(g), hess: None, energy: 0.0, journal: None }
    }
    /// Energy, gradient (when given) and an operator.
    pub fn with(g: Option<&'a mut [Vec3]>, h: &'a mut BlockMatrix, op: Operator) -> Self {
        Self { grad: g, hess: Some((h, op)), energy: 0.0, journal: None }
    }

    /// Adds `m` to block `id` (node pair `(a, b)`, see [`BlockMatrix::add`]) of the operator, recording the old
    /// block in the journal when there is one. Does nothing without an operator.
    #[inline]
    pub fn add_block(&mut self, id: u32, a: usize, b: usize, m: Mat3) {
        if let Some((h, _)) = self.hess.as_mut() {
            if let Some(j) = self.journal.as_deref_mut() {
                j.push((id, h.blocks[id as usize]));
            }
            h.add(id, a, b, m);
        }
    }

    /// Adds `m` = ∂²/∂x_a∂x_b for a node pair `a ≠ b` that need not be in the static pattern (the step's
    /// [`crate::sparse::ExtraBlocks`]: contact between faces). Does nothing without an operator. The contact
    /// stage's extra blocks are restored from a copy, not the journal ([`crate::potential::Potential::refine`]).
    #[inline]
    pub fn add_pair(&mut self, a: usize, b: usize, m: Mat3) {
        if let Some((h, _)) = self.hess.as_mut() {
            h.extra.add(a, b, m);
        }
    }
}

/// Block ids for all local pairs `p ≤ q` of a support (row-major over the upper triangle).
pub(crate) fn local_blocks(pattern: &BlockPattern, nodes: &[usize]) -> Vec<u32> {
    let mut ids = Vec::with_capacity(nodes.len() * (nodes.len() + 1) / 2);
    for p in 0..nodes.len() {
        for q in p..nodes.len() {
            ids.push(pattern.find(nodes[p], nodes[q]) as u32);
        }
    }
    ids
}

/// All pairs `p ≤ q` of a support.
pub(crate) fn local_pairs(nodes: &[usize]) -> impl Iterator<Item = (usize, usize)> + '_ {
    (0..nodes.len()).flat_map(move |p| (p..nodes.len()).map(move |q| (nodes[p], nodes[q])))
}
