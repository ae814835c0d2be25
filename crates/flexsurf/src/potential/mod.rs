//! The total potential `Π(x)`: every energy and force acting on the sheet is a [`Term`] with value, gradient and
//! Hessian side by side, held in one ordered, open list ([`Potential`]) by the model.
//!
//! The terms today: the elastic energy ([`crate::energy::membrane::Membrane`],
//! [`crate::energy::bending::Bending`], or the Terzopoulos bending force [`elastic::TerzopoulosBending`]),
//! gravity and nodal loads ([`external::External`]), springs ([`springs::Springs`]) and penalty contact with the
//! obstacles ([`contact::PenaltyContact`]); the dynamic step adds its own [`inertia::Inertia`]. Pins are
//! constraints, not terms: the fixed nodes of [`Pins`].
//!
//! Both solvers call the same assembly ([`Potential::assemble`]): the dynamic step minimises the incremental
//! potential `Π(y) + inertia(y)` (docs/model.md §8), the static solver `Π(x)` itself (§9). Neither knows a
//! concrete term: they see stages, energy parts and the capabilities a term declares (conservative or not, an
//! active set to refine).
//!
//! **Order.** Terms are evaluated in [`Stage`] order (fields, the step's inertia, nodal attachments, contact),
//! and in insertion order within a stage. The order of the floating-point additions is part of the
//! bit-for-bit reproducibility of a run; a new term picks its stage and is appended to it.

pub mod body_contact;
pub mod contact;
pub mod elastic;
pub mod external;
pub mod face_samples;
pub mod friction;
pub mod inertia;
pub mod self_contact;
pub mod sewing;
pub mod springs;

use crate::contact::Obstacle;
use crate::energy::{Operator, Sink};
use crate::math::{Mat3, Vec3};
use crate::sparse::{BlockMatrix, BlockPattern};
use std::any::Any;
use std::fmt::Debug;

/// Where a term sits in the evaluation order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Stage {
    /// Distributed over the sheet: elastic energy, gravity, loads.
    Field,
    /// The dynamic step's inertia and damping (added by the integrator, never held by a model).
    Inertia,
    /// Nodal attachments: springs.
    Attachment,
    /// Terms with an active set that a step refines after each solve: contact.
    Contact,
}

/// Which energy a term's value counts as, for records (`energy.csv`, summaries).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// Stretch and shear.
    Membrane,
    /// Bending and twist.
    Bending,
    /// Gravity and constant loads (`−Σ f·x`).
    Load,
    /// Springs.
    Spring,
    /// Obstacle contact.
    Contact,
    /// The step's inertia and damping.
    Inertia,
}

impl Part {
    /// True for the parts of the sheet's elastic energy.
    pub fn is_elastic(self) -> bool {
        matches!(self, Part::Membrane | Part::Bending)
    }
}

/// What a term is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TermInfo {
    /// Short name for messages, tests and the per-term energy records.
    pub name: &'static str,
    /// Where the term is evaluated.
    pub stage: Stage,
    /// Which energy its value counts as.
    pub part: Part,
    /// False when the gradient is not the derivative of the value (the Terzopoulos force): the static solver
    /// and line searches refuse such a potential.
    pub conservative: bool,
}

impl TermInfo {
    /// A conservative term.
    pub const fn new(name: &'static str, stage: Stage, part: Part) -> Self {
        Self { name, stage, part, conservative: true }
    }

    /// The same term, marked as not the gradient of its value.
    pub const fn non_conservative(self) -> Self {
        Self { conservative: false, ..self }
    }
}

/// The motion a dynamic step starts from, in the form every scheme shares: the step minimises
/// `Π(y) + Σ ½ m α |y − ŷ|² + ½ c β |y − z|²` over the new positions `y` (docs/model.md §8), where the scheme
/// chooses the inertial target `ŷ`, the damping centre `z` and the coefficients `α`, `β`:
/// central differences `ŷ = 2x_t − x⁻`, `z = x⁻`, `α = 1/Δt²`, `β = 1/(2Δt)`; BDF2
/// `ŷ = (4x_t − x⁻)/3 + (8v_t − 2v⁻)Δt/9`, `z = (4x_t − x⁻)/3`, `α = 9/(4Δt²)`, `β = 3/(2Δt)`.
#[derive(Debug, Clone, Copy)]
pub struct Motion<'a> {
    /// Positions at the start of the step (friction's anchor).
    pub x: &'a [Vec3],
    /// Positions one step earlier.
    pub x_prev: &'a [Vec3],
    /// Velocities at the start of the step.
    pub v: &'a [Vec3],
    /// Velocities one step earlier.
    pub v_prev: &'a [Vec3],
    /// The inertial target `ŷ`: where the nodes go with no force (also the contact prediction).
    pub target: &'a [Vec3],
    /// The damping centre `z`.
    pub damp_center: &'a [Vec3],
    /// `α` (1/s²).
    pub inertia: f64,
    /// `β` (1/s).
    pub damp: f64,
    /// Time step (s).
    pub dt: f64,
    /// Lumped node masses (kg).
    pub mass: &'a [f64],
    /// Lumped node damping (kg/s).
    pub damping: &'a [f64],
    /// The first assembly of a step: contact candidates also come from the target `ŷ`, and lagged quantities
    /// (friction's normal forces and tangent planes) are taken at this configuration.
    pub predict: bool,
    /// A Newton iteration of a converging contact step: friction takes its law's own second-order model at the
    /// iterate (the exact gradient and positive semi-definite Hessian of `μλ f₀(|u|)`, no majorant), and the
    /// solves do not re-linearise it (the line search on `Φ` settles the step).
    pub exact: bool,
}

