//! The KES round trip of a nonlinear fabric's curves (docs/materials.md, "Nonlinear fabrics"): each measured
//! point of each law, loaded as the instrument loads it, solved to static equilibrium, and read back.
//!
//! - tension (warp, weft): the strip of the linear test under the point's nominal force per width `T`; the
//!   engineering strain read between two middle columns is compared with the point's;
//! - shear: a square with its boundary held at the trellis shear of the point's angle `φ` (warp and weft turned
//!   by `±φ/2`, unstretched); the interior relaxes; the shear resultant is the boundary's virtual work per unit
//!   area and unit `γ = sin φ`, `N = Σ f_k·∂x_k/∂φ / (A cos φ)`, compared with the point's. The square is small
//!   enough (at most 5 cm) for its bending to keep it from wrinkling: the instrument's pre-tension does that;
//!   a wrinkled square measures less (2 % at 0.5° on the shipped example's 5 cm square);
//! - bending (warp, weft): as the KES bending tester, a strip (41 × 3 nodes, at most 20 cm long and bent by at
//!   most 1.5 rad) with both ends clamped (two node columns each) on the arc of the point's curvature, the
//!   interior relaxed; the moment per width is the couple on the end clamp (`Σ (x_k − x_c) × f_k`) over the
//!   width, compared with the point's. (The linear test's dead-load couple cannot reach a KES curvature of
//!   2.5 cm⁻¹: the strip short enough to keep the couple's rotation small carries end forces `M/h` that stretch
//!   it.)
//!
//! The strains and resultants are reported as measured (engineering strain and nominal force per width,
//! shear angle, curvature), in SI.

use super::kes::{solve, tension_strain};
use super::LabError;
use crate::energy::nonlinear::{NonlinearBending, NonlinearMembrane};
use crate::grid::Grid;
use crate::material::law::{Curve, Laws};
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::Vec3;
use crate::model::{ModelBuilder, ModelKind};
use serde::Serialize;
use std::sync::Arc;

/// One measured point of a law against what the virtual instrument read there.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CurvePoint {
    /// The point's strain (engineering strain, shear angle in rad, curvature in 1/m).
    pub strain_input: f64,
    /// The point's resultant (nominal force per width N/m, shear force per length N/m, moment per width N).
    pub resultant_input: f64,
    /// The strain the instrument read (tension, bending) or imposed (shear).
    pub strain_measured: f64,
    /// The resultant the instrument applied (tension, bending) or read (shear).
    pub resultant_measured: f64,
    /// The measured quantity over the input one, minus 1 (strain for tension and bending, resultant for shear).
    pub relative_error: f64,
}

/// One law's virtual test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CurveTest {
    /// `tensile_warp`, `tensile_weft`, `shear`, `bending_warp` or `bending_weft`.
    pub law: &'static str,
    /// Its points, in increasing strain.
    pub points: Vec<CurvePoint>,
    /// The input law sampled densely from 0 to its last point, as (strain, resultant) in the points' units.
    pub law_samples: Vec<(f64, f64)>,
}

/// The virtual tests of every law of a fabric.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CurveReport {
    /// One per law with a curve.
    pub tests: Vec<CurveTest>,
}

impl CurveReport {
    /// The largest relative error over every point.
    pub fn worst(&self) -> f64 {
        self.tests.iter().flat_map(|t| &t.points).fold(0.0, |a: f64, p| a.max(p.relative_error.abs()))
    }
}

