//! Seams (issue 18): edges joined node to node. A periodic direction written as a free grid whose first and
//! last node rows are seamed is the periodic grid (the skirt on the mannequin, 60 steps with contact and
//! friction); two flat sheets sewn along an edge are the one sheet of their union, whether the second is given
//! in place or cut out elsewhere and turned (the seam lays it back flat); the seam's bending term, with nodes
//! joined inside its stencils, through the shared finite-difference checker; and a seam that cannot be made is
//! an error naming it.

use crate::common::largest_difference;
use flexsurf::contact::Obstacle;
use flexsurf::energy::Operator;
use flexsurf::grid::{Grid, Topology};
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{ElasticOptions, Model, ModelBuilder, ModelKind, Spring};
use flexsurf::potential::contact::ContactParams;
use flexsurf::seam::{Edge, Seam, SeamSide};
use flexsurf::state::State;
use flexsurf::testing::{check, perturbed, repo};
use std::f64::consts::FRAC_PI_2;

const G: Vec3 = Vec3::new(0.0, 0.0, -9.81);

fn side(panel: usize, edge: Edge) -> SeamSide {
    SeamSide::whole(panel, edge, false)
}

/// Steps `model` from `x` at rest for `steps` steps of `dt`.
fn run(model: &Model, x: Vec<Vec3>, dt: f64, steps: usize) -> State {
    let v = vec![Vec3::ZERO; x.len()];
    let mut state = flexsurf::integrate::start(model, x, v, dt).unwrap();
    let mut stepper = Stepper::new(model, &StepParams::with_dt(dt)).unwrap();
    for _ in 0..steps {
        stepper.step(model, &mut state).unwrap();
    }
    state
}

/// The periodic skirt of `scenes/skirt.toml` (28 around × 14 down on the mannequin, waist springs, contact
/// with friction) against the same skirt on a free grid of 29 × 14 nodes whose last generatrix is seamed to
/// its first: 40 steps (0.4 s, the skirt swings onto the hips) agree to the solver's tolerance. (Over 60
/// steps the round-off the two orderings leave, 1e-11 m, grows to millimetres: an unconverged contact step
/// amplifies it by up to 50 a step where its contact and friction decisions come out differently; docs/model.md
/// §8.5.)
#[test]
fn periodic_skirt_equals_the_seamed_free_grid() {
    let scene = flexsurf::scene::load(&repo().join("scenes/skirt.toml")).unwrap();
    let m0 = &scene.model;
    let grid = m0.panels[0].grid;
    assert!(grid.periodic(0));
    let (m, n) = (grid.m, grid.n);
    let options = ElasticOptions { warp_angle: FRAC_PI_2, flat_pattern: true, ..Default::default() };
    let builder = |grid: Grid, rest: Vec<Vec3>, springs: Vec<Spring>| {
        let mut b = ModelBuilder::new(grid, rest, m0.fabric, m0.stiffness, m0.kind, m0.gravity).options(options);
        b.obstacles = m0.obstacles();
        b.contact = m0.contact_params().unwrap();
        b.springs = springs;
        b
    };
    let periodic = builder(grid, m0.panels[0].rest().to_vec(), m0.springs()).build().unwrap();
    // The free grid: generatrix i < m is the periodic grid's i, generatrix m repeats generatrix 0.
    let free = Grid::new(m + 1, n, grid.h1, grid.h2, [Topology::Free; 2]).unwrap();
    let widen = |v: &[Vec3]| -> Vec<Vec3> {
        (0..free.len())
            .map(|k| {
                let (i, j) = free.coords(k);
                v[grid.index(i % m, j)]
            })
            .collect()
    };
    let springs = m0.springs().iter().map(|s| Spring { node: free.index(grid.coords(s.node).0, 0), ..*s }).collect();
    let seamed = builder(free, widen(m0.panels[0].rest()), springs)
        .seam(Seam { a: side(0, Edge::U1Start), b: side(0, Edge::U1End) })
        .build()
        .unwrap();
    // The joined generatrix takes the first one's numbers: the model's nodes are the periodic grid's.
    assert_eq!(seamed.nodes(), periodic.nodes());
    assert_eq!(
        (0..n).map(|j| seamed.panels[0].global(free.index(m, j))).collect::<Vec<_>>(),
        (0..n).map(|j| grid.index(0, j)).collect::<Vec<_>>()
    );
    for (a, b) in periodic.mass.iter().zip(&seamed.mass) {
        assert!((a - b).abs() <= 1e-15 * a, "masses {a} and {b}");
    }
    let x0 = scene.state.x.clone();
    assert_eq!(seamed.from_panel_nodes(&widen(&x0)), x0);
    let (dt, steps) = (scene.dt, 40);
    let a = run(&periodic, x0.clone(), dt, steps);
    let b = run(&seamed, x0.clone(), dt, steps);
    let moved = largest_difference(&a.x, &x0);
    let apart = largest_difference(&a.x, &b.x);
    assert!(moved > 0.05, "the skirt should swing (moved {moved} m)");
    assert!(apart < 1e-9, "the seamed skirt is {apart} m from the periodic one (moved {moved} m)");
    let ea = periodic.elastic(&a.x, None);
    let eb = seamed.elastic(&b.x, None);
    assert!((ea.bending - eb.bending).abs() < 1e-6 * ea.bending, "bending {} vs {}", ea.bending, eb.bending);
}

