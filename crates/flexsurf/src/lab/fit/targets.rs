//! What a fit can be asked to explain, and the model's value of each with its exact derivatives in the free
//! constants.
//!
//! - **Peirce bending length** (warp, weft, bias): the virtual cantilever of [`crate::lab::cantilever`], the
//!   overhang `L*` at which the grid-extrapolated chord angle `Θ = 2θ_fine − θ_coarse` is 41.5°, halved. By the
//!   implicit function theorem `dc/dp = −½ (∂Θ/∂p) / (∂Θ/∂L)`; `∂Θ/∂p` is the adjoint of both static solves
//!   ([`super::adjoint`]), `∂Θ/∂L` (the overhang is geometry, not a constant of the energy) a central difference
//!   of two solves at `L*(1 ± 1e-4)`, one factor common to every constant.
//! - **KES-F characteristic values** (B warp/weft, G, tensile warp/weft/bias, W): what the Kawabata instruments
//!   read, which the virtual KES round trip returns to 2e-4 (docs/materials.md): the constants themselves, and on
//!   the bias the orthotropic `4 / (1/E1 + 1/E2 + 1/G − 2ν12/E1)`; closed forms, differentiated exactly.
//! - **Cusick DC** from the drape's hem polygon ([`hem_drape_coefficient`]), by the adjoint of the drape's static
//!   solve, the drape relaxed from the flat specimen at every evaluation (so the DC is a function of the
//!   constants, not of the fit's path).
//! - **Shape**: the symmetric Chamfer distance of the drape to a scanned point cloud ([`shape_residuals`]), by
//!   the forward sensitivities of the drape (one solve per constant).

use super::adjoint::Equilibrium;
use super::calib::Constant;
use crate::lab::cantilever::{hang_pair_from, strip_rigidity, Columns, Direction, Hanging, Strip, G, PEIRCE_ANGLE};
use crate::lab::cusick::{cusick_settled, default_polar, specimen_builder, PolarGrid, Settle, DISC};
use crate::lab::LabError;
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::Vec3;
use crate::model::Model;
use serde::Serialize;
use std::f64::consts::PI;

/// A KES-F characteristic value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum KesValue {
    /// B along warp (N·m).
    BendingWarp,
    /// B along weft (N·m).
    BendingWeft,
    /// G (N/m per rad).
    Shear,
    /// Tensile stiffness along warp (N/m).
    TensileWarp,
    /// Tensile stiffness along weft (N/m).
    TensileWeft,
    /// Tensile stiffness on the 45° bias (N/m).
    TensileBias,
    /// W, the areal density (kg/m²).
    Weight,
}

/// What a target measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// The Peirce bending length `c` (m) of a strip cut this way.
    BendingLength(Direction),
    /// A KES-F value.
    Kes(KesValue),
    /// The Cusick drape coefficient (%) of the virtual drape meter, from its hem polygon ([`drape_coefficient`]).
    DrapeCoefficient,
    /// The drape's shape against a scanned point cloud ([`FitProblem::scan`](super::FitProblem::scan)), by the
    /// symmetric Chamfer distance ([`shape_residuals`]); the measured value is 0 and `sigma` the scan's
    /// uncertainty per coordinate (m).
    Shape,
}

impl Quantity {
    /// The name a fit file and a report use.
    pub fn name(self) -> String {
        match self {
            Quantity::BendingLength(d) => format!("bending_length.{}", direction_name(d)),
            Quantity::Kes(k) => format!("kes.{}", kes_name(k)),
            Quantity::DrapeCoefficient => "cusick.dc".into(),
            Quantity::Shape => "shape".into(),
        }
    }
}

/// `warp`, `weft` or `bias`.
pub fn direction_name(d: Direction) -> &'static str {
    match d {
        Direction::Warp => "warp",
        Direction::Weft => "weft",
        Direction::Bias => "bias",
    }
}

/// The fit file's name of a KES value.
pub fn kes_name(k: KesValue) -> &'static str {
    match k {
        KesValue::BendingWarp => "bending_warp",
        KesValue::BendingWeft => "bending_weft",
        KesValue::Shear => "shear",
        KesValue::TensileWarp => "tensile_warp",
        KesValue::TensileWeft => "tensile_weft",
        KesValue::TensileBias => "tensile_bias",
        KesValue::Weight => "weight",
    }
}

