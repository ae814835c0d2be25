//! Fabric constants in scenes and material files: a `[material]` table (or a whole material file) names a
//! preset, a file, or gives the constants inline, in SI or in native KES-F units. Inline constants override the
//! preset's or the file's. Everything is converted to an SI [`Fabric`] here; the model never sees units.

use super::error::{parse_toml, parse_toml_foreign, SceneError, SceneWarning};
use super::ranges::{self, Range};
use super::validate::{Validator, Warnings};
use crate::material::law::{Curve, Interpolation, Laws};
use crate::material::{units, Fabric};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Built-in fabrics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub enum Preset {
    /// The paper's non-woven cotton ([`Fabric::paper_cotton`]).
    #[serde(rename = "paper-cotton")]
    PaperCotton,
}

impl Preset {
    /// Name as written in scene files.
    pub fn name(&self) -> &'static str {
        match self {
            Preset::PaperCotton => "paper-cotton",
        }
    }

    /// The preset's constants.
    pub fn fabric(&self) -> Fabric {
        match self {
            Preset::PaperCotton => Fabric::paper_cotton(),
        }
    }
}

/// Units of the constants in one `[material]` table or material file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// SI: density kg/m², tensile N/m, shear N/m per radian, bending and twist N·m, damping kg/(m²·s).
    #[default]
    Si,
    /// KES-F: weight mg/cm², tensile gf/cm, shear gf/(cm·deg), bending and twist gf·cm²/cm; damping stays
    /// kg/(m²·s) (KES measures none).
    Kes,
    /// FAST (SiroFAST): `density` is the weight W in g/m²; `tensile_warp`/`tensile_weft` are the extensibility
    /// E100 in % (at 100 gf/cm: E·h = 98.0665 N/m / (E100/100)); `shear` is the bias extensibility EB5 in %
    /// (G = 123/EB5 N/m); `bending_warp`/`bending_weft` are bending lengths C in mm (B = 9.81e-6 W C³ µN·m, so
    /// `density` must be given in the same table); twist in N·m; damping kg/(m²·s).
    Fast,
}

/// A fabric as written in a scene's `[material]` table or in a material file (same keys; a material file may not
/// use `preset` or `file`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// A built-in fabric to start from.
    pub preset: Option<Preset>,
    /// A material file to start from, relative to the file that names it.
    pub file: Option<PathBuf>,
    /// An ARCSim measured material (JSON: `density`, `stretching`, `bending`) to start from, relative to the file
    /// that names it: its density and its five laws ([`super::arcsim`]).
    pub arcsim: Option<PathBuf>,
    /// A name for summaries.
    pub name: Option<String>,
    /// Where the numbers come from (free text).
    pub source: Option<String>,
    /// Units of the constants given here (default `si`).
    #[serde(default)]
    pub units: Units,
    /// Areal density ρ: kg/m² (`kes`: weight W, mg/cm²).
    pub density: Option<f64>,
    /// Damping γ, force per area per velocity: kg/(m²·s) in both unit systems.
    pub damping: Option<f64>,
    /// Tensile stiffness along warp (u1), E1·h: N/m (`kes`: gf/cm).
    pub tensile_warp: Option<f64>,
    /// Tensile stiffness along weft (u2), E2·h: N/m (`kes`: gf/cm).
    pub tensile_weft: Option<f64>,
    /// In-plane shear stiffness G: N/m per radian (`kes`: gf/(cm·deg)).
    pub shear: Option<f64>,
    /// Bending rigidity along warp K1: N·m (`kes`: B, gf·cm²/cm).
    pub bending_warp: Option<f64>,
    /// Bending rigidity along weft K2: N·m (`kes`: B, gf·cm²/cm).
    pub bending_weft: Option<f64>,
    /// Poisson's ratio ν12 (default 0).
    pub poisson: Option<f64>,
    /// Bending Poisson coupling νb (default 0).
    pub bending_poisson: Option<f64>,
    /// Twist rigidity D66: N·m (`kes`: gf·cm²/cm); default Huber's `2 D66 = √(D11 D22) − D12`.
    pub twist: Option<f64>,
    /// Measured nonlinear laws (`[curves.tensile_warp]` …), each replacing the constant of the same name.
    pub curves: Option<CurvesSpec>,
    /// KES hysteresis loop widths (`[hysteresis]`), for the virtual KES test's loops and dynamic runs.
    pub hysteresis: Option<HysteresisSpec>,
}