fn cotton() -> (Fabric, Stiffness) {
    let fabric = Fabric::paper_cotton();
    (fabric, Stiffness::calibrate(&fabric, Calibration::Kes).unwrap())
}

/// A ball under a sheet of 0.6 × 0.6 m centred on the origin, 5 cm above it.
fn over_ball(builder: &mut ModelBuilder) {
    builder.obstacles.push(Obstacle::Sphere { center: Vec3::new(0.05, -0.03, -0.3), radius: 0.25 });
    builder.contact = ContactParams { stiffness: 1e4, offset: 0.004, friction: 0.3, ..ContactParams::default() };
}

/// A 0.6 m square of 13 × 13 nodes, bent into a shallow curve so that bending carries across the seam.
fn square() -> (Grid, Vec<Vec3>) {
    let grid = Grid::sheet(13, 13, 0.6, 0.6).unwrap();
    let rest = grid.flat_positions(0.0);
    (grid, rest)
}

fn curved(p: Vec3) -> Vec3 {
    Vec3::new(p.x, p.y, 0.05 + 0.4 * p.x * p.x - 0.2 * p.x * p.y)
}

/// Two halves of the square, 13 × 7 nodes each, joined along the square's middle column of nodes (the
/// left half's `u1` end to the right half's `u1` start), equal the square: the right half given in place, or
/// cut out elsewhere (moved and turned in its plane), which the seam lays back flat.
/// Two halves (`half`, 7 columns each) of the square `grid` sewn along the middle column, started from the whole
/// sheet's start `x0` and run 40 steps of 5 ms: the largest distance of a node from the whole sheet's `reference`
/// (panel nodes onto the model's: the left half's, then the right half's own, its first column joined).
fn sewn_apart_from_whole(sewn: &Model, (grid, half): (Grid, Grid), x0: &[Vec3], reference: &State) -> f64 {
    let order: Vec<usize> = (0..2 * half.len())
        .map(|k| {
            let (p, k) = (k / half.len(), k % half.len());
            let (i, j) = half.coords(k);
            grid.index(6 * p + i, j)
        })
        .collect();
    let start: Vec<Vec3> = sewn.from_panel_nodes(&order.iter().map(|&k| x0[k]).collect::<Vec<_>>());
    let state = run(sewn, start, 0.005, 40);
    (0..2 * half.len())
        .map(|k| {
            let (p, l) = (k / half.len(), k % half.len());
            (state.x[sewn.panels[p].global(l)] - reference.x[order[k]]).length()
        })
        .fold(0.0, f64::max)
}

