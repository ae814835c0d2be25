//! Checkpoint support of the [`Stepper`]: what it carries from one step to the next besides the [`State`]
//! (the potential workspace's warm state, [`WarmState`], and the per-stage counters), saved by
//! [`Stepper::warm_state`] and put back by [`Stepper::restore`] into a fresh stepper of the same model, so a
//! resumed run takes exactly the steps of an uninterrupted one.
//!
//! [`State`]: crate::state::State

use super::{Counters, Stepper};
use crate::potential::WarmState;

impl Stepper {
    /// The warm state of the stepper's workspace.
    pub fn warm_state(&self) -> Result<WarmState, String> {
        self.ws.warm_state()
    }

    /// Restores a [`Stepper::warm_state`] and the counters of the stepper that saved it.
    pub fn restore(&mut self, warm: &WarmState, counters: Counters) -> Result<(), String> {
        self.ws.restore_warm_state(warm)?;
        self.counters = counters;
        Ok(())
    }
}
