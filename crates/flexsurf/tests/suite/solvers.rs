//! The step's linear solvers against each other: multigrid-preconditioned conjugate gradients against the
//! sparse Cholesky factorisation on the step matrices of a free sheet, a periodic tube (a skirt's topology) and
//! the polar grid of a Cusick specimen, with pinned nodes; its iteration count under grid refinement and with
//! W-cycles; and the same bits on 1, 2 and 5 threads.

use crate::common::{largest_difference, largest_length};
use flexsurf::contact::Obstacle;
use flexsurf::grid::{Grid, Topology};
use flexsurf::integrate::linsolve::multigrid::Cycle;
use flexsurf::integrate::linsolve::{BlockSolver, Cholesky, LinearSolver, Multigrid, Reuse, SolverKind};
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{Model, ModelBuilder, ModelKind};
use flexsurf::potential::elastic::ElasticOptions;
use flexsurf::state::State;
use std::f64::consts::PI;

fn fabric() -> (Fabric, Stiffness) {
    let fabric = Fabric::paper_cotton();
    let s = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
    (fabric, s)
}

/// A deformed configuration: the rest shape with a smooth wave and a small deterministic roughness, so the
/// membrane and bending Hessians are those of a curved, stressed sheet.
fn deformed(grid: &Grid, rest: &[Vec3], amplitude: f64) -> Vec<Vec3> {
    rest.iter()
        .enumerate()
        .map(|(k, p)| {
            let (i, j) = grid.coords(k);
            let (u, v) = (i as f64 / grid.m as f64, j as f64 / grid.n as f64);
            let rough = ((k * 7919 % 101) as f64 / 101.0 - 0.5) * 0.05;
            *p + Vec3::new(0.1 * rough, -0.1 * rough, (2.0 * PI * u).sin() * (PI * v).cos() + rough) * amplitude
        })
        .collect()
}

/// A free `n × n` sheet of 1 m lying on a ball (contact in the matrix).
fn sheet(n: usize) -> (Model, Vec<Vec3>) {
    let (f, s) = fabric();
    let grid = Grid::sheet(n, n, 1.0, 1.0).unwrap();
    let rest = grid.flat_positions(0.0);
    let mut b = ModelBuilder::new(grid, rest.clone(), f, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81));
    b.obstacles.push(Obstacle::Sphere { center: Vec3::new(0.0, 0.0, -0.3), radius: 0.3 });
    let x = deformed(&grid, &rest, 0.01);
    (b.build().unwrap(), x)
}

/// A tube periodic around (`u1`) and free along its axis (`u2`), its top ring pinned: a skirt's grid.
fn tube(around: usize, down: usize) -> (Model, Vec<Vec3>) {
    let (f, s) = fabric();
    let (grid, rest) = flexsurf::testing::cylinder(around, down, 0.2, 0.5);
    let mut b = ModelBuilder::new(grid, rest.clone(), f, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81));
    b.panels[0].options = ElasticOptions { flat_pattern: true, ..Default::default() };
    for k in 0..grid.len() {
        b.pinned[k] = grid.coords(k).1 == down - 1;
    }
    let x = deformed(&grid, &rest, 0.005);
    (b.build().unwrap(), x)
}

/// A Cusick specimen's polar grid: free radially, periodic around, the two inner rings pinned, the warp along
/// one fixed direction of the flat fabric.
fn polar(radial: usize, angular: usize) -> (Model, Vec<Vec3>) {
    let (f, s) = fabric();
    let (rd, hr) = (0.09, 0.06 / radial as f64);
    let grid =
        Grid::new(radial + 2, angular, hr, 2.0 * PI / angular as f64, [Topology::Free, Topology::Periodic]).unwrap();
    let rest: Vec<Vec3> = (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            let (r, t) = (rd - hr + i as f64 * hr, j as f64 * grid.h2);
            Vec3::new(r * t.cos(), r * t.sin(), 0.0)
        })
        .collect();
    let mut b = ModelBuilder::new(grid, rest.clone(), f, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81));
    b.panels[0].options = ElasticOptions { warp_direction: Some(Vec3::X), ..Default::default() };
    for k in 0..grid.len() {
        b.pinned[k] = grid.coords(k).0 <= 1;
    }
    let x = deformed(&grid, &rest, 0.005);
    (b.build().unwrap(), x)
}

