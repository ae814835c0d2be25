//! Ball drop built by hand (no scene file): 1 m sheet, 21×21, Δt = 0.01 s, 300 steps.
use flexsurf::contact::Obstacle;
use flexsurf::grid::Grid;
use flexsurf::integrate::{linsolve::SolverKind, Scheme, StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{ModelBuilder, ModelKind};
use flexsurf::potential::contact::ContactParams;
use flexsurf::state::State;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(21);
    let scheme = if args.get(2).map(|s| s.as_str()) == Some("lagged") { Scheme::Lagged } else { Scheme::Linearized };
    let solver = if args.get(3).map(|s| s.as_str()) == Some("pcg") { SolverKind::Pcg } else { SolverKind::Cholesky };
    let model_kind =
        if args.get(4).map(|s| s.as_str()) == Some("terz") { ModelKind::Terzopoulos } else { ModelKind::Tfs };
    let grid = Grid::sheet(n, n, 1.0, 1.0).unwrap();
    let fabric = Fabric::paper_cotton();
    let s = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
    let rest = grid.flat_positions(0.0);
    let mut model = ModelBuilder::new(grid, rest.clone(), fabric, s, model_kind, Vec3::new(0.0, 0.0, -9.81));
    model.obstacles.push(Obstacle::Sphere { center: Vec3::ZERO, radius: 0.3 });
    let c: f64 = std::env::var("C").ok().and_then(|v| v.parse().ok()).unwrap_or(1e4);
    let off: f64 = std::env::var("OFF").ok().and_then(|v| v.parse().ok()).unwrap_or(0.005);
    model.contact = ContactParams { stiffness: c, offset: off, friction: 0.3, ..ContactParams::default() };
    let start: Vec<Vec3> = rest.iter().map(|p| *p + Vec3::new(0.0, 0.0, 0.35)).collect();
    let model = model.build().unwrap();
    let mut state = State::at_rest(start);
    let mut stepper = Stepper::new(&model, &StepParams { scheme, solver, ..StepParams::with_dt(0.01) }).unwrap();
    let t = std::time::Instant::now();
    let mut worst = (0.0, 0);
    let r = flexsurf::sim::run(&model, &mut state, &mut stepper, 300, |st, info| {
        let ms = model.max_strain(&st.x);
        if ms > worst.0 {
            worst = (ms, st.step);
        }
        if st.step % 50 == 0 {
            let d = flexsurf::sim::diagnose(&model, st, info.contacts);
            println!("{:?}", d);
        }
        std::ops::ControlFlow::Continue(())
    });
    println!("worst strain {:?}", worst);
    println!("{:?} wall {:?} counters {:?}", r, t.elapsed(), stepper.counters);
}
