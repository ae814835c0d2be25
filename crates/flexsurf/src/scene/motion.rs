//! `[[pin]] motion`: pinned nodes carried along a prescribed rigid motion (a turn about an axis and a shift),
//! the way a gripper or a tester's clamp moves a fabric's edge (`scenes/twist.toml` turns one end of a strip by
//! two turns).
//!
//! The motion's progress `s(t)` runs from 0 to 1 over `seconds` along the smooth step `3τ² − 2τ³`
//! (`τ = t/seconds`), so the clamp starts and stops with zero velocity and no impulse; after `seconds` it
//! holds. At time `t` a node that started at `p₀` is at `c + s·shift + R(s·2π·turns) (p₀ − c)`, `R` the
//! rotation about the unit axis through the centre `c` (default: the set's centroid at the start). Before
//! each step the runner moves the set to its position at the step's end ([`crate::model::Model::move_pin`]).

use crate::math::Vec3;
use crate::model::{Model, ModelError};
use crate::state::State;

/// A set of pinned nodes and the rigid motion that carries them.
#[derive(Debug, Clone, PartialEq)]
pub struct PinMotion {
    /// The nodes (model indices).
    pub nodes: Vec<usize>,
    /// Their positions at the start.
    pub start: Vec<Vec3>,
    /// The rotation's centre (m).
    pub center: Vec3,
    /// The rotation's unit axis.
    pub axis: Vec3,
    /// The whole turn (rad).
    pub angle: f64,
    /// The whole shift (m).
    pub shift: Vec3,
    /// The motion's duration (s).
    pub seconds: f64,
}

/// A checked `[[pin]] motion`, before the set's start positions are known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionParams {
    /// Turns about the axis.
    pub turns: f64,
    /// The axis (non-zero).
    pub axis: Vec3,
    /// The centre, if given.
    pub center: Option<Vec3>,
    /// The whole shift (m).
    pub shift: Vec3,
    /// Duration (s).
    pub seconds: f64,
}

impl PinMotion {
    /// The motion `p` of `nodes` from their positions in `x` (the centre, unless given, their centroid).
    pub fn new(nodes: Vec<usize>, x: &[Vec3], p: &MotionParams) -> Self {
        let start: Vec<Vec3> = nodes.iter().map(|&k| x[k]).collect();
        let centroid = start.iter().copied().sum::<Vec3>() / start.len().max(1) as f64;
        Self {
            nodes,
            start,
            center: p.center.unwrap_or(centroid),
            axis: p.axis.normalize_or(Vec3::Z),
            angle: p.turns * std::f64::consts::TAU,
            shift: p.shift,
            seconds: p.seconds,
        }
    }

    /// The fraction of the motion done at time `t` (s): the smooth step, 0 before the start, 1 after `seconds`.
    pub fn progress(&self, t: f64) -> f64 {
        let tau = (t / self.seconds).clamp(0.0, 1.0);
        tau * tau * (3.0 - 2.0 * tau)
    }

    /// Where the set's `i`-th node is at time `t`.
    pub fn position(&self, i: usize, t: f64) -> Vec3 {
        let s = self.progress(t);
        let r = crate::math::Mat3::from_axis_angle(self.axis, s * self.angle);
        self.center + self.shift * s + r * (self.start[i] - self.center)
    }

    /// Moves the set in `state` to its position at time `t` (the end of the coming step).
    pub fn apply(&self, model: &Model, state: &mut State, t: f64) -> Result<(), ModelError> {
        for (i, &k) in self.nodes.iter().enumerate() {
            model.move_pin(state, k, self.position(i, t))?;
        }
        Ok(())
    }
}

/// Moves every set of `motions` in `state` to its position at the end of the step of `dt` that starts at
/// `state.time`.
pub fn drive(motions: &[PinMotion], model: &Model, state: &mut State, dt: f64) -> Result<(), ModelError> {
    let t = state.time + dt;
    motions.iter().try_for_each(|m| m.apply(model, state, t))
}
