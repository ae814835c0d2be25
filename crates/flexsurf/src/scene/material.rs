//! Fabric constants in scenes and material files: a `[material]` table (or a whole material file) names a
//! preset, a file, or gives the constants inline, in SI or in native KES-F units. Inline constants override the
//! preset's or the file's. Everything is converted to an SI [`Fabric`] here; the model never sees units.

use super::error::{parse_toml, parse_toml_foreign, SceneError};
use super::validate::Validator;
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
}

/// A resolved fabric and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedMaterial {
    /// SI constants.
    pub fabric: Fabric,
    /// Display name (the spec's `name`, else the preset's or the file's name).
    pub name: String,
}

type Setter = fn(&mut Fabric, f64);
/// A key, its value as written, its conversion from KES units, and where it goes.
type Field = (&'static str, Option<f64>, fn(f64) -> f64, Setter);

impl MaterialSpec {
    /// The constants given in this table: (key, value converted to SI, setter).
    fn given(&self) -> Vec<(&'static str, f64, Setter)> {
        let kes = self.units == Units::Kes;
        let conv = |f: fn(f64) -> f64, v: f64| if kes { f(v) } else { v };
        let id = |v: f64| v;
        if self.units == Units::Fast {
            return self.given_fast();
        }
        let fields: [Field; 10] = [
            ("density", self.density, units::density_from_kes, |f, v| f.density = v),
            ("damping", self.damping, id, |f, v| f.damping = v),
            ("tensile_warp", self.tensile_warp, units::tension_from_kes, |f, v| f.tensile_warp = v),
            ("tensile_weft", self.tensile_weft, units::tension_from_kes, |f, v| f.tensile_weft = v),
            ("shear", self.shear, units::shear_from_kes, |f, v| f.shear = v),
            ("bending_warp", self.bending_warp, units::bending_from_kes, |f, v| f.bending_warp = v),
            ("bending_weft", self.bending_weft, units::bending_from_kes, |f, v| f.bending_weft = v),
            ("poisson", self.poisson, id, |f, v| f.poisson = v),
            ("bending_poisson", self.bending_poisson, id, |f, v| f.bending_poisson = v),
            ("twist", self.twist, units::bending_from_kes, |f, v| f.twist = Some(v)),
        ];
        fields.into_iter().filter_map(|(k, v, c, s)| v.map(|v| (k, conv(c, v), s))).collect()
    }

    /// The constants given in FAST units, converted (bending lengths need the weight given in the same table;
    /// without it they are left out and [`MaterialSpec::resolve`] reports the missing weight).
    fn given_fast(&self) -> Vec<(&'static str, f64, Setter)> {
        let mut out: Vec<(&'static str, f64, Setter)> = Vec::new();
        let w = self.density; // g/m²
        if let Some(v) = self.density {
            out.push(("density", units::density_from_fast(v), |f, v| f.density = v));
        }
        if let Some(v) = self.damping {
            out.push(("damping", v, |f, v| f.damping = v));
        }
        if let Some(v) = self.tensile_warp {
            out.push(("tensile_warp", units::tension_from_fast(v), |f, v| f.tensile_warp = v));
        }
        if let Some(v) = self.tensile_weft {
            out.push(("tensile_weft", units::tension_from_fast(v), |f, v| f.tensile_weft = v));
        }
        if let Some(v) = self.shear {
            out.push(("shear", units::shear_from_fast(v), |f, v| f.shear = v));
        }
        if let (Some(c), Some(w)) = (self.bending_warp, w) {
            out.push(("bending_warp", units::bending_from_fast(c, w), |f, v| f.bending_warp = v));
        }
        if let (Some(c), Some(w)) = (self.bending_weft, w) {
            out.push(("bending_weft", units::bending_from_fast(c, w), |f, v| f.bending_weft = v));
        }
        for (key, v, set) in [
            ("poisson", self.poisson, (|f: &mut Fabric, v| f.poisson = v) as Setter),
            ("bending_poisson", self.bending_poisson, |f, v| f.bending_poisson = v),
            ("twist", self.twist, |f, v| f.twist = Some(v)),
        ] {
            if let Some(v) = v {
                out.push((key, v, set));
            }
        }
        out
    }

    /// Resolves to SI constants. `file` is the file this table was read from (for relative paths and messages),
    /// `prefix` the dotted key of the table in it (`material` in a scene, empty in a material file).
    pub fn resolve(&self, file: &Path, prefix: &str) -> Result<ResolvedMaterial, SceneError> {
        let v = Validator::within(file, prefix);
        let (base, base_file, base_name) = match (&self.preset, &self.file) {
            (Some(_), Some(_)) => {
                return Err(v.bad("file", "give either `preset` or `file`, not both".into()));
            }
            (Some(p), None) => (Some(p.fabric()), None, Some(p.name().to_string())),
            (None, Some(rel)) => {
                let path = relative_to(file, rel);
                let m = load_material_file(&path).map_err(|e| match e {
                    SceneError::Io { source, .. } => {
                        v.bad("file", format!("cannot read material file {}: {source}", path.display()))
                    }
                    // An error inside the material file names it (and its key); this names the referencing
                    // file and key around it.
                    other => SceneError::referenced(file, v.key("file"), other),
                })?;
                (Some(m.fabric), Some(path), Some(m.name))
            }
            (None, None) => (None, None, None),
        };
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
        let fabric = match base {
            Some(mut f) => {
                for (_, v, set) in &given {
                    set(&mut f, *v);
                }
                f
            }
            None => {
                let required = ["density", "tensile_warp", "tensile_weft", "shear", "bending_warp", "bending_weft"];
                if let Some(missing) = required.iter().find(|r| !given.iter().any(|(k, _, _)| k == *r)) {
                    return Err(v.bad(
                        missing,
                        "missing value: give `preset`, `file`, or all of density, tensile_warp, tensile_weft, \
                         shear, bending_warp and bending_weft"
                            .into(),
                    ));
                }
                let mut f =
                    Fabric { damping: 0.0, poisson: 0.0, bending_poisson: 0.0, twist: None, ..Fabric::paper_cotton() };
                for (_, v, set) in &given {
                    set(&mut f, *v);
                }
                f
            }
        };
        if let Err(crate::material::MaterialError::Invalid { key: bad, value, what }) =
            fabric.validate().and_then(|()| fabric.check_ranges())
        {
            // Blame the table that set the value: this one if it gave the key, else the file it extends.
            let here = given.iter().any(|(k, _, _)| *k == bad);
            return Err(match (&base_file, here) {
                (Some(bf), false) => {
                    let inner = Validator::new(bf).bad(bad, format!("{value}: {what}"));
                    SceneError::referenced(file, v.key("file"), inner)
                }
                _ => v.bad(bad, format!("{value}: {what}")),
            });
        }
        let name = self.name.clone().or(base_name).unwrap_or_else(|| "inline".to_string());
        Ok(ResolvedMaterial { fabric, name })
    }
}

/// Reads and resolves a material file (`materials/*.toml`).
pub fn load_material_file(path: &Path) -> Result<ResolvedMaterial, SceneError> {
    let text = crate::io::input::read_text(path).map_err(|source| SceneError::io(path, source))?;
    let spec: MaterialSpec = parse_toml_foreign(&text, path)?;
    if spec.preset.is_some() || spec.file.is_some() {
        let k = if spec.preset.is_some() { "preset" } else { "file" };
        return Err(Validator::new(path).bad(k, "a material file gives constants; it cannot extend another".into()));
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
