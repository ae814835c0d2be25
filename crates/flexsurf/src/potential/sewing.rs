//! The sewing phase's term: springs between the node pairs of the seams still open, pulling each pair of edges
//! together before the model joins them ([`crate::garment::sewing`]). Each pair's spring has a rest length
//! `r = f r₀` that the phase shrinks from the pair's placed gap `r₀` to 0 (the fraction `f` from 1 to 0,
//! [`Sewing::set_fraction`]), and pulls only when stretched beyond it: energy `½ k (|d| − r)²` for `|d| > r`,
//! 0 below (`d = x_a − x_b`), so a seam closes as fast as its rest length shrinks and no faster. Its pairs are in
//! the static pattern (they are fixed for the phase); its Hessian is exact where `|d| ≠ r`:
//! `k [(1 − r/|d|) I + (r/|d|) n nᵀ]` (positive definite for `|d| > r`) in the blocks `[H −H; −H H]`, and with
//! `r = 0` the zero-length spring `k [I −I; −I I]`.

use super::{Context, Part, Scratch, Stage, Term, TermInfo};
use crate::energy::Sink;
use crate::math::{diag, outer, Vec3};
use crate::sparse::BlockPattern;

/// Springs between node pairs with shrinking rest lengths.
#[derive(Debug, Clone, PartialEq)]
pub struct Sewing {
    pairs: Vec<(usize, usize)>,
    /// Each pair's full rest length `r₀` (m): its placed gap, or 0.
    rest: Vec<f64>,
    /// The fraction `f` of the full rest lengths in force.
    fraction: f64,
    stiffness: f64,
    /// Block ids of `(a, a)`, `(b, b)`, `(a, b)` per pair, once bound.
    ids: Vec<[u32; 3]>,
}

impl Sewing {
    /// Zero-length springs of `stiffness` (N/m) between each pair of distinct nodes.
    pub fn new(pairs: Vec<(usize, usize)>, stiffness: f64) -> Self {
        let pairs: Vec<(usize, usize)> = pairs.into_iter().filter(|(a, b)| a != b).collect();
        Self { rest: vec![0.0; pairs.len()], pairs, fraction: 0.0, stiffness, ids: Vec::new() }
    }

    /// Springs whose full rest lengths are the pairs' distances at `x` (pairs naming a node outside `x` get 0),
    /// all of it in force (`f = 1`): at `x` the springs pull nothing, and shrinking `f` closes the seams.
    pub fn closing(pairs: Vec<(usize, usize)>, stiffness: f64, x: &[Vec3]) -> Self {
        let mut s = Self::new(pairs, stiffness);
        let gap = |&(a, b): &(usize, usize)| match (x.get(a), x.get(b)) {
            (Some(p), Some(q)) => (*p - *q).length(),
            _ => 0.0,
        };
        s.rest = s.pairs.iter().map(gap).collect();
        s.fraction = 1.0;
        s
    }

    /// Sets the fraction of the full rest lengths in force (clamped to `[0, 1]`; 0: zero-length springs).
    pub fn set_fraction(&mut self, fraction: f64) {
        self.fraction = if fraction.is_finite() { fraction.clamp(0.0, 1.0) } else { 0.0 };
    }

    /// The node pairs.
    pub fn node_pairs(&self) -> &[(usize, usize)] {
        &self.pairs
    }

    /// The largest distance between the two nodes of a pair at `x` (m; 0 without pairs).
    pub fn largest_gap(&self, x: &[Vec3]) -> f64 {
        self.pairs.iter().map(|&(a, b)| (x[a] - x[b]).length()).fold(0.0, f64::max)
    }

    /// The largest full rest length (m): the widest placed gap of a closing phase.
    pub fn largest_rest(&self) -> f64 {
        self.rest.iter().copied().fold(0.0, f64::max)
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
            let (length, r) = (d.length(), self.fraction * self.rest[n]);
            if length <= r {
                continue;
            }
            let stretch = length - r;
            total += 0.5 * k * stretch * stretch;
            // r < length, so length > 0 whenever r > 0; a zero-length spring's force is k d.
            let (force, block) = if r > 0.0 {
                let u = d / length;
                (u * (k * stretch), diag(k * (1.0 - r / length)) + outer(u, u) * (k * r / length))
            } else {
                (d * k, diag(k))
            };
            if let Some(g) = sink.grad.as_deref_mut() {
                g[a] += force;
                g[b] -= force;
            }
            if let Some(&[aa, bb, ab]) = self.ids.get(n) {
                sink.add_block(aa, a, a, block);
                sink.add_block(bb, b, b, block);
                sink.add_block(ab, a, b, -block);
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
