//! The Cusick drape test (BS 5058 / ISO 9073-9): a circular specimen clamped between 18 cm discs drapes under
//! gravity; the drape coefficient is the shadow area outside the disc as a percentage of the specimen's area
//! outside the disc, `DC = (A_shadow − A_disc)/(A_specimen − A_disc) × 100`, and the nodes are the folds around
//! the hem.
//!
//! The specimen is an annulus on a polar grid (u1 radial, free; u2 around, periodic), warp along x (a fixed
//! direction of the flat pattern, so the strains are measured in the fabric's axes at every point). Its inner two
//! rings (radius `R_disc − h/2` and `R_disc + h/2`) are clamped, so the clamped segment between them is level at
//! the disc's edge itself. The drape is found by damped implicit dynamics from the
//! flat state with a small many-mode perturbation of the hem (so that the fold count is chosen by the fabric, not
//! by the perturbation), run until no node moves faster than 1 cm/s ([`REST_SPEED`]) and finished by a static
//! solve; the residual is reported. The shadow is the xy footprint of the Coons
//! display surface (raster), plus the uncovered hole inside the clamp.
//!
//! Bending of an anisotropic fabric on this grid: the frame is not aligned with the grid except along the axes;
//! the bending energy carries the twist/normal-curvature coupling there (see `Bending::with_warp`).

use super::LabError;
use crate::grid::{Grid, Topology};
use crate::integrate::linsolve::SolverKind;
use crate::integrate::statics::{StaticOptions, StaticSolver};
use crate::integrate::{StepParams, Stepper};
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::Vec3;
use crate::model::{ElasticOptions, Model, ModelBuilder, ModelKind};
use crate::scene::budget;
use crate::state::State;
use crate::surface::coons::CoonsSurface;
use crate::surface::footprint::projected_area_xy;
use crate::surface::mesh::TriMesh;
use serde::Serialize;
use std::f64::consts::PI;

/// Support disc diameter (m).
pub const DISC: f64 = 0.18;

/// What the test reports.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CusickReport {
    /// Specimen diameter (m).
    pub specimen: f64,
    /// Drape coefficient (%).
    pub drape_coefficient: f64,
    /// Folds around the hem.
    pub nodes: usize,
    /// Shadow area (m²).
    pub shadow_area: f64,
    /// Grid: radial × angular nodes.
    pub grid: [usize; 2],
    /// Damped implicit steps (Δt = 0.04 s) taken to come to rest.
    pub steps: usize,
    /// Equilibrium residual of the reported shape: largest nodal force imbalance over the largest nodal weight,
    /// measured on the final positions (after the static solve when there is one).
    pub residual: f64,
    /// The same residual where the dynamic relaxation stopped, before the static solve.
    pub relaxed_residual: f64,
    /// The drape coefficient where the dynamic relaxation stopped (%), before the static solve.
    pub relaxed_drape_coefficient: f64,
    /// Newton iterations of the final static solve (0 without one).
    pub static_iterations: usize,
}

/// The draped specimen: report, model and positions (for pictures and meshes).
pub struct Drape {
    /// Numbers.
    pub report: CusickReport,
    /// The model (grid, obstacles, pins).
    pub model: Model,
    /// Equilibrium positions.
    pub x: Vec<Vec3>,
}

impl Drape {
    /// The Coons display mesh of the drape.
    pub fn mesh(&self, k: usize) -> TriMesh {
        CoonsSurface::new(&self.model.panels[0].grid, &self.x).tessellate(k)
    }
}

/// Default grids: radial cells of about 7.5, 5 and 3.75 mm outside the disc (level 0, 1, 2) and 96, 144, 192
/// nodes around (cells about as long around at the hem as radially). Level 1 is the default; levels 1 and 2 are
/// the convergence check (docs/materials.md, "The membrane's edge stiffness").
pub fn default_grid(specimen: f64, level: usize) -> (usize, usize) {
    let h = [0.0075, 0.005, 0.00375][level.min(2)];
    let radial = (((0.5 * specimen - 0.5 * DISC) / h).round() as usize).max(2);
    (radial, [96, 144, 192][level.min(2)])
}

