//! How deep the mannequin reaches through the skirt's faces between the nodes (issue 19): the shipped skirt
//! (`scenes/skirt.toml`) with either model, with and without `[contact] faces`, run to its end; each grid
//! triangle sampled at 45 barycentric points and each sample's signed distance from the body (cold queries).
//! Run: `cargo run --profile ci -p flexsurf --example skirt_faces -- tfs|terzopoulos on|off [STIFFNESS]`.
use flexsurf::math::Vec3;
use flexsurf::model::Model;
use flexsurf::potential::elastic::ModelKind;
use flexsurf::scene::SceneSpec;
use std::path::Path;

/// The deepest sample of the surface's triangles inside the body: (signed distance, triangle).
fn deepest_face_point(model: &Model, x: &[Vec3]) -> (f64, usize) {
    let body = &model.obstacles()[0];
    let n = 8;
    let mut worst = (f64::INFINITY, 0);
    for (t, tri) in model.faces().triangles.iter().enumerate() {
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = x[tri[0]] * (1.0 - a - b) + x[tri[1]] * a + x[tri[2]] * b;
                if let Some((d, _)) = body.distance_hinted(p, &mut None, 0.2) {
                    if d < worst.0 {
                        worst = (d, t);
                    }
                }
            }
        }
    }
    worst
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/skirt.toml");
    let mut spec = SceneSpec::from_toml(&std::fs::read_to_string(&file).unwrap(), &file).unwrap();
    spec.model.kind =
        if args.get(1).map(String::as_str) == Some("terzopoulos") { ModelKind::Terzopoulos } else { ModelKind::Tfs };
    spec.contact.faces = args.get(2).map(String::as_str) == Some("on");
    if let Some(k) = args.get(3) {
        spec.contact.stiffness = Some(k.parse().unwrap());
    }
    let scene = spec.build(&file).unwrap();
    let model = &scene.model;
    let mut state = scene.state.clone();
    let mut stepper = flexsurf::integrate::Stepper::new(model, &scene.step_params()).unwrap();
    let clock = std::time::Instant::now();
    let mut worst_run = (f64::INFINITY, 0, 0);
    for step in 1..=scene.steps {
        stepper.step(model, &mut state).unwrap();
        if step % 50 == 0 || step == scene.steps {
            let (d, t) = deepest_face_point(model, &state.x);
            let body = &model.obstacles()[0];
            let (nodes, k) = state
                .x
                .iter()
                .enumerate()
                .filter_map(|(k, p)| body.distance_hinted(*p, &mut None, 0.2).map(|r| (r.0, k)))
                .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
            println!(
                "step {step}: deepest face point {d:.4} m (triangle {t}), deepest node {nodes:.4} m ({} at {:?})",
                model.describe_node(k),
                state.x[k]
            );
            if d < worst_run.0 {
                worst_run = (d, t, step);
            }
        }
    }
    println!(
        "{:?} faces={}: worst {:.4} m at step {} ({:.1} s)",
        spec.model.kind,
        spec.contact.faces,
        worst_run.0,
        worst_run.2,
        clock.elapsed().as_secs_f64()
    );
}
