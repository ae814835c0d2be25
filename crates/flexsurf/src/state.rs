//! The changing part of a simulation: positions and velocities at the current and the previous step (the two
//! levels the schemes need: central differences read `x_t, x_{t−Δt}`, BDF2 also `v_t, v_{t−Δt}`), time and step
//! count. A run starts from a consistent history ([`State::start`]), so the first step makes no O(Δt) error.

use crate::math::Vec3;

/// Positions and velocities at `t` and `t − Δt`, time and step. Serialisable as a whole, so a checkpoint
/// ([`crate::runner::checkpoint`]) holds every field, including those added later.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct State {
    /// Current positions.
    pub x: Vec<Vec3>,
    /// Positions one step earlier (at the start: the consistent history of [`State::start`]).
    pub x_prev: Vec<Vec3>,
    /// Current velocities (the scheme's own estimate, second order: `(3x_t − 4x_{t−Δt} + x_{t−2Δt})/(2Δt)` for
    /// the central-difference schemes, the BDF2 velocity for BDF2).
    pub v: Vec<Vec3>,
    /// Velocities one step earlier.
    pub v_prev: Vec<Vec3>,
    /// Simulated time (s).
    pub time: f64,
    /// Steps taken.
    pub step: usize,
}

impl State {
    /// At rest at `x`, with a history at rest too (no force balance: see [`State::start`] for a consistent one).
    pub fn at_rest(x: Vec<Vec3>) -> Self {
        let n = x.len();
        Self { x_prev: x.clone(), x, v: vec![Vec3::ZERO; n], v_prev: vec![Vec3::ZERO; n], time: 0.0, step: 0 }
    }

    /// At `x` with velocities `v` and accelerations `a` at t = 0, and the step `dt`: the history one step back
    /// is the second-order Taylor expansion `x − Δt v + ½Δt² a`, `v − Δt a`, with which the central-difference
    /// schemes are exact for constant accelerations (free fall) and second-order consistent otherwise, and
    /// BDF2 starts at its own order (docs/model.md §8).
    pub fn start(x: Vec<Vec3>, v: Vec<Vec3>, a: &[Vec3], dt: f64) -> Self {
        let x_prev = x.iter().zip(&v).zip(a).map(|((&x, &v), &a)| x - v * dt + a * (0.5 * dt * dt)).collect();
        let v_prev = v.iter().zip(a).map(|(&v, &a)| v - a * dt).collect();
        Self { x, x_prev, v, v_prev, time: 0.0, step: 0 }
    }

    /// Velocity of node `k`.
    pub fn velocity(&self, k: usize) -> Vec3 {
        self.v[k]
    }

    /// Kinetic energy `½ Σ m |v|²`.
    pub fn kinetic_energy(&self, mass: &[f64]) -> f64 {
        self.v.iter().zip(mass).map(|(v, &m)| 0.5 * m * v.length_squared()).sum()
    }
}
