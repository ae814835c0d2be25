//! Helpers shared by several commands: running a built scene under a progress bar, the table that tells runs
//! apart (`run`, `demo`) and printing one pretty JSON object (`schema`, `bench`, the virtual tests).

use crate::progress;
use anyhow::{Context, Result};
use flexsurf::runner::{self, RunOptions, RunOutput};
use flexsurf::scene::{Scene, SceneWarning};
use std::path::Path;

/// Prints `value` as pretty JSON on stdout.
pub fn print_json(value: &serde_json::Value) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

/// Checks a `--steps` flag against the scene files' own range, in the flag's words (a scene's `time.steps` would
/// blame a key the user did not write, or the demo's embedded file).
pub fn check_steps_flag(steps: Option<usize>) -> Result<()> {
    match steps {
        Some(s) if !(1..=flexsurf::ranges::STEPS).contains(&s) => {
            anyhow::bail!("--steps: {s} must be between 1 and {}", flexsurf::ranges::STEPS)
        }
        _ => Ok(()),
    }
}

/// Runs one built scene into `out` with `options` and a progress bar.
pub fn run_built(scene: &Scene, out: &Path, label: &str, options: &RunOptions) -> Result<RunOutput> {
    let bar = progress::bar(scene.steps, label);
    let result = runner::run_scene_with(scene, out, options, |state| bar.set_position(state.step as u64));
    bar.finish_and_clear();
    result.with_context(|| format!("running {} ({} model) into {}", scene.file.display(), label, out.display()))
}

/// A short table of the numbers that tell runs apart.
pub fn print_table(rows: &[(&str, &RunOutput)]) {
    println!(
        "{:<12} {:>6} {:>9} {:>9} {:>8} {:>8} {:>10} {:>9} {:>10} {:>11} {:>11}",
        "model",
        "steps",
        "wall s",
        "steps/s",
        "min z",
        "max z",
        "area xy",
        "strain",
        "penetr.",
        "membrane J",
        "bending J"
    );
    for (name, o) in rows {
        let s = &o.summary;
        let f = &s.final_state;
        println!(
            "{:<12} {:>6} {:>9.3} {:>9.1} {:>8.4} {:>8.4} {:>10.4} {:>9.2e} {:>10.2e} {:>11.3e} {:>11.3e}",
            name,
            s.steps,
            s.wall_seconds,
            s.steps_per_second,
            f.min_z,
            f.max_z,
            f.projected_area_xy,
            f.max_strain,
            s.max_penetration_seen,
            f.membrane_energy,
            f.bending_energy
        );
    }
    for (name, o) in rows {
        for w in &o.summary.warnings {
            eprintln!("warning: {name}: {w}");
        }
    }
    for (name, o) in rows {
        // A static solve takes no steps: its own numbers instead of a rate.
        if let Some(r) = &o.summary.static_solve {
            println!(
                "{name}: static solve, {} Newton iterations ({} load steps, {} saddle escapes), relative residual \
                 {:.2e}, potential {:.6e} J",
                r.iterations,
                r.load_steps.len(),
                r.escapes,
                r.residual,
                r.potential
            );
        }
    }
    for (name, o) in rows {
        let s = &o.summary;
        if let (Some(drift), Some(gap)) = (s.waist_drift_max, s.initial_min_distance) {
            println!(
                "{name}: waist drift {drift:.2e} m (largest waist node distance from its spring target), initial \
                 clearance {gap:.4} m, {} waist node(s) fitted onto the body, most contacts {}",
                s.waist_fitted.unwrap_or(0),
                s.max_contacts
            );
        }
    }
}

/// Prints the warnings of a scene (values outside the usual range of fabrics) on stderr.
pub fn print_warnings(warnings: &[SceneWarning]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}