/// What a term may read besides the configuration.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// Fixed (pinned) nodes.
    pub fixed: &'a [bool],
    /// Block id of each node's diagonal block in the pattern.
    pub diag: &'a [u32],
    /// The step's motion (`None` in a static solve).
    pub motion: Option<Motion<'a>>,
}

/// Per-run scratch of one term (a contact cache and its active set): created by the term on first use
/// ([`Scratch::get_or`]), kept by the caller's [`Workspace`] between evaluations.
#[derive(Default)]
pub struct Scratch(Option<Box<dyn Any + Send>>);

// Saving and restoring the scratch that carries over between steps, for checkpoints (issue 11).
mod warm;
pub use warm::WarmState;

impl Scratch {
    /// The scratch as a `T`, created by `make` when absent (or of another type).
    pub fn get_or<T: Any + Send>(&mut self, make: impl FnOnce() -> T) -> &mut T {
        if !self.0.as_ref().is_some_and(|b| b.is::<T>()) {
            self.0 = Some(Box::new(make()));
        }
        match self.get_mut::<T>() {
            Some(t) => t,
            None => unreachable!("the scratch was just set to a T"),
        }
    }

    /// Forgets everything (the next evaluation starts cold).
    pub fn clear(&mut self) {
        self.0 = None;
    }
}

