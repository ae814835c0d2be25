//! Issue 11: every reproducer of the hostile-user report as a regression test named after it (panics, aborts
//! and hangs on odd input, NaN results with success, lost or mixed runs, weak messages and provenance), and
//! the output-folder cases (mixed runs, links, stale temporaries, files flexsurf did not write).

use flexsurf::runner::{run_scene_with, RunOptions};
use flexsurf::scene::{self, Limits, SceneError};
use flexsurf::testing::files;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use flexsurf::testing::repo;

/// A fresh empty directory for one test.
fn scratch(tag: &str) -> flexsurf::testing::ScratchDir {
    flexsurf::testing::scratch("hardening", tag)
}

/// A small valid scene; tests splice faults into it.
const SMALL: &str =
    "[sheet]\nsize = [1.0, 1.0]\nnodes = [5, 5]\ncenter = [0.0, 0.0, 0.35]\n[time]\ndt = 0.01\nsteps = 6\n\
[output]\nimage_size = [32, 24]\ncoons_subdivisions = 1\n";

fn load_text(dir: &Path, text: &[u8]) -> Result<scene::Scene, SceneError> {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    scene::load(&path)
}

fn err_text(dir: &Path, text: &str) -> String {
    match load_text(dir, text.as_bytes()) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

// --- panics, aborts and hangs -------------------------------------------------------------------------------

#[test]
fn regression_non_ascii_key_panicked_the_key_locator() {
    let d = scratch("non-ascii");
    let e = err_text(&d, "[sheet]\nsize = [1.0, 1.0]\nnodes = [5, 5]\n[time]\nsteps = 2\n\"défaut\" = 1\n");
    assert!(e.contains("scene.toml:6:1") && e.contains("`time.défaut`"), "{e}");
    let e = err_text(&d, "[sheet]\nsize = [1.0, 1.0]\nnodes = [5, 5]\nnœuds = 3\n[time]\nsteps = 2\n");
    assert!(e.contains("scene.toml:4:"), "{e}");
}

#[test]
fn regression_bom_panicked_the_key_locator() {
    let d = scratch("bom");
    let e = err_text(&d, "\u{feff}[sheet]\nsize = [1.0, 1.0]\nnodes = [5, 5]\n[time]\nsteps = 2\ndtt = 1\n");
    assert!(e.contains("`time.dtt`") && e.contains(":6:1"), "{e}");
    let e = err_text(&d, "[sheet]\nsize = [1.0, 1.0]\n\u{feff}nodes = [5, 5]\n[time]\nsteps = 2\n");
    assert!(e.contains("scene.toml:3:"), "{e}");
}

#[test]
fn regression_node_count_overflowed_size_arithmetic() {
    let d = scratch("overflow");
    let e = err_text(&d, &SMALL.replace("nodes = [5, 5]", "nodes = [9223372036854775807, 21]"));
    assert!(e.contains("`sheet.nodes`") && e.contains("more than the 100000000 nodes"), "{e}");
    let e = err_text(&d, &SMALL.replace("nodes = [5, 5]", "nodes = [18446744073709551615, 18446744073709551615]"));
    assert!(e.contains("`sheet.nodes`"), "{e}");
}

#[test]
fn regression_node_count_asked_for_a_2_tb_allocation() {
    let d = scratch("abort");
    let e = err_text(&d, &SMALL.replace("nodes = [5, 5]", "nodes = [4294967296, 21]"));
    assert!(e.contains("`sheet.nodes`"), "{e}");
    // Below the node cap, the memory estimate refuses it with its parts, and says how to raise the limit.
    let e = err_text(&d, &SMALL.replace("nodes = [5, 5]", "nodes = [9000, 9000]"));
    assert!(e.contains("`sheet.nodes`") && e.contains("estimated") && e.contains("--max-memory"), "{e}");
    let path = d.join("scene.toml");
    std::fs::write(&path, SMALL.replace("nodes = [5, 5]", "nodes = [300, 300]")).unwrap();
    let e = scene::load_with(&path, &Limits { max_memory: 1 << 20, ..Limits::default() }).unwrap_err().to_string();
    assert!(e.contains("more than the limit of 1.0 MiB"), "{e}");
    assert!(scene::load_with(&path, &Limits::default()).is_ok());
    std::fs::write(&path, SMALL.replace("nodes = [5, 5]", "nodes = [4294967296, 21]")).unwrap();
    assert!(
        scene::load_with(&path, &Limits { max_memory: u64::MAX, ..Limits::default() }).is_err(),
        "the node cap holds regardless"
    );
}

#[test]
fn regression_huge_counts_panicked_in_grid_and_membrane() {
    let d = scratch("grid");
    for nodes in ["[3, 40000000]", "[100000, 1000]", "[3, 4611686018427387904]"] {
        let e = err_text(&d, &SMALL.replace("nodes = [5, 5]", &format!("nodes = {nodes}")));
        assert!(e.contains("`sheet.nodes`"), "{nodes}: {e}");
    }
    // Huge pictures and subdivisions are in the estimate too.
    let e = err_text(&d, &SMALL.replace("image_size = [32, 24]", "image_size = [8192, 8192]"));
    assert!(e.contains("pictures"), "{e}");
}

#[test]
fn regression_huge_garment_counts_hung_the_skirt_builder() {
    let d = scratch("skirt");
    let text = "[garment]\nkind = \"skirt\"\nwaist_girth = 1.4\nhem_girth = 3.0\nlength = 0.5\nwaist_height = 0.15\n\
nodes = [12, 5]\n[time]\nsteps = 2\n[[obstacle]]\nsphere = { center = [0.0, 0.0, 0.0], radius = 0.3 }\n";
    assert!(load_text(&d, text.as_bytes()).is_ok());
    let t = std::time::Instant::now();
    for nodes in ["[4294967296, 5]", "[12, 9223372036854775807]", "[50000, 50000]"] {
        let e = err_text(&d, &text.replace("nodes = [12, 5]", &format!("nodes = {nodes}")));
        assert!(e.contains("`garment.nodes`"), "{nodes}: {e}");
    }
    assert!(t.elapsed().as_secs_f64() < 5.0);
}

/// Fuzz seed 40, input 206621: a pattern scene asking for `sewing_steps = 0x7fffffff` with seams closing by
/// 1e-9 m a step ran its sewing phase, which the scene's build runs, for over two minutes (a hang to every front
/// end's load and to `flexsurf check`). The count is now refused, naming the key, before any sewing.
#[test]
fn regression_a_huge_sewing_step_count_hung_the_scene_build() {
    let d = scratch("sewing-steps");
    let pattern = repo().join("garments/four_gore_skirt.toml");
    let text = std::fs::read_to_string(repo().join("scenes/four_gore_skirt.toml"))
        .unwrap()
        .replace("../garments/four_gore_skirt.toml", &pattern.display().to_string().replace('\\', "/"));
    let t = std::time::Instant::now();
    for steps in ["0x7fffffff", "100001", "18446744073709551615"] {
        let huge = text.replace("sewing_steps = 300", &format!("sewing_steps = {steps}"));
        let huge = huge.replace("sewing_gap = 0.0008", "sewing_gap = 0.0008\nsewing_closing = 1e-9");
        let e = err_text(&d, &huge);
        assert!(e.contains("`pattern.sewing_steps`") && e.contains("scene.toml"), "{steps}: {e}");
    }
    assert!(t.elapsed().as_secs_f64() < 5.0, "refused in {:?}", t.elapsed());
}

/// Makes a FIFO at `path` (with the system's `mkfifo`; no `unsafe` here).
#[cfg(unix)]
fn mkfifo(path: &Path) {
    let ok = std::process::Command::new("mkfifo").arg(path).status().map(|s| s.success()).unwrap_or(false);
    assert!(ok, "mkfifo {} failed", path.display());
}

#[cfg(unix)]
#[test]
fn regression_fifo_material_file_blocked_forever() {
    let d = scratch("fifo-material");
    mkfifo(&d.join("cloth.toml"));
    let t = std::time::Instant::now();
    let e = err_text(&d, &format!("{SMALL}[material]\nfile = \"cloth.toml\"\n"));
    assert!(e.contains("`material.file`") && e.contains("FIFO") && e.contains("not a regular file"), "{e}");
    assert!(t.elapsed().as_secs_f64() < 5.0);
    // The scene itself as a FIFO, and a directory.
    let fifo_scene = d.join("fifo-scene.toml");
    mkfifo(&fifo_scene);
    let e = format!("{:#}", anyhow_chain(scene::load(&fifo_scene).unwrap_err()));
    assert!(e.contains("FIFO"), "{e}");
    let e = format!("{:#}", anyhow_chain(scene::load(&d).unwrap_err()));
    assert!(e.contains("directory"), "{e}");
}

/// The error with its sources, as the CLI prints it.
fn anyhow_chain(e: SceneError) -> String {
    let mut s = e.to_string();
    let mut src = std::error::Error::source(&e);
    while let Some(inner) = src {
        s.push_str(": ");
        s.push_str(&inner.to_string());
        src = inner.source();
    }
    s
}

#[cfg(unix)]
#[test]
fn regression_fifo_body_and_mesh_files_blocked_forever() {
    let d = scratch("fifo-body");
    mkfifo(&d.join("body.toml"));
    mkfifo(&d.join("mesh.obj"));
    let e = err_text(&d, &format!("{SMALL}[[obstacle]]\nnurbs = {{ file = \"body.toml\" }}\n"));
    assert!(e.contains("`obstacle[0].nurbs.file`") && e.contains("FIFO"), "{e}");
    let e = err_text(&d, &format!("{SMALL}[[obstacle]]\nmesh = {{ file = \"mesh.obj\" }}\n"));
    assert!(e.contains("`obstacle[0].mesh.file`") && e.contains("FIFO"), "{e}");
    // A device is refused the same way, before it is opened.
    let e = err_text(&d, &format!("{SMALL}[material]\nfile = \"/dev/zero\"\n"));
    assert!(e.contains("device"), "{e}");
}

// --- exit 0 with NaN ----------------------------------------------------------------------------------------

const HAMMOCK: &str = "[sheet]\nsize = [0.6, 0.2]\nnodes = [9, 5]\ncenter = [0.0, 0.0, 0.306]\n[time]\nsteps = 1\n\
[integrator]\nkind = \"static\"\n[[pin]]\nset = \"edge_u1_0\"\n[[pin]]\nset = \"edge_u1_1\"\n[output]\nimage_size = [32, 24]\n";

#[test]
fn regression_static_solve_gave_nan_far_from_origin() {
    let d = scratch("far");
    assert!(load_text(&d, HAMMOCK.as_bytes()).is_ok());
    let e = err_text(&d, &HAMMOCK.replace("center = [0.0, 0.0, 0.306]", "center = [1e18, 0, 0.306]"));
    assert!(e.contains("`sheet.center`") && e.contains("accepted range"), "{e}");
}

#[test]
fn regression_static_solve_gave_nan_for_size_1e308() {
    let d = scratch("size");
    let e = err_text(&d, &HAMMOCK.replace("size = [0.6, 0.2]", "size = [1e308, 0.2]"));
    assert!(e.contains("`sheet.size`") && e.contains("accepted range"), "{e}");
    let e = err_text(&d, &HAMMOCK.replace("size = [0.6, 0.2]", "size = [1e-308, 0.2]"));
    assert!(e.contains("`sheet.size`"), "{e}");
}

#[test]
fn regression_check_accepted_dt_1e308_and_5e_324() {
    let d = scratch("dt");
    for dt in ["1e308", "5e-324", "1e-12", "11.0"] {
        let e = err_text(&d, &SMALL.replace("dt = 0.01", &format!("dt = {dt}")));
        assert!(e.contains("`time.dt`") && e.contains("accepted range"), "{dt}: {e}");
    }
    // The existing messages for values that are not positive or not finite are kept.
    let e = err_text(&d, &SMALL.replace("dt = 0.01", "dt = -1.0"));
    assert!(e.contains("must be positive"), "{e}");
}

#[test]
fn regression_check_accepted_density_1e_308() {
    let d = scratch("density");
    let e = err_text(&d, &format!("{SMALL}[material]\npreset = \"paper-cotton\"\ndensity = 1e-308\n"));
    assert!(e.contains("`material.density`") && e.contains("accepted range"), "{e}");
    std::fs::write(
        d.join("cloth.toml"),
        "density = 1e308\ntensile_warp = 1\ntensile_weft = 1\nshear = 1\nbending_warp = 1e-5\nbending_weft = 1e-5\n",
    )
    .unwrap();
    let e = err_text(&d, &format!("{SMALL}[material]\nfile = \"cloth.toml\"\n"));
    assert!(
        e.contains("scene.toml")
            && e.contains("`material.file`")
            && e.contains("cloth.toml")
            && e.contains("`density`"),
        "{e}"
    );
}

#[test]
fn regression_checked_values_no_physical_scene_has() {
    let d = scratch("ranges");
    for (from, to, key) in [
        ("[time]", "gravity = [0.0, 0.0, -1e300]\n[time]", "gravity"),
        ("steps = 6", "steps = 100000000000", "time.steps"),
        ("steps = 6", "steps = 100000000\noutput_every = 1", "time.output_every"),
    ] {
        let e = err_text(&d, &SMALL.replace(from, to));
        assert!(e.contains(&format!("`{key}`")), "{key}: {e}");
    }
    let e = err_text(&d, &format!("{SMALL}[[obstacle]]\nsphere = {{ center = [0, 0, 0], radius = 1e300 }}\n"));
    assert!(e.contains("`obstacle[0].sphere.radius`"), "{e}");
    let e = err_text(&d, &format!("{SMALL}[contact]\nstiffness = 1e300\n"));
    assert!(e.contains("`contact.stiffness`"), "{e}");
}

// --- messages -----------------------------------------------------------------------------------------------

#[test]
fn regression_material_file_errors_did_not_name_the_referencing_scene() {
    let d = scratch("material-ref");
    std::fs::write(d.join("cloth.toml"), "density = \"heavy\"\n").unwrap();
    let e = err_text(&d, &format!("{SMALL}[material]\nfile = \"cloth.toml\"\n"));
    assert!(e.starts_with(&d.join("scene.toml").display().to_string()), "{e}");
    assert!(e.contains("`material.file`") && e.contains("cloth.toml:1:11") && e.contains("`density`"), "{e}");
    assert!(e.contains("invalid type: string, expected") && !e.contains("heavy"), "{e}");
}

#[test]
fn regression_invalid_utf8_had_no_byte_position() {
    let d = scratch("utf8");
    let mut text = SMALL.as_bytes().to_vec();
    text.splice(3..3, [0xff, 0xfe]);
    let e = anyhow_chain(load_text(&d, &text).unwrap_err());
    assert!(e.contains("invalid UTF-8 at byte 3 (line 1, column 4)"), "{e}");
}

#[test]
fn regression_nurbs_body_error_echoed_the_file() {
    let d = scratch("echo");
    std::fs::write(d.join("notes.txt"), "password = hunter2 SECRET\nmore private text\n").unwrap();
    let e = err_text(&d, &format!("{SMALL}[[obstacle]]\nnurbs = {{ file = \"notes.txt\" }}\n"));
    assert!(e.contains("`obstacle[0].nurbs.file`") && e.contains(", column "), "{e}");
    assert!(!e.contains("hunter2") && !e.contains("SECRET") && !e.contains("private"), "{e}");
    std::fs::write(d.join("notes.obj"), "v 0 0 SECRET\n").unwrap();
    let e = err_text(&d, &format!("{SMALL}[[obstacle]]\nmesh = {{ file = \"notes.obj\" }}\n"));
    assert!(e.contains("notes.obj:1") && !e.contains("SECRET"), "{e}");
}

// --- runs: NaN, energy.csv, provenance ----------------------------------------------------------------------

fn built(dir: &Path, text: &str) -> scene::Scene {
    load_text(dir, text.as_bytes()).unwrap()
}

#[test]
fn regression_summary_had_no_version_hashes_or_resolved_constants() {
    let d = scratch("provenance");
    std::fs::write(d.join("cloth.toml"), "units = \"kes\"\ndensity = 20.0\ntensile_warp = 100\ntensile_weft = 80\nshear = 0.5\nbending_warp = 0.1\nbending_weft = 0.08\n").unwrap();
    let text = format!("{SMALL}[material]\nfile = \"cloth.toml\"\nshear = 2.0\n");
    let path = d.join("scene.toml");
    std::fs::write(&path, &text).unwrap();
    let (s, inputs) = flexsurf::io::input::recording(|| scene::load(&path));
    let s = s.unwrap();
    assert_eq!(inputs.len(), 2, "{inputs:?}");
    let options = RunOptions { command_line: vec!["flexsurf".into(), "run".into()], inputs, ..Default::default() };
    let out = d.join("out");
    run_scene_with(&s, &out, &options, |_| {}).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let p = &json["provenance"];
    assert_eq!(p["flexsurf_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(p["command_line"], serde_json::json!(["flexsurf", "run"]));
    assert_eq!(p["fingerprint"].as_str().unwrap().len(), 64);
    let files = p["inputs"].as_array().unwrap();
    assert!(files[0]["path"].as_str().unwrap().ends_with("scene.toml"));
    assert_eq!(files[0]["sha256"], flexsurf::io::input::sha256_hex(text.as_bytes()));
    assert!(files[1]["path"].as_str().unwrap().ends_with("cloth.toml"));
    // The constants in SI: the file's KES density 20 mg/cm² is 0.2 kg/m², the inline shear 2.0 (SI) overrides.
    let c = &p["material"]["constants_si"];
    assert!((c["density"].as_f64().unwrap() - 0.2).abs() < 1e-12, "{c}");
    assert_eq!(c["shear"], 2.0);
    assert_eq!(p["material"]["calibration"], "kes");
    assert_eq!(p["solver"]["Dynamic"]["dt"], 0.01);
    assert_eq!(p["solver"]["Dynamic"]["solver"], "auto");
    assert_eq!(json["solver"], "cholesky");
    assert_eq!(json["solver_requested"], "auto");
    assert_eq!(json["interrupted"], false);
}

#[test]
fn regression_energy_csv_was_kept_in_memory_until_the_end() {
    let d = scratch("energy");
    let s = built(&d, SMALL);
    let out = d.join("out");
    let csv = out.join("energy.csv");
    let mut seen = Vec::new();
    run_scene_with(&s, &out, &RunOptions::default(), |st| {
        // While the run goes on, the file already holds the header and a row per step so far (the row of
        // this step is written right after this call).
        seen.push((st.step, std::fs::read_to_string(&csv).unwrap().lines().count()));
    })
    .unwrap();
    assert_eq!(seen, (1..=6).map(|k| (k, k + 1)).collect::<Vec<_>>());
    assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), 8);
}

#[test]
fn stopping_writes_a_checkpoint_and_an_interrupted_summary() {
    let d = scratch("stop");
    let s = built(&d, SMALL);
    let out = d.join("out");
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let options = RunOptions { stop: Some(stop), ..Default::default() };
    let o = run_scene_with(&s, &out, &options, |st| flag.store(st.step == 3, Ordering::SeqCst)).unwrap();
    assert!(o.summary.interrupted && o.summary.steps == 3);
    assert!(out.join("checkpoint.bin").exists());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["interrupted"], true);
    // The manifest is not complete; a new run (not a resume) is refused, with the suggestion to resume.
    let e = run_scene_with(&s, &out, &RunOptions::default(), |_| {}).unwrap_err().to_string();
    assert!(e.contains("stopped run of this same scene") && e.contains("--resume"), "{e}");
    // Resuming with another scene is refused.
    let other = built(&d, &SMALL.replace("steps = 6", "steps = 7"));
    let e = run_scene_with(&other, &out, &RunOptions { resume: true, ..Default::default() }, |_| {}).unwrap_err();
    assert!(e.to_string().contains("another scene or other settings"), "{e}");
    let o = run_scene_with(&s, &out, &RunOptions { resume: true, ..Default::default() }, |_| {}).unwrap();
    assert!(!o.summary.interrupted && o.summary.steps == 6);
    assert!(!out.join("checkpoint.bin").exists(), "a finished run removes its checkpoint");
    assert_eq!(o.summary.provenance.resumed_from_step, Some(3));
    // A damaged checkpoint is refused with its reason.
    let o = run_scene_with(
        &s,
        &out,
        &RunOptions { overwrite: true, stop: Some(Arc::new(AtomicBool::new(true))), ..Default::default() },
        |_| {},
    )
    .unwrap();
    assert!(o.summary.interrupted && o.summary.steps == 1);
    let ck = out.join("checkpoint.bin");
    let mut bytes = std::fs::read(&ck).unwrap();
    let n = bytes.len();
    bytes[n - 3] ^= 0x55;
    std::fs::write(&ck, bytes).unwrap();
    let e = run_scene_with(&s, &out, &RunOptions { resume: true, ..Default::default() }, |_| {}).unwrap_err();
    assert!(e.to_string().contains("checksum"), "{e}");
}

