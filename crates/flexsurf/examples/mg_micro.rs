//! The multigrid solve's cost per conjugate-gradient iteration in matrix streams (issue 23, item 5): the
//! touching `N × N` sheet's step matrix after a few steps, solved by multigrid-preconditioned conjugate
//! gradients from zero, against one product with the same matrix in full block rows on one thread (the bench's
//! matrix stream).
//!
//!     cargo run --release -p flexsurf --example mg_micro -- 321 [solves] [v|w]
//!
//! Prints the median solve's iterations, seconds per iteration and streams per iteration (`v` or `w`: that
//! cycle, whatever the hierarchy's depth would choose). `DROP=k`: the bench's ball drop after `k` steps (on
//! Cholesky) instead, the sheet wrinkled where it hangs off the ball from about its 20th step.
use flexsurf::bench::{product_time, scene, Workload};
use flexsurf::integrate::linsolve::multigrid::Cycle;
use flexsurf::integrate::linsolve::{BlockSolver, Multigrid, Reuse};
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::math::Vec3;
use flexsurf::sparse::BlockRows;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|v| v.parse().ok()).unwrap_or(161);
    let solves: usize = args.next().and_then(|v| v.parse().ok()).unwrap_or(5);
    let cycle = match args.next().as_deref() {
        Some("v") => Some(Cycle::V),
        Some("w") => Some(Cycle::W),
        _ => None,
    };
    let drop: Option<usize> = std::env::var("DROP").ok().and_then(|v| v.parse().ok());
    let scene = match drop {
        Some(_) => flexsurf::bench::ball_drop(n).expect("the ball drop builds"),
        None => scene(n, Workload::Touching).expect("the touching scene builds"),
    };
    let mut state = scene.state.clone();
    // The drop steps on Cholesky (its contact steps are cheaper there once the sheet wrinkles).
    let solver = drop.map_or(scene.step_params().solver, |_| flexsurf::integrate::linsolve::SolverKind::Cholesky);
    let mut stepper = Stepper::new(&scene.model, &StepParams { solver, ..scene.step_params() }).expect("stepper");
    for _ in 0..drop.unwrap_or(2) {
        stepper.step(&scene.model, &mut state).expect("a step");
    }
    stepper.assemble(&scene.model, &state);
    let pattern = scene.model.potential.pattern();
    let a = stepper.matrix().clone();
    let fixed = scene.model.pinned().to_vec();
    let b: Vec<Vec3> = stepper.rhs().to_vec();
    let mut mg = Multigrid::new(pattern, &scene.model.panels).expect("multigrid");
    if let Some(c) = cycle {
        mg = mg.with_cycle(c);
    }
    mg.set_positions(&state.x);
    let product = product_time(&BlockRows::from_symmetric(&a, pattern));
    let mut rows = Vec::new();
    for _ in 0..solves {
        let mut x = vec![Vec3::ZERO; b.len()];
        let t = std::time::Instant::now();
        let (iters, setup) = match mg.solve(&a, &fixed, &b, &mut x, Reuse::Fresh) {
            Ok(s) => (s.iterations, s.setup_seconds),
            Err(e) => {
                println!("{e}");
                (Multigrid::MAX_ITERATIONS, 0.0)
            }
        };
        rows.push(((t.elapsed().as_secs_f64() - setup) / iters.max(1) as f64, iters, setup));
    }
    rows.sort_by(|p, q| p.0.total_cmp(&q.0));
    let (per_iter, iters, setup) = rows[rows.len() / 2];
    println!(
        "{n}²: {} levels, {:?}-cycle, {iters} iterations, {:.3} ms an iteration, product {:.3} ms: {:.2} streams \
         an iteration; set-up {:.1} ms ({:.1} streams)",
        mg.levels(),
        mg.cycle(),
        1e3 * per_iter,
        1e3 * product,
        per_iter / product,
        1e3 * setup,
        setup / product
    );
}