/// The order assumed by [`richardson`] when three levels do not show one: the drape's, measured between 3.75 and
/// 1.67 mm radial cells, is about first (docs/materials.md), though the clamp alone converges at nearly second
/// order (`cusick_clamp_deflects_as_the_annular_plate`).
pub const ASSUMED_ORDER: f64 = 1.0;

/// The Richardson estimate of the grid-converged value from `(spacing, value)` pairs, coarsest first (the grids
/// refined alike in both directions): `(value at spacing 0, order)`; [`grid_convergence`]'s first two numbers.
pub fn richardson(points: &[(f64, f64)]) -> Result<(f64, f64), LabError> {
    grid_convergence(points).map(|g| (g.extrapolated, g.order))
}

/// What a grid study says of the grid-converged value: the Richardson estimate and the numerical uncertainty of
/// the finest level's value, as Roache's grid convergence index (GCI; as in ASME V&V 20).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GridConvergence {
    /// The Richardson estimate at spacing 0 from the two finest levels.
    pub extrapolated: f64,
    /// The order used: observed from the last three levels where they converge monotonically with an order
    /// between 0.5 and 4, else [`ASSUMED_ORDER`].
    pub order: f64,
    /// Whether [`GridConvergence::order`] was observed (else assumed).
    pub observed: bool,
    /// The finest level's uncertainty band (same units as the values): `Fs |f₂ − f₁| / (r^p − 1)`, `r` the ratio
    /// of the two finest spacings, the safety factor `Fs` 1.25 with an observed order and 3 with an assumed one.
    pub uncertainty: f64,
    /// `|f₂ − f₁|`: how far apart the two finest levels are.
    pub spread: f64,
}

/// [`GridConvergence`] of `(spacing, value)` pairs, coarsest first: two or more finite values on decreasing
/// positive spacings.
pub fn grid_convergence(points: &[(f64, f64)]) -> Result<GridConvergence, LabError> {
    let n = points.len();
    if n < 2 || points.windows(2).any(|p| !(p[1].0 < p[0].0 && p[1].0 > 0.0)) || points.iter().any(|p| !p.1.is_finite())
    {
        return Err(LabError::Input(format!(
            "richardson: needs two or more finite values on decreasing positive spacings, got {points:?}"
        )));
    }
    let observed = if n >= 3 { observed_order(&points[n - 3..]) } else { None };
    let p = observed.unwrap_or(ASSUMED_ORDER);
    let ((h1, d1), (h2, d2)) = (points[n - 2], points[n - 1]);
    let grow = (h1 / h2).powf(p) - 1.0;
    let safety = if observed.is_some() { 1.25 } else { 3.0 };
    Ok(GridConvergence {
        extrapolated: d2 + (d2 - d1) / grow,
        order: p,
        observed: observed.is_some(),
        uncertainty: safety * (d2 - d1).abs() / grow,
        spread: (d2 - d1).abs(),
    })
}