/// KES hysteresis loop widths: bending 2HB (N·m/m; `kes`: gf·cm/cm) per direction, shear 2HG (N/m; `kes`:
/// gf/cm).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HysteresisSpec {
    /// 2HB along warp.
    pub bending_warp: Option<f64>,
    /// 2HB along weft.
    pub bending_weft: Option<f64>,
    /// 2HG.
    pub shear: Option<f64>,
}

/// Measured curves, one per direction, each replacing the linear constant of its name (docs/materials.md,
/// "Nonlinear fabrics").
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CurvesSpec {
    /// Tension along warp: strain (–; `kes`: %) → force per width (N/m; `kes`: gf/cm).
    pub tensile_warp: Option<CurveSpec>,
    /// Tension along weft, as `tensile_warp`.
    pub tensile_weft: Option<CurveSpec>,
    /// Shear: shear angle (rad; `kes`: degrees) → shear force per length (N/m; `kes`: gf/cm).
    pub shear: Option<CurveSpec>,
    /// Bending along warp: curvature (1/m; `kes`: 1/cm) → moment per width (N·m/m; `kes`: gf·cm/cm).
    pub bending_warp: Option<CurveSpec>,
    /// Bending along weft, as `bending_warp`.
    pub bending_weft: Option<CurveSpec>,
}

/// One measured curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    /// `[strain, resultant]` pairs with the strain increasing, in the table's units; the origin may be left out;
    /// given for positive strains only, the law is the same with both signs reversed.
    pub points: Vec<[f64; 2]>,
    /// `linear` (default) or `monotone-cubic`.
    #[serde(default)]
    pub interpolation: Interpolation,
}

/// The five curve keys, the constant each replaces, and how a point in KES units and as measured becomes one
/// in the model's variables (SI): tension by strain and nominal force per width to Green strain and the
/// conjugate force per reference width, shear by angle to `γ = sin φ`.
type Conversion = fn(f64, f64, bool) -> (f64, f64);

fn tensile_point(strain: f64, force: f64, kes: bool) -> (f64, f64) {
    let (e, t) = if kes { (strain / 100.0, units::tension_from_kes(force)) } else { (strain, force) };
    (e + 0.5 * e * e, t / (1.0 + e))
}

fn shear_point(angle: f64, force: f64, kes: bool) -> (f64, f64) {
    let (phi, n) = if kes { (angle.to_radians(), units::tension_from_kes(force)) } else { (angle, force) };
    // The shear angle between unstretched warp and weft: `G12 = sin φ`.
    (phi.sin(), n)
}

fn bending_point(curvature: f64, moment: f64, kes: bool) -> (f64, f64) {
    // gf·cm/cm is gf: 9.80665e-3 N; 1/cm is 100/m.
    if kes {
        (curvature * 100.0, moment * units::GF)
    } else {
        (curvature, moment)
    }
}

impl CurvesSpec {
    /// `(key, curve)` of each curve given, with its conversion and the place of its law.
    fn entries(&self) -> [(&'static str, Option<&CurveSpec>, Conversion); 5] {
        [
            ("tensile_warp", self.tensile_warp.as_ref(), tensile_point),
            ("tensile_weft", self.tensile_weft.as_ref(), tensile_point),
            ("shear", self.shear.as_ref(), shear_point),
            ("bending_warp", self.bending_warp.as_ref(), bending_point),
            ("bending_weft", self.bending_weft.as_ref(), bending_point),
        ]
    }
}

/// The law slot of a curve key.
fn law_slot<'l>(laws: &'l mut Laws, key: &str) -> &'l mut Option<Curve> {
    match key {
        "tensile_warp" => &mut laws.tensile_warp,
        "tensile_weft" => &mut laws.tensile_weft,
        "shear" => &mut laws.shear,
        "bending_warp" => &mut laws.bending_warp,
        _ => &mut laws.bending_weft,
    }
}

/// A resolved fabric and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedMaterial {
    /// SI constants.
    pub fabric: Fabric,
    /// Display name (the spec's `name`, else the preset's or the file's name).
    pub name: String,
    /// The constants outside the usual range of fabrics (of this table and of the file it extends).
    pub warnings: Vec<SceneWarning>,
    /// Nonlinear laws (empty for a linear fabric); the fabric's constants of their directions are their
    /// quadratic parts ([`Laws::apply`]).
    pub laws: Laws,
}

