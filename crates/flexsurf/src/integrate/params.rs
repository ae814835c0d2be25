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

    /// Default bounds for a model: speed `100 √(|g| L)` (or `100 L` per second without gravity) and strain 1.
    pub fn for_model(model: &Model) -> Self {
        let l = model.length_scale();
        let g = model.gravity.length();
        let v = if g > 0.0 { (g * l).sqrt() } else { l };
        Self { max_speed: 100.0 * v, max_strain: 1.0 }
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
    /// Most Newton iterations per step. The first is the linearised step of the paper's form; the default 2
    /// allows one correction towards the fully implicit solution when the residual is large (impacts) or when
    /// a node's friction turns out to reverse or stop within the step (4 measured 2× slower on the ball drop
    /// with friction for the same test results).
    pub newton_iterations: usize,
    /// Residual (N) above which a Newton correction is made, relative to the largest nodal weight (or load).
    /// The default 100 triggers corrections only at violent events such as the impact on the ball, where the
    /// linearised step alone stretches the sheet by 3.2% (measured, 21×21 ball drop, step 16) and one
    /// correction brings the peak strain to 0.2%; smooth steps are not corrected.
    pub newton_tolerance: f64,
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
            newton_iterations: 2,
            newton_tolerance: 100.0,
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
