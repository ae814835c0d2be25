//! Checkpoint and resume (issue 11): a run stopped at a random step (cleanly, as SIGINT/SIGTERM stop it, or
//! killed outright after a periodic checkpoint) and resumed gives outputs byte-identical to an uninterrupted
//! run: every frame, `energy.csv`, `snapshots.png` and `manifest.json` bit for bit, and `summary.json` equal in
//! everything but the wall-clock times and the provenance. On the ball drop (sphere contact) and on the skirt
//! on the NURBS mannequin, whose contact term warm-starts its closest-point projections from the last step's
//! (patch, u, v): the checkpoint must carry that cache for the resumed steps to be the same.

use flexsurf::integrate::linsolve::SolverKind;
use flexsurf::runner::{run_scene_with, RunOptions};
use flexsurf::scene::{Scene, SceneSpec};
use flexsurf::testing::assert_same_outputs;
use rand::{Rng, SeedableRng};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use flexsurf::testing::repo;

/// A fresh empty directory for one test.
fn scratch(tag: &str) -> flexsurf::testing::ScratchDir {
    flexsurf::testing::scratch("resume", tag)
}

fn scene(file: &str, steps: usize, every: usize, nodes: Option<[usize; 2]>) -> Scene {
    let path = repo().join(file);
    let mut spec = SceneSpec::load(&path).unwrap();
    spec.time.steps = steps;
    spec.time.output_every = Some(every);
    spec.output.image_size = [96, 72];
    if let (Some(n), Some(sheet)) = (nodes, spec.sheet.as_mut().map(flexsurf::scene::Sheets::first_mut)) {
        sheet.nodes = n;
    }
    spec.build(&path).unwrap()
}

/// Stops a run of `s` cleanly after step `k` (as a signal does), resumes it, and compares with `reference`.
fn stop_and_resume(s: &Scene, reference: &Path, dir: &Path, k: usize) {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let options = RunOptions { stop: Some(stop), ..Default::default() };
    let o = run_scene_with(s, dir, &options, |st| flag.store(st.step >= k, Ordering::SeqCst)).unwrap();
    assert!(o.summary.interrupted && o.summary.steps == k, "stopped after step {}", o.summary.steps);
    let o = run_scene_with(s, dir, &RunOptions { resume: true, ..Default::default() }, |_| {}).unwrap();
    assert!(!o.summary.interrupted);
    assert_eq!(o.summary.provenance.resumed_from_step, Some(k));
    assert_same_outputs(reference, dir, &format!("stopped at step {k}"));
}

/// Kills a run of `s` outright after step `k` (a panic unwinds out of the run where the step's outputs are
/// written, as a SIGKILL would leave them) with a checkpoint every `every` steps, resumes it from the last
/// checkpoint, and compares with `reference`.
fn kill_and_resume(s: &Scene, reference: &Path, dir: &Path, k: usize, every: usize) {
    let options = RunOptions { checkpoint_every: Some(every), ..Default::default() };
    let killed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run_scene_with(s, dir, &options, |st| {
            if st.step == k {
                panic!("killed at step {k}");
            }
        })
    }));
    assert!(killed.is_err(), "the run was not killed");
    assert!(!dir.join("summary.json").exists());
    let o = run_scene_with(
        s,
        dir,
        &RunOptions { resume: true, checkpoint_every: Some(every), ..Default::default() },
        |_| {},
    )
    .unwrap();
    // The step-k callback never returned: the last checkpoint is the last multiple of `every` before k.
    assert_eq!(o.summary.provenance.resumed_from_step, Some((k - 1) / every * every));
    assert_same_outputs(reference, dir, &format!("killed at step {k}, checkpoints every {every}"));
}

