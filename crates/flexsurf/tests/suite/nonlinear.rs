//! Nonlinear fabrics (issue 21, item 3; docs/model.md §4.5): the excess terms through the shared
//! finite-difference checker, a straight-line law against the linear material, closed forms of a strip in
//! uniaxial tension and of a pure moment, SI against KES units, the KES round trip of the curves, and the errors
//! of bad curves.

use flexsurf::energy::frame::Warp;
use flexsurf::energy::nonlinear::{NonlinearBending, NonlinearMembrane};
use flexsurf::energy::Operator;
use flexsurf::grid::Grid;
use flexsurf::integrate::statics::{StaticOptions, StaticSolver};
use flexsurf::lab::kes::kes_curves;
use flexsurf::material::law::{Curve, Interpolation, Laws};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{ElasticOptions, ModelBuilder, ModelKind};
use flexsurf::scene::material::material_from_toml;
use flexsurf::testing::{alone, check, cylinder, eigen_range, hessians, perturbed};
use std::path::Path;
use std::sync::Arc;

const TOL: f64 = 1e-6;

fn laws(kind: Interpolation) -> Laws {
    let c = |p: &[(f64, f64)]| Some(Curve::new(p, kind).unwrap());
    Laws {
        tensile_warp: c(&[(0.01, 100.0), (0.03, 250.0), (0.1, 2000.0), (0.3, 12000.0)]),
        tensile_weft: c(&[(0.02, 60.0), (0.1, 900.0), (0.25, 5000.0)]),
        shear: c(&[(0.02, 1.0), (0.1, 3.0), (0.3, 20.0)]),
        bending_warp: c(&[(2.0, 2e-4), (10.0, 6e-4), (30.0, 4e-3)]),
        bending_weft: c(&[(5.0, 1e-4), (20.0, 3e-4), (60.0, 5e-3)]),
        hysteresis: [0.0; 3],
    }
}

/// The excess terms' gradients and exact Hessians match central differences (aligned and rotated frames, a
/// periodic cylinder, both interpolations), and their projected operators are positive semi-definite.
#[test]
fn excess_terms_pass_the_checker() {
    let g = Grid::sheet(5, 4, 0.2, 0.15).unwrap();
    let rest = g.flat_positions(0.0);
    let x = perturbed(&rest, 0.02, 11);
    let (gc, restc) = cylinder(6, 4, 0.1, 0.2);
    let xc = perturbed(&restc, 0.01, 12);
    for kind in [Interpolation::Linear, Interpolation::MonotoneCubic] {
        let l = laws(kind);
        for (name, warp) in [
            ("aligned", Warp::Angle(0.0)),
            ("warp along u2", Warp::Angle(std::f64::consts::FRAC_PI_2)),
            ("warp 0.6 rad", Warp::Angle(0.6)),
        ] {
            let m = NonlinearMembrane::new(&g, &rest, &l, warp).unwrap();
            let b = NonlinearBending::new(&g, &rest, &l, warp, |_| true, |_, _| true).unwrap();
            let (pm, pb) = (alone(g.len(), Box::new(m)), alone(g.len(), Box::new(b)));
            check(&pm, &x, None, None, Operator::Exact).assert_below(&format!("membrane {kind:?} {name}"), TOL);
            check(&pb, &x, None, None, Operator::Exact).assert_below(&format!("bending {kind:?} {name}"), TOL);
            for (p, what) in [(&pm, "membrane"), (&pb, "bending")] {
                for op in [Operator::Projected, Operator::Reflected] {
                    let (dense, _) = hessians(p, &x, None, None, op);
                    let (lo, hi) = eigen_range(&dense);
                    assert!(lo > -1e-10 * hi, "{what} {kind:?} {name}: {op:?} has eigenvalue {lo:e} ({hi:e})");
                }
            }
        }
        let m = NonlinearMembrane::new(&gc, &restc, &l, Warp::default()).unwrap();
        let b = NonlinearBending::new(&gc, &restc, &l, Warp::default(), |_| true, |_, _| true).unwrap();
        check(&alone(gc.len(), Box::new(m)), &xc, None, None, Operator::Exact).assert_below("membrane cylinder", TOL);
        check(&alone(gc.len(), Box::new(b)), &xc, None, None, Operator::Exact).assert_below("bending cylinder", TOL);
    }
}

/// A model of `fabric` with `laws` applied (or linear), on `grid`, warp at `angle`.
fn model(fabric: Fabric, laws: Option<Laws>, grid: Grid, angle: f64) -> ModelBuilder {
    let mut f = fabric;
    if let Some(l) = &laws {
        l.apply(&mut f).unwrap();
    }
    let s = Stiffness::calibrate(&f, Calibration::Kes).unwrap();
    let rest = grid.flat_positions(0.0);
    let opts = ElasticOptions { warp_angle: angle, ..Default::default() };
    let mut b = ModelBuilder::new(grid, rest, f, s, ModelKind::Tfs, Vec3::ZERO).options(opts);
    b.laws = laws.map(Arc::new);
    b
}

