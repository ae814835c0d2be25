//! Time integration (docs/model.md §8). Both schemes solve the central-difference system of the paper's
//! (46)–(48)
//!
//! `(M/Δt² + C/(2Δt) + K) Δ = f_ext − ∇E(x_t) + M (x_t − x⁻)/Δt² − C (x_t − x⁻)/(2Δt)`, `x⁺ = x_t + Δ`,
//!
//! which is `A_t x⁺ = g_t` written for the increment: the Newton system of the incremental potential
//! `Π(y) + inertia(y)` ([`crate::potential`], [`crate::potential::inertia`]) at `y = x_t`. They differ in `K`:
//! - [`Scheme::Linearized`] (default): `K` is the potential's positive semi-definite Hessian (`H⁺` for the
//!   elastic terms, plus contact and spring stiffness): implicit in the material stiffness, unconditionally
//!   stable, exactly (46)–(48) for a linear system.
//! - [`Scheme::Lagged`]: the paper's lagged-coefficient secant operator. It integrates stretching explicitly
//!   (stable only below about `h/√(A11/ρ)`, 9e-5 s on the 1 m, 21×21 demo sheet) and detects its own
//!   divergence.
//!
//! That solve is the first Newton iteration on the incremental potential; for the linearised and the BDF2
//! scheme, Newton corrections with a line search on `Φ` follow until the residual is small relative to the
//! step's own forces in a step without contact, and at most one correction, at an impact, in a contact step
//! ([`Stepper::step`]).
//!
//! The parameters of a step are one [`StepParams`]; a run is a [`Method`]: a dynamic integration or a static
//! solve ([`statics`]).

mod descent;
pub mod linsolve;
pub mod params;
pub mod statics;
// The stepper's warm state for checkpoints (issue 11).
mod resume;

use crate::energy::Operator;
use crate::math::{finite, Vec3};
use crate::model::{Energies, Model};
use crate::potential::friction::{Misfit, MODEL_TOLERANCE};
use crate::potential::inertia::Inertia;
use crate::potential::self_contact::SelfContact;
use crate::potential::{Motion, Values, Want, Workspace};
use crate::state::State;
use linsolve::{LinearError, LinearSolver, Reuse};
pub use params::{Bounds, Method, Scheme, StepParams};
use serde::Serialize;
use std::time::Instant;
use thiserror::Error;

/// Why a step failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum StepError {
    /// Non-finite positions, velocities beyond the physical bound, or strains beyond the bound.
    #[error("the simulation diverged at step {step}: {what}; {hint}")]
    Diverged {
        /// Step at which it was detected.
        step: usize,
        /// What was seen.
        what: String,
        /// What to try.
        hint: &'static str,
    },
    /// A node passed through an obstacle, or two elements of the sheet met (self-contact), within the step
    /// although continuous detection gave it a contact (the active-set re-solves and the step's halvings ran out).
    #[error(
        "node {node} passed through an obstacle or met another part of the sheet at step {step}: the contact \
         re-solves did not settle even in halved steps; try a smaller dt or a stiffer contact (or self_contact)"
    )]
    Tunnelled {
        /// Step.
        step: usize,
        /// Node.
        node: usize,
    },
    /// The sheet fell or flew away from every obstacle (a sheet that missed them, or one dropped through a
    /// mistake of the scene): nothing more will happen to it.
    #[error(
        "the sheet left every obstacle behind at step {step}: its centre is {distance:.3e} m from the nearest one, \
         more than 100 sheet lengths; check the obstacles' positions and the sheet's placement"
    )]
    LeftBehind {
        /// Step.
        step: usize,
        /// Distance of the sheet's centre from the nearest obstacle (m).
        distance: f64,
    },
    /// The initial positions stretch an edge beyond what a step accepts ([`Bounds::max_strain`]).
    #[error(
        "the initial positions stretch an edge by {strain:.3e} % where a step accepts {bound:.0} %: check them (a \
         frame of another sheet, or a damaged file?)"
    )]
    Stretched {
        /// The largest edge strain, in per cent.
        strain: f64,
        /// The bound, in per cent.
        bound: f64,
    },
    /// The initial shape passes through itself (self-contact cannot start from it).
    #[error(
        "the initial shape passes through itself: the edge from {edge_from} to {edge_to} crosses the triangle of \
         {triangle}; self-contact needs a start without intersections (move the sheets or folds apart)"
    )]
    Intersecting {
        /// The edge's first node (`sheet k node [i, j]`).
        edge_from: String,
        /// Its second node.
        edge_to: String,
        /// The triangle's three nodes.
        triangle: String,
    },
    /// The linear solve failed.
    #[error("linear solve failed at step {step}: {cause}")]
    Linear {
        /// Step.
        step: usize,
        /// Cause.
        cause: LinearError,
    },
}

/// Wall-clock seconds spent per stage, summed over steps.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Counters {
    /// Energy, gradient and operator assembly.
    pub assembly: f64,
    /// Contact detection, contact terms and the continuous check of the step's paths.
    pub contact: f64,
    /// The part of `contact` that self-contact takes (its broad and narrow phases, its terms, its path
    /// check).
    pub self_contact: f64,
    /// Numeric factorisation (or preconditioner set-up).
    pub factorization: f64,
    /// Triangular solves (or CG iterations).
    pub solve: f64,
    /// Steps counted.
    pub steps: usize,
    /// Linear solves made (Newton iterations and contact active-set re-solves included).
    pub solves: usize,
    /// Conjugate-gradient iterations of the iterative solves.
    pub iterations: usize,
    /// Numeric factorisations (or multigrid hierarchy refills).
    pub factorizations: usize,
    /// Re-solves of a Newton iteration because an active set (contact, friction) changed.
    pub resolves: usize,
    /// Newton corrections after the linearised step (Newton iterations beyond the first of each step).
    pub corrections: usize,
    /// Steps whose Newton iterations stopped above [`StepParams::newton_tolerance`] (at the iteration cap,
    /// where no step along the solved increment lowered the incremental potential, or a contact step, which is
    /// not iterated to the tolerance: [`NewtonReport::contact`]).
    pub unconverged: usize,
    /// Steps that took the contact steps' Newton rule ([`NewtonReport::contact`]).
    pub contact_steps: usize,
    /// Largest final relative residual of a step's Newton iterations ([`NewtonReport::residual`]).
    pub residual_max: f64,
    /// Self-contact records active at the steps' starts, summed over the steps (their mean is this over
    /// `steps`).
    pub self_contact_pairs: usize,
    /// Builds of the self-contact broad phase's trees (triangles and edges, each counted).
    pub broad_builds: usize,
    /// Refits of the same trees (a refit keeps the tree and recomputes its boxes).
    pub broad_refits: usize,
    /// Steps whose solves an iterative solver made (every step of a multigrid or PCG run; under `auto` on
    /// mid-size grids, the steps it gave multigrid: [`linsolve::auto`]).
    pub iterative_steps: usize,
}

impl Counters {
    /// Adds `other` stage by stage.
    pub fn add(&mut self, other: &Counters) {
        self.assembly += other.assembly;
        self.contact += other.contact;
        self.self_contact += other.self_contact;
        self.factorization += other.factorization;
        self.solve += other.solve;
        self.steps += other.steps;
        self.solves += other.solves;
        self.iterations += other.iterations;
        self.factorizations += other.factorizations;
        self.resolves += other.resolves;
        self.corrections += other.corrections;
        self.unconverged += other.unconverged;
        self.contact_steps += other.contact_steps;
        self.residual_max = self.residual_max.max(other.residual_max);
        self.self_contact_pairs += other.self_contact_pairs;
        self.broad_builds += other.broad_builds;
        self.broad_refits += other.broad_refits;
        self.iterative_steps += other.iterative_steps;
    }
}