/// Cloning and inspection of boxed terms (implemented for every `Term + Clone`).
pub trait TermClone {
    /// A boxed copy.
    fn clone_box(&self) -> Box<dyn Term>;
    /// The term as `Any`, to find a concrete term ([`Potential::find`]).
    fn as_any(&self) -> &dyn Any;
    /// The term as mutable `Any`, to change a concrete term's data between steps ([`Potential::find_mut`]).
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: Term + Clone + 'static> TermClone for T {
    fn clone_box(&self) -> Box<dyn Term> {
        Box::new(self.clone())
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

impl Clone for Box<dyn Term> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// One term of the total potential.
///
/// `evaluate` adds the term's value to `sink.energy`, its gradient `∂/∂x` to `sink.grad` and the requested
/// Hessian approximation ([`Operator`]) to `sink.hess`, all from one pass so the three cannot drift apart, and
/// returns the term's value. A term that is not the gradient of its value says so in its [`TermInfo`].
///
/// That is the whole contract. What only some terms have is an opt-in capability: an active set that a step
/// refines ([`Term::active_set`], contact), and state that carries over between steps and so goes into
/// checkpoints ([`Term::save`], [`Term::restore`]).
pub trait Term: Send + Sync + Debug + TermClone {
    /// What the term is: name, stage, energy part, and whether it is conservative.
    fn info(&self) -> TermInfo;
    /// Node pairs whose Hessian block the term touches (its diagonal blocks are always in the pattern).
    fn pairs(&self) -> Vec<(usize, usize)> {
        Vec::new()
    }
    /// Precomputes block ids for a pattern that contains [`Term::pairs`].
    fn bind(&mut self, _pattern: &BlockPattern) {}
    /// Adds value, gradient and Hessian at `x` into `sink`; returns the value.
    fn evaluate(&self, x: &[Vec3], cx: &Context, scratch: &mut Scratch, sink: &mut Sink) -> f64;
    /// Magnitude of the prescribed forces of this term for a sheet of size `length` (N), the scale of residual
    /// tolerances; 0 for terms that only react.
    fn load_scale(&self, _length: f64) -> f64 {
        0.0
    }
    /// The term's active set, for terms whose support depends on the configuration (contact).
    fn active_set(&self) -> Option<&dyn ActiveSet> {
        None
    }
    /// The part of `scratch` that carries over between steps, encoded for a checkpoint (`None`: nothing).
    /// A term whose scratch changes later results must save it; the default refuses a non-empty scratch so
    /// that a new term cannot be silently resumed cold.
    fn save(&self, scratch: &Scratch) -> Result<Option<Vec<u8>>, String> {
        match scratch.0 {
            None => Ok(None),
            Some(_) => Err(format!("the term `{}` keeps a state it cannot save", self.info().name)),
        }
    }
    /// Restores what [`Term::save`] wrote into `scratch`.
    fn restore(&self, saved: Option<&[u8]>, scratch: &mut Scratch) -> Result<(), String> {
        match saved {
            None => {
                scratch.clear();
                Ok(())
            }
            Some(_) => {
                Err(format!("the checkpoint holds a state for the term `{}`, which keeps none", self.info().name))
            }
        }
    }
}

/// The capability of a term whose support depends on the configuration (contact): it finds the support
/// before an evaluation, refines it after a solve, measures how far its linear model is off, and carries
/// Coulomb friction (lagged in a step, re-lagged by the static solver).
pub trait ActiveSet {
    /// Finds the configuration-dependent support at `x` (contact detection) into `scratch`.
    fn prepare(&self, x: &[Vec3], cx: &Context, scratch: &mut Scratch);
    /// After a solve proposing `x + delta`, updates the support; true if it changed.
    fn refine(&self, x: &[Vec3], delta: &[Vec3], cx: &Context, scratch: &mut Scratch) -> bool;
    /// How far the term at `x` is from the linear model of it that the last assembly solved with (a lagged
    /// or linearised law, friction), each record relative to the term's own force scale; none for terms whose
    /// model is their Newton linearisation. A step makes Newton corrections while this exceeds its tolerance.
    fn model_error(&self, _x: &[Vec3], _cx: &Context, _scratch: &mut Scratch) -> friction::Misfit {
        friction::Misfit::default()
    }
    /// A node whose straight path from `from` to `to` passed through an obstacle (continuous detection after a
    /// step); `None` when none did.
    fn tunnelled(&self, from: &[Vec3], to: &[Vec3], scratch: &mut Scratch) -> Option<usize>;
    /// How many constraints are active in `scratch` (touching contacts).
    fn active(&self, scratch: &Scratch) -> usize;
    /// Whether the support in `scratch` holds anything a step's solve used: a contact record (touching, or
    /// predicted from the motion) or lagged friction. Such a step takes the contact steps' Newton rule
    /// ([`crate::integrate::Stepper::step`]).
    fn engaged(&self, scratch: &Scratch) -> bool {
        self.active(scratch) > 0
    }
    /// Whether a contact step the term is engaged in may be iterated by Newton's method with the line
    /// search: the term's value and gradient at an iterate are those of the step's incremental potential (its
    /// contacts found again there). False for a term whose records keep what the step's start fixed and whose
    /// set changes between iterates (the pairs between faces: docs/model.md §8.5).
    fn convergent(&self) -> bool {
        true
    }
    /// How far the contacts' linear models of the last solve were, at the iterate of the last assembly, from
    /// the contact forces found there, relative to the largest contact force (0 where not measured).
    fn linear_error(&self, _scratch: &Scratch) -> f64 {
        0.0
    }
    /// Largest violation at `x` (penetration below an obstacle's surface, m), warm-started from `scratch`.
    fn violation(&self, x: &[Vec3], cx: &Context, scratch: &mut Scratch) -> f64;
    /// Forgets the warm start and the support (the next evaluation starts cold); what a static solve lagged
    /// ([`ActiveSet::relag`]) is kept.
    fn forget(&self, scratch: &mut Scratch) {
        scratch.clear();
    }
    /// The slip speed `ε_v` of the term's friction (0 without friction).
    fn slip_speed(&self) -> f64 {
        0.0
    }
    /// The Coulomb limits of the term's touching contacts at `x`: `(node, unit normal, μλ)` (friction; the
    /// consistent start of a run needs them).
    fn coulomb(&self, _x: &[Vec3]) -> Vec<(usize, Vec3, f64)> {
        Vec::new()
    }
    /// Quasi-static friction of a static solve (docs/model.md §9, §10.2): with `start`, anchors the tangential
    /// displacement at `x` (the configuration the solve starts from) and lags the Coulomb limits there; else
    /// re-lags them at the equilibrium `x` just found. Friction's smoothing length is the slip speed times
    /// `slip_time`. True when the lagged limits changed (by more than 1 % of the largest; at the start: when
    /// there is friction at all), so the static solver solves again.
    fn relag(&self, _x: &[Vec3], _start: bool, _slip_time: f64, _scratch: &mut Scratch) -> bool {
        false
    }
    /// Whether the records in `scratch` can be held ([`ActiveSet::hold`]) for an assembly at `x`: none is
    /// deeper there than the contact offset below the obstacle's surface (the proposal of a solve that missed
    /// only shallow contacts). The default: only when it holds none (a term that cannot hold).
    fn can_hold(&self, _x: &[Vec3], scratch: &Scratch) -> bool {
        !self.engaged(scratch)
    }
    /// Holds the records of the last refinement (`on`) or releases them: while held, [`ActiveSet::prepare`]
    /// keeps them, their linear models evaluated at the iterate, instead of detecting the support again there.
    /// The default (a term that cannot hold) does nothing.
    fn hold(&self, _scratch: &mut Scratch, _on: bool) {}
    /// Sets `touched[k]` for every node a record in `scratch` acts on (contact, lagged friction); the default
    /// (a term that cannot hold, [`ActiveSet::can_hold`]) marks none.
    fn mark_touched(&self, _scratch: &Scratch, _touched: &mut [bool]) {}
}

/// Fixed (pinned) nodes: constraints held exactly at their position. The assembly zeroes their gradient rows
/// and the linear solvers eliminate their unknowns.
#[derive(Debug, Clone, PartialEq)]
pub struct Pins {
    fixed: Vec<bool>,
}

impl Pins {
    /// No node fixed among `n`.
    pub fn none(n: usize) -> Self {
        Self { fixed: vec![false; n] }
    }

    /// From one flag per node.
    pub fn from_flags(fixed: Vec<bool>) -> Self {
        Self { fixed }
    }

    /// One flag per node.
    pub fn flags(&self) -> &[bool] {
        &self.fixed
    }

    /// Number of fixed nodes.
    pub fn count(&self) -> usize {
        self.fixed.iter().filter(|&&f| f).count()
    }
}

/// Values of the parts of a potential after an evaluation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Values {
    /// The total (every term, in evaluation order).
    pub total: f64,
    /// Membrane energy.
    pub membrane: f64,
    /// Bending energy.
    pub bending: f64,
    /// Load potential `−Σ f·x`.
    pub load: f64,
    /// Spring energy.
    pub spring: f64,
    /// Contact energy.
    pub contact: f64,
    /// Touching contacts.
    pub contacts: usize,
}

impl Values {
    fn add(&mut self, part: Part, v: f64) {
        match part {
            Part::Membrane => self.membrane += v,
            Part::Bending => self.bending += v,
            Part::Load => self.load += v,
            Part::Spring => self.spring += v,
            Part::Contact => self.contact += v,
            Part::Inertia => {}
        }
    }
}

/// What an assembly computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Want {
    /// The gradient (into [`Workspace::grad`]).
    pub grad: bool,
    /// A Hessian approximation (into [`Workspace::matrix`]).
    pub hess: Option<Operator>,
}

