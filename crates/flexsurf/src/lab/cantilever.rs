//! The cantilever bending test (ASTM D1388 / Peirce): a strip clamped level on a ledge, hanging under its own
//! weight. The chord from the ledge edge to the tip makes the angle θ below horizontal; the overhang at which
//! θ = 41.5° is twice the bending length `c`, and the rigidity it implies is `w c³`.
//!
//! The strip ([`Strip`]: 2 cm wide by default, 3 nodes across) is clamped by pinning its first two node columns
//! and solved to static equilibrium on two grids (64 and 128 cells over the overhang), Newton starting from the
//! elastica and the coarse solution starting the fine one; the clamp's discretisation error is first order in
//! `h`, so the reported angle is the Richardson extrapolation `2 θ₁₂₈ − θ₆₄`. The reference is the inextensible
//! heavy elastica `K θ'' = −w (L − s) cos θ`, `θ(0) = 0`, `θ'(L) = 0` ([`Elastica`]) with `K` = K1, K2, or on the
//! 45° bias the free narrow strip's rigidity ([`strip_rigidity`]; a clamped strip of finite width is stiffer,
//! up to [`plate_rigidity`]).

use super::LabError;
use crate::energy::frame::Frame;
use crate::grid::{Grid, Topology};
use crate::integrate::statics::{StaticOptions, StaticSolver};
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::Vec3;
use crate::model::{ElasticOptions, ModelBuilder, ModelKind};
use crate::surface::mesh::TriMesh;
use serde::Serialize;

/// Standard gravity of the test (m/s²).
pub const G: f64 = 9.80665;
/// The Peirce chord angle (degrees).
pub const PEIRCE_ANGLE: f64 = 41.5;

/// Which way the strip is cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Along the warp (rigidity K1).
    Warp,
    /// Along the weft (rigidity K2).
    Weft,
    /// At 45° to both (rigidity: the orthotropic narrow-strip prediction, [`strip_rigidity`]).
    Bias,
}

/// The bending rigidity a strip cut along `direction` should show: `K1`, `K2`, or on the 45° bias the
/// narrow-strip value `1/(D'⁻¹)₁₁` of the bending stiffness `D` (calibrated the consistent way, `D11 = K1`)
/// rotated into the strip's axes: the strip's free edges carry no moment across and no twisting moment, so it
/// bends and twists freely. For the default Huber twist rigidity this is `4/(1/√K1 + 1/√K2)²`. (A wide plate,
/// held from curving across and twisting, would show `D'₁₁`, larger.)
pub fn strip_rigidity(fabric: &Fabric, direction: Direction) -> Result<f64, LabError> {
    Ok(match direction {
        Direction::Warp => fabric.bending_warp,
        Direction::Weft => fabric.bending_weft,
        Direction::Bias => {
            let c = strip_stiffness(fabric, Direction::Bias)?;
            // (C⁻¹)₁₁ = det / cofactor₁₁.
            det3(&c) / (c[1][1] * c[2][2] - c[1][2] * c[2][1])
        }
    })
}

/// The rigidity of a wide plate bent along `direction` with its other curvature and twist held: `D'₁₁`
/// (`(K1 + K2 + 2 D12 + 4 D66)/4` on the bias).
pub fn plate_rigidity(fabric: &Fabric, direction: Direction) -> Result<f64, LabError> {
    Ok(match direction {
        Direction::Bias => strip_stiffness(fabric, Direction::Bias)?[0][0],
        d => strip_rigidity(fabric, d)?,
    })
}

/// Determinant of a 3×3 matrix (rows).
fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The bending stiffness (consistent calibration) on `(κ11, κ22, 2κ12)` in the axes of a strip cut along
/// `direction` (κ11 along the strip).
pub fn strip_stiffness(fabric: &Fabric, direction: Direction) -> Result<[[f64; 3]; 3], LabError> {
    let s = Stiffness::calibrate(fabric, Calibration::Kes)?;
    let dv = [[s.d11, s.d12, 0.0], [s.d12, s.d22, 0.0], [0.0, 0.0, s.d66]];
    let angle = match direction {
        Direction::Warp => 0.0,
        Direction::Weft => std::f64::consts::FRAC_PI_2,
        Direction::Bias => std::f64::consts::FRAC_PI_4,
    };
    Ok(Frame::new(Vec3::X, Vec3::Y, angle).pull_back(&dv))
}

