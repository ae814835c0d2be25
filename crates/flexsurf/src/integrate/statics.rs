//! Quasi-static equilibrium (docs/model.md §9): minimises the total potential
//! `Π(x) = E_h(x) − Σ m g·x + contact penalty + springs` ([`crate::potential`], the same assembly as the time
//! step) over the free nodes, to a stable equilibrium (a local minimum, not a saddle).
//!
//! The globalisation, for energies that are far from convex (large rotations of a sheet that is stiff in
//! stretch and soft in bending, buckling, penalty contact):
//!
//! - **Levenberg–Marquardt trust region** on the exact Hessian: the step solves `(H + μI) p = −∇Π` with the
//!   smallest shift `μ ≥ 0` that makes the matrix positive definite and keeps the quadratic model honest; the
//!   step is accepted on the ratio of the actual to the predicted decrease of `Π` and `μ` adapted from it (the
//!   positive semi-definite Hessian stands in where the exact one cannot be factorised even at a shift of
//!   [`EXACT_SHIFT`]).
//! - **Watchdog** (Chamberlain, Powell, Lemaréchal and Pedersen 1982): a rotation step, linear in the nodes,
//!   stretches the sheet to second order, which its membrane stiffness punishes, so `Π` rejects good steps. A
//!   rejected step is followed anyway by further Newton steps (the next one restores the lengths) for up to
//!   [`WATCH_STEPS`] iterations; the first point below the checkpoint's sufficient decrease ends the watch, else
//!   the solver returns to the checkpoint with a larger shift.
//! - **Saddle escape**: at a stationary point where the exact Hessian is not positive semi-definite (a straight
//!   strip standing past its buckling height), the direction of most negative curvature (inverse iteration on
//!   the shifted Hessian) is followed until `Π` decreases, and Newton continues from there.
//! - **Load continuation** as the fallback: if the full load does not converge within a share of the iteration
//!   budget, the load terms (energy part [`Part::Load`]) are ramped by a load factor in adaptive increments from
//!   the start, each increment started from the extrapolation of the last two equilibria.
//!
//! A potential that decreases without bound (an unpinned sheet falling with nothing below it) has no
//! equilibrium: detected when the iterates run away or, after a failure, when a rigid translation along the
//! net force lowers `Π` linearly for ever ([`StaticError::NoEquilibrium`]). Convergence is judged on the residual
//! force relative to the largest load. A potential with a non-conservative term (the Terzopoulos force) has no
//! `Π` to minimise and is refused.

use super::descent::{self, ARMIJO};
use super::linsolve::{LinearSolver, Reuse, SolverKind};
use crate::energy::Operator;
use crate::math::{diag, Vec3};
use crate::model::Model;
use crate::potential::{Part, Want, Workspace};
use serde::Serialize;
use thiserror::Error;

/// Failure of the static solve.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum StaticError {
    /// Newton did not reach the tolerance within the iteration budget (or stalled at round-off above it).
    #[error(
        "static solve did not converge within {iterations} Newton iterations: relative residual {residual:.3e} \
         reached at load factor {load:.3} (hint: this does not mean there is no equilibrium; start closer to it, \
         raise the solver's iteration limit, or relax the sheet dynamically with `integrator.kind = \"linearized\"`)"
    )]
    NotConverged {
        /// Iterations made.
        iterations: usize,
        /// Relative residual reached.
        residual: f64,
        /// Load factor reached (1: the full load).
        load: f64,
    },
    /// The potential or its forces were not finite (an overflow, or a degenerate configuration such as
    /// coincident nodes): no residual can be measured there, so none is reported as if it were one.
    #[error(
        "static solve failed after {iterations} Newton iterations at load factor {load:.3}: the {what} not finite \
         ({value}) at {at}, so there is no residual to report (the last finite relative residual: {}) (hint: look \
         for coincident or far-off nodes, an overflowing stiffness or load, or relax the sheet dynamically with \
         `integrator.kind = \"linearized\"`)",
        last.map_or_else(|| "none".to_string(), |r| format!("{r:.3e}"))
    )]
    NonFinite {
        /// Iterations made.
        iterations: usize,
        /// Load factor of the failing evaluation (1: the full load).
        load: f64,
        /// What was not finite: `"potential is"`, `"forces are"` or `"force scale is"`.
        what: &'static str,
        /// The value found (`NaN`, `inf`).
        value: f64,
        /// Where: `"the start"` or `"the last iterate"`.
        at: &'static str,
        /// The last finite relative residual the solve reached (`None` when it had none).
        last: Option<f64>,
    },
    /// The total potential is unbounded below (shown along a rigid translation): there is no equilibrium.
    #[error(
        "static solve: no equilibrium: the total potential decreases without bound (a rigid translation of \
         {drift:.3e} m along the net force of {force:.3e} N lowers it at no less than half that force's rate, \
         meeting no support) (hint: a static solve needs the sheet held by pins or springs, or resting on a \
         support it cannot slide off without friction; for a drop or a slide use `integrator.kind = \"linearized\"`)"
    )]
    NoEquilibrium {
        /// Length of the translation probed, or of the iterates' run-away (m).
        drift: f64,
        /// The net force on the free nodes along the runaway (N).
        force: f64,
    },
    /// A term of the potential is not the gradient of an energy: there is no potential to minimise.
    #[error(
        "static solve: the {term} force is not the gradient of an energy, so it has no equilibrium potential; \
         use a dynamic integrator (integrator = \"linearized\") or the tfs model"
    )]
    NonConservative {
        /// The term.
        term: &'static str,
    },
    /// A linear solve failed even with regularisation.
    #[error("static solve: {0}")]
    Linear(#[from] super::linsolve::LinearError),
}

