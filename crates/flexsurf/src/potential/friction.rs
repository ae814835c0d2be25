//! Implicit Coulomb friction as a lagged dissipative potential (the approach of Li et al. 2020, "Incremental
//! Potential Contact", §5; docs/model.md §10.2).
//!
//! For a node in contact at the start of a step, with the normal force `λ` and the tangent projector
//! `P = I − ννᵀ` taken there (lagged), and the tangential displacement over the step `u = P (y − x_t)`, the
//! friction potential is `D(u) = μ λ f₀(|u|)` with the smooth magnitude
//!
//! `f₀(s) = −s³/(3ε²) + s²/ε + ε/3` for `s < ε`, `f₀(s) = s` beyond, `ε = ε_v Δt`,
//!
//! whose force `−μ λ f₁(s) u/s` (`f₁ = f₀'`, `f₁(s) = 2s/ε − s²/ε²` below `ε`, 1 beyond) has the Coulomb
//! magnitude `μ λ` once the node slides faster than `ε_v`, and below it is a stiff, smooth static friction: a
//! node held by friction creeps at most at `ε_v (1 − √(1 − F/(μλ)))` under a tangential load `F < μλ`.
//!
//! **Linear models.** A node that slides (`s_l ≥ ε` at its linearisation point `u_l`) is solved with the
//! friction's tangent (Newton) model about `u_l`: the Coulomb force `μλ û_l` plus the turning stiffness
//! `μλ/s_l (P − û_l û_lᵀ)`, exact in magnitude and second-order in direction. A node that sticks, or whose
//! proposal reverses or stops within a step, is solved with a majorising quadratic instead: `f₀(√t)` is concave
//! in `t = s²`, so its tangent in `t` at `s_l`, `M(u) = μλ (f₀(s_l) + f₁(s_l)/(2 s_l) (|u|² − s_l²))`, lies above
//! `D` and touches it (value and gradient) at `|u| = s_l`; minimising the step's potential with `M` can only
//! lower the true potential (a majorise–minimise, or iteratively reweighted, iteration), so re-linearising
//! converges monotonically, without the stick–slip flip-flop of Newton's method on `D`. `M` is isotropic with
//! the Hessian `μλ f₁(s_l)/s_l P`. Both models are positive semi-definite and go into the step matrix as they
//! are. The first solve of a step linearises about the slip the node's motion predicts, which makes steady
//! sliding and sticking exact at once; a node whose model is off at the solution by more than
//! [`MODEL_TOLERANCE`] of `μλ` is re-linearised there and the step re-solved (a node switched to the majorant
//! stays with it for the step).
//!
//! The functions here are the law for one node; [`super::contact::PenaltyContact`] holds the lagged data.

use crate::math::{outer, Mat3, Vec3};

/// Largest error of a node's friction force model, relative to the largest Coulomb limit `μλ` of the step's
/// contacts, that a step's solve accepts without re-linearising and re-solving (docs/model.md §10.2; one friction
/// re-solve per Newton iteration).
pub const MODEL_TOLERANCE: f64 = 0.05;

/// How far friction's linear models are off at an iterate, each record's force error relative to the largest
/// Coulomb limit `μλ` of its term: the largest record's, and the sum of squares over the records with their count,
/// whose root mean square ([`Misfit::rms`]) measures the error of the friction field as a whole (docs/model.md
/// §8.5: the converge rule iterates on it, the violent rule's slip-reversal test on the largest).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Misfit {
    /// The largest record's relative error.
    pub largest: f64,
    /// The sum of the records' squared relative errors.
    pub squares: f64,
    /// The records.
    pub count: usize,
}

impl Misfit {
    /// Adds one record's relative error.
    pub fn add(&mut self, error: f64) {
        self.largest = self.largest.max(error);
        self.squares += error * error;
        self.count += 1;
    }

    /// Both misfits' records together.
    pub fn merge(self, other: Misfit) -> Misfit {
        let largest = self.largest.max(other.largest);
        Misfit { largest, squares: self.squares + other.squares, count: self.count + other.count }
    }

    /// The root mean square of the records' relative errors (0 without records).
    pub fn rms(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            (self.squares / self.count as f64).sqrt()
        }
    }
}

/// Friction model error (relative to the largest `μλ`) above which a step makes a Newton correction: a slip reversed or
/// stopped within the step that the re-solves did not settle.
pub const NEWTON_TOLERANCE: f64 = 1.0;

/// The smoothed friction of one node: value, gradient and Hessian of `μ λ f₀(|u|)` with respect to the
/// node's position, for the tangential displacement `u` (already projected with `p`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionLaw {
    /// `μ λ` (N).
    pub limit: f64,
    /// Smoothing length `ε` (m).
    pub eps: f64,
}

impl FrictionLaw {
    /// The friction potential `μ λ f₀(s)` (J).
    pub fn energy(&self, s: f64) -> f64 {
        let e = self.eps;
        let f0 = if s < e { -s * s * s / (3.0 * e * e) + s * s / e + e / 3.0 } else { s };
        self.limit * f0
    }

    /// The magnitude of the friction force `μ λ f₁(s)` (N).
    pub fn force(&self, s: f64) -> f64 {
        let e = self.eps;
        self.limit * if s < e { 2.0 * s / e - s * s / (e * e) } else { 1.0 }
    }