// --- output folders -----------------------------------------------------------------------------------------

#[test]
fn regression_rerun_mixed_its_frames_with_an_earlier_runs() {
    let d = scratch("mixed");
    let seven = built(&d, &SMALL.replace("steps = 6", "steps = 7\noutput_every = 1"));
    let three = built(&d, &SMALL.replace("steps = 6", "steps = 3\noutput_every = 1"));
    let out = d.join("out");
    run_scene_with(&seven, &out, &RunOptions::default(), |_| {}).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let e = run_scene_with(&three, &out, &RunOptions::default(), |_| {}).unwrap_err().to_string();
    assert!(e.contains("holds the outputs of another run") && e.contains("frames/frame_00000.obj"), "{e}");
    assert!(e.contains("--overwrite"), "{e}");
    run_scene_with(&three, &out, &RunOptions { overwrite: true, ..Default::default() }, |_| {}).unwrap();
    let expected: Vec<String> = [
        "animation.glb",
        "animation.pvd",
        "energy.csv",
        "energy.png",
        "manifest.json",
        "notes.txt",
        "snapshots.png",
        "summary.json",
        "vtk/obstacles.vtu",
    ]
    .into_iter()
    .map(String::from)
    .chain((0..=3).map(|k| format!("frames/frame_{k:05}.obj")))
    .chain((0..=3).map(|k| format!("vtk/frame_{k:05}.vtu")))
    .collect();
    let mut expected = expected;
    expected.sort();
    assert_eq!(files(&out), expected, "only the new run's frames, and the user's file untouched");
    assert_eq!(std::fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
}

#[test]
fn overwrite_never_deletes_files_flexsurf_did_not_write() {
    let d = scratch("foreign");
    let s = built(&d, SMALL);
    let out = d.join("out");
    // Outputs of unknown origin (no manifest) are refused even with --overwrite.
    std::fs::create_dir_all(out.join("frames")).unwrap();
    std::fs::write(out.join("frames/frame_00000.obj"), "someone else's").unwrap();
    std::fs::write(out.join("summary.json"), "{}").unwrap();
    for overwrite in [false, true] {
        let e = run_scene_with(&s, &out, &RunOptions { overwrite, ..Default::default() }, |_| {}).unwrap_err();
        assert!(e.to_string().contains("no flexsurf manifest lists"), "{e}");
    }
    assert_eq!(std::fs::read_to_string(out.join("frames/frame_00000.obj")).unwrap(), "someone else's");
    // A manifest listing paths outside the folder or links: --overwrite removes none of them.
    let victim = d.join("victim.txt");
    std::fs::write(&victim, "keep").unwrap();
    let out2 = d.join("out2");
    run_scene_with(&s, &out2, &RunOptions::default(), |_| {}).unwrap();
    let mpath = out2.join("manifest.json");
    let mut m: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&mpath).unwrap()).unwrap();
    m["files"].as_array_mut().unwrap().extend([
        serde_json::json!("../victim.txt"),
        serde_json::json!(victim.display().to_string()),
        serde_json::json!("link.txt"),
    ]);
    std::fs::write(&mpath, m.to_string()).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(&victim, out2.join("link.txt")).unwrap();
    run_scene_with(&s, &out2, &RunOptions { overwrite: true, ..Default::default() }, |_| {}).unwrap();
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
}

