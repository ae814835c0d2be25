//! The automatic choice on mid-size grids, a [`BlockSolver`] that holds two: sparse Cholesky and multigrid,
//! and gives each step to one of them by the counts (solves, iterations) of the step before it
//! (docs/performance.md, "Which solver `auto` takes" and "Which solver takes a contact step"):
//!
//! - **Steps without contact** that Newton iterates with inexact solves (docs/model.md §8.5, "Inexact
//!   corrections") take multigrid: on the tumbling sheet (`flexsurf bench --workload tumble`) 1.4× faster than
//!   Cholesky at 51², 2.2× at 81² and 101²; a step one exact solve converges (a free fall) is cheaper on
//!   Cholesky below about 180² ([`super::AUTO_FREE_ITERATIVE_NODES`]), above which multigrid takes them all.
//! - **Steps with contact** (from [`super::AUTO_CONTACT_ITERATIVE_NODES`]) take multigrid while its solves of
//!   the last one took at most [`contact_iterations_limit`] iterations each, else Cholesky, which tries
//!   multigrid again every [`PROBE_STEPS`] contact steps. A sheet that lands flat on the ball takes 4–9
//!   multigrid iterations a solve, and multigrid is 1.6–2× faster than Cholesky there; once it wrinkles where it
//!   hangs off the ball (about ten steps later) its solves take 20–30 iterations (the wrinkles' low-energy modes
//!   are not in the grid's coarse space) and Cholesky, whose re-solves reuse its factor, is 1.1–2.2× faster
//!   (measured from 81² to 281²).
//!
//! The stepper says which kind of step comes ([`BlockSolver::set_free_motion`]) before the step's first solve;
//! the choice holds for the whole step (its re-solves and corrections). Both solvers are deterministic and the
//! choice depends only on the run's own counts (carried in checkpoints, [`AutoPicks`]), so the run is too.

use super::{
    AutoPicks, BlockSolver, Cholesky, LinearError, Multigrid, Reuse, SolveStats, SolverKind,
    AUTO_CONTACT_ITERATIVE_NODES, AUTO_FREE_ITERATIVE_NODES,
};
use crate::math::Vec3;
use crate::model::Panel;
use crate::sparse::{BlockMatrix, BlockPattern};

/// Contact steps on Cholesky after which the next one tries multigrid again (a sheet that slid off and lies
/// flat again): one probe costs about 1.7 Cholesky steps where the sheet is still wrinkled, 1–2 % of those
/// steps.
pub const PROBE_STEPS: u32 = 50;

/// The multigrid iterations a solve above which a contact step costs more on multigrid than on Cholesky, for
/// a grid of `nodes` nodes: `15 (nodes / 161²)^¼`. A factorisation's work grows faster with the grid than an
/// iteration's, so the break-even count grows with it; measured on the ball drop (`examples/solve_trace N 40
/// cholesky|multigrid`, docs/performance.md, "Which solver takes a contact step"): about 12 at 81², 14 at 121²,
/// 15 at 161², 22 at 201², 19 at 241² and 23 at 281², where this gives 10.6, 12.3, 15, 16.7, 18.4 and 19.8.
pub fn contact_iterations_limit(nodes: usize) -> f64 {
    15.0 * (nodes as f64 / 25_921.0).powf(0.25)
}

/// Cholesky and multigrid, each step given to one of them.
pub struct Auto {
    /// Analysed at its first solve: a run whose steps all take multigrid (a sheet turning freely on a large grid)
    /// never pays for the symbolic analysis (0.5 s and 165 MB at 281²).
    direct: Option<Cholesky>,
    /// The pattern it is analysed for.
    pattern: BlockPattern,
    /// `None` where the model's unknowns are not all grid nodes of its panels (multigrid cannot coarsen them):
    /// then every step takes Cholesky.
    iterative: Option<Multigrid>,
    /// The grid's nodes.
    nodes: usize,
    /// The solves since the last [`BlockSolver::set_free_motion`] belong to a step without contact.
    free: bool,
    /// They are multigrid's.
    on_iterative: bool,
    /// The picks the step under way was given.
    picks: AutoPicks,
    /// Fresh solves (the linearised step and its Newton corrections) since the last call.
    fresh: usize,
    /// All solves since the last call, and their iterations.
    solves: usize,
    iterations: usize,
}

