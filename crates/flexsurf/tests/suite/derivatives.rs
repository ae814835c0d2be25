//! Every term of the total potential through the one shared finite-difference checker (`flexsurf::testing`):
//! membrane and bending (free, periodic, curved rest, warp off the grid, flat pattern), gravity and loads,
//! springs, penalty contact with a plane, a ball, a triangle mesh and the NURBS mannequin, the step's inertia, and
//! the assembled step system. Each named Hessian approximation is tested for what its documentation says it
//! contains (docs/model.md §7).

#![allow(clippy::needless_range_loop)]

use flexsurf::contact::trimesh::TriMeshBody;
use flexsurf::contact::{mannequin, Obstacle};
use flexsurf::energy::bending::Bending;
use flexsurf::energy::frame::Warp;
use flexsurf::energy::membrane::Membrane;
use flexsurf::energy::{Operator, Sink};
use flexsurf::grid::Grid;
use flexsurf::integrate::statics::{StaticError, StaticOptions, StaticSolver};
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric};
use flexsurf::math::{outer, Mat3, Vec3};
use flexsurf::model::{ElasticOptions, Model, ModelBuilder, ModelKind, Spring};
use flexsurf::potential::contact::{ContactParams, PenaltyContact};
use flexsurf::potential::elastic::TerzopoulosBending;
use flexsurf::potential::external::External;
use flexsurf::potential::friction::{FrictionLaw, Lagged};
use flexsurf::potential::inertia::Inertia;
use flexsurf::potential::springs::Springs;
use flexsurf::potential::{Context, Motion, Part, Scratch, Stage, Term, TermInfo};
use flexsurf::state::State;
use flexsurf::testing::{alone, check, cotton, cylinder, eigen_range, hessians, perturbed};
use std::sync::Arc;

const TOL: f64 = 1e-6;

fn exact(name: &str, n: usize, term: Box<dyn Term>, x: &[Vec3]) {
    check(&alone(n, term), x, None, None, Operator::Exact).assert_below(name, TOL);
}

#[test]
fn elastic_terms_match_finite_differences() {
    for cal in [Calibration::Kes, Calibration::Paper] {
        let s = cotton(cal);
        let g = Grid::sheet(5, 4, 0.2, 0.15).unwrap();
        let rest = g.flat_positions(0.0);
        let x = perturbed(&rest, 0.02, 1);
        exact("membrane/free", g.len(), Box::new(Membrane::new(&g, &rest, &s)), &x);
        exact("bending/free", g.len(), Box::new(Bending::new(&g, &rest, &s)), &x);
        exact("bending/free/warp 0.6 rad", g.len(), Box::new(Bending::with_warp(&g, &rest, &s, Warp::Angle(0.6))), &x);
        exact(
            "membrane/free/warp 0.6 rad",
            g.len(),
            Box::new(Membrane::with_warp(&g, &rest, &s, Warp::Angle(0.6))),
            &x,
        );
        exact(
            "membrane/free/warp 0.6 rad, condensed edge stiffness",
            g.len(),
            Box::new(Membrane::with_options(&g, &rest, &s, Warp::Angle(0.6), true)),
            &x,
        );
        let (gc, restc) = cylinder(6, 4, 0.1, 0.2);
        let xc = perturbed(&restc, 0.01, 2);
        exact("membrane/periodic", gc.len(), Box::new(Membrane::new(&gc, &restc, &s)), &xc);
        exact("bending/periodic (curved rest)", gc.len(), Box::new(Bending::new(&gc, &restc, &s)), &xc);
        let mut flat = Bending::new(&gc, &restc, &s);
        flat.flatten_rest_curvature();
        exact("bending/periodic (flat pattern)", gc.len(), Box::new(flat), &xc);
    }
}

