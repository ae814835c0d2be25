//! Issue 11 through the binary: broken pipes end quietly with the usual status, SIGINT/SIGTERM stop a run with
//! a checkpoint and exit 130/143, a run killed (SIGTERM or SIGKILL) at a random moment resumes to outputs
//! byte-identical to an uninterrupted run, output folders are refused or overwritten safely, and extreme
//! command-line values are errors.

use flexsurf::testing::{assert_same_outputs, files};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_flexsurf");

use flexsurf::testing::repo;

/// A fresh empty directory for one test.
fn scratch(tag: &str) -> flexsurf::testing::ScratchDir {
    flexsurf::testing::scratch("cli-hardening", tag)
}

fn flexsurf(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(BIN).args(args).output().expect("run flexsurf");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.code().unwrap_or(-1), text(&out.stdout), text(&out.stderr))
}

/// Runs `args` with standard output a pipe whose reader has already gone; returns the exit code and stderr.
fn with_closed_stdout(args: &[&str]) -> (i32, String) {
    let mut child = Command::new(BIN).args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    drop(child.stdout.take());
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    (child.wait().unwrap().code().unwrap_or(-1), err)
}

#[test]
fn regression_broken_pipe_panicked() {
    let d = scratch("pipe");
    let scene = repo().join("scenes/ball_drop.toml");
    let scene = scene.to_str().unwrap();
    let out = d.join("out");
    let kes = d.join("kes");
    for args in [
        vec!["check", scene],
        vec!["schema"],
        vec!["run", scene, "--out", out.to_str().unwrap(), "--steps", "3"],
        vec!["test", "kes", "--json", "--out", kes.to_str().unwrap()],
    ] {
        let (code, err) = with_closed_stdout(&args);
        assert_eq!(code, 0, "{args:?}: {err}");
        assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{args:?}: {err}");
    }
    assert!(out.join("summary.json").exists(), "the run's outputs are written all the same");
}

/// Runs `command` with each case's options: each must fail with status 1 within seconds, its message naming
/// the case's options and containing `expect`, neither an aborted allocation nor a panic.
fn refused(command: &[&str], cases: &[(Vec<&str>, &str)], expect: &str) {
    let t = Instant::now();
    for (args, names) in cases {
        let all: Vec<&str> = command.iter().chain(args).copied().collect();
        let (code, _, err) = flexsurf(&all);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(err.contains(names) && err.contains(expect), "{args:?}: {err}");
        assert!(!err.contains("memory allocation") && !err.contains("panicked"), "{args:?}: {err}");
    }
    assert!(t.elapsed() < Duration::from_secs(20), "refused in {:?}", t.elapsed());
}

/// `flexsurf test cusick --specimen 1e9` (whose default grid then has 1e11 rings) and `--grid 100000,100000`
/// aborted the process on a failed allocation of hundreds of terabytes, and ten 5 m specimens draped at once
/// asked for 9.7 GiB; each is now an error naming the options and the estimated memory, before any specimen is
/// built, and the same grids through the library ([`flexsurf::lab::cusick`]) are errors too.
#[test]
fn regression_a_huge_cusick_grid_aborted_on_allocation() {
    let d = scratch("cusick-size");
    let out = d.join("out");
    let out = out.to_str().unwrap();
    let cases = [
        (vec!["--specimen", "1e9"], "--specimen, --level, --specimens"),
        (vec!["--grid", "100000,100000"], "--specimen, --grid, --specimens"),
        (vec!["--grid", "18446744073709551615,8"], "--specimen, --grid, --specimens"),
        (vec!["--specimen", "5", "--specimens", "10"], "--specimen, --level, --specimens"),
    ];
    refused(&["test", "cusick", "--out", out], &cases, "more than the limit of 4.0 GiB");
    assert!(!Path::new(out).exists(), "nothing written");
    use flexsurf::lab::cusick::{cusick_specimen, specimen_memory, PolarGrid};
    use flexsurf::material::{Calibration, Fabric};
    let fabric = Fabric::paper_cotton();
    let e = match cusick_specimen(&fabric, Calibration::Kes, 0.3, 100_000, 100_000, 0) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a 100000 x 100000 grid was draped"),
    };
    assert!(e.contains("memory"), "{e}");
    // A standard specimen's default grid (14 x 144 nodes) needs some tens of megabytes.
    let grid = PolarGrid { radial: 12, angular: 144, grading: 1.0 };
    let bytes = specimen_memory(0.3, grid, 3).unwrap();
    assert!((1 << 20..1 << 30).contains(&bytes), "{bytes}");
}