#[cfg(unix)]
#[test]
fn regression_frames_symlink_was_followed_out_of_the_folder() {
    let d = scratch("symlink");
    let s = built(&d, SMALL);
    let out = d.join("out");
    let elsewhere = d.join("elsewhere");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::os::unix::fs::symlink(&elsewhere, out.join("frames")).unwrap();
    let e = run_scene_with(&s, &out, &RunOptions::default(), |_| {}).unwrap_err().to_string();
    assert!(e.contains("frames") && e.contains("symbolic link"), "{e}");
    assert!(files(&elsewhere).is_empty(), "nothing written through the link");
    // A link in place of energy.csv is refused too.
    std::fs::remove_file(out.join("frames")).unwrap();
    std::os::unix::fs::symlink(d.join("elsewhere/target.csv"), out.join("energy.csv")).unwrap();
    let e = run_scene_with(&s, &out, &RunOptions::default(), |_| {}).unwrap_err().to_string();
    assert!(e.contains("energy.csv"), "{e}");
    assert!(!d.join("elsewhere/target.csv").exists());
}

#[test]
fn regression_a_killed_run_left_hidden_temporary_files() {
    let d = scratch("temps");
    let s = built(&d, SMALL);
    let out = d.join("out");
    run_scene_with(&s, &out, &RunOptions::default(), |_| {}).unwrap();
    // What a kill during atomic writes leaves, and two files that only look similar.
    for name in
        [".summary.json.tmp.999999991.0", "frames/.frame_00006.obj.tmp.999999991.3", ".energy.csv.tmp.999999992.2"]
    {
        std::fs::write(out.join(name), "partial").unwrap();
    }
    std::fs::write(out.join(".notes.txt.tmp.1.2"), "mine").unwrap();
    std::fs::write(out.join("summary.json.tmp"), "mine").unwrap();
    run_scene_with(&s, &out, &RunOptions { overwrite: true, ..Default::default() }, |_| {}).unwrap();
    let left = files(&out);
    assert!(!left.iter().any(|f| f.contains(".tmp.999999991") || f == ".energy.csv.tmp.999999992.2"), "{left:?}");
    assert!(left.contains(&".notes.txt.tmp.1.2".to_string()) && left.contains(&"summary.json.tmp".to_string()));
}

