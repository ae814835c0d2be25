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

/// Roache's grid convergence index against hand values: 10, 8, 6 at h = 3, 2, 1 (order 1 observed, r = 2):
/// `1.25 · 2 / (2 − 1)` = 2.5; 5 + h² at h = 1.5, 1, 0.75 (order 2 observed, r = 4/3): `1.25 · 0.4375 / (16/9 − 1)`
/// = 0.703125; two levels 43.41, 43.25 at 7.5, 5 (order 1 assumed, r = 1.5): `3 · 0.16 / 0.5` = 0.96.
#[test]
fn grid_convergence_index_against_hand_values() {
    use flexsurf::lab::cusick::grid_convergence;
    let g = grid_convergence(&[(3.0, 10.0), (2.0, 8.0), (1.0, 6.0)]).unwrap();
    assert!(g.observed && (g.uncertainty - 2.5).abs() < 1e-9 && (g.spread - 2.0).abs() < 1e-12, "{g:?}");
    let g = grid_convergence(&[(1.5, 7.25), (1.0, 6.0), (0.75, 5.5625)]).unwrap();
    assert!(g.observed && (g.uncertainty - 0.703125).abs() < 1e-9 && (g.extrapolated - 5.0).abs() < 1e-9, "{g:?}");
    let g = grid_convergence(&[(7.5, 43.41), (5.0, 43.25)]).unwrap();
    assert!(!g.observed && (g.uncertainty - 0.96).abs() < 1e-9 && g.order == 1.0, "{g:?}");
    // Levels that do not converge monotonically: the order is assumed, the band wide.
    let g = grid_convergence(&[(7.5, 39.61), (5.0, 38.49), (3.75, 35.11)]).unwrap();
    assert!(!g.observed && (g.uncertainty - 3.0 * 3.38 / (4.0 / 3.0 - 1.0)).abs() < 1e-9, "{g:?}");
}

/// Item 1's target: the drape coefficient at levels 1 and 2 within 1 point, on a soft, a medium and a stiff
/// woven. Met since the tester takes the membrane's condensed edge stiffness and 144 / 192 nodes around
/// (measured: soft 28.62 % vs 29.43 %, medium 45.55 % vs 46.18 %, stiff 81.83 % vs 82.11 %; before, with the
/// full edge stiffness and 72 / 96 around, 38.49 / 35.11, 48.52 / 45.67 and 81.24 / 82.52: docs/materials.md,
/// "The membrane's edge stiffness"). Run with `--ignored` (about 30 s).
#[test]
#[ignore = "long check (six Cusick specimens, about 30 s): run with --ignored"]
fn cusick_wovens_are_grid_converged() {
    for f in [soft(), medium(), stiff()] {
        let (a, b) = (drape(&f, 1).report, drape(&f, 2).report);
        assert!((a.drape_coefficient - b.drape_coefficient).abs() <= 1.0, "level 1 {a:?}, level 2 {b:?}");
        // Each static solve converged from the first relaxation's end: a failed one sends the specimen back to
        // a slower relaxation (the stiff woven's level 1 took 2,146 steps so before the static solver raised
        // its shift on the exact Hessian; 565 since).
        assert!(a.steps < 1000 && b.steps < 1000, "level 1 {a:?}, level 2 {b:?}");
    }
}