/// `flexsurf bench --steps 100000000000` aborted on allocating its step times up front (800 GB), `--threads
/// 100000` sat starting a pool of 100,000 threads, and `--steps 0` printed a row of zeros; each is now an error
/// naming the option (and the library's `bench::run` refuses such a step count too).
#[test]
fn regression_bench_step_and_thread_counts_aborted_or_stalled() {
    let cases = [
        (vec!["--steps", "100000000000"], "--steps"),
        (vec!["--steps", "0"], "--steps"),
        (vec!["--repeat", "0"], "--repeat"),
        (vec!["--threads", "100000"], "--threads"),
        (vec!["--threads", "0"], "--threads"),
    ];
    refused(&["bench", "--sizes", "21"], &cases, "must be between 1 and");
    let e =
        flexsurf::bench::run(21, 0, flexsurf::bench::Workload::Drop, flexsurf::integrate::linsolve::SolverKind::Auto)
            .unwrap_err();
    assert!(e.to_string().contains("0 steps"), "{e}");
}

/// `flexsurf bench --sizes 5000` (25 million nodes, within the side's cap of 10,000) built the scene without a
/// memory budget and grew until the machine's memory ran out (6.8 GB in 9 s, aborted on allocation under an 8 GB
/// limit); a size is now refused before it is built where its estimated model, step matrix and solver exceed
/// `--max-memory` (4 GiB by default, as for a run; frames and pictures are left out, which a benchmark does not
/// keep), naming the estimate and the option, and `--max-memory` lets it through.
#[test]
fn regression_bench_of_a_huge_size_ran_out_of_memory() {
    let cases = [
        (vec!["--sizes", "5000"], "200.2 GiB"),
        (vec!["--sizes", "1001"], "8.0 GiB"),
        (vec!["--sizes", "321", "--max-memory", "100M"], "limit of 100.0 MiB"),
        (vec!["--workload", "pile", "--sizes", "2000"], "32.0 GiB"),
    ];
    refused(&["bench", "--steps", "1", "--repeat", "1"], &cases, "(raise it with --max-memory)");
    let (code, out, err) = flexsurf(&["bench", "--sizes", "21", "--steps", "1", "--repeat", "1", "--max-memory", "1G"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("21x21"), "{out}");
    let e = flexsurf::bench::run_within(
        5000,
        1,
        flexsurf::bench::Workload::Drop,
        flexsurf::integrate::linsolve::SolverKind::Auto,
        4 << 30,
    )
    .unwrap_err();
    assert!(e.to_string().contains("`sheet.nodes`") && !e.to_string().contains("frames"), "{e}");
}

/// `flexsurf bench --sizes 0` (or 2, or 100000) was refused in the words of the embedded scene
/// (`scenes/ball_drop.toml: sheet.nodes: direction u1 has 0 nodes`), not of the option the user gave.
#[test]
fn regression_bench_sizes_were_refused_in_the_embedded_scene_s_words() {
    let cases = [
        (vec!["--sizes", "0"], "--sizes: 0"),
        (vec!["--sizes", "21,2"], "--sizes: 2"),
        (vec!["--sizes", "100000"], "--sizes: 100000"),
    ];
    refused(&["bench"], &cases, "must be between 3 and 10000");
}

/// `flexsurf demo --steps 0` was refused as "ball_drop.toml (embedded): `time.steps`: must be at least 1", a file
/// and a key the user never wrote, and `run --steps 0` blamed the scene file's `time.steps`; both now name the flag.
#[test]
fn regression_demo_steps_0_was_refused_in_the_embedded_scene_s_words() {
    let scene = repo().join("scenes/ball_drop.toml");
    let out = std::env::temp_dir().join(format!("flexsurf-steps-flag-{}", std::process::id()));
    let out = out.to_str().unwrap();
    for command in [vec!["demo", "--out", out], vec!["run", scene.to_str().unwrap(), "--out", out]] {
        let cases = [(vec!["--steps", "0"], "--steps: 0"), (vec!["--steps", "2000000000"], "--steps: 2000000000")];
        refused(&command, &cases, "must be between 1 and 1000000000");
    }
    assert!(!std::path::Path::new(out).exists(), "a refused run wrote {out}");
}

#[test]
fn regression_cantilever_overhang_1e308_printed_nan() {
    let (code, _, err) = flexsurf(&["test", "cantilever", "--overhang", "1e308"]);
    assert_eq!(code, 1);
    assert!(err.contains("--overhang") && err.contains("at most 10 m"), "{err}");
}

#[test]
fn max_memory_refuses_and_admits() {
    let scene = repo().join("scenes/ball_drop.toml");
    let scene = scene.to_str().unwrap();
    let (code, _, err) = flexsurf(&["check", scene, "--max-memory", "1M"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("`sheet.nodes`") && err.contains("--max-memory"), "{err}");
    let (code, out, err) = flexsurf(&["check", scene, "--max-memory", "2G"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("ok"));
    let (code, _, err) = flexsurf(&["check", scene, "--max-memory", "lots"]);
    assert_eq!(code, 2, "{err}");
}

/// A small, fast copy of the ball drop (13 × 13 nodes, 150 steps).
fn small_drop(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("scenes/ball_drop.toml")).unwrap();
    let text = text
        .replace("nodes = [21, 21]", "nodes = [13, 13]")
        .replace("steps = 300", "steps = 150")
        .replace("output_every = 100", "output_every = 25")
        .replace("image_size = [480, 360]", "image_size = [96, 72]");
    let path = dir.join("drop.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Sends `signal` (a `kill` name) to `pid` with the system's `kill` (no `unsafe` here).
fn kill(signal: &str, pid: u32) {
    let _ = Command::new("kill").args([&format!("-{signal}"), &pid.to_string()]).status();
}

/// Starts `command` (a `flexsurf run` writing to `out`), waits until it steps (its `energy.csv` appears), then
/// `after`, and sends it `signal`. Returns whether it was still running when signalled, its exit status and its
/// standard error.
fn signalled(mut command: Command, out: &Path, after: Duration, signal: &str) -> (bool, ExitStatus, String) {
    let mut child = command.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let started = Instant::now();
    while !out.join("energy.csv").exists() && started.elapsed() < Duration::from_secs(30) {
        std::thread::sleep(Duration::from_millis(2));
    }
    std::thread::sleep(after);
    let running = child.try_wait().unwrap().is_none();
    kill(signal, child.id());
    let status = child.wait().unwrap();
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    (running, status, err)
}

/// `flexsurf run` started the way a shell script starts a background job (`flexsurf run … &`: SIGINT
/// ignored, here by `trap '' INT` before `exec`) keeps ignoring SIGINT, as the shell's own commands do: a
/// SIGINT sent while it steps leaves it running to its normal end; SIGTERM still stops it.
#[cfg(unix)]
#[test]
fn a_run_started_with_sigint_ignored_keeps_ignoring_it() {
    let d = scratch("ignored");
    let text = std::fs::read_to_string(small_drop(&d)).unwrap();
    // Long enough (about a second here) for the signal to arrive while it steps; one frame at the end.
    let text = text.replace("steps = 150", "steps = 2000").replace("output_every = 25", "output_every = 2000");
    let scene = d.join("long.toml");
    std::fs::write(&scene, text).unwrap();
    let run = |tag: &str, signal: &str| {
        let out = d.join(tag);
        let mut sh = Command::new("sh");
        sh.args(["-c", "trap '' INT; exec \"$0\" \"$@\"", BIN, "run", scene.to_str().unwrap()]);
        sh.args(["--out", out.to_str().unwrap()]);
        let (running, status, err) = signalled(sh, &out, Duration::from_millis(100), signal);
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        (running, status.code(), summary["interrupted"].clone(), err)
    };
    let (running, code, interrupted, err) = run("int", "INT");
    assert!(running, "the run ended before the signal: the test proves nothing ({err})");
    assert_eq!((code, interrupted), (Some(0), serde_json::Value::Bool(false)), "{err}");
    let (running, code, interrupted, err) = run("term", "TERM");
    assert!(running, "the run ended before the signal: the test proves nothing ({err})");
    assert_eq!((code, interrupted), (Some(143), serde_json::Value::Bool(true)), "{err}");
    std::fs::remove_dir_all(&d).ok();
}

#[cfg(unix)]
#[test]
fn killed_at_random_moments_the_run_resumes_byte_identically() {
    let d = scratch("kill");
    let scene = small_drop(&d);
    let scene = scene.to_str().unwrap();
    let reference = d.join("reference");
    let t = Instant::now();
    let (code, _, err) = flexsurf(&["run", scene, "--out", reference.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let full = t.elapsed();
    // Deterministic "random" moments spread over the run (a small LCG; no clock in the choice).
    let mut x: u64 = 0x2545_F491_4F6C_DD1D;
    let mut next = || {
        x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (x >> 33) as f64 / (1u64 << 31) as f64
    };
    let mut interrupted = 0;
    for (round, signal) in ["TERM", "INT", "KILL", "TERM", "KILL", "INT"].iter().enumerate() {
        let out = d.join(format!("run-{round}"));
        let mut run = Command::new(BIN);
        run.args(["run", scene, "--out", out.to_str().unwrap(), "--checkpoint-every", "10"]);
        // A random part of its duration after it starts stepping.
        let (_, status, err) = signalled(run, &out, full.mul_f64(0.1 + 0.6 * next()), signal);
        let finished_first = status.code() == Some(0);
        match (*signal, finished_first) {
            (_, true) => {} // the run ended before the signal; nothing to resume
            ("TERM", false) => {
                assert_eq!(status.code(), Some(143), "{err}");
                let s: serde_json::Value =
                    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
                assert_eq!(s["interrupted"], true);
                assert!(err.contains("--resume"), "{err}");
            }
            ("INT", false) => assert_eq!(status.code(), Some(130), "{err}"),
            _ => assert!(status.code().is_none(), "SIGKILL: {status:?}"),
        }
        if !finished_first {
            interrupted += 1;
            let (code, _, err) =
                flexsurf(&["run", scene, "--resume", out.to_str().unwrap(), "--checkpoint-every", "10"]);
            if code != 0 && err.contains("checkpoint.bin") && *signal == "KILL" {
                // Killed before its first checkpoint: nothing to resume; a new run needs --overwrite.
                let (code, _, err) = flexsurf(&["run", scene, "--out", out.to_str().unwrap(), "--overwrite"]);
                assert_eq!(code, 0, "{err}");
            } else {
                assert_eq!(code, 0, "{signal} round {round}: {err}");
            }
        }
        assert_same_outputs(&reference, &out, &format!("round {round} ({signal})"));
    }
    assert!(interrupted >= 3, "only {interrupted} of 6 runs were stopped before they ended: the test proves nothing");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn output_folders_are_refused_or_overwritten_safely() {
    let d = scratch("folders");
    let scene = small_drop(&d);
    let scene = scene.to_str().unwrap();
    let out = d.join("out");
    let o = out.to_str().unwrap();
    assert_eq!(flexsurf(&["run", scene, "--out", o, "--steps", "7"]).0, 0);
    let (code, _, err) = flexsurf(&["run", scene, "--out", o, "--steps", "3"]);
    assert_eq!(code, 1);
    assert!(err.contains("holds the outputs of another run") && err.contains("--overwrite"), "{err}");
    std::fs::write(out.join("keep.txt"), "mine").unwrap();
    let (code, _, err) = flexsurf(&["run", scene, "--out", o, "--steps", "3", "--overwrite"]);
    assert_eq!(code, 0, "{err}");
    assert!(files(&out).contains(&"keep.txt".to_string()));
    assert!(!out.join("frames/frame_00007.obj").exists());
    // --resume with nothing to resume, and --out with --resume, are errors.
    let (code, _, err) = flexsurf(&["run", scene, "--resume", o]);
    assert_eq!(code, 1, "{err}");
    let (code, _, _) = flexsurf(&["run", scene, "--resume", o, "--out", o]);
    assert_eq!(code, 2);
    std::fs::remove_dir_all(&d).ok();
}
