//! `flexsurf demo`: one of the embedded demo scenes (the ball drop, the skirt on the mannequin) run with both
//! models, each into `out/<model>`, and a side-by-side `out/comparison.png` (the paper's Fig. 1 vs Fig. 2, or
//! its Fig. 3).

use super::shared::{print_table, print_warnings, run_built};
use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use flexsurf::io::render;
use flexsurf::model::ModelKind;
use flexsurf::runner::{self, RunOptions, RunOutput};
use flexsurf::scene::SceneSpec;
use std::path::{Path, PathBuf};

/// The canonical ball drop, embedded so `flexsurf demo` works from any directory.
const BALL_DROP: &str = include_str!("../../../../scenes/ball_drop.toml");
/// The skirt on the (built-in) mannequin, embedded likewise.
const SKIRT: &str = include_str!("../../../../scenes/skirt.toml");

/// The arguments of `flexsurf demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Which demo: the ball drop (Fig. 1 and 2) or the skirt on the mannequin (Fig. 3).
    #[arg(long, value_enum, default_value_t = DemoScene::Ball)]
    scene: DemoScene,
    /// Output directory: DIR/tfs, DIR/terzopoulos and DIR/comparison.png (default out/demo for the ball,
    /// out/skirt for the skirt).
    #[arg(long, short)]
    out: Option<PathBuf>,
    /// Number of steps (default as in the paper: 300 for the ball, 600 for the skirt).
    #[arg(long)]
    steps: Option<usize>,
}

/// The demo scenes, embedded in the binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DemoScene {
    /// The cloth falling on a ball (scenes/ball_drop.toml).
    Ball,
    /// The skirt on the mannequin (scenes/skirt.toml).
    Skirt,
}

/// `flexsurf demo`: a demo scene with both models, each into `out/<model>`, and `out/comparison.png`.
pub fn execute(args: &DemoArgs) -> Result<()> {
    let (text, file, what, default_out) = match args.scene {
        DemoScene::Ball => (BALL_DROP, Path::new("ball_drop.toml (embedded)"), "the ball drop", "out/demo"),
        DemoScene::Skirt => (SKIRT, Path::new("skirt.toml (embedded)"), "the skirt", "out/skirt"),
    };
    super::shared::check_steps_flag(args.steps)?;
    let out = args.out.as_deref().unwrap_or(Path::new(default_out));
    let base = SceneSpec::from_toml(text, file)?;
    let mut runs = Vec::new();
    for kind in [ModelKind::Tfs, ModelKind::Terzopoulos] {
        let mut spec = base.clone();
        spec.model.kind = kind;
        if let Some(s) = args.steps {
            spec.time.steps = s;
        }
        let scene = spec.build(file)?;
        print_warnings(&scene.warnings);
        let dir = out.join(kind.name());
        eprintln!("running {what} with the {} model into {}", kind.name(), dir.display());
        // The demo's folders are its own: a new demo replaces the files an earlier one wrote there (exactly
        // those its manifest lists; anything else is refused as for `run`).
        let options = RunOptions { overwrite: true, ..RunOptions::default() };
        let output = run_built(&scene, &dir, kind.name(), &options)?;
        runs.push((kind, scene, output));
    }
    // One camera for every picture, so the two rows compare directly.
    let first = &runs[0].1;
    let view = runner::view_for(&first.model, runs.iter().flat_map(|r| r.2.snapshots.iter().map(|s| &s.mesh)));
    let [w, h] = first.output.image_size;
    let mut images = Vec::new();
    let mut labels = Vec::new();
    for (kind, scene, output) in &runs {
        let name = match kind {
            ModelKind::Tfs => "TFS (this model)",
            ModelKind::Terzopoulos => "Terzopoulos",
        };
        for s in &output.snapshots {
            let mut img = runner::render_frame(&scene.model, &s.mesh, &view, w, h);
            render::annotate::scale_bar(&mut img, &view);
            render::annotate::axis_triad(&mut img, &view);
            images.push(img);
            labels.push(format!("{name}   step {}   t = {:.2} s", s.step, s.time));
        }
    }
    let columns = runs[0].2.snapshots.len().max(1);
    if runs.iter().any(|r| r.2.snapshots.len() != columns) {
        bail!("the two runs recorded different numbers of snapshots");
    }
    let path = out.join("comparison.png");
    let title = format!(
        "{}: {} steps of {} s with both models  (rows: models; columns: simulated time)",
        first.name, first.steps, first.dt
    );
    render::save_png(&path, &render::with_title(&render::panel(&images, &labels, columns), &title))
        .with_context(|| format!("writing {}", path.display()))?;
    let rows: Vec<(&str, &RunOutput)> = runs.iter().map(|(k, _, o)| (k.name(), o)).collect();
    print_table(&rows);
    println!("wrote {} (rows: models; columns: steps) and {}/{{tfs,terzopoulos}}", path.display(), out.display());
    println!("to watch a run in a browser: flexsurf view {}", out.join(ModelKind::Tfs.name()).display());
    Ok(())
}
