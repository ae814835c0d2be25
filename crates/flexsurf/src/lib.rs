//! # flexsurf
//!
//! A simulator of thin flexible surfaces (cloth, paper, non-wovens) implementing the variational deformation
//! model of Wang, Wu, Sun and Yuen, "A deformation model of thin flexible surfaces", in the corrected form of
//! `docs/model.md`.
//!
//! The modules follow the model's pipeline: [`grid`] (the `M × N` parametric grid) → [`ops`] (difference
//! operators of the quadratic patch, fundamental forms) → [`material`] (measured fabric constants and their
//! calibration) → [`energy`] (membrane and bending energy of scheme S with exact gradient and Hessian, and the
//! Terzopoulos force) → [`contact`] (obstacles, penalty contact) → [`integrate`] (the linearised implicit step and
//! the paper's lagged step, sparse solvers) → [`surface`] (the Coons display surface, the xy footprint) →
//! [`garment`] (garment patterns fitted onto a body) → [`scene`] (TOML scenes, checked and built into a model)
//! → [`runner`] (a built scene run into frames, `energy.csv`, `summary.json` and pictures) → [`io`] (meshes,
//! pictures). [`model::Model`] holds what is fixed during a run, [`state::State`] what changes, and [`sim`]
//! drives the time loop.
#![warn(missing_docs)]
// Index loops over small fixed-size stencil arrays mirror the formulas (Σ_ab Q_ab …) they implement.
#![allow(clippy::needless_range_loop)]

pub mod bench;
pub mod contact;
pub mod energy;
pub mod garment;
pub mod grid;
pub mod integrate;
pub mod io;
pub mod lab;
pub mod material;
pub mod math;
pub mod model;
pub mod ops;
pub mod potential;
pub mod runner;
pub mod scene;
pub mod sim;
pub mod sparse;
pub mod state;
pub mod surface;
#[cfg(feature = "testing")]
pub mod testing;
