//! Where a sewing phase fails: builds a `[pattern]` scene, keeping the sewing's last two frames, and on a
//! failure prints the failing node (its panel and grid place), its distance from the body, its last step's
//! move, whether it is one of a sewn pair, and the nearest triangles of the sheet that do not hold it; sewn,
//! the same for the first drape step that fails (of three). Run:
//! `cargo run --release -p flexsurf --example sewing_trace -- SCENE.toml`.
use flexsurf::math::Vec3;
use flexsurf::model::Model;
use flexsurf::potential::sewing::Sewing;
use std::path::PathBuf;

/// Distance from `p` to the triangle `a b c` (by projection onto its plane, else its edges).
fn to_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> f64 {
    let n = (b - a).cross(c - a);
    let area = n.length();
    if area > 0.0 {
        let n = n / area;
        let q = p - n * n.dot(p - a);
        let inside = [(a, b), (b, c), (c, a)].iter().all(|&(u, v)| (v - u).cross(q - u).dot(n) >= 0.0);
        if inside {
            return n.dot(p - a).abs();
        }
    }
    let seg = |u: Vec3, v: Vec3| {
        let t = ((p - u).dot(v - u) / (v - u).length_squared().max(1e-300)).clamp(0.0, 1.0);
        (p - (u + (v - u) * t)).length()
    };
    seg(a, b).min(seg(b, c)).min(seg(c, a))
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
    let mut near: Vec<(f64, [usize; 3])> = faces
        .triangles
        .iter()
        .filter(|t| !t.contains(&node))
        .map(|t| (to_triangle(x[node], t.map(|k| x[k])), *t))
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
            let node = e.to_string().split("node ").nth(1).and_then(|s| s.split(' ').next()?.parse::<usize>().ok());
            if let (Some(node), [.., (_, before), (model, x)]) = (node, frames.as_slice()) {
                report(model, x, before, node);
            }
            return;
        }
    };
    // Sewn: the drape's first steps, and where the first failing one fails.
    let (model, mut state) = (&scene.model, scene.state.clone());
    let mut stepper = flexsurf::integrate::Stepper::new(model, &scene.step_params()).unwrap();
    for step in 1..=3 {
        let before = state.x.clone();
        match stepper.step(model, &mut state) {
            Ok(_) => println!("drape step {step} taken"),
            Err(e) => {
                println!("drape step {step}: {e}");
                let node = e.to_string().split("node ").nth(1).and_then(|s| s.split(' ').next()?.parse::<usize>().ok());
                if let Some(node) = node {
                    report(model, &before, &before, node);
                }
                return;
            }
        }
    }
}
