//! What joining the T-shirt's seams does to the drape's start (docs/garments.md, Sewing): the shipped scene
//! (`scenes/tshirt.toml`) sewn, then the joined state's forces and the first three drape steps from
//! `integrate::start` (the accelerations of the joined state in the history) and from the scene's own start
//! (`integrate::start_unaccelerated`). Run:
//! `cargo run --profile ci -p flexsurf --example tshirt_join` (about 20 s).
use flexsurf::integrate::Stepper;
use flexsurf::math::Vec3;
use flexsurf::model::Model;
use flexsurf::potential::Part;
use flexsurf::state::State;
use std::path::Path;

/// The smallest signed distance of the nodes from the body (cold queries), and the node.
fn deepest(model: &Model, x: &[Vec3]) -> (f64, usize) {
    let body = &model.obstacles()[0];
    let near = x.iter().enumerate().filter_map(|(k, p)| body.distance_hinted(*p, &mut None, 0.1).map(|(d, _)| (d, k)));
    near.fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
}

/// The membrane energy of `model` at `x`, and its gradient.
fn membrane(model: &Model, x: &[Vec3]) -> (f64, Vec<Vec3>) {
    let mut g = vec![Vec3::ZERO; x.len()];
    let e = model.potential.value_of(x, |p| p == Part::Membrane, Some(&mut g)).total;
    (e, g)
}

/// Three drape steps from `state`: the deepest node and the kinetic energy after each.
fn drape(label: &str, model: &Model, mut state: State, params: &flexsurf::integrate::StepParams) {
    let mut stepper = Stepper::new(model, params).unwrap();
    for step in 1..=3 {
        let before = state.x.clone();
        stepper.step(model, &mut state).unwrap();
        let (d, k) = deepest(model, &state.x);
        let moved = before.iter().zip(&state.x).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        println!(
            "{label}, step {step}: deepest {d:.5} m ({}), largest move {moved:.5} m, kinetic energy {:.3e} J",
            model.describe_node(k),
            state.kinetic_energy(&model.mass)
        );
    }
}

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/tshirt.toml");
    let spec = flexsurf::scene::SceneSpec::load(&path).unwrap();
    let mut last: Option<(Model, Vec<Vec3>)> = None;
    let mut observe = |m: &Model, x: &[Vec3]| last = Some((m.clone(), x.to_vec()));
    let scene = spec.build_observed(&path, &flexsurf::scene::Limits::default(), &mut observe).unwrap();
    let (open, sewn) = last.unwrap();
    let (model, x) = (&scene.model, &scene.state.x);
    // Each panel node (the open model's numbering) to its joined node.
    let joined: Vec<usize> = model.panels.iter().flat_map(|p| p.nodes().iter().copied()).collect();
    let moved = joined.iter().enumerate().map(|(i, &k)| (sewn[i] - x[k]).length()).fold(0.0, f64::max);
    println!("the join moves a panel node {moved:.3e} m at the most (to the midpoint of its pair)");
    // The open model's membrane at the sewn positions and at the joined ones, against the joined model's.
    let at_joined: Vec<Vec3> = joined.iter().map(|&k| x[k]).collect();
    let (e_joined, g_joined) = membrane(model, x);
    let (e_open, g_open) = membrane(&open, &at_joined);
    let mut summed = vec![Vec3::ZERO; x.len()];
    joined.iter().zip(&g_open).for_each(|(&k, g)| summed[k] += *g);
    let differ = summed.iter().zip(&g_joined).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    println!(
        "membrane energy: sewn {:.5} J, joined {e_joined:.5} J (the open panels at the joined positions {e_open:.5} J, \
         their forces differing from the joined model's by {differ:.1e} N at the most)",
        membrane(&open, &sewn).0
    );
    // The accelerations `integrate::start` takes at the joined state.
    let dt = scene.dt;
    let zero = vec![Vec3::ZERO; x.len()];
    let accelerated = flexsurf::integrate::start(model, x.clone(), zero, dt).unwrap();
    let a: Vec<f64> = (0..x.len()).map(|k| (accelerated.x_prev[k] - x[k]).length() * 2.0 / (dt * dt)).collect();
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&i, &j| a[j].total_cmp(&a[i]));
    for &k in &order[..4] {
        let f = a[k] * model.mass[k];
        println!(
            "start acceleration {:.3e} m/s² ({f:.1} N on {:.1} mg) at {}",
            a[k],
            model.mass[k] * 1e6,
            model.describe_node(k)
        );
    }
    let (d, k) = deepest(model, x);
    println!("at the join: deepest {d:.5} m ({})", model.describe_node(k));
    let params = scene.step_params();
    drape("integrate::start", model, accelerated, &params);
    drape("the scene's start", model, scene.state.clone(), &params);
}
