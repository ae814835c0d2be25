//! The KES-F style round trip: small specimens of the fabric, loaded as the Kawabata instruments load them,
//! solved to static equilibrium, and the stiffnesses read back:
//! - tension along warp, weft and the 45° bias: a strip clamped at one end (two node columns pinned) and pulled
//!   by a uniform line load `T` at the other; the strain is read between two columns in the middle, away from the
//!   clamp, so the lateral contraction is free (uniaxial stress). Recovered `E·h = T/ε`.
//! - simple shear: a square specimen with every boundary node held at the homogeneous shear `γ`; the shear
//!   resultant is the clamp reaction along the top edge per unit length. Recovered `G = N12/γ`.
//! - pure bending along warp and weft: a strip clamped at one end with an end couple `M` per width (opposite
//!   line loads on the last two columns), small curvature; `κ` from a least-squares parabola through the middle
//!   third. Recovered `K = M/κ`.
//!
//! The bias test is reported against the orthotropic prediction
//! `1/E(45°) = ¼ (1/E1 + 1/E2 + 1/G − 2ν12/E1)`.

use super::dense::{det3, with_column};
use super::LabError;
use crate::grid::Grid;
use crate::integrate::statics::{StaticOptions, StaticSolver};
use crate::material::law::Laws;
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::Vec3;
use crate::model::{ElasticOptions, Model, ModelBuilder, ModelKind};
use serde::Serialize;
use std::sync::Arc;

pub use super::kes_curves::{bending_loop, kes_curves, linear_laws, shear_loop, CurvePoint, CurveReport, CurveTest};

/// The five constants the round trip compares.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct KesValues {
    /// Tensile stiffness along warp, `E1·h` (N/m).
    pub tensile_warp: f64,
    /// Tensile stiffness along weft, `E2·h` (N/m).
    pub tensile_weft: f64,
    /// Shear stiffness per radian (N/m).
    pub shear: f64,
    /// Bending rigidity along warp (N·m).
    pub bending_warp: f64,
    /// Bending rigidity along weft (N·m).
    pub bending_weft: f64,
    /// Tensile stiffness along the 45° bias (N/m).
    pub tensile_bias: f64,
}

/// Input, recovered values and relative errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct KesReport {
    /// What the fabric says (the bias value is the orthotropic prediction).
    pub input: KesValues,
    /// What the virtual instruments measured.
    pub recovered: KesValues,
    /// `recovered / input − 1`.
    pub relative_error: KesValues,
}

impl KesReport {
    /// Largest relative error over the five measured constants and the bias.
    pub fn worst(&self) -> f64 {
        let e = &self.relative_error;
        [e.tensile_warp, e.tensile_weft, e.shear, e.bending_warp, e.bending_weft, e.tensile_bias]
            .iter()
            .fold(0.0, |a: f64, b| a.max(b.abs()))
    }
}

/// Runs all KES virtual tests on `fabric` with `calibration`.
pub fn kes(fabric: &Fabric, calibration: Calibration) -> Result<KesReport, LabError> {
    let s = Stiffness::calibrate(fabric, calibration)?;
    let f = fabric;
    let bias = 4.0 / (1.0 / f.tensile_warp + 1.0 / f.tensile_weft + 1.0 / f.shear - 2.0 * f.poisson / f.tensile_warp);
    let input = KesValues {
        tensile_warp: f.tensile_warp,
        tensile_weft: f.tensile_weft,
        shear: f.shear,
        bending_warp: f.bending_warp,
        bending_weft: f.bending_weft,
        tensile_bias: bias,
    };
    let recovered = KesValues {
        tensile_warp: tension(f, &s, 0.0)?,
        tensile_weft: tension(f, &s, std::f64::consts::FRAC_PI_2)?,
        shear: shear(f, &s)?,
        bending_warp: bending(f, &s, false)?,
        bending_weft: bending(f, &s, true)?,
        tensile_bias: tension(f, &s, std::f64::consts::FRAC_PI_4)?,
    };
    let rel = |r: f64, i: f64| r / i - 1.0;
    let relative_error = KesValues {
        tensile_warp: rel(recovered.tensile_warp, input.tensile_warp),
        tensile_weft: rel(recovered.tensile_weft, input.tensile_weft),
        shear: rel(recovered.shear, input.shear),
        bending_warp: rel(recovered.bending_warp, input.bending_warp),
        bending_weft: rel(recovered.bending_weft, input.bending_weft),
        tensile_bias: rel(recovered.tensile_bias, input.tensile_bias),
    };
    Ok(KesReport { input, recovered, relative_error })
}

