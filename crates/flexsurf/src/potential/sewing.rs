//! The sewing phase's term: zero-length springs `½ k |x_a − x_b|²` between the node pairs of the seams still
//! open, pulling each pair of edges together before the model joins them ([`crate::garment::sewing`]). Its
//! pairs are in the static pattern (they are fixed for the phase); its Hessian is exact, `k [I −I; −I I]`.

use super::{Context, Part, Scratch, Stage, Term, TermInfo};
use crate::energy::Sink;
use crate::math::{diag, Vec3};
use crate::sparse::BlockPattern;

/// Zero-length springs between node pairs.
#[derive(Debug, Clone, PartialEq)]
pub struct Sewing {
    pairs: Vec<(usize, usize)>,
    stiffness: f64,
    /// Block ids of `(a, a)`, `(b, b)`, `(a, b)` per pair, once bound.
    ids: Vec<[u32; 3]>,
}

impl Sewing {
    /// Springs of `stiffness` (N/m) between each pair of distinct nodes.
    pub fn new(pairs: Vec<(usize, usize)>, stiffness: f64) -> Self {
        let pairs = pairs.into_iter().filter(|(a, b)| a != b).collect();
        Self { pairs, stiffness, ids: Vec::new() }
    }

    /// The node pairs.
    pub fn node_pairs(&self) -> &[(usize, usize)] {
        &self.pairs
    }

    /// The largest distance between the two nodes of a pair at `x` (m; 0 without pairs).
    pub fn largest_gap(&self, x: &[Vec3]) -> f64 {
        self.pairs.iter().map(|&(a, b)| (x[a] - x[b]).length()).fold(0.0, f64::max)
    }
}

impl Term for Sewing {
    fn info(&self) -> TermInfo {
        TermInfo::new("sewing", Stage::Attachment, Part::Spring)
    }
    fn pairs(&self) -> Vec<(usize, usize)> {
        self.pairs.clone()
    }
    fn bind(&mut self, pattern: &BlockPattern) {
        let id = |i: usize, j: usize| pattern.find(i, j) as u32;
        self.ids = self.pairs.iter().map(|&(a, b)| [id(a, a), id(b, b), id(a, b)]).collect();
    }
    fn evaluate(&self, x: &[Vec3], _cx: &Context, _scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let k = self.stiffness;
        let mut total = 0.0;
        for (n, &(a, b)) in self.pairs.iter().enumerate() {
            let d = x[a] - x[b];
            total += 0.5 * k * d.length_squared();
            if let Some(g) = sink.grad.as_deref_mut() {
                g[a] += d * k;
                g[b] -= d * k;
            }
            if let Some(&[aa, bb, ab]) = self.ids.get(n) {
                sink.add_block(aa, a, a, diag(k));
                sink.add_block(bb, b, b, diag(k));
                sink.add_block(ab, a, b, diag(-k));
            }
        }
        sink.energy += total;
        total
    }
    /// A pair's force at a thousandth of the sheet's size.
    fn load_scale(&self, length: f64) -> f64 {
        self.stiffness * length * 1e-3
    }
}
