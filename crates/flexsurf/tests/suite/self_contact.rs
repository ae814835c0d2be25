//! Self-collision (issue 19): the sheet never passes through itself or another panel. Checked on every step
//! by an exact triangle–triangle intersection test written apart from the contact code
//! (`flexsurf::testing::intersecting_triangles`, exact orientation predicates): a sheet that falls onto the
//! floor edge first and folds onto itself (intersecting without self-contact, never with it, at Δt = 0.01 s
//! and 0.1 s); sheets stacked on the floor rest a thickness apart; two sheets thrown at each other in free
//! flight keep their linear momentum; the term through the shared finite-difference checker.

use flexsurf::contact::Obstacle;
use flexsurf::energy::Operator;
use flexsurf::grid::Grid;
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{ElasticOptions, Model, ModelBuilder, ModelKind};
use flexsurf::potential::contact::ContactParams;
use flexsurf::potential::self_contact::{SelfContact, SelfContactParams};
use flexsurf::state::State;
use flexsurf::testing::{alone, check, intersecting_triangles};

const G: Vec3 = Vec3::new(0.0, 0.0, -9.81);
const THICKNESS: f64 = 0.005;

fn cotton() -> (Fabric, Stiffness) {
    let fabric = Fabric::paper_cotton();
    (fabric, Stiffness::calibrate(&fabric, Calibration::Kes).unwrap())
}

fn on_floor(b: &mut ModelBuilder, friction: f64) {
    b.obstacles.push(Obstacle::Plane { point: Vec3::ZERO, normal: Vec3::Z });
    b.contact = ContactParams { stiffness: 2e4, offset: 0.004, friction, ..ContactParams::default() };
}

fn self_contact(b: &mut ModelBuilder) {
    b.self_contact = Some(SelfContactParams { stiffness: 2e4, thickness: THICKNESS });
}

/// The first step whose state has intersecting triangles, and the pair.
type Hit = Option<(usize, (usize, usize))>;

/// Steps `model` from `state` for `steps` steps of `dt`, checking every step for intersecting triangles;
/// returns the first step with one (or `None`) and the final state.
fn run_checked(model: &Model, mut state: State, dt: f64, steps: usize) -> (Hit, State) {
    let tris = model.faces().triangles;
    let mut stepper = Stepper::new(model, &StepParams::with_dt(dt)).unwrap();
    for step in 1..=steps {
        stepper.step(model, &mut state).unwrap();
        if let Some(pair) = intersecting_triangles(&tris, &state.x) {
            return (Some((step, pair)), state);
        }
    }
    (None, state)
}

/// A 0.6 m square sheet of 21 × 21 nodes standing on its lower edge (leaning a little), 1 cm above a floor with
/// friction: it collapses under its weight and crumples onto itself in a pile.
fn standing_sheet(with_self_contact: bool, dt: f64) -> (Model, State) {
    let (fabric, stiffness) = cotton();
    let grid = Grid::sheet(21, 21, 0.6, 0.6).unwrap();
    let rest: Vec<Vec3> =
        grid.flat_positions(0.0).iter().map(|p| Vec3::new(p.x, 0.15 * (p.y + 0.3), 0.31 + p.y)).collect();
    let mut b = ModelBuilder::new(grid, rest.clone(), fabric, stiffness, ModelKind::Tfs, G);
    on_floor(&mut b, 0.8);
    if with_self_contact {
        self_contact(&mut b);
    }
    let model = b.build().unwrap();
    let state = flexsurf::integrate::start(&model, rest.clone(), vec![Vec3::ZERO; rest.len()], dt).unwrap();
    (model, state)
}

#[test]
fn a_sheet_folding_onto_itself_never_intersects() {
    // Without self-contact the sheet passes through itself: the scene tests what it should.
    for dt in [0.01, 0.1] {
        let steps = (2.0 / dt) as usize;
        let (model, state) = standing_sheet(false, dt);
        let (hit, _) = run_checked(&model, state, dt, steps);
        assert!(hit.is_some(), "Δt = {dt}: without self-contact the collapsing sheet should intersect itself");
        let (model, state) = standing_sheet(true, dt);
        let (hit, end) = run_checked(&model, state, dt, steps);
        assert!(
            hit.is_none(),
            "Δt = {dt}: triangles {:?} intersect at step {}",
            hit.map(|h| h.1),
            hit.map_or(0, |h| h.0)
        );
        // The layers lie on each other: pairs of the surface within twice the thickness, none closer than a
        // tenth of it.
        let faces = model.potential.find::<SelfContact>().unwrap().faces();
        let close = faces.close(&end.x, 2.0 * THICKNESS);
        assert!(close.len() > 20, "Δt = {dt}: only {} close pairs: the sheet did not fold onto itself", close.len());
        let nearest = close.iter().map(|c| c.distance()).fold(f64::INFINITY, f64::min);
        assert!(nearest > 0.1 * THICKNESS, "Δt = {dt}: two layers {nearest:e} m apart");
    }
}

