//! A seeded mutation fuzzer over the shipped inputs (issue 11), on stable Rust and in-process on the library's
//! `check` path (read, parse, validate and build a scene), with a short run (2 steps, written into a scratch
//! folder) for one in [`RUN_EVERY`] inputs (those that build). A panic, a non-finite summary or an input slower
//! than [`SLOW_SECONDS`] is a finding: it is written to `target/fuzz-findings/` and fails the test. A true hang
//! is caught by a watchdog thread that writes the input and exits the process; an abort (an allocation the
//! resource estimate should have refused) ends the process, and the campaign is reproducible from the seed and
//! the input number it printed last.
//!
//! The corpus: the shipped scenes, materials, NURBS body, garment patterns and fit files, plus `fuzz/corpus/` in
//! the repository (a small OBJ
//! mesh and scenes around each bug class the fuzzer found: non-ASCII keys, byte-order marks, huge counts,
//! extreme numbers). Each input is one of them mutated 1–6 times (bytes flipped, inserted, deleted, ranges
//! duplicated or spliced from another corpus file, numbers replaced by extreme ones, tokens inserted); a
//! mutated material, body, mesh or pattern file is checked through a scene that references it (a pattern's
//! with two sewing steps), so errors inside referenced files are exercised too; a fit file is read and checked,
//! not fitted. `FLEXSURF_FUZZ_DUMP=1` writes every input to the temporary folder as `fuzz-input-N`.
//!
//! A plain `cargo test` runs it for 10 s, CI (`.ci/run`) for 60 s more. A long campaign (docs/testing.md):
//!
//! ```text
//! FLEXSURF_FUZZ_SECONDS=3600 FLEXSURF_FUZZ_INPUTS=1000000 FLEXSURF_FUZZ_SEED=1 \
//!     nice -n 19 cargo test --profile ci -p flexsurf --test suite fuzz::mutation_fuzz -- --nocapture
//! ```

use flexsurf::scene::{Limits, SceneSpec};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// One input in this many (drawn per input) is also run for 2 steps if it builds.
const RUN_EVERY: u64 = 64;
/// An input slower than this (s) is a finding.
const SLOW_SECONDS: f64 = 20.0;
/// The watchdog ends the process after this (s) on one input.
const HANG_SECONDS: u64 = 120;

use flexsurf::testing::repo;

/// What a corpus file is, so a mutated copy is checked the right way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Scene,
    Material,
    Body,
    Mesh,
    /// A garment pattern file, through a scene that sews it (no body).
    Pattern,
    /// A fit file, read and checked (not fitted: a fit takes seconds to minutes).
    Fit,
}

struct Seed {
    name: String,
    role: Role,
    bytes: Vec<u8>,
    /// How often it is picked relative to the others: the mannequin's inputs (the built-in body's skirt
    /// scenes, 70–400 ms to build, and the 60 kB body file) less often than the rest (1–10 ms).
    weight: u32,
}

fn corpus() -> Vec<Seed> {
    let root = repo();
    let mut seeds = Vec::new();
    let mut add = |dir: &Path, role: Role, ext: &str| {
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|d| d.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == ext)).collect())
            .unwrap_or_default();
        files.sort();
        for p in files {
            // The fine skirt is the skirt at 4× the nodes (400 ms a build): the skirt stands for it.
            if p.file_stem().is_some_and(|s| s.to_string_lossy().ends_with("_fine")) {
                continue;
            }
            let bytes = std::fs::read(&p).unwrap();
            let heavy = String::from_utf8_lossy(&bytes).contains("mannequin") || bytes.len() > 16 * 1024;
            // Patterns build several panels, their seams and sewing (10–100 ms): as the mannequin's inputs.
            let heavy = heavy || role == Role::Pattern;
            seeds.push(Seed { name: p.display().to_string(), role, bytes, weight: if heavy { 1 } else { 8 } });
        }
    };
    add(&root.join("scenes"), Role::Scene, "toml");
    add(&root.join("materials"), Role::Material, "toml");
    add(&root.join("bodies"), Role::Body, "toml");
    add(&root.join("fuzz/corpus/scenes"), Role::Scene, "toml");
    add(&root.join("fuzz/corpus/materials"), Role::Material, "toml");
    add(&root.join("fuzz/corpus/meshes"), Role::Mesh, "obj");
    add(&root.join("garments"), Role::Pattern, "toml");
    add(&root.join("fuzz/corpus/patterns"), Role::Pattern, "toml");
    add(&root.join("examples/fit"), Role::Fit, "toml");
    // A fit file names its material relative to itself: the mutated copy is written elsewhere.
    let materials = format!("{:?}", root.join("materials").display().to_string());
    for seed in seeds.iter_mut().filter(|s| s.role == Role::Fit) {
        let text = String::from_utf8_lossy(&seed.bytes).replace("\"../../materials", &materials[..materials.len() - 1]);
        seed.bytes = text.into_bytes();
    }
    assert!(seeds.len() >= 12, "the fuzz corpus is missing files: {} found", seeds.len());
    seeds
}

