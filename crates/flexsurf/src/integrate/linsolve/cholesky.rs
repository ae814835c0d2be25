//! Sparse Cholesky from `faer` ([`BlockSolver`]) with the symbolic analysis (AMD ordering of the node graph,
//! elimination tree) done once per run and a numeric factorisation per new matrix. A re-solve after a contact
//! active-set change or a friction re-linearisation ([`Reuse::Nearby`]: a few diagonal blocks changed) first runs
//! conjugate gradients preconditioned by the existing factor and refactorises only if they do not converge within
//! [`Cholesky::MAX_REUSE_ITERATIONS`]. Keeping the factor across steps was measured and rejected
//! (docs/performance.md): the first solve of a step always factorises, so nothing carries over between steps.
//! Those re-solves stop at the tolerance the solve asks for ([`BlockSolver::solve_to`]: the contact steps'
//! [`super::CONTACT_STEP_TOLERANCE`] for the stepper's re-solves against obstacles), or
//! [`super::ITERATIVE_TOLERANCE`] where it asks for none (the static solver, the re-solves of steps with pairs
//! between faces). At 1e-11 many of the contact steps' re-solves ran out of their iterations and
//! refactorised; at 1e-6 the 81² ball drop takes 13 % fewer factorisations (docs/performance.md, "Cholesky's
//! re-solves at the contact steps' tolerance").
//!
//! A matrix with extra blocks outside the static pattern ([`crate::sparse::ExtraBlocks`]) is factorised on the
//! union of both, whose symbolic analysis is redone only when the extra set has changed since the last one.

use super::{BlockSolver, LinearError, Reduced, Reuse, SolveStats, SolverKind};
use crate::math::Vec3;
use crate::sparse::{BlockMatrix, BlockPattern, ExtraBlocks};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, simplicial, supernodal, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::utils::permute_self_adjoint_to_unsorted;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use std::time::Instant;

/// The union of the static pattern and the extra pairs of the generation it was analysed at, and where each
/// of their blocks goes in it.
struct Union {
    generation: usize,
    from_static: Vec<u32>,
    from_extra: Vec<u32>,
    matrix: BlockMatrix,
}

impl Union {
    fn new(pattern: &BlockPattern, extra: &ExtraBlocks) -> (Self, BlockPattern) {
        let cols = pattern.block_cols();
        let static_pairs = pattern.block_rows().iter().copied().zip(cols.iter().copied());
        let union =
            BlockPattern::from_pairs(pattern.nodes(), static_pairs.clone().chain(extra.pairs().iter().copied()));
        let from_static = static_pairs.map(|(i, j)| union.find(i, j) as u32).collect();
        let from_extra = extra.pairs().iter().map(|&(i, j)| union.find(i, j) as u32).collect();
        let matrix = BlockMatrix::zeros(&union);
        (Self { generation: extra.generation(), from_static, from_extra, matrix }, union)
    }

    /// The static blocks and the extra blocks of `a`, summed into the union's blocks.
    fn gather(&mut self, a: &BlockMatrix) {
        let blocks = &mut self.matrix.blocks;
        blocks.fill(crate::math::Mat3::ZERO);
        for (&u, m) in self.from_static.iter().zip(&a.blocks) {
            blocks[u as usize] += *m;
        }
        for (&u, m) in self.from_extra.iter().zip(&a.extra.blocks) {
            blocks[u as usize] += *m;
        }
    }
}

/// `faer` sparse Cholesky with a fixed symbolic structure and a reused factor.
pub struct Cholesky {
    system: Reduced,
    /// The union structure when the matrix has extra blocks.
    union: Option<Union>,
    /// The scalar structure, its analysis and the factor's buffers.
    st: Structure,
    /// Scalar right-hand side / solution of the triangular solves.
    flat: Vec<f64>,
    /// A factor of a recent matrix exists.
    factored: bool,
    /// The nodes without stiffness of the coarsest level of a hierarchy.
    no_fixed: Vec<bool>,
}

impl Cholesky {
    /// Iterations a preconditioned re-solve may take before it refactorises.
    pub const MAX_REUSE_ITERATIONS: usize = 8;

    /// Symbolic analysis of the scalar upper triangle of `pattern`.
    pub fn new(pattern: &BlockPattern) -> Result<Self, LinearError> {
        Ok(Self {
            system: Reduced::new(pattern),
            union: None,
            st: Structure::of(pattern)?,
            flat: vec![0.0; 3 * pattern.nodes()],
            factored: false,
            no_fixed: Vec::new(),
        })
    }

    /// Re-analyses on the union of the static pattern and `a`'s extra pairs when they have changed since the last
    /// analysis; true when it did.
    fn follow_extra(&mut self, a: &BlockMatrix) -> Result<bool, LinearError> {
        let analysed = self.union.as_ref().map_or(0, |u| u.generation);
        if a.extra.generation() == analysed {
            return Ok(false);
        }
        let (union, pattern) = Union::new(self.system.pattern(), &a.extra);
        self.st = Structure::of(&pattern)?;
        self.factored = false;
        self.union = Some(union);
        Ok(true)
    }