impl Auto {
    /// Both solvers for `pattern` on the model's `panels` (each analysed at its first solve).
    pub fn new(pattern: &BlockPattern, panels: &[Panel]) -> Self {
        let nodes = pattern.nodes();
        Self {
            direct: None,
            pattern: pattern.clone(),
            iterative: Multigrid::new(pattern, panels).ok(),
            nodes,
            free: false,
            on_iterative: false,
            picks: AutoPicks {
                free_iterative: nodes > AUTO_FREE_ITERATIVE_NODES,
                contact_iterative: nodes >= AUTO_CONTACT_ITERATIVE_NODES,
                contact_direct: 0,
            },
            fresh: 0,
            solves: 0,
            iterations: 0,
        }
    }

    /// The coming solves are multigrid's.
    fn iterating(&self) -> bool {
        self.on_iterative && self.iterative.is_some()
    }

    /// Cholesky, analysed now if it was not yet.
    fn direct(&mut self) -> Result<&mut Cholesky, LinearError> {
        let direct = match self.direct.take() {
            Some(direct) => direct,
            None => Cholesky::new(&self.pattern)?,
        };
        Ok(self.direct.insert(direct))
    }

    /// The picks for the next step, from the one that ended. Without contact: a step that one exact solve
    /// converged (free fall, a sheet at rest) costs one factorisation, which beats the two or more inexact
    /// solves multigrid then needs (its first is loose); a step that Newton had to correct (rotations: the
    /// tumbling sheet needs 2–3 corrections) is cheaper on multigrid. So a Cholesky step with a correction hands
    /// the next to multigrid, and a multigrid step converged in at most one correction hands it back. With
    /// contact: multigrid keeps the next while its iterations a solve stay within
    /// [`contact_iterations_limit`]; Cholesky hands it back after [`PROBE_STEPS`].
    fn next_picks(&self) -> AutoPicks {
        let mut picks = self.picks;
        if self.solves == 0 {
            return picks;
        }
        if self.free {
            let corrected = self.fresh > if self.on_iterative { 2 } else { 1 };
            picks.free_iterative = corrected || self.nodes > AUTO_FREE_ITERATIVE_NODES;
        } else if self.on_iterative {
            let per_solve = self.iterations as f64 / self.solves as f64;
            picks.contact_iterative = per_solve <= contact_iterations_limit(self.nodes);
            picks.contact_direct = 0;
        } else if self.nodes >= AUTO_CONTACT_ITERATIVE_NODES {
            picks.contact_direct += 1;
            if picks.contact_direct >= PROBE_STEPS {
                (picks.contact_iterative, picks.contact_direct) = (true, 0);
            }
        }
        picks
    }
}

impl BlockSolver for Auto {
    fn solve_to(
        &mut self,
        a: &BlockMatrix,
        fixed: &[bool],
        b: &[Vec3],
        x: &mut [Vec3],
        reuse: Reuse,
        tolerance: Option<f64>,
    ) -> Result<SolveStats, LinearError> {
        self.fresh += usize::from(reuse == Reuse::Fresh);
        let stats = match (&mut self.iterative, self.on_iterative) {
            (Some(iterative), true) => iterative.solve_to(a, fixed, b, x, reuse, tolerance)?,
            _ => self.direct()?.solve_to(a, fixed, b, x, reuse, tolerance)?,
        };
        self.solves += 1;
        self.iterations += stats.iterations;
        Ok(stats)
    }

    fn set_positions(&mut self, x: &[Vec3]) {
        if let Some(iterative) = &mut self.iterative {
            iterative.set_positions(x);
        }
    }

    fn set_free_motion(&mut self, free: bool) {
        self.picks = self.next_picks();
        self.free = free;
        let pick = if free { self.picks.free_iterative } else { self.picks.contact_iterative };
        self.on_iterative = self.iterative.is_some() && pick;
        (self.fresh, self.solves, self.iterations) = (0, 0, 0);
    }

    fn picks(&self) -> AutoPicks {
        self.next_picks()
    }

    fn set_picks(&mut self, picks: AutoPicks) {
        self.picks = picks;
        (self.free, self.on_iterative, self.fresh, self.solves, self.iterations) = (false, false, 0, 0, 0);
    }

    fn iteration_bytes(&self) -> usize {
        match (&self.iterative, self.on_iterative) {
            (Some(iterative), true) => iterative.iteration_bytes(),
            _ => 0,
        }
    }

    fn factor_nnz(&self) -> usize {
        self.direct.as_ref().map_or(0, |direct| direct.factor_nnz())
    }

    /// The solver of the coming solves.
    fn kind(&self) -> SolverKind {
        if self.iterating() {
            SolverKind::Multigrid
        } else {
            SolverKind::Cholesky
        }
    }
}
