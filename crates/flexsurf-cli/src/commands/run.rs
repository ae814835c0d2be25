//! `flexsurf run`: loads a TOML scene, applies the command-line overrides, runs it into `--out` with a progress
//! bar and prints the run table.

use super::shared::{print_table, print_warnings, run_built};
use anyhow::{Context, Result};
use flexsurf::integrate::linsolve::SolverKind;
use flexsurf::model::ModelKind;
use flexsurf::runner::RunOptions;
use flexsurf::scene::IntegratorKind;
use flexsurf::scene::{FrameFormat, Limits, SceneSpec};
use std::path::PathBuf;

/// The arguments of `flexsurf run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// The scene file (TOML; see docs/scenes.md).
    scene: PathBuf,
    /// Output directory (created if missing). A directory holding another run's outputs is refused unless
    /// --overwrite is given.
    #[arg(long, short, required_unless_present = "resume", conflicts_with = "resume")]
    out: Option<PathBuf>,
    /// Continue the run stopped in DIR (its checkpoint.bin) to the end, with the same scene and options; the
    /// outputs are those of an uninterrupted run, byte for byte.
    #[arg(long, value_name = "DIR")]
    resume: Option<PathBuf>,
    /// Remove the outputs of an earlier run in --out (exactly the files its manifest.json lists) first.
    #[arg(long)]
    overwrite: bool,
    /// Write a checkpoint (checkpoint.bin) every N steps; one is always written when the run is stopped by
    /// SIGINT or SIGTERM.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    checkpoint_every: Option<u64>,
    #[command(flatten)]
    limits: LimitArgs,
    #[command(flatten)]
    overrides: Overrides,
}

/// The resource limit of a scene (shared by `run` and `check`).
#[derive(Debug, Clone, clap::Args)]
pub struct LimitArgs {
    /// Largest estimated memory a scene may need (bytes, or with a unit: 512M, 16G); default 4G.
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    max_memory: Option<u64>,
}

fn parse_size(text: &str) -> Result<u64, String> {
    flexsurf::scene::budget::parse_size(text)
}

impl LimitArgs {
    /// The limits asked for.
    pub fn limits(&self) -> Limits {
        let mut l = Limits::default();
        if let Some(m) = self.max_memory {
            l.max_memory = m;
        }
        l
    }
}

/// Overrides of a scene's settings from the command line.
#[derive(Debug, Clone, Default, clap::Args)]
struct Overrides {
    /// Deformation model (overrides `[model] kind`).
    #[arg(long, value_enum)]
    model: Option<ModelKind>,
    /// Number of steps (overrides `[time] steps`).
    #[arg(long)]
    steps: Option<usize>,
    /// Time-stepping scheme (overrides `[integrator] kind`).
    #[arg(long, value_enum)]
    integrator: Option<IntegratorKind>,
    /// Linear solver (overrides `[integrator] solver`).
    #[arg(long, value_enum)]
    solver: Option<SolverKind>,
    /// Mesh format of the frames (overrides `[output] format`).
    #[arg(long, value_enum)]
    format: Option<FrameFormat>,
}

impl Overrides {
    fn apply(&self, spec: &mut SceneSpec) {
        let Overrides { model, steps, integrator, solver, format } = *self;
        spec.model.kind = model.unwrap_or(spec.model.kind);
        spec.time.steps = steps.unwrap_or(spec.time.steps);
        spec.integrator.kind = integrator.unwrap_or(spec.integrator.kind);
        spec.integrator.solver = solver.unwrap_or(spec.integrator.solver);
        spec.output.format = format.unwrap_or(spec.output.format);
    }
}

/// `flexsurf run`.
pub fn execute(args: &RunArgs) -> Result<()> {
    let RunArgs { scene: scene_path, out, resume, overwrite, checkpoint_every, limits, overrides } = args;
    let Some(out) = out.as_ref().or(resume.as_ref()) else { anyhow::bail!("give --out DIR or --resume DIR") };
    super::shared::check_steps_flag(overrides.steps)?;
    let limits = limits.limits();
    // The files read while building the scene, with their hashes, for the summary's provenance.
    let (built, inputs) = flexsurf::io::input::recording(|| -> Result<_> {
        let mut spec = SceneSpec::load(scene_path)?;
        overrides.apply(&mut spec);
        Ok(spec.build_with(scene_path, &limits)?)
    });
    let scene = built?;
    print_warnings(&scene.warnings);
    let stop = crate::signals::install().context("installing the SIGINT/SIGTERM handlers")?;
    let options = RunOptions {
        overwrite: *overwrite,
        checkpoint_every: checkpoint_every.map(|n| usize::try_from(n).unwrap_or(usize::MAX)),
        resume: resume.is_some(),
        stop: Some(stop),
        command_line: std::env::args_os().map(|a| a.to_string_lossy().into_owned()).collect(),
        inputs,
    };
    let label = scene.model.kind.name();
    let output = run_built(&scene, out, label, &options)?;
    print_table(&[(label, &output)]);
    if !output.summary.interrupted {
        crate::signals::forget();
    } else {
        eprintln!(
            "interrupted after step {}: checkpoint and summary written; continue with `flexsurf run {} --resume {}`",
            output.summary.steps,
            scene_path.display(),
            out.display()
        );
    }
    println!("wrote {}", out.display());
    Ok(())
}