/// The step matrix and right-hand side of `model` at `x` (at rest), Δt = 0.01 s.
fn system(model: &Model, x: &[Vec3]) -> (flexsurf::sparse::BlockMatrix, Vec<Vec3>) {
    let mut st = Stepper::new(model, &StepParams::with_dt(0.01)).unwrap();
    st.assemble(model, &State::at_rest(x.to_vec()));
    // A right-hand side with every scale in it: the step's own residual plus a rough part.
    let rhs = st
        .rhs()
        .iter()
        .enumerate()
        .map(|(k, r)| *r + Vec3::new(1.0, -0.5, 0.25) * (((k * 31) % 17) as f64 - 8.0) * 1e-4);
    let mut rhs: Vec<Vec3> = rhs.collect();
    for (r, &f) in rhs.iter_mut().zip(model.pinned()) {
        if f {
            *r = Vec3::new(1e-4, 0.0, -2e-4);
        }
    }
    (st.matrix().clone(), rhs)
}

fn solve(kind: SolverKind, model: &Model, a: &flexsurf::sparse::BlockMatrix, b: &[Vec3]) -> (Vec<Vec3>, usize) {
    let mut solver = LinearSolver::new(kind, model.potential.pattern(), &model.panels).unwrap();
    let mut x = vec![Vec3::ZERO; b.len()];
    let stats = solver.solve(a, model.pinned(), b, &mut x, Reuse::Fresh).unwrap();
    (x, stats.iterations)
}

/// The direct solver against the system it solves, on sheets small enough for `faer` to choose its simplicial
/// factorisation and large enough for its supernodal one (both read the matrix from the permuted triangle the
/// solver fills): `A x = b` on every row to round-off, checked with the matrix's own symmetric product.
#[test]
fn cholesky_solves_its_system_with_either_factorisation() {
    let mut kinds = Vec::new();
    for n in [3, 5, 21] {
        let (model, x) = sheet(n);
        let (a, b) = system(&model, &x);
        let pattern = model.potential.pattern();
        let mut chol = Cholesky::new(pattern).unwrap();
        let mut u = vec![Vec3::ZERO; b.len()];
        chol.solve_to(&a, model.pinned(), &b, &mut u, Reuse::Fresh, None).unwrap();
        kinds.push(chol.supernodal());
        let mut au = vec![Vec3::ZERO; b.len()];
        a.mul_add(pattern, &u, &mut au);
        let (scale, worst) = (largest_length(&b), largest_difference(&au, &b));
        eprintln!("{n}x{n}: supernodal {}, largest residual {worst:.2e} of {scale:.2e}", chol.supernodal());
        assert!(worst <= 1e-9 * scale, "{n}x{n}: residual {worst:e} of {scale:e}");
    }
    assert!(kinds.contains(&false) && kinds.contains(&true), "both factorisations exercised: {kinds:?}");
}

/// The direct solver orders the node graph (AMD on the blocks, each node's three unknowns together), for a
/// cheaper analysis where pairs between faces make it redo one at most factorisations; its factor fills as
/// `faer`'s AMD of the scalar pattern does (measured equal on the sheet, tube and polar grids): a poorer ordering
/// (a node's unknowns split apart, the identity) would fill more and fail this.
#[test]
fn the_node_ordering_fills_as_the_scalar_ordering_does() {
    use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, CholeskySymbolicParams, SymmetricOrdering};
    use faer::sparse::SymbolicSparseColMatRef;
    for (name, (model, _)) in
        [("sheet 21²", sheet(21)), ("tube 48 × 12", tube(48, 12)), ("polar 14 × 72", polar(14, 72))]
    {
        let pattern = model.potential.pattern();
        let (col_ptr, row_idx, _) = pattern.csc_upper();
        let n = 3 * pattern.nodes();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let params = CholeskySymbolicParams::default();
        let scalar = factorize_symbolic_cholesky(sym, faer::Side::Upper, SymmetricOrdering::Amd, params).unwrap();
        let ours = Cholesky::new(pattern).unwrap().factor_nnz();
        eprintln!("{name}: factor non-zeros {ours} with the node ordering, {} with the scalar AMD", scalar.len_val());
        assert!(ours as f64 <= 1.01 * scalar.len_val() as f64, "{name}: {ours} against {}", scalar.len_val());
    }
}

