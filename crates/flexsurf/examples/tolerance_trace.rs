//! Two runs of a scene side by side at two contact solve tolerances (`[integrator] contact_solve_tolerance`,
//! issue 23, item 2): per step the largest distance between their nodes and, for each run, its contacts, solves,
//! re-solves, corrections, iterations, relative Newton residual and Newton iterations. `SCENE=path.toml cargo run
//! --release -p flexsurf --example tolerance_trace -- N STEPS auto|cholesky|multigrid TOL_A TOL_B` (the scene's
//! sheet at N × N). `SCENE_B=other.toml`: the second run is of that scene instead (two inputs a relative 1e-12
//! apart in one number, at one tolerance given twice, show whether a result is continuous in its input).
use flexsurf::integrate::{linsolve::SolverKind, Stepper};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args[1].parse().unwrap();
    let steps: usize = args[2].parse().unwrap();
    let solver = match args[3].as_str() {
        "cholesky" => SolverKind::Cholesky,
        "multigrid" => SolverKind::Multigrid,
        _ => SolverKind::Auto,
    };
    let tols: Vec<f64> = vec![args[4].parse().unwrap(), args[5].parse().unwrap()];
    let path = std::env::var("SCENE").unwrap();
    let paths = [path.clone(), std::env::var("SCENE_B").unwrap_or(path)];
    let mut runs: Vec<_> = tols
        .iter()
        .zip(&paths)
        .map(|(&t, path)| {
            let scene = flexsurf::bench::scene_file(std::path::Path::new(path), n).unwrap();
            let p = flexsurf::integrate::StepParams { solver, contact_solve_tolerance: t, ..scene.step_params() };
            (scene.state.clone(), Stepper::new(&scene.model, &p).unwrap(), scene)
        })
        .collect();
    for s in 0..steps {
        let mut line = String::new();
        for (state, stepper, scene) in runs.iter_mut() {
            let info = stepper.step(&scene.model, state).unwrap();
            let c = info.timings;
            line += &format!(
                " | c{:4} s{} rs{} co{} it{:3} res {:.2e} v{}",
                info.contacts,
                c.solves,
                c.resolves,
                c.corrections,
                c.iterations,
                info.newton.residual,
                info.newton.iterations
            );
        }
        let d = runs[0].0.x.iter().zip(&runs[1].0.x).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        println!("step {:3} d {:.3e}{}", s + 1, d, line);
    }
}