pub(super) fn solve(model: &Model, x: &mut [Vec3], test: &'static str) -> Result<(), LabError> {
    let opts = StaticOptions { tolerance: 1e-10, max_iterations: 100 };
    StaticSolver::new(model)
        .and_then(|mut s| s.solve(model, x, &opts))
        .map(|_| ())
        .map_err(|cause| LabError::Solve { test, cause })
}

/// Tension test with the warp at `angle` from the strip's axis (u1); returns `T/ε`.
fn tension(f: &Fabric, s: &Stiffness, angle: f64) -> Result<f64, LabError> {
    // Line load T small enough for a linear response: strain ~1e-5.
    let t = 1e-5 * f.tensile_warp.min(f.tensile_weft).min(f.shear);
    let mut x = None;
    Ok(t / tension_strain(f, s, None, angle, t, &mut x)?)
}

/// The tension strip's engineering strain under the nominal line load `t` (N/m) with the warp at `angle` from
/// its axis; `x` is the start (the flat strip when `None`) and holds the equilibrium afterwards.
pub(super) fn tension_strain(
    f: &Fabric,
    s: &Stiffness,
    laws: Option<&Arc<Laws>>,
    angle: f64,
    t: f64,
    x: &mut Option<Vec<Vec3>>,
) -> Result<f64, LabError> {
    let (len, width, m, n) = (0.5, 0.04, 101, 9);
    let grid = Grid::sheet(m, n, len, width).expect("valid strip grid");
    let rest = grid.flat_positions(0.0);
    let opts = ElasticOptions { warp_angle: angle, ..Default::default() };
    let mut model = ModelBuilder::new(grid, rest.clone(), *f, *s, ModelKind::Tfs, Vec3::ZERO).options(opts);
    model.laws = laws.cloned();
    for k in 0..grid.len() {
        let (i, j) = grid.coords(k);
        model.pinned[k] = i <= 1;
        if i == m - 1 {
            model.loads[k] = Vec3::new(t * grid.h2 * grid.trapezoid(1, j), 0.0, 0.0);
        }
    }
    let model = model.build()?;
    let x = x.get_or_insert(rest);
    solve(&model, x, "tension")?;
    // Strain between columns a and b (middle of the strip), averaged across the width.
    let (a, b) = (m / 2 - 5, m / 2 + 5);
    let stretch: f64 =
        (0..n).map(|j| (x[grid.index(b, j)].x - x[grid.index(a, j)].x) * grid.trapezoid(1, j)).sum::<f64>()
            / (0..n).map(|j| grid.trapezoid(1, j)).sum::<f64>();
    Ok(stretch / ((b - a) as f64 * grid.h1) - 1.0)
}

/// Simple shear of a clamped square; returns `N12/γ`.
fn shear(f: &Fabric, s: &Stiffness) -> Result<f64, LabError> {
    let (side, m) = (0.05, 11);
    let grid = Grid::sheet(m, m, side, side).expect("valid square grid");
    let rest = grid.flat_positions(0.0);
    let model = {
        let mut model = ModelBuilder::new(grid, rest.clone(), *f, *s, ModelKind::Tfs, Vec3::ZERO);
        for k in 0..grid.len() {
            let (i, j) = grid.coords(k);
            model.pinned[k] = grid.on_free_edge(0, i) || grid.on_free_edge(1, j);
        }
        model.build()?
    };
    let gamma = 1e-4;
    let mut x: Vec<Vec3> = rest.iter().map(|p| Vec3::new(p.x + gamma * p.y, p.y, p.z)).collect();
    solve(&model, &mut x, "shear")?;
    // Reaction of the top clamp along x: minus the elastic force on the top row.
    let mut g = vec![Vec3::ZERO; grid.len()];
    model.elastic(&x, Some(&mut g));
    let top: f64 = (0..m).map(|i| g[grid.index(i, m - 1)].x).sum();
    Ok(top / side / gamma)
}