/// Multigrid solves as Cholesky does on the three grids, from zero to 1e-11 within an iteration bound each
/// (measured: 11, 13 and 15; the tube took 38 while its periodic lines were smoothed in halves, docs/performance.md,
/// "Periodic lines solved whole").
#[test]
fn multigrid_matches_cholesky_on_free_periodic_and_polar_grids() {
    for (name, (model, x), bound) in
        [("sheet 61x61", sheet(61), 12), ("tube 96x24", tube(96, 24), 14), ("polar 14x72", polar(12, 72), 16)]
    {
        let (a, b) = system(&model, &x);
        let (direct, _) = solve(SolverKind::Cholesky, &model, &a, &b);
        let (mg, iterations) = solve(SolverKind::Multigrid, &model, &a, &b);
        let (scale, diff) = (largest_length(&direct), largest_difference(&direct, &mg));
        eprintln!("{name}: {iterations} multigrid iterations, max difference {diff:.2e} of {scale:.2e}");
        assert!(diff <= 1e-6 * scale, "{name}: multigrid differs from Cholesky by {diff:e} of {scale:e}");
        assert!(iterations <= bound, "{name}: {iterations} iterations");
        for (k, &f) in model.pinned().iter().enumerate() {
            if f {
                assert_eq!(mg[k], b[k], "{name}: pinned node {k} moved");
            }
        }
    }
}

/// Pairs between faces (self-contact: blocks outside the pattern, [`flexsurf::sparse::ExtraBlocks`]) in the
/// multigrid: a 33 × 65 sheet of 0.4 × 0.8 m folded in two along its middle row, its upper half lying back over its
/// lower half 3 mm above it, inside the self-contact thickness of the pile (`scenes/pile.toml`: 4 mm, 2e5 N/m³), so
/// that each layer's nodes are held to the other's triangles, along the same `u2` lines. Multigrid solves its
/// step matrix as Cholesky does, in 29 iterations from zero to 1e-11 (docs/performance.md, "Pairs between faces in
/// the multigrid"): 142 while the two layers held together were relaxed by the lines alone, which take the pairs
/// from the sweep before, and not converged in its 200 iterations (a relative residual of 7.4e-6) before the
/// smoother's rows and the coarse levels took the pairs in at all.
#[test]
fn multigrid_solves_a_sheet_folded_onto_itself_as_cholesky_does() {
    use flexsurf::potential::self_contact::SelfContactParams;
    let (f, s) = fabric();
    let grid = Grid::sheet(33, 65, 0.4, 0.8).unwrap();
    let flat = grid.flat_positions(0.0);
    let folded: Vec<Vec3> = (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            match j <= 32 {
                true => flat[k],
                false => flat[grid.index(i, 64 - j)] + Vec3::new(0.0, 0.0, 0.003),
            }
        })
        .collect();
    let mut b = ModelBuilder::new(grid, flat, f, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81));
    b.self_contact = Some(SelfContactParams::frictionless(2e5, 0.004));
    let model = b.build().unwrap();
    let (a, b) = system(&model, &folded);
    assert!(a.extra.pairs().len() > 1000, "{} pairs between faces", a.extra.pairs().len());
    let (direct, _) = solve(SolverKind::Cholesky, &model, &a, &b);
    let (mg, iterations) = solve(SolverKind::Multigrid, &model, &a, &b);
    let (scale, diff) = (largest_length(&direct), largest_difference(&direct, &mg));
    eprintln!(
        "folded sheet, {} pairs: {iterations} multigrid iterations, difference {diff:.2e}",
        a.extra.pairs().len()
    );
    assert!(diff <= 1e-6 * scale, "multigrid differs from Cholesky by {diff:e} of {scale:e}");
    assert!(iterations <= 35, "{iterations} iterations");
}

