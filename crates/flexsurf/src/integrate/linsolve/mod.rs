//! The step's sparse symmetric positive definite solve, the last stage of a step in [`crate::integrate`]: a
//! [`LinearSolver`] bound to the model's block pattern (and grid) solves `A x = b` with the fixed (pinned)
//! unknowns eliminated symmetrically, so the matrix stays SPD. Each solver is a [`BlockSolver`] in its own file:
//!
//! - [`cholesky`]: sparse Cholesky from `faer`, the symbolic analysis (AMD ordering, elimination tree) done once
//!   per run; a factor is kept across solves and steps as the preconditioner of conjugate gradients until they
//!   need too many iterations, then the matrix is refactorised (docs/performance.md);
//! - [`multigrid`]: conjugate gradients preconditioned by a geometric multigrid cycle (V, or W from six levels)
//!   on the parametric grid's hierarchy (Galerkin coarse operators, symmetric block Gauss–Seidel smoothing,
//!   Cholesky on the coarsest level): memory and work proportional to the number of nodes;
//! - [`pcg`]: block-Jacobi preconditioned conjugate gradients (a reference, slow on stiff sheets);
//! - [`auto`]: the automatic choice on mid-size grids, Cholesky for the steps with contact and multigrid for
//!   those without.
//!
//! [`cg`] is the one conjugate-gradient loop they share. A new solver is one file implementing [`BlockSolver`],
//! a [`SolverKind`] variant and its arm in [`SolverKind::solver`].

pub mod auto;
pub mod cg;
pub mod cholesky;
pub mod lines;
pub mod multigrid;
pub mod pcg;

use crate::math::Vec3;
use crate::model::Panel;
use crate::sparse::{BlockMatrix, BlockPattern};
use serde::{Deserialize, Serialize};
use thiserror::Error;

pub use auto::Auto;
pub use cholesky::Cholesky;
pub use multigrid::Multigrid;
pub use pcg::Pcg;

/// Failure of the linear solve.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum LinearError {
    /// The symbolic analysis failed (out of memory).
    #[error("symbolic factorisation failed: {0}")]
    Symbolic(String),
    /// The matrix was not numerically positive definite.
    #[error(
        "the step matrix is not positive definite (pivot {index} of its factorisation): in a static solve part of \
         the sheet is free to move (pin it or hold it by springs); in a time step a position or coefficient is not \
         finite"
    )]
    NotPositiveDefinite {
        /// Failing column.
        index: usize,
    },
    /// Conjugate gradients did not reach the tolerance.
    #[error("conjugate gradients did not converge: residual {residual:.3e} after {iters} iterations")]
    NotConverged {
        /// Iterations made.
        iters: usize,
        /// Relative residual reached.
        residual: f64,
    },
}

/// Which linear solver the step uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "app", derive(schemars::JsonSchema))]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SolverKind {
    /// [`SolverKind::Cholesky`] up to [`AUTO_MULTIGRID_NODES`] nodes, [`SolverKind::Multigrid`] above; from
    /// [`AUTO_FREE_MOTION_NODES`] nodes some steps take multigrid too: those without contact that Newton
    /// corrects, and from [`AUTO_CONTACT_ITERATIVE_NODES`] those with contact while its iterations stay low
    /// ([`auto`]). The default; docs/performance.md.
    #[default]
    #[cfg_attr(
        feature = "clap",
        value(help = "Cholesky on small grids, multigrid on large ones; on mid-size ones each step on the one its \
                      kind and the steps before it favour")
    )]
    Auto,
    /// Sparse Cholesky, its factor reused across steps as a preconditioner.
    Cholesky,
    /// Multigrid-preconditioned conjugate gradients on the grid hierarchy.
    Multigrid,
    /// Block-Jacobi preconditioned conjugate gradients.
    Pcg,
}

/// Grids with more nodes than this take the multigrid solver under [`SolverKind::Auto`] for every step; below
/// it, from [`AUTO_FREE_MOTION_NODES`], `auto` holds Cholesky and multigrid and gives each step to one of them
/// ([`auto::Auto`]). Cholesky's factor needs 1.9 GB at 321² (103,041 nodes) against multigrid's 0.9 GB, and a
/// sheet touching the ball there took 7.5 s a step on Cholesky against 6.1–6.8 s on multigrid
/// (docs/performance.md, "Which solver `auto` takes").
pub const AUTO_MULTIGRID_NODES: usize = 90_000;