#[test]
fn ball_drop_resumes_byte_identically_from_random_steps() {
    let s = scene("scenes/ball_drop.toml", 120, 20, Some([13, 13]));
    let d = scratch("ball");
    let reference = d.join("reference");
    run_scene_with(&s, &reference, &RunOptions::default(), |_| {}).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    for round in 0..4 {
        let k = rng.random_range(1..120);
        stop_and_resume(&s, &reference, &d.join(format!("stopped-{round}")), k);
        let every = rng.random_range(1..=30);
        let k = rng.random_range(every + 1..120);
        kill_and_resume(&s, &reference, &d.join(format!("killed-{round}")), k, every);
    }
    // A run with periodic checkpoints writes the same outputs as one without.
    let with = d.join("with-checkpoints");
    run_scene_with(&s, &with, &RunOptions { checkpoint_every: Some(7), ..Default::default() }, |_| {}).unwrap();
    assert_same_outputs(&reference, &with, "periodic checkpoints");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn skirt_on_the_nurbs_mannequin_resumes_byte_identically() {
    let s = scene("scenes/skirt.toml", 40, 10, None);
    let d = scratch("skirt");
    let reference = d.join("reference");
    run_scene_with(&s, &reference, &RunOptions::default(), |_| {}).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
    for round in 0..2 {
        let k = rng.random_range(1..40);
        stop_and_resume(&s, &reference, &d.join(format!("stopped-{round}")), k);
        let every = rng.random_range(2..=12);
        let k = rng.random_range(every + 1..40);
        kill_and_resume(&s, &reference, &d.join(format!("killed-{round}")), k, every);
    }
    std::fs::remove_dir_all(&d).ok();
}

/// A self-contact run (the pile, folding onto the floor) resumed with frames that differed from the
/// uninterrupted run's in the last bits (9e-13 m on the 41² pile after 14 steps): the step matrix keeps the
/// pairs between faces from step to step, in the order they came and with the last assembly's blocks (which of
/// them go at the next prune), and multigrid's coarse levels kept theirs, and a resumed run started with none.
/// The checkpoint now carries the step matrix's ([`flexsurf::integrate::linsolve::SolverWarm::extra`]) and the
/// coarse levels make theirs afresh from it; on Cholesky and on multigrid.
#[test]
fn regression_a_self_contact_run_resumed_in_other_last_bits() {
    let d = scratch("pile");
    // The coarse levels' pairs went stale only on the 41² pile (at 21² and 31², or at twice the step, multigrid
    // resumed exactly before its levels made their pairs afresh).
    for (solver, n, dt, steps, k) in
        [(SolverKind::Cholesky, 21, 0.01, 70, 55), (SolverKind::Multigrid, 41, 0.01, 56, 48)]
    {
        let path = repo().join("scenes/pile.toml");
        let mut spec = SceneSpec::load(&path).unwrap();
        (spec.time.dt, spec.time.steps, spec.time.output_every) = (dt, steps, Some(4));
        spec.output.image_size = [96, 72];
        spec.sheet.as_mut().map(flexsurf::scene::Sheets::first_mut).unwrap().nodes = [n, n];
        spec.integrator.solver = solver;
        let s = spec.build(&path).unwrap();
        let reference = d.join(format!("{solver:?}-reference"));
        run_scene_with(&s, &reference, &RunOptions::default(), |_| {}).unwrap();
        stop_and_resume(&s, &reference, &d.join(format!("{solver:?}-stopped")), k);
    }
    std::fs::remove_dir_all(&d).ok();
}

/// `--resume` of a folder whose run had completed said "checkpoint.bin: cannot read the checkpoint to resume
/// from: No such file or directory", as it did for an empty folder and for a run killed before its first
/// checkpoint; each now says which it is, by the folder's manifest, and the complete run's outputs are untouched.
#[test]
fn regression_resuming_a_complete_run_said_no_such_file() {
    let s = scene("scenes/ball_drop.toml", 4, 2, Some([5, 5]));
    let dir = scratch("complete");
    let resume = RunOptions { resume: true, ..Default::default() };
    let why = |dir: &Path| run_scene_with(&s, dir, &resume, |_| {}).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(why(&dir).contains("there is no run to resume in this folder"), "{}", why(&dir));
    run_scene_with(&s, &dir, &RunOptions::default(), |_| {}).unwrap();
    let summary = std::fs::read(dir.join("summary.json")).unwrap();
    let e = why(&dir);
    assert!(e.contains("is complete: nothing to resume") && e.contains("--overwrite"), "{e}");
    assert_eq!(std::fs::read(dir.join("summary.json")).unwrap(), summary);
    let killed = scratch("killed");
    let kill = std::panic::AssertUnwindSafe(|| run_scene_with(&s, &killed, &RunOptions::default(), |_| panic!()));
    assert!(std::panic::catch_unwind(kill).is_err());
    let e = why(&killed);
    assert!(e.contains("ended before it wrote a checkpoint"), "{e}");
    let other = scene("scenes/ball_drop.toml", 5, 1, Some([5, 5]));
    let e = run_scene_with(&other, &dir, &resume, |_| {}).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(e.contains("a run of another scene or other settings"), "{e}");
}