/// The prolongation smoothed on its own sparsity ([`Multigrid::SMOOTHING`]) against the plain one (linear
/// interpolation with the fitted rotations), on the free sheet, the periodic tube and the polar grid: both solve
/// to Cholesky's solution, the smoothed one in fewer iterations on each (measured: 11 against 16, 13 against 15,
/// 15 against 17), at the same cost an iteration (the same sparsity of `P` and of the coarse operators).
#[test]
fn a_smoothed_prolongation_solves_in_fewer_iterations() {
    for (name, (model, x)) in [("sheet 61x61", sheet(61)), ("tube 96x24", tube(96, 24)), ("polar 14x72", polar(12, 72))]
    {
        let (a, b) = system(&model, &x);
        let (direct, _) = solve(SolverKind::Cholesky, &model, &a, &b);
        let scale = largest_length(&direct);
        let mut counts = Vec::new();
        for omega in [0.0, Multigrid::SMOOTHING] {
            let mut mg = Multigrid::new(model.potential.pattern(), &model.panels).unwrap().with_smoothing(omega);
            let mut u = vec![Vec3::ZERO; b.len()];
            let stats = mg.solve_to(&a, model.pinned(), &b, &mut u, Reuse::Fresh, None).unwrap();
            let diff = largest_difference(&direct, &u);
            assert!(diff <= 1e-6 * scale, "{name}, ω = {omega}: {diff:e} from Cholesky of {scale:e}");
            counts.push(stats.iterations);
        }
        eprintln!("{name}: {} iterations plain, {} smoothed", counts[0], counts[1]);
        assert!(counts[1] < counts[0], "{name}: {counts:?}");
    }
}

#[test]
fn multigrid_iterations_grow_slowly_under_refinement() {
    // A point smoother needed 78 iterations at 41² on this kind of matrix (membrane 400× stiffer in tension
    // than in shear); the line smoother's count must stay small and grow far slower than the grid.
    let mut counts = Vec::new();
    for n in [41, 81, 161] {
        let (model, x) = sheet(n);
        let (a, b) = system(&model, &x);
        let (_, iterations) = solve(SolverKind::Multigrid, &model, &a, &b);
        counts.push(iterations);
    }
    eprintln!("multigrid iterations at 41², 81², 161²: {counts:?}");
    assert!(counts[0] <= 15, "{counts:?}");
    assert!(counts[2] <= 3 * counts[0], "{counts:?}: iterations grew like the grid");
}

/// The W-cycle solves what the V-cycle solves (both to Cholesky's solution) in fewer iterations (15 against 17
/// from zero to 1e-11), on the first step matrix of the 161² sheet lying on the ball (`flexsurf bench --workload
/// touching`), a four-level hierarchy whose own choice is the V-cycle ([`Multigrid::W_CYCLE_LEVELS`]). The
/// W-cycle solves each coarse level's correction more accurately; on flat sheets and tubes of three to five
/// levels the V-cycle's coarse corrections are already as good (the same counts), on the touching sheet one
/// cycle solves the first coarse levels' corrections too inexactly (docs/performance.md, "W-cycles on deep
/// hierarchies").
#[test]
fn a_w_cycle_solves_as_the_v_cycle_in_fewer_iterations() {
    let scene = flexsurf::bench::scene(161, flexsurf::bench::Workload::Touching).unwrap();
    let (model, state) = (&scene.model, &scene.state);
    let mut st = Stepper::new(model, &scene.step_params()).unwrap();
    st.assemble(model, state);
    let (a, b) = (st.matrix().clone(), st.rhs().to_vec());
    let (direct, _) = solve(SolverKind::Cholesky, model, &a, &b);
    let scale = largest_length(&direct);
    let mut counts = Vec::new();
    for cycle in [None, Some(Cycle::W)] {
        let mut mg = Multigrid::new(model.potential.pattern(), &model.panels).unwrap();
        if let Some(c) = cycle {
            mg = mg.with_cycle(c);
        }
        mg.set_positions(&state.x);
        let mut u = vec![Vec3::ZERO; b.len()];
        let stats = mg.solve(&a, model.pinned(), &b, &mut u, Reuse::Fresh).unwrap();
        assert_eq!((mg.levels(), mg.cycle()), (4, cycle.unwrap_or(Cycle::V)));
        let diff = largest_difference(&direct, &u);
        eprintln!("{:?}: {} iterations, {diff:.2e} of {scale:.2e} from Cholesky", mg.cycle(), stats.iterations);
        assert!(diff <= 1e-6 * scale, "{:?}: {diff:e} of {scale:e} from Cholesky", mg.cycle());
        counts.push(stats.iterations);
    }
    assert!(counts[1] < counts[0], "W-cycle against V-cycle iterations: {counts:?}");
}