/// What one step reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct StepInfo {
    /// Elastic energies at `x_t` (the start of the step).
    pub energies: Energies,
    /// Active contacts at `x_t` (obstacles and self-contact).
    pub contacts: usize,
    /// The self-contact records among them.
    pub self_contacts: usize,
    /// Penalty energy at `x_t`.
    pub contact_energy: f64,
    /// Deepest penetration below the obstacle surface after the step (m, ≥ 0).
    pub max_penetration: f64,
    /// This step's seconds per stage (`steps` = 1, `solves` its linear solves).
    pub timings: Counters,
    /// How the step's Newton iterations ended.
    pub newton: NewtonReport,
}

/// How the Newton iterations of a step on its incremental potential ended (docs/model.md §8.5).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct NewtonReport {
    /// Newton iterations, the linearised step included (of both half steps, for a split step).
    pub iterations: usize,
    /// The final residual of the implicit equation relative to the step's force scale
    /// ([`StepParams::newton_tolerance`]); 0 where it is not measured (the lagged scheme, a potential with a
    /// non-conservative term: neither has the Jacobian Newton needs, so they make the linearised step alone).
    pub residual: f64,
    /// The residual reached the tolerance.
    pub converged: bool,
    /// The step had an active contact or friction set after its first solve and took the contact steps' rules
    /// ([`StepParams::contact_correction`], docs/model.md §8.5) instead of iterating to the tolerance.
    pub contact: bool,
}

impl NewtonReport {
    /// The report of a step taken as `self` and then `other` (two half steps).
    fn then(self, other: NewtonReport) -> NewtonReport {
        NewtonReport {
            iterations: self.iterations + other.iterations,
            residual: self.residual.max(other.residual),
            converged: self.converged && other.converged,
            contact: self.contact || other.contact,
        }
    }
}

/// Scratch buffers and the solver of one run (rapier's "pipeline" pattern: no physics state lives here).
pub struct Stepper {
    /// The step's parameters.
    pub params: StepParams,
    /// Divergence bounds in force.
    pub bounds: Bounds,
    /// Per-stage timings.
    pub counters: Counters,
    solver: LinearSolver,
    ws: Workspace,
    rhs: Vec<Vec3>,
    delta: Vec<Vec3>,
    /// The first increment of the last step: the iterative solvers' starting guess for the next.
    guess: Vec<Vec3>,
    y: Vec<Vec3>,
    /// The iterate a line search starts from, and the gradient of `Φ` there.
    y0: Vec<Vec3>,
    g0: Vec<Vec3>,
    /// Each node's panel (a seam-joined node: the first panel that has it; 0 for a model without panels).
    panel_of: Vec<u32>,
    /// Each panel's force scale for this step ([`Stepper::force_scale`]).
    scales: Vec<f64>,
    /// Each panel's largest nodal weight or load: the scale of the contact steps' correction threshold.
    weights: Vec<f64>,
    history: History,
    /// The length of the (sub-)step being taken.
    h: f64,
    /// Steps that were split into sub-steps, and sub-steps taken in all.
    pub split: (usize, usize),
    /// The pinned nodes the (sub-)step moves: `(node, from, to)` ([`Stepper::step`]).
    pin_moves: Vec<(usize, Vec3, Vec3)>,
    /// Contact seconds spent refining active sets inside the solves (counted as contact, not as solve).
    refine_seconds: f64,
    /// The first solve of this contact step may leave a change of its contact set to a Newton correction
    /// ([`Stepper::merges`]).
    merge: bool,
    /// It did: the refinement's records are held for the correction.
    merged: bool,
    /// This step's solves take the reflected operator ([`Stepper::reflects`]).
    reflect: bool,
    /// The first solve's proposal, the gradient there of the terms without contact, and the nodes a contact
    /// record or lagged friction acts on ([`Stepper::merges`]).
    proposal: Vec<Vec3>,
    field: Vec<Vec3>,
    touched: Vec<bool>,
}

/// Most trial points of a Newton correction's line search ([`Stepper::line_search`]).
const LINE_SEARCH_STEPS: usize = 12;

/// Most halvings of a step that failed (divergence or a node through an obstacle) before the error is reported.
pub const MAX_HALVINGS: usize = 8;

/// The scheme's form of a step from one state ([`Motion`]): the inertial target, the damping centre and the
/// two coefficients, computed once at the start of the step.
#[derive(Debug, Clone, Default)]
struct History {
    target: Vec<Vec3>,
    center: Vec<Vec3>,
    alpha: f64,
    beta: f64,
    /// The iterations of a converging contact step are under way ([`Motion::exact`]).
    exact: bool,
}

impl History {
    /// Fills the history of a step of `scheme` from `state`.
    fn fill(&mut self, scheme: Scheme, state: &State, dt: f64) {
        let n = state.x.len();
        self.target.resize(n, Vec3::ZERO);
        self.center.resize(n, Vec3::ZERO);
        match scheme {
            Scheme::Linearized | Scheme::Lagged => {
                for k in 0..n {
                    self.target[k] = state.x[k] * 2.0 - state.x_prev[k];
                    self.center[k] = state.x_prev[k];
                }
                self.alpha = 1.0 / (dt * dt);
                self.beta = 0.5 / dt;
            }
            Scheme::Bdf2 => {
                for k in 0..n {
                    let z = (state.x[k] * 4.0 - state.x_prev[k]) / 3.0;
                    self.center[k] = z;
                    self.target[k] = z + (state.v[k] * 8.0 - state.v_prev[k] * 2.0) * (dt / 9.0);
                }
                self.alpha = 2.25 / (dt * dt);
                self.beta = 1.5 / dt;
            }
        }
    }

    /// The step's motion from `state`.
    fn motion<'a>(&'a self, model: &'a Model, state: &'a State, dt: f64, predict: bool) -> Motion<'a> {
        Motion {
            x: &state.x,
            x_prev: &state.x_prev,
            v: &state.v,
            v_prev: &state.v_prev,
            target: &self.target,
            damp_center: &self.center,
            inertia: self.alpha,
            damp: self.beta,
            dt,
            mass: &model.mass,
            damping: &model.damping,
            predict,
            exact: self.exact && !predict,
        }
    }
}

/// The floor of a panel's force scale, as a fraction of its size moved in one step ([`Stepper::force_scale`]):
/// with the Newton tolerance 1e-6, a sheet whose forces are all round-off is converged when what is left could
/// move it by 1e-12 of its size.
pub const STILL: f64 = 1e-6;

