//! The integration tests of the `flexsurf` library, as one test binary (one link instead of one per file).
//!
//! A new test file is one `mod` line here. Run one module with its path as the filter, e.g.
//! `cargo test --profile ci -p flexsurf --test suite derivatives::` (docs/testing.md).
#![warn(clippy::too_many_lines)]

mod body_contact;
mod common;
mod contact_records;
mod continuity;
mod converged_step;
mod curved_multigrid;
mod cusick_convergence;
mod derivatives;
mod dynamics;
mod fit;
mod fuzz;
mod garments;
mod hardening;
mod hysteresis;
mod lab;
mod model;
mod nonlinear;
mod nurbs;
mod outputs;
mod panels;
mod resume;
mod scenarios;
mod scenes;
mod seams;
mod self_contact;
mod skirt;
mod solvers;
mod sparsity;
mod statics;
mod threads;
mod trust;
mod tshirt;
mod two_sheets;
mod unit_contact;
mod unit_core;
mod unit_integrate;
mod unit_io;
mod unit_lab;
mod unit_render;
mod unit_runner;
mod unit_scene;
mod unit_surface;

/// A fresh empty directory for one unit test (`unit_*` modules), named after `tag`.
fn scratch_dir(tag: &str) -> flexsurf::testing::ScratchDir {
    flexsurf::testing::scratch("unit", tag)
}