#[test]
fn two_sewn_halves_equal_the_whole_sheet() {
    let (fabric, stiffness) = cotton();
    let (grid, rest) = square();
    let mut whole = ModelBuilder::new(grid, rest.clone(), fabric, stiffness, ModelKind::Tfs, G);
    over_ball(&mut whole);
    let whole = whole.build().unwrap();
    let half = Grid::sheet(7, 13, 0.3, 0.6).unwrap();
    let part = |i0: usize| -> Vec<Vec3> {
        (0..half.len())
            .map(|k| {
                let (i, j) = half.coords(k);
                rest[grid.index(i0 + i, j)]
            })
            .collect()
    };
    let (left, right) = (part(0), part(6));
    // The right half cut out 2 m away and turned by 2 rad in the plane.
    let (c, s) = (2.0_f64.cos(), 2.0_f64.sin());
    let elsewhere: Vec<Vec3> =
        right.iter().map(|p| Vec3::new(c * p.x - s * p.y + 2.0, s * p.x + c * p.y - 1.0, 0.0)).collect();
    let x0: Vec<Vec3> = rest.iter().map(|p| curved(*p)).collect();
    let reference = run(&whole, x0.clone(), 0.005, 40);
    for right_rest in [right.clone(), elsewhere] {
        let mut sewn = ModelBuilder::new(half, left.clone(), fabric, stiffness, ModelKind::Tfs, G)
            .panel(half, right_rest, ElasticOptions::default())
            .seam(Seam { a: side(0, Edge::U1End), b: side(1, Edge::U1Start) });
        over_ball(&mut sewn);
        let sewn = sewn.build().unwrap();
        assert_eq!(sewn.nodes(), whole.nodes());
        let apart = sewn_apart_from_whole(&sewn, (grid, half), &x0, &reference);
        let moved = largest_difference(&reference.x, &x0);
        assert!(moved > 0.01, "the sheet should fall onto the ball (moved {moved} m)");
        assert!(apart < 1e-10, "the sewn halves are {apart} m from the whole sheet");
    }
}

/// The seam's bending points, with nodes joined inside their stencils (a closed band of four generatrices,
/// the narrowest a seam allows), match finite differences.
#[test]
fn seam_bending_matches_finite_differences() {
    let (fabric, stiffness) = cotton();
    for (count, warp) in [(4, 0.0), (4, 0.5), (7, 0.3)] {
        let free = Grid::new(count, 5, 0.1, 0.08, [Topology::Free; 2]).unwrap();
        let radius = 0.1 * (count - 1) as f64 / std::f64::consts::TAU;
        let rest: Vec<Vec3> = (0..free.len())
            .map(|k| {
                let (i, j) = free.coords(k);
                let a = std::f64::consts::TAU * i as f64 / (count - 1) as f64;
                Vec3::new(radius * a.cos(), radius * a.sin(), 0.08 * j as f64)
            })
            .collect();
        let options = ElasticOptions { warp_angle: warp, ..Default::default() };
        let model = ModelBuilder::new(free, rest.clone(), fabric, stiffness, ModelKind::Tfs, G)
            .options(options)
            .seam(Seam { a: side(0, Edge::U1End), b: side(0, Edge::U1Start) })
            .build()
            .unwrap();
        let x = perturbed(&model.from_panel_nodes(&rest), 0.01, 7);
        let seam_term = model.potential.terms().iter().filter(|t| t.info().name == "bending").count();
        assert_eq!(seam_term, 2, "the panel's bending and the seam's");
        check(&model.potential, &x, None, None, Operator::Exact)
            .assert_below(&format!("seamed band {count} {warp}"), 1e-6);
    }
}