/// Numbers and tokens that probe the edges.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "3",
    "21",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "5e-324",
    "1e-308",
    "1e18",
    "-1e18",
    "9223372036854775807",
    "-9223372036854775808",
    "4294967296",
    "65536",
    "100000",
    "nan",
    "inf",
    "-inf",
    "0.0",
    "1e-9",
    "1e9",
    "0x7fffffff",
    "18446744073709551615",
    "1e400",
    "3.5",
];
const TOKENS: &[&str] = &[
    "\u{feff}",
    "é",
    "ß",
    "\u{1F600}",
    "=",
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    "\"",
    "'",
    ",",
    ".",
    "#",
    "\n",
    "\t",
    " ",
    "\\",
    "\"\"\"",
    "[[obstacle]]\n",
    "[sheet]\n",
    "[time]\n",
    "[garment]\n",
    "[material]\n",
    "nodes = [9223372036854775807, 21]\n",
    "nodes = [4294967296, 21]\n",
    "file = \"/dev/zero\"\n",
    "file = \".\"\n",
    "preset = \"paper-cotton\"\n",
    "units = \"kes\"\n",
    "units = \"fast\"\n",
    "topology = [\"periodic\", \"free\"]\n",
    "kind = \"static\"\n",
    "kind = \"lagged\"\n",
    "solver = \"pcg\"\n",
    "sphere = { center = [0, 0, 0], radius = 0.3 }\n",
    "mesh = { file = \"cube.obj\" }\n",
    "nurbs = { builtin = \"mannequin\" }\n",
    "nurbs = { file = \"body.toml\" }\n",
    "set = \"all\"\n",
    "f 1 2 3\n",
    "v 1e308 0 0\n",
    "v nan 0 0\n",
    "f -1 -2 -3\n",
    "f 0 1 2\n",
];

fn pick<'a>(rng: &mut ChaCha8Rng, list: &'a [&'a str]) -> &'a str {
    list[rng.random_range(0..list.len())]
}

/// Byte ranges of the numbers in `b` (ASCII digits with sign, point and exponent).
fn numbers(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() {
            let mut s = i;
            if s > 0 && (b[s - 1] == b'-' || b[s - 1] == b'+') {
                s -= 1;
            }
            let mut e = i;
            while e < b.len()
                && (b[e].is_ascii_alphanumeric() || b[e] == b'.' || b[e] == b'-' || b[e] == b'+' || b[e] == b'_')
            {
                e += 1;
            }
            out.push((s, e));
            i = e;
        } else {
            i += 1;
        }
    }
    out
}

fn mutate(rng: &mut ChaCha8Rng, input: &mut Vec<u8>, others: &[Seed]) {
    let rounds = rng.random_range(1..=6);
    for _ in 0..rounds {
        let len = input.len();
        match rng.random_range(0..10) {
            // Replace a number by an extreme one (the most productive mutation).
            0..=2 => {
                let nums = numbers(input);
                if let Some(&(s, e)) = nums.get(rng.random_range(0..nums.len().max(1))) {
                    input.splice(s..e, pick(rng, NUMBERS).bytes());
                }
            }
            3 => {
                let at = rng.random_range(0..=len);
                input.splice(at..at, pick(rng, TOKENS).bytes());
            }
            4 if len > 0 => {
                let at = rng.random_range(0..len);
                input[at] ^= 1 << rng.random_range(0..8);
            }
            5 => {
                let at = rng.random_range(0..=len);
                input.insert(at, rng.random());
            }
            6 if len > 0 => {
                let s = rng.random_range(0..len);
                let e = (s + rng.random_range(1..=16)).min(len);
                input.drain(s..e);
            }
            7 if len > 0 => {
                let s = rng.random_range(0..len);
                let e = (s + rng.random_range(1..=64)).min(len);
                let copy = input[s..e].to_vec();
                let at = rng.random_range(0..=input.len());
                input.splice(at..at, copy);
            }
            8 => {
                let other = &others[rng.random_range(0..others.len())].bytes;
                if !other.is_empty() {
                    let s = rng.random_range(0..other.len());
                    let e = (s + rng.random_range(1..=128)).min(other.len());
                    let at = rng.random_range(0..=input.len());
                    input.splice(at..at, other[s..e].iter().copied());
                }
            }
            _ => {
                // Duplicate or drop a whole line.
                let lines: Vec<usize> = std::iter::once(0)
                    .chain(input.iter().enumerate().filter(|(_, &b)| b == b'\n').map(|(i, _)| i + 1))
                    .collect();
                let l = lines[rng.random_range(0..lines.len())];
                let end = input[l..].iter().position(|&b| b == b'\n').map_or(input.len(), |p| l + p + 1);
                if rng.random() {
                    let copy = input[l..end].to_vec();
                    input.splice(l..l, copy);
                } else {
                    input.drain(l..end);
                }
            }
        }
        if input.len() > 256 * 1024 {
            input.truncate(256 * 1024);
        }
    }
}

