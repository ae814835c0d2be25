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
//! The parameters of a step are one [`StepParams`]; a run is a [`Method`]: a dynamic integration or a static
//! solve ([`statics`]).

pub mod linsolve;
pub mod params;
pub mod statics;
// The stepper's warm state for checkpoints (issue 11).
mod resume;

use crate::energy::Operator;
use crate::math::{finite, Vec3};
use crate::model::{Energies, Model};
use crate::potential::inertia::Inertia;
use crate::potential::{Context, Motion, Stage, Values, Want, Workspace};
use crate::state::State;
use linsolve::{LinearError, LinearSolver};
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
    /// Contact detection and contact terms.
    pub contact: f64,
    /// Numeric factorisation (or preconditioner set-up).
    pub factorization: f64,
    /// Triangular solves (or CG iterations).
    pub solve: f64,
    /// Steps counted.
    pub steps: usize,
    /// Linear solves made (Newton iterations and contact active-set re-solves included).
    pub solves: usize,
}

impl Counters {
    /// Adds `other` stage by stage.
    pub fn add(&mut self, other: &Counters) {
        self.assembly += other.assembly;
        self.contact += other.contact;
        self.factorization += other.factorization;
        self.solve += other.solve;
        self.steps += other.steps;
        self.solves += other.solves;
    }
}

/// What one step reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct StepInfo {
    /// Elastic energies at `x_t` (the start of the step).
    pub energies: Energies,
    /// Active contacts at `x_t`.
    pub contacts: usize,
    /// Penalty energy at `x_t`.
    pub contact_energy: f64,
    /// Deepest penetration below the obstacle surface after the step (m, ≥ 0).
    pub max_penetration: f64,
    /// This step's seconds per stage (`steps` = 1, `solves` its linear solves).
    pub timings: Counters,
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
    y: Vec<Vec3>,
}

impl Stepper {
    /// Workspace for `model` with `params`; the symbolic factorisation happens here, once.
    pub fn new(model: &Model, params: &StepParams) -> Result<Self, StepError> {
        let pattern = model.potential.pattern();
        let n = model.grid.len();
        Ok(Self {
            params: *params,
            bounds: params.bounds.unwrap_or_else(|| Bounds::for_model(model)),
            counters: Counters::default(),
            solver: LinearSolver::new(params.solver, pattern).map_err(|cause| StepError::Linear { step: 0, cause })?,
            ws: Workspace::new(&model.potential),
            rhs: vec![Vec3::ZERO; n],
            delta: vec![Vec3::ZERO; n],
            y: vec![Vec3::ZERO; n],
        })
    }

    fn operator(&self) -> Operator {
        match self.params.scheme {
            Scheme::Linearized => Operator::Projected,
            Scheme::Lagged => Operator::Secant,
        }
    }

    /// Assembles the step system at `state` without solving: afterwards [`Stepper::matrix`] is `A_t` (before
    /// pinned unknowns are eliminated) and [`Stepper::rhs`] the right-hand side for the increment `x⁺ − x_t`.
    pub fn assemble(&mut self, model: &Model, state: &State) -> Values {
        self.y.copy_from_slice(&state.x);
        let want = Want { grad: true, hess: Some(self.operator()) };
        self.assemble_at(model, state, true, want)
    }

    /// The step's context: the motion from `state`.
    fn context<'a>(model: &'a Model, state: &'a State, dt: f64, predict: bool) -> Context<'a> {
        let motion =
            Motion { x: &state.x, x_prev: &state.x_prev, dt, mass: &model.mass, damping: &model.damping, predict };
        model.potential.context(Some(motion))
    }