/// Options of the Newton solver.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StaticOptions {
    /// Stop when `|r|∞ ≤ tolerance · (largest nodal external load)`.
    pub tolerance: f64,
    /// Newton iteration limit, all load steps together.
    pub max_iterations: usize,
}

impl Default for StaticOptions {
    fn default() -> Self {
        Self { tolerance: 1e-9, max_iterations: 500 }
    }
}

/// One load step of a converged static solve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LoadStep {
    /// Load factor at the end of the step (1: the full load).
    pub load: f64,
    /// Newton iterations of the step.
    pub iterations: usize,
}

/// Result of a converged static solve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StaticReport {
    /// Newton iterations taken, all load steps (and an abandoned full-load attempt) together.
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
    /// Final total potential (J).
    pub potential: f64,
    /// The load steps (one, at load factor 1, without continuation).
    pub load_steps: Vec<LoadStep>,
    /// Iterations of a full-load attempt abandoned for load continuation (0 if none).
    pub abandoned: usize,
    /// Saddle points left along a direction of negative curvature.
    pub escapes: usize,
}

/// How one Newton solve at a fixed load factor ended.
enum Outcome {
    /// Converged to a stable equilibrium: (iterations, residual, potential, escapes).
    Converged(usize, f64, f64, usize),
    /// Ran out of iterations, stalled or met a non-finite point: (iterations); the error measures the residual
    /// where it stopped ([`StaticSolver::diagnose`]).
    Failed(usize),
    /// The iterates ran away along a direction where `Π` falls for ever: (distance, net force).
    Runaway(f64, f64),
}

/// The full-load attempt leaves this share of the iteration budget (1/4) to continuation.
const FIRST_SHARE: usize = 4;
/// Least iterations of the full-load attempt.
const FIRST_MIN: usize = 40;
/// Newton iterations of one load step before its increment is halved.
const STEP_CAP: usize = 15;
/// A load step this quick doubles the next increment.
const STEP_QUICK: usize = 6;
/// Saddle escapes of one Newton solve at most.
const MAX_ESCAPES: usize = 8;
/// Tentative Newton steps of a watchdog.
const WATCH_STEPS: usize = 4;
/// Accepted steps after a failed watchdog before the next one.
const WATCH_REARM: usize = 2;

/// A watchdog's checkpoint: the point, its value, the rejected step's predicted decrease, the shift, and the
/// tentative steps left.
struct Watch {
    x: Vec<Vec3>,
    pi: f64,
    pred: f64,
    mu: f64,
    left: usize,
}

/// The state of one Newton solve ([`StaticSolver::newton`]): the load factor, scale and tolerance, the
/// buffers, and the trust region's and watchdog's bookkeeping.
struct Newton {
    lam: f64,
    load: f64,
    tol: f64,
    start: Vec<Vec3>,
    runaway: f64,
    grad: Vec<Vec3>,
    step: Vec<Vec3>,
    trial: Vec<Vec3>,
    /// Levenberg shift relative to the matrix scale (0: pure Newton).
    mu: f64,
    escapes: usize,
    res: f64,
    it: usize,
    /// The point is new: evaluate and assess it.
    fresh: bool,
    pi: f64,
    op: Operator,
    /// The last factorisation was of the exact Hessian with no more than the floor shift.
    certified: bool,
    /// Watchdog: a rejected full step is followed tentatively for a few Newton steps from this checkpoint.
    watch: Option<Watch>,
    /// Accepted steps since the last failed watchdog (a watchdog is armed after two).
    since_watch: usize,
}

impl Newton {
    fn new(model: &Model, x: &[Vec3], lam: f64, load: f64, tol: f64) -> Self {
        let n = x.len();
        Self {
            lam,
            load,
            tol,
            start: x.to_vec(),
            runaway: 1e3 * model.length_scale(),
            grad: vec![Vec3::ZERO; n],
            step: vec![Vec3::ZERO; n],
            trial: x.to_vec(),
            mu: 0.0,
            escapes: 0,
            res: f64::INFINITY,
            it: 0,
            fresh: true,
            pi: 0.0,
            op: Operator::Exact,
            certified: false,
            watch: None,
            since_watch: WATCH_REARM,
        }
    }
}

/// What a stage of a Newton iteration decides.
enum Flow {
    /// On to the next iteration.
    Next,
    /// The solve ends.
    Done(Outcome),
    /// On with this iteration (factorise and step).
    Go,
}

/// A step's numbers for [`StaticSolver::judge`]: `g·p`, `|p|²`, the model's predicted decrease, the matrix scale.
#[derive(Clone, Copy)]
struct Judged {
    gp: f64,
    pp: f64,
    pred: f64,
    scale: f64,
}

/// The largest absolute component of `g` (the residual's norm), NaN when any component is NaN: `f64::max`
/// alone drops NaN, which made a solve whose forces were all NaN report a residual of exactly 0.
fn max_abs(g: &[Vec3]) -> f64 {
    g.iter()
        .flat_map(|v| v.to_array())
        .fold(0.0, |a: f64, c| if a.is_nan() || c.is_nan() { f64::NAN } else { a.max(c.abs()) })
}