type Setter = fn(&mut Fabric, f64);
/// A constant given in a table: its entry of the range table (which names its key), its value converted to SI,
/// and where it goes.
type Given = (&'static Range, f64, Setter);
/// A key's entry, its value as written, its conversion from KES units, and where it goes.
type Field = (&'static Range, Option<f64>, fn(f64) -> f64, Setter);

/// The fabric a table extends, the material file it comes from, its name (all `None` for neither) and its laws.
type Base = (Option<Fabric>, Option<PathBuf>, Option<String>, Laws);

/// The keys a table without `preset` or `file` must give.
const REQUIRED: [&str; 6] = ["density", "tensile_warp", "tensile_weft", "shear", "bending_warp", "bending_weft"];

impl MaterialSpec {
    /// The constants given in this table: (entry, value converted to SI, setter).
    fn given(&self) -> Vec<Given> {
        let kes = self.units == Units::Kes;
        let conv = |f: fn(f64) -> f64, v: f64| if kes { f(v) } else { v };
        let id = |v: f64| v;
        if self.units == Units::Fast {
            return self.given_fast();
        }
        let fields: [Field; 10] = [
            (&ranges::DENSITY, self.density, units::density_from_kes, |f, v| f.density = v),
            (&ranges::DAMPING, self.damping, id, |f, v| f.damping = v),
            (&ranges::TENSILE_WARP, self.tensile_warp, units::tension_from_kes, |f, v| f.tensile_warp = v),
            (&ranges::TENSILE_WEFT, self.tensile_weft, units::tension_from_kes, |f, v| f.tensile_weft = v),
            (&ranges::SHEAR, self.shear, units::shear_from_kes, |f, v| f.shear = v),
            (&ranges::BENDING_WARP, self.bending_warp, units::bending_from_kes, |f, v| f.bending_warp = v),
            (&ranges::BENDING_WEFT, self.bending_weft, units::bending_from_kes, |f, v| f.bending_weft = v),
            (&ranges::POISSON, self.poisson, id, |f, v| f.poisson = v),
            (&ranges::BENDING_POISSON, self.bending_poisson, id, |f, v| f.bending_poisson = v),
            (&ranges::TWIST, self.twist, units::bending_from_kes, |f, v| f.twist = Some(v)),
        ];
        fields.into_iter().filter_map(|(r, v, c, s)| v.map(|v| (r, conv(c, v), s))).collect()
    }

    /// The constants given in FAST units, converted (bending lengths need the weight given in the same table;
    /// without it they are left out and [`MaterialSpec::resolve`] reports the missing weight).
    fn given_fast(&self) -> Vec<Given> {
        let w = self.density; // g/m²
        let bending = |c: Option<f64>| c.zip(w).map(|(c, w)| units::bending_from_fast(c, w));
        let fields: [(&'static Range, Option<f64>, Setter); 10] = [
            (&ranges::DENSITY, self.density.map(units::density_from_fast), |f, v| f.density = v),
            (&ranges::DAMPING, self.damping, |f, v| f.damping = v),
            (&ranges::TENSILE_WARP, self.tensile_warp.map(units::tension_from_fast), |f, v| f.tensile_warp = v),
            (&ranges::TENSILE_WEFT, self.tensile_weft.map(units::tension_from_fast), |f, v| f.tensile_weft = v),
            (&ranges::SHEAR, self.shear.map(units::shear_from_fast), |f, v| f.shear = v),
            (&ranges::BENDING_WARP, bending(self.bending_warp), |f, v| f.bending_warp = v),
            (&ranges::BENDING_WEFT, bending(self.bending_weft), |f, v| f.bending_weft = v),
            (&ranges::POISSON, self.poisson, |f, v| f.poisson = v),
            (&ranges::BENDING_POISSON, self.bending_poisson, |f, v| f.bending_poisson = v),
            (&ranges::TWIST, self.twist, |f, v| f.twist = Some(v)),
        ];
        fields.into_iter().filter_map(|(r, v, s)| v.map(|v| (r, v, s))).collect()
    }

    /// Resolves to SI constants. `file` is the file this table was read from (for relative paths and messages),
    /// `prefix` the dotted key of the table in it (`material` in a scene, whose messages may quote its values;
    /// empty in a material file, whose messages never do).
    pub fn resolve(&self, file: &Path, prefix: &str) -> Result<ResolvedMaterial, SceneError> {
        let warnings = Warnings::default();
        let v = if prefix.is_empty() { Validator::foreign(file, &warnings) } else { Validator::new(file, &warnings) };
        let mut m = self.resolve_with(&v.within(prefix))?;
        m.warnings = warnings.into_inner();
        Ok(m)
    }

    /// As [`MaterialSpec::resolve`] with the checker `v` of the table, which collects the warnings.
    pub(crate) fn resolve_with(&self, v: &Validator<'_>) -> Result<ResolvedMaterial, SceneError> {
        let (base, base_file, base_name, base_laws) = self.base(v)?;
        if self.units == Units::Fast
            && self.density.is_none()
            && (self.bending_warp.is_some() || self.bending_weft.is_some())
        {
            return Err(v.bad(
                "density",
                "missing value: FAST bending lengths (mm) need the weight W (g/m²) as `density` in the same table"
                    .into(),
            ));
        }
        let given = self.given();
        for (range, value, _) in &given {
            v.number(range, range.key, *value)?;
        }
        let mut fabric = match base {
            Some(f) => f,
            None => {
                let curve = |key: &str| {
                    self.curves.as_ref().is_some_and(|c| c.entries().iter().any(|e| e.0 == key && e.1.is_some()))
                };
                if let Some(missing) =
                    REQUIRED.iter().find(|r| !given.iter().any(|(g, _, _)| g.key == **r) && !curve(r))
                {
                    return Err(v.bad(
                        missing,
                        "missing value: give `preset`, `file`, or all of density, tensile_warp, tensile_weft, \
                         shear, bending_warp and bending_weft"
                            .into(),
                    ));
                }
                Fabric { damping: 0.0, poisson: 0.0, bending_poisson: 0.0, twist: None, ..Fabric::paper_cotton() }
            }
        };
        for (_, value, set) in &given {
            set(&mut fabric, *value);
        }
        // The constants together (Poisson's ratios against the stiffnesses): blame the table that set the value,
        // this one if it gave the key, else the file it extends.
        if let Err(crate::material::MaterialError::Invalid { key: bad, value, what }) = fabric.validate() {
            let here = given.iter().any(|(g, _, _)| g.key == bad);
            return Err(match &base_file {
                Some(bf) if !here => {
                    let inner = Validator::foreign(bf, &Warnings::default()).bad_value(bad, value, what);
                    SceneError::referenced(v.file(), v.key("file"), inner)
                }
                _ => v.bad_value(bad, value, what),
            });
        }
        let laws = self.laws(v, base_laws, &given)?;
        laws.apply(&mut fabric)
            .map_err(|crate::material::MaterialError::Invalid { key, value, what }| v.bad_value(key, value, what))?;
        let name = self.name.clone().or(base_name).unwrap_or_else(|| "inline".to_string());
        Ok(ResolvedMaterial { fabric, name, warnings: Vec::new(), laws })
    }

    /// The laws of this table over those of the file it extends: a curve given here replaces the base's law or
    /// constant, a constant given here drops the base's curve of that direction. Giving both a direction's
    /// constant and its curve is an error naming the curve.
    fn laws(&self, v: &Validator<'_>, base: Laws, given: &[Given]) -> Result<Laws, SceneError> {
        let mut laws = base;
        for (range, _, _) in given {
            if let Some(slot) = ["tensile_warp", "tensile_weft", "shear", "bending_warp", "bending_weft"]
                .iter()
                .find(|k| **k == range.key)
            {
                *law_slot(&mut laws, slot) = None;
            }
        }
        if let Some(h) = &self.hysteresis {
            let kes = self.units == Units::Kes;
            let entries = [
                ("bending_warp", h.bending_warp, if kes { units::GF } else { 1.0 }),
                ("bending_weft", h.bending_weft, if kes { units::GF } else { 1.0 }),
                ("shear", h.shear, if kes { units::tension_from_kes(1.0) } else { 1.0 }),
            ];
            for (i, (key, value, scale)) in entries.into_iter().enumerate() {
                let Some(value) = value else { continue };
                if !(value.is_finite() && value >= 0.0) {
                    return Err(v.bad_value(&format!("hysteresis.{key}"), value, "must be finite and non-negative"));
                }
                laws.hysteresis[i] = value * scale;
            }
        }
        let Some(curves) = &self.curves else { return Ok(laws) };
        for (key, spec, convert) in curves.entries() {
            let Some(spec) = spec else { continue };
            let at = format!("curves.{key}.points");
            if given.iter().any(|(g, _, _)| g.key == key) {
                return Err(v.bad(&at, format!("give either `{key}` or its curve, not both")));
            }
            if self.units == Units::Fast {
                return Err(v.bad(&at, "curves are given in `si` or `kes` units, not `fast`".into()));
            }
            if key == "shear"
                && spec
                    .points
                    .iter()
                    .any(|p| p[0].abs() >= if self.units == Units::Kes { 90.0 } else { std::f64::consts::FRAC_PI_2 })
            {
                return Err(v.bad(&at, "a shear angle must be below 90°".into()));
            }
            let kes = self.units == Units::Kes;
            let points: Vec<(f64, f64)> = spec.points.iter().map(|p| convert(p[0], p[1], kes)).collect();
            let curve = Curve::new(&points, spec.interpolation).map_err(|e| v.bad(&at, format!("the curve {e}")))?;
            *law_slot(&mut laws, key) = Some(curve);
        }
        Ok(laws)
    }

    /// The fabric this table extends (a preset's or a material file's), the file, and its name.
    fn base(&self, v: &Validator<'_>) -> Result<Base, SceneError> {
        let given =
            [("preset", self.preset.is_some()), ("file", self.file.is_some()), ("arcsim", self.arcsim.is_some())];
        if given.iter().filter(|g| g.1).count() > 1 {
            let key = given.iter().rev().find(|g| g.1).map_or("file", |g| g.0);
            return Err(v.bad(key, "give only one of `preset`, `file` and `arcsim`".into()));
        }
        if let Some(rel) = &self.arcsim {
            return Self::arcsim_base(v, rel);
        }
        Ok(match (&self.preset, &self.file) {
            (Some(p), _) => (Some(p.fabric()), None, Some(p.name().to_string()), Laws::default()),
            (None, Some(rel)) => {
                let path = relative_to(v.file(), rel);
                let m = load_material_file(&path).map_err(|e| match e {
                    SceneError::Io { source, .. } => {
                        v.bad("file", format!("cannot read material file {}: {source}", path.display()))
                    }
                    // An error inside the material file names it (and its key); this names the referencing
                    // file and key around it.
                    other => SceneError::referenced(v.file(), v.key("file"), other),
                })?;
                v.extend(m.warnings);
                (Some(m.fabric), Some(path), Some(m.name), m.laws)
            }
            (None, None) => (None, None, None, Laws::default()),
        })
    }

    /// The base of `arcsim = "rel"`: the file's density and laws; the constants the laws replace are set by
    /// [`Laws::apply`], the others (damping, Poisson's ratios, twist) are the defaults of an inline table.
    fn arcsim_base(v: &Validator<'_>, rel: &Path) -> Result<Base, SceneError> {
        let path = relative_to(v.file(), rel);
        let m = super::arcsim::load_arcsim(&path).map_err(|e| match e {
            SceneError::Io { source, .. } => {
                v.bad("arcsim", format!("cannot read ARCSim material file {}: {source}", path.display()))
            }
            other => SceneError::referenced(v.file(), v.key("arcsim"), other),
        })?;
        let fabric = Fabric {
            density: m.density,
            damping: 0.0,
            poisson: 0.0,
            bending_poisson: 0.0,
            twist: None,
            ..Fabric::paper_cotton()
        };
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        Ok((Some(fabric), None, name, m.laws))
    }
}

/// Reads and resolves a material file (`materials/*.toml`). Its messages and warnings never quote its values.
pub fn load_material_file(path: &Path) -> Result<ResolvedMaterial, SceneError> {
    let text = crate::io::input::read_text(path).map_err(|source| SceneError::io(path, source))?;
    let spec: MaterialSpec = parse_toml_foreign(&text, path)?;
    if spec.preset.is_some() || spec.file.is_some() {
        let k = if spec.preset.is_some() { "preset" } else { "file" };
        let message = "a material file gives constants (or names an ARCSim file); it cannot extend another".into();
        return Err(Validator::foreign(path, &Warnings::default()).bad(k, message));
    }
    let mut m = spec.resolve(path, "")?;
    if spec.name.is_none() {
        m.name = path.file_stem().map_or_else(|| "material".into(), |s| s.to_string_lossy().into_owned());
    }
    Ok(m)
}

/// Reads a `[material]` table given as TOML text (the keys of a scene's `[material]`, `preset` and `file`
/// included) and resolves it; `file` names the text in errors, and a `file = …` inside is found relative to it.
/// The Python bindings build materials from keyword arguments this way.
pub fn material_from_toml(text: &str, file: &Path) -> Result<ResolvedMaterial, SceneError> {
    let spec: MaterialSpec = parse_toml(text, file)?;
    spec.resolve(file, "")
}

/// Where a material file path points when given relative to `file`.
pub fn relative_to(file: &Path, rel: &Path) -> PathBuf {
    file.parent().unwrap_or(Path::new("")).join(rel)
}
