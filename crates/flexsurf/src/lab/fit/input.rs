//! The fit file (TOML): the material file to start from, the free constants with their bounds, and the targets
//! with their measured values and uncertainties. Errors name the file, the dotted key and what is wrong.
//!
//! ```toml
//! material = "../materials/woven-medium.toml"   # relative to this file
//! units = "kes"          # of bounds, starts and targets: "si" (default) or "kes" (see below)
//! max_iterations = 30    # Levenberg–Marquardt iterations (default 30)
//! columns = 66           # node columns of the virtual cantilever's coarse strip (the fine one has 2·66 − 2)
//! drape_specimen = 0.30  # the drape meter's specimen diameter (m; default 0.30)
//! drape_level = 1        # its grid level, as `flexsurf test cusick --level` (0, 1, 2; default 1)
//!
//! [free.bending_warp]    # density, tensile_warp, tensile_weft, shear, bending_warp, bending_weft, twist
//! lower = 0.01           # default: start / 100
//! upper = 1.0            # default: start · 100
//! start = 0.05           # default: the material's value
//!
//! [[target]]
//! quantity = "bending_length.warp"   # bending_length.{warp,weft,bias}, kes.{bending_warp, bending_weft,
//! value = 2.1                        #   shear, tensile_warp, tensile_weft, tensile_bias, weight}, cusick.dc (%);
//!                                    #   cusick.nodes: a whole count, no sigma, checked after the fit;
//!                                    #   kes_curve.{bending_warp, ...}: `file` of `measure, resultant`
//!                                    #   lines, `sigma` of the resultant, no value
//! sigma = 0.02                       # the value's standard uncertainty
//!
//! [[target]]
//! quantity = "shape"     # a scanned drape: `x y z` (m) per line; symmetric Chamfer distance to the drape
//! file = "scan.xyz"
//! sigma = 0.002          # the scan's uncertainty per coordinate (m); no value (the distance's is 0)
//! align = "rigid"        # "rigid" (default): the scan's placement in the meter's frame is fitted too (any
//!                        # frame: started from its principal axis); "none": the scan is in the meter's frame
//!                        # (disc centre at the origin, axis z, disc top at z = 0)
//! ```
//!
//! `units = "kes"`: constants and KES values in KES-F units (weight mg/cm², tensile gf/cm, shear gf/(cm·deg),
//! bending and twist gf·cm²/cm), bending lengths in cm; `"si"`: kg/m², N/m, N/m per rad, N·m and m.

