//! Issue 22, "trust boundaries": each reproducer of the run-folder, checkpoint and viewer cases as a regression
//! test named after it (links inside the output folder, files flexsurf did not write, two runs into one
//! folder, a forged checkpoint with a valid checksum, `/dev/zero` and FIFO inputs of the viewer, a scene name
//! that closed the viewer's `<script>`, an empty output path).
use flexsurf::runner::checkpoint;
use flexsurf::runner::fields::FrameFields;
use flexsurf::runner::outputs::OutputState;
use flexsurf::runner::FrameRecord;
use flexsurf::runner::{run_scene_with, RunOptions};
use flexsurf::scene;
use sha2::Digest;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

fn scratch(tag: &str) -> flexsurf::testing::ScratchDir {
    flexsurf::testing::scratch("trust", tag)
}

/// A small valid scene (5 × 5 nodes, 6 steps).
const SMALL: &str =
    "[sheet]\nsize = [1.0, 1.0]\nnodes = [5, 5]\ncenter = [0.0, 0.0, 0.35]\n[time]\ndt = 0.01\nsteps = 6\n\
     output_every = 1\n[output]\nimage_size = [32, 24]\ncoons_subdivisions = 1\n";

fn built(dir: &Path, text: &str) -> scene::Scene {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    scene::load(&path).unwrap()
}

fn run(s: &scene::Scene, out: &Path, overwrite: bool) -> Result<(), String> {
    run_scene_with(s, out, &RunOptions { overwrite, ..Default::default() }, |_| {})
        .map(|_| ())
        .map_err(|e| e.to_string())
}

fn manifest(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap()
}

fn sha256_hex(bytes: &[u8]) -> String {
    sha2::Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(unix)]
#[test]
fn regression_overwrite_deleted_a_file_through_a_symlinked_manifest_entry() {
    let d = scratch("manifest-link");
    let s = built(&d, SMALL);
    let out = d.join("out");
    run(&s, &out, false).unwrap();
    let victim = d.join("outside/sub/f.txt");
    std::fs::create_dir_all(victim.parent().unwrap()).unwrap();
    std::fs::write(&victim, "keep").unwrap();
    std::os::unix::fs::symlink(d.join("outside"), out.join("lnk")).unwrap();
    // A forged manifest: the outside file listed through the link, with its true hash.
    let mut m = manifest(&out);
    m["files"].as_array_mut().unwrap().push("lnk/sub/f.txt".into());
    m["sha256"]["lnk/sub/f.txt"] = sha256_hex(b"keep").into();
    std::fs::write(out.join("manifest.json"), m.to_string()).unwrap();
    run(&s, &out, true).unwrap();
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep", "nothing removed through a link");
}

#[test]
fn overwrite_removes_only_files_that_still_have_the_recorded_content() {
    let d = scratch("hashes");
    let s = built(&d, SMALL);
    let three = built(&d, &SMALL.replace("steps = 6", "steps = 3"));
    let out = d.join("out");
    run(&s, &out, false).unwrap();
    let m = manifest(&out);
    let frame = out.join("frames/frame_00006.obj");
    assert_eq!(m["sha256"]["frames/frame_00006.obj"], sha256_hex(&std::fs::read(&frame).unwrap()).as_str());
    std::fs::write(&frame, "edited by the user").unwrap();
    run(&three, &out, true).unwrap();
    assert_eq!(std::fs::read_to_string(&frame).unwrap(), "edited by the user", "a changed file is not flexsurf's");
    assert!(!out.join("frames/frame_00005.obj").exists(), "an unchanged file of the old run is removed");
    assert!(out.join("manifest.json").exists());
}

#[cfg(unix)]
#[test]
fn regression_a_symlinked_vtk_folder_was_followed() {
    let d = scratch("vtk-link");
    let s = built(&d, SMALL);
    let out = d.join("out");
    let elsewhere = d.join("elsewhere");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("frame_00000.vtu"), "keep").unwrap();
    std::os::unix::fs::symlink(&elsewhere, out.join("vtk")).unwrap();
    for overwrite in [false, true] {
        let e = run(&s, &out, overwrite).unwrap_err();
        assert!(e.contains("vtk") && e.contains("symbolic link"), "{e}");
    }
    assert_eq!(std::fs::read_to_string(elsewhere.join("frame_00000.vtu")).unwrap(), "keep");
    assert_eq!(flexsurf::testing::files(&elsewhere), vec!["frame_00000.vtu".to_string()]);
}

#[cfg(unix)]
#[test]
fn the_atomic_writer_refuses_a_link_inside_a_guarded_folder() {
    use flexsurf::io::atomic::{write_atomic, Guard};
    let d = scratch("guard");
    let (root, elsewhere) = (d.join("root"), d.join("elsewhere"));
    std::fs::create_dir_all(&root).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::os::unix::fs::symlink(&elsewhere, root.join("sub")).unwrap();
    // Unguarded, the link is an ordinary directory to the writer; guarded, it is refused.
    write_atomic(root.join("sub/a.txt"), b"a").unwrap();
    let guard = Guard::new(&root);
    let e = write_atomic(root.join("sub/b.txt"), b"b").unwrap_err().to_string();
    assert!(e.contains("symbolic link"), "{e}");
    write_atomic(root.join("c.txt"), b"c").unwrap();
    drop(guard);
    assert_eq!(flexsurf::testing::files(&elsewhere), vec!["a.txt".to_string()]);
}