impl Stepper {
    /// Workspace for `model` with `params`; the symbolic factorisation happens here, once.
    pub fn new(model: &Model, params: &StepParams) -> Result<Self, StepError> {
        let pattern = model.potential.pattern();
        let n = model.nodes();
        let panels = model.panels.len().max(1);
        let mut panel_of = vec![u32::MAX; n];
        for (p, panel) in model.panels.iter().enumerate() {
            for &k in panel.nodes() {
                if panel_of[k] == u32::MAX {
                    panel_of[k] = p as u32;
                }
            }
        }
        panel_of.iter_mut().filter(|p| **p == u32::MAX).for_each(|p| *p = 0);
        let mut weights = vec![0.0; panels];
        if let Some(ext) = model.potential.find::<crate::potential::external::External>() {
            for (k, &w) in ext.nodal_scales().iter().enumerate() {
                let p = panel_of[k] as usize;
                weights[p] = f64::max(weights[p], w);
            }
        }
        Ok(Self {
            params: *params,
            bounds: params.bounds.unwrap_or_else(|| Bounds::for_model(model, params.dt)),
            counters: Counters::default(),
            solver: LinearSolver::new(params.solver, pattern, &model.panels)
                .map_err(|cause| StepError::Linear { step: 0, cause })?,
            ws: Workspace::new(&model.potential),
            rhs: vec![Vec3::ZERO; n],
            delta: vec![Vec3::ZERO; n],
            guess: vec![Vec3::ZERO; n],
            y: vec![Vec3::ZERO; n],
            y0: vec![Vec3::ZERO; n],
            g0: vec![Vec3::ZERO; n],
            panel_of,
            scales: vec![0.0; panels],
            weights,
            history: History::default(),
            h: params.dt,
            split: (0, 0),
            pin_moves: Vec::new(),
            refine_seconds: 0.0,
            merge: false,
            merged: false,
            reflect: false,
            proposal: Vec::new(),
            field: Vec::new(),
            touched: Vec::new(),
        })
    }

    /// The operator of the step's solves: the lagged scheme's secant one; for the others the positive
    /// semi-definite `H⁺`, reflected ([`Operator::Reflected`]) in a contact step ([`Stepper::reflects`]).
    fn operator(&self) -> Operator {
        match self.params.scheme {
            Scheme::Linearized | Scheme::Bdf2 if self.reflect => Operator::Reflected,
            Scheme::Linearized | Scheme::Bdf2 => Operator::Projected,
            Scheme::Lagged => Operator::Secant,
        }
    }

    /// Whether this step's solves take the reflected operator: where contact with obstacles acts (detected at
    /// the step's start, or after its first solve) and no pair between faces is engaged. A contact step keeps
    /// its linearised step and at most a correction or a few, unconverged where the sheet folds
    /// (docs/performance.md, "The reflected operator in contact steps"), and with the compressed membrane's
    /// stress stiffness reflected those solves leave fewer re-solves and corrections and a smaller residual;
    /// a step without contact, which Newton's method iterates to its tolerance, converges faster near the
    /// solution with the projection, and the pairs between faces of a garment's sewing tunnelled with it.
    fn reflects(model: &Model, ws: &Workspace) -> bool {
        model.potential.engaged(ws) && model.potential.convergent(ws)
    }

    /// Assembles the step system at `state` without solving: afterwards [`Stepper::matrix`] is `A_t` (before
    /// pinned unknowns are eliminated) and [`Stepper::rhs`] the right-hand side for the increment `x⁺ − x_t`.
    pub fn assemble(&mut self, model: &Model, state: &State) -> Values {
        if std::mem::take(&mut self.merged) {
            // A failed step may have left the records held: a step detects its own.
            model.potential.hold(&mut self.ws, false);
        }
        self.history.fill(self.params.scheme, state, self.h);
        self.y.copy_from_slice(&state.x);
        for &(k, _, to) in &self.pin_moves {
            self.y[k] = to;
        }
        // The active sets first: a step that starts in contact is assembled with the reflected operator.
        let cx = model.potential.context(Some(self.history.motion(model, state, self.h, true)));
        model.potential.prepare(&self.y, &cx, &mut self.ws);
        self.reflect = Self::reflects(model, &self.ws);
        let want = Want { grad: true, hess: Some(self.operator()) };
        let values = model.potential.assemble_prepared(&self.y, &cx, Some(&Inertia), want, &mut self.ws);
        self.residual_from_gradient(model);
        values
    }

    /// Assembles the Newton system of the step's implicit equation
    /// `M α (y − ŷ) + C β (y − z) + ∇Π(y) = 0` ([`Motion`]; for central differences
    /// `M(y − 2x_t + x⁻)/Δt² + C(y − x⁻)/(2Δt) + ∇Π(y) = 0`) at the iterate `y = self.y`: the matrix
    /// `M α + C β + K(y)` (when `want` asks for it) and the residual, the right-hand side for the correction of
    /// `y`. At `y = x_t` this is exactly the linearised step (46)–(48). With `predict` (the first assembly of a
    /// step), contact candidates also include nodes whose target `ŷ` is inside the contact layer, and lagged
    /// quantities (friction) are taken here.
    fn assemble_at(&mut self, model: &Model, state: &State, predict: bool, want: Want) -> Values {
        let cx = model.potential.context(Some(self.history.motion(model, state, self.h, predict)));
        let values = model.potential.assemble(&self.y, &cx, Some(&Inertia), want, &mut self.ws);
        self.residual_from_gradient(model);
        values
    }

    /// `rhs = −∇Φ`, zero on fixed nodes.
    fn residual_from_gradient(&mut self, model: &Model) {
        for ((r, g), &f) in self.rhs.iter_mut().zip(&self.ws.grad).zip(model.pinned()) {
            *r = if f { Vec3::ZERO } else { -*g };
        }
    }

    /// Solves the assembled system for `self.delta`, correcting the active sets (contact) by re-solving (a
    /// violent contact step's first solve leaves the correction to its Newton correction: [`Stepper::merges`]).
    /// `newton`: the iteration of the step (0: the linearised step, started from the last step's increment;
    /// a correction starts from zero); a re-solve starts from the solution before it. Returns the set-up
    /// (factorisation) seconds. `tolerance`: the iterative solves' relative tolerance (a Newton correction's
    /// forcing term, [`descent::Forcing`]); `None`: the solver's own.
    fn solve_with_active_sets(
        &mut self,
        model: &Model,
        state: &State,
        (newton, tolerance): (usize, Option<f64>),
        op: Operator,
    ) -> Result<f64, StepError> {
        let mut tf = 0.0;
        let want = Want { grad: true, hess: Some(op) };
        if newton == 0 {
            self.delta.copy_from_slice(&self.guess);
        } else {
            self.delta.iter_mut().for_each(|d| *d = Vec3::ZERO);
        }
        // Multigrid's coarse space carries the rigid-body modes of the shape the step is at.
        self.solver.set_positions(&self.y);
        let reuse = |round: usize| if round == 0 { Reuse::Fresh } else { Reuse::Nearby };
        for round in 0..=self.params.active_set_rounds {
            // The first solve's tolerance is the caller's; a re-solve's, the active sets' rule.
            let round_tolerance = if round == 0 { tolerance } else { self.resolve_tolerance(model) };
            tf += self.linear_solve(state, model.pinned(), reuse(round), round_tolerance)?;
            if newton == 0 && round == 0 {
                self.guess.copy_from_slice(&self.delta);
            }
            if round == self.params.active_set_rounds {
                break;
            }
            let cx = model.potential.context(Some(self.history.motion(model, state, self.h, false)));
            let before = self.ws.contact_seconds;
            let changed = model.potential.refine(&self.y, &self.delta, &cx, want, &mut self.ws);
            self.refine_seconds += self.ws.contact_seconds - before;
            if !changed {
                break;
            }
            if newton == 0 && self.merge && self.merges(model, state) {
                break;
            }
            self.counters.resolves += 1;
            self.residual_from_gradient(model);
        }
        Ok(tf)
    }