/// Relative diagonal shift that keeps free rigid modes solvable and is the threshold of "negative" curvature.
const EPS_SHIFT: f64 = 1e-12;

/// The largest shift `μ` (relative to the Hessian's scale) tried on the exact Hessian before the positive
/// semi-definite one stands in. Near a drape's equilibrium the exact Hessian is often indefinite by a little
/// (a fold's soft mode): a shift of about 2e-6 factorises it, while the positive semi-definite operator, which
/// drops the compressed membrane's negative stiffness, overestimates the curvature along that mode and Newton
/// stalls (the stiff woven's Cusick specimen at 12 × 144: 300 iterations at a residual of 2.4e-5, each step
/// lowering `Π` by exactly twice its prediction; with the shift, 20 iterations; docs/materials.md).
const EXACT_SHIFT: f64 = 1e-6;

/// Newton solver workspace for one model.
pub struct StaticSolver {
    solver: LinearSolver,
    ws: Workspace,
    /// Gradient of the load terms (load continuation).
    load_grad: Vec<Vec3>,
    /// The right-hand side of a solve (the solution is written over the caller's vector).
    b: Vec<Vec3>,
    /// The last finite relative residual of the solve in progress (for the error of a non-finite one).
    last_res: Option<f64>,
}

/// Most outer iterations of a static solve with friction (re-lagging the normal forces at the equilibrium).
pub const FRICTION_LAGS: usize = 4;

/// Pseudo-time of a static solve (s): friction's smoothing length is its slip speed times this.
pub const SLIP_TIME: f64 = 1.0;

impl StaticSolver {
    /// Analyses the model's pattern.
    pub fn new(model: &Model) -> Result<Self, StaticError> {
        let n = model.potential.fixed().len();
        Ok(Self {
            solver: LinearSolver::new(SolverKind::Cholesky, model.potential.pattern(), &model.panels)?,
            ws: Workspace::new(&model.potential),
            b: vec![Vec3::ZERO; n],
            load_grad: vec![Vec3::ZERO; n],
            last_res: None,
        })
    }

    /// Total potential and (optionally) its gradient over free nodes (written into `grad`), from cold contact
    /// queries.
    pub fn potential(model: &Model, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        let mut ws = Workspace::new(&model.potential);
        model.potential.cold(&mut ws);
        let want = if grad.is_some() { Want::GRADIENT } else { Want::VALUE };
        let values = model.potential.assemble(x, &model.potential.context(None), None, want, &mut ws);
        if let Some(g) = grad {
            g.copy_from_slice(&ws.grad);
        }
        values.total
    }

    /// `Π_λ(x) = Π(x) − (1 − λ) Π_load(x)` at load factor `lam` and what `want` asks (gradient into
    /// `self.ws.grad`, matrix into `self.ws.matrix`), from cold contact queries. The load terms' Hessian is not
    /// scaled: gravity and constant loads are linear in `x` (zero Hessian).
    fn eval(&mut self, model: &Model, x: &[Vec3], lam: f64, want: Want) -> f64 {
        model.potential.cold(&mut self.ws);
        let cx = model.potential.context(None);
        let mut total = model.potential.assemble(x, &cx, None, want, &mut self.ws).total;
        if lam != 1.0 {
            let c = 1.0 - lam;
            if want.grad {
                self.load_grad.fill(Vec3::ZERO);
                let v = model.potential.value_of(x, |p| p == Part::Load, Some(&mut self.load_grad)).total;
                total -= c * v;
                for ((g, l), &f) in self.ws.grad.iter_mut().zip(&self.load_grad).zip(model.pinned()) {
                    if !f {
                        *g -= *l * c;
                    }
                }
            } else {
                total -= c * model.potential.value_of(x, |p| p == Part::Load, None).total;
            }
        }
        total
    }

    /// Size of the matrix entries, for relative shifts.
    fn scale(&self) -> f64 {
        self.ws.matrix.blocks.iter().map(|b| b.abs().to_cols_array()[0]).fold(0.0, f64::max).max(f64::MIN_POSITIVE)
    }

    /// Adds `s I` to every diagonal block.
    fn shift(&mut self, model: &Model, s: f64) {
        for d in model.potential.diag_ids() {
            self.ws.matrix.blocks[*d as usize] += diag(s);
        }
    }

    /// Solves for equilibrium starting from `x` (pinned nodes stay where they are). With friction, the solve is
    /// quasi-static and lagged: Coulomb friction resists the tangential displacement from `x` with the normal
    /// forces of the contacts at `x`, then of the equilibrium found, until they agree to 1 % (at most
    /// [`FRICTION_LAGS`] solves); a sheet that friction can hold then has an equilibrium.
    pub fn solve(&mut self, model: &Model, x: &mut [Vec3], opts: &StaticOptions) -> Result<StaticReport, StaticError> {
        let friction = model.potential.relag(x, true, SLIP_TIME, &mut self.ws);
        let mut report = self.solve_lagged(model, x, opts)?;
        for _ in 1..FRICTION_LAGS {
            if !friction || !model.potential.relag(x, false, SLIP_TIME, &mut self.ws) {
                break;
            }
            let again = self.solve_lagged(model, x, opts)?;
            report.iterations += again.iterations;
            report.residual = again.residual;
            report.potential = again.potential;
            report.load_steps.extend(again.load_steps);
            report.escapes += again.escapes;
        }
        Ok(report)
    }

