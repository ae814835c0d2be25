//! The ball-drop benchmark (docs/model.md §13.1 at several grid sizes): wall time of the time stepping and its
//! per-stage breakdown, as reported by `flexsurf bench` and the criterion bench `cargo bench -p flexsurf`.

use crate::integrate::{Counters, StepError, Stepper};
use crate::scene::{Scene, SceneError, SceneSpec};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// The canonical ball-drop scene file, embedded.
pub const BALL_DROP_TOML: &str = include_str!("../../../scenes/ball_drop.toml");

/// The canonical ball drop with `n × n` nodes (same sheet, ball, fabric and time step).
pub fn ball_drop(n: usize) -> Result<Scene, SceneError> {
    let file = Path::new("scenes/ball_drop.toml");
    let mut spec = SceneSpec::from_toml(BALL_DROP_TOML, file)?;
    if let Some(sheet) = spec.sheet.as_mut() {
        sheet.nodes = [n, n];
    }
    spec.build(file)
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
    /// Wall seconds of all timed steps.
    pub wall_seconds: f64,
    /// Median wall seconds of one step.
    pub step_median: f64,
    /// Mean seconds per step by stage.
    pub per_step: Counters,
    /// Non-zeros of the Cholesky factor (0 for other solvers).
    pub factor_nnz: usize,
}

/// Runs `steps` steps of the `n × n` ball drop (from its initial state) and times them.
pub fn run(n: usize, steps: usize) -> Result<BenchRow, BenchError> {
    let scene = ball_drop(n)?;
    let mut state = scene.state.clone();
    let mut stepper = Stepper::new(&scene.model, &scene.step_params())?;
    let mut times = Vec::with_capacity(steps);
    for _ in 0..steps {
        let t = Instant::now();
        stepper.step(&scene.model, &mut state)?;
        times.push(t.elapsed().as_secs_f64());
    }
    let wall_seconds = times.iter().sum();
    times.sort_by(f64::total_cmp);
    let step_median = if times.is_empty() { 0.0 } else { times[times.len() / 2] };
    let c = stepper.counters;
    let s = steps.max(1) as f64;
    let per_step = Counters {
        assembly: c.assembly / s,
        contact: c.contact / s,
        factorization: c.factorization / s,
        solve: c.solve / s,
        ..c
    };
    Ok(BenchRow { n, nodes: n * n, steps, wall_seconds, step_median, per_step, factor_nnz: stepper.factor_nnz() })
}

/// Least-squares exponent `p` of `t ∝ nodes^p` over the rows.
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
    Some(num / den)
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
}