/// The order `p` with `(d0 − d1)/(d1 − d2) = (h0^p − h1^p)/(h1^p − h2^p)`, by bisection on [0.5, 4]; `None`
/// when the differences change sign or no order in that range fits.
fn observed_order(pts: &[(f64, f64)]) -> Option<f64> {
    let [(h0, d0), (h1, d1), (h2, d2)] = [pts[0], pts[1], pts[2]];
    let (a, b) = (d0 - d1, d1 - d2);
    if a * b <= 0.0 {
        return None;
    }
    let f = |p: f64| (h0.powf(p) - h1.powf(p)) / (h1.powf(p) - h2.powf(p)) - a / b;
    let (mut lo, mut hi) = (0.5, 4.0);
    if f(lo) * f(hi) > 0.0 {
        return None;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if f(lo) * f(mid) <= 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The grid of `level` (0, 1, 2; above 2 is 2) for a specimen of diameter `specimen`: [`default_grid`]'s cells,
/// graded by [`GRADING`].
pub fn default_polar(specimen: f64, level: usize) -> PolarGrid {
    let (radial, angular) = default_grid(specimen, level);
    PolarGrid { radial, angular, grading: GRADING }
}

/// The default radial grading: the last radial cell (at the hem) this many times the first (at the disc's edge).
pub const GRADING: f64 = 1.0;

/// Drapes a specimen of diameter `specimen` with `radial` cells outside the disc and `angular` nodes around.
pub fn cusick(
    fabric: &Fabric,
    calibration: Calibration,
    specimen: f64,
    radial: usize,
    angular: usize,
) -> Result<Drape, LabError> {
    cusick_specimen(fabric, calibration, specimen, radial, angular, 0)
}

/// As [`cusick`] for the `index`-th specimen of the fabric: the phases of the hem's starting wobble differ from
/// specimen to specimen (index 0 is [`cusick`]'s), as a drape-meter operator tests several specimens and
/// reports their mean: a drape has several equilibria, and which one a specimen finds depends on its start.
pub fn cusick_specimen(
    fabric: &Fabric,
    calibration: Calibration,
    specimen: f64,
    radial: usize,
    angular: usize,
    index: usize,
) -> Result<Drape, LabError> {
    cusick_settled(fabric, calibration, specimen, PolarGrid::uniform(radial, angular), index, &Settle::default())
}

/// How a specimen comes to rest: damped implicit dynamics until no node moves faster than `rest_speed` (or
/// `max_steps`), then, when `equilibrium` is set, a static Newton solve from there to that residual (largest
/// nodal force imbalance over the largest nodal weight), so that the reported shape is an equilibrium
/// and not a snapshot of a slowly creeping sheet.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Settle {
    /// Speed (m/s) below which the relaxation stops.
    pub rest_speed: f64,
    /// Most relaxation steps.
    pub max_steps: usize,
    /// Tolerance of the final static solve; `None` reports the relaxation's end as it is.
    pub equilibrium: Option<f64>,
    /// Start from a wobble of the hem with this many folds instead of the many-mode wobble (a study of the
    /// equilibria: the fold count is then chosen by the start, not by the fabric).
    pub folds: Option<usize>,
}

/// The default tolerance of the final static solve: the largest nodal force imbalance, in largest nodal weights.
pub const EQUILIBRIUM_TOLERANCE: f64 = 1e-5;

/// The rest speed (m/s) at which the relaxation hands over to the static solve. Since the static solver raises
/// the exact Hessian's shift before the positive semi-definite operator stands in, it converges from 1 cm/s to
/// the equilibria it finds from 1 mm/s and 0.1 mm/s (the three wovens and the paper's cotton at 30 cm, levels 1
/// and 2, and the wovens at 24 and 36 cm, level 1: the same DC to 1e-4 point; at level 2 of the 24 and 36 cm
/// specimens within 0.02 point, a tenth of the spread between specimens) in about half the relaxation's steps
/// (docs/materials.md, "The hand-over at 1 cm/s"). At 3 cm/s the medium woven finds another equilibrium.
pub const REST_SPEED: f64 = 1e-2;

/// The rest speed of a relaxation that is reported as it ends, without the static solve (`--no-static`).
pub const RELAXED_REST_SPEED: f64 = 1e-4;

impl Default for Settle {
    fn default() -> Self {
        Self { rest_speed: REST_SPEED, max_steps: 1500, equilibrium: Some(EQUILIBRIUM_TOLERANCE), folds: None }
    }
}

impl Settle {
    /// What is wrong with these settings on a grid of `angular` nodes around, naming the setting
    /// (`rest_speed` or `folds`); `None` where they can be run. A start of `folds` folds needs at least two nodes
    /// a fold around the hem (more folds alias to fewer on the grid, so the start would not be the one asked for).
    pub fn problem(&self, angular: usize) -> Option<(&'static str, String)> {
        let speed = self.rest_speed;
        if !(speed.is_finite() && speed > 0.0) {
            return Some(("rest_speed", format!("{speed} m/s must be positive")));
        }
        match self.folds {
            Some(q) if q == 0 || q > angular / 2 => Some((
                "folds",
                format!("{q} must be between 1 and {} (half the grid's {angular} nodes around)", angular / 2),
            )),
            _ => None,
        }
    }

    /// The default settling, or without the static solve (`static_solve` false): the relaxation's end is then
    /// the reported shape, so it runs on to [`RELAXED_REST_SPEED`].
    pub fn with_static_solve(static_solve: bool) -> Self {
        if static_solve {
            Self::default()
        } else {
            Self { rest_speed: RELAXED_REST_SPEED, equilibrium: None, ..Self::default() }
        }
    }
}

/// The specimen's polar grid: `radial` cells outside the disc, `angular` nodes around, and the radial cells
/// growing geometrically from the disc's edge to the hem, the last `grading` times the first (1: uniform).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PolarGrid {
    /// Radial cells outside the disc.
    pub radial: usize,
    /// Nodes around.
    pub angular: usize,
    /// Ratio of the last radial cell (at the hem) to the first (at the disc's edge).
    pub grading: f64,
}