    fn solve_lagged(
        &mut self,
        model: &Model,
        x: &mut [Vec3],
        opts: &StaticOptions,
    ) -> Result<StaticReport, StaticError> {
        if let Some(term) = model.potential.non_conservative() {
            return Err(StaticError::NonConservative { term });
        }
        let load = Self::force_scale(model, x);
        self.last_res = None;
        // A start where nothing is finite has no residual, and no load step changes that.
        let bad = if load.is_finite() {
            self.non_finite(model, x, 1.0, load)
        } else {
            Some(("force scale (the largest elastic force or load) is", load))
        };
        if let Some((what, value)) = bad {
            return Err(StaticError::NonFinite { iterations: 0, load: 1.0, what, value, at: "the start", last: None });
        }
        let start = x.to_vec();
        let budget = opts.max_iterations;
        // The full load first, with a share of the budget when continuation can take over.
        let first = if model.potential.load_scale(None, model.length_scale()) > 0.0 {
            (budget - budget / FIRST_SHARE).max(FIRST_MIN).min(budget)
        } else {
            budget
        };
        match self.newton(model, x, 1.0, load, opts.tolerance, first)? {
            Outcome::Converged(it, residual, potential, escapes) => Ok(StaticReport {
                iterations: it,
                residual,
                potential,
                load_steps: vec![LoadStep { load: 1.0, iterations: it }],
                abandoned: 0,
                escapes,
            }),
            Outcome::Runaway(drift, force) => Err(StaticError::NoEquilibrium { drift, force }),
            Outcome::Failed(it) if first == budget => Err(self.diagnose(model, x, &start, it, 1.0, load)),
            Outcome::Failed(it) => {
                x.copy_from_slice(&start);
                self.continuation(model, x, load, opts, it)
            }
        }
    }

    /// Load continuation from `x` (the start) after a full-load attempt of `abandoned` iterations: the load
    /// factor ramps to 1 in increments that grow after quick steps and halve after failed ones; each step starts
    /// from the secant extrapolation of the last two equilibria.
    fn continuation(
        &mut self,
        model: &Model,
        x: &mut [Vec3],
        load: f64,
        opts: &StaticOptions,
        abandoned: usize,
    ) -> Result<StaticReport, StaticError> {
        let start = x.to_vec();
        let mut used = abandoned;
        let mut steps = Vec::new();
        let mut escapes = 0;
        // Last two equilibria (load factor, positions); the start counts as the equilibrium of load 0 only for
        // the extrapolation's direction.
        let mut prev: Option<(f64, Vec<Vec3>)> = None;
        let mut lam = 0.0;
        let mut inc: f64 = 0.125;
        let mut base = x.to_vec();
        let intermediate = opts.tolerance.max(1e-6);
        loop {
            let target = (lam + inc).min(1.0);
            let last = target >= 1.0;
            // Predictor: secant through the last two equilibria.
            if let Some((l0, x0)) = &prev {
                let r = (target - lam) / (lam - l0);
                for k in 0..x.len() {
                    x[k] = base[k] + (base[k] - x0[k]) * r;
                }
            } else {
                x.copy_from_slice(&base);
            }
            let tol = if last { opts.tolerance } else { intermediate };
            let left = opts.max_iterations.saturating_sub(used);
            if left == 0 {
                return Err(self.diagnose(model, x, &start, used, target, load));
            }
            // A step that Newton does not finish quickly is cut.
            let cap = left.min(STEP_CAP);
            match self.newton(model, x, target, load, tol, cap)? {
                Outcome::Converged(it, residual, potential, e) => {
                    used += it;
                    escapes += e;
                    steps.push(LoadStep { load: target, iterations: it });
                    if last {
                        return Ok(StaticReport {
                            iterations: used,
                            residual,
                            potential,
                            load_steps: steps,
                            abandoned,
                            escapes,
                        });
                    }
                    prev = Some((lam, std::mem::replace(&mut base, x.to_vec())));
                    lam = target;
                    if it <= STEP_QUICK {
                        inc = (inc * 2.0).min(0.5);
                    }
                }
                Outcome::Runaway(drift, force) => return Err(StaticError::NoEquilibrium { drift, force }),
                Outcome::Failed(it) => {
                    used += it;
                    inc *= 0.5;
                    if inc < 1e-4 {
                        return Err(self.diagnose(model, x, &start, used, target, load));
                    }
                }
            }
        }
    }

    /// The error of a failed solve that stopped at `x` while solving at load factor `load`: no equilibrium if
    /// `Π` is unbounded below along a rigid translation, else not converged with the residual of `x` (relative
    /// to `force_scale`, measured here), or non-finite when `Π` or its forces at `x` are not finite.
    fn diagnose(
        &mut self,
        model: &Model,
        x: &[Vec3],
        start: &[Vec3],
        iterations: usize,
        load: f64,
        force_scale: f64,
    ) -> StaticError {
        if let Some((drift, force)) = self.unbounded(model, x) {
            return StaticError::NoEquilibrium { drift, force };
        }
        if let Some((drift, force)) = self.unbounded(model, start) {
            return StaticError::NoEquilibrium { drift, force };
        }
        match self.non_finite(model, x, load, force_scale) {
            None => StaticError::NotConverged { iterations, residual: max_abs(&self.ws.grad) / force_scale, load },
            Some((what, value)) => {
                StaticError::NonFinite { iterations, load, what, value, at: "the last iterate", last: self.last_res }
            }
        }
    }

