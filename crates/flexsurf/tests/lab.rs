//! Virtual KES round trip: the model gives the fabric's measured constants back (issue 3's goal: within 1% with
//! the default calibration), for an isotropic-like, a strongly anisotropic and a Poisson-coupled fabric; the
//! paper-literal calibration does not (bending 2×, shear ½).

use flexsurf::lab::kes::kes;
use flexsurf::material::{Calibration, Fabric};

#[test]
fn kes_round_trip_recovers_the_inputs() {
    let paper = Fabric::paper_cotton();
    let anisotropic = Fabric { tensile_weft: 800.0, bending_weft: 5e-6, shear: 20.0, ..paper };
    let coupled = Fabric { poisson: 0.3, ..paper };
    for (name, f) in [("paper cotton", paper), ("anisotropic", anisotropic), ("poisson 0.3", coupled)] {
        let r = kes(&f, Calibration::Kes).unwrap();
        eprintln!("{name}: {:?}", r.relative_error);
        assert!(r.worst() < 0.01, "{name}: worst relative error {:.3e}: {:?}", r.worst(), r.relative_error);
    }
    let r = kes(&paper, Calibration::Paper).unwrap();
    assert!((r.relative_error.bending_warp - 1.0).abs() < 0.02, "paper calibration bends 2x stiff: {r:?}");
    assert!((r.relative_error.shear + 0.5).abs() < 0.02, "paper calibration shears at half: {r:?}");
}

#[test]
fn every_shipped_material_loads_and_round_trips() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../materials");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let m = flexsurf::scene::material::load_material_file(&path).unwrap();
        let r = kes(&m.fabric, Calibration::Kes).unwrap();
        assert!(r.worst() < 0.01, "{}: {:?}", path.display(), r.relative_error);
        count += 1;
    }
    assert!(count >= 7, "expected the material library, found {count} files");
}

#[test]
fn cantilever_gives_back_the_bending_rigidity() {
    use flexsurf::lab::cantilever::{cantilever, elastica_chord_deg, Direction};
    let f = Fabric::paper_cotton();
    for d in [Direction::Warp, Direction::Weft] {
        let t = std::time::Instant::now();
        let r = cantilever(&f, Calibration::Kes, d, None).unwrap();
        eprintln!("{d:?}: {r:?} in {:.2} s", t.elapsed().as_secs_f64());
        // At the Peirce length (q = 8) the chord is 41.5° (the test computes the elastica itself).
        assert!((elastica_chord_deg(8.0) - 41.49).abs() < 0.01);
        assert!((r.chord_angle_deg - r.elastica_deg).abs() < 0.1, "{d:?}: {r:?}");
        assert!((r.chord_angle_fine_deg - 41.5).abs() < 1.0, "{d:?}: {r:?}");
        assert!((r.implied_rigidity / r.input_rigidity - 1.0).abs() < 0.02, "{d:?}: {r:?}");
    }
    // Another ratio: a 10 cm warp strip hangs at 26.4° (AUDIT §7.7).
    let r = cantilever(&f, Calibration::Kes, Direction::Warp, Some(0.10)).unwrap();
    assert!((r.chord_angle_deg - 26.4).abs() < 0.2, "{r:?}");
}

/// Cusick drape (issue 3): bounds, grid convergence between the two finest default grids, and the trends a
/// drape meter shows: the drape coefficient rises with bending stiffness and falls with specimen size.
#[test]
fn cusick_drape_coefficient_behaves() {
    use flexsurf::lab::cusick::{cusick, default_grid};
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../materials");
    let soft = flexsurf::scene::material::load_material_file(&dir.join("silk-like-polyester.toml")).unwrap().fabric;
    let dc = |f: &Fabric, d: f64, level: usize| {
        let (nr, na) = default_grid(d, level);
        let r = cusick(f, Calibration::Kes, d, nr, na).unwrap().report;
        eprintln!("D = {d}, level {level}: DC {:.2}%, {} nodes, {} steps", r.drape_coefficient, r.nodes, r.steps);
        assert!((0.0..=100.0).contains(&r.drape_coefficient), "{r:?}");
        r
    };
    let base = dc(&soft, 0.30, 1);
    assert!(base.nodes >= 4 && base.nodes <= 12, "a soft fabric forms folds: {base:?}");
    let fine = dc(&soft, 0.30, 2);
    assert!((fine.drape_coefficient - base.drape_coefficient).abs() < 2.0, "not grid-converged: {base:?} {fine:?}");
    let stiffer = Fabric { bending_warp: 4.0 * soft.bending_warp, bending_weft: 4.0 * soft.bending_weft, ..soft };
    assert!(dc(&stiffer, 0.30, 1).drape_coefficient > base.drape_coefficient + 2.0);
    // Shear stiffness: measured, not asserted. The drape meter's correlation (DC rising with G) is not seen here:
    // ×4 G gives 42.8 % (7 nodes) against 44.4 % (8 nodes) for this fabric; an open question (closing note).
    let shear = Fabric { shear: 4.0 * soft.shear, ..soft };
    let _ = dc(&shear, 0.30, 1);
    let (small, large) = (dc(&soft, 0.24, 1), dc(&soft, 0.36, 1));
    assert!(small.drape_coefficient > base.drape_coefficient && base.drape_coefficient > large.drape_coefficient);
}

/// FAST units: weight g/m², E100 %, EB5 %, bending length mm (B = 9.81e-6 W C³ µN·m), against hand values;
/// bending lengths without the weight are an error naming `density`.
#[test]
fn fast_units_material_file() {
    let dir = std::env::temp_dir().join(format!("flexsurf-fast-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("fast.toml");
    std::fs::write(
        &path,
        "units = \"fast\"\ndensity = 150.0\ntensile_warp = 2.0\ntensile_weft = 4.0\nshear = 1.5\n\
         bending_warp = 20.0\nbending_weft = 15.0\n",
    )
    .unwrap();
    let f = flexsurf::scene::material::load_material_file(&path).unwrap().fabric;
    assert!((f.density - 0.150).abs() < 1e-15);
    assert!((f.tensile_warp - 4903.325).abs() < 1e-9 && (f.tensile_weft - 2451.6625).abs() < 1e-9);
    assert!((f.shear - 82.0).abs() < 1e-12);
    // 9.81e-6 · 150 · 20³ = 11.772 µN·m; 9.81e-6 · 150 · 15³ = 4.9663 µN·m.
    assert!((f.bending_warp - 11.772e-6).abs() < 1e-12 && (f.bending_weft - 4.966_312_5e-6).abs() < 1e-12);
    // And the model gives them back.
    assert!(kes(&f, Calibration::Kes).unwrap().worst() < 0.01);
    std::fs::write(&path, "units = \"fast\"\ntensile_warp = 2.0\ntensile_weft = 4.0\nshear = 1.5\nbending_warp = 20.0\nbending_weft = 15.0\n")
        .unwrap();
    let e = flexsurf::scene::material::load_material_file(&path).unwrap_err().to_string();
    assert!(e.contains("fast.toml") && e.contains("density"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