impl PolarGrid {
    /// A uniform grid.
    pub fn uniform(radial: usize, angular: usize) -> Self {
        Self { radial, angular, grading: 1.0 }
    }

    /// The node spacings (m) on a specimen of diameter `specimen`: [mean radial, first radial (at the disc's
    /// edge), around the hem].
    pub fn spacing(&self, specimen: f64) -> [f64; 3] {
        let ring = Annulus { rd: 0.5 * DISC, rs: 0.5 * specimen, radial: self.radial.max(1), grading: self.grading };
        [(ring.rs - ring.rd) / ring.radial as f64, ring.first(), 2.0 * PI * ring.rs / self.angular.max(1) as f64]
    }
}

/// As [`cusick_specimen`] on `grid`, settled as `settle` says.
pub fn cusick_settled(
    fabric: &Fabric,
    calibration: Calibration,
    specimen: f64,
    grid: PolarGrid,
    index: usize,
    settle: &Settle,
) -> Result<Drape, LabError> {
    let ring = annulus(specimen, grid)?;
    let PolarGrid { radial, angular, .. } = grid;
    if let Some((setting, problem)) = settle.problem(angular) {
        return Err(LabError::Input(format!("cusick: settle.{setting}: {problem}")));
    }
    let s = Stiffness::calibrate(fabric, calibration)?;
    let (model, start) = clamped_specimen(fabric, s, &ring, [radial + 2, angular], (index, settle.folds))?;
    let (mut x, mut steps) = relax(fabric, &model, start, settle)?;
    let relaxed = (residual(&model, &x), drape_coefficient(&model, &x, &ring));
    let iterations = match settle.equilibrium {
        Some(tolerance) => settle_statically(fabric, &model, (&mut x, &mut steps), tolerance, settle)?,
        None => 0,
    };
    let mut drape = measure(model, x, &ring, specimen, steps);
    drape.report.relaxed_residual = relaxed.0;
    drape.report.relaxed_drape_coefficient = relaxed.1;
    drape.report.static_iterations = iterations;
    Ok(drape)
}

/// The annulus of a specimen of diameter `specimen` on `grid`, checked (its memory too:
/// [`specimen_memory`]).
fn annulus(specimen: f64, grid: PolarGrid) -> Result<Annulus, LabError> {
    let PolarGrid { radial, angular, grading } = grid;
    if !(specimen.is_finite() && specimen > DISC) {
        return Err(LabError::Input(format!("cusick: specimen {specimen} m must exceed the {DISC} m disc")));
    }
    if radial < 2 || angular < 8 || !(1.0..=100.0).contains(&grading) {
        return Err(LabError::Input(format!(
            "cusick: grid {radial} x {angular}, grading {grading}: at least 2 radial cells, 8 nodes around and \
             a grading between 1 and 100"
        )));
    }
    specimen_memory(specimen, grid, 1)?;
    Ok(Annulus { rd: 0.5 * DISC, rs: 0.5 * specimen, radial, grading })
}