/// Grids with more nodes than this (and up to [`AUTO_MULTIGRID_NODES`]) give every step without contact to
/// multigrid under [`SolverKind::Auto`], the first and those one exact solve converges (a free fall) included:
/// three inexact solves cost about as much as one factorisation there. The ball drop's first 6 steps
/// (`flexsurf bench --sizes N --steps 6`, docs/performance.md) took 6.32, 7.00 and 11.62 s on Cholesky against
/// 4.94, 7.50 and 11.09 s on multigrid at 201², 241² and 281²; 8 steps at 161² 3.36 against 4.09 s.
pub const AUTO_FREE_ITERATIVE_NODES: usize = 32_000;

/// Grids with at least this many nodes (and up to [`AUTO_MULTIGRID_NODES`]) give their steps with contact to
/// multigrid under [`SolverKind::Auto`] while its iterations a solve stay low ([`auto::contact_iterations_limit`]),
/// to Cholesky otherwise. Below, Cholesky takes every step with contact: at 81² multigrid was faster only on the
/// five steps after the ball drop's sheet landed (0.43 against 0.67 s), slower on the others.
pub const AUTO_CONTACT_ITERATIVE_NODES: usize = 10_000;

/// Grids with at least this many nodes (and up to [`AUTO_MULTIGRID_NODES`]) take the multigrid solver under
/// [`SolverKind::Auto`] for their steps without contact that Newton's method corrects, Cholesky for the others
/// ([`auto::Auto`]). Measured on a sheet tumbling freely (docs/performance.md, "Which solver `auto` takes"): the
/// two are even at 41² (1,681 nodes), multigrid is 1.4× faster at 51² (2,601) and 2.2× at 81².
pub const AUTO_FREE_MOTION_NODES: usize = 2_500;

impl SolverKind {
    /// Name as in scene files and summaries.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Auto => "auto",
            SolverKind::Cholesky => "cholesky",
            SolverKind::Multigrid => "multigrid",
            SolverKind::Pcg => "pcg",
        }
    }

    /// The concrete solver of a grid of `nodes` nodes ([`SolverKind::Auto`] resolved, the others as they are):
    /// [`SolverKind::Cholesky`] for `auto` up to [`AUTO_MULTIGRID_NODES`], which from [`AUTO_FREE_MOTION_NODES`]
    /// holds multigrid too for some of the steps ([`auto::Auto`]).
    pub fn resolve(self, nodes: usize) -> SolverKind {
        match self {
            SolverKind::Auto if nodes > AUTO_MULTIGRID_NODES => SolverKind::Multigrid,
            SolverKind::Auto => SolverKind::Cholesky,
            k => k,
        }
    }

    /// Whether the solves of this (concrete) kind are iterative, so that they honour a tolerance
    /// ([`BlockSolver::solve_to`]).
    pub fn iterative(self) -> bool {
        matches!(self, SolverKind::Multigrid | SolverKind::Pcg)
    }

    /// The name of the solvers a run took, `self` being the one it resolved to ([`SolverKind::resolve`]),
    /// `iterative_steps` of its `steps` steps on an iterative solver (`Counters::iterative_steps`):
    /// `cholesky+multigrid` where the automatic choice gave some but not all of them to multigrid, `multigrid`
    /// where it gave it all, else `self`'s name.
    pub fn used(self, iterative_steps: usize, steps: usize) -> &'static str {
        match self {
            SolverKind::Cholesky if iterative_steps > 0 && iterative_steps == steps => "multigrid",
            SolverKind::Cholesky if iterative_steps > 0 => "cholesky+multigrid",
            k => k.name(),
        }
    }

    /// A solver of this kind for `pattern` on the model's `panels` (its analysis done): the one table of the
    /// linear solvers. Multigrid coarsens each panel on its own grid.
    pub fn solver(self, pattern: &BlockPattern, panels: &[Panel]) -> Result<Box<dyn BlockSolver>, LinearError> {
        let nodes = pattern.nodes();
        Ok(match self.resolve(nodes) {
            SolverKind::Cholesky if self == SolverKind::Auto && nodes >= AUTO_FREE_MOTION_NODES => {
                Box::new(Auto::new(pattern, panels))
            }
            SolverKind::Auto | SolverKind::Cholesky => Box::new(Cholesky::new(pattern)?),
            SolverKind::Multigrid => Box::new(Multigrid::new(pattern, panels)?),
            SolverKind::Pcg => Box::new(Pcg::new(pattern)),
        })
    }
}

