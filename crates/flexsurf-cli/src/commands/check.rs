//! `flexsurf check`: loads and checks a scene without building or running it, prints its warnings and a
//! one-line summary of it; with `--build` it also builds the model (a pattern's garment sewn), as a run's start
//! does, so what fails there (a sewing phase the contact cannot take) fails here.

use super::shared::print_warnings;
use anyhow::Result;
use flexsurf::scene::budget::human;
use std::path::PathBuf;

/// The arguments of `flexsurf check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The scene file.
    scene: PathBuf,
    /// Also build the model as a run starts it: a `[pattern]` garment is sewn (seconds for a fine one), and the
    /// sewing phase's steps, let-outs and widest seam gap are printed.
    #[arg(long)]
    build: bool,
    #[command(flatten)]
    limits: super::run::LimitArgs,
}

/// `flexsurf check`: every value, file and size checked (warnings on stderr), without building the model.
pub fn execute(args: &CheckArgs) -> Result<()> {
    let (scene_path, limits) = (&args.scene, args.limits.limits());
    // Read once: `--build` builds from the same checked spec.
    let spec = flexsurf::scene::SceneSpec::load(scene_path)?;
    let r = spec.check_with(scene_path, &limits)?;
    print_warnings(&r.warnings);
    let [m, n] = r.nodes;
    let sheets = if r.sheets > 1 { format!("{} sheets, the first of ", r.sheets) } else { String::new() };
    println!(
        "{}: ok — {sheets}{m} × {n} nodes, {} model, {} integrator, dt = {} s, {} steps, {} obstacle(s), {} pinned node(s), \
         {} spring(s), material {}, estimated memory {}",
        scene_path.display(),
        r.model.name(),
        r.method.name(),
        r.dt,
        r.steps,
        r.obstacles,
        r.pinned,
        r.springs,
        r.material,
        human(r.estimate.total()),
    );
    if args.build {
        let scene = spec.build_with(scene_path, &limits)?;
        let sewn = scene.sewing.as_ref().map_or_else(String::new, |s| {
            let r = &s.report;
            format!(
                "; pattern {} sewn in {} steps ({} let-outs), widest seam gap {:.2e} m, {:.2} s",
                s.pattern,
                r.steps,
                r.backoffs,
                r.largest_gap(),
                r.seconds
            )
        });
        println!("{}: built — {} nodes{sewn}", scene_path.display(), scene.model.nodes());
    }
    Ok(())
}
