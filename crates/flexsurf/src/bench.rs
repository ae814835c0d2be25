//! The ball-drop benchmark (docs/model.md §13.1 at several grid sizes), as reported by `flexsurf bench` and the
//! criterion bench `cargo bench -p flexsurf`: wall time of the time stepping, its per-step breakdown by stage,
//! the linear solver's work (solves and why, iterations, factorisations) and the process's peak memory.
//!
//! Six workloads: [`Workload::Drop`], the canonical scene (a fall of 5 cm, the impact, the drape),
//! [`Workload::Touching`], the same sheet placed on the ball so that contact acts from the first step (the
//! per-step cost of a drape in progress, without the free fall's easy steps), the self-contact pile
//! (`scenes/pile.toml`) with and without its self-contact ([`Workload::Pile`], [`Workload::PileAlone`]), the
//! drop's sheet tumbling freely without the ball ([`Workload::Tumble`]: Newton's iterated steps), and a sheet
//! hanging from two corners while one is carried towards the other ([`Workload::Hanging`]: Newton's steps on
//! a compressed, folding membrane).

use crate::integrate::linsolve::SolverKind;
use crate::integrate::{Counters, StepError, StepParams, Stepper};
use crate::math::Vec3;
use crate::scene::{Scene, SceneError, SceneSpec};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// The canonical ball-drop scene file, embedded.
pub const BALL_DROP_TOML: &str = include_str!("../../../scenes/ball_drop.toml");
/// The self-contact pile's scene file, embedded.
pub const PILE_TOML: &str = include_str!("../../../scenes/pile.toml");

/// What the benchmark runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Workload {
    /// The canonical ball drop from 5 cm above the ball.
    Drop,
    /// The sheet's centre placed on the ball (inside the contact layer): contact from the first step.
    Touching,
    /// The pile of `scenes/pile.toml`: a sheet collapsing onto the floor and onto itself, with self-contact
    /// (its thickness at most 0.4 of the grid spacing on fine grids).
    Pile,
    /// The same pile without self-contact (the sheet passes through itself): the cost self-contact adds.
    PileAlone,
    /// The drop's sheet without the ball or gravity, spinning at `ω = (1, −0.5, 2)` rad/s about its centre:
    /// large rotations without contact, the steps Newton's method iterates to its tolerance (their solves
    /// inexact on the iterative solvers, docs/model.md §8.5).
    Tumble,
    /// A 1 m sheet of the paper's cotton hanging from the two corners of its top edge, one carried 0.45 m
    /// towards the other over 1.5 s ([`HANGING_TOML`]): no contact, the top edge gathering into folds whose
    /// compressed membrane Newton's method converges slowly (docs/performance.md).
    Hanging,
}

/// The [`Workload::Hanging`] scene, `{n}` its nodes a side and `{last}` the last node's index.
pub const HANGING_TOML: &str = r#"name = "hanging"
calibration = "kes"
gravity = [0.0, 0.0, -9.81]

[sheet]
size = [1.0, 1.0]
nodes = [{n}, {n}]
center = [0.0, 0.0, 0.8]
rotate_deg = [90.0, 0.0, 0.0]

[material]
preset = "paper-cotton"

[time]
dt = 0.01
steps = 10

[[pin]]
nodes = [[0, {last}]]

[[pin]]
nodes = [[{last}, {last}]]
motion = { shift = [-0.45, 0.0, 0.0], seconds = 1.5 }
"#;

/// The scene file at `path` with its first sheet at `n × n` nodes (the examples' `SCENE=`: a shipped scene at
/// another resolution; a scene without a `[sheet]` as it is).
pub fn scene_file(path: &Path, n: usize) -> Result<Scene, SceneError> {
    let mut spec = SceneSpec::load(path)?;
    if let Some(sheet) = spec.sheet.as_mut().map(crate::scene::Sheets::first_mut) {
        sheet.nodes = [n, n];
    }
    spec.build(path)
}

/// The canonical ball drop with `n × n` nodes (same sheet, ball, fabric and time step).
pub fn ball_drop(n: usize) -> Result<Scene, SceneError> {
    scene(n, Workload::Drop)
}

/// The scene of `workload` with `n × n` nodes, whatever memory it needs.
pub fn scene(n: usize, workload: Workload) -> Result<Scene, SceneError> {
    scene_within(n, workload, u64::MAX)
}

