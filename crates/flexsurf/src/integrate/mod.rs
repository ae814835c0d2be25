//! Time integration (MODEL.md §5). Both schemes solve the central-difference system of the paper's (46)–(48)
//!
//! `(M/Δt² + C/(2Δt) + K) Δ = f_ext − ∇E(x_t) + M (x_t − x⁻)/Δt² − C (x_t − x⁻)/(2Δt)`, `x⁺ = x_t + Δ`,
//!
//! which is `A_t x⁺ = g_t` written for the increment. They differ in `K`:
//! - [`IntegratorKind::Linearized`] (default): `K = H⁺(x_t)`, the PSD-projected Hessian plus contact and spring
//!   stiffness: implicit in the material stiffness, unconditionally stable, exactly (46)–(48) for a linear system.
//! - [`IntegratorKind::Lagged`]: the paper's lagged-coefficient secant operator. It integrates stretching
//!   explicitly (stable only below about `h/√(A11/ρ)`, 9e-5 s on the 1 m, 21×21 demo sheet) and detects its own
//!   divergence.

pub mod linsolve;
pub mod statics;

use crate::contact::{self, Contact};
use crate::energy::{Operator, Sink};
use crate::math::{diag, finite, Vec3};
use crate::model::{Energies, Model};
use crate::sparse::BlockMatrix;
use crate::state::State;
use linsolve::{LinearError, LinearSolver, SolverKind};
use serde::{Deserialize, Serialize};
use std::time::Instant;
use thiserror::Error;

/// The time-stepping scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorKind {
    /// Linearised implicit step with `H⁺` (default).
    #[default]
    Linearized,
    /// The paper's literal lagged-coefficient step.
    Lagged,
}

impl IntegratorKind {
    /// Name used in scenes and summaries.
    pub fn name(&self) -> &'static str {
        match self {
            IntegratorKind::Linearized => "linearized",
            IntegratorKind::Lagged => "lagged",
        }
    }
}

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
    #[error("linear solve failed at step {step}: {source}")]
    Linear {
        /// Step.
        step: usize,
        /// Cause.
        source: LinearError,
    },
}

/// Limits beyond which a run counts as diverged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bounds {
    /// Largest node speed (m/s).
    pub max_speed: f64,
    /// Largest engineering edge strain.
    pub max_strain: f64,
}

impl Bounds {
    /// Default bounds for a model: speed `100 √(|g| L)` (or `100 L` per second without gravity) and strain 1.
    pub fn for_model(model: &Model) -> Self {
        let l = model.length_scale();
        let g = model.gravity.length();
        let v = if g > 0.0 { (g * l).sqrt() } else { l };
        Self { max_speed: 100.0 * v, max_strain: 1.0 }
    }
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
}

/// Scratch buffers and the solver of one run (rapier's "pipeline" pattern: no physics state lives here).
pub struct Stepper {
    /// Scheme.
    pub kind: IntegratorKind,
    /// Divergence bounds.
    pub bounds: Bounds,
    /// Per-stage timings.
    pub counters: Counters,
    solver: LinearSolver,
    matrix: BlockMatrix,
    diag: Vec<u32>,
    grad: Vec<Vec3>,
    rhs: Vec<Vec3>,
    contacts: Vec<Contact>,
}

impl Stepper {
    /// Workspace for `model`; the symbolic factorisation happens here, once.
    pub fn new(model: &Model, kind: IntegratorKind, solver: SolverKind) -> Result<Self, StepError> {
        let pattern = &model.elastic.pattern;
        let n = model.grid.len();
        Ok(Self {
            kind,
            bounds: Bounds::for_model(model),
            counters: Counters::default(),
            solver: LinearSolver::new(solver, pattern).map_err(|source| StepError::Linear { step: 0, source })?,
            matrix: BlockMatrix::zeros(pattern),
            diag: (0..n).map(|k| pattern.find(k, k) as u32).collect(),
            grad: vec![Vec3::ZERO; n],
            rhs: vec![Vec3::ZERO; n],
            contacts: Vec::new(),
        })
    }