/// A measured value the fit explains.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Target {
    /// What was measured.
    pub quantity: Quantity,
    /// The measured value (SI).
    pub value: f64,
    /// Its standard uncertainty (SI, positive).
    pub sigma: f64,
}

/// The virtual instruments: the cantilever's grids (node columns of the coarse and the fine strip; the fine
/// strip's cells are half the coarse one's, `fine = 2·coarse − 2`, for the extrapolation `2θ_fine − θ_coarse`)
/// and the drape meter's specimen and grid.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Instrument {
    /// Node columns of the coarse and the fine strip ([`crate::lab::cantilever::COLUMNS`] as the test runs).
    pub columns: (usize, usize),
    /// The drape meter's specimen diameter (m).
    pub specimen: f64,
    /// The drape meter's polar grid.
    pub drape_grid: PolarGrid,
}

impl Default for Instrument {
    fn default() -> Self {
        let specimen = 0.30;
        Self { columns: crate::lab::cantilever::COLUMNS, specimen, drape_grid: default_polar(specimen, 1) }
    }
}

/// What carries over between evaluations of a fit: the last drape, which starts the next one's static solve
/// (the same fold pattern followed as the constants change, instead of a new relaxation that may pick another).
#[derive(Debug, Clone, Default)]
pub struct Warm {
    /// The last drape's positions.
    pub drape: Option<Vec<Vec3>>,
    /// What the last drape was relaxed for: the fabric, the calibration and the instrument. A drape is a
    /// function of these alone, so a second target of the same evaluation (a DC and a shape) takes it as it is.
    pub drape_of: Option<(Fabric, Calibration, Instrument)>,
    /// The last overhang `L*` (m), `∂Θ/∂L` and coarse strip of each cantilever direction.
    pub lengths: Vec<(Direction, f64, f64, Columns)>,
}

/// A bending length and its derivatives.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BendingLength {
    /// `c = L*/2` (m).
    pub value: f64,
    /// `dc/dp` for each free constant.
    pub gradient: Vec<f64>,
    /// `∂Θ/∂L` at `L*` (degrees per m).
    pub dtheta_dl: f64,
    /// The coarse strip's node columns at `L*` (to start the next search from).
    #[serde(skip)]
    pub columns: Columns,
}

/// The extrapolated chord angle `Θ(L)` (degrees), the strips started from `near` (a coarse strip at a nearby
/// overhang).
fn theta(f: &Fabric, s: &Stiffness, strip: Strip, l: f64, ins: &Instrument, near: &Hanging) -> Result<f64, LabError> {
    let start = (&near.columns(), near.specimen.overhang);
    let (c, fi) = hang_pair_from(f, s, strip, l, ins.columns, Some(start))?;
    Ok(2.0 * fi.angle - c.angle)
}

/// The overhang `L*` where `Θ(L) = 41.5°`, by secant steps from `l0` and `l0 − f(l0)/slope` (a slope from the
/// last evaluation of a fit) or `1.05 l0`, to `|Θ − 41.5°| < 1e-11°`; returns it with the strips solved there.
fn peirce_overhang(
    f: &Fabric,
    s: &Stiffness,
    strip: Strip,
    ins: &Instrument,
    (l0, slope, near): (f64, Option<f64>, Option<(&Columns, f64)>),
) -> Result<(f64, Hanging, Hanging), LabError> {
    let at = |l: f64, near: &Hanging| -> Result<(f64, Hanging, Hanging), LabError> {
        let (c, fi) = hang_pair_from(f, s, strip, l, ins.columns, Some((&near.columns(), near.specimen.overhang)))?;
        Ok((2.0 * fi.angle - c.angle - PEIRCE_ANGLE, c, fi))
    };
    let (mut la, mut a) = (l0, {
        let (c, fi) = hang_pair_from(f, s, strip, l0, ins.columns, near)?;
        (2.0 * fi.angle - c.angle - PEIRCE_ANGLE, c, fi)
    });
    let mut lb = match slope.filter(|s| s.is_finite() && *s > 0.0) {
        Some(slope) => (l0 - a.0 / slope).clamp(0.5 * l0, 2.0 * l0),
        None => 1.05 * l0,
    };
    if a.0.abs() < 1e-11 {
        return Ok((la, a.1, a.2));
    }
    let mut b = at(lb, &a.1)?;
    for _ in 0..30 {
        if b.0.abs() < 1e-11 || (b.0 - a.0).abs() < 1e-15 {
            break;
        }
        let next = (lb - b.0 * (lb - la) / (b.0 - a.0)).clamp(0.5 * lb, 2.0 * lb);
        (la, a) = (lb, b);
        lb = next;
        b = at(lb, &a.1)?;
    }
    Ok((lb, b.1, b.2))
}

