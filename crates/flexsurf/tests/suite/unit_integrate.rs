//! Unit tests of the library, integrate area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `integrate::descent` (`src/integrate/descent.rs`).
mod descent {
    use flexsurf::integrate::internals::{backtrack, resolvable};

    #[test]
    fn backtrack_is_the_parabolas_minimum_within_bounds() {
        // φ(α) = 1 − 2α + 4α²: least at α = 1/4; φ(1) = 3.
        assert!((backtrack(1.0, -2.0, 3.0) - 0.25).abs() < 1e-15);
        // A parabola least beyond 1/2, or a non-finite value, is clamped.
        assert_eq!(backtrack(1.0, -2.0, 0.5), 0.5);
        assert_eq!(backtrack(1.0, -2.0, f64::INFINITY), 0.1);
        assert!(resolvable(-1e-3, 1.0) && !resolvable(-1e-16, 1.0) && !resolvable(1e-3, 1.0));
        assert!(!resolvable(f64::NAN, 1.0));
    }
}

/// The tests of `integrate::linsolve::lines` (`src/integrate/linsolve/lines.rs`).
mod lines {
    use flexsurf::integrate::linsolve::lines::internals::{band_factor, band_solve};

    #[test]
    fn banded_cholesky_solves_a_banded_system() {
        // Diagonally dominant SPD band matrices of half-bandwidths 1, 2 (pentadiagonal), 5 and 8 (the
        // smoother's, for couplings two nodes apart): odd and even numbers of terms in a row's sums.
        for (n, w) in [(7, 1), (12, 2), (17, 5), (30, 8)] {
            let a = |i: usize, j: usize| -> f64 {
                match i.abs_diff(j) {
                    0 => 2.0 * w as f64 + 2.0 + i as f64 * 0.1,
                    d if d <= w => (-1.0f64).powi(d as i32) * (1.0 + 0.3 * ((i + j) as f64).sin()),
                    _ => 0.0,
                }
            };
            let mut band = vec![0.0; n * (w + 1)];
            for i in 0..n {
                for d in 0..=w.min(i) {
                    band[i * (w + 1) + d] = a(i, i - d);
                }
            }
            band_factor(&mut band, w, n);
            let x_true: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
            let mut b: Vec<f64> = (0..n).map(|i| (0..n).map(|j| a(i, j) * x_true[j]).sum()).collect();
            band_solve(&band, w, &mut b);
            for (x, t) in b.iter().zip(&x_true) {
                assert!((x - t).abs() < 1e-12, "w = {w}: {x} vs {t}");
            }
        }
    }
}