/// The estimated memory (bytes) of `count` specimens of diameter `specimen` draped at once on `grid` (its
/// `radial + 2` rings of `angular` nodes), by the scene budget's estimate of a model, its step matrix and its
/// factor ([`budget::direct_solve_bytes`]); an error naming the grid (and the specimen, whose size sets the
/// default grids' rings) where the node count overflows or the estimate exceeds the default memory limit
/// ([`budget::DEFAULT_MAX_MEMORY`]), as a scene's is, instead of an allocation that aborts the process.
pub fn specimen_memory(specimen: f64, grid: PolarGrid, count: usize) -> Result<u64, LabError> {
    let PolarGrid { radial, angular, .. } = grid;
    let nodes = radial.checked_add(2).and_then(|m| m.checked_mul(angular));
    let bytes = nodes.map(|n| budget::direct_solve_bytes(n).saturating_mul(count as u64));
    match bytes {
        Some(b) if b <= budget::DEFAULT_MAX_MEMORY => Ok(b),
        _ => Err(LabError::Input(format!(
            "cusick: {count} specimen(s) of {specimen} m on {radial} radial cells x {angular} nodes around ({} \
             nodes each) need an estimated {} of memory, more than the limit of {} (a smaller specimen, a \
             coarser grid or fewer specimens at once)",
            nodes.map_or_else(|| "too many".to_string(), |n| n.to_string()),
            bytes.map_or_else(|| "unbounded amount".to_string(), budget::human),
            budget::human(budget::DEFAULT_MAX_MEMORY)
        ))),
    }
}

/// The flat specimen's model builder (its inner two rings clamped) of diameter `specimen` on `grid`, as
/// [`cusick_settled`] builds it: for the drape's sensitivities ([`crate::lab::fit`]).
pub fn specimen_builder(
    fabric: &Fabric,
    s: Stiffness,
    specimen: f64,
    grid: PolarGrid,
) -> Result<ModelBuilder, LabError> {
    let ring = annulus(specimen, grid)?;
    clamped_builder(fabric, s, &ring, [grid.radial + 2, grid.angular]).map(|(b, _)| b)
}

/// The specimen's annulus on the polar grid: disc radius `rd`, specimen radius `rs` (m), `radial` cells outside
/// the disc growing geometrically outwards, the last `grading` times the first.
#[derive(Clone, Copy)]
struct Annulus {
    rd: f64,
    rs: f64,
    radial: usize,
    grading: f64,
}

impl Annulus {
    /// Ratio of a radial cell to the one inside it.
    fn ratio(&self) -> f64 {
        if self.radial > 1 {
            self.grading.powf(1.0 / (self.radial - 1) as f64)
        } else {
            1.0
        }
    }

    /// The first radial cell, at the disc's edge (m): the free span `rs − rd − h₀/2` (the clamp's edge ring sits
    /// half a cell outside the disc) holds `radial` cells growing geometrically by [`Annulus::ratio`].
    fn first(&self) -> f64 {
        let (q, n, w) = (self.ratio(), self.radial as f64, self.rs - self.rd);
        let cells = if (q - 1.0).abs() < 1e-12 { n } else { (q.powf(n) - 1.0) / (q - 1.0) };
        w / (cells + 0.5)
    }

    /// Radius of ring `i` (m): 0 and 1 clamped, half a first cell inside and outside the disc's edge, so that
    /// the clamped segment between them is level at the edge itself (pinning two rings makes the slope vanish
    /// midway between them: a clamp at `rd − h₀` and `rd` would clamp at `rd − h₀/2`, an error of first order in
    /// the spacing); `radial + 1` the hem.
    fn radius(&self, i: usize) -> f64 {
        let (h0, q) = (self.first(), self.ratio());
        if i == 0 {
            return self.rd - 0.5 * h0;
        }
        let k = (i - 1) as f64;
        let grown = if (q - 1.0).abs() < 1e-12 { k } else { (q.powf(k) - 1.0) / (q - 1.0) };
        self.rd + h0 * (0.5 + grown)
    }
}