    /// Copies `a` into the permuted triangle the factorisation reads ([`Structure`]), with the fixed rows and
    /// columns replaced by the identity (through the union's blocks when the matrix has extra blocks).
    fn fill(&mut self, a: &BlockMatrix, fixed: &[bool]) {
        let a = match self.union.as_mut() {
            Some(u) => {
                u.gather(a);
                &u.matrix
            }
            None => a,
        };
        let st = &mut self.st;
        for ((v, &(blk, e)), &(r, c)) in st.values.iter_mut().zip(&st.src).zip(&st.at) {
            let (r, c) = (r as usize, c as usize);
            *v = if fixed[r / 3] || fixed[c / 3] {
                if r == c {
                    1.0
                } else {
                    0.0
                }
            } else {
                a.blocks[blk as usize].to_cols_array()[e as usize]
            };
        }
    }

    /// The numeric factorisation of the filled triangle, by the supernodal or simplicial kernel the symbolic
    /// analysis chose.
    fn factor(&mut self) -> Result<(), LinearError> {
        let n = self.flat.len();
        let st = &mut self.st;
        let mat = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_unsorted_checked(n, n, &st.col_ptr, None, &st.row_idx),
            &st.values,
        );
        self.factored = false;
        let stack = MemStack::new(&mut st.mem);
        let regularization = LltRegularization::default();
        let result = match st.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                simplicial::factorize_simplicial_numeric_llt(&mut st.l_values, mat, regularization, s, stack)
            }
            SymbolicCholeskyRaw::Supernodal(s) => supernodal::factorize_supernodal_numeric_llt(
                &mut st.l_values,
                mat,
                regularization,
                s,
                Par::Seq,
                stack,
                Default::default(),
            ),
        };
        result.map_err(|e| match e {
            faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                LinearError::NotPositiveDefinite { index }
            }
        })?;
        self.factored = true;
        Ok(())
    }
}

impl Cholesky {
    /// Factorises `a`, the coarsest level of [`super::multigrid`]: its nodes without any stiffness (every
    /// finer node under them pinned) are fixed, so they keep a zero correction.
    pub(crate) fn factorize(&mut self, a: &BlockMatrix) -> Result<(), LinearError> {
        self.follow_extra(a)?;
        let mut none = std::mem::take(&mut self.no_fixed);
        none.clear();
        none.extend((0..self.system.pattern().nodes()).map(|k| {
            let (s, e) = self.system.pattern().column(k);
            a.blocks[e - 1] == crate::math::Mat3::ZERO && s < e
        }));
        self.fill(a, &none);
        let result = self.factor();
        self.no_fixed = none;
        result
    }

    /// Whether `faer`'s analysis chose the supernodal factorisation (the simplicial one otherwise).
    pub fn supernodal(&self) -> bool {
        matches!(self.st.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_))
    }

    /// `x = (L Lᵀ)⁻¹ b` with the current factor.
    pub(crate) fn apply(&mut self, b: &[Vec3], x: &mut [Vec3]) {
        apply_factor(&self.st.symbolic, &self.st.l_values, &mut self.st.mem, &mut self.flat, b, x);
    }
}

/// The scalar structure of a block pattern, its symbolic Cholesky factorisation ([`node_ordering`]) and the
/// buffers sized for it. The triangle is kept already permuted by the ordering, in the form the numeric
/// kernel reads (the lower triangle for a supernodal factor, the upper for a simplicial one): `faer`'s
/// `factorize_numeric_llt` would otherwise permute a copy of it at every factorisation (4.6 % of the 21²
/// drop's time, docs/performance.md).
struct Structure {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Each entry's block and entry (column-major) in the block matrix.
    src: Vec<(u32, u8)>,
    /// Each entry's scalar row and column before the permutation.
    at: Vec<(u32, u32)>,
    values: Vec<f64>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
}

impl Structure {
    fn of(pattern: &BlockPattern) -> Result<Self, LinearError> {
        let (col_ptr, row_idx, src) = pattern.csc_upper();
        let n = 3 * pattern.nodes();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let (fwd, inv) = node_ordering(pattern)?;
        let ordering = SymmetricOrdering::Custom(PermRef::new_checked(&fwd, &inv, n));
        let symbolic = factorize_symbolic_cholesky(sym, Side::Upper, ordering, CholeskySymbolicParams::default())
            .map_err(|e| LinearError::Symbolic(format!("{e:?}")))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let mut mem = MemBuffer::new(req);
        // The permutation applied once, to the entries' own indices (exact in `f64`), tells where each goes.
        let nnz = row_idx.len();
        let index: Vec<f64> = (0..nnz).map(|p| p as f64).collect();
        let side = match symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(_) => Side::Upper,
            SymbolicCholeskyRaw::Supernodal(_) => Side::Lower,
        };
        // The ordering is the node graph's, which the symbolic factorisation keeps as it is.
        let perm = PermRef::new_checked(&fwd, &inv, n);
        let (mut moved, mut new_ptr, mut new_rows) = (vec![0.0; nnz], vec![0usize; n + 1], vec![0usize; nnz]);
        permute_self_adjoint_to_unsorted(
            &mut moved,
            &mut new_ptr,
            &mut new_rows,
            SparseColMatRef::new(sym, &index),
            perm,
            Side::Upper,
            side,
            MemStack::new(&mut mem),
        );
        let mut cols = vec![0u32; nnz];
        for c in 0..n {
            cols[col_ptr[c]..col_ptr[c + 1]].fill(c as u32);
        }
        let (src, at) =
            moved.iter().map(|&v| (src[v as usize], (row_idx[v as usize] as u32, cols[v as usize]))).unzip();
        let (l_values, values) = (vec![0.0; symbolic.len_val()], vec![0.0; nnz]);
        let (col_ptr, row_idx) = (new_ptr, new_rows);
        Ok(Self { col_ptr, row_idx, src, at, values, symbolic, l_values, mem })
    }
}