/// Secant iteration on ln L for `f(L) = 0` (`f` = chord angle − 41.5°), from `(l0, f0)` and `1.05 l0`: at most
/// `iterations` updates, stopping when `|f| < tol` or two values differ by less than `flat` (degrees). Returns
/// the last L.
fn secant_on_log<E>(
    (mut l0, mut f0): (f64, f64),
    iterations: usize,
    (tol, flat): (f64, f64),
    mut f: impl FnMut(f64) -> Result<f64, E>,
) -> Result<f64, E> {
    let mut l1 = l0 * 1.05;
    let mut f1 = f(l1)?;
    for _ in 0..iterations {
        if (f1 - f0).abs() < flat || f1.abs() < tol {
            break;
        }
        let next = (l1.ln() - f1 * (l1.ln() - l0.ln()) / (f1 - f0)).exp();
        (l0, f0) = (l1, f1);
        l1 = next;
        f1 = f(l1)?;
    }
    Ok(l1)
}

/// The overhang (m) at which the Kirchhoff rod of stiffness `c` ([`rod_chord_deg`]) hangs at 41.5°, from `guess`.
fn rod_peirce_length(c: &[[f64; 3]; 3], w: f64, guess: f64) -> f64 {
    let f = |l: f64| rod_chord_deg(c, w, l) - PEIRCE_ANGLE;
    let Ok(l) = secant_on_log((guess, f(guess)), 30, (1e-9, 1e-14), |l| Ok::<f64, std::convert::Infallible>(f(l)));
    l
}

/// The specimen of one cantilever test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Strip {
    /// Which way it is cut.
    pub direction: Direction,
    /// Width (m); ASTM D1388 uses 25 mm.
    pub width: f64,
}

impl Strip {
    /// Default width (m).
    pub const WIDTH: f64 = 0.02;
    /// Nodes across the width.
    pub const ACROSS: usize = 3;

    /// A strip of the default width.
    pub fn new(direction: Direction) -> Self {
        Self { direction, width: Self::WIDTH }
    }
}

/// What the test reports.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CantileverReport {
    /// Direction of the strip.
    pub direction: Direction,
    /// Strip width (m).
    pub width: f64,
    /// Overhang L (m).
    pub overhang: f64,
    /// Chord angle below horizontal (degrees), grid-extrapolated.
    pub chord_angle_deg: f64,
    /// Chord angle on the finer grid alone (degrees).
    pub chord_angle_fine_deg: f64,
    /// Tip drop below the ledge (m), finer grid.
    pub tip_drop: f64,
    /// The exact heavy elastica's chord angle at this overhang for the input rigidity (degrees).
    pub elastica_deg: f64,
    /// Bending length c = L(41.5°)/2 (m).
    pub bending_length: f64,
    /// Rigidity implied by the bending length, `w c³` (N·m).
    pub implied_rigidity: f64,
    /// The rigidity the strip should show (N·m): the input K1 or K2, on the bias [`strip_rigidity`].
    pub input_rigidity: f64,
    /// On the bias, the wide-plate rigidity `D'₁₁` (N·m), the upper bound of what a clamped strip of finite
    /// width shows (see [`plate_rigidity`]); along warp or weft the same as `input_rigidity`.
    pub plate_rigidity: f64,
    /// The chord angle (degrees) at this overhang of the narrow-strip, large-deflection reference: the
    /// bend–twist coupled Kirchhoff rod ([`rod_chord_deg`]); along warp or weft it is the planar elastica's.
    pub rod_chord_deg: f64,
    /// The bending length (m) of that rod: half the overhang at which it hangs at 41.5°.
    pub rod_bending_length: f64,
}

/// Runs the cantilever test on `strip`, at `overhang` (default: the Peirce length of the input).
pub fn cantilever(
    fabric: &Fabric,
    calibration: Calibration,
    strip: Strip,
    overhang: Option<f64>,
) -> Result<CantileverReport, LabError> {
    cantilever_with_hang(fabric, calibration, strip, overhang).map(|(report, _)| report)
}