    /// The tolerance of a re-solve (the active set changed: contact engages or leaves): the contact steps'
    /// [`StepParams::contact_solve_tolerance`], but the direct solver's re-solves (conjugate gradients
    /// preconditioned by its kept factor) while pairs between faces are engaged stay at the solver's own
    /// [`linsolve::ITERATIVE_TOLERANCE`]: those pairs are decided on every re-solve's proposal and keep what the
    /// step's start fixed ([`crate::potential::ActiveSet::convergent`]), so their re-solves stay those of exact
    /// solves (docs/performance.md, "Cholesky's re-solves at the contact steps' tolerance").
    fn resolve_tolerance(&self, model: &Model) -> Option<f64> {
        let exact = !self.solver.kind().iterative() && !model.potential.convergent(&self.ws);
        (!exact).then_some(self.params.contact_solve_tolerance)
    }

    /// Whether the change of contact set that the first solve of a contact step found (after the refinement)
    /// is left to a Newton correction at its proposal instead of a re-solve: where the step will take that
    /// correction anyway, because the terms without contact are off their linear model at the proposal by more
    /// than the violent rule's force ([`StepParams::contact_correction`] times the largest nodal weight) at a
    /// node no contact acts on (the membrane's forces of a sheet pressed into a new shape: docs/model.md §8.5).
    /// The correction then solves the new contacts with the membrane linearised where the step goes, one solve
    /// instead of two. Only where every record is shallow at the proposal (no deeper than the contact offset
    /// under the obstacle's surface: no path crossed it) and no pair between faces changed
    /// ([`crate::potential::ActiveSet::can_hold`]). True when it does: the refinement's records are then held
    /// for the correction's assembly ([`crate::potential::ActiveSet::hold`]), their linearised gaps evaluated
    /// at the proposal instead of the contacts being detected again there.
    fn merges(&mut self, model: &Model, state: &State) -> bool {
        let n = self.y.len();
        if self.proposal.len() != n {
            self.proposal = vec![Vec3::ZERO; n];
            self.field = vec![Vec3::ZERO; n];
            self.touched = vec![false; n];
        }
        for ((p, y), d) in self.proposal.iter_mut().zip(&self.y).zip(&self.delta) {
            *p = *y + *d;
        }
        if !model.potential.engaged(&self.ws) || !model.potential.can_hold(&self.proposal, &self.ws) {
            return false;
        }
        let cx = model.potential.context(Some(self.history.motion(model, state, self.h, false)));
        let out = (&mut self.field[..], &mut self.touched[..]);
        model.potential.field_gradient(&self.proposal, &cx, &Inertia, out, &mut self.ws);
        let violent = self.violent_force(model, &self.field, Some(&self.touched));
        if violent {
            model.potential.hold(&mut self.ws, true);
            self.merged = true;
        }
        violent
    }

    /// One solve of the assembled system for `self.delta` (from the guess in it), counted; returns the set-up
    /// seconds.
    fn linear_solve(
        &mut self,
        state: &State,
        fixed: &[bool],
        reuse: Reuse,
        tolerance: Option<f64>,
    ) -> Result<f64, StepError> {
        let stats = self
            .solver
            .solve_to(&self.ws.matrix, fixed, &self.rhs, &mut self.delta, reuse, tolerance)
            .map_err(|cause| StepError::Linear { step: state.step + 1, cause })?;
        self.counters.solves += 1;
        self.counters.iterations += stats.iterations;
        self.counters.factorizations += usize::from(stats.factorized);
        Ok(stats.setup_seconds)
    }

    /// Bytes one preconditioned iteration of the linear solver reads and writes (0 for a direct solver):
    /// [`linsolve::BlockSolver::iteration_bytes`].
    pub fn iteration_bytes(&self) -> usize {
        self.solver.iteration_bytes()
    }

    /// The linear solver in use (the automatic choice resolved).
    pub fn solver_kind(&self) -> linsolve::SolverKind {
        self.solver.kind()
    }

    /// Non-zeros of the Cholesky factor (0 for PCG).
    pub fn factor_nnz(&self) -> usize {
        self.solver.factor_nnz()
    }

    /// The step matrix of the last [`Stepper::assemble`] (contacts included).
    pub fn matrix(&self) -> &crate::sparse::BlockMatrix {
        &self.ws.matrix
    }

    /// The right-hand side of the last [`Stepper::assemble`].
    pub fn rhs(&self) -> &[Vec3] {
        &self.rhs
    }

    /// Advances `state` by `params.dt`: Newton's method on the step's incremental potential `Φ` (docs/model.md
    /// §8.5). The first iteration is the linearised step (46)–(48) with the positive semi-definite `K(x_t)`.
    /// In a step without contact, while the residual of the implicit equation at the iterate, relative to each
    /// panel's own force scale (inertial, elastic and other forces at the start, the weight as a floor;
    /// mass-weighted norms), exceeds [`StepParams::newton_tolerance`], a correction follows with the matrix at
    /// the iterate, taken by a line search that never raises `Φ` (at most [`StepParams::newton_iterations`]
    /// iterations in all): large rotations within one step then leave no spurious stretch to brake them. A
    /// contact step makes at most one correction where it is violent ([`StepParams::contact_correction`]), and
    /// is otherwise iterated while its contacts' linear models are off ([`Stepper::contact_corrections`]). The
    /// outcome is [`StepInfo::newton`]. Contact is implicit: the penalty stiffness is in the matrix for every
    /// node inside the contact layer at the start of the step or predicted to enter it, and the active set is
    /// corrected by re-solving (at most [`StepParams::active_set_rounds`] times) when the solution disagrees.
    ///
    /// A step that fails (a speed or strain bound, a non-finite value, a node through an obstacle, a failed
    /// solve) is retaken as two half steps from the same state (at most [`MAX_HALVINGS`] times nested), whose
    /// history is the second-order one of the half step: so any Δt the user gives either completes or stops
    /// with the step and the cause. The lagged scheme is not split (its instability is its defining property).
    ///
    /// Pinned nodes moved since the last step (to their end-of-step places: [`Model::move_pin`], a scene's
    /// `[[pin]] motion`) move within the step, from where the last step left them (`x⁻`, which a step leaves at
    /// a pinned node's place): the step starts from the configuration the last step accepted, its paths take
    /// the pins' motion, so contact and the continuous check see it, and a split step moves them half way.
    pub fn step(&mut self, model: &Model, state: &mut State) -> Result<StepInfo, StepError> {
        let fixed = model.pinned();
        let moves = (0..model.nodes()).filter(|&k| fixed[k] && state.x_prev[k] != state.x[k]);
        self.set_pin_moves(moves.map(|k| (k, state.x_prev[k], state.x[k])).collect(), state);
        let info = self.step_split(model, state, self.params.dt, 0);
        self.h = self.params.dt;
        self.pin_moves.clear();
        info
    }

    /// Takes `moves` as the (sub-)step's pin moves, the state holding each pin at its end and `x⁻` at its start
    /// (as a step is entered).
    fn set_pin_moves(&mut self, moves: Vec<(usize, Vec3, Vec3)>, state: &mut State) {
        for &(k, from, to) in &moves {
            (state.x[k], state.x_prev[k]) = (to, from);
        }
        self.pin_moves = moves;
    }

    /// [`Stepper::step_once`] with the pins of [`Stepper::pin_moves`] at their starts (the state has them at
    /// their ends, as it is left after a failure).
    fn step_pinned(&mut self, model: &Model, state: &mut State) -> Result<StepInfo, StepError> {
        for &(k, from, _) in &self.pin_moves {
            state.x[k] = from;
        }
        let result = self.step_once(model, state);
        for &(k, from, to) in &self.pin_moves {
            state.x[k] = to;
            if result.is_ok() {
                // Where the next step's move of this pin starts, and the pin's own speed.
                state.x_prev[k] = to;
                state.v[k] = (to - from) / self.h;
            }
        }
        result
    }

