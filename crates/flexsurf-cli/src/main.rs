//! `flexsurf`: the command-line front end. Runs TOML scenes (`run`), the paper's demos (the ball drop and the
//! skirt on the mannequin) with both models (`demo`), validates scenes (`check`), prints the scene format's
//! JSON schema (`schema`), times the solver (`bench`) and runs the virtual textile tests (`test`). This file holds
//! the top level of the command line and the dispatch; each command's arguments and implementation are in
//! `commands/`.

// No function over 80 lines (the threshold is `clippy.toml`'s).
#![warn(clippy::too_many_lines)]

// Output that ends quietly on a closed pipe (issue 11): these shadow the standard macros for every module
// declared below them (macro_rules scoping), so the commands keep writing `println!`.
macro_rules! println {
    () => { $crate::stdout::line(format_args!("")) };
    ($($arg:tt)*) => { $crate::stdout::line(format_args!($($arg)*)) };
}

macro_rules! eprintln {
    () => { $crate::stdout::error_line(format_args!("")) };
    ($($arg:tt)*) => { $crate::stdout::error_line(format_args!($($arg)*)) };
}

mod commands;
mod progress;
mod signals;
mod stdout;

use clap::{Parser, Subcommand};
use commands::{bench, check, demo, fit, run, schema, test, view};
use std::process::ExitCode;

/// Simulator of thin flexible surfaces (the variational model of Wang, Wu, Sun & Yuen).
#[derive(Debug, Parser)]
#[command(name = "flexsurf", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene file and write frames, energy.csv, summary.json and snapshots.png into --out.
    Run(run::RunArgs),
    /// Run a demo scene (the ball drop or the skirt) with both models and write a side-by-side comparison
    /// (the paper's Fig. 1 vs Fig. 2, or its Fig. 3).
    Demo(demo::DemoArgs),
    /// Validate a scene file without running it.
    Check(check::CheckArgs),
    /// Print the JSON schema of the scene format (with --pattern: of the pattern format, docs/garments.md).
    Schema(schema::SchemaArgs),
    /// Time the ball drop at several grid sizes, with the per-step breakdown (assembly, contact,
    /// factorisation, solve).
    Bench(bench::BenchArgs),
    /// Virtual textile tests on a fabric. `kes`: tension (warp, weft, 45° bias), simple shear and pure bending
    /// (warp, weft) on small specimens, solved to equilibrium; prints the recovered constants and their errors.
    /// `cantilever`: the Peirce / ASTM D1388 strip hanging off a ledge; chord angle, tip drop, bending length.
    /// `cusick`: the drape meter (18 cm disc); drape coefficient, nodes, a top-view picture and the mesh.
    #[command(subcommand)]
    Test(test::TestCommand),
    /// Fit material constants to measured targets (Peirce bending lengths, KES-F values, Cusick DC, a scanned
    /// drape) with adjoint gradients: the fitted constants, their standard errors and which the targets do not
    /// determine (docs/materials.md, "Fitting").
    Fit(fit::FitArgs),
    /// Write OUT_DIR/view.html: an interactive viewer of a run folder (orbit, play/scrub over the frames,
    /// obstacles, colour by strain, contact pressure, height or warp/weft lines), self-contained for offline use.
    View(view::ViewArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Run(args) => run::execute(args),
        Command::Demo(args) => demo::execute(args),
        Command::Check(args) => check::execute(args),
        Command::Schema(args) => schema::execute(args),
        Command::Bench(args) => bench::execute(args),
        Command::Test(which) => test::execute(which),
        Command::Fit(args) => fit::execute(args),
        Command::View(args) => view::execute(args),
    };
    match result {
        // A run stopped by SIGINT or SIGTERM: its checkpoint and summary are written; exit as the shell would
        // for the signal (130, 143).
        Ok(()) => match signals::received() {
            Some(code) => ExitCode::from(code),
            None => ExitCode::SUCCESS,
        },
        Err(e) => {
            eprintln!("error: {}", report(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes joined by ": ", as `{:#}` writes them, leaving out a cause whose text the message
/// before it already ends with (an error that writes its cause into its own message and also returns it as
/// its source, as `#[from]` variants do, would otherwise be read twice).
fn report(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !out.is_empty() && out.ends_with(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::report;
    use flexsurf::integrate::linsolve::LinearError;
    use flexsurf::integrate::statics::StaticError;

    #[test]
    fn a_cause_already_in_the_message_is_written_once() {
        let e = anyhow::Error::new(StaticError::from(LinearError::Symbolic("out of memory".into())))
            .context("KES curves of m");
        assert_eq!(report(&e), "KES curves of m: static solve: symbolic factorisation failed: out of memory");
        let plain = anyhow::anyhow!("inner").context("outer");
        assert_eq!(report(&plain), "outer: inner");
    }
}