/// As [`scene`], refused where the estimated memory of its model, step matrix and solver exceeds `max_memory`
/// bytes (the error names `sheet.nodes` and the estimate's parts).
pub fn scene_within(n: usize, workload: Workload, max_memory: u64) -> Result<Scene, SceneError> {
    if matches!(workload, Workload::Pile | Workload::PileAlone) {
        return pile_within(n, workload == Workload::Pile, max_memory);
    }
    if workload == Workload::Hanging {
        let text = HANGING_TOML.replace("{n}", &n.to_string()).replace("{last}", &n.saturating_sub(1).to_string());
        let file = Path::new("hanging.toml");
        return SceneSpec::from_toml(&text, file)?.build_with(file, &limits(max_memory));
    }
    let file = Path::new("scenes/ball_drop.toml");
    let mut spec = SceneSpec::from_toml(BALL_DROP_TOML, file)?;
    if let Some(sheet) = spec.sheet.as_mut().map(crate::scene::Sheets::first_mut) {
        sheet.nodes = [n, n];
        if workload == Workload::Touching {
            // The ball's radius is 0.3 m and the contact offset 5 mm: the centre node starts 0.1 mm inside the
            // contact layer.
            sheet.center[2] = 0.3049;
        }
    }
    if workload == Workload::Tumble {
        spec.obstacles.clear();
        spec.gravity = [0.0; 3];
        spec.initial.angular_velocity = [1.0, -0.5, 2.0];
    }
    spec.build_with(file, &limits(max_memory))
}

/// The pile of `scenes/pile.toml` with `n × n` nodes, with or without its self-contact.
pub fn pile(n: usize, self_contact: bool) -> Result<Scene, SceneError> {
    pile_within(n, self_contact, u64::MAX)
}

/// As [`pile`] within `max_memory` bytes ([`scene_within`]).
fn pile_within(n: usize, self_contact: bool, max_memory: u64) -> Result<Scene, SceneError> {
    let file = Path::new("scenes/pile.toml");
    let mut spec = SceneSpec::from_toml(PILE_TOML, file)?;
    if let Some(sheet) = spec.sheet.as_mut().map(crate::scene::Sheets::first_mut) {
        sheet.nodes = [n, n];
        let spacing = sheet.size[0].min(sheet.size[1]) / (n.max(2) - 1) as f64;
        if let Some(c) = spec.self_contact.as_mut() {
            c.thickness = c.thickness.min(0.4 * spacing);
        }
    }
    if !self_contact {
        spec.self_contact = None;
    }
    spec.build_with(file, &limits(max_memory))
}

/// A benchmark's limits: the largest estimated memory of its model, step matrix and solver (it keeps no frames
/// or pictures).
fn limits(max_memory: u64) -> crate::scene::Limits {
    crate::scene::Limits { max_memory, outputs: false }
}

/// One benchmark measurement.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BenchRow {
    /// Nodes per side.
    pub n: usize,
    /// Nodes in all.
    pub nodes: usize,
    /// Steps timed.
    pub steps: usize,
    /// The linear solvers used (`auto` resolved: [`SolverKind::used`]).
    pub solver: &'static str,
    /// Wall seconds of all timed steps.
    pub wall_seconds: f64,
    /// Median wall seconds of one step.
    pub step_median: f64,
    /// Mean seconds per step by stage; the counts are totals over the timed steps.
    pub per_step: Counters,
    /// Non-zeros of the Cholesky factor (0 for other solvers).
    pub factor_nnz: usize,
    /// Peak resident memory of the process during this measurement (bytes; 0 where not measurable).
    pub peak_bytes: u64,
    /// Median seconds of one product `y = A x` with the last step matrix stored in full block rows, one
    /// thread ([`crate::sparse::BlockRows`]): the *matrix stream* of issue 23.
    pub product_seconds: f64,
    /// Bytes one such product reads from the matrix.
    pub product_bytes: usize,
    /// The mean step (`wall_seconds / steps`) in matrix streams: how many products with the step matrix a
    /// step costs, independently of the machine's speed.
    pub streams_per_step: f64,
    /// For the iterative solvers (multigrid, block-Jacobi CG): the mean preconditioned iteration (the solve
    /// stage's time over the iterations) in the same products, the cost issue 23 item 5 bounds; `None` where
    /// some steps took Cholesky, whose solve stage is mostly triangular solves.
    pub streams_per_iteration: Option<f64>,
    /// Bytes one preconditioned iteration of an iterative solver reads and writes, by the model of
    /// docs/performance.md ("Bytes an iteration"); over `product_bytes`, the iteration's *byte streams*, its
    /// floor where memory bandwidth bounds it. 0 for Cholesky.
    pub iteration_bytes: usize,
}

/// Runs `steps` steps of the `n × n` `workload` (from its initial state) with `solver` and times them.
pub fn run(n: usize, steps: usize, workload: Workload, solver: SolverKind) -> Result<BenchRow, BenchError> {
    run_within(n, steps, workload, solver, u64::MAX)
}

