//! Two scene files run side by side (issue 23, item 2: how far apart two runs of nearly the same input end):
//! per step the largest distance between their nodes and, for each run, its contacts, solves, re-solves,
//! corrections, relative Newton residual and Newton iterations. `cargo run --release -p flexsurf --example
//! perturb_trace -- A.toml B.toml N STEPS` (each scene's sheet at N × N; for a garment, N as
//! `examples/tolerance_trace` takes it). Two files a relative 1e-12 apart in one number (the gravity, say) show
//! whether a scene's result is a continuous function of its input at the step's Δt.
use flexsurf::integrate::Stepper;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args[3].parse().expect("N");
    let steps: usize = args[4].parse().expect("STEPS");
    let mut runs: Vec<_> = args[1..3]
        .iter()
        .map(|path| {
            let scene = flexsurf::bench::scene_file(std::path::Path::new(path), n).expect("scene");
            let stepper = Stepper::new(&scene.model, &scene.step_params()).expect("stepper");
            (scene.state.clone(), stepper, scene)
        })
        .collect();
    for s in 0..steps {
        let mut line = String::new();
        for (state, stepper, scene) in runs.iter_mut() {
            let info = stepper.step(&scene.model, state).expect("step");
            let c = info.timings;
            line += &format!(
                " | c{:4} s{} rs{} co{} res {:.3e} v{}",
                info.contacts, c.solves, c.resolves, c.corrections, info.newton.residual, info.newton.iterations
            );
        }
        let d = runs[0].0.x.iter().zip(&runs[1].0.x).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        println!("step {:4} d {:.3e}{}", s + 1, d, line);
    }
}
