//! `flexsurf check`: loads and builds a scene without running it and prints a one-line summary of it.

use anyhow::Result;
use std::path::PathBuf;

/// The arguments of `flexsurf check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The scene file.
    scene: PathBuf,
    #[command(flatten)]
    limits: super::run::LimitArgs,
}

/// `flexsurf check`.
pub fn execute(args: &CheckArgs) -> Result<()> {
    let scene_path = &args.scene;
    let scene = flexsurf::scene::load_with(scene_path, &args.limits.limits())?;
    let g = &scene.model.grid;
    println!(
        "{}: ok — {} × {} nodes, {} model, {} integrator, dt = {} s, {} steps, {} obstacle(s), {} pinned node(s), \
         {} spring(s), material {}",
        scene_path.display(),
        g.m,
        g.n,
        scene.model.kind.name(),
        scene.method.name(),
        scene.dt,
        scene.steps,
        scene.model.obstacles().len(),
        scene.model.potential.pins().count(),
        scene.model.springs().len(),
        scene.material,
    );
    Ok(())
}