#[test]
fn an_unusable_output_folder_is_an_error_not_a_panic() {
    let d = scratch("unusable");
    let s = built(&d, SMALL);
    let file = d.join("a-file");
    std::fs::write(&file, "x").unwrap();
    let e = run_scene_with(&s, &file, &RunOptions::default(), |_| {}).unwrap_err().to_string();
    assert!(e.contains("cannot write"), "{e}");
    let e = run_scene_with(&s, &file.join("below"), &RunOptions::default(), |_| {}).unwrap_err().to_string();
    assert!(e.contains("cannot write"), "{e}");
    let _ = repo();
}

// --- issue 22 ---------------------------------------------------------------------------------------------

#[test]
fn regression_body_file_units_and_material_file_numbers_were_echoed() {
    let d = scratch("echo-values");
    let body = "units = \"furlongs-SECRET\"\n";
    std::fs::write(d.join("body.toml"), body).unwrap();
    let e = err_text(&d, &format!("{SMALL}[[obstacle]]\nnurbs = {{ file = \"body.toml\" }}\n"));
    assert!(e.contains("`obstacle[0].nurbs.file`") && e.contains("`units`"), "{e}");
    assert!(!e.contains("SECRET") && !e.contains("furlongs"), "{e}");
    // A bad number, and numbers that do not go together, in a material file: the file and the key, not the value.
    for (text, key) in [
        ("density = 0.1\ntensile_warp = 1000\ntensile_weft = 1000\nshear = -1234.5\nbending_warp = 1e-5\nbending_weft = 1e-5\n", "shear"),
        ("density = 0.1\ntensile_warp = 1000\ntensile_weft = 1000\nshear = 10\nbending_warp = 1e-5\nbending_weft = 1e-5\nbending_poisson = 1234.5\n", "bending_poisson"),
        ("density = 0.1\ntensile_warp = 1000\ntensile_weft = 1000\nshear = 10\nbending_warp = 1e-5\nbending_weft = 1e-5\npoisson = 123.45\n", "poisson"),
        ("density = 1234.5e10\ntensile_warp = 1000\ntensile_weft = 1000\nshear = 10\nbending_warp = 1e-5\nbending_weft = 1e-5\n", "density"),
    ] {
        std::fs::write(d.join("cloth.toml"), text).unwrap();
        let e = err_text(&d, &format!("{SMALL}[material]\nfile = \"cloth.toml\"\n"));
        assert!(e.contains("`material.file`") && e.contains("cloth.toml") && e.contains(&format!("`{key}`")), "{e}");
        assert!(!e.contains("1234") && !e.contains("123.45"), "{e}");
    }
    // The scene's own values are still quoted.
    let e = err_text(&d, &format!("{SMALL}[material]\npreset = \"paper-cotton\"\nshear = -1234.5\n"));
    assert!(e.contains("`material.shear`") && e.contains("-1234.5"), "{e}");
}

