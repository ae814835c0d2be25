//! The part of a [`Workspace`] that carries over from one step to the next and changes later results: each
//! term's [`Scratch`] (the contact term's warm-started closest-point cache — the NURBS projection restarts from
//! the last (patch, u, v), so a cold cache converges to a point a few ulps away — and its active set). A
//! checkpoint saves it as a [`WarmState`] and a resumed run restores it, so the resumed steps are bit for bit
//! those of an uninterrupted run. Everything else in the workspace (gradient, matrix, journal) is overwritten by
//! every assembly before it is read, and the linear solvers refactorise at the first solve of every step.
//!
//! A scratch of a kind this file does not know is an error (not a silent cold start): a new term with a
//! scratch of its own adds its type to [`save`] and [`load`].

use super::contact::ContactScratch;
use super::{Scratch, Workspace};
use serde::{Deserialize, Serialize};

/// The saved scratch of every term of a workspace (and of the extra term: inertia).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WarmState {
    terms: Vec<Saved>,
    extra: Saved,
}

/// One term's saved scratch: none, or its kind and its bytes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
enum Saved {
    Empty,
    Contact(Vec<u8>),
}

fn save(scratch: &Scratch) -> Result<Saved, String> {
    let Some(b) = scratch.0.as_ref() else { return Ok(Saved::Empty) };
    if let Some(c) = b.downcast_ref::<ContactScratch>() {
        return postcard::to_stdvec(c).map(Saved::Contact).map_err(|e| format!("cannot encode the contact state: {e}"));
    }
    Err("a term keeps a warm state of a kind the checkpoint does not know".into())
}

fn load(saved: &Saved, scratch: &mut Scratch) -> Result<(), String> {
    match saved {
        Saved::Empty => scratch.clear(),
        Saved::Contact(bytes) => {
            let c: ContactScratch =
                postcard::from_bytes(bytes).map_err(|e| format!("cannot decode the contact state: {e}"))?;
            scratch.0 = Some(Box::new(c));
        }
    }
    Ok(())
}

impl WarmState {
    /// Checks the saved state against a model of `obstacles` obstacles and `nodes` nodes (a checkpoint's,
    /// before it is used: a forged one must not index past a vector).
    pub fn check(&self, obstacles: usize, nodes: usize) -> Result<(), String> {
        for saved in self.terms.iter().chain([&self.extra]) {
            if let Saved::Contact(bytes) = saved {
                let c: ContactScratch =
                    postcard::from_bytes(bytes).map_err(|e| format!("cannot decode the contact state: {e}"))?;
                if !c.fits(obstacles, nodes) {
                    return Err(format!(
                        "its contact state does not fit the model ({obstacles} obstacles, {nodes} nodes)"
                    ));
                }
            }
        }
        Ok(())
    }

    /// The warm state of a workspace without terms (for tests of the checkpoint format).
    #[cfg(test)]
    pub(crate) fn empty() -> Self {
        Self { terms: Vec::new(), extra: Saved::Empty }
    }
}

impl Workspace {
    /// The warm state of every term, for a checkpoint.
    pub fn warm_state(&self) -> Result<WarmState, String> {
        Ok(WarmState { terms: self.scratch.iter().map(save).collect::<Result<_, _>>()?, extra: save(&self.extra)? })
    }

    /// Restores a [`Workspace::warm_state`] of a workspace of the same potential.
    pub fn restore_warm_state(&mut self, warm: &WarmState) -> Result<(), String> {
        if warm.terms.len() != self.scratch.len() {
            return Err(format!(
                "the checkpoint has the warm state of {} terms, the model has {}",
                warm.terms.len(),
                self.scratch.len()
            ));
        }
        for (saved, scratch) in warm.terms.iter().zip(self.scratch.iter_mut()) {
            load(saved, scratch)?;
        }
        load(&warm.extra, &mut self.extra)
    }
}
