//! The files a run writes for other tools, read back with independent readers: `animation.glb` through the
//! `gltf` crate (which validates the document), the VTK series through `vtkio`, the pictures through `image`,
//! and `view.html`'s data.

use flexsurf::io::viewer;
use flexsurf::runner::run_scene;
use flexsurf::scene::SceneSpec;
use std::path::{Path, PathBuf};

use flexsurf::testing::repo;

/// A fresh empty directory for one test.
fn scratch(tag: &str) -> PathBuf {
    flexsurf::testing::scratch("outputs", tag)
}

/// A short, coarse ball drop: 11 × 11 nodes, 60 steps, frames every 15 (steps 0, 15, 30, 45, 60).
fn short_ball_drop(out: &Path) -> flexsurf::runner::RunOutput {
    let path = repo().join("scenes/ball_drop.toml");
    let mut spec = SceneSpec::load(&path).unwrap();
    spec.sheet.as_mut().unwrap().nodes = [11, 11];
    spec.time.steps = 60;
    spec.time.output_every = Some(15);
    spec.output.image_size = [160, 120];
    spec.output.coons_subdivisions = 2;
    let scene = spec.build(&path).unwrap();
    run_scene(&scene, out, |_| {}).unwrap()
}

#[test]
fn glb_vtk_pictures_and_viewer_of_a_ball_drop() {
    let d = scratch("ball");
    let out = short_ball_drop(&d);
    let times: Vec<f64> = out.summary.frames.iter().map(|f| f.time).collect();
    assert_eq!(times.len(), 5);
    // Display mesh: 10 cells × 2 subdivisions + 1 = 21 vertices a side.
    let nv = 21 * 21;

    // ---- animation.glb, validated and read by the gltf crate.
    let bytes = std::fs::read(d.join("animation.glb")).unwrap();
    let gltf = gltf::Gltf::from_slice(&bytes).expect("a valid glTF binary");
    let blob = gltf.blob.as_deref().expect("a BIN chunk");
    let doc = &gltf.document;
    let cloth = doc.nodes().find(|n| n.name() == Some("cloth")).expect("a cloth node");
    let prim = cloth.mesh().unwrap().primitives().next().unwrap();
    let reader = prim.reader(|_| Some(blob));
    let base: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    assert_eq!(base.len(), nv);
    let uv: Vec<[f32; 2]> = reader.read_tex_coords(0).unwrap().into_f32().collect();
    // UVs in pattern metres: the 1 m × 1 m sheet spans [0, 1]².
    let (umax, vmax) = uv.iter().fold((0.0f32, 0.0f32), |a, t| (a.0.max(t[0]), a.1.max(t[1])));
    assert!((umax - 1.0).abs() < 1e-6 && (vmax - 1.0).abs() < 1e-6, "{umax} {vmax}");
    assert_eq!(reader.read_indices().unwrap().into_u32().count(), 3 * 2 * 20 * 20);
    let targets: Vec<_> = reader.read_morph_targets().collect();
    assert_eq!(targets.len(), 4, "one morph target per frame after the first");
    // The last frame (base + last target) is the last .vtu frame, and has fallen onto the ball (top ≈ 0.3 m).
    let last: Vec<[f32; 3]> = base
        .iter()
        .zip(targets[3].0.clone().unwrap())
        .map(|(p, dp)| [p[0] + dp[0], p[1] + dp[1], p[2] + dp[2]])
        .collect();
    let top = last.iter().map(|p| p[2]).fold(f32::MIN, f32::max);
    assert!(top < 0.32 && top > 0.28, "top of the last frame {top}");
    assert!(base.iter().all(|p| (p[2] - 0.35).abs() < 1e-6), "the first frame is the flat sheet at 0.35 m");
    // The animation samples the morph weights at the simulated times of the frames.
    let anim = doc.animations().next().expect("an animation");
    let channel = anim.channels().next().unwrap();
    assert_eq!(channel.target().node().name(), Some("cloth"));
    assert_eq!(channel.target().property(), gltf::animation::Property::MorphTargetWeights);
    let ch_reader = channel.reader(|_| Some(blob));
    let inputs: Vec<f32> = ch_reader.read_inputs().unwrap().collect();
    assert_eq!(inputs, times.iter().map(|&t| t as f32).collect::<Vec<_>>());
    let gltf::animation::util::ReadOutputs::MorphTargetWeights(w) = ch_reader.read_outputs().unwrap() else {
        panic!("not morph weights")
    };
    let w: Vec<f32> = w.into_f32().collect();
    assert_eq!(w.len(), 5 * 4);
    assert_eq!(&w[12..16], &[0.0, 0.0, 1.0, 0.0], "frame 3 is target 2 alone");
    // The obstacle: a sphere mesh of radius 0.3 about the origin, under the z-up root node.
    let ball = doc.nodes().find(|n| n.name().is_some_and(|s| s.contains("sphere"))).expect("the ball");
    let bp: Vec<[f32; 3]> =
        ball.mesh().unwrap().primitives().next().unwrap().reader(|_| Some(blob)).read_positions().unwrap().collect();
    assert!(bp.iter().all(|p| ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 0.3).abs() < 1e-5));
    let root = doc.scenes().next().unwrap().nodes().next().unwrap();
    assert_eq!(root.children().count(), 2);
    // Per-frame fields in extras: strain and contact pressure accessors, zero pressure before the fall.
    let extras: serde_json::Value = serde_json::from_str(doc.as_json().extras.as_ref().unwrap().get()).unwrap();
    let frames = extras["flexsurf"]["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 5);
    let scalar = |i: u64| -> Vec<f32> {
        let a = doc.accessors().nth(i as usize).unwrap();
        let v = a.view().unwrap();
        let at = v.offset() + a.offset();
        blob[at..at + 4 * a.count()].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
    };
    let p0 = scalar(frames[0]["pressure"].as_u64().unwrap());
    let p4 = scalar(frames[4]["pressure"].as_u64().unwrap());
    assert_eq!(p0.len(), nv);
    assert!(p0.iter().all(|&p| p == 0.0), "no contact at the start");
    assert!(p4.iter().any(|&p| p > 0.0), "contact pressure on the ball at the end");
    let s4 = scalar(frames[4]["strain"].as_u64().unwrap());
    assert!(s4.iter().all(|&s| s >= 0.0) && s4.iter().any(|&s| s > 0.0));
    let max_strain = s4.iter().copied().fold(0.0f32, f32::max) as f64;
    assert!(max_strain <= out.summary.final_state.max_strain * (1.0 + 1e-5), "{max_strain}");

    // ---- the VTK series, read by vtkio.
    let pvd = std::fs::read_to_string(d.join("animation.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet ").count(), 5);
    assert!(pvd.contains("file=\"vtk/frame_00060.vtu\""), "{pvd}");
    use vtkio::model::{Attribute, DataSet};
    let read = |name: &str| {
        let vtk = vtkio::Vtk::import(d.join(name)).unwrap();
        let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else { panic!("{name}: not an unstructured grid") };
        pieces.into_iter().next().unwrap().into_loaded_piece_data(None).unwrap()
    };
    let f60 = read("vtk/frame_00060.vtu");
    assert_eq!(f60.num_points(), nv);
    let names: Vec<&str> = f60
        .data
        .point
        .iter()
        .map(|a| match a {
            Attribute::DataArray(a) => a.name.as_str(),
            Attribute::Field { name, .. } => name.as_str(),
        })
        .collect();
    assert_eq!(names, ["velocity", "strain", "contact_pressure", "uv"]);
    let points: Vec<f32> = f60.points.into_vec::<f32>().unwrap();
    for (k, p) in last.iter().enumerate() {
        for c in 0..3 {
            assert!((points[3 * k + c] - p[c]).abs() < 1e-5, "glb and vtu frames differ at vertex {k}");
        }
    }
    let obstacles = read("vtk/obstacles.vtu");
    assert!(obstacles.num_points() > 100);

    // ---- pictures: five snapshots in one row under a title; energy.png.
    let snaps = image::open(d.join("snapshots.png")).unwrap();
    assert_eq!(snaps.width(), 5 * 160);
    let energy = image::open(d.join("energy.png")).unwrap();
    assert_eq!((energy.width(), energy.height()), (800, 480));

    // ---- view.html carries the glb and the summary, and refers to nothing outside itself.
    let page = viewer::write_view(&d).unwrap();
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains(&flexsurf::io::gltf::base64_encode(&bytes)));
    assert!(html.contains("\"scene\":\"ball_drop\""));
    assert!(!html.contains("<script src") && !html.contains("http://") && !html.contains("https://"));

    // ---- animation.gif from the glb: 0.6 s at 10 pictures a second, the cloth drawn, moving.
    let gif = viewer::movie::write_gif(&d, 10.0, (160, 120)).unwrap();
    use image::AnimationDecoder;
    let dec = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(std::fs::File::open(&gif).unwrap())).unwrap();
    let frames: Vec<image::RgbaImage> = dec.into_frames().map(|f| f.unwrap().into_buffer()).collect();
    assert_eq!(frames.len(), 7);
    let cloth = |img: &image::RgbaImage| {
        img.pixels().filter(|p| p.0[0] > 120 && u16::from(p.0[0]) > 2 * u16::from(p.0[1]) && p.0[2] < 110).count()
    };
    assert!(cloth(&frames[0]) > 500, "{} cloth pixels", cloth(&frames[0]));
    assert_ne!(frames[0], frames[6]);

    // ---- a run in progress (no animation.glb or summary.json yet): the viewer reads the VTK series, rebuilt
    // into the same animation, which the gltf crate validates.
    std::fs::remove_file(d.join("animation.glb")).unwrap();
    std::fs::remove_file(d.join("summary.json")).unwrap();
    let (rebuilt, n) = viewer::series::glb_from_series(&d, &serde_json::json!({})).unwrap();
    assert_eq!(n, 5);
    let g2 = gltf::Gltf::from_slice(&rebuilt).expect("a valid glTF binary from the series");
    let blob2 = g2.blob.as_deref().unwrap();
    let cloth2 = g2.document.nodes().find(|n| n.name() == Some("cloth")).unwrap();
    let prim2 = cloth2.mesh().unwrap().primitives().next().unwrap();
    let r2 = prim2.reader(|_| Some(blob2));
    let base2: Vec<[f32; 3]> = r2.read_positions().unwrap().collect();
    let t2: Vec<_> = r2.read_morph_targets().collect();
    assert_eq!(t2.len(), 4);
    for (k, (p, dp)) in base2.iter().zip(t2[3].0.clone().unwrap()).enumerate() {
        for c in 0..3 {
            assert!((p[c] + dp[c] - last[k][c]).abs() < 1e-5, "vertex {k}");
        }
    }
    assert!(g2.document.nodes().any(|n| n.name().is_some_and(|s| s.starts_with("obstacle_0"))));
    let html = std::fs::read_to_string(viewer::write_view(&d).unwrap()).unwrap();
    assert!(html.contains("\"in_progress\":true") && html.contains("\"summary\":null"));
    std::fs::remove_dir_all(&d).unwrap();
}
