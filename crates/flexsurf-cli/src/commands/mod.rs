//! The subcommands of `flexsurf`, one module each: thin wrappers over `flexsurf::scene`, `flexsurf::bench` and
//! `flexsurf::lab` that hold the command's clap arguments, add file context and progress, and print its tables.
//! `main.rs` parses the command line and calls the chosen module's `execute`; what several commands share (the
//! run table, a progress-bar run, JSON printing) is in [`shared`].

pub mod bench;
pub mod check;
pub mod demo;
pub mod fit;
pub mod run;
pub mod schema;
mod shared;
pub mod test;
pub mod view;