#[test]
fn regression_files_the_user_put_at_output_paths_were_replaced() {
    let d = scratch("foreign");
    let s = built(&d, SMALL);
    // No manifest: refused, even with overwrite, for every output name of a run.
    for name in ["animation.glb", "energy.png", "animation.pvd", "vtk/frame_00000.vtu"] {
        let out = d.join(format!("out-{}", name.replace('/', "-")));
        std::fs::create_dir_all(out.join("vtk")).unwrap();
        std::fs::write(out.join(name), "mine").unwrap();
        for overwrite in [false, true] {
            let e = run(&s, &out, overwrite).unwrap_err();
            assert!(e.contains("no flexsurf manifest lists") && e.contains(name), "{e}");
        }
        assert_eq!(std::fs::read_to_string(out.join(name)).unwrap(), "mine");
    }
    // A flexsurf folder whose manifest does not list the file: refused unless overwriting.
    let three = built(&d, &SMALL.replace("steps = 6", "steps = 3"));
    let out = d.join("out");
    run(&three, &out, false).unwrap();
    for f in manifest(&out)["files"].as_array().unwrap() {
        let _ = std::fs::remove_file(out.join(f.as_str().unwrap()));
    }
    std::fs::write(out.join("vtk/frame_00005.vtu"), "mine").unwrap();
    let e = run(&s, &out, false).unwrap_err();
    assert!(e.contains("does not list") && e.contains("vtk/frame_00005.vtu") && e.contains("--overwrite"), "{e}");
    assert_eq!(std::fs::read_to_string(out.join("vtk/frame_00005.vtu")).unwrap(), "mine");
    run(&s, &out, true).unwrap();
    assert!(std::fs::read_to_string(out.join("vtk/frame_00005.vtu")).unwrap().contains("VTKFile"));
}

#[test]
fn regression_two_concurrent_runs_into_one_folder_both_succeeded() {
    let d = scratch("lock");
    let s = built(&d, SMALL);
    let out = d.join("out");
    let held = flexsurf::runner::manifest::Folder::open(&out, "another run", false, false).unwrap();
    let e = run(&s, &out, true).unwrap_err();
    // The lock's holder is this very process.
    let pid = format!("process {}", std::process::id());
    assert!(e.contains("being written by another flexsurf run") && e.contains(&pid), "{e}");
    drop(held);
    run(&s, &out, true).unwrap();
}

#[test]
fn regression_concurrent_overwrites_left_the_folder_without_its_manifest() {
    let d = scratch("overwrites");
    let s = built(&d, SMALL);
    let out = d.join("out");
    run(&s, &out, false).unwrap();
    let results: Vec<Result<(), String>> = std::thread::scope(|scope| {
        let runs: Vec<_> = (0..4).map(|_| scope.spawn(|| run(&s, &out, true))).collect();
        runs.into_iter().map(|r| r.join().unwrap()).collect()
    });
    for r in &results {
        if let Err(e) = r {
            assert!(e.contains("being written by another flexsurf run"), "{e}");
        }
    }
    assert!(results.iter().any(Result::is_ok));
    assert_eq!(manifest(&out)["complete"], true);
    let e = run(&s, &out, false).unwrap_err();
    assert!(e.contains("holds the outputs of another run"), "{e}");
}

/// Runs `s` into `out`, stopped after step 3 (a checkpoint is written).
fn stopped(s: &scene::Scene, out: &Path) {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let options = RunOptions { stop: Some(stop), ..Default::default() };
    run_scene_with(s, out, &options, |st| flag.store(st.step == 3, Ordering::SeqCst)).unwrap();
}

#[test]
fn regression_rerunning_a_stopped_run_said_another_run() {
    let d = scratch("stopped");
    let s = built(&d, SMALL);
    let out = d.join("out");
    stopped(&s, &out);
    let e = run(&s, &out, false).unwrap_err();
    assert!(e.contains("stopped run of this same scene") && e.contains("--resume"), "{e}");
    assert!(!e.contains("another run"), "{e}");
}

/// A change made to a genuine checkpoint.
type Forgery = Box<dyn Fn(&mut checkpoint::Checkpoint)>;

/// The snapshots output's state: the pictured steps' (step, time, positions).
type Pictured = Vec<(usize, f64, Vec<flexsurf::math::Vec3>)>;

/// Changes the state the output `name` saved in `c` with `change`.
fn forge_output<T: serde::Serialize + serde::de::DeserializeOwned>(
    c: &mut checkpoint::Checkpoint,
    name: &str,
    change: impl Fn(&mut T),
) {
    let (_, state) = c.outputs.iter_mut().find(|(n, _)| n == name).unwrap();
    let mut value: T = state.get(name).unwrap();
    change(&mut value);
    *state = OutputState::of(&value).unwrap();
}

