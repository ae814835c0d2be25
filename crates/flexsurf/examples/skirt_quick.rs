//! Skirt on the mannequin built by hand: periodic 28×14 grid, flared cone pattern, waist springs k = 80,
//! contact c = 120 N/m³, Δt = 0.01 s, 600 steps.
use flexsurf::contact::{mannequin, ContactParams, Obstacle};
use flexsurf::grid::{Grid, Topology};
use flexsurf::integrate::{linsolve::SolverKind, IntegratorKind, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{ElasticOptions, Model, ModelKind, Spring};
use flexsurf::state::State;
use std::sync::Arc;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let m: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(28);
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(14);
    let c: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(120.0);
    let off: f64 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0.01);
    let body = Arc::new(mannequin::generate());
    let (waist_z, waist_girth, hem_girth, length) = (1.04, 0.72, 2.4, 0.55);
    let (rw, rh) = (waist_girth / std::f64::consts::TAU, hem_girth / std::f64::consts::TAU);
    let drop = (length * length - (rh - rw) * (rh - rw)).sqrt();
    let grid =
        Grid::new(m, n, waist_girth / m as f64, length / (n - 1) as f64, [Topology::Periodic, Topology::Free]).unwrap();
    // Rest (pattern metric): the cone. u1 around, u2 down the generatrix.
    let rest: Vec<Vec3> = (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            let t = j as f64 / (n - 1) as f64;
            let r = rw + (rh - rw) * t;
            let a = std::f64::consts::TAU * i as f64 / m as f64;
            Vec3::new(r * a.cos(), r * a.sin(), waist_z - drop * t)
        })
        .collect();
    let fabric = Fabric::paper_cotton();
    let s = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
    let opts = ElasticOptions { warp_angle: std::f64::consts::FRAC_PI_2, flat_pattern: true };
    let mut model =
        Model::with_options(grid, rest.clone(), fabric, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81), &opts);
    model.obstacles.push(Obstacle::Nurbs(body.clone()));
    model.contact = ContactParams { stiffness: c, offset: off, friction: 0.3 };
    for i in 0..m {
        let k = grid.index(i, 0);
        model.springs.push(Spring { node: k, target: rest[k], stiffness: 80.0 });
    }
    let pen0 = flexsurf::integrate::max_penetration(&model, &rest);
    println!("initial penetration {pen0:.4}");
    let mut state = State::at_rest(rest.clone());
    let mut stepper = Stepper::new(&model, IntegratorKind::Linearized, SolverKind::Cholesky).unwrap();
    let t = std::time::Instant::now();
    let mut worst_pen: f64 = 0.0;
    let r = flexsurf::sim::run(&model, &mut state, &mut stepper, 0.01, 600, |st, info| {
        worst_pen = worst_pen.max(info.max_penetration);
        if st.step % 100 == 0 {
            let d = flexsurf::sim::diagnose(&model, st, 0.01, info.contacts);
            let drift = (0..m).map(|i| (st.x[grid.index(i, 0)] - rest[grid.index(i, 0)]).length()).fold(0.0, f64::max);
            println!(
                "step {} ke {:.3e} contacts {} pen {:.4} strain {:.4} minz {:.3} drift {:.4}",
                st.step,
                d.kinetic,
                d.contacts,
                d.max_penetration,
                d.max_strain,
                st.x.iter().map(|p| p.z).fold(f64::INFINITY, f64::min),
                drift
            );
        }
        std::ops::ControlFlow::Continue(())
    });
    println!(
        "{:?} worst pen {worst_pen:.4} wall {:?} counters {:?}",
        r.map(|s| s.steps),
        t.elapsed(),
        stepper.counters
    );
}
