//! `flexsurf run`: loads a TOML scene, applies the command-line overrides, runs it into `--out` with a progress
//! bar and prints the run table.

use super::shared::{print_table, run_built};
use anyhow::Result;
use clap::ValueEnum;
use flexsurf::integrate::linsolve::SolverKind;
use flexsurf::model::ModelKind;
use flexsurf::scene::IntegratorKind;
use flexsurf::scene::{FrameFormat, SceneSpec};
use std::path::PathBuf;

/// The arguments of `flexsurf run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// The scene file (TOML; see docs/scenes.md).
    scene: PathBuf,
    /// Output directory (created if missing).
    #[arg(long, short)]
    out: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
}

/// Overrides of a scene's settings from the command line.
#[derive(Debug, Clone, Default, clap::Args)]
struct Overrides {
    /// Deformation model (overrides `[model] kind`).
    #[arg(long, value_enum)]
    model: Option<ModelArg>,
    /// Number of steps (overrides `[time] steps`).
    #[arg(long)]
    steps: Option<usize>,
    /// Time-stepping scheme (overrides `[integrator] kind`).
    #[arg(long, value_enum)]
    integrator: Option<IntegratorArg>,
    /// Linear solver (overrides `[integrator] solver`).
    #[arg(long, value_enum)]
    solver: Option<SolverArg>,
    /// Mesh format of the frames (overrides `[output] format`).
    #[arg(long, value_enum)]
    format: Option<FormatArg>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ModelArg {
    Tfs,
    Terzopoulos,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum IntegratorArg {
    Linearized,
    Lagged,
    Bdf2,
    Static,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SolverArg {
    Cholesky,
    Pcg,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum FormatArg {
    Obj,
    Ply,
    Gltf,
}

impl Overrides {
    fn apply(&self, spec: &mut SceneSpec) {
        if let Some(m) = self.model {
            spec.model.kind = match m {
                ModelArg::Tfs => ModelKind::Tfs,
                ModelArg::Terzopoulos => ModelKind::Terzopoulos,
            };
        }
        if let Some(s) = self.steps {
            spec.time.steps = s;
        }
        if let Some(i) = self.integrator {
            spec.integrator.kind = match i {
                IntegratorArg::Linearized => IntegratorKind::Linearized,
                IntegratorArg::Lagged => IntegratorKind::Lagged,
                IntegratorArg::Bdf2 => IntegratorKind::Bdf2,
                IntegratorArg::Static => IntegratorKind::Static,
            };
        }
        if let Some(s) = self.solver {
            spec.integrator.solver = match s {
                SolverArg::Cholesky => SolverKind::Cholesky,
                SolverArg::Pcg => SolverKind::Pcg,
            };
        }
        if let Some(f) = self.format {
            spec.output.format = match f {
                FormatArg::Obj => FrameFormat::Obj,
                FormatArg::Ply => FrameFormat::Ply,
                FormatArg::Gltf => FrameFormat::Gltf,
            };
        }
    }
}

/// `flexsurf run`.
pub fn execute(args: &RunArgs) -> Result<()> {
    let RunArgs { scene: scene_path, out, overrides } = args;
    let mut spec = SceneSpec::load(scene_path)?;
    overrides.apply(&mut spec);
    let scene = spec.build(scene_path)?;
    let label = scene.model.kind.name();
    let output = run_built(&scene, out, label)?;
    print_table(&[(label, &output)]);
    println!("wrote {}", out.display());
    Ok(())
}
