//! The run loop: steps a [`Model`] from a [`State`] with a [`Stepper`], calling back after every step so the
//! caller can record frames, energies and progress. Stops at the first error with the step number.

use crate::integrate::{max_penetration, StepError, StepInfo, Stepper};
use crate::model::{Energies, Model};
use crate::state::State;
use serde::Serialize;
use std::ops::ControlFlow;
use std::time::Instant;

/// Everything a caller may want to know about the configuration after a step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Diagnostics {
    /// Step number.
    pub step: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Kinetic energy (J) of the state's velocities.
    pub kinetic: f64,
    /// Elastic energies (J).
    pub energies: Energies,
    /// Gravitational potential energy (J).
    pub potential: f64,
    /// Active contacts.
    pub contacts: usize,
    /// Deepest penetration (m).
    pub max_penetration: f64,
    /// Largest engineering edge strain.
    pub max_strain: f64,
}

/// The energies of a state, the per-step record of a run (`energy.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EnergyRecord {
    /// Step number.
    pub step: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Kinetic energy (J) of the state's velocities.
    pub kinetic: f64,
    /// Elastic energies (J).
    pub energies: Energies,
    /// Gravitational potential energy (J).
    pub potential: f64,
}

/// Energies of a state (evaluates the elastic energy once; no obstacle queries).
pub fn energies(model: &Model, state: &State) -> EnergyRecord {
    EnergyRecord {
        step: state.step,
        time: state.time,
        kinetic: state.kinetic_energy(&model.mass),
        energies: model.elastic(&state.x, None),
        potential: model.potential_energy(&state.x),
    }
}

/// Diagnostics of a state: its [`energies`] plus penetration and strain.
pub fn diagnose(model: &Model, state: &State, contacts: usize) -> Diagnostics {
    let e = energies(model, state);
    Diagnostics {
        step: e.step,
        time: e.time,
        kinetic: e.kinetic,
        energies: e.energies,
        potential: e.potential,
        contacts,
        max_penetration: max_penetration(model, &state.x),
        max_strain: model.max_strain(&state.x),
    }
}

/// Wall time of a run's stepping.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RunStats {
    /// Steps taken.
    pub steps: usize,
    /// Seconds spent stepping (callbacks excluded).
    pub wall_seconds: f64,
    /// Largest penetration seen after any step (m).
    pub max_penetration_seen: f64,
    /// Largest contact count seen.
    pub max_contacts: usize,
}

/// Takes `steps` steps of the stepper's `dt`, calling `after(state, info)` after each; the callback may stop the run early.
pub fn run(
    model: &Model,
    state: &mut State,
    stepper: &mut Stepper,
    steps: usize,
    mut after: impl FnMut(&State, &StepInfo) -> ControlFlow<()>,
) -> Result<RunStats, StepError> {
    let mut stats = RunStats { steps: 0, wall_seconds: 0.0, max_penetration_seen: 0.0, max_contacts: 0 };
    for _ in 0..steps {
        let t0 = Instant::now();
        let info = stepper.step(model, state)?;
        stats.wall_seconds += t0.elapsed().as_secs_f64();
        stats.steps += 1;
        stats.max_penetration_seen = stats.max_penetration_seen.max(info.max_penetration);
        stats.max_contacts = stats.max_contacts.max(info.contacts);
        if after(state, &info).is_break() {
            break;
        }
    }
    Ok(stats)
}