impl Want {
    /// Value only.
    pub const VALUE: Want = Want { grad: false, hess: None };
    /// Value and gradient.
    pub const GRADIENT: Want = Want { grad: true, hess: None };
}

/// Buffers of an assembly, reused between evaluations: the gradient, the matrix on the potential's pattern, one
/// [`Scratch`] per term and the saved state that lets the contact stage be re-applied after its active set changes.
pub struct Workspace {
    /// `∂Φ/∂x` of the last assembly (rows of fixed nodes zero).
    pub grad: Vec<Vec3>,
    /// The Hessian approximation of the last assembly.
    pub matrix: BlockMatrix,
    /// Seconds spent in the contact stage (detection, contact terms, active-set refinement, the continuous
    /// check of the step's paths), summed.
    pub contact_seconds: f64,
    /// The same, per term (zero for terms outside the contact stage).
    pub term_seconds: Vec<f64>,
    scratch: Vec<Scratch>,
    extra: Scratch,
    base_grad: Vec<Vec3>,
    base_extra: Vec<Mat3>,
    journal: Vec<(u32, Mat3)>,
}

impl Workspace {
    /// Buffers for `potential`.
    pub fn new(potential: &Potential) -> Self {
        let n = potential.fixed().len();
        Self {
            grad: vec![Vec3::ZERO; n],
            matrix: BlockMatrix::zeros(&potential.pattern),
            contact_seconds: 0.0,
            term_seconds: vec![0.0; potential.terms.len()],
            scratch: potential.terms.iter().map(|_| Scratch::default()).collect(),
            extra: Scratch::default(),
            base_grad: vec![Vec3::ZERO; n],
            base_extra: Vec::new(),
            journal: Vec::new(),
        }
    }

    /// Counts the seconds since `t0` as contact time of term `t`.
    fn contact_time(&mut self, t: usize, t0: std::time::Instant) {
        let seconds = t0.elapsed().as_secs_f64();
        self.contact_seconds += seconds;
        self.term_seconds[t] += seconds;
    }

    /// Term `t`'s scratch (its support and warm start), for inspection.
    pub fn scratch(&self, t: usize) -> Option<&Scratch> {
        self.scratch.get(t)
    }
}

/// The total potential: an ordered list of terms on one sparsity pattern, and the fixed nodes.
#[derive(Debug, Clone)]
pub struct Potential {
    terms: Vec<Box<dyn Term>>,
    pins: Pins,
    pattern: BlockPattern,
    diag: Vec<u32>,
}

impl Potential {
    /// The potential of `terms` (evaluated in [`Stage`] order, stable within a stage) on `nodes` nodes with
    /// the fixed nodes `pins`; builds the pattern from every term's pairs and binds the terms to it.
    pub fn new(nodes: usize, mut terms: Vec<Box<dyn Term>>, pins: Pins) -> Self {
        terms.sort_by_key(|t| t.info().stage);
        let pattern = BlockPattern::from_pairs(nodes, terms.iter().flat_map(|t| t.pairs()));
        for t in &mut terms {
            t.bind(&pattern);
        }
        let diag = (0..nodes).map(|k| pattern.find(k, k) as u32).collect();
        Self { terms, pins, pattern, diag }
    }