/// Straight lines through several points (the paper cotton's constants as curves) give the linear material's
/// energy and force to round-off, on an aligned and on a rotated frame.
#[test]
fn straight_line_laws_are_the_linear_material() {
    let f = Fabric::paper_cotton();
    let line = |k: f64| {
        Some(Curve::new(&[(0.01, 0.01 * k), (0.05, 0.05 * k), (0.2, 0.2 * k)], Interpolation::Linear).unwrap())
    };
    let l = Laws {
        tensile_warp: line(f.tensile_warp),
        tensile_weft: line(f.tensile_weft),
        shear: line(f.shear),
        bending_warp: line(f.bending_warp),
        bending_weft: line(f.bending_weft),
        hysteresis: [0.0; 3],
    };
    let g = Grid::sheet(6, 5, 0.2, 0.15).unwrap();
    let x = perturbed(&g.flat_positions(0.0), 0.01, 21);
    for angle in [0.0, 0.5] {
        let (lin, nl) =
            (model(f, None, g, angle).build().unwrap(), model(f, Some(l.clone()), g, angle).build().unwrap());
        let (mut ga, mut gb) = (vec![Vec3::ZERO; g.len()], vec![Vec3::ZERO; g.len()]);
        let (ea, eb) = (lin.elastic(&x, Some(&mut ga)), nl.elastic(&x, Some(&mut gb)));
        let (ta, tb) = (ea.membrane + ea.bending, eb.membrane + eb.bending);
        assert!((ta - tb).abs() < 1e-12 * ta, "angle {angle}: energy {ta} vs {tb}");
        let scale = ga.iter().map(|v| v.length()).fold(0.0, f64::max);
        let err = ga.iter().zip(&gb).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        assert!(err < 1e-12 * scale, "angle {angle}: force differs by {err:e} of {scale:e}");
    }
}

/// The strip of the KES tension test under a nominal force per width `t`: its engineering strain between two
/// middle columns.
fn strip_strain(b: ModelBuilder, grid: Grid, t: f64) -> f64 {
    let (m, n) = (grid.count(0), grid.count(1));
    let mut b = b;
    for k in 0..grid.len() {
        let (i, j) = grid.coords(k);
        b.pinned[k] = i <= 1;
        if i == m - 1 {
            b.loads[k] = Vec3::new(t * grid.h2 * grid.trapezoid(1, j), 0.0, 0.0);
        }
    }
    let model = b.build().unwrap();
    let mut x = grid.flat_positions(0.0);
    let opts = StaticOptions { tolerance: 1e-11, max_iterations: 200 };
    StaticSolver::new(&model).unwrap().solve(&model, &mut x, &opts).unwrap();
    let (a, c) = (m / 2 - 4, m / 2 + 4);
    (0..n).map(|j| x[grid.index(c, j)].x - x[grid.index(a, j)].x).sum::<f64>() / n as f64 / ((c - a) as f64 * grid.h1)
        - 1.0
}

/// Uniaxial tension: the strip reaches the strain the curve gives for the applied force, `T = S(E)(1 + ε)`
/// with `E = ε + ε²/2` and `S` interpolated by hand between the curve's points, to 1e-6.
#[test]
fn strip_in_tension_reaches_the_curves_strain() {
    let pts = [(0.01, 100.0), (0.03, 250.0), (0.1, 2000.0)];
    let l = Laws { tensile_warp: Some(Curve::new(&pts, Interpolation::Linear).unwrap()), ..Laws::default() };
    let g = Grid::sheet(41, 5, 0.4, 0.04).unwrap();
    for eps in [0.005, 0.045] {
        let e = eps + 0.5 * eps * eps;
        let s = if e < 0.01 { 100.0 * e / 0.01 } else { 250.0 + (2000.0 - 250.0) * (e - 0.03) / 0.07 };
        let t = s * (1.0 + eps);
        let got = strip_strain(model(Fabric::paper_cotton(), Some(l.clone()), g, 0.0), g, t);
        assert!((got / eps - 1.0).abs() < 1e-6, "strain {got} for {eps} at {t} N/m");
    }
}

/// A pure moment bends a strip to the curvature its bending curve gives (to the dead-load couple's 1e-3).
#[test]
fn pure_moment_gives_the_curves_curvature() {
    let pts = [(0.04, 2e-6), (0.08, 3e-6), (0.3, 2e-5)];
    let l = Laws { bending_warp: Some(Curve::new(&pts, Interpolation::Linear).unwrap()), ..Laws::default() };
    // κ = 0.1 lies between 0.08 and 0.3: M = 3e-6 + (2e-5 − 3e-6)(0.1 − 0.08)/0.22.
    let (kappa, moment) = (0.1, 3e-6 + 1.7e-5 * 0.02 / 0.22);
    let (len, width, m, n) = (0.2, 0.02, 41, 3);
    let grid = Grid::sheet(m, n, len, width).unwrap();
    let mut b = model(Fabric::paper_cotton(), Some(l), grid, 0.0);
    let force = moment * width / grid.h1 / (n as f64 - 1.0);
    for k in 0..grid.len() {
        let (i, j) = grid.coords(k);
        b.pinned[k] = i <= 1;
        let w = grid.trapezoid(1, j);
        if i == m - 1 {
            b.loads[k] = Vec3::new(0.0, 0.0, force * w);
        } else if i == m - 2 {
            b.loads[k] = Vec3::new(0.0, 0.0, -force * w);
        }
    }
    let model = b.build().unwrap();
    let mut x = grid.flat_positions(0.0);
    StaticSolver::new(&model)
        .unwrap()
        .solve(&model, &mut x, &StaticOptions { tolerance: 1e-10, max_iterations: 100 })
        .unwrap();
    // Curvature from the second difference of the centre line's height over the middle third.
    let mid: Vec<f64> = (m / 3..2 * m / 3)
        .map(|i| {
            (x[grid.index(i + 1, 1)].z - 2.0 * x[grid.index(i, 1)].z + x[grid.index(i - 1, 1)].z) / (grid.h1 * grid.h1)
        })
        .collect();
    let got = mid.iter().sum::<f64>() / mid.len() as f64;
    assert!((got / kappa - 1.0).abs() < 1e-3, "curvature {got} for {kappa}");
}

