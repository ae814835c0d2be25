//! Garments from sewing patterns (issue 20): the Coons grid of a rectangle is the plain grid; node counts are
//! matched along seams; a flat pattern of two rectangles sewn along their common side steps as the one square
//! sheet; a pattern that cannot be sewn is a one-line error naming the panel and edge; the shipped straight
//! skirt sews closed on the mannequin; an outline read from DXF (pattern CAD) is the outline written out, its
//! arcs on their circles, and its errors name the key.

use flexsurf::garment::pattern::{BuiltPattern, Pattern, Placement};
use flexsurf::garment::sewing::{sew, sew_observed, SewingParams};
use flexsurf::grid::Grid;
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{Model, ModelBuilder, ModelKind};
use flexsurf::potential::self_contact::SelfContactParams;
use flexsurf::potential::sewing::Sewing;
use flexsurf::scene::PatternSpec;
use flexsurf::state::State;
use flexsurf::testing::{intersecting_triangles_joined, repo};
use std::path::Path;

const G: Vec3 = Vec3::new(0.0, 0.0, -9.81);

fn parse(text: &str) -> PatternSpec {
    PatternSpec::from_toml(text, Path::new("test.toml")).unwrap()
}

fn build(text: &str) -> BuiltPattern {
    parse(text).pattern().build().unwrap()
}

/// The error of building the pattern `text`, as one line.
fn failure(text: &str) -> String {
    let e = parse(text).pattern().build().unwrap_err().to_string();
    assert!(!e.contains('\n'), "not one line: {e}");
    e
}

/// A rectangle panel `name` from `(x0, y0)` to `(x1, y1)` with corners a, b, c, d counter-clockwise from the
/// lower left, placed flat, warp along x.
fn rectangle(name: &str, [x0, y0, x1, y1]: [f64; 4]) -> String {
    format!(
        r#"
[[panel]]
name = "{name}"
grain = [1.0, 0.0]
outline = [
  {{ at = [{x0}, {y0}], corner = "a" }},
  {{ at = [{x1}, {y0}], corner = "b" }},
  {{ at = [{x1}, {y1}], corner = "c" }},
  {{ at = [{x0}, {y1}], corner = "d" }},
]
placement = {{ flat = {{}} }}
"#
    )
}

fn seam(a: (&str, &str, &str), b: (&str, &str, &str)) -> String {
    format!(
        "[[seam]]\na = {{ panel = \"{}\", from = \"{}\", to = \"{}\" }}\nb = {{ panel = \"{}\", from = \"{}\", to = \"{}\" }}\n",
        a.0, a.1, a.2, b.0, b.1, b.2
    )
}

/// A rectangle of 0.6 × 0.4 m with an extra vertex on its bottom side and its top side drawn as a straight
/// Bézier: its Coons grid is the plain 13 × 9 grid of spacing 0.05 m (arc length is uniform on each side).
#[test]
fn coons_grid_of_a_rectangle_is_the_plain_grid() {
    let text = r#"
edge_length = 0.05
[[panel]]
name = "sheet"
grain = [1.0, 0.0]
outline = [
  { at = [0.1, 0.2], corner = "a" },
  { at = [0.35, 0.2] },
  { at = [0.7, 0.2], corner = "b" },
  { at = [0.7, 0.6], corner = "c" },
  { at = [0.1, 0.6], corner = "d", curve = [[0.5, 0.6], [0.3, 0.6]] },
]
placement = { flat = { offset = [0.0, 0.0, 1.0] } }
"#;
    let built = build(text);
    let p = &built.panels[0];
    assert_eq!((p.grid.m, p.grid.n), (13, 9));
    let mut worst: f64 = 0.0;
    for k in 0..p.grid.len() {
        let (i, j) = p.grid.coords(k);
        let expect = Vec3::new(0.1 + 0.05 * i as f64, 0.2 + 0.05 * j as f64, 0.0);
        worst = worst.max((p.flat[k] - expect).length());
        assert_eq!(p.placed[k], p.flat[k] + Vec3::Z);
    }
    // The Bézier's arc length is tabulated on 64 chords: exact for a straight one up to rounding.
    assert!(worst < 1e-12, "the Coons grid is {worst} m from the plain grid");
    let [lo, hi] = p.jacobian;
    assert!((lo - hi).abs() < 1e-12 * hi && (lo - 0.6 * 0.4 / 96.0).abs() < 1e-12, "Jacobian {lo}..{hi}");
    assert!(built.warnings.is_empty());
}

/// A trapezoid whose right side is 0.9 m long (19 nodes at 0.05 m) sewn by its left side (0.6 m) to a
/// rectangle's right side (0.6 m, 13 nodes on its own): both sewn sides get 19 nodes, and the rectangle's
/// opposite side too. Across, the rectangle's 0.3 m takes 7 nodes, the trapezoid's slanted bottom
/// (√(0.4² + 0.15²) = 0.427 m) 10.
#[test]
fn node_counts_match_along_seams() {
    let trapezoid = r#"
[[panel]]
name = "trapezoid"
grain = [0.0, 1.0]
outline = [
  { at = [0.0, 0.0], corner = "a" },
  { at = [0.4, -0.15], corner = "b" },
  { at = [0.4, 0.75], corner = "c" },
  { at = [0.0, 0.6], corner = "d" },
]
placement = { flat = { offset = [1.0, 0.0, 0.0] } }
"#;
    let text = format!(
        "edge_length = 0.05\n{}{trapezoid}{}",
        rectangle("rect", [-0.3, 0.0, 0.0, 0.6]),
        seam(("rect", "b", "c"), ("trapezoid", "a", "d"))
    );
    let built = build(&text);
    let (rect, trap) = (&built.panels[0].grid, &built.panels[1].grid);
    assert_eq!((rect.m, rect.n), (7, 19));
    assert_eq!((trap.m, trap.n), (10, 19));
    let s = built.seams[0];
    assert_eq!(s.a.edge.count(rect), s.b.edge.count(trap));
    // The sewn nodes sit at the same fractions of the two sides' lengths (both 0.6 m): the same points.
    let mut far: f64 = 0.0;
    for j in 0..19 {
        let p = built.panels[0].flat[rect.index(6, j)];
        let q = built.panels[1].flat[trap.index(0, j)];
        far = far.max((p - q).length());
    }
    assert!(far < 1e-12, "sewn nodes {far} m apart in the pattern");
    // The map is bilinear (straight sides): its Jacobian runs from the left side's 0.4 × 0.6 to the right
    // side's 0.4 × 0.9 per unit square, a ratio of 2/3 (per cell: divided by the same 9 × 18 cells).
    let [lo, hi] = built.panels[1].jacobian;
    assert!((lo / hi - 2.0 / 3.0).abs() < 1e-9, "trapezoid Jacobian ratio {}", lo / hi);
}

fn cotton() -> (Fabric, Stiffness) {
    let fabric = Fabric::paper_cotton();
    (fabric, Stiffness::calibrate(&fabric, Calibration::Kes).unwrap())
}

fn run(model: &Model, x: Vec<Vec3>, dt: f64, steps: usize) -> State {
    let v = vec![Vec3::ZERO; x.len()];
    let mut state = flexsurf::integrate::start(model, x, v, dt).unwrap();
    let mut stepper = Stepper::new(model, &StepParams::with_dt(dt)).unwrap();
    for _ in 0..steps {
        stepper.step(model, &mut state).unwrap();
    }
    state
}

/// The open model of a built pattern's panels (each on its flat rest shape, with its options) in cotton under
/// `G`, and the panels' placed positions in the model's order.
fn open_panels(built: &BuiltPattern) -> (ModelBuilder, Vec<Vec3>) {
    let (fabric, stiffness) = cotton();
    let [first, rest @ ..] = built.panels.as_slice() else { panic!("a pattern without panels") };
    let mut builder =
        ModelBuilder::new(first.grid, first.flat.clone(), fabric, stiffness, ModelKind::Tfs, G).options(first.options);
    for p in rest {
        builder = builder.panel(p.grid, p.flat.clone(), p.options);
    }
    (builder, built.panels.iter().flat_map(|p| p.placed.iter().copied()).collect())
}

/// Two 0.3 × 0.6 m rectangles placed flat `gap` apart along x, the left one's right side sewn to the right one's
/// left side, with `extra` (more panels' text) between the rectangles and the seam.
fn two_halves(gap: f64, extra: &str) -> String {
    format!(
        "edge_length = 0.05\n{}{}{extra}{}",
        rectangle("left", [-0.3, -0.3, 0.0, 0.3]),
        rectangle("right", [0.0, -0.3, 0.3, 0.3])
            .replace("flat = {}", &format!("flat = {{ offset = [{gap:?}, 0.0, 0.0] }}")),
        seam(("left", "b", "c"), ("right", "a", "d"))
    )
}

fn curved(p: Vec3) -> Vec3 {
    Vec3::new(p.x, p.y, 0.05 + 0.4 * p.x * p.x - 0.2 * p.x * p.y)
}