    /// The terms, in evaluation order.
    pub fn terms(&self) -> &[Box<dyn Term>] {
        &self.terms
    }

    /// The first term of type `T` (for inspection and outputs; solvers never need it).
    pub fn find<T: Term + 'static>(&self) -> Option<&T> {
        self.terms.iter().find_map(|t| t.as_any().downcast_ref::<T>())
    }

    /// The index of the first term of type `T` (for [`Workspace::term_seconds`] and [`Potential::active_of`]).
    pub fn position<T: Term + 'static>(&self) -> Option<usize> {
        self.terms.iter().position(|t| t.as_any().downcast_ref::<T>().is_some())
    }

    /// The active records of term `t` in `ws` (0 for a term without an active set).
    pub fn active_of(&self, t: usize, ws: &Workspace) -> usize {
        self.terms.get(t).and_then(|term| term.active_set()).map_or(0, |a| a.active(&ws.scratch[t]))
    }

    /// The first term of type `T`, mutably: for data that may change between steps without changing the
    /// term's sparsity pattern (a spring's target, [`crate::model::Model::set_spring_target`]).
    pub fn find_mut<T: Term + 'static>(&mut self) -> Option<&mut T> {
        self.terms.iter_mut().find_map(|t| t.as_any_mut().downcast_mut::<T>())
    }

    /// Block pattern of every term's Hessian.
    pub fn pattern(&self) -> &BlockPattern {
        &self.pattern
    }

    /// Block id of node `k`'s diagonal block.
    pub fn diag_ids(&self) -> &[u32] {
        &self.diag
    }

    /// The fixed nodes.
    pub fn pins(&self) -> &Pins {
        &self.pins
    }

    /// Fixed nodes, one flag per node.
    pub fn fixed(&self) -> &[bool] {
        self.pins.flags()
    }

    /// True when every term is the gradient of its value.
    pub fn conservative(&self) -> bool {
        self.terms.iter().all(|t| t.info().conservative)
    }

    /// The first term that is not conservative.
    pub fn non_conservative(&self) -> Option<&'static str> {
        self.terms.iter().map(|t| t.info()).find(|i| !i.conservative).map(|i| i.name)
    }

    /// True when some term has an active set.
    pub fn has_active_set(&self) -> bool {
        self.terms.iter().any(|t| t.active_set().is_some())
    }

    /// The terms with an active set, with their index in [`Potential::terms`].
    fn active_sets(&self) -> impl Iterator<Item = (usize, &dyn ActiveSet)> + '_ {
        self.terms.iter().enumerate().filter_map(|(t, term)| term.active_set().map(|a| (t, a)))
    }

    /// Every obstacle of the potential's obstacle contact.
    pub fn obstacles(&self) -> Vec<Obstacle> {
        self.find::<contact::PenaltyContact>().map(|c| c.obstacles().to_vec()).unwrap_or_default()
    }

    /// Every spring of the potential.
    pub fn springs(&self) -> Vec<springs::Spring> {
        self.find::<springs::Springs>().map(|s| s.springs().to_vec()).unwrap_or_default()
    }

    /// Largest load scale of the terms of `stage` (all stages when `None`).
    pub fn load_scale(&self, stage: Option<Stage>, length: f64) -> f64 {
        self.terms
            .iter()
            .filter(|t| stage.is_none_or(|s| t.info().stage == s))
            .map(|t| t.load_scale(length))
            .fold(0.0, f64::max)
    }

    /// Forgets every term's warm start and active set (the next evaluation starts cold), keeping what a
    /// static solve lagged ([`Potential::relag`]).
    pub fn cold(&self, ws: &mut Workspace) {
        for (t, term) in self.terms.iter().enumerate() {
            match term.active_set() {
                Some(a) => a.forget(&mut ws.scratch[t]),
                None => ws.scratch[t].clear(),
            }
        }
        ws.extra.clear();
    }

    /// Lags (`start`) or re-lags the quasi-static friction of every active set at `x` (see
    /// [`ActiveSet::relag`]); true when the static solver must solve again.
    pub fn relag(&self, x: &[Vec3], start: bool, slip_time: f64, ws: &mut Workspace) -> bool {
        let mut changed = false;
        for (t, a) in self.active_sets() {
            changed |= a.relag(x, start, slip_time, &mut ws.scratch[t]);
        }
        changed
    }

    /// The context of an evaluation with `motion` (`None`: static).
    pub fn context<'a>(&'a self, motion: Option<Motion<'a>>) -> Context<'a> {
        Context { fixed: self.pins.flags(), diag: &self.diag, motion }
    }

    /// Every term's active set detected at `x` ([`Potential::prepare`]), then every term evaluated there
    /// ([`Potential::assemble_prepared`]).
    pub fn assemble(
        &self,
        x: &[Vec3],
        cx: &Context,
        extra: Option<&dyn Term>,
        want: Want,
        ws: &mut Workspace,
    ) -> Values {
        self.prepare(x, cx, ws);
        self.assemble_prepared(x, cx, extra, want, ws)
    }

    /// Detects every term's active set at `x`, for [`Potential::assemble_prepared`] at the same `x` and `cx`: what is
    /// engaged ([`Potential::engaged`]) is then known before anything is assembled (the stepper chooses its
    /// operator by it).
    pub fn prepare(&self, x: &[Vec3], cx: &Context, ws: &mut Workspace) {
        for (t, a) in self.active_sets() {
            let t0 = std::time::Instant::now();
            a.prepare(x, cx, &mut ws.scratch[t]);
            if self.terms[t].info().stage == Stage::Contact {
                ws.contact_time(t, t0);
            }
        }
    }

    /// Evaluates every term (and `extra`, the integrator's own term, at its stage) at `x` with the active sets
    /// [`Potential::prepare`] detected: the value of each part, and what `want` asks into `ws.grad` and
    /// `ws.matrix`. Fixed nodes' gradient rows are zero afterwards.
    pub fn assemble_prepared(
        &self,
        x: &[Vec3],
        cx: &Context,
        extra: Option<&dyn Term>,
        want: Want,
        ws: &mut Workspace,
    ) -> Values {
        ws.grad.fill(Vec3::ZERO);
        if want.hess.is_some() {
            ws.matrix.clear();
        }
        let pass = Pass { x, cx, want };
        let mut values = Values::default();
        let mut energy = 0.0;
        let mut extra_done = extra.is_none();
        let mut contact_started = false;
        for (t, term) in self.terms.iter().enumerate() {
            let info = term.info();
            if !extra_done && info.stage > Stage::Inertia {
                energy = ws.apply(extra, Slot::Extra, &pass, energy, &mut values);
                extra_done = true;
            }
            let t0 = (info.stage == Stage::Contact).then(std::time::Instant::now);
            if info.stage == Stage::Contact && !contact_started {
                ws.journal.clear();
                ws.base_grad.copy_from_slice(&ws.grad);
                ws.base_extra.clone_from(&ws.matrix.extra.blocks);
                contact_started = true;
            }
            energy = ws.apply(Some(&**term), Slot::Term(t), &pass, energy, &mut values);
            if let Some(t0) = t0 {
                ws.contact_time(t, t0);
            }
        }
        if !extra_done {
            energy = ws.apply(extra, Slot::Extra, &pass, energy, &mut values);
        }
        values.total = energy;
        self.zero_fixed(&mut ws.grad);
        values
    }

    /// After a solve proposing `x + delta`: refines every active set; if one changed, undoes the contact stage
    /// of the last assembly (gradient and matrix) and re-applies it with the new sets. Returns true if anything
    /// changed (the caller solves again).
    pub fn refine(&self, x: &[Vec3], delta: &[Vec3], cx: &Context, want: Want, ws: &mut Workspace) -> bool {
        let t0 = std::time::Instant::now();
        let changed = self.refine_untimed(x, delta, cx, want, ws);
        ws.contact_seconds += t0.elapsed().as_secs_f64();
        changed
    }

    fn refine_untimed(&self, x: &[Vec3], delta: &[Vec3], cx: &Context, want: Want, ws: &mut Workspace) -> bool {
        let mut changed = false;
        for (t, a) in self.active_sets() {
            let t0 = std::time::Instant::now();
            changed |= a.refine(x, delta, cx, &mut ws.scratch[t]);
            ws.term_seconds[t] += t0.elapsed().as_secs_f64();
        }
        if !changed {
            return false;
        }
        self.undo_contact(ws);
        let pass = Pass { x, cx, want };
        let mut energy = 0.0;
        let mut values = Values::default();
        for (t, term) in self.terms.iter().enumerate() {
            if term.info().stage == Stage::Contact {
                let t0 = std::time::Instant::now();
                energy = ws.apply(Some(&**term), Slot::Term(t), &pass, energy, &mut values);
                ws.term_seconds[t] += t0.elapsed().as_secs_f64();
            }
        }
        self.zero_fixed(&mut ws.grad);
        true
    }

    /// Restores the gradient and the matrix blocks the contact stage changed (last change first).
    pub fn undo_contact(&self, ws: &mut Workspace) {
        ws.grad.copy_from_slice(&ws.base_grad);
        for &(id, blk) in ws.journal.iter().rev() {
            ws.matrix.blocks[id as usize] = blk;
        }
        ws.journal.clear();
        // Pairs the contact stage created stay (the set does not shrink within an assembly), with the blocks they
        // had before it: zero.
        let extra = &mut ws.matrix.extra.blocks;
        extra[..ws.base_extra.len()].copy_from_slice(&ws.base_extra);
        extra[ws.base_extra.len()..].fill(Mat3::ZERO);
    }

    /// The first node any term reports as having passed through an obstacle between `from` and `to`.
    pub fn tunnelled(&self, from: &[Vec3], to: &[Vec3], ws: &mut Workspace) -> Option<usize> {
        self.active_sets().find_map(|(t, a)| {
            let t0 = std::time::Instant::now();
            let found = a.tunnelled(from, to, &mut ws.scratch[t]);
            let seconds = t0.elapsed().as_secs_f64();
            ws.contact_seconds += seconds;
            ws.term_seconds[t] += seconds;
            found
        })
    }

    /// The largest slip speed `ε_v` of a term with friction (0 without friction).
    pub fn slip_speed(&self) -> f64 {
        self.active_sets().map(|(_, a)| a.slip_speed()).fold(0.0, f64::max)
    }

    /// Every term's [`Term::coulomb`] limits at `x`.
    pub fn coulomb(&self, x: &[Vec3]) -> Vec<(usize, Vec3, f64)> {
        self.active_sets().flat_map(|(_, a)| a.coulomb(x)).collect()
    }

    /// Every term's [`ActiveSet::model_error`] at `x`, their records together.
    pub fn model_error(&self, x: &[Vec3], cx: &Context, ws: &mut Workspace) -> friction::Misfit {
        let mut all = friction::Misfit::default();
        for (t, a) in self.active_sets() {
            all = all.merge(a.model_error(x, cx, &mut ws.scratch[t]));
        }
        all
    }

    /// Whether any term's active set in `ws` holds a contact record or lagged friction ([`ActiveSet::engaged`]).
    pub fn engaged(&self, ws: &Workspace) -> bool {
        self.active_sets().any(|(t, a)| a.engaged(&ws.scratch[t]))
    }

    /// Whether every term's records can be held for an assembly at `x` ([`ActiveSet::can_hold`]).
    pub fn can_hold(&self, x: &[Vec3], ws: &Workspace) -> bool {
        self.active_sets().all(|(t, a)| a.can_hold(x, &ws.scratch[t]))
    }

    /// Holds (`on`) or releases every term's records ([`ActiveSet::hold`]); only where [`Potential::can_hold`].
    pub fn hold(&self, ws: &mut Workspace, on: bool) {
        for (t, a) in self.active_sets() {
            a.hold(&mut ws.scratch[t], on);
        }
    }

    /// The gradient at `x` of every term but the contact stage's, and of `extra` (the step's inertia), into
    /// `grad` (overwritten; fixed nodes' rows zero), with the terms' scratch of `ws` (nothing in it changes
    /// for a step's motion); `touched[k]` set for every node a contact record or lagged friction acts on
    /// ([`ActiveSet::mark_touched`], where [`Potential::can_hold`]), whose gradient misses those terms.
    pub fn field_gradient(
        &self,
        x: &[Vec3],
        cx: &Context,
        extra: &dyn Term,
        (grad, touched): (&mut [Vec3], &mut [bool]),
        ws: &mut Workspace,
    ) {
        grad.fill(Vec3::ZERO);
        touched.fill(false);
        let mut sink = Sink { grad: Some(&mut *grad), hess: None, energy: 0.0, journal: None };
        extra.evaluate(x, cx, &mut ws.extra, &mut sink);
        for (t, term) in self.terms.iter().enumerate() {
            match term.active_set() {
                Some(a) => a.mark_touched(&ws.scratch[t], touched),
                None if term.info().stage != Stage::Contact => {
                    term.evaluate(x, cx, &mut ws.scratch[t], &mut sink);
                }
                None => {}
            }
        }
        self.zero_fixed(grad);
    }

    /// Whether every engaged term lets a contact step be iterated ([`ActiveSet::convergent`]).
    pub fn convergent(&self, ws: &Workspace) -> bool {
        self.active_sets().all(|(t, a)| !a.engaged(&ws.scratch[t]) || a.convergent())
    }

    /// The largest [`ActiveSet::linear_error`] over the terms.
    pub fn linear_error(&self, ws: &Workspace) -> f64 {
        self.active_sets().map(|(t, a)| a.linear_error(&ws.scratch[t])).fold(0.0, f64::max)
    }

    /// Largest violation over every term at `x` (penetration, m), warm-started from `ws`.
    pub fn violation(&self, x: &[Vec3], cx: &Context, ws: &mut Workspace) -> f64 {
        let mut worst: f64 = 0.0;
        for (t, a) in self.active_sets() {
            worst = worst.max(a.violation(x, cx, &mut ws.scratch[t]));
        }
        worst
    }

    /// Evaluates every term at `x` in a static context into a caller's `sink` (value added to `sink.energy`,
    /// gradient and operator added to), active sets detected cold; fixed rows are not zeroed. Returns the
    /// values by part.
    pub fn evaluate(&self, x: &[Vec3], sink: &mut Sink) -> Values {
        let cx = self.context(None);
        let mut values = Values::default();
        for term in &self.terms {
            let (v, contacts) = cold(&**term, x, &cx, sink);
            values.add(term.info().part, v);
            values.contacts += contacts;
        }
        values.total = sink.energy;
        values
    }

    /// The value of each term at `x` by name (terms of one name, such as the elastic terms of several panels,
    /// summed), in evaluation order; terms with an active set (contact) only when `active` (they are detected
    /// cold, a query per node). For the energy records: their columns follow the terms present.
    pub fn term_energies(&self, x: &[Vec3], active: bool) -> Vec<(&'static str, f64)> {
        self.energies_where(x, active, |_| true)
    }

    /// The names of the terms beyond the sheet's elastic energy and the loads that have no active set
    /// (springs, a library user's terms), once each: the per-step energy table's extra columns.
    pub fn extra_energy_names(&self) -> Vec<&'static str> {
        let mut names: Vec<&'static str> = Vec::new();
        for t in self.terms.iter().filter(|t| t.active_set().is_none()) {
            let info = t.info();
            if !(info.part.is_elastic() || info.part == Part::Load || names.contains(&info.name)) {
                names.push(info.name);
            }
        }
        names
    }

    /// As [`Potential::term_energies`] for the terms whose info satisfies `which`.
    pub fn energies_where(
        &self,
        x: &[Vec3],
        active: bool,
        which: impl Fn(&TermInfo) -> bool,
    ) -> Vec<(&'static str, f64)> {
        let cx = self.context(None);
        let mut out: Vec<(&'static str, f64)> = Vec::new();
        let wanted = |t: &dyn Term| which(&t.info()) && (active || t.active_set().is_none());
        for term in self.terms.iter().filter(|t| wanted(&***t)) {
            let (v, _) = cold(&**term, x, &cx, &mut Sink::none());
            let name = term.info().name;
            match out.iter_mut().find(|(n, _)| *n == name) {
                Some((_, total)) => *total += v,
                None => out.push((name, v)),
            }
        }
        out
    }

    /// Largest violation over every term at `x` (penetration, m), from cold queries.
    pub fn violation_cold(&self, x: &[Vec3]) -> f64 {
        let cx = self.context(None);
        let mut worst: f64 = 0.0;
        for (_, a) in self.active_sets() {
            worst = worst.max(a.violation(x, &cx, &mut Scratch::default()));
        }
        worst
    }

    /// Value of the terms whose part satisfies `which` at `x`, gradient into `grad` (added to, when given);
    /// no active set is detected (contact terms are skipped).
    pub fn value_of(&self, x: &[Vec3], which: impl Fn(Part) -> bool, grad: Option<&mut [Vec3]>) -> Values {
        let cx = self.context(None);
        let mut values = Values::default();
        let mut sink = Sink { grad, hess: None, energy: 0.0, journal: None };
        for term in self.terms.iter().filter(|t| which(t.info().part) && t.info().stage != Stage::Contact) {
            let v = term.evaluate(x, &cx, &mut Scratch::default(), &mut sink);
            values.add(term.info().part, v);
        }
        values.total = sink.energy;
        values
    }

    fn zero_fixed(&self, grad: &mut [Vec3]) {
        for (g, &f) in grad.iter_mut().zip(self.pins.flags()) {
            if f {
                *g = Vec3::ZERO;
            }
        }
    }
}