const SI: &str = r#"
units = "si"
density = 0.25
tensile_warp = 9800.0
shear = 123.0
bending_warp = 7e-6
[curves.tensile_weft]
points = [[0.01, 50.0], [0.03, 200.0], [0.06, 900.0]]
[curves.bending_weft]
points = [[10.0, 5e-5], [50.0, 1.5e-4], [200.0, 1e-3]]
interpolation = "monotone-cubic"
"#;

/// The same material in KES units: weight mg/cm², tensile gf/cm, strain %, shear gf/(cm·deg), curvature 1/cm,
/// moment gf·cm/cm (the SI values divided by the conversion factors).
fn kes_text() -> String {
    let gfcm = 0.980665; // N/m per gf/cm
    let gf = 9.80665e-3; // N per gf·cm/cm
    format!(
        "units = \"kes\"\ndensity = 2.5\ntensile_warp = {}\nshear = {}\nbending_warp = {}\n\
         [curves.tensile_weft]\npoints = [[1.0, {}], [3.0, {}], [6.0, {}]]\n\
         [curves.bending_weft]\npoints = [[0.1, {}], [0.5, {}], [2.0, {}]]\ninterpolation = \"monotone-cubic\"\n",
        9800.0 / gfcm,
        123.0 / (gfcm * 180.0 / std::f64::consts::PI),
        7e-6 / 9.80665e-5,
        50.0 / gfcm,
        200.0 / gfcm,
        900.0 / gfcm,
        5e-5 / gf,
        1.5e-4 / gf,
        1e-3 / gf
    )
}

/// SI and KES files give the same laws (to 1e-12) and the same strip strain; the file's tension points are
/// measured ones (engineering strain, nominal force), so a load at a point's force gives its strain.
#[test]
fn si_and_kes_units_give_the_same_fabric() {
    let a = material_from_toml(SI, Path::new("si.toml")).unwrap();
    let b = material_from_toml(&kes_text(), Path::new("kes.toml")).unwrap();
    for (ca, cb) in [(&a.laws.tensile_weft, &b.laws.tensile_weft), (&a.laws.bending_weft, &b.laws.bending_weft)] {
        let (ca, cb) = (ca.as_ref().unwrap(), cb.as_ref().unwrap());
        for (p, q) in ca.points().iter().zip(cb.points()) {
            assert!((p.0 / q.0 - 1.0).abs() < 1e-12 && (p.1 / q.1 - 1.0).abs() < 1e-12, "{p:?} vs {q:?}");
        }
    }
    assert!((a.fabric.tensile_weft / b.fabric.tensile_weft - 1.0).abs() < 1e-12);
    let g = Grid::sheet(41, 5, 0.4, 0.04).unwrap();
    let run = |m: &flexsurf::scene::material::ResolvedMaterial| {
        let s = Stiffness::calibrate(&m.fabric, Calibration::Kes).unwrap();
        let mut bld = ModelBuilder::new(g, g.flat_positions(0.0), m.fabric, s, ModelKind::Tfs, Vec3::ZERO)
            .options(ElasticOptions { warp_angle: std::f64::consts::FRAC_PI_2, ..Default::default() });
        bld.laws = Some(Arc::new(m.laws.clone()));
        strip_strain(bld, g, 200.0)
    };
    let (ea, eb) = (run(&a), run(&b));
    assert!((ea / 0.03 - 1.0).abs() < 1e-6 && (eb / ea - 1.0).abs() < 1e-9, "SI {ea}, KES {eb}, point 0.03");
}

/// The virtual KES tests read every point of every curve back: tension and shear to 1e-6; bending within 2 %
/// (the model's own departure at KES curvatures, `O(Dκ²/A)`: below 1 % up to 1.5 cm⁻¹), on the shipped
/// nonlinear example.
#[test]
fn kes_round_trip_of_the_curves() {
    let path = flexsurf::testing::repo().join("materials/woven-nonlinear-kes.toml");
    let m = flexsurf::scene::material::load_material_file(&path).unwrap();
    let report = kes_curves(&m.fabric, &m.laws).unwrap();
    assert_eq!(report.tests.len(), 5);
    for t in &report.tests {
        for p in &t.points {
            let tol = match t.law {
                "tensile_warp" | "tensile_weft" | "shear" => 1e-6,
                _ if p.strain_input <= 150.0 => 1e-2,
                _ => 2e-2,
            };
            assert!(p.relative_error.abs() < tol, "{}: {p:?}", t.law);
        }
    }
}