/// The fill-reducing ordering of the scalar unknowns: AMD on the node graph (one vertex a node, one edge a
/// block), each node's three unknowns kept together in its place. The factor is the scalar graph's AMD's
/// (the same non-zeros on the sheets, the skirts and the T-shirt, docs/performance.md) at a ninth of the
/// ordering's edges, which matters where the analysis is redone as pairs between faces come and go.
fn node_ordering(pattern: &BlockPattern) -> Result<(Vec<usize>, Vec<usize>), LinearError> {
    let n = pattern.nodes();
    let (col_ptr, rows) = pattern.csc_nodes();
    let graph = SymbolicSparseColMatRef::new_checked(n, n, col_ptr, None, rows);
    let (mut perm, mut inv) = (vec![0usize; n], vec![0usize; n]);
    let mut mem = MemBuffer::new(amd::order_scratch::<usize>(n, rows.len()));
    amd::order(&mut perm, &mut inv, graph, amd::Control::default(), MemStack::new(&mut mem))
        .map_err(|e| LinearError::Symbolic(format!("{e:?}")))?;
    let fwd: Vec<usize> = perm.iter().flat_map(|&k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
    let mut inv = vec![0usize; 3 * n];
    for (position, &unknown) in fwd.iter().enumerate() {
        inv[unknown] = position;
    }
    Ok((fwd, inv))
}

/// `out = (L Lᵀ)⁻¹ r` with the factor in `l_values`.
fn apply_factor(
    symbolic: &SymbolicCholesky<usize>,
    l_values: &[f64],
    mem: &mut MemBuffer,
    flat: &mut [f64],
    r: &[Vec3],
    out: &mut [Vec3],
) {
    for (k, v) in r.iter().enumerate() {
        flat[3 * k..3 * k + 3].copy_from_slice(&v.to_array());
    }
    let n = flat.len();
    let llt = LltRef::new(symbolic, l_values);
    llt.solve_in_place_with_conj(
        Conj::No,
        MatMut::from_column_major_slice_mut(flat, n, 1),
        Par::Seq,
        MemStack::new(mem),
    );
    for (k, v) in out.iter_mut().enumerate() {
        *v = Vec3::new(flat[3 * k], flat[3 * k + 1], flat[3 * k + 2]);
    }
}

impl BlockSolver for Cholesky {
    fn solve_to(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        reuse: Reuse,
        tolerance: Option<f64>,
    ) -> Result<SolveStats, LinearError> {
        let t0 = Instant::now();
        let analysed = self.follow_extra(a)?;
        self.system.eliminate(a, fixed, b, x);
        let mut tried = 0;
        if reuse == Reuse::Nearby && self.factored {
            let Self { system, st, flat, .. } = self;
            let Structure { symbolic, l_values, mem, .. } = st;
            apply_factor(symbolic, l_values, mem, flat, system.rhs(), x);
            let result = system.cg(
                a,
                fixed,
                x,
                |r, out| apply_factor(symbolic, l_values, mem, flat, r, out),
                tolerance.unwrap_or(super::ITERATIVE_TOLERANCE),
                Self::MAX_REUSE_ITERATIONS,
            );
            if let Ok(iterations) = result {
                return Ok(SolveStats::since(t0, t0, iterations, false).analysed(analysed));
            }
            tried = Self::MAX_REUSE_ITERATIONS;
        }
        self.fill(a, fixed);
        self.factor()?;
        let t1 = Instant::now();
        let Self { system, st, flat, .. } = self;
        let Structure { symbolic, l_values, mem, .. } = st;
        apply_factor(symbolic, l_values, mem, flat, system.rhs(), x);
        // The failed re-solve's iterations count, and their time is the factorisation's set-up.
        Ok(SolveStats::since(t0, t1, tried, true).analysed(analysed))
    }

    /// Non-zeros of the factor `L`.
    fn factor_nnz(&self) -> usize {
        self.st.symbolic.len_val()
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Cholesky
    }
}