    fn step_split(&mut self, model: &Model, state: &mut State, h: f64, depth: usize) -> Result<StepInfo, StepError> {
        self.h = h;
        // A failed step leaves the state as it was.
        let error = match self.step_pinned(model, state) {
            Ok(info) => return Ok(info),
            Err(e) => e,
        };
        if depth >= MAX_HALVINGS
            || self.params.scheme == Scheme::Lagged
            || matches!(error, StepError::LeftBehind { .. })
        {
            return Err(error);
        }
        let saved = state.clone();
        if depth == 0 {
            self.split.0 += 1;
        }
        // Two half steps from the saved state with the half step's history.
        let half = 0.5 * h;
        *state = saved.clone();
        for k in 0..state.x.len() {
            let a = (saved.v[k] - saved.v_prev[k]) / h;
            state.x_prev[k] = saved.x[k] - saved.v[k] * half + a * (0.5 * half * half);
            state.v_prev[k] = saved.v[k] - a * half;
        }
        // The pins move half way in each half.
        let moves = std::mem::take(&mut self.pin_moves);
        let half_of = |second: bool| {
            let half = |&(k, from, to): &(usize, Vec3, Vec3)| {
                let mid = (from + to) * 0.5;
                if second {
                    (k, mid, to)
                } else {
                    (k, from, mid)
                }
            };
            moves.iter().map(half).collect()
        };
        self.set_pin_moves(half_of(false), state);
        let mut info = self.step_split(model, state, half, depth + 1)?;
        state.step = saved.step;
        self.set_pin_moves(half_of(true), state);
        let second = self.step_split(model, state, half, depth + 1);
        self.pin_moves = moves;
        let second = second?;
        self.split.1 += 2;
        info.timings.add(&second.timings);
        info.timings.steps = 1;
        // The step's records are those at its start (the first half's).
        info.timings.self_contact_pairs = info.self_contacts;
        info.newton = info.newton.then(second.newton);
        info.max_penetration = second.max_penetration;
        // Back to the history of the whole step.
        state.x_prev.copy_from_slice(&saved.x);
        state.v_prev.copy_from_slice(&saved.v);
        state.step = saved.step + 1;
        state.time = saved.time + h;
        Ok(info)
    }

    fn step_once(&mut self, model: &Model, state: &mut State) -> Result<StepInfo, StepError> {
        let t0 = Instant::now();
        let contact_before = self.ws.contact_seconds;
        let self_term = model.potential.position::<SelfContact>();
        let self_before = self_term.map_or(0.0, |t| self.ws.term_seconds[t]);
        let refine_before = self.refine_seconds;
        let before = self.counters;
        let broad = |ws: &Workspace| self_term.and_then(|t| ws.scratch(t)).map_or((0, 0), SelfContact::broad_updates);
        let broad_before = broad(&self.ws);
        let step = state.step + 1;
        let first = self.assemble(model, state);
        let self_contacts = self_term.map_or(0, |t| model.potential.active_of(t, &self.ws));
        self.force_scale(model, state);
        let mut t_assembly = t0.elapsed().as_secs_f64();
        let (tf, t_solve, newton) = self.iterate(model, state, &mut t_assembly)?;
        let tv = Instant::now();
        let paths_before = self.ws.contact_seconds;
        let max_penetration = self.advance(model, state, step)?;
        // The continuous check of the paths is contact time spent after the solve.
        let paths = self.ws.contact_seconds - paths_before;
        let contact_time = self.ws.contact_seconds - contact_before;
        let refine = self.refine_seconds - refine_before;
        let broad_after = broad(&self.ws);
        let timings = Counters {
            assembly: (t_assembly - (contact_time - refine - paths)).max(0.0),
            contact: contact_time,
            self_contact: self_term.map_or(0.0, |t| self.ws.term_seconds[t]) - self_before,
            factorization: tf,
            solve: (t_solve - tf - refine).max(0.0) + (tv.elapsed().as_secs_f64() - paths).max(0.0),
            steps: 1,
            solves: self.counters.solves - before.solves,
            iterations: self.counters.iterations - before.iterations,
            factorizations: self.counters.factorizations - before.factorizations,
            resolves: self.counters.resolves - before.resolves,
            corrections: self.counters.corrections - before.corrections,
            unconverged: usize::from(!newton.converged),
            contact_steps: usize::from(newton.contact),
            residual_max: newton.residual,
            self_contact_pairs: self_contacts,
            broad_builds: broad_after.0 - broad_before.0,
            broad_refits: broad_after.1 - broad_before.1,
            iterative_steps: usize::from(self.solver.kind().iterative()),
        };
        // The solve loop counted this step's solves into `counters` as it went; `timings` holds them now.
        self.counters = before;
        self.counters.add(&timings);
        Ok(StepInfo {
            energies: Energies { membrane: first.membrane, bending: first.bending },
            contacts: first.contacts,
            self_contacts,
            contact_energy: first.contact,
            max_penetration,
            timings,
            newton,
        })
    }

    /// The Newton iterations of a step on its incremental potential `Φ` from the assembled first system: the
    /// linearised step; then, for a step without contact (no active set after the first solve), while the
    /// residual relative to the step's force scale exceeds [`StepParams::newton_tolerance`] (at most
    /// [`StepParams::newton_iterations`] iterations in all), a correction solved with the matrix at the iterate
    /// and taken by [`Stepper::line_search`], which never raises `Φ`; for a contact step,
    /// [`Stepper::contact_corrections`]. Returns the factorisation and the solve seconds and the outcome.
    fn iterate(
        &mut self,
        model: &Model,
        state: &State,
        t_assembly: &mut f64,
    ) -> Result<(f64, f64, NewtonReport), StepError> {
        // A failed step's iterations may have left the exact models on (the retaken halves start without).
        self.history.exact = false;
        let ts = Instant::now();
        let mut forcing = descent::Forcing::new(self.relative_residual(model));
        // A step that Newton will iterate (no contact found at its start) solves its linearised step loosely;
        // one that contact engages solves it to the contact steps' tolerance.
        let newton = self.params.scheme != Scheme::Lagged && model.potential.conservative();
        let free = newton && !model.potential.engaged(&self.ws);
        self.solver.set_free_motion(free);
        let loose = (self.solver.kind().iterative() && free).then_some(descent::FIRST_FORCING);
        let first = if free { loose } else { Some(self.params.contact_solve_tolerance) };
        self.merge = newton && !free;
        let mut tf = self.solve_with_active_sets(model, state, (0, first), self.operator())?;
        if loose.is_some() && model.potential.engaged(&self.ws) {
            // Contact engaged the loose solve after all: solved on from its solution.
            let tolerance = Some(self.params.contact_solve_tolerance);
            tf += self.linear_solve(state, model.pinned(), Reuse::Nearby, tolerance)?;
        }
        self.check_increment(state)?;
        for (y, d) in self.y.iter_mut().zip(&self.delta) {
            *y += *d;
        }
        let mut t_solve = ts.elapsed().as_secs_f64();
        let mut report = NewtonReport { iterations: 1, residual: 0.0, converged: true, contact: false };
        // Newton needs a consistent Jacobian: not the lagged secant operator, nor a force that is not the
        // gradient of an energy (Terzopoulos).
        if self.params.scheme == Scheme::Lagged || !model.potential.conservative() {
            return Ok((tf, t_solve, report));
        }
        self.reflect = Self::reflects(model, &self.ws);
        if model.potential.engaged(&self.ws) {
            report.contact = true;
            return self.contact_corrections(model, state, report, (tf, t_solve), t_assembly);
        }
        let ta = Instant::now();
        let mut phi = self.assemble_at(model, state, false, Want::GRADIENT).total;
        let mut res = self.relative_residual(model);
        *t_assembly += ta.elapsed().as_secs_f64();
        let tol = self.params.newton_tolerance;
        while (res > tol || res.is_nan()) && report.iterations < self.params.newton_iterations {
            let newton = (report.iterations, Some(forcing.next(res, tol)));
            tf += self.correction(model, state, newton, t_assembly, &mut t_solve)?;
            report.iterations += 1;
            self.counters.corrections += 1;
            let ta = Instant::now();
            let found = self.line_search(model, state, phi, res);
            *t_assembly += ta.elapsed().as_secs_f64();
            match found {
                Some((p, r)) => (phi, res) = (p, r),
                None => break,
            }
        }
        report.residual = res;
        report.converged = res <= tol;
        Ok((tf, t_solve, report))
    }

