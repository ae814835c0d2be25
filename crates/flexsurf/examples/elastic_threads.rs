//! Times the assembly of the elastic terms alone (energy, gradient and the projected operator) on an `n × n`
//! sheet for several thread counts: `cargo run --release --example elastic_threads -- 161 1,2`.
use flexsurf::energy::{Operator, Sink};
use flexsurf::grid::Grid;
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::ModelKind;
use flexsurf::sparse::BlockMatrix;
use flexsurf::testing::{elastic, perturbed};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(161);
    let threads: Vec<usize> =
        args.get(2).map(|s| s.split(',').filter_map(|t| t.parse().ok()).collect()).unwrap_or_else(|| vec![1, 2]);
    let reps: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(20);
    let grid = Grid::sheet(n, n, 1.0, 1.0).unwrap();
    let s = Stiffness::calibrate(&Fabric::paper_cotton(), Calibration::Kes).unwrap();
    let rest = grid.flat_positions(0.0);
    let x: Vec<Vec3> = perturbed(&rest, 0.2 / n as f64, 7);
    let potential = elastic(&grid, &rest, &s, ModelKind::Tfs);
    let mut g = vec![Vec3::ZERO; grid.len()];
    let mut h = BlockMatrix::zeros(potential.pattern());
    for &k in &threads {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(k).build().unwrap();
        let mut times: Vec<f64> = pool.install(|| {
            (0..reps + 2)
                .map(|_| {
                    g.iter_mut().for_each(|v| *v = Vec3::ZERO);
                    h.clear();
                    let t = Instant::now();
                    potential.evaluate(&x, &mut Sink::with(Some(&mut g), &mut h, Operator::Projected));
                    t.elapsed().as_secs_f64()
                })
                .skip(2)
                .collect()
        });
        times.sort_by(f64::total_cmp);
        println!("{n}x{n} threads {k}: median {:.3} ms, min {:.3} ms", times[times.len() / 2] * 1e3, times[0] * 1e3);
    }
}