    /// Evaluates `Π` and its gradient at `x` at load factor `load` (the gradient left in the workspace): what is
    /// not finite there and its value, or `None` when both are finite.
    fn non_finite(&mut self, model: &Model, x: &[Vec3], load: f64, force_scale: f64) -> Option<(&'static str, f64)> {
        let pi = self.eval(model, x, load, Want::GRADIENT);
        let residual = max_abs(&self.ws.grad) / force_scale;
        match (pi.is_finite(), residual.is_finite()) {
            (true, true) => None,
            (false, _) => Some(("potential is", pi)),
            (true, false) => Some(("forces are", residual)),
        }
    }

    /// A rigid translation of the free nodes along the net force on them that lowers `Π` linearly for ever
    /// (probed out to 10⁶ sheet lengths): (distance probed, net force).
    fn unbounded(&mut self, model: &Model, x: &[Vec3]) -> Option<(f64, f64)> {
        let pi = self.eval(model, x, 1.0, Want::GRADIENT);
        let force: Vec3 = self.ws.grad.iter().fold(Vec3::ZERO, |a, g| a - *g);
        let f = force.length();
        if !(f > 0.0 && f.is_finite()) {
            return None;
        }
        let dir = force / f;
        let fixed = model.pinned();
        let mut y = x.to_vec();
        let l = model.length_scale();
        let mut t = l;
        for _ in 0..6 {
            t *= 10.0;
            for k in 0..x.len() {
                if !fixed[k] {
                    y[k] = x[k] + dir * t;
                }
            }
            let pt = self.eval(model, &y, 1.0, Want::VALUE);
            if pt.is_nan() || pt >= pi - 0.5 * f * t {
                return None;
            }
        }
        Some((t, f))
    }

    /// Force scale of the residual: the largest external load or spring force scale, or (for a problem driven by
    /// prescribed positions) the largest elastic force at the start, pinned nodes included.
    fn force_scale(model: &Model, x: &[Vec3]) -> f64 {
        let mut grad = vec![Vec3::ZERO; x.len()];
        model.elastic(x, Some(&mut grad));
        // NaN forces make a NaN scale (`f64::max` alone would drop them).
        let scale =
            grad.iter().map(|g| g.length()).fold(model.potential.load_scale(None, model.length_scale()), |a, f| {
                if a.is_nan() || f.is_nan() {
                    f64::NAN
                } else {
                    a.max(f)
                }
            });
        if scale.is_nan() {
            scale
        } else {
            scale.max(f64::MIN_POSITIVE)
        }
    }

    /// Factorises the assembled matrix plus `s I` (added in place, then removed); true on success.
    fn factor_with(&mut self, model: &Model, s: f64, rhs: &mut [Vec3]) -> bool {
        self.shift(model, s);
        self.b.copy_from_slice(rhs);
        let ok = self.solver.solve(&self.ws.matrix, model.pinned(), &self.b, rhs, Reuse::Fresh).is_ok();
        self.shift(model, -s);
        ok
    }

    /// Back-substitution with the current factor (`rhs` in place); the matrix must be the factorised one.
    fn resolve(&mut self, model: &Model, s: f64, rhs: &mut [Vec3]) -> bool {
        self.shift(model, s);
        self.b.copy_from_slice(rhs);
        let ok = self.solver.solve(&self.ws.matrix, model.pinned(), &self.b, rhs, Reuse::Nearby).is_ok();
        self.shift(model, -s);
        ok
    }

    /// Newton's method at load factor `lam` from `x`, at most `budget` iterations: the trust region, the
    /// watchdog and the saddle escape of the module documentation. Each iteration: [`Self::assess`] the
    /// point (when it is new), [`Self::factorise`] the shifted Hessian, then judge the step
    /// ([`Self::unresolved`] when `Π` cannot resolve its decrease, else [`Self::judge`]).
    fn newton(
        &mut self,
        model: &Model,
        x: &mut [Vec3],
        lam: f64,
        load: f64,
        tol: f64,
        budget: usize,
    ) -> Result<Outcome, StaticError> {
        let mut nw = Newton::new(model, x, lam, load, tol);
        while nw.it < budget {
            if nw.fresh {
                match self.assess(model, x, &mut nw)? {
                    Flow::Next => continue,
                    Flow::Done(o) => return Ok(o),
                    Flow::Go => {}
                }
            }
            nw.it += 1;
            let scale = self.scale();
            if !self.factorise(model, x, &mut nw, scale) {
                return Ok(Outcome::Failed(nw.it));
            }
            let s = (nw.mu * scale).max(EPS_SHIFT * scale);
            let gp: f64 = nw.grad.iter().zip(&nw.step).map(|(g, p)| g.dot(*p)).sum();
            let pp: f64 = nw.step.iter().map(|p| p.length_squared()).sum();
            // Model decrease m(p) = g·p + ½ pᵀHp with (H + sI) p = −g.
            let pred = 0.5 * (gp - s * pp);
            for k in 0..x.len() {
                nw.trial[k] = x[k] + nw.step[k];
            }
            let flow = if descent::resolvable(pred, nw.pi) {
                self.judge(model, x, &mut nw, Judged { gp, pp, pred, scale })
            } else {
                self.unresolved(model, x, &mut nw)?
            };
            if let Flow::Done(o) = flow {
                return Ok(o);
            }
        }
        Ok(Outcome::Failed(nw.it))
    }

