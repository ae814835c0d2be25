//! Where a sewing phase fails: builds a `[pattern]` scene, keeping the sewing's last two frames, and on a
//! failure prints the failing node (its panel and grid place), its distance from the body, its last step's
//! move, whether it is one of a sewn pair, and the nearest triangles of the sheet that do not hold it; sewn,
//! the same for the first drape step that fails (of three, or of STEPS). Run:
//! `cargo run --release -p flexsurf --example sewing_trace -- SCENE.toml [STEPS]`.
use flexsurf::contact::proximity::Pair;
use flexsurf::integrate::StepError;
use flexsurf::math::Vec3;
use flexsurf::model::Model;
use flexsurf::potential::sewing::Sewing;
use std::path::PathBuf;

/// The node a failure's message names (`… node N …`).
fn node_in(message: &str) -> Option<usize> {
    message.split("node ").nth(1)?.split(' ').next()?.parse().ok()
}

fn report(model: &Model, x: &[Vec3], before: &[Vec3], node: usize) {
    println!("node {node}: {}", model.describe_node(node));
    println!("  at {:?}, moved {:.3e} m in the last step taken", x[node], (x[node] - before[node]).length());
    for (i, body) in model.obstacles().iter().enumerate() {
        println!("  obstacle {i}: signed distance {:.4e} m", body.distance(x[node]).0);
    }
    if let Some(s) = model.potential.find::<Sewing>() {
        for &(a, b) in s.node_pairs().iter().filter(|&&(a, b)| a == node || b == node) {
            println!("  sewn pair ({a}, {b}): {:.4e} m apart", (x[a] - x[b]).length());
        }
    }
    let faces = model.faces();
    // Folds near the node: the angle between the normals of two triangles sharing an edge, within 3 cm.
    let normal = |t: &[usize; 3]| (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).normalize_or_zero();
    let near: Vec<&[usize; 3]> = faces.triangles.iter().filter(|t| (x[t[0]] - x[node]).length() < 0.03).collect();
    let mut folds = Vec::new();
    for (a, ta) in near.iter().enumerate() {
        for tb in &near[a + 1..] {
            if ta.iter().filter(|k| tb.contains(k)).count() == 2 {
                folds.push((normal(ta).dot(normal(tb)).clamp(-1.0, 1.0).acos().to_degrees(), **ta, **tb));
            }
        }
    }
    folds.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (angle, ta, tb) in folds.iter().take(3) {
        println!(
            "  fold {angle:.1} deg between {:?} and {:?}",
            ta.map(|k| model.describe_node(k)),
            tb.map(|k| model.describe_node(k))
        );
    }
    // The self-contact's own closest points, node against each triangle that does not hold it.
    let mut near: Vec<(f64, [usize; 3])> = (faces.triangles.iter().enumerate())
        .filter(|(_, t)| !t.contains(&node))
        .map(|(k, t)| (faces.closest(Pair::PointFace(node, k), x).distance(), *t))
        .collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (d, t) in near.iter().take(4) {
        let who = t.map(|k| model.describe_node(k));
        println!("  triangle {t:?} at {d:.4e} m: {who:?}");
    }
}

fn main() {
    let path = PathBuf::from(std::env::args().nth(1).expect("usage: sewing_trace SCENE.toml"));
    let spec = flexsurf::scene::SceneSpec::load(&path).unwrap();
    let mut frames: Vec<(Model, Vec<Vec3>)> = Vec::new();
    let mut count = 0usize;
    let mut observe = |m: &Model, x: &[Vec3]| {
        count += 1;
        if frames.len() == 2 {
            frames.remove(0);
        }
        frames.push((m.clone(), x.to_vec()));
    };
    let result = spec.build_observed(&path, &flexsurf::scene::Limits::default(), &mut observe);
    println!("{count} sewing frames");
    let scene = match result {
        Ok(scene) => scene,
        Err(e) => {
            println!("{e}");
            if let (Some(node), [.., (_, before), (model, x)]) = (node_in(&e.to_string()), frames.as_slice()) {
                report(model, x, before, node);
            }
            return;
        }
    };
    // Sewn: the drape's first steps, and where the first failing one fails.
    let (model, mut state) = (&scene.model, scene.state.clone());
    let mut stepper = flexsurf::integrate::Stepper::new(model, &scene.step_params()).unwrap();
    let deepest = flexsurf::integrate::max_penetration(model, &state.x);
    println!("sewn: {} nodes, the deepest {deepest:.2e} m inside an obstacle", model.nodes());
    let drape_steps = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    for step in 1..=drape_steps {
        let before = state.x.clone();
        match stepper.step(model, &mut state) {
            Ok(info) => println!(
                "drape step {step} taken: {} solves, {} factorisations, deepest {:.2e} m, {:.2} s",
                info.timings.solves,
                info.timings.factorizations,
                info.max_penetration,
                info.timings.assembly + info.timings.contact + info.timings.factorization + info.timings.solve
            ),
            Err(e) => {
                println!("drape step {step}: {e}");
                if let StepError::Tunnelled { node, .. } = e {
                    report(model, &before, &before, node);
                }
                return;
            }
        }
    }
}