    /// The Newton rule of a contact step (an active contact or friction set after the first solve), decided at
    /// its first iterate (docs/model.md §8.5):
    ///
    /// - a *violent* step (a node's residual force above [`StepParams::contact_correction`] times the largest
    ///   nodal weight of its panel: the impact on the ball, the sewing's first pulls), or one with contact
    ///   records that keep what the step's start fixed (the pairs between faces, [`crate::potential::ActiveSet::
    ///   convergent`]), makes at most one correction, taken whole, when that force is large or the lagged
    ///   friction's linear model is off by more than its Coulomb limit;
    /// - any other contact step is iterated by Newton's method with the line search on `Φ`
    ///   ([`Stepper::line_search`], at most [`StepParams::newton_iterations`] iterations) while the contacts'
    ///   linear models of the last solve are off at the iterate by more than [`MODEL_TOLERANCE`] of the largest
    ///   contact force (the linearised gap misses the obstacle's curvature under a node that slides: the
    ///   capstan), or friction's by more than the same fraction of the largest Coulomb limit in the root mean
    ///   square over the records ([`Misfit::rms`]: a sliding region, not a few records flickering at the edge
    ///   of a sticking one); friction's model in these corrections is its law's own second-order one at each
    ///   iterate ([`crate::potential::Motion::exact`]).
    ///
    /// The residual relative to the step's force scale is measured after the last solve and reported, the step
    /// counted converged only where it is within [`StepParams::newton_tolerance`].
    fn contact_corrections(
        &mut self,
        model: &Model,
        state: &State,
        mut report: NewtonReport,
        (mut tf, mut t_solve): (f64, f64),
        t_assembly: &mut f64,
    ) -> Result<(f64, f64, NewtonReport), StepError> {
        let friction_error = |s: &mut Self| {
            let cx = model.potential.context(Some(s.history.motion(model, state, s.h, false)));
            model.potential.model_error(&s.y, &cx, &mut s.ws)
        };
        let merged = std::mem::take(&mut self.merged);
        if merged {
            // The first solve's new contacts and the membrane at its proposal, in one correction taken whole
            // (the violent rule's: [`Stepper::merges`]).
            let done = self.contact_correction(model, state, &mut report, t_assembly, &mut t_solve);
            model.potential.hold(&mut self.ws, false);
            tf += done?;
        }
        let friction = friction_error(self);
        let ta = Instant::now();
        let mut phi = self.assemble_at(model, state, false, Want::GRADIENT).total;
        *t_assembly += ta.elapsed().as_secs_f64();
        report.residual = self.relative_residual(model);
        let violent = merged || self.violent(model);
        let converge = !violent && model.potential.convergent(&self.ws);
        // The models' tolerances: a record's friction off by its Coulomb limit for the former rule (a slip
        // reversed within the step); for the iterated one, the friction field off by 5 % of the largest limit in
        // the root mean square over the records, so that a few records flickering between sticking and sliding
        // at the edge of a large sticking region do not keep the whole step iterating (the re-solves' own
        // tolerance, per record, still re-linearises those).
        let friction_off = |m: Misfit| {
            if converge {
                m.rms() > MODEL_TOLERANCE
            } else {
                m.largest > crate::potential::friction::NEWTON_TOLERANCE
            }
        };
        let contact_off = |s: &Self| converge && model.potential.linear_error(&s.ws) > MODEL_TOLERANCE;
        let cap = if converge { self.params.newton_iterations } else { self.params.newton_iterations.min(2) };
        let mut due = violent || friction_off(friction) || contact_off(self);
        self.history.exact = converge;
        while due && report.iterations < cap {
            // Friction's models are those of the solve until the next assembly re-linearises them: measured at
            // the full step.
            tf += self.contact_correction(model, state, &mut report, t_assembly, &mut t_solve)?;
            let friction_off = friction_off(friction_error(self));
            let ta = Instant::now();
            if converge {
                self.y.iter_mut().zip(&self.delta).for_each(|(y, d)| *y -= *d);
                let found = self.line_search(model, state, phi, report.residual);
                *t_assembly += ta.elapsed().as_secs_f64();
                let Some((p, r)) = found else { break };
                (phi, report.residual) = (p, r);
                due = friction_off || contact_off(self);
            } else {
                self.assemble_at(model, state, false, Want::GRADIENT);
                *t_assembly += ta.elapsed().as_secs_f64();
                report.residual = self.relative_residual(model);
                due = friction_off || self.violent(model);
            }
        }
        self.history.exact = false;
        report.converged = report.residual <= self.params.newton_tolerance;
        Ok((tf, t_solve, report))
    }

    /// One Newton correction of a contact step ([`Stepper::correction`], its solves to the contact steps'
    /// tolerance, the active sets refined on each solve's proposal), counted and taken whole: `y` moves by it.
    /// Returns the factorisation seconds.
    fn contact_correction(
        &mut self,
        model: &Model,
        state: &State,
        report: &mut NewtonReport,
        t_assembly: &mut f64,
        t_solve: &mut f64,
    ) -> Result<f64, StepError> {
        let newton = (report.iterations, Some(self.params.contact_solve_tolerance));
        let tf = self.correction(model, state, newton, t_assembly, t_solve)?;
        report.iterations += 1;
        self.counters.corrections += 1;
        self.y.iter_mut().zip(&self.delta).for_each(|(y, d)| *y += *d);
        Ok(tf)
    }

    /// Whether a free node's residual force in the last assembly exceeds [`StepParams::contact_correction`]
    /// times the largest nodal weight (or load) of its panel.
    fn violent(&self, model: &Model) -> bool {
        self.violent_force(model, &self.rhs, None)
    }

    /// The violent rule's test on `force` ([`Stepper::violent`]), the nodes `skip` marks left out.
    fn violent_force(&self, model: &Model, force: &[Vec3], skip: Option<&[bool]>) -> bool {
        let fixed = model.pinned();
        let threshold = self.params.contact_correction;
        (0..force.len()).any(|k| {
            !fixed[k]
                && !skip.is_some_and(|s| s[k])
                && force[k].length() > threshold * self.weights[self.panel_of[k] as usize]
        })
    }