    /// A new point `x`: evaluates `Π`, its gradient and exact Hessian there, settles a watchdog, and stops on
    /// convergence (a stable point, or one left along a negative curvature) or on a runaway.
    fn assess(&mut self, model: &Model, x: &mut [Vec3], nw: &mut Newton) -> Result<Flow, StaticError> {
        nw.op = Operator::Exact;
        nw.pi = self.eval(model, x, nw.lam, Want { grad: true, hess: Some(nw.op) });
        nw.grad.copy_from_slice(&self.ws.grad);
        nw.res = max_abs(&nw.grad) / nw.load;
        if nw.pi.is_finite() && nw.res.is_finite() {
            self.last_res = Some(nw.res);
        } else {
            return Ok(match nw.watch.take() {
                Some(w) => {
                    self.restore(x, &w, &mut nw.mu, &mut nw.since_watch);
                    Flow::Next
                }
                None => Flow::Done(Outcome::Failed(nw.it)),
            });
        }
        if let Some(w) = &mut nw.watch {
            if nw.pi <= w.pi + ARMIJO * w.pred {
                nw.watch = None;
            } else if w.left == 0 {
                let w = nw.watch.take().unwrap_or_else(|| unreachable!());
                self.restore(x, &w, &mut nw.mu, &mut nw.since_watch);
                return Ok(Flow::Next);
            } else {
                w.left -= 1;
            }
        }
        if nw.res <= nw.tol && nw.watch.is_none() {
            // A positive definite exact Hessian factorised at μ = 0 on the last iteration certifies stability;
            // else check (and leave a saddle).
            if self.settle(model, x, nw, true)? {
                return Ok(Flow::Done(Outcome::Converged(nw.it, nw.res, nw.pi, nw.escapes)));
            }
            nw.it += 1;
            return Ok(Flow::Next);
        }
        let drift = x.iter().zip(&nw.start).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        if drift > nw.runaway {
            // Far from the start: either the sheet falls for ever, or it drifted along a flat rigid mode.
            if let Some((d, f)) = self.unbounded(model, x) {
                return Ok(Flow::Done(Outcome::Runaway(d.max(drift), f)));
            }
            nw.runaway *= 10.0;
        }
        Ok(Flow::Go)
    }

    /// At a point within the tolerance: true when it is a stable equilibrium (certified by the last exact
    /// factorisation, or checked), or after the most saddle escapes; else it has left the saddle (into `x`):
    /// one more escape, a fresh trust region. `exact_at_x`: the workspace holds the exact Hessian at `x`.
    fn settle(
        &mut self,
        model: &Model,
        x: &mut [Vec3],
        nw: &mut Newton,
        exact_at_x: bool,
    ) -> Result<bool, StaticError> {
        if nw.certified
            || nw.escapes >= MAX_ESCAPES
            || self.stable_or_escape(model, x, nw.lam, nw.pi, &nw.grad, &mut nw.trial, exact_at_x)?
        {
            return Ok(true);
        }
        nw.escapes += 1;
        nw.certified = false;
        nw.mu = 0.0;
        Ok(false)
    }

    /// Factorises `H + μ s I` into the step `(H + μ s I) p = −g`, growing `μ` until positive definite: the exact
    /// Hessian up to a shift of [`EXACT_SHIFT`] ([`Self::exact_shift`]), then the PSD operator from the shift it
    /// started with. False when none could be.
    fn factorise(&mut self, model: &Model, x: &[Vec3], nw: &mut Newton, scale: f64) -> bool {
        if nw.op == Operator::Exact {
            if let Some(mu) = self.exact_shift(model, nw, scale) {
                nw.mu = mu;
                nw.certified = mu * scale <= EPS_SHIFT * scale;
                return true;
            }
            nw.op = Operator::Projected;
            self.eval(model, x, nw.lam, Want { grad: false, hess: Some(nw.op) });
        }
        nw.certified = false;
        for _ in 0..24 {
            if self.factor_step(model, nw, scale) {
                return true;
            }
            nw.mu = (nw.mu * 10.0).max(1e-10);
        }
        false
    }