/// Two rectangles of 0.3 × 0.6 m placed flat side by side and sewn along their common side by the sewing
/// phase (the seam's gap is zero, so it takes no step) equal the 0.6 m square sheet of 13 × 13 nodes: 30 steps
/// from a curved start (bending across the seam) agree to 1e-10 m.
#[test]
fn flat_pattern_sewn_into_a_square_equals_the_sheet() {
    let built = build(&two_halves(0.0, ""));
    let (fabric, stiffness) = cotton();
    let grid = Grid::sheet(13, 13, 0.6, 0.6).unwrap();
    let whole =
        ModelBuilder::new(grid, grid.flat_positions(0.0), fabric, stiffness, ModelKind::Tfs, G).build().unwrap();
    let (l, r) = (&built.panels[0], &built.panels[1]);
    let (builder, placed) = open_panels(&built);
    let x0: Vec<Vec3> = placed.into_iter().map(curved).collect();
    let params = SewingParams { stiffness: 10.0, dt: 0.005, steps: 10, gap: 1e-9, closing: None };
    let sewn = sew(&builder, &built.seams, x0, &[], &params).unwrap();
    assert_eq!(sewn.report.steps, 0);
    assert!(sewn.report.largest_gap() < 1e-15, "gap {}", sewn.report.largest_gap());
    assert_eq!(sewn.model.nodes(), 169);
    let reference = run(&whole, grid.flat_positions(0.0).iter().map(|p| curved(*p)).collect(), 0.005, 30);
    let state = run(&sewn.model, sewn.x, 0.005, 30);
    let mut apart: f64 = 0.0;
    for k in 0..grid.len() {
        let (i, j) = grid.coords(k);
        let (panel, local) = if i < 7 { (0, l.grid.index(i, j)) } else { (1, r.grid.index(i - 6, j)) };
        let node = sewn.model.panels[panel].global(local);
        apart = apart.max((state.x[node] - reference.x[k]).length());
    }
    let moved =
        reference.x.iter().zip(grid.flat_positions(0.0)).map(|(p, q)| (*p - curved(q)).length()).fold(0.0, f64::max);
    eprintln!("sewn square vs sheet after 30 steps: {apart:e} m apart (moved {moved} m)");
    // The welded garment mesh (k = 2) is the square's display mesh: (2·12 + 1)² vertices, 2·2²·144 triangles,
    // the seam's 25 vertices merged, every vertex used; flat at the start, so its area is the square's.
    let mesh = flexsurf::runner::fields::welded_mesh(&sewn.model, &sewn.model.rest, 2);
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (625, 1152));
    assert!((mesh.area() - 0.36).abs() < 1e-12, "area {}", mesh.area());
    assert!(mesh.validate().is_ok());
    assert!(moved > 1e-3, "the sheet should move (moved {moved} m)");
    assert!(apart < 1e-10, "the sewn square is {apart} m from the sheet (moved {moved} m)");
}

#[test]
fn a_seam_of_edges_of_different_lengths_is_an_error() {
    let text = format!(
        "edge_length = 0.05\n{}{}{}",
        rectangle("left", [0.0, 0.0, 0.3, 0.6]),
        rectangle("right", [0.0, 0.0, 0.3, 0.58]),
        seam(("left", "b", "c"), ("right", "a", "d"))
    );
    let e = failure(&text);
    assert!(
        e.contains("`seam[0]`")
            && e.contains("panel `left` edge b → c is 0.6000 m")
            && e.contains("panel `right` edge a → d 0.5800 m"),
        "{e}"
    );
}

#[test]
fn an_edge_sewn_twice_is_an_error() {
    let text = format!(
        "edge_length = 0.05\n{}{}{}{}",
        rectangle("left", [0.0, 0.0, 0.3, 0.6]),
        rectangle("right", [0.0, 0.0, 0.3, 0.6]),
        seam(("left", "b", "c"), ("right", "a", "d")),
        seam(("right", "b", "c"), ("left", "c", "b"))
    );
    let e = failure(&text);
    assert!(e.contains("`seam[1].b`") && e.contains("panel `left` edge c → b is already sewn by seam 0"), "{e}");
}

#[test]
fn a_self_intersecting_outline_is_an_error() {
    // A bow tie: the edge b → c crosses d → a.
    let text = r#"
edge_length = 0.05
[[panel]]
name = "bow"
grain = [1.0, 0.0]
outline = [
  { at = [0.0, 0.0], corner = "a" },
  { at = [0.4, 0.0], corner = "b" },
  { at = [0.0, 0.4], corner = "c" },
  { at = [0.4, 0.4], corner = "d" },
]
placement = { flat = {} }
"#;
    let e = failure(text);
    assert!(
        e.contains("`panel[0].outline`") && e.contains("panel `bow`") && e.contains("the edges b → c and d → a cross"),
        "{e}"
    );
}

#[test]
fn a_panel_with_three_corners_is_an_error() {
    let text = r#"
edge_length = 0.05
[[panel]]
name = "triangle"
grain = [1.0, 0.0]
outline = [
  { at = [0.0, 0.0], corner = "a" },
  { at = [0.4, 0.0], corner = "b" },
  { at = [0.2, 0.4], corner = "c" },
]
placement = { flat = {} }
"#;
    let e = failure(text);
    assert!(e.contains("panel `triangle`: 3 corners (a, b, c); a panel needs exactly four"), "{e}");
}

/// Both sides running with their outlines would sew a right side to a wrong side; a seam's edge must exist.
#[test]
fn a_seam_of_the_wrong_sense_or_a_missing_edge_is_an_error() {
    let two = format!(
        "edge_length = 0.05\n{}{}",
        rectangle("left", [0.0, 0.0, 0.3, 0.6]),
        rectangle("right", [0.0, 0.0, 0.3, 0.6])
    );
    let e = failure(&format!("{two}{}", seam(("left", "b", "c"), ("right", "d", "a"))));
    assert!(e.contains("both run with their outlines") && e.contains("panel `right` edge d → a"), "{e}");
    let e = failure(&format!("{two}{}", seam(("left", "a", "c"), ("right", "a", "d"))));
    assert!(e.contains("panel `left` edge a → c does not exist"), "{e}");
}

/// The shipped pattern builds: two panels of matched counts, the side seams equal in length, no warning; the
/// pattern format's JSON schema lists its tables.
#[test]
fn the_straight_skirt_pattern_builds() {
    let spec = PatternSpec::load(&repo().join("garments/straight_skirt.toml")).unwrap();
    let built = spec.pattern().build().unwrap();
    assert_eq!(built.panels.len(), 2);
    assert_eq!(built.seams.len(), 2);
    for [a, b] in &built.seam_lengths {
        assert!((a - b).abs() < 1e-12, "seam lengths {a} and {b}");
    }
    assert_eq!(built.panels[0].grid.n, built.panels[1].grid.n);
    assert!(built.warnings.is_empty(), "{:?}", built.warnings);
    let schema = PatternSpec::json_schema().to_string();
    for key in ["\"panel\"", "\"seam\"", "\"hold\"", "\"edge_length\"", "\"cylinder\""] {
        assert!(schema.contains(key), "schema lacks {key}");
    }
    match spec.pattern().panels[0].placement {
        Placement::Cylinder { radius, .. } => assert!(radius > 0.2),
        _ => panic!("the skirt is placed on a vertical cylinder"),
    }
    let _: &Pattern = &spec.pattern();
    // The four-gore skirt: four gores of 20 nodes down (0.55 m with curved hips at 0.03 m), matched all round.
    let gores = PatternSpec::load(&repo().join("garments/four_gore_skirt.toml")).unwrap().pattern().build().unwrap();
    assert_eq!(gores.panels.len(), 4);
    assert_eq!(gores.seams.len(), 4);
    assert!(
        gores.panels.iter().all(|p| p.grid.n == 20),
        "{:?}",
        gores.panels.iter().map(|p| p.grid.n).collect::<Vec<_>>()
    );
    assert!(gores.warnings.is_empty(), "{:?}", gores.warnings);
}

/// The shipped straight skirt (`scenes/straight_skirt.toml`) sews closed on the mannequin: after the sewing
/// phase every sewn node pair is within 1 mm, the seams are joined (the model has the panels' nodes less one
/// side of each seam), and no node of the sewn skirt is inside the body; then it drapes for 0.4 s without a
/// self-intersection or a node inside the body on any step.
#[test]
fn the_straight_skirt_sews_closed_on_the_mannequin() {
    let clock = std::time::Instant::now();
    let scene = flexsurf::scene::load(&repo().join("scenes/straight_skirt.toml")).unwrap();
    let seconds = clock.elapsed().as_secs_f64();
    let sewing = scene.sewing.as_ref().unwrap();
    let report = &sewing.report;
    let model = &scene.model;
    let panel_nodes: usize = model.panels.iter().map(|p| p.grid.len()).sum();
    let seam_nodes: usize = model.seams.iter().map(|s| s.a.edge.count(&model.panels[s.a.panel].grid)).sum();
    assert_eq!(model.nodes(), panel_nodes - seam_nodes);
    let body = &model.obstacles()[0];
    let deepest = scene
        .state
        .x
        .iter()
        .filter_map(|p| body.distance_hinted(*p, &mut None, 0.1).map(|(d, _)| d))
        .fold(f64::INFINITY, f64::min);
    eprintln!(
        "straight skirt: {} nodes, sewn in {} steps ({:.2} s; scene built in {seconds:.2} s), gaps {:?} m, closest \
         to the body {deepest:.4} m",
        model.nodes(),
        report.steps,
        report.seconds,
        report.gaps
    );
    assert!(report.largest_gap() < 1e-3, "gaps {:?}", report.gaps);
    assert!(deepest > 0.0, "a node is {deepest} m inside the body");
    // The first 0.4 s of the drape: on every frame no two triangles of the sewn skirt intersect (the independent
    // checker) and no node is inside the body.
    let triangles = model.faces().triangles;
    let mut state = scene.state.clone();
    let mut stepper = Stepper::new(model, &scene.step_params()).unwrap();
    for step in 0..=40 {
        if step > 0 {
            stepper.step(model, &mut state).unwrap();
        }
        let crossing = flexsurf::testing::intersecting_triangles(&triangles, &state.x);
        assert!(crossing.is_none(), "step {step}: triangles {crossing:?} intersect");
        let inside =
            state.x.iter().position(|p| body.distance_hinted(*p, &mut None, 0.1).is_some_and(|(d, _)| d < 0.0));
        assert!(inside.is_none(), "step {step}: node {inside:?} inside the body");
    }
}

