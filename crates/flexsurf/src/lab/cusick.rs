//! The Cusick drape test (BS 5058 / ISO 9073-9): a circular specimen clamped between 18 cm discs drapes under
//! gravity; the drape coefficient is the shadow area outside the disc as a percentage of the specimen's area
//! outside the disc, `DC = (A_shadow − A_disc)/(A_specimen − A_disc) × 100`, and the nodes are the folds around
//! the hem.
//!
//! The specimen is an annulus on a polar grid (u1 radial, free; u2 around, periodic), warp along x (a fixed
//! direction of the flat pattern, so the strains are measured in the fabric's axes at every point). Its inner two
//! rings (radius `R_disc − h` and `R_disc`) are clamped. The drape is found by damped implicit dynamics from the
//! flat state with a small many-mode perturbation of the hem (so that the fold count is chosen by the fabric, not
//! by the perturbation), run until no node moves faster than 0.1 mm/s; the remaining equilibrium residual is
//! reported. The shadow is the xy footprint of the Coons
//! display surface (raster), plus the uncovered hole inside the clamp.
//!
//! Bending of an anisotropic fabric on this grid: the frame is not aligned with the grid except along the axes;
//! the bending energy carries the twist/normal-curvature coupling there (see `Bending::with_warp`).

use super::LabError;
use crate::grid::{Grid, Topology};
use crate::integrate::linsolve::SolverKind;
use crate::integrate::statics::StaticSolver;
use crate::integrate::{StepParams, Stepper};
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::Vec3;
use crate::model::{ElasticOptions, Model, ModelBuilder, ModelKind};
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
    /// Equilibrium residual at the end: largest nodal force imbalance over the largest nodal weight.
    pub residual: f64,
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

/// Default grids: radial cells of about 7.5, 5 and 3.75 mm outside the disc (level 0, 1, 2) and 48, 72, 96
/// nodes around. Level 1 is the default; levels 1 and 2 are the convergence check.
pub fn default_grid(specimen: f64, level: usize) -> (usize, usize) {
    let h = [0.0075, 0.005, 0.00375][level.min(2)];
    let radial = (((0.5 * specimen - 0.5 * DISC) / h).round() as usize).max(2);
    (radial, [48, 72, 96][level.min(2)])
}

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
    let s = Stiffness::calibrate(fabric, calibration)?;
    let (rd, rs) = (0.5 * DISC, 0.5 * specimen);
    let hr = (rs - rd) / radial as f64;
    let ring = Annulus { rd, rs, hr };
    let (model, start) = clamped_specimen(fabric, s, &ring, radial + 2, angular, index)?;
    let (x, steps) = relax(fabric, &model, start)?;
    Ok(measure(model, x, &ring, specimen, steps))
}

/// The specimen's annulus on the polar grid: disc radius `rd`, specimen radius `rs`, radial cell `hr` (m).
#[derive(Clone, Copy)]
struct Annulus {
    rd: f64,
    rs: f64,
    hr: f64,
}

/// The flat specimen on an `m × angular` polar grid, its inner two rings clamped, and the start positions: a
/// small droop with a many-mode wobble of the hem whose phases depend on `index`.
fn clamped_specimen(
    fabric: &Fabric,
    s: Stiffness,
    ring: &Annulus,
    m: usize,
    angular: usize,
    index: usize,
) -> Result<(Model, Vec<Vec3>), LabError> {
    let Annulus { rd, rs, hr } = *ring;
    let grid = Grid::new(m, angular, hr, 2.0 * PI / angular as f64, [Topology::Free, Topology::Periodic])
        .expect("valid polar grid");
    let radius = |i: usize| rd - hr + i as f64 * hr;
    let rest: Vec<Vec3> = (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            let t = j as f64 * grid.h2;
            Vec3::new(radius(i) * t.cos(), radius(i) * t.sin(), 0.0)
        })
        .collect();
    let opts = ElasticOptions { warp_direction: Some(Vec3::X), ..Default::default() };
    let mut model =
        ModelBuilder::new(grid, rest.clone(), *fabric, s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -9.81)).options(opts);
    for k in 0..grid.len() {
        model.pinned[k] = grid.coords(k).0 <= 1;
    }
    let model = model.build()?;
    // A small droop with a many-mode wobble of the hem (deterministic phases).
    let start: Vec<Vec3> = rest
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let (i, j) = grid.coords(k);
            let sr = ((radius(i) - rd) / (rs - rd)).max(0.0);
            let t = j as f64 * grid.h2;
            let phase = |q: usize| (q * q) as f64 * 0.7 + index as f64 * (1.3 * q as f64 + 0.4);
            let wobble: f64 = (3..=10).map(|q| (phase(q) + q as f64 * t).cos() / 8.0).sum();
            *p + Vec3::new(0.0, 0.0, -0.01 * sr * sr * (1.0 + 0.5 * wobble))
        })
        .collect();
    Ok((model, start))
}