/// As [`cantilever`], with the strip as it hangs at the reported overhang (for pictures and meshes).
pub fn cantilever_with_hang(
    fabric: &Fabric,
    calibration: Calibration,
    strip: Strip,
    overhang: Option<f64>,
) -> Result<(CantileverReport, Hang), LabError> {
    if !(strip.width.is_finite() && strip.width > 0.0) {
        return Err(LabError::Input(format!("strip width {} m must be a positive length", strip.width)));
    }
    let s = Stiffness::calibrate(fabric, calibration)?;
    let w = fabric.density * G;
    let k = strip_rigidity(fabric, strip.direction)?;
    let peirce = 2.0 * (k / w).cbrt();
    // Bending length: secant iteration on ln L for θ(L) = 41.5°, from the Peirce estimate.
    let at_peirce = solve_pair(fabric, &s, strip, peirce)?;
    let l_peirce = secant_on_log((peirce, at_peirce.0 - PEIRCE_ANGLE), 8, (1e-6, 1e-12), |l| {
        extrapolated(fabric, &s, strip, l).map(|r| r.0 - PEIRCE_ANGLE)
    })?;
    let c = 0.5 * l_peirce;
    let l = overhang.unwrap_or(peirce);
    let (angle, fine, drop, columns) = if overhang.is_some() { solve_pair(fabric, &s, strip, l)? } else { at_peirce };
    let elastica = Elastica::new(w * l.powi(3) / k);
    let rod = strip_stiffness(fabric, strip.direction)?;
    let report = CantileverReport {
        direction: strip.direction,
        width: strip.width,
        overhang: l,
        chord_angle_deg: angle,
        chord_angle_fine_deg: fine,
        tip_drop: drop,
        elastica_deg: elastica.chord_deg(),
        bending_length: c,
        implied_rigidity: w * c.powi(3),
        input_rigidity: k,
        plate_rigidity: plate_rigidity(fabric, strip.direction)?,
        rod_chord_deg: rod_chord_deg(&rod, w, l),
        rod_bending_length: 0.5 * rod_peirce_length(&rod, w, peirce),
    };
    Ok((report, Hang { overhang: l, width: strip.width, columns, elastica }))
}

/// The grid-extrapolated chord angle (degrees) of `strip` with overhang `l`, without the search for the
/// bending length: (extrapolated, finest grid) angles.
pub fn chord_angle(fabric: &Fabric, calibration: Calibration, strip: Strip, l: f64) -> Result<(f64, f64), LabError> {
    let s = Stiffness::calibrate(fabric, calibration)?;
    extrapolated(fabric, &s, strip, l).map(|(a, f, _)| (a, f))
}

/// (extrapolated angle, fine angle, fine tip drop) at overhang `l`.
fn extrapolated(f: &Fabric, s: &Stiffness, strip: Strip, l: f64) -> Result<(f64, f64, f64), LabError> {
    solve_pair(f, s, strip, l).map(|(a, b, c, _)| (a, b, c))
}

/// The strip hanging at one overhang, for pictures and meshes: the finer grid's solution.
#[derive(Debug, Clone)]
pub struct Hang {
    /// Overhang (m).
    pub overhang: f64,
    /// Width (m).
    pub width: f64,
    /// Node columns from the ledge edge to the tip, each across the width.
    pub columns: Vec<[Vec3; Strip::ACROSS]>,
    /// The heavy elastica of the strip's nominal rigidity at this overhang, in units of the overhang.
    pub elastica: Elastica,
}

impl Hang {
    /// The strip as a triangle mesh (the ledge edge at x = 0).
    pub fn mesh(&self) -> TriMesh {
        ribbon(&self.columns.iter().map(|c| c.to_vec()).collect::<Vec<_>>())
    }

    /// The elastica as a band of thickness `thickness` in the vertical plane `y = offset` (a line drawn along
    /// the strip's edge in a side view).
    pub fn elastica_mesh(&self, offset: f64, thickness: f64) -> TriMesh {
        let n = 200;
        let point = |k: usize| {
            let (x, drop) = self.elastica.at(k as f64 / n as f64);
            Vec3::new(x * self.overhang, offset, -drop * self.overhang)
        };
        let cols: Vec<Vec<Vec3>> = (0..=n)
            .map(|k| {
                let p = point(k);
                let t = (point((k + 1).min(n)) - point(k.saturating_sub(1))).normalize_or_zero();
                let normal = Vec3::new(-t.z, 0.0, t.x) * (0.5 * thickness);
                vec![p - normal, p + normal]
            })
            .collect();
        ribbon(&cols)
    }
}

/// A quad strip through consecutive columns of points (same count in each), two triangles per quad.
fn ribbon(cols: &[Vec<Vec3>]) -> TriMesh {
    let across = cols.first().map_or(0, Vec::len);
    let positions: Vec<Vec3> = cols.iter().flatten().copied().collect();
    let mut triangles = Vec::new();
    for i in 0..cols.len().saturating_sub(1) {
        for a in 0..across.saturating_sub(1) {
            let k = |i: usize, a: usize| (i * across + a) as u32;
            triangles.push([k(i, a), k(i + 1, a), k(i + 1, a + 1)]);
            triangles.push([k(i, a), k(i + 1, a + 1), k(i, a + 1)]);
        }
    }
    TriMesh { positions, normals: Vec::new(), triangles }
}

/// Columns of the fine solution.
type Columns = Vec<[Vec3; Strip::ACROSS]>;