#[test]
fn regression_a_forged_checkpoint_with_a_valid_checksum_panicked() {
    let d = scratch("forged");
    let s = built(&d, SMALL);
    let out = d.join("out");
    stopped(&s, &out);
    let path = out.join(checkpoint::CHECKPOINT);
    let good = checkpoint::decode(&std::fs::read(&path).unwrap()).unwrap();
    let forgeries: Vec<(&str, Forgery)> = vec![
        ("a node short", Box::new(|c| c.state.x.truncate(24))),
        ("a velocity more", Box::new(|c| c.state.v.push(flexsurf::math::Vec3::ZERO))),
        ("a NaN position", Box::new(|c| c.state.x[3].y = f64::NAN)),
        ("a step past the end", Box::new(|c| c.state.step = 1_000_000)),
        (
            "a short picture",
            Box::new(|c| {
                forge_output(c, "snapshots", |v: &mut Pictured| v.push((1, 0.01, vec![flexsurf::math::Vec3::ZERO; 2])))
            }),
        ),
        (
            "a short animation frame",
            Box::new(|c| forge_output(c, "glb", |v: &mut Vec<FrameFields>| v[0].strain.clear())),
        ),
        (
            "too many frames",
            Box::new(|c| {
                forge_output(c, "frames", |v: &mut Vec<FrameRecord>| {
                    let f = v[0].clone();
                    v.resize(100, f);
                })
            }),
        ),
        ("a solver guess of another size", Box::new(|c| c.solver.guess = vec![flexsurf::math::Vec3::ZERO; 7])),
    ];
    for (what, forge) in forgeries {
        let mut ck = good.clone();
        forge(&mut ck);
        std::fs::write(&path, checkpoint::encode(&ck).unwrap()).unwrap();
        let resumed = run_scene_with(&s, &out, &RunOptions { resume: true, ..Default::default() }, |_| {});
        let e = resumed.unwrap_err().to_string();
        assert!(e.contains("does not fit the scene") || e.contains("cannot restore"), "{what}: {e}");
    }
    // The genuine one still resumes.
    std::fs::write(&path, checkpoint::encode(&good).unwrap()).unwrap();
    let o = run_scene_with(&s, &out, &RunOptions { resume: true, ..Default::default() }, |_| {}).unwrap();
    assert_eq!(o.summary.steps, 6);
}

#[cfg(unix)]
#[test]
fn regression_view_read_dev_zero_and_blocked_on_a_fifo() {
    use flexsurf::runner::viewer::view_html;
    let d = scratch("view-inputs");
    let s = built(&d, SMALL);
    let out = d.join("out");
    run(&s, &out, false).unwrap();
    assert!(view_html(&out).is_ok());
    std::fs::remove_file(out.join("summary.json")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", out.join("summary.json")).unwrap();
    let t = std::time::Instant::now();
    let e = view_html(&out).unwrap_err().to_string();
    assert!(e.contains("summary.json") && e.contains("device"), "{e}");
    std::fs::remove_file(out.join("summary.json")).unwrap();
    let status = std::process::Command::new("mkfifo").arg(out.join("summary.json")).status().unwrap();
    assert!(status.success());
    let e = view_html(&out).unwrap_err().to_string();
    assert!(e.contains("summary.json") && e.contains("FIFO"), "{e}");
    std::fs::remove_file(out.join("animation.glb")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", out.join("animation.glb")).unwrap();
    let e = view_html(&out).unwrap_err().to_string();
    assert!(e.contains("animation.glb") && e.contains("device"), "{e}");
    assert!(t.elapsed().as_secs() < 10, "answered at once, read nothing large");
}

#[test]
fn regression_a_scene_named_like_markup_blanked_the_viewer() {
    let d = scratch("view-name");
    let name = "<!--<script></script>&\u{2028}";
    let s = built(&d, &format!("name = {}\n{SMALL}", serde_json::to_string(name).unwrap()));
    let out = d.join("out");
    run(&s, &out, false).unwrap();
    let html = flexsurf::runner::viewer::view_html(&out).unwrap();
    let open = "<script id=\"flexsurf-data\" type=\"application/json\">";
    let start = html.find(open).unwrap() + open.len();
    let data = &html[start..start + html[start..].find("</script>").unwrap()];
    for markup in ["<", ">", "&", "\u{2028}"] {
        assert!(!data.contains(markup), "{markup:?} in the page's data");
    }
    let value: serde_json::Value = serde_json::from_str(data).unwrap();
    assert_eq!(value["summary"]["scene"], name);
}

#[test]
fn regression_an_empty_output_path_ran_into_the_working_directory() {
    let d = scratch("empty");
    let s = built(&d, SMALL);
    for resume in [false, true] {
        let options = RunOptions { resume, ..Default::default() };
        let e = run_scene_with(&s, Path::new(""), &options, |_| panic!("no step may run")).unwrap_err();
        let e = e.to_string();
        assert!(e.contains("the output folder's path is empty") && e.contains("\".\""), "{e}");
    }
}