/// Scenes that reference the mutated file of each role (written as `material.toml`, `body.toml`, `mesh.obj`;
/// `cube.obj`, referenced by corpus scenes, stays as it is).
const MATERIAL_SCENE: &str =
    "[sheet]\nsize = [0.5, 0.5]\nnodes = [5, 5]\n[material]\nfile = \"material.toml\"\n[time]\nsteps = 2\n";
const BODY_SCENE: &str = "[sheet]\nsize = [0.5, 0.5]\nnodes = [5, 5]\ncenter = [0, 0, 1.5]\n[time]\nsteps = 2\n[[obstacle]]\nnurbs = { file = \"body.toml\" }\n";
const MESH_SCENE: &str = "[sheet]\nsize = [0.5, 0.5]\nnodes = [5, 5]\ncenter = [0, 0, 1.5]\n[time]\nsteps = 2\n[[obstacle]]\nmesh = { file = \"mesh.obj\" }\n[contact]\nfaces = true\n";
/// The pattern scene's ball, far below the shipped garments, is what `fuzz/corpus/patterns/wrapped.toml` wraps
/// onto (`onto_body`).
const PATTERN_SCENE: &str = "[pattern]\nfile = \"pattern.toml\"\nsewing_steps = 2\n[time]\nsteps = 2\n\
                             [[obstacle]]\nsphere = { center = [0.0, 0.0, -5.0], radius = 0.1 }\n";

struct Findings {
    dir: PathBuf,
    list: Vec<String>,
}

impl Findings {
    fn add(&mut self, what: String, role: Role, input: &[u8]) {
        let _ = std::fs::create_dir_all(&self.dir);
        let path =
            self.dir.join(format!("finding-{}.{}", self.list.len(), if role == Role::Mesh { "obj" } else { "toml" }));
        let _ = std::fs::write(&path, input);
        self.list.push(format!("{what} ({role:?} input saved as {})", path.display()));
    }
}

/// Checks one input; `Err` describes a finding. A mutated scene is written as `scene.toml`, a mutated
/// referenced file under its name beside the fixed scene that references it (`material.toml` and
/// `material-scene.toml`, …).
fn check_one(dir: &Path, role: Role, input: &[u8], run: bool) -> Result<bool, String> {
    let limits = Limits { max_memory: 256 << 20, ..Limits::default() };
    let (file, scene, scene_name) = match role {
        Role::Scene => ("scene.toml", "", "scene.toml"),
        Role::Material => ("material.toml", MATERIAL_SCENE, "material-scene.toml"),
        Role::Body => ("body.toml", BODY_SCENE, "body-scene.toml"),
        Role::Mesh => ("mesh.obj", MESH_SCENE, "mesh-scene.toml"),
        Role::Pattern => ("pattern.toml", PATTERN_SCENE, "pattern-scene.toml"),
        Role::Fit => return check_fit_file(dir, input),
    };
    std::fs::write(dir.join(file), input).map_err(|e| e.to_string())?;
    let scene_path = dir.join(scene_name);
    if role != Role::Scene && !scene_path.exists() {
        std::fs::write(&scene_path, scene).map_err(|e| e.to_string())?;
    }
    let outcome = std::panic::catch_unwind(|| {
        let built = flexsurf::scene::load_with(&scene_path, &limits);
        let Ok(mut scene) = built else {
            let e = built.err().map(|e| e.to_string()).unwrap_or_default();
            // Every error names the file it is about.
            if !e.contains("scene.toml") && !e.contains(".toml") && !e.contains(".obj") {
                return Err(format!("an error names no file: {e}"));
            }
            return Ok(false);
        };
        if run {
            scene.steps = scene.steps.min(2);
            scene.output.image_size = [32, 24];
            scene.output.coons_subdivisions = scene.output.coons_subdivisions.min(2);
            let out = dir.join("out");
            let options = flexsurf::runner::RunOptions { overwrite: true, ..Default::default() };
            if let Ok(o) = flexsurf::runner::run_scene_with(&scene, &out, &options, |_| {}) {
                if !o.summary.final_state.max_z.is_finite() {
                    return Err("a run succeeded with a non-finite result".into());
                }
            }
        }
        Ok(true)
    });
    caught(outcome)
}