    /// Gradient `μ λ f₁(s)/s u` of the potential with respect to the node's position (`u = P (y − x_t)`).
    pub fn gradient(&self, u: Vec3) -> Vec3 {
        let s = u.length();
        let e = self.eps;
        let f1_over_s = if s < e { 2.0 / e - s / (e * e) } else { 1.0 / s };
        u * (self.limit * f1_over_s)
    }

    /// The majorising quadratic `M(u)` about the slip `s_l` at `u`: value, gradient, and its constant Hessian
    /// `μλ f₁(s_l)/s_l P` for the tangent projector `p`.
    pub fn majorant(&self, s_l: f64, u: Vec3, p: Mat3) -> (f64, Vec3, Mat3) {
        let e = self.eps;
        let w = self.limit * if s_l < e { 2.0 / e - s_l / (e * e) } else { 1.0 / s_l };
        let value = self.energy(s_l) + 0.5 * w * (u.length_squared() - s_l * s_l);
        (value, u * w, p * w)
    }

    /// Hessian with respect to the node's position for the tangent projector `p` (positive semi-definite).
    pub fn hessian(&self, u: Vec3, p: Mat3) -> Mat3 {
        let s = u.length();
        let e = self.eps;
        if s < e {
            let mut h = p * (2.0 / e - s / (e * e));
            if s > 0.0 {
                h -= outer(u, u) * (1.0 / (e * e * s));
            }
            h * self.limit
        } else {
            let d = u / s;
            (p - outer(d, d)) * (self.limit / s)
        }
    }
}

/// The lagged friction data of one node for one step: its contact's normal force and normal at the start, and
/// the linear model the last assembly solved with.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Lagged {
    /// Node index.
    pub node: usize,
    /// `μ λ` (N).
    pub limit: f64,
    /// Unit normal of the contact at the start of the step.
    pub normal: Vec3,
    /// The tangential displacement `u_l` the model is taken about.
    pub at: Vec3,
    /// The model is the majorant about `|u_l|` (else the tangent model about `u_l`).
    pub majorant: bool,
}

impl Lagged {
    /// The tangent projector `I − ννᵀ`.
    pub fn projector(&self) -> Mat3 {
        Mat3::IDENTITY - outer(self.normal, self.normal)
    }

    /// The tangential part `P d` of a displacement `d`.
    pub fn tangential(&self, d: Vec3) -> Vec3 {
        d - self.normal * self.normal.dot(d)
    }

    /// Linearises about `u`: the tangent model if the node slides there, else the majorant (kept once chosen
    /// unless `fresh`).
    pub fn linearize(&mut self, u: Vec3, eps: f64, fresh: bool) {
        let reverses = u.dot(self.at) <= 0.0;
        self.majorant = (self.majorant && !fresh) || u.length() < eps || (!fresh && reverses);
        self.at = u;
    }

    /// The model of a step's first solve, from the node's (or a face point's) motion: its displacement `last`
    /// over the step before and its velocities `v` at the start of the step and `v_prev` one step earlier.
    /// A node that stuck (moved less than `eps` in the last step) is linearised about that step's slip, from
    /// which the majorant's iteration approaches the creep from below (holding, never overshooting). One that
    /// slid is linearised about the slip its motion predicts, `(v + ½ a Δt) Δt` with `a Δt ≈ v − v⁻`: by the
    /// tangent model, which makes steady sliding exact at once, unless its slip reversed over the last step
    /// (`v · v⁻ < 0`, tangentially). Such a node is not sliding steadily, and the tangent model about the
    /// predicted slip would apply the Coulomb force along the node's motion wherever it reverses again: a
    /// friction force that drives the node, which the one re-linearisation of a solve undoes only in part, and
    /// which kept nodes of the 21² drop zig-zagging by ±10 μm a step for dozens of steps (a re-solve each) and
    /// made the drop's run a discontinuous function of its input (docs/performance.md, "Friction's predictor").
    /// It takes the majorant about the predicted slip instead, which resists a motion in any direction.
    pub fn predict(&mut self, last: Vec3, v: Vec3, v_prev: Vec3, dt: f64, eps: f64) {
        let last = self.tangential(last);
        if last.length() < eps {
            self.linearize(last, eps, true);
            return;
        }
        let (v, v_prev) = (self.tangential(v), self.tangential(v_prev));
        self.linearize((v * 1.5 - v_prev * 0.5) * dt, eps, true);
        self.majorant |= v.dot(v_prev) < 0.0;
    }

    /// Takes the law's own second-order model about `u`: its gradient there is the law's and its Hessian the
    /// law's exact, positive semi-definite one (a Newton iteration on the step's potential).
    pub fn exact(&mut self, u: Vec3) {
        self.majorant = false;
        self.at = u;
    }

    /// Value, gradient and Hessian of the current model at the tangential displacement `u`.
    pub fn model(&self, law: &FrictionLaw, u: Vec3) -> (f64, Vec3, Mat3) {
        let p = self.projector();
        if self.majorant {
            return law.majorant(self.at.length(), u, p);
        }
        let (g0, h0) = (law.gradient(self.at), law.hessian(self.at, p));
        let d = u - self.at;
        (law.energy(self.at.length()) + g0.dot(d) + 0.5 * d.dot(h0 * d), g0 + h0 * d, h0)
    }

    /// The model's force error at `u` (N).
    pub fn model_error(&self, law: &FrictionLaw, u: Vec3) -> f64 {
        (law.gradient(u) - self.model(law, u).1).length()
    }
}