/// Pure bending of a strip along warp (or weft); returns `M/κ`.
fn bending(f: &Fabric, s: &Stiffness, along_weft: bool) -> Result<f64, LabError> {
    let rigidity = if along_weft { f.bending_weft } else { f.bending_warp };
    // Couple per width M with curvature ~0.1 1/m: a pure moment to 1e-3 under dead loads.
    let moment = 0.1 * rigidity;
    Ok(moment / bending_curvature(f, s, None, along_weft, moment, 0.2)?)
}

/// The curvature of a strip of length `len` along warp (or weft) clamped at one end, under the end couple
/// `moment` per width (opposite line loads on its last two columns): from a least-squares parabola through its
/// middle third. A pure moment to `O(θ²)` for an end rotation `θ = κ len` (so `len` keeps `θ` near 0.02).
pub(super) fn bending_curvature(
    f: &Fabric,
    s: &Stiffness,
    laws: Option<&Arc<Laws>>,
    along_weft: bool,
    moment: f64,
    len: f64,
) -> Result<f64, LabError> {
    let (width, m, n) = (0.1 * len, 41, 3);
    // The strip runs along u1 for warp, along u2 for weft (warp along u1 in both).
    let (grid, d) = if along_weft {
        (Grid::sheet(n, m, width, len).expect("valid strip grid"), 1)
    } else {
        (Grid::sheet(m, n, len, width).expect("valid strip grid"), 0)
    };
    let rest = grid.flat_positions(0.0);
    let mut model = ModelBuilder::new(grid, rest.clone(), *f, *s, ModelKind::Tfs, Vec3::ZERO);
    model.laws = laws.cloned();
    let along = |k: usize| if d == 0 { grid.coords(k).0 } else { grid.coords(k).1 };
    let across = |k: usize| if d == 0 { grid.coords(k).1 } else { grid.coords(k).0 };
    let h = grid.spacing(d);
    let force = moment * width / h / (n as f64 - 1.0);
    for k in 0..grid.len() {
        model.pinned[k] = along(k) <= 1;
        let w = grid.trapezoid(1 - d, across(k));
        if along(k) == m - 1 {
            model.loads[k] = Vec3::new(0.0, 0.0, force * w);
        } else if along(k) == m - 2 {
            model.loads[k] = Vec3::new(0.0, 0.0, -force * w);
        }
    }
    let model = model.build()?;
    let mut x = rest.clone();
    solve(&model, &mut x, "bending")?;
    let mid = n / 2;
    let pts: Vec<(f64, f64)> = (m / 3..2 * m / 3)
        .map(|c| {
            let k = if d == 0 { grid.index(c, mid) } else { grid.index(mid, c) };
            (c as f64 * h, x[k].z)
        })
        .collect();
    Ok(2.0 * parabola(&pts))
}

/// Leading coefficient `a` of the least-squares `z = a s² + b s + c`.
fn parabola(pts: &[(f64, f64)]) -> f64 {
    let mut a = [[0.0; 3]; 3];
    let mut r = [0.0; 3];
    for &(s, z) in pts {
        let phi = [s * s, s, 1.0];
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += phi[i] * phi[j];
            }
            r[i] += phi[i] * z;
        }
    }
    // Cramer's rule on the 3×3 normal equations.
    det3(&with_column(&a, 0, r)) / det3(&a)
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    /// `parabola`.
    pub fn parabola(pts: &[(f64, f64)]) -> f64 {
        super::parabola(pts)
    }
}
