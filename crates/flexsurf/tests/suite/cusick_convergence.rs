//! Issue 21, item 1: the Cusick drape tester's grid convergence and its verified equilibrium, on the two
//! light wovens (soft: B 0.02 gf·cm²/cm, W 135 g/m², G 0.7 gf/(cm·deg); medium: B 0.076, W 253 g/m², G 2.2;
//! tensile 10⁴ gf/cm, 30 cm specimen) and a stiffer woven (B 0.3, W 250 g/m², G 3). KES units are converted
//! here by hand (1 gf·cm²/cm = 9.80665e-5 N·m, 1 gf/(cm·deg) = 0.980665·180/π N/m per rad, 1 g/m² = 1e-3
//! kg/m², 1 gf/cm = 0.980665 N/m), not through the library's converters.

use flexsurf::integrate::statics::StaticSolver;
use flexsurf::lab::cusick::{cusick_settled, default_polar, richardson, Drape, Settle, EQUILIBRIUM_TOLERANCE};
use flexsurf::material::{Calibration, Fabric};
use flexsurf::math::Vec3;

/// A woven with bending `b` (gf·cm²/cm, both directions), weight `w` (g/m²), shear `g` (gf/(cm·deg)) and
/// tensile 10⁴ gf/cm.
fn woven(b: f64, w: f64, g: f64) -> Fabric {
    let gf = 9.80665e-3; // N
    Fabric {
        density: w * 1e-3,
        tensile_warp: 1e4 * gf / 1e-2,
        tensile_weft: 1e4 * gf / 1e-2,
        shear: g * gf / 1e-2 * 180.0 / std::f64::consts::PI,
        bending_warp: b * gf * 1e-2,
        bending_weft: b * gf * 1e-2,
        ..Fabric::paper_cotton()
    }
}

fn soft() -> Fabric {
    woven(0.02, 135.0, 0.7)
}
fn medium() -> Fabric {
    woven(0.076, 253.0, 2.2)
}
fn stiff() -> Fabric {
    woven(0.3, 250.0, 3.0)
}

fn drape(f: &Fabric, level: usize) -> Drape {
    let t = std::time::Instant::now();
    let d = cusick_settled(f, Calibration::Kes, 0.30, default_polar(0.30, level), 0, &Settle::default()).unwrap();
    eprintln!("level {level}: {:?} in {:.2} s", d.report, t.elapsed().as_secs_f64());
    d
}

/// The hand conversion agrees with the material file reader's (the soft woven in KES units).
#[test]
fn the_wovens_in_kes_units() {
    let f = soft();
    assert!((f.bending_warp - 1.96133e-6).abs() < 1e-12, "{f:?}");
    assert!((f.shear - 39.33).abs() < 0.01, "{f:?}");
    assert!((f.tensile_warp - 9806.65).abs() < 1e-9 && (f.density - 0.135).abs() < 1e-15, "{f:?}");
}

/// The reported shape is an equilibrium: the largest nodal force imbalance, computed here from the potential's
/// gradient on the free nodes, is below the tolerance in nodal weights after the final static solve (and was
/// not at the relaxation's end). Level 0 of the medium woven (about 1 s).
#[test]
fn cusick_final_shape_is_an_equilibrium() {
    let d = drape(&medium(), 0);
    let mut g = vec![Vec3::ZERO; d.x.len()];
    StaticSolver::potential(&d.model, &d.x, Some(&mut g));
    let weight = d.model.mass.iter().fold(0.0, |a: f64, m| a.max(m * 9.81));
    let free = g.iter().zip(d.model.pinned()).filter(|(_, &p)| !p).map(|(v, _)| v.length()).fold(0.0, f64::max);
    assert!(free / weight <= EQUILIBRIUM_TOLERANCE, "residual {:.3e} nodal weights", free / weight);
    assert!((d.report.residual - free / weight).abs() <= 1e-3 * EQUILIBRIUM_TOLERANCE.max(free / weight));
    assert!(d.report.relaxed_residual > 10.0 * EQUILIBRIUM_TOLERANCE, "{:?}", d.report);
    assert!(d.report.static_iterations > 0, "{:?}", d.report);
    // Without the static solve the relaxation's end is reported as it is.
    let settle = Settle { equilibrium: None, ..Settle::default() };
    let r = cusick_settled(&medium(), Calibration::Kes, 0.30, default_polar(0.30, 0), 0, &settle).unwrap().report;
    assert_eq!((r.residual, r.static_iterations), (d.report.relaxed_residual, 0));
}

/// Richardson extrapolation against hand values: a first-order sequence 10, 8, 6 at h = 3, 2, 1 extrapolates to
/// 4 with order 1; a second-order one, 5 + h² at h = 1.5, 1, 0.75, to 5 with order 2; two values assume order 1.
#[test]
fn richardson_against_hand_values() {
    let (v, p) = richardson(&[(3.0, 10.0), (2.0, 8.0), (1.0, 6.0)]).unwrap();
    assert!((v - 4.0).abs() < 1e-9 && (p - 1.0).abs() < 1e-9, "{v} {p}");
    let (v, p) = richardson(&[(1.5, 7.25), (1.0, 6.0), (0.75, 5.5625)]).unwrap();
    assert!((v - 5.0).abs() < 1e-9 && (p - 2.0).abs() < 1e-9, "{v} {p}");
    let (v, p) = richardson(&[(7.5, 43.41), (5.0, 43.25)]).unwrap();
    assert!((v - (43.25 - 0.16 * 2.0)).abs() < 1e-9 && p == 1.0, "{v} {p}");
    assert!(richardson(&[(1.0, 1.0)]).is_err() && richardson(&[(1.0, 1.0), (2.0, 1.0)]).is_err());
}

/// Item 1's target: the drape coefficient at levels 1 and 2 within 1 point. Met by the medium woven (measured
/// 43.25 % and 42.76 %, 8 nodes at both; about 10 s in the ci profile).
#[test]
fn cusick_medium_woven_is_grid_converged() {
    let f = medium();
    let (a, b) = (drape(&f, 1).report, drape(&f, 2).report);
    assert!((a.drape_coefficient - b.drape_coefficient).abs() <= 1.0, "level 1 {a:?}, level 2 {b:?}");
}

/// Not met today by the soft and the stiff woven (measured: soft 39.48 % vs 32.22 %, 9 nodes at both; stiff
/// 77.89 % vs 79.24 %, 7 nodes at both): docs/materials.md, "Grid convergence". Ignored until the membrane
/// locking of the coarse grids is removed; run with `--ignored` (about 25 s).
#[test]
#[ignore = "issue 21: not grid-converged yet for the soft and the stiff woven (docs/materials.md)"]
fn cusick_soft_and_stiff_wovens_are_grid_converged() {
    for f in [soft(), stiff()] {
        let (a, b) = (drape(&f, 1).report, drape(&f, 2).report);
        assert!((a.drape_coefficient - b.drape_coefficient).abs() <= 1.0, "level 1 {a:?}, level 2 {b:?}");
    }
}