/// The Terzopoulos force is not a gradient: it says so, the checker confirms it, and the static solver refuses
/// it with a clear error.
#[test]
fn terzopoulos_bending_is_not_a_gradient_and_statics_refuse_it() {
    let s = cotton(Calibration::Kes);
    let g = Grid::sheet(5, 4, 0.2, 0.15).unwrap();
    let rest = g.flat_positions(0.0);
    let x = perturbed(&rest, 0.02, 3);
    let term = TerzopoulosBending(Bending::new(&g, &rest, &s));
    assert!(!term.info().conservative);
    let report = check(&alone(g.len(), Box::new(term)), &x, None, None, Operator::Projected);
    assert!(report.gradient_error > 1e-2, "the Terzopoulos force looks like a gradient: {report:?}");
    let fabric = Fabric::paper_cotton();
    let mut b = ModelBuilder::new(g, rest.clone(), fabric, s, ModelKind::Terzopoulos, Vec3::new(0.0, 0.0, -9.81));
    b.pinned[0] = true;
    let model = b.build().unwrap();
    assert!(!model.potential.conservative());
    let mut y = rest.clone();
    let err = StaticSolver::new(&model).unwrap().solve(&model, &mut y, &StaticOptions::default()).unwrap_err();
    assert!(matches!(err, StaticError::NonConservative { .. }), "{err:?}");
    assert!(err.to_string().contains("not the gradient of an energy"), "{err}");
}

#[test]
fn gravity_loads_and_springs_match_finite_differences() {
    let g = Grid::sheet(4, 3, 0.3, 0.2).unwrap();
    let n = g.len();
    let x = perturbed(&g.flat_positions(0.1), 0.01, 4);
    let mass: Vec<f64> = (0..n).map(|k| 0.01 + 0.001 * k as f64).collect();
    let loads: Vec<Vec3> = (0..n).map(|k| Vec3::new(0.1 * k as f64, -0.05, 0.02)).collect();
    exact("gravity and loads", n, Box::new(External::new(Vec3::new(0.3, 0.0, -9.81), &mass, &loads)), &x);
    let springs = (0..n)
        .step_by(2)
        .map(|k| Spring { node: k, target: Vec3::new(0.01 * k as f64, 0.2, -0.1), stiffness: 80.0 + k as f64 })
        .collect();
    exact("springs", n, Box::new(Springs::new(springs)), &x);
    // The sewing phase's zero-length springs, a node in two pairs (a corner on two seams) and one pair reversed.
    let pairs = vec![(0, 11), (3, 8), (8, 5), (10, 1)];
    exact("sewing", n, Box::new(flexsurf::potential::sewing::Sewing::new(pairs.clone(), 100.0)), &x);
    // Gradual sewing: rest lengths from another configuration, 0.6 of them in force (every pair stretched at x,
    // so the Hessian is the stretched spring's, exact).
    let placed: Vec<Vec3> = x.iter().map(|p| *p * 1.3).collect();
    let mut closing = flexsurf::potential::sewing::Sewing::closing(pairs, 100.0, &placed);
    closing.set_fraction(0.6);
    exact("sewing (closing)", n, Box::new(closing), &x);
}

fn contact_term(obstacle: Obstacle, n: usize, offset: f64) -> PenaltyContact {
    let area: Vec<f64> = (0..n).map(|k| 0.002 + 1e-4 * k as f64).collect();
    PenaltyContact::new(
        vec![obstacle],
        ContactParams { stiffness: 1e4, offset, friction: 0.0, ..ContactParams::default() },
        area,
    )
}

/// Nodes inside the contact layer of a plane: the penalty energy, force and stiffness are exact (the distance to
/// a plane is linear).
#[test]
fn contact_with_a_plane_and_a_mesh_face_is_exact() {
    let g = Grid::sheet(4, 3, 0.3, 0.2).unwrap();
    let n = g.len();
    let mut x = perturbed(&g.flat_positions(0.0), 0.001, 5);
    for (k, p) in x.iter_mut().enumerate() {
        p.z = -0.002 + 0.0005 * k as f64 / n as f64;
    }
    let plane = Obstacle::Plane { point: Vec3::ZERO, normal: Vec3::Z };
    exact("contact/plane", n, Box::new(contact_term(plane, n, 0.005)), &x);
    // The top face of a closed box mesh: inside the face's region the distance is linear too.
    let v: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 0.0 },
            )
        })
        .collect();
    let t = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    let mesh = Obstacle::Mesh(Arc::new(TriMeshBody::new(v, t).unwrap()));
    exact("contact/mesh face", n, Box::new(contact_term(mesh, n, 0.005)), &x);
}

