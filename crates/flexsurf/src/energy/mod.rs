//! The discrete energy `E_h` of MODEL.md §2 and §4 (scheme S) and the Terzopoulos force it is compared with.
//!
//! Each term ([`membrane::Membrane`], [`bending::Bending`]) evaluates value, gradient and Hessian through one
//! private local kernel per quadrature point, so the three cannot drift apart. The Hessian comes in named
//! variants ([`Operator`]): the exact one, the positive semi-definite one used by the implicit step, and the
//! paper's lagged secant operator.

pub mod bending;
pub mod curvature;
pub mod frame;
pub mod membrane;
pub mod terzopoulos;

use crate::math::Vec3;
use crate::sparse::{BlockMatrix, BlockPattern};

/// Which second-derivative operator to assemble.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Operator {
    /// `∇²E_h`, exact (finite-difference tested; may be indefinite).
    Exact,
    /// `H⁺`: Gauss–Newton (`Jᵀ C J`) plus the positive part of each quadrature point's stress (geometric)
    /// stiffness; positive semi-definite by construction (MODEL.md §5).
    Projected,
    /// The paper's lagged-coefficient secant operator: frozen (tension-clamped) stresses and frozen normals,
    /// material stiffness left out (AUDIT.md §4). Used only by the `lagged` integrator.
    Secant,
}

/// Where an evaluation writes: the gradient (added to), and optionally an operator (added to).
pub struct Sink<'a> {
    /// `∂E/∂x`, added to.
    pub grad: Option<&'a mut [Vec3]>,
    /// Second-derivative operator, added to.
    pub hess: Option<(&'a mut BlockMatrix, Operator)>,
}

impl<'a> Sink<'a> {
    /// Energy only.
    pub fn none() -> Self {
        Self { grad: None, hess: None }
    }
    /// Energy and gradient.
    pub fn grad(g: &'a mut [Vec3]) -> Self {
        Self { grad: Some(g), hess: None }
    }
}

/// One term of the discrete energy, defined on the nodes of a grid.
pub trait Energy {
    /// The node pairs whose Hessian block this term touches.
    fn pairs(&self) -> Vec<(usize, usize)>;
    /// Precomputes block ids for a pattern that contains [`Energy::pairs`].
    fn bind(&mut self, pattern: &BlockPattern);
    /// Adds gradient and operator into `sink`; returns the energy.
    fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> f64;
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