/// The Peirce bending length of `f` on `strip` and (with `free` not empty) its derivatives in `free`; `warm`: the
/// overhang, `∂Θ/∂L` and coarse strip of a nearby fabric's (the last evaluation of a fit) to start from.
pub fn bending_length(
    f: &Fabric,
    calibration: Calibration,
    strip: Strip,
    free: &[Constant],
    ins: &Instrument,
    warm: Option<(f64, f64, &Columns)>,
) -> Result<BendingLength, LabError> {
    let s = Stiffness::calibrate(f, calibration)?;
    let peirce = 2.0 * (strip_rigidity(f, strip.direction)? / (f.density * G)).cbrt();
    let start = warm.map_or((peirce, None, None), |(l, slope, cols)| (l, Some(slope), Some((cols, l))));
    let (l, coarse, fine) = peirce_overhang(f, &s, strip, ins, start)?;
    if free.is_empty() {
        let columns = coarse.columns();
        return Ok(BendingLength { value: 0.5 * l, gradient: Vec::new(), dtheta_dl: f64::NAN, columns });
    }
    let mut dtheta = vec![0.0; free.len()];
    for (h, weight) in [(&coarse, -1.0), (&fine, 2.0)] {
        let mut eq = Equilibrium::new(&h.specimen.builder, &h.model, &h.x)?;
        for (d, v) in dtheta.iter_mut().zip(eq.sensitivities(&h.angle_gradient(), free, calibration)?) {
            *d += weight * v;
        }
    }
    let dl = 1e-4 * l;
    let dtheta_dl =
        (theta(f, &s, strip, l + dl, ins, &coarse)? - theta(f, &s, strip, l - dl, ins, &coarse)?) / (2.0 * dl);
    let gradient = dtheta.iter().map(|d| -0.5 * d / dtheta_dl).collect();
    Ok(BendingLength { value: 0.5 * l, gradient, dtheta_dl, columns: coarse.columns() })
}

/// A KES value of `f` and its derivatives in `free`.
pub fn kes_value(f: &Fabric, k: KesValue, free: &[Constant]) -> (f64, Vec<f64>) {
    let direct = |c: Constant| -> (f64, Vec<f64>) {
        let v = c.get(f).unwrap_or(f64::NAN);
        (v, free.iter().map(|&p| if p == c { 1.0 } else { 0.0 }).collect())
    };
    match k {
        KesValue::BendingWarp => direct(Constant::BendingWarp),
        KesValue::BendingWeft => direct(Constant::BendingWeft),
        KesValue::Shear => direct(Constant::Shear),
        KesValue::TensileWarp => direct(Constant::TensileWarp),
        KesValue::TensileWeft => direct(Constant::TensileWeft),
        KesValue::Weight => direct(Constant::Density),
        KesValue::TensileBias => {
            let (e1, e2, g, nu) = (f.tensile_warp, f.tensile_weft, f.shear, f.poisson);
            let sum = 1.0 / e1 + 1.0 / e2 + 1.0 / g - 2.0 * nu / e1;
            let d = |p: Constant| match p {
                Constant::TensileWarp => (2.0 * nu - 1.0) / (e1 * e1),
                Constant::TensileWeft => -1.0 / (e2 * e2),
                Constant::Shear => -1.0 / (g * g),
                _ => 0.0,
            };
            (4.0 / sum, free.iter().map(|&p| -4.0 / (sum * sum) * d(p)).collect())
        }
    }
}