/// The straight skirt with the Terzopoulos–Fleischer comparison model: its sewing phase ran that model, whose
/// steps take no Newton corrections, and pulled the cloth through itself ("`initial`: the initial shape passes
/// through itself"). The sewing now runs the paper's model whatever the run's, so the garment's start is the
/// same for both models, bit for bit; and the scene warns, naming `model.kind`, that the comparison model is
/// not made for a sewn garment.
#[test]
fn regression_the_comparison_model_sewed_the_skirt_through_itself() {
    let path = repo().join("scenes/straight_skirt.toml");
    let mut spec = flexsurf::scene::SceneSpec::load(&path).unwrap();
    spec.model.kind = flexsurf::potential::elastic::ModelKind::Terzopoulos;
    let scene = spec.build(&path).unwrap_or_else(|e| panic!("{e}"));
    let warned = scene.warnings.iter().map(ToString::to_string).find(|w| w.contains("model.kind"));
    assert!(warned.as_ref().is_some_and(|w| w.contains("sewn garment")), "{:?}", scene.warnings);
    let paper = flexsurf::scene::load(&path).unwrap();
    assert!(paper.warnings.iter().all(|w| !w.to_string().contains("model.kind")));
    assert_eq!(scene.state.x, paper.state.x, "the sewn start depends on the run's model");
}

/// Two rectangles of 0.3 × 0.6 m placed flat 4 cm apart are pulled together by the sewing phase: the seam
/// closes below the phase's gap, and, the sewing forces being equal and opposite (and damping proportional to
/// mass), the centre of mass of the open panels stays where it was (to rounding); the joined model has the
/// square's 169 nodes.
#[test]
fn sewing_pulls_a_gap_closed_and_keeps_the_centre_of_mass() {
    let built = build(&two_halves(0.04, ""));
    let (l, r) = (&built.panels[0], &built.panels[1]);
    let (builder, x0) = open_panels(&built);
    assert!((x0[l.grid.index(6, 0)] - x0[91 + r.grid.index(0, 0)]).length() > 0.039);
    let params = SewingParams { stiffness: 100.0, dt: 0.01, steps: 200, gap: 5e-4, closing: None };
    let sewn = sew(&builder, &built.seams, x0.clone(), &[], &params).unwrap();
    let centre = |x: &[Vec3]| x.iter().copied().sum::<Vec3>() / x.len() as f64;
    // Equal masses per panel node on both panels: the open model's centre of mass is the mean position; the
    // joined positions are the pairs' midpoints, so the mean over panel nodes is recovered from them.
    let panel_nodes: Vec<Vec3> = sewn.model.panels.iter().flat_map(|p| p.gather(&sewn.x)).collect();
    let drift = (centre(&panel_nodes) - centre(&x0)).length();
    eprintln!(
        "sewing a 4 cm gap: {} steps, gap {:e} m, centre moved {drift:e} m",
        sewn.report.steps,
        sewn.report.largest_gap()
    );
    assert!(sewn.report.largest_gap() < 5e-4 && sewn.report.steps < 200, "{:?}", sewn.report);
    assert!(drift < 1e-12, "the centre moved {drift} m");
    assert_eq!(sewn.model.nodes(), 169);
}

/// The nodes of the open model taken as one where a sewing pair joins them: each node's smallest partner
/// through the pairs (a union–find of the test's own, from the sewing term's pairs).
pub fn identified(n: usize, pairs: &[(usize, usize)]) -> Vec<usize> {
    let mut rep: Vec<usize> = (0..n).collect();
    fn root(rep: &[usize], mut k: usize) -> usize {
        while rep[k] != k {
            k = rep[k];
        }
        k
    }
    for &(a, b) in pairs {
        let (ra, rb) = (root(&rep, a), root(&rep, b));
        rep[ra.max(rb)] = ra.min(rb);
    }
    (0..n).map(|k| root(&rep, k)).collect()
}

/// Gradual sewing with self-contact on: two 0.3 × 0.6 m rectangles placed flat 4 cm apart, closing 5 mm per
/// step. The rest lengths reach 0 after ⌈0.04 / 0.005⌉ = 8 steps, so the gap cannot fall below 0.5 mm sooner;
/// no node moves more than the closing in a step (the old zero-length springs moved them 2 cm in the first);
/// on every frame no two triangles intersect (the independent checker, a pair's two nodes counting as one);
/// the joined model is the square's 169 nodes.
#[test]
fn gradual_sewing_closes_a_gap_no_faster_than_its_rest_lengths_shrink() {
    let built = build(&two_halves(0.04, ""));
    let (mut builder, x0) = open_panels(&built);
    builder.self_contact = Some(SelfContactParams::frictionless(2e4, 0.004));
    let params = SewingParams { stiffness: 100.0, dt: 0.01, steps: 200, gap: 5e-4, closing: Some(0.005) };
    let (mut last, mut moved, mut frames): (Vec<Vec3>, f64, usize) = (x0.clone(), 0.0, 0);
    let mut observe = |model: &Model, x: &[Vec3]| {
        let sewing = model.potential.find::<Sewing>().unwrap();
        let same = identified(x.len(), sewing.node_pairs());
        let crossing = intersecting_triangles_joined(&model.faces().triangles, x, |k| same[k]);
        assert!(crossing.is_none(), "frame {frames}: triangles {crossing:?} intersect");
        moved = last.iter().zip(x).map(|(a, b)| (*a - *b).length()).fold(moved, f64::max);
        last = x.to_vec();
        frames += 1;
    };
    let sewn = sew_observed(&builder, &built.seams, x0, &[], &params, &mut observe).unwrap();
    eprintln!(
        "gradual sewing of a 4 cm gap: {} steps, gap {:e} m, largest node move in a step {moved:e} m",
        sewn.report.steps,
        sewn.report.largest_gap()
    );
    assert!(sewn.report.largest_gap() < 5e-4 && sewn.report.steps >= 8, "{:?}", sewn.report);
    assert!(moved <= 0.005, "a node moved {moved} m in one step");
    assert_eq!(frames, sewn.report.steps + 1);
    assert_eq!(sewn.model.nodes(), 169);
}

/// Four corners bunched on one side of a square (the sides a → b and c → d then run opposite ways along
/// one line) fold the Coons map: an error naming the panel; a strong taper (1 m at the bottom, 0.1 m at the top) is a warning of a badly distorted grid with
/// the bilinear map's Jacobian ratio 0.1.
#[test]
fn a_folded_map_is_an_error_and_a_distorted_one_a_warning() {
    let folded = r#"
edge_length = 0.05
[[panel]]
name = "bunched"
grain = [0.0, 1.0]
outline = [
  { at = [0.0, 0.0], corner = "a" },
  { at = [0.1, 0.0], corner = "b" },
  { at = [0.2, 0.0], corner = "c" },
  { at = [0.3, 0.0], corner = "d" },
  { at = [1.0, 0.0] },
  { at = [1.0, 1.0] },
  { at = [0.0, 1.0] },
]
placement = { flat = {} }
"#;
    let e = failure(folded);
    assert!(e.contains("`panel[0].outline`") && e.contains("panel `bunched`: its grid folds over"), "{e}");
    let tapered = r#"
edge_length = 0.05
[[panel]]
name = "taper"
grain = [0.0, 1.0]
outline = [
  { at = [0.0, 0.0], corner = "a" },
  { at = [1.0, 0.0], corner = "b" },
  { at = [0.55, 0.5], corner = "c" },
  { at = [0.45, 0.5], corner = "d" },
]
placement = { flat = {} }
"#;
    let built = build(tapered);
    let [lo, hi] = built.panels[0].jacobian;
    assert!((lo / hi - 0.1).abs() < 1e-9, "Jacobian ratio {}", lo / hi);
    assert_eq!(built.warnings.len(), 1);
    let (key, message) = &built.warnings[0];
    assert!(
        key == "panel[0].outline"
            && message.contains("panel `taper`: its grid is badly distorted (smallest to largest Jacobian 0.100)"),
        "{message}"
    );
}