/// (extrapolated angle, fine angle, fine tip drop, fine columns) at overhang `l`. The coarse solution,
/// interpolated along the strip, starts the fine solve.
fn solve_pair(f: &Fabric, s: &Stiffness, strip: Strip, l: f64) -> Result<(f64, f64, f64, Columns), LabError> {
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
        ModelBuilder::with_options(grid, rest.clone(), *f, *s, ModelKind::Tfs, Vec3::new(0.0, 0.0, -G), &opts);
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

/// The inextensible heavy elastica with `q = w L³ / K`, in units of the overhang `L`: `θ'' = −q (1 − σ) cos θ`
/// on `σ ∈ [0, 1]`, `θ(0) = 0`, `θ'(1) = 0` (θ measured downwards), solved by shooting on `θ'(0)` (RK4,
/// [`Elastica::STEPS`] steps, bisection). Positions `(x, −z)` along the arc are kept at every step.
#[derive(Debug, Clone)]
pub struct Elastica {
    /// `(x, drop)` at `σ = i / STEPS`, `i = 0..=STEPS`.
    pub profile: Vec<(f64, f64)>,
}

impl Elastica {
    /// RK4 steps over the strip.
    pub const STEPS: usize = 2000;

    /// Solves the elastica for `q`.
    pub fn new(q: f64) -> Self {
        // Integrate with θ'(0) = a; returns θ'(1) and the profile.
        let shoot = |a: f64, keep: bool| -> (f64, Vec<(f64, f64)>) {
            let hs = 1.0 / Self::STEPS as f64;
            let rhs = |s: f64, th: f64, om: f64| -> [f64; 4] { [om, -q * (1.0 - s) * th.cos(), th.cos(), th.sin()] };
            let (mut th, mut om, mut x, mut z) = (0.0, a, 0.0, 0.0);
            let mut profile = Vec::with_capacity(if keep { Self::STEPS + 1 } else { 0 });
            if keep {
                profile.push((0.0, 0.0));
            }
            for i in 0..Self::STEPS {
                let s = i as f64 * hs;
                let k1 = rhs(s, th, om);
                let k2 = rhs(s + 0.5 * hs, th + 0.5 * hs * k1[0], om + 0.5 * hs * k1[1]);
                let k3 = rhs(s + 0.5 * hs, th + 0.5 * hs * k2[0], om + 0.5 * hs * k2[1]);
                let k4 = rhs(s + hs, th + hs * k3[0], om + hs * k3[1]);
                th += hs / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]);
                om += hs / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]);
                x += hs / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]);
                z += hs / 6.0 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]);
                if keep {
                    profile.push((x, z));
                }
            }
            (om, profile)
        };
        // θ'(0) ∈ [0, q] brackets θ'(1) = 0.
        let (mut lo, mut hi) = (0.0, q.max(1e-9));
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if shoot(mid, false).0 > 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Self { profile: shoot(0.5 * (lo + hi), true).1 }
    }

    /// Chord angle below horizontal (degrees).
    pub fn chord_deg(&self) -> f64 {
        let (x, drop) = self.profile[Self::STEPS];
        drop.atan2(x).to_degrees().abs()
    }

    /// `(x, drop)` at arc length `σ ∈ [0, 1]` (linear between steps).
    pub fn at(&self, sigma: f64) -> (f64, f64) {
        let t = sigma.clamp(0.0, 1.0) * Self::STEPS as f64;
        let i = (t.floor() as usize).min(Self::STEPS - 1);
        let f = t - i as f64;
        let (a, b) = (self.profile[i], self.profile[i + 1]);
        (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1))
    }
}

