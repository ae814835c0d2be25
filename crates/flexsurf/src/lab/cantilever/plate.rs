//! The test specimen solved by the plate model: a strip of [`Strip::ACROSS`] node columns clamped on the ledge
//! by its first two columns, solved to static equilibrium on a coarse and a fine grid (the coarse solution
//! starting the fine one, the elastica starting the coarse one) and the chord angle extrapolated in the cell
//! size.

use super::{strip_rigidity, Direction, Elastica, Strip, G};
use crate::grid::{Grid, Topology};
use crate::integrate::statics::{StaticOptions, StaticSolver};
use crate::lab::LabError;
use crate::material::{Fabric, Stiffness};
use crate::math::Vec3;
use crate::model::{ElasticOptions, ModelBuilder, ModelKind};

/// (extrapolated angle, fine angle, fine tip drop) at overhang `l`.
pub(super) fn extrapolated(f: &Fabric, s: &Stiffness, strip: Strip, l: f64) -> Result<(f64, f64, f64), LabError> {
    solve_pair(f, s, strip, l).map(|(a, b, c, _)| (a, b, c))
}

/// Columns of the fine solution.
pub(super) type Columns = Vec<[Vec3; Strip::ACROSS]>;

/// (extrapolated angle, fine angle, fine tip drop, fine columns) at overhang `l`. The coarse solution,
/// interpolated along the strip, starts the fine solve.
pub(super) fn solve_pair(
    f: &Fabric,
    s: &Stiffness,
    strip: Strip,
    l: f64,
) -> Result<(f64, f64, f64, Columns), LabError> {
    let k = strip_rigidity(f, strip.direction)?;
    let shape = Elastica::new(f.density * G * l.powi(3) / k);
    // Start from the heavy elastica of the strip's nominal rigidity (from a flat start Newton needs about a
    // hundred damped steps).
    let elastica = |sigma: f64, y: f64| {
        let (sx, drop) = shape.at(sigma);
        Vec3::new(sx * l, y, -drop * l)
    };
    let (coarse, _, cols) = chord(f, s, strip, l, 66, &elastica)?;
    let along = |sigma: f64, a: usize| {
        let t = sigma * (cols.len() - 1) as f64;
        let i = (t.floor() as usize).min(cols.len() - 2);
        cols[i][a].lerp(cols[i + 1][a], t - i as f64)
    };
    let hw = strip.width / (Strip::ACROSS - 1) as f64;
    let from_coarse = |sigma: f64, y: f64| along(sigma, ((y + 0.5 * strip.width) / hw).round() as usize);
    let (fine, drop, fine_cols) = chord(f, s, strip, l, 130, &from_coarse)?;
    Ok((2.0 * fine - coarse, fine, drop, fine_cols))
}

/// Chord angle (degrees), tip drop and the solved node columns from the ledge edge to the tip of a strip with
/// `m` node columns (two clamped), starting from `start(σ, y)` (σ = arc length / overhang, y across).
fn chord(
    f: &Fabric,
    s: &Stiffness,
    strip: Strip,
    l: f64,
    m: usize,
    start: &dyn Fn(f64, f64) -> Vec3,
) -> Result<(f64, f64, Columns), LabError> {
    let (n, width) = (Strip::ACROSS, strip.width);
    let h = l / (m - 2) as f64;
    let hw = width / (n - 1) as f64;
    let weft = strip.direction == Direction::Weft;
    let grid =
        if weft { Grid::new(n, m, hw, h, [Topology::Free; 2]) } else { Grid::new(m, n, h, hw, [Topology::Free; 2]) }
            .map_err(|e| LabError::Input(format!("strip grid: {e}")))?;
    let node = |i: usize, a: usize| if weft { grid.index(a, i) } else { grid.index(i, a) };
    let mut rest = vec![Vec3::ZERO; grid.len()];
    for i in 0..m {
        for a in 0..n {
            rest[node(i, a)] = Vec3::new((i as f64 - 1.0) * h, a as f64 * hw - 0.5 * width, 0.0);
        }
    }
    // On the bias the warp runs at 45° to the strip (u1).
    let warp_angle = if strip.direction == Direction::Bias { std::f64::consts::FRAC_PI_4 } else { 0.0 };
    let opts = ElasticOptions { warp_angle, ..Default::default() };
    let mut model =
        ModelBuilder::new(grid, rest.clone(), *f, *s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -G)).options(opts);
    for a in 0..n {
        model.pinned[node(0, a)] = true;
        model.pinned[node(1, a)] = true;
    }
    let model = model.build()?;
    let mut x: Vec<Vec3> = rest.iter().map(|p| if p.x > 0.0 { start(p.x / l, p.y) } else { *p }).collect();
    let opts = StaticOptions { tolerance: 1e-9, max_iterations: 300 };
    StaticSolver::new(&model)
        .and_then(|mut solver| solver.solve(&model, &mut x, &opts))
        .map_err(|source| LabError::Solve { test: "cantilever", source })?;
    let mid = n / 2;
    let (clamp, tip) = (x[node(1, mid)], x[node(m - 1, mid)]);
    let drop = clamp.z - tip.z;
    let cols = (1..m).map(|i| std::array::from_fn(|a| x[node(i, a)])).collect();
    Ok((drop.atan2(tip.x - clamp.x).to_degrees(), drop, cols))
}