#[test]
fn multigrid_steps_are_the_same_on_any_number_of_threads() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let scene = flexsurf::bench::scene(81, flexsurf::bench::Workload::Touching).unwrap();
            let params = StepParams { solver: SolverKind::Multigrid, ..scene.step_params() };
            let mut st = Stepper::new(&scene.model, &params).unwrap();
            let mut state = scene.state.clone();
            for _ in 0..3 {
                st.step(&scene.model, &mut state).unwrap();
            }
            state.x.iter().flat_map(|p| p.to_array()).map(f64::to_bits).collect::<Vec<u64>>()
        })
    };
    let one = run(1);
    assert_eq!(one, run(2), "1 and 2 threads differ");
    assert_eq!(one, run(5), "1 and 5 threads differ");
}

/// `flexsurf bench` states an iteration's cost in matrix streams, and the bytes it moves, for the iterative
/// solvers (issue 23, item 5) and not for Cholesky, whose solve stage is triangular solves; its streams a step
/// are the mean step over one product.
#[test]
fn bench_states_streams_an_iteration_for_the_iterative_solvers_only() {
    use flexsurf::bench::{run, Workload};
    let mg = run(21, 2, Workload::Touching, SolverKind::Multigrid).unwrap();
    let chol = run(21, 2, Workload::Touching, SolverKind::Cholesky).unwrap();
    let per_iteration = mg.streams_per_iteration.expect("multigrid reports streams an iteration");
    assert!(mg.per_step.iterations > 0 && per_iteration > 0.0 && per_iteration.is_finite(), "{mg:?}");
    let expected = mg.per_step.solve * mg.steps as f64 / mg.per_step.iterations as f64 / mg.product_seconds;
    assert!((per_iteration - expected).abs() <= 1e-12 * expected, "{per_iteration} against {expected}");
    assert_eq!(chol.streams_per_iteration, None);
    assert!(chol.streams_per_step > 0.0, "{chol:?}");
    // Its bytes: at least the conjugate gradients' product over the upper blocks in `f64` (half the full
    // product's) and five passes of the smoother over the rows in `f32` (another 1.25 products), and not
    // more than a few times that.
    let streams = mg.iteration_bytes as f64 / mg.product_bytes as f64;
    assert!((1.75..10.0).contains(&streams), "{streams} byte streams an iteration");
    assert_eq!(chol.iteration_bytes, 0);
}

/// The `tumble` workload is free motion: no contact step, every step converged by Newton's method, with
/// corrections (the rotation stretches the linearised step), and the sheet keeps spinning.
#[test]
fn the_tumble_workload_is_newton_without_contact() {
    use flexsurf::bench::{run, scene, Workload};
    let s = scene(21, Workload::Tumble).unwrap();
    assert!(s.model.obstacles().is_empty());
    assert_eq!(s.model.gravity, flexsurf::math::Vec3::ZERO);
    assert!(s.state.v.iter().any(|v| v.length() > 0.1), "the sheet should start spinning");
    let row = run(21, 5, Workload::Tumble, SolverKind::Cholesky).unwrap();
    let c = row.per_step;
    assert_eq!((c.contact_steps, c.unconverged), (0, 0), "{c:?}");
    assert!(c.corrections >= 5, "{c:?}");
}

/// The `hanging` workload drives its carried corner as a run does (the smooth step `3τ² − 2τ³` of 0.45 m over
/// 1.5 s: after 0.1 s, `0.45 (3 τ² − 2 τ³)` with `τ = 1/15`), in `flexsurf bench` as in a run, and is
/// Newton's steps without contact.
#[test]
fn the_hanging_workload_carries_its_corner_without_contact() {
    use flexsurf::bench::{run, scene, Workload};
    let n = 21;
    let s = scene(n, Workload::Hanging).unwrap();
    assert!(s.model.obstacles().is_empty());
    let corner = n * n - 1;
    let start = s.state.x[corner];
    let row = run(n, 10, Workload::Hanging, SolverKind::Cholesky).unwrap();
    let c = row.per_step;
    assert_eq!(c.contact_steps, 0, "{c:?}");
    assert!(c.corrections >= 10, "{c:?}");
    let (x, driven) = bench_run(n, 10, Workload::Hanging, SolverKind::Cholesky);
    // The benchmark's steps are those of the driven run.
    let fingerprint = |c: &flexsurf::integrate::Counters| (c.solves, c.corrections, c.residual_max.to_bits());
    assert_eq!(fingerprint(&c), fingerprint(&driven));
    let tau: f64 = 0.1 / 1.5;
    let shift = 0.45 * (3.0 * tau * tau - 2.0 * tau * tau * tau);
    let moved = x[corner] - start;
    assert!((moved.x + shift).abs() < 1e-12 && moved.y.abs() < 1e-12 && moved.z.abs() < 1e-12, "{moved:?}");
}