/// On a ball the force is the exact gradient, and the stiffness `c a ν νᵀ` is the Gauss–Newton part: the exact
/// Hessian adds `−c a (δ − d) (I − ν νᵀ)/|x − centre|`, the obstacle's curvature (checked in closed form).
#[test]
fn contact_with_a_ball_is_gauss_newton_in_closed_form() {
    let g = Grid::sheet(3, 3, 0.2, 0.2).unwrap();
    let n = g.len();
    let (r, offset) = (0.5, 0.01);
    let x: Vec<Vec3> = g
        .flat_positions(0.0)
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let dir = Vec3::new(p.x, p.y, 1.0).normalize();
            dir * (r + 0.002 + 0.0004 * k as f64)
        })
        .collect();
    let ball = Obstacle::Sphere { center: Vec3::ZERO, radius: r };
    let term = contact_term(ball, n, offset);
    let pot = alone(n, Box::new(term.clone()));
    let report = check(&pot, &x, None, None, Operator::Exact);
    assert!(report.gradient_norm > 0.0 && report.gradient_error < TOL, "{report:?}");
    let (gn, fd) = hessians(&pot, &x, None, None, Operator::Exact);
    let mut worst: f64 = 0.0;
    let scale = gn.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    for k in 0..n {
        let d = x[k].length() - r;
        let nu = x[k] / x[k].length();
        let a = 0.002 + 1e-4 * k as f64;
        let expect: Mat3 =
            outer(nu, nu) * (1e4 * a) - (Mat3::IDENTITY - outer(nu, nu)) * (1e4 * a * (offset - d) / x[k].length());
        for (p, q) in (0..3).flat_map(|p| (0..3).map(move |q| (p, q))) {
            let (row, col) = (3 * k + p, 3 * k + q);
            worst = worst.max((fd[row][col] - expect.col(q)[p]).abs() / scale);
            let gn_expect = outer(nu, nu).col(q)[p] * 1e4 * a;
            assert!((gn[row][col] - gn_expect).abs() <= 1e-12 * scale, "assembled block of node {k}");
        }
    }
    assert!(worst < TOL, "ball contact: finite-difference Hessian differs from the closed form by {worst:.2e}");
}

/// The NURBS mannequin: the contact force is the gradient of the penalty energy (normals from the closest-point
/// projection).
#[test]
fn contact_with_the_nurbs_mannequin_is_a_gradient() {
    let body = mannequin::generate();
    let g = Grid::sheet(3, 3, 0.02, 0.02).unwrap();
    let n = g.len();
    // Points just inside the contact layer in front of the belly (outward normal about −y… found by projection).
    let obstacle = Obstacle::Nurbs(Arc::new(body));
    let probe = Vec3::new(0.0, -0.5, 0.95);
    let (d0, nu) = obstacle.distance(probe);
    let surface = probe - nu * d0;
    let x: Vec<Vec3> = g
        .flat_positions(0.0)
        .iter()
        .enumerate()
        .map(|(k, p)| surface + Vec3::new(p.x - 0.01, 0.0, p.y - 0.01) + nu * (0.001 + 0.0002 * k as f64))
        .collect();
    for p in &x {
        assert!(obstacle.distance(*p).0 < 0.005, "test point outside the contact layer");
    }
    let report = check(&alone(n, Box::new(contact_term(obstacle, n, 0.005))), &x, None, None, Operator::Exact);
    assert!(report.gradient_norm > 0.0 && report.gradient_error < 1e-5, "{report:?}");
}