/// The drape coefficient (%) of the drape `x` of `model` from its hem polygon, `100 (A_hem − A_disc) /
/// (A_flat − A_disc)` (`A_hem` the area the hem's xy projection encloses, `A_flat` the flat hem's), and its
/// gradient in the node positions. The drape meter's shadow is the area inside the hem where the hem is the
/// outermost part of the drape and its projection does not cross itself (as on a meter's drapes); this smooth
/// reading is what an adjoint can differentiate, where `flexsurf test cusick` rasterises the display surface.
pub fn hem_drape_coefficient(model: &Model, x: &[Vec3]) -> Result<(f64, Vec<Vec3>), LabError> {
    let grid = model.sheet_grid().copied().ok_or_else(|| LabError::Input("drape: not one polar sheet".into()))?;
    let (m, n) = (grid.m, grid.n);
    let hem: Vec<usize> = (0..n).map(|j| grid.index(m - 1, j)).collect();
    let area = |p: &dyn Fn(usize) -> Vec3| -> f64 {
        0.5 * (0..n).map(|j| p(hem[j]).x * p(hem[(j + 1) % n]).y - p(hem[(j + 1) % n]).x * p(hem[j]).y).sum::<f64>()
    };
    let a_disc = PI * 0.25 * DISC * DISC;
    let flat = area(&|k| model.rest[k]) - a_disc;
    let dc = 100.0 * (area(&|k| x[k]) - a_disc) / flat;
    let mut g = vec![Vec3::ZERO; x.len()];
    for j in 0..n {
        let (prev, next) = (x[hem[(j + n - 1) % n]], x[hem[(j + 1) % n]]);
        g[hem[j]] = Vec3::new(next.y - prev.y, prev.x - next.x, 0.0) * (50.0 / flat);
    }
    Ok((dc, g))
}

/// Static-solve tolerance of the drape (largest nodal force imbalance in largest nodal weights).
pub const DRAPE_TOLERANCE: f64 = 1e-9;

/// The hem drape coefficient (%) of `f` on the drape meter of `ins` and its derivatives in `free`: the drape is
/// relaxed from the flat specimen and solved statically, as `flexsurf test cusick` drapes specimen 0, and left
/// in `warm` (for the shape target).
pub fn drape_coefficient(
    f: &Fabric,
    calibration: Calibration,
    free: &[Constant],
    ins: &Instrument,
    warm: &mut Warm,
) -> Result<(f64, Vec<f64>), LabError> {
    let (builder, model, x) = drape(f, calibration, ins, warm)?;
    let (dc, dx) = hem_drape_coefficient(&model, &x)?;
    let gradient = if free.is_empty() {
        Vec::new()
    } else {
        Equilibrium::new(&builder, &model, &x)?.sensitivities(&dx, free, calibration)?
    };
    Ok((dc, gradient))
}

/// The model's values of `targets` for `f` and (row per target) their derivatives in `free`. Bending lengths of
/// one direction are computed once; the drape is computed once and left in `warm`.
pub fn evaluate(
    f: &Fabric,
    calibration: Calibration,
    free: &[Constant],
    targets: &[Target],
    ins: &Instrument,
    warm: &mut Warm,
) -> Result<(Vec<f64>, Vec<Vec<f64>>), LabError> {
    let mut drape: Option<(f64, Vec<f64>)> = None;
    let mut lengths: Vec<(Direction, BendingLength)> = Vec::new();
    let mut values = Vec::with_capacity(targets.len());
    let mut rows = Vec::with_capacity(targets.len());
    for t in targets {
        let (v, row) = match t.quantity {
            Quantity::BendingLength(d) => {
                let i = match lengths.iter().position(|(e, _)| *e == d) {
                    Some(i) => i,
                    None => {
                        let last = warm.lengths.iter().find(|w| w.0 == d).map(|w| (w.1, w.2, &w.3));
                        let b = bending_length(f, calibration, Strip::new(d), free, ins, last)?;
                        warm.lengths.retain(|w| w.0 != d);
                        if b.dtheta_dl.is_finite() {
                            warm.lengths.push((d, 2.0 * b.value, b.dtheta_dl, b.columns.clone()));
                        }
                        lengths.push((d, b));
                        lengths.len() - 1
                    }
                };
                (lengths[i].1.value, lengths[i].1.gradient.clone())
            }
            Quantity::Kes(k) => kes_value(f, k, free),
            // The shape's residuals are a vector (`shape_residuals`); its row here is its RMS distance alone.
            Quantity::Shape => (f64::NAN, vec![0.0; free.len()]),
            Quantity::DrapeCoefficient => {
                if drape.is_none() {
                    drape = Some(drape_coefficient(f, calibration, free, ins, warm)?);
                }
                drape.clone().unwrap_or_default()
            }
        };
        values.push(v);
        rows.push(row);
    }
    Ok((values, rows))
}

