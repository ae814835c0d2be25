//! The integration tests of the `flexsurf` command, as one test binary (one link instead of one per file).
//!
//! A new test file is one `mod` line here. Run one module with its path as the filter, e.g.
//! `cargo test --profile ci -p flexsurf-cli --test suite hardening::` (docs/testing.md).
#![warn(clippy::too_many_lines)]

mod cli;
mod hardening;
mod trust;