/// The step's inertia and damping term, and the whole incremental potential of a step (every term of a model
/// plus the inertia) with the exact Hessian.
#[test]
fn the_step_system_matches_finite_differences() {
    let fabric = Fabric { damping: 0.4, ..Fabric::paper_cotton() };
    let s = cotton(Calibration::Kes);
    let g = Grid::sheet(4, 4, 0.3, 0.3).unwrap();
    let rest = g.flat_positions(0.0);
    let mut b = ModelBuilder::new(g, rest.clone(), fabric, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81));
    b.loads[3] = Vec3::new(0.0, 0.1, 0.0);
    b.springs.push(Spring { node: 5, target: Vec3::new(0.0, 0.0, 0.01), stiffness: 80.0 });
    b.obstacles.push(Obstacle::Plane { point: Vec3::new(0.0, 0.0, -0.003), normal: Vec3::Z });
    b.contact = ContactParams { stiffness: 1e4, offset: 0.005, friction: 0.0, ..ContactParams::default() };
    let model = b.build().unwrap();
    let names: Vec<&str> = model.potential.terms().iter().map(|t| t.info().name).collect();
    assert_eq!(names, ["membrane", "bending", "gravity and loads", "springs", "penalty contact"]);
    let x_prev = perturbed(&rest, 0.002, 6);
    let x_t = perturbed(&rest, 0.002, 7);
    let y = perturbed(&rest, 0.001, 8);
    let (v, v_prev) =
        (perturbed(&vec![Vec3::ZERO; rest.len()], 0.1, 12), perturbed(&vec![Vec3::ZERO; rest.len()], 0.1, 13));
    let target: Vec<Vec3> = x_t.iter().zip(&x_prev).map(|(a, b)| *a * 2.0 - *b).collect();
    let motion = Motion {
        x: &x_t,
        x_prev: &x_prev,
        v: &v,
        v_prev: &v_prev,
        target: &target,
        damp_center: &x_prev,
        inertia: 1e4,
        damp: 50.0,
        dt: 0.01,
        mass: &model.mass,
        damping: &model.damping,
        predict: false,
        exact: false,
    };
    check(&alone(g.len(), Box::new(Inertia)), &y, Some(motion), None, Operator::Exact).assert_below("inertia", TOL);
    check(&model.potential, &y, Some(motion), Some(&Inertia), Operator::Exact).assert_below("step potential", TOL);
}

/// The stepper assembles exactly the potential's system: its matrix is the assembly's operator with the inertia
/// (`Reflected`: the plane touches at the start, a contact step), its right-hand side minus the gradient (zero on
/// pinned nodes).
#[test]
fn the_stepper_uses_the_potential_assembly() {
    let fabric = Fabric { damping: 0.4, ..Fabric::paper_cotton() };
    let g = Grid::sheet(5, 5, 0.4, 0.4).unwrap();
    let rest = g.flat_positions(0.0);
    let mut b = ModelBuilder::new(
        g,
        rest.clone(),
        fabric,
        cotton(Calibration::Kes),
        ModelKind::Tfs,
        Vec3::new(0.0, 0.0, -9.81),
    );
    b.pinned[0] = true;
    b.obstacles.push(Obstacle::Plane { point: Vec3::new(0.0, 0.0, -0.002), normal: Vec3::Z });
    b.contact = ContactParams { stiffness: 1e4, offset: 0.005, friction: 0.0, ..ContactParams::default() };
    let model: Model = b.build().unwrap();
    let zero = vec![Vec3::ZERO; rest.len()];
    let state = State {
        x: perturbed(&rest, 0.001, 9),
        x_prev: perturbed(&rest, 0.001, 10),
        v: perturbed(&zero, 0.01, 14),
        v_prev: perturbed(&zero, 0.01, 15),
        time: 0.0,
        step: 0,
    };
    let mut st = Stepper::new(&model, &StepParams::default()).unwrap();
    let values = st.assemble(&model, &state);
    assert!(values.contacts > 0, "the plane should touch");
    let target: Vec<Vec3> = state.x.iter().zip(&state.x_prev).map(|(a, b)| *a * 2.0 - *b).collect();
    let motion = Motion {
        x: &state.x,
        x_prev: &state.x_prev,
        v: &state.v,
        v_prev: &state.v_prev,
        target: &target,
        damp_center: &state.x_prev,
        inertia: 1.0 / (0.01 * 0.01),
        damp: 0.5 / 0.01,
        dt: 0.01,
        mass: &model.mass,
        damping: &model.damping,
        predict: true,
        exact: false,
    };
    let (assembled, _) = hessians(&model.potential, &state.x, Some(motion), Some(&Inertia), Operator::Reflected);
    assert_eq!(st.matrix().to_dense(model.potential.pattern()), assembled);
    let (_, grad) = flexsurf::testing::value_gradient(
        &model.potential,
        &mut flexsurf::potential::Workspace::new(&model.potential),
        &state.x,
        Some(motion),
        Some(&Inertia),
    );
    for k in 0..rest.len() {
        let expect = if model.pinned()[k] { Vec3::ZERO } else { -grad[k] };
        assert_eq!(st.rhs()[k], expect, "node {k}");
    }
}