/// Bad curves are errors naming the file, the key and what is wrong.
#[test]
fn bad_curves_name_file_key_and_fault() {
    let base = "density = 0.2\ntensile_warp = 1e4\ntensile_weft = 1e4\nshear = 50.0\nbending_warp = 1e-5\nbending_weft = 1e-5\n";
    let cases = [
        ("[curves.shear]\npoints = [[0.1, 2.0]]\n", "curves.shear.points", "at least two"),
        ("[curves.bending_weft]\npoints = [[2.0, 1e-4], [1.0, 2e-4]]\n", "curves.bending_weft.points", "not monotone"),
        (
            "[curves.bending_warp]\npoints = [[1.0, 2e-4], [2.0, 1e-4]]\n",
            "curves.bending_warp.points",
            "negative or zero stiffness",
        ),
        ("[curves.tensile_warp]\npoints = [[0.0, 1e-5], [2.0, 1e-4]]\n", "curves.tensile_warp.points", "origin"),
    ];
    for (extra, key, what) in cases {
        let text = base
            .replace(
                "tensile_warp = 1e4\n",
                if key.ends_with("tensile_warp.points") { "" } else { "tensile_warp = 1e4\n" },
            )
            .replace("shear = 50.0\n", if key.contains("shear") { "" } else { "shear = 50.0\n" })
            .replace("bending_warp = 1e-5\n", if key.contains("bending_warp") { "" } else { "bending_warp = 1e-5\n" })
            .replace("bending_weft = 1e-5\n", if key.contains("bending_weft") { "" } else { "bending_weft = 1e-5\n" });
        let e = material_from_toml(&format!("{text}{extra}"), Path::new("bad.toml")).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains(key) && e.contains(what), "{key}: {e}");
    }
    let both = format!("{base}[curves.shear]\npoints = [[0.1, 2.0], [0.2, 3.0]]\n");
    let e = material_from_toml(&both, Path::new("both.toml")).unwrap_err().to_string();
    assert!(e.contains("both.toml") && e.contains("curves.shear.points") && e.contains("not both"), "{e}");
    let poisson = format!(
        "{}poisson = 0.2\n[curves.tensile_warp]\npoints = [[0.1, 2.0], [0.2, 3.0]]\n",
        base.replace("tensile_warp = 1e4\n", "")
    );
    let e = material_from_toml(&poisson, Path::new("p.toml")).unwrap_err().to_string();
    assert!(e.contains("p.toml") && e.contains("poisson") && e.contains("tensile curve"), "{e}");
}

/// The hysteresis terms (bending 2HB, shear 2HG) pass the checker, away from and within their smoothing.
#[test]
fn hysteresis_terms_pass_the_checker() {
    let g = Grid::sheet(5, 4, 0.2, 0.15).unwrap();
    let rest = g.flat_positions(0.0);
    let reference = perturbed(&rest, 0.01, 31);
    let x = perturbed(&rest, 0.02, 32);
    for eps in [1e-3, 10.0] {
        for warp in [Warp::Angle(0.0), Warp::Angle(0.6)] {
            let b = NonlinearBending::hysteresis(&g, &rest, [2e-4, 1e-4], eps, warp, &reference).unwrap();
            check(&alone(g.len(), Box::new(b)), &x, None, None, Operator::Exact)
                .assert_below("bending hysteresis", TOL);
            let m = NonlinearMembrane::shear_hysteresis(&g, &rest, 0.5, eps * 1e-3, warp, &reference).unwrap();
            check(&alone(g.len(), Box::new(m)), &x, None, None, Operator::Exact).assert_below("shear hysteresis", TOL);
        }
    }
}

/// A KES bending cycle to ±2.5 cm⁻¹ with 2HB = 0.02 gf·cm/cm on the nonlinear example: the loop is 2HB wide at
/// ±0.5 cm⁻¹ (within 2 %) and the hysteretic moment's loop area is 2HB times the curvature range (2·2.5 cm⁻¹),
/// within 3 %.
#[test]
fn bending_hysteresis_loop_has_width_2hb() {
    let path = flexsurf::testing::repo().join("materials/woven-nonlinear-kes.toml");
    let m = flexsurf::scene::material::load_material_file(&path).unwrap();
    let hb2 = 0.02 * 9.80665e-3; // 2HB in N (0.02 gf·cm/cm, as the file gives it)
    assert!((m.laws.hysteresis[0] / hb2 - 1.0).abs() < 1e-12, "the file's 2HB warp");
    let (kmax, steps) = (250.0, 5);
    let cycle = flexsurf::lab::kes::bending_loop(&m.fabric, &m.laws, 0.5 * hb2, false, kmax, steps).unwrap();
    let at = |from: usize, k: f64| cycle[from..].iter().find(|p| (p.0 - k).abs() < 1e-9).unwrap().1;
    // Unloading passes +0.5 cm⁻¹ (50 1/m) on its way down, reloading on its way up.
    let (down, up) = (at(steps - 1, 50.0), at(3 * steps - 1, 50.0));
    assert!(((up - down) / hb2 - 1.0).abs() < 0.02, "loop width {} against 2HB {hb2}", up - down);
    let (down, up) = (at(steps - 1, -50.0), at(3 * steps - 1, -50.0));
    assert!(((up - down) / hb2 - 1.0).abs() < 0.02, "loop width at −0.5 cm⁻¹: {}", up - down);
    // The hysteretic term's loop: the moment less the input law, by the end-value rule (exact for the
    // piecewise-constant ±HB once sliding; the model's own bending departure cancels between the branches to
    // (err(κmax) − err(−κmax))·Δκ).
    let law = m.laws.bending_warp.as_ref().unwrap();
    let area: f64 = cycle[steps - 1..].windows(2).map(|w| (w[1].1 - law.resultant(w[1].0)) * (w[1].0 - w[0].0)).sum();
    assert!((area / (hb2 * 2.0 * kmax) - 1.0).abs() < 0.03, "loop area {area} against {}", hb2 * 2.0 * kmax);
}