/// Runs the virtual test of every law of `laws` on `fabric` (whose constants of those directions become the
/// laws' quadratic parts, [`Laws::apply`]) with the `kes` calibration.
pub fn kes_curves(fabric: &Fabric, laws: &Laws) -> Result<CurveReport, LabError> {
    let (applied, s, shared) = applied(fabric, laws)?;
    let fabric = &applied;
    let mut tests = Vec::new();
    let positive = |c: &Curve| c.points().iter().copied().filter(|p| p.0 > 0.0).collect::<Vec<_>>();
    for (law, curve, angle) in
        [("tensile_warp", &laws.tensile_warp, 0.0), ("tensile_weft", &laws.tensile_weft, std::f64::consts::FRAC_PI_2)]
    {
        let Some(c) = curve else { continue };
        let mut x = None;
        let mut points = Vec::new();
        for (e, n) in positive(c) {
            // Green strain and conjugate force to engineering strain and nominal force.
            let strain = (1.0 + 2.0 * e).sqrt() - 1.0;
            let t = n * (1.0 + strain);
            let measured = tension_strain(fabric, &s, Some(&shared), angle, t, &mut x)?;
            points.push(point(strain, t, measured, t, measured / strain - 1.0));
        }
        let law_samples = samples(c, |e, n| {
            let strain = (1.0 + 2.0 * e).sqrt() - 1.0;
            (strain, n * (1.0 + strain))
        });
        tests.push(CurveTest { law, points, law_samples });
    }
    if let Some(c) = &laws.shear {
        let mut x = None;
        let mut points = Vec::new();
        let n_max = c.points().iter().fold(0.0, |a: f64, p| a.max(p.1.abs()));
        let side = square_side(&s, n_max);
        for (g, n) in positive(c) {
            let phi = g.asin();
            let measured = shear_resultant(fabric, &s, &shared, (phi, side), None, &mut x)?;
            points.push(point(phi, n, phi, measured, measured / n - 1.0));
        }
        tests.push(CurveTest { law: "shear", points, law_samples: samples(c, |g, n| (g.asin(), n)) });
    }
    for (law, curve, weft) in [("bending_warp", &laws.bending_warp, false), ("bending_weft", &laws.bending_weft, true)]
    {
        let Some(c) = curve else { continue };
        let mut points = Vec::new();
        for (k, m) in positive(c) {
            let measured = bending_moment(fabric, &s, &shared, weft, k)?;
            points.push(point(k, m, k, measured, measured / m - 1.0));
        }
        tests.push(CurveTest { law, points, law_samples: samples(c, |k, m| (k, m)) });
    }
    Ok(CurveReport { tests })
}

/// `fabric` with the laws' quadratic parts ([`Laws::apply`]), its `kes` stiffness and the laws shared with the
/// test's terms: what every virtual test of this module starts from.
fn applied(fabric: &Fabric, laws: &Laws) -> Result<(Fabric, Stiffness, Arc<Laws>), LabError> {
    let mut applied = *fabric;
    laws.apply(&mut applied)?;
    let s = Stiffness::calibrate(&applied, Calibration::Kes)?;
    Ok((applied, s, Arc::new(laws.clone())))
}

/// The side of the sheared square: a clamped square plate wrinkles once its compressive principal stress (the
/// shear resultant) exceeds about 9.34 π² D/b²; the side b keeps that 4 times above `n_max`, at most 5 cm.
fn square_side(s: &Stiffness, n_max: f64) -> f64 {
    (std::f64::consts::PI * (9.34 * s.d11.min(s.d22) / (4.0 * n_max)).sqrt()).min(0.05)
}

/// A KES shear cycle with the shear hysteresis `2HG` (`half_width` = HG, N/m): the square of the curve test
/// sheared to angles `0 → φmax → −φmax → φmax` in `steps` increments per quarter (the first from the unsheared
/// square, without hysteresis), each a static solve lagged at the previous one. Returns `(φ, N)` (shear angle in
/// rad, shear force per length in N/m) along the cycle from `φmax/steps`; the closed loop starts at index
/// `steps − 1`. The resultant is the hysteresis's `±HG` on top of the elastic law once the square slides.
pub fn shear_loop(
    fabric: &Fabric,
    laws: &Laws,
    half_width: f64,
    phi_max: f64,
    steps: usize,
) -> Result<Vec<(f64, f64)>, LabError> {
    let (applied, s, shared) = applied(fabric, laws)?;
    let elastic = |g: f64| laws.shear.as_ref().map_or(applied.shear * g, |c| c.resultant(g));
    let side = square_side(&s, elastic(phi_max.sin()).abs() + half_width);
    let q = steps.max(1) as f64;
    let path = (1..=steps)
        .map(|i| i as f64 / q)
        .chain((1..=2 * steps).map(|i| 1.0 - i as f64 / q))
        .chain((1..=2 * steps).map(|i| -1.0 + i as f64 / q))
        .map(|t| t * phi_max);
    let mut x = None;
    let eps = 1e-3 * phi_max.sin();
    path.map(|p| Ok((p, shear_resultant(&applied, &s, &shared, (p, side), Some((half_width, eps)), &mut x)?))).collect()
}

/// 100 samples of the law `c` from 0 to its last point, mapped to the measured variables by `to`.
fn samples(c: &Curve, to: impl Fn(f64, f64) -> (f64, f64)) -> Vec<(f64, f64)> {
    let last = c.points().last().map_or(0.0, |p| p.0);
    (0..=100).map(|i| last * i as f64 / 100.0).map(|x| to(x, c.resultant(x))).collect()
}

fn point(si: f64, ri: f64, sm: f64, rm: f64, relative_error: f64) -> CurvePoint {
    CurvePoint { strain_input: si, resultant_input: ri, strain_measured: sm, resultant_measured: rm, relative_error }
}

