//! # flexsurf
//!
//! A simulator of thin flexible surfaces (cloth, paper, non-wovens) implementing the variational deformation
//! model of Wang, Wu, Sun and Yuen, "A deformation model of thin flexible surfaces", in the corrected form
//! documented in the repository's `docs/model.md`.
//!
//! The modules follow the model's pipeline: [`grid`] (the `M × N` parametric grid) → [`ops`] (difference
//! operators of the quadratic patch, fundamental forms) → [`material`] (measured fabric constants and their
//! calibration) → [`energy`] (the membrane and bending kernels of scheme S, and the Terzopoulos force) →
//! [`contact`] (obstacle geometry) → [`potential`] (the total potential: every energy and force a term with
//! value, gradient and Hessian, in one list, with one assembly) → [`model::Model`] (what is fixed during a run,
//! built through [`model::ModelBuilder`]) → [`integrate`] (the linearised implicit step and the paper's lagged
//! step, the static solver, sparse solvers; [`integrate::StepParams`] and [`integrate::Method`]) → [`sim`] (the
//! time loop) → [`surface`] (the Coons display surface, the xy footprint) → [`garment`] (garment patterns fitted
//! onto a body) → [`scene`] (TOML scenes, checked and built into a model) → [`runner`] (a built scene run into
//! frames, `energy.csv`, `summary.json` and pictures) → [`io`] (meshes, pictures). [`lab`] holds the virtual
//! textile tests (KES-F, cantilever, Cusick drape). `docs/design.md` says where a new term, obstacle, output
//! format or solver goes.
//!
//! **Core and application.** The physics core (grid, ops, material, energy, contact geometry, potential,
//! model, integrate, surface, garment fitting, the range table) builds on its own with
//! `default-features = false`: it depends on no image, plotting, VTK, glTF or TOML crate. The default feature
//! `app` adds the application on top: [`scene`], [`runner`], [`io`], [`lab`] and [`bench`]. [`prelude`] holds the
//! types most programs use.
//!
//! ## A sheet dropped on a ball, from the library
//!
//! ```
//! use flexsurf::contact::Obstacle;
//! use flexsurf::grid::Grid;
//! use flexsurf::integrate::{StepParams, Stepper};
//! use flexsurf::material::{Calibration, Fabric, Stiffness};
//! use flexsurf::math::Vec3;
//! use flexsurf::model::{ModelBuilder, ModelKind};
//! use flexsurf::potential::contact::ContactParams;
//! use flexsurf::state::State;
//!
//! // The paper's non-woven cotton, 1 m square on a 11 × 11 grid, 35 cm above a 30 cm ball.
//! let fabric = Fabric::paper_cotton();
//! let stiffness = Stiffness::calibrate(&fabric, Calibration::Kes)?;
//! let grid = Grid::sheet(11, 11, 1.0, 1.0)?;
//! let rest = grid.flat_positions(0.0);
//! let gravity = Vec3::new(0.0, 0.0, -9.81);
//! let mut sheet = ModelBuilder::new(grid, rest.clone(), fabric, stiffness, ModelKind::Tfs, gravity);
//! sheet.obstacles.push(Obstacle::Sphere { center: Vec3::ZERO, radius: 0.3 });
//! sheet.contact = ContactParams { stiffness: 1e4, offset: 0.005, friction: 0.3, ..ContactParams::default() };
//! let model = sheet.build()?;
//!
//! let mut state = State::at_rest(rest.iter().map(|p| *p + Vec3::new(0.0, 0.0, 0.35)).collect());
//! let mut stepper = Stepper::new(&model, &StepParams::with_dt(0.01))?;
//! for _ in 0..150 {
//!     stepper.step(&model, &mut state)?;
//! }
//! // The centre rests on top of the ball (radius + contact layer); the corners hang below its equator.
//! let centre = state.x[grid.index(5, 5)];
//! assert!((centre.z - 0.3).abs() < 0.01, "centre at {centre}");
//! assert!(state.x[grid.index(0, 0)].z < 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]
// No function over 80 lines (the threshold is `clippy.toml`'s).
#![warn(clippy::too_many_lines)]
// Index loops over small fixed-size stencil arrays mirror the formulas (Σ_ab Q_ab …) they implement.
#![allow(clippy::needless_range_loop)]

#[cfg(feature = "app")]
pub mod bench;
pub mod contact;
pub mod energy;
pub mod garment;
pub mod grid;
pub mod integrate;
#[cfg(feature = "app")]
pub mod io;
#[cfg(feature = "app")]
pub mod lab;
pub mod material;
pub mod math;
pub mod model;
pub mod ops;
pub mod potential;
pub mod ranges;
#[cfg(feature = "app")]
pub mod runner;
#[cfg(feature = "app")]
pub mod scene;
pub mod seam;
pub mod sim;
pub mod sparse;
pub mod state;
pub mod surface;
#[cfg(feature = "testing")]
pub mod testing;

/// The types most programs use, in one import: `use flexsurf::prelude::*;`.
pub mod prelude {
    pub use crate::contact::Obstacle;
    pub use crate::grid::{Grid, Topology};
    pub use crate::integrate::linsolve::SolverKind;
    pub use crate::integrate::statics::{StaticOptions, StaticSolver};
    pub use crate::integrate::{Method, Scheme, StepParams, Stepper};
    pub use crate::material::{Calibration, Fabric, Stiffness};
    pub use crate::math::{Mat3, Vec3};
    pub use crate::model::{ElasticOptions, Model, ModelBuilder, ModelKind, Panel, PanelSpec, Spring};
    pub use crate::potential::contact::ContactParams;
    pub use crate::potential::{ActiveSet, Context, Part, Potential, Scratch, Stage, Term, TermInfo};
    pub use crate::state::State;
}