/// What a solve may take over from the solve before it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reuse {
    /// A new matrix: factorise it (the first solve of a Newton iteration, a static solve that tests positive
    /// definiteness by factorising).
    Fresh,
    /// The matrix of the last solve changed in a few diagonal blocks (a contact active-set change, a friction
    /// re-linearisation): the kept factor may precondition conjugate gradients on it.
    Nearby,
}

/// What one solve did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolveStats {
    /// Seconds spent factorising or setting up the preconditioner.
    pub setup_seconds: f64,
    /// Seconds spent in triangular solves or iterations.
    pub solve_seconds: f64,
    /// Conjugate-gradient iterations (0 for a direct solve).
    pub iterations: usize,
    /// True when the solve factorised the matrix (or rebuilt the hierarchy's coarsest factor).
    pub factorized: bool,
    /// True when the solve redid the symbolic analysis (the step's extra block pairs changed).
    pub analysed: bool,
}

impl SolveStats {
    /// A solve that started at `start`, finished its set-up at `setup_done` and ends now.
    pub fn since(
        start: std::time::Instant,
        setup_done: std::time::Instant,
        iterations: usize,
        factorized: bool,
    ) -> Self {
        Self {
            setup_seconds: setup_done.duration_since(start).as_secs_f64(),
            solve_seconds: setup_done.elapsed().as_secs_f64(),
            iterations,
            factorized,
            analysed: false,
        }
    }

    /// The same statistics, marked as having redone the symbolic analysis when `analysed`.
    pub fn analysed(self, analysed: bool) -> Self {
        Self { analysed, ..self }
    }
}

/// A linear solver bound to one block pattern.
pub trait BlockSolver: Send {
    /// Solves `A x = b` for the unknowns not fixed; fixed unknowns take the value in `b` (their prescribed
    /// increment), and their columns are moved to the right-hand side. On entry `x` holds an initial guess
    /// (iterative solvers start from it; its fixed entries are ignored), on return the solution. Iterative
    /// solves stop at the solver's own tolerance ([`ITERATIVE_TOLERANCE`]).
    fn solve(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        reuse: Reuse,
    ) -> Result<SolveStats, LinearError> {
        self.solve_to(a, fixed, b, x, reuse, None)
    }

    /// [`BlockSolver::solve`], the iterative solves stopping at the relative residual `tolerance`
    /// (`‖b − A x‖ ≤ tolerance ‖b‖`; `None`: the solver's own) instead: an inexact Newton correction's
    /// forcing term. A direct solve is exact whatever `tolerance` says (Cholesky's re-solves preconditioned by
    /// its kept factor stop at it).
    fn solve_to(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        reuse: Reuse,
        tolerance: Option<f64>,
    ) -> Result<SolveStats, LinearError>;

    /// The nodes' current positions, for a solver whose preconditioner follows the shape ([`multigrid`]'s
    /// coarse space carries the rigid-body modes at these positions; without a call, those of the panels' rest
    /// shapes; positions of another length than the pattern's nodes are ignored). The default ignores them.
    fn set_positions(&mut self, _x: &[Vec3]) {}

    /// Whether the coming solves (until the next call) belong to a step without contact, which Newton iterates
    /// with inexact solves: the automatic choice ([`auto`]) takes its iterative solver for them. The stepper
    /// calls it before each step's first solve; the default ignores it.
    fn set_free_motion(&mut self, _free: bool) {}