/// The hem's deflection of an isotropic Kirchhoff annular plate clamped level at `r = a`, free at `r = b`,
/// under a uniform load `q` (N/m², along −z) with rigidity `d` and Poisson's ratio `nu`, from the closed form
/// `w = q r⁴/(64 D) + C1 + C2 r² + C3 ln r + C4 r² ln r`: the shear resultant free at `b` gives
/// `C4 = −q b²/(8 D)`; `w(a) = 0`, `w'(a) = 0` and the radial moment free at `b`, `w'' + ν w'/r = 0`, give
/// `C1`, `C2`, `C3` (a 3 × 3 system, solved here by Cramer's rule). For the test's plate it gives 8.709745e-5 m,
/// as an RK4 shooting of the slope equation `φ'' + φ'/r − φ/r² = q (b² − r²)/(2 r D)` did outside the suite
/// (and, for `a` = 10 m, the cantilevered strip's `q L⁴/(8 D)` within the curvature's 0.2 %).
fn annular_plate_hem(a: f64, b: f64, q: f64, d: f64, nu: f64) -> f64 {
    let c4 = -q * b * b / (8.0 * d);
    // w'(r) and w''(r) without the C1, C2, C3 terms; their coefficients are (0, 2r, 1/r) and (0, 2, −1/r²).
    let dw = |r: f64| q * r.powi(3) / (16.0 * d) + c4 * (2.0 * r * r.ln() + r);
    let ddw = |r: f64| 3.0 * q * r * r / (16.0 * d) + c4 * (2.0 * r.ln() + 3.0);
    let w0 = |r: f64| q * r.powi(4) / (64.0 * d) + c4 * r * r * r.ln();
    // Rows: w(a) = 0, w'(a) = 0, w''(b) + ν w'(b)/b = 0 in (C1, C2, C3).
    let m = [[1.0, a * a, a.ln()], [0.0, 2.0 * a, 1.0 / a], [0.0, 2.0 + 2.0 * nu, -1.0 / (b * b) + nu / (b * b)]];
    let rhs = [-w0(a), -dw(a), -(ddw(b) + nu * dw(b) / b)];
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let solve = |k: usize| {
        let mut mk = m;
        for (row, r) in mk.iter_mut().zip(rhs) {
            row[k] = r;
        }
        det(mk) / det(m)
    };
    let (c1, c2, c3) = (solve(0), solve(1), solve(2));
    w0(b) + c1 + c2 * b * b + c3 * b.ln()
}

/// The clamp of the drape tester against the closed form: a 30 cm specimen of an isotropic plate (ν = 0.3,
/// membrane 10⁴ N/m) clamped on the disc, under a weight light enough that its hem drops 0.09 mm (1.5e-3 of
/// the 6 cm overhang: linear), drops as the clamped-free annular plate says. Its two clamped rings lie half a
/// cell either side of the disc's edge, so the error falls at nearly second order in the radial spacing:
/// measured −1.81 %, −0.52 %, −0.17 % at 6, 12, 24 radial cells (96 around; 192 around: −1.79, −0.50,
/// −0.15 %). A clamp at `rd − h` and `rd`, as before, holds the slope level at `rd − h/2`, a longer overhang:
/// +35 %, +17 %, +8.5 %, first order. About 0.7 s in all.
#[test]
fn cusick_clamp_deflects_as_the_annular_plate() {
    use flexsurf::integrate::statics::StaticOptions;
    use flexsurf::lab::cusick::{specimen_builder, PolarGrid, DISC};
    use flexsurf::material::Stiffness;
    let (rigidity, nu, density) = (1e-2, 0.3, 0.05);
    let f = Fabric {
        density,
        tensile_warp: 1e4,
        tensile_weft: 1e4,
        poisson: 0.3,
        shear: 1e4 / 2.6,
        bending_warp: rigidity,
        bending_weft: rigidity,
        bending_poisson: nu,
        twist: None,
        ..Fabric::paper_cotton()
    };
    let exact = annular_plate_hem(0.5 * DISC, 0.15, density * 9.81, rigidity, nu);
    let mut errors = Vec::new();
    for radial in [6, 12, 24] {
        let s = Stiffness::calibrate(&f, Calibration::Kes).unwrap();
        let builder = specimen_builder(&f, s, 0.30, PolarGrid::uniform(radial, 96)).unwrap();
        let mut x = builder.panels[0].rest.clone();
        let model = builder.build().unwrap();
        let opts = StaticOptions { tolerance: 1e-10, max_iterations: 100 };
        StaticSolver::new(&model).unwrap().solve(&model, &mut x, &opts).unwrap();
        let grid = model.panels[0].grid;
        let hem = (0..grid.n).map(|j| -x[grid.index(grid.m - 1, j)].z).sum::<f64>() / grid.n as f64;
        let err = (hem - exact) / exact;
        eprintln!("{radial} radial cells: hem drop {hem:.6e} m, closed form {exact:.6e} m, error {err:.2e}");
        errors.push(err.abs());
    }
    assert!((exact - 8.7097e-5).abs() < 1e-9, "{exact}");
    assert!(errors[2] < 2.5e-3, "{errors:?}");
    // Order 1.5 or more: each halving of the spacing divides the error by more than 2.8.
    assert!(errors[0] / errors[1] > 2.8 && errors[1] / errors[2] > 2.8, "{errors:?}");
}