/// The bench's `workload` on an `n`² grid, `steps` steps with `solver`: the final positions and the counters.
fn bench_run(
    n: usize,
    steps: usize,
    workload: flexsurf::bench::Workload,
    solver: SolverKind,
) -> (Vec<Vec3>, flexsurf::integrate::Counters) {
    let scene = flexsurf::bench::scene(n, workload).unwrap();
    let mut state = scene.state.clone();
    let mut stepper = Stepper::new(&scene.model, &StepParams { solver, ..scene.step_params() }).unwrap();
    for _ in 0..steps {
        scene.drive(&mut state).unwrap();
        stepper.step(&scene.model, &mut state).unwrap();
    }
    (state.x, stepper.counters)
}

/// `auto` from [`AUTO_FREE_MOTION_NODES`] nodes: the ball drop's free fall, which one exact solve converges, and
/// its first contact steps stay on Cholesky, bit for bit; the tumbling sheet, whose steps Newton corrects, goes
/// to multigrid after its first step and ends where the Cholesky run ends, to what Newton's tolerance leaves.
#[test]
fn auto_takes_multigrid_for_the_steps_newton_corrects_without_contact() {
    use flexsurf::bench::Workload;
    use flexsurf::integrate::linsolve::AUTO_FREE_MOTION_NODES;
    let n = 51;
    assert!(n * n >= AUTO_FREE_MOTION_NODES);
    let (direct, c) = bench_run(n, 14, Workload::Drop, SolverKind::Cholesky);
    assert!(c.contact_steps > 0 && c.contact_steps < 14, "the drop should reach the ball: {c:?}");
    let (auto, c) = bench_run(n, 14, Workload::Drop, SolverKind::Auto);
    assert_eq!(c.iterative_steps, 0, "{c:?}");
    assert!(direct == auto, "the free fall should be Cholesky's, bit for bit");

    let steps = 5;
    let (direct, c) = bench_run(n, steps, Workload::Tumble, SolverKind::Cholesky);
    assert!(c.corrections >= steps && c.iterative_steps == 0, "{c:?}");
    let (auto, c) = bench_run(n, steps, Workload::Tumble, SolverKind::Auto);
    assert_eq!((c.iterative_steps, c.unconverged), (steps - 1, 0), "{c:?}");
    let apart = largest_difference(&direct, &auto);
    // The sheet is 1 m across; Newton stops at 1e-6 of each step's force scale.
    assert!(apart > 0.0 && apart < 1e-6, "{apart:e} m apart");
}

/// A run of `auto` resumed between steps makes the solves of an uninterrupted one, bit for bit: its pick for
/// the next step without contact travels with the solver's part of the checkpoint.
#[test]
fn auto_resumes_with_its_pick() {
    let scene = flexsurf::bench::scene(51, flexsurf::bench::Workload::Tumble).unwrap();
    let params = StepParams { solver: SolverKind::Auto, ..scene.step_params() };
    let (model, steps) = (&scene.model, |stepper: &mut Stepper, state: &mut State, n: usize| {
        for _ in 0..n {
            stepper.step(&scene.model, state).unwrap();
        }
    });
    let (mut whole, mut first) = (Stepper::new(model, &params).unwrap(), Stepper::new(model, &params).unwrap());
    let (mut x_whole, mut x_resumed) = (scene.state.clone(), scene.state.clone());
    steps(&mut whole, &mut x_whole, 4);
    steps(&mut first, &mut x_resumed, 2);
    let (warm, solver) = (first.warm_state(model).unwrap(), first.solver_warm());
    assert!(solver.picks.free_iterative, "the tumbling sheet's steps are corrected: multigrid next");
    let mut resumed = Stepper::new(model, &params).unwrap();
    resumed.restore(model, &warm, first.counters).unwrap();
    resumed.restore_solver(&solver).unwrap();
    steps(&mut resumed, &mut x_resumed, 2);
    assert!(x_whole.x == x_resumed.x, "the resumed run should be the whole run's, bit for bit");
    let counts = |c: &flexsurf::integrate::Counters| (c.solves, c.iterations, c.iterative_steps);
    assert_eq!(counts(&whole.counters), counts(&resumed.counters));
}