    /// The smallest shift of the ladder `μ₀, max(10 μ₀, 1e-10), …` (up to the first at or above
    /// [`EXACT_SHIFT`]) at which the exact Hessian factorises, factorised into the step; `None` when none does
    /// (`nw.mu` is then back at `μ₀`). The ladder's top is tried right after `μ₀`: near a drape's equilibrium
    /// the exact Hessian is mostly either positive definite or indefinite beyond the whole ladder (the Cusick
    /// specimens: 36 of the 43 ladders that failed at their first shift failed at every one), so a failing
    /// ladder costs two factorisations instead of seven; where the top succeeds the ladder is climbed from
    /// below as before, and the shift taken is the same.
    fn exact_shift(&mut self, model: &Model, nw: &mut Newton, scale: f64) -> Option<f64> {
        let mu0 = nw.mu;
        let ladder: Vec<f64> =
            std::iter::successors(Some(mu0), |&mu| (mu < EXACT_SHIFT).then(|| (mu * 10.0).max(1e-10))).collect();
        let top = ladder[ladder.len() - 1];
        let found = if self.factor_at(model, nw, scale, mu0) {
            Some(mu0)
        } else if ladder.len() > 2 && !self.factor_at(model, nw, scale, top) {
            // When even the top fails, so does every shift between.
            None
        } else {
            ladder[1..].iter().copied().find(|&mu| self.factor_at(model, nw, scale, mu))
        };
        nw.mu = mu0;
        found
    }

    /// [`Self::factor_step`] at the shift `mu` (left in `nw.mu`).
    fn factor_at(&mut self, model: &Model, nw: &mut Newton, scale: f64, mu: f64) -> bool {
        nw.mu = mu;
        self.factor_step(model, nw, scale)
    }

    /// Factorises the assembled matrix shifted by `μ s` (`s` the Hessian's scale, at least [`EPS_SHIFT`]) into
    /// the step `−(H + μ s I)⁻¹ g`; true on success.
    fn factor_step(&mut self, model: &Model, nw: &mut Newton, scale: f64) -> bool {
        let s = (nw.mu * scale).max(EPS_SHIFT * scale);
        for (p, g) in nw.step.iter_mut().zip(&nw.grad) {
            *p = -*g;
        }
        self.factor_with(model, s, &mut nw.step)
    }

    /// A step whose decrease `Π` cannot resolve: judged on the residual instead (taken when it halves it),
    /// else convergence within round-off, else a larger shift.
    fn unresolved(&mut self, model: &Model, x: &mut [Vec3], nw: &mut Newton) -> Result<Flow, StaticError> {
        let pt = self.eval(model, &nw.trial, nw.lam, Want::GRADIENT);
        let rt = max_abs(&self.ws.grad) / nw.load;
        if pt.is_finite() && rt < 0.5 * nw.res {
            x.copy_from_slice(&nw.trial);
            nw.fresh = true;
            return Ok(Flow::Next);
        }
        if nw.res <= nw.tol.sqrt() {
            // Within round-off of a stationary point, where `Π` cannot judge a step: a watchdog's checkpoint
            // (a tentative step under way) cannot be judged by `Π` either, and waiting for it would only grow
            // the shift until the budget ran out, as it did on the KES bending strip of an ARCSim material.
            nw.watch = None;
            let exact_at_x = nw.fresh && nw.op == Operator::Exact;
            if self.settle(model, x, nw, exact_at_x)? {
                return Ok(Flow::Done(Outcome::Converged(nw.it, nw.res, nw.pi, nw.escapes)));
            }
            nw.fresh = true;
            return Ok(Flow::Next);
        }
        if nw.mu > 1e6 {
            return Ok(Flow::Done(Outcome::Failed(nw.it)));
        }
        nw.mu = (nw.mu * 10.0).max(1e-10);
        nw.fresh = false;
        Ok(Flow::Next)
    }

    /// The trust region's verdict on the step to `nw.trial`: taken (the shift relaxed or tightened by the
    /// ratio of actual to predicted decrease), taken tentatively under a new watchdog, or rejected with the
    /// shift the quadratic fit of `Π` along the step asks for.
    fn judge(&mut self, model: &Model, x: &mut [Vec3], nw: &mut Newton, j: Judged) -> Flow {
        let Judged { gp, pp, pred, scale } = j;
        let (pi, mu) = (nw.pi, nw.mu);
        let pt = self.eval(model, &nw.trial, nw.lam, Want::VALUE);
        let rho = if pt.is_finite() { (pt - pi) / pred } else { f64::NEG_INFINITY };
        if nw.watch.is_some() {
            // Tentative: follow the Newton step whatever Π does (the checkpoint decides).
            x.copy_from_slice(&nw.trial);
            (nw.fresh, nw.mu) = (true, 0.0);
        } else if rho > ARMIJO {
            x.copy_from_slice(&nw.trial);
            if rho > 0.75 {
                nw.mu = if mu <= 1e-10 { 0.0 } else { mu * 0.125 };
            } else if rho < 0.25 {
                nw.mu = (mu * 4.0).max(1e-10);
            }
            nw.since_watch += 1;
            nw.fresh = true;
        } else if nw.since_watch >= WATCH_REARM && pt.is_finite() {
            nw.watch = Some(Watch { x: x.to_vec(), pi, pred, mu, left: WATCH_STEPS });
            x.copy_from_slice(&nw.trial);
            (nw.fresh, nw.mu) = (true, 0.0);
        } else {
            // Rejected: the step that the quadratic fit of Π along p would take sets the new shift.
            let alpha = descent::backtrack(pi, gp, pt);
            let gn: f64 = nw.grad.iter().map(|g| g.length_squared()).sum::<f64>().sqrt();
            let need = gn / (alpha * pp.sqrt()) / scale;
            nw.mu = (mu * 4.0).max(need.min(mu * 1e3 + 1e-10)).max(1e-10);
            nw.fresh = false;
            if nw.mu > 1e6 {
                // No step of any length decreases Π: round-off, if the residual is that small.
                return Flow::Done(if nw.res <= nw.tol.sqrt() {
                    Outcome::Converged(nw.it, nw.res, pi, nw.escapes)
                } else {
                    Outcome::Failed(nw.it)
                });
            }
        }
        Flow::Next
    }

