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
