//! The `flexsurf` command on good and bad input: exit codes and one-line error messages, never a panic.

use std::path::Path;
use std::process::Command;

fn flexsurf(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_flexsurf")).args(args).output().expect("run flexsurf");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.code().unwrap_or(-1), text(&out.stdout), text(&out.stderr))
}

#[test]
fn check_schema_and_errors() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/ball_drop.toml");
    let (code, stdout, _) = flexsurf(&["check", scene.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(stdout.contains("21 × 21"), "{stdout}");

    let (code, stdout, _) = flexsurf(&["schema"]);
    assert_eq!(code, 0);
    let schema: serde_json::Value = serde_json::from_str(&stdout).expect("schema is JSON");
    assert!(schema["properties"].get("sheet").is_some());
    assert!(schema["properties"].get("pattern").is_some());
    let (code, stdout, _) = flexsurf(&["schema", "--pattern"]);
    assert_eq!(code, 0);
    let schema: serde_json::Value = serde_json::from_str(&stdout).expect("the pattern schema is JSON");
    assert!(schema["properties"].get("panel").is_some() && schema["properties"].get("seam").is_some());

    let dir = std::env::temp_dir().join(format!("flexsurf-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad_dt.toml");
    std::fs::write(&bad, "[sheet]\nsize = [1.0, 1.0]\nnodes = [5, 5]\n[time]\ndt = -0.01\nsteps = 3\n").unwrap();
    for args in [vec!["check", bad.to_str().unwrap()], vec!["run", bad.to_str().unwrap(), "--out", "unused"]] {
        let (code, _, stderr) = flexsurf(&args);
        assert_ne!(code, 0);
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains("bad_dt.toml") && stderr.contains("`time.dt`"), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    let (code, _, stderr) = flexsurf(&["check", dir.join("absent.toml").to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("absent.toml") && !stderr.contains("panicked"), "{stderr}");
    assert!(!dir.join("unused").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `flexsurf test cantilever`: the bias strip reports both orthotropic bounds as JSON and writes its side view
/// and mesh; bad options are one-line errors naming the option.
#[test]
fn cantilever_command() {
    let dir = std::env::temp_dir().join(format!("flexsurf-cli-cantilever-{}", std::process::id()));
    let out = dir.to_str().unwrap();
    let (code, stdout, stderr) = flexsurf(&["test", "cantilever", "--direction", "bias", "--json", "--out", out]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    for (key, file) in [("picture", "cantilever_side.png"), ("mesh", "cantilever.obj")] {
        assert!(v[key].as_str().unwrap().ends_with(file), "{v}");
        assert!(dir.join(file).metadata().unwrap().len() > 1000, "{file}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
    let r = &v["report"];
    assert_eq!(r["direction"], "bias");
    let (input, implied, plate) = (
        r["input_rigidity"].as_f64().unwrap(),
        r["implied_rigidity"].as_f64().unwrap(),
        r["plate_rigidity"].as_f64().unwrap(),
    );
    assert!(input < implied && implied < plate, "{r}");
    for (opt, val) in [("--width", "-0.01"), ("--overhang", "0"), ("--width", "nan")] {
        let (code, _, stderr) = flexsurf(&["test", "cantilever", &format!("{opt}={val}")]);
        assert_ne!(code, 0);
        assert!(stderr.contains(opt) && !stderr.contains("panicked"), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    }
    for (opt, val) in [
        ("--level", "3"),
        ("--specimens", "0"),
        ("--specimens", "11"),
        ("--folds", "73"),
        ("--folds", "18446744073709551615"),
        ("--rest-speed", "0"),
    ] {
        let (code, _, stderr) = flexsurf(&["test", "cusick", opt, val]);
        assert_ne!(code, 0);
        assert!(stderr.contains(opt) && !stderr.contains("panicked"), "{stderr}");
    }
}

/// `flexsurf test` has one subcommand per virtual test, and each accepts only its own options: an option of
/// another test, a missing or unknown test are usage errors (exit code 2) naming what is wrong.
#[test]
fn test_options_belong_to_their_test() {
    for args in [
        ["kes", "--direction", "weft"],
        ["kes", "--width", "0.02"],
        ["kes", "--level", "1"],
        ["kes", "--specimens", "2"],
        ["cantilever", "--specimen", "0.30"],
        ["cantilever", "--level", "0"],
        ["cusick", "--direction", "bias"],
        ["cusick", "--overhang", "0.08"],
    ] {
        let (code, stdout, stderr) = flexsurf(&[&["test"][..], &args].concat());
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stdout.is_empty(), "{args:?}: {stdout}");
        assert!(stderr.contains(&format!("unexpected argument '{}'", args[1])), "{args:?}: {stderr}");
        assert!(stderr.contains(&format!("flexsurf test {}", args[0])), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    let (code, _, stderr) = flexsurf(&["test"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(["kes", "cantilever", "cusick"].iter().all(|t| stderr.contains(t)), "{stderr}");
    let (code, _, stderr) = flexsurf(&["test", "drape"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("unrecognized subcommand 'drape'"), "{stderr}");
}

#[test]
fn view_writes_a_self_contained_page_and_names_a_folder_without_a_run() {
    let dir = std::env::temp_dir().join(format!("flexsurf-cli-view-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/ball_drop.toml");
    let text = std::fs::read_to_string(&scene)
        .unwrap()
        .replace("nodes = [21, 21]", "nodes = [7, 7]")
        .replace("steps = 300", "steps = 20")
        .replace("output_every = 100", "output_every = 10")
        .replace("image_size = [480, 360]", "image_size = [80, 60]");
    let small = dir.join("small.toml");
    std::fs::write(&small, text).unwrap();
    let run = dir.join("run");
    let (code, _, stderr) = flexsurf(&["run", small.to_str().unwrap(), "--out", run.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let (code, stdout, stderr) = flexsurf(&["view", run.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("view.html"), "{stdout}");
    let html = std::fs::read_to_string(run.join("view.html")).unwrap();
    assert!(html.contains("window.flexsurfView") && html.contains("\"glb\":\"Z2xURg"), "the glb is inlined");
    assert!(!html.contains("__FLEXSURF_DATA__"));

    // A folder without a run: one line naming the missing file, no page, no panic.
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let (code, _, stderr) = flexsurf(&["view", empty.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("animation.glb") && !stderr.contains("panicked"), "{stderr}");
    assert!(!empty.join("view.html").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn cantilever_sweep_charts_the_chord_angle() {
    let dir = std::env::temp_dir().join(format!("flexsurf-cli-cantilever-sweep-{}", std::process::id()));
    let out = dir.to_str().unwrap();
    let (code, stdout, stderr) = flexsurf(&["test", "cantilever", "--overhang", "0.04,0.07", "--json", "--out", out]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let reports = v["reports"].as_array().unwrap();
    assert_eq!(reports.len(), 2);
    let chord = |k: usize| reports[k]["chord_angle_deg"].as_f64().unwrap();
    // A longer overhang droops more.
    assert!(chord(1) > chord(0), "{} then {}", chord(0), chord(1));
    assert!(v["chart"].as_str().unwrap().ends_with("cantilever_sweep.png"));
    assert!(dir.join("cantilever_sweep.png").metadata().unwrap().len() > 1000);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn view_serve_answers_on_the_loopback_interface() {
    use std::io::{BufRead, BufReader, Read, Write};
    let dir = std::env::temp_dir().join(format!("flexsurf-cli-serve-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/ball_drop.toml");
    let text = std::fs::read_to_string(&scene)
        .unwrap()
        .replace("nodes = [21, 21]", "nodes = [7, 7]")
        .replace("steps = 300", "steps = 10")
        .replace("output_every = 100", "output_every = 5")
        .replace("image_size = [480, 360]", "image_size = [80, 60]");
    let small = dir.join("small.toml");
    std::fs::write(&small, text).unwrap();
    let run = dir.join("run");
    assert_eq!(flexsurf(&["run", small.to_str().unwrap(), "--out", run.to_str().unwrap()]).0, 0);
    let mut child = Command::new(env!("CARGO_BIN_EXE_flexsurf"))
        .args(["view", run.to_str().unwrap(), "--serve", "--port", "0"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let serving = lines.find_map(|l| l.ok().filter(|l| l.starts_with("serving "))).expect("the address");
    let addr = serving.trim_start_matches("serving http://").split('/').next().unwrap().to_string();
    assert!(addr.starts_with("127.0.0.1:"), "{serving}");
    let get = |path: &str| {
        let mut s = std::net::TcpStream::connect(&addr).unwrap();
        write!(s, "GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
        let mut body = String::new();
        s.read_to_string(&mut body).unwrap();
        body
    };
    let page = get("/");
    let state = get("/state");
    let missing = get("/nope");
    child.kill().unwrap();
    let _ = child.wait();
    assert!(page.starts_with("HTTP/1.1 200 OK") && page.contains("window.flexsurfView"), "{}", &page[..200]);
    assert!(page.contains("\"live\":\""), "the served page follows the run");
    assert!(state.starts_with("HTTP/1.1 200 OK"));
    let token = state.split("\r\n\r\n").nth(1).unwrap();
    assert!(page.contains(&format!("\"live\":\"{token}\"")), "{token}");
    assert!(missing.starts_with("HTTP/1.1 404"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 22: `density = 70` (g/m² in the kg/m² key) was "ok"; `check` and `run` print a warning on stderr that
/// names the key, the value and the usual range in both unit systems, and still answer; a virtual test's and a
/// fit's material file's constants are warned about as well.
#[test]
fn check_and_run_warn_about_a_unit_slip() {
    let dir = flexsurf::testing::scratch("cli", "unit-slip");
    let scene = dir.join("heavy.toml");
    std::fs::write(
        &scene,
        "[sheet]\nsize = [1.0, 1.0]\nnodes = [5, 5]\n[time]\ndt = 0.01\nsteps = 2\n[output]\nimage_size = [32, 24]\n\
         [material]\npreset = \"paper-cotton\"\ndensity = 70\n",
    )
    .unwrap();
    let out = dir.join("out");
    for args in
        [vec!["check", scene.to_str().unwrap()], vec!["run", scene.to_str().unwrap(), "--out", out.to_str().unwrap()]]
    {
        let (code, stdout, stderr) = flexsurf(&args);
        assert_eq!(code, 0, "{args:?}: {stderr}");
        assert!(stderr.contains("warning: ") && stderr.contains("`material.density`"), "{stderr}");
        assert!(stderr.contains("70 kg/m²") && stderr.contains("mg/cm²"), "{stderr}");
        assert!(!stdout.contains("warning"), "{stdout}");
    }
    // The virtual tests say it too (they dropped the material file's warnings before).
    let material = dir.join("heavy-material.toml");
    let text = "units = \"si\"\ndensity = 70\ntensile_warp = 1000\ntensile_weft = 1000\nshear = 10\n\
                bending_warp = 1e-5\nbending_weft = 1e-5\n";
    std::fs::write(&material, text).unwrap();
    let kes = dir.join("kes");
    let (code, _, stderr) =
        flexsurf(&["test", "kes", "--material", material.to_str().unwrap(), "--out", kes.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("warning: ") && stderr.contains("`density`") && stderr.contains("mg/cm²"), "{stderr}");
    // And a fit that starts from it.
    let fit = dir.join("fit.toml");
    let text = "material = \"heavy-material.toml\"\n[free.density]\n[[target]]\nquantity = \"kes.weight\"\n\
                value = 25.0\nsigma = 0.5\n";
    std::fs::write(&fit, text).unwrap();
    let report = dir.join("fit.json");
    let (code, _, stderr) = flexsurf(&["fit", fit.to_str().unwrap(), "--out", report.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("warning: ") && stderr.contains("`density`"), "{stderr}");
    // The report keeps the warning (it was only printed).
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let kept = json["problem"]["warnings"].as_array().map(|w| w.iter().filter_map(|m| m.as_str()).collect());
    assert!(kept.is_some_and(|w: Vec<&str>| w.len() == 1 && w[0].contains("`density`")), "{json}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `flexsurf check` of a garment whose sewing phase pulls the cloth through itself said "ok" (it checks values
/// without building the model), and only the run failed; `check --build` builds it as a run starts, sewing
/// included, and fails as the run would, naming the file and `pattern`; a sound garment reports its sewing.
#[test]
fn regression_check_said_ok_of_a_garment_that_could_not_be_sewn() {
    let dir = flexsurf::testing::scratch("cli", "check-build");
    let repo = flexsurf::testing::repo();
    let text = std::fs::read_to_string(repo.join("scenes/four_gore_skirt.toml")).unwrap();
    let pattern = repo.join("garments/four_gore_skirt.toml").display().to_string();
    let text = text.replace("../garments/four_gore_skirt.toml", &pattern);
    let (good, bad) = (dir.join("skirt.toml"), dir.join("torn.toml"));
    std::fs::write(&good, &text).unwrap();
    let stiff = text.lines().map(|l| if l.starts_with("sewing_stiffness") { "sewing_stiffness = 1e9" } else { l });
    std::fs::write(&bad, stiff.collect::<Vec<_>>().join("\n")).unwrap();
    let (code, stdout, stderr) = flexsurf(&["check", bad.to_str().unwrap()]);
    assert!(code == 0 && stdout.contains("ok"), "{stderr}");
    let (code, _, stderr) = flexsurf(&["check", "--build", bad.to_str().unwrap()]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("torn.toml") && stderr.contains("`pattern`") && stderr.contains("passes through itself"));
    let (code, stdout, stderr) = flexsurf(&["check", "--build", good.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("built — 800 nodes; pattern four_gore_skirt sewn in"), "{stdout}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `flexsurf fit`: a small fit file (short strips) gives the constants, their standard errors and the residuals
/// as JSON and in the report file; shear, free beside two bending lengths alone, is reported not identifiable;
/// an error in the file is one line naming the file and the key.
#[test]
fn fit_command() {
    let dir = std::env::temp_dir().join(format!("flexsurf-cli-fit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let material = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../materials/woven-medium.toml");
    let text = format!(
        "material = {:?}\nunits = \"kes\"\ncolumns = 18\n[free.bending_warp]\n[free.bending_weft]\n[free.shear]\n\
         [[target]]\nquantity = \"bending_length.warp\"\nvalue = 1.6\nsigma = 0.02\n\
         [[target]]\nquantity = \"bending_length.weft\"\nvalue = 1.4\nsigma = 0.02\n",
        material.to_str().unwrap()
    );
    let file = dir.join("fit.toml");
    std::fs::write(&file, &text).unwrap();
    let report = dir.join("report.json");
    let (code, stdout, stderr) =
        flexsurf(&["fit", file.to_str().unwrap(), "--json", "--out", report.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let written: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(v, written);
    let r = &v["report"];
    assert_eq!(r["not_identifiable"], serde_json::json!(["shear"]), "{r}");
    assert_eq!(r["constants"][0]["name"], "bending_warp");
    assert!(r["constants"][0]["standard_error"].as_f64().unwrap() > 0.0, "{r}");
    assert!(r["residuals"][0]["normalised"].as_f64().unwrap().abs() < 1e-6, "{r}");
    std::fs::write(&file, text.replace("[free.shear]", "[free.shear]\nlower = -1.0")).unwrap();
    let (code, _, stderr) = flexsurf(&["fit", file.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("fit.toml") && stderr.contains("free.shear") && !stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}
