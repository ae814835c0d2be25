//! The run of a scene into its folder, in stages: open the folder and claim every output's files
//! ([`start`]), step (the run loop with its non-finite checks and stop flag, [`step_all`]; checkpoints,
//! [`save_checkpoint`]) or solve the statics ([`solve_static`]), then the summary and the outputs' last files
//! ([`complete`]), the summary last.

use super::checkpoint::{self, Checkpoint};
use super::fields::display_mesh;
use super::manifest::Folder;
use super::outputs::{self, animation_steps, output_steps, Context, Output, Outputs};
use super::summary::{self, Finished};
use super::{fingerprint, io_err, remove_if_present, Provenance, RunError, RunOptions, RunOutput, SUMMARY_FILE};
use crate::integrate::statics::{StaticOptions, StaticReport, StaticSolver};
use crate::integrate::{Counters, Method, StepParams, Stepper};
use crate::io::atomic;
use crate::math::finite;
use crate::scene::Scene;
use crate::sim::{self, RunStats};
use crate::state::State;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

/// A run under way: the scene, its folder and options, and its outputs.
struct Run<'a> {
    scene: &'a Scene,
    out: &'a Path,
    options: &'a RunOptions,
    fingerprint: String,
    outputs: Outputs<'a>,
    observe: &'a mut dyn FnMut(&State),
}

/// How the stepping or the static solve ended.
struct Ended {
    state: State,
    stats: RunStats,
    timings: Counters,
    static_report: Option<StaticReport>,
    interrupted: bool,
}

/// Runs `scene` into `out` with the standard outputs and `extra` ones (see [`super::run_scene_with`]).
pub(super) fn run<'a>(
    scene: &'a Scene,
    out: &'a Path,
    options: &'a RunOptions,
    extra: Vec<Box<dyn Output + 'a>>,
    observe: &'a mut dyn FnMut(&State),
) -> Result<RunOutput, RunError> {
    if out.as_os_str().is_empty() {
        // `Path::new("")` joins to bare file names: the run would go to the working directory unasked.
        let message = "the output folder's path is empty: name a folder (\".\" for the current one)".into();
        return Err(RunError::Folder { path: PathBuf::from("\"\""), message });
    }
    let fp = fingerprint(scene);
    let is_static = matches!(scene.method(), Method::Static(_));
    if options.resume && is_static {
        return Err(RunError::Resume("a static solve has no checkpoint to resume from".into()));
    }
    let resume = if options.resume {
        Some(checkpoint::read(out, &fp).and_then(|ck| checkpoint::validated(ck, scene))?)
    } else {
        None
    };
    let mut folder = Folder::open(out, &fp, options.overwrite, resume.is_some())?;
    // A static solve writes the initial state and the equilibrium (as step 1).
    let (steps, animation) = if is_static {
        (vec![0, 1], vec![0, 1])
    } else {
        let (n, every) = (scene.steps, scene.output_every);
        (output_steps(n, every), animation_steps(n, every, scene.animation_every))
    };
    let cx = Context { scene, out: out.to_path_buf(), steps, animation };
    let mut list = outputs::standard(&cx);
    list.extend(extra);
    let outputs = Outputs::new(cx, list);
    let mut run = Run { scene, out, options, fingerprint: fp, outputs, observe };
    let state = start(&mut run, &mut folder, resume.as_ref(), is_static)?;
    let ended = match scene.method() {
        Method::Static(o) => solve_static(&mut run, &o, state)?,
        Method::Dynamic(params) => step_all(&mut run, &params, state, resume.as_ref())?,
    };
    complete(run, folder, ended, resume.map(|ck| ck.state.step))
}

