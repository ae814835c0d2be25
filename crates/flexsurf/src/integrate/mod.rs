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
use crate::model::{Energies, Model, ModelKind};
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
    /// No time stepping: the quasi-static equilibrium (drape) by projected Newton ([`statics`]). A run then
    /// writes the initial and the equilibrium frame.
    Static,
}

impl IntegratorKind {
    /// Name used in scenes and summaries.
    pub fn name(&self) -> &'static str {
        match self {
            IntegratorKind::Linearized => "linearized",
            IntegratorKind::Lagged => "lagged",
            IntegratorKind::Static => "static",
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
    #[error("linear solve failed at step {step}: {cause}")]
    Linear {
        /// Step.
        step: usize,
        /// Cause.
        cause: LinearError,
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
    /// Linear solves made (Newton iterations and contact active-set re-solves included).
    pub solves: usize,
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
    rhs_base: Vec<Vec3>,
    delta: Vec<Vec3>,
    predicted: Vec<Vec3>,
    has_contact: Vec<bool>,
    saved: Vec<(usize, crate::math::Mat3)>,
    contacts: Vec<Contact>,
    cache: contact::ContactCache,
    y: Vec<Vec3>,
    /// Most Newton iterations per step. The first is the linearised step of the paper's form; the default 2
    /// allows one correction towards the fully implicit central-difference solution when the residual is large.
    pub newton_iterations: usize,
    /// Residual (N) above which a Newton correction is made, relative to the largest nodal weight (or load).
    /// The default 100 triggers corrections only at violent events such as the impact on the ball, where the
    /// linearised step alone stretches the sheet by 3.2% (measured, 21×21 ball drop, step 16) and one
    /// correction brings the peak strain to 0.2%; smooth steps are not corrected.
    pub newton_tolerance: f64,
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
            solver: LinearSolver::new(solver, pattern).map_err(|cause| StepError::Linear { step: 0, cause })?,
            matrix: BlockMatrix::zeros(pattern),
            diag: (0..n).map(|k| pattern.find(k, k) as u32).collect(),
            grad: vec![Vec3::ZERO; n],
            rhs: vec![Vec3::ZERO; n],
            rhs_base: vec![Vec3::ZERO; n],
            delta: vec![Vec3::ZERO; n],
            predicted: vec![Vec3::ZERO; n],
            has_contact: vec![false; n],
            saved: Vec::new(),
            contacts: Vec::new(),
            cache: contact::ContactCache::new(model.obstacles.len(), n),
            y: vec![Vec3::ZERO; n],
            newton_iterations: 2,
            newton_tolerance: 100.0,
        })
    }

    /// Assembles the step system at `state` without solving: afterwards [`Stepper::matrix`] is `A_t` (before
    /// pinned unknowns are eliminated) and [`Stepper::rhs`] the right-hand side for the increment `x⁺ − x_t`.
    /// Returns the energies, the number of contacts and the penalty energy at `x_t`.
    pub fn assemble(&mut self, model: &Model, state: &State, dt: f64) -> (Energies, usize, f64) {
        self.y.copy_from_slice(&state.x);
        self.assemble_at(model, state, dt, true, true)
    }

    /// Assembles the Newton system of the implicit central-difference equation
    /// `M(y − 2x_t + x⁻)/Δt² + C(y − x⁻)/(2Δt) + ∇E(y) = f(y)` at the iterate `y = self.y`: the matrix
    /// `M/Δt² + C/(2Δt) + K(y)` and the residual, the right-hand side for the correction of `y`. At `y = x_t`
    /// this is exactly the linearised step (46)–(48). With `predict`, contact candidates also include nodes whose
    /// extrapolated position `2x_t − x⁻` is inside the contact layer.
    fn assemble_at(
        &mut self,
        model: &Model,
        state: &State,
        dt: f64,
        predict: bool,
        with_matrix: bool,
    ) -> (Energies, usize, f64) {
        let n = model.grid.len();
        self.grad.fill(Vec3::ZERO);
        let op = match self.kind {
            IntegratorKind::Linearized | IntegratorKind::Static => Operator::Projected,
            IntegratorKind::Lagged => Operator::Secant,
        };
        let energies = if with_matrix {
            self.matrix.clear();
            model
                .elastic
                .evaluate(&self.y, &mut Sink { grad: Some(&mut self.grad), hess: Some((&mut self.matrix, op)) })
        } else {
            model.elastic.evaluate(&self.y, &mut Sink::grad(&mut self.grad))
        };
        let (idt, idt2) = (1.0 / dt, 1.0 / (dt * dt));
        for k in 0..n {
            let (m, c) = (model.mass[k], model.damping[k]);
            let (y, x, xm) = (self.y[k], state.x[k], state.x_prev[k]);
            self.rhs[k] =
                model.external_force(k) - self.grad[k] - (y - x * 2.0 + xm) * (m * idt2) - (y - xm) * (0.5 * c * idt);
            if with_matrix {
                self.matrix.blocks[self.diag[k] as usize] += diag(m * idt2 + 0.5 * c * idt);
            }
        }
        for s in &model.springs {
            self.rhs[s.node] += (s.target - self.y[s.node]) * s.stiffness;
            if with_matrix {
                self.matrix.blocks[self.diag[s.node] as usize] += diag(s.stiffness);
            }
        }
        for (k, &p) in model.pinned.iter().enumerate() {
            if p {
                self.rhs[k] = Vec3::ZERO;
            }
        }
        let t1 = Instant::now();
        self.rhs_base.copy_from_slice(&self.rhs);
        for (k, p) in self.predicted.iter_mut().enumerate() {
            *p = if predict { state.x[k] * 2.0 - state.x_prev[k] } else { self.y[k] };
        }
        contact::detect_predicted(
            &model.obstacles,
            &model.contact,
            &model.area,
            &self.y,
            &self.predicted,
            &mut self.cache,
            &mut self.contacts,
        );
        if with_matrix {
            self.apply_contacts(model, state, dt);
        } else {
            for c in &self.contacts {
                let k = c.node;
                if !model.pinned[k] {
                    self.rhs[k] += c.force_vector()
                        + contact::friction(c, model.contact.friction, state.velocity(k, dt), model.mass[k], dt);
                }
            }
        }
        let contact_energy = self.contacts.iter().map(|c| c.energy()).sum();
        let touching = self.contacts.iter().filter(|c| c.force > 0.0).count();
        self.counters.contact += t1.elapsed().as_secs_f64();
        (energies, touching, contact_energy)
    }

    /// Adds the current contacts to the base system (saving the diagonal blocks they change).
    fn apply_contacts(&mut self, model: &Model, state: &State, dt: f64) {
        self.rhs.copy_from_slice(&self.rhs_base);
        self.saved.clear();
        for c in &self.contacts {
            let k = c.node;
            if model.pinned[k] {
                continue;
            }
            let id = self.diag[k] as usize;
            self.saved.push((id, self.matrix.blocks[id]));
            self.rhs[k] += c.force_vector()
                + contact::friction(c, model.contact.friction, state.velocity(k, dt), model.mass[k], dt);
            self.matrix.blocks[id] += c.stiffness_block();
        }
    }

    /// Undoes [`Stepper::apply_contacts`] on the matrix (restores the saved blocks, last first).
    fn remove_contacts(&mut self) {
        for &(id, blk) in self.saved.iter().rev() {
            self.matrix.blocks[id] = blk;
        }
        self.saved.clear();
    }

    /// Active-set update after a solve giving the correction `delta` of `self.y`: a contact stays if its
    /// linearised gap at the new position is inside the layer; a node that ends inside the layer without a
    /// contact gets one, linearised at its new position. Returns true if the set changed.
    fn update_active_set(&mut self, model: &Model, delta: &[Vec3]) -> bool {
        let params = &model.contact;
        let before = self.contacts.len();
        let y = &self.y;
        self.contacts.retain(|c| c.gap(y[c.node] + delta[c.node]) < params.offset);
        let mut changed = self.contacts.len() != before;
        self.has_contact.iter_mut().for_each(|f| *f = false);
        for c in &self.contacts {
            self.has_contact[c.node] = true;
        }
        for k in 0..y.len() {
            if self.has_contact[k] || model.pinned[k] {
                continue;
            }
            let q = y[k] + delta[k];
            if self.cache.lower_bound(k, q) >= params.offset {
                continue;
            }
            if let Some((d, n)) = contact::closest_cached(&model.obstacles, &mut self.cache, k, q, params.offset) {
                if d < params.offset {
                    self.contacts.push(contact::Contact::new(k, y[k], q, d, n, params, model.area[k]));
                    changed = true;
                }
            }
        }
        if changed {
            self.contacts.sort_by_key(|c| c.node);
        }
        changed
    }

    /// Solves the assembled system for `self.delta`, correcting the contact active set.
    fn solve_with_contacts(&mut self, model: &Model, state: &State, dt: f64) -> Result<f64, StepError> {
        let mut tf = 0.0;
        for round in 0..=Self::ACTIVE_SET_ROUNDS {
            self.delta.copy_from_slice(&self.rhs);
            let (f, _) = self
                .solver
                .solve(&model.elastic.pattern, &self.matrix, &model.pinned, &mut self.delta, round > 0)
                .map_err(|cause| StepError::Linear { step: state.step + 1, cause })?;
            tf += f;
            self.counters.solves += 1;
            if model.obstacles.is_empty() || model.contact.stiffness <= 0.0 || round == Self::ACTIVE_SET_ROUNDS {
                break;
            }
            let delta = std::mem::take(&mut self.delta);
            let changed = self.update_active_set(model, &delta);
            self.delta = delta;
            if !changed {
                break;
            }
            self.remove_contacts();
            self.apply_contacts(model, state, dt);
        }
        self.remove_contacts();
        Ok(tf)
    }

    /// Non-zeros of the Cholesky factor (0 for PCG).
    pub fn factor_nnz(&self) -> usize {
        match &self.solver {
            LinearSolver::Cholesky(c) => c.factor_nnz(),
            LinearSolver::Pcg(_) => 0,
        }
    }

    /// The step matrix of the last [`Stepper::assemble`] (contacts included).
    pub fn matrix(&self) -> &BlockMatrix {
        &self.matrix
    }

    /// The right-hand side of the last [`Stepper::assemble`].
    pub fn rhs(&self) -> &[Vec3] {
        &self.rhs
    }

    /// Most re-solves per Newton iteration while the contact active set changes.
    pub const ACTIVE_SET_ROUNDS: usize = 4;

    /// Advances `state` by `dt`. The first iteration is the linearised step (46)–(48) with `K = H⁺(x_t)`;
    /// while the residual of the implicit equation at the new positions exceeds
    /// [`Stepper::newton_tolerance`] times the largest nodal weight, Newton corrections follow (at most
    /// [`Stepper::newton_iterations`] iterations in all): large rotations within one step then do not show up
    /// as spurious stretch. Contact is implicit: the penalty stiffness is in the matrix for every node inside
    /// the contact layer at the start of the step or predicted to enter it, and the active set is corrected by
    /// re-solving (at most [`Stepper::ACTIVE_SET_ROUNDS`] times) when the solution disagrees.
    pub fn step(&mut self, model: &Model, state: &mut State, dt: f64) -> Result<StepInfo, StepError> {
        let t0 = Instant::now();
        let n = model.grid.len();
        let idt = 1.0 / dt;
        let contact_before = self.counters.contact;
        let step = state.step + 1;
        let (energies, contacts, contact_energy) = self.assemble(model, state, dt);
        let force_scale = (0..n)
            .map(|k| (model.gravity * model.mass[k]).length())
            .fold(0.0, f64::max)
            .max((0..n).map(|k| model.loads[k].length()).fold(0.0, f64::max));
        let mut t_assembly = t0.elapsed().as_secs_f64();
        let mut tf = 0.0;
        let mut t_solve = 0.0;
        for iter in 0..self.newton_iterations.max(1) {
            if iter > 0 {
                let ta = Instant::now();
                // Residual first (gradient and contact forces only); the matrix only if a correction is due.
                self.assemble_at(model, state, dt, false, false);
                let res = (0..n).filter(|&k| !model.pinned[k]).map(|k| self.rhs[k].length()).fold(0.0, f64::max);
                if res <= self.newton_tolerance * force_scale {
                    t_assembly += ta.elapsed().as_secs_f64();
                    break;
                }
                self.assemble_at(model, state, dt, false, true);
                t_assembly += ta.elapsed().as_secs_f64();
            }
            let ts = Instant::now();
            tf += self.solve_with_contacts(model, state, dt)?;
            for k in 0..n {
                let d = self.delta[k];
                if !finite(d) {
                    return Err(StepError::Diverged {
                        step,
                        what: format!("non-finite position at node {k}"),
                        hint: self.hint(),
                    });
                }
                self.y[k] += d;
            }
            t_solve += ts.elapsed().as_secs_f64();
            // Newton corrections need a consistent Jacobian: not for the lagged secant operator, nor for the
            // Terzopoulos force, which is not the gradient of an energy.
            if self.kind == IntegratorKind::Lagged || model.elastic.kind == ModelKind::Terzopoulos || force_scale == 0.0
            {
                break;
            }
        }
        let tv = Instant::now();
        let mut worst_speed: f64 = 0.0;
        for k in 0..n {
            worst_speed = worst_speed.max((self.y[k] - state.x[k]).length() * idt);
        }
        if worst_speed > self.bounds.max_speed {
            return Err(StepError::Diverged {
                step,
                what: format!("node speed {worst_speed:.3e} m/s exceeds the bound {:.3e} m/s", self.bounds.max_speed),
                hint: self.hint(),
            });
        }
        std::mem::swap(&mut state.x_prev, &mut state.x);
        state.x.copy_from_slice(&self.y);
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
        let max_penetration = max_penetration_cached(model, &state.x, &mut self.cache);
        let contact_time = self.counters.contact - contact_before;
        self.counters.assembly += t_assembly - contact_time;
        self.counters.factorization += tf;
        self.counters.solve += t_solve - tf + tv.elapsed().as_secs_f64();
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
            IntegratorKind::Linearized | IntegratorKind::Static => {
                "try a smaller dt, a larger contact offset, or a softer contact stiffness (contact is implicit only to \
                 first order)"
            }
        }
    }
}

/// Deepest penetration below any obstacle's surface (0 when none), in metres.
pub fn max_penetration(model: &Model, x: &[Vec3]) -> f64 {
    let mut cache = contact::ContactCache::new(model.obstacles.len(), x.len());
    max_penetration_cached(model, x, &mut cache)
}

/// [`max_penetration`] with warm-started closest-point queries.
pub fn max_penetration_cached(model: &Model, x: &[Vec3], cache: &mut contact::ContactCache) -> f64 {
    let mut worst: f64 = 0.0;
    for (k, p) in x.iter().enumerate() {
        if cache.lower_bound(k, *p) >= 0.0 {
            continue;
        }
        if let Some((d, _)) = contact::closest_cached(&model.obstacles, cache, k, *p, model.contact.offset.max(0.0)) {
            worst = worst.max(-d);
        }
    }
    worst
}
