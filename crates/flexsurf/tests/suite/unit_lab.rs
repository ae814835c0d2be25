//! Unit tests of the library, lab area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `lab::cantilever::elastica` (`src/lab/cantilever/elastica.rs`).
mod elastica {
    use flexsurf::lab::cantilever::*;

    /// docs/model.md §A10 item 7: the exact heavy elastica's chord angles.
    #[test]
    fn elastica_matches_the_audit_table() {
        for (q, deg) in [(1.0, 7.10), (2.0, 13.86), (4.0, 25.53), (8.0, 41.49), (16.0, 57.39)] {
            let r = elastica_chord_deg(q);
            assert!((r - deg).abs() < 0.05, "q = {q}: {r}° vs {deg}°");
        }
    }
}

/// The tests of `lab::cantilever::rk4` (`src/lab/cantilever/rk4.rs`).
mod rk4 {
    use flexsurf::lab::cantilever::internals::rk4;

    /// `y' = y` to `s = 1` is `e`, to fourth order; the nested array state advances each component alike.
    #[test]
    fn exponential_to_fourth_order() {
        let e = rk4(1.0, 0.01, 100, |_, y| *y, |_| {});
        assert!((e - std::f64::consts::E).abs() < 1e-9, "{e}");
        let mut count = 0;
        let v = rk4([[1.0, 2.0], [0.0, -1.0]], 0.01, 100, |_, y| *y, |_| count += 1);
        assert_eq!(count, 100);
        // Scaling by a power of two is exact, so the components come out exactly scaled.
        assert_eq!(v, [[e, 2.0 * e], [0.0, -e]]);
    }
}

/// The tests of `lab::cusick` (`src/lab/cusick.rs`).
mod cusick {
    use flexsurf::lab::cusick::internals::count_folds;
    use std::f64::consts::PI;

    #[test]
    fn folds_of_a_six_lobed_hem() {
        let r: Vec<f64> = (0..72).map(|j| 0.12 + 0.01 * (6.0 * j as f64 * 2.0 * PI / 72.0).cos()).collect();
        assert_eq!(count_folds(&r), 6);
        assert_eq!(count_folds(&[0.1; 12]), 0);
    }
}

/// The tests of `lab::kes` (`src/lab/kes.rs`).
mod kes {
    use flexsurf::lab::kes::internals::parabola;

    #[test]
    fn parabola_fit_is_exact_on_a_parabola() {
        let pts: Vec<(f64, f64)> = (0..7).map(|i| (i as f64 * 0.1, 3.0 * (i as f64 * 0.1).powi(2) - 0.2)).collect();
        assert!((parabola(&pts) - 3.0).abs() < 1e-9);
    }
}

/// The tests of `lab::fit::lm` (`src/lab/fit/lm.rs`).
mod lm {
    use flexsurf::lab::fit::lm::{minimise, Evaluation, Options};

    /// A residual that jumps across its root, as a drape coefficient does where the drape changes equilibrium:
    /// `r = θ − 1 ∓ 0.05` below and above `θ = 1`, so the cost never falls below `½ 0.05² = 1.25e-3`, reached
    /// only at the jump. The step tolerance alone walks towards it until the iteration limit; the cost
    /// tolerance ends the fit beside the jump (the residual a tenth of its uncertainty, where a step no longer
    /// changes `χ²` by 2e-3) and says it converged.
    #[test]
    fn a_cost_floor_ends_the_fit_at_the_jump() {
        let eval = |t: &[f64]| -> Result<Evaluation, ()> {
            let jump = if t[0] < 1.0 { -0.05 } else { 0.05 };
            Ok((vec![t[0] - 1.0 + jump], vec![vec![1.0]]))
        };
        let bounds = (&[-10.0][..], &[10.0][..]);
        let strict = Options { max_iterations: 25, step_tolerance: 1e-10, cost_tolerance: 0.0 };
        let out = minimise(&[0.0], bounds, strict, eval).unwrap();
        assert!(!out.converged && out.iterations == 25, "{out:?}");
        let floor = Options { cost_tolerance: 1e-3, ..strict };
        let out = minimise(&[0.0], bounds, floor, eval).unwrap();
        let cost = 0.5 * out.at.0[0] * out.at.0[0];
        assert!(out.converged && out.iterations < 10, "{out:?}");
        assert!((out.theta[0] - 1.0).abs() < 0.15 && out.at.0[0].abs() < 0.1 && cost < 5e-3, "{out:?}");
        // A smooth residual: the Gauss–Newton steps reach the root first (the cost tolerance ends the fit one
        // accepted step later, at a residual far inside its uncertainty); the step tolerance alone goes on to
        // round-off.
        let smooth = |t: &[f64]| -> Result<Evaluation, ()> { Ok((vec![t[0] - 1.0], vec![vec![1.0]])) };
        let out = minimise(&[0.0], bounds, floor, smooth).unwrap();
        assert!(out.converged && (out.theta[0] - 1.0).abs() < 1e-6, "{out:?}");
        let out = minimise(&[0.0], bounds, strict, smooth).unwrap();
        assert!(out.converged && (out.theta[0] - 1.0).abs() < 1e-12, "{out:?}");
    }
}
