//! Unit tests of the library, core area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `grid` (`src/grid.rs`).
mod grid {
    use flexsurf::grid::*;

    #[test]
    fn validation_and_wrapping() {
        assert!(matches!(Grid::sheet(2, 5, 1.0, 1.0), Err(GridError::TooFewNodes { dir: 1, count: 2 })));
        assert!(matches!(Grid::new(3, 3, f64::NAN, 1.0, [Topology::Free; 2]), Err(GridError::BadSpacing { .. })));
        let g = Grid::new(4, 3, 0.1, 0.2, [Topology::Periodic, Topology::Free]).unwrap();
        assert_eq!(g.node(-1, 0), Some(3));
        assert_eq!(g.node(0, -1), None);
        assert_eq!(g.spans(0), 4);
        assert_eq!(g.spans(1), 2);
        assert_eq!(g.cells().count(), 8);
        let total: f64 = (0..g.len()).map(|k| g.node_area(k)).sum();
        assert!((total - 4.0 * 0.1 * 2.0 * 0.2).abs() < 1e-14);
    }
}

/// The tests of `math` (`src/math.rs`).
mod math {
    use flexsurf::math::*;

    #[test]
    fn skew_is_cross_product() {
        let a = Vec3::new(0.3, -1.2, 2.0);
        let b = Vec3::new(-0.7, 0.4, 1.1);
        assert!((skew(a) * b - a.cross(b)).length() < 1e-15);
        assert!((outer(a, b) * b - a * b.dot(b)).length() < 1e-14);
        assert_eq!(entry(&outer(a, b), 0, 1), a.x * b.y);
    }
}

/// The tests of `ops` (`src/ops/mod.rs`).
mod ops {
    use flexsurf::grid::{Grid, Topology};
    use flexsurf::math::Vec3;
    use flexsurf::ops::*;

    /// Every operator is exact on quadratics, at interior nodes and on edges (the quadratic patch's property).
    #[test]
    fn operators_exact_on_quadratics() {
        let g = Grid::new(5, 4, 0.3, 0.2, [Topology::Free; 2]).unwrap();
        let f = |u: f64, v: f64| Vec3::new(1.0 + 2.0 * u - v + 0.5 * u * u, 3.0 * u * v - v * v, u - 0.25 * v * v);
        let x: Vec<Vec3> = (0..g.len())
            .map(|k| {
                let (i, j) = g.coords(k);
                f(i as f64 * g.h1, j as f64 * g.h2)
            })
            .collect();
        for k in 0..g.len() {
            let (i, j) = g.coords(k);
            let (u, v) = (i as f64 * g.h1, j as f64 * g.h2);
            let t1 = apply(&tangent(&g, 0, i, j), &x);
            let t2 = apply(&tangent(&g, 1, i, j), &x);
            assert!((t1 - Vec3::new(2.0 + u, 3.0 * v, 1.0)).length() < 1e-12);
            assert!((t2 - Vec3::new(-1.0, 3.0 * u - 2.0 * v, -0.5 * v)).length() < 1e-12);
            if let Some(s) = second(&g, 0, i, j) {
                assert!((apply(&s, &x) - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-10);
            }
            if let Some(s) = second(&g, 1, i, j) {
                assert!((apply(&s, &x) - Vec3::new(0.0, -2.0, -0.5)).length() < 1e-10);
            }
        }
        let tw = nodal_twist(&g, &x);
        for t in tw {
            assert!((t - Vec3::new(0.0, 3.0, 0.0)).length() < 1e-10);
        }
    }
}

/// The tests of `energy::curvature` (`src/energy/curvature.rs`).
mod curvature {
    use flexsurf::energy::curvature::*;
    use flexsurf::math::Vec3;

