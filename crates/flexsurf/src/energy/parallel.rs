//! Parallel assembly of the elastic kernels whose result does not depend on the number of threads.
//!
//! A kernel is a loop over quadrature items (membrane cells, bending points), each adding its energy, one
//! gradient contribution per node of its support and one operator block per local pair `p ≤ q` into a
//! [`Sink`]. [`assemble`] runs that loop in batches of [`BATCH`] items (a constant, not a function of the
//! thread count): the items of a batch compute their local results in parallel into reused per-item buffers,
//! then the batch is added into the sink serially, in item order, while the next batch is computed. Every sum
//! therefore receives the same terms in the same order as the plain serial loop, and the result is bit for bit
//! that of the serial loop whatever the thread count. Below [`PARALLEL_MIN`] items, or on one thread, the plain
//! serial loop runs (the same additions in the same order, without the buffers).
//!
//! The serial addition is what bounds the speed-up: it is about a quarter of the single-threaded work at 161²
//! (a third at 321², where the gradient and the matrix no longer fit in cache).

use super::{Operator, Sink};
use crate::math::{Mat3, Vec3};
use crate::ops::MAX_SUPPORT;
use rayon::prelude::*;
use std::sync::{Mutex, TryLockError};

/// Items per batch of the parallel assembly (independent of the thread count).
pub(crate) const BATCH: usize = 4096;

/// Fewer items than this run the plain serial loop.
pub(crate) const PARALLEL_MIN: usize = 2048;

/// Items handed to one rayon task at least (the per-item work is a fraction of a microsecond).
const MIN_TASK: usize = 64;

/// Most operator blocks of one item: the pairs `p ≤ q` of the largest support.
pub(crate) const MAX_BLOCKS: usize = MAX_SUPPORT * (MAX_SUPPORT + 1) / 2;

/// A quadrature item: the nodes of its support and the ids of its operator blocks (row-major over the pairs
/// `p ≤ q` of the support, see [`super::local_blocks`]).
pub(crate) trait Item: Sync {
    /// The support's global node indices.
    fn nodes(&self) -> &[usize];
    /// The block ids of the local pairs.
    fn blocks(&self) -> &[u32];
    /// Sets them ([`bind`]).
    fn set_blocks(&mut self, blocks: Vec<u32>);
}

/// The node pairs whose Hessian blocks `items` touch (every local pair of every support): a kernel's
/// [`crate::potential::Term::pairs`].
pub(crate) fn pairs<T: Item>(items: &[T]) -> Vec<(usize, usize)> {
    items.iter().flat_map(|i| super::local_pairs(i.nodes()).collect::<Vec<_>>()).collect()
}

/// Precomputes the block ids of every item's local pairs in a pattern that contains [`pairs`].
pub(crate) fn bind<T: Item>(items: &mut [T], pattern: &crate::sparse::BlockPattern) {
    for i in items {
        let blocks = super::local_blocks(pattern, i.nodes());
        i.set_blocks(blocks);
    }
}

/// What one item's kernel is asked for: its gradient contributions (one per support node, `grad[k]` for
/// node `k`, overwritten) and its operator blocks (one per local pair, in [`Item::blocks`] order,
/// overwritten); `None` where the sink does not want them. The kernel returns the item's energy.
pub(crate) struct Local<'b> {
    /// Gradient contributions, when wanted.
    pub grad: Option<&'b mut [Vec3]>,
    /// Operator blocks and the operator, when wanted.
    pub hess: Option<(&'b mut [Mat3], Operator)>,
}

impl Local<'_> {
    /// Energy only is asked for.
    #[inline]
    pub fn energy_only(&self) -> bool {
        self.grad.is_none() && self.hess.is_none()
    }
}

/// The per-item results of one batch.
#[derive(Default)]
struct Buffers {
    energy: Vec<f64>,
    grad: Vec<Vec3>,
    blocks: Vec<Mat3>,
}

/// Batch buffers (two: one being added into the sink while the next batch is computed into the other) owned by
/// a kernel and reused between evaluations (no allocation per step once they have
/// grown). A copy of the kernel starts with empty buffers. When two evaluations of one kernel run at the same
/// time, the second uses buffers of its own.
#[derive(Default)]
pub(crate) struct Pool(Mutex<[Buffers; 2]>);

impl Clone for Pool {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for Pool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Pool")
    }
}

