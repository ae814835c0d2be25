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
use crate::model::{ElasticOptions, Model, ModelBuilder, ModelKind};

/// (extrapolated angle, fine angle, fine tip drop) at overhang `l`.
pub(super) fn extrapolated(f: &Fabric, s: &Stiffness, strip: Strip, l: f64) -> Result<(f64, f64, f64), LabError> {
    solve_pair(f, s, strip, l).map(|(a, b, c, _)| (a, b, c))
}

/// Node columns of a solved strip, from the ledge edge to the tip, each across the width.
pub type Columns = Vec<[Vec3; Strip::ACROSS]>;

/// (extrapolated angle, fine angle, fine tip drop, fine columns) at overhang `l`. The coarse solution,
/// interpolated along the strip, starts the fine solve.
pub(super) fn solve_pair(
    f: &Fabric,
    s: &Stiffness,
    strip: Strip,
    l: f64,
) -> Result<(f64, f64, f64, Columns), LabError> {
    let (coarse, fine) = hang_pair(f, s, strip, l, COLUMNS)?;
    Ok((2.0 * fine.angle - coarse.angle, fine.angle, fine.drop, fine.columns()))
}

/// Node columns of the coarse and the fine grid of the test (two of them clamped).
pub const COLUMNS: (usize, usize) = (66, 130);

/// One strip solved to equilibrium: its specimen, model and equilibrium, the chord angle and tip drop.
pub struct Hanging {
    /// The specimen (model builder, node numbering).
    pub specimen: Specimen,
    /// The model built from it.
    pub model: Model,
    /// The equilibrium.
    pub x: Vec<Vec3>,
    /// Chord angle below horizontal (degrees).
    pub angle: f64,
    /// Tip drop below the ledge (m).
    pub drop: f64,
}

impl Hanging {
    /// The solved node columns from the ledge edge to the tip.
    pub fn columns(&self) -> Columns {
        (1..self.specimen.m).map(|i| std::array::from_fn(|a| self.x[self.specimen.node(i, a)])).collect()
    }

    /// The chord angle's gradient (degrees per m) with respect to the node positions (zero but at the tip and
    /// the clamp's middle nodes).
    pub fn angle_gradient(&self) -> Vec<Vec3> {
        let (tip, clamp) = self.specimen.chord_nodes();
        let (dx, dz) = (self.x[tip].x - self.x[clamp].x, self.x[clamp].z - self.x[tip].z);
        let r2 = dx * dx + dz * dz;
        let deg = 180.0 / std::f64::consts::PI;
        let d = Vec3::new(-dz / r2, 0.0, -dx / r2) * deg;
        let mut g = vec![Vec3::ZERO; self.x.len()];
        g[tip] += d;
        g[clamp] -= d;
        g
    }
}

/// The coarse and fine strips of `columns` node columns at overhang `l`, the fine one started from the coarse.
pub fn hang_pair(
    f: &Fabric,
    s: &Stiffness,
    strip: Strip,
    l: f64,
    columns: (usize, usize),
) -> Result<(Hanging, Hanging), LabError> {
    hang_pair_from(f, s, strip, l, columns, None)
}

/// Interpolates `cols` (node columns from the ledge edge to the tip) at `σ` (arc length / overhang) across
/// column `a`.
fn along(cols: &Columns, sigma: f64, a: usize) -> Vec3 {
    let t = sigma * (cols.len() - 1) as f64;
    let i = (t.floor() as usize).min(cols.len() - 2);
    cols[i][a].lerp(cols[i + 1][a], t - i as f64)
}

/// As [`hang_pair`], the coarse strip started from `start` (the node columns of a strip hanging at overhang
/// `start.1`, stretched along to `l`) instead of the heavy elastica: for searches and fits that solve many
/// nearby strips.
pub fn hang_pair_from(
    f: &Fabric,
    s: &Stiffness,
    strip: Strip,
    l: f64,
    columns: (usize, usize),
    start: Option<(&Columns, f64)>,
) -> Result<(Hanging, Hanging), LabError> {
    let hw = strip.width / (Strip::ACROSS - 1) as f64;
    let across = |y: f64| ((y + 0.5 * strip.width) / hw).round() as usize;
    if let Some((cols, l0)) = start {
        if cols.len() < 2 || !(l0.is_finite() && l0 > 0.0) {
            return Err(LabError::Input(format!(
                "strip start: {} node columns at overhang {l0} m (need two or more at a positive overhang)",
                cols.len()
            )));
        }
    }
    let coarse = match start {
        Some((cols, l0)) => {
            let from = |sigma: f64, y: f64| {
                let p = along(cols, sigma, across(y));
                Vec3::new(p.x * l / l0, p.y, p.z * l / l0)
            };
            chord(f, s, strip, l, columns.0, &from)?
        }
        None => {
            let k = strip_rigidity(f, strip.direction)?;
            let shape = Elastica::new(f.density * G * l.powi(3) / k);
            // Start from the heavy elastica of the strip's nominal rigidity (from a flat start Newton needs about
            // a hundred damped steps).
            let elastica = |sigma: f64, y: f64| {
                let (sx, drop) = shape.at(sigma);
                Vec3::new(sx * l, y, -drop * l)
            };
            chord(f, s, strip, l, columns.0, &elastica)?
        }
    };
    let cols = coarse.columns();
    let from_coarse = |sigma: f64, y: f64| along(&cols, sigma, across(y));
    let fine = chord(f, s, strip, l, columns.1, &from_coarse)?;
    let gap = (fine.angle - coarse.angle).abs();
    if gap.is_nan() || gap > MAX_GRID_GAP {
        return Err(LabError::Input(format!(
            "cantilever: the strips of {} and {} node columns hang at {:.2}° and {:.2}°, {gap:.2}° apart (at most \
             {MAX_GRID_GAP}°): the two grids are not where their extrapolation holds (a strip of very short cells \
             can fold at the clamp)",
            columns.0, columns.1, coarse.angle, fine.angle
        )));
    }
    Ok((coarse, fine))
}