/// The tests of `integrate::linsolve::multigrid` (`src/integrate/linsolve/multigrid.rs`).
mod multigrid {
    use flexsurf::grid::{Grid, Topology};
    use flexsurf::integrate::linsolve::multigrid::internals::{self as mgi, build, refill_coarse};
    use flexsurf::integrate::linsolve::multigrid::Cycle;
    use flexsurf::integrate::linsolve::{BlockSolver, Cholesky, Multigrid, Reuse};
    use flexsurf::integrate::Stepper;
    use flexsurf::math::Vec3;
    use flexsurf::sparse::{BlockMatrix, BlockPattern};

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }

    /// The step matrix of the 41×41 ball drop after a few steps (contacts and friction in it).
    fn step_matrix(n: usize, topology: [Topology; 2]) -> (BlockPattern, BlockMatrix, Grid, Vec<Vec3>) {
        let scene = flexsurf::bench::ball_drop(n).unwrap();
        let mut state = scene.state.clone();
        let mut stepper = Stepper::new(&scene.model, &scene.step_params()).unwrap();
        stepper.assemble(&scene.model, &state);
        for _ in 0..3 {
            stepper.step(&scene.model, &mut state).unwrap();
        }
        stepper.assemble(&scene.model, &state);
        let grid = Grid { topology, ..scene.model.panels[0].grid };
        (scene.model.potential.pattern().clone(), stepper.matrix().clone(), grid, state.x)
    }

    /// A tube (periodic around, free along its axis, its top ring pinned, radius 0.2 m) at a slightly rough
    /// shape: its step matrix, grid, positions and pinned nodes.
    fn tube(around: usize, down: usize) -> (BlockPattern, BlockMatrix, Grid, Vec<Vec3>, Vec<bool>) {
        use flexsurf::material::{Calibration, Fabric, Stiffness};
        use flexsurf::model::{ModelBuilder, ModelKind};
        let fabric = Fabric::paper_cotton();
        let stiffness = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
        let (grid, rest) = flexsurf::testing::cylinder(around, down, 0.2, 0.5);
        let gravity = Vec3::new(0.0, 0.0, -9.81);
        let mut b = ModelBuilder::new(grid, rest.clone(), fabric, stiffness, ModelKind::Tfs, gravity);
        for k in 0..grid.len() {
            b.pinned[k] = grid.coords(k).1 == down - 1;
        }
        let model = b.build().unwrap();
        let mut seed = 11;
        let x: Vec<Vec3> =
            rest.iter().map(|p| *p + Vec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)) * 1e-3).collect();
        let mut stepper = Stepper::new(&model, &flexsurf::integrate::StepParams::with_dt(0.01)).unwrap();
        stepper.assemble(&model, &flexsurf::state::State::at_rest(x.clone()));
        (model.potential.pattern().clone(), stepper.matrix().clone(), grid, x, model.pinned().to_vec())
    }

    /// On a tube the prolongation carries a rigid motion `t + θ × x` of the coarse nodes exactly to every fine
    /// node with one or four parents (a cell's centre), and to a node between two parents up to the twist about
    /// their line, `(θ·ê) ê × (x − x̄)`; linear interpolation misses by `θ × (x − x̄)`, a tenth of a millimetre
    /// here.
    #[test]
    fn prolongation_carries_rigid_motions_on_a_tube() {
        let (pattern, a, grid, x, _) = tube(64, 16);
        let mut mg = Multigrid::on_grid(&pattern, &grid, &x).unwrap();
        build(&mut mg, &vec![false; pattern.nodes()]).unwrap();
        refill_coarse(&mut mg, &a, &x).unwrap();
        let level = mgi::level(&mg, 0);
        let (t, theta) = (Vec3::new(0.3, -0.2, 0.1), Vec3::new(0.7, 0.4, -0.5));
        let rigid = |p: Vec3| t + theta.cross(p);
        let coarse_x: Vec<Vec3> = level.pos.iter().map(|p| rigid(*p)).collect();
        let mut u = vec![Vec3::ZERO; x.len()];
        mgi::prolong_add(&mg, 0, &coarse_x, &mut u);
        let (mut worst, mut linear) = (0.0f64, 0.0f64);
        for (k, (uk, xk)) in u.iter().zip(&x).enumerate() {
            let parents: Vec<Vec3> = (level.p_start[k]..level.p_start[k + 1])
                .map(|e| level.pos[level.p_node[e as usize] as usize])
                .collect();
            let center = parents.iter().fold(Vec3::ZERO, |s, p| s + *p) / parents.len() as f64;
            let twist = match parents[..] {
                [p, q] => {
                    let e = (q - p).normalize();
                    (e * theta.dot(e)).cross(*xk - center)
                }
                _ => Vec3::ZERO,
            };
            worst = worst.max((*uk - rigid(*xk) + twist).length());
            linear = linear.max(theta.cross(*xk - center).length());
        }
        assert!(worst <= 1e-13, "a rigid motion is off by {worst:e} m (linear interpolation: {linear:e} m)");
        assert!(linear > 1e-4, "linear interpolation's miss {linear:e} m");
    }

    /// The V-cycle and the W-cycle on a tube with its top ring pinned (three levels, so that the W-cycle solves
    /// its middle level twice) are symmetric positive definite operators, and different ones.
    #[test]
    fn both_cycles_are_symmetric_positive_definite_on_a_tube() {
        let (pattern, a, grid, x, fixed) = tube(128, 32);
        let mut seed = 5;
        let mut random = || -> Vec<Vec3> {
            let v = (0..x.len()).map(|_| Vec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)));
            v.zip(&fixed).map(|(v, &f)| if f { Vec3::ZERO } else { v }).collect()
        };
        let (u, v) = (random(), random());
        let dot = |p: &[Vec3], q: &[Vec3]| p.iter().zip(q).map(|(a, b)| a.dot(*b)).sum::<f64>();
        let mut applied = Vec::new();
        for cycle in [Cycle::V, Cycle::W] {
            let mut mg = Multigrid::on_grid(&pattern, &grid, &x).unwrap().with_cycle(cycle);
            build(&mut mg, &fixed).unwrap();
            assert_eq!((mg.levels(), mg.cycle()), (3, cycle));
            mgi::refill_fine(&mut mg, &a);
            refill_coarse(&mut mg, &a, &x).unwrap();
            let (mut mu, mut mv) = (vec![Vec3::ZERO; x.len()], vec![Vec3::ZERO; x.len()]);
            mgi::cycle(&mut mg, &u, &mut mu);
            mgi::cycle(&mut mg, &v, &mut mv);
            let (uv, vu) = (dot(&mu, &v), dot(&u, &mv));
            let scale = dot(&mu, &mu).sqrt() * dot(&v, &v).sqrt();
            assert!((uv - vu).abs() <= 1e-10 * scale, "{cycle:?}: uᵀMv = {uv:e}, vᵀMu = {vu:e}");
            assert!(dot(&mu, &u) > 0.0 && dot(&mv, &v) > 0.0, "{cycle:?}");
            applied.push(mu);
        }
        let apart = applied[0].iter().zip(&applied[1]).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
        assert!(apart > 1e-6 * dot(&applied[0], &applied[0]).sqrt(), "the W-cycle is the V-cycle: {apart:e}");
    }

    #[test]
    fn coarse_operators_are_galerkin_products() {
        for topology in [[Topology::Free; 2], [Topology::Periodic, Topology::Free]] {
            let (pattern, a, grid, x) = step_matrix(41, topology);
            let fixed = vec![false; pattern.nodes()];
            let mut mg = Multigrid::on_grid(&pattern, &grid, &x).unwrap();
            build(&mut mg, &fixed).unwrap();
            refill_coarse(&mut mg, &a, &x).unwrap();
            let level = mgi::level(&mg, 0);
            let nc = level.pattern.nodes();
            let mut seed = 7;
            let v: Vec<Vec3> = (0..nc).map(|_| Vec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed))).collect();
            // P v, A P v, Pᵀ A P v.
            let mut pv = vec![Vec3::ZERO; pattern.nodes()];
            mgi::prolong_add(&mg, 0, &v, &mut pv);
            let mut apv = vec![Vec3::ZERO; pattern.nodes()];
            a.mul_add(&pattern, &pv, &mut apv);
            let restricted = mgi::restrict(&mg, 0, &apv);
            let mut acv = vec![Vec3::ZERO; nc];
            level.a.mul_add(level.pattern, &v, &mut acv);
            let scale = acv.iter().map(|w| w.length()).fold(0.0, f64::max);
            let err = acv.iter().zip(&restricted).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
            assert!(err <= 1e-12 * scale, "{topology:?}: |A_c v − Pᵀ A P v| = {err:e} of {scale:e}");
        }
    }

    #[test]
    fn multigrid_solution_matches_the_direct_solve() {
        let (pattern, a, grid, pos) = step_matrix(41, [Topology::Free; 2]);
        let mut fixed = vec![false; pattern.nodes()];
        fixed[5] = true;
        fixed[700] = true;
        let mut seed = 3;
        let b: Vec<Vec3> =
            (0..pattern.nodes()).map(|_| Vec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed))).collect();
        let mut x_direct = vec![Vec3::ZERO; b.len()];
        Cholesky::new(&pattern).unwrap().solve(&a, &fixed, &b, &mut x_direct, Reuse::Fresh).unwrap();
        let mut x = vec![Vec3::ZERO; b.len()];
        let stats =
            Multigrid::on_grid(&pattern, &grid, &pos).unwrap().solve(&a, &fixed, &b, &mut x, Reuse::Fresh).unwrap();
        let scale = x_direct.iter().map(|w| w.length()).fold(0.0, f64::max);
        let err = x.iter().zip(&x_direct).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
        assert!(
            err <= 1e-6 * scale,
            "multigrid differs from Cholesky by {err:e} (of {scale:e}), {} iterations",
            stats.iterations
        );
        assert_eq!(x[5], b[5]);
        assert_eq!(x[700], b[700]);
        eprintln!(
            "41x41 step matrix: {} multigrid iterations, max difference {:.2e} of {:.2e}",
            stats.iterations, err, scale
        );
    }
}