/// Which solver `auto` gives a grid's first steps: on a mid-size grid the first step without contact (it has no
/// history yet) takes Cholesky, from [`AUTO_FREE_ITERATIVE_NODES`] multigrid; the first step with contact takes
/// Cholesky below [`AUTO_CONTACT_ITERATIVE_NODES`], multigrid from there; above [`AUTO_MULTIGRID_NODES`] every
/// step takes multigrid.
#[test]
fn auto_gives_the_first_step_without_contact_to_multigrid_on_large_grids() {
    use flexsurf::integrate::linsolve::{
        AUTO_CONTACT_ITERATIVE_NODES, AUTO_FREE_ITERATIVE_NODES, AUTO_MULTIGRID_NODES,
    };
    let (chol, mg) = (SolverKind::Cholesky, SolverKind::Multigrid);
    for (n, free, contact) in [(51, chol, chol), (101, chol, mg), (181, mg, mg), (301, mg, mg)] {
        assert_eq!(n * n >= AUTO_CONTACT_ITERATIVE_NODES, n > 51);
        assert_eq!(n * n > AUTO_FREE_ITERATIVE_NODES, n > 101);
        assert_eq!(n * n > AUTO_MULTIGRID_NODES, n == 301);
        let (model, _) = sheet(n);
        let mut solver = SolverKind::Auto.solver(model.potential.pattern(), &model.panels).unwrap();
        solver.set_free_motion(true);
        assert_eq!(solver.kind(), free, "{n}²");
        solver.set_free_motion(false);
        assert_eq!(solver.kind(), contact, "{n}²");
    }
    // What `summary.json` and the bench call the solver of an `auto` run below the threshold.
    let named = |iterative| SolverKind::Auto.resolve(161 * 161).used(iterative, 10);
    assert_eq!((named(0), named(4), named(10)), ("cholesky", "cholesky+multigrid", "multigrid"));
}

/// `auto`'s steps with contact from [`AUTO_CONTACT_ITERATIVE_NODES`]: the ball drop's sheet lands flat and its
/// first contact steps take multigrid, whose solves take few iterations there; once the sheet wrinkles where it
/// hangs off the ball, a multigrid step's iterations a solve pass [`contact_iterations_limit`] and Cholesky
/// takes every later contact step (the run ends before a probe). With the smoothed prolongation that happens
/// at the 34th contact step (step 43; the limit is 11.9 iterations a solve at 101²), where without it the switch
/// came before step 28. A run resumed from a checkpoint after the
/// switch makes the same steps, bit for bit: the picks travel in the solver's part of the checkpoint.
#[test]
fn auto_gives_contact_steps_to_multigrid_while_its_iterations_stay_low() {
    use flexsurf::integrate::linsolve::auto::{contact_iterations_limit, PROBE_STEPS};
    use flexsurf::integrate::linsolve::AUTO_CONTACT_ITERATIVE_NODES;
    let n = 101;
    assert!(n * n >= AUTO_CONTACT_ITERATIVE_NODES);
    let (limit, steps) = (contact_iterations_limit(n * n), 49);
    assert!(steps < PROBE_STEPS as usize);
    let scene = flexsurf::bench::scene(n, flexsurf::bench::Workload::Drop).unwrap();
    let params = StepParams { solver: SolverKind::Auto, ..scene.step_params() };
    let mut stepper = Stepper::new(&scene.model, &params).unwrap();
    let mut state = scene.state.clone();
    // For each contact step: on multigrid, and its iterations a solve.
    let mut contact = Vec::new();
    let mut saved = None;
    for step in 0..steps {
        let c = stepper.step(&scene.model, &mut state).unwrap().timings;
        if c.contact_steps == 1 {
            contact.push((c.iterative_steps == 1, c.iterations as f64 / c.solves as f64));
        }
        if step == 45 {
            let warm = stepper.warm_state(&scene.model).unwrap();
            saved = Some((state.clone(), warm, stepper.counters, stepper.solver_warm()));
        }
    }
    eprintln!("{n}² drop under auto, contact steps (multigrid, iterations a solve): {contact:?}");
    let over = contact.iter().position(|&(mg, per_solve)| mg && per_solve > limit).expect("multigrid's count rises");
    assert!(over > 0 && contact[..over].iter().all(|&(mg, per_solve)| mg && per_solve <= limit), "{contact:?}");
    assert!(over + 2 < contact.len() && contact[over + 1..].iter().all(|&(mg, _)| !mg), "{contact:?}");
    let (mut resumed_state, warm, counters, solver) = saved.unwrap();
    assert!(!solver.picks.contact_iterative, "{:?}", solver.picks);
    let mut resumed = Stepper::new(&scene.model, &params).unwrap();
    resumed.restore(&scene.model, &warm, counters).unwrap();
    resumed.restore_solver(&solver).unwrap();
    for _ in 46..steps {
        resumed.step(&scene.model, &mut resumed_state).unwrap();
    }
    assert!(resumed_state.x == state.x, "the resumed run should be the whole run's, bit for bit");
}