/// The made-up ARCSim material of the tests' data (its own numbers; ARCSim's format).
fn arcsim_data() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/arcsim-made-up.json")
}

/// An ARCSim measured-material file becomes five laws in SI (docs/materials.md, "ARCSim material files"): the
/// resultant ARCSim's force gives at the table's own samples (principal stretch 1 + 1/6, curvature 5j 1/m) within
/// 1e-9, the zero-strain stiffness in compression, the last sample's beyond the table, and between the samples
/// ARCSim's interpolation to 1e-3.
#[test]
fn arcsim_file_gives_the_tables_laws() {
    let m = flexsurf::scene::arcsim::load_arcsim(&arcsim_data()).unwrap();
    assert_eq!(m.density, 0.15);
    let l = &m.laws;
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    // Tension: Green strain at λ = 7/6 is 13/72; ARCSim's S = 2 k E (k doubled in dde.cpp).
    let e1 = 13.0 / 72.0;
    let (warp, weft, shear) =
        (l.tensile_warp.as_ref().unwrap(), l.tensile_weft.as_ref().unwrap(), l.shear.as_ref().unwrap());
    assert!(rel(warp.resultant(e1), 2.0 * 300.0 * e1) < 1e-9, "warp at the sample: {}", warp.resultant(e1));
    assert!(rel(weft.resultant(e1), 2.0 * 200.0 * e1) < 1e-9);
    // As a nominal tension at the sample's engineering strain 1/6: T = (1 + ε) S.
    assert!(rel((7.0 / 6.0) * warp.resultant(e1), 7.0 / 6.0 * 600.0 * e1) < 1e-9);
    assert!(rel(warp.resultant(-0.15), -200.0 * 0.15) < 1e-9, "compression: the zero-strain stiffness");
    assert!(rel(warp.resultant(0.4), 600.0 * 0.4) < 1e-9, "beyond the table: the last sample's stiffness");
    // Between samples: ARCSim's k(s) linear in s = 6(√(1 + 2E) − 1).
    for e in [0.004f64, 0.013, 0.05, 0.11, 0.17] {
        let s = 6.0 * ((1.0 + 2.0 * e).sqrt() - 1.0);
        let arcsim = 2.0 * ((1.0 - s) * 100.0 + s * 300.0) * e;
        assert!(rel(warp.resultant(e), arcsim) < 1e-3, "warp at {e}: {} vs {arcsim}", warp.resultant(e));
    }
    // A sweep over the table's range and beyond: the largest departure from ARCSim's force is 6.2e-4 (next to the kink at s = 1).
    let worst = (1..400).map(|i| 1e-3 * i as f64).fold(0.0f64, |w, e| {
        let s = (6.0 * ((1.0 + 2.0 * e).sqrt() - 1.0)).min(1.0);
        w.max(rel(warp.resultant(e), 2.0 * ((1.0 - s) * 100.0 + s * 300.0) * e))
    });
    assert!(worst < 1e-3, "warp tension departs from ARCSim's by {worst:e}");
    // Shear: λ₁ = √(1 + γ) = 7/6 at γ = 13/36; ∂ψ/∂γ = k3 γ/4 with k3 = 2·40 (the 45° row).
    let g1 = 13.0 / 36.0;
    assert!(rel(shear.resultant(g1), 0.25 * 80.0 * g1) < 1e-9 && rel(shear.resultant(-g1), -20.0 * g1) < 1e-9);
    // Bending: M = k(κ) κ; warp from the 90° edge row, weft from the 0° edge row.
    let (bw, bf) = (l.bending_warp.as_ref().unwrap(), l.bending_weft.as_ref().unwrap());
    for (j, (kw, kf)) in [20e-6, 18e-6, 20e-6, 24e-6, 30e-6].iter().zip([10e-6, 12e-6, 14e-6, 16e-6, 18e-6]).enumerate()
    {
        let kappa = 5.0 * j as f64;
        if j > 0 {
            assert!(rel(bw.resultant(kappa), kw * kappa) < 1e-9, "warp bending at {kappa}");
            assert!(rel(bf.resultant(-kappa), -kf * kappa) < 1e-9, "weft bending at −{kappa}");
        }
    }
    assert!(rel(bw.resultant(33.0), 30e-6 * 33.0) < 1e-9 && rel(bw.initial_slope(), 20e-6) < 1e-3);
    for kappa in [1.0, 2.6, 7.5, 13.3, 18.0] {
        let k = if kappa < 5.0 {
            20e-6 - 0.4e-6 * kappa
        } else if kappa < 10.0 {
            18e-6 + 0.4e-6 * (kappa - 5.0)
        } else if kappa < 15.0 {
            20e-6 + 0.8e-6 * (kappa - 10.0)
        } else {
            24e-6 + 1.2e-6 * (kappa - 15.0)
        };
        assert!(
            rel(bw.resultant(kappa), k * kappa) < 1e-3,
            "warp bending at {kappa}: {} vs {}",
            bw.resultant(kappa),
            k * kappa
        );
    }
    // Through a material file and a scene's table: the density and the laws' smallest slopes as constants.
    let r = material_from_toml("arcsim = \"arcsim-made-up.json\"\ndamping = 0.01\n", &arcsim_data()).unwrap();
    assert_eq!((r.fabric.density, r.fabric.damping, r.name.as_str()), (0.15, 0.01, "arcsim-made-up"));
    assert_eq!(r.laws, m.laws);
    assert!(rel(r.fabric.tensile_warp, 200.0) < 1e-9 && r.fabric.shear == shear.min_slope());
    // A constant given beside `arcsim` replaces that direction's law.
    let r = material_from_toml("arcsim = \"arcsim-made-up.json\"\nshear = 3.0\n", &arcsim_data()).unwrap();
    assert!(r.laws.shear.is_none() && r.fabric.shear == 3.0 && r.laws.tensile_warp.is_some());
}

