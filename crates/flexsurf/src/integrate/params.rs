//! The parameters of a run in one place: [`StepParams`] for a dynamic integration (as rapier's
//! `IntegrationParameters`), [`StaticOptions`] for a static solve, and [`Method`],
//! which is one or the other.

use super::linsolve::SolverKind;
use super::statics::StaticOptions;
use crate::model::Model;
use serde::{Deserialize, Serialize};

/// The time-stepping scheme of a dynamic integration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "app", derive(schemars::JsonSchema))]
#[serde(rename_all = "lowercase")]
pub enum Scheme {
    /// Linearised implicit step with the positive semi-definite Hessian (default): unconditionally stable.
    #[default]
    Linearized,
    /// The paper's literal lagged-coefficient step: stable only below about `h/√(A11/ρ)`.
    Lagged,
    /// The second-order backward differentiation formula (BDF2; Curtiss and Hirschfelder 1952, in cloth
    /// Choi and Ko 2002) with the positive semi-definite Hessian: second order in Δt, unconditionally stable,
    /// little numerical damping of the resolved motion (docs/model.md §8).
    Bdf2,
}

impl Scheme {
    /// Name used in scenes and summaries.
    pub fn name(&self) -> &'static str {
        match self {
            Scheme::Linearized => "linearized",
            Scheme::Lagged => "lagged",
            Scheme::Bdf2 => "bdf2",
        }
    }
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
    /// The deepest penetration below an obstacle's surface still taken as contact: 10 offsets, or a tenth of
    /// the sheet's size where that is more (m).
    pub fn max_penetration(&self, model: &Model) -> f64 {
        let offset = model.contact_params().map_or(0.0, |c| c.offset);
        (10.0 * offset).max(0.1 * model.length_scale())
    }

    /// Default bounds for a model stepped at `dt`: a node speed of 10 times the larger of the membrane's wave
    /// speed `√(max(E₁h, E₂h)/ρ)` and the sheet's length per step `L/Δt` (`L` the pattern's diagonal), and an
    /// edge strain of 1. Neither depends on gravity: a sheet of any speed a simulation can resolve is accepted
    /// under any gravity (a 0.5 m/s sheet at |g| = 1e-6 m/s², which the former `100 √(|g| L)` refused), while a
    /// diverging step, whose speeds grow geometrically, reaches the bound within a few steps (if its strain or a
    /// non-finite value does not stop it first). The cotton demo sheet: 10 × 535 m/s.
    pub fn for_model(model: &Model, dt: f64) -> Self {
        let wave = model.fabric.wave_speed();
        let per_step = model.length_scale() / dt;
        let v = if wave.is_finite() { wave.max(per_step) } else { per_step };
        Self { max_speed: 10.0 * v, max_strain: 1.0 }
    }
}

/// Everything that controls a dynamic step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StepParams {
    /// Time step Δt (s).
    pub dt: f64,
    /// The scheme.
    pub scheme: Scheme,
    /// The linear solver of the step system.
    pub solver: SolverKind,
    /// Most Newton iterations per step on the step's incremental potential `Φ` (docs/model.md §8.5), the
    /// linearised step (46)–(48) included as the first, for a step without contact (no contact record, touching
    /// or predicted, and no friction after its first solve). Such a step that reaches it is kept and counted as
    /// unconverged ([`super::NewtonReport`], `Counters::unconverged`); free motion converges within the default
    /// 4 (the tumbling sheet of tests/suite/converged_step.rs). A contact step iterates while its contacts'
    /// linear models are off at the iterate (docs/model.md §8.5), at most as many; a violent one, or one with
    /// pairs between faces, makes at most 2 (one correction, [`StepParams::contact_correction`]).
    pub newton_iterations: usize,
    /// Relative residual at which the Newton iterations of a step without contact stop: the residual force of
    /// the implicit equation `∇Φ(y) = 0` over the step's own force scale, both in the mass-weighted norm
    /// `√(Σ |f_k|²/m_k)` over a panel's free nodes, the scale being the largest of the inertial force
    /// `M α (x_t − ŷ)` (plus damping), the other forces at the start of the step (elastic, loads, springs) and
    /// the panel's weight; the largest ratio over the panels counts, so a panel's convergence does not depend
    /// on the others' forces ([`super::Stepper`]). The default 1e-6 leaves a freely tumbling sheet (no gravity)
    /// within 0.1 % of its angular momentum over 2 s with BDF2 (tests/suite/converged_step.rs), where the
    /// former criterion (100 nodal weights) never corrected the linearised step's stretch `(ωΔt)²/2` and lost
    /// 89 %.
    pub newton_tolerance: f64,
    /// Residual (N) above which a contact step (an active contact or friction set after its first solve) makes
    /// its one Newton correction, relative to the largest nodal weight (or load) of the node's own panel. The
    /// default 100 corrects only at violent events such as the impact on the ball, where the linearised step
    /// alone stretches the sheet by 3.2% (measured, 21×21 ball drop, step 16) and one correction brings the
    /// peak strain to 0.2%. Other contact steps are iterated while their contacts' linear models are off (the
    /// obstacle's curvature under a sliding node), not to [`StepParams::newton_tolerance`]: the draped sheet's
    /// residual converges only linearly (docs/model.md §8.5).
    pub contact_correction: f64,
    /// Relative residual `‖b − A x‖ / ‖b‖` at which every linear solve of a contact step stops where it is
    /// iterative: the iterative solvers' solves and the direct solver's re-solves preconditioned by its kept
    /// factor (its factorised solves are exact). Default [`super::linsolve::CONTACT_STEP_TOLERANCE`] (1e-6). A
    /// contact step is not iterated to [`StepParams::newton_tolerance`], so its result depends on this
    /// tolerance as far as the step's friction decisions do: continuously where the friction law's stick zone
    /// `slip_speed · Δt` is resolved (docs/performance.md, "What the discontinuity is"). Tighter makes a run a
    /// smoother function of its inputs (a fit, a finite-difference sweep) at more iterations; looser is cheaper.
    pub contact_solve_tolerance: f64,
    /// Most re-solves per Newton iteration while an active set (contact) changes.
    pub active_set_rounds: usize,
    /// Divergence bounds; `None`: [`Bounds::for_model`].
    pub bounds: Option<Bounds>,
}

impl StepParams {
    /// The default time step Δt (s), also the scene format's `time.dt` default.
    pub const DT: f64 = 0.01;
}

impl Default for StepParams {
    fn default() -> Self {
        Self {
            dt: Self::DT,
            scheme: Scheme::Linearized,
            solver: SolverKind::Auto,
            newton_iterations: 4,
            newton_tolerance: 1e-6,
            contact_correction: 100.0,
            contact_solve_tolerance: super::linsolve::CONTACT_STEP_TOLERANCE,
            active_set_rounds: 4,
            bounds: None,
        }
    }
}

impl StepParams {
    /// The defaults with time step `dt`.
    pub fn with_dt(dt: f64) -> Self {
        Self { dt, ..Self::default() }
    }
}

/// A run is either a dynamic integration or a static solve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Method {
    /// Time stepping.
    Dynamic(StepParams),
    /// The quasi-static equilibrium by Newton's method.
    Static(StaticOptions),
}

impl Method {
    /// Name used in summaries: the scheme, or `static`.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Dynamic(p) => p.scheme.name(),
            Method::Static(_) => "static",
        }
    }
}