    /// Which solver the next steps would take: what the automatic choice ([`auto`]) carries from one step to
    /// the next, saved in checkpoints (the default for the others).
    fn picks(&self) -> AutoPicks {
        AutoPicks::default()
    }

    /// Restores [`BlockSolver::picks`] (a resumed run); the default ignores them.
    fn set_picks(&mut self, _picks: AutoPicks) {}

    /// Bytes one preconditioned iteration of an iterative solver reads and writes, by the model of
    /// docs/performance.md ("Bytes an iteration"); 0, the default, for a direct solver (and before the first
    /// solve).
    fn iteration_bytes(&self) -> usize {
        0
    }

    /// Non-zeros of the factor (0, the default, for a solver without one).
    fn factor_nnz(&self) -> usize {
        0
    }

    /// The concrete kind of the coming solves (for summaries; [`auto`]'s follows
    /// [`BlockSolver::set_free_motion`]).
    fn kind(&self) -> SolverKind;
}

/// The solver's part of a checkpoint: the iterative solvers' starting guess for the next step, the automatic
/// choice's picks for it, and the step matrix's extra pairs (pairs between faces), which it keeps from step to
/// step with the last assembly's blocks. (Nothing else carries over between steps: each step's first solve
/// factorises or refills afresh.)
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SolverWarm {
    /// The next step's starting guess.
    pub guess: Vec<Vec3>,
    /// The automatic choice's picks for the next steps ([`BlockSolver::picks`]).
    pub picks: AutoPicks,
    /// The step matrix's extra pairs and blocks ([`crate::sparse::ExtraBlocks::saved`]): without them a resumed
    /// self-contact run (the pile) started with none, summed and ordered its factor differently, and its frames
    /// differed from the uninterrupted run's in the last bits (9e-13 m after 14 steps).
    pub extra: crate::sparse::ExtraSaved,
}

/// What the automatic choice ([`auto::Auto`]) carries from one step to the next.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct AutoPicks {
    /// The next step without contact takes the iterative solver.
    pub free_iterative: bool,
    /// The next step with contact takes the iterative solver.
    pub contact_iterative: bool,
    /// Steps with contact the direct solver took since the iterative solver last took one (after
    /// [`auto::PROBE_STEPS`] the iterative solver is tried again).
    pub contact_direct: u32,
}

/// Relative residual `‖b − A x‖ / ‖b‖` an iterative solve reaches ([`cholesky`]'s preconditioned re-solves and
/// [`multigrid`]), `b` being the step's own residual. At 1e-9 a few contact and friction decisions of the 21²
/// ball drop came out differently from the direct solve's and its final membrane energy differed by 14%; at
/// 1e-11 the whole run agrees with the direct solve's to 4e-9 (docs/performance.md), for about a fifth more
/// iterations.
pub const ITERATIVE_TOLERANCE: f64 = 1e-11;

/// Relative residual `‖b − A x‖ / ‖b‖` at which the iterative solvers stop in every solve of a contact step
/// (docs/model.md §8.5): its linearised step, its active sets' re-solves and its Newton corrections. Such a step
/// decides its contact and friction sets on each solve's proposal by forces at 5 % of the step's largest
/// ([`crate::potential::friction::MODEL_TOLERANCE`]), and ends with a Newton residual of the order of its force
/// scale (it is not iterated to [`crate::integrate::StepParams::newton_tolerance`]); a solve to 1e-6 leaves
/// errors orders of magnitude below both. Measured on the 161² sheet touching the ball (10 steps): half the multigrid
/// iterations of [`ITERATIVE_TOLERANCE`], the same solves, and final positions within 2.1e-6 m (1.5e-6 of
/// the sheet's size) of those solves' (docs/performance.md). Sparse Cholesky's factorised solves are exact; its
/// re-solves preconditioned by the kept factor stop here too, but for steps with pairs between faces engaged.
pub const CONTACT_STEP_TOLERANCE: f64 = 1e-6;

/// A solver bound to one block pattern.
pub struct LinearSolver {
    solver: Box<dyn BlockSolver>,
}

impl LinearSolver {
    /// Analyses `pattern` on the model's `panels` for `kind`.
    pub fn new(kind: SolverKind, pattern: &BlockPattern, panels: &[Panel]) -> Result<Self, LinearError> {
        Ok(Self { solver: kind.solver(pattern, panels)? })
    }
}