/// As [`run`], refused before anything large is allocated where the scene's estimated memory exceeds
/// `max_memory` bytes ([`scene_within`]): `flexsurf bench --sizes 5000` asked for 25 million nodes and was
/// stopped only by the machine's memory.
pub fn run_within(
    n: usize,
    steps: usize,
    workload: Workload,
    solver: SolverKind,
    max_memory: u64,
) -> Result<BenchRow, BenchError> {
    if !(1..=crate::ranges::STEPS).contains(&steps) {
        return Err(BenchError::Steps(steps));
    }
    reset_peak_memory();
    let scene = scene_within(n, workload, max_memory)?;
    let mut state = scene.state.clone();
    let params = StepParams { solver, ..scene.step_params() };
    let mut stepper = Stepper::new(&scene.model, &params)?;
    // Grown as the steps run: a long bench's times are allocated as it goes, not up front.
    let mut times = Vec::with_capacity(steps.min(1 << 16));
    for _ in 0..steps {
        let t = Instant::now();
        // The pins' motions (the hanging sheet's carried corner), as the runner drives them before each step.
        scene.drive(&mut state)?;
        stepper.step(&scene.model, &mut state)?;
        times.push(t.elapsed().as_secs_f64());
    }
    let wall_seconds = times.iter().sum();
    times.sort_by(f64::total_cmp);
    let step_median = if times.is_empty() { 0.0 } else { times[times.len() / 2] };
    // The peak of the run itself, read before the product's full copy of the matrix is built (at 641² that copy
    // and its construction add about 0.9 GB, which is the measurement's, not the solver's).
    let peak_bytes = peak_memory();
    let full = crate::sparse::BlockRows::from_symmetric(stepper.matrix(), scene.model.potential.pattern());
    let product_seconds = product_time(&full);
    let c = stepper.counters;
    let s = steps.max(1) as f64;
    let per_step = Counters {
        assembly: c.assembly / s,
        contact: c.contact / s,
        self_contact: c.self_contact / s,
        factorization: c.factorization / s,
        solve: c.solve / s,
        ..c
    };
    Ok(BenchRow {
        n,
        nodes: n * n,
        steps,
        solver: solver.resolve(n * n).used(c.iterative_steps, c.steps),
        wall_seconds,
        step_median,
        per_step,
        factor_nnz: stepper.factor_nnz(),
        peak_bytes,
        product_seconds,
        product_bytes: full.bytes(),
        streams_per_step: if product_seconds > 0.0 { wall_seconds / s / product_seconds } else { 0.0 },
        streams_per_iteration: (c.iterative_steps == c.steps && c.iterations > 0 && product_seconds > 0.0)
            .then(|| c.solve / c.iterations as f64 / product_seconds),
        iteration_bytes: stepper.iteration_bytes(),
    })
}

/// Median seconds of one product with `a` (one thread): at least 5 products and 0.2 s of them, after one
/// product that brings the matrix into memory.
pub fn product_time(a: &crate::sparse::BlockRows) -> f64 {
    let n = a.rows();
    let x: Vec<Vec3> = (0..n).map(|k| Vec3::new(1.0, 0.5, -0.25) * (1.0 + (k % 7) as f64)).collect();
    let mut y = vec![Vec3::ZERO; n];
    a.mul(&x, &mut y);
    let (mut times, start) = (Vec::new(), Instant::now());
    while times.len() < 5 || start.elapsed().as_secs_f64() < 0.2 {
        let t = Instant::now();
        a.mul(&x, &mut y);
        times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(&y);
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Least-squares exponent `p` of `t ∝ nodes^p` over the rows (their median step times).
pub fn scaling_exponent(rows: &[BenchRow]) -> Option<f64> {
    if rows.len() < 2 {
        return None;
    }
    let pts: Vec<(f64, f64)> = rows.iter().map(|r| ((r.nodes as f64).ln(), r.step_median.ln())).collect();
    let m = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / m, sy / m);
    let num: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let den: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    (den > 0.0).then(|| num / den)
}

/// Resets the process's peak resident set (Linux: `/proc/self/clear_refs`); nothing elsewhere.
fn reset_peak_memory() {
    // Writing 5 resets the peak RSS the kernel reports as VmHWM.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The process's peak resident set since the last reset (bytes; 0 where `/proc` is missing).
pub fn peak_memory() -> u64 {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else { return 0 };
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map_or(0, |kb| kb * 1024)
}

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The embedded scene did not build.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A step failed.
    #[error(transparent)]
    Step(#[from] StepError),
    /// A pin's motion could not be applied.
    #[error(transparent)]
    Motion(#[from] crate::model::ModelError),
    /// The step count is outside 1 to [`crate::ranges::STEPS`].
    #[error("{0} steps: a bench times 1 to {max} steps", max = crate::ranges::STEPS)]
    Steps(usize),
}
