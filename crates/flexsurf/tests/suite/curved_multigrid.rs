//! Multigrid on curved sheets (issue 23, item 4): its prolongation carries the rigid rotations of the coarse
//! nodes at the positions the solver is given (`BlockSolver::set_positions`), and on the step matrix of a tube
//! (a skirt's topology, periodic around with its top ring pinned) it solves as Cholesky does within item 4's
//! bound of 12 iterations, at the rest shape and at a deformed one, and on the tube refined twice.

use flexsurf::integrate::linsolve::{LinearSolver, Reuse, SolverKind};
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{Model, ModelBuilder, ModelKind};
use flexsurf::state::State;

/// A tube of radius 0.2 m and length 0.5 m, `around × down` nodes, its top ring pinned, and a shape with a
/// smooth ovalisation and a small roughness.
fn tube(around: usize, down: usize) -> (Model, Vec<Vec3>) {
    let fabric = Fabric::paper_cotton();
    let s = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
    let (grid, rest) = flexsurf::testing::cylinder(around, down, 0.2, 0.5);
    let mut b = ModelBuilder::new(grid, rest.clone(), fabric, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81));
    for k in 0..grid.len() {
        b.pinned[k] = grid.coords(k).1 == down - 1;
    }
    let x = rest
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let (i, j) = grid.coords(k);
            let phi = std::f64::consts::TAU * i as f64 / around as f64;
            let hang = (down - 1 - j) as f64 / (down - 1) as f64;
            let rough = ((k * 7919 % 101) as f64 / 101.0 - 0.5) * 1e-4;
            let radial = Vec3::new(phi.cos(), phi.sin(), 0.0);
            *p + radial * (0.02 * hang * (2.0 * phi).cos() + rough)
        })
        .collect();
    (b.build().unwrap(), x)
}

/// Multigrid's solution and iterations on `model`'s step matrix at `x`, its coarse space at `positions` (none:
/// the rest shape), against Cholesky's: (iterations, largest difference relative to the solution).
fn solve(model: &Model, x: &[Vec3], positions: Option<&[Vec3]>) -> (usize, f64) {
    let mut st = Stepper::new(model, &StepParams::with_dt(0.01)).unwrap();
    st.assemble(model, &State::at_rest(x.to_vec()));
    let a = st.matrix().clone();
    let b: Vec<Vec3> = st
        .rhs()
        .iter()
        .enumerate()
        .map(|(k, r)| *r + Vec3::new(1.0, -0.5, 0.25) * (((k * 31) % 17) as f64 - 8.0) * 1e-4)
        .collect();
    let pattern = model.potential.pattern();
    let run = |kind| {
        let mut solver = LinearSolver::new(kind, pattern, &model.panels).unwrap();
        if let Some(p) = positions {
            solver.set_positions(p);
        }
        let mut out = vec![Vec3::ZERO; b.len()];
        let stats = solver.solve(&a, model.pinned(), &b, &mut out, Reuse::Fresh).unwrap();
        (out, stats.iterations)
    };
    let (direct, _) = run(SolverKind::Cholesky);
    let (mg, iterations) = run(SolverKind::Multigrid);
    let scale = direct.iter().map(|v| v.length()).fold(0.0, f64::max);
    let diff = direct.iter().zip(&mg).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
    (iterations, diff / scale)
}

#[test]
fn multigrid_on_a_tube_solves_as_cholesky_within_an_iteration_bound() {
    let (model, x) = tube(96, 24);
    let at_rest = solve(&model, &x, None);
    let deformed = solve(&model, &x, Some(&x));
    eprintln!("tube 96x24: {at_rest:?} (iterations, difference) at the rest shape's rotations, {deformed:?} at the deformed shape's");
    // Refined twice in each direction (a hierarchy of three levels instead of two): measured 12.
    let (fine_model, fine_x) = tube(192, 48);
    let refined = solve(&fine_model, &fine_x, Some(&fine_x));
    eprintln!("tube 192x48: {refined:?} at the deformed shape's rotations");
    for (iterations, diff) in [at_rest, deformed, refined] {
        assert!(diff <= 1e-7, "multigrid differs from Cholesky by {diff:e}");
        // Issue 23, item 4: at most 12 (measured 10 at both; 43 and 42 while the periodic rings were smoothed in
        // halves, whose cuts left the ring's stiff hoop coupling to the Gauss–Seidel sweep).
        assert!(iterations <= 12, "{iterations} iterations");
    }
}
