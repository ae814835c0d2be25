//! `flexsurf`: the command-line front end. Runs TOML scenes (`run`), the paper's demos (the ball drop and the
//! skirt on the mannequin) with both models (`demo`), validates scenes (`check`) and prints the scene format's
//! JSON schema (`schema`).

mod commands;
mod progress;

use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
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
    Run(RunArgs),
    /// Run a demo scene (the ball drop or the skirt) with both models and write a side-by-side comparison
    /// (the paper's Fig. 1 vs Fig. 2, or its Fig. 3).
    Demo(DemoArgs),
    /// Validate a scene file without running it.
    Check {
        /// The scene file.
        scene: PathBuf,
    },
    /// Print the JSON schema of the scene format.
    Schema,
    /// Time the ball drop at several grid sizes, with the per-step breakdown (assembly, contact,
    /// factorisation, solve).
    Bench(BenchArgs),
    /// Virtual textile tests on a fabric. `kes`: tension (warp, weft, 45° bias), simple shear and pure bending
    /// (warp, weft) on small specimens, solved to equilibrium; prints the recovered constants and their errors.
    /// `cantilever`: the Peirce / ASTM D1388 strip hanging off a ledge; chord angle, tip drop, bending length.
    /// `cusick`: the drape meter (18 cm disc); drape coefficient, nodes, a top-view picture and the mesh.
    Test(TestArgs),
}

#[derive(Debug, clap::Args)]
struct TestArgs {
    /// Which virtual test.
    #[arg(value_enum)]
    name: TestName,
    /// Material file (materials/*.toml, SI or KES units); default the paper's non-woven cotton.
    #[arg(long)]
    material: Option<PathBuf>,
    /// Calibration of the energy coefficients.
    #[arg(long, value_enum, default_value_t = CalibrationArg::Kes)]
    calibration: CalibrationArg,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
    /// `cantilever`: the strip's direction (bias: 45° to warp and weft).
    #[arg(long, value_enum, default_value_t = DirectionArg::Warp)]
    direction: DirectionArg,
    /// `cantilever`: overhang in metres (default: the Peirce length 2 (K/w)^(1/3) of the input).
    #[arg(long)]
    overhang: Option<f64>,
    /// `cantilever`: strip width in metres (default 0.02).
    #[arg(long)]
    width: Option<f64>,
    /// `cusick`: specimen diameter in metres (0.24, 0.30 or 0.36 in the standard).
    #[arg(long, default_value_t = 0.30)]
    specimen: f64,
    /// `cusick`: grid level, 0 (coarse), 1 (default) or 2 (fine; for a convergence check).
    #[arg(long, default_value_t = 1)]
    level: usize,
    /// `cusick`: how many specimens (each starts from a different small wobble of the hem; their mean and
    /// standard deviation are reported, as a drape-meter operator would).
    #[arg(long, default_value_t = 1)]
    specimens: usize,
    /// `cusick`, `cantilever`: where to write the picture and the mesh (default out/cusick, out/cantilever).
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum TestName {
    Kes,
    Cantilever,
    Cusick,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DirectionArg {
    Warp,
    Weft,
    Bias,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum CalibrationArg {
    Kes,
    Paper,
}

impl From<CalibrationArg> for flexsurf::material::Calibration {
    fn from(c: CalibrationArg) -> Self {
        match c {
            CalibrationArg::Kes => Self::Kes,
            CalibrationArg::Paper => Self::Paper,
        }
    }
}

impl From<DirectionArg> for flexsurf::lab::cantilever::Direction {
    fn from(d: DirectionArg) -> Self {
        match d {
            DirectionArg::Warp => Self::Warp,
            DirectionArg::Weft => Self::Weft,
            DirectionArg::Bias => Self::Bias,
        }
    }
}

#[derive(Debug, clap::Args)]
struct BenchArgs {
    /// Nodes per side of the sheet (one run each).
    #[arg(long, value_delimiter = ',', default_values_t = vec![21, 41, 81, 161, 321])]
    sizes: Vec<usize>,
    /// Steps per size (default: 300 for up to 41², fewer for larger grids so each size takes seconds).
    #[arg(long)]
    steps: Option<usize>,
    /// Repetitions of each size; the row with the median wall time is reported.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
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

#[derive(Debug, clap::Args)]
struct RunArgs {
    /// The scene file (TOML; see docs/scenes.md).
    scene: PathBuf,
    /// Output directory (created if missing).
    #[arg(long, short)]
    out: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
}

#[derive(Debug, clap::Args)]
struct DemoArgs {
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

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ModelArg {
    Tfs,
    Terzopoulos,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum IntegratorArg {
    Linearized,
    Lagged,
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => commands::run(&args.scene, &args.out, &args.overrides),
        Command::Demo(args) => commands::demo(args.scene, args.out.as_deref(), args.steps),
        Command::Check { scene } => commands::check(&scene),
        Command::Schema => commands::schema(),
        Command::Bench(a) => commands::bench(&a.sizes, a.steps, a.repeat, a.json),
        Command::Test(a) if a.name == TestName::Cusick => commands::cusick_test(
            commands::CusickArgs {
                specimen: a.specimen,
                level: a.level,
                specimens: a.specimens,
                out: a.out.as_deref().unwrap_or(std::path::Path::new("out/cusick")),
            },
            a.material.as_deref(),
            a.calibration.into(),
            a.json,
        ),
        Command::Test(a) => commands::virtual_test(
            (a.name == TestName::Cantilever).then(|| commands::CantileverArgs {
                direction: a.direction.into(),
                overhang: a.overhang,
                width: a.width,
                out: a.out.as_deref().unwrap_or(std::path::Path::new("out/cantilever")),
            }),
            a.material.as_deref(),
            a.calibration.into(),
            a.json,
        ),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