/// `term` evaluated into `sink` at `x` from a cold scratch (its active set, if any, detected first): its value
/// and its active constraints.
fn cold(term: &dyn Term, x: &[Vec3], cx: &Context, sink: &mut Sink) -> (f64, usize) {
    let mut scratch = Scratch::default();
    let active = term.active_set();
    if let Some(a) = active {
        a.prepare(x, cx, &mut scratch);
    }
    let v = term.evaluate(x, cx, &mut scratch, sink);
    (v, active.map_or(0, |a| a.active(&scratch)))
}

/// One evaluation pass: the configuration, the context and what is wanted.
struct Pass<'a> {
    x: &'a [Vec3],
    cx: &'a Context<'a>,
    want: Want,
}

/// Where a term's scratch lives in a [`Workspace`].
#[derive(Clone, Copy)]
enum Slot {
    Term(usize),
    Extra,
}

impl Workspace {
    /// Evaluates `term` (if any) into the workspace's buffers, its value added to the running `energy` (returned)
    /// and recorded in `values`; the contact stage writes the matrix through the journal.
    fn apply(&mut self, term: Option<&dyn Term>, slot: Slot, pass: &Pass, energy: f64, values: &mut Values) -> f64 {
        let Some(term) = term else { return energy };
        let scratch = match slot {
            Slot::Term(t) => &mut self.scratch[t],
            Slot::Extra => &mut self.extra,
        };
        let info = term.info();
        let journal = (info.stage == Stage::Contact).then_some(&mut self.journal);
        let grad = if pass.want.grad { Some(&mut self.grad[..]) } else { None };
        let hess = pass.want.hess.map(|op| (&mut self.matrix, op));
        let mut sink = Sink { grad, hess, energy, journal };
        let v = term.evaluate(pass.x, pass.cx, scratch, &mut sink);
        values.add(info.part, v);
        values.contacts += term.active_set().map_or(0, |a| a.active(scratch));
        sink.energy
    }
}