/// The flat specimen's builder on an `m × angular` polar grid, its inner two rings clamped, and the grid.
fn clamped_builder(
    fabric: &Fabric,
    s: Stiffness,
    ring: &Annulus,
    [m, angular]: [usize; 2],
) -> Result<(ModelBuilder, Grid), LabError> {
    let hr = (ring.rs - ring.rd) / ring.radial as f64;
    let grid = Grid::new(m, angular, hr, 2.0 * PI / angular as f64, [Topology::Free, Topology::Periodic])
        .map_err(|e| LabError::Input(format!("cusick: {e}")))?;
    let rest: Vec<Vec3> = (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            let t = j as f64 * grid.h2;
            Vec3::new(ring.radius(i) * t.cos(), ring.radius(i) * t.sin(), 0.0)
        })
        .collect();
    // The polar grid turns against the fixed warp: the condensed edge stiffness keeps its cells from locking
    // the folds (docs/materials.md, "The membrane's edge stiffness").
    let opts = ElasticOptions { warp_direction: Some(Vec3::X), condensed_stretch: true, ..Default::default() };
    let mut builder =
        ModelBuilder::new(grid, rest, *fabric, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81)).options(opts);
    for k in 0..grid.len() {
        builder.pinned[k] = grid.coords(k).0 <= 1;
    }
    Ok((builder, grid))
}

/// The flat specimen on an `m × angular` polar grid, its inner two rings clamped, and the start positions: a
/// small droop with a many-mode wobble of the hem whose phases depend on `index`.
fn clamped_specimen(
    fabric: &Fabric,
    s: Stiffness,
    ring: &Annulus,
    [m, angular]: [usize; 2],
    (index, folds): (usize, Option<usize>),
) -> Result<(Model, Vec<Vec3>), LabError> {
    let Annulus { rd, rs, .. } = *ring;
    let (builder, grid) = clamped_builder(fabric, s, ring, [m, angular])?;
    let rest = builder.panels[0].rest.clone();
    let radius = |i: usize| ring.radius(i);
    let model = builder.build()?;
    // A small droop with a many-mode wobble of the hem (deterministic phases): 1 cm at the hem, at most a third
    // of the overhang (a specimen a few millimetres wider than the disc started stretched 17-fold).
    let droop = 0.01_f64.min((rs - rd) / 3.0);
    let start: Vec<Vec3> = rest
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let (i, j) = grid.coords(k);
            let sr = ((radius(i) - rd) / (rs - rd)).max(0.0);
            let t = j as f64 * grid.h2;
            let phase = |q: usize| (q * q) as f64 * 0.7 + index as f64 * (1.3 * q as f64 + 0.4);
            let wobble: f64 = match folds {
                Some(q) => (phase(q) + q as f64 * t).cos(),
                None => (3..=10).map(|q| (phase(q) + q as f64 * t).cos() / 8.0).sum(),
            };
            *p + Vec3::new(0.0, 0.0, -droop * sr * sr * (1.0 + 0.5 * wobble))
        })
        .collect();
    Ok((model, start))
}