/// The drape of `f` on the drape meter of `ins`, relaxed from the flat specimen (see [`drape_coefficient`]) and
/// left in `warm`, or taken from `warm` when it was relaxed for the same fabric, calibration and instrument: the
/// builder, the model and the positions. Not continued from the last evaluation's drape by a
/// static solve: a drape has several equilibria at one set of constants, close to one another, and which one a
/// continuation reaches depends on the fit's path (the 24 cm test drape of the medium woven at the truth:
/// relaxed, DC 84.34 %; continued from 1.2 × its shear and bending, 83.46 %, 6.9 mm away), so a fit that
/// continued could not return to the constants that made its targets.
fn drape(
    f: &Fabric,
    calibration: Calibration,
    ins: &Instrument,
    warm: &mut Warm,
) -> Result<(crate::model::ModelBuilder, Model, Vec<Vec3>), LabError> {
    let s = Stiffness::calibrate(f, calibration)?;
    let builder = specimen_builder(f, s, ins.specimen, ins.drape_grid)?;
    let model = builder.clone().build()?;
    let key = Some((*f, calibration, *ins));
    let x = match &warm.drape {
        Some(x) if warm.drape_of == key => x.clone(),
        _ => {
            let settle = Settle { equilibrium: Some(DRAPE_TOLERANCE), ..Settle::default() };
            let x = cusick_settled(f, calibration, ins.specimen, ins.drape_grid, 0, &settle)?.x;
            (warm.drape, warm.drape_of) = (Some(x.clone()), key);
            x
        }
    };
    Ok((builder, model, x))
}

/// The node count of the drape of `f` ([`crate::lab::cusick::hem_nodes`]), relaxed from the flat specimen and
/// solved statically as for a DC: an integer, so a check after a fit rather than a least-squares target.
pub fn drape_nodes(f: &Fabric, calibration: Calibration, ins: &Instrument) -> Result<usize, LabError> {
    let (_, model, x) = drape(f, calibration, ins, &mut Warm::default())?;
    Ok(crate::lab::cusick::hem_nodes(&model, &x))
}

/// The index of the point of `cloud` nearest `p` (`cloud` not empty).
fn nearest(cloud: &[Vec3], p: Vec3) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, q) in cloud.iter().enumerate() {
        let d = (*q - p).length_squared();
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}

/// A drape's surface: the model's triangulated grid at the drape's positions, for the nearest points of a scan.
pub struct DrapeSurface {
    /// The model's triangles at the drape's positions, with a bounding-volume hierarchy for the nearest-point
    /// queries.
    mesh: parry3d_f64::shape::TriMesh,
    /// The drape's positions (every model node).
    pub x: Vec<Vec3>,
    /// The nodes that are not clamped.
    pub free: Vec<usize>,
}

impl DrapeSurface {
    /// The surface of `model` at `x`.
    pub fn new(model: &Model, x: Vec<Vec3>) -> Result<Self, LabError> {
        let vertices = x.iter().map(|p| parry3d_f64::math::Vector::new(p.x, p.y, p.z)).collect();
        let indices = model.faces().triangles.iter().map(|t| t.map(|k| k as u32)).collect();
        let mesh = parry3d_f64::shape::TriMesh::new(vertices, indices)
            .map_err(|e| LabError::Input(format!("shape: the drape's surface: {e}")))?;
        let free = (0..x.len()).filter(|&k| !model.pinned()[k]).collect();
        Ok(Self { mesh, x, free })
    }