    /// Assembles the Newton system of the implicit central-difference equation
    /// `M(y − 2x_t + x⁻)/Δt² + C(y − x⁻)/(2Δt) + ∇Π(y) = 0` at the iterate `y = self.y`: the matrix
    /// `M/Δt² + C/(2Δt) + K(y)` (when `want` asks for it) and the residual, the right-hand side for the
    /// correction of `y`. At `y = x_t` this is exactly the linearised step (46)–(48). With `predict`, contact
    /// candidates also include nodes whose extrapolated position `2x_t − x⁻` is inside the contact layer.
    fn assemble_at(&mut self, model: &Model, state: &State, predict: bool, want: Want) -> Values {
        let cx = Self::context(model, state, self.params.dt, predict);
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

    /// Solves the assembled system for `self.delta`, correcting the active sets (contact) by re-solving.
    fn solve_with_active_sets(&mut self, model: &Model, state: &State) -> Result<f64, StepError> {
        let mut tf = 0.0;
        let want = Want { grad: true, hess: Some(self.operator()) };
        for round in 0..=self.params.active_set_rounds {
            self.delta.copy_from_slice(&self.rhs);
            let (f, _) = self
                .solver
                .solve(model.potential.pattern(), &self.ws.matrix, model.pinned(), &mut self.delta, round > 0)
                .map_err(|cause| StepError::Linear { step: state.step + 1, cause })?;
            tf += f;
            self.counters.solves += 1;
            if round == self.params.active_set_rounds {
                break;
            }
            let cx = Self::context(model, state, self.params.dt, false);
            if !model.potential.refine(&self.y, &self.delta, &cx, want, &mut self.ws) {
                break;
            }
            self.residual_from_gradient(model);
        }
        Ok(tf)
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

    /// Advances `state` by `params.dt`. The first iteration is the linearised step (46)–(48) with the
    /// positive semi-definite `K(x_t)`; while the residual of the implicit equation at the new positions exceeds
    /// [`StepParams::newton_tolerance`] times the largest nodal weight, Newton corrections follow (at most
    /// [`StepParams::newton_iterations`] iterations in all): large rotations within one step then do not show up
    /// as spurious stretch. Contact is implicit: the penalty stiffness is in the matrix for every node inside
    /// the contact layer at the start of the step or predicted to enter it, and the active set is corrected by
    /// re-solving (at most [`StepParams::active_set_rounds`] times) when the solution disagrees.
    pub fn step(&mut self, model: &Model, state: &mut State) -> Result<StepInfo, StepError> {
        let t0 = Instant::now();
        let contact_before = self.ws.contact_seconds;
        let solves_before = self.counters.solves;
        let step = state.step + 1;
        let first = self.assemble(model, state);
        let force_scale = model.potential.load_scale(Some(Stage::Field), model.length_scale());
        let mut t_assembly = t0.elapsed().as_secs_f64();
        let (tf, t_solve) = self.iterate(model, state, force_scale, &mut t_assembly)?;
        let tv = Instant::now();
        self.advance(model, state, step)?;
        let cx = model.potential.context(None);
        let max_penetration = model.potential.violation(&state.x, &cx, &mut self.ws);
        let contact_time = self.ws.contact_seconds - contact_before;
        let timings = Counters {
            assembly: t_assembly - contact_time,
            contact: contact_time,
            factorization: tf,
            solve: t_solve - tf + tv.elapsed().as_secs_f64(),
            steps: 1,
            solves: self.counters.solves - solves_before,
        };
        // The solve loop counted this step's solves into `counters` as it went; `timings` holds them now.
        self.counters.solves = solves_before;
        self.counters.add(&timings);
        Ok(StepInfo {
            energies: Energies { membrane: first.membrane, bending: first.bending },
            contacts: first.contacts,
            contact_energy: first.contact,
            max_penetration,
            timings,
        })
    }

    /// The Newton iterations of a step from the assembled first system; returns the factorisation and the
    /// solve seconds.
    fn iterate(
        &mut self,
        model: &Model,
        state: &State,
        force_scale: f64,
        t_assembly: &mut f64,
    ) -> Result<(f64, f64), StepError> {
        let n = model.grid.len();
        let (mut tf, mut t_solve) = (0.0, 0.0);
        for iter in 0..self.params.newton_iterations.max(1) {
            if iter > 0 {
                let ta = Instant::now();
                // Residual first (gradient and contact forces only); the matrix only if a correction is due.
                self.assemble_at(model, state, false, Want::GRADIENT);
                let res = (0..n).filter(|&k| !model.pinned()[k]).map(|k| self.rhs[k].length()).fold(0.0, f64::max);
                if res <= self.params.newton_tolerance * force_scale {
                    *t_assembly += ta.elapsed().as_secs_f64();
                    break;
                }
                self.assemble_at(model, state, false, Want { grad: true, hess: Some(self.operator()) });
                *t_assembly += ta.elapsed().as_secs_f64();
            }
            let ts = Instant::now();
            tf += self.solve_with_active_sets(model, state)?;
            for k in 0..n {
                let d = self.delta[k];
                if !finite(d) {
                    return Err(self.diverged(state.step + 1, format!("non-finite position at node {k}")));
                }
                self.y[k] += d;
            }
            t_solve += ts.elapsed().as_secs_f64();
            // Newton corrections need a consistent Jacobian: not for the lagged secant operator, nor for a
            // force that is not the gradient of an energy (Terzopoulos).
            if self.params.scheme == Scheme::Lagged || !model.potential.conservative() || force_scale == 0.0 {
                break;
            }
        }
        Ok((tf, t_solve))
    }

    /// Checks the speed bound, moves `state` to the new positions and checks the strain bound.
    fn advance(&mut self, model: &Model, state: &mut State, step: usize) -> Result<(), StepError> {
        let idt = 1.0 / self.params.dt;
        let mut worst_speed: f64 = 0.0;
        for k in 0..model.grid.len() {
            worst_speed = worst_speed.max((self.y[k] - state.x[k]).length() * idt);
        }
        if worst_speed > self.bounds.max_speed {
            let what = format!("node speed {worst_speed:.3e} m/s exceeds the bound {:.3e} m/s", self.bounds.max_speed);
            return Err(self.diverged(step, what));
        }
        std::mem::swap(&mut state.x_prev, &mut state.x);
        state.x.copy_from_slice(&self.y);
        state.step = step;
        state.time += self.params.dt;
        let strain = model.max_strain(&state.x);
        if strain > self.bounds.max_strain {
            let what =
                format!("edge strain {:.1}% exceeds the bound {:.0}%", 100.0 * strain, 100.0 * self.bounds.max_strain);
            return Err(self.diverged(step, what));
        }
        Ok(())
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
            Scheme::Linearized => {
                "try a smaller dt, a larger contact offset, or a softer contact stiffness (contact is implicit only to \
                 first order)"
            }
        }
    }
}

/// Deepest penetration below any obstacle's surface (0 when none), in metres.
pub fn max_penetration(model: &Model, x: &[Vec3]) -> f64 {
    model.potential.violation_cold(x)
}