/// Adds an item's local results into the sink (gradient, then operator blocks), as the serial kernels did.
#[inline]
fn scatter<T: Item>(item: &T, grad: &[Vec3], blocks: &[Mat3], sink: &mut Sink) {
    let nodes = item.nodes();
    if let Some(g) = sink.grad.as_deref_mut() {
        for (k, &node) in nodes.iter().enumerate() {
            g[node] += grad[k];
        }
    }
    if let Some((h, _)) = sink.hess.as_mut() {
        let ids = item.blocks();
        let mut id = 0;
        for k in 0..nodes.len() {
            for l in k..nodes.len() {
                h.add(ids[id], nodes[k], nodes[l], blocks[id]);
                id += 1;
            }
        }
    }
}

/// Runs `kernel` over `items` into `sink` (gradient and operator added to; `sink.energy` untouched) and
/// returns the energy, summed in item order starting from `start`. `strides` are the most gradient
/// contributions and operator blocks of one item (at most [`MAX_SUPPORT`] and [`MAX_BLOCKS`]). The result is
/// bit-identical to the serial loop `for item { e += kernel(item); add its results }` for any thread count.
pub(crate) fn assemble<T, K>(
    items: &[T],
    pool: &Pool,
    strides: (usize, usize),
    start: f64,
    sink: &mut Sink,
    kernel: K,
) -> f64
where
    T: Item,
    K: Fn(&T, Local) -> f64 + Sync,
{
    let want_grad = sink.grad.is_some();
    let op = sink.hess.as_ref().map(|(_, op)| *op);
    let mut energy = start;
    if items.len() < PARALLEL_MIN || rayon::current_num_threads() == 1 {
        let mut grad = [Vec3::ZERO; MAX_SUPPORT];
        let mut blocks = [Mat3::ZERO; MAX_BLOCKS];
        for item in items {
            let local = Local { grad: want_grad.then_some(&mut grad[..]), hess: op.map(|op| (&mut blocks[..], op)) };
            energy += kernel(item, local);
            scatter(item, &grad, &blocks, sink);
        }
        return energy;
    }
    // Strides of the buffers; 1 (an unused slot per item) for what is not wanted.
    let gs = if want_grad { strides.0 } else { 1 };
    let hs = if op.is_some() { strides.1 } else { 1 };
    let mut own = None;
    let mut guard = match pool.0.try_lock() {
        Ok(g) => Some(g),
        Err(TryLockError::Poisoned(p)) => Some(p.into_inner()),
        Err(TryLockError::WouldBlock) => None,
    };
    let bufs: &mut [Buffers; 2] = match guard.as_deref_mut() {
        Some(b) => b,
        None => own.insert(Default::default()),
    };
    let n = BATCH.min(items.len());
    for buf in bufs.iter_mut() {
        fit(&mut buf.energy, n, 0.0);
        fit(&mut buf.grad, n * gs, Vec3::ZERO);
        fit(&mut buf.blocks, n * hs, Mat3::ZERO);
    }
    let compute = |batch: &[T], buf: &mut Buffers| {
        let n = batch.len();
        let (e, g, h) = (&mut buf.energy[..n], &mut buf.grad[..n * gs], &mut buf.blocks[..n * hs]);
        batch
            .par_iter()
            .zip(e.par_iter_mut())
            .zip(g.par_chunks_mut(gs))
            .zip(h.par_chunks_mut(hs))
            .with_min_len(MIN_TASK)
            .for_each(|(((item, e), g), h)| {
                let local = Local { grad: want_grad.then_some(g), hess: op.map(|op| (h, op)) };
                *e = kernel(item, local);
            });
    };
    // Batch `b` is added into the sink (serially, in item order) while batch `b + 1` is computed into the
    // other buffer: the thread adding it joins the computation when done.
    let batches = items.len().div_ceil(BATCH);
    let batch = |b: usize| &items[b * BATCH..((b + 1) * BATCH).min(items.len())];
    compute(batch(0), &mut bufs[0]);
    for b in 0..batches {
        let [even, odd] = bufs;
        let (done, next) = if b % 2 == 0 { (&*even, odd) } else { (&*odd, even) };
        let add = |sink: &mut Sink| {
            let mut energy = energy;
            for (i, item) in batch(b).iter().enumerate() {
                energy += done.energy[i];
                scatter(item, &done.grad[i * gs..(i + 1) * gs], &done.blocks[i * hs..(i + 1) * hs], sink);
            }
            energy
        };
        energy = if b + 1 < batches { rayon::join(|| add(sink), || compute(batch(b + 1), next)).0 } else { add(sink) };
    }
    energy
}

/// Grows `v` to at least `len` entries (never shrinks: the buffers are reused).
fn fit<V: Copy>(v: &mut Vec<V>, len: usize, zero: V) {
    if v.len() < len {
        v.resize(len, zero);
    }
}