/// The solver's methods ([`BlockSolver::solve`], [`BlockSolver::factor_nnz`]) directly on a [`LinearSolver`].
impl std::ops::Deref for LinearSolver {
    type Target = dyn BlockSolver;
    fn deref(&self) -> &Self::Target {
        &*self.solver
    }
}

impl std::ops::DerefMut for LinearSolver {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut *self.solver
    }
}

/// The system every solver solves: `A` with the fixed unknowns eliminated symmetrically (their rows and
/// columns replaced by the identity, their columns' products moved to the right-hand side), and the buffers
/// of conjugate gradients on it. One per solver, kept between solves.
pub(crate) struct Reduced {
    pattern: BlockPattern,
    rhs: Vec<Vec3>,
    scratch: Vec<Vec3>,
    work: cg::Work,
    any_fixed: bool,
}

impl Reduced {
    /// Bytes one conjugate-gradient iteration reads and writes outside the preconditioner: the symmetric
    /// product over the upper blocks (`f64`, with their row indices) and ten passes over vectors (the
    /// product's, the two dot products', the three updates').
    pub(crate) fn iteration_bytes(&self) -> usize {
        let block = std::mem::size_of::<crate::math::Mat3>() + std::mem::size_of::<usize>();
        self.pattern.blocks() * block + 10 * self.pattern.nodes() * std::mem::size_of::<Vec3>()
    }

    /// Buffers for `pattern`.
    pub(crate) fn new(pattern: &BlockPattern) -> Self {
        let n = pattern.nodes();
        Self {
            pattern: pattern.clone(),
            rhs: vec![Vec3::ZERO; n],
            scratch: vec![Vec3::ZERO; n],
            work: cg::Work::new(n),
            any_fixed: false,
        }
    }

    /// The block pattern.
    pub(crate) fn pattern(&self) -> &BlockPattern {
        &self.pattern
    }

    /// The reduced right-hand side of the last [`Reduced::eliminate`].
    pub(crate) fn rhs(&self) -> &[Vec3] {
        &self.rhs
    }

    /// `b' = b − A x_f` on free nodes and `b' = b` on fixed ones, and `x`'s fixed entries set to `b`'s.
    pub(crate) fn eliminate(&mut self, a: &BlockMatrix, fixed: &[bool], b: &[Vec3], x: &mut [Vec3]) {
        self.any_fixed = fixed.iter().any(|&f| f);
        for k in 0..b.len() {
            self.scratch[k] = if fixed[k] { b[k] } else { Vec3::ZERO };
            if fixed[k] {
                x[k] = b[k];
            }
        }
        self.rhs.iter_mut().for_each(|v| *v = Vec3::ZERO);
        if self.any_fixed {
            a.mul_add(&self.pattern, &self.scratch, &mut self.rhs);
        }
        for k in 0..b.len() {
            self.rhs[k] = if fixed[k] { b[k] } else { b[k] - self.rhs[k] };
        }
    }

    /// Conjugate gradients on the reduced system from `x` with `precondition`, after [`Reduced::eliminate`].
    pub(crate) fn cg(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        x: &mut [Vec3],
        precondition: impl FnMut(&[Vec3], &mut [Vec3]),
        tol: f64,
        max_iter: usize,
    ) -> Result<usize, LinearError> {
        let Self { pattern, rhs, scratch, work, any_fixed } = self;
        let any = *any_fixed;
        let apply = |v: &[Vec3], out: &mut [Vec3]| {
            out.iter_mut().for_each(|o| *o = Vec3::ZERO);
            if any {
                for k in 0..v.len() {
                    scratch[k] = if fixed[k] { Vec3::ZERO } else { v[k] };
                }
                a.mul_add(pattern, scratch, out);
                for k in 0..v.len() {
                    if fixed[k] {
                        out[k] = v[k];
                    }
                }
            } else {
                a.mul_add(pattern, v, out);
            }
        };
        cg::solve(apply, precondition, rhs, x, tol, max_iter, work)
    }
}