    fn b_of(z: &[f64; 9]) -> f64 {
        let a = Vec3::new(z[0], z[1], z[2]);
        let b = Vec3::new(z[3], z[4], z[5]);
        let v = Vec3::new(z[6], z[7], z[8]);
        NormalCurvature::new(a, b, v).value
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let z0 = [1.1, 0.2, -0.3, 0.1, 0.9, 0.4, 0.5, -0.7, 2.0];
        let (a, b, v) =
            (Vec3::new(z0[0], z0[1], z0[2]), Vec3::new(z0[3], z0[4], z0[5]), Vec3::new(z0[6], z0[7], z0[8]));
        let k = NormalCurvature::new(a, b, v);
        let grad: Vec<f64> = [k.da, k.db, k.dv].iter().flat_map(|g| [g.x, g.y, g.z]).collect();
        let h = k.hessian(a, b);
        let eps = 1e-6;
        for i in 0..9 {
            let mut zp = z0;
            let mut zm = z0;
            zp[i] += eps;
            zm[i] -= eps;
            let fd = (b_of(&zp) - b_of(&zm)) / (2.0 * eps);
            assert!((fd - grad[i]).abs() < 1e-8, "gradient {i}: {fd} vs {}", grad[i]);
            let gp = NormalCurvature::new(
                Vec3::new(zp[0], zp[1], zp[2]),
                Vec3::new(zp[3], zp[4], zp[5]),
                Vec3::new(zp[6], zp[7], zp[8]),
            );
            let gm = NormalCurvature::new(
                Vec3::new(zm[0], zm[1], zm[2]),
                Vec3::new(zm[3], zm[4], zm[5]),
                Vec3::new(zm[6], zm[7], zm[8]),
            );
            let dp: Vec<f64> = [gp.da, gp.db, gp.dv].iter().flat_map(|g| [g.x, g.y, g.z]).collect();
            let dm: Vec<f64> = [gm.da, gm.db, gm.dv].iter().flat_map(|g| [g.x, g.y, g.z]).collect();
            for j in 0..9 {
                let fd = (dp[j] - dm[j]) / (2.0 * eps);
                let an = h[j / 3][i / 3].col(i % 3)[j % 3];
                assert!((fd - an).abs() < 1e-7, "hessian ({j},{i}): {fd} vs {an}");
            }
        }
    }
}

/// The tests of `energy::frame` (`src/energy/frame.rs`).
mod frame {
    use flexsurf::energy::frame::*;
    use flexsurf::math::Vec3;

