//! Per-step solver trace of the bench ball drop: `cargo run --release -p flexsurf --example solve_trace -- N
//! STEPS [auto|cholesky|multigrid|pcg]` prints each step's solves, iterations, factorisations, re-solves and
//! Newton corrections (`SCENE=path.toml`: that scene's sheet at N × N instead of the bench's ball drop;
//! `TOUCHING=1`: the bench's touching workload, the sheet placed on the ball; `POSITIONS=path`: the final
//! positions written there, a node a line), and each step's relative Newton residual at its end.
use flexsurf::integrate::{linsolve::SolverKind, Stepper};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(21);
    let steps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(300);
    let solver = match args.get(3).map(String::as_str) {
        Some("cholesky") => SolverKind::Cholesky,
        Some("multigrid") => SolverKind::Multigrid,
        Some("pcg") => SolverKind::Pcg,
        _ => SolverKind::Auto,
    };
    let scene = match std::env::var("SCENE") {
        Ok(path) => flexsurf::bench::scene_file(std::path::Path::new(&path), n).expect("scene"),
        Err(_) if std::env::var("TOUCHING").is_ok() => {
            flexsurf::bench::scene(n, flexsurf::bench::Workload::Touching).expect("scene")
        }
        Err(_) => flexsurf::bench::ball_drop(n).expect("scene"),
    };
    let mut state = scene.state.clone();
    let params = flexsurf::integrate::StepParams { solver, ..scene.step_params() };
    let mut stepper = Stepper::new(&scene.model, &params).expect("stepper");
    let t = std::time::Instant::now();
    for _ in 0..steps {
        let info = stepper.step(&scene.model, &mut state).expect("step");
        let c = info.timings;
        println!(
            "step {:4} contacts {:5} solves {} iters {:3} factor {} resolves {} corrections {} setup {:.2} ms solve {:.2} ms res {:.3e}",
            state.step,
            info.contacts,
            c.solves,
            c.iterations,
            c.factorizations,
            c.resolves,
            c.corrections,
            1e3 * c.factorization,
            1e3 * c.solve,
            info.newton.residual
        );
    }
    if let Ok(path) = std::env::var("POSITIONS") {
        let text: String = state.x.iter().map(|p| format!("{:.17e} {:.17e} {:.17e}\n", p.x, p.y, p.z)).collect();
        std::fs::write(path, text).expect("dump");
    }
    let c = stepper.counters;
    eprintln!(
        "{} ({}): {steps} steps in {:.3} s; solves {} iterations {} factorisations {} re-solves {} corrections {}",
        stepper.solver_kind().name(),
        n,
        t.elapsed().as_secs_f64(),
        c.solves,
        c.iterations,
        c.factorizations,
        c.resolves,
        c.corrections
    );
}