    /// Solves Newton correction `newton.0` at the iterate `y` with the step's operator (its gradient kept in
    /// `g0`), the iterative solves to the relative tolerance `newton.1` (the forcing term; `None`: the solver's
    /// own). Returns the factorisation seconds. (The exact Hessian, with the positive semi-definite one where it
    /// does not factorise, was measured on the ball drop: its resting contact steps then converge quadratically,
    /// but its impact steps stall as before and half its contact steps stay unconverged at 4 iterations.)
    fn correction(
        &mut self,
        model: &Model,
        state: &State,
        newton: (usize, Option<f64>),
        t_assembly: &mut f64,
        t_solve: &mut f64,
    ) -> Result<f64, StepError> {
        let op = self.operator();
        let ta = Instant::now();
        self.assemble_at(model, state, false, Want { grad: true, hess: Some(op) });
        self.g0.copy_from_slice(&self.ws.grad);
        *t_assembly += ta.elapsed().as_secs_f64();
        let ts = Instant::now();
        let tf = self.solve_with_active_sets(model, state, newton, op)?;
        self.check_increment(state)?;
        *t_solve += ts.elapsed().as_secs_f64();
        Ok(tf)
    }

    /// A non-finite increment fails the step.
    fn check_increment(&self, state: &State) -> Result<(), StepError> {
        match self.delta.iter().position(|d| !finite(*d)) {
            Some(k) => Err(self.diverged(state.step + 1, format!("non-finite position at node {k}"))),
            None => Ok(()),
        }
    }

    /// Moves the iterate `y` (where `Φ = phi`, the relative residual is `res` and the gradient `g0`) along the
    /// solved increment to `y + α Δ`, `α` = 1 first, then shortened by the parabola through `Φ` along it
    /// ([`descent::backtrack`]), to the first point that lowers `Φ` by the Armijo fraction of its linear
    /// model (where `Φ` cannot resolve the decrease: the first that lowers the residual). Returns `Φ` and the
    /// relative residual there, the gradient assembled; `None`, with `y` unchanged, when no step longer than
    /// about 1e-6 does (Newton stops there).
    fn line_search(&mut self, model: &Model, state: &State, phi: f64, res: f64) -> Option<(f64, f64)> {
        let fixed = model.pinned();
        let slope: f64 = (0..self.y.len()).filter(|&k| !fixed[k]).map(|k| self.g0[k].dot(self.delta[k])).sum();
        self.y0.copy_from_slice(&self.y);
        let mut alpha = 1.0;
        for _ in 0..LINE_SEARCH_STEPS {
            for k in 0..self.y.len() {
                self.y[k] = self.y0[k] + self.delta[k] * alpha;
            }
            let trial = self.assemble_at(model, state, false, Want::GRADIENT).total;
            let r = self.relative_residual(model);
            let accept = if descent::resolvable(0.5 * alpha * slope, phi) {
                trial <= phi + descent::ARMIJO * alpha * slope
            } else {
                trial.is_finite() && r < res
            };
            if accept {
                return Some((trial, r));
            }
            alpha *= descent::backtrack(phi, alpha * slope, trial);
        }
        self.y.copy_from_slice(&self.y0);
        None
    }

    /// Each panel's force scale for the step (into `scales`), in the mass-weighted norm
    /// `‖f‖ = √(Σ |f_k|²/m_k)` over the panel's free nodes: the largest of the inertial force
    /// `m α (x_t − ŷ) + c β (x_t − z)` at the start of the step, the other forces of the first assembly there
    /// (elastic, loads, springs, contact, friction) and the panel's weight `|g| √(Σ m)` (the floor for a sheet at
    /// rest), at least [`STILL`] `· √(Σ m) · L / Δt²` with `L` the panel's size (the diagonal of its nodes' box):
    /// the force that would move the panel by `STILL · L` in a step, so that a sheet at rest without gravity or
    /// load, whose forces are round-off, has a scale a residual can be measured against. Called right after
    /// [`Stepper::assemble`].
    fn force_scale(&mut self, model: &Model, state: &State) {
        let h = &self.history;
        let panels = self.scales.len();
        let (mut inertial, mut others, mut mass) = (vec![0.0; panels], vec![0.0; panels], vec![0.0; panels]);
        let mut boxes = vec![(Vec3::INFINITY, Vec3::NEG_INFINITY); panels];
        for k in (0..state.x.len()).filter(|&k| !model.pinned()[k] && model.mass[k] > 0.0) {
            let (m, p) = (model.mass[k], self.panel_of[k] as usize);
            boxes[p] = (boxes[p].0.min(state.x[k]), boxes[p].1.max(state.x[k]));
            let f =
                (state.x[k] - h.target[k]) * (m * h.alpha) + (state.x[k] - h.center[k]) * (model.damping[k] * h.beta);
            inertial[p] += f.length_squared() / m;
            others[p] += (self.ws.grad[k] - f).length_squared() / m;
            mass[p] += m;
        }
        let g = model.gravity.length();
        for (p, scale) in self.scales.iter_mut().enumerate() {
            let weight = g * f64::sqrt(mass[p]);
            let size = if mass[p] > 0.0 { (boxes[p].1 - boxes[p].0).length() } else { 0.0 };
            let still = STILL * f64::sqrt(mass[p]) * size / (self.h * self.h);
            *scale = inertial[p].sqrt().max(others[p].sqrt()).max(weight).max(still).max(f64::MIN_POSITIVE);
        }
    }

    /// The residual of the last assembly (`rhs`) in the mass-weighted norm over each panel's free nodes,
    /// relative to the panel's force scale ([`Stepper::force_scale`]); the largest over the panels, so that a
    /// panel's convergence does not depend on another's forces.
    fn relative_residual(&self, model: &Model) -> f64 {
        let fixed = model.pinned();
        let mut r = vec![0.0; self.scales.len()];
        for k in (0..self.rhs.len()).filter(|&k| !fixed[k] && model.mass[k] > 0.0) {
            r[self.panel_of[k] as usize] += self.rhs[k].length_squared() / model.mass[k];
        }
        // A NaN residual stays NaN (f64::max would drop it).
        r.iter().zip(&self.scales).map(|(r, s)| r.sqrt() / s).fold(0.0, |a, b| if b.is_nan() || b > a { b } else { a })
    }

    /// Checks the speed bound, the paths through obstacles and the strain bound, then moves `state` to the new
    /// positions.
    fn advance(&mut self, model: &Model, state: &mut State, step: usize) -> Result<f64, StepError> {
        let idt = 1.0 / self.h;
        let mut worst_speed: f64 = 0.0;
        for k in 0..model.nodes() {
            worst_speed = worst_speed.max((self.y[k] - state.x[k]).length() * idt);
        }
        if worst_speed > self.bounds.max_speed {
            let what = format!("node speed {worst_speed:.3e} m/s exceeds the bound {:.3e} m/s", self.bounds.max_speed);
            return Err(self.diverged(step, what));
        }
        if let Some(k) = model.potential.tunnelled(&state.x, &self.y, &mut self.ws) {
            return Err(StepError::Tunnelled { step, node: k });
        }
        let strain = model.max_strain(&self.y);
        if strain > self.bounds.max_strain {
            let what =
                format!("edge strain {:.1}% exceeds the bound {:.0}%", 100.0 * strain, 100.0 * self.bounds.max_strain);
            return Err(self.diverged(step, what));
        }
        // Deep inside an obstacle is not a contact any more (a soft penalty overrun): non-physical.
        let cx = model.potential.context(None);
        let penetration = model.potential.violation(&self.y, &cx, &mut self.ws);
        let deepest = self.bounds.max_penetration(model);
        if penetration > deepest {
            let what = format!("a node is {penetration:.3e} m inside an obstacle (bound {deepest:.3e} m)");
            let hint = "the contact penalty is too soft for what presses the cloth on the obstacle: raise [contact] \
                        stiffness, or leave it out for the default (100 times the fabric's weight held within half \
                        the offset)";
            return Err(StepError::Diverged { step, what, hint });
        }
        if let Some(distance) = left_behind(model, &self.y) {
            return Err(StepError::LeftBehind { step, distance });
        }
        // Every check passed: only now is the state changed (a failed step leaves it as it was).
        // v⁺ = (3x⁺ − 4x_t + x⁻)/(2Δt): BDF2's own velocity, and the second-order estimate for central
        // differences (exact for a constant acceleration).
        std::mem::swap(&mut state.v_prev, &mut state.v);
        for k in 0..state.x.len() {
            state.v[k] = (self.y[k] * 3.0 - state.x[k] * 4.0 + state.x_prev[k]) * (0.5 * idt);
        }
        std::mem::swap(&mut state.x_prev, &mut state.x);
        state.x.copy_from_slice(&self.y);
        state.step = step;
        state.time += self.h;
        Ok(penetration)
    }

