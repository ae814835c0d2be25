//! Virtual textile tests: the simulator run as a measuring instrument on small specimens, so that a fabric's
//! measured constants can be checked to come back out of the model ([`kes`]).

pub mod cantilever;
pub mod cusick;
pub mod fit;
pub mod kes;
mod kes_curves;

mod dense;

use crate::integrate::statics::StaticError;
use crate::material::MaterialError;
use thiserror::Error;

/// Why a virtual test could not run.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum LabError {
    /// The material is unusable.
    #[error(transparent)]
    Material(#[from] MaterialError),
    /// The equilibrium solve failed.
    #[error("{test}: {cause}")]
    Solve {
        /// Which test.
        test: &'static str,
        /// Why.
        cause: StaticError,
    },
    /// A test option is out of range.
    #[error("{0}")]
    Input(String),
    /// The test's model cannot be built.
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    /// A dynamic relaxation step failed.
    #[error("{test}: {cause}")]
    Step {
        /// Which test.
        test: &'static str,
        /// Why.
        cause: crate::integrate::StepError,
    },
    /// A fit's evaluation of its targets failed at the free constants it names.
    #[error("at {at}: {cause}")]
    FitAt {
        /// The free constants, `key = value unit` (SI), comma-separated.
        at: String,
        /// Why.
        cause: Box<LabError>,
    },
}