    /// Assembles the step system at `state` without solving: afterwards [`Stepper::matrix`] is `A_t` (before
    /// pinned unknowns are eliminated) and [`Stepper::rhs`] the right-hand side for the increment `x⁺ − x_t`.
    /// Returns the energies, the number of contacts and the penalty energy at `x_t`.
    pub fn assemble(&mut self, model: &Model, state: &State, dt: f64) -> (Energies, usize, f64) {
        let n = model.grid.len();
        self.grad.fill(Vec3::ZERO);
        self.matrix.clear();
        let op = match self.kind {
            IntegratorKind::Linearized => Operator::Projected,
            IntegratorKind::Lagged => Operator::Secant,
        };
        let energies = model
            .elastic
            .evaluate(&state.x, &mut Sink { grad: Some(&mut self.grad), hess: Some((&mut self.matrix, op)) });
        let (idt, idt2) = (1.0 / dt, 1.0 / (dt * dt));
        for k in 0..n {
            let (m, c) = (model.mass[k], model.damping[k]);
            let dx = state.x[k] - state.x_prev[k];
            self.rhs[k] = model.external_force(k) - self.grad[k] + dx * (m * idt2) - dx * (0.5 * c * idt);
            self.matrix.blocks[self.diag[k] as usize] += diag(m * idt2 + 0.5 * c * idt);
        }
        for s in &model.springs {
            self.rhs[s.node] += (s.target - state.x[s.node]) * s.stiffness;
            self.matrix.blocks[self.diag[s.node] as usize] += diag(s.stiffness);
        }
        let t1 = Instant::now();
        contact::detect(&model.obstacles, &model.contact, &model.area, &state.x, &mut self.contacts);
        let mut contact_energy = 0.0;
        for c in &self.contacts {
            let k = c.node;
            self.rhs[k] += c.force_vector()
                + contact::friction(c, model.contact.friction, state.velocity(k, dt), model.mass[k], dt);
            self.matrix.blocks[self.diag[k] as usize] += c.stiffness_block();
            contact_energy += c.energy();
        }
        for (k, &p) in model.pinned.iter().enumerate() {
            if p {
                self.rhs[k] = Vec3::ZERO;
            }
        }
        self.counters.contact += t1.elapsed().as_secs_f64();
        (energies, self.contacts.len(), contact_energy)
    }

    /// The step matrix of the last [`Stepper::assemble`].
    pub fn matrix(&self) -> &BlockMatrix {
        &self.matrix
    }

    /// The right-hand side of the last [`Stepper::assemble`] (overwritten by the increment after a step).
    pub fn rhs(&self) -> &[Vec3] {
        &self.rhs
    }

    /// Advances `state` by `dt`.
    pub fn step(&mut self, model: &Model, state: &mut State, dt: f64) -> Result<StepInfo, StepError> {
        let t0 = Instant::now();
        let n = model.grid.len();
        let idt = 1.0 / dt;
        let contact_before = self.counters.contact;
        let (energies, contacts, contact_energy) = self.assemble(model, state, dt);
        let t1 = Instant::now();
        let t2 = t1;
        let (tf, _ts) = self
            .solver
            .solve(&model.elastic.pattern, &self.matrix, &model.pinned, &mut self.rhs)
            .map_err(|source| StepError::Linear { step: state.step + 1, source })?;
        let step = state.step + 1;
        let mut worst_speed: f64 = 0.0;
        for k in 0..n {
            let d = self.rhs[k];
            if !finite(d) {
                return Err(StepError::Diverged {
                    step,
                    what: format!("non-finite position at node {k}"),
                    hint: self.hint(),
                });
            }
            worst_speed = worst_speed.max(d.length() * idt);
        }
        if worst_speed > self.bounds.max_speed {
            return Err(StepError::Diverged {
                step,
                what: format!("node speed {worst_speed:.3e} m/s exceeds the bound {:.3e} m/s", self.bounds.max_speed),
                hint: self.hint(),
            });
        }
        std::mem::swap(&mut state.x_prev, &mut state.x);
        for k in 0..n {
            state.x[k] = state.x_prev[k] + self.rhs[k];
        }
        state.step = step;
        state.time += dt;
        let strain = model.max_strain(&state.x);
        if strain > self.bounds.max_strain {
            return Err(StepError::Diverged {
                step,
                what: format!(
                    "edge strain {:.1}% exceeds the bound {:.0}%",
                    100.0 * strain,
                    100.0 * self.bounds.max_strain
                ),
                hint: self.hint(),
            });
        }
        let max_penetration = max_penetration(model, &state.x);
        let t3 = Instant::now();
        self.counters.assembly += t1.duration_since(t0).as_secs_f64() - (self.counters.contact - contact_before);
        self.counters.factorization += tf;
        self.counters.solve += (t3 - t2).as_secs_f64() - tf;
        self.counters.steps += 1;
        Ok(StepInfo { energies, contacts, contact_energy, max_penetration })
    }

    fn hint(&self) -> &'static str {
        match self.kind {
            IntegratorKind::Lagged => {
                "the paper's lagged scheme integrates stretching explicitly and is stable only for a time step below \
                 about h/sqrt(A11/rho) (9e-5 s for the 1 m, 21x21 demo sheet): use integrator = \"linearized\" or a \
                 much smaller dt"
            }
            IntegratorKind::Linearized => {
                "try a smaller dt, a larger contact offset, or a softer contact stiffness (contact is implicit only to \
                 first order)"
            }
        }
    }
}

/// Deepest penetration below any obstacle's surface (0 when none), in metres.
pub fn max_penetration(model: &Model, x: &[Vec3]) -> f64 {
    let mut worst: f64 = 0.0;
    for p in x {
        for o in &model.obstacles {
            worst = worst.max(-o.distance(*p).0);
        }
    }
    worst
}
