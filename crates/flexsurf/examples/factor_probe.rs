//! Probe: factor size and time for the ball-drop matrix.
use flexsurf::grid::Grid;
use flexsurf::integrate::linsolve::Cholesky;
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{Model, ModelKind};
fn main() {
    for n in [21usize, 41, 81] {
        let g = Grid::sheet(n, n, 1.0, 1.0).unwrap();
        let f = Fabric::paper_cotton();
        let s = Stiffness::calibrate(&f, Calibration::Kes).unwrap();
        let m = Model::new(g, g.flat_positions(0.0), f, s, ModelKind::Tfs, Vec3::ZERO);
        let c = Cholesky::new(&m.elastic.pattern).unwrap();
        println!("n={n} blocks={} nnzL={}", m.elastic.pattern.blocks(), c.factor_nnz());
    }
}