/// Damped implicit dynamics of `model` from `start` to rest; returns the positions and the steps taken.
fn relax(fabric: &Fabric, model: &Model, start: Vec<Vec3>, settle: &Settle) -> Result<(Vec<Vec3>, usize), LabError> {
    // Damped dynamics towards rest (heavy damping: the path does not matter, the drape does).
    let mut dyn_model = model.clone();
    let damping = 5.0 * fabric.density; // 1/s · kg/m²
    dyn_model.damping = dyn_model.area.iter().map(|a| a * damping).collect();
    let mut state = State::at_rest(start);
    let dt = 0.04;
    // At most one Newton correction per step, as this relaxation was calibrated with: a drape has several
    // equilibria, and the relaxation path (not the physics) picks one.
    let params = StepParams { dt, solver: SolverKind::Auto, newton_iterations: 2, ..StepParams::default() };
    let mut stepper = Stepper::new(&dyn_model, &params).map_err(|e| LabError::Step { test: "cusick", cause: e })?;
    let mut steps = 0;
    for _ in 0..settle.max_steps {
        stepper.step(&dyn_model, &mut state).map_err(|e| LabError::Step { test: "cusick", cause: e })?;
        steps += 1;
        let vmax = (0..state.x.len()).map(|k| state.velocity(k).length()).fold(0.0, f64::max);
        if vmax < settle.rest_speed {
            break;
        }
    }
    Ok((state.x, steps))
}

/// The static solve from the relaxation's end `x` (after `steps` relaxation steps). Where it fails (a sheet
/// that stopped creeping only just below the rest speed can lie outside Newton's reach: the stiff woven at
/// 24 × 144), the relaxation goes on from where it stopped at a tenth of the rest speed, then a hundredth,
/// and the solve is tried again from there; the third failure is the error. Returns the Newton iterations.
fn settle_statically(
    fabric: &Fabric,
    model: &Model,
    (x, steps): (&mut Vec<Vec3>, &mut usize),
    tolerance: f64,
    settle: &Settle,
) -> Result<usize, LabError> {
    let mut tries = 0;
    loop {
        let mut y = x.clone();
        match equilibrate(model, &mut y, tolerance) {
            Ok(iterations) => {
                *x = y;
                return Ok(iterations);
            }
            Err(e) if tries == 2 => return Err(e),
            Err(_) => {
                tries += 1;
                let slower = Settle { rest_speed: settle.rest_speed * 0.1f64.powi(tries), ..*settle };
                let (y, more) = relax(fabric, model, x.clone(), &slower)?;
                *x = y;
                *steps += more;
            }
        }
    }
}

/// Static Newton solves from `x` until the equilibrium residual ([`residual`], in nodal weights) is below
/// `tolerance`: the static solver judges its own tolerance against the largest elastic force at its start
/// (the clamp's reaction, hundreds of nodal weights), so each further solve tightens it by what the last one
/// missed (at most four solves, quadratically convergent from the previous; a residual left above `tolerance` by
/// round-off is reported, not an error). Returns the Newton iterations.
fn equilibrate(model: &Model, x: &mut [Vec3], tolerance: f64) -> Result<usize, LabError> {
    let err = |cause| LabError::Solve { test: "cusick", cause };
    let mut solver = StaticSolver::new(model).map_err(err)?;
    let (mut tol, mut iterations) = (tolerance, 0);
    for _ in 0..4 {
        let opts = StaticOptions { tolerance: tol.max(1e-15), max_iterations: 300 };
        iterations += solver.solve(model, x, &opts).map_err(err)?.iterations;
        let r = residual(model, x);
        if r <= tolerance {
            return Ok(iterations);
        }
        tol *= 0.5 * tolerance / r;
    }
    // At the round-off floor (measured 1e-6 to 4e-5 nodal weights on stiff or large specimens): the report
    // gives the residual reached.
    Ok(iterations)
}

/// Equilibrium residual of `x`: the largest nodal force imbalance relative to the largest nodal weight.
fn residual(model: &Model, x: &[Vec3]) -> f64 {
    let mut g = vec![Vec3::ZERO; x.len()];
    StaticSolver::potential(model, x, Some(&mut g));
    let weight = model.mass.iter().fold(0.0, |a: f64, m| a.max(m * 9.81));
    g.iter().map(|v| v.length()).fold(0.0, f64::max) / weight
}