/// Claims every file of the run, removes an earlier summary and starts the outputs: a fresh run records its
/// initial state, a resumed one restores the outputs' states. Returns the state to go on from.
fn start(
    run: &mut Run<'_>,
    folder: &mut Folder,
    resume: Option<&Checkpoint>,
    is_static: bool,
) -> Result<State, RunError> {
    // Every file this run may write is claimed before any is written.
    let mut files = run.outputs.files();
    files.push(SUMMARY_FILE.to_string());
    if !is_static {
        files.push(checkpoint::CHECKPOINT.to_string());
    }
    folder.claim(&files)?;
    // A summary left by an earlier attempt would claim this run completed.
    remove_if_present(&run.out.join(SUMMARY_FILE))?;
    run.outputs.start(resume.map(|ck| ck.outputs.as_slice()))?;
    match resume {
        Some(ck) => Ok(ck.state.clone()),
        None => {
            run.outputs.record(&run.scene.state)?;
            Ok(run.scene.state.clone())
        }
    }
}

/// What the step callback found: a failure to report, or the stop flag.
#[derive(Default)]
struct Halt {
    failure: Option<RunError>,
    interrupted: bool,
}

/// After every step: the non-finite check, the observer, the outputs, the stop flag.
fn on_step(run: &mut Run<'_>, st: &State, halt: &mut Halt) -> ControlFlow<()> {
    if let Some(k) = st.x.iter().position(|p| !finite(*p)) {
        halt.failure = Some(RunError::NonFinite { stage: format!("step {} (node {k})", st.step) });
        return ControlFlow::Break(());
    }
    (run.observe)(st);
    if let Err(e) = run.outputs.record(st) {
        halt.failure = Some(e);
        return ControlFlow::Break(());
    }
    if run.options.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst)) {
        halt.interrupted = true;
        return ControlFlow::Break(());
    }
    ControlFlow::Continue(())
}

/// The run loop: steps `state` to the scene's last step in stretches that end at the checkpoint steps,
/// writing a checkpoint after each stretch (and when stopped) that does not end the run.
fn step_all(
    run: &mut Run<'_>,
    params: &StepParams,
    mut state: State,
    resume: Option<&Checkpoint>,
) -> Result<Ended, RunError> {
    let (scene, every) = (run.scene, run.options.checkpoint_every.filter(|&e| e > 0));
    let mut stepper = Stepper::new(&scene.model, params)?;
    let mut total = RunStats { steps: 0, wall_seconds: 0.0, max_penetration_seen: 0.0, max_contacts: 0 };
    if let Some(ck) = resume {
        stepper
            .restore(&scene.model, &ck.warm, ck.counters.into())
            .and_then(|()| stepper.restore_solver(&ck.solver))
            .map_err(|e| RunError::Resume(format!("cannot restore the checkpoint: {e}")))?;
        total = ck.stats.into();
    }
    let mut halt = Halt::default();
    while state.step < scene.steps && !halt.interrupted && halt.failure.is_none() {
        let left = scene.steps - state.step;
        let chunk = every.map_or(left, |e| (e - state.step % e).min(left));
        // Moving pins are placed before each step.
        let chunk = if scene.motions.is_empty() { chunk } else { 1 };
        scene.drive(&mut state)?;
        let part = sim::run(&scene.model, &mut state, &mut stepper, chunk, |st, _| on_step(run, st, &mut halt))?;
        merge(&mut total, &part);
        let due = every.is_some_and(|e| state.step % e == 0);
        if halt.failure.is_none() && state.step < scene.steps && (halt.interrupted || due) {
            save_checkpoint(run, &stepper, &state, total)?;
        }
    }
    // The energy history up to a failure is still useful; it is complete as far as it goes.
    if let Some(e) = halt.failure {
        return Err(e);
    }
    let timings = stepper.counters;
    Ok(Ended { state, stats: total, timings, static_report: None, interrupted: halt.interrupted })
}

/// Adds the statistics of one stretch of steps to `total`.
fn merge(total: &mut RunStats, part: &RunStats) {
    total.steps += part.steps;
    total.wall_seconds += part.wall_seconds;
    total.max_penetration_seen = total.max_penetration_seen.max(part.max_penetration_seen);
    total.max_contacts = total.max_contacts.max(part.max_contacts);
}