/// Damped implicit dynamics of `model` from `start` to rest; returns the positions and the steps taken.
fn relax(fabric: &Fabric, model: &Model, start: Vec<Vec3>) -> Result<(Vec<Vec3>, usize), LabError> {
    // Damped dynamics towards rest (heavy damping: the path does not matter, the drape does).
    let mut dyn_model = model.clone();
    let damping = 5.0 * fabric.density; // 1/s · kg/m²
    dyn_model.damping = dyn_model.area.iter().map(|a| a * damping).collect();
    let mut state = State::at_rest(start);
    let dt = 0.04;
    // At most one Newton correction per step, as this relaxation was calibrated with: a drape has several
    // equilibria, and the relaxation path (not the physics) picks one.
    let params = StepParams { dt, solver: SolverKind::Auto, newton_iterations: 2, ..StepParams::default() };
    let mut stepper = Stepper::new(&dyn_model, &params).map_err(|e| LabError::Step { test: "cusick", source: e })?;
    // To rest: stop when no node moves faster than 0.1 mm/s (or after 1500 steps).
    let mut steps = 0;
    for _ in 0..1500 {
        stepper.step(&dyn_model, &mut state).map_err(|e| LabError::Step { test: "cusick", source: e })?;
        steps += 1;
        let vmax = (0..state.x.len()).map(|k| state.velocity(k).length()).fold(0.0, f64::max);
        if vmax < 1e-4 {
            break;
        }
    }
    Ok((state.x, steps))
}

/// The drape `x` of `model` with its report: equilibrium residual, shadow, drape coefficient and folds.
fn measure(model: Model, x: Vec<Vec3>, ring: &Annulus, specimen: f64, steps: usize) -> Drape {
    let Annulus { rd, rs, hr } = *ring;
    // The specimen is one polar panel.
    let grid = model.panels[0].grid;
    let (m, angular) = (grid.m, grid.n);
    // Equilibrium residual: largest nodal force imbalance relative to the largest nodal weight.
    let mut g = vec![Vec3::ZERO; x.len()];
    StaticSolver::potential(&model, &x, Some(&mut g));
    let weight = model.mass.iter().fold(0.0, |a: f64, m| a.max(m * 9.81));
    let residual = g.iter().map(|v| v.length()).fold(0.0, f64::max) / weight;
    let mesh = CoonsSurface::new(&grid, &x).tessellate(4);
    let hole = PI * (rd - hr) * (rd - hr);
    let shadow = (projected_area_xy(&mesh, 1024) + hole).max(PI * rd * rd);
    let a_disc = PI * rd * rd;
    let dc = 100.0 * (shadow - a_disc) / (PI * rs * rs - a_disc);
    let nodes = count_folds(&(0..angular).map(|j| x[grid.index(m - 1, j)].truncate().length()).collect::<Vec<_>>());
    let report = CusickReport {
        specimen,
        drape_coefficient: dc,
        nodes,
        shadow_area: shadow,
        grid: [m, angular],
        steps,
        residual,
    };
    Drape { report, model, x }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folds_of_a_six_lobed_hem() {
        let r: Vec<f64> = (0..72).map(|j| 0.12 + 0.01 * (6.0 * j as f64 * 2.0 * PI / 72.0).cos()).collect();
        assert_eq!(count_folds(&r), 6);
        assert_eq!(count_folds(&[0.1; 12]), 0);
    }
}