/// A contact step's solves on multigrid stop at `CONTACT_STEP_TOLERANCE` (1e-6), not at the forcing terms of a
/// converged step nor at 1e-11: the 81² sheet touching the ball ends its first steps where the direct solves
/// put it to far less than the step leaves unconverged, with fewer than half the iterations it made at 1e-11.
#[test]
fn contact_steps_on_multigrid_end_where_direct_solves_do() {
    use flexsurf::integrate::linsolve::CONTACT_STEP_TOLERANCE;
    let scene = flexsurf::bench::scene(81, flexsurf::bench::Workload::Touching).unwrap();
    let run = |solver: SolverKind| {
        let params = StepParams { solver, ..scene.step_params() };
        let mut st = Stepper::new(&scene.model, &params).unwrap();
        let mut state = scene.state.clone();
        let mut residual: f64 = 0.0;
        for _ in 0..3 {
            let info = st.step(&scene.model, &mut state).unwrap();
            assert!(info.newton.contact, "the touching sheet's steps have contact");
            residual = residual.max(info.newton.residual);
        }
        (state.x, st.counters, residual)
    };
    let (mg, counters, residual) = run(SolverKind::Multigrid);
    let (direct, ..) = run(SolverKind::Cholesky);
    let (lo, hi) = direct.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), p| (l.min(*p), h.max(*p)));
    let far = largest_difference(&mg, &direct);
    eprintln!("81² touching, 3 steps: {far:.3e} m from the direct solves; {counters:?}; residual {residual:.3e}");
    assert!(far < 1e-6 * (hi - lo).length(), "{far:e} m from the direct solves");
    // The steps are far from converged (the contact steps' rule), which is why 1e-11 bought nothing.
    assert!(residual > 1e3 * CONTACT_STEP_TOLERANCE, "{residual:e}");
    let per_solve = counters.iterations as f64 / counters.solves as f64;
    assert!(per_solve <= 10.0, "{per_solve} multigrid iterations a solve");
}

/// A contact step whose first solve misses new contacts while the membrane at its proposal is far off its
/// linear model (the violent rule: a sheet pressed onto the ball) takes the new contacts into the one
/// correction it makes anyway, their records held as the refinement found them, instead of re-solving first
/// (docs/model.md §8.5): the 41² sheet touching the ball makes at most two solves a step on average over its
/// first eight steps (three before), and no node ever ends deeper under the ball's surface than the contact
/// offset.
#[test]
fn a_violent_contact_step_takes_its_new_contacts_into_its_correction() {
    let scene = flexsurf::bench::scene(41, flexsurf::bench::Workload::Touching).unwrap();
    let offset = scene.model.contact_params().unwrap().offset;
    let params = StepParams { solver: SolverKind::Cholesky, ..scene.step_params() };
    let mut st = Stepper::new(&scene.model, &params).unwrap();
    let mut state = scene.state.clone();
    let steps = 8;
    for _ in 0..steps {
        let info = st.step(&scene.model, &mut state).unwrap();
        assert!(info.max_penetration < offset, "step {}: {} m under the ball", state.step, info.max_penetration);
    }
    let c = st.counters;
    eprintln!("41² touching, {steps} steps: {c:?}");
    assert!(c.solves <= 2 * steps, "{} solves in {steps} steps", c.solves);
    assert!(c.corrections >= steps / 2 && c.resolves <= 2, "{} corrections, {} re-solves", c.corrections, c.resolves);
}