/// Three 0.3 m sheets dropped flat onto the floor, one above the other: at rest the k-th lies a contact
/// thickness above the one below (within 10 % of the thickness), the first at the floor's contact offset.
#[test]
fn stacked_sheets_rest_a_thickness_apart() {
    let (fabric, stiffness) = cotton();
    let grid = Grid::sheet(11, 11, 0.3, 0.3).unwrap();
    let flat = grid.flat_positions(0.0);
    let at =
        |z: f64, shift: f64| -> Vec<Vec3> { flat.iter().map(|p| Vec3::new(p.x + shift, p.y - shift, z)).collect() };
    let heights = [0.012, 0.024, 0.036];
    let mut b = ModelBuilder::new(grid, at(heights[0], 0.0), fabric, stiffness, ModelKind::Tfs, G);
    for (k, &z) in heights.iter().enumerate().skip(1) {
        b = b.panel(grid, at(z, 0.004 * k as f64), ElasticOptions::default());
    }
    on_floor(&mut b, 0.3);
    self_contact(&mut b);
    let model = b.build().unwrap();
    let x0 = model.rest.clone();
    let state = flexsurf::integrate::start(&model, x0, vec![Vec3::ZERO; model.nodes()], 0.01).unwrap();
    let (hit, end) = run_checked(&model, state, 0.01, 150);
    assert!(hit.is_none(), "{hit:?}");
    let centre = |p: usize| end.x[model.panels[p].global(grid.index(5, 5))].z;
    let offset = model.contact_params().unwrap().offset;
    assert!((centre(0) - offset).abs() < 0.1 * THICKNESS, "first sheet at {}", centre(0));
    for p in 1..3 {
        let gap = centre(p) - centre(p - 1);
        assert!((gap - THICKNESS).abs() < 0.1 * THICKNESS, "sheet {p} lies {gap} m above sheet {}", p - 1);
    }
}

/// Two sheets thrown at each other without gravity collide through self-contact and part: the total linear
/// momentum is what it was, to round-off of the solves.
#[test]
fn colliding_sheets_keep_their_momentum() {
    let (mut fabric, stiffness) = cotton();
    // No damping: it would be an external force (against the air) on each node.
    fabric.damping = 0.0;
    let grid = Grid::sheet(9, 9, 0.2, 0.2).unwrap();
    let flat = grid.flat_positions(0.0);
    let place = |z: f64, tilt: f64| -> Vec<Vec3> { flat.iter().map(|p| Vec3::new(p.x, p.y, z + tilt * p.x)).collect() };
    let mut b = ModelBuilder::new(grid, place(0.0, 0.05), fabric, stiffness, ModelKind::Tfs, Vec3::ZERO).panel(
        grid,
        place(0.03, -0.05),
        ElasticOptions::default(),
    );
    self_contact(&mut b);
    let model = b.build().unwrap();
    let n = grid.len();
    let v: Vec<Vec3> =
        (0..2 * n).map(|k| if k < n { Vec3::new(0.05, 0.0, 0.4) } else { Vec3::new(-0.02, 0.01, -0.3) }).collect();
    let momentum = |s: &State| -> Vec3 { s.v.iter().zip(&model.mass).map(|(v, m)| *v * *m).sum() };
    let scale: f64 = v.iter().zip(&model.mass).map(|(v, m)| v.length() * m).sum();
    let state = flexsurf::integrate::start(&model, model.rest.clone(), v, 0.005).unwrap();
    let p0 = momentum(&state);
    let (hit, end) = run_checked(&model, state, 0.005, 60);
    assert!(hit.is_none(), "{hit:?}");
    let gap = (0..n).map(|k| end.x[n + k].z - end.x[k].z).fold(f64::INFINITY, f64::min);
    assert!(gap > 0.0, "the sheets should have bounced apart (smallest gap {gap})");
    let drift = (momentum(&end) - p0).length();
    assert!(drift < 1e-9 * scale, "momentum changed by {drift:e} of {scale:e}");
}

/// The self-contact term (records of node–face and edge–edge pairs, four-node stencils) through the shared
/// finite-difference checker, on a sheet folded over itself.
#[test]
fn self_contact_matches_finite_differences() {
    let (fabric, stiffness) = cotton();
    let grid = Grid::sheet(7, 5, 0.3, 0.2).unwrap();
    let rest = grid.flat_positions(0.0);
    let mut b = ModelBuilder::new(grid, rest.clone(), fabric, stiffness, ModelKind::Tfs, G);
    self_contact(&mut b);
    let model = b.build().unwrap();
    // Folded at the middle column: the right half above the left, 3 mm over it.
    let x: Vec<Vec3> =
        rest.iter().map(|p| if p.x > 0.0 { Vec3::new(-p.x + 0.01, p.y + 0.003, 0.003) } else { *p }).collect();
    let close = model.potential.find::<SelfContact>().unwrap().faces().close(&x, THICKNESS);
    assert!(close.len() > 5, "the folded sheet should have close pairs");
    // The records' gap is the distance to first order (the closest points are stationary), so the gradient
    // is the distance penalty's exactly; the stiffness is its Gauss–Newton part (the distance's own curvature
    // is dropped, as for obstacles), so only the gradient is compared here.
    let term = model.potential.find::<SelfContact>().unwrap().clone();
    let report = check(&alone(model.nodes(), Box::new(term)), &x, None, None, Operator::Projected);
    assert!(report.gradient_error < 1e-6, "{report:?}");
}
