//! The changing part of a simulation: positions at the current and previous step (the central-difference
//! scheme's two levels), time and step count.

use crate::math::Vec3;

/// Positions `x_t`, `x_{t−Δt}`, time and step. Serialisable as a whole, so a checkpoint
/// ([`crate::runner::checkpoint`]) holds every field, including those added later.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct State {
    /// Current positions.
    pub x: Vec<Vec3>,
    /// Positions one step earlier.
    pub x_prev: Vec<Vec3>,
    /// Simulated time (s).
    pub time: f64,
    /// Steps taken.
    pub step: usize,
}

impl State {
    /// At rest at `x`.
    pub fn at_rest(x: Vec<Vec3>) -> Self {
        Self { x_prev: x.clone(), x, time: 0.0, step: 0 }
    }

    /// Central-difference velocity estimate `(x_t − x_{t−Δt})/Δt` of node `k`.
    pub fn velocity(&self, k: usize, dt: f64) -> Vec3 {
        (self.x[k] - self.x_prev[k]) / dt
    }

    /// Kinetic energy `½ Σ m |v|²` with the backward-difference velocity.
    pub fn kinetic_energy(&self, mass: &[f64], dt: f64) -> f64 {
        (0..self.x.len()).map(|k| 0.5 * mass[k] * self.velocity(k, dt).length_squared()).sum()
    }
}