    /// The point of the surface nearest `p`: its triangle's nodes and their weights (which sum to 1), and the
    /// point.
    pub fn closest(&self, p: Vec3) -> ([usize; 3], [f64; 3], Vec3) {
        use parry3d_f64::query::PointQueryWithLocation;
        let q = parry3d_f64::math::Vector::new(p.x, p.y, p.z);
        let (_, (face, location)) = self.mesh.project_local_point_and_get_location(q, false);
        let nodes = self.mesh.indices()[face as usize].map(|k| k as usize);
        let w = location.barycentric_coordinates().unwrap_or([1.0, 0.0, 0.0]);
        let at = (0..3).fold(Vec3::ZERO, |a, j| a + self.x[nodes[j]] * w[j]);
        (nodes, w, at)
    }
}

/// The surface of the drape of `f` on the drape meter of `ins` (meter frame), relaxed as for a DC (and left in
/// `warm`).
pub fn drape_surface(
    f: &Fabric,
    calibration: Calibration,
    ins: &Instrument,
    warm: &mut Warm,
) -> Result<DrapeSurface, LabError> {
    let (_, model, x) = drape(f, calibration, ins, warm)?;
    DrapeSurface::new(&model, x)
}

/// A shape target's residuals ([`shape_residuals`]).
#[derive(Debug, Clone, Default)]
pub struct ShapeResiduals {
    /// The residuals (m, weighted; not yet divided by the target's `sigma`).
    pub values: Vec<f64>,
    /// Their derivatives in the free constants (row per residual).
    pub rows: Vec<Vec<f64>>,
    /// For each residual, the scan point it involves and the residual's gradient in that point.
    pub scan_terms: Vec<(usize, Vec3)>,
}

/// The symmetric Chamfer residuals of the drape of `f` against the scanned points `scan` (in the drape meter's
/// frame: the disc's centre at the origin, its axis along z, its top at z = 0). For each scan point `s`, its
/// distance to the drape's surface (not to its nodes: a dense scan between two nodes is on the drape), signed
/// along the normal of the nearest triangle, `n · (y − s)` with `y` the nearest point, over `√N_scan`; for each
/// free node `x_k`, the coordinates of `x_k − s` (its nearest scan point) over `√N_nodes`. Their sum of squares is
/// the symmetric distance `mean_s min_y∈S |s − y|² + mean_k min_s |x_k − s|²` (exactly where the nearest point is
/// inside a triangle). The derivatives hold the nearest points, their weights and the normals (the first term
/// is then the point-to-plane distance, whose derivative along the surface is zero, as the distance's is): in
/// `free` by the equilibrium's displacements [`Equilibrium::displacements`], and in the scan's points.
pub fn shape_residuals(
    f: &Fabric,
    calibration: Calibration,
    free: &[Constant],
    ins: &Instrument,
    warm: &mut Warm,
    scan: &[Vec3],
) -> Result<ShapeResiduals, LabError> {
    if scan.is_empty() {
        return Err(LabError::Input("shape: the scan has no points".into()));
    }
    let (builder, model, x) = drape(f, calibration, ins, warm)?;
    let dx = if free.is_empty() {
        Vec::new()
    } else {
        Equilibrium::new(&builder, &model, &x)?.displacements(free, calibration)?
    };
    let surface = DrapeSurface::new(&model, x)?;
    let (ws, wn) = (1.0 / (scan.len() as f64).sqrt(), 1.0 / (surface.free.len() as f64).sqrt());
    let mut out = ShapeResiduals::default();
    for (i, s) in scan.iter().enumerate() {
        let (nodes, w, y) = surface.closest(*s);
        let [a, b, c] = nodes.map(|k| surface.x[k]);
        let n = (b - a).cross(c - a).try_normalize().or((y - *s).try_normalize()).unwrap_or(Vec3::Z);
        out.values.push(n.dot(y - *s) * ws);
        out.rows.push(dx.iter().map(|u| (0..3).map(|j| n.dot(u[nodes[j]]) * w[j]).sum::<f64>() * ws).collect());
        out.scan_terms.push((i, -n * ws));
    }
    for &k in &surface.free {
        let i = nearest(scan, surface.x[k]);
        let d = (surface.x[k] - scan[i]) * wn;
        for c in 0..3 {
            out.values.push(d[c]);
            out.rows.push(dx.iter().map(|u| u[k][c] * wn).collect());
            let mut e = Vec3::ZERO;
            e[c] = -wn;
            out.scan_terms.push((i, e));
        }
    }
    Ok(out)
}