/// A check's outcome, a panic caught in it as a finding with its message.
fn caught(outcome: std::thread::Result<Result<bool, String>>) -> Result<bool, String> {
    outcome.unwrap_or_else(|payload| {
        let msg = payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "(no message)".into());
        Err(format!("panic: {msg}"))
    })
}

/// Checks a mutated fit file: read and checked without a panic, an error naming the file.
fn check_fit_file(dir: &Path, input: &[u8]) -> Result<bool, String> {
    let path = dir.join("fit.toml");
    std::fs::write(&path, input).map_err(|e| e.to_string())?;
    let outcome = std::panic::catch_unwind(|| match flexsurf::lab::fit::input::load_fit_file(&path) {
        Ok(_) => Ok(true),
        Err(e) if e.to_string().contains("fit.toml") => Ok(false),
        Err(e) => Err(format!("an error names no file: {e}")),
    });
    caught(outcome)
}

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

#[test]
fn mutation_fuzz_of_the_shipped_inputs() {
    // 10 s in a plain `cargo test`; `.ci/run` runs a 60 s stage of its own.
    let seconds = env_u64("FLEXSURF_FUZZ_SECONDS").unwrap_or(10);
    let max_inputs = env_u64("FLEXSURF_FUZZ_INPUTS").unwrap_or(u64::MAX);
    let seed = env_u64("FLEXSURF_FUZZ_SEED").unwrap_or(11);
    let start_at = env_u64("FLEXSURF_FUZZ_START").unwrap_or(0);
    let seeds = corpus();
    let total_weight: u32 = seeds.iter().map(|s| s.weight).sum();
    let dir = std::env::temp_dir().join(format!("flexsurf-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    beside(&dir);
    let findings_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/fuzz-findings");
    let mut findings = Findings { dir: findings_dir.clone(), list: Vec::new() };

    quiet_panics_here();
    // Watchdog: the start time (ms since `t0`) of the input in progress, and the input itself.
    let t0 = Instant::now();
    let busy_since = Arc::new(AtomicU64::new(u64::MAX));
    let current: Arc<Mutex<(u64, Vec<u8>)>> = Arc::new(Mutex::new((0, Vec::new())));
    watch(t0, Arc::clone(&busy_since), Arc::clone(&current), findings_dir.clone());

    let deadline = Instant::now() + Duration::from_secs(seconds);
    let (mut inputs, mut built, mut runs) = (0u64, 0u64, 0u64);
    let mut slowest = (0.0f64, 0u64, String::new());
    let mut n = start_at;
    let dump = std::env::var("FLEXSURF_FUZZ_DUMP").is_ok();
    while Instant::now() < deadline && inputs < max_inputs {
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ n);
        let s = seed_at(&seeds, rng.random_range(0..total_weight));
        let mut input = s.bytes.clone();
        // One input in 32 is a seed as it is (the corpus itself must stay clean).
        if rng.random_range(0..32) != 0 {
            mutate(&mut rng, &mut input, &seeds);
        }
        if let Ok(mut c) = current.lock() {
            *c = (n, input.clone());
        }
        // Drawn from the input's own generator: an input is run or not whatever came before it.
        let run = rng.random_range(0..RUN_EVERY) == 0;
        let t = Instant::now();
        busy_since.store(t0.elapsed().as_millis() as u64, Ordering::SeqCst);
        if dump {
            let _ = std::fs::write(std::env::temp_dir().join(format!("fuzz-input-{n}")), &input);
        }
        match check_one(&dir, s.role, &input, run) {
            Ok(true) => {
                built += 1;
                runs += u64::from(run);
            }
            Ok(false) => {}
            Err(what) => findings.add(format!("input {n} (from {}): {what}", s.name), s.role, &input),
        }
        busy_since.store(u64::MAX, Ordering::SeqCst);
        let secs = t.elapsed().as_secs_f64();
        if secs > slowest.0 {
            slowest = (secs, n, s.name.clone());
        }
        if secs > SLOW_SECONDS {
            findings.add(format!("input {n} (from {}) took {secs:.1} s", s.name), s.role, &input);
        }
        inputs += 1;
        n += 1;
        if inputs % 50_000 == 0 {
            eprintln!(
                "fuzz: {inputs} inputs ({built} built, {runs} run), {:.0} s, next input {n}",
                t0.elapsed().as_secs_f64()
            );
        }
    }
    let _ = std::panic::take_hook();
    let elapsed = t0.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!(
        "fuzz: seed {seed}, inputs {start_at}..{n}: {inputs} inputs in {elapsed:.1} s ({:.0}/s), {built} built, {runs} \
         run for 2 steps, slowest {:.3} s (input {}, from {}), {} finding(s)",
        inputs as f64 / elapsed.max(1e-9),
        slowest.0,
        slowest.1,
        slowest.2,
        findings.list.len()
    );
    assert!(inputs > 0, "the fuzzer ran no input");
    assert!(findings.list.is_empty(), "fuzz findings:\n{}", findings.list.join("\n"));
}

/// Panics are findings, caught and reported; the default hook's messages would only clutter the log. Only this
/// thread's: the other tests of the binary run beside it and keep their messages.
fn quiet_panics_here() {
    let (fuzzing, default_hook) = (std::thread::current().id(), std::panic::take_hook());
    std::panic::set_hook(Box::new(move |info| {
        if std::thread::current().id() != fuzzing {
            default_hook(info);
        }
    }));
}

/// The watchdog of a campaign: a thread that, when the input in progress (started at `busy_since` ms after `t0`,
/// `u64::MAX` while none is) has run for more than [`HANG_SECONDS`], saves it (`current`) as `hang.toml` in
/// `findings_dir` and ends the process.
fn watch(t0: Instant, busy_since: Arc<AtomicU64>, current: Arc<Mutex<(u64, Vec<u8>)>>, findings_dir: PathBuf) {
    std::thread::spawn(move || loop {
        std::thread::sleep(Duration::from_secs(1));
        let since = busy_since.load(Ordering::SeqCst);
        if since != u64::MAX && t0.elapsed().as_millis() as u64 > since + HANG_SECONDS * 1000 {
            let (n, input) = current.lock().map(|c| c.clone()).unwrap_or_default();
            let _ = std::fs::create_dir_all(&findings_dir);
            let _ = std::fs::write(findings_dir.join("hang.toml"), &input);
            eprintln!(
                "fuzz: input {n} ran for more than {HANG_SECONDS} s (a hang); saved as target/fuzz-findings/hang.toml"
            );
            std::process::exit(3);
        }
    });
}

/// The seed whose share of the corpus's summed weights holds `at`.
fn seed_at(seeds: &[Seed], mut at: u32) -> &Seed {
    seeds
        .iter()
        .find(|s| {
            let here = at < s.weight;
            at = at.saturating_sub(s.weight);
            here
        })
        .unwrap_or(&seeds[0])
}

/// The files corpus scenes name, copied into the fuzz folder `dir`: `cube.obj` and the pattern `wrapped.toml`
/// (a mutated scene or referenced file is written beside them under another name).
fn beside(dir: &Path) {
    std::fs::copy(repo().join("fuzz/corpus/meshes/cube.obj"), dir.join("cube.obj")).unwrap();
    std::fs::copy(repo().join("fuzz/corpus/patterns/wrapped.toml"), dir.join("wrapped.toml")).unwrap();
}

/// The corpus itself checks cleanly (each seed builds or fails with an error, none panics) and every shipped
/// scene builds.
#[test]
fn the_corpus_checks_cleanly() {
    let dir = std::env::temp_dir().join(format!("flexsurf-fuzz-corpus-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    beside(&dir);
    for s in corpus() {
        let t = Instant::now();
        let result = check_one(&dir, s.role, &s.bytes, false);
        eprintln!("{:>9.3} ms  {:?}  {}", 1e3 * t.elapsed().as_secs_f64(), result, s.name);
        assert!(result.is_ok(), "{}: {result:?}", s.name);
        // A `[pattern]` scene's pattern file is not beside the copy (and its sewing phase is too slow to fuzz),
        // nor are the files a scene names in the repository's other folders (`"../bodies/table.obj"`).
        let text = String::from_utf8_lossy(&s.bytes);
        let pattern = text.contains("[pattern]");
        let elsewhere = text.lines().any(|l| !l.trim_start().starts_with('#') && l.contains("\"../"));
        if s.name.contains("/scenes/") && !s.name.contains("fuzz") && !pattern && !elsewhere {
            assert_eq!(result, Ok(true), "{} does not build", s.name);
        }
    }
    // A scene spec parses from text the same way (`SceneSpec::from_toml`, used by the demo).
    assert!(SceneSpec::from_toml("[time]\nsteps = 1\n", Path::new("t.toml")).is_ok());
    let _ = std::fs::remove_dir_all(&dir);
}