    /// Back to a watchdog's checkpoint after it failed: a larger shift, no new watchdog for a while.
    fn restore(&mut self, x: &mut [Vec3], w: &Watch, mu: &mut f64, since_watch: &mut usize) {
        x.copy_from_slice(&w.x);
        *mu = (w.mu * 4.0).max(1e-8);
        *since_watch = 0;
    }

    /// At a converged point `x`: true if it is stable (or cannot be left); else leaves the saddle along its most
    /// negative curvature (into `x`) and returns false. `exact_at_x`: the workspace holds the exact Hessian at `x`.
    #[allow(clippy::too_many_arguments)]
    fn stable_or_escape(
        &mut self,
        model: &Model,
        x: &mut [Vec3],
        lam: f64,
        pi: f64,
        grad: &[Vec3],
        trial: &mut [Vec3],
        exact_at_x: bool,
    ) -> Result<bool, StaticError> {
        if !exact_at_x {
            self.eval(model, x, lam, Want { grad: false, hess: Some(Operator::Exact) });
        }
        let Some(d) = self.negative_curvature(model)? else { return Ok(true) };
        if !self.escape(model, x, lam, pi, grad, &d, trial) {
            return Ok(true);
        }
        x.copy_from_slice(trial);
        Ok(false)
    }

    /// At a stationary point `x`: the direction of most negative curvature of the exact Hessian (assembled in
    /// the workspace by the last evaluation at `x`), or `None` when the Hessian is positive semi-definite to
    /// [`EPS_SHIFT`] of its scale.
    fn negative_curvature(&mut self, model: &Model) -> Result<Option<Vec<Vec3>>, StaticError> {
        let n = model.potential.fixed().len();
        let fixed = model.pinned();
        let scale = self.scale();
        let mut v = vec![Vec3::ZERO; n];
        let mut lo = EPS_SHIFT * scale;
        if self.factor_with(model, lo, &mut v) {
            return Ok(None);
        }
        // Bracket the smallest shift that factorises, then narrow it to a few per cent.
        let mut hi = lo;
        loop {
            hi *= 10.0;
            if hi > 1e3 * scale {
                return Ok(None);
            }
            if self.factor_with(model, hi, &mut v) {
                break;
            }
            lo = hi;
        }
        for _ in 0..6 {
            let mid = (lo * hi).sqrt();
            if self.factor_with(model, mid, &mut v) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        // Inverse iteration on H + hi I from a fixed, generic start.
        for (k, d) in v.iter_mut().enumerate() {
            let h = (k as f64 * 0.618_033_988_75).fract();
            *d = if fixed[k] {
                Vec3::ZERO
            } else {
                Vec3::new(h - 0.5, (3.0 * h).fract() - 0.5, (7.0 * h).fract() - 0.5)
            };
        }
        if !self.factor_with(model, hi, &mut v) {
            return Ok(None);
        }
        for _ in 0..12 {
            let norm = v.iter().map(|d| d.length_squared()).sum::<f64>().sqrt();
            if !(norm > 0.0 && norm.is_finite()) {
                return Ok(None);
            }
            v.iter_mut().for_each(|d| *d /= norm);
            if !self.resolve(model, hi, &mut v) {
                return Ok(None);
            }
        }
        let norm = v.iter().map(|d| d.length_squared()).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Ok(None);
        }
        v.iter_mut().for_each(|d| *d /= norm);
        // Rayleigh quotient with the unshifted matrix.
        let mut hv = vec![Vec3::ZERO; n];
        self.ws.matrix.mul_add(model.potential.pattern(), &v, &mut hv);
        let curv: f64 = v.iter().zip(&hv).zip(fixed).filter(|(_, &f)| !f).map(|((a, b), _)| a.dot(*b)).sum();
        Ok((curv < -EPS_SHIFT * scale).then_some(v))
    }

    /// Leaves a saddle at `x` (value `pi`, gradient `grad`) along the unit direction `d`: the largest step, from
    /// a tenth of the sheet's size down, that lowers `Π`, into `trial`. False if none does.
    #[allow(clippy::too_many_arguments)]
    fn escape(
        &mut self,
        model: &Model,
        x: &[Vec3],
        lam: f64,
        pi: f64,
        grad: &[Vec3],
        d: &[Vec3],
        trial: &mut [Vec3],
    ) -> bool {
        let gd: f64 = grad.iter().zip(d).map(|(g, v)| g.dot(*v)).sum();
        let sign = if gd > 0.0 { -1.0 } else { 1.0 };
        let big = d.iter().map(|v| v.length()).fold(0.0, f64::max);
        if big.is_nan() || big <= 0.0 {
            return false;
        }
        let mut alpha = 0.1 * model.length_scale() / big;
        for _ in 0..30 {
            for k in 0..x.len() {
                trial[k] = x[k] + d[k] * (sign * alpha);
            }
            let pt = self.eval(model, trial, lam, Want::VALUE);
            if pt < pi {
                return true;
            }
            alpha *= 0.5;
        }
        false
    }
}