    #[test]
    fn identity_rotation_and_scaling() {
        let f = Frame::new(Vec3::X, Vec3::Y, 0.0);
        assert_eq!(f.voigt(), [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert!(f.is_aligned() && (f.area - 1.0).abs() < 1e-15);
        // Polar-like scaling: u2 is an angle, |∂X/∂u2| = r.
        let f = Frame::new(Vec3::X, Vec3::Y * 0.25, 0.0);
        assert!((f.area - 0.25).abs() < 1e-15 && (f.voigt()[1][1] - 16.0).abs() < 1e-12);
        // Warp at 90°: the u1 strain is the weft strain.
        let f = Frame::new(Vec3::X, Vec3::Y, std::f64::consts::FRAC_PI_2);
        let t = f.voigt();
        assert!((t[1][0] - 1.0).abs() < 1e-12 && t[0][0].abs() < 1e-12);
        assert!(f.is_aligned(), "warp along u2 is aligned with the grid");
        // Warp at 45°: uniaxial u1 strain ε has warp and weft strain ε/2 and shear ∓ε.
        let f = Frame::new(Vec3::X, Vec3::Y, std::f64::consts::FRAC_PI_4);
        let t = f.voigt();
        assert!((t[0][0] - 0.5).abs() < 1e-12 && (t[1][0] - 0.5).abs() < 1e-12 && (t[2][0].abs() - 1.0).abs() < 1e-12);
        assert!(!f.is_aligned());
    }
}

/// The tests of `material` (`src/material/mod.rs`).
mod material {
    use flexsurf::material::*;

    #[test]
    fn kes_calibration_of_the_paper_fabric() {
        let s = Stiffness::calibrate(&Fabric::paper_cotton(), Calibration::Kes).unwrap();
        assert_eq!((s.a11, s.a22, s.a66, s.a12), (21300.0, 4300.0, 54.0, 0.0));
        // Huber: D66 = ½ √(175e-6 · 45e-6) = 44.37e-6 (docs/model.md §A4: 44.4e-6).
        assert!((s.d66 - 44.370598e-6).abs() < 1e-11);
        let p = Stiffness::calibrate(&Fabric::paper_cotton(), Calibration::Paper).unwrap();
        assert_eq!(p.d11, 2.0 * 175e-6);
        assert_eq!(p.a66, 27.0);
    }

    #[test]
    fn poisson_coupling_recovers_uniaxial_stiffness() {
        let f = Fabric { poisson: 0.3, ..Fabric::paper_cotton() };
        let s = Stiffness::calibrate(&f, Calibration::Kes).unwrap();
        // Uniaxial: lateral strain free, effective A11 − A12²/A22 must be E1h.
        assert!((s.a11 - s.a12 * s.a12 / s.a22 - 21300.0).abs() < 1e-9);
        let p = Stiffness::calibrate(&f, Calibration::Paper).unwrap();
        assert!((p.a11 - 21084.0).abs() < 1.0 && (p.a22 - 2402.0).abs() < 1.0, "AUDIT §2.4: 21084 and 2402");
    }

    #[test]
    fn bad_constants_name_their_key() {
        let e = Fabric { density: f64::NAN, ..Fabric::paper_cotton() }.validate().unwrap_err();
        assert!(e.to_string().contains("density"));
        let e = Fabric { shear: -1.0, ..Fabric::paper_cotton() }.validate().unwrap_err();
        assert!(e.to_string().contains("shear"));
        let e = Fabric { poisson: 2.5, ..Fabric::paper_cotton() }.validate().unwrap_err();
        assert!(e.to_string().contains("poisson"));
    }
}

/// The tests of `material::law` (`src/material/law.rs`).
mod law {
    use flexsurf::material::law::*;

    /// Value, resultant and slope agree with central differences; the energy vanishes at the origin.
    #[test]
    fn energy_is_the_integral_of_the_resultant() {
        let pts = [(0.01, 2.0), (0.02, 3.0), (0.05, 10.0), (0.06, 30.0)];
        for kind in [Interpolation::Linear, Interpolation::MonotoneCubic] {
            let c = Curve::new(&pts, kind).unwrap();
            assert_eq!(c.eval(0.0).0, 0.0);
            for &(x, y) in &pts {
                assert!((c.resultant(x) - y).abs() < 1e-12 && (c.resultant(-x) + y).abs() < 1e-12);
            }
            for v in [-0.08, -0.033, -0.004, 0.007, 0.015, 0.037, 0.055, 0.09] {
                let h = 1e-7;
                let (e, n, dn) = c.eval(v);
                let fd = (c.eval(v + h).0 - c.eval(v - h).0) / (2.0 * h);
                assert!((fd - n).abs() < 1e-6 * n.abs().max(1.0), "{kind:?} N at {v}: {fd} vs {n}");
                let fd2 = (c.eval(v + h).1 - c.eval(v - h).1) / (2.0 * h);
                assert!((fd2 - dn).abs() < 1e-5 * dn, "{kind:?} N' at {v}: {fd2} vs {dn}");
                assert!(e > 0.0 && dn >= c.min_slope() * (1.0 - 1e-12));
            }
            // Closed form of the linear interpolation: ψ(0.02) = ½·0.01·2 + ½·0.01·(2 + 3) = 0.035.
            if kind == Interpolation::Linear {
                assert!((c.eval(0.02).0 - 0.035).abs() < 1e-15);
                assert!((c.min_slope() - 100.0).abs() < 1e-9, "smallest slope (3 − 2)/0.01");
            }
            assert!((c.strain(10.0) - 0.05).abs() < 1e-14);
        }
    }

    /// A Hermite law reproduces a cubic from its values and slopes; bad knots are refused; NaN stays NaN.
    #[test]
    fn hermite_law_through_values_and_slopes() {
        let f = |x: f64| (x + x * x * x, 1.0 + 3.0 * x * x);
        let knots: Vec<(f64, f64, f64)> = [-1.0, 0.0, 0.5, 2.0].iter().map(|&x| (x, f(x).0, f(x).1)).collect();
        let c = Curve::hermite(&knots).unwrap();
        for v in [-0.7, 0.2, 1.3] {
            assert!((c.resultant(v) - f(v).0).abs() < 1e-12 && (c.eval(v).2 - f(v).1).abs() < 1e-12);
        }
        assert!(c.eval(f64::NAN).0.is_nan());
        let bad = [(-1.0, -1.0, 1.0), (1.0, 1.0, 0.0)];
        assert_eq!(Curve::hermite(&bad).unwrap_err(), CurveError::BadHermite(1));
    }

    #[test]
    fn bad_curves_say_what_is_wrong() {
        let e = |p: &[(f64, f64)]| Curve::new(p, Interpolation::Linear).unwrap_err();
        assert_eq!(e(&[(0.01, 1.0)]), CurveError::TooFewPoints(1));
        assert_eq!(e(&[(0.02, 1.0), (0.01, 2.0)]), CurveError::NotIncreasing(0, 1));
        assert_eq!(e(&[(0.01, 2.0), (0.02, 1.0)]), CurveError::NonPositiveStiffness(0, 1));
        assert_eq!(e(&[(0.0, 1.0), (0.02, 2.0)]), CurveError::NotThroughOrigin(0, 1.0));
        assert_eq!(e(&[(0.01, f64::NAN), (0.02, 2.0)]), CurveError::NotFinite(0));
        assert!(e(&[(-0.01, 1.0), (0.02, 2.0)]).to_string().contains("negative or zero stiffness"));
    }
}

/// The tests of `material::units` (`src/material/units.rs`).
mod units {
    use flexsurf::material::units::*;

    #[test]
    fn hand_computed_conversions() {
        assert!((bending_from_kes(1.0) - 9.80665e-5).abs() < 1e-18);
        assert!((shear_from_kes(1.0) - 56.1879).abs() < 1e-3);
        assert!((density_from_kes(7.45) - 0.0745).abs() < 1e-15);
        assert!((tension_from_kes(500.0) - 490.3325).abs() < 1e-9);
        // FAST: W = 80 g/m², C = 13.7 mm → 9.81e-6 · 80 · 2571.353 = 2.017998 µN·m.
        assert!((bending_from_fast(13.7, 80.0) - 2.017_998e-6).abs() < 1e-11);
        assert!((shear_from_fast(2.0) - 61.5).abs() < 1e-12);
        // E100 = 2 %: 100 gf/cm = 98.0665 N/m at 0.02 strain → 4903.325 N/m.
        assert!((tension_from_fast(2.0) - 4903.325).abs() < 1e-9);
        assert!((density_from_fast(80.0) - 0.08).abs() < 1e-15);
    }
}

/// The tests of `ranges` (`src/ranges.rs`).
mod ranges {
    use flexsurf::ranges::*;

    #[test]
    fn messages_quote_the_value_only_when_asked() {
        assert_eq!(DT.problem(-1.0, true).unwrap(), "-1 s must be positive");
        assert_eq!(DT.problem(f64::NAN, false).unwrap(), "must be a finite number");
        assert_eq!(DT.problem(11.0, true).unwrap(), "11 s is outside the accepted range 1e-9 to 1e1 s");
        assert_eq!(FRICTION.problem(-0.5, true).unwrap(), "-0.5 must be finite and non-negative");
        assert_eq!(GRAVITY.problem(-2e4, true).unwrap(), "-20000 m/s² is outside the accepted range ±1e4 m/s²");
        assert!(DT.problem(0.01, true).is_none());
        assert_eq!(SPHERE_RADIUS.problem(0.0, true).unwrap(), "0 m must be a positive length");
    }

    #[test]
    fn unusual_values_name_both_unit_systems() {
        // 70 kg/m² is 7000 mg/cm²; the usual 0.01 to 1.5 kg/m² are 1 to 150 mg/cm² (1 mg/cm² = 0.01 kg/m²).
        let w = DENSITY.unusual(70.0, true).unwrap();
        assert!(
            w.starts_with(
                "70 kg/m² (7000 mg/cm²) is outside the usual range of fabrics, 0.01 to 1.5 kg/m² (1 to 150 mg/cm²"
            ),
            "{w}"
        );
        assert!(DENSITY.unusual(0.0745, true).is_none());
        // 1e-8 N·m = 1.02e-4 gf·cm²/cm (1 gf·cm²/cm = 9.80665e-5 N·m).
        assert!(BENDING_WARP.unusual(1.0, false).unwrap().contains("1e-8 to 0.001 N·m (1.02e-4 to 10.2 gf·cm²/cm"));
        assert!(DT.unusual(100.0, true).is_none() && CONTACT_OFFSET.unusual(0.0, true).is_none());
        assert_eq!((short(10.197), short(1.0197e-4), short(150.0)), ("10.2".into(), "1.02e-4".into(), "150".into()));
    }
}

/// The tests of `sparse` (`src/sparse.rs`).
mod sparse {
    use flexsurf::math::{Mat3, Vec3};
    use flexsurf::sparse::*;

    #[test]
    fn full_rows_multiply_as_the_symmetric_matrix() {
        let p = BlockPattern::from_pairs(3, [(0, 1), (2, 1)]);
        let mut a = BlockMatrix::zeros(&p);
        let m = |k: f64| Mat3::from_cols_array(&[k, 1.0, 2.0, 3.0, k, 4.0, 5.0, 6.0, k]);
        for (id, k) in (0..p.blocks()).zip([7.0, 8.0, 9.0, 10.0, 11.0]) {
            a.blocks[id] = m(k);
        }
        a.extra.add(2, 0, m(-1.0));
        let x = [Vec3::new(1.0, -2.0, 0.5), Vec3::new(0.3, 0.1, -1.0), Vec3::new(2.0, 1.0, 1.0)];
        let (mut want, mut got) = (vec![Vec3::ZERO; 3], vec![Vec3::ZERO; 3]);
        a.mul_add(&p, &x, &mut want);
        let full = BlockRows::from_symmetric(&a, &p);
        full.mul(&x, &mut got);
        assert_eq!(full.blocks(), 2 * p.blocks() - 3 + 2);
        for (w, g) in want.iter().zip(&got) {
            assert!((*w - *g).length() < 1e-12 * w.length().max(1.0), "{w} {g}");
        }
    }

    #[test]
    fn csc_layout_matches_blocks() {
        let p = BlockPattern::from_pairs(3, [(0, 1), (2, 1), (1, 0)]);
        assert_eq!(p.blocks(), 5);
        let (cp, ri, src) = p.csc_upper();
        assert_eq!(cp.len(), 10);
        // Column 0 (node 0, comp 0): only (0,0).
        assert_eq!(&ri[cp[0]..cp[1]], &[0]);
        // Column 4 (node 1, comp 1): rows of node 0 (3) then node 1 comps 0..=1.
        assert_eq!(&ri[cp[4]..cp[5]], &[0, 1, 2, 3, 4]);
        assert_eq!(src.len(), ri.len());
        assert_eq!(p.find(1, 2), p.find(2, 1));
    }
}

/// The tests of `energy::membrane` (`src/energy/membrane.rs`).
mod membrane {
    use flexsurf::energy::frame::Frame;
    use flexsurf::energy::membrane::condensed;
    use flexsurf::math::Vec3;

    /// The condensed edge stiffness is the orthotropic sheet's tensile modulus along the edge (Lekhnitskii):
    /// `1/E(φ) = cos⁴φ S₁₁ + sin⁴φ S₂₂ + (2 S₁₂ + S₆₆) sin²φ cos²φ` with `S` the compliance in the material
    /// frame, here inverted by hand for a fabric with a Poisson coupling (`a₁₂`) and a soft shear.
    #[test]
    fn condensed_edge_stiffness_is_the_modulus_along_the_edge() {
        let (a11, a22, a12, a66) = (400.0, 250.0, 30.0, 2.0);
        let det = a11 * a22 - a12 * a12;
        let (s11, s22, s12, s66) = (a22 / det, a11 / det, -a12 / det, 1.0 / a66);
        let c = [[a11, a12, 0.0], [a12, a22, 0.0], [0.0, 0.0, a66]];
        for phi in [0.0, 0.1, 0.3, std::f64::consts::FRAC_PI_4, 1.0, std::f64::consts::FRAC_PI_2] {
            let pulled = Frame::new(Vec3::X, Vec3::Y, phi).pull_back(&c);
            let (cs, sn) = (phi.cos(), phi.sin());
            let along_u1 = 1.0 / (cs.powi(4) * s11 + sn.powi(4) * s22 + (2.0 * s12 + s66) * sn * sn * cs * cs);
            // Along u2 the warp is at φ − 90°.
            let along_u2 = 1.0 / (sn.powi(4) * s11 + cs.powi(4) * s22 + (2.0 * s12 + s66) * sn * sn * cs * cs);
            for (i, want) in [(0, along_u1), (1, along_u2)] {
                let got = condensed(&pulled, i);
                assert!((got - want).abs() < 1e-11 * want, "φ {phi}, strain {i}: {got} vs {want}");
                assert!(got <= pulled[i][i] * (1.0 + 1e-12), "φ {phi}: above the full stiffness");
            }
        }
        // Aligned and without Poisson coupling: exactly the full stiffness.
        let plain = [[a11, 0.0, 0.0], [0.0, a22, 0.0], [0.0, 0.0, a66]];
        assert_eq!(condensed(&plain, 0), a11);
        assert_eq!(condensed(&plain, 1), a22);
        // On the bias of a fabric of equal warp and weft: about four times the shear stiffness.
        let bias = Frame::new(Vec3::X, Vec3::Y, std::f64::consts::FRAC_PI_4).pull_back(&[
            [a11, 0.0, 0.0],
            [0.0, a11, 0.0],
            [0.0, 0.0, a66],
        ]);
        let want = 1.0 / (0.5 / a11 + 0.25 / a66);
        assert!((condensed(&bias, 0) - want).abs() < 1e-11 * want);
        assert!(bias[0][0] > 25.0 * condensed(&bias, 0), "{bias:?}");
    }
}