/// `Projected` is positive semi-definite for every elastic term; it equals `Exact` where the stresses vanish (the
/// rest state); for bending it is Gauss–Newton only, so it differs from `Exact` wherever moments act; for the
/// membrane under uniform stretch (tension only) it keeps the whole stress stiffness and equals `Exact`, and under
/// compression it drops it. `Reflected` is positive semi-definite too, equals `Projected` for bending and for the
/// membrane in tension, and under compression adds the dropped part back with its sign turned: `Reflected −
/// Projected = Projected − Exact` in the membrane's stress stiffness. `Secant` (the lagged operator) is positive
/// semi-definite.
#[test]
fn hessian_approximations_are_what_they_say() {
    let s = cotton(Calibration::Kes);
    let g = Grid::sheet(5, 4, 0.25, 0.2).unwrap();
    let n = g.len();
    let rest = g.flat_positions(0.0);
    let wrinkled = perturbed(&rest.iter().map(|p| *p * 0.97).collect::<Vec<_>>(), 0.005, 11);
    let terms: Vec<(&str, Box<dyn Term>)> = vec![
        ("membrane", Box::new(Membrane::new(&g, &rest, &s))),
        ("bending", Box::new(Bending::new(&g, &rest, &s))),
        ("bending/warp 0.6 rad", Box::new(Bending::with_warp(&g, &rest, &s, Warp::Angle(0.6)))),
    ];
    for (name, term) in terms {
        let pot = alone(n, term);
        let (ex_rest, _) = hessians(&pot, &rest, None, None, Operator::Exact);
        let (pr_rest, _) = hessians(&pot, &rest, None, None, Operator::Projected);
        let top = ex_rest.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        let diff = max_diff(&ex_rest, &pr_rest);
        assert!(diff <= 1e-12 * top, "{name}: Projected ≠ Exact at rest ({diff:.2e})");
        for op in [Operator::Projected, Operator::Reflected, Operator::Secant] {
            let (h, _) = hessians(&pot, &wrinkled, None, None, op);
            let (lo, hi) = eigen_range(&h);
            assert!(lo > -1e-12 * hi, "{name}: {op:?} has eigenvalue {lo:.3e} (top {hi:.3e})");
        }
        let (ex, _) = hessians(&pot, &wrinkled, None, None, Operator::Exact);
        let (lo, hi) = eigen_range(&ex);
        if name == "membrane" {
            assert!(lo < -1e-6 * hi, "{name}: the compressed state should make the exact Hessian indefinite");
        }
        let (pr, _) = hessians(&pot, &wrinkled, None, None, Operator::Projected);
        assert!(max_diff(&ex, &pr) > 1e-6 * hi, "{name}: Projected should drop stress stiffness here");
        let (re, _) = hessians(&pot, &wrinkled, None, None, Operator::Reflected);
        if name == "membrane" {
            // The membrane's material part is in all three: Reflected − Projected = Projected − Exact.
            let mirror = |a: &[Vec<f64>], b: &[Vec<f64>]| -> Vec<Vec<f64>> {
                a.iter().zip(b).map(|(r, q)| r.iter().zip(q).map(|(x, y)| x - y).collect()).collect()
            };
            let gap = max_diff(&mirror(&re, &pr), &mirror(&pr, &ex));
            assert!(gap <= 1e-10 * hi, "{name}: Reflected is not Projected's mirror of Exact ({gap:.2e})");
            assert!(max_diff(&re, &pr) > 1e-6 * hi, "{name}: Reflected should keep the compressed stiffness");
        } else {
            assert_eq!(re, pr, "{name}: Reflected is Projected outside the membrane");
        }
    }
    // Membrane under uniform biaxial stretch (no shear stress): all stretch stresses are tensions, kept whole.
    let pot = alone(n, Box::new(Membrane::new(&g, &rest, &s)));
    let stretched: Vec<Vec3> = rest.iter().map(|p| Vec3::new(1.01 * p.x, 1.01 * p.y, 0.0)).collect();
    let (ex, _) = hessians(&pot, &stretched, None, None, Operator::Exact);
    let (pr, _) = hessians(&pot, &stretched, None, None, Operator::Projected);
    let top = ex.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    assert!(max_diff(&ex, &pr) <= 1e-10 * top, "membrane in tension: Projected ≠ Exact ({:.2e})", max_diff(&ex, &pr));
    let (re, _) = hessians(&pot, &stretched, None, None, Operator::Reflected);
    assert!(max_diff(&ex, &re) <= 1e-10 * top, "membrane in tension: Reflected ≠ Exact ({:.2e})", max_diff(&ex, &re));
}