/// The largest difference (degrees) between the coarse and the fine strip's chord angles the extrapolation takes:
/// at the test's grids (66 and 130 columns) it is at most 0.44° over the shipped fabrics, three directions and
/// overhangs of 0.5 to 8 times `(K/w)^(1/3)`, and smaller on finer grids; a fine strip of 1,398 columns that had
/// folded at the clamp (89.9° against the coarse 72.95°, a fit's `columns = 700`) passed unseen before.
pub const MAX_GRID_GAP: f64 = 2.0;

/// The specimen of a strip with `m` node columns (two clamped) at overhang `l`: its model builder and node
/// numbering.
#[derive(Clone)]
pub struct Specimen {
    /// The model's builder (the first two columns pinned).
    pub builder: ModelBuilder,
    grid: Grid,
    weft: bool,
    /// Node columns.
    pub m: usize,
    /// Overhang (m).
    pub overhang: f64,
}

impl Specimen {
    /// The specimen of `strip` with `m ≥ 4` node columns at overhang `l`.
    pub fn new(f: &Fabric, s: &Stiffness, strip: Strip, l: f64, m: usize) -> Result<Self, LabError> {
        if m < 4 {
            return Err(LabError::Input(format!("strip grid: {m} node columns (need at least 4)")));
        }
        let (n, width) = (Strip::ACROSS, strip.width);
        let h = l / (m - 2) as f64;
        let hw = width / (n - 1) as f64;
        let weft = strip.direction == Direction::Weft;
        let grid = if weft {
            Grid::new(n, m, hw, h, [Topology::Free; 2])
        } else {
            Grid::new(m, n, h, hw, [Topology::Free; 2])
        }
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
        let mut builder = ModelBuilder::new(grid, rest, *f, *s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -G)).options(opts);
        for a in 0..n {
            builder.pinned[node(0, a)] = true;
            builder.pinned[node(1, a)] = true;
        }
        Ok(Self { builder, grid, weft, m, overhang: l })
    }

    /// The node of column `i` (0 and 1 clamped, `m − 1` the tip), `a` across.
    pub fn node(&self, i: usize, a: usize) -> usize {
        if self.weft {
            self.grid.index(a, i)
        } else {
            self.grid.index(i, a)
        }
    }

    /// The chord's nodes: (tip, clamp edge), both in the middle of the width.
    pub fn chord_nodes(&self) -> (usize, usize) {
        let mid = Strip::ACROSS / 2;
        (self.node(self.m - 1, mid), self.node(1, mid))
    }
}

/// The strip of `m` node columns at overhang `l` solved from `start(σ, y)` (σ = arc length / overhang, y
/// across).
fn chord(
    f: &Fabric,
    s: &Stiffness,
    strip: Strip,
    l: f64,
    m: usize,
    start: &dyn Fn(f64, f64) -> Vec3,
) -> Result<Hanging, LabError> {
    let specimen = Specimen::new(f, s, strip, l, m)?;
    let rest = specimen.builder.panels[0].rest.clone();
    let model = specimen.builder.clone().build()?;
    let mut x: Vec<Vec3> = rest.iter().map(|p| if p.x > 0.0 { start(p.x / l, p.y) } else { *p }).collect();
    let opts = StaticOptions { tolerance: 1e-9, max_iterations: 300 };
    StaticSolver::new(&model)
        .and_then(|mut solver| solver.solve(&model, &mut x, &opts))
        .map_err(|cause| LabError::Solve { test: "cantilever", cause })?;
    let (tip, clamp) = specimen.chord_nodes();
    let (clamp, tip) = (x[clamp], x[tip]);
    let drop = clamp.z - tip.z;
    let angle = drop.atan2(tip.x - clamp.x).to_degrees();
    Ok(Hanging { specimen, model, x, angle, drop })
}