/// A seam that cannot be made is an error of the builder's `seams`, naming the seam and what is wrong.
#[test]
fn a_bad_seam_is_an_error_naming_it() {
    let (fabric, stiffness) = cotton();
    let a = Grid::sheet(5, 4, 0.4, 0.3).unwrap();
    let b = Grid::new(5, 4, 0.1, 0.1, [Topology::Periodic, Topology::Free]).unwrap();
    let two = || {
        ModelBuilder::new(a, a.flat_positions(0.0), fabric, stiffness, ModelKind::Tfs, G).panel(
            b,
            b.flat_positions(1.0),
            ElasticOptions::default(),
        )
    };
    let square = Grid::sheet(4, 4, 0.3, 0.3).unwrap();
    let folded = ModelBuilder::new(square, square.flat_positions(0.0), fabric, stiffness, ModelKind::Tfs, G);
    let cases = [
        (two(), Seam { a: side(0, Edge::U1End), b: side(0, Edge::U2End) }, "4 and 5 nodes"),
        (two(), Seam { a: side(0, Edge::U1End), b: side(1, Edge::U1Start) }, "periodic"),
        (two(), Seam { a: side(0, Edge::U1End), b: side(2, Edge::U1Start) }, "panel 2 does not exist"),
        (two(), Seam { a: side(0, Edge::U2End), b: side(0, Edge::U2End) }, "itself"),
        (folded, Seam { a: side(0, Edge::U1Start), b: side(0, Edge::U2Start) }, "corners of cell (0, 0)"),
    ];
    for (builder, seam, words) in cases {
        let e = builder.seam(seam).build().unwrap_err();
        assert_eq!(e.field, "seams");
        assert!(e.message.contains(words) && e.message.contains("seam 0"), "{e} should say {words:?}");
    }
}

/// The bending hysteresis (2HB, docs/model.md §4.6) on seams: the two sewn halves of the curved square, with a
/// loop width of 2HB = 2e-4 N in both directions, fall as the whole square with the same hysteresis (40 steps,
/// to 1e-10 m), while the whole square without hysteresis ends 4 mm away (asserted above 10 µm): the seam puts
/// back the hysteresis of the bending points it puts back, and the panels leave theirs out.
#[test]
fn sewn_halves_carry_the_bending_hysteresis_of_the_whole_sheet() {
    use flexsurf::material::law::Laws;
    let (fabric, stiffness) = cotton();
    let (grid, rest) = square();
    let laws = std::sync::Arc::new(Laws { hysteresis: [2e-4, 2e-4, 0.0], ..Laws::default() });
    let with_laws = |mut b: ModelBuilder| {
        b.laws = Some(laws.clone());
        b.build().unwrap()
    };
    let whole = with_laws(ModelBuilder::new(grid, rest.clone(), fabric, stiffness, ModelKind::Tfs, G));
    let plain = ModelBuilder::new(grid, rest.clone(), fabric, stiffness, ModelKind::Tfs, G).build().unwrap();
    let half = Grid::sheet(7, 13, 0.3, 0.6).unwrap();
    let part = |i0: usize| -> Vec<Vec3> {
        (0..half.len()).map(|k| rest[grid.index(i0 + half.coords(k).0, half.coords(k).1)]).collect()
    };
    let sewn = with_laws(
        ModelBuilder::new(half, part(0), fabric, stiffness, ModelKind::Tfs, G)
            .panel(half, part(6), ElasticOptions::default())
            .seam(Seam { a: side(0, Edge::U1End), b: side(1, Edge::U1Start) }),
    );
    let x0: Vec<Vec3> = rest.iter().map(|p| curved(*p)).collect();
    let reference = run(&whole, x0.clone(), 0.005, 40);
    let without = run(&plain, x0.clone(), 0.005, 40);
    let apart = sewn_apart_from_whole(&sewn, (grid, half), &x0, &reference);
    let acts = largest_difference(&reference.x, &without.x);
    eprintln!("sewn vs whole {apart:e} m; with vs without hysteresis {acts:e} m");
    assert!(acts > 1e-5, "the hysteresis should act (with and without: {acts} m apart)");
    assert!(apart < 1e-10, "the sewn halves are {apart} m from the whole sheet");
}
