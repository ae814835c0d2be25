//! The step matrix's pattern is the static stencil plus the step's extra block pairs (issue 18): a term may
//! couple nodes that no stencil joins (contact between two faces of the sheet), every linear solver solves
//! the whole matrix, the Cholesky solver redoes its symbolic analysis only when the extra set grows, and a
//! coupling entered as extra blocks gives the step of the same coupling entered in the static pattern.

use flexsurf::energy::Sink;
use flexsurf::grid::Grid;
use flexsurf::integrate::linsolve::{LinearSolver, Reuse, SolverKind};
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::{Mat3, Vec3};
use flexsurf::model::{Model, ModelBuilder, ModelKind, Panel};
use flexsurf::potential::{Context, Part, Scratch, Stage, Term, TermInfo};
use flexsurf::sparse::{BlockMatrix, BlockPattern};
use flexsurf::state::State;

/// Gaussian elimination with partial pivoting on a dense copy: the reference solution, independent of the
/// sparse solvers.
fn dense_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs())).unwrap();
        a.swap(c, p);
        b.swap(c, p);
        let (pivot, below) = a.split_at_mut(c + 1);
        let pivot = &pivot[c];
        for (r, row) in below.iter_mut().enumerate() {
            let f = row[c] / pivot[c];
            for (v, p) in row[c..].iter_mut().zip(&pivot[c..]) {
                *v -= f * p;
            }
            b[c + 1 + r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

/// A 5 × 5 grid's stencil (cells' corners coupled) with an SPD diagonally dominant matrix on it.
fn grid_system() -> (BlockPattern, BlockMatrix, Vec<Vec3>) {
    let g = Grid::sheet(5, 5, 1.0, 1.0).unwrap();
    let pairs: Vec<(usize, usize)> = g
        .cells()
        .flat_map(|(i, j)| {
            let c = g.cell(i, j);
            [(c[0], c[1]), (c[0], c[2]), (c[1], c[3]), (c[2], c[3]), (c[0], c[3])]
        })
        .collect();
    let pattern = BlockPattern::from_pairs(g.len(), pairs.iter().copied());
    let mut a = BlockMatrix::zeros(&pattern);
    for &(i, j) in &pairs {
        let m = Mat3::from_diagonal(Vec3::new(1.0, 0.5, 0.25)) * -0.3;
        a.add(pattern.find(i, j) as u32, i, j, m);
    }
    for k in 0..g.len() {
        a.add(
            pattern.find(k, k) as u32,
            k,
            k,
            Mat3::from_diagonal(Vec3::new(4.0, 3.0, 2.0))
                + Mat3::from_cols_array(&[0.0, 0.1, 0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0]),
        );
    }
    let b = (0..g.len()).map(|k| Vec3::new((k as f64).sin(), 1.0, -0.5 * (k as f64).cos())).collect();
    (pattern, a, b)
}

/// A spring of stiffness `k` between nodes `p` and `q` entered as their two diagonal blocks (in the pattern)
/// and the off-diagonal pair as an extra block.
fn couple(pattern: &BlockPattern, a: &mut BlockMatrix, p: usize, q: usize, k: f64) {
    let m = Mat3::IDENTITY * k;
    a.add(pattern.find(p, p) as u32, p, p, m);
    a.add(pattern.find(q, q) as u32, q, q, m);
    a.extra.add(q, p, -m);
}

fn flat(v: &[Vec3]) -> Vec<f64> {
    v.iter().flat_map(|p| p.to_array()).collect()
}

/// The largest difference of `x` from the dense elimination's solution of `a x = b`.
fn off_dense(pattern: &BlockPattern, a: &BlockMatrix, b: &[Vec3], x: &[Vec3]) -> f64 {
    let reference = dense_solve(a.to_dense(pattern), flat(b));
    flat(x).iter().zip(&reference).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max)
}

/// The grid system ([`grid_system`]: pattern, matrix, right-hand side) with nothing fixed, a Cholesky solver of
/// its pattern and a zero solution to start from.
fn cholesky_of_grid() -> (BlockPattern, BlockMatrix, Vec<Vec3>, Vec<bool>, LinearSolver, Vec<Vec3>) {
    let (pattern, base, b) = grid_system();
    let solver = LinearSolver::new(SolverKind::Cholesky, &pattern, &[]).unwrap();
    (pattern, base, b, vec![false; 25], solver, vec![Vec3::ZERO; 25])
}

#[test]
fn every_solver_solves_the_stencil_plus_the_extra_blocks() {
    let (pattern, mut a, b) = grid_system();
    couple(&pattern, &mut a, 0, 24, 2.0);
    couple(&pattern, &mut a, 3, 20, 1.5);
    let fixed = vec![false; 25];
    let reference = dense_solve(a.to_dense(&pattern), flat(&b));
    let grid = Grid::sheet(5, 5, 1.0, 1.0).unwrap();
    let panels = [Panel::contiguous(grid, 0, grid.flat_positions(0.0))];
    for kind in [SolverKind::Cholesky, SolverKind::Pcg, SolverKind::Multigrid] {
        let mut solver = LinearSolver::new(kind, &pattern, &panels).unwrap();
        let mut x = vec![Vec3::ZERO; 25];
        solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap();
        let err = off_dense(&pattern, &a, &b, &x);
        assert!(err < 1e-9, "{kind:?}: {err:e} from the dense solution");
    }
    // Without the extra blocks the answer is another one: the test sees them.
    let mut plain = a.clone();
    plain.extra = Default::default();
    let other = dense_solve(plain.to_dense(&pattern), flat(&b));
    assert!(other.iter().zip(&reference).any(|(p, q)| (p - q).abs() > 1e-3));
}

#[test]
fn the_analysis_is_redone_only_when_the_extra_set_changes() {
    let (pattern, base, b, fixed, mut solver, mut x) = cholesky_of_grid();
    let mut a = base.clone();
    assert!(!solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap().analysed, "no extra blocks yet");
    couple(&pattern, &mut a, 0, 24, 2.0);
    assert!(solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap().analysed, "a new pair");
    // The next step: the matrix is cleared (the pair stays, zero) and the same pair is coupled again, stiffer.
    a.clear();
    a.blocks.copy_from_slice(&base.blocks);
    couple(&pattern, &mut a, 24, 0, 3.0);
    let stats = solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap();
    assert!(!stats.analysed && stats.factorized, "{stats:?}");
    let err = off_dense(&pattern, &a, &b, &x);
    assert!(err < 1e-9, "{err:e}");
    // A re-solve after a change of the coupling reuses the factor on the same structure.
    let again = solver.solve(&a, &fixed, &b, &mut x, Reuse::Nearby).unwrap();
    assert!(!again.analysed && !again.factorized, "{again:?}");
    couple(&pattern, &mut a, 7, 17, 1.0);
    assert!(solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap().analysed, "a second pair");
}

/// Pairs that no term coupled in the last assembly leave the set once they are the majority: the structure is
/// analysed again without them (its factor as small as if they had never been), the solution is the dense one,
/// and while the pairs left at zero are at most half of the set nothing changes.
#[test]
fn pairs_left_at_zero_are_pruned_once_they_are_the_majority() {
    let (pattern, base, b, fixed, mut solver, mut x) = cholesky_of_grid();
    let mut a = base.clone();
    solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap();
    let plain = solver.factor_nnz();
    for (p, q) in [(0, 24), (3, 20), (4, 21), (1, 23)] {
        couple(&pattern, &mut a, p, q, 2.0);
    }
    assert!(solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap().analysed);
    let coupled = solver.factor_nnz();
    assert!(coupled > plain, "the far couplings add fill: {coupled} against {plain}");
    // The next assembly couples two of the four again: half the set is live, nothing is pruned.
    let refill = |a: &mut BlockMatrix, pairs: &[(usize, usize)]| {
        a.clear();
        a.blocks.copy_from_slice(&base.blocks);
        for &(p, q) in pairs {
            couple(&pattern, a, p, q, 3.0);
        }
    };
    refill(&mut a, &[(0, 24), (3, 20)]);
    let generation = a.extra.generation();
    assert!(!a.extra.prune());
    assert_eq!(a.extra.generation(), generation);
    assert_eq!(a.extra.pairs().len(), 4);
    // One live pair of four: the three others go, and the solver analyses the smaller structure.
    refill(&mut a, &[(3, 20)]);
    assert!(a.extra.prune());
    assert_ne!(a.extra.generation(), generation);
    assert_eq!(a.extra.pairs(), &[(3, 20)]);
    let stats = solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap();
    assert!(stats.analysed && stats.factorized, "{stats:?}");
    assert!(solver.factor_nnz() < coupled);
    let err = off_dense(&pattern, &a, &b, &x);
    assert!(err < 1e-9, "{err:e}");
    // A pruned pair that comes back is a new pair.
    couple(&pattern, &mut a, 0, 24, 1.0);
    assert!(solver.solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap().analysed);
}

/// A spring joining two nodes of the sheet that no stencil joins: its off-diagonal Hessian block goes into the
/// step's extra blocks (`dynamic`) or, for the reference, into the static pattern through `pairs`.
#[derive(Debug, Clone)]
struct Tether {
    ends: (usize, usize),
    stiffness: f64,
    dynamic: bool,
    ids: [u32; 3],
}

impl Term for Tether {
    fn info(&self) -> TermInfo {
        TermInfo::new("tether", Stage::Attachment, Part::Spring)
    }
    fn pairs(&self) -> Vec<(usize, usize)> {
        if self.dynamic {
            Vec::new()
        } else {
            vec![self.ends]
        }
    }
    fn bind(&mut self, pattern: &BlockPattern) {
        let (p, q) = self.ends;
        self.ids[0] = pattern.find(p, p) as u32;
        self.ids[1] = pattern.find(q, q) as u32;
        if !self.dynamic {
            self.ids[2] = pattern.find(p, q) as u32;
        }
    }
    fn evaluate(&self, x: &[Vec3], _cx: &Context, _s: &mut Scratch, sink: &mut Sink) -> f64 {
        let (p, q) = self.ends;
        let d = x[q] - x[p];
        let e = 0.5 * self.stiffness * d.length_squared();
        sink.energy += e;
        if let Some(g) = sink.grad.as_deref_mut() {
            g[p] -= d * self.stiffness;
            g[q] += d * self.stiffness;
        }
        let m = Mat3::IDENTITY * self.stiffness;
        sink.add_block(self.ids[0], p, p, m);
        sink.add_block(self.ids[1], q, q, m);
        if self.dynamic {
            sink.add_pair(p, q, -m);
        } else {
            sink.add_block(self.ids[2], p, q, -m);
        }
        e
    }
}

/// A 9 × 9 sheet hanging from two corners, its two free corners tied together by a tether.
fn tied(dynamic: bool) -> (Model, State) {
    let fabric = Fabric::paper_cotton();
    let stiffness = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
    let grid = Grid::sheet(9, 9, 0.5, 0.5).unwrap();
    let rest = grid.flat_positions(1.0);
    let mut b = ModelBuilder::new(grid, rest.clone(), fabric, stiffness, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81));
    b.pinned[grid.index(0, 8)] = true;
    b.pinned[grid.index(8, 8)] = true;
    let ends = (grid.index(0, 0), grid.index(8, 0));
    b.extra_terms.push(Box::new(Tether { ends, stiffness: 2.0, dynamic, ids: [0; 3] }));
    (b.build().unwrap(), State::at_rest(rest))
}

#[test]
fn a_coupling_in_the_extra_blocks_steps_as_the_same_coupling_in_the_pattern() {
    let ((dynamic, mut a), (fixed, mut b)) = (tied(true), tied(false));
    assert!(dynamic.potential.pattern().blocks() < fixed.potential.pattern().blocks());
    let params = StepParams { solver: SolverKind::Cholesky, ..StepParams::with_dt(0.01) };
    let (mut sa, mut sb) = (Stepper::new(&dynamic, &params).unwrap(), Stepper::new(&fixed, &params).unwrap());
    for _ in 0..60 {
        sa.step(&dynamic, &mut a).unwrap();
        sb.step(&fixed, &mut b).unwrap();
    }
    let diff = a.x.iter().zip(&b.x).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
    assert!(diff < 1e-12, "the two couplings differ by {diff:e} m");
    // The tether pulled the free corners together (it acts).
    let (p, q) = (0, 8);
    let gap = (a.x[q] - a.x[p]).length();
    assert!(gap < 0.45, "corners {gap} m apart");
}