/// An inextensible anisotropic Kirchhoff rod with bend–twist coupling: the narrow-strip limit of the bias
/// cantilever at large deflection, independent of the plate code. Body frame (d1 tangent, d2 across, d3 normal),
/// curvatures `κ_b` about d2 and twist `τ` about d1 (in-plane bending held at zero); the strip's
/// `κ11 = −κ_b`, `κ12 = τ`; energy per length `½ b [κ11, 2κ12] K_r [κ11, 2κ12]ᵀ` with `K_r` the plate stiffness
/// condensed over the free cross curvature κ22. Clamped level at s = 0, free at L, weight `w b` per length.
/// `c` is the plate's bending stiffness on `(κ11, κ22, 2κ12)` in the strip's axes (N·m), `w` the weight per area
/// (N/m²), `l` the overhang (m). Returns the chord angle (degrees below horizontal, in the vertical plane of the
/// strip) by RK4 on frame, position and moment (1000 steps) and Newton shooting on the three components of the
/// clamp moment. Without coupling (`c` diagonal) it is the planar heavy elastica.
pub fn rod_chord_deg(c: &[[f64; 3]; 3], w: f64, l: f64) -> f64 {
    type V = [f64; 3];
    let idx = [0usize, 2];
    let mut kr = [[0.0; 2]; 2];
    for (r, &i) in idx.iter().enumerate() {
        for (q, &j) in idx.iter().enumerate() {
            kr[r][q] = c[i][j] - c[i][1] * c[1][j] / c[1][1];
        }
    }
    // Per unit width: A = P K_r P, P = diag(−1, 2), on q = (κ_b, τ); moments (about d2, about d1) = A q.
    let a = [[kr[0][0], -2.0 * kr[0][1]], [-2.0 * kr[1][0], 4.0 * kr[1][1]]];
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let cross = |x: V, y: V| -> V { [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]] };
    let dot = |x: V, y: V| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    // State: frame d1, d2, d3, position r, moment m (world), all per unit width (w per area).
    let shoot = |m0: V| -> (V, V) {
        let steps = 1000;
        let h = l / steps as f64;
        let mut st: [V; 5] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0; 3], m0];
        let rhs = |s: f64, st: &[V; 5]| -> [V; 5] {
            let (d1, d2, d3, m) = (st[0], st[1], st[2], st[4]);
            let (mb, mt) = (dot(m, d2), dot(m, d1));
            let kb = (a[1][1] * mb - a[0][1] * mt) / det;
            let tau = (-a[1][0] * mb + a[0][0] * mt) / det;
            let om: V = [tau * d1[0] + kb * d2[0], tau * d1[1] + kb * d2[1], tau * d1[2] + kb * d2[2]];
            // n(s) = −w (L − s) ẑ; m' = −d1 × n.
            let n: V = [0.0, 0.0, -w * (l - s)];
            let dm = cross(n, d1);
            [cross(om, d1), cross(om, d2), cross(om, d3), d1, dm]
        };
        let add = |x: &[V; 5], k: &[V; 5], f: f64| -> [V; 5] {
            std::array::from_fn(|i| std::array::from_fn(|j| x[i][j] + f * k[i][j]))
        };
        for i in 0..steps {
            let s = i as f64 * h;
            let k1 = rhs(s, &st);
            let k2 = rhs(s + 0.5 * h, &add(&st, &k1, 0.5 * h));
            let k3 = rhs(s + 0.5 * h, &add(&st, &k2, 0.5 * h));
            let k4 = rhs(s + h, &add(&st, &k3, h));
            for q in 0..5 {
                for j in 0..3 {
                    st[q][j] += h / 6.0 * (k1[q][j] + 2.0 * k2[q][j] + 2.0 * k3[q][j] + k4[q][j]);
                }
            }
        }
        (st[4], st[3])
    };
    // Start: the planar cantilever's clamp moment w L²/2 about +y (bending down), Newton on m(L) = 0.
    let mut m0: V = [0.0, 0.5 * w * l * l, 0.0];
    for _ in 0..30 {
        let (ml, _) = shoot(m0);
        if dot(ml, ml).sqrt() < 1e-12 * w * l * l {
            break;
        }
        let mut jac = [[0.0; 3]; 3];
        for j in 0..3 {
            let mut mp = m0;
            let eps = 1e-7 * w * l * l;
            mp[j] += eps;
            let (mlp, _) = shoot(mp);
            for i in 0..3 {
                jac[i][j] = (mlp[i] - ml[i]) / eps;
            }
        }
        // Solve jac · δ = −ml (Cramer).
        let dj = det3(&jac);
        for j in 0..3 {
            let mut mj = jac;
            for i in 0..3 {
                mj[i][j] = -ml[i];
            }
            m0[j] += det3(&mj) / dj;
        }
    }
    let (_, tip) = shoot(m0);
    (-tip[2]).atan2(tip[0]).to_degrees()
}

/// Chord angle (degrees) of the inextensible heavy elastica with `q = w L³ / K` ([`Elastica`]).
pub fn elastica_chord_deg(q: f64) -> f64 {
    Elastica::new(q).chord_deg()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// AUDIT.md §7 item 7: the exact heavy elastica's chord angles.
    #[test]
    fn elastica_matches_the_audit_table() {
        for (q, deg) in [(1.0, 7.10), (2.0, 13.86), (4.0, 25.53), (8.0, 41.49), (16.0, 57.39)] {
            let r = elastica_chord_deg(q);
            assert!((r - deg).abs() < 0.05, "q = {q}: {r}° vs {deg}°");
        }
    }
}