/// Writes the checkpoint of `state`: the stepper's warm state and the state of every output.
fn save_checkpoint(run: &Run<'_>, stepper: &Stepper, state: &State, total: RunStats) -> Result<(), RunError> {
    let (warm, counters) = checkpoint::stepper_state(stepper, &run.scene.model, &checkpoint::path_in(run.out))?;
    let ck = Checkpoint {
        fingerprint: run.fingerprint.clone(),
        state: state.clone(),
        warm,
        counters,
        solver: stepper.solver_warm(),
        stats: total.into(),
        outputs: run.outputs.save()?,
    };
    checkpoint::write(run.out, &ck)
}

/// `integrator = "static"`: solves for the equilibrium from `state`, records it as step 1 and reports it.
fn solve_static(run: &mut Run<'_>, options: &StaticOptions, mut state: State) -> Result<Ended, RunError> {
    let model = &run.scene.model;
    let t = std::time::Instant::now();
    let report =
        StaticSolver::new(model).and_then(|mut s| s.solve(model, &mut state.x, options)).map_err(RunError::Static)?;
    let wall = t.elapsed().as_secs_f64();
    // The solver's own report may look converged (0 iterations, residual 0) when its arithmetic overflowed.
    if let Some(k) = state.x.iter().position(|p| !finite(*p)) {
        return Err(RunError::NonFinite { stage: format!("the static solve (node {k})") });
    }
    if !(report.residual.is_finite() && report.potential.is_finite()) {
        return Err(RunError::NonFinite { stage: "the static solve (its residual or potential)".into() });
    }
    state.x_prev.copy_from_slice(&state.x);
    state.v.iter_mut().chain(state.v_prev.iter_mut()).for_each(|v| *v = crate::math::Vec3::ZERO);
    state.step = 1;
    (run.observe)(&state);
    run.outputs.record(&state)?;
    let stats = RunStats {
        steps: 0,
        wall_seconds: wall,
        max_penetration_seen: crate::integrate::max_penetration(model, &state.x),
        max_contacts: 0,
    };
    Ok(Ended { state, stats, timings: Counters::default(), static_report: Some(report), interrupted: false })
}

/// The summary (checked for non-finite numbers), the outputs' last files, then the summary: its presence
/// means the run completed (or, marked `interrupted`, stopped cleanly).
fn complete(
    mut run: Run<'_>,
    mut folder: Folder,
    ended: Ended,
    resumed_from: Option<usize>,
) -> Result<RunOutput, RunError> {
    let scene = run.scene;
    let Ended { state, stats, timings, static_report, interrupted } = ended;
    let final_mesh = display_mesh(&scene.model, &state.x, scene.output.coons_subdivisions);
    let provenance = Provenance::of(scene, run.options, &run.fingerprint, resumed_from);
    let done = Finished { stats, timings, static_report, interrupted, provenance };
    let mut output = RunOutput { summary: summary::summarize(scene, &state, &final_mesh, done), snapshots: Vec::new() };
    run.outputs.report(&mut output);
    if let Some(field) = summary::non_finite(&output.summary) {
        return Err(RunError::NonFinite { stage: format!("the final state (summary field `{field}`)") });
    }
    let path = run.out.join(SUMMARY_FILE);
    let json = serde_json::to_string_pretty(&output.summary)
        .map_err(|e| RunError::Io { path: path.clone(), source: std::io::Error::other(e) })?;
    run.outputs.finish(&output.summary)?;
    atomic::write_atomic(&path, json.as_bytes()).map_err(io_err(&path))?;
    if !interrupted {
        // A finished run needs no checkpoint.
        remove_if_present(&checkpoint::path_in(run.out))?;
        folder.complete()?;
    }
    Ok(output)
}
