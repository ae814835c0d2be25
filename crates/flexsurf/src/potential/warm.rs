//! The part of a [`Workspace`] that carries over from one step to the next and changes later results: each
//! term's [`Scratch`] (the contact term's warm-started closest-point cache — the NURBS projection restarts from
//! the last (patch, u, v), so a cold cache converges to a point a few ulps away — and its active set). A
//! checkpoint saves it as a [`WarmState`] and a resumed run restores it, so the resumed steps are bit for bit
//! those of an uninterrupted run. Everything else in the workspace (gradient, matrix, journal) is overwritten by
//! every assembly before it is read, and the linear solvers refactorise at the first solve of every step.
//!
//! Each term encodes and decodes its own scratch ([`super::Term::save`], [`super::Term::restore`]); a term
//! that keeps a scratch it cannot save is an error at the checkpoint (not a silent cold start on resume).

use super::{Potential, Scratch, Workspace};
use serde::{Deserialize, Serialize};

/// The saved scratch of every term of a workspace, by term name, in evaluation order (the integrator's own
/// term, inertia, keeps none).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WarmState {
    terms: Vec<(String, Option<Vec<u8>>)>,
}

impl WarmState {
    /// The warm state of a workspace without terms (for tests of the checkpoint format).
    #[cfg(feature = "testing")]
    #[doc(hidden)]
    pub fn empty() -> Self {
        Self { terms: Vec::new() }
    }
}

impl Potential {
    /// The warm state of every term in `ws`, for a checkpoint.
    pub fn warm_state(&self, ws: &Workspace) -> Result<WarmState, String> {
        if ws.extra.0.is_some() {
            return Err("the integrator's own term keeps a state the checkpoint does not know".into());
        }
        let terms = self
            .terms
            .iter()
            .zip(&ws.scratch)
            .map(|(term, scratch)| Ok((term.info().name.to_string(), term.save(scratch)?)))
            .collect::<Result<_, String>>()?;
        Ok(WarmState { terms })
    }

    /// Restores a [`Potential::warm_state`] of the same potential into `ws`.
    pub fn restore_warm_state(&self, warm: &WarmState, ws: &mut Workspace) -> Result<(), String> {
        if warm.terms.len() != self.terms.len() {
            return Err(format!(
                "the checkpoint has the warm state of {} terms, the model has {}",
                warm.terms.len(),
                self.terms.len()
            ));
        }
        for ((term, scratch), (name, saved)) in self.terms.iter().zip(ws.scratch.iter_mut()).zip(&warm.terms) {
            if term.info().name != name {
                return Err(format!(
                    "the checkpoint has the state of a term `{name}` where the model has `{}`",
                    term.info().name
                ));
            }
            term.restore(saved.as_deref(), scratch)?;
        }
        ws.extra.clear();
        Ok(())
    }
}

impl Scratch {
    /// The scratch as a `T`, if it holds one.
    pub fn get<T: std::any::Any>(&self) -> Option<&T> {
        self.0.as_ref().and_then(|b| b.downcast_ref::<T>())
    }

    /// The scratch as a `T`, mutable, if it is one.
    pub fn get_mut<T: std::any::Any>(&mut self) -> Option<&mut T> {
        self.0.as_mut().and_then(|b| b.downcast_mut::<T>())
    }

    /// Holds `value` from now on.
    pub fn set<T: std::any::Any + Send>(&mut self, value: T) {
        self.0 = Some(Box::new(value));
    }
}