/// The trellis shear of a square of `side` at angle `phi`: its boundary held, the interior relaxed from `x`
/// (the previous angle's equilibrium), the shear resultant from the boundary's virtual work.
fn shear_resultant(
    f: &Fabric,
    s: &Stiffness,
    laws: &Arc<Laws>,
    (phi, side): (f64, f64),
    hysteresis: Option<(f64, f64)>,
    x: &mut Option<Vec<Vec3>>,
) -> Result<f64, LabError> {
    let m = 11;
    let grid = Grid::sheet(m, m, side, side).expect("valid square grid");
    let rest = grid.flat_positions(0.0);
    let mut model = ModelBuilder::new(grid, rest.clone(), *f, *s, ModelKind::Tfs, Vec3::ZERO);
    model.laws = Some(laws.clone());
    let boundary = |k: usize| {
        let (i, j) = grid.coords(k);
        grid.on_free_edge(0, i) || grid.on_free_edge(1, j)
    };
    for k in 0..grid.len() {
        model.pinned[k] = boundary(k);
    }
    if let (Some((hg, eps)), Some(reference)) = (hysteresis, x.as_ref()) {
        let warp = crate::energy::frame::Warp::default();
        if let Some(term) = NonlinearMembrane::shear_hysteresis(&grid, &rest, hg, eps, warp, reference) {
            model.extra_terms.push(Box::new(term));
        }
    }
    let model = model.build()?;
    // Warp (u1) turned by +φ/2 and weft (u2) by −φ/2 about the centre: lengths kept, angle 90° − φ.
    let (c, sn) = ((0.5 * phi).cos(), (0.5 * phi).sin());
    let map = |p: Vec3| Vec3::new(p.x * c + p.y * sn, p.x * sn + p.y * c, 0.0);
    let rate = |p: Vec3| Vec3::new(-p.x * sn + p.y * c, p.x * c - p.y * sn, 0.0) * 0.5;
    let centre = Vec3::new(0.5 * side, 0.5 * side, 0.0);
    let mut y: Vec<Vec3> = match x.take() {
        Some(prev) => prev,
        None => rest.iter().map(|&p| map(p - centre) + centre).collect(),
    };
    for k in (0..grid.len()).filter(|&k| boundary(k)) {
        y[k] = map(rest[k] - centre) + centre;
    }
    solve(&model, &mut y, "shear")?;
    let mut g = vec![Vec3::ZERO; grid.len()];
    model.elastic(&y, Some(&mut g));
    let work: f64 = (0..grid.len()).filter(|&k| boundary(k)).map(|k| g[k].dot(rate(rest[k] - centre))).sum();
    *x = Some(y);
    Ok(work / (side * side * phi.cos()))
}

/// The moment per width of a strip along warp (or weft) held by both ends on an arc of curvature `kappa`.
fn bending_moment(f: &Fabric, s: &Stiffness, laws: &Arc<Laws>, along_weft: bool, kappa: f64) -> Result<f64, LabError> {
    let arc = BendingTester { f, s, laws, along_weft, len: (1.5 / kappa).min(0.2) };
    arc.moment(kappa, None, &mut None)
}

/// A strip on the KES bending tester: both ends clamped (two node columns each) on an arc.
struct BendingTester<'a> {
    f: &'a Fabric,
    s: &'a Stiffness,
    laws: &'a Arc<Laws>,
    along_weft: bool,
    len: f64,
}

