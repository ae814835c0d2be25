//! Checkpoint support of the [`Stepper`]: what it carries from one step to the next besides the [`State`]
//! (the potential workspace's warm state, [`WarmState`], and the per-stage counters), saved by
//! [`Stepper::warm_state`] and put back by [`Stepper::restore`] into a fresh stepper of the same model, so a
//! resumed run takes exactly the steps of an uninterrupted one.
//!
//! [`State`]: crate::state::State

use super::linsolve::SolverWarm;
use super::{Counters, Stepper};
use crate::model::Model;
use crate::potential::WarmState;

impl Stepper {
    /// The warm state of the stepper's workspace for `model` (the model it steps).
    pub fn warm_state(&self, model: &Model) -> Result<WarmState, String> {
        model.potential.warm_state(&self.ws)
    }

    /// Restores a [`Stepper::warm_state`] of `model` and the counters of the stepper that saved it.
    pub fn restore(&mut self, model: &Model, warm: &WarmState, counters: Counters) -> Result<(), String> {
        model.potential.restore_warm_state(warm, &mut self.ws)?;
        self.counters = counters;
        Ok(())
    }

    /// What the linear solver carries between steps (the iterative solvers' starting guess, the automatic
    /// choice's picks), so a resumed run makes the same solves.
    pub fn solver_warm(&self) -> SolverWarm {
        SolverWarm { guess: self.guess.clone(), picks: self.solver.picks(), extra: self.ws.matrix.extra.saved() }
    }

    /// Restores a [`Stepper::solver_warm`].
    pub fn restore_solver(&mut self, warm: &SolverWarm) -> Result<(), String> {
        if warm.guess.len() != self.guess.len() {
            return Err(format!(
                "the saved solver guess has {} nodes, the model {}",
                warm.guess.len(),
                self.guess.len()
            ));
        }
        self.ws.matrix.extra = crate::sparse::ExtraBlocks::from_saved(&warm.extra, self.guess.len())?;
        self.guess.copy_from_slice(&warm.guess);
        self.solver.set_picks(warm.picks);
        Ok(())
    }
}