/// A scene whose pattern cannot be sewn names the scene file, its `pattern.file`, the pattern file and the
/// pattern's key.
#[test]
fn a_pattern_error_names_the_scene_and_the_pattern_file() {
    let dir = flexsurf::testing::scratch("garments", "pattern-error");
    let text = format!(
        "edge_length = 0.05\n{}{}{}",
        rectangle("left", [0.0, 0.0, 0.3, 0.6]),
        rectangle("right", [0.0, 0.0, 0.3, 0.5]),
        seam(("left", "b", "c"), ("right", "a", "d"))
    );
    std::fs::write(dir.join("bad_pattern.toml"), text).unwrap();
    let scene = "[pattern]\nfile = \"bad_pattern.toml\"\n[time]\nsteps = 1\n";
    std::fs::write(dir.join("sewn.toml"), scene).unwrap();
    let e = flexsurf::scene::load(&dir.join("sewn.toml")).unwrap_err();
    let m = e.to_string();
    assert!(m.contains("sewn.toml") && m.contains("`pattern.file`") && m.contains("bad_pattern.toml"), "{m}");
    assert!(m.contains("`seam[0]`") && m.contains("panel `right` edge a → d 0.5000 m"), "{m}");
    assert_eq!(e.key(), "seam[0]");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------------------------------
// Outlines from DXF (pattern CAD)
// ---------------------------------------------------------------------------------------------------------------

/// Writes a DXF file `name` in `dir` with one closed `LWPOLYLINE` per `(layer, vertices [x, y, bulge])`, its
/// `$INSUNITS` set to `units`; returns its path.
fn write_dxf(
    dir: &Path,
    name: &str,
    units: dxf::enums::Units,
    polylines: &[(&str, Vec<[f64; 3]>)],
) -> std::path::PathBuf {
    let mut drawing = dxf::Drawing::new();
    drawing.header.version = dxf::enums::AcadVersion::R2000;
    drawing.header.default_drawing_units = units;
    for (layer, vertices) in polylines {
        let mut poly = dxf::entities::LwPolyline::default();
        poly.set_is_closed(true);
        poly.vertices = vertices
            .iter()
            .map(|v| dxf::LwPolylineVertex { x: v[0], y: v[1], bulge: v[2], ..Default::default() })
            .collect();
        let mut entity = dxf::entities::Entity::new(dxf::entities::EntityType::LwPolyline(poly));
        entity.common.layer = layer.to_string();
        drawing.add_entity(entity);
    }
    let path = dir.join(name);
    drawing.save_file(&path).unwrap();
    path
}

/// A one-panel pattern `name` whose outline is the `layer` of `panel.dxf`, with `corners` (name, [x, y] in the
/// drawing's units) and extra `dxf` keys.
fn dxf_pattern(layer: &str, corners: &[(&str, [f64; 2])], extra: &str) -> String {
    let corners: Vec<String> =
        corners.iter().map(|(n, [x, y])| format!("{{ name = \"{n}\", at = [{x}, {y}] }}")).collect();
    format!(
        "edge_length = 0.05\n[[panel]]\nname = \"p\"\ngrain = [1.0, 0.0]\ndxf = {{ file = \"panel.dxf\", layer = \"{layer}\", corners = [{}]{extra} }}\nplacement = {{ flat = {{}} }}\n",
        corners.join(", ")
    )
}

#[test]
fn a_panel_read_from_dxf_is_the_panel_written_out() {
    // A 600 × 400 mm rectangle drawn clockwise from its top-left corner, in millimetres: the same grid as the
    // outline written in metres, counter-clockwise from the lower left.
    let dir = flexsurf::testing::scratch("garments", "dxf-rectangle");
    let clockwise = vec![[0.0, 400.0, 0.0], [600.0, 400.0, 0.0], [600.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
    write_dxf(
        &dir,
        "panel.dxf",
        dxf::enums::Units::Millimeters,
        &[("FRONT", clockwise), ("OTHER", vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])],
    );
    let corners = [("a", [0.0, 0.0]), ("b", [600.0, 0.0]), ("c", [600.0, 400.0]), ("d", [0.0, 400.0])];
    let file = dir.join("pattern.toml");
    let from_dxf = parse(&dxf_pattern("FRONT", &corners, "")).build(&file).unwrap();
    let written = build(&format!("edge_length = 0.05\n{}", rectangle("p", [0.0, 0.0, 0.6, 0.4])));
    let (a, b) = (&from_dxf.panels[0], &written.panels[0]);
    assert_eq!((a.grid.count(0), a.grid.count(1)), (b.grid.count(0), b.grid.count(1)));
    assert_eq!(a.corners, b.corners);
    for (p, q) in a.flat.iter().zip(&b.flat) {
        assert!((*p - *q).length() < 1e-12, "{p} against {q}");
    }
}

#[test]
fn a_dxf_arc_edge_lies_on_its_circle() {
    // A 0.4 × 0.3 m panel whose top edge is a 60° arc bulging up (bulge tan(60°/4)), in metres: the grid's top
    // row lies on that circle, radius 0.2/sin 30° = 0.4, centre 0.4 cos 30° below the chord's midpoint.
    let dir = flexsurf::testing::scratch("garments", "dxf-arc");
    let bulge = (60f64.to_radians() / 4.0).tan();
    let outline = vec![[0.0, 0.0, 0.0], [0.4, 0.0, 0.0], [0.4, 0.3, bulge], [0.0, 0.3, 0.0]];
    write_dxf(&dir, "panel.dxf", dxf::enums::Units::Meters, &[("TOP", outline)]);
    let corners = [("a", [0.0, 0.0]), ("b", [0.4, 0.0]), ("c", [0.4, 0.3]), ("d", [0.0, 0.3])];
    let built = parse(&dxf_pattern("TOP", &corners, "")).build(&dir.join("pattern.toml")).unwrap();
    let panel = &built.panels[0];
    let (m, n) = (panel.grid.count(0), panel.grid.count(1));
    let centre = Vec3::new(0.2, 0.3 - 0.4 * 30f64.to_radians().cos(), 0.0);
    for i in 0..m {
        let p = panel.flat[panel.grid.index(i, n - 1)];
        let r = (p - centre).length();
        assert!((r - 0.4).abs() < 1e-4 * 0.4, "top node {i} at {p}: {r} m from the centre");
        assert!(p.y >= 0.3 - 1e-12, "top node {i} at {p} below the chord");
    }
}

#[test]
fn dxf_outline_errors_name_the_key_and_what_is_wrong() {
    let dir = flexsurf::testing::scratch("garments", "dxf-errors");
    let square = vec![[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [100.0, 100.0, 0.0], [0.0, 100.0, 0.0]];
    write_dxf(&dir, "panel.dxf", dxf::enums::Units::Unitless, &[("P", square)]);
    let file = dir.join("pattern.toml");
    let corners = [("a", [0.0, 0.0]), ("b", [100.0, 0.0]), ("c", [100.0, 100.0]), ("d", [0.0, 100.0])];
    let error = |text: String| parse(&text).build(&file).unwrap_err().to_string();
    let no_unit = error(dxf_pattern("P", &corners, ""));
    assert!(no_unit.contains("panel[0].dxf.file") && no_unit.contains("give `unit`"), "{no_unit}");
    let no_layer = error(dxf_pattern("Q", &corners, ", unit = \"mm\""));
    assert!(no_layer.contains("no polyline on layer `Q`") && no_layer.contains("[\"P\"]"), "{no_layer}");
    let bad_unit = error(dxf_pattern("P", &corners, ", unit = \"furlong\""));
    assert!(bad_unit.contains("panel[0].dxf.unit"), "{bad_unit}");
    let far = [("a", [0.0, 0.0]), ("b", [100.0, 0.0]), ("c", [100.0, 100.0]), ("d", [0.0, 50.0])];
    let far = error(dxf_pattern("P", &far, ", unit = \"mm\""));
    assert!(far.contains("panel[0].dxf.corners[3]") && far.contains("corner `d`"), "{far}");
    let three = error(dxf_pattern("P", &corners[..3], ", unit = \"mm\""));
    assert!(three.contains("3 corners given"), "{three}");
    for e in [no_unit, no_layer, bad_unit, far, three] {
        println!("{e}");
        assert!(!e.contains('\n') && e.contains("pattern.toml"), "{e}");
    }
}

/// Marks on a DXF outline (notches): a mark between the vertices of a straight side becomes a vertex there, so
/// the panel is the written outline with that marked vertex (the same grid to 1e-12 m, the mark where it was
/// put); a mark on an arc splits the arc exactly (the grid's row stays on the circle); a seam runs from a mark.
/// A mark far from the outline, on a corner, or on another mark is an error naming the key.
#[test]
fn marks_on_a_dxf_outline_are_vertices_where_they_are_put() {
    let dir = flexsurf::testing::scratch("garments", "dxf-marks");
    let bulge = (60f64.to_radians() / 4.0).tan();
    let outline = vec![[0.0, 0.0, 0.0], [600.0, 0.0, 0.0], [600.0, 400.0, bulge], [0.0, 400.0, 0.0]];
    let plain = vec![[0.0, 0.0, 0.0], [600.0, 0.0, 0.0], [600.0, 400.0, 0.0], [0.0, 400.0, 0.0]];
    write_dxf(&dir, "panel.dxf", dxf::enums::Units::Millimeters, &[("P", outline), ("R", plain)]);
    let file = dir.join("pattern.toml");
    let corners = [("a", [0.0, 0.0]), ("b", [600.0, 0.0]), ("c", [600.0, 400.0]), ("d", [0.0, 400.0])];
    // The arc: radius 0.6, centre 0.6 cos 30° below the chord's midpoint; its top at (0.3, 0.4 + 0.6 (1 − cos 30°)).
    let top = 400.0 + 600.0 * (1.0 - 30f64.to_radians().cos());
    let marks = format!(", marks = [{{ name = \"n\", at = [200.0, 0.0] }}, {{ name = \"t\", at = [300.0, {top}] }}]");
    let text = format!(
        "{}{}{}",
        dxf_pattern("P", &corners, &marks),
        rectangle("q", [0.0, -0.2, 0.2, 0.0]),
        seam(("p", "a", "n"), ("q", "d", "c"))
    );
    let spec = parse(&text);
    let built = spec.build(&file).unwrap();
    let outline = &spec.with_dxf_outlines(&file).unwrap().pattern().panels[0].outline;
    let n = outline.iter().find(|v| v.mark.as_deref() == Some("n")).expect("mark n");
    assert!((n.at[0] - 0.2).abs() < 1e-12 && n.at[1].abs() < 1e-12, "{n:?}");
    let t = outline.iter().find(|v| v.mark.as_deref() == Some("t")).expect("mark t");
    let centre = [0.3, 0.4 - 0.6 * 30f64.to_radians().cos()];
    let r = (t.at[0] - centre[0]).hypot(t.at[1] - centre[1]);
    assert!(
        (r - 0.6).abs() < 3e-4 * 0.6 && (t.at[0] - 0.3).abs() < 1e-3,
        "mark t at {:?}, {r} m from the centre",
        t.at
    );
    let panel = &built.panels[0];
    let (m, k) = (panel.grid.count(0), panel.grid.count(1));
    for i in 0..m {
        let q = panel.flat[panel.grid.index(i, k - 1)];
        let r = (q.x - centre[0]).hypot(q.y - centre[1]);
        assert!((r - 0.6).abs() < 3e-4 * 0.6, "top node {i} at {q}: {r} m from the centre");
    }
    // The seam from the mark: the bottom from a to n, 0.2 m, is sewn to q's top.
    assert_eq!(built.seams.len(), 1);
    // The written twin of the plain rectangle with the mark n: the same grid.
    let from_dxf =
        parse(&dxf_pattern("R", &corners, ", marks = [{ name = \"n\", at = [200.0, 0.0] }]")).build(&file).unwrap();
    let written = build(
        "edge_length = 0.05\n[[panel]]\nname = \"p\"\ngrain = [1.0, 0.0]\noutline = [{ at = [0.0, 0.0], corner = \"a\" }, \
         { at = [0.2, 0.0], mark = \"n\" }, { at = [0.6, 0.0], corner = \"b\" }, { at = [0.6, 0.4], corner = \"c\" }, \
         { at = [0.0, 0.4], corner = \"d\" }]\nplacement = { flat = {} }\n",
    );
    let (a, b) = (&from_dxf.panels[0], &written.panels[0]);
    assert_eq!((a.grid.count(0), a.grid.count(1)), (b.grid.count(0), b.grid.count(1)));
    for (p, q) in a.flat.iter().zip(&b.flat) {
        assert!((*p - *q).length() < 1e-12, "{p} against {q}");
    }
    let error = |marks: &str| parse(&dxf_pattern("P", &corners, marks)).build(&file).unwrap_err().to_string();
    let far = error(", marks = [{ name = \"f\", at = [300.0, 200.0] }]");
    assert!(far.contains("panel[0].dxf.marks[0]") && far.contains("mark `f`"), "{far}");
    let on_corner = error(", marks = [{ name = \"x\", at = [600.0, 0.0] }]");
    assert!(on_corner.contains("panel[0].dxf.corners[1]") && on_corner.contains("mark `x`"), "{on_corner}");
    let twice = error(", marks = [{ name = \"x\", at = [200.0, 0.0] }, { name = \"y\", at = [201.0, 0.0] }]");
    assert!(twice.contains("panel[0].dxf.marks[1]") && twice.contains("mark `x`"), "{twice}");
}

/// A hold may run between marks, as a seam side does: a 0.6 × 0.4 m panel whose top carries the mark `t` at
/// x = 0.43 m, held from `t` to the corner `d` (0.43 m), gets a grid node at `t` (the top cut into 0.17 and
/// 0.43 m, the second of 9 cells) and exactly the ten nodes from `t` to `d` held; without the hold the top is spread evenly (no node at 0.43). A hold between a mark and a corner of
/// another edge is an error naming `hold[0]`.
#[test]
fn a_hold_runs_between_marks() {
    let text = |hold: &str| {
        format!(
            "edge_length = 0.05\n[[panel]]\nname = \"p\"\ngrain = [1.0, 0.0]\noutline = [{{ at = [0.0, 0.0], corner = \"a\" }}, \
             {{ at = [0.6, 0.0], corner = \"b\" }}, {{ at = [0.6, 0.4], corner = \"c\" }}, {{ at = [0.43, 0.4], mark = \"t\" }}, \
             {{ at = [0.0, 0.4], corner = \"d\" }}]\nplacement = {{ flat = {{}} }}\n{hold}"
        )
    };
    let file = Path::new("test.toml");
    let spec = parse(&text("[[hold]]\npanel = \"p\"\nfrom = \"t\"\nto = \"d\"\n"));
    let built = spec.build(file).unwrap();
    let panel = &built.panels[0];
    let held = spec.holds(&built, file).unwrap();
    assert_eq!(held.len(), 10, "{held:?}");
    let top: Vec<Vec3> = held.iter().map(|&(k, _)| panel.flat[k]).collect();
    assert!(top.iter().all(|q| (q.y - 0.4).abs() < 1e-12 && q.x <= 0.43 + 1e-12), "{top:?}");
    assert!(top.iter().any(|q| (q.x - 0.43).abs() < 1e-12) && top.iter().any(|q| q.x.abs() < 1e-12), "{top:?}");
    let plain = build(&text(""));
    let row = plain.panels[0].grid.count(1) - 1;
    let xs: Vec<f64> = (0..plain.panels[0].grid.count(0))
        .map(|i| plain.panels[0].flat[plain.panels[0].grid.index(i, row)].x)
        .collect();
    assert!(xs.iter().all(|x| (x - 0.43).abs() > 1e-3), "{xs:?}");
    let e = parse(&text("[[hold]]\npanel = \"p\"\nfrom = \"t\"\nto = \"b\"\n")).build(file).unwrap_err().to_string();
    assert!(e.contains("hold[0]") && e.contains("mark `t`") && !e.contains('\n'), "{e}");
}

// ---------------------------------------------------------------------------------------------------------------
// A garment of two fabrics
// ---------------------------------------------------------------------------------------------------------------

/// Two 0.3 × 0.1 m panels sewn end to end, the right one of another fabric (a quarter of the tensile stiffness,
/// 0.2 kg/m²): the sewn strip weighs `ρ₁A₁ + ρ₂A₂`, and pulled by 0.2 N (a uniform traction on its free end,
/// the other end pinned, no gravity) it stretches by `F L₁/(E₁ w) + F L₂/(E₂ w)` = 1.408e-4 m, the two panels in
/// series (Poisson's ratio 0; Green's strain leaves 1.5 ε ≈ 2e-4 of nonlinearity).
#[test]
fn panels_of_two_fabrics_weigh_their_own_and_stretch_in_series() {
    let text = format!(
        "edge_length = 0.025\n{}{}{}",
        rectangle("left", [0.0, 0.0, 0.3, 0.1]),
        rectangle("right", [0.3, 0.0, 0.6, 0.1]),
        seam(("left", "b", "c"), ("right", "a", "d"))
    );
    let built = build(&text);
    let (f1, s1) = cotton();
    let f2 = Fabric { tensile_warp: f1.tensile_warp / 4.0, density: 0.2, ..f1 };
    let s2 = Stiffness::calibrate(&f2, Calibration::Kes).unwrap();
    let [l, r] = [&built.panels[0], &built.panels[1]];
    let mut builder = ModelBuilder::new(l.grid, l.flat.clone(), f1, s1, ModelKind::Tfs, Vec3::ZERO)
        .options(l.options)
        .panel(r.grid, r.flat.clone(), r.options);
    builder.panels[1].material = Some(flexsurf::model::PanelMaterial { fabric: f2, stiffness: s2 });
    let (force, n) = (0.2, r.grid.n);
    for j in 0..l.grid.n {
        builder.pinned[l.grid.index(0, j)] = true;
    }
    for j in 0..n {
        // Tributary shares of the end's width: half at the two corners.
        let share = if j == 0 || j == n - 1 { 0.5 } else { 1.0 } / (n - 1) as f64;
        builder.loads[l.grid.len() + r.grid.index(r.grid.m - 1, j)] = Vec3::new(force * share, 0.0, 0.0);
    }
    let x0: Vec<Vec3> = l.placed.iter().chain(&r.placed).copied().collect();
    let params = SewingParams { stiffness: 10.0, dt: 0.005, steps: 10, gap: 1e-9, closing: None };
    let sewn = sew(&builder, &built.seams, x0, &[], &params).unwrap();
    let model = &sewn.model;
    let weight: f64 = model.mass.iter().sum();
    let expected = f1.density * 0.03 + f2.density * 0.03;
    assert!((weight - expected).abs() < 1e-12 * expected, "mass {weight} kg against {expected} kg");
    let mut x = sewn.x.clone();
    flexsurf::integrate::statics::StaticSolver::new(model)
        .unwrap()
        .solve(model, &mut x, &flexsurf::integrate::statics::StaticOptions::default())
        .unwrap();
    let end: Vec<usize> = (0..n).map(|j| model.panels[1].global(r.grid.index(r.grid.m - 1, j))).collect();
    let stretch = end.iter().map(|&k| x[k].x - sewn.x[k].x).sum::<f64>() / n as f64;
    let series = force * 0.3 / (f1.tensile_warp * 0.1) + force * 0.3 / (f2.tensile_warp * 0.1);
    eprintln!("two fabrics in series: stretched {stretch:.6e} m against {series:.6e} m");
    assert!((stretch / series - 1.0).abs() < 1e-3, "stretched {stretch} m, in series {series} m");
}

/// A pattern's panel naming a material file (`materials/denim.toml`, relative to the pattern) takes that
/// fabric: the straight skirt with a denim back weighs its cotton front (half the all-cotton skirt, the two
/// panels being alike) plus the back scaled by denim's density over cotton's.
#[test]
fn a_pattern_panel_takes_its_own_material_file() {
    let dir = flexsurf::testing::scratch("garments", "panel-material");
    for sub in ["scenes", "garments", "materials"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    std::fs::copy(repo().join("scenes/straight_skirt.toml"), dir.join("scenes/straight_skirt.toml")).unwrap();
    std::fs::copy(repo().join("materials/denim.toml"), dir.join("materials/denim.toml")).unwrap();
    let pattern = std::fs::read_to_string(repo().join("garments/straight_skirt.toml")).unwrap();
    let pattern = pattern.replacen("name = \"back\"", "name = \"back\"\nmaterial = \"../materials/denim.toml\"", 1);
    std::fs::write(dir.join("garments/straight_skirt.toml"), pattern).unwrap();
    let cotton = flexsurf::scene::load(&repo().join("scenes/straight_skirt.toml")).unwrap();
    let mixed = flexsurf::scene::load(&dir.join("scenes/straight_skirt.toml")).unwrap();
    // denim.toml's weight: 40 mg/cm² = 0.4 kg/m².
    let all_cotton: f64 = cotton.model.mass.iter().sum();
    let expected = 0.5 * all_cotton * (1.0 + 0.4 / cotton.model.fabric.density);
    let weight: f64 = mixed.model.mass.iter().sum();
    assert!((weight / expected - 1.0).abs() < 1e-9, "mass {weight} kg against {expected} kg");
}

/// A panel on a cone is the cone's development (`placement = { cone = ... }`): the shipped one-panel skirt, an
/// annular sector of 360° sin α about the pattern point [0, 0.88] (waist 0.90 m, hem 2.4 m, 0.55 m long, so
/// sin α = 1.5 / (2π 0.55) and the waist and hem arcs at slant 0.33 and 0.88 m), wrapped on its cone with the
/// waist's middle at z = 1.04 m: every node on the cone at its pattern distance from the apex, the hem row a
/// closed regular polygon on the circle of radius 0.88 sin α (its perimeter `2 n r sin(π/n)`), the two
/// straight edges meeting, the right side facing out.
#[test]
fn a_panel_wrapped_on_a_cone_is_its_development() {
    use std::f64::consts::PI;
    let spec = PatternSpec::load(&repo().join("garments/one_panel_skirt.toml")).unwrap();
    assert!(matches!(spec.pattern().panels[0].placement, Placement::Cone { .. }));
    let built = spec.pattern().build().unwrap();
    let p = &built.panels[0];
    let sin = 1.5 / (2.0 * PI * 0.55);
    let cos = (1.0 - sin * sin).sqrt();
    let (apex_flat, apex) = (Vec3::new(0.0, 0.88, 0.0), Vec3::new(0.0, 0.0, 1.04 + 0.33 * cos));
    for (f, x) in p.flat.iter().zip(&p.placed) {
        let s = (*f - apex_flat).length();
        assert!(((*x - apex).length() - s).abs() < 1e-12, "{x:?}: slant {} against {s}", (*x - apex).length());
        let (r, depth) = (x.x.hypot(x.y), apex.z - x.z);
        assert!((r - depth * sin / cos).abs() < 1e-12, "{x:?} is off the cone");
    }
    let hem = p.edge_nodes("hem_left", "hem_right").unwrap();
    let n = hem.len() - 1;
    let (first, last) = (p.placed[hem[0]], p.placed[hem[n]]);
    assert!((first - last).length() < 2e-6, "the straight edges do not meet: {first:?}, {last:?}");
    let perimeter: f64 = hem.windows(2).map(|w| (p.placed[w[1]] - p.placed[w[0]]).length()).sum();
    let r = 0.88 * sin;
    assert!((perimeter - 2.0 * n as f64 * r * (PI / n as f64).sin()).abs() < 2e-5, "hem perimeter {perimeter}");
    // Right side out: the grid's (u1 × u2) normal points away from the axis at the hem's middle.
    let (i, j) = (p.grid.m / 2, 0);
    let at = |i: usize, j: usize| p.placed[p.grid.index(i, j)];
    let normal = (at(i + 1, j) - at(i, j)).cross(at(i, j + 1) - at(i, j));
    let outward = Vec3::new(at(i, j).x, at(i, j).y, 0.0);
    assert!(normal.dot(outward) > 0.0, "the normal {normal:?} points inward at {:?}", at(i, j));
}

/// A cone's half-angle outside (0°, 90°] or its apex on its centre point is an error naming the panel's
/// placement.
#[test]
fn a_cone_placement_out_of_range_is_an_error() {
    let text = |half: f64, apex: f64| {
        let placement = format!(
            "placement = {{ cone = {{ half_angle_deg = {half}, angle_deg = 0.0, height = 1.0, center = [0.1, 0.1], \
             apex = [0.1, {apex}] }} }}"
        );
        format!(
            "edge_length = 0.05\n{}",
            rectangle("r", [0.0, 0.0, 0.2, 0.1]).replace("placement = { flat = {} }", &placement)
        )
    };
    for half in [0.0, 95.0] {
        let e = failure(&text(half, 0.5));
        assert!(e.contains("`panel[0].placement`") && e.contains("panel `r`") && e.contains("half-angle"), "{e}");
    }
    let e = failure(&text(30.0, 0.1));
    assert!(e.contains("`panel[0].placement`") && e.contains("is its `center`"), "{e}");
    assert_eq!(build(&text(30.0, 0.5)).panels.len(), 1);
}

/// A grid too coarse for a seam (found by the fuzzer: the T-shirt's pattern at a 4.3e9 m edge length gave its
/// shoulder seams two nodes, and building the seam's bending strip panicked) is an error naming the seam, from
/// the pattern's own checks (so `flexsurf check` reports it too), not a panic when the model is built.
#[test]
fn regression_a_seam_of_two_nodes_panicked_the_seam_strip() {
    let text = std::fs::read_to_string(repo().join("garments/tshirt.toml")).unwrap();
    let coarse: String = text
        .lines()
        .map(|l| if l.starts_with("edge_length") { "edge_length = 4294967296".to_string() } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n");
    let e = failure(&coarse);
    assert!(e.contains("`seam[") && e.contains("have 2 nodes at edge_length = 4294967296 m"), "{e}");
    assert!(e.contains("panel `") && e.contains("a seam needs 3 or more: a smaller edge_length"), "{e}");
}

/// Two rectangles side by side: the left one's grain along pattern `x`, the right one's along pattern `y`.
fn crossed_grains() -> String {
    let right = rectangle("right", [0.0, -0.3, 0.3, 0.3]).replace("grain = [1.0, 0.0]", "grain = [0.0, 1.0]");
    format!(
        "edge_length = 0.05\n{}{right}{}",
        rectangle("left", [-0.3, -0.3, 0.0, 0.3]),
        seam(("left", "b", "c"), ("right", "a", "d"))
    )
}

/// The display's UVs are the pattern's metres along each panel's grain and across it: the left panel (grain
/// `x`) maps pattern `(x, y)` to `(x, y)`, the right one (grain `y`) to `(y, −x)` (the weft is the grain turned
/// a quarter counter-clockwise); every display triangle keeps its flat pattern area in UV, and the seam's
/// display vertices have one UV on each side.
#[test]
fn display_uvs_run_along_each_panels_grain() {
    let built = build(&crossed_grains());
    let (builder, x0) = open_panels(&built);
    let params = SewingParams { stiffness: 10.0, dt: 0.005, steps: 10, gap: 1e-9, closing: None };
    let sewn = sew(&builder, &built.seams, x0, &[], &params).unwrap();
    let k = 2;
    let topology = flexsurf::runner::fields::display_topology(&sewn.model.panels, k);
    let rows = 2 * 6 + 1; // display vertices along x per panel (6 cells of 5 cm at k = 2)
    assert_eq!(topology.uv.len(), 2 * rows * (2 * 12 + 1));
    let uv = |panel: usize, a: usize, b: usize| topology.uv[panel * rows * 25 + a + rows * b];
    let near = |got: [f32; 2], want: [f64; 2]| (got[0] as f64 - want[0]).hypot(got[1] as f64 - want[1]) < 1e-6;
    // Corners and the centre of a display cell of each panel, from the outlines' numbers.
    for (a, b, x, y) in [(0, 0, -0.3, -0.3), (12, 24, 0.0, 0.3), (3, 5, -0.225, -0.175)] {
        assert!(near(uv(0, a, b), [x, y]), "left ({a}, {b}): {:?}", uv(0, a, b));
    }
    for (a, b, x, y) in [(0, 0, 0.0, -0.3), (12, 24, 0.3, 0.3), (3, 5, 0.075, -0.175)] {
        assert!(near(uv(1, a, b), [y, -x]), "right ({a}, {b}): {:?}", uv(1, a, b));
    }
    // The seam (the left's last column, the right's first) has two UVs per vertex, a quarter turn apart.
    assert!(near(uv(0, 12, 10), [0.0, -0.05]) && near(uv(1, 0, 10), [-0.05, 0.0]));
    let area = |t: &[u32; 3]| {
        let [p, q, s] = t.map(|v| topology.uv[v as usize].map(f64::from));
        0.5 * ((q[0] - p[0]) * (s[1] - p[1]) - (q[1] - p[1]) * (s[0] - p[0]))
    };
    let total: f64 = topology.triangles.iter().map(area).sum();
    assert!(
        topology.triangles.iter().all(|t| (area(t) - 0.025f64.powi(2) / 2.0).abs() < 1e-9),
        "a triangle is not flat-sized"
    );
    assert!((total - 0.36).abs() < 1e-6, "UV area {total}"); // f32 UVs
}

/// The welded garment mesh a run writes carries the pattern's UVs: one `vt` per display vertex, the faces'
/// texture corners those of the unwelded display mesh, so the seam's welded vertices have two.
#[test]
fn the_written_garment_mesh_has_the_patterns_uvs() {
    let dir = crate::scratch_dir("garment-uv");
    std::fs::write(dir.join("pattern.toml"), crossed_grains()).unwrap();
    let scene = "name = \"uv\"\ngravity = [0.0, 0.0, -9.81]\n[pattern]\nfile = \"pattern.toml\"\n\
                 [material]\npreset = \"paper-cotton\"\n[time]\ndt = 0.01\nsteps = 1\noutput_every = 1\n\
                 [output]\ncoons_subdivisions = 2\n";
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    let scene = flexsurf::scene::load(&dir.join("scene.toml")).unwrap();
    let out = dir.join("out");
    flexsurf::runner::run_scene(&scene, &out, |_| {}).unwrap();
    let text = std::fs::read_to_string(out.join("garment/garment_00001.obj")).unwrap();
    let count = |tag: &str| text.lines().filter(|l| l.starts_with(tag)).count();
    // 2 × 13 × 25 display vertices, the seam's 25 welded.
    assert_eq!((count("v "), count("vt "), count("vn "), count("f ")), (625, 650, 625, 1152));
    let faces: Vec<Vec<[usize; 2]>> = text
        .lines()
        .filter_map(|l| l.strip_prefix("f "))
        .map(|f| {
            f.split(' ')
                .map(|c| c.split('/').map(|n| n.parse().unwrap()))
                .map(|mut c| [c.next().unwrap(), c.next().unwrap()])
                .collect()
        })
        .collect();
    // Some welded vertex is used with two texture coordinates (the seam), none with three.
    let mut uvs: std::collections::BTreeMap<usize, std::collections::BTreeSet<usize>> = Default::default();
    faces.iter().flatten().for_each(|[v, t]| {
        uvs.entry(*v).or_default().insert(*t);
    });
    assert_eq!(uvs.values().filter(|s| s.len() == 2).count(), 25);
    assert!(uvs.values().all(|s| s.len() <= 2));
}

/// A 0.6 m tall band wrapped onto the body's offset surface (`onto_body`): around a sphere of radius 0.2 m with
/// an offset of 0.01 m, every node within 0.21 m of the sphere's equatorial plane ends on the offset sphere at
/// the horizontal distance `√(0.21² − z²)` from the axis, at its angle and height on the cylinder, whether the
/// cylinder was wider than the body (0.35 m: the nodes come in) or cut through it (0.1 m: the nodes that were
/// inside move out, those above the body's narrowing come in); the nodes above and below the body stay on
/// the cylinder. The same about a tilted (horizontal) axis.
#[test]
fn a_panel_wrapped_onto_the_body_lies_on_its_offset_surface() {
    use flexsurf::contact::Obstacle;
    use flexsurf::garment::wrap::wrap_onto_body;
    let sphere = [Obstacle::Sphere { center: Vec3::ZERO, radius: 0.2 }];
    let reach = 0.21;
    let grid = Grid::sheet(12, 25, 0.3, 0.6).unwrap();
    let band = |radius: f64| -> Vec<Vec3> {
        // 12 × 25 points of a band of the cylinder, angles 0.1..1.2 rad, heights −0.3..0.3 m.
        (0..12 * 25)
            .map(|k| {
                Vec3::new(
                    radius * (0.1 * (1 + k % 12) as f64).cos(),
                    radius * (0.1 * (1 + k % 12) as f64).sin(),
                    -0.3 + 0.025 * (k / 12) as f64,
                )
            })
            .collect()
    };
    for radius in [0.35, 0.1] {
        let placement = Placement::Cylinder { axis: [0.0, 0.0], radius, angle: 0.0, height: 0.0, center: [0.0, 0.0] };
        let before = band(radius);
        let mut x = before.clone();
        let moved = wrap_onto_body(&mut x, &grid, &placement, 0.01, &sphere);
        let mut expected_moves = 0;
        for (p, q) in x.iter().zip(&before) {
            let (rho, angle) = (p.x.hypot(p.y), p.y.atan2(p.x));
            assert!((angle - q.y.atan2(q.x)).abs() < 1e-12 && p.z == q.z, "{q:?} moved off its line to {p:?}");
            if q.z.abs() < reach - 1e-9 {
                let want = (reach * reach - q.z * q.z).sqrt();
                assert!((rho - want).abs() < 2e-5, "radius {radius}, z {}: at {rho} m from the axis, not {want}", q.z);
                expected_moves += usize::from((want - radius).abs() > 1e-9);
            } else {
                assert_eq!(p, q, "radius {radius}: a node beyond the body moved");
            }
        }
        assert_eq!(moved, expected_moves);
    }
    // A sleeve-like tilted cylinder about the x axis: the same, distances measured from the x axis.
    let placement =
        Placement::Tilted { origin: Vec3::ZERO, direction: Vec3::X, radius: 0.3, angle: 0.0, center: [0.0, 0.0] };
    let mut x: Vec<Vec3> = band(0.3).iter().map(|q| Vec3::new(q.z, q.x, q.y)).collect();
    let before = x.clone();
    wrap_onto_body(&mut x, &grid, &placement, 0.01, &sphere);
    for (p, q) in x.iter().zip(&before) {
        let want = if q.x.abs() < reach { (reach * reach - q.x * q.x).sqrt() } else { 0.3 };
        assert!((p.y.hypot(p.z) - want).abs() < 2e-5 && p.x == q.x, "{q:?} went to {p:?}, not {want} m from the axis");
    }
}

/// `onto_body` on a flat placement, a negative offset, or a scene without obstacles is an error naming the
/// panel's placement.
#[test]
fn onto_body_errors_name_the_panels_placement() {
    let cylinder = |offset: &str| {
        rectangle("band", [0.0, 0.0, 0.3, 0.2]).replace(
            "placement = { flat = {} }",
            &format!("placement = {{ cylinder = {{ radius = 0.3, angle_deg = 0.0, height = 1.0, center = [0.0, 0.0]{offset} }} }}"),
        )
    };
    let e = failure(&format!("edge_length = 0.05\n{}", cylinder(", onto_body = -0.01")));
    assert!(e.contains("panel[0].placement") && e.contains("`onto_body` -0.01 m is not a distance"), "{e}");
    let mut pattern = parse(&format!("edge_length = 0.05\n{}", rectangle("flat", [0.0, 0.0, 0.3, 0.2]))).pattern();
    pattern.panels[0].onto_body = Some(0.01);
    let e = pattern.build().unwrap_err().to_string();
    assert!(e.contains("panel[0].placement") && e.contains("needs a cylinder or a cone"), "{e}");
    let dir = crate::scratch_dir("onto-body-no-obstacle");
    std::fs::write(dir.join("pattern.toml"), format!("edge_length = 0.05\n{}", cylinder(", onto_body = 0.01")))
        .unwrap();
    let scene = "name = \"wrap\"\n[pattern]\nfile = \"pattern.toml\"\n[material]\npreset = \"paper-cotton\"\n\
                 [time]\ndt = 0.01\nsteps = 1\n";
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    let e = flexsurf::scene::load(&dir.join("scene.toml")).unwrap_err().to_string();
    assert!(e.contains("pattern.toml") && e.contains("panel[0].placement") && e.contains("has none"), "{e}");
}

/// A row wrapped onto two bodies side by side (two legs: spheres of radius 0.08 m at `x = ±0.12` m, offset
/// 0.01 m) is pulled taut across the gap between them: the front of the row, wrapped from a cylinder of 0.35 m,
/// lies on the two offset circles' common tangent `y = −0.09` m between them (the node straight in front, whose
/// line passes between the legs, included), and no two neighbours are farther apart than on the cylinder.
#[test]
fn a_row_wrapped_onto_two_bodies_is_taut_across_the_gap() {
    use flexsurf::contact::Obstacle;
    use flexsurf::garment::wrap::wrap_onto_body;
    let legs = [-0.12, 0.12].map(|x| Obstacle::Sphere { center: Vec3::new(x, 0.0, 0.0), radius: 0.08 });
    let m = 49; // angles −150° … −30° every 2.5°
    let grid = Grid::sheet(m, 3, 0.3, 0.01).unwrap();
    let placement = Placement::Cylinder { axis: [0.0, 0.0], radius: 0.35, angle: 0.0, height: 0.0, center: [0.0, 0.0] };
    let angle = |i: usize| (-150.0 + 2.5 * i as f64).to_radians();
    let mut x: Vec<Vec3> = (0..3 * m)
        .map(|k| Vec3::new(0.35 * angle(k % m).cos(), 0.35 * angle(k % m).sin(), 0.001 * (k / m) as f64))
        .collect();
    wrap_onto_body(&mut x, &grid, &placement, 0.01, &legs);
    let front = &x[..m];
    let straight = front[m / 2];
    assert!(straight.x.abs() < 1e-12 && (straight.y + 0.09).abs() < 5e-4, "straight in front: {straight:?}");
    for p in front.iter().filter(|p| p.x.abs() < 0.11) {
        assert!((p.y + 0.09).abs() < 5e-4, "{p:?} is off the tangent between the legs");
    }
    let step = front.windows(2).map(|w| (w[1] - w[0]).length()).fold(0.0, f64::max);
    assert!(step < 0.35 * 2.5f64.to_radians(), "neighbours {step} m apart");
}

/// A seam whose two edges are pulled together through a wall of cloth held in place (a pinned panel between
/// them, as a layer caught between a seam's edges) is let out, not pushed through: the springs press the
/// edges onto the wall harder than its self-contact holds, and each step that the contact cannot take lets the
/// gradual closing out by a few closings ([`flexsurf::garment::sewing::BACK_OFF`]) instead of failing the
/// phase; no frame ever crosses, and the seam stays open across the wall when the steps run out.
#[test]
fn a_seam_pulled_through_a_layer_of_cloth_is_let_out_not_pushed_through() {
    let wall = rectangle("wall", [-0.35, -0.1, 0.35, 0.1]).replace(
        "placement = { flat = {} }",
        "placement = { cylinder = { axis = [-99.96, 0.0], radius = 100.0, angle_deg = 0.0, height = 0.0, center = [0.0, 0.0] } }",
    );
    let built = build(&two_halves(0.08, &wall));
    let (l, r, w) = (&built.panels[0], &built.panels[1], &built.panels[2]);
    let (mut builder, x0) = open_panels(&built);
    let wall_nodes = l.grid.len() + r.grid.len()..builder.pinned.len();
    builder.pinned[wall_nodes.clone()].iter_mut().for_each(|p| *p = true);
    builder.self_contact = Some(SelfContactParams::frictionless(2e4, 0.004));
    assert!(w.placed.iter().all(|p| (p.x - 0.04).abs() < 1e-3), "the wall is not the plane x = 0.04");
    let params = SewingParams { stiffness: 100.0, dt: 0.01, steps: 40, gap: 5e-4, closing: Some(0.005) };
    let (mut frames, mut sides) = (0, (0.0, 0.0));
    let mut observe = |model: &Model, x: &[Vec3]| {
        let same = identified(x.len(), model.potential.find::<Sewing>().unwrap().node_pairs());
        let crossing = intersecting_triangles_joined(&model.faces().triangles, x, |k| same[k]);
        assert!(crossing.is_none(), "frame {frames}: triangles {crossing:?} intersect");
        let pairs = model.potential.find::<Sewing>().unwrap().node_pairs();
        sides.0 = pairs.iter().map(|&(a, _)| x[a].x).fold(f64::MIN, f64::max);
        sides.1 = pairs.iter().map(|&(_, b)| x[b].x).fold(f64::MAX, f64::min);
        frames += 1;
    };
    let sewn = sew_observed(&builder, &built.seams, x0, &[], &params, &mut observe).unwrap();
    eprintln!("seam through a wall: {:?}", sewn.report);
    assert!(sewn.report.backoffs > 0, "never let out: {:?}", sewn.report);
    assert_eq!((frames, sewn.report.steps), (41, 40));
    // Each edge on its own side of the wall (the joined node is the pair's midpoint, so look at the open
    // panels' last frame through the report's gap: the pairs are held about the layer's compressed thickness
    // apart), and the gap no smaller than that.
    assert!(sewn.report.largest_gap() > 0.002, "the seam closed through the wall: {:?}", sewn.report);
    assert!(sides.0 < 0.04 && sides.1 > 0.04, "an edge went through the wall: {sides:?}");
}

/// A row that meets the body along one line only (a narrow post in front of one node) keeps that node's traced
/// point and leaves the others on the cylinder; nothing falls onto the axis.
#[test]
fn a_row_meeting_the_body_once_moves_only_that_node() {
    use flexsurf::contact::Obstacle;
    use flexsurf::garment::wrap::wrap_onto_body;
    // A sphere of 1 cm at 0.2 m along +x: only the line of the node at angle 0 meets its 2 cm offset sphere.
    let post = [Obstacle::Sphere { center: Vec3::new(0.2, 0.0, 0.0), radius: 0.01 }];
    let grid = Grid::sheet(5, 3, 0.3, 0.01).unwrap();
    let placement = Placement::Cylinder { axis: [0.0, 0.0], radius: 0.35, angle: 0.0, height: 0.0, center: [0.0, 0.0] };
    let angle = |i: usize| -0.6 + 0.3 * i as f64;
    let before: Vec<Vec3> = (0..15)
        .map(|k| Vec3::new(0.35 * angle(k % 5).cos(), 0.35 * angle(k % 5).sin(), 0.001 * (k / 5) as f64))
        .collect();
    let mut x = before.clone();
    assert_eq!(wrap_onto_body(&mut x, &grid, &placement, 0.01, &post), 3);
    for (k, (p, q)) in x.iter().zip(&before).enumerate() {
        if k % 5 == 2 {
            assert!((p.x.hypot(p.y) - (0.2 + (0.02f64.powi(2) - q.z * q.z).sqrt())).abs() < 2e-5, "{p:?}");
        } else {
            assert_eq!(p, q);
        }
    }
}

/// A sewing phase whose steps run out before the seams close warns, naming `pattern.sewing_steps`, the seam, its
/// gap at the join and `sewing_gap`; one that closes does not.
#[test]
fn seams_joined_open_when_the_steps_run_out_are_a_warning() {
    let dir = crate::scratch_dir("sewing-open");
    std::fs::write(dir.join("pattern.toml"), two_halves(0.04, "")).unwrap();
    let scene = |steps: usize| {
        format!(
            "name = \"open\"\n[pattern]\nfile = \"pattern.toml\"\nsewing_stiffness = 100.0\nsewing_steps = {steps}\n\
             sewing_gap = 0.0005\nsewing_closing = 0.005\n[material]\npreset = \"paper-cotton\"\n[time]\ndt = 0.01\n\
             steps = 1\n[self_contact]\nthickness = 0.004\n"
        )
    };
    for (steps, warned) in [(3, true), (200, false)] {
        std::fs::write(dir.join("scene.toml"), scene(steps)).unwrap();
        let built = flexsurf::scene::load(&dir.join("scene.toml")).unwrap();
        let warning = built.warnings.iter().find(|w| w.key.contains("sewing_steps"));
        assert_eq!(warning.is_some(), warned, "{steps} steps: {:?}", built.warnings);
        if let Some(w) = warning {
            let text = w.to_string();
            assert!(text.contains("did not close in 3 sewing steps") && text.contains("seam 0"), "{text}");
            assert!(text.contains("`sewing_gap` 0.50 mm"), "{text}");
        }
    }
}

/// A trapezoid (straight sides, so its Coons grid is not uniform) built at two edge lengths.
fn trapezoid(edge: f64) -> BuiltPattern {
    let text = format!(
        "edge_length = {edge:?}\n[[panel]]\nname = \"t\"\ngrain = [1.0, 0.0]\noutline = [\n  {{ at = [0.0, 0.0], \
         corner = \"a\" }},\n  {{ at = [0.5, 0.0], corner = \"b\" }},\n  {{ at = [0.4, 0.3], corner = \"c\" }},\n  \
         {{ at = [0.05, 0.35], corner = \"d\" }},\n]\nplacement = {{ flat = {{}} }}\n"
    );
    build(&text)
}

/// An affine map of the plane into space: a rotation, a shear and a shift.
fn affine(p: Vec3) -> Vec3 {
    Vec3::new(0.3 + 0.6 * p.x - 0.8 * p.y, -0.2 + 0.8 * p.x + 0.6 * p.y + 0.1 * p.x, 1.0 + 0.5 * p.x - 0.25 * p.y)
}

/// Carrying a coarse grid's shape onto a fine grid of the same pattern interpolates on the coarse triangles, so
/// an affine shape (which every triangle carries exactly) comes out as the same affine map of the fine grid's
/// flat nodes; a fine panel that is not on the coarse one, or another count of panels, is an error.
#[test]
fn a_shape_carried_from_a_coarse_grid_keeps_an_affine_map() {
    use flexsurf::garment::carry::{carry, CarryError};
    let (coarse, fine) = (trapezoid(0.1), trapezoid(0.013));
    assert!(fine.panels[0].grid.len() > 20 * coarse.panels[0].grid.len());
    let shape: Vec<Vec3> = coarse.panels[0].flat.iter().map(|&p| affine(p)).collect();
    let carried = carry(&coarse.panels, std::slice::from_ref(&shape), &fine.panels, &[]).unwrap();
    let worst = carried.iter().zip(&fine.panels[0].flat).map(|(x, &p)| (*x - affine(p)).length()).fold(0.0, f64::max);
    assert!(worst < 1e-13, "carried {worst} m off the affine map");
    // Back onto itself: every node is a corner of its own cell.
    let same = carry(&coarse.panels, std::slice::from_ref(&shape), &coarse.panels, &[]).unwrap();
    assert!(same.iter().zip(&shape).all(|(a, b)| (*a - *b).length() < 1e-15));
    let mut moved = fine.clone();
    moved.panels[0].flat.iter_mut().for_each(|p| p.x += 0.2);
    let outside = carry(&coarse.panels, std::slice::from_ref(&shape), &moved.panels, &[]).unwrap_err();
    assert!(matches!(outside, CarryError::Outside { .. }), "{outside}");
    assert!(outside.to_string().contains("panel `t`"), "{outside}");
    let count = carry(&coarse.panels, &[shape], &[], &[]).unwrap_err();
    assert_eq!(count, CarryError::Panels { coarse: 1, fine: 0 });
}

/// A scene that sews on a coarser grid (`sewing_edge_length`) drapes on the pattern's grid at the scene's
/// `edge_length`: the model has the fine grid's nodes, the report the coarse ones, and the fine seam starts
/// closed; sewn on a grid of the pattern's own edge length, the garment is the one sewn on it directly.
#[test]
fn a_garment_sewn_on_a_coarse_grid_drapes_on_the_fine_one() {
    let dir = crate::scratch_dir("sewing-coarse");
    std::fs::write(dir.join("pattern.toml"), two_halves(0.04, "")).unwrap();
    let scene = |extra: &str| {
        format!(
            "name = \"coarse\"\n[pattern]\nfile = \"pattern.toml\"\nsewing_stiffness = 100.0\nsewing_steps = 200\n\
             sewing_gap = 0.0005\nsewing_closing = 0.005\n{extra}\n[material]\npreset = \"paper-cotton\"\n[time]\n\
             dt = 0.01\nsteps = 1\n[self_contact]\nthickness = 0.004\n"
        )
    };
    let load = |extra: &str| {
        std::fs::write(dir.join("scene.toml"), scene(extra)).unwrap();
        flexsurf::scene::load(&dir.join("scene.toml")).unwrap()
    };
    let coarse = load("edge_length = 0.025\nsewing_edge_length = 0.05");
    let sewing = coarse.sewing.as_ref().unwrap();
    // Two halves of 13 × 25 nodes sewn along 25 pairs: 625; sewn on 7 × 13 each.
    assert_eq!((coarse.model.nodes(), sewing.report.nodes), (625, 182));
    assert!(sewing.report.largest_gap() < 1e-9, "carried gap {}", sewing.report.largest_gap());
    assert!(coarse.state.x.iter().all(|p| p.z == 0.0), "sewn in the plane");
    let direct = load("");
    let same = load("sewing_edge_length = 0.05");
    assert_eq!(same.model.nodes(), direct.model.nodes());
    let apart = same.state.x.iter().zip(&direct.state.x).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    assert!(apart < 1e-12, "sewn on the same grid, {apart} m apart");
    std::fs::write(dir.join("scene.toml"), scene("sewing_edge_length = 0.05") + "[[pin]]\nnodes = [[0, 0]]\n").unwrap();
    let e = flexsurf::scene::load(&dir.join("scene.toml")).unwrap_err().to_string();
    assert!(e.contains("pattern.sewing_edge_length") && e.contains("[[pin]]"), "{e}");
    for (extra, what) in [
        ("sewing_edge_length = 0.02", "below the grid's edge_length 0.05 m"),
        ("sewing_edge_length = -1.0", "must be a positive length"),
        ("edge_length = 0.0", "must be a positive length"),
    ] {
        std::fs::write(dir.join("scene.toml"), scene(extra)).unwrap();
        let e = flexsurf::scene::load(&dir.join("scene.toml")).unwrap_err().to_string();
        assert!(e.contains("scene.toml") && e.contains(what) && !e.contains('\n'), "{extra}: {e}");
    }
}

/// Carried onto a finer grid, a coarse shape whose nodes lie 2 mm outside a ball (its cells' chords cutting
/// up to a few millimetres closer) keeps every fine node at least those 2 mm out: a node nearer to the ball than
/// its cell's corners is moved out along the ball's normal. Without the ball the chords come closer.
#[test]
fn a_carried_node_is_no_nearer_to_the_body_than_its_coarse_cell() {
    use flexsurf::contact::Obstacle;
    use flexsurf::garment::carry::carry;
    let (coarse, fine) = (trapezoid(0.1), trapezoid(0.013));
    let (center, radius, clearance) = (Vec3::new(0.2, 0.15, -0.3), 0.3, 0.002);
    // The flat panel (z = 0) pushed radially onto the sphere of radius + clearance about the centre.
    let onto = |p: Vec3| center + (p - center).normalize() * (radius + clearance);
    let shape: Vec<Vec3> = coarse.panels[0].flat.iter().map(|&p| onto(p)).collect();
    let ball = [Obstacle::Sphere { center, radius }];
    let gap = |x: &[Vec3]| x.iter().map(|p| (*p - center).length() - radius).fold(f64::INFINITY, f64::min);
    let plain = carry(&coarse.panels, std::slice::from_ref(&shape), &fine.panels, &[]).unwrap();
    let lifted = carry(&coarse.panels, std::slice::from_ref(&shape), &fine.panels, &ball).unwrap();
    // A 0.1 m chord of a 0.302 m sphere sags 4.1 mm: the plain carry comes well inside the clearance.
    assert!(gap(&plain) < 0.0, "chords {} m from the ball", gap(&plain));
    assert!((gap(&lifted) - clearance).abs() < 1e-12, "lifted {} m from the ball", gap(&lifted));
    let moved = plain.iter().zip(&lifted).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    assert!(moved < 0.01, "moved {moved} m");
}