impl BendingTester<'_> {
    /// The signed moment per width at curvature `kappa` (positive bending up), with a bending hysteresis
    /// `(HB, smoothing)` lagged at `x` (the previous equilibrium, which `x` holds afterwards).
    fn moment(&self, kappa: f64, hysteresis: Option<(f64, f64)>, x: &mut Option<Vec<Vec3>>) -> Result<f64, LabError> {
        let (width, m, n) = (0.1 * self.len, 41, 3);
        let (grid, d) = if self.along_weft {
            (Grid::sheet(n, m, width, self.len).expect("valid strip grid"), 1)
        } else {
            (Grid::sheet(m, n, self.len, width).expect("valid strip grid"), 0)
        };
        let rest = grid.flat_positions(0.0);
        let mut model = ModelBuilder::new(grid, rest.clone(), *self.f, *self.s, ModelKind::Tfs, Vec3::ZERO);
        model.laws = Some(self.laws.clone());
        let along = |k: usize| if d == 0 { grid.coords(k).0 } else { grid.coords(k).1 };
        for k in 0..grid.len() {
            model.pinned[k] = along(k) <= 1 || along(k) >= m - 2;
        }
        if let (Some((hb, eps)), Some(reference)) = (hysteresis, x.as_ref()) {
            let h = if self.along_weft { [0.0, hb] } else { [hb, 0.0] };
            let warp = crate::energy::frame::Warp::default();
            if let Some(term) = NonlinearBending::hysteresis(&grid, &rest, h, eps, warp, reference) {
                model.extra_terms.push(Box::new(term));
            }
        }
        let model = model.build()?;
        // The discrete arc: chords of one grid spacing, the angle step 2 asin(hκ/2).
        let h = grid.spacing(d);
        let step = 2.0 * (0.5 * h * kappa).asin();
        let arc = |k: usize| {
            let (a, p) = (along(k) as f64 * step, rest[k]);
            let (u, z) =
                if kappa == 0.0 { (along(k) as f64 * h, 0.0) } else { (a.sin() / kappa, (1.0 - a.cos()) / kappa) };
            if d == 0 {
                Vec3::new(u, p.y, z)
            } else {
                Vec3::new(p.x, u, z)
            }
        };
        // Started on the arc (where a hysteresis slides, away from its stiff smoothing about the reference).
        let mut y: Vec<Vec3> = (0..grid.len()).map(arc).collect();
        solve(&model, &mut y, "bending")?;
        let mut g = vec![Vec3::ZERO; grid.len()];
        model.elastic(&y, Some(&mut g));
        let clamp: Vec<usize> = (0..grid.len()).filter(|&k| along(k) >= m - 2).collect();
        let centre = clamp.iter().fold(Vec3::ZERO, |a, &k| a + y[k]) / clamp.len() as f64;
        let couple = clamp.iter().fold(Vec3::ZERO, |a, &k| a + (y[k] - centre).cross(g[k]));
        *x = Some(y);
        // dW/dθ for the end turning up: about −y for a strip along x, about +x for one along y.
        Ok(if d == 0 { -couple.y } else { couple.x } / width)
    }
}

/// A KES bending cycle with the bending hysteresis `2HB` (`half_width` = HB, moment per width, N): the strip of
/// the curve test at curvatures `0 → κmax → −κmax → κmax` in `steps` increments per quarter (the first from the
/// flat strip, without hysteresis), each a static solve lagged at the previous one. Returns `(κ, M)` along the
/// cycle from `κmax/steps`; the closed loop starts at index `steps − 1`.
pub fn bending_loop(
    fabric: &Fabric,
    laws: &Laws,
    half_width: f64,
    along_weft: bool,
    kappa_max: f64,
    steps: usize,
) -> Result<Vec<(f64, f64)>, LabError> {
    let (applied, s, shared) = applied(fabric, laws)?;
    let arc = BendingTester { f: &applied, s: &s, laws: &shared, along_weft, len: (1.5 / kappa_max).min(0.2) };
    let q = steps.max(1) as f64;
    // From the first increment (a flat strip without load has no scale for the solver's residual).
    let path = (1..=steps)
        .map(|i| i as f64 / q)
        .chain((1..=2 * steps).map(|i| 1.0 - i as f64 / q))
        .chain((1..=2 * steps).map(|i| -1.0 + i as f64 / q))
        .map(|t| t * kappa_max);
    let mut x = None;
    let eps = 1e-3 * kappa_max;
    path.map(|k| Ok((k, arc.moment(k, Some((half_width, eps)), &mut x)?))).collect()
}

/// Straight-line laws of a linear fabric's constants over the KES instruments' ranges (tension to 5 % Green
/// strain, shear to 8°, bending to 2.5 cm⁻¹), for its curves: they are the linear material to round-off
/// (`tests/suite/nonlinear.rs`). `None` with Poisson coupling, which laws do not have.
pub fn linear_laws(f: &Fabric) -> Option<Laws> {
    if f.poisson != 0.0 || f.bending_poisson != 0.0 {
        return None;
    }
    let line = |k: f64, xs: &[f64]| {
        let pts: Vec<(f64, f64)> = xs.iter().map(|&x| (x, k * x)).collect();
        Curve::new(&pts, crate::material::law::Interpolation::Linear).ok()
    };
    let tension = [0.01, 0.02, 0.03, 0.04, 0.05];
    let shear: Vec<f64> = [0.5f64, 1.0, 2.0, 4.0, 8.0].iter().map(|d| d.to_radians().sin()).collect();
    let bending = [10.0, 50.0, 100.0, 150.0, 250.0];
    Some(Laws {
        tensile_warp: line(f.tensile_warp, &tension),
        tensile_weft: line(f.tensile_weft, &tension),
        shear: line(f.shear, &shear),
        bending_warp: line(f.bending_warp, &bending),
        bending_weft: line(f.bending_weft, &bending),
        hysteresis: [0.0; 3],
    })
}