fn max_diff(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    a.iter().flatten().zip(b.iter().flatten()).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

/// The elastic terms of a garment model (flat pattern, warp along u2) go through the same checker.
#[test]
fn a_flat_pattern_model_matches_finite_differences() {
    let (gc, restc) = cylinder(8, 4, 0.1, 0.15);
    let options = ElasticOptions { warp_angle: std::f64::consts::FRAC_PI_2, flat_pattern: true, ..Default::default() };
    let model = ModelBuilder::new(
        gc,
        restc.clone(),
        Fabric::paper_cotton(),
        cotton(Calibration::Kes),
        ModelKind::Tfs,
        Vec3::ZERO,
    )
    .options(options)
    .build()
    .unwrap();
    let x = perturbed(&restc, 0.005, 12);
    check(&model.potential, &x, None, None, Operator::Exact).assert_below("garment elastic terms", TOL);
}

/// Coulomb friction of one node through the shared checker: the smoothed law `μλ f₀(|u|)` itself (both regimes),
/// its tangent model about a slip, and its majorant, each value/gradient/Hessian consistent.
#[derive(Debug, Clone)]
struct OneFriction {
    law: FrictionLaw,
    lagged: Lagged,
    anchor: Vec3,
    /// 0: the law itself; 1: the current linear model of `lagged`.
    which: u8,
}

impl Term for OneFriction {
    fn info(&self) -> TermInfo {
        TermInfo::new("friction", Stage::Contact, Part::Contact)
    }
    fn evaluate(&self, y: &[Vec3], cx: &Context, _s: &mut Scratch, sink: &mut Sink) -> f64 {
        let u = self.lagged.tangential(y[0] - self.anchor);
        let (e, g, h) = if self.which == 0 {
            (self.law.energy(u.length()), self.law.gradient(u), self.law.hessian(u, self.lagged.projector()))
        } else {
            self.lagged.model(&self.law, u)
        };
        sink.energy += e;
        if let Some(gr) = sink.grad.as_deref_mut() {
            gr[0] += g;
        }
        sink.add_block(cx.diag[0], 0, 0, h);
        e
    }
}

#[test]
fn friction_law_and_models_pass_the_checker() {
    let normal = Vec3::new(0.3, -0.2, 0.9).normalize();
    let eps = 1e-3;
    let law = FrictionLaw { limit: 0.7, eps };
    let anchor = Vec3::new(0.1, 0.2, 0.3);
    let tangent = (Vec3::X - normal * normal.x).normalize();
    for (slip, majorant) in [(0.4e-3, true), (2.5e-3, false), (2.5e-3, true), (0.05, false)] {
        let lagged = Lagged { node: 0, limit: law.limit, normal, at: tangent * slip, majorant };
        for which in [0u8, 1] {
            for s in [0.3e-3, 0.8e-3, 4e-3, 0.03] {
                let y = vec![anchor + (tangent * 0.8 + normal.cross(tangent) * 0.6) * s + normal * 1e-4];
                let term = OneFriction { law, lagged, anchor, which };
                let r = check(&alone(1, Box::new(term)), &y, None, None, Operator::Exact);
                let name = format!("friction which={which} slip={slip} majorant={majorant} s={s}");
                r.assert_below(&name, 1e-5);
            }
        }
    }
}