    fn diverged(&self, step: usize, what: String) -> StepError {
        StepError::Diverged { step, what, hint: self.hint() }
    }

    fn hint(&self) -> &'static str {
        match self.params.scheme {
            Scheme::Lagged => {
                "the paper's lagged scheme integrates stretching explicitly and is stable only for a time step below \
                 about h/sqrt(A11/rho) (9e-5 s for the 1 m, 21x21 demo sheet): use integrator = \"linearized\" or a \
                 much smaller dt"
            }
            Scheme::Linearized | Scheme::Bdf2 => {
                "try a smaller dt, a larger contact offset, or a softer contact stiffness (contact is implicit only to \
                 first order)"
            }
        }
    }
}

/// The consistent start of a dynamic run at positions `x` with velocities `v` (zero on fixed nodes) for the
/// step `dt`: the accelerations at t = 0 from every force of the model (elastic, gravity and loads, springs,
/// contact, damping `−c v`, Coulomb friction: kinetic for a sliding node, static up to `μλ` for one at rest) give the history of [`State::start`], so the first step makes no O(Δt) error
/// (docs/model.md §8.4). Non-finite forces are an error naming the node.
pub fn start(model: &Model, x: Vec<Vec3>, v: Vec<Vec3>, dt: f64) -> Result<State, StepError> {
    let n = x.len();
    not_crossing(model, &x)?;
    within_strain(model, &x, dt)?;
    let fixed = model.pinned();
    let mut grad = vec![Vec3::ZERO; n];
    model.potential.evaluate(&x, &mut crate::energy::Sink::grad(&mut grad));
    let mut force: Vec<Vec3> = (0..n).map(|k| -grad[k] - v[k] * model.damping[k]).collect();
    // Coulomb friction at t = 0: kinetic against a tangential velocity, else static up to the limit.
    for (k, normal, limit) in model.potential.coulomb(&x) {
        let tangential = |w: Vec3| w - normal * normal.dot(w);
        let vt = tangential(v[k]);
        let ft = tangential(force[k]);
        force[k] -= if vt.length() > 0.0 {
            vt * (limit / vt.length())
        } else if ft.length() <= limit {
            ft
        } else {
            ft * (limit / ft.length())
        };
    }
    let mut a = vec![Vec3::ZERO; n];
    let mut v = v;
    for k in 0..n {
        if fixed[k] {
            v[k] = Vec3::ZERO;
            continue;
        }
        let m = model.mass[k];
        if m > 0.0 {
            a[k] = force[k] / m;
        }
        if !finite(a[k]) || !finite(v[k]) {
            let what = format!("non-finite initial acceleration or velocity at node {k}");
            return Err(StepError::Diverged { step: 0, what, hint: "check the initial positions and velocities" });
        }
    }
    Ok(State::start(x, v, &a, dt))
}

/// A start at positions `x` with velocities `v` (zero on fixed nodes) whose history is uniform motion
/// (`x − Δt v`, no acceleration): for a configuration that no motion has just passed through, such as a sewn
/// garment whose seams were joined at the midpoints of their pairs ([`crate::garment::sewing`]). There the
/// forces are far from balance at the stiff cells beside the seams (the T-shirt's: up to 84 N on a node of
/// 13 mg at the neckline, 6.6e6 m/s²), a motion a step cannot resolve: [`start`]'s Taylor history `x + ½Δt² a` would move the
/// step's inertial target by `½Δt² a` (metres), and the first step would throw the cloth (docs/garments.md,
/// Sewing). The crossing check and the finiteness check are [`start`]'s.
pub fn start_unaccelerated(model: &Model, x: Vec<Vec3>, v: Vec<Vec3>, dt: f64) -> Result<State, StepError> {
    not_crossing(model, &x)?;
    let fixed = model.pinned();
    let v: Vec<Vec3> = v.iter().zip(fixed).map(|(&v, &f)| if f { Vec3::ZERO } else { v }).collect();
    if let Some(k) = (0..x.len()).find(|&k| !finite(x[k]) || !finite(v[k])) {
        let what = format!("non-finite initial position or velocity at node {k}");
        return Err(StepError::Diverged { step: 0, what, hint: "check the initial positions and velocities" });
    }
    let still = vec![Vec3::ZERO; x.len()];
    Ok(State::start(x, v, &still, dt))
}

/// An error where an edge at `x` is stretched beyond the strain a step accepts ([`Bounds::for_model`]): such a
/// start (a node of a damaged frame file 1e10 m away) failed its first step's factorisation ("not positive
/// definite") instead of naming the start.
fn within_strain(model: &Model, x: &[Vec3], dt: f64) -> Result<(), StepError> {
    let bound = Bounds::for_model(model, dt).max_strain;
    let strain = model.max_strain(x);
    // A NaN strain (a non-finite position) is left to the finiteness check, after the forces.
    if strain.is_nan() || strain <= bound {
        return Ok(());
    }
    Err(StepError::Stretched { strain: 100.0 * strain, bound: 100.0 * bound })
}

/// An error naming the first edge of `x` through a triangle, when the model has self-contact.
fn not_crossing(model: &Model, x: &[Vec3]) -> Result<(), StepError> {
    let Some(faces) = model.potential.find::<SelfContact>().map(SelfContact::faces) else { return Ok(()) };
    let Some((e, t)) = faces.crossing(x) else { return Ok(()) };
    let [a, b] = faces.edges[e];
    let name = |k: usize| model.describe_node(k);
    let [p, q, r] = faces.triangles[t].map(name);
    Err(StepError::Intersecting { edge_from: name(a), edge_to: name(b), triangle: format!("{p}, {q} and {r}") })
}

/// With obstacles, the distance of the sheet's centre from the nearest one when it exceeds 100 sheet lengths.
fn left_behind(model: &Model, x: &[Vec3]) -> Option<f64> {
    if x.is_empty() {
        return None;
    }
    let centre = x.iter().copied().sum::<Vec3>() / x.len() as f64;
    // The nearest obstacle, without collecting them (this runs every step).
    let d = model
        .potential
        .find::<crate::potential::contact::PenaltyContact>()
        .map_or(&[][..], |c| c.obstacles())
        .iter()
        .map(|o| o.distance(centre).0.abs())
        .fold(f64::INFINITY, f64::min);
    (d.is_finite() && d > 100.0 * model.length_scale()).then_some(d)
}

/// Deepest penetration below any obstacle's surface (0 when none), in metres.
pub fn max_penetration(model: &Model, x: &[Vec3]) -> f64 {
    model.potential.violation_cold(x)
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    /// `descent::backtrack`.
    pub fn backtrack(phi0: f64, slope: f64, phi1: f64) -> f64 {
        super::descent::backtrack(phi0, slope, phi1)
    }

    /// `descent::resolvable`.
    pub fn resolvable(pred: f64, value: f64) -> bool {
        super::descent::resolvable(pred, value)
    }
}