/// Shadow area (m²) of the drape `x`: the xy footprint of its Coons surface (1024² raster) plus the hole inside
/// the clamp, and never less than the disc.
fn shadow_area(model: &Model, x: &[Vec3], ring: &Annulus) -> f64 {
    let (rd, inner) = (ring.rd, ring.radius(0));
    let mesh = CoonsSurface::new(&model.panels[0].grid, x).tessellate(4);
    let hole = PI * inner * inner;
    (projected_area_xy(&mesh, 1024) + hole).max(PI * rd * rd)
}

/// The drape coefficient (%) of the drape `x`.
fn drape_coefficient(model: &Model, x: &[Vec3], ring: &Annulus) -> f64 {
    let a_disc = PI * ring.rd * ring.rd;
    100.0 * (shadow_area(model, x, ring) - a_disc) / (PI * ring.rs * ring.rs - a_disc)
}

/// The drape `x` of `model` with its report: equilibrium residual, shadow, drape coefficient and folds.
fn measure(model: Model, x: Vec<Vec3>, ring: &Annulus, specimen: f64, steps: usize) -> Drape {
    // The specimen is one polar panel.
    let grid = model.panels[0].grid;
    let (m, angular) = (grid.m, grid.n);
    let shadow = shadow_area(&model, &x, ring);
    let a_disc = PI * ring.rd * ring.rd;
    let dc = 100.0 * (shadow - a_disc) / (PI * ring.rs * ring.rs - a_disc);
    let nodes = hem_nodes(&model, &x);
    let residual = residual(&model, &x);
    let report = CusickReport {
        specimen,
        drape_coefficient: dc,
        nodes,
        shadow_area: shadow,
        grid: [m, angular],
        steps,
        residual,
        relaxed_residual: residual,
        relaxed_drape_coefficient: dc,
        static_iterations: 0,
    };
    Drape { report, model, x }
}

/// The least radial depth of the hem's folds, as a share of the overhang (the specimen's rest radius beyond the
/// disc), for a drape to have nodes: a hem within it lies level, with no fold a drape meter's shadow shows.
/// Measured on five fabrics at 19–36 cm (level 1): specimens that drape have hem radii varying by 4–66 % of the
/// overhang, specimens that hardly drape (DC ≥ 99.4 %) by 0.04–0.33 %, whose wobble's remnant was counted as
/// four to eight nodes.
pub const LEVEL_HEM: f64 = 0.01;

/// The drape's node count: the folds of the hem (the outer ring of the specimen's polar grid, `x` its nodes)
/// counted as [`count_folds`] counts them, or none where the hem lies level ([`LEVEL_HEM`]).
pub fn hem_nodes(model: &Model, x: &[Vec3]) -> usize {
    let panel = &model.panels[0];
    let grid = panel.grid;
    let radii: Vec<f64> = (0..grid.n).map(|j| x[grid.index(grid.m - 1, j)].truncate().length()).collect();
    let overhang = panel.rest()[grid.index(grid.m - 1, 0)].truncate().length() - 0.5 * DISC;
    let (lo, hi) = radii.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &r| (a.0.min(r), a.1.max(r)));
    if hi - lo < LEVEL_HEM * overhang {
        return 0;
    }
    count_folds(&radii)
}

/// Local maxima of the (periodic) hem radius, after a 3-point smoothing, that stand out by more than 2% of the
/// radius range.
fn count_folds(r: &[f64]) -> usize {
    let n = r.len();
    let s: Vec<f64> = (0..n).map(|j| (r[(j + n - 1) % n] + 2.0 * r[j] + r[(j + 1) % n]) / 4.0).collect();
    let (lo, hi) = s.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &v| (a.0.min(v), a.1.max(v)));
    if hi - lo < 1e-6 * hi {
        return 0;
    }
    let tol = 0.02 * (hi - lo);
    (0..n).filter(|&j| s[j] > s[(j + n - 1) % n] && s[j] >= s[(j + 1) % n] && s[j] - lo > tol).count()
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    /// `count_folds`.
    pub fn count_folds(r: &[f64]) -> usize {
        super::count_folds(r)
    }
}