use super::targets::{Instrument, KesValue, Quantity, Target};
use super::{Align, Constant, FitProblem, Free};
use crate::lab::cantilever::Direction;
use crate::material::{units, Calibration, Fabric};
use crate::math::Vec3;
use crate::scene::material::load_material_file;
use crate::scene::SceneError;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Units of a fit file's numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
enum FitUnits {
    #[default]
    Si,
    Kes,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FitSpec {
    material: PathBuf,
    #[serde(default)]
    calibration: Calibration,
    #[serde(default)]
    units: FitUnits,
    max_iterations: Option<usize>,
    columns: Option<usize>,
    drape_specimen: Option<f64>,
    drape_level: Option<usize>,
    free: BTreeMap<String, FreeSpec>,
    #[serde(default)]
    target: Vec<TargetSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FreeSpec {
    start: Option<f64>,
    lower: Option<f64>,
    upper: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TargetSpec {
    quantity: String,
    value: Option<f64>,
    sigma: Option<f64>,
    file: Option<PathBuf>,
    align: Option<String>,
}

/// SI value of constant `c` given in `u`.
fn constant_si(c: Constant, u: FitUnits, v: f64) -> f64 {
    match (u, c) {
        (FitUnits::Si, _) => v,
        (FitUnits::Kes, Constant::Density) => units::density_from_kes(v),
        (FitUnits::Kes, Constant::TensileWarp | Constant::TensileWeft) => units::tension_from_kes(v),
        (FitUnits::Kes, Constant::Shear) => units::shear_from_kes(v),
        (FitUnits::Kes, Constant::BendingWarp | Constant::BendingWeft | Constant::Twist) => units::bending_from_kes(v),
    }
}

/// A conversion to SI.
type Conversion = fn(f64) -> f64;

/// The quantity named `name`, and the SI value of a number of it given in `u`.
fn quantity(name: &str, u: FitUnits) -> Option<(Quantity, Conversion)> {
    let kes = u == FitUnits::Kes;
    let id = |v: f64| v;
    if name == "cusick.dc" {
        return Some((Quantity::DrapeCoefficient, id));
    }
    if name == "shape" {
        return Some((Quantity::Shape, id));
    }
    if let Some(d) = name.strip_prefix("bending_length.") {
        let d = match d {
            "warp" => Direction::Warp,
            "weft" => Direction::Weft,
            "bias" => Direction::Bias,
            _ => return None,
        };
        return Some((Quantity::BendingLength(d), if kes { |v| v * 1e-2 } else { id }));
    }
    let (k, conv): (KesValue, fn(f64) -> f64) = match name.strip_prefix("kes.")? {
        "bending_warp" => (KesValue::BendingWarp, units::bending_from_kes),
        "bending_weft" => (KesValue::BendingWeft, units::bending_from_kes),
        "shear" => (KesValue::Shear, units::shear_from_kes),
        "tensile_warp" => (KesValue::TensileWarp, units::tension_from_kes),
        "tensile_weft" => (KesValue::TensileWeft, units::tension_from_kes),
        "tensile_bias" => (KesValue::TensileBias, units::tension_from_kes),
        "weight" => (KesValue::Weight, units::density_from_kes),
        _ => return None,
    };
    Some((Quantity::Kes(k), if kes { conv } else { id }))
}

/// The instruments a fit file asks for (checked by [`problem_from_toml`]).
fn instrument(spec: &FitSpec) -> Instrument {
    let mut ins = Instrument::default();
    if let Some(c) = spec.columns {
        ins.columns = (c, (2 * c).saturating_sub(2));
    }
    ins.specimen = spec.drape_specimen.unwrap_or(ins.specimen);
    ins.drape_grid = crate::lab::cusick::default_polar(ins.specimen, spec.drape_level.unwrap_or(1));
    ins
}

/// The measured Cusick node count of a `cusick.nodes` target `t` (the `i`-th): a positive whole `value`, no
/// `sigma` or `file` (it is checked after the fit, not fitted).
fn node_count(t: &TargetSpec, i: usize, file: &Path) -> Result<usize, SceneError> {
    let bad = |key: &str, message: &str| SceneError::invalid(file, format!("target[{i}].{key}"), message.into());
    if t.sigma.is_some() || t.file.is_some() {
        let key = if t.sigma.is_some() { "sigma" } else { "file" };
        return Err(bad(key, "a node count is checked after the fit, not fitted: give its value alone"));
    }
    match t.value {
        Some(v) if v.fract() == 0.0 && (1.0..=1000.0).contains(&v) => Ok(v as usize),
        Some(_) => Err(bad("value", "must be a whole number of nodes, 1 to 1000")),
        None => Err(bad("value", "missing")),
    }
}

/// What a fit file's targets give: the targets, the scanned points of its shape target (if any) and their
/// placement, and its Cusick node count (if any).
type Targets = (Vec<Target>, (Vec<Vec3>, Align), Option<usize>);

/// The `align` of the `i`-th target `t`: only a shape target's, `"rigid"` (the default) or `"none"`.
fn align_of(t: &TargetSpec, i: usize, shape: bool, file: &Path) -> Result<Align, SceneError> {
    let bad = |m: &str| Err(SceneError::invalid(file, format!("target[{i}].align"), m.into()));
    match (t.align.as_deref(), shape) {
        (None, _) => Ok(Align::Rigid),
        (Some(_), false) => bad("only a shape target's scan is aligned"),
        (Some("rigid"), true) => Ok(Align::Rigid),
        (Some("none"), true) => Ok(Align::None),
        (Some(_), true) => {
            bad("must be \"rigid\" (the scan's placement fitted) or \"none\" (the scan in the meter's frame)")
        }
    }
}

/// The targets of a fit file.
fn targets_of(spec: &FitSpec, file: &Path) -> Result<Targets, SceneError> {
    let bad = |key: String, message: String| SceneError::invalid(file, key, message);
    let (mut targets, mut scan, mut nodes, mut align) = (Vec::new(), Vec::new(), None, Align::Rigid);
    for (i, t) in spec.target.iter().enumerate() {
        let shape = t.quantity == "shape";
        let a = align_of(t, i, shape, file)?;
        if shape {
            align = a;
        }
        if t.quantity == "cusick.nodes" {
            if nodes.is_some() {
                return Err(bad(format!("target[{i}].quantity"), "a fit takes one node count".into()));
            }
            nodes = Some(node_count(t, i, file)?);
            continue;
        }
        if let Some(kind) = t.quantity.strip_prefix("kes_curve.") {
            targets.extend(curve_targets(t, i, kind, spec.units, file)?);
            continue;
        }
        let Some((q, conv)) = quantity(&t.quantity, spec.units) else {
            return Err(bad(format!("target[{i}].quantity"), format!("unknown quantity `{}`", t.quantity)));
        };
        let sigma = t.sigma.ok_or_else(|| bad(format!("target[{i}].sigma"), "missing".into()))?;
        if let Some(problem) = super::sigma_problem(0.0, sigma) {
            return Err(bad(format!("target[{i}].sigma"), problem));
        }
        if q == Quantity::Shape {
            let Some(rel) = &t.file else {
                return Err(bad(
                    format!("target[{i}].file"),
                    "a shape target names its scan (x y z per line, m)".into(),
                ));
            };
            if t.value.is_some() {
                return Err(bad(
                    format!("target[{i}].value"),
                    "a shape target has no value (its distance is 0)".into(),
                ));
            }
            scan = read_points(&crate::scene::material::relative_to(file, rel))
                .map_err(|m| bad(format!("target[{i}].file"), m))?;
            targets.push(Target { quantity: q, value: 0.0, sigma });
            continue;
        }
        if t.file.is_some() {
            return Err(bad(format!("target[{i}].file"), "only a shape target names a file".into()));
        }
        let value = t.value.ok_or_else(|| bad(format!("target[{i}].value"), "missing".into()))?;
        if let Some(problem) = value_problem(q, value) {
            return Err(bad(format!("target[{i}].value"), problem));
        }
        if let Some(problem) = super::sigma_problem(value, sigma) {
            return Err(bad(format!("target[{i}].sigma"), problem));
        }
        targets.push(Target { quantity: q, value: conv(value), sigma: conv(sigma) });
    }
    Ok((targets, (scan, align), nodes))
}

/// The points of a measured KES curve target `t` (the `i`-th, `kes_curve.KIND`): one target of the KES value
/// `kes.KIND` per point `(x, y)` with `x ≠ 0`, valued `y/x` with uncertainty `sigma/|x|`, so that its residual
/// `(k x − y)/sigma` is the point's own for the linear resultant `y = k x` of the constant `k` (pointwise least
/// squares on the curve, not on its characteristic value); a point at `x = 0` says nothing of the slope.
fn curve_targets(t: &TargetSpec, i: usize, kind: &str, u: FitUnits, file: &Path) -> Result<Vec<Target>, SceneError> {
    let bad = |key: &str, m: String| SceneError::invalid(file, format!("target[{i}].{key}"), m);
    let weight = Quantity::Kes(KesValue::Weight);
    let Some((q, conv)) = quantity(&format!("kes.{kind}"), u).filter(|(q, _)| *q != weight) else {
        let known = "bending_warp, bending_weft, shear, tensile_warp, tensile_weft, tensile_bias";
        return Err(bad("quantity", format!("unknown curve `{}` (kes_curve.{{{known}}})", t.quantity)));
    };
    if t.value.is_some() {
        return Err(bad("value", "a curve target has no value: its points are in its file".into()));
    }
    let Some(rel) = &t.file else {
        return Err(bad("file", "a curve target names its file of `measure, resultant` per line".into()));
    };
    let sigma = t.sigma.ok_or_else(|| bad("sigma", "missing".into()))?;
    if let Some(problem) = super::sigma_problem(0.0, sigma) {
        return Err(bad("sigma", problem));
    }
    let points = read_curve(&crate::scene::material::relative_to(file, rel)).map_err(|m| bad("file", m))?;
    for &(x, y) in &points {
        if let Some(problem) = super::sigma_problem(y, sigma) {
            return Err(bad("sigma", format!("at the point ({x:?}, {y:?}) of {}: {problem}", rel.display())));
        }
    }
    let targets: Vec<Target> = points
        .iter()
        .filter(|(x, _)| *x != 0.0)
        .map(|&(x, y)| Target { quantity: q, value: conv(y / x), sigma: conv(sigma / x.abs()) })
        .collect();
    if targets.is_empty() {
        return Err(bad("file", format!("the curve {} has no point off zero", rel.display())));
    }
    Ok(targets)
}

/// The points of a curve: `measure, resultant` per line (comma or blanks between); blank lines and lines
/// starting with `#` are skipped.
fn read_curve(path: &Path) -> Result<Vec<(f64, f64)>, String> {
    let text =
        crate::io::input::read_text(path).map_err(|e| format!("cannot read the curve {}: {e}", path.display()))?;
    let mut points = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields = line.split(|c: char| c == ',' || c.is_whitespace()).filter(|f| !f.is_empty());
        let v: Vec<f64> = fields.map(str::parse).collect::<Result<_, _>>().unwrap_or_default();
        if v.len() != 2 || v.iter().any(|c| !c.is_finite()) {
            return Err(format!("{}:{}: need two finite numbers `measure, resultant`", path.display(), n + 1));
        }
        points.push((v[0], v[1]));
    }
    Ok(points)
}

/// The points of a scan: `x y z` (m) per line; blank lines and lines starting with `#` are skipped.
fn read_points(path: &Path) -> Result<Vec<Vec3>, String> {
    let text =
        crate::io::input::read_text(path).map_err(|e| format!("cannot read the scan {}: {e}", path.display()))?;
    let mut points = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let v: Vec<f64> = line.split_whitespace().map(str::parse).collect::<Result<_, _>>().unwrap_or_default();
        if v.len() != 3 || v.iter().any(|c| !c.is_finite()) {
            return Err(format!("{}:{}: need three finite numbers `x y z`", path.display(), n + 1));
        }
        points.push(Vec3::new(v[0], v[1], v[2]));
    }
    if points.is_empty() {
        return Err(format!("the scan {} has no points", path.display()));
    }
    Ok(points)
}

/// Reads a fit file.
pub fn load_fit_file(path: &Path) -> Result<FitProblem, SceneError> {
    let text = crate::io::input::read_text(path).map_err(|source| SceneError::io(path, source))?;
    problem_from_toml(&text, path)
}

/// The free constant `key` of a fit file (`f`: its start and bounds in `units`), its start set in `fabric`.
fn free_constant(
    key: &str,
    f: &FreeSpec,
    units: FitUnits,
    fabric: &mut Fabric,
    file: &Path,
) -> Result<Free, SceneError> {
    let bad = |key: String, message: String| SceneError::invalid(file, key, message);
    let c = Constant::from_key(key).ok_or_else(|| {
        bad(format!("free.{key}"), "not a constant a fit can free (density, tensile_warp, tensile_weft, shear, bending_warp, bending_weft, twist)".into())
    })?;
    let si = |v: f64| constant_si(c, units, v);
    let si_value = |v: f64| crate::ranges::with_unit(crate::ranges::short(v), c.range().unit);
    if let Some(s) = f.start {
        if !(s.is_finite() && s > 0.0) {
            return Err(bad(format!("free.{key}.start"), "must be a positive number".into()));
        }
        c.set(fabric, si(s));
    }
    let Some(start) = c.get(fabric) else {
        return Err(bad(format!("free.{key}"), "the material leaves twist to Huber's rule; give `start`".into()));
    };
    // Unless given, a factor 100 either side of the start, within the range a material file accepts.
    let (low, high) = c.range().bounds;
    let lower = f.lower.map_or((start / 100.0).max(low), si);
    let upper = f.upper.map_or((start * 100.0).min(high), si);
    if let Some(problem) = c.bounds_problem(lower, upper) {
        return Err(bad(format!("free.{key}"), problem));
    }
    if !(lower..=upper).contains(&start) {
        return Err(bad(
            format!("free.{key}.start"),
            format!("the start {} lies outside the bounds {} to {}", si_value(start), si_value(lower), si_value(upper)),
        ));
    }
    Ok(Free { constant: c, lower, upper })
}

/// The most node columns of a fit's coarse cantilever strip: the fit of `examples/fit/woven-medium.toml`'s
/// bending length takes 2.7 s at 300 and 9.5 s at 450, and at 500 its static solve fails at the start (the
/// fine strip's cells 0.2 mm long on a 2 cm strip); at 66, the test's own, the extrapolated chord angle agrees with
/// that of 500 columns to 5e-4° (the medium woven 5 cm out: 72.88599° and 72.88643°).
pub const MAX_COLUMNS: usize = 300;

/// Reads a fit file's text; `file` names it in errors and the material file is found relative to it.
pub fn problem_from_toml(text: &str, file: &Path) -> Result<FitProblem, SceneError> {
    let spec: FitSpec = crate::scene::parse_toml(text, file)?;
    let bad = |key: String, message: String| SceneError::invalid(file, key, message);
    if spec.columns.is_some_and(|c| !(4..=MAX_COLUMNS).contains(&c)) {
        return Err(bad(
            "columns".into(),
            format!(
                "must be 4 to {MAX_COLUMNS} node columns (the fine strip has twice as many; on finer grids the \
                 strip's static solves fail or fold at the clamp)"
            ),
        ));
    }
    if spec.drape_specimen.is_some_and(|d| !(d.is_finite() && d > crate::lab::cusick::DISC && d <= 2.0)) {
        return Err(bad("drape_specimen".into(), "must be a diameter (m) above the 0.18 m disc, at most 2 m".into()));
    }
    if spec.drape_level.is_some_and(|l| l > 2) {
        return Err(bad("drape_level".into(), "must be 0, 1 or 2".into()));
    }
    let material_path = crate::scene::material::relative_to(file, &spec.material);
    let m = load_material_file(&material_path).map_err(|e| match e {
        SceneError::Io { source, .. } => {
            bad("material".into(), format!("cannot read material file {}: {source}", material_path.display()))
        }
        other => SceneError::referenced(file, "material".into(), other),
    })?;
    if !m.laws.is_empty() {
        return Err(bad("material".into(), "the material has nonlinear laws; a fit takes a linear material".into()));
    }
    let (mut fabric, m_warnings) = (m.fabric, m.warnings);
    let free = spec
        .free
        .iter()
        .map(|(key, f)| free_constant(key, f, spec.units, &mut fabric, file))
        .collect::<Result<_, _>>()?;
    let (targets, (scan, align), cusick_nodes) = targets_of(&spec, file)?;
    let problem = FitProblem {
        fabric,
        calibration: spec.calibration,
        free,
        targets,
        instrument: instrument(&spec),
        max_iterations: spec.max_iterations.unwrap_or(30),
        scan,
        align,
        cusick_nodes,
        warnings: m_warnings,
    };
    super::check(&problem).map_err(|e| bad("(top level)".into(), e.to_string()))?;
    Ok(problem)
}

/// What is wrong with a measured `value` of `q` (`None`: nothing): every quantity is positive, and a drape
/// coefficient, the shadow's share of the overhang, is at most 100 % (a reading of 150 was fitted to a χ² of
/// thousands without a word).
fn value_problem(q: Quantity, value: f64) -> Option<String> {
    if !(value.is_finite() && value > 0.0) {
        Some("must be a positive number".into())
    } else if q == Quantity::DrapeCoefficient && value > 100.0 {
        Some(format!(
            "{value} %: a drape coefficient is the shadow's share of the specimen outside the disc, at most 100 %"
        ))
    } else {
        None
    }
}