/// `check --max-memory 1T` on a 2000² grid built the whole model (11 GB, 84 s) before answering; it answers
/// from the sizes and the checked values (the model is not built) in a fraction of that.
#[test]
fn regression_check_max_memory_1t_on_a_2000_grid_took_11_gb_and_84_s() {
    let d = scratch("check-2000");
    let path = d.join("scene.toml");
    let text = format!("{SMALL}[[obstacle]]\nsphere = {{ center = [0, 0, 0], radius = 0.3 }}\n")
        .replace("nodes = [5, 5]", "nodes = [2000, 2000]");
    std::fs::write(&path, text).unwrap();
    let t = std::time::Instant::now();
    let r = scene::check_with(&path, &Limits { max_memory: 1 << 40, ..Limits::default() }).unwrap();
    assert_eq!(r.nodes, [2000, 2000]);
    // The estimate (bytes per node: model 1500, matrix 50 blocks of 72) is at least 4e6 · 5100 = 20.4 GB.
    assert!(r.estimate.total() >= 4_000_000 * 5100, "{:?}", r.estimate);
    assert!(t.elapsed().as_secs_f64() < 20.0, "{:?}", t.elapsed());
    // Without the raised limit the same scene is refused from its sizes alone.
    let e = scene::check_with(&path, &Limits::default()).unwrap_err().to_string();
    assert!(e.contains("`sheet.nodes`") && e.contains("--max-memory"), "{e}");
}