/// ARCSim files that cannot be used: each error names the file and the key (`stretching[2]`, `bending[1][3]`)
/// and what is wrong; a scene's table names its own key (`arcsim`) around it.
#[test]
fn arcsim_errors_name_file_and_key() {
    use flexsurf::scene::arcsim::arcsim_from_json;
    let f = Path::new("m.json");
    let ok_s = "[[100,10,50,20],[300,10,80,25],[250,10,90,30],[200,10,100,40],[150,10,150,30],[120,10,200,25]]";
    let ok_b = "[[1e-5,1.2e-5,1.4e-5,1.6e-5,1.8e-5],[1e-5,1e-5,1e-5,1e-5,1e-5],[2e-5,2e-5,2e-5,2e-5,2e-5]]";
    let text = |d: &str, s: &str, b: &str| format!("{{\"density\": {d}, \"stretching\": {s}, \"bending\": {b}}}");
    let err = |t: String| arcsim_from_json(&t, f).unwrap_err().to_string();
    assert!(arcsim_from_json(&text("0.1", ok_s, ok_b), f).is_ok());
    let cases = [
        (text("-1", ok_s, ok_b), "`density`", "accepted range"),
        ("{\"density\": 0.1, \"bending\": []}".to_string(), "`stretching`", "missing: must be 6 rows of 4 numbers"),
        (text("0.1", "[[1,2,3,4]]", ok_b), "`stretching`", "must be 6 rows"),
        (text("0.1", ok_s, &ok_b.replacen("1.4e-5", "\"x\"", 1)), "`bending[0][2]`", "finite number"),
        (
            text("0.1", ok_s, &ok_b.replacen(",1e-5,1e-5,1e-5,1e-5]", ",1e-5,1e-5,1e-5]", 1)),
            "`bending[1]`",
            "5 numbers",
        ),
        (text("0.1", &ok_s.replacen("[100,", "[-100,", 1), ok_b), "`stretching[0][0]`", "must be positive"),
        (text("0.1", ok_s, &ok_b.replacen("1.6e-5,1.8e-5", "1.6e-5,0.2e-5", 1)), "`bending[0]`", "falls between"),
        ("{\"density\": 0.1,, }".to_string(), "m.json:1:", "not an ARCSim material"),
    ];
    for (t, key, what) in cases {
        let e = err(t);
        assert!(e.contains("m.json") && e.contains(key) && e.contains(what), "{e}");
    }
    // Comments as ARCSim's reader allows them.
    assert!(arcsim_from_json(&format!("// c\n/* d */{}", text("0.1", ok_s, ok_b)), f).is_ok());
    // Through a table: the referencing key, then the ARCSim file and its key.
    let dir = std::env::temp_dir().join(format!("flexsurf-arcsim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bad.json"), text("0.1", &ok_s.replacen("[100,", "[-100,", 1), ok_b)).unwrap();
    let scene = dir.join("s.toml");
    let e = material_from_toml("arcsim = \"bad.json\"\n", &scene).unwrap_err().to_string();
    assert!(e.contains("`arcsim`") && e.contains("bad.json") && e.contains("`stretching[0][0]`"), "{e}");
    let e = material_from_toml("arcsim = \"none.json\"\n", &scene).unwrap_err().to_string();
    assert!(e.contains("`arcsim`") && e.contains("none.json") && e.contains("cannot read"), "{e}");
    let e = material_from_toml("preset = \"paper-cotton\"\narcsim = \"bad.json\"\n", &scene).unwrap_err().to_string();
    assert!(e.contains("give only one of"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The laws of an ARCSim file (cubic Hermite with ARCSim's own stiffness at the knots) through the shared
/// finite-difference checker, strained past the table's kinks.
#[test]
fn arcsim_laws_pass_the_checker() {
    let l = flexsurf::scene::arcsim::load_arcsim(&arcsim_data()).unwrap().laws;
    let g = Grid::sheet(5, 4, 0.2, 0.15).unwrap();
    let rest = g.flat_positions(0.0);
    for (amp, seed) in [(0.01, 21), (0.05, 22)] {
        let x = perturbed(&rest, amp, seed);
        let m = NonlinearMembrane::new(&g, &rest, &l, Warp::Angle(0.3)).unwrap();
        let b = NonlinearBending::new(&g, &rest, &l, Warp::Angle(0.3), |_| true, |_, _| true).unwrap();
        check(&alone(g.len(), Box::new(m)), &x, None, None, Operator::Exact).assert_below("arcsim membrane", TOL);
        check(&alone(g.len(), Box::new(b)), &x, None, None, Operator::Exact).assert_below("arcsim bending", TOL);
    }
}

/// A KES shear cycle to ±8° with 2HG = 1 gf/cm on the nonlinear example: the loop is 2HG wide at ±4° (within
/// 2 %) and the hysteretic force's loop area in `(γ, N)` is 2HG times the shear range (2 sin 8°), within 3 %.
#[test]
fn shear_hysteresis_loop_has_width_2hg() {
    let path = flexsurf::testing::repo().join("materials/woven-nonlinear-kes.toml");
    let m = flexsurf::scene::material::load_material_file(&path).unwrap();
    let hg2 = 0.980665; // 2HG in N/m (1 gf/cm, as the file gives it)
    assert!((m.laws.hysteresis[2] / hg2 - 1.0).abs() < 1e-12, "the file's 2HG");
    let (phi_max, steps) = (8f64.to_radians(), 4);
    let cycle = flexsurf::lab::kes::shear_loop(&m.fabric, &m.laws, 0.5 * hg2, phi_max, steps).unwrap();
    let at = |from: usize, p: f64| cycle[from..].iter().find(|q| (q.0 - p).abs() < 1e-12).unwrap().1;
    let half = 0.5 * phi_max;
    for p in [half, -half] {
        let (down, up) = (at(steps - 1, p), at(3 * steps - 1, p));
        assert!(
            ((up - down) / hg2 - 1.0).abs() < 0.02,
            "loop width at {:.1}°: {} against 2HG {hg2}",
            p.to_degrees(),
            up - down
        );
    }
    let law = m.laws.shear.as_ref().unwrap();
    let area: f64 = cycle[steps - 1..]
        .windows(2)
        .map(|w| (w[1].1 - law.resultant(w[1].0.sin())) * (w[1].0.sin() - w[0].0.sin()))
        .sum();
    let expected = hg2 * 2.0 * phi_max.sin();
    assert!((area / expected - 1.0).abs() < 0.03, "loop area {area} against {expected}");
}

/// The hysteresis terms of a dynamic run (2HB, 2HG lagged at the step's start, docs/model.md §4.6) through the
/// shared checker, with a step's motion whose start differs from the evaluation point; nothing in a static solve.
#[test]
fn hysteresis_in_a_step_passes_the_checker() {
    use flexsurf::potential::elastic::{BendingHysteresis, ShearHysteresis};
    use flexsurf::potential::Motion;
    let g = Grid::sheet(5, 4, 0.2, 0.15).unwrap();
    let rest = g.flat_positions(0.0);
    let start = perturbed(&rest, 0.02, 31);
    let y = perturbed(&rest, 0.02, 32);
    let zero = vec![Vec3::ZERO; rest.len()];
    let ones = vec![1e-3; rest.len()];
    let motion = Motion {
        x: &start,
        x_prev: &start,
        v: &zero,
        v_prev: &zero,
        target: &start,
        damp_center: &start,
        inertia: 1e4,
        damp: 0.0,
        dt: 0.01,
        mass: &ones,
        damping: &ones,
        predict: false,
        exact: false,
    };
    let b = NonlinearBending::hysteresis(&g, &rest, [2e-4, 1e-4], 1.0, Warp::Angle(0.3), &rest).unwrap();
    let m = NonlinearMembrane::shear_hysteresis(&g, &rest, 0.5, 1.0, Warp::Angle(0.3), &rest).unwrap();
    let pb = alone(g.len(), Box::new(BendingHysteresis(b)));
    let pm = alone(g.len(), Box::new(ShearHysteresis(m)));
    check(&pb, &y, Some(motion), None, Operator::Exact).assert_below("bending hysteresis in a step", TOL);
    check(&pm, &y, Some(motion), None, Operator::Exact).assert_below("shear hysteresis in a step", TOL);
}

/// A run of a hysteretic fabric (the nonlinear example with its 2HB and 2HG): the terms act (the run differs from
/// the same fabric without `[hysteresis]`), and stopped at a step and resumed it gives byte-identical outputs: the
/// lagged state is the step's start, which the checkpoint holds.
#[test]
fn hysteresis_run_resumes_byte_identically() {
    use flexsurf::runner::{run_scene_with, RunOptions};
    use flexsurf::scene::SceneSpec;
    use std::sync::atomic::{AtomicBool, Ordering};
    let d = flexsurf::testing::scratch("nonlinear", "hysteresis-resume");
    let material = flexsurf::testing::repo().join("materials/woven-nonlinear-kes.toml");
    let text = |extra: &str| {
        format!(
            "name = \"hysteresis\"\ncalibration = \"kes\"\ngravity = [0.0, 0.0, -9.81]\n[sheet]\nsize = [0.1, 0.1]\n\
             nodes = [7, 7]\ncenter = [0.0, 0.0, 0.2]\n[material]\nfile = {:?}\n{extra}\n[time]\ndt = 0.01\n\
             steps = 16\noutput_every = 4\n[[pin]]\nnodes = [[0, 0], [0, 6]]\n[output]\nimage_size = [96, 72]\n",
            material.to_str().unwrap()
        )
    };
    let scene = |name: &str, extra: &str| {
        let path = d.join(name);
        std::fs::write(&path, text(extra)).unwrap();
        SceneSpec::load(&path).unwrap().build(&path).unwrap()
    };
    let s = scene("h.toml", "");
    let reference = d.join("reference");
    let o = run_scene_with(&s, &reference, &RunOptions::default(), |_| {}).unwrap();
    let none = scene("n.toml", "[material.hysteresis]\nbending_warp = 0.0\nbending_weft = 0.0\nshear = 0.0\n");
    let o2 = run_scene_with(&none, &d.join("none"), &RunOptions::default(), |_| {}).unwrap();
    let (a, b) = (o.summary.final_state.bending_energy, o2.summary.final_state.bending_energy);
    assert!(a != b, "the hysteresis acts: bending energy {a} with, {b} without");
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let flag = std::sync::Arc::clone(&stop);
    let dir = d.join("stopped");
    let options = RunOptions { stop: Some(stop), ..Default::default() };
    run_scene_with(&s, &dir, &options, |st| flag.store(st.step >= 7, Ordering::SeqCst)).unwrap();
    let o = run_scene_with(&s, &dir, &RunOptions { resume: true, ..Default::default() }, |_| {}).unwrap();
    assert_eq!(o.summary.provenance.resumed_from_step, Some(7));
    flexsurf::testing::assert_same_outputs(&reference, &dir, "stopped at step 7");
    std::fs::remove_dir_all(&d).ok();
}

/// Regression: the virtual KES test of an ARCSim material with the file's own tension laws stopped with "static
/// solve did not converge within 21 Newton iterations: relative residual 2.842e-10" (the made-up file with its
/// stretching table ×100). The bending strip's static solve had reached round-off at a point taken tentatively
/// under a watchdog, which `Π` could no longer judge; the solver grew its shift until the budget ran out instead
/// of accepting the point. Now it comes back with the laws' points as the curve test reads them elsewhere:
/// tension and shear to 1e-9, bending within 5e-4 at these curvatures (the model's own κ² departure).
#[test]
fn regression_arcsim_kes_bending_stalled_under_a_watchdog() {
    let d = std::env::temp_dir().join(format!("flexsurf-arcsim-kes-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let json = std::fs::read_to_string(arcsim_data()).unwrap();
    // The stretching rows ×100: tensile stiffnesses of order 1e4 N/m, as a woven's.
    let scaled = json
        .replace("[100.0, 10.0, 50.0, 20.0]", "[1e4, 1e3, 5e3, 2e3]")
        .replace("[300.0, 10.0, 80.0, 25.0]", "[3e4, 1e3, 8e3, 2.5e3]")
        .replace("[250.0, 10.0, 90.0, 30.0]", "[2.5e4, 1e3, 9e3, 3e3]")
        .replace("[200.0, 10.0, 100.0, 40.0]", "[2e4, 1e3, 1e4, 4e3]")
        .replace("[150.0, 10.0, 150.0, 30.0]", "[1.5e4, 1e3, 1.5e4, 3e3]")
        .replace("[120.0, 10.0, 200.0, 25.0]", "[1.2e4, 1e3, 2e4, 2.5e3]");
    assert_ne!(scaled, json, "the data file changed: scale its table here");
    std::fs::write(d.join("made.json"), scaled).unwrap();
    std::fs::write(d.join("made.toml"), "arcsim = \"made.json\"\n").unwrap();
    let m = flexsurf::scene::material::load_material_file(&d.join("made.toml")).unwrap();
    let report = kes_curves(&m.fabric, &m.laws).unwrap();
    for t in &report.tests {
        let tol = if t.law.starts_with("bending") { 5e-4 } else { 1e-9 };
        for p in &t.points {
            assert!(p.relative_error.abs() < tol, "{}: {p:?}", t.law);
        }
    }
    std::fs::remove_dir_all(&d).ok();
}
